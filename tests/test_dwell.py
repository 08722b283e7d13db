"""The dwell model's S/I assembly [66]-[67], Doppler separation (2.2.1) and rain region."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shipradar.sensors.detection import Interference
from shipradar.sim.dwell.model import DwellModel
from shipradar.tables.scene import SceneTables
from tests.helpers import bare_scene, quiet_radar

NOISE, CLUTTER, JAMMING = Interference.NOISE, Interference.CLUTTER, Interference.JAMMING


def _model(radar=None, **env):
    s = bare_scene(radar or quiet_radar(processor={"type": "fir_bank", "n_coherent": 8}))
    if env:
        d = s.model_dump(mode="json")
        d["environment"].update(env)
        from shipradar.sim.world.scenario import parse_scenario

        s = parse_scenario(d)
    p = s.platforms[0]
    return DwellModel(s, p, p.radars[0], SceneTables())


def test_dominance_rule_is_total_and_as_documented():
    m = _model()
    n = m.n0
    p_r = np.full(5, 1e-12)
    clutter = np.array([0.0, 0.49 * n, 0.5 * n, 10 * n, 0.0])
    jam = np.array([0.0, 0.0, 0.0, 0.0, 2.01 * n])
    si, code = m.signal_to_interference(p_r, clutter, jam, np.ones(5), np.ones(5))
    assert code.tolist() == [NOISE, NOISE, CLUTTER, CLUTTER, JAMMING]
    # jamming is noise-like [66]: S/(N+J) with the noise losses
    assert si[4] == pytest.approx(1e-12 / ((n + jam[4]) * m.l_x * m.l_cfar), rel=1e-12)


@settings(max_examples=200, deadline=None)
@given(c_over_n_db=st.floats(-3.0, 80.0), i_f_db=st.floats(0.0, 120.0),
       cg_db=st.floats(0.0, 24.0), l_d_db=st.floats(0.0, 10.0))
def test_clutter_si_is_the_residue_and_the_filtered_noise_summed(c_over_n_db, i_f_db, cg_db,
                                                                 l_d_db):
    """Clutter dominant: 1/S/I = 1/(S/C G_p / L...) + 1/(S/N CG / L...), by hand."""
    m = _model()
    n = m.n0
    c = n * 10 ** (c_over_n_db / 10)
    p_r = 1e-13
    i_f, cg, l_d = 10 ** (i_f_db / 10), 10 ** (cg_db / 10), 10 ** (l_d_db / 10)
    si, code = m.signal_to_interference(np.array([p_r]), np.array([c]), np.zeros(1),
                                        np.array([i_f]), np.array([l_d]), np.array([cg]))
    if code[0] != CLUTTER:
        assert c < 0.5 * n
        return
    residue = p_r / (c * m.l_c) * (i_f / l_d) / (m.l_cfar * m.l_cd * m.l_b)
    noise_out = p_r / (n * m.l_x * m.l_cfar) * cg
    assert si[0] == pytest.approx(1.0 / (1.0 / residue + 1.0 / noise_out), rel=1e-9)
    # never better than the filter's own noise limit, nor than the clutter residue alone
    assert si[0] <= noise_out * (1 + 1e-12)
    assert si[0] <= residue * (1 + 1e-12)


def test_strong_filter_cannot_lift_a_target_above_the_noise_limit():
    """I_F = 60 dB against clutter just above the noise: S/I is the noise's, not +60 dB."""
    m = _model()
    n = m.n0
    p_r = np.array([1e-13])
    noise_si, _ = m.signal_to_interference(p_r, np.zeros(1), np.zeros(1), np.ones(1), np.ones(1))
    si, code = m.signal_to_interference(p_r, np.array([2.0 * n]), np.zeros(1), np.array([1e6]),
                                        np.ones(1), np.array([8.0]))
    assert code[0] == CLUTTER
    # a filter of coherent gain 8 (9 dB) gives at most 9 dB over the unfiltered S/N
    assert 10 * np.log10(si[0] / noise_si[0]) == pytest.approx(10 * np.log10(8.0), abs=0.01)


@pytest.mark.parametrize(("ptype", "extra", "n_filters"), [
    ("dft_bank", {}, 8),
    ("fir_bank", {"n_filters": 5}, 5),
    ("mti_bank", {"mti_order": 1}, 7),  # N_c - N_pc taps behind a 1st-order canceller
    ("mti_bank", {"mti_order": 2}, 6),
])
def test_doppler_filters_separate_targets_by_the_bank_size(ptype, extra, n_filters):
    r = quiet_radar(processor={"type": ptype, "n_coherent": 8, **extra})
    m = _model(r)
    prf = r["prf_hz"]
    # one target at the centre of every filter (Doppler relative to the clutter mean)
    idx = m.doppler_filter(np.arange(n_filters) * prf / n_filters)
    assert idx.tolist() == list(range(n_filters))
    # one more filter's width folds back to filter 0 (Doppler ambiguity)
    assert m.doppler_filter(np.array([prf]))[0] == 0


def test_mti_only_radar_never_separates_by_doppler():
    m = _model(quiet_radar(processor={"type": "mti", "mti_order": 2}))
    assert set(m.doppler_filter(np.linspace(-300, 300, 7))) == {0}


def _rain_model(region):
    from types import SimpleNamespace

    from shipradar.sim.world.scenario import parse_scenario
    from shipradar.tables.scene import load_scene_tables

    r = quiet_radar(prf_hz=5000, instrumented_range_m=100e3, pulse_width_s=1e-6,
                    processor={"type": "fir_bank", "n_coherent": 8})
    d = bare_scene(r).model_dump(mode="json")
    d["environment"]["rain"] = {"rate_mm_h": 4.0, "cloud_base_m": 2000.0, "region": region}
    d["fidelity"].update(clutter=True)
    s = parse_scenario(d)
    p = s.platforms[0]
    m = DwellModel(s, p, p.radars[0], load_scene_tables(s))

    def power(ground_range_m, azimuth_rad):
        g = SimpleNamespace(ground_range=np.asarray(ground_range_m, float),
                            azimuth=np.asarray(azimuth_rad, float))
        return m._folded_rain_power(g, np.zeros((g.ground_range.size, 2)))

    return m, power


def test_rain_region_counts_each_trip_by_its_own_cell(table_cache):
    """A rain cell east at 10 +- 5 km; R_u = c / 2 f_r = 29.98 km at 5 kHz."""
    m, power = _rain_model({"east_m": 10e3, "north_m": 0.0, "radius_m": 5e3})
    trip = m._wx_trip_reader
    east, north = np.pi / 2, 0.0
    r_u = 299_792_458.0 / (2 * 5000)
    p = power([10e3, 30e3, 10e3 + r_u, 10e3 + 2 * r_u, 10e3], [east, east, east, east, north])
    one = trip(np.array([10e3]), np.array([east]))[0, 0]
    assert one > 0
    # inside the rain, first trip only (its second trip at 40 km is outside the cell)
    assert p[0] == pytest.approx(one, rel=1e-12)
    # outside the rain and no trip of its delay inside: nothing (the old code gave 0 too)
    assert p[1] == 0.0
    # outside the rain, but the rain at 10 km shares its delay: the second-trip echo
    assert p[2] == pytest.approx(one, rel=1e-12)
    assert p[3] == pytest.approx(one, rel=1e-12)
    # the same range due north: the beam misses the cell
    assert p[4] == 0.0


def test_rain_everywhere_reads_the_maps_trip_sum(table_cache):
    """No region: every trip is in the rain, the map's own sum is read (and agrees)."""
    m, power = _rain_model({"east_m": 0.0, "north_m": 0.0, "radius_m": 2e6})
    ranges = np.array([5e3, 20e3, 45e3, 80e3])
    az = np.full(4, 1.0)
    summed = m._wx_reader(ranges, az)[:, 0]
    assert power(ranges, az) == pytest.approx(summed, rel=0.02)  # interpolation of a sum


def _jam_scene(propagation, rain=None):
    from shipradar.sim.world.scenario import parse_scenario

    d = bare_scene(quiet_radar(pattern_az={"type": "sinc", "sidelobe_db": 30}),
                   propagation=propagation).model_dump(mode="json")
    d["jammers"] = [{"id": "j", "waypoints": [{"east_m": 0.0, "north_m": 40e3,
                                               "altitude_m": 300.0}],
                     "power_w": 100.0, "gain_db": 10.0, "bandwidth_hz": 1e8}]
    if rain:
        d["environment"]["rain"] = rain
        d["fidelity"]["atmosphere"] = True
    s = parse_scenario(d)
    p = s.platforms[0]
    if rain:
        from shipradar.tables.scene import load_scene_tables

        return s, DwellModel(s, p, p.radars[0], load_scene_tables(s))
    return s, DwellModel(s, p, p.radars[0], SceneTables())


def _jam_geometry(s):
    from shipradar.sim.world.kinematics import LocalFrame, antenna_geometry

    frame = LocalFrame(s.origin)
    jpos = np.array([[0.0, 40e3, 300.0]])
    geom = antenna_geometry(np.zeros((1, 3)), np.zeros((1, 3)), 20.0, jpos, np.zeros((1, 3)),
                            frame)
    return geom, jpos


def test_jamming_is_one_way_propagated_and_attenuated(table_cache):
    """[47] with F_j² and L_atm toward the jammer: against free space, the two-ray scene
    scales P_j by (F_j / g_el)², and rain on the path divides it by its one-way loss."""
    from shipradar.sensors.propagation import two_ray_factor

    s, free = _jam_scene("free_space")
    geom, jpos = _jam_geometry(s)
    beam = np.array([geom.azimuth[0]])  # main beam on the jammer
    p_free = free.jamming_power(beam, geom, jpos)
    # hand [47], main beam, isotropic elevation, free space, B/B_j = 1 MHz / 100 MHz
    lam = free.wavelength
    hand = (100.0 * 10.0 * free.gain * lam**2 * min(free.bandwidth / 1e8, 1.0)
            / ((4 * np.pi) ** 2 * geom.slant_range[0] ** 2 * free.l_r))
    assert p_free[0] == pytest.approx(hand, rel=1e-9)

    _, two = _jam_scene("two_ray")
    f_j = two_ray_factor(geom.ground_range, np.array([300.0]), two.radar.antenna_height_m,
                         two.radar.frequency_hz, two.radar.polarization,
                         wave_height_m=s.wave_height, elevation_pattern=two.elevation_pattern)
    assert two.jamming_power(beam, geom, jpos)[0] == pytest.approx(
        p_free[0] * float(f_j[0]) ** 2, rel=1e-6)

    import itur

    _, wet = _jam_scene("free_space", rain={"rate_mm_h": 25.0})
    ratio_db = 10 * np.log10(p_free[0] / wet.jamming_power(beam, geom, jpos)[0])
    # rain everywhere below the 3 km cloud base: the whole 40 km path, at P.838's γ_r (HP,
    # horizontal path), plus a few tenths of a dB of gases (P.676) one way
    gamma = itur.models.itu838.rain_specific_attenuation(25.0, 5.6, 0.4, 0.0).value
    assert 0.0 < ratio_db - gamma * geom.slant_range[0] / 1e3 < 0.6


def test_jammer_in_a_sinc_null_still_gets_the_sidelobe_level():
    """Off the main beam [47]'s constant L_sl (default S_L): no null toward the jammer, and
    no fall-off below L_sl in the far sidelobes."""
    s, m = _jam_scene("free_space")
    geom, jpos = _jam_geometry(s)
    main = m.jamming_power(np.array([geom.azimuth[0]]), geom, jpos)[0]
    # the first null of a sinc of 2° beamwidth is near 1.13 θ_b; look across the sidelobes
    offsets = np.radians(np.linspace(4.0, 180.0, 400))
    side = m.jamming_power(geom.azimuth[0] + offsets, geom, jpos)
    rel_db = 10 * np.log10(side / main)
    # S_L = 30 dB down at the first sidelobe and everywhere beyond (the envelope would fall
    # to -56 dB at 60° and to nothing at 180°)
    np.testing.assert_allclose(rel_db, -30.0, atol=0.05)


def _hand_47(m, geom, l_sl):
    """[47] by hand: P_jt G_r G_j L_sl (B/B_j) λ² F_j² / ((4π)² R_j² L_r L_atm), free space
    (F_j = 1, isotropic elevation), no atmosphere (L_atm = 1), the _jam_scene jammer."""
    return (100.0 * m.gain * 10.0 * l_sl * min(m.bandwidth / 1e8, 1.0) * m.wavelength**2
            / ((4 * np.pi) ** 2 * geom.slant_range[0] ** 2 * m.l_r))


@pytest.mark.parametrize(("pattern", "offset_deg", "l_sl_db"), [
    ({"type": "sinc", "sidelobe_db": 28.0}, 180.0, 28.0),   # behind the antenna
    ({"type": "sinc", "sidelobe_db": 28.0, "jamming_sidelobe_db": 45.0}, 180.0, 45.0),
    ({"type": "gaussian", "sidelobe_db": 25.0}, 20.0, 25.0),  # 10 beamwidths off a Gaussian
    ({"type": "gaussian", "sidelobe_db": 25.0, "jamming_sidelobe_db": 38.0}, 90.0, 38.0),
])
def test_jammer_outside_the_main_beam_against_47_by_hand(pattern, offset_deg, l_sl_db):
    from shipradar.sim.world.scenario import parse_scenario

    d = bare_scene(quiet_radar(pattern_az=pattern)).model_dump(mode="json")
    d["jammers"] = [{"id": "j", "waypoints": [{"east_m": 0.0, "north_m": 40e3,
                                               "altitude_m": 300.0}],
                     "power_w": 100.0, "gain_db": 10.0, "bandwidth_hz": 1e8}]
    s = parse_scenario(d)
    p = s.platforms[0]
    m = DwellModel(s, p, p.radars[0], SceneTables())
    geom, jpos = _jam_geometry(s)
    beam = np.array([geom.azimuth[0] + np.radians(offset_deg)])
    p_j = m.jamming_power(beam, geom, jpos)[0]
    assert p_j == pytest.approx(_hand_47(m, geom, 10 ** (-l_sl_db / 10)), rel=1e-9)
    # and in the main beam L_sl plays no part: G_r alone
    on = m.jamming_power(np.array([geom.azimuth[0]]), geom, jpos)[0]
    assert on == pytest.approx(_hand_47(m, geom, 1.0), rel=1e-9)


def test_pulse_compression_gains_the_echo_not_the_noise():
    """τ/τ' multiplies K_R [3] (targets and clutter alike); N0' = k T_s / τ' [19] stays."""
    from shipradar.sensors.radar import radar_constants

    plain = bare_scene(quiet_radar())
    coded = bare_scene(quiet_radar(transmitted_pulse_width_s=50e-6))  # 50:1 on τ' = 1 µs
    kp = radar_constants(plain, plain.platforms[0].radars[0])
    kc = radar_constants(coded, coded.platforms[0].radars[0])
    assert kc.k_r0 / kp.k_r0 == pytest.approx(50.0, rel=1e-12)
    assert kc.n0 == kp.n0 and kc.range_cell == kp.range_cell and kc.bandwidth == kp.bandwidth


@pytest.mark.parametrize(("radar", "fidelity", "line"), [
    ({"detector": "log"}, {},
     "platforms[0].radars[0].detector: the exact P_d (fidelity.pd_method: exact) is for a "
     "'square' detector; use fidelity.pd_method: seed for 'log', got 'log'"),
    ({"integrator": "single_loop"}, {},
     "platforms[0].radars[0].integrator: the exact P_d (fidelity.pd_method: exact) is for a "
     "'uniform' integrator; use fidelity.pd_method: seed for 'single_loop', got 'single_loop'"),
    ({"transmitted_pulse_width_s": 5e-7}, {},
     "platforms[0].radars[0]: transmitted_pulse_width_s must be >= pulse_width_s (1e-06 s), "
     "got 5e-07"),
    ({"transmitted_pulse_width_s": 3e-4}, {},
     "platforms[0].radars[0]: prf_hz * transmitted_pulse_width_s (the duty cycle) must be "
     "< 0.5, got 0.6"),
])
def test_radar_inputs_the_model_cannot_honour_are_refused(radar, fidelity, line):
    from shipradar.sim.world.scenario import ScenarioError

    with pytest.raises(ScenarioError) as err:
        bare_scene(quiet_radar(**radar), **fidelity)
    assert err.value.lines == [line]


def test_log_detector_runs_with_the_seed_method():
    s = bare_scene(quiet_radar(detector="log", integrator="single_loop"), pd_method="seed")
    p = s.platforms[0]
    m = DwellModel(s, p, p.radars[0], SceneTables())
    assert m.method == "seed"
