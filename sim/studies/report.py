"""The study report of one scene: a folder of PNG figures and an index page.

``shipradar report SCENARIO [--out DIR] [--montecarlo STUDY.csv]`` (entry :func:`cli_main`).

Figures (each skipped with a note in the index when the scene lacks its input):

- ``pd_range.png``: P_d against ground range per target — the dwell model's P_d at every
  beam crossing along the target's track (:func:`shipradar.sim.studies.montecarlo.model_pd_looks`),
  and, when a Monte Carlo study is given or found, its empirical P_d per target kind with 95 %
  Wilson intervals (``*_pd_range.csv`` of :mod:`shipradar.sim.studies.montecarlo`).
- ``propagation_*.png``: F against range for the standard and ducted atmospheres, and with
  a PE table in the scene, F against range from the table and its coverage diagram
  (:mod:`shipradar.sim.studies.figures.propagation`);
- ``sigma0_range.png``: σ0* against range with and without the scene's duct
  (:func:`shipradar.sim.studies.figures.clutter.plot_ducting_reflectivity`), and the scene's clutter
  map when it has one (:func:`shipradar.sim.studies.figures.clutter.plot_clutter_ppi`);
- ``improvement_doppler.png``: I_F against Doppler for the radar's processor
  (:func:`shipradar.sim.studies.figures.doppler.plot_improvement_vs_doppler`);
- ``false_alarms_range.png``: the seed's Fig. 8, histograms of false-alarm range, noise-induced
  (flat) beside sea-clutter-induced (falling with range), from the dwell model's own per-scan
  draws (:func:`shipradar.sim.studies.figures.false_alarms.generated_false_alarms`) over
  ``fa_scans`` scans — the code the engine runs every scan, repeated to get a visible histogram
  (noise panel from 500 draws' worth of scans);
- ``pfac_map.png``: the radar's P_fac map (7.2) as a PPI, and against range the expected
  false alarms per scan with P_fac upwind, crosswind and downwind (when it has one);
- ``ppi.png``: one scan of a run (the scan with the most plots, one with a target plot if
  any), plots coloured by origin, full range and zoomed on the sea-clutter false alarms, with
  the targets' tracks (:func:`shipradar.sim.studies.figures.false_alarms.plot_ppi_by_origin`).

Only the first radar of the scene is drawn. matplotlib runs with the Agg backend.
"""

from __future__ import annotations

import argparse
import csv
import html
import json
import math
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from shipradar.sim.stream.sink import MemorySink

if TYPE_CHECKING:
    from shipradar.sim.studies.figures.false_alarms import GeneratedFalseAlarms

__all__ = ["build_report", "cli_main"]



def _summary(doc: str | None) -> str:
    """A figure function's caption: its docstring's first paragraph on one line (a first
    *line* cut sentences in two: "... the PE table, and")."""
    first = (doc or "").strip().split("\n\n")[0]
    return " ".join(first.split())


def _processor_words(kw: dict[str, Any]) -> str:
    """The Doppler processor of :func:`_doppler_kwargs` in words, for a caption."""
    window = kw["window"]
    if "sidelobe_db" in kw:
        window = f"{window} {kw['sidelobe_db']:g} dB"
    words = f"{kw['n_filters']} filters of {kw['n_taps']} pulses, {window} window"
    if "mti_pulses" in kw:
        words += f", after a {kw['mti_pulses']}-pulse MTI canceller"
    return words


def _scene_heights(scenario) -> tuple[float, float]:
    """(duct height [m], 0 without a given-height duct; first target's first altitude [m])."""
    env = scenario.environment
    duct = env.duct.height_m if env.duct is not None and env.duct.type == "height" else 0.0
    target_h = scenario.targets[0].waypoints[0].altitude_m if scenario.targets else 10.0
    return duct, target_h


# --------------------------------------------------------------------------- figures
def _fig_pd(path: Path, model_rows: list[dict], study_csv: Path | None) -> str:
    fig, ax = plt.subplots(figsize=(8, 5))
    by_target: dict[str, list[dict]] = {}
    for r in model_rows:
        by_target.setdefault(r["target"], []).append(r)
    for tid, rows in sorted(by_target.items()):
        rows.sort(key=lambda r: r["ground_range_m"])
        ax.plot([r["ground_range_m"] / 1e3 for r in rows], [r["pd"] for r in rows], ".-",
                ms=3, lw=1, label=f"model: {tid} ({rows[0]['kind']})")
    caption = "P_d against ground range: the dwell model at each beam crossing"
    if study_csv is not None:
        with open(study_csv) as f:
            agg = list(csv.DictReader(f))
        kinds = sorted({r["kind"] for r in agg})
        for kind in kinds:
            rows = [r for r in agg if r["kind"] == kind]
            mid = np.array([(float(r["range_lo_m"]) + float(r["range_hi_m"])) / 2e3
                            for r in rows])
            pd = np.array([float(r["pd"]) for r in rows])
            lo = np.array([float(r["ci_lo"]) for r in rows])
            hi = np.array([float(r["ci_hi"]) for r in rows])
            ax.errorbar(mid, pd, yerr=[pd - lo, hi - pd], fmt="o", ms=4, capsize=2,
                        label=f"runs: {kind} (95 % Wilson)")
            # the model averaged over the same bins: what the points estimate
            model_kind = [m for m in model_rows if m["kind"] == kind]
            if model_kind:
                rg = np.array([m["ground_range_m"] for m in model_kind])
                pm = np.array([m["pd"] for m in model_kind])
                avg = [pm[(rg >= float(r["range_lo_m"])) & (rg < float(r["range_hi_m"]))]
                       for r in rows]
                sel = np.array([a.size > 0 for a in avg])
                if sel.any():
                    ax.plot(mid[sel], [a.mean() for a in avg if a.size], "s", mfc="none",
                            ms=7, color="0.3", label=f"model: {kind}, bin mean")
        caption += (f"; points: Monte Carlo study {study_csv.name} (95 % Wilson intervals), "
                    "squares: the model's P_d averaged over the same range bins")
    ax.set_xlabel("ground range [km]")
    ax.set_ylabel("P_d")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return caption


def _fig_false_alarms(path: Path, scenario, tables, radar_id: str, scans: int,
                      seed: int) -> tuple[str, GeneratedFalseAlarms]:
    """The seed's Fig. 8 for the scene: noise-induced (flat) beside sea-clutter-induced
    (falling with range), from the dwell model's own per-scan generators."""
    from shipradar.sim.studies.figures.false_alarms import (
        generated_false_alarms,
        plot_false_alarm_histograms,
    )

    fa = generated_false_alarms(scenario, radar_id, scans=scans, seed=seed, min_noise=500,
                                tables=tables)
    noise, clutter = fa["origin"] == 1, fa["origin"] == 2
    plot_false_alarm_histograms(path, fa["range_m"][noise], fa["range_m"][clutter],
                                max_range_m=fa["max_range_m"], noise_scans=fa["noise_scans"],
                                clutter_scans=fa["scans"],
                                title=f"{scenario.name}: {radar_id} (seed Fig. 8)")
    caption = (f"False alarms against range (seed Fig. 8): (a) noise-induced [90]-[93], "
               f"uniform in range; (b) sea-clutter-induced (7.2), falling with range; the "
               f"dwell model's per-scan draws ({scans} scans; panel a from "
               f"{fa['noise_scans']:,.0f} scans' worth, noise false alarms being rare)")
    return caption, fa


def _fig_ppi(path: Path, messages: list, sensor: str, r_max_m: float,
             wind_from_rad: float) -> str:
    from shipradar.sim.studies.figures.false_alarms import clutter_extent_m, plot_ppi_by_origin

    plots: dict[int, list[dict[str, Any]]] = {}
    truth_plots: dict[int, list[dict[str, Any]]] = {}
    targets: list[dict[str, Any]] = []
    eos: dict[int, dict[str, Any]] = {}
    for topic, _t, p in messages:
        if p.get("sensor") != sensor:
            continue
        if topic == b"plots":
            plots.setdefault(p["scan"], []).append(p)
        elif topic == b"truth" and p["kind"] == "plots":
            truth_plots.setdefault(p["scan"], []).append(p)
        elif topic == b"truth" and p["kind"] == "targets":
            targets.append(p)
        elif topic == b"eos":
            eos[p["scan"]] = p

    def count(scan):
        n = sum(np.size(p["range_m"]) for p in plots.get(scan, []))
        n_t = sum(int(np.count_nonzero(np.asarray(p["origin"]) == 0))
                  for p in truth_plots.get(scan, []))
        return (n_t > 0, n, -scan)  # ties: the earliest, target farthest out

    scan = max(eos, key=count) if eos else None
    if scan is None:
        plot_ppi_by_origin(path, np.zeros(0), np.zeros(0), np.zeros(0, np.uint8),
                           max_range_m=r_max_m, title="no scan in the run")
        return "PPI: no scan in the run"
    rng = np.concatenate([np.asarray(p["range_m"]) for p in plots.get(scan, [])] or
                         [np.zeros(0)])
    az = np.concatenate([np.asarray(p["azimuth_rad"]) for p in plots.get(scan, [])] or
                        [np.zeros(0)])
    origin = np.concatenate([np.asarray(p["origin"]) for p in truth_plots.get(scan, [])]
                            or [np.zeros(0, np.uint8)])
    # the targets' tracks over the run, relative to the ship's position at that scan
    tracks = []
    pe, pn = eos[scan]["position"]["east_m"], eos[scan]["position"]["north_m"]
    if targets:
        e = np.array([np.asarray(t["east_m"]) for t in targets]) - pe
        n = np.array([np.asarray(t["north_m"]) for t in targets]) - pn
        act = np.array([np.asarray(t["active"]) for t in targets])
        for j in range(e.shape[1]):
            m = act[:, j]
            tracks.append((np.arctan2(e[m, j], n[m, j]), np.hypot(e[m, j], n[m, j])))
    zoom = clutter_extent_m(rng, origin)
    plot_ppi_by_origin(path, rng, az, origin, max_range_m=r_max_m, zoom_range_m=zoom,
                       tracks=tracks, wind_from_rad=wind_from_rad,
                       title=f"{sensor}: scan {scan} (t = {eos[scan]['time_s']:.1f} s)")
    return (f"PPI of scan {scan}: every plot of the scan coloured by origin (truth topic), "
            f"full range" + (f" and out to {zoom / 1e3:g} km" if zoom else "") +
            "; grey: the targets' tracks relative to the ship; arrow: wind direction")


def _doppler_kwargs(radar) -> dict[str, Any] | None:
    proc = radar.processor
    if proc.type not in ("dft_bank", "fir_bank", "mti_bank"):
        return None
    kw = {"n_taps": proc.n_coherent, "n_filters": proc.n_filters or proc.n_coherent,
          "window": "rectangular" if proc.type == "dft_bank" else proc.window.type}
    if proc.window.type in ("taylor", "chebyshev") and proc.type != "dft_bank":
        kw["sidelobe_db"] = proc.window.sidelobe_db
    if proc.type == "mti_bank":
        kw["mti_pulses"] = proc.mti_order + 1
    return kw


def _find_study(scenario_path: Path | None, out_dir: Path, name: str) -> Path | None:
    """A ``*_pd_range.csv`` of a study of this scene: beside the report, the scenario, or
    the working directory (``montecarlo_pd_range.csv``, the CLI's default, or ``NAME``)."""
    dirs = [out_dir, Path.cwd()] + ([scenario_path.parent] if scenario_path else [])
    for d in dirs:
        for stem in ("montecarlo", name, f"{name}_montecarlo", "study"):
            p = d / f"{stem}_pd_range.csv"
            if p.exists():
                return p
    return None


# --------------------------------------------------------------------------- report
# long: the report page's sections in page order, each a call of its figure module
def build_report(scenario, out_dir: str | os.PathLike = "report", *,
                 montecarlo: str | os.PathLike | None = None, duration_s: float | None = None,
                 seed: int | None = None, fa_scans: int = 300, tables=None) -> dict[str, Any]:
    """Write the scene's figures and ``index.html`` into ``out_dir``.

    Parameters
    ----------
    scenario : str, path-like or shipradar.sim.world.scenario.Scenario
    out_dir : path-like
        Output folder (created).
    montecarlo : path-like or None
        A study's results CSV or its ``*_pd_range.csv``; None looks for one
        (:func:`_find_study`), "" (empty) uses none.
    duration_s : float or None
        Duration of the run behind the model P_d and the PPI [s]; default the scenario's.
    seed : int or None
        Seed of that run; default the scenario's.
    fa_scans : int
        Scans of false-alarm draws for the histograms.
    tables : shipradar.tables.scene.SceneTables or None
        The scene's tables (default: loaded or built through the cache).

    Returns
    -------
    dict
        ``index`` (path), ``figures``: list of ``{"file", "caption"}``, ``notes``: list of
        str (figures skipped and why).
    """
    from shipradar.sim.studies.montecarlo import model_pd_looks, study_paths
    from shipradar.sim.world.scenario import Scenario, load_scenario
    from shipradar.tables.scene import load_scene_tables

    scenario_path = None
    if not isinstance(scenario, Scenario):
        scenario_path = Path(scenario)
        scenario = load_scenario(scenario_path)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if tables is None:
        tables = load_scene_tables(scenario)
    platform, radar = scenario.radars()[0]
    figures: list[dict[str, str]] = []
    notes: list[str] = []

    def add(name: str, caption: str) -> None:
        figures.append({"file": name, "caption": caption})

    # one run: model P_d at every crossing, and the stream for the PPI
    bus = MemorySink()
    model_rows = model_pd_looks(scenario, tables=tables, duration_s=duration_s, bus=bus,
                                seed=seed)
    model_rows = [r for r in model_rows if r["sensor"] == radar.id]
    study = None
    if montecarlo is None:
        study = _find_study(scenario_path, out, scenario.name)
    elif str(montecarlo):
        m = Path(montecarlo)
        study = m if m.name.endswith("_pd_range.csv") else study_paths(m)["pd_range"]
        if not study.exists():
            notes.append(f"Monte Carlo file {study} not found: model curve only")
            study = None
    if study is None:
        notes.append("P_d against range: no Monte Carlo study given or found (run "
                     "`shipradar montecarlo` first for the empirical points)")
    if model_rows or study is not None:
        add("pd_range.png", _fig_pd(out / "pd_range.png", model_rows, study))
    else:
        notes.append("P_d against range: the beam crossed no target in the run")

    rt = tables.for_radar(radar.id)
    figures += _propagation_figures(out, scenario, radar, rt.propagation, notes)
    figures += _clutter_figures(out, scenario, radar, rt.sea_clutter, notes)
    kw = _doppler_kwargs(radar)
    if kw is None:
        notes.append(f"I_F against Doppler: processor {radar.processor.type!r} has no "
                     "filter bank")
    else:
        from shipradar.sim.studies.figures.doppler import plot_improvement_vs_doppler

        plot_improvement_vs_doppler(out / "improvement_doppler.png", **kw)
        add("improvement_doppler.png",
            f"I_F against normalized Doppler f_d/f_r for the radar's processor "
            f"({_processor_words(kw)})")
    # false alarms (seed Fig. 8) and the PPI of one scan of the run
    caption, _ = _fig_false_alarms(out / "false_alarms_range.png", scenario, tables, radar.id,
                                   fa_scans, scenario.seed if seed is None else seed)
    add("false_alarms_range.png", caption)
    pfac = tables.for_radar(radar.id).pfac
    if pfac is None:
        notes.append("P_fac map: the radar has none (sea clutter off, or not of "
                     "medium-to-high resolution: X = θ_b τ' ≥ 4 °·µs or τ' ≥ 4 µs)")
    else:
        from shipradar.sim.studies.figures.false_alarms import plot_pfac_map

        plot_pfac_map(out / "pfac_map.png", pfac,
                      wind_from_rad=math.radians(scenario.environment.wind_direction_deg),
                      title=f"{scenario.name}: {radar.id}")
        add("pfac_map.png", "Sea-clutter false-alarm probability P_fac per sector (seed 7.2, "
            "[94]-[96]) and the expected false alarms per scan against range")
    add("ppi.png", _fig_ppi(out / "ppi.png", bus.messages, radar.id, radar.instrumented_range_m,
                            math.radians(scenario.environment.wind_direction_deg)))
    index = _write_index(out, scenario, figures, notes)
    return {"index": str(index), "figures": figures, "notes": notes}


def _propagation_figures(out: Path, scenario, radar, table, notes: list[str]) -> list[dict]:
    """F against range for the standard and ducted atmospheres (two-ray and PE reference
    curves), and, with a PE table in the scene, F against range from it and its coverage."""
    from shipradar.sim.studies.figures import propagation as prop_fig
    from shipradar.sim.studies.figures.case import SeaCase

    duct, target_h = _scene_heights(scenario)
    figs = []
    prop_fig.plot_factor_vs_range(
        out / "propagation_factor_vs_range.png",
        SeaCase.of_radar(radar, scenario, prop_fig.SEED_FIG4.max_range_m),
        target_height_m=target_h)
    figs.append({"file": "propagation_factor_vs_range.png",
                 "caption": _summary(prop_fig.plot_factor_vs_range.__doc__)})
    if table is None:
        notes.append("F from the scene's PE table and its coverage diagram: the scene has no "
                     f"PE table (fidelity.propagation = {scenario.fidelity.propagation!r})")
        return figs
    prop_fig.plot_table_factor_vs_range(out / "propagation_table_factor_vs_range.png", table,
                                        height_m=target_h, wave_height_m=scenario.wave_height)
    prop_fig.plot_coverage(out / "propagation_coverage.png", table)
    figs += [{"file": "propagation_table_factor_vs_range.png",
              "caption": _summary(prop_fig.plot_table_factor_vs_range.__doc__)},
             {"file": "propagation_coverage.png",
              "caption": _summary(prop_fig.plot_coverage.__doc__)}]
    return figs


def _clutter_figures(out: Path, scenario, radar, sea_map, notes: list[str]) -> list[dict]:
    """σ0* against range with and without the scene's duct (seed Fig. 6), and the scene's
    sea-clutter map when it has one."""
    from shipradar.sim.studies.figures import clutter as clutter_fig
    from shipradar.sim.studies.figures.case import SeaCase

    duct, _ = _scene_heights(scenario)
    clutter_fig.plot_ducting_reflectivity(
        out / "sigma0_range.png", SeaCase.of_radar(radar, scenario, radar.instrumented_range_m),
        duct_height_m=duct, wind_speed_mps=scenario.environment.wind_speed_mps)
    figs = [{"file": "sigma0_range.png",
             "caption": "σ0* against range, standard atmosphere and with the scene's duct "
                        "(seed Fig. 6), at the radar's frequency and polarization"}]
    if sea_map is None:
        notes.append("clutter map: the scene has no sea-clutter table (clutter off)")
    else:
        clutter_fig.plot_clutter_ppi(out / "clutter_map.png", sea_map)
        figs.append({"file": "clutter_map.png", "caption": "The scene's sea-clutter map (PPI)"})
    return figs


def _write_index(out: Path, scenario, figures, notes) -> Path:
    e = html.escape
    parts = [
        "<!doctype html>", "<html><head><meta charset='utf-8'>",
        f"<title>shipradar report: {e(scenario.name)}</title>",
        "<style>body{font-family:sans-serif;max-width:60em;margin:auto}"
        "img{max-width:100%;border:1px solid #ccc}figure{margin:2em 0}</style>",
        "</head><body>", f"<h1>{e(scenario.name)}</h1>", f"<p>{e(scenario.description)}</p>",
    ]
    for f in figures:
        parts.append(f"<figure><img src='{e(f['file'])}' alt='{e(f['file'])}'>"
                     f"<figcaption>{e(f['caption'])}</figcaption></figure>")
    if notes:
        parts.append("<h2>Not drawn</h2><ul>")
        parts += [f"<li>{e(n)}</li>" for n in notes]
        parts.append("</ul>")
    parts.append("</body></html>")
    path = out / "index.html"
    path.write_text("\n".join(parts) + "\n", encoding="utf-8")
    return path


def cli_main(argv: list[str] | None = None) -> int:
    """``shipradar report SCENARIO [--out DIR] [--montecarlo CSV]``; returns 0."""
    ap = argparse.ArgumentParser(prog="shipradar report",
                                 description="Write a scene's figures and an index page.")
    ap.add_argument("scenario", help="scenario YAML")
    ap.add_argument("--out", default="report", help="output folder (default: report)")
    ap.add_argument("--montecarlo", default=None,
                    help="Monte Carlo results CSV (default: look for one; '' for none)")
    ap.add_argument("--duration", type=float, default=None, help="run duration [s]")
    ap.add_argument("--seed", type=int, default=None, help="run seed")
    ap.add_argument("--fa-scans", type=int, default=300, help="scans of false-alarm draws")
    a = ap.parse_args(argv)
    res = build_report(a.scenario, a.out, montecarlo=a.montecarlo, duration_s=a.duration,
                       seed=a.seed, fa_scans=a.fa_scans)
    print(json.dumps({"index": res["index"], "figures": len(res["figures"]),
                      "notes": res["notes"]}))
    return 0


if __name__ == "__main__":
    sys.exit(cli_main())
