"""The pure-Python twin of the compiled extension ``shipradar._frames`` (``_frames.c``).

Used when the extension was not built (``pip install`` on a machine without a C compiler or
the Python headers: it is an optional extension, setup.py) or is switched off with the
environment variable ``SHIPRADAR_PURE_PYTHON=1`` (:mod:`shipradar._framing` chooses). The
same functions and the same bytes, slower (docs/performance.md section 15):

- :func:`encode_slices` joins the bodies in Python (per message the prefix, the time, the
  fixed part and the column slices);
- :func:`frame_records` returns None: the recorder then frames the records with its own
  Python loop (:meth:`shipradar.sim.stream.recording.Recorder.write_many`), the reference
  the compiled framing is tested against;
- :func:`crc32` is :func:`zlib.crc32`.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["crc32", "encode_slices", "frame_records", "uses_zlib"]

_FIXEXT_CODES = {1: 0xD4, 2: 0xD5, 4: 0xD6, 8: 0xD7, 16: 0xD8}
_U8 = struct.Struct(">B")
_U16 = struct.Struct(">H")
_U32 = struct.Struct(">I")
_COUNT = struct.Struct("<Q")  # the element count after the array head, little-endian


def _ext_header(size: int, ext_type: bytes) -> bytes:
    """msgpack header of an extension of ``size`` bytes, in the smallest format (as
    ``put_ext_header`` in _frames.c and every msgpack packer)."""
    code = _FIXEXT_CODES.get(size)
    if code is not None:
        return bytes((code,)) + ext_type
    if size < 0x100:
        return b"\xc7" + _U8.pack(size) + ext_type
    if size < 0x10000:
        return b"\xc8" + _U16.pack(size) + ext_type
    return b"\xc9" + _U32.pack(size) + ext_type


def encode_slices(prefix: bytes, fixed: tuple[bytes, ...], which: np.ndarray,
                  times: np.ndarray, cols: tuple[tuple[Any, ...], ...], ext_type: int,
                  max_body: int) -> list[bytes]:
    """The bodies of :func:`shipradar.sim.stream.protocol.encode_slices`, as the compiled
    ``encode_slices``: per message ``j`` the prefix, its float64 time, its fixed part
    (``fixed[which[j]]``), then per column ``(key, head, itemsize, data, start, stop)`` its
    key, extension header, array head, element count and slice of the data.

    Raises
    ------
    OverflowError
        A body's size [bytes] (its message) when it exceeds ``max_body``.
    ValueError, IndexError, TypeError
        Bad arguments, as the compiled function.
    """
    if not all(type(f) is bytes for f in fixed):
        raise TypeError("encode_slices: fixed parts must be bytes")
    t_be = np.asarray(times, dtype=">f8").ravel().tobytes()  # msgpack float 64, big-endian
    n_msg = len(t_be) // 8
    fixed_of = np.asarray(which, dtype=np.int64).ravel().tolist()
    if len(fixed_of) != n_msg:
        raise ValueError("encode_slices: one fixed part index per time")
    if any(f < 0 or f >= len(fixed) for f in fixed_of):
        raise IndexError("encode_slices: fixed part index out of range")
    ext = struct.pack("b", ext_type)
    columns = []
    for key, head, itemsize, data, start, stop in cols:
        i0s = np.asarray(start, dtype=np.int64).ravel().tolist()
        i1s = np.asarray(stop, dtype=np.int64).ravel().tolist()
        if len(i0s) != n_msg or len(i1s) != n_msg or itemsize <= 0:
            raise ValueError("encode_slices: one start and stop per time")
        raw = np.ascontiguousarray(data).view(np.uint8).data  # a memoryview of its bytes
        columns.append((bytes(key), bytes(head), int(itemsize), raw, i0s, i1s))
    bodies = []
    for j in range(n_msg):
        parts = [prefix, b"\xcb", t_be[8 * j:8 * j + 8], fixed[fixed_of[j]]]
        for key, head, size, raw, i0s, i1s in columns:
            i0, i1 = i0s[j], i1s[j]
            if i0 < 0 or i1 < i0 or i1 * size > len(raw):
                raise IndexError("encode_slices: slice out of the column")
            n = i1 - i0
            parts += (key, _ext_header(len(head) + 8 + n * size, ext), head, _COUNT.pack(n),
                      raw[i0 * size:i1 * size])
        body = b"".join(parts)
        if len(body) > max_body:
            raise OverflowError(str(len(body)))
        bodies.append(body)
    return bodies


def frame_records(records: Sequence[Any], seq: int, max_record: int, offset: int) -> None:
    """None: the recorder frames the records with its own Python loop (same bytes)."""
    return None


def crc32(data: bytes | memoryview, crc: int = 0, table: bool = False) -> int:
    """:func:`zlib.crc32` (``table`` is the compiled module's test switch, ignored here)."""
    return zlib.crc32(data, crc)


def uses_zlib() -> bool:
    """True: the CRC-32 is zlib's."""
    return True
