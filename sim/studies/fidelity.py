"""``shipradar fidelity``: the speed/accuracy trade measured on the user's own scene (issue 18).

The scene is run under each fidelity choice that applies to it (``fidelity:`` in the scenario,
:class:`shipradar.sim.world.scenario.Fidelity`) and compared with the most accurate setting, the
*reference*, with **common random numbers**: every look (one radar, one target, one scan) gets one
uniform number derived from (run seed, radar, target, scan) alone, and is detected when it is below
that look's P_d (the dwell model's opt-in ``look_uniforms``, which a normal run leaves at
None); each look's P_d is read by an observer of the model's looks (``on_look``,
:class:`shipradar.sim.dwell.look.LookResults`). Two settings therefore differ only where their
P_d differ: the reference against itself gives exactly zero, and a change that the scene never
reads gives exactly zero too.

What is measured per setting, per (radar, target) and in total
---------------------------------------------------------------
* mean |ΔP_d| per look and its maximum (P_d of the same look under both settings);
* the change in detections: expected (Σ P_d over the looks, dice-free) and realized (looks
  whose uniform falls below P_d);
* the change in first-detection range [m]: expected, E[R_1 | detected] with
  P(first at look i) = p_i Π_{j<i}(1 - p_j) over the looks in order (slant range), and
  realized (the first detected look; it moves by a whole scan when one look's outcome
  flips, 1.5 km for a Mach-0.9 target and a 5 s scan, so the tolerance reads the expected);
* false alarms per scan by origin: the model's expected count per scan (noise: cells × P_fa
  [90]; sea clutter: Σ η of the P_fac map, seed 7.2), exact and dice-free, and the counts the
  run drew;
* the cost, as a user pays it (:mod:`shipradar.sim.studies.timing`): the run's CPU, warm
  (a Monte Carlo study's later replications) and first (table load + the first run of a
  process), each as the ratio to the reference's over alternating pairs with its interval;
  the table load [s] per process and the table build [s] per cache (measured with
  ``--cold``, else the cost model's estimate).

Tolerances (the recommendation keeps every (radar, target) inside all of them): mean |ΔP_d|
per look ≤ ``--tolerance-pd``; |Δ expected first-detection range| ≤ ``--tolerance-range-m``,
and a target detected (probability ≥ 5 %) under one setting but not the other is outside;
expected false alarms per scan of each radar and origin within ``--tolerance-fa``
(relative to the reference's count, or to 5 per scan if fewer); the latency added by fewer
sectors per scan (one sector, the scan period over ``sectors_per_scan``) ≤
``--max-latency-s`` (default: the scene's own).

Recommendation (:func:`_recommend`): it minimises one stated cost, ``--optimise per-run``
(default) or ``first-run``. A value is taken only when it is inside the tolerances and its
cost ratio's whole interval lies below 1 - :data:`shipradar.sim.studies.timing.SAVING_MIN`;
the combination is then run as a whole, for accuracy and, in fresh alternating pairs, for
cost, and changes go back to the reference until both hold. Choices the block makes unread
(``pe_grid`` beside ``propagation: two_ray``) are left out of it. A study shortened with
``--duration`` says that its recommendation holds for the simulated span only, and
``--apply`` refuses it unless ``--allow-shortened``.

The parts of the model a scene exercises, and those it skips with the reason, are
:func:`explain` (also ``shipradar validate --explain``).
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import sys
import tempfile
import time
import typing
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from shipradar.sim.dwell.look import LookObserver, LookResults
from shipradar.sim.studies.timing import (
    CONFIDENCE,
    SAVING_MIN,
    Interval,
    PairedCost,
    SampleTimer,
    SceneTimer,
    is_cheaper,
    mean_interval,
    paired_costs,
)
from shipradar.sim.world.scenario import Fidelity, Jammer, Radar, Scenario, ScenarioError, Target

__all__ = [
    "Part",
    "Setting",
    "apply_fidelity",
    "cli_main",
    "explain",
    "explain_lines",
    "look_uniforms",
    "plan_settings",
    "run_fidelity_study",
]

#: Choices of ``fidelity:`` the command varies, in report order.
CHOICES = ("pd_method", "propagation", "pe_grid", "improvement_grid", "clutter_fa_model",
           "clutter", "atmosphere", "sectors_per_scan")
#: Sectors per scan tried below the scene's own (cost only: the model is unchanged).
SECTOR_CHOICES = (4, 12, 36)
#: The false-alarm tolerance is relative to at least this many per scan [1/scan], so that a
#: radar expecting almost none is not held to a fraction of a false alarm.
FA_REL_FLOOR = 5.0
#: Below this probability of any detection a target counts as never detected.
P_DETECTED_MIN = 0.05
#: Margin of the engine's beam-crossing search (shipradar.sim.engine.simulation._CROSSING_EPS_S)
#: [s]: a revolution owns crossings in [start - ε, end - ε).
_CROSSING_EPS_S = 1e-6


# =========================================================================== explain
@dataclass(frozen=True)
class Part:
    """One part of the radar model and whether the scene exercises it.

    Attributes
    ----------
    name : str
        The part (e.g. ``"weather clutter [39]-[45]"``).
    exercised : bool
        True when the scene reads it.
    reason : str
        Why it is exercised or skipped.
    radar : str or None
        The radar it concerns, None for the whole scene.
    choice : str or None
        The ``fidelity`` choice it makes relevant, if any.
    """

    name: str
    exercised: bool
    reason: str
    radar: str | None = None
    choice: str | None = None


def explain(scenario: Scenario) -> list[Part]:
    """The parts of the model the scene exercises and those it skips, each with its reason.

    Decided from the scenario alone (nothing is run): no rain, no weather clutter; no jammer,
    no jamming; a low-resolution radar, no sea-clutter false alarms; targets above the PE
    table's top, the two-ray model for them; and so on.

    Parameters
    ----------
    scenario : Scenario
        The validated scene.

    Returns
    -------
    list of Part
        The targets' parts, propagation, atmosphere, jamming, then each radar's parts.
    """
    out = _target_parts(scenario)
    out += _propagation_parts(scenario)
    out.append(_atmosphere_part(scenario))
    n_j = len(scenario.jammers)
    out.append(Part("stand-off jamming [47]-[48]", n_j > 0,
                    f"{n_j} jammer(s)" if n_j else "no jammer: S/J not computed"))
    for _platform, radar in scenario.radars():
        out += _radar_parts(scenario, radar)
    return out


def _movers(scenario: Scenario) -> list[Target | Jammer]:
    """The scene's targets and jammers (what propagation and the atmosphere are read for)."""
    return [*scenario.targets, *scenario.jammers]


def _target_parts(scenario: Scenario) -> list[Part]:
    """The echo, S/I and P_d chain, and unresolved targets."""
    n_t = len(scenario.targets)
    name = "target echo, S/I and P_d [2]-[3], [66]-[83]"
    if n_t:
        cases = sorted({t.swerling_case for t in scenario.targets})
        echo = Part(name, True, f"{n_t} target(s), Swerling {cases}; P_d method "
                                f"{scenario.fidelity.pd_method!r}", choice="pd_method")
    else:
        echo = Part(name, False, "no targets: only false alarms are drawn", choice="pd_method")
    merge = Part("unresolved targets (2.2.1)", n_t > 1,
                 f"{n_t} targets may share a cell" if n_t > 1 else
                 "fewer than two targets: nothing to merge")
    return [echo, merge]


def _propagation_parts(scenario: Scenario) -> list[Part]:
    """The PE table and the two-ray fallback: which movers are inside the PE table's height
    (:data:`shipradar.tables.scene.PE_MAX_HEIGHT_M`) and which above it."""
    from shipradar.tables.scene import PE_MAX_HEIGHT_M

    fid = scenario.fidelity
    movers = _movers(scenario)
    if not movers:
        return [Part("propagation factor F [4]-[7]", False, "no targets or jammers",
                     choice="propagation")]
    if fid.propagation != "pe":
        other = "two-ray model" if fid.propagation == "two_ray" else "pattern alone"
        return [Part("PE table [5]-[7]", False,
                     f"fidelity.propagation is {fid.propagation!r}: F by the {other}",
                     choice="propagation")]
    top = PE_MAX_HEIGHT_M
    # highest altitude including climbs and pop-ups where the schema knows them
    above = sorted(m.id for m in movers if min(w.altitude_m for w in m.waypoints) > top)
    partly = sorted(m.id for m in movers if m.max_altitude_m > top and m.id not in above)
    inside = [m.id for m in movers if m.id not in above]
    if inside:
        pe = Part("PE table [5]-[7]", True,
                  f"{len(inside)} target(s)/jammer(s) at or below its {top:g} m top; "
                  f"{_refractivity_description(scenario)}; grid {fid.pe_grid!r}",
                  choice="pe_grid")
    else:
        pe = Part("PE table [5]-[7]", False,
                  f"every target is above the PE table's {top:g} m top: two-ray",
                  choice="pe_grid")
    if above or partly:
        what = []
        if above:
            what.append(f"always above {top:g} m: {', '.join(above)}")
        if partly:
            what.append(f"partly above: {', '.join(partly)}")
        why = "targets above the PE domain use two-ray (" + "; ".join(what) + ")"
    else:
        why = ("only for points outside the PE table (steep angles, beyond its range), "
               "counted as propagation_fallbacks")
    return [pe, Part("two-ray fallback (3.1.2)", True, why, choice="propagation")]


def _refractivity_description(scenario: Scenario) -> str:
    """The scene's M-profile in words (standard, a profile, an evaporation duct)."""
    from shipradar.tables.scene import duct_height_m

    duct = scenario.environment.duct
    if duct is None:
        return "standard atmosphere"
    if duct.type == "profile":
        return f"M-profile of {len(duct.heights_m)} points"
    return f"evaporation duct {duct_height_m(scenario):.3g} m" + (
        " (bulk model)" if duct.type == "bulk" else "")


def _atmosphere_part(scenario: Scenario) -> Part:
    """Atmospheric attenuation [16]: gases, fog and rain."""
    name = "atmospheric attenuation [16]"
    env = scenario.environment
    if not _movers(scenario):
        return Part(name, False, "no targets or jammers", choice="atmosphere")
    if not scenario.fidelity.atmosphere:
        return Part(name, False, "fidelity.atmosphere is false", choice="atmosphere")
    bits = ["gases (ITU-R P.676)", "fog (P.840)" if env.fog else "no fog",
            "rain (P.838)" if env.rain else "no rain"]
    return Part(name, True, ", ".join(bits), choice="atmosphere")


def _radar_parts(scenario: Scenario, r: Radar) -> list[Part]:
    """One radar's clutter, processor and false-alarm parts."""
    from shipradar.sensors.radar import radar_constants
    from shipradar.sensors.sea_clutter import is_medium_high_resolution

    fid, env = scenario.fidelity, scenario.environment
    clutter_off = "fidelity.clutter is false"
    k = radar_constants(scenario, r)
    hi_res = bool(is_medium_high_resolution(k.theta_b, r.pulse_width_s))
    x = math.degrees(k.theta_b) * r.pulse_width_s * 1e6
    out = []
    sea = "sea clutter [21]-[38]"
    out.append(Part(sea, False, clutter_off, r.id, "clutter") if not fid.clutter else
               Part(sea, True, f"sea state {env.sea_state}, wave height "
                               f"{scenario.wave_height:g} m", r.id, "clutter"))
    wx = "weather clutter [39]-[45]"
    if env.rain is None:
        out.append(Part(wx, False, "no rain", r.id))
    elif not fid.clutter:
        out.append(Part(wx, False, clutter_off, r.id))
    else:
        out.append(Part(wx, True, f"rain {env.rain.rate_mm_h:g} mm/h ({env.rain.kind})", r.id))
    proc = r.processor.type
    dop = "Doppler processor, I_F table [49]-[62]"
    if proc == "none":
        out.append(Part(dop, False, "no processor", r.id, "improvement_grid"))
    elif not fid.clutter:
        out.append(Part(dop, False, f"{clutter_off} (I_F is read only against clutter)",
                        r.id, "improvement_grid"))
    else:
        out.append(Part(dop, True, f"{proc}; grid {fid.improvement_grid!r}", r.id,
                        "improvement_grid"))
    cfa = "sea-clutter false alarms [94]-[96]"
    if not hi_res:
        out.append(Part(cfa, False, f"low resolution (θ_b τ' = {x:.2g} deg µs, τ' = "
                                    f"{r.pulse_width_s * 1e6:.3g} µs: Rayleigh clutter, seed "
                                    "4.1.2)", r.id, "clutter_fa_model"))
    elif not fid.clutter:
        out.append(Part(cfa, False, clutter_off, r.id, "clutter_fa_model"))
    else:
        out.append(Part(cfa, True, f"medium/high resolution (θ_b τ' = {x:.2g} deg µs); model "
                                   f"{fid.clutter_fa_model!r}, K_clutter {r.k_clutter:g}",
                        r.id, "clutter_fa_model"))
    out.append(Part("noise false alarms [90]-[93]", True,
                    f"t_fa = {r.false_alarm_time_s:g} s", r.id))
    return out


def explain_lines(scenario: Scenario) -> list[str]:
    """:func:`explain` as text lines, exercised parts first."""
    parts = explain(scenario)
    lines = ["exercised:"]
    for p in parts:
        if p.exercised:
            lines.append(f"  + {p.name}{f' ({p.radar})' if p.radar else ''}: {p.reason}")
    lines.append("skipped:")
    skipped = [p for p in parts if not p.exercised]
    for p in skipped:
        lines.append(f"  - {p.name}{f' ({p.radar})' if p.radar else ''}: {p.reason}")
    if not skipped:
        lines.append("  (nothing: the scene exercises every part)")
    return lines


# =========================================================================== settings
@dataclass(frozen=True)
class Setting:
    """A fidelity setting to run: a label, the choice it changes and the full block."""

    label: str
    choice: str | None
    value: Any
    fidelity: dict[str, Any]
    exercised: bool = True
    kind: str = "alternative"  # "reference", "alternative", "scene", "combined"


def _with_fidelity(scenario: Scenario, fid: dict[str, Any]) -> Scenario:
    """The scenario with another fidelity block, validated again (the exact P_d's check)."""
    data = scenario.model_dump(mode="python")
    data["fidelity"] = dict(fid)
    return Scenario.model_validate(data)


def _exact_pd_allowed(scenario: Scenario) -> bool:
    return all(r.detector == "square" and r.integrator == "uniform"
               for _, r in scenario.radars())


def reference_fidelity(scenario: Scenario) -> dict[str, Any]:
    """The most accurate setting of every choice (sectors per scan: the scene's own)."""
    return {
        "pd_method": "exact" if _exact_pd_allowed(scenario) else "seed",
        "propagation": "pe",
        "pe_grid": "fine",
        "improvement_grid": "fine",
        "sectors_per_scan": scenario.fidelity.sectors_per_scan,
        "clutter": True,
        "atmosphere": True,
        "clutter_fa_model": "weibull_median",
    }


def plan_settings(scenario: Scenario, *, include_unexercised: bool = False
                  ) -> tuple[dict[str, Any], list[Setting], list[tuple[str, str]]]:
    """The reference, the one-at-a-time alternatives and the choices skipped with reasons.

    Parameters
    ----------
    scenario : Scenario
        The scene.
    include_unexercised : bool
        Also run the alternatives of choices the scene does not exercise (they must then
        show zero differences; a test of the common random numbers). Sectors-per-scan
        values below the scene's are always run (their latency is judged by
        :class:`Tolerances`).

    Returns
    -------
    reference : dict
        The reference fidelity block.
    settings : list of Setting
        The reference first, then the alternatives, then the scene's own setting when it
        differs from the reference.
    skipped : list of (choice, reason)
    """
    ref = reference_fidelity(scenario)
    parts = explain(scenario)

    def used(choice: str) -> tuple[bool, str]:
        rel = [p for p in parts if p.choice == choice]
        if any(p.exercised for p in rel):
            return True, ""
        return False, "; ".join(sorted({f"{p.radar + ': ' if p.radar else ''}{p.reason}"
                                        for p in rel})) or "not read by this scene"

    has_movers = bool(scenario.targets or scenario.jammers)
    alternatives: dict[str, list[Any]] = {
        # every other P_d method the schema offers (the seed's; a tabulated exact P_d)
        "pd_method": ([v for v in typing.get_args(Fidelity.model_fields["pd_method"].annotation)
                       if v != "exact"] if ref["pd_method"] == "exact" else []),
        "propagation": ["two_ray", "free_space"],
        "pe_grid": ["standard", "coarse"],
        "improvement_grid": ["standard", "coarse"],
        "clutter_fa_model": ["seed"],
        "clutter": [False],
        "atmosphere": [False],
        "sectors_per_scan": [n for n in SECTOR_CHOICES if n < ref["sectors_per_scan"]],
    }
    reasons = {
        "pd_method": (bool(scenario.targets), "no targets"),
        "propagation": (has_movers, "no targets or jammers"),
        "pe_grid": used("pe_grid"),
        "improvement_grid": used("improvement_grid"),
        "clutter_fa_model": used("clutter_fa_model"),
        "clutter": (True, ""),
        "atmosphere": (has_movers, "no targets or jammers"),
        "sectors_per_scan": (True, ""),
    }
    if not alternatives["pd_method"] and scenario.targets:
        reasons["pd_method"] = (False, "a radar's detector/integrator needs the seed method "
                                       "(the exact P_d is for square-law, uniform)")
    settings = [Setting("reference", None, None, ref, True, "reference")]
    skipped: list[tuple[str, str]] = []
    for choice in CHOICES:
        exercised, why = reasons[choice]
        values = alternatives[choice]
        if not values:
            if choice == "sectors_per_scan":
                why = f"already {ref['sectors_per_scan']} (no cheaper value tried)"
            skipped.append((choice, why or "no alternative"))
            continue
        if not exercised:
            skipped.append((choice, why))
            if not include_unexercised:
                continue
        for v in values:
            fid = {**ref, choice: v}
            settings.append(Setting(f"{choice}={_fmt(v)}", choice, v, fid, exercised))
    own = scenario.fidelity.model_dump()
    if own != ref:
        settings.append(Setting("scene's own", None, None, own, True, "scene"))
    return ref, settings, skipped


def _fmt(v: Any) -> str:
    return str(v).lower() if isinstance(v, bool) else str(v)


# =========================================================================== one run
def look_uniforms(seed: int, radar_index: int, scan_period_s: float):
    """The common-random-number source of one radar in one run.

    Returns ``u(target_rows, t_s)``: one uniform in [0, 1) per look, a pure function of
    (seed, radar, target, scan), the scan being the revolution that owns the crossing time
    ``t_s`` (the engine's rule: [start - 1 µs, end - 1 µs)). The bits are the SplitMix64
    finaliser (Steele, Lea & Flood 2014) of the four keys combined with odd constants, the
    top 53 bits scaled to [0, 1).
    """
    base = np.array([seed & 0xFFFFFFFFFFFFFFFF], dtype=np.uint64)
    base = _splitmix64(base ^ np.uint64((radar_index * 0x9E3779B97F4A7C15) & 0xFFFFFFFFFFFFFFFF))

    def u(rows: np.ndarray, t: np.ndarray) -> np.ndarray:
        scan = np.floor((np.asarray(t, dtype=float) + _CROSSING_EPS_S) / scan_period_s)
        scan = np.maximum(scan, 0).astype(np.uint64)
        x = base ^ _splitmix64(np.asarray(rows, dtype=np.uint64) * np.uint64(0xBF58476D1CE4E5B9)
                               + np.uint64(1))
        x = _splitmix64(x ^ _splitmix64(scan + np.uint64(0x94D049BB133111EB)))
        return (x >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0)

    return u


def _splitmix64(x: np.ndarray) -> np.ndarray:
    """SplitMix64 finaliser of uint64 arrays (wrapping arithmetic)."""
    x = np.asarray(x, dtype=np.uint64).copy()
    x += np.uint64(0x9E3779B97F4A7C15)
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


@dataclass
class RunResult:
    """What one setting gave over its runs."""

    setting: Setting
    looks: dict[str, np.ndarray]  # run, radar, target, scan, pd, hit, range_m
    expected_fa: dict[tuple[str, str], float]  # (radar id, origin) -> per scan
    drawn_fa: dict[str, float]  # origin -> per radar-scan, drawn
    table_s: float
    tables_built: int
    run_wall_s: float
    run_cpu_s: float
    simulated_s: float
    fallbacks: int = 0
    error: str | None = None


#: The fidelity choices each table kind depends on (shipradar.tables.scene decides whether it
#: exists): settings that agree on them share the table, loaded once per command.
TABLE_CHOICES = {"atmosphere": (), "propagation": ("propagation", "pe_grid"),
                 "improvement": ("improvement_grid",), "sea_clutter": (),
                 "weather_clutter": ("atmosphere",), "pfac": ("clutter_fa_model",)}


class _TableClock:
    """Times every table a setting reads; a table key seen before in this command keeps the
    time it took then (its build, if it was built here). Tables are kept for the command's
    life, so each distinct table is built or read once (a kind not in
    :data:`TABLE_CHOICES` is keyed on the whole fidelity block)."""

    def __init__(self):
        self.seconds: dict[str, float] = {}
        self.built: set[str] = set()
        self._memo: dict[tuple, tuple[Any, str]] = {}

    def load(self, scenario: Scenario):
        from shipradar.tables.scene import SceneTables, table_specs
        from shipradar.tables.store import cache_path

        scene = SceneTables()
        for _p, r in scenario.radars():
            scene.for_radar(r.id)
        total, built = 0.0, 0
        base = scenario.model_dump_json(exclude={"fidelity"})
        fid = scenario.fidelity.model_dump()
        for spec in table_specs(scenario):
            choices = TABLE_CHOICES.get(spec.kind, tuple(sorted(fid)))
            memo_key = (base, spec.radar_id, spec.kind, tuple(fid[c] for c in choices))
            if memo_key in self._memo:
                table, key = self._memo[memo_key]
                total += self.seconds[key]
                built += key in self.built
                setattr(scene.for_radar(spec.radar_id), spec.kind, table)
                continue
            before = {p.name for p in _cache_files()}
            t0 = time.perf_counter()
            table = spec.make()
            dt = time.perf_counter() - t0
            key = f"{table.name}-{table.key}"
            self._memo[memo_key] = (table, key)
            if key not in self.seconds:
                self.seconds[key] = dt
                if cache_path(table.name, table.key).name not in before:
                    self.built.add(key)
            total += self.seconds[key]
            built += key in self.built
            setattr(scene.for_radar(spec.radar_id), spec.kind, table)
        return scene, total, built


def _cache_files() -> list[Path]:
    from shipradar.tables.store import cache_dir

    d = cache_dir()
    return list(d.glob("*.npz")) if d.is_dir() else []


def run_setting(scenario: Scenario, setting: Setting, seeds: Sequence[int], duration_s: float,
                clock: _TableClock, *, crn: bool = True) -> RunResult:
    """Run the scene under one setting, once per seed, with common random numbers.

    ``crn=False`` leaves the detection draw on the engine's sequential stream (for tests:
    then a change in the number of other draws, false alarms for instance, moves the dice
    of every later look)."""
    from shipradar.sim.engine.simulation import Simulation

    scene = _with_fidelity(scenario, setting.fidelity)
    tables, table_s, built = clock.load(scene)
    cols: dict[str, list[np.ndarray]] = {k: [] for k in
                                         ("run", "radar", "target", "scan", "pd", "hit",
                                          "range_m")}
    # best of the runs (the usual benchmark reading: the others were slowed by the machine)
    wall = cpu = math.inf
    fa = {"noise": 0.0, "sea_clutter": 0.0}
    scans = 0
    expected: dict[tuple[str, str], float] = {}
    fallbacks = 0
    for run, seed in enumerate(seeds):
        sim = Simulation(scene, seed=seed, duration_s=duration_s, tables=tables)
        for k, proc in enumerate(sim.radars):
            model = proc.model
            period = proc.radar.scan_period_s
            if crn:
                model.look_uniforms = look_uniforms(seed, k, period)
            model.on_look.append(_look_recorder(cols, run, k, period))
            if run == 0:
                expected[(proc.radar.id, "noise")] = float(model.noise_false_alarms_per_scan)
                expected[(proc.radar.id, "sea_clutter")] = _clutter_fa_per_scan(model)
        w0, c0 = time.perf_counter(), time.process_time()
        sim.run()
        wall = min(wall, time.perf_counter() - w0)
        cpu = min(cpu, time.process_time() - c0)
        fa["noise"] += sim.stats.noise_false_alarms
        fa["sea_clutter"] += sim.stats.clutter_false_alarms
        scans += sim.stats.scans
        fallbacks += sim.stats.propagation_fallbacks
    looks = {k: (np.concatenate(v) if v else np.zeros(0)) for k, v in cols.items()}
    n = len(seeds)
    return RunResult(setting, looks, expected,
                     {o: c / max(scans, 1) for o, c in fa.items()}, table_s, built,
                     wall, cpu, duration_s, fallbacks // n)


def _look_recorder(cols: dict[str, list[np.ndarray]], run: int, radar: int,
                   period: float) -> LookObserver:
    """An observer of the dwell model's looks (``DwellModel.on_look``) that appends each
    look's run, radar, target, scan, P_d, detection and slant range to ``cols``."""
    def record(look: LookResults) -> None:
        scan = np.floor((look.time_s + _CROSSING_EPS_S) / period).astype(np.int64)
        cols["run"].append(np.full(look.size, run, dtype=np.int64))
        cols["radar"].append(np.full(look.size, radar, dtype=np.int64))
        cols["target"].append(np.asarray(look.target, dtype=np.int64))
        cols["scan"].append(scan)
        cols["pd"].append(np.asarray(look.pd, dtype=float))
        cols["hit"].append(np.asarray(look.hit, dtype=bool))
        cols["range_m"].append(np.asarray(look.slant_range_m, dtype=float))

    return record


def _clutter_fa_per_scan(model) -> float:
    pfac = model.tables.pfac
    if pfac is None:
        return 0.0
    from shipradar.tables.pfac import clutter_range_profile

    return float(clutter_range_profile(pfac)[1].sum())


# =========================================================================== comparison
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
    latency = _latency_s(scenario, res.setting.fidelity)
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
    ea, pa = _expected_first_range(A["pd"][s0], A["range_m"][s0])
    eb, pb = _expected_first_range(B["pd"][s0], B["range_m"][s0])
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
                   f"{_fmt_m(row['abs_dfirst_m'])} > {tol.range_m:g} m")
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


def _expected_first_range(pd: np.ndarray, range_m: np.ndarray
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


def _fmt_m(x: float) -> str:
    return "never/always" if math.isinf(x) else f"{x:.0f} m"


def _latency_s(scenario: Scenario, fid: dict[str, Any]) -> float:
    """Longest delay a plot waits for the end of its sector [s]: one sector."""
    return max(r.scan_period_s for _, r in scenario.radars()) / fid["sectors_per_scan"]


@dataclass(frozen=True)
class Tolerances:
    """What the recommendation must stay within (see the module docstring)."""

    pd: float = 0.02
    range_m: float = 500.0
    fa_rel: float = 0.1
    latency_s: float | None = None


# =========================================================================== study
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
                       tolerances: Tolerances = Tolerances(), include_unexercised: bool = False,
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
    tolerances : Tolerances
        The limits of the recommendation.
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
    duration = float(scenario.duration_s if duration_s is None else duration_s)
    seeds = [run_seed(c) for c in np.random.SeedSequence(scenario.seed).spawn(runs)]
    if tolerances.latency_s is None:
        tolerances = Tolerances(tolerances.pd, tolerances.range_m, tolerances.fa_rel,
                                _latency_s(scenario, scenario.fidelity.model_dump()))
    ref_fid, settings, skipped = plan_settings(scenario,
                                               include_unexercised=include_unexercised)
    clock = _TableClock()

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
        lambda fid: _with_fidelity(scenario, fid), duration)
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
            scene = _with_fidelity(scenario, s.fidelity)
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
    parts = explain(_with_fidelity(scenario, fid))
    out = []
    for choice in ("pe_grid", "improvement_grid", "clutter_fa_model"):
        rel = [p for p in parts if p.choice == choice]
        if not any(p.exercised for p in rel):
            out.append(choice)
    return tuple(out)


def _recommend(study: Study, timer: SampleTimer, clock: _TableClock,
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
        more_accurate = _error_score(c, tol) < _error_score(best, tol)
        if (more_accurate and not ratio.low > b_ratio.high) or ratio.high < b_ratio.low:
            pick[s.choice] = c
    candidate = {**ref_fid, **{k: v.result.setting.value for k, v in pick.items()}}
    for choice in unread_choices(scenario, candidate):
        if choice in pick:
            study.notes.append(f"{choice} dropped: not read with "
                               f"{_diff_label(candidate, ref_fid)}")
            del pick[choice]
            candidate[choice] = ref_fid[choice]
    ref = results["reference"]
    while pick:
        label = _diff_label(candidate, ref_fid)
        comp = next((c for c in study.comparisons if c.result.setting.fidelity == candidate),
                    None)
        if comp is None:
            say(f"fidelity: running the combination {label} ...")
            s = Setting("recommended", None, None, dict(candidate), True, "combined")
            comp = compare(ref, run_setting(scenario, s, study.seeds, study.duration_s, clock),
                           scenario, tol)
            study.comparisons.append(comp)
        if not comp.ok:
            worst = max(pick, key=lambda k: _error_score(pick[k], tol))
            study.notes.append(f"the combination {label} was outside the tolerances "
                               f"({'; '.join(comp.violations[:3])}); {worst} back to "
                               f"{_fmt(ref_fid[worst])}")
            candidate[worst] = ref_fid[worst]
            del pick[worst]
            continue
        say(f"fidelity: timing the block {label} against the reference ...")
        (cost,) = paired_costs(timer, ref_fid, [candidate], study.seeds, study.pairs)
        ratio = cost.ratio(obj)
        if not is_cheaper(ratio):
            least = max(pick, key=lambda k: _ratio_value(study, pick[k]))
            study.notes.append(f"the block {label} re-timed as a whole: {obj} CPU "
                               f"{ratio.fmt()}x the reference's, not measurably cheaper; "
                               f"{least} back to {_fmt(ref_fid[least])}")
            candidate[least] = ref_fid[least]
            del pick[least]
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


def _error_score(c: Comparison, tol: Tolerances) -> float:
    """Largest error of a setting as a fraction of its tolerance."""
    t = c.total
    score = t["worst_target_mean_abs_dpd"] / max(tol.pd, 1e-12)
    score = max(score, t["max_abs_dfirst_m"] / max(tol.range_m, 1e-12))
    for k, e in t["expected_fa"].items():
        e_ref = t["expected_fa_ref"][k]
        score = max(score, abs(e - e_ref) / max(tol.fa_rel * max(e_ref, FA_REL_FLOOR), 1e-12))
    return score


def _diff_label(fid: dict[str, Any], ref: dict[str, Any]) -> str:
    d = [f"{k}={_fmt(v)}" for k, v in fid.items() if ref.get(k) != v]
    return ", ".join(d) if d else "reference"


# =========================================================================== output
def fidelity_yaml(fid: dict[str, Any], unread: Sequence[str] = ()) -> str:
    """A ready-to-paste ``fidelity:`` block (every choice explicit, schema order); the
    choices in ``unread`` (the scene does not read them under this block) are left out,
    named in a comment."""
    block = Fidelity(**fid).model_dump()
    lines = ["fidelity:"]
    for k, v in block.items():
        if k not in unread:
            lines.append(f"  {k}: {_fmt(v)}")
    if unread:
        lines.append(f"  # not read by this scene with this block: {', '.join(unread)}")
    return "\n".join(lines) + "\n"


def format_per_target(study: Study) -> str:
    """One line per setting and (radar, target): the per-target columns of the CSV."""
    out = ["per target (mean|ΔPd|, max|ΔPd|, E[det] ref -> setting, |ΔE[R1]| m, "
           "realized detections ref -> setting):"]
    for c in study.comparisons:
        label = c.result.setting.label
        for r in c.rows:
            out.append(
                f"  {label:28.28s} {r['radar'] + '/' + r['target']:24.24s} "
                f"{r['mean_abs_dpd']:.4f} {r['max_abs_dpd']:.3f}  "
                f"{r['expected_detections_ref']:6.1f} -> {r['expected_detections']:6.1f}  "
                f"{'inf' if math.isinf(r['abs_dfirst_m']) else format(r['abs_dfirst_m'], '.0f'):>6}"
                f"  {r['detections_ref']:5.1f} -> {r['detections']:5.1f}")
    return "\n".join(out)


def _cost_cells(study: Study, c: Comparison) -> tuple[str, str, str, str]:
    """Warm run CPU and first run as ratios to the reference, table load [s], build [s]."""
    cost = study.cost(c)
    if cost is None:
        return "-", "-", "-", "-"
    p = cost.paired
    if p is None:  # the reference: its own seconds, over every pair
        ref = study.costs
        samples = [s for k in ref.values() if k.paired is not None for s in k.paired.reference]
        warm = mean_interval([s.warm_run_s for s in samples])
        first = mean_interval([s.first_s for s in samples])
        load = mean_interval([s.load_s for s in samples])
        run = f"{warm.fmt(3)} s"
        first_s = f"{first.fmt(3)} s"
    else:
        run = p.warm_ratio.fmt() + "x" + ("*" if is_cheaper(p.warm_ratio) else "")
        first_s = p.first_ratio.fmt() + "x" + ("*" if is_cheaper(p.first_ratio) else "")
        load = p.seconds("load_s")
    build = (cost.build.fmt(2) if cost.build is not None else
             f"~{cost.build_estimate_s:.2g} est.")
    return run, first_s, load.fmt(3), build


def format_report(study: Study) -> str:
    """The stdout table, the skipped choices and the recommendation."""
    s = study.scenario
    tol = study.tolerances
    out = [f"shipradar fidelity: {s.name}, {study.duration_s:g} s simulated x "
           f"{len(study.seeds)} run(s); reference {_diff_label(study.reference, {})}",
           f"tolerances: mean |ΔP_d| per look <= {tol.pd:g} per target; |Δ expected "
           f"first-detection range| <= {tol.range_m:g} m; expected FA/scan within "
           f"{tol.fa_rel:.0%}; latency <= {tol.latency_s:.3g} s",
           f"cost: CPU seconds, {study.pairs} alternating pairs (reference, setting) per "
           f"setting, {CONFIDENCE:.0%} intervals; the recommendation minimises the "
           + ("per-run CPU (warm: the 2nd and later runs of a Monte Carlo study)"
              if study.objective == "per-run" else
              "first run's CPU (table load + the first run of a process)"), ""]
    if study.shortened:
        out[-1:] = [_shortened_warning(study), ""]
    head = ("setting", "mean|ΔPd|", "max|ΔPd|", "worst tgt", "ΔE[det]", "Δdet",
            "max|ΔE[R1]|m", "max|ΔR1|m", "FA/scan n+c", "run CPU (warm)", "first run",
            "load s", "build s", "ok")
    rows = []
    for c in study.comparisons:
        t, r = c.total, c.result
        label = r.setting.label if r.setting.kind != "combined" else (
            "combined: " + _diff_label(r.setting.fidelity, study.reference))
        if not r.setting.exercised:
            label += " (not exercised)"
        rows.append((
            label, f"{t['mean_abs_dpd']:.4f}", f"{t['max_abs_dpd']:.3f}",
            f"{t['worst_target_mean_abs_dpd']:.4f}", f"{t['d_expected_detections']:+.2f}",
            f"{t['d_detections']:+.1f}",
            "inf" if math.isinf(t["max_abs_dfirst_m"]) else f"{t['max_abs_dfirst_m']:.0f}",
            ("inf" if math.isinf(t["max_realized_abs_dfirst_m"])
             else f"{t['max_realized_abs_dfirst_m']:.0f}"),
            f"{t['noise_fa_per_scan']:.3g}+{t['clutter_fa_per_scan']:.3g}",
            *_cost_cells(study, c), "yes" if c.ok else "no"))
    widths = [max(len(h), *(len(x[i]) for x in rows)) for i, h in enumerate(head)]
    out.append("  ".join(h.ljust(w) if i == 0 else h.rjust(w)
                         for i, (h, w) in enumerate(zip(head, widths, strict=True))))
    for x in rows:
        out.append("  ".join(v.ljust(w) if i == 0 else v.rjust(w)
                             for i, (v, w) in enumerate(zip(x, widths, strict=True))))
    out.append("(E[...]: expected from the looks' P_d, dice-free; Δdet, |ΔR1|: realized with "
               "common random numbers. FA/scan: expected noise + sea-clutter false alarms per "
               "scan, all radars. run CPU (warm), first run: the setting's CPU over the "
               "reference's, geometric mean of the pairs [interval], * measurably cheaper "
               f"(whole interval below {1 - SAVING_MIN:g}); the reference's row in seconds. "
               "first run = table load + the first run on the loaded tables; load s: the "
               "tables read from the cache, once per process; build s: once per cache, "
               + ("measured (--cold)" if study.builds_measured else
                  "the cost model's estimate (--cold measures it)") + ")")
    if study.skipped:
        out.append("")
        out.append("not run (the scene does not exercise them):")
        for choice, why in study.skipped:
            out.append(f"  {choice}: {why}")
    bad = [c for c in study.comparisons if not c.ok and c.result.setting.kind != "reference"]
    if bad:
        out.append("")
        out.append("outside the tolerances:")
        for c in bad:
            out.append(f"  {c.result.setting.label}: {'; '.join(c.violations[:3])}"
                       + (f" (+{len(c.violations) - 3} more)" if len(c.violations) > 3 else ""))
    if study.undecided:
        out.append("")
        out.append(f"within noise (inside the tolerances; the {study.objective} interval "
                   f"straddles {1 - SAVING_MIN:g}x, so neither cheaper nor not: more --pairs "
                   "may decide):")
        for u in study.undecided:
            out.append(f"  {u}x")
    for n in study.notes:
        out.append(f"note: {n}")
    out.append("")
    out += _recommendation_lines(study)
    out.append("")
    out.append(f"command: {len(study.comparisons)} settings in {study.wall_s:.1f} s wall")
    return "\n".join(out)


def _shortened_warning(study: Study) -> str:
    return (f"WARNING: shortened study ({study.duration_s:g} s of the scene's "
            f"{study.scenario.duration_s:g} s): the recommendation holds for the first "
            f"{study.duration_s:g} s only; --apply refuses it unless --allow-shortened")


def _recommendation_lines(study: Study) -> list[str]:
    out = []
    rc = study.recommended_comparison
    label = _diff_label(study.recommended, study.reference)
    if label == "reference":
        out.append("recommended: the reference (no setting inside the tolerances is "
                   f"measurably cheaper by {study.objective} CPU)")
    else:
        out.append(f"recommended (cheapest by {study.objective} CPU inside the tolerances; "
                   f"{label}):")
    cost = study.recommended_cost
    if cost is not None:
        warm, first = cost.saving_s("warm_run_s"), cost.saving_s("first_s")
        out.append(f"  the block re-timed as a whole ({cost.warm_ratio.n} fresh alternating "
                   f"pairs): run CPU (warm) {cost.warm_ratio.fmt()}x the reference's, saving "
                   f"{warm.fmt(3)} s per run (reference "
                   f"{cost.seconds('warm_run_s', 'reference').fmt(3)} s); first run (table "
                   f"load + run) {cost.first_ratio.fmt()}x, saving {first.fmt(3)} s per "
                   f"process (reference {cost.seconds('first_s', 'reference').fmt(3)} s; a "
                   "process's start-up and imports, the same for both, are not in these "
                   "seconds: the saving carries over to a whole process, the ratio does not)")
    if rc is not None and rc.result.setting.kind != "reference":
        t = rc.total
        out.append(f"  accuracy of the block as a whole: mean |ΔP_d| {t['mean_abs_dpd']:.4f}, "
                   f"worst target {t['worst_target_mean_abs_dpd']:.4f}, largest "
                   f"|Δ expected first-detection range| {_fmt_m(t['max_abs_dfirst_m'])}")
    if study.shortened:
        out.append("  " + _shortened_warning(study))
    out.append("")
    out.append(fidelity_yaml(study.recommended, study.unread).rstrip())
    return out


CSV_COLUMNS = ("setting", "kind", "choice", "value", "exercised", "radar", "target", "looks",
               "mean_abs_dpd", "max_abs_dpd", "mean_pd_ref", "mean_pd",
               "expected_detections_ref", "expected_detections", "d_expected_detections",
               "detections_ref", "detections", "d_detections", "p_detected_ref", "p_detected",
               "expected_first_range_ref_m", "expected_first_range_m", "abs_dfirst_m",
               "first_range_ref_m", "first_range_m", "realized_abs_dfirst_m",
               "expected_noise_fa_per_scan",
               "expected_clutter_fa_per_scan", "drawn_noise_fa_per_scan",
               "drawn_clutter_fa_per_scan", "latency_s", "pairs",
               "warm_run_ratio", "warm_run_ratio_low", "warm_run_ratio_high",
               "first_run_ratio", "first_run_ratio_low", "first_run_ratio_high",
               "warm_run_s", "first_run_s", "warm_saving_s", "warm_saving_s_low",
               "warm_saving_s_high", "first_saving_s", "first_saving_s_low",
               "first_saving_s_high", "load_s", "load_s_low", "load_s_high",
               "build_s", "build_s_low", "build_s_high", "build_estimated_s",
               "cheaper", "within_tolerance")


def _cost_columns(study: Study, c: Comparison) -> dict[str, Any]:
    """The CSV's cost columns of one setting (ratios to the reference with their
    intervals; the reference's own rows hold its seconds)."""
    cost = study.cost(c)
    out: dict[str, Any] = {"pairs": study.pairs}
    if cost is None:
        return out
    if cost.build is not None:
        out.update(build_s=cost.build.value, build_s_low=cost.build.low,
                   build_s_high=cost.build.high)
    out["build_estimated_s"] = cost.build_estimate_s
    p = cost.paired
    if p is None:
        samples = [s for k in study.costs.values() if k.paired is not None
                   for s in k.paired.reference]
        out["warm_run_s"] = mean_interval([s.warm_run_s for s in samples]).value
        out["first_run_s"] = mean_interval([s.first_s for s in samples]).value
        load = mean_interval([s.load_s for s in samples])
    else:
        for name, r in (("warm_run_ratio", p.warm_ratio), ("first_run_ratio", p.first_ratio)):
            out.update({name: r.value, f"{name}_low": r.low, f"{name}_high": r.high})
        out["warm_run_s"] = p.seconds("warm_run_s").value
        out["first_run_s"] = p.seconds("first_s").value
        for name, what in (("warm_saving_s", "warm_run_s"), ("first_saving_s", "first_s")):
            d = p.saving_s(what)
            out.update({name: d.value, f"{name}_low": d.low, f"{name}_high": d.high})
        out["cheaper"] = is_cheaper(p.ratio(study.objective))
        load = p.seconds("load_s")
    out.update(load_s=load.value, load_s_low=load.low, load_s_high=load.high)
    return out


def write_csv(study: Study, path: Path) -> None:
    """One row per setting and (radar, target), and one ``*`` total row per setting."""
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(CSV_COLUMNS)
        for c in study.comparisons:
            r, t = c.result, c.total
            s = r.setting
            common = {
                "setting": s.label if s.kind != "combined" else
                "combined: " + _diff_label(s.fidelity, study.reference),
                "kind": s.kind, "choice": s.choice or "", "value": "" if s.value is None
                else _fmt(s.value), "exercised": s.exercised,
                "latency_s": t["latency_s"], **_cost_columns(study, c),
                "within_tolerance": c.ok,
            }
            for row in c.rows:
                e = t["expected_fa"]
                full = {**common, **row,
                        "expected_noise_fa_per_scan": e.get(f"{row['radar']}:noise", ""),
                        "expected_clutter_fa_per_scan": e.get(f"{row['radar']}:sea_clutter",
                                                              "")}
                w.writerow([_csv(full.get(k, "")) for k in CSV_COLUMNS])
            tot = {**common, "radar": "*", "target": "*", "looks": t["looks"],
                   "mean_abs_dpd": t["mean_abs_dpd"], "max_abs_dpd": t["max_abs_dpd"],
                   "detections": t["detections"], "d_detections": t["d_detections"],
                   "d_expected_detections": t["d_expected_detections"],
                   "abs_dfirst_m": t["max_abs_dfirst_m"],
                   "realized_abs_dfirst_m": t["max_realized_abs_dfirst_m"],
                   "expected_noise_fa_per_scan": t["noise_fa_per_scan"],
                   "expected_clutter_fa_per_scan": t["clutter_fa_per_scan"],
                   "drawn_noise_fa_per_scan": t["drawn_noise_fa_per_scan"],
                   "drawn_clutter_fa_per_scan": t["drawn_clutter_fa_per_scan"]}
            w.writerow([_csv(tot.get(k, "")) for k in CSV_COLUMNS])


def _csv(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return "inf" if math.isinf(v) else repr(v)
    return str(v)


def pareto_front(cost: Sequence[float], error: Sequence[float]) -> list[int]:
    """Indices of the non-dominated points (no other point is both cheaper and as accurate,
    or as cheap and more accurate), sorted by cost."""
    idx = sorted(range(len(cost)), key=lambda i: (cost[i], error[i]))
    front, best = [], math.inf
    for i in idx:
        if error[i] < best:
            front.append(i)
            best = error[i]
    return front


def tolerated_front(cost: Sequence[float], error: Sequence[float], ok: Sequence[bool]
                    ) -> list[int]:
    """:func:`pareto_front` over the points inside the tolerances only (indices into all)."""
    inside = [i for i, good in enumerate(ok) if good]
    return [inside[j] for j in pareto_front([cost[i] for i in inside],
                                            [error[i] for i in inside])]


def plot_pareto(study: Study, path: Path) -> None:
    """PNG: error (worst target's mean |ΔP_d|; |Δ first-detection range|) against cost (the
    objective's CPU over the reference's, with its interval), the Pareto front joined over
    the settings inside the tolerances only, the tolerances drawn, labels placed apart."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    comps = study.comparisons
    ratios = [study.ratio(c) for c in comps]
    cost = [1.0 if r is None else r.value for r in ratios]
    lo = [0.0 if r is None else r.value - r.low for r in ratios]
    hi = [0.0 if r is None else r.high - r.value for r in ratios]
    err_pd = [c.total["worst_target_mean_abs_dpd"] for c in comps]
    err_r = [c.total["max_abs_dfirst_m"] for c in comps]
    fig, axes = plt.subplots(1, 2, figsize=(14, 6), constrained_layout=True)
    for ax, err, tol, name in ((axes[0], err_pd, study.tolerances.pd,
                                "worst target's mean |ΔP_d| per look"),
                               (axes[1], err_r, study.tolerances.range_m,
                                "largest |Δ expected first-detection range| [m]")):
        finite = [e for e in err if 0 < e < math.inf]
        floor = min([tol, *finite]) / 3 if tol > 0 else min(finite, default=1.0) / 3
        ceiling = 3 * max([tol, *finite])
        # zero drawn at a floor below everything, "never detected by one side" above
        shown = [floor if e <= 0 else (ceiling if math.isinf(e) else e) for e in err]
        front = tolerated_front(cost, err, [c.ok for c in comps])
        for i, c in enumerate(comps):
            rec = c is study.recommended_comparison
            marker = "*" if rec else ("^" if math.isinf(err[i]) else
                                      ("v" if err[i] <= 0 else "o"))
            color = "tab:green" if rec else ("tab:blue" if c.ok else "tab:red")
            ax.errorbar(cost[i], shown[i], xerr=[[lo[i]], [hi[i]]], fmt="none",
                        ecolor=color, elinewidth=0.8, alpha=0.6, zorder=2)
            ax.scatter(cost[i], shown[i], s=110 if rec else 30, c=color, marker=marker,
                       zorder=3)
        labels = [("combined" if c.result.setting.kind == "combined"
                   else c.result.setting.label) for c in comps]
        ax.plot([cost[i] for i in front], [shown[i] for i in front], "k--", lw=1,
                label="Pareto front (inside the tolerances)")
        ax.axhline(tol, color="tab:orange", lw=1, label="tolerance")
        ax.axvline(1.0 - SAVING_MIN, color="0.6", lw=0.8, ls=":",
                   label=f"cheaper: interval left of {1 - SAVING_MIN:g}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"{study.objective} CPU / the reference's ({CONFIDENCE:.0%} interval)")
        ax.set_ylabel(name)
        ax.grid(True, which="both", alpha=0.3)
        # below the axes: the labels then have the whole plot
        ax.legend(fontsize=8, title="▼ zero, ▲ detected by one side only", title_fontsize=7,
                  loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2)
        place_labels(ax, cost, shown, labels)
    fig.suptitle(f"{study.scenario.name}: error against cost ({study.duration_s:g} s, "
                 f"{len(study.seeds)} run(s), {study.pairs} timing pairs; blue inside the "
                 "tolerances, red outside, star recommended)", fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)


#: Label offsets tried around a point, in points (nearest first).
_LABEL_OFFSETS = [(dx * r, dy * r) for r in (1, 1.6, 2.4, 3.5, 5, 7)
                  for dx, dy in ((5, 4), (5, -11), (-5, 4), (-5, -11), (0, 12), (0, -18))]


def place_labels(ax: Any, x: Sequence[float], y: Sequence[float], labels: Sequence[str]
                 ) -> list[Any]:
    """Annotate each point with its label where it overlaps no other label or point.

    Greedy: the offsets of :data:`_LABEL_OFFSETS` are tried nearest first, and a label
    goes to the first place whose box (as drawn) lies inside the axes and meets no placed
    label and no marker; a label with no free place takes the farthest, with a leader line.
    Points at the same place share one label. Returns the annotations.
    """
    fig = ax.figure
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    groups: dict[tuple[float, float], list[str]] = {}
    for xi, yi, lb in zip(x, y, labels, strict=True):
        groups.setdefault((xi, yi), []).append(lb)
    pts = ax.transData.transform(np.array(list(groups), dtype=float))
    dots = [matplotlib_bbox(px - 4, py - 4, px + 4, py + 4) for px, py in pts]
    frame = ax.get_window_extent(renderer)
    placed: list[Any] = []
    boxes: list[Any] = []
    for (xy, names) in groups.items():
        text = ", ".join(names)
        ann = None
        for k, (dx, dy) in enumerate(_LABEL_OFFSETS):
            far = k == len(_LABEL_OFFSETS) - 1
            ann = ax.annotate(text, xy, xytext=(dx, dy), textcoords="offset points",
                              fontsize=6.5, ha="left" if dx >= 0 else "right",
                              arrowprops={"arrowstyle": "-", "lw": 0.4, "color": "0.5"}
                              if abs(dx) > 10 or abs(dy) > 20 else None)
            box = text_box(ann, renderer).expanded(1.02, 1.1)
            inside = (frame.x0 <= box.x0 and box.x1 <= frame.x1 and frame.y0 <= box.y0
                      and box.y1 <= frame.y1)
            if far or (inside and not any(box.overlaps(b) for b in boxes + dots)):
                break
            ann.remove()
        assert ann is not None
        boxes.append(text_box(ann, renderer))
        placed.append(ann)
    return placed


def text_box(ann: Any, renderer: Any) -> Any:
    """The box of an annotation's text alone (its leader line left out) [display units]."""
    from matplotlib.text import Text

    ann.update_positions(renderer)  # what Annotation.get_window_extent does first
    return Text.get_window_extent(ann, renderer)


def matplotlib_bbox(x0: float, y0: float, x1: float, y1: float) -> Any:
    """A display-coordinate box (matplotlib's Bbox)."""
    from matplotlib.transforms import Bbox

    return Bbox([[x0, y0], [x1, y1]])


# =========================================================================== --apply
def apply_fidelity(scenario_path: Path, fid: dict[str, Any], out: Path, *,
                   overwrite: bool = False, unread: Sequence[str] = ()) -> Path | None:
    """Write the scenario file with its ``fidelity:`` block replaced by ``fid``.

    ``unread``: choices the scene does not read under ``fid``, left out of the block
    (:func:`fidelity_yaml`; the schema's defaults then stand for them, unread).

    Everything else of the file is kept as written (comments included): a top-level
    ``fidelity:`` block is replaced in place, else the block is appended. The result is
    validated before anything is written, and written atomically. An existing ``out`` is
    refused unless ``overwrite``; then its former content is first kept beside it as
    ``OUT.bak`` (``OUT.bak.1``, ... if that exists), so nothing is lost.

    Returns
    -------
    Path or None
        The backup written, if any.

    Raises
    ------
    FileExistsError
        ``out`` exists and ``overwrite`` is False.
    ScenarioError
        The result does not validate.
    """
    from shipradar.sim.world.scenario import load_scenario

    text = Path(scenario_path).read_text(encoding="utf-8")
    lines = text.splitlines(keepends=True)
    block = fidelity_yaml(fid, unread)
    start = next((i for i, ln in enumerate(lines) if ln.startswith("fidelity:")), None)
    if start is None:
        new = text + ("" if text.endswith("\n") or not text else "\n") + block
    else:
        end = start + 1
        while end < len(lines) and (not lines[end].strip() or lines[end][0] in " \t#"):
            end += 1
        # trailing blank/comment lines belong to what follows
        while end > start + 1 and (not lines[end - 1].strip()
                                   or lines[end - 1].lstrip().startswith("#")):
            end -= 1
        new = "".join(lines[:start]) + block + "".join(lines[end:])
    out = Path(out)
    if out.exists() and not overwrite:
        raise FileExistsError(f"--apply: {out} exists; pass --overwrite to replace it (its "
                              "content is then kept as a .bak file)")
    fd, tmp = tempfile.mkstemp(dir=out.parent if str(out.parent) else ".",
                               prefix=f".{out.name}.", suffix=".tmp")
    backup = None
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(new)
        check = load_scenario(tmp)  # raises ScenarioError: nothing written
        read = set(Fidelity.model_fields) - set(unread)
        if check.fidelity.model_dump(include=read) != Fidelity(**fid).model_dump(include=read):
            raise ScenarioError(["--apply: the fidelity block did not round-trip"])
        if out.exists():
            backup = out.with_name(out.name + ".bak")
            n = 1
            while backup.exists():
                backup = out.with_name(f"{out.name}.bak.{n}")
                n += 1
            try:
                os.link(out, backup)  # the old file itself, kept under the new name
            except OSError:  # a file system without hard links
                backup.write_bytes(out.read_bytes())
        os.replace(tmp, out)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return backup


# =========================================================================== command line
def _number(name: str, lo: float, hi: float, integer: bool = False):
    def conv(text: str):
        try:
            v = int(text) if integer else float(text)
        except ValueError:
            v = None
        if v is None or not (lo <= v <= hi) or (not integer and not math.isfinite(v)):
            kind = "an integer" if integer else "a number"
            raise argparse.ArgumentTypeError(f"{name} must be {kind} in [{lo:g}, {hi:g}], "
                                             f"got {text!r}")
        return v

    return conv


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="shipradar fidelity",
        description="Measure the speed/accuracy trade of the fidelity choices on a scene, "
                    "with common random numbers, and recommend the cheapest setting inside "
                    "the tolerances (docs/accuracy.md).")
    p.add_argument("scenario", nargs="?", default=None, help="scenario YAML file")
    p.add_argument("--example", default=None, metavar="NAME",
                   help="a shipped example scenario instead of a file")
    p.add_argument("--duration", type=_number("--duration", 1e-3, 1e6), default=None,
                   metavar="S", help="simulated seconds per run (default: the scenario's)")
    p.add_argument("--runs", type=_number("--runs", 1, 1000, integer=True), default=1,
                   metavar="K", help="replications per setting, common seeds (default 1)")
    p.add_argument("--tolerance-pd", type=_number("--tolerance-pd", 0.0, 1.0), default=0.02,
                   metavar="X", help="largest mean |ΔP_d| per look of any target (default 0.02)")
    p.add_argument("--tolerance-range-m", type=_number("--tolerance-range-m", 0.0, 1e6),
                   default=500.0, metavar="M",
                   help="largest |Δ first-detection range| of any target [m] (default 500)")
    p.add_argument("--tolerance-fa", type=_number("--tolerance-fa", 0.0, 100.0), default=0.1,
                   metavar="R", help="largest relative change of the expected false alarms "
                                     "per scan of any radar and origin (default 0.1)")
    p.add_argument("--max-latency-s", type=_number("--max-latency-s", 0.0, 1e4), default=None,
                   metavar="S", help="largest plot latency (one sector) [s] (default: the "
                                     "scene's own)")
    p.add_argument("--all", action="store_true", dest="include_unexercised",
                   help="also run the choices the scene does not exercise")
    p.add_argument("--cold", action="store_true",
                   help=f"also measure the table builds: every distinct table built "
                        f"{BUILD_REPEATS} times in a private empty cache (else the cost "
                        "model's estimate is shown)")
    p.add_argument("--pairs", type=_number("--pairs", 2, 1000, integer=True),
                   default=DEFAULT_PAIRS, metavar="N",
                   help="alternating timing pairs (reference, setting) per setting "
                        f"(default {DEFAULT_PAIRS})")
    p.add_argument("--optimise", choices=OBJECTIVES, default="per-run",
                   help="the cost the recommendation minimises: per-run (warm run CPU, a "
                        "Monte Carlo study's replications; default) or first-run (table load "
                        "+ the first run of a process)")
    p.add_argument("--allow-shortened", action="store_true",
                   help="let --apply write a recommendation measured over a shortened "
                        "--duration (it holds for that span only)")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="write fidelity.csv and fidelity.png there")
    p.add_argument("--apply", default=None, metavar="OUT.yaml",
                   help="write the scenario with the recommended fidelity block")
    p.add_argument("--overwrite", action="store_true",
                   help="let --apply replace an existing file (kept as OUT.yaml.bak)")
    p.add_argument("--per-target", action="store_true",
                   help="also print one line per setting and (radar, target)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.add_argument("--max-build-s", type=_number("--max-build-s", 1e-3, 1e9), default=None,
                   metavar="S", help="longest estimated time to build the tables of every "
                   "setting [s]; over it the study is refused before any work (default "
                   "$SHIPRADAR_MAX_BUILD_S or 600)")
    return p


def _build_time(scenario: Scenario, args) -> list[str]:
    """The tables every setting of the study needs, estimated before any work (one line
    each for the missing ones); raises shipradar.tables.budget.BuildTimeError over the limit."""
    from shipradar.tables.budget import announce_builds, check_build_time

    _, settings, _ = plan_settings(scenario, include_unexercised=args.include_unexercised)
    variants = [_with_fidelity(scenario, s.fidelity) for s in settings]
    return announce_builds(check_build_time(scenario, args.max_build_s, suggest=False,
                                            variants=variants, cold=args.cold))


def cli_main(argv: Sequence[str]) -> int:
    """``shipradar fidelity ...``; exit 0, 2 on bad input, 1 on failure."""
    from shipradar.sim.world.scenario import load_scenario

    try:
        args = build_parser().parse_args(list(argv))
    except SystemExit as exc:
        return int(exc.code or 0)
    if (args.scenario is None) == (args.example is None):
        print("shipradar fidelity: give a scenario path or --example NAME (not both)",
              file=sys.stderr)
        return 2
    path = args.scenario
    if args.example is not None:
        from shipradar.scenarios import example_path

        try:
            path = str(example_path(args.example))
        except KeyError as exc:
            print(exc.args[0], file=sys.stderr)
            return 2
    try:
        scenario = load_scenario(path)
    except ScenarioError as exc:
        print("\n".join(f"{path}: {ln}" for ln in exc.lines), file=sys.stderr)
        return 2
    out_dir = Path(args.out) if args.out else None
    if out_dir is not None and out_dir.exists() and not out_dir.is_dir():
        print(f"--out: {out_dir} exists and is not a directory", file=sys.stderr)
        return 2
    if args.apply and Path(args.apply).exists() and not args.overwrite:
        print(f"--apply: {args.apply} exists; pass --overwrite to replace it (its content is "
              "then kept as a .bak file)", file=sys.stderr)
        return 2
    if args.apply and not Path(args.apply).resolve().parent.is_dir():
        print(f"--apply: the folder of {args.apply} does not exist", file=sys.stderr)
        return 2
    if (args.apply and args.duration is not None and args.duration < scenario.duration_s
            and not args.allow_shortened):
        print(f"--apply: --duration {args.duration:g} s is shorter than the scene's "
              f"{scenario.duration_s:g} s; a recommendation measured over the first "
              f"{args.duration:g} s holds for that span only (drop --duration, or pass "
              "--allow-shortened)", file=sys.stderr)
        return 2
    tol = Tolerances(args.tolerance_pd, args.tolerance_range_m, args.tolerance_fa,
                     args.max_latency_s)
    from shipradar.tables.budget import BuildTimeError

    try:
        lines = _build_time(scenario, args)
    except BuildTimeError as exc:
        print(str(exc), file=sys.stderr)
        return 2
    for line in lines:
        print(line, file=sys.stderr)
    study = run_fidelity_study(scenario, duration_s=args.duration, runs=args.runs,
                               tolerances=tol, include_unexercised=args.include_unexercised,
                               log=None if args.quiet else sys.stderr, pairs=args.pairs,
                               objective=args.optimise, measure_builds=args.cold)
    print(format_report(study))
    if args.per_target:
        print()
        print(format_per_target(study))
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
        write_csv(study, out_dir / "fidelity.csv")
        plot_pareto(study, out_dir / "fidelity.png")
        print(f"wrote {out_dir / 'fidelity.csv'} and {out_dir / 'fidelity.png'}")
    if args.apply:
        try:
            backup = apply_fidelity(Path(path), study.recommended, Path(args.apply),
                                    overwrite=args.overwrite, unread=study.unread)
        except FileExistsError as exc:
            print(str(exc), file=sys.stderr)
            return 2
        except ScenarioError as exc:
            print("\n".join(exc.lines), file=sys.stderr)
            return 1
        print(f"wrote {args.apply}" + (f" (former content kept as {backup})" if backup else ""))
    return 0
