"""Recorded traffic files as targets (sim/world/traffic.py): reading, presets, the smooth path
between fixes, gaps, overrides, limits, and a missile from a plain CSV against the demo's."""

from __future__ import annotations

import copy
import math
import subprocess
import sys

import numpy as np
import pytest
import yaml
from scipy import stats
from scipy.interpolate import PchipInterpolator

from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream import protocol
from shipradar.sim.world.kinematics import LocalFrame
from shipradar.sim.world.scenario import Origin, parse_scenario
from shipradar.sim.world.traffic import (
    TrafficError,
    hermite_coefficients,
    limited_slopes,
    monotone_slopes,
    scene_targets,
)

from .helpers import ROOT, CaptureBus, example

TRAFFIC = ROOT / "scenarios" / "traffic"
sys.path.insert(0, str(TRAFFIC))
import generate as sample  # noqa: E402  (the sample files' own generator: the truth)

MISSILE_RCS = {"type": "missile", "sigma_nose_m2": 0.1, "length_m": 4.7, "diameter_m": 0.35}


def _scene(traffic: list[dict], targets=(), **over) -> dict:
    d = example("single_missile")
    d["targets"] = list(targets)
    d["traffic"] = [{**t, "path": str(TRAFFIC / t["path"]) if not t["path"].startswith("/")
                     else t["path"]} for t in traffic]
    d.update(over)
    return d


def _ais(**over) -> dict:
    return {"path": "ais_sample.csv", "preset": "ais", "max_gap_s": 120.0,
            "rcs": {"type": "constant", "sigma_m2": 1000.0}, **over}


# ------------------------------------------------------------------ interpolation
def test_monotone_slopes_are_scipys_pchip_derivatives():
    """Every run's derivatives equal scipy's PchipInterpolator's at its knots (second
    method), for runs of 2, 3 and many knots, flat stretches and sign changes."""
    rng = np.random.default_rng(4)
    lengths = [2, 3, 4, 7, 30]
    t, y, starts = [], [], [0]
    for n in lengths:
        tt = np.cumsum(rng.uniform(0.5, 20.0, n))
        yy = rng.normal(0.0, 100.0, (n, 2))
        yy[n // 2:, 1] = yy[n // 2, 1]  # a flat stretch
        t.append(tt)
        y.append(yy)
        starts.append(starts[-1] + n)
    d = monotone_slopes(np.concatenate(t), np.concatenate(y), np.asarray(starts))
    for k, (tt, yy) in enumerate(zip(t, y, strict=True)):
        ref = PchipInterpolator(tt, yy, axis=0).derivative()(tt)
        assert d[starts[k]:starts[k + 1]] == pytest.approx(ref, rel=1e-12, abs=1e-12)


@pytest.mark.parametrize(("t", "y", "want"), [
    # h0 = 1, h1 = 2, m0 = 1, m1 = 0.25: d = (4 - 0.25)/3
    ([0.0, 1.0, 3.0], [0.0, 1.0, 1.5], 1.25),
    # m0 = 1, m1 = 9: d = (3 - 9)/2 = -3, of the wrong sign: 0
    ([0.0, 1.0, 2.0], [0.0, 1.0, 10.0], 0.0),
    # h0 = 10, h1 = 1, m0 = 1, m1 = -10: d = (21 + 100)/11 = 11 > 3 m0: 3 m0
    ([0.0, 10.0, 11.0], [0.0, 10.0, 0.0], 3.0),
])
def test_end_slopes_take_each_branch_of_the_three_point_rule(t, y, want):
    """The end derivative of a run of three (Moler's shape-preserving three-point rule),
    worked by hand for each of its branches (plain, wrong sign, overshoot), at the first knot
    and, mirrored, at the last; and equal to scipy's PchipInterpolator's (second method)."""
    t, y = np.asarray(t), np.asarray(y)
    starts = np.array([0, 3, 6])
    # the second run is the first mirrored in time: its last knot's derivative is -want
    tt = np.concatenate([t, t[-1] - t[::-1]])
    yy = np.concatenate([y, y[::-1]])
    d = monotone_slopes(tt, yy[:, None], starts)[:, 0]
    assert d[0] == pytest.approx(want, rel=1e-12, abs=1e-12)
    assert d[5] == pytest.approx(-want, rel=1e-12, abs=1e-12)
    for k in range(2):
        run = slice(starts[k], starts[k + 1])
        ref = PchipInterpolator(tt[run], yy[run]).derivative()(tt[run])
        assert d[run] == pytest.approx(ref, rel=1e-12, abs=1e-12)


def test_hermite_matches_ends_and_reproduces_a_cubic():
    """The cubic through (p0, v0) and (p1, v1) over h ends at p1 with velocity v1, and a
    cubic given by its end values is recovered exactly."""
    rng = np.random.default_rng(5)
    p0, p1, v0, v1 = (rng.normal(0, 50, (20, 3)) for _ in range(4))
    h = rng.uniform(0.1, 60.0, 20)
    c2, c3 = hermite_coefficients(p0, p1, v0, v1, h)
    hh = h[:, None]
    assert p0 + v0 * hh + c2 * hh**2 + c3 * hh**3 == pytest.approx(p1, rel=1e-9, abs=1e-9)
    assert v0 + 2 * c2 * hh + 3 * c3 * hh**2 == pytest.approx(v1, rel=1e-9, abs=1e-9)


def test_limited_slopes_keep_a_climb_between_its_fixes():
    """Reported vertical rates far too large (a glitch) are limited so the altitude stays
    between its neighbouring fixes; a NaN rate takes the monotone derivative."""
    t = np.array([0.0, 10.0, 20.0, 30.0])
    z = np.array([1000.0, 1100.0, 1100.0, 1000.0])
    given = np.array([200.0, np.nan, 50.0, -300.0])
    d = limited_slopes(t, z, given, np.array([0, 4]))
    assert d[2] == 0.0  # a local maximum: the slopes around it differ (0 and -10)
    tau = np.linspace(0.0, 10.0, 101)
    for i in range(3):
        c2, c3 = hermite_coefficients(z[i:i + 1, None], z[i + 1:i + 2, None], d[i:i + 1, None],
                                      d[i + 1:i + 2, None], np.array([10.0]))
        zz = z[i] + d[i] * tau + c2[0, 0] * tau**2 + c3[0, 0] * tau**3
        lo, hi = min(z[i], z[i + 1]), max(z[i], z[i + 1])
        assert zz.min() >= lo - 1e-9 and zz.max() <= hi + 1e-9


# ------------------------------------------------------------------ the sample files
def test_ais_sample_follows_the_generating_motion():
    """The AIS sample's ships, read back through the ais preset, lie on the motion that made
    the file (sample generator: circles at constant speed) between their fixes, within
    1.5 m (the file's 7 decimals of latitude are ~1 cm; the cubic's error on a 10 s
    interval of a 0.2 deg/s turn ~1e-3 m); velocities within 0.05 m/s."""
    s = parse_scenario(_scene([_ais()]))
    targets = scene_targets(s)
    traj = targets.trajectories(LocalFrame(s.origin))
    assert targets.ids == sorted(str(x[0]) for x in sample.SHIPS)
    assert targets.kinds == ["ship"] * 6 and list(targets.swerling) == [1] * 6
    by_id = {str(x[0]): x for x in sample.SHIPS}
    for row, tid in enumerate(targets.ids):
        mmsi, name, _, e0, n0, course, kn, turn = by_id[tid]
        assert targets.names[row] == name
        t = np.linspace(traj.t_first[row], traj.t_last[row], 400)
        pos, vel, active = traj.state(t, np.full(t.size, row))
        want = sample.circle(t, e0, n0, course, kn * sample.KNOT, turn)
        err = np.hypot(*(pos[active, :2] - want[active]).T)
        assert err.max() < 1.5, (tid, err.max())
        dt = 1e-3
        v_want = (sample.circle(t + dt, e0, n0, course, kn * sample.KNOT, turn)
                  - sample.circle(t - dt, e0, n0, course, kn * sample.KNOT, turn)) / (2 * dt)
        assert np.abs(vel[active, :2] - v_want[active]).max() < 0.05
        assert np.all(pos[:, 2] == 0.0)


def test_velocity_is_continuous_at_every_fix():
    s = parse_scenario(_scene([_ais(), {"path": "adsb_sample.csv", "preset": "adsb",
                                        "rcs": {"type": "constant", "sigma_m2": 20}}]))
    traj = scene_targets(s).trajectories(LocalFrame(s.origin))
    live = traj.live & (traj.kind == 3)
    j = np.flatnonzero(live[:-1] & live[1:] & (np.abs(traj.t0[:-1] + traj.dt[:-1]
                                                      - traj.t0[1:]) < 1e-9))
    assert j.size > 50
    tau = traj.dt[j][:, None]
    par = traj.par[j]
    end_p = traj.p0[j] + tau * (traj.v0[j] + tau * (par[:, :3] + tau * par[:, 3:]))
    end_v = traj.v0[j] + tau * (2 * par[:, :3] + 3 * tau * par[:, 3:])
    assert end_p == pytest.approx(traj.p0[j + 1], abs=1e-6)
    assert end_v == pytest.approx(traj.v0[j + 1], abs=1e-8)


def test_a_gap_longer_than_max_gap_leaves_the_target_inactive():
    """Ship 4 of the sample is silent from ~40 s to ~280 s: inactive between (max_gap_s
    120 s), active on each side; a max_gap_s longer than the silence bridges it."""
    s = parse_scenario(_scene([_ais()]))
    targets = scene_targets(s)
    row = targets.ids.index("316001004")
    traj = targets.trajectories(LocalFrame(s.origin))
    _, _, act = traj.state(np.array([20.0, 150.0, 300.0]), np.full(3, row))
    assert act.tolist() == [True, False, True]
    _, _, outside = traj.state(np.array([traj.t_first[row] - 1, traj.t_last[row] + 1]),
                               np.full(2, row))
    assert not outside.any()
    s2 = parse_scenario(_scene([_ais(max_gap_s=400.0)]))
    t2 = scene_targets(s2)
    _, _, act2 = t2.trajectories(LocalFrame(s2.origin)).state(np.array([150.0]),
                                                               np.array([row]))
    assert act2.all()


def test_adsb_preset_altitude_climb_and_names():
    """The climbing aircraft (3000 m + 12 m/s up to 120 s) follows its climb within 0.5 m
    and never leaves [3000, 4440] m; callsigns are the names, stripped."""
    s = parse_scenario(_scene([{"path": "adsb_sample.csv", "preset": "adsb",
                                "rcs": {"type": "constant", "sigma_m2": 20}}]))
    targets = scene_targets(s)
    assert targets.kinds == ["aircraft"] * 3
    row = targets.ids.index("c0a5e1")
    assert targets.names[row] == "WJA231"
    traj = targets.trajectories(LocalFrame(s.origin))
    t = np.linspace(traj.t_first[row], traj.t_last[row], 500)
    pos, vel, _ = traj.state(t, np.full(t.size, row))
    want = 3000.0 + 12.0 * np.minimum(t, 120.0)
    # the generating climb levels off abruptly at 120 s; the C1 path rounds that corner in
    # the two intervals around it, and follows the climb exactly elsewhere
    far = np.abs(t - 120.0) > 10.0
    assert np.abs(pos[far, 2] - want[far]).max() < 0.5
    assert pos[:, 2].min() >= 3000.0 - 1e-6 and pos[:, 2].max() <= 4440.0 + 1e-6


def test_overrides_by_id_and_class_and_the_first_match_wins():
    ov = [{"ids": ["316001001"], "rcs": {"type": "constant", "sigma_m2": 5.0}, "swerling": 0},
          {"classes": ["30", "31"], "kind": "other", "swerling": 2},
          {"ids": ["316001001"], "swerling": 4}]
    targets = scene_targets(parse_scenario(_scene([_ais(overrides=ov)])))
    by = dict(zip(targets.ids, zip(targets.rcs, targets.swerling, targets.kinds,
                                   strict=True), strict=True))
    assert by["316001001"][0].sigma_m2 == 5.0 and by["316001001"][1] == 0
    assert by["316001003"][1:] == (2, "other")  # VesselType 30
    assert by["316001006"][1:] == (2, "other")  # VesselType 31
    assert by["316001002"][0].sigma_m2 == 1000.0 and by["316001002"][1] == 1


def test_time_alignment_window_and_id_filter():
    base = scene_targets(parse_scenario(_scene([_ais()])))
    moved = scene_targets(parse_scenario(_scene([_ais(time_offset_s=30.0)])))
    kept = scene_targets(parse_scenario(_scene([_ais(ids=["316001002", "316001005"],
                                                     window_start_s=50.0)])))
    s = parse_scenario(_scene([_ais()]))
    f = LocalFrame(s.origin)
    a, b = base.trajectories(f), moved.trajectories(f)
    assert b.t_first == pytest.approx(a.t_first + 30.0, abs=1e-9)
    assert kept.ids == ["316001002", "316001005"]
    assert kept.trajectories(f).t_first.min() >= 50.0
    first = scene_targets(parse_scenario(_scene([_ais(align="first_fix")])))
    assert first.trajectories(f).t_first.min() == 0.0


def test_plain_time_column_iso_and_a_scene_without_own_targets(tmp_path):
    p = tmp_path / "iso.csv"
    p.write_text("time,id,lat_deg,lon_deg,alt_m\n"
                 "2026-06-01T12:00:10Z,a,44.70,-63.0,100\n"
                 "2026-06-01T12:00:20Z,a,44.71,-63.0,100\n"
                 "2026-06-01T12:00:30Z,a,,-63.0,100\n")
    s = parse_scenario(_scene([{"path": str(p), "rcs": {"type": "constant", "sigma_m2": 1}}]))
    targets = scene_targets(s)
    traj = targets.trajectories(LocalFrame(s.origin))
    assert (traj.t_first[0], traj.t_last[0]) == (10.0, 20.0)
    assert targets.dropped == {"no position": 1}
    assert s.targets == []


def test_parquet_reads_like_csv(tmp_path):
    import pyarrow.csv as pcsv
    import pyarrow.parquet as pq

    pq.write_table(pcsv.read_csv(TRAFFIC / "ais_sample.csv"), tmp_path / "ais.parquet")
    a = scene_targets(parse_scenario(_scene([_ais()])))
    b = scene_targets(parse_scenario(_scene([_ais(path=str(tmp_path / "ais.parquet"))])))
    f = LocalFrame(Origin(lat_deg=44.6, lon_deg=-63.0))
    ta, tb = a.trajectories(f), b.trajectories(f)
    assert a.ids == b.ids and a.names == b.names
    assert np.array_equal(ta.p0, tb.p0) and np.array_equal(ta.t0, tb.t0)


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize("over, words", [
    ({"path": "/nonexistent/x.csv"}, ["traffic[0].path", "cannot read"]),
    ({"limits": {"max_rows": 10}}, ["traffic[0].path", "rows", "limits.max_rows 10"]),
    ({"limits": {"max_ids": 3}}, ["traffic[0].path", "6 ids", "limits.max_ids 3"]),
    ({"limits": {"max_bytes": 100}}, ["traffic[0].path", "bytes", "limits.max_bytes 100"]),
    ({"columns": {"lat": "Latitude"}}, ["traffic[0].columns.lat", "'Latitude'"]),
    ({"preset": "plain"}, ["traffic[0].columns.id", "'id'"]),
])
def test_bad_files_are_refused_in_one_line(over, words):
    with pytest.raises(TrafficError) as err:
        scene_targets(parse_scenario(_scene([_ais(**over)])))
    msg = str(err.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg, msg


def test_garbage_file_and_bad_times(tmp_path):
    junk = tmp_path / "junk.parquet"
    junk.write_bytes(b"\x00\x01 not parquet" * 10)
    with pytest.raises(TrafficError, match=r"traffic\[0\]\.path: .*not a readable Parquet"):
        scene_targets(parse_scenario(_scene([_ais(path=str(junk))])))
    bad = tmp_path / "bad.csv"
    bad.write_text("time,id,lat_deg,lon_deg\nyesterday,a,44.7,-63\n")
    with pytest.raises(TrafficError, match=r"traffic\[0\]\.columns\.time: .*ISO 8601"):
        scene_targets(parse_scenario(_scene([{"path": str(bad),
                                              "rcs": {"type": "constant", "sigma_m2": 1}}])))


def test_duplicate_ids_and_schema_errors():
    d = _scene([_ais()], targets=[])
    d["platforms"][0]["id"] = "316001001"
    with pytest.raises(TrafficError, match=r"traffic\[0\]\.id_prefix: id '316001001'"):
        scene_targets(parse_scenario(d))
    from shipradar.sim.world.scenario import ScenarioError

    with pytest.raises(ScenarioError, match=r"traffic\.0\.max_gap_s|traffic\[0\]\.max_gap_s"):
        parse_scenario(_scene([_ais(max_gap_s=0)]))
    with pytest.raises(ScenarioError, match="window_end_s"):
        parse_scenario(_scene([_ais(window_start_s=10, window_end_s=5)]))


def test_cli_refuses_a_bad_file_with_exit_2(tmp_path):
    d = _scene([_ais(limits={"max_rows": 5})])
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(d))
    proc = subprocess.run([sys.executable, "-m", "shipradar.sim.cli", "validate", str(path)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and "limits.max_rows 5" in proc.stderr


def test_relative_path_is_against_the_scenario_file(tmp_path):
    d = _scene([_ais()])
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "a.csv").write_bytes((TRAFFIC / "ais_sample.csv").read_bytes())
    d["traffic"][0]["path"] = "data/a.csv"
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(d))
    from shipradar.sim.world.scenario import load_scenario

    assert scene_targets(load_scenario(path)).n == 6


# ------------------------------------------------------------------ the demo's missile from CSV
def _run(d: dict, seed: int):
    bus = CaptureBus()
    sim = Simulation(parse_scenario(d), bus=bus, seed=seed)
    summary = sim.run()
    return summary, bus


def _plot_errors(bus) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    plots = bus.of(protocol.TOPIC_PLOTS)
    truth = [p for _, p in bus.of(protocol.TOPIC_TRUTH) if p["kind"] == "plots"]
    cat = {k: np.concatenate([p[k] for _, p in plots]) for k in (
        "range_m", "azimuth_rad", "sigma_range_m", "sigma_azimuth_rad", "plot_id")}
    tru = {k: np.concatenate([p[k] for p in truth]) for k in (
        "plot_id", "origin", "true_range_m", "true_azimuth_rad")}
    assert np.array_equal(cat["plot_id"], tru["plot_id"])
    sel = tru["origin"] == 0
    z_r = (cat["range_m"] - tru["true_range_m"])[sel] / cat["sigma_range_m"][sel]
    d_az = np.mod(cat["azimuth_rad"] - tru["true_azimuth_rad"] + math.pi, 2 * math.pi) - math.pi
    return z_r, d_az[sel] / cat["sigma_azimuth_rad"][sel], tru["true_range_m"][sel]


@pytest.mark.slow
def test_missile_from_a_plain_csv_is_the_demos_missile():
    """The demo's sea-skimmer given as a plain CSV (one fix a second along its path, no own
    targets) against the demo itself:

    * same seed: the same looks (the path between fixes is the straight line to < 1 cm, so
      the same crossings, the same draws) and the same plots, to the cm;
    * other seeds: total detections within the binomial limits of the demo's (two-sample
      test, 99.9 %);
    * the plots' errors against the truth topic are N(0, 1) in range and azimuth.
    """
    demo = example("single_missile")
    csv_scene = _scene([{"path": "missile_plain.csv", "kind": "missile", "rcs": MISSILE_RCS}])
    s_demo, b_demo = _run(demo, 1)
    s_csv, b_csv = _run(csv_scene, 1)
    assert s_csv["dwells"] == s_demo["dwells"]
    assert s_csv["target_plots"] == s_demo["target_plots"]
    _, _, r_demo = _plot_errors(b_demo)
    _, _, r_csv = _plot_errors(b_csv)
    assert r_csv == pytest.approx(r_demo, abs=0.01)
    meta = b_csv.of(protocol.TOPIC_META)[0][1]
    assert meta["target_ids"] == ["missile1"] and meta["target_names"] == ["missile1"]
    assert s_csv["traffic"] == {"targets": 1, "rows": 106, "left_out": {}}

    hits = {"demo": 0, "csv": 0}
    looks = {"demo": 0, "csv": 0}
    zs = []
    for k in range(6):
        for name, d, seed in (("demo", demo, 100 + k), ("csv", csv_scene, 200 + k)):
            s, bus = _run(copy.deepcopy(d), seed)
            hits[name] += s["target_plots"]
            looks[name] += s["dwells"]
            if name == "csv":
                zs.append(_plot_errors(bus)[:2])
    p1, p2 = hits["demo"] / looks["demo"], hits["csv"] / looks["csv"]
    p = (hits["demo"] + hits["csv"]) / (looks["demo"] + looks["csv"])
    se = math.sqrt(p * (1 - p) * (1 / looks["demo"] + 1 / looks["csv"]))
    assert abs(p1 - p2) < stats.norm.isf(0.0005) * se, (hits, looks)
    z_r = np.concatenate([z[0] for z in zs])
    z_a = np.concatenate([z[1] for z in zs])
    n = z_r.size
    assert n > 300
    for z in (z_r, z_a):
        assert abs(z.mean()) < 4.0 / math.sqrt(n)
        assert z.std() == pytest.approx(1.0, abs=5.0 / math.sqrt(2 * n))
        assert stats.kstest(z, "norm").pvalue > 1e-3
