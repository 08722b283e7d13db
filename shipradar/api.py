"""The library entry points promised by :mod:`shipradar` (everything else may change).

Each function takes a scenario already loaded (:func:`shipradar.load_scenario`), a path, or
the name of a shipped example.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from shipradar.scenarios import example_path
from shipradar.sim.engine.simulation import CallbackSink, Simulation
from shipradar.sim.world.scenario import Scenario, load_scenario

if TYPE_CHECKING:
    from shipradar.sim.studies.evaluate.metrics import MetricConfig
    from shipradar.tables.scene import SceneTables

__all__ = ["build_tables", "evaluate", "example", "messages", "run"]

ScenarioLike = Scenario | str | Path


def example(name: str) -> Scenario:
    """The shipped example scenario ``name`` (see :func:`shipradar.example_names`), validated."""
    return load_scenario(example_path(name))


def _scenario(scenario: ScenarioLike) -> Scenario:
    return scenario if isinstance(scenario, Scenario) else load_scenario(scenario)


def build_tables(scenario: ScenarioLike, *, progress: bool = False) -> SceneTables:
    """Build (or load from the cache) the off-line tables the scenario reads.

    Returns
    -------
    shipradar.tables.scene.SceneTables
        Pass it to :func:`run` or :func:`messages` to skip the cache look-up.
    """
    from shipradar.tables.scene import load_scene_tables

    s = _scenario(scenario)
    estimated_s = None
    if progress:
        from shipradar.tables.budget import build_seconds, estimate_build

        estimated_s = build_seconds(estimate_build(s, include_pd=False))
    return load_scene_tables(s, progress=progress, estimated_s=estimated_s)


def _simulation(scenario: ScenarioLike, tables: SceneTables | None, seed: int | None,
                duration_s: float | None, bus: CallbackSink | None = None) -> Simulation:
    s = _scenario(scenario)
    return Simulation(s, bus=bus, seed=seed, duration_s=duration_s,
                      tables=tables if tables is not None else build_tables(s))


def run(scenario: ScenarioLike, *, on_message: Callable[[str, float, dict], Any] | None = None,
        seed: int | None = None, duration_s: float | None = None,
        tables: SceneTables | None = None) -> dict[str, Any]:
    """Run a scenario in process, as fast as possible, with no sockets.

    Parameters
    ----------
    scenario : Scenario, path or str
        The scene.
    on_message : callable, optional
        Called as ``on_message(topic, t_sim, payload)`` for every message of the stream
        (topics ``meta``, ``plots``, ``eos``, ``truth``; payload keys as in docs/protocol.md).
    seed : int, optional
        Overrides the scenario's seed.
    duration_s : float, optional
        Overrides the scenario's duration [s].
    tables : SceneTables, optional
        From :func:`build_tables`; built or loaded from the cache when omitted.

    Returns
    -------
    dict
        The run's summary (the JSON line that ``shipradar run`` prints).
    """
    sink = CallbackSink(on_message) if on_message is not None else None
    return _simulation(scenario, tables, seed, duration_s, sink).run()


def messages(scenario: ScenarioLike, *, seed: int | None = None,
             duration_s: float | None = None, tables: SceneTables | None = None
             ) -> Iterator[tuple[str, float, dict]]:
    """Iterate the messages of an in-process run as ``(topic, t_sim, payload)``.

    Same messages, in the same order, as :func:`run` gives its callback; the simulation
    advances one scan at a time as the iterator is consumed, so breaking out early stops it.
    """
    yield from _simulation(scenario, tables, seed, duration_s).messages()


def evaluate(scenario: ScenarioLike, *, tracker: Any, runs: int = 1, seed: int | None = None,
             duration_s: float | None = None, tables: SceneTables | None = None,
             config: MetricConfig | None = None, out: str | Path | None = None
             ) -> dict[str, Any]:
    """Score an in-process tracker on seeded runs (``shipradar evaluate`` for a Python object).

    ``tracker`` has ``on_message(topic, t_sim, payload)`` returning None or a ``tracks``
    payload (docs/protocol.md section 4.6), or is a callable making one per run; it sees
    ``meta``, ``plots`` and ``eos``, never ``truth``. ``config``: a
    :class:`shipradar.sim.studies.evaluate.metrics.MetricConfig`. Returns the per-run,
    per-scan and per-target rows and the summary over runs with 95 % intervals
    (docs/studies.md, "Scoring a tracker").
    """
    from shipradar.sim.studies.evaluate.metrics import DEFAULT_METRICS
    from shipradar.sim.studies.evaluate.study import evaluate_object

    s = _scenario(scenario)
    return evaluate_object(s, tracker, runs=runs, seed=seed, duration_s=duration_s,
                           tables=tables, config=config or DEFAULT_METRICS, out=out)
