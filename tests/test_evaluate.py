"""``shipradar evaluate`` (issue 26): metrics against closed forms and Stone Soup called
directly, the harness with trackers of known behaviour, failures, Dask clusters.

The metric tests build a run's data by hand (no simulation); the harness tests run the demo
scene for a few seconds with the trackers of ``tests/evaluate_trackers.py`` (ids ``T<j>``,
the truth the harness counts). Socket tests bind 127.0.0.1 on free ports and stop every
process they start.
"""

from __future__ import annotations

import datetime as dt
import json
import math
import os
import shlex
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from shipradar.sim.stream.protocol import encode
from shipradar.sim.studies.evaluate.data import (
    MalformedTracks,
    RunData,
    TracksMessage,
    check_tracks,
)
from shipradar.sim.studies.evaluate.metrics import (
    MetricConfig,
    counted_targets,
    detectable,
    score_run,
)

ROOT = Path(__file__).resolve().parents[1]
DEMO = str(ROOT / "scenarios" / "single_missile.yaml")
TRACKERS = ROOT / "tests" / "evaluate_trackers.py"
PY = shlex.quote(sys.executable)
#: The harness tests run the demo for a few seconds, before any radar can detect the missile
#: (about 21 km): they score by the geometric rule, and their oracle publishes by it.
COVERAGE = MetricConfig(truth="coverage")
#: Timestamps handed to Stone Soup: simulated t [s] after this (any fixed epoch would do).
EPOCH = dt.datetime(2000, 1, 1)


# ------------------------------------------------------------------------ synthetic runs
def _run(n_scans=10, n_targets=2, period=1.0):
    """Targets flying east at 200 m/s, 10 km north of a radar at the origin (in coverage)."""
    t = period * np.arange(1, n_scans + 1)
    pos = np.zeros((n_scans, n_targets, 3))
    vel = np.zeros((n_scans, n_targets, 3))
    for j in range(n_targets):
        pos[:, j, 0] = 200.0 * t + 5000.0 * j
        pos[:, j, 1] = 10_000.0
        pos[:, j, 2] = 10.0
        vel[:, j, 0] = 200.0
    radar = {"instrumented_range_m": 60_000.0, "scan_period_s": period,
             "eos_t": t, "eos_pos": np.tile([0.0, 0.0, 20.0], (n_scans, 1))}
    return RunData(info={"seed": 1, "status": "ok", "duration_s": float(t[-1])},
                   target_ids=[f"tgt{j}" for j in range(n_targets)], ref_sensor="r",
                   scan_t=t, truth_pos=pos, truth_vel=vel,
                   truth_active=np.ones((n_scans, n_targets), bool), radars={"r": radar},
                   inputs={})


def _tracks_from_truth(data, shift_m=0.0, ids=None):
    out = []
    for i, t in enumerate(data.scan_t):
        names = ids(i) if ids else [f"T{j}" for j in range(len(data.target_ids))]
        p, v = data.truth_pos[i], data.truth_vel[i]
        out.append(TracksMessage(float(t), "r", i, tuple(names), p[:, 0] + shift_m,
                                 p[:, 1].copy(), v[:, 0].copy(), v[:, 1].copy()))
    return out


def test_oracle_scores_zero():
    data = _run()
    data.tracks = _tracks_from_truth(data)
    s = score_run(data)
    assert s.run["gospa"] == 0.0
    assert s.run["siap_completeness"] == 1.0
    assert s.run["siap_spuriousness"] == 0.0
    assert s.run["false_tracks"] == 0 and s.run["identity_swaps"] == 0
    assert all(r["held_fraction"] == 1.0 for r in s.per_target)


@pytest.mark.parametrize(("c", "p"), [(2000.0, 1.0), (500.0, 2.0)])
def test_silent_tracker_scores_only_missed_closed_form(c, p):
    data = _run(n_targets=3)
    s = score_run(data, MetricConfig(c_m=c, p=p))
    for row in s.per_scan:
        # GOSPA (alpha = 2): each missed target costs c^p / 2; the distance is the p-th root
        assert row["missed"] == pytest.approx(3 * c**p / 2, rel=1e-12)
        assert row["localisation"] == 0.0 and row["false"] == 0.0
        assert row["gospa"] == pytest.approx((3 * c**p / 2) ** (1 / p), rel=1e-12)
    assert s.run["siap_completeness"] == 0.0


def test_shifted_truth_scores_localisation_d():
    d = 37.5
    data = _run(n_targets=1)
    data.tracks = _tracks_from_truth(data, shift_m=d)
    s = score_run(data)  # p = 1: the localisation part is the distance itself [m]
    assert s.run["localisation"] == pytest.approx(d, rel=1e-12)
    assert s.run["missed"] == 0.0 and s.run["false"] == 0.0
    assert s.run["siap_position_accuracy_m"] == pytest.approx(d, rel=1e-12)
    assert s.per_target[0]["mean_error_m"] == pytest.approx(d, rel=1e-12)


def test_two_identities_swapped_count_one_swap():
    data = _run(n_targets=2)
    data.tracks = _tracks_from_truth(
        data, ids=lambda i: ["A", "B"] if i < 5 else ["B", "A"])
    s = score_run(data)
    assert s.run["identity_swaps"] == 1
    assert [r["identity_swaps"] for r in s.per_target] == [1, 1]
    assert s.run["gospa"] == 0.0  # positions are right: only the identities changed


def test_breaks_first_track_and_false_tracks():
    data = _run(n_targets=1, n_scans=12)
    tracks = _tracks_from_truth(data)
    held = [i for i in range(12) if i >= 2 and i not in (6, 7)]
    data.tracks = [tracks[i] for i in held]
    # plus a false track far away for the whole run, listed first
    data.tracks = [TracksMessage(m.time_s, "r", m.scan, ("F", *m.track_id),
                                 np.insert(m.east_m, 0, -40_000.0),
                                 np.insert(m.north_m, 0, 0.0),
                                 np.insert(m.v_east_mps, 0, 0.0),
                                 np.insert(m.v_north_mps, 0, 0.0))
                   for m in data.tracks]
    s = score_run(data, MetricConfig(max_track_age_s=0.5))
    row = s.per_target[0]
    assert row["first_track_s"] == 3.0 and row["first_track_delay_s"] == 2.0
    assert row["first_track_range_m"] == pytest.approx(math.hypot(600.0, 10_000.0), rel=1e-9)
    assert row["track_breaks"] == 1 and row["scans_held"] == 8
    assert s.run["false_tracks"] == 1
    assert s.run["false_tracks_per_hour"] == pytest.approx(3600.0 / 12.0, rel=1e-12)


def test_gospa_and_siap_equal_stonesoup_called_directly():
    """The same sets handed to Stone Soup's classes by hand give the harness's values."""
    from stonesoup.dataassociator.tracktotrack import TrackToTruth
    from stonesoup.measures import Euclidean
    from stonesoup.metricgenerator.manager import MultiManager
    from stonesoup.metricgenerator.ospametric import GOSPAMetric
    from stonesoup.metricgenerator.tracktotruthmetrics import SIAPMetrics
    from stonesoup.types.groundtruth import GroundTruthPath, GroundTruthState
    from stonesoup.types.state import State
    from stonesoup.types.track import Track

    rng = np.random.default_rng(3)
    data = _run(n_targets=3, n_scans=8)
    data.tracks = _tracks_from_truth(data)
    for m in data.tracks:  # noisy, with an extra track from scan 3
        m.east_m[:] += rng.normal(0, 80, m.east_m.size)
        m.north_m[:] += rng.normal(0, 80, m.north_m.size)
    data.tracks = [m if m.scan < 3 else TracksMessage(
        m.time_s, "r", m.scan, (*m.track_id, "X"), np.append(m.east_m, 3e4),
        np.append(m.north_m, 0.0), np.append(m.v_east_mps, 0.0),
        np.append(m.v_north_mps, 0.0)) for m in data.tracks]
    config = MetricConfig(c_m=1500.0, p=2.0, siap_threshold_m=400.0)
    s = score_run(data, config)

    def when(t):
        return EPOCH + dt.timedelta(seconds=float(t))

    tracks, truths = {}, {}
    for m in data.tracks:
        for k, tid in enumerate(m.track_id):
            tracks.setdefault(tid, []).append(State(
                [m.east_m[k], m.v_east_mps[k], m.north_m[k], m.v_north_mps[k]],
                timestamp=when(m.time_s)))
    for i, t in enumerate(data.scan_t):
        for j in range(3):
            p, v = data.truth_pos[i, j], data.truth_vel[i, j]
            truths.setdefault(j, []).append(GroundTruthState([p[0], v[0], p[1], v[1]],
                                                             timestamp=when(t)))
    gospa = GOSPAMetric(c=1500.0, p=2.0, measure=Euclidean(mapping=(0, 2)))
    for i, t in enumerate(data.scan_t):
        meas = [st for v in tracks.values() for st in v if st.timestamp == when(t)]
        tru = [v[i] for v in truths.values()]
        ref, _ = gospa.compute_gospa_metric(meas, tru)
        row = s.per_scan[i]
        for key, name in (("gospa", "distance"), ("localisation", "localisation"),
                          ("missed", "missed"), ("false", "false")):
            assert row[key] == pytest.approx(float(ref.value[name]), rel=1e-12, abs=1e-9)
    manager = MultiManager(
        [SIAPMetrics(position_measure=Euclidean(mapping=(0, 2)),
                     velocity_measure=Euclidean(mapping=(1, 3)), generator_name="s",
                     tracks_key="tracks", truths_key="truths")],
        associator=TrackToTruth(association_threshold=400.0, consec_pairs_confirm=2,
                                consec_misses_end=1, measure=Euclidean(mapping=(0, 2))))
    manager.add_data({"tracks": {Track(v, id=k) for k, v in tracks.items()},
                      "truths": {GroundTruthPath(v, id=str(k)) for k, v in truths.items()}})
    ref = manager.generate_metrics()["s"]
    for key, name in (("completeness", "SIAP Completeness"), ("ambiguity", "SIAP Ambiguity"),
                      ("spuriousness", "SIAP Spuriousness"),
                      ("position_accuracy_m", "SIAP Position Accuracy"),
                      ("velocity_accuracy_mps", "SIAP Velocity Accuracy"),
                      ("track_number_change_rate", "SIAP Rate of Track Number Change"),
                      ("longest_segment", "SIAP Longest Track Segment")):
        assert s.run[f"siap_{key}"] == pytest.approx(float(ref[name].value), rel=1e-12)
    assert 0 < s.run["siap_spuriousness"] < 1


def test_longest_segment_is_the_longest_unbroken_stretch():
    """A track held 7-67 s, lost for the scan at 68 s (5 km off), held again 69-100 s: its
    longest unbroken association is 60 s (Stone Soup's SIAP adds the two pieces of the same
    track-truth pair: 91 s); the other SIAP figures equal Stone Soup's on the same sets."""
    data = _run(n_targets=1, n_scans=100)  # scans at 1..100 s
    tracks = _tracks_from_truth(data)
    data.tracks = [m for m in tracks if m.time_s >= 7.0]
    for m in data.tracks:
        if m.time_s == 68.0:
            m.north_m[:] += 5000.0
    s = score_run(data, MetricConfig(max_track_age_s=0.5))
    life = 100.0 - 1.0  # counted from the first scan
    assert s.run["siap_longest_segment"] == pytest.approx(60.0 / life, rel=1e-12)
    assert s.run["siap_completeness"] == pytest.approx((61 + 32) / 100, rel=1e-12)
    assert s.run["siap_track_number_change_rate"] == pytest.approx(1 / (60.0 + 31.0),
                                                                  rel=1e-12)
    ref = _stonesoup_siap(data, threshold=2000.0)
    assert ref["SIAP Longest Track Segment"] == pytest.approx(91.0 / life, rel=1e-12)
    for key, name in (("completeness", "SIAP Completeness"),
                      ("spuriousness", "SIAP Spuriousness"),
                      ("position_accuracy_m", "SIAP Position Accuracy"),
                      ("track_number_change_rate", "SIAP Rate of Track Number Change")):
        assert s.run[f"siap_{key}"] == pytest.approx(ref[name], rel=1e-12, abs=1e-12)


def _stonesoup_siap(data, threshold):
    """Stone Soup's SIAP values (by name) on the run's tracks and truths, both sampled at the
    scans, a track absent at a scan split there (as the harness scores)."""
    from stonesoup.dataassociator.tracktotrack import TrackToTruth
    from stonesoup.measures import Euclidean
    from stonesoup.metricgenerator.manager import MultiManager
    from stonesoup.metricgenerator.tracktotruthmetrics import SIAPMetrics
    from stonesoup.types.groundtruth import GroundTruthPath, GroundTruthState
    from stonesoup.types.state import State
    from stonesoup.types.track import Track

    def when(t):
        return EPOCH + dt.timedelta(seconds=float(t))

    period = data.radars["r"]["scan_period_s"]
    pieces: dict[str, list] = {}
    last: dict[str, float] = {}
    count: dict[str, int] = {}
    for m in data.tracks:
        for k, tid in enumerate(m.track_id):
            if tid not in last or m.time_s - last[tid] > 1.01 * period:
                count[tid] = count.get(tid, -1) + 1
            last[tid] = m.time_s
            pieces.setdefault(f"{tid}#{count[tid]}", []).append(State(
                [m.east_m[k], m.v_east_mps[k], m.north_m[k], m.v_north_mps[k]],
                timestamp=when(m.time_s)))
    truths = {GroundTruthPath([GroundTruthState(
        [data.truth_pos[i, j, 0], data.truth_vel[i, j, 0], data.truth_pos[i, j, 1],
         data.truth_vel[i, j, 1]], timestamp=when(t)) for i, t in enumerate(data.scan_t)],
        id=str(j)) for j in range(len(data.target_ids))}
    manager = MultiManager(
        [SIAPMetrics(position_measure=Euclidean(mapping=(0, 2)),
                     velocity_measure=Euclidean(mapping=(1, 3)), generator_name="s",
                     tracks_key="tracks", truths_key="truths")],
        associator=TrackToTruth(association_threshold=threshold, consec_pairs_confirm=2,
                                consec_misses_end=1, measure=Euclidean(mapping=(0, 2))))
    manager.add_data({"tracks": {Track(v, id=k) for k, v in pieces.items()},
                      "truths": truths})
    return {k: float(v.value) for k, v in manager.generate_metrics()["s"].items()
            if not k.endswith("at times")}


def _crossing(period=1.0, lag_m=0.0, heights=False):
    """Two targets passing head-on at 200 m/s, 200 m apart horizontally at closest approach
    (t = 50 s) and 500 m apart in height (1000 m, 1500 m); the tracker's ids never change,
    its tracks lag ``lag_m`` behind along the velocity, with heights when ``heights``."""
    t = period * np.arange(1, int(100 / period) + 1)
    pos = np.zeros((t.size, 2, 3))
    vel = np.zeros((t.size, 2, 3))
    pos[:, 0] = np.stack([200.0 * t - 10_000.0, np.full(t.size, 100.0),
                          np.full(t.size, 1000.0)], axis=-1)
    pos[:, 1] = np.stack([10_000.0 - 200.0 * t, np.full(t.size, -100.0),
                          np.full(t.size, 1500.0)], axis=-1)
    vel[:, 0, 0], vel[:, 1, 0] = 200.0, -200.0
    radar = {"instrumented_range_m": 60_000.0, "scan_period_s": period, "eos_t": t,
             "eos_pos": np.tile([0.0, -30_000.0, 20.0], (t.size, 1))}
    data = RunData(info={"seed": 1, "status": "ok", "duration_s": float(t[-1])},
                   target_ids=["a", "b"], ref_sensor="r", scan_t=t, truth_pos=pos,
                   truth_vel=vel, truth_active=np.ones((t.size, 2), bool),
                   radars={"r": radar}, inputs={})
    data.tracks = [TracksMessage(float(ti), "r", i, ("A", "B"),
                                 pos[i, :, 0] - lag_m * np.sign(vel[i, :, 0]),
                                 pos[i, :, 1].copy(), vel[i, :, 0].copy(), vel[i, :, 1].copy(),
                                 up_m=pos[i, :, 2].copy() if heights else None)
                   for i, ti in enumerate(t)]
    return data


def test_clean_crossing_gives_no_swap_and_no_track_number_change():
    """A perfect tracker (right positions and heights) through a crossing 200 m apart
    horizontally and 500 m in height: no identity swap, no track-number change."""
    s = score_run(_crossing(heights=True))
    assert s.run["identity_swaps"] == 0 and s.run["siap_track_number_change_rate"] == 0.0
    assert [r["track_ids"] for r in s.per_target] == [1, 1]
    assert s.run["gospa"] == 0.0


def test_crossing_with_lagging_tracks_one_scan_flip_is_no_swap():
    """Tracks lagging 300 m (the template tracker's accuracy) through the same crossing,
    horizontal only: for the scan at 51 s the crossed pairing is nearer (2 x 224 m against
    2 x 300 m), so a per-scan assignment swaps twice and SIAP's nearest-truth association
    moves both tracks; the kept assignment (3 scans) and heights (538 m crossed against
    300 m) see none."""
    lagging = _crossing(lag_m=300.0)
    per_scan = score_run(lagging, MetricConfig(switch_scans=1))
    assert per_scan.run["identity_swaps"] == 2
    assert per_scan.run["siap_track_number_change_rate"] > 0
    kept = score_run(lagging)
    assert kept.run["identity_swaps"] == 0
    assert kept.run["siap_track_number_change_rate"] == 0.0
    assert [r["track_ids"] for r in kept.per_target] == [1, 1]
    with_heights = score_run(_crossing(lag_m=300.0, heights=True), MetricConfig(switch_scans=1))
    assert with_heights.run["identity_swaps"] == 0
    assert with_heights.run["siap_track_number_change_rate"] == 0.0
    # GOSPA is a per-scan distance: the same with or without the kept identities
    assert kept.run["gospa"] == per_scan.run["gospa"]


def test_a_real_exchange_within_c_is_one_swap_after_switch_scans():
    """Two tracks exchange ids at scan 5 while their targets are 500 m apart (within c): the
    kept assignment follows after 3 scans, one swap; a one-scan exchange is none."""
    data = _run(n_targets=2, n_scans=12)
    data.truth_pos[:, 1, 0] -= 4500.0  # 500 m apart
    data.tracks = _tracks_from_truth(data, ids=lambda i: ["A", "B"] if i < 5 else ["B", "A"])
    s = score_run(data)
    assert s.run["identity_swaps"] == 1
    held = [h["track_id"] for h in s.holding if h["target"] == "tgt0"]
    assert held == ["A"] * 7 + ["B"] * 5  # moved at the third scan of the exchange
    data.tracks = _tracks_from_truth(data, ids=lambda i: ["B", "A"] if i == 5 else ["A", "B"])
    assert score_run(data).run["identity_swaps"] == 0


def test_counted_by_pd_reads_the_looks():
    """``truth = "pd"``: a target counts while some radar's look within the window reached
    the threshold, whatever in_coverage says."""
    data = _run(n_scans=6, n_targets=3)
    t = data.scan_t  # 1..6 s, period 1 s: window 3 s
    cover = np.zeros((6, 3), bool)  # no target in geometric coverage
    look_t = np.tile([1.0, 1.0, np.nan], (6, 1))
    look_t[:, 0] = t - 0.5  # target 0 looked at every scan
    pd = np.tile([0.9, 0.9, np.nan], (6, 1))
    pd[3:, 0] = 0.2  # ...with a P_d below the threshold from the 4th scan
    _with_coverage(data, {"r": (t, cover)})
    data.looks = {"r": (t, look_t, pd)}
    assert not counted_targets(data, 0, COVERAGE).any()  # the geometric rule
    got = [counted_targets(data, i).tolist() for i in range(6)]  # the default: "pd"
    # target 0: its good looks (0.5..2.5 s) stay in the 3 s window until the 6th scan;
    # target 1: one look at 1 s with P_d 0.9, counted until the window passes it (t >= 4)
    assert got == [[True, True, False], [True, True, False], [True, True, False],
                   [True, False, False], [True, False, False], [False, False, False]]
    got = [counted_targets(data, i, MetricConfig(truth="pd", pd_threshold=0.95,
                                                 pd_window_s=10.0)).any() for i in range(6)]
    assert not any(got)


def test_metric_config_refuses_bad_values():
    for kw in ({"switch_scans": 0}, {"truth": "radar"}, {"pd_threshold": 0.0},
               {"pd_window_s": -1.0}, {"siap_threshold_m": 0.0}):
        with pytest.raises(ValueError, match=next(iter(kw))):
            MetricConfig(**kw)


def test_intervals_stay_within_the_bounds():
    """Student-t by hand (t_{0.975, 3} = 3.1824, tables) where nothing binds; clipped at a
    proportion's 1 and a count's 0 (the issue's completeness 1.03 and -241 false tracks per
    hour over 2 runs); a paired difference of proportions within [-1, 1]."""
    from shipradar.sim.studies.evaluate import stats

    m, lo, hi, n = stats.mean_interval([1.0, 2.0, 3.0, 4.0])
    half = 3.182446 * math.sqrt(5.0 / 3.0) / 2.0
    assert (m, n) == (2.5, 4)
    assert lo == pytest.approx(2.5 - half, rel=1e-6) and hi == pytest.approx(2.5 + half,
                                                                            rel=1e-6)
    rows = [{"siap_completeness": 1.0, "false_tracks_per_hour": 0.0, "gospa": 10.0},
            {"siap_completeness": 0.94, "false_tracks_per_hour": 120.0, "gospa": 12.0}]
    got = {r["metric"]: r for r in stats.summarise(rows)}
    c, f = got["siap_completeness"], got["false_tracks_per_hour"]
    assert c["mean"] == pytest.approx(0.97, rel=1e-12) and c["high"] == 1.0 and c["low"] < 0.97
    assert f["mean"] == 60.0 and f["low"] == 0.0 and f["high"] > 60.0
    assert got["gospa"]["low"] == 0.0  # 11 +- 12.7: a distance is not negative
    d = stats.paired_differences(
        [{"seed": s, "siap_completeness": 0.0} for s in range(3)],
        [{"seed": 0, "siap_completeness": 1.0}, {"seed": 1, "siap_completeness": 0.0},
         {"seed": 2, "siap_completeness": 1.0}], ["siap_completeness"])[0]
    assert -1.0 <= d["low"] <= d["high"] == 1.0


def test_detectable_horizon_and_range():
    ant = [(np.array([0.0, 0.0, 25.0]), 60_000.0)]
    a_e = 4.0 / 3.0 * 6_371_008.8
    horizon = math.sqrt(2 * a_e * 25.0) + math.sqrt(2 * a_e * 5.0)
    pos = np.array([[horizon - 10.0, 0, 5.0], [horizon + 10.0, 0, 5.0],
                    [59_000.0, 0, 10_000.0], [0, 61_000.0, 10_000.0], [1000.0, 0, 5.0],
                    [59_500.0, 0, 10_000.0]])
    got = detectable(pos, np.array([True, True, True, True, False, True]), ant)
    # the last is 60.3 km away in slant but 59.5 km on the ground: the engine looks at it
    # (its test before a look is the ground range), so it counts
    assert got.tolist() == [True, False, True, False, False, True]


def _with_coverage(data, cover_by_sensor):
    """``data`` with per-sensor ``in_coverage`` copies: {sensor: (times, (M, k) bool)}."""
    for s, (t, c) in cover_by_sensor.items():
        data.radars.setdefault(s, dict(data.radars["r"]))
        data.coverage[s] = (np.asarray(t, float), np.asarray(c, bool))
    return data


def test_counted_targets_reads_the_streams_in_coverage():
    """The stream's in_coverage decides, not geometry: a target the geometry puts in coverage
    is left out when no radar reported it covered; another radar's latest copy at or before
    the scan counts; a copy after the scan does not; inactive targets never count."""
    data = _run(n_scans=3, n_targets=3)  # all three in coverage by geometry
    t = data.scan_t
    data.truth_active[2, 2] = False
    ref = np.array([[True, False, False], [True, False, False], [True, False, True]])
    other_t = [0.5, 1.5, 2.5]  # between the reference scans
    other = np.array([[False, True, False], [False, False, False], [False, False, True]])
    _with_coverage(data, {"r": (t, ref), "b": (other_t, other)})
    got = [counted_targets(data, i).tolist() for i in range(3)]
    assert got == [[True, True, False],    # b's copy at 0.5 covers target 1
                   [True, False, False],   # b's copy at 1.5 no longer does
                   [True, False, False]]   # target 2 covered by both, but inactive


def test_counted_targets_falls_back_to_geometry_without_in_coverage():
    """A version-1 stream (no in_coverage) is scored by detectable at the antennas."""
    data = _run(n_scans=2, n_targets=2)
    data.truth_pos[1, 1, 0] = 80_000.0  # beyond the 60 km instrumented range
    got = [counted_targets(data, i).tolist() for i in range(2)]
    assert got == [[True, True], [True, False]]


@pytest.mark.parametrize(("payload", "reason"), [
    ({"sensor": "r", "scan": 0, "time_s": 1.0}, "missing key"),
    ({"sensor": "r", "scan": 0, "time_s": 1.0, "track_id": ["a"], "east_m": np.zeros(2),
      "north_m": np.zeros(1), "v_east_mps": np.zeros(1), "v_north_mps": np.zeros(1)},
     "length mismatch"),
    ({"sensor": "r", "scan": 0, "time_s": 1.0, "track_id": ["a"], "east_m": [math.nan],
      "north_m": [0.0], "v_east_mps": [0.0], "v_north_mps": [0.0]}, "non-finite"),
    ({"sensor": "r", "scan": 0, "time_s": 1.0, "track_id": ["a", "a"], "east_m": [0.0, 1.0],
      "north_m": [0.0, 1.0], "v_east_mps": [0.0, 1.0], "v_north_mps": [0.0, 1.0]},
     "duplicate track_id"),
    ({"sensor": "r", "scan": 0, "time_s": 1.0, "track_id": [1], "east_m": [0.0],
      "north_m": [0.0], "v_east_mps": [0.0], "v_north_mps": [0.0]}, "bad track_id"),
    ({"sensor": "r", "scan": 0, "time_s": 1.0, "track_id": ["a"], "east_m": [0.0],
      "north_m": [0.0], "v_east_mps": [0.0], "v_north_mps": [0.0], "up_m": [1.0, 2.0]},
     "length mismatch"),
])
def test_malformed_tracks_named(payload, reason):
    with pytest.raises(MalformedTracks) as info:
        check_tracks(encode(b"tracks", 1.0, payload))
    assert info.value.reason == reason
    with pytest.raises(MalformedTracks) as info:
        check_tracks([b"tracks", b"\xc1"])
    assert info.value.reason == "undecodable"


# ------------------------------------------------------------------- harness, processes
def _spec(tmp_path, mode, *extra, seed=7, duration=6.0, **kw):
    from shipradar.sim.studies.evaluate.runner import RunSpec

    cmd = f"{PY} {shlex.quote(str(TRACKERS))} {mode} {{plots}} {{tracks}} " + " ".join(extra)
    if mode in ("oracle", "crash", "malformed"):
        cmd += " --truth coverage"
    return RunSpec(DEMO, seed, str(tmp_path / f"{mode}-{seed}"), cmd, duration_s=duration,
                   **kw)


def _run_and_score(spec):
    from shipradar.sim.studies.evaluate.data import load_run
    from shipradar.sim.studies.evaluate.runner import run_tracker_command

    info = run_tracker_command(spec)
    return info, (score_run(load_run(spec.run_dir), COVERAGE) if info["status"] == "ok"
                  else None)


def test_harness_oracle_and_shift(tmp_path):
    info, s = _run_and_score(_spec(tmp_path, "oracle"))
    assert info["status"] == "ok", info
    assert info["stopped_by_harness"]
    assert s.run["scans"] == 6 and s.run["tracks_messages"] == 6
    assert s.run["gospa"] == 0.0 and s.run["siap_completeness"] == 1.0
    assert s.run["siap_spuriousness"] == 0.0
    assert 0 < s.run["latency_median_s"] <= s.run["latency_p95_s"] < 5
    _, s2 = _run_and_score(_spec(tmp_path, "oracle", "--shift-m", "25", seed=8))
    assert s2.run["localisation"] == pytest.approx(25.0, rel=1e-9)


@pytest.mark.slow
def test_harness_silent_scores_missed_only(tmp_path):
    info, s = _run_and_score(_spec(tmp_path, "silent"))
    assert info["status"] == "ok" and s.run["tracks_messages"] == 0
    assert s.run["missed"] == pytest.approx(2000.0 / 2, rel=1e-12)  # one missile, c/2
    assert s.run["localisation"] == 0.0 and s.run["false"] == 0.0


def test_harness_collects_what_load_run_reads_back(tmp_path):
    """The data collected while a run goes (what a study scores) equals the run directory
    read back (what --rescore scores): the same truth, coverage, looks, inputs with their
    wall times, tracks, and so the same scores, latency included."""
    from shipradar.sim.studies.evaluate.data import load_run
    from shipradar.sim.studies.evaluate.runner import run_and_collect

    spec = _spec(tmp_path, "oracle", "--shift-m", "10", seed=9)
    info, live = run_and_collect(spec)
    assert info["status"] == "ok", info
    back = load_run(spec.run_dir)
    for name in ("scan_t", "truth_pos", "truth_vel", "truth_active"):
        np.testing.assert_array_equal(getattr(live, name), getattr(back, name))
    assert live.target_ids == back.target_ids and live.ref_sensor == back.ref_sensor
    for mine, theirs in ((live.inputs, back.inputs), (live.coverage, back.coverage),
                         (live.looks, back.looks)):
        assert mine.keys() == theirs.keys()
        for k in mine:
            for a, b in zip(mine[k], theirs[k], strict=True):
                np.testing.assert_array_equal(a, b)
    assert len(live.tracks) == len(back.tracks) > 0
    a, b = score_run(live, COVERAGE), score_run(back, COVERAGE)
    assert a.per_scan == b.per_scan and a.per_target == b.per_target
    assert a.run == b.run


def test_harness_crashing_tracker_fails_its_run(tmp_path):
    info, _ = _run_and_score(_spec(tmp_path, "crash", "--after", "2", duration=30.0))
    assert info["status"] == "failed" and info["exit_code"] == 3
    assert "exited with code 3" in info["error"]
    assert "crashing on purpose" in info["stderr_tail"]
    assert not info["stopped_by_harness"]


def test_harness_tracker_that_never_subscribes_times_out(tmp_path):
    info, _ = _run_and_score(_spec(tmp_path, "never", wait_timeout_s=1.5))
    assert info["status"] == "failed"
    assert "did not subscribe" in info["error"] and "1.5 s" in info["error"]
    assert info["stopped_by_harness"]


def test_harness_malformed_tracks_counted_not_trusted(tmp_path):
    info, s = _run_and_score(_spec(tmp_path, "malformed"))
    assert info["status"] == "ok"
    assert s.run["malformed_by_reason"] == {"missing key": 6, "undecodable": 6}
    assert s.run["gospa"] == 0.0 and s.run["tracks_messages"] == 6


def test_collector_drain_waits_on_valid_tracks_only():
    """The drain ends once ``last_time_s`` reaches the last scan; a malformed message of
    that scan (here one lacking ``track_id``, which still has a finite ``time_s``) must not
    move it, or the harness stops before the messages sent after it (the malformed tracker's
    undecodable and valid ones) are read: under load that lost one ``undecodable``."""
    import time

    import zmq

    from shipradar.sim.studies.evaluate.runner import _Collector, free_port

    ep = f"tcp://127.0.0.1:{free_port()}"
    ctx = zmq.Context()
    pub = ctx.socket(zmq.PUB)
    pub.bind(ep)
    col = _Collector(ep, time.perf_counter())
    col.start()
    try:
        assert col.connected.wait(10.0)
        valid = {"sensor": "r", "scan": 0, "time_s": 1.0, "track_id": ["a"],
                 "east_m": [0.0], "north_m": [0.0], "v_east_mps": [0.0],
                 "v_north_mps": [0.0]}

        def until(cond):
            deadline = time.monotonic() + 10.0
            while not cond():
                assert time.monotonic() < deadline
                time.sleep(0.01)

        def sent_until(cond, msg):
            # the subscription reaches the publisher some time after the handshake
            deadline = time.monotonic() + 10.0
            while not cond():
                assert time.monotonic() < deadline
                pub.send_multipart(msg)
                time.sleep(0.05)

        sent_until(lambda: col.last_time_s == 1.0, encode(b"tracks", 1.0, valid))
        n = len(col.records)
        bad = {k: v for k, v in valid.items() if k != "track_id"}
        pub.send_multipart(encode(b"tracks", 6.0, dict(bad, time_s=6.0)))
        pub.send_multipart([b"tracks", b"\xc1 not msgpack"])
        until(lambda: len(col.records) == n + 2)
        assert col.last_time_s == 1.0
        pub.send_multipart(encode(b"tracks", 6.0, dict(valid, time_s=6.0)))
        until(lambda: col.last_time_s == 6.0)
        assert len(col.records) == n + 3
    finally:
        col.stop.set()
        col.join()
        pub.close(linger=0)
        ctx.term()


def test_harness_asterix_only_tracker(tmp_path):
    """A tracker fed by ASTERIX alone, decoded by asterix-decoder (PyPI, not ours): the
    harness sends CAT048/034 to ``{asterix}``, starts the run once ``{tracks}`` is bound and
    scores what comes back. Its tracks are the plots, placed from I042 and the radar's
    CAT034 position, with new ids each scan (so SIAP associates none): GOSPA assigns the
    missile's plot to it once it is detected (frame, units and times right), and charges the
    ~40 clutter plots a scan as false."""
    from shipradar.sim.studies.evaluate.runner import RunSpec

    noon = 12 * 3600.0  # the demo's start_time, 12:00:00 UTC
    cmd = (f"{PY} {shlex.quote(str(TRACKERS))} asterix {{asterix}} {{tracks}} "
           f"--tod0 {noon}")
    info, s = _run_and_score(RunSpec(DEMO, 7, str(tmp_path / "asterix"), cmd))
    assert info["status"] == "ok", info
    assert s.run["malformed_by_reason"] == {}
    # UDP, unpaced: a loaded machine may drop a few datagrams (north markers among them)
    assert s.run["tracks_messages"] > 0.8 * s.run["scans"] > 80
    # a silent tracker's missed part is c/2 = 1000 m a scan (one missile, counted from t = 1 s)
    assert s.run["missed"] < 500.0  # the missile is detected at about a third of the run
    assert 0.0 < s.run["localisation"] < 400.0  # a plot's error and < 1 s of flight, per scan
    assert s.run["false"] > 20 * 1000.0  # the clutter false alarms, c/2 each


# ------------------------------------------------------------------ studies on Dask, CLI
@pytest.mark.slow
def test_study_cli_rescore_compare_determinism(tmp_path):
    import pandas as pd
    from distributed import Client, LocalCluster

    from shipradar.sim.studies.evaluate.cli import cli_main
    from shipradar.sim.studies.evaluate.study import run_study

    oracle = f"{PY} {shlex.quote(str(TRACKERS))} oracle {{plots}} {{tracks}} --truth coverage"
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        a = run_study(DEMO, oracle, runs=2, out=tmp_path / "a", seed=3, duration_s=5.0,
                      client=client, config=COVERAGE)
        b = run_study(DEMO, oracle + " --shift-m 40", runs=2, out=tmp_path / "b", seed=3,
                      duration_s=5.0, client=client, config=COVERAGE)
        a2 = run_study(DEMO, oracle, runs=2, out=tmp_path / "a2", seed=3, duration_s=5.0,
                       client=client, report=False, config=COVERAGE)
    assert a["scored"] == 2 and not a["failed"] and b["scored"] == a2["scored"] == 2
    for name in ("index.html", "gospa.svg", "coverage.svg", "ppi.svg", "per_scan.parquet",
                 "per_run.csv", "per_target.parquet", "summary.csv"):
        assert (tmp_path / "a" / name).stat().st_size > 0, name
    # determinism: same seeds and a deterministic tracker, identical scores
    cols = ["seed", "scan", "t_s", "gospa", "localisation", "missed", "false", "tracks"]
    pa = pd.read_parquet(tmp_path / "a" / "per_scan.parquet")[cols]
    pd.testing.assert_frame_equal(pa, pd.read_parquet(tmp_path / "a2" / "per_scan.parquet")[cols])
    # rescore with another cut-off, no run
    assert cli_main(["--rescore", str(tmp_path / "b"), "--c", "30", "--truth", "coverage"]) == 0
    rb = pd.read_parquet(tmp_path / "b" / "per_run.parquet")
    assert (rb["missed"] == 15.0).all() and (rb["false"] == 15.0).all()  # 40 m > c = 30 m
    assert cli_main(["--rescore", str(tmp_path / "b"), "--truth", "coverage"]) == 0
    assert cli_main(["--compare", str(tmp_path / "a"), str(tmp_path / "b"),
                     "--out", str(tmp_path / "cmp")]) == 0
    cmp = pd.read_csv(tmp_path / "cmp" / "compare.csv")
    diff = cmp[(cmp["kind"] != "mean") & (cmp["metric"] == "localisation")].iloc[0]
    assert diff["mean"] == pytest.approx(40.0, rel=1e-9) and diff["runs"] == 2


def test_cli_failed_run_exit_code_and_bad_input(tmp_path, capsys):
    from shipradar.sim.studies.evaluate.cli import cli_main

    assert cli_main(["--tracker", "x", str(tmp_path / "nope.yaml")]) == 2
    assert cli_main(["--rescore", str(tmp_path)]) == 2
    crash = f"{PY} {shlex.quote(str(TRACKERS))} crash {{plots}} {{tracks}} --after 1"
    code = cli_main([DEMO, "--tracker", crash, "--runs", "1", "--duration", "20",
                     "--workers", "1", "--out", str(tmp_path / "c"), "--quiet"])
    assert code == 1
    assert "exited with code 3" in capsys.readouterr().err
    html = (tmp_path / "c" / "index.html").read_text()
    assert "Failed runs" in html and "crashing on purpose" in html


def _free_port():
    from shipradar.sim.studies.evaluate.runner import free_port

    return free_port()


@pytest.mark.slow
def test_study_on_dask_cli_cluster(tmp_path):
    """A separately started ``dask scheduler`` and two ``dask worker`` processes."""
    from distributed import Client

    from shipradar.sim.studies.evaluate.study import run_study

    dask = str(Path(sys.executable).with_name("dask"))
    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    procs = []
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    try:
        procs.append(subprocess.Popen(
            [dask, "scheduler", "--host", "127.0.0.1", "--port", str(port),
             "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            env=env, start_new_session=True))
        for _ in range(2):
            procs.append(subprocess.Popen(
                [dask, "worker", addr, "--host", "127.0.0.1", "--nthreads", "1",
                 "--no-dashboard", "--nworkers", "1"], stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL, env=env, start_new_session=True))
        with Client(addr, timeout=60) as client:
            client.wait_for_workers(2, timeout=60)
            oracle = (f"{PY} {shlex.quote(str(TRACKERS))} oracle {{plots}} {{tracks}} "
                      f"--truth coverage")
            res = run_study(DEMO, oracle, runs=2, out=tmp_path / "s", seed=5,
                            duration_s=4.0, client=client, report=False, config=COVERAGE)
            workers = {w["host"] for w in client.scheduler_info()["workers"].values()}
        assert res["scored"] == 2 and workers == {"127.0.0.1"}
        assert all(r["mean"] == 0.0 for r in res["metrics"] if r["metric"] == "gospa")
        settings = json.loads((tmp_path / "s" / "study.json").read_text())
        assert len(settings["seeds"]) == 2
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in procs:
            try:
                p.wait(20)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()


# ------------------------------------------------------------------------ in process
class _OracleObject:
    """In-process oracle: it must not read the truth, so it is handed the scene's
    trajectories by the test (as a perfect tracker would estimate them)."""

    def __init__(self, scenario):
        from shipradar.sim.world.kinematics import LocalFrame
        from shipradar.sim.world.trajectory import trajectories

        self.traj = trajectories(scenario.targets, LocalFrame(scenario.origin), hold=False)
        self.ids = [t.id for t in scenario.targets]

    def on_message(self, topic, t, payload):
        if topic != "eos":
            return None
        n = len(self.ids)
        pos, vel, _, active = self.traj.state_acc(np.full(n, t), np.arange(n))
        idx = np.flatnonzero(active)
        return {"sensor": payload["sensor"], "scan": payload["scan"], "time_s": t,
                "track_id": [self.ids[j] for j in idx], "east_m": pos[idx, 0],
                "north_m": pos[idx, 1], "v_east_mps": vel[idx, 0],
                "v_north_mps": vel[idx, 1]}


def test_in_process_evaluate():
    import shipradar
    from shipradar.api import evaluate

    s = shipradar.load_scenario(DEMO)
    res = evaluate(s, tracker=lambda: _OracleObject(s), runs=2, seed=2, duration_s=5.0,
                   config=COVERAGE)
    assert len(res["per_run"]) == 2 and not res["failed"]
    assert all(r["gospa"] == 0.0 and r["siap_completeness"] == 1.0 for r in res["per_run"])

    class Broken:
        def on_message(self, topic, t, payload):
            raise RuntimeError("boom")

    res = evaluate(s, tracker=Broken, runs=1, seed=2, duration_s=3.0)
    assert res["failed"] and "boom" in res["failed"][0]["error"]


def test_template_tracker_stands_alone_and_scores(tmp_path):
    """examples/tracker_template.py imports nothing of shipradar and tracks the demo."""
    import ast

    path = ROOT / "examples" / "tracker_template.py"
    tree = ast.parse(path.read_text())
    roots = {(n.module if isinstance(n, ast.ImportFrom) else a.name).split(".")[0]
             for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom))
             for a in (n.names if isinstance(n, ast.Import) else [n])}
    assert roots <= {"__future__", "argparse", "itertools", "struct", "msgpack", "numpy",
                     "zmq"}, roots
    from shipradar.sim.studies.evaluate.runner import RunSpec

    spec = RunSpec(DEMO, 11, str(tmp_path / "tpl"),
                   f"{PY} {shlex.quote(str(path))} {{plots}} {{tracks}}", duration_s=60.0)
    info, s = _run_and_score(spec)
    assert info["status"] == "ok", info
    assert s.run["malformed_messages"] == 0 and s.run["tracks_messages"] == 60
    row = s.per_target[0]
    assert row["scans_held"] >= 15 and row["mean_error_m"] < 600  # the missile, from ~20 km
