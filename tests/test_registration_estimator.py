"""The template tracker's bias estimator (issue 33, item 6): on a synthetic two-radar
geometry whose plots come from shipradar's own truth-to-plot geometry
(:func:`shipradar.local_to_plot`, which the template does not import), it recovers known
range and azimuth biases of both radars, with targets at heights it does not know; its own
plot-to-local conversion agrees with :func:`shipradar.plot_to_local`."""

from __future__ import annotations

import importlib.util
import math
import sys

import numpy as np
import pytest

from shipradar import local_to_plot, plot_to_local
from tests.helpers import ROOT

_spec = importlib.util.spec_from_file_location("tracker_template",
                                               ROOT / "examples" / "tracker_template.py")
tpl = importlib.util.module_from_spec(_spec)
sys.modules["tracker_template"] = tpl
_spec.loader.exec_module(tpl)

ORIGIN = {"lat_deg": 44.6, "lon_deg": -63.0}
FRAME = tpl.local_frame(ORIGIN["lat_deg"])
# two antennas 31 km apart, the second well off the origin's meridian (true north there is
# 0.24° from the frame's grid north)
RADARS = {"a": np.array([0.0, 0.0, 22.0]), "b": np.array([30_000.0, 8_000.0, 18.0])}
BIASES = {"a": (150.0, math.radians(0.3)), "b": (-60.0, math.radians(-0.12))}


def _estimate(n, sigma, seed, per_target=5):
    """``n`` pairs of plots of ``n / per_target`` targets at 50-9000 m, each seen at
    ``per_target`` places spread over the common coverage."""
    rng = np.random.default_rng(seed)
    est = tpl.BiasEstimator(FRAME)
    target = np.arange(n) // per_target
    heights = rng.uniform(50.0, 9_000.0, target[-1] + 1)
    targets = np.column_stack([rng.uniform(-20_000.0, 50_000.0, n),
                               rng.uniform(10_000.0, 60_000.0, n), heights[target]])
    rows = {}
    for s, pos in RADARS.items():
        g = local_to_plot(targets, pos, ORIGIN)
        noise = rng.normal(0.0, 1.0, (2, n)) * np.array(sigma)[:, None]
        r = g.range_m + BIASES[s][0] + noise[0]
        az = g.azimuth_rad + BIASES[s][1] + noise[1]
        rows[s] = [(0.0, r[i], az[i], max(sigma[0], 1.0), max(sigma[1], 1e-5), *pos)
                   for i in range(n)]
    for i, (ra, rb) in enumerate(zip(rows["a"], rows["b"], strict=True)):
        est.add("a", ra, "b", rb, np.zeros(2), 0.0, target[i])
    est.solve()
    return est


def test_plot_to_local_agrees_with_shipradar():
    rng = np.random.default_rng(9)
    r = rng.uniform(2_000.0, 90_000.0, 200)
    az = rng.uniform(0.0, 2 * math.pi, 200)
    h = rng.uniform(0.0, 9_000.0, 200)
    ant = np.tile(RADARS["b"], (200, 1))
    ok = r > np.abs(h - ant[:, 2]) / 0.9
    mine = tpl.plot_to_local(r[ok], az[ok], ant[ok], h[ok], FRAME)
    ref = plot_to_local(r[ok], az[ok], RADARS["b"], ORIGIN, h[ok])[:, :2]
    np.testing.assert_allclose(mine, ref, rtol=0, atol=1e-4)
    assert np.isnan(tpl.plot_to_local(np.array([100.0]), np.array([0.0]), ant[:1],
                                      np.array([500.0]), FRAME)).all()


def test_noise_free_pairs_recover_the_biases():
    """Without noise: every bias within 0.5 m and 0.0005° (the finite differences' and the
    fit's tolerance), at least 90 % of the pairs kept (a few high targets near an
    antenna settle at another height than theirs and are left out)."""
    est = _estimate(200, (0.0, 0.0), seed=1)
    assert est.cov is not None and est.inliers >= 180
    for i, s in enumerate(("a", "b")):
        assert est.beta[2 * i] == pytest.approx(BIASES[s][0], abs=0.5)
        assert est.beta[2 * i + 1] == pytest.approx(BIASES[s][1], abs=math.radians(0.0005))


@pytest.mark.parametrize("seed", [2, 3])
def test_noisy_pairs_recover_the_biases_within_the_stated_sigma(seed):
    """With the plots' noise (20 m, 0.15°: a surveillance radar's), 300 pairs: each bias
    within 4 of its stated σ, the stated σ below 20 m and 0.03°; at most 5 % of the pairs
    left out as outliers."""
    est = _estimate(300, (20.0, math.radians(0.15)), seed=seed)
    assert est.cov is not None
    sig = np.sqrt(np.diag(est.cov))
    assert np.all(sig[0::2] < 20.0) and np.all(sig[1::2] < math.radians(0.03))
    truth = np.array([*BIASES["a"], *BIASES["b"]])
    assert np.all(np.abs(est.beta - truth) < 4 * sig), (est.beta - truth) / sig
    assert est.inliers >= 285


def test_nothing_published_before_enough_pairs():
    est = _estimate(tpl.MIN_PAIRS - 1, (20.0, math.radians(0.15)), seed=4)
    assert est.cov is None and est.messages(10.0) == []
    assert est.correction("a") == (0.0, 0.0)
    est = _estimate(tpl.MIN_PAIRS + 60, (20.0, math.radians(0.15)), seed=4)
    msgs = est.messages(10.0)
    assert [m[0] for m in msgs] == [b"registration", b"registration"]


@pytest.mark.slow
def test_template_on_the_registration_scene_with_and_without_estimation(tmp_path):
    """``shipradar evaluate``'s harness on scenarios/registration.yaml (90 s, one seed): the
    template with ``--estimate-bias`` publishes registration estimates for both radars, which
    are scored (RMSE and time to converge), and its GOSPA localisation part is smaller than
    the same template's without (the same plots: the same seed)."""
    import shlex

    from shipradar.sim.studies.evaluate.data import load_run
    from shipradar.sim.studies.evaluate.metrics import score_run
    from shipradar.sim.studies.evaluate.runner import RunSpec, run_tracker_command

    scene = str(ROOT / "scenarios" / "registration.yaml")
    cmd = (f"{shlex.quote(sys.executable)} "
           f"{shlex.quote(str(ROOT / 'examples' / 'tracker_template.py'))} {{plots}} {{tracks}}")
    scores = {}
    for name, extra in (("with", " --estimate-bias"), ("without", "")):
        spec = RunSpec(scene, 5, str(tmp_path / name), cmd + extra, duration_s=90.0)
        info = run_tracker_command(spec)
        assert info["status"] == "ok", info
        scores[name] = score_run(load_run(spec.run_dir)).run
    w, wo = scores["with"], scores["without"]
    assert w["malformed_messages"] == 0 and w["registration_messages"] > 0
    for s in ("giraffe_a", "giraffe_b"):
        assert math.isfinite(w[f"registration_{s}_rmse_range_bias_m"])
        assert math.isfinite(w[f"registration_{s}_rmse_azimuth_bias_deg"])
        assert f"registration_{s}_range_bias_m_converge_s" in w
        # better than not estimating at all (an estimate of 0: RMSE = the true bias)
    assert w["registration_giraffe_a_rmse_range_bias_m"] < 150.0
    assert w["registration_giraffe_a_rmse_azimuth_bias_deg"] < 0.3
    assert "registration_messages" not in wo or wo["registration_messages"] == 0
    assert w["localisation"] < wo["localisation"], (w["localisation"], wo["localisation"])
