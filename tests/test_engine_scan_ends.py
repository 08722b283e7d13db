"""The ends of scan are computed per block of revolutions (``_RadarProcess._scan_end_states``:
states, coverage and last looks of every end of scan of a block at once) and give what one
computation per end of scan gives; a radar alone on the batched path resumes once per
revolution and gives SimPy's recording byte for byte."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream.bus import Bus
from shipradar.sim.stream.recording import Recorder
from shipradar.sim.stream.sink import MemorySink
from shipradar.sim.world.kinematics import LocalFrame, antenna_azimuth
from shipradar.sim.world.scenario import Origin, load_scenario
from tests.helpers import ROOT


def test_antenna_azimuth_of_many_antennas_is_one_call_per_antenna():
    # one antenna row per object (the ends of a block's revolutions) gives, bit for bit, one
    # call per antenna position
    frame = LocalFrame(Origin(lat_deg=44.6, lon_deg=-63.0))
    rng = np.random.default_rng(11)
    ant = np.column_stack([rng.uniform(-40e3, 40e3, (300, 2)), rng.uniform(0.0, 30.0, 300)])
    obj = np.column_stack([rng.uniform(-90e3, 90e3, (300, 2)), rng.uniform(0.0, 9e3, 300)])
    obj[:5] = ant[:5]  # the antenna's own position: zero range
    az, ground = antenna_azimuth(ant, obj, frame)
    for i in range(300):
        az1, ground1 = antenna_azimuth(ant[i], obj[i:i + 1], frame)
        assert az1[0] == az[i]
        assert ground1[0] == ground[i]


@pytest.mark.parametrize("scene, duration", [("raid", 13.7), ("manoeuvres", 21.0)])
def test_truth_targets_per_block_is_one_computation_per_end_of_scan(scene, duration):
    s = load_scenario(ROOT / f"scenarios/{scene}.yaml")
    bus = MemorySink(skip={b"plots"})
    sim = Simulation(s, bus=bus, duration_s=duration, seed=3)
    sim.run()
    radars = {r.radar.id: r for r in sim.radars}
    n = sim.targets.n
    seen = 0
    for topic, t, p in bus.messages:
        if topic != b"truth" or p["kind"] != "targets":
            continue
        seen += 1
        radar = radars[p["sensor"]]
        pos, _ = radar.platform_state(np.array([t]))
        tpos, tvel, tacc, active = sim.targets.state_acc(np.full(n, t), np.arange(n))
        assert p["time_s"] == t
        np.testing.assert_array_equal(p["active"], active)
        assert np.array_equal(p["in_coverage"], radar.in_coverage(pos[0], tpos, active))
        for key, col in (("east_m", tpos[:, 0]), ("up_m", tpos[:, 2]),
                         ("v_north_mps", tvel[:, 1]), ("a_east_mps2", tacc[:, 0])):
            np.testing.assert_array_equal(p[key], np.where(active, col, np.nan))
    assert seen == sum(r.scans_in_run for r in sim.radars)


class _SimPyLoop(Simulation):
    batched = False


def _recording(cls, scenario, path, **kw):
    bus = Bus(None, Recorder(path))
    sim = cls(scenario, bus=bus, **kw)
    summary = sim.run()
    bus.close()
    return hashlib.sha256(path.read_bytes()).hexdigest(), summary["sectors"], sim


@pytest.mark.parametrize("duration", [13.7, 12.0])
def test_a_radar_alone_resumes_per_revolution_with_simpys_bytes(tmp_path, duration):
    # 13.7 s ends inside a revolution, 12 s at the end of one
    s = load_scenario(ROOT / "scenarios/single_missile.yaml")
    fast, sectors_fast, sim = _recording(Simulation, s, tmp_path / "fast.rec",
                                         duration_s=duration, seed=3)
    assert sim.batched and len(sim.radars) == 1
    slow, sectors_slow, sim = _recording(_SimPyLoop, s, tmp_path / "slow.rec",
                                         duration_s=duration, seed=3)
    assert not sim.batched
    assert (fast, sectors_fast) == (slow, sectors_slow)
