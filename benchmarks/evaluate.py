"""``shipradar evaluate``: runs per minute on 1 and 2 workers, and the harness's own share.

    python benchmarks/evaluate.py [--runs 8] [--duration 110] [--tracker CMD] [--out DIR]

Each study runs the demo scene (single missile) with the tracker (default: the Stone Soup CV
example, ``examples/track_stonesoup.py``) on a ``LocalCluster`` of 1, then 2 workers, the
same seeds. Printed per study: runs/minute (wall time of the whole study, cluster start-up
excluded: the client is opened first), and the harness's share of a run: its own work
(``harness_s``: stopping the tracker, writing the files; plus the scoring, ``score_s``)
over the run's wall time, which also holds the simulation with the tracker reading
(``run_s``), the drain and the start-up of tracker and scenario (``startup_s``).
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=8)
    ap.add_argument("--duration", type=float, default=110.0)
    ap.add_argument("--scenario", default=str(ROOT / "scenarios" / "single_missile.yaml"))
    ap.add_argument("--tracker", default=f"{shlex.quote(sys.executable)} "
                    f"{shlex.quote(str(ROOT / 'examples' / 'track_stonesoup.py'))} {{plots}} "
                    f"--publish-tracks {{tracks}} --quiet")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    from distributed import Client, LocalCluster

    from shipradar.sim.studies.evaluate.study import run_study

    out = Path(a.out or tempfile.mkdtemp(prefix="bench-evaluate-"))
    print(f"load average before: {os.getloadavg()[0]:.2f}", file=sys.stderr)
    for n in a.workers:
        with LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            t0 = time.perf_counter()
            res = run_study(a.scenario, a.tracker, runs=a.runs, out=out / f"w{n}", seed=1,
                            duration_s=a.duration, client=client, report=False)
            wall = time.perf_counter() - t0
        runs = [json.loads(p.read_text()) for p in sorted((out / f"w{n}" / "runs").glob(
            "*/run.json"))]
        parts = {k: float(np.mean([r.get(k) or 0.0 for r in runs]))
                 for k in ("wall_s", "startup_s", "run_s", "drain_s", "harness_s")}
        print(json.dumps({
            "workers": n, "runs": a.runs, "scored": res["scored"], "wall_s": round(wall, 2),
            "runs_per_minute": round(60.0 * a.runs / wall, 2),
            "harness_share": round(res["harness_share"], 4),
            "mean_run_parts_s": {k: round(v, 3) for k, v in parts.items()},
            "load_average": round(os.getloadavg()[0], 2)}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
