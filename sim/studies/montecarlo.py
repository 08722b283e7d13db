"""Monte Carlo studies on Dask: many replications of one scenario, tidy results, P_d vs range.

``shipradar montecarlo SCENARIO --runs N [--scheduler ADDRESS]`` (entry :func:`cli_main`).

How a study runs
----------------
1. The scene's tables are built (or found) once, in this process, by
   :func:`shipradar.tables.scene.load_scene_tables`; the workers then *read* those cache files
   (:meth:`shipradar.tables.store.Table.load`), once per worker process, and never run a builder.
   With a remote scheduler the workers must see the same cache directory (``$SHIPRADAR_TABLES``
   on a shared file system); if a table has no cache file the tables are sent to the workers
   instead (``Client.scatter``, broadcast).
2. Per-run seeds: ``numpy.random.SeedSequence(seed).spawn(runs)``, ``seed`` being the
   scenario's (or the one given); run ``i`` uses the 63-bit integer
   :func:`run_seed` of child ``i``. The study is reproducible whatever the number of workers
   or the order in which runs finish (results are put back in run order).
3. Each run is a :class:`shipradar.sim.engine.simulation.Simulation` with an in-memory bus; its
truth topic links
   every plot to its origin, from which the worker reduces the run to rows (below).

Definitions (per run, sensor and target)
----------------------------------------
- A *look* is a scan in which the target was active and inside the instrumented range at the
  end of scan (ground range from the sensor's end-of-scan position, both from the stream),
  or in which it produced a plot. Its range is that end-of-scan range, so a look's range is
  off by at most the distance the target covers in one scan (≤ 300 m for a Mach-1 target and
  a 1 s scan): bin widths of 1 km or more are not affected.
- *Detected*: at least one plot of the scan has the target among its contributors (a plot of
  unresolved targets, seed 2.2.1, credits each of them). *Misses* = looks − detections.
- *False alarms by origin*: plots whose truth origin is noise or sea clutter, per run.

Files written (``out`` = ``study.csv``)
---------------------------------------
- ``study.csv``: one row per run, sensor and target: ``run, seed, sensor, target, kind,
  scans, looks, detections, misses, first_detection_range_m, first_detection_time_s,
  noise_false_alarms, sea_clutter_false_alarms`` (the false-alarm counts are the run's and
  repeat on each target row of that run). A scene without targets gets one row per run with
  an empty target.
- ``study_looks.csv``: one row per look: ``run, sensor, target, kind, scan, time_s, range_m,
  detected``.
- ``study_pd_range.csv``: P_d against range per sensor and target kind: ``range_lo_m,
  range_hi_m, looks, detections, pd, ci_lo, ci_hi`` (Wilson score interval, 95 %).
- ``study_false_alarms.csv``: false alarms per scan per sensor and origin, with the exact
  (Garwood) Poisson 95 % interval of the rate.

Rows are sorted and floats written with ``repr``, so two studies with the same seed write
byte-identical files.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
import threading
import time
import uuid
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from shipradar.sim.dwell.look import LookResults
from shipradar.sim.stream.sink import MemorySink

__all__ = [
    "cli_main",
    "model_pd_looks",
    "poisson_interval",
    "reduce_run",
    "run_seed",
    "run_study",
    "wilson_interval",
]

#: Default width of the range bins of P_d against range [m].
DEFAULT_BIN_M = 2000.0
#: Confidence level of every interval written.
CONFIDENCE = 0.95

RESULT_COLUMNS = ("run", "seed", "sensor", "target", "kind", "scans", "looks", "detections",
                  "misses", "first_detection_range_m", "first_detection_time_s",
                  "noise_false_alarms", "sea_clutter_false_alarms")
LOOK_COLUMNS = ("run", "sensor", "target", "kind", "scan", "time_s", "range_m", "detected")
PD_COLUMNS = ("sensor", "kind", "range_lo_m", "range_hi_m", "looks", "detections", "pd",
              "ci_lo", "ci_hi")
FA_COLUMNS = ("sensor", "origin", "runs", "scans", "false_alarms", "per_scan", "ci_lo",
              "ci_hi")
ORIGIN_NOISE, ORIGIN_SEA_CLUTTER = 1, 2  # shipradar.sim.engine.simulation's codes (truth topic)


# --------------------------------------------------------------------------- statistics
def wilson_interval(successes, trials, confidence: float = CONFIDENCE):
    """Wilson score interval of a binomial proportion.

    Parameters
    ----------
    successes, trials : int or array_like
        Counts (trials > 0).
    confidence : float
        Two-sided level, e.g. 0.95.

    Returns
    -------
    (lo, hi) : float or ndarray
        Bounds in [0, 1]. Wilson (1927), J. Am. Stat. Assoc. 22, 209; keeps its coverage at
        P_d near 0 or 1 where the normal (Wald) interval collapses to a point.
    """
    from scipy.stats import norm

    x = np.asarray(successes, dtype=float)
    n = np.asarray(trials, dtype=float)
    z = norm.ppf(0.5 + 0.5 * confidence)
    p = x / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2.0 * n)) / denom
    half = z * np.sqrt(p * (1.0 - p) / n + z * z / (4.0 * n * n)) / denom
    # exact ends at x = 0 and x = n (the formula leaves rounding residue of ~1e-17 there)
    lo = np.where(x <= 0.0, 0.0, np.clip(centre - half, 0.0, 1.0))
    hi = np.where(x >= n, 1.0, np.clip(centre + half, 0.0, 1.0))
    return (lo[()], hi[()])


def poisson_interval(count, exposure, confidence: float = CONFIDENCE):
    """Exact (Garwood 1936) interval of a Poisson rate: ``count`` events in ``exposure``.

    Returns (lo, hi) of the rate [events per unit exposure]; lo = 0 for a zero count.
    """
    from scipy.stats import chi2

    k = np.asarray(count, dtype=float)
    a = 1.0 - confidence
    lo = np.where(k > 0, 0.5 * chi2.ppf(0.5 * a, 2.0 * np.maximum(k, 1.0)), 0.0)
    hi = 0.5 * chi2.ppf(1.0 - 0.5 * a, 2.0 * k + 2.0)
    return lo / exposure, hi / exposure


def run_seed(child: np.random.SeedSequence) -> int:
    """The 63-bit integer seed a run passes to the engine, from its spawned SeedSequence."""
    return int(child.generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))


# --------------------------------------------------------------------------- one run
def reduce_run(messages: Sequence[tuple[bytes, float, dict]], scenario, run: int,
               seed: int) -> dict[str, list[dict]]:
    """Rows of one run from its messages ``(topic, t_sim, payload)`` (see module docstring).

    Only ``meta``, ``eos`` and ``truth`` are read. Returns ``{"results": [...], "looks":
    [...], "false_alarms": [...]}`` (lists of row dicts).
    """
    kinds = [t.kind for t in scenario.targets]
    ids = [t.id for t in scenario.targets]
    n_t = len(ids)
    per_sensor: dict[str, dict[str, Any]] = {}

    def sensor_state(name):
        return per_sensor.setdefault(name, {
            "detected": {}, "eos": {}, "truth": {}, "fa": {ORIGIN_NOISE: 0, ORIGIN_SEA_CLUTTER: 0},
            "r_max": None})

    for topic, _t, p in messages:
        if topic not in (b"meta", b"eos", b"truth"):  # plots, the run's end
            continue
        st = sensor_state(p["sensor"])
        if topic == b"meta":
            st["r_max"] = float(p["radar"]["instrumented_range_m"])
        elif topic == b"eos":
            st["eos"][p["scan"]] = p
        elif topic == b"truth" and p["kind"] == "targets":
            st["truth"][p["scan"]] = p
        elif topic == b"truth" and p["kind"] == "plots":
            origin = np.asarray(p["origin"])
            for code in (ORIGIN_NOISE, ORIGIN_SEA_CLUTTER):
                st["fa"][code] += int(np.count_nonzero(origin == code))
            contrib = np.asarray(p["contrib_targets"])
            lead = np.asarray(p["target"])[origin == 0]
            hit = set(contrib.tolist()) | set(lead[lead >= 0].tolist())
            st["detected"].setdefault(p["scan"], set()).update(hit)
    results, looks, fas = [], [], []
    for sensor in sorted(per_sensor):
        st = per_sensor[sensor]
        n_scans = len(st["eos"])
        first: list[tuple[float, float] | None] = [None] * n_t
        count = np.zeros((n_t, 2), dtype=int)  # looks, detections
        for scan in sorted(st["eos"]):
            eos, truth = st["eos"][scan], st["truth"].get(scan)
            if truth is None:
                continue
            det = st["detected"].get(scan, set())
            pe, pn = eos["position"]["east_m"], eos["position"]["north_m"]
            rng_m = np.hypot(np.asarray(truth["east_m"]) - pe, np.asarray(truth["north_m"]) - pn)
            active = np.asarray(truth["active"], bool)
            r_max = st["r_max"] if st["r_max"] is not None else np.inf
            for i in range(n_t):
                d = i in det
                if not (d or (active[i] and rng_m[i] <= r_max)):
                    continue
                count[i, 0] += 1
                count[i, 1] += d
                if d and first[i] is None:
                    first[i] = (float(rng_m[i]), float(eos["time_s"]))
                looks.append({"run": run, "sensor": sensor, "target": ids[i], "kind": kinds[i],
                              "scan": int(scan), "time_s": float(eos["time_s"]),
                              "range_m": float(rng_m[i]), "detected": int(d)})
        fa_n, fa_c = st["fa"][ORIGIN_NOISE], st["fa"][ORIGIN_SEA_CLUTTER]
        for origin_name, k in (("noise", fa_n), ("sea_clutter", fa_c)):
            fas.append({"run": run, "sensor": sensor, "origin": origin_name, "scans": n_scans,
                        "false_alarms": k})
        base = {"run": run, "seed": seed, "sensor": sensor, "scans": n_scans,
                "noise_false_alarms": fa_n, "sea_clutter_false_alarms": fa_c}
        if n_t == 0:
            results.append(dict(base, target="", kind="", looks=0, detections=0, misses=0,
                                first_detection_range_m="", first_detection_time_s=""))
        for i in range(n_t):
            fi = first[i]
            results.append(dict(
                base, target=ids[i], kind=kinds[i], looks=int(count[i, 0]),
                detections=int(count[i, 1]), misses=int(count[i, 0] - count[i, 1]),
                first_detection_range_m="" if fi is None else fi[0],
                first_detection_time_s="" if fi is None else fi[1]))
    return {"results": results, "looks": looks, "false_alarms": fas}


# Per worker process: tables read from the cache once, keyed by their files.
_WORKER_TABLES: dict[tuple, Any] = {}
_WORKER_LOCK = threading.Lock()
#: Per worker process: the preparation of the study's scenario on its tables
#: (:class:`shipradar.sim.dwell.prepared.PreparedScene`) by the scenario's token (its content,
#: :func:`dask.base.tokenize` in the client), made by a worker's first run and passed to its
#: next runs of that scenario on the same tables; one kept, the last study's.
_WORKER_PREPARED: dict[str, Any] = {}


def _worker_prepared(token: str, tables):
    """The preparation this worker keeps for the scenario of ``token`` on ``tables``, or
    None."""
    with _WORKER_LOCK:
        prepared = _WORKER_PREPARED.get(token)
        return prepared if prepared is not None and prepared.tables is tables else None


def _keep_prepared(token: str, prepared) -> None:
    with _WORKER_LOCK:
        _WORKER_PREPARED.clear()
        _WORKER_PREPARED[token] = prepared


def _tables_from_files(files: tuple[tuple[str, str, str], ...]):
    from shipradar.tables.scene import SceneTables
    from shipradar.tables.store import Table

    with _WORKER_LOCK:
        scene = _WORKER_TABLES.get(files)
        if scene is None:
            scene = SceneTables()
            for radar_id, kind, path in files:
                setattr(scene.for_radar(radar_id), kind, Table.load(path))
            _WORKER_TABLES[files] = scene
        return scene


def _table_files(scene, radar_ids: Sequence[str]) -> tuple[tuple[str, str, str], ...] | None:
    """(radar, kind, cache file) of every table of the scene; None if one has no file."""
    from dataclasses import fields

    from shipradar.tables.store import cache_path

    out = []
    for rid in radar_ids:
        rt = scene.for_radar(rid)
        for f in fields(rt):
            table = getattr(rt, f.name)
            if table is None:
                continue
            path = cache_path(table.name, table.key)
            if not path.exists():
                return None
            out.append((rid, f.name, str(path.resolve())))
    return tuple(out)


def _one_run(scenario, run: int, seed: int, duration_s, tables_ref, token: str) -> dict:
    """A Dask task: one replication, reduced to rows in the worker. ``token`` names the
    scenario's content: a run of the scenario a previous run of this worker prepared runs
    that (equal) scenario object with its preparation."""
    from shipradar.sim.engine.simulation import Simulation

    if isinstance(tables_ref, tuple):
        tables = _tables_from_files(tables_ref)
    else:
        tables = tables_ref
    prepared = _worker_prepared(token, tables)
    if prepared is not None:
        scenario = prepared.scenario  # the same content (token): the object it was made for
    bus = MemorySink(skip={b"plots"})  # truth, eos and meta only
    sim = Simulation(scenario, bus=bus, seed=seed, duration_s=duration_s, tables=tables,
                     prepared=prepared)
    _keep_prepared(token, sim.prepared)
    summary = sim.run()
    out: dict[str, Any] = dict(reduce_run(bus.messages, scenario, run, seed))
    out["summary"] = {"run": run, "wall_s": summary.get("wall_s"), "pid": os.getpid()}
    return out


# --------------------------------------------------------------------------- aggregation
def aggregate_pd(looks: list[dict], bin_m: float = DEFAULT_BIN_M) -> list[dict]:
    """P_d against range per sensor and target kind, with Wilson intervals."""
    groups: dict[tuple, np.ndarray] = {}
    for row in looks:
        key = (row["sensor"], row["kind"], int(row["range_m"] // bin_m))
        acc = groups.setdefault(key, np.zeros(2, dtype=int))
        acc += (1, int(row["detected"]))
    rows = []
    for (sensor, kind, b), (n, x) in sorted(groups.items()):
        lo, hi = wilson_interval(x, n)
        rows.append({"sensor": sensor, "kind": kind, "range_lo_m": b * bin_m,
                     "range_hi_m": (b + 1) * bin_m, "looks": int(n), "detections": int(x),
                     "pd": float(x / n), "ci_lo": float(lo), "ci_hi": float(hi)})
    return rows


def aggregate_false_alarms(fas: list[dict]) -> list[dict]:
    """False alarms per scan per sensor and origin, with the exact Poisson interval."""
    groups: dict[tuple, list[int]] = {}
    for row in fas:
        acc = groups.setdefault((row["sensor"], row["origin"]), [0, 0, 0])
        acc[0] += 1
        acc[1] += row["scans"]
        acc[2] += row["false_alarms"]
    rows = []
    for (sensor, origin), (runs, scans, k) in sorted(groups.items()):
        lo, hi = poisson_interval(k, scans) if scans else (float("nan"), float("nan"))
        rows.append({"sensor": sensor, "origin": origin, "runs": runs, "scans": scans,
                     "false_alarms": k, "per_scan": k / scans if scans else float("nan"),
                     "ci_lo": float(lo), "ci_hi": float(hi)})
    return rows


def _write_csv(path: Path, columns: Sequence[str], rows: list[dict]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(columns)
        for row in rows:
            w.writerow([_cell(row[c]) for c in columns])


def _cell(v):
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float):
        return repr(v)
    return v


def study_paths(out: str | os.PathLike) -> dict[str, Path]:
    """The four files of a study written to ``out`` (see the module docstring)."""
    out = Path(out)
    stem = out.with_suffix("")
    return {"results": out, "looks": Path(f"{stem}_looks.csv"),
            "pd_range": Path(f"{stem}_pd_range.csv"),
            "false_alarms": Path(f"{stem}_false_alarms.csv")}


# --------------------------------------------------------------------------- study
def run_study(
    scenario,
    runs: int,
    *,
    scheduler: str | None = None,
    n_workers: int | None = None,
    seed: int | None = None,
    out: str | os.PathLike = "montecarlo.csv",
    duration_s: float | None = None,
    bin_m: float = DEFAULT_BIN_M,
    progress: bool = True,
    client=None,
) -> dict[str, Any]:
    """Run ``runs`` replications of a scenario on Dask and write the study's files.

    Parameters
    ----------
    scenario : str, path-like or shipradar.sim.world.scenario.Scenario
        Scenario file or object.
    runs : int
        Number of replications (>= 1).
    scheduler : str or None
        Address of an existing Dask scheduler (``tcp://host:8786``); None starts a local
        cluster of ``n_workers`` single-threaded worker processes.
    n_workers : int or None
        Local cluster size; default the number of cores.
    seed : int or None
        Study seed; default the scenario's.
    out : path-like
        Results CSV; the other files are written beside it (:func:`study_paths`).
    duration_s : float or None
        Override the scenario's duration [s].
    bin_m : float
        Range bin width of P_d against range [m].
    progress : bool
        Show a progress bar (tqdm, on stderr) as runs complete.
    client : distributed.Client or None
        Use this client (and leave it open) instead of creating one.

    Returns
    -------
    dict
        ``files`` (paths), ``runs``, ``seed``, ``n_workers``, ``wall_s``,
        ``runs_per_minute``, ``worker_pids`` (distinct processes that ran replications).
    """
    from shipradar.sim.world.scenario import Scenario, load_scenario

    if runs < 1:
        raise ValueError(f"runs must be >= 1, got {runs}")
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    base_seed = scenario.seed if seed is None else int(seed)
    seeds = [run_seed(c) for c in np.random.SeedSequence(base_seed).spawn(runs)]
    tables, files = _study_tables(scenario, progress)
    t0 = time.perf_counter()
    done, workers = _run_replications(scenario, seeds, base_seed, duration_s, tables, files,
                                      scheduler=scheduler, n_workers=n_workers, client=client,
                                      progress=progress)
    wall = time.perf_counter() - t0
    paths = _write_study(done, out, bin_m)
    return {
        "scenario": scenario.name,
        "files": {k: str(v) for k, v in paths.items()},
        "runs": runs,
        "seed": base_seed,
        "n_workers": workers,
        "wall_s": round(wall, 3),
        "runs_per_minute": round(60.0 * runs / wall, 2) if wall > 0 else None,
        "worker_pids": len({res["summary"]["pid"] for res in done}),
        "tables_from_cache_files": files is not None,
    }


def _study_tables(scenario, progress: bool) -> tuple[Any, tuple[tuple[str, str, str], ...] | None]:
    """The off-line level, once, here (step 1 of the module docstring): the scene's tables
    and their cache files (None if one has none: the tables are then sent to the workers)."""
    from shipradar.tables.scene import load_scene_tables

    tables = load_scene_tables(scenario, log=sys.stderr if progress else None)
    return tables, _table_files(tables, [r.id for _, r in scenario.radars()])


def local_cluster(n_workers: int | None) -> Any:
    """A Dask cluster of ``n_workers`` single-threaded worker processes on this machine (all
    cores when None or 0), its HTTP server on a free port (``dashboard_address=None`` still
    binds 8787, and warns when another study holds it); the caller closes it."""
    from distributed import LocalCluster

    return LocalCluster(n_workers=n_workers or os.cpu_count() or 1, threads_per_worker=1,
                        processes=True, dashboard_address=":0")


def task_keys(kind: str, base_seed: int, n: int) -> list[str]:
    """Dask keys of a study's ``n`` tasks: ``shipradar-{kind}-{base_seed}-{i}-{study}``, the
    last part random per call. Dask takes a submitted key it still holds as the same task and
    hands back that task's future (``pure=False`` does not change this for an explicit key),
    so two studies with the same seeds in one client would share results without it (a second
    study got the first one's runs: tests/test_evaluate.py's rescore test failed 2 in 9)."""
    study = uuid.uuid4().hex[:12]
    return [f"shipradar-{kind}-{base_seed}-{i}-{study}" for i in range(n)]


def _run_replications(scenario, seeds: list[int], base_seed: int, duration_s: float | None,
                      tables, files, *, scheduler: str | None, n_workers: int | None,
                      client, progress: bool) -> tuple[list[dict], int]:
    """Every replication as a Dask task (:func:`_one_run`) on ``client``, or on a client
    to ``scheduler``, or on a local cluster of ``n_workers`` processes (those two closed
    after); returns the runs' reduced rows in run order and the number of workers."""
    from distributed import Client, as_completed

    cluster = own_client = None
    try:
        if client is None:
            if scheduler is None:
                cluster = local_cluster(n_workers)
                own_client = client = Client(cluster)
            else:
                own_client = client = Client(scheduler)
        from dask.base import tokenize

        tables_ref = files if files is not None else client.scatter(tables, broadcast=True)
        # the scenario's content, by which a worker finds the preparation of its runs
        token = tokenize(scenario)
        keys = task_keys("run", base_seed, len(seeds))
        futures = [client.submit(_one_run, scenario, i, s, duration_s, tables_ref, token,
                                 key=keys[i], pure=False)
                   for i, s in enumerate(seeds)]
        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=len(seeds), unit="run", file=sys.stderr, desc=scenario.name)
        done: dict[int, dict] = {}
        for fut in as_completed(futures):
            res = fut.result()
            done[res["summary"]["run"]] = res
            if bar is not None:
                bar.update(1)
        if bar is not None:
            bar.close()
        workers = len(client.scheduler_info().get("workers", {}))
    finally:
        if own_client is not None:
            own_client.close()
        if cluster is not None:
            cluster.close()
    return [done[i] for i in range(len(seeds))], workers


def _write_study(done: list[dict], out: str | os.PathLike, bin_m: float) -> dict[str, Path]:
    """The study's four files (:func:`study_paths`) from the runs' rows, sorted."""
    results: list[dict] = []
    looks: list[dict] = []
    fas: list[dict] = []
    for res in done:
        results += res["results"]
        looks += res["looks"]
        fas += res["false_alarms"]
    results.sort(key=lambda r: (r["run"], r["sensor"], r["target"]))
    looks.sort(key=lambda r: (r["run"], r["sensor"], r["target"], r["scan"]))
    paths = study_paths(out)
    _write_csv(paths["results"], RESULT_COLUMNS, results)
    _write_csv(paths["looks"], LOOK_COLUMNS, looks)
    _write_csv(paths["pd_range"], PD_COLUMNS, aggregate_pd(looks, bin_m))
    _write_csv(paths["false_alarms"], FA_COLUMNS, aggregate_false_alarms(fas))
    return paths


# --------------------------------------------------------------------------- model P_d
def model_pd_looks(scenario, *, tables=None, duration_s: float | None = None, bus=None,
                   seed: int | None = None) -> list[dict]:
    """The dwell model's P_d at every beam crossing of every target (no random draw used).

    Runs the engine once and records, for each target the beam crosses inside the
    instrumented range, the P_d the dwell model computed before its detection draw: the
    exact probability every replication draws from, since crossings depend on the
    kinematics only. ``bus`` (optional) receives the run's messages, so the same run can
    feed a figure. Rows: ``sensor, target, kind, scan, time_s, ground_range_m, pd``, sorted
    by sensor, target and time.

    Notes
    -----
    The P_d is read through the dwell model's look hook (``DwellModel.on_look``, one
    :class:`shipradar.sim.dwell.look.LookResults` per call), whatever the fidelity's
    ``pd_method`` (exact, seed or table). Targets merged into one contact (2.2.1) share
    their contact's P_d and are skipped (rare: same range cell, beam and Doppler filter).
    """
    from shipradar.sim.engine.simulation import Simulation

    sim = Simulation(scenario, tables=tables, duration_s=duration_s, bus=bus, seed=seed)
    rows: list[dict] = []
    for rp in sim.radars:
        rp.model.on_look.append(_pd_recorder(rows, scenario, rp.sector_s, rp.n_sectors))
    sim.run()
    rows.sort(key=lambda r: (r["sensor"], r["target"], r["time_s"]))
    return rows


def _pd_recorder(rows: list[dict], scenario, sector_s: float, n_sectors: int):
    """An observer of a dwell model's looks appending one row per unmerged target to
    ``rows`` (:func:`model_pd_looks`); the scan is the revolution of the crossing's sector."""
    kinds = [t.kind for t in scenario.targets]
    ids = [t.id for t in scenario.targets]

    def record(look: LookResults) -> None:
        for j in np.flatnonzero(~look.merged):
            i = int(look.target[j])
            t = float(look.time_s[j])
            rows.append({"sensor": look.radar, "target": ids[i], "kind": kinds[i],
                         "scan": int(math.floor(t / sector_s + 1e-9)) // n_sectors,
                         "time_s": t, "ground_range_m": float(look.ground_range_m[j]),
                         "pd": float(look.pd[j])})

    return record


# --------------------------------------------------------------------------- CLI
def cli_main(argv: list[str] | None = None) -> int:
    """``shipradar montecarlo SCENARIO --runs N [--scheduler ADDRESS] ...``; returns 0."""
    ap = argparse.ArgumentParser(
        prog="shipradar montecarlo",
        description="Replicate a scenario on Dask; write tidy results, P_d against range "
                    "and false alarms per scan with confidence intervals.")
    ap.add_argument("scenario", help="scenario YAML")
    ap.add_argument("--runs", type=int, required=True, help="number of replications")
    ap.add_argument("--scheduler", default=None,
                    help="address of a Dask scheduler (default: a local cluster)")
    ap.add_argument("--workers", type=int, default=None,
                    help="local cluster: worker processes (default: cores)")
    ap.add_argument("--seed", type=int, default=None, help="study seed (default: scenario's)")
    ap.add_argument("--duration", type=float, default=None, help="override duration [s]")
    ap.add_argument("--out", default="montecarlo.csv", help="results CSV (others beside it)")
    ap.add_argument("--bin", type=float, default=DEFAULT_BIN_M, help="range bin [m]")
    ap.add_argument("--no-progress", action="store_true", help="no progress bar")
    a = ap.parse_args(argv)
    summary = run_study(a.scenario, a.runs, scheduler=a.scheduler, n_workers=a.workers,
                        seed=a.seed, out=a.out, duration_s=a.duration, bin_m=a.bin,
                        progress=not a.no_progress)
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    raise SystemExit(cli_main())
