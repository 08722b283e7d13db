"""The stream's frames: plots (slant range, azimuth), local east/north/up, and geodetic.

A tracker reads plots as (slant range, true-north azimuth) from a moving antenna, and
positions (``eos``, ``truth``) as east/north/up in the scenario's local frame; these
functions convert between the three with the geometry the engine itself uses to turn a
target's true position into its plot (:func:`shipradar.sim.world.kinematics.antenna_geometry`),
so that a conversion and the simulation agree to float precision (docs/protocol.md 4, "The
frame").

The local frame (:class:`shipradar.sim.world.kinematics.LocalFrame`):

* ``east``, ``north`` [m] are coordinates on the plane tangent to the WGS-84 ellipsoid at
  the origin (``meta.origin``); the point they name is that plane's point projected from
  the centre of the sphere of the Gaussian radius R = √(M N) at the origin's latitude (the
  sphere osculating the ellipsoid there) onto the sphere. ``up`` [m] is the altitude above
  that sphere, along its vertical: the height above the sea wherever the point is, not the
  height above the tangent plane.
* Azimuth is the initial great-circle bearing on that sphere from the antenna, from true
  north, clockwise.  The ground range is the great-circle arc at sea level.
* Slant range is that of the 4/3 effective earth (standard refraction): on a sphere of
  radius k R (k = 4/3), heights h1 (antenna) and h2 (target) a ground range G apart are
  R_s = √((h2 - h1)² + 4 (kR + h1)(kR + h2) sin²(G / (2 k R))) (law of cosines;
  :func:`shipradar.sensors.geometry.slant_range_elevation`).

A plot has no elevation: a 2-D radar measures range and azimuth only, so placing a plot
needs the target's altitude (``target_up_m``), taken as the sea surface (0) unless known.
With the wrong altitude the ground range, not the azimuth, is wrong.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shipradar.sensors.geometry import K_FACTOR
from shipradar.sim.world import geodesy
from shipradar.sim.world.kinematics import (
    LocalFrame,
    antenna_geometry,
    north_east,
)
from shipradar.sim.world.scenario import Origin

__all__ = [
    "PlotGeometry",
    "geodetic_to_local",
    "local_frame",
    "local_to_geodetic",
    "local_to_plot",
    "plot_to_geodetic",
    "plot_to_local",
]

#: What names the local frame: the scenario's :class:`~shipradar.sim.world.scenario.Origin`,
#: the ``meta.origin`` mapping of the stream (``lat_deg``, ``lon_deg``; ``alt_m`` ignored:
#: the frame's sea surface is the ellipsoid), or a ready :class:`LocalFrame`.
OriginLike = Origin | Mapping[str, Any] | LocalFrame

#: Fixed-point iterations of :func:`geodetic_to_local` (each shrinks the error ~10^4 times).
_GEODETIC_ITERATIONS = 3


class PlotGeometry(NamedTuple):
    """What :func:`local_to_plot` returns, one entry per target."""

    #: Slant range on the 4/3 earth [m] (the plot's ``range_m`` without noise).
    range_m: NDArray[np.float64]
    #: True-north azimuth from the antenna, clockwise, in [0, 2π) [rad].
    azimuth_rad: NDArray[np.float64]
    #: Elevation at the antenna on the 4/3 earth [rad] (a plot does not carry it).
    elevation_rad: NDArray[np.float64]
    #: Great-circle ground range at sea level [m].
    ground_range_m: NDArray[np.float64]
    #: Rate of the straight-line antenna-target distance, positive receding [m/s] (the
    #: plot's ``range_rate_mps`` before the Doppler bank folds and quantises it); NaN unless
    #: the velocities are given.
    range_rate_mps: NDArray[np.float64]


@functools.lru_cache(maxsize=32)
def _frame(lat_deg: float, lon_deg: float) -> LocalFrame:
    return LocalFrame(Origin(lat_deg=lat_deg, lon_deg=lon_deg))


def local_frame(origin: OriginLike) -> LocalFrame:
    """The scenario's local frame from its origin (see :data:`OriginLike`)."""
    if isinstance(origin, LocalFrame):
        return origin
    if isinstance(origin, Origin):
        return _frame(float(origin.lat_deg), float(origin.lon_deg))
    return _frame(float(origin["lat_deg"]), float(origin["lon_deg"]))


def _enu(x: ArrayLike) -> NDArray[np.float64]:
    a = np.asarray(x, dtype=float)
    if a.shape[-1:] != (3,):
        raise ValueError(f"positions must have a last axis of 3 (east, north, up) [m], got "
                         f"shape {a.shape}")
    return a


def plot_to_local(
    range_m: ArrayLike,
    azimuth_rad: ArrayLike,
    sensor_enu: ArrayLike,
    origin: OriginLike,
    target_up_m: ArrayLike = 0.0,
    k_factor: float = K_FACTOR,
) -> NDArray[np.float64]:
    """Local east/north/up of plots, given the antenna and the target's altitude.

    The inverse of :func:`local_to_plot` for a known target altitude.

    Parameters
    ----------
    range_m : array_like
        Slant range from the antenna [m] (the plot's ``range_m``).
    azimuth_rad : array_like
        True-north azimuth from the antenna, clockwise [rad] (the plot's ``azimuth_rad``).
    sensor_enu : array_like, shape (3,) or (..., 3)
        The antenna's east, north [m] and altitude above the sea [m] in the local frame:
        ``eos`` (or ``meta``) ``position``'s ``east_m``, ``north_m``, ``up_m`` (``up_m`` is
        the antenna's own height, platform altitude plus mast), at the plot's time.
    origin : Origin, mapping or LocalFrame
        The local frame's origin (``meta.origin``).
    target_up_m : array_like, optional
        The target's altitude above the sea [m]. A plot carries no elevation, so this is an
        assumption: 0 (the sea surface, a ship) by default; an aircraft's plot needs its
        altitude, else its ground range comes out too long.
    k_factor : float, optional
        Effective earth-radius factor (4/3, the model's).

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        East, north [m] and up (= ``target_up_m``) [m] of each plot, broadcast over the
        inputs. NaN where the slant range is shorter than the height difference between
        antenna and target (no point at that altitude is that close) or the point would lie
        a quarter of the earth or more from the origin.

    Notes
    -----
    With a = k R (R: the frame's sphere radius), r1 = a + h_antenna, r2 = a + h_target,
    the 4/3-earth central angle is γ = 2 asin √((R_s² - (r2 - r1)²) / (4 r1 r2)), the ground
    range G = a γ, the central angle on the sphere σ = G / R = k γ, and the target's
    direction from the sphere's centre u_t = cos σ u_a + sin σ (cos θ n̂ + sin θ ê) with ê,
    n̂ true east and north at the antenna's direction u_a: the great circle from the antenna
    along azimuth θ.  Then the point is projected back onto the tangent plane.
    """
    frame = local_frame(origin)
    sensor = _enu(sensor_enu)
    r, az, h_t, e_a, n_a, h_a = np.broadcast_arrays(
        np.asarray(range_m, dtype=float), np.asarray(azimuth_rad, dtype=float),
        np.asarray(target_up_m, dtype=float), sensor[..., 0], sensor[..., 1], sensor[..., 2])
    shape = r.shape
    r, az, h_t = r.reshape(-1), az.reshape(-1), h_t.reshape(-1)
    ant = np.stack([e_a.reshape(-1), n_a.reshape(-1), h_a.reshape(-1)], axis=1)
    a_e = k_factor * frame.radius
    r1, r2 = a_e + ant[:, 2], a_e + h_t
    s2 = (r * r - (r2 - r1) ** 2) / (4.0 * r1 * r2)
    ok = (s2 >= 0.0) & (s2 <= 1.0)
    gamma = 2.0 * np.arcsin(np.sqrt(np.where(ok, s2, 0.0)))
    sigma = k_factor * gamma
    u_a, _ = frame.unit(ant)
    north, east = north_east(u_a)
    heading = np.cos(az)[:, None] * north + np.sin(az)[:, None] * east
    u_t = np.cos(sigma)[:, None] * u_a + np.sin(sigma)[:, None] * heading
    up0 = u_t @ frame.up0
    ok &= up0 > 1e-9  # the tangent plane reaches the point (less than 90° from the origin)
    t = u_t * (frame.radius / np.where(ok, up0, 1.0))[:, None]
    out = np.stack([t @ frame.east0, t @ frame.north0, h_t], axis=1)
    out[~ok] = np.nan
    return out.reshape(*shape, 3)


def local_to_plot(
    target_enu: ArrayLike,
    sensor_enu: ArrayLike,
    origin: OriginLike,
    target_velocity_enu: ArrayLike | None = None,
    sensor_velocity_enu: ArrayLike | None = None,
    k_factor: float = K_FACTOR,
) -> PlotGeometry:
    """Slant range, azimuth (and elevation, ground range, range rate) of targets from an
    antenna: the plot a target gives without measurement noise.

    This is the engine's own truth-to-plot geometry
    (:func:`shipradar.sim.world.kinematics.antenna_geometry`), not a copy of it.

    Parameters
    ----------
    target_enu : array_like, shape (3,) or (N, 3)
        Targets' east, north, up [m] in the local frame (``truth[targets]``).
    sensor_enu : array_like, shape (3,) or (N, 3)
        The antenna's east, north, up [m] (``position``'s ``east_m``, ``north_m``,
        ``up_m``), one for all targets or one per target.
    origin : Origin, mapping or LocalFrame
        The local frame's origin (``meta.origin``).
    target_velocity_enu, sensor_velocity_enu : array_like, optional
        Velocities [m/s] in the local frame (``truth[targets]`` ``v_*_mps``;
        ``velocity_enu_mps``), for the range rate; NaN range rates without them.
    k_factor : float, optional
        Effective earth-radius factor (4/3, the model's).

    Returns
    -------
    PlotGeometry
        One entry per target (1-D arrays).
    """
    frame = local_frame(origin)
    tgt = np.atleast_2d(_enu(target_enu))
    ant = np.broadcast_to(_enu(sensor_enu), tgt.shape)
    have_velocity = target_velocity_enu is not None or sensor_velocity_enu is not None
    zero = np.zeros(3)
    tv = np.broadcast_to(_enu(zero if target_velocity_enu is None else target_velocity_enu),
                         tgt.shape)
    av = np.broadcast_to(_enu(zero if sensor_velocity_enu is None else sensor_velocity_enu),
                         tgt.shape)
    # the antenna's own height is in its up coordinate: no mast to add
    g = antenna_geometry(ant, av, 0.0, tgt, tv, frame, k_factor)
    rate = g.radial_velocity if have_velocity else np.full(tgt.shape[0], np.nan)
    return PlotGeometry(g.slant_range, g.azimuth, g.elevation, g.ground_range, rate)


def local_to_geodetic(enu: ArrayLike, origin: OriginLike
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """WGS-84 latitude, longitude [deg] and altitude [m] of local points.

    Parameters
    ----------
    enu : array_like, shape (3,) or (..., 3)
        East, north, up [m] in the local frame.
    origin : Origin, mapping or LocalFrame
        The local frame's origin (``meta.origin``).

    Returns
    -------
    lat_deg, lon_deg, alt_m : numpy.ndarray, shape (...)
        The geodetic latitude and longitude of the model's point (WGS-84,
        :mod:`shipradar.sim.world.geodesy`: pymap3d's formulas bit for bit),
        and its altitude above the sea, ``up`` itself: the convention of ``eos``'s
        ``position`` and ASTERIX I034/120, the model's sea surface being the ellipsoid.
        The model's point sits on the frame's sphere, which departs from the ellipsoid
        away from the origin (docs/protocol.md 4): ``geodesy.geodetic2ecef(lat, lon,
        alt)`` is within that departure of it, not exactly on it.
    """
    frame = local_frame(origin)
    p = _enu(enu)
    lat, lon, _ = frame.geodetic(p.reshape(-1, 3))
    shape = p.shape[:-1]
    return lat.reshape(shape), lon.reshape(shape), p[..., 2].copy()


def geodetic_to_local(lat_deg: ArrayLike, lon_deg: ArrayLike, alt_m: ArrayLike,
                      origin: OriginLike) -> NDArray[np.float64]:
    """Local east/north/up of geodetic points: the inverse of :func:`local_to_geodetic`.

    Parameters
    ----------
    lat_deg, lon_deg : array_like
        WGS-84 latitude and longitude [deg].
    alt_m : array_like
        Altitude above the sea [m] (becomes ``up``).
    origin : Origin, mapping or LocalFrame
        The local frame's origin (``meta.origin``).

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        East, north, up [m].

    Notes
    -----
    The sphere's vertical through a point is not the ellipsoid's normal, so the direction
    u of the point at altitude h whose geodetic latitude and longitude are given is found
    by a fixed-point iteration: the point of the ellipsoid normal at the sphere point's
    ellipsoidal height gives the next direction (three passes: below 1 µm).
    """
    frame = local_frame(origin)
    lat, lon, h = np.broadcast_arrays(np.asarray(lat_deg, dtype=float),
                                      np.asarray(lon_deg, dtype=float),
                                      np.asarray(alt_m, dtype=float))
    shape = lat.shape
    lat, lon, h = lat.reshape(-1), lon.reshape(-1), h.reshape(-1)
    h_e = np.zeros_like(h)
    for _ in range(_GEODETIC_ITERATIONS + 1):
        x = np.stack(geodesy.geodetic2ecef(lat, lon, h_e), axis=1) - frame.centre
        u = x / np.linalg.norm(x, axis=1)[:, None]
        p = frame.centre + (frame.radius + h)[:, None] * u
        _, _, h_e = geodesy.ecef2geodetic(p[:, 0], p[:, 1], p[:, 2])
        h_e = np.asarray(h_e, dtype=float)
    t = u * (frame.radius / (u @ frame.up0))[:, None]
    out = np.stack([t @ frame.east0, t @ frame.north0, h], axis=1)
    return out.reshape(*shape, 3)


def plot_to_geodetic(
    range_m: ArrayLike,
    azimuth_rad: ArrayLike,
    sensor_enu: ArrayLike,
    origin: OriginLike,
    target_up_m: ArrayLike = 0.0,
    k_factor: float = K_FACTOR,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """WGS-84 latitude, longitude [deg] and altitude [m] of plots: :func:`plot_to_local`
    then :func:`local_to_geodetic` (same parameters; the altitude is ``target_up_m``)."""
    enu = plot_to_local(range_m, azimuth_rad, sensor_enu, origin, target_up_m, k_factor)
    return local_to_geodetic(enu, origin)
