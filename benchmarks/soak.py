"""Soak: many simulated hours of the raid with a recording and a live subscriber.

Starts ``shipradar run --example raid --duration H*3600 --record FILE --publish ENDPOINT
--wait-subscribers 1`` as a child process, subscribes to it (counting messages and bytes),
and at every simulated hour (read from the messages' times) prints the child's resident
set size, which must stay flat: no state that grows with the run. At the end it prints the
recording's size and ``shipradar recording verify`` of it.

    python benchmarks/soak.py [--hours 24] [--compress zstd] [--out DIR]

The raid records about 250 MB per simulated hour (6 GB per day; zstd about 0.70 of that),
so give ``--out`` a disk with room for it. Measured for 24 simulated hours (2-core machine,
niced beside a test suite): RSS 307.1 MiB at every hour, 6 534 754 messages sent and
received, 7.01 GB recorded at 107x real time, verify clean (docs/performance.md, section 7).
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import zmq

from shipradar.sim.stream.protocol import decode

ROOT = Path(__file__).resolve().parents[1]


def _rss_mib(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=24.0, help="simulated hours")
    ap.add_argument("--compress", choices=("none", "zstd"), default="none")
    ap.add_argument("--out", default=None, help="directory of the recording (default: temp)")
    a = ap.parse_args()
    out_dir = Path(a.out) if a.out else Path(tempfile.mkdtemp(prefix="soak-"))
    rec = out_dir / "soak.srrec"
    if rec.exists():
        rec.unlink()
    endpoint = f"tcp://127.0.0.1:{_free_port()}"
    ctx = zmq.Context()
    sub = ctx.socket(zmq.SUB)
    sub.setsockopt(zmq.LINGER, 0)
    sub.setsockopt(zmq.RCVHWM, 0)
    sub.connect(endpoint)
    sub.setsockopt(zmq.SUBSCRIBE, b"")
    duration = a.hours * 3600.0
    child = subprocess.Popen(
        [sys.executable, "-m", "shipradar.sim.cli", "run", "--example", "raid", "--duration",
         f"{duration:g}", "--record", str(rec), "--compress", a.compress, "--publish",
         endpoint, "--wait-subscribers", "1", "--quiet"],
        stdout=subprocess.PIPE, text=True, cwd=ROOT)
    print(json.dumps({"hours": a.hours, "recording": str(rec), "compress": a.compress,
                      "load_avg_1min": os.getloadavg()[0]}), flush=True)
    wall0 = time.perf_counter()
    next_hour, messages, nbytes, rss = 1, 0, 0, []
    try:
        while True:
            if not sub.poll(200):
                if child.poll() is not None:
                    break
                continue
            frames = sub.recv_multipart()
            messages += 1
            nbytes += sum(len(f) for f in frames)
            t = decode(frames)[1]
            while t >= next_hour * 3600.0:
                r = _rss_mib(child.pid)
                rss.append(r)
                print(json.dumps({"sim_hour": next_hour, "rss_mib": round(r, 1),
                                  "messages": messages, "stream_mb": round(nbytes / 1e6, 1),
                                  "wall_s": round(time.perf_counter() - wall0, 1)}),
                      flush=True)
                next_hour += 1
        summary_line = child.stdout.read().strip().splitlines()[-1]
    finally:
        if child.poll() is None:
            child.terminate()
        child.wait()
        sub.close()
        ctx.term()
    summary = json.loads(summary_line)
    verify = subprocess.run([sys.executable, "-m", "shipradar.sim.cli", "recording", "verify",
                             str(rec)], capture_output=True, text=True, cwd=ROOT)
    report = json.loads(verify.stdout)
    print(json.dumps({
        "run_exit": child.returncode,
        "realtime_factor": summary.get("realtime_factor"),
        "messages_received": messages, "messages_sent": summary["bus"]["messages"],
        "rss_first_last_max_mib": [round(rss[0], 1), round(rss[-1], 1), round(max(rss), 1)]
        if rss else None,
        "recording_bytes": rec.stat().st_size,
        "verify_exit": verify.returncode,
        "verify": {k: report[k] for k in ("status", "records", "t_first", "t_last",
                                          "sensors", "damaged_regions", "truncated")},
    }), flush=True)


if __name__ == "__main__":
    main()
