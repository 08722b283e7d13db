"""Probability of detection: cost and accuracy of the seed method [78]-[83] against the exact one.

Measures, in this process:

* P_d evaluations per second of each method over ``--points`` random points (per-pulse S/I
  -10..30 dB, P_fa 1e-12..1e-4, 1..``--max-pulses`` pulses, per Swerling case), with a real
  number of pulses as N_e of [73]-[77] is, and for the exact method also with integer N;
* the seed method's error against the exact one over the grid P_d 0.1-0.9, P_fa 1e-12-1e-4,
  1-100 pulses (integer and non-integer), Swerling 0-4: the error of the required S/I [dB]
  and the absolute P_d error at the exact method's required S/I;

prints a table and writes the section "## Probability of detection" of docs/accuracy.md
(other sections of that file are kept).

    .venv/bin/python benchmarks/pd.py [--points 1000000] [--max-pulses 30] [--no-write]
"""

from __future__ import annotations

import argparse
import re
import time
from pathlib import Path

import numpy as np

from shipradar.sensors.detection import probability_of_detection, required_snr_db

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "accuracy.md"
TITLE = "# Speed versus accuracy"
SECTION = "## Probability of detection"

GRID_PD = np.linspace(0.1, 0.9, 9)
GRID_PFA = np.logspace(-12, -4, 9)
GRID_N = np.array([1, 1.5, 2, 3, 5, 7.5, 10, 20, 30, 50, 100])


def throughput(
    method: str, swerling: int, points: int, max_pulses: int, seed: int, integer_n: bool = False
) -> float:
    """P_d evaluations per second for one method and Swerling case."""
    rng = np.random.default_rng(seed)
    snr_db = rng.uniform(-10.0, 30.0, points)
    pfa = 10.0 ** rng.uniform(-12.0, -4.0, points)
    if integer_n:
        n = rng.integers(1, max_pulses + 1, points).astype(float)
    else:
        n = rng.uniform(1.0, max_pulses, points)
    t0 = time.perf_counter()
    p = probability_of_detection(snr_db, pfa, n, swerling, method)
    dt = time.perf_counter() - t0
    assert np.all(np.isfinite(p))
    return points / dt


def accuracy(swerling: int) -> dict[str, float]:
    """Seed-minus-exact errors over the validity grid for one Swerling case."""
    pd = GRID_PD[:, None, None]
    pfa = GRID_PFA[None, :, None]
    n = GRID_N[None, None, :]
    exact_db = required_snr_db(pd, pfa, n, swerling)
    seed_db = required_snr_db(pd, pfa, n, swerling, "seed")
    d_db = seed_db - exact_db
    pd_seed = probability_of_detection(exact_db, pfa, n, swerling, "seed")
    d_pd = pd_seed - np.broadcast_to(pd, pd_seed.shape)
    worst = np.unravel_index(np.argmax(np.abs(d_db)), d_db.shape)
    return {
        "max_db": float(np.max(np.abs(d_db))),
        "rms_db": float(np.sqrt(np.mean(d_db**2))),
        "bias_db": float(np.mean(d_db)),
        "max_pd": float(np.max(np.abs(d_pd))),
        "worst": (GRID_PD[worst[0]], GRID_PFA[worst[1]], GRID_N[worst[2]]),
    }


def markdown(rows: list[dict], points: int, max_pulses: int) -> str:
    lines = [
        SECTION,
        "",
        "Measured by `benchmarks/pd.py` on this machine (2 cores, shared with other jobs at",
        f"the time, so rates may be low by up to ~2x), in-process. Speed: {points:,} random points",
        f"per case (per-pulse S/I -10..30 dB, P_fa 1e-12..1e-4, N uniform in 1..{max_pulses},",
        "real as N_e is; the exact method also with integer N). Accuracy: the seed method",
        "[78]-[83] (uniform integrator, square-law detector, constant pulse train) against the",
        "exact Swerling P_d over the grid P_d 0.1-0.9 (9), P_fa 1e-12-1e-4 (9),",
        f"N = {', '.join(f'{v:g}' for v in GRID_N)}: the error of the required per-pulse",
        "S/I, and the absolute P_d error at the exact required S/I.",
        "",
        "| Swerling | exact [eval/s] | exact, integer N [eval/s] | seed [eval/s] | "
        "seed/exact speed | max abs ΔS/I [dB] | rms ΔS/I [dB] | mean ΔS/I [dB] | "
        "max abs ΔP_d | worst (P_d, P_fa, N) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        w = r["worst"]
        lines.append(
            f"| {r['swerling']} | {r['exact_rate']:.3g} | {r['exact_int_rate']:.3g} | "
            f"{r['seed_rate']:.3g} | "
            f"{r['seed_rate'] / r['exact_rate']:.2f} | {r['max_db']:.2f} | {r['rms_db']:.2f} | "
            f"{r['bias_db']:+.2f} | {r['max_pd']:.3f} | ({w[0]:.1f}, {w[1]:.0e}, {w[2]:g}) |"
        )
    lines += [
        "",
        "Reading: the seed method keeps within its stated 0.7 dB of the exact one inside its",
        "validity range, at integer and non-integer N; a fraction of a dB of S/I moves P_d by",
        "up to the ΔP_d column on the steep part of the curve. The seed method is not the",
        "fast form: its forward P_d is the seed's iteration and costs about as much as the",
        "exact closed forms for Swerling 0-3 (its inverse, the required S/I, is a closed",
        "form); it is much faster only for Swerling 4 at non-integer N. The exact method is",
        "the default (`fidelity.pd_method`); the seed method is the seed's model, for",
        'comparison with the report. Table I\'s "Gaussian" column (beam-shaped pulse train)',
        "is not included here: it adds up to ~3 dB by design.",
        "The exact method's cost is flat in N except for Swerling 4: at integer N its",
        "binomial sum has min(N + 1, ~24 sqrt(N) + 81) terms, at non-integer N (the usual",
        "case in a run) it is a 48-node quadrature of the non-central chi-square tail, the",
        "slowest entry here. The seed method costs 12 evaluations of [78]-[83] (its",
        "fixed-midpoint bisection, 10 steps, then an interpolation), whatever the case.",
        "",
        "",
    ]
    return "\n".join(lines)


def write_section(text: str) -> None:
    """Replace (or add) this section of docs/accuracy.md, keeping every other section."""
    DOC.parent.mkdir(parents=True, exist_ok=True)
    old = DOC.read_text() if DOC.exists() else f"{TITLE}\n\n"
    if not old.startswith(TITLE):
        old = f"{TITLE}\n\n" + old
    pattern = re.compile(rf"^{re.escape(SECTION)}\n.*?(?=^## |\Z)", re.S | re.M)
    if pattern.search(old):
        new = pattern.sub(lambda _: text, old, count=1)
    else:
        head, sep, rest = old.partition("\n## ")
        new = head.rstrip("\n") + "\n\n" + text + ("\n## " + rest if sep else "")
    DOC.write_text(new)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--max-pulses", type=int, default=30)
    ap.add_argument("--no-write", action="store_true", help="do not update docs/accuracy.md")
    args = ap.parse_args()

    rows = []
    print(
        f"{'Sw':>2} {'exact/s':>10} {'int N/s':>10} {'seed/s':>10} {'ratio':>6} {'maxdB':>6} "
        f"{'rmsdB':>6} "
        f"{'biasdB':>7} {'maxdPd':>7}"
    )
    for sw in range(5):
        row = {"swerling": sw}
        row["exact_rate"] = throughput("exact", sw, args.points, args.max_pulses, seed=sw)
        row["exact_int_rate"] = throughput(
            "exact", sw, args.points, args.max_pulses, seed=sw, integer_n=True
        )
        row["seed_rate"] = throughput("seed", sw, args.points, args.max_pulses, seed=sw)
        row.update(accuracy(sw))
        rows.append(row)
        print(
            f"{sw:>2} {row['exact_rate']:>10.3g} {row['exact_int_rate']:>10.3g} "
            f"{row['seed_rate']:>10.3g} "
            f"{row['seed_rate'] / row['exact_rate']:>6.2f} {row['max_db']:>6.2f} "
            f"{row['rms_db']:>6.2f} {row['bias_db']:>+7.2f} {row['max_pd']:>7.3f}",
            flush=True,
        )
    if not args.no_write:
        write_section(markdown(rows, args.points, args.max_pulses))
        print(f"wrote {DOC.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
