"""False-alarm figures (PNG, matplotlib Agg): the seed's Fig. 8 (histograms against range of
noise-induced and sea-clutter-induced false alarms), a PPI of one scan's plots by origin and
the P_fac map of 7.2.

Both take plain arrays (from a run's truth and plot topics, or from the generators of
:mod:`shipradar.sensors.false_alarms`); :func:`generated_false_alarms` draws them for a scenario
without running the engine.
``python -m shipradar.sim.studies.figures.false_alarms SCENARIO.yaml OUTDIR`` writes all three.
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path
from typing import TypedDict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.projections.polar import PolarAxes  # noqa: E402

#: Origin codes as on the truth topic (shipradar.sim.engine.simulation): target, noise, sea clutter.
ORIGIN_LABELS = {0: "target", 1: "noise", 2: "sea clutter"}
ORIGIN_COLOURS = {0: "tab:red", 1: "tab:blue", 2: "tab:orange"}


def _panel_title(name: str, n: int, scans: float | None) -> str:
    if not scans:
        return f"{name} ({n})"
    return f"{name}: {n} in {scans:,.0f} scans ({n / scans:.3g} per scan)"


def plot_false_alarm_histograms(
    path: str | os.PathLike[str],
    noise_range_m: np.ndarray,
    clutter_range_m: np.ndarray,
    *,
    max_range_m: float,
    n_bins: int = 40,
    clutter_max_range_m: float | None = None,
    title: str = "",
    noise_scans: float | None = None,
    clutter_scans: float | None = None,
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
    noise_scans, clutter_scans : float, optional
        Revolutions the noise and the clutter false alarms come from: each panel's title then
        gives the rate per scan (noise false alarms are rare at a real t_fa, so panel a is
        usually drawn from many more scans than panel b).
    """
    path = Path(path)
    noise = np.asarray(noise_range_m, dtype=float)
    clutter = np.asarray(clutter_range_m, dtype=float)
    fig, (ax_n, ax_c) = plt.subplots(1, 2, figsize=(10, 4), dpi=110)
    ax_n.hist(noise / 1e3, bins=np.linspace(0.0, max_range_m / 1e3, n_bins + 1),
              color=ORIGIN_COLOURS[1], edgecolor="k", linewidth=0.3)
    ax_n.set_title(_panel_title("(a) noise-induced", noise.size, noise_scans), fontsize=10)
    c_max = clutter_max_range_m
    if c_max is None:
        c_max = float(clutter.max()) if clutter.size else max_range_m
    ax_c.hist(clutter / 1e3, bins=np.linspace(0.0, c_max / 1e3, n_bins + 1),
              color=ORIGIN_COLOURS[2], edgecolor="k", linewidth=0.3)
    ax_c.set_title(_panel_title("(b) sea-clutter-induced", clutter.size, clutter_scans),
                   fontsize=10)
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
    zoom_range_m: float | None = None,
    tracks: list[tuple[np.ndarray, np.ndarray]] | None = None,
) -> Path:
    """PPI (north up, clockwise) of one scan's plots coloured by origin (truth topic codes).

    With ``zoom_range_m`` a second panel shows the same plots out to that range (the sea-clutter
    false alarms crowd the first kilometres, a dot at the centre of a full-range PPI).

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
    zoom_range_m : float, optional
        Radius of a second, zoomed panel [m]; None: one panel.
    tracks : list of (azimuth [rad], range [m]) arrays, optional
        Target tracks relative to the radar, drawn as grey lines.
    """
    path = Path(path)
    r = np.asarray(range_m, dtype=float) / 1e3
    az = np.asarray(azimuth_rad, dtype=float)
    org = np.asarray(origin)
    r_max = (max_range_m / 1e3) if max_range_m else (float(r.max()) if r.size else 1.0)
    radii = [r_max] + ([zoom_range_m / 1e3] if zoom_range_m else [])
    fig = plt.figure(figsize=(6.5 * len(radii), 6.8), dpi=110)
    for k, rad in enumerate(radii):
        ax = fig.add_subplot(1, len(radii), k + 1, projection="polar")
        assert isinstance(ax, PolarAxes)
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)
        for t_az, t_r in tracks or []:
            ax.plot(np.asarray(t_az), np.asarray(t_r) / 1e3, color="0.6", lw=0.8)
        # targets last, larger and outlined: a handful among hundreds of false alarms
        for code in (1, 2, 0):
            sel = org == code
            ax.scatter(az[sel], r[sel], s=30 if code == 0 else 5, c=ORIGIN_COLOURS[code],
                       edgecolors="k" if code == 0 else "none", linewidths=0.6 if code == 0
                       else 0, label=f"{ORIGIN_LABELS[code]} ({int(sel.sum())})", zorder=3)
        ax.set_rmax(rad)
        if wind_from_rad is not None:
            ax.annotate("", xy=(wind_from_rad, 0.15 * rad), xytext=(wind_from_rad, 0.95 * rad),
                        arrowprops={"arrowstyle": "->", "color": "k"})
            ax.text(wind_from_rad, 0.98 * rad, "wind", ha="center")
        ax.set_xlabel("range [km]")
        if len(radii) > 1:
            ax.set_title(f"out to {rad:g} km", fontsize=9)
    handles, labels = fig.axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=9, markerscale=1.5)
    if title:
        fig.suptitle(title)
    fig.tight_layout(rect=(0.0, 0.05, 1.0, 1.0))
    fig.savefig(path)
    plt.close(fig)
    return path


def plot_pfac_map(
    path: str | os.PathLike[str],
    table,
    *,
    wind_from_rad: float | None = None,
    title: str = "",
) -> Path:
    """The P_fac map of seed 7.2: a PPI of P_fac per sector (log colour scale) out to the last
    range holding any, and against range the expected false alarms per scan and km (summed
    over azimuth) with P_fac upwind, crosswind and downwind.

    Parameters
    ----------
    path : path-like
        Output PNG.
    table : shipradar.tables.store.Table
        A P_fac map (:func:`shipradar.tables.pfac.build_pfac_map`).
    wind_from_rad : float, optional
        Direction the wind blows from [rad] (picks the upwind/downwind columns).
    title : str, optional
    """
    from matplotlib.colors import LogNorm

    from shipradar.tables.pfac import sector_edges

    path = Path(path)
    p = np.asarray(table.values, dtype=float)
    eta = np.asarray(table.extra["expected_count"], dtype=float)
    r_c, az_c = table.axes
    r_e, az_e = sector_edges(table)
    rows = np.nonzero(p.max(axis=1) > 0.0)[0]
    fig = plt.figure(figsize=(12, 5.5), dpi=110)
    ax = fig.add_subplot(1, 2, 1, projection="polar")
    assert isinstance(ax, PolarAxes)
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    ax2 = fig.add_subplot(1, 2, 2)
    if rows.size == 0:
        ax.set_title("P_fac = 0 everywhere", fontsize=9)
    else:
        n = rows[-1] + 1
        pos = p[:n][p[:n] > 0.0]
        mesh = ax.pcolormesh(az_e, r_e[:n + 1] / 1e3, np.ma.masked_less_equal(p[:n], 0.0),
                             norm=LogNorm(vmin=max(pos.min(), pos.max() * 1e-4),
                                          vmax=pos.max()), shading="flat", cmap="viridis")
        fig.colorbar(mesh, ax=ax, shrink=0.8, label="P_fac per cell")
        ax.set_title(f"P_fac map, range in km (Σ η = {eta.sum():.4g} per scan)", fontsize=9)
        dr_km = (r_e[1] - r_e[0]) / 1e3
        ax2.plot(r_c[:n] / 1e3, eta[:n].sum(axis=1) / dr_km, color=ORIGIN_COLOURS[2],
                 label="expected false alarms per scan and km")
        ax2.set_xlabel("ground range [km]")
        ax2.set_ylabel("false alarms per scan per km")
        ax2.grid(alpha=0.3)
        ax3 = ax2.twinx()
        w = 0.0 if wind_from_rad is None else wind_from_rad
        for off, name, ls in ((0.0, "upwind", "-"), (0.5 * np.pi, "crosswind", "--"),
                              (np.pi, "downwind", ":")):
            j = int(np.argmin(np.abs(np.angle(np.exp(1j * (az_c - w - off))))))
            ax3.semilogy(r_c[:n] / 1e3, np.where(p[:n, j] > 0, p[:n, j], np.nan), "k",
                         ls=ls, lw=0.9, label=f"P_fac {name}")
        ax3.set_ylabel("P_fac per cell")
        h1, l1 = ax2.get_legend_handles_labels()
        h2, l2 = ax3.get_legend_handles_labels()
        ax2.legend(h1 + h2, l1 + l2, fontsize=8)
        if wind_from_rad is not None:
            r_top = r_e[n] / 1e3
            ax.annotate("", xy=(wind_from_rad, 0.15 * r_top),
                        xytext=(wind_from_rad, 0.95 * r_top),
                        arrowprops={"arrowstyle": "->", "color": "w"})
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


class GeneratedFalseAlarms(TypedDict):
    """The false alarms of :func:`generated_false_alarms` and what they stand for."""

    range_m: np.ndarray  # [m]
    azimuth_rad: np.ndarray  # [rad]
    origin: np.ndarray  # 1 noise, 2 sea clutter
    scan: np.ndarray  # revolution, -1 for the extra noise draw
    radar_id: str
    max_range_m: float  # the radar's instrumented range [m]
    scans: int  # revolutions drawn
    noise_scans: float  # revolutions the noise false alarms stand for
    wind_from_rad: float  # [rad]


def generated_false_alarms(scenario, radar_id: str | None = None, scans: int = 20,
                           seed: int = 0, min_noise: int = 0,
                           tables=None) -> GeneratedFalseAlarms:
    """Noise and sea-clutter false alarms of ``scans`` revolutions of one radar, drawn by the
    model's generators (no targets, no engine): ranges [m], azimuths [rad], scan and origin.

    Noise false alarms are rare at a real t_fa (one a minute); ``min_noise`` > 0 adds noise
    false alarms of as many further scans as needed to expect that many (scan -1), drawn in
    one go (a sum of per-scan counts is a count with the summed η), for a readable Fig. 8a.

    Parameters
    ----------
    scenario : shipradar.sim.world.scenario.Scenario
        The scene (its tables are loaded from the cache or built).
    radar_id : str, optional
        Default: the first radar with a P_fac map, else the first radar.
    scans : int, optional
    seed : int, optional
    min_noise : int, optional
    tables : shipradar.tables.scene.SceneTables, optional
        The scene's tables; default loaded (or built) through the cache.

    Returns
    -------
    GeneratedFalseAlarms
        ``range_m``, ``azimuth_rad``, ``origin`` (1 noise, 2 sea clutter), ``scan`` (-1 for
        the extra noise draw) arrays; ``radar_id``, ``max_range_m``, ``scans``,
        ``noise_scans`` (revolutions the noise false alarms stand for) and ``wind_from_rad``.
    """
    from shipradar.sim.dwell.model import DwellModel
    from shipradar.tables.scene import load_scene_tables

    if tables is None:
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
        nf = model.false_alarms.noise_false_alarms(rng)
        cf = model.false_alarms.clutter_false_alarms(k * period, (k + 1) * period, 0.0, omega, rng)
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
        from shipradar.sensors import false_alarms as fa

        n_more = int(fa.false_alarm_count(min_noise, radar.n_channels, rng))
        r, az = fa.uniform_positions(n_more, 0.0, radar.instrumented_range_m, 0.0,
                                     2.0 * math.pi, rng)
        out["range_m"].append(r)
        out["azimuth_rad"].append(az)
        out["origin"].append(np.full(r.size, 1, dtype=np.uint8))
        out["scan"].append(np.full(r.size, -1, dtype=np.int64))
    return GeneratedFalseAlarms(
        range_m=np.concatenate(out["range_m"]),
        azimuth_rad=np.concatenate(out["azimuth_rad"]),
        origin=np.concatenate(out["origin"]),
        scan=np.concatenate(out["scan"]),
        radar_id=radar.id,
        max_range_m=radar.instrumented_range_m,
        scans=scans,
        # the extra noise draw stands for min_noise/η further revolutions
        noise_scans=scans + (min_noise / eta if min_noise > 0 and eta > 0 else 0.0),
        wind_from_rad=math.radians(scenario.environment.wind_direction_deg),
    )


def clutter_extent_m(range_m: np.ndarray, origin: np.ndarray,
                     quantile: float = 0.999) -> float | None:
    """Radius [m] of a zoomed PPI holding the sea-clutter false alarms (``origin`` 2) among
    false alarms at ``range_m`` [m] (e.g. of :func:`generated_false_alarms`): 1.1 × their
    ``quantile`` range, rounded up to 0.5 km; None without any."""
    r = range_m[origin == 2]
    if r.size == 0:
        return None
    return 500.0 * math.ceil(1.1 * float(np.quantile(r, quantile)) / 500.0)


def main(argv: list[str] | None = None) -> int:
    """``python -m shipradar.sim.studies.figures.false_alarms SCENARIO.yaml OUTDIR [SCANS]``."""
    from shipradar.sim.world.scenario import load_scenario

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
        max_range_m=fa["max_range_m"], title=f"{scenario.name}: {fa['radar_id']}",
        noise_scans=fa["noise_scans"], clutter_scans=fa["scans"])
    first = fa["scan"] == 0
    p2 = plot_ppi_by_origin(
        out / "ppi_false_alarms.png", fa["range_m"][first], fa["azimuth_rad"][first],
        fa["origin"][first], title=f"{fa['radar_id']}: one scan's false alarms",
        max_range_m=fa["max_range_m"], zoom_range_m=clutter_extent_m(fa["range_m"], fa["origin"]),
        wind_from_rad=fa["wind_from_rad"])
    print(p1)
    print(p2)
    from shipradar.tables.scene import load_scene_tables

    pfac = load_scene_tables(scenario).for_radar(fa["radar_id"]).pfac
    if pfac is not None:
        print(plot_pfac_map(out / "pfac_map.png", pfac, wind_from_rad=fa["wind_from_rad"],
                            title=f"{scenario.name}: {fa['radar_id']}"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
