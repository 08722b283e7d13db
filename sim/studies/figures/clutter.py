"""Clutter figures (PNG, matplotlib Agg): σ0* against range with and without a duct (the seed's
Fig. 6) and a PPI-style map of a clutter table."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.projections.polar import PolarAxes  # noqa: E402

from shipradar.sensors import sea_clutter as sc  # noqa: E402
from shipradar.sim.studies.figures.case import SeaCase  # noqa: E402
from shipradar.tables.store import Table  # noqa: E402

#: Lowest clutter-to-noise ratio drawn by :func:`plot_clutter_ppi` [dB].
PPI_CNR_FLOOR_DB = -10.0


#: The seed's Fig. 6 case: 9.8 GHz VP, antenna 25 m, waves 1 m, to 60 km.
SEED_FIG6 = SeaCase(freq_hz=9.8e9, polarization="V", antenna_height_m=25.0, wave_height_m=1.0,
                    max_range_m=60e3)


def plot_ducting_reflectivity(
    path: str | os.PathLike[str],
    case: SeaCase = SEED_FIG6,
    *,
    duct_height_m: float = 10.0,
    wind_speed_mps: float = 4.5,
) -> Path:
    """σ0* [dB] against ground range, standard atmosphere and with a duct (seed Fig. 6, [22]).

    Defaults are the seed's Fig. 6 case (:data:`SEED_FIG6`), with a 10 m duct and a 4.5 m/s
    wind (looking upwind).  Marks the transition ranges used.

    Parameters
    ----------
    path : path-like
        Output PNG.
    case : SeaCase
        The radar and the sea (default :data:`SEED_FIG6`).
    duct_height_m : float
        Evaporation duct height [m] (seed [7]).
    wind_speed_mps : float
        [m/s].
    """
    path = Path(path)
    freq_hz, polarization = case.freq_hz, case.polarization
    antenna_height_m, wave_height_m = case.antenna_height_m, case.wave_height_m
    d = np.linspace(200.0, case.max_range_m, 1200)
    common: dict[str, Any] = dict(
        antenna_height_m=antenna_height_m,
        freq_hz=freq_hz,
        wind_speed_mps=wind_speed_mps,
        wind_relative_azimuth_rad=0.0,
        wave_height_m=wave_height_m,
        polarization=polarization,
    )
    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=110)
    for h, label in ((0.0, "no duct"), (duct_height_m, f"duct {duct_height_m:g} m")):
        s = sc.ducted_reflectivity_db(d, duct_height_m=h, **common)
        (line,) = ax.plot(d / 1e3, s, label=label)
        r_tr = min(
            float(sc.transition_range_m(antenna_height_m, wave_height_m, h)),
            float(sc.git_limit_range_m(antenna_height_m)),
        )
        ax.axvline(r_tr / 1e3, color=line.get_color(), ls=":", lw=1)
    ax.set_ylim(-160, -20)
    ax.set_xlabel("ground range [km]")
    ax.set_ylabel("σ0* [dB m²/m²]")
    ax.set_title(
        f"Sea reflectivity with ducting extension [22] — {freq_hz / 1e9:g} GHz {polarization}P, "
        f"h_a {antenna_height_m:g} m, wind {wind_speed_mps:g} m/s, waves {wave_height_m:g} m",
        fontsize=9,
    )
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path


def plot_clutter_ppi(
    path: str | os.PathLike[str],
    table: Table,
    *,
    array: str | None = None,
    floor_db: float | None = None,
) -> Path:
    """PPI-style map of a clutter table over (ground range, azimuth from true north).

    Powers are shown against the thermal noise N0' when the table knows it (sea maps: the
    clutter-to-noise ratio C/N0' [dB], floored at :data:`PPI_CNR_FLOOR_DB`), otherwise in dBW
    floored 80 dB below the maximum; extras as stored (``array`` picks one).  North up,
    azimuth clockwise; the radial axis stops a little beyond the farthest cell above the floor
    (the clutter extent), and the direction the wind blows from is marked.

    Parameters
    ----------
    path : path-like
        Output PNG.
    table : Table
        A map from :mod:`shipradar.tables.clutter`.
    array : str, optional
        Extra to show instead of the power.
    floor_db : float, optional
        Lowest dB value shown (power only).
    """
    path = Path(path)
    ranges, az = table.axes
    inputs = table.inputs
    power_db = sc.to_db(table.values)
    noise = inputs.get("noise_power_w")
    if noise:
        power_db = power_db - float(sc.to_db(noise))
        lo = PPI_CNR_FLOOR_DB if floor_db is None else floor_db
        label = "clutter-to-noise ratio C/N0' [dB]"
    else:
        lo = float(np.max(power_db)) - 80.0 if floor_db is None else floor_db
        label = f"{table.value_name} [dBW]"
    extent = ranges[-1]
    above = np.flatnonzero(np.any(power_db > lo, axis=1))
    if above.size:
        extent = min(ranges[-1], max(1.25 * ranges[above[-1]], 2e3))
    if array is None:
        data = np.maximum(power_db, lo)
    else:
        data, label = table.extra[array], array
    keep = ranges <= extent + (ranges[1] - ranges[0])
    fig = plt.figure(figsize=(6.5, 6), dpi=110)
    ax = fig.add_subplot(projection="polar")
    assert isinstance(ax, PolarAxes)
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    mesh = ax.pcolormesh(az, ranges[keep] / 1e3, data[keep], shading="auto", cmap="viridis")
    ax.set_ylim(0.0, ranges[keep][-1] / 1e3)
    fig.colorbar(mesh, ax=ax, label=label, shrink=0.8)
    wind_from = inputs.get("wind_direction_rad")
    if wind_from is not None:
        r_top = ranges[keep][-1] / 1e3
        ax.annotate("", xy=(wind_from, 0.55 * r_top), xytext=(wind_from, 0.95 * r_top),
                    arrowprops=dict(arrowstyle="->", color="w", lw=1.5))
        ax.text(wind_from, 1.0 * r_top, "wind", color="k", ha="center", fontsize=8)
    what = table.name if array is None else f"{table.name}: {array}"
    ax.set_title(f"{what} (range in km, 0-{ranges[keep][-1] / 1e3:.3g} of "
                 f"{ranges[-1] / 1e3:.3g} km)", fontsize=9)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path
