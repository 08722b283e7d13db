"""``shipradar evaluate``: score a tracker under test on seeded runs.

::

    shipradar evaluate SCENARIO --tracker "CMD {plots} {tracks}" --runs N [--seed S]
        [--duration S] [--out DIR] [--scheduler ADDRESS | --workers K] [--c 2000] [--p 1]
        [--switch-scans 3] [--truth coverage|pd [--pd-threshold 0.5] [--pd-window S]]
        [--reg-tol-range 20] [--reg-tol-scale 100] [--reg-tol-azimuth 0.05]
        [--reg-tol-time 0.010] [--reg-warmup 0]
    shipradar evaluate --rescore DIR [--c ...]      # score the recorded runs again
    shipradar evaluate --compare DIR_A DIR_B ...    # side by side, paired by seed

Exit codes: 0 every run scored; 1 some run failed (the others are scored and the report
lists the failures); 2 bad input.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

__all__ = ["add_arguments", "build_parser", "cli_main", "main"]

EXIT_OK, EXIT_FAILURE, EXIT_BAD_INPUT = 0, 1, 2


def add_arguments(p: argparse.ArgumentParser) -> None:
    """``evaluate``'s options on ``p`` (``shipradar``'s sub-parser, registered in
    :data:`shipradar.sim.cli.SUBCOMMANDS` with :func:`main`, or :func:`build_parser`'s)."""
    p.add_argument("scenario", nargs="?", default=None, help="scenario file")
    p.add_argument("--example", default=None, metavar="NAME",
                   help="a shipped example scenario instead of a path")
    p.add_argument("--tracker", default=None, metavar="CMD",
                   help="tracker command; placeholders {plots} (endpoint to subscribe to), "
                        "{tracks} (endpoint to bind and publish the 'tracks' topic on), "
                        "{asterix} (UDP destination of ASTERIX CAT048/034), {seed}, {run_dir}")
    p.add_argument("--runs", type=int, default=10, help="seeded runs (default 10)")
    p.add_argument("--seed", type=int, default=None, help="seed of the seeds (default: the "
                                                         "scenario's)")
    p.add_argument("--duration", type=float, default=None, help="simulated s per run")
    p.add_argument("--out", default="out/evaluate", help="study directory")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="a running Dask scheduler (default: a local cluster)")
    p.add_argument("--workers", type=int, default=None, help="local cluster workers")
    p.add_argument("--wait-timeout", type=float, default=30.0,
                   help="longest wait for the tracker to subscribe [s]")
    p.add_argument("--stall-timeout", type=float, default=120.0,
                   help="a tracker that reads nothing this long fails its run [s]")
    p.add_argument("--drain", type=float, default=5.0,
                   help="after a run, quiet time before the tracker is stopped [s]")
    p.add_argument("--realtime", type=float, default=None, metavar="FACTOR",
                   help="pace the runs at FACTOR x the wall clock (latency without queueing)")
    p.add_argument("--entities", default=None, metavar="RECORDING",
                   help="move the targets by the entities topic of a recording (a live "
                        "--dis or --entities session, re-simulated with each run's seed); "
                        "docs/external.md")
    p.add_argument("--c", type=float, default=2000.0, help="GOSPA cut-off c [m]")
    p.add_argument("--p", type=float, default=1.0, help="GOSPA order p")
    p.add_argument("--siap-threshold", type=float, default=None,
                   help="SIAP track-to-truth association distance [m] (default: c)")
    p.add_argument("--max-track-age", type=float, default=None,
                   help="oldest tracks message scored at a scan [s] (default: 1.5 scans)")
    p.add_argument("--switch-scans", type=int, default=3,
                   help="scans in a row another assignment must be better before a track's "
                        "association (identity, SIAP) moves to it (default 3; 1: each scan "
                        "on its own)")
    p.add_argument("--truth", choices=("coverage", "pd"), default="pd",
                   help="which targets count: 'pd' (some radar's look of the window reached "
                        "--pd-threshold; default) or 'coverage' (in_coverage: instrumented "
                        "range and 4/3-earth horizon)")
    p.add_argument("--pd-threshold", type=float, default=0.5,
                   help="--truth pd: P_d a look must reach (default 0.5)")
    p.add_argument("--pd-window", type=float, default=None, metavar="S",
                   help="--truth pd: how far back looks are read [s] (default: 3 scan "
                        "periods of each radar)")
    p.add_argument("--reg-tol-range", type=float, default=None, metavar="M",
                   help="registration: convergence tolerance of range_bias_m [m] (default "
                        "20)")
    p.add_argument("--reg-tol-scale", type=float, default=None, metavar="PPM",
                   help="registration: of range_scale_ppm [ppm] (default 100)")
    p.add_argument("--reg-tol-azimuth", type=float, default=None, metavar="DEG",
                   help="registration: of azimuth_bias_rad, in degrees (default 0.05)")
    p.add_argument("--reg-tol-time", type=float, default=None, metavar="S",
                   help="registration: of time_offset_s [s] (default 0.010)")
    p.add_argument("--reg-warmup", type=float, default=0.0, metavar="S",
                   help="registration: RMSE over the estimates from this simulated time on "
                        "[s] (default 0: all)")
    p.add_argument("--rescore", default=None, metavar="DIR",
                   help="score the recorded runs of DIR again, with these metric settings")
    p.add_argument("--compare", nargs="+", default=None, metavar="DIR",
                   help="two or more study directories side by side (paired by seed); "
                        "the comparison goes to --out")
    p.add_argument("--no-report", action="store_true", help="tables only, no index.html")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="shipradar evaluate", description=__doc__.split("\n")[0])
    add_arguments(p)
    return p


def _config(args):
    from shipradar.sim.studies.evaluate.metrics import MetricConfig
    from shipradar.sim.studies.evaluate.registration import RegistrationConfig

    given = {"tolerance_range_bias_m": args.reg_tol_range,
             "tolerance_range_scale_ppm": args.reg_tol_scale,
             "tolerance_azimuth_bias_deg": args.reg_tol_azimuth,
             "tolerance_time_offset_s": args.reg_tol_time}
    reg = RegistrationConfig(warmup_s=args.reg_warmup,
                             **{k: v for k, v in given.items() if v is not None})
    return MetricConfig(c_m=args.c, p=args.p, siap_threshold_m=args.siap_threshold,
                        max_track_age_s=args.max_track_age, switch_scans=args.switch_scans,
                        truth=args.truth, pd_threshold=args.pd_threshold,
                        pd_window_s=args.pd_window, registration=reg)


def _print_summary(summary: dict) -> None:
    short = {k: v for k, v in summary.items() if k not in ("settings", "metrics")}
    short["metrics"] = {r["metric"]: [r["mean"], r["low"], r["high"]]
                        for r in summary.get("metrics", [])}
    print(json.dumps(short, default=str, allow_nan=True))


def main(args: argparse.Namespace) -> int:
    """Run the sub-command from parsed arguments; the exit code."""
    from shipradar.sim.studies.evaluate import study

    try:
        config = _config(args)
    except ValueError as exc:
        print(f"evaluate: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if args.compare:
        if len(args.compare) < 2:
            print("evaluate: --compare needs two study directories or more", file=sys.stderr)
            return EXIT_BAD_INPUT
        for d in args.compare:
            if not (Path(d) / "per_run.parquet").exists():
                print(f"evaluate: {d} is not a scored study directory", file=sys.stderr)
                return EXIT_BAD_INPUT
        res = study.compare(args.compare, args.out)
        print(json.dumps({k: v for k, v in res.items() if k != "rows"}))
        return EXIT_OK
    if args.rescore:
        if not (Path(args.rescore) / "study.json").exists():
            print(f"evaluate: {args.rescore} is not a study directory (no study.json)",
                  file=sys.stderr)
            return EXIT_BAD_INPUT
        summary = study.rescore(args.rescore, config, report=not args.no_report)
        _print_summary(summary)
        return EXIT_FAILURE if summary["failed"] else EXIT_OK
    scenario = args.scenario
    if args.example is not None:
        from shipradar.scenarios import example_path

        try:
            scenario = str(example_path(args.example))
        except KeyError as exc:
            print(f"evaluate: {exc.args[0]}", file=sys.stderr)
            return EXIT_BAD_INPUT
    if scenario is None or not Path(scenario).exists():
        print("evaluate: a scenario file is needed (SCENARIO.yaml or --example NAME)",
              file=sys.stderr)
        return EXIT_BAD_INPUT
    if not args.tracker:
        print("evaluate: --tracker CMD is needed (with {plots} and {tracks})", file=sys.stderr)
        return EXIT_BAD_INPUT
    if args.runs < 1:
        print(f"evaluate: --runs must be >= 1, got {args.runs}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if args.entities is not None:
        from shipradar.sim.stream.entities import EntitiesError, RecordedEntities
        from shipradar.sim.world.scenario import load_scenario

        try:
            if not Path(args.entities).is_file():
                raise EntitiesError(f"--entities: {args.entities!r} is not a recording file")
            if RecordedEntities(args.entities).messages == 0:
                raise EntitiesError(f"--entities: {args.entities!r} has no entities topic "
                                    f"(record a run with --dis or --entities)")
            s = load_scenario(scenario)
            if s.targets or s.traffic:
                raise EntitiesError(f"--entities: the targets come from {args.entities!r}; "
                                    f"the scene must have no targets: or traffic: of its own")
        except EntitiesError as exc:
            print(f"evaluate: {exc}", file=sys.stderr)
            return EXIT_BAD_INPUT
    summary = study.run_study(
        scenario, args.tracker, runs=args.runs, out=args.out, seed=args.seed,
        duration_s=args.duration, config=config, scheduler=args.scheduler,
        workers=args.workers, wait_timeout_s=args.wait_timeout,
        stall_timeout_s=args.stall_timeout, drain_s=args.drain, realtime=args.realtime,
        progress=not args.quiet and sys.stderr.isatty(), report=not args.no_report,
        entities=args.entities)
    _print_summary(summary)
    for f in summary["failed"]:
        print(f"run seed {f['seed']} failed: {f['error']} (exit code {f['exit_code']})",
              file=sys.stderr)
    return EXIT_FAILURE if summary["failed"] else EXIT_OK


def cli_main(argv: list[str] | None = None) -> int:
    """``shipradar evaluate`` from an argument list (tests, ``python -m``)."""
    return main(build_parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(cli_main())
