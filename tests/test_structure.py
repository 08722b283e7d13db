"""Issue 31's limits in sim/, sensors/ and tables/: no function over 80 lines and none with
more than 10 parameters without a one-line reason beside it (``# long:``, ``# params:``),
counted by benchmarks/structure.py (``ast``; nothing is imported or run)."""

from __future__ import annotations

import importlib.util
import textwrap

from .helpers import ROOT

_SPEC = importlib.util.spec_from_file_location("structure", ROOT / "benchmarks" / "structure.py")
assert _SPEC is not None and _SPEC.loader is not None
structure = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(structure)


def test_no_function_over_a_limit_without_its_reason() -> None:
    fns = structure.functions(list(structure.DEFAULT_FOLDERS))
    assert {f["path"].split("/")[0] for f in fns} == {"sim", "sensors", "tables"}
    bare = structure.over_limits(fns)
    assert not bare, ("functions over issue 31's limits without a one-line reason beside "
                      "their def:\n" + "\n".join(bare))


def test_the_counter_counts_lines_parameters_and_reasons() -> None:
    """The counter on a module written here: a def's lines from ``def`` to its last line,
    ``self`` not a parameter, ``*args``/``**kwargs`` one each, a reason in the comment lines
    right above the def (or its decorators) or at the end of its ``def`` line."""
    body = "\n".join(f"    x{i} = {i}" for i in range(80))  # 80 lines: 81 with the def
    text = textwrap.dedent('''\
        class A:
            def method(self, a, b, c, d, e, f, g, h, i, j):
                return a

            # params: the eleven inputs of the thing
            @staticmethod
            def wide(a, b, c, d, e, f, g, h, i, j, *rest):
                return a


        def kwargs_only(*, a, b, c, d, e, f, g, h, i, j, **more):  # params: by keyword
            return a


        def long_one():
        ''') + body + "\n\n\n" + "# long: a table written out\ndef long_why():\n" + body + "\n"
    fns = {f["name"]: f for f in structure.functions_in(text, "m.py")}
    assert fns["method"]["params"] == 10 and not fns["method"]["params_reason"]
    assert fns["wide"]["params"] == 11 and fns["wide"]["params_reason"]
    assert fns["kwargs_only"]["params"] == 11 and fns["kwargs_only"]["params_reason"]
    assert fns["long_one"]["lines"] == 81 and not fns["long_one"]["lines_reason"]
    assert fns["long_why"]["lines"] == 81 and fns["long_why"]["lines_reason"]
    assert structure.over_limits(list(fns.values())) == [
        "m.py:15 long_one: 81 lines (over 80, no '# long:' reason)"]
