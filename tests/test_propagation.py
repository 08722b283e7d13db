"""Physics of sensors/propagation.py: profiles [7], duct height, sea surface, two-ray fallback."""

import numpy as np
import pytest
import scipy.constants as sc
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar

from shipradar.sensors import propagation as p

Z0 = p.ROUGHNESS_LENGTH_M


# ----------------------------------------------------------------------------- profiles [7]
def test_duct_profile_minimum_at_duct_height_and_deficit_20m():
    delta = 20.0
    res = minimize_scalar(lambda h: float(p.evaporation_duct_profile(h, delta)),
                          bounds=(0.0, 100.0), method="bounded", options={"xatol": 1e-7})
    assert res.x == pytest.approx(delta - Z0, abs=1e-4)
    deficit = 320.0 - res.fun
    closed = 0.125 * (delta * np.log((delta + Z0) / Z0) - delta)
    assert deficit == pytest.approx(closed, rel=1e-9)
    assert deficit == pytest.approx(27.0, abs=0.01)  # issue 4: "about 27.0 M units"


@given(st.floats(0.5, 40.0))
def test_duct_deficit_closed_form_any_height(delta):
    # the deficit is M(0) - M(delta); the true minimum, at delta - z0, is lower by
    # 0.125 z0^2 / (2 delta) only
    closed = 0.125 * (delta * np.log((delta + Z0) / Z0) - delta)
    assert 320.0 - p.evaporation_duct_profile(delta, delta) == pytest.approx(closed, rel=1e-9)
    m_min = p.evaporation_duct_profile(delta - Z0, delta)
    assert 0 <= p.evaporation_duct_profile(delta, delta) - m_min < 0.125 * Z0**2 / delta


def test_duct_profile_defined_down_to_the_surface():
    # SPEC section 4 item 8: the seed's ln(h/z0) is -inf at h = 0; ours is m0 there, finite below z0
    h = np.array([0.0, 1e-9, Z0 / 2, Z0, 2 * Z0])
    m = p.evaporation_duct_profile(h, 15.0)
    assert m[0] == 320.0
    assert np.all(np.isfinite(m))
    assert np.all(np.diff(m) < 0)  # decreasing from the surface up to the duct height
    with pytest.raises(ValueError):
        p.evaporation_duct_profile(-0.1, 15.0)


def test_duct_profile_matches_seed_form_above_roughness():
    h = np.array([1.0, 5.0, 50.0])
    delta = 12.0
    seed_form = 320.0 + 0.125 * (h - delta * np.log(h / Z0))
    # difference 0.125 delta ln(1 + z0/h) <= 0.125 delta z0 / h
    assert p.evaporation_duct_profile(h, delta) == pytest.approx(seed_form, abs=0.125 * delta * Z0)


def test_zero_duct_is_linear_and_standard_gradient():
    h = np.linspace(0, 1000, 11)
    assert p.evaporation_duct_profile(h, 0.0) == pytest.approx(320 + 0.125 * h, rel=1e-12)
    assert p.standard_profile(h) == pytest.approx(320 + 0.118 * h, rel=1e-12)
    # 0.118 M/m is the 4/3 earth: 1e6 / (4/3 a)
    assert 1e6 / (4 / 3 * p.EARTH_RADIUS_M) == pytest.approx(p.STANDARD_M_GRADIENT, rel=0.01)


def test_piecewise_profile_surface_duct():
    prof = p.piecewise_profile([0, 50, 80, 200], [340, 350, 330, 344.16])
    assert prof(25.0) == pytest.approx(345.0)
    assert prof(80.0) == pytest.approx(330.0)
    slope = (344.16 - 330) / 120
    assert prof(1200.0) == pytest.approx(344.16 + slope * 1000)
    with pytest.raises(ValueError):
        p.piecewise_profile([10, 50], [340, 350])
    with pytest.raises(ValueError):
        prof(-1.0)


def test_profile_spec_defaults_fill_so_equal_profiles_hash_equal():
    a = p.normalize_profile_spec({"kind": "standard"})
    b = p.normalize_profile_spec({"kind": "standard", "m0": 320, "gradient": 0.118})
    assert a == b
    f = p.profile_from_spec({"kind": "evaporation", "duct_height_m": 10})
    assert f(10.0) == pytest.approx(p.evaporation_duct_profile(10.0, 10.0))
    with pytest.raises(ValueError):
        p.normalize_profile_spec({"kind": "evaporation"})


# ----------------------------------------------------------------------------- duct height
def test_duct_height_typical_value_and_no_evaporation():
    # near-neutral, 80 % RH, 8 m/s: mid-latitude evaporation ducts are 5-20 m (Babin et al. 1997)
    d = p.evaporation_duct_height(20.0, 20.0, 0.8, 8.0)
    assert 5.0 < d < 20.0
    # saturated air over an equally warm sea (sea vapour pressure is 98 % of saturation): no duct
    assert p.evaporation_duct_height(20.0, 20.0, 1.0, 8.0) == 0.0


def test_duct_height_decreases_with_humidity_and_grows_in_stable_air():
    rh = np.linspace(0.5, 0.95, 10)
    d = p.evaporation_duct_height(20.0, 20.0, rh, 8.0)
    assert np.all(np.diff(d) < 0)
    stable = p.evaporation_duct_height(22.0, 20.0, 0.8, 8.0)
    unstable = p.evaporation_duct_height(18.0, 20.0, 0.8, 8.0)
    assert stable > unstable
    # very stable air with little wind: capped, documented
    assert p.evaporation_duct_height(15.0, 14.0, 0.8, 3.0) == p.MAX_EVAPORATION_DUCT_HEIGHT_M
    with pytest.raises(ValueError):
        p.evaporation_duct_height(20.0, 20.0, 80.0, 8.0)  # percent, not a fraction


@settings(max_examples=30, deadline=None)
@given(st.floats(-5, 35), st.floats(-2, 32), st.floats(0, 1), st.floats(0, 30))
def test_duct_height_always_in_range(ta, ts, rh, u):
    d = p.evaporation_duct_height(ta, ts, rh, u)
    assert 0.0 <= d <= p.MAX_EVAPORATION_DUCT_HEIGHT_M


# ----------------------------------------------------------------------------- sea water
def test_conductivity_of_standard_sea_water():
    # practical salinity scale: S = 35, 15 degC conducts 42.914 mS/cm (UNESCO 1981)
    assert p.sea_water_conductivity(15.0, 35.0) == pytest.approx(4.2914, rel=5e-3)


def test_pure_water_static_permittivity_and_relaxation():
    # Malmberg & Maryott (1956): static permittivity of water at 20 degC is 80.10
    eps_low = p.sea_water_permittivity(1e6, 20.0, 0.0)
    assert eps_low.real == pytest.approx(80.10, rel=2e-3)
    # Debye loss peak of pure water at 20 degC near 17 GHz (tau = 9.3 ps, Kaatze 1989)
    f = np.linspace(5e9, 40e9, 3501)
    loss = -p.sea_water_permittivity(f, 20.0, 0.0).imag
    assert f[np.argmax(loss)] == pytest.approx(1 / (2 * np.pi * 9.3e-12), rel=0.05)


def test_fresnel_grazing_normal_and_brewster():
    eps = p.sea_water_permittivity(3e9)
    psi = np.radians(np.linspace(0.0, 0.5, 6))
    gh = p.fresnel_reflection(psi, eps, "H")
    assert np.all(np.abs(gh) > 0.99)
    assert gh[0] == pytest.approx(-1.0)
    assert p.fresnel_reflection(0.0, eps, "V") == pytest.approx(-1.0)
    # normal incidence: Gamma_H = -Gamma_V = (1 - sqrt eps) / (1 + sqrt eps)
    normal = (1 - np.sqrt(eps)) / (1 + np.sqrt(eps))
    assert p.fresnel_reflection(np.pi / 2, eps, "H") == pytest.approx(normal, rel=1e-9)
    assert p.fresnel_reflection(np.pi / 2, eps, "V") == pytest.approx(-normal, rel=1e-9)
    # the Brewster minimum of |Gamma_V| at 3 GHz lies near 5-6 deg grazing (issue 4)
    grid = np.radians(np.linspace(0.1, 20, 20000))
    gv = np.abs(p.fresnel_reflection(grid, eps, "V"))
    psi_b = np.degrees(grid[np.argmin(gv)])
    assert 5.0 <= psi_b <= 7.0  # Klein & Swift sea water at 15 degC: 6.33 deg
    # the pseudo-Brewster angle of a good dielectric, sin psi = 1 / sqrt|eps| (Blake 6.4)
    assert psi_b == pytest.approx(np.degrees(np.arcsin(1 / np.sqrt(abs(eps)))), abs=0.1)
    # lossless dielectric: Gamma_V = 0 exactly at the Brewster angle, tan(90 - psi) = sqrt(eps)
    psi_b = np.pi / 2 - np.arctan(2.0)
    assert abs(p.fresnel_reflection(psi_b, 4.0 + 0j, "V")) < 1e-12


def test_roughness_factors_hand_values():
    f = 10e9
    lam = sc.c / f
    psi = np.radians(30.0)
    # g = 2 pi sigma sin(psi) / lambda = 0.5 with sigma = H_1/3 / 4
    wave = 4 * 0.5 * lam / (2 * np.pi * np.sin(psi))
    i0_half = 1 + 0.0625 + 0.0625**2 / 4 + 0.0625**3 / 36 + 0.0625**4 / 576  # I0(0.5), series
    assert p.roughness_factor(psi, wave, f, "ament") == pytest.approx(np.exp(-0.5), rel=1e-12)
    assert p.roughness_factor(psi, wave, f) == pytest.approx(np.exp(-0.5) * i0_half, rel=1e-6)
    assert p.roughness_factor(psi, 0.0, f) == 1.0
    # very rough sea: Miller-Brown tends to 1 / (2 g sqrt(pi))
    g = 100.0
    wave = 4 * g * lam / (2 * np.pi * np.sin(psi))
    assert p.roughness_factor(psi, wave, f) == pytest.approx(1 / (2 * g * np.sqrt(np.pi)), rel=1e-3)


# ----------------------------------------------------------------------------- two-ray
def test_specular_point_obeys_fermat():
    a_e = 4 / 3 * p.EARTH_RADIUS_M
    for d, h1, h2 in [(10e3, 20.0, 300.0), (30e3, 25.0, 40.0), (5e3, 100.0, 5.0)]:
        d1 = p._reflection_geometry(d, h1, h2, a_e)

        def path(x, d=d, h1=h1, h2=h2):
            return p._chord(h1, 0.0, a_e, x / a_e) + p._chord(0.0, h2, a_e, (d - x) / a_e)

        best = minimize_scalar(path, bounds=(0, d), method="bounded", options={"xatol": 1e-6})
        # Kerr's cubic uses the small-angle sphere; its point is off by < 0.01 %, and the
        # path (what the phase uses) is stationary there: error well below a micrometre
        assert d1 == pytest.approx(best.x, rel=1e-4)
        assert path(d1) - path(best.x) < 1e-6


def test_two_ray_flat_earth_limit_is_image_theory():
    f, h1 = 3e9, 20.0
    k = 2 * np.pi * f / sc.c
    d = np.linspace(500, 5000, 50)[:, None]
    h2 = np.array([5.0, 30.0, 100.0])[None, :]
    eps = p.sea_water_permittivity(f)
    rd = np.hypot(d, h2 - h1)
    rr = np.hypot(d, h2 + h1)
    psi = np.arctan2(h1 + h2, d)
    for pol in "HV":
        gamma = p.fresnel_reflection(psi, eps, pol)
        image = np.abs(1 + gamma * rd / rr * np.exp(-1j * k * (rr - rd)))
        flat = p.two_ray_factor(d, h1, h2, f, pol, k_factor=1e6)
        assert flat == pytest.approx(image, rel=2e-3, abs=2e-3)


def test_two_ray_pattern_per_ray_and_edges():
    f = 10e9
    beam = np.radians(1.0)

    def pattern(el):
        return np.exp(-2 * np.log(2) * (np.asarray(el) / beam) ** 2)

    # beam tilted up 2 deg, target on the beam axis at short range: the reflected ray is
    # 4 beamwidths down the pattern, so F -> g(axis) = 1
    tilt = np.radians(2.0)
    d = 2000.0
    h2 = 20.0 + d * np.tan(tilt)
    f_axis = p.two_ray_factor(d, 20.0, h2, f, "H", elevation_pattern=pattern, tilt_rad=tilt)
    assert f_axis == pytest.approx(1.0, abs=0.02)
    # zero range, zero heights: finite
    out = p.two_ray_factor(np.array([0.0, 10.0, 1e5]), 20.0, np.array([30.0, 0.0, 0.0]), f, "V")
    assert np.all(np.isfinite(out)) and np.all(out >= 0)


def test_two_ray_beyond_horizon_is_smooth_earth_diffraction():
    f, h1 = 10e9, 20.0
    h2 = np.array([10.0, 50.0])
    dh = p.horizon_range(h1, h2)
    d = dh + 20e3
    expected = p.smooth_earth_diffraction_factor(d, h1, h2, f, "H")
    assert p.two_ray_factor(d, h1, h2, f, "H") == pytest.approx(expected, rel=1e-9)
    far = p.two_ray_factor(dh[0] + np.linspace(0, 60e3, 30), h1, 10.0, f, "H")
    assert np.all(np.diff(far) < 0)
    # P.526 first term: continuity of F(X) at X = 1.6 and G(Y) at B = 2 (both branches meet)
    x = 1.6
    assert 11 + 10 * np.log10(x) - 17.6 * x == pytest.approx(
        -20 * np.log10(x) - 5.6488 * x**1.425, abs=0.02)


def test_two_ray_intermediate_region_is_between_its_ends():
    f, h1, h2 = 3e9, 20.0, 30.0
    dl = p.interference_region_limit(h1, h2, f)
    dh = p.horizon_range(h1, h2)
    assert 0 < dl < dh
    d = np.linspace(dl, dh, 20)
    fd = p.two_ray_factor(d, h1, h2, f, "H")
    lo, hi = sorted([fd[0], fd[-1]])
    assert np.all((fd >= lo * (1 - 1e-6)) & (fd <= hi * (1 + 1e-6)))


@settings(max_examples=60, deadline=None)
@given(
    st.floats(0, 200e3), st.floats(1, 100), st.floats(0, 3000), st.sampled_from("HV"),
    st.floats(0, 5),
)
def test_two_ray_is_finite_and_bounded(d, h1, h2, pol, wave):
    f = float(p.two_ray_factor(d, h1, h2, 5e9, pol, wave_height_m=wave))
    assert np.isfinite(f)
    assert 0.0 <= f <= 2.0 + 1e-9  # |g_d + rho D Gamma g_r| with |.| <= 1 each


def test_surface_duct_height_of_a_profile():
    """A trapping layer reaching down to the sea is a surface duct up to its minimum; an
    elevated duct or a monotone profile has none."""
    assert p.surface_duct_height([0.0, 150.0, 300.0], [330.0, 320.0, 350.0]) == 150.0
    assert p.surface_duct_height([0.0, 100.0, 150.0, 300.0], [330.0, 331.0, 329.0, 350.0]) == 150.0
    assert p.surface_duct_height([0.0, 200.0, 300.0], [330.0, 350.0, 340.0]) == 0.0
    assert p.surface_duct_height([0.0, 1000.0], [330.0, 448.0]) == 0.0
