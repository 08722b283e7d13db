"""Small matrix products on one BLAS thread.

numpy's bundled OpenBLAS splits a product of a few thousand rows (the dwell model's
``(points, pulses) @ (pulses, filters)`` responses, one revolution's looks at a time) over
its threads.  On a loaded machine the calling thread then spins waiting for workers that
are not scheduled: a 2,000 x 8 x 7 complex product took 2 µs of the caller's CPU per row
instead of 0.02 (``docs/performance.md`` 13.1), a fixed cost per call that made one
revolution per block (a live source) ~1.4x the cost of blocks of revolutions.

:func:`matmul_one_thread` runs the product with the BLAS libraries set to one thread and
restores their counts, through ``threadpoolctl`` (which finds the loaded BLAS libraries,
numpy's OpenBLAS among them, whatever their file and symbol names, and uses the OpenMP
thread control where OpenBLAS is built on OpenMP).  For the dwell model's shapes (a few to
tens of thousands of rows, 8 pulses, 7 filters, complex) the result is bit for bit the
threaded one (``tests/test_blas.py``; the shipped scenes' recordings are unchanged); in
general a BLAS product's bits may depend on its thread count
(``shipradar.sim.dwell.false_alarm_model.sum_over_sectors``), and one thread makes them the
same on every machine.  Where no BLAS library is found the product is numpy's ``@`` as it is.

Cost (``benchmarks/blas_limits.py``, load ~10): ``threadpoolctl.threadpool_limits`` made
at each call finds the loaded libraries anew, 0.5-0.7 ms per call, so one
``ThreadpoolController`` is kept (made at the first product, when the run's libraries are
loaded) and its ``limit`` entered per call: ~20 µs per call (19-22) where the ctypes calls it
replaces (numpy's ``openblas_get/set_num_threads``, found by file and symbol name) took 1-4
µs; a 2,000-row product on one thread 73 µs instead of 63.  The product runs once per block
and radar (the steep cells of the improvement table), a block costing tens of ms: ~0.05 %
of it, for a thread control that does not depend on numpy's packaging.
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
from numpy.typing import NDArray

_LOCK = threading.Lock()
#: The BLAS libraries' thread controller, made at the first product (None: none loaded).
_CONTROLLER: Any = None
_MADE = False


def blas_controller() -> Any:
    """The kept ``threadpoolctl.ThreadpoolController`` of the loaded BLAS libraries (made at
    the first call), or None when numpy's product uses no BLAS library it knows."""
    global _CONTROLLER, _MADE
    if not _MADE:
        from threadpoolctl import ThreadpoolController

        blas = ThreadpoolController().select(user_api="blas")
        _CONTROLLER = blas if blas.lib_controllers else None
        _MADE = True
    return _CONTROLLER


def matmul_one_thread(a: NDArray, b: NDArray) -> NDArray:
    """``a @ b`` computed on one BLAS thread (module docstring); the same bits."""
    with _LOCK:
        controller = blas_controller()
        if controller is None:
            return np.asarray(a @ b)
        with controller.limit(limits=1, user_api="blas"):
            return np.asarray(a @ b)
