"""A block of plots as the engine assembles it: batches (targets, noise and sea-clutter false
alarms) merged in the order they are sent, and a revolution's rows sliced out of it.

The columns and their dtypes are the schema's (:mod:`shipradar.sim.stream.schema`); which plots
go in which message is :func:`shipradar.sim.stream.framing.sector_columns`'.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from shipradar.sim.stream.schema import (
    PLOT_COLUMNS,
    PLOT_TRUTH_COLUMNS,
    TRUTH_PLOTS,
    empty_plots,
)

__all__ = ["ABSENT", "PLOT_DTYPES", "merge_plot_batches", "slice_plots"]

#: Every per-plot column the engine carries, with its dtype (the schema's).
PLOT_DTYPES: dict[str, np.dtype] = {c: a.dtype for c, a in empty_plots().items()
                                    if c in PLOT_COLUMNS or c in PLOT_TRUTH_COLUMNS}
#: The value of a truth column in a batch that has none (false alarms: no ``target``, -1).
ABSENT: dict[str, float] = {"target": -1, "true_range_m": np.nan, "true_azimuth_rad": np.nan,
                            "true_range_rate_mps": np.nan}
_CONTRIB_DTYPES = (TRUTH_PLOTS["contrib_offsets"].dtype, TRUTH_PLOTS["contrib_targets"].dtype)


def merge_plot_batches(parts: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    """Concatenate plot batches (targets, noise and clutter false alarms) sorted by
    revolution and by time within each (every batch carries the ``revolution`` index of each
    plot, kept in the result); ties keep the batches' order.

    Each batch may carry the targets merged into each plot as ``contrib_offsets`` (one more
    than its plots) and ``contrib_targets``; batches without them have no contributors, nor a
    ``target`` (-1).  The columns and their dtypes are the schema's
    (:mod:`shipradar.sim.stream.schema`); no batch gives an empty block of plots.
    """
    if not parts:
        parts = [{**empty_plots(), "revolution": np.zeros(0, dtype=np.int64)}]
    sizes = [p["range_m"].size for p in parts]
    first = np.cumsum([0, *sizes])
    time_s = np.concatenate([p["time_s"] for p in parts])
    order = np.argsort(time_s)  # introsort: a stable sort only when two times are equal
    t_sorted = time_s.take(order)
    if np.any(t_sorted[1:] == t_sorted[:-1]):
        order = np.argsort(time_s, kind="stable")
        t_sorted = time_s.take(order)
    rev = np.concatenate([p["revolution"] for p in parts])
    rev_sorted = rev.take(order)
    if np.any(rev_sorted[1:] < rev_sorted[:-1]):
        # a plot a hair before its revolution's start (a target crossing the start
        # azimuth) sorts before the previous revolution's last plots: by revolution first
        order = np.lexsort((time_s, rev))
        t_sorted, rev_sorted = time_s.take(order), rev.take(order)
    # every other column gathered through one buffer per dtype (not a new array per
    # concatenation); the schema's dtypes whatever a batch's (as astype)
    out = {}
    buffers: dict[np.dtype, np.ndarray] = {}
    for c, dtype in PLOT_DTYPES.items():
        if c == "time_s":
            out[c] = t_sorted.astype(dtype, copy=False)
            continue
        buf = buffers.get(dtype)
        if buf is None:
            buf = buffers[dtype] = np.empty(time_s.size, dtype)
        np.concatenate([p[c] if c in p else np.full(p["range_m"].size, ABSENT[c], dtype)
                        for p in parts], out=buf, casting="unsafe")
        out[c] = buf.take(order)
    out["revolution"] = rev_sorted
    # contributors: only some batches have them (the targets'); the others count none
    counts = np.zeros(time_s.size, dtype=np.int64)
    starts = np.zeros(time_s.size, dtype=np.int64)
    pool, base = [], 0
    for p, a, b in zip(parts, first[:-1], first[1:], strict=True):
        off = p.get("contrib_offsets")
        if off is None:
            continue
        starts[a:b] = off[:-1] + base
        counts[a:b] = np.diff(off)
        pool.append(p["contrib_targets"])
        base += p["contrib_targets"].size
    c_sorted = counts[order]
    new_off = np.concatenate([[0], np.cumsum(c_sorted)]).astype(_CONTRIB_DTYPES[0])
    if base:
        s_sorted = starts[order]
        gather = np.repeat(s_sorted, c_sorted) + (np.arange(new_off[-1])
                                                  - np.repeat(new_off[:-1], c_sorted))
        contrib = np.concatenate(pool)[gather].astype(_CONTRIB_DTYPES[1])
    else:
        contrib = np.zeros(0, dtype=_CONTRIB_DTYPES[1])
    out.update(contrib_offsets=new_off, contrib_targets=contrib)
    return out


def slice_plots(part: dict[str, np.ndarray], i0: int, i1: int) -> dict[str, np.ndarray]:
    """Plots ``i0:i1`` of a batch, with their contributors."""
    off = part["contrib_offsets"]
    out = {c: part[c][i0:i1] for c in (*PLOT_COLUMNS, *PLOT_TRUTH_COLUMNS)}
    out["contrib_offsets"] = off[i0:i1 + 1] - off[i0]
    out["contrib_targets"] = part["contrib_targets"][off[i0]:off[i1]]
    return out
