"""One setting run over its seeds with common random numbers.

Every look (one radar, one target, one scan) gets one uniform number derived from (run
seed, radar, target, scan) alone (:func:`look_uniforms`, set on the dwell model's public
``look_uniforms``), and each look's P_d is read by an observer of the model's looks
(``on_look``); the tables each setting reads are timed (:class:`TableClock`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from shipradar.sim.dwell.look import LookObserver, LookResults
from shipradar.sim.studies.fidelity.plan import Setting, with_fidelity
from shipradar.sim.world.scenario import Scenario

#: Margin of the engine's beam-crossing search (shipradar.sim.engine.simulation._CROSSING_EPS_S)
#: [s]: a revolution owns crossings in [start - ε, end - ε).
_CROSSING_EPS_S = 1e-6


def look_uniforms(seed: int, radar_index: int, scan_period_s: float):
    """The common-random-number source of one radar in one run.

    Returns ``u(target_rows, t_s)``: one uniform in [0, 1) per look, a pure function of
    (seed, radar, target, scan), the scan being the revolution that owns the crossing time
    ``t_s`` (the engine's rule: [start - 1 µs, end - 1 µs)). The bits are the SplitMix64
    finaliser (Steele, Lea & Flood 2014) of the four keys combined with odd constants, the
    top 53 bits scaled to [0, 1).
    """
    base = np.array([seed & 0xFFFFFFFFFFFFFFFF], dtype=np.uint64)
    base = _splitmix64(base ^ np.uint64((radar_index * 0x9E3779B97F4A7C15) & 0xFFFFFFFFFFFFFFFF))

    def u(rows: np.ndarray, t: np.ndarray) -> np.ndarray:
        scan = np.floor((np.asarray(t, dtype=float) + _CROSSING_EPS_S) / scan_period_s)
        scan = np.maximum(scan, 0).astype(np.uint64)
        x = base ^ _splitmix64(np.asarray(rows, dtype=np.uint64) * np.uint64(0xBF58476D1CE4E5B9)
                               + np.uint64(1))
        x = _splitmix64(x ^ _splitmix64(scan + np.uint64(0x94D049BB133111EB)))
        return (x >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0)

    return u


def _splitmix64(x: np.ndarray) -> np.ndarray:
    """SplitMix64 finaliser of uint64 arrays (wrapping arithmetic)."""
    x = np.asarray(x, dtype=np.uint64).copy()
    x += np.uint64(0x9E3779B97F4A7C15)
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


@dataclass
class RunResult:
    """What one setting gave over its runs."""

    setting: Setting
    looks: dict[str, np.ndarray]  # run, radar, target, scan, pd, hit, range_m
    expected_fa: dict[tuple[str, str], float]  # (radar id, origin) -> per scan
    drawn_fa: dict[str, float]  # origin -> per radar-scan, drawn
    table_s: float
    tables_built: int
    run_wall_s: float
    run_cpu_s: float
    simulated_s: float
    fallbacks: int = 0
    error: str | None = None


#: The fidelity choices each table kind depends on (shipradar.tables.scene decides whether it
#: exists): settings that agree on them share the table, loaded once per command.
TABLE_CHOICES = {"atmosphere": (), "propagation": ("propagation", "pe_grid"),
                 "improvement": ("improvement_grid",), "sea_clutter": (),
                 "weather_clutter": ("atmosphere",), "pfac": ("clutter_fa_model",)}


class TableClock:
    """Times every table a setting reads; a table key seen before in this command keeps the
    time it took then (its build, if it was built here). Tables are kept for the command's
    life, so each distinct table is built or read once (a kind not in
    :data:`TABLE_CHOICES` is keyed on the whole fidelity block)."""

    def __init__(self):
        self.seconds: dict[str, float] = {}
        self.built: set[str] = set()
        self._memo: dict[tuple, tuple[Any, str]] = {}

    def load(self, scenario: Scenario):
        from shipradar.tables.scene import SceneTables, table_specs
        from shipradar.tables.store import cache_path

        scene = SceneTables()
        for _p, r in scenario.radars():
            scene.for_radar(r.id)
        total, built = 0.0, 0
        base = scenario.model_dump_json(exclude={"fidelity"})
        fid = scenario.fidelity.model_dump()
        for spec in table_specs(scenario):
            choices = TABLE_CHOICES.get(spec.kind, tuple(sorted(fid)))
            memo_key = (base, spec.radar_id, spec.kind, tuple(fid[c] for c in choices))
            if memo_key in self._memo:
                table, key = self._memo[memo_key]
                total += self.seconds[key]
                built += key in self.built
                setattr(scene.for_radar(spec.radar_id), spec.kind, table)
                continue
            before = {p.name for p in _cache_files()}
            t0 = time.perf_counter()
            table = spec.make()
            dt = time.perf_counter() - t0
            key = f"{table.name}-{table.key}"
            self._memo[memo_key] = (table, key)
            if key not in self.seconds:
                self.seconds[key] = dt
                if cache_path(table.name, table.key).name not in before:
                    self.built.add(key)
            total += self.seconds[key]
            built += key in self.built
            setattr(scene.for_radar(spec.radar_id), spec.kind, table)
        return scene, total, built


def _cache_files() -> list[Path]:
    from shipradar.tables.store import cache_dir

    d = cache_dir()
    return list(d.glob("*.npz")) if d.is_dir() else []


def run_setting(scenario: Scenario, setting: Setting, seeds: Sequence[int], duration_s: float,
                clock: TableClock, *, crn: bool = True) -> RunResult:
    """Run the scene under one setting, once per seed, with common random numbers.

    ``crn=False`` leaves the detection draw on the engine's sequential stream (for tests:
    then a change in the number of other draws, false alarms for instance, moves the dice
    of every later look)."""
    from shipradar.sim.engine.simulation import Simulation

    scene = with_fidelity(scenario, setting.fidelity)
    tables, table_s, built = clock.load(scene)
    cols: dict[str, list[np.ndarray]] = {k: [] for k in
                                         ("run", "radar", "target", "scan", "pd", "hit",
                                          "range_m")}
    # best of the runs (the usual benchmark reading: the others were slowed by the machine)
    wall = cpu = math.inf
    fa = {"noise": 0.0, "sea_clutter": 0.0}
    scans = 0
    expected: dict[tuple[str, str], float] = {}
    fallbacks = 0
    prepared = None  # the first run's preparation, passed to the next (the same tables)
    for run, seed in enumerate(seeds):
        sim = Simulation(scene, seed=seed, duration_s=duration_s, tables=tables,
                         prepared=prepared)
        prepared = sim.prepared
        for k, proc in enumerate(sim.radars):
            model = proc.model
            period = proc.radar.scan_period_s
            if crn:
                model.look_uniforms = look_uniforms(seed, k, period)
            model.on_look.append(_look_recorder(cols, run, k, period))
            if run == 0:
                expected[(proc.radar.id, "noise")] = float(model.noise_false_alarms_per_scan)
                expected[(proc.radar.id, "sea_clutter")] = _clutter_fa_per_scan(model)
        w0, c0 = time.perf_counter(), time.process_time()
        sim.run()
        wall = min(wall, time.perf_counter() - w0)
        cpu = min(cpu, time.process_time() - c0)
        fa["noise"] += sim.stats.noise_false_alarms
        fa["sea_clutter"] += sim.stats.clutter_false_alarms
        scans += sim.stats.scans
        fallbacks += sim.stats.propagation_fallbacks
    looks = {k: (np.concatenate(v) if v else np.zeros(0)) for k, v in cols.items()}
    n = len(seeds)
    return RunResult(setting, looks, expected,
                     {o: c / max(scans, 1) for o, c in fa.items()}, table_s, built,
                     wall, cpu, duration_s, fallbacks // n)


def _look_recorder(cols: dict[str, list[np.ndarray]], run: int, radar: int,
                   period: float) -> LookObserver:
    """An observer of the dwell model's looks (``DwellModel.on_look``) that appends each
    look's run, radar, target, scan, P_d, detection and slant range to ``cols``."""
    def record(look: LookResults) -> None:
        scan = np.floor((look.time_s + _CROSSING_EPS_S) / period).astype(np.int64)
        cols["run"].append(np.full(look.size, run, dtype=np.int64))
        cols["radar"].append(np.full(look.size, radar, dtype=np.int64))
        cols["target"].append(np.asarray(look.target, dtype=np.int64))
        cols["scan"].append(scan)
        cols["pd"].append(np.asarray(look.pd, dtype=float))
        cols["hit"].append(np.asarray(look.hit, dtype=bool))
        cols["range_m"].append(np.asarray(look.slant_range_m, dtype=float))

    return record


def _clutter_fa_per_scan(model) -> float:
    """The radar's expected sea-clutter false alarms per scan (its P_fac map's, 0 without
    one), from the range profile its preparation keeps for ``meta``."""
    profile = model.prepared.clutter_range_profile
    return 0.0 if profile is None else profile[2]
