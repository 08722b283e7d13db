"""Scaling of the run's cost: wall time per simulated minute against targets, radars and
sea-clutter false alarms per scan (issue 16, item 5).

    .venv/bin/python benchmarks/scaling.py [--duration 60] [--repeat 2] [--no-plot]

Every case is the `stress` scene (one Giraffe-type radar on a stationary frigate, sea
state 6), fast mode, with a recording (the product's configuration), varied along one axis:

* **targets** 1 → 2000: the scene's 220 targets, copied and turned about the ship by the
  golden angle (so the copies do not overlap) or cut, with the clutter false alarms almost
  off (K_clutter = 10^6) so that the target term shows alone;
* **radars** 1 → 8: copies of the radar on the same mast (own id, start azimuth spread), the
  scene's 220 targets and its full clutter false alarms;
* **clutter false alarms per scan** 0 → 5000: K_clutter [96] from 10^6 down to 1 (the
  scene's own 5047 per scan is the most this sea gives; 10^4 would need a rougher sea),
  with the 220 targets.

Each case is timed after a warm-up run that builds or loads its tables (off-line level:
not part of the cost), best of ``--repeat``; wall and CPU time are printed, and the load
average (2 shared cores: the wall clock is noisy, the CPU time less so).  Writes
docs/scaling.png and prints a markdown table and the least-squares slope of each curve.
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream.bus import Bus
from shipradar.sim.stream.recording import Recorder
from shipradar.sim.world.scenario import Scenario, load_scenario
from shipradar.tables.scene import load_scene_tables

ROOT = Path(__file__).resolve().parents[1]
PNG = ROOT / "docs" / "scaling.png"
TARGETS = (1, 10, 100, 300, 1000, 2000)
RADARS = (1, 2, 4, 8)
K_CLUTTER = (1e6, 50.0, 10.0, 4.0, 2.0, 1.0)
GOLDEN = math.pi * (3.0 - math.sqrt(5.0))


def _with_targets(base: dict, n: int) -> dict:
    src = base["targets"]
    out = []
    for i in range(n):
        t = dict(src[i % len(src)])
        turn = (i // len(src)) * GOLDEN
        c, s = math.cos(turn), math.sin(turn)
        t["id"] = f"s{i:04d}"
        t["waypoints"] = [{**w, "east_m": c * w["east_m"] - s * w["north_m"],
                           "north_m": s * w["east_m"] + c * w["north_m"]}
                          for w in t["waypoints"]]
        out.append(t)
    return {**base, "targets": out}


def _with_radars(base: dict, n: int) -> dict:
    plat = dict(base["platforms"][0])
    radar = plat["radars"][0]
    plat["radars"] = [{**radar, "id": f"{radar['id']}{k}", "sic": k + 1,
                       "start_azimuth_deg": (360.0 * k / n) % 360.0} for k in range(n)]
    return {**base, "platforms": [plat, *base["platforms"][1:]]}


def _with_k_clutter(base: dict, k: float) -> dict:
    plat = dict(base["platforms"][0])
    plat["radars"] = [{**r, "k_clutter": k} for r in plat["radars"]]
    return {**base, "platforms": [plat, *base["platforms"][1:]]}


def time_case(doc: dict, duration: float, repeat: int) -> dict:
    scenario = Scenario.model_validate(doc)
    tables = load_scene_tables(scenario)
    if tables.missing_lines():
        from shipradar.tables.scene import build_scene_tables

        tables = build_scene_tables(scenario)
    Simulation(scenario, duration_s=min(duration, 5.0), tables=tables).run()  # warm-up
    best = None
    for _ in range(max(1, repeat)):
        with tempfile.TemporaryDirectory() as tmp:
            bus = Bus(None, Recorder(Path(tmp) / "s.rec"))
            sim = Simulation(scenario, bus=bus, duration_s=duration, tables=tables)
            w0, c0 = time.perf_counter(), time.process_time()
            summary = sim.run()
            bus.close()
            wall, cpu = time.perf_counter() - w0, time.process_time() - c0
        if best is None or wall < best["wall_s"]:
            best = {"wall_s": wall, "cpu_s": cpu, "summary": summary}
    s = best["summary"]
    per_min = 60.0 / duration
    return {"wall_per_min": best["wall_s"] * per_min, "cpu_per_min": best["cpu_s"] * per_min,
            "scans": s["scans"], "dwells": s["dwells"],
            "clutter_fa_per_scan": s["clutter_false_alarms"] / max(s["scans"], 1),
            "plots": s["target_plots"] + s["noise_false_alarms"] + s["clutter_false_alarms"]}


def slope(x, y) -> tuple[float, float]:
    """Least-squares line y = a + b x: (a, b)."""
    b, a = np.polyfit(np.asarray(x, float), np.asarray(y, float), 1)
    return float(a), float(b)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0, help="simulated seconds per case")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--no-plot", action="store_true")
    args = ap.parse_args()
    base = load_scenario(ROOT / "scenarios" / "stress.yaml").model_dump(mode="json")
    quiet = _with_k_clutter(base, 1e6)
    load0 = os.getloadavg()[0]
    curves = {"targets": [], "radars": [], "clutter": []}
    for n in TARGETS:
        r = time_case(_with_targets(quiet, n), args.duration, args.repeat)
        curves["targets"].append((n, r))
        print(f"targets {n:5d}: {r['wall_per_min']:.3f} s wall / {r['cpu_per_min']:.3f} s CPU "
              f"per simulated minute, {r['dwells']} dwells", flush=True)
    for n in RADARS:
        r = time_case(_with_radars(base, n), args.duration, args.repeat)
        curves["radars"].append((n, r))
        print(f"radars {n:2d}: {r['wall_per_min']:.3f} s wall / {r['cpu_per_min']:.3f} s CPU "
              f"per simulated minute", flush=True)
    for k in K_CLUTTER:
        r = time_case(_with_k_clutter(base, k), args.duration, args.repeat)
        curves["clutter"].append((r["clutter_fa_per_scan"], r))
        print(f"K_clutter {k:g}: {r['clutter_fa_per_scan']:.0f} clutter FA/scan: "
              f"{r['wall_per_min']:.3f} s wall / {r['cpu_per_min']:.3f} s CPU per simulated "
              "minute", flush=True)
    print(f"\nstress scene, {args.duration:g} simulated s per case, recording on, best of "
          f"{args.repeat}; {os.cpu_count()} CPUs, load average {load0:.2f} before, "
          f"{os.getloadavg()[0]:.2f} after\n")
    print("| axis | value | wall s / sim min | CPU s / sim min | dwells | plots |")
    print("|---|---|---|---|---|---|")
    labels = {"targets": "targets", "radars": "radars", "clutter": "clutter FA / scan"}
    for axis, rows in curves.items():
        for x, r in rows:
            print(f"| {labels[axis]} | {x:.0f} | {r['wall_per_min']:.3f} | "
                  f"{r['cpu_per_min']:.3f} | {r['dwells']} | {r['plots']} |")
    print()
    for axis, rows in curves.items():
        a, b = slope([x for x, _ in rows], [r["cpu_per_min"] for _, r in rows])
        unit = {"targets": "target", "radars": "radar", "clutter": "false alarm per scan"}[axis]
        print(f"{axis}: CPU s per simulated minute ≈ {a:.3f} + {b:.3g} per {unit}")
    if not args.no_plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 3, figsize=(13, 4), constrained_layout=True)
        for ax, (axis, rows) in zip(axes, curves.items(), strict=True):
            x = [v for v, _ in rows]
            ax.plot(x, [r["wall_per_min"] for _, r in rows], "o-", label="wall")
            ax.plot(x, [r["cpu_per_min"] for _, r in rows], "s--", label="CPU")
            ax.set_xlabel(labels[axis])
            ax.set_ylabel("s per simulated minute")
            ax.set_ylim(bottom=0)
            ax.grid(alpha=0.3)
            ax.legend()
        fig.suptitle(f"stress scene, fast mode with a recording (load {load0:.1f} on "
                     f"{os.cpu_count()} shared cores)")
        fig.savefig(PNG, dpi=110)
        print(f"wrote {PNG.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
