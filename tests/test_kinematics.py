"""Kinematics and geometry against independent computations; exact beam-crossing times."""

import math

import numpy as np
import pymap3d
import pymap3d.vincenty
import pytest
from scipy.optimize import brentq

from shipradar.sensors.geometry import EARTH_RADIUS_M, K_FACTOR, slant_range_elevation
from shipradar.sim.world.kinematics import (
    LocalFrame,
    Trajectories,
    antenna_geometry,
    ship_motion,
    waypoint_enu,
    wrap_pi,
)
from shipradar.sim.world.scenario import Origin, Waypoint

from .helpers import first_crossings

ORIGIN = Origin(lat_deg=44.6, lon_deg=-63.0)
FRAME = LocalFrame(ORIGIN)


def _traj(points, hold):
    return Trajectories([np.array(p, dtype=float) for p in points], hold=hold)


def test_piecewise_linear_state():
    tr = _traj([[(0, 0, 0, 10), (10, 100, 0, 10), (20, 100, 200, 30)],
                [(5, 0, 0, 0)]], hold=False)
    pos, vel, act = tr.state(np.array([15.0, 5.0]))
    assert pos[0] == pytest.approx([100, 100, 20])
    assert vel[0] == pytest.approx([0, 20, 2])
    assert act.tolist() == [True, True]
    pos, vel, act = tr.state(25.0)
    assert act.tolist() == [False, False]  # targets exist only within their waypoint times
    plat = _traj([[(0, 0, 0, 0), (10, 50, 0, 0)]], hold=True)
    pos, vel, act = plat.state(30.0)
    assert pos[0] == pytest.approx([50, 0, 0]) and vel[0] == pytest.approx([0, 0, 0]) and act[0]


def test_latlon_waypoints_round_trip():
    w = [Waypoint(time_s=0, lat_deg=44.7, lon_deg=-62.9, altitude_m=5)]
    enu = waypoint_enu(w, FRAME)
    lat, lon, _ = pymap3d.enu2geodetic(enu[0, 1], enu[0, 2], 0, 44.6, -63.0, 0)
    # the tangent-plane up offset is dropped (east/north are map coordinates): ~3 cm here
    assert (lat, lon) == pytest.approx((44.7, -62.9), abs=1e-6)


def test_azimuth_and_range_against_pymap3d():
    rng = np.random.default_rng(3)
    ant = np.array([30e3, -20e3, 0.0])
    tgt = np.column_stack([rng.uniform(-150e3, 150e3, 50), rng.uniform(-150e3, 150e3, 50),
                           rng.uniform(0, 5000, 50)])
    g = antenna_geometry(ant, np.zeros(3), 20.0, tgt, np.zeros_like(tgt), FRAME)
    lat_a, lon_a, _ = FRAME.geodetic(ant[None, :])
    lat_t, lon_t, _ = FRAME.geodetic(tgt)
    # the geodesic on the ellipsoid (Vincenty) as the independent reference: the sphere
    # osculating at the origin gives bearings within 0.01° and distances within 0.05 %
    dist, az = pymap3d.vincenty.vdist(lat_a[0], lon_a[0], lat_t, lon_t)
    assert np.degrees(np.abs(wrap_pi(g.azimuth - np.radians(az)))).max() < 0.01
    assert g.ground_range == pytest.approx(np.asarray(dist), rel=5e-4)


def test_slant_range_closed_forms():
    a_e = K_FACTOR * EARTH_RADIUS_M
    d = np.array([1e3, 50e3, 300e3])
    slant, elev = slant_range_elevation(d, 0.0, 0.0)
    gamma = d / a_e
    assert slant == pytest.approx(2 * a_e * np.sin(gamma / 2), rel=1e-12)
    assert elev == pytest.approx(-gamma / 2, rel=1e-9)
    s, e = slant_range_elevation(0.0, 10.0, 110.0)  # straight up
    assert s == pytest.approx(100.0) and e == pytest.approx(math.pi / 2)
    # flat-earth limit at short range
    s, e = slant_range_elevation(1000.0, 20.0, 520.0)
    assert s == pytest.approx(math.hypot(1000, 500), rel=1e-4)
    assert e == pytest.approx(math.atan2(500, 1000), abs=2e-4)


@pytest.mark.parametrize("rpm", [6.0, 60.0])
def test_beam_crossing_exact_moving_ship_and_targets(rpm):
    ship = _traj([[(0, 0, 0, 0), (600, 0, 6000, 0)]], hold=True)  # 10 m/s north
    rng = np.random.default_rng(1)
    n = 40
    tracks = []
    for _ in range(n):
        p0 = rng.uniform(-20e3, 20e3, 2)
        v = rng.uniform(-300, 300, 2)
        tracks.append([(0, *p0, 5.0), (600, *(p0 + 600 * v), 5.0)])
    tg = _traj(tracks, hold=False)
    omega = rpm / 60 * 2 * math.pi

    def az_at(t, rows=None):
        rows = np.arange(n) if rows is None else rows
        tp, tv, _ = tg.state(t, rows)
        sp, sv, _ = ship.state(t, np.zeros(rows.size, dtype=int))
        return antenna_geometry(sp, sv, 25.0, tp, tv, FRAME).azimuth

    def geometry_at(t, rows):
        tp, tv, _ = tg.state(t, rows)
        sp, sv, _ = ship.state(t, np.zeros(rows.size, dtype=int))
        g = antenna_geometry(sp, sv, 25.0, tp, tv, FRAME)
        return g.azimuth, g.ground_range

    t_start, beam0 = 37.3, 1.1
    tc = first_crossings(geometry_at, t_start, beam0, omega, n, 10.0 + 300 * math.sqrt(2))
    period = 2 * math.pi / omega
    assert np.all(tc >= t_start - 1e-9) and np.all(tc < t_start + 1.5 * period)
    for i in range(n):
        def f(t, i=i):
            return wrap_pi(az_at(np.array([t]), np.array([i]))[0] - (beam0 + omega * (t - t_start)))

        root = brentq(f, tc[i] - 0.05 * period, tc[i] + 0.05 * period, xtol=1e-12)
        assert tc[i] == pytest.approx(root, abs=1e-7)


def test_beam_crossing_flat_analytic():
    """Short ranges near the origin: a flat-earth analytic rotation gives the same times."""
    ship_v = np.array([3.0, 8.0])
    tgt_p0, tgt_v = np.array([2000.0, -1500.0]), np.array([-250.0, 100.0])
    ship = _traj([[(0, 0, 0, 0), (100, *(100 * ship_v), 0)]], hold=True)
    tg = _traj([[(0, *tgt_p0, 10.0), (100, *(tgt_p0 + 100 * tgt_v), 10.0)]], hold=False)
    omega = 2 * math.pi / 2.5

    def az_flat(t):
        d = tgt_p0 + tgt_v * t - ship_v * t
        return math.atan2(d[0], d[1])

    def geometry_at(t, rows):
        tp, tv, _ = tg.state(t)
        sp, sv, _ = ship.state(t, np.zeros(1, dtype=int))
        g = antenna_geometry(sp, sv, 0.0, tp, tv, FRAME)
        return g.azimuth, g.ground_range

    tc = first_crossings(geometry_at, 10.0, 0.0, omega, 1, 300.0)[0]
    root = brentq(lambda t: wrap_pi(az_flat(t) - omega * (t - 10.0)), tc - 0.2, tc + 0.2)
    # flat frame vs ellipsoid: meridian convergence a few 1e-3 deg at 2.5 km
    assert tc == pytest.approx(root, abs=2e-4)


def test_radial_velocity_sign():
    ant = np.zeros(3)
    tgt = np.array([[0.0, 10e3, 10.0]])
    g = antenna_geometry(ant, np.zeros(3), 20, tgt, np.array([[0.0, -300.0, 0.0]]), FRAME)
    assert g.radial_velocity[0] == pytest.approx(-300.0, rel=1e-4)  # closing: negative


@pytest.mark.parametrize("hold", [False, True])
def test_one_segment_fast_path_equals_the_general_search(hold):
    """Trajectories of at most two waypoints skip the segment search: same numbers."""
    rng = np.random.default_rng(2)
    tracks = [[(0, 0, 0, 5)]]  # a single waypoint
    for _ in range(30):
        t0 = rng.uniform(0, 50)
        tracks.append([(t0, *rng.uniform(-1e4, 1e4, 3)), (t0 + rng.uniform(1, 100),
                                                          *rng.uniform(-1e4, 1e4, 3))])
    fast = _traj(tracks, hold=hold)
    slow = _traj(tracks, hold=hold)
    slow._one_segment = False
    assert fast._one_segment
    rows = rng.integers(0, len(tracks), 200)
    for t in (rng.uniform(-10, 200, 200), 37.5):
        for r in (rows, None):
            tt = t if r is not None or np.isscalar(t) else t[: len(tracks)]
            for a, b in zip(fast.state(tt, r), slow.state(tt, r), strict=True):
                np.testing.assert_array_equal(a, b)


def test_ship_motion_first_leg():
    """Speed and course of the first leg; a stationary ship (or a geodetic leg) keeps its
    heading and speed 0."""
    from types import SimpleNamespace

    leg = [Waypoint(time_s=0.0, east_m=0.0, north_m=0.0),
           Waypoint(time_s=100.0, east_m=300.0, north_m=-400.0),
           Waypoint(time_s=200.0, east_m=0.0, north_m=0.0)]
    speed, course = ship_motion(SimpleNamespace(waypoints=leg, heading_deg=10.0))
    assert speed == pytest.approx(5.0, rel=1e-12)
    assert course == pytest.approx(math.atan2(300.0, -400.0) % (2 * math.pi), rel=1e-12)
    still = SimpleNamespace(waypoints=leg[:1], heading_deg=30.0)
    assert ship_motion(still) == (0.0, pytest.approx(math.radians(30.0), rel=1e-12))
    geo = [Waypoint(time_s=0.0, lat_deg=45.0, lon_deg=-63.0),
           Waypoint(time_s=60.0, lat_deg=45.01, lon_deg=-63.0)]
    assert ship_motion(SimpleNamespace(waypoints=geo, heading_deg=90.0))[0] == 0.0
