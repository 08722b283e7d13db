"""False-alarm figures (PNG, matplotlib Agg): the seed's Fig. 8 (histograms against range of
noise-induced and sea-clutter-induced false alarms) and a PPI of one scan's plots by origin.

Both take plain arrays (from a run's truth and plot topics, or from the generators of
:mod:`sensors.false_alarms`); :func:`generated_false_alarms` draws them for a scenario without
running the engine.  ``python -m sim.figures.false_alarms SCENARIO.yaml OUTDIR`` writes both.
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

#: Origin codes as on the truth topic (sim.engine): target, noise, sea clutter.
ORIGIN_LABELS = {0: "target", 1: "noise", 2: "sea clutter"}
ORIGIN_COLOURS = {0: "tab:green", 1: "tab:blue", 2: "tab:orange"}


def plot_false_alarm_histograms(
    path: str | os.PathLike[str],
    noise_range_m: np.ndarray,
    clutter_range_m: np.ndarray,
    *,
    max_range_m: float,
    n_bins: int = 40,
    clutter_max_range_m: float | None = None,
    title: str = "",
) -> Path:
    """The seed's Fig. 8: false alarms against range, (a) noise-induced, (b) sea-clutter-induced.

    Parameters
    ----------
    path : path-like
        Output PNG.
    noise_range_m, clutter_range_m : array_like
        Ranges of the noise and of the sea-clutter false alarms [m] (any number of scans).
    max_range_m : float
        Instrumented range [m] (axis of panel a).
    n_bins : int, optional
        Histogram bins per panel.
    clutter_max_range_m : float, optional
        Axis of panel b [m]; default: the largest clutter range (the clutter false alarms
        lie near the ship).
    title : str, optional
        Figure title.
    """
    path = Path(path)
    noise = np.asarray(noise_range_m, dtype=float)
    clutter = np.asarray(clutter_range_m, dtype=float)
    fig, (ax_n, ax_c) = plt.subplots(1, 2, figsize=(10, 4), dpi=110)
    ax_n.hist(noise / 1e3, bins=np.linspace(0.0, max_range_m / 1e3, n_bins + 1),
              color=ORIGIN_COLOURS[1], edgecolor="k", linewidth=0.3)
    ax_n.set_title(f"(a) noise-induced ({noise.size})")
    c_max = clutter_max_range_m
    if c_max is None:
        c_max = float(clutter.max()) if clutter.size else max_range_m
    ax_c.hist(clutter / 1e3, bins=np.linspace(0.0, c_max / 1e3, n_bins + 1),
              color=ORIGIN_COLOURS[2], edgecolor="k", linewidth=0.3)
    ax_c.set_title(f"(b) sea-clutter-induced ({clutter.size})")
    for ax in (ax_n, ax_c):
        ax.set_xlabel("range [km]")
        ax.set_ylabel("false alarms per bin")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def plot_ppi_by_origin(
    path: str | os.PathLike[str],
    range_m: np.ndarray,
    azimuth_rad: np.ndarray,
    origin: np.ndarray,
    *,
    max_range_m: float | None = None,
    title: str = "",
    wind_from_rad: float | None = None,
) -> Path:
    """PPI (north up, clockwise) of one scan's plots coloured by origin (truth topic codes).

    Parameters
    ----------
    path : path-like
        Output PNG.
    range_m, azimuth_rad : array_like
        Plot range [m] and azimuth from true north [rad].
    origin : array_like of int
        0 target, 1 noise, 2 sea clutter (:data:`ORIGIN_LABELS`).
    max_range_m : float, optional
        Radius of the display [m]; default the largest range.
    title : str, optional
    wind_from_rad : float, optional
        Direction the wind blows from [rad]: drawn as an arrow (clutter is upwind).
    """
    path = Path(path)
    r = np.asarray(range_m, dtype=float) / 1e3
    az = np.asarray(azimuth_rad, dtype=float)
    org = np.asarray(origin)
    fig = plt.figure(figsize=(6.5, 6.5), dpi=110)
    ax = fig.add_subplot(projection="polar")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    for code, label in ORIGIN_LABELS.items():
        sel = org == code
        ax.scatter(az[sel], r[sel], s=4 if code else 16, c=ORIGIN_COLOURS[code],
                   label=f"{label} ({int(sel.sum())})", linewidths=0)
    r_max = (max_range_m / 1e3) if max_range_m else (float(r.max()) if r.size else 1.0)
    ax.set_rmax(r_max)
    if wind_from_rad is not None:
        ax.annotate("", xy=(wind_from_rad, 0.15 * r_max), xytext=(wind_from_rad, 0.95 * r_max),
                    arrowprops={"arrowstyle": "->", "color": "k"})
        ax.text(wind_from_rad, 0.98 * r_max, "wind", ha="center")
    ax.set_xlabel("range [km]")
    ax.legend(loc="lower left", bbox_to_anchor=(-0.12, -0.12), fontsize=8, markerscale=2)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def generated_false_alarms(scenario, radar_id: str | None = None, scans: int = 20,
                           seed: int = 0, min_noise: int = 0) -> dict[str, np.ndarray]:
    """Noise and sea-clutter false alarms of ``scans`` revolutions of one radar, drawn by the
    model's generators (no targets, no engine): ranges [m], azimuths [rad], scan and origin.

    Noise false alarms are rare at a real t_fa (one a minute); ``min_noise`` > 0 adds noise
    false alarms of as many further scans as needed to expect that many (scan -1), drawn in
    one go (a sum of per-scan counts is a count with the summed η), for a readable Fig. 8a.

    Parameters
    ----------
    scenario : sim.scenario.Scenario
        The scene (its tables are loaded from the cache or built).
    radar_id : str, optional
        Default: the first radar with a P_fac map, else the first radar.
    scans : int, optional
    seed : int, optional
    """
    from sensors.dwell import DwellModel
    from tables.scene import load_scene_tables

    tables = load_scene_tables(scenario)
    pairs = scenario.radars()
    if radar_id is None:
        with_map = [pr for pr in pairs if tables.for_radar(pr[1].id).pfac is not None]
        platform, radar = (with_map or pairs)[0]
    else:
        platform, radar = next(pr for pr in pairs if pr[1].id == radar_id)
    model = DwellModel(scenario, platform, radar, tables)
    rng = np.random.default_rng(seed)
    period = radar.scan_period_s
    omega = 2.0 * math.pi / period
    out: dict[str, list] = {"range_m": [], "azimuth_rad": [], "origin": [], "scan": []}
    for k in range(scans):
        nf = model.noise_false_alarms(rng)
        cf = model.clutter_false_alarms(k * period, (k + 1) * period, 0.0, omega, rng)
        parts = [(nf["range_m"], nf["azimuth_rad"], 1)]
        if cf is not None:
            parts.append((cf["range_m"], cf["azimuth_rad"], 2))
        for r, az, code in parts:
            out["range_m"].append(r)
            out["azimuth_rad"].append(az)
            out["origin"].append(np.full(r.size, code, dtype=np.uint8))
            out["scan"].append(np.full(r.size, k, dtype=np.int64))
    eta = model.noise_false_alarms_per_scan
    if min_noise > 0 and eta > 0:
        from sensors import false_alarms as fa

        n_more = int(fa.false_alarm_count(min_noise, radar.n_channels, rng))
        r, az = fa.uniform_positions(n_more, 0.0, radar.instrumented_range_m, 0.0,
                                     2.0 * math.pi, rng)
        out["range_m"].append(r)
        out["azimuth_rad"].append(az)
        out["origin"].append(np.full(r.size, 1, dtype=np.uint8))
        out["scan"].append(np.full(r.size, -1, dtype=np.int64))
    res = {k: np.concatenate(v) for k, v in out.items()}
    res["radar_id"] = radar.id
    res["max_range_m"] = radar.instrumented_range_m
    return res


def main(argv: list[str] | None = None) -> int:
    """``python -m sim.figures.false_alarms SCENARIO.yaml OUTDIR [SCANS]``."""
    from sim.scenario import load_scenario

    args = sys.argv[1:] if argv is None else argv
    if len(args) < 2:
        print(main.__doc__, file=sys.stderr)
        return 2
    scenario = load_scenario(args[0])
    out = Path(args[1])
    out.mkdir(parents=True, exist_ok=True)
    scans = int(args[2]) if len(args) > 2 else 20
    fa = generated_false_alarms(scenario, scans=scans, min_noise=500)
    noise, clutter = fa["origin"] == 1, fa["origin"] == 2
    p1 = plot_false_alarm_histograms(
        out / "fig8_false_alarms.png", fa["range_m"][noise], fa["range_m"][clutter],
        max_range_m=fa["max_range_m"], title=f"{scenario.name}: {fa['radar_id']}, {scans} scans")
    first = fa["scan"] == 0
    p2 = plot_ppi_by_origin(
        out / "ppi_false_alarms.png", fa["range_m"][first], fa["azimuth_rad"][first],
        fa["origin"][first], title=f"{fa['radar_id']}: one scan's false alarms",
        max_range_m=float(fa["range_m"][first & clutter].max()) * 1.1 if np.any(first & clutter)
        else None,
        wind_from_rad=math.radians(scenario.environment.wind_direction_deg))
    print(p1)
    print(p2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
