"""Recording cost and zstd compression on the raid: size ratio, write cost, read cost.

Runs the raid once in process and keeps its messages (encoded frames), then, in this one
process, writes them with each compression and reads them back, several times, and prints
the medians: bytes on disk, ratio to uncompressed, write and read time per message and per
MB of stream, and those as a share of the run's own wall time. Also checks that each
compression gives byte-identical files for the same messages (determinism).

    python benchmarks/recording.py [--duration S] [--repeat N]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream import protocol
from shipradar.sim.stream.recording import Recorder, read_recording
from shipradar.sim.world.scenario import load_scenario
from shipradar.tables.scene import load_scene_tables

ROOT = Path(__file__).resolve().parents[1]


class _Keep:
    """A bus that encodes each message once, as the real one does, and keeps the frames."""

    def __init__(self):
        self.items: list[tuple[float, list[bytes]]] = []

    def emit(self, topic, t, payload):
        self.items.append((t, protocol.encode(topic, t, payload)))

    def flush(self, fsync=False):
        pass


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=300.0, help="simulated seconds [s]")
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    scene = load_scenario(ROOT / "scenarios/raid.yaml")
    tables = load_scene_tables(scene)
    keep = _Keep()
    t0 = time.perf_counter()
    Simulation(scene, bus=keep, tables=tables, duration_s=a.duration).run()
    run_s = time.perf_counter() - t0
    msgs = keep.items
    stream = sum(len(f[0]) + len(f[1]) for _, f in msgs)
    out = {"scenario": "raid", "simulated_s": a.duration, "messages": len(msgs),
           "stream_bytes": stream, "run_wall_s_with_encoding": round(run_s, 3),
           "load_avg_1min": os.getloadavg()[0], "cases": {}}
    with tempfile.TemporaryDirectory() as d:
        sizes = {}
        for comp in ("none", "zstd"):
            writes, reads, blobs = [], [], set()
            for i in range(a.repeat):
                path = Path(d) / f"{comp}{i}.srrec"
                t0 = time.perf_counter()
                with Recorder(path, compress=comp) as rec:
                    for t, frames in msgs:
                        rec.write(t, frames)
                writes.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                with read_recording(path, strict=True) as reader:
                    n = sum(1 for _ in reader)
                reads.append(time.perf_counter() - t0)
                assert n == len(msgs)
                blobs.add(path.read_bytes())
                sizes[comp] = path.stat().st_size
            w, r = statistics.median(writes), statistics.median(reads)
            out["cases"][comp] = {
                "file_bytes": sizes[comp],
                "ratio_to_uncompressed": round(sizes[comp] / sizes["none"], 4),
                "write_s": round(w, 4), "read_s": round(r, 4),
                "write_us_per_message": round(1e6 * w / len(msgs), 2),
                "read_us_per_message": round(1e6 * r / len(msgs), 2),
                "write_mb_per_s": round(stream / w / 1e6, 1),
                "read_mb_per_s": round(stream / r / 1e6, 1),
                "write_share_of_run": round(w / run_s, 4),
                "deterministic": len(blobs) == 1,
            }
    z, n = out["cases"]["zstd"], out["cases"]["none"]
    out["zstd_over_none"] = {"size": z["ratio_to_uncompressed"],
                             "write_time": round(z["write_s"] / n["write_s"], 2),
                             "read_time": round(z["read_s"] / n["read_s"], 2)}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
