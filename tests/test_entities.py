"""Live entities (``shipradar run --entities``): the checks on fed states, dead reckoning,
a ZeroMQ feed from another process, the recording of what a run used, and its re-simulation."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream import protocol
from shipradar.sim.stream.bus import Bus
from shipradar.sim.stream.entities import EntityFeed, RecordedEntities
from shipradar.sim.stream.recording import Recorder, read_recording
from shipradar.sim.world.live import MACH_30_MPS, LiveTargets, check_states
from shipradar.sim.world.scenario import parse_scenario

from .helpers import CaptureBus, free_port, quiet_radar


def _scene(**over) -> dict:
    d = {"name": "live", "duration_s": 4.0, "seed": 3,
         "origin": {"lat_deg": 44.6, "lon_deg": -63.0},
         "platforms": [{"id": "ship", "waypoints": [{"east_m": 0, "north_m": 0}],
                        "radars": [quiet_radar()]}],
         "entity_types": [{"match": "ship*", "kind": "ship",
                           "rcs": {"type": "constant", "sigma_m2": 1000.0}},
                          {"match": "missile", "kind": "missile",
                           "rcs": {"type": "constant", "sigma_m2": 0.1}}],
         "fidelity": {"propagation": "free_space", "atmosphere": False, "clutter": False}}
    d.update(over)
    return d


def _rows(ids, t, pos, vel, **extra) -> dict:
    pos, vel = np.atleast_2d(pos).astype(float), np.atleast_2d(vel).astype(float)
    out = {"id": list(ids), "time_s": np.asarray(t, float),
           "east_m": pos[:, 0], "north_m": pos[:, 1], "up_m": pos[:, 2],
           "v_east_mps": vel[:, 0], "v_north_mps": vel[:, 1], "v_up_mps": vel[:, 2]}
    out.update(extra)
    return out


# ------------------------------------------------------------------ checks and motion
def test_bad_states_are_counted_by_reason_and_never_raise():
    bad: dict[str, int] = {}
    p = _rows(["a", "b", "c", "d", "", "f"], [1.0] * 6,
              [[0, 1e4, 10], [np.nan, 0, 0], [0, 0, -7e6], [0, 0, 0], [0, 0, 0], [3e6, 0, 0]],
              [[10, 0, 0], [0, 0, 0], [0, 0, 0], [MACH_30_MPS * 1.01, 0, 0], [0, 0, 0],
               [0, 0, 0]])
    rows = check_states(p, bad)
    assert rows is not None and rows["id"] == ["a"]
    assert bad == {"not finite": 1, "inside the earth": 1, "faster than Mach 30": 1,
                   "bad id": 1, "beyond the frame": 1}
    assert check_states({"id": ["a"], "time_s": [1.0, 2.0]}, bad) is None
    assert check_states({"nothing": 1}, bad) is None
    assert bad["no id column"] == 1


def test_dead_reckoning_out_of_order_leaving_and_timeout():
    live = LiveTargets(parse_scenario(_scene()))
    live.apply(check_states(_rows(["s1", "m"], [1.0, 1.0], [[1000, 0, 0], [0, 5e3, 5]],
                                  [[0, 10, 0], [0, -300, 0]], type=["ship A", "missile"],
                                  name=["Alpha", None]), live.bad), now=1.0)
    assert live.ids == ["s1", "m"] and live.names == ["Alpha", "m"]
    assert live.kinds == ["ship", "missile"] and list(live.swerling) == [1, 3]
    assert live.rcs[0].sigma_m2 == 1000.0 and live.rcs[1].sigma_m2 == 0.1
    pos, vel, act = live.state(np.array([3.5, 3.5]), np.array([0, 1]))
    assert pos[0] == pytest.approx([1000, 25, 0]) and pos[1] == pytest.approx([0, 4250, 5])
    assert act.all()
    # a newer state moves the entity; an older one (out of order) is ignored
    live.apply(check_states(_rows(["s1"], [2.0], [[1000, 30, 0]], [[0, 10, 0]]), live.bad), 2.0)
    live.apply(check_states(_rows(["s1"], [1.5], [[0, 0, 0]], [[0, 0, 0]]), live.bad), 2.0)
    assert live.bad == {"out_of_order": 1}
    pos, _, _ = live.state(np.array([4.0]), np.array([0]))
    assert pos[0] == pytest.approx([1000, 50, 0])
    # leaving: active false; the other times out 12 s after its last state
    live.apply(check_states(_rows(["s1"], [5.0], [[1000, 60, 0]], [[0, 10, 0]],
                                  active=[False]), live.bad), 5.0)
    _, _, act = live.state(np.array([4.9, 5.1, 12.9, 13.1]), np.array([0, 0, 1, 1]))
    assert act.tolist() == [True, False, True, False]
    assert live.t_last == pytest.approx([5.0, 13.0])


def test_a_state_below_the_sea_is_seen_at_the_surface_and_runs():
    """A ship reported 3 m below the ellipsoid and a dead-reckoned dive: height 0, and a
    run through the two-ray model (which refuses negative heights) goes on."""
    scenario = parse_scenario(_scene(fidelity={"propagation": "two_ray", "atmosphere": False,
                                               "clutter": False}))
    live = LiveTargets(scenario)
    live.apply(check_states(_rows(["s", "d"], [0.0, 0.0], [[0, 8e3, -3.0], [2e3, 8e3, 50.0]],
                                  [[0, 5, 0], [0, 0, -20.0]]), live.bad), 0.0)
    pos, _, _ = live.state(np.array([1.0, 5.0]), np.array([0, 1]))
    assert pos[:, 2].tolist() == [0.0, 0.0]

    class Once:
        endpoint = "test"

        def __init__(self):
            self.rows = [_rows(["s", "d"], [0.0, 0.0], [[0, 8e3, -3.0], [2e3, 8e3, 50.0]],
                               [[0, 5, 0], [0, 0, -20.0]])]

        def drain(self, now):
            out, self.rows = self.rows, []
            return out

        def stats(self):
            return {}

    summary = Simulation(scenario, entities=Once()).run()
    assert summary["live"]["entities"] == 2 and summary["dwells"] >= 6


def test_an_unmapped_type_gets_the_stated_default():
    live = LiveTargets(parse_scenario(_scene()))
    live.apply(check_states(_rows(["x"], [0.0], [[0, 1e4, 0]], [[0, 0, 0]],
                                  type=["tank"]), live.bad), 0.0)
    assert live.rcs[0].sigma_m2 == 10.0 and live.swerling[0] == 1 and live.kinds == ["other"]


def _reference_apply(known: dict, ids, times, values, active):
    """Row-by-row model of the update rule (docs/external.md): in order, a row applies when
    its time is later than its entity's latest; an entity keeps its last applied row."""
    applied, late = [], 0
    for i, (eid, t) in enumerate(zip(ids, times, strict=True)):
        if eid in known and t <= known[eid][0]:
            late += 1
            continue
        known[eid] = (t, values[i], active[i])
        applied.append(i)
    return applied, late


@settings(max_examples=60, deadline=None)
@given(st.lists(st.lists(st.tuples(st.integers(0, 5), st.integers(-3, 6), st.booleans()),
                         min_size=1, max_size=25), min_size=1, max_size=4))
def test_vectorized_apply_is_the_row_by_row_rule(batches):
    """Batches with repeated entities, equal and falling times (Hypothesis): the vectorized
    :meth:`LiveTargets.apply` applies exactly the rows, and leaves exactly the states, of a
    row-by-row loop over the rule."""
    live = LiveTargets(parse_scenario(_scene()))
    known: dict = {}
    late_total = 0
    for k, batch in enumerate(batches):
        ids = [f"e{e}" for e, _, _ in batch]
        times = [float(t) for _, t, _ in batch]
        east = [1000.0 * k + i for i in range(len(batch))]  # which row a state came from
        active = [a for _, _, a in batch]
        applied, late = _reference_apply(known, ids, times, east, active)
        late_total += late
        rows = check_states(_rows(ids, times, [[e, 5e3, 0] for e in east],
                                  [[0, 0, 0]] * len(batch), active=active), live.bad)
        got = live.apply(rows, now=0.0)
        assert got["id"] == [ids[i] for i in applied]
        assert got["east_m"].tolist() == [east[i] for i in applied]
    assert live.bad.get("out_of_order", 0) == late_total
    assert sorted(live.ids) == sorted(known)
    for eid, (t, e, act) in known.items():
        r = live.ids.index(eid)
        assert live._t_u[r] == t and live._p[r, 0] == e
        assert live._t_end[r] == (np.inf if act else t)


# ------------------------------------------------------------------ a feed in another process
SENDER = textwrap.dedent("""
    import sys, time, math
    import msgpack, zmq
    port, seconds = int(sys.argv[1]), float(sys.argv[2])
    ctx = zmq.Context()
    pub = ctx.socket(zmq.PUB)
    pub.bind(f"tcp://127.0.0.1:{port}")
    t0 = time.monotonic()
    k = 0
    while time.monotonic() - t0 < seconds:
        # plain msgpack lists (no shipradar, no numpy): time_s NaN = when received
        body = {"v": 2, "t": 0.0, "source": "test",
                "id": ["ship-1", "missile-1", "bad"],
                "time_s": [float("nan")] * 3,
                "east_m": [3000.0, -2000.0, 0.0], "north_m": [8000.0, 9000.0, 0.0],
                "up_m": [0.0, 10.0, -9.0e6],
                "v_east_mps": [0.0, 250.0, 0.0], "v_north_mps": [5.0, 0.0, 0.0],
                "v_up_mps": [0.0, 0.0, 0.0], "type": ["ship", "missile", "x"],
                "name": ["Alpha", "Vampire", "junk"]}
        pub.send_multipart([b"entities", msgpack.packb(body)])
        pub.send_multipart([b"entities", b"\\x00garbage"])
        k += 1
        time.sleep(0.1)
    pub.close(0)
    ctx.term()
""")


@pytest.fixture
def feed():
    port = free_port()
    proc = subprocess.Popen([sys.executable, "-c", SENDER, str(port), "20"])
    src = EntityFeed(f"tcp://127.0.0.1:{port}", queue_size=1000)
    try:
        assert src.first_message.wait(15.0), "the sender never reached us"
        yield src
    finally:
        src.close()
        proc.kill()
        proc.wait(10)


@pytest.mark.slow
def test_live_feed_paced_recorded_and_resimulated(feed, tmp_path):
    """A feed from another process: entities become targets (ids appended to meta), bad rows
    are counted, the run keeps the wall clock's pace, and the recording's entities re-run in
    fast mode with another seed give the same target motion in truth[targets]."""
    scenario = parse_scenario(_scene())
    rec = tmp_path / "live.rec"
    with Bus(None, Recorder(rec)) as bus:
        sim = Simulation(scenario, bus=bus, realtime=1.0, entities=feed)
        summary = sim.run()
    assert summary["realtime_factor"] == pytest.approx(1.0, abs=0.15)
    live = summary["live"]
    assert live["entities"] == 2 and live["updates"] >= 20
    assert live["bad"]["inside the earth"] >= 20
    assert live["source"]["bad_messages"]["undecodable message"] >= 20
    assert summary["target_plots"] >= 3  # the 1000 m² ship at 8.5 km, every scan
    frames = [protocol.decode(f) for _, f in read_recording(rec)]
    metas = [p for top, _, p in frames if top == protocol.TOPIC_META]
    assert metas[-1]["target_ids"] == ["ship-1", "missile-1"]
    assert metas[-1]["target_names"] == ["Alpha", "Vampire"]
    assert all(m["target_ids"] == metas[-1]["target_ids"][:len(m["target_ids"])]
               for m in metas)
    assert any(top == protocol.TOPIC_ENTITIES for top, _, _ in frames)

    def states(frames):
        return [(t, p["east_m"], p["north_m"], p["active"]) for top, t, p in frames
                if top == protocol.TOPIC_TRUTH and p["kind"] == "targets"]

    bus2 = CaptureBus()
    sim2 = Simulation(scenario, bus=bus2, seed=99, entities=RecordedEntities(rec))
    again = sim2.run()
    assert again["live"]["entities"] == 2 and again["live"]["updates"] == live["updates"]
    a, b = states(frames), states(bus2.messages)
    assert len(a) == len(b) >= 3
    for x, y in zip(a, b, strict=True):
        assert x[0] == y[0]
        assert np.array_equal(x[3], y[3])
        assert np.allclose(x[1], y[1], equal_nan=True) and np.allclose(x[2], y[2],
                                                                        equal_nan=True)


# ------------------------------------------------------------------ the command line
def _cli(*argv, timeout=120):
    return subprocess.run([sys.executable, "-m", "shipradar.sim.cli", *argv],
                          capture_output=True, text=True, timeout=timeout)


@pytest.mark.parametrize("extra, words", [
    (["--entities", "tcp://127.0.0.1:1", "--realtime", "2"], ["--realtime 1", "got"]),
    (["--entities", "nowhere.rec"], ["neither a recording file nor"]),
])
def test_cli_refusals(tmp_path, extra, words):
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(_scene()))
    proc = _cli("run", str(path), "--quiet", *extra)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().count("\n") == 0
    for w in words:
        assert w in proc.stderr


def test_cli_refuses_own_targets_with_a_live_source(tmp_path):
    d = _scene(targets=[{"id": "t", "rcs": {"type": "constant", "sigma_m2": 1},
                         "waypoints": [{"east_m": 0, "north_m": 5000}]}])
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(d))
    rec = tmp_path / "x.rec"
    rec.write_bytes(b"")
    proc = _cli("run", str(path), "--quiet", "--entities", str(rec), "--realtime", "1")
    assert proc.returncode == 2 and "--entities" in proc.stderr


def test_cli_resimulates_a_recording_in_fast_mode(tmp_path):
    """A recording's entities (written here by a run fed in-process) re-run from the command
    line with another seed: exit 0, the live summary, fast."""
    scenario = parse_scenario(_scene())
    rec = tmp_path / "fed.rec"

    class Fixed:
        endpoint = "test"

        def __init__(self):
            self.sent = False

        def drain(self, now):
            if self.sent:
                return []
            self.sent = True
            return [_rows(["ship-1"], [0.0], [[3000, 8000, 0]], [[0, 5, 0]], type=["ship"])]

        def stats(self):
            return {}

        def close(self):
            pass

    with Bus(None, Recorder(rec)) as bus:
        Simulation(scenario, bus=bus, entities=Fixed()).run()
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(_scene()))
    proc = _cli("run", str(path), "--quiet", "--entities", str(rec), "--seed", "5")
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    assert summary["live"]["entities"] == 1 and summary["target_plots"] >= 3


def test_truth_flags_targets_outside_the_envelope():
    """``truth[targets].outside_envelope``: true where an active entity is above
    ``external.max_altitude_m`` or farther than ``max_range_m`` from the origin (computed here
    from the dead-reckoned positions), false elsewhere and for inactive ones; the summary
    counts the updates outside. Without a live source the key is absent."""
    ext = {"max_altitude_m": 500.0, "max_range_m": 20_000.0}
    scenario = parse_scenario(_scene(external=ext))

    class Once:
        endpoint = "test"

        def __init__(self):
            # low and near (inside); high (800 m); far (25 km); climbing from 200 m at
            # 100 m/s, out through 500 m at t = 3 s
            self.rows = [_rows(["in", "high", "far", "climb"], [0.0] * 4,
                               [[0, 8e3, 10], [0, 9e3, 800], [0, 25e3, 0], [3e3, 8e3, 200]],
                               [[0, 5, 0], [0, 0, 0], [0, 0, 0], [0, 0, 100.0]])]

        def drain(self, now):
            out, self.rows = self.rows, []
            return out

        def stats(self):
            return {}

    bus = CaptureBus()
    summary = Simulation(scenario, bus=bus, entities=Once()).run()
    assert summary["live"]["outside_envelope"] == 2  # high and far at their one update
    truth = [(t, p) for top, t, p in bus.messages
             if top == protocol.TOPIC_TRUTH and p["kind"] == "targets"]
    assert len(truth) >= 3
    for _, p in truth:
        up = np.asarray(p["up_m"])
        ground = np.hypot(p["east_m"], p["north_m"])
        want = np.asarray(p["active"]) & ((up > ext["max_altitude_m"])
                                          | (ground > ext["max_range_m"]))
        assert np.asarray(p["outside_envelope"]).tolist() == want.tolist()
        assert list(p["outside_envelope"][:3]) == [False, True, True]
        assert p["outside_envelope"][3] == (200 + 100 * p["time_s"] > 500)
    assert {bool(p["outside_envelope"][3]) for _, p in truth} == {False, True}
    # the run's own targets (no live source): no such key
    d = _scene(targets=[{"id": "t", "rcs": {"type": "constant", "sigma_m2": 1},
                         "waypoints": [{"east_m": 0, "north_m": 5000}]}])
    bus = CaptureBus()
    Simulation(parse_scenario(d), bus=bus).run()
    assert all("outside_envelope" not in p for top, _, p in bus.messages
               if top == protocol.TOPIC_TRUTH and p["kind"] == "targets")


# ------------------------------------------------------------------ evaluate on a live session
def _growing_recording(tmp_path):
    """A scene with no targets of its own and the recording of a run fed in-process: a ship
    from t = 0 and a second from t = 2.5 s (the target list grows)."""
    d = _scene(duration_s=6.0)
    path = tmp_path / "live.yaml"
    path.write_text(yaml.safe_dump(d))
    rec = tmp_path / "live.rec"

    class Two:
        endpoint = "test"

        def __init__(self):
            self.sent = 0

        def drain(self, now):
            out = []
            if self.sent == 0:
                out.append(_rows(["ship-1"], [0.0], [[3000, 8000, 0]], [[0, 5, 0]],
                                 type=["ship"]))
                self.sent = 1
            if self.sent == 1 and now >= 2.5:
                out.append(_rows(["ship-2"], [now], [[-4000, 9000, 0]], [[3, 0, 0]],
                                 type=["ship"]))
                self.sent = 2
            return out

        def stats(self):
            return {}

    with Bus(None, Recorder(rec)) as bus:
        Simulation(parse_scenario(d), bus=bus, entities=Two()).run()
    return path, rec


@pytest.mark.slow
def test_evaluate_scores_a_tracker_on_an_entities_recording(tmp_path):
    """``shipradar evaluate --entities RECORDING``: the harness runs the scene with the
    recording's entities moving the targets (another seed), the oracle tracker (which
    publishes the truth) scores GOSPA 0 and SIAP completeness 1 with both ships counted,
    the second one only from its first state on."""
    from shipradar.sim.studies.evaluate.data import load_run
    from shipradar.sim.studies.evaluate.metrics import score_run
    from shipradar.sim.studies.evaluate.runner import RunSpec, run_tracker_command

    from .helpers import ROOT

    path, rec = _growing_recording(tmp_path)
    trackers = ROOT / "tests" / "evaluate_trackers.py"
    spec = RunSpec(str(path), 11, str(tmp_path / "run"),
                   f"{sys.executable} {trackers} oracle {{plots}} {{tracks}}",
                   entities=str(rec), realtime=3.0)  # paced: a 30 ms run would end before
    # the harness's tracks subscription has joined the oracle's freshly bound publisher
    info = run_tracker_command(spec)
    assert info["status"] == "ok", info
    assert info["summary"]["live"]["entities"] == 2
    data = load_run(spec.run_dir)
    assert data.target_ids == ["ship-1", "ship-2"]
    assert data.truth_active[0].tolist() == [True, False]
    assert data.truth_active[-1].tolist() == [True, True]
    s = score_run(data)
    assert s.run["gospa"] == 0.0 and s.run["siap_completeness"] == 1.0


def test_evaluate_cli_refuses_a_recording_without_entities(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(_scene()))
    rec = tmp_path / "empty.rec"
    with Recorder(rec):
        pass
    proc = _cli("evaluate", str(path), "--tracker", "x {plots} {tracks}", "--entities",
                str(rec), "--quiet")
    assert proc.returncode == 2, proc.stderr
    assert "no entities topic" in proc.stderr and proc.stderr.strip().count("\n") == 0
