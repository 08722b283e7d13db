"""The median-consistent sea-clutter false-alarm model (``fidelity.clutter_fa_model``), 7.2.

The seed's [94]-[95] put the mean σ0 in place of the median on both sides, so σ0 cancels and
P_fac depends on a alone.  The "weibull_median" option sets the threshold on the mean (the
threshold giving P_fa on a_min clutter of mean σ0; Y = σ0 ln(1/P_fa) for Rayleigh) and takes
[94] over the true median of [30].  The reference values here come from scipy's Weibull
distribution and numerical quadrature (mean, threshold and tail integrated, the threshold
found by root-finding), never from the formula in :mod:`shipradar.sensors.false_alarms`.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, optimize, stats

from shipradar.sensors import false_alarms as fa
from shipradar.sim.world.scenario import ScenarioError
from shipradar.tables.pfac import (
    PFAC_MAP_NAME,
    PFAC_MAP_VERSION,
    clutter_false_alarm_generator,
    pfac_map_inputs,
)
from shipradar.tables.store import inputs_hash

from .test_clutter_false_alarms import clutter_scene, model_of, specs_of

LN2 = math.log(2.0)
#: P_fa of the demo radar (docs/false_alarms.md, tests/test_pfac_hand.py)
PFA_DEMO = 3.603e-8
MODELS = ("seed", "weibull_median")


def weibull_of(a: float):
    """[94] as a distribution of the power x with median 1: x = (E/ln 2)^a, E ~ Exp(1)."""
    return stats.weibull_min(c=1.0 / a, scale=LN2**-a)


def numerical_mean(a: float) -> float:
    """E[x] by quadrature of x f(x) (not the Γ formula of [30])."""
    w = weibull_of(a)
    med = w.median()
    # split at the median: the density is singular at 0 for a > 1
    lo = integrate.quad(lambda x: x * w.pdf(x), 0.0, med, limit=200)[0]
    hi = integrate.quad(lambda x: x * w.pdf(x), med, np.inf, limit=200)[0]
    return lo + hi


def numerical_pfac(a: float, pfa: float, a_min: float = 1.0) -> float:
    """P(x > Y) for clutter of parameter a and mean σ0, Y the threshold that a CFAR designed
    for a_min clutter of the same mean sets for P_fa (root of the a_min tail, in σ0 units)."""
    w_min = weibull_of(a_min)
    m_min = numerical_mean(a_min)
    # threshold over the mean: P(x_min/m_min > t) = P_fa
    t = optimize.brentq(lambda t: w_min.logsf(t * m_min) - math.log(pfa), 1e-9, 1e9,
                        xtol=1e-14, rtol=1e-14)
    w = weibull_of(a)
    y = t * numerical_mean(a)  # the same threshold over a's median-1 scale
    return integrate.quad(w.pdf, y, np.inf, epsabs=0.0, epsrel=1e-11, limit=200)[0]


# --------------------------------------------------------------------------- the formula
@pytest.mark.parametrize("pfa", [1e-10, PFA_DEMO, 1e-6, 1e-3])
@pytest.mark.parametrize("a", [1.2, 1.5, 2.0, 2.5, 3.0, 4.0])
def test_variant_equals_numerical_integration(a, pfa):
    got = float(fa.clutter_fa_probability(a, pfa, model="weibull_median"))
    assert got == pytest.approx(numerical_pfac(a, pfa), rel=1e-6)


@pytest.mark.parametrize("a_min,a", [(0.8, 1.5), (0.8, 3.0), (1.3, 2.0), (1.7, 2.6)])
def test_variant_with_a_min_not_one(a_min, a):
    """The threshold is the one that gives P_fa on a_min clutter of the same mean."""
    pfa = 1e-6
    got = float(fa.clutter_fa_probability(a, pfa, a_min, model="weibull_median"))
    assert got == pytest.approx(numerical_pfac(a, pfa, a_min), rel=1e-6)
    y = float(fa.clutter_threshold_ratio(pfa, a_min, "weibull_median"))
    m = numerical_mean(a_min)
    assert weibull_of(a_min).sf(y * m) == pytest.approx(pfa, rel=1e-8)


def test_threshold_is_the_rayleigh_cfar_on_the_mean():
    """a_min = 1: Y = σ0 ln(1/P_fa), what a cell-averaging CFAR on exponential power sets."""
    for pfa in (1e-12, PFA_DEMO, 1e-3, 0.5):
        y = float(fa.clutter_threshold_ratio(pfa, 1.0, "weibull_median"))
        assert y == pytest.approx(math.log(1.0 / pfa), rel=1e-13)
        assert stats.expon.sf(y) == pytest.approx(pfa, rel=1e-12)
    # the seed's reading is that threshold over the *median* σ0 ln 2 of Rayleigh clutter
    assert float(fa.clutter_threshold_ratio(PFA_DEMO)) == pytest.approx(
        math.log(1 / PFA_DEMO) / LN2, rel=1e-13)


@pytest.mark.parametrize("a", [0.5, 1.0, 1.5, 2.0, 3.0, 4.5])
def test_median_ratio_is_30(a):
    """[30]: σ0^50 = σ0 - 1.6 a - 10 log Γ(1+a) [dB] (1.6 = -10 log10 ln 2), against scipy's
    median and the quadrature mean."""
    ratio = float(fa.weibull_median_ratio(a))
    assert ratio == pytest.approx(weibull_of(a).median() / numerical_mean(a), rel=1e-7)
    from scipy.special import gamma
    db = -10 * math.log10(LN2) * a + 10 * math.log10(gamma(1 + a))
    assert 10 * math.log10(ratio) == pytest.approx(-db, abs=1e-9)


# the demo radar: docs/false_alarms.md and docs/accuracy.md quote these
@pytest.mark.parametrize("a,seed,median", [
    (1.5, 2.8e-3, 3.2e-4), (2.0, 0.032, 2.9e-3), (2.5, 0.082, 6.5e-3), (3.0, 0.133, 9.2e-3),
])
def test_demo_values_and_ratio(a, seed, median):
    p_seed = float(fa.clutter_fa_probability(a, PFA_DEMO))
    p_med = float(fa.clutter_fa_probability(a, PFA_DEMO, model="weibull_median"))
    assert p_seed == pytest.approx(seed, rel=0.02)
    assert p_med == pytest.approx(median, rel=0.02)
    # the seed's substitution: with the seed's own threshold over the *mean* (σ0 for the
    # median), scipy's Weibull of that mean gives the seed's number
    y = math.log(1 / PFA_DEMO) / LN2
    assert weibull_of(a).sf(y) == pytest.approx(p_seed, rel=1e-10)
    assert 8.0 < p_seed / p_med < 15.0


def test_ratio_to_seed_grows_with_a():
    a = np.array([1.5, 2.0, 2.5, 3.0])
    ratio = (fa.clutter_fa_probability(a, PFA_DEMO)
             / fa.clutter_fa_probability(a, PFA_DEMO, model="weibull_median"))
    np.testing.assert_allclose(ratio, [8.62, 11.11, 12.64, 14.38], rtol=2e-3)
    assert np.all(np.diff(ratio) > 0)


@pytest.mark.parametrize("pfa", [1e-14, 1e-10, PFA_DEMO, 1e-6, 1e-4])
def test_monotone_up_to_a_peak_then_down(pfa):
    """Rising in a on [a_min, 3] (the range a takes in VP maps); at fixed mean the tail
    beyond Y = σ0 L is bounded by Markov, P ≤ 1/L, so it peaks (a ≈ 3.3-4.7) and falls
    back to 0, whereas the seed's form rises to 1/2."""
    a = np.linspace(1.0 + 1e-9, 40.0, 4000)
    p = fa.clutter_fa_probability(a, pfa, model="weibull_median")
    seed = fa.clutter_fa_probability(a, pfa)
    assert np.all(np.diff(p[a <= 3.0]) > 0) and np.all(np.diff(seed) > 0)
    i = int(np.argmax(p))
    assert 3.2 < a[i] < 4.8
    assert np.all(np.diff(p[: i + 1]) > 0) and np.all(np.diff(p[i:]) < 0)
    # independent position of the peak: maximize the quadrature over a
    res = optimize.minimize_scalar(lambda x: -numerical_pfac(x, pfa), bounds=(2.0, 6.0),
                                   method="bounded", options={"xatol": 1e-4})
    assert a[i] == pytest.approx(res.x, abs=0.02)
    assert p.max() <= 1.0 / math.log(1 / pfa)  # Markov
    assert np.all(p <= seed)


# --------------------------------------------------------------------------- edges
def test_limits_without_floating_point_warnings():
    ref_tiny = numerical_pfac(3.0, 1e-300)  # scipy's quadrature underflows: outside
    with np.errstate(all="raise"):
        # a → a_min+: P_fa (the threshold's definition); a ≤ a_min: 0 (the seed's cut-off)
        for a_min in (0.8, 1.0, 2.0):
            p = fa.clutter_fa_probability(a_min * (1 + 1e-12), 1e-6, a_min,
                                          model="weibull_median")
            assert float(p) == pytest.approx(1e-6, rel=1e-9)
            assert float(fa.clutter_fa_probability(a_min, 1e-6, a_min,
                                                   model="weibull_median")) == 0.0
            assert float(fa.clutter_fa_probability(0.5 * a_min, 1e-6, a_min,
                                                   model="weibull_median")) == 0.0
        # P_fa → 1: threshold → 0, everything exceeds it
        a = np.array([1.5, 3.0, 1e6, 1e300, 1.7e308, np.inf])
        np.testing.assert_allclose(fa.clutter_fa_probability(a, 1.0 - 1e-15,
                                                             model="weibull_median")[:2],
                                   1.0, atol=1e-3)
        np.testing.assert_array_equal(
            fa.clutter_fa_probability(a, 1.0, model="weibull_median"), 1.0)
        # huge a: → 0 quietly (no overflow in Γ(1+a) or in the exponent)
        p = fa.clutter_fa_probability(a, PFA_DEMO, model="weibull_median")
        assert p[2] < 1e-100 and np.all(p[3:] == 0.0)
        # tiny P_fa: finite, small (the a = 3 tail is heavy: 1.1e-7)
        p = fa.clutter_fa_probability(np.array([1.5, 3.0]), 1e-300, model="weibull_median")
        assert 0.0 < p[0] < 1e-40 and p[1] == pytest.approx(ref_tiny, rel=1e-5)
        p = fa.clutter_fa_probability(2.0, 5e-324, 0.5, model="weibull_median")
        assert 0.0 < float(p) < 1e-3
        assert np.all(fa.weibull_median_ratio(np.array([1e3, 1e300, np.inf])) == 0.0)


def test_bad_inputs_raise():
    with pytest.raises(ValueError, match="model"):
        fa.clutter_fa_probability(2.0, 1e-6, model="median")
    with pytest.raises(ValueError):
        fa.clutter_fa_probability(np.nan, 1e-6, model="weibull_median")
    with pytest.raises(ValueError):
        fa.clutter_fa_probability(2.0, 0.0, model="weibull_median")
    with pytest.raises(ValueError):
        fa.clutter_fa_probability(2.0, 1e-6, 0.0, model="weibull_median")
    with pytest.raises(ValueError):
        fa.default_p_fac_max(1e-6, model="median")
    with pytest.raises(ValueError):
        pfac_map_inputs({"max_range_m": 1e4, "n_range": 11, "n_azimuth": 4,
                         "polarization": "V"}, pfa=1e-6, clutter_fa_model="x")


@pytest.mark.parametrize("k", [1.0, 3.0, 10.0, 1e4])
def test_k_clutter_divides_both_models(k):
    a = np.array([0.9, 1.0, 1.3, 2.0, 3.0])
    for model in MODELS:
        p1 = fa.clutter_fa_probability(a, PFA_DEMO, model=model)
        pk = fa.clutter_fa_probability(a, PFA_DEMO, k_clutter=k, model=model)
        np.testing.assert_allclose(pk, p1 / k, rtol=1e-14)
    with pytest.raises(ValueError):
        fa.clutter_fa_probability(a, PFA_DEMO, k_clutter=0.5, model="weibull_median")


def test_noise_like_cut_off_applies_to_both_models():
    a = np.array([2.0, 2.0, 2.0])
    p_sc = np.array([1.0, 2.0, 3.0])
    for model in MODELS:
        p = fa.clutter_fa_probability(a, 1e-6, 1.0, 1.0, p_sc, 1.0, model=model)
        assert p[0] == 0.0 and p[1] > 0.0 and p[2] == p[1]


def test_hp_default_p_fac_max():
    """HP: P_facmax = [94]-[95] at a = 3 under the chosen model (9.2e-3 for the demo P_fa,
    within the seed's suggested 1e-3 to 1e-2)."""
    p = float(fa.default_p_fac_max(PFA_DEMO, model="weibull_median"))
    assert p == pytest.approx(numerical_pfac(3.0, PFA_DEMO), rel=1e-6)
    assert 1e-3 < p < 1e-2
    assert float(fa.default_p_fac_max(PFA_DEMO)) == pytest.approx(0.1327, rel=1e-3)
    # a_min ≥ 3: P_fa, as for the seed's model
    assert float(fa.default_p_fac_max(1e-6, 3.5, "weibull_median")) == 1e-6


@pytest.mark.parametrize("a", [1.5, 3.0])
def test_spike_size_is_the_conditional_tail(a):
    """Spike x/σ0 above Y, drawn with the median of [30]: KS against scipy's Weibull of
    mean 1 conditioned on x > Y."""
    y = float(fa.clutter_threshold_ratio(1e-6, 1.0, "weibull_median"))
    x = fa.spike_excess(y, np.full(20_000, a), np.random.default_rng(5), "weibull_median")
    m = numerical_mean(a)
    w = weibull_of(a)
    assert x.min() >= y * (1 - 1e-12)

    def cdf(v):
        return 1.0 - w.sf(v * m) / w.sf(y * m)
    assert stats.kstest(x, cdf).pvalue > 1e-3
    # the seed's draw, from the same threshold, is a different (heavier) law
    xs = fa.spike_excess(y, np.full(20_000, a), np.random.default_rng(5))
    assert stats.kstest(xs, cdf).pvalue < 1e-6


# --------------------------------------------------------------------------- scenario, tables
def test_fidelity_field():
    assert clutter_scene().fidelity.clutter_fa_model == "seed"
    s = clutter_scene(fid={"clutter_fa_model": "weibull_median"})
    assert s.fidelity.clutter_fa_model == "weibull_median"
    with pytest.raises(ScenarioError, match="clutter_fa_model"):
        clutter_scene(fid={"clutter_fa_model": "median"})


def test_seed_key_unchanged():
    """The seed model adds nothing to the inputs: keys of cached seed tables stay valid."""
    sea = {"max_range_m": 2e4, "n_range": 201, "n_azimuth": 360, "polarization": "V"}
    base = pfac_map_inputs(sea, pfa=1e-6, k_clutter=2.0)
    assert "clutter_fa_model" not in base
    assert pfac_map_inputs(sea, pfa=1e-6, k_clutter=2.0, clutter_fa_model="seed") == base
    med = pfac_map_inputs(sea, pfa=1e-6, k_clutter=2.0, clutter_fa_model="weibull_median")
    assert med == {**base, "clutter_fa_model": "weibull_median"}
    assert PFAC_MAP_VERSION == 1


@pytest.mark.parametrize("pol", ["V", "H"])
def test_scene_picks_the_model(table_cache, pol):
    seed_s = clutter_scene(polarization=pol)
    med_s = clutter_scene(polarization=pol, fid={"clutter_fa_model": "weibull_median"})
    t_seed = specs_of(seed_s)["pfac"].make()
    t_med = specs_of(med_s)["pfac"].make()
    assert "clutter_fa_model" not in t_seed.inputs
    assert t_med.inputs["clutter_fa_model"] == "weibull_median"
    assert (inputs_hash(PFAC_MAP_NAME, PFAC_MAP_VERSION, t_seed.inputs)
            != inputs_hash(PFAC_MAP_NAME, PFAC_MAP_VERSION, t_med.inputs))
    assert t_med.inputs["sea_map"] == t_seed.inputs["sea_map"]  # the same sea map
    # fewer clutter false alarms everywhere, none where the seed has none
    assert np.all(t_med.values <= t_seed.values)
    assert np.all((t_med.values > 0) == (t_seed.values > 0))
    eta_seed = t_seed.extra["expected_count"].sum()
    eta_med = t_med.extra["expected_count"].sum()
    if pol == "V":
        # a ≤ 2.6 in this sea-state-5 scene: the ratio at a from 1 to 2.6, weighted
        assert 3.0 < eta_seed / eta_med < 14.0
    else:
        # HP: the same taper, P_facmax 0.133 → 9.2e-3 (the ratio at a = 3, P_fa of the scene)
        pfa = model_of(seed_s).pfa
        ratio = fa.default_p_fac_max(pfa) / fa.default_p_fac_max(pfa, model="weibull_median")
        assert eta_seed / eta_med == pytest.approx(float(ratio), rel=1e-9)
    # the generator carries the model: threshold over the mean and the [30] median
    m = model_of(med_s)
    g = clutter_false_alarm_generator(t_med, pfa=m.pfa, n_channels=2, n_pulses=10)
    assert g.clutter_fa_model == "weibull_median"
    assert g.threshold_ratio == pytest.approx(math.log(1 / m.pfa), rel=1e-12)
    g0 = clutter_false_alarm_generator(t_seed, pfa=m.pfa, n_channels=2, n_pulses=10)
    assert g0.clutter_fa_model == "seed"
    assert g0.expected_per_scan == pytest.approx(eta_seed, rel=1e-12)
    assert g.expected_per_scan == pytest.approx(eta_med, rel=1e-12)


def test_k_clutter_divides_the_variant_map(table_cache):
    fid = {"clutter_fa_model": "weibull_median"}
    t1 = specs_of(clutter_scene(fid=fid))["pfac"].make()
    t5 = specs_of(clutter_scene(fid=fid, k_clutter=5.0))["pfac"].make()
    # the sector mean of node P_fac / K (trapezoid): equal to rounding
    np.testing.assert_allclose(t5.values, t1.values / 5.0, rtol=1e-9, atol=1e-18)
    assert t5.values.max() > 0.0
