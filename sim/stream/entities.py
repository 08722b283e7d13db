"""Live sources of entity states: a ZeroMQ feed (``--entities ENDPOINT``) and a recording.

Transport only: the message is :data:`shipradar.sim.stream.schema.ENTITIES` in the stream's
envelope (:mod:`shipradar.sim.stream.protocol` decodes it); what the states mean to the run
is :mod:`shipradar.sim.world.live`'s.  Both sources answer ``drain(now_s)`` with the payloads
that arrived up to the run's current time, their ``time_s`` resolved where the sender left it
NaN (the time of reception).

The ZeroMQ feed receives on its own thread, so that a flood of messages never delays a scan:
the thread decodes and queues at most ``queue_size`` rows (older ones stay, newer ones are
dropped and counted), and the run takes the queue at each revolution start.
"""

from __future__ import annotations

import collections
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from shipradar.sim.stream.protocol import MAX_BODY_BYTES, ProtocolError, decode
from shipradar.sim.stream.schema import TOPIC_ENTITIES
from shipradar.sim.world.errors import BadInputError

__all__ = ["EntitiesError", "EntityFeed", "RecordedEntities", "entity_source"]

#: Poll period of the receiving thread [ms]: bounds how long close() waits for it.
_POLL_MS = 50


class EntitiesError(ValueError, BadInputError):
    """An ``--entities`` argument that cannot be used (one line)."""


class EntityFeed:
    """Entity states from a ZeroMQ publisher (SUB connected to ``endpoint``, topic
    ``entities``), received on a thread into a bounded queue.

    Parameters
    ----------
    endpoint : ZeroMQ endpoint of the feed's publisher (``tcp://127.0.0.1:5560``)
    queue_size : rows held until the run takes them; more are dropped and counted
    """

    def __init__(self, endpoint: str, queue_size: int = 100_000):
        import zmq

        self.endpoint = endpoint
        self.queue_size = int(queue_size)
        self._ctx: Any = zmq.Context.instance()
        self._sock = self._ctx.socket(zmq.SUB)
        self._sock.setsockopt(zmq.LINGER, 0)
        self._sock.setsockopt(zmq.RCVHWM, 100_000)
        self._sock.setsockopt(zmq.MAXMSGSIZE, MAX_BODY_BYTES + 4096)
        self._sock.setsockopt(zmq.SUBSCRIBE, TOPIC_ENTITIES)
        try:
            self._sock.connect(endpoint)
        except zmq.ZMQError as exc:
            self._sock.close(0)
            raise EntitiesError(f"--entities: cannot connect to {endpoint!r} ({exc}); give a "
                                f"ZeroMQ endpoint such as tcp://127.0.0.1:5560 or a "
                                f"recording file") from None
        self._queue: collections.deque[tuple[float, dict[str, Any], int]] = collections.deque()
        self._queued_rows = 0
        self._lock = threading.Lock()
        self.messages = 0
        self.rows = 0
        self.dropped = 0
        self.bad: dict[str, int] = {}
        self._stop = threading.Event()
        #: set once the first message has been received (tests wait on it)
        self.first_message = threading.Event()
        self._thread = threading.Thread(target=self._receive, name="entities", daemon=True)
        self._thread.start()

    def _count(self, reason: str) -> None:
        with self._lock:
            self.bad[reason] = self.bad.get(reason, 0) + 1

    def _receive(self) -> None:
        import zmq

        poller = zmq.Poller()
        poller.register(self._sock, zmq.POLLIN)
        while not self._stop.is_set():
            if not poller.poll(_POLL_MS):
                continue
            while True:
                try:
                    frames = self._sock.recv_multipart(zmq.NOBLOCK)
                except zmq.Again:
                    break
                except zmq.ZMQError:
                    return
                received = time.monotonic()
                try:
                    topic, _t, payload = decode(frames)
                except (ProtocolError, ValueError, TypeError, KeyError):
                    self._count("undecodable message")
                    continue
                if topic != TOPIC_ENTITIES or not isinstance(payload, dict):
                    self._count("not an entities message")
                    continue
                ids = payload.get("id")
                n = len(ids) if isinstance(ids, (list, tuple)) else 0
                with self._lock:
                    self.messages += 1
                    self.rows += n
                    if self._queued_rows + n > self.queue_size:
                        self.dropped += n
                        continue
                    self._queue.append((received, payload, n))
                    self._queued_rows += n
                self.first_message.set()

    def drain(self, now_s: float) -> list[dict[str, Any]]:
        """The payloads received since the last call; a NaN ``time_s`` becomes the simulated
        time of reception (``now_s`` less the wall time since, the run being paced 1:1)."""
        with self._lock:
            items = list(self._queue)
            self._queue.clear()
            self._queued_rows = 0
        wall = time.monotonic()
        out = []
        for received, payload, _n in items:
            t = payload.get("time_s")
            if t is not None:
                try:
                    a = np.array(t, dtype=float).reshape(-1)
                except (TypeError, ValueError):
                    out.append(payload)  # counted by the checker
                    continue
                # before the run's start: negative, so the latest state stands
                a[np.isnan(a)] = now_s - (wall - received)
                payload = {**payload, "time_s": a}
            out.append(payload)
        return out

    def stats(self) -> dict[str, Any]:
        with self._lock:
            return {"endpoint": self.endpoint, "messages": self.messages, "rows": self.rows,
                    "dropped": self.dropped, "bad_messages": dict(sorted(self.bad.items()))}

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)
        self._sock.close(0)


class RecordedEntities:
    """The ``entities`` messages of a recording, handed back at their times: a live session
    re-simulated (fast mode, any seed)."""

    def __init__(self, path: str | Path):
        from shipradar.sim.stream.recording import read_recording

        self.endpoint = str(path)
        self._items: list[tuple[float, dict[str, Any]]] = []
        try:
            with read_recording(path) as reader:
                for _t_rec, frames in reader:
                    if bytes(frames[0]) != TOPIC_ENTITIES:
                        continue
                    _topic, t, payload = decode(frames)
                    self._items.append((t, payload))
        except (OSError, ProtocolError, ValueError) as exc:
            raise EntitiesError(f"--entities: cannot read the recording {str(path)!r} "
                                f"({exc})") from None
        self._next = 0
        self.messages = len(self._items)
        self.bad: dict[str, int] = {}

    def drain(self, now_s: float) -> list[dict[str, Any]]:
        """The recorded payloads up to ``now_s`` (their times are resolved already)."""
        out = []
        while self._next < len(self._items) and self._items[self._next][0] <= now_s + 1e-9:
            out.append(self._items[self._next][1])
            self._next += 1
        return out

    def stats(self) -> dict[str, Any]:
        return {"recording": self.endpoint, "messages": self.messages}

    def close(self) -> None:
        pass


def entity_source(spec: str, queue_size: int) -> EntityFeed | RecordedEntities:
    """``--entities SPEC``: a recording when ``SPEC`` is an existing file, else an endpoint."""
    if "://" not in spec:
        if Path(spec).is_file():
            return RecordedEntities(spec)
        raise EntitiesError(f"--entities: {spec!r} is neither a recording file nor a ZeroMQ "
                            f"endpoint (tcp://HOST:PORT, ipc://PATH)")
    return EntityFeed(spec, queue_size)
