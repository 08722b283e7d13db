"""Transport of the stream: ZeroMQ publisher, the run's bus, replay of a recording, and tail.

The message format lives in :mod:`shipradar.sim.stream.protocol` and the file format in
:mod:`shipradar.sim.stream.recording`; this module owns the sockets. Behaviour a subscriber can rely
on is in docs/protocol.md ("Transport", "Replay", "Backpressure").
"""

from __future__ import annotations

import ipaddress
import json
import logging
import sys
import time
from collections import Counter
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TextIO

if TYPE_CHECKING:
    import zmq

from shipradar.sim.stream.protocol import MAX_BODY_BYTES, ProtocolError, decode, encode, to_jsonable
from shipradar.sim.stream.recording import Recorder, RecordingReader, read_recording
from shipradar.sim.stream.sink import Closing
from shipradar.sim.world.errors import BadInputError, PeerError

__all__ = [
    "DEFAULT_LINGER_MS",
    "DEFAULT_SNDHWM",
    "Bus",
    "EndpointError",
    "Publisher",
    "PublisherStalledError",
    "ReplaySettings",
    "RunInterrupted",
    "SubscriberTimeoutError",
    "check_bind_endpoint",
    "message_json",
    "replay",
    "tail",
]

log = logging.getLogger(__name__)

#: Messages queued per subscriber before backpressure starts (ZeroMQ's own default).
DEFAULT_SNDHWM: int = 1000
#: How long :meth:`Publisher.close` keeps delivering queued messages [ms].
DEFAULT_LINGER_MS: int = 5000
# Period of the wake-ups while paced by a slow subscriber [ms]: bounds the latency of the
# stall check; the wait itself is event-driven inside libzmq.
_PACE_SLICE_MS = 100
_ON_SLOW = ("pace", "drop")
# Messages between two looks at pending (un)subscriptions while sending.
_DRAIN_EVERY = 64


class EndpointError(ValueError, BadInputError):
    """An endpoint the publisher refuses to bind."""


class SubscriberTimeoutError(TimeoutError, PeerError):
    """The expected subscribers did not all subscribe in time."""


class PublisherStalledError(TimeoutError, PeerError):
    """In pace mode, a subscriber stopped reading for longer than the stall timeout."""


class RunInterrupted(Exception):
    """Raised by :meth:`Bus.flush` (an end of scan) once a stop was requested (SIGTERM,
    Ctrl-C): the run ends on a whole scan, with the recording complete up to it."""


def check_bind_endpoint(endpoint: str, *, allow_remote: bool = False,
                        secured: bool = False) -> bool:
    """Refuse endpoints reachable from other machines unless secured or explicitly allowed.

    Parameters
    ----------
    endpoint : str
        ZeroMQ endpoint to bind, e.g. ``tcp://127.0.0.1:5555``, ``tcp://127.0.0.1:*``,
        ``ipc:///tmp/radar``, ``inproc://radar``.
    allow_remote : bool, optional
        Accept any endpoint (``tcp://0.0.0.0:5555``, ``tcp://*:5555``, an interface name or
        a non-loopback address) without CURVE. The stream is unauthenticated and
        unencrypted: only do this on a trusted network.
    secured : bool, optional
        The stream is CURVE-authenticated and encrypted (:mod:`shipradar.sim.stream.security`): any
        TCP endpoint is accepted.

    Returns
    -------
    bool
        True if the bind is an insecure remote one: reachable from other machines without
        CURVE, accepted only because ``allow_remote`` is True (the command line warns and
        records ``insecure_remote`` in the run summary); False for a local or secured bind.

    Raises
    ------
    EndpointError
        If the endpoint is malformed, or is neither ``ipc://``, ``inproc://`` nor TCP on a
        loopback address (127.0.0.0/8, ::1, localhost) while neither ``secured`` (TCP) nor
        ``allow_remote`` is True.
    """
    scheme, sep, rest = endpoint.partition("://")
    if not sep or not rest:
        raise EndpointError(f"malformed endpoint {endpoint!r}: expected e.g. tcp://127.0.0.1:5555")
    if scheme in ("ipc", "inproc") or (secured and scheme == "tcp"):
        return False
    hint = ("bind a loopback address such as tcp://127.0.0.1:5555, secure the stream with "
            "CURVE (--curve-secret-key and --curve-authorized; shipradar keys generate DIR), "
            "or accept anyone on the network with --allow-insecure-remote")
    if scheme != "tcp":
        if allow_remote:
            return True
        raise EndpointError(
            f"refusing to bind {endpoint}: transport {scheme!r} is not local; {hint}"
        )
    host, colon, _port = rest.rpartition(":")
    if not colon:
        if allow_remote:  # ZeroMQ will refuse it; not this function's concern then
            return True
        raise EndpointError(f"malformed endpoint {endpoint!r}: no port")
    host = host.strip("[]")
    if host == "localhost":
        return False
    try:
        loopback = ipaddress.ip_address(host).is_loopback
    except ValueError:  # '*', an interface name, a host name
        loopback = False
    if loopback:
        return False
    if allow_remote:
        return True
    raise EndpointError(
        f"refusing to bind {endpoint}: it is reachable from other machines; {hint}"
    )


def _topic_str(topic: bytes) -> str:
    return topic.decode("utf-8", "backslashreplace")


class Publisher(Closing):
    """ZeroMQ publisher of encoded messages, with subscriber counting and no silent loss.

    An XPUB socket (``XPUB_VERBOSER``: every subscribe and unsubscribe of every subscriber
    is seen; ``XPUB_NODROP``: a full queue refuses the message instead of dropping it).

    Parameters
    ----------
    endpoint : str
        Endpoint to bind (see :func:`check_bind_endpoint`); ``tcp://127.0.0.1:*`` picks a free
        port, read back from :attr:`endpoint`.
    wait_subscribers : int, optional
        Subscribers to wait for before the first message is sent (0: do not wait).
    wait_timeout_s : float, optional
        How long :meth:`wait_for_subscribers` waits [s].
    on_slow : {"pace", "drop"}, optional
        When a subscriber's queue is full (``sndhwm`` messages): ``"pace"`` waits until it
        drains, so the run slows to the slowest subscriber and nothing is lost; ``"drop"``
        drops the message (for every subscriber, this is how ``XPUB_NODROP`` works), counts it
        by topic in :attr:`stats` and logs a warning on the first drop.
    sndhwm : int, optional
        Messages queued per subscriber before ``on_slow`` applies (0: unbounded memory).
    allow_remote : bool, optional
        Allow binding non-loopback endpoints (see :func:`check_bind_endpoint`).
    stall_timeout_s : float or None, optional
        In pace mode, raise :class:`PublisherStalledError` if one message waits this long
        [s]. None (default) waits as long as the subscriber needs.
    context : zmq.Context or None, optional
        Context to use (needed for ``inproc://`` peers). By default the publisher owns a
        private context, which lets :meth:`close` block until queued messages are delivered.
    curve : shipradar.sim.stream.security.CurveServer or None, optional
        Authenticate subscribers and encrypt the stream with CurveZMQ: only subscribers
        whose public key is authorised complete the handshake (the others receive nothing
        and are not counted as subscribers). A CURVE publisher may bind any TCP endpoint.

    Notes
    -----
    Subscribers are counted from subscription messages: for each topic prefix the number of
    subscribers currently subscribed to it; :attr:`subscribers` is the largest such count.
    It never exceeds the number of distinct subscribers and equals it when they all subscribe
    to a common prefix (all topics ``b""``, or ``b"plots"``, ...), which is what trackers do.
    """

    def __init__(
        self,
        endpoint: str,
        *,
        wait_subscribers: int = 0,
        wait_timeout_s: float = 30.0,
        on_slow: str = "pace",
        sndhwm: int = DEFAULT_SNDHWM,
        allow_remote: bool = False,
        stall_timeout_s: float | None = None,
        context: zmq.Context | None = None,
        curve: Any = None,
    ) -> None:
        import zmq  # imported when used: a run without --publish never loads it
        if on_slow not in _ON_SLOW:
            raise ValueError(f"on_slow must be one of {_ON_SLOW}, got {on_slow!r}")
        if wait_subscribers < 0:
            raise ValueError(f"wait_subscribers must be >= 0, got {wait_subscribers}")
        if sndhwm < 0:
            raise ValueError(f"sndhwm must be >= 0, got {sndhwm}")
        check_bind_endpoint(endpoint, allow_remote=allow_remote, secured=curve is not None)
        self.wait_subscribers = wait_subscribers
        self.wait_timeout_s = wait_timeout_s
        self.on_slow = on_slow
        self.stall_timeout_s = stall_timeout_s
        self._own_context = context is None
        self.context: zmq.Context = zmq.Context() if context is None else context
        self._sock = self.context.socket(zmq.XPUB)
        self._auth = None
        try:
            if curve is not None:
                # the ZAP handler must run before the socket binds, or early handshakes
                # would go unauthenticated
                self._auth = curve.start_authenticator(self.context)
                curve.apply(self._sock)
            self._sock.setsockopt(zmq.XPUB_VERBOSER, 1)
            self._sock.setsockopt(zmq.XPUB_NODROP, 1)
            self._sock.setsockopt(zmq.SNDHWM, sndhwm)
            self._sock.setsockopt(zmq.SNDTIMEO, _PACE_SLICE_MS)
            self._sock.setsockopt(zmq.LINGER, 0)
            if "[" in endpoint:
                self._sock.setsockopt(zmq.IPV6, 1)
            self._sock.bind(endpoint)
        except zmq.ZMQError as exc:
            self._abort()
            raise EndpointError(f"cannot bind {endpoint}: {exc}") from exc
        except BaseException:
            self._abort()
            raise
        #: The bound endpoint, with the port resolved when ``*`` was asked.
        endpoint_bytes = self._sock.getsockopt(zmq.LAST_ENDPOINT)
        assert isinstance(endpoint_bytes, bytes)  # LAST_ENDPOINT is a bytes option
        self.endpoint: str = endpoint_bytes.decode()
        self._subscriptions: Counter[bytes] = Counter()
        self._waited = wait_subscribers == 0
        self._sent: Counter[bytes] = Counter()
        self._dropped: Counter[bytes] = Counter()
        self._unheard: Counter[bytes] = Counter()
        self._paced_s = 0.0
        self._since_drain = 0
        self._closed = False

    def _abort(self) -> None:
        self._sock.close(linger=0)
        if self._auth is not None:
            self._auth.stop()
        if self._own_context:
            self.context.term()

    # -- subscriptions -------------------------------------------------------------------
    def _drain_subscriptions(self, timeout_ms: int = 0) -> None:
        """Read pending (un)subscription messages, waiting up to ``timeout_ms`` for the first."""
        import zmq
        sock = self._sock
        if not sock.poll(timeout_ms, zmq.POLLIN):
            return
        while True:
            try:
                msg = sock.recv(zmq.NOBLOCK)
            except zmq.Again:
                return
            if not msg:
                continue
            prefix = msg[1:]
            if msg[0] == 1:
                self._subscriptions[prefix] += 1
            elif msg[0] == 0 and self._subscriptions[prefix] > 0:
                self._subscriptions[prefix] -= 1
                if not self._subscriptions[prefix]:
                    del self._subscriptions[prefix]

    @property
    def subscribers(self) -> int:
        """Subscribers currently subscribed (see Notes of the class)."""
        if not self._closed:
            self._drain_subscriptions()
        return max(self._subscriptions.values(), default=0)

    def poll_subscriptions(self, timeout_s: float = 0.0) -> int:
        """Take in (un)subscriptions, waiting up to ``timeout_s`` for the first one.

        Parameters
        ----------
        timeout_s : float, optional
            Longest wait for a subscription change [s]; 0 only reads what is pending.

        Returns
        -------
        int
            :attr:`subscribers` afterwards.
        """
        self._drain_subscriptions(max(0, int(timeout_s * 1000)))
        return self.subscribers

    def wait_for_subscribers(self, n: int | None = None, timeout_s: float | None = None) -> int:
        """Block until ``n`` subscribers have subscribed.

        Parameters
        ----------
        n : int or None, optional
            Subscribers to wait for; default ``wait_subscribers`` of the constructor.
        timeout_s : float or None, optional
            Longest wait [s]; default ``wait_timeout_s`` of the constructor.

        Returns
        -------
        int
            The number of subscribers counted (>= n).

        Raises
        ------
        SubscriberTimeoutError
            If fewer than ``n`` subscribed within the timeout.
        """
        n = self.wait_subscribers if n is None else n
        timeout_s = self.wait_timeout_s if timeout_s is None else timeout_s
        deadline = time.monotonic() + timeout_s
        while True:
            count = self.subscribers
            if count >= n:
                self._waited = True
                return count
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise SubscriberTimeoutError(
                    f"{count} of {n} expected subscriber(s) subscribed to {self.endpoint} "
                    f"within {timeout_s:g} s"
                )
            self._drain_subscriptions(max(1, min(200, int(remaining * 1000))))

    # -- sending -------------------------------------------------------------------------
    def send(self, frames: Sequence[bytes]) -> bool:
        """Publish one message.

        Parameters
        ----------
        frames : Sequence[bytes]
            ``[topic, body]`` from :func:`shipradar.sim.stream.protocol.encode` (sent unchanged).

        Returns
        -------
        bool
            True if sent, False if dropped (``on_slow="drop"`` only; counted in :attr:`stats`).

        Raises
        ------
        SubscriberTimeoutError
            On the first message, if ``wait_subscribers`` were expected and did not come.
        PublisherStalledError
            In pace mode, if ``stall_timeout_s`` is set and was exceeded.
        """
        import zmq
        if self._closed:
            raise RuntimeError("publisher is closed")
        if not self._waited:
            self.wait_for_subscribers()
        sock = self._sock
        self._since_drain += 1
        if self._since_drain >= _DRAIN_EVERY:
            # Reading EVENTS costs about a send, so subscriptions are taken in periodically.
            self._since_drain = 0
            if int(sock.getsockopt(zmq.EVENTS)) & zmq.POLLIN:
                self._drain_subscriptions()
        topic = bytes(frames[0])
        last = len(frames) - 1
        try:
            sock.send(frames[0], zmq.NOBLOCK | (zmq.SNDMORE if last else 0))
        except zmq.Again:
            if self.on_slow == "drop":
                if not self._dropped:
                    log.warning(
                        "subscriber too slow on %s: dropping messages (counted by topic)",
                        self.endpoint,
                    )
                self._dropped[topic] += 1
                return False
            self._send_paced(frames[0], zmq.SNDMORE if last else 0)
        # Later frames of a message pass the same queue check as the first (libzmq counts
        # whole messages), so they do not block; the paced path covers the odd exception.
        for i in range(1, last + 1):
            flags = zmq.SNDMORE if i < last else 0
            try:
                sock.send(frames[i], zmq.NOBLOCK | flags)
            except zmq.Again:
                self._send_paced(frames[i], flags)
        self._sent[topic] += 1
        if not any(topic.startswith(p) for p in self._subscriptions):
            self._unheard[topic] += 1
        return True

    def _send_paced(self, frame: bytes, flags: int) -> None:
        """Blocking send in slices of SNDTIMEO, checking the stall timeout between them."""
        import zmq
        start = time.monotonic()
        try:
            while True:
                try:
                    self._sock.send(frame, flags)
                    return
                except zmq.Again:
                    waited = time.monotonic() - start
                    if self.stall_timeout_s is not None and waited > self.stall_timeout_s:
                        raise PublisherStalledError(
                            f"a subscriber of {self.endpoint} read nothing for {waited:.1f} s"
                        ) from None
        finally:
            self._paced_s += time.monotonic() - start

    @property
    def stats(self) -> dict[str, Any]:
        """Counters, JSON-ready.

        Returns
        -------
        dict
            ``sent`` and ``dropped`` (messages), ``sent_by_topic``, ``dropped_by_topic``,
            ``unheard_by_topic`` (sent while nobody was subscribed to that topic; the
            subscription list is refreshed every 64 messages, so this count is approximate
            around a subscriber's arrival or departure),
            ``subscribers`` (see :attr:`subscribers`) and ``paced_s`` (time spent waiting
            for slow subscribers [s]).
        """
        return {
            "endpoint": self.endpoint,
            "sent": sum(self._sent.values()),
            "dropped": sum(self._dropped.values()),
            "sent_by_topic": {_topic_str(k): v for k, v in self._sent.items()},
            "dropped_by_topic": {_topic_str(k): v for k, v in self._dropped.items()},
            "unheard_by_topic": {_topic_str(k): v for k, v in self._unheard.items()},
            "subscribers": self.subscribers,
            "paced_s": self._paced_s,
        }

    def close(self, linger_ms: int = DEFAULT_LINGER_MS) -> None:
        """Deliver queued messages to connected subscribers, then close (idempotent).

        Parameters
        ----------
        linger_ms : int, optional
            Longest time spent delivering what is still queued [ms]. With a context of its
            own the publisher blocks here until the queue is empty or this expires; with a
            caller's context delivery continues until that context is terminated.
        """
        if self._closed:
            return
        self._drain_subscriptions()
        self._closed = True
        self._sock.close(linger=linger_ms)
        if self._auth is not None:
            self._auth.stop()  # its socket must be closed before the context ends
        if self._own_context:
            self.context.term()



class Bus(Closing):
    """Where the engine emits messages: encoded once, recorded and published identically.

    Parameters
    ----------
    publisher : Publisher or None, optional
        Live stream (``--publish``).
    recorder : Recorder or None, optional
        Recording (``--record``). Each message is written before it is published, so the
        recording holds every message of the run, including any dropped on the live stream.
    """

    #: The engine hands this bus encoded frames (:class:`shipradar.sim.stream.sink.FrameSink`):
    #: it only moves bytes.
    encodes_ahead = True

    def __init__(self, publisher: Publisher | None = None, recorder: Recorder | None = None):
        self.publisher = publisher
        self.recorder = recorder
        self._messages: Counter[bytes] = Counter()
        self._bytes = 0
        #: Set (e.g. by a signal handler) to end the run at the next end of scan.
        self.stop_requested = False
        #: Simulated time of the last message [s] (None before the first).
        self.t_last: float | None = None

    @property
    def accepts_batches(self) -> bool:
        """True without a publisher (:class:`shipradar.sim.stream.sink.BatchSink`): nothing
        live sees the messages as they are made, so a fast run may hand over a scan's
        messages at once (:meth:`emit_many`)."""
        return self.publisher is None

    def emit(self, topic: bytes, t_sim: float, payload: Mapping[str, Any]) -> list[bytes]:
        """Encode one message and send it to the recorder and the publisher.

        Parameters
        ----------
        topic : bytes
            One of :data:`shipradar.sim.stream.protocol.TOPICS`.
        t_sim : float
            Simulated time [s since scenario start].
        payload : Mapping[str, Any]
            Message content (see :func:`shipradar.sim.stream.protocol.encode`).

        Returns
        -------
        list[bytes]
            The frames sent.
        """
        frames = encode(topic, t_sim, payload)
        self.emit_frames(t_sim, frames)
        return frames

    def emit_frames(self, t_sim: float, frames: Sequence[bytes]) -> None:
        """Record and publish already encoded frames unchanged.

        Parameters
        ----------
        t_sim : float
            Simulated time [s since scenario start].
        frames : Sequence[bytes]
            ``[topic, body]``.
        """
        if self.recorder is not None:
            self.recorder.write(t_sim, frames)
        if self.publisher is not None:
            self.publisher.send(frames)
        topic = frames[0]
        self._messages[topic if type(topic) is bytes else bytes(topic)] += 1
        self._bytes += len(topic) + len(frames[1]) if len(frames) == 2 else sum(
            len(f) for f in frames)
        self.t_last = t_sim

    def emit_many(self, records: Sequence[tuple[float, Sequence[bytes]]]) -> None:
        """:meth:`emit_frames` for several messages at once, in order (the recorder frames
        them in one :meth:`Recorder.write_many`: the same records, byte for byte).

        Parameters
        ----------
        records : Sequence[tuple[float, Sequence[bytes]]]
            ``(t_sim, [topic, body])`` per message, in stream order.
        """
        if not records:
            return
        # the recorder's compiled framing measures the frames (every one bytes) as it goes
        counted = self.recorder.write_many(records) if self.recorder is not None else None
        if self.publisher is not None:
            send = self.publisher.send
            for _, frames in records:
                send(frames)
        topics = [frames[0] for _, frames in records]
        if counted is None:
            if not all(type(t) is bytes for t in topics):
                topics = [bytes(t) for t in topics]
            counted = sum([len(f) for _, frames in records for f in frames])
        self._messages.update(topics)
        self._bytes += counted
        self.t_last = records[-1][0]

    def flush(self, fsync: bool = False) -> None:
        """End of scan: hand the recording to the OS (``fsync``: to the disk).

        Parameters
        ----------
        fsync : bool, optional
            Also wait for stable storage.

        Raises
        ------
        RunInterrupted
            After flushing, if :attr:`stop_requested` is set.
        """
        if self.recorder is not None:
            self.recorder.flush(fsync=fsync)
        if self.stop_requested:
            raise RunInterrupted(f"stop requested at t = {self.t_last} s")

    def close(self, linger_ms: int = DEFAULT_LINGER_MS) -> None:
        """Close the recorder and the publisher (delivering queued messages first).

        Parameters
        ----------
        linger_ms : int, optional
            See :meth:`Publisher.close` [ms].
        """
        try:
            if self.recorder is not None:
                self.recorder.close()
        finally:
            if self.publisher is not None:
                self.publisher.close(linger_ms)

    @property
    def stats(self) -> dict[str, Any]:
        """Counters, JSON-ready: ``messages``, ``bytes``, ``messages_by_topic``, plus the
        ``publisher`` stats and ``recorder`` (``path``, ``records``, ``bytes``) or None."""
        rec = self.recorder
        return {
            "messages": sum(self._messages.values()),
            "bytes": self._bytes,
            "messages_by_topic": {_topic_str(k): v for k, v in self._messages.items()},
            "publisher": None if self.publisher is None else self.publisher.stats,
            "recorder": None
            if rec is None
            else {"path": str(rec.path), "records": rec.records, "bytes": rec.bytes_written},
        }



def message_json(frames: Sequence[bytes]) -> str:
    """One JSON line (without newline) for a message, as printed by tail and replay.

    Parameters
    ----------
    frames : Sequence[bytes]
        ``[topic, body]``.

    Returns
    -------
    str
        ``{"topic": ..., "t": ..., "payload": {...}}``, or ``{"topic": ..., "error": ...}``
        if the message cannot be decoded. Strict JSON (no NaN).
    """
    try:
        topic, t_sim, payload = decode(frames)
    except ProtocolError as exc:
        topic = bytes(frames[0]) if frames else b""
        obj: dict[str, Any] = {"topic": _topic_str(topic), "error": str(exc)}
    else:
        obj = {"topic": _topic_str(topic), "t": t_sim, "payload": to_jsonable(payload)}
    return json.dumps(obj, allow_nan=False, separators=(",", ":"))


#: Where :func:`replay` hands a message, ``sink(t_sim, frames)`` (what it returns is ignored).
_ReplaySink = Callable[[float, Sequence[bytes]], object]


@dataclass(frozen=True)
class ReplaySettings:
    """How :func:`replay` republishes a recording (``shipradar replay``'s options).

    Attributes
    ----------
    endpoint : str or None
        Publish on this endpoint (as :class:`Publisher`). None: do not publish.
    speed : float
        Simulated seconds per wall-clock second (2.0: twice real time); > 0 and finite
        unless ``fast``.
    fast : bool
        Ignore times and send as fast as the subscribers take them.
    wait_subscribers : int
        Subscribers to wait for before the first message.
    wait_timeout_s, on_slow, allow_remote
        As for :class:`Publisher` ([s], ``"pace"`` or ``"drop"``, bool).
    linger_ms : int
        Time allowed at the end to deliver queued messages [ms].
    strict : bool
        Stop with :class:`shipradar.sim.stream.recording.RecordingError` at the first damaged
        record (default: skip damaged records and go on; the summary counts them).
    curve : shipradar.sim.stream.security.CurveServer or None
        Authenticate and encrypt the stream (see :class:`Publisher`).

    Raises
    ------
    ValueError
        A speed that is not a positive finite number (without ``fast``).
    """

    endpoint: str | None = None
    speed: float = 1.0
    fast: bool = False
    wait_subscribers: int = 0
    wait_timeout_s: float = 30.0
    on_slow: str = "pace"
    allow_remote: bool = False
    linger_ms: int = DEFAULT_LINGER_MS
    strict: bool = False
    curve: Any = None

    def __post_init__(self) -> None:
        if not self.fast and not (self.speed > 0 and self.speed < float("inf")):
            raise ValueError(f"speed must be a positive finite number, got {self.speed!r}")


def replay(
    path: str,
    settings: ReplaySettings = ReplaySettings(),
    *,
    out: TextIO | None = None,
    tap: Callable[[float, Sequence[bytes]], None] | None = None,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> dict[str, Any]:
    """Republish a recording's messages unchanged, paced by their simulated times.

    The steps: the recording opened (a bad file fails before anything is bound), the
    publisher bound and its subscribers awaited (:func:`_replay_publisher`), each message
    sent at its paced time to the publisher, ``tap`` and ``out`` (:func:`_deliver_paced`),
    the publisher closed and the counts summed up (:func:`_replay_summary`).

    Parameters
    ----------
    path : str
        Recording to replay.
    settings : ReplaySettings, optional
        Where to publish, how fast, how strictly.
    out : TextIO or None, optional
        Also print each message as a JSON line (:func:`message_json`) to this stream.
    tap : callable or None, optional
        Also called as ``tap(t_sim, frames)`` for each message, at its paced time (e.g. the
        ASTERIX output of ``replay --asterix``,
        :class:`shipradar.sim.adapters.asterix.udp.AsterixBus`).
    clock, sleep : callable, optional
        Monotonic clock [s] and sleep function (replaceable in tests).

    Returns
    -------
    dict
        ``frames`` (messages republished), ``truncated`` and ``bytes_ignored``,
        ``damaged_regions``, ``bytes_skipped`` and ``records_skipped`` (see
        :class:`shipradar.sim.stream.recording.RecordingReader`), ``t_first`` and ``t_last`` [s
        simulated], ``wall_s``, ``schema_version`` and ``publisher`` (stats or None).

    Notes
    -----
    Message i is sent at wall time ``w0 + (t_i - t_0) / speed``, ``w0`` being when the
    subscribers are ready; a message late (slow subscriber, non-increasing times) goes out
    at once and later ones keep the original schedule, so lateness never accumulates.
    """
    reader = read_recording(path, strict=settings.strict)  # bad file: fail before binding
    publisher = None
    try:
        publisher = _replay_publisher(settings)
        sinks = [s for s in (None if publisher is None else _publish(publisher), tap,
                             None if out is None else _print_json(out)) if s is not None]
        sent = _deliver_paced(reader, settings, sinks, clock, sleep)
        if publisher is not None:
            publisher.close(settings.linger_ms)
        return _replay_summary(reader, sent, publisher)
    finally:
        reader.close()
        if publisher is not None:
            publisher.close(0)


def _replay_publisher(settings: ReplaySettings) -> Publisher | None:
    """The publisher of a replay, bound, with its subscribers arrived (None: no endpoint)."""
    if settings.endpoint is None:
        return None
    publisher = Publisher(settings.endpoint, wait_subscribers=settings.wait_subscribers,
                          wait_timeout_s=settings.wait_timeout_s, on_slow=settings.on_slow,
                          allow_remote=settings.allow_remote, curve=settings.curve)
    publisher.wait_for_subscribers()
    return publisher


def _publish(publisher: Publisher) -> _ReplaySink:
    """A replay sink that publishes each message."""
    return lambda _t, frames: publisher.send(frames)


def _print_json(out: TextIO) -> _ReplaySink:
    """A replay sink that prints each message as a JSON line (:func:`message_json`)."""
    return lambda _t, frames: out.write(message_json(frames) + "\n")


def _deliver_paced(reader: RecordingReader, settings: ReplaySettings,
                sinks: Sequence[_ReplaySink],
                clock: Callable[[], float], sleep: Callable[[float], None]
                ) -> tuple[int, float | None, float | None, float]:
    """Hand each message to every sink at its paced time (see :func:`replay`'s Notes).

    Returns
    -------
    tuple
        Messages sent, first and last simulated times [s] (None when there were none), and
        the wall seconds from the first message to the end [s].
    """
    count = 0
    t_first = t_last = None
    w0 = clock()
    for t_sim, frames in reader:
        if t_first is None:
            t_first = t_sim
            w0 = clock()
        if not settings.fast:
            delay = w0 + (t_sim - t_first) / settings.speed - clock()
            if delay > 0:
                sleep(delay)
        for sink in sinks:
            sink(t_sim, frames)
        count += 1
        t_last = t_sim
    return count, t_first, t_last, clock() - w0


def _replay_summary(reader: RecordingReader,
                    sent: tuple[int, float | None, float | None, float],
                    publisher: Publisher | None) -> dict[str, Any]:
    """The JSON-ready summary of a replay (see :func:`replay`'s Returns)."""
    count, t_first, t_last, wall_s = sent
    return {
        "frames": count,
        "truncated": reader.truncated,
        "bytes_ignored": reader.bytes_ignored,
        "damaged_regions": len(reader.damaged),
        "bytes_skipped": reader.bytes_skipped,
        "records_skipped": reader.records_skipped,
        "t_first": t_first,
        "t_last": t_last,
        "wall_s": wall_s,
        "schema_version": reader.schema_version,
        "publisher": None if publisher is None else publisher.stats,
    }


def tail(
    endpoint: str,
    *,
    topics: Iterable[bytes | str] | None = None,
    out: TextIO = sys.stdout,
    max_messages: int | None = None,
    timeout_s: float | None = None,
    context: zmq.Context | None = None,
    curve: Any = None,
) -> int:
    """Subscribe to a stream and print one JSON line per message.

    Parameters
    ----------
    endpoint : str
        Endpoint to connect to, e.g. ``tcp://127.0.0.1:5555``.
    topics : iterable of bytes or str, optional
        Topic prefixes to subscribe to; default all.
    out : TextIO, optional
        Where lines go (flushed after each line).
    max_messages : int or None, optional
        Stop after this many messages.
    timeout_s : float or None, optional
        Stop after this long without a message [s] (idle timeout). None: never.
    context : zmq.Context or None, optional
        Context to use (needed for ``inproc://``); default the process-wide instance.
    curve : shipradar.sim.stream.security.CurveClient or None, optional
        Subscribe to a CURVE publisher with these keys.

    Returns
    -------
    int
        Messages printed. Lines are as :func:`message_json`; an undecodable message gives
        an ``error`` line instead of stopping. A closed output pipe ends the tail quietly.
    """
    import zmq
    ctx = zmq.Context.instance() if context is None else context
    sock = ctx.socket(zmq.SUB)
    sock.setsockopt(zmq.LINGER, 0)
    # a message larger than any valid one drops the connection instead of being allocated
    sock.setsockopt(zmq.MAXMSGSIZE, MAX_BODY_BYTES + 1024)
    if curve is not None:
        curve.apply(sock)
    count = 0
    try:
        sock.connect(endpoint)
        for topic in [b""] if topics is None else topics:
            sock.setsockopt(zmq.SUBSCRIBE, topic.encode() if isinstance(topic, str) else topic)
        last = time.monotonic()
        while max_messages is None or count < max_messages:
            # Short poll slices keep Ctrl-C responsive.
            if not sock.poll(200):
                if timeout_s is not None and time.monotonic() - last >= timeout_s:
                    break
                continue
            frames = sock.recv_multipart()
            last = time.monotonic()
            try:
                out.write(message_json(frames) + "\n")
                out.flush()
            except BrokenPipeError:
                break
            count += 1
    finally:
        sock.close()
    return count
