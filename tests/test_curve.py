"""CurveZMQ: only authorised subscribers receive; remote binds need CURVE; key files checked.

Every wait is on a socket event (handshake result, message) with a deadline, never a sleep.
"""

from __future__ import annotations

import argparse
import io
import json
import stat
import threading
import time

import numpy as np
import pytest
import zmq
from zmq.utils.monitor import recv_monitor_message

from shipradar.sim.cli import main
from shipradar.sim.stream.bus import EndpointError, Publisher, check_bind_endpoint, tail
from shipradar.sim.stream.protocol import TOPIC_PLOTS, encode
from shipradar.sim.stream.security import (
    CurveClient,
    CurveKeyError,
    CurveServer,
    add_curve_arguments,
    curve_from_args,
    generate_keys,
)

LOOPBACK = "tcp://127.0.0.1:*"
_FAILED = (zmq.EVENT_HANDSHAKE_FAILED_AUTH, zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL,
           zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL)


@pytest.fixture(scope="module")
def keys(tmp_path_factory):
    """server, alice (authorised) and mallory (a valid key pair, not authorised)."""
    d = tmp_path_factory.mktemp("keys")
    generate_keys(d, clients=["alice", "mallory"])
    (d / "authorized" / "mallory.key").unlink()
    return d


def _sub(ctx, endpoint, curve):
    sock = ctx.socket(zmq.SUB)
    sock.setsockopt(zmq.LINGER, 0)
    if curve is not None:
        curve.apply(sock)
    mon = sock.get_monitor_socket(zmq.EVENT_HANDSHAKE_SUCCEEDED | zmq.EVENT_HANDSHAKE_FAILED_AUTH
                                  | zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL
                                  | zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL)
    sock.connect(endpoint)
    sock.setsockopt(zmq.SUBSCRIBE, b"")
    return sock, mon


def _handshake(mon, timeout_s: float = 10.0) -> int:
    """The first handshake event of a subscriber (success or the reason it failed)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if mon.poll(100):
            return recv_monitor_message(mon)["event"]
    raise AssertionError("no handshake event within the timeout")


def test_only_the_authorised_subscriber_receives(keys):
    server = CurveServer.from_files(keys / "server.key_secret", keys / "authorized")
    alice = CurveClient.from_files(keys / "alice.key_secret", keys / "server.key")
    mallory = CurveClient.from_files(keys / "mallory.key_secret", keys / "server.key")
    # knows her own key pair but trusts the wrong server key (an impostor's)
    fooled = CurveClient.from_files(keys / "alice.key_secret", keys / "mallory.key")
    frames = [encode(TOPIC_PLOTS, 0.1 * i, {"scan": i, "range_m": np.full(5, float(i))})
              for i in range(50)]
    ctx = zmq.Context()
    socks = []
    try:
        with Publisher(LOOPBACK, curve=server, wait_subscribers=1, wait_timeout_s=20) as pub:
            subs = {name: _sub(ctx, pub.endpoint, c) for name, c in
                    (("alice", alice), ("mallory", mallory), ("fooled", fooled),
                     ("plain", None))}
            socks = [s for pair in subs.values() for s in pair]
            assert _handshake(subs["alice"][1]) == zmq.EVENT_HANDSHAKE_SUCCEEDED
            assert _handshake(subs["mallory"][1]) == zmq.EVENT_HANDSHAKE_FAILED_AUTH
            assert _handshake(subs["fooled"][1]) in _FAILED
            assert _handshake(subs["plain"][1]) in _FAILED
            assert pub.wait_for_subscribers(1) == 1
            for f in frames:
                pub.send(f)
            got = []
            deadline = time.monotonic() + 20
            sock = subs["alice"][0]
            while len(got) < len(frames) and time.monotonic() < deadline:
                if sock.poll(100):
                    got.append(sock.recv_multipart())
            assert got == frames
            assert pub.subscribers == 1  # the rejected ones never subscribed
            for name in ("mallory", "fooled", "plain"):
                assert not subs[name][0].poll(0), name
    finally:
        for s in socks:
            s.close(linger=0)
        ctx.term()


def test_tail_with_keys_receives_every_message(keys):
    server = CurveServer.from_files(keys / "server.key_secret", keys / "authorized")
    alice = CurveClient.from_files(keys / "alice.key_secret", keys / "server.key")
    out = io.StringIO()
    frames = [encode(TOPIC_PLOTS, float(i), {"scan": i}) for i in range(10)]
    with Publisher(LOOPBACK, curve=server, wait_subscribers=1, wait_timeout_s=20) as pub:
        th = threading.Thread(target=tail, args=(pub.endpoint,),
                              kwargs={"out": out, "max_messages": 10, "timeout_s": 20,
                                      "curve": alice}, daemon=True)
        th.start()
        pub.wait_for_subscribers()
        for f in frames:
            pub.send(f)
        th.join(30)
    assert [json.loads(x)["payload"]["scan"] for x in out.getvalue().splitlines()] == list(
        range(10))


def test_stonesoup_reader_iterates_a_curve_stream(keys):
    pytest.importorskip("stonesoup")
    from shipradar.sim.adapters.stonesoup_reader import iter_messages

    server = CurveServer.from_files(keys / "server.key_secret", keys / "authorized")
    alice = CurveClient.from_files(keys / "alice.key_secret", keys / "server.key")
    got = []
    with Publisher(LOOPBACK, curve=server, wait_subscribers=1, wait_timeout_s=20) as pub:
        it = iter_messages(pub.endpoint, [TOPIC_PLOTS], idle_timeout_s=20, curve=alice)
        th = threading.Thread(target=lambda: got.extend(t for _, t, _ in
                                                        (next(it) for _ in range(5))),
                              daemon=True)
        th.start()
        pub.wait_for_subscribers()
        for i in range(5):
            pub.send(encode(TOPIC_PLOTS, float(i), {"scan": i}))
        th.join(30)
        it.close()
    assert got == [0.0, 1.0, 2.0, 3.0, 4.0]


def test_remote_bind_needs_curve_or_an_explicit_insecure_opt_in(keys):
    with pytest.raises(EndpointError, match="secure the stream with CURVE .*"
                                            "--allow-insecure-remote"):
        check_bind_endpoint("tcp://0.0.0.0:5556")
    check_bind_endpoint("tcp://0.0.0.0:5556", secured=True)
    check_bind_endpoint("tcp://0.0.0.0:5556", allow_remote=True)
    with pytest.raises(EndpointError):  # CURVE is a TCP/IPC mechanism: UDP stays refused
        check_bind_endpoint("udp://10.0.0.1:5556", secured=True)


def test_cli_refuses_a_remote_bind_without_keys(capsys, table_cache):
    assert main(["run", "--example", "single_missile", "--duration", "1",
                 "--publish", "tcp://0.0.0.0:5556"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("refusing to bind tcp://0.0.0.0:5556: it is reachable from other "
                          "machines; bind a loopback address")
    # refused before any work: no table was built into the empty cache
    assert not table_cache.exists() or not any(table_cache.iterdir())


def test_keys_generate_writes_private_secrets_and_refuses_to_overwrite(tmp_path, capsys):
    d = tmp_path / "k"
    assert main(["keys", "generate", str(d), "--name", "ops", "--name", "tracker"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["clients"]) == {"ops", "tracker"}
    for name in ("server", "ops", "tracker"):
        assert stat.S_IMODE((d / f"{name}.key_secret").stat().st_mode) == 0o600
    assert sorted(p.name for p in (d / "authorized").iterdir()) == ["ops.key", "tracker.key"]
    before = (d / "server.key_secret").read_bytes()
    assert main(["keys", "generate", str(d)]) == 2
    assert "exists" in capsys.readouterr().err
    assert (d / "server.key_secret").read_bytes() == before


def test_bad_key_options_are_clear(keys, tmp_path, capsys):
    big = tmp_path / "big.key"
    big.write_bytes(b"#" * 70000)
    empty = tmp_path / "empty"
    empty.mkdir()
    cases = [
        (["--curve-secret-key", str(keys / "server.key")],
         "--curve-secret-key needs --curve-authorized DIR too"),
        (["--curve-secret-key", str(keys / "server.key"), "--curve-authorized",
          str(keys / "authorized")],
         f"--curve-secret-key: {keys / 'server.key'} holds no secret key; give the "
         f".key_secret file (shipradar keys generate DIR writes both)"),
        (["--curve-secret-key", str(big), "--curve-authorized", str(keys / "authorized")],
         f"--curve-secret-key: {big} is 70000 bytes, must be <= 65536 (a key file)"),
        (["--curve-secret-key", str(keys / "server.key_secret"), "--curve-authorized",
          str(empty)],
         f"--curve-authorized: {empty} holds no public key (*.key files); copy each "
         f"subscriber's NAME.key there"),
        (["--curve-secret-key", str(tmp_path / "nope"), "--curve-authorized", str(empty)],
         f"--curve-secret-key: cannot read {tmp_path / 'nope'} (No such file or directory)"),
    ]
    for extra, message in cases:
        # through the command line: exit 2, the message alone, before any table or socket
        assert main(["run", "--example", "single_missile", "--publish", LOOPBACK, *extra]) == 2
        assert capsys.readouterr().err == message + "\n"
        p = argparse.ArgumentParser()
        add_curve_arguments(p, "server")
        with pytest.raises(CurveKeyError) as exc:
            curve_from_args(p.parse_args(extra), "server")
        assert str(exc.value) == message
    p = argparse.ArgumentParser()
    add_curve_arguments(p, "client")
    with pytest.raises(CurveKeyError, match="--curve-server-key needs --curve-secret-key"):
        curve_from_args(p.parse_args(["--curve-server-key", str(keys / "server.key")]), "client")
    assert curve_from_args(p.parse_args([]), "client") is None
