"""Kinematics and radar geometry, vectorized over objects.

Positions are kept in the scenario origin's local frame: east and north [m] on the tangent
plane (waypoints given as latitude/longitude are converted once on the WGS-84 ellipsoid,
:mod:`shipradar.sim.world.geodesy`: pymap3d's formulas, without its import of astropy) and the
altitude above the sea [m].  Motion between waypoints is at constant velocity; scenario
segments (turns, speed changes, weaves, climbs, rounded waypoint corners) are pieces with
closed forms (:class:`Piece`, :func:`piece_state`), built by :mod:`shipradar.sim.world.trajectory`.

Geometry from an antenna to its targets is computed on the WGS-84 ellipsoid:
true-north azimuth in the antenna's own local frame (so a ship 100 km from the origin still
reports true north, not grid north), terrestrial range along the earth, and slant range and
elevation on the 4/3 effective earth used throughout the radar model.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import ellipeinc

from shipradar.sensors.geometry import K_FACTOR, slant_range_elevation
from shipradar.sim.world import geodesy
from shipradar.sim.world.scenario import Origin, Platform, Waypoint

TWO_PI = 2.0 * np.pi


class LocalFrame:
    """The scenario's local east/north frame, mapped onto the sphere osculating at the origin.

    East/north [m] are coordinates on the plane tangent to the WGS-84 ellipsoid at the origin;
    a point (e, n, altitude) is the point of that plane projected from the centre of the
    sphere of Gaussian radius R = √(M N) tangent at the origin, raised by its altitude along
    the sphere's vertical.  Over a few hundred kilometres the sphere departs from the ellipsoid
    by decimetres, while every geometric quantity becomes a handful of vector operations
    (no iterative geodetic conversion on the hot path).  Latitude/longitude waypoints enter,
    and reported positions leave, through :mod:`shipradar.sim.world.geodesy` on the ellipsoid.
    """

    def __init__(self, origin: Origin):
        self.origin = origin
        lat, lon = np.radians(origin.lat_deg), np.radians(origin.lon_deg)
        self.radius = float(gaussian_radius_m(origin.lat_deg))
        self.up0 = np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
        self.east0 = np.array([-np.sin(lon), np.cos(lon), 0.0])
        self.north0 = np.cross(self.up0, self.east0)
        o = np.array(geodesy.geodetic2ecef(origin.lat_deg, origin.lon_deg, 0.0), dtype=float)
        self.centre = o - self.radius * self.up0

    def unit(self, en: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unit vertical (from the sphere centre, ECEF axes) of east/north points, and |T|/R."""
        t = (self.radius * self.up0[None, :] + en[:, 0:1] * self.east0[None, :]
             + en[:, 1:2] * self.north0[None, :])
        norm = np.linalg.norm(t, axis=1)
        return t / norm[:, None], norm / self.radius

    def velocity(self, u: np.ndarray, stretch: np.ndarray, alt: np.ndarray,
                 vel: np.ndarray) -> np.ndarray:
        """Velocity (ECEF axes) of points moving with origin-frame velocity ``vel`` (N, 3)."""
        v = vel[:, 0:1] * self.east0[None, :] + vel[:, 1:2] * self.north0[None, :]
        v = v - np.sum(v * u, axis=1, keepdims=True) * u
        scale = (self.radius + alt) / (self.radius * stretch)
        return v * scale[:, None] / stretch[:, None] + vel[:, 2:3] * u

    def en_of_geodetic(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """East/north [m] of a latitude/longitude (inverse of the projection)."""
        x = np.array(geodesy.geodetic2ecef(lat_deg, lon_deg, 0.0), dtype=float) - self.centre
        u = x / np.linalg.norm(x)
        t = u * self.radius / float(u @ self.up0)
        return float(t @ self.east0), float(t @ self.north0)

    def geodetic(self, enu: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Latitude, longitude [deg] and height above the ellipsoid [m] of (N, 3) points."""
        u, _ = self.unit(enu)
        x = self.centre[None, :] + (self.radius + enu[:, 2:3]) * u
        lat, lon, h = geodesy.ecef2geodetic(x[:, 0], x[:, 1], x[:, 2])
        return np.asarray(lat, float), np.asarray(lon, float), np.asarray(h, float)


def waypoint_enu(waypoints: Sequence[Waypoint], frame: LocalFrame | Origin) -> np.ndarray:
    """Waypoints as an ``(W, 4)`` array of (time [s], east [m], north [m], altitude [m])."""
    frame = frame if isinstance(frame, LocalFrame) else LocalFrame(frame)
    out = np.empty((len(waypoints), 4))
    for i, w in enumerate(waypoints):
        if w.east_m is not None and w.north_m is not None:
            e, n = w.east_m, w.north_m
        elif w.lat_deg is not None and w.lon_deg is not None:
            e, n = frame.en_of_geodetic(w.lat_deg, w.lon_deg)
        else:  # the schema gives exactly one of the two forms
            raise ValueError(f"waypoints[{i}]: give east_m and north_m or lat_deg and lon_deg")
        out[i] = (w.time_s, e, n, w.altitude_m)
    return out


def ship_motion(platform: Platform) -> tuple[float, float]:
    """Speed [m/s] and course [rad, clockwise from north] of the platform's first leg.

    The ship's own motion the clutter spectrum [34] is shifted by (the clutter tables and the
    dwell model read it once).  A stationary platform, or one whose first two waypoints are
    given as latitude/longitude, gives speed 0 and its declared heading.
    """
    w = platform.waypoints
    if len(w) < 2:
        return 0.0, math.radians(platform.heading_deg)
    e0, n0, e1, n1 = w[0].east_m, w[0].north_m, w[1].east_m, w[1].north_m
    if e0 is None or n0 is None or e1 is None or n1 is None:
        return 0.0, math.radians(platform.heading_deg)
    de, dn = e1 - e0, n1 - n0
    dt = w[1].time_s - w[0].time_s
    return math.hypot(de, dn) / dt, math.atan2(de, dn) % (2 * math.pi)

#: Piece kinds of :class:`Trajectories`: constant velocity; a horizontal arc or straight line
#: with a constant turn rate or a constant along-track acceleration (never both: their product
#: has no closed form) and a constant vertical acceleration; a sinusoidal offset (weave, or
#: smooth climb/dive) flown at constant speed.
LINEAR, ARC, SINE = 0, 1, 2
#: Offset planes of a :data:`SINE` piece.
LATERAL, VERTICAL = 0, 1


@dataclass(frozen=True)
class Piece:
    """One analytic piece of a trajectory, starting at time ``t0`` [s] for ``dt`` [s].

    ``p0`` (3,) start position (east, north, up) [m]; ``vel`` (3,) the constant velocity of a
    :data:`LINEAR` piece [m/s] (zero for the others); ``kind`` and ``par`` (6,):

    * :data:`ARC`: ψ0 heading [rad, clockwise from north], v0 horizontal speed [m/s], a
      along-track acceleration [m/s²], ω turn rate [rad/s, > 0 clockwise], vz0 vertical speed
      [m/s], az vertical acceleration [m/s²];
    * :data:`SINE`: ψ0 base heading [rad], v speed along the path [m/s], A offset amplitude
      [m] (signed: right/up positive), k angular frequency [rad/s], plane (:data:`LATERAL` or
      :data:`VERTICAL`), m = (A k / v)² < 1.
    """

    t0: float
    dt: float
    p0: np.ndarray
    vel: np.ndarray
    kind: int = LINEAR
    par: np.ndarray = field(default_factory=lambda: np.zeros(6))

    def end(self) -> tuple[np.ndarray, np.ndarray]:
        """Position (3,) [m] and velocity (3,) [m/s] at the end of the piece."""
        pos, vel, _ = piece_state(self.p0[None], self.vel[None], np.array([self.kind]),
                                  self.par[None], np.array([self.dt]), accel=False)
        return pos[0], vel[0]


def piece_state(p0: np.ndarray, vel0: np.ndarray, kind: np.ndarray, par: np.ndarray,
                tau: ArrayLike, accel: bool = True
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Closed-form position, velocity and acceleration of M pieces at times ``tau`` [s] into
    them (no numerical integration).

    Parameters
    ----------
    p0, vel0 : (M, 3) start positions [m] and linear velocities [m/s]
    kind : (M,) piece kinds (:data:`LINEAR`, :data:`ARC`, :data:`SINE`)
    par : (M, 6) piece parameters (:class:`Piece`)
    tau : (M,) time into each piece [s], >= 0
    accel : also return the accelerations (else None)

    Notes
    -----
    ARC: the chord of an arc flown at constant speed is v τ sinc(ωτ/2) along the mean heading
    ψ0 + ωτ/2; with ω = 0 and an along-track acceleration a it is v0 τ + a τ²/2 along ψ0.  The
    one expression (v0 τ + a τ²/2) sinc(ωτ/2) covers both, and stays exact as ω -> 0.

    SINE: offset d(τ) = A (1 - cos kτ) across (lateral) or above (vertical) the base heading,
    flown at the constant path speed v: the along-track speed is √(v² - d'²) =
    v √(1 - m sin² kτ), whose integral is (v/k) E(kτ | m), the incomplete elliptic integral
    of the second kind (``scipy.special.ellipeinc``).  d' = 0 at τ = 0 and at every half
    period, so the velocity is continuous with a straight entry and, after whole half
    periods, with a straight exit.
    """
    tau = np.asarray(tau, dtype=float)
    pos = p0 + vel0 * tau[:, None]
    vel = vel0.copy()
    acc = np.zeros_like(vel) if accel else None
    nl = np.flatnonzero(kind != LINEAR)
    if nl.size == 0:
        return pos, vel, acc
    for code in (ARC, SINE):
        sel = nl[kind[nl] == code]
        if sel.size == 0:
            continue
        q, ts = par[sel], tau[sel]
        psi0 = q[:, 0]
        if code == ARC:
            v0, a, w, vz0, az = q[:, 1], q[:, 2], q[:, 3], q[:, 4], q[:, 5]
            chord = (v0 * ts + 0.5 * a * ts * ts) * np.sinc(w * ts / (2.0 * np.pi))
            mid = psi0 + 0.5 * w * ts
            pos[sel, 0] += chord * np.sin(mid)
            pos[sel, 1] += chord * np.cos(mid)
            pos[sel, 2] += vz0 * ts + 0.5 * az * ts * ts
            v, psi = v0 + a * ts, psi0 + w * ts
            s, c = np.sin(psi), np.cos(psi)
            vel[sel] = np.column_stack([v * s, v * c, vz0 + az * ts])
            if acc is not None:
                # along-track a, centripetal v ω to the right of the heading (cos ψ, -sin ψ)
                acc[sel] = np.column_stack([a * s + v * w * c, a * c - v * w * s, az])
            continue
        v, amp, k, plane, m = q[:, 1], q[:, 2], q[:, 3], q[:, 4], q[:, 5]
        th = k * ts
        st, ct = np.sin(th), np.cos(th)
        along = v / k * ellipeinc(th, m)
        off = amp * (1.0 - ct)
        root = np.sqrt(np.maximum(1.0 - m * st * st, 0.0))
        ds, dd = v * root, amp * k * st
        u = np.column_stack([np.sin(psi0), np.cos(psi0), np.zeros(sel.size)])
        lateral = (plane == LATERAL)[:, None]
        n = np.where(lateral, np.column_stack([np.cos(psi0), -np.sin(psi0),
                                               np.zeros(sel.size)]), [0.0, 0.0, 1.0])
        pos[sel] += along[:, None] * u + off[:, None] * n
        vel[sel] = ds[:, None] * u + dd[:, None] * n
        if acc is not None:
            dds = -v * m * k * st * ct / np.where(root > 0, root, 1.0)
            acc[sel] = dds[:, None] * u + (amp * k * k * ct)[:, None] * n
    return pos, vel, acc


def pieces_max_speed(kind: np.ndarray, vel: np.ndarray, par: np.ndarray,
                     dt: np.ndarray) -> np.ndarray:
    """The largest horizontal speed along each piece [m/s] (any shape of pieces): a constant
    velocity's (``vel`` [..., 3]), an arc's at either end (its along-track acceleration is
    constant), a sine piece's path speed (``par`` [..., 6], ``dt`` [s] as in :class:`Piece`)."""
    out = np.hypot(vel[..., 0], vel[..., 1])
    arc = kind == ARC
    v0, a = par[..., 1], par[..., 2]
    out = np.where(arc, np.maximum(np.abs(v0), np.abs(v0 + a * dt)), out)
    return np.where(kind == SINE, np.abs(v0), out)


def linear_pieces(track: np.ndarray) -> list[Piece]:
    """Constant-velocity pieces between the waypoints of a ``(W, 4)`` track (one
    zero-length piece for a single waypoint)."""
    if len(track) == 1:
        return [Piece(float(track[0, 0]), 0.0, track[0, 1:].copy(), np.zeros(3))]
    out = []
    for i in range(len(track) - 1):
        dt = float(track[i + 1, 0] - track[i, 0])
        out.append(Piece(float(track[i, 0]), dt, track[i, 1:].copy(),
                         (track[i + 1, 1:] - track[i, 1:]) / dt))
    return out


class Trajectories:
    """Piecewise-analytic tracks of N objects, evaluated for all of them at once.

    Parameters
    ----------
    tracks : list of ndarray
        One ``(W_i, 4)`` array per object (see :func:`waypoint_enu`): constant velocity
        between waypoints.
    hold : bool
        If True (platforms, jammers) an object holds its first/last position outside its
        track's times and is always active; if False (targets) it exists only between the
        start and the end of its track.
    pieces : list of list of Piece, optional
        Instead of ``tracks``: each object's consecutive :class:`Piece` list (segments, turns,
        weaves; :mod:`shipradar.sim.world.trajectory` builds them from the scenario).
    """

    def __init__(self, tracks: Sequence[np.ndarray] | None, hold: bool,
                 pieces: Sequence[Sequence[Piece]] | None = None):
        ends = None
        if pieces is None:
            if tracks is None:
                raise ValueError("give the tracks or the pieces")
            tracks = [np.asarray(t, dtype=float) for t in tracks]
            pieces = [linear_pieces(t) for t in tracks]
            # the last waypoint's own time (t0 + dt could differ from it in the last bit)
            ends = np.array([t[-1, 0] for t in tracks])
        self.n = len(pieces)
        self.hold = hold
        w = max((len(p) for p in pieces), default=1)
        self.times = np.full((self.n, w), np.inf)
        self.pos = np.zeros((self.n, w, 3))
        self.vel = np.zeros((self.n, w, 3))
        self.seg_dt = np.zeros((self.n, w))
        self.kind = np.zeros((self.n, w), dtype=np.int8)
        self.par = np.zeros((self.n, w, 6))
        self.count = np.array([len(p) for p in pieces], dtype=int)
        for i, plist in enumerate(pieces):
            for j, p in enumerate(plist):
                self.times[i, j] = p.t0
                self.pos[i, j] = p.p0
                self.vel[i, j] = p.vel
                self.seg_dt[i, j] = p.dt
                self.kind[i, j] = p.kind
                self.par[i, j] = p.par
            # padding holds the last piece's end, so a clamped look-up past it is harmless
            self.pos[i, len(plist):] = self.pos[i, len(plist) - 1]
        self.last_seg = np.maximum(self.count - 1, 0)
        self.t_first = self.times[:, 0] if self.n else np.zeros(0)
        last = self.last_seg
        self.t_last = (self.times[np.arange(self.n), last] + self.seg_dt[np.arange(self.n), last]
                       if self.n else np.zeros(0))
        if ends is not None and self.n:
            self.t_last = ends
        self.linear = not bool(np.any(self.kind != LINEAR))
        #: a bound on each object's horizontal speed over its whole track [m/s] (the
        #: beam-crossing search's bound on a target's angular rate)
        speed = pieces_max_speed(self.kind, self.vel, self.par, self.seg_dt)
        speed[np.arange(w)[None, :] >= self.count[:, None]] = 0.0  # the padding
        self.max_speed = speed.max(axis=1, initial=0.0)
        # Every object on one linear piece (at most two waypoints: the usual case): the piece
        # search of :meth:`state` is skipped, with the first piece's columns kept contiguous.
        self._one_segment = w <= 1 and self.linear
        self._t0 = np.ascontiguousarray(self.times[:, 0]) if self.n else np.zeros(0)
        self._pos0 = np.ascontiguousarray(self.pos[:, 0])
        self._vel0 = np.ascontiguousarray(self.vel[:, 0])
        self._dt0 = np.ascontiguousarray(self.seg_dt[:, 0])

    def state(
        self, t: float | np.ndarray, rows: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions ``(M, 3)`` [m], velocities ``(M, 3)`` [m/s] and activity ``(M,)``.

        ``rows`` picks the objects (default: all N, M = N; repeats allowed, e.g. one platform
        at many times); ``t`` is a scalar or one time per row [s].
        """
        if self._one_segment:
            return self._state_one_segment(t, rows)
        pos, vel, _, active = self.state_acc(t, rows, accel=False)
        return pos, vel, active

    def state_acc(self, t: ArrayLike, rows: ArrayLike | None = None, accel: bool = True
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
        """:meth:`state` with the accelerations ``(M, 3)`` [m/s²] (third item; None unless
        ``accel``): positions, velocities, accelerations, activity."""
        rows = np.arange(self.n) if rows is None else np.asarray(rows, dtype=int)
        t = np.broadcast_to(np.asarray(t, dtype=float), rows.shape)
        times = self.times[rows]
        i = np.count_nonzero(times <= t[:, None], axis=1) - 1
        i = np.minimum(np.maximum(i, 0), self.last_seg[rows])
        t0 = times[np.arange(rows.size), i]
        dt = self.seg_dt[rows, i]
        tau = np.minimum(np.maximum(t - t0, 0.0), dt)
        if self.linear:
            vel = self.vel[rows, i]
            pos = self.pos[rows, i] + vel * tau[:, None]
            acc = np.zeros_like(vel) if accel else None
        else:
            pos, vel, acc = piece_state(self.pos[rows, i], self.vel[rows, i], self.kind[rows, i],
                                        self.par[rows, i], tau, accel=accel)
        inside = (t >= self.t_first[rows]) & (t <= self.t_last[rows])
        if self.hold:
            vel = vel * inside[:, None]
            if acc is not None:
                acc = acc * inside[:, None]
            active = np.ones(rows.shape, dtype=bool)
        else:
            active = inside
        return pos, vel, acc, active

    def _state_one_segment(self, t: ArrayLike, rows: ArrayLike | None
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`state` when every object has one linear piece (same arithmetic)."""
        if rows is None:
            t0, p0, v0, dt0 = self._t0, self._pos0, self._vel0, self._dt0
            first, last = self.t_first, self.t_last
            shape = (self.n,)
        else:
            rows = np.asarray(rows, dtype=int)
            t0, p0, v0, dt0 = self._t0[rows], self._pos0[rows], self._vel0[rows], self._dt0[rows]
            first, last = self.t_first[rows], self.t_last[rows]
            shape = rows.shape
        t = np.asarray(t, dtype=float)
        if t.shape != shape:
            t = np.broadcast_to(t, shape)
        tau = np.minimum(np.maximum(t - t0, 0.0), dt0)
        pos = p0 + v0 * tau[:, None]
        inside = (t >= first) & (t <= last)
        if self.hold:
            return pos, v0 * inside[:, None], np.ones(shape, dtype=bool)
        return pos, v0.copy(), inside


@dataclass(frozen=True)
class Geometry:
    """Antenna-to-object geometry, one entry per object.

    Attributes
    ----------
    azimuth : true-north azimuth from the antenna, clockwise [rad], in [0, 2π)
    ground_range : terrestrial (great-circle) range R_t [m]
    slant_range : slant range R on the 4/3 earth [m]
    elevation : elevation angle at the antenna on the 4/3 earth [rad]
    radial_velocity : range rate, positive receding [m/s]
    los_enu : unit line of sight in the antenna's local east/north/up frame, ``(N, 3)``
    velocity_enu : object velocity relative to the sea in the antenna's frame, ``(N, 3)`` [m/s]
    """

    azimuth: np.ndarray
    ground_range: np.ndarray
    slant_range: np.ndarray
    elevation: np.ndarray
    radial_velocity: np.ndarray
    los_enu: np.ndarray
    velocity_enu: np.ndarray


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (N, 3) arrays (np.cross is several times slower here)."""
    return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
                     a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                     a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)


def north_east(u_a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit east and true-north vectors (ECEF axes) at sphere points ``u_a`` (N, 3).

    east = ẑ × up / |ẑ × up| with ẑ the earth's axis; north = up × east.
    """
    horiz = np.hypot(u_a[:, 0], u_a[:, 1])
    east = np.stack([-u_a[:, 1] / horiz, u_a[:, 0] / horiz, np.zeros(u_a.shape[0])], axis=1)
    return _cross(u_a, east), east


def antenna_azimuth(antenna_enu: np.ndarray, obj_enu: np.ndarray, frame: LocalFrame
                    ) -> tuple[np.ndarray, np.ndarray]:
    """True-north azimuth [rad] and great-circle ground range [m] only (the fast path of
    :func:`antenna_geometry`, used while solving for beam-crossing times)."""
    obj_enu = np.atleast_2d(obj_enu)
    u_a, _ = frame.unit(np.broadcast_to(antenna_enu, obj_enu.shape))
    u_t, _ = frame.unit(obj_enu)
    north, east = north_east(u_a)
    chord = u_t - u_a
    az = np.mod(np.arctan2(np.einsum("ij,ij->i", chord, east),
                           np.einsum("ij,ij->i", chord, north)), TWO_PI)
    cross = np.linalg.norm(_cross(u_a, u_t), axis=1)
    ground = frame.radius * np.arctan2(cross, np.einsum("ij,ij->i", u_a, u_t))
    return az, ground


def antenna_geometry(
    antenna_enu: np.ndarray,
    antenna_vel: np.ndarray,
    antenna_height_m: float,
    obj_enu: np.ndarray,
    obj_vel: np.ndarray,
    frame: LocalFrame,
    k_factor: float = K_FACTOR,
) -> Geometry:
    """Geometry from one antenna to N objects.

    Parameters
    ----------
    antenna_enu : (3,) or (N, 3) platform position(s) in the origin frame (east, north,
        altitude) [m]: one per object when the objects are seen at different times
    antenna_vel : (3,) or (N, 3) platform velocity in the origin frame [m/s]
    antenna_height_m : height of the antenna above the platform's waterline [m]
    obj_enu, obj_vel : (N, 3) object positions [m] and velocities [m/s] in the origin frame
    frame : the scenario's :class:`LocalFrame`

    Azimuth is the initial great-circle bearing at the antenna from true north (exact on the
    sphere), the terrestrial range the great-circle arc, slant range and elevation those of
    the 4/3 earth (:func:`slant_range_elevation`), the radial velocity the rate of the true
    straight-line distance.
    """
    obj_enu = np.atleast_2d(np.asarray(obj_enu, dtype=float))
    obj_vel = np.atleast_2d(np.asarray(obj_vel, dtype=float))
    ant = np.broadcast_to(np.asarray(antenna_enu, dtype=float), obj_enu.shape)
    ant_vel = np.broadcast_to(np.asarray(antenna_vel, dtype=float), obj_enu.shape)
    r = frame.radius
    u_a, s_a = frame.unit(ant)
    u_t, s_t = frame.unit(obj_enu)
    h_a = ant[:, 2] + antenna_height_m
    h_t = obj_enu[:, 2]
    north, east = north_east(u_a)  # local true-north frame at the antenna
    chord = u_t - u_a
    cross = np.linalg.norm(_cross(u_a, u_t), axis=1)
    ground = r * np.arctan2(cross, np.sum(u_a * u_t, axis=1))
    azimuth = np.mod(np.arctan2(np.sum(chord * east, axis=1), np.sum(chord * north, axis=1)),
                     TWO_PI)
    slant, elev = slant_range_elevation(ground, h_a, h_t, k_factor, radius_m=r)
    los = np.stack([np.sin(azimuth) * np.cos(elev), np.cos(azimuth) * np.cos(elev), np.sin(elev)],
                   axis=-1)
    v_t = frame.velocity(u_t, s_t, h_t, obj_vel)
    v_a = frame.velocity(u_a, s_a, h_a, ant_vel)
    d = (r + h_t)[:, None] * u_t - (r + h_a)[:, None] * u_a
    dn = np.linalg.norm(d, axis=1)
    radial = np.sum((v_t - v_a) * d, axis=1) / np.where(dn > 0, dn, 1.0)
    vel_enu = np.stack([np.sum(v_t * east, axis=1), np.sum(v_t * north, axis=1),
                        np.sum(v_t * u_a, axis=1)], axis=-1)
    return Geometry(azimuth, ground, slant, elev, radial, los, vel_enu)


def gaussian_radius_m(lat_deg: ArrayLike) -> NDArray[np.float64]:
    """Gaussian mean radius of curvature √(M N) of the WGS-84 ellipsoid at a latitude [m]."""
    a, f = 6_378_137.0, 1.0 / 298.257223563
    e2 = f * (2.0 - f)
    s2 = np.sin(np.radians(lat_deg)) ** 2
    return a * np.sqrt(1.0 - e2) / (1.0 - e2 * s2)


def wrap_pi(a: np.ndarray) -> np.ndarray:
    """Angle wrapped to [-π, π) [rad]."""
    return np.mod(np.asarray(a) + np.pi, TWO_PI) - np.pi


#: Time tolerance of the beam-crossing solver [s]: its safeguarded Newton iteration stops
#: when a step or the root's bracket is shorter (the root is then exact to the last bits).
CROSSING_TOL_S = 1e-9
#: Horizontal distance from the antenna's vertical within which an object has no azimuth
#: the beam can meet [m]: an interval over which it stays that close holds no crossing (a
#: target hovering over the mast would otherwise be split down to the resolution).
CROSSING_VERTICAL_M = 1.0
#: The crossing search's resolution [s]: an interval the rate bound cannot certify is split
#: until it is this short; its crossings are sign changes at this resolution (a tangency rule).
CROSSING_RESOLUTION_S = 1e-6


#: The crossing search's view of the objects: ``look_at(t (M,) [s], idx (M,) object indices)``
#: -> azimuth [rad], its rate [rad/s] (an estimate: it only speeds the Newton steps up) and
#: ground range [m].
LookAt = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]


class _Intervals(NamedTuple):
    """Intervals of the crossing search, one row each: the object, the ends t0, t1 [s], and at
    the ends the object's azimuth [rad], its ground range [m] and the beam's lead over it
    (:func:`_beam_lead`) [rad]."""

    obj: np.ndarray
    t0: np.ndarray
    t1: np.ndarray
    az0: np.ndarray
    az1: np.ndarray
    rho0: np.ndarray
    rho1: np.ndarray
    d0: np.ndarray
    d1: np.ndarray


class _Brackets(NamedTuple):
    """Brackets [lo, hi] [s] of the roots of D - 2πk, one row each: the object; a reference
    time [s], the azimuth there [rad] and D - 2πk there [rad] (D's unwrapping); ``sign`` 1
    where D increases through the root, -1 where it decreases."""

    obj: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    ref_t: np.ndarray
    ref_az: np.ndarray
    ref_d: np.ndarray
    sign: np.ndarray


@dataclass(frozen=True, eq=False)
class CrossingSearch:
    """The inputs of one beam-crossing search (:func:`beam_crossings`) and its steps.

    The beam turns as β(t) = β_a + ω (t - t_a); object i's true-north azimuth az_i(t) from
    the antenna has a rate |az_i'| ≤ A = v_i/ρ_min + slack on any interval, with v_i a bound
    on its horizontal speed relative to the antenna and ρ_min ≥ (ρ_0 + ρ_1 - v_i h)/2 the
    least ground range the interval's end ranges allow.  A crossing is a root of
    D(t) = β(t) - az(t) - 2πk, the beam's lead over the object, unwrapped; D' = ω - az'.

    The search works on intervals, all objects at once, every interval a revolution at first
    (:meth:`_pass`, once per halving):

    * ``A h < π`` unwraps the azimuth over the interval (D at its end is known, not only
      modulo 2π); else the interval is split;
    * ``A < ω``: D increases, its roots are the multiples of 2π in [D(t0), D(t1)) (0, 1, 2 or
      more: an object moving against the rotation can be met twice in a revolution, one
      moving with it faster than the beam not at all), each bracketed;
    * otherwise (the object may outrun the beam) the interval is dropped when the envelope
      D(t0) ± (ω + A)(t - t0), D(t1) ∓ (ω + A)(t1 - t) holds no multiple of 2π, else split;
      at ``resolution_s`` each sign change of D - 2πk is a crossing (tangency rule: the beam
      reaching the azimuth without passing it within the resolution is no crossing, nor are
      two crossings closer than the resolution; an object passing within v × resolution of
      the antenna's vertical, where the azimuth is undefined, is not met there, nor is one
      staying within ``vertical_m`` of it all through an interval).

    Each bracketed root is then solved by Newton's method with the object's own angular rate
    in the step, t ← t - D/(ω - az'), bisecting whenever a step leaves the bracket, to
    ``tol_s`` (:meth:`_solve`).  A root lies in [t0, t1) of the interval holding it, and a
    revolution owns the crossings in its half-open [t_a, t_b): β and az at a shared boundary
    are the same numbers for both revolutions (``beam_b`` of one is ``beam_a`` of the next),
    so a crossing on the boundary is counted once, by the later revolution.

    The fields are the parameters of :func:`beam_crossings` (the arrays float64), with the
    solver's tolerances ``tol_s``, ``resolution_s`` (:data:`CROSSING_TOL_S`,
    :data:`CROSSING_RESOLUTION_S`) and ``vertical_m`` (:data:`CROSSING_VERTICAL_M`) [m].
    """

    look_at: LookAt
    t_a: np.ndarray
    t_b: np.ndarray
    beam_a: np.ndarray
    beam_b: np.ndarray
    rate_rad_s: float
    speed_m_s: np.ndarray
    rate_slack_rad_s: float = 0.0
    min_separation_s: float = 0.0
    ends: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
    tol_s: float = CROSSING_TOL_S
    resolution_s: float = CROSSING_RESOLUTION_S
    vertical_m: float = CROSSING_VERTICAL_M

    def crossings(self) -> tuple[np.ndarray, np.ndarray]:
        """The object index and time [s] of every crossing, sorted by object then time."""
        found: list[_Brackets] = []
        iv: _Intervals | None = self._revolutions()
        while iv is not None and iv.obj.size:
            iv = self._pass(iv, found)
        if not found:
            return np.zeros(0, np.int64), np.zeros(0)
        brackets = _Brackets(*(np.concatenate(c) for c in zip(*found, strict=True)))
        t = self._solve(brackets)
        order = np.lexsort((t, brackets.obj))
        b_i, t = _first_of_close(brackets.obj[order], t[order], self.min_separation_s)
        return b_i.astype(np.int64), t

    def _revolutions(self) -> _Intervals:
        """The first intervals: each object's whole search [t_a, t_b)."""
        ids = np.arange(self.t_a.size)
        if self.ends is None:
            az_a, _, rho_a = self.look_at(self.t_a, ids)
            az_b, _, rho_b = self.look_at(self.t_b, ids)
        else:
            az_a, rho_a, az_b, rho_b = self.ends
        return _Intervals(ids, self.t_a, self.t_b, az_a, az_b, rho_a, rho_b,
                          _beam_lead(self.beam_a - az_a), _beam_lead(self.beam_b - az_b))

    def _pass(self, iv: _Intervals, found: list[_Brackets]) -> _Intervals | None:
        """One pass over the intervals: the brackets it finds appended to ``found``; returns
        the halves of the intervals it cannot decide (None when there are none)."""
        w = self.rate_rad_s
        h = iv.t1 - iv.t0
        v = self.speed_m_s[iv.obj]
        bound = self._rate_bound(iv, v, h)
        unwraps = bound * h < np.pi
        # D at t1 with D(t0) = d0 in [0, 2π): d1 plus the whole turns between
        turns = np.round((iv.d0 + w * h - wrap_pi(iv.az1 - iv.az0) - iv.d1) / TWO_PI)
        big_d1 = iv.d1 + TWO_PI * turns
        rising = unwraps & (bound < w)
        if rising.any():
            got = self._rising(iv, np.flatnonzero(rising), bound, turns, big_d1)
            if got is not None:
                found.append(got)
        # the others: dropped when no multiple of 2π is within the envelope, else split
        rest = ~rising
        half = 0.5 * (w + bound) * h
        mid_d = 0.5 * (iv.d0 + big_d1)
        near = np.ceil((mid_d - half) / TWO_PI) <= np.floor((mid_d + half) / TWO_PI)
        rest &= ~unwraps | near
        # an object that stays within vertical_m of the antenna's vertical all through the
        # interval has no azimuth to meet there
        rest &= 0.5 * (iv.rho0 + iv.rho1 + v * h) > self.vertical_m
        leaf = rest & (h <= self.resolution_s)
        if leaf.any():
            found.append(_sign_changes(np.flatnonzero(leaf & unwraps), iv, big_d1))
        split = np.flatnonzero(rest & ~leaf)
        return self._halves(iv, split) if split.size else None

    def _rate_bound(self, iv: _Intervals, v: np.ndarray, h: np.ndarray) -> np.ndarray:
        """A = v/ρ_min + slack, the bound on the azimuth's rate over each interval [rad/s]
        (infinite when the ground range may vanish); ``v`` [m/s], ``h`` the lengths [s]."""
        rho_min = 0.5 * (iv.rho0 + iv.rho1 - v * h)
        with np.errstate(divide="ignore"):
            bound = np.where(rho_min > 0.0, v / np.where(rho_min > 0.0, rho_min, 1.0), np.inf)
        return bound + self.rate_slack_rad_s

    def _rising(self, iv: _Intervals, r: np.ndarray, bound: np.ndarray, turns: np.ndarray,
                big_d1: np.ndarray) -> _Brackets | None:
        """Brackets of the roots on intervals ``r``, where D increases: k = (0 if d0 = 0 else
        1) ... (turns if d1 > 0 else turns - 1), each between the lines of slopes ω ± A
        through both ends; None when there are none."""
        w = self.rate_rad_s
        t0, t1, d0 = iv.t0, iv.t1, iv.d0
        k_lo = (d0[r] > 0.0).astype(np.int64)
        k_hi = turns[r].astype(np.int64) - (iv.d1[r] <= 0.0)
        count = np.maximum(k_hi - k_lo + 1, 0)
        if not count.any():
            return None
        rr = np.repeat(r, count)
        k = np.repeat(k_lo, count) + _ranks(count)
        target = TWO_PI * k
        a = bound[rr]
        lo = np.maximum(t0[rr] + (target - d0[rr]) / (w + a),
                        t1[rr] - (big_d1[rr] - target) / (w - a))
        hi = np.minimum(t0[rr] + (target - d0[rr]) / (w - a),
                        t1[rr] - (big_d1[rr] - target) / (w + a))
        lo = np.clip(lo, t0[rr], t1[rr])
        hi = np.clip(hi, lo, t1[rr])
        return _Brackets(iv.obj[rr], lo, hi, t0[rr], iv.az0[rr], d0[rr] - target,
                         np.ones(rr.size))

    def _halves(self, iv: _Intervals, split: np.ndarray) -> _Intervals:
        """Intervals ``split`` cut at their midpoints: every first half, then every second."""
        w = self.rate_rad_s
        tm = 0.5 * (iv.t0[split] + iv.t1[split])
        js = iv.obj[split]
        azm, _, rhom = self.look_at(tm, js)
        dm = _beam_lead(self.beam_a[js] + w * (tm - self.t_a[js]) - azm)
        cat = np.concatenate
        return _Intervals(cat([js, js]), cat([iv.t0[split], tm]), cat([tm, iv.t1[split]]),
                          cat([iv.az0[split], azm]), cat([azm, iv.az1[split]]),
                          cat([iv.rho0[split], rhom]), cat([rhom, iv.rho1[split]]),
                          cat([iv.d0[split], dm]), cat([dm, iv.d1[split]]))

    def _solve(self, b: _Brackets) -> np.ndarray:
        """Roots [s] of D(t) = ref_d + ω (t - ref_t) - wrap(az(t) - ref_az) on the brackets,
        where D goes from ``-sign`` to ``sign``: safeguarded Newton with the object's own
        rate, D' = ω - az', bisecting whenever a step leaves the bracket."""
        w, i, sign = self.rate_rad_s, b.obj, b.sign
        ref_t, ref_az, ref_d = b.ref_t, b.ref_az, b.ref_d
        lo, hi = b.lo.copy(), b.hi.copy()
        # first guess: where the beam would meet the object frozen at the bracket's reference
        t = np.clip(ref_t - ref_d / w, lo, hi)
        out = t.copy()
        act = np.arange(i.size)
        for _ in range(200):
            az, rate, _ = self.look_at(t, i[act])
            f = (ref_d[act] + w * (t - ref_t[act]) - wrap_pi(az - ref_az[act])) * sign[act]
            below = f < 0.0
            lo[act] = np.where(below, t, lo[act])
            hi[act] = np.where(below, hi[act], t)
            slope = (w - rate) * sign[act]
            with np.errstate(divide="ignore", invalid="ignore"):
                step = -f / slope
            nt = t + step
            newton = (slope > 0.0) & (nt >= lo[act]) & (nt <= hi[act])
            nt = np.where(newton, nt, 0.5 * (lo[act] + hi[act]))
            done = ((newton & (np.abs(step) <= self.tol_s)) | (hi[act] - lo[act] <= self.tol_s)
                    | (f == 0.0))
            out[act] = np.where(f == 0.0, t, nt)
            keep = ~done
            act, t = act[keep], nt[keep]
            if not act.size:
                break
        return out


def beam_crossings(
    look_at: LookAt,
    t_a: ArrayLike,
    t_b: ArrayLike,
    beam_a: ArrayLike,
    beam_b: ArrayLike,
    rate_rad_s: float,
    speed_m_s: ArrayLike,
    rate_slack_rad_s: float = 0.0,
    min_separation_s: float = 0.0,
    ends: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Every time in ``[t_a, t_b)`` at which a clockwise beam meets each of N objects.

    The search and its guarantees are those of :class:`CrossingSearch` (which also takes the
    solver's tolerances, fixed here at their defaults).

    Parameters
    ----------
    look_at : callable(t (M,) [s], idx (M,) object indices) -> azimuth [rad], its rate
        [rad/s] (an estimate: it only speeds the Newton steps up) and ground range [m]
    t_a, t_b : (N,) start and end of each object's search [s]
    beam_a, beam_b : (N,) beam azimuth at ``t_a`` and ``t_b`` [rad]
    rate_rad_s : rotation rate ω > 0 [rad/s]
    speed_m_s : (N,) bound on each object's horizontal speed relative to the antenna [m/s]
    rate_slack_rad_s : added to the azimuth-rate bound (the true-north frame's own rotation
        along a moving antenna's track, the sphere's departure from the plane) [rad/s]
    min_separation_s : crossings of one object closer than this are one (the first) [s]
    ends : optional (N,) azimuths [rad] and ground ranges [m] at ``t_a`` and at ``t_b``
        (az_a, ground_a, az_b, ground_b), when the caller has them (one revolution's end is
        the next one's start); else ``look_at`` gives them

    Returns
    -------
    idx, t : the object index and time [s] of every crossing, sorted by object then time
    """
    t_a, t_b, beam_a, beam_b, speed_m_s = (np.asarray(x, dtype=float)
                                           for x in (t_a, t_b, beam_a, beam_b, speed_m_s))
    return CrossingSearch(look_at, t_a, t_b, beam_a, beam_b, float(rate_rad_s), speed_m_s,
                          rate_slack_rad_s, min_separation_s, ends).crossings()


def _first_of_close(b_i: np.ndarray, t: np.ndarray, min_separation_s: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Crossings ``b_i``, ``t`` (sorted by object then time) without those closer than
    ``min_separation_s`` [s] after the object's last one kept (greedy, in time: a close pair
    is its first; a chain of close crossings longer than ``min_separation_s`` keeps more
    than one)."""
    if b_i.size > 1 and min_separation_s > 0.0:
        keep = np.ones(b_i.size, dtype=bool)
        same = b_i[1:] == b_i[:-1]
        close = same & (t[1:] - t[:-1] < min_separation_s)
        if close.any():  # a run of close crossings is one: keep its first (objects with one)
            for obj in np.unique(b_i[1:][close]).tolist():
                rows = np.flatnonzero(b_i == obj)
                last_kept = t[rows[0]]
                for j in rows[1:].tolist():
                    if t[j] - last_kept < min_separation_s:
                        keep[j] = False
                    else:
                        last_kept = t[j]
            b_i, t = b_i[keep], t[keep]
    return b_i, t


def _beam_lead(x: np.ndarray) -> np.ndarray:
    """The beam's lead over an azimuth modulo 2π, in [0, 2π) [rad] (2π itself, which np.mod
    gives for a tiny negative lead, is 0: the beam is on the object)."""
    d = np.mod(x, TWO_PI)
    return np.where(d >= TWO_PI, 0.0, d)


def _ranks(count: np.ndarray) -> np.ndarray:
    """0, 1, ..., c - 1 for each c of ``count``, concatenated."""
    total = int(count.sum())
    starts = np.repeat(np.cumsum(count) - count, count)
    return np.arange(total) - starts


def _sign_changes(r: np.ndarray, iv: _Intervals, big_d1: np.ndarray) -> _Brackets:
    """Brackets of the sign changes of D - 2πk over the intervals ``r`` of ``iv`` (the
    search's leaves): D from d0 at t0 to ``big_d1`` at t1, up or down; a root at t0 itself
    (d0 = 0) counts, one at t1 belongs to the next interval."""
    i, t0, t1, az0, d0 = iv.obj[r], iv.t0[r], iv.t1[r], iv.az0[r], iv.d0[r]
    d1 = big_d1[r]
    up = d1 >= d0
    # up: multiples in [d0, d1); down: in (d1, d0]
    k_lo = np.where(up, np.ceil(d0 / TWO_PI), np.floor(d1 / TWO_PI) + 1).astype(np.int64)
    k_hi = np.where(up, np.ceil(d1 / TWO_PI) - 1, np.floor(d0 / TWO_PI)).astype(np.int64)
    count = np.maximum(k_hi - k_lo + 1, 0)
    rr = np.repeat(np.arange(r.size), count)
    k = np.repeat(k_lo, count) + _ranks(count)
    target = TWO_PI * k
    return _Brackets(i[rr], t0[rr], t1[rr], t0[rr], az0[rr], d0[rr] - target,
                     np.where(up[rr], 1.0, -1.0))
