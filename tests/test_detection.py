"""Tests of shipradar.sensors.detection: P_fa [68]-[72], N_e [73]-[77], P_d exact and seed
[78]-[83]."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, special, stats

from shipradar.sensors import detection
from shipradar.sensors.detection import (
    effective_pulses,
    pfa_from_false_alarm_time,
    probability_of_detection,
    pulses_per_beam,
    range_cells,
    required_snr_db,
    sweep_time,
)

PD_LIT = 0.9
PFA_LIT = 1e-6


def _db(x):
    return 10.0 * np.log10(x)


# ----------------------------------------------------------------------------- references
def marcum_q1_quad(a: float, b: float) -> float:
    """Marcum Q_1(a, b) by quadrature of the Rice density (independent of scipy's ncx2)."""

    def rice(x):
        # x exp(-(x²+a²)/2) I0(ax), with i0e for range: I0(ax) = i0e(ax) e^{ax}
        return x * np.exp(-0.5 * (x - a) ** 2) * special.i0e(a * x)

    val, _ = integrate.quad(rice, b, np.inf, epsabs=0, epsrel=1e-12, limit=200)
    return val


def chi_square_family_pd(snr_db, pfa, n, swerling):
    """P_d as the Poisson / negative-binomial mixture of Gamma(N + j) tails, summed term by
    term: the chi-square family of Table III (K = inf, 1, N, 2, 2N), Shnidman (1999,
    IEEE AES 35(3)) eq. 2 form.  Independent of the closed forms in the module."""
    s = 10 ** (snr_db / 10)
    t = special.gammainccinv(n, pfa)
    k = {0: np.inf, 1: 1.0, 2: n, 3: 2.0, 4: 2.0 * n}[swerling]
    mean = n * s
    sd = np.sqrt(mean) if np.isinf(k) else np.sqrt(mean * (1 + mean / k))
    j = np.arange(0, int(mean + 40 * sd + 200))
    w = stats.poisson.pmf(j, mean) if np.isinf(k) else stats.nbinom.pmf(j, k, k / (k + mean))
    return float(np.sum(w * special.gammaincc(n + j, t)))


def albersheim_db(pd, pfa, n):
    """Albersheim (1981, Proc. IEEE 69(2) p. 165) required S/N per pulse [dB]; stated error
    < 0.2 dB for 0.1 <= Pd <= 0.9, 1e-7 <= Pfa <= 1e-3, 1 <= N <= 8096 (linear detector)."""
    a = np.log(0.62 / pfa)
    b = np.log(pd / (1 - pd))
    return -5 * np.log10(n) + (6.2 + 4.54 / np.sqrt(n + 0.44)) * np.log10(
        a + 0.12 * a * b + 1.7 * b
    )


# ----------------------------------------------------------------------------- [68]-[73]
def test_pfa_from_false_alarm_time_hand_computation():
    # θ_b = 1.5°, 2 s scan, f_r = 1 kHz, τ' = 1 µs, t_fa = 100 s, N_ch = 2
    theta = np.deg2rad(1.5)
    t_swp = theta / (2 * np.pi) * 2.0  # 8.333e-3 s
    n_rc = 1 / (1e3 * 1e-6) - 2  # 998
    n_prime = 2 * n_rc * 100.0 / t_swp
    assert t_swp == pytest.approx(1.5 / 360 * 2.0, rel=1e-12)
    assert float(sweep_time(theta, 2.0)) == pytest.approx(t_swp, rel=1e-12)
    assert float(range_cells(1e3, 1e-6)) == pytest.approx(998.0, rel=1e-12)
    assert float(pulses_per_beam(theta, 2.0, 1e3)) == pytest.approx(1000 * t_swp, rel=1e-12)
    # t_fa the mean time between false alarms: one per t_fa, P_fa = 1/n' (issue 23 item 5a;
    # the seed's [68] has 0.69/n', kept as t_fa_definition="median")
    pfa = float(pfa_from_false_alarm_time(100.0, theta, 2.0, 1e3, 1e-6))
    assert pfa == pytest.approx(1.0 / n_prime, rel=1e-12)
    assert pfa == pytest.approx(4.1750e-8, rel=1e-4)  # 1 / (2*998*100/8.3333e-3), by hand
    seed = float(pfa_from_false_alarm_time(100.0, theta, 2.0, 1e3, 1e-6,
                                           t_fa_definition="median"))
    assert seed == pytest.approx(2.8808e-8, rel=1e-4)  # 0.69 / n', the seed's letter
    assert detection.N_CHANNELS == 2 and detection.LN2_SEED == pytest.approx(np.log(2), abs=0.01)
    # R_inst = 60 km inside c/(2 f_r) = 149.9 km: n_0 counts the 300.2 gates within it
    c_r = 299_792_458.0 * 1e-6 / 2
    inside = float(pfa_from_false_alarm_time(100.0, theta, 2.0, 1e3, 1e-6,
                                             instrumented_range_m=60e3))
    assert inside == pytest.approx(t_swp / (2 * (60e3 / c_r) * 100.0), rel=1e-12)
    assert float(pfa_from_false_alarm_time(100.0, theta, 2.0, 1e3, 1e-6,
                                           instrumented_range_m=200e3)) == pfa
    with pytest.raises(ValueError, match="t_fa_definition"):
        pfa_from_false_alarm_time(100.0, theta, 2.0, 1e3, 1e-6, t_fa_definition="marcum")


def test_pfa_vectorized_over_t_fa():
    t_fa = np.array([1.0, 10.0, 100.0])
    pfa = pfa_from_false_alarm_time(t_fa, 0.02, 4.0, 2e3, 0.5e-6)
    assert pfa.shape == (3,)
    np.testing.assert_allclose(pfa[0] / pfa, t_fa, rtol=1e-12)


@pytest.mark.parametrize("prf, tau", [(1e4, 50e-6), (1e4, 60e-6), (2e3, 1e-3)])
def test_range_cells_nonpositive_raises(prf, tau):
    # f_r τ' >= 1/2: N_rc <= 0 (SPEC §4 item 14)
    with pytest.raises(ValueError, match="N_rc"):
        range_cells(prf, tau)
    with pytest.raises(ValueError, match="N_rc"):
        pfa_from_false_alarm_time(60.0, 0.02, 2.0, prf, tau)


def test_range_cells_just_inside_edge():
    assert float(range_cells(1e4, 49.9e-6)) > 0


def test_pfa_not_below_one_raises():
    # tiny t_fa: n' < 0.69 → P_fa >= 1
    with pytest.raises(ValueError, match=r"P_fa .*\(0, 1\)"):
        pfa_from_false_alarm_time(1e-9, 0.02, 2.0, 1e3, 0.4e-3)
    with pytest.raises(ValueError, match="t_fa_s"):
        pfa_from_false_alarm_time(0.0, 0.02, 2.0, 1e3, 1e-6)


# ----------------------------------------------------------------------------- [74]-[77]
def test_effective_pulses_noise_dominated_is_n_n():
    n = effective_pulses(np.array([0.2, 3.7, 40.0]), clutter_dominated=False, mti_order=3)
    np.testing.assert_allclose(n, [1.0, 3.7, 40.0])


def test_effective_pulses_clutter_branches():
    common = dict(
        clutter_dominated=True,
        wavelength_m=0.05,
        prf_hz=1000.0,
        beamwidth_rad=0.02,
        rotation_rate_rad_s=np.pi,
    )
    # correlated clutter: N_n' = floor(1 + 5 σ θ_b/(λ ω)) = floor(1 + 5*2*0.02/(0.05π)) = 2
    assert float(effective_pulses(20.0, clutter_velocity_spread_mps=2.0, **common)) == 2.0
    # σ/(λ f_r) = 20/50 = 0.4 ≥ 0.2: decorrelated, N_n' = floor(N_n)
    assert float(effective_pulses(20.5, clutter_velocity_spread_mps=20.0, **common)) == 20.0
    # frequency agility every 4 pulses [75]
    assert float(
        effective_pulses(20.0, clutter_velocity_spread_mps=2.0, pulses_per_frequency=4, **common)
    ) == pytest.approx(5.0)
    # 2-pulse MTI after full agility [76]: 20 / (1 + 1.06)
    assert float(
        effective_pulses(20.0, pulses_per_frequency=1, mti_order=2, **common)
    ) == pytest.approx(20.0 / 2.06)
    # filter bank of 8 [77]
    assert float(effective_pulses(20.0, n_coherent=8, **common)) == pytest.approx(2.5)
    # long time on target: 1 + 5*1*0.02/(0.05*0.01) = 201 → capped at N_n = 30
    slow = dict(common, rotation_rate_rad_s=0.01)
    assert float(effective_pulses(30.0, clutter_velocity_spread_mps=1.0, **slow)) == 30.0


def test_effective_pulses_mti_feeding_a_bank_limits_and_hand_value():
    """[76]/[77] cascade (issue 23 item 5b): (N_n - N_pc) / (N_b (1 + 0.53 N_pc / N_b²)),
    N_b = N_c - N_pc the bank's taps."""
    common = dict(clutter_dominated=True, wavelength_m=0.05, prf_hz=1000.0,
                  beamwidth_rad=0.02, rotation_rate_rad_s=np.pi, pulses_per_frequency=1)
    n_n = 25.0
    # N_pc = 0: [77] exactly
    for n_c in (2, 8, 16):
        assert float(effective_pulses(n_n, mti_order=0, n_coherent=n_c, **common)) == \
            pytest.approx(n_n / n_c, rel=1e-12)
    # a one-tap bank (N_c = N_pc + 1): [76] on the canceller's N_n - N_pc outputs, i.e. [76]
    # with decorrelated pulses (N_fc = 1: N_e' = N_n) less the N_pc fill pulses
    for n_pc in (1, 2, 4):
        mti_alone = float(effective_pulses(n_n, mti_order=n_pc, **common))
        assert mti_alone == pytest.approx(n_n / (1 + 0.53 * n_pc), rel=1e-12)  # [76]
        cascade = float(effective_pulses(n_n, mti_order=n_pc, n_coherent=n_pc + 1, **common))
        assert cascade == pytest.approx(mti_alone * (n_n - n_pc) / n_n, rel=1e-12)
    # by hand, the shipped Giraffe mti_bank: N_n = 25, N_pc = 1, N_c = 8 (7 bank taps):
    # 24 / (7 (1 + 0.53/49)) = 24 / 7.075714 = 3.39188 (the old [77] alone: 25/8 = 3.125)
    assert float(effective_pulses(n_n, mti_order=1, n_coherent=8, **common)) == \
        pytest.approx(3.39188, rel=1e-5)
    # noise dominated: the filters are off, N_n [73]
    assert float(effective_pulses(n_n, clutter_dominated=False, mti_order=1, n_coherent=8)) \
        == n_n
    # a bank with no tap left after the canceller is refused (the schema refuses it first)
    with pytest.raises(ValueError, match="n_coherent > mti_order"):
        effective_pulses(n_n, mti_order=3, n_coherent=3, **common)
    # never below 1, even with fewer pulses than the canceller's fill
    assert float(effective_pulses(1.5, mti_order=2, n_coherent=4, **common)) == 1.0


def _block_correlation_factor(n_pc: int, n_taps: int, window: str) -> float:
    """1 + Σ_{m≠0} |ρ(m)|² of the cascade's outputs N_b pulses apart, white input, averaged
    over the bank's filters: the exact counterpart of 1 + 0.53 N_pc / N_b² (Trunk's
    square-law reasoning behind [76], at the bank's stride)."""
    from shipradar.sensors import doppler_filters as df

    a = df.canceller_weights(n_pc + 1)
    out = []
    for b in df.bank_weights(n_taps, window=window):
        h = np.convolve(a, b)
        var = np.sum(np.abs(h) ** 2)
        s = 0.0
        for m in range(1, h.size // n_taps + 1):
            shift = m * n_taps
            if shift < h.size:
                s += 2.0 * abs(np.sum(h[shift:] * np.conj(h[: h.size - shift])) / var) ** 2
        out.append(1.0 + s)
    return float(np.mean(out))


@pytest.mark.parametrize("window", ["hann", "hamming"])
@pytest.mark.parametrize("n_pc", [1, 2, 3, 6])
@pytest.mark.parametrize("n_taps", [3, 4, 7, 8, 16])
def test_cascade_block_correlation_against_the_cascade_weights(window, n_pc, n_taps):
    """The interpolated loss 1 + 0.53 N_pc / N_b² is within 25 % of the exact block
    correlation of the cascade's own weights (both near 1 for tapered banks); at N_b = 1
    the exact value is Trunk's, which [76]'s 0.53 fits."""
    exact = _block_correlation_factor(n_pc, n_taps, window)
    fit = 1.0 + 0.53 * n_pc / n_taps**2
    assert 1.0 <= exact < 1.2
    assert fit == pytest.approx(exact, rel=0.25)


def test_cascade_stride_one_is_trunks_mti_correlation():
    """At a stride of one pulse the cascade's outputs are the canceller's, whose factor
    1 + Σ|ρ|² is 1.5, 1.944, 2.31 for N_pc = 1, 2, 3: [76]'s fit gives 1.53, 2.06, 2.59."""
    from shipradar.sensors import doppler_filters as df

    for n_pc, exact in ((1, 1.5), (2, 1.9444), (3, 2.31)):
        a = df.canceller_weights(n_pc + 1)
        rho = np.correlate(a, a, "full") / np.sum(a**2)
        assert float(np.sum(rho**2)) == pytest.approx(exact, rel=1e-4)
        assert 1 + 0.53 * n_pc == pytest.approx(exact, rel=0.13)


X_BAND = dict(clutter_dominated=True, wavelength_m=0.03, prf_hz=1000.0,
              beamwidth_rad=np.radians(1.5), rotation_rate_rad_s=2 * np.pi * 30 / 60)


def test_effective_pulses_74_hand_values_in_the_seeds_own_units():
    """[74] as printed, θ_b = 1.5° and f_rot = 30 rpm: 5 σ θ_b / (6 λ f_rot) with σ = 2 m/s,
    λ = 3 cm is 5*2*1.5/(6*0.03*30) = 2.78, so N_n' = [3.78] = 3 (the code's SI time on
    target θ_b/ω = 8.33 ms must give the same); σ = 8 m/s is decorrelated (8/(0.03*1000) =
    0.27 ≥ 0.2), N_n' = [N_n] = [1000 * 8.33 ms] = 8."""
    n_n = 1000.0 * (1.5 / (6 * 30))
    assert n_n == pytest.approx(8.333, abs=1e-3)
    seed_units = 1 + 5 * 2.0 * 1.5 / (6 * 0.03 * 30)
    assert float(effective_pulses(n_n, clutter_velocity_spread_mps=2.0, **X_BAND)) == \
        np.floor(seed_units) == 3.0
    assert float(effective_pulses(n_n, clutter_velocity_spread_mps=8.0, **X_BAND)) == 8.0


@settings(max_examples=200, deadline=None)
@given(lam=st.floats(0.008, 0.7), prf=st.floats(200.0, 20000.0),
       theta_deg=st.floats(0.3, 10.0), rpm=st.floats(1.0, 120.0))
def test_effective_pulses_74_continuous_at_the_switch(lam, prf, theta_deg, rpm):
    """Both branches of [74] meet at σ_s'/(λ f_r) = 0.2 (only the coefficient 5 does this:
    1 + 5 (0.2 λ f_r) t_ot / λ = 1 + N_n, capped to ⌊N_n⌋)."""
    theta, omega = np.radians(theta_deg), 2 * np.pi * rpm / 60
    n_n = prf * theta / omega
    args = dict(X_BAND, wavelength_m=lam, prf_hz=prf, beamwidth_rad=theta,
                rotation_rate_rad_s=omega)
    switch = 0.2 * lam * prf
    below = effective_pulses(n_n, clutter_velocity_spread_mps=switch * (1 - 1e-9), **args)
    above = effective_pulses(n_n, clutter_velocity_spread_mps=switch * (1 + 1e-9), **args)
    assert float(below) == float(above) == max(np.floor(n_n), 1.0)


def test_effective_pulses_never_below_one_vectorized():
    dom = np.array([True, True, False, True])
    n = effective_pulses(
        np.array([3.0, 0.4, 0.4, 10.0]),
        clutter_dominated=dom,
        pulses_per_frequency=1,
        mti_order=np.array([10, 0, 0, 0]),
        n_coherent=np.array([1, 1, 1, 64]),
    )
    np.testing.assert_array_equal(n, [1.0, 1.0, 1.0, 1.0])  # SPEC §4 item 16


# ----------------------------------------------------------------------------- exact P_d
def test_swerling1_single_pulse_closed_form():
    s_db = np.linspace(-20, 40, 61)
    pfa = np.array([1e-15, 1e-8, 1e-3, 0.1])[:, None]
    got = probability_of_detection(s_db, pfa, 1, 1)
    want = pfa ** (1 / (1 + 10 ** (s_db / 10)))
    np.testing.assert_allclose(got, want, rtol=1e-12)


def test_swerling2_is_incomplete_gamma_of_scaled_threshold():
    # pulse-to-pulse Rayleigh: each pulse's power is exponential with mean 1+S, so the sum is
    # Gamma(N, 1+S): P_d = Q(N, T/(1+S)); checked against scipy.stats.gamma.sf
    for n in (1, 4, 25):
        t = stats.gamma.isf(1e-6, n)
        for s_db in (-5.0, 3.0, 10.0):
            s = 10 ** (s_db / 10)
            want = stats.gamma.sf(t, n, scale=1 + s)
            got = probability_of_detection(s_db, 1e-6, n, 2)
            assert got == pytest.approx(want, rel=1e-9)


@pytest.mark.parametrize("s_db", [-10.0, 0.0, 5.0, 10.0, 13.0, 16.0])
@pytest.mark.parametrize("pfa", [1e-12, 1e-6, 1e-2])
def test_swerling0_single_pulse_is_marcum_q(s_db, pfa):
    s = 10 ** (s_db / 10)
    want = marcum_q1_quad(np.sqrt(2 * s), np.sqrt(-2 * np.log(pfa)))
    assert probability_of_detection(s_db, pfa, 1, 0) == pytest.approx(want, rel=1e-7)


def test_single_pulse_identities():
    s_db = np.linspace(-10, 30, 9)
    # one pulse: scan-to-scan and pulse-to-pulse models coincide
    np.testing.assert_allclose(
        probability_of_detection(s_db, 1e-6, 1, 2),
        probability_of_detection(s_db, 1e-6, 1, 1),
        rtol=1e-10,
    )
    np.testing.assert_allclose(
        probability_of_detection(s_db, 1e-6, 1, 4),
        probability_of_detection(s_db, 1e-6, 1, 3),
        rtol=1e-10,
    )


def test_swerling1_multi_pulse_difranco_rubin_form():
    # DiFranco & Rubin (1968) eq. 10-77: P_d = Q(N-1,T) + (1+1/(NS))^{N-1}
    # P(N-1, T/(1+1/(NS))) exp(-T/(1+NS)); algebraically distinct from the module's form
    for n in (2, 5, 30):
        t = special.gammainccinv(n, 1e-6)
        for s_db in (0.0, 5.0, 12.0):
            ns = n * 10 ** (s_db / 10)
            want = special.gammaincc(n - 1, t) + (1 + 1 / ns) ** (n - 1) * special.gammainc(
                n - 1, t / (1 + 1 / ns)
            ) * np.exp(-t / (1 + ns))
            assert probability_of_detection(s_db, 1e-6, n, 1) == pytest.approx(want, rel=1e-10)


def test_swerling3_two_pulses_meyer_mayer():
    # Meyer & Mayer (1973): exact for N = 1, 2: P_d = (1 + 2/(NS))^{N-2}
    # [1 + T/(1 + NS/2) - 2(N-2)/(NS)] exp(-T/(1 + NS/2)); for N = 2 no (N-2) terms
    for n in (1, 2):
        t = special.gammainccinv(n, 1e-5)
        for s_db in (-3.0, 4.0, 15.0):
            ns = n * 10 ** (s_db / 10)
            want = (
                (1 + 2 / ns) ** (n - 2)
                * (1 + t / (1 + ns / 2) - 2 * (n - 2) / ns)
                * np.exp(-t / (1 + ns / 2))
            )
            assert probability_of_detection(s_db, 1e-5, n, 3) == pytest.approx(want, rel=1e-10)


@pytest.mark.parametrize("swerling", [0, 1, 2, 3, 4])
def test_exact_against_chi_square_family_sum(swerling):
    worst = 0.0
    for n in (1, 3, 10, 200, 1000):
        for pfa in (1e-15, 1e-6, 0.1):
            for s_db in (-50.0, -20.0, -8.0, 0.0, 6.0, 12.0):
                if n * 10 ** (s_db / 10) > 3e3:
                    continue
                want = chi_square_family_pd(s_db, pfa, n, swerling)
                got = probability_of_detection(s_db, pfa, n, swerling)
                worst = max(worst, abs(got - want) / want)
    assert worst < 1e-9


def test_literature_single_pulse_values():
    # Skolnik, Introduction to Radar Systems (3rd ed.) Fig. 2.7 / Blake: 13.2 dB for a steady
    # target; Swerling 1 closed form 10 log10(ln Pfa / ln Pd - 1) = 21.14 dB (Skolnik: ~21 dB)
    assert required_snr_db(PD_LIT, PFA_LIT, 1, 0) == pytest.approx(13.2, abs=0.05)
    assert required_snr_db(PD_LIT, PFA_LIT, 1, 1) == pytest.approx(21.1, abs=0.1)
    assert required_snr_db(PD_LIT, PFA_LIT, 1, 1) == pytest.approx(
        _db(np.log(PFA_LIT) / np.log(PD_LIT) - 1), abs=1e-9
    )


@pytest.mark.parametrize("n", [1, 10, 100, 1000, 8000])
@pytest.mark.parametrize("pd", [0.5, 0.9])
@pytest.mark.parametrize("pfa", [1e-7, 1e-5, 1e-3])
def test_steady_target_multi_pulse_albersheim(n, pd, pfa):
    # Albersheim's stated 0.2 dB, plus up to ~0.15 dB between his linear detector and the
    # square law modelled here
    assert required_snr_db(pd, pfa, n, 0) == pytest.approx(albersheim_db(pd, pfa, n), abs=0.35)


@pytest.mark.parametrize("n, pd_aim, pfa", [(4, 0.5, 1e-2), (10, 0.9, 1e-3)])
@pytest.mark.parametrize("swerling", [0, 1, 2, 3, 4])
def test_monte_carlo_each_swerling_case(swerling, n, pd_aim, pfa):
    rng = np.random.default_rng(1000 + 10 * swerling + n)
    trials = 40_000
    s_db = float(required_snr_db(pd_aim, pfa, n, swerling))
    s = 10 ** (s_db / 10)
    t = special.gammainccinv(n, pfa)  # threshold on Σ|x|² with unit noise power per pulse
    if swerling in (0, 1, 3):
        k = {0: None, 1: 1, 3: 2}[swerling]
        power = np.full((trials, 1), s) if k is None else rng.gamma(k, s / k, (trials, 1))
        power = np.broadcast_to(power, (trials, n))  # constant over the dwell
    else:
        k = {2: 1, 4: 2}[swerling]
        power = rng.gamma(k, s / k, (trials, n))  # independent pulse to pulse
    phase = rng.uniform(0, 2 * np.pi, (trials, n))
    amp = np.sqrt(power) * np.exp(1j * phase)
    noise = (rng.standard_normal((trials, n)) + 1j * rng.standard_normal((trials, n))) / np.sqrt(2)
    y = np.sum(np.abs(amp + noise) ** 2, axis=1)
    pd_mc = np.mean(y > t)
    pd = probability_of_detection(s_db, pfa, n, swerling)
    assert pd == pytest.approx(pd_aim, abs=1e-6)
    assert abs(pd_mc - pd) < 5 * np.sqrt(pd * (1 - pd) / trials)
    # noise alone: the threshold gives P_fa
    fa = np.mean(np.sum(np.abs(noise) ** 2, axis=1) > t)
    assert abs(fa - pfa) < 5 * np.sqrt(pfa * (1 - pfa) / trials)


@pytest.mark.parametrize("swerling", [0, 1, 2, 3, 4])
def test_real_n_is_the_chi_square_family_continuation(swerling):
    # non-integer N_e: Gamma(N) noise and a non-central gamma of order N, as the family sum
    # (real N is allowed there); Swerling 4 by quadrature, worst 3.6e-4 near N = 1, P_fa 1e-15
    tol = 5e-4 if swerling == 4 else 1e-9
    for n in (1.01, 1.5, 2.5, 7.7, 30.4, 200.5):
        for pfa in (1e-15, 1e-6, 0.1):
            for s_db in (-20.0, -5.0, 0.0, 6.0, 12.0, 20.0):
                if n * 10 ** (s_db / 10) > 2e3:
                    continue
                want = chi_square_family_pd(s_db, pfa, n, swerling)
                got = probability_of_detection(s_db, pfa, n, swerling)
                if swerling == 4:
                    assert got == pytest.approx(want, abs=tol)
                else:
                    assert got == pytest.approx(want, rel=tol)


@pytest.mark.parametrize("swerling", [0, 1, 2, 3, 4])
def test_more_pulses_never_detect_less(swerling):
    n = np.linspace(1.0, 12.0, 45)
    s_db = np.array([-6.0, 0.0, 4.0, 10.0])[:, None]
    p = probability_of_detection(s_db, 1e-6, n, swerling)
    # Swerling 4: the quadrature at non-integer N meets the binomial sum at integers to 4e-4
    assert np.all(np.diff(p, axis=1) >= (-5e-4 if swerling == 4 else -1e-12))
    # the old P_d-linear interpolation between integers was 1.1-1.4 dB off here
    pd_lin = 0.5 * (
        probability_of_detection(s_db, 1e-6, 1, swerling)
        + probability_of_detection(s_db, 1e-6, 2, swerling)
    )
    assert not np.allclose(probability_of_detection(s_db, 1e-6, 1.5, swerling), pd_lin, atol=1e-3)


def test_limits_zero_and_infinite_snr():
    for method in ("exact", "seed"):
        for sw in range(5):
            assert probability_of_detection(-np.inf, 1e-6, 10, sw, method) == pytest.approx(
                1e-6, rel=1e-12
            )
            assert probability_of_detection(np.inf, 1e-6, 10, sw, method) == 1.0


def test_broadcasting_shapes_and_scalars():
    out = probability_of_detection(
        np.zeros((2, 1, 1, 1)),
        np.full((1, 3, 1, 1), 1e-6),
        np.ones((1, 1, 4, 1)),
        np.arange(5).reshape(1, 1, 1, 5),
    )
    assert out.shape == (2, 3, 4, 5)
    assert isinstance(probability_of_detection(10.0, 1e-6, 3, 1), float)


def test_invalid_inputs_raise():
    with pytest.raises(ValueError, match="swerling"):
        probability_of_detection(10, 1e-6, 1, 5)
    with pytest.raises(ValueError, match="pfa"):
        probability_of_detection(10, 0.0, 1, 1)
    with pytest.raises(ValueError, match="pfa"):
        probability_of_detection(10, 0.3, 1, 1, "seed")
    with pytest.raises(ValueError, match="n_pulses"):
        probability_of_detection(10, 1e-6, 0.5, 1)
    with pytest.raises(ValueError, match="NaN"):
        probability_of_detection(np.nan, 1e-6, 1, 1)
    with pytest.raises(ValueError, match="square-law"):
        probability_of_detection(10, 1e-6, 1, 1, integrator="single_loop")
    with pytest.raises(ValueError, match="method"):
        probability_of_detection(10, 1e-6, 1, 1, "blake")
    with pytest.raises(ValueError, match="integrator"):
        probability_of_detection(10, 1e-6, 1, 1, "seed", integrator="triple_loop")
    with pytest.raises(ValueError, match="detector"):
        probability_of_detection(10, 1e-6, 1, 1, "seed", detector="cubic")


# ----------------------------------------------------------------------------- seed method
def test_seed_tables():
    assert detection.TABLE_II == {"square": 1.0, "linear": 0.915, "log": 0.608}
    assert float(detection.equivalent_pulses(10, "uniform", "gaussian")) == pytest.approx(5.58)
    assert float(detection.equivalent_pulses(10, "double_loop", "constant")) == pytest.approx(
        13.347 * np.exp(-0.3)
    )
    k = detection.fluctuation_k(np.arange(5), 7.0)
    np.testing.assert_array_equal(k, [np.inf, 1.0, 7.0, 2.0, 14.0])


def test_seed_quantile_fits_near_normal_quantiles():
    # [80]-[82] approximate the normal quantiles inside their ranges
    pfa = np.logspace(-12, -4, 17)
    # Blake's g_fa is tuned for the detection formula, not a pure quantile fit: within 2 %
    np.testing.assert_allclose(detection.g_fa(pfa), -special.ndtri(pfa), rtol=0.02)
    pd = np.linspace(0.1, 0.9, 17)
    np.testing.assert_allclose(detection.g_d(special.ndtri(pd)), special.ndtri(pd), atol=0.06)
    # continuous at the edges of validity, and the exact quantile slope outside
    eps = 1e-9
    for edge in detection.SEED_PFA_RANGE:
        assert detection.g_fa(edge * (1 + eps)) == pytest.approx(
            detection.g_fa(edge * (1 - eps)), abs=1e-6
        )
    z9 = special.ndtri(0.9)
    assert detection.g_d(z9 + 1.0) - detection.g_d(z9) == pytest.approx(1.0, abs=1e-12)


def test_seed_single_pulse_steady_blake_value():
    # [78]-[82] for N = 1, Pd 0.9, Pfa 1e-6: X0 = (4.7607 + 1.2769)², D0 = 13.03 dB (hand)
    gfa = 2.36 * np.sqrt(6) - 1.02
    t = 0.9 * 0.8
    gd = 1.231 * t / np.sqrt(1 - t * t)
    x0 = (gfa + gd) ** 2
    d0 = x0 / 4 * (1 + np.sqrt(1 + 16 / x0))
    assert required_snr_db(0.9, 1e-6, 1, 0, "seed") == pytest.approx(_db(d0), abs=1e-9)
    # Swerling 1: D0 plus [83] with K = 1
    lf = 1 / (-np.log(0.9) * (1 + gd / gfa))
    assert required_snr_db(0.9, 1e-6, 1, 1, "seed") == pytest.approx(_db(d0 * lf), abs=1e-9)


def test_seed_within_stated_error_of_exact_inside_validity():
    pd = np.linspace(0.1, 0.9, 9)[:, None, None, None]
    pfa = np.logspace(-12, -4, 5)[None, :, None, None]
    n = np.array([1, 1.5, 2, 5, 10, 30, 100])[None, None, :, None]
    sw = np.arange(5)[None, None, None, :]
    err = required_snr_db(pd, pfa, n, sw, "seed") - required_snr_db(pd, pfa, n, sw)
    assert np.max(np.abs(err)) < 0.7  # seed 6.4: "maximum error of 0.7 dB"
    # and it is not a loose bound: the worst case uses most of it (0.62 dB, Swerling 1-2)
    assert np.max(np.abs(err)) > 0.5


def test_seed_iteration_meets_one_percent_of_snr():
    rng = np.random.default_rng(7)
    s_db = rng.uniform(-5, 25, 400)
    pfa = 10 ** rng.uniform(-12, -4, 400)
    n = rng.integers(1, 60, 400).astype(float)
    sw = rng.integers(0, 5, 400)
    pd = probability_of_detection(s_db, pfa, n, sw, "seed")
    inside = (pd > 0.1) & (pd < 0.9)
    assert inside.sum() > 50
    back = required_snr_db(pd[inside], pfa[inside], n[inside], sw[inside], "seed")
    ratio = 10 ** ((back - s_db[inside]) / 10)
    assert np.max(np.abs(ratio - 1)) < detection.SEED_SNR_TOLERANCE


def test_seed_gaussian_variation_and_detectors_need_more_snr():
    base = required_snr_db(0.5, 1e-6, 10, 1, "seed")
    assert required_snr_db(0.5, 1e-6, 10, 1, "seed", signal_variation="gaussian") > base
    assert required_snr_db(0.5, 1e-6, 10, 1, "seed", detector="log") > base


# ----------------------------------------------------------------------------- properties
snr_st = st.floats(-50.0, 100.0)
pfa_st = st.floats(-15.0, -1.0).map(lambda e: 10.0**e)
n_st = st.one_of(st.integers(1, 10_000).map(float), st.floats(1.0, 10_000.0))
sw_st = st.integers(0, 4)


@settings(max_examples=60, deadline=None)
@given(
    s1=snr_st, s2=snr_st, pfa=pfa_st, n=n_st, sw=sw_st, method=st.sampled_from(["exact", "seed"])
)
def test_property_extremes_finite_bounded_monotone(s1, s2, pfa, n, sw, method):
    lo, hi = min(s1, s2), max(s1, s2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        p = probability_of_detection(np.array([lo, hi]), pfa, n, sw, method)
    assert np.all(np.isfinite(p))
    assert np.all((p >= 0) & (p <= 1))
    assert p[0] >= pfa * (1 - 1e-9)
    # the seed method is monotone by construction; the exact one up to rounding (1e-14)
    assert p[1] >= p[0] - (0.0 if method == "seed" else 1e-14)


@settings(max_examples=15, deadline=None)
@given(pfa=pfa_st, n=st.floats(1.0, 10_000.0), sw=sw_st)
def test_property_monotone_on_dense_grid(pfa, n, sw):
    s = np.linspace(-50, 100, 301)
    for method in ("exact", "seed"):
        p = probability_of_detection(s, pfa, n, sw, method)
        assert np.all(np.diff(p) >= (0.0 if method == "seed" else -1e-14))
        # Swerling 1 at 100 dB misses with probability about ln(1/Pfa)/S < 4e-9
        assert p[-1] >= 1 - 1e-8


@settings(max_examples=40, deadline=None)
@given(
    pd=st.floats(0.01, 0.999),
    pfa=st.floats(-12.0, -2.0).map(lambda e: 10.0**e),
    n=st.floats(1.0, 300.0),
    sw=sw_st,
)
def test_property_required_snr_round_trip(pd, pfa, n, sw):
    s_db = required_snr_db(pd, pfa, n, sw)
    assert probability_of_detection(s_db, pfa, n, sw) == pytest.approx(pd, abs=1e-9)
    s_seed = required_snr_db(pd, pfa, n, sw, "seed")
    assert probability_of_detection(s_seed, pfa, n, sw, "seed") == pytest.approx(pd, abs=2e-3)


def test_required_snr_edges():
    out = required_snr_db(np.array([0.0, 1e-7, 1.0]), 1e-6, 5, 1)
    assert out[0] == -np.inf and out[1] == -np.inf and out[2] == np.inf
    out = required_snr_db(np.array([0.0, 1.0]), 1e-6, 5, 1, "seed")
    assert out[0] == -np.inf and out[1] == np.inf
    with pytest.raises(ValueError, match="pd"):
        required_snr_db(1.2, 1e-6, 5, 1)
