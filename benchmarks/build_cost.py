"""Calibrate the build-time model of shipradar.tables.budget, and time the slow cases of issue 23.

    python benchmarks/build_cost.py            # calibration: fit COST, fitted vs measured
    python benchmarks/build_cost.py --slow     # the four slow cases, estimate vs measured
    python benchmarks/build_cost.py --slow --before   # ... and with the former code paths
    python benchmarks/build_cost.py --accuracy # F of each large-grid change, small proxy

Calibration builds about thirty tables of varied size (PE, I_F, clutter, P_fac, atmosphere,
P_d) from variants of scenarios/single_missile.yaml in a private empty cache, each timed
around the builder (saving included), and fits the constants of ``shipradar.tables.budget.COST`` one
kind at a time by non-negative least squares on the relative error. It prints each table's
measured time, the time the fitted constants give and their ratio, then the constants to
paste into tables/budget.py (with the machine and the date).

``--slow`` builds the tables of the slow scenes of issue 23 (a 100 GHz radar; a 1000 km
instrumented range; both with pe_grid coarse; a 256-pulse FIR bank with a 499/500 kHz
stagger) and prints the estimate, the measured time and their ratio. ``--before`` also
builds them with the former code paths (the PE to the instrumented range with complex
powers; the I_F by one steering vector per Doppler node), and prints the speed-up and the
largest difference of F [dB] or I_F [dB] over the cells both tables hold. The former
paths of the 1000 km cases run for hours: ``--before`` skips them unless ``--all``.
"""

from __future__ import annotations

import argparse
import copy
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenarios" / "single_missile.yaml"


def _scene(mutate) -> dict:
    d = yaml.safe_load(SCENE.read_text())
    d = copy.deepcopy(d)
    mutate(d)
    return d


def _radar(d: dict) -> dict:
    return d["platforms"][0]["radars"][0]


def calibration_scenes() -> list[tuple[str, dict]]:
    """Variants of the demo scene whose tables span the work units of every cost kind."""
    out = []
    for f, r, sea in ((3e9, 20e3, 3), (5.6e9, 60e3, 3), (1e10, 40e3, 3), (2e10, 30e3, 3),
                      (1e10, 60e3, 0), (3e10, 15e3, 0), (5.6e9, 100e3, 5)):
        def m(d, f=f, r=r, sea=sea):
            _radar(d).update(frequency_hz=f, instrumented_range_m=r)
            d["environment"]["sea_state"] = sea
            d["fidelity"] = {"atmosphere": True, "pd_method": "table"}
        out.append((f"PE {f / 1e9:g} GHz {r / 1e3:g} km sea {sea}", _scene(m)))
    for n, stagger in ((8, False), (32, False), (128, False), (8, True), (32, True),
                       (64, True), (128, True)):
        def m(d, n=n, stagger=stagger):
            _radar(d)["processor"] = {"type": "fir_bank", "n_coherent": n}
            if stagger:
                _radar(d).update(prf_hz=5e5, stagger_prf_hz=[499000.0, 500000.0],
                                 pulse_width_s=0.1e-6, transmitted_pulse_width_s=0.5e-6)
            d["fidelity"] = {"propagation": "two_ray"}
        out.append((f"I_F N={n}{' stagger' if stagger else ''}", _scene(m)))

    def rain(d):
        d["environment"]["rain"] = {"rate_mm_h": 4.0}
        _radar(d)["instrumented_range_m"] = 150e3
        d["fidelity"] = {"propagation": "two_ray"}
    out.append(("rain 150 km", _scene(rain)))
    return out


def slow_scenes() -> list[tuple[str, dict]]:
    """The slow cases of issue 23 (one field, or a few, changed in the demo scene)."""
    def f100(d):
        _radar(d)["frequency_hz"] = 1e11

    def r1000(d):
        _radar(d)["instrumented_range_m"] = 1e6

    def both(d):
        _radar(d).update(frequency_hz=1e11, instrumented_range_m=1e6)
        d["fidelity"] = {"pe_grid": "coarse"}

    def stagger(d):
        _radar(d).update(prf_hz=5e5, stagger_prf_hz=[499000.0, 500000.0],
                         pulse_width_s=0.1e-6, transmitted_pulse_width_s=0.5e-6)
        _radar(d)["processor"] = {"type": "fir_bank", "n_coherent": 256}
    return [("frequency_hz 1e11", _scene(f100)), ("instrumented_range_m 1e6", _scene(r1000)),
            ("1e11 Hz, 1e6 m, pe_grid coarse", _scene(both)),
            ("fir_bank 256, stagger 499/500 kHz", _scene(stagger))]


def build_and_time(label: str, d: dict, kinds=None) -> list[dict]:
    """Build every missing table of a scene (and its P_d tables), timed one by one."""
    from shipradar.sim.world.scenario import parse_scenario
    from shipradar.tables.budget import estimate_build
    from shipradar.tables.scene import table_specs

    s = parse_scenario(d)
    est = {}
    for e in estimate_build(s):
        est.setdefault((e.radar_id, e.kind), []).append(e)
    rows = []
    for spec in table_specs(s):
        if spec.cached() or (kinds and spec.kind not in kinds):
            continue
        e = est[(spec.radar_id, spec.kind)][0]
        t0 = time.perf_counter()
        table = spec.make()
        dt = time.perf_counter() - t0
        rows.append({"label": label, "kind": spec.kind, "work": e.work, "estimate": e.seconds,
                     "measured": dt, "table": table})
    for e in est.get((s.platforms[0].radars[0].id, "pd"), []):
        if e.cached or (kinds and "pd" not in kinds):
            continue
        from shipradar.tables import pd as tpd

        inputs_case = int(e.detail.split("Swerling ")[1].split(")")[0])
        radar = s.platforms[0].radars[0]
        from shipradar.sensors.radar import false_alarm_probability, pulses_per_beamwidth

        pfa = false_alarm_probability(radar)
        n_max = pulses_per_beamwidth(radar)
        t0 = time.perf_counter()
        tpd.PdTables(pfa, n_max, [inputs_case])
        rows.append({"label": label, "kind": "pd", "work": e.work, "estimate": e.seconds,
                     "measured": time.perf_counter() - t0, "table": None})
    return rows


def fit(rows: list[dict]) -> dict[str, float]:
    """COST constants by non-negative least squares on the relative error, per kind group."""
    from scipy.optimize import nnls

    from shipradar.tables.budget import COST

    fitted = dict(COST)
    for group in ({"propagation"}, {"improvement"}, {"sea_clutter"}, {"weather_clutter"},
                  {"pfac"}, {"atmosphere"}, {"pd"}):
        sel = [r for r in rows if r["kind"] in group]
        if not sel:
            continue
        keys = sorted({k for r in sel for k, v in r["work"].items() if v > 0})
        a = np.array([[r["work"].get(k, 0.0) / r["measured"] for k in keys] for r in sel])
        scale = a.max(axis=0)
        x, _ = nnls(a / scale, np.ones(len(sel)))
        for k, v in zip(keys, x / scale, strict=True):
            fitted[k] = float(v)
    return fitted


def _seconds(work: dict, cost: dict) -> float:
    return sum(cost[k] * v for k, v in work.items())


def calibrate() -> None:
    rows = []
    for label, d in calibration_scenes():
        rows += build_and_time(label, d)
        print(f"built {label}", file=sys.stderr)
    cost = fit(rows)
    print(f"{'table':40s} {'kind':16s} {'measured':>9s} {'fitted':>9s} {'ratio':>6s}")
    ratios = []
    for r in rows:
        t = _seconds(r["work"], cost)
        ratios.append(t / r["measured"])
        print(f"{r['label']:40s} {r['kind']:16s} {r['measured']:8.2f}s {t:8.2f}s "
              f"{t / r['measured']:6.2f}")
    big = [q for q, r in zip(ratios, rows, strict=True) if r["measured"] > 0.5]
    print(f"\nfitted/measured over {len(ratios)} tables: {min(ratios):.2f} .. "
          f"{max(ratios):.2f}; tables over 0.5 s: {min(big):.2f} .. {max(big):.2f}")
    print(f"\n# machine: {platform.machine()} {platform.processor() or ''} "
          f"{os.cpu_count()} cores, python {platform.python_version()}, "
          f"{time.strftime('%Y-%m-%d')}")
    print("COST = {")
    for k, v in cost.items():
        print(f'    "{k}": {v:.3g},')
    print("}")


def _compare(a, b) -> str:
    """F [dB] (PE tables, :func:`_diff_stats`) or I_F [dB] (same grid) differences."""
    if a.name == "propagation_factor":
        return _diff_stats(a, b)
    d = np.abs(a.values - b.values)
    ties = np.any(d > 1e-9, axis=0)
    rest = float(d[:, ~ties].max()) if (~ties).any() else 0.0
    return (f"I_F max {rest:.2g} dB outside {int(ties.sum())} of {ties.size} Doppler nodes "
            f"where two filters tie to rounding (max {d.max():.3g} dB there)")


def _diff_stats(a, b) -> str:
    """|F_a - F_b| [dB] over (range, height) points both tables cover: the largest where
    either F > -60 dB and the 99th percentile and largest where either F > -20 dB."""
    from shipradar.tables.propagation import propagation_factor

    r = b.axes[0][b.axes[0] <= a.axes[0][-1]]
    h = np.linspace(0.5, min(a.inputs["max_height_m"], b.inputs["max_height_m"]), 400)
    rr, hh = np.meshgrid(r, h, indexing="ij")
    fa, fb = propagation_factor(a, rr, hh), propagation_factor(b, rr, hh)
    ok = np.isfinite(fa) & np.isfinite(fb) & (fa > 0) & (fb > 0)
    d = np.abs(20 * np.log10(np.where(ok, fa, 1) / np.where(ok, fb, 1)))
    m60 = ok & ((fa > 1e-3) | (fb > 1e-3))
    m20 = ok & ((fa > 0.1) | (fb > 0.1))
    return (f"max {d[m60].max():.3g} dB (F > -60 dB), p99 {np.percentile(d[m20], 99):.3g} / "
            f"max {d[m20].max():.3g} dB (F > -20 dB)")


def accuracy() -> None:
    """What each large-grid change of the PE does to F, on a proxy small enough to build
    three times (30 GHz, 30 km, the missile from 10 km): the large-grid rules forced on."""
    import shipradar.sensors.parabolic_equation as pe
    import shipradar.tables.propagation as tp
    from shipradar.sensors.radar import radar_constants
    from shipradar.sim.world.scenario import parse_scenario
    from shipradar.tables.scene import pe_table_grid_kwargs

    def m(d):
        _radar(d).update(frequency_hz=3e10, instrumented_range_m=30e3)
        d["targets"][0]["waypoints"][0].update(east_m=7071.0, north_m=7071.0)
    s = parse_scenario(_scene(m))
    radar = s.platforms[0].radars[0]
    k = radar_constants(s, radar)
    kind, phi_b, sl, tilt = k.pattern_key(radar)
    desc = {"kind": kind, "beamwidth_rad": phi_b, "sidelobe_db": sl, "tilt_rad": tilt,
            "convention": "absolute elevation"}
    saved = pe.LARGE_GRID_WORK

    def build(large: float, capped: bool):
        pe.LARGE_GRID_WORK = large
        try:
            kw = pe_table_grid_kwargs(s, radar)
            if not capped:
                kw["max_range_m"] = radar.instrumented_range_m
            h = kw.pop("antenna_height_m")
            t0 = time.perf_counter()
            t = tp.build_propagation_table(radar.frequency_hz, h,
                                           elevation_pattern=k.elevation_pattern(radar),
                                           pattern_description=desc, **kw)
            return t, time.perf_counter() - t0
        finally:
            pe.LARGE_GRID_WORK = saved

    old, t_old = build(float("inf"), False)
    fast, t_fast = build(0.0, False)
    capped, t_cap = build(0.0, True)
    print(f"proxy 30 GHz 30 km: former {t_old:.1f} s {old.values.shape}; fast powers "
          f"{t_fast:.1f} s; fast powers + range to {capped.axes[0][-1]:.0f} m {t_cap:.1f} s "
          f"{capped.values.shape}")
    print(f"  fast powers vs former:         {_diff_stats(old, fast)}")
    print(f"  range cap vs full (fast both): {_diff_stats(fast, capped)}")


def slow(before: bool, everything: bool) -> None:
    import shipradar.sensors.parabolic_equation as pe

    for label, d in slow_scenes():
        kinds = {"improvement"} if "stagger" in label else {"propagation"}
        with tempfile.TemporaryDirectory() as cache:
            os.environ["SHIPRADAR_TABLES"] = cache
            (after,) = build_and_time(label, d, kinds)
        print(f"{label:36s} after:  estimate ~{after['estimate']:7.1f} s, measured "
              f"{after['measured']:7.1f} s, ratio {after['estimate'] / after['measured']:.2f}, "
              f"shape {after['table'].values.shape}", flush=True)
        if not before or ("1e6" in label and not everything):
            continue
        if "stagger" in label:
            continue  # issue 36: a stagger's table is its weights' constant-PRF one
        saved = pe.LARGE_GRID_WORK
        pe.LARGE_GRID_WORK = float("inf")
        try:
            with tempfile.TemporaryDirectory() as cache:
                os.environ["SHIPRADAR_TABLES"] = cache
                (old,) = build_and_time(label, d, kinds)
        finally:
            pe.LARGE_GRID_WORK = saved
        print(f"{label:36s} before: measured {old['measured']:7.1f} s, shape "
              f"{old['table'].values.shape}; speed-up {old['measured'] / after['measured']:.1f}x,"
              f" |difference| {_compare(old['table'], after['table'])}",
              flush=True)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--slow", action="store_true", help="time the slow cases of issue 23")
    p.add_argument("--before", action="store_true", help="also with the former code paths")
    p.add_argument("--all", action="store_true", help="--before also on the 1000 km cases")
    p.add_argument("--accuracy", action="store_true",
                   help="what each large-grid change of the PE does to F, on a small proxy")
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as cache:
        os.environ["SHIPRADAR_TABLES"] = cache
        if args.accuracy:
            accuracy()
        elif args.slow:
            slow(args.before, args.all)
        else:
            calibrate()


if __name__ == "__main__":
    main()
