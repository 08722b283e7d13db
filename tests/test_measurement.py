"""Tests of shipradar.sensors.measurement: expected errors [84]-[85] and noisy plots [86]-[89]."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from shipradar.sensors import measurement
from shipradar.sensors.measurement import (
    expected_errors,
    measure,
    noisy_azimuth,
    noisy_range,
    output_snr,
)


def test_errors_equal_resolution_at_12_db():
    # seed 6.5: with H = 4 the mean error is the resolution when (S/I)_out = 12 dB
    snr_out = 10**1.2
    eps_r, eps_t = expected_errors(snr_out, 1, 150.0, 0.02)
    assert eps_r == pytest.approx(150.0 * 4 / np.sqrt(snr_out), rel=1e-12)
    assert eps_r == pytest.approx(150.0, rel=0.01)
    assert eps_t == pytest.approx(0.02, rel=0.01)


def test_output_snr_is_energy_over_pulses():
    # (S/I)_out = N_e S/I: 10 pulses at 5 dB give the errors of one pulse at 15 dB
    a = expected_errors(10**0.5, 10, 100.0, 0.01, h_range=2.0, h_azimuth=3.0)
    b = expected_errors(10**1.5, 1, 100.0, 0.01, h_range=2.0, h_azimuth=3.0)
    np.testing.assert_allclose(a, b, rtol=1e-12)
    assert a[0] == pytest.approx(2.0 * 100.0 / np.sqrt(10**1.5), rel=1e-12)
    assert a[1] == pytest.approx(3.0 * 0.01 / np.sqrt(10**1.5), rel=1e-12)


def test_low_snr_is_capped_and_finite():
    snr = np.array([0.0, 1e-30, 0.5, 1.0, 4.0, np.inf])
    eps_r, eps_t = expected_errors(snr, 1.0, 30.0, 0.03)
    assert np.all(np.isfinite(eps_r)) and np.all(np.isfinite(eps_t))
    # below 0 dB output S/I the errors stay at H C_R and H θ_b
    np.testing.assert_allclose(eps_r[:4], 4 * 30.0, rtol=1e-12)
    np.testing.assert_allclose(eps_t[:4], 4 * 0.03, rtol=1e-12)
    assert eps_r[4] == pytest.approx(60.0, rel=1e-12)
    assert eps_r[5] == 0.0
    assert output_snr(-3.0, 2).item() == measurement.MIN_OUTPUT_SNR


def test_output_snr_rejects_nan_and_few_pulses():
    with pytest.raises(ValueError):
        output_snr(np.nan, 1)
    with pytest.raises(ValueError):
        output_snr(1.0, 0.5)


def test_measurement_std_is_eps_over_three_chi_square():
    rng = np.random.default_rng(11)
    n = 20_000
    r_true = np.full(n, 20_000.0)
    az_true = np.full(n, 1.0)
    out = measure(r_true, az_true, 10**1.0, 4, 150.0, 0.025, rng)
    eps_r, eps_t = expected_errors(10**1.0, 4, 150.0, 0.025)
    sig_r, sig_t = eps_r / 3, eps_t / 3
    np.testing.assert_allclose(out["sigma_range_m"], sig_r, rtol=1e-12)
    np.testing.assert_allclose(out["sigma_azimuth_rad"], sig_t, rtol=1e-12)
    for err, sig in ((out["range_m"] - r_true, sig_r), (out["azimuth_rad"] - az_true, sig_t)):
        # sample variance: (n-1) s²/σ² ~ χ²(n-1); two-sided 99.9 % interval
        q = (n - 1) * np.var(err, ddof=1) / sig**2
        lo, hi = stats.chi2.ppf([5e-4, 1 - 5e-4], n - 1)
        assert lo < q < hi
        assert abs(np.mean(err)) < 4 * sig / np.sqrt(n)
        assert stats.normaltest(err).pvalue > 1e-4
    # the seed's "99 % within ± ε": P(|e| < 3σ) = 0.9973
    assert np.mean(np.abs(out["range_m"] - r_true) < eps_r) == pytest.approx(0.9973, abs=0.002)


def test_range_folded_nonnegative_and_azimuth_wrapped():
    rng = np.random.default_rng(3)
    r = noisy_range(np.zeros(5000), 300.0, rng)
    assert np.all(r >= 0)
    # folded normal: E|N(0, σ)| = σ sqrt(2/π)
    assert np.mean(r) == pytest.approx(100.0 * np.sqrt(2 / np.pi), rel=0.05)
    az = noisy_azimuth(np.array([0.0, 2 * np.pi - 1e-12] * 2000), 0.3, rng)
    assert np.all((az >= 0) & (az < 2 * np.pi))
    assert measurement.wrap_azimuth(-1e-18) == 0.0  # np.mod alone rounds this to 2π


def test_reproducible_with_same_seed():
    a = measure([1e3, 2e3], [0.1, 0.2], [10.0, 100.0], 5, 150.0, 0.02, np.random.default_rng(5))
    b = measure([1e3, 2e3], [0.1, 0.2], [10.0, 100.0], 5, 150.0, 0.02, np.random.default_rng(5))
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])


@settings(max_examples=50, deadline=None)
@given(
    snr_db=st.floats(-300.0, 300.0),
    n=st.floats(1.0, 1e4),
    r=st.floats(0.0, 5e5),
    az=st.floats(-10.0, 10.0),
)
def test_property_finite_bounded_monotone(snr_db, n, r, az):
    snr = 10 ** (snr_db / 10)
    eps_r, eps_t = expected_errors(np.array([snr, 2 * snr]), n, 150.0, 0.02)
    assert np.all(np.isfinite(eps_r)) and np.all(eps_r <= 4 * 150.0) and np.all(eps_r >= 0)
    assert eps_r[1] <= eps_r[0] and eps_t[1] <= eps_t[0]  # better S/I, smaller error
    out = measure(r, az, snr, n, 150.0, 0.02, np.random.default_rng(0))
    assert out["range_m"] >= 0 and 0 <= out["azimuth_rad"] < 2 * np.pi
