"""The package's layers import downward only, and no module imports itself through a circle.

Read from the source with ``ast`` (nothing is executed), lazy imports inside functions
included. The layers, bottom to top (README, "Layers"):

0. world: ``shipradar.sim.world.scenario``, the scenario as plain, validated data, and the motion it
   declares (``shipradar.sim.world.kinematics``, ``shipradar.sim.world.trajectory``: positions and
   velocities of its objects at any time, from the schema alone), and the geometry both share
   (``shipradar.sensors.geometry``: the earth's radius, k = 4/3, slant range, N_n, N_rep);
1. physics: ``shipradar.sensors.*`` (one module per phenomenon), which imports nothing of ours
   but the schema;
2. tables: ``shipradar.tables.*``, the off-line level, building and reading tables from the
   physics;
3. on-line composition: ``shipradar.sim.dwell.model``, the dwell model composing physics and
   tables per beam crossing;
4. service: the engine, bus, recording, CLI and the rest of ``shipradar.sim``, the public API
   (``shipradar``, ``shipradar.api``) and the shipped examples (``shipradar.scenarios``).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

from .helpers import package_modules

ROOT = Path(__file__).resolve().parents[1]
SCHEMA, PHYSICS, TABLES, ONLINE, SERVICE = range(5)


MODULES = package_modules()


#: The folder (package) of each layer below the service; everything else is layer 4.
LAYER_PACKAGES = {
    # the shared earth and scan geometry imports nothing of ours: the schema checks a radar's
    # feasibility and moves its objects with it (issue 31, one home per fact)
    "shipradar.sensors.geometry": SCHEMA,
    "shipradar.sim.world": SCHEMA,
    "shipradar.sensors": PHYSICS,
    "shipradar.tables": TABLES,
    "shipradar.sim.dwell": ONLINE,
}


def layer(name: str) -> int:
    for pkg, level in LAYER_PACKAGES.items():
        if name == pkg or name.startswith(pkg + "."):
            return level
    return SERVICE


def imports_of(name: str) -> set[str]:
    """Our modules that ``name`` imports anywhere in its source (lazy imports included)."""
    tree = ast.parse(MODULES[name].read_text(encoding="utf-8"))
    package = name if MODULES[name].name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative import
                anchor = package.split(".")
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join([*anchor, base]) if base else ".".join(anchor)
            if base in MODULES:
                found.add(base)
            for alias in node.names:
                if f"{base}.{alias.name}" in MODULES:
                    found.add(f"{base}.{alias.name}")
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name in MODULES)
    found.discard(name)
    return found


GRAPH = {name: imports_of(name) for name in MODULES}


def test_every_package_folder_is_installed():
    """Each folder with an ``__init__.py`` under the mapped folders is a listed package (a
    new subpackage missing from pyproject.toml would not be in the wheel)."""
    if sys.version_info < (3, 11):
        pytest.skip("tomllib needs Python 3.11")
    import tomllib

    meta = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    setup = meta["tool"]["setuptools"]
    listed = set(setup["packages"])
    for pkg, folder in setup["package-dir"].items():
        for init in (ROOT / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(ROOT / folder).parts
            assert ".".join([pkg, *rel]) in listed, f"{init.parent} is not in packages"
    packages = {m for m, path in MODULES.items() if path.name == "__init__.py"}
    assert packages <= listed


def test_the_walk_sees_the_known_modules():
    # a guard against a walk that finds nothing and so passes trivially
    for name in ("shipradar.sim.engine.simulation", "shipradar.sim.dwell.model",
                 "shipradar.tables.scene",
                 "shipradar.sensors.detection", "shipradar.sim.world.scenario", "shipradar.api"):
        assert name in GRAPH
    assert "shipradar.sim.world.scenario" in GRAPH["shipradar.sim.dwell.model"]
    assert "shipradar.tables.scene" in GRAPH["shipradar.sim.engine.simulation"] or any(
        "shipradar.tables" in m for m in GRAPH["shipradar.sim.engine.simulation"])


def test_imports_point_downward_only():
    upward = sorted(f"{a} ({layer(a)}) imports {b} ({layer(b)})"
                    for a, deps in GRAPH.items() for b in deps if layer(b) > layer(a))
    assert upward == []


def test_no_import_circles():
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:  # Tarjan's strongly connected components
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(GRAPH[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                circles.append(sorted(comp))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))
    for v in sorted(GRAPH):
        if v not in index:
            visit(v)
    assert circles == []


def test_the_stream_imports_no_adapter():
    """The adapters (ASTERIX, DIS, viewer, export) read the stream; the stream never reads
    an adapter (issue 31: the export that needs ASTERIX lives in sim/adapters/)."""
    stream, adapters = "shipradar.sim.stream", "shipradar.sim.adapters"
    assert [f"{a} imports {b}" for a, deps in sorted(GRAPH.items()) if a.startswith(stream)
            for b in sorted(deps) if b.startswith(adapters)] == []
