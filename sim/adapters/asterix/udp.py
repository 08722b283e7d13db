"""ASTERIX over UDP: the socket of ``shipradar run|replay --asterix udp://HOST:PORT``.

Whole data blocks per datagram (whole records; the payload at most ``max_block_bytes``).
Loopback only unless remote sending is explicitly allowed, as for the ZeroMQ stream
(docs/protocol.md 1):
ASTERIX has no authentication and no encryption, and a multicast group or a remote host
puts the plots on a network.
"""

from __future__ import annotations

import ipaddress
import socket
from collections.abc import Mapping, Sequence
from typing import Any

from shipradar.sim.adapters.asterix.encode import DEFAULT_MAX_BLOCK_BYTES, AsterixError
from shipradar.sim.adapters.asterix.stream import AsterixStream, datagrams
from shipradar.sim.stream import protocol
from shipradar.sim.stream.sink import takes_frames

__all__ = ["AsterixBus", "UdpSender", "parse_udp_url"]


def parse_udp_url(url: str, *, allow_remote: bool = False) -> tuple[str, int, bool]:
    """Check an ``--asterix`` destination.

    Parameters
    ----------
    url : str
        ``udp://HOST:PORT``; HOST an IPv4/IPv6 address (``[...]`` for IPv6) or
        ``localhost``; PORT in [1, 65535].
    allow_remote : bool, optional
        Accept a non-loopback host, a host name or a multicast group.

    Returns
    -------
    host : str
    port : int
    multicast : bool

    Raises
    ------
    AsterixError
        Malformed URL, port out of range, or a destination off this machine while
        ``allow_remote`` is False.
    """
    scheme, sep, rest = url.partition("://")
    if scheme != "udp" or not sep:
        raise AsterixError(f"--asterix: {url!r} is not udp://HOST:PORT "
                           "(e.g. udp://127.0.0.1:8600)")
    host, colon, port_text = rest.rpartition(":")
    host = host.strip("[]")
    if not colon or not host:
        raise AsterixError(f"--asterix: {url!r} has no HOST:PORT (e.g. udp://127.0.0.1:8600)")
    try:
        port = int(port_text)
    except ValueError:
        port = -1
    if not 1 <= port <= 65535:
        raise AsterixError(f"--asterix: port must be in [1, 65535], got {port_text!r}")
    hint = ("send to a loopback address such as udp://127.0.0.1:8600, or pass "
            "--allow-insecure-remote")
    if host == "localhost":
        return "127.0.0.1", port, False
    try:
        addr = ipaddress.ip_address(host)
    except ValueError:
        if not allow_remote:
            raise AsterixError(f"--asterix: refusing host {host!r}: a host name may be "
                               f"another machine; {hint}") from None
        return host, port, False
    if addr.is_multicast:
        if not allow_remote:
            raise AsterixError(f"--asterix: refusing multicast group {host}: it reaches "
                               f"the network; {hint}")
        return host, port, True
    if not addr.is_loopback and not allow_remote:
        raise AsterixError(f"--asterix: refusing {host}: it is reachable from other "
                           f"machines; {hint}")
    return host, port, False


class UdpSender:
    """Sends data blocks as UDP datagrams, counting them.

    Parameters
    ----------
    url : str
        ``udp://HOST:PORT`` (see :func:`parse_udp_url`).
    allow_remote : bool, optional
        Allow a non-loopback destination or a multicast group.
    multicast_ttl : int, optional
        IP TTL of multicast datagrams (1: the local network segment only).
    """

    def __init__(self, url: str, *, allow_remote: bool = False, multicast_ttl: int = 1):
        self.host, self.port, multicast = parse_udp_url(url, allow_remote=allow_remote)
        family = socket.AF_INET6 if ":" in self.host else socket.AF_INET
        self._sock = socket.socket(family, socket.SOCK_DGRAM)
        if multicast:
            level = socket.IPPROTO_IPV6 if family == socket.AF_INET6 else socket.IPPROTO_IP
            opt = (socket.IPV6_MULTICAST_HOPS if family == socket.AF_INET6
                   else socket.IP_MULTICAST_TTL)
            self._sock.setsockopt(level, opt, multicast_ttl)
        self.url = url
        self.datagrams = 0
        self.bytes = 0
        self._dest = (self.host, self.port)

    def send(self, block: bytes) -> None:
        """Send one data block as one datagram (blocking while the socket buffer is full,
        so a fast run never drops a datagram on this side)."""
        self._sock.sendto(block, self._dest)
        self.datagrams += 1
        self.bytes += len(block)

    def close(self) -> None:
        """Close the socket (idempotent)."""
        self._sock.close()


class AsterixBus:
    """A bus (``emit``/``flush``/``close``/``stats``) that also sends the run as ASTERIX.

    Parameters
    ----------
    inner : object or None
        The run's other bus (:class:`shipradar.sim.stream.bus.Bus`: ZeroMQ and recording),
        unchanged; None when ASTERIX is the only output.
    sender : UdpSender
        Where the data blocks go.
    max_block_bytes : int, optional
        Largest datagram [bytes].
    """

    def __init__(self, inner: Any, sender: UdpSender,
                 max_block_bytes: int = DEFAULT_MAX_BLOCK_BYTES):
        self.inner = inner
        self.sender = sender
        self.stream = AsterixStream(max_block_bytes)
        self.max_block_bytes = max_block_bytes
        # CAT048 blocks made ahead (plots_ahead), by the id of the msgpack body of their
        # plots message (held here, so the id is that body's): (body, sensor, plots,
        # blocks); and each radar's bodies, to drop unsent ones
        self._ahead: dict[int, tuple[bytes, str, int, list[bytes]]] = {}
        self._ahead_bodies: dict[str, Sequence[bytes]] = {}

    @property
    def encodes_ahead(self) -> bool:
        """True when the engine may hand this bus encoded frames (:meth:`emit_frames`) and
        a revolution's plots ahead (:meth:`plots_ahead`): when the inner bus is a
        bus that takes frames itself (:func:`shipradar.sim.stream.sink.takes_frames`: a
        :class:`shipradar.sim.stream.bus.Bus`) or there is none."""
        return self.inner is None or takes_frames(self.inner)

    @property
    def pending_ahead(self) -> int:
        """Messages whose CAT048 blocks :meth:`plots_ahead` made and :meth:`emit_frames`
        has not sent yet (0 at the end of a run that reached every sector it made)."""
        return len(self._ahead)

    def plots_ahead(self, sensor: str, bodies: Sequence[bytes], plots: Mapping[str, Any],
                    starts: Sequence[int], stops: Sequence[int]) -> None:
        """A revolution's ``plots`` messages of radar ``sensor``, before they are emitted.

        ``bodies[j]`` is the msgpack body of the message that holds the plots
        ``starts[j]:stops[j]`` of ``plots``' columns. Their CAT048 blocks are made now, at
        once (:meth:`AsterixStream.encode_ahead`); each message's datagrams are still sent
        when the message is emitted (:meth:`emit_frames`), at its time. Nothing is made
        ahead when a plot cannot be encoded: that message then raises when it is emitted.
        """
        for body in self._ahead_bodies.pop(sensor, ()):
            self._ahead.pop(id(body), None)  # sectors the run did not reach
        try:
            blocks = self.stream.encode_ahead(sensor, plots, starts, stops)
        except AsterixError:
            return
        if blocks is None:
            return
        for body, i0, i1, b in zip(bodies, starts, stops, blocks, strict=True):
            self._ahead[id(body)] = (body, sensor, i1 - i0, b)
        self._ahead_bodies[sensor] = bodies

    def emit(self, topic: bytes, t_sim: float, payload: Mapping[str, Any]) -> None:
        """Pass the message on to ``inner``, then send its ASTERIX blocks."""
        if self.inner is not None:
            self.inner.emit(topic, t_sim, payload)
        if topic == b"truth":
            return  # never sent, and the bulk of the messages
        self._send(self.stream.feed(topic, t_sim, payload))

    def emit_frames(self, t_sim: float, frames: Sequence[bytes]) -> None:
        """Same as :meth:`emit` for an already encoded message (the engine's sector frames,
        a replay)."""
        if self.inner is not None:
            self.inner.emit_frames(t_sim, frames)
        topic = bytes(frames[0])
        if topic == b"truth":
            return
        body = frames[1]
        ahead = self._ahead.pop(id(body), None) if self._ahead else None
        if ahead is not None and ahead[0] is body:
            self._send(self.stream.feed_encoded(ahead[1], t_sim, ahead[2], ahead[3]))
            return
        topic, t, payload = protocol.decode(frames)
        self._send(self.stream.feed(topic, t, payload))

    def _send(self, blocks: list[tuple[float, bytes]]) -> None:
        n = len(blocks)
        if n == 1:
            self.sender.send(blocks[0][1])
        elif n == 2:  # the usual sector: its CAT048 block and the sector crossing after it
            a, b = blocks[0][1], blocks[1][1]
            if len(a) + len(b) <= self.max_block_bytes:
                self.sender.send(a + b)  # as datagrams() packs them
            else:
                self.sender.send(a)
                self.sender.send(b)
        elif n:
            for _, payload_bytes in datagrams(blocks, self.max_block_bytes):
                self.sender.send(payload_bytes)

    def flush(self, fsync: bool = False) -> None:
        if self.inner is not None:
            self.inner.flush(fsync=fsync)

    def close(self, *args: Any, **kwargs: Any) -> None:
        try:
            if self.inner is not None:
                self.inner.close(*args, **kwargs)
        finally:
            self.sender.close()

    @property
    def stats(self) -> dict[str, Any]:
        """The inner bus's stats (if any) plus ``asterix``: the destination, datagrams and
        bytes sent and the stream's counts (:class:`AsterixStream`)."""
        out = dict(self.inner.stats) if self.inner is not None else {}
        out["asterix"] = {"destination": self.sender.url, "datagrams": self.sender.datagrams,
                          "bytes": self.sender.bytes, **self.stream.stats}
        return out
