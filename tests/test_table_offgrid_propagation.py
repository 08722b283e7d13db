"""The PE propagation table is a cache of the PE: read off its grid as the dwell reads it, it
equals :func:`shipradar.sensors.parabolic_equation.solve_pe` (issue 36; STYLE lesson 15).

Each table is built the way tables/scene.py builds it (``table_specs`` of a scene with the
duct as ``environment.duct``, a target high enough to set the table's top near 500 m) and
read through :func:`shipradar.tables.propagation.propagation_factor`, the dwell's reader, at
random nodes of the PE's own output (its heights are not the table's h/R nodes), with the
first and last range and the top height, and outside the table (NaN, the dwell's fallback).

Tolerance, outside the PE's nulls (F below -20 dB): the 95th percentile of the dB error at
most 1.5 dB in every height band at 50-100 km (the issue's bar; measured 0.01-0.26 dB), and at
most 1 % of all points over 3 dB (no false nulls).
"""

from __future__ import annotations

import numpy as np
import pytest

from shipradar.sensors import parabolic_equation as pe
from shipradar.sensors import propagation as prop
from shipradar.sim.world.scenario import parse_scenario
from shipradar.tables.propagation import propagation_factor
from shipradar.tables.scene import table_specs
from tests.helpers import quiet_radar

#: Trilinear M-profiles of the issue: a surface-based duct trapping at 100-150 m (M falls
#: 40 units, below its surface value) and an elevated duct at 300-350 m (falls 30).
SURFACE_DUCT = {"heights_m": [0.0, 100.0, 150.0, 2000.0],
                "m_units": [330.0, 341.8, 301.8, 301.8 + 0.118 * 1850.0]}
ELEVATED_DUCT = {"heights_m": [0.0, 300.0, 350.0, 2000.0],
                 "m_units": [330.0, 365.4, 335.4, 335.4 + 0.118 * 1650.0]}
BANDS_M = ((0.0, 30.0), (30.0, 100.0), (100.0, 150.0), (150.0, 300.0), (300.0, 350.0),
           (350.0, 500.0))


def _scene(freq_hz: float, duct: dict):
    return parse_scenario({
        "name": "pe", "duration_s": 10, "seed": 3,
        "origin": {"lat_deg": 44.6, "lon_deg": -63.0},
        "platforms": [{"id": "ship", "waypoints": [{"east_m": 0, "north_m": 0}],
                       "radars": [quiet_radar(frequency_hz=freq_hz, instrumented_range_m=100e3,
                                              antenna_height_m=20.0)]}],
        "targets": [{"id": "t", "waypoints": [{"east_m": 50e3, "north_m": 0,
                                               "altitude_m": 400.0}],
                     "rcs": {"type": "constant", "sigma_m2": 1.0}}],
        "environment": {"duct": duct},
        "fidelity": {"propagation": "pe", "atmosphere": False, "clutter": False},
    })


def _compare(freq_hz: float, duct: dict, rng: np.random.Generator):
    scene = _scene(freq_hz, duct)
    table = next(s for s in table_specs(scene) if s.kind == "propagation").make()
    p = table.inputs
    assert p["pattern"]["kind"] == "isotropic"
    ranges, heights, f_pe = pe.solve_pe(
        p["freq_hz"], p["antenna_height_m"], polarization=p["polarization"],
        elevation_pattern=None, profile=p["profile"], wave_height_m=p["wave_height_m"],
        max_range_m=p["max_range_m"], max_height_m=p["max_height_m"], fidelity=p["fidelity"],
        permittivity=complex(prop.sea_water_permittivity(p["freq_hz"])), progress=False)
    assert np.allclose(ranges, table.axes[0])
    top = p["max_height_m"]
    # random PE nodes, half beyond 50 km; plus the first and last range and the top
    n = 6000
    i = np.concatenate([rng.integers(0, ranges.size, n // 2),
                        rng.integers(np.searchsorted(ranges, 50e3), ranges.size, n // 2),
                        [0, ranges.size - 1, ranges.size - 1]])
    hmax = np.searchsorted(heights, top, side="right")
    j = np.concatenate([rng.integers(0, hmax, n), [0, 0, hmax - 1]])
    r, h, ref = ranges[i], heights[j], f_pe[i, j].astype(float)
    got = propagation_factor(table, r, h)
    # outside the table: NaN (the dwell falls back to the two-ray model and counts it)
    outside = propagation_factor(table, np.array([ranges[-1] * 1.01, 50e3, 0.0]),
                                 np.array([10.0, top * 1.01, 10.0]))
    assert np.all(np.isnan(outside))
    ok = np.isfinite(ref) & np.isfinite(got) & (ref >= 0.1)
    err = np.abs(20 * np.log10(np.maximum(got[ok], 1e-12) / ref[ok]))
    return r[ok], h[ok], err


def _check(r, h, err):
    assert np.mean(err > 3.0) <= 0.01, (err.max(), r[np.argmax(err)], h[np.argmax(err)])
    far = r >= 50e3
    for lo, hi in BANDS_M:
        band = far & (h >= lo) & (h < hi)
        if band.sum() >= 50:
            assert np.percentile(err[band], 95) <= 1.5, (lo, hi, np.percentile(err[band], 95))


@pytest.mark.slow
def test_surface_duct_3ghz_table_equals_pe(table_cache):
    _check(*_compare(3e9, {"type": "profile", **SURFACE_DUCT}, np.random.default_rng(3)))


@pytest.mark.slow
def test_surface_duct_10ghz_table_equals_pe(table_cache):
    _check(*_compare(10e9, {"type": "profile", **SURFACE_DUCT}, np.random.default_rng(10)))


@pytest.mark.slow
def test_elevated_duct_table_equals_pe(table_cache):
    _check(*_compare(3e9, {"type": "profile", **ELEVATED_DUCT}, np.random.default_rng(30)))


@pytest.mark.slow
def test_evaporation_duct_table_equals_pe(table_cache):
    """The evaporation duct stays where it was (p95 ≤ 0.34 dB in every band)."""
    r, h, err = _compare(10e9, {"type": "height", "height_m": 20.0}, np.random.default_rng(20))
    _check(r, h, err)
    far = r >= 50e3
    for lo, hi in BANDS_M:
        band = far & (h >= lo) & (h < hi)
        if band.sum() >= 50:
            assert np.percentile(err[band], 95) <= 0.34 + 0.1, (lo, hi)


def test_false_null_of_the_issue(table_cache):
    """3 GHz surface duct, 92 km, 123 m: the table read -24.4 dB where the PE gives +5.6 dB."""
    scene = _scene(3e9, {"type": "profile", **SURFACE_DUCT})
    table = next(s for s in table_specs(scene) if s.kind == "propagation").make()
    p = table.inputs
    ranges, heights, f_pe = pe.solve_pe(
        p["freq_hz"], p["antenna_height_m"], polarization=p["polarization"],
        elevation_pattern=None, profile=p["profile"], max_range_m=p["max_range_m"],
        max_height_m=p["max_height_m"], fidelity=p["fidelity"],
        permittivity=complex(prop.sea_water_permittivity(p["freq_hz"])), progress=False)
    i = int(np.argmin(np.abs(ranges - 92e3)))
    j = int(np.argmin(np.abs(heights - 123.0)))
    got = float(propagation_factor(table, ranges[i], heights[j]))
    assert 20 * np.log10(got) == pytest.approx(20 * np.log10(f_pe[i, j]), abs=1.0)


def test_trapping_layer_by_hand():
    """θ_trap = sqrt(2 ΔM 1e-6) with ΔM the largest fall of M with height (Snell's law in M)."""
    sbd = prop.profile_from_spec({"kind": "piecewise", **SURFACE_DUCT})
    theta, z_min = pe.trapping_layer(sbd, 500.0)
    # (M sampled every 2.5 cm: the corners of the profile within 1e-4 relative)
    assert theta == pytest.approx(np.sqrt(2 * 40.0 * 1e-6), rel=1e-4)   # 341.8 -> 301.8
    assert z_min == pytest.approx(150.0, abs=0.05)
    elevated = prop.profile_from_spec({"kind": "piecewise", **ELEVATED_DUCT})
    theta, z_min = pe.trapping_layer(elevated, 500.0)
    assert theta == pytest.approx(np.sqrt(2 * 30.0 * 1e-6), rel=1e-4)   # 365.4 -> 335.4
    assert z_min == pytest.approx(350.0, abs=0.05)
    # below the trap's top only part of the fall is seen; a standard atmosphere traps nothing
    assert pe.trapping_layer(sbd, 125.0)[0] == pytest.approx(np.sqrt(2 * 20.0 * 1e-6), rel=1e-3)
    assert pe.trapping_layer(prop.profile_from_spec({"kind": "standard"}), 500.0) == (0.0, 0.0)
