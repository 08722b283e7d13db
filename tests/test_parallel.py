"""Tests of shipradar.sim.engine.parallel: radars in worker processes give the single-process
stream, byte for
byte, and the merge replays SimPy's order (the independent oracle: SimPy itself)."""

from __future__ import annotations

import hashlib

import pytest
import simpy
from hypothesis import given, settings
from hypothesis import strategies as st

from shipradar.sim.engine import parallel
from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream.bus import Bus
from shipradar.sim.stream.recording import Recorder
from shipradar.sim.world.scenario import load_scenario
from tests.helpers import ROOT, identical_radars_scene


@settings(max_examples=60, deadline=None)
@given(st.lists(st.lists(st.sampled_from([0.25, 0.5, 0.75, 1.0, 1.0 / 3.0]), min_size=0,
                         max_size=12), min_size=1, max_size=5))
def test_merge_order_is_simpys(steps):
    # processes with arbitrary (often equal) step lengths: SimPy's own order of resumptions
    env = simpy.Environment()
    seen, times = [], {}

    def proc(r, delays):
        times[r] = [env.now]
        seen.append((r, 0))
        for k, d in enumerate(delays, start=1):
            yield env.timeout(d)
            times[r].append(env.now)
            seen.append((r, k))

    for r, delays in enumerate(steps):
        env.process(proc(r, delays))
    env.run()
    assert parallel.merge_order(times) == seen


def test_groups_parent_takes_half_a_share():
    assert parallel.groups(8, 2) == [[0, 1, 2], [3, 4, 5, 6, 7]]
    assert parallel.groups(8, 4) == [[0], [1, 4, 7], [2, 5], [3, 6]]
    assert parallel.groups(2, 8) == [[0], [1]]
    assert parallel.groups(3, 1) == [[0, 1, 2]]
    for r in range(1, 12):
        for n in range(1, 6):
            g = parallel.groups(r, n)
            assert sorted(i for part in g for i in part) == list(range(r))
            assert all(g) and len(g) <= n


def _recording(scenario, tmp_path, name, **kw):
    path = tmp_path / f"{name}.rec"
    bus = Bus(None, Recorder(path))
    summary = Simulation(scenario, bus=bus, **kw).run()
    bus.close()
    return hashlib.sha256(path.read_bytes()).hexdigest(), summary


def _counts(summary):
    return {k: v for k, v in summary.items() if k not in ("wall_s", "realtime_factor", "bus")}


def test_raid_two_processes_byte_identical(tmp_path):
    s = load_scenario(ROOT / "scenarios/raid.yaml")
    one, sum1 = _recording(s, tmp_path, "one", duration_s=40.3, seed=5)
    two, sum2 = _recording(s, tmp_path, "two", duration_s=40.3, seed=5, processes=2)
    assert one == two
    assert _counts(sum1) == _counts(sum2)


def test_identical_radars_tie_order(tmp_path):
    # the tie order is SimPy's (scenario order); also more processes than radars
    s = identical_radars_scene(3)
    one, _ = _recording(s, tmp_path, "one", duration_s=12.0)
    many, _ = _recording(s, tmp_path, "many", duration_s=12.0, processes=4)
    assert one == many


def test_processes_rejected_in_realtime():
    s = load_scenario(ROOT / "scenarios/single_missile.yaml")
    with pytest.raises(ValueError, match="fast mode"):
        Simulation(s, processes=2, realtime=10.0)
    with pytest.raises(ValueError):
        Simulation(s, processes=0)
