"""Beam crossings where the geometry is hard (issue 37), against an independent root finder.

The solver (:func:`shipradar.sim.world.kinematics.beam_crossings`) is checked on planar
scenes with closed-form azimuths, against every sign change of β(t) - az(t) found on a fine
grid and polished by ``scipy.optimize.brentq``: close Mach 2-3 targets with and against the
rotation at 6 and 60 rpm, circles round the antenna both ways, a 30 m overflight and a pass
straight over the antenna, north crossings both ways, a moving antenna making 90° corners.
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from shipradar.sim.world.kinematics import TWO_PI, beam_crossings, wrap_pi

MACH = 340.0


class Planar:
    """Objects on the plane seen from an antenna, both with closed-form motion.

    ``paths`` are callables t -> (east, north) [m] of a scalar or array time, the antenna's
    ``antenna(t)`` likewise; azimuth clockwise from north, its rate by central difference
    (the solver only uses the rate to speed Newton's steps up).
    """

    def __init__(self, paths, antenna=lambda t: (0.0 * np.asarray(t), 0.0 * np.asarray(t))):
        self.paths = paths
        self.antenna = antenna

    def rel(self, t, i):
        """East and north [m] of objects ``i`` (an int or an array) from the antenna."""
        t = np.asarray(t, dtype=float)
        i = np.broadcast_to(np.asarray(i), t.shape)
        e, n = np.empty(t.shape), np.empty(t.shape)
        for j in np.unique(i):
            sel = i == j
            e[sel], n[sel] = self.paths[j](t[sel])
        ae, an = self.antenna(t)
        return e - ae, n - an

    def az(self, t, i):
        e, n = self.rel(t, i)
        return np.mod(np.arctan2(e, n), TWO_PI)

    def look_at(self, t, idx):
        e, n = self.rel(t, idx)
        h = 1e-6
        e1, n1 = self.rel(t + h, idx)
        e0, n0 = self.rel(t - h, idx)
        rate = wrap_pi(np.arctan2(e1, n1) - np.arctan2(e0, n0)) / (2 * h)
        return np.mod(np.arctan2(e, n), TWO_PI), rate, np.hypot(e, n)


def reference_roots(scene, i, t_a, t_b, beam_a, omega, step=2e-4):
    """Every t in [t_a, t_b) with β(t) = az(t) (mod 2π): sign changes of wrap(β - az) on a
    grid (where both values are within π/2 of zero: not the wrap's jump), then brentq."""
    def f(t):
        return float(wrap_pi(beam_a + omega * (t - t_a) - scene.az(np.array([t]), i)[0]))

    grid = np.arange(t_a, t_b + step, step)
    vals = wrap_pi(beam_a + omega * (grid - t_a) - scene.az(grid, i))
    a, b = vals[:-1], vals[1:]
    roots = list(grid[:-1][a == 0.0])
    for k in np.flatnonzero((a * b < 0.0) & (np.abs(a) < 1.5) & (np.abs(b) < 1.5)):
        roots.append(brentq(f, grid[k], grid[k + 1], xtol=1e-13, rtol=1e-15))
    return [r for r in sorted(roots) if t_a <= r < t_b]


def straight(p0, v):
    p0, v = np.asarray(p0, float), np.asarray(v, float)
    return lambda t: (p0[0] + v[0] * np.asarray(t), p0[1] + v[1] * np.asarray(t))


def circle(centre, radius, rate, phase=0.0):
    return lambda t: (centre[0] + radius * np.sin(phase + rate * np.asarray(t)),
                      centre[1] + radius * np.cos(phase + rate * np.asarray(t)))


def square(speed, leg_s):
    """A ship making 90° corners: north, east, south, west legs of ``leg_s`` each."""
    dirs = np.array([[0.0, 1.0], [1.0, 0.0], [0.0, -1.0], [-1.0, 0.0]])
    corners = np.vstack([[0.0, 0.0], np.cumsum(dirs * speed * leg_s, axis=0)])

    def at(t):
        t = np.asarray(t, dtype=float)
        k = np.floor(t / leg_s).astype(int) % 4
        lap = np.floor(t / (4 * leg_s))
        tau = t - np.floor(t / leg_s) * leg_s
        e = corners[k, 0] + dirs[k, 0] * speed * tau + 0.0 * lap
        n = corners[k, 1] + dirs[k, 1] * speed * tau
        return e, n
    return at


def _scenes():
    m2, m3 = 2 * MACH, 3 * MACH
    return {
        # close Mach 2-3 targets crossing the antenna's view with and against the rotation
        "close_fast": [straight((-3000.0, 1000.0), (m3, 0.0)),      # with (clockwise) at north
                       straight((3000.0, -1500.0), (-m3, 0.0)),     # with, south
                       straight((-2500.0, -2000.0), (m2, 0.0)),     # against, south side
                       straight((2500.0, 2500.0), (-m2, 0.0)),      # against, north
                       straight((1000.0, -3000.0), (0.0, m3)),      # north-bound east of it
                       straight((-1200.0, 3000.0), (0.0, -m3))],
        # circles round the antenna at 1-3 km, both ways, faster and slower than the beam
        "circles": [circle((0.0, 0.0), 1000.0, m3 / 1000.0),
                    circle((0.0, 0.0), 2000.0, -m2 / 2000.0),
                    circle((0.0, 0.0), 3000.0, m3 / 3000.0, 1.0),
                    circle((1500.0, 0.0), 1000.0, m2 / 1000.0, 2.0)],
        # a 30 m overflight (a miss distance of 30 m) and a pass straight over the antenna
        "overflight": [straight((-5000.0, 30.0), (m3, 0.0)),
                       straight((-4000.0, -30.0), (m2, 0.0)),
                       straight((0.0, -6000.0), (0.0, m3))],
        # north crossings both ways, slow and fast, close and far
        "north": [straight((-2000.0, 1500.0), (m2, 0.0)),
                  straight((2000.0, 800.0), (-m2, 0.0)),
                  straight((-30000.0, 20000.0), (300.0, 0.0)),
                  straight((30000.0, 5000.0), (-300.0, 0.0))],
    }


def _check(scene, n_obj, rpm, t_end, start_deg, min_sep=0.0):
    omega = rpm / 60.0 * TWO_PI
    period = TWO_PI / omega
    starts = np.append(np.arange(0.0, t_end, period), t_end)
    beam = np.mod(math.radians(start_deg) + omega * starts, TWO_PI)
    n_rev = starts.size - 1
    idx_obj = np.repeat(np.arange(n_obj), n_rev)
    rev = np.tile(np.arange(n_rev), n_obj)
    speed = np.full(idx_obj.size, 1.05 * 4 * MACH)
    pair, t = beam_crossings(lambda tt, k: scene.look_at(tt, idx_obj[k]), starts[rev],
                             starts[rev + 1], beam[rev], beam[rev + 1], omega, speed,
                             min_separation_s=min_sep)
    # no pair's crossing outside its revolution, none twice
    assert np.all(t >= starts[rev[pair]]) and np.all(t <= starts[rev[pair] + 1])
    for i in range(n_obj):
        got = np.sort(t[idx_obj[pair] == i])
        ref = np.array(reference_roots(scene, i, 0.0, t_end, beam[0], omega))
        assert got.size == ref.size, (i, got, ref)
        assert np.max(np.abs(got - ref), initial=0.0) < 1e-8, (i, got - ref)
    return pair, t


@pytest.mark.parametrize("name", ["close_fast", "circles", "overflight", "north"])
@pytest.mark.parametrize("rpm, start_deg", [(6.0, 183.35), (60.0, 0.0)])
def test_every_crossing_of_the_hard_scenes_is_found_once(name, rpm, start_deg):
    paths = _scenes()[name]
    t_end = 20.0 if rpm == 6.0 else 8.0
    _check(Planar(paths), len(paths), rpm, t_end, start_deg)


@pytest.mark.parametrize("rpm", [6.0, 60.0])
def test_crossings_from_a_ship_making_90_degree_corners(rpm):
    paths = [straight((800.0, 900.0), (0.0, 0.0)), straight((-2000.0, 500.0), (MACH, 50.0)),
             circle((300.0, 300.0), 1500.0, -0.4)]
    _check(Planar(paths, antenna=square(40.0, 5.0)), len(paths), rpm, 20.0, 90.0)


def test_a_target_against_the_rotation_is_met_twice_in_a_revolution():
    """At 6 rpm a Mach 2 target passing 1 km from the antenna against the rotation (az' up
    to -0.68 rad/s against ω = 0.63) is met at 0.5 s and again at 6.9 s, in one revolution."""
    scene = Planar([straight((-2000.0, -1000.0), (2 * MACH, 0.0))])
    pair, t = _check(scene, 1, 6.0, 20.0, 220.0)
    assert np.count_nonzero(t < 10.0) == 2


def test_a_target_outrunning_the_beam_is_met_when_it_passes_it():
    """A target on a 1 km circle at Mach 3 (1.02 rad/s, clockwise) outruns a 6 rpm beam
    (0.63 rad/s): it passes the beam from behind, about once every 16 s."""
    scene = Planar([circle((0.0, 0.0), 1000.0, 3 * MACH / 1000.0)])
    _, t = _check(scene, 1, 6.0, 40.0, 10.0)
    assert 2 <= t.size <= 3
    assert np.diff(t) == pytest.approx(TWO_PI / (3 * MACH / 1000.0 - 0.2 * math.pi), rel=1e-6)


def test_a_crossing_on_a_revolution_boundary_is_counted_once():
    """A still target on the start azimuth is met at every revolution's boundary: once
    each, by one revolution or the other as the rounding of β - az there says (both read
    the same numbers); with the engine's windows shifted 1 µs early, by the later one."""
    scene = Planar([straight((1000.0 * math.sin(1.0), 1000.0 * math.cos(1.0)), (0.0, 0.0))])
    omega = TWO_PI
    for shift in (0.0, 1e-6):
        starts = np.arange(0.0, 5.5, 1.0) - shift
        beam = np.mod(1.0 + omega * starts, TWO_PI)
        n = starts.size - 1
        pair, t = beam_crossings(lambda tt, k: scene.look_at(tt, 0 * k), starts[:-1],
                                 starts[1:], beam[:-1], beam[1:], omega, np.full(n, 1.0))
        assert np.unique(t).size == t.size == n
        assert np.all(np.abs(t - np.round(t)) < 1e-9)
        if shift:
            assert np.all(np.abs(t - (starts[:-1][pair] + shift)) < 1e-9)


def test_close_crossings_within_a_dwell_are_one_look():
    """A target keeping pace with the beam, weaving about it (its azimuth ω t + 0.3 +
    0.05 sin 2t at 1 km): the beam crosses it every 1.4 s or so; with a separation of 2 s
    the crossings kept are the first of each run closer than that."""
    omega = 0.2 * math.pi

    def path(t):
        a = omega * np.asarray(t) + 0.3 + 0.05 * np.sin(2.0 * np.asarray(t))
        return 1000.0 * np.sin(a), 1000.0 * np.cos(a)

    scene = Planar([path])
    starts = np.array([0.0, 10.0])
    beam = np.array([0.31, 0.31 + 10.0 * omega])
    args = (scene.look_at, starts[:1], starts[1:], beam[:1], beam[1:], omega,
            np.array([800.0]))
    _, t_all = beam_crossings(*args)
    ref = reference_roots(scene, 0, 0.0, 10.0, 0.31, omega)
    assert t_all.size == len(ref) >= 5
    assert t_all == pytest.approx(ref, abs=1e-8)
    _, t_one = beam_crossings(*args, min_separation_s=2.0)
    kept = [t_all[0]]
    for x in t_all[1:]:
        if x - kept[-1] >= 2.0:
            kept.append(x)
    assert t_one == pytest.approx(kept, abs=0.0)


@pytest.mark.parametrize("rate", [-0.392, 0.296, 0.55, -2.0])
def test_a_constant_angular_rate_against_the_closed_form(rate):
    """The issue's cases: at 6 rpm a target at azimuth 1 rad turning at a constant rate
    (the old fixed-point iteration erred by +36, -15.5 and -5028 ms on the first three).
    β0 + ω t = 1 + r t + 2πk gives every crossing t_k = (1 - β0 + 2πk)/(ω - r)."""
    omega, beam0, rho = 0.2 * math.pi, 0.3, 1000.0

    def look_at(t, idx):
        return np.mod(1.0 + rate * t, TWO_PI), np.full(t.size, rate), np.full(t.size, rho)

    starts = np.arange(0.0, 200.0 + 1e-9, 10.0)
    beam = np.mod(beam0 + omega * starts, TWO_PI)
    n = starts.size - 1
    _, t = beam_crossings(look_at, starts[:-1], starts[1:], beam[:-1], beam[1:], omega,
                          np.full(n, abs(rate) * rho))
    k = np.arange(-100, 100)
    want = (1.0 - beam0 + TWO_PI * k) / (omega - rate)
    want = np.sort(want[(want >= 0.0) & (want < 200.0)])
    assert t.size == want.size
    assert np.sort(t) == pytest.approx(want, abs=1e-9)


def test_speed_bounds_hold_along_every_kind_of_piece():
    """The crossing search's speed bound (``max_speed``) is at least the horizontal speed
    sampled along arcs with along-track acceleration, weaves, straight legs and traffic's
    cubic pieces."""
    from shipradar.sim.world.kinematics import ARC, LINEAR, SINE, Piece, Trajectories
    from shipradar.sim.world.traffic import CUBIC, PieceTable, hermite_coefficients

    rng = np.random.default_rng(8)
    pieces = [
        [Piece(0.0, 20.0, np.zeros(3), np.zeros(3), ARC,
               np.array([0.3, 200.0, 15.0, 0.05, 0.0, 0.0])),
         Piece(20.0, 10.0, np.zeros(3), np.array([-120.0, 310.0, 5.0]), LINEAR)],
        [Piece(0.0, 30.0, np.zeros(3), np.zeros(3), SINE,
               np.array([1.0, 250.0, 300.0, 0.4, 0.0, (300.0 * 0.4 / 250.0) ** 2]))]]
    tr = Trajectories(None, hold=False, pieces=pieces)
    t = np.linspace(0.0, 30.0, 3001)
    for i in range(tr.n):
        _, vel, _ = tr.state(t, np.full(t.size, i))
        assert tr.max_speed[i] >= np.max(np.hypot(vel[:, 0], vel[:, 1])) - 1e-9
    p0, p1 = rng.normal(0, 500.0, (4, 3)), rng.normal(0, 500.0, (4, 3))
    v0, v1 = rng.normal(0, 200.0, (4, 3)), rng.normal(0, 200.0, (4, 3))
    h = np.array([5.0, 8.0, 3.0, 12.0])
    c2, c3 = hermite_coefficients(p0, p1, v0, v1, h)
    table = PieceTable(np.array([0, 2, 4]), np.array([0.0, 5.0, 0.0, 3.0]), h, p0, v0,
                       np.full(4, CUBIC, np.int8), np.hstack([c2, c3]), np.ones(4, bool))
    for i in range(2):
        ts = np.linspace(0.0, 12.0 if i else 13.0, 2001)
        _, vel, _ = table.state(ts, np.full(ts.size, i))
        assert table.max_speed[i] >= np.max(np.hypot(vel[:, 0], vel[:, 1])) - 1e-9


@pytest.mark.parametrize("speed", [0.0, 20.0, 1000.0])
def test_an_object_over_the_antenna_ends_the_search(speed):
    """A target on the antenna's vertical for whole revolutions (riding with the ship): no
    azimuth, no crossing, and the search ends at once instead of splitting to 1 µs."""
    scene = Planar([straight((0.0, 0.0), (0.0, 0.0))])
    omega = 0.2 * math.pi
    starts = np.arange(0.0, 60.0 + 1e-9, 10.0)
    beam = np.mod(omega * starts, TWO_PI)
    n = starts.size - 1
    pair, t = beam_crossings(lambda tt, k: scene.look_at(tt, 0 * k), starts[:-1], starts[1:],
                             beam[:-1], beam[1:], omega, np.full(n, speed))
    assert t.size == 0
