"""What a fidelity setting costs, as a user pays it, with its spread (issue 38).

A setting's cost has three parts, paid at different times:

* **table build** [s CPU]: once per table cache (``shipradar tables build``, or the first
  run on an empty cache);
* **table load** [s CPU]: once per process, reading the setting's tables from the cache;
* **run** [s CPU]: every run. *Warm*: a run in a process that has already run the setting on
  the same tables, given the first run's preparation (a Monte Carlo study's second and later
  replications: :class:`shipradar.sim.dwell.prepared.PreparedScene`). *First*: the table
  load plus the first run on the freshly loaded tables, with a preparation of its own made
  by the run, as in a new process (imports and Python's own caches stay warm).

A candidate is timed against the reference **in alternation** (reference, candidate; then
candidate, reference; ...), with the same seed in a pair, so that the machine's slow
minutes fall on both sides; the cost is the geometric mean of the paired ratios
candidate/reference and its Student-t interval on the logarithms
(:func:`ratio_interval`). Seconds are CPU seconds (``time.process_time``): this machine is
shared, and CPU time is what a study is billed in cores.

A candidate is *cheaper* only when the whole interval of its ratio lies below
1 - :data:`SAVING_MIN`; otherwise the measurement cannot tell it from the reference
(:func:`is_cheaper`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from shipradar.sim.studies.montecarlo import CONFIDENCE

__all__ = [
    "CONFIDENCE",
    "SAVING_MIN",
    "Interval",
    "PairedCost",
    "Sample",
    "SampleTimer",
    "SceneTimer",
    "is_cheaper",
    "mean_interval",
    "paired_costs",
    "ratio_interval",
]

#: The smallest saving the advisor calls a saving: a candidate is cheaper when its ratio's
#: whole interval is below 1 - SAVING_MIN. With ~10 candidates, a one-sided 2.5 % error
#: each would make one of two commands pick a setting that is not cheaper at all; the
#: margin keeps a true tie on the reference's side.
SAVING_MIN = 0.05


@dataclass(frozen=True)
class Interval:
    """An estimate and its two-sided confidence interval (:data:`CONFIDENCE`)."""

    value: float
    low: float
    high: float
    n: int

    def fmt(self, digits: int = 2, unit: str = "") -> str:
        """``value [low, high]unit``."""
        if self.n == 0 or not math.isfinite(self.value):
            return "-"
        return (f"{self.value:.{digits}f} [{self.low:.{digits}f}, {self.high:.{digits}f}]"
                f"{unit}")


def _t(n: int, confidence: float) -> float:
    from scipy.stats import t

    return float(t.ppf(0.5 + confidence / 2, n - 1))


def mean_interval(samples: Sequence[float], confidence: float = CONFIDENCE) -> Interval:
    """The mean of ``samples`` and its Student-t interval (zero width for one sample)."""
    x = np.asarray(samples, dtype=float)
    if x.size == 0:
        return Interval(math.nan, math.nan, math.nan, 0)
    m = float(x.mean())
    if x.size < 2:
        return Interval(m, m, m, 1)
    h = _t(x.size, confidence) * float(x.std(ddof=1)) / math.sqrt(x.size)
    return Interval(m, m - h, m + h, int(x.size))


def ratio_interval(candidate: Sequence[float], reference: Sequence[float],
                   confidence: float = CONFIDENCE) -> Interval:
    """Geometric mean of the paired ratios ``candidate[i] / reference[i]`` and its interval.

    The interval is the Student-t interval of the mean log ratio, exponentiated: a ratio
    of costs is multiplicative noise (a loaded minute slows both sides by a factor), and the
    log keeps 0.5x and 2x symmetric.
    """
    c = np.maximum(np.asarray(candidate, dtype=float), 1e-9)
    r = np.maximum(np.asarray(reference, dtype=float), 1e-9)
    if c.size != r.size:
        raise ValueError(f"paired samples of unequal length: {c.size} and {r.size}")
    m = mean_interval(np.log(c / r), confidence)
    if m.n == 0:
        return m
    return Interval(math.exp(m.value), math.exp(m.low), math.exp(m.high), m.n)


def is_cheaper(ratio: Interval, saving_min: float = SAVING_MIN) -> bool:
    """Whether the interval of a cost ratio says the candidate is cheaper (all of it below
    ``1 - saving_min``); a single pair never does."""
    return ratio.n >= 2 and ratio.high < 1.0 - saving_min


@dataclass(frozen=True)
class Sample:
    """One timing of one setting [s CPU]."""

    load_s: float
    first_run_s: float
    warm_run_s: float

    @property
    def first_s(self) -> float:
        """Load plus the first run: what one ``shipradar run`` pays after start-up."""
        return self.load_s + self.first_run_s


class SampleTimer(Protocol):
    """Times one setting once: ``timer(fidelity_block, seed) -> Sample``. The study's is
    :class:`SceneTimer`; a test passes a cost model instead."""

    def __call__(self, fidelity: dict[str, Any], seed: int) -> Sample: ...


@dataclass
class PairedCost:
    """A candidate timed against the reference in alternation (one entry per pair)."""

    reference: list[Sample] = field(default_factory=list)
    candidate: list[Sample] = field(default_factory=list)

    def _ratio(self, what: Callable[[Sample], float]) -> Interval:
        return ratio_interval([what(s) for s in self.candidate],
                              [what(s) for s in self.reference])

    @property
    def warm_ratio(self) -> Interval:
        """Warm run CPU, candidate over reference."""
        return self._ratio(lambda s: s.warm_run_s)

    @property
    def first_ratio(self) -> Interval:
        """Table load + first run, candidate over reference."""
        return self._ratio(lambda s: s.first_s)

    def saving_s(self, what: str) -> Interval:
        """The reference's CPU minus the candidate's [s], mean over the pairs and its
        interval, of ``what`` (a :class:`Sample` attribute: ``warm_run_s``, ``first_s``).
        Unlike the ratio it does not depend on what both sides pay alike (a fresh
        process's imports: the saving carries over to a whole process unchanged)."""
        return mean_interval([getattr(r, what) - getattr(c, what)
                              for r, c in zip(self.reference, self.candidate, strict=True)])

    def ratio(self, objective: str) -> Interval:
        """The ratio the objective reads (``per-run``: warm; ``first-run``: load + first)."""
        return self.warm_ratio if objective == "per-run" else self.first_ratio

    def seconds(self, what: str, side: str = "candidate") -> Interval:
        """Mean seconds of ``what`` (``load_s``, ``first_run_s``, ``warm_run_s``,
        ``first_s``) on one side, with its interval."""
        samples = self.candidate if side == "candidate" else self.reference
        return mean_interval([getattr(s, what) for s in samples])


def paired_costs(timer: SampleTimer, reference: dict[str, Any],
                 candidates: Sequence[dict[str, Any]], seeds: Sequence[int], pairs: int,
                 *, log: Callable[[str], None] | None = None) -> list[PairedCost]:
    """Time every candidate against the reference, ``pairs`` alternating pairs each.

    Pair ``i`` of every candidate uses ``seeds[i % len(seeds)]``; the reference goes first in
    even pairs and second in odd ones (an order effect, a warm cache or a drifting load,
    then cancels); the candidates are visited in turn inside each round, so that a slow
    minute of the machine is spread over all of them rather than landing on one.
    """
    out = [PairedCost() for _ in candidates]
    for i in range(pairs):
        seed = seeds[i % len(seeds)]
        if log is not None:
            log(f"fidelity: timing pair {i + 1} of {pairs} ({len(candidates)} setting(s)) ...")
        order = range(len(candidates)) if i % 2 == 0 else reversed(range(len(candidates)))
        for k in order:
            if i % 2 == 0:
                r = timer(reference, seed)
                c = timer(candidates[k], seed)
            else:
                c = timer(candidates[k], seed)
                r = timer(reference, seed)
            out[k].reference.append(r)
            out[k].candidate.append(c)
    return out


class SceneTimer:
    """Times a scene under a fidelity block as a user runs it (no observers, no common
    random numbers: the stream's own draws), over ``duration_s`` simulated seconds.
    ``with_fidelity(fidelity_block)`` gives the scene under a block (validated)."""

    def __init__(self, with_fidelity: Callable[[dict[str, Any]], Any], duration_s: float):
        self.with_fidelity = with_fidelity
        self.duration_s = duration_s
        self._scenes: dict[str, Any] = {}

    def _scene(self, fid: dict[str, Any]) -> Any:
        key = repr(sorted(fid.items()))
        if key not in self._scenes:
            self._scenes[key] = self.with_fidelity(fid)
        return self._scenes[key]

    def __call__(self, fidelity: dict[str, Any], seed: int) -> Sample:
        from shipradar.sim.engine.simulation import Simulation
        from shipradar.tables.scene import load_scene_tables

        scene = self._scene(fidelity)
        c0 = time.process_time()
        tables = load_scene_tables(scene)
        c1 = time.process_time()
        first = Simulation(scene, seed=seed, duration_s=self.duration_s, tables=tables)
        first.run()  # its own preparation, made in the run's set-up
        c2 = time.process_time()
        Simulation(scene, seed=seed, duration_s=self.duration_s, tables=tables,
                   prepared=first.prepared).run()
        c3 = time.process_time()
        return Sample(c1 - c0, c2 - c1, c3 - c2)
