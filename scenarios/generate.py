"""Write the raid and stress example scenarios (deterministic; run from the repository root).

    python scenarios/generate.py

The radar parameters are public-domain figures rounded to typical values, approximate:
an L-band long-range radar like the AN/SPS-49 (851-942 MHz, ~360 kW peak, 28.5 dB gain,
3.3° x 11° beam, 6/12 rpm, 125 µs pulse compressed to ~2 µs) and a C-band radar like the
Sea Giraffe (5.4-5.9 GHz, 1.8° x 20° cosec² beam, 60 rpm, ~10 µs pulse compressed to
~0.25 µs).  Neither radar's short blanking-range pulse is modelled (no eclipsing).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent

SPS49 = {
    "id": "sps49",
    "peak_power_w": 360000,
    "gain_db": 28.5,
    "frequency_hz": 9.0e8,
    "polarization": "H",
    "antenna_height_m": 30,
    "beamwidth_az_deg": 3.3,
    "beamwidth_el_deg": 11,
    "pattern_az": {"type": "sinc", "sidelobe_db": 30},
    "pattern_el": {"type": "cosec2", "sidelobe_db": 20, "tilt_deg": 3},
    "rotation_rpm": 12,
    "prf_hz": 1000,
    "stagger_prf_hz": [950, 1050],
    "pulse_width_s": 2.0e-6,
    "transmitted_pulse_width_s": 125.0e-6,
    "noise_figure_db": 3,
    "loss_tr_db": 3,
    "false_alarm_time_s": 120,
    "processor": {"type": "mti", "mti_order": 2},
    "instrumented_range_m": 250000,
}

GIRAFFE = {
    "id": "giraffe",
    "peak_power_w": 60000,
    "gain_db": 28,
    "frequency_hz": 5.6e9,
    "polarization": "V",
    "antenna_height_m": 25,
    "beamwidth_az_deg": 1.8,
    "beamwidth_el_deg": 20,
    "pattern_az": {"type": "sinc", "sidelobe_db": 28},
    "pattern_el": {"type": "cosec2", "sidelobe_db": 20, "tilt_deg": 2},
    "rotation_rpm": 60,
    "prf_hz": 5000,
    "pulse_width_s": 0.25e-6,
    "transmitted_pulse_width_s": 10.0e-6,
    "noise_figure_db": 4,
    "loss_tr_db": 4,
    "false_alarm_time_s": 60,
    "processor": {
        "type": "mti_bank",
        "mti_order": 1,
        "n_coherent": 8,
        "window": {"type": "chebyshev", "sidelobe_db": 50},
    },
    "instrumented_range_m": 100000,
}


def _inbound(rng, tid, kind, r0, r1, alt, speed, t0, ship_speed_north):
    """A straight inbound track from range r0 to r1 on a random bearing, starting at t0."""
    brg = rng.uniform(0.0, 2.0 * math.pi)
    t1 = t0 + (r0 - r1) / speed
    # aim at where the ship will be at t1 (ship steams north from the origin)
    e0, n0 = r0 * math.sin(brg), r0 * math.cos(brg) + ship_speed_north * t0
    e1, n1 = r1 * math.sin(brg), r1 * math.cos(brg) + ship_speed_north * t1
    wp = [
        {"time_s": round(t0, 1), "east_m": round(e0), "north_m": round(n0), "altitude_m": alt},
        {"time_s": round(t1, 1), "east_m": round(e1), "north_m": round(n1), "altitude_m": alt},
    ]
    return {"id": tid, "kind": kind, "waypoints": wp}


def raid() -> dict:
    rng = np.random.default_rng(20261122)
    v_ship = 9.0
    targets = []
    for i in range(16):
        t = _inbound(rng, f"missile{i + 1:02d}", "missile", rng.uniform(35e3, 60e3), 1500.0,
                     float(rng.choice([3.0, 5.0, 8.0])), 280.0, rng.uniform(0.0, 300.0), v_ship)
        t["rcs"] = {"type": "missile", "sigma_nose_m2": 0.1, "length_m": 4.7, "diameter_m": 0.35}
        targets.append(t)
    for i in range(8):
        t = _inbound(rng, f"aircraft{i + 1:02d}", "aircraft", rng.uniform(120e3, 200e3), 20e3,
                     float(rng.uniform(1000.0, 9000.0)).__round__(), 250.0, 0.0, v_ship)
        t["rcs"] = {"type": "constant", "sigma_m2": float(rng.choice([2.0, 5.0, 10.0]))}
        t["swerling"] = 1
        targets.append(t)
    return {
        "name": "raid",
        "description": "16 sea-skimming missiles and 8 aircraft on a frigate with an L-band "
        "(SPS-49-like) and a C-band (Sea Giraffe-like) radar; 10 minutes.",
        "start_time": "2026-06-01T12:00:00Z",
        "duration_s": 600,
        "seed": 7,
        "origin": {"lat_deg": 44.6, "lon_deg": -63.0},
        "platforms": [{
            "id": "frigate",
            "waypoints": [{"time_s": 0, "east_m": 0, "north_m": 0},
                          {"time_s": 3600, "east_m": 0, "north_m": v_ship * 3600}],
            "radars": [SPS49, GIRAFFE],
        }],
        "targets": targets,
        "environment": {"sea_state": 3, "wind_speed_mps": 8, "wind_direction_deg": 300,
                        "duct": {"type": "height", "height_m": 12}},
    }


def stress() -> dict:
    rng = np.random.default_rng(5)
    targets = []
    for i in range(220):
        missile = i % 3 == 0
        r0 = rng.uniform(20e3, 90e3)
        t = _inbound(rng, f"t{i:03d}", "missile" if missile else "aircraft", r0, 1000.0,
                     5.0 if missile else float(round(rng.uniform(300.0, 8000.0))),
                     280.0 if missile else 200.0, 0.0, 0.0)
        t["rcs"] = ({"type": "missile", "sigma_nose_m2": 0.1, "length_m": 4.7, "diameter_m": 0.35}
                    if missile else {"type": "constant", "sigma_m2": float(rng.uniform(1.0, 20.0))})
        targets.append(t)
    return {
        "name": "stress",
        "description": "220 targets on a stationary frigate in a rough sea (sea state 6).",
        "duration_s": 120,
        "seed": 11,
        "origin": {"lat_deg": 44.6, "lon_deg": -63.0},
        "platforms": [{"id": "frigate", "heading_deg": 90,
                       "waypoints": [{"time_s": 0, "east_m": 0, "north_m": 0}],
                       "radars": [GIRAFFE]}],
        "targets": targets,
        "environment": {"sea_state": 6, "wind_speed_mps": 15, "wind_direction_deg": 200},
    }


def main() -> None:
    for name, doc in (("raid", raid()), ("stress", stress())):
        text = "# Generated by scenarios/generate.py; edit that script, not this file.\n"
        text += yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=100)
        (HERE / f"{name}.yaml").write_text(text)


if __name__ == "__main__":
    main()
