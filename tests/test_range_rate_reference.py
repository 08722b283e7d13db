"""The range rate a tracker can unfold (issue 39, item 9): the bank's reference and span.

A C-band radar (λ = 5.35 cm, f_r = 2 kHz, a 16-filter DFT bank: span S = λ f_r/2 = 53.5 m/s,
filter spacing S/16 = 3.35 m/s) on a ship making 10 m/s, targets closing and receding up to
150 m/s (beyond ±S/2: folded). Checked against predictions made here from the truth alone:

- the published reference against the sea clutter's mean velocity written from the seed's
  [34]-[35] (ship speed along the beam and the waves' 0.5 m/s drift; the motion-compensated
  processor's f1 alone);
- every target plot's ``range_rate_mps`` against ``truth[plots].true_range_rate_mps`` folded
  into the published interval (reference − S/2, reference + S/2] and quantised to the nearest
  filter centre;
- unfolding ``range_rate_mps`` with reference and span gives back the true rate (within half
  a filter) when it is inside the interval, and with a tracker's prediction when it is not;
- ``fidelity.clutter`` off leaves every reported rate of the same target looks unchanged.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream import protocol
from shipradar.tables.scene import SceneTables, load_scene_tables

from .helpers import CaptureBus, moving_ship_scene, quiet_radar

N_FILTERS = 16
SHIP_SPEED = 10.0  # [m/s]
SHIP_COURSE_DEG = 60.0
WIND_FROM_DEG = 30.0
DRIFT = 0.5  # [m/s], the waves' drift of the seed's [35] ("a few knots (0.5 m/s)")
ANTENNA_HEIGHT = 20.0  # quiet_radar's [m]


def _scene(compensated: bool, clutter: bool):
    radar = quiet_radar(processor={"type": "dft_bank", "n_coherent": N_FILTERS,
                                   "motion_compensated": compensated},
                        instrumented_range_m=20000)
    targets = []
    for i in range(12):
        az = math.radians(i * 30.0 + 7.0)
        r0 = 9e3 + 500.0 * i
        v = -150.0 + 25.0 * i + 3.0  # radial [m/s], receding when positive
        pos = (r0 * math.sin(az), r0 * math.cos(az))
        targets.append({
            "id": f"t{i}", "rcs": {"type": "constant", "sigma_m2": 1e5}, "swerling": 0,
            "waypoints": [
                {"time_s": 0.0, "east_m": pos[0], "north_m": pos[1], "altitude_m": 50.0},
                {"time_s": 100.0, "east_m": pos[0] + 100.0 * v * math.sin(az),
                 "north_m": pos[1] + 100.0 * v * math.cos(az), "altitude_m": 50.0}]})
    return moving_ship_scene(radar, name="rr", duration_s=6.0, seed=11, speed_mps=SHIP_SPEED,
                             course_deg=SHIP_COURSE_DEG, wind_speed_mps=10.0,
                             wind_from_deg=WIND_FROM_DEG, clutter=clutter, targets=targets)


def _run(scenario, tables) -> dict:
    """Every target plot's columns, with its truth, and the span from ``meta``."""
    bus = CaptureBus()
    Simulation(scenario, bus=bus, tables=tables).run()
    span = bus.of(protocol.TOPIC_META)[0][1]["range_rate_span_mps"]
    plots = [p for _, p in bus.of(protocol.TOPIC_PLOTS)]
    truth = [p for _, p in bus.of(protocol.TOPIC_TRUTH) if p["kind"] == "plots"]
    cols = {k: np.concatenate([p[k] for p in plots])
            for k in ("plot_id", "time_s", "range_rate_mps", "range_rate_reference_mps",
                      "sigma_range_rate_mps", "range_m")}
    for k in ("plot_id", "origin", "target", "true_range_rate_mps", "true_azimuth_rad",
              "true_range_m"):
        cols["truth_" + k] = np.concatenate([p[k] for p in truth])
    assert (cols["plot_id"] == cols["truth_plot_id"]).all()
    keep = cols["truth_origin"] == 0
    out = {k: v[keep] for k, v in cols.items()}
    out["span"] = span
    return out


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The uncompensated radar with clutter modelled (its sea-clutter map, I_F and P_fac
    tables in a private cache) and without; the compensated one without."""
    old = os.environ.get("SHIPRADAR_TABLES")
    os.environ["SHIPRADAR_TABLES"] = str(tmp_path_factory.mktemp("tables"))
    try:
        on = _scene(False, True)
        return {"on": _run(on, load_scene_tables(on)),
                "off": _run(_scene(False, False), SceneTables()),
                "compensated": _run(_scene(True, False), SceneTables())}
    finally:
        if old is None:
            del os.environ["SHIPRADAR_TABLES"]
        else:
            os.environ["SHIPRADAR_TABLES"] = old


def _sea_reference_mps(run: dict, compensated: bool) -> np.ndarray:
    """The sea surface's range rate at each plot's true azimuth, seed [34]-[35] written here:
    the ship closes on the patch at v_s cos(θ − course) cos ψ_d, and the waves drift downwind
    at 0.5 m/s (towards the ship when looking upwind); a motion-compensated processor removes
    the ship's term and sets μ_c = 0, so its reference is the ship's term alone."""
    az = run["truth_true_azimuth_rad"]
    # ψ_d at the target's range: a few mrad at most here, kept to stay exact at 1e-6 m/s
    psi = np.arcsin(ANTENNA_HEIGHT / run["truth_true_range_m"])
    ship = SHIP_SPEED * np.cos(az - math.radians(SHIP_COURSE_DEG)) * np.cos(psi)
    drift = 0.0 if compensated else DRIFT * np.cos(az - math.radians(WIND_FROM_DEG))
    return -(ship + drift)


def _predicted_rate(true_rate, reference, span):
    """``true_rate`` folded into (reference − S/2, reference + S/2] and quantised to the
    nearest of the N filter centres reference + k S/N, −N/2 < k ≤ N/2; and the distance of
    the quantisation from a tie (in filters)."""
    q = span / N_FILTERS
    x = (true_rate - reference) / q
    k = np.round(x)
    k = k - N_FILTERS * np.ceil((k - N_FILTERS / 2) / N_FILTERS)
    return reference + k * q, np.abs(np.abs(x - np.round(x)) - 0.5)


@pytest.mark.parametrize("case", ["on", "compensated"])
def test_reference_is_the_sea_clutter_mean(runs, case):
    run = runs[case]
    assert run["range_rate_mps"].size > 40
    # ψ_d is taken at the ground range by the model and from the slant range here: 1e-6 m/s
    assert run["range_rate_reference_mps"] == pytest.approx(
        _sea_reference_mps(run, case == "compensated"), abs=1e-4)


@pytest.mark.parametrize("case", ["on", "off", "compensated"])
def test_rate_is_the_true_rate_folded_and_quantised(runs, case):
    run = runs[case]
    span = run["span"]
    lam = 299792458.0 / 5.6e9
    assert span == pytest.approx(lam * 2000.0 / 2.0, rel=1e-12)
    assert run["sigma_range_rate_mps"] == pytest.approx(span / N_FILTERS / math.sqrt(12.0),
                                                        rel=1e-12)
    predicted, tie = _predicted_rate(run["truth_true_range_rate_mps"],
                                     run["range_rate_reference_mps"], span)
    clear = tie > 1e-6
    assert clear.sum() > 40
    assert run["range_rate_mps"][clear] == pytest.approx(predicted[clear], abs=1e-6)
    # some plots come from beyond the interval: the fold is exercised
    outside = np.abs(run["truth_true_range_rate_mps"] - run["range_rate_reference_mps"])
    assert (outside > span / 2).sum() > 10


@pytest.mark.parametrize("case", ["on", "compensated"])
def test_unfolding_recovers_the_true_rate(runs, case):
    run = runs[case]
    span, q = run["span"], run["span"] / N_FILTERS
    rr, ref, true = (run["range_rate_mps"], run["range_rate_reference_mps"],
                     run["truth_true_range_rate_mps"])
    # inside the interval, away from its edges by half a filter (the edge filters straddle
    # ±S/2): the measured rate is the true one within half a filter, no fold
    inside = np.abs(true - ref) < span / 2 - q / 2
    assert inside.sum() > 10
    assert (np.abs(rr[inside] - true[inside]) <= q / 2 + 1e-9).all()
    # every measurement lies in the published interval
    assert ((rr > ref - span / 2 - 1e-9) & (rr <= ref + span / 2 + 1e-9)).all()
    # beyond it: a tracker's prediction within S/2 − q/2 of the truth picks the fold,
    # v = rr + k S with k = round((v_pred − rr) / S)
    rng = np.random.default_rng(5)
    pred = true + rng.uniform(-1.0, 1.0, true.size) * (span / 2 - q / 2)
    k = np.round((pred - rr) / span)
    assert (np.abs(rr + k * span - true) <= q / 2 + 1e-9).all()
    assert (k != 0).sum() > 10


def test_clutter_off_leaves_the_reported_rates_alone(runs):
    """The reference is the processor's: the same target looks report the same range rate
    whether the clutter's power is modelled or not (only which looks are detected
    changes)."""
    on, off = runs["on"], runs["off"]

    def by_look(run):
        return {(int(t), float(s)): (r, f) for t, s, r, f in zip(
            run["truth_target"], run["time_s"], run["range_rate_mps"],
            run["range_rate_reference_mps"], strict=True)}

    a, b = by_look(on), by_look(off)
    common = sorted(set(a) & set(b))
    assert len(common) > 40
    assert [a[k] for k in common] == [b[k] for k in common]


def test_filter_zero_at_a_zero_reference_is_plus_zero(runs):
    """A stationary ship's compensated bank has a zero reference: filter 0 reads +0.0."""
    from shipradar.sim.dwell.model import DwellModel

    s = _scene(True, False)
    p = s.platforms[0]
    m = DwellModel(s, p, p.radars[0], SceneTables())
    rate = m.range_rate_from_filter(np.zeros(40, dtype=np.int64), 0.0)
    assert (rate == 0.0).all() and not np.signbit(rate).any()
    one = m.range_rate_from_filter(np.array([0]), np.zeros(1))
    assert not np.signbit(one).any()
