"""Every cross-reference in a docstring names something a reader can import.

A Sphinx role (``:func:`...```, ``:class:``, ``:meth:``, ``:mod:``, ``:data:``, ``:attr:``,
``:exc:``) names either a dotted path that imports as written (``shipradar.tables.store.Table``,
``scipy.special.gammaincc``) or a bare name defined in the module itself (``:func:`solve_pe```,
``:meth:`DwellModel.clutter_at```). Read with ``ast`` from the installed package's sources; the
targets are resolved by importing them.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import inspect
import re

import pytest

from .helpers import package_modules

ROLE = re.compile(r":(?:func|class|meth|mod|data|attr|exc|obj):`~?([A-Za-z_][\w.]*)(?:\(\))?`")


MODULES = package_modules()


def _docstrings(tree: ast.Module) -> list[tuple[str, str]]:
    """``(enclosing class or "", docstring)`` of the module, its classes and functions."""
    out = []

    def visit(node: ast.AST, cls: str) -> None:
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            inner = node.name if isinstance(node, ast.ClassDef) and not cls else cls
            doc = ast.get_docstring(node, clean=False)
            if doc:
                out.append((inner, doc))
            for child in ast.iter_child_nodes(node):
                visit(child, inner)

    visit(tree, "")
    return out


def _resolves(target: str, module_name: str, cls: str = "") -> bool:
    """Import the longest importable prefix of ``target`` and walk the rest as attributes;
    a name without a package is looked up in its class (Sphinx's rule inside a class), then
    in ``module_name``."""
    candidates = [target]
    if not target.startswith(("shipradar.", "scipy.", "numpy.", "np.", "zmq.", "simpy.")):
        candidates.insert(0, f"{module_name}.{target}")
        if cls:
            candidates.insert(0, f"{module_name}.{cls}.{target}")
    for cand in candidates:
        cand = cand.replace("np.", "numpy.", 1) if cand.startswith("np.") else cand
        parts = cand.split(".")
        for i in range(len(parts), 0, -1):
            try:
                obj = importlib.import_module(".".join(parts[:i]))
            except ImportError:
                continue
            rest = parts[i:]
            try:
                for j, attr in enumerate(rest):
                    if not hasattr(obj, attr) and j == len(rest) - 1 and _instance_attr(obj, attr):
                        break
                    obj = getattr(obj, attr)
            except AttributeError:
                break
            return True
    return False


def _instance_attr(cls: object, name: str) -> bool:
    """``name`` is an attribute of ``cls``'s instances: a dataclass or annotated field, or
    assigned as ``self.name`` in its source."""
    if not isinstance(cls, type):
        return False
    if any(name in getattr(k, "__annotations__", {}) for k in cls.__mro__):
        return True
    try:
        source = inspect.getsource(cls)
    except (OSError, TypeError):
        return False
    return re.search(rf"self\.{re.escape(name)}\s*(?::[^=]*)?=", source) is not None


def _references() -> list[tuple[str, str, str]]:
    """``(module, enclosing class, target)`` of every role in every docstring."""
    refs = []
    for name, path in sorted(MODULES.items()):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for cls, doc in _docstrings(tree):
            refs.extend((name, cls, m.group(1).rstrip(".")) for m in ROLE.finditer(doc))
    return refs


REFS = _references()


def test_the_scan_finds_references():
    assert len(REFS) > 100


@pytest.mark.parametrize("module", sorted({m for m, _, _ in REFS}))
def test_docstring_references_import(module):
    bad = sorted({t for m, c, t in REFS if m == module and not _resolves(t, module, c)})
    assert bad == [], f"{module}: references that do not import: {bad}"
