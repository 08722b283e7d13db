"""Trackers with known scores for tests/test_evaluate.py, run as ``--tracker`` commands.

``python tests/evaluate_trackers.py MODE {plots} {tracks} [--shift-m D] [--after N]``:

- ``oracle``: publishes the truth topic's counted targets (the harness's own definition,
  :func:`shipradar.sim.studies.evaluate.metrics.counted_matrix`, by its default rule or
  ``--truth``: ``pd``, active and some radar's look of the last three of its scans reached
  the P_d threshold; ``coverage``, active and ``in_coverage`` in some radar's latest
  ``truth[targets]``) as its tracks at every end of scan of the first radar, ids
  ``T<index>``; ``--shift-m D`` moves them D metres east;
- ``silent``: subscribes and reads, never publishes;
- ``crash``: like the oracle, then exits with code 3 and a message on stderr after
  ``--after`` tracks messages;
- ``malformed``: publishes, at every end of scan, one message lacking ``track_id``, one
  that is not msgpack, then a valid oracle message;
- ``never``: sleeps without subscribing (until the harness stops it);
- ``asterix``: ASTERIX only, ``python tests/evaluate_trackers.py asterix {asterix} {tracks}
  --tod0 S``: decodes the UDP datagrams with asterix-decoder (PyPI, not ours) and, at each
  CAT034 north marker, publishes the revolution's CAT048 plots as tracks, placed by I042 (x,
  y from the radar [NM]) plus the radar's CAT034 I120 position relative to its first report
  (flat earth: the ship starts at the origin); ``time_s`` = the marker's time of day minus
  ``--tod0``, the scenario's start.
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
from shipradar.sim.studies.evaluate.metrics import (  # noqa: E402
    DEFAULT_METRICS,
    PD_WINDOW_SCANS,
)


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", choices=("oracle", "silent", "crash", "malformed", "never",
                                     "asterix"))
    ap.add_argument("plots", help="the plots endpoint; for asterix, the UDP destination")
    ap.add_argument("tracks")
    ap.add_argument("--shift-m", type=float, default=0.0)
    ap.add_argument("--after", type=int, default=3)
    ap.add_argument("--tod0", type=float, default=0.0)
    ap.add_argument("--truth", choices=("coverage", "pd"), default=DEFAULT_METRICS.truth)
    a = ap.parse_args()
    if a.mode == "never":
        time.sleep(3600)
        return 0
    if a.mode == "asterix":
        return asterix_tracker(a.plots, a.tracks, a.tod0)
    ctx = zmq.Context()
    pub = ctx.socket(zmq.PUB)
    pub.setsockopt(zmq.SNDHWM, 0)
    pub.bind(a.tracks)
    sub = ctx.socket(zmq.SUB)
    sub.setsockopt(zmq.RCVHWM, 0)
    sub.connect(a.plots)
    sub.setsockopt(zmq.SUBSCRIBE, b"")  # the oracle reads the truth: a test tracker only
    covered: dict[str, np.ndarray] = {}
    looks: dict[str, list[tuple[float, np.ndarray, np.ndarray]]] = {}
    period: dict[str, float] = {}
    first = None
    sent = 0
    while True:
        if not sub.poll(20000):
            return 0
        topic, t, p = decode(sub.recv_multipart())
        if topic == b"meta":
            first = first or p["sensor"]
            period[p["sensor"]] = float(p["scan_period_s"])
        elif topic == b"truth" and p["kind"] == "targets":
            covered[p["sensor"]] = np.asarray(p["in_coverage"], bool)
            looks.setdefault(p["sensor"], []).append(
                (p["time_s"], np.asarray(p["look_time_s"]), np.asarray(p["pd"])))
            if p["sensor"] != first or a.mode == "silent":
                continue
            pos = np.stack([p["east_m"], p["north_m"], p["up_m"]], axis=-1)
            if a.truth == "coverage":
                seen = np.logical_or.reduce(list(covered.values()))
            else:  # a look of the window reached the threshold, for some radar
                now = p["time_s"]
                seen = np.zeros(pos.shape[0], bool)
                for s, copies in looks.items():
                    w = PD_WINDOW_SCANS * period[s]
                    for tc, lt, pd in copies:
                        if now - w < tc <= now + 1e-6:
                            n = min(lt.size, seen.size)
                            ok = np.nan_to_num(pd[:n]) >= DEFAULT_METRICS.pd_threshold
                            seen[:n] |= ok & (np.nan_to_num(lt[:n], nan=-np.inf) > now - w)
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


NM = 1852.0


def asterix_tracker(destination: str, tracks_endpoint: str, tod0: float) -> int:
    import math
    import socket

    import asterix  # asterix-decoder (PyPI)

    host, port = destination.removeprefix("udp://").rsplit(":", 1)
    udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    # the simulator sends in fast mode, unpaced (UDP): room for the whole demo's datagrams
    udp.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
    udp.bind((host, int(port)))  # before {tracks}: the harness starts the run once it is bound
    udp.settimeout(20.0)
    pub = zmq.Context().socket(zmq.PUB)
    pub.setsockopt(zmq.SNDHWM, 0)
    pub.bind(tracks_endpoint)
    ref = None
    radar = (0.0, 0.0)
    east: list[float] = []
    north: list[float] = []
    scan = 0
    while True:
        try:
            datagram = udp.recv(65536)
        except TimeoutError:
            return 0
        for r in asterix.parse(datagram):
            if r["category"] == 48:
                east.append(radar[0] + r["I042"]["X"]["val"] * NM)
                north.append(radar[1] + r["I042"]["Y"]["val"] * NM)
            elif r["I000"]["MsgTyp"]["val"] == 1:  # north marker: the revolution is complete
                p = r["I120"]
                lat, lon = p["LAT"]["val"], p["Lon"]["val"]
                ref = ref or (lat, lon)
                radar = ((lon - ref[1]) * 111_320.0 * math.cos(math.radians(lat)),
                         (lat - ref[0]) * 111_132.0)
                t = r["I030"]["ToD"]["val"] - tod0
                n = len(east)
                tracks = {"sensor": "asterix", "scan": scan, "time_s": t,
                          "track_id": [f"P{scan}.{j}" for j in range(n)],
                          "east_m": np.array(east), "north_m": np.array(north),
                          "v_east_mps": np.zeros(n), "v_north_mps": np.zeros(n),
                          "sigma_east_m": np.full(n, 100.0), "sigma_north_m": np.full(n, 100.0)}
                pub.send_multipart(encode(b"tracks", t, tracks))
                east, north = [], []
                scan += 1


if __name__ == "__main__":
    raise SystemExit(main())
