"""The running chain: free-space S/N by hand, noise false alarms against [90]-[93]."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import constants, stats

from shipradar.sim.dwell.model import DwellModel
from shipradar.sim.engine.simulation import ORIGIN_NOISE, Simulation
from shipradar.sim.stream import protocol
from shipradar.sim.world.kinematics import LocalFrame, antenna_geometry
from shipradar.tables.scene import SceneTables

from .helpers import CaptureBus, bare_scene, quiet_radar


def _target(east, north, alt, sigma, t_end=1000.0):
    return {"id": "tgt", "waypoints": [
        {"time_s": 0, "east_m": east, "north_m": north, "altitude_m": alt},
        {"time_s": t_end, "east_m": east, "north_m": north + 1.0, "altitude_m": alt}],
        "rcs": {"type": "constant", "sigma_m2": sigma}, "swerling": 0}


def test_free_space_snr_by_hand():
    s = bare_scene(targets=[_target(0.0, 20e3, 20.0, 1.0)])
    radar = s.platforms[0].radars[0]
    m = DwellModel(s, s.platforms[0], radar, SceneTables())
    geom = antenna_geometry(np.zeros(3), np.zeros(3), 20.0, np.array([[0.0, 20e3, 20.0]]),
                            np.zeros((1, 3)), LocalFrame(s.origin))
    # hand computation, seed [2]-[3], [17]-[20]; L_r = sqrt(L_t/r) (half in dB)
    lam = constants.c / 5.6e9
    g = 10 ** 3.0
    l_tr = 10 ** 0.2
    r = geom.slant_range[0]
    p_r = 50000 * g**2 * lam**2 * 1.0 / ((4 * math.pi) ** 3 * r**4 * l_tr)
    l_r = 10 ** 0.1
    t_s = 290.0 + 290.0 * (l_r - 1) + l_r * 290.0 * (10**0.3 - 1)
    n0 = constants.k * t_s / 1e-6
    snr_db = 10 * math.log10(p_r / (n0 * 10 ** 0.5))
    si_db = snr_db - 1.5  # [66] noise dominant: G_p = 1, L_CFAR 1.5 dB
    res = m.process_targets(geom, np.array([0]), np.array([0.0]), np.array([[0.0, 20e3, 20.0]]),
                            np.random.default_rng(0))
    assert res["snr_db"].size == 1  # 20 km, 1 m², 50 kW: far above threshold
    assert res["snr_db"][0] == pytest.approx(si_db, abs=0.01)
    assert res["interference"][0] == 0


@settings(max_examples=25, deadline=None)
@given(r1=st.floats(2e3, 50e3), k=st.floats(1.1, 4.0))
def test_snr_falls_as_r4(r1, k):
    """Free space, isotropic elevation pattern: S/I(r1) - S/I(k r1) = 40 log10 k (flat limit)."""
    s = bare_scene(targets=[_target(0.0, 20e3, 20.0, 1e6)])
    m = DwellModel(s, s.platforms[0], s.platforms[0].radars[0], SceneTables())
    out = []
    for r in (r1, k * r1):
        pos = np.array([[0.0, r, 20.0]])
        geom = antenna_geometry(np.zeros(3), np.zeros(3), 20.0, pos, np.zeros((1, 3)),
                                LocalFrame(s.origin))
        res = m.process_targets(geom, np.array([0]), np.zeros(1), pos, np.random.default_rng(1))
        out.append((res["snr_db"][0], geom.slant_range[0]))
    expected = 40 * math.log10(out[1][1] / out[0][1])
    assert out[0][0] - out[1][0] == pytest.approx(expected, abs=1e-6)


def _noise_counts(t_fa, scans, rpm=60.0, seed=5):
    radar = quiet_radar(false_alarm_time_s=t_fa, rotation_rpm=rpm)
    dur = scans * 60.0 / rpm
    s = bare_scene(radar, duration_s=dur, seed=seed, sectors_per_scan=8)
    bus = CaptureBus()
    sim = Simulation(s, bus=bus, tables=SceneTables())
    sim.run()
    model = sim.radars[0].model
    per_scan = np.zeros(scans, dtype=int)
    ranges, azs = [], []
    for _, p in bus.of(protocol.TOPIC_PLOTS):
        per_scan[p["scan"]] += p["range_m"].size
        ranges.append(p["range_m"])
        azs.append(p["azimuth_rad"])
    return model, per_scan, np.concatenate(ranges or [[]]), np.concatenate(azs or [[]])


@pytest.mark.parametrize("t_fa,rpm,scans,regime", [
    (0.2, 6.0, 300, "normal"),      # η >= 9
    (1.0, 60.0, 800, "poisson"),    # 0.69/(2 N_ch) <= η < 9
    (8.0, 60.0, 1500, "bernoulli"),  # η = t_scan/t_fa < 0.69/(2 N_ch)
])
def test_noise_false_alarm_counts(t_fa, rpm, scans, regime):
    model, counts, ranges, azs = _noise_counts(t_fa, scans, rpm=rpm)
    eta = model.noise_false_alarms_per_scan
    lo = 0.69 / (2 * 2)
    assert {"normal": eta >= 9, "poisson": lo <= eta < 9, "bernoulli": eta < lo}[regime]
    # mean within 4 standard errors of η; variance as the regime's law says
    var = eta * (1 - eta) if regime == "bernoulli" else eta
    assert abs(counts.mean() - eta) < 4 * math.sqrt(var / scans)
    # sample variance of n draws: relative sd ~ sqrt(2/n) (+ kurtosis); 5 sigma bound
    assert counts.var(ddof=1) == pytest.approx(var, rel=5 * math.sqrt(3.0 / scans) + 0.02)
    if regime == "bernoulli":
        assert counts.max() <= 1
    # uniform in range and in azimuth
    r_max = model.radar.instrumented_range_m
    assert stats.kstest(ranges / r_max, "uniform").pvalue > 1e-3
    assert stats.kstest(azs / (2 * math.pi), "uniform").pvalue > 1e-3


def test_false_alarms_timed_when_the_beam_sweeps_them():
    model, counts, ranges, azs = _noise_counts(2.0, 20)
    s = model.scenario
    bus = CaptureBus()
    Simulation(s, bus=bus, tables=SceneTables()).run()
    omega = 2 * math.pi / model.radar.scan_period_s
    for _, p in bus.of(protocol.TOPIC_PLOTS):
        beam = np.mod(omega * p["time_s"], 2 * math.pi)
        d = np.abs(np.mod(beam - p["azimuth_rad"] + math.pi, 2 * math.pi) - math.pi)
        assert d.max() < 1e-9


def test_truth_marks_noise_origin():
    model, counts, *_ = _noise_counts(2.0, 10)
    bus = CaptureBus()
    Simulation(model.scenario, bus=bus, tables=SceneTables()).run()
    truth = [p for _, p in bus.of(protocol.TOPIC_TRUTH) if p["kind"] == "plots"]
    plots = bus.of(protocol.TOPIC_PLOTS)
    assert len(truth) == len(plots)
    for (_, p), t in zip(plots, truth, strict=True):
        assert np.array_equal(p["plot_id"], t["plot_id"])
        assert np.all(t["origin"] == ORIGIN_NOISE)


def test_realtime_mode_runs_the_same_model_paced_by_the_clock():
    """simpy.rt with a factor: the same frames as fast mode, and the wall clock follows
    simulated time / factor."""
    import time

    s = bare_scene(targets=[_target(0.0, 20e3, 20.0, 1.0)], duration_s=3.0)
    fast, paced = CaptureBus(), CaptureBus()
    Simulation(s, bus=fast, tables=SceneTables()).run()
    t0 = time.perf_counter()
    summary = Simulation(s, bus=paced, tables=SceneTables(), realtime=10.0).run()
    wall = time.perf_counter() - t0
    assert paced.frames == fast.frames
    assert 0.3 - 0.02 <= wall < 3.0  # 3 simulated s at 10x: 0.3 s, never faster
    assert summary["realtime_factor"] == pytest.approx(10.0, rel=0.5)


def test_meta_carries_the_radar_clutter_false_alarm_profile():
    """A tracker reads the radar's own sea-clutter rate (7.2) from the meta: the P_fac map's
    Σ η, split in 250 m rings; a radar that draws no clutter false alarms sends no profile."""
    from shipradar.tables.scene import load_scene_tables
    from tests.helpers import example, scenario

    s = scenario(example("single_missile"), atmosphere=False, propagation="free_space")
    s = s.model_copy(update={"duration_s": 1.0})
    tables = load_scene_tables(s)
    bus = CaptureBus()
    Simulation(s, bus=bus, tables=tables).run()
    _, meta = bus.of(protocol.TOPIC_META)[0]
    prof = meta["clutter_false_alarm_profile"]
    eta = tables.for_radar("giraffe").pfac.extra["expected_count"].sum()
    assert meta["clutter_false_alarms_per_scan"] == pytest.approx(eta, rel=1e-9)
    assert prof["per_scan"].sum() == pytest.approx(eta, rel=1e-9)
    assert np.allclose(np.diff(prof["range_edges_m"]), 250.0)
    quiet = CaptureBus()
    Simulation(bare_scene(duration_s=1.0), bus=quiet, tables=SceneTables()).run()
    assert "clutter_false_alarm_profile" not in quiet.of(protocol.TOPIC_META)[0][1]


@pytest.mark.slow
def test_a_long_run_keeps_no_per_sector_state(table_cache):
    """Memory a run keeps must not grow with its length (the soak benchmark's flat RSS):
    what the SimPy path still holds after 100 s is within a few kB of what it holds after
    20 s. A list of one float per sector (3 600 sectors in 100 s of the demo) would add
    about 100 kB."""
    import gc
    import tracemalloc

    import shipradar
    from shipradar.sim.engine.simulation import CallbackSink

    scenario = shipradar.example("single_missile")
    tables = shipradar.build_tables(scenario)
    kept = {}
    for duration in (20.0, 100.0):
        gc.collect()
        tracemalloc.start()
        sim = Simulation(scenario, tables=tables, duration_s=duration,
                         bus=CallbackSink(lambda *m: None))
        assert not sim.batched  # the SimPy loop, as with a live publisher
        sim.run()
        gc.collect()
        snap = tracemalloc.take_snapshot().filter_traces(
            [tracemalloc.Filter(True, "*simpy*"), tracemalloc.Filter(True, "*engine.py")])
        tracemalloc.stop()
        kept[duration] = sum(s.size for s in snap.statistics("filename"))
        del sim
    assert kept[100.0] - kept[20.0] < 20_000, kept
