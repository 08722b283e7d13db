"""Cost per call of running a product on one OpenBLAS thread (issue 31, tables/blas.py).

The dwell model's response product ``(points, 8) @ (8, 7)``, complex, is computed on one
OpenBLAS thread once per block (``shipradar.tables.blas.matmul_one_thread``): this times, per
call, what each way of setting the thread count and restoring it adds to the bare product:

* ``ctypes``: numpy's OpenBLAS ``get/set_num_threads`` called directly (the get, and a set
  to 1 and back when the count is not already 1);
* ``threadpool_limits``: ``threadpoolctl.threadpool_limits(limits=1, user_api="blas")`` as a
  context manager, made at each call (it finds the loaded libraries each time);
* ``controller.limit``: one ``threadpoolctl.ThreadpoolController`` kept, its
  ``limit(limits=1, user_api="blas")`` per call (every BLAS library loaded when it was made:
  numpy's and scipy's OpenBLAS here);
* ``numpy's lib``: that controller narrowed to numpy's OpenBLAS, ``limit(limits=1)``;
* ``matmul_one_thread``: what the dwell model calls (a kept controller of the BLAS
  libraries, under a lock).

Each is checked bit-identical to the bare product.  Times are process CPU per call [µs], the
best of ``--repeat`` rounds of ``--calls`` calls (other processes only slow a round).

Usage: python benchmarks/blas_limits.py [--rows 2000] [--calls 2000] [--repeat 5]
"""

from __future__ import annotations

import argparse
import ctypes
import glob
import os
import time
from collections.abc import Callable

import numpy as np
import scipy.linalg  # noqa: F401 - a run has scipy's OpenBLAS loaded beside numpy's
import threadpoolctl

from shipradar.tables import blas


def _numpy_openblas_threads() -> tuple[Callable[[], int], Callable[[int], None]]:
    """numpy's OpenBLAS thread count getter and setter by file and symbol name (what
    tables/blas.py did with ctypes before threadpoolctl)."""
    libs = os.path.join(os.path.dirname(np.__file__), os.pardir, "numpy.libs")
    for path in sorted(glob.glob(os.path.join(libs, "*openblas*.so*"))):
        lib = ctypes.CDLL(path)
        for stem in ("scipy_openblas", "openblas"):
            for suffix in ("64_", ""):
                get = getattr(lib, f"{stem}_get_num_threads{suffix}", None)
                put = getattr(lib, f"{stem}_set_num_threads{suffix}", None)
                if get is not None and put is not None:
                    get.restype, get.argtypes = ctypes.c_int, []
                    put.restype, put.argtypes = None, [ctypes.c_int]
                    return get, put
    raise SystemExit("numpy's OpenBLAS thread control not found (numpy.libs)")


def _per_call_us(fn: Callable[[], object], calls: int, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.process_time()
        for _ in range(calls):
            fn()
        best = min(best, time.process_time() - t0)
    return best / calls * 1e6


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=2000, help="points of the product")
    ap.add_argument("--calls", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(1)
    w = rng.normal(size=(7, 8)) + 1j * rng.normal(size=(7, 8))
    d = rng.uniform(-0.5, 0.5, args.rows)
    a = np.exp(-2j * np.pi * np.mod(d[:, None] * np.arange(8), 1.0))
    b = np.conj(w).T
    want = (a @ b).view(float)

    controller = threadpoolctl.ThreadpoolController()
    blas_libs = controller.select(user_api="blas")
    numpy_lib = blas_libs.select(filepath=[lib.filepath for lib in blas_libs.lib_controllers
                                           if "numpy" in lib.filepath])

    get, put = _numpy_openblas_threads()

    def ctypes_way() -> np.ndarray:
        before = get()
        if before == 1:
            return a @ b
        put(1)
        try:
            return a @ b
        finally:
            put(before)

    def limits_way() -> np.ndarray:
        with threadpoolctl.threadpool_limits(limits=1, user_api="blas"):
            return a @ b

    def controller_way() -> np.ndarray:
        with controller.limit(limits=1, user_api="blas"):
            return a @ b

    def numpy_lib_way() -> np.ndarray:
        with numpy_lib.limit(limits=1):
            return a @ b

    print(f"BLAS libraries loaded: {len(blas_libs.lib_controllers)} "
          f"({', '.join(lib.filepath.rsplit('/', 2)[-2] for lib in blas_libs.lib_controllers)}); "
          f"numpy's threads {numpy_lib.info()[0]['num_threads']}; product {args.rows} x 8 x 7 "
          f"complex")
    bare = _per_call_us(lambda: a @ b, args.calls, args.repeat)
    print(f"  {'bare product':24s} {bare:8.1f} µs per call")
    for name, fn in (("ctypes (before)", ctypes_way), ("threadpool_limits", limits_way),
                     ("controller.limit", controller_way), ("numpy's lib .limit", numpy_lib_way),
                     ("matmul_one_thread", lambda: blas.matmul_one_thread(a, b))):
        assert np.array_equal(np.asarray(fn()).view(float), want), name
        us = _per_call_us(fn, args.calls, args.repeat)
        print(f"  {name:24s} {us:8.1f} µs per call, {us - bare:+8.1f} µs over the bare product")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
