"""Transport: publisher over loopback, backpressure, bus, replay and tail
(shipradar.sim.stream.bus)."""

from __future__ import annotations

import io
import json
import threading
import time

import numpy as np
import pytest
import zmq

from shipradar.sim.stream.bus import (
    Bus,
    EndpointError,
    Publisher,
    ReplaySettings,
    SubscriberTimeoutError,
    check_bind_endpoint,
    message_json,
    replay,
    tail,
)
from shipradar.sim.stream.protocol import TOPIC_EOS, TOPIC_META, TOPIC_PLOTS, TOPIC_TRUTH, encode
from shipradar.sim.stream.recording import Recorder, RecordingError, read_recording

LOOPBACK = "tcp://127.0.0.1:*"


def plot_frames(n: int, width: int = 10) -> list[list[bytes]]:
    return [
        encode(TOPIC_PLOTS, 0.1 * i, {"scan": i, "range_m": np.full(width, float(i))})
        for i in range(n)
    ]


class Collector(threading.Thread):
    """A SUB socket in a thread that collects ``n`` messages (or gives up at a deadline).

    With a ``gate``, it subscribes at once but only starts reading once the gate is set,
    through a small receive buffer: a subscriber that lags behind the publisher.
    """

    def __init__(self, endpoint: str, n: int, topics=(b"",), timeout_s: float = 20.0, gate=None):
        super().__init__(daemon=True)
        self.endpoint, self.n, self.topics, self.timeout_s = endpoint, n, topics, timeout_s
        self.gate = gate
        self.frames: list[list[bytes]] = []

    def run(self) -> None:
        ctx = zmq.Context()
        sock = ctx.socket(zmq.SUB)
        sock.setsockopt(zmq.LINGER, 0)
        if self.gate is not None:
            sock.setsockopt(zmq.RCVHWM, 5)
            sock.setsockopt(zmq.RCVBUF, 64 * 1024)
        sock.connect(self.endpoint)
        for t in self.topics:
            sock.setsockopt(zmq.SUBSCRIBE, t)
        if self.gate is not None:
            self.gate.wait(self.timeout_s)
        last = time.monotonic()
        while len(self.frames) < self.n and time.monotonic() - last < self.timeout_s:
            if sock.poll(100):
                self.frames.append(sock.recv_multipart())
                last = time.monotonic()
        sock.close()
        ctx.term()


def slow_subscriber(endpoint: str) -> tuple[zmq.Context, zmq.Socket]:
    """A SUB socket that buffers little, so a publisher feels it when it stops reading."""
    ctx = zmq.Context()
    sock = ctx.socket(zmq.SUB)
    sock.setsockopt(zmq.LINGER, 0)
    sock.setsockopt(zmq.RCVHWM, 5)
    sock.setsockopt(zmq.RCVBUF, 64 * 1024)
    sock.connect(endpoint)
    sock.setsockopt(zmq.SUBSCRIBE, b"")
    return ctx, sock


def recv_n(sock: zmq.Socket, n: int, timeout_s: float = 20.0) -> list[list[bytes]]:
    got = []
    deadline = time.monotonic() + timeout_s
    while len(got) < n and time.monotonic() < deadline:
        if sock.poll(100):
            got.append(sock.recv_multipart())
    return got


# -- endpoints -------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "endpoint",
    [
        "tcp://127.0.0.1:5555",
        "tcp://127.0.0.1:*",
        "tcp://127.5.0.1:5555",
        "tcp://localhost:5555",
        "tcp://[::1]:5555",
        "ipc:///tmp/radar.ipc",
        "inproc://radar",
    ],
)
def test_local_endpoints_are_accepted(endpoint):
    check_bind_endpoint(endpoint)


@pytest.mark.parametrize(
    "endpoint",
    [
        "tcp://0.0.0.0:5555",
        "tcp://*:5555",
        "tcp://[::]:5555",
        "tcp://192.168.1.20:5555",
        "tcp://eth0:5555",
        "udp://127.0.0.1:5555",
        "epgm://eth0;239.192.1.1:5555",
    ],
)
def test_remote_endpoints_are_refused_unless_allowed(endpoint):
    with pytest.raises(EndpointError, match="refusing to bind"):
        check_bind_endpoint(endpoint)
    check_bind_endpoint(endpoint, allow_remote=True)


@pytest.mark.parametrize("endpoint", ["127.0.0.1:5555", "tcp://", "tcp://127.0.0.1"])
def test_malformed_endpoints_are_refused(endpoint):
    with pytest.raises(EndpointError, match="malformed"):
        check_bind_endpoint(endpoint)


def test_publisher_refuses_wildcard_bind_and_bad_options():
    with pytest.raises(EndpointError, match="refusing to bind"):
        Publisher("tcp://0.0.0.0:*")
    with pytest.raises(ValueError, match="on_slow"):
        Publisher(LOOPBACK, on_slow="block")


def test_publisher_reports_the_resolved_port():
    with Publisher(LOOPBACK) as pub:
        assert pub.endpoint.startswith("tcp://127.0.0.1:")
        assert int(pub.endpoint.rsplit(":", 1)[1]) > 0


def test_bind_failure_is_a_clear_error():
    with Publisher(LOOPBACK) as pub, pytest.raises(EndpointError, match="cannot bind"):
        Publisher(pub.endpoint)


# -- delivery --------------------------------------------------------------------------------
def test_waited_subscriber_receives_exactly_the_frames_sent_in_order():
    frames = plot_frames(500)
    pub = Publisher(LOOPBACK, wait_subscribers=1, wait_timeout_s=10)
    col = Collector(pub.endpoint, len(frames))
    col.start()
    for f in frames:  # the first send waits for the subscriber
        assert pub.send(f)
    col.join(30)
    stats = pub.stats
    pub.close()
    assert col.frames == frames
    assert stats["sent"] == 500 and stats["dropped"] == 0
    assert stats["sent_by_topic"] == {"plots": 500} and stats["unheard_by_topic"] == {}


def test_close_delivers_what_is_still_queued():
    frames = plot_frames(3000, width=1000)  # 24 MB, far more than the socket buffers
    pub = Publisher(LOOPBACK, sndhwm=0)  # unbounded queue: sending never waits
    gate = threading.Event()
    col = Collector(pub.endpoint, len(frames), timeout_s=3.0, gate=gate)
    col.start()
    pub.wait_for_subscribers(1, timeout_s=10)
    for f in frames:
        pub.send(f)
    gate.set()  # the subscriber starts reading only now: most messages are still queued
    pub.close()  # returns once the queue reached the subscriber
    col.join(30)
    assert len(col.frames) == len(frames)
    assert col.frames == frames


def test_wait_for_subscribers_times_out_with_a_clear_error():
    with Publisher(LOOPBACK, wait_subscribers=2, wait_timeout_s=0.3) as pub:
        ctx, sub = slow_subscriber(pub.endpoint)
        try:
            with pytest.raises(SubscriberTimeoutError, match="1 of 2 expected subscriber"):
                pub.wait_for_subscribers()
            with pytest.raises(SubscriberTimeoutError):
                pub.send(plot_frames(1)[0])  # the first send waits too
        finally:
            sub.close()
            ctx.term()


def test_subscribers_are_counted_per_subscriber_and_leave():
    with Publisher(LOOPBACK) as pub:
        ctx = zmq.Context()
        subs = []
        for _ in range(2):
            s = ctx.socket(zmq.SUB)
            s.setsockopt(zmq.LINGER, 0)
            s.connect(pub.endpoint)
            for topic in (TOPIC_META, TOPIC_PLOTS, TOPIC_EOS):  # several topics each
                s.setsockopt(zmq.SUBSCRIBE, topic)
            subs.append(s)
        assert pub.wait_for_subscribers(2, timeout_s=10) == 2
        subs[0].close()
        deadline = time.monotonic() + 10
        while pub.poll_subscriptions(0.1) != 1 and time.monotonic() < deadline:
            pass
        assert pub.subscribers == 1
        subs[1].close()
        ctx.term()


def test_messages_nobody_subscribed_to_are_counted_as_unheard():
    with Publisher(LOOPBACK) as pub:
        ctx, sub = slow_subscriber(pub.endpoint)
        sub.setsockopt(zmq.UNSUBSCRIBE, b"")
        sub.setsockopt(zmq.SUBSCRIBE, TOPIC_PLOTS)
        try:
            pub.wait_for_subscribers(1, timeout_s=10)
            pub.send(encode(TOPIC_TRUTH, 0.0, {"targets": []}))
            pub.send(plot_frames(1)[0])
            stats = pub.stats
        finally:
            sub.close()
            ctx.term()
    assert stats["sent_by_topic"] == {"truth": 1, "plots": 1}
    assert stats["unheard_by_topic"] == {"truth": 1}


def test_slow_subscriber_paces_the_publisher_and_loses_nothing():
    frames = plot_frames(3000, width=1000)  # 8 kB each, 24 MB: more than socket buffers
    pub = Publisher(LOOPBACK, sndhwm=5, on_slow="pace")
    ctx, sub = slow_subscriber(pub.endpoint)
    try:
        pub.wait_for_subscribers(1, timeout_s=10)
        done = threading.Event()

        def produce() -> None:
            for f in frames:
                pub.send(f)
            done.set()

        producer = threading.Thread(target=produce, daemon=True)
        producer.start()
        # The subscriber is not reading: the producer must be held back, not run ahead.
        assert not done.wait(0.5)
        got = recv_n(sub, len(frames))
        assert done.wait(10)
        producer.join(10)
        stats = pub.stats
    finally:
        pub.close(0)
        sub.close()
        ctx.term()
    assert got == frames
    assert stats["sent"] == 3000 and stats["dropped"] == 0
    assert stats["paced_s"] > 0.3


def test_slow_subscriber_in_drop_mode_counts_every_drop(tmp_path, caplog):
    frames = plot_frames(3000, width=1000)
    pub = Publisher(LOOPBACK, sndhwm=5, on_slow="drop")
    bus = Bus(pub, Recorder(tmp_path / "run.srrec"))
    ctx, sub = slow_subscriber(pub.endpoint)
    try:
        pub.wait_for_subscribers(1, timeout_s=10)
        sent_ok = []
        for i, f in enumerate(frames):
            bus.emit_frames(0.1 * i, f)
        stats = pub.stats
        sent_ok = stats["sent"]
        got = recv_n(sub, sent_ok)
        assert not sub.poll(200)  # nothing more than what was counted as sent
    finally:
        bus.close(0)
        sub.close()
        ctx.term()
    assert stats["dropped"] > 0
    assert stats["sent"] + stats["dropped"] == 3000
    assert stats["dropped_by_topic"] == {"plots": stats["dropped"]}
    assert len(got) == stats["sent"]
    # What arrived is in order and each message is intact.
    idx = [frames.index(g) for g in got]
    assert idx == sorted(idx)
    assert "dropping messages" in caplog.text
    # The recording holds every message, dropped or not.
    assert [f for _, f in read_recording(tmp_path / "run.srrec")] == frames
    assert bus.stats["messages"] == 3000 and bus.stats["recorder"]["records"] == 3000


# -- bus -------------------------------------------------------------------------------------
def test_bus_sends_the_recorded_bytes(tmp_path):
    path = tmp_path / "run.srrec"
    pub = Publisher(LOOPBACK, wait_subscribers=1, wait_timeout_s=10)
    col = Collector(pub.endpoint, 4)
    col.start()
    with Bus(pub, Recorder(path)) as bus:
        emitted = [
            bus.emit(TOPIC_META, 0.0, {"sensor": "sps49", "schema_version": 1}),
            bus.emit(TOPIC_PLOTS, 0.5, {"range_m": np.array([1.0, np.nan])}),
            bus.emit(TOPIC_TRUTH, 0.5, {"origin": ["target:1", "noise"]}),
            bus.emit(TOPIC_EOS, 1.0, {"sensor": "sps49", "scan": 0}),
        ]
        bus.flush(fsync=True)
        stats = bus.stats
        col.join(20)
    recorded = list(read_recording(path))
    assert [t for t, _ in recorded] == [0.0, 0.5, 0.5, 1.0]
    assert [f for _, f in recorded] == emitted == col.frames
    assert stats["messages"] == 4
    assert stats["messages_by_topic"] == {"meta": 1, "plots": 1, "truth": 1, "eos": 1}
    assert stats["publisher"]["sent"] == 4 and stats["recorder"]["records"] == 4


def test_bus_without_outputs_still_encodes():
    bus = Bus()
    frames = bus.emit(TOPIC_EOS, 1.0, {"scan": 1})
    bus.flush()
    bus.close()
    assert frames == encode(TOPIC_EOS, 1.0, {"scan": 1})
    assert bus.stats["publisher"] is None and bus.stats["recorder"] is None


# -- replay ----------------------------------------------------------------------------------
def make_recording(path, times) -> list[list[bytes]]:
    frames = []
    with Recorder(path) as rec:
        for i, t in enumerate(times):
            f = encode(TOPIC_PLOTS, t, {"scan": i, "range_m": np.arange(5.0) + i})
            rec.write(t, f)
            frames.append(f)
    return frames


def test_replay_republishes_byte_identical_frames(tmp_path):
    path = tmp_path / "run.srrec"
    frames = make_recording(path, [0.1 * i for i in range(200)])
    endpoint = f"ipc://{tmp_path}/replay.ipc"
    col = Collector(endpoint, len(frames))  # connects before replay binds: ZeroMQ retries
    col.start()
    summary = replay(path, ReplaySettings(endpoint=endpoint, fast=True, wait_subscribers=1,
                                           wait_timeout_s=10))
    col.join(20)
    assert col.frames == frames
    assert summary["frames"] == 200 and not summary["truncated"]
    assert summary["bytes_ignored"] == 0
    assert summary["t_first"] == 0.0 and summary["t_last"] == pytest.approx(19.9, abs=1e-12)
    assert summary["publisher"]["sent"] == 200


def test_replay_paces_by_simulated_time_over_speed(tmp_path):
    path = tmp_path / "run.srrec"
    make_recording(path, [0.0, 1.0, 1.0, 3.0, 2.0, 4.0])
    now = [100.0]
    sent_at = []

    class Out(io.StringIO):
        def write(self, s):
            sent_at.append(now[0])
            return super().write(s)

    def sleep(d):
        now[0] += d

    summary = replay(path, ReplaySettings(speed=2.0), out=Out(), clock=lambda: now[0], sleep=sleep)
    # t/speed from the first message; a late message (t=2 after t=3) goes out at once.
    assert [s - 100.0 for s in sent_at] == pytest.approx([0.0, 0.5, 0.5, 1.5, 1.5, 2.0])
    assert summary["wall_s"] == pytest.approx(2.0)
    assert summary["publisher"] is None


def test_replay_real_clock_speed(tmp_path):
    path = tmp_path / "run.srrec"
    make_recording(path, [0.05 * i for i in range(11)])  # 0.5 s simulated
    t0 = time.monotonic()
    summary = replay(path, ReplaySettings(speed=2.0))
    wall = time.monotonic() - t0
    assert 0.24 <= summary["wall_s"] <= wall < 2.0
    fast = replay(path, ReplaySettings(fast=True))
    assert fast["wall_s"] < 0.2


def test_replay_of_truncated_recording_reports_it(tmp_path):
    path = tmp_path / "run.srrec"
    frames = make_recording(path, [float(i) for i in range(5)])
    data = path.read_bytes()
    path.write_bytes(data[:-3])
    out = io.StringIO()
    summary = replay(path, ReplaySettings(fast=True), out=out)
    assert summary["frames"] == 4 and summary["truncated"]
    # format 2: 32-byte record header (marker, length, flags, sequence, CRCs), then t_sim,
    # frame count and the frames with their lengths
    last_record = 32 + 10 + 4 + len(frames[4][0]) + 4 + len(frames[4][1])
    assert summary["bytes_ignored"] == last_record - 3
    lines = [json.loads(line) for line in out.getvalue().splitlines()]
    assert [ln["payload"]["scan"] for ln in lines] == [0, 1, 2, 3]
    assert lines[1] == {"topic": "plots", "t": 1.0, "payload": {"scan": 1,
                        "range_m": [1.0, 2.0, 3.0, 4.0, 5.0]}}  # fmt: skip


def test_replay_rejects_bad_input_before_binding(tmp_path):
    bad = tmp_path / "bad.srrec"
    bad.write_bytes(b"not a recording at all")
    with pytest.raises(RecordingError):
        replay(bad, ReplaySettings(endpoint="tcp://0.0.0.0:1"))
    good = tmp_path / "good.srrec"
    make_recording(good, [0.0])
    for speed in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="speed"):
            replay(good, ReplaySettings(speed=speed))
    with pytest.raises(EndpointError):
        replay(good, ReplaySettings(endpoint="tcp://0.0.0.0:1"))


# -- tail ------------------------------------------------------------------------------------
def test_tail_prints_one_json_line_per_message():
    out = io.StringIO()
    with Publisher(LOOPBACK, wait_subscribers=1, wait_timeout_s=10) as pub:
        result = {}
        th = threading.Thread(
            target=lambda: result.setdefault(
                "n",
                tail(pub.endpoint, topics=["plots", b"eos"], out=out, max_messages=3,
                     timeout_s=10),
            )
        )  # fmt: skip
        th.start()
        pub.send(encode(TOPIC_PLOTS, 1.5, {"sensor": "sps49", "snr_db": np.array([12.0, np.nan])}))
        pub.send(encode(TOPIC_TRUTH, 1.5, {"origin": ["noise"]}))  # not subscribed
        pub.send([TOPIC_PLOTS, b"\xc1"])  # undecodable: reported, not fatal
        pub.send(encode(TOPIC_EOS, 2.0, {"scan": 0, "raw": b"ok"}))
        th.join(20)
    assert result["n"] == 3
    lines = [json.loads(line) for line in out.getvalue().splitlines()]
    assert lines[0] == {"topic": "plots", "t": 1.5,
                        "payload": {"sensor": "sps49", "snr_db": [12.0, None]}}  # fmt: skip
    assert lines[1]["topic"] == "plots" and "not valid msgpack" in lines[1]["error"]
    assert lines[2] == {"topic": "eos", "t": 2.0, "payload": {"scan": 0, "raw": "ok"}}


def test_tail_idle_timeout_ends_it():
    t0 = time.monotonic()
    assert tail("tcp://127.0.0.1:1", out=io.StringIO(), timeout_s=0.3) == 0
    assert time.monotonic() - t0 < 5


def test_message_json_is_strict_json():
    line = message_json(encode(TOPIC_PLOTS, 0.0, {"x": float("inf")}))
    assert line == '{"topic":"plots","t":0.0,"payload":{"x":null}}'
