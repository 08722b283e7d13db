"""Message envelope of the shipradar stream: topics, encoding and decoding (no sockets).

Every message is a ZeroMQ multipart message of two frames, ``[topic, body]``. The body is one
msgpack map holding the schema version ``"v"``, the simulated time ``"t"`` [s since scenario
start] and the payload's own keys, in insertion order. Numpy arrays anywhere in the payload
travel as typed little-endian columns in a msgpack extension (type :data:`EXT_NDARRAY`), so
that one frame per dwell or sector carries whole columns of plots.

The transport (:mod:`shipradar.sim.stream.bus`) and the recorder
(:mod:`shipradar.sim.stream.recording`) only move the bytes that :func:`encode` returns;
:func:`decode` is the single inverse. ``docs/protocol.md`` is the reference for users writing a
subscriber in another language.
"""

from __future__ import annotations

import math
import struct
import threading
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import msgpack
import numpy as np

from shipradar._framing import frames as _frames
from shipradar.sim.stream import schema as _schema

__all__ = [
    "EXT_NDARRAY",
    "MAX_BODY_BYTES",
    "MAX_NDIM",
    "SCHEMA_VERSION",
    "SUPPORTED_SCHEMA_VERSIONS",
    "TOPICS",
    "TOPIC_ENTITIES",
    "TOPIC_END",
    "TOPIC_EOS",
    "TOPIC_META",
    "TOPIC_PLOTS",
    "TOPIC_TRUTH",
    "ProtocolError",
    "decode",
    "decode_array",
    "encode",
    "encode_array",
    "encode_reference",
    "encode_slices",
    "float_rows",
    "to_jsonable",
]

#: Version of the payload schema (topics, keys, units) described in docs/protocol.md.
#: Bumped when a key changes meaning (new keys and topics alone do not bump it). 2: the
#: states of an inactive target in ``truth[targets]`` are NaN (1: frozen values).
SCHEMA_VERSION: int = 2
#: Schema versions :func:`decode` accepts: a version 1 stream or recording (no key of
#: version 2 is required of it, :mod:`shipradar.sim.stream.schema`) still reads.
SUPPORTED_SCHEMA_VERSIONS: tuple[int, ...] = (1, 2)

#: Sensor metadata, sent at start and repeated every scan for late joiners.
TOPIC_META: bytes = b"meta"
#: Plots (detections), one columnar message per dwell or sector.
TOPIC_PLOTS: bytes = b"plots"
#: End of scan marker with the sensor's own position and heading.
TOPIC_EOS: bytes = b"eos"
#: Ground truth (target states, origin of each plot); a tracker under test ignores it.
TOPIC_TRUTH: bytes = b"truth"
#: The end of the run: one message after every radar's last, for a client to wait for.
TOPIC_END: bytes = b"end"
#: The topics the engine publishes. ZeroMQ subscriptions match by prefix, so no topic may be
#: a prefix of another (a new topic must not start with ``meta``, ``plots``, ``eos``,
#: ``truth``, ``end``).
TOPICS: tuple[bytes, ...] = (TOPIC_META, TOPIC_PLOTS, TOPIC_EOS, TOPIC_TRUTH, TOPIC_END)
#: Entity states a program feeds in (``shipradar run --entities ENDPOINT``), and the updates a
#: run used, in its recording (docs/protocol.md section 4.7; declared in the schema).
TOPIC_ENTITIES: bytes = _schema.TOPIC_ENTITIES

#: Largest body :func:`encode` produces and :func:`decode` accepts [bytes] (64 MiB).
MAX_BODY_BYTES: int = 64 * 1024 * 1024
#: Largest topic frame [bytes].
MAX_TOPIC_BYTES: int = 255
#: msgpack extension type code of a numpy array column.
EXT_NDARRAY: int = 1
#: Largest number of array dimensions (numpy's own limit).
MAX_NDIM: int = 32

# Array element types allowed on the wire, as numpy array-interface type strings
# (byte order '<' little-endian, '|' not applicable). Object, string and datetime arrays are
# refused: they have no portable fixed-width representation.
_WIRE_TYPESTRS: frozenset[str] = frozenset(
    "|b1 |i1 <i2 <i4 <i8 |u1 <u2 <u4 <u8 <f2 <f4 <f8 <c8 <c16".split()
)
_RESERVED_KEYS = ("v", "t")
_EXT_HEAD = struct.Struct("<BB")  # ndim, len(typestr)
_MAX_DEPTH = 32  # nesting depth of maps/arrays in a payload


class ProtocolError(ValueError):
    """A message that cannot be encoded or decoded under this schema."""


def _pad8(n: int) -> int:
    return (-n) % 8


# Per (dtype, ndim): the constant start of the extension header and the wire dtype.
_HEAD_CACHE: dict[tuple[np.dtype, int], tuple[bytes, np.dtype]] = {}
_SHAPES = [struct.Struct(f"<{n}Q") for n in range(MAX_NDIM + 1)]
_WIRE_DTYPES: dict[bytes, np.dtype] = {ts.encode("ascii"): np.dtype(ts) for ts in _WIRE_TYPESTRS}


def _array_head(dtype: np.dtype, ndim: int) -> tuple[bytes, np.dtype]:
    cached = _HEAD_CACHE.get((dtype, ndim))
    if cached is not None:
        return cached
    if dtype.kind not in "biufc" or dtype.fields is not None:
        raise ProtocolError(
            f"numpy arrays of dtype {dtype} cannot be encoded: use bool, int, uint, float or "
            "complex columns"
        )
    little = dtype.newbyteorder("<") if dtype.byteorder == ">" else dtype
    typestr = little.str
    if typestr not in _WIRE_TYPESTRS:  # e.g. float128 on some platforms
        raise ProtocolError(f"numpy arrays of dtype {dtype} cannot be encoded")
    if ndim > MAX_NDIM:
        raise ProtocolError(f"array has {ndim} dimensions, more than {MAX_NDIM}")
    ts = typestr.encode("ascii")
    head = _EXT_HEAD.pack(ndim, len(ts)) + ts
    head += b"\0" * _pad8(len(head))
    _HEAD_CACHE[(dtype, ndim)] = (head, little)
    return head, little


# Header start (ndim, type string, padding) -> (ndim, dtype), for the decoder's fast path.
_PREFIXES: dict[bytes, tuple[int, np.dtype]] = {
    _array_head(dt, nd)[0]: (nd, dt) for dt in _WIRE_DTYPES.values() for nd in range(MAX_NDIM + 1)
}
assert all(len(prefix) == 8 for prefix in _PREFIXES)


def encode_array(array: np.ndarray) -> bytes:
    """Encode one numpy array as the data of a :data:`EXT_NDARRAY` extension.

    Layout (all integers little-endian): ``uint8 ndim``, ``uint8 L``, ``L`` ASCII bytes of the
    numpy type string (``"<f8"``, ``"|u1"``, ...), zero padding up to a multiple of 8 bytes,
    ``ndim`` x ``uint64`` shape, then the elements in C order, little-endian. The element
    data thus starts at an 8-byte aligned offset.

    Parameters
    ----------
    array : numpy.ndarray
        Array of bool, signed or unsigned integers, floats or complex numbers, any shape
        (zero-size and 0-d included). Big-endian or non-contiguous arrays are converted.

    Returns
    -------
    bytes
        The extension data.

    Raises
    ------
    ProtocolError
        If the dtype has no wire representation (object, str, datetime, structured...).
    """
    head, little = _array_head(array.dtype, array.ndim)
    data = array.astype(little, copy=False).tobytes()
    return b"".join((head, _SHAPES[array.ndim].pack(*array.shape), data))


def decode_array(data: bytes) -> np.ndarray:
    """Decode the data of a :data:`EXT_NDARRAY` extension (inverse of :func:`encode_array`).

    Parameters
    ----------
    data : bytes
        The extension data.

    Returns
    -------
    numpy.ndarray
        A read-only array viewing ``data`` (no copy), little-endian.

    Raises
    ------
    ProtocolError
        If the layout is inconsistent (unknown type, length not matching the shape).
    """
    size = len(data)
    fast = _PREFIXES.get(data[:8])
    if fast is not None:  # every wire type string fits the first 8 bytes
        ndim, dtype = fast
        end_shape = 8 + 8 * ndim
        if size >= end_shape:
            shape = _SHAPES[ndim].unpack_from(data, 8)
            count = shape[0] if ndim == 1 else math.prod(shape)
            if count * dtype.itemsize == size - end_shape:
                array = np.frombuffer(data, dtype=dtype, count=count, offset=end_shape)
                return array if ndim == 1 else array.reshape(shape)
    # Slow path: unusual or malformed header; find what is wrong and say so.
    if size < _EXT_HEAD.size:
        raise ProtocolError("array column too short for its header")
    ndim, lts = data[0], data[1]
    pos = _EXT_HEAD.size + lts
    if ndim > MAX_NDIM or size < pos:
        raise ProtocolError("array column header is malformed")
    wire = _WIRE_DTYPES.get(bytes(data[_EXT_HEAD.size : pos]))
    if wire is None:
        raise ProtocolError(
            f"array column has unsupported element type {bytes(data[_EXT_HEAD.size : pos])!r}"
        )
    dtype = wire
    pos += _pad8(pos)
    end_shape = pos + 8 * ndim
    if size < end_shape:
        raise ProtocolError("array column header is malformed")
    shape = _SHAPES[ndim].unpack_from(data, pos)
    count = shape[0] if ndim == 1 else math.prod(shape)
    if count * dtype.itemsize != size - end_shape:
        raise ProtocolError(
            f"array column of shape {shape} and type {dtype.str} holds "
            f"{size - end_shape} bytes, expected {count * dtype.itemsize}"
        )
    array = np.frombuffer(data, dtype=dtype, count=count, offset=end_shape)
    return array if ndim == 1 else array.reshape(shape)


def _default(obj: Any) -> Any:
    """msgpack hook for what it does not pack natively."""
    if isinstance(obj, np.ndarray):
        return msgpack.ExtType(EXT_NDARRAY, encode_array(obj))
    if isinstance(obj, np.generic):
        if isinstance(obj, (np.bool_, np.integer, np.floating)):
            return obj.item()  # numpy scalar -> the Python scalar of the same value
        raise ProtocolError(f"numpy scalar of type {obj.dtype} cannot be encoded")
    raise ProtocolError(
        f"value of type {type(obj).__name__} cannot be encoded: payloads hold dict (str keys), "
        "list, tuple, str, bytes, int, float, bool, None and numpy arrays"
    )


# Value types that hold no map (nothing to check inside them): most values of a payload.
_LEAVES: frozenset[type] = frozenset((float, int, str, bool, type(None), bytes, np.ndarray))


def _check_keys(mapping: Mapping[Any, Any], depth: int = 0) -> None:
    """Require str keys in every map (portable to JSON and every msgpack library)."""
    if depth > _MAX_DEPTH:
        raise ProtocolError(f"payload nested deeper than {_MAX_DEPTH} levels")
    # msgpack itself packs only dict and list/tuple (and their subclasses) as containers;
    # a value of a leaf type is passed over at the cost of one set lookup
    for key, value in mapping.items():
        if type(key) is not str and not isinstance(key, str):
            raise ProtocolError(f"payload map keys must be str, got {key!r}")
        if type(value) in _LEAVES:
            continue
        if isinstance(value, dict):
            _check_keys(value, depth + 1)
        elif isinstance(value, (list, tuple)):
            _check_items(value, depth + 1)


def _check_items(items: Sequence[Any], depth: int) -> None:
    if depth > _MAX_DEPTH:
        raise ProtocolError(f"payload nested deeper than {_MAX_DEPTH} levels")
    for value in items:
        if type(value) in _LEAVES:
            continue
        if isinstance(value, dict):
            _check_keys(value, depth + 1)
        elif isinstance(value, (list, tuple)):
            _check_items(value, depth + 1)


# One packer per thread, reused for speed (a Packer allocates its buffer when created);
# autoreset empties it between messages, so the bytes depend on the message alone.
_LOCAL = threading.local()


def _packer() -> msgpack.Packer:
    packer = getattr(_LOCAL, "packer", None)
    if packer is None:
        packer = _LOCAL.packer = msgpack.Packer(default=_default, use_bin_type=True)
    return packer


_FLOAT64 = struct.Struct(">Bd")  # msgpack float 64: 0xcb, big-endian IEEE double
_EXT8 = struct.Struct(">BBb")  # 0xc7, length, type
_EXT16 = struct.Struct(">BHb")  # 0xc8, length, type
_EXT32 = struct.Struct(">BIb")  # 0xc9, length, type
# msgpack's fixext formats, used by every msgpack packer when the data length is exactly one
# of these sizes (an empty 1-d column is 16 bytes: fixext 16).
_FIXEXT = {n: bytes((code, EXT_NDARRAY)) for n, code in
           ((1, 0xD4), (2, 0xD5), (4, 0xD6), (8, 0xD7), (16, 0xD8))}
# Envelope: the packed "v" key and schema version, and the "t" key (its value follows).
_ENVELOPE_V = msgpack.packb("v") + msgpack.packb(SCHEMA_VERSION)
_ENVELOPE_T_KEY = msgpack.packb("t")
# Packed payload keys (str -> bytes); payloads reuse a small set of keys.
_KEY_CACHE: dict[str, bytes] = {}
_KEY_CACHE_MAX = 4096


_U64 = struct.Struct("<Q")
# Array header start (ndim 1) of the wire dtypes that need no conversion: native-order dtypes
# that are already little-endian (or byte-sized).
_COLUMN_HEADS: dict[np.dtype, bytes] = {
    dt: _array_head(dt, 1)[0] for dt in _WIRE_DTYPES.values() if _array_head(dt, 1)[1] == dt
}


# A column's extension header, array head and element count, by (array head, elements):
# columns of a given dtype and length recur message after message.
_COLUMN_PREFIXES: dict[tuple[bytes, int], bytes] = {}
_COLUMN_PREFIXES_MAX = 1 << 14


def _map_header(n: int) -> bytes:
    """msgpack header of a map of ``n`` entries (fixmap, map 16 or map 32)."""
    if n < 16:
        return bytes((0x80 | n,))
    if n < 0x10000:
        return struct.pack(">BH", 0xDE, n)
    return struct.pack(">BI", 0xDF, n)


def _ext_header(size: int) -> bytes:
    """msgpack header of an :data:`EXT_NDARRAY` extension holding ``size`` bytes, in the
    smallest format (the choice every msgpack packer makes)."""
    head = _EXT_HEADERS.get(size)
    if head is not None:
        return head
    fixed = _FIXEXT.get(size)
    if fixed is not None:
        head = fixed
    elif size < 0x100:
        head = _EXT8.pack(0xC7, size, EXT_NDARRAY)
    elif size < 0x10000:
        head = _EXT16.pack(0xC8, size, EXT_NDARRAY)
    else:
        head = _EXT32.pack(0xC9, size, EXT_NDARRAY)
    if size < _EXT_HEADERS_MAX_SIZE:
        _EXT_HEADERS[size] = head
    return head


# Extension headers by data size, for the sizes of small and medium columns.
_EXT_HEADERS: dict[int, bytes] = {}
_EXT_HEADERS_MAX_SIZE = 1 << 16
# Packed small values that recur in every message: positive fixints and short strings
# (sensor ids, kinds). Same bytes as msgpack's.
_FIXINTS: tuple[bytes, ...] = tuple(bytes((i,)) for i in range(128))
_STR_CACHE: dict[str, bytes] = {}
_STR_CACHE_MAX = 4096


def _packed_key(key: Any) -> bytes:
    packed = _KEY_CACHE.get(key) if type(key) is str else None
    if packed is None:
        if not isinstance(key, str):
            raise ProtocolError(f"payload map keys must be str, got {key!r}")
        if key in _RESERVED_KEYS:
            raise ProtocolError(f"payload key {key!r} is reserved for the envelope")
        packed = msgpack.packb(key, use_bin_type=True)
        if type(key) is str and len(_KEY_CACHE) < _KEY_CACHE_MAX:
            _KEY_CACHE[key] = packed
    return packed


# long: 37 docstring lines; each payload kind's columns framed in one pass (the byte format)
def encode(topic: bytes, t_sim: float, payload: Mapping[str, Any]) -> list[bytes]:
    """Encode one message as its two ZeroMQ frames ``[topic, body]``.

    Parameters
    ----------
    topic : bytes
        Topic frame, e.g. :data:`TOPIC_PLOTS` (1 to 255 bytes).
    t_sim : float
        Simulated time of the message [s since scenario start]; finite.
    payload : Mapping[str, Any]
        The message content. Keys are str and must not be ``"v"`` or ``"t"`` (the envelope's).
        Values: dicts with str keys, lists, tuples (sent as arrays), str, bytes, int, float
        (NaN and inf allowed), bool, None, numpy scalars (sent as Python scalars) and numpy
        arrays of bool/int/uint/float/complex (sent as typed columns). The encoder does not
        interpret keys.

    Returns
    -------
    list[bytes]
        ``[topic, body]``. Equal inputs give identical bytes (insertion order is kept, floats
        are always float64, no wall-clock value is added).

    Raises
    ------
    ProtocolError
        On a bad topic, non-finite time, reserved or non-str key, unencodable value, or a
        body larger than :data:`MAX_BODY_BYTES`.

    Notes
    -----
    The body is exactly what ``msgpack.packb({"v": ..., "t": ..., **payload})`` gives with
    arrays as :data:`EXT_NDARRAY` extensions (the reference encoder,
    :func:`encode_reference`, which the tests compare it with). The top-level map is written here
    directly: the envelope and the payload keys are pre-packed, and each numpy column goes
    out as its extension header plus :func:`encode_array` without passing through msgpack's
    ``default`` hook and an ``ExtType`` object (the stream's hot path: a plot frame is a
    handful of columns).
    """
    if not isinstance(topic, bytes) or not 0 < len(topic) <= MAX_TOPIC_BYTES:
        raise ProtocolError(f"topic must be 1 to {MAX_TOPIC_BYTES} bytes, got {topic!r}")
    t = float(t_sim)
    if not math.isfinite(t):
        raise ProtocolError(f"t_sim must be finite, got {t_sim!r}")
    if type(payload) is not dict and not isinstance(payload, Mapping):
        raise ProtocolError(f"payload must be a mapping, got {type(payload).__name__}")
    parts = [_map_header(len(payload) + 2), _ENVELOPE_V, _ENVELOPE_T_KEY,
             _FLOAT64.pack(0xCB, t)]
    append = parts.append
    packer = None
    for key, value in payload.items():
        packed_key = _KEY_CACHE.get(key)
        append(_packed_key(key) if packed_key is None else packed_key)
        if type(value) is np.ndarray:
            head = _COLUMN_HEADS.get(value.dtype) if value.ndim == 1 else None
            if head is not None:
                # the usual column: 1-d, already little-endian (same bytes as encode_array;
                # tobytes gives the elements in order whatever the strides), after its
                # extension header, array head and element count
                n = len(value)
                prefix = _COLUMN_PREFIXES.get((head, n))
                if prefix is None:
                    prefix = _ext_header(16 + n * value.itemsize) + head + _U64.pack(n)
                    if len(_COLUMN_PREFIXES) < _COLUMN_PREFIXES_MAX:
                        _COLUMN_PREFIXES[head, n] = prefix
                append(prefix)
                append(value.tobytes())
                continue
            data = encode_array(value)
            append(_ext_header(len(data)))
            append(data)
            continue
        vtype = type(value)
        if vtype is float:  # msgpack's float 64, as every packer writes a Python float
            append(_FLOAT64.pack(0xCB, value))
            continue
        if vtype is int and 0 <= value < 128:
            append(_FIXINTS[value])
            continue
        if vtype is str:
            packed = _STR_CACHE.get(value)
            if packed is None:
                try:
                    packed = msgpack.packb(value, use_bin_type=True)
                except ValueError as exc:  # e.g. a lone surrogate, not UTF-8 encodable
                    raise ProtocolError(f"payload cannot be encoded: {exc}") from exc
                if len(value) <= 64 and len(_STR_CACHE) < _STR_CACHE_MAX:
                    _STR_CACHE[value] = packed
            append(packed)
            continue
        if isinstance(value, dict):
            _check_keys(value, 1)
        elif isinstance(value, (list, tuple)):
            _check_items(value, 1)
        if packer is None:
            packer = _packer()
        try:
            packed = packer.pack(value)
        except ProtocolError:
            packer.reset()
            raise
        except (TypeError, ValueError, OverflowError) as exc:  # e.g. int beyond 64 bits
            packer.reset()
            raise ProtocolError(f"payload cannot be encoded: {exc}") from exc
        append(packed)
    body = b"".join(parts)
    if len(body) > MAX_BODY_BYTES:
        raise ProtocolError(
            f"encoded body is {len(body)} bytes, over the {MAX_BODY_BYTES}-byte maximum: "
            "split the payload (e.g. one message per sector)"
        )
    return [topic, body]


def _flat_items(payload: Mapping[str, Any]) -> bytes | None:
    """What :func:`encode` writes for the items of ``payload`` when every key is one it has
    packed before and every value a str it has packed before, an int in [0, 128) or a float
    (a message's fixed part: sensor, scan, kind); None otherwise (then :func:`encode`
    packs it, and remembers its keys and strings)."""
    parts = []
    for key, value in payload.items():
        packed = _KEY_CACHE.get(key) if type(key) is str else None
        if packed is None:
            return None
        parts.append(packed)
        vtype = type(value)
        if vtype is str:
            packed = _STR_CACHE.get(value)
            if packed is None:
                return None
        elif vtype is int and 0 <= value < 128:
            packed = _FIXINTS[value]
        elif vtype is float:
            packed = _FLOAT64.pack(0xCB, value)
        else:
            return None
        parts.append(packed)
    return b"".join(parts)


# long: 36 docstring lines; encode's byte format for many slices at once, kept beside it
def encode_slices(
    topic: bytes,
    times: Sequence[float] | np.ndarray,
    fixed: Mapping[str, Any] | Sequence[Mapping[str, Any]],
    columns: Mapping[str, tuple[np.ndarray, Sequence[int] | np.ndarray,
                                Sequence[int] | np.ndarray]],
    fixed_index: Sequence[int] | np.ndarray | None = None,
) -> list[bytes]:
    """Encode many messages that share their keys and slice the same columns: the bodies.

    Message ``j`` is exactly ``encode(topic, times[j], {**fixed, **{key: array[start[j]:
    stop[j]] for key, (array, start, stop) in columns.items()}})[1]``: the same bytes, for
    the engine's sector frames, whose columns are the slices of a block of revolutions'
    arrays.  The fixed part is packed once, each column's elements are converted to bytes
    once, and the bodies are assembled in compiled code (``shipradar/_frames.c``: no
    per-message dict, array or msgpack call; without the extension its pure-Python twin
    ``shipradar/_frames_py.py``, the same bytes).

    Parameters
    ----------
    topic : bytes
        Topic of every message (checked as by :func:`encode`).
    times : Sequence[float]
        Simulated time of each message [s]; finite.
    fixed : Mapping[str, Any] or Sequence[Mapping[str, Any]]
        Keys and values common to every message, first in each payload (as :func:`encode`
        takes them); or several such mappings, all with the same keys, message ``j`` taking
        ``fixed[fixed_index[j]]`` (the sector frames of several revolutions: their scan
        numbers).
    columns : Mapping[str, tuple[numpy.ndarray, Sequence[int], Sequence[int]]]
        For each column key, in payload order after ``fixed``: a 1-d array and the start and
        stop index of each message's slice.
    fixed_index : Sequence[int], optional
        With a sequence ``fixed``: the index in it of each message's fixed part.

    Returns
    -------
    list[bytes]
        One body per message; the frames of message ``j`` are ``[topic, bodies[j]]``.

    Raises
    ------
    ProtocolError
        As :func:`encode` (the keys of ``fixed`` and ``columns`` together must be distinct).
    """
    many = not isinstance(fixed, Mapping)
    parts: list[Mapping[str, Any]] = [fixed] if isinstance(fixed, Mapping) else list(fixed)
    if not parts or any(list(p) != list(parts[0]) for p in parts):
        raise ProtocolError("fixed parts must be one or more mappings with the same keys")
    if any(key in parts[0] for key in columns):
        raise ProtocolError("a key is both fixed and a column")
    keys = len(parts[0])
    # each fixed part, as encode() packs it: the body of a message holding only that part,
    # after its map header and envelope
    head_len = len(_map_header(keys + 2)) + len(_ENVELOPE_V) + len(_ENVELOPE_T_KEY) + 9
    prefix = _map_header(keys + len(columns) + 2) + _ENVELOPE_V + _ENVELOPE_T_KEY
    fixed_parts = tuple(_flat_items(p) or encode(topic, 0.0, p)[1][head_len:] for p in parts)
    n_msg = len(times)
    if many:
        if fixed_index is None:
            raise ProtocolError("several fixed parts need a fixed_index")
        which = np.ascontiguousarray(fixed_index, dtype=np.int64)
    else:
        which = np.zeros(n_msg, dtype=np.int64)
    t_msg = np.asarray(times, dtype=np.float64)
    if t_msg.ndim != 1:
        raise ProtocolError("times must be 1-d")
    if not np.isfinite(t_msg).all():
        raise ProtocolError(f"t_sim must be finite, got {t_msg[~np.isfinite(t_msg)][0]!r}")
    cols = []
    bounds: dict[int, np.ndarray] = {}  # columns often share their start and stop arrays
    for key, (array, start, stop) in columns.items():
        for b in (start, stop):
            if id(b) not in bounds:
                bounds[id(b)] = np.ascontiguousarray(b, dtype=np.int64)
        array = np.asarray(array)
        if array.ndim != 1:
            raise ProtocolError(f"column {key!r} must be 1-d")
        head = _COLUMN_HEADS.get(array.dtype)
        if head is None:  # big-endian or unusual: convert once, same bytes as encode_array
            head, little = _array_head(array.dtype, 1)
            array = array.astype(little)
        cols.append((_packed_key(key), head, array.dtype.itemsize,
                     np.ascontiguousarray(array), bounds[id(start)], bounds[id(stop)]))
    # the bodies are joined in compiled code (shipradar/_frames.c): per message the prefix,
    # the time, the fixed part, and per column its key, extension header, array head,
    # element count and slice of the column's bytes
    try:
        return _frames.encode_slices(prefix, fixed_parts, which, t_msg, tuple(cols),
                                     EXT_NDARRAY, MAX_BODY_BYTES)
    except OverflowError as exc:
        raise ProtocolError(
            f"encoded body is {exc} bytes, over the {MAX_BODY_BYTES}-byte maximum: "
            "split the payload (e.g. one message per sector)"
        ) from None
    except (ValueError, IndexError) as exc:
        raise ProtocolError(f"encode_slices: {exc}") from None


def payload_items(topic: bytes, payload: Mapping[str, Any]) -> bytes:
    """The bytes :func:`encode` writes for the items of ``payload`` (after the map header and
    the envelope): each key then its value, in order, whatever else the message holds.

    Joined under one header by :func:`encode_items`, the items of several payloads give
    exactly the body of one :func:`encode` of the merged payload, so a message whose keys
    mostly never change (the sensor metadata) is packed once and re-used.
    """
    body = encode(topic, 0.0, payload)[1]
    return body[len(_map_header(len(payload) + 2)) + len(_ENVELOPE_V) + len(_ENVELOPE_T_KEY)
                + 9:]


def encode_items(topic: bytes, t_sim: float, n_items: int, items: Sequence[bytes]
                 ) -> list[bytes]:
    """``encode(topic, t_sim, payload)`` from the :func:`payload_items` of its parts:
    ``n_items`` keys in all, ``items`` in payload order (distinct keys; same bytes)."""
    t = float(t_sim)
    if not math.isfinite(t):
        raise ProtocolError(f"t_sim must be finite, got {t_sim!r}")
    body = b"".join((_map_header(n_items + 2), _ENVELOPE_V, _ENVELOPE_T_KEY,
                     _FLOAT64.pack(0xCB, t), *items))
    if len(body) > MAX_BODY_BYTES:
        raise ProtocolError(
            f"encoded body is {len(body)} bytes, over the {MAX_BODY_BYTES}-byte maximum: "
            "split the payload (e.g. one message per sector)"
        )
    return [topic, body]


def float_rows(topic: bytes, template: Mapping[str, Any], columns: Sequence[np.ndarray]
               ) -> list[bytes]:
    """:func:`payload_items` of many payloads shaped as ``template``: payload ``j`` is the
    template with its float leaves (in the order they are packed, nested maps and arrays
    included) replaced by ``columns[i][j]``, every other value the template's.

    The same bytes, for all payloads at once: a Python float is always packed as msgpack's
    float 64 (0xcb and the big-endian double, :func:`encode`), so every payload has the
    template's layout, and its floats are written into copies of the template's bytes.

    Parameters
    ----------
    topic : bytes
        Topic of the messages (checked as by :func:`encode`).
    template : Mapping[str, Any]
        A payload of the shape (keys, nesting, non-float values) of every row.
    columns : Sequence[numpy.ndarray]
        One array per float leaf of ``template``, in packing order, each with one float64
        value per row (NaN and signed zeros kept bit for bit).

    Returns
    -------
    list[bytes]
        One :func:`payload_items` per row.

    Raises
    ------
    ProtocolError
        As :func:`encode`, or when ``columns`` are not one per float leaf, of one length.
    """
    marks: list[float] = []
    marked = payload_items(topic, _float_marks(template, marks))
    if len(columns) != len(marks):
        raise ProtocolError(f"float_rows: {len(marks)} float leaves, {len(columns)} columns")
    values = [np.asarray(c, dtype=np.float64) for c in columns]
    n = len(values[0]) if values else 0
    if any(v.shape != (n,) for v in values):
        raise ProtocolError("float_rows: columns must be 1-d and of one length")
    offsets = []
    for mark in marks:
        packed = _FLOAT64.pack(0xCB, mark)
        at = marked.find(packed)
        if at < 0 or marked.find(packed, at + 1) >= 0:  # a mark's bytes elsewhere too
            rows_of = zip(*(v.tolist() for v in values), strict=True)
            return [payload_items(topic, _float_filled(template, iter(row))) for row in rows_of]
        offsets.append(at + 1)
    size = len(marked)
    rows = np.empty(n, np.dtype({"names": [f"f{i}" for i in range(len(values))],
                                 "formats": [">f8"] * len(values), "offsets": offsets,
                                 "itemsize": size}))
    rows.view(np.uint8).reshape(n, size)[:] = np.frombuffer(marked, np.uint8)
    for i, v in enumerate(values):
        rows[f"f{i}"] = v
    blob = rows.tobytes()
    return [blob[j * size:(j + 1) * size] for j in range(n)]


def _float_marks(value: Any, marks: list[float]) -> Any:
    """``value`` with each float leaf replaced by a distinct mark (appended to ``marks``):
    subnormal doubles whose 8 bytes are unlikely anywhere else in a packed payload."""
    if type(value) is float:
        mark = b"\x00\x0f\xa5\x3c\x96" + len(marks).to_bytes(3, "big")
        marks.append(struct.unpack(">d", mark)[0])
        return marks[-1]
    if isinstance(value, Mapping):
        return {k: _float_marks(v, marks) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_float_marks(v, marks) for v in value]
    return value


def _float_filled(value: Any, floats: Iterator[float]) -> Any:
    """``value`` with its float leaves replaced, in packing order, by ``floats``."""
    if type(value) is float:
        return next(floats)
    if isinstance(value, Mapping):
        return {k: _float_filled(v, floats) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_float_filled(v, floats) for v in value]
    return value


def encode_reference(topic: bytes, t_sim: float, payload: Mapping[str, Any]) -> list[bytes]:
    """The straightforward encoder (msgpack with a ``default`` hook for the arrays): the
    bytes :func:`encode` must give, without its fast paths (the tests compare the two; slow,
    not for the stream)."""
    _check_keys(payload)
    for key in _RESERVED_KEYS:
        if key in payload:
            raise ProtocolError(f"payload key {key!r} is reserved for the envelope")
    body_map: dict[str, Any] = {"v": SCHEMA_VERSION, "t": float(t_sim)}
    body_map.update(payload)
    return [topic, msgpack.packb(body_map, default=_default, use_bin_type=True)]


def _ext_hook(code: int, data: bytes) -> Any:
    if code == EXT_NDARRAY:
        return decode_array(data)
    raise ProtocolError(f"unknown msgpack extension type {code}")


def decode(frames: Sequence[bytes]) -> tuple[bytes, float, dict[str, Any]]:
    """Decode the frames of one message (inverse of :func:`encode`).

    Parameters
    ----------
    frames : Sequence[bytes]
        ``[topic, body]`` as received from a SUB socket or read from a recording
        (``bytes``, ``memoryview`` or ``zmq.Frame`` buffers).

    Returns
    -------
    topic : bytes
        The topic frame.
    t_sim : float
        Simulated time [s since scenario start].
    payload : dict[str, Any]
        The payload without the envelope keys; numpy arrays come back as read-only arrays.

    Raises
    ------
    ProtocolError
        If there are not exactly two frames, the body is over :data:`MAX_BODY_BYTES`, is not
        valid msgpack, lacks ``"v"``/``"t"``, or has an unsupported schema version.
    """
    if len(frames) != 2:
        raise ProtocolError(f"a message has 2 frames [topic, body], got {len(frames)}")
    topic = bytes(frames[0])
    body = frames[1]
    size = memoryview(body).nbytes
    if size > MAX_BODY_BYTES:
        raise ProtocolError(f"message body is {size} bytes, over the {MAX_BODY_BYTES}-byte maximum")
    try:
        obj = msgpack.unpackb(
            body,
            raw=False,
            ext_hook=_ext_hook,
            strict_map_key=True,
        )
    except ProtocolError:
        raise
    except Exception as exc:  # msgpack raises several unrelated types on garbage
        raise ProtocolError(f"message body on topic {topic!r} is not valid msgpack: {exc}") from exc
    if not isinstance(obj, dict) or "v" not in obj or "t" not in obj:
        raise ProtocolError(f"message body on topic {topic!r} lacks the 'v'/'t' envelope")
    version = obj.pop("v")
    if version not in SUPPORTED_SCHEMA_VERSIONS:
        raise ProtocolError(
            f"message schema version {version!r} is not supported "
            f"(this decoder reads {list(SUPPORTED_SCHEMA_VERSIONS)})"
        )
    t_sim = obj.pop("t")
    if not isinstance(t_sim, (int, float)) or isinstance(t_sim, bool):
        raise ProtocolError(f"message time 't' must be a number, got {t_sim!r}")
    return topic, float(t_sim), obj


def _json_float(x: float) -> float | None:
    return x if math.isfinite(x) else None


def _json_bytes(b: bytes) -> str:
    try:
        return b.decode("utf-8")
    except UnicodeDecodeError:
        return "0x" + b.hex()


def to_jsonable(value: Any) -> Any:
    """Convert a decoded payload to plain JSON types (used by ``shipradar tail``).

    Parameters
    ----------
    value : Any
        A payload as returned by :func:`decode`, or any part of it.

    Returns
    -------
    Any
        The same structure with numpy arrays as (nested) lists, numpy scalars as Python
        scalars, NaN and +/-inf as ``None`` (JSON has no such numbers), bytes as UTF-8 text
        (or ``"0x"`` + hex when not valid UTF-8), tuples as lists and map keys as str.
    """
    if isinstance(value, Mapping):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, (list, tuple)):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return to_jsonable(value.item())
    if isinstance(value, float):
        return _json_float(value)
    if isinstance(value, complex):
        return [_json_float(value.real), _json_float(value.imag)]
    if isinstance(value, (bytes, bytearray, memoryview)):
        return _json_bytes(bytes(value))
    return value


def retime(body: bytes, t_sim: float) -> bytes:
    """An encoded message's body (:func:`encode`, :func:`encode_items`, a sector frame) with
    the envelope's ``t`` set to ``t_sim`` (a message that leaves late, issue 33's reporting
    latency): the same bytes as encoding the payload at ``t_sim``."""
    t = float(t_sim)
    if not math.isfinite(t):
        raise ProtocolError(f"t_sim must be finite, got {t_sim!r}")
    head = body[0]
    n = 1 if 0x80 <= head <= 0x8F else 3 if head == 0xDE else 5 if head == 0xDF else 0
    at = n + len(_ENVELOPE_V) + len(_ENVELOPE_T_KEY)
    if not n or body[n:at] != _ENVELOPE_V + _ENVELOPE_T_KEY or body[at] != 0xCB:
        raise ProtocolError("not a message body of this protocol (v, t first)")
    return b"".join((body[:at], _FLOAT64.pack(0xCB, t), body[at + 9:]))
