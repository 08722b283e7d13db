"""docs/stability.md §1 lists every bounded field of the schema with the schema's bounds.

The table is written by hand (it gives the reason for each bound); this test walks the pydantic
schema with the extremes campaign's classifier (tests/extremes.py) so that a field added,
removed or re-bounded in ``shipradar.sim.world.scenario`` without its row fails here.
"""

from __future__ import annotations

import re
from collections.abc import Iterator

from pydantic import BaseModel

from shipradar.sim.world.scenario import Scenario

from . import extremes as ex
from .helpers import ROOT

DOC = ROOT / "docs" / "stability.md"


def _tag(model: type[BaseModel]) -> str:
    """``(kind)`` for a member of a union told apart by its ``type`` literal."""
    if "type" not in model.model_fields:
        return ""
    leaf = ex.field_leaf(model, "type")
    return f"({leaf.choices[0]})" if leaf.kind == "literal" and len(leaf.choices) == 1 else ""


def _bounds_text(leaf: ex.Leaf) -> str:
    parts = []
    if leaf.lo is not None:
        parts.append(f"{'>' if leaf.lo_open else '>='} {leaf.lo:g}")
    if leaf.hi is not None:
        parts.append(f"{'<' if leaf.hi_open else '<='} {leaf.hi:g}")
    return ", ".join(parts)


def bounded_fields(model: type[BaseModel] = Scenario, prefix: str = "",
                   seen: tuple[type[BaseModel], ...] = ()) -> Iterator[tuple[str, str]]:
    """``(path, bounds)`` of every numeric field with a declared bound, depth first."""
    for name in model.model_fields:
        leaf = ex.field_leaf(model, name)
        while leaf.kind == "list" and leaf.item is not None:
            leaf = leaf.item
        if leaf.kind in ("number", "int") and (leaf.lo is not None or leaf.hi is not None):
            yield f"{prefix}{name}", _bounds_text(leaf)
        members = leaf.models if leaf.kind in ("model", "union") else ()
        for m in members:
            if m in seen:
                continue
            tag = _tag(m) if leaf.kind == "union" else ""
            yield from bounded_fields(m, f"{prefix}{name}{tag}.", (*seen, m))


def documented_fields() -> dict[str, str]:
    """``path -> bounds`` from the rows of the table in §1."""
    rows = re.findall(r"^\| `([^`]+)` \| ([^|]+?) \| .+ \|$", DOC.read_text(encoding="utf-8"),
                      flags=re.MULTILINE)
    return dict(rows)


def test_every_bounded_field_is_documented_with_its_bounds() -> None:
    schema = dict(bounded_fields())
    documented = documented_fields()
    assert len(schema) > 100
    missing = sorted(set(schema) - set(documented))
    assert missing == [], f"fields without a row in docs/stability.md §1: {missing}"
    wrong = {p: (documented[p], b) for p, b in schema.items() if documented[p] != b}
    assert wrong == {}, f"rows whose bounds differ from the schema's (doc, schema): {wrong}"
    stale = sorted(p for p in set(documented) - set(schema)
                   if "." in p or p in Scenario.model_fields)
    assert stale == [], f"rows for fields the schema no longer has: {stale}"


def test_every_row_says_why() -> None:
    text = DOC.read_text(encoding="utf-8")
    rows = re.findall(r"^\| `[^`]+` \| [^|]+ \| (.*) \|$", text, flags=re.MULTILINE)
    assert rows and all(len(why.strip()) > 5 for why in rows)
