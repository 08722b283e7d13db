"""The geodetic conversions of :mod:`shipradar.sim.world.geodesy` against pymap3d, bit for bit.

They replace pymap3d on the run path (its import pulls in astropy, issue 27); the engine's
recordings stay byte-identical only if the numbers are the same floats, so the comparison is
exact, not within a tolerance.
"""

from __future__ import annotations

import numpy as np
import pymap3d
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shipradar.sim.world.geodesy import ecef2geodetic, geodetic2ecef


def _points(n: int, seed: int):
    rng = np.random.default_rng(seed)
    lat = rng.uniform(-90.0, 90.0, n)
    lon = rng.uniform(-180.0, 180.0, n)
    alt = rng.uniform(-1.0e5, 3.0e5, n)
    return lat, lon, alt


def test_geodetic2ecef_is_pymap3d_bit_for_bit():
    lat, lon, alt = _points(2000, 1)
    ours = geodetic2ecef(lat, lon, alt)
    ref = pymap3d.geodetic2ecef(lat, lon, alt)
    for o, r in zip(ours, ref, strict=True):
        np.testing.assert_array_equal(o, r)
    # scalars, as LocalFrame calls it
    for o, r in zip(geodetic2ecef(44.6, -63.0, 0.0), pymap3d.geodetic2ecef(44.6, -63.0, 0.0),
                    strict=True):
        assert o == r


def test_ecef2geodetic_is_pymap3d_bit_for_bit():
    lat, lon, alt = _points(2000, 2)
    x, y, z = pymap3d.geodetic2ecef(lat, lon, alt)
    # the edge cases of You (2000): on the polar axis, at the centre, inside the ellipsoid
    x = np.concatenate([x, [0.0, 0.0, 0.0, 0.0, 1.0e6]])
    y = np.concatenate([y, [0.0, 0.0, 0.0, 0.0, 0.0]])
    z = np.concatenate([z, [6.4e6, -6.4e6, 0.0, 1.0e3, 0.0]])
    ours = ecef2geodetic(x, y, z)
    ref = pymap3d.ecef2geodetic(x, y, z)
    for o, r in zip(ours, ref, strict=True):
        np.testing.assert_array_equal(o, r)


def test_round_trip():
    lat, lon, alt = _points(500, 3)
    lat2, lon2, alt2 = ecef2geodetic(*geodetic2ecef(lat, lon, alt))
    np.testing.assert_allclose(lat2, lat, rtol=0, atol=1e-9)
    np.testing.assert_allclose(lon2, lon, rtol=0, atol=1e-9)
    np.testing.assert_allclose(alt2, alt, rtol=0, atol=1e-6)


def test_literature_values():
    # TR8350.2: the equator at the prime meridian is (a, 0, 0), the pole (0, 0, b)
    assert geodetic2ecef(0.0, 0.0, 0.0)[0] == pytest.approx(6378137.0, abs=1e-9)
    assert geodetic2ecef(90.0, 0.0, 0.0)[2] == pytest.approx(6356752.31424518, abs=1e-6)


@settings(max_examples=200, deadline=None)
@given(st.floats(-89.9, 89.9), st.floats(-180.0, 180.0), st.floats(-1.0e4, 1.0e5))
def test_ecef2geodetic_matches_pymap3d_anywhere(lat, lon, alt):
    x, y, z = (np.array([v]) for v in geodetic2ecef(lat, lon, alt))
    for o, r in zip(ecef2geodetic(x, y, z), pymap3d.ecef2geodetic(x, y, z), strict=True):
        np.testing.assert_array_equal(o, r)
