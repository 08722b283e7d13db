"""Geodetic ↔ ECEF conversion on the WGS-84 ellipsoid, without ``pymap3d``'s import cost.

``pymap3d`` (3.x) imports its ECI module, and with it ``astropy`` when astropy is installed,
whichever function is used: about 0.4 s of every run's start-up for two conversions.  The two
functions here are ``pymap3d.ecef.geodetic2ecef`` and ``pymap3d.ecef.ecef2geodetic``
transcribed with the same numpy operations in the same order, so that they return the same
floating-point numbers bit for bit (``tests/test_geodesy.py`` checks this against pymap3d,
and the recordings stay byte-identical).

References
----------
- NIMA TR8350.2, *Department of Defense World Geodetic System 1984*, 3rd ed. (2000):
  the ellipsoid (a, b) and eq. 4-14/4-15 (geodetic to ECEF).
- R.-J. You, "Transformation of Cartesian to Geodetic Coordinates without Iterations",
  *J. Surveying Engineering* 126 (1), 2000, doi:10.1061/(ASCE)0733-9453(2000)126:1(1),
  eqs. 4a-4c, 7 and 13 (ECEF to geodetic, the method pymap3d implements).
"""

from __future__ import annotations

from math import pi

import numpy as np
from numpy.typing import NDArray

#: A scalar or an array of floats (kept as given: pymap3d's arithmetic, bit for bit).
Floats = float | NDArray[np.float64]

#: WGS-84 semi-major axis [m] (TR8350.2; pymap3d's ``Ellipsoid.from_name("wgs84")``).
WGS84_A_M = 6378137.0
#: WGS-84 semi-minor axis [m] (the value pymap3d uses).
WGS84_B_M = 6356752.31424518


def geodetic2ecef(lat_deg: Floats, lon_deg: Floats, alt_m: Floats
                  ) -> tuple[Floats, Floats, Floats]:
    """ECEF x, y, z [m] of a geodetic latitude, longitude [deg] and height [m] (WGS-84).

    Parameters
    ----------
    lat_deg, lon_deg : geodetic latitude and longitude [deg], scalars or arrays
    alt_m : height above the ellipsoid [m]

    Returns
    -------
    x, y, z : ECEF coordinates [m] (numpy scalars for scalar input).

    The closed form of TR8350.2 eq. 4-14, with N the radius of curvature in the prime
    vertical; valid everywhere, poles included.
    """
    a, b = WGS84_A_M, WGS84_B_M
    lat = np.radians(lat_deg)
    lon = np.radians(lon_deg)
    # radius of curvature of the prime vertical section
    n = a**2 / np.hypot(a * np.cos(lat), b * np.sin(lat))
    x = (n + alt_m) * np.cos(lat) * np.cos(lon)
    y = (n + alt_m) * np.cos(lat) * np.sin(lon)
    z = (n * (b / a) ** 2 + alt_m) * np.sin(lat)
    return x, y, z


def ecef2geodetic(x: Floats, y: Floats, z: Floats
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Geodetic latitude, longitude [deg] and height [m] (WGS-84) of ECEF points [m].

    Parameters
    ----------
    x, y, z : ECEF coordinates [m], scalars or arrays of one shape

    Returns
    -------
    lat, lon : geodetic latitude and longitude [deg]
    alt : height above the ellipsoid [m], negative inside it.

    You (2000), eqs. 4a-4c and 13, without iteration; on the polar axis or at the centre
    (u or the distance from the axis ≈ 0) the reduced latitude is set to 0 or ±90°.
    """
    a, b = WGS84_A_M, WGS84_B_M
    x = np.asarray(x)
    y = np.asarray(y)
    z = np.asarray(z)
    r = np.sqrt(x**2 + y**2 + z**2)
    e = np.sqrt(a**2 - b**2)
    # eq. 4a
    u = np.sqrt(0.5 * (r**2 - e**2) + 0.5 * np.hypot(r**2 - e**2, 2 * e * z))
    hxy = np.hypot(x, y)
    hue = np.hypot(u, e)
    # eq. 4b, then the correction of eq. 13
    beta = np.empty_like(r)
    bad = np.isclose(u, 0) | np.isclose(hxy, 0)
    ok = ~bad
    beta[ok] = np.arctan(hue[ok] / u[ok] * z[ok] / hxy[ok])
    beta[ok] += ((b * u[ok] - a * hue[ok] + e**2) * np.sin(beta[ok])) / (
        a * hue[ok] * 1 / np.cos(beta[ok]) - e**2 * np.cos(beta[ok]))
    on_axis_z0 = bad & np.isclose(z, 0)
    north = bad & ~on_axis_z0 & (z > 0)
    south = bad & ~on_axis_z0 & ~north
    beta[on_axis_z0] = 0
    beta[north] = pi / 2
    beta[south] = -pi / 2
    # eq. 4c
    lat = np.arctan(a / b * np.tan(beta))
    lim_pi2 = pi / 2 - np.finfo(beta.dtype).eps  # pymap3d's guard against float32 loss
    lat = np.where(beta >= lim_pi2, pi / 2, lat)
    lat = np.where(beta <= -lim_pi2, -pi / 2, lat)
    lon = np.arctan2(y, x)
    # eq. 7
    cos_beta = np.cos(beta)
    cos_beta = np.where(beta >= lim_pi2, 0, cos_beta)
    cos_beta = np.where(beta <= -lim_pi2, 0, cos_beta)
    alt = np.hypot(z - b * np.sin(beta), hxy - a * cos_beta)
    inside = x**2 / a**2 + y**2 / a**2 + z**2 / b**2 < 1
    alt = np.where(inside, -alt, alt)
    return np.degrees(lat), np.degrees(lon), alt
