"""Cost of the beam-crossing search and of the unresolved-target grouping (issue 37).

    python benchmarks/crossings.py [--scenarios raid stress] [--duration 300] [--repeat 10]

Finds, for each scene (seed 7), the block of revolutions with the most (target, revolution)
pairs to search and times its crossing search again
(:meth:`shipradar.sim.engine.simulation.RadarProcess.crossings`, on the pairs of
``plan_scans`` for the revolutions of ``block_bounds``: the engine's public methods, the same
calls a run makes); then runs the scene keeping the inputs of every look's processing step
(:meth:`shipradar.sim.dwell.model.DwellModel.processing`: the unresolved-target grouping 2.2.1,
and the contacts' sums and leads; the look chain's public step, wrapped on each radar's model)
and times the largest again. Process CPU, best of ``--repeat`` runs of 20 calls (the process
CPU, not the wall clock: on a loaded machine other processes only stretch the wall clock).

Measured on the 2-core machine when issue 37 landed, on the same inputs, process CPU per
block: crossings, raid 1.82 ms (the old fixed-point iteration, 7fe6d38) -> 1.16 ms, stress
15.3 -> 14.6 ms; grouping a stress block of 10,560 looks, the grid 0.44 ms -> 2.9 ms (the
grouping alone, before the processing step was timed as a whole).
"""

from __future__ import annotations

import argparse
import time
import timeit
from collections.abc import Callable
from pathlib import Path
from typing import Any

from shipradar.sim.engine.simulation import RadarProcess, Simulation
from shipradar.sim.world.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def _best_ms(f: Callable[[], Any], repeat: int) -> float:
    return min(timeit.Timer(f, timer=time.process_time).repeat(number=20, repeat=repeat)) / 20e-3


def largest_crossing_block(sim: Simulation) -> tuple[RadarProcess, tuple[Any, ...]]:
    """The radar and the arguments of :meth:`RadarProcess.crossings` of the run's block with
    the most (target, revolution) pairs: the blocks a run computes, revolution ``0``,
    ``scans_per_block``, ... (nothing is run)."""
    best: tuple[RadarProcess, tuple[Any, ...]] | None = None
    for proc in sim.radars:
        for scan0 in range(0, proc.scans_in_run, proc.scans_per_block):
            t_as = [t_a for t_a, _ in proc.block_bounds(scan0)]
            rows, scan_of = proc.plan_scans(t_as)
            if best is None or rows.size > best[1][0].size:
                best = (proc, (rows, scan_of, t_as, scan0))
    assert best is not None
    return best


def processing_inputs(sim: Simulation) -> list[tuple[Callable[..., Any], tuple[Any, ...]]]:
    """Run ``sim`` keeping every call of each radar's processing step: the step (bound to its
    model) and its arguments (the public step wrapped on each model instance)."""
    store: list[tuple[Callable[..., Any], tuple[Any, ...]]] = []
    for proc in sim.radars:
        step = proc.model.processing

        def keep(*args: Any, _step: Callable[..., Any] = step) -> Any:
            store.append((_step, args))
            return _step(*args)

        proc.model.processing = keep  # type: ignore[method-assign]
    sim.run()
    return store


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", nargs="+", default=["raid", "stress"])
    ap.add_argument("--duration", type=float, default=300.0)
    ap.add_argument("--repeat", type=int, default=10)
    args = ap.parse_args()
    for name in args.scenarios:
        sc = load_scenario(ROOT / "scenarios" / f"{name}.yaml")
        sim = Simulation(sc, seed=7, duration_s=args.duration)
        proc, c_args = largest_crossing_block(sim)
        crossings_ms = _best_ms(lambda: proc.crossings(*c_args), args.repeat)  # noqa: B023
        calls = processing_inputs(Simulation(sc, seed=7, duration_s=args.duration))
        step, g_args = max(calls, key=lambda g: g[1][0].size)
        grouping_ms = _best_ms(lambda: step(*g_args), args.repeat)  # noqa: B023
        print(f"{name}: crossings {crossings_ms:.2f} ms per block ({c_args[0].size} "
              f"target-revolution pairs), processing (grouping) {grouping_ms:.2f} ms "
              f"({g_args[0].size} looks)")


if __name__ == "__main__":
    main()
