"""A radar alone in fast mode with the stream's own bus (a publisher) resumes once per
revolution, its sectors' messages sent in order at the revolution's end (as on the batched
path): the publisher gets the recording's frames and the counts are the same; a wall clock
and in-process sinks keep a resumption per message sector (they can see the clock)."""

from __future__ import annotations

import pytest

from shipradar.sim.engine import simulation as engine
from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream.bus import Bus
from shipradar.sim.stream.recording import Recorder, read_recording
from shipradar.sim.world.scenario import load_scenario
from tests.helpers import ROOT, KeepingPublisher


def _count_resumptions(monkeypatch):
    """Count the radar process's resumptions (its timeouts)."""
    seen = []
    run = engine.RadarProcess.run

    def counted(self, env, per_sector=True):
        gen = run(self, env, per_sector)
        value = None
        while True:
            try:
                event = gen.send(value)
            except StopIteration:
                return
            seen.append(event)
            value = yield event

    monkeypatch.setattr(engine.RadarProcess, "run", counted)
    return seen


@pytest.mark.parametrize("duration", [13.7, 12.0, 30.0])
def test_a_lone_publisher_radar_resumes_per_revolution_with_the_recordings_frames(
        tmp_path, monkeypatch, duration):
    s = load_scenario(ROOT / "scenarios/single_missile.yaml")
    path = tmp_path / "r.rec"
    bus = Bus(None, Recorder(path))
    summary_rec = Simulation(s, bus=bus, duration_s=duration, seed=5).run()
    bus.close()
    with read_recording(path) as reader:
        recorded = [(bytes(frames[0]), bytes(frames[1])) for _, frames in reader]
    seen = _count_resumptions(monkeypatch)
    pub = KeepingPublisher()
    live = Simulation(s, bus=Bus(publisher=pub), duration_s=duration,  # type: ignore[arg-type]
                      seed=5)
    assert not live.batched
    summary_live = live.run()
    assert pub.sent == recorded
    for key in ("sectors", "scans", "target_plots", "clutter_false_alarms"):
        assert summary_live[key] == summary_rec[key]
    assert len(seen) == summary_live["scans"]  # one resumption per revolution


def test_an_in_process_sink_keeps_a_resumption_per_message_sector(monkeypatch):
    s = load_scenario(ROOT / "scenarios/single_missile.yaml")
    seen = _count_resumptions(monkeypatch)
    got = []

    class Sink:
        def emit(self, topic, t_sim, payload):
            got.append(topic)

        def flush(self, fsync=False):
            pass

    sim = Simulation(s, bus=Sink(), duration_s=12.0, seed=5)  # type: ignore[arg-type]
    summary = sim.run()
    assert len(seen) > summary["scans"]
    assert got
