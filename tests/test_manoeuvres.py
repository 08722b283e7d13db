"""scenarios/manoeuvres.yaml end to end: truth accelerations, range rates, and the example
tracker's IMM option holding the weaving sea-skimmer.

Measured on this scene (seed 17, 100 s, docs/studies.md, before issue 16 changed the order
of the random draws): constant-velocity EKF mean OSPA 520 m with 13 confirmed tracks, IMM
(CV + coordinated turns at ±0.2 rad/s) 400 m with 5; the IMM holds the skimmer (a confirmed
track within 300 m) in 62 of the 65 scans from the 11th to its pop-up's end, RMS 75 m (the
CV filter 128 m).  One seed's hold varies: 0.75-1.0 of the scans over seeds 1-5 and 17,
mean OSPA 340-770 m, with the code before and after that change alike; the test pools three
seeds.
"""

import importlib.util
import math
import subprocess
import sys

import numpy as np
import pytest

from shipradar.sim.stream import protocol
from shipradar.sim.stream.recording import read_recording

from .helpers import ROOT

#: Distance under which the nearest confirmed track holds a target [m].
HOLD_M = 300.0


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    rec = tmp_path_factory.mktemp("man") / "man.shr"
    proc = subprocess.run([sys.executable, "-m", "shipradar.sim.cli", "run",
                           "scenarios/manoeuvres.yaml", "--record", str(rec)], cwd=ROOT,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return rec


def _messages(path):
    with read_recording(path) as reader:
        return [protocol.decode(frames) for _, frames in reader]


@pytest.mark.slow
def test_truth_accelerations_and_range_rates(recording):
    msgs = _messages(recording)
    truth = [p for topic, _, p in msgs if topic == protocol.TOPIC_TRUTH
             and p["kind"] == "targets"]
    acc = np.array([[p["a_east_mps2"][0], p["a_north_mps2"][0], p["a_up_mps2"][0]]
                    for p in truth])
    # the weave's peak lateral acceleration A (2π/P)² = 120 (2π/8)² = 74 m/s² (NaN while the
    # target is not active: schema 2)
    assert np.nanmax(np.hypot(acc[:, 0], acc[:, 1])) == pytest.approx(120 * (2 * math.pi / 8) ** 2,
                                                                 rel=0.02)
    plots = [p for topic, _, p in msgs if topic == protocol.TOPIC_PLOTS]
    rr = np.concatenate([p["range_rate_mps"] for p in plots])
    sig = np.concatenate([p["sigma_range_rate_mps"] for p in plots])
    lam = 299_792_458.0 / 5.6e9
    limit = 5000 * lam / 4
    assert np.isfinite(rr).all() and (np.abs(rr) <= limit + 1e-9).all()
    assert sig == pytest.approx(lam / 2 * 5000 / (8 * math.sqrt(12)))
    # the ship's heading follows its turn: 0° before 30 s, 90° after 120 s
    eos = [p for topic, _, p in msgs if topic == protocol.TOPIC_EOS]
    head = {round(p["time_s"]): p["heading_deg"] for p in eos}
    assert head[10] == pytest.approx(0.0, abs=1e-6) or head[10] == pytest.approx(360.0)
    assert head[75] == pytest.approx(45.0, abs=1e-6)


def _track_module():
    spec = importlib.util.spec_from_file_location(
        "track_stonesoup", ROOT / "examples" / "track_stonesoup.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _imm_hold(recording):
    """The IMM tracker's hold on the skimmer (target 0): per scan from the 11th (after
    confirmation) with all three targets active, whether the nearest confirmed track is
    within HOLD_M, the held distances, and the run's mean OSPA."""
    res = _track_module().track(str(recording), imm=True)
    dist = [s["nearest_m"][0] for s in res["scans"][10:] if s["truths"] == 3]
    held = np.array([d is not None and d < HOLD_M for d in dist])
    err = np.array([d for d in dist if d is not None and d < HOLD_M])
    return held, err, res["mean_ospa"]


@pytest.mark.slow
def test_imm_holds_the_weaving_missile(recording, tmp_path):
    # one seed's hold varies (0.75-1.0 of the scans over seeds 1-5 and 17): pooled over
    # three seeds (the scene's 17, then 1 and 2)
    recs = [recording]
    for seed in (1, 2):
        scene = tmp_path / f"seed{seed}.yaml"
        text = (ROOT / "scenarios" / "manoeuvres.yaml").read_text()
        scene.write_text(text.replace("\nseed: 17\n", f"\nseed: {seed}\n"))
        assert f"seed: {seed}" in scene.read_text()
        rec = tmp_path / f"seed{seed}.shr"
        proc = _cli("run", str(scene), "--record", str(rec))
        assert proc.returncode == 0, proc.stderr
        recs.append(rec)
    runs = [_imm_hold(r) for r in recs]
    held = np.concatenate([h for h, _, _ in runs])
    err = np.concatenate([e for _, e, _ in runs])
    assert held.size >= 180
    assert held.mean() >= 0.85
    assert np.sqrt(np.mean(err**2)) < 100.0
    assert np.mean([o for _, _, o in runs]) < 600.0


def _cli(*argv, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "shipradar.sim.cli", *argv], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


@pytest.mark.slow
def test_authoring_aids_explain_and_geometry(tmp_path):
    proc = _cli("validate", "--explain", "scenarios/manoeuvres.yaml")
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    assert "resolved scene (every default filled in, units in brackets):" in out
    # defaults the file does not write, with their units
    assert "      cfar_db: 1.5  [dB]" in out
    assert "    sectors_per_scan: 36" in out
    assert "targets[0] skimmer: segments, 5 piece(s), 0-75.0 s" in out
    assert "altitude 5-250 m" in out
    proc = _cli("plot", "scenarios/manoeuvres.yaml", "geometry", "--out", str(tmp_path),
                "--height", "5")
    assert proc.returncode == 0, proc.stderr
    png = tmp_path / "geometry.png"
    assert proc.stdout.strip() == str(png) and png.read_bytes()[:4] == b"\x89PNG"


def test_bad_manoeuvre_is_one_line_naming_the_field(tmp_path):
    text = (ROOT / "scenarios" / "manoeuvres.yaml").read_text()
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace("{type: weave, amplitude_m: 120, period_s: 8",
                                "{type: weave, amplitude_m: 500, period_s: 8"))
    proc = _cli("validate", str(bad))
    assert proc.returncode == 2
    assert ("targets[0].segments[1].amplitude_m: a weave of period 8 s at 290 m/s must have "
            "amplitude < 369.2 m (lateral speed 2πA/P below the speed), got 500") in proc.stderr
