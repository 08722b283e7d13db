"""Bus throughput: plots/s end to end over loopback TCP, per-plot vs columnar framing.

End to end = encode + publish (``shipradar.sim.stream.bus.Publisher``, pace mode) in this process,
receive + decode (``shipradar.sim.stream.protocol.decode``) in a subscriber process, timed until the
subscriber has decoded the last plot. Also the recorder's write and read rates.

Usage::

    .venv/bin/python benchmarks/bus.py [--plots N] [--per-dwell K]

SPEC section 5 expects about 1e5 plots/s with one frame per plot and about 2e6 plots/s with
one columnar frame per dwell on a 2-core machine.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import tempfile
import time
from pathlib import Path

import numpy as np

from shipradar.sim.stream.bus import Publisher
from shipradar.sim.stream.protocol import TOPIC_EOS, TOPIC_PLOTS, decode, encode
from shipradar.sim.stream.recording import Recorder, read_recording

COLUMNS = ("time_s", "range_m", "azimuth_rad", "snr_db", "sigma_range_m", "sigma_azimuth_rad")


def dwell_payload(rng: np.random.Generator, scan: int, k: int) -> dict:
    """A plot message as the engine sends it: one column per field, ``k`` plots."""
    payload: dict = {"sensor": "sps49", "scan": scan}
    for name in COLUMNS:
        payload[name] = rng.uniform(0.0, 1e5, k)
    payload["interference"] = rng.integers(0, 3, k, dtype=np.uint8)
    return payload


def plot_payloads(rng: np.random.Generator, n: int) -> list[dict]:
    """``n`` one-plot messages with scalar fields."""
    cols = {name: rng.uniform(0.0, 1e5, n).tolist() for name in COLUMNS}
    interference = rng.integers(0, 3, n).tolist()
    return [
        {"sensor": "sps49", "scan": 0, **{c: cols[c][i] for c in COLUMNS},
         "interference": interference[i]}
        for i in range(n)
    ]  # fmt: skip


def subscriber(endpoint: str, conn) -> None:
    """Receive and decode until the end marker; send back the number of plots decoded."""
    import zmq

    ctx = zmq.Context()
    sock = ctx.socket(zmq.SUB)
    sock.setsockopt(zmq.RCVHWM, 10_000)
    sock.connect(endpoint)
    sock.setsockopt(zmq.SUBSCRIBE, b"")
    plots = 0
    while True:
        topic, _t, payload = decode(sock.recv_multipart())
        if topic == TOPIC_EOS:
            break
        r = payload["range_m"]
        plots += r.size if isinstance(r, np.ndarray) else 1
    conn.send(plots)
    sock.close(linger=0)
    ctx.term()


def end_to_end(payloads: list[dict], expected_plots: int) -> dict:
    """Publish ``payloads`` to a subscriber process; plots/s until it decoded them all."""
    pub = Publisher("tcp://127.0.0.1:*", wait_subscribers=1, wait_timeout_s=30)
    parent, child = mp.Pipe()
    proc = mp.get_context("spawn").Process(target=subscriber, args=(pub.endpoint, child))
    proc.start()
    pub.wait_for_subscribers()
    t0 = time.perf_counter()
    for i, p in enumerate(payloads):
        pub.send(encode(TOPIC_PLOTS, 0.001 * i, p))
    pub.send(encode(TOPIC_EOS, 0.0, {"scan": 0}))
    plots = parent.recv()
    wall = time.perf_counter() - t0
    stats = pub.stats
    pub.close()
    proc.join(30)
    assert plots == expected_plots, (plots, expected_plots)
    return {
        "messages": len(payloads),
        "plots": plots,
        "wall_s": round(wall, 3),
        "plots_per_s": round(plots / wall),
        "paced_s": round(stats["paced_s"], 3),
        "dropped": stats["dropped"],
    }


def encode_decode_only(payloads: list[dict]) -> dict:
    t0 = time.perf_counter()
    frames = [encode(TOPIC_PLOTS, 0.0, p) for p in payloads]
    t1 = time.perf_counter()
    for f in frames:
        decode(f)
    t2 = time.perf_counter()
    n = len(payloads)
    return {"encode_us_per_msg": round((t1 - t0) / n * 1e6, 2),
            "decode_us_per_msg": round((t2 - t1) / n * 1e6, 2)}  # fmt: skip


def recorder_rate(payloads: list[dict], per_scan: int) -> dict:
    frames = [encode(TOPIC_PLOTS, 0.001 * i, p) for i, p in enumerate(payloads)]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.srrec"
        t0 = time.perf_counter()
        with Recorder(path) as rec:
            for i, f in enumerate(frames):
                rec.write(0.001 * i, f)
                if i % per_scan == per_scan - 1:
                    rec.flush()  # the engine flushes at every end of scan
        t1 = time.perf_counter()
        size = path.stat().st_size
        n = sum(1 for _ in read_recording(path))
        t2 = time.perf_counter()
    assert n == len(frames)
    return {"bytes": size, "write_MB_per_s": round(size / (t1 - t0) / 1e6),
            "read_MB_per_s": round(size / (t2 - t1) / 1e6),
            "records_per_s_write": round(n / (t1 - t0))}  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plots", type=int, default=2_000_000, help="plots, columnar runs")
    parser.add_argument("--single-plots", type=int, default=200_000, help="plots, per-plot run")
    parser.add_argument("--per-dwell", type=int, default=100, help="plots per columnar frame")
    args = parser.parse_args()
    rng = np.random.default_rng(0)

    single = plot_payloads(rng, args.single_plots)
    dwells = [dwell_payload(rng, i, args.per_dwell) for i in range(args.plots // args.per_dwell)]
    results = {
        "one_frame_per_plot": {**end_to_end(single, len(single)),
                               **encode_decode_only(single[:20_000])},
        f"columnar_{args.per_dwell}_per_frame": {
            **end_to_end(dwells, len(dwells) * args.per_dwell),
            **encode_decode_only(dwells[:5_000])},
        "recorder_columnar": recorder_rate(dwells, per_scan=100),
    }  # fmt: skip
    for name, res in results.items():
        print(json.dumps({"case": name, **res}))


if __name__ == "__main__":
    main()
