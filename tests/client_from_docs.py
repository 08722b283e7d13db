"""A tracker's front end written from docs/protocol.md and the shipped JSON Schemas only.

No ``shipradar`` import (``tests/test_client_from_docs.py`` checks it): pyzmq, msgpack and
numpy, as a tracker in another code base would have them. What it relies on, by section:

- 1, 2, 5: two frames ``[topic, body]``; the body a msgpack map with ``v``, ``t``; arrays as
  msgpack extension type 1 (section 3), decoded as section 5 does.
- 4.1/4.3: the antenna position, velocity and heading of ``meta`` at the start of a scan when
  present, else the latest ``eos``; ``origin`` of ``meta`` for the local frame.
- 4: azimuths from true north, clockwise; ranges slant ranges from the antenna over the 4/3
  effective earth; local east/north on the plane tangent at the origin, projected onto the
  sphere of the origin's Gaussian radius, ``up`` the height above the sea.
- 4.2 (measurement errors): Gaussian, range and azimuth independent, σ one standard deviation.
- 4.4: ``truth[targets]`` states at each end of scan; ``truth[plots]`` origins and
  contributors; ``end`` marks the end of the run (when the stream has it).
- The JSON Schemas (``x-length``, ``required``) for which columns go together.
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import msgpack
import numpy as np
import zmq

A_WGS84 = 6_378_137.0
F_WGS84 = 1.0 / 298.257223563
K_EFFECTIVE = 4.0 / 3.0


# ------------------------------------------------------------------ section 5: decoding
def ext_hook(code: int, data: bytes) -> Any:
    """msgpack ext type 1 -> numpy array (section 5)."""
    if code != 1:
        return msgpack.ExtType(code, data)
    ndim, lts = data[0], data[1]
    dtype = np.dtype(data[2:2 + lts].decode("ascii"))
    pos = (2 + lts + 7) // 8 * 8
    shape = struct.unpack_from(f"<{ndim}Q", data, pos)
    return np.frombuffer(data, dtype, offset=pos + 8 * ndim).reshape(shape)


def decode_body(body: bytes, versions: tuple[int, ...]) -> dict[str, Any]:
    msg = msgpack.unpackb(body, ext_hook=ext_hook, raw=False)
    if msg["v"] not in versions:
        raise ValueError(f"unsupported schema version {msg['v']}")
    return msg


def schema_versions(schema_dir: Path) -> tuple[int, ...]:
    """The schema versions the shipped contract accepts (its ``v``)."""
    s = json.loads((schema_dir / "plots.schema.json").read_text(encoding="utf-8"))
    v = s["properties"]["v"]
    return tuple(v["enum"]) if "enum" in v else (v["const"],)


def plot_columns(schema_dir: Path) -> list[str]:
    """The per-plot columns of ``plots`` (``x-length`` ``n``) from its JSON Schema."""
    s = json.loads((schema_dir / "plots.schema.json").read_text(encoding="utf-8"))
    return [k for k, p in s["properties"].items() if p.get("x-length") == "n"]


# ------------------------------------------------------------------ section 4: the frame
class Frame:
    """The local frame of ``meta.origin``: east/north on the tangent plane, projected onto
    the sphere of the Gaussian radius √(M N) at the origin; ``up`` the height above the sea."""

    def __init__(self, lat_deg: float, lon_deg: float):
        lat, lon = np.radians(lat_deg), np.radians(lon_deg)
        e2 = F_WGS84 * (2.0 - F_WGS84)
        self.radius = A_WGS84 * np.sqrt(1.0 - e2) / (1.0 - e2 * np.sin(lat) ** 2)
        self.up0 = np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
        self.east0 = np.array([-np.sin(lon), np.cos(lon), 0.0])
        self.north0 = np.cross(self.up0, self.east0)

    def unit(self, east: np.ndarray, north: np.ndarray) -> np.ndarray:
        t = (self.radius * self.up0 + np.multiply.outer(east, self.east0)
             + np.multiply.outer(north, self.north0))
        return t / np.linalg.norm(t, axis=-1, keepdims=True)

    @staticmethod
    def _north_east(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        horiz = np.hypot(u[..., 0], u[..., 1])
        east = np.stack([-u[..., 1] / horiz, u[..., 0] / horiz, np.zeros_like(horiz)], -1)
        return np.cross(u, east), east

    def to_plot(self, antenna: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Slant range [m] and true-north azimuth [rad] of local points ``target`` (..., 3)
        from local antenna positions ``antenna`` (..., 3), up = height above the sea."""
        u_a = self.unit(antenna[..., 0], antenna[..., 1])
        u_t = self.unit(target[..., 0], target[..., 1])
        north, east = self._north_east(u_a)
        chord = u_t - u_a
        az = np.mod(np.arctan2(np.sum(chord * east, -1), np.sum(chord * north, -1)), 2 * np.pi)
        ground = self.radius * np.arctan2(np.linalg.norm(np.cross(u_a, u_t), axis=-1),
                                          np.sum(u_a * u_t, -1))
        a_e = K_EFFECTIVE * self.radius
        r1, r2 = a_e + antenna[..., 2], a_e + target[..., 2]
        slant = np.sqrt((r2 - r1) ** 2 + 4 * r1 * r2 * np.sin(0.5 * ground / a_e) ** 2)
        return slant, az

    def place(self, antenna: np.ndarray, range_m: np.ndarray, azimuth_rad: np.ndarray,
              up_m: np.ndarray) -> np.ndarray:
        """Local east/north/up of plots (the inverse of :meth:`to_plot`) for an assumed
        height ``up_m`` (a 2-D radar measures none)."""
        a_e = K_EFFECTIVE * self.radius
        r1, r2 = a_e + antenna[..., 2], a_e + up_m
        s2 = np.clip((range_m ** 2 - (r2 - r1) ** 2) / (4 * r1 * r2), 0.0, 1.0)
        ground = 2 * a_e * np.arcsin(np.sqrt(s2))
        u_a = self.unit(antenna[..., 0], antenna[..., 1])
        north, east = self._north_east(u_a)
        d = ground / self.radius
        heading = (np.cos(azimuth_rad)[..., None] * north
                   + np.sin(azimuth_rad)[..., None] * east)
        u_t = np.cos(d)[..., None] * u_a + np.sin(d)[..., None] * heading
        t = u_t * (self.radius / np.sum(u_t * self.up0, -1))[..., None]
        return np.stack([t @ self.east0, t @ self.north0, up_m], -1)


# ------------------------------------------------------------------ the client
@dataclass
class SensorState:
    t: float
    position: np.ndarray  # local east, north, up [m]
    velocity: np.ndarray  # east, north, up [m/s]

    def at(self, t: np.ndarray) -> np.ndarray:
        dt = np.asarray(t, dtype=float) - self.t
        return self.position + np.multiply.outer(dt, self.velocity)


@dataclass
class Client:
    """Collects what a tracker sees (plots placed with the sensor state of the stream) and
    what an evaluator sees (truth), until ``end`` or silence."""

    schema_dir: Path
    use_meta_position: bool = True
    frame: Frame | None = None
    sensor_state: dict[str, SensorState] = field(default_factory=dict)
    state_source: dict[str, str] = field(default_factory=dict)
    placed_with: dict[str, int] = field(default_factory=dict)
    plots: dict[tuple[str, int], dict[str, Any]] = field(default_factory=dict)
    truth_plots: dict[tuple[str, int], dict[str, Any]] = field(default_factory=dict)
    truth_states: dict[float, dict[str, Any]] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)
    ended: bool = False

    def __post_init__(self) -> None:
        self.versions = schema_versions(self.schema_dir)
        self.columns = plot_columns(self.schema_dir)

    def _state(self, msg: dict[str, Any]) -> SensorState:
        p = msg["position"]
        return SensorState(float(msg["t"]), np.array([p["east_m"], p["north_m"], p["up_m"]]),
                           np.asarray(msg["velocity_enu_mps"], dtype=float))

    def handle(self, topic: bytes, body: bytes) -> None:
        msg = decode_body(body, self.versions)
        name = topic.decode("ascii")
        self.counts[name] = self.counts.get(name, 0) + 1
        if topic == b"meta" and self.frame is None:
            self.frame = Frame(msg["origin"]["lat_deg"], msg["origin"]["lon_deg"])
        if "position" in msg and (topic == b"eos" or topic == b"meta" and self.use_meta_position):
            # the latest antenna state: meta's at the start of a scan (section 4.1) when the
            # stream carries it, else the last end of scan's (4.3)
            old = self.sensor_state.get(msg["sensor"])
            if old is None or old.t <= msg["t"]:
                self.sensor_state[msg["sensor"]] = self._state(msg)
                self.state_source[msg["sensor"]] = name
        if topic == b"plots":
            self._place(msg)
        elif topic == b"truth":
            if msg["kind"] == "plots":
                for i, pid in enumerate(msg["plot_id"]):
                    a, b = msg["contrib_offsets"][i], msg["contrib_offsets"][i + 1]
                    self.truth_plots[(msg["sensor"], int(pid))] = {
                        "origin": int(msg["origin"][i]), "target": int(msg["target"][i]),
                        "contributors": int(b - a)}
            else:
                keys = ("east_m", "north_m", "up_m", "v_east_mps", "v_north_mps", "v_up_mps",
                        "active")
                self.truth_states[float(msg["time_s"])] = {k: np.array(msg[k]) for k in keys}
        elif topic == b"end":
            self.ended = True

    def _place(self, msg: dict[str, Any]) -> None:
        state = self.sensor_state.get(msg["sensor"])
        if state is None or self.frame is None:
            return  # no position yet: a tracker would hold these plots
        source = self.state_source[msg["sensor"]]
        self.placed_with[source] = self.placed_with.get(source, 0) + len(msg["plot_id"])
        t = np.asarray(msg["time_s"])
        antenna = state.at(t)
        for i, pid in enumerate(msg["plot_id"]):
            self.plots[(msg["sensor"], int(pid))] = {
                **{c: float(msg[c][i]) for c in self.columns if c in msg},
                "antenna": antenna[i], "state_t": state.t}

    def run(self, endpoint: str, idle_s: float, alive: Any) -> None:
        """Receive until ``end``, or ``idle_s`` without a message once ``alive()`` is
        false (the publisher has exited)."""
        sub = zmq.Context.instance().socket(zmq.SUB)
        sub.setsockopt(zmq.LINGER, 0)
        sub.setsockopt(zmq.SUBSCRIBE, b"")
        sub.connect(endpoint)
        try:
            while not self.ended:
                if sub.poll(int(idle_s * 1000)):
                    topic, body = sub.recv_multipart()
                    self.handle(topic, body)
                elif not alive():
                    break
        finally:
            sub.close()

    # ------------------------------------------------------------------ scoring
    def truth_at(self, target: int, t: float) -> np.ndarray | None:
        """Target ``target``'s local position at ``t``: cubic Hermite between the two
        end-of-scan states around ``t`` (positions and velocities); None when either is
        missing or the target is inactive at either."""
        times = np.array(sorted(self.truth_states))
        k = int(np.searchsorted(times, t))
        if k == 0 or k >= times.size:
            return None
        s0, s1 = self.truth_states[times[k - 1]], self.truth_states[times[k]]
        if not (s0["active"][target] and s1["active"][target]):
            return None
        h = times[k] - times[k - 1]
        if h <= 0:
            return None
        x = (t - times[k - 1]) / h
        p0 = np.array([s0[c][target] for c in ("east_m", "north_m", "up_m")])
        p1 = np.array([s1[c][target] for c in ("east_m", "north_m", "up_m")])
        v0 = np.array([s0[c][target] for c in ("v_east_mps", "v_north_mps", "v_up_mps")])
        v1 = np.array([s1[c][target] for c in ("v_east_mps", "v_north_mps", "v_up_mps")])
        h00, h10 = 2 * x**3 - 3 * x**2 + 1, x**3 - 2 * x**2 + x
        h01, h11 = -2 * x**3 + 3 * x**2, x**3 - x**2
        return h00 * p0 + h10 * h * v0 + h01 * p1 + h11 * h * v1

    def normalised_errors(self) -> dict[str, np.ndarray]:
        """Range and azimuth errors over σ of every single-target plot, against the truth's
        position at the plot's time seen from the antenna's; and, for each, how far the
        plot placed in the local frame at the truth's height is from where it measures
        (``roundtrip``: the larger of its range [m] and azimuth [µrad] differences)."""
        assert self.frame is not None
        z_r, z_a, placed = [], [], []
        for key, plot in self.plots.items():
            truth = self.truth_plots.get(key)
            if truth is None or truth["origin"] != 0 or truth["contributors"] != 1:
                continue
            pos = self.truth_at(truth["target"], plot["time_s"])
            if pos is None:
                continue
            r, az = self.frame.to_plot(plot["antenna"], pos)
            z_r.append((plot["range_m"] - r) / plot["sigma_range_m"])
            d_az = (plot["azimuth_rad"] - az + np.pi) % (2 * np.pi) - np.pi
            z_a.append(d_az / plot["sigma_azimuth_rad"])
            where = self.frame.place(plot["antenna"], plot["range_m"], plot["azimuth_rad"],
                                     pos[2])
            r_back, az_back = self.frame.to_plot(plot["antenna"], where)
            d_back = (az_back - plot["azimuth_rad"] + np.pi) % (2 * np.pi) - np.pi
            placed.append(max(abs(r_back - plot["range_m"]), 1e6 * abs(d_back)))
        return {"range": np.array(z_r), "azimuth": np.array(z_a),
                "roundtrip": np.array(placed)}
