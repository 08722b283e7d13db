"""shipradar: a shipborne surveillance radar simulator (DREV-R-9429) for data fusion studies.

The command line: ``shipradar examples | validate | tables build | run | replay | export |
tail | recording | keys | view | plot | montecarlo | report | fidelity | evaluate`` (``-h`` on
each). A sub-command is registered in one place: an entry of :data:`SUBCOMMANDS`.

Exit codes: 0 success, 2 bad input (scenario, arguments, files), 1 runtime failure.
Every bad-input message names the field or option, the value and what is allowed.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import signal
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from shipradar.sim.world.errors import BadInputError, PeerError

#: When this module started executing [perf_counter s]: the start of the process as the run
#: summary's ``process_wall_s`` counts it (the interpreter's own start-up and ``import
#: shipradar`` come before, about 0.03-0.1 s that this clock cannot see).
PROCESS_T0 = time.perf_counter()

if TYPE_CHECKING:
    from types import FrameType

    from shipradar.sim.adapters.asterix.udp import AsterixBus
    from shipradar.sim.stream.bus import Bus

    _Subcommands = argparse._SubParsersAction[argparse.ArgumentParser]
    _SignalHandler = Callable[[int, FrameType | None], Any] | int | signal.Handlers | None

EXIT_OK, EXIT_FAILURE, EXIT_BAD_INPUT = 0, 1, 2


class BadInput(Exception, BadInputError):
    """Bad command-line input: one message line per problem."""


def _scenario_path(args) -> str:
    """The scenario file of a command: its path, or the shipped example ``--example NAME``."""
    example = getattr(args, "example", None)
    if example is not None:
        if args.scenario is not None:
            raise BadInput(f"give a scenario path or --example, not both "
                           f"({args.scenario!r} and --example {example!r})")
        from shipradar.scenarios import example_path

        try:
            args.scenario = str(example_path(example))
        except KeyError as exc:
            raise BadInput(exc.args[0]) from None
    elif args.scenario is None:
        raise BadInput("a scenario is needed: SCENARIO.yaml or --example NAME "
                       "(shipradar examples lists them)")
    return args.scenario


def _load(path: str):
    from shipradar.sim.world.scenario import ScenarioError, load_scenario

    try:
        scenario = load_scenario(path)
    except ScenarioError as exc:
        raise BadInput("\n".join(f"{path}: {line}" for line in exc.lines)) from None
    if scenario.traffic:  # the traffic files read and checked once, before any work
        from shipradar.sim.world.traffic import TrafficError, scene_targets

        try:
            scene_targets(scenario)
        except TrafficError as exc:
            raise BadInput(f"{path}: {exc}") from None
    return scenario


def _positive(name: str):
    def conv(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
        if not v > 0:
            raise argparse.ArgumentTypeError(f"{name} must be > 0, got {text}")
        return v

    return conv


def _count(name: str):
    def conv(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be an integer, got {text!r}") from None
        if v < 0:
            raise argparse.ArgumentTypeError(f"{name} must be >= 0, got {text}")
        return v

    return conv


# --------------------------------------------------------------------------- commands
def cmd_examples(args) -> int:
    from shipradar.scenarios import example_names, example_path
    from shipradar.sim.world.scenario import load_scenario

    for name in example_names():
        s = load_scenario(example_path(name))
        print(f"{name:16s} {s.name}: {len(s.targets)} targets, "
              f"radars {', '.join(r.id for _, r in s.radars())}, {s.duration_s:g} s")
    return EXIT_OK


def _target_count(s) -> str:
    """The scene's targets: its own, and those of its traffic files with the rows read."""
    if not s.traffic:
        return str(len(s.targets))
    from shipradar.sim.world.traffic import scene_targets

    t = scene_targets(s)
    dropped = sum(t.dropped.values())
    return (f"{t.n} ({len(s.targets)} own, {t.from_files} from {len(s.traffic)} traffic "
            f"file(s): {t.traffic_rows} rows, {dropped} left out)")


def cmd_validate(args) -> int:
    s = _load(_scenario_path(args))
    radars = ", ".join(r.id for _, r in s.radars())
    print(f"{args.scenario}: valid ({_target_count(s)} targets, radars: {radars}, "
          f"{s.duration_s:g} s)")
    if getattr(args, "explain", False):
        from shipradar.sim.studies.fidelity import explain_lines
        from shipradar.sim.world.trajectory import resolved_scene_lines

        print("\n".join(explain_lines(s)))
        print("\n".join(resolved_scene_lines(s)))
    return EXIT_OK


def cmd_tables_build(args) -> int:
    from shipradar.tables.budget import build_seconds
    from shipradar.tables.scene import build_scene_tables

    s = _load(_scenario_path(args))
    _memory_budget(args, s)
    estimates = _build_time(args, s, include_pd=False)
    _announce(estimates)
    report = build_scene_tables(s, progress=sys.stderr.isatty(), log=sys.stderr,
                                estimated_s=build_seconds(estimates))
    print(json.dumps(report, sort_keys=False))
    return EXIT_OK


def _curve(args, role: str):
    """The ``--curve-*`` options as a CurveServer/CurveClient (None when not given)."""
    from shipradar.sim.stream.security import curve_from_args

    return curve_from_args(args, role)


def _memory_budget(args, scenario) -> None:
    """Refuse, before any work, a scene whose tables exceed the memory budget."""
    from shipradar.tables.budget import check_memory_budget, memory_budget_bytes

    check_memory_budget(scenario, memory_budget_bytes(getattr(args, "memory_budget", None)))


def _build_time(args, scenario, *, include_pd: bool = True):
    """Refuse, before any work, a scene whose missing tables would take longer than
    ``--max-build-s`` to build; else every table's estimate
    (:func:`shipradar.tables.budget.check_build_time`)."""
    from shipradar.tables.budget import check_build_time

    return check_build_time(scenario, getattr(args, "max_build_s", None),
                            include_pd=include_pd)


def _announce(estimates) -> None:
    """One line on stderr per table to build, with its estimated size and time."""
    from shipradar.tables.budget import announce_builds

    for line in announce_builds(estimates):
        print(line, file=sys.stderr)


class _AllowInsecureRemote(argparse.Action):
    """``--allow-insecure-remote`` and its deprecated alias ``--allow-remote``: set
    ``allow_remote``, and ``allow_remote_alias`` when the alias was the one written (the
    command then says it is deprecated, :func:`_insecure_remote`)."""

    def __init__(self, option_strings, dest, **kwargs):
        super().__init__(option_strings, dest, nargs=0, default=False, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, True)
        if option_string == "--allow-remote":
            namespace.allow_remote_alias = True


def _insecure_remote(args, curve) -> bool:
    """Whether ``run``/``replay`` sends unencrypted data off this machine (a non-loopback
    ``--publish`` without CURVE, or a non-loopback ``--asterix`` destination), allowed by
    ``--allow-insecure-remote`` or ``--allow-remote``; each such destination, and the
    deprecated alias, is warned about on stderr.  The value goes into the run summary as
    ``insecure_remote`` (issue 25: an insecure remote bind is never silent)."""
    if getattr(args, "allow_remote_alias", False):
        print("warning: --allow-remote is deprecated; use --allow-insecure-remote (the same "
              "permission, named for what it allows)", file=sys.stderr)
    insecure = False
    if args.publish:
        from shipradar.sim.stream.bus import check_bind_endpoint

        insecure = check_bind_endpoint(args.publish, allow_remote=args.allow_remote,
                                       secured=curve is not None)
    if insecure:
        print(f"warning: INSECURE: publishing on {args.publish} without CURVE: the stream is "
              "unauthenticated and unencrypted, anyone who can reach this machine can "
              "subscribe (secure it with --curve-secret-key and --curve-authorized, "
              "docs/protocol.md section 9, or bind a loopback address)", file=sys.stderr)
    if args.asterix:
        from shipradar.sim.adapters.asterix.encode import AsterixError
        from shipradar.sim.adapters.asterix.udp import parse_udp_url

        try:
            parse_udp_url(args.asterix)
        except AsterixError:  # off this machine (the caller checked it with allow_remote)
            insecure = True
            print(f"warning: INSECURE: sending ASTERIX to {args.asterix}: it leaves this "
                  "machine unauthenticated and unencrypted (ASTERIX has neither)",
                  file=sys.stderr)
    return insecure


class _StopOnSignal:
    """SIGTERM or Ctrl-C: stop the run at the next end of scan (the bus raises
    RunInterrupted from its flush, so the recording ends with a whole scan); a second
    signal, or a run without a bus, stops at once (KeyboardInterrupt)."""

    def __init__(self, bus):
        self.bus = bus
        self.signum: int | None = None
        self._old: dict[int, _SignalHandler] = {}

    def _handler(self, signum, frame) -> None:
        self.signum = signum
        if self.bus is None or self.bus.stop_requested:
            raise KeyboardInterrupt
        self.bus.stop_requested = True

    def __enter__(self):
        for sig in (signal.SIGINT, signal.SIGTERM):
            try:
                self._old[sig] = signal.signal(sig, self._handler)
            except ValueError:  # not the main thread (library use): leave signals alone
                pass
        return self

    def __exit__(self, *exc) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old)


def _check_run(args, s):
    """Everything ``run`` can refuse, before any table is built or loaded; returns the
    publisher's CURVE keys (or None)."""
    if args.record and Path(args.record).exists() and not args.overwrite:
        raise BadInput(f"--record: {args.record} exists; pass --overwrite to replace it")
    curve = _curve(args, "server")
    _memory_budget(args, s)
    args.build_estimates = _build_time(args, s)
    if args.processes > 1 and args.realtime:
        raise BadInput(f"--processes {args.processes} is for fast mode; drop --realtime or "
                       "use --processes 1")
    if args.publish:
        from shipradar.sim.stream.bus import check_bind_endpoint

        check_bind_endpoint(args.publish, allow_remote=args.allow_remote,
                            secured=curve is not None)
    if args.asterix:
        from shipradar.sim.adapters.asterix.stream import scenario_problems
        from shipradar.sim.adapters.asterix.udp import parse_udp_url

        parse_udp_url(args.asterix, allow_remote=args.allow_remote)
        problems = scenario_problems(s)
        if problems:
            raise BadInput("\n".join(f"--asterix: {p}" for p in problems))
    args.insecure_remote = _insecure_remote(args, curve)
    _check_entities(args, s)
    return curve


def _check_entities(args, s) -> None:
    """``--entities``: a live feed implies ``--realtime 1`` (refused with another factor or
    several processes); a recording runs in fast mode; the scene's targets come from it."""
    dis = getattr(args, "dis", None)
    spec = getattr(args, "entities", None)
    if dis is None and getattr(args, "dis_wait_start", False):
        raise BadInput("--dis-wait-start: waits for a DIS Start/Resume PDU, so it needs "
                       "--dis udp://ADDRESS:PORT")
    if dis is not None:
        from shipradar.sim.adapters.dis import parse_dis_url

        if spec is not None:
            raise BadInput(f"--dis and --entities: give one live source, got both ({dis!r} "
                           f"and {spec!r})")
        _host, _port, insecure = parse_dis_url(dis, allow_remote=args.allow_remote)
        if insecure:
            args.insecure_remote = True
            print(f"warning: INSECURE: listening for DIS on {dis}: anyone who can reach this "
                  f"machine can inject entities (DIS has no security of its own)",
                  file=sys.stderr)
        args.dis_address = None
        if args.dis_site_app is not None:
            try:
                site, app = (int(x) for x in args.dis_site_app.split(":"))
                if not (0 <= site <= 65535 and 0 <= app <= 65535):
                    raise ValueError
            except ValueError:
                raise BadInput(f"--dis-site-app: expected SITE:APP, two integers in [0, "
                               f"65535], got {args.dis_site_app!r}") from None
            args.dis_address = (site, app)
        spec = dis
    if spec is None:
        return
    if s.targets or s.traffic:
        raise BadInput(f"--entities: the targets come from {spec!r}; a scene with targets: or "
                       f"traffic: of its own is not supported with it (remove them), got "
                       f"{len(s.targets)} target(s) and {len(s.traffic)} traffic file(s)")
    if args.processes > 1:
        raise BadInput(f"--entities: one process only, got --processes {args.processes}")
    if "://" in spec:  # a live feed: the wall clock
        if args.realtime not in (None, 1.0):
            raise BadInput(f"--entities: a live feed runs at the wall clock's pace "
                           f"(--realtime 1); got --realtime {args.realtime:g}")
        args.realtime = 1.0
    elif args.realtime is not None:
        raise BadInput(f"--entities: a recording re-simulates in fast mode; drop --realtime "
                       f"(got {args.realtime:g})")


def _stopped_summary(sim, core_bus, wall0: float, signum) -> dict:
    """The summary of a run stopped by SIGINT/SIGTERM at an end of scan."""
    summary = sim.summary(time.perf_counter() - wall0)
    summary["interrupted"] = True
    t_last = getattr(core_bus, "t_last", None)
    summary["simulated_s"] = t_last  # the last message's time (None: no bus)
    wall = summary["wall_s"]
    summary["realtime_factor"] = round(t_last / wall, 2) if t_last and wall else None
    print(f"interrupted ({signal.Signals(signum or signal.SIGINT).name}): the run stopped "
          f"at t = {t_last} s; the recording, if any, is closed and complete up to there",
          file=sys.stderr)
    return summary


class _Outputs:
    """Where a run's stream goes: the ZeroMQ publisher and the recording (one bus), and
    ASTERIX over it; closed as a whole whatever was opened before a failure."""

    def __init__(self) -> None:
        self.publisher: Any = None
        self.recorder: Any = None
        self.core_bus: Bus | None = None  # ZeroMQ and the recording
        self.asterix_bus: AsterixBus | None = None
        self.bus: Bus | AsterixBus | None = None  # what the simulation emits to

    def open(self, args, curve) -> None:
        from shipradar.sim.stream.bus import Bus, Publisher
        from shipradar.sim.stream.recording import Recorder

        if args.publish:
            self.publisher = Publisher(args.publish, wait_subscribers=args.wait_subscribers,
                                       wait_timeout_s=args.wait_timeout, on_slow=args.on_slow,
                                       allow_remote=args.allow_remote, curve=curve)
        if args.record:
            self.recorder = Recorder(args.record, overwrite=args.overwrite,
                                     compress=args.compress)
        if self.publisher or self.recorder:
            self.bus = self.core_bus = Bus(self.publisher, self.recorder)
        if args.asterix:
            from shipradar.sim.adapters.asterix.udp import AsterixBus, UdpSender

            self.bus = self.asterix_bus = AsterixBus(
                self.bus, UdpSender(args.asterix, allow_remote=args.allow_remote),
                args.asterix_max_datagram)

    def close(self, summary: dict | None) -> None:
        """Close what was opened; a recording that cannot take its last records is an
        error in ``summary`` (raised when there is no summary yet)."""
        from shipradar.sim.stream.recording import RecordingWriteError

        try:
            if self.bus is not None:
                self.bus.close()
            else:
                for part in (self.publisher, self.recorder):
                    if part is not None:
                        part.close()
        except RecordingWriteError as exc:  # the last buffered records did not fit
            if summary is None:
                raise
            print(f"error: {exc}", file=sys.stderr)
            summary["error"] = str(exc)


def _entity_source(args, s) -> Any:
    """The live source of target states ``run`` was given (DIS, a ZeroMQ feed or a
    recording's entities), or None."""
    from shipradar.sim.world.scenario import External

    queue_size = (s.external or External()).queue_size
    if args.dis is not None:
        from shipradar.sim.adapters.dis import DisReceiver
        from shipradar.sim.world.kinematics import LocalFrame

        return DisReceiver(args.dis, LocalFrame(s.origin), exercise_id=args.dis_exercise,
                           site_app=args.dis_address, queue_size=queue_size,
                           allow_remote=args.allow_remote, wait_start=args.dis_wait_start)
    if args.entities is not None:
        from shipradar.sim.stream.entities import entity_source

        return entity_source(args.entities, queue_size)
    return None


def _run_tables(args, s):
    """The tables the scene reads: from the cache, built now if missing (announced with their
    estimated time, shown on stderr)."""
    from shipradar.tables.budget import build_seconds
    from shipradar.tables.scene import load_scene_tables

    _announce(args.build_estimates)
    if any(not e.cached for e in args.build_estimates):
        gc.enable()  # tables to build (seconds to minutes of work): the collector on for it
    return load_scene_tables(s, progress=sys.stderr.isatty() and not args.quiet,
                             log=sys.stderr, estimated_s=build_seconds(args.build_estimates))


def _run_loop(args, sim, core_bus) -> tuple[dict, int | None]:
    """Run to the end, or to a stop (a signal, a recording that cannot be written); the
    summary and the signal that stopped it, if one did."""
    from shipradar.sim.stream.bus import RunInterrupted
    from shipradar.sim.stream.recording import RecordingWriteError

    if getattr(args, "gc_off_until_run", False):
        _objects_so_far_kept()
    wall0 = time.perf_counter()
    with _StopOnSignal(core_bus) as stop:
        try:
            summary = sim.run()
        except (RunInterrupted, KeyboardInterrupt):
            summary = _stopped_summary(sim, core_bus, wall0, stop.signum)
        except RecordingWriteError as exc:
            print(f"error: {exc}", file=sys.stderr)
            summary = sim.summary(time.perf_counter() - wall0)
            summary["error"] = str(exc)
            summary["simulated_s"] = getattr(core_bus, "t_last", None)
    return summary, stop.signum


def cmd_run(args) -> int:
    from shipradar.sim.engine.simulation import Simulation

    s = _load(_scenario_path(args))
    curve = _check_run(args, s)
    tables = _run_tables(args, s)
    if args.record and hasattr(signal, "SIGXFSZ"):
        # past a file-size limit write() then fails with EFBIG, which the recorder reports
        # and recovers from, instead of the signal killing the process mid-record
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    out = _Outputs()
    entities: Any = None  # a live source: DIS, a ZeroMQ feed or a recording's entities
    summary = None
    try:
        out.open(args, curve)
        entities = _entity_source(args, s)
        sim = Simulation(s, bus=out.bus, seed=args.seed, duration_s=args.duration,
                         realtime=args.realtime, tables=tables,
                         progress=sys.stderr.isatty() and not args.quiet,
                         processes=args.processes, entities=entities)
        for line in sim.tables.missing_lines():
            print(f"note: {line}", file=sys.stderr)
        if out.publisher is not None and args.wait_subscribers:
            out.publisher.wait_for_subscribers()
        summary, signum = _run_loop(args, sim, out.core_bus)
    finally:
        if entities is not None:
            entities.close()
        out.close(summary)
    return _report_run(args, summary, out.asterix_bus, signum)


def _report_run(args, summary: dict, asterix_bus, signum: int | None) -> int:
    """Complete the summary (the whole command's time), print it as one JSON line on stdout
    and, on a terminal, as a few lines for a person on stderr; the exit code."""
    summary["insecure_remote"] = args.insecure_remote
    # the whole command as a user times it (imports, scenario, tables, set-up, run, close),
    # beside the loop's own wall_s and realtime_factor
    process_wall = time.perf_counter() - PROCESS_T0
    summary["process_wall_s"] = round(process_wall, 4)
    simulated = summary.get("simulated_s")
    summary["process_realtime_factor"] = (round(simulated / process_wall, 2)
                                          if simulated and process_wall > 0 else None)
    if "error" not in summary:
        if asterix_bus is not None:
            summary["asterix"] = asterix_bus.stats["asterix"]  # datagrams, records, markers
        pub = (summary.get("bus") or {}).get("publisher") or {}
        if pub.get("dropped"):
            print(f"warning: {pub['dropped']} message(s) dropped for slow subscribers "
                  f"({pub['dropped_by_topic']}); the recording, if any, holds them all",
                  file=sys.stderr)
    print(json.dumps(summary))
    if sys.stderr.isatty() and not args.quiet:
        sys.stdout.flush()  # the JSON line first where both go to the terminal
        print("\n".join(run_summary_lines(summary)), file=sys.stderr)
    if "error" in summary:
        return EXIT_FAILURE
    if summary.get("interrupted"):
        return 128 + int(signum or signal.SIGINT)  # the shell's convention: 130, 143
    return EXIT_OK


def _mb(n: float) -> str:
    return f"{n / 1e6:,.1f} MB"


def run_summary_lines(summary: dict) -> list[str]:
    """The run's summary for a person (what ``shipradar run`` prints on a terminal's stderr
    after the JSON line): what was simulated and how fast (the loop's real-time factor and
    the whole command's), the counts, and where the stream went."""
    sim_s, wall, factor = summary.get("simulated_s"), summary["wall_s"], summary.get(
        "realtime_factor")
    whole, whole_factor = summary.get("process_wall_s"), summary.get("process_realtime_factor")
    how = ("interrupted: " if summary.get("interrupted") else "error: "
           if "error" in summary else "")
    lines = [
        f"{how}{summary['scenario']} (seed {summary['seed']}): {sim_s or 0:g} s simulated; "
        f"run loop {wall:.2f} s ({_x(factor)} real time), whole command {whole or 0:.2f} s "
        f"({_x(whole_factor)})",
        f"  {summary['scans']:,} scans, {summary['dwells']:,} dwells: "
        f"{summary['target_plots']:,} target plots, {summary['missed_detections']:,} missed, "
        f"{summary['merged_targets']:,} merged; false alarms {summary['noise_false_alarms']:,} "
        f"noise, {summary['clutter_false_alarms']:,} clutter",
    ]
    bus = summary.get("bus") or {}
    rec, pub = bus.get("recorder"), bus.get("publisher")
    if rec:
        lines.append(f"  recording: {rec['path']} ({rec['records']:,} messages, "
                     f"{_mb(rec['bytes'])})")
    if pub:
        lines.append(f"  published on {pub['endpoint']}: {pub['sent']:,} messages sent, "
                     f"{pub['dropped']:,} dropped")
    if not rec and not pub and "asterix" not in summary:
        lines.append("  nothing recorded or published (--record FILE, --publish ENDPOINT)")
    if "asterix" in summary:
        ast = summary["asterix"]
        lines.append(f"  ASTERIX to {ast['destination']}: {ast['datagrams']:,} datagrams, "
                     f"{_mb(ast['bytes'])}")
    if "error" in summary:
        lines.append(f"  error: {summary['error']}")
    return lines


def _x(factor: float | None) -> str:
    """A real-time factor as a person reads it: 143x, 0.98x, or n/a."""
    if factor is None:
        return "n/a"
    return f"{factor:,.0f}x" if factor >= 10 else f"{factor:.2g}x"


def cmd_replay(args) -> int:
    from shipradar.sim.stream.bus import ReplaySettings, replay

    if not Path(args.recording).exists():
        raise BadInput(f"replay: recording {args.recording} does not exist")
    curve = _curve(args, "server")
    if args.asterix:
        from shipradar.sim.adapters.asterix.udp import parse_udp_url

        parse_udp_url(args.asterix, allow_remote=args.allow_remote)
    insecure_remote = _insecure_remote(args, curve)
    asterix = None
    if args.asterix:
        from shipradar.sim.adapters.asterix.udp import AsterixBus, UdpSender

        asterix = AsterixBus(None, UdpSender(args.asterix, allow_remote=args.allow_remote),
                             args.asterix_max_datagram)
    try:
        settings = ReplaySettings(endpoint=args.publish, speed=args.speed, fast=args.fast,
                                  wait_subscribers=args.wait_subscribers,
                                  wait_timeout_s=args.wait_timeout, on_slow=args.on_slow,
                                  allow_remote=args.allow_remote, strict=args.strict,
                                  curve=curve)
        summary = replay(args.recording, settings,
                         out=None if args.publish or args.asterix else sys.stdout,
                         tap=None if asterix is None else asterix.emit_frames)
    finally:
        if asterix is not None:
            asterix.close()
    summary["insecure_remote"] = insecure_remote  # before asterix, as in run's summary
    if asterix is not None:
        summary["asterix"] = asterix.stats["asterix"]
    if summary["truncated"]:
        print(f"warning: {args.recording} is truncated: {summary['frames']} whole frame(s) "
              f"replayed, {summary['bytes_ignored']} byte(s) of a partial last frame ignored",
              file=sys.stderr)
    if summary["damaged_regions"]:
        print(f"warning: {args.recording} is damaged: {summary['damaged_regions']} region(s), "
              f"{summary['bytes_skipped']} byte(s) and {summary['records_skipped']} record(s) "
              f"skipped; {summary['frames']} valid record(s) replayed (shipradar recording "
              f"verify gives the regions; --strict stops at the first)", file=sys.stderr)
    pub = summary.get("publisher") or {}
    if pub.get("dropped"):
        print(f"warning: {pub['dropped']} message(s) dropped for slow subscribers",
              file=sys.stderr)
    print(json.dumps(summary))
    return EXIT_OK


def cmd_export(args) -> int:
    from shipradar.sim.adapters.export import ExportError, export

    if not Path(args.recording).exists():
        raise BadInput(f"export: recording {args.recording} does not exist")
    if Path(args.out).exists() and not args.overwrite:
        raise BadInput(f"--out: {args.out} exists; pass --overwrite to replace it")
    try:
        summary = export(args.recording, args.format, args.out, port=args.port,
                         max_block_bytes=args.asterix_max_datagram)
    except ExportError as exc:
        print(str(exc), file=sys.stderr)
        return EXIT_FAILURE
    print(json.dumps(summary))
    return EXIT_OK


def _datagram_size(text: str) -> int:
    from shipradar.sim.adapters.asterix.encode import MAX_BLOCK_BYTES, MIN_BLOCK_BYTES

    try:
        v = int(text)
    except ValueError:
        v = None
    if v is None or not MIN_BLOCK_BYTES <= v <= MAX_BLOCK_BYTES:
        raise argparse.ArgumentTypeError(
            f"--asterix-max-datagram must be an integer in [{MIN_BLOCK_BYTES}, "
            f"{MAX_BLOCK_BYTES}] bytes, got {text!r}")
    return v


def _udp_port(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        v = None
    if v is None or not 1 <= v <= 65535:
        raise argparse.ArgumentTypeError(f"--port must be an integer in [1, 65535], got {text!r}")
    return v


def _asterix_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--asterix", default=None, metavar="udp://HOST:PORT",
                   help="also send the plots as ASTERIX CAT048 + CAT034 UDP datagrams "
                        "(loopback unless --allow-insecure-remote; docs/asterix.md)")
    p.add_argument("--asterix-max-datagram", type=_datagram_size, default=1400,
                   metavar="BYTES", help="largest ASTERIX datagram [bytes] (default 1400)")


def cmd_tail(args) -> int:
    from shipradar.sim.stream.bus import tail

    topics = [t.encode() for t in args.topic] if args.topic else None
    tail(args.endpoint, topics=topics, max_messages=args.count, timeout_s=args.timeout,
         curve=_curve(args, "client"))
    return EXIT_OK


def cmd_recording_verify(args) -> int:
    from shipradar.sim.stream.recording import verify_recording

    if not Path(args.recording).is_file():
        raise BadInput(f"recording verify: {args.recording} does not exist or is not a file")
    rep = verify_recording(args.recording)
    for r in rep["damage"]:
        print(f"warning: {args.recording}: damaged region at bytes {r['start']}-{r['end']}: "
              f"{r['reason']} ({r['records']} record(s) lost)", file=sys.stderr)
    if rep["truncated"]:
        print(f"warning: {args.recording} is truncated: the last {rep['bytes_ignored']} "
              f"byte(s) are a torn or zero-filled tail", file=sys.stderr)
    print(json.dumps(rep))
    return EXIT_OK if rep["status"] == "clean" else EXIT_FAILURE


def cmd_recording_repair(args) -> int:
    from shipradar.sim.stream.recording import repair_recording

    if not Path(args.recording).is_file():
        raise BadInput(f"recording repair: {args.recording} does not exist or is not a file")
    rep = repair_recording(args.recording, args.out, overwrite=args.overwrite,
                           compress=args.compress)
    print(json.dumps(rep))
    return EXIT_OK


def cmd_recording_compare(args) -> int:
    from shipradar.sim.stream.compare import compare_recordings

    for path in (args.expected, args.actual):
        if not Path(path).is_file():
            raise BadInput(f"recording compare: {path} does not exist or is not a file")
    if not args.rtol >= 0.0:
        raise BadInput(f"recording compare: --rtol must be >= 0, got {args.rtol}")
    same_bytes = Path(args.expected).read_bytes() == Path(args.actual).read_bytes()
    c = compare_recordings(args.expected, args.actual, rtol=args.rtol)
    first = None if c.first is None else {
        "message": c.first.index, "topic": c.first.topic, "t": c.first.t_sim,
        "where": c.first.where, "kind": c.first.kind, "detail": c.first.detail}
    print(json.dumps({"same_bytes": same_bytes, "equal": c.equal, "rtol": c.rtol,
                      "messages": c.messages, "max_rel": c.max_rel, "worst": c.worst,
                      "by_key": c.by_key, "first_difference": first}))
    if c.first is not None:
        print(f"{args.actual}: {c.first}", file=sys.stderr)
    return EXIT_OK if c.equal else EXIT_FAILURE


def cmd_keys_generate(args) -> int:
    from shipradar.sim.stream.security import generate_keys

    out = generate_keys(args.directory, clients=args.name or ["client"])
    print(json.dumps(out))
    return EXIT_OK


def cmd_view(args) -> int:
    from shipradar.sim.adapters.viewer.server import HostError, ViewerServer, run_viewer
    from shipradar.sim.stream.bus import EndpointError

    source = args.source
    if "://" not in source and not Path(source).is_file():
        raise BadInput(f"view: SOURCE {source!r} is neither a ZeroMQ endpoint (tcp://HOST:PORT, "
                       "ipc://PATH) nor an existing recording file")
    for ep in args.tracks or []:
        if "://" not in ep:
            raise BadInput(f"--tracks {ep!r} is not a ZeroMQ endpoint (tcp://HOST:PORT)")
    from shipradar.sim.stream.security import curve_from_args

    curve = curve_from_args(args, "client")
    if curve is not None and "://" not in source:
        raise BadInput(f"--curve-secret-key/--curve-server-key secure a live endpoint; "
                       f"{source!r} is a recording")
    if args.allow_remote:
        from shipradar.sim.adapters.viewer.server import check_http_host

        try:
            check_http_host(args.host)
        except HostError:  # allowed: say so, as run and replay do for their streams
            print(f"warning: INSECURE: the viewer listens on {args.host}: its page and "
                  "stream are unauthenticated and unencrypted, anyone who can reach this "
                  "machine can watch", file=sys.stderr)
    try:
        server = ViewerServer(source, host=args.host, port=args.port,
                              allow_remote=args.allow_remote, tracks=args.tracks,
                              speed=args.speed, max_queue=args.max_queue, curve=curve)
        run_viewer(server, open_browser=args.open)
    except HostError as exc:
        raise BadInput(str(exc)) from None
    except EndpointError as exc:
        raise BadInput(f"view: {exc}") from None
    except OSError as exc:  # the port is taken, or the address is not ours
        raise BadInput(f"--port {args.port}: cannot listen on {args.host}:{args.port} "
                       f"({exc.strerror or exc}); choose another port (0 picks a free one)"
                       ) from None
    except KeyboardInterrupt:
        return EXIT_OK
    return EXIT_OK


def _in_range(name: str, lo, hi, cast=int):
    """argparse type: ``cast(text)`` within [lo, hi], else a message naming option, range
    and value."""
    what, bounds = (("an integer", f"[{lo}, {hi}]") if cast is int
                    else ("a number", f"[{lo:g}, {hi:g}]"))

    def conv(text: str):
        try:
            v = cast(text)
        except ValueError:
            v = None
        if v is None or not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"{name} must be {what} in {bounds}, got {text!r}")
        return v

    return conv


def _int_range(name: str, lo: int, hi: int):
    return _in_range(name, lo, hi, int)


def _float_range(name: str, lo: float, hi: float):
    return _in_range(name, lo, hi, float)


def cmd_plot(args) -> int:
    from shipradar.sim.studies.figures.scene import render

    s = _load(args.scenario)
    if args.what == "geometry":  # the scene's map, no tables needed
        from shipradar.sim.studies.figures.geometry import render_geometry

        written = render_geometry(s, Path(args.out), height_m=args.height, radar_id=args.radar)
    else:
        written = render(s, args.what, Path(args.out), radar_id=args.radar,
                         height_m=args.height)
    for p in written:
        print(p)
    return EXIT_OK


def cmd_montecarlo(args) -> int:
    from shipradar.sim.studies.montecarlo import cli_main

    return cli_main(args.rest)


def cmd_report(args) -> int:
    from shipradar.sim.studies.report import cli_main

    return cli_main(args.rest)


def cmd_fidelity(args) -> int:
    from shipradar.sim.studies.fidelity import cli_main

    return cli_main(args.rest)


# --------------------------------------------------------------------------- parser
def _scenario_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenario", nargs="?", default=None, help="scenario YAML file")
    p.add_argument("--example", default=None, metavar="NAME",
                   help="a shipped example scenario instead of a file (shipradar examples)")


def _budget_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument("--memory-budget", type=_positive("--memory-budget"), default=None,
                   metavar="MIB", help="largest memory the scene's tables may take [MiB] "
                   "(default $SHIPRADAR_MEMORY_BUDGET_MIB or 4096)")
    p.add_argument("--max-build-s", type=_positive("--max-build-s"), default=None,
                   metavar="S", help="longest estimated time to build the scene's missing "
                   "tables [s]; a scene over it is refused before any work (default "
                   "$SHIPRADAR_MAX_BUILD_S or 600)")


def _validate_arguments(v: argparse.ArgumentParser) -> None:
    _scenario_arguments(v)
    v.add_argument("--explain", action="store_true",
                   help="list the parts of the model the scene exercises and those it skips")


def _tables_build_arguments(tb: argparse.ArgumentParser) -> None:
    _scenario_arguments(tb)
    _budget_argument(tb)


#: ``--compress``'s choices: :data:`shipradar.sim.stream.recording.COMPRESSIONS`, spelled out so
#: that building the parser (``--help``) does not import the recording module and numpy behind
#: it (``tests/test_startup.py`` checks the two equal).
_COMPRESSIONS: tuple[str, ...] = ("none", "zstd")


def _run_arguments(r: argparse.ArgumentParser) -> None:
    from shipradar.sim.stream.security import add_curve_arguments

    _scenario_arguments(r)
    r.add_argument("--seed", type=_count("--seed"), default=None, help="override the seed")
    r.add_argument("--duration", type=_positive("--duration"), default=None,
                   help="override the duration [s]")
    r.add_argument("--record", default=None, help="append-only recording file")
    r.add_argument("--overwrite", action="store_true", help="replace an existing recording")
    r.add_argument("--publish", default=None, help="ZeroMQ endpoint, e.g. tcp://127.0.0.1:5556")
    r.add_argument("--wait-subscribers", type=_count("--wait-subscribers"), default=0,
                   help="wait for N subscribers before starting")
    r.add_argument("--wait-timeout", type=_positive("--wait-timeout"), default=60.0,
                   help="longest wait for those subscribers [s]")
    r.add_argument("--on-slow", choices=("pace", "drop"), default="pace",
                   help="slow subscriber: slow the run down (pace) or count dropped frames")
    r.add_argument("--compress", choices=_COMPRESSIONS, default="none",
                   help="compress each record of the recording (zstd; docs/protocol.md)")
    r.add_argument("--allow-insecure-remote", "--allow-remote", dest="allow_remote",
                   action=_AllowInsecureRemote,
                   help="allow binding a non-loopback address (e.g. tcp://0.0.0.0:5556) "
                        "without CURVE, or a non-loopback --asterix destination: anyone on "
                        "the network can subscribe; warned on stderr and recorded as "
                        "insecure_remote in the summary (--allow-remote: deprecated alias)")
    add_curve_arguments(r, "server")
    _budget_argument(r)
    r.add_argument("--realtime", nargs="?", const=1.0, default=None,
                   type=_positive("--realtime"), help="pace to the wall clock x FACTOR")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.add_argument("--processes", type=_int_range("--processes", 1, 64), default=1,
                   metavar="N",
                   help="run the radars in N processes (fast mode; same bytes as one)")
    _asterix_arguments(r)
    r.add_argument("--dis", metavar="udp://ADDRESS:PORT", default=None,
                   help="targets from a DIS simulation's Entity State PDUs (port 3000 by "
                        "default; loopback unless --allow-insecure-remote; the run is paced "
                        "to the wall clock); docs/external.md")
    r.add_argument("--dis-exercise", type=_int_range("--dis-exercise", 0, 255), default=None,
                   metavar="N", help="keep only DIS exercise N")
    r.add_argument("--dis-site-app", default=None, metavar="SITE:APP",
                   help="this radar's DIS site and application numbers, for Start/Resume and "
                        "Stop/Freeze PDUs addressed to it (those addressed to all apply "
                        "anyway)")
    r.add_argument("--dis-wait-start", action="store_true",
                   help="hold the run's start until a Start/Resume PDU addressed to this "
                        "radar (--dis-site-app) or to all: the simulation manager starts it")
    r.add_argument("--entities", metavar="ENDPOINT|RECORDING", default=None,
                   help="targets from a live ZeroMQ feed (topic entities; the run is paced "
                        "to the wall clock) or the entities of a recording (fast mode, any "
                        "seed); docs/external.md")


def _replay_arguments(rp: argparse.ArgumentParser) -> None:
    from shipradar.sim.stream.security import add_curve_arguments

    rp.add_argument("recording")
    rp.add_argument("--publish", default=None, help="ZeroMQ endpoint")
    g = rp.add_mutually_exclusive_group()
    g.add_argument("--speed", type=_positive("--speed"), default=1.0)
    g.add_argument("--fast", action="store_true")
    rp.add_argument("--wait-subscribers", type=_count("--wait-subscribers"), default=0,
                    help="wait for N subscribers before the first frame")
    rp.add_argument("--wait-timeout", type=_positive("--wait-timeout"), default=60.0,
                    help="longest wait for those subscribers [s]")
    rp.add_argument("--on-slow", choices=("pace", "drop"), default="pace",
                    help="slow subscriber: slow the replay down (pace) or count dropped frames")
    rp.add_argument("--allow-insecure-remote", "--allow-remote", dest="allow_remote",
                    action=_AllowInsecureRemote,
                    help="allow binding a non-loopback address without CURVE, or a "
                         "non-loopback --asterix destination; warned on stderr and recorded "
                         "as insecure_remote in the summary (--allow-remote: deprecated alias)")
    rp.add_argument("--strict", action="store_true",
                    help="stop at the first damaged record (default: skip it and go on)")
    add_curve_arguments(rp, "server")
    _asterix_arguments(rp)


def _export_arguments(xp: argparse.ArgumentParser) -> None:
    xp.add_argument("recording")
    xp.add_argument("--format", required=True, choices=("asterix", "pcap", "csv", "parquet"),
                    help="asterix: concatenated data blocks (.ast); pcap: the UDP datagrams "
                         "(Wireshark); csv/parquet: plots with their truth, and target states")
    xp.add_argument("--out", required=True, help="output file (csv/parquet: the plots table; "
                    "the target states go beside it as STEM.targets.EXT)")
    xp.add_argument("--overwrite", action="store_true", help="replace existing output")
    xp.add_argument("--port", type=_udp_port, default=8600,
                    help="UDP destination port written in the pcap (default 8600)")
    xp.add_argument("--asterix-max-datagram", type=_datagram_size, default=1400,
                    metavar="BYTES", help="largest ASTERIX data block [bytes] (default 1400)")


def _tail_arguments(tl: argparse.ArgumentParser) -> None:
    from shipradar.sim.stream.security import add_curve_arguments

    tl.add_argument("endpoint")
    tl.add_argument("--topic", action="append", help="topic to keep (repeatable)")
    tl.add_argument("--count", type=_count("--count"), default=None, help="stop after N messages")
    tl.add_argument("--timeout", type=_positive("--timeout"), default=None,
                    help="stop after S seconds without a message")
    add_curve_arguments(tl, "client")


def _recording_verify_arguments(rv: argparse.ArgumentParser) -> None:
    rv.add_argument("recording")


def _recording_repair_arguments(rr: argparse.ArgumentParser) -> None:
    rr.add_argument("recording")
    rr.add_argument("out", metavar="OUT")
    rr.add_argument("--overwrite", action="store_true", help="replace an existing OUT")
    rr.add_argument("--compress", choices=_COMPRESSIONS, default="none",
                    help="compression of OUT")


def _recording_compare_arguments(rp: argparse.ArgumentParser) -> None:
    rp.add_argument("expected")
    rp.add_argument("actual")
    rp.add_argument("--rtol", type=float, default=1e-5,
                    help="largest relative difference of a float (a dB level's as a power); "
                         "default 1e-5, above what installs and CPUs move (README, "
                         "'Reproducibility')")


def _keys_generate_arguments(kg: argparse.ArgumentParser) -> None:
    kg.add_argument("directory", metavar="DIR")
    kg.add_argument("--name", action="append", metavar="NAME",
                    help="subscriber key pair to create (repeatable; default 'client')")


def _view_arguments(vw: argparse.ArgumentParser) -> None:
    from shipradar.sim.stream.security import add_curve_arguments

    vw.add_argument("source", help="ZeroMQ endpoint of a run/replay (tcp://HOST:PORT) or a "
                                   "recording file (replayed by the viewer)")
    vw.add_argument("--port", type=_int_range("--port", 0, 65535), default=8765,
                    help="HTTP port of the page (0: a free one) [default 8765]")
    vw.add_argument("--host", default="127.0.0.1",
                    help="address to listen on [default 127.0.0.1]")
    vw.add_argument("--allow-remote", action="store_true",
                    help="allow listening on a non-loopback address (no authentication)")
    vw.add_argument("--open", action="store_true", help="open the page in the browser")
    vw.add_argument("--tracks", action="append", metavar="ENDPOINT",
                    help="also draw the tracks a tracker publishes there (repeatable)")
    vw.add_argument("--speed", type=_float_range("--speed", 1, 100), default=1.0,
                    help="recording: initial replay speed, x1 to x100 [default 1]")
    vw.add_argument("--max-queue", type=_int_range("--max-queue", 16, 1_000_000),
                    default=4096, help="messages queued per page before the oldest are "
                                       "dropped [default 4096]")
    add_curve_arguments(vw, "client")


def _plot_arguments(pl: argparse.ArgumentParser) -> None:
    pl.add_argument("scenario")
    pl.add_argument("what", choices=("propagation", "coverage", "clutter", "improvement", "all",
                                     "geometry"),
                    help="geometry: the trajectories on a map with time ticks and each "
                         "radar's coverage contour at --height")
    pl.add_argument("--out", default="out/figures")
    pl.add_argument("--radar", default=None, help="radar id (default: every radar)")
    pl.add_argument("--height", type=float, default=10.0, help="target height for F vs range [m]")


def _evaluate_arguments(p: argparse.ArgumentParser) -> None:
    """``evaluate``'s options live with the harness (:mod:`shipradar.sim.studies.evaluate.cli`)."""
    from shipradar.sim.studies.evaluate.cli import add_arguments

    add_arguments(p)


def cmd_evaluate(args) -> int:
    from shipradar.sim.studies.evaluate.cli import main as evaluate_main

    return evaluate_main(args)


# --------------------------------------------------------------------------- the registry
@dataclass(frozen=True)
class Subcommand:
    """One ``shipradar`` sub-command, as :func:`build_parser` and :func:`main` read it: the
    one place a command is registered (an entry of :data:`SUBCOMMANDS`)."""

    #: its words after ``shipradar``: ``("run",)``, or a group and a command
    #: (``("recording", "verify")``, the group's help in :data:`GROUPS`)
    path: tuple[str, ...]
    #: the line ``shipradar -h`` shows
    help: str
    #: what runs it, from the parsed arguments; the exit code
    run: Callable[[argparse.Namespace], int]
    #: declares its options on its sub-parser (None: none)
    arguments: Callable[[argparse.ArgumentParser], None] | None = None
    #: it parses what follows its name itself (``run`` gets ``rest``, that argument list):
    #: the studies' commands, whose parsers live with them
    own_parser: bool = False


#: The help of each group of sub-commands.
GROUPS: dict[str, str] = {
    "tables": "off-line level: precompute a scenario's tables",
    "recording": "check or salvage a recording (verify, repair, compare)",
    "keys": "CurveZMQ keys for authenticated, encrypted streams",
}

#: Every sub-command, in the order ``shipradar -h`` lists them.
SUBCOMMANDS: tuple[Subcommand, ...] = (
    Subcommand(("examples",), "list the shipped example scenarios", cmd_examples),
    Subcommand(("validate",), "check a scenario file", cmd_validate, _validate_arguments),
    Subcommand(("tables", "build"), "build the tables a scenario needs (cached)",
               cmd_tables_build, _tables_build_arguments),
    Subcommand(("run",), "run a scenario headless", cmd_run, _run_arguments),
    Subcommand(("replay",), "republish a recording", cmd_replay, _replay_arguments),
    Subcommand(("export",), "convert a recording: raw ASTERIX, pcap, CSV, Parquet", cmd_export,
               _export_arguments),
    Subcommand(("tail",), "print a stream as JSON lines", cmd_tail, _tail_arguments),
    Subcommand(("recording", "verify"), "report records, time span, sensors, damage, "
               "truncation (exit 0 clean, 1 damaged, 2 unreadable)", cmd_recording_verify,
               _recording_verify_arguments),
    Subcommand(("recording", "repair"), "write every valid record to a new file (the input "
               "is never modified)", cmd_recording_repair, _recording_repair_arguments),
    Subcommand(("recording", "compare"), "compare two recordings by value: the same messages, "
               "plot ids and integers, floats within --rtol (exit 0 equal, 1 different; "
               "docs/stability.md section 6)", cmd_recording_compare,
               _recording_compare_arguments),
    Subcommand(("keys", "generate"), "a publisher key pair, subscriber key pairs and "
               "DIR/authorized/ (docs/protocol.md, Security)", cmd_keys_generate,
               _keys_generate_arguments),
    Subcommand(("view",), "live PPI in the browser, of a stream or a recording", cmd_view,
               _view_arguments),
    Subcommand(("plot",), "render figures of a scenario's tables as PNG", cmd_plot,
               _plot_arguments),
    Subcommand(("montecarlo",), "replications on a Dask cluster (see: shipradar montecarlo -h)",
               cmd_montecarlo, own_parser=True),
    Subcommand(("report",), "study report: PNG figures and an index page (shipradar report -h)",
               cmd_report, own_parser=True),
    Subcommand(("fidelity",), "measure the speed/accuracy trade on a scene and recommend a "
               "fidelity block (shipradar fidelity -h)", cmd_fidelity, own_parser=True),
    Subcommand(("evaluate",), "score a tracker under test on seeded runs (GOSPA, SIAP, "
               "per-target, latency)", cmd_evaluate, _evaluate_arguments),
)


def build_parser() -> argparse.ArgumentParser:
    """The ``shipradar`` parser: a sub-parser per entry of :data:`SUBCOMMANDS` (and per group
    of :data:`GROUPS`), each calling its ``run``."""
    from shipradar import __version__

    p = argparse.ArgumentParser(prog="shipradar", description=__doc__.splitlines()[0])
    p.add_argument("--version", action="version", version=f"shipradar {__version__}")
    top = p.add_subparsers(dest="command", required=True)
    groups: dict[str, _Subcommands] = {}
    for cmd in SUBCOMMANDS:
        sub = top
        if len(cmd.path) == 2:
            group = cmd.path[0]
            if group not in groups:
                groups[group] = top.add_parser(group, help=GROUPS[group]).add_subparsers(
                    dest=f"{group}_command", required=True)
            sub = groups[group]
        leaf = sub.add_parser(cmd.path[-1], help=cmd.help, add_help=not cmd.own_parser)
        if cmd.own_parser:
            leaf.add_argument("rest", nargs=argparse.REMAINDER)
        elif cmd.arguments is not None:
            cmd.arguments(leaf)
        leaf.set_defaults(func=cmd.run)
    return p


def _parse(argv: list[str]) -> argparse.Namespace:
    """The parsed arguments of ``shipradar ARGV``; a command with its own parser gets the
    words after its name as they are (argparse would take an option among them for the top
    parser's)."""
    for cmd in SUBCOMMANDS:
        if cmd.own_parser and argv[:len(cmd.path)] == list(cmd.path):
            return argparse.Namespace(rest=argv[len(cmd.path):], func=cmd.run)
    return build_parser().parse_args(argv)  # argparse exits with 2 on bad options


def _objects_so_far_kept() -> None:
    """Move every object made so far out of the garbage collector's sight, and turn it on.

    What a command imports and builds before its work (numpy, scipy, pydantic's schemas, the
    tables: about a million objects) lives until the process ends; each full collection walks
    all of it again.  ``gc.freeze`` keeps them out of every later collection.  Only for the
    process's own command (:func:`main` without ``argv``): the cycles among them that become
    garbage later are never collected, which only a process about to end can afford.
    """
    gc.freeze()
    gc.enable()


#: The environment variables that set the BLAS libraries' thread counts (OpenBLAS, the
#: OpenMP runtime, MKL): a user's own setting of any of them is kept.
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _one_blas_thread() -> None:
    """One BLAS thread for a ``run`` process, unless the user set a count or numpy is already
    imported (then it is too late to matter).

    The on-line level has no BLAS work worth a thread, and the stream's bytes do not depend
    on the count (``tests/test_blas_determinism.py``); OpenBLAS's idle worker threads spin
    instead: 0.29 s of CPU and ~0.03 s of wall per raid run on 2 cores (docs/performance.md
    section 12).  Tables a run has to build are built on one thread too; ``shipradar tables
    build`` uses them all.
    """
    if "numpy" in sys.modules or any(v in os.environ for v in BLAS_THREAD_VARIABLES):
        return
    os.environ.update(dict.fromkeys(BLAS_THREAD_VARIABLES, "1"))


def main(argv: list[str] | None = None) -> int:
    """The ``shipradar`` command; ``argv`` defaults to the process's own arguments.

    Called without ``argv`` (the console script, ``python -m shipradar.sim.cli``) it is the
    process's whole work, and the garbage collector is told so: ``run`` imports and builds
    its set-up with the collector off (its collections took ~40 ms of the imports; on again
    while tables are built) and freezes that set-up before the loop
    (:func:`_objects_so_far_kept`), and every command freezes what is left at its end, so
    that the interpreter's exit does not walk every object once more (~50 ms).  ``run`` also
    asks for one BLAS thread (:func:`_one_blas_thread`).  None of this changes what a command
    computes or writes.
    """
    command_line = argv is None
    argv = sys.argv[1:] if argv is None else list(argv)
    args = _parse(argv)
    if command_line and args.func is cmd_run:
        gc.disable()
        args.gc_off_until_run = True
        _one_blas_thread()
    try:
        return args.func(args)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except Exception as exc:
        # marked by their classes (shipradar.sim.world.errors): the commands' modules are
        # imported only when a command uses them, so they cannot be listed here
        if isinstance(exc, BadInputError):
            print(str(exc), file=sys.stderr)
            return EXIT_BAD_INPUT
        if isinstance(exc, PeerError):
            print(str(exc), file=sys.stderr)
            return EXIT_FAILURE
        raise
    finally:
        if command_line:  # the process ends now: its exit need not collect
            _objects_so_far_kept()


if __name__ == "__main__":
    sys.exit(main())
