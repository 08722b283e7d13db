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

from shipradar.sim import protocol
from shipradar.sim.asterix.encode import DEFAULT_MAX_BLOCK_BYTES, AsterixError
from shipradar.sim.asterix.stream import AsterixStream, datagrams

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
    hint = "send to a loopback address such as udp://127.0.0.1:8600, or pass --allow-remote"
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

    def send(self, block: bytes) -> None:
        """Send one data block as one datagram (blocking while the socket buffer is full,
        so a fast run never drops a datagram on this side)."""
        self._sock.sendto(block, (self.host, self.port))
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
        The run's other bus (:class:`sim.bus.Bus`: ZeroMQ and recording), unchanged; None
        when ASTERIX is the only output.
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

    def emit(self, topic: bytes, t_sim: float, payload: Mapping[str, Any]) -> None:
        """Pass the message on to ``inner``, then send its ASTERIX blocks."""
        if self.inner is not None:
            self.inner.emit(topic, t_sim, payload)
        if topic == b"truth":
            return  # never sent, and the bulk of the messages
        blocks = self.stream.feed(topic, t_sim, payload)
        if blocks:
            for _, payload_bytes in datagrams(blocks, self.max_block_bytes):
                self.sender.send(payload_bytes)

    def emit_frames(self, t_sim: float, frames: Sequence[bytes]) -> None:
        """Same as :meth:`emit` for an already encoded message (replay)."""
        if self.inner is not None:
            self.inner.emit_frames(t_sim, frames)
        if bytes(frames[0]) == b"truth":
            return
        topic, t, payload = protocol.decode(frames)
        blocks = self.stream.feed(topic, t, payload)
        if blocks:
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
