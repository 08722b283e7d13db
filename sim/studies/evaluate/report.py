"""The study report: ``index.html`` with the figures a fusion engineer expects.

- ``gospa.png``: GOSPA over time with its localisation, missed and false parts (mean over
  runs per scan, the total's 95 % band);
- ``coverage.png``: per target, which track held it at each scan of one run (a colour per
  track id, grey where the target counted and no track held it);
- ``ppi.png``: one run's tracks over the truth, local east/north [km];
- the metric table (mean and 95 % interval over runs), the per-target table, failed runs
  with their exit codes and stderr tails; links to the CSV and Parquet files.
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["write_compare", "write_report"]

_STYLE = ("body{font-family:sans-serif;max-width:1100px;margin:2em auto}"
          "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 8px;"
          "text-align:right}th{background:#eee}pre{background:#f6f6f6;padding:6px}")


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        if math.isnan(v):
            return "–"
        return f"{v:.4g}"
    return html.escape(str(v))


def _table(rows: Sequence[dict[str, Any]], columns: Sequence[str]) -> str:
    head = "".join(f"<th>{html.escape(c)}</th>" for c in columns)
    body = "".join("<tr>" + "".join(f"<td>{_fmt(r.get(c))}</td>" for c in columns) + "</tr>"
                   for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _gospa_png(path: Path, scan_rows: Sequence[dict[str, Any]]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.array([r["t_s"] for r in scan_rows], float)
    fig, ax = plt.subplots(figsize=(8, 4))
    for key, style in (("gospa", "k-"), ("localisation", "C0-"), ("missed", "C3-"),
                       ("false", "C1-")):
        ax.plot(t, [r[key] for r in scan_rows], style, label=key)
    lo = np.array([r["gospa_low"] for r in scan_rows], float)
    hi = np.array([r["gospa_high"] for r in scan_rows], float)
    if np.isfinite(lo).any():
        ax.fill_between(t, lo, hi, color="k", alpha=0.15, label="GOSPA 95 % interval")
    ax.set_xlabel("simulated time [s]")
    ax.set_ylabel("GOSPA and its parts [m^p]")
    ax.set_title("GOSPA per scan, mean over runs")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _coverage_png(path: Path, holding: Sequence[dict[str, Any]], seed: Any) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [h for h in holding if h["seed"] == seed]
    targets = sorted({h["target"] for h in rows})
    ids = sorted({h["track_id"] for h in rows if h["track_id"] is not None})
    colour = {tid: plt.cm.tab20(i % 20) for i, tid in enumerate(ids)}
    dt = np.median(np.diff(sorted({h["t_s"] for h in rows}))) if len(rows) > 1 else 1.0
    fig, ax = plt.subplots(figsize=(8, 1.6 + 0.35 * max(len(targets), 1)))
    for y, name in enumerate(targets):
        for h in rows:
            if h["target"] == name:
                c = colour.get(h["track_id"], (0.8, 0.8, 0.8, 1.0))
                ax.broken_barh([(h["t_s"] - dt, dt)], (y - 0.4, 0.8), color=c)
    ax.set_yticks(range(len(targets)), targets)
    ax.set_xlabel("simulated time [s]")
    ax.set_title(f"track coverage, seed {seed}: one colour per track id, grey: not held "
                 f"({len(ids)} track ids)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _ppi_png(path: Path, run_dir: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from shipradar.sim.studies.evaluate.data import load_run

    data = load_run(run_dir)
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    for j, name in enumerate(data.target_ids):
        a = data.truth_active[:, j]
        ax.plot(data.truth_pos[a, j, 0] / 1e3, data.truth_pos[a, j, 1] / 1e3, "k-", lw=1)
        if a.any():
            ax.annotate(name, data.truth_pos[a, j, :2][0] / 1e3, fontsize=7)
    by_id: dict[str, list[tuple[float, float]]] = {}
    for m in data.tracks:
        for tid, e, n in zip(m.track_id, m.east_m, m.north_m, strict=True):
            by_id.setdefault(tid, []).append((e / 1e3, n / 1e3))
    for i, (_tid, pts) in enumerate(sorted(by_id.items())):
        p = np.array(pts)
        ax.plot(p[:, 0], p[:, 1], ".", ms=3, color=plt.cm.tab20(i % 20))
    for s, r in data.radars.items():
        if r["eos_pos"].size:
            ax.plot(r["eos_pos"][:, 0] / 1e3, r["eos_pos"][:, 1] / 1e3, "b-", lw=2)
            ax.plot(*r["eos_pos"][-1, :2] / 1e3, "b^", label=f"radar {s}")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east [km]")
    ax.set_ylabel("north [km]")
    ax.set_title(f"seed {data.info.get('seed')}: truth (black), tracks (dots, a colour per id)",
                 fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def write_report(out: Path, settings: dict[str, Any], per_run, holding, summary_rows,
                 scan_rows, target_rows, failed) -> Path:
    """Write ``index.html`` and its PNGs into ``out``; a figure that cannot be drawn (no
    scored run) is listed with the reason."""
    out = Path(out)
    figures, missing = [], []
    if scan_rows:
        _gospa_png(out / "gospa.png", scan_rows)
        figures.append(("gospa.png", "GOSPA per scan and its localisation, missed and false "
                                     "parts (mean over runs; band: 95 % interval of GOSPA)"))
    else:
        missing.append("gospa.png: no scored run")
    if per_run:
        seed = per_run[0]["seed"]
        _coverage_png(out / "coverage.png", holding, seed)
        figures.append(("coverage.png", f"which track held each target, seed {seed}"))
        _ppi_png(out / "ppi.png", out / "runs" / f"seed-{seed}")
        figures.append(("ppi.png", f"tracks over truth, seed {seed}"))
    else:
        missing += ["coverage.png: no scored run", "ppi.png: no scored run"]
    m = settings.get("metrics", {})
    parts = [f"<html><head><meta charset='utf-8'><title>shipradar evaluate</title>"
             f"<style>{_STYLE}</style></head><body>",
             "<h1>Tracker evaluation</h1>",
             f"<p>Scenario <b>{html.escape(str(settings.get('scenario_name')))}</b>, tracker "
             f"<code>{html.escape(str(settings.get('tracker')))}</code>, "
             f"{len(per_run)} scored run(s) of {len(per_run) + len(failed)}, seed "
             f"{settings.get('seed')}. GOSPA c = {m.get('c_m')} m, p = {m.get('p')}, "
             f"alpha = 2; SIAP association within {m.get('siap_threshold_m') or m.get('c_m')}"
             f" m. Intervals: 95 %, Student t over runs.</p>",
             "<h2>Metrics (mean over runs, 95 % interval)</h2>",
             _table(summary_rows, ["metric", "mean", "low", "high", "runs"])]
    if target_rows:
        cols = ["target", "runs"] + [c for c in target_rows[0] if c not in ("target", "runs")]
        parts += ["<h2>Per target (mean over runs, 95 % interval)</h2>",
                  _table(target_rows, cols)]
    for name, caption in figures:
        parts.append(f"<h2>{html.escape(caption)}</h2><img src='{name}' alt='{name}'>")
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
                 + ", <a href='summary.csv'>summary.csv</a></p></body></html>")
    page = out / "index.html"
    page.write_text("\n".join(parts))
    return page


def write_compare(out: Path, dirs, settings, rows) -> Path:
    """``compare.html``: the studies' means and the paired differences, one table."""
    head = "".join(f"<li><code>{html.escape(str(d))}</code>: "
                   f"<code>{html.escape(str(s['tracker']))}</code></li>"
                   for d, s in zip(dirs, settings, strict=True))
    page = Path(out) / "compare.html"
    page.write_text(
        f"<html><head><meta charset='utf-8'><title>shipradar evaluate --compare</title>"
        f"<style>{_STYLE}</style></head><body><h1>Trackers compared on the same seeds</h1>"
        f"<ul>{head}</ul><p>Differences are paired by seed (study minus the first), with "
        f"95 % Student-t intervals.</p>"
        + _table(rows, ["study", "kind", "metric", "mean", "low", "high", "runs"])
        + "</body></html>")
    return page
