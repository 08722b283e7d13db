"""Hard limits: memory budget before any work, disk full while recording, SIGTERM/Ctrl-C.

Each run is a real ``shipradar run`` in a subprocess; the table cache is built once for the
module, outside any file-size limit.
"""

from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import sys
import time

import pytest
import yaml

from shipradar.sim.cli import main
from shipradar.sim.stream.recording import read_recording, verify_recording
from shipradar.sim.world.scenario import parse_scenario
from shipradar.tables.budget import check_memory_budget, estimate_tables

from .helpers import ROOT

SCENE = "scenarios/single_missile.yaml"


@pytest.fixture(scope="module")
def env(tmp_path_factory):
    e = dict(os.environ)
    e["SHIPRADAR_TABLES"] = str(tmp_path_factory.mktemp("tables"))
    proc = subprocess.run([sys.executable, "-m", "shipradar.sim.cli", "tables", "build", SCENE],
                          capture_output=True, text=True, cwd=ROOT, env=e, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return e


def _big_radar_scene() -> dict:
    d = yaml.safe_load((ROOT / "scenarios/raid.yaml").read_text())
    radar = d["platforms"][0]["radars"][1]
    radar["frequency_hz"] = 9.5e10  # a W-band radar: the PE height step is ~0.9 mm
    radar["instrumented_range_m"] = 400000.0
    return d


# -- memory budget ---------------------------------------------------------------------------
def test_memory_budget_refuses_with_size_and_field(tmp_path, capsys, monkeypatch):
    big = tmp_path / "big.yaml"
    big.write_text(yaml.safe_dump(_big_radar_scene(), sort_keys=False))
    monkeypatch.setenv("SHIPRADAR_TABLES", str(tmp_path / "never-built"))
    t0 = time.perf_counter()
    assert main(["run", str(big), "--record", str(tmp_path / "x.rec")]) == 2
    err = capsys.readouterr().err
    assert time.perf_counter() - t0 < 30  # refused up front, not after building
    assert err.startswith("platforms[0].radars[1].frequency_hz: the scene's tables need an "
                          "estimated ")
    assert "over the memory budget of 4.0 GiB (--memory-budget)" in err
    assert "PE table" in err and err.count("\n") == 1
    assert not (tmp_path / "x.rec").exists() and not (tmp_path / "never-built").exists()
    assert main(["tables", "build", str(big)]) == 2
    assert capsys.readouterr().err == err


def test_memory_budget_option_and_environment(tmp_path, capsys, monkeypatch):
    scene = parse_scenario(yaml.safe_load((ROOT / SCENE).read_text()))
    total = sum(e.bytes for e in estimate_tables(scene))
    assert 1 << 20 < total < 1 << 30
    assert check_memory_budget(scene) == total
    with pytest.raises(ValueError, match=r"instrumented_range_m: .*over the memory budget of "
                                         r"1\.0 MiB"):
        check_memory_budget(scene, 1 << 20)
    assert main(["run", SCENE, "--memory-budget", "1"]) == 2
    assert "over the memory budget of 1.0 MiB (--memory-budget)" in capsys.readouterr().err
    monkeypatch.setenv("SHIPRADAR_MEMORY_BUDGET_MIB", "2")
    assert main(["validate", SCENE]) == 0  # validation does not estimate tables
    assert main(["tables", "build", SCENE]) == 2
    assert "over the memory budget of 2.0 MiB" in capsys.readouterr().err


def test_the_budget_grows_with_the_field_it_names():
    d = _big_radar_scene()
    sizes = []
    for f in (5.6e9, 2e10, 9.5e10):
        d["platforms"][0]["radars"][1]["frequency_hz"] = f
        est = {e.radar_id: e for e in estimate_tables(parse_scenario(d))
               if e.kind == "propagation"}
        sizes.append(est["giraffe"].bytes)
    assert sizes[0] < sizes[1] < sizes[2]


# -- disk full -------------------------------------------------------------------------------
def _limit_file_size():
    resource.setrlimit(resource.RLIMIT_FSIZE, (120_000, 120_000))
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)


@pytest.mark.slow
def test_disk_full_ends_the_run_with_a_valid_recording(tmp_path, env):
    rec = tmp_path / "full.rec"
    proc = subprocess.run(
        [sys.executable, "-m", "shipradar.sim.cli", "run", SCENE, "--duration", "120",
         "--record", str(rec), "--quiet"], capture_output=True, text=True, cwd=ROOT, env=env,
        timeout=300, preexec_fn=_limit_file_size)
    assert proc.returncode == 1, proc.stderr
    first = proc.stderr.splitlines()[0]
    assert first.startswith(f"error: recording {rec}: cannot write (file size limit reached); "
                            "it keeps its first ")
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    assert summary["error"] == first.removeprefix("error: ")
    size = rec.stat().st_size
    assert 100_000 < size <= 120_000
    report = verify_recording(rec)
    assert report["status"] == "clean" and report["bytes"] == size
    assert report["records"] == summary["bus"]["recorder"]["records"] > 100
    assert f"it keeps its first {report['records']} record(s), {size} bytes" in first


# -- signals ---------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_signal_mid_run_closes_the_recording_and_prints_the_summary(tmp_path, env, sig):
    rec = tmp_path / "sig.rec"
    proc = subprocess.Popen(
        [sys.executable, "-m", "shipradar.sim.cli", "run", SCENE, "--realtime", "4",
         "--record", str(rec), "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True, cwd=ROOT, env=env)
    try:
        deadline = time.monotonic() + 120
        # the engine flushes at every end of scan: wait until one scan is on disk
        while time.monotonic() < deadline and proc.poll() is None:
            if rec.exists() and rec.stat().st_size > 4000:
                break
            time.sleep(0.05)
        assert proc.poll() is None, proc.communicate()
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 128 + sig, err
    summary = json.loads(out.strip().splitlines()[-1])
    assert summary["interrupted"] is True
    assert 0 < summary["simulated_s"] < 60
    assert f"interrupted ({signal.Signals(sig).name})" in err
    report = verify_recording(rec)
    assert report["status"] == "clean"
    assert report["records"] == summary["bus"]["recorder"]["records"]
    assert report["t_last"] == summary["simulated_s"]
    with read_recording(rec, strict=True) as reader:
        topics = [bytes(f[0]) for _, f in reader]
    assert topics[-2:] == [b"eos", b"truth"]  # it ended on a whole scan
