"""Scores of one run: which truth counts, time alignment, GOSPA and SIAP, per-target figures.

What is computed (all of it here, vectorised per scan with numpy and
:func:`scipy.optimize.linear_sum_assignment`; ``tests/test_evaluate.py`` checks it against
Stone Soup's classes called directly on the same sets, and against closed forms):

- **GOSPA** (generalised optimal sub-pattern assignment, Rahmathullah, García-Fernández &
  Svensson, *Generalized optimal sub-pattern assignment metric*, FUSION 2017), ``alpha = 2``,
  at every scored scan, with its decomposition into localisation, missed and false parts, as
  Stone Soup's :meth:`~stonesoup.metricgenerator.ospametric.GOSPAMetric.compute_gospa_metric`
  computes them (:func:`gospa_scan`). The parts are in the metric's own unit, metres to the
  power ``p``: with ``p = 1`` (default) the localisation part is the sum of the assigned
  tracks' horizontal position errors [m], and the missed and false parts are ``c / 2`` per
  missed target and per false track. GOSPA's assignment is the best of each scan alone: it
  is a distance between two sets, not an identity.
- **Identity** (which track holds which target, :func:`identity_assignment`): a one-to-one
  assignment of tracks to counted targets within ``c`` that is kept from scan to scan: at
  each scan the previous scan's pairs still within ``c`` are kept (the other tracks and
  targets assigned as GOSPA would), unless GOSPA's best assignment of that scan has been
  strictly cheaper for ``switch_scans`` scans in a row, when it is taken. A crossing where
  the per-scan optimum flips for a scan or two is therefore no identity change; a tracker
  that really exchanges two tracks shows the exchange ``switch_scans - 1`` scans late (at
  once when a kept pair goes beyond ``c``). Per target from it: the time and range of its
  first track, scans held, track breaks, identity swaps, mean error; false tracks.
- **SIAP** (Votruba et al., *Single Integrated Air Picture (SIAP) Metrics Implementation*,
  2001), the definitions of Stone Soup's
  :class:`~stonesoup.metricgenerator.tracktotruthmetrics.SIAPMetrics` (:func:`siap`) on a
  track-to-truth association (:func:`siap_association`) that is Stone Soup's
  :class:`~stonesoup.dataassociator.tracktotrack.TrackToTruth` (nearest truth within
  ``siap_threshold_m``; confirmed from the first of :data:`SIAP_CONFIRM_SCANS` scans in a
  row; ended at the first scan its truth is beyond the threshold) with one change: while its
  truth is within the threshold, a track moves to another, nearer truth only once that one
  has been the nearer for ``switch_scans`` scans in a row. Completeness, ambiguity,
  spuriousness, position and velocity accuracy and the rate of track-number change are
  Stone Soup's formulas; the **longest track segment** is the longest *unbroken*
  association of one track with a truth (Stone Soup adds the pieces of one track-truth
  pair: a track held 7-67 s and 69-100 s reads 91 s there, 60 s here), over the truth's
  lifetime, summed over truths.
- **By hand**, because no library has them: false tracks per hour, the tracker's latency.

Distances: GOSPA, the errors and the accuracies are horizontal (east, north). The
association (identity and SIAP) is horizontal too, unless a ``tracks`` message gives
``up_m`` (optional, docs/protocol.md section 4.6): then it measures that message's tracks in
three dimensions against the targets' heights, so targets crossing at different heights keep
their tracks. Both associations accept a pair within ``c`` (2 km by default; the SIAP
threshold defaults to it): wide against the ~300 m accuracy of a track on a 100 km radar,
so that a coasting or lagging track still counts as held.

Which truth counts (:func:`counted_matrix`, the one place), by ``MetricConfig.truth``
(default ``"pd"``: a tracker is scored against what the radars could detect; docs/studies.md
says why):

- ``"coverage"``: at each scored scan, a target that is active and *in coverage* of at
  least one radar, as the stream says it: each radar's ``in_coverage`` of its latest
  ``truth[targets]`` copy at or before the scan (the reference radar's is at the scan
  itself; another radar's is at most one of its scans old). That is the engine's own test
  before a look: ground range from the antenna within the instrumented range, and within the
  radio horizon over the 4/3 earth (docs/protocol.md section 4.4): geometric, so a target a
  duct carries beyond the horizon, which the radar does detect, is not counted (a track on
  it is a false track). A stream of schema version 1 has no ``in_coverage``; it is scored by
  :func:`detectable`, the same test computed from the antennas' positions at the scan.
- ``"pd"``: a target that is active and that some radar's looks of the last ``pd_window_s``
  (default three of that radar's scan periods) gave a probability of detection of at least
  ``pd_threshold`` (0.5): the ``look_time_s`` and ``pd`` of each radar's ``truth[targets]``
  copies, the simulator's own P_d of each look (ducting, multipath, clutter, jamming and
  resolution included). A stream without them falls back to ``"coverage"``.

A target that does not count is neither missed nor held; a track on it is false.

Time alignment: the run is scored at the reference sensor's ends of scan (the first radar of
the stream). At each, the tracker's latest valid ``tracks`` message at or before that time,
and not older than ``max_track_age_s``, is taken and its tracks extrapolated at constant
velocity to the scan time (heights held); none: the tracker holds no track at that scan.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from shipradar.sensors.propagation import horizon_range
from shipradar.sim.studies.evaluate.data import RunData, TracksMessage
from shipradar.sim.studies.evaluate.registration import RegistrationConfig, score_registration

__all__ = ["DEFAULT_METRICS", "MetricConfig", "RunScores", "TRUTH_RULES",
           "counted_matrix", "counted_targets", "detectable", "gospa_scan",
           "identity_assignment", "score_run", "siap", "siap_association", "tracks_at"]

# Two times closer than this are the same scan [s] (the stream's times are exact floats).
_SAME_T_S = 1e-6

#: The rules of which truth counts (module docstring).
TRUTH_RULES: tuple[str, ...] = ("coverage", "pd")


@dataclass(frozen=True)
class MetricConfig:
    """Every setting of the metrics, declared once (``shipradar evaluate --rescore`` takes
    other values without re-running).

    Attributes
    ----------
    c_m : float
        GOSPA cut-off c [m]: farther than this a track and a target are not assigned, and a
        missed target or a false track costs c^p / 2. Also the identity association's
        distance.
    p : float
        GOSPA order p (1 <= p).
    siap_threshold_m : float or None
        Track-to-truth association distance of the SIAP metrics [m]; None: ``c_m``.
    max_track_age_s : float or None
        Longest time between a ``tracks`` message and the scan it is scored at [s]; None:
        1.5 scan periods of the reference sensor.
    switch_scans : int
        Scans in a row another assignment (identity) or another truth (SIAP) must be better
        before a track's association moves to it (>= 1; 1: every scan on its own).
    truth : str
        Which truth counts: ``"pd"`` (the looks' P_d, default) or ``"coverage"``
        (geometric).
    pd_threshold : float
        ``truth = "pd"``: the P_d a look must reach for its target to count (0 < x <= 1).
    pd_window_s : float or None
        ``truth = "pd"``: how far back the looks are read [s]; None: three scan periods of
        each radar.
    registration : RegistrationConfig
        Tolerances and warm-up of the registration scores
        (:mod:`shipradar.sim.studies.evaluate.registration`).
    """

    c_m: float = 2000.0
    p: float = 1.0
    siap_threshold_m: float | None = None
    max_track_age_s: float | None = None
    switch_scans: int = 3
    truth: str = "pd"
    pd_threshold: float = 0.5
    pd_window_s: float | None = None
    registration: RegistrationConfig = RegistrationConfig()

    def __post_init__(self) -> None:
        if not self.c_m > 0:
            raise ValueError(f"c_m must be > 0, got {self.c_m}")
        if not self.p >= 1:
            raise ValueError(f"p must be >= 1, got {self.p}")
        if self.siap_threshold_m is not None and not self.siap_threshold_m > 0:
            raise ValueError(f"siap_threshold_m must be > 0, got {self.siap_threshold_m}")
        if isinstance(self.switch_scans, bool) or not isinstance(self.switch_scans, int) \
                or self.switch_scans < 1:
            raise ValueError(f"switch_scans must be an integer >= 1, got {self.switch_scans}")
        if self.truth not in TRUTH_RULES:
            raise ValueError(f"truth must be one of {', '.join(TRUTH_RULES)}, got "
                             f"{self.truth!r}")
        if not 0 < self.pd_threshold <= 1:
            raise ValueError(f"pd_threshold must be in (0, 1], got {self.pd_threshold}")
        if self.pd_window_s is not None and not self.pd_window_s > 0:
            raise ValueError(f"pd_window_s must be > 0, got {self.pd_window_s}")

    @property
    def threshold_m(self) -> float:
        return self.c_m if self.siap_threshold_m is None else float(self.siap_threshold_m)

    def as_dict(self) -> dict[str, Any]:
        return dict(asdict(self), alpha=2)


#: Scans in a row within the SIAP threshold that start a track-to-truth association (from
#: the first of them), as Stone Soup's ``TrackToTruth(consec_pairs_confirm=2)``: a track
#: within the threshold for a single scan is not associated (spurious at that scan).
SIAP_CONFIRM_SCANS = 2

#: The documented defaults.
DEFAULT_METRICS = MetricConfig()

#: ``pd_window_s`` default, in scan periods of each radar.
PD_WINDOW_SCANS = 3.0


def detectable(pos_m: np.ndarray, active: np.ndarray, antennas: list[tuple[np.ndarray, float]]
               ) -> np.ndarray:
    """Which targets count at one time, computed from geometry (the fallback of
    :func:`counted_matrix` for a stream without ``in_coverage``): active and in coverage of
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


def counted_matrix(data: RunData, config: MetricConfig | None = None) -> np.ndarray:
    """Which targets count at every scored scan (module docstring, "Which truth counts").

    Returns
    -------
    ndarray of bool, shape (K, k)
        Row ``i``: the targets counted at ``data.scan_t[i]``.
    """
    config = DEFAULT_METRICS if config is None else config
    t = np.asarray(data.scan_t, float)
    active = np.asarray(data.truth_active, bool).reshape(t.size, -1)
    if config.truth == "pd" and data.radars and all(s in data.looks for s in data.radars):
        return _counted_by_pd(data, config) & active
    if not data.radars or any(s not in data.coverage for s in data.radars):
        out = np.zeros(active.shape, bool)
        for i in range(t.size):
            antennas = [(_antenna_at(r, float(t[i])), r["instrumented_range_m"])
                        for r in data.radars.values()]
            out[i] = detectable(data.truth_pos[i], active[i], antennas)
        return out
    out = np.zeros(active.shape, bool)
    for s in data.radars:
        times, cover = data.coverage[s]
        j = np.searchsorted(times, t + _SAME_T_S, side="right") - 1
        ok = j >= 0
        out[ok] |= cover[j[ok]]
    return out & active


def _counted_by_pd(data: RunData, config: MetricConfig) -> np.ndarray:
    """``truth = "pd"``: for some radar, a look within the window reached the threshold."""
    t = np.asarray(data.scan_t, float)
    k = data.truth_active.shape[1] if data.truth_active.ndim == 2 else 0
    out = np.zeros((t.size, k), bool)
    for s, r in data.radars.items():
        times, look_t, pd = data.looks[s]
        window = (config.pd_window_s if config.pd_window_s is not None
                  else PD_WINDOW_SCANS * float(r["scan_period_s"]))
        # each copy holds its targets' last look; a look inside the window is in a copy
        # made at or after it, so the copies of (t - window, t] hold every such look
        hi = np.searchsorted(times, t + _SAME_T_S, side="right")
        lo = np.searchsorted(times, t - window, side="right")
        good = np.where(np.isfinite(pd) & (pd >= config.pd_threshold), look_t, -np.inf)
        for i in range(t.size):
            if hi[i] > lo[i]:
                out[i] |= (good[lo[i]:hi[i]] > t[i] - window).any(axis=0)
    return out


def counted_targets(data: RunData, i: int, config: MetricConfig | None = None
                    ) -> np.ndarray:
    """Row ``i`` of :func:`counted_matrix`: the targets counted at ``data.scan_t[i]``.

    Returns
    -------
    ndarray of bool, shape (k,)
    """
    return counted_matrix(data, config)[i]


def _antenna_at(radar: dict[str, Any], t: float | np.ndarray) -> np.ndarray:
    """Antenna position at t [m] (shape (3,), or (K, 3) for K times), linear between the
    ends of scan (the nearest outside)."""
    et, ep = radar["eos_t"], radar["eos_pos"]
    t = np.asarray(t, float)
    if et.size == 0:
        return np.zeros((*t.shape, 3))
    return np.stack([np.interp(t, et, ep[:, i]) for i in range(3)], axis=-1)


def tracks_at(tracks: list[TracksMessage], t_s: float, max_age_s: float,
              times: np.ndarray | None = None
              ) -> tuple[tuple[str, ...], np.ndarray, np.ndarray | None]:
    """The tracker's tracks at ``t_s``: its latest message at or before it, not older than
    ``max_age_s`` [s], extrapolated at constant velocity.

    Parameters
    ----------
    tracks : list of TracksMessage
        Sorted by ``time_s``.
    times : ndarray or None
        Their ``time_s`` (computed when None).

    Returns
    -------
    ids : tuple of str
    state : ndarray, shape (n, 4)
        east [m], v_east [m/s], north [m], v_north [m/s] at ``t_s``.
    up : ndarray (n,) or None
        Heights [m] when the message gives them.
    """
    if times is None:
        times = np.array([m.time_s for m in tracks], float)
    j = int(np.searchsorted(times, t_s + _SAME_T_S, side="right")) - 1
    if j < 0 or t_s - tracks[j].time_s > max_age_s:
        return (), np.zeros((0, 4)), None
    best = tracks[j]
    dt_s = t_s - best.time_s
    state = np.stack([best.east_m + best.v_east_mps * dt_s, best.v_east_mps,
                      best.north_m + best.v_north_mps * dt_s, best.v_north_mps], axis=-1)
    return best.track_id, state.reshape(-1, 4), best.up_m


def _lsa(cost: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if cost.size == 0:
        return np.zeros(0, int), np.zeros(0, int)
    return linear_sum_assignment(cost)


def gospa_scan(track_xy: np.ndarray, truth_xy: np.ndarray, c: float, p: float
               ) -> tuple[dict[str, float], np.ndarray]:
    """GOSPA (alpha = 2) of one scan, as Stone Soup's ``compute_gospa_metric``.

    Parameters
    ----------
    track_xy, truth_xy : ndarray, shapes (n, 2), (m, 2)
        Horizontal positions [m].
    c : float
        Cut-off [m].
    p : float
        Order.

    Returns
    -------
    parts : dict
        ``distance`` [m], ``localisation``, ``missed``, ``false`` [m^p].
    truth_to_track : ndarray of int, shape (m,)
        The track assigned to each truth, -1 for none (a pair at c or beyond is none).
    """
    n, m = len(track_xy), len(truth_xy)
    half = c**p / 2.0
    to_track = np.full(m, -1)
    if n == 0 or m == 0:
        parts = {"localisation": 0.0, "missed": m * half, "false": n * half}
    else:
        d = np.hypot(truth_xy[:, None, 0] - track_xy[None, :, 0],
                     truth_xy[:, None, 1] - track_xy[None, :, 1])
        cost = np.power(np.where(d < c, d, c), p)
        r, k = _lsa(cost)
        ok = cost[r, k] < c**p
        to_track[r[ok]] = k[ok]
        a = int(ok.sum())
        parts = {"localisation": float(cost[r[ok], k[ok]].sum()),
                 "missed": (m - a) * half, "false": (n - a) * half}
    total = parts["localisation"] + parts["missed"] + parts["false"]
    # + 0.0: no negative zero in the tables
    return {"distance": float(total ** (1.0 / p)) + 0.0, **parts}, to_track


def _assoc_distance(track_xy: np.ndarray, track_up: np.ndarray | None, truth_pos: np.ndarray
                    ) -> np.ndarray:
    """Association distances (n tracks, m truths) [m]: horizontal, or three-dimensional
    when the tracks' heights are given."""
    d2 = ((track_xy[:, None, 0] - truth_pos[None, :, 0]) ** 2
          + (track_xy[:, None, 1] - truth_pos[None, :, 1]) ** 2)
    if track_up is not None:
        d2 = d2 + (track_up[:, None] - truth_pos[None, :, 2]) ** 2
    return np.sqrt(d2)


@dataclass
class _Scan:
    """What the associations read of one scored scan."""

    ids: tuple[str, ...]
    state: np.ndarray  # (n, 4) east, v_east, north, v_north
    idx: np.ndarray  # the counted targets (global indices), (m,)
    dist: np.ndarray  # association distances (n, m) [m]


def identity_assignment(scans: list[_Scan], c: float, p: float, switch_scans: int
                        ) -> list[dict[int, int]]:
    """Per scan: target (global index) -> track (index in that scan's ``ids``), the
    temporally consistent assignment of the module docstring ("Identity").

    The cost of an assignment is GOSPA's: the sum of the pairs' distances to the power p,
    plus c^p / 2 per track and per target left out; pairs at c or beyond are not made.
    """
    out: list[dict[int, int]] = []
    prev: dict[str, int] = {}  # track id -> target held at the previous scan
    streak = 0
    cp = c**p
    for sc in scans:
        n, m = sc.dist.shape
        cost = np.power(np.where(sc.dist < c, sc.dist, c), p)
        r, k = _lsa(cost)
        ok = cost[r, k] < cp
        best = {int(sc.idx[a]): int(b) for b, a in zip(r[ok], k[ok], strict=True)}
        # the previous scan's pairs still within c, then the rest as GOSPA would
        col = {int(j): a for a, j in enumerate(sc.idx)}
        kept = {}
        for b, tid in enumerate(sc.ids):
            j = prev.get(tid)
            if j is not None and j in col and sc.dist[b, col[j]] < c:
                kept[j] = b
        if kept:
            rest_t = np.array([b for b in range(n) if b not in kept.values()], int)
            rest_j = np.array([a for a in range(m) if int(sc.idx[a]) not in kept], int)
            sub = cost[np.ix_(rest_t, rest_j)]
            r2, k2 = _lsa(sub)
            ok2 = sub[r2, k2] < cp
            keep = dict(kept)
            keep.update({int(sc.idx[rest_j[a]]): int(rest_t[b])
                         for b, a in zip(r2[ok2], k2[ok2], strict=True)})
        else:
            keep = best

        if keep is best or _cost(keep, cost, col, cp) <= _cost(best, cost, col, cp) * (
                1 + 1e-12):
            chosen, streak = keep, 0
        else:
            streak += 1
            chosen = best if streak >= switch_scans else keep
            if chosen is best:
                streak = 0
        out.append(chosen)
        prev = {sc.ids[b]: j for j, b in chosen.items()}
    return out


def _cost(pairs: dict[int, int], cost: np.ndarray, col: dict[int, int], cp: float) -> float:
    """GOSPA's cost of an assignment (target -> track) on a scan's cost matrix."""
    n, m = cost.shape
    return float(sum(cost[b, col[j]] for j, b in pairs.items())) + cp / 2.0 * (
        n + m - 2 * len(pairs))


@dataclass(frozen=True)
class Association:
    """One unbroken association of a track with a truth: scored scans ``first`` to
    ``last`` (inclusive) of the track's piece ``track`` (``id#n``: its n-th unbroken run of
    scans) on the truth's piece ``truth`` (``j#n``)."""

    track: str
    truth: str
    target: int
    first: int
    last: int

    @property
    def track_id(self) -> str:
        return self.track.rsplit("#", 1)[0]


def _pieces(present: np.ndarray) -> np.ndarray:
    """Piece number of each scan of a presence row: a new piece after every gap; -1 where
    absent."""
    starts = present & ~np.concatenate([[False], present[:-1]])
    return np.where(present, np.cumsum(starts) - 1, -1)


def siap_association(scans: list[_Scan], threshold: float, switch_scans: int
                     ) -> list[Association]:
    """The SIAP track-to-truth associations (module docstring, "SIAP"): per track piece,
    the nearest counted truth within ``threshold`` [m] is its candidate at each scan."""
    k_scans = len(scans)
    ids = sorted({tid for sc in scans for tid in sc.ids})
    out: list[Association] = []
    targets = sorted({int(j) for sc in scans for j in sc.idx})
    counted = np.zeros((k_scans, (max(targets) + 1) if targets else 0), bool)
    for i, sc in enumerate(scans):
        counted[i, sc.idx] = True
    truth_piece = np.stack([_pieces(counted[:, j]) for j in range(counted.shape[1])], axis=1) \
        if counted.size else counted.astype(int)
    row_of = [{tid: b for b, tid in enumerate(sc.ids)} for sc in scans]
    col_of = [{int(j): a for a, j in enumerate(sc.idx)} for sc in scans]
    for tid in ids:
        present = np.array([tid in r for r in row_of], bool)
        piece = _pieces(present)
        cur: int | None = None
        pend: int | None = None
        chal: int | None = None
        start = p_start = p_count = c_count = 0
        for i in (int(x) for x in np.flatnonzero(present)):
            if i > 0 and not present[i - 1]:  # a new piece of the track
                if cur is not None:
                    last = _last_present(present, i)
                    out.append(_association(tid, piece, truth_piece, cur, start, last))
                cur = pend = chal = None
                p_count = c_count = 0
            sc, b = scans[i], row_of[i][tid]
            d = sc.dist[b]
            a = int(np.argmin(d)) if d.size else -1
            cand = int(sc.idx[a]) if a >= 0 and d[a] < threshold else None
            if cur is None:
                if cand is None:
                    pend, p_count = None, 0
                elif cand == pend:
                    p_count += 1
                else:
                    pend, p_count, p_start = cand, 1, i
                if pend is not None and p_count >= SIAP_CONFIRM_SCANS:
                    cur, start, pend, p_count, chal, c_count = pend, p_start, None, 0, None, 0
                continue
            a_cur = col_of[i].get(cur)
            if a_cur is not None and d[a_cur] < threshold:
                if cand is not None and cand != cur:
                    c_count = c_count + 1 if cand == chal else 1
                    chal = cand
                    if c_count >= switch_scans:
                        out.append(_association(tid, piece, truth_piece, cur, start, i - 1))
                        cur, start, chal, c_count = cand, i, None, 0
                else:
                    chal, c_count = None, 0
                continue
            # its truth is beyond the threshold (or no longer counted): the association
            # ends at the previous scan, and the candidate, if any, starts pending
            out.append(_association(tid, piece, truth_piece, cur, start, i - 1))
            cur, chal, c_count = None, None, 0
            pend, p_count, p_start = cand, (1 if cand is not None else 0), i
        if cur is not None:
            last = int(np.flatnonzero(present)[-1])
            out.append(_association(tid, piece, truth_piece, cur, start, last))
    return out


def _association(tid: str, piece: np.ndarray, truth_piece: np.ndarray, target: int,
                 first: int, last: int) -> Association:
    return Association(f"{tid}#{piece[last]}", f"{target}#{truth_piece[last, target]}",
                       target, first, last)


def _last_present(present: np.ndarray, i: int) -> int:
    return int(np.flatnonzero(present[:i])[-1])
# long: 24 docstring lines; Stone Soup's SIAP formulas one after the other
def siap(scans: list[_Scan], assocs: list[Association], scan_t: np.ndarray,
         truth_state: np.ndarray) -> dict[str, Any]:
    """SIAP metrics (Stone Soup's ``SIAPMetrics`` formulas, module docstring) of the
    associations ``assocs`` over the scored scans.

    Parameters
    ----------
    scans : list of _Scan
        Per scan the tracks (ids, state) and the counted targets.
    assocs : list of Association
        From :func:`siap_association`.
    scan_t : ndarray (K,)
        The scans' times [s].
    truth_state : ndarray (K, k, 4)
        Targets' east [m], v_east [m/s], north [m], v_north [m/s] at each scan.

    Returns
    -------
    dict
        ``completeness``, ``ambiguity``, ``spuriousness``, ``position_accuracy_m``,
        ``velocity_accuracy_mps``, ``track_number_change_rate`` [1/s],
        ``longest_segment`` (the longest unbroken association over the truth's lifetime,
        summed over truths) and ``at_times``: per scan ``completeness`` and
        ``spuriousness`` (NaN at a scan with neither track nor truth); NaN everywhere when
        there is no truth and no track.
    """
    names = ("completeness", "ambiguity", "spuriousness", "position_accuracy_m",
             "velocity_accuracy_mps", "track_number_change_rate", "longest_segment")
    k_scans = len(scans)
    n_truths = np.array([sc.idx.size for sc in scans], float)
    n_tracks = np.array([len(sc.ids) for sc in scans], float)
    if not n_truths.sum() and not n_tracks.sum():
        return {**dict.fromkeys(names, math.nan), "at_times": [math.nan] * k_scans,
                "at_times_spuriousness": [math.nan] * k_scans}
    pairs: list[list[tuple[int, int]]] = [[] for _ in range(k_scans)]  # (track row, target)
    for a in assocs:
        for i in range(a.first, a.last + 1):
            pairs[i].append((scans[i].ids.index(a.track_id), a.target))
    n_assoc = np.array([len(p) for p in pairs], float)
    n_assoc_truths = np.array([len({j for _, j in p}) for p in pairs], float)
    pa = va = 0.0
    for i, p in enumerate(pairs):
        if p:
            rows_b = np.array([x for x, _ in p])
            tgt = np.array([y for _, y in p])
            st, tr = scans[i].state[rows_b], truth_state[i, tgt]
            pa += float(np.hypot(st[:, 0] - tr[:, 0], st[:, 2] - tr[:, 2]).sum())
            va += float(np.hypot(st[:, 1] - tr[:, 1], st[:, 3] - tr[:, 3]).sum())
    sj, sjt, sn, sna = n_truths.sum(), n_assoc_truths.sum(), n_tracks.sum(), n_assoc.sum()
    out = {
        "completeness": sjt / sj if sj else 0.0,
        "ambiguity": sna / sjt if sjt else 1.0,
        "spuriousness": (sn - sna) / sn if sn else 0.0,
        "position_accuracy_m": pa / sna if sna else 0.0,
        "velocity_accuracy_mps": va / sna if sna else 0.0,
    }
    # per truth piece (a target's unbroken run of counted scans): lifetime, time tracked
    # (union of its associations), tracks needed to cover it, longest unbroken association
    t = np.asarray(scan_t, float)
    by_piece: dict[str, list[Association]] = {}
    for assoc in assocs:
        by_piece.setdefault(assoc.truth, []).append(assoc)
    k = truth_state.shape[1] if truth_state.ndim == 3 else 0
    counted = np.zeros((k_scans, k), bool)
    for i, sc in enumerate(scans):
        counted[i, sc.idx] = True
    life = tracked = longest = 0.0
    changes = 0
    for j in range(k):
        piece = _pieces(counted[:, j])
        for n in range(int(piece.max()) + 1 if piece.size else 0):
            rows = np.flatnonzero(piece == n)
            life += float(t[rows[-1]] - t[rows[0]])
            spans = sorted((x.first, x.last) for x in by_piece.get(f"{j}#{n}", []))
            if not spans:
                continue
            longest += max(float(t[s1] - t[s0]) for s0, s1 in spans)
            end = -1  # union of the closed spans [t_first, t_last]
            for s0, s1 in spans:
                if s1 > end:
                    tracked += float(t[s1] - t[max(s0, end)])
                    end = s1
            needed, at = 0, int(rows[0])
            while at <= rows[-1]:  # greedy cover: the span through `at` that ends last
                through = [s1 for s0, s1 in spans if s0 <= at <= s1]
                if through:
                    needed += 1
                    at = max(through) + 1
                else:
                    at += 1
            changes += needed - 1
    out["track_number_change_rate"] = changes / tracked if tracked else 0.0
    out["longest_segment"] = longest / life if life else 0.0
    out = {key: float(v) for key, v in out.items()}
    none = (n_truths == 0) & (n_tracks == 0)
    comp = np.where(n_truths > 0, n_assoc_truths / np.maximum(n_truths, 1), 0.0)
    spur = np.where(n_tracks > 0, (n_tracks - n_assoc) / np.maximum(n_tracks, 1), 0.0)
    return {**out, "at_times": np.where(none, np.nan, comp).tolist(),
            "at_times_spuriousness": np.where(none, np.nan, spur).tolist()}


@dataclass
class RunScores:
    """Scores of one run: ``per_scan``, ``per_target`` (lists of row dicts), ``run`` (one
    dict) and ``holding`` (per scan and counted target: the track that held it, or None),
    every row carrying the run's ``seed``."""

    per_scan: list[dict[str, Any]]
    per_target: list[dict[str, Any]]
    run: dict[str, Any]
    holding: list[dict[str, Any]]
    registration: list[dict[str, Any]] = field(default_factory=list)  #: per radar, component
    registration_series: list[dict[str, Any]] = field(default_factory=list)  #: per estimate


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
    merged = None
    for msg in data.tracks:
        if not math.isfinite(msg.recv_s):
            continue
        got = data.inputs.get(msg.sensor)
        if got is None:
            merged = _merged_inputs(data) if merged is None else merged
            got = merged
        t_in, sent = got
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


# long: the metrics of one run in the module docstring's order
def score_run(data: RunData, config: MetricConfig = DEFAULT_METRICS) -> RunScores:
    """Score one run (see the module docstring for every definition).

    Parameters
    ----------
    data : RunData
        From :func:`shipradar.sim.studies.evaluate.data.load_run` (or collected during the
        run).
    config : MetricConfig
        The metrics' settings.
    """
    seed = data.info.get("seed")
    max_age = _max_age(data, config)
    tracks = sorted(data.tracks, key=lambda m: m.time_s)
    track_t = np.array([m.time_s for m in tracks], float)
    k_targets = len(data.target_ids)
    ref = data.radars.get(data.ref_sensor)
    counted_all = counted_matrix(data, config)
    n_scans = data.scan_t.size
    ref_range = np.full((n_scans, k_targets), np.nan)
    truth_state = np.stack([data.truth_pos[..., 0], data.truth_vel[..., 0],
                            data.truth_pos[..., 1], data.truth_vel[..., 1]], axis=-1) \
        if n_scans else np.zeros((0, k_targets, 4))
    if ref is not None and n_scans:
        a = _antenna_at(ref, data.scan_t)
        ref_range = np.hypot(data.truth_pos[..., 0] - a[:, None, 0],
                             data.truth_pos[..., 1] - a[:, None, 1])
    per_scan: list[dict[str, Any]] = []
    scans: list[_Scan] = []
    ids_seen: set[str] = set()
    for i, t in enumerate(data.scan_t):
        pos = data.truth_pos[i]
        idx = np.flatnonzero(counted_all[i])
        ids, state, up = tracks_at(tracks, float(t), max_age, track_t)
        v, to_track = gospa_scan(state[:, [0, 2]], pos[idx][:, :2], config.c_m, config.p)
        scans.append(_Scan(ids, state, idx, _assoc_distance(state[:, [0, 2]], up, pos[idx])))
        ids_seen.update(ids)
        per_scan.append({
            "seed": seed, "scan": i, "t_s": float(t), "truths": int(idx.size),
            "tracks": len(ids), "gospa": v["distance"], "localisation": v["localisation"],
            "missed": v["missed"], "false": v["false"],
            "assigned": int((to_track >= 0).sum()),
        })
    identity = identity_assignment(scans, config.c_m, config.p, config.switch_scans)
    held: list[list[str | None]] = []
    err_sum = np.zeros(k_targets)
    ids_assigned: set[str] = set()
    for i, (sc, pairs) in enumerate(zip(scans, identity, strict=True)):
        held_row: list[str | None] = [None] * k_targets
        for j, b in pairs.items():
            held_row[j] = sc.ids[b]
            ids_assigned.add(sc.ids[b])
            st, tr = sc.state[b], truth_state[i, j]
            err_sum[j] += math.hypot(st[0] - tr[0], st[2] - tr[2])
        held.append(held_row)
    s = siap(scans, siap_association(scans, config.threshold_m, config.switch_scans),
             data.scan_t, truth_state)
    for scan_row, comp, spur in zip(per_scan, s["at_times"], s["at_times_spuriousness"],
                                    strict=True):
        scan_row["completeness"] = comp
        scan_row["spuriousness"] = spur

    per_target, swaps = _per_target(data, held, counted_all, err_sum, ref_range, seed)
    duration_h = data.duration_s / 3600.0
    false_ids = sorted(ids_seen - ids_assigned)
    lat = latencies(data)

    def mean(key):
        return float(np.mean([r[key] for r in per_scan])) if per_scan else math.nan

    run = {
        "seed": seed, "status": data.info.get("status", "ok"),
        "scans": len(per_scan),
        "gospa": mean("gospa"), "localisation": mean("localisation"),
        "missed": mean("missed"), "false": mean("false"),
        **{f"siap_{k}": v for k, v in s.items() if not k.startswith("at_times")},
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
    reg = score_registration(data.registration, data.sensor_truth, config.registration, seed)
    run.update(reg.run)
    return RunScores(per_scan, per_target, run, holding, reg.rows, reg.series)


def _per_target(data: RunData, held, counted_all, err_sum, ref_range, seed):
    """First track, breaks, identity swaps per target, from the identity assignment."""
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
    counted_all = np.asarray(counted_all, bool).reshape(len(held), k)
    for j, name in enumerate(data.target_ids):
        counted = counted_all[:, j]
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
