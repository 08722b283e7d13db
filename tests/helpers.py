"""Shared test helpers: small scenarios, a capturing bus, free loopback ports."""

from __future__ import annotations

import copy
import math
import os
import shutil
import socket
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml

from shipradar.sim.stream import protocol
from shipradar.sim.world.scenario import parse_scenario

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


def moving_ship_scene(radar: dict, *, name: str, duration_s: float, seed: int,
                      speed_mps: float, course_deg: float, wind_speed_mps: float,
                      wind_from_deg: float, clutter: bool, targets=(), sea_state: int = 3):
    """One ship with ``radar`` leaving the origin at ``speed_mps`` [m/s] on ``course_deg``
    [deg] (a straight leg of 1000 s), in sea state ``sea_state`` with the wind
    ``wind_speed_mps`` [m/s] from ``wind_from_deg`` [deg]; free space, no atmosphere, the
    clutter's power modelled when ``clutter``."""
    c = math.radians(course_deg)
    return parse_scenario({
        "name": name, "duration_s": duration_s, "seed": seed,
        "origin": {"lat_deg": 44.6, "lon_deg": -63.0},
        "environment": {"wind_speed_mps": wind_speed_mps, "wind_direction_deg": wind_from_deg,
                        "sea_state": sea_state},
        "platforms": [{"id": "ship", "waypoints": [
            {"time_s": 0.0, "east_m": 0.0, "north_m": 0.0},
            {"time_s": 1000.0, "east_m": 1000.0 * speed_mps * math.sin(c),
             "north_m": 1000.0 * speed_mps * math.cos(c)}], "radars": [radar]}],
        "targets": list(targets),
        "fidelity": {"propagation": "free_space", "atmosphere": False, "clutter": clutter},
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


def require_system_tool(find, package: str) -> str:
    """The path of a tool from a Debian package, installed now when missing (as root, with
    apt-get); the test is skipped without it, and failed under CI (``CI`` set), where every
    test must run.

    Parameters
    ----------
    find : callable
        Returns the tool's path or None (e.g. ``lambda: shutil.which("tshark")``).
    package : str
        The Debian package that provides it.
    """
    path = find()
    if path is None and os.geteuid() == 0 and shutil.which("apt-get"):
        env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
        subprocess.run(["apt-get", "update", "-q"], capture_output=True, env=env, timeout=600)
        subprocess.run(["apt-get", "install", "-y", "-q", package], capture_output=True,
                       env=env, timeout=900)
        path = find()
    if path is None:
        message = f"{package} is not installed and could not be (apt-get install {package})"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    return path


def identical_radars_scene(n: int = 3):
    """The demo scene with its radar copied ``n`` times (ids r0.., SIC 1..): every sector of
    every radar ends at the same instants, the case where only SimPy's tie order (scenario
    order) decides the order of the messages."""
    from shipradar.sim.world.scenario import Scenario, load_scenario

    doc = load_scenario(ROOT / "scenarios/single_missile.yaml").model_dump(mode="json")
    plat = doc["platforms"][0]
    radar = plat["radars"][0]
    plat["radars"] = [{**radar, "id": f"r{k}", "sic": k + 1} for k in range(n)]
    return Scenario.model_validate(doc)


def package_modules() -> dict[str, Path]:
    """Every module of the installed ``shipradar`` package and its source file, found by the
    import system itself (pkgutil over the package's path, whatever folders it maps)."""
    import importlib.util
    import pkgutil

    import shipradar

    out = {"shipradar": Path(str(shipradar.__file__))}
    for info in pkgutil.walk_packages(shipradar.__path__, "shipradar."):
        spec = importlib.util.find_spec(info.name)
        if spec is not None and spec.origin and spec.origin.endswith(".py"):
            out[info.name] = Path(spec.origin)
    return out


def random_clutter_generator(eta, rng, clutter_fa_model: str = "seed"):
    """A P_fac generator over random sectors with the expected counts ``eta``: ranges in
    0-52 km, azimuths across north, drawn from ``rng`` in a fixed order (the tests' data
    depend on it)."""
    import numpy as np

    from shipradar.sensors.false_alarms import ClutterFalseAlarms

    n = np.asarray(eta).size
    r0 = rng.uniform(0.0, 5e4, n)
    a0 = rng.uniform(-0.5, 2.0 * np.pi, n)
    return ClutterFalseAlarms(
        r0, r0 + rng.uniform(0.0, 2e3, n), a0, a0 + rng.uniform(0.0, 0.2, n), np.ones(n), eta,
        rng.uniform(0.5, 4.0, n), threshold_ratio=12.0, n_channels=2, n_pulses=10.0,
        range_cell_m=30.0, beamwidth_rad=0.03, antenna_height_m=25.0,
        clutter_fa_model=clutter_fa_model)


class KeepingPublisher:
    """What :class:`shipradar.sim.stream.bus.Bus` needs of a publisher, keeping every
    (topic, body) it is sent."""

    def __init__(self):
        self.sent = []

    def send(self, frames):
        self.sent.append((bytes(frames[0]), bytes(frames[1])))

    def close(self, linger_ms=0):
        pass

    @property
    def stats(self):
        return {}


def first_crossings(geometry_at, t_start, beam0, omega, n, speed_m_s):
    """The first beam crossing of each of ``n`` objects in the revolution from ``t_start``
    [s] (NaN if none), by :func:`shipradar.sim.world.kinematics.beam_crossings`;
    ``geometry_at(t, rows)`` gives their azimuth [rad] and ground range [m] (no rate: the
    Newton steps then take the beam's alone), ``speed_m_s`` bounds their speed relative to
    the antenna."""
    from shipradar.sim.world.kinematics import beam_crossings

    def look_at(t, rows):
        az, ground = geometry_at(t, rows)
        return az, np.zeros(t.size), ground

    period = 2 * np.pi / omega
    pair, t = beam_crossings(look_at, np.full(n, t_start), np.full(n, t_start + period),
                             np.full(n, beam0), np.full(n, beam0 + 2 * np.pi), omega,
                             np.full(n, speed_m_s))
    first = np.full(n, np.nan)
    keep = np.r_[True, pair[1:] != pair[:-1]] if pair.size else pair.astype(bool)
    first[pair[keep]] = t[keep]
    return first
