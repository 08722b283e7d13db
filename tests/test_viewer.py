"""shipradar view without a browser: wire format, bad input, and a stalled page on a live run."""

from __future__ import annotations

import base64
import os
import socket
import time
from collections import Counter

import numpy as np
import pytest

from shipradar.sim.adapters.viewer.server import (
    HostError,
    ViewerServer,
    ViewerThread,
    check_http_host,
)
from shipradar.sim.adapters.viewer.wire import ViewError, pack_batch, to_view, unpack_batch
from shipradar.sim.cli import main
from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream import protocol
from shipradar.sim.stream.bus import Bus, Publisher
from shipradar.sim.stream.recording import Recorder, read_recording
from shipradar.sim.world.scenario import load_scenario
from tests.helpers import ROOT, free_port

DEMO = ROOT / "scenarios" / "single_missile.yaml"
# the run's counters a viewer must not change
COUNTS = ("scans", "sectors", "dwells", "target_plots", "missed_detections",
          "noise_false_alarms", "clutter_false_alarms")


def wait_until(pred, timeout_s: float = 20.0, what: str = "condition"):
    """Poll ``pred`` (cheap, cross-thread state) until true; fail after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not pred():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.02)


@pytest.fixture(scope="module")
def demo_recording(tmp_path_factory):
    """The demo scenario recorded whole (110 scans, target plots from 16 s to 85 s), and what
    it holds: plots per (sensor, scan) by origin, and every target plot's position."""
    path = tmp_path_factory.mktemp("viewer") / "demo.rec"
    s = load_scenario(DEMO)
    with Bus(recorder=Recorder(path)) as bus:
        Simulation(s, bus=bus).run()
    per_scan: dict[tuple[str, int], Counter] = {}
    targets = []
    plots = {}
    with read_recording(path) as reader:
        for _t, frames in reader:
            topic, t, p = protocol.decode(frames)
            if topic == b"plots":
                plots[(p["sensor"], int(p["plot_id"][0]))] = (t, p)
                c = per_scan.setdefault((p["sensor"], p["scan"]), Counter())
                c["total"] += p["plot_id"].size
            elif topic == b"truth" and p["kind"] == "plots":
                t_msg, pp = plots[(p["sensor"], int(p["plot_id"][0]))]
                c = per_scan[(p["sensor"], p["scan"])]
                for name, code in (("target", 0), ("noise", 1), ("clutter", 2)):
                    c[name] += int(np.count_nonzero(p["origin"] == code))
                for i in np.flatnonzero(p["origin"] == 0):
                    targets.append({"sensor": p["sensor"], "t_msg": t_msg,
                                    "time_s": float(pp["time_s"][i]),
                                    "range_m": float(pp["range_m"][i]),
                                    "azimuth_rad": float(pp["azimuth_rad"][i])})
    return {"path": path, "per_scan": per_scan, "targets": targets}


# ----------------------------------------------------------------------------- wire
def test_batch_round_trip_keeps_columns_and_alignment():
    frames = protocol.encode(b"plots", 3.5, {
        "sensor": "r1", "scan": 3, "plot_id": np.arange(5, dtype=np.int64),
        "time_s": np.linspace(3, 3.5, 5), "range_m": np.array([1e3, 2e3, 3e3, 4e3, 5e3]),
        "azimuth_rad": np.full(5, 0.5), "snr_db": np.full(5, 13.0)})
    item = to_view(*protocol.decode(frames))
    data = pack_batch([item, {"k": "clock", "t": 3.5}], {"dropped": 2}, 1.0)
    back = unpack_batch(data)
    assert back["status"] == {"dropped": 2}
    got = back["items"][0]
    assert got["k"] == "plots" and got["scan"] == 3
    np.testing.assert_array_equal(got["id"], np.arange(5.0))
    np.testing.assert_allclose(got["r"], [1e3, 2e3, 3e3, 4e3, 5e3], rtol=0, atol=0)
    assert got["r"].dtype == np.float32 and got["ts"].dtype == np.float64
    # every column starts 8-byte aligned in the message (typed arrays need it in the page)
    h = int.from_bytes(data[:4], "little")
    base = 4 + h + (-(4 + h) % 8)
    assert base % 8 == 0
    assert back["items"][1] == {"k": "clock", "t": 3.5}


@pytest.mark.parametrize("payload, match", [
    ({"sensor": "r1", "scan": 1, "plot_id": np.arange(3), "time_s": np.zeros(2),
      "range_m": np.zeros(3), "azimuth_rad": np.zeros(3), "snr_db": np.zeros(3)},
     "'time_s' holds 2 elements, expected 3"),
    ({"sensor": 5, "scan": 1, "plot_id": np.arange(1)}, "'sensor' must be a string"),
    ({"sensor": "r1", "scan": "x", "plot_id": np.arange(1)}, "'scan' must be an integer"),
])
def test_malformed_messages_are_refused_with_the_field_named(payload, match):
    with pytest.raises(ViewError, match=match):
        to_view(b"plots", 0.0, payload)


def test_unknown_topics_are_ignored():
    assert to_view(b"asterix", 0.0, {}) is None


# ----------------------------------------------------------------------------- bad input
def test_http_host_is_loopback_unless_allowed():
    check_http_host("127.0.0.1")
    check_http_host("::1")
    check_http_host("localhost")
    with pytest.raises(HostError, match="--host 0.0.0.0 .*--allow-remote"):
        check_http_host("0.0.0.0")
    check_http_host("0.0.0.0", allow_remote=True)


@pytest.mark.parametrize("args, message", [
    (["--port", "70000"], "--port must be an integer in [0, 65535], got '70000'"),
    (["--speed", "0.5"], "--speed must be a number in [1, 100], got '0.5'"),
    (["--host", "0.0.0.0"], "--host 0.0.0.0 is reachable from other machines"),
    (["--max-queue", "3"], "--max-queue must be an integer in [16, 1000000], got '3'"),
])
def test_view_bad_options_exit_2_naming_option_value_and_range(demo_recording, capsys, args,
                                                               message):
    try:
        code = main(["view", str(demo_recording["path"]), *args])
    except SystemExit as exc:  # argparse
        code = exc.code
    assert code == 2
    assert message in capsys.readouterr().err


def test_view_bad_source_exit_2(tmp_path, capsys):
    assert main(["view", str(tmp_path / "missing.rec")]) == 2
    assert "neither a ZeroMQ endpoint" in capsys.readouterr().err
    bad = tmp_path / "bad.rec"
    bad.write_bytes(b"not a recording")
    assert main(["view", str(bad), "--port", "0"]) == 2
    assert "bad magic" in capsys.readouterr().err


def test_port_in_use_exit_2(demo_recording, capsys):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        assert main(["view", str(demo_recording["path"]), "--port", str(port)]) == 2
    assert f"--port {port}: cannot listen" in capsys.readouterr().err


def test_cross_origin_websocket_is_refused(demo_recording):
    server = ViewerServer(str(demo_recording["path"]), port=0)
    with ViewerThread(server):
        port = int(server.url.rsplit(":", 1)[1].strip("/"))
        status = _handshake(port, origin="http://evil.example")[0]
        assert b"403" in status
        sock, status = _handshake(port, origin=f"http://127.0.0.1:{port}", keep=True)
        sock.close()
        assert b"101" in status


# ----------------------------------------------------------------------------- backpressure
def _handshake(port: int, origin: str | None = None, keep: bool = False,
               rcvbuf: int | None = None):
    """Open the WebSocket by hand; returns (status line) or (socket, status line) if kept.

    A raw socket, so that the test controls reading: a client library would keep reading
    into its own buffer in the background."""
    sock = socket.socket()
    if rcvbuf:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
    sock.settimeout(10)
    sock.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    lines = ["GET /ws HTTP/1.1", f"Host: 127.0.0.1:{port}", "Upgrade: websocket",
             "Connection: Upgrade", f"Sec-WebSocket-Key: {key}", "Sec-WebSocket-Version: 13"]
    if origin:
        lines.append(f"Origin: {origin}")
    sock.sendall(("\r\n".join(lines) + "\r\n\r\n").encode())
    head = b""
    while b"\r\n\r\n" not in head:
        chunk = sock.recv(1)  # byte by byte: leave the WebSocket frames unread
        if not chunk:
            break
        head += chunk
    status = head.split(b"\r\n", 1)[0]
    if keep:
        return sock, status
    sock.close()
    return (status,)


@pytest.mark.slow
def test_stalled_page_does_not_change_the_run(tmp_path):
    """A page that never reads: the viewer drops for it and says so; the run, publishing with
    on_slow="drop" (any backpressure would show as drops), loses nothing and counts the same
    as a run without the viewer."""
    s = load_scenario(DEMO)
    reference = Simulation(s).run()
    endpoint = f"tcp://127.0.0.1:{free_port()}"
    publisher = Publisher(endpoint, wait_subscribers=1, wait_timeout_s=20, on_slow="drop")
    server = ViewerServer(endpoint, port=0, max_queue=64)
    with ViewerThread(server) as viewer:
        port = int(server.url.rsplit(":", 1)[1].strip("/"))
        sock, status = _handshake(port, keep=True, rcvbuf=4096)
        try:
            assert b"101" in status
            wait_until(lambda: viewer.call(lambda: len(server.clients)) == 1, what="the page")
            with Bus(publisher) as bus:
                summary = Simulation(s, bus=bus, realtime=50.0).run()
            sent = summary["bus"]["publisher"]["sent"]
            wait_until(lambda: viewer.call(lambda: server.live.received) >= sent,
                       what="the viewer to read the whole stream")
            page = viewer.call(lambda: [c.status() for c in server.clients])[0]
        finally:
            sock.close()
    assert summary["bus"]["publisher"]["dropped"] == 0
    assert {k: summary[k] for k in COUNTS} == {k: reference[k] for k in COUNTS}
    assert page["dropped"] > 0, page  # the page was told: its status line shows this count


# ----------------------------------------------------------------------------- tracks
@pytest.mark.slow
def test_example_tracker_publishes_tracks_that_reach_the_page(demo_recording):
    """examples/track_stonesoup.py --publish-tracks -> shipradar view --tracks -> page."""
    import asyncio
    import datetime as dt
    import importlib.util

    import aiohttp

    spec = importlib.util.spec_from_file_location(
        "track_stonesoup", ROOT / "examples" / "track_stonesoup.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    endpoint = f"tcp://127.0.0.1:{free_port()}"
    server = ViewerServer(str(demo_recording["path"]), port=0, autoplay=False,
                          tracks=[endpoint])
    with ViewerThread(server):
        items = []

        async def page(ready: asyncio.Event, done: asyncio.Event):
            async with aiohttp.ClientSession() as session, \
                    session.ws_connect(server.url + "ws") as ws:
                ready.set()
                while not done.is_set():
                    try:
                        msg = await asyncio.wait_for(ws.receive(), 0.2)
                    except asyncio.TimeoutError:
                        continue
                    items.extend(it for it in unpack_batch(msg.data)["items"]
                                 if it["k"] == "tracks")

        async def main():
            ready, done = asyncio.Event(), asyncio.Event()
            reader = asyncio.create_task(page(ready, done))
            await ready.wait()
            res = await asyncio.to_thread(mod.track, str(demo_recording["path"]),
                                          publish_tracks=endpoint)
            # only plain values leave the task: asyncio.run's clean-up may repr its result,
            # and the repr of Stone Soup tracks takes minutes
            out.update(scans=res["scans"], tracks_publisher=res["tracks_publisher"])
            await asyncio.sleep(0.5)  # the last messages in flight
            done.set()
            await reader

        out: dict = {}
        asyncio.run(main())
        res = out
    assert res["tracks_publisher"]["dropped"] == 0
    assert res["tracks_publisher"]["sent"] == len(res["scans"])
    with_tracks = [it for it in items if it["ids"]]
    assert with_tracks, "no track reached the page"
    # the page gets what the tracker estimated: the confirmed missile track, near the truth
    last = with_tracks[-1]
    start = dt.datetime.fromisoformat("2026-06-01T12:00:00+00:00")  # the demo's start_time
    by_time = {round((dt.datetime.fromisoformat(r["time"]) - start).total_seconds(), 6): r
               for r in res["scans"]}
    row = by_time[round(last["t"], 6)]
    assert row["tracks"] == len(last["ids"])
    assert last["e"].shape == last["n"].shape == (len(last["ids"]),)


# ----------------------------------------------------------------------------- CurveZMQ
def test_view_subscribes_to_a_curve_stream_only_with_authorised_keys(tmp_path):
    """shipradar view --curve-secret-key/--curve-server-key: a viewer with an authorised key
    reads the CURVE publisher's stream; one whose key is not authorised reads nothing."""
    from shipradar.sim.stream.security import CurveClient, CurveServer, generate_keys

    keys = tmp_path / "keys"
    generate_keys(keys, clients=["alice", "mallory"])
    (keys / "authorized" / "mallory.key").unlink()
    server_keys = CurveServer.from_files(keys / "server.key_secret", keys / "authorized")
    frames = [protocol.encode(protocol.TOPIC_EOS, float(i), {"sensor": "r", "scan": i})
              for i in range(20)]
    with Publisher("tcp://127.0.0.1:*", curve=server_keys, wait_subscribers=1,
                   wait_timeout_s=20) as pub:
        views = {name: ViewerServer(pub.endpoint, port=0, curve=CurveClient.from_files(
            keys / f"{name}.key_secret", keys / "server.key")) for name in ("alice", "mallory")}
        with ViewerThread(views["alice"]) as alice, ViewerThread(views["mallory"]) as mallory:
            pub.wait_for_subscribers()  # only an authorised key completes the handshake
            for f in frames:
                pub.send(f)
            seen = lambda v, th: th.call(lambda: v.live.received)  # noqa: E731
            wait_until(lambda: seen(views["alice"], alice) == len(frames),
                       what="the authorised viewer to read every frame")
            assert seen(views["mallory"], mallory) == 0


def test_view_curve_options_refused_on_a_recording(demo_recording, tmp_path, capsys):
    from shipradar.sim.stream.security import generate_keys

    generate_keys(tmp_path / "k", clients=["alice"])
    code = main(["view", str(demo_recording["path"]), "--port", "0",
                 "--curve-secret-key", str(tmp_path / "k" / "alice.key_secret"),
                 "--curve-server-key", str(tmp_path / "k" / "server.key")])
    assert code == 2
    assert "secure a live endpoint" in capsys.readouterr().err
