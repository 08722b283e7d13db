"""The tables one scene needs, built or loaded through the cache (off-line level, seed 2.1).

A scene builds only what it reads (SPEC §2): no rain, no weather-clutter map; clutter
switched off in the fidelity section, no sea-clutter map or P_fac map; no Doppler processor,
no improvement-factor table; propagation "free_space" or "two_ray", no PE table; atmosphere
switched off, no loss table.  Every table is keyed by a hash of exactly its inputs
(:mod:`tables.store`), so ``shipradar tables build`` ahead of a run and the run itself find
the same files, and a Monte Carlo study builds each table once.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TextIO

import numpy as np

from sim.scenario import Platform, Radar, Scenario
from tables.store import Table


@dataclass
class TableSpec:
    """One table a scene needs: which radar, what kind, and how to get it (cache or build)."""

    radar_id: str
    kind: str
    describe: str
    make: Callable[[], Table]


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
    """Slant range [m] and elevation [rad] axes of the atmospheric-loss table.

    The loss grows smoothly (about linearly) with range and falls with elevation as the path
    leaves the absorbing layers, so 41 ranges to the instrumented range and 25 elevations
    from -2° to 60° (denser near the horizon) interpolate to well under 0.05 dB.
    """
    ranges = np.linspace(0.0, radar.instrumented_range_m * 1.05, 41)
    elev = np.radians(np.concatenate([np.linspace(-2.0, 2.0, 9), np.geomspace(2.5, 60.0, 16)]))
    return ranges, elev


def table_specs(scenario: Scenario) -> list[TableSpec]:
    """Every table the scene reads, in build order."""
    specs: list[TableSpec] = []
    for platform, radar in scenario.radars():
        if scenario.fidelity.atmosphere:
            specs.append(_atmosphere_spec(scenario, platform, radar))
        specs.extend(_optional_specs(scenario, platform, radar))
    return specs


def _atmosphere_spec(scenario: Scenario, platform: Platform, radar: Radar) -> TableSpec:
    from sensors.atmosphere import atmospheric_loss_grid

    env = scenario.environment
    ranges, elev = atmosphere_axes(radar)

    def make() -> Table:
        return atmospheric_loss_grid(
            radar.frequency_hz, ranges, elev,
            temperature_k=env.temperature_c + 273.15,
            pressure_hpa=env.pressure_hpa,
            water_vapour_density_g_m3=env.water_vapour_g_m3,
            fog_lwc_g_m3=env.fog.liquid_water_g_m3 if env.fog else 0.0,
            fog_top_m=env.fog.top_m if env.fog else 100.0,
            antenna_height_m=radar.antenna_height_m,
        )

    return TableSpec(radar.id, "atmosphere", "one-way gas/fog loss vs slant range, elevation",
                     make)


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
def load_scene_tables(scenario: Scenario, *, progress: bool = False,
                      log: TextIO | None = None) -> SceneTables:
    """Load every table the scene needs from the cache, building the missing ones."""
    scene = SceneTables()
    for platform, radar in scenario.radars():
        scene.for_radar(radar.id)
    for spec in table_specs(scenario):
        t0 = time.perf_counter()
        table = spec.make()
        dt = time.perf_counter() - t0
        if dt > 1.0 and log is not None:
            print(f"{spec.radar_id}: {spec.kind} table ready in {dt:.1f} s", file=log)
        setattr(scene.for_radar(spec.radar_id), spec.kind, table)
    return scene


def build_scene_tables(scenario: Scenario, *, progress: bool = False,
                       log: TextIO | None = sys.stderr) -> dict[str, Any]:
    """Build (or find in the cache) every table of the scene; a JSON-able report."""
    from tables.store import cache_path

    rows = []
    for spec in table_specs(scenario):
        t0 = time.perf_counter()
        table = spec.make()
        dt = time.perf_counter() - t0
        rows.append({
            "radar": spec.radar_id,
            "kind": spec.kind,
            "what": spec.describe,
            "key": table.key,
            "file": str(cache_path(table.name, table.key)),
            "shape": list(table.values.shape),
            "seconds": round(dt, 3),
        })
        if log is not None:
            print(f"{spec.radar_id}: {spec.kind} {table.values.shape} in {dt:.2f} s", file=log)
    return {"scenario": scenario.name, "tables": rows}
