"""A Stone Soup tracker on a shipradar stream, scored by OSPA against the truth topic.

Run it beside a simulation (start the tracker first; the run waits for it)::

    shipradar run scenarios/single_missile.yaml --publish tcp://127.0.0.1:5555 --wait 1 &
    python examples/track_stonesoup.py tcp://127.0.0.1:5555

or on a recording::

    python examples/track_stonesoup.py run.shr

The tracker: extended Kalman filter (:class:`ExtendedKalmanPredictor`/``Updater``) on a
nearly-constant-velocity model in the scenario's local east/north frame; detections with
their own bearing-range models (:mod:`sim.stonesoup_reader`); PDA hypotheses scored with the
clutter density of the radar's noise false alarms and associated by global nearest neighbour
(:class:`GNNWith2DAssignment`); tracks confirmed by a :class:`MultiMeasurementInitiator`
(``confirm`` updates) and deleted after ``delete_after`` scans without an update.

Clutter density: the stream's meta gives the expected noise false alarms per scan λ
(``noise_false_alarms_per_scan``) over the disc of the instrumented range R; spread uniformly
in the bearing-range measurement space that is λ / (2π R) [1/(rad m)]. Sea-clutter false
alarms are not in that figure; a floor of ``min_false_alarms_per_scan`` keeps the density
non-zero for a radar with a very long false-alarm time.

OSPA (Stone Soup's :class:`OSPAMetric`, position only, cut-off ``ospa_c``, order ``ospa_p``) is
computed at every end of scan between the confirmed tracks, predicted to the end-of-scan
time, and the truth topic's active targets at that time.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

try:  # run as a script from the repository, without installing it
    import sim  # noqa: F401
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
)
from stonesoup.predictor.kalman import ExtendedKalmanPredictor
from stonesoup.types.array import CovarianceMatrix, StateVector
from stonesoup.types.state import GaussianState, State
from stonesoup.updater.kalman import ExtendedKalmanUpdater

from sim.stonesoup_reader import ShipradarDetectionReader

__all__ = ["clutter_density", "track", "main"]


def clutter_density(meta: dict, *, min_false_alarms_per_scan: float = 0.01) -> float:
    """Clutter density in bearing-range space [1/(rad m)] from the stream's meta.

    λ / (2π R): λ the expected noise false alarms per scan (at least the floor), R the
    instrumented range [m].
    """
    lam = max(float(meta.get("noise_false_alarms_per_scan", 0.0)), min_false_alarms_per_scan)
    r_max = float(meta["radar"]["instrumented_range_m"])
    return lam / (2.0 * math.pi * r_max)


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


def track(
    source: Any,
    *,
    sensor: str | None = None,
    q_m2_s3: float = 10.0,
    prob_detect: float = 0.8,
    confirm: int = 3,
    delete_after: int = 4,
    prior_speed_sigma_mps: float = 350.0,
    min_false_alarms_per_scan: float = 0.01,
    ospa_c: float = 2000.0,
    ospa_p: float = 1.0,
    idle_timeout_s: float = 10.0,
    context=None,
    out=None,
) -> dict[str, Any]:
    """Track one sensor of a stream and score it at every end of scan.

    Parameters
    ----------
    source : str, path-like or iterable
        Endpoint (``tcp://...``), recording file, or encoded messages
        (:class:`sim.stonesoup_reader.ShipradarDetectionReader`).
    sensor : str or None
        Radar id; None: the first one in the stream.
    q_m2_s3 : float
        Noise diffusion coefficient of the constant-velocity model, per axis [m²/s³].
    prob_detect : float
        P_d assumed by the PDA hypothesiser [1].
    confirm : int
        Updates needed to confirm a tentative track.
    delete_after : int
        Delete a track after this many scans (tracker steps) without an update.
    prior_speed_sigma_mps : float
        Standard deviation of each velocity component of a new track [m/s].
    min_false_alarms_per_scan : float
        Floor of λ in the clutter density (see :func:`clutter_density`).
    ospa_c, ospa_p : float
        OSPA cut-off [m] and order.
    idle_timeout_s : float
        Live source: stop after this long without a message [s].
    out : TextIO or None
        Print one JSON line per scan there.

    Returns
    -------
    dict
        ``scans``: one dict per scan (``time``, ``scan``, ``ospa`` [m], ``tracks`` (confirmed),
        ``truths`` (active targets), ``detections``, ``nearest_m``: per active target the
        distance [m] to the nearest confirmed track, None without tracks); ``tracks``: every
        confirmed Stone Soup track (alive or deleted); ``mean_ospa`` [m]; ``meta``.
    """
    reader = ShipradarDetectionReader(source=source, sensor=sensor, truth=True,
                                      idle_timeout_s=idle_timeout_s, context=context)
    transition = CombinedLinearGaussianTransitionModel(
        [ConstantVelocity(q_m2_s3), ConstantVelocity(q_m2_s3)])
    predictor = ExtendedKalmanPredictor(transition)
    updater = ExtendedKalmanUpdater(measurement_model=None)  # each detection has its own
    hypothesiser = PDAHypothesiser(predictor, updater, clutter_spatial_density=1e-9,
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
    configured = False
    for when, detections in reader:
        if not configured:
            hypothesiser.clutter_spatial_density = clutter_density(
                reader.meta, min_false_alarms_per_scan=min_false_alarms_per_scan)
            configured = True
        hypotheses = associator.associate(tracks, detections, when)
        used = set()
        for trk, hyp in hypotheses.items():
            if hyp:
                trk.append(updater.update(hyp))
                used.add(hyp.measurement)
            else:
                trk.append(hyp.prediction)
        tracks -= deleter.delete_tracks(tracks)
        new = initiator.initiate(detections - used, when)
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
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("source", help="endpoint (tcp://host:port) or recording file")
    ap.add_argument("--sensor", default=None, help="radar id (default: the first)")
    ap.add_argument("--q", type=float, default=10.0, help="CV process noise [m^2/s^3]")
    ap.add_argument("--confirm", type=int, default=3, help="updates to confirm a track")
    ap.add_argument("--delete-after", type=int, default=4, help="scans without update")
    ap.add_argument("--ospa-c", type=float, default=2000.0, help="OSPA cut-off [m]")
    ap.add_argument("--timeout", type=float, default=10.0, help="idle timeout, live [s]")
    ap.add_argument("--quiet", action="store_true", help="only the summary line")
    a = ap.parse_args(argv)
    res = track(a.source, sensor=a.sensor, q_m2_s3=a.q, confirm=a.confirm,
                delete_after=a.delete_after, ospa_c=a.ospa_c, idle_timeout_s=a.timeout,
                out=None if a.quiet else sys.stdout)
    print(json.dumps({"scans": len(res["scans"]), "confirmed_tracks": len(res["tracks"]),
                      "mean_ospa_m": res["mean_ospa"]}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
