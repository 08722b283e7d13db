"""Stone Soup detection reader for the shipradar stream (live endpoint or recording).

:class:`ShipradarDetectionReader` turns the ``meta``/``plots``/``eos`` topics of one sensor
into the ``(datetime, set[Detection])`` steps a Stone Soup tracker consumes. Each
:class:`~stonesoup.types.detection.Detection` carries its own
:class:`~stonesoup.models.measurement.nonlinear.CartesianToBearingRange` model, built from the
sensor's position at the plot's time and the plot's own expected errors, so a moving ship and
plots of unequal quality are handled without a shared model.

Conventions (read before using the detections)
---------------------------------------------
- Cartesian frame: the scenario's local frame at its origin, x = east, y = north [m] — the
  frame of ``eos.position.east_m/north_m`` and of the truth topic. The reader's state space
  is ``[x, vx, y, vy]`` (``mapping=(0, 2)``, Stone Soup's constant-velocity layout).
- Bearing: Stone Soup's ``CartesianToBearingRange`` measures ``atan2(y, x)``, anticlockwise
  from the x (east) axis, in [-π, π). The stream's azimuth is true north, clockwise, in
  [0, 2π). So ``bearing = π/2 - azimuth`` wrapped (:func:`azimuth_to_bearing`). The plots are
  already referenced to true north, so the model has no rotation offset; the ship's heading
  does not enter (it is kept in the detection metadata for information).
- Range: the plot's range (slant range on the 4/3 earth) is used as the horizontal range.
  For surface and sea-skimming targets the two differ by centimetres at tracking ranges; for
  high-altitude aircraft a 2D tracker sees a range bias of about h²/(2R) (1 km at 10 km
  altitude and 50 km): use a 3D model for them. The convergence of meridians between the
  antenna's and the origin's north is ignored (about 0.7° per 100 km east-west offset of the
  ship from the origin at 45° latitude).
- Noise: ``noise_covar = diag(σ_az², σ_r²)`` from the plot's ``sigma_azimuth_rad`` and
  ``sigma_range_m`` columns (the standard deviations the radar model reports, [84]-[89]).
- Sensor position at a plot's time: linear interpolation between the positions of the two
  end-of-scan markers that bracket the scan (exact for a ship on a straight leg, a chord
  across a waypoint turn); for the first scan, and in per-sector mode where the next marker
  has not arrived yet, the last known marker's position moved by its velocity (dead
  reckoning, exact at constant velocity).
- Timestamps: ``meta.start_time`` (UTC) + the stream's simulated seconds. Each detection has
  its plot's time; the step's time is the end of scan (or the sector's frame time).

Steps
-----
``per_scan=True`` (default): one step per end-of-scan marker of the sensor, holding every
plot of that revolution; the radar revisits each target once per scan, which is the natural
tracker cycle, and a step with no plots is still yielded (empty set) so deleters see time
pass. ``per_scan=False``: one step per plot frame (one per sector), for lower latency.

Late joiners on a live stream: plots are ignored until the sensor's first ``meta`` message
(sent at every scan start), so the first step is a whole scan.
"""

from __future__ import annotations

import datetime as dt
import math
import os
import time
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from stonesoup.base import Property
from stonesoup.buffered_generator import BufferedGenerator
from stonesoup.models.measurement.nonlinear import (
    CartesianToBearingRange,
    CartesianToBearingRangeRate2D,
)
from stonesoup.reader.base import DetectionReader
from stonesoup.types.angle import Bearing
from stonesoup.types.array import CovarianceMatrix, StateVector
from stonesoup.types.detection import Detection

from shipradar.sim.stream import protocol
from shipradar.sim.stream.schema import EOS, META, PLOTS, TRUTH_PLOTS, TRUTH_TARGETS

__all__ = [
    "ShipradarDetectionReader",
    "azimuth_to_bearing",
    "bearing_to_azimuth",
    "iter_messages",
    "measurement_model",
]

#: The plot columns a detection is made of (checked against the stream's schema).
_PLOT_COLUMNS = PLOTS.keys_of("plot_id", "time_s", "range_m", "azimuth_rad", "snr_db",
                              "sigma_range_m", "sigma_azimuth_rad")
#: The plot columns a stream may lack (added after schema version 1 began; NaN when absent).
_OPTIONAL_COLUMNS = tuple(k for k in PLOTS.columns("n") if not PLOTS[k].required)
# the other keys read below, checked against the schema when this module is imported
META.keys_of("sensor", "scan", "start_time", "target_ids")
EOS.keys_of("sensor", "scan", "time_s", "position", "velocity_enu_mps", "heading_deg")
TRUTH_PLOTS.keys_of("sensor", "scan", "kind", "plot_id", "origin", "target")
TRUTH_TARGETS.keys_of("sensor", "scan", "kind", "time_s")


def azimuth_to_bearing(azimuth_rad):
    """Stone Soup bearing [rad], anticlockwise from east in [-π, π), of a true-north azimuth.

    Parameters
    ----------
    azimuth_rad : float or array_like
        Azimuth clockwise from true north [rad].
    """
    b = 0.5 * math.pi - np.asarray(azimuth_rad, dtype=float)
    return np.mod(b + math.pi, 2.0 * math.pi) - math.pi


def bearing_to_azimuth(bearing_rad):
    """True-north clockwise azimuth [rad] in [0, 2π) of a Stone Soup bearing (inverse)."""
    return np.mod(0.5 * math.pi - np.asarray(bearing_rad, dtype=float), 2.0 * math.pi)


def measurement_model(east_m: float, north_m: float, sigma_azimuth_rad: float,
                      sigma_range_m: float, *, ndim_state: int = 4,
                      mapping: tuple[int, int] = (0, 2)) -> CartesianToBearingRange:
    """The bearing-range model of one plot seen from a sensor at (east, north) [m]."""
    return CartesianToBearingRange(
        ndim_state=ndim_state,
        mapping=mapping,
        noise_covar=CovarianceMatrix(np.diag([sigma_azimuth_rad**2, sigma_range_m**2])),
        translation_offset=StateVector([east_m, north_m]),
    )


def range_rate_detection(detection: Detection, sensor_velocity=(0.0, 0.0)) -> Detection | None:
    """The plot as a bearing, range and range-rate measurement, or None without a range rate
    (an MTI-only radar, or a recording made before plots carried it).

    The range rate is the Doppler bank's filter centre folded by the PRF (docs/protocol.md,
    ``range_rate_mps``): ambiguous beyond ±f_r λ/4, so a tracker either unfolds it (adds the
    multiple of f_r λ/2 nearest its prediction) or uses it only for slow targets.  Its noise
    is ``sigma_range_rate_mps`` (the filter width / √12).

    Parameters
    ----------
    detection : Detection
        A detection of :class:`ShipradarDetectionReader` (bearing-range).
    sensor_velocity : (2,) sequence
        The sensor's east/north velocity [m/s] (the ``eos`` topic's ``velocity_enu_mps``):
        the range rate is relative to the ship.
    """
    rr = detection.metadata.get("range_rate_mps")
    sig = detection.metadata.get("sigma_range_rate_mps")
    if rr is None or not math.isfinite(rr) or sig is None or not math.isfinite(sig):
        return None
    base = detection.measurement_model
    cov = np.zeros((3, 3))
    cov[:2, :2] = np.asarray(base.noise_covar, dtype=float)
    cov[2, 2] = sig**2
    model = CartesianToBearingRangeRate2D(
        ndim_state=base.ndim_state, mapping=base.mapping,
        velocity_mapping=tuple(m + 1 for m in base.mapping), noise_covar=CovarianceMatrix(cov),
        translation_offset=base.translation_offset,
        velocity=StateVector([float(v) for v in sensor_velocity[:2]]))
    sv = detection.state_vector
    return Detection(StateVector([sv[0], sv[1], float(rr)]), timestamp=detection.timestamp,
                     measurement_model=model, metadata=detection.metadata)


def _is_endpoint(source: Any) -> bool:
    return isinstance(source, str) and "://" in source


def iter_messages(source, topics: Iterable[bytes], *, idle_timeout_s: float | None = 10.0,
                  context=None, curve=None) -> Iterator[tuple[bytes, float, dict]]:
    """Decoded ``(topic, t_sim, payload)`` of a source, keeping only ``topics``.

    Parameters
    ----------
    source : str, path-like or iterable
        ``tcp://``/``ipc://``/``inproc://`` endpoint to subscribe to; a recording file; or an
        iterable of messages, each ``[topic, body]`` frames or ``(t_sim, frames)``.
    topics : iterable of bytes
        Topics to keep (and subscribe to).
    idle_timeout_s : float or None
        Live source: stop after this long without a message [s]; None waits for ever.
    context : zmq.Context or None
        For ``inproc://`` endpoints; default the process-wide context.
    curve : shipradar.sim.stream.security.CurveClient or None
        Keys for a CURVE publisher (docs/protocol.md, Security).
    """
    wanted = tuple(topics)
    if _is_endpoint(source):
        yield from _iter_endpoint(source, wanted, idle_timeout_s, context, curve)
        return
    if isinstance(source, (str, os.PathLike)):
        from shipradar.sim.stream.recording import read_recording

        with read_recording(Path(source)) as reader:
            for _t, frames in reader:
                if bytes(frames[0]) in wanted:
                    yield protocol.decode(frames)
        return
    for item in source:
        frames = item[1] if isinstance(item, tuple) and len(item) == 2 and \
            isinstance(item[0], (int, float)) else item
        if bytes(frames[0]) in wanted:
            yield protocol.decode(frames)


def _iter_endpoint(endpoint, topics, idle_timeout_s, context, curve=None):
    import zmq

    ctx = zmq.Context.instance() if context is None else context
    sock = ctx.socket(zmq.SUB)
    sock.setsockopt(zmq.LINGER, 0)
    if curve is not None:
        curve.apply(sock)
    # The run may send faster than the tracker takes plots; a large queue plus the
    # publisher's "pace" mode means nothing is lost (docs/protocol.md, backpressure).
    sock.setsockopt(zmq.RCVHWM, 0)
    try:
        sock.connect(endpoint)
        for topic in topics:
            sock.setsockopt(zmq.SUBSCRIBE, topic)
        last = time.monotonic()
        while True:
            if not sock.poll(200):  # short slices keep Ctrl-C responsive
                if idle_timeout_s is not None and time.monotonic() - last >= idle_timeout_s:
                    return
                continue
            frames = sock.recv_multipart()
            last = time.monotonic()
            yield protocol.decode(frames)
    finally:
        sock.close()


class _SensorState:
    """What the reader knows about one sensor between steps."""

    def __init__(self, meta: dict):
        self.meta = meta
        self.start = dt.datetime.fromisoformat(meta["start_time"])
        self.pending: list[dict] = []  # plot frames not yet yielded
        self.eos: dict | None = None  # last end-of-scan marker

    def when(self, t_s: float) -> dt.datetime:
        return self.start + dt.timedelta(seconds=float(t_s))


def _position(eos: dict) -> tuple[float, float, float, float, float]:
    p = eos["position"]
    v = eos.get("velocity_enu_mps") or (0.0, 0.0, 0.0)
    return float(eos["time_s"]), p["east_m"], p["north_m"], float(v[0]), float(v[1])


def sensor_positions(t_s: np.ndarray, before: dict | None, after: dict | None):
    """East, north [m] of the sensor at times ``t_s`` from the bracketing eos markers.

    Linear interpolation between ``before`` and ``after``; with only one of them, its
    position moved by its velocity. Returns two arrays.
    """
    t_s = np.asarray(t_s, dtype=float)
    if before is not None and after is not None:
        t0, e0, n0, _, _ = _position(before)
        t1, e1, n1, _, _ = _position(after)
        if t1 > t0:
            w = (t_s - t0) / (t1 - t0)
            return e0 + w * (e1 - e0), n0 + w * (n1 - n0)
    ref = after if after is not None else before
    if ref is None:
        raise ValueError("no end-of-scan marker to place the sensor")
    t, e, n, ve, vn = _position(ref)
    return e + ve * (t_s - t), n + vn * (t_s - t)


class ShipradarDetectionReader(DetectionReader):
    """Detections of one shipradar sensor, per end of scan, with per-plot measurement models.

    See the module docstring for the frame, bearing, range and timing conventions.

    After each step, :attr:`scan` holds the scan number, :attr:`sensor_position` the
    sensor's east/north [m] at the step's time, and, when ``truth`` is True,
    :attr:`truth_targets` the truth topic's ``"targets"`` message of that scan (positions at
    the end of scan, with ``ids`` from ``meta.target_ids`` and ``timestamp``) and
    :attr:`plot_truth` a dict ``plot_id -> (origin code, target index)``. A tracker under
    test leaves ``truth`` False; evaluation code (OSPA) turns it on.
    """

    source: Any = Property(doc="Endpoint to subscribe to (``tcp://host:port``), a recording "
                               "file, or an iterable of encoded messages (tests).")
    sensor: str = Property(default=None,
                           doc="Sensor (radar) id to read; None: the first sensor in a meta.")
    per_scan: bool = Property(default=True,
                              doc="One step per end of scan (default) or per plot frame.")
    truth: bool = Property(default=False, doc="Also read the truth topic (for evaluation).")
    idle_timeout_s: float = Property(default=10.0,
                                     doc="Live source: stop after this long idle [s].")
    ndim_state: int = Property(default=4, doc="Dimension of the tracker's state.")
    mapping: tuple = Property(default=(0, 2), doc="Indices of x (east) and y (north).")
    context: Any = Property(default=None, doc="zmq.Context for inproc:// endpoints.")
    curve: Any = Property(default=None, doc="Keys for a CURVE publisher "
                          "(:class:`shipradar.sim.stream.security.CurveClient`, e.g. "
                          "``CurveClient.from_files(secret_key_file, server_key_file)``).")

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.meta: dict | None = None
        self.scan: int | None = None
        self.sensor_position: tuple[float, float] | None = None
        self.truth_targets: dict | None = None
        self.plot_truth: dict[int, tuple[int, int]] = {}

    # ---------------------------------------------------------------- conversion
    def _detections(self, st: _SensorState, frames: list[dict], before, after) -> set[Detection]:
        if not frames:
            return set()
        cols = {c: np.concatenate([np.asarray(f[c]) for f in frames]) for c in _PLOT_COLUMNS}
        n_plots = cols["plot_id"].size
        # range rate (Doppler bank, folded; NaN for MTI-only radars, absent from old streams)
        for c in _OPTIONAL_COLUMNS:
            cols[c] = np.concatenate([np.asarray(f.get(c, np.full(np.size(f["plot_id"]),
                                                                   np.nan))) for f in frames]
                                     ) if n_plots else np.zeros(0)
        east, north = sensor_positions(cols["time_s"], before, after)
        bearing = azimuth_to_bearing(cols["azimuth_rad"])
        heading = None if after is None and before is None else (after or before).get(
            "heading_deg")
        out = set()
        for i in range(cols["plot_id"].size):
            model = measurement_model(float(east[i]), float(north[i]),
                                      float(cols["sigma_azimuth_rad"][i]),
                                      float(cols["sigma_range_m"][i]),
                                      ndim_state=self.ndim_state, mapping=tuple(self.mapping))
            out.add(Detection(
                StateVector([Bearing(float(bearing[i])), float(cols["range_m"][i])]),
                timestamp=st.when(cols["time_s"][i]),
                measurement_model=model,
                metadata={
                    "sensor": self.sensor,
                    "plot_id": int(cols["plot_id"][i]),
                    "snr_db": float(cols["snr_db"][i]),
                    "scan": int(frames[0]["scan"]),
                    "heading_deg": heading,
                    "range_rate_mps": float(cols["range_rate_mps"][i]),
                    "sigma_range_rate_mps": float(cols["sigma_range_rate_mps"][i]),
                },
            ))
        return out

    # ---------------------------------------------------------------- generator
    @BufferedGenerator.generator_method
    def detections_gen(self):
        topics = [protocol.TOPIC_META, protocol.TOPIC_PLOTS, protocol.TOPIC_EOS]
        if self.truth:
            topics.append(protocol.TOPIC_TRUTH)
        st: _SensorState | None = None
        # A finished step waiting for its truth message (the engine sends a sector's truth
        # "plots" right after its plots, and the scan's truth "targets" right after eos).
        ready: dict | None = None
        plot_truth: dict[int, tuple[int, int]] = {}
        for topic, t_sim, p in iter_messages(self.source, topics,
                                             idle_timeout_s=self.idle_timeout_s,
                                             context=self.context, curve=self.curve):
            if self.sensor is None and topic == protocol.TOPIC_META:
                self.sensor = p["sensor"]
            if p.get("sensor") != self.sensor:
                continue
            if ready is not None:
                if (topic == protocol.TOPIC_TRUTH and p.get("kind") == ready["wait"]
                        and p.get("scan") == ready["scan"]):
                    if ready["wait"] == "targets":
                        assert st is not None  # a step is made only once the meta is known
                        self._set_truth(st, p)
                    else:
                        ready["plot_truth"].update(_plot_truth(p))
                    yield self._emit(ready)
                    ready = None
                    continue
                yield self._emit(ready)
                ready = None
            if topic == protocol.TOPIC_META:
                if st is None:
                    st = _SensorState(p)
                    self.meta = p
                continue
            if st is None:
                continue  # joined mid-scan: wait for the next scan's meta
            if topic == protocol.TOPIC_TRUTH:
                if p.get("kind") == "plots":
                    plot_truth.update(_plot_truth(p))
                continue
            step = None
            if topic == protocol.TOPIC_PLOTS:
                st.pending.append(p)
                if not self.per_scan and st.eos is not None:
                    dets = self._detections(st, st.pending, st.eos, None)
                    e, n = sensor_positions(np.array([t_sim]), st.eos, None)
                    step = {"when": st.when(t_sim), "dets": dets, "scan": p["scan"],
                            "pos": (float(e[0]), float(n[0])), "plot_truth": plot_truth,
                            "wait": "plots"}
            elif topic == protocol.TOPIC_EOS:
                if self.per_scan or st.pending:
                    dets = self._detections(st, st.pending, st.eos, p)
                    step = {"when": st.when(t_sim), "dets": dets, "scan": p["scan"],
                            "pos": (p["position"]["east_m"], p["position"]["north_m"]),
                            "plot_truth": plot_truth, "wait": "targets"}
                st.eos = p
            if step is not None:
                st.pending = []
                plot_truth = {}
                if self.truth:
                    ready = step
                else:
                    yield self._emit(step)
        if ready is not None:
            yield self._emit(ready)

    def _set_truth(self, st: _SensorState, p: dict) -> None:
        truth = dict(p)
        truth["ids"] = list(st.meta.get("target_ids", []))
        truth["timestamp"] = st.when(p["time_s"])
        self.truth_targets = truth

    def _emit(self, step: dict):
        self.scan = step["scan"]
        self.sensor_position = (float(step["pos"][0]), float(step["pos"][1]))
        self.plot_truth = step["plot_truth"]
        return step["when"], step["dets"]


def _plot_truth(p: dict) -> dict[int, tuple[int, int]]:
    """plot_id -> (origin code, target index) of a truth "plots" message."""
    return dict(zip(np.asarray(p["plot_id"]).tolist(),
                    zip(np.asarray(p["origin"]).tolist(), np.asarray(p["target"]).tolist(),
                        strict=True), strict=True))
