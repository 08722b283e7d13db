"""Cost of the sensor errors (issue 33) on the raid's loop, with a recording.

    python benchmarks/sensor_errors.py [--baseline f3dec34^] [--duration 600] [--repeat 7]

Five cases, each the raid run for ``--duration`` simulated seconds into a recording (the
batched fast path, as ``shipradar run --record``), its tables loaded and a warm-up run made
outside the timing; each run's process CPU time and wall time, the fastest of ``--repeat``
kept (other processes only ever slow a run down), the cases alternated run by run so that a
change of load hits them alike, each in its own process:

- ``off, before``: the code of ``--baseline`` (the commit before the errors were added, in a
  temporary git worktree imported in a subprocess, the working tree's compiled frame
  extension beside it when its source is the same);
- ``off``: today's code, no ``errors:`` (the shipped raid), and ``off, again``, the same in
  another process (its ratio to ``off`` is the comparison's noise floor);
- ``on``: every radar with a Gauss-Markov range bias, range scale, north alignment and time
  offset plus a time-stamp jitter, and the ship's navigation with Gauss-Markov position and
  heading errors (no latency);
- ``on + latency``: the same and a reporting latency of 0.5 s + an exponential 0.5 s per
  sector message (every process then resumes at its messages' publication times).

Issue 33's targets: ``off`` costs nothing measurable against ``off, before``; ``on`` at most
10 % more than ``off``.  On a loaded machine the run-to-run spread of such short runs is
itself ~10 %, so besides the fastest run of each case and the median of the per-round ratios
to ``off``, the error code's own time inside the ``on`` runs is measured directly (every
function of :mod:`shipradar.sensors.sensor_errors` and the engine's truth[sensors] and
latency helpers wrapped in a timer, outermost calls only) as a share of the run's loop.
"""

from __future__ import annotations

import argparse
import filecmp
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GM = {"sigma": 1.0, "correlation_time_s": 300.0}
ERRORS = {"range_bias_m": {"mean": 150.0, **GM, "sigma": 20.0},
          "range_scale_ppm": {"mean": 50.0, **GM, "sigma": 10.0},
          "azimuth_bias_deg": {"mean": 0.3, **GM, "sigma": 0.05},
          "time_offset_s": {"mean": 0.05, **GM, "sigma": 0.01},
          "time_jitter_s": 0.002}
NAVIGATION = {"east_error_m": {"mean": 10.0, **GM, "sigma": 15.0},
              "north_error_m": {"mean": -5.0, **GM, "sigma": 15.0},
              "up_error_m": {"mean": 0.0, **GM, "sigma": 2.0},
              "heading_bias_deg": {"mean": 0.1, **GM, "sigma": 0.05}}
LATENCY = {"fixed_s": 0.5, "random_mean_s": 0.5}


def scene(case: str):
    """The raid, with the errors of ``case`` (``off``, ``on``, ``on + latency``)."""
    from shipradar.sim.world.scenario import load_scenario

    s = load_scenario(ROOT / "scenarios" / "raid.yaml")
    if case == "off":
        return s
    d = s.model_dump(mode="json")
    for p in d["platforms"]:
        p["navigation"] = NAVIGATION
        for r in p["radars"]:
            r["errors"] = {**ERRORS, **({"latency": LATENCY} if "latency" in case else {})}
    return type(s).model_validate(d)


def time_run(s, duration: float, tables) -> tuple[float, float]:
    """(process CPU, wall) [s] of one run of ``s`` into a recording."""
    from shipradar.sim.engine.simulation import Simulation
    from shipradar.sim.stream.bus import Bus
    from shipradar.sim.stream.recording import Recorder

    with tempfile.TemporaryDirectory() as tmp:
        with Bus(None, Recorder(Path(tmp) / "run.srrec")) as bus:
            sim = Simulation(s, bus=bus, duration_s=duration, tables=tables)
            c0, w0 = time.process_time(), time.perf_counter()
            sim.run()
            return time.process_time() - c0, time.perf_counter() - w0


class Worker:
    """Runs of one case in a process (this one, or a subprocess on the baseline's code)."""

    def __init__(self, case: str, duration: float):
        from shipradar.tables.scene import load_scene_tables

        self.s = scene(case)
        self.tables = load_scene_tables(self.s)
        self.duration = duration
        time_run(self.s, min(duration, 60.0), self.tables)  # warm-up

    def run(self) -> tuple[float, float]:
        return time_run(self.s, self.duration, self.tables)


def _importable(tree: Path) -> Path:
    """``tree`` (a checkout, whose ``shipradar/`` links its subpackages) with the working
    tree's compiled frame extension beside its source when that source is the same."""
    pkg = tree / "shipradar"
    if filecmp.cmp(pkg / "_frames.c", ROOT / "shipradar" / "_frames.c", shallow=False):
        for so in (ROOT / "shipradar").glob("_frames*.so"):
            (pkg / so.name).symlink_to(so)
    return tree


class ErrorCodeTimer:
    """Wall time spent in the error code, outermost calls only (the wrapped functions call
    one another)."""

    def __init__(self) -> None:
        from shipradar.sensors import sensor_errors
        from shipradar.sim.engine import simulation

        self.total = 0.0
        self._depth = 0
        targets = [(sensor_errors.RadarErrors, n) for n in (
            "apply", "values", "navigation_offset", "heading_bias_rad", "latencies_s",
            "forget_before")]
        targets += [(simulation.RadarProcess, n) for n in (
            "_truth_sensors_items", "_truth_sensors", "_publication_times")]
        for owner, name in targets:
            setattr(owner, name, self._wrap(getattr(owner, name)))

    def _wrap(self, fn):
        def timed(*a, **kw):
            self._depth += 1
            t0 = time.perf_counter()
            try:
                return fn(*a, **kw)
            finally:
                self._depth -= 1
                if not self._depth:
                    self.total += time.perf_counter() - t0
        return timed


class Subprocess:
    """A worker of one case in its own process (each case alike: its own tables, memory and
    caches), on today's code or, with ``rev``, on that revision's (a temporary git worktree):
    one line in, one run's times out."""

    def __init__(self, case: str, duration: float, rev: str | None = None):
        self.tmp = tempfile.TemporaryDirectory()
        tmp = Path(self.tmp.name)
        self.tree: Path | None = None
        env = dict(os.environ)
        if rev is not None:
            self.tree = tmp / "tree"
            subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach",
                            str(self.tree), rev], check=True, capture_output=True)
            env["PYTHONPATH"] = str(_importable(self.tree))
        self.proc = subprocess.Popen(
            [sys.executable, str(Path(__file__).resolve()), "--worker", case,
             "--duration", str(duration)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            text=True, env=env, cwd=tmp)
        code = Path(self._read())
        want = ROOT if self.tree is None else self.tree
        if code.resolve() != want.resolve():
            raise SystemExit(f"the {case!r} worker imported {code}, not {want}")

    def _read(self):
        assert self.proc.stdout is not None
        return json.loads(self.proc.stdout.readline())

    def ask(self, what: str):
        assert self.proc.stdin is not None
        self.proc.stdin.write(what + "\n")
        self.proc.stdin.flush()
        return self._read()

    def run(self) -> tuple[float, float]:
        cpu, wall = self.ask("run")
        return cpu, wall

    def close(self) -> None:
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        self.proc.wait()
        if self.tree is not None:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force",
                            str(self.tree)], check=True, capture_output=True)
        self.tmp.cleanup()


def worker_loop(case: str, duration: float) -> None:
    import shipradar.sim.engine.simulation as engine

    w = Worker(case, duration)
    print(json.dumps(str(Path(engine.__file__).resolve().parents[2])), flush=True)
    timer = None
    for line in sys.stdin:
        what = line.strip()
        if what == "run":
            print(json.dumps(w.run()), flush=True)
        elif what == "timed":  # the error code's own wall time, and the run's
            timer = timer or ErrorCodeTimer()
            timer.total = 0.0
            _, wall = w.run()
            print(json.dumps([timer.total, wall]), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default="f3dec34^",
                    help="git revision before the errors (none: skip that case)")
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        worker_loop(args.worker, args.duration)
        return
    cases: dict[str, Subprocess] = {}
    try:
        if args.baseline != "none":
            cases["off, before"] = Subprocess("off", args.duration, args.baseline)
        for case in ("off", "on", "on + latency"):
            cases[case] = Subprocess(case, args.duration)
        # the same code in another process: the noise floor of the comparison
        cases["off, again"] = Subprocess("off", args.duration)
        best: dict[str, tuple[float, float]] = {}
        ratios: dict[str, list[float]] = {name: [] for name in cases}
        for _ in range(args.repeat):
            cpus = {}
            for name, w in cases.items():
                cpu, wall = w.run()
                cpus[name] = cpu
                old = best.get(name)
                best[name] = (min(cpu, old[0]), min(wall, old[1])) if old else (cpu, wall)
            for name, cpu in cpus.items():
                ratios[name].append(cpu / cpus["off"])
        share = {case: min(tuple(cases[case].ask("timed")) for _ in range(3))
                 for case in ("on", "on + latency")}
    finally:
        for w in cases.values():
            w.close()
    print(f"raid, {args.duration:g} simulated s, with a recording; fastest of {args.repeat}; "
          f"load average {os.getloadavg()[0]:.2f}")
    ref = best["off"][0]
    for name, (cpu, wall) in best.items():
        med = sorted(ratios[name])[len(ratios[name]) // 2]
        print(f"{name:>14}: CPU {cpu:.3f} s ({cpu / ref:.3f}x off; median ratio {med:.3f}), "
              f"wall {wall:.3f} s, {args.duration / wall:.0f}x real time")
    for case, (secs, wall) in share.items():
        print(f"{case:>14}: error code {secs * 1e3:.1f} ms, {100 * secs / wall:.1f} % of the "
              f"run's wall time")


if __name__ == "__main__":
    main()
