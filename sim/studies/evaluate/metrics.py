"""Scores of one run: which truth counts, time alignment, GOSPA and SIAP, per-target figures.

What is computed and by whom:

- **GOSPA** (generalised optimal sub-pattern assignment, Rahmathullah, García-Fernández &
  Svensson, *Generalized optimal sub-pattern assignment metric*, FUSION 2017) with its
  decomposition into localisation, missed and false parts: Stone Soup's
  :class:`stonesoup.metricgenerator.ospametric.GOSPAMetric` (``alpha = 2``, its only value),
  :meth:`~stonesoup.metricgenerator.ospametric.GOSPAMetric.compute_gospa_metric` at every
  scored scan. The parts are in the metric's own unit, metres to the power ``p``: with
  ``p = 1`` (default) the localisation part is the sum of the assigned tracks' position
  errors [m], and the missed and false parts are ``c / 2`` per missed target and per false
  track.
- **SIAP** (Votruba et al., *Single Integrated Air Picture (SIAP) Metrics Implementation*,
  2001): Stone Soup's :class:`stonesoup.metricgenerator.tracktotruthmetrics.SIAPMetrics`
  through a :class:`~stonesoup.metricgenerator.manager.MultiManager` whose associator is
  :class:`~stonesoup.dataassociator.tracktotrack.TrackToTruth` (a track and a truth are
  associated from the first of two scans in a row within ``siap_threshold_m``, until the
  first scan beyond it, :data:`SIAP_CONFIRM_SCANS`): completeness, ambiguity, spuriousness,
  position and velocity accuracy, rate of track-number change, longest track segment.
- **By hand**, because no library has them: per target the time and range of its first
  track, track breaks and identity swaps; false tracks per hour; the tracker's latency.
  They read the GOSPA assignment of each scan (a target is *held* at a scan by the track
  GOSPA assigns it, within ``c``).

Configured once, in :class:`MetricConfig`. Positions are horizontal (east, north): a
``tracks`` message has no altitude (docs/protocol.md section 4.6).

Which truth counts (:func:`counted_targets`, the one place): at each scored scan, a target
that is active and *in coverage* of at least one radar, as the stream says it: each radar's
``in_coverage`` of its latest ``truth[targets]`` copy at or before the scan (the reference
radar's is at the scan itself; another radar's is at most one of its scans old). That is the
engine's own test before a look: ground range from the antenna within the instrumented range,
and within the radio horizon over the 4/3 earth (docs/protocol.md section 4.4). A stream of
schema version 1 has no ``in_coverage``; it is scored by :func:`detectable`, the same test
computed from the antennas' positions at the scan. A target outside coverage is neither
missed nor a reason to call a track false (a track on it is not false either: it is left out
of the scan's sets).

Time alignment: the run is scored at the reference sensor's ends of scan (the first radar of
the stream). At each, the tracker's latest valid ``tracks`` message at or before that time,
and not older than ``max_track_age_s``, is taken and its tracks extrapolated at constant
velocity to the scan time; none: the tracker holds no track at that scan.
"""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from shipradar.sensors.propagation import horizon_range
from shipradar.sim.studies.evaluate.data import RunData, TracksMessage

__all__ = ["DEFAULT_METRICS", "EPOCH", "MetricConfig", "RunScores", "counted_targets",
           "detectable",
           "gospa_metric", "score_run", "siap", "tracks_at"]

#: Timestamps handed to Stone Soup: simulated t [s] after this (any fixed epoch would do).
EPOCH = dt.datetime(2000, 1, 1)
# Two times closer than this are the same scan [s] (the stream's times are exact floats).
_SAME_T_S = 1e-6


@dataclass(frozen=True)
class MetricConfig:
    """Every setting of the metrics, declared once (``shipradar evaluate --rescore`` takes
    other values without re-running).

    Attributes
    ----------
    c_m : float
        GOSPA cut-off c [m]: farther than this a track and a target are not assigned, and a
        missed target or a false track costs c^p / 2.
    p : float
        GOSPA order p (1 <= p).
    siap_threshold_m : float or None
        Track-to-truth association distance of the SIAP metrics [m]; None: ``c_m``.
    max_track_age_s : float or None
        Longest time between a ``tracks`` message and the scan it is scored at [s]; None:
        1.5 scan periods of the reference sensor.
    """

    c_m: float = 2000.0
    p: float = 1.0
    siap_threshold_m: float | None = None
    max_track_age_s: float | None = None

    def __post_init__(self) -> None:
        if not self.c_m > 0:
            raise ValueError(f"c_m must be > 0, got {self.c_m}")
        if not self.p >= 1:
            raise ValueError(f"p must be >= 1, got {self.p}")

    @property
    def threshold_m(self) -> float:
        return self.c_m if self.siap_threshold_m is None else float(self.siap_threshold_m)

    def as_dict(self) -> dict[str, Any]:
        return dict(asdict(self), alpha=2)


#: Scans in a row within the SIAP threshold that start a track-to-truth association (from
#: the first of them). Not 1: Stone Soup's association is a time range that must not be
#: empty, so a one-scan association raises; a track within the threshold for a single scan
#: is therefore not associated (spurious at that scan).
SIAP_CONFIRM_SCANS = 2

#: The documented defaults.
DEFAULT_METRICS = MetricConfig()


def detectable(pos_m: np.ndarray, active: np.ndarray, antennas: list[tuple[np.ndarray, float]]
               ) -> np.ndarray:
    """Which targets count at one time, computed from geometry (the fallback of
    :func:`counted_targets` for a stream without ``in_coverage``): active and in coverage of
    at least one radar, by the engine's test before a look.

    Parameters
    ----------
    pos_m : ndarray, shape (k, 3)
        Target positions, local east/north/up [m].
    active : ndarray of bool, shape (k,)
        Targets that exist at that time.
    antennas : list of (ndarray (3,), float)
        Per radar its antenna position east/north/up [m] (up: height above the sea) and its
        instrumented range [m].

    Returns
    -------
    ndarray of bool, shape (k,)
        Active, and for some radar: ground range <= instrumented range and <= the 4/3-earth
        radio horizon of antenna and target heights (a target below the sea surface is taken
        at 0 m). The local plane's ground range and the mean earth radius
        (:func:`shipradar.sensors.propagation.horizon_range`) stand in for the engine's great
        circle on the frame's sphere: the two differ by metres at the horizon.
    """
    pos_m = np.asarray(pos_m, float).reshape(-1, 3)
    out = np.zeros(pos_m.shape[0], bool)
    for ant, r_inst in antennas:
        d = pos_m - np.asarray(ant, float)
        ground = np.hypot(d[:, 0], d[:, 1])
        horizon = horizon_range(max(float(ant[2]), 0.0), np.maximum(pos_m[:, 2], 0.0))
        out |= (ground <= r_inst) & (ground <= horizon)
    return out & np.asarray(active, bool)


def counted_targets(data: RunData, i: int) -> np.ndarray:
    """Which targets count at the scored scan ``i`` (time ``data.scan_t[i]``): active and in
    coverage of at least one radar, from the stream's ``in_coverage`` (each radar's latest
    ``truth[targets]`` copy at or before the scan; a radar that has sent none yet covers
    nothing), or, for a stream without it, :func:`detectable` at the antennas' positions.

    Returns
    -------
    ndarray of bool, shape (k,)
    """
    t = float(data.scan_t[i])
    active = np.asarray(data.truth_active[i], bool)
    if not data.radars or any(s not in data.coverage for s in data.radars):
        antennas = [(_antenna_at(r, t), r["instrumented_range_m"])
                    for r in data.radars.values()]
        return detectable(data.truth_pos[i], active, antennas)
    out = np.zeros(active.shape, bool)
    for s in data.radars:
        times, cover = data.coverage[s]
        j = int(np.searchsorted(times, t, side="right")) - 1
        if j >= 0:
            out |= cover[j]
    return out & active


def _antenna_at(radar: dict[str, Any], t: float) -> np.ndarray:
    """Antenna position at t [m], linear between the ends of scan (the nearest outside)."""
    et, ep = radar["eos_t"], radar["eos_pos"]
    if et.size == 0:
        return np.zeros(3)
    return np.array([np.interp(t, et, ep[:, i]) for i in range(3)])


def tracks_at(tracks: list[TracksMessage], t_s: float, max_age_s: float
              ) -> tuple[tuple[str, ...], np.ndarray]:
    """The tracker's tracks at ``t_s``: its latest message at or before it, not older than
    ``max_age_s`` [s], extrapolated at constant velocity.

    Returns
    -------
    ids : tuple of str
    state : ndarray, shape (n, 4)
        east [m], v_east [m/s], north [m], v_north [m/s] at ``t_s``.
    """
    best = None
    for msg in tracks:  # sorted by time_s; the last one not after t wins
        if msg.time_s <= t_s + _SAME_T_S:
            best = msg
        else:
            break
    if best is None or t_s - best.time_s > max_age_s:
        return (), np.zeros((0, 4))
    dt_s = t_s - best.time_s
    state = np.stack([best.east_m + best.v_east_mps * dt_s, best.v_east_mps,
                      best.north_m + best.v_north_mps * dt_s, best.v_north_mps], axis=-1)
    return best.track_id, state.reshape(-1, 4)


def gospa_metric(config: MetricConfig):
    """Stone Soup's GOSPA generator as configured (position only, ``alpha`` = 2)."""
    from stonesoup.measures import Euclidean
    from stonesoup.metricgenerator.ospametric import GOSPAMetric

    return GOSPAMetric(c=config.c_m, p=config.p, measure=Euclidean(mapping=(0, 2)))


def _states(rows: np.ndarray, when: dt.datetime):
    from stonesoup.types.array import StateVector
    from stonesoup.types.state import State

    return [State(StateVector(r), timestamp=when) for r in rows]


def siap(tracks: dict[str, list[tuple[float, np.ndarray]]],
         truths: dict[int, list[tuple[float, np.ndarray]]], config: MetricConfig
         ) -> dict[str, Any]:
    """SIAP metrics by Stone Soup's
    :class:`~stonesoup.metricgenerator.tracktotruthmetrics.SIAPMetrics` on tracks and truths
    sampled at the scored scans.

    Parameters
    ----------
    tracks, truths : dict
        id -> list of (t [s], state [east, v_east, north, v_north]).

    Returns
    -------
    dict
        ``completeness``, ``ambiguity``, ``spuriousness``, ``position_accuracy_m``,
        ``velocity_accuracy_mps``, ``track_number_change_rate`` [1/s],
        ``longest_segment`` (whole run) and ``at_times``: t -> per-scan ``completeness``,
        ``ambiguity``, ``spuriousness``; NaN everywhere when there is no truth and no track.
    """
    from stonesoup.dataassociator.tracktotrack import TrackToTruth
    from stonesoup.measures import Euclidean
    from stonesoup.metricgenerator.manager import MultiManager
    from stonesoup.metricgenerator.tracktotruthmetrics import SIAPMetrics
    from stonesoup.types.groundtruth import GroundTruthPath, GroundTruthState
    from stonesoup.types.state import State
    from stonesoup.types.track import Track

    nan = math.nan
    names = ("completeness", "ambiguity", "spuriousness", "position_accuracy_m",
             "velocity_accuracy_mps", "track_number_change_rate", "longest_segment")
    if not tracks and not truths:
        return {**dict.fromkeys(names, nan), "at_times": {}}

    def when(t):
        return EPOCH + dt.timedelta(seconds=t)

    # Stone Soup's TrackToTruth associates over a time range and SIAP then reads both objects
    # at every scan of it, so a track or truth absent at some scan inside its span (a track
    # dropped and resumed under its id, a target leaving coverage) is split there: a resumed
    # track counts as a new track number for SIAP's continuity measures.
    times = sorted({t for v in (*tracks.values(), *truths.values()) for t, _ in v})
    order = {t: i for i, t in enumerate(times)}
    ss_tracks = {Track([State(s, timestamp=when(t)) for t, s in seg], id=f"{k}#{n}")
                 for k, v in sorted(tracks.items())
                 for n, seg in enumerate(_segments(v, order))}
    ss_truths = {GroundTruthPath([GroundTruthState(s, timestamp=when(t)) for t, s in seg],
                                 id=f"{k}#{n}")
                 for k, v in sorted(truths.items())
                 for n, seg in enumerate(_segments(v, order))}
    gen = SIAPMetrics(position_measure=Euclidean(mapping=(0, 2)),
                      velocity_measure=Euclidean(mapping=(1, 3)), generator_name="siap",
                      tracks_key="tracks", truths_key="truths")
    assoc = TrackToTruth(association_threshold=config.threshold_m,
                         consec_pairs_confirm=SIAP_CONFIRM_SCANS, consec_misses_end=1,
                         measure=Euclidean(mapping=(0, 2)))
    manager = MultiManager([gen], associator=assoc)
    manager.add_data({"tracks": ss_tracks, "truths": ss_truths})
    m = manager.generate_metrics()["siap"]
    out = {
        "completeness": m["SIAP Completeness"].value,
        "ambiguity": m["SIAP Ambiguity"].value,
        "spuriousness": m["SIAP Spuriousness"].value,
        "position_accuracy_m": m["SIAP Position Accuracy"].value,
        "velocity_accuracy_mps": m["SIAP Velocity Accuracy"].value,
        "track_number_change_rate": m["SIAP Rate of Track Number Change"].value,
        "longest_segment": m["SIAP Longest Track Segment"].value,
    }
    out = {k: float(v) for k, v in out.items()}
    at: dict[float, dict[str, float]] = {}
    for key, name in (("completeness", "SIAP Completeness at times"),
                      ("ambiguity", "SIAP Ambiguity at times"),
                      ("spuriousness", "SIAP Spuriousness at times")):
        for single in m[name].value:
            t = round((single.timestamp - EPOCH).total_seconds(), 6)
            at.setdefault(t, {})[key] = float(single.value)
    out["at_times"] = at
    return out


def _segments(rows: list[tuple[float, np.ndarray]], order: dict[float, int]):
    """``rows`` (sorted by time) cut where a scored scan is missing between two of them."""
    seg: list[tuple[float, np.ndarray]] = []
    for row in rows:
        if seg and order[row[0]] != order[seg[-1][0]] + 1:
            yield seg
            seg = []
        seg.append(row)
    if seg:
        yield seg


@dataclass
class RunScores:
    """Scores of one run: ``per_scan``, ``per_target`` (lists of row dicts), ``run`` (one
    dict) and ``holding`` (per scan and counted target: the track that held it, or None),
    every row carrying the run's ``seed``."""

    per_scan: list[dict[str, Any]]
    per_target: list[dict[str, Any]]
    run: dict[str, Any]
    holding: list[dict[str, Any]]


def _max_age(data: RunData, config: MetricConfig) -> float:
    if config.max_track_age_s is not None:
        return float(config.max_track_age_s)
    period = data.radars.get(data.ref_sensor, {}).get("scan_period_s", 1.0)
    return 1.5 * period


def latencies(data: RunData) -> np.ndarray:
    """Per valid ``tracks`` message: wall time from the last ``plots`` or ``eos`` message of
    its sensor at or before its ``time_s`` (and sent before it was received) to its
    reception [s]. Messages without wall times (in process without timing) are left out."""
    out = []
    for msg in data.tracks:
        if not math.isfinite(msg.recv_s):
            continue
        t_in, sent = data.inputs.get(msg.sensor) or _merged_inputs(data)
        ok = (t_in <= msg.time_s + _SAME_T_S) & (sent <= msg.recv_s) & np.isfinite(sent)
        if ok.any():
            out.append(msg.recv_s - sent[np.flatnonzero(ok)[-1]])
    return np.array(out)


def _merged_inputs(data: RunData) -> tuple[np.ndarray, np.ndarray]:
    if not data.inputs:
        return np.zeros(0), np.zeros(0)
    t = np.concatenate([v[0] for v in data.inputs.values()])
    s = np.concatenate([v[1] for v in data.inputs.values()])
    order = np.argsort(s, kind="stable")
    return t[order], s[order]


def score_run(data: RunData, config: MetricConfig = DEFAULT_METRICS) -> RunScores:
    """Score one run (see the module docstring for every definition).

    Parameters
    ----------
    data : RunData
        From :func:`shipradar.sim.studies.evaluate.data.load_run` (or the in-process run).
    config : MetricConfig
        The metrics' settings.
    """
    seed = data.info.get("seed")
    gospa = gospa_metric(config)
    max_age = _max_age(data, config)
    tracks = sorted(data.tracks, key=lambda m: m.time_s)
    k_targets = len(data.target_ids)
    ref = data.radars.get(data.ref_sensor)
    per_scan: list[dict[str, Any]] = []
    held: list[list[str | None]] = []
    counted_all: list[np.ndarray] = []
    err_sum = np.zeros(k_targets)
    ss_tracks: dict[str, list[tuple[float, np.ndarray]]] = {}
    ss_truths: dict[int, list[tuple[float, np.ndarray]]] = {}
    ids_seen: set[str] = set()
    ids_assigned: set[str] = set()
    ref_range = np.full((data.scan_t.size, k_targets), np.nan)
    for i, t in enumerate(data.scan_t):
        pos = data.truth_pos[i]
        counted = counted_targets(data, i)
        counted_all.append(counted)
        if ref is not None:
            a = _antenna_at(ref, t)
            ref_range[i] = np.hypot(pos[:, 0] - a[0], pos[:, 1] - a[1])
        vel = data.truth_vel[i]
        truth_rows = np.stack([pos[:, 0], vel[:, 0], pos[:, 1], vel[:, 1]], axis=-1)
        idx = np.flatnonzero(counted)
        ids, track_rows = tracks_at(tracks, float(t), max_age)
        when = EPOCH + dt.timedelta(seconds=float(t))
        if idx.size or len(ids):
            value, assignment = gospa.compute_gospa_metric(_states(track_rows, when),
                                                           _states(truth_rows[idx], when))
            v = value.value
        else:  # two empty sets: GOSPA 0 (Stone Soup asks for at least one state)
            v, assignment = dict.fromkeys(("distance", "localisation", "missed", "false"),
                                          0.0), []
        row_held: list[str | None] = [None] * k_targets
        for j, a in zip(idx, assignment, strict=False):
            if a != -1:
                row_held[j] = ids[a]
                ids_assigned.add(ids[a])
                err_sum[j] += math.dist(track_rows[a][[0, 2]], truth_rows[j][[0, 2]])
        held.append(row_held)
        ids_seen.update(ids)
        for tid, s in zip(ids, track_rows, strict=True):
            ss_tracks.setdefault(tid, []).append((float(t), s))
        for j in idx:
            ss_truths.setdefault(int(j), []).append((float(t), truth_rows[j]))
        per_scan.append({
            "seed": seed, "scan": i, "t_s": float(t), "truths": int(idx.size),
            # + 0.0: Stone Soup's sums of negated costs give -0.0
            "tracks": len(ids), "gospa": float(v["distance"]) + 0.0,
            "localisation": float(v["localisation"]) + 0.0,
            "missed": float(v["missed"]) + 0.0, "false": float(v["false"]) + 0.0,
            "assigned": int(sum(h is not None for h in row_held)),
        })
    s = siap(ss_tracks, ss_truths, config)
    for row in per_scan:
        at = s["at_times"].get(round(row["t_s"], 6), {})
        row["completeness"] = at.get("completeness", math.nan)
        row["spuriousness"] = at.get("spuriousness", math.nan)

    per_target, swaps = _per_target(data, held, counted_all, err_sum, ref_range, seed)
    duration_h = data.duration_s / 3600.0
    false_ids = sorted(ids_seen - ids_assigned)
    lat = latencies(data)
    scored = per_scan

    def mean(key):
        return float(np.mean([r[key] for r in scored])) if scored else math.nan

    run = {
        "seed": seed, "status": data.info.get("status", "ok"),
        "scans": len(per_scan),
        "gospa": mean("gospa"), "localisation": mean("localisation"),
        "missed": mean("missed"), "false": mean("false"),
        **{f"siap_{k}": v for k, v in s.items() if k != "at_times"},
        "false_tracks": len(false_ids),
        "false_tracks_per_hour": len(false_ids) / duration_h if duration_h > 0 else math.nan,
        "track_breaks": int(sum(r["track_breaks"] for r in per_target)),
        "identity_swaps": swaps,
        "latency_median_s": float(np.median(lat)) if lat.size else math.nan,
        "latency_p95_s": float(np.percentile(lat, 95)) if lat.size else math.nan,
        "tracks_messages": len(data.tracks),
        "malformed_messages": int(sum(data.malformed.values())),
        "malformed_by_reason": dict(sorted(data.malformed.items())),
    }
    holding = [{"seed": seed, "scan": i, "t_s": float(data.scan_t[i]), "target": name,
                "track_id": held[i][j]}
               for i in range(len(held)) for j, name in enumerate(data.target_ids)
               if counted_all[i][j]]
    return RunScores(per_scan, per_target, run, holding)


def _per_target(data: RunData, held, counted_all, err_sum, ref_range, seed):
    """First track, breaks, identity swaps per target, from the scans' assignments."""
    k = len(data.target_ids)
    t = data.scan_t
    breaks = np.zeros(k, int)
    swap_events: set[tuple[int, frozenset[str]]] = set()
    involved: dict[int, set[tuple[int, frozenset[str]]]] = {j: set() for j in range(k)}
    for i in range(1, len(held)):
        prev, cur = held[i - 1], held[i]
        owner_prev = {tid: j for j, tid in enumerate(prev) if tid is not None}
        for j in range(k):
            if prev[j] is not None and cur[j] is None and counted_all[i][j]:
                breaks[j] += 1
            if prev[j] is not None and cur[j] is not None and cur[j] != prev[j]:
                other = owner_prev.get(cur[j])
                if other is not None and other != j:
                    ev = (i, frozenset((prev[j], cur[j])))
                    swap_events.add(ev)
                    involved[j].add(ev)
                    involved[other].add(ev)
    rows = []
    for j, name in enumerate(data.target_ids):
        counted = np.array([c[j] for c in counted_all], bool) if counted_all else np.zeros(0,
                                                                                         bool)
        is_held = np.array([h[j] is not None for h in held], bool)
        first_c = int(np.argmax(counted)) if counted.any() else None
        first_h = int(np.argmax(is_held)) if is_held.any() else None
        n_held = int(is_held.sum())
        rows.append({
            "seed": seed, "target": name,
            "scans_counted": int(counted.sum()), "scans_held": n_held,
            "held_fraction": n_held / int(counted.sum()) if counted.any() else math.nan,
            "first_counted_s": float(t[first_c]) if first_c is not None else math.nan,
            "first_track_s": float(t[first_h]) if first_h is not None else math.nan,
            "first_track_delay_s": float(t[first_h] - t[first_c])
            if first_h is not None and first_c is not None else math.nan,
            "first_track_range_m": float(ref_range[first_h, j]) if first_h is not None
            else math.nan,
            "track_breaks": int(breaks[j]),
            "identity_swaps": len(involved[j]),
            "track_ids": len({h[j] for h in held if h[j] is not None}),
            "mean_error_m": float(err_sum[j] / n_held) if n_held else math.nan,
        })
    return rows, len(swap_events)
