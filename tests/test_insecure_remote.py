"""An insecure remote bind is never silent (issue 25, item 9): a non-loopback ``--publish``
without CURVE (or a non-loopback ``--asterix``), allowed by ``--allow-insecure-remote`` or
its deprecated alias ``--allow-remote``, warns on stderr and records ``insecure_remote`` in
the run summary."""

from __future__ import annotations

import json
import socket

import pytest

from shipradar.sim.cli import main
from shipradar.sim.stream.bus import check_bind_endpoint

DEPRECATED = "warning: --allow-remote is deprecated; use --allow-insecure-remote"
INSECURE = "warning: INSECURE: publishing on tcp://0.0.0.0:"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("0.0.0.0", 0))
        return s.getsockname()[1]


def test_check_bind_endpoint_says_whether_the_bind_is_insecure_and_remote():
    assert check_bind_endpoint("tcp://0.0.0.0:5556", allow_remote=True) is True
    assert check_bind_endpoint("tcp://*:5556", allow_remote=True) is True
    assert check_bind_endpoint("tcp://0.0.0.0:5556", secured=True) is False
    assert check_bind_endpoint("tcp://0.0.0.0:5556", secured=True, allow_remote=True) is False
    assert check_bind_endpoint("tcp://127.0.0.1:5556", allow_remote=True) is False
    assert check_bind_endpoint("tcp://localhost:5556") is False
    assert check_bind_endpoint("ipc:///tmp/radar", allow_remote=True) is False


def _run(capsys, *extra: str) -> tuple[dict, str]:
    code = main(["run", "--example", "single_missile", "--duration", "1", "--quiet", *extra])
    out, err = capsys.readouterr()
    assert code == 0, err
    return json.loads(out.strip().splitlines()[-1]), err


@pytest.mark.parametrize("flag", ["--allow-insecure-remote", "--allow-remote"])
def test_run_warns_and_records_an_insecure_remote_bind(capsys, flag):
    summary, err = _run(capsys, "--publish", f"tcp://0.0.0.0:{_free_port()}", flag)
    assert summary["insecure_remote"] is True
    assert INSECURE in err and "without CURVE" in err
    assert (DEPRECATED in err) == (flag == "--allow-remote")


def test_a_loopback_bind_is_not_insecure_remote_even_with_the_flag(capsys):
    summary, err = _run(capsys, "--publish", "tcp://127.0.0.1:*", "--allow-insecure-remote")
    assert summary["insecure_remote"] is False
    assert "INSECURE" not in err and "deprecated" not in err


def test_replay_warns_and_records_an_insecure_remote_bind(capsys, tmp_path):
    rec = tmp_path / "run.srrec"
    summary, _ = _run(capsys, "--record", str(rec))
    assert summary["insecure_remote"] is False
    assert main(["replay", str(rec), "--fast", "--publish", f"tcp://0.0.0.0:{_free_port()}",
                 "--allow-remote"]) == 0
    out, err = capsys.readouterr()
    replayed = json.loads(out.strip().splitlines()[-1])
    assert replayed["insecure_remote"] is True
    assert DEPRECATED in err and INSECURE in err
