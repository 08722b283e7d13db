"""Radars of one scene in parallel processes, merged into the one stream (issue 16, item 6).

A scene's radars share nothing on the on-line level but the (read-only) trajectories and
tables: each has its own random generator (spawned from the seed in scenario order), its own
dwells, false alarms and frames.  :func:`run_parallel` therefore runs groups of radars in
forked worker processes (and one group in this process), each encoding its own messages, and
merges them into the run's bus in exactly the order the single-process run gives them, so the
recording is byte-identical for a given seed (``tests/test_parallel.py``).

The order
---------
In one process the messages leave from the radars' SimPy processes, one batch per
resumption (a sector's frames, an end of scan, the next metadata).  SimPy orders resumptions
by (time, priority, event id), the id counting events in the order they were *scheduled*,
and a radar schedules its next timeout while it runs.  So the order is reproduced from the
times alone: every worker records ``env.now`` at each resumption of each radar, and
:func:`merge_order` replays SimPy's heap on those times
(:class:`shipradar.sim.engine.order.EventOrder`, the batched path's too): the processes start
in radar order (urgent initialisation events at t = 0), and each popped resumption schedules
that radar's next one with the next id.  Ties between radars at one instant (common sector ends) are
broken exactly as SimPy breaks them, with no assumption about the radars' timings.

Fast mode only (a wall-clock run is paced by one clock); ``Simulation.messages`` stays in one
process.  Workers are forked (``fork`` start method: the scene's tables are inherited, not
pickled); where fork is unavailable the run stays in one process.
"""

from __future__ import annotations

import multiprocessing
import pickle
import time
from collections.abc import Mapping, Sequence
from dataclasses import fields
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from shipradar.sim.engine.order import EventOrder
from shipradar.sim.stream import protocol
from shipradar.sim.stream.sink import takes_frames

# What a forked worker needs, set by the parent just before it forks (not pickled).
_FORK_STATE: dict[str, Any] = {}


class FrameCollector:
    """A bus that keeps every message encoded, tagged with its radar and resumption.

    A :class:`shipradar.sim.stream.sink.FrameSink`: the engine encodes ahead for it
    (``encodes_ahead``), as for :class:`shipradar.sim.stream.bus.Bus`.
    """

    encodes_ahead = True

    def __init__(self, sim: Any) -> None:
        self.sim = sim
        self.messages: list[tuple[int, int, float, bytes, bytes]] = []
        for r in sim.radars:  # the engine records its resumptions only when asked
            r.resume_times = []
        self._resumes = {r.index: r.resume_times for r in sim.radars}

    def emit(self, topic: bytes, t_sim: float, payload: Mapping[str, Any]) -> None:
        self.emit_frames(t_sim, protocol.encode(topic, t_sim, payload))

    def emit_frames(self, t_sim: float, frames: Sequence[bytes]) -> None:
        r = self.sim.active_radar
        self.messages.append((r, len(self._resumes[r]) - 1, t_sim, bytes(frames[0]),
                              bytes(frames[1])))

    def flush(self, fsync: bool = False) -> None:
        """Nothing to hand on: the parent's bus flushes at each end of scan."""


def _stats_dict(stats: Any) -> dict[str, Any]:
    return {f.name: getattr(stats, f.name) for f in fields(stats)}


def _run_group(indices: Sequence[int]) -> dict[str, Any]:
    """Run the radars ``indices`` of the scene in _FORK_STATE; their messages and times."""
    st = _FORK_STATE
    # the class from the parent's instance: no import of the engine here (no import circle)
    sim = st["cls"](st["scenario"], seed=st["seed"], duration_s=st["duration"],
                     tables=st["tables"], only_radars=set(indices))
    sim.bus = FrameCollector(sim)
    sim.run()
    return {"stats": _stats_dict(sim.stats), "messages": sim.bus.messages,
            "resume_times": {r.index: r.resume_times for r in sim.radars}}


def _pack(out: dict[str, Any]) -> bytes:
    """A worker's result as one pickle in which the frame bodies are one bytes object and
    an array of lengths (pickling 10^5 small bytes objects one by one costs more than the
    simulation saves)."""
    msgs = out.pop("messages")
    out["index"] = np.array([(r, k) for r, k, _, _, _ in msgs], dtype=np.int64).reshape(-1, 2)
    out["times"] = np.array([t for _, _, t, _, _ in msgs], dtype=float)
    out["topics"] = [topic for _, _, _, topic, _ in msgs]
    out["lengths"] = np.array([len(body) for _, _, _, _, body in msgs], dtype=np.int64)
    out["bodies"] = b"".join(body for _, _, _, _, body in msgs)
    return pickle.dumps(out, protocol=pickle.HIGHEST_PROTOCOL)


def _unpack(data: bytes) -> dict[str, Any]:
    out = pickle.loads(data)
    if "error" in out:
        return out
    ends = np.cumsum(out.pop("lengths")).tolist()
    starts = [0, *ends[:-1]]
    blob = out.pop("bodies")
    out["messages"] = [(r, k, t, topic, blob[a:b]) for (r, k), t, topic, a, b in zip(
        out.pop("index").tolist(), out.pop("times").tolist(), out.pop("topics"), starts, ends,
        strict=True)]
    return out


def _worker(indices: Sequence[int], conn: Connection) -> None:
    try:
        conn.send_bytes(_pack(_run_group(indices)))
    except BaseException as exc:  # reported by the parent
        conn.send_bytes(pickle.dumps({"error": repr(exc)}))
    finally:
        conn.close()


def merge_order(resume_times: dict[int, list[float]]) -> list[tuple[int, int]]:
    """(radar, resumption) pairs in the order one SimPy environment runs them.

    Parameters
    ----------
    resume_times : dict[int, list[float]]
        For each radar index (``scenario.radars()`` order), ``env.now`` at each resumption
        of its process [s], the first being its start at 0.

    Returns
    -------
    list[tuple[int, int]]
        Every (radar, k) once, in the single-process order (module notes).
    """
    radars = sorted(resume_times)
    events = EventOrder(len(radars))
    taken = [0] * len(radars)  # resumptions of each radar replayed so far
    order = []
    for i, _ in events.resumptions():
        times = resume_times[radars[i]]
        k = taken[i]
        if k >= len(times):  # a radar that never started (no times)
            continue
        order.append((radars[i], k))
        taken[i] = k + 1
        if k + 1 < len(times):
            events.schedule(i, times[k + 1])
    return order


def groups(n_radars: int, processes: int) -> list[list[int]]:
    """Radar indices per process, the first group for the parent process.

    The parent also merges, records and publishes every radar's messages, so it takes half
    a worker's share of the radars (at least one when there are radars to spare); the
    workers share the rest round robin.  At most ``processes`` groups, none empty.
    """
    n = max(1, min(processes, n_radars))
    if n == 1:
        return [list(range(n_radars))]
    own = max(1, min(n_radars - (n - 1), round(n_radars * 0.5 / (n - 0.5))))
    rest = list(range(own, n_radars))
    return [list(range(own)), *(rest[i::n - 1] for i in range(n - 1))]


def run_parallel(sim: Any) -> dict[str, Any]:  # the Simulation (it imports this module)
    """Run ``sim`` (a :class:`shipradar.sim.engine.simulation.Simulation` with ``processes`` > 1)
    with its radars
    in worker processes; publish and record the merged stream on ``shipradar.sim.stream.bus``.

    Returns
    -------
    dict
        The summary, as :meth:`shipradar.sim.engine.simulation.Simulation.run` (counts
        summed over the radars).
    """
    try:
        ctx = multiprocessing.get_context("fork")
    except ValueError:  # no fork on this platform: one process
        sim.processes = 1
        return sim.run()
    wall0 = time.perf_counter()
    parts = groups(len(sim.radars), sim.processes)
    _FORK_STATE.update(cls=type(sim), scenario=sim.scenario, seed=sim.seed, duration=sim.duration,
                       tables=sim.tables)
    workers = []
    try:
        for indices in parts[1:]:
            recv, send = ctx.Pipe(duplex=False)
            proc = ctx.Process(target=_worker, args=(indices, send), daemon=True)
            proc.start()
            send.close()
            workers.append((proc, recv))
        results = [_run_group(parts[0])]  # this process works too
        for proc, recv in workers:
            out = _unpack(recv.recv_bytes())
            proc.join()
            if "error" in out:
                raise RuntimeError(f"radar worker failed: {out['error']}")
            results.append(out)
    finally:
        _FORK_STATE.clear()
        for proc, _ in workers:
            if proc.is_alive():
                proc.terminate()
    resume_times: dict[int, list[float]] = {}
    batches: dict[tuple[int, int], list[tuple[float, bytes, bytes]]] = {}
    for out in results:
        resume_times.update(out["resume_times"])
        for r, k, t, topic, body in out["messages"]:
            batches.setdefault((r, k), []).append((t, topic, body))
        for name, value in out["stats"].items():
            if isinstance(value, dict):
                for key, v in value.items():
                    getattr(sim.stats, name)[key] += v
            else:
                setattr(sim.stats, name, getattr(sim.stats, name) + value)
    bus = sim.bus
    if bus is not None:
        frames = takes_frames(bus)
        for key in merge_order(resume_times):
            for t, topic, body in batches.get(key, ()):
                if frames:
                    bus.emit_frames(t, [topic, body])
                else:
                    bus.emit(*protocol.decode([topic, body]))
                if topic == protocol.TOPIC_EOS:
                    bus.flush()  # as the engine does at each end of scan
        bus.flush()
    return sim.summary(time.perf_counter() - wall0)


__all__ = ["FrameCollector", "groups", "merge_order", "run_parallel"]
