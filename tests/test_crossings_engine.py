"""The engine's looks on hard scenes against an independent root finder (issue 37).

Each scene runs through :class:`~shipradar.sim.engine.simulation.Simulation`; every look the
dwell model makes (``DwellModel.on_look``) is compared with every crossing found here
independently: the beam β(t) = β0 + ω t (clockwise from the radar's start azimuth) against
the target's azimuth from the moving antenna, computed on the ellipsoid by pymap3d from the
trajectories rebuilt from the scenario, sign changes on a 1 ms grid polished by brentq.
Crossings less than a dwell θ_b/ω apart are one look (the first), as the engine counts them.
"""

import math

import numpy as np
import pymap3d
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream import protocol
from shipradar.sim.world.kinematics import LocalFrame, wrap_pi
from shipradar.sim.world.trajectory import trajectories
from shipradar.tables.scene import SceneTables

from .helpers import CaptureBus, bare_scene, quiet_radar

MACH = 340.0


def _line(i, p0, v, duration, alt=20.0):
    p1 = (p0[0] + v[0] * duration, p0[1] + v[1] * duration)
    return {"id": f"t{i}", "waypoints": [
        {"time_s": 0, "east_m": p0[0], "north_m": p0[1], "altitude_m": alt},
        {"time_s": duration, "east_m": p1[0], "north_m": p1[1], "altitude_m": alt}],
        "rcs": {"type": "constant", "sigma_m2": 10.0}, "swerling": 0}


def _circle(i, radius, speed, direction, duration):
    """A circle round the origin from its south point, heading east: 'left' turns
    counter-clockwise (against the beam), 'right' ... from its north point, clockwise."""
    north = -radius if direction == "left" else radius
    return {"id": f"t{i}", "speed_mps": speed, "heading_deg": 90.0,
            "waypoints": [{"time_s": 0, "east_m": 0.0, "north_m": north, "altitude_m": 20.0}],
            "segments": [{"type": "turn", "turn_rate_deg_s": math.degrees(speed / radius),
                          "duration_s": duration, "direction": direction}],
            "rcs": {"type": "constant", "sigma_m2": 10.0}, "swerling": 0}


def _scene(targets, rpm, start_deg, duration, ship=None):
    radar = quiet_radar(rotation_rpm=rpm, start_azimuth_deg=start_deg,
                        false_alarm_time_s=1e6, instrumented_range_m=60000)
    s = bare_scene(radar=radar, targets=targets, duration_s=duration)
    if ship is not None:
        plat = {"id": "ship", "waypoints": ship, "radars": [s.platforms[0].radars[0].model_dump()]}
        s = s.model_copy(update={"platforms": [type(s.platforms[0]).model_validate(plat)]})
    return s


def _run(s):
    sim = Simulation(s, bus=CaptureBus(), tables=SceneTables())
    looks = []
    sim.radars[0].model.on_look.append(looks.append)
    sim.run()
    target = np.concatenate([lk.target for lk in looks])
    time = np.concatenate([lk.time_s for lk in looks])
    return sim, target, time


class Reference:
    """Target azimuths from the antenna by pymap3d on the ellipsoid."""

    def __init__(self, s):
        self.frame = LocalFrame(s.origin)
        self.tg = trajectories(s.targets, self.frame, hold=False)
        self.sp = trajectories(s.platforms, self.frame, hold=True)
        self.h_ant = s.platforms[0].radars[0].antenna_height_m

    def azimuth(self, t, i):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        tpos, _, _ = self.tg.state(t, np.full(t.size, i))
        spos, _, _ = self.sp.state(t, np.zeros(t.size, dtype=int))
        lat_t, lon_t, h_t = self.frame.geodetic(tpos)
        lat_s, lon_s, h_s = self.frame.geodetic(spos + [0.0, 0.0, self.h_ant])
        az, _, _ = pymap3d.geodetic2aer(lat_t, lon_t, h_t, lat_s, lon_s, h_s)
        return np.radians(az)

    def crossings(self, i, beam0, omega, duration, separation, step=1e-3):
        def f(t):
            return float(wrap_pi(beam0 + omega * t - self.azimuth(t, i)[0]))

        grid = np.arange(0.0, duration + step, step)
        vals = wrap_pi(beam0 + omega * grid - self.azimuth(grid, i))
        a, b = vals[:-1], vals[1:]
        roots = list(grid[:-1][a == 0.0])
        for k in np.flatnonzero((a * b < 0.0) & (np.abs(a) < 1.5) & (np.abs(b) < 1.5)):
            roots.append(brentq(f, grid[k], grid[k + 1], xtol=1e-12, rtol=1e-15))
        kept = []
        for r in sorted(r for r in roots if r < duration):
            if not kept or r - kept[-1] >= separation:
                kept.append(r)
        return np.array(kept)


def _compare(s, tol_s=1e-5):
    sim, target, time = _run(s)
    radar = s.platforms[0].radars[0]
    omega = 2 * math.pi / radar.scan_period_s
    beam0 = math.radians(radar.start_azimuth_deg)
    ref = Reference(s)
    worst, total = 0.0, 0
    for i in range(len(s.targets)):
        want = ref.crossings(i, beam0, omega, s.duration_s,
                             math.radians(radar.beamwidth_az_deg) / omega)
        got = np.sort(time[target == i])
        assert got.size == want.size, (s.targets[i].id, got, want)
        if got.size:
            worst = max(worst, float(np.max(np.abs(got - want))))
        total += got.size
    assert worst < tol_s
    return sim, worst, total


FAST = [_line(0, (-20000.0, 1000.0), (3 * MACH, 0.0), 40.0),     # with the beam, at north
        _line(1, (20000.0, 2500.0), (-2 * MACH, 0.0), 40.0),     # against it, at north
        _line(2, (-15000.0, -1500.0), (2.5 * MACH, 0.0), 40.0),  # against it, south
        _line(3, (1200.0, -20000.0), (0.0, 3 * MACH), 40.0),     # north-bound, 1.2 km east
        _line(4, (-2500.0, 20000.0), (0.0, -2 * MACH), 40.0),    # south-bound, 2.5 km west
        _line(5, (-16000.0, 30.0), (2 * MACH, 0.0), 40.0)]       # a 30 m overflight
CIRCLES = [_circle(0, 2000.0, 2 * MACH, "left", 40.0),   # against the beam
           _circle(1, 3000.0, 2 * MACH, "right", 40.0),  # with it, slower at 6 rpm
           _circle(2, 1000.0, 3 * MACH, "right", 40.0)]  # with it, faster at 6 rpm
NORTH = [_line(0, (-3000.0, 30000.0), (300.0, 0.0), 40.0),
         _line(1, (3000.0, 20000.0), (-300.0, 0.0), 40.0),
         _line(2, (-20000.0, 2000.0), (2 * MACH, 0.0), 40.0),
         _line(3, (20000.0, 800.0), (-2 * MACH, 0.0), 40.0)]


def _square(speed, leg_s, laps_s):
    """A ship making 90° corners: north, east, south, west legs of ``leg_s``."""
    pts, p, t = [], np.zeros(2), 0.0
    dirs = [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0)]
    k = 0
    while t <= laps_s:
        pts.append({"time_s": t, "east_m": float(p[0]), "north_m": float(p[1])})
        p = p + speed * leg_s * np.array(dirs[k % 4])
        t += leg_s
        k += 1
    return pts


@pytest.mark.slow
@pytest.mark.parametrize("name, targets", [("fast", FAST), ("circles", CIRCLES),
                                           ("north", NORTH)])
@pytest.mark.parametrize("rpm, start_deg, duration", [(6.0, 183.35, 40.0), (60.0, 0.0, 8.0)])
def test_every_look_of_a_hard_scene_is_a_crossing_found_independently(
        name, targets, rpm, start_deg, duration):
    _, worst, total = _compare(_scene(targets, rpm, start_deg, duration))
    assert total > 0


@pytest.mark.slow
@pytest.mark.parametrize("rpm", [6.0, 60.0])
def test_looks_from_a_ship_making_90_degree_corners(rpm):
    targets = [_line(0, (800.0, 900.0), (0.0, 0.0), 40.0),
               _line(1, (-15000.0, 500.0), (MACH, 20.0), 40.0),
               _circle(2, 1500.0, 2 * MACH, "left", 40.0)]
    duration = 40.0 if rpm == 6.0 else 10.0
    _compare(_scene(targets, rpm, 45.0, duration, ship=_square(40.0, 5.0, 40.0)))


def _beam_miss(s, bus):
    radar = s.platforms[0].radars[0]
    omega = 2 * math.pi / radar.scan_period_s
    beam0 = math.radians(radar.start_azimuth_deg)
    misses = []
    for (_, p), (_, tr) in zip(bus.of(protocol.TOPIC_PLOTS),
                               [m for m in bus.of(protocol.TOPIC_TRUTH)
                                if m[1]["kind"] == "plots"], strict=True):
        alone = np.diff(tr["contrib_offsets"]) == 1
        beam = beam0 + omega * np.asarray(p["time_s"])
        miss = wrap_pi(beam - np.asarray(tr["true_azimuth_rad"]))
        misses.append(miss[alone & (np.asarray(tr["target"]) >= 0)])
    return np.concatenate(misses) if misses else np.zeros(0)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31 - 1), rpm=st.sampled_from([6.0, 12.0, 13.0, 60.0]),
       start=st.floats(0.0, 359.99))
def test_the_beam_points_at_every_target_plot(seed, rpm, start):
    """A random scene of close fast targets: at every single-target plot's ``time_s`` the
    beam's azimuth equals the truth's azimuth of its target to 1 µrad."""
    rng = np.random.default_rng(seed)
    duration = 3 * 60.0 / rpm
    targets = []
    for i in range(8):
        r, a = rng.uniform(800.0, 4000.0), rng.uniform(0, 2 * math.pi)
        speed, heading = rng.uniform(0.0, 3 * MACH), rng.uniform(0, 2 * math.pi)
        p0 = (r * math.sin(a), r * math.cos(a))
        targets.append(_line(i, p0, (speed * math.sin(heading), speed * math.cos(heading)),
                             duration))
    s = _scene(targets, rpm, start, duration,
               ship=[{"time_s": 0, "east_m": 0, "north_m": 0},
                     {"time_s": duration, "east_m": 12.0 * duration, "north_m": 0.0}])
    bus = CaptureBus()
    Simulation(s, bus=bus, tables=SceneTables()).run()
    miss = _beam_miss(s, bus)
    assert miss.size
    assert np.max(np.abs(miss)) < 1e-6
