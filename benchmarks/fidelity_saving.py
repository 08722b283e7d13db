"""An independent check of the saving ``shipradar fidelity`` prints (issue 38).

Times two fidelity blocks of a scene against each other in alternating pairs through the
public API alone (``shipradar.build_tables``, ``shipradar.run``), not through the advisor's
timing code, and prints the ratio of their CPU and the saving [s CPU], each with a 95 %
interval:

* ``--what per-run`` (default): in this process, the tables of both blocks loaded once, then
  ``--pairs`` pairs of runs (the first run of each block untimed);
* ``--what first-run``: each sample a fresh Python process that loads the block's tables
  from the cache and runs the scene once, timing both in the child (its start-up, the
  imports, left out; the advisor's first run leaves them out too).

Example (the block the advisor recommended, against its reference)::

    python benchmarks/fidelity_saving.py --example single_missile --pairs 20 \\
        --set pe_grid=coarse --what first-run

The reference is the advisor's most accurate block
(:func:`shipradar.sim.studies.fidelity.reference_fidelity`); ``--set`` changes the
candidate's choices, ``--reference-set`` the reference's.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from typing import Any

import numpy as np
from scipy import stats

_CHILD = """
import json, sys, time
import shipradar
from shipradar.sim.world.scenario import Scenario
data = json.loads(sys.argv[1])
s = Scenario.model_validate(data["scenario"])
t0 = time.process_time()
tables = shipradar.build_tables(s)
shipradar.run(s, tables=tables, seed=data["seed"], duration_s=data["duration"])
print(time.process_time() - t0)
"""


def _value(text: str) -> Any:
    low = text.lower()
    if low in ("true", "false"):
        return low == "true"
    try:
        return int(text)
    except ValueError:
        return text


def _block(base: dict[str, Any], sets: list[str]) -> dict[str, Any]:
    out = dict(base)
    for item in sets:
        key, _, val = item.partition("=")
        if key not in out:
            raise SystemExit(f"--set: unknown fidelity choice {key!r} (one of {sorted(out)})")
        out[key] = _value(val)
    return out


def _with(scenario, fid: dict[str, Any]):
    from shipradar.sim.world.scenario import Scenario

    data = scenario.model_dump(mode="python")
    data["fidelity"] = fid
    return Scenario.model_validate(data)


def _interval(cand: list[float], ref: list[float]) -> dict[str, float]:
    """Geometric mean of the paired ratios and the 95 % t-interval of the mean log ratio;
    also the median ratio and how many pairs had the candidate cheaper."""
    d = np.log(np.asarray(cand)) - np.log(np.asarray(ref))
    n = d.size
    t = stats.t.ppf(0.975, n - 1)
    half = t * d.std(ddof=1) / math.sqrt(n)
    sv = np.asarray(ref) - np.asarray(cand)
    sv_half = t * sv.std(ddof=1) / math.sqrt(n)
    return {"pairs": n, "ratio": math.exp(d.mean()), "low": math.exp(d.mean() - half),
            "high": math.exp(d.mean() + half),
            "saving_s": float(sv.mean()), "saving_s_low": float(sv.mean() - sv_half),
            "saving_s_high": float(sv.mean() + sv_half),
            "median_ratio": float(np.median(np.asarray(cand) / np.asarray(ref))),
            "candidate_cheaper_in": int((d < 0).sum()),
            "ref_mean_s": float(np.mean(ref)), "candidate_mean_s": float(np.mean(cand))}


def per_run(ref, cand, pairs: int, seed: int, duration: float | None) -> dict[str, float]:
    import shipradar

    tables = {k: shipradar.build_tables(s) for k, s in (("ref", ref), ("cand", cand))}
    for k, s in (("ref", ref), ("cand", cand)):  # the untimed first runs
        shipradar.run(s, tables=tables[k], seed=seed, duration_s=duration)
    r, c = [], []
    for i in range(pairs):
        order = (("ref", ref), ("cand", cand)) if i % 2 == 0 else (("cand", cand), ("ref", ref))
        for k, s in order:
            t0 = time.process_time()
            shipradar.run(s, tables=tables[k], seed=seed + i, duration_s=duration)
            (r if k == "ref" else c).append(time.process_time() - t0)
    return _interval(c, r)


def first_run(ref, cand, pairs: int, seed: int, duration: float | None) -> dict[str, float]:
    def child(s, i: int) -> float:
        arg = json.dumps({"scenario": s.model_dump(mode="json"), "seed": seed + i,
                          "duration": duration})
        out = subprocess.run([sys.executable, "-c", _CHILD, arg], check=True,
                             capture_output=True, text=True, env=os.environ.copy())
        return float(out.stdout.strip().splitlines()[-1])

    child(ref, 0), child(cand, 0)  # the cache filled, the bytecode compiled
    r, c = [], []
    for i in range(pairs):
        if i % 2 == 0:
            r.append(child(ref, i))
            c.append(child(cand, i))
        else:
            c.append(child(cand, i))
            r.append(child(ref, i))
    return _interval(c, r)


def main(argv: list[str] | None = None) -> int:
    from shipradar.sim.studies.fidelity import reference_fidelity
    from shipradar.sim.world.scenario import load_scenario

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scenario", nargs="?")
    p.add_argument("--example")
    p.add_argument("--set", action="append", default=[], metavar="CHOICE=VALUE")
    p.add_argument("--reference-set", action="append", default=[], metavar="CHOICE=VALUE")
    p.add_argument("--pairs", type=int, default=20)
    p.add_argument("--seed", type=int, default=1000)
    p.add_argument("--duration", type=float, default=None)
    p.add_argument("--what", choices=("per-run", "first-run"), default="per-run")
    args = p.parse_args(argv)
    if args.example:
        from shipradar.scenarios import example_path

        path = str(example_path(args.example))
    else:
        path = args.scenario
    scenario = load_scenario(path)
    base = reference_fidelity(scenario)
    ref = _with(scenario, _block(base, args.reference_set))
    cand = _with(scenario, _block(base, args.set))
    fn = per_run if args.what == "per-run" else first_run
    out = fn(ref, cand, args.pairs, args.seed, args.duration)
    print(json.dumps({"scenario": scenario.name, "what": args.what,
                      "candidate": args.set, "reference": args.reference_set or "advisor's",
                      "load_average": os.getloadavg()[0], **out}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
