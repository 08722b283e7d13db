"""What a user's stopwatch sees: start-up, table loading, and the run, in one run (issue 27).

    python benchmarks/startup.py [--scenario scenarios/raid.yaml] [--duration 600] [--repeat 5]

Prints, each the median (and min) of ``--repeat`` runs, interleaved:

- ``shipradar --help``: wall and CPU of the whole process;
- ``shipradar run SCENE --duration D --quiet`` (tables from the cache): the process's wall and
  CPU measured from outside, the summary's ``process_wall_s`` and the loop's ``wall_s``, the
  ratio process / loop and the process's wall minus the loop's (the start-up a user pays);
  and its main thread's CPU time outside ``Simulation.run`` (``time.thread_time``: without
  the CPU numpy's and scipy's OpenBLAS threads spin away, and without the waits of a loaded
  machine: the steadiest measure of the start-up's own work);
- the same run with the modules' bytecode cached (``--bytecode both``, the default):
  ``PYTHONDONTWRITEBYTECODE=1`` (set in these sessions, and an editable install has no
  bytecode of its own) compiles every shipradar module from source at each start, which a
  normal install does not (pip compiles the wheel's modules);
- the import time of that command (``python -X importtime``: the sum of every module's own
  time) and the modules above 20 ms;
- the scene's tables loaded from the cache (``load_scene_tables`` in this process, warm).

CPU time is the better guide on a loaded machine; ``os.getloadavg()`` is printed beside.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CLI = [sys.executable, "-m", "shipradar.sim.cli"]
#: ``python -m shipradar.sim.cli``, printing on stderr at exit its main thread's CPU time and
#: that thread's CPU time inside ``Simulation.run`` (wrapped when the engine is imported, so
#: the command's own imports are left as they are).
_MAIN_THREAD_CPU = """
import atexit, importlib.abc, importlib.machinery, runpy, sys, time
loop = [0.0]
class Wrap(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name != "shipradar.sim.engine.simulation":
            return None
        sys.meta_path.remove(self)
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        exec_module = spec.loader.exec_module
        def exec_and_wrap(module):
            exec_module(module)
            run = module.Simulation.run
            def timed(self, *a, **k):
                c = time.thread_time()
                try:
                    return run(self, *a, **k)
                finally:
                    loop[0] += time.thread_time() - c
            module.Simulation.run = timed
        spec.loader.exec_module = exec_and_wrap
        return spec
sys.meta_path.insert(0, Wrap())
atexit.register(lambda: sys.stderr.write(
    f"\\nMAIN_THREAD_CPU {time.thread_time()} {loop[0]}\\n"))
sys.argv[0] = "shipradar"
runpy.run_module("shipradar.sim.cli", run_name="__main__", alter_sys=True)
"""
CLI_TIMED = [sys.executable, "-c", _MAIN_THREAD_CPU]


def _timed(cmd: list[str], env: dict[str, str] | None = None) -> tuple[float, float, str, str]:
    """Wall [s], CPU of the child [s], stdout and stderr of one process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, check=True, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, proc.stdout, proc.stderr


def _row(name: str, values: list[float], unit: str = "s") -> str:
    return f"| {name} | {statistics.median(values):.3f} {unit} | {min(values):.3f} {unit} |"


def import_times(cmd: list[str]) -> tuple[float, list[tuple[float, str]]]:
    """Sum of the modules' own import times [s] and the top-level imports above 20 ms."""
    proc = subprocess.run([sys.executable, "-X", "importtime", *cmd[1:]], capture_output=True,
                          text=True, cwd=ROOT, check=True)
    total, top = 0.0, []
    for line in proc.stderr.splitlines():
        m = re.match(r"import time:\s+(\d+) \|\s+(\d+) \|( *)(\S+)", line)
        if not m:
            continue
        total += int(m[1]) / 1e6
        if len(m[3]) <= 1 and int(m[2]) > 20_000:
            top.append((int(m[2]) / 1e6, m[4]))
    return total, sorted(top, reverse=True)


def table_load_s(scenario: str, repeat: int) -> list[float]:
    from shipradar.sim.world.scenario import load_scenario
    from shipradar.tables.scene import load_scene_tables

    s = load_scenario(ROOT / scenario)
    load_scene_tables(s)  # builds what is missing, rewrites old-layout files
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        load_scene_tables(s)
        out.append(time.perf_counter() - t0)
    return out


def _environments(bytecode: str, pycache: str) -> dict[str, dict[str, str]]:
    """The environments of the timed runs: as this one (``env``) and/or with bytecode
    cached in ``pycache`` (``cached``)."""
    out = {}
    if bytecode in ("env", "both"):
        out["env"] = dict(os.environ)
    if bytecode in ("cached", "both"):
        env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        out["cached"] = dict(env, PYTHONPYCACHEPREFIX=pycache)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="scenarios/raid.yaml")
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--bytecode", choices=("env", "cached", "both"), default="both",
                    help="run as this environment says (these sessions: no bytecode written), "
                         "with the bytecode cached in a temporary directory, or both")
    args = ap.parse_args(argv)
    run = ["run", args.scenario, "--duration", str(args.duration), "--quiet"]
    help_ = [*CLI, "--help"]
    pycache = tempfile.mkdtemp(prefix="shipradar-pycache-")
    envs = _environments(args.bytecode, pycache)
    for env in envs.values():  # tables into the cache; bytecode into pycache
        subprocess.run([*CLI, *run], capture_output=True, cwd=ROOT, check=True, env=env)
    rows: dict[str, list[float]] = {"help wall": [], "help CPU": []}
    for name in envs:
        rows.update({f"{k} ({name})": [] for k in (
            "run wall", "run CPU", "main-thread CPU", "process_wall_s", "loop wall_s",
            "wall - loop", "CPU - loop", "main-thread CPU outside the loop")})
    loads = [os.getloadavg()[0]]
    for _ in range(args.repeat):
        w, c, _, _ = _timed(help_)
        rows["help wall"].append(w)
        rows["help CPU"].append(c)
        for name, env in envs.items():
            w, c, out, err = _timed([*CLI_TIMED, *run], env)
            summary = json.loads(out.strip().splitlines()[-1])
            main_cpu, loop_cpu = map(float, err.rsplit("MAIN_THREAD_CPU ", 1)[1].split())
            for k, v in (("run wall", w), ("run CPU", c), ("main-thread CPU", main_cpu),
                         ("process_wall_s", summary["process_wall_s"]),
                         ("loop wall_s", summary["wall_s"]), ("wall - loop", w - summary["wall_s"]),
                         ("CPU - loop", c - summary["wall_s"]),
                         ("main-thread CPU outside the loop", main_cpu - loop_cpu)):
                rows[f"{k} ({name})"].append(v)
        loads.append(os.getloadavg()[0])
    total, top = import_times([*CLI, *run])
    table_loads = table_load_s(args.scenario, args.repeat)
    print(f"load average {min(loads):.2f}-{max(loads):.2f}; {args.scenario}, "
          f"{args.duration:g} s, {args.repeat} runs; PYTHONDONTWRITEBYTECODE="
          f"{os.environ.get('PYTHONDONTWRITEBYTECODE', '')!r}")
    print("| measure | median | min |\n|---|---|---|")
    for k, v in rows.items():
        print(_row(k, v))
    print(_row("tables from the cache", table_loads))
    first = next(iter(envs))
    walls, loops = rows[f"run wall ({first})"], rows[f"loop wall_s ({first})"]
    ratio = [p / max(w, 1e-9) for p, w in zip(walls, loops, strict=True)]
    print(_row(f"process / loop (wall, {first})", ratio, "x"))
    sim = args.duration
    print(f"real-time factor ({first}): loop {sim / statistics.median(loops):.0f}x, "
          f"process {sim / statistics.median(walls):.0f}x")
    print(f"import time (-X importtime, sum of own times): {total:.3f} s; above 20 ms: "
          + ", ".join(f"{n} {t * 1e3:.0f} ms" for t, n in top))
    shutil.rmtree(pycache, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
