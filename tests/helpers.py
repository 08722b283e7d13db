"""Shared test helpers: small scenarios, a capturing bus, free loopback ports."""

from __future__ import annotations

import copy
import socket
from pathlib import Path

import yaml

from shipradar.sim import protocol
from shipradar.sim.scenario import parse_scenario

ROOT = Path(__file__).resolve().parents[1]


def example(name: str) -> dict:
    return yaml.safe_load((ROOT / "scenarios" / f"{name}.yaml").read_text())


def scenario(data: dict, **fidelity):
    d = copy.deepcopy(data)
    d.setdefault("fidelity", {}).update(fidelity)
    return parse_scenario(d)


def quiet_radar(**over) -> dict:
    """A C-band radar in free space: isotropic elevation pattern, T_a given, no processor."""
    r = {
        "id": "r1", "peak_power_w": 50000, "gain_db": 30, "frequency_hz": 5.6e9,
        "polarization": "H", "antenna_height_m": 20, "beamwidth_az_deg": 2.0,
        "beamwidth_el_deg": 20.0, "pattern_az": {"type": "gaussian"},
        "pattern_el": {"type": "isotropic"}, "rotation_rpm": 60, "prf_hz": 2000,
        "pulse_width_s": 1e-6, "noise_figure_db": 3, "loss_tr_db": 2,
        "antenna_temperature_k": 290.0, "false_alarm_time_s": 60,
        "processor": {"type": "none"}, "instrumented_range_m": 60000,
    }
    r.update(over)
    return r


def bare_scene(radar: dict | None = None, targets=(), duration_s=10.0, seed=3, **fidelity):
    fid = {"propagation": "free_space", "atmosphere": False, "clutter": False}
    fid.update(fidelity)
    return parse_scenario({
        "name": "bare", "duration_s": duration_s, "seed": seed,
        "origin": {"lat_deg": 44.6, "lon_deg": -63.0},
        "platforms": [{"id": "ship", "waypoints": [{"east_m": 0, "north_m": 0}],
                       "radars": [radar or quiet_radar()]}],
        "targets": list(targets),
        "fidelity": fid,
    })


class CaptureBus:
    """Keeps decoded messages (and the encoded frames) in memory."""

    def __init__(self):
        self.messages = []
        self.frames = []

    def emit(self, topic, t, payload):
        frames = protocol.encode(topic, t, payload)
        self.frames.append(frames)
        self.messages.append(protocol.decode(frames))

    def flush(self):
        pass

    def of(self, topic: bytes):
        return [(t, p) for top, t, p in self.messages if top == topic]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]
