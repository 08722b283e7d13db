"""Real-time factor of the raid scenario in fast mode with a recording (issue 2).

    python benchmarks/realtime_factor.py [--duration 600] [--scenario scenarios/raid.yaml]

Builds (or loads) the scene's tables first, outside the timed run, then runs the scenario
for the simulated duration with a recording and prints scans/s, plots/s and the real-time
factor, plus a baseline in the same process: the same run without a recording, and with the
cheapest fidelity (free-space propagation, no clutter), so the cost of each part shows as a
ratio.  Target: >= 200x real time on a 2-core machine.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from sim.bus import Bus
from sim.engine import Simulation
from sim.recording import Recorder
from sim.scenario import load_scenario
from tables.scene import load_scene_tables

ROOT = Path(__file__).resolve().parents[1]


def run_once(scenario, duration, record: bool) -> dict:
    tables = load_scene_tables(scenario)
    with tempfile.TemporaryDirectory() as tmp:
        bus = Bus(None, Recorder(Path(tmp) / "bench.rec")) if record else None
        sim = Simulation(scenario, bus=bus, duration_s=duration, tables=tables)
        t0 = time.perf_counter()
        summary = sim.run()
        wall = time.perf_counter() - t0
        if bus is not None:
            bus.close()
    plots = summary["target_plots"] + summary["noise_false_alarms"] + summary[
        "clutter_false_alarms"]
    return {
        "wall_s": round(wall, 3),
        "scans_per_s": round(summary["scans"] / wall, 1),
        "plots_per_s": round(plots / wall, 1),
        "dwells_per_s": round(summary["dwells"] / wall, 1),
        "realtime_factor": round(duration / wall, 1),
        "plots": plots,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default=str(ROOT / "scenarios/raid.yaml"))
    ap.add_argument("--duration", type=float, default=600.0)
    args = ap.parse_args()
    s = load_scenario(args.scenario)
    cheap = s.model_copy(update={"fidelity": s.fidelity.model_copy(
        update={"propagation": "free_space", "clutter": False, "atmosphere": False})})
    rows = {
        "full fidelity + recording": run_once(s, args.duration, True),
        "full fidelity, no recording": run_once(s, args.duration, False),
        "free space, no clutter, no atmosphere": run_once(cheap, args.duration, True),
    }
    base = rows["full fidelity + recording"]["wall_s"]
    print(f"scenario {s.name}, {args.duration:g} simulated s, fast mode")
    print(f"{'case':40s} {'wall s':>8s} {'scans/s':>9s} {'plots/s':>10s} {'RT factor':>10s} "
          f"{'vs full':>8s}")
    for name, r in rows.items():
        print(f"{name:40s} {r['wall_s']:8.2f} {r['scans_per_s']:9.1f} {r['plots_per_s']:10.1f} "
              f"{r['realtime_factor']:10.1f} {base / r['wall_s']:8.2f}x")
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
