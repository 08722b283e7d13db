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


def _scene() -> dict:
    return {"name": "dis", "duration_s": 3.0, "seed": 3,
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
    proc = subprocess.Popen([sys.executable, str(SENDER), "--port", str(port), "--seconds",
                             "8", "--freeze-at", "1.5", "--resume-at", "2.5"])
    try:
        assert rx.first_entity.wait(30.0)
        bus = CaptureBus()
        sim = Simulation(parse_scenario(_scene()), bus=bus, realtime=1.0, entities=rx)
        t0 = time.monotonic()
        summary = sim.run()
        wall = time.monotonic() - t0
    finally:
        proc.kill()
        proc.wait(10)
        rx.close()
    src = summary["live"]["source"]
    assert src["freezes"] == 1
    assert src["frozen_s"] == pytest.approx(1.0, abs=0.4)
    assert wall == pytest.approx(3.0 + src["frozen_s"], abs=0.5)
    assert summary["live"]["entities"] == 3
    assert summary["target_plots"] >= 2
    assert bus.of(b"entities")
