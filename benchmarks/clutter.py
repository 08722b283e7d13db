"""Benchmark: sea-clutter maps of the raid scenario's two radars (off-line build) and the
on-line cost per dwell of reading them.

Radars: ``scenarios/raid.yaml`` as written (the SPS-49-like UHF radar, 0.9 GHz HP, 30 m,
2 µs, 250 km; the Sea Giraffe-like C-band radar, 5.6 GHz VP, 25 m, 0.25 µs, 100 km), with the
scene's own grid (:func:`shipradar.tables.scene.clutter_grid_size`), through the same table specs a
run uses (:func:`shipradar.tables.scene.table_specs`).

Measured, in-process with ``time.perf_counter`` (best of N):

* build: the map built and written to an empty cache (what ``shipradar tables build`` pays
  once per radar and environment); load: the same map read back from the cache (what every
  later run pays);
* the same builds on a 4x finer range grid, to show the cost scales with the cell count;
* on-line, per dwell: :meth:`shipradar.sim.dwell.model.DwellModel.clutter_at` for the targets in one
beam
  (power, μ_c, σ_s, Weibull a read from the map; the I_F table lookup; the distribution loss),
  and the bare map read (:class:`shipradar.tables.store.StackedLookup2D`) it is built on, for 1, 24
  and 1000 targets in the beam.

Run ``python benchmarks/clutter.py``; numbers are disturbed by other jobs on a shared machine.
"""

from __future__ import annotations

import math
import os
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

RAID = Path(__file__).resolve().parents[1] / "scenarios" / "raid.yaml"
#: Targets in one beam position for the on-line cost (one, the raid's 24, a dense scene).
TARGETS_PER_DWELL = (1, 24, 1000)


def best_of(fn, n):
    best, out = math.inf, None
    for _ in range(n):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def _fresh_cache():
    """Point the table cache at a new empty directory (the env var is read at each call)."""
    d = tempfile.mkdtemp(prefix="shipradar-bench-")
    os.environ["SHIPRADAR_TABLES"] = d
    return d


def main() -> None:
    from shipradar.sensors.radar import radar_constants
    from shipradar.sim.dwell.model import DwellModel
    from shipradar.sim.world.scenario import load_scenario
    from shipradar.tables import scene as ts
    from shipradar.tables.clutter import build_sea_clutter_map
    from shipradar.tables.store import StackedLookup2D

    scenario = load_scenario(RAID)
    print(f"scenario {scenario.name}: wind {scenario.environment.wind_speed_mps} m/s, "
          f"waves {scenario.wave_height:.2f} m")
    rng = np.random.default_rng(0)
    for platform, radar in scenario.radars():
        def spec(kind, radar=radar):
            return next(s for s in ts.table_specs(scenario)
                        if s.radar_id == radar.id and s.kind == kind)

        def build():
            _fresh_cache()
            return spec("sea_clutter").make()

        t_build, table = best_of(build, 3)
        t_load, _ = best_of(lambda: spec("sea_clutter").make(), 5)
        n_r, n_a = table.values.shape
        print(f"\n{radar.id} ({radar.frequency_hz / 1e9:g} GHz {radar.polarization}P, "
              f"{radar.pulse_width_s * 1e6:g} us, {radar.instrumented_range_m / 1e3:g} km)")
        print(f"  sea-clutter map {n_r} x {n_a}: build + save {t_build * 1e3:7.1f} ms "
              f"({t_build / table.values.size * 1e9:.0f} ns/cell), load {t_load * 1e3:6.1f} ms")

        # a 4x finer range grid, built directly (the scene's grid is fixed by clutter_grid_size)
        directivity = radar_constants(scenario, radar).elevation_pattern(radar)
        for factor in (1, 4):
            kw = dict(table.inputs)
            kw["n_range"] = factor * (n_r - 1) + 1
            kw["elevation_pattern"] = tuple(kw["elevation_pattern"])
            t_pure, pure = best_of(
                lambda g=directivity, kw=kw: build_sea_clutter_map(elevation_directivity=g, **kw),
                3)
            print(f"  physics only (no save), {pure.values.shape[0]} x {n_a}"
                  f"{' (range step /4)' if factor > 1 else ''}: {t_pure * 1e3:7.1f} ms "
                  f"({t_pure / pure.values.size * 1e9:.0f} ns/cell)")

        tables = ts.SceneTables()
        rt = tables.for_radar(radar.id)
        rt.sea_clutter = table
        kw_if = ts.improvement_kwargs(scenario, radar)
        if kw_if is not None:
            from shipradar.tables.improvement import improvement_table

            rt.improvement = improvement_table(radar.processor.type, **kw_if)[0]
        model = DwellModel(scenario, platform, radar, tables)
        reader = StackedLookup2D(table, (None, "doppler_mean_hz", "doppler_spread_hz",
                                         "weibull_a"), periodic1=True)
        for n in TARGETS_PER_DWELL:
            az = np.full(n, rng.uniform(0.0, 2 * math.pi))
            geom = SimpleNamespace(
                ground_range=rng.uniform(1e3, 0.9 * radar.instrumented_range_m, n),
                azimuth=az,
                radial_velocity=rng.uniform(-700.0, 300.0, n),
            )
            tpos = np.zeros((n, 3))
            t_read, _ = best_of(lambda g=geom, r=reader: r(g.ground_range, g.azimuth), 300)
            t_dwell, _ = best_of(lambda g=geom, p=tpos, m=model: m.clutter_at(g, p, None), 300)
            print(f"  {n:5d} targets in the beam: map read {t_read * 1e6:7.1f} us, "
                  f"DwellModel.clutter_at (read + I_F lookup + L_d) {t_dwell * 1e6:7.1f} us "
                  f"per dwell")


if __name__ == "__main__":
    main()
