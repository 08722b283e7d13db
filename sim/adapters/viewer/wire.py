"""What the viewer sends to the page: stream messages reduced to what a PPI draws, in batches.

A stream message (``meta``, ``plots``, ``eos``, ``truth``, ``tracks``; docs/protocol.md)
becomes a *view item*: a small dict with a kind ``k`` and the time ``t``, whose numeric
columns stay numpy arrays. Items are sent in *batches*, one WebSocket binary message each::

    uint32 LE   length H of the header
    H bytes     header, UTF-8 JSON: {"ws": wall ms, "status": {...}, "items": [...]}
    pad         zero bytes up to a multiple of 8
    blob        the columns, each 8-byte aligned

In the header every column is replaced by ``{"$": [offset, length, type]}`` (offset into
the blob [bytes], element count, one of ``f8 f4 u1 i4``), which the page wraps as a typed
array without copying. Binary columns keep the cost per plot to a ``tobytes`` on the server
and a view in the browser: JSON would spend more time formatting floats than the
simulator spends making them.
"""

from __future__ import annotations

import json
import math
import struct
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from shipradar.sim.stream import schema

__all__ = [
    "ITEM_KINDS",
    "MAX_BATCH_BYTES",
    "MAX_PLOTS_PER_MESSAGE",
    "TOPIC_TRACKS",
    "ViewError",
    "pack_batch",
    "to_view",
    "unpack_batch",
]

#: Topic of the tracks a tracker publishes back (docs/protocol.md, "tracks").
TOPIC_TRACKS: bytes = schema.TOPIC_TRACKS

# The stream keys a view item is made of (to_view), checked against the schema
# (shipradar.sim.stream.schema) when the module is imported.
schema.META.keys_of("sensor", "platform", "scan", "scan_period_s", "radar", "target_ids",
                    "origin_codes", "noise_false_alarms_per_scan",
                    "clutter_false_alarms_per_scan")
schema.PLOTS.keys_of("sensor", "scan", "plot_id", "time_s", "range_m", "azimuth_rad", "snr_db")
schema.EOS.keys_of("sensor", "scan", "position", "velocity_enu_mps", "heading_deg")
schema.TRUTH_PLOTS.keys_of("sensor", "scan", "kind", "plot_id", "origin", "target")
schema.TRUTH_TARGETS.keys_of("sensor", "kind", "east_m", "north_m", "active")
schema.TRACKS.keys_of("sensor", "track_id", "east_m", "north_m", "v_east_mps", "v_north_mps",
                      "sigma_east_m", "sigma_north_m")
#: Kinds of view item.
ITEM_KINDS = ("meta", "plots", "origin", "eos", "targets", "tracks")
#: Most plots (or targets, tracks) accepted in one message: larger ones are refused as
#: malformed rather than drawn (a sector of the densest example holds a few thousand).
MAX_PLOTS_PER_MESSAGE: int = 1_000_000
#: A batch stops growing past this size [bytes]; what is left goes in the next one.
MAX_BATCH_BYTES: int = 4 << 20

_U32 = struct.Struct("<I")
_TYPES: dict[str, np.dtype] = {"f8": np.dtype("<f8"), "f4": np.dtype("<f4"), "u1": np.dtype("u1"),
          "i4": np.dtype("<i4")}


class ViewError(ValueError):
    """A stream message that does not hold what its topic promises."""


def _str(p: Mapping[str, Any], key: str, limit: int = 256) -> str:
    v = p.get(key)
    if not isinstance(v, str) or len(v) > limit:
        raise ViewError(f"{key!r} must be a string of at most {limit} characters")
    return v


def _num(p: Mapping[str, Any], key: str, default: float | None = None) -> float:
    v = p.get(key, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ViewError(f"{key!r} must be a finite number, got {v!r}")
    return float(v)


def _int(p: Mapping[str, Any], key: str) -> int:
    v = p.get(key)
    if isinstance(v, bool) or not isinstance(v, int) or not -(2**53) < v < 2**53:
        raise ViewError(f"{key!r} must be an integer, got {v!r}")
    return v


def _col(p: Mapping[str, Any], key: str, kind: str, n: int | None = None) -> np.ndarray:
    v = p.get(key)
    if not isinstance(v, np.ndarray) or v.ndim != 1:
        if isinstance(v, (list, tuple)) and len(v) <= MAX_PLOTS_PER_MESSAGE:
            v = np.asarray(v)
        else:
            raise ViewError(f"{key!r} must be a 1-d array")
    if v.size > MAX_PLOTS_PER_MESSAGE:
        raise ViewError(f"{key!r} holds {v.size} elements, over {MAX_PLOTS_PER_MESSAGE}")
    if n is not None and v.size != n:
        raise ViewError(f"{key!r} holds {v.size} elements, expected {n}")
    if v.dtype.kind not in "biuf":
        raise ViewError(f"{key!r} has element type {v.dtype}, expected numbers")
    return v.astype(_TYPES[kind], copy=False)


def _str_list(p: Mapping[str, Any], key: str, limit: int = 100_000) -> list[str]:
    v = p.get(key, [])
    if not isinstance(v, (list, tuple)) or len(v) > limit or \
            not all(isinstance(s, str) and len(s) <= 256 for s in v):
        raise ViewError(f"{key!r} must be a list of strings")
    return list(v)


def to_view(topic: bytes, t: float, p: Mapping[str, Any]) -> dict[str, Any] | None:
    """Reduce one decoded stream message to a view item.

    Parameters
    ----------
    topic : bytes
        Topic frame (``meta``, ``plots``, ``eos``, ``truth``, ``tracks``).
    t : float
        Simulated time of the message [s since scenario start].
    p : Mapping[str, Any]
        Decoded payload (:func:`shipradar.sim.stream.protocol.decode`).

    Returns
    -------
    dict or None
        The item (kinds :data:`ITEM_KINDS`), or None for a topic the page does not draw.

    Raises
    ------
    ViewError
        If a field the page needs is missing or of the wrong type or length (the message is
        then skipped and counted, never drawn half-read).
    """
    fields = _VIEW_FIELDS.get(topic)
    if fields is None:
        return None
    item = fields(p)
    if item is None:
        return None
    return {"t": float(t), **item}


def _plots_fields(p: Mapping[str, Any]) -> dict[str, Any]:
    """A ``plots`` message: the plots' ids, times, ranges, azimuths and S/I."""
    ids = _col(p, "plot_id", "f8")
    n = ids.size
    return dict(k="plots", sensor=_str(p, "sensor"), scan=_int(p, "scan"), id=ids,
                ts=_col(p, "time_s", "f8", n), r=_col(p, "range_m", "f4", n),
                az=_col(p, "azimuth_rad", "f4", n), snr=_col(p, "snr_db", "f4", n))


def _truth_fields(p: Mapping[str, Any]) -> dict[str, Any] | None:
    """``truth[plots]`` (each plot's origin and target) or ``truth[targets]`` (positions,
    activity); None for the other truth kinds."""
    kind = p.get("kind")
    if kind == "plots":
        ids = _col(p, "plot_id", "f8")
        n = ids.size
        return dict(k="origin", sensor=_str(p, "sensor"), scan=_int(p, "scan"),
                    id0=float(ids[0]) if n else -1.0, n=n,
                    o=_col(p, "origin", "u1", n), tg=_col(p, "target", "i4", n))
    if kind == "targets":
        e = _col(p, "east_m", "f8")
        n = e.size
        return dict(k="targets", sensor=_str(p, "sensor"), e=e,
                    n=_col(p, "north_m", "f8", n), a=_col(p, "active", "u1", n))
    return None


def _eos_fields(p: Mapping[str, Any]) -> dict[str, Any]:
    """An ``eos`` message: the platform's position, heading and horizontal velocity."""
    pos = p.get("position")
    if not isinstance(pos, Mapping):
        raise ViewError("'position' must be a map")
    vel = p.get("velocity_enu_mps", [0.0, 0.0, 0.0])
    if not isinstance(vel, (list, tuple)) or len(vel) < 2:
        raise ViewError("'velocity_enu_mps' must be a list of 3 numbers")
    return dict(k="eos", sensor=_str(p, "sensor"), scan=_int(p, "scan"),
                e=_num(pos, "east_m"), n=_num(pos, "north_m"),
                hd=_num(p, "heading_deg"),
                ve=_num({"v": vel[0]}, "v"), vn=_num({"v": vel[1]}, "v"))


def _meta_fields(p: Mapping[str, Any]) -> dict[str, Any]:
    """A ``meta`` message: the radar's period, range, beam and the code lists."""
    radar = p.get("radar")
    if not isinstance(radar, Mapping):
        raise ViewError("'radar' must be a map")
    item: dict[str, Any] = dict(
        k="meta", sensor=_str(p, "sensor"), platform=_str(p, "platform"),
        scan=_int(p, "scan"), period=_num(p, "scan_period_s"),
        range_m=_num(radar, "instrumented_range_m"),
        beam_deg=_num(radar, "beamwidth_az_deg", 1.0),
        az0_deg=_num(radar, "start_azimuth_deg", 0.0),
        target_ids=_str_list(p, "target_ids"),
        origin_codes=_str_list(p, "origin_codes"),
        nfa=_num(p, "noise_false_alarms_per_scan", 0.0),
        cfa=_num(p, "clutter_false_alarms_per_scan", 0.0))
    if item["period"] <= 0 or item["range_m"] <= 0:
        raise ViewError("'scan_period_s' and 'instrumented_range_m' must be > 0")
    return item


def _tracks_fields(p: Mapping[str, Any]) -> dict[str, Any]:
    """A ``tracks`` message of a tracker: ids, positions, velocities and their sigmas."""
    e = _col(p, "east_m", "f8")
    n = e.size
    track_ids = _str_list(p, "track_id", MAX_PLOTS_PER_MESSAGE)
    if len(track_ids) != n:
        raise ViewError(f"'track_id' holds {len(track_ids)} ids, expected {n}")
    return dict(k="tracks", sensor=_str(p, "sensor"), ids=track_ids, e=e,
                n=_col(p, "north_m", "f8", n), ve=_col(p, "v_east_mps", "f4", n),
                vn=_col(p, "v_north_mps", "f4", n),
                se=_col(p, "sigma_east_m", "f4", n), sn=_col(p, "sigma_north_m", "f4", n))


# the view fields of each topic the page draws
_VIEW_FIELDS: dict[bytes, Callable[[Mapping[str, Any]], dict[str, Any] | None]] = {
    b"plots": _plots_fields, b"truth": _truth_fields, b"eos": _eos_fields,
    b"meta": _meta_fields, TOPIC_TRACKS: _tracks_fields}


def item_weight(item: Mapping[str, Any]) -> int:
    """Approximate size of an item in a batch [bytes] (for the batch size limit)."""
    return 256 + sum(v.nbytes for v in item.values() if isinstance(v, np.ndarray))


def pack_batch(items: Sequence[Mapping[str, Any]], status: Mapping[str, Any],
               wall_ms: float) -> bytes:
    """Encode view items (and the server's status) as one batch (layout in the module doc).

    Parameters
    ----------
    items : Sequence[Mapping]
        View items, in the order the page must apply them.
    status : Mapping
        Server counters shown on the status line (JSON types).
    wall_ms : float
        Server wall clock when the batch was made [ms since the epoch]; the page measures
        its latency against it.

    Returns
    -------
    bytes
        The WebSocket message.
    """
    blobs: list[bytes] = []
    pos = 0
    out_items = []
    for item in items:
        d: dict[str, Any] = {}
        for key, value in item.items():
            if isinstance(value, np.ndarray):
                data = value.tobytes()
                code = next(c for c, dt in _TYPES.items() if dt == value.dtype)
                d[key] = {"$": [pos, int(value.size), code]}
                blobs.append(data)
                pad = -len(data) % 8
                if pad:
                    blobs.append(b"\0" * pad)
                pos += len(data) + pad
            else:
                d[key] = value
        out_items.append(d)
    header = json.dumps({"ws": wall_ms, "status": dict(status), "items": out_items},
                        separators=(",", ":"), allow_nan=False).encode()
    pad = -(4 + len(header)) % 8
    return b"".join([_U32.pack(len(header)), header, b"\0" * pad, *blobs])


def unpack_batch(data: bytes) -> dict[str, Any]:
    """Decode a batch (inverse of :func:`pack_batch`, for tests and Python clients).

    Parameters
    ----------
    data : bytes
        One WebSocket message from the viewer.

    Returns
    -------
    dict
        ``{"ws", "status", "items"}`` with columns back as numpy arrays.
    """
    (h,) = _U32.unpack_from(data, 0)
    head = json.loads(bytes(data[4:4 + h]))
    base = 4 + h + (-(4 + h) % 8)
    for item in head["items"]:
        for key, value in list(item.items()):
            if isinstance(value, dict) and "$" in value:
                off, n, code = value["$"]
                item[key] = np.frombuffer(data, _TYPES[code], count=n, offset=base + off)
    return head
