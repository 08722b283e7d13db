"""What the engine asks of a bus, declared as protocols, and the in-process buses.

The engine (:class:`shipradar.sim.engine.simulation.Simulation`) publishes through any object
that satisfies :class:`MessageSink` (``emit`` a payload, ``flush`` at each end of scan). Two
optional capabilities, each a protocol with a flag the bus sets, choose faster paths that
give the same messages:

- :class:`FrameSink` (``encodes_ahead`` True, ``emit_frames``): the bus takes encoded
  frames, so the engine encodes a block's sector messages at once
  (:meth:`shipradar.sim.stream.framing.Slices.encode`) and the metadata from items packed
  once. :class:`shipradar.sim.stream.bus.Bus`, the ASTERIX bus over one, the parallel
  workers' collector.
- :class:`BatchSink` (a :class:`FrameSink` with ``accepts_batches`` True, ``emit_many``):
  nothing downstream watches messages as they are made (a recording, no live publisher), so
  a fast run hands it a scan's messages at once on a plain clock
  (:meth:`shipradar.sim.engine.simulation.Simulation._run_batched`).

An object that has the method but sets the flag False (e.g. an ASTERIX bus over a bus that
takes payloads) is served as a plain :class:`MessageSink`.
"""

from __future__ import annotations

from collections.abc import Callable, Container, Mapping, Sequence
from types import TracebackType
from typing import Any, Protocol, TypeGuard, TypeVar, runtime_checkable

__all__ = [
    "BatchSink",
    "CallbackSink",
    "FrameSink",
    "MemorySink",
    "MessageSink",
    "PlotsAheadSink",
    "takes_batches",
    "takes_frames",
]


@runtime_checkable
class MessageSink(Protocol):
    """What the engine calls on every bus."""

    def emit(self, topic: bytes, t_sim: float, payload: Mapping[str, Any], /) -> object:
        """One message: its topic (``b"plots"``, ...), simulated time [s] and payload (keys of
        :mod:`shipradar.sim.stream.schema`, numpy columns as numpy arrays)."""

    def flush(self) -> None:
        """End of a scan: everything emitted so far may be handed on."""


@runtime_checkable
class FrameSink(MessageSink, Protocol):
    """A bus that also takes encoded messages."""

    #: True when the engine should give it frames (:meth:`emit_frames`) rather than payloads
    encodes_ahead: bool

    def emit_frames(self, t_sim: float, frames: Sequence[bytes], /) -> None:
        """One message already encoded (:func:`shipradar.sim.stream.protocol.encode`):
        ``[topic, body]`` at simulated time ``t_sim`` [s]."""


@runtime_checkable
class BatchSink(FrameSink, Protocol):
    """A bus that may take a scan's messages at once."""

    #: True when nothing downstream watches the messages as they are made
    accepts_batches: bool

    def emit_many(self, records: Sequence[tuple[float, Sequence[bytes]]], /) -> None:
        """Several encoded messages ``(t_sim, [topic, body])``, in stream order."""


@runtime_checkable
class PlotsAheadSink(FrameSink, Protocol):
    """A frame bus that wants a revolution's plots before their messages are emitted (the
    ASTERIX bus makes its CAT048 records from the columns at once)."""

    def plots_ahead(self, sensor: str, bodies: Sequence[bytes], plots: Mapping[str, Any],
                    starts: Sequence[int], stops: Sequence[int], /) -> None:
        """``bodies[j]`` is the body of the ``plots`` message that will carry the plots
        ``starts[j]:stops[j]`` of the revolution's columns ``plots``."""


def takes_frames(bus: object) -> TypeGuard[FrameSink]:
    """True when ``bus`` is a :class:`FrameSink` that asks for frames."""
    return isinstance(bus, FrameSink) and bus.encodes_ahead is True


def takes_batches(bus: object) -> TypeGuard[BatchSink]:
    """True when ``bus`` is a :class:`BatchSink` that accepts a scan's messages at once."""
    return (isinstance(bus, BatchSink) and bus.encodes_ahead is True
            and bus.accepts_batches is True)


class CallbackSink:
    """A bus for in-process use: hands each message to ``callback(topic, t_sim, payload)``.

    ``topic`` is the topic as text (``"meta"``, ``"plots"``, ``"eos"``, ``"truth"``), ``t_sim``
    the simulated time [s] and ``payload`` the message's keys exactly as the stream carries
    them (numpy columns for plots); nothing is encoded, no socket is opened.
    """

    def __init__(self, callback: Callable[[str, float, dict[str, Any]], object]) -> None:
        self.callback = callback
        self.messages = 0

    def emit(self, topic: bytes, t_sim: float, payload: Mapping[str, Any]) -> None:
        self.messages += 1
        self.callback(topic.decode(), t_sim,
                      payload if isinstance(payload, dict) else dict(payload))

    def flush(self, fsync: bool = False) -> None:
        """Nothing is buffered."""

    @property
    def stats(self) -> dict[str, Any]:
        return {"messages": self.messages}


class MemorySink:
    """A bus that keeps the messages in memory, as ``(topic, t_sim, payload)`` with the topic
    as bytes (studies that read a run's truth and metadata afterwards).

    Parameters
    ----------
    skip : Container[bytes], optional
        Topics not kept (e.g. ``{b"plots"}`` when only the truth is read).
    """

    def __init__(self, skip: Container[bytes] = ()) -> None:
        self.skip = skip
        self.messages: list[tuple[bytes, float, dict[str, Any]]] = []

    def emit(self, topic: bytes, t_sim: float, payload: Mapping[str, Any]) -> None:
        if topic not in self.skip:
            self.messages.append(
                (topic, t_sim, payload if isinstance(payload, dict) else dict(payload)))

    def flush(self, fsync: bool = False) -> None:
        """Nothing is buffered."""

    @property
    def stats(self) -> dict[str, Any]:
        return {"messages": len(self.messages)}


_Closing = TypeVar("_Closing", bound="Closing")


class Closing:
    """``with obj:`` closes it at the end, however the block ends: for the stream's objects
    that hold a socket or a file and have a ``close()`` (publisher, bus, recorder, reader)."""

    def close(self) -> None:
        raise NotImplementedError

    def __enter__(self: _Closing) -> _Closing:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()
