"""Probability-of-detection tables: the exact Swerling P_d on a grid, read by interpolation.

The exact method of :func:`shipradar.sensors.detection.probability_of_detection` costs from a few
10^5 evaluations per second (Swerling 0-3) down to ~10^4 (Swerling 4 at non-integer N, a
48-node quadrature per point).  In a run P_fa is fixed per radar and N_e of [73]-[77] lies
in [1, N_n] (N_n the pulses per beam, [73]): P_d is then a function of two variables, the
per-pulse S/I and N_e, per Swerling case.  :func:`build_pd_table` tabulates it off-line with
the exact method, and :class:`PdTable` reads it at ~10^7 points per second whatever the case
(``fidelity.pd_method: table``; docs/accuracy.md gives the interpolation error).

Choices
-------
* **What is interpolated.**  z = Φ⁻¹(P_d), the normal quantile, not P_d: on the steep part of
  the curve z is nearly linear in S/I [dB] (P_d itself is an S-curve), and the inverse map
  ``ndtr`` keeps every result in [0, 1].  P_d is clipped to [P_fa, 1 - 2^-53] before the
  quantile, so z is finite.
* **Grid.**  S/I uniform in dB (O(1) cell index), N_e uniform in ln N_e from 1 to N_max with
  both ends on the grid (the noise-dominated N_e = N_n is the top row, read without
  interpolation in N).  Bilinear in (ln N_e, S/I dB).
* **Monotone in S/I.**  Each row is made non-decreasing (running maximum; the exact method is
  monotone up to 1e-14) before it is stored.  Bilinear interpolation with non-negative
  weights of non-decreasing rows is non-decreasing in S/I, and ``ndtr`` is increasing, so
  the lookup is monotone in S/I exactly, not just up to rounding.
* **Outside the grid.**  Above the top S/I the top value (P_d within 1e-8 of 1 there for
  every case at the default 100 dB); below the bottom S/I, the linear-in-power join from
  P_fa at S/I = 0 to the bottom value (continuous, monotone, and the exact limit P_fa at
  S/I = 0); N_e outside [1, N_max] (not produced by [74]-[77] for this radar) falls back to
  the exact method.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import special

from shipradar.sensors.detection import SWERLING_CASES, probability_of_detection
from shipradar.tables.store import Table, get_or_build

NAME = "pd"
#: Builder version: bump when the tabulated quantity or the grid rule changes.
VERSION = 1
#: Default S/I axis: bottom, top and step [dB].
SNR_DB_RANGE = (-40.0, 100.0)
SNR_DB_STEP = 0.1
#: Default N_e grid density: points per factor e of N_e (≈ 8.3 per octave).
N_PER_E_FOLD = 12
#: Largest P_d kept below 1 before the quantile (z ≤ 8.2).
_PD_MAX = 1.0 - 2.0**-53


def pd_table_inputs(pfa: float, swerling: int, n_max: float, *,
                    snr_db_range: tuple[float, float] = SNR_DB_RANGE,
                    snr_db_step: float = SNR_DB_STEP,
                    n_per_e_fold: int = N_PER_E_FOLD) -> dict:
    """The inputs that define a P_d table (its cache key)."""
    if not 0.0 < pfa < 1.0:
        raise ValueError(f"pfa must be in (0, 1), got {pfa}")
    if swerling not in SWERLING_CASES:
        raise ValueError(f"swerling must be one of {SWERLING_CASES}, got {swerling}")
    if not (n_max >= 1.0 and math.isfinite(n_max)):
        raise ValueError(f"n_max must be finite and >= 1, got {n_max}")
    if not (snr_db_step > 0 and snr_db_range[1] > snr_db_range[0]):
        raise ValueError("need snr_db_step > 0 and a non-empty snr_db_range")
    return {"pfa": float(pfa), "swerling": int(swerling), "n_max": float(n_max),
            "snr_db_range": [float(v) for v in snr_db_range],
            "snr_db_step": float(snr_db_step), "n_per_e_fold": int(n_per_e_fold)}


def pd_table_axes(inputs: dict) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(N_e axis [-], S/I axis [dB]) of a table with these inputs."""
    lo, hi = inputs["snr_db_range"]
    n_snr = int(round((hi - lo) / inputs["snr_db_step"])) + 1
    snr = np.linspace(lo, hi, n_snr)
    log_top = math.log(inputs["n_max"])
    n_n = max(2, int(math.ceil(log_top * inputs["n_per_e_fold"])) + 1)
    n_axis = np.exp(np.linspace(0.0, log_top, n_n)) if log_top > 0 else np.array([1.0, 1.0 + 1e-9])
    n_axis[0], n_axis[-1] = 1.0, max(inputs["n_max"], n_axis[-1])
    return n_axis, snr


def build_pd_table(pfa: float, swerling: int, n_max: float, **grid) -> Table:
    """Tabulate z = Φ⁻¹(P_d) of the exact method against (N_e, S/I) for one P_fa and case.

    Parameters
    ----------
    pfa : float
        Probability of false alarm [-], in (0, 1) (the radar's, [68]-[72]).
    swerling : int
        Swerling case 0-4.
    n_max : float
        Largest N_e [-] ≥ 1 (the radar's pulses per beam N_n, [73]).
    **grid
        ``snr_db_range`` [dB], ``snr_db_step`` [dB], ``n_per_e_fold`` (see the defaults).

    Returns
    -------
    Table
        Axes ``n_e`` [-] and ``snr_db`` [dB]; values z [-], each row non-decreasing in S/I.
    """
    inputs = pd_table_inputs(pfa, swerling, n_max, **grid)
    n_axis, snr = pd_table_axes(inputs)
    pd = probability_of_detection(snr[None, :], pfa, n_axis[:, None], swerling, "exact")
    z = special.ndtri(np.clip(pd, pfa, _PD_MAX))
    z = np.maximum.accumulate(z, axis=1)  # monotone in S/I (module notes)
    return Table(name=NAME, version=VERSION, inputs=inputs,
                 axes=(n_axis, snr), axis_names=("n_e", "snr_db"), axis_units=("-", "dB"),
                 values=z, value_name="pd_quantile", value_unit="-")


@dataclass
class PdTable:
    """Reader of one :func:`build_pd_table` table (one P_fa, one Swerling case).

    Parameters
    ----------
    table : Table
        A table made by :func:`build_pd_table`.
    """

    table: Table

    def __post_init__(self) -> None:
        t = self.table
        self.pfa = float(t.inputs["pfa"])
        self.swerling = int(t.inputs["swerling"])
        n_axis, snr = t.axes
        self.n_max = float(n_axis[-1])
        self.log_n = np.log(n_axis)
        self.snr0 = float(snr[0])
        self.snr_top = float(snr[-1])
        self.step = float(snr[1] - snr[0])
        self.n_snr = snr.size
        self.z = np.ascontiguousarray(t.values, dtype=float).ravel()
        self.pd_bottom = special.ndtr(t.values[:, 0])
        self.s_bottom = 10.0 ** (self.snr0 / 10.0)

    def __call__(self, snr_db: ArrayLike, n_e: ArrayLike) -> NDArray[np.float64]:
        """P_d [-] at per-pulse S/I ``snr_db`` [dB] (-inf allowed) and N_e ``n_e`` [-] ≥ 1.

        Returns
        -------
        ndarray
            P_d in [P_fa, 1], non-decreasing in S/I; the exact method where N_e is outside
            [1, N_max].
        """
        s_db, n = np.broadcast_arrays(np.asarray(snr_db, dtype=float),
                                      np.asarray(n_e, dtype=float))
        shape = s_db.shape
        s_db, n = s_db.ravel(), n.ravel()
        if np.isnan(s_db).any():
            raise ValueError("snr_db must not be NaN")
        inside_n = (n >= 1.0) & (n <= self.n_max)
        ln = np.log(np.where(inside_n, n, 1.0))
        i = np.clip(np.searchsorted(self.log_n, ln, side="right") - 1, 0, self.log_n.size - 2)
        wn = (ln - self.log_n[i]) / (self.log_n[i + 1] - self.log_n[i])
        x = (np.clip(s_db, self.snr0, self.snr_top) - self.snr0) / self.step
        j = np.minimum(x.astype(np.int64), self.n_snr - 2)
        ws = x - j
        k = i * self.n_snr + j
        z = self.z
        top = z[k] + ws * (z[k + 1] - z[k])
        k2 = k + self.n_snr
        bottom = z[k2] + ws * (z[k2 + 1] - z[k2])
        pd = special.ndtr(top + wn * (bottom - top))
        low = s_db < self.snr0
        if low.any():
            # linear in power from (S = 0, P_fa) to the bottom of the grid
            p0 = self.pd_bottom[i[low]] * (1.0 - wn[low]) + self.pd_bottom[i[low] + 1] * wn[low]
            frac = np.power(10.0, s_db[low] / 10.0) / self.s_bottom
            pd[low] = self.pfa + frac * (p0 - self.pfa)
        if not inside_n.all():
            out = ~inside_n
            pd[out] = probability_of_detection(s_db[out], self.pfa, np.maximum(n[out], 1.0),
                                               self.swerling, "exact")
        return np.clip(pd, self.pfa, 1.0).reshape(shape)


class PdTables:
    """The P_d tables of one radar: one :class:`PdTable` per Swerling case, built (exact
    method) or loaded from the table cache on first use.

    Parameters
    ----------
    pfa : float
        The radar's P_fa [-].
    n_max : float
        The radar's pulses per beam N_n [-] (largest N_e).
    cases : iterable of int, optional
        Swerling cases to prepare now (the scene's targets'); others are loaded when asked.
    """

    def __init__(self, pfa: float, n_max: float, cases=()):
        self.pfa, self.n_max = float(pfa), float(n_max)
        self._tables: dict[int, PdTable] = {}
        for c in sorted(set(int(c) for c in cases)):
            self.table(c)

    def table(self, swerling: int) -> PdTable:
        """The reader for one Swerling case (built and cached if needed)."""
        t = self._tables.get(swerling)
        if t is None:
            inputs = pd_table_inputs(self.pfa, swerling, self.n_max)
            table, _ = get_or_build(NAME, VERSION, inputs,
                                    lambda: build_pd_table(self.pfa, swerling, self.n_max))
            t = self._tables[swerling] = PdTable(table)
        return t

    def __call__(self, snr_db: ArrayLike, n_e: ArrayLike, swerling: ArrayLike) -> NDArray:
        """P_d [-] per point, each with its own Swerling case (arrays broadcast together)."""
        s_db, n, sw = np.broadcast_arrays(np.asarray(snr_db, dtype=float),
                                          np.asarray(n_e, dtype=float), np.asarray(swerling))
        out = np.empty(s_db.shape)
        for c in np.unique(sw).tolist():
            m = sw == c
            out[m] = self.table(int(c))(s_db[m], n[m])
        return out


__all__ = ["PdTable", "PdTables", "build_pd_table", "pd_table_axes", "pd_table_inputs"]
