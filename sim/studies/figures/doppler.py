"""Improvement factor against normalized Doppler for a filter set (the seed's Fig. 7).

The seed's Fig. 7 shows a bank of five FIR filters of 32 Hann-weighted taps: the improvement
factor peaks at the filter centres ``f_i = (i-1)/5`` [60] and dips between them (scalloping or
picket-fence effect).  The seed does not state the clutter spread of its figure; this one
draws a few spreads, the clutter centred on zero Doppler.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from shipradar.sensors import doppler_filters as df  # noqa: E402

#: Spreads drawn by default, σ_s/f_r [1].
FIG7_SPREADS_NORM = (0.001, 0.01, 0.03)


def improvement_vs_doppler_db(
    weights: np.ndarray,
    spreads_norm: Sequence[float],
    doppler_norm: np.ndarray,
    *,
    pick: df.PickRule = "response",
    stability_limit_db: float = df.DEFAULT_STABILITY_LIMIT_DB,
) -> np.ndarray:
    """I_F [dB], shape (len(spreads_norm), len(doppler_norm)), of a bank (F, N) or filter (N,).

    Parameters
    ----------
    weights : ndarray
        Filter weights [1].
    spreads_norm : sequence of float
        Clutter spreads over the PRF, ``σ_s/f_r`` [1].
    doppler_norm : ndarray
        Target Dopplers over the PRF, ``f_d/f_r`` [1].
    pick, stability_limit_db
        As in :func:`shipradar.sensors.doppler_filters.bank_improvement_factor`.
    """
    spreads = np.asarray(spreads_norm, dtype=float)[:, None]
    i_f = df.bank_improvement_factor(
        weights,
        spreads,
        np.asarray(doppler_norm, float)[None, :],
        pick=pick,
        stability_limit_db=stability_limit_db,
    )
    return 10.0 * np.log10(i_f)


def plot_improvement_vs_doppler(
    path: str | os.PathLike[str],
    *,
    n_taps: int = 32,
    n_filters: int = 5,
    window: str = "hann",
    sidelobe_db: float | None = None,
    mti_pulses: int | None = None,
    spreads_norm: Sequence[float] = FIG7_SPREADS_NORM,
    pick: df.PickRule = "response",
    n_points: int = 2001,
    stability_limit_db: float = df.DEFAULT_STABILITY_LIMIT_DB,
) -> Path:
    """Write a PNG of I_F against ``f_d/f_r`` in [0, 1]; defaults reproduce the seed's Fig. 7.

    Parameters
    ----------
    path : path-like
        Output PNG file.
    n_taps, n_filters, window, sidelobe_db
        The FIR bank ([59]-[62]): taps per filter, filters, window, design sidelobe level [dB].
    mti_pulses : int, optional
        If given, an MTI canceller of this many pulses precedes the bank ([61]).
    spreads_norm : sequence of float
        Clutter spreads ``σ_s/f_r`` [1], one curve each.
    pick : {"response", "best"}
        Filter-pick rule (:func:`shipradar.sensors.doppler_filters.bank_improvement_factor`).
    n_points : int
        Doppler samples over one PRF.
    stability_limit_db : float
        System-stability limit [dB].

    Returns
    -------
    Path
        The written file.
    """
    weights = df.bank_weights(n_taps, n_filters, window=window, sidelobe_db=sidelobe_db)
    title = f"{n_filters} FIR filters, {n_taps} {window} taps"
    if mti_pulses is not None:
        weights = df.cascade_weights(df.canceller_weights(mti_pulses), weights)
        title = f"{mti_pulses}-pulse MTI + " + title
    doppler = np.linspace(0.0, 1.0, int(n_points))
    curves = improvement_vs_doppler_db(
        weights, spreads_norm, doppler, pick=pick, stability_limit_db=stability_limit_db
    )
    fig, ax = plt.subplots(figsize=(7.0, 4.2), dpi=120)
    try:
        for spread, curve in zip(spreads_norm, curves, strict=True):
            ax.plot(doppler, curve, lw=1.0, label=f"σ_s/f_r = {spread:g}")
        for centre in df.filter_centres_norm(n_filters):
            ax.axvline(centre, color="0.8", lw=0.6, zorder=0)
        ax.set_xlim(0.0, 1.0)
        ax.set_ylim(max(curves.min(), -60.0), curves.max() + 5.0)
        ax.set_xlabel("normalized Doppler f_d / f_r")
        ax.set_title(f"I_F vs Doppler: {title} (pick: {pick})")
        return _save_improvement_figure(fig, ax, path)
    finally:
        plt.close(fig)


#: Clutter spreads σ_s/f_r drawn from an I_F table [1].
TABLE_SPREADS_NORM = (1e-3, 1e-2, 3e-2, 1e-1)
#: Widest Doppler span of a stagger's figure, over the reference PRF [1].
TABLE_MAX_SPAN_NORM = 20.0


def plot_improvement_table(
    path: str | os.PathLike[str],
    table,
    *,
    spreads_norm: Sequence[float] = TABLE_SPREADS_NORM,
    title: str | None = None,
    n_points: int = 4001,
) -> Path:
    """Write a PNG of an I_F table (:mod:`shipradar.tables.improvement`) against ``f_d/f_r``.

    One curve per clutter spread, read through the on-line lookup
    (:func:`shipradar.tables.improvement.improvement_factor_db`) over one Doppler period of the
    processor (1 for a constant PRF; the stagger's period, at most
    :data:`TABLE_MAX_SPAN_NORM`), so the picture shows what a run reads.

    Parameters
    ----------
    path : path-like
        Output PNG file.
    table : Table
        An improvement-factor table.
    spreads_norm : sequence of float
        Clutter spreads ``σ_s/f_r`` [1].
    title : str, optional
        Prefix of the title (e.g. the radar id).
    n_points : int
        Doppler samples.

    Returns
    -------
    Path
        The written file.
    """
    from shipradar.tables.improvement import doppler_period, improvement_factor_db

    period = min(doppler_period(table.inputs), TABLE_MAX_SPAN_NORM)
    doppler = np.linspace(0.0, period, int(n_points))
    inputs = table.inputs
    desc = inputs["processor"]
    if "mti_pulses" in inputs:
        desc += f", {inputs['mti_pulses']}-pulse MTI"
    if "n_pulses" in inputs:
        taps = inputs["n_pulses"] - (inputs.get("mti_pulses", 1) - 1)
        desc += f", {inputs['n_filters']} filters of {taps} {inputs['window']} taps"
        if taps != inputs["n_pulses"]:
            desc += f" (CPI {inputs['n_pulses']} pulses)"
    if "stagger_prf_hz" in inputs:
        lo, hi = inputs["stagger_prf_hz"]
        desc += f", stagger {lo:g}/{hi:g} Hz (f_r = {inputs['prf_hz']:g} Hz)"
    fig, ax = plt.subplots(figsize=(7.5, 4.2), dpi=120)
    try:
        lowest = 0.0
        for spread in spreads_norm:
            curve = improvement_factor_db(table, spread, doppler)
            lowest = min(lowest, float(np.min(curve)))
            ax.plot(doppler, curve, lw=0.9, label=f"σ_s/f_r = {spread:g}")
        ax.set_xlim(0.0, period)
        ax.set_ylim(max(lowest, -60.0) - 2.0, float(np.max(table.values)) + 5.0)
        ax.set_xlabel("normalized Doppler (f_d - μ_c) / f_r")
        ax.set_title(f"{title + ': ' if title else ''}{desc}", fontsize=9)
        return _save_improvement_figure(fig, ax, path)
    finally:
        plt.close(fig)


def _save_improvement_figure(fig, ax, path) -> Path:
    """Common axis, grid and legend of an I_F-vs-Doppler figure; write it as PNG."""
    ax.set_ylabel("improvement factor I_F [dB]")
    ax.grid(True, lw=0.3)
    ax.legend(loc="lower right", fontsize=8)
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    return out
