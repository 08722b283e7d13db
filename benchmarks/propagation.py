"""Benchmark of the propagation tables (issue 4): build time, peak memory and error of a
10 GHz, 0-100 km, 0-1000 m table at each fidelity against the finest, and lookup time.

Run: ``.venv/bin/python benchmarks/propagation.py [H|V ...]``.  Prints one line per case,
measured in this process (wall clock; tracemalloc peak of Python and numpy allocations).
"""

from __future__ import annotations

import sys
import time
import tracemalloc

import numpy as np

from tables import propagation as tp

FREQ_HZ = 10e9
ANTENNA_M = 20.0
MAX_RANGE_M = 100e3
MAX_HEIGHT_M = 1000.0
PROFILE = {"kind": "evaporation", "duct_height_m": 10.0}
#: Only where the reference F is above this is the error counted [dB].
ERROR_FLOOR_DB = -30.0


def build(fidelity: str, pol: str):
    """The production table (default output grid), its build time [s] and peak memory [B]."""
    tracemalloc.start()
    t0 = time.perf_counter()
    table = tp.build_propagation_table(
        FREQ_HZ, ANTENNA_M, polarization=pol, elevation_pattern=None, profile=PROFILE,
        max_range_m=MAX_RANGE_M, max_height_m=MAX_HEIGHT_M, fidelity=fidelity, progress=False,
    )
    seconds = time.perf_counter() - t0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return table, seconds, peak


def solve_on_common_grid(fidelity: str, pol: str):
    """The same PE with its output on a common 500 m range grid, so that fidelities are
    compared at exactly computed ranges (no interpolation across range lobes)."""
    r, h, f = tp.solve_pe(
        FREQ_HZ, ANTENNA_M, polarization=pol, elevation_pattern=None, profile=PROFILE,
        max_range_m=MAX_RANGE_M, max_height_m=MAX_HEIGHT_M, fidelity=fidelity,
        range_step_m=500.0, progress=False,
    )
    heights = np.arange(0.0, MAX_HEIGHT_M + 0.1, 0.25)
    return r, np.array([np.interp(heights, h, row) for row in f])


def error_db(f, f_ref):
    """|dF| [dB] where both are defined and the reference is above ERROR_FLOOR_DB."""
    ok = np.isfinite(f) & np.isfinite(f_ref) & (f_ref > 10 ** (ERROR_FLOOR_DB / 20)) & (f > 0)
    return np.abs(20 * np.log10(f[ok] / f_ref[ok])), ok.mean()


def interpolation_error_db(table, pol):
    """Error of looking the table up half-way between its range nodes against the PE there."""
    r_axis = table.axes[0]
    mid = 0.5 * (r_axis[:-1] + r_axis[1:])
    step = r_axis[1] - r_axis[0]
    r, h, f = tp.solve_pe(
        FREQ_HZ, ANTENNA_M, polarization=pol, elevation_pattern=None, profile=PROFILE,
        max_range_m=MAX_RANGE_M, max_height_m=MAX_HEIGHT_M, fidelity=table.inputs["fidelity"],
        range_step_m=step / 2, progress=False,
    )
    keep = np.isin(np.round(r / step * 2).astype(int), np.round(mid / step * 2).astype(int))
    rr, hh = np.meshgrid(r[keep], h, indexing="ij")
    return error_db(tp.propagation_factor(table, rr, hh), f[keep])


def lookup_time(table, n=100_000, repeats=20):
    rng = np.random.default_rng(1)
    r = rng.uniform(0, MAX_RANGE_M, n)
    h = rng.uniform(0, MAX_HEIGHT_M, n)
    tp.propagation_factor(table, r, h)
    t0 = time.perf_counter()
    for _ in range(repeats):
        tp.propagation_factor(table, r, h)
    return (time.perf_counter() - t0) / repeats


def main(pols):
    for pol in pols:
        reference = None
        for fid in ("fine", "standard", "coarse"):
            table, seconds, peak = build(fid, pol)
            shape = table.values.shape
            line = (f"{pol} {fid:8s} build {seconds:6.2f} s  peak {peak / 2**20:7.1f} MiB  "
                    f"table {shape[0]}x{shape[1]} ({table.values.nbytes / 2**20:.0f} MiB)")
            r, f = solve_on_common_grid(fid, pol)
            if reference is None:
                reference = f
                line += "  (reference)"
            else:
                err, covered = error_db(f, reference)
                line += (f"  vs fine: rms {np.sqrt(np.mean(err**2)):.3f} dB  p95 "
                         f"{np.percentile(err, 95):.3f} dB  max {err.max():.2f} dB "
                         f"({covered:.0%} of grid)")
            print(line, flush=True)
            if fid == "standard":
                err, _ = interpolation_error_db(table, pol)
                print(f"{pol} standard table, lookup mid-way between range nodes vs PE: rms "
                      f"{np.sqrt(np.mean(err**2)):.2f} dB  p95 {np.percentile(err, 95):.2f} dB",
                      flush=True)
                ms = lookup_time(table) * 1e3
                print(f"{pol} lookup of 1e5 points in the standard table: {ms:.2f} ms",
                      flush=True)
        del reference


if __name__ == "__main__":
    main(sys.argv[1:] or ["H", "V"])
