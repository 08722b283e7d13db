"""The last look of every target at each end of scan (``truth[targets]``: ``look_time_s``,
``pd``, ``snr_db``, ``interference``), from the looks the dwell model reports.

A radar's process computes a block of revolutions at once (:mod:`shipradar.sim.engine.simulation`):
the dwell model reports each call's looks (its ``on_look`` observers), which are held here with
their revolutions (:meth:`LastLooks.add`) and folded, once the block's looks are all made,
into the last look of every target up to the end of each of its revolutions
(:meth:`LastLooks.fold`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["LastLooks"]


class LastLooks:
    """The last look of ``targets`` targets: its time [s], P_d, S/I [dB] and dominant
    interference code (NaN, NaN, NaN, -1 before any), and the looks not folded yet.

    Attributes
    ----------
    last : tuple of numpy.ndarray
        The last look of each target up to the last revolution folded: time, P_d, S/I [dB]
        (float64) and interference (int8), one element per target.
    pending : list of tuple of numpy.ndarray
        The looks added and not folded yet, call by call: (revolution, target, time, P_d,
        S/I [dB], interference) of each look.
    """

    def __init__(self, targets: int) -> None:
        self.last: tuple[np.ndarray, ...] = (
            np.full(targets, np.nan), np.full(targets, np.nan), np.full(targets, np.nan),
            np.full(targets, -1, np.int8))
        self.pending: list[tuple[np.ndarray, ...]] = []

    def add(self, revolution: np.ndarray, target: np.ndarray, time_s: np.ndarray,
            pd: np.ndarray, si_db: np.ndarray, interference: np.ndarray) -> None:
        """Hold one call's looks: the revolution, target, time [s], P_d, S/I [dB] and
        interference code of each."""
        self.pending.append((revolution, target, time_s, pd, si_db, interference))

    def grow(self, more: int) -> None:
        """``more`` targets appended (a live source's new entities), with no look yet."""
        t_look, pd, si, code = self.last
        self.last = (np.concatenate([t_look, np.full(more, np.nan)]),
                     np.concatenate([pd, np.full(more, np.nan)]),
                     np.concatenate([si, np.full(more, np.nan)]),
                     np.concatenate([code, np.full(more, -1, np.int8)]))

    def clear(self) -> None:
        """Drop the looks not folded (the run is over)."""
        self.pending = []

    def fold(self, scan0: int, count: int) -> tuple[np.ndarray, ...]:
        """The last look of every target up to the end of each revolution ``scan0`` to
        ``scan0 + count - 1``: its time, P_d, S/I [dB] and dominant interference (NaN, NaN,
        NaN, -1 before any), ``count`` rows of one per target each (the ``truth[targets]``
        columns); :attr:`last` moves on to the end of the block, and the looks of later
        revolutions stay :attr:`pending`.

        The looks are taken revolution after revolution, in each the calls in their order
        and a call's looks by time (stably): a target's last look up to a revolution is the
        last one in that order.  All the block's looks at once: sorted by (target,
        revolution, call, time), the last of a target up to revolution j is found by
        bisection (the same look a sequential fold of each revolution keeps).
        """
        last = self.last
        k = last[0].size
        out = tuple(np.tile(a, count) for a in last)
        if not count:
            return out
        calls, self.pending = self.pending, []
        later = [c for c in calls if (c[0] >= scan0 + count).any()]
        if later:  # looks of revolutions after the block wait for theirs
            self.pending = [tuple(a[c[0] >= scan0 + count] for a in c) for c in later]
            calls = [tuple(a[c[0] < scan0 + count] for a in c) for c in calls]
        calls = [c for c in calls if c[0].size]
        if not calls:
            return out
        rev, target, t, pd, si_db, code = (np.concatenate(a) for a in zip(*calls, strict=True))
        call = np.repeat(np.arange(len(calls)), [c[0].size for c in calls])
        order = np.lexsort((t, call, rev, target))  # stable: a tie keeps the call's order
        target, rev = target[order].astype(np.int64), rev[order] - scan0
        key = target * count + np.maximum(rev, 0)
        # the last look of target i up to revolution j: the last key <= i count + j
        want = np.arange(k)[None, :] * count + np.arange(count)[:, None]
        pos = np.searchsorted(key, want.ravel(), side="right") - 1
        hit = pos >= 0
        hit[hit] = target[pos[hit]] == np.tile(np.arange(k), count)[hit]
        src = order[pos[hit]]
        for o, a in zip(out, (t, pd, si_db, code), strict=True):
            o[hit] = a[src]
        for a, o in zip(last, out, strict=True):
            a[:] = o[(count - 1) * k:]
        return out
