"""The SimPy engine: one process per radar, rotating its antenna and publishing sectors.

Each antenna revolution is cut into ``fidelity.sectors_per_scan`` sectors.  Ahead of the
beam, a block of revolutions (:data:`_BLOCK_S` of simulated time, at least one revolution) is
computed at once: (1) for every target and revolution, every time at which the rotating
beam crosses it (none, once, or more; moving ship and moving targets,
:func:`shipradar.sim.world.kinematics.beam_crossings`), (2) the dwell model on every crossing
of the block in one vectorized call (S/I, P_d, noisy contacts; targets of different revolutions are
never merged), (3) the noise and sea-clutter false alarms of every revolution of the block, drawn
together and timed when the beam sweeps their azimuths.  The process
then advances sector by sector and, at the end of each sector, publishes one columnar plot
frame and one truth frame holding exactly the plots the beam made in that sector.  The end
of each revolution publishes an end-of-scan frame with the antenna's position and heading,
and the sensor metadata again for late joiners.  Computing ahead changes no time and no
frame boundary of the stream, only the order of the random draws.

Fast mode uses :class:`simpy.Environment`, real-time mode :class:`simpy.rt.RealtimeEnvironment`;
the process code is the same in both (STYLE: SimPy's ``rt`` only overrides ``step()``).  A
fast run with nothing live downstream (no bus, or one that accepts a scan's messages at once,
:class:`shipradar.sim.stream.sink.BatchSink`: :attr:`Simulation.batched`) drives the same
processes on a plain clock that replays SimPy's event order
(:class:`shipradar.sim.engine.order.EventOrder`), and hands the recorder a scan's messages at
once; the bytes are the same.

What the engine asks of its bus is declared in :mod:`shipradar.sim.stream.sink`; the keys of
its messages in :mod:`shipradar.sim.stream.schema`.  The engine gathers values; the stream
shapes the messages from them: which plots go in which sector message in
:func:`shipradar.sim.stream.framing.sector_columns`, and ``meta``, ``eos``,
``truth[sensors]``, ``end`` and ``entities`` from typed records (an antenna's state, a
radar's description, a block's ends of scan) in :mod:`shipradar.sim.stream.payloads`, for a
bus that takes frames and for one that takes payloads alike.
"""

from __future__ import annotations

import bisect
import functools
import itertools
import math
import sys
import time
from collections import deque
from collections.abc import Generator, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import simpy
import simpy.rt

from shipradar.sensors.geometry import K_FACTOR, sweep_time
from shipradar.sim.engine.last_looks import LastLooks
from shipradar.sim.engine.order import EventOrder
from shipradar.sim.engine.plot_blocks import merge_plot_batches, slice_plots
from shipradar.sim.stream import protocol
from shipradar.sim.stream.framing import Slices, sector_columns, target_columns
from shipradar.sim.stream.payloads import (
    AntennaState,
    AntennaStates,
    ClutterFalseAlarmMeta,
    PackedMeta,
    SensorDescription,
    SensorTruthRows,
    end_of_scan_frames,
    end_payload,
    entities_payload,
    eos_payload,
    meta_payload,
    pack_meta,
    truth_sensors_frames,
    truth_sensors_items,
    truth_sensors_payload,
)
from shipradar.sim.stream.sink import (
    CallbackSink,
    FrameSink,
    MessageSink,
    PlotsAheadSink,
    takes_batches,
    takes_frames,
)
from shipradar.sim.world.kinematics import (
    TWO_PI,
    Geometry,
    LocalFrame,
    antenna_azimuth,
    antenna_geometry,
    beam_crossings,
)
from shipradar.sim.world.scenario import Platform, Radar, Scenario
from shipradar.sim.world.traffic import scene_targets
from shipradar.sim.world.trajectory import trajectories

if TYPE_CHECKING:
    from shipradar.sensors.sensor_errors import RadarErrors
    from shipradar.sim.dwell.look import LookResults
    from shipradar.sim.dwell.model import DwellModel
    from shipradar.sim.dwell.prepared import PreparedScene

#: Plot origin codes on the truth topic.
ORIGIN_TARGET, ORIGIN_NOISE, ORIGIN_SEA_CLUTTER = 0, 1, 2
ORIGIN_NAMES = ("target", "noise", "sea_clutter")


@dataclass
class RunStats:
    """Counters of one run; the summary line is built from them."""

    scans: int = 0
    sectors: int = 0
    dwells: int = 0
    target_plots: int = 0
    missed_detections: int = 0
    noise_false_alarms: int = 0
    clutter_false_alarms: int = 0
    merged_targets: int = 0
    by_interference: dict[str, int] = field(default_factory=lambda: {
        "noise": 0, "clutter": 0, "jamming": 0})
    propagation_fallbacks: int = 0


class Simulation:
    """A scenario ready to run.

    Parameters
    ----------
    scenario : the validated scenario
    bus : a :class:`shipradar.sim.stream.sink.MessageSink` (``emit(topic, t_sim, payload)``
        and ``flush()``; e.g. :class:`shipradar.sim.stream.bus.Bus`), or None
    seed : overrides the scenario's seed
    duration_s : overrides the scenario's duration [s]
    realtime : None for as fast as possible, or a speed factor (1 = wall clock, 10 = 10x)
    tables : scene tables (``shipradar.tables.scene.SceneTables``) or None to load what is cached
    progress : show a progress bar on stderr
    processes : run the radars in this many processes (fast mode only;
    ``shipradar.sim.engine.parallel``):
        the same messages in the same order, byte for byte, as one process
    only_radars : indices (in ``scenario.radars()`` order) of the radars to simulate, the
        others left out (a worker of ``shipradar.sim.engine.parallel``); every radar keeps its own
        random stream, so a radar's messages do not depend on which others run beside it
    prepared : what the runs of this scenario on these ``tables`` share
        (:class:`shipradar.sim.dwell.prepared.PreparedScene`: the clutter maps' readers, the
        two-ray fallback, the false-alarm generator, spectrum, density and range profile),
        made from the same scenario and table objects; None: made here (as in a new process).
        A study that runs the scene again passes the previous run's :attr:`prepared`.
    """

    # params: the run's options, keyword-only and each with a default (documented above)
    def __init__(
        self,
        scenario: Scenario,
        *,
        bus: MessageSink | None = None,
        seed: int | None = None,
        duration_s: float | None = None,
        realtime: float | None = None,
        tables: Any = None,
        progress: bool = False,
        processes: int = 1,
        only_radars: Sequence[int] | None = None,
        entities: Any = None,
        prepared: PreparedScene | None = None,
    ) -> None:
        from shipradar.sim.dwell.prepared import PreparedScene
        from shipradar.tables.scene import load_scene_tables

        self.scenario = scenario
        self.bus: MessageSink | None = bus
        self.seed = scenario.seed if seed is None else seed
        self.duration = float(scenario.duration_s if duration_s is None else duration_s)
        self.realtime = realtime
        self.progress = progress
        #: the radars this instance runs, None for all (a parallel worker runs some and leaves
        #: the run's ``end`` message to the parent)
        self.only_radars = only_radars
        self.processes = int(processes)
        if self.processes < 1:
            raise ValueError(f"processes must be >= 1, got {processes}")
        if self.processes > 1 and realtime:
            raise ValueError("processes > 1 is for fast mode (no --realtime)")
        #: index of the radar whose process is running (shipradar.sim.engine.parallel tags messages
        #: with it)
        self.active_radar = 0
        self.stats = RunStats()
        self.frame = LocalFrame(scenario.origin)
        self._scene_objects(scenario, entities)
        self.tables = tables if tables is not None else load_scene_tables(scenario)
        if prepared is None:
            prepared = PreparedScene(scenario, self.tables)
        else:
            prepared.check(scenario, self.tables)
        #: what the runs of this scenario on these tables share
        #: (:class:`shipradar.sim.dwell.prepared.PreparedScene`): pass it to the next run
        self.prepared = prepared
        self.radars: list[RadarProcess] = self._radar_processes(only_radars)
        #: some radar's messages leave late (issue 33): each process waits for its messages'
        #: publication times, the run lasts until the last has left (SimPy or the batched
        #: path; one process)
        self.latency = any(r.errors is not None and r.errors.has_latency for r in self.radars)
        #: the latest publication time of any message [s] (the run's end without latency)
        self.last_publication = 0.0

    def _radar_processes(self, only_radars: Sequence[int] | None) -> list[RadarProcess]:
        """A :class:`RadarProcess` per radar run (``only_radars``: those indices), each with
        its dwell model on its preparation and its own random stream."""
        from shipradar.sim.dwell.model import DwellModel  # the on-line radar model

        scenario = self.scenario
        seeds = np.random.SeedSequence(self.seed).spawn(len(scenario.radars()))
        out: list[RadarProcess] = []
        for k, (platform, radar) in enumerate(scenario.radars()):
            if only_radars is not None and k not in only_radars:
                continue
            p_index = scenario.platforms.index(platform)
            model = DwellModel(scenario, platform, radar, self.tables, self.target_set,
                               self.prepared.radar(platform, radar))
            rng = np.random.default_rng(seeds[k])
            process = RadarProcess(self, p_index, platform, radar, model, rng)
            if scenario.has_sensor_errors:  # issue 33: own streams, none drawn otherwise
                from shipradar.sensors.sensor_errors import RadarErrors

                process.errors = RadarErrors(
                    radar.errors, platform.navigation, seed=self.seed, radar_id=radar.id,
                    platform_id=platform.id, sector_s=process.sector_s)
            process.index = k
            out.append(process)
        return out

    def _scene_objects(self, scenario: Scenario, entities: Any) -> None:
        """The run's moving objects in its local frame (:attr:`frame`): the targets (the
        scenario's own and its traffic files', :mod:`shipradar.sim.world.traffic`, or the
        entities of a live source, :mod:`shipradar.sim.world.live`: a list that grows), the
        platforms (riding on live entities with ``platforms[].dis_entity``) and the jammers;
        waypoints, segments or rounded corners as analytic pieces
        (:mod:`shipradar.sim.world.trajectory`)."""
        #: the live source of entity states (shipradar.sim.stream.entities), None without
        self.live_source = entities
        self._live_refreshed = -math.inf
        self.target_set: Any
        if entities is not None:
            from shipradar.sim.world.live import LiveTargets

            if self.processes > 1:
                raise ValueError("processes > 1 is not for a live source (--entities)")
            self.target_set = LiveTargets(scenario)
        else:
            self.target_set = scene_targets(scenario)
        self.targets = self.target_set.trajectories(self.frame)
        self.platforms: Any = trajectories(scenario.platforms, self.frame, hold=True)
        #: the entities the platforms ride on (``platforms[].dis_entity``), None without
        self.ridden = None
        riders = {i: p.dis_entity for i, p in enumerate(scenario.platforms) if p.dis_entity}
        if riders and entities is not None:
            from shipradar.sim.world.live import LiveTargets, RiddenPlatforms

            self.ridden = LiveTargets(scenario)
            self.platforms = RiddenPlatforms(self.platforms, self.ridden, riders)
        self.jammers = trajectories(scenario.jammers, self.frame, hold=True)

    # ------------------------------------------------------------------ running
    def _environment(self) -> simpy.Environment:
        env: simpy.Environment
        if self.realtime:
            env = simpy.rt.RealtimeEnvironment(factor=1.0 / self.realtime, strict=False)
        else:
            env = simpy.Environment()
        self._processes = [env.process(r.run(env)) for r in self.radars]
        if self.live_source is not None and hasattr(self.live_source, "wait_while_frozen"):
            env.process(self._simulation_management(env))
        return env

    def _simulation_management(self, env: simpy.Environment) -> Generator[Any, Any, None]:
        """A DIS simulation manager's Stop/Freeze holds the run's clock until Start/Resume
        (shipradar.sim.adapters.dis): looked at every tenth of a second; after a freeze the
        wall clock is taken again where it stopped (no catching up)."""
        source = self.live_source
        while True:
            yield env.timeout(0.1)
            waited = source.wait_while_frozen()
            if waited > 0.0 and isinstance(env, simpy.rt.RealtimeEnvironment):
                # the wall clock's origin moved on by the freeze (SimPy's sync() would also
                # replay the time already run)
                env.real_start += waited

    def run(self) -> dict[str, Any]:
        """Run to the end; returns the summary (the JSON line ``shipradar run`` prints)."""
        if self.processes > 1 and len(self.radars) > 1 and not self.latency:
            from shipradar.sim.engine.parallel import run_parallel

            out = run_parallel(self)
            self._emit_end()
            return out
        batched = self.batched
        if self.live_source is not None and hasattr(self.live_source, "wait_for_start"):
            # DIS --dis-wait-start: the simulation manager's Start/Resume starts the clock
            self.live_source.wait_for_start()
        env = None if batched else self._environment()
        bar = None
        if self.progress:
            from tqdm import tqdm

            bar = tqdm(total=round(self.duration), unit="sim s", file=sys.stderr, leave=False)
            if env is not None:
                env.process(self._progress(env, bar))
        wall0 = time.perf_counter()
        if env is None:
            self._run_batched(bar)
        else:
            env.run(until=self._until(env))
        wall = time.perf_counter() - wall0
        for r in self.radars:
            r.release()
        if bar is not None:
            bar.close()
        self._emit_end()
        return self.summary(wall)

    def _until(self, env: simpy.Environment) -> Any:
        """Where a SimPy run stops: the run's duration, or with latency (issue 33) when every
        radar's last message has left."""
        if self.latency:
            return env.all_of(self._processes)
        return self.duration + 1e-9

    def _emit_end(self) -> None:
        """The run's last message, ``end`` (after every radar's last ``eos`` and
        ``truth``), and the bus flushed; not from a worker that runs some radars only."""
        if self.bus is None:
            return
        if self.only_radars is None:
            self.bus.emit(protocol.TOPIC_END, max(self.duration, self.last_publication),
                          self._end_payload())
        self.bus.flush()

    def _end_payload(self) -> dict[str, Any]:
        return end_payload(self.duration, [r.radar.id for r in self.radars],
                           [r.scans_in_run for r in self.radars])

    @property
    def batched(self) -> bool:
        """True when :meth:`run` takes the batched fast path (:meth:`_run_batched`): fast
        mode (no ``realtime``) and nothing live downstream, i.e. no bus, or a bus that accepts
        a scan's messages at once (:func:`shipradar.sim.stream.sink.takes_batches`: a
        :class:`shipradar.sim.stream.bus.Bus` without a publisher, recording only).  A
        publisher (a live subscriber gets each message as it leaves: per sector, or for a
        radar alone in fast mode per revolution), the ASTERIX bus, in-process sinks, test
        doubles and the wall-clock modes keep SimPy's event loop."""
        if self.realtime:
            return False
        return self.bus is None or takes_batches(self.bus)

    def _run_batched(self, bar: Any = None) -> None:
        """Run the radars' processes (:meth:`RadarProcess.run`, the same code as under
        SimPy) on a plain clock, and hand the recording a scan's messages at once.

        The processes resume in SimPy's own order (:class:`shipradar.sim.engine.order.EventOrder`:
        started in radar order, each resumption scheduling the next at ``now + delay``,
        nothing at or after ``duration + 1e-9``); so the radars' messages interleave exactly
        as under :class:`simpy.Environment` (``tests/test_engine_batched.py``); a radar that
        runs alone resumes once per revolution (nothing to interleave with,
        ``tests/test_engine_scan_ends.py``).  The messages go to a :class:`_BatchingBus`
        that passes them on to the run's bus at each end of scan (the flush the engine does
        there), in one :meth:`shipradar.sim.stream.bus.Bus.emit_many`.
        """
        real = self.bus
        batch = _BatchingBus(real) if real is not None else None
        clock = _FastClock()
        # alone, a radar's resumptions order nothing but its own messages: one per revolution
        procs = [r.run(clock, per_sector=len(self.radars) > 1 or self.latency)
                 for r in self.radars]
        order = EventOrder(len(procs))
        # with latency the processes end after their last message has left (issue 33)
        until = math.inf if self.latency else self.duration + 1e-9
        step = max(self.duration / 200.0, 0.5)
        next_bar = step
        self.bus = batch
        try:
            for i, t in order.resumptions(until):
                clock.now = t
                try:
                    delay = next(procs[i])
                except StopIteration:
                    continue
                order.schedule(i, t + delay)
                if bar is not None and t >= next_bar:
                    bar.n = min(round(t), bar.total)
                    bar.refresh()
                    next_bar = t + step
            if bar is not None:  # the run reached its end, which is not a resumption of a
                bar.n = bar.total  # radar that resumes once per revolution
                bar.refresh()
            if batch is not None:
                batch.hand_on()
        except BaseException:
            if batch is not None and batch.pending:  # what was emitted reaches the bus
                try:
                    batch.hand_on()
                except Exception:
                    pass
            raise
        finally:
            self.bus = real

    def messages(self, step_s: float | None = None) -> Iterator[tuple[str, float, dict]]:
        """Run in process and yield every message as ``(topic, t_sim, payload)``, in the
        stream's order, with no sockets and no recording.

        The clock advances ``step_s`` simulated seconds at a time (default: the shortest
        scan period) and the messages of each step are yielded before the next is computed,
        so a consumer that stops early stops the run. Any ``bus`` given at construction is
        bypassed. ``summary(wall_s)`` gives the counts once the iterator is exhausted.

        Parameters
        ----------
        step_s : float, optional
            Simulated time per step [s], > 0.
        """
        step = step_s or min(r.radar.scan_period_s for r in self.radars)
        if not step > 0:
            raise ValueError(f"step_s must be > 0, got {step_s}")
        pending: deque[tuple[str, float, dict]] = deque()
        self.bus = CallbackSink(lambda topic, t, payload: pending.append((topic, t, payload)))
        env = self._environment()
        t = 0.0
        while t < self.duration:
            t = min(t + step, self.duration)
            env.run(until=t + 1e-9 if t >= self.duration else t)
            while pending:
                yield pending.popleft()
        if self.latency:  # the messages still on their way (issue 33)
            env.run(until=self._until(env))
            while pending:
                yield pending.popleft()
        yield (protocol.TOPIC_END.decode(), max(self.duration, self.last_publication),
               self._end_payload())

    def _progress(self, env: simpy.Environment, bar: Any) -> Generator[Any, Any, None]:
        step = max(self.duration / 200.0, 0.5)
        while True:
            yield env.timeout(step)
            bar.n = min(round(env.now), bar.total)
            bar.refresh()

    def refresh_live(self, now: float) -> None:
        """Take the live source's entity states that arrived up to ``now`` [s] (once per
        time, whichever radar asks first): checked, applied to the target list
        (:class:`shipradar.sim.world.live.LiveTargets`), and those applied sent as one
        ``entities`` message at ``now`` (the recording keeps what the run used)."""
        if self.live_source is None or now <= self._live_refreshed:
            return
        from shipradar.sim.world.live import check_states, take_rows

        self._live_refreshed = now
        live = self.target_set
        ridden = self.ridden
        riders = set(self.platforms.riders.values()) if ridden is not None else set()
        used = []
        for payload in self.live_source.drain(now):
            rows = check_states(payload, live.bad)
            if rows is None or not rows["id"]:
                continue
            parts = [(live, rows)]
            if ridden is not None:  # the platforms' own entities are not targets
                own = np.array([i in riders for i in rows["id"]], dtype=np.bool_)
                if own.any():
                    parts = [(live, take_rows(rows, ~own)), (ridden, take_rows(rows, own))]
            for store, part in parts:
                if part["id"]:
                    applied = store.apply(part, now)
                    if applied["id"]:
                        used.append(applied)
        if used and self.bus is not None:
            self.bus.emit(protocol.TOPIC_ENTITIES, now, entities_payload(used))

    def summary(self, wall_s: float) -> dict[str, Any]:
        s = self.stats
        out = {
            "scenario": self.scenario.name,
            "seed": self.seed,
            "scans": s.scans,
            "sectors": s.sectors,
            "dwells": s.dwells,
            "target_plots": s.target_plots,
            "missed_detections": s.missed_detections,
            "merged_targets": s.merged_targets,
            "noise_false_alarms": s.noise_false_alarms,
            "clutter_false_alarms": s.clutter_false_alarms,
            "dominant_interference": dict(s.by_interference),
            "propagation_fallbacks": s.propagation_fallbacks,
            "simulated_s": round(self.duration, 6),
            "wall_s": round(wall_s, 4),
            "realtime_factor": round(self.duration / wall_s, 2) if wall_s > 0 else None,
        }
        ts = self.target_set
        if self.live_source is not None:  # the live source and what it gave
            out["live"] = {**ts.summary(), "source": self.live_source.stats()}
        elif ts.files:  # what the traffic files gave (shipradar.sim.world.traffic)
            out["traffic"] = {"targets": ts.from_files, "rows": ts.traffic_rows,
                              "left_out": dict(sorted(ts.dropped.items()))}
        if self.bus is not None and hasattr(self.bus, "stats"):
            out["bus"] = self.bus.stats
        return out

    def emit(self, topic: bytes, t: float, payload: dict) -> None:
        if self.bus is not None:
            self.bus.emit(topic, t, payload)

    @property
    def encodes_ahead(self) -> bool:
        """True when the bus takes encoded frames (:func:`shipradar.sim.stream.sink.takes_frames`:
        a :class:`shipradar.sim.stream.bus.Bus`, the ASTERIX bus over one): the sector frames
        of a block of revolutions are then encoded together
        (:meth:`shipradar.sim.stream.framing.Slices.encode`, the same bytes) and the metadata
        from items packed once.  Other buses (the in-process
        :class:`shipradar.sim.stream.sink.CallbackSink`, test doubles) get each payload as a
        dict."""
        return takes_frames(self.bus)


class _Clock(Protocol):
    """What :meth:`RadarProcess.run` asks of its clock: a :class:`simpy.Environment`, or the
    batched path's :class:`_FastClock`."""

    @property
    def now(self) -> float: ...

    def timeout(self, delay: float, /) -> Any: ...


def _is_plain_bus(bus: Any) -> bool:
    """True for the stream's own :class:`shipradar.sim.stream.bus.Bus` (recording and/or
    publisher; not a subclass, an in-process sink or a test double)."""
    from shipradar.sim.stream.bus import Bus

    return type(bus) is Bus


class _FastClock:
    """What :meth:`RadarProcess.run` asks of a SimPy environment (``now``, ``timeout``),
    for :meth:`Simulation._run_batched`: a timeout is its delay, the loop does the rest."""

    __slots__ = ("now",)

    def __init__(self) -> None:
        self.now = 0.0

    @staticmethod
    def timeout(delay: float) -> float:
        return delay


class _BatchingBus:
    """The run's :class:`shipradar.sim.stream.bus.Bus` as the engine sees it on the batched fast
    path: the
    messages (encoded as ``Bus.emit`` encodes them) are kept until the end of scan's flush,
    then passed on in one :meth:`shipradar.sim.stream.bus.Bus.emit_many`, and the bus flushed."""

    encodes_ahead = True

    def __init__(self, bus: Any) -> None:
        self.bus = bus
        self.pending: list[tuple[float, Sequence[bytes]]] = []

    def emit(self, topic: bytes, t_sim: float, payload: Mapping[str, Any]) -> None:
        self.pending.append((t_sim, protocol.encode(topic, t_sim, payload)))

    def emit_frames(self, t_sim: float, frames: Sequence[bytes]) -> None:
        self.pending.append((t_sim, frames))

    def hand_on(self) -> None:
        """Pass what is pending on to the run's bus, in one ``emit_many``."""
        pending, self.pending = self.pending, []
        self.bus.emit_many(pending)

    def flush(self, fsync: bool = False) -> None:
        self.hand_on()
        self.bus.flush(fsync)


class RadarProcess:
    """One rotating radar: sector events, beam crossings, false alarms, frames.

    Public (issue 31): :attr:`Simulation.radars` lists them, and a study observes a radar's
    looks or sets its common random numbers through its :attr:`model`'s public, typed
    ``on_look`` and ``look_uniforms`` before the run.
    """

    def __init__(self, sim: Simulation, p_index: int, platform: Platform, radar: Radar,
                 model: DwellModel, rng: np.random.Generator):
        self.sim = sim
        self.p_index = p_index
        self.platform = platform
        self.radar = radar
        self.model = model
        self.rng = rng
        self.omega = TWO_PI / radar.scan_period_s
        self.beam0 = math.radians(radar.start_azimuth_deg)
        self.n_sectors = sim.scenario.fidelity.sectors_per_scan
        self.sector_s = radar.scan_period_s / self.n_sectors
        self.plot_counter = 0
        # a real sensor does not tell its errors (issue 33: truth[sensors] does)
        self._radar_dump = radar.model_dump(mode="json", exclude={"errors"})
        #: its errors and its platform's navigation's (issue 33), None in a scene without
        self.errors: RadarErrors | None = None
        # the true times of the block's plots when errors changed their time stamps (the
        # sectors hold the plots the beam made in them)
        self._block_true_t: np.ndarray | None = None
        # the latency of the current scan's last sector message [s] (truth[sensors]), NaN
        # before any
        self._scan_latency = math.nan
        # when this radar's link is free [s]: its last message's publication (issue 33's
        # latency; a message never overtakes the one before it)
        self._link_free = 0.0
        self._meta_items: PackedMeta | None = None
        # what the bus takes (_bus_caps), found once per bus: a runtime-checkable protocol's
        # isinstance costs ~20 us, once per sector it was half of a sparse recorded run
        self._caps_of: tuple[object, FrameSink | None, PlotsAheadSink | None] = (
            object(), None, None)
        # the end of the last scan: (time [s], platform position, velocity, lat, lon), which
        # is the next scan's start (its meta's antenna state)
        self._last_eos: tuple[float, np.ndarray, np.ndarray, float, float] | None = None
        # the next scan's meta items of scan and antenna state, packed with the last end of
        # scan's eos (_frame_ends), for a bus that takes frames
        self._next_meta: tuple[float, bytes] | None = None
        #: position in scenario.radars(); env.now at each resumption of run() (the order of
        #: the messages between radars in shipradar.sim.engine.parallel), kept only in a parallel
        #: worker: one float per sector would grow with the run (≈5 MB per simulated hour of the
        #: raid)
        self.index = 0
        self.resume_times: list[float] | None = None
        self.target_ids = list(sim.target_set.ids)
        # the ends of the revolutions computed ahead (_scan_end_states)
        self._ends: _ScanEnds | None = None
        # the looks of the revolutions computed ahead (_on_look), folded into the last look
        # of each target at each end of scan for truth[targets]
        self._looks = LastLooks(len(self.target_ids))
        self._block_scan0 = 0
        model.on_look.append(self._on_look)
        # revolutions computed ahead (see _compute_block), consumed one per scan: the rows
        # of each in the block's plots (_block_plots)
        self._block: list[tuple[int, int]] = []
        self._block_plots: tuple[int, dict, list[int]] | None = None
        self._block_frames: list[_Revolution] | None = None
        # a block's false alarms are held at once: fewer revolutions when a scan has many
        clutter = self._clutter_false_alarms
        expected = model.noise_false_alarms_per_scan + (0.0 if clutter is None
                                                        else clutter.per_scan)
        self.scans_per_block = max(1, min(int(_BLOCK_S // radar.scan_period_s),
                                          int(_BLOCK_PLOTS // max(expected, 1.0))))
        if sim.live_source is not None:  # the entities known at each revolution's start
            self.scans_per_block = 1
        # a ship whose velocity changes (several legs, turns): the clutter spectrum's platform
        # terms [33]-[38] follow its instantaneous velocity, not the tables' first leg
        plat = sim.platforms
        self._platform_manoeuvres = bool(plat.count[p_index] > 1 or not plat.linear)

    def release(self) -> None:
        """Drop the revolutions computed ahead (a block's plots: up to :data:`_BLOCK_S` of
        simulated time) once the run is over."""
        self._block = []
        self._block_plots = self._block_frames = None
        self._ends = None
        self._last_eos = self._next_meta = None
        self._looks.clear()

    # ------------------------------------------------------------------ helpers
    def _bus_caps(self) -> tuple[FrameSink | None, PlotsAheadSink | None]:
        """The run's bus if it takes frames (:func:`shipradar.sim.stream.sink.takes_frames`)
        and if it wants plots ahead (:class:`shipradar.sim.stream.sink.PlotsAheadSink`), else
        None; checked again only when ``sim.bus`` is another object."""
        bus = self.sim.bus
        seen, frames, ahead = self._caps_of
        if bus is not seen:
            frames = bus if takes_frames(bus) else None
            ahead = bus if isinstance(bus, PlotsAheadSink) else None
            self._caps_of = (bus, frames, ahead)
        return frames, ahead

    def beam_azimuth(self, t: Any) -> Any:
        """Beam azimuth at times ``t`` [rad], true north (scalar or array)."""
        return (self.beam0 + self.omega * t) % TWO_PI

    def sector_end(self, k: Any) -> Any:
        """End of sector(s) ``k`` (counted from the start of the run, an int or an int array)
        [s]: (k + 1) sector_s, the run's end at the latest; the same number the process loop
        computes."""
        return np.minimum((np.asarray(k) + 1) * self.sector_s, self.sim.duration)

    def platform_state(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rows = np.full(np.shape(t), self.p_index, dtype=int)
        pos, vel, _ = self.sim.platforms.state(t, rows)
        return pos, vel

    def geometry(self, t: np.ndarray, rows: np.ndarray
                 ) -> tuple[Geometry, np.ndarray, np.ndarray]:
        """Antenna-to-target geometry for targets ``rows`` each at its own time ``t``."""
        tpos, tvel, active = self.sim.targets.state(t, rows)
        ppos, pvel = self.platform_state(t)
        geom = antenna_geometry(ppos, pvel, self.radar.antenna_height_m, tpos, tvel,
                                self.sim.frame)
        return geom, active, tpos

    def jammer_geometry(self, t: Any, ppos: np.ndarray | None = None,
                        pvel: np.ndarray | None = None
                        ) -> tuple[Geometry, np.ndarray, np.ndarray] | None:
        """Geometry from the antenna to every jammer at each time of ``t`` (N,) [s], the
        jammers' positions (N M, 3) and the antenna's east/north (N M, 2), look after look,
        jammer after jammer (the layout
        :meth:`shipradar.sim.dwell.model.DwellModel.jamming_power` reads); None
        without jammers.  ``ppos``, ``pvel`` (N, 3): the platform's state at those times, when
        the caller has it.

        Each look sees the jammers where they are at its own time: at 6 rpm a 250 m/s jammer
        crossing at 20 km moves 3.6° in half a revolution, which is the whole main beam.
        """
        jam = self.sim.jammers
        if jam.n == 0:
            return None
        t = np.atleast_1d(np.asarray(t, dtype=float))
        jpos, jvel, _ = jam.state(np.repeat(t, jam.n), np.tile(np.arange(jam.n), t.size))
        if ppos is None or pvel is None:
            ppos, pvel = self.platform_state(t)
        ppos, pvel = np.repeat(ppos, jam.n, axis=0), np.repeat(pvel, jam.n, axis=0)
        geom = antenna_geometry(ppos, pvel, self.radar.antenna_height_m, jpos, jvel,
                                self.sim.frame)
        return geom, jpos, ppos[:, :2]

    @property
    def scans_in_run(self) -> int:
        """Scans the run gives this radar (``eos`` messages): those that start before its
        end, as :meth:`run` counts them (also in the parent of a parallel run, whose own
        processes do not run)."""
        period = self.n_sectors * self.sector_s
        s = max(int(math.ceil(self.sim.duration / period)), 0)
        while s > 0 and (s - 1) * self.n_sectors * self.sector_s >= self.sim.duration:
            s -= 1
        while s * self.n_sectors * self.sector_s < self.sim.duration:
            s += 1
        return s

    def _on_look(self, look: LookResults) -> None:
        """Keep a call's looks with their revolutions (the dwell model's ``on_look``: the
        engine's own observer), for the last look of each target in ``truth[targets]``."""
        rev = (np.zeros(look.size, np.int64) if look.batch is None
               else np.asarray(look.batch, np.int64)) + self._block_scan0
        self._looks.add(rev, look.target, look.time_s, look.pd, look.si_db, look.interference)

    def antenna_state(self, t: float, pos: np.ndarray | None = None,
                      vel: np.ndarray | None = None, lat: float | None = None,
                      lon: float | None = None) -> AntennaState:
        """The antenna's position, velocity and heading at time ``t`` [s], as ``meta`` (scan
        start) and ``eos`` (scan end) report them (navigated, issue 33); the platform's
        state and geodetic position are computed unless given."""
        if pos is None or vel is None:
            p, v = self.platform_state(np.array([t]))
            pos, vel = p[0], v[0]
            if self.errors is not None and self.errors.navigates:  # as navigated (issue 33)
                pos = pos + self.errors.navigation_offset(np.array([t]))[0]
                lat = lon = None
        if lat is None or lon is None:
            la, lo, _ = self.sim.frame.geodetic(pos[None, :])
            lat, lon = float(la[0]), float(lo[0])
        heading = self._heading(float(vel[0]), float(vel[1]), t)
        if self.errors is not None and self.errors.navigates:
            heading = (heading + math.degrees(float(self.errors.heading_bias_rad(t)))) % 360.0
        return AntennaState(lat, lon, float(pos[0]), float(pos[1]),
                            float(pos[2] + self.radar.antenna_height_m),
                            (float(vel[0]), float(vel[1]), float(vel[2])), heading)

    def _heading(self, v_east: float, v_north: float, t: float | None = None) -> float:
        """The platform's heading [deg] from its velocity east and north [m/s], true north,
        clockwise; the scenario's heading when it stands still; a platform riding on a DIS
        entity (``dis_entity``) has its entity's heading at ``t`` [s] when the PDUs gave one."""
        if self.sim.ridden is not None and t is not None:
            h = self.sim.platforms.heading_deg(self.p_index, t)
            if h is not None:
                return h
        if math.hypot(v_east, v_north) > 0:
            return math.degrees(math.atan2(v_east, v_north)) % 360.0
        return self.platform.heading_deg

    def _antenna_states(self, ends: _ScanEnds) -> AntennaStates:
        """:meth:`antenna_state` at every end of ``ends``, as columns (element by element the
        same numbers)."""
        pos, vel = ends.pos, ends.vel
        heading = [self._heading(e, n, tt) for (e, n), tt in zip(vel[:, :2].tolist(), ends.t,
                                                                 strict=True)]
        if self.errors is not None and self.errors.navigates:  # the gyro's bias (issue 33)
            bias = np.degrees(self.errors.heading_bias_rad(np.asarray(ends.t)))
            heading = np.mod(np.asarray(heading) + bias, 360.0).tolist()
        return AntennaStates(np.asarray(ends.lat), np.asarray(ends.lon), pos[:, 0], pos[:, 1],
                             pos[:, 2] + self.radar.antenna_height_m, vel,
                             np.asarray(heading))

    # ------------------------------------------------------------------ process
    def run(self, env: _Clock, per_sector: bool = True) -> Generator[Any, Any, None]:
        """The radar's process, one revolution after another: it resumes at the end of every
        sector (``per_sector``, :meth:`_revolution_by_sector`), or only at the end of every
        revolution, its sectors' messages sent in order at that resumption
        (:meth:`_revolution_at_once`): for a radar that runs alone on the batched path
        (:meth:`Simulation._run_batched`), where the resumptions order nothing but its own
        messages, and every message carries its own time; likewise alone in fast mode with
        the stream's own bus (a publisher: nothing reads the clock between its messages).
        Alone under a wall clock or with another sink, it resumes at the end of every sector
        that sends a message and of every revolution: its messages leave at the same
        simulated (and wall) times."""
        sim = self.sim
        sim.active_radar = self.index
        if self.resume_times is not None:
            self.resume_times.append(env.now)
        self._live_update(0.0)
        t_at = self._leaves(0.0)
        if t_at > env.now:  # latency (issue 33)
            yield env.timeout(t_at - env.now)
        self._emit_meta(0.0, scan=0, t_at=t_at)
        # alone under SimPy (a publisher, a wall clock), a resumption orders nothing but
        # this radar's own messages: the end of a sector that sends none is not waited for
        # (a worker of a parallel run keeps every one: its resumption times order the
        # radars' messages in the parent)
        alone = len(sim.radars) == 1 and self.resume_times is None
        if per_sector and alone and not sim.realtime and _is_plain_bus(sim.bus) \
                and not sim.latency:
            # alone in fast mode, with the stream's own bus (a publisher): nothing reads the
            # clock between its messages (no wall clock, no in-process sink, no other
            # process's messages to interleave), and each message carries its own time, so
            # the revolution's messages leave in order at its end, as on the batched path
            # (the block's messages are made at once before any leaves, either way)
            per_sector = False
        k = 0  # sectors since the start: sector k is [k, k + 1) sector_s
        for scan in itertools.count():
            if k * self.sector_s >= sim.duration:
                return
            if scan > 0:
                self._live_update(k * self.sector_s)
                t_at = self._leaves(k * self.sector_s)
                if t_at > env.now:  # latency: after the eos it follows (issue 33)
                    yield env.timeout(t_at - env.now)
                self._emit_meta(k * self.sector_s, scan, t_at=t_at)
            rev = self._next_revolution(scan)
            if per_sector:
                k = yield from self._revolution_by_sector(env, scan, k, rev, alone)
            else:
                k = yield from self._revolution_at_once(env, scan, k, rev)

    def _next_revolution(self, scan: int) -> _Revolution | None:
        """Revolution ``scan``'s messages, from the current block (the next block computed
        and framed when this one is used up; None without a bus); its CAT048 handed to an
        ASTERIX bus ahead."""
        sim = self.sim
        if not self._block:
            self._block = self._compute_block(scan)
            self._block_frames = self._frame_block() if sim.bus is not None else None
        rows = self._block.pop(0)
        rev = self._block_frames.pop(0) if self._block_frames is not None else None
        if rev is not None and rev.encoded and rev.sectors:
            ahead = self._bus_caps()[1]
            if ahead is not None:  # ASTERIX: CAT048 ahead
                assert self._block_plots is not None
                ahead.plots_ahead(self.radar.id, rev.plots,
                                  slice_plots(self._block_plots[1], *rows), rev.starts,
                                  rev.stops)
        return rev

    def _revolution_at_once(self, env: _Clock, scan: int, k: int, rev: _Revolution | None
                            ) -> Generator[Any, Any, int]:
        """One revolution from sector ``k`` on, with one resumption at its end (the run's end
        at the latest), where its sectors' messages leave in order, each at its own time.
        Returns the next revolution's first sector."""
        n, sector_s, duration = self.n_sectors, self.sector_s, self.sim.duration
        reached = n
        t_end = (k + n) * sector_s
        if t_end >= duration:  # the run ends in this revolution: t_b ≥ duration
            reached = next(s for s in range(1, n + 1) if (k + s) * sector_s >= duration)
            t_end = duration
        yield env.timeout(t_end - env.now)
        self._scan_latency = math.nan
        if rev is not None:
            count = bisect.bisect_left(rev.sectors, reached)
            self._send_sectors(rev, count)
            if count:
                self._scan_latency = 0.0
        self.sim.stats.sectors += reached
        self._end_of_scan(t_end, scan)
        return k + reached

    def _revolution_by_sector(self, env: _Clock, scan: int, k: int, rev: _Revolution | None,
                              alone: bool) -> Generator[Any, Any, int]:
        """One revolution from sector ``k`` on, resuming at the end of each sector (``alone``:
        of each sector that sends a message, and of the revolution), where that sector's
        messages leave.  Returns the next revolution's first sector."""
        sim = self.sim
        n, sector_s, duration, stats = self.n_sectors, self.sector_s, sim.duration, sim.stats
        resumes = self.resume_times
        i = 0  # the revolution's next message
        # its frames straight to a bus that takes them (what _send_sector does, without
        # its checks per sector); the batched path's list through _send_sector
        emit = None
        if rev is not None and rev.encoded and type(sim.bus) is not _BatchingBus:
            frames = self._bus_caps()[0]
            emit = frames.emit_frames if frames is not None else None
        plots_topic, truth_topic = protocol.TOPIC_PLOTS, protocol.TOPIC_TRUTH
        self._scan_latency = math.nan
        # with latency (issue 33) a sector without a message is not waited for either: each
        # resumption is a message's publication (the end of scan's, at the last sector)
        skip = alone or sim.latency
        for sector in range(n):
            if k * sector_s >= duration:
                break
            t_b = (k + 1) * sector_s
            if t_b > duration:
                t_b = duration
            has_msg = rev is not None and i < len(rev.sectors) and rev.sectors[i] == sector
            if skip and t_b < duration and sector < n - 1 and not has_msg:
                stats.sectors += 1  # nothing to send: its end is not waited for
                k += 1
                continue
            if not sim.latency:
                t_at = t_b
            elif has_msg:  # framed at its publication time (_publication_times)
                assert rev is not None
                t_at = self._link_free = rev.pub[i]
                if t_at > sim.last_publication:
                    sim.last_publication = t_at
            else:  # the end of scan's
                t_at = self._leaves(t_b)
            yield env.timeout(t_at - env.now)
            sim.active_radar = self.index
            if resumes is not None:
                resumes.append(env.now)
            if has_msg:
                assert rev is not None
                plots, truth = rev.plots[i], rev.truth[i]
                self._scan_latency = t_at - t_b
                if emit is not None:
                    self.plot_counter += rev.rows[i]
                    emit(t_at, [plots_topic, plots])
                    emit(t_at, [truth_topic, truth])
                else:
                    self._send_sector(t_at, rev.rows[i], plots, truth)
                i += 1
            stats.sectors += 1
            k += 1
            if sector == n - 1 or t_b >= duration:
                self._end_of_scan(t_b, scan, t_at=self._leaves(t_b))
        return k

    def _leaves(self, t: float) -> float:
        """When a ``meta``, ``eos`` or their truth made at ``t`` [s] leaves this radar (issue
        33's latency): after the fixed delay, never before the message ahead of it on the link
        (a sector's ``plots`` leave as :meth:`_publication_times` planned); ``t`` without
        latency."""
        errors = self.errors
        if errors is None or not errors.has_latency:
            return t
        t_at = max(self._link_free, t + errors.latency_fixed_s)
        self._link_free = t_at
        if t_at > self.sim.last_publication:
            self.sim.last_publication = t_at
        return t_at

    def _live_update(self, t: float) -> None:
        """At a revolution's start ``t`` [s] with a live source: the entity states that
        arrived (:meth:`Simulation.refresh_live`), and this radar's per-target state grown to
        the new entities (target ids, last looks, the dwell model's RCS and Swerling)."""
        sim = self.sim
        if sim.live_source is None:
            return
        sim.refresh_live(t)
        n, old = sim.targets.n, len(self.target_ids)
        if n <= old:
            return
        self.target_ids.extend(sim.target_set.ids[old:n])
        self._looks.grow(n - old)
        self.model.refresh_targets()
        self._meta_items = None  # target_ids and target_names changed
        self.__dict__.pop("_target_names", None)

    @functools.cached_property
    def _target_names(self) -> list[str] | None:
        """``meta.target_names`` when traffic files or a live source name their targets
        (vessel names, callsigns); None for a scene of its own targets only (their names are
        their ids)."""
        targets = self.sim.target_set
        live = self.sim.live_source is not None
        return list(targets.names) if targets.files or live else None

    @functools.cached_property
    def _clutter_false_alarms(self) -> ClutterFalseAlarmMeta | None:
        """The radar's expected sea-clutter false alarms per scan, total, per 250 m ring and
        per (ring, sector) cell (seed 7.2, from its P_fac map), for a tracker's clutter
        density (``meta``); None without a map."""
        profile = self.model.prepared.clutter_range_profile  # shared by the runs on its map
        if profile is None:
            return None
        edges, per_scan, total = profile
        return ClutterFalseAlarmMeta(total, edges, per_scan,
                                     self.model.false_alarms.clutter_false_alarm_density())

    def _emit_meta(self, t: float, scan: int, t_at: float | None = None) -> None:
        """The sensor metadata of revolution ``scan``, starting at time ``t``, with the
        antenna's state at ``t`` (:meth:`antenna_state`).  To a bus that takes frames
        (:func:`shipradar.sim.stream.sink.takes_frames`) it goes packed from the items
        packed once (only ``scan`` and the antenna's state change;
        :func:`shipradar.sim.stream.protocol.encode_items`, the same bytes as encoding the
        payload); other buses get the payload."""
        sim = self.sim
        bus = sim.bus
        if bus is None:
            return
        at = t if t_at is None else t_at  # it leaves late with latency (issue 33)
        frames = self._bus_caps()[0]
        packed = self._next_meta
        if frames is not None and self._meta_items is not None and packed is not None \
                and packed[0] == t:  # packed with the previous scan's end (_frame_ends)
            frames.emit_frames(at, self._meta_items.encode(at, packed[1]))
            return
        last = self._last_eos
        if last is not None and last[0] == t:  # the previous scan's end: its state
            state = self.antenna_state(t, *last[1:])
        else:
            state = self.antenna_state(t)
        if frames is not None:
            if self._meta_items is None:  # what does not change, packed once
                self._meta_items = pack_meta(self._description(), scan, state)
            frames.emit_frames(at, self._meta_items.encode(at, PackedMeta.scan_state(scan,
                                                                                     state)))
        else:
            bus.emit(protocol.TOPIC_META, at, meta_payload(self._description(), scan, state))

    def _description(self) -> SensorDescription:
        """What ``meta`` says of this radar besides the scan and the antenna's state."""
        r, model, scenario = self.radar, self.model, self.sim.scenario
        return SensorDescription(
            sensor=r.id, platform=self.platform.id, radar=self._radar_dump,
            scan_period_s=r.scan_period_s, sectors_per_scan=self.n_sectors,
            sector_s=self.sector_s, pfa=model.pfa,
            noise_false_alarms_per_scan=model.noise_false_alarms_per_scan,
            clutter=self._clutter_false_alarms,
            target_ids=self.target_ids, target_names=self._target_names,
            origin_codes=ORIGIN_NAMES, interference_codes=model.INTERFERENCE_NAMES,
            origin=scenario.origin.model_dump(), start_time=scenario.start_time.isoformat(),
            # for ASTERIX output (sim/adapters/asterix): the data source and the noise floor
            # that turns a plot's S/I into an amplitude (I048/130 PAM)
            sac_sic=scenario.asterix_sources()[r.id],
            noise_power_dbm=10.0 * math.log10(model.n0 * 1e3),
            # the span a tracker unfolds plots.range_rate_mps by (docs/protocol.md 4.2)
            range_rate_span_mps=model.range_rate_span_mps if model.has_doppler_bank else None)

    def plan_scans(self, t_scans: list[float]) -> tuple[np.ndarray, np.ndarray]:
        """The targets the beam may meet in each revolution starting at ``t_scans``: their
        rows and the index in ``t_scans`` of their revolution, revolution after revolution
        (rows ascending within one).

        Those that exist during the revolution and can be inside the instrumented range at
        some time of it (ground range at its start minus what the relative horizontal speed
        covers in one period); the others are not solved for.  The revolutions of a block
        are planned together (the tests and the geometry are element by element: the same
        rows as one revolution at a time).
        """
        sim = self.sim
        period = self.radar.scan_period_s
        t_of = np.asarray(t_scans, dtype=float)
        t = t_of[:, None]
        # (revolution, target) pairs in row-major order: revolution after revolution
        scan_of, rows = np.nonzero((sim.targets.t_last >= t) & (sim.targets.t_first < t + period))
        scan_of = scan_of.astype(np.int64, copy=False)
        if not rows.size:
            return rows, scan_of
        t = t_of[scan_of]
        tpos, tvel, _ = sim.targets.state(t, rows)
        ppos, pvel = self.platform_state(t)
        _, ground = antenna_azimuth(ppos, tpos, sim.frame)
        reach = np.hypot(tvel[:, 0] - pvel[:, 0], tvel[:, 1] - pvel[:, 1]) * period
        near = ground <= self.radar.instrumented_range_m + reach
        return rows[near], scan_of[near]

    def _dwell(self, rows: np.ndarray, tc: np.ndarray, scan_of: np.ndarray) -> dict | None:
        """Run the dwell model on the targets crossed at times ``tc``; update the counters.

        ``scan_of`` is the index of each crossing's revolution in the block; targets of
        different revolutions are never merged.  Each look sees the stand-off jammers where
        they are at its own time (:meth:`jammer_geometry`).
        """
        sim = self.sim
        geom, active, tpos = self.geometry(tc, rows)
        ppos, pvel = self.platform_state(tc)
        ok = active & (geom.ground_range <= self.radar.instrumented_range_m)
        ok &= geom.slant_range > 0.0
        if not ok.any():
            return None
        idx = np.flatnonzero(ok)
        geom, scan_of = _take(geom, idx), scan_of[idx]
        jam_w = None
        if sim.jammers.n:
            jam = self.jammer_geometry(tc[idx], ppos[idx], pvel[idx])
            assert jam is not None  # the scene has jammers
            jam_w = self.model.jamming_power(geom.azimuth, *jam)
        res = self.model.process_targets(
            geom, rows[idx], tc[idx], tpos[idx], self.rng,
            antenna_en=ppos[idx, :2], jam_power_w=jam_w, batch=scan_of,
            platform_vel=pvel[idx] if self._platform_manoeuvres else None)
        sim.stats.dwells += idx.size
        sim.stats.missed_detections += res.pop("missed")
        sim.stats.merged_targets += res.pop("merged")
        sim.stats.propagation_fallbacks += res.pop("fallbacks", 0)
        nplots = res["range_m"].size
        if nplots:
            # the strongest contributor's true geometry at the plot's time (a merged plot's
            # time is its contributors' power-weighted one): what the plot measures
            true, _, _ = self.geometry(res["time_s"], res["target"].astype(np.int64))
            res.update(true_range_m=true.slant_range, true_azimuth_rad=true.azimuth,
                       true_range_rate_mps=true.radial_velocity)
        sim.stats.target_plots += nplots
        for code, name in enumerate(self.model.INTERFERENCE_NAMES):
            sim.stats.by_interference[name] += int(np.count_nonzero(res["interference"] == code))
        res["origin"] = np.full(nplots, ORIGIN_TARGET, dtype=np.uint8)
        return res

    def _false_alarms(self, bounds: list[tuple[float, float]]) -> list[dict]:
        """The noise-induced ([90]-[93], uniform in R and θ) and sea-clutter-induced (seed
        7.2) false alarms of the revolutions ``bounds`` ([start, end) each), drawn for all of
        them together, timed when the beam sweeps their azimuths; each plot carries the
        index of its ``revolution``."""
        sim, model = self.sim, self.model
        t_a = np.array([a for a, _ in bounds])
        t_b = np.array([b for _, b in bounds])
        beam = self.beam_azimuth(t_a)
        parts = []
        fa = model.false_alarms.noise_false_alarms(self.rng, len(bounds))
        rev = fa["revolution"]
        t = t_a[rev] + np.mod(fa["azimuth_rad"] - beam[rev], TWO_PI) / self.omega
        keep = t < t_b[rev]
        n = int(np.count_nonzero(keep))
        if n:
            plots = model.false_alarms.false_alarm_plots(
                fa["range_m"][keep], fa["azimuth_rad"][keep], t[keep], self.rng)
            plots["origin"] = np.full(n, ORIGIN_NOISE, dtype=np.uint8)
            plots["revolution"] = rev[keep]
            sim.stats.noise_false_alarms += n
            parts.append(plots)
        clutter = model.false_alarms.clutter_false_alarms(t_a, t_b, beam, self.omega, self.rng)
        if clutter is not None and clutter["range_m"].size:
            n = clutter["range_m"].size
            clutter["origin"] = np.full(n, ORIGIN_SEA_CLUTTER, np.uint8)
            sim.stats.clutter_false_alarms += n
            parts.append(clutter)
        return parts

    def block_bounds(self, scan0: int) -> list[tuple[float, float]]:
        """The revolutions of the block that starts with revolution ``scan0`` (at most
        :attr:`scans_per_block`, those that start before the run's end): [start, end) [s] of
        each, as the process counts them (the run's end at the latest)."""
        period, duration = self.radar.scan_period_s, self.sim.duration
        bounds = []
        for j in range(self.scans_per_block):
            t_a = (scan0 + j) * self.n_sectors * self.sector_s
            if t_a >= duration:
                break
            bounds.append((t_a, min(t_a + period, duration)))
        return bounds

    def _compute_block(self, scan0: int) -> list[tuple[int, int]]:
        """Every plot of the next revolutions from ``scan0``, kept in :attr:`_block_plots`
        revolution after revolution, each sorted by time (emitted sector by sector); the
        rows ``[start, stop)`` of each revolution there.

        The on-line level is vectorized over a block of revolutions (:data:`_BLOCK_S` of
        simulated time, at least one): the beam-crossing times of every target in every
        revolution are solved together and the dwell model runs once on all of them; the
        false alarms of every revolution are drawn together too.  The plots still leave at
        the end of the sector in which the beam made them, so the stream is the same whatever
        the block (only the order of the random draws depends on it).
        """
        sim = self.sim
        self._block_scan0 = scan0  # the revolution of a look's batch 0 (_on_look)
        if self.errors is not None:  # nothing before the block is asked again
            self.errors.forget_before(scan0 * self.n_sectors * self.sector_s - 1.0)
        bounds = self.block_bounds(scan0)
        self._scan_end_states(scan0, len(bounds))
        # beam crossings of every (revolution, target) pair, solved at once
        target_part = None
        t_as = [t_a for t_a, _ in bounds]
        rows, scan_of = (self.plan_scans(t_as) if sim.targets.n
                         else (np.zeros(0, np.int64), np.zeros(0, np.int64)))
        if rows.size:
            idx, tc = self.crossings(rows, scan_of, t_as, scan0)
            if idx.size:
                target_part = self._dwell(rows[idx], tc, scan_of[idx])
                if target_part is not None:
                    target_part["revolution"] = target_part.pop("batch")
        parts = [] if target_part is None else [target_part]
        parts += self._false_alarms(bounds)
        looks = self._looks.fold(scan0, len(bounds))  # the block's looks are all made
        assert self._ends is not None
        if self._ends.columns is not None:
            self._ends.columns.update(zip(("look_time_s", "pd", "snr_db", "interference"),
                                          looks, strict=True))
        merged = merge_plot_batches(parts)
        self._block_true_t = None
        if self.errors is not None and self.errors.touches_plots:
            # issue 33: the reported range, azimuth and time; the sectors still hold the
            # plots the beam made in them (their true times)
            self._block_true_t = merged["time_s"]
            self.errors.apply(merged)
        edges = np.searchsorted(merged["revolution"], np.arange(len(bounds) + 1)).tolist()
        self._block_plots = (scan0, merged, edges)  # for _frame_block
        return list(zip(edges[:-1], edges[1:], strict=True))

    def crossings(self, rows: np.ndarray, scan_of: np.ndarray, t_as: list[float], scan0: int
                  ) -> tuple[np.ndarray, np.ndarray]:
        """Every beam crossing of the (target ``rows``, revolution ``scan_of``) pairs: the
        pair of each and its time [s], by pair then time
        (:func:`shipradar.sim.world.kinematics.beam_crossings`); ``t_as`` the starts [s] of
        the block's revolutions (from :meth:`block_bounds`), the first one revolution
        ``scan0``, and the pairs from :meth:`plan_scans`.  Reads the scene and the radar only
        (``benchmarks/crossings.py`` times it on a run's blocks).

        Revolution j, starting at t_j as the process counts it, owns the crossings in
        [t_j - ε, t_j+1 - ε) (the run's end for the last): every crossing is counted once,
        and one on a boundary (a target on the start azimuth) by the later revolution,
        whatever the rounding of the azimuths there.  Two crossings of one target less than
        a dwell θ_b/ω apart (a target keeping pace with the beam) are one look.
        """
        sim = self.sim
        starts = np.array(t_as + [(scan0 + len(t_as)) * self.n_sectors
                                  * self.sector_s]) - _CROSSING_EPS_S
        if starts[-1] >= sim.duration - _CROSSING_EPS_S:
            starts[-1] = sim.duration
        t_a, t_b = starts[:-1][scan_of], starts[1:][scan_of]
        beam = self.beam_azimuth(starts)
        speed = _SPEED_MARGIN * (sim.targets.max_speed[rows]
                                 + sim.platforms.max_speed[self.p_index])

        def look_at(t: np.ndarray, i: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            tpos, tvel, active = sim.targets.state(t, rows[i])
            ppos, pvel = self.platform_state(t)
            az, ground = antenna_azimuth(ppos, tpos, sim.frame)
            # the plane's angular rate east/north, for Newton's steps only (a target outside
            # its track's times holds its end position)
            de, dn = tpos[:, 0] - ppos[:, 0], tpos[:, 1] - ppos[:, 1]
            ve = np.where(active, tvel[:, 0], 0.0) - pvel[:, 0]
            vn = np.where(active, tvel[:, 1], 0.0) - pvel[:, 1]
            rho2 = de * de + dn * dn
            rate = (dn * ve - de * vn) / np.where(rho2 > 0.0, rho2, 1.0)
            return az, rate, ground

        # each target's azimuth at each revolution boundary, once (one revolution's end is
        # the next one's start): the same numbers on both sides of a boundary
        key = np.concatenate([rows * starts.size + scan_of, rows * starts.size + scan_of + 1])
        uniq, inv = np.unique(key, return_inverse=True)
        ut = starts[uniq % starts.size]
        ur = uniq // starts.size
        tpos, _, _ = sim.targets.state(ut, ur)
        az, ground = antenna_azimuth(self.platform_state(ut)[0], tpos, sim.frame)
        n = rows.size
        ends = (az[inv[:n]], ground[inv[:n]], az[inv[n:]], ground[inv[n:]])
        pair, tc = beam_crossings(look_at, t_a, t_b, beam[:-1][scan_of], beam[1:][scan_of],
                                  self.omega, speed, rate_slack_rad_s=_RATE_SLACK_RAD_S,
                                  min_separation_s=float(sweep_time(
                                      self.model.theta_b, self.radar.scan_period_s)),
                                  ends=ends)
        # the first revolution's margin lies before the run: a target on the start azimuth
        # (met at -2e-15 s by rounding) is met at the start, where it exists
        return pair, np.maximum(tc, 0.0)

    def sector_cuts(self, scan0: int, times: np.ndarray, edges: list[int]) -> np.ndarray:
        """Where each sector's plots end in a block's plot ``times`` (revolution ``scan0 +
        r`` in rows ``edges[r]:edges[r + 1]``, sorted by time within each): the revolution's
        times before the sector's end (:meth:`sector_end`), everything left in the last
        sector; one row per revolution."""
        n = self.n_sectors
        first = (scan0 + np.arange(len(edges) - 1))[:, None] * n
        ends = self.sector_end(first + np.arange(n - 1))
        e = np.asarray(edges, dtype=np.int64)
        cuts = np.empty((len(edges) - 1, n), dtype=np.int64)
        cuts[:, -1] = e[1:]
        if np.all(times[1:] >= times[:-1]):
            # sorted through the block: the count of a revolution's times before an end is
            # the block's count clipped to the revolution's rows
            cuts[:, :-1] = np.clip(np.searchsorted(times, ends, side="left"), e[:-1, None],
                                   e[1:, None])
        else:  # a plot a hair before its revolution's start
            for r, (a, b) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
                cuts[r, :-1] = a + np.searchsorted(times[a:b], ends[r], side="left")
        return cuts

    def _frame_block(self) -> list[_Revolution]:
        """The ``plots`` and ``truth`` messages of every non-empty sector of the revolutions
        :meth:`_compute_block` computed last (:func:`shipradar.sim.stream.framing.sector_columns`):
        for a bus that takes frames, their bodies encoded at once; for another, their
        payloads (:class:`_Revolution`).

        Sectors the run does not reach (its end inside a revolution) are framed but never
        sent.  Plot ids run on through the block: its plots are sent in their order.
        """
        assert self._block_plots is not None
        scan0, merged, edges = self._block_plots
        n = self.n_sectors
        true_t = self._block_true_t
        cuts = self.sector_cuts(scan0, merged["time_s"] if true_t is None else true_t, edges)
        i1 = cuts.ravel()
        i0 = np.concatenate([np.asarray(edges[:-1], dtype=np.int64)[:, None], cuts[:, :-1]],
                            axis=1).ravel()
        msg = np.flatnonzero(i1 > i0)  # non-empty sectors, sector k of the block
        rev, sectors = np.divmod(msg, n)
        i0, i1 = i0[msg], i1[msg]
        total = int(edges[-1])
        plot_id = np.arange(self.plot_counter, self.plot_counter + total, dtype=np.int64)
        scans = range(scan0, scan0 + len(edges) - 1)
        plots, truth = sector_columns(self.radar.id, scans, merged, plot_id, i0, i1, rev)
        times = self.sector_end((scan0 + rev) * n + sectors)
        # with latency (issue 33) each message is framed at its publication time
        pub = self._publication_times(rev, sectors, times)
        at = times if pub is None else pub
        encoded = self.sim.encodes_ahead
        if encoded:
            p_msgs: list[bytes] | list[dict] = plots.encode(at)
            t_msgs: list[bytes] | list[dict] = truth.encode(at)
        else:
            p_msgs = [plots.message(j) for j in range(len(plots))]
            t_msgs = [truth.message(j) for j in range(len(truth))]
        self._frame_ends(encoded)
        # the messages are in revolution order: each revolution's are a run of them
        first = np.asarray(edges)[rev]
        sec, tim, rows = sectors.tolist(), times.tolist(), (i1 - i0).tolist()
        s0, s1 = (i0 - first).tolist(), (i1 - first).tolist()
        m = np.searchsorted(rev, np.arange(len(scans) + 1)).tolist()
        pubs = at.tolist()
        return [_Revolution(encoded, sec[a:b], tim[a:b], rows[a:b], p_msgs[a:b], t_msgs[a:b],
                            s0[a:b], s1[a:b], pubs[a:b])
                for a, b in zip(m[:-1], m[1:], strict=True)]

    def _publication_times(self, rev: np.ndarray, sectors: np.ndarray, times: np.ndarray
                           ) -> np.ndarray | None:
        """When each sector message of the block framed now leaves (issue 33's latency; None
        without): revolution ``rev`` (from the block's first), ``sector``, made at ``times``
        [s]; the radar's link first in, first out from where it is now, each revolution's end
        of scan after the fixed delay (:meth:`_leaves`, the same recursion as the process);
        a message the run never sends (its sector starts at or after the run's end) draws
        nothing."""
        errors, ends = self.errors, self._ends
        if errors is None or not errors.has_latency:
            return None
        assert ends is not None
        n, sector_s, duration = self.n_sectors, self.sector_s, self.sim.duration
        # first in, first out: each leaves at the running maximum of (the link's state now,
        # every earlier message's own arrival, the earlier ends of scan + the fixed delay)
        sent = ((ends.scan0 + rev) * n + sectors) * sector_s < duration
        arrival = np.full(times.size, -np.inf)
        arrival[sent] = times[sent] + errors.latencies_s(int(np.count_nonzero(sent)))
        floor = np.concatenate([[self._link_free],
                                np.asarray(ends.t) + errors.latency_fixed_s])
        floor = np.maximum.accumulate(floor)[rev]
        out = np.maximum(np.maximum.accumulate(arrival), floor)
        return np.where(sent, out, times)

    def _send_sector(self, t_b: float, rows: int, plots: bytes | dict, truth: bytes | dict
                     ) -> None:
        """Publish a sector's ``plots`` and ``truth`` messages framed ahead
        (:meth:`_frame_block`): their bodies to a bus that takes frames, or their payloads."""
        self.plot_counter += rows
        bus = self.sim.bus
        if isinstance(plots, bytes) and isinstance(truth, bytes):
            if type(bus) is _BatchingBus:  # the batched path: kept until the end of scan
                bus.pending += ((t_b, [protocol.TOPIC_PLOTS, plots]),
                                (t_b, [protocol.TOPIC_TRUTH, truth]))
                return
            frames = self._bus_caps()[0]
            assert frames is not None  # framed for it (_frame_block)
            frames.emit_frames(t_b, [protocol.TOPIC_PLOTS, plots])
            frames.emit_frames(t_b, [protocol.TOPIC_TRUTH, truth])
        elif isinstance(plots, dict) and isinstance(truth, dict) and bus is not None:
            bus.emit(protocol.TOPIC_PLOTS, t_b, plots)
            bus.emit(protocol.TOPIC_TRUTH, t_b, truth)

    def _send_sectors(self, rev: _Revolution, count: int) -> None:
        """Publish the first ``count`` messages of revolution ``rev`` (:meth:`_send_sector`
        each; to the batched path's bus, all at once)."""
        bus = self.sim.bus
        if rev.encoded and isinstance(bus, _BatchingBus):
            self.plot_counter += sum(rev.rows[:count])
            # each message's two records (t, (topic, body)), plots then truth, made by zip
            # (made per revolution and dropped at its flush: a block's thousands held at
            # once would set off the garbage collector's full passes)
            times: list = [None] * (2 * count)
            bodies = list(times)
            times[::2] = times[1::2] = rev.times[:count]
            bodies[::2], bodies[1::2] = rev.plots[:count], rev.truth[:count]
            bus.pending += zip(times, zip(_SECTOR_TOPICS * count, bodies, strict=True), strict=True)
            return
        frames = self._bus_caps()[0] if rev.encoded else None
        if frames is not None:  # _send_sector's frames path, the bus's emit_frames resolved once
            emit, plots_topic, truth_topic = frames.emit_frames, protocol.TOPIC_PLOTS, \
                protocol.TOPIC_TRUTH
            for j in range(count):
                self.plot_counter += rev.rows[j]
                t_b = rev.times[j]
                emit(t_b, [plots_topic, rev.plots[j]])
                emit(t_b, [truth_topic, rev.truth[j]])
            return
        for j in range(count):
            self._send_sector(rev.times[j], rev.rows[j], rev.plots[j], rev.truth[j])

    def _scan_end_states(self, scan0: int, count: int) -> None:
        """The ends of revolutions ``scan0`` to ``scan0 + count - 1`` (the end of their last
        sector, :meth:`sector_end`: the times the run reaches them), computed together and
        kept for :meth:`_end_of_scan` (:class:`_ScanEnds`): the platform's position,
        velocity, latitude and longitude (the geodetic conversion is iterative) and the
        ``truth[targets]`` columns of every target: position, velocity, acceleration,
        activity and :meth:`in_coverage` (the last looks follow once the block's dwells are
        done, :meth:`shipradar.sim.engine.last_looks.LastLooks.fold`).  Element-wise the same
        numbers as one call per end of scan."""
        sim = self.sim
        t = self.sector_end(self.n_sectors * np.arange(scan0 + 1, scan0 + 1 + count) - 1)
        pos, vel = self.platform_state(t)
        true_pos = pos
        if self.errors is not None and self.errors.navigates:
            # eos and the next meta report the navigated position (issue 33); coverage and
            # truth[sensors] the true one
            pos = pos + self.errors.navigation_offset(t)
        lat, lon, _ = sim.frame.geodetic(pos)
        columns = None
        n = sim.targets.n
        if n:
            tpos, tvel, tacc, active = sim.targets.state_acc(np.repeat(t, n),
                                                             np.tile(np.arange(n), t.size))
            cover = self.in_coverage(np.repeat(true_pos, n, axis=0), tpos, active)
            # an inactive target has no state (schema 2): NaN, not a frozen one
            for a in (tpos, tvel, tacc):
                a[~active] = np.nan
            columns = {"east_m": tpos[:, 0], "north_m": tpos[:, 1], "up_m": tpos[:, 2],
                       "v_east_mps": tvel[:, 0], "v_north_mps": tvel[:, 1],
                       "v_up_mps": tvel[:, 2], "a_east_mps2": tacc[:, 0],
                       "a_north_mps2": tacc[:, 1], "a_up_mps2": tacc[:, 2],
                       "active": active, "in_coverage": cover}
            if sim.live_source is not None:  # beyond the declared envelope (docs/external.md)
                columns["outside_envelope"] = active & sim.targets.outside(tpos)
        self._ends = _ScanEnds(scan0, t.tolist(), pos, vel, lat.tolist(), lon.tolist(),
                               columns, true_pos=true_pos)

    def _eos_payload(self, j: int) -> dict[str, Any]:
        """``eos`` of the ``j``-th revolution of :attr:`_ends`, with the antenna's state at
        its end (:meth:`antenna_state`)."""
        ends = self._ends
        assert ends is not None
        t, scan = ends.t[j], ends.scan0 + j
        state = self.antenna_state(t, ends.pos[j], ends.vel[j], ends.lat[j], ends.lon[j])
        return eos_payload(self.radar.id, scan, t, state, self._eos_complete(t, scan))

    def _eos_complete(self, t: float, scan: int) -> bool:
        """Whether revolution ``scan``, ending at ``t`` [s], is complete: the run's end
        inside a revolution cuts it short (the sector loop ends it at t_b = duration); a
        revolution ending exactly at the run's end is complete."""
        return bool(t >= (scan + 1) * self.n_sectors * self.sector_s - 1e-9)

    def _frame_ends(self, encoded: bool) -> None:
        """The ``eos`` and ``truth[targets]`` messages of the revolutions computed last
        (:attr:`_ends`): the latter as :class:`shipradar.sim.stream.framing.Slices`, one
        message per revolution; for a bus that takes frames, both encoded at once, and the
        next scan's ``meta`` items of its scan number and antenna state (that of this end,
        :meth:`_emit_meta`)."""
        ends = self._ends
        assert ends is not None
        scans = range(ends.scan0, ends.scan0 + len(ends.t))
        if ends.columns is not None:
            ends.targets = target_columns(self.radar.id, scans, ends.t, ends.columns,
                                          len(self.target_ids))
        if encoded:
            # every end's eos and the next meta's scan and antenna state, packed at once
            packed = end_of_scan_frames(
                self.radar.id, ends.scan0, ends.t, self._antenna_states(ends),
                [self._eos_complete(t, scan) for t, scan in zip(ends.t, scans, strict=True)])
            truth = (ends.targets.encode(np.asarray(ends.t)) if ends.targets is not None
                     else [None] * len(ends.t))
            ends.frames = list(zip(packed.eos, truth, packed.next_meta, strict=True))

    def _end_of_scan(self, t: float, scan: int, t_at: float | None = None) -> None:
        """The end of revolution ``scan`` at time ``t`` (its ``eos`` and ``truth[targets]``,
        :meth:`_frame_ends`), and the bus flushed: each scan's records are written at its
        end."""
        sim = self.sim
        sim.stats.scans += 1
        ends = self._ends
        assert ends is not None
        j = scan - ends.scan0  # ends.t[j] == t (_scan_end_states)
        self._last_eos = (t, ends.pos[j], ends.vel[j], ends.lat[j], ends.lon[j])
        bus = sim.bus
        if bus is None:
            return
        self._next_meta = None
        at = t if t_at is None else t_at  # it leaves late with latency (issue 33)
        if ends.frames is not None:
            eos, truth, meta = ends.frames[j]
            self._next_meta = (t, meta)
            frames = self._bus_caps()[0]
            assert frames is not None  # framed for it (_frame_ends)
            if at != t:
                eos = protocol.retime(eos, at)
                truth = None if truth is None else protocol.retime(truth, at)
            frames.emit_frames(at, [protocol.TOPIC_EOS, eos])
            if truth is not None:
                frames.emit_frames(at, [protocol.TOPIC_TRUTH, truth])
        else:
            bus.emit(protocol.TOPIC_EOS, at, self._eos_payload(j))
            if ends.targets is not None:
                bus.emit(protocol.TOPIC_TRUTH, at, ends.targets.message(j))
        if self.errors is not None:
            frames = self._bus_caps()[0]
            if frames is not None:  # packed once per block, but the latency (issue 33)
                frames.emit_frames(at, truth_sensors_frames(self._truth_sensors_items(j),
                                                            self._scan_latency, at))
            else:
                bus.emit(protocol.TOPIC_TRUTH, at, self._truth_sensors(t, scan, j))
        bus.flush()

    def _truth_sensors_items(self, j: int) -> bytes:
        """The items of the ``j``-th end's ``truth[sensors]`` but its last key, ``latency_s``,
        those of every end of the block packed at once
        (:func:`shipradar.sim.stream.payloads.truth_sensors_items`): the same bytes as
        :meth:`_truth_sensors`."""
        ends = self._ends
        assert ends is not None and ends.true_pos is not None and self.errors is not None
        if ends.sensor_items is None:
            if ends.errors is None:  # every end of the block's at once
                ends.errors = self.errors.values(np.asarray(ends.t))
            pos, vel = ends.true_pos, ends.vel
            heading = [math.radians(self._heading(e, n, tt)) for (e, n), tt in zip(
                vel[:, :2].tolist(), ends.t, strict=True)]
            ends.sensor_items = truth_sensors_items(self.radar.id, ends.scan0, SensorTruthRows(
                ends.t, ends.errors, pos[:, 0], pos[:, 1],
                pos[:, 2] + self.radar.antenna_height_m, heading))
        return ends.sensor_items[j]

    def _truth_sensors(self, t: float, scan: int, j: int) -> dict[str, Any]:
        """``truth[sensors]`` at the end ``t`` [s] of revolution ``scan`` (the ``j``-th of
        :attr:`_ends`): every error's value, the antenna's true position and heading, the
        latency of the scan's last sector message (issue 33)."""
        ends, errors = self._ends, self.errors
        assert ends is not None and ends.true_pos is not None and errors is not None
        pos, vel = ends.true_pos[j], ends.vel[j]
        heading = self._heading(float(vel[0]), float(vel[1]), t)
        if ends.errors is None:  # every end of the block's at once
            ends.errors = errors.values(np.asarray(ends.t))
        return truth_sensors_payload(
            self.radar.id, scan, t, {k: v[j] for k, v in ends.errors.items()},
            (float(pos[0]), float(pos[1]), float(pos[2] + self.radar.antenna_height_m)),
            math.radians(heading), self._scan_latency)

    def in_coverage(self, platform_pos: np.ndarray, target_pos: np.ndarray,
                    active: np.ndarray) -> np.ndarray:
        """Which targets the radar can see from its platform at ``platform_pos`` [m], (3,)
        or one (k, 3) row per target: active, ground range from the antenna within the
        instrumented range (the engine's own test before a look, :meth:`_dwell`) and inside
        the radio horizon over the effective earth, √(2 a_e h_a) + √(2 a_e h_t) with a_e =
        4/3 the frame's radius and heights above the sea [m] (targets ``target_pos`` (k, 3)
        [m], NaN when inactive)."""
        out = np.zeros(active.shape, dtype=bool)
        if not active.any():
            return out
        idx = np.flatnonzero(active)
        tpos = target_pos[idx]
        ppos = platform_pos if platform_pos.ndim == 1 else platform_pos[idx]
        _, ground = antenna_azimuth(ppos, tpos, self.sim.frame)
        a_e = K_FACTOR * self.sim.frame.radius
        h_a = np.maximum(ppos[..., 2] + self.radar.antenna_height_m, 0.0)
        horizon = np.sqrt(2.0 * a_e * h_a) + np.sqrt(2.0 * a_e * np.maximum(tpos[:, 2], 0.0))
        out[idx] = (ground <= self.radar.instrumented_range_m) & (ground <= horizon)
        return out


@dataclass
class _ScanEnds:
    """The ends of a block's revolutions (:meth:`RadarProcess._scan_end_states`): revolution
    ``scan0 + j`` ends at ``t[j]`` [s]."""

    scan0: int
    t: list[float]
    #: the platform's position and velocity (m, 3) [m, m/s], latitude and longitude [deg]
    pos: np.ndarray
    vel: np.ndarray
    lat: list[float]
    lon: list[float]
    #: the ``truth[targets]`` columns, revolution j in rows j k:(j + 1) k; None without targets
    columns: dict[str, np.ndarray] | None
    #: the platform's true position (m, 3) [m]; ``pos`` is the navigated one (issue 33)
    true_pos: np.ndarray | None = None
    #: each error's value at every end, by its ``truth[sensors]`` key (issue 33)
    errors: dict[str, list[float]] | None = None
    #: each end's ``truth[sensors]`` items but ``latency_s`` (for a bus that takes frames)
    sensor_items: list[bytes] | None = None
    #: their messages (:meth:`RadarProcess._frame_ends`)
    targets: Slices | None = None
    #: the bodies of each revolution's ``eos`` and ``truth[targets]`` and the next scan's
    #: ``meta`` items of its scan and antenna state, for a bus that takes frames
    frames: list[tuple[bytes, bytes | None, bytes]] | None = None


#: Margin of the beam-crossing search at the boundary between two revolutions [s].
_CROSSING_EPS_S = 1e-6
#: The beam-crossing search bounds a target's angular rate from the antenna by v/ρ on the
#: plane: the sphere raises it by (ρ/R)²/6 (1e-3 at 500 km), a factor the speed bound
#: covers with room to spare ...
_SPEED_MARGIN = 1.01
#: ... and the true-north frame turns along a moving antenna's track, v tan(lat)/R
#: (4e-5 rad/s at 40 m/s and 80° of latitude), an added rate [rad/s].
_RATE_SLACK_RAD_S = 1e-3
#: Simulated time whose revolutions are computed together [s] (at least one revolution).
_BLOCK_S = 64.0
#: Expected false alarms a block of revolutions holds at most (fewer revolutions, at least
#: one, when a scan has many: ≈ 200 bytes each while the block is computed).
_BLOCK_PLOTS = 250_000
#: the topics of a sector's two messages, in their order
_SECTOR_TOPICS = [protocol.TOPIC_PLOTS, protocol.TOPIC_TRUTH]


@dataclass
class _Revolution:
    """One revolution's ``plots`` and ``truth[plots]`` messages framed ahead
    (:meth:`RadarProcess._frame_block`), one pair per non-empty sector, in sector order."""

    #: bodies (for a bus that takes frames) or payloads
    encoded: bool
    #: each message's sector (0 to sectors_per_scan - 1) and its end [s] (the message's time)
    sectors: list[int]
    times: list[float]
    #: its plots
    rows: list[int]
    plots: list[Any]
    truth: list[Any]
    #: its first and last row + 1 in the revolution's plots (the ASTERIX bus's
    #: ``plots_ahead``)
    starts: list[int]
    stops: list[int]
    #: each message's publication time [s] (its end, or later with latency: issue 33)
    pub: list[float]


def _take(geom: Geometry, idx: Any) -> Geometry:
    from dataclasses import fields, replace

    return replace(geom, **{f.name: getattr(geom, f.name)[idx] for f in fields(geom)})
