"""Registration scores (issue 33, item 5): a tracker's bias estimates against
``truth[sensors]``, checked against closed forms on synthetic message sequences; malformed
``registration`` messages refused with the reason named; a run directory read back."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from shipradar.sim.stream.protocol import encode
from shipradar.sim.stream.recording import Recorder
from shipradar.sim.stream.schema import REGISTRATION, TOPIC_REGISTRATION, TOPIC_TRACKS
from shipradar.sim.studies.evaluate.data import RunData, add_registration, load_run
from shipradar.sim.studies.evaluate.metrics import MetricConfig, score_run
from shipradar.sim.studies.evaluate.registration import (
    TRUTH_KEYS,
    MalformedRegistration,
    RegistrationConfig,
    RegistrationMessage,
    check_registration,
    convergence_time,
    run_metric_names,
    score_registration,
    summarise_rows,
    truth_errors,
)

SCAN_S = 4.0


def _truth(n: int = 50, **values) -> dict[str, np.ndarray]:
    """One radar's truth[sensors] columns at ends of scan 4 s apart; each error constant
    (a number) or a function of time."""
    t = SCAN_S * np.arange(1, n + 1)
    out = {"time_s": t}
    for k in TRUTH_KEYS[1:]:
        v = values.get(k, 0.0)
        out[k] = v(t) if callable(v) else np.full(n, float(v))
    return out


def _msgs(sensor, t, **series) -> list[RegistrationMessage]:
    return [RegistrationMessage(float(ti), sensor, "test",
                                {k: float(v[i]) for k, v in series.items()})
            for i, ti in enumerate(t)]


def test_constant_offset_rmse_is_the_offset():
    """An estimate off the truth by a constant d has RMSE |d| and mean error d; it never
    converges within a tolerance below |d| and converges at its first estimate above."""
    truth = {"a": _truth(range_bias_m=150.0, azimuth_bias_rad=math.radians(0.3),
                         time_offset_s=0.05)}
    t = SCAN_S * np.arange(1, 41)
    d_r, d_az, d_t = 30.0, -math.radians(0.02), 0.004
    msgs = _msgs("a", t, range_bias_m=np.full(t.size, 150.0 + d_r),
                 azimuth_bias_rad=np.full(t.size, math.radians(0.3) + d_az),
                 time_offset_s=np.full(t.size, 0.05 + d_t))
    s = score_registration(msgs, truth, RegistrationConfig(), seed=3)
    rows = {r["component"]: r for r in s.rows}
    assert rows["range_bias_m"]["rmse"] == pytest.approx(d_r, rel=1e-12)
    assert rows["range_bias_m"]["mean_error"] == pytest.approx(d_r, rel=1e-12)
    assert math.isnan(rows["range_bias_m"]["converge_s"])  # 30 m > 20 m for ever
    assert rows["azimuth_bias_rad"]["rmse"] == pytest.approx(abs(d_az), rel=1e-9)
    assert rows["azimuth_bias_rad"]["converge_s"] == t[0]  # 0.02° < 0.05° throughout
    assert rows["time_offset_s"]["rmse"] == pytest.approx(d_t, rel=1e-9)
    assert rows["time_offset_s"]["converge_s"] == t[0]
    assert s.run["registration_a_rmse_range_bias_m"] == rows["range_bias_m"]["rmse"]
    assert s.run["registration_a_rmse_azimuth_bias_deg"] == pytest.approx(0.02, rel=1e-9)
    assert s.run["registration_a_time_offset_s_converge_s"] == t[0]
    assert s.run["registration_messages"] == t.size
    assert [r["seed"] for r in s.rows] == [3, 3, 3]
    assert len(s.series) == 3 * t.size


def test_converging_estimate_exact_convergence_time():
    """e(t) = b + A exp(−t/τ): within tol from t* = τ ln(A/tol) on, so the convergence time
    is the first estimate time at or after t*; the RMSE after a warm-up W is the closed
    form over those samples."""
    b, amp, tau, tol = 150.0, 200.0, 50.0, 20.0
    t = SCAN_S * np.arange(1, 76)
    est = b + amp * np.exp(-t / tau)
    truth = {"a": _truth(100, range_bias_m=b)}
    t_star = tau * math.log(amp / tol)  # 115.13 s
    s = score_registration(_msgs("a", t, range_bias_m=est), truth,
                           RegistrationConfig(tolerance_range_bias_m=tol, warmup_s=100.0))
    row = s.rows[0]
    assert row["converge_s"] == t[t >= t_star][0] == 116.0
    after = t >= 100.0
    want = math.sqrt(np.mean((amp * np.exp(-t[after] / tau)) ** 2))
    assert row["rmse"] == pytest.approx(want, rel=1e-12)
    assert row["scored"] == after.sum() and row["estimates"] == t.size
    # an estimate leaving the tolerance again moves it later; one outside at the end: NaN
    err = est - b
    err[40] = 25.0
    assert convergence_time(t, err, tol) == t[41]
    err[-1] = -21.0
    assert math.isnan(convergence_time(t, err, tol))
    assert math.isnan(convergence_time(np.zeros(0), np.zeros(0), tol))


def test_truth_between_scans_azimuth_sum_and_scene_without_errors():
    """The truth is interpolated linearly between ends of scan (exact for a linear drift),
    held outside them; azimuth is north alignment + gyro; no truth[sensors]: all zero."""
    drift = {"range_bias_m": lambda t: 100.0 + 0.5 * t,
             "azimuth_bias_rad": 0.004, "heading_bias_rad": 0.001}
    tr = _truth(20, **drift)
    t = np.array([1.0, 6.0, 30.0, 79.5, 200.0])
    np.testing.assert_allclose(truth_errors(tr, "range_bias_m", t),
                               100.0 + 0.5 * np.clip(t, 4.0, 80.0), rtol=1e-14)
    np.testing.assert_allclose(truth_errors(tr, "azimuth_bias_rad", t), 0.005, rtol=1e-14)
    assert np.all(truth_errors(None, "time_offset_s", t) == 0.0)
    msgs = _msgs("b", t, range_bias_m=np.full(t.size, 12.0))
    s = score_registration(msgs, {}, RegistrationConfig())  # an error-free scene
    assert s.rows[0]["rmse"] == pytest.approx(12.0, rel=1e-12)
    assert s.rows[0]["converge_s"] == t[0]


def test_two_radars_metric_names_and_summary_over_runs():
    truth = {"a": _truth(range_bias_m=150.0), "b": _truth(range_bias_m=-40.0)}
    t = SCAN_S * np.arange(1, 11)
    rows = []
    per_run = []
    for seed, d in ((1, 10.0), (2, 30.0)):
        msgs = (_msgs("a", t, range_bias_m=np.full(t.size, 150.0 + d))
                + _msgs("b", t, range_bias_m=np.full(t.size, -40.0 - d),
                        time_offset_s=np.zeros(t.size)))
        s = score_registration(msgs, truth, RegistrationConfig(), seed=seed)
        rows += s.rows
        per_run.append(s.run)
    assert run_metric_names(per_run) == (
        "registration_a_rmse_range_bias_m", "registration_a_range_bias_m_converge_s",
        "registration_b_rmse_range_bias_m", "registration_b_range_bias_m_converge_s",
        "registration_b_rmse_time_offset_s", "registration_b_time_offset_s_converge_s")
    summ = {(r["sensor"], r["component"]): r for r in summarise_rows(rows)}
    assert summ[("a", "range_bias_m")]["rmse"] == pytest.approx(20.0, rel=1e-12)
    assert summ[("a", "range_bias_m")]["converged_runs"] == 1  # 10 m yes, 30 m no
    assert summ[("b", "time_offset_s")]["rmse"] == 0.0


def test_config_refuses_bad_tolerances():
    with pytest.raises(ValueError, match="tolerance_range_bias_m must be > 0, got -1"):
        RegistrationConfig(tolerance_range_bias_m=-1.0)
    with pytest.raises(ValueError, match="warmup_s must be >= 0"):
        RegistrationConfig(warmup_s=-5.0)
    assert RegistrationConfig().tolerance("azimuth_bias_rad") == pytest.approx(
        math.radians(0.05), rel=1e-15)


# ---------------------------------------------------------------- the tracker's messages
GOOD = {"sensor": "a", "time_s": 8.0, "source": "x", "range_bias_m": 150.0,
        "sigma_range_bias_m": 12.0}


@pytest.mark.parametrize(("payload", "reason", "detail"), [
    ({k: v for k, v in GOOD.items() if k != "sensor"}, "missing key", "sensor"),
    ({k: v for k, v in GOOD.items() if k != "time_s"}, "missing key", "time_s"),
    ({**GOOD, "range_bias": 150.0}, "unknown key", "range_bias"),
    ({**GOOD, "range_bias_m": "150"}, "bad value", "range_bias_m = '150'"),
    ({**GOOD, "range_bias_m": math.nan}, "bad value", "not finite"),
    ({**GOOD, "time_s": math.inf}, "bad value", "time_s"),
    ({**GOOD, "sensor": 7}, "bad value", "sensor = 7"),
    ({"sensor": "a", "time_s": 8.0}, "no estimate", "range_bias_m"),
])
def test_malformed_registration_refused_with_reason(payload, reason, detail):
    frames = encode(TOPIC_REGISTRATION, 8.0, payload)
    with pytest.raises(MalformedRegistration, match=detail) as exc:
        check_registration(frames)
    assert exc.value.reason == f"registration: {reason}"
    data = _data()
    add_registration(data, frames, 0.1)
    assert data.malformed == {f"registration: {reason}": 1} and not data.registration
    assert detail in data.malformed_examples[f"registration: {reason}"]


def test_registration_accepted_and_unknown_sensor_counted():
    msg = check_registration(encode(TOPIC_REGISTRATION, 8.0, GOOD), 0.5)
    assert msg.estimates == {"range_bias_m": 150.0}
    assert msg.sigmas == {"sigma_range_bias_m": 12.0} and msg.recv_s == 0.5
    assert set(GOOD) <= set(REGISTRATION.keys)
    with pytest.raises(MalformedRegistration, match="wrong topic"):
        check_registration(encode(TOPIC_TRACKS, 8.0, GOOD))
    with pytest.raises(MalformedRegistration, match="undecodable"):
        check_registration([TOPIC_REGISTRATION, b"\xc1"])
    data = _data()
    add_registration(data, encode(TOPIC_REGISTRATION, 8.0, {**GOOD, "sensor": "zz"}), 0.1)
    assert data.malformed == {"registration: unknown sensor": 1}


def _data() -> RunData:
    radar = {"instrumented_range_m": 60_000.0, "scan_period_s": SCAN_S,
             "eos_t": np.zeros(0), "eos_pos": np.zeros((0, 3))}
    return RunData(info={"seed": 1, "status": "ok", "duration_s": 40.0}, target_ids=[],
                   ref_sensor="a", scan_t=np.zeros(0), truth_pos=np.zeros((0, 0, 3)),
                   truth_vel=np.zeros((0, 0, 3)), truth_active=np.zeros((0, 0), bool),
                   radars={"a": radar}, inputs={})


def test_run_directory_read_back_and_scored(tmp_path: Path):
    """A run directory as the harness writes it: truth[sensors] in stream.rec, registration
    beside tracks in tracks.rec; load_run + score_run give the closed-form RMSE and count a
    malformed registration message among the tracker's malformed messages."""
    n, d = 10, 25.0
    with Recorder(tmp_path / "stream.rec") as rec:
        meta = {"sensor": "a", "platform": "p", "scan": 0, "radar": {
            "instrumented_range_m": 60_000.0}, "scan_period_s": SCAN_S, "target_ids": ["x"]}
        rec.write(0.0, encode(b"meta", 0.0, meta))
        for i in range(1, n + 1):
            t = SCAN_S * i
            one = np.array([1e4])
            rec.write(t, encode(b"truth", t, {
                "sensor": "a", "scan": i - 1, "kind": "targets", "time_s": t,
                **{k: one for k in ("east_m", "north_m", "up_m")},
                **{k: 0 * one for k in ("v_east_mps", "v_north_mps", "v_up_mps")},
                "active": np.array([True]), "in_coverage": np.array([True])}))
            rec.write(t, encode(b"truth", t, {
                "sensor": "a", "scan": i - 1, "kind": "sensors", "time_s": t,
                "range_bias_m": 150.0, "range_scale_ppm": 0.0, "azimuth_bias_rad": 0.005,
                "time_offset_s": 0.05, "heading_bias_rad": 0.0, "nav_east_error_m": 0.0,
                "nav_north_error_m": 0.0, "nav_up_error_m": 0.0, "true_east_m": 0.0,
                "true_north_m": 0.0, "true_up_m": 20.0, "true_heading_rad": 0.0,
                "latency_s": math.nan}))
    with Recorder(tmp_path / "tracks.rec") as rec:
        for i in range(1, n + 1):
            t = SCAN_S * i
            rec.write(t, encode(TOPIC_REGISTRATION, t, {
                "sensor": "a", "time_s": t, "range_bias_m": 150.0 + d,
                "azimuth_bias_rad": 0.005}))
        rec.write(t, encode(TOPIC_REGISTRATION, t, {"sensor": "a", "time_s": t}))
    (tmp_path / "run.json").write_text(json.dumps({"seed": 5, "status": "ok",
                                                   "duration_s": SCAN_S * n}))
    data = load_run(tmp_path)
    assert len(data.registration) == n
    np.testing.assert_array_equal(data.sensor_truth["a"]["time_s"], SCAN_S * np.arange(1, 11))
    s = score_run(data, MetricConfig())
    assert s.run["registration_a_rmse_range_bias_m"] == pytest.approx(d, rel=1e-12)
    assert s.run["registration_a_rmse_azimuth_bias_deg"] == 0.0
    assert s.run["malformed_by_reason"] == {"registration: no estimate": 1}
    assert s.run["tracks_messages"] == 0


def test_summary_intervals_clipped_at_zero():
    """An RMSE's or a time's Student-t interval over runs does not reach below 0."""
    from shipradar.sim.studies.evaluate.registration import summarise_run_metrics

    rows = [{"registration_a_rmse_range_bias_m": v, "registration_a_range_bias_m_converge_s": c}
            for v, c in ((0.5, 10.0), (40.0, 200.0))]
    out = {r["metric"]: r for r in summarise_run_metrics(rows)}
    assert set(out) == set(rows[0])
    for r in out.values():
        assert r["low"] == 0.0 and r["high"] > r["mean"] and r["runs"] == 2
    assert out["registration_a_rmse_range_bias_m"]["mean"] == pytest.approx(20.25, rel=1e-12)


def test_report_section_fixed_notation_and_figure(tmp_path):
    """The report's registration table shows each component in its display unit (deg, ms)
    in fixed notation, never 1e-05, and draws registration.svg."""
    import re

    from shipradar.sim.studies.evaluate.registration import report_section

    truth = {"a": _truth(azimuth_bias_rad=0.004, time_offset_s=0.05)}
    t = SCAN_S * np.arange(1, 11)
    msgs = _msgs("a", t, azimuth_bias_rad=np.full(t.size, 0.004 + 1e-7),
                 time_offset_s=np.full(t.size, 0.05 + 2e-6))
    s = score_registration(msgs, truth, RegistrationConfig(), seed=1)
    page = report_section(tmp_path, summarise_rows(s.rows), s.series)
    assert "<td>deg</td>" in page and "<td>ms</td>" in page
    assert not re.search(r"\d[eE][-+]?\d", page), page
    assert (tmp_path / "registration.svg").stat().st_size > 1000
    assert report_section(tmp_path, [], []) == ""
