"""The study report: ``index.html`` with the figures a fusion engineer expects.

- ``gospa.svg``: GOSPA over time with its localisation, missed and false parts (mean over
  runs per scan, the total's 95 % band);
- ``coverage.svg``: per target, which track held it at each scan of one run (a colour per
  track id, grey where the target counted and no track held it), with its legend;
- ``ppi.svg``: one run's tracks over the truth, local east/north [km], with its legend (the
  same colour per track id as the coverage timeline);
- the metric table (mean and 95 % interval over runs, a unit per row), the per-target table
  (a unit per column; split into several tables when it has many columns), failed runs with
  their exit codes and stderr tails; links to the CSV and Parquet files.

The figures are SVG with their text kept as text, written beside the page and inlined in it
(the legends and tick labels are then part of the page a browser test reads). Every number
on the page goes through :func:`format_value` with its quantity's unit and precision
(:data:`QUANTITIES`), in fixed notation. Intervals come clipped to each figure's bounds
(:data:`shipradar.sim.studies.evaluate.stats.BOUNDS`); the report cuts them there again
(:func:`bounded`) for the tables and GOSPA's band, so no page shows a value a figure cannot
take.
"""

from __future__ import annotations

import html
import math
import re
from collections.abc import Collection, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from shipradar.sim.studies.evaluate.display import Quantity, format_value

__all__ = ["QUANTITIES", "Quantity", "bounded", "format_value", "quantity", "write_compare",
           "write_report"]


_COUNT = "count/run"
#: Every figure the report shows, by its stored name (the CSV/Parquet column).
QUANTITIES: dict[str, Quantity] = {
    # GOSPA: the total in m, the parts in m^p (:func:`quantity` sets the unit from p)
    "gospa": Quantity("GOSPA, mean over scans", "m", 0),
    "localisation": Quantity("GOSPA localisation part: assigned tracks' errors", "m", 0),
    "missed": Quantity("GOSPA missed part: c^p/2 per missed target", "m", 0),
    "false": Quantity("GOSPA false part: c^p/2 per false track", "m", 0),
    "siap_completeness": Quantity("SIAP completeness: targets tracked", "1", 3),
    "siap_ambiguity": Quantity("SIAP ambiguity: tracks per tracked target", "1", 3),
    "siap_spuriousness": Quantity("SIAP spuriousness: tracks on no target", "1", 3),
    "siap_position_accuracy_m": Quantity("SIAP position accuracy (horizontal)", "m", 0),
    "siap_velocity_accuracy_mps": Quantity("SIAP velocity accuracy (horizontal)", "m/s", 1),
    "siap_track_number_change_rate": Quantity(
        "SIAP track-number changes per hour of tracked time", "1/h", 2, scale=3600.0),
    "siap_longest_segment": Quantity("SIAP longest unbroken track segment / lifetime", "1",
                                     3),
    "false_tracks": Quantity("false tracks: ids never on a counted target", _COUNT, 1),
    "false_tracks_per_hour": Quantity("false tracks per simulated hour", "1/h", 0),
    "track_breaks": Quantity("track breaks (held, then not while counted)", _COUNT, 1),
    "identity_swaps": Quantity("identity swaps", _COUNT, 1),
    "latency_median_s": Quantity("latency, median", "s", 3),
    "latency_p95_s": Quantity("latency, 95th percentile", "s", 3),
    "tracks_messages": Quantity("tracks messages received", _COUNT, 0),
    "malformed_messages": Quantity("malformed tracks messages", _COUNT, 1),
    "scans": Quantity("scored scans", _COUNT, 0),
    "wall_s": Quantity("wall time of a run", "s", 2),
    "harness_s": Quantity("harness's own time in a run", "s", 2),
    "score_s": Quantity("scoring time of a run", "s", 2),
    # per target (a count is per target and run)
    "held_fraction": Quantity("held fraction of counted scans", "1", 3),
    "first_track_delay_s": Quantity("first-track delay after counted", "s", 1),
    "first_track_range_m": Quantity("range at first track", "km", 1, scale=1e-3),
    "mean_error_m": Quantity("mean position error when held", "m", 0),
    "scans_counted": Quantity("scans counted", _COUNT, 0),
    "scans_held": Quantity("scans held", _COUNT, 0),
    "track_ids": Quantity("track ids that held it", _COUNT, 1),
    "first_counted_s": Quantity("first counted", "s", 1),
    "first_track_s": Quantity("first track", "s", 1),
    # per scan
    "t_s": Quantity("simulated time", "s", 1),
    "truths": Quantity("counted targets", "count", 1),
    "tracks": Quantity("tracks", "count", 1),
    "completeness": Quantity("counted targets held", "1", 3),
    "spuriousness": Quantity("tracks on no counted target", "1", 3),
    "runs": Quantity("runs", "count", 0),
}

_UNIT_BY_SUFFIX = (("_mps", "m/s", 1), ("_per_hour", "1/h", 1), ("_m", "m", 0),
                   ("_s", "s", 3), ("_deg", "deg", 4), ("_ppm", "ppm", 1))


def quantity(name: str, p: float = 1.0) -> Quantity:
    """The :class:`Quantity` of a stored figure; the GOSPA parts are in m^p.

    A name not in :data:`QUANTITIES` (a figure added since) is shown by its name's unit
    suffix (``_m``, ``_s``, ``_mps``, ``_per_hour``), else as a dimensionless number with 3
    decimals and no bound.
    """
    q = QUANTITIES.get(name)
    if q is None:
        for suffix, unit, decimals in _UNIT_BY_SUFFIX:
            if name.endswith(suffix):
                return Quantity(name.replace("_", " "), unit, decimals)
        return Quantity(name.replace("_", " "), "1", 3)
    if name in ("localisation", "missed", "false") and p != 1:
        return replace(q, unit=f"m^{format_value(p)}", decimals=0)
    return q


def bounded(low: float, high: float, name: str) -> tuple[float, float]:
    """An interval of figure ``name`` cut at its bounds, ``stats.BOUNDS`` (NaN stays NaN; a
    figure not listed there is unbounded)."""
    from shipradar.sim.studies.evaluate.stats import BOUNDS

    lo_b, hi_b = BOUNDS.get(name, (-math.inf, math.inf))
    return tuple(min(max(x, lo_b), hi_b) if math.isfinite(x) else x  # type: ignore[return-value]
                 for x in (low, high))


# ---------------------------------------------------------------------------- HTML
_STYLE = (
    "body{font-family:sans-serif;max-width:1340px;margin:1em auto;padding:0 1em}"
    "table{border-collapse:collapse;max-width:100%;margin:0.5em 0}"
    "td,th{border:1px solid #ccc;padding:2px 6px;text-align:right;vertical-align:top}"
    "th{background:#eee}.l{text-align:left}td.name{overflow-wrap:anywhere;min-width:9em}"
    "tr.unit th{font-weight:normal;font-style:italic}"
    ".ci{display:block;color:#555;font-size:85%;white-space:nowrap}"
    "code{overflow-wrap:anywhere}th code{overflow-wrap:normal}"
    "pre{background:#f6f6f6;padding:6px;white-space:pre-wrap;overflow-wrap:anywhere}"
    "figure{margin:0.5em 0}figure svg{max-width:100%;height:auto}"
    "figcaption,.note{color:#333;max-width:70em}")


def _cell(text: str, cls: str = "") -> str:
    return f"<td class='{cls}'>{text}</td>" if cls else f"<td>{text}</td>"


def _interval(low: Any, high: Any, q: Quantity, name: str | None) -> tuple[str, str]:
    """An interval's two ends as shown; cut at figure ``name``'s bounds (None: not cut)."""
    lo = float("nan") if low is None else float(low)
    hi = float("nan") if high is None else float(high)
    if name is not None:
        lo, hi = bounded(lo, hi, name)
    return format_value(lo, q), format_value(hi, q)


def _summary_table(rows: Sequence[dict[str, Any]], p: float) -> str:
    """One row per metric: its name, meaning, unit, mean, interval, runs."""
    head = ("<tr><th class='l'>metric</th><th class='l'>meaning</th><th class='l'>unit</th>"
            "<th>mean</th><th>95 % low</th><th>95 % high</th><th>runs</th></tr>")
    body = []
    for r in rows:
        q = quantity(str(r["metric"]), p)
        lo, hi = _interval(r.get("low"), r.get("high"), q, str(r["metric"]))
        body.append("<tr>" + _cell(f"<code>{html.escape(str(r['metric']))}</code>", "l")
                    + _cell(html.escape(q.label), "l") + _cell(html.escape(q.unit), "l")
                    + _cell(format_value(r.get("mean"), q)) + _cell(lo) + _cell(hi)
                    + _cell(format_value(r.get("runs"), QUANTITIES["runs"])) + "</tr>")
    return f"<table class='metrics'>{head}{''.join(body)}</table>"


#: Most metric columns in one per-target table (more: the table is split).
TARGET_COLUMNS_PER_TABLE = 6


def _target_tables(rows: Sequence[dict[str, Any]], metrics: Sequence[str]) -> str:
    """Per target: each metric's mean with its interval under it; a unit row under the
    header; split into tables of at most :data:`TARGET_COLUMNS_PER_TABLE` metrics."""
    out = []
    for k in range(0, len(metrics), TARGET_COLUMNS_PER_TABLE):
        chunk = list(metrics[k:k + TARGET_COLUMNS_PER_TABLE])
        qs = [quantity(m) for m in chunk]
        head = ("<tr><th class='l'>target</th><th>runs</th>"
                + "".join(f"<th>{html.escape(q.label)}<br><code>{html.escape(m)}</code></th>"
                          for m, q in zip(chunk, qs, strict=True)) + "</tr>"
                + "<tr class='unit'><th class='l'>unit</th><th>count</th>"
                + "".join(f"<th>{html.escape(q.unit)}</th>" for q in qs) + "</tr>")
        body = []
        for r in rows:
            cells = [_cell(html.escape(str(r["target"])), "l name"),
                     _cell(format_value(r.get("runs"), QUANTITIES["runs"]))]
            for m, q in zip(chunk, qs, strict=True):
                lo, hi = _interval(r.get(f"{m}_low"), r.get(f"{m}_high"), q, m)
                ci = f"<span class='ci'>[{lo}, {hi}]</span>" if lo != "–" else ""
                cells.append(_cell(format_value(r.get(m), q) + ci))
            body.append("<tr>" + "".join(cells) + "</tr>")
        out.append(f"<table class='targets'>{head}{''.join(body)}</table>")
    return "".join(out)


# ------------------------------------------------------------------------- figures
_RC = {"svg.fonttype": "none", "axes.formatter.useoffset": False,
       "axes.formatter.limits": (-9, 9), "font.size": 9}


def _svg(fig, path: Path, salt: str) -> str:
    """Save ``fig`` as SVG (deterministic ids, salted per figure so that several inlined
    figures do not share one) and return the markup to inline."""
    import matplotlib
    import matplotlib.pyplot as plt

    with matplotlib.rc_context({"svg.hashsalt": salt}):
        fig.savefig(path, format="svg", metadata={"Date": None}, bbox_inches="tight")
    plt.close(fig)
    text = path.read_text()
    return text[text.index("<svg"):]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _natural(tid: Any) -> tuple[Any, ...]:
    """Sort key of a track id: "T2" before "T10"."""
    return tuple((0, int(x), "") if x.isdigit() else (1, 0, x)
                 for x in re.split(r"(\d+)", str(tid)) if x)


def _track_colours(ids: Sequence[str]) -> dict[str, Any]:
    """One colour per track id, in natural order (tab20: the 21st id reuses the first)."""
    plt = _pyplot()
    return {tid: plt.cm.tab20(i % 20) for i, tid in enumerate(sorted(set(ids), key=_natural))}


def _gospa_svg(path: Path, scan_rows: Sequence[dict[str, Any]], c_text: str, p: float
               ) -> str:
    plt = _pyplot()
    t = np.array([r["t_s"] for r in scan_rows], float)
    with plt.rc_context(_RC):
        fig, ax = plt.subplots(figsize=(9, 4))
        for key, style in (("gospa", "k-"), ("localisation", "C0-"), ("missed", "C3-"),
                           ("false", "C1-")):
            ax.plot(t, [r[key] for r in scan_rows], style, label=key)
        lo = np.array([r["gospa_low"] for r in scan_rows], float)
        hi = np.array([r["gospa_high"] for r in scan_rows], float)
        if np.isfinite(lo).any():
            lo, hi = np.array([bounded(a, b, "gospa") for a, b in zip(lo, hi, strict=True)]).T
            ax.fill_between(t, lo, hi, color="k", alpha=0.15, label="GOSPA 95 % interval")
        ax.set_ylim(bottom=0.0)
        ax.set_xlabel("simulated time [s]")
        ax.set_ylabel("GOSPA and its parts [m]" if p == 1 else
                      f"GOSPA [m], its parts [{quantity('missed', p).unit}]")
        ax.set_title(f"GOSPA per scan, mean over runs ({c_text})")
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0)).set_gid(
            "legend-gospa")
        fig.tight_layout()
        return _svg(fig, path, "gospa")


def _segments(scans: np.ndarray, holders: list[Any]) -> list[tuple[int, int, Any]]:
    """Runs of consecutive scans with one holder: (first scan, last scan, holder)."""
    out: list[tuple[int, int, Any]] = []
    for s, h in zip(scans.tolist(), holders, strict=True):
        if out and out[-1][2] == h and out[-1][1] == s - 1:
            out[-1] = (out[-1][0], s, h)
        else:
            out.append((s, s, h))
    return out


#: Most track ids listed in a figure's legend (the rest are counted in its last entry).
LEGEND_IDS = 30


def _id_handles(colours: dict[str, Any], ids: Sequence[str], style: str,
                false_ids: Collection[str] = ()) -> list[Any]:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    out: list[Any] = []
    for tid in sorted(ids, key=_natural)[:LEGEND_IDS]:
        label = f"track {tid}" + (" (false)" if tid in false_ids else "")
        if style == "patch":
            out.append(Patch(color=colours[tid], label=label))
        else:
            out.append(Line2D([], [], ls="", marker="o", ms=4, color=colours[tid],
                              label=label))
    if len(ids) > LEGEND_IDS:
        out.append(Patch(color="none", label=f"… {len(ids) - LEGEND_IDS} more track ids"))
    return out


def _legend_columns(n: int, rows: int) -> int:
    return max(1, math.ceil(n / max(rows, 1)))


def _coverage_svg(path: Path, holding: Sequence[dict[str, Any]], seed: Any,
                  colours: dict[str, Any], c_text: str,
                  uncounted: str = "inactive or out of coverage") -> str:
    from matplotlib.patches import Patch

    plt = _pyplot()
    rows = [h for h in holding if h["seed"] == seed]
    targets = sorted({h["target"] for h in rows})
    ids = sorted({h["track_id"] for h in rows if h["track_id"] is not None}, key=_natural)
    times = sorted({(h["scan"], h["t_s"]) for h in rows})
    t_of = dict(times)
    dt = float(np.median(np.diff([t for _, t in times]))) if len(times) > 1 else 1.0
    grey = (0.8, 0.8, 0.8, 1.0)
    span = (max(t_of.values()) - min(t_of.values()) + dt) if t_of else 1.0
    with plt.rc_context(_RC):
        fig, ax = plt.subplots(figsize=(9, 1.4 + 0.3 * max(len(targets), 4)))
        for y, name in enumerate(targets):
            mine = sorted((h["scan"], h["track_id"]) for h in rows if h["target"] == name)
            scans = np.array([s for s, _ in mine], int)
            for first, last, tid in _segments(scans, [h for _, h in mine]):
                x0, width = t_of[first] - dt, t_of[last] - t_of[first] + dt
                ax.broken_barh([(x0, width)], (y - 0.4, 0.8),
                               color=grey if tid is None else colours.get(tid, grey))
                if tid is not None and width > 0.06 * span:
                    ax.text(x0 + width / 2, y, str(tid), ha="center", va="center",
                            fontsize=7, clip_on=True)
        ax.set_yticks(range(len(targets)), targets)
        ax.set_ylim(-0.6, max(len(targets), 1) - 0.4)
        ax.set_xlabel("simulated time [s]")
        ax.set_title(f"which track held each target, seed {seed} ({len(ids)} track ids; "
                     f"held: assigned within {c_text})", fontsize=9)
        handles = [Patch(color=grey, label="counted, no track held it"),
                   Patch(facecolor="white", edgecolor="0.6",
                         label=f"blank: not counted ({uncounted})")]
        handles += _id_handles(colours, ids, "patch")
        ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                  ncol=_legend_columns(len(handles), 2 + 2 * max(len(targets), 4))
                  ).set_gid("legend-coverage")
        fig.tight_layout()
        return _svg(fig, path, "coverage")


def _ppi_svg(path: Path, data, colours: dict[str, Any], held_ids: set[str]) -> str:
    from matplotlib.lines import Line2D

    plt = _pyplot()
    with plt.rc_context(_RC):
        fig, ax = plt.subplots(figsize=(9, 6.5))
        for j, name in enumerate(data.target_ids):
            a = data.truth_active[:, j]
            ax.plot(data.truth_pos[a, j, 0] / 1e3, data.truth_pos[a, j, 1] / 1e3, "k-", lw=1)
            if a.any():
                ax.annotate(name, data.truth_pos[a, j, :2][0] / 1e3, fontsize=7)
        by_id: dict[str, list[tuple[float, float]]] = {}
        for m in data.tracks:
            for tid, e, n in zip(m.track_id, m.east_m, m.north_m, strict=True):
                by_id.setdefault(tid, []).append((e / 1e3, n / 1e3))
        for tid, pts in sorted(by_id.items()):
            p = np.array(pts)
            ax.plot(p[:, 0], p[:, 1], ".", ms=3, color=colours[tid], rasterized=True)
        handles: list[Any] = [Line2D([], [], color="k", lw=1,
                                     label="truth (labelled at its start)")]
        for k, (s, r) in enumerate(data.radars.items()):
            if r["eos_pos"].size:
                colour = ("navy", "blue", "steelblue", "slateblue")[k % 4]
                marker = "^sDv"[k % 4]
                ax.plot(r["eos_pos"][:, 0] / 1e3, r["eos_pos"][:, 1] / 1e3, lw=2,
                        color=colour)
                ax.plot(*r["eos_pos"][-1, :2] / 1e3, ls="", ms=7, color=colour, marker=marker)
                handles.append(Line2D([], [], lw=2, label=f"radar {s} (its ship's track)",
                                      color=colour, marker=marker))
        false_ids = set(by_id) - held_ids
        handles += _id_handles(colours, list(by_id), "dot", false_ids)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("east [km]")
        ax.set_ylabel("north [km]")
        ax.set_title(f"tracks over truth, seed {data.info.get('seed')}", fontsize=9)
        ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                  ncol=_legend_columns(len(handles), 34)).set_gid("legend-ppi")
        fig.tight_layout()
        return _svg(fig, path, "ppi")


# -------------------------------------------------------------------------- pages
_FIGURE_TITLES = {"gospa": "GOSPA over time", "coverage": "Track coverage timeline",
                  "ppi": "PPI: tracks over truth"}


def _head(title: str) -> str:
    return (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<meta name='viewport' content='width=device-width'><title>{title}</title>"
            f"<style>{_STYLE}</style></head><body>")


def _mean_of(rows: Sequence[dict[str, Any]], metric: str) -> float:
    for r in rows:
        if r.get("metric") == metric:
            v = r.get("mean")
            return math.nan if v is None else float(v)
    return math.nan


# long: the HTML page's sections in page order
def write_report(out: Path, settings: dict[str, Any], per_run, holding, summary_rows,
                 scan_rows, target_rows, failed, extra_html: str = "") -> Path:
    """Write ``index.html`` and its SVG figures into ``out``; a figure that cannot be drawn
    (no scored run) is listed with the reason. ``extra_html``: a section placed after the
    figures (the registration scores).

    Parameters
    ----------
    out : Path
        The study directory (``runs/seed-N/`` inside it for the PPI).
    settings : dict
        ``study.json``'s content.
    per_run, holding, summary_rows, scan_rows, target_rows, failed : list of dict
        The rows of :func:`shipradar.sim.studies.evaluate.study.write_results`.
    """
    out = Path(out)
    m = settings.get("metrics", {})
    p = float(m.get("p") or 1.0)
    c_m = float(m.get("c_m") or math.nan)
    siap_m = float(m.get("siap_threshold_m") or c_m)
    metre = Quantity("distance", "m", 0)
    acc = _mean_of(summary_rows, "siap_position_accuracy_m")
    c_text = f"c = {format_value(c_m, metre)} m"
    against = (f", against a position accuracy of {format_value(acc, metre)} m (SIAP, mean "
               "over runs)" if math.isfinite(acc) and acc > 0 else "")
    c_note = (f"<p class='note'>Association distance {c_text}{against}: a track farther than "
              "c from a target is not assigned to it (GOSPA, identity), costs c<sup>p</sup>/2 "
              "as a false track and leaves the target missed.</p>")
    switch = m.get("switch_scans")
    identity = (f"the identity association: one track per counted target within {c_text}"
                f"{against}, kept from scan to scan"
                + (f" unless GOSPA's best assignment is cheaper for {format_value(switch)} "
                   "scans in a row" if switch is not None else ""))
    if m.get("truth") == "pd":
        counted = (f"counted truth: a target some radar's recent looks gave P_d ≥ "
                   f"{format_value(m.get('pd_threshold'))}")
        uncounted = "inactive, or no recent look reached the P_d threshold"
    else:
        counted = "counted truth: a target in some radar's coverage (geometric)"
        uncounted = "inactive or out of coverage"
    figures: list[tuple[str, str, str]] = []
    missing = []
    if scan_rows:
        figures.append(("gospa", _gospa_svg(out / "gospa.svg", scan_rows, c_text, p),
                        "GOSPA per scan and its localisation, missed and false parts (mean "
                        f"over runs; band: 95 % interval of GOSPA, cut at 0). {c_text}"
                        f"{against}; p = {format_value(p)}: a missed target or a false track "
                        "adds c<sup>p</sup>/2 a scan."))
    else:
        missing.append("gospa.svg: no scored run")
    if per_run:
        from shipradar.sim.studies.evaluate.data import load_run

        seed = per_run[0]["seed"]
        data = load_run(out / "runs" / f"seed-{seed}")
        track_ids = [t for msg in data.tracks for t in msg.track_id]
        track_ids += [h["track_id"] for h in holding
                      if h["seed"] == seed and h["track_id"] is not None]
        colours = _track_colours(track_ids)
        held = {h["track_id"] for h in holding if h["seed"] == seed}
        figures.append(("coverage", _coverage_svg(out / "coverage.svg", holding, seed,
                                                  colours, c_text, uncounted),
                        f"Which track held each target, seed {seed}: a target is held at a "
                        f"scan by the track {identity}. A colour per track id (legend at "
                        "right; tab20 colours repeat after 20 ids, the id is written on its "
                        "bar where it fits)."))
        figures.append(("ppi", _ppi_svg(out / "ppi.svg", data, colours, held),
                        f"Tracks over truth, seed {seed}, local east/north [km]; a track "
                        f"marked (false) never held a counted target ({c_text})."))
    else:
        missing += ["coverage.svg: no scored run", "ppi.svg: no scored run"]
    threshold = (f"SIAP association within {format_value(siap_m, metre)} m (from the first "
                 "of 2 scans in a row)")
    if switch is not None:
        threshold += (f", a track moving to a nearer truth once it has been nearer for "
                      f"{format_value(switch)} scans")
    parts = [_head("shipradar evaluate"),
             "<h1>Tracker evaluation</h1>",
             f"<p>Scenario <b>{html.escape(str(settings.get('scenario_name')))}</b>, tracker "
             f"<code>{html.escape(str(settings.get('tracker')))}</code>, "
             f"{len(per_run)} scored run(s) of {len(per_run) + len(failed)}, seed "
             f"{html.escape(str(settings.get('seed')))}. GOSPA {c_text}, "
             f"p = {format_value(p)}, alpha = 2; {threshold}; {counted}. Intervals: 95 %, "
             "Student t over runs, clipped to each figure's bounds (0 below every figure "
             "here, 1 above a fraction, 1 below the ambiguity).</p>",
             "<h2>Metrics (mean over runs, 95 % interval)</h2>", c_note,
             _summary_table(summary_rows, p)]
    if target_rows:
        skip = {"target", "runs"}
        metrics = [k for k in target_rows[0] if k not in skip
                   and not k.endswith(("_low", "_high"))]
        parts += ["<h2>Per target (mean over runs, 95 % interval under it)</h2>",
                  f"<p class='note'>Held, breaks, swaps and first track read {identity}. "
                  "Counts are per target and run.</p>", _target_tables(target_rows, metrics)]
    for name, svg, caption in figures:
        parts.append(f"<h2>{_FIGURE_TITLES[name]}</h2><figure id='figure-{name}'>{svg}"
                     f"<figcaption>{caption}</figcaption></figure>")
    if extra_html:
        parts.append(extra_html)
    if missing:
        parts.append("<h2>Not drawn</h2><ul>" + "".join(
            f"<li>{html.escape(x)}</li>" for x in missing) + "</ul>")
    if failed:
        parts.append("<h2>Failed runs</h2>")
        for f in failed:
            parts.append(f"<p>seed {f['seed']}: {html.escape(str(f['error']))} (exit code "
                         f"{f['exit_code']})</p><pre>{html.escape(f['stderr_tail'] or '')}"
                         f"</pre>")
    parts.append("<h2>Files</h2><p>" + ", ".join(
        f"<a href='{n}.{e}'>{n}.{e}</a>" for n in ("per_run", "per_scan", "per_target",
                                                  "holding") for e in ("csv", "parquet"))
                 + ", <a href='summary.csv'>summary.csv</a>, " + ", ".join(
        f"<a href='{n}.svg'>{n}.svg</a>" for n, _, _ in figures) + "</p></body></html>")
    page = out / "index.html"
    page.write_text("\n".join(parts))
    return page


def write_compare(out: Path, dirs, settings, rows) -> Path:
    """``compare.html``: the studies' means and the paired differences, one table with a
    unit per row (a difference has its metric's unit, and no bound)."""
    head = "".join(f"<li><code>{html.escape(str(d))}</code>: "
                   f"<code>{html.escape(str(s['tracker']))}</code></li>"
                   for d, s in zip(dirs, settings, strict=True))
    ps = {float((s.get("metrics") or {}).get("p") or 1.0) for s in settings}
    p = ps.pop() if len(ps) == 1 else 1.0
    th = "".join(f"<th class='{c}'>{n}</th>" for n, c in (
        ("study", "l"), ("kind", "l"), ("metric", "l"), ("unit", "l"), ("mean", ""),
        ("95 % low", ""), ("95 % high", ""), ("runs", "")))
    body = []
    for r in rows:
        q = quantity(str(r["metric"]), p)
        # a difference comes clipped to its own bounds (stats.paired_differences)
        lo, hi = _interval(r.get("low"), r.get("high"), q,
                           str(r["metric"]) if r["kind"] == "mean" else None)
        body.append("<tr>" + _cell(f"<code>{html.escape(str(r['study']))}</code>", "l")
                    + _cell(html.escape(str(r["kind"])), "l")
                    + _cell(f"<code>{html.escape(str(r['metric']))}</code>", "l")
                    + _cell(html.escape(q.unit), "l") + _cell(format_value(r.get("mean"), q))
                    + _cell(lo) + _cell(hi)
                    + _cell(format_value(r.get("runs"), QUANTITIES["runs"])) + "</tr>")
    page = Path(out) / "compare.html"
    page.write_text(
        _head("shipradar evaluate --compare") + "<h1>Trackers compared on the same seeds</h1>"
        f"<ul>{head}</ul><p>Differences are paired by seed (study minus the first), with "
        "95 % Student-t intervals; a mean's interval is cut at its quantity's bounds.</p>"
        f"<table class='compare'><tr>{th}</tr>{''.join(body)}</table></body></html>")
    return page

