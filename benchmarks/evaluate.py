"""``shipradar evaluate``: runs per minute on 1 and 2 workers, the harness's share, scoring.

    python benchmarks/evaluate.py [--runs 12] [--duration 110] [--tracker CMD] [--out DIR]
        [--workers 1 2] [--profile]

Each study runs the demo scene (single missile) with the tracker (default: the template,
``examples/tracker_template.py``, the one the targets are stated for; the Stone Soup CV
example with ``--tracker stonesoup``) on a ``LocalCluster`` of 1, then 2 workers, the same
seeds. Printed per study: runs/minute (wall time of the whole study, cluster start-up
excluded: the client is opened first), the harness's share of a run (its own work after the
run, ``harness_s``: stopping the tracker, writing the files; plus the scoring, ``score_s``;
over the run's wall time, which also holds the simulation with the tracker reading,
``run_s``, the drain and the start-up of tracker and scene, ``startup_s``), each part's mean
and the load average before and after. ``--profile`` then scores one recorded run under
cProfile (collected from its recording, as ``--rescore`` does) and prints where the time goes.

Targets (issue 39): scoring <= 0.05 s per demo run, harness share <= 10 %, >= 60 runs/min
on 2 workers of this 2-core machine.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import json
import os
import pstats
import shlex
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _trackers() -> dict[str, str]:
    py = shlex.quote(sys.executable)
    ex = ROOT / "examples"
    return {"template": f"{py} {shlex.quote(str(ex / 'tracker_template.py'))} {{plots}} "
                        f"{{tracks}}",
            "stonesoup": f"{py} {shlex.quote(str(ex / 'track_stonesoup.py'))} {{plots}} "
                         f"--publish-tracks {{tracks}} --quiet"}


def profile_scoring(run_dir: Path, repeat: int = 20) -> None:
    """Time the scoring of one recorded run (best of ``repeat``) and print its profile."""
    from shipradar.sim.studies.evaluate.data import load_run
    from shipradar.sim.studies.evaluate.metrics import score_run

    t0 = time.perf_counter()
    data = load_run(run_dir)
    t_load = time.perf_counter() - t0
    score_run(data)  # warm
    best = min(_timed(lambda: score_run(data)) for _ in range(repeat))
    prof = cProfile.Profile()
    prof.enable()
    for _ in range(repeat):
        score_run(data)
    prof.disable()
    out = io.StringIO()
    pstats.Stats(prof, stream=out).sort_stats("tottime").print_stats(12)
    print(json.dumps({"run": str(run_dir), "scans": int(data.scan_t.size),
                      "tracks_messages": len(data.tracks),
                      "load_run_s (rescore only)": round(t_load, 4),
                      "score_run_best_s": round(best, 4)}))
    print(out.getvalue())


def _timed(f) -> float:
    t0 = time.perf_counter()
    f()
    return time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=12)
    ap.add_argument("--duration", type=float, default=110.0)
    ap.add_argument("--scenario", default=str(ROOT / "scenarios" / "single_missile.yaml"))
    ap.add_argument("--tracker", default="template",
                    help="template, stonesoup, or a command with {plots} and {tracks}")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--out", default=None)
    ap.add_argument("--profile", action="store_true")
    a = ap.parse_args(argv)
    from distributed import Client, LocalCluster

    from shipradar.sim.studies.evaluate.study import run_study

    tracker = _trackers().get(a.tracker, a.tracker)
    out = Path(a.out or tempfile.mkdtemp(prefix="bench-evaluate-"))
    for n in a.workers:
        load0 = os.getloadavg()[0]
        with LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            t0 = time.perf_counter()
            res = run_study(a.scenario, tracker, runs=a.runs, out=out / f"w{n}", seed=1,
                            duration_s=a.duration, client=client, report=False)
            wall = time.perf_counter() - t0
        runs = [json.loads(p.read_text()) for p in sorted((out / f"w{n}" / "runs").glob(
            "*/run.json"))]
        parts = {k: float(np.mean([r.get(k) or 0.0 for r in runs]))
                 for k in ("wall_s", "startup_s", "run_s", "drain_s", "harness_s", "stop_s",
                           "write_s")}
        import pandas as pd

        per_run = pd.read_parquet(out / f"w{n}" / "per_run.parquet")
        score = per_run["score_s"].to_numpy(float)
        print(json.dumps({
            "workers": n, "runs": a.runs, "scored": res["scored"], "wall_s": round(wall, 2),
            "runs_per_minute": round(60.0 * a.runs / wall, 2),
            "harness_share": round(res["harness_share"], 4),
            "score_s_mean": round(float(score.mean()), 4),
            "score_s_max": round(float(score.max()), 4),
            "mean_run_parts_s": {k: round(v, 3) for k, v in parts.items()},
            "load_average_before_after": [round(load0, 2), round(os.getloadavg()[0], 2)]}))
    if a.profile:
        profile_scoring(sorted((out / f"w{a.workers[-1]}" / "runs").glob("seed-*"))[0])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
