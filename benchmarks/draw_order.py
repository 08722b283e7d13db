"""Old and new code on the same scenes and seeds: counts by origin within their Poisson spread.

    python benchmarks/draw_order.py --baseline 653d797 [--scenarios raid stress]
                                    [--duration 120] [--seeds 10]

A change of the order of the random draws (issue 16: the false alarms of a block of
revolutions drawn together) changes the byte stream for a given seed; it is acceptable only
if the statistics do not change.  This runs every scenario at seeds 1..N with the code of
the working tree and with the code of ``--baseline`` (a git revision, checked out in a
temporary worktree and imported from there in a subprocess), sums the counts by origin (target
plots, missed detections, noise and sea-clutter false alarms) over the seeds, and prints
z = (new - old) / sqrt(new + old), the difference in units of the Poisson spread of two
independent counts; |z| < 3 is agreement.  It also prints the CPU time of each side.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
KEYS = ("target_plots", "missed_detections", "noise_false_alarms", "clutter_false_alarms")
#: Folders mapped into the shipradar namespace (pyproject's package-dir).
SUBPACKAGES = ("sim", "sensors", "tables", "scenarios")


def counts(scenario_path: str, duration: float, seeds: int) -> dict:
    """Summed counts by origin and CPU time of the runs at seeds 1..``seeds``."""
    from shipradar.sim.engine.simulation import Simulation
    from shipradar.sim.world.scenario import load_scenario
    from shipradar.tables.scene import load_scene_tables

    base = load_scenario(scenario_path)
    tables = load_scene_tables(base)
    total = dict.fromkeys(KEYS, 0)
    cpu = 0.0
    for seed in range(1, seeds + 1):
        s = base.model_copy(update={"seed": seed})
        c0 = time.process_time()
        summary = Simulation(s, bus=None, duration_s=duration, tables=tables).run()
        cpu += time.process_time() - c0
        for k in KEYS:
            total[k] += summary[k]
    return {"counts": total, "cpu_s": cpu}


def _namespace(tree: Path, into: Path) -> Path:
    """A folder holding ``shipradar`` as the package-dir mapping lays it out, from a tree."""
    pkg = into / "shipradar"
    pkg.mkdir(parents=True)
    for f in (tree / "shipradar").iterdir():
        (pkg / f.name).symlink_to(f)
    for name in SUBPACKAGES:
        (pkg / name).symlink_to(tree / name)
    return into


def baseline_counts(rev: str, scenario: str, duration: float, seeds: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        tree = Path(tmp) / "tree"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(tree), rev],
                       check=True, capture_output=True)
        try:
            path = _namespace(tree, Path(tmp) / "path")
            env = {**os.environ, "PYTHONPATH": str(path)}
            out = subprocess.run(
                [sys.executable, str(Path(__file__).resolve()), "--worker", scenario,
                 "--duration", str(duration), "--seeds", str(seeds)],
                check=True, capture_output=True, text=True, env=env, cwd=tmp)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)],
                           check=True, capture_output=True)
    result = json.loads(out.stdout.splitlines()[-1])
    if Path(result["code"]) == ROOT:
        raise SystemExit(f"the baseline run imported the working tree ({ROOT}), not {rev}")
    return result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default="653d797", help="git revision of the old code")
    ap.add_argument("--scenarios", nargs="+", default=["raid", "stress"])
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        import shipradar.sim.engine.simulation

        out = counts(args.worker, args.duration, args.seeds)
        out["code"] = str(Path(shipradar.sim.engine.simulation.__file__).resolve().parents[1])
        print(json.dumps(out))
        return
    print(f"{args.seeds} seeds x {args.duration:g} simulated s; baseline {args.baseline}; "
          f"load average {os.getloadavg()[0]:.2f}")
    worst = 0.0
    for name in args.scenarios:
        path = str(ROOT / "scenarios" / f"{name}.yaml")
        old = baseline_counts(args.baseline, path, args.duration, args.seeds)
        new = counts(path, args.duration, args.seeds)
        print(f"{name}: CPU old {old['cpu_s']:.2f} s, new {new['cpu_s']:.2f} s "
              f"(new/old {new['cpu_s'] / old['cpu_s']:.2f})")
        for k in KEYS:
            a, b = old["counts"][k], new["counts"][k]
            z = (b - a) / (a + b) ** 0.5 if a + b else 0.0
            worst = max(worst, abs(z))
            print(f"  {k:22s} old {a:9d}  new {b:9d}  z {z:+6.2f}")
    print(f"largest |z| {worst:.2f}: {'agree' if worst < 3 else 'DISAGREE'} (|z| < 3)")


if __name__ == "__main__":
    main()
