"""Tests of shipradar.sensors.doppler_filters: seed [49]-[65] against closed forms and literature
values."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.linalg import toeplitz

from shipradar.sensors import doppler_filters as df

#: A stability limit high enough that the residue does not disturb the closed forms [dB].
NO_RESIDUE_DB = 150.0
EPS_150 = 10.0 ** (-NO_RESIDUE_DB / 10.0)


def explicit_quadratic_form(w, lags):
    """wᴴ M w with M(k, l) = c(k - l) built as a full matrix (second, O(N²) method)."""
    m = toeplitz(lags)  # first column c(0..N-1), first row conj(c): M(k,l) = c(k-l)
    return np.real(np.conj(w) @ m @ w)


def direct_response(w, f):
    """|Σ conj(w_n) exp(-j2π f n)|² summed directly."""
    n = np.arange(len(w))
    return np.abs(np.exp(-2j * np.pi * np.outer(f, n)) @ np.conj(w)) ** 2


def rho(spread):
    """Lag-1 clutter correlation of [56] at zero mean: exp(-2 π² σ²)."""
    return np.exp(-2.0 * (np.pi * spread) ** 2)


# ----------------------------------------------------------------------------- quadratic form
@pytest.mark.parametrize("n_taps", [1, 2, 7, 64])
def test_toeplitz_quadratic_form_matches_explicit_matrix(n_taps):
    rng = np.random.default_rng(n_taps)
    w = rng.normal(size=n_taps) + 1j * rng.normal(size=n_taps)
    for lags in (
        df.clutter_lag_covariance(n_taps, 0.07, 0.13),
        df.signal_lag_covariance(n_taps, 0.31, 0.2),
        df.signal_lag_covariance(n_taps, -2.6),
    ):
        assert df.quadratic_form_toeplitz(w, lags) == pytest.approx(
            explicit_quadratic_form(w, lags), rel=1e-10, abs=1e-12
        )


def test_point_target_response_matches_direct_sum():
    rng = np.random.default_rng(3)
    w = rng.normal(size=17) + 1j * rng.normal(size=17)
    f = np.linspace(-1.3, 2.2, 301)
    np.testing.assert_allclose(df.filter_response(w, f), direct_response(w, f), rtol=1e-10)


# ----------------------------------------------------------------------------- MTI [58]
def test_canceller_weights_are_alternating_binomials():
    np.testing.assert_array_equal(df.canceller_weights(2), [1, -1])
    np.testing.assert_array_equal(df.canceller_weights(3), [1, -2, 1])
    np.testing.assert_array_equal(df.canceller_weights(5), [1, -4, 6, -4, 1])
    with pytest.raises(ValueError):
        df.canceller_weights(1)


@pytest.mark.parametrize("n_pulses", [2, 3, 4])
def test_canceller_response_is_sine_power(n_pulses):
    # (1 - z)^n with z = exp(-j2πf): |H|² = (2 sin πf)^(2n), max at f_r/2, nulls at k f_r
    f = np.linspace(-1.0, 2.0, 61)
    expected = (2.0 * np.sin(np.pi * f)) ** (2 * (n_pulses - 1))
    got = df.filter_response(df.canceller_weights(n_pulses), f)
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12)


SPREADS = [1e-3, 1e-2, 0.05, 0.1, 0.3]
BANDS = [0.0, 0.25, 0.5, 1.0]


@pytest.mark.parametrize("spread", SPREADS)
@pytest.mark.parametrize("band", BANDS)
def test_two_pulse_canceller_closed_form(spread, band):
    # w = [1, -1]: r0 = 2, r1 = -1.  Band-averaged signal [55] at f_i = 1/2:
    #   S = 2 + 2 Re(e^{-jπ} sinc(B)) (-1) = 2 + 2 sin(πB)/(πB);  clutter [56]: C = 2 - 2ρ.
    sinc_b = 1.0 if band == 0 else math.sin(math.pi * band) / (math.pi * band)
    s = 2.0 + 2.0 * sinc_b
    c = -2.0 * np.expm1(-2.0 * (np.pi * spread) ** 2)
    expected = (s + 2.0 * EPS_150) / (c + 2.0 * EPS_150)
    got = df.improvement_factor(
        df.canceller_weights(2),
        spread,
        0.5,
        bandwidth_norm=band,
        stability_limit_db=NO_RESIDUE_DB,
    )
    assert got == pytest.approx(expected, rel=1e-6)


@pytest.mark.parametrize("spread", SPREADS)
@pytest.mark.parametrize("band", BANDS)
def test_three_pulse_canceller_closed_form(spread, band):
    # w = [1, -2, 1]: r0 = 6, r1 = -4, r2 = 1.  At f_i = 1/2:
    #   S = 6 + 8 sinc(B) + 2 sinc(2B);  C = 6 - 8ρ + 2ρ⁴ = -8(ρ-1) + 2(ρ⁴-1).
    def sinc(x):
        return 1.0 if x == 0 else math.sin(math.pi * x) / (math.pi * x)

    s = 6.0 + 8.0 * sinc(band) + 2.0 * sinc(2.0 * band)
    x = 2.0 * (np.pi * spread) ** 2
    c = -8.0 * np.expm1(-x) + 2.0 * np.expm1(-4.0 * x)
    expected = (s + 6.0 * EPS_150) / (c + 6.0 * EPS_150)
    got = df.improvement_factor(
        df.canceller_weights(3),
        spread,
        0.5,
        bandwidth_norm=band,
        stability_limit_db=NO_RESIDUE_DB,
    )
    # the lag sum 6 - 8ρ + 2ρ⁴ loses ~1e-16 * 6 / C of relative precision: 1e-7 at σ = 1e-3
    assert got == pytest.approx(expected, rel=1e-6)


@pytest.mark.parametrize("spread", [1e-3, 3e-3, 1e-2])
def test_canceller_small_spread_approximations(spread):
    # Nathanson / Skolnik: I_2 ≈ 2 (f_r / 2πσ)², I_3 ≈ 2 (f_r / 2πσ)⁴ for the Doppler-averaged
    # signal (B = f_r).  The neglected terms are O(2π²σ²) < 0.2 % (I_2) and < 0.6 % (I_3)
    # at σ/f_r = 0.01; a 1 % tolerance holds both.
    i2 = df.improvement_factor(
        df.canceller_weights(2), spread, 0.5, bandwidth_norm=1.0, stability_limit_db=150.0
    )
    i3 = df.improvement_factor(
        df.canceller_weights(3), spread, 0.5, bandwidth_norm=1.0, stability_limit_db=150.0
    )
    assert i2 == pytest.approx(2.0 / (2.0 * np.pi * spread) ** 2, rel=0.01)
    assert i3 == pytest.approx(2.0 / (2.0 * np.pi * spread) ** 4, rel=0.01)


@pytest.mark.parametrize("n_pulses", [2, 3, 5])
def test_doppler_average_of_point_target_equals_full_band(n_pulses):
    # Parseval: the mean of |H(f)|² over one PRF is Σ|w|² = wᴴ M_s w with B = 1.  The
    # rectangle rule on K > N equally spaced points is exact for this trigonometric polynomial.
    w = df.canceller_weights(n_pulses)
    f = np.arange(64) / 64
    spreads = np.array([1e-4, 0.01, 0.2])
    point = df.improvement_factor(w, spreads[:, None], f[None, :])
    band = df.improvement_factor(w, spreads, 0.5, bandwidth_norm=1.0)
    np.testing.assert_allclose(point.mean(axis=1), band, rtol=1e-10)


# ----------------------------------------------------------------------------- stability
@pytest.mark.parametrize("n_pulses", [2, 3, 5, 8])
@pytest.mark.parametrize("limit_db", [40.0, df.DEFAULT_STABILITY_LIMIT_DB, 150.0])
def test_mti_tends_to_stability_limit_as_spread_vanishes(n_pulses, limit_db):
    # Doppler-averaged MTI: S = (1 + ε)E, C -> εE, so I_F -> (1 + ε)/ε, i.e. the limit.
    w = df.canceller_weights(n_pulses)
    # at σ = 1e-12 even the 2-pulse canceller's clutter limit, 2/(2πσ)² = 5e22, is far above
    # the stability limit, so the limit alone should remain
    spreads = np.array([0.0, 1e-15, 1e-12])
    i_f = df.improvement_factor(w, spreads, 0.5, bandwidth_norm=1.0, stability_limit_db=limit_db)
    eps = 10.0 ** (-limit_db / 10.0)
    assert np.all(np.isfinite(i_f))
    np.testing.assert_allclose(i_f, (1.0 + eps) / eps, rtol=1e-6)
    # and the improvement factor does not rise as the clutter widens (a lag sum near the
    # singular covariance would jitter here by up to 1e-3 at 150 dB; the quadrature does not)
    sweep = df.improvement_factor(
        w, np.logspace(-9, 1, 200), 0.5, bandwidth_norm=1.0, stability_limit_db=limit_db
    )
    assert np.all(np.diff(sweep) <= 1e-12 * sweep[:-1])


def test_clutter_power_branches_agree_at_the_switch():
    # quadrature below σ (N-1) = NARROW_SPREAD_TAPS, lag sum above: both against the matrix
    n = 16
    bank = df.bank_weights(n, window="hann")
    threshold = df.NARROW_SPREAD_TAPS / (n - 1)
    for spread in (threshold * (1 - 1e-9), threshold * (1 + 1e-9)):
        for mean in (0.0, 0.1):
            lags = df.clutter_lag_covariance(n, spread, mean)
            expected = np.array([explicit_quadratic_form(w, lags) for w in bank])
            got = df.clutter_output_power(bank, spread, mean)
            # where the output is well above the matrix method's own rounding (~1e-16 N E)
            energy = np.sum(np.abs(bank) ** 2, axis=1)
            sure = expected > 1e-3 * energy
            assert sure.sum() >= 2
            np.testing.assert_allclose(got[sure], expected[sure], rtol=1e-10)


def test_stability_residue_combines_like_independent_limits():
    # 1/I ≈ 1/I_clutter + 1/I_stability (Skolnik): exact form for the 2-pulse canceller is
    # (1 + ε)/(1 - ρ + ε).
    limit_db, spread = 40.0, 0.003
    eps = 1e-4
    expected = (1.0 + eps) / (-np.expm1(-2.0 * (np.pi * spread) ** 2) + eps)
    got = df.improvement_factor(
        df.canceller_weights(2), spread, 0.5, bandwidth_norm=1.0, stability_limit_db=limit_db
    )
    assert got == pytest.approx(expected, rel=1e-9)
    i_clutter = 2.0 / (2.0 * np.pi * spread) ** 2
    assert 1.0 / got == pytest.approx(1.0 / i_clutter + eps, rel=0.01)


def test_target_on_the_clutter_spectrum_gets_unit_improvement():
    # σ -> 0 and f_d = μ_c: signal and clutter covariances are equal, so I_F = 1 for any filter
    for w in (df.canceller_weights(3), df.bank_weights(16, window="hann")[3]):
        for mu in (0.0, 0.37):
            got = df.improvement_factor(w, 0.0, mu, clutter_mean_norm=mu)
            assert got == pytest.approx(1.0, rel=1e-9)


def test_blind_speed_is_finite_and_tiny():
    # at a blind speed only the residue passes: I_F = εE / (C + εE), C = 6 - 8ρ + 2ρ⁴
    w = df.canceller_weights(3)
    eps = 10.0 ** (-df.DEFAULT_STABILITY_LIMIT_DB / 10.0)
    for spread in (0.01, 0.05, 0.3):
        x = 2.0 * (np.pi * spread) ** 2
        c = -8.0 * np.expm1(-x) + 2.0 * np.expm1(-4.0 * x)
        got = df.improvement_factor(w, spread, np.array([0.0, 1.0, -2.0, 7.0]))
        assert np.all(np.isfinite(got)) and np.all(got > 0)
        np.testing.assert_allclose(got, 6.0 * eps / (c + 6.0 * eps), rtol=1e-6)


@pytest.mark.parametrize("n_taps", [64, 256])
def test_long_cascade_is_finite_and_matches_explicit_matrix(n_taps):
    bank = df.bank_weights(n_taps, 8, window="chebyshev", sidelobe_db=100.0)
    w = df.cascade_weights(df.canceller_weights(4), bank)
    spreads = np.array([0.0, 1e-12, 1e-6, 1e-3, 0.05, 0.5, 10.0, np.inf])
    f = np.linspace(0, 1, 33)
    i_f = df.improvement_factor(w, spreads[:, None], f[None, :])
    assert i_f.shape == (8, len(spreads), len(f))
    assert np.all(np.isfinite(i_f)) and np.all(i_f > 0)
    if n_taps == 64:
        # second method: the full O(N²) matrices of [55]-[57], with the residue
        eps = 10.0 ** (-df.DEFAULT_STABILITY_LIMIT_DB / 10.0)
        k = w.shape[-1]
        # (at points where both powers are far above the matrix method's rounding floor,
        # ~1e-16 N E: here the signal sits in the passband and the clutter is wide)
        for filt in (2, 3):
            ww = w[filt]
            energy = np.sum(np.abs(ww) ** 2)
            for spread in (0.2, 0.5):
                c = explicit_quadratic_form(ww, df.clutter_lag_covariance(k, spread))
                for fd in (filt / 8, filt / 8 + 0.01):
                    s = explicit_quadratic_form(ww, df.signal_lag_covariance(k, fd))
                    got = df.improvement_factor(ww, spread, fd)
                    assert got == pytest.approx((s + eps * energy) / (c + eps * energy), rel=1e-8)


def test_stability_limit_out_of_range_raises():
    for bad in (0.0, -3.0, df.MAX_STABILITY_LIMIT_DB + 1.0):
        with pytest.raises(ValueError):
            df.improvement_factor([1, -1], 0.1, 0.5, stability_limit_db=bad)
    with pytest.raises(ValueError):
        df.improvement_factor([1, -1], -0.1, 0.5)


# ----------------------------------------------------------------------------- banks [59]-[62]
@pytest.mark.parametrize("n", [4, 16, 64])
def test_dft_bank_against_white_noise_has_coherent_gain_n(n):
    # "no clutter spread" read as the issue means it: a point target (no Doppler spread of its
    # own, B = 0 in [55]) at a filter centre against white interference gets the coherent gain
    # N.  (Against zero-spread *clutter* at DC, filter k != 0 of a rectangular DFT bank has an
    # exact null there and only the stability limit bounds I_F: see the stability tests.)
    bank = df.bank_weights(n)
    centres = df.filter_centres_norm(n)
    eps = 10.0 ** (-df.DEFAULT_STABILITY_LIMIT_DB / 10.0)
    # M_c = I explicitly ...
    identity = np.zeros(n)
    identity[0] = 1.0
    np.testing.assert_allclose(df.quadratic_form_toeplitz(bank, identity), n, rtol=1e-12)
    # ... and as the white limit of [56] (a spread much wider than the PRF)
    for white in (10.0, np.inf):
        i_f = df.improvement_factor(bank, white, centres)  # (filter, target)
        np.testing.assert_allclose(np.diag(i_f), (n + eps) / (1.0 + eps), rtol=1e-12)
        picked = df.bank_improvement_factor(bank, white, centres)
        np.testing.assert_allclose(picked, n, rtol=1e-9)


@pytest.mark.parametrize(
    ("window", "harris_scalloping_db"),
    # Harris, Proc. IEEE 66(1), 1978, Table I (DFT-even windows; ours are symmetric, which
    # differs by O(1/N): 0.1 dB at N = 64)
    [("rectangular", 3.92), ("hann", 1.42), ("hamming", 1.78)],
)
def test_scalloping_loss_between_dft_filters(window, harris_scalloping_db):
    n = 64
    bank = df.bank_weights(n, window=window)
    mid = (np.arange(n) + 0.5) / n
    gain_centre = df.bank_improvement_factor(bank, np.inf, df.filter_centres_norm(n))
    gain_mid = df.bank_improvement_factor(bank, np.inf, mid)
    loss_db = 10 * np.log10(gain_centre / gain_mid)
    np.testing.assert_allclose(loss_db, harris_scalloping_db, atol=0.1)


def peak_sidelobe_db(weights):
    """Peak sidelobe of a filter's power response, relative to its mainlobe [dB].

    The response on [0, 1/2] at 2^-18 resolution by a zero-padded FFT (the same sum as
    :func:`shipradar.sensors.doppler_filters.filter_response`, |Σ conj(w_n) e^{-j2πfn}|², evaluated
    on a grid; checked against it at a few points).
    """
    n_fft = 2**18
    h = np.abs(np.fft.fft(np.conj(weights), n_fft)[: n_fft // 2 + 1]) ** 2
    f = np.arange(h.size) / n_fft
    probe = np.array([0, 1234, 56789])
    np.testing.assert_allclose(h[probe], df.filter_response(weights, f[probe]), rtol=1e-9,
                               atol=1e-12 * h[0])
    h_db = 10 * np.log10(np.maximum(h / h[0], 1e-30))
    first_null = np.argmax(np.diff(h_db) > 0)  # first local minimum past the mainlobe
    return h_db[first_null:].max()


@pytest.mark.parametrize(
    ("window", "kwargs", "expected_db", "tol_db"),
    [
        # Harris 1978 Table I: highest sidelobe (rounded to 1 dB there)
        ("rectangular", {}, -13.26, 0.05),
        ("hann", {}, -31.5, 0.5),
        ("hamming", {}, -42.7, 1.0),
        # Dolph-Chebyshev: equiripple at exactly its design level
        ("chebyshev", {"sidelobe_db": 50.0}, -50.0, 0.01),
        ("chebyshev", {"sidelobe_db": 90.0}, -90.0, 0.01),
        # Taylor: the first nbar-1 sidelobes sit near sll
        ("taylor", {"sidelobe_db": 35.0, "nbar": 5}, -35.0, 0.5),
        ("taylor", {}, -df.DEFAULT_TAYLOR_SIDELOBE_DB, 0.5),
    ],
)
def test_window_sidelobe_levels_of_bank_filters(window, kwargs, expected_db, tol_db):
    bank = df.bank_weights(64, 4, window=window, **kwargs)
    for i, centre in enumerate(df.filter_centres_norm(4)):
        # the filter of centre f_i is the window shifted to f_i: measure it re-centred at 0
        shifted = bank[i] * np.exp(2j * np.pi * centre * np.arange(64))
        assert peak_sidelobe_db(shifted) == pytest.approx(expected_db, abs=tol_db)
        assert df.filter_response(bank[i], centre) == pytest.approx(
            np.sum(np.abs(bank[i])) ** 2, rel=1e-10
        )


def test_window_errors():
    with pytest.raises(ValueError):
        df.window_weights("chebyshev", 16)
    with pytest.raises(ValueError):
        df.window_weights("kaiser", 16)


# ----------------------------------------------------------------------------- cascade [61]
def test_cascade_is_the_corrected_matrix_of_61_and_multiplies_responses():
    a = df.canceller_weights(3)
    bank = df.bank_weights(12, window="hamming")
    w = df.cascade_weights(a, bank)
    m, nb = len(a), bank.shape[1]
    assert w.shape == (12, m + nb - 1)
    # [61] with consistent dimensions: a banded (M + N_b - 1) x N_b matrix of the a's times b
    band = np.zeros((m + nb - 1, nb))
    for col in range(nb):
        band[col : col + m, col] = a
    np.testing.assert_allclose(w, (band @ bank.T).T, rtol=1e-13, atol=1e-13)
    f = np.linspace(0, 1, 97)
    np.testing.assert_allclose(
        df.filter_response(w, f),
        df.filter_response(a, f) * df.filter_response(bank, f),
        rtol=1e-8,
        atol=1e-9,
    )


# ----------------------------------------------------------------------------- pick rule
def test_response_pick_reads_the_filter_holding_the_doppler():
    n = 16
    bank = df.bank_weights(n, window="hann")
    f = np.array([0.02, 0.2, 0.33, 0.61, 0.97])
    idx = df.doppler_filter_index(f * 1000.0, 1000.0, n)
    got = df.bank_improvement_factor(bank, 0.01, f)
    direct = df.improvement_factor(bank[idx], 0.01, f)[np.arange(len(f)), np.arange(len(f))]
    np.testing.assert_allclose(got, direct, rtol=1e-12)
    best = df.bank_improvement_factor(bank, 0.01, f, pick="best")
    assert np.all(best >= got * (1 - 1e-12))
    with pytest.raises(ValueError):
        df.bank_improvement_factor(bank, 0.01, f, pick="nearest")


def test_fig7_five_hann_filters_peak_at_centres_and_dip_between():
    # seed Fig. 7: five FIR filters of 32 Hann taps, centres 0, 0.2, ..., 0.8
    bank = df.bank_weights(32, 5, window="hann")
    f = np.linspace(0.0, 1.0, 4001)
    for spread in (0.001, 0.01, 0.03):
        i_db = 10 * np.log10(df.bank_improvement_factor(bank, spread, f))
        for lo in (0.2, 0.4, 0.6):  # the gaps away from the clutter filter at 0
            hi = lo + 0.2
            centre_lo = i_db[np.argmin(abs(f - lo))]
            centre_hi = i_db[np.argmin(abs(f - hi))]
            # maxima at the centres: the largest values within ±0.05 of each centre
            for c, val in ((lo, centre_lo), (hi, centre_hi)):
                near = np.abs(f - c) <= 0.05
                assert val == pytest.approx(i_db[near].max(), abs=0.01)
            # a dip midway: deep below both centres, and the gap's minimum between the lobes
            mid = i_db[np.argmin(abs(f - (lo + 0.1)))]
            assert mid < min(centre_lo, centre_hi) - 20.0
            gap = (f > lo + 0.03) & (f < hi - 0.03)
            assert i_db[gap].min() < min(centre_lo, centre_hi) - 20.0
            inner = (f > lo) & (f < hi)
            f_min = f[inner][np.argmin(i_db[inner])]
            assert lo + 0.03 < f_min < hi - 0.03


def test_fig7_png(tmp_path):
    from shipradar.sim.studies.figures.doppler import plot_improvement_vs_doppler

    out = plot_improvement_vs_doppler(tmp_path / "fig7.png", n_points=401)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# ----------------------------------------------------------------------------- stagger 5.1.4
@pytest.mark.parametrize(
    "weights",
    [df.canceller_weights(3), df.bank_weights(16, window="hamming")],
    ids=["mti3", "bank16"],
)
def test_staggered_prf_lies_between_its_bounds(weights):
    prf, stagger = 1000.0, [900.0, 1000.0, 1100.0]
    spread = np.array([1e-3, 0.02, 0.1])[:, None]
    f = np.linspace(0.0, 10.0, 1001)[None, :]
    got = df.staggered_improvement_factor(weights, spread, f, prf_hz=prf, stagger_prf_hz=stagger)
    lo = df.bank_improvement_factor(weights, spread * prf / 900.0, f * prf / 900.0)
    hi = df.bank_improvement_factor(weights, spread * prf / 1100.0, f * prf / 1100.0)
    assert np.all(got >= np.minimum(lo, hi) * (1 - 1e-12))
    assert np.all(got <= np.maximum(lo, hi) * (1 + 1e-12))
    # a constant PRF "stagger" is the constant-PRF model
    same = df.staggered_improvement_factor(weights, spread, f, prf_hz=prf, stagger_prf_hz=[prf])
    np.testing.assert_allclose(same, df.bank_improvement_factor(weights, spread, f), rtol=1e-12)


def test_staggered_prf_fills_the_first_blind_speed():
    w = df.canceller_weights(3)
    constant = df.bank_improvement_factor(w, 0.01, 1.0)
    stagger = df.staggered_improvement_factor(
        w, 0.01, 1.0, prf_hz=1000.0, stagger_prf_hz=[900.0, 1100.0]
    )
    # the 1000 Hz PRF is blind at 1000 Hz (only the residue passes); 900 and 1100 Hz are not
    assert constant < 1e-4 and stagger > 100.0


# ----------------------------------------------------------------------------- separation
def test_doppler_filter_index_folds_and_rounds_to_nearest_centre():
    prf, n = 1000.0, 10
    fd = np.array([0.0, 49.0, 51.0, -51.0, 999.0, 450.0])
    np.testing.assert_array_equal(df.doppler_filter_index(fd, prf, n), [0, 0, 1, 9, 0, 5])
    for k in (-3, 1, 7):
        np.testing.assert_array_equal(
            df.doppler_filter_index(fd + k * prf, prf, n), df.doppler_filter_index(fd, prf, n)
        )
    # MTI only: one filter, targets never separated
    assert np.all(df.doppler_filter_index(fd, prf, 1) == 0)
    with pytest.raises(ValueError):
        df.doppler_filter_index(np.nan, prf, n)


# ----------------------------------------------------------------------------- [63]-[65]
def ld0_db(d_db):
    """[64] written out, clamped at 0 dB."""
    return max(15.0 * (1.0 - math.exp(-d_db / 8.45)) - 5.0, 0.0)


@pytest.mark.parametrize("d_db", [4.0, 8.45, 12.0, 30.0])
def test_distribution_loss_flat_below_20_db_and_decaying_above(d_db):
    below = df.distribution_loss_db(np.array([-5.0, 0.0, 10.0, 19.99]), d_db)
    np.testing.assert_allclose(below, ld0_db(d_db), rtol=1e-12)
    assert ld0_db(8.45) == pytest.approx(15.0 * (1.0 - math.exp(-1.0)) - 5.0, rel=1e-12)
    # continuous at the knee, e^-1 of L_d0 ten dB above it, monotone decreasing, -> 0
    assert df.distribution_loss_db(20.0, d_db) == pytest.approx(ld0_db(d_db), rel=1e-12)
    assert df.distribution_loss_db(30.0, d_db) == pytest.approx(ld0_db(d_db) / math.e, rel=1e-12)
    above = df.distribution_loss_db(np.linspace(20.0, 80.0, 61), d_db)
    assert np.all(np.diff(above) < 0)
    assert above[-1] < 1e-12


def test_distribution_loss_edges():
    # [64] is negative below d = 8.45 ln 1.5: clamped at 0 dB (Rayleigh: d = -10 log10 ln 2)
    rayleigh_d_db = -10 * math.log10(math.log(2.0))
    edge = 8.45 * math.log(1.5)
    got = df.distribution_loss_db(10.0, np.array([0.0, rayleigh_d_db, edge, edge + 0.5]))
    np.testing.assert_allclose(got[:3], 0.0, atol=1e-12)
    assert got[3] > 0
    # saturates at 15 - 5 = 10 dB for very skewed clutter
    assert df.distribution_loss_db(0.0, 1e4) == pytest.approx(10.0, rel=1e-12)
    # only where sea clutter dominates and the resolution is medium-to-high
    np.testing.assert_array_equal(
        df.distribution_loss_db(10.0, 12.0, applies=np.array([False, True])) > 0, [False, True]
    )
    with pytest.raises(ValueError):
        df.distribution_loss_db(10.0, -1.0)


def test_processing_gain_linear_and_db_agree():
    i_db = np.array([0.0, 15.0, 25.0, 60.0])
    l_db = df.distribution_loss_db(i_db, 12.0)
    gp_db = df.processing_gain_db(i_db, l_db)
    gp = df.processing_gain(10 ** (i_db / 10), 10 ** (l_db / 10))
    np.testing.assert_allclose(10 * np.log10(gp), gp_db, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(df.processing_gain_db(i_db), i_db)


# ----------------------------------------------------------------------------- properties
complex_weights = st.integers(1, 48).flatmap(
    lambda n: st.lists(
        st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3)), min_size=n, max_size=n
    ).filter(lambda t: sum(a * a + b * b for a, b in t) > 1e-6)
)


@settings(max_examples=60, deadline=None)
@given(
    taps=complex_weights,
    spread=st.one_of(st.just(0.0), st.floats(0.0, 5.0), st.floats(1e-12, 1e-3)),
    doppler=st.floats(-50.0, 50.0),
    band=st.floats(0.0, 1.0),
    mean=st.floats(-1.0, 1.0),
    limit_db=st.floats(1.0, 150.0),
)
def test_improvement_factor_is_finite_positive_bounded_and_periodic(
    taps, spread, doppler, band, mean, limit_db
):
    w = np.array([complex(a, b) for a, b in taps])
    n = len(w)
    kw = dict(bandwidth_norm=band, clutter_mean_norm=mean, stability_limit_db=limit_db)
    i_f = df.improvement_factor(w, spread, doppler, **kw)
    eps = 10.0 ** (-limit_db / 10.0)
    assert np.isfinite(i_f) and i_f > 0
    # Rayleigh-quotient bounds: eigenvalues of M_s, M_c lie in [0, N], plus the residue ε
    assert eps / (n + eps) * (1 - 1e-9) <= i_f <= (n + eps) / eps * (1 + 1e-9)
    shifted = df.improvement_factor(w, spread, doppler + 3.0, **kw)
    assert shifted == pytest.approx(i_f, rel=1e-6)


def test_stagger_average_is_linear_where_one_bound_is_blind():
    # at 9000 Hz the 900 Hz PRF is blind, the 1100 Hz one is not: the linear average is half
    # the 1100 Hz value (-3 dB), where a dB average would sit tens of dB lower
    w = df.canceller_weights(3)
    high = df.bank_improvement_factor(w, 0.01 * 1000 / 1100, 9.0 * 1000 / 1100)
    stagger = df.staggered_improvement_factor(
        w, 0.01, 9.0, prf_hz=1000.0, stagger_prf_hz=[900.0, 1100.0]
    )
    assert stagger == pytest.approx(high / 2, rel=1e-6)
