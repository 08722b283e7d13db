"""The cache key of every table of every shipped example scene, as JSON (issue 31).

Run it before and after a refactor of the table builders' inputs and compare the outputs:
unchanged inputs must keep their keys (a warm cache stays valid), and a key that moves
must come with a bumped builder version. Nothing is built (only the keys are computed).

Usage: .venv/bin/python benchmarks/table_keys.py > keys.json
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import shipradar.scenarios
from shipradar.sim.world.scenario import load_scenario
from shipradar.tables.scene import table_specs
from shipradar.tables.store import inputs_hash


def table_keys() -> dict[str, str]:
    """``{"scene/radar/kind": key}`` over the shipped example scenes."""
    out = {}
    for path in sorted(Path(shipradar.scenarios.__file__).parent.glob("*.yaml")):
        for spec in table_specs(load_scenario(path)):
            name, version, inputs = spec.key()
            out[f"{path.stem}/{spec.radar_id}/{spec.kind}"] = inputs_hash(name, version, inputs)
    return out


if __name__ == "__main__":
    json.dump(table_keys(), sys.stdout, indent=1, sort_keys=True)
    print()
