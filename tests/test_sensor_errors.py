"""Imperfect sensors (issue 33): registration biases, clock errors, navigation errors and
their truth, against truth[plots] and closed forms (seeded statistical tests)."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from shipradar.sensors.sensor_errors import GaussMarkov, error_stream, gauss_markov_path
from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream import protocol
from shipradar.sim.stream.schema import TRUTH_SENSORS
from shipradar.sim.world.kinematics import LocalFrame
from shipradar.sim.world.scenario import ErrorTerm, ScenarioError, parse_scenario
from shipradar.tables.scene import SceneTables

from .helpers import CaptureBus, quiet_radar

# --------------------------------------------------------------------- Gauss-Markov process


def test_gauss_markov_variance_and_autocorrelation():
    """x_{k+1} = e^{-Δt/T} x_k + σ √(1 − e^{-2Δt/T}) w_k, started stationary: variance σ²
    and autocorrelation exp(−τ/T) (the continuous process's, independent of Δt).

    One path of n = 400 000 steps with T = 20 Δt holds n Δt / (2 T) = 10 000 independent
    stretches: the variance's standard error is about σ² √(2 / 10 000) = 1.4 %, the
    autocorrelation's about 0.01; tolerances are 4 standard errors."""
    sigma, tau, dt, n = 2.5, 20.0, 1.0, 400_000
    gm = GaussMarkov(ErrorTerm(mean=0.0, sigma=sigma, correlation_time_s=tau), dt,
                     np.random.default_rng(11))
    x = gm.at_index(np.arange(n))
    assert np.var(x) == pytest.approx(sigma**2, rel=0.056)
    assert abs(np.mean(x)) < 4 * sigma * math.sqrt(2 * tau / (n * dt))
    for lag in (5, 10, 20, 40):
        rho = np.mean(x[:-lag] * x[lag:]) / np.var(x)
        assert rho == pytest.approx(math.exp(-lag * dt / tau), abs=0.04)


def test_gauss_markov_is_the_same_however_asked():
    """Asked in pieces (as the engine asks block after block, forgetting behind), the path is
    the one asked at once; the grid step (k Δt, (k + 1) Δt] holds x_k."""
    term = ErrorTerm(mean=1.0, sigma=0.3, correlation_time_s=50.0)
    whole = GaussMarkov(term, 0.5, np.random.default_rng(3)).at_index(np.arange(20_000))
    pieces = GaussMarkov(term, 0.5, np.random.default_rng(3))
    got = []
    for a in range(0, 20_000, 1234):
        pieces.forget_before(a * 0.5)
        got.append(pieces.at_index(np.arange(a, min(a + 1234, 20_000))))
    np.testing.assert_array_equal(np.concatenate(got), whole)
    gm = GaussMarkov(term, 0.5, np.random.default_rng(3))
    assert gm.at(np.array([0.0, 0.25, 0.5, 0.5001, 1.0])).tolist() == \
        gm.at_index(np.array([0, 0, 0, 1, 1])).tolist()


def test_gauss_markov_path_one_step_law():
    """One step from x_0: mean e^{-Δt/T} x_0 and variance σ² (1 − e^{-2Δt/T}) (many draws)."""
    rng = np.random.default_rng(5)
    a = math.exp(-0.3)
    steps = np.array([gauss_markov_path(2.0, 1, 0.3, 1.5, 1.0, rng)[0] for _ in range(20_000)])
    se = 1.5 * math.sqrt(1 - a * a) / math.sqrt(steps.size)
    assert abs(steps.mean() - a * 2.0) < 4 * se
    assert steps.var() == pytest.approx(1.5**2 * (1 - a * a), rel=0.04)


def test_error_streams_are_independent_and_stable():
    """A stream depends on the seed, the owner and the error's name only."""
    a = error_stream(7, "r1", "range_bias_m").standard_normal(4)
    assert np.array_equal(a, error_stream(7, "r1", "range_bias_m").standard_normal(4))
    for other in (error_stream(8, "r1", "range_bias_m"), error_stream(7, "r2", "range_bias_m"),
                  error_stream(7, "r1", "time_offset_s"), np.random.default_rng(
                      np.random.SeedSequence(7).spawn(1)[0])):
        assert not np.array_equal(a, other.standard_normal(4))


# --------------------------------------------------------------------- scenario input
def _scene(errors=None, navigation=None, targets=40, duration_s=40.0, seed=9, radars=None):
    """A stationary ship, a 1 s radar (60 rpm) and ``targets`` large steady targets spread in
    range (8-50 km) and azimuth, far apart (no two in one resolution cell)."""
    radar = quiet_radar(false_alarm_time_s=600)
    if errors is not None:
        radar["errors"] = errors
    rng = np.random.default_rng(1)
    tgts = []
    for i in range(targets):
        r, az = rng.uniform(8e3, 50e3), 2 * math.pi * i / targets
        e, n = r * math.sin(az), r * math.cos(az)
        tgts.append({"id": f"t{i}", "waypoints": [
            {"time_s": 0, "east_m": e, "north_m": n, "altitude_m": 300.0},
            {"time_s": 10_000, "east_m": e + 1.0, "north_m": n, "altitude_m": 300.0}],
            "rcs": {"type": "constant", "sigma_m2": 1000.0}, "swerling": 0})
    platform = {"id": "ship", "waypoints": [{"east_m": 0, "north_m": 0}],
                "heading_deg": 30.0, "radars": radars or [radar]}
    if navigation is not None:
        platform["navigation"] = navigation
    return {
        "name": "errors", "duration_s": duration_s, "seed": seed,
        "origin": {"lat_deg": 44.6, "lon_deg": -63.0}, "platforms": [platform],
        "targets": tgts,
        "fidelity": {"propagation": "free_space", "atmosphere": False, "clutter": False,
                     "sectors_per_scan": 8},
    }


def _run(data):
    bus = CaptureBus()
    Simulation(parse_scenario(data), bus=bus, tables=SceneTables()).run()
    return bus


@pytest.mark.parametrize("field,value,expect", [
    ("range_bias_m", {"sigma": -1.0}, "errors.range_bias_m.sigma: must be >= 0, got -1"),
    ("range_bias_m", {"sigma": 1.0, "correlation_time_s": 0},
     "errors.range_bias_m.correlation_time_s: must be > 0, got 0"),
    ("azimuth_bias_deg", 400.0, "errors.azimuth_bias_deg.mean: must be in [-180, 180] deg, "
     "got 400"),
    ("range_bias_m", 1e9, "errors.range_bias_m.mean: must be in [-10000, 10000] m, got 1e+09"),
    ("time_jitter_s", -0.1, "errors.time_jitter_s: must be >= 0, got -0.1"),
    ("latency", {"random_mean_s": -1}, "errors.latency.random_mean_s: must be >= 0, got -1"),
])
def test_bad_errors_one_clear_line(field, value, expect):
    data = _scene({field: value}, targets=0)
    with pytest.raises(ScenarioError) as exc:
        parse_scenario(data)
    assert exc.value.lines == [f"platforms[0].radars[0].{expect}"]


def test_bad_navigation_one_clear_line():
    data = _scene(navigation={"heading_bias_deg": {"sigma": 0.1, "correlation_time_s": -5}},
                  targets=0)
    with pytest.raises(ScenarioError) as exc:
        parse_scenario(data)
    assert exc.value.lines == ["platforms[0].navigation.heading_bias_deg.correlation_time_s: "
                               "must be > 0, got -5"]


def test_zero_errors_given_explicitly_change_nothing():
    """An ``errors:`` and a ``navigation:`` section of zeros are the defaults: the same bytes,
    no truth[sensors]."""
    zero = {"range_bias_m": 0, "range_scale_ppm": {"mean": 0, "sigma": 0},
            "azimuth_bias_deg": 0.0, "time_offset_s": 0, "time_jitter_s": 0,
            "latency": {"fixed_s": 0, "random_mean_s": 0}}
    nav = {"east_error_m": 0, "north_error_m": 0, "up_error_m": 0, "heading_bias_deg": 0}
    base = _run(_scene(targets=10, duration_s=6.0))
    given = _run(_scene(zero, nav, targets=10, duration_s=6.0))
    assert given.frames == base.frames
    assert not [p for _, p in base.of(protocol.TOPIC_TRUTH) if p["kind"] == "sensors"]


# --------------------------------------------------------------------- through the engine
def _pairs(bus):
    """Every plot with its truth: columns of plots and truth[plots], concatenated."""
    plots = [p for _, p in bus.of(protocol.TOPIC_PLOTS)]
    truth = [p for _, p in bus.of(protocol.TOPIC_TRUTH) if p["kind"] == "plots"]
    out = {k: np.concatenate([p[k] for p in plots]) for k in (
        "plot_id", "time_s", "range_m", "azimuth_rad", "sigma_range_m", "sigma_azimuth_rad")}
    for k in ("plot_id", "target", "true_range_m", "true_azimuth_rad", "contrib_offsets"):
        out["truth_" + k] = np.concatenate([p[k][:-1] if k == "contrib_offsets" else p[k]
                                            for p in truth])
    counts = np.concatenate([np.diff(p["contrib_offsets"]) for p in truth])
    assert np.array_equal(out["plot_id"], out["truth_plot_id"])
    single = (out["truth_target"] >= 0) & (counts == 1)
    return {k: v[single] for k, v in out.items()}


def _wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def test_biases_recovered_from_truth_and_spread_is_the_seeds():
    """Constant errors: (measured − true) regressed on the true range gives the range bias
    (intercept) and scale (slope) within 4 standard errors; the azimuth's mean error is the
    north alignment plus the gyro bias; the residuals normalised by the plots' own σ have unit
    spread (the seed's noise [84]-[89] unchanged)."""
    errors = {"range_bias_m": 150.0, "range_scale_ppm": 800.0, "azimuth_bias_deg": 0.3}
    nav = {"heading_bias_deg": -0.12}
    p = _pairs(_run(_scene(errors, nav)))
    n = p["range_m"].size
    assert n > 1000
    # range: weighted least squares of d = b + s r_true on the plots' own σ
    d = p["range_m"] - p["truth_true_range_m"]
    w = 1.0 / p["sigma_range_m"]
    a = np.stack([np.ones(n), p["truth_true_range_m"]], axis=1) * w[:, None]
    coef, *_ = np.linalg.lstsq(a, d * w, rcond=None)
    cov = np.linalg.inv(a.T @ a)
    se_b, se_s = np.sqrt(np.diag(cov))
    assert abs(coef[0] - 150.0) < 4 * se_b
    assert abs(coef[1] - 800e-6) < 4 * se_s
    resid = (d - coef[0] - coef[1] * p["truth_true_range_m"]) / p["sigma_range_m"]
    assert np.std(resid) == pytest.approx(1.0, abs=4 * math.sqrt(0.5 / n) + 0.02)
    # azimuth
    da = _wrap(p["azimuth_rad"] - p["truth_true_azimuth_rad"])
    want = math.radians(0.3 - 0.12)
    z = da / p["sigma_azimuth_rad"]
    se = np.std(da) / math.sqrt(n)
    assert abs(np.mean(da) - want) < 4 * se
    assert np.std((da - want) / p["sigma_azimuth_rad"]) == pytest.approx(
        1.0, abs=4 * math.sqrt(0.5 / n) + 0.02)
    assert abs(np.mean(z)) > 3  # the bias is many plots' σ/√n: the test can see it


def test_time_offset_and_jitter_against_the_error_free_run():
    """The time errors have their own streams: with the same seed, the plots are those of
    the error-free run (same ranges and azimuths, bit for bit) stamped time + offset +
    jitter; the difference's mean is the offset within 4 standard errors and its spread the
    jitter's σ (χ² bound)."""
    base = _pairs(_run(_scene()))
    late = _pairs(_run(_scene({"time_offset_s": 0.05, "time_jitter_s": 0.004})))
    np.testing.assert_array_equal(base["range_m"], late["range_m"])
    np.testing.assert_array_equal(base["azimuth_rad"], late["azimuth_rad"])
    dt = late["time_s"] - base["time_s"]
    n = dt.size
    assert abs(dt.mean() - 0.05) < 4 * 0.004 / math.sqrt(n)
    assert dt.std() == pytest.approx(0.004, rel=4 * math.sqrt(0.5 / n))


def test_time_offset_against_the_beam():
    """Independent of a second run: a plot's true time is when the beam (start azimuth 0,
    ω = 2π/1 s) pointed at its true azimuth in its scan; the reported time is that plus the
    offset (the plots' azimuth noise moves nothing: the true azimuth is used)."""
    bus = _run(_scene({"time_offset_s": -0.2}))
    plots = [p for _, p in bus.of(protocol.TOPIC_PLOTS)]
    truth = [p for _, p in bus.of(protocol.TOPIC_TRUTH) if p["kind"] == "plots"]
    t = np.concatenate([p["time_s"] for p in plots])
    scan = np.concatenate([np.full(p["time_s"].size, p["scan"]) for p in plots])
    az = np.concatenate([p["true_azimuth_rad"] for p in truth])
    ok = np.isfinite(az)
    t_true = scan[ok] + np.mod(az[ok], 2 * math.pi) / (2 * math.pi)
    # a target on the start azimuth is met at a revolution's boundary: the beam's time is
    # known modulo one period
    d = np.mod(t[ok] - t_true + 0.5, 1.0) - 0.5
    np.testing.assert_allclose(d, -0.2, atol=1e-3)


def test_navigation_in_meta_and_eos_and_truth():
    """meta and eos report the navigated antenna (true + error), truth[sensors] the true one
    and every error's value; lat/lon are the navigated east/north's."""
    nav = {"east_error_m": 35.0, "north_error_m": -20.0, "up_error_m": 2.0,
           "heading_bias_deg": 0.5}
    errors = {"range_bias_m": 40.0, "azimuth_bias_deg": -0.2, "time_offset_s": 0.01,
              "range_scale_ppm": 3.0}
    data = _scene(errors, nav, targets=2, duration_s=5.0)
    bus = _run(data)
    sensors = [p for _, p in bus.of(protocol.TOPIC_TRUTH) if p["kind"] == "sensors"]
    eos = [p for _, p in bus.of(protocol.TOPIC_EOS)]
    assert len(sensors) == len(eos) == 5
    frame = LocalFrame(parse_scenario(data).origin)
    for s, e in zip(sensors, eos, strict=True):
        TRUTH_SENSORS.check(s)
        assert (s["sensor"], s["scan"], s["time_s"]) == (e["sensor"], e["scan"], e["time_s"])
        assert s["true_east_m"] == 0.0 and s["true_north_m"] == 0.0
        assert s["true_up_m"] == pytest.approx(20.0)
        assert s["true_heading_rad"] == pytest.approx(math.radians(30.0))
        pos = e["position"]
        assert pos["east_m"] == pytest.approx(35.0, abs=1e-9)
        assert pos["north_m"] == pytest.approx(-20.0, abs=1e-9)
        assert pos["up_m"] == pytest.approx(22.0, abs=1e-9)
        assert e["heading_deg"] == pytest.approx(30.5, abs=1e-9)
        lat, lon, _ = frame.geodetic(np.array([[35.0, -20.0, 2.0]]))
        assert pos["lat_deg"] == pytest.approx(float(lat[0]), abs=1e-12)
        assert pos["lon_deg"] == pytest.approx(float(lon[0]), abs=1e-12)
        assert s["range_bias_m"] == 40.0 and s["range_scale_ppm"] == 3.0
        assert s["azimuth_bias_rad"] == pytest.approx(math.radians(-0.2))
        assert s["heading_bias_rad"] == pytest.approx(math.radians(0.5))
        assert s["time_offset_s"] == 0.01
        assert (s["nav_east_error_m"], s["nav_north_error_m"], s["nav_up_error_m"]) == (
            35.0, -20.0, 2.0)
    for _, m in bus.of(protocol.TOPIC_META):
        assert m["position"]["east_m"] == pytest.approx(35.0, abs=1e-9)
        assert m["heading_deg"] == pytest.approx(30.5, abs=1e-9)
        assert "errors" not in m["radar"]  # a real sensor does not tell its errors


def test_truth_sensors_follows_a_gauss_markov_error():
    """A Gauss-Markov range bias: truth[sensors] gives its value at each end of scan, and the
    last sector's plots of each scan carry that value (their mean error, against truth[plots],
    within 4 standard errors of it)."""
    errors = {"range_bias_m": {"mean": 100.0, "sigma": 60.0, "correlation_time_s": 5.0}}
    bus = _run(_scene(errors, targets=80, duration_s=20.0))
    sensors = {p["scan"]: p for _, p in bus.of(protocol.TOPIC_TRUTH) if p["kind"] == "sensors"}
    values = np.array([sensors[s]["range_bias_m"] for s in sorted(sensors)])
    assert values.std() > 10.0  # it moves
    plots = [(t, p) for t, p in bus.of(protocol.TOPIC_PLOTS)]
    truth = [p for _, p in bus.of(protocol.TOPIC_TRUTH) if p["kind"] == "plots"]
    seen = 0
    for (t, p), tr in zip(plots, truth, strict=True):
        if not math.isclose(t, p["scan"] + 1.0):  # the scan's last sector
            continue
        ok = tr["target"] >= 0
        if ok.sum() < 3:
            continue
        d = (p["range_m"] - tr["true_range_m"])[ok]
        se = float(np.sqrt(np.mean(p["sigma_range_m"][ok] ** 2) / ok.sum()))
        assert abs(d.mean() - sensors[p["scan"]]["range_bias_m"]) < 4 * se + 1e-6
        seen += 1
    assert seen >= 5


def test_every_radar_on_a_ship_shares_its_navigation():
    """Two radars on one ship: the same navigation errors (the platform's streams); each its
    own radar errors."""
    r1 = quiet_radar(id="r1", errors={"range_bias_m": {"sigma": 5.0, "correlation_time_s": 9}})
    r2 = quiet_radar(id="r2", rotation_rpm=40, sic=2,
                     errors={"range_bias_m": {"sigma": 5.0, "correlation_time_s": 9}})
    nav = {"east_error_m": {"sigma": 10.0, "correlation_time_s": 30.0}, "update_s": 0.5}
    bus = _run(_scene(navigation=nav, radars=[r1, r2], targets=0, duration_s=6.0))
    sensors = [p for _, p in bus.of(protocol.TOPIC_TRUTH) if p["kind"] == "sensors"]
    by = {}
    for s in sensors:
        by.setdefault(s["sensor"], {})[s["time_s"]] = s
    common = sorted(set(by["r1"]) & set(by["r2"]))
    assert common  # 3 s: both end a scan there
    for t in common:
        assert by["r1"][t]["nav_east_error_m"] == by["r2"][t]["nav_east_error_m"]
        assert by["r1"][t]["range_bias_m"] != by["r2"][t]["range_bias_m"]


def test_same_seed_same_bytes_with_errors():
    errors = {"range_bias_m": {"mean": 10, "sigma": 3, "correlation_time_s": 4},
              "time_jitter_s": 0.01}
    data = _scene(errors, {"north_error_m": {"sigma": 4, "correlation_time_s": 8}}, targets=5,
                  duration_s=5.0)
    assert _run(copy.deepcopy(data)).frames == _run(data).frames


# --------------------------------------------------------------------- ASTERIX
def _asterix_records(blocks):
    """CAT048 (sic, tod, rho [NM], theta [deg]) and CAT034 north markers (sic, lat, lon) as
    asterix-decoder (PyPI, its own XML definitions) reads them."""
    asterix = pytest.importorskip("asterix")
    r48, r34 = [], []
    for _, block in blocks:
        for r in asterix.parse(block):
            if r["category"] == 48:
                r48.append((r["I010"]["SIC"]["val"], r["I140"]["ToD"]["val"],
                            r["I040"]["RHO"]["val"], r["I040"]["THETA"]["val"]))
            elif r["I000"]["MsgTyp"]["val"] == 1:
                r34.append((r["I010"]["SIC"]["val"], r["I120"]["LAT"]["val"],
                            r["I120"]["Lon"]["val"]))
    return r48, r34


def test_asterix_carries_the_errors():
    """CAT048's time of day, range and azimuth are the plots' with their errors (the same
    seed's error-free run plus the biases, within the items' LSBs); CAT034's antenna
    position is the navigated one."""
    from shipradar.sim.adapters.asterix import AsterixStream
    from shipradar.sim.adapters.asterix.encode import seconds_of_day

    from .asterix_helpers import scene_dict

    nm = 1852.0
    d0 = scene_dict()
    d1 = copy.deepcopy(d0)
    d1["platforms"][0]["radars"][0]["errors"] = {
        "range_bias_m": 300.0, "azimuth_bias_deg": 0.5, "time_offset_s": 0.25}
    d1["platforms"][0]["navigation"] = {"east_error_m": 500.0, "north_error_m": -300.0}
    out = []
    for d in (d0, d1):
        s = parse_scenario(d)
        msgs = list(Simulation(s).messages())
        stream = AsterixStream()
        out.append((s, msgs, _asterix_records([b for m in msgs for b in stream.feed(*m)])))
    (s, _, (a48, a34)), (_, msgs, (b48, b34)) = out
    sic = s.asterix_sources()["r1"][1]
    a = np.array([r[1:] for r in a48 if r[0] == sic])
    b = np.array([r[1:] for r in b48 if r[0] == sic])
    assert a.shape == b.shape and a.shape[0] > 20
    tod = np.mod(b[:, 0] - a[:, 0] + 43200.0, 86400.0) - 43200.0
    np.testing.assert_allclose(tod, 0.25, atol=2 / 128)
    np.testing.assert_allclose((b[:, 1] - a[:, 1]) * nm, 300.0, atol=2 * nm / 256)
    np.testing.assert_allclose(np.mod(b[:, 2] - a[:, 2] + 180, 360) - 180, 0.5,
                               atol=2 * 360 / 2**16)
    # and the stream's own plots, whose time of day they are
    t = np.concatenate([p["time_s"] for top, _, p in msgs if top == "plots"
                        and p["sensor"] == "r1"])
    sod = seconds_of_day(s.start_time)
    got = np.mod(b[:, 0] - sod - t + 43200.0, 86400.0) - 43200.0
    assert np.abs(got).max() <= 1 / 128
    # CAT034 north markers: the navigated position, 500 m east and 300 m south of the true
    m0 = np.array([r[1:] for r in a34 if r[0] == sic])
    m1 = np.array([r[1:] for r in b34 if r[0] == sic])
    assert m0.shape == m1.shape and m0.shape[0] >= 5
    lat0 = math.radians(44.6)
    np.testing.assert_allclose((m1[:, 0] - m0[:, 0]) * 111_132.0, -300.0, atol=3.0)
    np.testing.assert_allclose((m1[:, 1] - m0[:, 1]) * 111_412.0 * math.cos(lat0), 500.0,
                               atol=3.0)


# --------------------------------------------------------------------- latency
def _latency_scene():
    """r1 reports 1 s late plus an exponential delay of mean 20 ms per sector message (its
    sectors 125 ms apart: a message almost never waits for the one ahead); r2 on time."""
    r1 = quiet_radar(id="r1", errors={"latency": {"fixed_s": 1.0, "random_mean_s": 0.02}})
    r2 = quiet_radar(id="r2", rotation_rpm=40, sic=2)
    return _scene(radars=[r1, r2], targets=30, duration_s=30.0)


def _by_sensor(bus):
    """Each radar's messages (``t``, frames), but ``truth[sensors]``, which only the run with
    errors has."""
    out = {}
    for (topic, t, p), frames in zip(bus.messages, bus.frames, strict=True):
        if topic != protocol.TOPIC_END and p.get("kind") != "sensors":
            out.setdefault(p["sensor"], []).append((t, frames))
    return out


def test_latency_orders_the_stream_by_publication():
    """With latency, each radar's messages are those of the run without (the same bytes but
    the envelope's `t`: nothing lost, duplicated or reordered within a radar), published
    late: `t` − the on-time `t` is at least the fixed delay, a sector message's extra delay
    is exponential with the stated mean (Kolmogorov-Smirnov, and the mean within 4 standard
    errors), and the whole stream is in publication order, so r1's messages come after r2's
    later ones. ``end`` comes last, at the last publication."""
    from scipy import stats

    late = _run(_latency_scene())
    zero = _latency_scene()
    zero["platforms"][0]["radars"][0].pop("errors")
    on_time = _by_sensor(_run(zero))
    got = _by_sensor(late)
    times = [t for _, t, _ in late.messages]
    assert times == sorted(times)
    assert late.messages[-1][0] == protocol.TOPIC_END and times[-1] == max(times[:-1])
    assert got["r2"] == on_time["r2"]
    assert len(got["r1"]) == len(on_time["r1"])
    extra, overtaken = [], 0
    for (t, frames), (t0, frames0) in zip(got["r1"], on_time["r1"], strict=True):
        assert frames[0] == frames0[0]
        assert protocol.retime(frames[1], t0) == frames0[1]
        assert t - t0 >= 1.0 - 1e-12
        if frames[0] == protocol.TOPIC_PLOTS:
            extra.append(t - t0 - 1.0)
    extra = np.array(extra)
    assert extra.size > 100
    assert abs(extra.mean() - 0.02) < 4 * 0.02 / math.sqrt(extra.size)
    assert stats.kstest(extra, "expon", args=(0, 0.02)).pvalue > 1e-3
    # across radars, out of their on-time order
    pos = {id(f): i for i, f in enumerate(late.frames)}
    on_time_r2 = dict(zip([id(f) for _, f in got["r2"]], [t for t, _ in on_time["r2"]],
                          strict=True))
    for (_, frames), (t0, _) in zip(got["r1"], on_time["r1"], strict=True):
        overtaken += sum(1 for f_id, t2 in on_time_r2.items() if t0 < t2 and pos[f_id] < pos[
            id(frames)])
    assert overtaken > 100


def test_truth_sensors_reports_the_latency():
    """truth[sensors].latency_s is the delay of the scan's last ``plots`` message."""
    late = _run(_latency_scene())
    zero = _latency_scene()
    zero["platforms"][0]["radars"][0].pop("errors")
    on_time = _run(zero)
    t0 = {(p["sensor"], p["scan"], int(p["plot_id"][0])): t
          for t, p in on_time.of(protocol.TOPIC_PLOTS)}
    last = {}
    for t, p in late.of(protocol.TOPIC_PLOTS):
        key = (p["sensor"], p["scan"], int(p["plot_id"][0]))
        last[(p["sensor"], p["scan"])] = t - t0[key]
    sensors = [p for _, p in late.of(protocol.TOPIC_TRUTH) if p["kind"] == "sensors"]
    assert sensors
    for s in sensors:
        want = last.get((s["sensor"], s["scan"]), math.nan)
        if math.isnan(want):
            assert math.isnan(s["latency_s"])
        else:
            assert s["latency_s"] == pytest.approx(want, abs=1e-9)


def test_latency_recording_is_the_simpy_order_and_reproducible(tmp_path):
    """A recording (the batched fast path) holds the messages SimPy's loop gives, in its
    order, and the same seed gives the same bytes."""
    from shipradar.sim.stream.bus import Bus
    from shipradar.sim.stream.recording import Recorder, read_recording

    data = _latency_scene()
    data["duration_s"] = 8.0
    bodies = []
    for k in range(2):
        path = tmp_path / f"{k}.srrec"
        with Bus(None, Recorder(path)) as bus:
            sim = Simulation(parse_scenario(data), bus=bus, tables=SceneTables())
            assert sim.batched
            sim.run()
        with read_recording(path, strict=True) as reader:
            bodies.append([(bytes(topic), bytes(body)) for _, (topic, body) in reader])
        assert path.read_bytes() == (tmp_path / "0.srrec").read_bytes()
    simpy_run = _run(data)
    assert bodies[0] == [(bytes(f[0]), bytes(f[1])) for f in simpy_run.frames]


def test_asterix_bus_encoding_ahead_with_errors_and_latency():
    """The ASTERIX bus that the engine hands each revolution's plots ahead sends what the
    stream fed message by message gives, with errors and a latency (retimed messages fall
    back to encoding from the message)."""
    from shipradar.sim.adapters.asterix import AsterixStream
    from shipradar.sim.adapters.asterix.stream import datagrams
    from shipradar.sim.adapters.asterix.udp import AsterixBus

    from .asterix_helpers import MemorySender, scene_dict

    d = scene_dict()
    d["platforms"][0]["radars"][0]["errors"] = {
        "range_bias_m": 300.0, "azimuth_bias_deg": {"sigma": 0.2, "correlation_time_s": 5.0},
        "time_offset_s": 0.25, "time_jitter_s": 0.01, "latency": {"fixed_s": 0.2,
                                                                  "random_mean_s": 0.3}}
    d["platforms"][0]["navigation"] = {"east_error_m": 500.0}
    s = parse_scenario(d)
    msgs = list(Simulation(s).messages())
    sender = MemorySender()
    bus = AsterixBus(None, sender)
    sim = Simulation(s, bus=bus)
    assert sim.encodes_ahead
    sim.run()
    stream = AsterixStream()
    want = [d for m in msgs for _, d in datagrams(stream.feed(*m), 1400)]
    assert sender.sent == want and len(want) > 10


def test_retime_is_encoding_at_another_time():
    """A body retimed is the payload encoded at that time (fixmap and map16 headers)."""
    small = {"sensor": "r1", "scan": 3, "time_s": 1.5}
    big = {f"k{i}": float(i) for i in range(20)}
    for payload in (small, big):
        body = protocol.encode(protocol.TOPIC_EOS, 1.0, payload)[1]
        assert protocol.retime(body, 7.25) == protocol.encode(protocol.TOPIC_EOS, 7.25,
                                                              payload)[1]
    with pytest.raises(protocol.ProtocolError):
        protocol.retime(b"\x91\x01", 1.0)


def test_gauss_markov_through_the_engine():
    """A Gauss-Markov range bias (σ = 10 m, T = 2 s) as truth[sensors] reports it at 2000
    ends of scan 1 s apart: variance σ² and autocorrelation exp(−τ/T) at τ = 1, 2, 4 s.
    About 500 independent stretches: the variance's standard error is ~6 %, the
    autocorrelation's ~0.045; tolerances 4 standard errors."""
    errors = {"range_bias_m": {"sigma": 10.0, "correlation_time_s": 2.0}}
    bus = _run(_scene(errors, targets=0, duration_s=2000.0))
    x = np.array([p["range_bias_m"] for _, p in bus.of(protocol.TOPIC_TRUTH)
                  if p["kind"] == "sensors"])
    assert x.size == 2000
    assert np.var(x) == pytest.approx(100.0, rel=0.25)
    for lag in (1, 2, 4):
        rho = np.mean((x[:-lag] - x.mean()) * (x[lag:] - x.mean())) / np.var(x)
        assert rho == pytest.approx(math.exp(-lag / 2.0), abs=0.18)


def test_latency_in_wall_clock_mode_and_with_processes():
    """With latency, a run paced to the wall clock (SimPy's real-time environment) and one
    asked for two processes (run in one: docs/protocol.md 4.5) give the fast run's
    messages."""
    data = _latency_scene()
    data["duration_s"] = 3.0
    fast = _run(data)
    paced = CaptureBus()
    Simulation(parse_scenario(data), bus=paced, tables=SceneTables(), realtime=50.0).run()
    assert paced.frames == fast.frames
    two = CaptureBus()
    Simulation(parse_scenario(data), bus=two, tables=SceneTables(), processes=2).run()
    assert two.frames == fast.frames


def _latency_errors(fixed_s: float, mean_s: float):
    from shipradar.sensors.sensor_errors import RadarErrors
    from shipradar.sim.world.scenario import Navigation, SensorErrors

    errors = SensorErrors.model_validate({"latency": {"fixed_s": fixed_s,
                                                      "random_mean_s": mean_s}})
    return RadarErrors(errors, Navigation(), seed=4, radar_id="r1", platform_id="ship",
                       sector_s=0.1)


def test_latencies_are_the_same_however_asked_and_exponential():
    """The engine asks a block's latencies at once: asked one by one, in uneven pieces or all
    at once, the draws are the same; they are the fixed delay plus an exponential law of the
    stated mean (seeded: mean within 4σ/√n, median at mean ln 2, none below the fixed)."""
    n = 20_000
    whole = _latency_errors(0.2, 1.5).latencies_s(n)
    pieces = _latency_errors(0.2, 1.5)
    sizes = [1, 0, 255, 256, 257, 1000, 3, n - 1772]
    got = np.concatenate([pieces.latencies_s(k) for k in sizes])
    np.testing.assert_array_equal(got, whole)
    x = whole - 0.2
    assert x.min() >= 0.0
    assert abs(x.mean() - 1.5) < 4.0 * 1.5 / math.sqrt(n)
    # median of an exponential: mean ln 2; its sampling 1σ ≈ mean/√n
    assert abs(np.median(x) - 1.5 * math.log(2.0)) < 4.0 * 1.5 / math.sqrt(n)
    fixed = _latency_errors(0.7, 0.0).latencies_s(5)
    assert fixed.tolist() == [0.7] * 5


def test_gauss_markov_refuses_a_forgotten_step():
    """A step before the path kept (:meth:`GaussMarkov.forget_before`) raises instead of
    wrapping round to the path's end."""
    gm = GaussMarkov(ErrorTerm(mean=0.0, sigma=1.0, correlation_time_s=10.0), 1.0,
                     np.random.default_rng(2))
    gm.forget_before(100.0)
    with pytest.raises(ValueError, match="grid step 5 was forgotten"):
        gm.at_index(np.array([5, 120]))
    assert gm.at_index(np.zeros(0, np.int64)).shape == (0,)
