"""Cost of the beam-crossing search and of the unresolved-target grouping (issue 37).

    python benchmarks/crossings.py [--scenarios raid stress] [--duration 300] [--repeat 10]

Runs each scene once (seed 7) keeping the inputs of every block's crossing search
(``_RadarProcess._crossings``) and of every look's grouping
(``DwellModel._resolution_groups``), then times both again on the largest block's inputs:
process CPU, best of ``--repeat`` runs of 20 calls (the process CPU, not the wall clock: on a
loaded machine other processes only stretch the wall clock).

Measured on the 2-core machine when issue 37 landed, on the same inputs, process CPU per
block: crossings, raid 1.82 ms (the old fixed-point iteration, 7fe6d38) -> 1.16 ms, stress
15.3 -> 14.6 ms; grouping a stress block of 10,560 looks, the grid 0.44 ms -> 2.9 ms.
"""

from __future__ import annotations

import argparse
import time
import timeit
from pathlib import Path

from shipradar.sim.dwell import model as dwell_model
from shipradar.sim.engine import simulation as engine
from shipradar.sim.world.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def _capture(cls, name: str, store: list):
    """Wrap ``cls.name`` to keep its inputs; returns the original."""
    orig = getattr(cls, name)

    def keep(self, *args, **kw):
        # the block's first revolution (the crossing search reads it) as it was at the call
        store.append((self, args, {**kw, "_scan0": getattr(self, "_block_scan0", None)}))
        return orig(self, *args, **kw)

    setattr(cls, name, keep)
    return orig


def _best_ms(f, repeat: int) -> float:
    return min(timeit.Timer(f, timer=time.process_time).repeat(number=20, repeat=repeat)) / 20e-3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", nargs="+", default=["raid", "stress"])
    ap.add_argument("--duration", type=float, default=300.0)
    ap.add_argument("--repeat", type=int, default=10)
    args = ap.parse_args()
    for name in args.scenarios:
        crossings: list = []
        groups: list = []
        cross = _capture(engine._RadarProcess, "_crossings", crossings)
        group = _capture(dwell_model.DwellModel, "_resolution_groups", groups)
        try:
            sc = load_scenario(ROOT / "scenarios" / f"{name}.yaml")
            engine.Simulation(sc, seed=7, duration_s=args.duration).run()
        finally:
            engine._RadarProcess._crossings = cross
            dwell_model.DwellModel._resolution_groups = group
        proc, c_args, c_kw = max(crossings, key=lambda c: c[1][0].size)
        model, g_args, g_kw = max(groups, key=lambda g: g[1][0].slant_range.size)
        g_kw.pop("_scan0")
        solve = _solver(cross, proc, c_args, c_kw["_scan0"])
        print(f"{name}: crossings {_best_ms(solve, args.repeat):.2f} "
              f"ms per block ({c_args[0].size} target-revolution pairs), grouping "
              f"{_best_ms(lambda: group(model, *g_args, **g_kw), args.repeat):.2f} ms "  # noqa: B023
              f"({g_args[0].slant_range.size} looks)")


def _solver(cross, proc, c_args, scan0: int):
    """One block's crossing search again, with the block's first revolution restored."""

    def solve():
        proc._block_scan0 = scan0
        return cross(proc, *c_args)

    return solve

if __name__ == "__main__":
    main()
