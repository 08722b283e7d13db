"""A run directory read back: the simulator's stream, the tracker's ``tracks``, the timings.

A run directory (written by :mod:`shipradar.sim.studies.evaluate.runner`) holds:

- ``stream.rec``: the simulator's stream, every topic (docs/protocol.md section 6 format);
- ``tracks.rec``: every message the tracker published on ``{tracks}`` (topics ``tracks`` and
  ``registration``), as received, even the malformed ones; a record's time is the message's
  ``t`` (NaN when it could not be read);
- ``timing.npz``: ``stream_sent_s`` (wall time at which each ``stream.rec`` record was sent,
  same order) and ``tracks_recv_s`` (wall time at which each ``tracks.rec`` record was
  received), both [s] from the same origin (the start of the run);
- ``run.json``: seed, status (``ok``, ``failed``), exit code and stderr tail of the tracker,
  endpoints, wall times.

Nothing here trusts the tracker: each ``tracks`` message is checked by
:func:`check_tracks`, each ``registration`` message by
:func:`~shipradar.sim.studies.evaluate.registration.check_registration`, and a malformed one
is counted under its reason, never scored.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from shipradar.sim.stream.protocol import ProtocolError, decode
from shipradar.sim.stream.recording import read_recording
from shipradar.sim.stream.schema import (
    EOS,
    META,
    PLOTS,
    TOPIC_REGISTRATION,
    TOPIC_TRACKS,
    TRACKS,
    TRUTH_TARGETS,
)
from shipradar.sim.studies.evaluate.registration import (
    TRUTH_KEYS,
    TRUTH_SENSORS_KIND,
    MalformedRegistration,
    RegistrationMessage,
    check_registration,
)

__all__ = ["MalformedTracks", "RunData", "TracksMessage", "add_registration", "check_tracks",
           "load_run",
           "TRACKS_REQUIRED", "TRACKS_COLUMNS"]

#: Keys a ``tracks`` message must carry to be scored (the 1σ columns are not scored, so
#: they may be absent); checked against the schema's ``tracks`` keys (docs/protocol.md 4.6).
TRACKS_REQUIRED: tuple[str, ...] = TRACKS.keys_of("sensor", "scan", "time_s", "track_id",
                                                  "east_m", "north_m", "v_east_mps",
                                                  "v_north_mps")
#: The per-track numeric columns that are scored.
TRACKS_COLUMNS: tuple[str, ...] = TRACKS.keys_of("east_m", "north_m", "v_east_mps",
                                                 "v_north_mps")
#: The optional altitude column: when a message carries it, the track-to-truth association
#: measures in three dimensions (:mod:`shipradar.sim.studies.evaluate.metrics`).
TRACKS_ALTITUDE: str = TRACKS.keys_of("up_m")[0]


class MalformedTracks(ValueError):
    """A ``tracks`` message that cannot be trusted; ``reason`` is a short class name
    (``undecodable``, ``missing key``, ``bad track_id``, ``bad column``, ``length mismatch``,
    ``non-finite``, ``duplicate track_id``, ``bad time``), ``str()`` the detail."""

    def __init__(self, reason: str, detail: str):
        super().__init__(f"{reason}: {detail}")
        self.reason = reason


@dataclass(frozen=True)
class TracksMessage:
    """One valid ``tracks`` message: the tracks at ``time_s`` [s] as the tracker gave them."""

    time_s: float
    sensor: str
    scan: int
    track_id: tuple[str, ...]
    east_m: np.ndarray
    north_m: np.ndarray
    v_east_mps: np.ndarray
    v_north_mps: np.ndarray
    recv_s: float = math.nan  #: wall time received [s], NaN in process
    up_m: np.ndarray | None = None  #: estimated heights [m], None when not given


def check_tracks(frames, recv_s: float = math.nan) -> TracksMessage:
    """Decode and check one ``tracks`` message (docs/protocol.md section 4.6).

    Parameters
    ----------
    frames : sequence of bytes
        ``[topic, body]`` as received.
    recv_s : float, optional
        Wall time of reception [s].

    Raises
    ------
    MalformedTracks
        Naming what is wrong.
    """
    try:
        topic, t, p = decode(frames)
    except ProtocolError as exc:
        raise MalformedTracks("undecodable", str(exc)) from None
    if topic != TOPIC_TRACKS:
        raise MalformedTracks("wrong topic", repr(topic))
    return tracks_from_payload(p, recv_s)


def tracks_from_payload(p: dict, recv_s: float = math.nan) -> TracksMessage:
    """:func:`check_tracks` on a payload already decoded (the in-process tracker's)."""
    if not isinstance(p, dict):
        raise MalformedTracks("bad type", f"payload is {type(p).__name__}, not a map")
    missing = [k for k in TRACKS_REQUIRED if k not in p]
    if missing:
        raise MalformedTracks("missing key", ", ".join(missing))
    ids = p["track_id"]
    if not isinstance(ids, (list, tuple)) or not all(isinstance(i, str) for i in ids):
        raise MalformedTracks("bad track_id", "track_id must be a list of strings")
    if len(set(ids)) != len(ids):
        raise MalformedTracks("duplicate track_id", f"{len(ids) - len(set(ids))} repeated")
    cols = {k: _column(p, k, len(ids)) for k in TRACKS_COLUMNS}
    up = None
    if p.get(TRACKS_ALTITUDE) is not None:
        up = _column(p, TRACKS_ALTITUDE, len(ids))
    t = p["time_s"]
    if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
        raise MalformedTracks("bad time", f"time_s = {t!r}")
    scan = p["scan"]
    if isinstance(scan, bool) or not isinstance(scan, (int, np.integer)):
        raise MalformedTracks("bad type", f"scan = {scan!r}")
    return TracksMessage(float(t), str(p["sensor"]), int(scan), tuple(ids), cols["east_m"],
                         cols["north_m"], cols["v_east_mps"], cols["v_north_mps"], recv_s,
                         up)


def _column(p: dict, k: str, n: int) -> np.ndarray:
    """Column ``k`` of a ``tracks`` payload as n finite float64 values."""
    try:
        a = np.asarray(p[k], dtype=np.float64)
    except (TypeError, ValueError):
        raise MalformedTracks("bad column", f"{k} is not numeric") from None
    if a.ndim != 1:
        raise MalformedTracks("bad column", f"{k} has {a.ndim} dimensions")
    if a.size != n:
        raise MalformedTracks("length mismatch", f"{k} has {a.size} values for "
                                                 f"{n} track_id")
    if not np.all(np.isfinite(a)):
        raise MalformedTracks("non-finite", f"{k} holds NaN or inf")
    return a


@dataclass
class RunData:
    """What the scoring of one run reads (all times simulated [s], positions local ENU [m]).

    ``scan_t``: the reference sensor's end-of-scan times (K,), the times at which the run is
    scored; ``truth_pos``/``truth_vel`` (K, k, 3) and ``truth_active`` (K, k) the targets'
    states then; ``radars``: per sensor ``instrumented_range_m``, ``scan_period_s``, and its
    antenna positions ``eos_t`` (M,) / ``eos_pos`` (M, 3); ``coverage``: per sensor the times
    (M,) of its ``truth[targets]`` copies and their ``in_coverage`` (M, k) (schema 2; empty
    for a version-1 stream, which has no such key); ``looks``: per sensor the times (M,) of
    those copies and their ``look_time_s`` and ``pd`` (M, k) (schema 2); ``inputs``: per
    sensor the (simulated t, wall sent) of its ``plots`` and ``eos`` messages, for the
    latency.
    """

    info: dict[str, Any]
    target_ids: list[str]
    ref_sensor: str
    scan_t: np.ndarray
    truth_pos: np.ndarray
    truth_vel: np.ndarray
    truth_active: np.ndarray
    radars: dict[str, dict[str, Any]]
    inputs: dict[str, tuple[np.ndarray, np.ndarray]]
    tracks: list[TracksMessage] = field(default_factory=list)
    coverage: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    looks: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=dict)
    malformed: Counter = field(default_factory=Counter)
    malformed_examples: dict[str, str] = field(default_factory=dict)
    #: the tracker's valid ``registration`` messages; per radar its ``truth[sensors]``
    #: columns (:data:`~shipradar.sim.studies.evaluate.registration.TRUTH_KEYS`, arrays over
    #: its ends of scan; empty for a scene without errors)
    registration: list[RegistrationMessage] = field(default_factory=list)
    sensor_truth: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)

    @property
    def duration_s(self) -> float:
        return float(self.info.get("duration_s") or (self.scan_t[-1] if self.scan_t.size
                                                       else 0.0))


class Collect:
    """Accumulates the simulator's messages into :class:`RunData` (from a recording or in
    process: the same code)."""

    def __init__(self) -> None:
        self.radars: dict[str, dict[str, Any]] = {}
        self.target_ids: list[str] = []
        self.ref: str | None = None
        self.scan_t: list[float] = []
        self.pos: list[np.ndarray] = []
        self.vel: list[np.ndarray] = []
        self.active: list[np.ndarray] = []
        self.eos: dict[str, list[tuple[float, tuple[float, float, float]]]] = {}
        self.coverage: dict[str, list[tuple[float, np.ndarray]]] = {}
        self.looks: dict[str, list[tuple[float, np.ndarray, np.ndarray]]] = {}
        self.inputs: dict[str, list[tuple[float, float]]] = {}
        self.sensor_truth: dict[str, list[tuple[float, ...]]] = {}

    def add(self, topic: bytes, t: float, p: Mapping[str, Any], sent_s: float = math.nan
            ) -> None:
        if topic == PLOTS.topic or topic == EOS.topic:
            self.inputs.setdefault(p["sensor"], []).append((t, sent_s))
        if topic == META.topic:
            s = p["sensor"]
            if s not in self.radars:
                self.radars[s] = {
                    "instrumented_range_m": float(p["radar"]["instrumented_range_m"]),
                    "scan_period_s": float(p["scan_period_s"]),
                }
                self.target_ids = list(p.get("target_ids", []))
                if self.ref is None:
                    self.ref = s
            elif len(p.get("target_ids", ())) > len(self.target_ids):
                # a live source's targets: the list grows, earlier ids keep their index
                self.target_ids = list(p["target_ids"])
        elif topic == EOS.topic:
            q = p["position"]
            self.eos.setdefault(p["sensor"], []).append(
                (float(p["time_s"]), (float(q["east_m"]), float(q["north_m"]),
                                      float(q["up_m"]))))
        elif topic == TRUTH_TARGETS.topic and p.get("kind") == TRUTH_SENSORS_KIND:
            self.sensor_truth.setdefault(p["sensor"], []).append(
                tuple(float(p[k]) for k in TRUTH_KEYS))
        elif topic == TRUTH_TARGETS.topic and p.get("kind") == TRUTH_TARGETS.kind:
            if "in_coverage" in p:
                self.coverage.setdefault(p["sensor"], []).append(
                    (float(p["time_s"]), np.asarray(p["in_coverage"], bool)))
            if "look_time_s" in p and "pd" in p:
                self.looks.setdefault(p["sensor"], []).append(
                    (float(p["time_s"]), np.asarray(p["look_time_s"], float),
                     np.asarray(p["pd"], float)))
            if p["sensor"] == self.ref:
                self.scan_t.append(float(p["time_s"]))
                self.pos.append(np.stack([p["east_m"], p["north_m"], p["up_m"]], axis=-1))
                self.vel.append(np.stack([p["v_east_mps"], p["v_north_mps"], p["v_up_mps"]],
                                         axis=-1))
                self.active.append(np.asarray(p["active"], bool))

    def result(self, info: dict[str, Any]) -> RunData:
        # a list that grew (a live source): earlier rows padded, a target not yet there is
        # inactive (NaN state, not in coverage)
        k = max([len(self.target_ids), *(len(a) for a in self.active)])

        def pad(rows: list[np.ndarray], fill: Any) -> list[np.ndarray]:
            out = []
            for a in rows:
                if len(a) < k:
                    a = np.concatenate([a, np.full((k - len(a), *a.shape[1:]), fill,
                                                   dtype=a.dtype)])
                out.append(a)
            return out

        self.pos, self.vel = pad(self.pos, np.nan), pad(self.vel, np.nan)
        self.active = pad(self.active, False)
        self.coverage = {s: list(zip([a for a, _ in v], pad([c for _, c in v], False),
                                     strict=True))
                         for s, v in self.coverage.items()}
        looks = {}
        for s, v in self.looks.items():
            lt = pad([a for _, a, _ in v], np.nan)
            pd = pad([b for _, _, b in v], np.nan)
            looks[s] = (np.array([a for a, _, _ in v]), np.array(lt, float).reshape(-1, k),
                        np.array(pd, float).reshape(-1, k))
        radars = {}
        for s, r in self.radars.items():
            eos = self.eos.get(s, [])
            radars[s] = dict(r, eos_t=np.array([e[0] for e in eos]),
                             eos_pos=np.array([e[1] for e in eos]).reshape(-1, 3))
        inputs = {s: (np.array([a for a, _ in v]), np.array([b for _, b in v]))
                  for s, v in self.inputs.items()}
        coverage = {s: (np.array([a for a, _ in v]), np.array([c for _, c in v], bool)
                        .reshape(-1, k)) for s, v in self.coverage.items()}
        sensor_truth = {s: dict(zip(TRUTH_KEYS, np.array(v, float).reshape(-1, len(TRUTH_KEYS)).T,
                                    strict=True))
                        for s, v in self.sensor_truth.items()}
        return RunData(
            info=info, target_ids=self.target_ids, ref_sensor=self.ref or "",
            scan_t=np.array(self.scan_t),
            truth_pos=np.array(self.pos).reshape(-1, k, 3),
            truth_vel=np.array(self.vel).reshape(-1, k, 3),
            truth_active=np.array(self.active, bool).reshape(-1, k),
            radars=radars, inputs=inputs, coverage=coverage, looks=looks,
            sensor_truth=sensor_truth)


def add_tracks(data: RunData, frames_or_payload, recv_s: float, *, decoded: bool) -> None:
    """Append one tracker message (its frames, or its payload when ``decoded``) received at
    ``recv_s`` [s] to ``data``: a ``tracks`` message, or (frames only) a ``registration``
    one."""
    if not decoded and len(frames_or_payload) >= 1 \
            and bytes(frames_or_payload[0]) == TOPIC_REGISTRATION:
        add_registration(data, frames_or_payload, recv_s)
        return
    try:
        msg = (tracks_from_payload(frames_or_payload, recv_s) if decoded
               else check_tracks(frames_or_payload, recv_s))
    except MalformedTracks as exc:
        data.malformed[exc.reason] += 1
        data.malformed_examples.setdefault(exc.reason, str(exc))
        return
    data.tracks.append(msg)


def add_registration(data: RunData, frames, recv_s: float) -> None:
    """Append one ``registration`` message (its frames) received at ``recv_s`` [s] to
    ``data``; a malformed one, or one about a radar the stream does not have, is counted
    under its reason."""
    try:
        msg = check_registration(frames, recv_s)
        if data.radars and msg.sensor not in data.radars:
            raise MalformedRegistration("registration: unknown sensor",
                                        f"{msg.sensor!r} is not a radar of the stream "
                                        f"({', '.join(data.radars)})")
    except MalformedRegistration as exc:
        data.malformed[exc.reason] += 1
        data.malformed_examples.setdefault(exc.reason, str(exc))
        return
    data.registration.append(msg)


def load_run(run_dir: str | Path) -> RunData:
    """Read a run directory back (see the module docstring).

    Raises
    ------
    FileNotFoundError
        If ``run.json`` or ``stream.rec`` is missing.
    """
    run_dir = Path(run_dir)
    info = json.loads((run_dir / "run.json").read_text())
    timing = run_dir / "timing.npz"
    sent = recv = None
    if timing.exists():
        with np.load(timing) as z:
            sent, recv = z["stream_sent_s"], z["tracks_recv_s"]
    col = Collect()
    with read_recording(run_dir / "stream.rec") as reader:
        for i, (_t, frames) in enumerate(reader):
            topic, t, p = decode(frames)
            col.add(topic, t, p, math.nan if sent is None or i >= sent.size
                    else float(sent[i]))
    data = col.result(info)
    path = run_dir / "tracks.rec"
    if path.exists():
        with read_recording(path) as reader:
            for i, (_t, frames) in enumerate(reader):
                add_tracks(data, frames, math.nan if recv is None or i >= recv.size
                            else float(recv[i]), decoded=False)
    return data
