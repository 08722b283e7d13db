"""The stream as a tracker writer needs it (issue 25, items 1, 3, 4, 5, 8, 10): the antenna's
state in ``meta``, the clutter false-alarm density per cell, per-radar truth, truth at the
plot's time, ``eos.complete``, the ``end`` message, and schema version 2 beside 1."""

from __future__ import annotations

import math

import msgpack
import numpy as np
import pytest

from shipradar.sim.engine.simulation import ORIGIN_SEA_CLUTTER, ORIGIN_TARGET, Simulation
from shipradar.sim.stream import protocol
from shipradar.sim.world.scenario import parse_scenario
from shipradar.tables.scene import SceneTables

from .helpers import CaptureBus, quiet_radar
from .test_clutter_false_alarms import clutter_scene


def _target(tid, east, north, alt, t0=0.0, t1=1000.0, ve=0.0, vn=0.0, sigma=5.0):
    return {"id": tid, "waypoints": [
        {"time_s": t0, "east_m": east, "north_m": north, "altitude_m": alt},
        {"time_s": t1, "east_m": east + ve * (t1 - t0), "north_m": north + vn * (t1 - t0),
         "altitude_m": alt}],
        "rcs": {"type": "constant", "sigma_m2": sigma}, "swerling": 1}


def _scene(targets, duration_s=10.0, ship_speed=0.0, seed=3, **radar_over):
    """A free-space C-band radar on a ship steaming north at ``ship_speed`` [m/s]."""
    return parse_scenario({
        "name": "trackers", "duration_s": duration_s, "seed": seed,
        "origin": {"lat_deg": 44.6, "lon_deg": -63.0},
        "platforms": [{"id": "ship", "waypoints": [
            {"time_s": 0, "east_m": 0, "north_m": 0},
            {"time_s": 3600, "east_m": 0, "north_m": ship_speed * 3600}],
            "radars": [quiet_radar(**radar_over)]}],
        "targets": targets,
        "fidelity": {"propagation": "free_space", "atmosphere": False, "clutter": False},
    })


def _run(s, **kw):
    bus = CaptureBus()
    sim = Simulation(s, bus=bus, tables=SceneTables(), **kw)
    sim.run()
    return sim, bus


def _truth(bus, kind):
    return [(t, p) for t, p in bus.of(protocol.TOPIC_TRUTH) if p["kind"] == kind]


# ------------------------------------------------------------------ item 1: meta
def test_meta_carries_the_antenna_state_at_the_scan_start():
    s = _scene([], duration_s=6.0, ship_speed=8.0)
    _, bus = _run(s)
    metas, eos = bus.of(protocol.TOPIC_META), bus.of(protocol.TOPIC_EOS)
    assert [p["scan"] for _, p in metas] == list(range(6))
    for t, m in metas:
        # the ship steams north at 8 m/s from the origin: at t it is 8 t north
        assert m["position"]["north_m"] == pytest.approx(8.0 * t, abs=1e-6)
        assert m["position"]["east_m"] == pytest.approx(0.0, abs=1e-6)
        assert m["position"]["up_m"] == m["position"]["alt_m"] == 20.0
        assert m["velocity_enu_mps"] == pytest.approx([0.0, 8.0, 0.0], abs=1e-9)
        assert m["heading_deg"] == pytest.approx(0.0, abs=1e-9)
        assert m["sector_s"] == pytest.approx(m["scan_period_s"] / m["sectors_per_scan"],
                                              rel=1e-15)
    # the start of scan s is the end of scan s - 1: the same numbers
    for (_, m), (_, e) in zip(metas[1:], eos[:-1], strict=True):
        assert m["position"] == e["position"]
        assert m["velocity_enu_mps"] == e["velocity_enu_mps"]
        assert m["heading_deg"] == e["heading_deg"]


def test_meta_position_places_a_plot_as_it_arrives():
    """Antenna at a plot's time = meta position + velocity x (time_s - t): a tracker places
    the plot without waiting for eos (checked against the end-of-scan position)."""
    s = _scene([], duration_s=4.0, ship_speed=8.0)
    _, bus = _run(s)
    metas, eos = bus.of(protocol.TOPIC_META), bus.of(protocol.TOPIC_EOS)
    for (t0, m), (t1, e) in zip(metas, eos, strict=True):
        v = np.asarray(m["velocity_enu_mps"])
        at_end = np.array([m["position"][k] for k in ("east_m", "north_m")]) + v[:2] * (t1 - t0)
        assert at_end == pytest.approx([e["position"]["east_m"], e["position"]["north_m"]],
                                       abs=1e-6)


# ------------------------------------------------------------------ item 5: complete; end
@pytest.mark.parametrize(("duration", "last_complete"), [(10.5, False), (10.0, True)])
def test_eos_complete_and_end(duration, last_complete):
    s = _scene([_target("a", 0.0, 10e3, 100.0)], duration_s=duration)
    sim, bus = _run(s)
    eos = [p for _, p in bus.of(protocol.TOPIC_EOS)]
    assert [e["complete"] for e in eos] == [True] * (len(eos) - 1) + [last_complete]
    assert len(eos) == math.ceil(duration)
    topic, t, end = bus.messages[-1]
    assert topic == protocol.TOPIC_END and t == duration
    assert end == {"time_s": duration, "sensors": ["r1"], "scans": [len(eos)]}
    assert sum(top == protocol.TOPIC_END for top, _, _ in bus.messages) == 1
    # the in-process iterator ends with it too
    msgs = list(Simulation(s, tables=SceneTables()).messages())
    assert msgs[-1][0] == "end" and msgs[-1][2] == end


def test_end_comes_once_after_every_radar_in_parallel():
    s = parse_scenario({
        "name": "two", "duration_s": 5.5, "seed": 4,
        "origin": {"lat_deg": 44.6, "lon_deg": -63.0},
        "platforms": [{"id": "ship", "waypoints": [{"east_m": 0, "north_m": 0}],
                       "radars": [quiet_radar(), quiet_radar(id="r2", rotation_rpm=24)]}],
        "targets": [_target("a", 0.0, 10e3, 100.0)],
        "fidelity": {"propagation": "free_space", "atmosphere": False, "clutter": False},
    })
    one, many = CaptureBus(), CaptureBus()
    Simulation(s, bus=one, tables=SceneTables()).run()
    Simulation(s, bus=many, tables=SceneTables(), processes=2).run()
    assert one.frames == many.frames
    top, _, end = one.messages[-1]
    assert top == protocol.TOPIC_END and end["sensors"] == ["r1", "r2"]
    per = {k: sum(1 for _, p in one.of(protocol.TOPIC_EOS) if p["sensor"] == k)
           for k in ("r1", "r2")}
    assert end["scans"] == [per["r1"], per["r2"]] == [6, 3]


# ------------------------------------------------------------------ item 8: truth at plot time
def test_plot_minus_truth_is_the_declared_error():
    """Over a run, (plot - truth at the plot's time) / sigma has mean 0 and deviation 1, in
    range and azimuth, for single-contributor plots; false alarms have NaN truth."""
    rng = np.random.default_rng(11)
    targets = [_target(f"t{i}", *rng.uniform(-25e3, 25e3, 2), 200.0, ve=rng.uniform(-200, 200),
                       vn=rng.uniform(-200, 200), sigma=2.0) for i in range(12)]
    s = _scene(targets, duration_s=60.0, ship_speed=8.0, false_alarm_time_s=2.0)
    _, bus = _run(s)
    plots = bus.of(protocol.TOPIC_PLOTS)
    truth = _truth(bus, "plots")
    cat = {k: np.concatenate([p[k] for _, p in plots]) for k in (
        "range_m", "azimuth_rad", "sigma_range_m", "sigma_azimuth_rad", "plot_id")}
    tru = {k: np.concatenate([p[k] for _, p in truth]) for k in (
        "plot_id", "origin", "true_range_m", "true_azimuth_rad", "true_range_rate_mps",
        "contrib_offsets")}
    assert np.array_equal(cat["plot_id"], tru["plot_id"])
    single = np.concatenate([np.diff(p["contrib_offsets"]) == 1 for _, p in truth])
    is_t = tru["origin"] == ORIGIN_TARGET
    assert np.all(np.isnan(tru["true_range_m"][~is_t]))
    assert np.all(np.isnan(tru["true_range_rate_mps"][~is_t]))
    assert np.all(np.isfinite(tru["true_range_m"][is_t]))
    sel = is_t & single
    n = int(sel.sum())
    assert n > 500
    z_r = (cat["range_m"] - tru["true_range_m"])[sel] / cat["sigma_range_m"][sel]
    d_az = np.mod(cat["azimuth_rad"] - tru["true_azimuth_rad"] + math.pi, 2 * math.pi) - math.pi
    z_a = d_az[sel] / cat["sigma_azimuth_rad"][sel]
    for z in (z_r, z_a):
        assert abs(z.mean()) < 4.0 / math.sqrt(n)
        assert z.std() == pytest.approx(1.0, abs=5.0 / math.sqrt(2 * n))


def test_true_range_rate_is_the_radial_velocity():
    """A target receding due north at 150 m/s from a ship at rest: its true range rate is
    +150 m/s (less the few mm/s of the curvature terms)."""
    s = _scene([_target("a", 0.0, 8e3, 10.0, vn=150.0)], duration_s=8.0)
    _, bus = _run(s)
    rr = np.concatenate([p["true_range_rate_mps"] for _, p in _truth(bus, "plots")])
    assert rr.size >= 6
    assert rr == pytest.approx(150.0, abs=0.1)


# ------------------------------------------------------------------ item 4 and 8: truth[targets]
def test_truth_targets_inactive_nan_coverage_and_last_look():
    targets = [
        _target("near", 3e3, 10e3, 100.0),                 # seen every scan
        _target("late", 5e3, 5e3, 100.0, t0=4.0, t1=7.0),  # active from 4 s to 7 s only
        _target("far", 0.0, 80e3, 5000.0),                 # beyond the instrumented 60 km
        _target("low", 0.0, 55e3, 5.0),                    # in range, under the horizon
    ]
    s = _scene(targets, duration_s=10.0)
    sim, bus = _run(s)
    looks = []
    sim2 = Simulation(s, bus=CaptureBus(), tables=SceneTables())
    sim2.radars[0].model.on_look.append(looks.append)
    sim2.run()
    for t, p in _truth(bus, "targets"):
        act = p["active"]
        assert act.tolist() == [True, 4.0 <= t <= 7.0, True, True]
        for k in ("east_m", "v_north_mps", "a_up_mps2"):
            assert np.all(np.isnan(p[k][~act])) and np.all(np.isfinite(p[k][act]))
        assert p["in_coverage"].tolist() == [True, bool(act[1]), False, False]
        # never looked at beyond the instrumented range
        assert math.isnan(p["pd"][2]) and p["interference"][2] == -1
        assert math.isnan(p["look_time_s"][2]) and math.isnan(p["snr_db"][2])
        # the near target's last look is in the scan that ended, and it is the model's own
        assert t - 1.0 < p["look_time_s"][0] <= t
        mine = [(lk.time_s[i], lk.pd[i], lk.si_db[i], lk.interference[i])
                for lk in looks for i in range(lk.size) if lk.target[i] == 0
                and lk.time_s[i] <= t]
        last = max(mine)
        assert (p["look_time_s"][0], p["pd"][0], p["snr_db"][0], p["interference"][0]) == last
        # the low target is looked at (inside the ground range) though under the horizon (the
        # free-space propagation of this scene does not see the horizon; in_coverage does)
        assert np.isfinite(p["pd"][3])
    # the late target keeps its last look after it ended
    _, final = _truth(bus, "targets")[-1]
    assert 6.0 < final["look_time_s"][1] <= 7.0


def test_expected_detections_match_the_counted_ones():
    """Σ P_d of the looks of truth[targets] is the expected number of target plots: a
    detectable definition a scorer can trust (binomial limits, seeded)."""
    rng = np.random.default_rng(5)
    targets = [_target(f"t{i}", *rng.uniform(-50e3, 50e3, 2), 300.0, sigma=0.05)
               for i in range(40)]
    s = _scene(targets, duration_s=60.0)
    _, bus = _run(s)
    pd, hits = 0.0, 0
    var = 0.0
    for t, p in _truth(bus, "targets"):
        fresh = p["look_time_s"] > t - 1.0
        pd += float(p["pd"][fresh].sum())
        var += float((p["pd"][fresh] * (1 - p["pd"][fresh])).sum())
    for _, p in _truth(bus, "plots"):
        hits += int(np.count_nonzero(p["origin"] == ORIGIN_TARGET))
    assert var > 20  # the test has power: many looks of intermediate P_d
    assert abs(hits - pd) < 5 * math.sqrt(var)


# ------------------------------------------------------------------ item 3: clutter density
def test_clutter_counts_match_the_density_per_cell(table_cache):
    """Sea-clutter false alarms of a long run, binned by the plots' own slant range and
    azimuth in meta's cells, against per_scan x scans: Poisson limits cell by cell."""
    scans = 12
    s = clutter_scene(duration_s=float(scans), rotation_rpm=60)
    bus = CaptureBus()
    Simulation(s, bus=bus).run()
    meta = bus.of(protocol.TOPIC_META)[0][1]
    d = meta["clutter_false_alarm_density"]
    r_edges, az_edges, per_scan = d["range_edges_m"], d["azimuth_edges_rad"], d["per_scan"]
    assert per_scan.shape == (r_edges.size - 1, az_edges.size - 1)
    assert az_edges[0] == 0.0 and az_edges[-1] == pytest.approx(2 * math.pi)
    assert per_scan.sum() == pytest.approx(meta["clutter_false_alarms_per_scan"], rel=1e-9)
    # the ground-range profile and the slant-range density are the same alarms
    assert per_scan.sum() == pytest.approx(
        meta["clutter_false_alarm_profile"]["per_scan"].sum(), rel=1e-9)
    plots = bus.of(protocol.TOPIC_PLOTS)
    origin = np.concatenate([p["origin"] for _, p in _truth(bus, "plots")])
    c = origin == ORIGIN_SEA_CLUTTER
    r = np.concatenate([p["range_m"] for _, p in plots])[c]
    az = np.concatenate([p["azimuth_rad"] for _, p in plots])[c]
    counts, _, _ = np.histogram2d(r, az, bins=(r_edges, az_edges))
    assert counts.sum() == c.sum()  # every alarm inside the cells
    expected = scans * per_scan
    big = expected >= 10.0
    assert big.sum() > 100
    z = (counts[big] - expected[big]) / np.sqrt(expected[big])
    assert np.abs(z).max() < 5.0
    # counts are Poisson or tighter (Bernoulli sectors): chi² per cell at most about 1
    assert 0.5 < float(np.mean(z**2)) < 1.0 + 5.0 * math.sqrt(2.0 / big.sum())
    small = (expected > 0) & ~big
    assert abs(counts[small].sum() - expected[small].sum()) < 5 * math.sqrt(
        expected[small].sum())
    # no alarm where the density says none
    assert counts[expected == 0].sum() == 0
    # the wind (from the north) shows: the density is not the same in every sector
    by_sector = per_scan.sum(axis=0)
    assert by_sector.max() > 1.2 * by_sector.min()


# ------------------------------------------------------------------ item 10: versions
def test_version_2_written_version_1_still_read():
    frames = protocol.encode(protocol.TOPIC_EOS, 1.0, {"scan": 0})
    assert msgpack.unpackb(frames[1])["v"] == protocol.SCHEMA_VERSION == 2
    old = msgpack.packb({"v": 1, "t": 2.0, "sensor": "r1", "scan": 0, "kind": "targets",
                         "active": [True]})
    topic, t, payload = protocol.decode([b"truth", old])
    assert (topic, t, payload["active"]) == (b"truth", 2.0, [True])
    with pytest.raises(protocol.ProtocolError, match="not supported"):
        protocol.decode([b"eos", msgpack.packb({"v": 3, "t": 0.0})])


def test_same_seed_same_bytes():
    s = _scene([_target("a", 0.0, 10e3, 100.0, vn=50.0)], duration_s=5.5, ship_speed=8.0)
    assert _run(s)[1].frames == _run(s)[1].frames
