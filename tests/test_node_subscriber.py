"""The Node.js reference subscriber (``examples/node_subscriber``, issue 39 item 10) against a
live ``shipradar run --publish``: a second decoder, outside Python, written from
docs/protocol.md and the shipped JSON Schemas. It validates every message with ajv (strict,
draft-07), decodes the msgpack extension columns (section 3), places the plots (4.0, 4.1),
unfolds the range rate (4.2) and stops on ``end``.

Node.js and npm come from Debian (installed here when missing, as root; under ``CI`` the test
fails rather than skips without them); the packages from the npm registry with ``npm ci``
from the example's ``package-lock.json``, into a cache directory kept across runs (the
system's temporary directory, or ``SHIPRADAR_NODE_SUBSCRIBER_DIR``).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from tests.helpers import ROOT, free_port, require_system_tool

EXAMPLE = ROOT / "examples/node_subscriber"
CONTRACT = ROOT / "sim/stream/contract"
FILES = ("package.json", "package-lock.json", "subscriber.mjs")


def _installed_example() -> Path:
    """A directory holding the example and its ``node_modules`` (``npm ci``), keyed by the
    lock file so that a changed lock installs afresh."""
    require_system_tool(lambda: shutil.which("node"), "nodejs")
    npm = require_system_tool(lambda: shutil.which("npm"), "npm")
    lock = (EXAMPLE / "package-lock.json").read_bytes()
    key = hashlib.sha256(lock + (EXAMPLE / "package.json").read_bytes()).hexdigest()[:12]
    where = Path(os.environ.get("SHIPRADAR_NODE_SUBSCRIBER_DIR",
                                Path(tempfile.gettempdir()) / f"shipradar-node-subscriber-{key}"))
    where.mkdir(parents=True, exist_ok=True)
    for name in FILES:
        shutil.copyfile(EXAMPLE / name, where / name)
    if not (where / "node_modules/.package-lock.json").exists():
        proc = subprocess.run([npm, "ci", "--no-audit", "--no-fund"], cwd=where,
                              capture_output=True, text=True, timeout=600)
        if proc.returncode != 0:
            message = f"npm ci failed in {where}: {proc.stderr[-1500:]}"
            if os.environ.get("CI"):
                pytest.fail(message)
            pytest.skip(message)
    return where


def test_example_declares_its_packages():
    """zeromq, @msgpack/msgpack and ajv, pinned, and the lock file agrees."""
    package = json.loads((EXAMPLE / "package.json").read_text(encoding="utf-8"))
    lock = json.loads((EXAMPLE / "package-lock.json").read_text(encoding="utf-8"))
    deps = package["dependencies"]
    assert set(deps) == {"zeromq", "@msgpack/msgpack", "ajv"}
    for name, version in deps.items():
        assert lock["packages"][f"node_modules/{name}"]["version"] == version
    assert lock["packages"][""]["dependencies"] == deps


# the two tests that install share one cache directory: on one xdist worker (make test's
# --dist loadgroup), never two npm ci at once in it
@pytest.mark.slow
@pytest.mark.xdist_group("node_subscriber")
def test_node_subscriber_on_a_live_run():
    """Manoeuvres (a fir_bank radar, a turning ship, fighters beyond the unambiguous
    range rate), 60 simulated s, published on a free loopback port; the subscriber holds the
    first message with ``--wait-subscribers 1`` and stops on ``end`` by itself."""
    where = _installed_example()
    endpoint = f"tcp://127.0.0.1:{free_port()}"
    run = subprocess.Popen(
        [sys.executable, "-m", "shipradar.sim.cli", "run", "--example", "manoeuvres",
         "--duration", "60", "--quiet", "--publish", endpoint, "--wait-subscribers", "1",
         "--wait-timeout", "120"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        node = subprocess.run(
            ["node", str(where / "subscriber.mjs"), endpoint, "--schemas", str(CONTRACT),
             "--idle-s", "120"], capture_output=True, text=True, timeout=400)
        out, err = run.communicate(timeout=120)
    finally:
        if run.poll() is None:
            run.kill()
            run.communicate()
    assert run.returncode == 0, err[-2000:]
    assert node.returncode == 0, (node.stdout[-2000:], node.stderr[-2000:])
    got = json.loads(node.stdout.strip().splitlines()[-1])
    sent = json.loads(out.strip().splitlines()[-1])["bus"]["publisher"]["sent_by_topic"]
    # every message heard and valid, the run's end seen
    assert got["counts"] == sent
    assert got["schema_failures"] == 0, got["failure_examples"]
    assert got["ended"] is True
    # the ext data at odd offsets: the copy before the typed-array view was needed
    assert 0 < got["columns_unaligned"] <= got["columns"]
    # plots placed with meta's antenna state (4.1) reproduce the truth within sigma (4.2)
    assert set(got["placed_with"]) == {"meta"}
    for name in ("z_range", "z_azimuth"):
        z = got[name]
        assert z["n"] >= 100, z
        assert abs(z["mean"]) < 4.0 / z["n"] ** 0.5, (name, z)
        assert 0.7 < z["std"] < 1.3, (name, z)
    assert got["roundtrip_max"] < 1e-3
    # range rate: every measurement in its published interval; inside it the true rate
    # within half a filter, beyond it unfolded by a prediction
    rr = got["range_rate"]
    assert rr["outside_interval"] == 0
    assert rr["unfolded"] > 10
    assert rr["max_error_inside_mps"] <= rr["half_filter_mps"] + 1e-9
    assert rr["max_error_unfolded_mps"] <= rr["half_filter_mps"] + 1e-9


@pytest.mark.slow
@pytest.mark.xdist_group("node_subscriber")
def test_node_subscriber_refuses_a_wrong_message():
    """A publisher here sends a recorded run's first messages, one of them altered (a plot
    column of strings), then ``end``: the subscriber counts exactly one schema failure and
    exits 1. The publisher waits for the subscription (an XPUB's subscription message), not
    for a fixed time."""
    import numpy as np
    import zmq

    from shipradar.sim.stream import protocol
    from shipradar.sim.stream.recording import read_recording

    where = _installed_example()
    frames = []
    with read_recording(ROOT / "tests/golden/single_missile.rec") as reader:
        for _t, f in reader:
            frames.append(f)
            if f[0] == b"plots":
                break
    topic, t, body = protocol.decode(frames[-1])
    bad = dict(body, range_m=[str(x) for x in np.asarray(body["range_m"])])
    frames[-1] = protocol.encode(topic, t, bad)
    frames.append(protocol.encode(b"end", t, {"time_s": t, "sensors": [body["sensor"]],
                                              "scans": [1]}))
    ctx = zmq.Context.instance()
    pub = ctx.socket(zmq.XPUB)
    pub.setsockopt(zmq.LINGER, 5000)
    port = pub.bind_to_random_port("tcp://127.0.0.1")
    node = subprocess.Popen(
        ["node", str(where / "subscriber.mjs"), f"tcp://127.0.0.1:{port}", "--schemas",
         str(CONTRACT), "--idle-s", "60"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True)
    try:
        assert pub.poll(60_000), "no subscription within 60 s"
        assert pub.recv()[:1] == b"\x01"  # a subscribe message
        for f in frames:
            pub.send_multipart(f)
        out, err = node.communicate(timeout=120)
    finally:
        if node.poll() is None:
            node.kill()
            node.communicate()
        pub.close()
    assert node.returncode == 1, (out, err)
    got = json.loads(out.strip().splitlines()[-1])
    assert got["schema_failures"] == 1, got
    assert got["failure_examples"][0].startswith("plots: /range_m/0 must be number"), got
    assert got["ended"] is True
    assert sum(got["counts"].values()) == len(frames)
