"""Range rate from the Doppler bank: the folded filter centre, aliasing, error statistics.

A C-band radar (λ = 5.35 cm) at PRF 2 kHz with a 16-filter DFT bank: the filter spacing is
λ f_r / (2 N) = 3.35 m/s, the unambiguous interval ±f_r λ/4 = ±26.8 m/s, and the declared 1σ
(λ/2) f_r / (N √12) = 0.966 m/s.
"""

import math

import numpy as np
import pytest

from shipradar.sim.dwell.model import DwellModel
from shipradar.sim.world.kinematics import LocalFrame, antenna_geometry
from shipradar.tables.scene import SceneTables

from .helpers import bare_scene, quiet_radar

N_FILTERS = 16
PRF = 2000.0


def _model(processor):
    target = {"id": "t", "waypoints": [{"east_m": 0, "north_m": 10e3, "altitude_m": 100}],
              "rcs": {"type": "constant", "sigma_m2": 1e4}, "swerling": 0}
    s = bare_scene(radar=quiet_radar(prf_hz=PRF, processor=processor), targets=[target])
    p = s.platforms[0]
    return s, DwellModel(s, p, p.radars[0], SceneTables())


@pytest.fixture(scope="module")
def bank():
    return _model({"type": "dft_bank", "n_coherent": N_FILTERS})


def _plots(scene_model, radial_mps, seed=0):
    """Process targets 10 km away, one per azimuth cell, each closing/receding at
    ``radial_mps``; every one is detected (σ = 10⁴ m², Swerling 0)."""
    s, m = scene_model
    radial = np.asarray(radial_mps, dtype=float)
    n = radial.size
    az = np.radians(np.arange(n) * 3.0 % 360.0 + 0.01 * (np.arange(n) // 120))
    pos = np.column_stack([10e3 * np.sin(az), 10e3 * np.cos(az), np.full(n, 100.0)])
    vel = np.column_stack([np.sin(az), np.cos(az), np.zeros(n)]) * radial[:, None]
    frame = LocalFrame(s.origin)
    geom = antenna_geometry(np.zeros(3), np.zeros(3), 20.0, pos, vel, frame)
    rows = np.zeros(n, dtype=int)
    batch = np.arange(n)  # never merged: each its own batch
    out = m.process_targets(geom, rows, np.zeros(n), pos, np.random.default_rng(seed),
                            batch=batch)
    assert out["range_m"].size == n
    return geom.radial_velocity, out


def test_declared_sigma_is_the_filter_width_over_root_12(bank):
    _, m = bank
    lam = m.wavelength
    assert m.range_rate_sigma_mps == pytest.approx(lam * PRF / (2 * N_FILTERS * math.sqrt(12)),
                                                   rel=1e-12)
    assert m.range_rate_sigma_mps == pytest.approx(0.9659, abs=1e-4)


def test_target_at_a_filter_centre_is_reported_there(bank):
    _, m = bank
    step = m.wavelength * PRF / (2 * N_FILTERS)
    k = np.arange(-7, 8)
    v_true, out = _plots(bank, k * step)
    # the slant geometry (100 m target, 20 m antenna) takes 1e-3 m/s off the line-of-sight
    # speed: still nearest to the same centre
    assert v_true == pytest.approx(k * step, abs=1e-2)
    assert out["range_rate_mps"] == pytest.approx(k * step, abs=1e-9)
    assert out["sigma_range_rate_mps"] == pytest.approx(m.range_rate_sigma_mps)
    # between centres: the nearest centre
    v_true, out = _plots(bank, k * step + 0.3 * step)
    assert out["range_rate_mps"] == pytest.approx(k * step, abs=1e-6)


def test_aliasing_beyond_a_quarter_prf_wavelength(bank):
    _, m = bank
    blind = m.wavelength * PRF / 2  # the first blind speed, twice the unambiguous limit
    limit = blind / 2
    v0 = np.array([-17.0, -3.0, 4.5, 12.0])
    for fold in (-2, -1, 1, 3):
        _, near = _plots(bank, v0)
        _, far = _plots(bank, v0 + fold * blind)
        assert far["range_rate_mps"] == pytest.approx(near["range_rate_mps"], abs=1e-6)
    # past +f_r λ/4 (by more than half a filter) a receding target reads as a fast closer,
    # a closer as a fast opener, and the blind speed as 0; the edge filter straddles ±limit
    step = m.wavelength * PRF / (2 * N_FILTERS)
    _, out = _plots(bank, [limit + 4.0, -limit - 4.0, blind, -blind, limit + 0.6])
    rr = out["range_rate_mps"]
    assert rr[0] == pytest.approx(-(limit - step), abs=1e-6)
    assert rr[1] == pytest.approx(limit - step, abs=1e-6)
    assert rr[2:4] == pytest.approx([0.0, 0.0], abs=1e-6)
    assert abs(rr[4]) == pytest.approx(limit, abs=1e-6)
    assert np.all(np.abs(rr) <= limit + 1e-9)


def test_error_statistics_match_the_declared_sigma(bank):
    _, m = bank
    rng = np.random.default_rng(17)
    v = rng.uniform(-25.0, 25.0, 3000)
    v_true, out = _plots(bank, v)
    err = out["range_rate_mps"] - v_true
    sigma = m.range_rate_sigma_mps
    n = err.size
    assert np.abs(err).max() <= math.sqrt(3) * sigma * (1 + 1e-9)  # half a filter width
    assert abs(err.mean()) < 4 * sigma / math.sqrt(n)
    # the standard deviation of a sample variance of a uniform: σ² √(0.8/n)
    assert err.std() == pytest.approx(sigma, rel=4 * 0.5 * math.sqrt(0.8 / n))


def test_mti_only_radar_reports_nan():
    scene_model = _model({"type": "mti", "mti_order": 2})
    _, out = _plots(scene_model, [10.0, -40.0])
    assert np.isnan(out["range_rate_mps"]).all() and np.isnan(out["sigma_range_rate_mps"]).all()
    _, m = scene_model
    fa = m.false_alarms.false_alarm_plots(np.array([1e3]), np.array([0.1]), np.array([0.0]),
                             np.random.default_rng(0))
    assert np.isnan(fa["range_rate_mps"]).all()


def test_noise_false_alarms_fall_uniformly_on_the_filter_centres(bank):
    _, m = bank
    rng = np.random.default_rng(3)
    n = 16000
    before = np.random.default_rng(3)
    fa = m.false_alarms.false_alarm_plots(np.full(n, 5e3), np.zeros(n), np.zeros(n), rng)
    step = m.wavelength * PRF / (2 * N_FILTERS)
    k = fa["range_rate_mps"] / step
    assert k == pytest.approx(np.round(k), abs=1e-9)
    counts = np.bincount(np.mod(np.round(k).astype(int), N_FILTERS), minlength=N_FILTERS)
    expected = n / N_FILTERS
    chi2 = ((counts - expected) ** 2 / expected).sum()
    assert chi2 < 37.7  # 15 degrees of freedom, p = 0.001
    # the Doppler draws come from a spawned child: the radar's own stream is unchanged
    before.random(n)
    assert rng.random() == before.random()


def test_clutter_motion_terms_follow_the_instantaneous_platform_velocity():
    """[34]-[35] with a turning ship: f1 from the velocity at the look, not the first leg."""
    radar = quiet_radar(prf_hz=PRF, processor={"type": "dft_bank", "n_coherent": N_FILTERS,
                                               "motion_compensated": True})
    s = bare_scene(radar=radar)
    ship = {"id": "ship", "radars": [radar],
            "waypoints": [{"time_s": 0, "east_m": 0, "north_m": 0},
                          {"time_s": 100, "east_m": 0, "north_m": 1000}]}
    s = s.model_copy(update={"platforms": [type(s.platforms[0]).model_validate(ship)]})
    m = DwellModel(s, s.platforms[0], s.platforms[0].radars[0], SceneTables())
    az = np.radians([0.0, 45.0, 90.0, 200.0])
    pos = np.column_stack([8e3 * np.sin(az), 8e3 * np.cos(az), np.zeros(4)])
    geom = antenna_geometry(np.zeros(3), np.zeros(3), 20.0, pos, np.zeros((4, 3)),
                            LocalFrame(s.origin))
    north = np.tile([0.0, 10.0, 0.0], (4, 1))
    east = np.tile([10.0, 0.0, 0.0], (4, 1))
    assert m.target_doppler_hz(geom, north) == pytest.approx(m.target_doppler_hz(geom),
                                                             rel=1e-12, abs=1e-9)
    from shipradar.sensors.sea_clutter import depression_angle_rad

    dep = depression_angle_rad(geom.ground_range, 20.0)
    fd = -2.0 * geom.radial_velocity / m.wavelength
    want = fd - 2.0 * 10.0 / m.wavelength * np.cos(az - np.pi / 2) * np.cos(dep)
    assert m.target_doppler_hz(geom, east) == pytest.approx(want, rel=1e-12, abs=1e-9)


def test_stonesoup_reader_exposes_a_range_rate_model():
    from stonesoup.types.array import StateVector
    from stonesoup.types.state import State

    from shipradar.sim.adapters.stonesoup_reader import (
        ShipradarDetectionReader,
        range_rate_detection,
    )

    from .test_stonesoup_reader import synthetic_stream

    frames = []
    for f in synthetic_stream(scans=2, other_sensor=False):
        from shipradar.sim.stream import protocol

        topic, t, p = protocol.decode(f)
        if topic == protocol.TOPIC_PLOTS:
            n = p["range_m"].size
            p = dict(p, range_rate_mps=np.full(n, -12.5), sigma_range_rate_mps=np.full(n, 0.8))
        frames.append(protocol.encode(topic, t, p))
    dets = [d for _, ds in ShipradarDetectionReader(source=frames) for d in ds]
    assert dets and all(d.metadata["range_rate_mps"] == -12.5 for d in dets)
    d3 = range_rate_detection(dets[0])
    assert d3.state_vector.shape == (3, 1) and float(d3.state_vector[2, 0]) == -12.5
    assert np.asarray(d3.measurement_model.noise_covar)[2, 2] == pytest.approx(0.64)
    # the model's range rate of a state closing on the sensor along the line of sight
    off = np.asarray(d3.measurement_model.translation_offset, float).ravel()
    x = State(StateVector([off[0] + 3000.0, -20.0, off[1] + 4000.0, 0.0]))
    z = d3.measurement_model.function(x, noise=False)
    assert float(z[2, 0]) == pytest.approx(-20.0 * 0.6, rel=1e-9)
    # an MTI-only plot (NaN) has no range-rate measurement
    nan = dets[0].__class__(dets[0].state_vector, timestamp=dets[0].timestamp,
                            measurement_model=dets[0].measurement_model,
                            metadata=dict(dets[0].metadata, range_rate_mps=math.nan))
    assert range_rate_detection(nan) is None
