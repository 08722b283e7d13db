"""``shipradar run`` on a terminal ends with a summary for a person on stderr (issue 39).

Run with stderr on a pseudo-terminal (``pty``) as a user's shell has it, stdout a pipe: the
JSON line is on stdout as always, and stderr ends with the summary lines, whose numbers are the
JSON's. With stderr a pipe (a script, a CI log) or ``--quiet``, no summary. The tables come
from the usual cache (``SHIPRADAR_TABLES``).
"""

from __future__ import annotations

import json
import os
import pty
import subprocess
import sys
from pathlib import Path

import pytest

from shipradar.sim.cli import run_summary_lines

ROOT = Path(__file__).resolve().parents[1]


def _run(args: list[str], cwd: Path, tty: bool) -> tuple[int, str, str]:
    """The command's exit code, stdout and stderr (stderr on a pseudo-terminal if ``tty``)."""
    cmd = [sys.executable, "-m", "shipradar.sim.cli", "run", *args]
    if not tty:
        proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=600)
        return proc.returncode, proc.stdout, proc.stderr
    master, slave = pty.openpty()
    proc = subprocess.Popen(cmd, cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=slave)
    os.close(slave)
    err = b""
    while True:  # read the terminal until the process has closed its side
        try:
            chunk = os.read(master, 65536)
        except OSError:  # EIO: no process holds the terminal any more
            break
        if not chunk:
            break
        err += chunk
    os.close(master)
    out = proc.stdout.read() if proc.stdout is not None else b""
    proc.wait(timeout=600)
    return proc.returncode, out.decode(), err.decode(errors="replace").replace("\r\n", "\n")


@pytest.mark.slow
def test_on_a_terminal_the_run_ends_with_a_summary_for_a_person(tmp_path):
    rec = tmp_path / "demo.rec"
    code, out, err = _run(["--example", "single_missile", "--duration", "6", "--record",
                           str(rec)], tmp_path, tty=True)
    assert code == 0, err[-3000:]
    lines = out.strip().splitlines()
    assert len(lines) == 1  # stdout: the JSON line alone, as without a terminal
    summary = json.loads(lines[0])
    tail = err.rstrip("\n").splitlines()[-3:]
    assert tail[0].startswith(f"single_missile (seed {summary['seed']}): 6 s simulated; run loop ")
    assert f"{summary['realtime_factor']:,.0f}x real time" in tail[0]
    assert "whole command" in tail[0]
    assert tail[1].startswith(f"  {summary['scans']:,} scans, {summary['dwells']:,} dwells: ")
    assert f"{summary['clutter_false_alarms']:,} clutter" in tail[1]
    recorder = summary["bus"]["recorder"]
    assert tail[2].startswith(f"  recording: {rec} ({recorder['records']:,} messages, ")


@pytest.mark.slow
def test_no_summary_on_stderr_through_a_pipe_or_with_quiet(tmp_path):
    for args, tty in ((["--duration", "3"], False), (["--duration", "3", "--quiet"], True)):
        code, out, err = _run(["--example", "single_missile", *args], tmp_path, tty=tty)
        assert code == 0, err[-3000:]
        assert json.loads(out.strip().splitlines()[-1])["scans"] == 3
        assert "simulated; run loop" not in err, (args, tty, err)


def test_the_summary_says_where_the_stream_went_and_how_a_run_ended():
    base = {"scenario": "raid", "seed": 7, "simulated_s": 12.0, "wall_s": 0.25,
            "realtime_factor": 48.0, "process_wall_s": 1.5, "process_realtime_factor": 8.0,
            "scans": 24, "dwells": 90, "target_plots": 70, "missed_detections": 20,
            "merged_targets": 1, "noise_false_alarms": 2, "clutter_false_alarms": 1234}
    plain = run_summary_lines(base)
    assert plain[0] == ("raid (seed 7): 12 s simulated; run loop 0.25 s (48x real time), "
                        "whole command 1.50 s (8x)")
    assert plain[1] == ("  24 scans, 90 dwells: 70 target plots, 20 missed, 1 merged; false "
                        "alarms 2 noise, 1,234 clutter")
    assert plain[2].startswith("  nothing recorded or published")
    published = run_summary_lines({**base, "interrupted": True, "bus": {
        "recorder": None, "publisher": {"endpoint": "tcp://127.0.0.1:5556", "sent": 3000,
                                        "dropped": 5}}})
    assert published[0].startswith("interrupted: raid")
    assert published[2] == "  published on tcp://127.0.0.1:5556: 3,000 messages sent, 5 dropped"
    failed = run_summary_lines({**base, "error": "disk full", "realtime_factor": None})
    assert failed[0].startswith("error: raid") and "(n/a real time)" in failed[0]
    assert failed[-1] == "  error: disk full"
