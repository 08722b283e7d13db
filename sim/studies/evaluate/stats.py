"""Means over runs with 95 % intervals, and paired differences between two trackers.

Runs are independent replications (one seed each), so a figure's mean over runs has the
Student-t interval ``mean ± t_{0.975, n-1} s / sqrt(n)``; a comparison pairs runs by seed
(the same plots went to both trackers) and takes the same interval on the per-seed
differences, which removes the scene-to-scene variation the two share. A figure undefined in
a run (NaN: no target was ever tracked, no latency measured) is left out of that figure's
runs, and ``n`` says how many were used.

Bounds: a figure bounded by its definition (a proportion in [0, 1], a count, a distance or a
time that cannot be negative, an ambiguity of at least 1) never gets an interval beyond its
bounds: the Student-t interval is clipped to them (:data:`BOUNDS`). Clipping keeps the
interval's coverage at least nominal (the true mean lies inside the bounds, so an interval
that held it still does) and only removes values the quantity cannot take; with few runs
and all values at a bound (0 swaps in every run) the interval is that bound alone, which
says "no spread seen", not "certain". A paired difference of two such figures is clipped to
``[lo - hi, hi - lo]``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from scipy import stats as _st

__all__ = ["BOUNDS", "CONFIDENCE", "RUN_METRICS", "TARGET_METRICS", "SCAN_METRICS", "by_key",
           "mean_interval", "paired_differences", "summarise"]

#: Confidence of every interval.
CONFIDENCE = 0.95

#: Per-run figures summarised over runs, in the report's order.
RUN_METRICS: tuple[str, ...] = (
    "gospa", "localisation", "missed", "false",
    "siap_completeness", "siap_ambiguity", "siap_spuriousness", "siap_position_accuracy_m",
    "siap_velocity_accuracy_mps", "siap_track_number_change_rate", "siap_longest_segment",
    "false_tracks_per_hour", "track_breaks", "identity_swaps",
    "latency_median_s", "latency_p95_s", "malformed_messages")
#: Per-target figures summarised over runs, per target.
TARGET_METRICS: tuple[str, ...] = (
    "held_fraction", "first_track_delay_s", "first_track_range_m", "track_breaks",
    "identity_swaps", "mean_error_m")
#: Per-scan figures summarised over runs, per scan.
SCAN_METRICS: tuple[str, ...] = ("gospa", "localisation", "missed", "false", "truths",
                                 "tracks", "completeness")


_INF = math.inf
_PROPORTION = (0.0, 1.0)
_NON_NEGATIVE = (0.0, _INF)

#: Each figure's bounds (low, high), by its name in the per-run, per-target and per-scan
#: rows; a figure not listed is unbounded.
BOUNDS: dict[str, tuple[float, float]] = {
    **dict.fromkeys(("siap_completeness", "siap_spuriousness", "siap_longest_segment",
                     "held_fraction", "completeness", "spuriousness"), _PROPORTION),
    "siap_ambiguity": (1.0, _INF),
    **dict.fromkeys(("gospa", "localisation", "missed", "false", "siap_position_accuracy_m",
                     "siap_velocity_accuracy_mps", "siap_track_number_change_rate",
                     "false_tracks", "false_tracks_per_hour", "track_breaks",
                     "identity_swaps", "latency_median_s", "latency_p95_s",
                     "malformed_messages", "first_track_delay_s", "first_track_range_m",
                     "mean_error_m",
                     "truths", "tracks", "scans_held", "track_ids"), _NON_NEGATIVE),
}


def mean_interval(values: Iterable[float | None], confidence: float = CONFIDENCE,
                  bounds: tuple[float, float] = (-_INF, _INF)
                  ) -> tuple[float, float, float, int]:
    """Mean and its two-sided Student-t interval over the finite values, clipped to
    ``bounds`` (module docstring).

    Returns
    -------
    (mean, low, high, n)
        NaN for an empty set; the interval is the mean itself for one value or no spread.
        ``None`` values (a metric a run could not give) are left out like non-finite ones.
    """
    x = np.asarray([v for v in values if v is not None], dtype=float)
    x = x[np.isfinite(x)]
    n = int(x.size)
    if n == 0:
        return math.nan, math.nan, math.nan, 0
    m = float(x.mean())
    if n == 1:
        return m, math.nan, math.nan, 1
    half = float(_st.t.ppf(0.5 + confidence / 2, n - 1) * x.std(ddof=1) / math.sqrt(n))
    lo, hi = bounds
    return m, min(max(m - half, lo), hi), max(min(m + half, hi), lo), n


def _difference_bounds(metric: str) -> tuple[float, float]:
    lo, hi = BOUNDS.get(metric, (-_INF, _INF))
    return lo - hi, hi - lo


def summarise(rows: Sequence[dict[str, Any]], metrics: Sequence[str] = RUN_METRICS
              ) -> list[dict[str, Any]]:
    """One row per metric: ``metric``, ``mean``, ``low``, ``high``, ``runs``."""
    out = []
    for k in metrics:
        m, lo, hi, n = mean_interval((r.get(k) for r in rows),
                                     bounds=BOUNDS.get(k, (-_INF, _INF)))
        out.append({"metric": k, "mean": m, "low": lo, "high": hi, "runs": n})
    return out


def by_key(rows: Sequence[dict[str, Any]], key: str, metrics: Sequence[str]
           ) -> list[dict[str, Any]]:
    """Per value of ``key`` (a scan, a target): each metric's mean and interval over runs."""
    groups: dict[Any, list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault(r[key], []).append(r)
    out = []
    for k in sorted(groups, key=lambda v: (str(type(v)), v)):
        row: dict[str, Any] = {key: k, "runs": len(groups[k])}
        for m in metrics:
            mean, lo, hi, _ = mean_interval((g.get(m) for g in groups[k]),
                                            bounds=BOUNDS.get(m, (-_INF, _INF)))
            row[m], row[f"{m}_low"], row[f"{m}_high"] = mean, lo, hi
        if key == "scan":
            row["t_s"] = groups[k][0].get("t_s")
        out.append(row)
    return out


def paired_differences(a: Sequence[dict[str, Any]], b: Sequence[dict[str, Any]],
                       metrics: Sequence[str] = RUN_METRICS) -> list[dict[str, Any]]:
    """B − A per metric on the seeds both scored: mean difference and its interval.

    Returns
    -------
    list of dict
        ``metric``, ``a``, ``b`` (means over the common seeds), ``difference``, ``low``,
        ``high``, ``runs`` (pairs used).
    """
    ra = {r["seed"]: r for r in a}
    rb = {r["seed"]: r for r in b}
    common = sorted(set(ra) & set(rb))
    out = []
    for k in metrics:
        raw = [(ra[s].get(k), rb[s].get(k)) for s in common]
        pairs = [(float(x), float(y)) for x, y in raw if x is not None and y is not None
                 and math.isfinite(x) and math.isfinite(y)]
        d, lo, hi, n = mean_interval((y - x for x, y in pairs),
                                     bounds=_difference_bounds(k))
        out.append({"metric": k,
                    "a": float(np.mean([x for x, _ in pairs])) if pairs else math.nan,
                    "b": float(np.mean([y for _, y in pairs])) if pairs else math.nan,
                    "difference": d, "low": lo, "high": hi, "runs": n})
    return out
