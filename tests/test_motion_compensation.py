"""Motion compensation ([34]-[35]) shifts the target's Doppler as it shifts the clutter's.

A motion-compensated processor sets the sea-clutter mean to 0 Hz by removing the platform
Doppler f1 [34] from everything it receives; the target's Doppler relative to the clutter,
which indexes I_F and picks the Doppler filter, must then be the same as without
compensation, up to the wave-drift term of [35].
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shipradar.sensors import sea_clutter as sc
from shipradar.sim.dwell.model import DwellModel
from shipradar.sim.world.kinematics import LocalFrame, antenna_geometry
from shipradar.tables.scene import SceneTables, load_scene_tables
from tests.helpers import moving_ship_scene, quiet_radar

WIND_FROM_DEG = 30.0
SHIP_SPEED = 8.0  # [m/s], due north


def _scene(compensated: bool, *, speed=SHIP_SPEED, course_deg=0.0, clutter=True,
           processor=None):
    radar = quiet_radar(processor={"type": "mti", "mti_order": 2,
                                   "motion_compensated": compensated, **(processor or {})},
                        instrumented_range_m=20000)
    return moving_ship_scene(radar, name="mc", duration_s=10.0, seed=1, speed_mps=speed,
                             course_deg=course_deg, wind_speed_mps=8.0,
                             wind_from_deg=WIND_FROM_DEG, clutter=clutter)


def _model(scenario, tables=None):
    p = scenario.platforms[0]
    return DwellModel(scenario, p, p.radars[0], tables if tables is not None else SceneTables())


def _geometry(scenario, ship_vel, target_enu, target_vel):
    frame = LocalFrame(scenario.origin)
    return antenna_geometry(np.zeros(3), ship_vel, scenario.platforms[0].radars[0]
                            .antenna_height_m, np.asarray(target_enu, float),
                            np.asarray(target_vel, float), frame)


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    """The same MTI radar on the same moving ship, with and without compensation, with its
    real sea-clutter map and I_F table (a private table cache)."""
    import os

    old = os.environ.get("SHIPRADAR_TABLES")
    os.environ["SHIPRADAR_TABLES"] = str(tmp_path_factory.mktemp("tables"))
    try:
        out = {}
        for comp in (True, False):
            s = _scene(comp)
            out[comp] = (s, _model(s, load_scene_tables(s)))
        return out
    finally:
        if old is None:
            del os.environ["SHIPRADAR_TABLES"]
        else:
            os.environ["SHIPRADAR_TABLES"] = old


def _drift_hz(model, azimuth):
    """The wave-drift term of [35] at a look azimuth: μ_c(uncompensated) - f1."""
    phi = azimuth - math.radians(WIND_FROM_DEG)
    return 2.0 * sc.WAVE_DRIFT_SPEED_MPS / model.wavelength * np.cos(phi)


def _targets():
    az = np.radians([0.0, 45.0, 90.0, 170.0, 250.0, 330.0])
    r = np.array([3e3, 5e3, 8e3, 12e3, 6e3, 15e3])
    enu = np.stack([r * np.sin(az), r * np.cos(az), np.full(az.size, 5.0)], axis=1)
    return az, enu


def test_relative_doppler_same_with_and_without_compensation(models):
    (s, comp), (_, raw) = models[True], models[False]
    ship = np.array([0.0, SHIP_SPEED, 0.0])
    az, enu = _targets()
    vel = np.array([[0, 0, 0], [100, -50, 0], [-250, 0, 0], [0, 300, 0], [20, 20, 0],
                    [0, -5, 0]], float)
    g = _geometry(s, ship, enu, vel)
    pos = np.asarray(enu)
    rel_c = comp.clutter_at(g, pos, None)["doppler_relative_hz"]
    rel_u = raw.clutter_at(g, pos, None)["doppler_relative_hz"]
    # compensated - uncompensated = the wave drift (the only part of μ_c that is not f1);
    # 0.5 Hz allows the clutter map's 1° x 100 m interpolation of μ_c
    np.testing.assert_allclose(rel_c - rel_u, _drift_hz(comp, g.azimuth), atol=0.5)


def test_sea_stationary_target_sits_in_the_mti_notch_in_both_modes(models):
    """A buoy at rest on the sea, ship at 8 m/s, C band: f_d relative to the clutter is
    within the wave drift of 0 Hz in both modes (f1 alone would be 2 v/λ ≈ 299 Hz)."""
    ship = np.array([0.0, SHIP_SPEED, 0.0])
    for comp in (True, False):
        s, m = models[comp]
        g = _geometry(s, ship, [[0.0, 4000.0, 0.0]], [[0.0, 0.0, 0.0]])
        c = m.clutter_at(g, np.array([[0.0, 4000.0, 0.0]]), None)
        drift = abs(float(_drift_hz(m, g.azimuth)[0]))
        assert abs(float(c["doppler_relative_hz"][0])) <= drift + 0.5
        # the 3-pulse MTI puts it deep in its notch: no improvement, a loss
        assert 10 * np.log10(c["improvement"][0]) < -10.0
    f1 = 2 * SHIP_SPEED / m.wavelength
    assert f1 == pytest.approx(298.9, abs=0.5)  # the Doppler the old code left in


def test_crossing_target_in_the_notch_radial_target_outside(models):
    """Seen from the moving ship, a target crossing the line of sight at 250 m/s has no
    radial speed relative to the sea: it is in the clutter notch in both modes; the same
    target flying down the line of sight is not, and both modes agree on its I_F."""
    ship = np.array([0.0, SHIP_SPEED, 0.0])
    pos = np.array([[0.0, 6000.0, 30.0]])
    for comp in (True, False):
        s, m = models[comp]
        crossing = m.clutter_at(_geometry(s, ship, pos, [[250.0, 0.0, 0.0]]), pos, None)
        assert 10 * np.log10(crossing["improvement"][0]) < -10.0
    i_f = {}
    for comp in (True, False):
        s, m = models[comp]
        g = _geometry(s, ship, pos, [[0.0, -37.0, 0.0]])  # inbound at 37 m/s
        i_f[comp] = 10 * np.log10(m.clutter_at(g, pos, None)["improvement"][0])
    assert i_f[True] > 3.0
    # same relative Doppler up to the drift (1/λ ≈ 19 Hz at this azimuth's cos φ): the
    # MTI response near its peak differs by well under 3 dB
    assert i_f[True] == pytest.approx(i_f[False], abs=3.0)


def test_uncompensated_radar_does_not_shift_the_target():
    s = _scene(False, clutter=False)
    m = _model(s)
    g = _geometry(s, np.array([0.0, SHIP_SPEED, 0.0]), [[0.0, 5000.0, 0.0]], [[0.0, 0.0, 0.0]])
    assert m.target_doppler_hz(g)[0] == pytest.approx(-2 * g.radial_velocity[0] / m.wavelength,
                                                      rel=1e-12)


@settings(max_examples=40, deadline=None)
@given(speed=st.floats(0.5, 20.0), course=st.floats(0.0, 359.0),
       az_deg=st.floats(0.0, 359.9), r_km=st.floats(0.5, 19.0),
       tv=st.tuples(st.floats(-300, 300), st.floats(-300, 300)))
def test_property_relative_doppler_invariant_up_to_wave_drift(speed, course, az_deg, r_km,
                                                              tv):
    """For random ship and target velocities and azimuths, (f_d - μ_c) with compensation
    equals (f_d - μ_c) without it, plus the wave-drift term of [35]; μ_c as the clutter
    map builds it ([34]-[35] at the patch's depression angle)."""
    az = math.radians(az_deg)
    pos = np.array([[1e3 * r_km * math.sin(az), 1e3 * r_km * math.cos(az), 10.0]])
    c = math.radians(course)
    ship = np.array([speed * math.sin(c), speed * math.cos(c), 0.0])
    rel = {}
    for comp in (True, False):
        s = _scene(comp, speed=speed, course_deg=course, clutter=False)
        m = _model(s)
        g = _geometry(s, ship, pos, [[tv[0], tv[1], 0.0]])
        depression = sc.depression_angle_rad(g.ground_range, m.radar.antenna_height_m)
        f1 = sc.platform_doppler_hz(speed, g.azimuth - c, depression, m.wavelength)
        phi = g.azimuth - math.radians(WIND_FROM_DEG)
        mu = sc.mean_clutter_doppler_hz(f1, phi, m.wavelength, motion_compensated=comp)
        rel[comp] = float((m.target_doppler_hz(g) - mu)[0])
        drift = float(_drift_hz(m, g.azimuth)[0])
    assert rel[True] - rel[False] == pytest.approx(drift, abs=1e-6)
