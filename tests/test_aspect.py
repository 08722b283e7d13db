"""Aspect and jammer geometry at each look, end to end (issue 40).

The missile model [15] and an RCS table holding the same law against the angle off the nose
give the same S/I through the whole engine; a fast jammer's bearing at each look is checked
against a bearing computed independently of the engine's geometry code.
"""

from __future__ import annotations

import numpy as np
import pytest

import shipradar
from shipradar.sensors import rcs
from tests.helpers import bare_scene, quiet_radar

SIGMA_N, LENGTH, DIAMETER = 0.1, 4.7, 0.35


def _law_15(psi_rad):
    """[15] folded fore-aft, written out: σ_n (|cos ψ| + 4L/(πD) |sin ψ|) [m²]."""
    return SIGMA_N * (np.abs(np.cos(psi_rad))
                      + 4 * LENGTH / (np.pi * DIAMETER) * np.abs(np.sin(psi_rad)))


def _receding_targets(model: dict) -> list[dict]:
    """Missiles seen from behind while they climb or dive, at four bearings (never merged)."""
    legs = [  # start (east, north, up) [m], velocity [m/s] over 16 s
        ((0.0, 20e3, 4.5e3), (0.0, 150.0, -260.0)),  # issue 40: receding, diving
        ((10e3, 0.0, 1e3), (150.0, 0.0, 260.0)),     # receding, climbing
        ((0.0, -12e3, 200.0), (60.0, -200.0, 150.0)),  # receding, crossing, climbing
        ((-9e3, 4e3, 4e3), (-230.0, 60.0, -120.0)),  # receding, crossing, diving
    ]
    out = []
    for i, (p, v) in enumerate(legs):
        end = [p[k] + 16.0 * v[k] for k in range(3)]
        out.append({"id": f"m{i}", "kind": "missile", "swerling": 0, "rcs": model,
                    "waypoints": [
                        {"time_s": 0, "east_m": p[0], "north_m": p[1], "altitude_m": p[2]},
                        {"time_s": 16, "east_m": end[0], "north_m": end[1],
                         "altitude_m": end[2]}]})
    return out


def _look_snr_db(scenario) -> np.ndarray:
    """S/I of each target's last look at every end of scan (truth[targets]) [dB]."""
    rows = [p["snr_db"] for topic, _, p in shipradar.messages(scenario)
            if topic == "truth" and "snr_db" in p]
    return np.array(rows)


def test_missile_model_equals_a_table_of_its_law_against_the_off_nose_angle():
    """The same receding, climbing and diving missiles with the ``missile`` model and with a
    ``table`` holding [15] against the angle off the nose every 0.1°: the same S/I at every
    look (the table's linear interpolation between 0.1° nodes: < 1e-4 dB)."""
    aspect = np.round(np.linspace(0.0, 180.0, 1801), 6)
    table = {"type": "table", "aspect_deg": aspect.tolist(),
             "sigma_m2": _law_15(np.radians(aspect)).tolist()}
    missile = {"type": "missile", "sigma_nose_m2": SIGMA_N, "length_m": LENGTH,
               "diameter_m": DIAMETER}
    radar = quiet_radar(instrumented_range_m=40e3)
    a = _look_snr_db(bare_scene(radar, _receding_targets(missile), duration_s=15.0))
    b = _look_snr_db(bare_scene(radar, _receding_targets(table), duration_s=15.0))
    assert a.shape == (15, 4) and np.isfinite(a[1:]).all()
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-4, equal_nan=True)


def test_the_scene_is_one_where_the_printed_combination_is_wrong():
    """The scene above is not a trivial one: [15] as printed (ψ = √(θ'² + φ'²)) is off by
    several dB at every start of a leg, where the model now agrees with the table."""
    for t in _receding_targets({}):
        p, q = t["waypoints"]
        los = np.array([p["east_m"], p["north_m"], p["altitude_m"]])
        vel = (np.array([q["east_m"], q["north_m"], q["altitude_m"]]) - los) / 16.0
        theta, phi = rcs.aspect_angles(los, vel)
        true = rcs.missile_rcs(SIGMA_N, LENGTH, DIAMETER, theta, phi)
        seed = rcs.missile_rcs(SIGMA_N, LENGTH, DIAMETER, theta, phi, aspect="seed")
        assert 10 * np.log10(true / seed) > 2.5  # the printed ψ passes π: σ toward σ_n
        assert true == pytest.approx(_law_15(rcs.off_nose_angle(theta, phi)), rel=1e-12)


# --------------------------------------------------------------------------- moving jammer
#: A jammer crossing at 250 m/s, 20 km north, 1 km up, over 30 s (issue 40): its bearing
#: sweeps ±10.6°, 3.6° in half a 6 rpm revolution.
JAM_T = 30.0
JAM_START = np.array([-3750.0, 20e3, 1e3])
JAM_VEL = np.array([250.0, 0.0, 0.0])
JAM_POWER_W, JAM_GAIN_DB, JAM_BANDWIDTH_HZ = 100.0, 3.0, 1e8


def _jammer_scene(with_jammer: bool):
    """6 rpm radar, a 2° Gaussian beam with a 40 dB jamming floor; targets at 17 km on fixed
    bearings across the jammer's sweep (two beamwidths apart: never in one azimuth cell), and
    three flying in formation at fixed bearings from the jammer's line of sight (0°, +1.5°,
    -1°: their tracks are the jammer's, scaled and turned about the radar)."""
    radar = quiet_radar(rotation_rpm=6, pattern_az={"type": "gaussian", "sidelobe_db": 40.0})
    targets = []
    for i, b in enumerate(np.radians([-9.0, -5.0, -1.0, 3.0, 7.0])):
        p = {"east_m": 17e3 * np.sin(b), "north_m": 17e3 * np.cos(b), "altitude_m": 100.0}
        targets.append({"id": f"t{i}", "rcs": {"type": "constant", "sigma_m2": 10.0},
                        "swerling": 0,
                        "waypoints": [{"time_s": 0, **p}, {"time_s": JAM_T, **p}]})
    end = JAM_START + JAM_T * JAM_VEL
    for k, turn in ((0.6, 0.0), (0.75, 1.5), (0.45, -1.0)):
        c, s = np.cos(np.radians(turn)), np.sin(np.radians(turn))
        targets.append({"id": f"escort{len(targets)}", "swerling": 0,
                        "rcs": {"type": "constant", "sigma_m2": 10.0}, "waypoints": [
                            {"time_s": t, "east_m": k * (c * e + s * n),
                             "north_m": k * (-s * e + c * n), "altitude_m": 100.0}
                            for t, (e, n) in ((0, JAM_START[:2]), (JAM_T, end[:2]))]})
    d = bare_scene(radar, targets, duration_s=JAM_T).model_dump(mode="json")
    if with_jammer:
        d["jammers"] = [{"id": "j", "power_w": JAM_POWER_W, "gain_db": JAM_GAIN_DB,
                         "bandwidth_hz": JAM_BANDWIDTH_HZ, "waypoints": [
                             {"time_s": 0, "east_m": JAM_START[0], "north_m": JAM_START[1],
                              "altitude_m": JAM_START[2]},
                             {"time_s": JAM_T, "east_m": end[0], "north_m": end[1],
                              "altitude_m": end[2]}]}]
    from shipradar.sim.world.scenario import parse_scenario

    return parse_scenario(d)


def _looks(scenario):
    """(look time [s], S/I [dB]) of every target's look in every revolution (truth)."""
    seen: dict[tuple[int, float], float] = {}
    for topic, _, p in shipradar.messages(scenario):
        if topic == "truth" and "snr_db" in p:
            for i, (t, s) in enumerate(zip(p["look_time_s"], p["snr_db"], strict=True)):
                if np.isfinite(t):
                    seen[(i, float(t))] = float(s)
    return seen


def test_a_fast_crossing_jammer_is_seen_where_it_is_at_each_look():
    """The jamming at every look against [47] by hand with the jammer's bearing and range at
    the look's own time, computed here on the flat local plane (atan2 of its straight-line
    track): a jammer 250 m/s across at 20 km, 6 rpm.  The engine's P_j is read from the
    stream: S/I without the jammer over S/I with it is (N + J)/N."""
    from shipradar.sensors import antenna
    from shipradar.sim.dwell.model import DwellModel
    from shipradar.tables.scene import SceneTables

    jammed, clear = _jammer_scene(True), _jammer_scene(False)
    a, b = _looks(jammed), _looks(clear)
    assert a.keys() == b.keys() and len(a) >= 20
    p = jammed.platforms[0]
    m = DwellModel(jammed, p, p.radars[0], SceneTables())
    errors = []
    worst_frozen = 0.0
    for (_, t), si_jammed in a.items():
        j_over_n = 10 ** ((b[(_, t)] - si_jammed) / 10) - 1.0
        pos = JAM_START + t * JAM_VEL
        bearing = np.arctan2(pos[0], pos[1])
        slant = np.sqrt(pos[0] ** 2 + pos[1] ** 2 + (pos[2] - 20.0) ** 2)
        beam = _target_bearing(jammed, _, t)
        g2 = max(antenna.gaussian_directivity(beam - bearing, np.radians(2.0)) ** 2, 1e-4)
        hand = (JAM_POWER_W * 10 ** (JAM_GAIN_DB / 10) * m.gain * g2
                * min(m.bandwidth / JAM_BANDWIDTH_HZ, 1.0) * m.wavelength**2
                / ((4 * np.pi) ** 2 * slant**2 * m.l_r))
        errors.append(10 * np.log10(j_over_n * m.n0 / hand))
        # the jammer frozen at the middle of the look's revolution, as before issue 40
        mid = JAM_START + (10.0 * (t // 10.0) + 5.0) * JAM_VEL
        g2_mid = max(antenna.gaussian_directivity(
            beam - np.arctan2(mid[0], mid[1]), np.radians(2.0)) ** 2, 1e-4)
        worst_frozen = max(worst_frozen, abs(10 * np.log10(g2_mid / g2)))
    np.testing.assert_allclose(errors, 0.0, atol=0.02)
    assert worst_frozen > 20.0  # the scene tells the two apart


def _target_bearing(scenario, i: int, t: float) -> float:
    """Bearing [rad] of target ``i`` at ``t`` on the flat local plane (its straight track)."""
    p, q = scenario.targets[i].waypoints
    w = (t - p.time_s) / (q.time_s - p.time_s)
    return float(np.arctan2(p.east_m + w * (q.east_m - p.east_m),
                            p.north_m + w * (q.north_m - p.north_m)))


# --------------------------------------------------------------------------- radio horizon
@pytest.mark.parametrize("mode", ["free_space", "two_ray"])
def test_a_jammer_beyond_the_horizon_is_propagated_as_a_target_there(mode):
    """Free space has no earth, for jammers as for targets: a jammer 50 km out at 10 m, past
    the 31.5 km radio horizon of a 20 m antenna, keeps F_j = 1 (isotropic elevation pattern),
    and so does a target there (it is seen: the truth's ``in_coverage`` is a separate,
    geometric test).  The two-ray model puts both in the earth's shadow, by the same F."""
    from shipradar.sim.dwell.model import DwellModel
    from shipradar.sim.world.kinematics import LocalFrame, antenna_geometry
    from shipradar.sim.world.scenario import parse_scenario
    from shipradar.tables.scene import SceneTables

    d = bare_scene(quiet_radar(), propagation=mode).model_dump(mode="json")
    d["jammers"] = [{"id": "j", "waypoints": [{"east_m": 0.0, "north_m": 50e3,
                                               "altitude_m": 10.0}],
                     "power_w": 100.0, "gain_db": 10.0, "bandwidth_hz": 1e8}]
    s = parse_scenario(d)
    p = s.platforms[0]
    m = DwellModel(s, p, p.radars[0], SceneTables())
    jpos = np.array([[0.0, 50e3, 10.0]])
    geom = antenna_geometry(np.zeros((1, 3)), np.zeros((1, 3)), 20.0, jpos, np.zeros((1, 3)),
                            LocalFrame(s.origin))
    a_e = 4.0 / 3.0 * 6371e3
    assert geom.ground_range[0] > np.sqrt(2 * a_e * 20.0) + np.sqrt(2 * a_e * 10.0)
    p_j = m.jamming_power(np.array([geom.azimuth[0]]), geom, jpos)[0]
    free = (100.0 * 10.0 * m.gain * min(m.bandwidth / 1e8, 1.0) * m.wavelength**2
            / ((4 * np.pi) ** 2 * geom.slant_range[0] ** 2 * m.l_r))  # [47], F_j = 1
    f_target, _ = m.propagation_factor(geom.ground_range, np.array([10.0]), geom.elevation)
    assert p_j / free == pytest.approx(float(f_target[0]) ** 2, rel=1e-9)
    if mode == "free_space":
        assert p_j == pytest.approx(free, rel=1e-9)
    else:
        assert 10 * np.log10(p_j / free) < -20.0  # diffraction, deep past the horizon
