"""Expected measurement errors and noisy range/azimuth of a contact, seed [84]-[89].

ε_R = H_r C_R / sqrt((S/I)_out)  [84],   ε_θ = H_θ θ_b / sqrt((S/I)_out)  [85],
R_meas = R + N(0, (ε_R/3)²)  [86], [88],   θ_meas = θ + N(0, (ε_θ/3)²)  [87], [89].

Choices where the seed is silent
--------------------------------
* **(S/I)_out.**  The seed defines it as the S/I "at the output of the threshold stage ...
  which includes the effect of the non-coherent integration".  Here
  (S/I)_out = N_e · (S/I per pulse): the ratio of the total received signal energy over the
  dwell to the noise spectral density, E/N_0, which is what the classical accuracy formulas
  depend on (Barton, *Radar System Analysis and Modeling*, 2005, §§ 11.1-11.2:
  σ ∝ resolution / sqrt(2E/N_0)).  The non-coherent integration loss affects detection, not
  the energy available to the estimator, so it is not applied.
* **Low S/I (SPEC §4 item 13).**  (S/I)_out is floored at :data:`MIN_OUTPUT_SNR` = 1
  (0 dB): below it a plot carries the errors of a 0 dB plot, ε_R = H_r C_R and
  ε_θ = H_θ θ_b (four resolution cells, four beamwidths by default), finite for S/I = 0
  or negative dB.
* **Edges of the measured values.**  Range is folded at 0 (|R_meas|: the error
  distribution stays continuous, with no atom at 0); azimuth is wrapped to [0, 2π).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shipradar.sensors import plot_columns as pc

#: Default constants H_r and H_θ of [84]-[85] (seed 6.5: the mean error equals the
#: resolution at (S/I)_out = 12 dB).
H_DEFAULT = 4.0
#: [86]-[89]: ε is three standard deviations ("99 % of cases within ± ε").
SIGMAS_PER_ERROR = 3.0
#: Floor of (S/I)_out in [84]-[85] [-] (0 dB), see the module notes.
MIN_OUTPUT_SNR = 1.0
TWO_PI = 2.0 * np.pi


def output_snr(snr: ArrayLike, n_pulses: ArrayLike) -> NDArray[np.float64]:
    """S/I at the output of the threshold stage, (S/I)_out = N_e S/I, floored at 1.

    Parameters
    ----------
    snr : array_like
        Per-pulse signal-to-interference ratio S/I (linear power ratio) [-], ≥ 0.
    n_pulses : array_like
        Pulses integrated non-coherently N_e [-], ≥ 1.

    Returns
    -------
    ndarray
        (S/I)_out [-], ≥ :data:`MIN_OUTPUT_SNR`; +inf stays +inf (zero error).
    """
    s = np.asarray(snr, dtype=np.float64)
    n = np.asarray(n_pulses, dtype=np.float64)
    if np.any(np.isnan(s)) or np.any(~(n >= 1)):
        raise ValueError("output_snr: snr must not be NaN and n_pulses must be >= 1")
    return np.maximum(np.maximum(s, 0.0) * n, MIN_OUTPUT_SNR)


def expected_errors(
    snr: ArrayLike,
    n_pulses: ArrayLike,
    range_cell_m: ArrayLike,
    beamwidth_rad: ArrayLike,
    *,
    h_range: ArrayLike = H_DEFAULT,
    h_azimuth: ArrayLike = H_DEFAULT,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Expected (mean) range and azimuth errors ε_R, ε_θ, seed [84]-[85].

    Parameters
    ----------
    snr : array_like
        Per-pulse S/I (linear) [-].
    n_pulses : array_like
        Pulses integrated non-coherently N_e [-].
    range_cell_m : array_like
        Range cell C_R [m].
    beamwidth_rad : array_like
        Horizontal 3 dB beamwidth θ_b [rad].
    h_range, h_azimuth : array_like, optional
        Constants H_r and H_θ [-] (default 4).

    Returns
    -------
    eps_range_m : ndarray
        ε_R [m], at most H_r C_R (the 0 dB floor of (S/I)_out).
    eps_azimuth_rad : ndarray
        ε_θ [rad], at most H_θ θ_b.
    """
    root = np.sqrt(output_snr(snr, n_pulses))
    eps_r = (
        np.asarray(h_range, dtype=np.float64) * np.asarray(range_cell_m, dtype=np.float64) / root
    )
    eps_t = (
        np.asarray(h_azimuth, dtype=np.float64) * np.asarray(beamwidth_rad, dtype=np.float64) / root
    )
    return eps_r, eps_t


def noisy_range(
    range_m: ArrayLike, eps_range_m: ArrayLike, rng: np.random.Generator
) -> NDArray[np.float64]:
    """Measured range R + N(0, (ε_R/3)²), folded at 0, seed [86], [88].

    Parameters
    ----------
    range_m : array_like
        True range [m], ≥ 0.
    eps_range_m : array_like
        Expected range error ε_R [m].
    rng : numpy.random.Generator
        Source of randomness (one standard normal per element).

    Returns
    -------
    ndarray
        Measured range [m], ≥ 0 (|R + e|).
    """
    r = np.asarray(range_m, dtype=np.float64)
    sigma = np.asarray(eps_range_m, dtype=np.float64) / SIGMAS_PER_ERROR
    shape = np.broadcast_shapes(r.shape, sigma.shape)
    return np.abs(r + sigma * rng.standard_normal(shape))


def noisy_azimuth(
    azimuth_rad: ArrayLike, eps_azimuth_rad: ArrayLike, rng: np.random.Generator
) -> NDArray[np.float64]:
    """Measured azimuth θ + N(0, (ε_θ/3)²), wrapped to [0, 2π), seed [87], [89].

    Parameters
    ----------
    azimuth_rad : array_like
        True azimuth [rad].
    eps_azimuth_rad : array_like
        Expected azimuth error ε_θ [rad].
    rng : numpy.random.Generator
        Source of randomness (one standard normal per element).

    Returns
    -------
    ndarray
        Measured azimuth [rad] in [0, 2π).
    """
    a = np.asarray(azimuth_rad, dtype=np.float64)
    sigma = np.asarray(eps_azimuth_rad, dtype=np.float64) / SIGMAS_PER_ERROR
    shape = np.broadcast_shapes(a.shape, sigma.shape)
    return wrap_azimuth(a + sigma * rng.standard_normal(shape))


def wrap_azimuth(azimuth_rad: ArrayLike) -> NDArray[np.float64]:
    """Azimuth wrapped to [0, 2π) [rad] (np.mod can round a tiny negative angle up to 2π)."""
    w = np.mod(np.asarray(azimuth_rad, dtype=np.float64), TWO_PI)
    return np.where(w >= TWO_PI, 0.0, w)


def measure(
    range_m: ArrayLike,
    azimuth_rad: ArrayLike,
    snr: ArrayLike,
    n_pulses: ArrayLike,
    range_cell_m: ArrayLike,
    beamwidth_rad: ArrayLike,
    rng: np.random.Generator,
    *,
    h_range: ArrayLike = H_DEFAULT,
    h_azimuth: ArrayLike = H_DEFAULT,
) -> dict[str, NDArray[np.float64]]:
    """Noisy range and azimuth of contacts with their standard deviations, seed [84]-[89].

    Parameters
    ----------
    range_m, azimuth_rad : array_like
        True range [m] and azimuth [rad] of each contact.
    snr : array_like
        Per-pulse S/I (linear) [-].
    n_pulses : array_like
        Pulses integrated non-coherently N_e [-].
    range_cell_m : array_like
        Range cell C_R [m].
    beamwidth_rad : array_like
        Horizontal 3 dB beamwidth θ_b [rad].
    rng : numpy.random.Generator
        Source of randomness: all range errors are drawn first, then all azimuth errors.
    h_range, h_azimuth : array_like, optional
        H_r and H_θ [-].

    Returns
    -------
    dict
        ``range_m`` [m], ``azimuth_rad`` [rad], ``sigma_range_m`` = ε_R/3 [m] and
        ``sigma_azimuth_rad`` = ε_θ/3 [rad], all of the broadcast shape.
    """
    eps_r, eps_t = expected_errors(
        snr, n_pulses, range_cell_m, beamwidth_rad, h_range=h_range, h_azimuth=h_azimuth
    )
    r, a, eps_r, eps_t = np.broadcast_arrays(
        np.asarray(range_m, dtype=np.float64),
        np.asarray(azimuth_rad, dtype=np.float64),
        eps_r,
        eps_t,
    )
    return {
        pc.RANGE_M: noisy_range(r, eps_r, rng),
        pc.AZIMUTH_RAD: noisy_azimuth(a, eps_t, rng),
        pc.SIGMA_RANGE_M: eps_r / SIGMAS_PER_ERROR,
        pc.SIGMA_AZIMUTH_RAD: eps_t / SIGMAS_PER_ERROR,
    }


__all__ = [
    "H_DEFAULT",
    "MIN_OUTPUT_SNR",
    "expected_errors",
    "measure",
    "noisy_azimuth",
    "noisy_range",
    "output_snr",
    "wrap_azimuth",
]
