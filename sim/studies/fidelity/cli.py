"""``shipradar fidelity``'s command line."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

from shipradar.sim.studies.fidelity.apply import apply_fidelity
from shipradar.sim.studies.fidelity.compare import Tolerances
from shipradar.sim.studies.fidelity.pareto import plot_pareto
from shipradar.sim.studies.fidelity.plan import plan_settings, with_fidelity
from shipradar.sim.studies.fidelity.report import format_per_target, format_report, write_csv
from shipradar.sim.studies.fidelity.trade import (
    BUILD_REPEATS,
    DEFAULT_PAIRS,
    OBJECTIVES,
    run_fidelity_study,
)
from shipradar.sim.world.scenario import Scenario, ScenarioError


def _number(name: str, lo: float, hi: float, integer: bool = False):
    def conv(text: str):
        try:
            v = int(text) if integer else float(text)
        except ValueError:
            v = None
        if v is None or not (lo <= v <= hi) or (not integer and not math.isfinite(v)):
            kind = "an integer" if integer else "a number"
            raise argparse.ArgumentTypeError(f"{name} must be {kind} in [{lo:g}, {hi:g}], "
                                             f"got {text!r}")
        return v

    return conv


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="shipradar fidelity",
        description="Measure the speed/accuracy trade of the fidelity choices on a scene, "
                    "with common random numbers, and recommend the cheapest setting inside "
                    "the tolerances (docs/accuracy.md).")
    p.add_argument("scenario", nargs="?", default=None, help="scenario YAML file")
    p.add_argument("--example", default=None, metavar="NAME",
                   help="a shipped example scenario instead of a file")
    p.add_argument("--duration", type=_number("--duration", 1e-3, 1e6), default=None,
                   metavar="S", help="simulated seconds per run (default: the scenario's)")
    p.add_argument("--runs", type=_number("--runs", 1, 1000, integer=True), default=1,
                   metavar="K", help="replications per setting, common seeds (default 1)")
    p.add_argument("--tolerance-pd", type=_number("--tolerance-pd", 0.0, 1.0), default=0.02,
                   metavar="X", help="largest mean |ΔP_d| per look of any target (default 0.02)")
    p.add_argument("--tolerance-range-m", type=_number("--tolerance-range-m", 0.0, 1e6),
                   default=500.0, metavar="M",
                   help="largest |Δ first-detection range| of any target [m] (default 500)")
    p.add_argument("--tolerance-fa", type=_number("--tolerance-fa", 0.0, 100.0), default=0.1,
                   metavar="R", help="largest relative change of the expected false alarms "
                                     "per scan of any radar and origin (default 0.1)")
    p.add_argument("--max-latency-s", type=_number("--max-latency-s", 0.0, 1e4), default=None,
                   metavar="S", help="largest plot latency (one sector) [s] (default: the "
                                     "scene's own)")
    p.add_argument("--all", action="store_true", dest="include_unexercised",
                   help="also run the choices the scene does not exercise")
    p.add_argument("--cold", action="store_true",
                   help=f"also measure the table builds: every distinct table built "
                        f"{BUILD_REPEATS} times in a private empty cache (else the cost "
                        "model's estimate is shown)")
    p.add_argument("--pairs", type=_number("--pairs", 2, 1000, integer=True),
                   default=DEFAULT_PAIRS, metavar="N",
                   help="alternating timing pairs (reference, setting) per setting "
                        f"(default {DEFAULT_PAIRS})")
    p.add_argument("--optimise", choices=OBJECTIVES, default="per-run",
                   help="the cost the recommendation minimises: per-run (warm run CPU, a "
                        "Monte Carlo study's replications; default) or first-run (table load "
                        "+ the first run of a process)")
    p.add_argument("--allow-shortened", action="store_true",
                   help="let --apply write a recommendation measured over a shortened "
                        "--duration (it holds for that span only)")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="write fidelity.csv and fidelity.png there")
    p.add_argument("--apply", default=None, metavar="OUT.yaml",
                   help="write the scenario with the recommended fidelity block")
    p.add_argument("--overwrite", action="store_true",
                   help="let --apply replace an existing file (kept as OUT.yaml.bak)")
    p.add_argument("--per-target", action="store_true",
                   help="also print one line per setting and (radar, target)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.add_argument("--max-build-s", type=_number("--max-build-s", 1e-3, 1e9), default=None,
                   metavar="S", help="longest estimated time to build the tables of every "
                   "setting [s]; over it the study is refused before any work (default "
                   "$SHIPRADAR_MAX_BUILD_S or 600)")
    return p


def _build_time(scenario: Scenario, args) -> list[str]:
    """The tables every setting of the study needs, estimated before any work (one line
    each for the missing ones); raises shipradar.tables.budget.BuildTimeError over the limit."""
    from shipradar.tables.budget import announce_builds, check_build_time

    _, settings, _ = plan_settings(scenario, include_unexercised=args.include_unexercised)
    variants = [with_fidelity(scenario, s.fidelity) for s in settings]
    return announce_builds(check_build_time(scenario, args.max_build_s, suggest=False,
                                            variants=variants, cold=args.cold))


def cli_main(argv: Sequence[str]) -> int:
    """``shipradar fidelity ...``; exit 0, 2 on bad input, 1 on failure."""
    from shipradar.sim.world.scenario import load_scenario

    try:
        args = build_parser().parse_args(list(argv))
    except SystemExit as exc:
        return int(exc.code or 0)
    if (args.scenario is None) == (args.example is None):
        print("shipradar fidelity: give a scenario path or --example NAME (not both)",
              file=sys.stderr)
        return 2
    path = args.scenario
    if args.example is not None:
        from shipradar.scenarios import example_path

        try:
            path = str(example_path(args.example))
        except KeyError as exc:
            print(exc.args[0], file=sys.stderr)
            return 2
    try:
        scenario = load_scenario(path)
    except ScenarioError as exc:
        print("\n".join(f"{path}: {ln}" for ln in exc.lines), file=sys.stderr)
        return 2
    out_dir = Path(args.out) if args.out else None
    if out_dir is not None and out_dir.exists() and not out_dir.is_dir():
        print(f"--out: {out_dir} exists and is not a directory", file=sys.stderr)
        return 2
    if args.apply and Path(args.apply).exists() and not args.overwrite:
        print(f"--apply: {args.apply} exists; pass --overwrite to replace it (its content is "
              "then kept as a .bak file)", file=sys.stderr)
        return 2
    if args.apply and not Path(args.apply).resolve().parent.is_dir():
        print(f"--apply: the folder of {args.apply} does not exist", file=sys.stderr)
        return 2
    if (args.apply and args.duration is not None and args.duration < scenario.duration_s
            and not args.allow_shortened):
        print(f"--apply: --duration {args.duration:g} s is shorter than the scene's "
              f"{scenario.duration_s:g} s; a recommendation measured over the first "
              f"{args.duration:g} s holds for that span only (drop --duration, or pass "
              "--allow-shortened)", file=sys.stderr)
        return 2
    tol = Tolerances(args.tolerance_pd, args.tolerance_range_m, args.tolerance_fa,
                     args.max_latency_s)
    from shipradar.tables.budget import BuildTimeError

    try:
        lines = _build_time(scenario, args)
    except BuildTimeError as exc:
        print(str(exc), file=sys.stderr)
        return 2
    for line in lines:
        print(line, file=sys.stderr)
    study = run_fidelity_study(scenario, duration_s=args.duration, runs=args.runs,
                               tolerances=tol, include_unexercised=args.include_unexercised,
                               log=None if args.quiet else sys.stderr, pairs=args.pairs,
                               objective=args.optimise, measure_builds=args.cold)
    print(format_report(study))
    if args.per_target:
        print()
        print(format_per_target(study))
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
        write_csv(study, out_dir / "fidelity.csv")
        plot_pareto(study, out_dir / "fidelity.png")
        print(f"wrote {out_dir / 'fidelity.csv'} and {out_dir / 'fidelity.png'}")
    if args.apply:
        try:
            backup = apply_fidelity(Path(path), study.recommended, Path(args.apply),
                                    overwrite=args.overwrite, unread=study.unread)
        except FileExistsError as exc:
            print(str(exc), file=sys.stderr)
            return 2
        except ScenarioError as exc:
            print("\n".join(exc.lines), file=sys.stderr)
            return 1
        print(f"wrote {args.apply}" + (f" (former content kept as {backup})" if backup else ""))
    return 0
