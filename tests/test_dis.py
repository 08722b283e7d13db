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
