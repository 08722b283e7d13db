"""Which truth a tracker is scored against: the geometric rule against the looks' P_d.

    python benchmarks/truth_rules.py STUDY_DIR

For each recorded run of a study (``shipradar evaluate ... --out STUDY_DIR``): the scan-target
pairs each rule counts (``--truth coverage``: in_coverage, instrumented range and 4/3-earth
horizon; ``--truth pd``: some radar's look of the last three scans reached P_d 0.5), the
looks and the target plots on targets outside ``in_coverage``, and the run's scores by each
rule. Used for docs/studies.md, "Which truth a tracker is scored against" (the raid, and
``benchmarks/scenes/ducted.yaml``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

KEYS = ("gospa", "missed", "false", "siap_completeness", "siap_spuriousness",
        "false_tracks", "track_breaks")


def plots_outside_coverage(run_dir: Path) -> dict[str, tuple[int, int]]:
    """Per radar: target plots, and of them those whose target was not in_coverage at the
    radar's previous end of scan."""
    from shipradar.sim.stream.protocol import decode
    from shipradar.sim.stream.recording import read_recording

    cover: dict[str, np.ndarray] = {}
    out: dict[str, list[int]] = {}
    with read_recording(run_dir / "stream.rec") as reader:
        for _, frames in reader:
            topic, _, p = decode(frames)
            if topic != b"truth":
                continue
            if p["kind"] == "targets":
                cover[p["sensor"]] = np.asarray(p["in_coverage"], bool)
            elif p["sensor"] in cover:
                tg = np.asarray(p["target"])
                tg = tg[tg >= 0]
                n = out.setdefault(p["sensor"], [0, 0])
                n[0] += tg.size
                n[1] += int((~cover[p["sensor"]][tg]).sum())
    return {s: (a, b) for s, (a, b) in out.items()}


def main(argv: list[str] | None = None) -> int:
    from shipradar.sim.studies.evaluate.data import load_run
    from shipradar.sim.studies.evaluate.metrics import MetricConfig, counted_matrix, score_run

    study = Path((argv or sys.argv[1:])[0])
    for run_dir in sorted((study / "runs").glob("seed-*")):
        data = load_run(run_dir)
        cov = counted_matrix(data, MetricConfig(truth="coverage"))
        pdc = counted_matrix(data, MetricConfig(truth="pd"))
        print(f"{run_dir.name}: scan-target pairs counted: coverage {int(cov.sum())}, pd "
              f"{int(pdc.sum())} (pd only {int((pdc & ~cov).sum())}, coverage only "
              f"{int((cov & ~pdc).sum())})")
        for s, (_times, look_t, pd) in data.looks.items():
            _, inside = data.coverage[s]
            before = np.vstack([np.full((1, look_t.shape[1]), np.nan), look_t[:-1]])
            new = np.isfinite(look_t) & ~(look_t == before)  # a copy's look not seen before
            out = new & ~inside
            print(f"  {s}: looks {int(new.sum())}, on targets not in_coverage "
                  f"{int(out.sum())}, of them with P_d >= 0.5 {int((out & (pd >= 0.5)).sum())}")
        for s, (n, outside) in plots_outside_coverage(run_dir).items():
            print(f"  {s}: target plots {n}, on targets not in_coverage {outside}")
        for rule in ("coverage", "pd"):
            run = score_run(data, MetricConfig(truth=rule)).run
            print(f"  --truth {rule}: " + ", ".join(f"{k} {run[k]:.3g}" for k in KEYS))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
