"""A radar alone under SimPy's loop resumes only where it has something to send: at the ends of
the sectors that send a message and of its revolutions (a wall clock, in-process sinks), or,
in fast mode with the stream's own Bus (a publisher), at the ends of its revolutions
(tests/test_engine_lone_publisher.py); either way the publisher gets the recording's frames,
in the same order, and the counts are the same."""

from __future__ import annotations

import pytest

from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream.bus import Bus
from shipradar.sim.stream.recording import Recorder, read_recording
from shipradar.sim.world.scenario import load_scenario
from tests.helpers import ROOT, KeepingPublisher


@pytest.mark.parametrize("duration", [13.7, 12.0])
def test_a_radar_alone_under_simpy_publishes_the_recordings_frames(tmp_path, duration):
    s = load_scenario(ROOT / "scenarios/single_missile.yaml")
    pub = KeepingPublisher()
    live = Simulation(s, bus=Bus(publisher=pub), duration_s=duration,  # type: ignore[arg-type]
                      seed=3)
    assert not live.batched and len(live.radars) == 1
    summary_live = live.run()
    path = tmp_path / "r.rec"
    bus = Bus(None, Recorder(path))
    rec = Simulation(s, bus=bus, duration_s=duration, seed=3)
    assert rec.batched
    summary_rec = rec.run()
    bus.close()
    with read_recording(path) as reader:
        recorded = [(bytes(frames[0]), bytes(frames[1])) for _, frames in reader]
    assert pub.sent == recorded
    for key in ("sectors", "scans", "target_plots", "clutter_false_alarms"):
        assert summary_live[key] == summary_rec[key]
