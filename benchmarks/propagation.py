"""Benchmark of the propagation tables (issue 4): build time, peak memory and error of a
10 GHz, 0-100 km, 0-1000 m table at each fidelity against the finest, the table's
interpolation error, and the lookup time.

Run: ``.venv/bin/python benchmarks/propagation.py [H|V ...]``.  Prints one line per case,
measured in this process: wall clock and CPU time of this process (the CPU time is the
number to trust when other jobs share the machine), tracemalloc peak of Python and numpy
allocations.

Error metrics (all |20 log10(F / F_ref)| in dB, over points where both are defined):

* ``vs fine``: the PE of each fidelity against the fine one at exactly computed points (a
  common 500 m range grid, heights interpolated on each PE's own nodes).  Reported where the
  reference F >= -10 dB and where F >= -20 dB: median, p95, p99 and max.  Deeper points are
  excluded: a null moved by a few centimetres changes F there by tens of dB, and such a
  number says nothing about the table's use (F enters S/N as F^4; -20 dB is already 80 dB
  down).  ``max`` is still taken at the edge of a null and is reported for completeness.
* ``two-ray fallback vs PE``: the on-line fallback against the PE in a standard
  atmosphere, by region (rms and p95 where the PE's F > -60 dB).
* ``lookup mid-way``: the table looked up half-way between its range nodes, at heights on a
  0.3 m grid (arbitrary with respect to the table's nodes), against the PE run with half the
  range step.  Part of that difference is the PE's own range-step error (the PE with step dx
  against the PE with dx / 2 at the same points), reported beside it.
"""

from __future__ import annotations

import resource
import sys
import time
import tracemalloc

import numpy as np

from shipradar.sensors import parabolic_equation as pe
from shipradar.tables import propagation as tp

FREQ_HZ = 10e9
ANTENNA_M = 20.0
MAX_RANGE_M = 100e3
MAX_HEIGHT_M = 1000.0
PROFILE = {"kind": "evaporation", "duct_height_m": 10.0}
#: Error is counted only where the reference F is above these levels [dB].
ERROR_FLOORS_DB = (-10.0, -20.0)
LOOKUP_POINTS = 100_000


def build(fidelity: str, pol: str):
    """The production table, its build wall and CPU times [s] and peak memory [B]."""
    tracemalloc.start()
    t0, c0 = time.perf_counter(), time.process_time()
    table = tp.build_propagation_table(
        FREQ_HZ, ANTENNA_M, polarization=pol, elevation_pattern=None, profile=PROFILE,
        max_range_m=MAX_RANGE_M, max_height_m=MAX_HEIGHT_M, fidelity=fidelity, progress=False,
    )
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return table, seconds, cpu, peak


def solve(fidelity: str, pol: str, range_step_m: float, height_step_m: float | None = None):
    return pe.solve_pe(
        FREQ_HZ, ANTENNA_M, polarization=pol, elevation_pattern=None, profile=PROFILE,
        max_range_m=MAX_RANGE_M, max_height_m=MAX_HEIGHT_M, fidelity=fidelity,
        range_step_m=range_step_m, height_step_m=height_step_m, progress=False,
    )


def solve_on_common_grid(fidelity: str, pol: str):
    """The PE on a common 500 m range grid and 0.25 m heights (interpolated on its nodes)."""
    r, h, f = solve(fidelity, pol, 500.0)
    heights = np.arange(0.0, MAX_HEIGHT_M + 0.1, 0.25)
    return r, np.array([np.interp(heights, h, row) for row in f])


def errors_db(f, f_ref, floor_db):
    """|dF| [dB] where both are defined and the reference is above floor_db."""
    ok = np.isfinite(f) & np.isfinite(f_ref) & (f_ref >= 10 ** (floor_db / 20)) & (f > 0)
    return np.abs(20 * np.log10(f[ok] / f_ref[ok]))


def summary(err) -> str:
    return (f"median {np.median(err):.3f}  p95 {np.percentile(err, 95):.3f}  "
            f"p99 {np.percentile(err, 99):.3f}  max {err.max():.2f} dB")


def interpolation_errors(table, pol):
    """Table looked up mid-way between range nodes vs the PE at dx / 2, and the PE's own
    dx vs dx / 2 difference at the table's nodes, both at F_ref >= each floor."""
    step = table.axes[0][1] - table.axes[0][0]
    r2, h2, f2 = solve(table.inputs["fidelity"], pol, step / 2, height_step_m=0.3)
    r1, h1, f1 = solve(table.inputs["fidelity"], pol, step, height_step_m=0.3)
    mid, nodes = f2[0::2], f2[1::2]
    rr, hh = np.meshgrid(r2[0::2], h2, indexing="ij")
    looked_up = tp.propagation_factor(table, rr, hh)
    return {floor: (errors_db(looked_up, mid, floor), errors_db(f1, nodes, floor))
            for floor in ERROR_FLOORS_DB}


def lookup_time(table, n=LOOKUP_POINTS, repeats=50):
    """Wall and CPU time [s] of one lookup of n random points in the table's domain."""
    rng = np.random.default_rng(1)
    r = rng.uniform(0, MAX_RANGE_M, n)
    h = rng.uniform(0, MAX_HEIGHT_M, n)
    tp.propagation_factor(table, r, h)
    best_wall = best_cpu = np.inf
    for _ in range(3):
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(repeats):
            tp.propagation_factor(table, r, h)
        best_wall = min(best_wall, (time.perf_counter() - t0) / repeats)
        best_cpu = min(best_cpu, (time.process_time() - c0) / repeats)
    return best_wall, best_cpu


def fallback_errors(freq_hz: float, pol: str):
    """The two-ray fallback against the PE in a standard atmosphere (antenna 20 m,
    isotropic, 0-70 km, 0-200 m), by region, where the PE's F > -60 dB:
    ``{region: |dF| [dB]}`` for the interference region (grazing angle above 0.7 Fock
    angles), the intermediate region (interpolated in dB) and the diffraction region."""
    from shipradar.sensors import propagation as prop

    r, h, f = pe.solve_pe(freq_hz, ANTENNA_M, polarization=pol, elevation_pattern=None,
                          profile={"kind": "standard"}, max_range_m=70e3, max_height_m=200.0,
                          fidelity="standard", range_step_m=250.0, height_step_m=0.5,
                          progress=False)
    rr, hh = np.meshgrid(r, h, indexing="ij")
    f2 = prop.two_ray_factor(rr, ANTENNA_M, hh, freq_hz, pol)
    ok = np.isfinite(f) & (f > 10 ** (-60 / 20)) & (f2 > 0) & (hh > 0)
    d_lim = prop.interference_region_limit(ANTENNA_M, hh, freq_hz)
    d_h = prop.horizon_range(ANTENNA_M, hh)
    regions = {"interference": rr <= d_lim, "intermediate": (rr > d_lim) & (rr < d_h),
               "diffraction": rr >= d_h}
    return {name: np.abs(20 * np.log10(f2[ok & m] / f[ok & m])) for name, m in regions.items()}


def main(pols):
    for freq in (3e9, 10e9):
        for pol in pols:
            for name, err in fallback_errors(freq, pol).items():
                print(f"two-ray fallback vs PE, {freq / 1e9:g} GHz {pol}, {name:12s} "
                      f"({err.size} points): rms {np.sqrt(np.mean(err**2)):.2f}  "
                      f"p95 {np.percentile(err, 95):.2f} dB", flush=True)
    for pol in pols:
        reference = None
        for fid in ("fine", "standard", "coarse"):
            table, seconds, cpu, peak = build(fid, pol)
            shape = table.values.shape
            print(f"{pol} {fid:8s} build {seconds:6.2f} s wall {cpu:6.2f} s cpu  peak "
                  f"{peak / 2**20:7.1f} MiB  table {shape[0]}x{shape[1]} "
                  f"({table.values.nbytes / 2**20:.1f} MiB)", flush=True)
            _, f = solve_on_common_grid(fid, pol)
            if reference is None:
                reference = f
            else:
                for floor in ERROR_FLOORS_DB:
                    err = errors_db(f, reference, floor)
                    print(f"{pol} {fid:8s} vs fine where F_fine >= {floor:g} dB "
                          f"({err.size} points): {summary(err)}", flush=True)
            if fid == "standard":
                for floor, (lookup_err, pe_err) in interpolation_errors(table, pol).items():
                    print(f"{pol} standard lookup mid-way vs PE(dx/2), F >= {floor:g} dB: "
                          f"{summary(lookup_err)}", flush=True)
                    print(f"{pol} standard   (PE(dx) vs PE(dx/2) at nodes, same floor: "
                          f"{summary(pe_err)})", flush=True)
                wall, cpu = lookup_time(table)
                print(f"{pol} lookup of {LOOKUP_POINTS:.0e} points in the standard table: "
                      f"{wall * 1e3:.2f} ms wall, {cpu * 1e3:.2f} ms cpu", flush=True)
        del reference


if __name__ == "__main__":
    main(sys.argv[1:] or ["H", "V"])
    print(f"process peak RSS: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**10:.0f} MiB")
