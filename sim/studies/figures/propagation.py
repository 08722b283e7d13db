"""Propagation figures (PNG, matplotlib Agg): F in dB against range at a height (the seed's
Fig. 4 when given several duct heights) and the range-height coverage diagram of a table."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from shipradar.sensors import parabolic_equation as pe  # noqa: E402
from shipradar.sensors import propagation as prop  # noqa: E402
from shipradar.sim.studies.figures.case import SeaCase  # noqa: E402
from shipradar.tables import propagation as tp  # noqa: E402
from shipradar.tables.store import Table  # noqa: E402

#: Lowest F shown [dB] (nulls go to -inf).
FLOOR_DB = -60.0


def _db(f: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.maximum(20 * np.log10(f), FLOOR_DB)


#: The seed's Fig. 4 case: 10 GHz HP, antenna 20 m, a calm sea, to 60 km.
SEED_FIG4 = SeaCase(freq_hz=10e9, polarization="H", antenna_height_m=20.0, wave_height_m=0.0,
                    max_range_m=60e3)


def plot_factor_vs_range(
    path: str | os.PathLike[str],
    case: SeaCase = SEED_FIG4,
    *,
    target_height_m: float = 25.0,
    duct_heights_m: Sequence[float] = (0.0, 5.0, 10.0, 15.0),
    fidelity: str = "coarse",
    with_two_ray: bool = True,
) -> Path:
    """F [dB] against range at one height, one PE curve per evaporation-duct height.

    Defaults are the seed's Fig. 4 case (:data:`SEED_FIG4`, target 25 m, ducts 0/5/10/15 m;
    the seed's caption swaps the two heights, its text does not).  The two-ray fallback for
    the standard atmosphere is drawn dashed for comparison.

    Parameters
    ----------
    path : path-like
        Output PNG.
    case : SeaCase
        The radar and the sea (default :data:`SEED_FIG4`).
    target_height_m : float
        [m].
    duct_heights_m : sequence of float
        Evaporation duct heights [m] (seed [7]).
    fidelity : str
        PE fidelity.
    with_two_ray : bool
        Also draw :func:`shipradar.sensors.propagation.two_ray_factor`.
    """
    path = Path(path)
    freq_hz, polarization = case.freq_hz, case.polarization
    antenna_height_m, wave_height_m = case.antenna_height_m, case.wave_height_m
    max_range_m = case.max_range_m
    top = max(3 * target_height_m, 2 * antenna_height_m, 100.0)
    fig, ax = plt.subplots(figsize=(7.5, 4.5), dpi=110)
    for duct in duct_heights_m:
        r, h, f = pe.solve_pe(
            freq_hz, antenna_height_m, polarization=polarization, elevation_pattern=None,
            profile={"kind": "evaporation", "duct_height_m": float(duct)},
            wave_height_m=wave_height_m, max_range_m=max_range_m, max_height_m=top,
            fidelity=fidelity, range_step_m=max_range_m / 2000, progress=False,
        )
        row = np.array([np.interp(target_height_m, h, col) for col in f])
        ax.plot(r / 1e3, _db(row), lw=1.0, label=f"PE, duct {duct:g} m")
    if with_two_ray:
        r = np.linspace(max_range_m / 2000, max_range_m, 2000)
        f2 = prop.two_ray_factor(r, antenna_height_m, target_height_m, freq_hz, polarization,
                                 wave_height_m=wave_height_m)
        ax.plot(r / 1e3, _db(f2), "k--", lw=0.8, label="two-ray, 4/3 earth")
    return _save_factor_vs_range(fig, ax, path, freq_hz, polarization, antenna_height_m,
                                 target_height_m)


def plot_table_factor_vs_range(
    path: str | os.PathLike[str],
    table: Table,
    *,
    height_m: float = 10.0,
    wave_height_m: float | None = None,
    elevation_pattern: Callable[[np.ndarray], np.ndarray] | None = None,
    n_points: int = 3000,
) -> Path:
    """F [dB] against range at one height as the on-line model sees it: the PE table, and
    the two-ray fallback where the table has no value (steep angles, outside its domain).

    The standard-atmosphere two-ray factor is drawn dashed for comparison.

    Parameters
    ----------
    path : path-like
        Output PNG.
    table : Table
        A table from :func:`shipradar.tables.propagation.build_propagation_table`.
    height_m : float
        Target height [m].
    wave_height_m : float, optional
        Significant wave height [m] of the two-ray curves; default the table's.
    elevation_pattern : callable, optional
        The pattern the table was built with (absolute elevation [rad] -> field factor), for
        the two-ray curves; None: isotropic.
    n_points : int
        Number of ranges drawn.
    """
    path = Path(path)
    inputs = table.inputs
    r_axis = table.axes[0]
    r = np.linspace(r_axis[0], r_axis[-1], n_points)
    h = np.full_like(r, float(height_m))
    f_table = tp.propagation_factor(table, r, h)
    wave = inputs.get("wave_height_m", 0.0) if wave_height_m is None else wave_height_m
    f_two_ray = prop.two_ray_factor(r, inputs["antenna_height_m"], h, inputs["freq_hz"],
                                    inputs["polarization"], wave_height_m=wave,
                                    elevation_pattern=elevation_pattern)
    fallback = ~np.isfinite(f_table)
    fig, ax = plt.subplots(figsize=(7.5, 4.5), dpi=110)
    ax.plot(r / 1e3, _db(np.where(fallback, np.nan, f_table)), lw=1.0, color="C0",
            label=f"PE table ({_profile_label(inputs.get('profile', {}))})")
    if np.any(fallback):
        ax.plot(r / 1e3, _db(np.where(fallback, f_two_ray, np.nan)), lw=1.0, color="C3",
                label="two-ray fallback (outside the table)")
    ax.plot(r / 1e3, _db(f_two_ray), "k--", lw=0.7, alpha=0.7,
            label="two-ray, standard atmosphere")
    return _save_factor_vs_range(fig, ax, path, inputs["freq_hz"], inputs["polarization"],
                                 inputs["antenna_height_m"], height_m)


def plot_coverage(
    path: str | os.PathLike[str],
    table: Table,
    *,
    max_height_m: float | None = None,
    n_ranges: int = 900,
    n_heights: int = 600,
) -> Path:
    """Range-height coverage diagram: F [dB] of a propagation table, grey where the table has
    no value (there the on-line model uses the two-ray fallback).

    The picture is the table's own lookup (:func:`shipradar.tables.propagation.propagation_factor`)
    on a regular range-height grid, i.e. exactly what the on-line model reads.

    Parameters
    ----------
    path : path-like
        Output PNG.
    table : Table
        A table from :func:`shipradar.tables.propagation.build_propagation_table`.
    max_height_m : float, optional
        Top of the diagram [m]; default the table's maximum height.
    n_ranges, n_heights : int
        Pixels of the diagram.
    """
    path = Path(path)
    inputs = table.inputs
    r_axis = table.axes[0]
    top = float(inputs.get("max_height_m", 1000.0)) if max_height_m is None else max_height_m
    ranges = np.linspace(r_axis[0], r_axis[-1], n_ranges)
    heights = np.linspace(0.0, top, n_heights)
    f = tp.propagation_factor(table, ranges[None, :], heights[:, None])
    fig, ax = plt.subplots(figsize=(8, 4.5), dpi=110)
    ax.set_facecolor("0.85")
    mesh = ax.pcolormesh(ranges / 1e3, heights, np.ma.masked_invalid(_db(f)),
                         cmap="viridis", vmin=-50.0, vmax=10, shading="auto")
    fig.colorbar(mesh, ax=ax, label="F [dB]")
    ax.set_xlabel("terrestrial range [km]")
    ax.set_ylabel("height [m]")
    ax.set_title(f"{inputs.get('freq_hz', float('nan')) / 1e9:g} GHz "
                 f"{inputs.get('polarization', '')}P, antenna "
                 f"{inputs.get('antenna_height_m', float('nan')):g} m, "
                 f"{_profile_label(inputs.get('profile', {}))}; grey: two-ray fallback",
                 fontsize=9)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path


def _profile_label(profile: dict) -> str:
    kind = profile.get("kind", "?")
    if kind == "evaporation":
        return f"evaporation duct {profile.get('duct_height_m', float('nan')):g} m"
    if kind == "standard":
        return "standard atmosphere"
    return f"{kind} M profile"


def _save_factor_vs_range(fig, ax, path: Path, freq_hz: float, polarization: str,
                          antenna_height_m: float, target_height_m: float) -> Path:
    """Axes, title and legend of an F-vs-range figure; write it as PNG and close it."""
    ax.set_xlabel("terrestrial range [km]")
    ax.set_ylabel("propagation factor F [dB]")
    ax.set_ylim(FLOOR_DB, 12)
    ax.grid(alpha=0.3)
    ax.set_title(f"{freq_hz / 1e9:g} GHz {polarization}P, antenna {antenna_height_m:g} m, "
                 f"target {target_height_m:g} m")
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path
