"""Stand-off noise jamming [47]-[48]: hand computation, antenna pattern, bandwidth cap, vectors."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shipradar.sensors import antenna, jamming
from shipradar.sensors.noise import power_ratio

LAM = 0.03


def test_jammer_power_and_sj_hand_computation_in_db():
    # P_jt 100 W (20 dBW), G_j 10 dB, G 35 dB, sidelobe at -40 dB (g_az = 0.01), main beam
    # in elevation, λ 3 cm, R_j 100 km, B 1 MHz, B_j 100 MHz (-20 dB), F_j 1,
    # L_r 1.5 dB, L_atm 0.5 dB:
    # 20 + 10 + 35 - 40 - 20 + 20 log 0.03 - 20 log 4π - 20 log 1e5 - 1.5 - 0.5
    # = 20 + 10 + 35 - 40 - 20 - 30.458 - 21.984 - 100 - 2 = -149.442 dBW
    pj = jamming.jammer_power_w(
        100.0,
        power_ratio(10.0),
        power_ratio(35.0),
        0.01,
        1.0,
        LAM,
        100e3,
        1e6,
        100e6,
        l_r=power_ratio(1.5),
        l_atm=power_ratio(0.5),
    )
    assert 10 * np.log10(pj) == pytest.approx(-149.442, abs=0.002)
    # [48] with P_r = -130 dBW and L_j = L_x = 5 dB: S/J = -130 + 149.442 - 5 = 14.442 dB.
    sj = jamming.signal_to_jamming(1e-13, pj)
    assert 10 * np.log10(sj) == pytest.approx(14.442, abs=0.002)


def test_bandwidth_ratio_capped_at_one():
    assert jamming.bandwidth_ratio(1e6, 100e6) == pytest.approx(0.01, rel=1e-15)
    assert jamming.bandwidth_ratio(1e6, 1e5) == 1.0
    wide = jamming.jammer_power_w(1.0, 1.0, 1.0, 1.0, 1.0, LAM, 1e4, 1e6, 1e6)
    spot = jamming.jammer_power_w(1.0, 1.0, 1.0, 1.0, 1.0, LAM, 1e4, 1e6, 1e5)
    assert spot == pytest.approx(wide, rel=1e-15)


def test_main_beam_versus_sidelobe_with_the_antenna_pattern():
    bw = np.deg2rad(1.5)
    offsets = np.deg2rad(np.array([0.0, 10.0, 90.0]))
    g_az = antenna.directivity(offsets, bw, "sinc", sidelobe_db=30.0, envelope=True)
    pj = jamming.jammer_power_w(100.0, 10.0, 3000.0, g_az, 1.0, LAM, 50e3, 1e6, 50e6)
    main = jamming.jammer_power_w(100.0, 10.0, 3000.0, 1.0, 1.0, LAM, 50e3, 1e6, 50e6)
    assert pj[0] == pytest.approx(main, rel=1e-12)
    # Sidelobes at least 30 dB down (the sidelobe level) off the main beam.
    assert np.all(10 * np.log10(pj[1:] / main) <= -30.0 + 1e-9)
    # A Gaussian beam has no sidelobes: the seed's constant L_sl keeps a floor.
    g_gauss = antenna.directivity(np.deg2rad(90.0), bw, "gaussian")
    floor = power_ratio(-40.0)
    pj_floor = jamming.jammer_power_w(
        100.0, 10.0, 3000.0, g_gauss, 1.0, LAM, 50e3, 1e6, 50e6, sidelobe_floor=floor
    )
    assert pj_floor == pytest.approx(main * floor, rel=1e-12)


def test_vectorized_over_dwells_and_jammers():
    n_dwell, n_jam = 7, 3
    rng = np.random.default_rng(5)
    g_az = rng.uniform(0.0, 1.0, (n_dwell, n_jam))
    ranges = np.array([30e3, 80e3, 150e3])
    p = np.array([50.0, 200.0, 1000.0])
    pj = jamming.jammer_power_w(
        p, 10.0, 3000.0, g_az, 0.9, LAM, ranges, 1e6, np.array([2e7, 5e7, 1e8])
    )
    assert pj.shape == (n_dwell, n_jam)
    for i in range(n_dwell):
        for j in range(n_jam):
            one = jamming.jammer_power_w(
                p[j], 10.0, 3000.0, g_az[i, j], 0.9, LAM, ranges[j], 1e6, [2e7, 5e7, 1e8][j]
            )
            assert pj[i, j] == pytest.approx(one, rel=1e-14)
    total = pj.sum(axis=1)
    sj = jamming.signal_to_jamming(np.full(n_dwell, 1e-12), total)
    assert sj.shape == (n_dwell,)


def test_no_jamming_gives_infinite_sj_without_warning():
    sj = jamming.signal_to_jamming(np.array([1e-12, 1e-12]), np.array([0.0, 1e-14]))
    assert np.isinf(sj[0]) and np.isfinite(sj[1])


@settings(max_examples=100, deadline=None)
@given(r=st.floats(10.0, 1e6), g=st.floats(0.0, 1.0), f_j=st.floats(0.0, 2.0))
def test_inverse_square_range_law_and_finite(r, g, f_j):
    p1 = jamming.jammer_power_w(100.0, 10.0, 3000.0, g, 1.0, LAM, r, 1e6, 1e7, f_j=f_j)
    p2 = jamming.jammer_power_w(100.0, 10.0, 3000.0, g, 1.0, LAM, 2 * r, 1e6, 1e7, f_j=f_j)
    assert np.isfinite(p1) and p1 >= 0.0
    assert p1 == pytest.approx(4.0 * p2, rel=1e-12)
    assert np.isfinite(jamming.jammer_power_w(100.0, 10.0, 3000.0, g, 1.0, LAM, 0.0, 1e6, 1e7))
