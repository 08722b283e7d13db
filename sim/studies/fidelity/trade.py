"""The trade study: every setting run, compared with the reference, timed in alternating
pairs, and the cheapest block inside the tolerances recommended (:func:`_recommend`).
"""

from __future__ import annotations

import math
import os
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from shipradar.sim.studies.fidelity.compare import (
    FA_REL_FLOOR,
    Comparison,
    Tolerances,
    compare,
    plot_latency_s,
)
from shipradar.sim.studies.fidelity.explain import explain
from shipradar.sim.studies.fidelity.plan import (
    Setting,
    diff_label,
    format_value,
    plan_settings,
    with_fidelity,
)
from shipradar.sim.studies.fidelity.runs import RunResult, TableClock, run_setting
from shipradar.sim.studies.timing import (
    SAVING_MIN,
    Interval,
    PairedCost,
    SampleTimer,
    SceneTimer,
    is_cheaper,
    mean_interval,
    paired_costs,
)
from shipradar.sim.world.scenario import Scenario

#: Table builds timed per distinct table with ``--cold`` (a Student-t interval needs two).
BUILD_REPEATS = 3
#: Alternating pairs per setting by default (reference and candidate, :mod:`.timing`).
DEFAULT_PAIRS = 8
#: What the recommendation can minimise: the CPU of every run of a Monte Carlo study after
#: the first (``per-run``), or of one ``shipradar run`` (``first-run``: table load + run).
OBJECTIVES = ("per-run", "first-run")


@dataclass
class Cost:
    """A setting's measured cost: the paired timing against the reference, and its tables'
    build (measured with an interval by ``--cold``, else the cost model's estimate)."""

    paired: PairedCost | None
    build: Interval | None = None
    build_estimate_s: float = 0.0


@dataclass
class Study:
    """Everything the command measured."""

    scenario: Scenario
    reference: dict[str, Any]
    comparisons: list[Comparison]
    skipped: list[tuple[str, str]]
    recommended: dict[str, Any]
    recommended_comparison: Comparison | None
    tolerances: Tolerances
    duration_s: float
    seeds: list[int]
    wall_s: float = 0.0
    notes: list[str] = field(default_factory=list)
    objective: str = "per-run"
    pairs: int = DEFAULT_PAIRS
    costs: dict[str, Cost] = field(default_factory=dict)  # by setting label
    recommended_cost: PairedCost | None = None
    unread: tuple[str, ...] = ()
    undecided: list[str] = field(default_factory=list)
    builds_measured: bool = False

    @property
    def shortened(self) -> bool:
        """The study simulated less than the scene's own duration."""
        return self.duration_s < self.scenario.duration_s * (1 - 1e-12)

    def cost(self, c: Comparison) -> Cost | None:
        return self.costs.get(c.result.setting.label)

    def ratio(self, c: Comparison) -> Interval | None:
        """The setting's cost over the reference's, as the objective reads it."""
        cost = self.cost(c)
        if cost is None or cost.paired is None:
            return None
        return cost.paired.ratio(self.objective)


def run_fidelity_study(scenario: Scenario, *, duration_s: float | None = None, runs: int = 1,
                       tolerances: Tolerances | None = None, include_unexercised: bool = False,
                       log=None, pairs: int = DEFAULT_PAIRS, objective: str = "per-run",
                       timer: SampleTimer | None = None, measure_builds: bool = False) -> Study:
    """Run the reference and every alternative, compare them, time them, recommend a setting.

    Parameters
    ----------
    scenario : Scenario
        The scene.
    duration_s : float, optional
        Simulated duration of each run [s]; default the scenario's.
    runs : int
        Replications for the accuracy (seeds spawned from the scenario's seed, as
        ``shipradar montecarlo``).
    tolerances : Tolerances, optional
        The limits of the recommendation (default :class:`Tolerances`'s).
    include_unexercised : bool
        Also run choices the scene does not exercise.
    log : file-like, optional
        Progress lines.
    pairs : int
        Alternating timing pairs per setting (:func:`shipradar.sim.studies.timing.paired_costs`).
    objective : str
        ``per-run`` (warm run CPU, a Monte Carlo study's replications) or ``first-run``
        (table load + first run of a process).
    timer : SampleTimer, optional
        Times one setting once; default :class:`shipradar.sim.studies.timing.SceneTimer`
        (tests pass a cost model).
    measure_builds : bool
        Build every distinct table :data:`BUILD_REPEATS` times in a private empty cache and
        report the build with its interval (else the cost model's estimate).

    Returns
    -------
    Study
    """
    from shipradar.sim.studies.montecarlo import run_seed

    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
    t0 = time.perf_counter()
    tolerances = Tolerances() if tolerances is None else tolerances
    duration = float(scenario.duration_s if duration_s is None else duration_s)
    seeds = [run_seed(c) for c in np.random.SeedSequence(scenario.seed).spawn(runs)]
    if tolerances.latency_s is None:
        tolerances = Tolerances(tolerances.pd, tolerances.range_m, tolerances.fa_rel,
                                plot_latency_s(scenario, scenario.fidelity.model_dump()))
    ref_fid, settings, skipped = plan_settings(scenario,
                                               include_unexercised=include_unexercised)
    clock = TableClock()

    def say(msg: str) -> None:
        if log is not None:
            print(msg, file=log, flush=True)

    # accuracy: every setting once per seed, common random numbers (this also fills the
    # table cache, so that the timing below reads every table from it)
    results: dict[str, RunResult] = {}
    for s in settings:
        say(f"fidelity: running {s.label} ...")
        results[s.label] = run_setting(scenario, s, seeds, duration, clock)
    ref = results["reference"]
    comps = [compare(ref, results[s.label], scenario, tolerances) for s in settings]
    # cost: every setting against the reference, in alternation
    timer = timer if timer is not None else SceneTimer(
        lambda fid: with_fidelity(scenario, fid), duration)
    others = settings[1:]
    paired = paired_costs(timer, ref_fid, [s.fidelity for s in others], seeds, pairs,
                          log=say)
    builds = _build_costs(scenario, settings, measure_builds, say)
    costs = {s.label: Cost(p, *builds[s.label]) for s, p in zip(others, paired, strict=True)}
    costs["reference"] = Cost(None, *builds["reference"])
    study = Study(scenario, ref_fid, comps, skipped, dict(ref_fid), comps[0], tolerances,
                  duration, seeds, objective=objective, pairs=pairs, costs=costs,
                  builds_measured=measure_builds)
    _recommend(study, timer, clock, results, say)
    study.wall_s = time.perf_counter() - t0
    return study


def _build_costs(scenario: Scenario, settings: Sequence[Setting], measure: bool,
                 say: Callable[[str], None]) -> dict[str, tuple[Interval | None, float]]:
    """Each setting's table build: (measured interval or None, the cost model's estimate).

    Measured: every distinct table built :data:`BUILD_REPEATS` times in a private empty
    cache (CPU seconds), after one untimed build of the first table of each kind (its
    module's imports and lazy set-up, paid once per process, would otherwise swamp the
    spread); a setting's build is the sum over its tables (intervals added in quadrature:
    the builds are independent; the lower end floored at 0). Estimated:
    :func:`shipradar.tables.budget.estimate_build` (the cost model of docs/stability.md),
    every table counted as missing.
    """
    from shipradar.tables.budget import estimate_build
    from shipradar.tables.scene import table_specs
    from shipradar.tables.store import cache_path, inputs_hash

    out: dict[str, tuple[Interval | None, float]] = {}
    per_table: dict[str, Interval] = {}
    kinds: set[str] = set()
    tmp = tempfile.TemporaryDirectory(prefix="shipradar-fidelity-build-") if measure else None
    old = os.environ.get("SHIPRADAR_TABLES")
    try:
        for s in settings:
            scene = with_fidelity(scenario, s.fidelity)
            est = sum(e.seconds for e in estimate_build(scene, include_pd=False))
            if tmp is None:
                out[s.label] = (None, est)
                continue
            os.environ["SHIPRADAR_TABLES"] = tmp.name
            parts: list[Interval] = []
            seen: set[str] = set()
            for spec in table_specs(scene):
                name, version, inputs = spec.key()
                key = inputs_hash(name, version, inputs)
                if key in seen:
                    continue
                seen.add(key)
                if key not in per_table:
                    say(f"fidelity: building {spec.radar_id} {spec.kind} "
                        f"({BUILD_REPEATS} times) ...")
                    if spec.kind not in kinds:  # its module's imports and lazy set-up, once
                        kinds.add(spec.kind)
                        cache_path(name, key).unlink(missing_ok=True)
                        spec.make()
                    samples = []
                    for _ in range(BUILD_REPEATS):
                        cache_path(name, key).unlink(missing_ok=True)
                        c0 = time.process_time()
                        spec.make()
                        samples.append(time.process_time() - c0)
                    per_table[key] = mean_interval(samples)
                parts.append(per_table[key])
            total = sum(p.value for p in parts)
            half = math.sqrt(sum((p.high - p.value) ** 2 for p in parts))
            out[s.label] = (Interval(total, max(total - half, 0.0), total + half,
                                     BUILD_REPEATS), est)
    finally:
        if tmp is not None:
            if old is None:
                os.environ.pop("SHIPRADAR_TABLES", None)
            else:
                os.environ["SHIPRADAR_TABLES"] = old
            tmp.cleanup()
    return out


def unread_choices(scenario: Scenario, fid: dict[str, Any]) -> tuple[str, ...]:
    """The grid and model choices a scene under ``fid`` never reads (``pe_grid`` beside
    ``propagation: two_ray``, ``improvement_grid`` without a processor or clutter, ...)."""
    parts = explain(with_fidelity(scenario, fid))
    out = []
    for choice in ("pe_grid", "improvement_grid", "clutter_fa_model"):
        rel = [p for p in parts if p.choice == choice]
        if not any(p.exercised for p in rel):
            out.append(choice)
    return tuple(out)


def _recommend(study: Study, timer: SampleTimer, clock: TableClock,
               results: dict[str, RunResult], say: Callable[[str], None]) -> None:
    """Pick each choice's value, then check the combination as a whole (accuracy and cost).

    A value is a candidate when it is inside the tolerances and *measured* cheaper than
    the reference (:func:`shipradar.sim.studies.timing.is_cheaper` on the objective's
    ratio); of several, the most accurate one, unless a less accurate one's whole interval
    lies below it. A choice the picks make unread (``pe_grid`` once ``propagation`` leaves
    ``pe``) is dropped. The combination is then run against the reference for accuracy
    (common random numbers) and timed again in fresh alternating pairs: outside a tolerance,
    the change with the largest error of its own goes back to the reference value; not
    measured cheaper, the change with the smallest saving of its own goes back. The
    saving printed is the last timing's, of the block as printed.
    """
    ref_fid, tol, obj = study.reference, study.tolerances, study.objective
    scenario = study.scenario
    pick: dict[str, Comparison] = {}
    for c in study.comparisons:
        s = c.result.setting
        ratio = study.ratio(c)
        if s.kind != "alternative" or s.choice is None or not c.ok or ratio is None:
            continue
        if not is_cheaper(ratio):
            if ratio.n >= 2 and ratio.low < 1.0 - SAVING_MIN:
                study.undecided.append(f"{s.label} {ratio.fmt()}")
            continue
        best = pick.get(s.choice)
        if best is None:
            pick[s.choice] = c
            continue
        b_ratio = study.ratio(best)
        assert b_ratio is not None
        more_accurate = error_score(c, tol) < error_score(best, tol)
        if (more_accurate and not ratio.low > b_ratio.high) or ratio.high < b_ratio.low:
            pick[s.choice] = c
    candidate = {**ref_fid, **{k: v.result.setting.value for k, v in pick.items()}}

    def back(choice: str, note: str) -> None:
        """``choice`` back to the reference value, ``note`` saying why."""
        study.notes.append(note)
        candidate[choice] = ref_fid[choice]
        del pick[choice]

    for choice in unread_choices(scenario, candidate):
        if choice in pick:
            back(choice, f"{choice} dropped: not read with {diff_label(candidate, ref_fid)}")
    ref = results["reference"]
    while pick:
        label = diff_label(candidate, ref_fid)
        comp = next((c for c in study.comparisons if c.result.setting.fidelity == candidate),
                    None)
        if comp is None:
            say(f"fidelity: running the combination {label} ...")
            s = Setting("recommended", None, None, dict(candidate), True, "combined")
            comp = compare(ref, run_setting(scenario, s, study.seeds, study.duration_s, clock),
                           scenario, tol)
            study.comparisons.append(comp)
        if not comp.ok:
            worst = max(pick, key=lambda k: error_score(pick[k], tol))
            back(worst, f"the combination {label} was outside the tolerances "
                        f"({'; '.join(comp.violations[:3])}); {worst} back to "
                        f"{format_value(ref_fid[worst])}")
            continue
        say(f"fidelity: timing the block {label} against the reference ...")
        (cost,) = paired_costs(timer, ref_fid, [candidate], study.seeds, study.pairs)
        ratio = cost.ratio(obj)
        if not is_cheaper(ratio):
            least = max(pick, key=lambda k: _ratio_value(study, pick[k]))
            back(least, f"the block {label} re-timed as a whole: {obj} CPU {ratio.fmt()}x "
                        f"the reference's, not measurably cheaper; {least} back to "
                        f"{format_value(ref_fid[least])}")
            continue
        study.recommended = dict(candidate)
        study.recommended_comparison = comp
        study.recommended_cost = cost
        break
    else:
        study.recommended = dict(ref_fid)
        study.recommended_comparison = study.comparisons[0]
    study.unread = unread_choices(scenario, study.recommended)


def _ratio_value(study: Study, c: Comparison) -> float:
    r = study.ratio(c)
    return math.inf if r is None else r.value


def error_score(c: Comparison, tol: Tolerances) -> float:
    """Largest error of a setting as a fraction of its tolerance."""
    t = c.total
    score = t["worst_target_mean_abs_dpd"] / max(tol.pd, 1e-12)
    score = max(score, t["max_abs_dfirst_m"] / max(tol.range_m, 1e-12))
    for k, e in t["expected_fa"].items():
        e_ref = t["expected_fa_ref"][k]
        score = max(score, abs(e - e_ref) / max(tol.fa_rel * max(e_ref, FA_REL_FLOOR), 1e-12))
    return score
