"""Size of the code's units: long functions, long parameter lists, large modules (issue 31).

The limits of issue 31: no function over :data:`MAX_LINES` lines and none with more than
:data:`MAX_PARAMS` parameters, unless a one-line reason comment stands beside its ``def`` (in
the comment lines right above it or its decorators, or at the end of the ``def`` line)
beginning ``# long:`` (length) or ``# params:`` (parameters). Read with ``ast`` (nothing runs).

Usage: python benchmarks/structure.py [FOLDER ...]   (default: sim sensors tables, the
folders of issue 31's limits); ``--strict`` exits 1 when a function is over a limit without
its reason, naming each (tests/test_structure.py runs the same check).
"""

from __future__ import annotations

import argparse
import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_FOLDERS = ("sim", "sensors", "tables")
#: Longest function [lines, def to last line] and most parameters allowed without a reason.
MAX_LINES = 80
MAX_PARAMS = 10
REASONS = {"lines": "# long:", "params": "# params:"}


def _params(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Parameters a caller can pass (``self``/``cls`` of a method not counted)."""
    a = fn.args
    names = [*a.posonlyargs, *a.args, *a.kwonlyargs]
    n = len(names) + (a.vararg is not None) + (a.kwarg is not None)
    if names and names[0].arg in ("self", "cls"):
        n -= 1
    return n


def _reason(lines: list[str], fn: ast.FunctionDef | ast.AsyncFunctionDef, kind: str) -> bool:
    first = min([fn.lineno, *(d.lineno for d in fn.decorator_list)])
    body0 = fn.body[0].lineno if fn.body else fn.lineno
    above = []  # the comment lines right above the def (or its decorators)
    i = first - 2
    while i >= 0 and lines[i].strip().startswith("#"):
        above.append(lines[i])
        i -= 1
    here = [*above, *lines[fn.lineno - 1:body0 - 1]]
    return any(REASONS[kind] in line for line in here)


def functions_in(text: str, path: str) -> list[dict]:
    """Every function (methods and nested ones included) of one module's source ``text``:
    ``path``, name, first line, lines (def to last line), docstring lines, parameters, and
    whether a ``# long:`` (``lines_reason``) or ``# params:`` (``params_reason``) reason
    stands beside it."""
    lines = text.splitlines()
    out = []
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            n_lines = (node.end_lineno or node.lineno) - node.lineno + 1
            doc = node.body[0] if node.body else None
            n_doc = ((doc.end_lineno or doc.lineno) - doc.lineno + 1
                     if isinstance(doc, ast.Expr) and isinstance(doc.value, ast.Constant)
                     and isinstance(doc.value.value, str) else 0)
            out.append({"path": path, "name": node.name, "line": node.lineno,
                        "lines": n_lines, "doc_lines": n_doc, "params": _params(node),
                        "lines_reason": _reason(lines, node, "lines"),
                        "params_reason": _reason(lines, node, "params")})
    return out


def functions(folders: list[str]) -> list[dict]:
    """Every function of the ``.py`` files below ``folders`` (relative to the checkout), as
    :func:`functions_in` gives them."""
    out = []
    for folder in folders:
        for path in sorted((ROOT / folder).rglob("*.py")):
            out += functions_in(path.read_text(encoding="utf-8"), str(path.relative_to(ROOT)))
    return out


def over_limits(fns: list[dict]) -> list[str]:
    """One line per function over a limit without its reason (empty: the limits hold)."""
    bare = []
    for f in fns:
        if f["lines"] > MAX_LINES and not f["lines_reason"]:
            bare.append(f"{f['path']}:{f['line']} {f['name']}: {f['lines']} lines "
                        f"(over {MAX_LINES}, no '{REASONS['lines']}' reason)")
        if f["params"] > MAX_PARAMS and not f["params_reason"]:
            bare.append(f"{f['path']}:{f['line']} {f['name']}: {f['params']} parameters "
                        f"(over {MAX_PARAMS}, no '{REASONS['params']}' reason)")
    return bare


def modules(folders: list[str]) -> list[tuple[int, str]]:
    """(lines, path) of every ``.py`` file below ``folders``, largest first."""
    found = [(len(p.read_text(encoding="utf-8").splitlines()), str(p.relative_to(ROOT)))
             for f in folders for p in (ROOT / f).rglob("*.py")]
    return sorted(found, reverse=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="*", default=list(DEFAULT_FOLDERS))
    ap.add_argument("--most", type=int, default=10, help="rows of each list")
    ap.add_argument("--strict", action="store_true",
                    help="exit 1 when a function is over a limit without its reason")
    args = ap.parse_args(argv)
    fns = functions(args.folders)
    long_ = [f for f in fns if f["lines"] > MAX_LINES]
    many = [f for f in fns if f["params"] > MAX_PARAMS]
    bare = over_limits(fns)
    print(f"folders: {' '.join(args.folders)}; {len(fns)} functions")
    print(f"over {MAX_LINES} lines: {len(long_)} ({sum(not f['lines_reason'] for f in long_)} "
          f"without a reason); over {MAX_PARAMS} parameters: {len(many)} "
          f"({sum(not f['params_reason'] for f in many)} without a reason)")
    print("longest functions:")
    for f in sorted(fns, key=lambda f: -f["lines"])[:args.most]:
        why = " (reason given)" if f["lines_reason"] else ""
        print(f"  {f['lines']:5d}  {f['path']}:{f['line']} {f['name']} "
              f"(docstring {f['doc_lines']}){why}")
    print("most parameters:")
    for f in sorted(fns, key=lambda f: -f["params"])[:args.most]:
        why = " (reason given)" if f["params_reason"] else ""
        print(f"  {f['params']:5d}  {f['path']}:{f['line']} {f['name']}{why}")
    print("largest modules [lines]:")
    for n, p in modules(args.folders)[:args.most]:
        print(f"  {n:5d}  {p}")
    if args.strict and bare:
        print("over a limit without its reason:", *bare, sep="\n  ")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
