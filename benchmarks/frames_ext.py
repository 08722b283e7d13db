"""The compiled extension against the pure-Python encoder: what a run without a C compiler costs.

A recorded run (``Bus(None, Recorder)``, as ``shipradar run --record``) of a shipped scene in
this one process, alternately with the compiled ``shipradar._frames`` and with the pure-Python
twin ``shipradar._frames_py`` (what an install without a C compiler, or
``SHIPRADAR_PURE_PYTHON=1``, runs), ``--pairs`` pairs after a warm-up of each; per run the CPU
time and wall time of the loop and the close, and the recording's hash (the two must be
equal). Prints the medians, the ratios and the extra CPU per 1,000 messages
(docs/performance.md section 15). CPU time is the figure to read on a shared machine.

    python benchmarks/frames_ext.py [--example raid] [--duration 120] [--pairs 7]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path
from types import ModuleType
from typing import Any

from shipradar import _frames_py, _framing, example_path
from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream import protocol, recording
from shipradar.sim.stream.bus import Bus
from shipradar.sim.stream.recording import Recorder
from shipradar.sim.world.scenario import load_scenario
from shipradar.tables.scene import load_scene_tables


def _use(module: ModuleType) -> None:
    """Every user of the byte work takes ``module`` (as shipradar._framing would choose)."""
    protocol._frames = module  # type: ignore[attr-defined]
    recording._frames = module  # type: ignore[attr-defined]


def _one(scenario: Any, tables: Any, duration: float, module: ModuleType, out: Path
         ) -> dict[str, Any]:
    _use(module)
    bus = Bus(None, Recorder(out, overwrite=True))
    sim = Simulation(scenario, bus=bus, duration_s=duration, tables=tables, seed=1)
    t0, c0 = time.perf_counter(), time.process_time()
    summary = sim.run()
    bus.close()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"wall_s": wall, "cpu_s": cpu, "messages": summary["bus"]["messages"],
            "sha256": hashlib.sha256(out.read_bytes()).hexdigest()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--example", default="raid")
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--pairs", type=int, default=7)
    args = ap.parse_args()
    if not _framing.COMPILED:
        sys.exit("shipradar._frames is not in use here (not built, or SHIPRADAR_PURE_PYTHON "
                 "set): nothing to compare with")
    compiled = _framing.frames
    scenario = load_scenario(example_path(args.example))
    tables = load_scene_tables(scenario)
    impls = {"compiled": compiled, "pure_python": _frames_py}
    runs: dict[str, list[dict[str, Any]]] = {name: [] for name in impls}
    with tempfile.TemporaryDirectory() as tmp:
        for module in impls.values():  # warm-up: imports, caches, first-touch pages
            _one(scenario, tables, min(args.duration, 10.0), module, Path(tmp) / "warm.rec")
        for k in range(args.pairs):
            names = list(impls) if k % 2 == 0 else list(impls)[::-1]  # alternate the order
            for name in names:
                runs[name].append(_one(scenario, tables, args.duration, impls[name],
                                       Path(tmp) / f"{name}.rec"))
    _use(compiled)
    messages = runs["compiled"][0]["messages"]
    med = {name: {key: statistics.median(r[key] for r in rs) for key in ("cpu_s", "wall_s")}
           for name, rs in runs.items()}
    print(json.dumps({
        "example": args.example, "duration_s": args.duration, "pairs": args.pairs,
        "messages": messages,
        "same_bytes": len({r["sha256"] for rs in runs.values() for r in rs}) == 1,
        "median": {name: {k: round(v, 4) for k, v in m.items()} for name, m in med.items()},
        "ratio_pure_over_compiled": {k: round(med["pure_python"][k] / med["compiled"][k], 3)
                                     for k in ("cpu_s", "wall_s")},
        "extra_cpu_ms_per_1000_messages": round(
            1e6 * (med["pure_python"]["cpu_s"] - med["compiled"]["cpu_s"]) / messages, 2),
        "realtime_factor_cpu": {name: round(args.duration / m["cpu_s"], 1)
                                for name, m in med.items()},
    }, indent=1))


if __name__ == "__main__":
    main()
