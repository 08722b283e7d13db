"""DIS input under load (issue 32): 2,000 entities at 5 Hz beside the raid's two radars, in
real time; the receive path's CPU and the scan cost against the same targets as YAML.

    .venv/bin/python benchmarks/dis_load.py [--entities 2000] [--rate 5] [--duration 20]

A sender process (opendis only: the PDUs are built and serialized once, then sent round
after round at ``--rate`` per entity, 10,000 PDUs/s by default) feeds ``--entities`` ships and
aircraft within 50 km of the raid's frigate; the raid's two radars (SPS-49-like and
Giraffe-like, their tables from the cache) run ``--duration`` s at the wall clock's pace with
no targets of their own.  Measured:

* the receiving thread's CPU time (the socket, the batch decoder, checks, the frame
  conversion) per wall second: the fraction of one core the receive path takes;
* the run's own CPU per scan (the main thread: taking the updates, dead reckoning,
  crossings, dwells), against the same entities given as YAML targets (constant-velocity
  waypoints through the same states) in fast mode, and the part of it spent taking the
  updates (``Simulation.refresh_live``: drain, checks, apply);
* PDUs received, dropped, superseded and counted bad;
* memory per 1,000 entities (``--memory``, no sender): ``--entities`` Entity State PDUs (made
  with the decoder's own dtype) through a receiver's batch path, the drain, the checks and a
  live target list, under tracemalloc: what stays allocated (the receiver's per-entity
  tables, the target list) and the peak.
"""

from __future__ import annotations

import argparse
import math
import os
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np

from shipradar.sim.adapters.dis import DisReceiver
from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.world.kinematics import LocalFrame
from shipradar.sim.world.scenario import load_scenario, parse_scenario
from shipradar.tables.scene import load_scene_tables

ROOT = Path(__file__).resolve().parents[1]

SENDER = textwrap.dedent("""
    import math, socket, sys, time
    from io import BytesIO
    from opendis.DataOutputStream import DataOutputStream
    from opendis.dis7 import EntityID, EntityStatePdu, EntityType, Vector3Double, Vector3Float
    port, n = int(sys.argv[1]), int(sys.argv[2])
    rate, seconds = float(sys.argv[3]), float(sys.argv[4])
    A, B = 6378137.0, 6356752.31424518
    def ecef(lat, lon, h):
        lat, lon = math.radians(lat), math.radians(lon)
        N = A * A / math.hypot(A * math.cos(lat), B * math.sin(lat))
        return ((N + h) * math.cos(lat) * math.cos(lon), (N + h) * math.cos(lat) * math.sin(lon),
                (N * (B / A) ** 2 + h) * math.sin(lat))
    pdus = []
    for k in range(n):
        r, b = 5000.0 + 45000.0 * ((k * 0.618034) % 1.0), 2.399963 * k
        lat = 44.6 + math.degrees(r * math.cos(b) / 6367000.0)
        lon = -63.0 + math.degrees(r * math.sin(b) / (6388000.0 * math.cos(math.radians(44.6))))
        air = k % 4 == 0
        p = EntityStatePdu()
        p.protocolVersion, p.exerciseID, p.pduStatus = 7, 1, 0
        p.pduType, p.protocolFamily = 1, 1
        p.entityID = EntityID(1, 1 + k // 60000, 1 + k % 60000)
        p.entityType = EntityType(1, 2 if air else 3, 39, 1, 1, 0, 0)
        p.entityLocation = Vector3Double(*ecef(lat, lon, 3000.0 if air else 0.0))
        p.entityLinearVelocity = Vector3Float(0.0, 0.0, 0.0)
        p.deadReckoningParameters.deadReckoningAlgorithm = 2
        p.marking.setString(f"E{k}")
        p.entityAppearance, p.capabilities = 0, 0
        buf = BytesIO()
        p.serialize(DataOutputStream(buf))
        d = bytearray(buf.getvalue())
        d[8:10] = len(d).to_bytes(2, "big")
        pdus.append(bytes(d))
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    to = ("127.0.0.1", port)
    t0 = time.monotonic()
    period = 1.0 / rate
    k = 0
    while time.monotonic() - t0 < seconds:
        for i, d in enumerate(pdus):
            sock.sendto(d, to)
            if i % 200 == 199:  # spread a round over its period
                lag = t0 + k * period + (i + 1) * period / n - time.monotonic()
                if lag > 0:
                    time.sleep(lag)
        k += 1
""")


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sk:
        sk.bind(("127.0.0.1", 0))
        return int(sk.getsockname()[1])


def memory(n: int, scene) -> None:
    """Memory per 1,000 entities of the live path (module notes)."""
    import gc
    import tracemalloc

    from shipradar.sim.adapters.dis import ESPDU_DTYPE
    from shipradar.sim.world import geodesy
    from shipradar.sim.world.live import LiveTargets, check_states

    k = np.arange(n)
    rec = np.zeros(n, ESPDU_DTYPE)
    rec["version"], rec["pdu_type"], rec["family"], rec["length"] = 7, 1, 1, 144
    rec["site"], rec["application"], rec["entity"] = 1, 1 + k // 60000, 1 + k % 60000
    rec["type"] = [1, 3, 0, 39, 1, 1, 0, 0]
    r, b = 5000.0 + 45000.0 * ((k * 0.618034) % 1.0), 2.399963 * k
    lat, lon = 44.6 + np.degrees(r * np.cos(b) / 6367000.0), -63.0 + np.degrees(
        r * np.sin(b) / (6388000.0 * np.cos(np.radians(44.6))))
    rec["location"] = np.column_stack(geodesy.geodetic2ecef(lat, lon, 0.0))
    rec["dr_algorithm"] = 2
    rec["marking"][:, :6] = np.frombuffer(b"".join(f"E{i:05d}".encode() for i in k),
                                          np.uint8).reshape(n, 6)
    data = [d.tobytes() for d in rec]
    frame = LocalFrame(scene.origin)
    rx = DisReceiver(f"udp://127.0.0.1:{free_port()}", frame, queue_size=10 * n)
    try:
        gc.collect()
        tracemalloc.start()
        with rx._lock:
            for lo in range(0, n, 1024):
                rx._batch(data[lo:lo + 1024], [0.0] * len(data[lo:lo + 1024]))
        live = LiveTargets(scene)
        for payload in rx.drain(0.0):
            live.apply(check_states(payload, live.bad), 0.0)
        del payload
        gc.collect()
        kept, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    finally:
        rx.close()
    print(f"memory, {live.n} entities (receiver tables + live target list): "
          f"{kept / 2**20 * 1000 / n:.2f} MiB per 1,000 entities kept, "
          f"peak {peak / 2**20 * 1000 / n:.2f} MiB per 1,000 while taking them")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--entities", type=int, default=2000)
    ap.add_argument("--rate", type=float, default=5.0)
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--memory", action="store_true",
                    help="measure memory per 1,000 entities only (no sender, no run)")
    args = ap.parse_args()
    raid = load_scenario(ROOT / "scenarios" / "raid.yaml")
    d = raid.model_dump(mode="json")
    d["targets"] = []
    d["entity_types"] = [
        {"match": "1:3:*", "kind": "ship", "rcs": {"type": "constant", "sigma_m2": 1000.0}},
        {"match": "1:2:*", "kind": "aircraft", "rcs": {"type": "constant", "sigma_m2": 10.0}}]
    d["external"] = {"queue_size": 1_000_000}
    scene = parse_scenario(d)
    if args.memory:
        memory(args.entities, scene)
        return
    tables = load_scene_tables(scene)
    frame = LocalFrame(scene.origin)
    port = free_port()
    rx = DisReceiver(f"udp://127.0.0.1:{port}", frame, queue_size=1_000_000)
    proc = subprocess.Popen([sys.executable, "-c", SENDER, str(port), str(args.entities),
                             str(args.rate), str(args.duration + 30.0)])
    try:
        if not rx.first_entity.wait(60.0):
            raise SystemExit("the sender never reached the receiver")
        warm = time.monotonic() + 1.0 / args.rate + 0.5  # one whole round in the queue first
        while time.monotonic() < warm:
            rx.first_entity.wait(0.05)
        sim = Simulation(scene, realtime=1.0, entities=rx, duration_s=args.duration)
        taking = [0.0]
        refresh = sim.refresh_live

        def timed_refresh(now: float) -> None:
            c = time.thread_time()
            refresh(now)
            taking[0] += time.thread_time() - c

        sim.refresh_live = timed_refresh  # type: ignore[method-assign]
        st0 = rx.stats()
        w0, c0 = time.monotonic(), time.thread_time()
        summary = sim.run()
        wall, main_cpu = time.monotonic() - w0, time.thread_time() - c0
        st1 = rx.stats()
    finally:
        proc.kill()
        proc.wait(10)
        rx.close()
    scans = summary["scans"]
    recv_cpu = st1["cpu_s"] - st0["cpu_s"]
    pdus = st1["entity_states"] - st0["entity_states"]
    print(f"{args.entities} entities x {args.rate:g} Hz, raid radars, {args.duration:g} s real "
          f"time: {summary['live']['entities']} entities, {pdus} PDUs in the run "
          f"({pdus / wall:.0f}/s), dropped {st1['dropped']}, superseded "
          f"{st1['superseded'] - st0['superseded']}, bad {st1['bad_datagrams']}, "
          f"wall {wall:.2f} s")
    print(f"receive path: {recv_cpu:.2f} s CPU over {wall:.2f} s = {100 * recv_cpu / wall:.1f} % "
          f"of one core ({1e6 * recv_cpu / max(pdus, 1):.1f} us per PDU)")
    # the same entities as YAML targets (constant velocity: their states stand still)
    live = sim.target_set
    pos, _, _ = live.state(np.zeros(live.n), np.arange(live.n))
    yd = dict(d)
    yd.pop("external")
    yd["targets"] = [
        {"id": f"e{k}", "kind": live.kinds[k], "rcs": live.rcs[k].model_dump(),
         "waypoints": [{"time_s": 0.0, "east_m": float(p[0]), "north_m": float(p[1]),
                        "altitude_m": max(0.0, float(p[2]))},
                       {"time_s": args.duration + 1.0, "east_m": float(p[0]),
                        "north_m": float(p[1]), "altitude_m": max(0.0, float(p[2]))}]}
        for k, p in enumerate(pos)]
    twin = parse_scenario(yd)
    best = math.inf
    for _ in range(2):
        s2 = Simulation(twin, tables=tables, duration_s=args.duration)
        c1 = time.thread_time()
        s2.run()
        best = min(best, time.thread_time() - c1)
    print(f"scan cost (main thread CPU per scan, {scans} scans of two radars): DIS "
          f"{1e3 * main_cpu / scans:.2f} ms (idle waits excluded; taking the updates "
          f"{1e3 * taking[0] / scans:.2f} ms of it); the same targets in YAML "
          f"{1e3 * best / scans:.2f} ms; ratio {main_cpu / best:.2f}")
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
