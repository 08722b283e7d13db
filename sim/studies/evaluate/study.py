"""A study: the seeded runs of one tracker on one scene, on Dask; rescoring; comparison.

Layout of a study directory ``DIR``:

- ``study.json``: the scenario, tracker command, seeds, duration, metric settings;
- ``runs/seed-<seed>/``: each run's files (:mod:`shipradar.sim.studies.evaluate.data`);
- ``per_scan``, ``per_run``, ``per_target``: every run's rows, ``.csv`` and ``.parquet``;
- ``summary.csv`` (per-run figures over runs: mean and 95 % interval),
  ``summary_scan.csv``, ``summary_target.csv``;
- with a tracker that publishes ``registration``: ``registration`` (per run, radar and
  component: RMSE, time to converge), ``registration_series`` (per estimate) and
  ``summary_registration.csv``
  (:mod:`shipradar.sim.studies.evaluate.registration`);
- ``index.html`` and its SVG figures (:mod:`shipradar.sim.studies.evaluate.report`).

Runs go to Dask: a ``LocalCluster`` (one single-threaded worker process per core, or
``workers``) by default, or an existing cluster (``scheduler``). Each run's simulator and
tracker run in the worker, which also scores it; the run directory must be on a file system
the workers and the client share (as the table cache, ``$SHIPRADAR_TABLES``, must be: the
tables are built once here, before any run, and the workers read them from the cache).
Seeds: ``SeedSequence(seed).spawn(runs)`` as ``shipradar montecarlo`` does, so a study's
seeds do not depend on the cluster, and two studies with the same ``--seed`` are paired run
by run.
"""

from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from shipradar.sim.studies.evaluate import registration, stats
from shipradar.sim.studies.evaluate.data import load_run
from shipradar.sim.studies.evaluate.metrics import (
    DEFAULT_METRICS,
    MetricConfig,
    RunScores,
    score_run,
)
from shipradar.sim.studies.evaluate.runner import RunSpec, run_and_collect

__all__ = ["compare", "rescore", "run_dir_name", "run_study", "study_seeds", "write_results"]


def study_seeds(seed: int, runs: int) -> list[int]:
    """The seeds of a study's runs (as ``shipradar montecarlo``'s)."""
    from shipradar.sim.studies.montecarlo import run_seed

    return [run_seed(c) for c in np.random.SeedSequence(int(seed)).spawn(runs)]


def run_dir_name(seed: int) -> str:
    return f"seed-{seed}"


def _failed_row(info: dict[str, Any]) -> dict[str, Any]:
    return {"seed": info["seed"], "status": "failed", "error": info.get("error"),
            "exit_code": info.get("exit_code"), "stderr_tail": info.get("stderr_tail", "")}


def _score_dir(run_dir: str, config: MetricConfig) -> tuple[dict[str, Any], RunScores | None]:
    """(run.json, scores) of a run directory; no scores for a failed run."""
    info = json.loads((Path(run_dir) / "run.json").read_text())
    if info.get("status") != "ok":
        return info, None
    return info, score_run(load_run(run_dir), config)


def _run_and_score(spec: RunSpec, config: MetricConfig) -> tuple[dict, RunScores | None]:
    """In the worker: one run, then its scores from the data collected during the run (the
    same as ``load_run(spec.run_dir)``; the harness's scoring time is counted)."""
    info, data = run_and_collect(spec)
    if data is None:
        return info, None
    t0 = time.perf_counter()
    try:
        scores = score_run(data, config)
    except Exception as exc:  # noqa: BLE001 - reported on the run; the others are scored
        info.update(status="failed", error=f"scoring error: {exc!r}")
        return info, None
    info["score_s"] = time.perf_counter() - t0 + info.get("collect_s", 0.0)
    return info, scores


# long: 28 docstring lines; the study's steps (runs, scheduler, scores, report)
# params: shipradar evaluate's options, by keyword (the public API mirrors the CLI)
def run_study(scenario: str, tracker: str, *, runs: int, out: str | Path,
              seed: int | None = None, duration_s: float | None = None,
              config: MetricConfig = DEFAULT_METRICS, scheduler: str | None = None,
              workers: int | None = None, client=None, wait_timeout_s: float = 30.0,
              stall_timeout_s: float = 120.0, drain_s: float = 5.0,
              realtime: float | None = None, progress: bool = False,
              report: bool = True, entities: str | None = None) -> dict[str, Any]:
    """Run and score a study (module docstring); returns :func:`write_results`' summary.

    Parameters
    ----------
    scenario : str
        Scenario file.
    tracker : str
        The tracker command, with ``{plots}``, ``{tracks}``, ``{asterix}``, ``{seed}``,
        ``{run_dir}`` placeholders (:mod:`shipradar.sim.studies.evaluate.runner`).
    runs : int
        Seeded runs (>= 1).
    out : path
        Study directory (created).
    seed : int or None
        Seed of the seeds; None: the scenario's.
    duration_s : float or None
        Simulated seconds per run; None: the scenario's.
    config : MetricConfig
    scheduler : str or None
        Address of a running Dask scheduler; None: a ``LocalCluster``.
    workers : int or None
        Workers of the ``LocalCluster`` (default: the cores).
    client : distributed.Client or None
        An open client to use instead.
    entities : str or None
        A recording whose ``entities`` topic moves the targets in every run (a live session
        re-simulated with each seed, ``shipradar run --entities RECORDING``).
    """
    from distributed import Client, as_completed

    from shipradar.sim.studies.montecarlo import local_cluster, task_keys
    from shipradar.sim.world.scenario import load_scenario
    from shipradar.tables.scene import load_scene_tables

    if runs < 1:
        raise ValueError(f"runs must be >= 1, got {runs}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    scenario = str(Path(scenario).resolve())
    s = load_scenario(scenario)
    base = s.seed if seed is None else int(seed)
    seeds = study_seeds(base, runs)
    load_scene_tables(s, log=sys.stderr if progress else None)  # built once, here
    settings = {"scenario": scenario, "scenario_name": s.name, "tracker": tracker,
                "runs": runs, "seed": base, "seeds": seeds, "duration_s": duration_s,
                "metrics": config.as_dict(), "realtime": realtime}
    if entities is not None:
        entities = str(Path(entities).resolve())
        settings["entities"] = entities
    (out / "study.json").write_text(json.dumps(settings, indent=1))
    specs = [RunSpec(scenario, sd, str((out / "runs" / run_dir_name(sd)).resolve()), tracker,
                     duration_s=duration_s, wait_timeout_s=wait_timeout_s,
                     stall_timeout_s=stall_timeout_s, drain_s=drain_s, realtime=realtime,
                     entities=entities)
             for sd in seeds]
    cluster = own = None
    t0 = time.perf_counter()
    try:
        if client is None:
            if scheduler is None:
                cluster = local_cluster(workers)
                own = client = Client(cluster)
            else:
                own = client = Client(scheduler)
        keys = task_keys("evaluate", base, len(specs))
        futures = [client.submit(_run_and_score, sp, config, pure=False, key=keys[i])
                   for i, sp in enumerate(specs)]
        results: dict[int, tuple[dict, RunScores | None]] = {}
        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=runs, unit="run", file=sys.stderr, desc="evaluate")
        for fut in as_completed(futures):
            info, scores = fut.result()
            results[info["seed"]] = (info, scores)
            if bar is not None:
                bar.update(1)
        if bar is not None:
            bar.close()
        n_workers = len(client.scheduler_info().get("workers", {}))
    finally:
        if own is not None:
            own.close()
        if cluster is not None:
            cluster.close()
    wall = time.perf_counter() - t0
    ordered = [results[sd] for sd in seeds]
    summary = write_results(out, ordered, settings, report=report)
    summary.update(wall_s=wall, workers=n_workers,
                   runs_per_minute=60.0 * runs / wall if wall > 0 else math.nan)
    infos = [i for i, _ in ordered]
    # of the worker's time on a run: the run itself (wall_s) and its scoring (score_s)
    costs = [(i.get("harness_s", 0.0) + i.get("score_s", 0.0))
             / (i["wall_s"] + i.get("score_s", 0.0)) for i in infos if i.get("wall_s")]
    summary["harness_share"] = float(np.mean(costs)) if costs else math.nan
    (out / "summary.json").write_text(json.dumps(summary, indent=1, default=str))
    return summary


def rescore(study_dir: str | Path, config: MetricConfig = DEFAULT_METRICS, *,
            report: bool = True) -> dict[str, Any]:
    """Score a study's recorded runs again (other metric settings), without running them."""
    study_dir = Path(study_dir)
    settings = json.loads((study_dir / "study.json").read_text())
    settings["metrics"] = config.as_dict()
    (study_dir / "study.json").write_text(json.dumps(settings, indent=1))
    results = [_score_dir(str(study_dir / "runs" / run_dir_name(sd)), config)
               for sd in settings["seeds"]]
    summary = write_results(study_dir, results, settings, report=report)
    (study_dir / "summary.json").write_text(json.dumps(summary, indent=1, default=str))
    return summary


def _frame(rows: list[dict[str, Any]]):
    import pandas as pd

    df = pd.DataFrame(rows)
    for c in df.columns:  # dicts (malformed_by_reason) as JSON text in the files
        if df[c].map(lambda v: isinstance(v, dict)).any():
            df[c] = df[c].map(lambda v: json.dumps(v) if isinstance(v, dict) else v)
    return df


def _write_table(out: Path, name: str, rows: list[dict[str, Any]]) -> None:
    df = _frame(rows)
    df.to_csv(out / f"{name}.csv", index=False, float_format="%.12g")
    df.to_parquet(out / f"{name}.parquet", index=False)


def write_results(out: str | Path, results: Sequence[tuple[dict, RunScores | None]],
                  settings: dict[str, Any], *, report: bool = True) -> dict[str, Any]:
    """Write the tables, the summaries and the report of scored runs.

    Returns
    -------
    dict
        ``runs``, ``scored``, ``failed`` (seed, error, exit code, stderr tail each),
        ``metrics`` (the summary rows: mean and 95 % interval of each per-run figure).
    """
    out = Path(out)
    per_scan, per_target, per_run, failed, holding = [], [], [], [], []
    reg_rows, reg_series = [], []
    for info, scores in results:
        if scores is None:
            failed.append(_failed_row(info))
            continue
        per_scan += scores.per_scan
        per_target += scores.per_target
        holding += scores.holding
        reg_rows += scores.registration
        reg_series += scores.registration_series
        per_run.append(dict(scores.run, wall_s=info.get("wall_s"),
                            harness_s=info.get("harness_s"), score_s=info.get("score_s")))
    _write_table(out, "per_scan", per_scan)
    _write_table(out, "per_target", per_target)
    _write_table(out, "per_run", per_run + failed)
    _write_table(out, "holding", holding)
    summary_rows = stats.summarise(per_run) + registration.summarise_run_metrics(per_run)
    reg_summary = registration.summarise_rows(reg_rows)
    if reg_rows:
        _write_table(out, "registration", reg_rows)
        _write_table(out, "registration_series", reg_series)
        _frame(reg_summary).to_csv(out / "summary_registration.csv", index=False,
                                   float_format="%.12g")
    _frame(summary_rows).to_csv(out / "summary.csv", index=False, float_format="%.12g")
    scan_rows = stats.by_key(per_scan, "scan", stats.SCAN_METRICS)
    target_rows = stats.by_key(per_target, "target", stats.TARGET_METRICS)
    _frame(scan_rows).to_csv(out / "summary_scan.csv", index=False, float_format="%.12g")
    _frame(target_rows).to_csv(out / "summary_target.csv", index=False, float_format="%.12g")
    summary = {"runs": len(results), "scored": len(per_run), "failed": failed,
               "metrics": summary_rows, "settings": settings}
    if reg_summary:
        summary["registration"] = reg_summary
    if report:
        from shipradar.sim.studies.evaluate.report import write_report

        summary["report"] = str(write_report(
            out, settings, per_run, holding, summary_rows, scan_rows, target_rows, failed,
            extra_html=registration.report_section(out, reg_summary, reg_series)))
    return summary


def _read_runs(study_dir: Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    import pandas as pd

    settings = json.loads((study_dir / "study.json").read_text())
    df = pd.read_parquet(study_dir / "per_run.parquet")
    rows = [r for r in df.to_dict("records") if r.get("status") == "ok"]
    return settings, rows


def compare(study_dirs: Sequence[str | Path], out: str | Path | None = None
            ) -> dict[str, Any]:
    """Two or more studies side by side on the same seeds: each one's means with intervals,
    and every other study's paired differences against the first.

    Writes ``compare.csv`` (and ``compare.html``) into ``out`` (default: the first study's
    directory). Studies whose seeds differ are paired on the seeds they share.
    """
    if len(study_dirs) < 2:
        raise ValueError("compare needs two study directories or more")
    dirs = [Path(d) for d in study_dirs]
    loaded = [_read_runs(d) for d in dirs]
    base_settings, base_rows = loaded[0]
    rows = []
    metrics = stats.RUN_METRICS + registration.run_metric_names(
        [r for _, runs in loaded for r in runs])
    for d, (settings, runs) in zip(dirs, loaded, strict=True):
        for r in stats.summarise(runs, metrics):
            rows.append({"study": str(d), "tracker": settings["tracker"], "kind": "mean", **r})
    for d, (settings, runs) in zip(dirs[1:], loaded[1:], strict=True):
        for r in stats.paired_differences(base_rows, runs, metrics):
            rows.append({"study": str(d), "tracker": settings["tracker"],
                         "kind": f"minus {dirs[0]}", "metric": r["metric"],
                         "mean": r["difference"], "low": r["low"], "high": r["high"],
                         "runs": r["runs"]})
    out = Path(out) if out is not None else dirs[0]
    out.mkdir(parents=True, exist_ok=True)
    _frame(rows).to_csv(out / "compare.csv", index=False, float_format="%.12g")
    from shipradar.sim.studies.evaluate.report import write_compare

    page = write_compare(out, dirs, [s for s, _ in loaded], rows)
    return {"rows": rows, "report": str(page), "csv": str(out / "compare.csv"),
            "studies": [str(d) for d in dirs],
            "seeds_in_common": len(set.intersection(*[{r["seed"] for r in runs}
                                                      for _, runs in loaded]))}


def evaluate_object(scenario, tracker, *, runs: int = 1, seed: int | None = None,
                    duration_s: float | None = None, tables=None,
                    config: MetricConfig = DEFAULT_METRICS,
                    out: str | Path | None = None) -> dict[str, Any]:
    """A study of an in-process tracker object (``shipradar.evaluate``), runs one after the
    other in this process.

    Parameters
    ----------
    scenario : Scenario
    tracker : object or callable
        See :func:`shipradar.sim.studies.evaluate.runner.run_tracker_object`.
    runs, seed, duration_s, tables, config
        As for :func:`run_study`.
    out : path or None
        Also write the study directory (run recordings for ``--rescore``, tables, report).

    Returns
    -------
    dict
        ``per_run``, ``per_scan``, ``per_target`` (rows), ``summary`` (per-run figures over
        runs with 95 % intervals), ``failed``.
    """
    from shipradar.sim.dwell.prepared import PreparedScene
    from shipradar.sim.studies.evaluate.runner import run_tracker_object
    from shipradar.tables.scene import load_scene_tables

    base = scenario.seed if seed is None else int(seed)
    seeds = study_seeds(base, runs)
    results = []
    # the runs share the scene's tables and their preparation (loaded once, not per run)
    tables = load_scene_tables(scenario) if tables is None else tables
    prepared = PreparedScene(scenario, tables)
    for sd in seeds:
        run_dir = None if out is None else Path(out) / "runs" / run_dir_name(sd)
        data = run_tracker_object(scenario, tracker, seed=sd, duration_s=duration_s,
                                  tables=tables, run_dir=run_dir, prepared=prepared)
        ok = data.info["status"] == "ok"
        results.append((data.info, score_run(data, config) if ok else None))
    settings = {"scenario": None, "scenario_name": scenario.name,
                "tracker": f"python object {type(tracker).__name__}", "runs": runs,
                "seed": base, "seeds": seeds, "duration_s": duration_s,
                "metrics": config.as_dict()}
    if out is not None:
        (Path(out) / "study.json").write_text(json.dumps(settings, indent=1))
        summary = write_results(out, results, settings)
    else:
        summary = {"failed": [_failed_row(i) for i, s in results if s is None],
                   "metrics": stats.summarise([s.run for _, s in results if s is not None])}
    return {"per_run": [s.run for _, s in results if s is not None],
            "per_scan": [r for _, s in results if s is not None for r in s.per_scan],
            "per_target": [r for _, s in results if s is not None for r in s.per_target],
            "summary": summary["metrics"], "failed": summary["failed"]}
