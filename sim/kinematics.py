"""Kinematics and radar geometry, vectorized over objects.

Positions are kept in the scenario origin's local frame: east and north [m] on the tangent
plane (waypoints given as latitude/longitude are converted once with ``pymap3d``) and the
altitude above the sea [m].  Motion between waypoints is at constant velocity.

Geometry from an antenna to its targets is computed on the WGS-84 ellipsoid (``pymap3d``):
true-north azimuth in the antenna's own local frame (so a ship 100 km from the origin still
reports true north, not grid north), terrestrial range along the earth, and slant range and
elevation on the 4/3 effective earth used throughout the radar model.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pymap3d

from sim.scenario import Origin, Waypoint

#: Mean earth radius [m] (IUGG).
EARTH_RADIUS_M = 6_371_008.8
#: Effective earth-radius factor of the standard atmosphere.
K_FACTOR = 4.0 / 3.0
TWO_PI = 2.0 * np.pi


def waypoint_enu(waypoints: Sequence[Waypoint], origin: Origin) -> np.ndarray:
    """Waypoints as an ``(W, 4)`` array of (time [s], east [m], north [m], altitude [m])."""
    out = np.empty((len(waypoints), 4))
    for i, w in enumerate(waypoints):
        if w.lat_deg is not None:
            e, n, _ = pymap3d.geodetic2enu(w.lat_deg, w.lon_deg, 0.0,
                                           origin.lat_deg, origin.lon_deg, 0.0)
        else:
            e, n = w.east_m, w.north_m
        out[i] = (w.time_s, e, n, w.altitude_m)
    return out


class Trajectories:
    """Piecewise-linear tracks of N objects, evaluated for all of them at once.

    Parameters
    ----------
    tracks : list of ndarray
        One ``(W_i, 4)`` array per object (see :func:`waypoint_enu`).
    hold : bool
        If True (platforms, jammers) an object holds its first/last position outside its
        waypoint times and is always active; if False (targets) it exists only between its
        first and last waypoint times.
    """

    def __init__(self, tracks: Sequence[np.ndarray], hold: bool):
        self.n = len(tracks)
        self.hold = hold
        w = max((len(t) for t in tracks), default=1)
        self.times = np.full((self.n, w), np.inf)
        self.pos = np.zeros((self.n, w, 3))
        self.count = np.array([len(t) for t in tracks], dtype=int)
        for i, t in enumerate(tracks):
            k = len(t)
            self.times[i, :k] = t[:, 0]
            self.pos[i, :k] = t[:, 1:]
            self.pos[i, k:] = t[-1, 1:]
        self.t_first = self.times[:, 0] if self.n else np.zeros(0)
        self.t_last = self.times[np.arange(self.n), self.count - 1] if self.n else np.zeros(0)

    def state(
        self, t: float | np.ndarray, rows: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions ``(M, 3)`` [m], velocities ``(M, 3)`` [m/s] and activity ``(M,)``.

        ``rows`` picks the objects (default: all N, M = N; repeats allowed, e.g. one platform
        at many times); ``t`` is a scalar or one time per row [s].
        """
        rows = np.arange(self.n) if rows is None else np.asarray(rows, dtype=int)
        t = np.broadcast_to(np.asarray(t, dtype=float), rows.shape)
        times, count = self.times[rows], self.count[rows]
        # segment index: last waypoint with time <= t, limited so that i+1 exists
        i = np.sum(times <= t[:, None], axis=1) - 1
        i = np.clip(i, 0, np.maximum(count - 2, 0))
        single = count == 1
        j = np.where(single, i, i + 1)
        t0, t1 = self.times[rows, i], self.times[rows, j]
        p0, p1 = self.pos[rows, i], self.pos[rows, j]
        dt = np.where(single, 1.0, t1 - t0)
        vel = np.where(single[:, None], 0.0, (p1 - p0) / dt[:, None])
        tau = np.clip(t - t0, 0.0, np.where(single, 0.0, dt))
        pos = p0 + vel * tau[:, None]
        inside = (t >= self.t_first[rows]) & (t <= self.t_last[rows])
        if self.hold:
            vel = np.where(inside[:, None], vel, 0.0)
            active = np.ones(rows.shape, dtype=bool)
        else:
            active = inside
        return pos, vel, active


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


def slant_range_elevation(
    ground_range_m: np.ndarray, h1_m: np.ndarray, h2_m: np.ndarray, k_factor: float = K_FACTOR
) -> tuple[np.ndarray, np.ndarray]:
    """Slant range [m] and elevation [rad] between heights h1 and h2 a ground range apart.

    Spherical earth of effective radius k·a: central angle γ = R_t/(k a), law of cosines for
    the slant range, and elevation atan2((a_e+h2) cos γ - (a_e+h1), (a_e+h2) sin γ).  At zero
    ground range the elevation is ±90° (or 0 if the heights are equal, where R = 0).
    """
    a_e = k_factor * EARTH_RADIUS_M
    g = np.asarray(ground_range_m, dtype=float) / a_e
    r1 = a_e + np.asarray(h1_m, dtype=float)
    r2 = a_e + np.asarray(h2_m, dtype=float)
    # 2 r1 r2 (1 - cos γ) = 4 r1 r2 sin²(γ/2): no cancellation at short range
    slant = np.sqrt((r2 - r1) ** 2 + 4.0 * r1 * r2 * np.sin(0.5 * g) ** 2)
    elev = np.arctan2(r2 * np.cos(g) - r1, r2 * np.sin(g))
    return slant, elev


def enu_to_geodetic(enu: np.ndarray, origin: Origin) -> tuple[np.ndarray, np.ndarray]:
    """Latitude and longitude [deg] of origin-frame east/north positions ``(N, >=2)``."""
    lat, lon, _ = pymap3d.enu2geodetic(enu[..., 0], enu[..., 1], 0.0,
                                       origin.lat_deg, origin.lon_deg, 0.0)
    return np.asarray(lat, dtype=float), np.asarray(lon, dtype=float)


def antenna_geometry(
    antenna_enu: np.ndarray,
    antenna_vel: np.ndarray,
    antenna_height_m: float,
    obj_enu: np.ndarray,
    obj_vel: np.ndarray,
    origin: Origin,
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
    origin : the scenario origin
    """
    obj_enu = np.atleast_2d(obj_enu)
    ant = np.broadcast_to(np.asarray(antenna_enu, dtype=float), obj_enu.shape)
    ant_vel = np.broadcast_to(np.asarray(antenna_vel, dtype=float), obj_enu.shape)
    lat_a, lon_a = enu_to_geodetic(ant, origin)
    lat_o, lon_o = enu_to_geodetic(obj_enu, origin)
    h_a = ant[:, 2] + antenna_height_m
    x, y, z = pymap3d.geodetic2ecef(lat_o, lon_o, obj_enu[:, 2])
    e, n, u = pymap3d.ecef2enu(x, y, z, lat_a, lon_a, h_a)
    e, n, u = (np.asarray(c, dtype=float) for c in (e, n, u))
    azimuth = np.mod(np.arctan2(e, n), TWO_PI)
    # terrestrial range: arc on the sphere of the local Gaussian radius that osculates the
    # ellipsoid at the antenna, centre (R + h_a) below it in its own frame
    r_loc = gaussian_radius_m(lat_a)
    ground = r_loc * np.arctan2(np.hypot(e, n), u + r_loc + h_a)
    slant, elev = slant_range_elevation(ground, h_a, obj_enu[:, 2], k_factor)
    los = np.stack([np.sin(azimuth) * np.cos(elev), np.cos(azimuth) * np.cos(elev), np.sin(elev)],
                   axis=-1)
    # velocities: origin frame -> ECEF -> antenna frame (the frames differ by the convergence
    # of the meridians, about a degree per 100 km at mid latitude)
    rel = np.asarray(obj_vel, dtype=float) - ant_vel
    vel_enu = _rotate_origin_to_local(np.asarray(obj_vel, dtype=float), origin, lat_a, lon_a)
    rel_enu = _rotate_origin_to_local(rel, origin, lat_a, lon_a)
    radial = np.sum(rel_enu * los, axis=-1)
    return Geometry(azimuth, ground, slant, elev, radial, los, vel_enu)


def _rotate_origin_to_local(
    v: np.ndarray, origin: Origin, lat: np.ndarray, lon: np.ndarray
) -> np.ndarray:
    u, w, s = pymap3d.enu2uvw(v[:, 0], v[:, 1], v[:, 2], origin.lat_deg, origin.lon_deg)
    e, n, up = pymap3d.uvw2enu(u, w, s, lat, lon)
    return np.stack([np.asarray(e), np.asarray(n), np.asarray(up)], axis=-1).astype(float)


def gaussian_radius_m(lat_deg: np.ndarray) -> np.ndarray:
    """Gaussian mean radius of curvature √(M N) of the WGS-84 ellipsoid at a latitude [m]."""
    a, f = 6_378_137.0, 1.0 / 298.257223563
    e2 = f * (2.0 - f)
    s2 = np.sin(np.radians(lat_deg)) ** 2
    return a * np.sqrt(1.0 - e2) / (1.0 - e2 * s2)


def wrap_pi(a: np.ndarray) -> np.ndarray:
    """Angle wrapped to [-π, π) [rad]."""
    return np.mod(np.asarray(a) + np.pi, TWO_PI) - np.pi


def beam_crossing_times(
    azimuth_at,
    t_start: float,
    beam_azimuth_start: float,
    rate_rad_s: float,
    n: int,
    iterations: int = 6,
) -> np.ndarray:
    """First time at or after ``t_start`` when a clockwise-rotating beam meets each object.

    Solves β(t) ≡ az_i(t) (mod 2π) with β(t) = β_start + ω (t - t_start), for all objects
    at once: a first estimate from the azimuths at ``t_start``, then Newton-like refinements
    t ← t + wrap(az(t) - β(t))/ω, exact when the objects' angular rates are small against ω
    (a target at 300 m/s and 1 km moves 0.3 rad/s; a 6 rpm antenna turns 0.63 rad/s).

    Parameters
    ----------
    azimuth_at : callable(t (N,) [s]) -> (N,) true-north azimuth from the antenna [rad]
    t_start : start of the search [s]
    beam_azimuth_start : beam azimuth at ``t_start`` [rad]
    rate_rad_s : rotation rate ω > 0 [rad/s]
    n : number of objects
    """
    t0 = np.full(n, float(t_start))
    t = t0 + np.mod(azimuth_at(t0) - beam_azimuth_start, TWO_PI) / rate_rad_s
    for _ in range(iterations):
        beam = beam_azimuth_start + rate_rad_s * (t - t_start)
        t = t + wrap_pi(azimuth_at(t) - beam) / rate_rad_s
    return t
