"""One setting against the reference: the looks aligned, per (radar, target) differences
in P_d and first-detection range, the expected false alarms, the latency, and the
tolerances they are held to.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from shipradar.sim.studies.fidelity.runs import RunResult
from shipradar.sim.world.scenario import Scenario

#: The false-alarm tolerance is relative to at least this many per scan [1/scan], so that a
#: radar expecting almost none is not held to a fraction of a false alarm.
FA_REL_FLOOR = 5.0
#: Below this probability of any detection a target counts as never detected.
P_DETECTED_MIN = 0.05


@dataclass
class Comparison:
    """One setting against the reference: per (radar, target) rows and the totals."""

    result: RunResult
    rows: list[dict[str, Any]]
    total: dict[str, Any]
    violations: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.violations


def _look_key(looks: dict[str, np.ndarray], n_targets: int) -> np.ndarray:
    n_r = int(looks["radar"].max()) + 1 if looks["radar"].size else 1
    return (((looks["run"] * n_r + looks["radar"]) * max(n_targets, 1) + looks["target"])
            * (1 << 32) + looks["scan"])


def compare(ref: RunResult, res: RunResult, scenario: Scenario, tol: Tolerances) -> Comparison:
    """Differences of ``res`` from ``ref`` (same looks, common random numbers).

    Steps: the two runs' looks aligned (:func:`_align_looks`); one row per (radar, target)
    (:func:`_target_row`) checked against the P_d and range tolerances; the expected false
    alarms per scan (:func:`_false_alarm_changes`); the latency; the totals
    (:func:`_totals`).
    """
    radar_ids = [r.id for _, r in scenario.radars()]
    target_ids = [t.id for t in scenario.targets]
    A, B = _align_looks(ref.looks, res.looks, len(target_ids))
    dpd = np.abs(B["pd"] - A["pd"])
    runs = int(A["run"].max()) + 1 if A["run"].size else 1
    order = np.lexsort((A["scan"], A["target"], A["radar"], A["run"]))
    rows: list[dict[str, Any]] = []
    violations: list[str] = []
    for ri, rid in enumerate(radar_ids):
        for ti, tid in enumerate(target_ids):
            sel = order[(A["radar"][order] == ri) & (A["target"][order] == ti)]
            if sel.size == 0:
                continue
            row = _target_row(A, B, dpd, sel, runs, rid, tid)
            violations += _target_violations(row, tol)
            rows.append(row)
    fa_rows, fa_violations = _false_alarm_changes(ref, res, tol)
    violations += fa_violations
    latency = plot_latency_s(scenario, res.setting.fidelity)
    if tol.latency_s is not None and latency > tol.latency_s * (1 + 1e-9):
        violations.append(f"latency {latency:.3g} s (one sector) > {tol.latency_s:.3g} s")
    if res.error:
        violations.append(res.error)
    return Comparison(res, rows, _totals(rows, dpd, runs, fa_rows, res, latency), violations)


def _align_looks(a: dict[str, np.ndarray], b: dict[str, np.ndarray], n_targets: int
                 ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """The looks of two runs side by side: those both have, then those only the first has,
    then those only the second has. The looks depend on the kinematics alone; a look only
    one side has is compared with P_d = 0 (not seen) on the other (:func:`_blank`), and its
    identity (run, radar, target, scan, range) is taken from whichever side has it."""
    ka, kb = _look_key(a, n_targets), _look_key(b, n_targets)
    _, ia, ib = np.intersect1d(ka, kb, assume_unique=False, return_indices=True)
    only_a = np.setdiff1d(np.arange(ka.size), ia)
    only_b = np.setdiff1d(np.arange(kb.size), ib)
    A = {k: np.concatenate([a[k][ia], a[k][only_a], _blank(b, only_b, k)]) for k in a}
    B = {k: np.concatenate([b[k][ib], _blank(a, only_a, k), b[k][only_b]]) for k in b}
    for k in ("run", "radar", "target", "scan", "range_m"):
        B[k] = A[k] = np.concatenate([a[k][ia], a[k][only_a], b[k][only_b]])
    return A, B


def _target_row(A: dict[str, np.ndarray], B: dict[str, np.ndarray], dpd: np.ndarray,
                sel: np.ndarray, runs: int, rid: str, tid: str) -> dict[str, Any]:
    """One (radar, target)'s differences over its looks ``sel`` (in run and scan order)."""
    # realized (common random numbers): the first look whose uniform fell below P_d
    d_real: list[float] = []
    first_a_all: list[float | None] = []
    first_b_all: list[float | None] = []
    for run in range(runs):
        s = sel[A["run"][sel] == run]
        fa_, fb_ = _first_range(A, s), _first_range(B, s)
        first_a_all.append(fa_)
        first_b_all.append(fb_)
        if fa_ is None and fb_ is None:
            continue
        d_real.append(math.inf if fa_ is None or fb_ is None else fb_ - fa_)
    # expected (dice-free, what the tolerance reads): P_d is a function of the look
    # alone, so run 0's looks give it
    s0 = sel[A["run"][sel] == 0]
    ea, pa = expected_first_range(A["pd"][s0], A["range_m"][s0])
    eb, pb = expected_first_range(B["pd"][s0], B["range_m"][s0])
    if ea is None and eb is None:
        d_exp = 0.0
    elif ea is None or eb is None:
        d_exp = math.inf
    else:
        d_exp = abs(eb - ea)
    detections_ref = int(A["hit"][sel].sum()) / runs
    detections = int(B["hit"][sel].sum()) / runs
    expected_ref = float(A["pd"][s0].sum())
    expected = float(B["pd"][s0].sum())
    return {
        "radar": rid, "target": tid, "looks": int(sel.size) // runs,
        "mean_abs_dpd": float(dpd[sel].mean()),
        "max_abs_dpd": float(dpd[sel].max()),
        "mean_pd_ref": float(A["pd"][sel].mean()),
        "mean_pd": float(B["pd"][sel].mean()),
        "expected_detections_ref": expected_ref,
        "expected_detections": expected,
        "detections_ref": detections_ref,
        "detections": detections,
        "p_detected_ref": pa, "p_detected": pb,
        "expected_first_range_ref_m": ea, "expected_first_range_m": eb,
        "abs_dfirst_m": d_exp,
        "first_range_ref_m": _mean_or_none(first_a_all),
        "first_range_m": _mean_or_none(first_b_all),
        "realized_abs_dfirst_m": (float(np.mean(np.abs(d_real))) if d_real else 0.0),
        "d_detections": detections - detections_ref,
        "d_expected_detections": expected - expected_ref,
    }


def _target_violations(row: dict[str, Any], tol: Tolerances) -> list[str]:
    """A (radar, target) row outside the P_d or the first-detection range tolerance."""
    who = f"{row['radar']}/{row['target']}"
    out = []
    if row["mean_abs_dpd"] > tol.pd:
        out.append(f"{who}: mean |ΔP_d| {row['mean_abs_dpd']:.3g} > {tol.pd:g}")
    if row["abs_dfirst_m"] > tol.range_m:
        out.append(f"{who}: |Δ expected first-detection range| "
                   f"{format_range_m(row['abs_dfirst_m'])} > {tol.range_m:g} m")
    return out


def _false_alarm_changes(ref: RunResult, res: RunResult, tol: Tolerances
                         ) -> tuple[dict[tuple[str, str], tuple[float, float]], list[str]]:
    """The model's expected false alarms per scan of each radar and origin, (reference,
    setting), and those outside the tolerance (relative, at least :data:`FA_REL_FLOOR`)."""
    fa_rows: dict[tuple[str, str], tuple[float, float]] = {}
    violations = []
    for (rid, origin), e_ref in ref.expected_fa.items():
        e = res.expected_fa.get((rid, origin), 0.0)
        fa_rows[(rid, origin)] = (e_ref, e)
        if abs(e - e_ref) > tol.fa_rel * max(e_ref, FA_REL_FLOOR):
            violations.append(f"{rid}: expected {origin.replace('_', '-')} false alarms per scan "
                              f"{e:.4g} vs {e_ref:.4g} (tolerance {tol.fa_rel:.0%})")
    return fa_rows, violations


def _totals(rows: list[dict[str, Any]], dpd: np.ndarray, runs: int,
            fa_rows: dict[tuple[str, str], tuple[float, float]], res: RunResult,
            latency: float) -> dict[str, Any]:
    """The setting's totals over every (radar, target) and look; ``zero`` when nothing at
    all differs from the reference."""
    return {
        "looks": int(dpd.size) // max(runs, 1),
        "mean_abs_dpd": float(dpd.mean()) if dpd.size else 0.0,
        "max_abs_dpd": float(dpd.max()) if dpd.size else 0.0,
        "worst_target_mean_abs_dpd": max((r["mean_abs_dpd"] for r in rows), default=0.0),
        "d_detections": sum(r["d_detections"] for r in rows),
        "detections": sum(r["detections"] for r in rows),
        "d_expected_detections": sum(r["d_expected_detections"] for r in rows),
        "max_abs_dfirst_m": max((r["abs_dfirst_m"] for r in rows), default=0.0),
        "max_realized_abs_dfirst_m": max((r["realized_abs_dfirst_m"] for r in rows),
                                         default=0.0),
        "expected_fa": {f"{rid}:{o}": v[1] for (rid, o), v in fa_rows.items()},
        "expected_fa_ref": {f"{rid}:{o}": v[0] for (rid, o), v in fa_rows.items()},
        "noise_fa_per_scan": sum(v[1] for (rid, o), v in fa_rows.items() if o == "noise"),
        "clutter_fa_per_scan": sum(v[1] for (rid, o), v in fa_rows.items()
                                   if o == "sea_clutter"),
        "drawn_noise_fa_per_scan": res.drawn_fa["noise"],
        "drawn_clutter_fa_per_scan": res.drawn_fa["sea_clutter"],
        "latency_s": latency,
        "zero": bool(dpd.size == 0 or dpd.max() == 0.0) and all(
            r["d_detections"] == 0 and r["abs_dfirst_m"] == 0
            and r["realized_abs_dfirst_m"] == 0 for r in rows) and all(
            v[0] == v[1] for v in fa_rows.values()),
    }


def _blank(d: dict[str, np.ndarray], idx: np.ndarray, k: str) -> np.ndarray:
    """Stand-in values of looks missing on one side (P_d 0, not detected)."""
    if k == "pd":
        return np.zeros(idx.size)
    if k == "hit":
        return np.zeros(idx.size, dtype=bool)
    return d[k][idx]


def expected_first_range(pd: np.ndarray, range_m: np.ndarray
                          ) -> tuple[float | None, float]:
    """Expected range of the first detection of a target from its looks' P_d, in look order.

    P(first detection at look i) = p_i Π_{j<i} (1 - p_j) (independent looks); the range is
    the mean over those probabilities, conditioned on a detection at all.

    Returns
    -------
    range_m : float or None
        E[R_1 | detected] [m]; None when the target is detected with probability below
        :data:`P_DETECTED_MIN` (never, in practice).
    p_detected : float
        Probability of at least one detection [-].
    """
    pd = np.clip(np.asarray(pd, dtype=float), 0.0, 1.0)
    before = np.concatenate([[1.0], np.cumprod(1.0 - pd)[:-1]])
    first = pd * before
    p_any = float(first.sum())
    if p_any < P_DETECTED_MIN:
        return None, p_any
    return float((first * range_m).sum() / p_any), p_any


def _first_range(d: dict[str, np.ndarray], sel: np.ndarray) -> float | None:
    hits = sel[d["hit"][sel]]
    return None if hits.size == 0 else float(d["range_m"][hits[0]])


def _mean_or_none(values: list[float | None]) -> float | None:
    v = [x for x in values if x is not None]
    return float(np.mean(v)) if v else None


def format_range_m(x: float) -> str:
    return "never/always" if math.isinf(x) else f"{x:.0f} m"


def plot_latency_s(scenario: Scenario, fid: dict[str, Any]) -> float:
    """Longest delay a plot waits for the end of its sector [s]: one sector."""
    return max(r.scan_period_s for _, r in scenario.radars()) / fid["sectors_per_scan"]


@dataclass(frozen=True)
class Tolerances:
    """What the recommendation must stay within (see the module docstring)."""

    pd: float = 0.02
    range_m: float = 500.0
    fa_rel: float = 0.1
    latency_s: float | None = None
