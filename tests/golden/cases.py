"""The golden recordings: which runs, how they are made, and the install that made them.

One home for the cases, shared by the test (``tests/test_golden.py``) and the regeneration
(``make golden``, i.e. ``python -m tests.golden``); ``tests/golden/README.md`` says when to
regenerate and what the test promises.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import subprocess
import sys
from dataclasses import dataclass
from importlib.metadata import distributions
from pathlib import Path
from typing import Any

import numpy as np
import scipy

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
LOCK = ROOT / "requirements" / "lock.txt"
MADE_WITH = HERE / "made_with.json"

# Largest relative difference |a - b| / max(|a|, |b|) allowed between a golden value and a
# rerun's when the install or the CPU differs from the golden files' own: about 8 times the
# largest difference measured between installs and CPUs (1.3e-6, a P_d deep in its tail, on
# 60 s runs; docs/stability.md section 6). A change of the physics can move values by less
# (issue 40 moved the manoeuvres case by 4.6e-9): on the golden files' own install and CPU the
# test asks for the same bytes.
RTOL = 1e-5


@dataclass(frozen=True)
class Case:
    """One golden run: a shipped scene, seed and duration, recorded with zstd."""

    scene: str
    seed: int
    duration_s: float

    @property
    def file(self) -> Path:
        return HERE / f"{self.scene}.rec"


# A few seconds of four shipped scenes (about 400 kB in all): the demo scene's sea clutter and
# noise false alarms; manoeuvring targets with Doppler plots; jamming and rain; the raid's
# many targets, each radar's own tables.
CASES = (
    Case("single_missile", 7, 3.0),
    Case("manoeuvres", 7, 4.0),
    Case("jammed_squall", 7, 3.0),
    Case("raid", 7, 2.0),
)


def record(case: Case, out: Path) -> None:
    """Run ``case`` with the command line, as a user would, recording to ``out``.

    The tables come from (or are built into) the usual cache, ``SHIPRADAR_TABLES``.
    """
    scenario = ROOT / "scenarios" / f"{case.scene}.yaml"
    proc = subprocess.run(
        [sys.executable, "-m", "shipradar.sim.cli", "run", str(scenario), "--seed",
         str(case.seed), "--duration", str(case.duration_s), "--record", str(out),
         "--overwrite", "--compress", "zstd", "--quiet"],
        capture_output=True, text=True, timeout=600, env=dict(os.environ),
    )
    if proc.returncode != 0:
        raise RuntimeError(f"shipradar run {case.scene} failed:\n{proc.stderr[-3000:]}")


def _norm(name: str) -> str:
    return name.lower().replace("_", "-").replace(".", "-")


def locked_versions() -> dict[str, str]:
    """The lock's ``name==version`` pins (names normalised)."""
    pins = {}
    for line in LOCK.read_text().splitlines():
        if line and line[0].isalnum() and "==" in line:
            name, version = line.split(" ")[0].split("==")
            pins[_norm(name)] = version
    return pins


def installed_differences() -> list[str]:
    """The locked packages whose installed version is not the lock's (empty: as locked)."""
    installed = {_norm(d.metadata["Name"]): d.version for d in distributions()}
    return [f"{name} {installed.get(name, 'missing')} (lock {version})"
            for name, version in sorted(locked_versions().items())
            if installed.get(name) != version]


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            return next((line.split(":", 1)[1].strip() for line in f
                         if line.startswith("model name")), platform.processor())
    except OSError:
        return platform.processor()


def environment() -> dict[str, Any]:
    """What the bytes of a recording depend on beyond the code: the install and the CPU.

    The lock's hash (every dependency's version), numpy's and scipy's versions and BLAS
    builds, the Python, the C library (libm), the CPU, the SIMD kernels numpy runs (its
    baseline and the dispatched targets this CPU has, less any NPY_DISABLE_CPU_FEATURES) and
    an OpenBLAS core type forced by OPENBLAS_CORETYPE.
    """
    try:
        from numpy._core import _multiarray_umath as umath
    except ImportError:  # numpy 1
        from numpy.core import _multiarray_umath as umath  # type: ignore[no-redef]
    found = [f for f in umath.__cpu_dispatch__ if umath.__cpu_features__.get(f)]

    def blas(module: Any) -> str:
        try:
            b = module.show_config(mode="dicts")["Build Dependencies"]["blas"]
        except (TypeError, KeyError):  # an old build without the dictionary
            return "BLAS unknown"
        return f"{b.get('name')} {b.get('version')}"

    return {
        "lock_sha256": hashlib.sha256(LOCK.read_bytes()).hexdigest(),
        "numpy": f"{np.__version__} ({blas(np)})",
        "scipy": f"{scipy.__version__} ({blas(scipy)})",
        "python": platform.python_version(),
        "machine": platform.machine(),
        "libc": " ".join(platform.libc_ver()),
        "cpu": _cpu_model(),
        "numpy_simd": " ".join(umath.__cpu_baseline__) + " + " + " ".join(found),
        "openblas_coretype": os.environ.get("OPENBLAS_CORETYPE", ""),
    }


def bytes_expected() -> tuple[bool, str]:
    """Whether this install and CPU are the golden files' own (then the bytes must be equal).

    Returns the answer and, when it is no, why not.
    """
    made = json.loads(MADE_WITH.read_text())
    here = environment()
    why = [f"{k}: {here[k]} here, {made.get(k)} for the golden files"
           for k in here if here[k] != made.get(k)]
    why += [f"not as locked: {d}" for d in installed_differences()]
    return not why, "; ".join(why)


def regenerate() -> None:
    """Record every case anew and note the install that made them (``make golden``)."""
    if diffs := installed_differences():
        raise SystemExit("make golden needs the locked install (make install): "
                         + "; ".join(diffs))
    for case in CASES:
        record(case, case.file)
        print(f"{case.file.relative_to(ROOT)}: {case.file.stat().st_size} bytes")
    MADE_WITH.write_text(json.dumps(environment(), indent=1) + "\n")
    print(f"{MADE_WITH.relative_to(ROOT)} written")
