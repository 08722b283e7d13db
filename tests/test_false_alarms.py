"""Tests of shipradar.sensors.false_alarms: N_cells [90], counts [91]-[93], uniform positions."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from shipradar.sensors import false_alarms
from shipradar.sensors.false_alarms import false_alarm_count, resolution_cells, uniform_positions

DRAWS = 200_000


def test_resolution_cells_hand_computation_and_degree_erratum():
    # 60 km instrumented, θ_b = 1.5°, C_R = 150 m: 240 beams × 400 cells = 96 000
    n = resolution_cells(60e3, np.deg2rad(1.5), 150.0)
    assert n == pytest.approx(96_000.0, rel=1e-12)
    # the seed's [90] with θ_b in degrees gives the same number (SPEC §4 item 7)
    assert n == pytest.approx(360 * 60e3 / (1.5 * 150.0), rel=1e-12)
    assert resolution_cells(0.0, 0.02, 150.0) == 0.0
    with pytest.raises(ValueError):
        resolution_cells(1e4, 0.0, 150.0)


def test_bernoulli_limit_value():
    assert false_alarms.bernoulli_limit(2) == pytest.approx(0.69 / 4, rel=1e-12)


def _mean_var(eta, n_ch=2, seed=0):
    counts = false_alarm_count(eta, n_ch, np.random.default_rng(seed), size=DRAWS)
    assert counts.dtype == np.int64 and np.all(counts >= 0)
    return counts, counts.mean(), counts.var(ddof=1)


@pytest.mark.parametrize("eta", [0.001, 0.05, 0.17])
def test_bernoulli_regime(eta):
    counts, mean, var = _mean_var(eta, seed=1)
    assert set(np.unique(counts)) <= {0, 1}
    se = np.sqrt(eta * (1 - eta) / DRAWS)
    assert abs(mean - eta) < 5 * se
    assert var == pytest.approx(eta * (1 - eta), rel=10 * np.sqrt(2 / DRAWS) / np.sqrt(eta))


@pytest.mark.parametrize("eta", [0.1726, 0.5, 2.0, 8.9])
def test_poisson_regime_distribution(eta):
    counts, mean, var = _mean_var(eta, seed=2)
    assert abs(mean - eta) < 5 * np.sqrt(eta / DRAWS)
    # variance of the sample variance of a Poisson: (μ + 2μ²)/n approximately
    assert abs(var - eta) < 5 * np.sqrt((eta + 2 * eta**2) / DRAWS)
    # chi-square goodness of fit against Poisson(η), pooled tail
    k_max = int(stats.poisson.ppf(1 - 1e-4, eta))
    obs = np.bincount(np.minimum(counts, k_max), minlength=k_max + 1)
    exp = stats.poisson.pmf(np.arange(k_max + 1), eta) * DRAWS
    exp[-1] = stats.poisson.sf(k_max - 1, eta) * DRAWS
    assert stats.chisquare(obs, exp).pvalue > 1e-4


@pytest.mark.parametrize("eta", [9.0, 40.0, 1e4])
def test_normal_regime_with_squared_exponent(eta):
    # erratum 1: N(η, η); rounding to integers adds 1/12 to the variance
    counts, mean, var = _mean_var(eta, seed=3)
    assert abs(mean - eta) < 5 * np.sqrt(eta / DRAWS)
    assert abs(var - (eta + 1 / 12)) < 5 * eta * np.sqrt(2 / DRAWS)
    # shape: symmetric (a Poisson(9) would have skewness 1/3)
    assert abs(stats.skew(counts)) < 5 * np.sqrt(6 / DRAWS)


def test_regime_depends_on_channels():
    # η = 0.2 is Poisson for N_ch = 2 (limit 0.1725) and Bernoulli for N_ch = 1 (0.345)
    c1 = false_alarm_count(0.2, 1, np.random.default_rng(4), size=DRAWS)
    c2 = false_alarm_count(0.2, 2, np.random.default_rng(4), size=DRAWS)
    assert c1.max() == 1 and c2.max() >= 2


def test_vectorized_over_sectors_and_edge_values():
    eta = np.array([0.0, 0.01, 1.0, 25.0, 1e6])
    rng = np.random.default_rng(5)
    counts = np.stack([false_alarm_count(eta, 2, rng) for _ in range(2000)])
    assert counts.shape == (2000, 5)
    assert np.all(counts[:, 0] == 0)
    se = np.sqrt(eta[1:4] / 2000)
    assert np.all(np.abs(counts.mean(axis=0)[1:4] - eta[1:4]) < 5 * se)
    assert counts[:, 4].mean() == pytest.approx(1e6, rel=1e-3)
    assert false_alarm_count(3.0, 2, rng).shape == ()
    with pytest.raises(ValueError):
        false_alarm_count(-1.0, 2, rng)
    with pytest.raises(ValueError):
        false_alarm_count(np.nan, 2, rng)


def test_one_uniform_per_element_whatever_the_regime():
    a = np.random.default_rng(9)
    false_alarm_count(np.array([0.01, 3.0, 50.0]), 2, a)
    b = np.random.default_rng(9)
    b.random(3)
    assert a.random() == b.random()


def test_uniform_positions_ks():
    rng = np.random.default_rng(6)
    r, az = uniform_positions(20_000, 1e3, 60e3, 0.0, 2 * np.pi, rng)
    assert r.size == az.size == 20_000
    assert stats.kstest(r, stats.uniform(1e3, 59e3).cdf).pvalue > 1e-3
    assert stats.kstest(az, stats.uniform(0, 2 * np.pi).cdf).pvalue > 1e-3
    # uniform in R, not in area: the mean range is the midpoint, not 2/3 of the way out
    assert r.mean() == pytest.approx(30.5e3, rel=0.01)


def test_uniform_positions_per_sector_and_across_north():
    rng = np.random.default_rng(8)
    counts = np.array([3000, 0, 5000])
    a0 = np.array([np.deg2rad(350), 1.0, 2.0])
    a1 = a0 + np.deg2rad(20)
    r, az = uniform_positions(counts, [0.0, 0.0, 5e3], [1e4, 1e4, 6e3], a0, a1, rng)
    assert r.size == 8000
    first, last = az[:3000], az[3000:]
    assert np.all((first >= np.deg2rad(350)) | (first < np.deg2rad(10)))
    assert np.all((last >= 2.0) & (last <= 2.0 + np.deg2rad(20)))
    assert np.all((r[3000:] >= 5e3) & (r[3000:] < 6e3))
    unwrapped = np.where(first < 1.0, first + 2 * np.pi, first)
    assert stats.kstest(unwrapped, stats.uniform(a0[0], a1[0] - a0[0]).cdf).pvalue > 1e-3
    with pytest.raises(ValueError):
        uniform_positions(3, 10.0, 5.0, 0.0, 1.0, rng)
    empty = uniform_positions(0, 0.0, 1.0, 0.0, 1.0, rng)
    assert empty[0].size == 0


@settings(max_examples=40, deadline=None)
@given(eta=st.floats(0.0, 1e7), n_ch=st.integers(1, 4), seed=st.integers(0, 2**32 - 1))
def test_property_counts_nonnegative_integers(eta, n_ch, seed):
    c = false_alarm_count(np.array([eta, eta]), n_ch, np.random.default_rng(seed))
    assert c.dtype == np.int64 and np.all(c >= 0)
    assert np.all(c <= eta + 12 * np.sqrt(eta) + 40)


@pytest.mark.slow
def test_poisson_quantile_equals_scipy_ppf_and_edges():
    # the fast inverse CDF of [93] gives scipy's counts draw for draw (the stream depends
    # on it), over the whole Poisson regime and at U = 0
    rng = np.random.default_rng(5)
    eta = rng.uniform(0.0, false_alarms.NORMAL_MIN_ETA, 200_000)
    u = rng.random(eta.size)
    u[:10] = 0.0
    u[10:20] = np.nextafter(1.0, 0.0)
    ref = np.maximum(stats.poisson.ppf(u, eta), 0.0).astype(np.int64)
    np.testing.assert_array_equal(false_alarms.poisson_quantile(u, eta), ref)
    cdf = false_alarms.poisson_cdf_table(eta[:50])
    np.testing.assert_array_equal(false_alarms.poisson_quantile(u[:50], cdf=cdf), ref[:50])


def test_clutter_generator_counts_match_false_alarm_count():
    # ClutterFalseAlarms prepares the regimes once; its counts are false_alarm_count's
    eta = np.array([0.0, 0.05, 0.17, 0.2, 1.0, 5.0, 8.99, 9.0, 30.0])
    gen = false_alarms.ClutterFalseAlarms(
        np.zeros(eta.size), np.full(eta.size, 1e4), np.zeros(eta.size),
        np.full(eta.size, 0.1), np.ones(eta.size), eta, np.full(eta.size, 2.0),
        threshold_ratio=10.0, n_channels=2, n_pulses=10.0, range_cell_m=30.0,
        beamwidth_rad=0.03, antenna_height_m=20.0)
    for seed in range(20):
        counts, _, _ = gen.draw(np.random.default_rng(seed))
        ref = false_alarm_count(gen.eta, 2, np.random.default_rng(seed))
        np.testing.assert_array_equal(counts, ref)
    # several revolutions drawn together (the engine's block): the counts of the same
    # uniforms, one row per revolution, and every alarm placed in its own sector
    for seed in range(5):
        counts, sector, revolution, r, az = gen._draw(np.random.default_rng(seed), 7)
        m = gen.eta.size  # the active sectors (η > 0)
        ref = false_alarm_count(gen.eta, 2, np.random.default_rng(seed), size=(7, m))
        np.testing.assert_array_equal(counts, ref)
        assert np.all(np.diff(revolution) >= 0)
        np.testing.assert_array_equal(np.bincount(revolution * m + sector,
                                                  minlength=counts.size), counts.ravel())
        assert np.all((r >= gen.r_min_m[sector]) & (r < gen.r_max_m[sector]))


def test_clutter_block_of_revolutions_times_and_counts():
    """scans() of K revolutions: each alarm inside its own revolution (before the run's end
    when it ends inside the last), and per revolution a count with mean Σ η (seeded test
    against the Poisson-binomial/Poisson sum's mean and variance)."""
    n = 400
    rng = np.random.default_rng(3)
    eta = rng.uniform(0.0, 2.0, n)
    gen = false_alarms.ClutterFalseAlarms(
        np.full(n, 1e3), np.full(n, 2e4), np.linspace(0, 6, n), np.linspace(0, 6, n) + 0.01,
        np.ones(n), eta, np.full(n, 1.5), threshold_ratio=10.0, n_channels=2,
        n_pulses=10.0, range_cell_m=30.0, beamwidth_rad=0.03, antenna_height_m=20.0)
    k, period = 200, 2.0
    t_a = np.arange(k) * period
    t_b = t_a + period
    t_b[-1] = t_a[-1] + 0.5  # the run ends inside its last revolution
    out = gen.scans(t_a, t_b, np.full(k, 0.3), 2 * np.pi / period, rng)
    rev = out["revolution"]
    assert np.all((out["time_s"] >= t_a[rev]) & (out["time_s"] < t_b[rev]))
    per_rev = np.bincount(rev, minlength=k)[:-1]  # the whole revolutions
    mean = gen.expected_per_scan
    # per sector: Bernoulli variance η(1 - η) below the limit, Poisson η above it
    bern = gen.eta < false_alarms.bernoulli_limit(2)
    var = float(np.where(bern, gen.eta * (1 - gen.eta), gen.eta).sum())
    z = (per_rev.mean() - mean) / np.sqrt(var / per_rev.size)
    assert abs(z) < 4, (per_rev.mean(), mean)
    assert 0.6 < per_rev.var() / var < 1.5


@pytest.mark.parametrize("eta", [0.0, 0.01, 0.1725, 0.2, 3.0, 8.99, 9.0, 50.0, 1e4])
def test_scalar_count_and_positions_are_the_array_paths(eta):
    # the one-count and one-interval fast paths draw and compute as the general ones
    for seed in range(30):
        a = false_alarm_count(eta, 2, np.random.default_rng(seed))
        b = false_alarm_count(np.array([eta]), 2, np.random.default_rng(seed))
        assert a.shape == () and int(a) == int(b[0])
    n = int(min(eta, 20))
    r1, a1 = uniform_positions(n, 5.0, 1.1e5, 1.0, 1.0 + 2 * np.pi, np.random.default_rng(1))
    r2, a2 = uniform_positions(np.array([n]), 5.0, 1.1e5, 1.0, 1.0 + 2 * np.pi,
                               np.random.default_rng(1))
    np.testing.assert_array_equal(r1, r2)
    np.testing.assert_array_equal(a1, a2)
    with pytest.raises(ValueError):
        uniform_positions(1, 10.0, 5.0, 0.0, 1.0, np.random.default_rng(1))


@pytest.mark.parametrize("model", ["seed", "weibull_median"])
def test_generator_spike_excess_is_spike_excess(model):
    # the per-sector threshold term computed once gives spike_excess's numbers draw for draw
    n = 50
    rng = np.random.default_rng(8)
    a = rng.uniform(0.3, 4.0, n)
    gen = false_alarms.ClutterFalseAlarms(
        np.zeros(n), np.full(n, 1e4), np.zeros(n), np.full(n, 0.1), np.full(n, 0.01),
        np.full(n, 100.0), a, threshold_ratio=37.0, n_channels=2, n_pulses=10.0,
        range_cell_m=30.0, beamwidth_rad=0.03, antenna_height_m=20.0, clutter_fa_model=model)
    sector = rng.integers(0, n, 5000)
    got = gen.spike_excess(sector, np.random.default_rng(2))
    ref = false_alarms.spike_excess(37.0, a[sector], np.random.default_rng(2), model)
    np.testing.assert_array_equal(got, ref)
    assert np.all(got >= 37.0 * (1 - 1e-12)) if model == "seed" else np.all(got > 0)
