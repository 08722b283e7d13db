"""Benchmark of the improvement-factor tables (seed [49]-[62]): build time, accuracy, lookup.

For a few processors (including the raid scenario's two): the build time of the I_F table at
each grid resolution, the error of the coarse and standard tables against the fine one and of
every table against the exact physics, at the same random points (both tables read through the
on-line lookup; dB), and the on-line lookup cost per 1e5 points (the fast uniform-grid lookup
and the generic ``Table.lookup``).  Docs: docs/doppler.md and docs/accuracy.md.  Everything
is measured in-process with ``time.perf_counter``; run ``python benchmarks/improvement.py``.
"""

from __future__ import annotations

import time

import numpy as np

from shipradar.sensors import doppler_filters as df
from shipradar.tables import improvement as imp

PROCESSORS = {
    "mti 3-pulse": dict(processor="mti", mti_pulses=3),
    "dft 16": dict(processor="dft_bank", n_pulses=16),
    "fir 5x32 hann (Fig. 7)": dict(processor="fir_bank", n_pulses=32, n_filters=5, window="hann"),
    "mti2 + 64 cheb-60": dict(
        processor="mti_bank", n_pulses=65, mti_pulses=2, window="chebyshev", window_sidelobe_db=60
    ),
    "mti3 stagger 900/1100": dict(
        processor="mti", mti_pulses=3, prf_hz=1000.0, stagger_prf_hz=[900.0, 1100.0]
    ),
    # the raid scenario's two processors (scenarios/raid.yaml)
    "raid sps49 mti3 950/1050": dict(
        processor="mti", mti_pulses=3, prf_hz=1000.0, stagger_prf_hz=[950.0, 1050.0]
    ),
    "raid giraffe mti2+7 cheb50": dict(
        processor="mti_bank", n_pulses=8, mti_pulses=2, window="chebyshev", window_sidelobe_db=50
    ),
}
N_LOOKUP = 100_000
N_EXACT = 20_000


def best_time(fn, repeat=3):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def exact_db(table, spread, dop):
    inputs = table.inputs
    w = imp.processor_weights(inputs)
    if "stagger_prf_hz" in inputs:
        i_f = df.staggered_improvement_factor(
            w, spread, dop, prf_hz=inputs["prf_hz"], stagger_prf_hz=inputs["stagger_prf_hz"]
        )
    else:
        i_f = df.bank_improvement_factor(w, spread, dop)
    return 10 * np.log10(i_f)


def main() -> None:
    rng = np.random.default_rng(0)
    print("build time [ms], grid (spread x Doppler)")
    print(f"{'processor':24s} {'coarse':>18s} {'standard':>18s} {'fine':>18s}")
    built = {}
    for name, kw in PROCESSORS.items():
        row = []
        for res in ("coarse", "standard", "fine"):
            t, table = best_time(
                lambda kw=kw, res=res: imp.build_improvement_table(**kw, resolution=res)
            )
            built[name, res] = table
            row.append(f"{1e3 * t:7.1f} ({table.values.shape[0]}x{table.values.shape[1]})")
        print(f"{name:24s} " + " ".join(f"{r:>18s}" for r in row))

    # random points, not the fine grid's nodes: the nodes include the exact crossovers
    # between filters, where the pick rule's tie-break and the lookup's side of the jump
    # legitimately differ by the full jump (tens of dB) on a set of measure zero
    print(f"\nerror at {N_EXACT} random points (log-uniform spread over the axis, uniform Doppler)"
          " [dB]: median / RMS / 99th percentile / max")
    print(f"{'':24s} {'':9s} {'coarse/standard vs fine table':>43s}   {'vs exact physics':>35s}")
    for name in PROCESSORS:
        fine = built[name, "fine"]
        log_s = rng.uniform(imp.LOG10_SPREAD_MIN, imp.LOG10_SPREAD_MAX, N_EXACT)
        dop = rng.uniform(0.0, fine.axes[1][-1], N_EXACT)
        exact = exact_db(fine, 10.0**log_s, dop)
        fine_read = imp.improvement_factor_db(fine, 10.0**log_s, dop)
        for res in ("coarse", "standard", "fine"):
            table = built[name, res]
            read = imp.improvement_factor_db(table, 10.0**log_s, dop)
            vs_fine = _stats(read - fine_read) if res != "fine" else " " * 35
            print(f"{name:26s} {res:9s} {vs_fine:>43s}   {_stats(read - exact):>35s}")

    print(
        f"\nlookup cost per {N_LOOKUP:.0e} points [ms] (fast uniform grid / generic Table.lookup)"
    )
    for name in PROCESSORS:
        table = built[name, "standard"]
        spread = 10.0 ** rng.uniform(-6, 0, N_LOOKUP)
        dop = rng.uniform(-20, 20, N_LOOKUP)
        t_fast, _ = best_time(
            lambda t=table, s=spread, d=dop: imp.improvement_factor_db(t, s, d), 5
        )
        log_s = np.log10(spread)
        d_fold = np.mod(dop, table.axes[1][-1])
        t_gen, _ = best_time(lambda t=table, s=log_s, d=d_fold: t.lookup(s, d), 5)
        print(f"{name:24s} {1e3 * t_fast:7.2f} / {1e3 * t_gen:7.2f}")

    print("\ndirect physics (no table) per 1e5 points [ms] (timed on 1e4 points, x10)")
    for name in ("mti 3-pulse", "fir 5x32 hann (Fig. 7)", "mti2 + 64 cheb-60"):
        table = built[name, "standard"]
        spread = 10.0 ** rng.uniform(-6, 0, N_LOOKUP // 10)
        dop = rng.uniform(0, 1, N_LOOKUP // 10)
        t, _ = best_time(lambda t=table, s=spread, d=dop: exact_db(t, s, d), 1)
        print(f"{name:24s} {1e4 * t:9.1f}")


def _stats(err: np.ndarray) -> str:
    err = np.abs(err[np.isfinite(err)])
    rms = np.sqrt(np.mean(err**2))
    return (f"{np.median(err):6.3f} / {rms:7.3f} / {np.percentile(err, 99):7.3f} / "
            f"{err.max():7.2f}")


if __name__ == "__main__":
    main()
