"""Target cross section: missile model [15], aspect angles from geometry, RCS tables."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from shipradar.sensors import rcs

SIGMA_N, LENGTH, DIAMETER = 0.1, 5.0, 0.35
BROADSIDE = SIGMA_N * 4 * LENGTH / (np.pi * DIAMETER)


def test_nose_on_and_broadside_values():
    assert rcs.missile_rcs(SIGMA_N, LENGTH, DIAMETER, 0.0, 0.0) == pytest.approx(SIGMA_N, rel=1e-15)
    for theta, phi in ((np.pi / 2, 0.0), (-np.pi / 2, 0.0), (0.0, np.pi / 2), (0.0, -np.pi / 2)):
        assert rcs.missile_rcs(SIGMA_N, LENGTH, DIAMETER, theta, phi) == pytest.approx(
            BROADSIDE, rel=1e-12
        )


def test_seed_formula_inside_ninety_degrees():
    psi = np.deg2rad(np.array([10.0, 30.0, 60.0, 89.0]))
    expected = SIGMA_N * (np.cos(psi) + 4 * LENGTH / (np.pi * DIAMETER) * np.sin(psi))
    # [15] as printed: split ψ between θ' and φ' (ψ = sqrt(θ'² + φ'²)) in a 3-4-5 ratio
    theta, phi = 0.6 * psi, 0.8 * psi
    assert rcs.missile_rcs(SIGMA_N, LENGTH, DIAMETER, theta, phi, aspect="seed") == (
        pytest.approx(expected, rel=1e-12))
    # the true cone angle: θ' and φ' with cos θ' cos φ' = cos ψ (spherical cosine law)
    phi = 0.5 * psi
    theta = np.arccos(np.cos(psi) / np.cos(phi))
    assert rcs.missile_rcs(SIGMA_N, LENGTH, DIAMETER, theta, phi) == pytest.approx(
        expected, rel=1e-12)


@pytest.mark.parametrize("aspect", ["off_nose", "seed"])
def test_the_two_aspects_agree_where_either_angle_is_zero(aspect):
    a = np.deg2rad(np.linspace(-180.0, 180.0, 73))
    ref = SIGMA_N * (np.abs(np.cos(a)) + 4 * LENGTH / (np.pi * DIAMETER) * np.abs(np.sin(a)))
    assert rcs.missile_rcs(SIGMA_N, LENGTH, DIAMETER, a, 0.0, aspect=aspect) == pytest.approx(
        ref, rel=1e-12)
    half = a[np.abs(a) <= np.pi / 2]  # φ' lives in [-π/2, π/2]
    assert rcs.missile_rcs(SIGMA_N, LENGTH, DIAMETER, 0.0, half, aspect=aspect) == (
        pytest.approx(ref[np.abs(a) <= np.pi / 2], rel=1e-12))
    with pytest.raises(ValueError, match="aspect"):
        rcs.missile_rcs(SIGMA_N, LENGTH, DIAMETER, 0.0, 0.0, aspect="sqrt")  # type: ignore[arg-type]


def _hand_15(sigma_n, length, diameter, psi):
    """[15] folded fore-aft, written out: σ_n (|cos ψ| + 4L/(πD) |sin ψ|) [m²]."""
    return sigma_n * (abs(np.cos(psi)) + 4 * length / (np.pi * diameter) * abs(np.sin(psi)))


@pytest.mark.parametrize(("los", "vel", "psi_deg"), [
    # issue 40: 10 km north, on the radar's horizon, flying away at 150 m/s and diving at
    # 260 m/s: the nose points 60° below the horizontal away from the radar, 120° off it
    ([0.0, 10e3, 0.0], [0.0, 150.0, -260.0], 120.0),
    # the same, climbing: 120° too
    ([0.0, 10e3, 0.0], [0.0, 150.0, 260.0], 120.0),
    # 3 km up, seen from the radar: the dot product gives the angle (103.3°)
    ([0.0, 10e3, 3e3], [0.0, 150.0, -260.0], None),
    ([0.0, 10e3, 3e3], [0.0, 150.0, 260.0], None),
    # receding and crossing, climbing steeply, off to the side
    ([4e3, 9e3, 1e3], [-80.0, 200.0, 300.0], None),
    ([-7e3, 2e3, 500.0], [-250.0, 20.0, -90.0], None),
])
def test_receding_climbs_and_dives_use_the_true_angle_off_the_nose(los, vel, psi_deg):
    """A receding target that climbs or dives: σ at the angle between its velocity and the
    direction to the radar (a dot product, independent of the aspect-angle code)."""
    los, vel = np.array(los), np.array(vel)
    to_radar = -los / np.linalg.norm(los)
    psi = np.arccos(np.dot(vel, to_radar) / np.linalg.norm(vel))
    if psi_deg is not None:
        assert np.degrees(psi) == pytest.approx(psi_deg, abs=0.02)  # 260/150 ≈ tan 60°
    assert psi > np.pi / 2  # receding
    theta, phi = rcs.aspect_angles(los, vel)
    sigma = rcs.missile_rcs(0.1, 4.7, 0.35, theta, phi)
    assert sigma == pytest.approx(_hand_15(0.1, 4.7, 0.35, psi), rel=1e-12)


@settings(max_examples=300, deadline=None)
@given(
    los=st.lists(st.floats(-1e5, 1e5), min_size=3, max_size=3),
    vel=st.lists(st.floats(-1e3, 1e3), min_size=3, max_size=3),
    ratio=st.floats(1.0, 50.0),
)
@example(los=[943.0, 282.375, 282.375], vel=[943.0, 282.375, 282.375], ratio=38.0)  # tail-on
def test_missile_rcs_is_15_at_the_angle_between_velocity_and_radar(los, vel, ratio):
    """Any geometry, receding, climbing, diving or crossing: σ is [15] at the angle between
    the velocity and the direction to the radar (from the vectors alone), as an RCS table
    reads it."""
    los, vel = np.array(los), np.array(vel)
    if np.linalg.norm(los) < 1.0 or np.linalg.norm(vel) < 1e-3:
        return
    # atan2 of the cross and dot products: well conditioned at 0 and π (arccos is not)
    psi = np.arctan2(np.linalg.norm(np.cross(vel, -los)), np.dot(vel, -los))
    theta, phi = rcs.aspect_angles(los, vel)
    diameter = 0.3
    length = ratio * diameter
    assert rcs.missile_rcs(1.0, length, diameter, theta, phi) == pytest.approx(
        _hand_15(1.0, length, diameter, psi), rel=1e-6, abs=1e-6)


def test_issue_40_diving_missile_against_the_printed_combination():
    """The issue's numbers: 1.85 dBsm at 120° off the nose; [15] as printed gave -4.11."""
    theta, phi = rcs.aspect_angles(np.array([0.0, 10e3, 0.0]), np.array([0.0, 150.0, -260.0]))
    true_db = 10 * np.log10(rcs.missile_rcs(0.1, 4.7, 0.35, theta, phi))
    seed_db = 10 * np.log10(rcs.missile_rcs(0.1, 4.7, 0.35, theta, phi, aspect="seed"))
    assert true_db == pytest.approx(1.85, abs=0.005)
    assert seed_db == pytest.approx(-4.11, abs=0.005)


def test_beyond_ninety_degrees_folds_to_tail_symmetric_aspect():
    psi = np.deg2rad(np.array([100.0, 135.0, 170.0, 180.0]))
    assert rcs.missile_rcs(SIGMA_N, LENGTH, DIAMETER, psi, 0.0) == pytest.approx(
        rcs.missile_rcs(SIGMA_N, LENGTH, DIAMETER, np.pi - psi, 0.0), rel=1e-12
    )
    # Tail-on equals nose-on, and [15] as printed would have been negative there.
    assert rcs.missile_rcs(SIGMA_N, LENGTH, DIAMETER, np.pi, 0.0) == pytest.approx(
        SIGMA_N, rel=1e-12
    )
    assert SIGMA_N * (np.cos(np.pi) + 0.0) < 0.0


@settings(max_examples=100, deadline=None)
@given(
    theta=st.floats(-np.pi, np.pi),
    phi=st.floats(-np.pi / 2, np.pi / 2),
    ratio=st.floats(1.0, 100.0),
)
def test_missile_rcs_symmetric_positive_bounded(theta, phi, ratio):
    length, diameter = ratio * 0.1, 0.1
    s = rcs.missile_rcs(1.0, length, diameter, theta, phi)
    assert np.isfinite(s)
    k = 4 * length / (np.pi * diameter)
    # |cos| + k|sin| lies between min(1, k) and sqrt(1 + k²).
    assert min(1.0, k) - 1e-12 <= s <= np.hypot(1.0, k) + 1e-12
    for t2, p2 in ((-theta, phi), (theta, -phi), (-theta, -phi)):
        assert rcs.missile_rcs(1.0, length, diameter, t2, p2) == pytest.approx(s, rel=1e-12)


def test_aspect_angles_from_geometry():
    # Radar at the origin, target 10 km north.
    los = np.array([[0.0, 10e3, 0.0]] * 5)
    vel = np.array(
        [
            [0.0, -300.0, 0.0],  # flying at the radar: nose-on
            [0.0, 300.0, 0.0],  # flying away: tail-on
            [300.0, 0.0, 0.0],  # flying east: radar on its right, broadside
            [0.0, 0.0, 300.0],  # climbing vertically: radar 90° off the nose
            [0.0, -300.0, -300.0],  # diving toward the radar at 45°
        ]
    )
    theta, phi = rcs.aspect_angles(los, vel)
    assert theta[0] == pytest.approx(0.0, abs=1e-12) and phi[0] == pytest.approx(0.0, abs=1e-12)
    assert abs(theta[1]) == pytest.approx(np.pi, rel=1e-12)
    assert abs(theta[2]) == pytest.approx(np.pi / 2, rel=1e-12) and phi[2] == pytest.approx(
        0.0, abs=1e-12
    )
    # Vertical velocity: the radar is 90° off the nose.
    assert rcs.off_nose_angle(theta[3], phi[3]) == pytest.approx(np.pi / 2, rel=1e-12)
    # Diving at 45° toward a radar on the horizon: 45° off the nose, in the vertical plane.
    assert rcs.off_nose_angle(theta[4], phi[4]) == pytest.approx(np.pi / 4, rel=1e-12)
    assert theta[4] == pytest.approx(0.0, abs=1e-12)


@settings(max_examples=100, deadline=None)
@given(
    los=st.lists(st.floats(-1e5, 1e5), min_size=3, max_size=3),
    vel=st.lists(st.floats(-1e3, 1e3), min_size=3, max_size=3),
)
def test_off_nose_angle_matches_dot_product(los, vel):
    los, vel = np.array(los), np.array(vel)
    if np.linalg.norm(los) < 1.0 or np.linalg.norm(vel) < 1e-3:
        return
    theta, phi = rcs.aspect_angles(los, vel)
    # Second method: angle between the velocity and the direction target -> radar.
    cos_true = np.dot(vel, -los) / (np.linalg.norm(vel) * np.linalg.norm(los))
    assert rcs.off_nose_angle(theta, phi) == pytest.approx(
        np.arccos(np.clip(cos_true, -1, 1)), abs=1e-6
    )


def test_zero_velocity_is_nose_on():
    theta, phi = rcs.aspect_angles(
        np.array([[1e3, 2e3, 10.0], [0.0, 0.0, 0.0]]),
        np.array([[0.0, 0.0, 0.0], [100.0, 0.0, 0.0]]),
    )
    assert theta == pytest.approx([0.0, 0.0], abs=0.0) and phi == pytest.approx([0.0, 0.0], abs=0.0)
    assert rcs.missile_rcs(SIGMA_N, LENGTH, DIAMETER, theta, phi) == pytest.approx([SIGMA_N] * 2)


def test_tabulated_rcs_exact_at_nodes_and_symmetric():
    axis = np.deg2rad([0.0, 30.0, 90.0, 150.0, 180.0])
    sigma = np.array([0.5, 2.0, 40.0, 3.0, 1.0])
    assert rcs.tabulated_rcs(axis, sigma, axis) == pytest.approx(sigma, rel=1e-15)
    assert rcs.tabulated_rcs(axis, sigma, -axis) == pytest.approx(sigma, rel=1e-15)
    assert rcs.tabulated_rcs(axis, sigma, axis + 2 * np.pi) == pytest.approx(sigma, rel=1e-12)
    # Midway between nodes: linear in m².
    assert rcs.tabulated_rcs(axis, sigma, np.deg2rad(60.0)) == pytest.approx(21.0, rel=1e-12)
    # Beyond π folds back: 200° off the nose is 160°.
    assert rcs.tabulated_rcs(axis, sigma, np.deg2rad(200.0)) == pytest.approx(
        rcs.tabulated_rcs(axis, sigma, np.deg2rad(160.0)), rel=1e-12
    )


def test_tabulated_rcs_holds_end_values_and_rejects_bad_tables():
    axis = np.deg2rad([10.0, 90.0])
    sigma = np.array([1.0, 5.0])
    assert rcs.tabulated_rcs(axis, sigma, np.array([0.0, np.pi])) == pytest.approx([1.0, 5.0])
    with pytest.raises(ValueError):
        rcs.tabulated_rcs(np.array([0.0, 0.0]), sigma, 0.1)
    with pytest.raises(ValueError):
        rcs.tabulated_rcs(np.array([0.0, 4.0]), sigma, 0.1)
