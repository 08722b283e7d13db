"""Recorded traffic (issue 32): load time of a 100,000-row AIS file, its cost per scan against
the same targets given as YAML waypoints, and memory per 1,000 entities.

    .venv/bin/python benchmarks/traffic.py [--ships 1000] [--fixes 100] [--duration 60]
        [--repeat 3]

The file is made here (MarineCadastre's columns, ``preset: ais``): ``--ships`` vessels within
55 km of the demo's frigate, each reporting ``--fixes`` times 10 s apart (jittered), straight
at 3-15 kn on random courses, with SOG/COG.  The scene is the demo's radar (its PE table from
the cache) with no targets of its own.  Timed:

* **load**: :func:`shipradar.sim.world.traffic.read_traffic` from a cold cache (CSV parse,
  filters, frame projection, Hermite pieces), best of ``--repeat``;
* **per scan**: a fast run of ``--duration`` s without a bus (the dwell loop alone), with
  the targets from the file, then from YAML with the same fixes as waypoints (constant
  velocity between them; the same looks, within the two paths' difference), best of
  ``--repeat``, wall and CPU per scan;
* **memory**: the piece table's arrays and the peak of Python's allocations during the
  load (tracemalloc), per 1,000 entities.
"""

from __future__ import annotations

import argparse
import csv
import datetime as dt
import math
import os
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.world import traffic
from shipradar.sim.world.kinematics import LocalFrame
from shipradar.sim.world.scenario import load_scenario, parse_scenario
from shipradar.tables.scene import load_scene_tables

ROOT = Path(__file__).resolve().parents[1]
KNOT = 1852.0 / 3600.0


def write_ais(path: Path, ships: int, fixes: int, frame: LocalFrame, start: dt.datetime,
              rng: np.random.Generator) -> list[np.ndarray]:
    """The AIS file; returns each ship's (time, east, north) fixes for the YAML twin."""
    tracks = []
    rows = []
    for k in range(ships):
        r = rng.uniform(3000.0, 55000.0)
        b = rng.uniform(0.0, 2 * math.pi)
        course = rng.uniform(0.0, 2 * math.pi)
        speed = rng.uniform(3.0, 15.0) * KNOT
        t = np.arange(fixes) * 10.0 + rng.uniform(0.0, 2.0, fixes)
        e = r * math.sin(b) + speed * t * math.sin(course)
        n = r * math.cos(b) + speed * t * math.cos(course)
        lat, lon, _ = frame.geodetic(np.column_stack([e, n, np.zeros(fixes)]))
        mmsi = 316_000_000 + k
        cog = math.degrees(course) % 360.0
        for j in range(fixes):
            when = (start + dt.timedelta(seconds=float(t[j]))).strftime("%Y-%m-%dT%H:%M:%S.%f")
            rows.append((mmsi, when[:-3], f"{lat[j]:.7f}", f"{lon[j]:.7f}",
                         f"{speed / KNOT:.2f}", f"{cog:.2f}", round(cog) % 360, f"SHIP {k}",
                         70))
        tracks.append(np.column_stack([t, e, n]))
    rows.sort(key=lambda x: x[1])
    with open(path, "w", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(["MMSI", "BaseDateTime", "LAT", "LON", "SOG", "COG", "Heading",
                      "VesselName", "VesselType"])
        out.writerows(rows)
    return tracks


def timed_run(scenario, tables, duration: float, repeat: int) -> tuple[float, float, int]:
    best_w = best_c = math.inf
    scans = 0
    for _ in range(repeat):
        sim = Simulation(scenario, tables=tables, duration_s=duration)
        w0, c0 = time.perf_counter(), time.process_time()
        s = sim.run()
        best_w = min(best_w, time.perf_counter() - w0)
        best_c = min(best_c, time.process_time() - c0)
        scans = s["scans"]
    return best_w, best_c, scans


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ships", type=int, default=1000)
    ap.add_argument("--fixes", type=int, default=100)
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    demo = load_scenario(ROOT / "scenarios" / "single_missile.yaml")
    frame = LocalFrame(demo.origin)
    rng = np.random.default_rng(32)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "ais.csv"
        tracks = write_ais(path, args.ships, args.fixes, frame, demo.start_time, rng)
        size = path.stat().st_size
        base = demo.model_dump(mode="json")
        base["targets"] = []
        base["traffic"] = [{"path": str(path), "preset": "ais",
                            "rcs": {"type": "constant", "sigma_m2": 100.0}}]
        scene = parse_scenario(base)
        loads = []
        for _ in range(args.repeat):
            traffic._READ_CACHE.clear()
            t0 = time.perf_counter()
            tracks_read = traffic.read_traffic(scene.traffic[0], 0, scene, frame)
            loads.append(time.perf_counter() - t0)
        traffic._READ_CACHE.clear()
        tracemalloc.start()
        traffic.read_traffic(scene.traffic[0], 0, scene, frame)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        rows = tracks_read.rows
        targets = traffic.scene_targets(scene)
        table = targets.trajectories(frame)
        assert isinstance(table, traffic.PieceTable)
        per_k = 1000.0 / targets.n
        print(f"file: {rows} rows, {targets.n} ids, {size / 2**20:.1f} MiB CSV")
        print(f"load (read_traffic, cold): best {min(loads):.3f} s, all "
              f"{', '.join(f'{x:.3f}' for x in loads)}")
        print(f"memory per 1,000 entities ({args.fixes} fixes each): piece table "
              f"{table.nbytes * per_k / 2**20:.2f} MiB, load peak (tracemalloc) "
              f"{peak * per_k / 2**20:.2f} MiB")

        yaml_scene = demo.model_dump(mode="json")
        yaml_scene["targets"] = [
            {"id": f"s{k}", "kind": "ship", "rcs": {"type": "constant", "sigma_m2": 100.0},
             "waypoints": [{"time_s": float(t), "east_m": float(e), "north_m": float(n)}
                           for t, e, n in tr]} for k, tr in enumerate(tracks)]
        twin = parse_scenario(yaml_scene)
        tables = load_scene_tables(scene)
        w_f, c_f, scans = timed_run(scene, tables, args.duration, args.repeat)
        w_y, c_y, _ = timed_run(twin, tables, args.duration, args.repeat)
        print(f"per scan ({scans} scans, {args.duration:g} s, best of {args.repeat}): "
              f"traffic file {1e3 * w_f / scans:.2f} ms wall {1e3 * c_f / scans:.2f} ms CPU; "
              f"same targets in YAML {1e3 * w_y / scans:.2f} ms wall {1e3 * c_y / scans:.2f} "
              f"ms CPU; ratio (CPU) {c_f / c_y:.2f}")
        print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
