"""Where the bytes part between installs (issue 34; docs/stability.md section 6).

Runs the five shipped scenes (seed 7; 60 s, the stress scene 30 s, as
benchmarks/recording_hashes.sh) with other installs' ``shipradar`` (scratch venvs with other
numpy/scipy, hence other OpenBLAS builds) and compares with a reference install's (the lock's
numpy and scipy; every venv holds the same shipradar wheel):

- the tables each install builds (every array of every ``.npz``: equal bytes, or the largest
  relative difference);
- the recordings made with each install's own tables, and with this install's tables (which
  separates the on-line level from the off-line one): equal bytes, equal within which relative
  tolerance, or the first message that differs in structure (which plots exist).

Usage: python benchmarks/install_variation.py OUTDIR REFERENCE_VENV VENV [VENV ...]
(each venv has shipradar and its dependencies; this interpreter only compares.)
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from shipradar.sim.stream.compare import compare_recordings, plot_ids, recording_messages

ROOT = Path(__file__).resolve().parents[1]
CPU_VARIABLES = ("NPY_DISABLE_CPU_FEATURES", "OPENBLAS_CORETYPE")
SCENES = {"single_missile": 60, "raid": 60, "stress": 30, "manoeuvres": 60, "jammed_squall": 60}


def _versions(python: Path) -> str:
    """numpy's and scipy's versions and the BLAS each was built with (their show_config)."""
    code = ("import numpy, scipy\n"
            "def blas(m):\n"
            "    b = m.show_config(mode='dicts')['Build Dependencies']['blas']\n"
            "    return f\"{b.get('name')} {b.get('version')}\"\n"
            "print(f'numpy {numpy.__version__} ({blas(numpy)}), '\n"
            "      f'scipy {scipy.__version__} ({blas(scipy)})')")
    return subprocess.run([str(python), "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip()


def _run(venv: Path, cache: Path, scene: str, out: Path) -> None:
    env = dict(os.environ, SHIPRADAR_TABLES=str(cache))
    cli = str(venv / "bin" / "shipradar")
    path = str(ROOT / "scenarios" / f"{scene}.yaml")
    subprocess.run([cli, "tables", "build", path], env=env, check=True, capture_output=True)
    subprocess.run([cli, "run", path, "--seed", "7", "--duration", str(SCENES[scene]),
                    "--record", str(out), "--overwrite", "--quiet"], env=env, check=True,
                   capture_output=True)


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()[:16]


def _tables(ref: Path, other: Path) -> list[str]:
    """Per table file: missing (another key: its inputs differ), equal bytes (not listed), or
    per array the largest relative difference and how many values differ."""
    rows = []
    for f in sorted(ref.glob("*.npz")):
        g = other / f.name
        if not g.exists():
            rows.append(f"  {f.name}: not built (the other install keys it otherwise)")
            continue
        if f.read_bytes() == g.read_bytes():
            continue
        parts = []
        with np.load(f) as a, np.load(g) as b:
            for k in a.files:
                x, y = a[k], b[k]
                if x.shape != y.shape:
                    parts.append(f"{k} shape {x.shape} vs {y.shape}")
                elif x.dtype.kind in "fc":
                    rel = np.abs(x - y) / np.maximum(np.maximum(np.abs(x), np.abs(y)), 1e-300)
                    rel[(x == y) | (np.isnan(x) & np.isnan(y))] = 0.0
                    if n := int(np.count_nonzero(rel)):
                        parts.append(f"{k} {float(np.nanmax(rel)):.2g} ({n}/{rel.size})")
                elif not np.array_equal(x, y):
                    parts.append(f"{k} differs")
        rows.append(f"  {f.name}: " + ", ".join(parts))
    return rows


def _recording(ref: Path, other: Path) -> str:
    """Equal bytes, or the comparison by value (rtol 1e-6, then without a tolerance when a
    value is beyond it) and the keys whose values differ most."""
    if ref.read_bytes() == other.read_bytes():
        return "same bytes"
    c = compare_recordings(ref, other, rtol=1e-6)
    n_ref = len(plot_ids(recording_messages(ref)))
    n_other = len(plot_ids(recording_messages(other)))
    text = f"{c}; plots {n_ref} vs {n_other}"
    if c.first is not None and c.first.kind == "value":
        c = compare_recordings(ref, other, rtol=1.0)
        text += f"; beyond it: {c}"
    top = sorted(c.by_key.items(), key=lambda kv: -kv[1])[:4]
    return text + "; by key: " + ", ".join(f"{k} {v:.2g}" for k, v in top)


def main(argv: list[str]) -> int:
    out = Path(argv[1])
    reference = Path(argv[2])
    venvs = [Path(v) for v in argv[3:]]
    print(f"reference {reference.name}: {_versions(reference / 'bin' / 'python')}")
    ref_cache = out / "lock" / "tables"
    for scene in SCENES:
        if not (out / "lock" / f"{scene}.rec").exists():
            _run(reference, ref_cache, scene, out / "lock" / f"{scene}.rec")
    for venv in venvs:
        py = venv / "bin" / "python"
        # a CPU without some of this one's SIMD kernels, emulated: numpy's dispatch and
        # OpenBLAS's kernels set by the environment of this script
        cpu = " ".join(f"{v}={os.environ[v]}" for v in CPU_VARIABLES if v in os.environ)
        name = venv.name + ("-cpu-" + hashlib.sha256(cpu.encode()).hexdigest()[:6] if cpu else "")
        if cpu:
            print(f"\n(emulated CPU: {cpu})")
        print(f"\n## {name}: {_versions(py)}")
        cache = out / name / "tables"
        for scene in SCENES:
            _run(venv, cache, scene, out / name / f"{scene}.rec")
            _run(venv, ref_cache, scene, out / name / f"{scene}.lock-tables.rec")
        rows = _tables(ref_cache, cache)
        print("tables: " + ("all bytes equal" if not rows else "\n" + "\n".join(rows)))
        for scene in SCENES:
            ref = out / "lock" / f"{scene}.rec"
            own = out / name / f"{scene}.rec"
            mixed = out / name / f"{scene}.lock-tables.rec"
            print(f"{scene} {_sha(own)} (lock {_sha(ref)})\n"
                  f"  own tables: {_recording(ref, own)}\n"
                  f"  lock's tables: {_recording(ref, mixed)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
