"""The last look of every target at each end of scan (``truth[targets]``) folded for a whole
block at once (:class:`shipradar.sim.engine.last_looks.LastLooks`) is the sequential fold,
revolution after revolution, of the looks the dwell model reports (calls in order, a call's
looks by time, the last one kept)."""

from __future__ import annotations

import numpy as np
import pytest

from shipradar.sim.engine.last_looks import LastLooks


def _sequential(last, calls, scan0, count):
    """The fold as it was written: per revolution, per call, sorted by time, last wins."""
    last = tuple(a.copy() for a in last)
    k = last[0].size
    out = tuple(np.empty(count * k, a.dtype) for a in last)
    for j in range(count):
        for rev, target, t, pd, si_db, code in calls:
            sel = rev == scan0 + j
            target, t, pd, si_db, code = (a[sel] for a in (target, t, pd, si_db, code))
            order = np.argsort(t, kind="stable")
            rows = target[order]
            last[0][rows], last[1][rows] = t[order], pd[order]
            last[2][rows], last[3][rows] = si_db[order], code[order].astype(np.int8)
        for o, a in zip(out, last, strict=True):
            o[j * k:(j + 1) * k] = a
    return out, last


def _looks(k, last):
    looks = LastLooks(k)
    looks.last = last
    return looks


def _call(rng, k, revs, n, ties):
    rev = rng.choice(revs, n)
    target = rng.integers(0, k, n)
    t = np.round(rng.uniform(0.0, 5.0, n), 0 if ties else 6)
    t[rng.random(n) < 0.02] = np.nan
    return (rev.astype(np.int64), target, t, rng.random(n), rng.normal(10.0, 5.0, n),
            rng.integers(0, 4, n).astype(np.uint8))


@pytest.mark.parametrize("seed", range(8))
def test_block_fold_is_the_sequential_fold(seed):
    rng = np.random.default_rng(seed)
    k = int(rng.integers(1, 9))
    scan0, count = int(rng.integers(0, 50)), int(rng.integers(1, 12))
    last = (rng.uniform(0, 1, k), rng.uniform(0, 1, k), rng.uniform(0, 1, k),
            rng.integers(-1, 3, k).astype(np.int8))
    last[0][rng.random(k) < 0.3] = np.nan
    # several calls per block, ties in time, revolutions without a look, and one call with
    # looks of the next block's revolutions (kept for it)
    revs = scan0 + rng.choice(count, max(1, count // 2), replace=False)
    calls = [_call(rng, k, revs, int(rng.integers(0, 40)), ties=bool(seed % 2))
             for _ in range(int(rng.integers(1, 4)))]
    calls.append(_call(rng, k, np.array([scan0 + count - 1, scan0 + count]), 10, ties=True))
    want, want_last = _sequential(last, [tuple(a[c[0] < scan0 + count] for a in c)
                                         for c in calls], scan0, count)
    looks = _looks(k, tuple(a.copy() for a in last))
    for c in calls:
        looks.add(*c)
    got = looks.fold(scan0, count)
    for g, w in zip(got, want, strict=True):
        assert g.dtype == w.dtype and g.tobytes() == w.tobytes()
    for g, w in zip(looks.last, want_last, strict=True):
        assert g.tobytes() == w.tobytes()
    # the next block's looks are kept, and fold as they would have
    nxt, _ = _sequential(want_last, [tuple(a[c[0] == scan0 + count] for a in c)
                                     for c in calls], scan0 + count, 1)
    got = looks.fold(scan0 + count, 1)
    for g, w in zip(got, nxt, strict=True):
        assert g.tobytes() == w.tobytes()
    assert looks.pending == []


def test_fold_without_looks_repeats_the_last_ones():
    last = (np.array([1.0, np.nan]), np.array([0.5, np.nan]), np.array([3.0, np.nan]),
            np.array([2, -1], np.int8))
    looks = _looks(2, tuple(a.copy() for a in last))
    got = looks.fold(7, 3)
    for g, a in zip(got, last, strict=True):
        assert g.tobytes() == np.tile(a, 3).tobytes()
