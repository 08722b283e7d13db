"""The package's layers import downward only, and no module imports itself through a circle.

Read from the source with ``ast`` (nothing is executed), lazy imports inside functions
included. The layers, bottom to top (README, "Layers"):

0. world: ``shipradar.sim.scenario``, the scenario as plain, validated data, and the motion it
   declares (``shipradar.sim.kinematics``, ``shipradar.sim.trajectory``: positions and
   velocities of its objects at any time, from the schema alone);
1. physics: ``shipradar.sensors.*`` (one module per phenomenon), which imports nothing of ours
   but the schema;
2. tables: ``shipradar.tables.*``, the off-line level, building and reading tables from the
   physics;
3. on-line composition: ``shipradar.sensors.dwell``, the dwell model composing physics and
   tables per beam crossing;
4. service: the engine, bus, recording, CLI and the rest of ``shipradar.sim``, the public API
   (``shipradar``, ``shipradar.api``) and the shipped examples (``shipradar.scenarios``).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: Import name -> folder, as pyproject.toml's [tool.setuptools.package-dir] maps them.
PACKAGE_DIRS = {
    "shipradar": "shipradar",
    "shipradar.sim": "sim",
    "shipradar.sensors": "sensors",
    "shipradar.tables": "tables",
    "shipradar.scenarios": "scenarios",
}
SCHEMA, PHYSICS, TABLES, ONLINE, SERVICE = range(5)
#: Layer 0: the scenario and the motion it declares.
WORLD = {"shipradar.sim.scenario", "shipradar.sim.kinematics", "shipradar.sim.trajectory"}


def _modules() -> dict[str, Path]:
    out = {}
    for pkg, folder in PACKAGE_DIRS.items():
        base = ROOT / folder
        for path in base.rglob("*.py"):
            rel = path.relative_to(base).with_suffix("")
            if pkg == "shipradar" and rel.parts[0] != "__init__" and len(rel.parts) > 1:
                continue
            parts = [p for p in rel.parts if p != "__init__"]
            out[".".join([pkg, *parts])] = path
    return out


MODULES = _modules()


def layer(name: str) -> int:
    if name in WORLD:
        return SCHEMA
    if name == "shipradar.sensors.dwell":
        return ONLINE
    if name == "shipradar.sensors" or name.startswith("shipradar.sensors."):
        return PHYSICS
    if name == "shipradar.tables" or name.startswith("shipradar.tables."):
        return TABLES
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


def test_package_dirs_match_pyproject():
    if sys.version_info < (3, 11):
        pytest.skip("tomllib needs Python 3.11")
    import tomllib

    meta = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    dirs = meta["tool"]["setuptools"]["package-dir"]
    assert dirs == PACKAGE_DIRS


def test_the_walk_sees_the_known_modules():
    # a guard against a walk that finds nothing and so passes trivially
    for name in ("shipradar.sim.engine", "shipradar.sensors.dwell", "shipradar.tables.scene",
                 "shipradar.sensors.detection", "shipradar.sim.scenario", "shipradar.api"):
        assert name in GRAPH
    assert "shipradar.sim.scenario" in GRAPH["shipradar.sensors.dwell"]
    assert "shipradar.tables.scene" in GRAPH["shipradar.sim.engine"] or any(
        "shipradar.tables" in m for m in GRAPH["shipradar.sim.engine"])


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
