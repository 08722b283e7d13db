"""False-alarm generation speed and its share of a raid run's wall time (issue 7).

    python benchmarks/false_alarms.py [--duration 600] [--scenario scenarios/raid.yaml]

1. Generator alone: sea-clutter false alarms per second of
   :meth:`shipradar.sensors.false_alarms.ClutterFalseAlarms.scan` (counts per sector [91]-[93],
   uniform positions, beam times, spike S/I, errors [84]-[85]) on the scenario's P_fac map, and
   noise false alarms per second of the model's noise path (count, positions, plot columns).
2. In a run (fast mode, no bus): the time spent inside the model's false-alarm generators
   (timed by wrapping the public methods of each radar's ``model.false_alarms``:
   ``clutter_false_alarms``, ``noise_false_alarms`` and ``false_alarm_plots``) as a
   share of the run's wall time, and the end-to-end cost (also
   merging, sorting and emitting those plots): the same run with the clutter false alarms
   switched off.
3. The same two runs with every message encoded (msgpack frames, as a publisher or recorder
   would send them; no socket).
Tables are built or loaded before anything is timed.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from shipradar.sim.dwell.model import DwellModel
from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.world.scenario import load_scenario
from shipradar.tables.pfac import clutter_false_alarm_generator
from shipradar.tables.scene import load_scene_tables

ROOT = Path(__file__).resolve().parents[1]


def generator_rates(scenario, tables, scans: int = 300) -> dict:
    """False alarms per second of the clutter and noise generators alone, per radar."""
    out = {}
    for platform, radar in scenario.radars():
        model = DwellModel(scenario, platform, radar, tables)
        rng = np.random.default_rng(1)
        omega = 2.0 * math.pi / radar.scan_period_s
        row = {}
        if model.tables.pfac is not None:
            gen = clutter_false_alarm_generator(model.tables.pfac, pfa=model.pfa,
                                                n_channels=radar.n_channels,
                                                n_pulses=model.n_pulses)
            gen.scan(0.0, 1e9, 0.0, omega, rng)  # warm-up
            n, t0 = 0, time.perf_counter()
            for _ in range(scans):
                n += gen.scan(0.0, 1e9, 0.0, omega, rng)["range_m"].size
            dt = time.perf_counter() - t0
            row.update(clutter_active_sectors=int(gen.eta.size),
                       clutter_per_scan=round(n / scans, 1),
                       clutter_ms_per_scan=round(1e3 * dt / scans, 3),
                       clutter_fa_per_s=round(n / dt))
        # noise: force a large η so that the rate is per plot, not per call
        model.noise_false_alarms_per_scan = 2000.0
        n, t0 = 0, time.perf_counter()
        for _ in range(scans):
            fa = model.false_alarms.noise_false_alarms(rng)
            t = np.mod(fa["azimuth_rad"], 2 * math.pi) / omega
            n += model.false_alarms.false_alarm_plots(fa["range_m"], fa["azimuth_rad"], t, rng)[
                "range_m"].size
        dt = time.perf_counter() - t0
        row.update(noise_fa_per_s=round(n / dt))
        out[radar.id] = row
    return out


def _timed(fn, acc: list):
    def wrapper(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            acc[0] += time.perf_counter() - t0
    return wrapper


class _EncodeBus:
    """Encodes every message as a publisher would (msgpack frames), then drops it."""

    def emit(self, topic, t, payload):
        from shipradar.sim.stream import protocol

        protocol.encode(topic, t, payload)

    def flush(self):
        pass


def run_share(scenario, tables, duration: float, clutter_fa: bool = True,
              encode: bool = False) -> dict:
    """One run: wall time, time inside the false-alarm generators, counts.

    ``encode``: every message is encoded (the cost of publishing, minus the socket)."""
    sim = Simulation(scenario, bus=_EncodeBus() if encode else None, duration_s=duration,
                     tables=tables)
    t_clutter, t_noise = [0.0], [0.0]
    for rp in sim.radars:
        # the model's public generators, timed on each radar's instance
        fam = rp.model.false_alarms
        if clutter_fa:
            fam.clutter_false_alarms = _timed(fam.clutter_false_alarms, t_clutter)
        else:
            fam.clutter_false_alarms = lambda *a, **k: None
        fam.noise_false_alarms = _timed(fam.noise_false_alarms, t_noise)
        fam.false_alarm_plots = _timed(fam.false_alarm_plots, t_noise)
    t0 = time.perf_counter()
    summary = sim.run()
    wall = time.perf_counter() - t0
    return {
        "wall_s": round(wall, 3),
        "clutter_generator_s": round(t_clutter[0], 3),
        "noise_generator_s": round(t_noise[0], 3),
        "generator_share": round((t_clutter[0] + t_noise[0]) / wall, 4),
        "clutter_false_alarms": summary["clutter_false_alarms"],
        "noise_false_alarms": summary["noise_false_alarms"],
        "target_plots": summary["target_plots"],
        "realtime_factor": round(duration / wall, 1),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default=str(ROOT / "scenarios/raid.yaml"))
    ap.add_argument("--duration", type=float, default=600.0)
    args = ap.parse_args()
    s = load_scenario(args.scenario)
    tables = load_scene_tables(s)
    rates = generator_rates(s, tables)
    on = run_share(s, tables, args.duration, True)
    off = run_share(s, tables, args.duration, False)
    end_to_end = (on["wall_s"] - off["wall_s"]) / on["wall_s"]
    on_enc = run_share(s, tables, args.duration, True, encode=True)
    off_enc = run_share(s, tables, args.duration, False, encode=True)
    end_to_end_enc = (on_enc["wall_s"] - off_enc["wall_s"]) / on_enc["wall_s"]
    print(f"scenario {s.name}, {args.duration:g} simulated s")
    for rid, r in rates.items():
        print(f"  {rid}: {r}")
    print(f"run with clutter false alarms : {on}")
    print(f"run without                   : {off}")
    print(f"generators' share of the run wall time: {100 * on['generator_share']:.1f} % "
          f"(clutter {100 * on['clutter_generator_s'] / on['wall_s']:.1f} %, "
          f"noise {100 * on['noise_generator_s'] / on['wall_s']:.1f} %); "
          f"end to end (on vs off): {100 * end_to_end:.1f} %")
    print(f"with every message encoded    : on {on_enc}")
    print(f"                                off {off_enc}")
    print(f"generators' share, encoded run: {100 * on_enc['generator_share']:.1f} %; "
          f"end to end (on vs off): {100 * end_to_end_enc:.1f} %")
    print(json.dumps({"rates": rates, "on": on, "off": off,
                      "end_to_end_share": round(end_to_end, 4), "on_encoded": on_enc,
                      "off_encoded": off_enc,
                      "end_to_end_share_encoded": round(end_to_end_enc, 4)}))


if __name__ == "__main__":
    main()
