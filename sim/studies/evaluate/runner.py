"""One seeded run of a study: the simulator, the tracker under test, everything recorded.

:func:`run_tracker_command` runs a tracker given as a command line, in its own process:

1. the simulator's publisher binds a free loopback port (``{plots}``), in ``pace`` mode (a
   slow tracker slows the run and loses nothing, docs/protocol.md section 8) with a stall
   timeout (a tracker that stops reading fails the run instead of hanging it), and records
   the stream to ``stream.rec``;
2. a SUB socket of the harness connects to ``{tracks}`` (a free loopback port the tracker
   binds, topics ``tracks`` and ``registration``, docs/protocol.md sections 4.6 and 4.8)
   before the tracker starts;
3. the tracker starts with its placeholders filled in (``{plots}``, ``{tracks}``,
   ``{asterix}``: a free UDP port on 127.0.0.1 where ASTERIX CAT048/034 goes, docs/asterix.md;
   ``{seed}``; ``{run_dir}``), its stdout and stderr to files of the run directory;
4. the run starts once the tracker has subscribed (``--wait-subscribers 1``; a tracker that
   only reads ASTERIX is ready when its ``{tracks}`` endpoint is up) or fails with a clear
   timeout; it stops early, at an end of scan, if the tracker dies;
5. after the last message, the harness waits until the tracker has published valid tracks
   for the last scan (a malformed message does not count), has exited, or has been quiet
   for ``drain_s``; then stops it (SIGTERM to its process group, SIGKILL 5 s later) and
   reads what is still arriving until ``POLL_S`` of quiet.

A tracker that exits by itself with a non-zero code fails the run (its exit code and the
tail of its stderr in ``run.json``); one that exits with 0 is scored on what it published.

:func:`run_tracker_object` is the in-process form for a tracker written as a Python object.
"""

from __future__ import annotations

import json
import math
import os
import shlex
import signal
import socket
import subprocess
import threading
import time
import traceback
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import msgpack
import numpy as np
import zmq
from zmq.utils.monitor import recv_monitor_message

from shipradar.sim.stream.bus import Bus, Publisher, PublisherStalledError, RunInterrupted
from shipradar.sim.stream.protocol import ProtocolError, decode, encode
from shipradar.sim.stream.recording import Recorder
from shipradar.sim.stream.schema import EOS, META, PLOTS, TOPIC_REGISTRATION, TRUTH_TARGETS
from shipradar.sim.studies.evaluate.data import (
    TOPIC_TRACKS,
    Collect,
    MalformedTracks,
    RunData,
    add_tracks,
    tracks_from_payload,
)
from shipradar.sim.studies.evaluate.registration import TRUTH_SENSORS_KIND

if TYPE_CHECKING:
    from shipradar.sim.dwell.prepared import PreparedScene

__all__ = ["RunSpec", "fill_placeholders", "free_port", "run_and_collect",
           "run_tracker_command", "run_tracker_object"]

#: Lines of the tracker's stderr kept in ``run.json`` when it fails.
STDERR_TAIL_LINES = 20
#: Grace between SIGTERM and SIGKILL when the harness stops a tracker [s].
KILL_GRACE_S = 5.0
#: How often the collector thread looks at its stop flag, and the drain at its three
#: conditions [s]: the harness's delay in stopping after a run.
POLL_S = 0.01

#: Longest the collector reads what is still arriving once told to stop [s] (it stops
#: sooner, after POLL_S of quiet).
FINAL_READ_S = 1.0


@dataclass(frozen=True)
class RunSpec:
    """One run of a study.

    Attributes
    ----------
    scenario : str
        Scenario file.
    seed : int
        The run's seed (the simulator's; also ``{seed}`` for the tracker).
    run_dir : str
        Directory of the run's files (created).
    tracker : str
        Tracker command with placeholders (module docstring).
    duration_s : float or None
        Simulated duration [s]; None: the scenario's.
    wait_timeout_s : float
        Longest wait for the tracker to subscribe [s].
    stall_timeout_s : float
        A tracker that reads nothing for this long fails the run [s].
    drain_s : float
        After the run, how long a silent tracker is given before it is stopped [s].
    realtime : float or None
        Run paced at this multiple of the wall clock (latency then measures the tracker, not
        its input queue); None: as fast as the tracker reads.
    entities : str or None
        A recording whose ``entities`` topic moves the targets (a live session re-simulated,
        ``shipradar run --entities RECORDING``); None: the scenario's own targets.
    """

    scenario: str
    seed: int
    run_dir: str
    tracker: str
    duration_s: float | None = None
    wait_timeout_s: float = 30.0
    stall_timeout_s: float = 120.0
    drain_s: float = 5.0
    realtime: float | None = None
    entities: str | None = None


def _entities(path: str | None):
    """The recorded entities of ``path`` (a fresh reader per run), or None."""
    if path is None:
        return None
    from shipradar.sim.stream.entities import RecordedEntities

    return RecordedEntities(path)


def free_port(kind: int = socket.SOCK_STREAM) -> int:
    """A free port on 127.0.0.1 (TCP or UDP), as the OS hands it out."""
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def fill_placeholders(command: str, values: dict[str, str]) -> list[str]:
    """The tracker's argv: ``command`` split as a shell would (no shell runs), each
    ``{name}`` of ``values`` replaced; other braces are left as they are."""
    argv = shlex.split(command)
    out = []
    for a in argv:
        for k, v in values.items():
            a = a.replace("{" + k + "}", v)
        out.append(a)
    return out


class _TimedPublisher(Publisher):
    """The publisher, noting the wall time of each message it sends (the latency's start),
    and asking the bus to stop at the next end of scan once the tracker has died."""

    def __init__(self, *args, t0: float, proc_alive: Callable[[], bool], **kwargs):
        super().__init__(*args, **kwargs)
        self.t0 = t0
        self.sent_s: list[float] = []
        self.proc_alive = proc_alive
        self.bus: Bus | None = None

    def send(self, frames) -> bool:
        ok = super().send(frames)
        self.sent_s.append(time.perf_counter() - self.t0)
        if len(self.sent_s) % 64 == 0 and self.bus is not None and not self.proc_alive():
            self.bus.stop_requested = True
        return ok


def _peek(body, keys: tuple[str, ...]) -> dict[str, Any]:
    """Top-level ``keys`` of a message body, read without decoding the rest (its arrays are
    skipped, not built)."""
    u = msgpack.Unpacker(raw=False)
    u.feed(body)
    out: dict[str, Any] = {}
    for _ in range(u.read_map_header()):
        k = u.unpack()
        if k in keys:
            out[k] = u.unpack()
            if len(out) == len(keys):
                break
        else:
            u.skip()
    return out


#: The ``truth`` kinds the scorer reads (``Collect.add``): the targets' states, the radars'
#: true errors (registration).
_TRUTH_KINDS_READ = (TRUTH_TARGETS.kind, TRUTH_SENSORS_KIND)


class _CollectingBus(Bus):
    """The run's bus, also handing the scorer what it reads (a
    :class:`~shipradar.sim.studies.evaluate.data.Collect`) as each message goes out, so that
    a run is scored without reading its recording back: the ``meta``, ``eos``,
    ``truth[targets]`` and ``truth[sensors]`` messages decoded, of a ``plots`` message only
    its time and sensor (the latency's inputs), nothing of the others. The same
    ``Collect.add`` calls as :func:`~shipradar.sim.studies.evaluate.data.load_run`'s, with
    the same wall times (the publisher's, by message index), so the two give the same
    data."""

    def __init__(self, publisher: _TimedPublisher, recorder: Recorder, collect: Collect):
        super().__init__(publisher, recorder)
        self.collect = collect
        self.sent_s = publisher.sent_s
        self.n = 0

    def emit_frames(self, t_sim: float, frames) -> None:
        super().emit_frames(t_sim, frames)
        self._add(frames)

    def emit_many(self, records) -> None:
        super().emit_many(records)
        for _, frames in records:
            self._add(frames)

    def _add(self, frames) -> None:
        i, self.n = self.n, self.n + 1
        sent = self.sent_s[i] if i < len(self.sent_s) else math.nan
        topic = bytes(frames[0])
        if topic == PLOTS.topic:
            p = _peek(frames[1], ("t", "sensor"))
            self.collect.add(topic, float(p["t"]), p, sent)
        elif topic in (META.topic, EOS.topic) or (
                topic == TRUTH_TARGETS.topic
                and _peek(frames[1], ("kind",)).get("kind") in _TRUTH_KINDS_READ):
            _, t, payload = decode(frames)
            self.collect.add(topic, t, payload, sent)


class _Collector(threading.Thread):
    """Receives the tracker's ``tracks`` (and ``registration``) messages with their wall
    times; ``connected`` is set once the ZMTP handshake with the tracker's publisher has
    succeeded."""

    def __init__(self, endpoint: str, t0: float):
        super().__init__(daemon=True, name="evaluate-tracks")
        self.ctx = zmq.Context()
        self.sock = self.ctx.socket(zmq.SUB)
        self.sock.setsockopt(zmq.LINGER, 0)
        self.sock.setsockopt(zmq.RCVHWM, 0)  # keep everything the tracker sends
        self.monitor = self.sock.get_monitor_socket(
            zmq.EVENT_HANDSHAKE_SUCCEEDED | zmq.EVENT_CONNECTED)
        self.sock.setsockopt(zmq.SUBSCRIBE, TOPIC_TRACKS)
        self.sock.setsockopt(zmq.SUBSCRIBE, TOPIC_REGISTRATION)  # its bias estimates, if any
        self.sock.connect(endpoint)
        self.t0 = t0
        self.records: list[tuple[float, float, list[bytes]]] = []  # (t, recv, frames)
        self.last_time_s = -math.inf
        self.last_recv = time.perf_counter()
        self.connected = threading.Event()
        self.stop = threading.Event()

    def run(self) -> None:
        poller = zmq.Poller()
        poller.register(self.sock, zmq.POLLIN)
        poller.register(self.monitor, zmq.POLLIN)
        try:
            while not self.stop.is_set():
                for s, _ in poller.poll(int(POLL_S * 1000)):
                    if s is self.monitor:
                        # the handshake, not the TCP connection: the subscription goes out
                        # with it, so the tracker's first message is not dropped
                        event = recv_monitor_message(self.monitor)
                        if event["event"] == zmq.EVENT_HANDSHAKE_SUCCEEDED:
                            self.connected.set()
                        continue
                    self._receive(self.sock.recv_multipart())
            # what the tracker sent before it stopped and the harness has not read yet
            # (the stop flag is looked at between messages): read until quiet for POLL_S
            deadline = time.perf_counter() + FINAL_READ_S
            while time.perf_counter() < deadline and self.sock.poll(int(POLL_S * 1000)):
                self._receive(self.sock.recv_multipart())
        finally:
            self.sock.disable_monitor()
            self.monitor.close(linger=0)
            self.sock.close(linger=0)
            self.ctx.term()

    def _receive(self, frames: list[bytes]) -> None:
        """Keep one message with its wall time; a valid ``tracks`` message moves
        ``last_time_s`` (what the drain waits on), once it is kept. A malformed one does
        not: the messages a tracker sends before its last valid one (in order, on one
        connection) are then all kept when the drain ends."""
        now = time.perf_counter()
        ts = None
        try:
            topic, t, p = decode(frames)
        except ProtocolError:
            t = math.nan
        else:
            if topic == TOPIC_TRACKS:
                try:
                    ts = tracks_from_payload(p).time_s
                except MalformedTracks:
                    pass
        self.records.append((t, now - self.t0, frames))
        self.last_recv = now
        if ts is not None:
            self.last_time_s = max(self.last_time_s, ts)


def _tail(path: Path, lines: int = STDERR_TAIL_LINES) -> str:
    try:
        text = path.read_text(errors="replace")
    except OSError:
        return ""
    return "\n".join(text.splitlines()[-lines:])


def _stop(proc: subprocess.Popen) -> int | None:
    """SIGTERM to the tracker's process group, SIGKILL after the grace; its exit code."""
    if proc.poll() is not None:
        return proc.returncode
    try:
        os.killpg(proc.pid, signal.SIGTERM)
        return proc.wait(KILL_GRACE_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        return proc.wait()
    except ProcessLookupError:
        return proc.wait()


def _write_tracks(run_dir: Path, records: list[tuple[float, float, list[bytes]]]) -> None:
    with Recorder(run_dir / "tracks.rec", overwrite=True) as rec:
        for t, _, frames in records:
            rec.write(t, frames)


_SCENES: dict[tuple[str, int, str | None], tuple[Any, Any, PreparedScene]] = {}


def _scene(path: str) -> tuple[Any, Any, PreparedScene]:
    """The scenario of ``path``, its tables and their preparation, loaded once per process
    while the file and the table cache are the same (a study's worker runs one scene many
    times; the tables are read-only, as :func:`run_tracker_object` already shares them
    between runs, and each run is given the preparation:
    :class:`shipradar.sim.dwell.prepared.PreparedScene`)."""
    from shipradar.sim.dwell.prepared import PreparedScene
    from shipradar.sim.world.scenario import load_scenario
    from shipradar.tables.scene import load_scene_tables

    key = (str(Path(path).resolve()), os.stat(path).st_mtime_ns,
           os.environ.get("SHIPRADAR_TABLES"))
    if key not in _SCENES:
        _SCENES.clear()
        scenario = load_scenario(path)
        tables = load_scene_tables(scenario)
        _SCENES[key] = (scenario, tables, PreparedScene(scenario, tables))
    return _SCENES[key]


def run_tracker_command(spec: RunSpec) -> dict[str, Any]:
    """Run one seeded run with the tracker command of ``spec``; write its run directory.

    Returns
    -------
    dict
        The content of ``run.json``: ``seed``, ``status`` (``ok`` or ``failed``),
        ``error`` (why it failed), ``exit_code`` and ``stderr_tail`` of the tracker,
        ``stopped_by_harness``, the endpoints, ``duration_s``, the simulator's summary and the
        wall times: ``wall_s`` (the whole run), ``run_s`` (the simulation with the tracker
        reading), ``startup_s`` (scenario, tables, tracker start until it subscribed, the
        simulation built),
        ``drain_s``, ``harness_s`` (the rest: the harness's own work after the run:
        ``stop_s`` stopping the tracker and the collector, ``write_s`` writing the files).
    """
    return _run_command(spec, None)


def run_and_collect(spec: RunSpec) -> tuple[dict[str, Any], RunData | None]:
    """:func:`run_tracker_command`, and the run's data as
    :func:`~shipradar.sim.studies.evaluate.data.load_run` would read it back from the run
    directory (None for a failed run), collected while the run went: no recording is read.
    ``collect_s``: the time to assemble it after the run [s]."""
    collect = Collect()
    info = _run_command(spec, collect)
    records = info.pop("_records", [])
    if info["status"] != "ok":
        return info, None
    t0 = time.perf_counter()
    data = collect.result(json.loads(json.dumps(info, default=_json_default)))
    for _, recv, frames in records:
        add_tracks(data, frames, recv, decoded=False)
    info["collect_s"] = time.perf_counter() - t0  # part of the scoring's cost
    return info, data


@dataclass
class _Run:
    """One run of a tracker command while it goes: the tracker's process, the harness's
    sockets, the tracker's output files, what the run gave and the times of its phases [s]."""

    spec: RunSpec
    run_dir: Path
    wall0: float  # perf_counter at the start [s]
    info: dict[str, Any]  # becomes run.json
    stdout: IO[bytes]
    stderr: IO[bytes]
    proc: subprocess.Popen | None = None
    publisher: _TimedPublisher | None = None
    collector: _Collector | None = None
    bus: Any = None  # the simulator's bus while the simulation runs
    summary: Any = None
    startup_s: float = 0.0
    run_s: float = 0.0
    drain_s: float = 0.0
    stop_s: float = 0.0

    def tracker_alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None


def _run_command(spec: RunSpec, collect: Collect | None) -> dict[str, Any]:
    """The steps of :func:`run_tracker_command`: start the tracker, run the simulation, wait
    for the last tracks, stop everything, write the run directory; a failure of any step is
    reported in the run's ``status`` and ``error``, never raised."""
    wall0 = time.perf_counter()
    run_dir = Path(spec.run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    scenario, tables, prepared = _scene(spec.scenario)
    duration = float(scenario.duration_s if spec.duration_s is None else spec.duration_s)
    info: dict[str, Any] = {"seed": spec.seed, "status": "ok", "error": None,
                            "scenario": scenario.name, "duration_s": duration,
                            "tracker": spec.tracker, "exit_code": None, "stderr_tail": "",
                            "stopped_by_harness": False, "spec": asdict(spec)}
    run = _Run(spec, run_dir, wall0, info,
               open(run_dir / "tracker.stdout", "wb"),  # noqa: SIM115 - closed by _stop_run
               open(run_dir / "tracker.stderr", "wb"))  # noqa: SIM115
    try:
        _start_tracker(run)
        _simulate(run, scenario, tables, prepared, duration, collect)
        t_drain = time.perf_counter()
        assert run.proc is not None and run.collector is not None  # started above
        _drain(spec, run.proc, run.collector, duration)
        run.drain_s = time.perf_counter() - t_drain
    except _RunFailed as exc:
        info["status"], info["error"] = "failed", str(exc)
    except Exception as exc:  # the harness's own failure: reported on the run, not raised
        info["status"] = "failed"
        info["error"] = f"harness error: {exc!r}"
        info["traceback"] = traceback.format_exc(limit=8)
    finally:
        _stop_run(run)
    return _write_run(run, keep_records=collect is not None)


def _start_tracker(run: _Run) -> None:
    """Bind the stream's publisher, connect the collector to ``{tracks}``, start the
    tracker with its placeholders filled in and wait until it is ready."""
    spec, info = run.spec, run.info
    run.publisher = publisher = _TimedPublisher(
        "tcp://127.0.0.1:*", on_slow="pace", stall_timeout_s=spec.stall_timeout_s,
        t0=run.wall0, proc_alive=run.tracker_alive)
    tracks_ep = f"tcp://127.0.0.1:{free_port()}"
    asterix_ep = f"udp://127.0.0.1:{free_port(socket.SOCK_DGRAM)}"
    values = {"plots": publisher.endpoint, "tracks": tracks_ep, "asterix": asterix_ep,
              "seed": str(spec.seed), "run_dir": str(run.run_dir)}
    info["endpoints"] = {"plots": publisher.endpoint, "tracks": tracks_ep,
                         "asterix": asterix_ep}
    run.collector = collector = _Collector(tracks_ep, run.wall0)
    collector.start()
    argv = fill_placeholders(spec.tracker, values)
    info["argv"] = argv
    try:
        run.proc = subprocess.Popen(argv, stdout=run.stdout, stderr=run.stderr,
                                    stdin=subprocess.DEVNULL, start_new_session=True)
    except OSError as exc:
        raise _RunFailed(f"cannot start the tracker: {exc}") from None
    _wait_ready(spec, run.proc, publisher, collector, uses_plots="{plots}" in spec.tracker,
                uses_tracks="{tracks}" in spec.tracker)


def _simulate(run: _Run, scenario: Any, tables: Any, prepared: PreparedScene | None,
              duration: float, collect: Collect | None) -> None:
    """The simulation, its stream recorded and published (and sent as ASTERIX when the
    tracker reads ``{asterix}``), given the scene's ``prepared`` set-up; its summary,
    ``startup_s`` and ``run_s`` kept on ``run``."""
    from shipradar.sim.engine.simulation import Simulation

    spec, publisher = run.spec, run.publisher
    assert publisher is not None  # bound by _start_tracker
    # built after the tracker is ready: the milliseconds it takes also let the tracker's
    # publisher take in the harness's subscription before its first message
    recorder = Recorder(run.run_dir / "stream.rec", overwrite=True)
    bus = run.bus = (Bus(publisher, recorder) if collect is None
                     else _CollectingBus(publisher, recorder, collect))
    publisher.bus = bus
    sim_bus: Any = bus
    if "{asterix}" in spec.tracker:
        from shipradar.sim.adapters.asterix.udp import AsterixBus, UdpSender

        sim_bus = AsterixBus(bus, UdpSender(run.info["endpoints"]["asterix"]), 1400)
    sim = Simulation(scenario, bus=sim_bus, seed=spec.seed, duration_s=duration,
                     realtime=spec.realtime, tables=tables, entities=_entities(spec.entities),
                     prepared=prepared)
    t_run = time.perf_counter()
    run.startup_s = t_run - run.wall0  # the tracker until it subscribed, the simulation built
    try:
        run.summary = sim.run()
    except RunInterrupted:
        run.summary = sim.summary(time.perf_counter() - t_run)
    except PublisherStalledError as exc:
        raise _RunFailed(f"the tracker stopped reading: {exc}") from None
    finally:
        (sim_bus if sim_bus is not bus else bus).close()
        run.bus = None
    run.run_s = time.perf_counter() - t_run


def _stop_run(run: _Run) -> None:
    """Close the stream, stop the tracker (its exit code on the run; a non-zero exit of its
    own fails the run) and the collector, close the output files; ``stop_s`` on ``run``."""
    t_stop = time.perf_counter()
    info = run.info
    if run.bus is not None:
        run.bus.close(linger_ms=0)
    elif run.publisher is not None:  # close is idempotent
        run.publisher.close(linger_ms=0)
    if run.proc is not None:
        exited = run.proc.poll()
        code = _stop(run.proc)
        info["exit_code"] = code
        info["stopped_by_harness"] = exited is None
        if exited is not None and exited != 0:
            info["status"] = "failed"
            info["error"] = info["error"] or f"the tracker exited with code {exited}"
    if run.collector is not None:
        run.collector.stop.set()
        run.collector.join()
    run.stdout.close()
    run.stderr.close()
    run.stop_s = time.perf_counter() - t_stop


def _write_run(run: _Run, keep_records: bool) -> dict[str, Any]:
    """Write the run directory (``tracks``, ``timing.npz``, ``run.json``) and return
    ``run.json``'s content (with ``_records``, the tracks as received, if ``keep_records``)."""
    t_write = time.perf_counter()
    info, run_dir = run.info, run.run_dir
    if info["status"] != "ok":
        info["stderr_tail"] = _tail(run_dir / "tracker.stderr")
    records = run.collector.records if run.collector is not None else []
    _write_tracks(run_dir, records)
    sent = run.publisher.sent_s if run.publisher is not None else []
    np.savez(run_dir / "timing.npz", stream_sent_s=np.array(sent, float),
             tracks_recv_s=np.array([r[1] for r in records], float))
    info["summary"] = run.summary
    wall = time.perf_counter() - run.wall0
    info.update(wall_s=wall, startup_s=run.startup_s, run_s=run.run_s, drain_s=run.drain_s,
                harness_s=max(wall - run.startup_s - run.run_s - run.drain_s, 0.0),
                stop_s=run.stop_s, write_s=time.perf_counter() - t_write)
    (run_dir / "run.json").write_text(json.dumps(info, indent=1, default=_json_default))
    if keep_records:
        info["_records"] = records
    return info


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    return str(obj)


class _RunFailed(Exception):
    """The run cannot be scored (the message says why)."""


def _wait_ready(spec: RunSpec, proc, publisher, collector, *, uses_plots: bool,
                uses_tracks: bool) -> None:
    """Until the tracker has subscribed to ``{plots}`` (or, for an ASTERIX-only tracker,
    bound ``{tracks}``), and the harness is connected to its ``{tracks}``."""
    deadline = time.monotonic() + spec.wait_timeout_s
    if uses_plots:
        while publisher.poll_subscriptions(0.1) < 1:
            if proc.poll() is not None:
                raise _RunFailed(f"the tracker exited with code {proc.returncode} before "
                                 f"subscribing to {publisher.endpoint}")
            if time.monotonic() > deadline:
                raise _RunFailed(f"the tracker did not subscribe to {publisher.endpoint} "
                                 f"within {spec.wait_timeout_s:g} s (--wait-timeout)")
    if uses_tracks:
        # the tracker binds {tracks} before it subscribes, in the usual order; this only
        # makes sure the harness hears its first message
        while not collector.connected.wait(0.1):
            if proc.poll() is not None:
                raise _RunFailed(f"the tracker exited with code {proc.returncode} before "
                                 f"binding its tracks endpoint")
            if time.monotonic() > deadline:
                if uses_plots:
                    return  # subscribed but never binds {tracks}: scored as silent
                raise _RunFailed(f"the tracker did not bind its tracks endpoint within "
                                 f"{spec.wait_timeout_s:g} s (--wait-timeout)")


def _drain(spec: RunSpec, proc, collector, last_t: float) -> None:
    """Wait for the tracker's last tracks (at the last scan), its exit, or its silence."""
    while proc.poll() is None:
        if collector.last_time_s >= last_t - 1e-6:
            return
        if time.perf_counter() - collector.last_recv > spec.drain_s:
            return
        time.sleep(POLL_S)  # a bounded poll of three conditions, none of them an event


# ----------------------------------------------------------------------------- in process
class _InProcessSink:
    """The simulation's bus for an in-process tracker: every message goes to the collector
    of truth; ``meta``, ``plots`` and ``eos`` go to the tracker, whose answers are checked
    and kept with their wall times. ``record`` encodes everything for the run directory."""

    def __init__(self, tracker, collect: Collect, data_tracks: RunData, t0: float,
                 record: bool):
        self.tracker = tracker
        self.collect = collect
        self.data = data_tracks
        self.t0 = t0
        self.stream: list[tuple[float, list[bytes]]] | None = [] if record else None
        self.tracks: list[tuple[float, list[bytes]]] | None = [] if record else None
        self.sent: list[float] = []
        self.recv: list[float] = []
        self.messages = 0

    def emit(self, topic: bytes, t: float, payload: Mapping[str, Any]) -> None:
        self.messages += 1
        now = time.perf_counter() - self.t0
        self.collect.add(topic, t, payload, now)
        if self.stream is not None:
            self.stream.append((t, encode(topic, t, payload)))
            self.sent.append(now)
        if topic == b"truth":
            return
        out = self.tracker.on_message(topic.decode(), t, payload)
        if out is None:
            return
        for p in (out if isinstance(out, (list, tuple)) else [out]):
            recv = time.perf_counter() - self.t0
            add_tracks(self.data, p, recv, decoded=True)
            if self.tracks is not None:
                try:
                    self.tracks.append((float(p.get("time_s", t)), encode(TOPIC_TRACKS,
                                        float(p.get("time_s", t)), p)))
                    self.recv.append(recv)
                except Exception:  # noqa: BLE001 - malformed: counted above, not recorded
                    pass

    def flush(self, fsync: bool = False) -> None:
        """Nothing is buffered."""

    @property
    def stats(self) -> dict[str, Any]:
        return {"messages": self.messages}


def run_tracker_object(scenario, tracker, *, seed: int, duration_s: float | None = None,
                       tables=None, run_dir: str | Path | None = None,
                       entities: str | None = None,
                       prepared: PreparedScene | None = None) -> RunData:
    """One seeded run with an in-process tracker object; the run's data, ready to score.

    Parameters
    ----------
    scenario : Scenario
        The scene.
    tracker : object or callable
        An object with ``on_message(topic, t_sim, payload)`` that returns None, a ``tracks``
        payload (docs/protocol.md section 4.6, as a dict) or a list of them; or a class or
        callable returning such an object (called once per run: a fresh tracker per seed). It sees
        the ``meta``, ``plots`` and ``eos`` messages, never ``truth``.
    seed : int
    duration_s : float or None
        [s]
    tables : SceneTables or None
    run_dir : path or None
        Also write the run directory (recordings, timings, ``run.json``) for ``--rescore``.
    entities : str or None
        A recording whose ``entities`` move the targets (:class:`RunSpec`).
    prepared : PreparedScene or None
        What the runs of ``scenario`` on ``tables`` share
        (:class:`shipradar.sim.dwell.prepared.PreparedScene`, e.g. the previous run's);
        None: the run makes its own.
    """
    from shipradar.sim.engine.simulation import Simulation

    # a class or a factory makes a fresh tracker per run; an instance is used as it is
    fresh = isinstance(tracker, type) or not hasattr(tracker, "on_message")
    obj = tracker() if fresh else tracker
    duration = float(scenario.duration_s if duration_s is None else duration_s)
    info: dict[str, Any] = {"seed": seed, "status": "ok", "error": None,
                            "scenario": scenario.name, "duration_s": duration,
                            "tracker": type(obj).__name__}
    collect = Collect()
    holder = RunData(info, [], "", np.zeros(0), np.zeros((0, 0, 3)), np.zeros((0, 0, 3)),
                     np.zeros((0, 0), bool), {}, {})
    t0 = time.perf_counter()
    sink = _InProcessSink(obj, collect, holder, t0, record=run_dir is not None)
    sim = Simulation(scenario, bus=sink, seed=seed, duration_s=duration, tables=tables,
                     entities=_entities(entities), prepared=prepared)
    try:
        info["summary"] = sim.run()
    except Exception as exc:  # the tracker's failure is the run's result
        info["status"], info["error"] = "failed", f"the tracker raised {exc!r}"
        info["stderr_tail"] = traceback.format_exc(limit=-4)
    info["wall_s"] = time.perf_counter() - t0
    data = collect.result(info)
    data.tracks, data.malformed = holder.tracks, holder.malformed
    data.malformed_examples = holder.malformed_examples
    if run_dir is not None:
        run_dir = Path(run_dir)
        run_dir.mkdir(parents=True, exist_ok=True)
        with Recorder(run_dir / "stream.rec", overwrite=True) as rec:
            for t, frames in sink.stream or []:
                rec.write(t, frames)
        with Recorder(run_dir / "tracks.rec", overwrite=True) as rec:
            for t, frames in sink.tracks or []:
                rec.write(t, frames)
        np.savez(run_dir / "timing.npz", stream_sent_s=np.array(sink.sent, float),
                 tracks_recv_s=np.array(sink.recv, float))
        (run_dir / "run.json").write_text(json.dumps(info, indent=1, default=_json_default))
    return data
