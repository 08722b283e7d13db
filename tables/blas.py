"""Small matrix products on one BLAS thread.

numpy's bundled OpenBLAS splits a product of a few thousand rows (the dwell model's
``(points, pulses) @ (pulses, filters)`` responses, one revolution's looks at a time) over
its threads.  On a loaded machine the calling thread then spins waiting for workers that
are not scheduled: a 2,000 x 8 x 7 complex product took 2 µs of the caller's CPU per row
instead of 0.02 (``docs/performance.md`` 13.1), a fixed cost per call that made one
revolution per block (a live source) ~1.4x the cost of blocks of revolutions.

:func:`matmul_one_thread` runs the product with OpenBLAS set to one thread and restores the
previous count.  For the dwell model's shapes (a few to tens of thousands of rows, 8 pulses,
7 filters, complex) the result is bit for bit the threaded one (``tests/test_blas.py``; the
shipped scenes' recordings are unchanged); in general a BLAS product's bits may depend on
its thread count (``shipradar.sim.dwell.model._sum_over_sectors``), and one thread makes
them the same on every machine.  Where numpy is not linked to OpenBLAS (or its thread
control is not found) the product is numpy's ``@`` as it is.
"""

from __future__ import annotations

import ctypes
import glob
import os
import threading
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

_LOCK = threading.Lock()


def _openblas_threads() -> tuple[Callable[[], int], Callable[[int], None]] | None:
    """numpy's OpenBLAS thread count getter and setter, or None if not found."""
    libs = os.path.join(os.path.dirname(np.__file__), os.pardir, "numpy.libs")
    for path in sorted(glob.glob(os.path.join(libs, "*openblas*.so*"))):
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for get_name, set_name in (
                ("scipy_openblas_get_num_threads64_", "scipy_openblas_set_num_threads64_"),
                ("scipy_openblas_get_num_threads", "scipy_openblas_set_num_threads"),
                ("openblas_get_num_threads64_", "openblas_set_num_threads64_"),
                ("openblas_get_num_threads", "openblas_set_num_threads")):
            get = getattr(lib, get_name, None)
            put = getattr(lib, set_name, None)
            if get is not None and put is not None:
                get.restype, get.argtypes = ctypes.c_int, []
                put.restype, put.argtypes = None, [ctypes.c_int]
                return get, put
    return None


_THREADS = _openblas_threads()


def matmul_one_thread(a: NDArray, b: NDArray) -> NDArray:
    """``a @ b`` computed on one OpenBLAS thread (module docstring); the same bits."""
    if _THREADS is None:
        return np.asarray(a @ b)
    get, put = _THREADS
    with _LOCK:
        before = get()
        if before == 1:
            return np.asarray(a @ b)
        put(1)
        try:
            return np.asarray(a @ b)
        finally:
            put(before)
