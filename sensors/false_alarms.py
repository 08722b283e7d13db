"""False alarms: counts per scan or sector and their positions, seed chapter 7.

Noise-induced false alarms, seed 7.1, [90]-[93].  The count generator and the position
generator are generic: the sea-clutter part (7.2, [94]-[96]) draws per sector with the same
functions from its own η = N_cells P_fac.

Choices where the seed is silent or wrong
-----------------------------------------
* **[90] units (SPEC §4 item 7).**  The seed's 360 R_inst/(θ_b C_R) takes θ_b in degrees;
  here θ_b is in radians: N_cells = 2π R_inst / (θ_b C_R) (beam positions per revolution
  times range cells).
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
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import special, stats

from sensors.detection import LN2_SEED, N_CHANNELS

#: [91]: the normal approximation is used for η ≥ 9.
NORMAL_MIN_ETA = 9.0
TWO_PI = 2.0 * np.pi


def resolution_cells(
    instrumented_range_m: ArrayLike, beamwidth_rad: ArrayLike, range_cell_m: ArrayLike
) -> NDArray[np.float64]:
    """Resolution cells in the instrumented domain, N_cells = 2π R_inst/(θ_b C_R), seed [90].

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
    r = np.asarray(instrumented_range_m, dtype=float)
    theta = np.asarray(beamwidth_rad, dtype=float)
    c_r = np.asarray(range_cell_m, dtype=float)
    if np.any(~(r >= 0)) or np.any(~(theta > 0)) or np.any(~(c_r > 0)):
        raise ValueError(
            "resolution_cells: instrumented_range_m must be >= 0, beamwidth_rad and "
            "range_cell_m > 0"
        )
    return TWO_PI * r / (theta * c_r)


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
    return LN2_SEED / (2.0 * np.asarray(n_channels, dtype=float))


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
    eta_a = np.asarray(eta, dtype=float)
    n_ch = np.asarray(n_channels, dtype=float)
    if np.any(~((eta_a >= 0) & np.isfinite(eta_a))):
        raise ValueError("false_alarm_count: eta must be finite and >= 0")
    if np.any(~(n_ch > 0)):
        raise ValueError("false_alarm_count: n_channels must be > 0")
    shape = eta_a.shape if size is None else (size if isinstance(size, tuple) else (size,))
    eta_b = np.broadcast_to(eta_a, shape)
    limit = np.broadcast_to(bernoulli_limit(n_ch), shape)
    u = rng.random(shape)
    count = np.zeros(shape, dtype=np.int64)
    bern = eta_b < limit
    count[bern] = u[bern] < eta_b[bern]
    normal = (eta_b >= NORMAL_MIN_ETA) & ~bern
    if np.any(normal):
        e = eta_b[normal]
        # u = 0 gives -inf, floored to 0 below (probability 2^-53)
        x = e + np.sqrt(e) * special.ndtri(u[normal])
        count[normal] = np.rint(np.maximum(x, 0.0)).astype(np.int64)
    pois = ~bern & ~normal
    if np.any(pois):
        # poisson.ppf(0, mu) is -1 by scipy's convention: the count is then 0
        m = stats.poisson.ppf(u[pois], eta_b[pois])
        count[pois] = np.maximum(m, 0.0).astype(np.int64)
    return count


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
    c, r0, r1, a0, a1 = np.broadcast_arrays(
        counts,
        np.asarray(r_min_m, dtype=float),
        np.asarray(r_max_m, dtype=float),
        np.asarray(az_min_rad, dtype=float),
        np.asarray(az_max_rad, dtype=float),
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


__all__ = [
    "NORMAL_MIN_ETA",
    "bernoulli_limit",
    "false_alarm_count",
    "resolution_cells",
    "uniform_positions",
]
