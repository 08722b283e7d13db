"""I_F tables against their function off the grid (issue 36), for docs/accuracy.md.

For every processor of ``tests/test_table_offgrid_improvement.py`` (constant PRF, staggers of
short and of long Doppler period): build the table (standard, and with ``--coarse`` the coarse
grid too), read it through the dwell's reader at 4000 points of the test's sampler (axis edges,
both Doppler signs, past one period, within f_r/64 of blind speeds, beyond the spread axis),
and print per table the build time [s], its Doppler nodes, and for the I_F and the coherent
gain the fraction of points more than 1 dB off the direct function [%], the 95th percentile
and the largest error [dB].  Run ``python benchmarks/improvement_offgrid.py`` from the
repository root.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from shipradar.tables import improvement as imp  # noqa: E402
from tests.test_table_offgrid_improvement import CASES, table_errors_db  # noqa: E402

N_POINTS = 4000


def _stats(err: np.ndarray) -> str:
    return (f"{100 * np.mean(err > 1.0):6.2f} % {np.percentile(err, 95):7.3f} "
            f"{err.max():7.2f}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--coarse", action="store_true", help="the coarse grid too")
    args = p.parse_args()
    print(f"{'processor':28s} {'grid':8s} {'build s':>8s} {'nodes':>7s}   "
          f"{'I_F: >1dB   p95    max':>24s}   {'gain: >1dB   p95    max':>24s}")
    for res in ("standard", "coarse") if args.coarse else ("standard",):
        for name, kw in CASES.items():
            t0 = time.perf_counter()
            table = imp.build_improvement_table(**kw, resolution=res)
            build = time.perf_counter() - t0
            err_if, err_gain = table_errors_db(table, N_POINTS, seed=2026)
            print(f"{name:28s} {res:8s} {build:8.2f} {table.axes[1].size:7d}   "
                  f"{_stats(err_if):>24s}   {_stats(err_gain):>24s}", flush=True)


if __name__ == "__main__":
    main()
