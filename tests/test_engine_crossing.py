"""The engine's plot times against an analytic rotation, with a moving ship and moving targets.

Every target plot must be timed when the beam, turning at β(t) = β0 + 2π t / T from the
radar's start azimuth, points at the target's true azimuth from the antenna at that instant
(computed here independently on the ellipsoid with pymap3d), be detected once per scan, and
leave in the frame of the sector in which the beam made it.
"""

import math

import numpy as np
import pymap3d
import pytest

from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream import protocol
from shipradar.sim.world.kinematics import LocalFrame, Trajectories, waypoint_enu
from shipradar.tables.scene import SceneTables

from .helpers import CaptureBus, bare_scene, quiet_radar


def _target(i, p0, v, duration):
    p1 = (p0[0] + v[0] * duration, p0[1] + v[1] * duration)
    return {"id": f"t{i}", "waypoints": [
        {"time_s": 0, "east_m": p0[0], "north_m": p0[1], "altitude_m": 50.0},
        {"time_s": duration, "east_m": p1[0], "north_m": p1[1], "altitude_m": 50.0}],
        "rcs": {"type": "constant", "sigma_m2": 1e4}, "swerling": 0}


@pytest.mark.parametrize("rpm, start_deg, sectors", [(60.0, 0.0, 36), (12.0, 137.0, 8)])
def test_plot_times_follow_the_analytic_rotation(rpm, start_deg, sectors):
    duration = 3.0 * 60.0 / rpm + 0.5  # three whole scans and part of a fourth
    rng = np.random.default_rng(11)
    targets = [_target(i, rng.uniform(-25e3, 25e3, 2), rng.uniform(-300, 300, 2), duration)
               for i in range(12)]
    radar = quiet_radar(rotation_rpm=rpm, start_azimuth_deg=start_deg, false_alarm_time_s=1e6,
                        instrumented_range_m=60000)
    s = bare_scene(radar=radar, targets=targets, duration_s=duration, sectors_per_scan=sectors)
    ship = {"id": "ship", "waypoints": [{"time_s": 0, "east_m": 0, "north_m": 0},
                                        {"time_s": duration, "east_m": 8.0 * duration,
                                         "north_m": -12.0 * duration}],
            "radars": [s.platforms[0].radars[0].model_dump()]}
    s = s.model_copy(update={"platforms": [type(s.platforms[0]).model_validate(ship)]})
    bus = CaptureBus()
    summary = Simulation(s, bus=bus, tables=SceneTables()).run()
    frame = LocalFrame(s.origin)
    tg = Trajectories([waypoint_enu(t.waypoints, frame) for t in s.targets], hold=False)
    sp = Trajectories([waypoint_enu(p.waypoints, frame) for p in s.platforms], hold=True)
    period = 60.0 / rpm
    omega = 2 * math.pi / period
    beam0 = math.radians(start_deg)
    plots = bus.of(protocol.TOPIC_PLOTS)
    truth = [(t, p) for t, p in bus.of(protocol.TOPIC_TRUTH) if p["kind"] == "plots"]
    assert len(plots) == len(truth)
    seen = {}
    for (t_msg, p), (_, tr) in zip(plots, truth, strict=True):
        assert np.array_equal(p["plot_id"], tr["plot_id"])
        times = p["time_s"]
        # the frame leaves at the end of the sector holding every one of its plots
        sector = period / sectors
        # (a crossing within 1 µs before a revolution starts belongs to that revolution)
        assert np.all(times <= t_msg + 1e-9) and np.all(times > t_msg - sector - 2e-6)
        for k in range(times.size):
            i, t = int(tr["target"][k]), float(times[k])
            assert i >= 0  # no false alarms here
            tpos, _, active = tg.state(t, np.array([i]))
            spos, _, _ = sp.state(t, np.array([0]))
            assert active[0]
            lat_t, lon_t, h_t = frame.geodetic(tpos)
            lat_s, lon_s, h_s = frame.geodetic(spos + [0.0, 0.0, radar["antenna_height_m"]])
            az, _, _ = pymap3d.geodetic2aer(lat_t[0], lon_t[0], h_t[0],
                                            lat_s[0], lon_s[0], h_s[0])
            beam = (beam0 + omega * t) % (2 * math.pi)
            miss = (math.radians(az) - beam + math.pi) % (2 * math.pi) - math.pi
            assert abs(miss) < 2e-5, (i, t, miss)  # 0.001 deg; the beam is 2 deg wide
            seen.setdefault(i, []).append(t)
    # every target in range is seen once per revolution, one period apart (within the time
    # its own angular motion takes)
    assert len(seen) >= 10
    for times in seen.values():
        assert len(times) in (3, 4)
        gaps = np.diff(times)
        assert np.all(np.abs(gaps - period) < 0.2 * period)
    assert summary["target_plots"] == sum(len(v) for v in seen.values())


def _skeleton(bus):
    """What does not depend on the random draws: topics, times, sensors, scans, targets."""
    out = []
    for top, t, p in bus.messages:
        row = [top, t, p.get("sensor"), p.get("scan")]
        if top == protocol.TOPIC_TRUTH and p["kind"] == "plots":
            row.append(sorted(p["target"].tolist()))
        out.append(row)
    return out


def test_block_of_revolutions_changes_no_frame(monkeypatch):
    """Revolutions computed one at a time or eight at once: the same frames at the same
    times with the same targets (stationary ones included: never merged across scans)."""
    from shipradar.sim.engine import simulation as engine

    targets = [_target(i, p, v, 20.0) for i, (p, v) in enumerate([
        ((0.0, 20e3), (0.0, 0.0)), ((15e3, -5e3), (0.0, 0.0)), ((-9e3, 9e3), (120.0, -80.0))])]
    radar = quiet_radar(rotation_rpm=60.0, false_alarm_time_s=1e6)
    s = bare_scene(radar=radar, targets=targets, duration_s=9.5)
    runs = []
    for block_s in (0.5, 8.0):
        monkeypatch.setattr(engine, "_BLOCK_S", block_s)
        bus = CaptureBus()
        summary = Simulation(s, bus=bus, tables=SceneTables()).run()
        runs.append((_skeleton(bus), summary))
    assert runs[0][0] == runs[1][0]
    # 9.5 revolutions: 9 or 10 crossings each; the due-north target is on the start azimuth,
    # met at every revolution's start, t = 0 included (where the rounding puts the crossing
    # at -2e-15 s, before the target exists: taken at 0)
    assert runs[0][1]["target_plots"] == runs[1][1]["target_plots"] == 10 + 10 + 9
