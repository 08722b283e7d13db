"""The weather clutter the dwell sees against an independent evaluation of [39]-[45].

The reference below is written from the seed (DREV-R-9429 [39]-[45]) and ITU-R P.838 (the
``itur`` package, called here directly), not from shipradar's functions: Marshall-Palmer
reflectivity ϑ0 = K f⁴ p_r^1.6 [42] with the seed's K, the cell ϑ0 R θ_b d_h C_R [40],
d_h = min(h_cloud, R φ_b) [43], the slant range over the 4/3 earth by the law of cosines,
every pulse in flight at its own range (the folding erratum on [41]), and each trip through
its own two-way rain loss along the straight way to its cell's centre (K_r of [3] holds
L_atm², L_atm the rain's γ_r R_s of [16]); a rain cylinder by its own chord.  Only the radar
constant K_r of [3] is taken from the project (it is not what is tested here).

The project's side is what a run computes: the shipped scenes' radars (the jammed_squall's
Giraffe, the raid's SPS-49) in rain, the weather map built by the scene's table spec, and
the dwell model's ``clutter_at`` (the map's reader, or the trip sum of a rain region).
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from shipradar.sim.dwell.model import DwellModel
from shipradar.sim.world.scenario import parse_scenario
from shipradar.tables.scene import SceneTables, table_specs

ROOT = Path(__file__).resolve().parents[1]

C = 299_792_458.0
EARTH_RADIUS_M = 6_371_008.8
#: [42]: K = 7e-48 up to 6 GHz, 13e-48 from 35 GHz, linear between [s⁴/m].
K_LOW, K_HIGH = 7.0e-48, 13.0e-48
#: [45]: the seed's shear k [1/s] and turbulence σ_turb [m/s] (Nathanson).
SHEAR_PER_S, TURBULENCE_MPS = 4.0e-3, 1.0


def _scene(file: str, radar_id: str, rain: dict):
    d = yaml.safe_load((ROOT / "scenarios" / file).read_text())
    d["environment"]["rain"] = rain
    d["fidelity"] = {**d.get("fidelity", {}), "propagation": "two_ray", "atmosphere": True,
                     "clutter": True}
    s = parse_scenario(d)
    platform, radar = next((p, r) for p, r in s.radars() if r.id == radar_id)
    spec = next(sp for sp in table_specs(s) if sp.radar_id == radar_id
                and sp.kind == "weather_clutter")
    tables = SceneTables()
    tables.for_radar(radar_id).weather_clutter = spec.make()
    return DwellModel(s, platform, radar, tables), radar


def _project_power(m: DwellModel, ground_range, azimuth):
    n = np.size(ground_range)
    geom = SimpleNamespace(ground_range=np.asarray(ground_range, float),
                           azimuth=np.asarray(azimuth, float), radial_velocity=np.zeros(n))
    out = m.clutter_at(geom, np.zeros((n, 3)), np.zeros((n, 2)))
    return out["power_w"], out["spread_mps"]


def _gamma_db_per_km(freq_hz, rate_mm_h, polarization):
    from itur.models import itu838

    tau = {"H": 0.0, "V": 90.0}[polarization]
    return float(itu838.rain_specific_attenuation(rate_mm_h, freq_hz / 1e9, 0.0, tau).value)


def _chord_fraction(p0, p1, centre, radius):
    """Fraction of the horizontal segment p0 -> p1 inside a circle (by hand)."""
    d = (p1[0] - p0[0], p1[1] - p0[1])
    f = (p0[0] - centre[0], p0[1] - centre[1])
    a = d[0] ** 2 + d[1] ** 2
    b = 2 * (f[0] * d[0] + f[1] * d[1])
    c = f[0] ** 2 + f[1] ** 2 - radius**2
    disc = b * b - 4 * a * c
    if a == 0.0 or disc <= 0.0:
        return 0.0
    t0, t1 = (-b - math.sqrt(disc)) / (2 * a), (-b + math.sqrt(disc)) / (2 * a)
    return max(0.0, min(t1, 1.0) - max(t0, 0.0))


def reference_power_w(radar, rain: dict, k_r, ground_range, azimuth, attenuate=True):
    """P_wc at the delay of ground range R along ``azimuth``, and its spread σ_v [m/s]."""
    f = radar.frequency_hz
    k_const = K_LOW if f <= 6e9 else K_HIGH if f >= 35e9 else (
        K_LOW + (f - 6e9) / (35e9 - 6e9) * (K_HIGH - K_LOW))
    eta = k_const * f**4 * rain["rate_mm_h"] ** 1.6
    theta_b, phi_b = math.radians(radar.beamwidth_az_deg), math.radians(radar.beamwidth_el_deg)
    c_r = C * radar.pulse_width_s / 2
    h_a, h_cloud = radar.antenna_height_m, rain["cloud_base_m"]
    gamma = _gamma_db_per_km(f, rain["rate_mm_h"], radar.polarization) if attenuate else 0.0
    a_e = 4.0 / 3.0 * EARTH_RADIUS_M
    r_u = C / (2 * radar.prf_hz)
    region = rain.get("region")
    lam = C / f
    sigma_r = (2 * math.pi / radar.scan_period_s) / (5.35 * theta_b)  # [37], Hz

    def trip(x):
        if x <= 0.0:
            return 0.0, 0.0
        cell_en = (x * math.sin(azimuth), x * math.cos(azimuth))
        d_h = min(h_cloud, x * phi_b)
        way = math.hypot(x, h_a - d_h / 2)  # straight to the cell's centre, antenna in rain
        if region is not None:
            centre = (region["east_m"], region["north_m"])
            if math.hypot(cell_en[0] - centre[0], cell_en[1] - centre[1]) > region["radius_m"]:
                return 0.0, 0.0
            way *= _chord_fraction((0.0, 0.0), cell_en, centre, region["radius_m"])
        slant = math.sqrt((a_e + h_a) ** 2 + a_e**2 - 2 * a_e * (a_e + h_a) * math.cos(x / a_e))
        p = k_r * eta * x * theta_b * d_h * c_r / slant**4 * 10 ** (-2 * gamma * way / 1e4)
        shear = min(0.42 * SHEAR_PER_S * x * phi_b, SHEAR_PER_S * h_cloud / math.sqrt(12))
        sigma_hz2 = (2 / lam) ** 2 * (shear**2 + TURBULENCE_MPS**2) + sigma_r**2
        return p, sigma_hz2

    r = math.fmod(ground_range, r_u)
    total = second = 0.0
    x = r
    while x <= max(radar.instrumented_range_m, ground_range):
        p, s2 = trip(x)
        total += p
        second += p * s2
        x += r_u
    spread_mps = math.sqrt(second / total) * lam / 2 if total > 0 else math.nan
    return total, spread_mps


GIRAFFE = ("jammed_squall.yaml", "giraffe")
SPS49 = ("raid.yaml", "sps49")
#: Ground ranges [m]: near, mid, just either side of R_u and of 2 R_u (folded), far.
RANGES = {"giraffe": [2.0e3, 10e3, 20e3, 29.9e3, 30.1e3, 45e3, 59.9e3, 59.95e3],
          "sps49": [5e3, 50e3, 120e3, 149.8e3, 150.0e3, 200e3, 249e3]}


@pytest.mark.parametrize("which", [GIRAFFE, SPS49], ids=["giraffe", "sps49"])
@pytest.mark.parametrize("rate", [4.0, 16.0, 50.0])
def test_rain_everywhere_matches_the_reference(table_cache, which, rate):
    rain = {"rate_mm_h": rate, "cloud_base_m": 2500.0}
    m, radar = _scene(*which, rain)
    ranges = np.array(RANGES[radar.id])
    az = np.full(ranges.size, 0.7)
    power, spread = _project_power(m, ranges, az)
    ref = [reference_power_w(radar, rain, m.k_r0, x, 0.7) for x in ranges]
    ref_p = np.array([p for p, _ in ref])
    err_db = 10 * np.log10(power / ref_p)
    assert np.max(np.abs(err_db)) < 0.5, (ranges, err_db)
    # the attenuation is really there: against the same reference without rain loss, the
    # farthest unfolded range lost at least its first trip's 2 γ_r R (later trips lose more)
    gamma = _gamma_db_per_km(radar.frequency_hz, rate, radar.polarization)
    i = int(np.argmax(np.where(ranges < C / (2 * radar.prf_hz), ranges, 0.0)))
    dry = reference_power_w(radar, rain, m.k_r0, ranges[i], 0.7, attenuate=False)[0]
    assert 10 * np.log10(dry / power[i]) >= 2 * gamma * ranges[i] / 1e3 - 0.05
    ref_s = np.array([s for _, s in ref])
    assert spread == pytest.approx(ref_s, rel=0.02)


def test_rain_region_and_folded_trips_match_the_reference(table_cache):
    """The jammed_squall's cell (7.5 km radius, 18 km south) at 50 mm/h: looks due south
    through it, beside it, and at delays whose second or third trip falls in it."""
    rain = {"rate_mm_h": 50.0, "cloud_base_m": 2500.0,
            "region": {"east_m": 0.0, "north_m": -18000.0, "radius_m": 7500.0}}
    m, radar = _scene(*GIRAFFE, rain)
    r_u = C / (2 * radar.prf_hz)
    south, beside = math.pi, math.pi - 0.3
    looks = [(x, south) for x in (11e3, 14e3, 18e3, 22e3, 25e3, 14e3 + r_u, 20e3 + r_u,
                                  24e3 + r_u - 100.0)]
    looks += [(x, beside) for x in (20e3, 25e3)]
    ranges = np.array([x for x, _ in looks])
    az = np.array([a for _, a in looks])
    power, _ = _project_power(m, ranges, az)
    ref = np.array([reference_power_w(radar, rain, m.k_r0, x, a)[0] for x, a in looks])
    inside = ref > 0
    assert np.all(power[~inside] == 0.0)
    err_db = 10 * np.log10(power[inside] / ref[inside])
    assert np.max(np.abs(err_db)) < 0.5, err_db
    # the far edge of the cell, 25.5 km south: 15 km of rain each way at P.838's γ_r
    gamma = _gamma_db_per_km(radar.frequency_hz, 50.0, "V")
    assert 2 * gamma * 15.0 > 4.0


@pytest.mark.parametrize("which", [GIRAFFE, SPS49], ids=["giraffe", "sps49"])
def test_shear_spread_stays_within_the_rain_layer(table_cache, which):
    """The map's spread, less the scan [37] and turbulence [44], is a velocity spread the
    rain layer can make: at most the standard deviation of k z over a uniformly filled layer
    0 <= z <= h_cloud (computed here by sampling the layer), far below the 20-48 m/s the
    elevation beamwidth alone gave."""
    h_cloud = 2500.0
    m, radar = _scene(*which, {"rate_mm_h": 16.0, "cloud_base_m": h_cloud})
    table = m.tables.weather_clutter
    ranges = table.axes[0][table.axes[0] > 0.0]
    lam = C / radar.frequency_hz
    sigma_r = (2 * math.pi / radar.scan_period_s) / (5.35 * math.radians(radar.beamwidth_az_deg))
    total_hz = table.extra["doppler_spread_hz"][table.axes[0] > 0.0, 0]
    shear = np.sqrt(np.maximum((total_hz**2 - sigma_r**2) * (lam / 2) ** 2
                               - TURBULENCE_MPS**2, 0.0))
    layer = float(np.std(SHEAR_PER_S * np.linspace(0.0, h_cloud, 100_001)))
    assert layer == pytest.approx(10.0 / math.sqrt(12.0), rel=1e-4)
    assert np.max(shear) <= layer * (1 + 1e-6)
    # and the seed's beam-limited value where the beam is thinner than the layer
    phi_b = math.radians(radar.beamwidth_el_deg)
    near = (ranges * phi_b * 0.42 < 0.5 * h_cloud / math.sqrt(12)) & (ranges > 500.0)
    if near.any():
        assert shear[near] == pytest.approx(0.42 * SHEAR_PER_S * ranges[near] * phi_b,
                                            rel=0.02)
