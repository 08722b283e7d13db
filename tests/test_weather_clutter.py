"""Tests of shipradar.sensors.weather_clutter, seed [39]-[45]."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shipradar.sensors import weather_clutter as wc

C = 299_792_458.0


def test_rain_reflectivity_by_hand():
    # [42] at 3 GHz, 4 mm/h: K = 7e-48
    assert wc.rain_reflectivity(3e9, 4.0) == pytest.approx(7e-48 * (3e9) ** 4 * 4.0**1.6, rel=1e-12)
    # 20 GHz: K interpolated linearly between 6 GHz (7e-48) and 35 GHz (13e-48)
    k20 = 7e-48 + (20 - 6) / (35 - 6) * 6e-48
    assert wc.rain_reflectivity(20e9, 10.0) == pytest.approx(
        k20 * (20e9) ** 4 * 10.0**1.6, rel=1e-12
    )
    for f in (35e9, 60e9, 95e9):
        assert wc.reflectivity_constant(f) == pytest.approx(13e-48, rel=1e-12)
    for f in (1e9, 6e9):
        assert wc.reflectivity_constant(f) == pytest.approx(7e-48, rel=1e-12)


def test_rain_reflectivity_rayleigh_marshall_palmer():
    # second method: η = π⁵ |K_w|² Z / λ⁴ with Z = 200 R^1.6 mm⁶/m³ and |K_w|² = 0.93
    # (Rayleigh scattering by water drops; valid below ~6 GHz, where [42] uses K = 7e-48)
    for f, rate in ((1.3e9, 1.0), (3e9, 4.0), (5.6e9, 16.0)):
        lam = C / f
        eta = math.pi**5 * 0.93 * 200e-18 * rate**1.6 / lam**4
        assert wc.rain_reflectivity(f, rate) == pytest.approx(eta, rel=0.01)


def test_snow_rain_equivalent():
    assert wc.rain_equivalent_rate_mm_h(10.0, "dry_snow") == pytest.approx(1.0)
    assert wc.rain_equivalent_rate_mm_h(10.0, "wet_snow") == pytest.approx(2.0)
    assert wc.rain_reflectivity(5e9, 10.0, "dry_snow") == pytest.approx(
        wc.rain_reflectivity(5e9, 1.0), rel=1e-12
    )
    with pytest.raises(ValueError):
        wc.rain_equivalent_rate_mm_h(1.0, "hail")
    assert wc.rain_reflectivity(5e9, 0.0) == 0.0


def test_range_folding_item3():
    prf = 1000.0
    r_u = C / (2 * prf)  # 149.9 km, the unambiguous range of the PRF (not the carrier)
    assert wc.folded_range_m(50e3, prf) == pytest.approx(50e3)
    assert wc.folded_range_m(r_u + 100.0, prf) == pytest.approx(100.0, rel=1e-9)
    assert wc.folded_range_m(2 * r_u + 7e3, prf) == pytest.approx(7e3, rel=1e-6)
    with pytest.raises(ValueError):
        wc.folded_range_m(1e3, 0.0)


def test_volume_cell_by_hand():
    eta, rc, th, ph, hc, cr = 5e-9, 20e3, math.radians(1.5), math.radians(20.0), 3000.0, 150.0
    # [43]: d_h = min(h_cloud, R_c φ_b) = min(3000, 6981) = 3000
    assert wc.volume_height_m(rc, ph, hc) == pytest.approx(3000.0)
    assert wc.volume_height_m(5e3, ph, hc) == pytest.approx(5e3 * ph)
    # [40]
    assert wc.volume_cross_section_m2(eta, rc, th, ph, hc, cr) == pytest.approx(
        eta * rc * th * 3000.0 * cr, rel=1e-12
    )
    # [39]
    vol = eta * rc * th * 3000.0 * cr
    assert wc.weather_clutter_power_w(2.0e3, vol, 20e3) == pytest.approx(
        2.0e3 * vol / 20e3**4, rel=1e-12
    )
    assert wc.weather_clutter_power_w(2.0e3, vol, 20e3, rain_fraction=0.0) == 0.0
    assert wc.volume_cross_section_m2(eta, 0.0, th, ph, hc, cr) == 0.0
    with pytest.raises(ValueError):
        wc.weather_clutter_power_w(1.0, vol, 0.0)


def test_weather_spread_by_hand():
    lam, r, phi_b = 0.05, 30e3, math.radians(2.0)
    # a 2° beam at 30 km is 1047 m tall, inside a 3 km layer: the seed's Gaussian beam [45]
    shear = 0.42 * 4e-3 * r * phi_b
    assert wc.shear_spread_mps(r, phi_b, 3000.0) == pytest.approx(shear, rel=1e-12)
    # a 20° fan beam at 29.9 km (10.4 km tall) holds a 2.5 km layer whole: velocities 4e-3 z
    # uniform over 0-2500 m span 10 m/s, standard deviation 10/√12 = 2.89 m/s (the beam
    # alone would give 0.42 · 4e-3 · 29.9e3 · 0.349 = 17.5 m/s)
    assert wc.shear_spread_mps(29.9e3, math.radians(20.0), 2500.0) == pytest.approx(
        10.0 / math.sqrt(12.0), rel=1e-12)
    expected = 2 / lam * math.sqrt(shear**2 + 1.0**2)
    assert wc.weather_spread_hz(lam, shear, 1.0) == pytest.approx(expected, rel=1e-12)
    assert wc.weather_spread_hz(lam, shear, 1.0, 30.0) == pytest.approx(
        math.hypot(expected, 30.0), rel=1e-12
    )
    assert wc.weather_mean_doppler_hz(10.0, 0.0, lam) == pytest.approx(400.0)
    assert wc.weather_mean_doppler_hz(10.0, math.pi, lam, 5.0) == pytest.approx(-395.0)


def test_rain_cylinder_fraction():
    f = wc.rain_cylinder_fraction([0.0, 900.0, 1100.0, 5000.0], 0.0, 0.0, 0.0, 1000.0)
    assert f.tolist() == [1.0, 1.0, 0.0, 0.0]
    assert wc.rain_cylinder_fraction(1e6, 1e6).tolist() == 1.0


@settings(max_examples=100, deadline=None)
@given(
    f=st.floats(5e8, 1e11),
    rate=st.floats(0.0, 300.0),
    r=st.floats(1.0, 1e6),
    prf=st.floats(50.0, 5e5),
    hc=st.floats(1.0, 15e3),
    kind=st.sampled_from(["rain", "dry_snow", "wet_snow"]),
)
def test_weather_power_finite_non_negative(f, rate, r, prf, hc, kind):
    eta = wc.rain_reflectivity(f, rate, kind)
    rc = wc.folded_range_m(r, prf)
    vol = wc.volume_cross_section_m2(eta, rc, 0.02, 0.3, hc, 150.0)
    p = wc.weather_clutter_power_w(1e3, vol, r)
    assert np.isfinite(p) and p >= 0.0
    assert 0.0 <= rc < C / (2 * prf)
