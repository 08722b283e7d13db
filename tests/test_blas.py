"""shipradar.tables.blas: a product on one BLAS thread is numpy's product, and it restores the
thread count."""

from __future__ import annotations

import numpy as np
import pytest

from shipradar.tables import blas


@pytest.mark.parametrize("rows", [1, 700, 2001, 40001])
def test_one_thread_product_is_the_threaded_product(rows: int) -> None:
    """The dwell model's response product (points x pulses) @ (pulses x filters), complex:
    the same bits as numpy's (threaded) ``@`` and, independently, an explicit sum over the
    pulses to rounding."""
    rng = np.random.default_rng(rows)
    w = rng.normal(size=(7, 8)) + 1j * rng.normal(size=(7, 8))
    d = rng.uniform(-0.5, 0.5, rows)
    steer = np.exp(-2j * np.pi * np.mod(d[:, None] * np.arange(8), 1.0))
    got = blas.matmul_one_thread(steer, np.conj(w).T)
    assert np.array_equal(got.view(float), (steer @ np.conj(w).T).view(float))
    ref = sum(steer[:, [n]] * np.conj(w[:, n])[None, :] for n in range(8))
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)


def test_thread_count_restored() -> None:
    """Every BLAS library's thread count is what it was after the product, also after a
    product in another thread (OpenBLAS's count is process-wide)."""
    import threading

    from threadpoolctl import threadpool_info

    if blas.blas_controller() is None:
        pytest.skip("numpy is not linked to a BLAS library threadpoolctl knows")

    def counts() -> list[tuple[str, int]]:
        return [(i["filepath"], i["num_threads"]) for i in threadpool_info()
                if i["user_api"] == "blas"]

    before = counts()
    blas.matmul_one_thread(np.ones((3000, 8)), np.ones((8, 7)))
    assert counts() == before
    seen = []
    th = threading.Thread(target=lambda: seen.append(
        blas.matmul_one_thread(np.ones((3000, 8)), np.ones((8, 7)))))
    th.start()
    th.join()
    assert counts() == before and seen[0].shape == (3000, 7)
