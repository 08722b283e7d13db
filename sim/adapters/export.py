"""``shipradar export``: a recording as raw ASTERIX, a pcap, or tidy CSV/Parquet tables.

- ``asterix``: the data blocks that ``replay --asterix`` would send, back to back (the
  common ``.ast`` file that ASTERIX tools read).
- ``pcap``: the datagrams that ``replay --asterix`` sends (127.0.0.1 -> 127.0.0.1:PORT,
  whole data blocks, Ethernet framing), stamped with the scenario's UTC time of their last
  block; Wireshark decodes
  them with ``-d udp.port==PORT,asterix`` (8600 by default, Wireshark's ASTERIX port).
  Written with ``dpkt``.
- ``csv`` / ``parquet``: two tables for pandas, written with ``pyarrow``: the plots, one
  row per plot with its truth origin (``OUT``), and the target states at each end of scan,
  one row per (sensor, scan, target) (``STEM.targets.EXT`` beside it); their columns are the
  schema's (:mod:`shipradar.sim.stream.schema`, :func:`plot_tables`).

Same recording -> same bytes (no wall-clock value is written).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from shipradar.sim.adapters.asterix.encode import DEFAULT_MAX_BLOCK_BYTES
from shipradar.sim.adapters.asterix.stream import AsterixStream, datagrams
from shipradar.sim.stream import protocol
from shipradar.sim.stream.recording import read_recording
from shipradar.sim.stream.schema import (
    META,
    PLOT_TRUTH_COLUMNS,
    PLOTS,
    TRUTH_PLOTS,
    TRUTH_TARGETS,
    Field,
)

__all__ = ["FORMATS", "ExportError", "export", "plot_tables", "targets_path", "write_pcap"]

FORMATS = ("asterix", "pcap", "csv", "parquet")
#: Wireshark's registered ASTERIX UDP port, used in the pcap by default.
DEFAULT_PORT = 8600


class ExportError(RuntimeError):
    """The export cannot run (a missing optional package)."""


def _messages(path: str | os.PathLike[str]) -> Iterator[tuple[str, float, dict[str, Any]]]:
    with read_recording(path) as reader:
        for _, frames in reader:
            topic, t, payload = protocol.decode(frames)
            yield topic.decode(), t, payload


def targets_path(out: str | os.PathLike[str]) -> Path:
    """Where the target-state table of a CSV/Parquet export goes: ``STEM.targets.EXT``."""
    out = Path(out)
    return out.with_name(f"{out.stem}.targets{out.suffix}")


def _blocks(path, max_block_bytes: int) -> tuple[list[tuple[float, bytes]], AsterixStream]:
    stream = AsterixStream(max_block_bytes)
    blocks: list[tuple[float, bytes]] = []
    for topic, t, payload in _messages(path):
        # the datagrams that replay --asterix sends for this message
        blocks.extend(datagrams(stream.feed(topic, t, payload), max_block_bytes))
    return blocks, stream


def write_pcap(out: str | os.PathLike[str], blocks: list[tuple[float, bytes]],
               epoch0: float, port: int = DEFAULT_PORT) -> None:
    """Write datagrams as a pcap: 127.0.0.1 -> 127.0.0.1:``port`` over UDP, Ethernet framing.

    Parameters
    ----------
    out : path
        The pcap file (replaced).
    blocks : list[tuple[float, bytes]]
        ``(t_sim, datagram)`` pairs (:func:`shipradar.sim.adapters.asterix.stream.datagrams`):
        simulated time [s since scenario start] and UDP payload.
    epoch0 : float
        POSIX time of the scenario start [s]; a packet is stamped ``epoch0 + t_sim``, to the
        microsecond.
    port : int, optional
        UDP source and destination port (Wireshark's ASTERIX port 8600 by default).

    Raises
    ------
    ExportError
        ``dpkt`` is not installed.
    """
    try:
        import dpkt
    except ImportError:
        raise ExportError("export --format pcap needs dpkt: pip install 'shipradar[export]'") \
            from None
    lo = bytes((127, 0, 0, 1))
    with open(out, "wb") as f:
        writer = dpkt.pcap.Writer(f, linktype=dpkt.pcap.DLT_EN10MB)
        for i, (t, block) in enumerate(blocks):
            udp = dpkt.udp.UDP(sport=port, dport=port, data=block)
            udp.ulen = len(udp)
            ip = dpkt.ip.IP(src=lo, dst=lo, p=dpkt.ip.IP_PROTO_UDP, ttl=1, id=i & 0xFFFF,
                            data=udp)
            ip.len = len(ip)
            eth = dpkt.ethernet.Ethernet(src=b"\x00" * 6, dst=b"\x00" * 6,
                                         type=dpkt.ethernet.ETH_TYPE_IP, data=ip)
            # microsecond stamps, rounded once here (the ASTERIX time is 1/128 s anyway)
            writer.writepkt(bytes(eth), ts=round((epoch0 + t) * 1e6) / 1e6)


# The columns of the two tables, from the schema: every per-plot column of ``plots`` (codes as
# names) and of ``truth[plots]`` (origin and target as names) and the number of targets merged
# into each plot; every per-target column of ``truth[targets]``.
_PLOT_NUMBERS = PLOTS.columns("n")  # plot_id, time_s, range_m, ..., interference, ...
_PLOT_TRUTH = PLOT_TRUTH_COLUMNS  # origin, target
_TARGET_COLUMNS = TRUTH_TARGETS.columns("k")  # east_m, ..., active
# what a code column reads as: the meta list of names it indexes
_CODE_NAMES = {"interference": "interference_codes", "origin": "origin_codes"}
# the other keys read below, checked against the schema when this module is imported
META.keys_of("sensor", *_CODE_NAMES.values(), "target_ids")
TRUTH_PLOTS.keys_of("sensor", "scan", "kind", "plot_id", "contrib_offsets")
TRUTH_TARGETS.keys_of("sensor", "scan", "kind", "time_s")


def plot_tables(path: str | os.PathLike[str]) -> tuple[dict[str, np.ndarray],
                                                       dict[str, np.ndarray]]:
    """The plots (with their truth) and the target states of a recording, as columns.

    The columns follow the stream's schema (:mod:`shipradar.sim.stream.schema`): a new
    column of the ``plots`` or ``truth`` topics is a new column here.

    Parameters
    ----------
    path : str or os.PathLike
        A recording.

    Returns
    -------
    plots : dict[str, numpy.ndarray]
        One row per plot: ``sensor``, ``scan``, then every per-plot column of the ``plots``
        topic (``plot_id``, ``time_s`` [s], ``range_m`` [m], ``azimuth_rad`` [rad],
        ``snr_db`` [dB], ``sigma_range_m`` [m], ``sigma_azimuth_rad`` [rad],
        ``interference`` (name), ``range_rate_mps`` and ``sigma_range_rate_mps`` [m/s]; NaN
        when the recording predates them), ``origin`` (``target``, ``noise`` or
        ``sea_clutter``), ``target`` (id of the strongest target, empty for false alarms)
        and ``n_targets`` (targets merged into the plot).
    targets : dict[str, numpy.ndarray]
        One row per (sensor, end of scan, target): ``sensor``, ``scan``, ``time_s`` [s],
        ``target``, then every per-target column of ``truth[targets]``: ``east_m``,
        ``north_m``, ``up_m`` [m], ``v_east_mps``, ``v_north_mps``, ``v_up_mps`` [m/s],
        ``a_east_mps2``, ``a_north_mps2``, ``a_up_mps2`` [m/s²], ``active``.

    Raises
    ------
    ValueError
        If a ``truth`` message does not describe the ``plots`` message before it.
    """
    parts: dict[str, list[np.ndarray]] = {k: [] for k in (
        "sensor", "scan", *_PLOT_NUMBERS, *_PLOT_TRUTH, "n_targets")}
    tparts: dict[str, list[np.ndarray]] = {k: [] for k in (
        "sensor", "scan", "time_s", "target", *_TARGET_COLUMNS)}
    meta: dict[str, dict] = {}
    pending: dict[str, dict] = {}
    for topic, _, p in _messages(path):
        if topic == "meta":
            meta.setdefault(p["sensor"], p)
        elif topic == "plots":
            pending[p["sensor"]] = p
        elif topic == "truth" and p.get("kind") == "plots":
            pl = pending.pop(p["sensor"], None)
            if pl is None or not np.array_equal(pl["plot_id"], p["plot_id"]):
                raise ValueError(f"truth of sensor {p['sensor']} scan {p['scan']} does not "
                                 "follow the plots it describes")
            m = meta[p["sensor"]]
            n = len(pl["plot_id"])
            parts["sensor"].append(np.full(n, p["sensor"], dtype=object))
            parts["scan"].append(np.full(n, pl["scan"], dtype=np.int64))
            for k in _PLOT_NUMBERS:
                parts[k].append(_column(pl, PLOTS[k], n, m))
            for k in _PLOT_TRUTH:
                parts[k].append(_column(p, TRUTH_PLOTS[k], n, m))
            parts["n_targets"].append(np.diff(p["contrib_offsets"]).astype(np.int64))
        elif topic == "truth" and p.get("kind") == "targets":
            ids = np.asarray(meta[p["sensor"]]["target_ids"], dtype=object)
            n_t = ids.size
            tparts["sensor"].append(np.full(n_t, p["sensor"], dtype=object))
            tparts["scan"].append(np.full(n_t, p["scan"], dtype=np.int64))
            tparts["time_s"].append(np.full(n_t, p["time_s"], dtype=float))
            tparts["target"].append(ids)
            for c in _TARGET_COLUMNS:
                tparts[c].append(_column(p, TRUTH_TARGETS[c], n_t, meta[p["sensor"]]))
    empty = {"sensor": object, "scan": np.int64, "n_targets": np.int64, "target": object,
             **{k: object for k in _CODE_NAMES},
             **{k: PLOTS[k].dtype for k in _PLOT_NUMBERS if k not in _CODE_NAMES},
             **{k: TRUTH_TARGETS[k].dtype for k in _TARGET_COLUMNS}}

    def cat(d: dict[str, list[np.ndarray]]) -> dict[str, np.ndarray]:
        return {k: np.concatenate(v) if v else np.zeros(0, dtype=empty.get(k, float))
                for k, v in d.items()}

    return cat(parts), cat(tparts)


def _column(payload: dict[str, Any], field: Field, n: int, meta: dict[str, Any]) -> np.ndarray:
    """One column of a message for a table: codes as their names, ``target`` as the
    target's id (``""`` for -1), a column the recording predates (not required) as NaN."""
    if field.key not in payload and not field.required:
        return np.full(n, np.nan)
    value = np.asarray(payload[field.key], dtype=field.dtype)
    if field.key in _CODE_NAMES:
        return np.asarray(meta[_CODE_NAMES[field.key]], dtype=object)[value]
    if field.key == "target":
        return np.asarray([*meta["target_ids"], ""], dtype=object)[value]  # -1 -> ""
    return value


def _arrow_table(cols: dict[str, np.ndarray]):
    import pyarrow as pa

    arrays = {}
    for k, v in cols.items():
        arrays[k] = pa.array(v.tolist(), type=pa.string()) if v.dtype == object \
            else pa.array(v)
    return pa.table(arrays)


def export(recording: str | os.PathLike[str], fmt: str, out: str | os.PathLike[str], *,
           port: int = DEFAULT_PORT,
           max_block_bytes: int = DEFAULT_MAX_BLOCK_BYTES) -> dict[str, Any]:
    """Convert a recording (see the module docstring for the formats).

    Parameters
    ----------
    recording : str or os.PathLike
        The recording to read.
    fmt : {"asterix", "pcap", "csv", "parquet"}
        Output format.
    out : str or os.PathLike
        Output file (replaced if it exists; the CLI asks for ``--overwrite`` first).
    port : int, optional
        UDP port of the pcap's datagrams.
    max_block_bytes : int, optional
        Largest ASTERIX data block [bytes].

    Returns
    -------
    dict
        JSON-ready summary: ``format``, ``out``, and the counts written (``blocks``,
        ``bytes``, ASTERIX stream counts; or ``plots`` and ``target_states`` rows).

    Raises
    ------
    ExportError
        When pyarrow or dpkt, needed for that format, is not installed.
    """
    if fmt not in FORMATS:
        raise ValueError(f"format must be one of {FORMATS}, got {fmt!r}")
    out = Path(out)
    summary: dict[str, Any] = {"format": fmt, "out": str(out)}
    if fmt in ("asterix", "pcap"):
        blocks, stream = _blocks(recording, max_block_bytes)
        if fmt == "asterix":
            with open(out, "wb") as f:
                for _, block in blocks:
                    f.write(block)
        else:
            write_pcap(out, blocks, stream.start_epoch_s or 0.0, port)
            summary.update(port=port, datagrams=len(blocks))
        summary.update(stream.stats)
        return summary
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        raise ExportError(f"export --format {fmt} needs pyarrow: pip install "
                          "'shipradar[export]'") from None
    plots, targets = plot_tables(recording)
    tables = {out: _arrow_table(plots), targets_path(out): _arrow_table(targets)}
    for path, table in tables.items():
        if fmt == "csv":
            import pyarrow.csv as pcsv

            pcsv.write_csv(table, path)
        else:
            import pyarrow.parquet as pq

            pq.write_table(table, path)
    summary.update(plots=len(plots["plot_id"]), target_states=len(targets["time_s"]),
                   targets_out=str(targets_path(out)))
    return summary
