"""Atmospheric loss [16]: gases (P.676), fog (P.840), rain (P.838) and the path geometry."""

import time

import itur.models.itu676 as itu676
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from shipradar.sensors import atmosphere as atm
from shipradar.tables import atmosphere as atm_table
from shipradar.tables.store import Table

F_HZ = 10e9
T_K, P_HPA, RHO = 288.15, 1013.25, 7.5


@pytest.fixture(scope="module")
def gas10():
    go, gw = atm.gaseous_specific_attenuation_db_per_km(F_HZ)
    ho, hw = atm.gaseous_equivalent_heights_m(F_HZ)
    return dict(gamma_o_db_per_km=go, gamma_w_db_per_km=gw, h_o_m=ho, h_w_m=hw)


def test_surface_specific_attenuation_literature():
    go, gw = atm.gaseous_specific_attenuation_db_per_km(F_HZ)
    # ITU-R P.676-12 Fig. 1 (standard atmosphere, 7.5 g/m³): about 0.014 dB/km at 10 GHz,
    # shared roughly 60/40 between oxygen and water vapour.
    assert go + gw == pytest.approx(0.014, rel=0.1)
    go22, gw22 = atm.gaseous_specific_attenuation_db_per_km(22.235e9)
    assert gw22 > 10 * gw  # the 22 GHz water line
    _, gw_dry = atm.gaseous_specific_attenuation_db_per_km(F_HZ, water_vapour_density_g_m3=0.0)
    assert gw_dry == 0.0


def test_horizontal_10km_equals_surface_attenuation_times_range(gas10):
    loss = atm.gaseous_loss_db(10e3, 0.0, **gas10)
    # Independent: itur's own surface value at the dry pressure p = P - ρT/216.7 (P.453),
    # times 10 km; the 4/3-earth path climbs only 5.9 m in 10 km.
    p_dry = P_HPA - RHO * T_K / 216.7
    gamma = float(itu676.gamma_exact(10.0, p_dry, RHO, T_K).value)
    assert loss == pytest.approx(gamma * 10.0, rel=2e-3)


def test_zenith_closed_form(gas10):
    r = np.array([100.0, 1e3, 5e3, 20e3, 100e3])
    loss = atm.gaseous_loss_db(r, np.pi / 2, **gas10)
    g = gas10
    expected = (
        g["gamma_o_db_per_km"] * g["h_o_m"] * (1 - np.exp(-r / g["h_o_m"]))
        + g["gamma_w_db_per_km"] * g["h_w_m"] * (1 - np.exp(-r / g["h_w_m"]))
    ) / 1e3
    assert loss == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("el_deg, rel", [(90.0, 0.05), (30.0, 0.05), (10.0, 0.05), (5.0, 0.06)])
def test_slant_path_against_itur_line_by_line_layers(gas10, el_deg, rel):
    # Second method: P.676 Annex 1 through ~900 layers of the P.835 standard atmosphere.
    exact = float(
        itu676.gaseous_attenuation_slant_path(10.0, el_deg, RHO, P_HPA, T_K, mode="exact").value
    )
    ours = atm.gaseous_loss_db(2000e3, np.deg2rad(el_deg), **gas10)
    assert ours == pytest.approx(exact, rel=rel)


def test_monotone_in_range_and_lower_at_high_elevation(gas10):
    r = np.linspace(0.0, 300e3, 301)
    els = np.deg2rad([-1.0, 0.0, 1.0, 5.0, 30.0, 90.0])
    loss = atm.gaseous_loss_db(r[:, None], els[None, :], **gas10)
    # Strictly increasing while the path is in the air; flat (to rounding) once out of it.
    assert np.all(np.diff(loss[:, :3], axis=0) > 0.0)
    assert np.all(np.diff(loss, axis=0) >= -1e-12 * loss[1:])
    assert loss[0] == pytest.approx(np.zeros(6), abs=0.0)
    # At every range beyond the first metres, the loss falls with elevation above 0.
    assert np.all(np.diff(loss[10:, 1:], axis=1) < 0.0)
    # High elevation: tends to the finite total column (γ_o h_o + γ_w h_w)/sin(el).
    g = gas10
    column = (g["gamma_o_db_per_km"] * g["h_o_m"] + g["gamma_w_db_per_km"] * g["h_w_m"]) / 1e3
    assert loss[-1, -1] == pytest.approx(column, rel=1e-6)


def test_layer_path_length_hand_geometry():
    a = atm.EFFECTIVE_EARTH_RADIUS_M
    # Horizontal from the sea surface: the ray leaves a 100 m layer at sqrt((a+100)² - a²).
    expected = np.sqrt((a + 100.0) ** 2 - a**2)
    assert atm.layer_path_length_m(1e6, 0.0, 100.0) == pytest.approx(expected, rel=1e-9)
    assert atm.layer_path_length_m(10e3, 0.0, 100.0) == pytest.approx(10e3, rel=1e-12)
    # Zenith from a 20 m antenna through a 100 m layer: 80 m.
    assert atm.layer_path_length_m(1e3, np.pi / 2, 100.0, 20.0) == pytest.approx(80.0, rel=1e-9)
    # Antenna above the layer looking up: nothing; looking down far enough: some.
    assert atm.layer_path_length_m(50e3, 0.01, 100.0, 150.0) == 0.0
    assert atm.layer_path_length_m(50e3, -0.01, 100.0, 150.0) > 0.0


def test_fog_specific_attenuation_linear_in_water_content():
    g1 = atm.fog_specific_attenuation_db_per_km(F_HZ, 0.1)
    g2 = atm.fog_specific_attenuation_db_per_km(F_HZ, 0.5)
    assert g2 == pytest.approx(5 * g1, rel=1e-12)
    assert atm.fog_specific_attenuation_db_per_km(F_HZ, 0.0) == 0.0
    # Rayleigh regime: K_l grows about as f² below 30 GHz (P.840 Fig. 1).
    ratio = atm.fog_specific_attenuation_db_per_km(20e9, 0.1) / g1
    assert 3.0 < ratio < 4.2


def test_rain_specific_attenuation_p838_coefficients():
    # ITU-R P.838-3 Table 5 at 10 GHz: k_H = 0.01217, α_H = 1.2571; k_V = 0.01129, α_V = 1.2156.
    r = np.array([1.0, 10.0, 50.0])
    assert atm.rain_specific_attenuation_db_per_km(F_HZ, r, "H") == pytest.approx(
        0.01217 * r**1.2571, rel=1e-3
    )
    assert atm.rain_specific_attenuation_db_per_km(F_HZ, r, "V") == pytest.approx(
        0.01129 * r**1.2156, rel=1e-3
    )
    assert atm.rain_specific_attenuation_db_per_km(F_HZ, 0.0, "H") == 0.0
    with pytest.raises(ValueError):
        atm.rain_specific_attenuation_db_per_km(F_HZ, 1.0, "X")


def test_rain_loss_zero_without_rain_and_proportional_to_path():
    gamma = atm.rain_specific_attenuation_db_per_km(F_HZ, 0.0, "H")
    assert atm.rain_loss_db(gamma, 25e3) == 0.0
    gamma = atm.rain_specific_attenuation_db_per_km(F_HZ, 10.0, "H")
    paths = np.array([0.0, 1e3, 2e3, 7.5e3])
    assert atm.rain_loss_db(gamma, paths) == pytest.approx(gamma * paths / 1e3, rel=1e-15)
    assert atm.rain_loss_db(gamma, 2e3) == pytest.approx(
        2 * atm.rain_loss_db(gamma, 1e3), rel=1e-15
    )


def _path(target_en, target_up, centre_en, radius, top, radar_en=(0.0, 0.0), radar_up=0.0):
    return atm.rain_path_length_m(
        np.array(radar_en),
        np.array(target_en),
        radar_up,
        target_up,
        np.array(centre_en),
        radius,
        top,
    )


def test_rain_chord_hand_geometry():
    # Diameter of the circle on the axis.
    assert _path((20e3, 0.0), 0.0, (10e3, 0.0), 5e3, 3e3) == pytest.approx(10e3, rel=1e-12)
    # Chord 3 km off the centre: 2 sqrt(5² - 3²) = 8 km.
    assert _path((20e3, 0.0), 0.0, (10e3, 3e3), 5e3, 3e3) == pytest.approx(8e3, rel=1e-12)
    # Target inside the cell: from the edge at 5 km to the target at 12 km.
    assert _path((12e3, 0.0), 0.0, (10e3, 0.0), 5e3, 3e3) == pytest.approx(7e3, rel=1e-12)
    # Misses the cell.
    assert _path((20e3, 0.0), 0.0, (10e3, 6e3), 5e3, 3e3) == 0.0
    # Rain everywhere, climbing target at 6 km: half the slant path is below a 3 km top.
    assert _path((20e3, 0.0), 6e3, (0.0, 0.0), np.inf, 3e3) == pytest.approx(
        0.5 * np.hypot(20e3, 6e3), rel=1e-12
    )
    # Both ends above the rain top.
    assert _path((20e3, 0.0), 4e3, (10e3, 0.0), 5e3, 3e3, radar_up=3.5e3) == 0.0
    # Vertical segment on the axis, from 1 km to 5 km, 3 km top: 2 km.
    assert _path(
        (10e3, 0.0), 5e3, (10e3, 0.0), 5e3, 3e3, radar_en=(10e3, 0.0), radar_up=1e3
    ) == pytest.approx(2e3, rel=1e-12)


def test_rain_path_vectorized_over_targets():
    targets = np.array([[20e3, 0.0], [20e3, 0.0], [12e3, 0.0]])
    out = atm.rain_path_length_m(
        np.zeros(2), targets, 0.0, np.zeros(3), np.array([10e3, 0.0]), 5e3, 3e3
    )
    assert out == pytest.approx([10e3, 10e3, 7e3], rel=1e-12)


@settings(max_examples=100, deadline=None)
@given(
    coords=st.lists(st.floats(-5e4, 5e4), min_size=6, max_size=6),
    ups=st.lists(st.floats(0.0, 1e4), min_size=2, max_size=2),
    radius=st.floats(1.0, 5e4),
    top=st.floats(1.0, 1e4),
)
# subnormal climb or horizontal extent: 1/d overflowed before the level-segment guard
@example(coords=[0.0] * 6, ups=[0.0, 2.225073858507203e-309], radius=1.0, top=1.0)
@example(coords=[0.0, 0.0, 5e-324, 0.0, 0.0, 0.0], ups=[0.0, 5.0], radius=1.0, top=1.0)
# a long chord tangent to the cell: B² - AC cancelled (0.1 mm one way, 0 the other)
@example(coords=[0.0, 1e-5, 0.0, 8398.0, 1.0, 0.0], ups=[0.0, 0.0], radius=1.0, top=1.0)
def test_rain_path_bounded_and_reversible(coords, ups, radius, top):
    a, b, c = np.array(coords[:2]), np.array(coords[2:4]), np.array(coords[4:])
    length = np.sqrt(np.sum((b - a) ** 2) + (ups[1] - ups[0]) ** 2)
    fwd = atm.rain_path_length_m(a, b, ups[0], ups[1], c, radius, top)
    back = atm.rain_path_length_m(b, a, ups[1], ups[0], c, radius, top)
    assert np.isfinite(fwd)
    assert -1e-9 <= fwd <= length * (1 + 1e-12) + 1e-9
    assert fwd == pytest.approx(back, rel=1e-9, abs=1e-6)


def test_grid_table_build_cache_and_lookup(table_cache, gas10):
    ranges = np.linspace(0.0, 200e3, 201)
    els = np.deg2rad(np.linspace(-1.0, 30.0, 63))
    t0 = time.perf_counter()
    table = atm_table.atmospheric_loss_grid(
        F_HZ, ranges, els, fog_lwc_g_m3=0.2, fog_top_m=150.0, antenna_height_m=20.0
    )
    build_s = time.perf_counter() - t0
    print(f"atmospheric_loss_grid 201x63 build: {build_s:.3f} s")
    assert isinstance(table, Table)
    assert table.axis_names == ("slant_range_m", "elevation_rad")
    assert table.values == pytest.approx(table.extra["gaseous_db"] + table.extra["fog_db"])
    assert np.all(np.diff(table.values, axis=0) >= 0.0)
    # The gas part equals the direct integral at the nodes.
    j = 20
    assert table.extra["gaseous_db"][:, j] == pytest.approx(
        atm.gaseous_loss_db(ranges, els[j], antenna_height_m=20.0, **gas10), rel=1e-12
    )
    # Fog part: K_l M times the length below the fog top.
    fog = (
        atm.fog_specific_attenuation_db_per_km(F_HZ, 0.2)
        * atm.layer_path_length_m(ranges, els[j], 150.0, 20.0)
        / 1e3
    )
    assert table.extra["fog_db"][:, j] == pytest.approx(fog, rel=1e-12)
    # Cached: a second call reads the file and gives the same table.
    again = atm_table.atmospheric_loss_grid(
        F_HZ, ranges, els, fog_lwc_g_m3=0.2, fog_top_m=150.0, antenna_height_m=20.0
    )
    assert again.key == table.key
    assert len(list(table_cache.glob("atmospheric_loss-*.npz"))) == 1
    assert np.array_equal(again.values, table.values)
    # Lookup: exact at nodes; beyond the last range and above the last elevation the direct
    # integral (no extrapolation, no clamp); the fog is the exact chord below its top.
    r_q = np.array([ranges[50], ranges[-1] + 10e3, 100e3])
    e_q = np.array([els[j], els[j], np.deg2rad(80.0)])
    got = atm_table.lookup_gas_fog_loss_db(table, r_q, e_q)
    assert got[0] == pytest.approx(table.values[50, j], rel=1e-12)
    gamma_fog = atm.fog_specific_attenuation_db_per_km(F_HZ, 0.2)
    direct = (atm.gaseous_loss_db(r_q[1:], e_q[1:], antenna_height_m=20.0, **gas10)
              + gamma_fog * atm.layer_path_length_m(r_q[1:], e_q[1:], 150.0, 20.0) / 1e3)
    assert got[1:] == pytest.approx(direct, rel=1e-9)


@settings(max_examples=100, deadline=None)
@given(r=st.floats(1.0, 4e5), el=st.floats(-0.02, 1.5), ha=st.floats(0.0, 100.0))
def test_ray_elevation_inverts_path_height(r, el, ha):
    h = float(atm.path_height_m(r, el, ha))
    if h < 0.0:
        return  # a ray into the sea has no target
    assert atm.ray_elevation_rad(r, h, ha) == pytest.approx(el, abs=1e-7)


def test_ray_elevation_hand_geometry():
    # Zenith: target straight above at R + h_a.
    assert atm.ray_elevation_rad(1000.0, 1020.0, 20.0) == pytest.approx(np.pi / 2, abs=1e-6)
    # Sea-level to sea-level at 20 km over a 4/3 earth: the chord dips by R/(2 a_e).
    expected = -20e3 / (2 * atm.EFFECTIVE_EARTH_RADIUS_M)
    assert atm.ray_elevation_rad(20e3, 0.0, 0.0) == pytest.approx(expected, rel=1e-6)
    assert atm.ray_elevation_rad(0.0, 10.0, 10.0) == 0.0


def test_per_plot_path_never_calls_itur(table_cache, monkeypatch):
    # [16] per plot is a table lookup plus the rain chord: once the scene's grid and its rain
    # γ_r (P.838) exist, no ITU-R model may run (SPEC §4 item 20, issue 3 item 3).
    import itur.models.itu838 as itu838
    import itur.models.itu840 as itu840

    ranges = np.linspace(0.0, 100e3, 21)
    els = np.deg2rad(np.linspace(-1.0, 10.0, 12))
    table = atm_table.atmospheric_loss_grid(F_HZ, ranges, els, fog_lwc_g_m3=0.1, fog_top_m=100.0)
    gamma_r = atm.rain_specific_attenuation_db_per_km(F_HZ, 10.0, "H")

    def forbidden(*args, **kwargs):
        raise AssertionError("an ITU-R model was called per plot")

    for module in (itu676, itu838, itu840):
        for name in dir(module):
            if not name.startswith("_") and callable(getattr(module, name)):
                monkeypatch.setattr(module, name, forbidden)
    rng = np.random.default_rng(3)
    r = rng.uniform(1e3, 120e3, 1000)
    el = rng.uniform(-0.01, 0.2, 1000)
    loss = atm_table.lookup_gas_fog_loss_db(table, r, el)
    targets = np.column_stack([r, np.zeros_like(r)])
    chord = atm.rain_path_length_m(
        np.zeros(2), targets, 20.0, 100.0, np.array([30e3, 0.0]), 10e3, 3e3
    )
    loss = loss + atm.rain_loss_db(gamma_r, chord)
    assert np.all(np.isfinite(loss)) and np.all(loss >= 0.0)
