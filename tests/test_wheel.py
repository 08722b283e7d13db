"""The wheel works outside the checkout: built, installed in a fresh virtual environment beside
PyTables (import name ``tables``), an example run by name, the summary checked.

Needs the package registries (pip downloads the build backend and the dependencies, from
pip's cache when warm); about a minute.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# one worker builds the wheel and the venv for both tests (pytest-xdist, --dist loadgroup)
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("wheel")]


def _run(cmd, **kw):
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, **kw)
    assert proc.returncode == 0, (
        f"{cmd}\nstdout:\n{proc.stdout[-3000:]}\nstderr:\n{proc.stderr[-3000:]}")
    return proc


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """A fresh venv outside the repository with the wheel and PyTables installed."""
    tmp = tmp_path_factory.mktemp("wheel")
    dist = tmp / "dist"
    # built from a copy of the sources: setuptools writes build/ and *.egg-info into the tree
    # it builds, so two builds of the checkout at once (two test processes) collide there
    src = tmp / "src"
    shutil.copytree(ROOT, src, symlinks=True, ignore=shutil.ignore_patterns(
        ".git", ".venv", "build", "out", "*.egg-info", "__pycache__", ".*_cache",
        ".hypothesis", "node_modules", "*.rec", "*.so"))
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(dist), str(src)])
    wheels = list(dist.glob("shipradar-*.whl"))
    assert len(wheels) == 1
    env_dir = tmp / "venv"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    py = env_dir / "bin" / "python"
    _run([str(py), "-m", "pip", "install", "-q", str(wheels[0]), "tables"])
    return tmp, py, wheels[0]


def test_wheel_holds_only_the_shipradar_namespace(installed):
    import zipfile

    _, _, wheel = installed
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names}
    name, version = wheel.name.split("-")[:2]  # a platform wheel: it holds shipradar._frames
    assert tops == {"shipradar", f"{name}-{version}.dist-info"}
    assert any(n.startswith("shipradar/_frames.") and n.endswith(".so") for n in names)
    # the design card's folders live under the namespace; the examples ship as package data
    for sub in ("sim/engine/simulation.py", "sim/dwell/model.py", "tables/scene.py",
                "scenarios/raid.yaml",
                "scenarios/single_missile.yaml"):
        assert f"shipradar/{sub}" in names


def test_pip_show_lists_only_shipradar_modules(installed):
    _, py, _ = installed
    out = _run([str(py), "-m", "pip", "show", "-f", "shipradar"]).stdout
    files = out.split("Files:", 1)[1].split()
    assert files
    for f in files:
        assert f.startswith(("shipradar/", "shipradar-", "../../../bin/shipradar")), f


def test_example_runs_from_the_installed_wheel_beside_pytables(installed):
    tmp, py, _ = installed
    bin_dir = py.parent
    env = dict(os.environ, SHIPRADAR_TABLES=str(tmp / "tables"))
    env.pop("PYTHONPATH", None)
    listed = _run([str(bin_dir / "shipradar"), "examples"], cwd=tmp, env=env).stdout
    assert {"raid", "single_missile", "stress", "jammed_squall"} <= {
        line.split()[0] for line in listed.splitlines() if line.strip()}
    run = _run([str(bin_dir / "shipradar"), "run", "--example", "single_missile",
                "--duration", "4", "--quiet"], cwd=tmp, env=env)
    summary = json.loads(run.stdout.strip().splitlines()[-1])
    assert summary["scenario"] == "single_missile"
    assert summary["simulated_s"] == 4.0 and summary["scans"] == 4
    # both packages import side by side, each from its own place in site-packages
    probe = ("import tables, shipradar, shipradar.tables.store as s; "
             "print(tables.__file__); print(s.__file__); print(shipradar.__version__)")
    lines = _run([str(py), "-c", probe], cwd=tmp, env=env).stdout.splitlines()
    assert lines[0].endswith(os.path.join("site-packages", "tables", "__init__.py"))
    assert lines[1].endswith(os.path.join("site-packages", "shipradar", "tables", "store.py"))
    from importlib.metadata import version

    assert lines[2] == version("shipradar")  # __version__ from the package metadata
