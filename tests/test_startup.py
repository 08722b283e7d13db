"""Start-up imports only what a command uses (issue 27).

Each check runs in a fresh interpreter and inspects ``sys.modules``: not a timing test.  The
forbidden modules are the ones the issue's profile found on the run path (astropy through
pymap3d and itur: 0.5 s; scipy.stats through scipy.signal: 0.3-0.7 s) and the heavy optional
packages of other commands (matplotlib for the figures, aiohttp for the viewer, dask and Stone
Soup for studies).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

FORBIDDEN = (
    "astropy", "pymap3d", "itur", "pyproj", "scipy.stats", "scipy.signal", "scipy.interpolate",
    "scipy.optimize", "matplotlib", "aiohttp", "dask", "stonesoup", "pandas", "tqdm",
)

_REPORT = """
import json, sys
bad = sorted(m for m in sys.modules
             if any(m == f or m.startswith(f + ".") for f in {forbidden!r}))
print("\\nFORBIDDEN " + json.dumps(bad))
"""


def _imported_forbidden(code: str, env: dict[str, str] | None = None,
                        forbidden: tuple[str, ...] = FORBIDDEN) -> list[str]:
    script = code + _REPORT.format(forbidden=forbidden)
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    line = [x for x in proc.stdout.splitlines() if x.startswith("FORBIDDEN ")][-1]
    return json.loads(line[len("FORBIDDEN "):])


def test_importing_the_engine_imports_nothing_heavy():
    assert _imported_forbidden("import shipradar.sim.engine.simulation") == []


def test_help_imports_nothing_heavy():
    code = """
import contextlib, io, sys
sys.argv = ["shipradar", "--help"]
from shipradar.sim import cli
with contextlib.redirect_stdout(io.StringIO()):
    try:
        cli.main()
    except SystemExit:
        pass
"""
    assert _imported_forbidden(code) == []
    # nor numpy (the recording module, for --compress's choices) nor zmq
    assert _imported_forbidden(code, forbidden=("numpy", "zmq")) == []


def test_the_parser_s_compressions_are_the_recording_s():
    from shipradar.sim import cli
    from shipradar.sim.stream.recording import COMPRESSIONS

    assert cli._COMPRESSIONS == COMPRESSIONS


@pytest.fixture(scope="module")
def built_cache(tmp_path_factory):
    env = dict(os.environ)
    env["SHIPRADAR_TABLES"] = str(tmp_path_factory.mktemp("tables"))
    proc = subprocess.run([sys.executable, "-m", "shipradar.sim.cli", "tables", "build",
                           "scenarios/single_missile.yaml"], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return env


def test_a_run_from_the_cache_imports_nothing_heavy(built_cache):
    """The run path: the scenario, its tables from the cache, the engine, the command."""
    code = """
import contextlib, io, sys
sys.argv = ["shipradar", "run", "scenarios/single_missile.yaml", "--duration", "12",
            "--quiet"]
from shipradar.sim import cli
with contextlib.redirect_stdout(io.StringIO()):
    assert cli.main() == 0
"""
    assert _imported_forbidden(code, env=built_cache) == []
    # zmq only with --publish, the ASTERIX adapter only with --asterix
    assert _imported_forbidden(code, env=built_cache,
                               forbidden=("zmq", "shipradar.sim.adapters.asterix")) == []


def test_the_library_run_path_imports_nothing_heavy(built_cache):
    code = """
import shipradar
s = shipradar.load_scenario("scenarios/single_missile.yaml")
from shipradar.tables.scene import load_scene_tables
from shipradar.sim.engine.simulation import Simulation
Simulation(s, tables=load_scene_tables(s), duration_s=12.0).run()
"""
    assert _imported_forbidden(code, env=built_cache) == []


def test_the_itur_versions_of_a_table_key_are_itur_s_own():
    """The atmosphere table's key names the itur release and its P.676/P.840 versions without
    importing itur (:data:`shipradar.tables.atmosphere.ITUR_DEFAULT_VERSIONS`); they must be
    what itur itself says."""
    code = """
import json, sys
from shipradar.tables.atmosphere import itur_versions
without = itur_versions()
assert "itur" not in sys.modules
import itur
from itur.models import itu676, itu840
print(json.dumps([without, {"itur": itur.__version__, "p676": itu676.get_version(),
                            "p840": itu840.get_version()}]))
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    without, own = json.loads(proc.stdout.splitlines()[-1])
    assert without == own


_GC_WATCH = """
import contextlib, gc, io, json, sys
import shipradar.sim.engine.simulation as engine
import shipradar.tables.scene as scene
from shipradar.sim import cli
seen = []
def watch(cls, name, what):
    f = getattr(cls, name)
    def watched(*a, **k):
        seen.append([what, gc.isenabled(), gc.get_freeze_count() > 0])
        return f(*a, **k)
    setattr(cls, name, watched)
watch(scene, "load_scene_tables", "tables")
watch(engine.Simulation, "run", "loop")
argv = ["run", "scenarios/single_missile.yaml", "--duration", "12", "--quiet"]
with contextlib.redirect_stdout(io.StringIO()):
    if {library}:
        assert cli.main(argv) == 0
    else:
        sys.argv = ["shipradar", *argv]
        assert cli.main() == 0
print(json.dumps([seen, gc.isenabled(), gc.get_freeze_count() > 0]))
"""


def _gc_seen(env: dict[str, str], library: bool) -> list:
    proc = subprocess.run([sys.executable, "-c", _GC_WATCH.format(library=library)],
                          capture_output=True, text=True, cwd=ROOT, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout.splitlines()[-1])


def test_the_command_line_run_collects_garbage_in_its_loop(built_cache, tmp_path):
    """``main()`` as the process's command: the collector is off over the imports and the
    tables read from the cache, on (with the set-up frozen) during the loop, and what is
    left is frozen at the end; on while tables are built; a library call ``main(argv)``
    leaves it alone."""
    enabled, frozen = True, True
    assert _gc_seen(built_cache, library=False) == [
        [["tables", not enabled, not frozen], ["loop", enabled, frozen]], enabled, frozen]
    assert _gc_seen(built_cache, library=True) == [
        [["tables", enabled, not frozen], ["loop", enabled, not frozen]], enabled, not frozen]
    # one table to build (a copy of the cache without the atmosphere tables)
    cache = tmp_path / "tables"
    shutil.copytree(built_cache["SHIPRADAR_TABLES"], cache)
    for f in cache.glob("atmospheric_loss-*.npz"):
        f.unlink()
    env = dict(built_cache, SHIPRADAR_TABLES=str(cache))
    assert _gc_seen(env, library=False)[0][0] == ["tables", enabled, not frozen]
