"""The physics functions at the edges of their domains (issue 23 item 3).

Each test puts one function at an edge of its domain (grazing angle 0 and the horizon, zero
wind and waves, zero range, beyond the horizon, the ends of each model's fitted frequency
range, 300 mm/h, the Weibull shape's limits, S/I of +150 and -60 dB) and checks the value
against something the code does not compute itself: a closed form, a limiting law, a
literature value or a second method.  numpy floating-point errors raise here
(tests/conftest.py), so an overflow, a log of 0 or a 0/0 anywhere is a failure.
docs/stability.md §2 lists, per model, its fitted range and what the code does outside
it (clamp, extrapolate or refuse); the tests named there hold those choices.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.special import gammaln, zeta

from shipradar.sensors import antenna as an
from shipradar.sensors import atmosphere as at
from shipradar.sensors import detection as det
from shipradar.sensors import jamming as jm
from shipradar.sensors import measurement as me
from shipradar.sensors import noise
from shipradar.sensors import propagation as pr
from shipradar.sensors import sea_clutter as sc
from shipradar.sensors import weather_clutter as wc

C = 299_792_458.0
A_E = 4.0 / 3.0 * 6_371_008.8
#: the scenario schema's frequency bounds [Hz] (sim/world/scenario.py, Radar.frequency_hz)
F_MIN, F_MAX = 0.5e9, 100e9


# =========================================================================== two-ray [4]
def test_two_ray_zero_range_is_the_vertical_image():
    # d = 0: the target straight above the antenna.  Image theory on the vertical: the
    # reflected ray goes down h1 and up h1 + h2 (path difference 2 h1, spreading
    # (h2 - h1)/(h2 + h1)), at normal incidence Γ = ∓(√ε - 1)/(√ε + 1) (H: -, V: +) and
    # with no divergence (d1 d2 = 0)
    f, h1, h2 = 3e9, 20.0, 500.0
    k = 2 * math.pi * f / C
    eps = pr.sea_water_permittivity(f)
    gamma_n = (np.sqrt(eps) - 1) / (np.sqrt(eps) + 1)
    for pol, gamma in (("H", -gamma_n), ("V", gamma_n)):
        image = abs(1 + gamma * (h2 - h1) / (h2 + h1) * np.exp(-1j * k * 2 * h1))
        assert pr.two_ray_factor(0.0, h1, h2, f, pol) == pytest.approx(image, rel=1e-9)


def test_two_ray_both_ends_on_the_surface_is_finite():
    # d = h1 = h2 = 0 made Kerr's cubic divide 0 by 0 (a finding of this file): now F is
    # finite everywhere, and past 0 it is the smooth-earth diffraction of two surface points
    d = np.array([0.0, 10.0, 1e3, 1e5])
    for pol in "HV":
        f = pr.two_ray_factor(d, 0.0, 0.0, 3e9, pol)
        assert np.all(np.isfinite(f)) and np.all(f >= 0.0)
        diffraction = pr.smooth_earth_diffraction_factor(d[1:], 0.0, 0.0, 3e9, pol)
        assert f[1:] == pytest.approx(diffraction, rel=1e-9)
    assert pr.interference_region_limit(0.0, 0.0, 3e9) == 0.0


def test_two_ray_low_grazing_is_the_flat_earth_small_angle_law():
    # grazing angle -> 0 over a perfect conductor (Γ_H = -1), calm sea, short range:
    # F = 2 |sin(k h1 h2 / d)| (Blake 1986 eq. 6.14); the curved-earth code agrees within the
    # divergence and path-length corrections of a few km
    f, h1, h2 = 3e9, 10.0, 2.0
    k = 2 * math.pi * f / C
    d = np.array([2e3, 3e3, 4e3, 5e3])
    two_ray = pr.two_ray_factor(d, h1, h2, f, "H", permittivity=complex(np.inf), k_factor=1e6)
    assert two_ray == pytest.approx(2 * np.abs(np.sin(k * h1 * h2 / d)), rel=2e-3)
    # and at zero target height a perfectly reflecting flat sea cancels the direct ray
    zero = pr.two_ray_factor(d, h1, 0.0, f, "H", permittivity=complex(np.inf), k_factor=1e6)
    assert np.all(zero < 1e-6)


def test_two_ray_is_continuous_at_the_interference_limit_and_the_horizon():
    f, h1, h2 = 3e9, 25.0, 10.0
    d_lim = float(pr.interference_region_limit(h1, h2, f))
    d_hor = float(pr.horizon_range(h1, h2))
    assert 0.0 < d_lim < d_hor
    for edge in (d_lim, d_hor):
        below, above = pr.two_ray_factor([edge * (1 - 1e-9), edge * (1 + 1e-9)], h1, h2, f, "V")
        assert above == pytest.approx(below, rel=1e-5)
    # beyond the horizon: diffraction, monotone down with range, 2.3 dB/km-ish at S band
    far = pr.two_ray_factor(np.linspace(d_hor, 3 * d_hor, 50), h1, h2, f, "V")
    assert np.all(np.diff(far) < 0.0) and far[-1] < 1e-3 * far[0]


@pytest.mark.parametrize("h2", [3e4, 1e5])
def test_two_ray_above_any_pe_table_top_is_the_direct_ray(h2):
    # a target far above the PE table's top (the dwell falls back on the two-ray model): at
    # steep elevation the reflected ray's grazing angle is large and, over a rough sea
    # (8 m waves), Miller-Brown removes it: F -> the direct ray, 1 for an isotropic antenna
    d = np.array([1e3, 2e4, 1e5])
    f = pr.two_ray_factor(d, 25.0, h2, 3e9, "H", wave_height_m=8.0)
    assert f == pytest.approx(1.0, abs=0.05)


@pytest.mark.parametrize("freq", [F_MIN, 1e9, F_MAX])
def test_two_ray_at_the_frequency_ends_is_bounded(freq):
    d = np.geomspace(1.0, 1e6, 60)
    for pol in "HV":
        f = pr.two_ray_factor(d, 25.0, 10.0, freq, pol, wave_height_m=2.0)
        assert np.all(np.isfinite(f)) and np.all(f >= 0.0) and np.all(f <= 2.0 + 1e-9)


def test_sea_water_permittivity_debye_limits():
    # second method: the Debye form's two limits, ε -> ε_s - j σ/(ω ε0) at low frequency
    # (static permittivity plus conduction) and ε' -> ε_∞ = 4.9 far above the relaxation
    eps_lo = pr.sea_water_permittivity(1e6)
    sigma = float(pr.sea_water_conductivity(15.0, 35.0))
    assert -eps_lo.imag == pytest.approx(sigma / (2 * math.pi * 1e6 * 8.8541878128e-12), rel=1e-3)
    eps_hi = pr.sea_water_permittivity(1e14)
    assert eps_hi.real == pytest.approx(4.9, rel=1e-3)
    for f in (F_MIN, F_MAX):
        e = pr.sea_water_permittivity(f)
        assert np.isfinite(e) and e.real > 4.9 and e.imag < 0.0


@pytest.mark.parametrize("wind", [0.0, 0.1, 40.0])
def test_bulk_duct_height_at_calm_and_storm_is_in_range(wind):
    # calm is outside similarity theory: 0.5 m/s is used (documented clamp); a humid, cold
    # sea (air as moist as the surface) gives no duct at any wind
    h = pr.evaporation_duct_height([20.0, 10.0, 25.0], [15.0, 20.0, 28.0], [0.6, 0.9, 0.8], wind)
    assert np.all((h >= 0.0) & (h <= pr.MAX_EVAPORATION_DUCT_HEIGHT_M))
    assert pr.evaporation_duct_height(15.0, 15.0, 1.0, wind) == 0.0
    assert pr.evaporation_duct_height(20.0, 15.0, 0.6, 0.0) == pr.evaporation_duct_height(
        20.0, 15.0, 0.6, pr._MIN_WIND_MPS
    )


# =========================================================================== GIT [22]
def test_git_grazing_to_zero_is_the_critical_angle_power_law():
    # ψ -> 0: A_i -> σ_φ⁴ ∝ ψ⁴ and A_u -> its ψ = 0 value, so σ0_HH ∝ ψ^4.4 below 10 GHz and
    # ψ^4.547 above (limiting law of the published formulas, not the code's own numbers)
    for f, exponent in ((3e9, 4.4), (35e9, 4.547)):
        psi = np.array([1e-7, 2e-7])
        s = sc.git_reflectivity(psi, f, 10.0, 0.0, 2.0, "H")
        assert math.log2(s[1] / s[0]) == pytest.approx(exponent, rel=1e-5)
    # exactly 0 at and behind the horizon, never negative, no log of 0 in the VV branch
    for pol in "HV":
        assert np.all(sc.git_reflectivity([0.0, -0.01, -1.0], 9.8e9, 10.0, 0.0, 2.0, pol) == 0.0)
        tiny = sc.git_reflectivity(1e-300, 9.8e9, 10.0, 0.0, 2.0, pol)
        assert np.isfinite(tiny) and tiny >= 0.0


def test_git_above_its_fit_is_held_at_ten_degrees():
    # documented clamp: ψ > 10° evaluated at 10° (the (1 - 2.8 ψ) factor flips at 20.5°)
    for pol in "HV":
        s = sc.git_reflectivity([np.deg2rad(10.0), np.deg2rad(45.0), np.pi / 2], 9.8e9, 10.0,
                                0.0, 2.0, pol)
        assert s[1] == s[0] and s[2] == s[0]


def test_git_wind_to_zero_follows_the_wind_factor_power_law():
    # fixed waves, V_w -> 0: A_w = (1.94 V/(1 + V/15.4))^q -> (1.94 V)^q, so halving a tiny
    # wind divides σ0 by 2^q, q = 1.1 (λ + 0.015)^-0.4 (1-10 GHz), 1.93 λ^-0.04 (10-100 GHz)
    for f in (3e9, 9.8e9, 35e9):
        lam = C / f
        q = 1.1 * (lam + 0.015) ** -0.4 if f < 10e9 else 1.93 * lam**-0.04
        s = sc.git_reflectivity(0.02, f, [1e-6, 2e-6], 0.0, 1.0, "V")
        assert math.log2(s[1] / s[0]) == pytest.approx(q, rel=1e-4)
        assert sc.git_reflectivity(0.02, f, 0.0, 0.0, 1.0, "V") == 0.0


def test_git_wave_height_to_zero_is_the_fourth_power_law():
    # fixed wind, h_av -> 0: A_i ∝ h_av⁴ (HH); exactly 0 at a flat sea
    s = sc.git_reflectivity(0.02, 9.0e9, 10.0, 0.0, [1e-6, 2e-6], "H")
    assert math.log2(s[1] / s[0]) == pytest.approx(4.0, rel=1e-6)
    for pol in "HV":
        assert sc.git_reflectivity(0.02, 9.0e9, 10.0, 0.0, 0.0, pol) == 0.0


def test_git_frequency_ends_extrapolate_then_refuse():
    # fitted 1-100 GHz; 0.5-1 GHz extrapolated (continuous in λ: the value at 1 GHz is met
    # from below); outside, refused
    below, at_1 = sc.git_reflectivity(0.02, [1e9 * (1 - 1e-9), 1e9], 10.0, 0.0, 2.0, "H")
    assert below == pytest.approx(at_1, rel=1e-6)
    for f in (F_MIN, F_MAX):
        for pol in "HV":
            s = sc.git_reflectivity([1e-4, 0.02, 0.2], f, [0.0, 10.0, 40.0], 0.0, 2.0, pol)
            assert np.all(np.isfinite(s)) and np.all(s >= 0.0)
    for f in (0.49e9, 100.1e9):
        with pytest.raises(ValueError, match="GIT"):
            sc.git_reflectivity(0.02, f, 10.0, 0.0, 2.0, "H")


# =========================================================================== ducting [22]-[29]
def test_ducting_fit_at_its_frequency_ends():
    # [26] h_opt = 37 - 8.69 ln f: 43.0 m at 0.5 GHz (the fit's low end, extrapolated), 0 at
    # 70.7 GHz: floored at the 1 m duct of [23] from 63 GHz (clamp)
    assert sc.optimal_duct_height_m(F_MIN) == pytest.approx(37 - 8.69 * math.log(0.5), rel=1e-12)
    assert sc.optimal_duct_height_m([63.3e9, 70.7e9, F_MAX]) == pytest.approx(1.0, abs=0.05)
    # [28] divides by 30 - h_opt, 0 at 2.24 GHz: β stays in [1, 4] across it
    f = np.array([F_MIN, 2.2e9, 2.2406e9, 2.25e9, 9.0e9, F_MAX])
    beta = sc.reflectivity_decrease_beta(20.0, f, 1.0)
    assert np.all((beta >= 1.0) & (beta <= 4.0))
    # [29] log10(9 - 0.9 f): 0.932 (β+1)/4 at 0.5 GHz, 0 from 8.89 GHz up (a loss, never a gain)
    loss = sc.clutter_propagation_loss_db_per_km(20.0, [F_MIN, 8.8e9, 8.9e9, 9.99e9, F_MAX], 1.0)
    assert loss[0] == pytest.approx(0.5 * math.log10(9 - 0.45), rel=1e-12)
    assert loss[1] == pytest.approx(0.5 * math.log10(9 - 0.9 * 8.8), rel=1e-9)
    assert np.all(loss[2:] == 0.0)


def test_ducted_reflectivity_to_the_horizon_and_beyond():
    # from zero range to far past the horizon, for calm, flat and stormy seas and every duct:
    # finite, floored at DB_FLOOR, non-increasing beyond the transition range
    d = np.concatenate(([0.0, 1.0], np.geomspace(10.0, 1e6, 200)))
    for wind, waves in ((0.0, None), (10.0, 0.0), (10.0, None), (40.0, 14.0)):
        for duct in (0.0, 0.5, 20.0, 1000.0):
            s = sc.ducted_reflectivity_db(d, 25.0, 9.8e9, wind, 0.0, waves, "V", duct)
            assert np.all(np.isfinite(s)) and np.all(s >= sc.DB_FLOOR)
            r_tr = min(float(sc.transition_range_m(25.0, sc._significant_wave_height(
                waves, wind), duct)), float(sc.git_limit_range_m(25.0)))
            beyond = s[d >= r_tr]
            assert np.all(np.diff(beyond) <= 1e-9)
    # the transition: seed [25] R_tc in km, clamped at 60 m (SPEC §4 item 9)
    assert sc.transition_range_m(25.0, 2.0, [10.0, 60.0, 1000.0]) == pytest.approx(
        [3.5e3, 1e3 * (7.1 - 3.6 * math.log10(60.0)), 1e3 * (7.1 - 3.6 * math.log10(60.0))],
        rel=1e-12,
    )


def test_grazing_angle_at_zero_range_and_the_horizon():
    h = 25.0
    assert sc.grazing_angle_rad(0.0, h) == pytest.approx(math.pi / 2, rel=1e-12)
    horizon = math.sqrt(2 * A_E * h)  # the geometric horizon over the effective earth
    assert sc.ground_range_at_grazing_m(0.0, h) == pytest.approx(horizon, rel=1e-5)
    assert sc.grazing_angle_rad(horizon, h) == pytest.approx(0.0, abs=1e-8)
    assert sc.grazing_angle_rad(2 * horizon, h) < 0.0
    # zero-range clutter power is finite: R_sc = h_a there (SPEC §4 item 13)
    assert sc.slant_range_m(0.0, h) == pytest.approx(h)
    p = sc.sea_clutter_power_w(1.0, 1.0, sc.slant_range_m(0.0, h), 0.02, 30.0, 1e-2)
    assert p == pytest.approx(0.02 * 30.0 * 1e-2 / h**3, rel=1e-12)


# =========================================================================== Weibull [30]-[32]
def test_weibull_shape_limits():
    # d_mm = 10 log10(Γ(1+a) / (ln 2)^a): 0 as a -> 0 (a degenerate, constant clutter: mean =
    # median), 10 log10(1/ln 2) = 1.592 dB at a = 1 (Rayleigh), Stirling's series for large a
    assert sc.median_mean_difference_db(1e-9) == pytest.approx(0.0, abs=1e-6)
    assert sc.median_mean_difference_db(1.0) == pytest.approx(
        -10 * math.log10(math.log(2)), rel=1e-12)
    for a in (50.0, 300.0):
        # ln Γ(1+a) = (a + 1/2) ln a - a + ln √(2π) + 1/(12 a) - 1/(360 a³) + ...
        stirling = ((a + 0.5) * math.log(a) - a + 0.5 * math.log(2 * math.pi) + 1 / (12 * a)
                    - 1 / (360 * a**3) - a * math.log(math.log(2)))
        assert sc.median_mean_difference_db(a) == pytest.approx(
            10 * stirling / math.log(10), rel=1e-6)
    with pytest.raises(ValueError):
        sc.median_mean_difference_db(0.0)
    # a = max(a_min, a_ref + 0.066 σ0d) [32]: a_min at no wind and at no clutter (DB_FLOOR)
    assert sc.weibull_a_reference([0.0, 1e-300, 10.0, 40.0], 1.0) == pytest.approx(
        [1.0, 1.0, 3.0, 3 * math.log10(40.0)], rel=1e-12)
    assert sc.weibull_a_vp([sc.DB_FLOOR, 0.0, 100.0], 10.0, 1.0) == pytest.approx(
        [1.0, 3.0, 3.0 + 6.6], rel=1e-12)
    # HP heuristic: a in [a_min, a_max] even when the two ranges meet (no ramp)
    a = sc.weibull_a_hp([0.0, 5e3, 1e4, 1e6], 5e3, 5e3, 1.0, 3.0)
    assert np.all((a >= 1.0) & (a <= 3.0))
    assert np.isfinite(gammaln(1.0 + 300.0))


@settings(max_examples=60, deadline=None)
@given(
    diff_db=st.floats(sc.DB_FLOOR, 400.0),
    wind=st.floats(0.0, 40.0),
    a_min=st.floats(0.05, 5.0),
)
def test_weibull_a_property_finite_and_above_a_min(diff_db, wind, a_min):
    a = sc.weibull_a_vp(diff_db, wind, a_min)
    assert np.isfinite(a) and a >= a_min
    assert np.isfinite(sc.median_mean_difference_db(a))


# =========================================================================== atmosphere [16]
def test_p676_at_its_frequency_ends_and_the_60ghz_complex():
    go, gw = at.gaseous_specific_attenuation_db_per_km([F_MIN, 1e9, 22.235e9, 60e9, F_MAX])
    assert np.all(np.isfinite(go)) and np.all(go > 0.0) and np.all(gw > 0.0)
    # literature (ITU-R P.676-12 Fig. 1, sea level, 7.5 g/m³): the oxygen complex near
    # 15 dB/km at 60 GHz, the 22 GHz water line near 0.18 dB/km
    assert go[3] == pytest.approx(15.0, rel=0.1)
    assert gw[2] == pytest.approx(0.18, rel=0.15)
    # below 1 GHz (extrapolated line-by-line): less absorption than at 1 GHz
    assert go[0] < go[1] and gw[0] < gw[1]


def test_p676_equivalent_heights_clamped_below_1ghz():
    # a finding of this file: P.676-12 Annex 2 eq. (33) has a pole at 0.715 GHz, so the
    # oxygen equivalent height went negative (-367 km at 0.714 GHz) and the loss along a
    # climbing path *grew* with height.  Below 1 GHz the 1 GHz heights are used (clamp).
    f = np.array([0.5, 0.6, 0.69, 0.714, 0.716, 0.8, 0.99, 1.0]) * 1e9
    ho, hw = at.gaseous_equivalent_heights_m(f)
    h1o, h1w = at.gaseous_equivalent_heights_m(1e9)
    assert ho == pytest.approx(np.full(f.shape, h1o), rel=1e-12)
    assert hw == pytest.approx(np.full(f.shape, h1w), rel=1e-12)
    # P.676-12 eq. (31) at 1 GHz without the line terms: h_o ≈ 6.1 A/(1 + 0.17) ≈ 5.3-5.6 km
    assert 5.0e3 < h1o < 6.0e3 and 1.6e3 < h1w < 1.8e3
    # zenith loss at 0.7 GHz: the closed form γ_o h_o + γ_w h_w of the exponential profiles
    go, gw = at.gaseous_specific_attenuation_db_per_km(0.7e9)
    loss = at.gaseous_loss_db(1e6, math.pi / 2, gamma_o_db_per_km=go, gamma_w_db_per_km=gw,
                              h_o_m=h1o, h_w_m=h1w)
    assert loss == pytest.approx((go * h1o + gw * h1w) / 1e3, rel=1e-4)


@pytest.mark.parametrize(
    ("freq", "k_h", "alpha_h", "k_v", "alpha_v"),
    [
        # ITU-R P.838-3 Table (coefficients at the ends of the table and at 10 GHz)
        (1e9, 0.0000259, 0.9691, 0.0000308, 0.8592),
        (10e9, 0.01217, 1.2571, 0.01129, 1.2156),
        (100e9, 1.3671, 0.6815, 1.3680, 0.6765),
    ],
)
def test_p838_at_300_mm_h_and_the_table_ends(freq, k_h, alpha_h, k_v, alpha_v):
    for pol, k, alpha in (("H", k_h, alpha_h), ("V", k_v, alpha_v)):
        gamma = at.rain_specific_attenuation_db_per_km(freq, [1.0, 300.0], pol)
        assert gamma == pytest.approx([k, k * 300.0**alpha], rel=2e-3)


def test_p838_below_its_table_uses_1ghz():
    # documented clamp: the 1 GHz coefficients below 1 GHz (k falls with f: an upper bound)
    assert at.rain_specific_attenuation_db_per_km(F_MIN, 300.0, "H") == pytest.approx(
        at.rain_specific_attenuation_db_per_km(1e9, 300.0, "H"), rel=1e-12)


def test_p840_fog_follows_the_rayleigh_f_squared_law_at_low_frequency():
    # K_l = 0.819 f / (ε'' (1 + η²)) -> ∝ f² when f << the double-Debye relaxations
    k = at.fog_specific_attenuation_db_per_km([0.25e9, F_MIN], 1.0)
    assert k[1] / k[0] == pytest.approx(4.0, rel=0.01)
    top = at.fog_specific_attenuation_db_per_km(F_MAX, [0.0, 0.05, 5.0])
    assert top[0] == 0.0 and np.all(np.isfinite(top)) and top[2] == pytest.approx(100 * top[1])


# =========================================================================== weather [39]-[45]
def test_rain_k_interpolation_at_its_ends():
    # [42]: 7e-48 up to 6 GHz, 13e-48 from 35 GHz, linear between (clamped outside)
    k = wc.reflectivity_constant([F_MIN, 6e9, 6e9 * (1 + 1e-12), 20.5e9, 35e9, F_MAX])
    assert k == pytest.approx([7e-48, 7e-48, 7e-48, 10e-48, 13e-48, 13e-48], rel=1e-9)


def test_rain_300_mm_h_is_marshall_palmer():
    # second method: Z = 200 R^1.6 mm⁶/m³ (62.6 dBZ at 300 mm/h), η = π⁵ |K_w|² Z / λ⁴ with
    # |K_w|² = 0.93 (Rayleigh, valid at 3 GHz)
    z = 200.0 * 300.0**1.6
    assert 10 * math.log10(z) == pytest.approx(62.6, abs=0.05)
    lam = C / 3e9
    assert wc.rain_reflectivity(3e9, 300.0) == pytest.approx(
        math.pi**5 * 0.93 * z * 1e-18 / lam**4, rel=0.01)
    for f in (F_MIN, F_MAX):
        eta = wc.rain_reflectivity(f, [0.0, 300.0], "rain")
        assert eta[0] == 0.0 and np.isfinite(eta[1]) and eta[1] > 0.0


def test_weather_clutter_beyond_the_unambiguous_range_closed_form():
    # issue 23 item 5(c): rain everywhere, the cell's height at the cloud base (R φ_b > h_c),
    # a radar on a flat earth at the surface: P_1(x) = A x / x⁴ = A / x³ with
    # A = K_r ϑ0 θ_b h_c C_R, and the rain of every pulse in flight adds,
    # P_wc(R) = A Σ_{k=0}^{K} (r + k R_u)^-3 = A R_u^-3 [ζ(3, x) - ζ(3, x + K + 1)],
    # x = r / R_u, the Hurwitz zeta function (scipy.special.zeta)
    prf, r_max = 5000.0, 200e3
    r_u = C / (2 * prf)
    k_r, eta, th, ph, hc, cr = 2.0, 1e-7, 0.03, 0.35, 500.0, 37.5
    a = k_r * eta * th * hc * cr

    def single(x):
        return wc.single_trip_power_w(k_r, eta, x, x, th, ph, hc, cr)

    ranges = np.array([2e3, 20e3, 50e3, 170e3, 199e3])
    got = wc.range_folded_power_w(single, ranges, prf, r_max)
    x = np.mod(ranges, r_u) / r_u
    n_trips = np.floor((r_max - np.mod(ranges, r_u)) / r_u) + 1
    closed = a * r_u**-3 * (zeta(3, x) - zeta(3, x + n_trips))
    assert got == pytest.approx(closed, rel=1e-9)
    # the seed-literal value at 170 km (volume at R_c, R⁴ at the true range) is 37.5 dB lower
    r_c = float(wc.folded_range_m(170e3, prf))
    seed = a * r_c / 170e3**4
    assert 10 * math.log10(got[3] / seed) == pytest.approx(10 * math.log10(
        (170e3 / r_c) ** 4 * r_c**3 * r_u**-3 * (zeta(3, r_c / r_u) - zeta(3, r_c / r_u + 7))
    ), rel=1e-9)
    assert 10 * math.log10(got[3] / seed) > 37.0
    # a radar whose instrumented range is inside R_u sees only its own cell (the seed's case)
    assert wc.range_folded_power_w(single, 20e3, prf, 25e3) == pytest.approx(single(20e3))


@settings(max_examples=60, deadline=None)
@given(
    r=st.floats(0.0, 1e6),
    prf=st.floats(50.0, 5e5),
    r_max=st.floats(1e3, 1e6),
    rate=st.floats(0.0, 300.0),
    f=st.floats(F_MIN, F_MAX),
)
def test_weather_folded_power_property(r, prf, r_max, rate, f):
    eta = wc.rain_reflectivity(f, rate)

    def single(x):
        return wc.single_trip_power_w(1e3, eta, x, np.hypot(x, 25.0), 0.03, 0.35, 2000.0, 37.5)

    p = wc.range_folded_power_w(single, r, prf, r_max)
    assert np.isfinite(p) and p >= 0.0
    # the cell's own rain is one of the terms: never less than the single-trip power
    assert p >= single(np.asarray(r)) * (1 - 1e-12)


# =========================================================================== [2], [47]: range 0
def test_zero_range_is_floored_not_infinite():
    # SPEC §4 item 13: [2] and [47] floor R at 1 m (inside the eclipsed zone, never detected)
    assert noise.received_power(1.0, 1.0, 1.0, [0.0, 1e-300, 1.0]) == pytest.approx([1.0] * 3)
    p = jm.jammer_power_w(1e6, 1e3, 1e4, 1.0, 1.0, 0.05, [0.0, 1.0], 1e6, 1e9)
    assert p[0] == p[1] and np.isfinite(p[0])
    with pytest.raises(ValueError):
        wc.weather_clutter_power_w(1.0, 1.0, 0.0)


@pytest.mark.parametrize("freq", [F_MIN, 1e9, 60e9, F_MAX])
def test_sky_noise_at_the_frequency_ends_is_bounded(freq):
    # between the external temperature (transparent) and the surface air temperature (opaque)
    t = noise.sky_temperature_k(freq, [0.0, math.pi / 2])
    t_ext = noise.T_COSMIC_K + noise.galactic_noise_temperature_k(freq)
    assert np.all(t >= t_ext * 0.99) and np.all(t <= 288.15)
    if freq == 60e9:  # opaque oxygen complex: the sky is the air
        assert t[0] == pytest.approx(288.15, rel=0.01)


# =========================================================================== S/I +150 and -60 dB
@pytest.mark.parametrize("method", ["exact", "seed"])
@pytest.mark.parametrize("swerling", [0, 1, 2, 3, 4])
def test_extreme_si_through_detection_and_measurement(method, swerling):
    # S/I of +150 dB and -60 dB from the powers (noise, clutter, jamming) to P_d and the
    # measurement errors: P_d -> 1 and -> P_fa (the limits of every Swerling case), errors ->
    # 0 (∝ (S/I)^-1/2, so 10^-7.5 of the resolution at 150 dB and N = 1) and -> their cap
    # H C_R, H θ_b (the (S/I)_out floor at 0 dB); nothing overflows, nothing takes log of 0
    pfa = 1e-6
    n0, lx = 1e-14, noise.power_ratio(noise.L_X_DB)
    for si_db in (150.0, -60.0):
        p_r = n0 * lx * 10 ** (si_db / 10)
        snr = noise.signal_to_noise(p_r, n0)
        s_c = sc.signal_to_clutter(p_r, 0.0, 0.0, 1.0)  # no clutter: +inf, no warning
        s_j = jm.signal_to_jamming(p_r, 0.0)
        assert np.isinf(s_c) and np.isinf(s_j)
        snr_db = 10 * np.log10(snr)
        assert snr_db == pytest.approx(si_db, rel=1e-12)
        for n in (1.0, 30.0, 1e4):
            pd = det.probability_of_detection(snr_db, pfa, n, swerling, method)
            assert np.isfinite(pd) and pfa * (1 - 1e-3) <= pd <= 1.0
            if si_db > 0:
                assert pd == pytest.approx(1.0, abs=1e-9)
            elif n == 1.0:
                assert pd == pytest.approx(pfa, rel=1e-2)
            eps_r, eps_t = me.expected_errors(snr, n, 37.5, 0.03)
            assert np.isfinite(eps_r) and np.isfinite(eps_t) and eps_r > 0.0 and eps_t > 0.0
            if si_db > 0:
                assert eps_r == pytest.approx(4.0 * 37.5 / math.sqrt(n * snr), rel=1e-12)
            else:
                assert eps_r == pytest.approx(4.0 * 37.5) and eps_t == pytest.approx(4.0 * 0.03)
    # -inf dB (S/I = 0: a target that reflects nothing) is accepted and gives P_fa
    assert det.probability_of_detection(-np.inf, pfa, 1.0, swerling, method) == pytest.approx(
        pfa, rel=1e-2)


@settings(max_examples=60, deadline=None)
@given(
    snr_db=st.floats(-60.0, 150.0),
    n=st.floats(1.0, 1e4),
    swerling=st.integers(0, 4),
    pfa=st.floats(1e-12, 1e-4),
)
def test_pd_and_errors_property_over_the_whole_si_range(snr_db, n, swerling, pfa):
    pd = det.probability_of_detection([snr_db, snr_db + 1.0], pfa, n, swerling, "exact")
    assert np.all(np.isfinite(pd)) and np.all((pd >= 0.0) & (pd <= 1.0))
    assert pd[1] >= pd[0] - 1e-12
    eps_r, eps_t = me.expected_errors(10 ** (snr_db / 10), n, 37.5, 0.03)
    assert 0.0 < eps_r <= 4.0 * 37.5 and 0.0 < eps_t <= 4.0 * 0.03


def test_measured_values_stay_in_their_domain_at_zero_range():
    rng = np.random.default_rng(5)
    out = me.measure(np.zeros(1000), np.full(1000, 2 * math.pi - 1e-16), 1e-6, 1.0, 37.5, 0.03,
                     rng)
    assert np.all(out["range_m"] >= 0.0)
    assert np.all((out["azimuth_rad"] >= 0.0) & (out["azimuth_rad"] < 2 * math.pi))


# =========================================================================== antenna edges
@pytest.mark.parametrize("pattern", ["gaussian", "sinc", "cosec2"])
def test_patterns_at_the_schema_beamwidth_ends(pattern):
    # the schema's θ_b 0.05°-20° and φ_b 0.1°-90°: |g| <= 1, g(0) = 1 (cosec2: at the tilt),
    # finite behind the antenna
    angles = np.linspace(-math.pi, math.pi, 2001)
    for bw_deg in (0.05, 20.0, 90.0):
        bw = math.radians(bw_deg)
        tilt = 0.5 * bw if pattern == "cosec2" else 0.0
        g = an.elevation_directivity(angles, bw, pattern, tilt_rad=tilt)
        assert np.all(np.isfinite(g)) and np.all(np.abs(g) <= 1.0)
        assert an.elevation_directivity(tilt, bw, pattern, tilt_rad=tilt) == pytest.approx(
            1.0, rel=1e-12)
    # the widest sinc has no first null before the back ([12] edge), and [10]-[11] put its
    # half-power point at φ_b/2 only up to the obliquity factor: g² = ½ ((1 + cos φ_b/2)/2)²
    # there (seed-literal: -0.07 dB at φ_b = 20°, -1.4 dB at 90°; docs/stability.md §2)
    for bw_deg in (20.0, 90.0):
        bw = math.radians(bw_deg)
        assert an.sinc_directivity(0.5 * bw, bw) ** 2 == pytest.approx(
            0.5 * (0.5 * (1 + math.cos(0.5 * bw))) ** 2, rel=1e-4)
    assert an.sinc_first_null_rad(math.radians(90.0)) == math.pi
