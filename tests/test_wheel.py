"""The wheel works outside the checkout: built, installed in a fresh virtual environment beside
PyTables (import name ``tables``), an example run by name, the summary checked. And built on
a machine without a C compiler (``CC=false``): the optional extension left out, the install
works with the pure-Python encoder and records the same bytes.

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
import zipfile
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


def _wheel(tmp: Path, name: str, env: dict[str, str] | None = None) -> Path:
    """The wheel pip builds of a copy of the sources (setuptools writes build/ and
    *.egg-info into the tree it builds, so two builds of the checkout at once, two test
    processes, would collide there), in ``tmp/name``."""
    src = tmp / f"src-{name}"
    shutil.copytree(ROOT, src, symlinks=True, ignore=shutil.ignore_patterns(
        ".git", ".venv", "build", "out", "*.egg-info", "__pycache__", ".*_cache",
        ".hypothesis", "node_modules", "*.rec", "*.so", ".tables"))
    dist = tmp / name
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(dist), str(src)],
         env=env)
    wheels = list(dist.glob("shipradar-*.whl"))
    assert len(wheels) == 1
    return wheels[0]


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """A fresh venv outside the repository with the wheel and PyTables installed."""
    tmp = tmp_path_factory.mktemp("wheel")
    wheel = _wheel(tmp, "dist")
    env_dir = tmp / "venv"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    py = env_dir / "bin" / "python"
    _run([str(py), "-m", "pip", "install", "-q", str(wheel), "tables"])
    return tmp, py, wheel


def test_wheel_holds_only_the_shipradar_namespace(installed):
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


def test_without_a_c_compiler_the_install_works_and_records_the_same_bytes(installed):
    tmp, py, _ = installed
    # no compiler: setuptools' compile step runs `false` and fails; the extension is optional
    wheel = _wheel(tmp, "dist-nocc", env=dict(os.environ, CC="false"))
    names = zipfile.ZipFile(wheel).namelist()
    assert not any(n.startswith("shipradar/_frames.") and n.endswith(".so") for n in names)
    assert "shipradar/_frames_py.py" in names
    # a second fresh venv with this wheel alone; its dependencies (the same as the first
    # wheel's) are taken from the first venv by a .pth line rather than installed again
    env_dir = tmp / "venv-nocc"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    py_nocc = env_dir / "bin" / "python"
    _run([sys.executable, "-m", "pip", "--python", str(py_nocc), "install", "-q", "--no-deps",
          str(wheel)])
    site = "import sysconfig; print(sysconfig.get_path('purelib'))"
    deps, own = (Path(_run([str(p), "-c", site]).stdout.strip()) for p in (py, py_nocc))
    (own / "_deps.pth").write_text(f"{deps}\n")
    env = dict(os.environ, SHIPRADAR_TABLES=str(tmp / "tables"))
    env.pop("PYTHONPATH", None)
    env.pop("SHIPRADAR_PURE_PYTHON", None)
    recordings = []
    for python, name, module in ((py, "compiled", "shipradar._frames"),
                                 (py_nocc, "nocc", "shipradar._frames_py")):
        probe = ("import shipradar._framing as f; print(f.frames.__name__); "
                 "print(f.__file__)")
        found, path = _run([str(python), "-c", probe], cwd=tmp, env=env).stdout.split()
        assert found == module and path.startswith(str(python.parents[1]))
        out = tmp / f"{name}.rec"
        _run([str(python.parent / "shipradar"), "run", "--example", "single_missile",
              "--duration", "8", "--record", str(out), "--quiet"], cwd=tmp, env=env)
        recordings.append(out.read_bytes())
    assert len(recordings[0]) > 10_000
    assert recordings[1] == recordings[0]
