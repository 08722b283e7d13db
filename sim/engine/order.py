"""SimPy's event order for processes that only wait on timeouts, replayed without SimPy.

:class:`simpy.Environment` runs its events from a heap ordered by (time, priority, event
id), the id counting events in the order they were *scheduled*. A radar's process
(:meth:`shipradar.sim.engine.simulation.RadarProcess.run`) only ever waits on a timeout,
which it schedules while it runs: its initialisation is an URGENT event at t = 0 (one per
process, in the order the processes are started), and each resumption schedules the next one
(a NORMAL event, with the next id) at ``now + delay``. So the order in which the radars
resume follows from their times alone, and :class:`EventOrder` is that heap:

- the batched fast path (:meth:`shipradar.sim.engine.simulation.Simulation._run_batched`)
  drives the processes' generators with it on a plain clock;
- the parallel merge (:func:`shipradar.sim.engine.parallel.merge_order`) replays the times
  the workers recorded with it.

Both give the radars' messages in exactly the order one SimPy environment gives them
(``tests/test_engine_batched.py``, ``tests/test_parallel.py``).
"""

from __future__ import annotations

import heapq
from collections.abc import Iterator

__all__ = ["NORMAL", "URGENT", "EventOrder"]

#: SimPy's priorities: process initialisation (URGENT) before timeouts (NORMAL).
URGENT, NORMAL = 0, 1


class EventOrder:
    """The heap of one SimPy environment whose processes only wait on timeouts.

    Parameters
    ----------
    processes : int
        Processes started at t = 0, in this order (their indices ``0 .. processes - 1``).
    """

    __slots__ = ("_eid", "_heap")

    def __init__(self, processes: int) -> None:
        self._heap: list[tuple[float, int, int, int]] = [
            (0.0, URGENT, eid, eid) for eid in range(processes)]
        self._eid = processes

    def schedule(self, process: int, t: float) -> None:
        """Resume ``process`` at time ``t`` [s] (a timeout scheduled now: the next id)."""
        heapq.heappush(self._heap, (t, NORMAL, self._eid, process))
        self._eid += 1

    def resumptions(self, until: float = float("inf")) -> Iterator[tuple[int, float]]:
        """``(process, time)`` of each resumption in SimPy's order, those before ``until``
        [s]; the caller schedules each process's next resumption (:meth:`schedule`) before
        taking the next one."""
        heap, pop = self._heap, heapq.heappop
        while heap and heap[0][0] < until:
            t, _, _, process = pop(heap)
            yield process, t
