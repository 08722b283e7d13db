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
from shipradar.tables.pd import PdTable, build_pd_table

#: P_fa of the table measurements (the example radars' Giraffe, [68]-[72]).
TABLE_PFA = 3.6e-8
#: Points of the table-against-exact error measurement per case.
TABLE_ERROR_POINTS = 20_000

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


def table_case(swerling: int, points: int, max_pulses: int, seed: int) -> dict[str, float]:
    """Build time, evaluations per second and error against the exact method of the P_d
    table (tables/pd.py) for one Swerling case at P_fa = TABLE_PFA, N_e in 1..max_pulses."""
    c0 = time.process_time()
    reader = PdTable(build_pd_table(TABLE_PFA, swerling, float(max_pulses)))
    build = time.process_time() - c0
    rng = np.random.default_rng(seed)
    snr_db = rng.uniform(-10.0, 30.0, points)
    n = rng.uniform(1.0, max_pulses, points)
    t0 = time.perf_counter()
    p = reader(snr_db, n)
    rate = points / (time.perf_counter() - t0)
    assert np.all(np.isfinite(p))
    m = TABLE_ERROR_POINTS
    err = np.abs(p[:m] - probability_of_detection(snr_db[:m], TABLE_PFA, n[:m], swerling))
    return {"table_rate": rate, "table_build_s": build, "table_max_dpd": float(err.max()),
            "table_rms_dpd": float(np.sqrt(np.mean(err**2)))}


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
        "P_d table (`fidelity.pd_method: table`, tables/pd.py): the exact method tabulated per",
        f"radar P_fa and Swerling case against (ln N_e, S/I dB), here at P_fa = {TABLE_PFA:g}",
        f"and N_e in 1..{max_pulses} (default grid: S/I -40..100 dB by 0.1 dB, 12 points per",
        "e-fold of N_e, bilinear in z = Φ⁻¹(P_d)). Speed over the same random points (P_fa",
        "fixed, as in a run); error against the exact method at "
        f"{TABLE_ERROR_POINTS:,} of them.",
        "",
        "| Swerling | table [eval/s] | table/exact speed | build [s CPU] | max abs ΔP_d | "
        "rms ΔP_d |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['swerling']} | {r['table_rate']:.3g} | "
            f"{r['table_rate'] / r['exact_rate']:.0f} | {r['table_build_s']:.1f} | "
            f"{r['table_max_dpd']:.1e} | {r['table_rms_dpd']:.1e} |")
    lines += [
        "",
        "The table is monotone in S/I by construction and within 1e-3 of the exact P_d",
        "(`tests/test_pd_table.py` checks both, with the exact method as the oracle); the",
        "raid's detections over 5 seeds × 600 s were identical with either method. Its",
        "rows are built once per radar and case and cached in the table store (Swerling 4",
        "at real N dominates the build: the exact method's slowest case, once per grid point).",
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
        row.update(table_case(sw, args.points, args.max_pulses, seed=sw))
        rows.append(row)
        print(
            f"{sw:>2} {row['exact_rate']:>10.3g} {row['exact_int_rate']:>10.3g} "
            f"{row['seed_rate']:>10.3g} "
            f"{row['seed_rate'] / row['exact_rate']:>6.2f} {row['max_db']:>6.2f} "
            f"{row['rms_db']:>6.2f} {row['bias_db']:>+7.2f} {row['max_pd']:>7.3f} "
            f"table {row['table_rate']:.3g}/s max dPd {row['table_max_dpd']:.1e}",
            flush=True,
        )
    if not args.no_write:
        write_section(markdown(rows, args.points, args.max_pulses))
        print(f"wrote {DOC.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
