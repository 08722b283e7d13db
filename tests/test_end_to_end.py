"""End to end: CLI run publishing over ZeroMQ and recording; replay; determinism; truncation."""

import json
import os
import subprocess
import sys
import threading

import pytest
import zmq

from shipradar.sim.stream.recording import read_recording

from .helpers import ROOT, free_port

FAST = ["--duration", "12"]


def _cli(*argv, env=None, timeout=300):
    return subprocess.run([sys.executable, "-m", "shipradar.sim.cli", *argv], capture_output=True,
                          text=True, cwd=ROOT, timeout=timeout, env=env)


@pytest.fixture(scope="module")
def env(tmp_path_factory):
    e = dict(os.environ)
    e["SHIPRADAR_TABLES"] = str(tmp_path_factory.mktemp("tables"))
    return e


def _subscriber(endpoint, frames, ready, done):
    ctx = zmq.Context.instance()
    sub = ctx.socket(zmq.SUB)
    sub.setsockopt(zmq.LINGER, 0)
    sub.setsockopt(zmq.SUBSCRIBE, b"")
    sub.connect(endpoint)
    ready.set()
    poller = zmq.Poller()
    poller.register(sub, zmq.POLLIN)
    try:
        # stop once the publisher has finished and nothing more arrives
        while True:
            if poller.poll(500):
                frames.append(sub.recv_multipart())
            elif done.is_set():
                break
    finally:
        sub.close()


def _recorded(path):
    reader = read_recording(path)
    msgs = [list(f) for _, f in reader]
    return msgs, reader


@pytest.mark.slow
def test_publish_equals_recording_then_replay_identical(tmp_path, env):
    rec = tmp_path / "run.rec"
    endpoint = f"tcp://127.0.0.1:{free_port()}"
    got, ready, done = [], threading.Event(), threading.Event()
    th = threading.Thread(target=_subscriber, args=(endpoint, got, ready, done), daemon=True)
    th.start()
    ready.wait(10)
    proc = _cli("run", "scenarios/single_missile.yaml", *FAST, "--record", str(rec),
                "--publish", endpoint, "--wait-subscribers", "1", "--quiet", env=env)
    done.set()
    th.join(30)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    for key in ("scans", "dwells", "target_plots", "missed_detections", "noise_false_alarms",
                "clutter_false_alarms", "simulated_s", "wall_s", "realtime_factor"):
        assert key in summary
    assert summary["scans"] == 12 and summary["dwells"] >= 11
    recorded, reader = _recorded(rec)
    assert not reader.truncated
    assert [list(map(bytes, f)) for f in got] == recorded
    topics = {f[0] for f in recorded}
    assert {b"meta", b"plots", b"eos", b"truth"} <= topics

    # replay to a new endpoint, as fast as the subscriber takes it: byte-identical
    endpoint2 = f"tcp://127.0.0.1:{free_port()}"
    got2, ready2, done2 = [], threading.Event(), threading.Event()
    th2 = threading.Thread(target=_subscriber, args=(endpoint2, got2, ready2, done2), daemon=True)
    th2.start()
    ready2.wait(10)
    proc2 = _cli("replay", str(rec), "--publish", endpoint2, "--fast", "--wait-subscribers", "1",
                 env=env)
    done2.set()
    th2.join(30)
    assert proc2.returncode == 0, proc2.stderr
    assert [list(map(bytes, f)) for f in got2] == recorded


@pytest.mark.slow
def test_same_seed_same_bytes_other_seed_differs(tmp_path, env):
    paths = []
    for name, seed in (("a", "4"), ("b", "4"), ("c", "5")):
        p = tmp_path / f"{name}.rec"
        proc = _cli("run", "scenarios/single_missile.yaml", *FAST, "--seed", seed,
                    "--record", str(p), "--quiet", env=env)
        assert proc.returncode == 0, proc.stderr
        paths.append(p.read_bytes())
    assert paths[0] == paths[1]
    assert paths[0] != paths[2]


@pytest.mark.slow
def test_truncated_recording_replays_whole_frames(tmp_path, env):
    rec = tmp_path / "t.rec"
    assert _cli("run", "scenarios/single_missile.yaml", *FAST, "--record", str(rec), "--quiet",
                env=env).returncode == 0
    whole, _ = _recorded(rec)
    data = rec.read_bytes()
    cut = tmp_path / "cut.rec"
    cut.write_bytes(data[: len(data) - 7])  # kill -9 in the middle of the last record
    msgs, reader = _recorded(cut)
    assert msgs == whole[:-1]
    assert reader.truncated and reader.bytes_ignored > 0
    proc = _cli("replay", str(cut), "--fast", env=env)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["frames"] == len(whole) - 1 and out["truncated"] is True
    assert out["bytes_ignored"] == reader.bytes_ignored
    assert (f"warning: {cut} is truncated: {len(whole) - 1} whole frame(s) replayed, "
            f"{reader.bytes_ignored} byte(s) of a partial last frame ignored") in proc.stderr
    # without --publish every replayed frame is also printed as a JSON line
    lines = proc.stdout.strip().splitlines()[:-1]
    assert len(lines) == len(whole) - 1
    assert {json.loads(x)["topic"] for x in lines} >= {"meta", "plots", "eos", "truth"}


@pytest.mark.slow
def test_record_refuses_to_overwrite(tmp_path, env):
    rec = tmp_path / "keep.rec"
    rec.write_bytes(b"precious")
    proc = _cli("run", "scenarios/single_missile.yaml", *FAST, "--record", str(rec), env=env)
    assert proc.returncode == 2 and "--overwrite" in proc.stderr
    assert rec.read_bytes() == b"precious"


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(p.stem for p in (ROOT / "scenarios").glob("*.yaml")))
def test_every_example_runs(name, env, tmp_path):
    proc = _cli("run", f"scenarios/{name}.yaml", "--duration", "20", "--quiet",
                "--record", str(tmp_path / "x.rec"), env=env)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    assert summary["scans"] >= 1


@pytest.mark.slow
def test_jammed_squall_sees_each_interference(env):
    """The jamming-and-rain example: contacts are limited by noise, by clutter (sea and the
    squall's weather clutter) and by the escort jammer, each at least once."""
    proc = _cli("run", "scenarios/jammed_squall.yaml", "--quiet", env=env)
    assert proc.returncode == 0, proc.stderr
    dom = json.loads(proc.stdout.strip().splitlines()[-1])["dominant_interference"]
    assert min(dom.values()) > 0, dom


@pytest.mark.slow
def test_progress_bar_only_on_a_terminal(tmp_path, env):
    """stderr on a pseudo-terminal: a progress bar; on a pipe: none (the summary alone)."""
    import fcntl
    import pty
    import struct
    import termios

    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))  # 100 columns
    chunks = []
    try:
        proc = subprocess.Popen(
            [sys.executable, "-m", "shipradar.sim.cli", "run", "scenarios/single_missile.yaml",
             "--duration", "30"], stdout=subprocess.PIPE, stderr=slave, cwd=ROOT, env=env)
        os.close(slave)
        while True:  # read while it runs: Linux drops a pty's data once its child side closes
            try:
                data = os.read(master, 65536)
            except OSError:  # EIO: the child side is closed
                break
            if not data:
                break
            chunks.append(data)
        out, _ = proc.communicate(timeout=300)
    finally:
        os.close(master)
    assert proc.returncode == 0
    tty_err = b"".join(chunks).decode(errors="replace")
    assert "sim s" in tty_err and "30/30" in tty_err  # tqdm's bar, run to the end
    assert json.loads(out.decode().strip().splitlines()[-1])["simulated_s"] == 30
    piped = _cli("run", "scenarios/single_missile.yaml", "--duration", "30", env=env)
    assert piped.returncode == 0 and "sim s" not in piped.stderr
