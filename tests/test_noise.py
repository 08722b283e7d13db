"""System noise and radar equation: [2]-[3], [17]-[20], and the sky-noise model of T'_a."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shipradar.sensors import atmosphere as atm
from shipradar.sensors import noise


def test_named_constants_are_the_seeds():
    assert noise.T0_K == 290.0
    assert noise.L_X_DB == 5.0
    assert noise.L_C_DB == 6.0
    assert noise.L_J_DB == noise.L_X_DB
    assert (noise.L_CFAR_DB, noise.L_CD_DB, noise.L_B_DB) == (1.5, 2.0, 1.6)
    assert 10 * np.log10(noise.processing_loss()) == pytest.approx(5.0, rel=1e-12)


def test_receive_loss_is_half_the_transmit_receive_loss_in_db():
    assert 10 * np.log10(noise.receive_loss(noise.power_ratio(4.0))) == pytest.approx(
        2.0, rel=1e-12
    )
    assert noise.receive_loss(1.0) == 1.0


def test_system_noise_temperature_hand_computation():
    # T_a = 100 K, L_r = 1 dB = 1.258925, N_f = 3 dB = 1.995262:
    # T_s = 100 + 290 (0.258925) + 1.258925 · 290 · 0.995262 = 100 + 75.088 + 363.355 = 538.443 K
    ts = noise.system_noise_temperature_k(100.0, 1.258925412, 1.995262315)
    assert ts == pytest.approx(538.443, abs=0.01)
    # Lossless, noiseless receiver: T_s = T_a.
    assert noise.system_noise_temperature_k(123.0, 1.0, 1.0) == pytest.approx(123.0, rel=1e-15)


def test_blake_antenna_temperature():
    # L_a = 1: T_a = 0.876 T'_a + 36 K.
    assert noise.antenna_temperature_k(100.0) == pytest.approx(87.6 + 36.0, rel=1e-12)
    # A very lossy antenna is a 290 K resistor.
    assert noise.antenna_temperature_k(100.0, 1e9) == pytest.approx(290.0, rel=1e-6)


def test_noise_power_ktb():
    n0 = noise.noise_power_w(290.0, 1e6)
    assert 10 * np.log10(n0 / 1e-3) == pytest.approx(-113.98, abs=0.01)
    assert noise.noise_bandwidth_hz(1e-6) == pytest.approx(1e6, rel=1e-15)


def test_radar_equation_snr_hand_computation_in_db():
    # P_t 1 MW, G 35 dB, 10 GHz, L_t/r 3 dB, σ 1 m², R 50 km, F 1, T_s 500 K, B 1 MHz, L_x 5 dB.
    # In dB: 60 + 2·35 + 20 log λ - 30 log 4π - 3 + 0 - 40 log R - 10 log(k T_s B) - 5.
    lam = 299792458.0 / 10e9
    snr_db_hand = (
        60
        + 70
        + 20 * np.log10(lam)
        - 30 * np.log10(4 * np.pi)
        - 3
        - 40 * np.log10(50e3)
        - 10 * np.log10(1.380649e-23 * 500 * 1e6)
        - 5
    )
    assert snr_db_hand == pytest.approx(12.21, abs=0.01)  # worked by hand: 12.21 dB
    kr = noise.radar_constant(1e6, noise.power_ratio(35.0), lam, noise.power_ratio(3.0))
    pr = noise.received_power(kr, 1.0, 1.0, 50e3)
    snr = noise.signal_to_noise(pr, noise.noise_power_w(500.0, 1e6))
    assert 10 * np.log10(snr) == pytest.approx(snr_db_hand, abs=1e-9)


def test_atmospheric_loss_enters_twice():
    k1 = noise.radar_constant(1.0, 1.0, 0.03, 1.0, 1.0)
    k2 = noise.radar_constant(1.0, 1.0, 0.03, 1.0, noise.power_ratio(1.5))
    assert 10 * np.log10(k1 / k2) == pytest.approx(3.0, rel=1e-12)


def test_zero_range_is_finite():
    kr = noise.radar_constant(1e6, 1e3, 0.03, 2.0)
    p0 = noise.received_power(kr, 1.0, 1.0, np.array([0.0, noise.MIN_RANGE_M]))
    assert np.all(np.isfinite(p0))
    assert p0[0] == p0[1]


@settings(max_examples=100, deadline=None)
@given(r=st.floats(10.0, 1e6), sigma=st.floats(1e-4, 1e4), f=st.floats(1e-3, 2.0))
def test_snr_inverse_fourth_power_of_range(r, sigma, f):
    kr = noise.radar_constant(1e6, 1e3, 0.03, 2.0)
    n0 = noise.noise_power_w(500.0, 1e6)
    s1 = noise.signal_to_noise(noise.received_power(kr, sigma, f, r), n0)
    s2 = noise.signal_to_noise(noise.received_power(kr, sigma, f, 2 * r), n0)
    assert np.isfinite(s1) and s1 > 0
    assert s1 / s2 == pytest.approx(16.0, rel=1e-12)


def test_galactic_noise_p372():
    # P.372 eq. (13) at 100 MHz: F_am = 52 - 46 = 6 dB -> 290 · 10^0.6 = 1154.5 K.
    assert noise.galactic_noise_temperature_k(100e6) == pytest.approx(1154.5, rel=1e-4)
    # f^-2.3 law: a decade in frequency is 23 dB.
    ratio = noise.galactic_noise_temperature_k(1e9) / noise.galactic_noise_temperature_k(10e9)
    assert 10 * np.log10(ratio) == pytest.approx(23.0, rel=1e-12)


def test_sky_temperature_isothermal_closed_form():
    # With no lapse the radiative transfer integral is T (1 - 1/L) + T_ext / L exactly, with L
    # the one-way loss through the whole atmosphere along the same path (second method).
    els = np.deg2rad([0.0, 2.0, 10.0, 90.0])
    t_sky = noise.sky_temperature_k(10e9, els, lapse_rate_k_per_m=0.0, include_galactic=False)
    go, gw = atm.gaseous_specific_attenuation_db_per_km(10e9)
    ho, hw = atm.gaseous_equivalent_heights_m(10e9)
    path = atm.layer_path_length_m(1e9, els, noise.ATMOSPHERE_TOP_M)
    loss = noise.power_ratio(
        atm.gaseous_loss_db(
            path, els, gamma_o_db_per_km=go, gamma_w_db_per_km=gw, h_o_m=ho, h_w_m=hw
        )
    )
    expected = 288.15 * (1 - 1 / loss) + noise.T_COSMIC_K / loss
    assert t_sky == pytest.approx(expected, rel=1e-6)


def test_sky_temperature_against_blake_fig_4_8():
    # Blake (1986) Fig. 4.8 at 3 GHz (read from the figure, ±30 %): about 100 K at 0°,
    # 15 K at 10°, 3-5 K at the zenith (cosmic + a little oxygen).
    t = noise.sky_temperature_k(3e9, np.deg2rad([0.0, 10.0, 90.0]))
    assert t[0] == pytest.approx(100.0, rel=0.3)
    assert t[1] == pytest.approx(15.0, rel=0.3)
    assert 3.0 < t[2] < 8.0


def test_sky_temperature_monotone_and_bounded():
    els = np.deg2rad(np.linspace(-5.0, 90.0, 40))
    for f in (1e9, 10e9, 35e9):
        t = noise.sky_temperature_k(f, els)
        assert np.all(np.diff(t) <= 1e-9)
        assert np.all(t >= noise.T_COSMIC_K) and np.all(
            t <= 288.15 + noise.galactic_noise_temperature_k(f)
        )
    # Near the 60 GHz oxygen band the air is opaque: the sky is the air temperature.
    assert noise.sky_temperature_k(60e9, 0.0) == pytest.approx(288.15, rel=0.02)
