"""Monte Carlo throughput: replications per minute with one and with two Dask workers.

For each cluster size: start a local cluster (single-threaded worker processes), run a
warm-up study of one run per worker (imports, table files read once per worker), then time
a study of ``--runs`` replications (dispatch, runs, reduction and the CSV files). The
cluster start-up is reported separately. Usage::

    python benchmarks/montecarlo.py [--scenario scenarios/single_missile.yaml] [--runs 16]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

ROOT = Path(__file__).resolve().parents[1]


def measure(scenario, runs: int, workers: int, out_dir: Path) -> dict:
    from distributed import Client, LocalCluster

    from shipradar.sim.studies.montecarlo import run_study

    t0 = time.perf_counter()
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        client.wait_for_workers(workers)
        start_s = time.perf_counter() - t0
        run_study(scenario, workers, out=out_dir / f"warm{workers}.csv", progress=False,
                  client=client, seed=999)
        t1 = time.perf_counter()
        res = run_study(scenario, runs, out=out_dir / f"study{workers}.csv", progress=False,
                        client=client)
        wall = time.perf_counter() - t1
    return {"workers": workers, "runs": runs, "wall_s": round(wall, 3),
            "runs_per_minute": round(60.0 * runs / wall, 1),
            "cluster_start_s": round(start_s, 2), "processes_used": res["worker_pids"]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default=str(ROOT / "scenarios" / "single_missile.yaml"))
    ap.add_argument("--runs", type=int, default=16)
    a = ap.parse_args(argv)
    from shipradar.sim.world.scenario import load_scenario
    from shipradar.tables.scene import load_scene_tables

    sc = load_scenario(a.scenario)
    load_scene_tables(sc)  # tables in the cache before any timing
    with tempfile.TemporaryDirectory() as tmp:
        one = measure(sc, a.runs, 1, Path(tmp))
        two = measure(sc, a.runs, 2, Path(tmp))
    print(json.dumps({"scenario": sc.name, "cores": os.cpu_count(), "one_worker": one,
                      "two_workers": two,
                      "speed_up": round(two["runs_per_minute"] / one["runs_per_minute"], 2)},
                     indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
