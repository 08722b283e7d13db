"""The weather-clutter map read off its grid equals its direct function (issue 36).

The map (:func:`shipradar.tables.clutter.build_weather_clutter_map`) is a cache of
:func:`shipradar.tables.clutter.weather_clutter_profile`: the trip sum P_wc of [39]-[41]
with each trip's rain loss, its spread, and the single trip P_1.  The dwell reads it with
:class:`shipradar.tables.store.StackedLookup2D` (bilinear); the sum jumps at every multiple
of R_u and where a trip leaves the instrumented range, and is steep just after each
multiple (the first trip's near rain).  Here the reader is compared with the direct
function at random points off the grid, a share of them within metres of each jump and
below 180 m: at most 0.5 % of points more than 1 dB off and none more than 6 dB, outside
the documented gaps of :data:`shipradar.tables.clutter.FOLD_NODE_GAP_M` at the jumps.  The
domain is that of an exact map: at most :data:`shipradar.tables.clutter.MAX_FOLD_NODES`
fold nodes (beyond, the near runs are thinned; docs/accuracy.md).
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from shipradar.sensors import weather_clutter as wc
from shipradar.tables import clutter as tc
from shipradar.tables.store import StackedLookup2D

C = 299_792_458.0
READ = (None, "doppler_spread_hz", "single_trip_power_w")


def _inputs(**over):
    kw = dict(freq_hz=5.6e9, antenna_height_m=25.0, beamwidth_az_rad=math.radians(1.8),
              beamwidth_el_rad=math.radians(20.0), pulse_width_s=0.25e-6, prf_hz=5000.0,
              radar_constant_w_m2=1.0, rain_rate_mm_h=16.0, cloud_base_m=2500.0,
              rotation_rate_rad_s=2 * math.pi, wind_speed_mps=10.0, wind_direction_rad=0.0,
              max_range_m=60e3, precipitation="rain", rain_attenuation_db_per_km=0.0276,
              n_azimuth=4)
    kw.update(over)
    kw.setdefault("n_range", int(min(3001, max(201, kw["max_range_m"] / 100.0 + 1))))
    return kw


def _points(rng, r_max, r_u):
    """Uniform points, points within 300 m and within 5 m of each jump, and below 180 m."""
    folds = r_u * np.arange(0.0, np.floor(r_max / r_u) + 1.0)
    jumps = np.concatenate([folds[1:], np.mod(r_max, r_u) + folds])
    jumps = jumps[(jumps > 0) & (jumps < r_max)]
    pts = [rng.uniform(0.0, r_max, 1500), rng.uniform(0.0, 180.0, 200)]
    for j in jumps[:: max(1, jumps.size // 30)]:
        pts.append(j + rng.uniform(-300.0, 300.0, 20))
        pts.append(j + rng.choice([-1.0, 1.0], 20) * rng.uniform(0.0, 5.0, 20))
    x = np.concatenate(pts)
    x = x[(x >= 0.0) & (x <= r_max)]
    gap = tc.FOLD_NODE_GAP_M
    near_jump = np.any(np.abs(x[:, None] - jumps[None, :]) <= gap, axis=1)
    return x[~near_jump]


def _errors_db(kw, seed):
    table = tc.build_weather_clutter_map(**kw)
    inputs = tc.weather_clutter_map_inputs(**kw)
    r_u = C / (2 * kw["prf_hz"])
    x = _points(np.random.default_rng(seed), kw["max_range_m"], r_u)
    az = np.random.default_rng(seed + 1).uniform(-7.0, 7.0, x.size)
    got = StackedLookup2D(table, READ, periodic1=True)(x, az)
    want = np.stack(tc.weather_clutter_profile(x, inputs), axis=1)
    ok = (want > 0.0) & (got > 0.0)
    # a zero on one side only is a failure (an infinite error)
    assert np.array_equal(want > 0.0, got > 0.0)
    err = np.zeros_like(want)
    err[ok] = np.abs(10 * np.log10(got[ok] / want[ok]))
    return x, err


def _check(x, err):
    for k, name in enumerate(("power", "spread", "single trip")):
        e = err[:, k]
        worst = int(np.argmax(e))
        assert np.mean(e > 1.0) <= 0.005, (name, np.mean(e > 1.0), x[e > 1.0][:5])
        assert e[worst] <= 6.0, (name, x[worst], e[worst])


def test_shipped_radars_off_the_grid():
    """The jammed_squall's Giraffe (R_u 30 km over 60 km) and the raid's SPS-49 (150 km
    over 250 km) in 16 and 50 mm/h, and a 20 kHz radar folding 8 times."""
    for kw in (_inputs(),
               _inputs(rain_rate_mm_h=50.0, rain_attenuation_db_per_km=0.169),
               _inputs(freq_hz=9e8, antenna_height_m=30.0, beamwidth_az_rad=math.radians(3.3),
                       beamwidth_el_rad=math.radians(11.0), pulse_width_s=2e-6, prf_hz=1000.0,
                       rotation_rate_rad_s=2 * math.pi / 5, max_range_m=250e3,
                       rain_attenuation_db_per_km=0.0011),
               _inputs(prf_hz=20e3, precipitation="wet_snow"),
               _inputs(prf_hz=20e3, precipitation="dry_snow", max_range_m=150e3)):
        x, err = _errors_db(kw, 11)
        _check(x, err)
        # the max error, for docs/accuracy.md's row (printed with -s)
        print(f"prf {kw['prf_hz']:.0f} Hz, {kw['max_range_m'] / 1e3:.0f} km, "
              f"{kw['precipitation']}: max {err.max(axis=0).round(3)} dB, "
              f"over 1 dB {np.mean(err > 1.0, axis=0)}")


@settings(max_examples=25, deadline=None)
@given(prf=st.floats(300.0, 3.0e4), r_max=st.floats(5e3, 300e3), h_a=st.floats(3.0, 200.0),
       phi_b_deg=st.floats(0.5, 60.0), theta_b_deg=st.floats(0.3, 10.0),
       cloud=st.floats(200.0, 15e3), rate=st.floats(0.1, 300.0),
       kind=st.sampled_from(["rain", "dry_snow", "wet_snow"]), gamma=st.floats(0.0, 5.0),
       seed=st.integers(0, 2**31))
def test_weather_map_reader_equals_the_direct_function(prf, r_max, h_a, phi_b_deg,
                                                      theta_b_deg, cloud, rate, kind, gamma,
                                                      seed):
    kw = _inputs(prf_hz=prf, max_range_m=r_max, antenna_height_m=h_a,
                 beamwidth_el_rad=math.radians(phi_b_deg),
                 beamwidth_az_rad=math.radians(theta_b_deg), cloud_base_m=cloud,
                 rain_rate_mm_h=rate, precipitation=kind, rain_attenuation_db_per_km=gamma)
    axis = tc.weather_range_axis(r_max, kw["n_range"], prf)
    r_u = float(wc.unambiguous_range_m(prf))
    folds = int(r_max // r_u) + 1
    uniform = kw["n_range"]
    if axis.size - uniform >= tc.MAX_FOLD_NODES - 3 * folds:
        return  # thinned: outside the exact map's domain (docs/accuracy.md)
    x, err = _errors_db(kw, seed)
    _check(x, err)
