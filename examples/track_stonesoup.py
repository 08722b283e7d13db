"""A Stone Soup tracker on a shipradar stream, scored by OSPA against the truth topic.

Run it beside a simulation (start the tracker first; the run waits for it)::

    shipradar run scenarios/single_missile.yaml --publish tcp://127.0.0.1:5555 --wait 1 &
    python examples/track_stonesoup.py tcp://127.0.0.1:5555

or on a recording::

    python examples/track_stonesoup.py run.shr

The tracker: extended Kalman filter (:class:`ExtendedKalmanPredictor`/``Updater``) on a
nearly-constant-velocity model in the scenario's local east/north frame; detections with
their own bearing-range models (:mod:`shipradar.sim.adapters.stonesoup_reader`); PDA hypotheses
scored with the clutter density of the radar's noise false alarms and associated by global nearest
neighbour (:class:`GNNWith2DAssignment`); tracks confirmed by a :class:`MultiMeasurementInitiator`
(``confirm`` updates) and deleted after ``delete_after`` scans without an update (8 by
default, enough to coast a sea-skimmer across a multipath null).

Clutter density: the stream's meta gives the expected noise false alarms per scan λ
(``noise_false_alarms_per_scan``) over the disc of the instrumented range R; spread uniformly
in the bearing-range measurement space that is λ / (2π R) [1/(rad m)]. Sea-clutter false
alarms are not in that figure; a floor of ``min_false_alarms_per_scan`` keeps the density
non-zero for a radar with a very long false-alarm time.

Sea clutter: the radar's sea-clutter false alarms crowd the first kilometres around the ship
(tens to hundreds per scan). When the meta carries the radar's expected sea-clutter false
alarms per range ring (``clutter_false_alarm_profile``, from its P_fac map), the tracker's
clutter map starts from it (as if 10 scans had been seen); in any case it learns from the
stream itself (it never reads the truth): the mean number of plots per scan in each range
ring. It uses the map twice: (1) the PDA clutter density at a track's predicted position is
the larger of the meta rate's and the ring's, λ_ring / (2π Δr); (2) no track is initiated
from a plot in a ring whose plot density exceeds ``max_initiation_clutter_per_km2`` (a
clutter-map initiation gate, as operational trackers do), so hundreds of tentative tracks
never start; confirmed tracks are followed into the clutter. Detections farther than
``pregate_m`` (plus four predicted standard deviations) from every track are left out of the
association, which only saves time (the PDA gate is much smaller).

OSPA (Stone Soup's :class:`OSPAMetric`, position only, cut-off ``ospa_c``, order ``ospa_p``) is
computed at every end of scan between the confirmed tracks, predicted to the end-of-scan
time, and the truth topic's active targets at that time.

Tracks back to a display: ``--publish-tracks ENDPOINT`` binds a ZeroMQ publisher there and
sends, at every end of scan, one ``tracks`` message (docs/protocol.md, "tracks") with the
confirmed tracks predicted to that time; ``shipradar view SOURCE --tracks ENDPOINT`` draws them::

    python examples/track_stonesoup.py tcp://127.0.0.1:5555 --publish-tracks tcp://127.0.0.1:5560
    shipradar view tcp://127.0.0.1:5555 --tracks tcp://127.0.0.1:5560
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

try:  # run as a script from the repository, without installing it
    import shipradar  # noqa: F401
except ImportError:  # pragma: no cover
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
from stonesoup.deleter.time import UpdateTimeStepsDeleter
from stonesoup.hypothesiser.probability import PDAHypothesiser
from stonesoup.initiator.simple import MultiMeasurementInitiator
from stonesoup.measures import Euclidean
from stonesoup.metricgenerator.ospametric import OSPAMetric
from stonesoup.models.transition.linear import (
    CombinedLinearGaussianTransitionModel,
    ConstantVelocity,
    KnownTurnRate,
)
from stonesoup.predictor.kalman import ExtendedKalmanPredictor
from stonesoup.types.array import CovarianceMatrix, StateVector
from stonesoup.types.hypothesis import SingleHypothesis
from stonesoup.types.prediction import GaussianStatePrediction
from stonesoup.types.state import GaussianState, State
from stonesoup.types.update import GaussianStateUpdate
from stonesoup.updater.kalman import ExtendedKalmanUpdater

from shipradar.sim.adapters.stonesoup_reader import ShipradarDetectionReader
from shipradar.sim.stream.schema import TRACKS

__all__ = ["ClutterMap", "clutter_density", "main", "radar_clutter_profile", "track",
           "tracks_payload"]


def clutter_density(meta: dict, *, min_false_alarms_per_scan: float = 0.01) -> float:
    """Clutter density in bearing-range space [1/(rad m)] from the stream's meta.

    λ / (2π R): λ the expected noise false alarms per scan (at least the floor), R the
    instrumented range [m].
    """
    lam = max(float(meta.get("noise_false_alarms_per_scan", 0.0)), min_false_alarms_per_scan)
    r_max = float(meta["radar"]["instrumented_range_m"])
    return lam / (2.0 * math.pi * r_max)


def radar_clutter_profile(meta: dict):
    """The radar's expected sea-clutter false alarms per scan by range ring, from the meta
    (``clutter_false_alarm_profile``: ``range_edges_m``, ``per_scan``), or None."""
    prof = meta.get("clutter_false_alarm_profile")
    if not prof:
        return None
    return np.asarray(prof["range_edges_m"], float), np.asarray(prof["per_scan"], float)


class ClutterMap:
    """Mean plots per scan in range rings, learned from the stream (tracker-side only).

    Optionally started from the radar's own expected false alarms per ring (``prior``, as
    ``(range_edges_m, per_scan)``), counted as ``prior_scans`` scans already seen: the map
    then holds the radar's rate from the first scan and the stream refines it.
    """

    def __init__(self, r_max_m: float, ring_m: float = 250.0, prior=None,
                 prior_scans: int = 10):
        self.ring_m = ring_m
        self.counts = np.zeros(int(math.ceil(r_max_m / ring_m)) + 1)
        self.scans = 0
        if prior is not None and prior_scans > 0:
            edges, per_scan = (np.asarray(v, dtype=float) for v in prior)
            if per_scan.size:
                # the prior's cumulative count, read at this map's ring edges
                mine = ring_m * np.arange(self.counts.size + 1, dtype=float)
                cum = np.interp(mine, edges, np.concatenate([[0.0], np.cumsum(per_scan)]))
                self.counts += prior_scans * np.diff(cum)
                self.scans = prior_scans

    def update(self, ranges_m: np.ndarray) -> None:
        idx = np.minimum((np.asarray(ranges_m) // self.ring_m).astype(int), self.counts.size - 1)
        self.counts += np.bincount(idx, minlength=self.counts.size)
        self.scans += 1

    def per_scan(self, range_m):
        idx = np.minimum((np.asarray(range_m) // self.ring_m).astype(int), self.counts.size - 1)
        return self.counts[idx] / max(self.scans, 1)

    def density_bearing_range(self, range_m) -> np.ndarray:
        """Clutter density [1/(rad m)] in bearing-range space at ``range_m``."""
        return self.per_scan(range_m) / (2.0 * math.pi * self.ring_m)

    def density_area_km2(self, range_m) -> np.ndarray:
        """Plots per scan per km² at ``range_m``."""
        r = np.maximum(np.asarray(range_m, dtype=float), 0.5 * self.ring_m)
        return self.per_scan(range_m) / (2.0 * math.pi * r * self.ring_m) * 1e6


class _MapPDAHypothesiser(PDAHypothesiser):
    """PDA hypotheses with the clutter density at the track's predicted position."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.density_at = None  # callable (east, north) -> density, set by track()

    def hypothesise(self, track, detections, timestamp, **kwargs):
        if self.density_at is not None and track.states:
            pred = self.predictor.predict(track.state, timestamp=timestamp)
            self.clutter_spatial_density = float(
                self.density_at(pred.state_vector[0, 0], pred.state_vector[2, 0]))
        return super().hypothesise(track, detections, timestamp, **kwargs)


# --------------------------------------------------------------------------- IMM (--imm)
class IMMPredictor:
    """Interacting multiple model prediction (Blom & Bar-Shalom 1988) over M Kalman modes.

    The track's state carries its mode means/covariances and probabilities
    (``imm_modes``, ``imm_mu``) when it came from this predictor or :class:`IMMUpdater`; a
    plain Gaussian (a new track) starts every mode from it with ``mode_priors``.  The modes
    are mixed with the Markov ``transition`` matrix (row: from, column: to), each predicted
    by its own model, and the moment-matched mixture is returned (the hypothesiser gates and
    scores on it) with the per-mode predictions attached for the update.
    """

    def __init__(self, models, transition, mode_priors):
        self.transition_model = models[0]
        self._predictors = [ExtendedKalmanPredictor(m) for m in models]
        self._pi = np.asarray(transition, dtype=float)
        self._mu0 = np.asarray(mode_priors, dtype=float)
        self._cache: dict = {}

    def predict(self, prior, timestamp=None, **kwargs):
        state = getattr(prior, "state", prior)  # a Track or a state
        # the pre-gate, the hypothesiser and the initiator predict the same state to the
        # same time: once is enough
        key = (id(state), timestamp)
        hit = self._cache.get(key)
        if hit is not None and hit[0] is state:
            return hit[1]
        if len(self._cache) > 4096:
            self._cache.clear()
        out = self._predict(state, timestamp)
        self._cache[key] = (state, out)
        return out

    def _predict(self, state, timestamp):
        modes = getattr(state, "imm_modes", None)
        mu = getattr(state, "imm_mu", None)
        if modes is None:
            modes = [(np.asarray(state.state_vector, float), np.asarray(state.covar, float))
                     ] * len(self._predictors)
            mu = self._mu0
        c = mu @ self._pi  # predicted mode probabilities
        w = self._pi * mu[:, None] / np.maximum(c[None, :], 1e-300)  # mixing weights w[i, j]
        preds = []
        for j, predictor in enumerate(self._predictors):
            x0 = sum(w[i, j] * modes[i][0] for i in range(len(modes)))
            p0 = sum(w[i, j] * (modes[i][1] + (modes[i][0] - x0) @ (modes[i][0] - x0).T)
                     for i in range(len(modes)))
            pr = predictor.predict(GaussianState(StateVector(x0), CovarianceMatrix(p0),
                                                 timestamp=state.timestamp),
                                   timestamp=timestamp)
            preds.append((np.asarray(pr.state_vector, float), np.asarray(pr.covar, float)))
        out = _moment_match(preds, c, timestamp, GaussianStatePrediction)
        out.imm_modes, out.imm_mu = preds, c
        return out


def _moment_match(modes, mu, timestamp, cls, **kwargs):
    x = sum(m * xm for m, (xm, _) in zip(mu, modes, strict=True))
    p = sum(m * (pm + (xm - x) @ (xm - x).T) for m, (xm, pm) in zip(mu, modes, strict=True))
    return cls(StateVector(x), CovarianceMatrix(p), timestamp=timestamp, **kwargs)


class IMMUpdater(ExtendedKalmanUpdater):
    """IMM update: each mode updated by the EKF with the detection's own bearing-range model,
    mode probabilities from the modes' Gaussian likelihoods (bearing innovation wrapped)."""

    def update(self, hypothesis, **kwargs):
        pred = hypothesis.prediction
        modes = getattr(pred, "imm_modes", None)
        if modes is None:
            return super().update(hypothesis, **kwargs)
        z = hypothesis.measurement
        model = z.measurement_model
        ups, lik = [], []
        for xm, pm in modes:
            mp = GaussianStatePrediction(StateVector(xm), CovarianceMatrix(pm),
                                         timestamp=pred.timestamp)
            mz = self.predict_measurement(mp, measurement_model=model)
            up = super().update(SingleHypothesis(mp, z, measurement_prediction=mz))
            ups.append((np.asarray(up.state_vector, float), np.asarray(up.covar, float)))
            nu = (np.asarray(z.state_vector, float) - np.asarray(mz.state_vector, float)).ravel()
            nu[0] = (nu[0] + math.pi) % (2 * math.pi) - math.pi  # bearing first
            s_cov = np.asarray(mz.covar, float)
            lik.append(math.exp(-0.5 * nu @ np.linalg.solve(s_cov, nu))
                       / math.sqrt(np.linalg.det(2 * math.pi * s_cov)))
        mu = pred.imm_mu * np.asarray(lik)
        mu = mu / mu.sum() if mu.sum() > 0 else pred.imm_mu
        out = _moment_match(ups, mu, pred.timestamp, GaussianStateUpdate, hypothesis=hypothesis)
        out.imm_modes, out.imm_mu = ups, mu
        return out


def imm_models(q_m2_s3: float, turn_rate_rad_s: float, q_turn_m2_s3: float):
    """Constant velocity and coordinated turns at ±ω (Stone Soup's ``KnownTurnRate``) on the
    same (east, v_east, north, v_north) state."""
    cv = CombinedLinearGaussianTransitionModel(
        [ConstantVelocity(q_m2_s3), ConstantVelocity(q_m2_s3)])
    return [cv] + [KnownTurnRate(turn_noise_diff_coeffs=[q_turn_m2_s3, q_turn_m2_s3],
                                 turn_rate=w) for w in (turn_rate_rad_s, -turn_rate_rad_s)]


def _cartesian(dets: list) -> np.ndarray:
    """(N, 2) east/north of detections from their bearing, range and model offset."""
    out = np.empty((len(dets), 2))
    for i, d in enumerate(dets):
        b, r = float(d.state_vector[0, 0]), float(d.state_vector[1, 0])
        off = d.measurement_model.translation_offset
        out[i] = (off[0, 0] + r * math.cos(b), off[1, 0] + r * math.sin(b))
    return out


def _truth_states(truth: dict | None) -> list[State]:
    if truth is None:
        return []
    out = []
    active = np.asarray(truth["active"], bool)
    for i in np.flatnonzero(active):
        out.append(State(StateVector([truth["east_m"][i], truth["v_east_mps"][i]
                                      if "v_east_mps" in truth else 0.0,
                                      truth["north_m"][i], truth["v_north_mps"][i]
                                      if "v_north_mps" in truth else 0.0]),
                         timestamp=truth["timestamp"]))
    return out


def tracks_payload(sensor: str, scan: int, time_s: float, tracks, predictor, when) -> dict:
    """The ``tracks`` message (docs/protocol.md) of the confirmed ``tracks`` at ``when``.

    Each track's state is predicted to ``when`` (the end of scan, simulated ``time_s`` [s]);
    positions, velocities and 1-sigma position errors are in the scenario's local frame.
    """
    rows = sorted(tracks, key=lambda trk: trk.id)  # a stable order, message to message
    preds = [predictor.predict(trk.state, timestamp=when) for trk in rows]
    sv = np.array([np.asarray(p.state_vector, dtype=float).ravel() for p in preds]
                  ).reshape(-1, 4)
    cov = np.array([np.diag(np.asarray(p.covar, dtype=float)) for p in preds]).reshape(-1, 4)
    return TRACKS.message(
        sensor=sensor, scan=int(scan), time_s=float(time_s),
        track_id=[str(trk.id) for trk in rows],
        east_m=sv[:, 0].copy(), north_m=sv[:, 2].copy(),
        v_east_mps=sv[:, 1].copy(), v_north_mps=sv[:, 3].copy(),
        sigma_east_m=np.sqrt(np.maximum(cov[:, 0], 0.0)),
        sigma_north_m=np.sqrt(np.maximum(cov[:, 2], 0.0)),
    )


def track(
    source: Any,
    *,
    sensor: str | None = None,
    q_m2_s3: float = 10.0,
    prob_detect: float = 0.8,
    confirm: int = 3,
    delete_after: int = 8,
    prior_speed_sigma_mps: float = 350.0,
    min_false_alarms_per_scan: float = 0.01,
    ospa_c: float = 2000.0,
    ospa_p: float = 1.0,
    max_initiation_clutter_per_km2: float = 0.5,
    pregate_m: float = 3000.0,
    idle_timeout_s: float = 10.0,
    context=None,
    out=None,
    publish_tracks: str | None = None,
    curve=None,
    imm: bool = False,
    imm_turn_rate_rad_s: float = 0.2,
    imm_q_turn_m2_s3: float = 50.0,
    imm_stay: float = 0.9,
) -> dict[str, Any]:
    """Track one sensor of a stream and score it at every end of scan.

    Parameters
    ----------
    source : str, path-like or iterable
        Endpoint (``tcp://...``), recording file, or encoded messages
        (:class:`shipradar.sim.adapters.stonesoup_reader.ShipradarDetectionReader`).
    sensor : str or None
        Radar id; None: the first one in the stream.
    q_m2_s3 : float
        Noise diffusion coefficient of the constant-velocity model, per axis [m²/s³].
    prob_detect : float
        P_d assumed by the PDA hypothesiser [1].
    confirm : int
        Updates needed to confirm a tentative track.
    delete_after : int
        Delete a track after this many scans (tracker steps) without an update.  8: a
        sea-skimmer crosses multipath nulls (the first near 4.7 km for the demo's 25 m antenna
        and 5 m missile at C band, ~1.5 km wide: 5-6 scans at 280 m/s) where nothing can
        detect it; the track coasts across instead of being dropped and re-initiated.
    prior_speed_sigma_mps : float
        Standard deviation of each velocity component of a new track [m/s].
    min_false_alarms_per_scan : float
        Floor of λ in the clutter density (see :func:`clutter_density`).
    ospa_c, ospa_p : float
        OSPA cut-off [m] and order.
    max_initiation_clutter_per_km2 : float
        No track starts from a plot where the learned clutter map holds more plots per scan
        and km² than this.
    pregate_m : float
        Detections farther than this (plus 4 σ of the predicted position) from every track
        are not offered to the associator [m].
    idle_timeout_s : float
        Live source: stop after this long without a message [s].
    curve : shipradar.sim.stream.security.CurveClient or None
        Keys for a CURVE publisher (``--curve-secret-key``, ``--curve-server-key``).
    out : TextIO or None
        Print one JSON line per scan there.
    imm : bool
        Interacting multiple models (:class:`IMMPredictor`, :class:`IMMUpdater`): constant
        velocity (``q_m2_s3``) and coordinated turns at ±``imm_turn_rate_rad_s`` [rad/s]
        (``imm_q_turn_m2_s3`` [m²/s³]), staying in a mode with probability ``imm_stay`` per
        step; False: the constant-velocity EKF alone.
    publish_tracks : str or None
        Publish the confirmed tracks at every end of scan on this ZeroMQ endpoint (topic
        ``tracks``, :func:`tracks_payload`; loopback only). Published with
        ``on_slow="drop"``: a slow display never slows the tracker (losses are counted in
        the returned ``tracks_publisher``).

    Returns
    -------
    dict
        ``scans``: one dict per scan (``time``, ``scan``, ``ospa`` [m], ``tracks`` (confirmed),
        ``truths`` (active targets), ``detections``, ``nearest_m``: per active target the
        distance [m] to the nearest confirmed track, None without tracks); ``tracks``: every
        confirmed Stone Soup track (alive or deleted); ``mean_ospa`` [m]; ``meta``;
        ``tracks_publisher``: the publisher's counters, or None.
    """
    publisher = None
    if publish_tracks is not None:
        from shipradar.sim.stream.bus import Publisher

        publisher = Publisher(publish_tracks, on_slow="drop")
    try:
        res = _track(source, sensor=sensor, q_m2_s3=q_m2_s3, prob_detect=prob_detect,
                     confirm=confirm, delete_after=delete_after,
                     prior_speed_sigma_mps=prior_speed_sigma_mps,
                     min_false_alarms_per_scan=min_false_alarms_per_scan, ospa_c=ospa_c,
                     ospa_p=ospa_p,
                     max_initiation_clutter_per_km2=max_initiation_clutter_per_km2,
                     pregate_m=pregate_m, idle_timeout_s=idle_timeout_s, context=context,
                     out=out, publisher=publisher, curve=curve, imm=imm,
                     imm_turn_rate_rad_s=imm_turn_rate_rad_s,
                     imm_q_turn_m2_s3=imm_q_turn_m2_s3, imm_stay=imm_stay)
    finally:
        if publisher is not None:
            stats = publisher.stats
            publisher.close()
    res["tracks_publisher"] = None if publisher is None else stats
    return res


def _track(source, *, sensor, q_m2_s3, prob_detect, confirm, delete_after,
           prior_speed_sigma_mps, min_false_alarms_per_scan, ospa_c, ospa_p,
           max_initiation_clutter_per_km2, pregate_m, idle_timeout_s, context, out,
           publisher, curve=None, imm=False, imm_turn_rate_rad_s=0.2, imm_q_turn_m2_s3=50.0,
           imm_stay=0.9) -> dict[str, Any]:
    reader = ShipradarDetectionReader(source=source, sensor=sensor, truth=True,
                                      idle_timeout_s=idle_timeout_s, context=context,
                                      curve=curve)
    transition = CombinedLinearGaussianTransitionModel(
        [ConstantVelocity(q_m2_s3), ConstantVelocity(q_m2_s3)])
    predictor = ExtendedKalmanPredictor(transition)
    updater = ExtendedKalmanUpdater(measurement_model=None)  # each detection has its own
    if imm:
        models = imm_models(q_m2_s3, imm_turn_rate_rad_s, imm_q_turn_m2_s3)
        m = len(models)
        pi = np.full((m, m), (1.0 - imm_stay) / (m - 1))
        np.fill_diagonal(pi, imm_stay)
        predictor = IMMPredictor(models, pi, np.full(m, 1.0 / m))
        updater = IMMUpdater(measurement_model=None)
    hypothesiser = _MapPDAHypothesiser(predictor, updater, clutter_spatial_density=1e-9,
                                       prob_detect=prob_detect, prob_gate=0.9999)
    associator = GNNWith2DAssignment(hypothesiser)
    deleter = UpdateTimeStepsDeleter(time_steps_since_update=delete_after)
    v2 = prior_speed_sigma_mps**2
    initiator = MultiMeasurementInitiator(
        prior_state=GaussianState(StateVector([0.0, 0.0, 0.0, 0.0]),
                                  CovarianceMatrix(np.diag([0.0, v2, 0.0, v2]))),
        deleter=UpdateTimeStepsDeleter(time_steps_since_update=2),
        data_associator=GNNWith2DAssignment(hypothesiser),
        updater=updater,
        min_points=confirm,
    )
    ospa = OSPAMetric(c=ospa_c, p=ospa_p, measure=Euclidean(mapping=(0, 2)))
    tracks: set = set()
    all_tracks: set = set()
    scans = []
    cmap = None
    background = 0.0
    for when, detections in reader:
        if cmap is None:
            background = clutter_density(
                reader.meta, min_false_alarms_per_scan=min_false_alarms_per_scan)
            cmap = ClutterMap(float(reader.meta["radar"]["instrumented_range_m"]),
                              prior=radar_clutter_profile(reader.meta))
        dets = sorted(detections, key=lambda d: d.metadata["plot_id"])  # deterministic order
        xy = _cartesian(dets)
        sensor_xy = np.asarray(reader.sensor_position, dtype=float)
        rng_m = np.hypot(*(xy - sensor_xy).T) if dets else np.zeros(0)
        cmap.update(rng_m)

        def density_at(east, north, _s=sensor_xy, _map=cmap, _floor=background):
            r = math.hypot(east - _s[0], north - _s[1])
            return max(_floor, float(_map.density_bearing_range(r)))

        hypothesiser.density_at = density_at
        # coarse pre-gate around the tracks' predicted positions (speed only)
        near = np.zeros(len(dets), dtype=bool)
        for trk in tracks:
            pred = predictor.predict(trk.state, timestamp=when)
            c = np.asarray(pred.covar, dtype=float)
            radius = pregate_m + 4.0 * math.sqrt(max(c[0, 0] + c[2, 2], 0.0))
            p = np.array([pred.state_vector[0, 0], pred.state_vector[2, 0]], dtype=float)
            if dets:
                near |= np.hypot(*(xy - p).T) <= radius
        offered = {d for d, k in zip(dets, near, strict=True) if k}
        hypotheses = associator.associate(tracks, offered, when)
        used = set()
        for trk, hyp in hypotheses.items():
            if hyp:
                trk.append(updater.update(hyp))
                used.add(hyp.measurement)
            else:
                trk.append(hyp.prediction)
        tracks -= deleter.delete_tracks(tracks)
        # clutter-map initiation gate
        quiet = cmap.density_area_km2(rng_m) <= max_initiation_clutter_per_km2 if dets else []
        candidates = {d for d, q in zip(dets, quiet, strict=True) if q} - used
        new = initiator.initiate(candidates, when)
        tracks |= new
        all_tracks |= new
        truth = reader.truth_targets
        if truth is not None and truth["timestamp"] != when:
            truth = None  # a scan whose truth message was not received
        truths = _truth_states(truth)
        estimates = [State(predictor.predict(t.state, timestamp=when).state_vector,
                           timestamp=when) for t in tracks]
        row = {
            "time": when.isoformat(),
            "scan": reader.scan,
            "detections": len(detections),
            "tracks": len(tracks),
            "truths": len(truths),
            "ospa": float(ospa.compute_OSPA_distance(estimates, truths).value)
            if (estimates or truths) else 0.0,
            "nearest_m": [min((float(np.hypot(e.state_vector[0, 0] - s.state_vector[0, 0],
                                               e.state_vector[2, 0] - s.state_vector[2, 0]))
                               for e in estimates), default=None) for s in truths],
        }
        scans.append(row)
        if publisher is not None:
            from shipradar.sim.stream.protocol import encode

            time_s = (when - dt.datetime.fromisoformat(reader.meta["start_time"])
                      ).total_seconds()
            publisher.send(encode(TRACKS.topic, time_s, tracks_payload(
                reader.meta["sensor"], reader.scan, time_s, tracks, predictor, when)))
        if out is not None:
            print(json.dumps(row), file=out, flush=True)
    values = [s["ospa"] for s in scans if s["truths"]]
    return {
        "scans": scans,
        "tracks": all_tracks,
        "mean_ospa": float(np.mean(values)) if values else None,
        "meta": reader.meta,
    }


def main(argv: list[str] | None = None) -> int:
    from shipradar.sim.stream.security import CurveKeyError, add_curve_arguments, curve_from_args

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("source", help="endpoint (tcp://host:port) or recording file")
    ap.add_argument("--sensor", default=None, help="radar id (default: the first)")
    ap.add_argument("--q", type=float, default=10.0, help="CV process noise [m^2/s^3]")
    ap.add_argument("--confirm", type=int, default=3, help="updates to confirm a track")
    ap.add_argument("--delete-after", type=int, default=8, help="scans without update")
    ap.add_argument("--ospa-c", type=float, default=2000.0, help="OSPA cut-off [m]")
    ap.add_argument("--timeout", type=float, default=10.0, help="idle timeout, live [s]")
    ap.add_argument("--quiet", action="store_true", help="only the summary line")
    ap.add_argument("--publish-tracks", default=None, metavar="ENDPOINT",
                    help="publish the confirmed tracks there every scan (topic 'tracks', "
                         "for shipradar view --tracks ENDPOINT)")
    ap.add_argument("--imm", action="store_true",
                    help="IMM: constant velocity + coordinated turns at +-omega")
    ap.add_argument("--imm-turn-rate", type=float, default=0.2, help="omega [rad/s]")
    add_curve_arguments(ap, "client")
    a = ap.parse_args(argv)
    try:
        curve = curve_from_args(a, "client")
    except CurveKeyError as exc:
        ap.error(str(exc))  # exit 2 with the option, the file and what is wrong
    res = track(a.source, sensor=a.sensor, q_m2_s3=a.q, confirm=a.confirm,
                delete_after=a.delete_after, ospa_c=a.ospa_c, idle_timeout_s=a.timeout,
                out=None if a.quiet else sys.stdout, publish_tracks=a.publish_tracks,
                curve=curve, imm=a.imm, imm_turn_rate_rad_s=a.imm_turn_rate)
    print(json.dumps({"scans": len(res["scans"]), "confirmed_tracks": len(res["tracks"]),
                      "mean_ospa_m": res["mean_ospa"]}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
