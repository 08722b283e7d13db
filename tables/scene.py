"""The tables one scene needs, built or loaded through the cache (off-line level, seed 2.1).

A scene builds only what it reads (SPEC §2): no rain, no weather-clutter map; clutter
switched off in the fidelity section, no sea-clutter map or P_fac map; no Doppler processor,
no improvement-factor table; propagation "free_space" or "two_ray", no PE table; atmosphere
switched off, no loss table.  Every table is keyed by a hash of exactly its inputs
(:mod:`shipradar.tables.store`), so ``shipradar tables build`` ahead of a run and the run itself
find the same files, and a Monte Carlo study builds each table once.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, TextIO

import numpy as np

from shipradar.sim.world.scenario import Jammer, Platform, Radar, Scenario, Target
from shipradar.tables.store import Table


@dataclass
class TableSpec:
    """One table a scene needs: which radar, what kind, and how to get it (cache or build).

    ``key`` gives the builder's name, version and inputs without building anything: the
    cache key of the table (:func:`shipradar.tables.store.is_cached`), which
    :mod:`shipradar.tables.budget` checks so that only the tables still to build are estimated and
    announced.
    """

    radar_id: str
    kind: str
    describe: str
    make: Callable[[], Table]
    key: Callable[[], tuple[str, int, dict[str, Any]]]

    def cached(self) -> bool:
        """Whether the table is already in the cache."""
        from shipradar.tables.store import is_cached

        return is_cached(*self.key())


@dataclass
class RadarTables:
    """The tables of one radar; ``None`` where the scene does not need that table."""

    atmosphere: Table | None = None
    propagation: Table | None = None
    sea_clutter: Table | None = None
    weather_clutter: Table | None = None
    improvement: Table | None = None
    pfac: Table | None = None


@dataclass
class SceneTables:
    radars: dict[str, RadarTables] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def for_radar(self, radar_id: str) -> RadarTables:
        return self.radars.setdefault(radar_id, RadarTables())

    def missing_lines(self) -> list[str]:
        return list(self.notes)


# --------------------------------------------------------------------------- specs
def atmosphere_axes(radar: Radar) -> tuple[np.ndarray, np.ndarray]:
    """Slant range [m] and elevation [rad] axes of the atmospheric-loss table (gas part).

    Ranges: 81 uniform nodes to 1.05 R_inst and 40 geometric ones from 50 m (the loss of a
    steep path saturates within a few scale heights).  Elevations: every
    :data:`ATMOSPHERE_HORIZON_STEP_DEG` from below the lowest ray that reaches the sea at the
    last range (at least -2°) to +2°, where the height along a long path, and so the loss,
    changes fastest with elevation; then 48 geometric nodes to 90° (nothing clamps).  The fog
    is evaluated exactly and points outside the axes integrated directly
    (:func:`shipradar.tables.atmosphere.lookup_gas_fog_loss_db`).  Measured against the direct
    quadrature at random points (docs/accuracy.md): within max(0.05 dB, 1 % of the loss) up to
    400 km at 10-94 GHz, the 60 GHz oxygen band (> 100 dB) aside.
    """
    from shipradar.sensors.atmosphere import ray_elevation_rad

    r_max = radar.instrumented_range_m * 1.05
    ranges = np.unique(np.concatenate([np.linspace(0.0, r_max, 81), np.geomspace(50.0, r_max, 40)]))
    step = ATMOSPHERE_HORIZON_STEP_DEG
    lowest = float(np.degrees(ray_elevation_rad(r_max, 0.0, radar.antenna_height_m))) - step
    low = min(-2.0, step * math.floor(lowest / step))
    horizon = np.linspace(low, 2.0, round((2.0 - low) / step) + 1)
    elev = np.radians(np.concatenate([horizon, np.geomspace(2.0, 90.0, 49)[1:]]))
    return ranges, elev


#: Elevation step of the atmospheric-loss table within ±2° of the horizon [deg].
ATMOSPHERE_HORIZON_STEP_DEG = 0.025


def table_specs(scenario: Scenario) -> list[TableSpec]:
    """Every table the scene reads, in build order."""
    specs: list[TableSpec] = []
    for platform, radar in scenario.radars():
        if scenario.fidelity.atmosphere:
            specs.append(_atmosphere_spec(scenario, platform, radar))
        specs.extend(_optional_specs(scenario, platform, radar))
    return specs


def _atmosphere_spec(scenario: Scenario, platform: Platform, radar: Radar) -> TableSpec:
    from shipradar.tables import atmosphere as ta

    env = scenario.environment
    ranges, elev = atmosphere_axes(radar)
    kw: dict[str, Any] = {
        "temperature_k": env.temperature_c + 273.15,
        "pressure_hpa": env.pressure_hpa,
        "water_vapour_density_g_m3": env.water_vapour_g_m3,
        "fog_lwc_g_m3": env.fog.liquid_water_g_m3 if env.fog else 0.0,
        "fog_top_m": env.fog.top_m if env.fog else 100.0,
        "antenna_height_m": radar.antenna_height_m,
    }

    def make() -> Table:
        return ta.atmospheric_loss_grid(radar.frequency_hz, ranges, elev, **kw)

    def key():
        return (ta.TABLE_NAME, ta.TABLE_VERSION,
                ta.atmospheric_loss_inputs(radar.frequency_hz, ranges, elev, **kw))

    return TableSpec(radar.id, "atmosphere", "one-way gas/fog loss vs slant range, elevation",
                     make, key)


def _optional_specs(scenario: Scenario, platform: Platform, radar: Radar) -> list[TableSpec]:
    """Propagation, clutter and improvement-factor tables (registered by their modules)."""
    out = []
    for provider in _PROVIDERS:
        out.extend(provider(scenario, platform, radar))
    return out


#: Functions ``(scenario, platform, radar) -> list[TableSpec]`` of the other table kinds.
_PROVIDERS: list[Callable[[Scenario, Platform, Radar], list[TableSpec]]] = []


def provider(fn):
    """Register a table-spec provider (decorator)."""
    _PROVIDERS.append(fn)
    return fn


# --------------------------------------------------------------------------- build / load
#: Missing tables estimated to take longer than this to build show a progress bar [s].
PROGRESS_ABOVE_S: float = 3.0

#: Estimated build seconds of a scene's tables, by (radar id, table kind); a cached table 0.
BuildSeconds = Mapping[tuple[str, str], float]


def _made(scenario: Scenario, progress: bool, estimated_s: BuildSeconds | None):
    """Yield ``(spec, table, seconds)`` for every table of the scene, cache first.

    ``progress`` (a terminal, or asked) with ``estimated_s`` (the cost model's seconds,
    :func:`shipradar.tables.budget.build_seconds`): when the missing tables are estimated to
    take more than :data:`PROGRESS_ABOVE_S`, a bar over their estimated seconds with tqdm's
    ETA (the PE march and a large I_F table add their own bar beneath it).
    """
    specs = table_specs(scenario)
    bar = None
    est = dict(estimated_s or {})
    total = sum(est.values())
    if progress and total > PROGRESS_ABOVE_S:
        from tqdm import tqdm

        bar = tqdm(total=round(total, 1), desc="tables", unit="s est.", file=sys.stderr,
                   leave=False, bar_format="{desc}: {percentage:3.0f}%|{bar}| "
                   "{n:.0f}/{total:.0f} s est. [{elapsed}<{remaining}] {postfix}")
    try:
        for spec in specs:
            if bar is not None:
                bar.set_postfix_str(f"{spec.radar_id} {spec.kind}")
            t0 = time.perf_counter()
            table = spec.make()
            if bar is not None:
                bar.update(round(est.get((spec.radar_id, spec.kind), 0.0), 1))
            yield spec, table, time.perf_counter() - t0
    finally:
        if bar is not None:
            bar.close()


def _say(line: str, log: TextIO | None, progress: bool) -> None:
    """Print a log line, above the progress bar when there is one."""
    if log is None:
        return
    if progress:
        from tqdm import tqdm

        tqdm.write(line, file=log)
    else:
        print(line, file=log)


def load_scene_tables(scenario: Scenario, *, progress: bool = False,
                      log: TextIO | None = None,
                      estimated_s: BuildSeconds | None = None) -> SceneTables:
    """Load every table the scene needs from the cache, building the missing ones.

    ``progress`` shows a bar over the estimated build seconds (``estimated_s``, see
    :func:`_made`) on stderr; ``log`` gets a line for each table that took more than a
    second (a build rather than a cache hit).
    """
    scene = SceneTables()
    for _platform, radar in scenario.radars():
        scene.for_radar(radar.id)
    for spec, table, dt in _made(scenario, progress, estimated_s):
        if dt > 1.0:
            _say(f"{spec.radar_id}: {spec.kind} table ready in {dt:.1f} s", log, progress)
        setattr(scene.for_radar(spec.radar_id), spec.kind, table)
    return scene


def build_scene_tables(scenario: Scenario, *, progress: bool = False,
                       log: TextIO | None = sys.stderr,
                       estimated_s: BuildSeconds | None = None) -> dict[str, Any]:
    """Build (or find in the cache) every table of the scene; a JSON-able report.

    ``progress`` and ``estimated_s`` as :func:`load_scene_tables`.
    """
    from shipradar.tables.sky import scene_radar_constants
    from shipradar.tables.store import cache_path

    for _platform, radar in scenario.radars():  # the sky temperatures the runs read
        scene_radar_constants(scenario, radar)
    rows = []
    for spec, table, dt in _made(scenario, progress, estimated_s):
        rows.append({
            "radar": spec.radar_id,
            "kind": spec.kind,
            "what": spec.describe,
            "key": table.key,
            "file": str(cache_path(table.name, table.key)),
            "shape": list(table.values.shape),
            "seconds": round(dt, 3),
        })
        _say(f"{spec.radar_id}: {spec.kind} {table.values.shape} in {dt:.2f} s", log, progress)
    return {"scenario": scenario.name, "tables": rows}


# --------------------------------------------------------------------------- providers
def improvement_kwargs(scenario: Scenario, radar: Radar) -> dict[str, Any] | None:
    """Keywords of :func:`shipradar.tables.improvement.improvement_table` for a radar's
    processor."""
    proc = radar.processor
    if proc.type == "none":
        return None
    kw: dict[str, Any] = {"resolution": scenario.fidelity.improvement_grid}
    if proc.type in ("mti", "mti_bank"):
        kw["mti_pulses"] = proc.mti_order + 1  # an N_pc-order canceller uses N_pc + 1 pulses
    if proc.type in ("dft_bank", "fir_bank", "mti_bank"):
        kw["n_pulses"] = proc.n_coherent
        kw["window"] = proc.window.type
        if proc.window.type in ("taylor", "chebyshev"):
            kw["window_sidelobe_db"] = proc.window.sidelobe_db
        if proc.n_filters is not None:
            kw["n_filters"] = proc.n_filters
    if radar.stagger_prf_hz:
        kw["prf_hz"] = radar.prf_hz
        kw["stagger_prf_hz"] = list(radar.stagger_prf_hz)
    return kw


@provider
def _improvement_specs(scenario: Scenario, platform: Platform, radar: Radar) -> list[TableSpec]:
    """I_F(σ_s/f_r, f_d/f_r) [57]: read only when clutter can dominate, so only with clutter."""
    kw = improvement_kwargs(scenario, radar)
    if kw is None or not scenario.fidelity.clutter:
        return []
    from shipradar.tables import improvement as ti

    def make() -> Table:
        table, _ = ti.improvement_table(radar.processor.type, **kw)
        if table is None:  # improvement_kwargs gave inputs, so the processor has a table
            raise RuntimeError(f"{radar.id}: no improvement table for {radar.processor.type}")
        return table

    def key():
        return (ti.BUILDER_NAME, ti.BUILDER_VERSION,
                ti.improvement_table_inputs(radar.processor.type, **kw))

    return [TableSpec(radar.id, "improvement", "improvement factor vs spread and Doppler", make,
                      key)]


def clutter_grid_size(radar: Radar) -> tuple[int, int]:
    """Clutter map grid: range step near a tenth of the range cell-limited detail, capped.

    The map is smooth in range except near the horizon and the duct transition; 100 m steps
    (at most 3001 nodes) and 1° in azimuth resolve both against the GIT's wind-direction term.
    """
    n_range = int(min(3001, max(201, radar.instrumented_range_m / 100.0 + 1)))
    return n_range, 360


@provider
def _clutter_specs(scenario: Scenario, platform: Platform, radar: Radar) -> list[TableSpec]:
    """Sea-clutter map [21]-[38] (and weather map [39]-[45] only when it rains)."""
    if not scenario.fidelity.clutter:
        return []
    from shipradar.sim.world.kinematics import ship_motion
    from shipradar.tables import clutter as tc
    from shipradar.tables.sky import scene_radar_constants

    env = scenario.environment
    k = scene_radar_constants(scenario, radar, store=False)  # an estimate writes nothing
    speed, course = ship_motion(platform)
    n_range, n_az = clutter_grid_size(radar)
    duct = 0.0
    if env.duct is not None:
        duct = duct_height_m(scenario)
    common: dict[str, Any] = {
        "freq_hz": radar.frequency_hz,
        "antenna_height_m": radar.antenna_height_m,
        "beamwidth_az_rad": k.theta_b,
        "pulse_width_s": radar.pulse_width_s,
        "radar_constant_w_m2": k.k_r0,
        "rotation_rate_rad_s": 2 * math.pi / radar.scan_period_s,
        "wind_speed_mps": env.wind_speed_mps,
        "wind_direction_rad": math.radians(env.wind_direction_deg),
        "max_range_m": radar.instrumented_range_m,
        "motion_compensated": radar.processor.motion_compensated,
        "ship_speed_mps": speed,
        "ship_heading_rad": course,
        "n_range": n_range,
        "n_azimuth": n_az,
    }
    sea: dict[str, Any] = {
        "polarization": radar.polarization,
        "elevation_pattern": k.pattern_key(radar),
        "noise_power_w": k.n0,
        "wave_height_m": scenario.wave_height,
        "sea_state": env.sea_state,
        "duct_height_m": duct,
        "a_min": radar.a_min,
        **common,
    }
    specs = [TableSpec(
        radar.id, "sea_clutter", "sea-clutter power, σ0*, Weibull a, spectrum vs range, azimuth",
        lambda: tc.sea_clutter_map(elevation_directivity=k.elevation_pattern(radar), **sea)[0],
        lambda: (tc.SEA_MAP_NAME, tc.SEA_MAP_VERSION, tc.sea_clutter_map_inputs(**sea)))]
    if env.rain is not None:
        weather: dict[str, Any] = {
            "beamwidth_el_rad": k.phi_b,
            "prf_hz": radar.prf_hz,
            "rain_rate_mm_h": env.rain.rate_mm_h,
            "cloud_base_m": env.rain.cloud_base_m,
            "precipitation": env.rain.kind,
            **common,
        }

        def wet() -> dict[str, Any]:
            # the rain's γ_r on each trip's way [3], [16], as the targets get it (none with
            # the atmosphere switched off); asked only when the map's key is (itur: 0.6 s)
            return {**weather, "rain_attenuation_db_per_km": weather_rain_attenuation_db_per_km(
                scenario, radar)}

        specs.append(TableSpec(
            radar.id, "weather_clutter", "weather-clutter power and spectrum vs range, azimuth",
            lambda: tc.weather_clutter_map(**wet())[0],
            lambda: (tc.WEATHER_MAP_NAME, tc.WEATHER_MAP_VERSION,
                     tc.weather_clutter_map_inputs(**wet()))))
    return specs


def weather_rain_attenuation_db_per_km(scenario: Scenario, radar: Radar) -> float:
    """γ_r [dB/km] (ITU-R P.838, one way, horizontal) the weather-clutter map's trips carry.

    The same number the dwell model puts on the targets' paths: the rain-equivalent rate of
    the scene's precipitation at the radar's frequency and polarisation, from the table
    store; 0 without rain or with ``fidelity.atmosphere`` off (no [16] loss at all then).
    """
    rain = scenario.environment.rain
    if rain is None or not scenario.fidelity.atmosphere:
        return 0.0
    from shipradar.sensors.weather_clutter import rain_equivalent_rate_mm_h
    from shipradar.tables.sky import rain_attenuation_db_per_km

    rate = float(rain_equivalent_rate_mm_h(rain.rate_mm_h, rain.kind))
    return rain_attenuation_db_per_km(radar.frequency_hz, rate, radar.polarization,
                                      store=False)


def duct_height_m(scenario: Scenario) -> float:
    """Height [m] of the surface duct, as the sea-clutter ducting extension [22]-[29] reads it.

    Given, or from the bulk model of :mod:`shipradar.sensors.propagation`; for an M-profile, the
    height of its lowest minimum when that minimum is at or below the surface value (a surface-based
    duct, seen by the clutter like an evaporation duct of that height), else 0 (an elevated
    duct leaves the sea-clutter horizon alone; the PE table still carries its effect on F).
    """
    from shipradar.sensors.propagation import evaporation_duct_height, surface_duct_height

    duct = scenario.environment.duct
    if duct is None:
        return 0.0
    if duct.type == "height":
        return duct.height_m
    if duct.type == "profile":
        return surface_duct_height(duct.heights_m, duct.m_units)
    env = scenario.environment
    return float(evaporation_duct_height(
        duct.air_temperature_c, duct.sea_temperature_c, duct.relative_humidity,
        env.wind_speed_mps, duct.pressure_hpa))


@provider
def _pfac_specs(scenario: Scenario, platform: Platform, radar: Radar) -> list[TableSpec]:
    """P_fac map (seed 7.2): clutter on and a medium/high-resolution radar only
    (shipradar.tables.pfac).

    The sea-clutter map comes from the scene's own clutter spec (same inputs, so a cache hit
    after :func:`_clutter_specs` has built it); the [94]-[95] reading from
    ``scenario.fidelity.clutter_fa_model``.
    """
    if not scenario.fidelity.clutter:
        return []
    from shipradar.sensors.radar import false_alarm_probability
    from shipradar.sensors.sea_clutter import is_medium_high_resolution
    from shipradar.tables import pfac as tp

    theta_b = math.radians(radar.beamwidth_az_deg)
    if not bool(is_medium_high_resolution(theta_b, radar.pulse_width_s)):
        return []
    sea_spec = next(s for s in _clutter_specs(scenario, platform, radar) if s.kind == "sea_clutter")
    pfa = false_alarm_probability(radar)

    kw: dict[str, Any] = {"pfa": pfa, "k_clutter": radar.k_clutter,
                          "p_fac_max": radar.p_fac_max,
                          "clutter_fa_model": scenario.fidelity.clutter_fa_model}

    def key():
        return (tp.PFAC_MAP_NAME, tp.PFAC_MAP_VERSION,
                tp.pfac_map_inputs(sea_spec.key()[2], **kw))

    def make() -> Table:
        # keyed by the sea map's inputs, so the sea map (17-43 MB) is read only to build
        # (tp.pfac_map would read it first, a second time in every run)
        from shipradar.tables.store import get_or_build

        name, version, inputs = key()
        return get_or_build(name, version, inputs,
                            lambda: tp.build_pfac_map(sea_spec.make(), **kw))[0]

    return [TableSpec(radar.id, "pfac", "sea-clutter false-alarm probability P_fac per sector",
                      make, key)]


#: Highest height of a PE table [m]: above it targets are at elevations where ducts and the
#: parabolic equation add nothing over the two-ray model, which takes over there (counted).
PE_MAX_HEIGHT_M = 1500.0


def pe_table_height_m(scenario: Scenario, radar: Radar) -> float:
    """Top of a radar's PE table [m]: 20 % above the highest look, and 20 m more.

    The highest look is the highest altitude any target or jammer reaches (climbs and pop-ups
    included) or the radar's own antenna, whichever is higher: the PE starts its field at the
    antenna, so the table must hold it (an antenna above the highest target used to fall
    outside the table and stop the run). At least 100 m, at most :data:`PE_MAX_HEIGHT_M`
    (above it the two-ray model answers, counted as a fallback).
    """
    movers: list[Target | Jammer] = [*scenario.targets, *scenario.jammers]
    top = max([radar.antenna_height_m, *(m.max_altitude_m for m in movers)])
    if scenario.traffic:  # the highest fix of the traffic files
        from shipradar.sim.world.traffic import scene_targets

        top = max(top, scene_targets(scenario).max_altitude_m)
    if scenario.external is not None:  # the declared envelope of live entities
        top = max(top, scenario.external.max_altitude_m)
    return min(PE_MAX_HEIGHT_M, max(100.0, 1.2 * top + 20.0))


def refractivity_profile(scenario: Scenario) -> dict[str, Any]:
    """The scene's M-profile: the user's piecewise profile, an evaporation duct [7] or standard."""
    duct = scenario.environment.duct
    if duct is not None and duct.type == "profile":
        return {"kind": "piecewise", "heights_m": list(duct.heights_m),
                "m_units": list(duct.m_units)}
    h = duct_height_m(scenario)
    if h > 0.0:
        return {"kind": "evaporation", "duct_height_m": h}
    return {"kind": "standard"}


@provider
def _propagation_specs(scenario: Scenario, platform: Platform, radar: Radar) -> list[TableSpec]:
    """F(R_t, h) by the split-step PE [5]-[7], only when the scene asks for it."""
    if scenario.fidelity.propagation != "pe":
        return []
    from shipradar.tables import propagation as tp
    from shipradar.tables.sky import scene_radar_constants

    k = scene_radar_constants(scenario, radar, store=False)  # an estimate writes nothing
    kind, phi_b, sidelobe, tilt = k.pattern_key(radar)
    description = {"kind": kind, "beamwidth_rad": phi_b, "sidelobe_db": sidelobe,
                   "tilt_rad": tilt, "convention": "absolute elevation"}
    kw = pe_table_grid_kwargs(scenario, radar)
    kw.pop("antenna_height_m")

    def make() -> Table:
        return tp.get_propagation_table(
            freq_hz=radar.frequency_hz,
            antenna_height_m=radar.antenna_height_m,
            elevation_pattern=k.elevation_pattern(radar),
            pattern_description=description,
            **kw,
        )[0]

    def key():
        return (tp.TABLE_NAME, tp.TABLE_VERSION, tp.propagation_table_inputs(
            radar.frequency_hz, radar.antenna_height_m, pattern_description=description, **kw))

    return [TableSpec(radar.id, "propagation", "propagation factor F vs range, height (PE)",
                      make, key)]


def pe_table_grid_kwargs(scenario: Scenario, radar: Radar) -> dict[str, Any]:
    """The grid arguments of a radar's PE table (one rule for the builder and the budget):
    keywords of :func:`shipradar.tables.propagation.table_grid` and, with the pattern, of the
    builder."""
    kw = pe_table_grid_kwargs_uncapped(scenario, radar)
    kw["max_range_m"] = pe_table_range_m(scenario, radar, kw)
    return kw


#: Margin on the farthest ground range a target or jammer reaches (:func:`pe_table_range_m`):
#: relative, and absolute [m] (covers the chord/arc difference and a last range step).
PE_RANGE_MARGIN = 0.05
PE_RANGE_MARGIN_M = 1000.0


def pe_table_range_m(scenario: Scenario, radar: Radar, grid: dict[str, Any] | None = None
                     ) -> float:
    """Last range of a radar's PE table [m]: the instrumented range, or less on a large grid.

    F is read only at the targets' and jammers' positions (shipradar.sim.dwell.model). When the
    table to the instrumented range is a large grid
    (:data:`shipradar.sensors.parabolic_equation.LARGE_GRID_WORK`, e.g. a 100 GHz radar or a 1000 km
    instrumented range), it stops at the farthest ground range from the radar's platform that any
    target or jammer of the scene reaches, plus :data:`PE_RANGE_MARGIN` and
    :data:`PE_RANGE_MARGIN_M`: beyond it nothing is there to look up (a look beyond would fall back
    to the two-ray model and be counted). Targets exist only along their tracks and platforms and
    jammers hold their ends, so the farthest range holds for any run duration. Smaller grids keep
    the instrumented range (the shipped scenes' tables are unchanged).
    """
    from shipradar.sensors.parabolic_equation import LARGE_GRID_WORK
    from shipradar.tables.propagation import table_grid

    full = radar.instrumented_range_m
    if grid is None:
        grid = pe_table_grid_kwargs_uncapped(scenario, radar)
    g = table_grid(radar.frequency_hz, **{**grid, "max_range_m": full})
    if g["n"] * g["n_steps"] <= LARGE_GRID_WORK:
        return full
    reach = farthest_mover_range_m(scenario, radar)
    ext = scenario.external
    if ext is not None:  # live entities anywhere in their declared envelope
        reach = max(reach, full if ext.max_range_m is None else ext.max_range_m)
    return float(min(full, reach * (1 + PE_RANGE_MARGIN) + PE_RANGE_MARGIN_M))


def pe_table_grid_kwargs_uncapped(scenario: Scenario, radar: Radar) -> dict[str, Any]:
    """:func:`pe_table_grid_kwargs` to the instrumented range."""
    return {
        "antenna_height_m": radar.antenna_height_m,
        "polarization": radar.polarization,
        "profile": refractivity_profile(scenario),
        "wave_height_m": scenario.wave_height,
        "max_range_m": radar.instrumented_range_m,
        "max_height_m": pe_table_height_m(scenario, radar),
        "fidelity": scenario.fidelity.pe_grid,
    }


#: Times sampled between the first and the last time of any track (besides every piece's
#: start) by :func:`farthest_mover_range_m`.
_REACH_SAMPLES = 4001


def farthest_mover_range_m(scenario: Scenario, radar: Radar) -> float:
    """Largest horizontal distance [m] between a radar's platform and any target (while it
    exists) or jammer, over the whole scene.

    Exact for straight legs (the distance between two straight legs is largest at an end of
    a common interval, and every piece start is sampled); turns and weaves are sampled at
    :data:`_REACH_SAMPLES` times. 0 for a scene without targets or jammers.
    """
    from shipradar.sim.world.kinematics import LocalFrame
    from shipradar.sim.world.trajectory import trajectories

    platform = next(p for p, r in scenario.radars() if r.id == radar.id)
    frame = LocalFrame(scenario.origin)
    ship = trajectories([platform], frame, hold=True)
    best = 0.0
    for movers, hold in ((scenario.targets, False), (scenario.jammers, True)):
        if not movers:
            continue
        tr = trajectories(movers, frame, hold=hold)
        starts = [ship.times[0][np.isfinite(ship.times[0])], tr.t_last, ship.t_last]
        starts += [row[np.isfinite(row)] for row in tr.times]
        times = np.concatenate([np.ravel(x) for x in starts])
        lo, hi = float(times.min()), float(times.max())
        times = np.unique(np.concatenate([times, np.linspace(lo, hi, _REACH_SAMPLES)]))
        rows = np.repeat(np.arange(tr.n), times.size)
        t = np.tile(times, tr.n)
        pos, _, active = tr.state(t, rows)
        own, _, _ = ship.state(t, np.zeros(t.size, dtype=int))
        d = np.hypot(pos[:, 0] - own[:, 0], pos[:, 1] - own[:, 1])
        if np.any(active):
            best = max(best, float(d[active].max()))
    if scenario.traffic:  # the traffic files' fixes, from wherever the platform sails
        from shipradar.sim.world.traffic import scene_targets

        at = np.append(ship.times[0][np.isfinite(ship.times[0])], ship.t_last)
        ship_pos, _, _ = ship.state(at, np.zeros(at.size, dtype=int))
        targets = scene_targets(scenario)
        best = max([best, *(targets.max_ground_range_m(p[:2]) for p in ship_pos)])
    return best
