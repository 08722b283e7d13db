"""DIS input (``shipradar run --dis``): PDUs built with opendis in another process
(examples/dis_sender.py, which imports nothing of shipradar), decoded, dead-reckoned,
counted, and a run frozen and resumed by Stop/Freeze and Start/Resume PDUs."""

from __future__ import annotations

import subprocess
import sys
import threading
import time

import numpy as np
import pytest

pytest.importorskip("opendis")

from shipradar.sim.adapters.dis import (  # noqa: E402
    DisError,
    DisReceiver,
    ecef_state_to_local,
    parse_dis_url,
)
from shipradar.sim.engine.simulation import Simulation  # noqa: E402
from shipradar.sim.world import geodesy  # noqa: E402
from shipradar.sim.world.kinematics import LocalFrame  # noqa: E402
from shipradar.sim.world.live import LiveTargets, check_states  # noqa: E402
from shipradar.sim.world.scenario import Origin, parse_scenario  # noqa: E402

from .helpers import ROOT, CaptureBus, free_port, quiet_radar  # noqa: E402

SENDER = ROOT / "examples" / "dis_sender.py"
FRAME = LocalFrame(Origin(lat_deg=44.6, lon_deg=-63.0))


def test_urls_loopback_by_default():
    assert parse_dis_url("udp://127.0.0.1:3000") == ("127.0.0.1", 3000, False)
    assert parse_dis_url("udp://localhost") == ("localhost", 3000, False)
    with pytest.raises(DisError, match="--allow-insecure-remote"):
        parse_dis_url("udp://0.0.0.0:3000")
    assert parse_dis_url("udp://0.0.0.0:3000", allow_remote=True)[2] is True
    with pytest.raises(DisError, match=r"port must be in \[1, 65535\], got 70000"):
        parse_dis_url("udp://127.0.0.1:70000")
    with pytest.raises(DisError, match="expected udp://"):
        parse_dis_url("tcp://127.0.0.1:3000")


def test_ecef_states_land_in_the_local_frame():
    """A local state taken to ECEF (the frame's own geodetic conversion, then WGS-84) comes
    back within a millimetre; an ECEF velocity along the local north is the local north."""
    enu = np.array([[5000.0, -12000.0, 0.0], [-30000.0, 40000.0, 3000.0]])
    lat, lon, _ = FRAME.geodetic(np.column_stack([enu[:, :2], np.zeros(2)]))
    xyz = np.column_stack(geodesy.geodetic2ecef(lat, lon, enu[:, 2]))
    # a velocity: the ECEF difference of two points 1 s apart at 100 m/s due local north
    step = enu + [0.0, 100.0, 0.0]
    lat2, lon2, _ = FRAME.geodetic(np.column_stack([step[:, :2], np.zeros(2)]))
    xyz2 = np.column_stack(geodesy.geodetic2ecef(lat2, lon2, enu[:, 2]))
    pos, vel, acc = ecef_state_to_local(FRAME, xyz, xyz2 - xyz, np.zeros_like(xyz))
    assert pos == pytest.approx(enu, abs=1e-3)
    assert vel == pytest.approx(np.array([[0, 100.0, 0]] * 2), abs=0.05)
    assert acc == pytest.approx(np.zeros((2, 3)), abs=1e-9)


def test_ecef_vectors_carried_by_the_exact_derivative():
    """The analytic derivative that carries velocities against a second method: a central
    difference (±0.01 s) of positions mapped through geodetic coordinates and the frame's
    own projection (``traffic.local_positions``), for points to 200 km and 12 km up."""
    from shipradar.sim.world.traffic import local_positions

    def mapped(xyz):
        lat, lon, h = geodesy.ecef2geodetic(xyz[:, 0], xyz[:, 1], xyz[:, 2])
        return np.column_stack([local_positions(FRAME, lat, lon), h])

    rng = np.random.default_rng(8)
    enu = np.column_stack([rng.uniform(-2e5, 2e5, (40, 2)), rng.uniform(0, 1.2e4, 40)])
    lat, lon, h = FRAME.geodetic(enu)
    xyz = np.column_stack(geodesy.geodetic2ecef(lat, lon, h))
    vel = rng.normal(0.0, 300.0, (40, 3))
    pos, v_loc, _ = ecef_state_to_local(FRAME, xyz, vel, np.zeros_like(vel))
    step = 0.01
    ref = (mapped(xyz + vel * step) - mapped(xyz - vel * step)) / (2 * step)
    assert pos == pytest.approx(mapped(xyz), abs=1e-4)
    assert v_loc == pytest.approx(ref, abs=2e-4)


def _wait_for(predicate, timeout=15.0):
    done = threading.Event()
    deadline = time.monotonic() + timeout
    while not predicate() and time.monotonic() < deadline:
        done.wait(0.02)
    return predicate()


def test_pdus_from_opendis_in_another_process():
    """Entity states (FPW ship, FVW missile, RVW aircraft), a truncated datagram, one of
    another protocol version, a Fire PDU, Stop/Freeze, Start/Resume, Remove Entity and a
    deactivated last state, from examples/dis_sender.py."""
    port = free_port()
    rx = DisReceiver(f"udp://127.0.0.1:{port}", FRAME, exercise_id=1)
    try:
        proc = subprocess.run([sys.executable, str(SENDER), "--port", str(port), "--seconds",
                               "1.2", "--rate", "10", "--junk", "--freeze-at", "0.3",
                               "--resume-at", "0.6", "--remove-at", "0.9"], timeout=60)
        assert proc.returncode == 0
        # the sender has exited: its datagrams are in the socket's buffer; wait until the
        # receiver's count settles
        seen = [-1, 0]

        def settled() -> bool:
            n = rx.stats()["datagrams"]
            seen[1] = seen[1] + 1 if n == seen[0] else 0
            seen[0] = n
            return seen[1] >= 10 and n > 30

        assert _wait_for(settled)
        st = rx.stats()
        assert st["bad_datagrams"] == {"protocol version": 1, "truncated": 1}
        assert st["ignored"] == {"pdu type 2": 1}
        assert st["freezes"] == 1 and not rx.frozen.is_set()
        payloads = rx.drain(20.0)
    finally:
        rx.close()
    live = LiveTargets(parse_scenario(_scene()))
    for p in payloads:
        live.apply(check_states(p, live.bad), 20.0)
    assert live.ids == ["1:1:1", "1:1:2", "1:1:3"]
    assert live.names == ["FRIGATE 2", "SKIMMER", "PATROL"]
    assert live.kinds == ["ship", "missile", "aircraft"]
    assert live.bad == {}
    # the frigate at 12 kn due north, the patrol circling (centripetal acceleration
    # 4000 (2π/120)² = 11 m/s²), the missile removed, the patrol deactivated at its last PDU
    _, vel, _ = live.state(np.array([20.0]), np.array([0]))
    assert vel[0] == pytest.approx([0.0, 12 * 1852 / 3600, 0.0], abs=0.05)
    _, _, acc, _ = live.state_acc(np.array([20.0]), np.array([2]))
    assert np.hypot(acc[0, 0], acc[0, 1]) == pytest.approx(4000 * (2 * np.pi / 120) ** 2,
                                                           rel=0.01)
    t_end = live.t_last
    assert np.isfinite(t_end[1]) and np.isfinite(t_end[2])
    assert t_end[0] == pytest.approx(live._t_u[0] + 12.0)


def _scene(duration_s: float = 3.0) -> dict:
    return {"name": "dis", "duration_s": duration_s, "seed": 3,
            "origin": {"lat_deg": 44.6, "lon_deg": -63.0},
            "platforms": [{"id": "ship", "waypoints": [{"east_m": 0, "north_m": 0}],
                           "radars": [quiet_radar()]}],
            "entity_types": [
                {"match": "1:3:*", "kind": "ship", "rcs": {"type": "constant", "sigma_m2": 1e3}},
                {"match": "2:6:*", "kind": "missile",
                 "rcs": {"type": "constant", "sigma_m2": 0.1}},
                {"match": "1:2:*", "kind": "aircraft",
                 "rcs": {"type": "constant", "sigma_m2": 10.0}}],
            "fidelity": {"propagation": "free_space", "atmosphere": False, "clutter": False}}


@pytest.mark.slow
def test_a_run_fed_frozen_and_resumed_by_dis():
    """A 3 s run fed by the sender; a Stop/Freeze 1 s in holds the clock until the
    Start/Resume 1 s later: the run takes ~4 s of wall time for 3 s simulated, the frigate
    is seen, and the entity states go into the stream's entities topic."""
    port = free_port()
    rx = DisReceiver(f"udp://127.0.0.1:{port}", FRAME)
    summary, wall, bus = _run_beside_sender(
        rx, port, ["--freeze-at", "1.5", "--resume-at", "2.5"], _scene())
    src = summary["live"]["source"]
    assert src["freezes"] == 1
    assert src["frozen_s"] == pytest.approx(1.0, abs=0.4)
    assert wall == pytest.approx(3.0 + src["frozen_s"], abs=0.5)
    assert summary["live"]["entities"] == 3
    assert summary["target_plots"] >= 2
    assert bus.of(b"entities")


@pytest.mark.slow
def test_a_run_held_until_the_simulation_manager_starts_it():
    """``--dis-wait-start``: the run waits for the sender's Start/Resume (sent 2 s after its
    first PDUs, to all), then runs its 2 s at the wall clock's pace; the entities received
    meanwhile are targets from the start."""
    port = free_port()
    rx = DisReceiver(f"udp://127.0.0.1:{port}", FRAME, wait_start=True)
    assert rx.frozen.is_set()
    summary, wall, _ = _run_beside_sender(rx, port, ["--resume-at", "2.0"],
                                          _scene(duration_s=2.0))
    src = summary["live"]["source"]
    # the first PDU reached us at most ~0.3 s after the sender started (2 s before Start)
    assert 1.0 < src["start_wait_s"] < 2.3
    assert src["freezes"] == 0 and src["frozen_s"] == 0.0
    assert wall == pytest.approx(2.0 + src["start_wait_s"], abs=0.5)
    assert summary["live"]["entities"] == 3
    assert summary["target_plots"] >= 1


def test_cli_refuses_wait_start_without_dis(tmp_path):
    import yaml

    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(_scene()))
    proc = subprocess.run([sys.executable, "-m", "shipradar.sim.cli", "run", str(path),
                           "--quiet", "--dis-wait-start"], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 2 and "--dis-wait-start" in proc.stderr
    assert proc.stderr.strip().count("\n") == 0


def test_orientation_gives_the_heading():
    """DIS Euler angles of a level body whose x axis (pymap3d's ENU -> ECEF, independent of
    the code) heads h at various places: ``ecef_heading_deg`` gives h back within 2e-4 deg
    (its geocentric north: (1 - cos 0.19 deg)/2 rad = 1.6e-4 deg at most)."""
    import pymap3d

    from shipradar.sim.adapters.dis import ecef_heading_deg

    rng = np.random.default_rng(5)
    lat = rng.uniform(-80, 80, 50)
    lon = rng.uniform(-180, 180, 50)
    head = rng.uniform(0, 360, 50)
    x, y, z = pymap3d.geodetic2ecef(lat, lon, 0.0)
    u, v, w = pymap3d.enu2uvw(np.sin(np.radians(head)), np.cos(np.radians(head)), 0.0,
                              lat, lon)
    psi, theta = np.arctan2(v, u), -np.arcsin(w)
    got = ecef_heading_deg(np.column_stack([x, y, z]), np.column_stack([psi, theta]))
    diff = (got - head + 180.0) % 360.0 - 180.0
    assert np.abs(diff).max() < 2e-4


@pytest.mark.slow
def test_a_platform_riding_on_a_dis_entity():
    """``platforms[].dis_entity``: the radar's ship rides on the sender's frigate (1:1:1,
    12 kn due north from 6 km east, 2 km north, heading north): the antenna's reported
    position follows the frigate's path (within 5 m; the sender's own flat-earth offsets
    differ from the frame's by ~1e-3), its velocity is 12 kn north (0.05 m/s) and its heading
    the PDUs' 0 deg (0.1 deg) rather than the scenario's 90; the frigate is not a target."""
    port = free_port()
    rx = DisReceiver(f"udp://127.0.0.1:{port}", FRAME)
    proc = subprocess.Popen([sys.executable, str(SENDER), "--port", str(port), "--seconds",
                             "10"])
    scene = _scene(duration_s=3.0)
    scene["platforms"][0].update(dis_entity="1:1:1", heading_deg=90.0)
    try:
        assert rx.first_entity.wait(30.0)
        t_sent = time.monotonic()
        bus = CaptureBus()
        sim = Simulation(parse_scenario(scene), bus=bus, realtime=1.0, entities=rx)
        summary = sim.run()
    finally:
        proc.kill()
        proc.wait(10)
        rx.close()
    assert summary["live"]["entities"] == 2
    metas = bus.of(b"meta")
    assert "1:1:1" not in metas[-1][1]["target_ids"]
    v = 12 * 1852.0 / 3600.0
    eos = bus.of(b"eos")
    assert len(eos) >= 2
    for _, p in eos:
        q = p["position"]
        assert q["east_m"] == pytest.approx(6000.0, abs=10.0)
        assert p["velocity_enu_mps"][0] == pytest.approx(0.0, abs=0.05)
        assert p["velocity_enu_mps"][1] == pytest.approx(v, abs=0.05)
        assert min(p["heading_deg"], 360.0 - p["heading_deg"]) < 0.1
    # north along the path: consecutive ends of scan 1 s apart move v s north, to the
    # jitter of the PDUs' arrival times, which stamp their states (under 80 ms: 0.5 m)
    north = [p["position"]["north_m"] for _, p in eos]
    assert np.diff(north) == pytest.approx(v * np.diff([p["time_s"] for _, p in eos]),
                                           abs=0.5)
    assert 2000.0 < north[0] < 2000.0 + v * (time.monotonic() - t_sent + 10.0)


# ------------------------------------------------------------------ the demo's missile by DIS
MISSILE_SENDER = """
import json, socket, sys, time
sys.path.insert(0, sys.argv[3])
from dis_sender import management, serialize   # opendis only
from opendis.dis7 import (EntityID, EntityStatePdu, EntityType, StartResumePdu,
                          Vector3Double, Vector3Float)
port, path = int(sys.argv[1]), sys.argv[2]
d = json.load(open(path))
sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
to = ("127.0.0.1", port)
t0 = time.monotonic()
started = False
for k, (s, xyz, vel) in enumerate(zip(d["s"], d["xyz"], d["vel"])):
    w = s + d["start_wall_s"]          # sim time s is sent at sender wall time w
    time.sleep(max(0.0, t0 + w - time.monotonic()))
    if not started and w >= d["start_wall_s"]:
        sock.sendto(management(StartResumePdu, 1), to)
        started = True
    pdu = EntityStatePdu()
    pdu.protocolVersion = 7
    pdu.exerciseID = 1
    pdu.entityID = EntityID(2, 7, 1)
    pdu.entityType = EntityType(2, 6, 222, 1, 1, 0, 0)
    pdu.entityLocation = Vector3Double(*xyz)
    pdu.entityLinearVelocity = Vector3Float(*vel)
    pdu.deadReckoningParameters.deadReckoningAlgorithm = 2
    pdu.marking.setString("VAMPIRE")
    pdu.entityAppearance = 0
    pdu.capabilities = 0
    sock.sendto(serialize(pdu), to)
"""


def _terminal_phase(window_s: float, t_from: float) -> tuple[dict, dict]:
    """The demo (scenarios/single_missile.yaml) from ``t_from`` for ``window_s`` s: the
    frigate and the missile where the demo has them then (both legs straight); the YAML
    scene and the same scene with the missile left to DIS (``entity_types`` giving it the
    demo's RCS model)."""
    import copy

    import yaml

    from .helpers import ROOT

    demo = yaml.safe_load((ROOT / "scenarios" / "single_missile.yaml").read_text())
    d = copy.deepcopy(demo)
    d["duration_s"] = window_s
    fw = d["platforms"][0]["waypoints"]  # 0 -> 600 s
    frac = t_from / (fw[1]["time_s"] - fw[0]["time_s"])
    fw[0] = {"time_s": 0, "east_m": 0,
             "north_m": fw[0]["north_m"] + frac * (fw[1]["north_m"] - fw[0]["north_m"])}
    fw[1] = dict(fw[1], time_s=fw[1]["time_s"] - t_from)
    mw = d["targets"][0]["waypoints"]  # 0 -> 105 s
    frac = t_from / (mw[1]["time_s"] - mw[0]["time_s"])
    mw[0] = {"time_s": 0, "altitude_m": mw[0]["altitude_m"],
             **{k: mw[0][k] + frac * (mw[1][k] - mw[0][k]) for k in ("east_m", "north_m")}}
    mw[1] = dict(mw[1], time_s=mw[1]["time_s"] - t_from)
    dis = copy.deepcopy(d)
    target = dis.pop("targets")[0]
    dis["entity_types"] = [{"match": "2:6:*", "kind": "missile", "rcs": target["rcs"]}]
    dis["external"] = {"max_altitude_m": 5.0}
    return d, dis


def _z_errors(bus) -> tuple[np.ndarray, np.ndarray]:
    plots = bus.of(b"plots")
    truth = [p for _, p in bus.of(b"truth") if p["kind"] == "plots"]
    if not plots:
        return np.zeros(0), np.zeros(0)
    cat = {k: np.concatenate([p[k] for _, p in plots]) for k in (
        "range_m", "azimuth_rad", "sigma_range_m", "sigma_azimuth_rad")}
    tru = {k: np.concatenate([p[k] for p in truth]) for k in (
        "origin", "true_range_m", "true_azimuth_rad")}
    sel = tru["origin"] == 0
    z_r = (cat["range_m"] - tru["true_range_m"])[sel] / cat["sigma_range_m"][sel]
    d_az = np.mod(cat["azimuth_rad"] - tru["true_azimuth_rad"] + np.pi, 2 * np.pi) - np.pi
    return z_r, d_az[sel] / cat["sigma_azimuth_rad"][sel]


@pytest.mark.slow
def test_the_demos_missile_flown_by_dis(tmp_path):
    """The demo's sea-skimmer flown by DIS (an opendis process, 5 PDUs a second, FPW, along
    the demo's path; its Start/Resume starts the run, ``wait_start``) over the demo's
    terminal phase (25 s from t = 80 s, 5 to 12 km) against the same window of the demo with
    its YAML missile:

    * the DIS run's detections per look within the two-sample binomial limits (99.9 %) of
      the demo's over 8 seeds;
    * its plots' range and azimuth errors against the truth topic N(0, 1) (mean, spread and
      Kolmogorov-Smirnov).
    """
    from scipy import stats

    from shipradar.tables.scene import load_scene_tables

    from .helpers import ROOT

    window, t_from = 25.0, 80.0
    yaml_scene, dis_scene = _terminal_phase(window, t_from)
    sc_yaml, sc_dis = parse_scenario(yaml_scene), parse_scenario(dis_scene)
    tables = load_scene_tables(sc_yaml)
    hits = looks = 0
    for seed in range(8):
        s = Simulation(parse_scenario(yaml_scene), seed=100 + seed, tables=tables).run()
        hits += s["target_plots"]
        looks += s["dwells"]
    # the DIS side: the same path, sampled every 0.2 s of simulated time from -2 s to the
    # window's end, carried to ECEF by the scene's own frame (the sender is given numbers)
    frame = LocalFrame(sc_dis.origin)
    mw = yaml_scene["targets"][0]["waypoints"]
    p0 = np.array([mw[0]["east_m"], mw[0]["north_m"], mw[0]["altitude_m"]], float)
    p1 = np.array([mw[1]["east_m"], mw[1]["north_m"], mw[1]["altitude_m"]], float)
    v = (p1 - p0) / (mw[1]["time_s"] - mw[0]["time_s"])
    s_k = np.arange(-2.0, window + 1.0, 0.2)

    def ecef(s):
        lat, lon, h = frame.geodetic(p0[None, :] + np.asarray(s)[:, None] * v[None, :])
        return np.column_stack(geodesy.geodetic2ecef(lat, lon, h))

    xyz = ecef(s_k)
    vel = (ecef(s_k + 0.05) - ecef(s_k - 0.05)) / 0.1
    path = tmp_path / "path.json"
    import json

    path.write_text(json.dumps({"s": s_k.tolist(), "xyz": xyz.tolist(), "vel": vel.tolist(),
                                "start_wall_s": 2.0}))
    port = free_port()
    rx = DisReceiver(f"udp://127.0.0.1:{port}", frame, wait_start=True)
    proc = subprocess.Popen([sys.executable, "-c", MISSILE_SENDER, str(port), str(path),
                             str(ROOT / "examples")])
    try:
        bus = CaptureBus()
        sim = Simulation(sc_dis, bus=bus, seed=7, realtime=1.0, entities=rx,
                         tables=load_scene_tables(sc_dis))
        summary = sim.run()
    finally:
        proc.kill()
        proc.wait(10)
        rx.close()
    assert summary["live"]["entities"] == 1 and summary["live"]["source"]["dropped"] == 0
    assert summary["realtime_factor"] == pytest.approx(1.0, abs=0.15)
    h2, n2 = summary["target_plots"], summary["dwells"]
    p1_, p2_ = hits / looks, h2 / n2
    p = (hits + h2) / (looks + n2)
    se = np.sqrt(p * (1 - p) * (1 / looks + 1 / n2))
    assert abs(p1_ - p2_) < stats.norm.isf(0.0005) * se, (hits, looks, h2, n2)
    # the truth topic has the missile on the demo's path (the run's clock follows the
    # sender's Start/Resume: within 1 s of flight, 240 m, along the path)
    tt = [(t, q) for t, q in bus.of(b"truth") if q["kind"] == "targets"]
    for t, q in tt:
        want = p0 + t * v
        off = np.array([q["east_m"][0], q["north_m"][0]]) - want[:2]
        across = abs(off[0] * v[1] - off[1] * v[0]) / np.hypot(v[0], v[1])
        assert across < 5.0 and np.hypot(*off) < 240.0
    z_r, z_a = _z_errors(bus)
    n = z_r.size
    assert n >= 8
    for z in (z_r, z_a):
        assert abs(z.mean()) < 4.0 / np.sqrt(n)
        assert z.std() == pytest.approx(1.0, abs=5.0 / np.sqrt(2 * n))
        assert stats.kstest(z, "norm").pvalue > 1e-3


def _run_beside_sender(rx, port, sender_args, scene):
    """Run ``scene`` at the wall clock's pace on ``rx`` while examples/dis_sender.py (8 s,
    ``sender_args``) sends to ``port`` from its own process: (summary, wall seconds, bus)."""
    proc = subprocess.Popen([sys.executable, str(SENDER), "--port", str(port), "--seconds",
                             "8", *sender_args])
    try:
        assert rx.first_entity.wait(30.0)
        bus = CaptureBus()
        sim = Simulation(parse_scenario(scene), bus=bus, realtime=1.0, entities=rx)
        t0 = time.monotonic()
        summary = sim.run()
        wall = time.monotonic() - t0
    finally:
        proc.kill()
        proc.wait(10)
        rx.close()
    return summary, wall, bus


# ------------------------------------------------------------------ orientation dead reckoning
def _level_euler(lat, lon, heading_deg, bank_rad=0.0):
    """DIS Euler angles (psi, theta, phi) of a level body heading ``heading_deg`` with bank
    ``bank_rad``, through scipy's rotations and pymap3d's ENU axes (not the code's)."""
    import pymap3d
    from scipy.spatial.transform import Rotation

    lat, lon, h = np.atleast_1d(lat), np.atleast_1d(lon), np.radians(heading_deg)
    enu = []
    for vec in ((np.sin(h), np.cos(h), 0 * h), (np.cos(h), -np.sin(h), 0 * h),
                (0 * h, 0 * h, -1 + 0 * h)):  # body x forward, y right, z down
        enu.append(np.column_stack(pymap3d.enu2uvw(*vec, lat, lon)))
    mats = np.stack(enu, axis=2)  # columns: the body axes in ECEF
    rot = Rotation.from_matrix(mats) * Rotation.from_rotvec(
        np.column_stack([np.broadcast_to(bank_rad, lat.shape), 0 * lat, 0 * lat]))
    return rot.as_euler("ZYX")  # intrinsic yaw, pitch, roll: DIS's psi, theta, phi


def test_a_constant_yaw_rate_turns_the_heading_linearly():
    """Closed form: a level body (any bank φ) turning at Ω about the vertical has body rates
    Ω (0, sin φ, cos φ); IEEE 1278.1's rotation by ω Δt (scipy's, about the body-fixed axis)
    then heads it h0 + Ω t (pymap3d's ENU: to 1e-8 deg over 20 s), and the code's heading rate
    is Ω: h0 + ḣ t is that heading to the code's geocentric-north bounds (1.6e-4 deg on the
    heading, 5.5e-6 relative on its rate)."""
    import pymap3d
    from scipy.spatial.transform import Rotation

    from shipradar.sim.adapters.dis import ecef_heading_deg, ecef_heading_rate_dps

    rng = np.random.default_rng(11)
    lat, lon = rng.uniform(-70, 70, 30), rng.uniform(-180, 180, 30)
    h0, bank = rng.uniform(0, 360, 30), rng.uniform(-0.8, 0.8, 30)
    rate = rng.uniform(-6, 6, 30)  # [deg/s]
    euler = _level_euler(lat, lon, h0, bank)
    xyz = np.column_stack(pymap3d.geodetic2ecef(lat, lon, 0.0))
    omega = np.radians(rate)[:, None] * np.column_stack([0 * bank, np.sin(bank),
                                                         np.cos(bank)])
    got = ecef_heading_rate_dps(xyz, euler, omega)
    assert got == pytest.approx(rate, rel=6e-6)
    r0 = Rotation.from_euler("ZYX", euler)

    def off(a, b):
        return np.abs((a - b + 180.0) % 360.0 - 180.0)

    for t in (1.0, 7.0, 20.0):
        truth = h0 + rate * t
        x = (r0 * Rotation.from_rotvec(omega * t)).as_matrix()[:, :, 0]
        e, n, _ = pymap3d.uvw2enu(x[:, 0], x[:, 1], x[:, 2], lat, lon)
        assert off(np.degrees(np.arctan2(e, n)), truth).max() < 1e-8
        code = ecef_heading_deg(xyz, euler[:, :2]) + got * t
        assert (off(code, truth) <= 1.6e-4 + 5.5e-6 * np.abs(rate) * t + 1e-9).all()


def test_the_heading_rate_is_the_rotations_derivative():
    """A second method for any orientation and angular velocity: the heading of scipy's
    rotation by ω Δt (body-fixed), differentiated numerically (±1 ms), is
    ``ecef_heading_rate_dps``."""
    from scipy.spatial.transform import Rotation

    from shipradar.sim.adapters.dis import ecef_heading_deg, ecef_heading_rate_dps

    rng = np.random.default_rng(12)
    n = 40
    lat, lon = rng.uniform(-70, 70, n), rng.uniform(-180, 180, n)
    xyz = np.column_stack(geodesy.geodetic2ecef(lat, lon, rng.uniform(0, 1e4, n)))
    euler = np.column_stack([rng.uniform(-np.pi, np.pi, n), rng.uniform(-1.2, 1.2, n),
                             rng.uniform(-np.pi, np.pi, n)])
    omega = rng.normal(0, 0.3, (n, 3))
    r0 = Rotation.from_euler("ZYX", euler)

    def heading(t):
        return ecef_heading_deg(xyz, (r0 * Rotation.from_rotvec(omega * t)).as_euler("ZYX")[:, :2])

    d = (heading(1e-3) - heading(-1e-3) + 180.0) % 360.0 - 180.0
    assert ecef_heading_rate_dps(xyz, euler, omega) == pytest.approx(d / 2e-3, rel=1e-5,
                                                                       abs=1e-6)


def test_a_ridden_platform_turns_with_its_entity():
    """``platforms[].dis_entity`` on an entity whose state has heading 350° turning at
    3°/s: its heading is 350 + 3 t (mod 360) until the entity leaves, then held."""
    from shipradar.sim.world.live import RiddenPlatforms
    from shipradar.sim.world.trajectory import trajectories

    scene = parse_scenario(_scene())
    ent = LiveTargets(scene)
    rows = {"id": ["1:1:1"], "time_s": [2.0], "east_m": [0.0], "north_m": [0.0], "up_m": [0.0],
            "v_east_mps": [0.0], "v_north_mps": [5.0], "v_up_mps": [0.0],
            "heading_deg": [350.0], "heading_rate_dps": [3.0], "active": [True]}
    ent.apply(check_states(rows, ent.bad), 2.0)
    ridden = RiddenPlatforms(trajectories(scene.platforms, FRAME, hold=True), ent,
                             {0: "1:1:1"})
    assert ridden.heading_deg(0, 1.0) is None
    for t in (2.0, 4.0, 10.0):
        assert ridden.heading_deg(0, t) == pytest.approx((350.0 + 3.0 * (t - 2.0)) % 360.0)
    # the entity leaves 12 s after its state (the timeout): held after
    assert ridden.heading_deg(0, 30.0) == pytest.approx((350.0 + 3.0 * 12.0) % 360.0)
