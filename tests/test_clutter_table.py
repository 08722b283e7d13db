"""Tests of shipradar.tables.clutter: wiring of the sea and weather clutter maps, cache and
lookup."""

import math
from dataclasses import fields

import numpy as np
import pytest

from shipradar.sensors import sea_clutter as sc
from shipradar.sensors import weather_clutter as wc
from shipradar.tables import clutter as tc
from shipradar.tables.store import Table, inputs_hash

BW_EL = math.radians(4.0)
TILT = 0.0


def gaussian_el(elev):
    """Gaussian field pattern, 3 dB beamwidth BW_EL (g = 1/√2 at ±BW_EL/2), beam at the horizon."""
    return np.exp(-2.0 * math.log(2.0) * ((np.asarray(elev) - TILT) / BW_EL) ** 2 / 2.0)


def sea_kwargs(**over):
    kw = dict(
        freq_hz=9.8e9,
        polarization="V",
        antenna_height_m=25.0,
        beamwidth_az_rad=math.radians(1.5),
        pulse_width_s=0.25e-6,
        radar_constant_w_m2=50.0,
        elevation_pattern=("gaussian", BW_EL, 0.0, TILT),
        noise_power_w=1.38e-23 * 600 / 0.25e-6,
        rotation_rate_rad_s=2 * math.pi / 3,
        wind_speed_mps=8.0,
        wind_direction_rad=math.radians(40.0),
        wave_height_m=1.2,
        max_range_m=60e3,
        n_range=241,
        n_azimuth=72,
    )
    kw.update(over)
    return kw


@pytest.fixture(scope="module")
def vp_map():
    return tc.build_sea_clutter_map(elevation_directivity=gaussian_el, **sea_kwargs())


def test_sea_map_values_match_physics_functions(vp_map):
    kw = sea_kwargs()
    r = vp_map.axes[0][[4, 40, 120]]
    az = vp_map.axes[1][[0, 9, 30]]
    phi = az[None, :] - kw["wind_direction_rad"]
    s_db = sc.ducted_reflectivity_db(r[:, None], 25.0, 9.8e9, 8.0, phi, 1.2, "V")
    slant = sc.slant_range_m(r, 25.0)
    g = gaussian_el(-sc.depression_angle_rad(r, 25.0))
    cr = 299_792_458.0 * 0.25e-6 / 2
    p = (
        50.0
        * g[:, None] ** 4
        * slant[:, None]
        * kw["beamwidth_az_rad"]
        * cr
        * sc.from_db(s_db)
        / slant[:, None] ** 4
    )
    got = vp_map.values[np.ix_([4, 40, 120], [0, 9, 30])]
    assert got == pytest.approx(p, rel=1e-12)
    assert vp_map.extra["sigma0_db"][np.ix_([4, 40, 120], [0, 9, 30])] == pytest.approx(
        s_db, rel=1e-12
    )


def test_sea_map_wind_direction(vp_map):
    wind_from = math.radians(40.0)
    r = np.array([2e3, 5e3, 8e3])
    up = tc.lookup_clutter(vp_map, r, wind_from)
    down = tc.lookup_clutter(vp_map, r, wind_from + math.pi)
    c1 = tc.lookup_clutter(vp_map, r, wind_from + math.pi / 2)
    c2 = tc.lookup_clutter(vp_map, r, wind_from - math.pi / 2)
    assert np.all(up > c1) and np.all(c1 > down)
    assert c1 == pytest.approx(c2, rel=1e-9)
    # azimuth wrap: -π/2 and 3π/2 read the same cell
    assert tc.lookup_clutter(vp_map, r, -1.0) == pytest.approx(
        tc.lookup_clutter(vp_map, r, 2 * math.pi - 1.0)
    )


def test_sea_map_finite_non_negative(vp_map):
    for arr in [vp_map.values, *vp_map.extra.values()]:
        assert np.all(np.isfinite(arr))
    assert np.all(vp_map.values >= 0.0)
    assert np.all(vp_map.extra["weibull_a"] >= 1.0)


def test_vp_a_equals_a_ref_at_reference_condition():
    # 9.8 GHz VP, looking upwind at the 3° range: σ0d = 0, so a = a_ref = 3 log10(w)
    r_ref = float(sc.ground_range_at_grazing_m(sc.REFERENCE_GRAZING_RAD, 25.0))
    kw = sea_kwargs(max_range_m=2 * r_ref, n_range=3, wind_direction_rad=0.0, n_azimuth=4)
    m = tc.build_sea_clutter_map(elevation_directivity=gaussian_el, **kw)
    i = int(np.argmin(np.abs(m.axes[0] - r_ref)))
    assert m.axes[0][i] == pytest.approx(r_ref)
    assert m.extra["sigma0_diff_db"][i, 0] == pytest.approx(0.0, abs=1e-9)
    assert m.extra["weibull_a"][i, 0] == pytest.approx(3 * math.log10(8.0), rel=1e-9)


def test_hp_a_falls_from_three_to_a_min():
    m = tc.build_sea_clutter_map(
        elevation_directivity=gaussian_el, **sea_kwargs(polarization="H", a_min=0.8)
    )
    a = m.extra["weibull_a"]
    r_ref = float(sc.ground_range_at_grazing_m(sc.REFERENCE_GRAZING_RAD, 25.0))
    ranges = m.axes[0]
    assert np.all(a[ranges <= r_ref] == pytest.approx(3.0))
    assert np.all(np.diff(a, axis=0) <= 1e-12)
    assert a[-1, :] == pytest.approx(0.8)
    # a reaches a_min where P_sc has fallen to 2 N0'
    noise2 = 2 * sea_kwargs()["noise_power_w"]
    for j in (0, 20, 50):
        first_min = ranges[np.argmax(a[:, j] <= 0.8 + 1e-12)]
        assert m.values[ranges >= first_min + ranges[1], j].max() <= noise2 * (1 + 1e-9)


def test_low_resolution_is_rayleigh():
    m = tc.build_sea_clutter_map(
        elevation_directivity=gaussian_el, **sea_kwargs(pulse_width_s=20e-6, n_range=21)
    )
    assert np.all(m.extra["weibull_a"] == 1.0)


def test_spectrum_extras(vp_map):
    lam = 299_792_458.0 / 9.8e9
    wind_from = math.radians(40.0)
    assert np.all(vp_map.extra["doppler_mean_hz"] == 0.0)  # motion-compensated by default
    sr = (2 * math.pi / 3) / (5.35 * math.radians(1.5))
    spread = tc.lookup_clutter(vp_map, 10e3, wind_from, "doppler_spread_hz")
    assert spread == pytest.approx(math.hypot(8.0 / (2 * lam), sr), rel=1e-6)
    m = tc.build_sea_clutter_map(
        elevation_directivity=gaussian_el,
        **sea_kwargs(
            motion_compensated=False, ship_speed_mps=10.0, ship_heading_rad=wind_from, n_range=11
        ),
    )
    j = int(round(wind_from / (2 * math.pi / 72)))
    assert m.axes[1][j] == pytest.approx(wind_from)
    psi_d = sc.depression_angle_rad(m.axes[0][5], 25.0)
    expected = 2 * 10.0 / lam * math.cos(psi_d) + 1 / lam
    assert m.extra["doppler_mean_hz"][5, j] == pytest.approx(expected, rel=1e-9)


def test_ducted_map_above_standard_beyond_horizon():
    std = tc.build_sea_clutter_map(elevation_directivity=gaussian_el, **sea_kwargs(n_azimuth=4))
    duct = tc.build_sea_clutter_map(
        elevation_directivity=gaussian_el, **sea_kwargs(n_azimuth=4, duct_height_m=10.0)
    )
    far = std.axes[0] > 25e3
    assert np.all(duct.values[far] > 1e3 * std.values[far])


def test_cache_round_trip(table_cache):
    kw = sea_kwargs(n_range=31, n_azimuth=8)
    t1, built1 = tc.sea_clutter_map(elevation_directivity=gaussian_el, **kw)
    t2, built2 = tc.sea_clutter_map(elevation_directivity=gaussian_el, **kw)
    assert built1 and not built2
    assert np.array_equal(t1.values, t2.values)
    for k in t1.extra:
        assert np.array_equal(t1.extra[k], t2.extra[k])
    _, built3 = tc.sea_clutter_map(
        elevation_directivity=gaussian_el, **{**kw, "duct_height_m": 5.0}
    )
    assert built3
    loaded = Table.load(table_cache / f"sea_clutter_map-{t1.key}.npz")
    assert np.array_equal(loaded.values, t1.values) and loaded.inputs["duct_height_m"] == 0.0


def test_frequency_outside_git_refused():
    with pytest.raises(ValueError, match="1 to 100 GHz"):
        tc.build_sea_clutter_map(
            elevation_directivity=gaussian_el, **sea_kwargs(freq_hz=0.4e9, n_range=5)
        )


def weather_kwargs(**over):
    kw = dict(
        freq_hz=5.6e9,
        antenna_height_m=25.0,
        beamwidth_az_rad=math.radians(1.5),
        beamwidth_el_rad=BW_EL,
        pulse_width_s=1e-6,
        prf_hz=1200.0,
        radar_constant_w_m2=50.0,
        rain_rate_mm_h=8.0,
        cloud_base_m=2000.0,
        rotation_rate_rad_s=1.0,
        wind_speed_mps=8.0,
        wind_direction_rad=0.0,
        max_range_m=200e3,
        n_range=401,
        n_azimuth=36,
    )
    kw.update(over)
    return kw


def test_weather_map_values_by_hand(table_cache):
    m, built = tc.weather_clutter_map(**weather_kwargs())
    assert built
    r_u = 299_792_458.0 / (2 * 1200.0)  # 124.9 km, below the map's 200 km
    eta = wc.reflectivity_constant(5.6e9) * (5.6e9) ** 4 * 8.0**1.6
    c_r = 299_792_458.0 * 1e-6 / 2

    def one_cell(x):  # [39], [40], [43] with the volume and R⁴ of the same cell
        vol = eta * x * math.radians(1.5) * min(2000.0, x * BW_EL) * c_r
        return 50.0 * vol / sc.slant_range_m(x, 25.0) ** 4

    # the rain of both pulses in flight arrives with the echo of 50 km (the second trip at
    # 174.9 km, inside the 200 km map) and of 174.9 km (the first trip at 50 km); before
    # issue 23 item 5(c) the map held the seed's volume at R_c over the true R⁴ instead
    for i in (100, 350):
        r = m.axes[0][i]
        r_near = r % r_u
        p = one_cell(r_near) + (one_cell(r_near + r_u) if r_near + r_u <= 200e3 else 0.0)
        assert m.values[i, 0] == pytest.approx(p, rel=1e-12)
        assert m.extra["single_trip_power_w"][i, 0] == pytest.approx(one_cell(r), rel=1e-12)
    assert np.all(np.isfinite(m.values)) and np.all(m.values >= 0)
    # beyond the unambiguous range the first trip's near rain dominates: far more clutter
    # than the seed-literal map's volume at R_c over the true R⁴
    far = m.axes[0] > r_u
    assert m.values[far][0, 0] > m.values[~far][-1, 0]


def test_weather_map_needs_precipitation():
    with pytest.raises(ValueError, match="precipitation"):
        tc.build_weather_clutter_map(**weather_kwargs(rain_rate_mm_h=0.0))


def test_figures_written(tmp_path, vp_map):
    from shipradar.sim.studies.figures.clutter import plot_clutter_ppi, plot_ducting_reflectivity

    for p in (
        plot_ducting_reflectivity(tmp_path / "fig6.png"),
        plot_clutter_ppi(tmp_path / "ppi.png", vp_map),
    ):
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_map_inputs_every_field_plain_and_type_blind():
    """The cache key holds every spec field once, as a plain value of its declared type:
    equal inputs of other Python types (int, numpy) give the same key, a changed one does not."""
    sea = tc.sea_clutter_map_inputs(**sea_kwargs())
    assert list(sea) == [f.name for f in fields(tc.SeaClutterMapSpec)]
    assert sea["polarization"] == "V" and sea["elevation_pattern"] == ["gaussian", BW_EL, 0.0, TILT]
    assert sea["sea_state"] is None and sea["motion_compensated"] is True
    same = tc.sea_clutter_map_inputs(**sea_kwargs(
        freq_hz=9_800_000_000, antenna_height_m=np.float32(25.0), n_range=241.0,
        motion_compensated=1, polarization="vertical"))
    assert inputs_hash("s", 1, same) == inputs_hash("s", 1, sea)
    assert type(same["freq_hz"]) is float and type(same["n_range"]) is int
    assert inputs_hash("s", 1, tc.sea_clutter_map_inputs(**sea_kwargs(sea_state=3))) != \
        inputs_hash("s", 1, sea)
    wet = tc.weather_clutter_map_inputs(**weather_kwargs())
    assert list(wet) == [f.name for f in fields(tc.WeatherClutterMapSpec)]
    wet_int = tc.weather_clutter_map_inputs(**weather_kwargs(prf_hz=1200, max_range_m=200_000))
    assert inputs_hash("w", 1, wet_int) == inputs_hash("w", 1, wet)
