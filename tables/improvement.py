"""Improvement-factor tables I_F(σ_s/f_r, f_d/f_r), the off-line level of seed chapter 5.

One table per radar processor, built by :func:`build_improvement_table` from the physics of
:mod:`shipradar.sensors.doppler_filters`, cached by :func:`improvement_table` (key: exactly the
inputs that change the table) and read on-line by :func:`improvement_factor_db`.

Grid
    * axis 0: ``log10(σ_s/f_r)`` from :data:`LOG10_SPREAD_MIN` to :data:`LOG10_SPREAD_MAX`,
      uniform.  I_F varies as a power of the spread (20 dB per decade per canceller stage), so
      interpolation in dB against ``log10 σ`` is accurate where a linear axis is not.  Below
      the axis the clutter is nearly coherent and the processor near its stability limit (a
      2-pulse canceller within 0.01 dB of it at 1e-7 with the default 100 dB limit), but not
      every processor (a rectangular DFT bank, whose filters have exact nulls at zero
      Doppler, reads 1.6 dB higher at 0 than at 1e-7; any processor with a limit above 100
      dB): there the lookup evaluates the picked filter's clutter output
      (:func:`shipradar.sensors.doppler_filters.clutter_output_power`, O(64 F N) per point)
      with the exact response.  Above ``σ_s = f_r`` the clutter is white to 1e-8: the lookup
      clamps to the last row.
    * axis 1: ``f_d/f_r`` over one period of the processor's response, 0 to 1, uniform.

Staggered PRF.  The seed's staggered I_F (5.1.4) is the linear mean of two constant-PRF
systems, one at each bounding PRF ``f_k`` of the stagger
(:func:`shipradar.sensors.doppler_filters.staggered_improvement_factor`); each is the
constant-PRF I_F of the same filter weights with the spread and the Doppler normalized to its
own PRF, ``σ_s/f_k = (σ_s/f_r)(f_r/f_k)``.  A stagger table therefore holds the constant-PRF
table of its weights (with its filter switches and steep cells), and its reader evaluates
each bound there, at ``(f_r/f_k)`` times the point, and averages the two in linear power.
This reads any Doppler of either sign exactly as the constant-PRF table does, whatever the
stagger's period (the least common multiple of the two PRFs: hundreds or thousands of f_r for
close PRFs, which a table over the period could not hold), and its grid is as small as the
constant-PRF one.  A bound whose scaled spread leaves the spread axis is read as any spread
outside it.

The Doppler axis is the target Doppler *relative to the clutter mean* (the table is built with
the clutter centred on zero Doppler).  This is the seed's MTI with its clutter mean brought
back to zero [58]; for a bank it is exact when the clutter mean sits on a filter centre and an
approximation otherwise.

Filter-pick rule (banks): a target is read from the filter with the largest signal response at
its Doppler (the filter whose passband holds it); the table holds that filter's I_F.  The
alternative ``pick="best"`` takes the largest I_F over the filters.

Besides the I_F (``values``, dB), the table carries ``extra["coherent_gain_db"]``: the I_F
against white noise (``M_c = I``) with the same pick rule, i.e. the limit of the table for
``σ_s -> ∞``.  It is read like the I_F: across a filter switch each side follows its own
filter, and steep cells (blind speeds) are read with the exact response.

Steep cells.  For one filter the I_F separates, ``I_F = (|H_p(f)|² + εE_p)/(C_p(σ) + εE_p)``:
the Doppler enters only through the picked filter's response.  Near a null of that response
(an MTI's blind speed, a sidelobe null between non-overlapping FIR filters) the response is
logarithmic and no dB interpolation across the cell follows it (the chord reads tens of dB
low, or misses a null inside the cell and the neighbouring filter that takes over there).
The "response" table therefore also stores the picked filter and its response at each
Doppler node (``picked_filter``, ``signal_db``), and attaches every filter's clutter output
``C_p(σ) + εE_p`` on the spread axis and its white-noise output ``C_p(∞) + εE_p``
(``clutter_db``, ``white_db``) and a mask of the cells to read exactly (``exact_cells``: those
where the coherent gain read from the grid misses the function by more than
:data:`EXACT_CELL_DB` at a quarter, the middle or three quarters of the cell, found when the
table is built).  In those cells, and wherever the picked response changes by more than
:data:`STEEP_CELL_DB` across the cell, the lookup evaluates every filter's response exactly,
picks by the same rule, and keeps only the smooth clutter part of the picked filter from the
table, interpolated along the spread axis (O(F N) per such point).  The coherent gain is read
the same way, with the white-noise output in place of ``C_p(σ)``.

Exact ties of the pick rule (two filters of equal response per unit energy at the target's
Doppler): the direct function takes the lowest index; the lookup takes, within 1e-9
(:data:`TIE_RELATIVE`), the filter the table picked at the cell's node on that side, else the
lowest index.  The two agree except on the measure-zero set where two filters that are not
mirror images of each other tie exactly (mirror filters, e.g. at ``f_d/f_r = 1/2`` in a
symmetric bank, have equal I_F).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shipradar.sensors import doppler_filters as df
from shipradar.tables.blas import matmul_one_thread
from shipradar.tables.store import Table, get_or_build

BUILDER_NAME = "improvement_factor"
#: 4: a "response" table at constant PRF keeps its processor's ``weights`` (read by the
#: steep cells on-line, which then need no window function: no scipy.signal in a run).
#: 5: a stagger table holds its weights' constant-PRF table, read at each bound; the
#: coherent gain is read like the I_F; cells with a null inside are read exactly (issue 36).
#: 6: the "best" pick keeps its filters' clutter outputs and is read exactly in Doppler.
BUILDER_VERSION = 6

#: Processor kinds: none (I_F = 1, no table), MTI canceller, DFT bank, FIR bank, MTI + bank.
PROCESSORS = ("none", "mti", "dft_bank", "fir_bank", "mti_bank")

#: Spread axis limits, log10(σ_s/f_r) [1].
LOG10_SPREAD_MIN = -7.0
LOG10_SPREAD_MAX = 0.0
#: PRFs are made rational at this resolution to find a stagger's Doppler period [Hz].
PRF_RESOLUTION_HZ = 1e-3
#: A Doppler cell over which the picked filter's response changes by more than this is read
#: with the exact response of that filter (see :func:`improvement_factor_db`) [dB].
STEEP_CELL_DB = 3.0
#: A Doppler cell where the coherent gain read from the grid misses the function by more
#: than this at a quarter, the middle or three quarters of the cell is read exactly [dB].
EXACT_CELL_DB = 0.5
#: Points of each Doppler cell where the build checks the reading (fractions of the cell).
_CHECK_POINTS = (0.25, 0.5, 0.75)
#: Filter responses this close (relative) are a tie of the pick rule [1].
TIE_RELATIVE = 1e-9


@dataclass(frozen=True)
class GridResolution:
    """Sampling of the table grid.

    Attributes
    ----------
    spread_per_decade : int
        Points per decade of ``σ_s/f_r``.
    doppler_per_bin : int
        Doppler points per ``1/N`` (N the filter length in taps), per PRF period.
    doppler_min : int
        Minimum Doppler points per PRF period (short filters).
    """

    spread_per_decade: int
    doppler_per_bin: int
    doppler_min: int


RESOLUTIONS = {
    "coarse": GridResolution(spread_per_decade=6, doppler_per_bin=4, doppler_min=64),
    "standard": GridResolution(spread_per_decade=12, doppler_per_bin=8, doppler_min=128),
    "fine": GridResolution(spread_per_decade=24, doppler_per_bin=16, doppler_min=256),
}


@dataclass(frozen=True)
class ImprovementTableSpec:
    """What an improvement-factor table depends on: one declaration, read by the cache key
    (:meth:`inputs`) and by :func:`build_improvement_table`.

    Parameters
    ----------
    processor : {"none", "mti", "dft_bank", "fir_bank", "mti_bank"}
        ``"none"``: no Doppler processing (I_F = 1, no table).  ``"mti"``: an
        ``mti_pulses``-pulse canceller [58].  ``"dft_bank"``: ``n_pulses`` filters of
        ``n_pulses`` taps [59]-[60], windowed [62].  ``"fir_bank"``: ``n_filters`` filters of
        ``n_pulses`` taps, windowed.  ``"mti_bank"``: the canceller followed by a bank, [61];
        the coherent processing interval is ``n_pulses`` pulses, so the bank has
        ``n_pulses - mti_pulses + 1`` taps and (default) as many filters.
    n_pulses : int
        Pulses per coherent processing interval, ``N_c`` [1] (banks and cascades).
    mti_pulses : int
        Pulses processed by the canceller, ``M`` [1], ``>= 2`` (2: single canceller).
    n_filters : int, optional
        Filters in the bank [1]; default: as many as the bank has taps (DFT bank).
    window : str
        Data window of the bank [62], one of :data:`shipradar.sensors.doppler_filters.WINDOWS`.
    window_sidelobe_db : float, optional
        Taylor/Chebyshev design sidelobe level below the mainlobe [dB].
    taylor_nbar : int
        Taylor n-bar [1].
    prf_hz : float, optional
        Reference PRF that normalizes the table axes [Hz]; needed with a stagger.
    stagger_prf_hz : sequence of float, optional
        PRFs of a staggered waveform [Hz] (seed 5.1.4: bounded by the lowest and highest).
    resolution : {"coarse", "standard", "fine"}
        Grid resolution, see :data:`RESOLUTIONS`.
    pick : {"response", "best"}
        Filter-pick rule for banks (module docstring).
    stability_limit_db : float
        System-stability limit of the improvement factor [dB].
    """

    processor: str
    n_pulses: int | None = None
    mti_pulses: int = 2
    n_filters: int | None = None
    window: str = "rectangular"
    window_sidelobe_db: float | None = None
    taylor_nbar: int = df.DEFAULT_TAYLOR_NBAR
    prf_hz: float | None = None
    stagger_prf_hz: Sequence[float] | None = None
    resolution: str = "standard"
    pick: str = "response"
    stability_limit_db: float = df.DEFAULT_STABILITY_LIMIT_DB

    def inputs(self) -> dict[str, Any] | None:
        """Validate the processor description and return the table's inputs (its cache key
        and provenance); None for ``processor="none"``.

        Only the inputs that change the table are kept (e.g. the PRF only for a stagger, the
        window only for a bank), so that equal tables share one cache file.
        """
        processor = self.processor
        if processor not in PROCESSORS:
            raise ValueError(f"unknown processor {processor!r}; choose one of {PROCESSORS}")
        if processor == "none":
            return None
        if self.resolution not in RESOLUTIONS:
            raise ValueError(f"resolution must be one of {sorted(RESOLUTIONS)}, "
                             f"got {self.resolution!r}")
        if self.pick not in ("response", "best"):
            raise ValueError(f"pick must be 'response' or 'best', got {self.pick!r}")
        df.stability_residue(self.stability_limit_db)  # validates the range
        inputs: dict[str, Any] = {
            "processor": processor,
            "resolution": self.resolution,
            "stability_limit_db": float(self.stability_limit_db),
        }
        mti_pulses = self.mti_pulses
        if processor in ("mti", "mti_bank"):
            if int(mti_pulses) != mti_pulses or mti_pulses < 2:
                raise ValueError(f"mti_pulses must be an integer >= 2, got {mti_pulses}")
            inputs["mti_pulses"] = int(mti_pulses)
        if processor != "mti":
            inputs.update(self._bank_inputs())
        if self.stagger_prf_hz is not None and len(self.stagger_prf_hz) > 0:
            prfs = sorted(float(f) for f in self.stagger_prf_hz)
            if self.prf_hz is None or self.prf_hz <= 0 or prfs[0] <= 0:
                raise ValueError("a staggered PRF needs prf_hz > 0 and positive stagger PRFs")
            # only the two bounding PRFs enter the model (5.1.4)
            inputs.update(prf_hz=float(self.prf_hz), stagger_prf_hz=[prfs[0], prfs[-1]])
        return inputs

    def _bank_inputs(self) -> dict[str, Any]:
        """The bank's inputs (taps, filters, window, pick) of a bank or a cascade."""
        processor, n_pulses, window = self.processor, self.n_pulses, self.window
        if n_pulses is None or int(n_pulses) != n_pulses:
            raise ValueError(f"processor {processor!r} needs an integer n_pulses")
        n_taps = int(n_pulses) - (int(self.mti_pulses) - 1 if processor == "mti_bank" else 0)
        if n_taps < 1:
            raise ValueError(f"n_pulses={n_pulses} leaves no tap for the bank")
        if processor == "dft_bank":
            if self.n_filters is not None and int(self.n_filters) != n_taps:
                raise ValueError("a DFT bank has as many filters as taps; use 'fir_bank'")
            filters = n_taps
        else:
            filters = n_taps if self.n_filters is None else int(self.n_filters)
        if filters < 1:
            raise ValueError("n_filters must be >= 1")
        if window not in df.WINDOWS:
            raise ValueError(f"unknown window {window!r}; choose one of {df.WINDOWS}")
        out: dict[str, Any] = dict(n_pulses=int(n_pulses), n_filters=filters, window=window,
                                   pick=self.pick)
        if window == "taylor":
            sll = (df.DEFAULT_TAYLOR_SIDELOBE_DB if self.window_sidelobe_db is None
                   else self.window_sidelobe_db)
            out.update(window_sidelobe_db=float(sll), taylor_nbar=int(self.taylor_nbar))
        elif window == "chebyshev":
            if self.window_sidelobe_db is None:
                raise ValueError("the Chebyshev window needs window_sidelobe_db")
            out["window_sidelobe_db"] = float(self.window_sidelobe_db)
        return out


def improvement_table_inputs(processor: str, **kwargs: Any) -> dict[str, Any] | None:
    """The inputs of an improvement-factor table (its cache key), validated; None for
    ``processor="none"``.  The keywords are the fields of :class:`ImprovementTableSpec`
    (the arguments of :func:`build_improvement_table` and :func:`improvement_table`)."""
    return ImprovementTableSpec(processor, **kwargs).inputs()


def processor_weights(inputs: dict[str, Any]) -> NDArray:
    """Filter weights, shape (F, N), of the processor described by ``inputs``."""
    kind = inputs["processor"]
    mti = df.canceller_weights(inputs["mti_pulses"]) if "mti_pulses" in inputs else None
    if kind in ("mti", "mti_bank") and mti is None:
        raise ValueError(f"a {kind!r} processor needs mti_pulses")
    if kind == "mti" and mti is not None:
        return mti[None, :]
    n_taps = inputs["n_pulses"] - (inputs["mti_pulses"] - 1 if kind == "mti_bank" else 0)
    bank = df.bank_weights(
        n_taps,
        inputs["n_filters"],
        window=inputs["window"],
        sidelobe_db=inputs.get("window_sidelobe_db"),
        nbar=inputs.get("taylor_nbar", df.DEFAULT_TAYLOR_NBAR),
    )
    if kind == "mti_bank" and mti is not None:
        return df.cascade_weights(mti, bank)
    return bank


def doppler_period(inputs: dict[str, Any]) -> float:
    """Doppler period of the processor's I_F in units of the reference PRF [1].

    1 for a constant PRF.  For a stagger, the least common multiple of the two bounding PRFs
    (made rational at :data:`PRF_RESOLUTION_HZ`) over the reference PRF: hundreds of f_r or
    more for close PRFs.  The table's Doppler axis is one period of each bound (0 to 1 in its
    own PRF), whatever this is (module docstring); figures show the stagger over it.
    """
    if "stagger_prf_hz" not in inputs:
        return 1.0
    fracs = [
        Fraction(f).limit_denominator(round(1 / PRF_RESOLUTION_HZ))
        for f in inputs["stagger_prf_hz"]
    ]
    common = math.lcm(*(f.denominator for f in fracs))
    nums = [f.numerator * (common // f.denominator) for f in fracs]
    lcm_hz = Fraction(math.lcm(*nums), common)
    return float(lcm_hz / Fraction(inputs["prf_hz"]))


def stagger_scales(inputs: dict[str, Any]) -> tuple[float, ...]:
    """``f_r/f_k`` [1] of the two bounding PRFs ``f_k`` of a stagger (lowest first), by which
    the lookup scales a point ``(σ_s/f_r, f_d/f_r)`` to read each bound; ``()`` at constant
    PRF.  The same products as
    :func:`shipradar.sensors.doppler_filters.staggered_improvement_factor`."""
    if "stagger_prf_hz" not in inputs:
        return ()
    return tuple(inputs["prf_hz"] / f_k for f_k in inputs["stagger_prf_hz"])


def improvement_axes(inputs: dict[str, Any], n_taps: int) -> tuple[NDArray, NDArray]:
    """The table's axes for its ``inputs`` and a filter of ``n_taps`` taps: log10 of the
    clutter spread over the PRF [-] and the Doppler over the PRF in [0, 1] [-]."""
    res = RESOLUTIONS[inputs["resolution"]]
    n_spread = round((LOG10_SPREAD_MAX - LOG10_SPREAD_MIN) * res.spread_per_decade) + 1
    log_spread = np.linspace(LOG10_SPREAD_MIN, LOG10_SPREAD_MAX, n_spread)
    per_prf = max(res.doppler_min, res.doppler_per_bin * n_taps)
    doppler = np.linspace(0.0, 1.0, per_prf + 1)
    return log_spread, doppler


def _switch_aware_grid(
    weights: NDArray, spread: NDArray, doppler: NDArray, limit_db: float
) -> dict[str, NDArray]:
    """I_F [linear] on the grid with the "response" pick, and the data to read its jumps.

    The picked filter depends on the Doppler only; where it changes between two Doppler nodes
    the I_F jumps.  For each cell ``[d_j, d_j+1]`` this returns ``ahead`` (the I_F of the filter
    picked at ``d_j``, evaluated at ``d_j+1``), ``behind`` (the filter picked at ``d_j+1``,
    evaluated at ``d_j``) and ``crossover``, the fraction of the cell where their responses are
    equal (found by bisection; 1 where the pick does not change), so that the lookup follows
    each filter up to the switch instead of smearing the jump over the cell.
    """
    eps = df.stability_residue(limit_db)
    energy = np.sum(np.abs(weights) ** 2, axis=-1)
    sig = df.signal_output_power(weights, doppler) + eps * energy[:, None]  # (F, D)
    clu = df.clutter_output_power(weights, spread) + eps * energy[:, None]  # (F, S)
    # the same rule (and the same tie-break) as df.bank_improvement_factor
    pick = np.argmax(sig / energy[:, None], axis=0)
    cols = np.arange(len(doppler))
    values = sig[pick, cols][None, :] / clu[pick, :].T
    nxt = np.append(pick[1:], pick[-1])
    nxt_col = np.minimum(cols + 1, len(doppler) - 1)
    ahead = sig[pick, nxt_col][None, :] / clu[pick, :].T
    behind = sig[nxt, cols][None, :] / clu[nxt, :].T
    crossover = np.ones(len(doppler))
    cells = np.flatnonzero(pick != nxt)
    if cells.size:
        a, b = pick[cells], nxt[cells]
        lo, hi = np.zeros(cells.size), np.ones(cells.size)
        step = doppler[1] - doppler[0]
        for _ in range(50):  # 2^-50 of a cell
            mid = 0.5 * (lo + hi)
            f = doppler[cells] + mid * step
            r_a = np.abs(np.sum(np.conj(weights[a]) * _steer(f, weights.shape[-1]), axis=-1)) ** 2
            r_b = np.abs(np.sum(np.conj(weights[b]) * _steer(f, weights.shape[-1]), axis=-1)) ** 2
            left = r_a / energy[a] >= r_b / energy[b]
            lo = np.where(left, mid, lo)
            hi = np.where(left, hi, mid)
        crossover[cells] = 0.5 * (lo + hi)
    shape = values.shape
    return {
        "values": values,
        "ahead": ahead,
        "behind": behind,
        "crossover": np.broadcast_to(crossover, shape).copy(),
        "picked_filter": np.broadcast_to(pick.astype(float), shape).copy(),
        "signal_db": np.broadcast_to(10.0 * np.log10(sig[pick, cols]), shape).copy(),
    }


def _steer(f: NDArray, n: int) -> NDArray:
    """exp(-j2π f n) for each f (rows) and tap n (columns)."""
    return np.exp(-2j * np.pi * np.mod(f[:, None] * np.arange(n), 1.0))


#: Above this many filter-tap-Doppler products (both bounds of a stagger), the staggered
def build_improvement_table(processor: str, **kwargs: Any) -> Table | None:
    """Build the I_F table of a processor (keywords of :func:`improvement_table_inputs`).

    Returns ``None`` for ``processor="none"`` (I_F = 1 everywhere; :func:`improvement_factor_db`
    accepts ``None``).  The table's ``values`` are I_F [dB] on (``log10(σ_s/f_r)``,
    ``f_d/f_r``) computed exactly at every grid point ([57], O(N) per point), with the pick
    rule of :func:`shipradar.sensors.doppler_filters.bank_improvement_factor`.  For a stagger
    they are the constant-PRF I_F of its filter weights, which the lookup reads at each of
    the two bounds of 5.1.4 (module docstring): the same grid as without the stagger.

    Extra arrays: ``coherent_gain_db`` (I_F against white noise, the ``σ_s -> ∞`` limit);
    for the "response" pick, ``ahead_db``, ``behind_db`` and ``crossover`` locate the jumps
    of the I_F where the picked filter changes, and ``picked_filter`` and ``signal_db`` (the
    picked filter's ``|H|² + εE`` at each Doppler node [dB]) let the lookup read steep cells
    exactly (see :func:`improvement_factor_db`), with the attached ``weights`` (F, N), the
    processor's filter weights they are computed from (so that a run reads them from the
    table rather than building the window again).  Attached besides: every filter's clutter
    output on the spread axis and white-noise output (``clutter_db``, ``white_db`` [dB]) and,
    for the "response" pick, the ``exact_cells`` mask.  The "best" pick (a maximum over the
    filters, whose filter changes with the spread) is read exactly in Doppler (each filter's
    response at the point over its clutter output interpolated in spread); its ``values``
    serve the generic :meth:`Table.lookup` and figures.
    """
    inputs = improvement_table_inputs(processor, **kwargs)
    if inputs is None:
        return None
    weights = processor_weights(inputs)
    log_spread, doppler = improvement_axes(inputs, weights.shape[-1])
    spread = 10.0**log_spread
    limit = inputs["stability_limit_db"]
    pick = inputs.get("pick", "response")
    common = dict(pick=pick, stability_limit_db=limit)
    white = df.bank_improvement_factor(weights, np.inf, doppler, **common)
    if pick == "response":
        grid = _switch_aware_grid(weights, spread, doppler, limit)
    else:
        grid = {
            "values": df.bank_improvement_factor(
                weights, spread[:, None], doppler[None, :], **common
            )
        }
    values = 10.0 * np.log10(grid["values"])
    if "ahead" not in grid:
        # no jumps: the continuations are the neighbouring nodes themselves
        grid["ahead"] = np.concatenate([grid["values"][:, 1:], grid["values"][:, -1:]], axis=1)
        grid["behind"] = grid["values"]
        grid["crossover"] = np.ones(values.shape)
    extra = {
        "coherent_gain_db": np.broadcast_to(10.0 * np.log10(white), values.shape).copy(),
        "ahead_db": 10.0 * np.log10(grid["ahead"]),
        "behind_db": 10.0 * np.log10(grid["behind"]),
        "crossover": grid["crossover"],
    }
    if "signal_db" in grid:
        extra["picked_filter"] = grid["picked_filter"]
        extra["signal_db"] = grid["signal_db"]
    table = Table(
        name=BUILDER_NAME,
        version=BUILDER_VERSION,
        axes=(log_spread, doppler),
        axis_names=("log10_spread_norm", "doppler_norm"),
        axis_units=("log10(1)", "1"),
        values=values,
        value_name="improvement_factor_db",
        value_unit="dB",
        inputs=inputs,
        extra=extra,
        # the exact responses of steep cells and of the "best" pick (_processor_of)
        attached={"weights": weights} | _clutter_outputs_db(weights, spread, limit),
    )
    if "signal_db" in grid:
        table.attached["exact_cells"] = _exact_cells(table, weights, limit)
    return table


def _clutter_outputs_db(weights: NDArray, spread: NDArray, limit_db: float
                        ) -> dict[str, NDArray]:
    """Every filter's clutter output ``C_p(σ) + εE_p`` on the spread axis, (S, F), and its
    white-noise output ``C_p(∞) + εE_p``, (F,) [dB]: the smooth part of a steep cell's I_F
    and coherent gain."""
    floor = df.stability_residue(limit_db) * np.sum(np.abs(weights) ** 2, axis=-1)
    clutter = df.clutter_output_power(weights, spread) + floor[:, None]
    white = df.clutter_output_power(weights, np.inf) + floor
    return {"clutter_db": 10.0 * np.log10(clutter.T), "white_db": 10.0 * np.log10(white)}


def _exact_cells(table: Table, weights: NDArray, limit_db: float) -> NDArray:
    """Doppler cells (D-1,) where the coherent gain read from the grid (switches and steep
    cells included) misses the function by more than :data:`EXACT_CELL_DB` at one of
    :data:`_CHECK_POINTS`: a null of the picked filter inside the cell with both nodes on
    its flanks, or another filter's sidelobe taking over there.  The I_F has the same
    Doppler dependence (module docstring), so these cells are read exactly for both."""
    ax_d = table.axes[1]
    frac = np.asarray(_CHECK_POINTS)
    d = (ax_d[:-1, None] + frac * (ax_d[1] - ax_d[0])).ravel()
    table.attached["exact_cells"] = np.zeros(ax_d.size - 1, dtype=bool)
    (read,) = _read_cells(table, _cells(table, np.ones(d.size), d), (_SEPARABLE,))
    exact = 10.0 * np.log10(df.bank_improvement_factor(weights, np.inf, d,
                                                       stability_limit_db=limit_db))
    miss = np.abs(read - exact).reshape(ax_d.size - 1, frac.size)
    return np.any(miss > EXACT_CELL_DB, axis=1)


def improvement_table(
    processor: str, *, root: Path | None = None, **kwargs: Any
) -> tuple[Table | None, bool]:
    """Cached :func:`build_improvement_table`: ``(table, built)``; ``(None, False)`` for none.

    ``root`` overrides the cache directory (default :func:`shipradar.tables.store.cache_dir`).
    """
    inputs = improvement_table_inputs(processor, **kwargs)
    if inputs is None:
        return None, False
    return get_or_build(
        BUILDER_NAME,
        BUILDER_VERSION,
        inputs,
        lambda: build_improvement_table(processor, **kwargs),
        root=root,
    )


def improvement_factor_db(
    table: Table | None,
    spread_norm: ArrayLike,
    doppler_norm: ArrayLike,
    *,
    array: str | None = None,
) -> NDArray:
    """Vectorized on-line lookup of the improvement factor I_F [dB].

    Bilinear interpolation (in dB, against ``log10 σ`` and ``f_d/f_r``) on the uniform grid,
    by direct index arithmetic: O(1) per point, no search.  In a Doppler cell where the
    picked filter changes, each side of the crossover interpolates its own filter's I_F, so
    the jump of the pick rule stays sharp; in a cell where the picked filter's response
    changes by more than :data:`STEEP_CELL_DB` (a blind speed, a null between filters) the
    response is evaluated exactly (module docstring), as in the cells marked at build time
    and below the spread axis.  A stagger table is read at each bounding PRF and the two are
    averaged in linear power; the "best" pick is read exactly in Doppler (module docstring).

    Parameters
    ----------
    table : Table or None
        A table from :func:`build_improvement_table`; ``None`` (no processing) gives 0 dB.
    spread_norm : array_like
        Clutter spread over the reference PRF, ``σ_s/f_r`` [1], ``>= 0``.  Above the spread
        axis the clutter is white (clamped to it); below it the clutter output is evaluated.
    doppler_norm : array_like
        Target Doppler relative to the clutter mean over the reference PRF, ``f_d/f_r`` [1],
        any finite real value (each bound's response is periodic in its own PRF).
    array : str, optional
        Read ``table.extra[array]`` instead of the I_F.  ``"coherent_gain_db"`` is read with
        the I_F's switches and steep cells; any other array bilinearly.

    Returns
    -------
    ndarray, broadcast shape of the inputs
        [dB]; NaN where an input is NaN or the Doppler is infinite.
    """
    s, d = np.broadcast_arrays(np.asarray(spread_norm, float), np.asarray(doppler_norm, float))
    if table is None:
        return np.where(np.isnan(s) | np.isnan(d), np.nan, 0.0)
    return _read(table, s, d, (array,))[0]


def improvement_and_gain_db(
    table: Table | None, spread_norm: ArrayLike, doppler_norm: ArrayLike, array: str
) -> tuple[NDArray, NDArray]:
    """``(improvement_factor_db(table, s, d), improvement_factor_db(table, s, d, array=array))``
    with the cells of the points located once: the same numbers as the two calls."""
    s, d = np.broadcast_arrays(np.asarray(spread_norm, float), np.asarray(doppler_norm, float))
    if table is None:
        none = np.where(np.isnan(s) | np.isnan(d), np.nan, 0.0)
        return none, none.copy()
    i_f, other = _read(table, s, d, (None, array))
    return i_f, other


def _read(table: Table, s: NDArray, d: NDArray, arrays: Sequence[str | None]) -> list[NDArray]:
    """The ``arrays`` (None: the I_F) of :func:`improvement_factor_db` at the points."""
    if np.any(s < 0):
        raise ValueError("spread_norm must be >= 0")
    scales = stagger_scales(table.inputs)
    if not scales:
        cells = _cells(table, s, d)
        return _read_cells(table, cells, arrays)
    # 5.1.4: the linear mean of the two bounding constant-PRF systems, each read from the
    # table in its own PRF (the products are those of staggered_improvement_factor); both
    # bounds in one pass over the points stacked
    both = _read_cells(table, _cells(table, np.stack([s * k for k in scales]),
                                     np.stack([d * k for k in scales])), arrays)
    return [_mean_power_db(x[0], x[1]) for x in both]


def _mean_power_db(a_db: NDArray, b_db: NDArray) -> NDArray:
    """``10 log10((10^(a/10) + 10^(b/10)) / 2)`` [dB], without overflow; NaN stays NaN."""
    top = np.fmax(a_db, b_db)
    gap = np.abs(a_db - b_db)
    finite = np.isfinite(gap)
    gap = np.where(finite, gap, 0.0)
    out = top + 10.0 * np.log10(0.5 * (1.0 + 10.0 ** (-gap / 10.0)))
    return np.where(finite, out, np.nan)


def _cells(table: Table, s: NDArray, d: NDArray) -> tuple[NDArray, ...]:
    """Where :func:`improvement_factor_db` reads the points ``(s, d)`` (broadcast): valid
    mask, spread, Doppler, cell indices and fractions ``(ok, s, d, i, j, tx, ty)``."""
    ax_s, ax_d = table.axes
    ok = ~np.isnan(s) & np.isfinite(d)
    s0 = 10.0 ** ax_s[0]
    x = (np.log10(np.where(ok, np.maximum(s, s0), s0)) - ax_s[0]) / (ax_s[1] - ax_s[0])
    x = np.clip(x, 0.0, len(ax_s) - 1)
    period = ax_d[-1]
    y = np.mod(np.where(ok, d, 0.0), period) / (ax_d[1] - ax_d[0])
    y = np.clip(y, 0.0, len(ax_d) - 1)
    i = np.minimum(x.astype(np.intp), len(ax_s) - 2)
    j = np.minimum(y.astype(np.intp), len(ax_d) - 2)
    return ok, s, d, i, j, x - i, y - j


#: The extra array read with the I_F's switches and steep cells (see :func:`_read_cells`).
_SEPARABLE = "coherent_gain_db"


def _read_cells(table: Table, cells: tuple[NDArray, ...],
                arrays: Sequence[str | None]) -> list[NDArray]:
    """:func:`improvement_factor_db` of each of ``arrays`` (None: the I_F) at the points
    located by :func:`_cells`; the exact responses of the steep cells evaluated once."""
    ok, s, d, i, j, tx, ty = cells
    ex = table.extra
    if table.inputs.get("pick") == "best":
        return _best_pick_db(table, cells, arrays)
    response_pick = "signal_db" in ex
    # gathers from the flattened (S, D) arrays (several times faster than 2-D indexing)
    n_d = table.values.shape[1]
    f00 = i * n_d + j
    f10 = f00 + n_d
    v, ahead, behind = (a.reshape(-1) for a in (table.values, ex["ahead_db"], ex["behind_db"]))
    # follow the filter picked at the cell's left node up to the crossover, then the one
    # picked at its right node: the jump is placed where the responses cross
    crossover = ex["crossover"][0][j]
    left = ty < crossover
    if_lo0 = np.where(left, v[f00], behind[f00])
    if_hi0 = np.where(left, ahead[f00], v[f00 + 1])
    corners = []
    for array in arrays:
        if array is None:
            lo1 = np.where(left, v[f10], behind[f10])
            hi1 = np.where(left, ahead[f10], v[f10 + 1])
            corners.append((if_lo0, if_hi0, lo1, hi1))
        elif array == _SEPARABLE and response_pick:
            # the coherent gain is the picked filter's response over its white-noise output:
            # along a Doppler cell it changes as the I_F of the same filter (any spread row),
            # so the I_F's continuations across a switch carry over by the same dB step
            g, v0, a0, b0 = ex[array][0], table.values[0], ex["ahead_db"][0], ex["behind_db"][0]
            g0, g1 = g[j], g[j + 1]
            switch = crossover < 1.0
            lo = np.where(left, g0, np.where(switch, g1 + b0[j] - v0[j + 1], g0))
            hi = np.where(left, np.where(switch, g0 + a0[j] - v0[j], g1), g1)
            corners.append((lo, hi, lo, hi))
        else:
            data = ex[array].reshape(-1)
            corners.append((data[f00], data[f00 + 1], data[f10], data[f10 + 1]))
    outs = [(1 - tx) * ((1 - ty) * lo0 + ty * hi0) + tx * ((1 - ty) * lo1 + ty * hi1)
            for lo0, hi0, lo1, hi1 in corners]
    exact_arrays = [k for k, a in enumerate(arrays) if a is None
                    or (a == _SEPARABLE and response_pick)]
    if exact_arrays and response_pick:
        # along a Doppler cell the I_F of one filter changes only through its response, so
        # |hi - lo| is that response's change: steep cells (and the cells with a null inside,
        # found at build time) are read exactly (module docstring), and so are the points
        # below the spread axis, whose clutter output is evaluated (_spread_interpolated_db)
        below = s < 10.0 ** table.axes[0][0]
        steep = np.atleast_1d(ok & ((np.abs(if_hi0 - if_lo0) > STEEP_CELL_DB)
                                    | table.attached["exact_cells"][j] | below))
        if np.any(steep):
            flat = steep.reshape(-1)
            node = np.where(left, j, j + 1)
            s_s, d_s, i_s, tx_s, node_s = (
                np.atleast_1d(a).reshape(-1)[flat] for a in (s, d, i, tx, node)
            )
            node_filter = ex["picked_filter"][0, node_s].astype(np.intp)
            p, response_db = _exact_response_db(table, d_s, node_filter)
            for k in exact_arrays:
                if arrays[k] is None:
                    c_db = _spread_interpolated_db(table, s_s, i_s, tx_s)
                    floor_db = c_db[np.arange(p.size), p]
                else:
                    floor_db = table.attached["white_db"][p]
                shape = np.shape(outs[k])
                out = np.array(outs[k], dtype=float).reshape(-1)
                out[flat] = response_db - floor_db
                outs[k] = out.reshape(shape)
    return [np.where(ok, out, np.nan) for out in outs]


_PROCESSOR_CACHE: dict[str, tuple[NDArray, NDArray, float]] = {}


def _processor_of(table: Table) -> tuple[NDArray, NDArray, float]:
    """A table's processor, cached by table key: weights (F, N) (the table's own, computed
    when it was built), filter energies (F,) and the residue ε."""
    got = _PROCESSOR_CACHE.get(table.key)
    if got is None:
        w = table.attached["weights"]
        got = (w, np.sum(np.abs(w) ** 2, axis=-1),
               df.stability_residue(table.inputs["stability_limit_db"]))
        _PROCESSOR_CACHE[table.key] = got
    return got


def _best_pick_db(table: Table, cells: tuple[NDArray, ...],
                  arrays: Sequence[str | None]) -> list[NDArray]:
    """The "best" pick's I_F (or coherent gain) [dB]: the largest over the filters of the
    exact ``|H_p|² + εE_p`` over the filter's clutter output interpolated along the spread
    axis (or its white-noise output); any other array bilinearly.

    A maximum of the filters' I_F has no single filter's response to follow across a
    Doppler cell (it changes filter wherever two I_F cross, at every spread differently), so
    every point is evaluated in Doppler: O(F N) per point, the "best" pick being an
    analysis option no scene uses.
    """
    ok, s, d, i, j, tx, ty = cells
    shape = np.shape(ok)
    flat_ok = np.atleast_1d(ok).reshape(-1)
    s_s, d_s, i_s, tx_s = (np.atleast_1d(a).reshape(-1)[flat_ok] for a in (s, d, i, tx))
    w, energy, eps = _processor_of(table)
    n = np.arange(w.shape[-1])
    steer = np.exp(-2j * np.pi * np.mod(d_s[:, None] * n, 1.0))
    signal_db = 10.0 * np.log10(np.abs(matmul_one_thread(steer, np.conj(w).T)) ** 2
                                  + eps * energy)  # (P, F)
    outs = []
    for array in arrays:
        if array is None:
            best = np.max(signal_db - _spread_interpolated_db(table, s_s, i_s, tx_s), axis=1)
        elif array == _SEPARABLE:
            best = np.max(signal_db - table.attached["white_db"], axis=1)
        else:
            data = table.extra[array]
            out = ((1 - tx) * ((1 - ty) * data[i, j] + ty * data[i, j + 1])
                   + tx * ((1 - ty) * data[i + 1, j] + ty * data[i + 1, j + 1]))
            outs.append(np.where(ok, out, np.nan))
            continue
        out = np.full(flat_ok.shape, np.nan)
        out[flat_ok] = best
        outs.append(out.reshape(shape))
    return outs


def _spread_interpolated_db(table: Table, s: NDArray, i: NDArray, tx: NDArray) -> NDArray:
    """Every filter's clutter output ``C_p(σ) + εE_p`` [dB] at the points, (P, F):
    interpolated along the spread axis from ``attached["clutter_db"]``, and evaluated by
    :func:`shipradar.sensors.doppler_filters.clutter_output_power` below the axis, where the
    first row would hold a DFT bank's exact nulls at zero Doppler 1.6 dB too high (and any
    processor's too high for a stability limit above 100 dB).  Above the axis the last row
    is white (module docstring) and is kept."""
    c_db = table.attached["clutter_db"]
    out: NDArray = (1 - tx)[:, None] * c_db[i] + tx[:, None] * c_db[i + 1]
    below = np.flatnonzero(s < 10.0 ** table.axes[0][0])
    if below.size:
        w, energy, eps = _processor_of(table)
        exact = df.clutter_output_power(w, s[below]) + (eps * energy)[:, None]  # (F, B)
        out[below] = 10.0 * np.log10(exact.T)
    return out


def _exact_response_db(table: Table, doppler: NDArray, node_filter: NDArray
                       ) -> tuple[NDArray, NDArray]:
    """The filter ``p`` picked at each Doppler by the table's rule and its exact
    ``|H_p|² + εE_p`` [dB], for the steep cells; the I_F (or coherent gain) is this over the
    picked filter's clutter output ``attached["clutter_db"]`` interpolated along the spread
    axis (or its white-noise output ``attached["white_db"]``).

    The responses of every filter are evaluated at the Doppler, and the filter is picked as
    the grid was: largest response per unit energy, ties as in the module docstring.
    """
    w, energy, eps = _processor_of(table)
    n = np.arange(w.shape[-1])
    steer = np.exp(-2j * np.pi * np.mod(doppler[:, None] * n, 1.0))
    # one BLAS thread: a revolution's few thousand points (shipradar.tables.blas)
    response = np.abs(matmul_one_thread(steer, np.conj(w).T)) ** 2  # (points, filters)
    # the table's rule on the table's quantity, |H|²/E + ε (adding ε turns rounding-level
    # responses at a common null, an MTI's blind speed, into ties); ties within rounding
    # (symmetric points between two filters) go to the filter the table picked at the cell's
    # node on that side, else to the lowest index, so that grid nodes read back exactly
    score = response / energy + eps
    tied = score >= score.max(axis=1, keepdims=True) * (1.0 - TIE_RELATIVE)
    rows = np.arange(doppler.size)
    p = np.where(tied[rows, node_filter], node_filter, np.argmax(tied, axis=1))
    return p, 10.0 * np.log10(response[rows, p] + eps * energy[p])
