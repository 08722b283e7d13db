"""Memory and time the off-line tables of a scene will take, checked before anything is built.

A PE table grows with the frequency (its height step is a fraction of a wavelength) times
the instrumented range (its range steps), and a scene with a millimetre-wave radar and a long
range can ask for tens of gigabytes: the run would thrash or be killed by the kernel after
minutes of work. :func:`check_memory_budget` estimates each table from the same grid rules
the builders use and refuses the scene at once, naming the field that drives the size.

The same grid rules give each table's build time (:func:`estimate_build`): a few cost
constants per kind of table, fitted once by ``benchmarks/build_cost.py`` on this machine,
turn the grid's work units into seconds. Before building, the commands print one line per
table still missing from the cache, and :func:`check_build_time` refuses a scene whose
tables would take longer than ``--max-build-s``, naming the field that drives the time and
the cheaper ``fidelity`` setting that would fit (docs/stability.md §4).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace

from shipradar.sim.world.errors import BadInputError
from shipradar.sim.world.scenario import Scenario

__all__ = [
    "DEFAULT_MAX_BUILD_S",
    "DEFAULT_MEMORY_BUDGET_MIB",
    "BuildEstimate",
    "BuildTimeError",
    "MemoryBudgetError",
    "TableEstimate",
    "announce_builds",
    "check_build_time",
    "check_memory_budget",
    "build_seconds",
    "estimate_build",
    "estimate_tables",
    "max_build_seconds",
    "memory_budget_bytes",
]

#: Default budget for the tables of one scene [MiB]; ``--memory-budget`` or the environment
#: variable ``SHIPRADAR_MEMORY_BUDGET_MIB`` change it.
DEFAULT_MEMORY_BUDGET_MIB: int = 4096
# Bytes per PE output cell while the table is built: the float32 rows, their stacked copy
# and the boolean "beyond the angles carried" mask (shipradar.sensors.parabolic_equation.solve_pe).
_PE_BYTES_PER_CELL = 4 + 4 + 1
# Bytes per clutter-map cell: eight float64 fields (power, sigma0, sigma0_diff, a, Doppler
# mean and spread, ...) and as many temporaries while they are computed.
_CLUTTER_BYTES_PER_CELL = 2 * 8 * 8


class MemoryBudgetError(ValueError, BadInputError):
    """The scene's tables would not fit in the memory budget (one line, field and size)."""


@dataclass(frozen=True)
class TableEstimate:
    """Estimated peak memory of one table while it is built [bytes], and why."""

    radar_index: tuple[int, int]
    radar_id: str
    kind: str
    bytes: int
    field: str
    detail: str


def memory_budget_bytes(mib: float | None = None) -> int:
    """The budget [bytes]: ``mib`` if given, else the environment's, else the default."""
    if mib is None:
        env = os.environ.get("SHIPRADAR_MEMORY_BUDGET_MIB")
        if env:
            try:
                mib = float(env)
            except ValueError:
                raise MemoryBudgetError(
                    f"SHIPRADAR_MEMORY_BUDGET_MIB must be a number of MiB, got {env!r}") from None
            if not mib > 0:
                raise MemoryBudgetError(f"SHIPRADAR_MEMORY_BUDGET_MIB must be > 0, got {env}")
        else:
            mib = DEFAULT_MEMORY_BUDGET_MIB
    return int(mib * 2**20)


def _fmt(n: float) -> str:
    for unit, size in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if n >= size:
            return f"{n / size:.1f} {unit}"
    return f"{n:.0f} B"


def estimate_tables(scenario: Scenario) -> list[TableEstimate]:
    """Estimated build memory of each PE table, I_F table and clutter map of the scene.

    Uses the builders' own grid rules (:func:`shipradar.sensors.parabolic_equation.grid_steps`,
    :func:`shipradar.tables.scene.clutter_grid_size`) without building anything; the estimate covers
    the output arrays and their temporaries, not the PE's working field (a few columns).
    """
    import numpy as np
    import scipy.constants as sc

    from shipradar.sensors import propagation as prop
    from shipradar.sensors.parabolic_equation import grid_steps, pe_top_height
    from shipradar.tables.clutter import sea_map_ranges
    from shipradar.tables.scene import (
        clutter_grid_size,
        pe_table_height_m,
        refractivity_profile,
    )

    out: list[TableEstimate] = []
    fid = scenario.fidelity
    profile = None
    for pi, platform in enumerate(scenario.platforms):
        for ri, radar in enumerate(platform.radars):
            where = f"platforms[{pi}].radars[{ri}]"
            if fid.propagation == "pe":
                if profile is None:
                    profile = prop.profile_from_spec(refractivity_profile(scenario))
                max_height = pe_table_height_m(scenario, radar)
                steps = grid_steps(
                    radar.frequency_hz,
                    pe_top_height(max_height, radar.instrumented_range_m,
                                  radar.antenna_height_m),
                    radar.instrumented_range_m, profile, fid.pe_grid,
                    polarization=radar.polarization)
                lam = sc.c / radar.frequency_hz
                decim = max(1, round(lam / (4 * np.sin(steps["max_angle_rad"])) / steps["dz"]))
                n_h = int(max_height / (decim * steps["dz"])) + 2
                n_r = int(math.ceil(radar.instrumented_range_m / steps["dx"]))
                # which axis makes the table big: heights follow the wavelength, ranges the
                # instrumented range
                field = "frequency_hz" if n_h >= n_r else "instrumented_range_m"
                out.append(TableEstimate(
                    (pi, ri), radar.id, "propagation", n_r * n_h * _PE_BYTES_PER_CELL,
                    f"{where}.{field}",
                    f"PE table {n_r} ranges x {n_h} heights (frequency_hz "
                    f"{radar.frequency_hz:g} Hz, instrumented_range_m "
                    f"{radar.instrumented_range_m:g} m, heights to {max_height:g} m, "
                    f"pe_grid {fid.pe_grid!r})"))
            if radar.processor.type != "none":
                _, size, field, detail = _improvement_estimate(scenario, radar, where)
                out.append(TableEstimate((pi, ri), radar.id, "improvement", size, field,
                                         detail))
            if fid.clutter:
                n_range, n_az = clutter_grid_size(radar)
                # the sea map's near-range nodes (tables.clutter.sea_map_ranges) counted for both
                n_range = sea_map_ranges(radar.instrumented_range_m, n_range,
                                         radar.antenna_height_m).size
                maps = 2 if scenario.environment.rain is not None else 1
                out.append(TableEstimate(
                    (pi, ri), radar.id, "clutter", maps * n_range * n_az
                    * _CLUTTER_BYTES_PER_CELL, f"{where}.instrumented_range_m",
                    f"clutter map{'s' if maps > 1 else ''} {n_range} ranges x {n_az} azimuths"))
    return out


def check_memory_budget(scenario: Scenario, budget_bytes: int | None = None) -> int:
    """Refuse a scene whose tables would exceed the memory budget, before any work.

    Parameters
    ----------
    scenario : Scenario
        The validated scene.
    budget_bytes : int or None, optional
        The budget [bytes]; default :func:`memory_budget_bytes`.

    Returns
    -------
    int
        The estimated total [bytes].

    Raises
    ------
    MemoryBudgetError
        One line naming the field that drives the largest table, the estimated total and
        the budget.
    """
    budget = memory_budget_bytes() if budget_bytes is None else int(budget_bytes)
    estimates = estimate_tables(scenario)
    total = sum(e.bytes for e in estimates)
    if total > budget:
        worst = max(estimates, key=lambda e: e.bytes)
        raise MemoryBudgetError(
            f"{worst.field}: the scene's tables need an estimated {_fmt(total)}, over the "
            f"memory budget of {_fmt(budget)} (--memory-budget); the largest is radar "
            f"{worst.radar_id!r}'s {worst.detail} at {_fmt(worst.bytes)}; lower that field, "
            f"use a coarser fidelity (pe_grid, propagation: two_ray) or raise the budget")
    return total


# =========================================================================== build time
#: Default limit on the estimated build time of a scene's missing tables [s];
#: ``--max-build-s`` or the environment variable ``SHIPRADAR_MAX_BUILD_S`` change it.
DEFAULT_MAX_BUILD_S: float = 600.0

#: Cost constants [s per work unit], fitted by ``benchmarks/build_cost.py`` (non-negative
#: least squares on the relative error, one kind at a time) on 43 tables of 0.01-5 s:
#: fitted/measured 0.32-1.29 on the tables over 0.5 s (0.56-1.29 for the PE). Machine: the
#: project's container, x86_64, 2 cores shared with other work, Python 3.11.7,
#: numpy/OpenBLAS, 2026-11-26. Re-run the benchmark and paste its output here on another
#: machine: the estimates are stated as estimates ("~12 s est."), a factor 2 either way is
#: expected.
COST = {
    # PE march: per (range step x height node x log2(height nodes)); the rough-sea
    # impedance rebuilt at every step: per (range step x height node); the table's cells
    # interpolated from the field (windowed sinc, reference phase); every table cell
    # (alignment, modulus, saving)
    "pe_march": 3.09e-09,
    "pe_rough": 8.58e-08,
    "pe_sample": 1.24e-06,
    "pe_cell": 3.04e-08,
    # improvement factor: per steering exponential (direct path), per filter-tap-Doppler
    # product, per grid cell, per table
    "if_exp": 7.29e-08,
    "if_mac": 1.49e-10,
    "if_cell": 1.88e-07,
    "if_fixed": 0.0255,
    # clutter maps and P_fac, per (range x azimuth) node; atmosphere: per table
    "sea_cell": 2.86e-07,
    "weather_cell": 7.72e-08,
    "pfac_cell": 2.29e-07,
    "atmosphere": 0.00356,
    # P_d table: per (N_e x S/I) node of the exact method
    "pd_cell": 7.43e-07,
}


class BuildTimeError(ValueError, BadInputError):
    """The scene's missing tables would take longer than the limit (one line)."""


@dataclass(frozen=True)
class BuildEstimate:
    """Estimated build of one table: time [s], size of its arrays [bytes], and why.

    ``field`` is the scenario field that drives the time (its path); ``work`` the grid's
    work units by cost constant (what :data:`COST` multiplies); ``cached`` whether the
    table is already in the cache (then nothing is built and it does not count).
    """

    radar_id: str
    kind: str
    seconds: float
    bytes: int
    field: str
    detail: str
    cached: bool
    key: str
    work: dict[str, float]


def max_build_seconds(seconds: float | None = None) -> float:
    """The limit [s]: ``seconds`` if given, else the environment's, else the default."""
    if seconds is not None:
        return float(seconds)
    env = os.environ.get("SHIPRADAR_MAX_BUILD_S")
    if not env:
        return DEFAULT_MAX_BUILD_S
    try:
        value = float(env)
    except ValueError:
        raise BuildTimeError(
            f"SHIPRADAR_MAX_BUILD_S must be a number of seconds, got {env!r}") from None
    if not value > 0:
        raise BuildTimeError(f"SHIPRADAR_MAX_BUILD_S must be > 0, got {env}")
    return value


def fmt_seconds(t: float) -> str:
    """A duration for a person: ``0.3 s``, ``12 s``, ``4 min``, ``1.5 h``."""
    if t < 10:
        return f"{t:.1f} s"
    if t < 120:
        return f"{t:.0f} s"
    if t < 2 * 3600:
        return f"{t / 60:.0f} min"
    return f"{t / 3600:.1f} h"


def _seconds(work: dict[str, float]) -> float:
    return sum(COST[k] * v for k, v in work.items())


def _pe_cost(radar, kwargs: dict) -> tuple[dict[str, float], dict]:
    from shipradar.tables.propagation import table_grid

    g = table_grid(radar.frequency_hz, **kwargs)
    march = g["n_steps"] * g["n"] * math.log2(max(g["n"], 2))
    cells = g["n_ranges"] * g["n_w"]
    work = {"pe_march": march, "pe_rough": g["n_steps"] * g["n"] if g["rough"] else 0.0,
            "pe_sample": g["sampled"], "pe_cell": cells}
    return work, g


#: Usual frequency [Hz] and PE range [m], against which the field that drives a PE
#: table's time is named.
_USUAL_HZ = 10e9
_USUAL_RANGE_M = 100e3


def _pe_estimate(scenario: Scenario, radar, where: str):
    from shipradar.tables.scene import pe_table_grid_kwargs

    kw = pe_table_grid_kwargs(scenario, radar)
    work, g = _pe_cost(radar, kw)
    # the field that drives the time: the one furthest above a usual value (X band, 100 km),
    # weighted by how the time scales with it (the exponent of a halving)
    t = max(_seconds(work), 1e-12)
    half_f = _seconds(_pe_cost(radar.model_copy(
        update={"frequency_hz": radar.frequency_hz / 2}), kw)[0])
    half_r = _seconds(_pe_cost(radar, {**kw, "max_range_m": kw["max_range_m"] / 2})[0])
    score_f = math.log2(t / max(half_f, 1e-12)) * math.log(radar.frequency_hz / _USUAL_HZ)
    score_r = math.log2(t / max(half_r, 1e-12)) * math.log(kw["max_range_m"] / _USUAL_RANGE_M)
    field = "frequency_hz" if score_f >= score_r else "instrumented_range_m"
    detail = (f"PE table {g['n_ranges']} ranges x {g['n_w']} h/R nodes, "
              f"{g['n_steps']} steps of {g['n']} height nodes (frequency_hz "
              f"{radar.frequency_hz:g} Hz, to {kw['max_range_m']:g} m and "
              f"{kw['max_height_m']:g} m, pe_grid {kw['fidelity']!r})")
    # values, field_re, field_im (float32)
    return work, g["n_ranges"] * g["n_w"] * 12, f"{where}.{field}", detail


def _improvement_estimate(scenario: Scenario, radar, where: str):
    from shipradar.tables import improvement as ti
    from shipradar.tables.scene import improvement_kwargs

    kw = improvement_kwargs(scenario, radar)
    inputs = None if kw is None else ti.improvement_table_inputs(radar.processor.type, **kw)
    if inputs is None:  # the scene has an improvement spec only when there are inputs
        raise ValueError(f"{radar.id}: the processor has no improvement-factor table")
    if inputs["processor"] == "mti":
        n_taps, n_filters = inputs["mti_pulses"], 1
    else:
        n_taps = inputs["n_pulses"]
        n_filters = inputs["n_filters"]
    spread, doppler = ti.improvement_axes(inputs, n_taps)
    n_s, n_d = spread.size, doppler.size
    stagger = "stagger_prf_hz" in inputs
    # every response evaluated with its own steering vector: 2 calls (grid and white limit);
    # a stagger's table is its weights' constant-PRF one (read at each bound), the same work
    work = {"if_exp": 2 * n_d * n_taps, "if_mac": 2 * n_filters * n_taps * n_d,
            "if_cell": n_s * n_d, "if_fixed": 1.0}
    field = "processor.n_coherent"
    detail = (f"improvement-factor table {n_s} spreads x {n_d} Dopplers, {n_filters} "
              f"filters of {n_taps} taps{' (staggered PRF)' if stagger else ''}, "
              f"improvement_grid {inputs['resolution']!r}")
    return work, n_s * n_d * 8 * 7, f"{where}.{field}", detail


def _clutter_estimate(kind: str, radar, where: str):
    from shipradar.tables.scene import clutter_grid_size

    n_r, n_az = clutter_grid_size(radar)
    if kind == "sea_clutter":  # the uniform axis and the near-range nodes
        from shipradar.tables.clutter import sea_map_ranges

        n_r = sea_map_ranges(radar.instrumented_range_m, n_r, radar.antenna_height_m).size
    if kind == "weather_clutter":  # the uniform axis and the nodes at the folds
        from shipradar.tables.clutter import weather_range_axis

        n_r = weather_range_axis(radar.instrumented_range_m, n_r, radar.prf_hz).size
    cost = {"sea_clutter": "sea_cell", "weather_clutter": "weather_cell", "pfac": "pfac_cell"}
    what = {"sea_clutter": "sea-clutter map", "weather_clutter": "weather-clutter map",
            "pfac": "P_fac map"}[kind]
    return ({cost[kind]: n_r * n_az}, n_r * n_az * 8 * (8 if kind != "pfac" else 4),
            f"{where}.instrumented_range_m", f"{what} {n_r} ranges x {n_az} azimuths")


def _spec_estimate(scenario: Scenario, spec, radar, where: str):
    if spec.kind == "propagation":
        return _pe_estimate(scenario, radar, where)
    if spec.kind == "improvement":
        return _improvement_estimate(scenario, radar, where)
    if spec.kind == "atmosphere":
        from shipradar.tables.scene import atmosphere_axes

        n_r, n_el = (a.size for a in atmosphere_axes(radar))
        return ({"atmosphere": 1.0}, n_r * n_el * 8 * 3, "fidelity.atmosphere",
                f"gas/fog loss table {n_r} ranges x {n_el} elevations")
    return _clutter_estimate(spec.kind, radar, where)


def _pd_estimates(scenario: Scenario) -> list[BuildEstimate]:
    """The exact-P_d tables a run builds when ``fidelity.pd_method`` is ``table`` (the dwell
    model asks for them when it starts, one per Swerling case of the scene's targets)."""
    if scenario.fidelity.pd_method != "table" or not (scenario.targets or scenario.traffic):
        return []
    from shipradar.sensors.radar import false_alarm_probability, pulses_per_beamwidth
    from shipradar.sim.world.traffic import scene_targets
    from shipradar.tables import pd as tpd
    from shipradar.tables.store import inputs_hash, is_cached

    out = []
    cases = sorted({int(c) for c in scene_targets(scenario).swerling})
    for pi, platform in enumerate(scenario.platforms):
        for ri, radar in enumerate(platform.radars):
            pfa = false_alarm_probability(radar)
            n_max = pulses_per_beamwidth(radar)
            for case in cases:
                inputs = tpd.pd_table_inputs(pfa, case, n_max)
                n_axis, snr = tpd.pd_table_axes(inputs)
                cells = n_axis.size * snr.size
                work = {"pd_cell": float(cells)}
                out.append(BuildEstimate(
                    radar.id, "pd", _seconds(work), cells * 8,
                    f"platforms[{pi}].radars[{ri}].prf_hz",
                    f"P_d table (Swerling {case}) {n_axis.size} N_e x {snr.size} S/I",
                    is_cached(tpd.NAME, tpd.VERSION, inputs),
                    f"{tpd.NAME}-{inputs_hash(tpd.NAME, tpd.VERSION, inputs)}", work))
    return out


def estimate_build(scenario: Scenario, *, include_pd: bool = True) -> list[BuildEstimate]:
    """Estimated build time and size of every table the scene reads, cached or not.

    From the builders' own grid rules (:func:`shipradar.tables.propagation.table_grid`,
    :func:`shipradar.tables.improvement.improvement_axes`,
    :func:`shipradar.tables.scene.clutter_grid_size`, ...) and the cost constants :data:`COST`;
    nothing is built. ``include_pd``: also the exact-P_d tables the run's dwell model builds
    (``tables build`` does not build them).
    """
    from shipradar.tables.scene import table_specs
    from shipradar.tables.store import inputs_hash

    where = {}
    radars = {}
    for pi, platform in enumerate(scenario.platforms):
        for ri, radar in enumerate(platform.radars):
            where[radar.id] = f"platforms[{pi}].radars[{ri}]"
            radars[radar.id] = radar
    out: list[BuildEstimate] = []
    seen: set[str] = set()
    for spec in table_specs(scenario):
        name, version, inputs = spec.key()
        key = f"{name}-{inputs_hash(name, version, inputs)}"
        if key in seen:  # two radars with one table: built once
            continue
        seen.add(key)
        work, size, field, detail = _spec_estimate(scenario, spec, radars[spec.radar_id],
                                                   where[spec.radar_id])
        out.append(BuildEstimate(spec.radar_id, spec.kind, _seconds(work), int(size), field,
                                 detail, spec.cached(), key, work))
    if include_pd:
        out.extend(e for e in _pd_estimates(scenario) if e.key not in seen)
    return out


def build_seconds(estimates: list[BuildEstimate]) -> dict[tuple[str, str], float]:
    """Estimated seconds by (radar id, table kind), 0 for a cached table: the progress bar's
    input (:func:`shipradar.tables.scene.load_scene_tables` ``estimated_s``)."""
    out: dict[tuple[str, str], float] = {}
    for e in estimates:
        key = (e.radar_id, e.kind)
        out[key] = out.get(key, 0.0) + (0.0 if e.cached else e.seconds)
    return out


def announce_builds(estimates: list[BuildEstimate]) -> list[str]:
    """One line per table still to build: what, its size and its estimated time."""
    return [f"building {e.radar_id} {e.kind} table: {e.detail}, {_fmt(e.bytes)}, "
            f"~{fmt_seconds(e.seconds)} est." for e in estimates if not e.cached]


def _missing_seconds(estimates: list[BuildEstimate]) -> float:
    return sum(e.seconds for e in estimates if not e.cached)


#: Cheaper fidelity settings tried, in order of the accuracy they give up (docs/accuracy.md):
#: (choice, value, the table kind it makes cheaper).
CHEAPER = (("pe_grid", "coarse", "propagation"),
           ("improvement_grid", "coarse", "improvement"),
           ("propagation", "two_ray", "propagation"))


def _cheaper_setting(scenario: Scenario, limit_s: float, include_pd: bool
                     ) -> tuple[str, float] | None:
    """The first cheaper ``fidelity`` change (alone, then accumulated) that fits the limit."""
    fid = scenario.fidelity.model_dump()
    kinds = {e.kind for e in estimate_build(scenario, include_pd=include_pd) if not e.cached}
    tried: dict[str, object] = {}
    for choice, value, kind in CHEAPER:
        if fid.get(choice) == value or kind not in kinds:
            continue
        for change in ({choice: value}, {**tried, choice: value}):
            if change.get("propagation") == "two_ray":
                change.pop("pe_grid", None)
            cheaper = scenario.model_copy(update={
                "fidelity": scenario.fidelity.model_copy(update=change)})
            t = _missing_seconds(estimate_build(cheaper, include_pd=include_pd))
            if t <= limit_s:
                what = " with ".join(f"fidelity.{k}: {v}" for k, v in change.items())
                return what, t
        tried[choice] = value
    return None


def check_build_time(scenario: Scenario, limit_s: float | None = None, *,
                     include_pd: bool = True, suggest: bool = True,
                     variants: list[Scenario] | None = None,
                     cold: bool = False) -> list[BuildEstimate]:
    """Refuse a scene whose missing tables would take longer than the limit to build.

    Parameters
    ----------
    scenario : Scenario
        The validated scene.
    limit_s : float or None, optional
        The limit [s]; default :func:`max_build_seconds`.
    include_pd : bool, optional
        Count the exact-P_d tables of a run (see :func:`estimate_build`).
    suggest : bool, optional
        Name the cheaper ``fidelity`` setting that would fit, if any.
    variants : list of Scenario, optional
        Scenes built one after the other (``shipradar fidelity``: the scene under each
        fidelity setting it compares); their tables are counted once each.
    cold : bool, optional
        Every table counts, cached or not (a build in an empty cache).

    Returns
    -------
    list of BuildEstimate
        Every table's estimate (the cached ones flagged), for :func:`announce_builds`.

    Raises
    ------
    BuildTimeError
        One line: the field that drives the longest missing table, the estimated total, the
        limit and the cheaper setting.
    """
    limit = max_build_seconds(limit_s)
    estimates = []
    seen: set[str] = set()
    for scene in variants or [scenario]:
        for e in estimate_build(scene, include_pd=include_pd):
            if e.key not in seen:
                seen.add(e.key)
                estimates.append(replace(e, cached=False) if cold else e)
    total = _missing_seconds(estimates)
    if total > limit:
        worst = max((e for e in estimates if not e.cached), key=lambda e: e.seconds)
        line = (f"{worst.field}: the scene's tables need an estimated {fmt_seconds(total)} "
                f"to build, over --max-build-s {limit:g}; the longest is radar "
                f"{worst.radar_id!r}'s {worst.detail} at ~{fmt_seconds(worst.seconds)}")
        cheaper = _cheaper_setting(scenario, limit, include_pd) if suggest else None
        if cheaper is not None:
            line += f"; {cheaper[0]} would take ~{fmt_seconds(cheaper[1])}"
        elif variants:
            line += ("; the study builds the tables of every fidelity setting it compares "
                     "(the reference's are the finest): lower that field or raise "
                     "--max-build-s")
        else:
            line += "; lower that field or raise --max-build-s"
        raise BuildTimeError(line)
    return estimates
