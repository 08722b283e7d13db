"""The build and the optional extension as a user's machine meets them.

- the build backend (setuptools, as ``make install`` and ``pip install .`` run it) builds the
  wheel and the editable install of the tree without a single setuptools warning;
- a run with the compiled extension switched off (``SHIPRADAR_PURE_PYTHON=1``: the
  pure-Python encoder, what an install without a C compiler runs) records the very bytes of
  a run with it. The install without a compiler itself: tests/test_wheel.py.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
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


@pytest.mark.slow
def test_the_build_emits_no_setuptools_warning(tmp_path):
    src = _copy_tree(tmp_path / "src")
    dist = tmp_path / "dist"
    dist.mkdir()
    # the backend's own two entry points, as pip calls them (no isolation: this venv's
    # setuptools, the locked one make install uses); every warning shown
    code = ("import sys, setuptools.build_meta as b; "
            f"print(b.build_wheel({str(dist)!r})); print(b.build_editable({str(dist)!r}))")
    env = dict(os.environ, PYTHONWARNINGS="always")
    # distutils' own "byte-compiling is disabled" note when the environment says so
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    proc = subprocess.run([sys.executable, "-c", code], cwd=src, env=env, capture_output=True,
                          text=True, timeout=600)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out[-3000:]
    # every warning class (SetuptoolsWarning and its kin, distutils' "warning:" lines); the
    # editable build's one note, setuptools' InformationOnly "Editable installation" (a
    # folder named like the package in the working directory), is information by its class
    lines = [line for line in out.splitlines() if "warning" in line.lower()]
    assert not lines, "\n".join(lines)
    assert sorted(p.suffix for p in dist.iterdir()) == [".whl", ".whl"]
    # the package data the config lists is in the wheel, and no source beside it
    wheel = next(p for p in dist.iterdir() if "editable" not in p.name)
    names = set(zipfile.ZipFile(wheel).namelist())
    for folder, pattern in (("sim/stream/contract", "*.json"), ("sim/stream/contract", "*.yaml"),
                            ("scenarios", "*.yaml"), ("scenarios/traffic", "*.csv"),
                            ("sim/adapters/viewer/static", "*.js"), ("shipradar", "py.typed")):
        files = sorted((ROOT / folder).glob(pattern))
        assert files
        for f in files:  # the design card's folders sit under shipradar/ in the wheel
            rel = f.relative_to(ROOT).as_posix()
            assert (rel if rel.startswith("shipradar/") else f"shipradar/{rel}") in names, f
    assert not any(n.endswith(".c") for n in names)


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


def test_pyright_reads_each_module_once():
    # imports resolve through shipradar/'s links (shipradar/sim -> ../sim, ...): the folders
    # they point to are excluded, so that pyright does not read each module at both paths
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    exclude = set(config["tool"]["pyright"]["exclude"])
    links = [p for p in (ROOT / "shipradar").iterdir() if p.is_symlink()]
    assert {p.name for p in links} == {"sim", "sensors", "tables", "scenarios"}
    for link in links:
        target = (link.parent / os.readlink(link)).resolve()
        assert target.parent == ROOT and target.name in exclude, link
    # pyright's own defaults, which an exclude list replaces
    assert {"**/node_modules", "**/__pycache__", "**/.*"} <= exclude
