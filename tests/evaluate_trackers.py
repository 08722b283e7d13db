"""Trackers with known scores for tests/test_evaluate.py, run as ``--tracker`` commands.

``python tests/evaluate_trackers.py MODE {plots} {tracks} [--shift-m D] [--after N]``:

- ``oracle``: publishes the truth topic's counted targets (the harness's own definition,
  :func:`shipradar.sim.studies.evaluate.metrics.counted_targets`: active, and ``in_coverage``
  in some radar's latest ``truth[targets]``) as its tracks at every end of scan of the first
  radar, ids ``T<index>``; ``--shift-m D`` moves them D metres east;
- ``silent``: subscribes and reads, never publishes;
- ``crash``: like the oracle, then exits with code 3 and a message on stderr after
  ``--after`` tracks messages;
- ``malformed``: publishes, at every end of scan, one message lacking ``track_id``, one
  that is not msgpack, then a valid oracle message;
- ``never``: sleeps without subscribing (until the harness stops it).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import zmq

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from shipradar.sim.stream.protocol import decode, encode  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", choices=("oracle", "silent", "crash", "malformed", "never"))
    ap.add_argument("plots")
    ap.add_argument("tracks")
    ap.add_argument("--shift-m", type=float, default=0.0)
    ap.add_argument("--after", type=int, default=3)
    a = ap.parse_args()
    if a.mode == "never":
        time.sleep(3600)
        return 0
    ctx = zmq.Context()
    pub = ctx.socket(zmq.PUB)
    pub.setsockopt(zmq.SNDHWM, 0)
    pub.bind(a.tracks)
    sub = ctx.socket(zmq.SUB)
    sub.setsockopt(zmq.RCVHWM, 0)
    sub.connect(a.plots)
    sub.setsockopt(zmq.SUBSCRIBE, b"")  # the oracle reads the truth: a test tracker only
    covered: dict[str, np.ndarray] = {}
    first = None
    sent = 0
    while True:
        if not sub.poll(20000):
            return 0
        topic, t, p = decode(sub.recv_multipart())
        if topic == b"meta":
            first = first or p["sensor"]
        elif topic == b"truth" and p["kind"] == "targets":
            covered[p["sensor"]] = np.asarray(p["in_coverage"], bool)
            if p["sensor"] != first or a.mode == "silent":
                continue
            pos = np.stack([p["east_m"], p["north_m"], p["up_m"]], axis=-1)
            seen = np.logical_or.reduce(list(covered.values()))
            idx = np.flatnonzero(seen & np.asarray(p["active"], bool))
            tracks = {
                "sensor": p["sensor"], "scan": p["scan"], "time_s": p["time_s"],
                "track_id": [f"T{j}" for j in idx],
                "east_m": pos[idx, 0] + a.shift_m, "north_m": pos[idx, 1].copy(),
                "v_east_mps": np.asarray(p["v_east_mps"])[idx],
                "v_north_mps": np.asarray(p["v_north_mps"])[idx],
                "sigma_east_m": np.ones(idx.size), "sigma_north_m": np.ones(idx.size),
            }
            if a.mode == "malformed":
                bad = dict(tracks)
                del bad["track_id"]
                pub.send_multipart(encode(b"tracks", t, bad))
                pub.send_multipart([b"tracks", b"\xc1 not msgpack"])
            pub.send_multipart(encode(b"tracks", t, tracks))
            sent += 1
            if a.mode == "crash" and sent >= a.after:
                print("evaluate_trackers: crashing on purpose", file=sys.stderr, flush=True)
                return 3


if __name__ == "__main__":
    raise SystemExit(main())
