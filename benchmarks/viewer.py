"""shipradar view under load: a live run as fast as possible, one page that keeps up and one
that never reads.

Prints one JSON line: the run's wall time and paced time with and without the viewer, what
the viewer read, what it pushed to the fast page (items and batches per second, latency from
the batch's creation to its receipt) and what it dropped for the stalled page.

    python benchmarks/viewer.py [SCENARIO] [--duration S]
"""

from __future__ import annotations

import argparse
import asyncio
import base64
import json
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def stalled_page(port: int) -> socket.socket:
    """A WebSocket that is opened and never read (small receive buffer)."""
    sock = socket.socket()
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall((f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
                  f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                  "Sec-WebSocket-Version: 13\r\n\r\n").encode())
    head = b""
    while b"\r\n\r\n" not in head:
        head += sock.recv(1)
    return sock


def main() -> int:
    import aiohttp

    from shipradar.sim.adapters.viewer.server import ViewerServer, ViewerThread
    from shipradar.sim.adapters.viewer.wire import unpack_batch
    from shipradar.sim.world.scenario import load_scenario
    from shipradar.tables.scene import load_scene_tables

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", nargs="?", default=str(ROOT / "scenarios" / "raid.yaml"))
    ap.add_argument("--duration", type=float, default=120.0)
    a = ap.parse_args()
    s = load_scenario(a.scenario)
    load_scene_tables(s)  # built once, before anything is timed

    endpoint = f"tcp://127.0.0.1:{free_port()}"

    def run(*extra):
        """The run as users start it: its own process (the viewer does not share its GIL)."""
        out = subprocess.run([sys.executable, "-m", "shipradar.sim.cli", "run", a.scenario,
                              "--duration", str(a.duration), "--publish", endpoint,
                              "--quiet", *extra], capture_output=True, text=True, check=True)
        return json.loads(out.stdout.strip().splitlines()[-1])

    ref = run()  # reference: a publisher nobody reads
    server = ViewerServer(endpoint, port=0)
    stats = {"items": 0, "batches": 0, "bytes": 0, "lat_ms": [], "first": None, "last": None}
    stop = threading.Event()
    ready = threading.Event()

    async def fast_page():
        async with aiohttp.ClientSession() as session, \
                session.ws_connect(server.url + "ws", max_msg_size=0) as ws:
            ready.set()
            while not stop.is_set():
                try:
                    msg = await asyncio.wait_for(ws.receive(), 0.2)
                except asyncio.TimeoutError:
                    continue
                if msg.type != aiohttp.WSMsgType.BINARY:
                    break
                b = unpack_batch(msg.data)
                now = time.monotonic()
                if stats["first"] is None and any(it["k"] == "plots" for it in b["items"]):
                    stats["first"] = now  # the stream starts (not the page's greeting)
                stats["last"] = now
                stats["lat_ms"].append(time.time() * 1000 - b["ws"])
                stats["items"] += len(b["items"])
                stats["batches"] += 1
                stats["bytes"] += len(msg.data)

    with ViewerThread(server) as viewer:
        port = int(server.url.rsplit(":", 1)[1].strip("/"))
        page = threading.Thread(target=lambda: asyncio.run(fast_page()), daemon=True)
        page.start()
        ready.wait(10)
        stalled = stalled_page(port)
        while viewer.call(lambda: len(server.clients)) < 2:
            time.sleep(0.01)
        # on_slow=drop: any backpressure from the viewer would show as drops
        run = run("--wait-subscribers", "1", "--on-slow", "drop")
        sent = run["bus"]["publisher"]["sent"]
        while viewer.call(lambda: server.live.received) < sent:
            time.sleep(0.01)
        time.sleep(1.0)
        pages = viewer.call(lambda: [c.status() for c in server.clients])
        stop.set()
        page.join(5)
        stalled.close()
    lat = sorted(stats["lat_ms"])
    span = max(1e-9, (stats["last"] or 0) - (stats["first"] or 0))
    q = (lambda f: round(lat[min(len(lat) - 1, int(f * len(lat)))], 1)) if lat else (
        lambda f: None)
    print(json.dumps({
        "scenario": s.name, "simulated_s": run["simulated_s"],
        "messages": sent, "plots": run["target_plots"] + run["noise_false_alarms"]
        + run["clutter_false_alarms"],
        "run_wall_s_without_viewer": ref["wall_s"], "run_wall_s_with_viewer": run["wall_s"],
        "paced_s": run["bus"]["publisher"]["paced_s"],
        "same_counts": all(run[k] == ref[k] for k in (
            "scans", "target_plots", "noise_false_alarms", "clutter_false_alarms")),
        "dropped_zmq": run["bus"]["publisher"]["dropped"],
        "page_stream_s": round(span, 3),
        "fast_page": {"items": stats["items"], "batches": stats["batches"],
                      "items_per_s": round(stats["items"] / span),
                      "batches_per_s": round(stats["batches"] / span),
                      "mbytes": round(stats["bytes"] / 1e6, 2),
                      "latency_ms_p50": q(0.5), "latency_ms_p95": q(0.95),
                      "latency_ms_max": q(1.0)},
        "pages": pages,
    }))
    return 0


if __name__ == "__main__":
    sys.exit(main())
