"""Two streams compared by value: the same messages, ids and origins, floats within a tolerance.

A recording is byte-identical across runs, BLAS thread counts and processes on one install
(README, "Reproducibility"); across installs (numpy, scipy, OpenBLAS) and CPUs only the low
bits of the floating-point values may move. This module tells the two apart: it walks two
message streams side by side and returns the first message that differs in anything but the
low bits of its floats (topic, time, key, shape, dtype, integer or text value, which plots
exist), or whose floats differ by more than a relative tolerance, with the size of the
difference; and the largest relative difference it saw before. Used by the golden recordings
(``tests/golden/``) and the install study (docs/stability.md section 6).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from itertools import zip_longest
from pathlib import Path
from typing import Any

import numpy as np

from shipradar.sim.stream.protocol import decode
from shipradar.sim.stream.recording import read_recording

Message = tuple[str, float, Mapping[str, Any]]


@dataclass(frozen=True)
class Difference:
    """The first difference between two streams.

    ``index`` is the message's position (0-based) in the streams; ``where`` names the value
    (``plots.range_m[3]``); ``kind`` is ``"value"`` when only a float's size differs beyond
    the tolerance, ``"structure"`` for anything else (a missing message, another topic, key,
    shape, dtype, plot id or integer); ``rel`` is the relative difference of a ``"value"``.
    """

    index: int
    topic: str
    t_sim: float
    where: str
    kind: str
    detail: str
    rel: float = math.inf

    def __str__(self) -> str:
        return (f"message {self.index} ({self.topic} at t={self.t_sim!r} s) differs at "
                f"{self.where}: {self.detail}")


@dataclass
class Comparison:
    """What :func:`compare_streams` found.

    ``messages``: messages compared (up to and including the first difference);
    ``max_rel``: the largest relative difference of a float among them, at ``worst``;
    ``by_key``: the largest per ``topic.key``; ``first``: the first difference or None.
    """

    rtol: float
    messages: int = 0
    max_rel: float = 0.0
    worst: str = ""
    by_key: dict[str, float] = field(default_factory=dict)
    first: Difference | None = None

    @property
    def equal(self) -> bool:
        """True when no message differs beyond the tolerance."""
        return self.first is None

    def __str__(self) -> str:
        head = (f"{self.messages} messages compared, largest relative difference "
                f"{self.max_rel:.3g}" + (f" ({self.worst})" if self.worst else ""))
        if self.first is None:
            return f"{head}: equal within rtol={self.rtol:g}"
        return f"{head}; first difference beyond rtol={self.rtol:g}: {self.first}"


def recording_messages(path: str | Path) -> Iterator[Message]:
    """Decode a recording's messages as ``(topic, t_sim, payload)``; damage raises."""
    with read_recording(path, strict=True) as reader:
        for _, frames in reader:
            topic, t_sim, payload = decode(frames)
            yield topic.decode("ascii", "replace"), t_sim, payload


def relative_difference(a: np.ndarray, b: np.ndarray, *, db: bool = False) -> np.ndarray:
    """|a - b| / max(|a|, |b|) elementwise; 0 where both are equal (NaN with NaN, inf with the
    same inf), inf where only one is NaN or infinite.

    Parameters
    ----------
    a, b : numpy.ndarray
        Float arrays of one shape.
    db : bool, optional
        ``a`` and ``b`` are levels in dB: the relative difference is that of the powers they
        stand for, A = 10^(a/10): |A - B| / max(A, B) = 1 - 10^(-|a - b|/10) (a relative
        difference of a dB number itself means nothing near 0 dB).

    Returns
    -------
    numpy.ndarray
        The relative differences, in [0, 2] for finite values (below 1 with ``db``), or inf.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    finite = np.isfinite(a) & np.isfinite(b)
    out = np.full(a.shape, np.inf)
    ok = finite & ~same
    if db:
        out[ok] = -np.expm1(-np.abs(a[ok] - b[ok]) * (np.log(10.0) / 10.0))
    else:
        scale = np.maximum(np.abs(a[ok]), np.abs(b[ok]))
        out[ok] = np.abs(a[ok] - b[ok]) / scale
    out[same] = 0.0
    return out


class _Found(Exception):
    def __init__(self, where: str, kind: str, detail: str, rel: float = math.inf):
        self.where, self.kind, self.detail, self.rel = where, kind, detail, rel


def _is_float(x: Any) -> bool:
    return isinstance(x, float) or (isinstance(x, np.ndarray) and x.dtype.kind == "f")


class _Walker:
    """Compares two decoded payloads, noting the largest relative difference per key."""

    def __init__(self, out: Comparison, topic: str, index: int):
        self.out, self.topic, self.index = out, topic, index

    def floats(self, where: str, a: Any, b: Any) -> None:
        db = where.split("[")[0].endswith(("_db", "_dbm", "_dbi"))
        rel = relative_difference(np.asarray(a), np.asarray(b), db=db)
        if rel.size == 0:
            return
        i = int(np.argmax(rel))
        worst = float(rel.flat[i])
        if worst == 0.0:
            return
        at = f"{where}[{i}]" if rel.ndim else where
        key = f"{self.topic}.{where.split('[')[0].split('.')[0]}"
        if worst > self.out.by_key.get(key, 0.0):
            self.out.by_key[key] = worst
        if worst > self.out.max_rel:
            self.out.max_rel = worst
            self.out.worst = f"message {self.index}, {self.topic}.{at}"
        if worst > self.out.rtol:
            x, y = float(np.asarray(a).flat[i]), float(np.asarray(b).flat[i])
            raise _Found(at, "value", f"{x!r} vs {y!r}, relative difference {worst:.3g}",
                         worst)

    def value(self, where: str, a: Any, b: Any) -> None:
        if isinstance(a, Mapping) and isinstance(b, Mapping):
            if list(a) != list(b):
                only_a = [k for k in a if k not in b]
                only_b = [k for k in b if k not in a]
                detail = (f"keys only in the first {only_a}, only in the second {only_b}"
                          if only_a or only_b else f"keys in another order: {list(b)}")
                raise _Found(where or "keys", "structure", detail)
            for k in a:
                self.value(f"{where}.{k}" if where else str(k), a[k], b[k])
        elif isinstance(a, np.ndarray) and isinstance(b, np.ndarray):
            if a.dtype != b.dtype or a.shape != b.shape:
                raise _Found(where, "structure", f"{a.dtype}{list(a.shape)} vs "
                                                 f"{b.dtype}{list(b.shape)}")
            if a.dtype.kind == "f":
                self.floats(where, a, b)
            elif not np.array_equal(a, b):
                i = int(np.argmax(a != b))
                raise _Found(f"{where}[{i}]", "structure", f"{a.flat[i].item()!r} vs "
                                                            f"{b.flat[i].item()!r}")
        elif isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
            if len(a) != len(b):
                raise _Found(where, "structure", f"{len(a)} items vs {len(b)}")
            for i, (x, y) in enumerate(zip(a, b, strict=True)):
                self.value(f"{where}[{i}]", x, y)
        elif type(a) is not type(b):
            raise _Found(where, "structure", f"{a!r} vs {b!r}")
        elif _is_float(a):
            self.floats(where, a, b)
        elif a != b:
            raise _Found(where, "structure", f"{a!r} vs {b!r}")


def compare_streams(expected: Iterable[Message], actual: Iterable[Message], *,
                    rtol: float) -> Comparison:
    """Compare two message streams by value, message by message, up to the first difference.

    Parameters
    ----------
    expected, actual : iterable of (topic, t_sim, payload)
        Decoded messages (:func:`recording_messages`, :func:`shipradar.messages`).
    rtol : float
        Largest allowed relative difference |a - b| / max(|a|, |b|) of any float (message
        times included; a ``*_db`` level's is that of the power it stands for,
        :func:`relative_difference`); integers, ids, text, shapes and dtypes must be equal,
        NaN where NaN.

    Returns
    -------
    Comparison
        The first difference (or None) and the largest relative difference seen.
    """
    out = Comparison(rtol=rtol)
    missing: Message = ("(no message)", math.nan, {})
    for index, (a, b) in enumerate(zip_longest(expected, actual, fillvalue=None)):
        out.messages = index + 1
        ta, sa, pa = a if a is not None else missing
        tb, sb, pb = b if b is not None else missing
        topic = ta if a is not None else tb
        time = sa if a is not None else sb
        walker = _Walker(out, topic, index)
        try:
            if a is None or b is None or ta != tb:
                raise _Found("topic", "structure", f"{ta} vs {tb}")
            walker.floats("t", sa, sb)
            walker.value("", pa, pb)
        except _Found as found:
            out.first = Difference(index, topic, time, found.where, found.kind, found.detail,
                                   found.rel)
            return out
    return out


def compare_recordings(expected: str | Path, actual: str | Path, *, rtol: float
                       ) -> Comparison:
    """:func:`compare_streams` over two recording files."""
    return compare_streams(recording_messages(expected), recording_messages(actual), rtol=rtol)


def plot_ids(messages: Iterable[Message]) -> Sequence[tuple[str, int]]:
    """Every plot of a stream as ``(sensor, plot_id)``, in stream order: which plots exist."""
    ids: list[tuple[str, int]] = []
    for topic, _, payload in messages:
        if topic == "plots":
            ids.extend((payload["sensor"], int(i)) for i in payload["plot_id"])
    return ids
