"""The batched fast path (``Simulation._run_batched``: no SimPy event per sector, a scan's
records written at once) gives the SimPy path's recording byte for byte; ``write_many`` gives
the records of one ``write`` per message."""

from __future__ import annotations

import hashlib
import os
import random

import pytest

from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream.bus import Bus
from shipradar.sim.stream.recording import MAX_RECORD_BYTES, Recorder, RecordingError
from shipradar.sim.world.scenario import load_scenario
from tests.helpers import ROOT, identical_radars_scene


class _SimPyLoop(Simulation):
    """The same run under SimPy's event loop (as with a publisher or in real time)."""

    batched = False


def _run(cls, scenario, path, compress="none", **kw):
    bus = Bus(None, Recorder(path, compress=compress))
    sim = cls(scenario, bus=bus, **kw)
    summary = sim.run()
    bus.close()
    return hashlib.sha256(path.read_bytes()).hexdigest(), summary, sim


def _counts(summary):
    out = {k: v for k, v in summary.items() if k not in ("wall_s", "realtime_factor", "bus")}
    bus = dict(summary["bus"])
    bus["recorder"] = {k: v for k, v in bus["recorder"].items() if k != "path"}
    return out, bus


@pytest.mark.parametrize("duration, compress", [(20.0, "none"), (13.7, "zstd")])
def test_raid_batched_is_the_simpy_recording(tmp_path, duration, compress):
    # two radars of different periods; 13.7 s ends inside a revolution of both
    s = load_scenario(ROOT / "scenarios/raid.yaml")
    fast, sum_fast, sim = _run(Simulation, s, tmp_path / "fast.rec", compress,
                               duration_s=duration, seed=3)
    assert sim.batched
    slow, sum_slow, sim = _run(_SimPyLoop, s, tmp_path / "slow.rec", compress,
                               duration_s=duration, seed=3)
    assert not sim.batched
    assert fast == slow
    assert _counts(sum_fast) == _counts(sum_slow)


def test_identical_radars_keep_simpys_tie_order(tmp_path):
    s = identical_radars_scene(3)
    fast, _, _ = _run(Simulation, s, tmp_path / "fast.rec", duration_s=9.0)
    slow, _, _ = _run(_SimPyLoop, s, tmp_path / "slow.rec", duration_s=9.0)
    assert fast == slow


def test_batched_only_without_a_live_consumer():
    s = load_scenario(ROOT / "scenarios/single_missile.yaml")
    assert Simulation(s, duration_s=1.0).batched  # no bus
    assert not Simulation(s, duration_s=1.0, realtime=10.0).batched

    class Publisher:
        def send(self, frames):
            pass

    assert not Simulation(s, bus=Bus(Publisher()), duration_s=1.0).batched
    # the path follows the bus's declared capabilities (shipradar.sim.stream.sink), not its
    # class: a subclass inherits them, and one that declines batches is not batched
    assert Simulation(s, bus=type("Sub", (Bus,), {})(None), duration_s=1.0).batched
    per_frame = type("PerFrame", (Bus,), {"accepts_batches": False})(None)
    assert not Simulation(s, bus=per_frame, duration_s=1.0).batched
    assert Simulation(s, bus=per_frame, duration_s=1.0).encodes_ahead
    per_payload = type("PerPayload", (Bus,), {"encodes_ahead": False})(None)
    assert not Simulation(s, bus=per_payload, duration_s=1.0).batched
    assert not Simulation(s, bus=per_payload, duration_s=1.0).encodes_ahead


class _PayloadBus(Bus):
    """A recording bus that takes payloads: the engine's dict path (what in-process sinks
    get), encoded by ``Bus.emit``."""

    encodes_ahead = False


@pytest.mark.parametrize(("scene", "duration_s"), [
    ("raid", 13.7), ("manoeuvres", 21.0), ("single_missile", 12.3)])
def test_payload_path_is_the_frame_path(tmp_path, scene, duration_s):
    # both output paths frame their sectors with shipradar.sim.stream.framing.sector_columns:
    # the payloads, encoded one by one, are the bodies encoded at once; and the ends of scan
    # (eos, the next meta's antenna state: payloads per end against protocol.float_rows for
    # a block); each duration ends inside a revolution (eos "complete" false), the
    # manoeuvres' ship turns
    s = load_scenario(ROOT / f"scenarios/{scene}.yaml")

    def run(bus_cls, path):
        bus = bus_cls(None, Recorder(path))
        sim = Simulation(s, bus=bus, duration_s=duration_s, seed=3)
        assert sim.encodes_ahead is (bus_cls is Bus)
        sim.run()
        bus.close()
        return path.read_bytes()

    assert run(_PayloadBus, tmp_path / "payloads.rec") == run(Bus, tmp_path / "frames.rec")


def test_batched_without_a_bus_counts_the_same():
    s = load_scenario(ROOT / "scenarios/raid.yaml")
    a = Simulation(s, duration_s=10.0, seed=2).run()
    b = _SimPyLoop(s, duration_s=10.0, seed=2).run()
    for k in ("wall_s", "realtime_factor"):
        a.pop(k), b.pop(k)
    assert a == b


@pytest.mark.parametrize("compress", ["none", "zstd"])
def test_write_many_is_write_per_message(tmp_path, compress):
    rnd = random.Random(4)
    records = [(rnd.random() * 100.0, [rnd.choice([b"plots", b"truth", b"eos"]),
                                       os.urandom(rnd.choice([0, 3, 200, 5000]))])
               for _ in range(500)]
    records.insert(7, (1.5, [b"a", b"b", b"c"]))  # not a two-frame message
    one, many = Recorder(tmp_path / "one", compress=compress, buffer_bytes=50_000), Recorder(
        tmp_path / "many", compress=compress, buffer_bytes=50_000)
    for t, frames in records:
        one.write(t, frames)
    for i in range(0, len(records), 37):
        many.write_many(records[i:i + 37])
    many.write_many([])
    for attr in ("records", "bytes_written", "raw_payload_bytes", "stored_payload_bytes"):
        assert getattr(one, attr) == getattr(many, attr)
    one.close()
    many.close()
    assert (tmp_path / "one").read_bytes() == (tmp_path / "many").read_bytes()


def test_write_many_stops_at_an_oversized_record(tmp_path):
    rec = Recorder(tmp_path / "r")
    big = b"x" * MAX_RECORD_BYTES
    with pytest.raises(RecordingError, match="exceeds"):
        rec.write_many([(0.0, [b"plots", b"ok"]), (1.0, [b"plots", big]), (2.0, [b"eos", b""])])
    assert rec.records == 1  # the record before it is kept, nothing after it
    rec.write(3.0, [b"eos", b"again"])
    rec.close()
    ref = Recorder(tmp_path / "ref")
    ref.write(0.0, [b"plots", b"ok"])
    ref.write(3.0, [b"eos", b"again"])
    ref.close()
    assert (tmp_path / "r").read_bytes() == (tmp_path / "ref").read_bytes()


def test_emit_many_counts_as_emit_frames(tmp_path):
    msgs = [(0.5, [b"plots", b"abc"]), (0.5, [b"truth", b"de"]), (1.0, [b"eos", b""])]
    a, b = Bus(None, Recorder(tmp_path / "a")), Bus(None, Recorder(tmp_path / "b"))
    for t, frames in msgs:
        a.emit_frames(t, frames)
    b.emit_many(msgs)
    sa, sb = a.stats, b.stats
    for st in (sa, sb):
        st["recorder"].pop("path")
    assert sa == sb and a.t_last == b.t_last == 1.0
    a.close()
    b.close()
    assert (tmp_path / "a").read_bytes() == (tmp_path / "b").read_bytes()


@pytest.mark.parametrize("compress", ["none", "zstd"])
def test_emit_many_counts_as_emit_frames_in_every_path(tmp_path, compress):
    """The bus's counters after ``emit_many`` (the bytes from the recorder's compiled framing
    when every message is [topic, body], counted by the bus otherwise) equal one
    ``emit_frames`` per message."""
    rnd = random.Random(5)
    records = [(rnd.random() * 100.0, [rnd.choice([b"plots", b"truth", b"eos"]),
                                       os.urandom(rnd.choice([0, 3, 200, 5000]))])
               for _ in range(300)]
    batches = [records[i:i + 37] for i in range(0, len(records), 37)]
    batches[3] = [*batches[3], (1.5, [b"a", b"b", b"c"])]  # not a two-frame message
    batches[5] = [(t, [bytearray(a), b]) for t, (a, b) in batches[5]]  # topics not bytes
    one = Bus(None, Recorder(tmp_path / "one", compress=compress))
    many = Bus(None, Recorder(tmp_path / "many", compress=compress))
    bare = Bus(None, None)
    for batch in batches:
        for t, frames in batch:
            one.emit_frames(t, frames)
        many.emit_many(batch)
        bare.emit_many(batch)
    a, b, c = one.stats, many.stats, bare.stats
    assert a["recorder"].pop("path") != b["recorder"].pop("path")
    assert a == b
    assert {k: v for k, v in a.items() if k != "recorder"} == {
        k: v for k, v in c.items() if k != "recorder"}
    one.close()
    many.close()
