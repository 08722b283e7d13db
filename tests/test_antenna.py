"""Antenna directivity factors [8]-[14]: closed forms, root finding, sidelobe maxima, properties."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq, minimize_scalar

from shipradar.sensors import antenna

BEAMWIDTHS_RAD = np.deg2rad([0.5, 1.5, 2.0, 5.0, 10.0])


@pytest.mark.parametrize("bw", BEAMWIDTHS_RAD)
def test_gaussian_half_power_points_exact(bw):
    g = antenna.gaussian_directivity(np.array([-bw / 2, bw / 2]), bw)
    assert g**2 == pytest.approx([0.5, 0.5], rel=1e-12)
    assert antenna.gaussian_directivity(0.0, bw) == 1.0


@pytest.mark.parametrize("bw", BEAMWIDTHS_RAD)
def test_sinc_half_power_points(bw):
    # [11] makes sin(x)/x = 1/sqrt(2) at ±φ_b/2 to the 5 digits of 1.3916; [10]'s obliquity
    # factor (1+cos φ)/2 lowers it by (1+cos(φ_b/2))²/4 (0.4 % in power at φ_b = 10°).
    g = antenna.sinc_directivity(np.array([-bw / 2, bw / 2]), bw)
    obliquity2 = ((1 + np.cos(bw / 2)) / 2) ** 2
    assert g**2 == pytest.approx([0.5 * obliquity2] * 2, rel=1e-4)
    if bw <= np.deg2rad(5.0):
        assert g**2 == pytest.approx([0.5, 0.5], rel=1e-3)
    # Independent: the half-power angle found by root finding on the pattern itself.
    half = brentq(lambda a: antenna.sinc_directivity(a, bw) ** 2 - 0.5, 0.1 * bw, 0.9 * bw)
    assert half == pytest.approx(bw / 2, rel=5e-3)


@pytest.mark.parametrize("bw", BEAMWIDTHS_RAD)
def test_sinc_first_null_matches_12_and_the_pattern_zero(bw):
    null = antenna.sinc_first_null_rad(bw)
    # [12] closed form, and the exact zero of sin(k sin φ): k sin φ = π.
    assert null == pytest.approx(np.arcsin(2.2575 * np.sin(bw / 2)), rel=1e-12)
    k = antenna.sinc_constant_k(bw)
    assert null == pytest.approx(np.arcsin(np.pi / k), rel=2e-5)
    root = brentq(lambda a: antenna.sinc_directivity(a, bw), 0.6 * bw, 0.99 * null + 0.02 * bw)
    assert root == pytest.approx(null, rel=2e-5)
    assert antenna.sinc_directivity(null, bw) == pytest.approx(0.0, abs=1e-4)


@pytest.mark.parametrize("sidelobe_db", [13.26, 20.0, 30.0, 45.0])
def test_first_sidelobe_peak_level(sidelobe_db):
    bw = np.deg2rad(2.0)
    null = float(antenna.sinc_first_null_rad(bw))
    # The first sidelobe lies between the first and the second null (x = π .. 2π).
    second_null = np.arcsin(2 * np.pi / antenna.sinc_constant_k(bw))
    res = minimize_scalar(
        lambda a: -abs(antenna.sinc_directivity(a, bw, sidelobe_db)),
        bounds=(null * 1.0001, second_null),
        method="bounded",
        options={"xatol": 1e-10},
    )
    peak_db = 20 * np.log10(-res.fun)
    assert peak_db == pytest.approx(-sidelobe_db, abs=0.02)
    # Literature: the first sidelobe of sin(x)/x peaks at x = 4.4934 (tan x = x).
    assert antenna.sinc_constant_k(bw) * np.sin(res.x) == pytest.approx(4.4934, rel=1e-3)


def test_sidelobe_factor_only_beyond_first_null():
    bw = np.deg2rad(3.0)
    inside = np.linspace(-0.99, 0.99, 41) * antenna.sinc_first_null_rad(bw)
    assert antenna.sinc_directivity(inside, bw, 40.0) == pytest.approx(
        antenna.sinc_directivity(inside, bw, 13.26), rel=1e-12
    )


def test_wide_beam_has_no_null_and_sidelobe_factor_unused():
    bw = np.deg2rad(60.0)  # 2.2575 sin(30°) > 1
    assert antenna.sinc_first_null_rad(bw) == np.pi
    a = np.linspace(-np.pi, np.pi, 101)
    assert antenna.sinc_directivity(a, bw, 40.0) == pytest.approx(
        antenna.sinc_directivity(a, bw), rel=1e-12
    )


def test_envelope_bounds_the_sidelobes():
    bw = np.deg2rad(2.0)
    a = np.linspace(float(antenna.sinc_first_null_rad(bw)), np.pi / 2, 5001)
    env = antenna.sinc_directivity(a, bw, 30.0, envelope=True)
    assert np.all(env >= np.abs(antenna.sinc_directivity(a, bw, 30.0)) - 1e-15)
    assert np.all(env >= 0.0)


def _first_sidelobe_peak_x():
    """x of the first sidelobe peak of sin x / x: the root of tan x = x in (π, 3π/2)."""
    from scipy.optimize import brentq

    return brentq(lambda x: np.sin(x) - x * np.cos(x), np.pi + 0.1, 1.5 * np.pi - 0.01,
                  xtol=1e-14)


@pytest.mark.parametrize("bw_deg", [0.5, 2.0, 10.0, 40.0])
@pytest.mark.parametrize("sl_db", [13.26, 30.0, 45.0])
def test_envelope_is_continuous_monotone_and_at_the_sidelobe_level(bw_deg, sl_db):
    """The peak envelope (jamming, [47]): from the axis to the back it never increases and
    never jumps; outside the main lobe it is never above the stated first sidelobe -S_L (the
    bound 1/|x| alone was 3.3 dB above it just past the null: S_L 30 dB gave -26.69 dB);
    in front it never falls below the pattern; at the first sidelobe's peak it is the
    pattern."""
    bw = np.deg2rad(bw_deg)
    a = np.linspace(0.0, np.pi, 400_001)
    env = antenna.sinc_directivity(a, bw, sl_db, envelope=True)
    g = np.abs(antenna.sinc_directivity(a, bw, sl_db))
    assert np.all(np.diff(env) <= 1e-15)
    # no jump: no step steeper than the main lobe's steepest (a continuous envelope's)
    main = a < antenna.sinc_first_null_rad(bw)
    assert np.max(np.abs(np.diff(env))) <= 1.01 * np.max(np.abs(np.diff(g[main])))
    front = a <= np.pi / 2  # behind, [10]'s sin φ brings a back lobe the envelope leaves out
    assert np.all(env[front] >= g[front] - 1e-15)
    level = 10 ** (-sl_db / 20)
    obliquity = 0.5 * (1 + np.cos(a))
    side = a >= antenna.sinc_first_null_rad(bw)
    assert np.all(env[side] <= level * obliquity[side] * (1 + 1e-12))
    # at the null, the level itself: no jump either side
    null = float(antenna.sinc_first_null_rad(bw))
    lo, hi = antenna.sinc_directivity(np.array([null * (1 - 1e-12), null]), bw, sl_db,
                                      envelope=True)
    assert lo == pytest.approx(hi, rel=1e-9)
    assert 20 * np.log10(hi) == pytest.approx(-sl_db + 20 * np.log10(0.5 * (1 + np.cos(null))),
                                              abs=1e-9)
    # the first sidelobe's peak (tan x = x, found here): the pattern's own value, to the
    # rounding of 13.26 dB (0.0015 dB)
    k = antenna.sinc_constant_k(bw)
    if _first_sidelobe_peak_x() < k:  # a 40° beam has no first sidelobe in front
        peak = np.arcsin(_first_sidelobe_peak_x() / k)
        e_peak = antenna.sinc_directivity(peak, bw, sl_db, envelope=True)
        g_peak = abs(antenna.sinc_directivity(peak, bw, sl_db))
        assert 20 * np.log10(e_peak / g_peak) == pytest.approx(0.0, abs=2e-3)


def test_envelope_just_past_the_null_is_the_stated_sidelobe_level():
    """Issue 40's number: S_L = 30 dB, 2° beam, just past the first null: -30.00 dB (was
    -26.69 dB with the bound 1/|x| = 1/π there)."""
    bw = np.deg2rad(2.0)
    null = float(antenna.sinc_first_null_rad(bw))
    g = antenna.sinc_directivity(null * (1 + 1e-9), bw, 30.0, envelope=True)
    assert 20 * np.log10(g) == pytest.approx(-30.0, abs=0.01)
    # the plain bound it replaces, by hand: 1/π times the reduction [13]
    assert 20 * np.log10(1 / np.pi) - (30.0 - 13.26) == pytest.approx(-26.69, abs=0.01)


def test_cosec2_junction_continuity_and_law():
    bw, tilt = np.deg2rad(4.0), np.deg2rad(2.0)
    phi_j = tilt + bw / 2
    eps = 1e-9
    below, at, above = antenna.cosec2_directivity(
        np.array([phi_j - eps, phi_j, phi_j + eps]), bw, tilt
    )
    assert below == pytest.approx(above, abs=1e-6)
    # Both sides are [14]'s 1/sqrt(2) there, within [11]'s digits and the obliquity factor.
    assert at == pytest.approx(1 / np.sqrt(2), rel=1e-3)
    assert below == pytest.approx(1 / np.sqrt(2), rel=1e-3)
    # Power ∝ csc² above the junction: g sin φ is constant.
    el = np.linspace(phi_j, antenna.COSEC_MAX_ELEVATION_RAD, 50)
    g = antenna.cosec2_directivity(el, bw, tilt)
    assert g * np.sin(el) == pytest.approx(np.full(50, at * np.sin(phi_j)), rel=1e-12)
    # The maximum is at the tilt.
    assert antenna.cosec2_directivity(tilt, bw, tilt) == pytest.approx(1.0, rel=1e-12)


def test_cosec2_follows_the_seed_to_the_zenith():
    """[14] has no upper end, and neither has the pattern by default: at 60° (φ_b 4°, tilt
    2°) g² = sin²(4°)/(2 sin² 60°), -24.9 dB (was -36.3 dB of sinc sidelobes above a 40°
    end, and ~100 dB lower in their nulls); csc² to 90°, positive and decreasing."""
    bw, tilt = np.deg2rad(4.0), np.deg2rad(2.0)
    g60 = antenna.cosec2_directivity(np.deg2rad(60.0), bw, tilt, 25.0)
    hand = np.sin(np.deg2rad(4.0)) ** 2 / (2 * np.sin(np.deg2rad(60.0)) ** 2)
    assert 20 * np.log10(g60) == pytest.approx(10 * np.log10(hand), abs=0.005)
    assert 20 * np.log10(g60) == pytest.approx(-24.9, abs=0.05)
    el = np.linspace(tilt + bw / 2, np.pi / 2, 2001)
    g = antenna.cosec2_directivity(el, bw, tilt, 25.0)
    assert g * np.sin(el) == pytest.approx(np.full(el.size, g[0] * np.sin(el[0])), rel=1e-12)
    assert np.all(g > 0.0) and np.all(np.diff(g) < 0.0)


def test_cosec2_with_an_upper_end_falls_to_the_sidelobe_envelope():
    """An antenna shaped only to φ_max = 40°: above it the sinc sidelobes' peak envelope (no
    null), never above the cosec law, never below the oscillating sidelobes."""
    bw, tilt, top = np.deg2rad(4.0), np.deg2rad(2.0), np.deg2rad(40.0)
    el = np.linspace(top + 1e-6, np.pi / 2, 20001)
    g = antenna.cosec2_directivity(el, bw, tilt, 25.0, cosec_max_rad=top)
    law = antenna.cosec2_directivity(el, bw, tilt, 25.0)
    sidelobes = np.abs(antenna.sinc_directivity(el - tilt, bw, 25.0))
    assert np.all(g <= law * (1 + 1e-12))
    assert np.all(g >= np.minimum(sidelobes, law) * (1 - 1e-12))
    # no pattern null: the oscillating sidelobes there go 80 dB and more below the envelope
    assert np.min(20 * np.log10(g)) > -55.0
    assert np.min(20 * np.log10(np.maximum(sidelobes, 1e-300))) < -100.0
    envelope = antenna.sinc_directivity(el - tilt, bw, 25.0, envelope=True)
    assert g == pytest.approx(np.minimum(envelope, law), rel=1e-12)
    # below φ_max nothing changes
    below = np.linspace(tilt + bw / 2, top, 101)
    assert antenna.cosec2_directivity(below, bw, tilt, 25.0, cosec_max_rad=top) == (
        pytest.approx(antenna.cosec2_directivity(below, bw, tilt, 25.0), rel=1e-15))


def test_cosec2_rejects_junction_below_horizon():
    with pytest.raises(ValueError):
        antenna.cosec2_directivity(0.1, np.deg2rad(4.0), np.deg2rad(-3.0))


def test_dispatcher_and_elevation_convention():
    bw = np.deg2rad(3.0)
    a = np.linspace(-0.2, 0.2, 11)
    assert antenna.directivity(a, bw, "gaussian") == pytest.approx(
        antenna.gaussian_directivity(a, bw)
    )
    assert antenna.directivity(a, bw, "isotropic") == pytest.approx(np.ones(11))
    tilt = np.deg2rad(1.5)
    for pattern in ("gaussian", "sinc", "cosec2"):
        assert antenna.elevation_directivity(tilt, bw, pattern, tilt_rad=tilt) == pytest.approx(1.0)
    el = np.deg2rad(10.0)
    assert antenna.elevation_directivity(el, bw, "cosec2", tilt_rad=tilt) == pytest.approx(
        antenna.cosec2_directivity(el, bw, tilt)
    )
    with pytest.raises(ValueError):
        antenna.directivity(0.0, bw, "parabolic")


def test_back_of_antenna_is_finite():
    bw = np.deg2rad(2.0)
    for a in (np.pi, -np.pi, 3 * np.pi):
        assert antenna.sinc_directivity(a, bw) == pytest.approx(0.0, abs=1e-15)
        assert np.isfinite(antenna.gaussian_directivity(a, bw))


@settings(max_examples=150, deadline=None)
@given(
    angle=st.floats(-20.0, 20.0),
    bw=st.floats(1e-3, 2.5),
    sl=st.floats(13.26, 60.0),
    pattern=st.sampled_from(["isotropic", "gaussian", "sinc"]),
    envelope=st.booleans(),
)
def test_symmetric_patterns_finite_bounded_even(angle, bw, sl, pattern, envelope):
    g = antenna.directivity(angle, bw, pattern, sidelobe_db=sl, envelope=envelope)
    g_neg = antenna.directivity(-angle, bw, pattern, sidelobe_db=sl, envelope=envelope)
    assert np.isfinite(g)
    assert abs(g) <= 1.0
    assert g == pytest.approx(g_neg, abs=1e-12)


@settings(max_examples=150, deadline=None)
@given(
    el=st.floats(-np.pi, np.pi),
    bw=st.floats(1e-3, 1.0),
    tilt_frac=st.floats(-0.99, 3.0),
    sl=st.floats(13.26, 60.0),
)
def test_cosec2_finite_bounded(el, bw, tilt_frac, sl):
    g = antenna.elevation_directivity(el, bw, "cosec2", sidelobe_db=sl, tilt_rad=tilt_frac * bw / 2)
    assert np.isfinite(g)
    assert abs(g) <= 1.0
