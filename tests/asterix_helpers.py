"""Helpers of the ASTERIX and export tests: a small moving-ship scene, an in-memory sender,
tshark on demand."""

from __future__ import annotations

import json
import shutil
import subprocess

from shipradar.sim.world.scenario import parse_scenario

from .helpers import quiet_radar, require_system_tool

#: The scene starts 10 s before a UTC midnight, so every run crosses it.
START = "2026-06-01T23:59:50Z"


def scene_dict(duration_s: float = 8.0, radars=None, start: str = START,
               doppler: bool = False) -> dict:
    """A ship under way (10 m/s) with two radars and one closing target; many noise false
    alarms (t_fa 0.5 s), so a few seconds give a few dozen plots. ``doppler``: the first
    radar has a Doppler bank (its plots carry a range rate, I048/120), the second none."""
    bank = {"processor": {"type": "dft_bank", "n_coherent": 16}} if doppler else {}
    radars = radars or [
        quiet_radar(id="r1", false_alarm_time_s=0.5, **bank),
        # starts at 100°: its north crossings fall mid-revolution (dead-reckoned position)
        quiet_radar(id="r2", false_alarm_time_s=1.0, rotation_rpm=40, start_azimuth_deg=100.0,
                    beamwidth_az_deg=1.2, sac=25, sic=7),
    ]
    return {
        "name": "asterix", "duration_s": duration_s, "seed": 5, "start_time": start,
        "origin": {"lat_deg": 44.6, "lon_deg": -63.0},
        "platforms": [{"id": "ship", "radars": radars, "waypoints": [
            {"time_s": 0, "east_m": 0, "north_m": 0},
            {"time_s": 100, "east_m": 800, "north_m": 600}]}],
        "targets": [{"id": "m1", "rcs": {"type": "constant", "sigma_m2": 10.0}, "waypoints": [
            {"time_s": 0, "east_m": 20000, "north_m": 15000, "altitude_m": 50},
            {"time_s": 100, "east_m": 5000, "north_m": 3000, "altitude_m": 50}]}],
        "fidelity": {"propagation": "free_space", "atmosphere": False, "clutter": False},
    }


def scene(**kw):
    return parse_scenario(scene_dict(**kw))


def tshark_path() -> str:
    """tshark, installed now if missing (root); skipped without it, failed under CI."""
    return require_system_tool(lambda: shutil.which("tshark"), "tshark")


def tshark_asterix(pcap, port: int) -> list[dict]:
    """Wireshark's dissection of every ASTERIX data block of a pcap, in order: one
    ``{"category": int, "records": [message dict, ...]}`` per data block (a datagram may
    hold several)."""
    res = subprocess.run(
        [tshark_path(), "-r", str(pcap), "-d", f"udp.port=={port},asterix", "-T", "json",
         "--no-duplicate-keys"], capture_output=True, text=True, timeout=120, check=True)
    out = []
    for pkt in json.loads(res.stdout):
        layer = pkt["_source"]["layers"]["asterix"]
        for a in layer if isinstance(layer, list) else [layer]:
            msgs = a["asterix.message"]
            out.append({"category": int(a["asterix.category"]),
                        "records": msgs if isinstance(msgs, list) else [msgs]})
    return out


class MemorySender:
    """An :class:`~shipradar.sim.adapters.asterix.udp.UdpSender` that keeps the datagrams
    (``sent``, in order) instead of sending them: what an ``AsterixBus`` would put on the
    wire."""

    url = "memory"

    def __init__(self) -> None:
        self.sent: list[bytes] = []
        self.datagrams = 0
        self.bytes = 0

    def send(self, block: bytes) -> None:
        self.sent.append(block)
        self.datagrams += 1
        self.bytes += len(block)

    def close(self) -> None:
        pass
