"""The loop against batch 1's code, interleaved in one run on the same machine (issue 27, item 4).

    python benchmarks/batch1_compare.py [--baseline 0074262] [--scenarios raid stress]
                                        [--duration 600 300] [--rounds 5]

Checks ``--baseline`` out in a temporary git worktree, and runs ``shipradar run SCENE
--record FILE --seed 7`` with that code (its own ``sim.cli``, its own scenario file, its own
table cache, so its tables are built once by a warm-up run) and with the working tree's,
alternately, ``--rounds`` times per scene.  Each run is a fresh process; printed per scene:

- the loop's ``wall_s`` from each side's summary (best and median), and old/new;
- the process's CPU time (``os.wait4``'s rusage: user + system), best and median, and old/new;
- the process wall time, best and median.

Other processes only ever slow a run down, so the best of the rounds is the figure to quote
on a loaded machine; the median is printed beside it.  The streams differ (batch 1 draws the
false alarms in another order and has fewer keys; ``benchmarks/draw_order.py`` compares their
statistics): this measures the same scene, the same simulated duration, with a recording.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The code of batch 1 (the issue's reference: "5.8x (raid) and 4.8x (stress)").
BATCH1 = "0074262"
_OLD_MAIN = ("import sys; sys.path.insert(0, sys.argv.pop(1)); "
             "from sim.cli import main; sys.exit(main())")


def _timed(cmd: list[str], env: dict[str, str], cwd: str) -> dict[str, float]:
    """One process: its summary's loop ``wall_s``, its CPU time (``os.wait4``) and wall time."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, env=env, cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True)
    assert proc.stdout is not None
    out = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode})")
    summary = json.loads(out.strip().splitlines()[-1])
    return {"loop_s": float(summary["wall_s"]), "cpu_s": usage.ru_utime + usage.ru_stime,
            "wall_s": wall}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default=BATCH1, help="git revision of the old code")
    ap.add_argument("--scenarios", nargs="+", default=["raid", "stress"])
    ap.add_argument("--duration", nargs="+", type=float, default=[600.0, 300.0],
                    help="simulated seconds, one per scenario (or one for all)")
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    durations = args.duration * len(args.scenarios) if len(args.duration) == 1 else args.duration
    if len(durations) != len(args.scenarios):
        raise SystemExit("--duration: give one value, or one per scenario")
    with tempfile.TemporaryDirectory() as tmp:
        tree = Path(tmp) / "tree"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(tree),
                        args.baseline], check=True, capture_output=True)
        try:
            _compare(args, durations, tree, Path(tmp))
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)],
                           check=True, capture_output=True)


def _compare(args: argparse.Namespace, durations: list[float], tree: Path, tmp: Path) -> None:
    base_env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    old_env = {**base_env, "SHIPRADAR_TABLES": str(tmp / "old-tables")}
    new_env = dict(base_env)
    rec = str(tmp / "rec.bin")
    print(f"baseline {args.baseline} against the working tree; {args.rounds} rounds, "
          f"interleaved; load average {os.getloadavg()[0]:.2f}")
    for name, duration in zip(args.scenarios, durations, strict=True):
        tail = ["run", "--duration", f"{duration:g}", "--seed", "7", "--record", rec,
                "--overwrite", "--quiet"]
        old = [sys.executable, "-c", _OLD_MAIN, str(tree), tail[0],
               str(tree / "scenarios" / f"{name}.yaml"), *tail[1:]]
        new = [sys.executable, "-m", "shipradar.sim.cli", tail[0],
               str(ROOT / "scenarios" / f"{name}.yaml"), *tail[1:]]
        for cmd, env in ((old, old_env), (new, new_env)):  # warm-up: tables, page cache
            _timed(cmd, env, str(tmp))
        runs: dict[str, list[dict[str, float]]] = {"old": [], "new": []}
        for _ in range(args.rounds):
            runs["old"].append(_timed(old, old_env, str(tmp)))
            runs["new"].append(_timed(new, new_env, str(tmp)))
        print(f"\n{name}, {duration:g} simulated s, with a recording "
              f"(load average now {os.getloadavg()[0]:.2f}):")
        print(f"  {'measure':18s} {'old best':>9s} {'new best':>9s} {'old/new':>8s}"
              f"   {'old med':>8s} {'new med':>8s} {'old/new':>8s}")
        for key, label in (("loop_s", "loop wall_s [s]"), ("cpu_s", "process CPU [s]"),
                           ("wall_s", "process wall [s]")):
            o = [r[key] for r in runs["old"]]
            n = [r[key] for r in runs["new"]]
            ob, nb, om, nm = min(o), min(n), statistics.median(o), statistics.median(n)
            print(f"  {label:18s} {ob:9.3f} {nb:9.3f} {ob / nb:7.2f}x   {om:8.3f} {nm:8.3f} "
                  f"{om / nm:7.2f}x")


if __name__ == "__main__":
    main()
