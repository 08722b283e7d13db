"""The viewer's web server: one page, one WebSocket per browser, a live stream or a replay.

Two kinds of source:

- **Live** (a ZeroMQ endpoint of ``shipradar run``/``replay``): one SUB socket reads the
  stream as fast as it comes and fans each message out to every browser's bounded queue.
  Fan-out never waits for a browser, so a slow page cannot slow the ZeroMQ reader, hence
  never makes the simulator pace or drop (docs/viewer.md, "Backpressure").
- **Recording**: every browser gets its own player (play, pause, speed, seek) reading the
  file with :class:`shipradar.sim.stream.recording.RecordingReader` and pacing it by simulated time.

Per browser, a sender task takes whatever is queued and sends it as one batch
(:func:`.wire.pack_batch`): a page that keeps up gets one batch per stream message, a slow
one gets fewer, larger batches, and when its queue is full the oldest items are dropped and
counted; the count is on the page's status line.
"""

from __future__ import annotations

import asyncio
import collections
import ipaddress
import json
import logging
import math
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aiohttp import WSMsgType, web

from shipradar.sim.adapters.viewer.wire import (
    MAX_BATCH_BYTES,
    ViewError,
    item_weight,
    pack_batch,
    to_view,
)
from shipradar.sim.stream.bus import EndpointError
from shipradar.sim.stream.protocol import MAX_BODY_BYTES, ProtocolError, decode
from shipradar.sim.stream.recording import RecordingError, RecordingReader, read_recording

if TYPE_CHECKING:  # zmq is imported when a live source opens
    import zmq.asyncio

__all__ = [
    "DEFAULT_MAX_QUEUE",
    "DEFAULT_PORT",
    "MAX_FADE_SCANS",
    "MAX_SPEED",
    "HostError",
    "ViewerServer",
    "check_http_host",
    "run_viewer",
]

log = logging.getLogger(__name__)

DEFAULT_PORT: int = 8765
#: View items queued per browser before the oldest are dropped.
DEFAULT_MAX_QUEUE: int = 4096
#: Longest fade the page offers [scans]; bounds what a late joiner or a seek is sent.
MAX_FADE_SCANS: int = 50
#: Replay speeds the page offers [simulated s per wall s].
MIN_SPEED, MAX_SPEED = 1.0, 100.0
#: Largest message a page may send (its controls are a few dozen bytes) [bytes].
MAX_CONTROL_BYTES: int = 4096
# Kernel send buffer of a page's socket [bytes]: small, so a slow page's backlog builds in
# its queue (where it is coalesced, dropped and counted) instead of in the kernel, where it
# would only add latency.
_WS_SNDBUF = 64 * 1024
# Stream messages read between two yields to the pages' senders during a burst.
_YIELD_EVERY = 16
# Target truth points (targets x ends of scan) a recording source keeps for seeks.
_MAX_TRUTH_POINTS = 2_000_000
# How often the server tells the pages its clock and counters [s].
_CLOCK_PERIOD_S = 0.25
STATIC = Path(__file__).with_name("static")


class HostError(ValueError):
    """An HTTP host the viewer refuses to bind."""


def check_http_host(host: str, *, allow_remote: bool = False) -> None:
    """Refuse a listening address reachable from other machines unless allowed.

    Parameters
    ----------
    host : str
        Address to listen on (``127.0.0.1``, ``::1``, ``localhost``, ...).
    allow_remote : bool, optional
        Accept any address. The page and its WebSocket have no authentication.

    Raises
    ------
    HostError
        If ``host`` is not a loopback address and ``allow_remote`` is False.
    """
    if allow_remote or host == "localhost":
        return
    try:
        loopback = ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        loopback = False
    if not loopback:
        raise HostError(f"--host {host} is reachable from other machines; use a loopback "
                        "address (127.0.0.1, ::1) or pass --allow-remote")


def _wall_ms() -> float:
    return time.time() * 1000.0


class Client:
    """One browser: a bounded queue of view items and the task that sends them.

    Parameters
    ----------
    ws : aiohttp.web.WebSocketResponse
        The page's WebSocket.
    max_queue : int
        Items queued before the oldest are dropped.
    """

    def __init__(self, ws: web.WebSocketResponse, max_queue: int) -> None:
        self.ws = ws
        self.max_queue = max_queue
        self.queue: collections.deque[dict[str, Any]] = collections.deque()
        # Controls (info, reset, clock, errors) are few and are never dropped; the clock is
        # coalesced to its latest value.
        self.controls: list[dict[str, Any]] = []
        self.clock: dict[str, Any] | None = None
        self.dropped = 0
        self.items_sent = 0
        self.batches_sent = 0
        self._ready = asyncio.Event()

    def push(self, item: dict[str, Any]) -> None:
        """Queue a view item; never waits (drops the oldest item when full)."""
        if len(self.queue) >= self.max_queue:
            self.queue.popleft()
            self.dropped += 1
        self.queue.append(item)
        self._ready.set()

    def control(self, item: dict[str, Any]) -> None:
        """Queue a control item (sent before the queued items of the next batch)."""
        if item.get("k") == "reset":
            self.queue.clear()  # what was queued before a seek is stale
        self.controls.append(item)
        self._ready.set()

    def set_clock(self, clock: dict[str, Any]) -> None:
        """Replace the clock sent with the next batch."""
        self.clock = clock
        self._ready.set()

    def status(self) -> dict[str, Any]:
        return {"dropped": self.dropped, "queued": len(self.queue),
                "items_sent": self.items_sent, "batches_sent": self.batches_sent}

    async def sender(self, extra_status) -> None:
        """Send batches until the socket closes."""
        while not self.ws.closed:
            await self._ready.wait()
            self._ready.clear()
            items = self.controls
            self.controls = []
            size = 0
            while self.queue and size < MAX_BATCH_BYTES:
                item = self.queue.popleft()
                size += item_weight(item)
                items.append(item)
            if self.queue:
                self._ready.set()  # the rest goes in the next batch
            if self.clock is not None:
                items.append(self.clock)
                self.clock = None
            data = pack_batch(items, {**extra_status(), **self.status()}, _wall_ms())
            await self.ws.send_bytes(data)
            self.items_sent += len(items)
            self.batches_sent += 1


# ----------------------------------------------------------------------------- live
class LiveSource:
    """A ZeroMQ stream read continuously and fanned out to the pages.

    Parameters
    ----------
    endpoints : list of str
        The stream's endpoint first, then any tracker endpoints publishing ``tracks``.
    context : zmq.asyncio.Context or None, optional
        Context (needed for ``inproc://``); default a private one.
    curve : shipradar.sim.stream.security.CurveClient or None, optional
        CurveZMQ keys for the subscription (every endpoint of this source is then a CURVE
        publisher holding the matching server key).

    Notes
    -----
    Keeps what a page opened later needs: each sensor's last ``meta``, its recent ``eos``
    and truth states, and its plots of the last :data:`MAX_FADE_SCANS` scans.
    """

    live = True

    def __init__(self, endpoints: list[str], context=None, curve=None) -> None:
        self.endpoints = endpoints
        self._context = context
        self._curve = curve
        self._ctx: zmq.asyncio.Context | None = None
        self._sock: zmq.asyncio.Socket | None = None
        self.clients: set[Client] = set()
        self.received = 0
        self.bad = 0
        self.t_last: float | None = None
        self._rate = 0.0  # simulated s per wall s, smoothed
        self._rate_ref: tuple[float, float] | None = None
        self._meta: dict[str, dict] = {}
        self._recent: dict[str, collections.deque] = {}
        self._latest_scan: dict[str, int] = {}
        self._tracks: collections.deque = collections.deque(maxlen=MAX_FADE_SCANS * 4)
        self.first_message = asyncio.Event()

    def status(self) -> dict[str, Any]:
        return {"mode": "live", "received": self.received, "bad": self.bad}

    def info(self) -> dict[str, Any]:
        return {"k": "info", "mode": "live", "source": self.endpoints[0],
                "tracks": self.endpoints[1:], "t0": 0.0, "t1": self.t_last}

    def clock(self) -> dict[str, Any]:
        return {"k": "clock", "t": self.t_last, "playing": True, "speed": self._rate,
                "live": True, "ended": False, "wall_ms": _wall_ms()}

    def attach(self, client: Client) -> None:
        """Send a new page what it needs to draw the recent scans, then the stream."""
        client.control(self.info())
        backlog = [*self._meta.values(), *self._tracks]
        for dq in self._recent.values():
            backlog.extend(dq)
        backlog.sort(key=lambda it: it["t"])  # stable: same-time items keep stream order
        for item in backlog:
            client.push(item)
        client.set_clock(self.clock())
        self.clients.add(client)

    def detach(self, client: Client) -> None:
        self.clients.discard(client)

    def _remember(self, item: dict[str, Any]) -> None:
        k = item["k"]
        if k == "meta":
            self._meta[item["sensor"]] = item
            return
        if k == "tracks":
            self._tracks.append(item)
            return
        sensor = item["sensor"]
        dq = self._recent.setdefault(sensor, collections.deque())
        dq.append(item)
        scan = item.get("scan")
        if scan is not None and scan > self._latest_scan.get(sensor, -1):
            self._latest_scan[sensor] = scan
            keep_from = scan - MAX_FADE_SCANS
            while dq and dq[0].get("scan", scan) < keep_from:
                dq.popleft()
            if k == "targets":  # no scan key: bounded by the item count instead
                pass
        while len(dq) > 64 * MAX_FADE_SCANS * 4:
            dq.popleft()

    def _tick_rate(self, t: float) -> None:
        now = time.monotonic()
        if self._rate_ref is None:
            self._rate_ref = (now, t)
            return
        w0, t0 = self._rate_ref
        if now - w0 >= 0.5:
            rate = max(0.0, (t - t0) / (now - w0))
            self._rate = rate if self._rate == 0 else 0.5 * self._rate + 0.5 * rate
            self._rate_ref = (now, t)

    def open(self) -> None:
        """Create the SUB socket and connect it to every endpoint.

        Raises
        ------
        EndpointError
            If an endpoint is malformed or cannot be connected to.
        """
        import zmq
        import zmq.asyncio

        self._ctx = self._context or zmq.asyncio.Context()
        sock = self._sock = self._ctx.socket(zmq.SUB)
        sock.setsockopt(zmq.LINGER, 0)
        # A message larger than any valid one drops the connection instead of being
        # allocated (as shipradar tail).
        sock.setsockopt(zmq.MAXMSGSIZE, MAX_BODY_BYTES + 1024)
        # The reader never waits for a page, so this queue only absorbs bursts of the
        # stream itself; the publisher's own rules apply beyond it (docs/protocol.md §8).
        sock.setsockopt(zmq.RCVHWM, 100_000)
        if self._curve is not None:
            self._curve.apply(sock)
        for ep in self.endpoints:
            try:
                sock.connect(ep)
            except zmq.ZMQError as exc:
                self.close()
                raise EndpointError(f"cannot connect to {ep}: {exc}") from None
        sock.setsockopt(zmq.SUBSCRIBE, b"")

    def close(self) -> None:
        if self._sock is not None:
            self._sock.close(0)
            self._sock = None
        if self._context is None and self._ctx is not None:
            self._ctx.term()
            self._ctx = None

    async def run(self) -> None:
        """Read the stream until cancelled (after :meth:`open`)."""
        sock = self._sock
        if sock is None:
            raise RuntimeError("open() the live source before running it")
        try:
            while True:
                frames = await sock.recv_multipart(copy=True)
                self.received += 1
                try:
                    topic, t, payload = decode(frames)
                    item = to_view(topic, t, payload)
                except (ProtocolError, ViewError) as exc:
                    self.bad += 1
                    if self.bad == 1:
                        log.warning("skipping an unreadable message: %s", exc)
                    continue
                if item is None:
                    continue
                if item["k"] != "tracks":
                    self.t_last = t if self.t_last is None else max(self.t_last, t)
                    self._tick_rate(self.t_last)
                self._remember(item)
                for client in self.clients:
                    client.push(item)
                self.first_message.set()
                if self.received % _YIELD_EVERY == 0:
                    # a ready socket completes recv without yielding: let the pages' senders
                    # run during a burst, or a page that keeps up would see drops
                    await asyncio.sleep(0)
        finally:
            self.close()

    async def run_clock(self) -> None:
        while True:
            await asyncio.sleep(_CLOCK_PERIOD_S)
            if self.t_last is not None:
                clock = self.clock()
                for client in self.clients:
                    client.set_clock(clock)


# ----------------------------------------------------------------------------- replay
class RecordingSource:
    """A recording, replayed for each page by its own :class:`Player`.

    Parameters
    ----------
    path : str or Path
        The recording. It is read once on opening (every CRC checked) to learn its time
        span and sensors; a bad file raises :class:`shipradar.sim.stream.recording.RecordingError`
        then.
    """

    live = False

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        first: float | None = None
        last: float | None = None
        self.records = 0
        self.meta: dict[str, dict] = {}
        self.truncated = False
        #: Target truth states of the whole recording (one item per time), so that a page
        #: that seeks draws the targets' whole past, not only the fade window's.
        self.truth: list[dict] = []
        truth_times: set[float] = set()
        truth_points = 0
        with read_recording(self.path) as reader:
            for t, frames in reader:
                if first is None:
                    first = t
                last = t
                self.records += 1
                topic = bytes(frames[0])
                if topic not in (b"meta", b"truth"):
                    continue
                try:
                    item = to_view(topic, *decode(frames)[1:])
                except (ProtocolError, ViewError):
                    continue
                if item is None:
                    continue
                if item["k"] == "meta" and item["sensor"] not in self.meta:
                    self.meta[item["sensor"]] = item
                elif item["k"] == "targets" and item["t"] not in truth_times \
                        and truth_points < _MAX_TRUTH_POINTS:
                    # each radar sends the same states at its ends of scan: one per time
                    truth_times.add(item["t"])
                    truth_points += item["e"].size
                    self.truth.append(item)
            self.truncated = reader.truncated
        #: Simulated times of the first and last message [s] (0 for an empty recording).
        self.t0: float = 0.0 if first is None else first
        self.t1: float = self.t0 if last is None else last
        self.clients: set[Client] = set()

    @property
    def window_s(self) -> float:
        """Simulated time of one scan of the slowest radar [s] (1 s if none)."""
        return max((m["period"] for m in self.meta.values()), default=1.0)

    def status(self) -> dict[str, Any]:
        return {"mode": "recording"}

    def info(self) -> dict[str, Any]:
        return {"k": "info", "mode": "recording", "source": str(self.path), "t0": self.t0,
                "t1": self.t1, "records": self.records, "truncated": self.truncated}


class Player:
    """One page's replay of a recording: play, pause, speed, seek.

    Message i goes out at wall time ``w + (t_i - t_w) / speed`` where ``(w, t_w)`` is the
    last anchor (play, speed change or seek), as ``shipradar replay`` does; a seek sends the
    scans before the new time at once, so the page shows the plots that would still be fading.
    """

    def __init__(self, source: RecordingSource, client: Client, speed: float) -> None:
        self.source = source
        self.client = client
        self.speed = speed
        self.playing = False
        self.ended = False
        self.t = source.t0
        self._anchor = (time.monotonic(), source.t0)
        self._wake = asyncio.Event()
        self._records: Iterator[tuple[float, list[bytes]]] | None = None
        self._reader: RecordingReader | None = None
        self._pending: collections.deque = collections.deque()
        self.bad = 0
        self._seek_to: tuple[float, int] | None = (source.t0, 0)

    # -- controls (from the page) ---------------------------------------------------------
    def now(self) -> float:
        """Current simulated time of the replay [s]."""
        if not self.playing:
            return self.t
        w, tw = self._anchor
        return min(self.source.t1, tw + (time.monotonic() - w) * self.speed)

    def play(self) -> None:
        if self.ended:
            self.seek(self.source.t0, 0)
        self._anchor = (time.monotonic(), self.t)
        self.playing = True
        self._changed()

    def pause(self) -> None:
        self.t = self.now()
        self.playing = False
        self._changed()

    def set_speed(self, speed: float) -> None:
        self.t = self.now()
        self._anchor = (time.monotonic(), self.t)
        self.speed = speed
        self._changed()

    def seek(self, t: float, window_scans: int) -> None:
        self._seek_to = (min(max(t, self.source.t0), self.source.t1), window_scans)
        self._changed()

    def _changed(self) -> None:
        self.client.set_clock(self.clock())
        self._wake.set()

    def clock(self) -> dict[str, Any]:
        return {"k": "clock", "t": self.now(), "playing": self.playing, "speed": self.speed,
                "live": False, "ended": self.ended, "wall_ms": _wall_ms()}

    # -- reading --------------------------------------------------------------------------
    def _open(self) -> None:
        self._close()
        self._reader = read_recording(self.source.path)
        self._records = iter(self._reader)
        self._pending.clear()

    def _close(self) -> None:
        if self._reader is not None:
            self._reader.close()
            self._reader = None

    def _iter_records(self) -> Iterator[tuple[float, list[bytes]]]:
        """The open recording's records from where the reader stands (opened if need be)."""
        if self._records is None:
            self._open()
        assert self._records is not None  # _open sets it
        return self._records

    def _read_chunk(self, n: int = 512) -> int:
        """Read up to n records into the pending queue (runs in a worker thread)."""
        got = 0
        for t, frames in self._iter_records():
            self._pending.append((t, frames))
            got += 1
            if got >= n:
                break
        return got

    def _skip_before(self, t_from: float) -> None:
        """Position the reader at the first record at or after ``t_from`` (worker thread).

        The file is read from its start: records are variable-length and the reader checks
        each CRC, so this costs a sequential read of the skipped part (a few ms per MB).
        """
        self._open()
        for t, frames in self._iter_records():
            if t >= t_from:
                self._pending.append((t, frames))
                return

    def _view(self, t: float, frames: list[bytes]) -> dict[str, Any] | None:
        try:
            return to_view(*decode(frames))
        except (ProtocolError, ViewError):
            self.bad += 1
            return None

    async def _do_seek(self, t: float, window_scans: int) -> None:
        window = max(window_scans, 1) * self.source.window_s
        self.client.control({"k": "reset", "t": t})
        # the meta of every sensor first: the page needs it before any plot
        for meta in self.source.meta.values():
            self.client.push(meta)
        for item in self.source.truth:
            if item["t"] >= t - window:
                break  # the window's own states come with its records
            self.client.push(item)
        await asyncio.to_thread(self._skip_before, t - window)
        while True:
            if not self._pending and not await asyncio.to_thread(self._read_chunk):
                break
            while self._pending and self._pending[0][0] <= t:
                view = self._view(*self._pending.popleft())
                if view is not None:
                    self.client.push(view)
            if self._pending:
                break
        self.t = t
        self._anchor = (time.monotonic(), t)
        self.ended = False
        self.client.set_clock(self.clock())

    async def run(self) -> None:
        """Replay until cancelled (a corrupt record ends the replay with an error item)."""
        try:
            await self._run()
        except RecordingError as exc:
            self.playing, self.ended = False, True
            self.client.control({"k": "error", "message": str(exc)})
            self.client.set_clock(self.clock())
        finally:
            self._close()

    async def _run(self) -> None:
        while True:
            if self._seek_to is not None:
                t, window = self._seek_to
                self._seek_to = None
                await self._do_seek(t, window)
                continue
            if not self.playing:
                await self._wake.wait()
                self._wake.clear()
                continue
            if not self._pending and not await asyncio.to_thread(self._read_chunk):
                self.t = self.source.t1
                self.playing = False
                self.ended = True
                self.client.set_clock(self.clock())
                continue
            t_next = self._pending[0][0]
            w, tw = self._anchor
            delay = w + (t_next - tw) / self.speed - time.monotonic()
            if delay > 0:
                try:
                    await asyncio.wait_for(self._wake.wait(), delay)
                except asyncio.TimeoutError:
                    pass
                self._wake.clear()
                continue  # controls may have changed; re-evaluate
            # every record already due goes out now (a late loop catches up in one go)
            due = tw + (time.monotonic() - w) * self.speed
            while self._pending and self._pending[0][0] <= due:
                item = self._view(*self._pending.popleft())
                if item is not None:
                    self.client.push(item)
            self.t = min(max(self.t, t_next), self.source.t1)


# ----------------------------------------------------------------------------- server
def _number(msg: dict, key: str, lo: float, hi: float) -> float:
    v = msg.get(key)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
            or not lo <= v <= hi:
        raise ValueError(f"{key!r} must be a number in [{lo:g}, {hi:g}], got {v!r}")
    return float(v)


class ViewerServer:
    """The viewer: aiohttp application, its source and its pages.

    Parameters
    ----------
    source : str
        A ZeroMQ endpoint (``tcp://…``, ``ipc://…``) or a recording file.
    host : str, optional
        Address to listen on (see :func:`check_http_host`).
    port : int, optional
        TCP port; 0 picks a free one (read :attr:`url` once started).
    allow_remote : bool, optional
        Listen on a non-loopback address.
    tracks : list of str, optional
        Endpoints of trackers publishing ``tracks`` (live or recording source alike).
    speed : float, optional
        Initial replay speed [x real time], 1 to 100.
    max_queue : int, optional
        Items queued per page before the oldest are dropped.
    autoplay : bool, optional
        A recording starts playing when a page opens (else it waits for play).
    zmq_context : zmq.asyncio.Context or None, optional
        For ``inproc://`` sources.
    curve : shipradar.sim.stream.security.CurveClient or None, optional
        CurveZMQ keys for a live source (``--curve-*``); tracker endpoints are then read on
        a socket of their own, without CURVE.
    """

    def __init__(self, source: str, *, host: str = "127.0.0.1", port: int = DEFAULT_PORT,
                 allow_remote: bool = False, tracks: list[str] | None = None,
                 speed: float = 1.0, max_queue: int = DEFAULT_MAX_QUEUE,
                 autoplay: bool = True, zmq_context=None, curve=None) -> None:
        check_http_host(host, allow_remote=allow_remote)
        if not MIN_SPEED <= speed <= MAX_SPEED:
            raise ValueError(f"speed must be in [{MIN_SPEED:g}, {MAX_SPEED:g}], got {speed}")
        if max_queue < 1:
            raise ValueError(f"max_queue must be >= 1, got {max_queue}")
        self.host, self.port, self.allow_remote = host, port, allow_remote
        self.speed = speed
        self.autoplay = autoplay
        self.max_queue = max_queue
        self.tracks = list(tracks or [])
        self.is_live = "://" in source
        # A recording is opened (and checked) here, before anything listens.
        self.recording = None if self.is_live else RecordingSource(source)
        self.source_name = source
        self._zmq_context = zmq_context
        self._curve = curve
        self.live: LiveSource | None = None
        self.clients: set[Client] = set()
        self.url: str | None = None
        self._runner: web.AppRunner | None = None
        self._tasks: list[asyncio.Task] = []

    # -- pages ------------------------------------------------------------------------------
    def app(self) -> web.Application:
        app = web.Application(client_max_size=MAX_CONTROL_BYTES)
        app.router.add_get("/", self._index)
        app.router.add_get("/ws", self._websocket)
        app.router.add_get("/status.json", self._status)
        app.router.add_static("/static/", STATIC, show_index=False, follow_symlinks=False)
        return app

    async def _index(self, request: web.Request) -> web.StreamResponse:
        return web.FileResponse(STATIC / "index.html",
                                headers={"Cache-Control": "no-store"})

    def _replay(self) -> RecordingSource:
        """The recording a replay viewer shows (a live viewer has none)."""
        if self.recording is None:
            raise RuntimeError("a live viewer has no recording to replay")
        return self.recording

    def _server_status(self) -> dict[str, Any]:
        src = self.live.status() if self.live is not None else self._replay().status()
        return {**src, "pages": len(self.clients)}

    async def _status(self, request: web.Request) -> web.Response:
        body = {**self._server_status(),
                "clients": [c.status() for c in self.clients]}
        return web.json_response(body)

    def _same_origin(self, request: web.Request) -> bool:
        # A page from another site must not read the stream through the user's browser
        # (cross-site WebSocket hijacking, DNS rebinding): the Origin, when sent, must be
        # this server.
        origin = request.headers.get("Origin")
        if origin is None:
            return True  # not a browser (a script, a test client)
        return origin in (f"http://{request.host}", f"https://{request.host}")

    async def _websocket(self, request: web.Request) -> web.StreamResponse:
        if not self._same_origin(request):
            raise web.HTTPForbidden(text="cross-origin WebSocket refused")
        ws = web.WebSocketResponse(max_msg_size=MAX_CONTROL_BYTES, heartbeat=20.0,
                                   compress=False)
        await ws.prepare(request)
        sock = request.transport.get_extra_info("socket") if request.transport else None
        if sock is not None:
            try:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, _WS_SNDBUF)
            except OSError:
                pass
        client = Client(ws, self.max_queue)
        self.clients.add(client)
        sender = asyncio.create_task(client.sender(self._server_status))
        player = None
        player_task = None
        if self.live is not None:
            self.live.attach(client)
        else:
            client.control(self._replay().info())
            player = Player(self._replay(), client, self.speed)
            if self.autoplay:
                player.play()
            player_task = asyncio.create_task(player.run())
        try:
            async for msg in ws:
                if msg.type != WSMsgType.TEXT:
                    if msg.type == WSMsgType.ERROR:
                        break
                    continue
                try:
                    self._control(json.loads(msg.data), player)
                except (ValueError, TypeError, AttributeError) as exc:
                    client.control({"k": "error", "message": f"control refused: {exc}"})
        finally:
            self.clients.discard(client)
            if self.live is not None:
                self.live.detach(client)
            for task in (sender, player_task):
                if task is not None:
                    task.cancel()
            await asyncio.gather(*(t for t in (sender, player_task) if t is not None),
                                 return_exceptions=True)
        return ws

    def _control(self, msg: Any, player: Player | None) -> None:
        """Apply one control message from a page (play, pause, speed, seek)."""
        if not isinstance(msg, dict):
            raise ValueError("a control is a JSON object")
        cmd = msg.get("cmd")
        if cmd == "hello":
            return
        if player is None:
            raise ValueError(f"{cmd!r}: a live stream cannot be paused or seeked on the "
                             "server (the page freezes its own display)")
        if cmd == "play":
            player.play()
        elif cmd == "pause":
            player.pause()
        elif cmd == "speed":
            player.set_speed(_number(msg, "value", MIN_SPEED, MAX_SPEED))
        elif cmd == "seek":
            src = self._replay()
            t = _number(msg, "t", src.t0, src.t1)
            window = int(_number(msg, "window_scans", 0, MAX_FADE_SCANS)) \
                if "window_scans" in msg else 10
            player.seek(t, window)
        else:
            raise ValueError(f"unknown command {cmd!r} (play, pause, speed, seek)")

    # -- life cycle -------------------------------------------------------------------------
    async def start(self) -> str:
        """Listen and start reading the source; returns the page's URL."""
        # a CURVE stream needs its own socket: the keys apply to every connection of one
        separate_tracks = bool(self.tracks) and (not self.is_live or self._curve is not None)
        if self.is_live:
            shared = [] if separate_tracks else self.tracks
            self.live = LiveSource([self.source_name, *shared], self._zmq_context, self._curve)
            self.live.open()
            self._tasks += [asyncio.create_task(self.live.run()),
                            asyncio.create_task(self.live.run_clock())]
        if separate_tracks:
            # tracks from a tracker beside a replay go to every page as they come; the page
            # draws each when its replay reaches the track's time
            self._tracks_source = LiveSource(self.tracks, self._zmq_context)
            self._tracks_source.clients = self.clients
            self._tracks_source.open()
            self._tasks.append(asyncio.create_task(self._tracks_source.run()))
        self._runner = web.AppRunner(self.app(), access_log=None)
        await self._runner.setup()
        site = web.TCPSite(self._runner, self.host, self.port)
        try:
            await site.start()
        except OSError:
            await self.stop()
            raise
        # the bound port (port 0: the kernel's choice), from the runner's public socket list
        addresses = self._runner.addresses
        port = addresses[0][1] if addresses else self.port
        host = f"[{self.host}]" if ":" in self.host else self.host
        self.url = f"http://{host}:{port}/"
        return self.url

    async def stop(self) -> None:
        for task in self._tasks:
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        self._tasks = []
        for client in list(self.clients):
            await client.ws.close()
        if self._runner is not None:
            await self._runner.cleanup()
            self._runner = None


def run_viewer(server: ViewerServer, *, open_browser: bool = False, out=None) -> None:
    """Serve until interrupted (Ctrl-C).

    Parameters
    ----------
    server : ViewerServer
        The configured viewer.
    open_browser : bool, optional
        Open the page in the default browser once listening.
    out : TextIO or None, optional
        Where the URL line goes (default stderr).
    """
    import sys
    import webbrowser

    out = sys.stderr if out is None else out

    async def main() -> None:
        url = await server.start()
        print(f"shipradar view: {url}  ({server.source_name}; Ctrl-C to stop)", file=out,
              flush=True)
        if open_browser:
            webbrowser.open(url)
        try:
            await asyncio.Event().wait()
        finally:
            await server.stop()

    asyncio.run(main())


class ViewerThread:
    """A viewer served from a background thread (tests, screenshots).

    Parameters
    ----------
    server : ViewerServer
        The configured viewer (``port=0`` picks a free port).
    """

    def __init__(self, server: ViewerServer) -> None:
        self.server = server
        self.loop = asyncio.new_event_loop()
        self._started = threading.Event()
        self._error: BaseException | None = None
        self._stop: asyncio.Event | None = None
        self._thread = threading.Thread(target=self._main, name="shipradar-viewer",
                                        daemon=True)

    def _main(self) -> None:
        asyncio.set_event_loop(self.loop)

        async def main() -> None:
            self._stop = asyncio.Event()
            try:
                await self.server.start()
            except BaseException as exc:
                self._error = exc
                self._started.set()
                return
            self._started.set()
            try:
                await self._stop.wait()
            finally:
                await self.server.stop()

        self.loop.run_until_complete(main())
        self.loop.close()

    def start(self, timeout_s: float = 10.0) -> str:
        """Start serving; returns the URL."""
        self._thread.start()
        if not self._started.wait(timeout_s):
            raise TimeoutError("viewer did not start")
        if self._error is not None:
            raise self._error
        if self.server.url is None:
            raise RuntimeError("viewer started without an address")
        return self.server.url

    def call(self, fn, timeout_s: float = 10.0):
        """Run ``fn()`` on the viewer's loop and return its result."""
        async def wrap():
            return fn()
        return asyncio.run_coroutine_threadsafe(wrap(), self.loop).result(timeout_s)

    def stop(self, timeout_s: float = 10.0) -> None:
        if self._stop is not None and self._thread.is_alive():
            self.loop.call_soon_threadsafe(self._stop.set)
        self._thread.join(timeout_s)

    def __enter__(self) -> ViewerThread:
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop()
