"""Noise false alarms come at the rate the user asks, 1/t_fa (issue 23 item 5a).

The seed sets P_fa by [68]-[72] (0.69 false alarms per t_fa over N_ch N_rc decisions per
sweep) and draws N_cells P_fa per scan by [90] (N_cells over R_inst, no N_ch): on the shipped
radars the emitted rate was 0.46-1.15 / t_fa.  P_fa = 1/n' over the reported decisions and
the count over the same decisions give t_scan/t_fa per scan exactly
(``shipradar.sensors.detection`` and ``shipradar.sensors.false_alarms`` module notes).
"""

import math

import numpy as np
import pytest
from scipy import constants

from shipradar.sensors import detection, false_alarms
from shipradar.sim.dwell.model import DwellModel
from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream import protocol
from shipradar.sim.studies.montecarlo import poisson_interval
from shipradar.sim.world.scenario import load_scenario
from shipradar.tables.scene import SceneTables

from .helpers import ROOT, CaptureBus, bare_scene, quiet_radar

SHIPPED = sorted((ROOT / "scenarios").glob("*.yaml"))
#: Two-sided confidence of the Poisson intervals (exact, Garwood).
CONFIDENCE = 0.999


def _shipped_radars():
    out = []
    for path in SHIPPED:
        sc = load_scenario(path)
        for platform in sc.platforms:
            for radar in platform.radars:
                out.append(pytest.param(sc, platform, radar, id=f"{path.stem}-{radar.id}"))
    return out


def _seed_letter_rate(radar) -> float:
    """Noise false alarms per second by the seed's letter: [68] with 0.69 over N_ch N_rc,
    [90] N_cells P_fa over R_inst."""
    theta = math.radians(radar.beamwidth_az_deg)
    pfa = float(detection.pfa_from_false_alarm_time(
        radar.false_alarm_time_s, theta, radar.scan_period_s, radar.prf_hz, radar.pulse_width_s,
        n_channels=radar.n_channels, t_fa_definition="median"))
    n_cells = float(false_alarms.resolution_cells(
        radar.instrumented_range_m, theta, constants.c * radar.pulse_width_s / 2.0))
    return n_cells * pfa / radar.scan_period_s


@pytest.mark.parametrize("sc, platform, radar", _shipped_radars())
def test_shipped_radars_expect_one_false_alarm_per_t_fa(sc, platform, radar):
    model = DwellModel(sc, platform, radar, SceneTables())
    rate = model.noise_false_alarms_per_scan / radar.scan_period_s
    assert rate == pytest.approx(1.0 / radar.false_alarm_time_s, rel=1e-12)
    # the seed's letter was off by 0.46-1.15 on these radars (every one of them R_inst > c/2f_r,
    # so P_fa's gates are the seed's N_rc and only [68]'s 0.69 moves P_fa: x 1/0.69)
    ratio = _seed_letter_rate(radar) * radar.false_alarm_time_s
    assert 0.45 < ratio < 1.16 and abs(ratio - 1.0) > 0.15
    # the ratio in closed form (review: the band above alone would pass a factor-of-two
    # slip in either rate): the seed's P_fa = 0.69 t_scan / (t_fa N_ch N_rc 2π/θ_b) with
    # N_rc = 1/(f_r τ) - 2, and N_cells = 2π R_inst / (θ_b C_R) [90], so
    # ratio = 0.69 (R_inst / C_R) / (N_ch N_rc), exact up to rounding
    n_rc = 1.0 / (radar.prf_hz * radar.pulse_width_s) - 2.0
    c_r = constants.c * radar.pulse_width_s / 2.0
    assert ratio == pytest.approx(
        0.69 * (radar.instrumented_range_m / c_r) / (radar.n_channels * n_rc), rel=1e-9)
    assert model.pfa == pytest.approx(float(detection.pfa_from_false_alarm_time(
        radar.false_alarm_time_s, math.radians(radar.beamwidth_az_deg), radar.scan_period_s,
        radar.prf_hz, radar.pulse_width_s, n_channels=radar.n_channels,
        t_fa_definition="median")) / detection.LN2_SEED, rel=1e-12)


@pytest.mark.parametrize("sc, platform, radar", _shipped_radars())
def test_shipped_radars_emit_noise_false_alarms_at_one_per_t_fa(sc, platform, radar):
    """Seeded: ~4000 noise false alarms drawn by the radar's own generator over many scans;
    the exact 99.9 % Poisson interval of the rate holds 1/t_fa and not the seed's rate (a
    Bernoulli count per scan, as here, has less variance than Poisson: the test is
    conservative)."""
    model = DwellModel(sc, platform, radar, SceneTables())
    t_fa, t_scan = radar.false_alarm_time_s, radar.scan_period_s
    revolutions = int(4000 * t_fa / t_scan)
    fa = model.false_alarms.noise_false_alarms(np.random.default_rng(20230), revolutions)
    k = fa["range_m"].size
    lo, hi = poisson_interval(k, revolutions * t_scan, confidence=CONFIDENCE)
    assert lo <= 1.0 / t_fa <= hi
    assert not lo <= _seed_letter_rate(radar) <= hi
    # reported inside the instrumented disc
    assert np.all((fa["range_m"] >= 0) & (fa["range_m"] <= radar.instrumented_range_m))


@pytest.mark.parametrize("r_inst_m", [60e3, 150e3])
def test_running_scene_emits_false_alarms_at_one_per_t_fa(r_inst_m):
    """Through the engine and the bus: noise plots per second of a 300 s run against 1/t_fa,
    with R_inst inside the unambiguous range (75 km at 2 kHz: P_fa counts the 400 gates
    within R_inst, not the 498 of the interpulse period) and beyond it (every gate)."""
    t_fa, scans = 0.25, 300
    radar = quiet_radar(false_alarm_time_s=t_fa, instrumented_range_m=r_inst_m)
    s = bare_scene(radar, duration_s=scans * 1.0, seed=11)
    bus = CaptureBus()
    sim = Simulation(s, bus=bus, tables=SceneTables())
    sim.run()
    k = sum(p["range_m"].size for _, p in bus.of(protocol.TOPIC_PLOTS))
    assert sim.stats.noise_false_alarms == k  # no target: every plot is a false alarm
    lo, hi = poisson_interval(k, s.duration_s, confidence=CONFIDENCE)
    assert lo <= 1.0 / t_fa <= hi
    r = s.platforms[0].radars[0]
    assert not lo <= _seed_letter_rate(r) <= hi


def test_reported_range_cells_by_hand():
    # f_r = 2 kHz, τ' = 1 µs: N_rc = 500 - 2 = 498 gates, C_R = 149.9 m
    c_r = constants.c * 1e-6 / 2.0
    assert float(detection.reported_range_cells(2e3, 1e-6)) == pytest.approx(498.0, rel=1e-12)
    assert float(detection.reported_range_cells(2e3, 1e-6, 60e3)) == pytest.approx(
        60e3 / c_r, rel=1e-12)  # 400.3 gates inside R_inst
    assert float(detection.reported_range_cells(2e3, 1e-6, 150e3)) == pytest.approx(
        498.0, rel=1e-12)  # R_inst beyond c/(2 f_r) = 74.9 km: the interpulse period's gates
    with pytest.raises(ValueError, match="instrumented_range_m"):
        detection.reported_range_cells(2e3, 1e-6, 0.0)


def test_noise_false_alarms_per_scan_is_t_scan_over_t_fa():
    """η = N_ch N_rep (2π/θ_b) P_fa with P_fa = 1/n' is t_scan/t_fa for any radar (vectorized
    over R_inst across the unambiguous range, N_ch and t_fa)."""
    theta, t_scan, prf, tau = np.deg2rad(1.5), 2.0, 1e3, 1e-6
    r_inst = np.array([[5e3], [100e3], [149.8e3], [400e3]])
    n_ch = np.array([1, 2, 5])
    t_fa = 30.0
    pfa = detection.pfa_from_false_alarm_time(t_fa, theta, t_scan, prf, tau, n_ch,
                                              instrumented_range_m=r_inst)
    eta = false_alarms.noise_false_alarms_per_scan(pfa, theta, prf, tau, r_inst, n_ch)
    np.testing.assert_allclose(eta, t_scan / t_fa, rtol=1e-12)
    with pytest.raises(ValueError, match="pfa"):
        false_alarms.noise_false_alarms_per_scan(1.5, theta, prf, tau, 1e4)
