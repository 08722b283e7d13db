"""False alarms: counts per scan or sector and their positions, seed chapter 7.

Noise-induced false alarms, seed 7.1, [90]-[93].  The count generator and the position
generator are generic: the sea-clutter part (7.2, [94]-[96]) draws per sector with the same
functions from its own η = N_cells P_fac.

Choices where the seed is silent or wrong
-----------------------------------------
* **[90] units (SPEC §4 item 7).**  The seed's 360 R_inst/(θ_b C_R) takes θ_b in degrees;
  here θ_b is in radians: N_cells = 2π R_inst / (θ_b C_R) (beam positions per revolution
  times range cells).
* **[90] against [68]-[72] (erratum, issue 23 item 5a).**  The seed draws η = N_cells P_fa
  per scan over the N_cells = 2π R_inst/(θ_b C_R) cells of the instrumented disc, while
  [68]-[72] set P_fa for 0.69 false alarms per t_fa over N_ch N_rc decisions per sweep:
  η t_fa/t_scan was 0.69 R_inst/(N_ch N_rc C_R), 0.46-1.15 on the shipped radars instead
  of 1.  The count here is over the decisions that [68]-[72] count
  (:func:`noise_false_alarms_per_scan`): N_ch channels in each of the N_rep =
  min(N_rc, R_inst/C_R) reported gates of each of the 2π/θ_b beam positions, every channel's
  crossing a plot of its own; with P_fa = 1/n'
  (:func:`shipradar.sensors.detection.pfa_from_false_alarm_time`) η = t_scan/t_fa exactly, whatever
  the radar.  The positions stay uniform over the instrumented disc (R_inst > c/(2 f_r): the N_rc
  gates' crossings are reported over it, as the targets are, the ambiguity resolution not being
  modelled). :func:`resolution_cells` keeps [90]'s geometric count of the disc's cells.
* **Sea-clutter counts and P_fa.**  A sector's η = P_fac × cells counts one decision per
  cell, not N_ch: a spike is one return of one cell, seen alike by every channel, unlike
  noise, whose channels cross independently.  The P_fac of [94]-[95] depends on P_fa
  through the threshold: P_fa = 1/n' instead of 0.69/n' (shipped radars: ×1.45) lowers
  Y/σ0 = (ln(1/P_fa)/ln 2)^a_min by 2 % (0.1 dB): on the demo scene the clutter false
  alarms rise by 3.4 % (388.3 → 401.4 per scan at K_clutter = 1; ``weibull_median``:
  33.7 → 35.8), per sector by 2-19 % (most where P_fac is smallest), and the HP default
  P_facmax by 5 % (docs/stability.md §5a).
* **[91] (SPEC §4 item 1).**  The normal density lacks its square; the density used is
  exp(-(x-η)²/(2η)) / sqrt(2πη), mean and variance η.
* **Sampling.**  Every regime is drawn by the seed's inverse-CDF ("innovation filter",
  Ref. 26) method with exactly one uniform U per element, whatever the regime, so that a
  run's random stream does not depend on η:
  Bernoulli [92]: n = 1 if U < η (the seed writes ≤; U ∈ [0, 1) so both have P = η, and
  < gives 0 at η = 0);
  Poisson [93]: the smallest m with CDF(m) ≥ U (exact);
  normal [91]: the normal quantile η + sqrt(η) Φ⁻¹(U) rounded to the nearest integer
  (continuity correction) and floored at 0, so counts are non-negative integers.
* **Positions.**  Uniform in range and in azimuth, as the seed says (7.1 and Fig. 8a: "the
  false alarms are uniformly distributed in range"), not uniform in area: each range cell
  of a sector is equally likely to hold a false alarm, as each has the same P_fa.

Sea-clutter-induced false alarms, seed 7.2, [94]-[96]
-----------------------------------------------------
* **[95] (SPEC §4 item 6).**  Y_R is in dB and [94] takes the linear ratio Y/σ0.  The seed's
  1.6 dB is -10 log10(ln 2) = 1.592 dB exactly, so the threshold over the mean is
  Y/σ0 = (ln(1/P_fa) / ln 2)^a_min (:func:`clutter_threshold_ratio`), and at a = a_min [94]
  returns P_fa exactly (the threshold's definition).  As the seed says, the mean σ0 stands
  in for the median on both sides of the ratio, so σ0 cancels: in VP P_fac depends on a only
  (and a on σ0 through [32]).
* **Cut-off.**  P_fac = 0 where a ≤ a_min or P_sc < 2 N0' (the seed: the CFAR is fully
  efficient there).  Just above a_min [94] gives ≈ P_fa: the jump to 0 is of order P_fa.
* **[96].**  K_clutter ≥ 1 divides every P_fac, VP and HP (also a user-given P_facmax), so
  it is the user's one knob on the global clutter false-alarm density.
* **HP heuristic.**  P_facmax up to the 3° grazing range R_ref, then a raised-cosine taper
  P_facmax (1 + cos πt)/2, t = (R - R_ref)/(R_end - R_ref), to 0 at R_end, the first range
  beyond R_ref where a reaches a_min or P_sc falls to 2 N0' (:func:`hp_clutter_fa_probability`):
  smooth (zero slope at both ends) and, as 7.2 asks, flatter in range than VP.
  P_facmax is the user's, or [94]-[95] at a = 3 (:func:`default_p_fac_max`).
* **Spike S/I.**  A clutter false alarm is a Weibull return x above the threshold Y; its
  size is drawn from the conditional tail, (x/σ0)^(1/a) = (Y/σ0)^(1/a) + E/ln 2 with
  E ~ Exp(1) (exact inverse CDF of [94] given x > Y), and the plot reports the excess over
  the mean clutter, S/I = x/σ0 - 1 (the noise plots' "excess over the mean" convention).
* **Median-consistent variant** (``model="weibull_median"``, the scenario's
  ``fidelity.clutter_fa_model``; the default ``"seed"`` is the seed's formula above).  The
  seed's mean-for-median substitution makes σ0 cancel, so P_fac depends on a alone and is
  9-14 times what a Weibull sea of mean σ0 gives against a Rayleigh CFAR at a = 1.5-3.  The
  variant keeps [94] and [95]'s intent and corrects both sides: a cell-averaging CFAR
  estimates the *mean*, so the threshold that gives P_fa on clutter of skewness a_min and
  mean σ0 is Y/σ0 = ln(1/P_fa)^a_min / Γ(1+a_min) (= ln(1/P_fa) for Rayleigh, a_min = 1);
  and [94] uses the cell's true Weibull median, [30] in linear form
  σ_median/σ0 = (ln 2)^a / Γ(1+a) (:func:`weibull_median_ratio`).  Hence
  P_fac = exp(-(ln(1/P_fa)^a_min Γ(1+a)/Γ(1+a_min))^(1/a)): P_fa at a = a_min as in the
  seed, and never above σ0/Y (Markov's inequality: 1/ln(1/P_fa) for a_min = 1), so it
  rises with a to a maximum (a ≈ 4 at P_fa = 3.6e-8, P_fac = 0.011) and then falls back to
  0 as a → ∞, whereas the seed's form tends to 1/2.  The same median is used for the
  spike's S/I and for the HP default P_facmax (the variant at a = 3).
"""

from __future__ import annotations

import copy
import functools
import threading
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import special

from shipradar.sensors import plot_columns as pc
from shipradar.sensors.detection import (
    LN2_SEED,
    N_CHANNELS,
    Interference,
    reported_range_cells,
)
from shipradar.sensors.geometry import K_FACTOR
from shipradar.sensors.measurement import SIGMAS_PER_ERROR, expected_errors
from shipradar.sensors.sea_clutter import slant_range_m

# array types of the private helpers' signatures
_Floats = NDArray[np.float64]
_Ints = NDArray[np.int64]

#: [91]: the normal approximation is used for η ≥ 9.
NORMAL_MIN_ETA = 9.0
TWO_PI = 2.0 * np.pi


def _mod_two_pi(x: NDArray[np.float64], out: NDArray[np.float64] | None = None
                ) -> NDArray[np.float64]:
    """``np.mod(x, TWO_PI)`` bit for bit, without np.mod's fmod (~16 ns an element) when every
    ``x`` is in [-2π, 4π) (the false alarms' azimuths and their offsets from the beam): there
    fmod is ``x`` itself or ``x - 2π`` (exact, Sterbenz), and numpy adds 2π to a negative
    one; a zero is +0.0 either way.  Anything else (NaN included) goes to np.mod.  Angles in
    [rad]; as with np.mod, a tiny negative ``x`` can give exactly 2π (unlike
    :func:`shipradar.sensors.measurement.wrap_azimuth`, which maps it to 0).  ``out`` (may be
    ``x``): where to write it, as a ufunc's."""
    if x.size == 0:
        return np.mod(x, TWO_PI, out=out)
    lo, hi = x.min(), x.max()
    if not (lo >= -TWO_PI and hi < 2.0 * TWO_PI):
        return np.mod(x, TWO_PI, out=out)
    # the shift 2π, 0.0 (+0.0: x + 0.0 turns -0.0 into +0.0, as np.mod) or -2π; a mask times
    # 2π is 7x cheaper than np.where(x < 0, 2π, 0.0) on a random mask
    shift = (x < 0.0) * TWO_PI
    if hi >= TWO_PI:
        shift[x >= TWO_PI] = -TWO_PI
    wrapped: NDArray[np.float64] = np.add(x, shift, out=out)
    return wrapped


def resolution_cells(
    instrumented_range_m: ArrayLike, beamwidth_rad: ArrayLike, range_cell_m: ArrayLike
) -> NDArray[np.float64]:
    """Resolution cells in the instrumented domain, N_cells = 2π R_inst/(θ_b C_R), seed [90].

    The geometry of [90].  The noise false-alarm count is not N_cells P_fa (the seed's
    letter) but :func:`noise_false_alarms_per_scan` (erratum, module notes).

    Parameters
    ----------
    instrumented_range_m : array_like
        Instrumented range R_inst [m], ≥ 0.
    beamwidth_rad : array_like
        Horizontal 3 dB beamwidth θ_b [rad] (the seed's [90] has degrees: SPEC §4 item 7).
    range_cell_m : array_like
        Range cell C_R [m], > 0.

    Returns
    -------
    ndarray
        N_cells [-] (not rounded; 0 for R_inst = 0).

    Raises
    ------
    ValueError
        If θ_b or C_R is not positive, or R_inst is negative.
    """
    r = np.asarray(instrumented_range_m, dtype=np.float64)
    theta = np.asarray(beamwidth_rad, dtype=np.float64)
    c_r = np.asarray(range_cell_m, dtype=np.float64)
    if np.any(~(r >= 0)) or np.any(~(theta > 0)) or np.any(~(c_r > 0)):
        raise ValueError(
            "resolution_cells: instrumented_range_m must be >= 0, beamwidth_rad and "
            "range_cell_m > 0"
        )
    return TWO_PI * r / (theta * c_r)


def noise_false_alarms_per_scan(
    pfa: ArrayLike,
    beamwidth_rad: ArrayLike,
    prf_hz: ArrayLike,
    pulse_width_s: ArrayLike,
    instrumented_range_m: ArrayLike,
    n_channels: ArrayLike = N_CHANNELS,
) -> NDArray[np.float64]:
    """Expected noise false alarms per revolution, η = N_ch N_rep (2π/θ_b) P_fa, seed [90].

    The decisions that [68]-[72] count, over one revolution: N_ch channels (each crossing a
    plot) in each of the N_rep = min(N_rc, R_inst/C_R) reported range gates
    (:func:`shipradar.sensors.detection.reported_range_cells`) of each of the 2π/θ_b beam positions.
    Erratum to [90] (issue 23 item 5a, module notes): the seed's N_cells P_fa, with
    N_cells = 2π R_inst/(θ_b C_R) (:func:`resolution_cells`), leaves out N_ch and counts the
    disc's cells instead of the gates decided.  With P_fa of
    :func:`shipradar.sensors.detection.pfa_from_false_alarm_time` for the same R_inst, η =
    t_scan/t_fa.

    Parameters
    ----------
    pfa : array_like
        P_fa per decision [-], in [0, 1].
    beamwidth_rad : array_like
        Horizontal 3 dB beamwidth θ_b [rad], > 0.
    prf_hz : array_like
        Pulse repetition frequency f_r [Hz].
    pulse_width_s : array_like
        Compressed pulse length τ' [s].
    instrumented_range_m : array_like
        R_inst [m], > 0.
    n_channels : array_like, optional
        Decision channels per cell N_ch [-].

    Returns
    -------
    ndarray
        η [-] per revolution.

    Raises
    ------
    ValueError
        If P_fa ∉ [0, 1], θ_b or N_ch is not positive, or as
        :func:`shipradar.sensors.detection.reported_range_cells`.
    """
    p = np.asarray(pfa, dtype=np.float64)
    theta = np.asarray(beamwidth_rad, dtype=np.float64)
    n_ch = np.asarray(n_channels, dtype=np.float64)
    if np.any(~((p >= 0) & (p <= 1))) or np.any(~(theta > 0)) or np.any(~(n_ch > 0)):
        raise ValueError("noise_false_alarms_per_scan: need 0 <= pfa <= 1, beamwidth_rad > 0 "
                         "and n_channels > 0")
    n_rep = reported_range_cells(prf_hz, pulse_width_s, instrumented_range_m)
    return n_ch * n_rep * (TWO_PI / theta) * p


def bernoulli_limit(n_channels: ArrayLike = N_CHANNELS) -> NDArray[np.float64]:
    """η below which the count is Bernoulli, 0.69 / (2 N_ch), seed [92].

    Parameters
    ----------
    n_channels : array_like
        Decision channels per cell N_ch [-].

    Returns
    -------
    ndarray
        The limit [-] (0.1725 for N_ch = 2).
    """
    return LN2_SEED / (2.0 * np.asarray(n_channels, dtype=np.float64))


def false_alarm_count(
    eta: ArrayLike,
    n_channels: ArrayLike,
    rng: np.random.Generator,
    size: int | tuple[int, ...] | None = None,
) -> NDArray[np.int64]:
    """Number of false alarms in a scan or sector with mean η, seed [91]-[93].

    Parameters
    ----------
    eta : array_like
        Expected number of false alarms η = N_cells P_fa [-], ≥ 0 (one per sector, say).
    n_channels : array_like
        Decision channels per cell N_ch [-] (sets the Bernoulli limit 0.69/(2 N_ch)).
    rng : numpy.random.Generator
        Source of randomness: one uniform per element of the output.
    size : int or tuple of int, optional
        Output shape; ``eta`` must broadcast to it.  Default: the shape of ``eta``.

    Returns
    -------
    ndarray of int64
        Counts ≥ 0: Bernoulli (P(1) = η) for η < 0.69/(2 N_ch) [92]; Poisson(η) for
        0.69/(2 N_ch) ≤ η < 9 [93]; normal N(η, η) rounded and floored at 0 for η ≥ 9 [91]
        with the squared exponent (SPEC §4 item 1).  A 0-d array for scalar ``eta``.

    Raises
    ------
    ValueError
        If η is negative or not finite, or N_ch ≤ 0.
    """
    eta_a = np.asarray(eta, dtype=np.float64)
    n_ch = np.asarray(n_channels, dtype=np.float64)
    if np.any(~((eta_a >= 0) & np.isfinite(eta_a))):
        raise ValueError("false_alarm_count: eta must be finite and >= 0")
    if np.any(~(n_ch > 0)):
        raise ValueError("false_alarm_count: n_channels must be > 0")
    shape = eta_a.shape if size is None else (size if isinstance(size, tuple) else (size,))
    if shape == () and n_ch.ndim == 0:
        # one count (the noise false alarms of a scan): the same draw and arithmetic as
        # below, without the array machinery that costs ~50 µs per call
        e, u0 = float(eta_a), float(rng.random())
        if e < float(bernoulli_limit(n_ch)):
            c = int(u0 < e)
        elif e >= NORMAL_MIN_ETA:
            c = int(np.rint(max(e + np.sqrt(e) * special.ndtri(u0), 0.0)))
        else:
            c = int(poisson_quantile(np.array([u0]), np.array([e]))[0])
        return np.asarray(c, dtype=np.int64)
    eta_b = np.broadcast_to(eta_a, shape)
    limit = np.broadcast_to(bernoulli_limit(n_ch), shape)
    u = rng.random(shape)
    count = np.zeros(shape, dtype=np.int64)
    bern = eta_b < limit
    count[bern] = u[bern] < eta_b[bern]
    normal = (eta_b >= NORMAL_MIN_ETA) & ~bern
    if np.any(normal):
        e_n = eta_b[normal]
        # u = 0 gives -inf, floored to 0 below (probability 2^-53)
        x = e_n + np.sqrt(e_n) * special.ndtri(u[normal])
        count[normal] = np.rint(np.maximum(x, 0.0)).astype(np.int64)
    pois = ~bern & ~normal
    if np.any(pois):
        count[pois] = poisson_quantile(u[pois], eta_b[pois])
    return count


def poisson_cdf_table(eta: ArrayLike) -> NDArray[np.float64]:
    """Poisson CDF of each mean on k = 0, 1, ..., K, one row per mean (for [93]).

    Parameters
    ----------
    eta : array_like
        Poisson means [-], 0 ≤ η < :data:`NORMAL_MIN_ETA` (the [93] regime).

    Returns
    -------
    ndarray, shape (n, K + 1)
        ``special.pdtr(k, η)``; K = ⌈η_max + 12 sqrt(η_max)⌉ + 20, beyond which the CDF is 1
        to double precision (its last column is set to 1 so that every U < 1 finds a k).
    """
    e = np.asarray(eta, dtype=np.float64).ravel()
    top = float(e.max()) if e.size else 0.0
    k = np.arange(int(np.ceil(top + 12.0 * np.sqrt(top))) + 21, dtype=np.float64)
    table: NDArray[np.float64] = special.pdtr(k[None, :], e[:, None])  # scipy is untyped
    table[:, -1] = 1.0
    return table


def poisson_quantile(
    u: ArrayLike, eta: ArrayLike | None = None, cdf: NDArray[np.float64] | None = None
) -> NDArray[np.int64]:
    """Smallest m with Poisson CDF(m; η) ≥ U: the exact inverse CDF of [93].

    The same counts as ``scipy.stats.poisson.ppf(U, η)`` (checked on 2×10^6 draws and by
    ``tests/test_false_alarms.py``) at a small fraction of its cost: the CDF rows are
    formed once (:func:`poisson_cdf_table`, reusable when the means do not change, as for a
    clutter map's sectors) and the count is the number of CDF values below U.

    Parameters
    ----------
    u : array_like
        Uniforms in [0, 1), one per count.
    eta : array_like, optional
        Poisson means [-], as many as ``u`` (ignored when ``cdf`` is given).
    cdf : ndarray, optional
        :func:`poisson_cdf_table` of the means, one row per element of ``u``.

    Returns
    -------
    ndarray of int64
        Counts ≥ 0 (0 at U = 0).
    """
    u = np.asarray(u, dtype=np.float64).ravel()
    if cdf is None:
        if eta is None:
            raise ValueError("poisson_quantile needs the means eta or their CDF table cdf")
        cdf = poisson_cdf_table(eta)
    counts: NDArray[np.int64] = np.count_nonzero(cdf < u[:, None], axis=1).astype(np.int64)
    return counts


def uniform_positions(
    n: ArrayLike,
    r_min_m: ArrayLike,
    r_max_m: ArrayLike,
    az_min_rad: ArrayLike,
    az_max_rad: ArrayLike,
    rng: np.random.Generator,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Positions uniform in range and in azimuth, seed 7.1 (last step of [90]-[93]).

    Parameters
    ----------
    n : int or array_like of int
        Number of positions; an array gives one count per sector, the bounds then
        broadcast against it.
    r_min_m, r_max_m : array_like
        Range interval [m], 0 ≤ r_min ≤ r_max.
    az_min_rad, az_max_rad : array_like
        Azimuth interval [rad], az_min ≤ az_max ≤ az_min + 2π (unwrapped: a sector across
        north is e.g. 350° to 370°).
    rng : numpy.random.Generator
        Source of randomness: all ranges are drawn first, then all azimuths.

    Returns
    -------
    range_m : ndarray
        Ranges [m], uniform on [r_min, r_max) (uniform in R, not in area).
    azimuth_rad : ndarray
        Azimuths [rad], uniform on the sector, wrapped to [0, 2π).
        Both flat, sector after sector, of length sum(n).
    """
    counts = np.asarray(n)
    if counts.dtype.kind not in "iu" and not np.all(np.mod(counts, 1) == 0):
        raise ValueError("uniform_positions: n must be integers")
    counts = counts.astype(np.int64)
    if np.any(counts < 0):
        raise ValueError("uniform_positions: n must be >= 0")
    if counts.ndim == 0 and all(np.ndim(v) == 0 for v in (r_min_m, r_max_m, az_min_rad,
                                                           az_max_rad)):
        # one interval (a whole scan's noise false alarms): the same draws and arithmetic
        # as the general path below, without broadcasting and repeating
        r_lo, r_hi, az_lo, az_hi = (float(np.asarray(v, dtype=np.float64))
                                    for v in (r_min_m, r_max_m, az_min_rad, az_max_rad))
        if not (0 <= r_lo <= r_hi and az_lo <= az_hi <= az_lo + TWO_PI):
            raise ValueError(
                "uniform_positions: need 0 <= r_min_m <= r_max_m and "
                "az_min_rad <= az_max_rad <= az_min_rad + 2 pi"
            )
        total = int(counts)
        rng_r = r_lo + (r_hi - r_lo) * rng.random(total)
        az = np.mod(az_lo + (az_hi - az_lo) * rng.random(total), TWO_PI)
        return rng_r, np.where(az >= TWO_PI, 0.0, az)
    c, r0, r1, a0, a1 = np.broadcast_arrays(
        counts,
        np.asarray(r_min_m, dtype=np.float64),
        np.asarray(r_max_m, dtype=np.float64),
        np.asarray(az_min_rad, dtype=np.float64),
        np.asarray(az_max_rad, dtype=np.float64),
    )
    if np.any(~((r0 >= 0) & (r1 >= r0))) or np.any(~((a1 >= a0) & (a1 - a0 <= TWO_PI))):
        raise ValueError(
            "uniform_positions: need 0 <= r_min_m <= r_max_m and "
            "az_min_rad <= az_max_rad <= az_min_rad + 2 pi"
        )
    c = c.ravel()
    total = int(c.sum())
    r0, r1, a0, a1 = (np.repeat(v.ravel(), c) for v in (r0, r1, a0, a1))
    rng_r = r0 + (r1 - r0) * rng.random(total)
    az = a0 + (a1 - a0) * rng.random(total)
    az = np.mod(az, TWO_PI)
    return rng_r, np.where(az >= TWO_PI, 0.0, az)


# --------------------------------------------------------------------------- sea clutter 7.2
#: 1.6 dB of [95] written exactly: -10 log10(ln 2) = 1.592 dB (SPEC §4 item 6).
LN2_DB = float(-10.0 * np.log10(np.log(2.0)))
#: 7.2: P_facmax for HP defaults to the VP value at this Weibull parameter.
HP_DEFAULT_A = 3.0
#: 7.2: clutter below this many N0' behaves like noise (P_fac = 0).
NOISE_LIKE_FACTOR = 2.0
#: The P_fac models of [94]-[95]: the seed's (mean σ0 for the median) and the
#: median-consistent one (threshold on the mean, median from [30]).
ClutterFaModel = Literal["seed", "weibull_median"]
CLUTTER_FA_MODELS: tuple[ClutterFaModel, ...] = ("seed", "weibull_median")
DEFAULT_CLUTTER_FA_MODEL: ClutterFaModel = "seed"


def _model_checked(model: str) -> ClutterFaModel:
    if model not in CLUTTER_FA_MODELS:
        raise ValueError(f"clutter false-alarm model must be one of {CLUTTER_FA_MODELS}, "
                         f"not {model!r}")
    return model


def log_weibull_median_ratio(a: ArrayLike) -> NDArray[np.float64]:
    """ln(σ_median/σ0) = a ln(ln 2) - ln Γ(1+a), seed [30] in natural-log linear form.

    Parameters
    ----------
    a : array_like
        Weibull parameter a [-] > 0 (inf allowed: -inf).

    Returns
    -------
    ndarray
        ln of the median-to-mean power ratio [-] (< 0; ln ln 2 at a = 1), finite for
        finite a: no overflow where (ln 2)^a/Γ(1+a) itself underflows.
    """
    a = np.asarray(a, dtype=np.float64)
    if np.any(~(a > 0.0)):
        raise ValueError("Weibull parameter a must be > 0")
    with np.errstate(invalid="ignore"):
        out = a * np.log(np.log(2.0)) - special.gammaln(1.0 + a)
    return np.where(np.isinf(a), -np.inf, out)


def weibull_median_ratio(a: ArrayLike) -> NDArray[np.float64]:
    """Median-to-mean power ratio of Weibull clutter, σ_median/σ0 = (ln 2)^a / Γ(1+a), [30].

    [30] in dB is σ0^50 = σ0 - 1.6 a - 10 log10 Γ(1+a) with 1.6 = -10 log10(ln 2); it follows
    from [94]: if P(x > t) = exp(-ln 2 (t/σ_median)^(1/a)), then x = σ_median (E/ln 2)^a with
    E ~ Exp(1), whose mean is σ_median Γ(1+a)/(ln 2)^a.

    Parameters
    ----------
    a : array_like
        Weibull parameter a [-] > 0.

    Returns
    -------
    ndarray
        σ_median/σ0 [-] in (0, 1) for a > 0 (ln 2 at a = 1, 0.0555 at a = 3); underflows to 0
        quietly for very large a.
    """
    with np.errstate(under="ignore"):
        return np.exp(log_weibull_median_ratio(a))


def _pfa_checked(pfa: ArrayLike) -> NDArray[np.float64]:
    p = np.asarray(pfa, dtype=np.float64)
    if np.any(~((p > 0.0) & (p <= 1.0))):
        raise ValueError("P_fa must be in (0, 1]")
    return p


def clutter_threshold_db(pfa: ArrayLike, a_min: ArrayLike = 1.0) -> NDArray[np.float64]:
    """Threshold over the mean clutter, Y_R - σ0 = a_min (10 log10 ln(1/P_fa) + 1.6), seed [95].

    Parameters
    ----------
    pfa : array_like
        Required noise false-alarm probability per cell P_fa [-], in (0, 1].
    a_min : array_like, optional
        a_min [-] (1: the CFAR threshold of Rayleigh clutter).

    Returns
    -------
    ndarray
        Y_R - σ0 [dB] (SPEC §4 item 6: Y_R in dB, 1.6 = -10 log10(ln 2) exactly).
        -inf at P_fa = 1 (threshold 0).
    """
    p = _pfa_checked(pfa)
    lnp = -np.log(p)
    with np.errstate(divide="ignore"):
        return np.asarray(a_min, dtype=np.float64) * (10.0 * np.log10(lnp) + LN2_DB)


def clutter_threshold_ratio(
    pfa: ArrayLike, a_min: ArrayLike = 1.0, model: ClutterFaModel = DEFAULT_CLUTTER_FA_MODEL
) -> NDArray[np.float64]:
    """Linear CFAR threshold over the mean clutter power Y/σ0, seed [95].

    Parameters
    ----------
    pfa : array_like
        P_fa [-], in (0, 1].
    a_min : array_like, optional
        a_min [-] > 0.
    model : {"seed", "weibull_median"}, optional
        "seed": [95] in linear form with the mean σ0 standing for the median,
        Y/σ0 = (ln(1/P_fa)/ln 2)^a_min (10^(:func:`clutter_threshold_db`/10)).
        "weibull_median": the threshold giving P_fa on clutter of skewness a_min and mean
        σ0, i.e. [95] over the true median of [30],
        Y/σ0 = (σ_median(a_min)/σ0) (ln(1/P_fa)/ln 2)^a_min = ln(1/P_fa)^a_min/Γ(1+a_min)
        (the cell-averaging Rayleigh CFAR, Y = σ0 ln(1/P_fa), for a_min = 1).

    Returns
    -------
    ndarray
        Y/σ0 [-] ≥ 0 (0 at P_fa = 1).
    """
    p = _pfa_checked(pfa)
    a_min = np.asarray(a_min, dtype=np.float64)
    if _model_checked(model) == "seed":
        seed_ratio: NDArray[np.float64] = (-np.log(p) / np.log(2.0)) ** a_min
        return seed_ratio
    if np.any(~(a_min > 0.0)):
        raise ValueError("a_min must be > 0")
    ratio: _Floats = (-np.log(p)) ** a_min / special.gamma(1.0 + a_min)  # scipy is untyped
    return ratio


def weibull_exceedance(threshold_ratio: ArrayLike, a: ArrayLike) -> NDArray[np.float64]:
    """Probability that Weibull clutter exceeds Y, exp(-ln 2 (Y/σ0)^(1/a)), seed [94].

    Parameters
    ----------
    threshold_ratio : array_like
        Y/σ0 [-] ≥ 0, linear (the mean σ0 stands for the median, as in the seed).
    a : array_like
        Weibull parameter a [-] > 0 (1: Rayleigh clutter, exponential power).

    Returns
    -------
    ndarray
        P_Weibull(Y, a) in [0, 1]: 1 at Y = 0, → 0 as Y → ∞; underflows to 0 quietly.
    """
    y = np.asarray(threshold_ratio, dtype=np.float64)
    a = np.asarray(a, dtype=np.float64)
    if np.any(~(y >= 0.0)) or np.any(~(a > 0.0)):
        raise ValueError("weibull_exceedance: need Y/σ0 >= 0 and a > 0")
    with np.errstate(under="ignore"):
        exceedance: NDArray[np.float64] = np.exp(-np.log(2.0) * y ** (1.0 / a))
    return exceedance


def weibull_median_exceedance(
    a: ArrayLike, pfa: ArrayLike, a_min: ArrayLike = 1.0
) -> NDArray[np.float64]:
    """[94]-[95] with the true Weibull median: P(x > Y) for clutter of mean σ0 and parameter a.

    The threshold is the one that gives P_fa on clutter of parameter a_min and mean σ0,
    Y/σ0 = L^a_min/Γ(1+a_min) with L = ln(1/P_fa) (:func:`clutter_threshold_ratio`), and [94]
    is taken over the cell's median σ_median = σ0 (ln 2)^a/Γ(1+a) ([30]):

        P = exp(-ln 2 (Y/σ_median)^(1/a)) = exp(-(L^a_min Γ(1+a)/Γ(1+a_min))^(1/a)).

    σ0 cancels again, but now from the two true statistics rather than by substitution.
    Evaluated as exp(-exp((a_min ln L - ln Γ(1+a_min) + ln Γ(1+a))/a)) so that nothing
    overflows for large a or a_min.

    Parameters
    ----------
    a : array_like
        Weibull parameter of the cell [-] > 0 (inf allowed: the limit).
    pfa : array_like
        P_fa [-], in (0, 1].
    a_min : array_like, optional
        a_min [-] > 0.

    Returns
    -------
    ndarray
        P in [0, 1]: P_fa at a = a_min; rising with a up to a maximum (a ≈ 4, P = 0.011 at
        P_fa = 3.6e-8) and falling back to 0 as a → ∞ (Markov: P ≤ σ0/Y); 1 at P_fa = 1
        (Y = 0).  No cut-off at a ≤ a_min here (:func:`clutter_fa_probability` applies it).
    """
    p = _pfa_checked(pfa)
    a = np.asarray(a, dtype=np.float64)
    a_min = np.asarray(a_min, dtype=np.float64)
    if np.any(~(a > 0.0)) or np.any(~(a_min > 0.0)):
        raise ValueError("weibull_median_exceedance: need a > 0 and a_min > 0")
    with np.errstate(divide="ignore", over="ignore", under="ignore", invalid="ignore"):
        ln_l = np.log(-np.log(p))  # -inf at P_fa = 1
        log_ratio = (a_min * ln_l - special.gammaln(1.0 + a_min)
                     + special.gammaln(1.0 + a)) / a
        out = np.exp(-np.exp(log_ratio))
    # Y = 0 (P_fa = 1): every return exceeds it, whatever a (also a = inf, where the
    # formula is -inf + inf); otherwise a = inf: Γ(1+a)^(1/a) ~ a/e → ∞, so P → 0
    return np.where(ln_l == -np.inf, 1.0, np.where(np.isinf(a), 0.0, out))


def clutter_fa_probability(
    a: ArrayLike,
    pfa: ArrayLike,
    a_min: ArrayLike = 1.0,
    k_clutter: ArrayLike = 1.0,
    clutter_power_w: ArrayLike | None = None,
    noise_power_w: ArrayLike | None = None,
    *,
    model: ClutterFaModel = DEFAULT_CLUTTER_FA_MODEL,
) -> NDArray[np.float64]:
    """Sea-clutter false-alarm probability per cell for VP, seed [94]-[96].

    P_fac = P_Weibull(Y_R, a) / K_clutter with Y_R of [95]; 0 where a ≤ a_min or, when the
    powers are given, where P_sc < 2 N0' (seed 7.2: clutter then behaves like noise and the
    CFAR is fully efficient).

    ``model="seed"`` (default): as the seed, the mean σ0 stands for the median on both sides
    of [94]-[95], P_Weibull = exp(-ln 2 (ln(1/P_fa)/ln 2)^(a_min/a)) (:func:`weibull_exceedance`
    of :func:`clutter_threshold_ratio`); it tends to 1/2 as a → ∞.
    ``model="weibull_median"``: threshold on the mean and the true median of [30],
    P_Weibull = exp(-(ln(1/P_fa)^a_min Γ(1+a)/Γ(1+a_min))^(1/a))
    (:func:`weibull_median_exceedance`): 8.6 / 11 / 12.6 / 14.4 times less than the seed's at
    a = 1.5 / 2 / 2.5 / 3 (P_fa = 3.6e-8, a_min = 1).  Both give P_fa at a = a_min.

    Parameters
    ----------
    a : array_like
        Weibull parameter of the cell [-] (the clutter map's ``weibull_a``), > 0.
    pfa : array_like
        P_fa [-], in (0, 1].
    a_min : array_like, optional
        a_min [-], > 0.
    k_clutter : array_like, optional
        K_clutter [-] ≥ 1 ([96]).
    clutter_power_w, noise_power_w : array_like, optional
        Mean sea-clutter power P_sc and noise power N0' [W].
    model : {"seed", "weibull_median"}, optional
        The [94]-[95] reading (the scenario's ``fidelity.clutter_fa_model``).

    Returns
    -------
    ndarray
        P_fac in [0, 1/K_clutter].
    """
    k = np.asarray(k_clutter, dtype=np.float64)
    if np.any(~(k >= 1.0)):
        raise ValueError("K_clutter must be >= 1")
    a = np.asarray(a, dtype=np.float64)
    a_min = np.asarray(a_min, dtype=np.float64)
    if np.any(~(a_min > 0.0)):
        raise ValueError("a_min must be > 0")
    a_eff = np.maximum(a, a_min)
    if _model_checked(model) == "seed":
        p = weibull_exceedance(clutter_threshold_ratio(pfa, a_min), a_eff) / k
    else:
        p = weibull_median_exceedance(a_eff, pfa, a_min) / k
    off = a <= a_min
    if clutter_power_w is not None or noise_power_w is not None:
        if clutter_power_w is None or noise_power_w is None:
            raise ValueError("give both clutter_power_w and noise_power_w, or neither")
        off = off | (np.asarray(clutter_power_w, dtype=np.float64)
                     < NOISE_LIKE_FACTOR * np.asarray(noise_power_w, dtype=np.float64))
    return np.where(off, 0.0, p)


def default_p_fac_max(
    pfa: ArrayLike, a_min: ArrayLike = 1.0, model: ClutterFaModel = DEFAULT_CLUTTER_FA_MODEL
) -> NDArray[np.float64]:
    """HP P_facmax taken from VP with a = 3, seed 7.2 ([94]-[95], before K_clutter).

    The seed suggests P_facmax "between 10⁻² and 10⁻³ ... or the probability corresponding
    to a = 3.0 in VP"; the latter is [94]-[95] at a = 3 under the chosen ``model``: 0.133
    with the seed's reading, 9.2e-3 with the median-consistent one (P_fa = 3.6e-8), the
    latter inside the seed's suggested range.

    Parameters
    ----------
    pfa : array_like
        P_fa [-], in (0, 1].
    a_min : array_like, optional
        a_min [-] (< 3, else P_fac would be 0 in VP: then P_fa is returned).
    model : {"seed", "weibull_median"}, optional
        The [94]-[95] reading (:func:`clutter_fa_probability`).

    Returns
    -------
    ndarray
        P_facmax [-] (0.133, or 9.2e-3 for "weibull_median", at P_fa = 3.6e-8, a_min = 1).
    """
    if _model_checked(model) == "seed":
        p = weibull_exceedance(clutter_threshold_ratio(pfa, a_min), HP_DEFAULT_A)
    else:
        a_m = np.minimum(np.asarray(a_min, dtype=np.float64), HP_DEFAULT_A)
        p = weibull_median_exceedance(HP_DEFAULT_A, pfa, a_m)
    return np.where(np.asarray(a_min, dtype=np.float64) < HP_DEFAULT_A, p, _pfa_checked(pfa))


def hp_clutter_fa_probability(
    ground_range_m: ArrayLike,
    reference_range_m: ArrayLike,
    end_range_m: ArrayLike,
    p_fac_max: ArrayLike,
    k_clutter: ArrayLike = 1.0,
) -> NDArray[np.float64]:
    """Sea-clutter false-alarm probability per cell for HP, the heuristic of seed 7.2.

    P_facmax up to the reference range (3° grazing), then a raised-cosine decrease
    P_facmax (1 + cos π t)/2 with t = (R - R_ref)/(R_end - R_ref), reaching 0 at R_end (where
    a reaches a_min or P_sc falls to 2 N0'), and 0 beyond; all divided by K_clutter [96].
    If R_end ≤ R_ref there is no ramp: P_facmax before R_end, 0 from it on.

    Parameters
    ----------
    ground_range_m : array_like
        Ground range R [m].
    reference_range_m : array_like
        Ground range of 3° grazing R_ref [m].
    end_range_m : array_like
        R_end [m].
    p_fac_max : array_like
        P_facmax [-] in [0, 1] (the seed suggests 1e-3 to 1e-2, or :func:`default_p_fac_max`).
    k_clutter : array_like, optional
        K_clutter [-] ≥ 1.

    Returns
    -------
    ndarray
        P_fac in [0, P_facmax/K_clutter], non-increasing in R.
    """
    k = np.asarray(k_clutter, dtype=np.float64)
    pmax = np.asarray(p_fac_max, dtype=np.float64)
    if np.any(~(k >= 1.0)) or np.any(~((pmax >= 0.0) & (pmax <= 1.0))):
        raise ValueError("need K_clutter >= 1 and 0 <= P_facmax <= 1")
    r, r0, r1 = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64)
                                      for v in (ground_range_m, reference_range_m, end_range_m)))
    span = r1 - r0
    ramp = span > 0.0
    t = np.clip((r - r0) / np.where(ramp, span, 1.0), 0.0, 1.0)
    shape = np.where(ramp, 0.5 * (1.0 + np.cos(np.pi * t)), (r < r1).astype(np.float64))
    return pmax * shape / k


def sector_cells(
    range_extent_m: ArrayLike,
    azimuth_extent_rad: ArrayLike,
    range_cell_m: ArrayLike,
    beamwidth_rad: ArrayLike,
) -> NDArray[np.float64]:
    """Resolution cells in a (range, azimuth) sector, ΔR/C_R × Δθ/θ_b ([90] per sector).

    Parameters
    ----------
    range_extent_m : array_like
        ΔR [m] ≥ 0.
    azimuth_extent_rad : array_like
        Δθ [rad] ≥ 0.
    range_cell_m : array_like
        C_R [m] > 0.
    beamwidth_rad : array_like
        θ_b [rad] > 0.

    Returns
    -------
    ndarray
        Cells [-] (not rounded); summed over 2π and R_inst it is :func:`resolution_cells`.
    """
    c_r = np.asarray(range_cell_m, dtype=np.float64)
    th = np.asarray(beamwidth_rad, dtype=np.float64)
    if np.any(~(c_r > 0.0)) or np.any(~(th > 0.0)):
        raise ValueError("sector_cells: C_R and θ_b must be > 0")
    return np.asarray(range_extent_m, dtype=np.float64) / c_r * (
        np.asarray(azimuth_extent_rad, dtype=np.float64) / th)


def spike_excess(
    threshold_ratio: ArrayLike,
    a: ArrayLike,
    rng: np.random.Generator,
    model: ClutterFaModel = DEFAULT_CLUTTER_FA_MODEL,
) -> NDArray[np.float64]:
    """A clutter return x/σ0 drawn from the Weibull tail of [94] above the threshold Y/σ0.

    Given x > Y, (x/σ_m)^(1/a) - (Y/σ_m)^(1/a) is exponential with mean 1/ln 2 (the tail of
    [94] is exp(-ln 2 (x/σ_m)^(1/a))), so x/σ_m = ((Y/σ_m)^(1/a) + E/ln 2)^a, E ~ Exp(1).
    ``model="seed"``: σ_m = σ0 (the seed's substitution).  ``model="weibull_median"``:
    σ_m = σ0 (ln 2)^a/Γ(1+a) of [30] (:func:`weibull_median_ratio`), evaluated in logs.

    Parameters
    ----------
    threshold_ratio : array_like
        Y/σ0 [-] ≥ 0.
    a : array_like
        Weibull parameter [-] > 0, one per draw (broadcast against ``threshold_ratio``).
    rng : numpy.random.Generator
        One standard exponential per draw.
    model : {"seed", "weibull_median"}, optional
        Which σ_m [94] is taken over (the model of the threshold ``threshold_ratio``).

    Returns
    -------
    ndarray
        x/σ0 [-] ≥ Y/σ0.
    """
    y, a = np.broadcast_arrays(np.asarray(threshold_ratio, dtype=np.float64),
                               np.asarray(a, dtype=np.float64))
    if np.any(~(y >= 0.0)) or np.any(~(a > 0.0)):
        raise ValueError("spike_excess: need Y/σ0 >= 0 and a > 0")
    e = rng.standard_exponential(y.shape)
    return _spike_from_terms(*_spike_terms(y, a, _model_checked(model)), a, e)


def _spike_terms(y: _Floats, a: _Floats, model: ClutterFaModel) -> tuple[_Floats, _Floats | None]:
    """The threshold's terms of :func:`spike_excess`: (Y/σ_m)^(1/a) and ln(σ_m/σ0) (None
    for the ``seed`` model, σ_m = σ0), computed in logs for ``weibull_median``."""
    if model == "seed":
        return y ** (1.0 / a), None
    ln_m = log_weibull_median_ratio(a)
    with np.errstate(divide="ignore", over="ignore", under="ignore"):
        return np.exp((np.log(y) - ln_m) / a), ln_m


def _spike_from_terms(base: _Floats, ln_m: _Floats | None, a: _Floats, e: _Floats) -> _Floats:
    """x/σ0 = σ_m/σ0 ((Y/σ_m)^(1/a) + E/ln 2)^a from :func:`_spike_terms` and the
    exponentials E (:func:`spike_excess`)."""
    if ln_m is None:
        seed_excess: NDArray[np.float64] = (base + e / np.log(2.0)) ** a
        return seed_excess
    with np.errstate(divide="ignore", over="ignore", under="ignore"):
        excess: NDArray[np.float64] = np.exp(ln_m + a * np.log(base + e / np.log(2.0)))
    return excess


#: Count regimes of [91]-[93] of a clutter false-alarm sector (ClutterFalseAlarms._draw).
_REGIME_BERNOULLI, _REGIME_POISSON, _REGIME_NORMAL = 0, 1, 2


class ClutterFalseAlarms:
    """Per-scan generator of sea-clutter-induced false alarms, seed 7.2 with 7.1's method.

    Built once per radar from the P_fac map (:mod:`shipradar.tables.pfac`); only the sectors with
    P_fac > 0 are kept.  :meth:`scan` draws one revolution, vectorized over sectors and
    plots: the count of each sector by [91]-[93] from η = P_fac × cells
    (:func:`false_alarm_count`, one uniform per sector), positions uniform in ground range
    and azimuth inside the sector (:func:`uniform_positions`), the time at which the beam
    sweeps the azimuth, and the spike's S/I from the Weibull tail (:func:`spike_excess`).

    Parameters
    ----------
    r_min_m, r_max_m : array_like
        Ground-range bounds of each sector [m].
    az_min_rad, az_max_rad : array_like
        Azimuth bounds of each sector, true north [rad], az_min < az_max ≤ az_min + 2π.
    p_fac : array_like
        P_fac of each sector [-] in [0, 1].
    cells : array_like
        Resolution cells in each sector [-] (:func:`sector_cells`).
    weibull_a : array_like
        Weibull parameter of each sector [-] > 0 (for the spike's S/I).
    threshold_ratio : float
        Y/σ0 of [95] [-] (:func:`clutter_threshold_ratio` of the same ``clutter_fa_model``).
    n_channels : int
        N_ch (the Bernoulli limit of [92]).
    n_pulses : float
        Pulses integrated N_e [-] (measurement errors [84]-[85]).
    range_cell_m, beamwidth_rad : float
        C_R [m] and θ_b [rad] (measurement errors).
    antenna_height_m : float
        h_a [m]: the plots report the slant range of the sea point.
    k_factor : float, optional
        Effective earth radius factor (slant range).
    h_range, h_azimuth : float, optional
        H_r, H_θ of [84]-[85].
    clutter_fa_model : {"seed", "weibull_median"}, optional
        The [94]-[95] reading of the map (the spike's tail, :func:`spike_excess`).
    """

    # params: the P_fac sectors' columns and the radar's constants of [94]-[96], by keyword
    def __init__(self, r_min_m: ArrayLike, r_max_m: ArrayLike, az_min_rad: ArrayLike,
                 az_max_rad: ArrayLike, p_fac: ArrayLike, cells: ArrayLike,
                 weibull_a: ArrayLike, *,
                 threshold_ratio: float, n_channels: int, n_pulses: float, range_cell_m: float,
                 beamwidth_rad: float, antenna_height_m: float,
                 k_factor: float = K_FACTOR,
                 h_range: float = 4.0, h_azimuth: float = 4.0,
                 clutter_fa_model: ClutterFaModel = DEFAULT_CLUTTER_FA_MODEL) -> None:
        arrs = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64).ravel() for v in (
            r_min_m, r_max_m, az_min_rad, az_max_rad, p_fac, cells, weibull_a)))
        p = arrs[4]
        if np.any(~((p >= 0.0) & (p <= 1.0))):
            raise ValueError("ClutterFalseAlarms: P_fac must be in [0, 1]")
        eta = p * arrs[5]
        keep = eta > 0.0
        (self.r_min_m, self.r_max_m, self.az_min_rad, self.az_max_rad, self.p_fac, self.cells,
         self.weibull_a) = (np.ascontiguousarray(v[keep]) for v in arrs)
        #: Expected count per active sector per scan, η = P_fac × cells [-].
        self.eta = np.ascontiguousarray(eta[keep])
        self.threshold_ratio = float(threshold_ratio)
        self.n_channels = int(n_channels)
        self.n_pulses = float(n_pulses)
        self.range_cell_m = float(range_cell_m)
        self.beamwidth_rad = float(beamwidth_rad)
        self.antenna_height_m = float(antenna_height_m)
        self.k_factor = float(k_factor)
        self.h_range, self.h_azimuth = float(h_range), float(h_azimuth)
        self.clutter_fa_model = _model_checked(clutter_fa_model)
        # The sectors' regimes of [91]-[93] and the Poisson CDF rows never change during a
        # run: classify once, so a scan's counts are a few whole-array operations.
        bern = self.eta < float(bernoulli_limit(self.n_channels))
        normal = (self.eta >= NORMAL_MIN_ETA) & ~bern
        pois = ~bern & ~normal
        self._regime = np.where(bern, _REGIME_BERNOULLI,
                                np.where(normal, _REGIME_NORMAL, _REGIME_POISSON))
        self._pois_cdf = poisson_cdf_table(self.eta[pois])  # no rows if no Poisson sector
        self._pois_row = np.cumsum(pois) - 1  # the CDF row of each Poisson sector
        # _draw_block's forms of the same: the CDF column by column (CDF(k) of every row,
        # contiguous), the row of each sector or -1, whether any sector is normal, and the
        # runs [a, b) of consecutive Poisson sectors (the only ones a uniform hits from above)
        self._pois_cdf_cols = np.ascontiguousarray(self._pois_cdf.T)
        self._pois_row_or_none = np.where(pois, self._pois_row, -1)
        self._any_normal = bool(normal.any())
        edges = np.flatnonzero(np.diff(np.concatenate(([0], pois.astype(np.int8), [0]))))
        self._pois_runs: list[tuple[int, int]] = [
            (int(a), int(b)) for a, b in edges.reshape(-1, 2)]
        # a sector draws one alarm or more when U < _hit_below or U > _hit_above: U < η
        # (Bernoulli), U > P(0) = e^-η (Poisson), always (normal); see _draw
        self._hit_below = np.where(bern, self.eta, np.where(normal, 2.0, -1.0))
        self._hit_above = np.full(self.eta.shape, 2.0)
        self._hit_above[pois] = self._pois_cdf[:, 0]
        # the scratch arrays of _draw_block, kept per thread (shared with the twins of
        # shared(): a draw uses them only inside one call and returns none of them)
        self._scratch_kept = threading.local()
        # uniform_positions' spans, formed once: r0 + (r1 - r0) U is the same number whether
        # the difference is taken before or after selecting the sector
        self._r_span = self.r_max_m - self.r_min_m
        self._az_span = self.az_max_rad - self.az_min_rad
        if np.any(~((self.r_min_m >= 0) & (self._r_span >= 0))) or np.any(
                ~((self._az_span >= 0) & (self._az_span <= TWO_PI))):
            raise ValueError("ClutterFalseAlarms: need 0 <= r_min <= r_max and "
                             "az_min <= az_max <= az_min + 2 pi")

    def shared(self) -> ClutterFalseAlarms:
        """A generator drawing exactly as this one that shares its arrays, made read-only
        here (this one's too, and its spike terms computed), and its scratch arrays
        (:meth:`_scratch`, one set per thread): what depends on the map alone is built once
        and each run takes a twin (the sectors' ``ravel`` and selection copies are ~1 ms a
        run for the demo's 216,000-sector map, and fresh scratch arrays ~650 page faults,
        ~1 ms)."""
        self._spike_terms  # noqa: B018 (computed once, shared by the twins)
        for value in (*vars(self).values(), *self._spike_terms):
            if isinstance(value, np.ndarray):
                value.setflags(write=False)
        return copy.copy(self)

    def spike_excess(self, sector: NDArray[np.int64], rng: np.random.Generator
                     ) -> NDArray[np.float64]:
        """:func:`spike_excess` ([94]'s Weibull tail above the threshold [95]) of alarms in
        active sectors ``sector``, the same numbers for the same draws: the threshold's terms
        depend on the sector alone and are computed once per sector."""
        base, ln_m = self._spike_terms
        e = rng.standard_exponential(sector.shape)
        if ln_m is None:
            # _spike_from_terms' (base + e / ln 2) ** a, written in place on e (the same
            # operations: a sum and a product are the same whichever operand comes first)
            e /= np.log(2.0)
            e += base.take(sector)
            np.power(e, self.weibull_a.take(sector), out=e)
            return e
        return _spike_from_terms(base[sector], ln_m[sector], self.weibull_a[sector], e)

    def _scratch(self, revolutions: int) -> tuple[_Floats, NDArray[np.bool_], NDArray[np.bool_]]:
        """The uniforms and two masks of :meth:`_draw_block`, one per sector and revolution:
        the first rows of arrays kept between calls and runs (a block's are up to tens of
        MB: allocated when a block needs more rows than any before in this thread, not at
        every block)."""
        kept = getattr(self._scratch_kept, "arrays", None)
        if kept is None or kept[0].shape[0] < revolutions:
            shape = (revolutions, self.eta.size)
            kept = self._scratch_kept.arrays = (np.empty(shape), np.empty(shape, dtype=bool),
                                                np.empty(shape, dtype=bool))
        u, below, above = kept
        return u[:revolutions], below[:revolutions], above[:revolutions]

    @functools.cached_property
    def _spike_terms(self) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """:func:`_spike_terms` of every active sector."""
        return _spike_terms(np.full(self.eta.shape, self.threshold_ratio), self.weibull_a,
                            self.clutter_fa_model)

    @property
    def expected_per_scan(self) -> float:
        """Expected clutter false alarms per full revolution, Σ η [-]."""
        return float(self.eta.sum())

    def draw(self, rng: np.random.Generator) -> tuple[NDArray[np.int64], NDArray, NDArray]:
        """One revolution's counts per active sector and the positions (ground range [m],
        azimuth [rad]), sector after sector."""
        counts, _, _, r, az = self._draw(rng)
        assert counts is not None  # _draw's counts_per_sector defaults to True
        return counts[0], r, az

    def _draw(self, rng: np.random.Generator, revolutions: int = 1,
              counts_per_sector: bool = True
              ) -> tuple[_Ints | None, _Ints, _Ints, _Floats, _Floats]:
        """:meth:`draw` of ``revolutions`` revolutions at once, with the active-sector index
        and the revolution index of every false alarm (revolution after revolution, sector
        after sector: one revolution draws the same numbers as :meth:`draw`); the counts per
        sector (a revolutions × sectors array) only when ``counts_per_sector``."""
        hit, counts, sector, per_revolution, r, az = self._draw_block(rng, revolutions)
        per_sector = None
        if counts_per_sector:
            per_sector = np.zeros((revolutions, self.eta.size), dtype=np.int64)
            per_sector.ravel()[hit] = 1 if counts is None else counts
        revolution = np.repeat(np.arange(revolutions, dtype=np.int64), per_revolution)
        return per_sector, sector, revolution, r, az

    def _hit_mask(self, u: _Floats, below: NDArray[np.bool_], above: NDArray[np.bool_]
                  ) -> NDArray[np.bool_]:
        """Which sector uniforms ``u`` (revolutions × sectors) give one alarm or more: U < η
        (Bernoulli), U > P(0) = e^-η (Poisson's inverse CDF), always (normal, η ≥ 9);
        ``below`` and ``above`` are scratch masks of ``u``'s shape (the result is ``below``)."""
        # _hit_below is -1 in the Poisson sectors and _hit_above 2 elsewhere: "below" alone,
        # then the Poisson sectors' "above" written over it run by run (a strided slice of
        # the block per run), unless the runs are so many that their calls cost more
        np.less(u, self._hit_below, out=below)
        if len(self._pois_runs) * 4096 <= u.size:
            for a, b in self._pois_runs:
                np.greater(u[:, a:b], self._hit_above[a:b], out=below[:, a:b])
            return below
        np.greater(u, self._hit_above, out=above)
        return np.logical_or(below, above, out=below)

    def _draw_block(self, rng: np.random.Generator, revolutions: int
                    ) -> tuple[_Ints, _Ints | None, _Ints, _Ints, _Floats, _Floats]:
        """The draws of :meth:`_draw`: the flat index (revolution × sectors + sector) of every
        sector with one alarm or more, their counts (None: every count is 1), the sector of
        every alarm, the alarms of each revolution, and their ground ranges and azimuths."""
        # false_alarm_count's draw (one uniform per sector and revolution, same counts) with
        # the regimes and the Poisson CDF rows prepared in the constructor.  Most sectors
        # draw no alarm: the counts are worked out only where one is drawn (_hit_mask)
        n = self.eta.size
        u, below, above = self._scratch(revolutions)
        rng.random(out=u)
        hit = np.flatnonzero(self._hit_mask(u, below, above))
        # the hits come revolution after revolution: each revolution's first by bisection,
        # and the sector is the flat index less its revolution's (np.divmod costs 5 times a
        # subtraction an element)
        first = np.searchsorted(hit, n * np.arange(revolutions + 1, dtype=np.int64))
        sector = hit - np.repeat(n * np.arange(revolutions, dtype=np.int64), np.diff(first))
        counts = None
        per_revolution = np.diff(first)
        if self._any_normal or self._pois_cdf.shape[0]:
            counts = self._hit_counts(u.ravel(), hit, sector)
            per_revolution = np.diff(np.concatenate(([0], np.cumsum(counts)))[first])
            sector = np.repeat(sector, counts)
        # uniform_positions of these counts (same draws, same numbers), with the sector of
        # every plot found once instead of repeating each bound array over the counts;
        # r0 + (r1 - r0) U formed in place on U
        r = rng.random(sector.size)
        r *= self._r_span.take(sector)
        r += self.r_min_m.take(sector)
        az = rng.random(sector.size)
        az *= self._az_span.take(sector)
        az += self.az_min_rad.take(sector)
        az = _mod_two_pi(az, out=az)
        az[az >= TWO_PI] = 0.0
        return hit, counts, sector, per_revolution, r, az

    def _hit_counts(self, u: _Floats, hit: _Ints, sector: _Ints) -> _Ints:
        """Counts ([91]-[93]) of the sectors ``sector`` hit at flat indices ``hit`` of the
        block's uniforms ``u`` (raveled): 1 in the Bernoulli regime."""
        counts = np.ones(hit.size, dtype=np.int64)
        if self._any_normal:
            normal = self._regime.take(sector) == _REGIME_NORMAL
            if normal.any():
                e = self.eta[sector[normal]]
                x = e + np.sqrt(e) * special.ndtri(u[hit[normal]])
                counts[normal] = np.rint(np.maximum(x, 0.0)).astype(np.int64)
        rows = self._pois_row_or_none.take(sector)
        pois = np.flatnonzero(rows >= 0)
        if pois.size:
            # the inverse CDF, count = #{k: CDF(k) < U} (≥ 1 here), one column at a time
            # over the sectors still above it (most stop at 1 or 2)
            rows, up = rows.take(pois), u.take(hit.take(pois))
            for column in self._pois_cdf_cols[1:]:
                more = up > column.take(rows)
                if not more.any():
                    break
                pois, rows, up = pois[more], rows[more], up[more]
                counts[pois] += 1
        return counts

    def scan(self, t_scan: float, t_end: float, beam_start_rad: float, omega_rad_s: float,
             rng: np.random.Generator) -> dict[str, NDArray] | None:
        """Plot columns of one revolution's clutter false alarms, or None if there are none:
        :meth:`scans` of one revolution (the same draws), without its ``revolution``
        column."""
        out = self.scans([t_scan], [t_end], [beam_start_rad], omega_rad_s, rng)
        if out is not None:
            del out["revolution"]
        return out

    def scans(self, t_scan: ArrayLike, t_end: ArrayLike, beam_start_rad: ArrayLike,
              omega_rad_s: float, rng: np.random.Generator) -> dict[str, NDArray] | None:
        """Plot columns of the clutter false alarms of several revolutions drawn together
        (the on-line level's block of revolutions), or None if there are no active sectors.

        Parameters
        ----------
        t_scan : array_like
            Start of each revolution [s].
        t_end : array_like
            End of each revolution or of the run [s]: later plots are dropped.
        beam_start_rad : array_like
            Beam azimuth at each ``t_scan`` [rad].
        omega_rad_s : float
            Rotation rate [rad/s] > 0.
        rng : numpy.random.Generator
            The counts of every revolution are drawn first (one uniform per sector and
            revolution), then all ranges, all azimuths and all spike excesses.

        Returns
        -------
        dict or None
            ``time_s`` (t_scan + mod(θ - θ_start, 2π)/ω), ``range_m`` (slant range of the sea
            point), ``azimuth_rad``, ``snr_db`` (spike excess x/σ0 - 1 in dB),
            ``sigma_range_m``, ``sigma_azimuth_rad`` ([84]-[85] / 3), ``interference``
            (uint8, 1 = clutter), ``ground_range_m``, ``revolution`` (index into
            ``t_scan``) and ``sector`` (index of the active sector: ``eta``, ``r_min_m``...),
            revolution after revolution (not sorted by time within one).
        """
        if self.eta.size == 0:
            return None
        t_scan, t_end, beam = (np.atleast_1d(np.asarray(v, dtype=np.float64)) for v in (
            t_scan, t_end, beam_start_rad))
        _, _, sector, per_revolution, ground, az = self._draw_block(rng, t_scan.size)
        # the alarms come revolution after revolution: each revolution's start, beam and end
        # repeated over its alarms (a gather by revolution gives the same numbers); the
        # time t_scan + mod(θ - θ_start, 2π)/ω formed in place
        t = az - np.repeat(beam, per_revolution)
        t = _mod_two_pi(t, out=t)
        t /= omega_rad_s
        t += np.repeat(t_scan, per_revolution)
        keep = t < np.repeat(t_end, per_revolution)
        revolution = np.repeat(np.arange(t_scan.size, dtype=np.int64), per_revolution)
        if not keep.all():  # only the run's last revolution ends early
            ground, az, t = ground[keep], az[keep], t[keep]
            revolution, sector = revolution[keep], sector[keep]
        x = self.spike_excess(sector, rng)
        x -= 1.0
        si = np.maximum(x, 1e-3, out=x)
        eps_r, eps_t = expected_errors(si, self.n_pulses, self.range_cell_m, self.beamwidth_rad,
                                       h_range=self.h_range, h_azimuth=self.h_azimuth)
        slant = slant_range_m(ground, self.antenna_height_m, self.k_factor)
        n = t.size
        snr_db = np.log10(si)
        snr_db *= 10.0
        return {
            pc.TIME_S: t,
            pc.RANGE_M: slant,
            pc.AZIMUTH_RAD: az,
            pc.SNR_DB: snr_db,
            pc.SIGMA_RANGE_M: _divided(eps_r, SIGMAS_PER_ERROR, n),
            pc.SIGMA_AZIMUTH_RAD: _divided(eps_t, SIGMAS_PER_ERROR, n),
            pc.INTERFERENCE: np.full(n, Interference.CLUTTER, dtype=np.uint8),
            "ground_range_m": ground,
            "revolution": revolution,
            "sector": sector,
        }


def _divided(x: _Floats, by: float, n: int) -> _Floats:
    """``x / by`` as a column of ``n`` values: in place when ``x`` is already one (a fresh
    array of that shape), else broadcast and copied."""
    if isinstance(x, np.ndarray) and x.shape == (n,) and x.flags.writeable and x.base is None:
        x /= by
        return x
    column: _Floats = np.broadcast_to(x / by, (n,)).copy()
    return column


__all__ = [
    "CLUTTER_FA_MODELS",
    "DEFAULT_CLUTTER_FA_MODEL",
    "NORMAL_MIN_ETA",
    "ClutterFalseAlarms",
    "bernoulli_limit",
    "clutter_fa_probability",
    "clutter_threshold_db",
    "clutter_threshold_ratio",
    "default_p_fac_max",
    "false_alarm_count",
    "hp_clutter_fa_probability",
    "poisson_cdf_table",
    "poisson_quantile",
    "resolution_cells",
    "sector_cells",
    "spike_excess",
    "uniform_positions",
    "weibull_exceedance",
    "weibull_median_exceedance",
    "weibull_median_ratio",
    "log_weibull_median_ratio",
    "noise_false_alarms_per_scan",
]
