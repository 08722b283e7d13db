"""shipradar: a shipborne surveillance radar simulator (DREV-R-9429) for data fusion studies.

The public API, everything a library user needs::

    import shipradar

    scenario = shipradar.load_scenario("scene.yaml")       # or shipradar.example("raid")
    tables = shipradar.build_tables(scenario)               # off-line level, cached
    for topic, t, msg in shipradar.messages(scenario, tables=tables, duration_s=60):
        if topic == "plots":
            print(t, msg["range_m"], msg["azimuth_rad"])

``run(scenario, on_message=...)`` runs to the end with a callback and returns the summary;
``probability_of_detection`` and ``required_snr_db`` are the detection functions;
``read_recording`` iterates a recording; ``plot_to_local``, ``plot_to_geodetic``,
``local_to_plot``, ``local_to_geodetic`` and ``geodetic_to_local`` convert between plots
(slant range, azimuth), the stream's local frame and WGS-84 (docs/protocol.md 4). The
subpackages ``shipradar.sim``, ``shipradar.sensors`` and ``shipradar.tables`` are
importable, but only the names listed in ``__all__`` are promised to stay.
"""

from __future__ import annotations

from importlib import import_module
from importlib.metadata import PackageNotFoundError, version
from typing import Any

try:
    __version__ = version("shipradar")
except PackageNotFoundError:  # pragma: no cover - running from an uninstalled checkout
    __version__ = "0+unknown"

# name -> module that defines it; imported on first use so `import shipradar` stays cheap
_EXPORTS = {
    "Scenario": "shipradar.sim.world.scenario",
    "ScenarioError": "shipradar.sim.world.scenario",
    "load_scenario": "shipradar.sim.world.scenario",
    "parse_scenario": "shipradar.sim.world.scenario",
    "geodetic_to_local": "shipradar.sim.world.frames",
    "local_to_geodetic": "shipradar.sim.world.frames",
    "local_to_plot": "shipradar.sim.world.frames",
    "plot_to_geodetic": "shipradar.sim.world.frames",
    "plot_to_local": "shipradar.sim.world.frames",
    "Simulation": "shipradar.sim.engine.simulation",
    "probability_of_detection": "shipradar.sensors.detection",
    "required_snr_db": "shipradar.sensors.detection",
    "read_recording": "shipradar.sim.stream.recording",
    "RecordingError": "shipradar.sim.stream.recording",
    "decode": "shipradar.sim.stream.protocol",
    "example_names": "shipradar.scenarios",
    "example_path": "shipradar.scenarios",
    "build_tables": "shipradar.api",
    "evaluate": "shipradar.api",
    "example": "shipradar.api",
    "messages": "shipradar.api",
    "run": "shipradar.api",
}

__all__ = ["__version__", *sorted(_EXPORTS)]


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'shipradar' has no attribute {name!r}")
    value = getattr(import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
