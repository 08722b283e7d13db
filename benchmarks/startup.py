"""What a user's stopwatch sees: start-up, table loading, and the run, in one run (issue 27).

    python benchmarks/startup.py [--scenario scenarios/raid.yaml] [--duration 600] [--repeat 5]

Prints, each the median (and min) of ``--repeat`` runs, interleaved:

- ``shipradar --help``: wall and CPU of the whole process;
- ``shipradar run SCENE --duration D --quiet`` (tables from the cache): the process's wall and
  CPU measured from outside, the summary's ``process_wall_s`` and the loop's ``wall_s``, the
  ratio process / loop and the process's wall minus the loop's (the start-up a user pays);
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
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CLI = [sys.executable, "-m", "shipradar.sim.cli"]


def _timed(cmd: list[str]) -> tuple[float, float, str, str]:
    """Wall [s], CPU of the child [s], stdout and stderr of one process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, check=True)
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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="scenarios/raid.yaml")
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    run = [*CLI, "run", args.scenario, "--duration", str(args.duration), "--quiet"]
    help_ = [*CLI, "--help"]
    subprocess.run(run, capture_output=True, cwd=ROOT, check=True)  # tables into the cache
    rows: dict[str, list[float]] = {k: [] for k in (
        "help wall", "help CPU", "run wall", "run CPU", "process_wall_s", "loop wall_s",
        "wall - loop", "CPU - loop")}
    for _ in range(args.repeat):
        w, c, _, _ = _timed(help_)
        rows["help wall"].append(w)
        rows["help CPU"].append(c)
        w, c, out, _ = _timed(run)
        summary = json.loads(out.strip().splitlines()[-1])
        rows["run wall"].append(w)
        rows["run CPU"].append(c)
        rows["process_wall_s"].append(summary["process_wall_s"])
        rows["loop wall_s"].append(summary["wall_s"])
        rows["wall - loop"].append(w - summary["wall_s"])
        rows["CPU - loop"].append(c - summary["wall_s"])
    total, top = import_times(run)
    loads = table_load_s(args.scenario, args.repeat)
    print(f"load average {os.getloadavg()[0]:.2f}; {args.scenario}, {args.duration:g} s, "
          f"{args.repeat} runs")
    print("| measure | median | min |\n|---|---|---|")
    for k, v in rows.items():
        print(_row(k, v))
    print(_row("tables from the cache", loads))
    ratio = [p / max(w, 1e-9) for p, w in zip(rows["run wall"], rows["loop wall_s"],
                                               strict=True)]
    print(_row("process / loop (wall)", ratio, "x"))
    sim = args.duration
    print(f"real-time factor: loop {sim / statistics.median(rows['loop wall_s']):.0f}x, "
          f"process {sim / statistics.median(rows['run wall']):.0f}x")
    print(f"import time (-X importtime, sum of own times): {total:.3f} s; above 20 ms: "
          + ", ".join(f"{n} {t * 1e3:.0f} ms" for t, n in top))
    return 0


if __name__ == "__main__":
    sys.exit(main())
