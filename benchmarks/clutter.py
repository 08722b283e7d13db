"""Benchmark: build time of sea-clutter maps and the on-line cost of reading them per dwell.

Two radars like the raid scenario's: L band (1.3 GHz, HP, 20 m antenna, 20 µs long pulse) and
C band (5.6 GHz, VP, 25 m antenna, 0.25 µs).  Maps 0-150 km × 360 azimuths, at 1501 ranges
(100 m) and at the C-band range cell (37.5 m, 4001 ranges).  On-line: one dwell reads a few
hundred cells (the range cells of one beam position) of the power and the Weibull a, μ, σ.
Prints numbers measured in-process (time.perf_counter, best of N).
"""

from __future__ import annotations

import math
import time

import numpy as np

from tables.clutter import (
    ClutterMapReader,
    build_sea_clutter_map,
    build_weather_clutter_map,
    lookup_clutter,
)

BW_EL = math.radians(20.0)


def cosec2_like(elev):
    """Gaussian main beam tilted up by half a beamwidth; a fixed stand-in elevation pattern."""
    return np.exp(-math.log(2.0) * ((np.asarray(elev) - BW_EL / 2) / BW_EL) ** 2 * 2.0 / 2.0)


RADARS = {
    "L-band 1.3 GHz HP 20 m, 20 us": dict(
        freq_hz=1.3e9,
        polarization="H",
        antenna_height_m=20.0,
        beamwidth_az_rad=math.radians(1.4),
        pulse_width_s=20e-6,
        radar_constant_w_m2=8.0e3,
        noise_power_w=1.38e-23 * 500 / 20e-6,
    ),
    "C-band 5.6 GHz VP 25 m, 0.25 us": dict(
        freq_hz=5.6e9,
        polarization="V",
        antenna_height_m=25.0,
        beamwidth_az_rad=math.radians(1.5),
        pulse_width_s=0.25e-6,
        radar_constant_w_m2=3.0e2,
        noise_power_w=1.38e-23 * 600 / 0.25e-6,
    ),
}
ENV = dict(
    elevation_pattern=("gaussian", BW_EL, 0.0, BW_EL / 2),
    rotation_rate_rad_s=2 * math.pi / 4,
    wind_speed_mps=9.0,
    wind_direction_rad=math.radians(30.0),
    wave_height_m=1.5,
    duct_height_m=12.0,
    max_range_m=150e3,
    n_azimuth=360,
)


def best_of(fn, n):
    best = math.inf
    out = None
    for _ in range(n):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def main() -> None:
    rng = np.random.default_rng(0)
    for name, radar in RADARS.items():
        for n_range in (1501, 4001):
            kw = {**ENV, **radar, "n_range": n_range}
            t_build, table = best_of(
                lambda kw=kw: build_sea_clutter_map(elevation_directivity=cosec2_like, **kw), 3
            )
            cells = table.values.size
            print(
                f"{name}: build {n_range}x361 map: {t_build * 1e3:.0f} ms "
                f"({t_build / cells * 1e9:.0f} ns/cell)"
            )
        for n_cells in (300, 3000):
            ranges = np.sort(rng.uniform(0.0, 150e3, n_cells))
            az = rng.uniform(0.0, 2 * math.pi)

            def dwell(table=table, ranges=ranges, az=az):
                p = lookup_clutter(table, ranges, az)
                a = lookup_clutter(table, ranges, az, "weibull_a")
                mu = lookup_clutter(table, ranges, az, "doppler_mean_hz")
                sd = lookup_clutter(table, ranges, az, "doppler_spread_hz")
                return p, a, mu, sd

            t_dwell, _ = best_of(dwell, 200)
            print(
                f"{name}: Table.lookup of {n_cells} cells x 4 arrays: "
                f"{t_dwell * 1e6:.0f} us per dwell"
            )
            reader = ClutterMapReader(table)
            t_fast, _ = best_of(lambda r=reader, x=ranges, a=az: r.read(x, a), 200)
            print(
                f"{name}: ClutterMapReader.read of {n_cells} cells x 6 arrays: "
                f"{t_fast * 1e6:.0f} us per dwell"
            )
    kw = dict(
        freq_hz=5.6e9,
        antenna_height_m=25.0,
        beamwidth_az_rad=math.radians(1.5),
        beamwidth_el_rad=BW_EL,
        pulse_width_s=0.25e-6,
        prf_hz=1000.0,
        radar_constant_w_m2=3.0e2,
        rain_rate_mm_h=4.0,
        cloud_base_m=3000.0,
        rotation_rate_rad_s=2 * math.pi / 4,
        wind_speed_mps=9.0,
        wind_direction_rad=0.5,
        max_range_m=150e3,
        n_range=1501,
        n_azimuth=360,
    )
    t_w, _ = best_of(lambda: build_weather_clutter_map(**kw), 3)
    print(f"C-band weather map 1501x361: build {t_w * 1e3:.0f} ms")


if __name__ == "__main__":
    main()
