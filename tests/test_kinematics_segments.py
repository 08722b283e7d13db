"""Manoeuvre segments and rounded corners against closed forms; joins; exact beam crossings.

Each check holds a number the kinematics could get wrong: the turn radius v²/(g n) and rate
g n / v, the weave's lateral excursion and constant speed, the pop-up apex, position and
velocity continuity at every join, velocity = d(position)/dt and acceleration = d(velocity)/dt
inside the pieces (the closed forms integrate each other), and the beam-crossing time of a
turning target against a brute-force fine-step search.
"""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from shipradar.sim.world.kinematics import (
    LocalFrame,
    Trajectories,
    antenna_azimuth,
    wrap_pi,
)
from shipradar.sim.world.scenario import STANDARD_GRAVITY as G
from shipradar.sim.world.scenario import Origin, Target
from shipradar.sim.world.trajectory import object_pieces, trajectories

from .helpers import first_crossings, quiet_radar

FRAME = LocalFrame(Origin(lat_deg=44.6, lon_deg=-63.0))


def _target(segments, speed=250.0, heading=90.0, alt=100.0, **extra):
    return Target.model_validate({
        "id": "t", "rcs": {"type": "constant", "sigma_m2": 1.0}, "heading_deg": heading,
        "speed_mps": speed, "waypoints": [{"time_s": 0, "east_m": 0, "north_m": 0,
                                           "altitude_m": alt}],
        "segments": segments, **extra})


def _traj(obj, hold=False):
    return Trajectories(None, hold=hold, pieces=[object_pieces(obj, FRAME)])


def _eval(tr, t):
    t = np.atleast_1d(np.asarray(t, dtype=float))
    pos, vel, acc, act = tr.state_acc(t, np.zeros(t.size, dtype=int))
    return pos, vel, acc, act


@pytest.mark.parametrize("n_g, speed", [(4.0, 250.0), (1.0, 120.0), (9.0, 600.0)])
def test_turn_radius_and_rate(n_g, speed):
    tg = _target([{"type": "turn", "turn_g": n_g, "to_heading_deg": 270.0,
                   "direction": "right"}], speed=speed)
    tr = _traj(tg)
    radius = speed**2 / (G * n_g)
    rate = G * n_g / speed
    assert tr.t_last[0] == pytest.approx(math.pi / rate, rel=1e-12)
    t = np.linspace(0.0, math.pi / rate, 101)
    pos, vel, acc, _ = _eval(tr, t)
    # heading east, turning right (clockwise): the centre is R south of the start
    centre = np.array([0.0, -radius])
    assert np.hypot(*(pos[:, :2] - centre).T) == pytest.approx(radius, rel=1e-10)
    assert np.hypot(vel[:, 0], vel[:, 1]) == pytest.approx(speed, rel=1e-12)
    heading = np.unwrap(np.arctan2(vel[:, 0], vel[:, 1]))
    assert np.diff(heading) / np.diff(t) == pytest.approx(rate, rel=1e-9)
    assert np.hypot(acc[:, 0], acc[:, 1]) == pytest.approx(n_g * G, rel=1e-12)
    assert pos[-1, :2] == pytest.approx([0.0, -2 * radius], abs=1e-6 * radius)
    assert pos[:, 2] == pytest.approx(100.0)


def test_weave_amplitude_speed_and_return():
    amp, period, speed = 150.0, 6.0, 290.0
    tg = _target([{"type": "straight", "duration_s": 2.0},
                  {"type": "weave", "amplitude_m": amp, "period_s": period,
                   "duration_s": 3 * period, "first_side": "left"},
                  {"type": "straight", "duration_s": 2.0}], speed=speed, heading=0.0)
    tr = _traj(tg)
    t = np.linspace(2.0, 2.0 + 3 * period, 3001)
    pos, vel, _, _ = _eval(tr, t)
    # heading north, first to the left (west): lateral offset -A (1 - cos 2πτ/P)
    assert pos[:, 0].min() == pytest.approx(-2 * amp, rel=1e-6)
    assert pos[:, 0].max() == pytest.approx(0.0, abs=1e-9)
    tau = t - 2.0
    assert pos[:, 0] == pytest.approx(-amp * (1 - np.cos(2 * np.pi * tau / period)), abs=1e-9)
    assert np.linalg.norm(vel, axis=1) == pytest.approx(speed, rel=1e-12)
    # back on the entry line and course after whole periods; along-track it has lost the
    # path length of the excursions (E(2π|m) against 2π)
    p_end, v_end, _, _ = _eval(tr, 2.0 + 3 * period)
    assert p_end[0, 0] == pytest.approx(0.0, abs=1e-9)
    assert v_end[0] == pytest.approx([0.0, speed, 0.0], abs=1e-9)
    assert p_end[0, 1] < 2.0 * speed + 3 * period * speed


def test_popup_apex_and_dive():
    tg = _target([{"type": "straight", "duration_s": 1.0},
                  {"type": "popup", "peak_altitude_m": 400.0, "climb_s": 4.0, "dive_s": 3.0,
                   "to_altitude_m": 5.0}], speed=300.0, alt=8.0)
    tr = _traj(tg)
    t = np.linspace(0.0, 8.0, 8001)
    pos, vel, _, _ = _eval(tr, t)
    assert pos[:, 2].max() == pytest.approx(400.0, rel=1e-9)
    assert t[np.argmax(pos[:, 2])] == pytest.approx(5.0, abs=1e-3)
    assert pos[-1, 2] == pytest.approx(5.0, abs=1e-9)
    assert np.linalg.norm(vel, axis=1) == pytest.approx(300.0, rel=1e-12)
    # peak climb rate π Δh / (2 T)
    assert vel[:, 2].max() == pytest.approx(math.pi * 392.0 / 8.0, rel=1e-6)
    assert tg.max_altitude_m == 400.0


CHAIN = [
    {"type": "straight", "duration_s": 3.0},
    {"type": "turn", "turn_g": 4.0, "to_heading_deg": 10.0},
    {"type": "accelerate", "to_speed_mps": 320.0, "accel_g": 2.0},
    {"type": "weave", "amplitude_m": 80.0, "period_s": 5.0, "duration_s": 7.3},
    {"type": "climb", "to_altitude_m": 900.0, "duration_s": 12.0},
    {"type": "turn", "turn_rate_deg_s": 6.0, "duration_s": 5.0, "direction": "left"},
    {"type": "accelerate", "to_speed_mps": 200.0, "duration_s": 4.0},
    {"type": "popup", "peak_altitude_m": 1500.0, "climb_s": 6.0, "dive_s": 9.0},
    {"type": "straight", "duration_s": 2.0},
]


def test_continuity_at_joins_and_closed_forms_integrate_each_other():
    tg = _target(CHAIN, speed=250.0, heading=120.0)
    tr = _traj(tg)
    joins = tr.times[0, 1:tr.count[0]]
    assert joins.size >= len(CHAIN)
    eps = 1e-7
    before = _eval(tr, joins - eps)
    after = _eval(tr, joins + eps)
    # position within what the velocity covers in 2 eps, velocity within what a 10 g
    # acceleration changes in 2 eps
    assert np.abs(before[0] - after[0]).max() < 2 * eps * 400.0
    assert np.abs(before[1] - after[1]).max() < 2 * eps * 10 * G
    # inside the pieces: central differences of position give the velocity, of velocity
    # the acceleration (so the acceleration is continuous there and each closed form is the
    # integral of the next)
    rng = np.random.default_rng(5)
    starts, ends = tr.times[0, :tr.count[0]], tr.times[0, :tr.count[0]] + tr.seg_dt[0, :tr.count[0]]
    h = 1e-4
    for a, b in zip(starts, ends, strict=True):
        t = rng.uniform(a + 2 * h, b - 2 * h, 8)
        p_p, v_p, _, _ = _eval(tr, t + h)
        p_m, v_m, _, _ = _eval(tr, t - h)
        _, v, acc, _ = _eval(tr, t)
        assert (p_p - p_m) / (2 * h) == pytest.approx(v, abs=1e-4)
        assert (v_p - v_m) / (2 * h) == pytest.approx(acc, abs=2e-3)


def test_acceleration_segment_speed_profile():
    tg = _target([{"type": "accelerate", "to_speed_mps": 100.0, "accel_g": 1.5}], speed=250.0)
    tr = _traj(tg)
    dt = 150.0 / (1.5 * G)
    assert tr.t_last[0] == pytest.approx(dt, rel=1e-12)
    t = np.linspace(0, dt, 50)
    pos, vel, acc, _ = _eval(tr, t)
    assert vel[:, 0] == pytest.approx(250.0 - 1.5 * G * t, rel=1e-12)
    assert pos[:, 0] == pytest.approx(250.0 * t - 0.75 * G * t**2, rel=1e-12)
    assert acc[:, 0] == pytest.approx(-1.5 * G)


segment = st.one_of(
    st.builds(lambda d: {"type": "straight", "duration_s": d}, st.floats(0.1, 60)),
    st.builds(lambda g, h, d: {"type": "turn", "turn_g": g, "to_heading_deg": h,
                               "direction": d},
              st.floats(0.1, 30), st.floats(0, 359.9), st.sampled_from(["shortest", "left",
                                                                         "right"])),
    st.builds(lambda r, d, s: {"type": "turn", "turn_rate_deg_s": r, "duration_s": d,
                               "direction": s},
              st.floats(0.1, 40), st.floats(0.1, 60), st.sampled_from(["left", "right"])),
    st.builds(lambda v, g: {"type": "accelerate", "to_speed_mps": v, "accel_g": g},
              st.floats(20, 900), st.floats(0.05, 20)),
    st.builds(lambda f, p, d: {"type": "weave", "amplitude_m": f, "period_s": p,
                               "duration_s": d},
              st.floats(0.01, 0.99), st.floats(0.5, 30), st.floats(0.1, 60)),
    st.builds(lambda z, d: {"type": "climb", "to_altitude_m": z, "duration_s": d},
              st.floats(0, 12000), st.floats(0.1, 100)),
    st.builds(lambda z, c, d: {"type": "popup", "peak_altitude_m": z, "climb_s": c,
                               "dive_s": d},
              st.floats(1, 3000), st.floats(0.5, 60), st.floats(0.5, 60)),
)


def _feasible(chain, speed):
    """Scale weave amplitudes to a fraction of their limit and stretch climbs so that the
    chain validates (the property is about the kinematics, not the schema's refusals)."""
    v, z, out = speed, 100.0, []
    for s in chain:
        s = dict(s)
        if s["type"] == "accelerate":
            v = s["to_speed_mps"]
        elif s["type"] == "weave":
            s["amplitude_m"] = s["amplitude_m"] * v * s["period_s"] / (2 * math.pi)
        elif s["type"] == "climb":
            s["duration_s"] = max(s["duration_s"], 1.01 * math.pi * abs(s["to_altitude_m"] - z)
                                  / (2 * v))
            z = s["to_altitude_m"]
        elif s["type"] == "popup":
            s["climb_s"] = max(s["climb_s"], 1.01 * math.pi * abs(s["peak_altitude_m"] - z)
                               / (2 * v))
            s["dive_s"] = max(s["dive_s"], 1.01 * math.pi * abs(s["peak_altitude_m"] - z)
                              / (2 * v))
        out.append(s)
    return out


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(segment, min_size=1, max_size=8), st.floats(30, 900), st.floats(0, 359.9))
def test_random_chains_finite_and_never_faster_than_declared(chain, speed, heading):
    tg = _target(_feasible(chain, speed), speed=speed, heading=heading)
    tr = _traj(tg)
    declared = max([speed] + [s["to_speed_mps"] for s in chain if s["type"] == "accelerate"])
    t = np.linspace(0.0, tr.t_last[0], 997)
    pos, vel, acc, act = _eval(tr, t)
    assert np.isfinite(pos).all() and np.isfinite(vel).all() and np.isfinite(acc).all()
    assert act.all()
    assert np.linalg.norm(vel, axis=1).max() <= declared * (1 + 1e-9)
    assert pos[:, 2].min() >= -1e-6  # climbs and dives stay above the sea


def _smoothed(turn_g, raw=False):
    data = ({
        "id": "w", "rcs": {"type": "constant", "sigma_m2": 1.0}, "smoothing": {"turn_g": turn_g},
        "waypoints": [{"time_s": 0, "east_m": 0, "north_m": 0, "altitude_m": 500},
                      {"time_s": 100, "east_m": 20000, "north_m": 0, "altitude_m": 500},
                      {"time_s": 200, "east_m": 20000, "north_m": 20000, "altitude_m": 1500},
                      {"time_s": 260, "east_m": 8000, "north_m": 20000, "altitude_m": 1500}]})
    return data if raw else Target.model_validate(data)


def test_smoothed_corners():
    n_g = 3.0
    tr = _traj(_smoothed(n_g))
    plain = trajectories([_smoothed(n_g).model_copy(update={"smoothing": None})], FRAME, False)
    t = np.linspace(0, tr.t_last[0], 20001)
    pos, vel, acc, _ = _eval(tr, t)
    speed = np.hypot(vel[:, 0], vel[:, 1])
    # never more than the load: |a_h| <= n g (turns at n g, speed changes at n g)
    assert np.hypot(acc[:, 0], acc[:, 1]).max() == pytest.approx(n_g * G, rel=1e-9)
    # the first corner (200 m/s, 90°) is a quarter circle of radius v²/(g n): it passes the
    # waypoint at R (√2 - 1)
    radius = 200.0**2 / (G * n_g)
    d = np.hypot(pos[:, 0] - 20000, pos[:, 1])
    assert d.min() == pytest.approx(radius * (math.sqrt(2) - 1), rel=1e-4)
    # velocity continuous along the whole track (no jumps at waypoints)
    dv = np.abs(np.diff(vel, axis=0)).max()
    assert dv < n_g * G * (t[1] - t[0]) * 1.01 + 1e-9
    # the plain waypoint track jumps at the same corner
    _, vp, _ = plain.state(np.array([99.999, 100.001]), np.zeros(2, dtype=int))
    assert np.abs(vp[1] - vp[0]).max() > 100.0
    # speeds of the legs are kept (200, 200 -> 240 with a climb)
    assert speed[t < 80] == pytest.approx(200.0)
    assert speed.max() == pytest.approx(200.0, rel=1e-9)  # third leg 12000 m in 60 s


def test_smoothing_refused_when_corners_do_not_fit():
    from shipradar.sim.world.scenario import ScenarioError, parse_scenario

    data = {"name": "s", "duration_s": 10, "origin": {"lat_deg": 44, "lon_deg": -63},
            "platforms": [{"id": "p", "waypoints": [{"east_m": 0, "north_m": 0}],
                           "radars": [quiet_radar()]}],
            "targets": [_smoothed(0.2, raw=True)]}
    with pytest.raises(ScenarioError) as err:
        parse_scenario(data)
    assert any(line.startswith("targets[0].smoothing.turn_g: rounding the corners of leg "
                               "waypoints[0] -> waypoints[1] takes") and "got 0.2" in line
               for line in err.value.lines)


def test_beam_crossing_of_a_turning_target_against_brute_force():
    """A 6 g turn 3-8 km from a turning frigate, a 60 rpm beam: Newton's crossing times
    against a 1 ms grid search refined by Brent."""
    frigate = _target([{"type": "turn", "turn_rate_deg_s": 3.0, "duration_s": 60,
                        "direction": "right"}], speed=12.0, heading=0.0, alt=0.0)
    ship = Trajectories(None, hold=True, pieces=[object_pieces(frigate, FRAME)])
    targets = [_target([{"type": "turn", "turn_g": 6.0, "duration_s": 60.0,
                         "direction": d}], speed=s, heading=h)
               for d, s, h in (("right", 300, 0), ("left", 250, 200), ("right", 600, 45))]
    tg = Trajectories(None, hold=False, pieces=[
        [p.__class__(p.t0, p.dt, p.p0 + off, p.vel, p.kind, p.par)
         for p in object_pieces(t, FRAME)]
        for t, off in zip(targets, (np.array([4000.0, 1000, 0]), np.array([-3000.0, 5000, 0]),
                                    np.array([2000.0, -7000, 0])), strict=True)])
    omega = 2 * math.pi
    n = tg.n

    def az_at(t, rows=None):
        rows = np.arange(n) if rows is None else rows
        tp, _, _ = tg.state(t, rows)
        sp, _, _ = ship.state(t, np.zeros(rows.size, dtype=int))
        return antenna_azimuth(sp, tp, FRAME)[0]

    def geometry_at(t, rows):
        tp, _, _ = tg.state(t, rows)
        sp, _, _ = ship.state(t, np.zeros(rows.size, dtype=int))
        return antenna_azimuth(sp, tp, FRAME)

    for t_start in (3.3, 17.9, 41.0):
        tc = first_crossings(geometry_at, t_start, 0.4, omega, n, 612.0)
        grid = t_start + np.arange(0.0, 1.0, 1e-3)
        for i in range(n):
            rows = np.full(grid.size, i)
            f = wrap_pi(az_at(grid, rows) - (0.4 + omega * (grid - t_start)))
            # az - beam falls through zero as the beam passes the target
            k = np.flatnonzero((f[:-1] > 0) & (f[1:] <= 0) & (np.abs(f[:-1]) < 1))[0]

            def g(t, i=i, t_start=t_start):
                return wrap_pi(az_at(np.array([t]), np.array([i]))[0]
                               - (0.4 + omega * (t - t_start)))

            root = brentq(g, grid[k], grid[k + 1], xtol=1e-13)
            assert tc[i] == pytest.approx(root, abs=1e-8)
