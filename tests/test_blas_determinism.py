"""The same scenario and seed give the same bytes whatever the BLAS thread count (issue 27).

The ``meta`` message's clutter false-alarm density was a matrix product; OpenBLAS splits such
a sum differently with one thread than with two, so the raid's recording differed between
this 2-core machine and a 1-core one, or a Dask worker (which runs with one thread). The
density is now summed in a fixed order without BLAS
(``sim.dwell.false_alarm_model.sum_over_sectors``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from shipradar.sim.dwell.false_alarm_model import sum_over_sectors

ROOT = Path(__file__).resolve().parents[1]
RAID = str(ROOT / "scenarios" / "raid.yaml")
BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _env(cache: Path, threads: int | None) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in BLAS_THREADS}
    env["SHIPRADAR_TABLES"] = str(cache)
    if threads is not None:
        env.update(dict.fromkeys(BLAS_THREADS, str(threads)))
    return env


@pytest.fixture(scope="module")
def raid_cache(tmp_path_factory):
    cache = tmp_path_factory.mktemp("tables")
    subprocess.run([sys.executable, "-m", "shipradar.sim.cli", "tables", "build", RAID],
                   env=_env(cache, None), check=True, capture_output=True, timeout=600,
                   cwd=cache)
    return cache


def test_the_raid_records_the_same_bytes_with_one_and_several_blas_threads(raid_cache,
                                                                          tmp_path):
    recordings = []
    for threads in (1, 2, None):
        out = tmp_path / f"raid-{threads}.rec"
        proc = subprocess.run([sys.executable, "-m", "shipradar.sim.cli", "run", RAID,
                               "--duration", "3", "--seed", "7", "--record", str(out),
                               "--quiet"], env=_env(raid_cache, threads),
                              capture_output=True, text=True, timeout=600, cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr[-2000:]
        recordings.append(out.read_bytes())
    assert recordings[0] == recordings[1] == recordings[2]


_THREADS_SEEN = """
import json, os, sys
from shipradar.sim import cli
sys.argv = ["shipradar", "run", sys.argv[1], "--duration", "1", "--quiet"]
try:
    cli.main()
finally:
    print(json.dumps({v: os.environ.get(v) for v in cli.BLAS_THREAD_VARIABLES}))
"""


@pytest.mark.parametrize(("threads", "expected"), [(None, "1"), (2, "2")])
def test_a_command_line_run_asks_for_one_blas_thread_unless_told(raid_cache, threads,
                                                                 expected):
    proc = subprocess.run([sys.executable, "-c", _THREADS_SEEN, RAID], capture_output=True,
                          text=True, timeout=600, env=_env(raid_cache, threads),
                          cwd=raid_cache)
    assert proc.returncode == 0, proc.stderr[-2000:]
    seen = json.loads(proc.stdout.strip().splitlines()[-1])
    assert seen == dict.fromkeys(BLAS_THREADS, expected)


def test_the_sum_over_sectors_is_the_product():
    """Against the matrix product it replaces (to rounding), with sectors in one or two cells,
    cells holding no sector, and the total kept."""
    rng = np.random.default_rng(3)
    n_rings, n_cells, n_sectors = 40, 36, 5000
    by_ring = rng.random((n_rings, n_sectors)) * (rng.random((n_rings, n_sectors)) < 0.1)
    by_azimuth = np.zeros((n_cells, n_sectors))
    cell = rng.integers(0, n_cells - 3, n_sectors)  # the last three cells hold nothing
    split = rng.random(n_sectors)
    by_azimuth[cell, np.arange(n_sectors)] = split
    by_azimuth[cell + 1, np.arange(n_sectors)] += 1.0 - split
    got = sum_over_sectors(by_ring, by_azimuth)
    np.testing.assert_allclose(got, by_ring @ by_azimuth.T, rtol=1e-13, atol=1e-300)
    assert np.all(got[:, -2:] == 0.0)
    np.testing.assert_allclose(got.sum(), by_ring.sum(), rtol=1e-12)
    # no sector at all: zeros of the right shape
    assert sum_over_sectors(by_ring, np.zeros((n_cells, n_sectors))).shape == (n_rings, n_cells)
