"""The build and the optional extension as a user's machine meets them.

- a run with the compiled extension switched off (``SHIPRADAR_PURE_PYTHON=1``: the
  pure-Python encoder, what an install without a C compiler runs) records the very bytes of
  a run with it. The install without a compiler itself: tests/test_wheel.py.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from shipradar import _framing

ROOT = Path(__file__).resolve().parents[1]


def _copy_tree(dst: Path) -> Path:
    """The sources as a fresh checkout has them (setuptools writes into the tree it builds)."""
    shutil.copytree(ROOT, dst, symlinks=True, ignore=shutil.ignore_patterns(
        ".git", ".venv", "build", "out", "*.egg-info", "__pycache__", ".*_cache",
        ".hypothesis", "node_modules", "*.rec", "*.so", ".tables"))
    return dst


def _record(tmp_path: Path, name: str, env: dict[str, str]) -> bytes:
    out = tmp_path / f"{name}.rec"
    probe = ("import sys; from shipradar import _framing; "
             "print(_framing.frames.__name__, file=sys.stderr); "
             "from shipradar.sim.cli import main; sys.exit(main())")
    proc = subprocess.run([sys.executable, "-c", probe, "run", "--example", "raid",
                           "--duration", "20", "--record", str(out), "--quiet"],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stderr.splitlines()[0] == f"shipradar.{name}"
    return out.read_bytes()


@pytest.mark.skipif(not _framing.COMPILED, reason="shipradar._frames was not built")
def test_the_stream_without_the_extension_is_byte_identical(tmp_path):
    # the raid (two radars, targets, clutter and false alarms: every message kind the
    # encoder's slices and the recorder's framing handle), 20 s, uncompressed (the compiled
    # framing's path); the tables from the usual cache (SHIPRADAR_TABLES), as the golden runs
    env = {k: v for k, v in os.environ.items() if k != _framing.PURE_PYTHON_VARIABLE}
    compiled = _record(tmp_path, "_frames", env)
    pure = _record(tmp_path, "_frames_py", {**env, _framing.PURE_PYTHON_VARIABLE: "1"})
    assert len(compiled) > 100_000
    assert pure == compiled
