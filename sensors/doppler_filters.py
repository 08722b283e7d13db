"""Doppler filtering: improvement factor of transversal filters (seed chapter 5, [49]-[65]).

An MTI canceller, a bank of Doppler filters, or their cascade is a transversal filter [49]
with complex weights ``w``.  Its improvement factor [57] is the ratio of the signal and the
clutter output powers, ``I_F = wᴴ M_s w / wᴴ M_c w``, each input normalized to unit power per
pulse.  Both covariance matrices are Toeplitz and Hermitian, ``M(k, l) = c(k - l)``, so the
quadratic form is computed from the weight autocorrelation ``r[m] = Σ_l w_l conj(w_{l+m})``:

    wᴴ M w = c(0) r[0] + 2 Re Σ_{m=1}^{N-1} c(m) r[m],

which costs O(N) per covariance instead of O(N²), and a grid of clutter spreads and target
Dopplers becomes one matrix product.

Conventions (the seed's, kept so that its equations read unchanged):

* Frequencies are normalized to the pulse repetition frequency: ``doppler_norm = f_d/f_r``,
  ``spread_norm = σ_s/f_r``, ``bandwidth_norm = B/f_r``.  Everything is periodic in
  ``doppler_norm`` with period 1 (Doppler ambiguity).
* Lag covariances follow [55]-[56], ``c(m) = exp(-j2π f m) ...``, and the bank weights follow
  [59], ``w_n = exp(-j2π f_i n)``; with these two signs a filter of centre ``f_i`` responds
  most to a target at ``f_d = f_i``.
* The signal covariance of a *point* target is [55] with ``B -> 0`` (``sinc -> 1``): this is the
  per-target improvement factor the on-line level needs.  ``B > 0`` gives the seed's
  band-averaged gain [50]-[54]; ``B = 1`` averages over all Dopplers, the classical MTI
  improvement factor (Nathanson; Skolnik).

System stability.  As ``σ_s/f_r -> 0`` the clutter covariance [56] becomes the all-ones matrix,
singular, and an MTI's clutter output ``|Σ w|²`` vanishes: [57] diverges.  No radar reaches
that: transmitter and timing instabilities leave a pulse-to-pulse uncorrelated residue of
relative power ``ε`` on every echo, target and clutter alike, so both covariances become
``M + ε I``.  Then the Doppler-averaged MTI factor obeys the classical combination of limits
``1/I_F ≈ 1/I_clutter + 1/I_stability`` with ``I_stability = 1/ε`` (Skolnik, *Introduction to
Radar Systems*, 3rd ed., §3.7, "limitations to MTI performance"), a target whose spectrum equals
the clutter's gets ``I_F = 1``, and a target in a blind speed gets a small, finite ``I_F``.  The
seed has no stability term; the default limit (:data:`DEFAULT_STABILITY_LIMIT_DB`, 100 dB) is
beyond any practical radar's (40-70 dB) so it only keeps the model finite; set the radar's own
value when known.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import comb

#: Default system-stability limit of the improvement factor [dB] (see the module docstring).
DEFAULT_STABILITY_LIMIT_DB = 100.0
#: Largest stability limit accepted [dB]: the lag sums carry rounding errors of ~1e-15 of the
#: filter energy, so a residue below 1e-15 would be dominated by rounding.
MAX_STABILITY_LIMIT_DB = 150.0

#: Clutter spread over the PRF beyond which [56] is white to double precision (exp(-2π²·100)
#: underflows) [1].
WHITE_SPREAD_NORM = 10.0

#: Gauss-Hermite order of the narrow-clutter quadrature of :func:`clutter_output_power` [1].
GAUSS_HERMITE_ORDER = 64
#: Spread times filter length up to which the clutter output uses the quadrature [1].
NARROW_SPREAD_TAPS = 0.5
_GH_T, _GH_W = np.polynomial.hermite.hermgauss(GAUSS_HERMITE_ORDER)
# nodes t_k and weights w_k/√π of ∫ g(x) N(x; 0, 1/2) dx
_GH_NODES = _GH_T
_GH_WEIGHTS = _GH_W / np.sqrt(np.pi)

#: [63] improvement factor above which the distribution loss decays [dB].
DISTRIBUTION_LOSS_KNEE_DB = 20.0
#: [63] decay scale: L_d = L_d0 exp(-(I_F - 20)² / 100), I_F in dB [dB²].
DISTRIBUTION_LOSS_DECAY_DB2 = 100.0
#: [64] L_d0 = 15 (1 - exp(-d_mm / 8.45)) - 5: amplitude [dB], scale [dB], offset [dB].
DISTRIBUTION_LOSS_AMPLITUDE_DB = 15.0
DISTRIBUTION_LOSS_SCALE_DB = 8.45
DISTRIBUTION_LOSS_OFFSET_DB = 5.0

#: Window names accepted by :func:`window_weights` ([62], ``scipy.signal.windows``).
WINDOWS = ("rectangular", "hann", "hamming", "taylor", "chebyshev")
#: scipy's default Taylor design: peak sidelobe level [dB below the mainlobe] and n-bar.
DEFAULT_TAYLOR_SIDELOBE_DB = 30.0
DEFAULT_TAYLOR_NBAR = 4

PickRule = Literal["response", "best"]


# ----------------------------------------------------------------------------- residue
def stability_residue(stability_limit_db: float) -> float:
    """Relative power ``ε`` of the uncorrelated instability residue for a stability limit.

    Parameters
    ----------
    stability_limit_db : float
        Improvement factor limit set by system instabilities [dB], in
        ``(0, MAX_STABILITY_LIMIT_DB]``.

    Returns
    -------
    float
        ``ε = 10^(-limit/10)`` [1], the white residue added to both covariances of [57].
    """
    limit = float(stability_limit_db)
    if not (0.0 < limit <= MAX_STABILITY_LIMIT_DB):
        raise ValueError(
            f"stability_limit_db must be in (0, {MAX_STABILITY_LIMIT_DB}] dB, got {limit}"
        )
    residue: float = 10.0 ** (-limit / 10.0)  # float ** float is typed Any
    return residue


# ----------------------------------------------------------------------------- covariances
def weight_autocorrelation(weights: ArrayLike) -> NDArray[np.complexfloating]:
    """Weight autocorrelation ``r[m] = Σ_l w_l conj(w_{l+m})`` for lags ``m = 0 .. N-1``.

    Parameters
    ----------
    weights : array_like, shape (..., N)
        Filter weights [1] along the last axis (one filter per leading index).

    Returns
    -------
    ndarray, shape (..., N), complex
        ``r[..., 0]`` is the filter energy ``Σ |w|²``; negative lags are ``conj(r[m])``.
    """
    w = np.asarray(weights, dtype=np.complex128)
    if w.ndim == 0 or w.shape[-1] == 0:
        raise ValueError("weights must have at least one tap along the last axis")
    n = w.shape[-1]
    r = np.empty(w.shape, dtype=np.complex128)
    for m in range(n):
        r[..., m] = np.sum(w[..., : n - m] * np.conj(w[..., m:]), axis=-1)
    return r


def quadratic_form_toeplitz(weights: ArrayLike, lag_covariance: ArrayLike) -> NDArray:
    """``wᴴ M w`` for a Hermitian Toeplitz ``M(k, l) = c(k - l)`` given by its lags ``c(m)``.

    Used by [57] for both covariances.  Cost O(N) per covariance.

    Parameters
    ----------
    weights : array_like, shape (F..., N)
        Weights [1] of one filter, or of several along the leading axes.
    lag_covariance : array_like, shape (P..., N)
        ``c(m)`` for ``m = 0 .. N-1`` [1]; ``c(-m) = conj(c(m))`` is implied.

    Returns
    -------
    ndarray, shape (F..., P...), float
        The output power [1]; non-negative for a positive semi-definite ``M`` up to rounding
        (of order 1e-16 of the filter energy), which the callers clip at 0.
    """
    r = weight_autocorrelation(weights)
    c = np.asarray(lag_covariance, dtype=np.complex128)
    n = r.shape[-1]
    if c.shape[-1] != n:
        raise ValueError(f"lag_covariance has {c.shape[-1]} lags, the filter has {n} taps")
    doubling = np.full(n, 2.0)
    doubling[0] = 1.0
    return np.real(np.tensordot(r * doubling, c, axes=([-1], [-1])))


def signal_lag_covariance(
    n_lags: int, doppler_norm: ArrayLike, bandwidth_norm: ArrayLike = 0.0
) -> NDArray[np.complexfloating]:
    """Lags of the target signal covariance, seed [55]: ``exp(-j2π f m) sinc(B m)``.

    Parameters
    ----------
    n_lags : int
        Number of lags ``m = 0 .. n_lags-1`` (the filter length).
    doppler_norm : array_like
        Target Doppler, or the centre ``f_i`` of the uniform Doppler band [50]-[51], over the
        PRF, ``f/f_r`` [1]; any real value (periodic with period 1).
    bandwidth_norm : array_like
        Width of the uniform Doppler band over the PRF, ``B/f_r`` [1], ``>= 0``.  ``0`` is a
        point target (``sinc -> 1``); ``1`` averages over all Dopplers (``M_s = I``).

    Returns
    -------
    ndarray, shape (broadcast(doppler_norm, bandwidth_norm) + (n_lags,)), complex
    """
    f, b = np.broadcast_arrays(
        np.asarray(doppler_norm, np.float64), np.asarray(bandwidth_norm, np.float64)
    )
    if np.any(b < 0):
        raise ValueError("bandwidth_norm must be >= 0")
    m = np.arange(n_lags)
    # the phase is reduced modulo 1 before the product so that large |f| keeps full precision
    phase = np.mod(f[..., None] * m, 1.0)
    rotation: NDArray[np.complex128] = np.exp(-2j * np.pi * phase)
    return rotation * np.sinc(b[..., None] * m)


def clutter_lag_covariance(
    n_lags: int, spread_norm: ArrayLike, mean_norm: ArrayLike = 0.0
) -> NDArray[np.complexfloating]:
    """Lags of the Gaussian clutter covariance, seed [56].

    ``c(m) = exp(-2 (π σ_s/f_r)² m² - j2π (μ_c/f_r) m)``, the characteristic function of a
    Gaussian spectrum of standard deviation ``σ_s`` and mean ``μ_c``, sampled at the PRF (the
    aliasing of a spectrum wider than the PRF is therefore included).

    Parameters
    ----------
    n_lags : int
        Number of lags ``m = 0 .. n_lags-1`` (the filter length).
    spread_norm : array_like
        Clutter spectrum standard deviation over the PRF, ``σ_s/f_r`` [1], ``>= 0``.  At ``0``
        every lag is 1 (fully coherent clutter, singular covariance; see the stability residue
        in the module docstring).  Large values (``>~ 1``, including ``inf``) give white
        clutter, ``M_c -> I``.
    mean_norm : array_like
        Clutter mean Doppler over the PRF, ``μ_c/f_r`` [1] (0 for a clutter-locked MTI).

    Returns
    -------
    ndarray, shape (broadcast(spread_norm, mean_norm) + (n_lags,)), complex
    """
    s, mu = np.broadcast_arrays(
        np.asarray(spread_norm, np.float64), np.asarray(mean_norm, np.float64)
    )
    if np.any(s < 0):
        raise ValueError("spread_norm must be >= 0")
    m = np.arange(n_lags)
    # beyond WHITE_SPREAD_NORM every lag m >= 1 underflows to 0 anyway; clipping avoids
    # inf * 0 at m = 0 and overflow of the square for huge or infinite spreads
    s = np.minimum(s, WHITE_SPREAD_NORM)
    magnitude: NDArray[np.float64] = np.exp(-2.0 * (np.pi * s[..., None] * m) ** 2)
    phase = np.mod(mu[..., None] * m, 1.0)
    rotation: NDArray[np.complex128] = np.exp(-2j * np.pi * phase)
    return magnitude * rotation


def filter_response(weights: ArrayLike, doppler_norm: ArrayLike) -> NDArray:
    """Power response ``|H(f)|² = |Σ_n conj(w_n) exp(-j2π f n)|²`` to a point target.

    This is ``wᴴ M_s w`` of [57] with [55] at ``B -> 0`` and unit input power.  It is summed
    as an amplitude and then squared, so that near a null the absolute error is of order
    ``(1e-16 Σ|w|)²`` rather than the ``1e-16 Σ|w|²`` of the lag sum.

    Parameters
    ----------
    weights : array_like, shape (F..., N)
        Filter weights [1].
    doppler_norm : array_like
        Target Doppler over the PRF, ``f_d/f_r`` [1] (periodic with period 1).

    Returns
    -------
    ndarray, shape (F..., doppler_norm.shape), float, ``>= 0``
        0 at a null of the filter (e.g. the blind speeds ``f_d/f_r ∈ Z`` of an MTI).
    """
    w = np.asarray(weights, dtype=np.complex128)
    f = np.asarray(doppler_norm, dtype=np.float64)
    n = np.arange(w.shape[-1])
    steering = np.exp(-2j * np.pi * np.mod(f[..., None] * n, 1.0))
    response: NDArray[np.float64] = (
        np.abs(np.tensordot(np.conj(w), steering, axes=([-1], [-1]))) ** 2
    )
    return response


def signal_output_power(
    weights: ArrayLike, doppler_norm: ArrayLike, bandwidth_norm: ArrayLike = 0.0
) -> NDArray:
    """Signal output power ``wᴴ M_s w`` of [57] with the signal covariance [55].

    Parameters
    ----------
    weights : array_like, shape (F..., N)
        Filter weights [1].
    doppler_norm : array_like
        Target Doppler, or centre ``f_i`` of its uniform band, over the PRF [1].
    bandwidth_norm : array_like, optional
        Band ``B/f_r`` [1], ``>= 0``; all zeros (default) is a point target, evaluated by
        :func:`filter_response`; otherwise the lag sum with [55].

    Returns
    -------
    ndarray, shape (F..., broadcast(doppler_norm, bandwidth_norm)), float, ``>= 0``
    """
    w = np.asarray(weights)
    f, b = np.broadcast_arrays(
        np.asarray(doppler_norm, np.float64), np.asarray(bandwidth_norm, np.float64)
    )
    if np.all(b == 0):
        return filter_response(w, f)
    cov = signal_lag_covariance(w.shape[-1], f, b)
    power: NDArray[np.float64] = np.maximum(quadratic_form_toeplitz(w, cov), 0.0)
    return power


def clutter_output_power(
    weights: ArrayLike, spread_norm: ArrayLike, mean_norm: ArrayLike = 0.0
) -> NDArray:
    """Clutter output power ``wᴴ M_c w`` of [57] with the Gaussian clutter covariance [56].

    Two evaluations of the same quantity, chosen by the spread:

    * narrow clutter, ``σ_s (N-1)/f_r <= NARROW_SPREAD_TAPS``: the spectral form
      ``∫ |H(f)|² G(f; μ_c, σ_s) df`` by Gauss-Hermite quadrature
      (:data:`GAUSS_HERMITE_ORDER` nodes; the periodic ``|H|²`` makes the aliasing of [56]
      implicit).  ``|H|`` is summed as an amplitude, so an MTI's vanishing output
      (``~σ^(2n)`` for ``n`` stages) keeps its relative precision as ``σ_s -> 0``, where [56]
      becomes singular and the lag sum would cancel down to a rounding floor of ~1e-16 of the
      filter energy.  The quadrature is exact to double precision here: ``|H|²`` is a sum of
      ``exp(j2πfm)``, ``|m| <= N-1``, and the Gauss-Hermite remainder for ``exp(jat)`` is
      ``K! √π a^(2K) / (2^K (2K)!)`` with ``a = 2√2 π σ m <= √2 π``: below 1e-60 for K = 64.
    * wider clutter: the O(N) lag sum with [56], whose output is then far above that floor.

    Parameters
    ----------
    weights : array_like, shape (F..., N)
        Filter weights [1].
    spread_norm : array_like
        Clutter spectrum standard deviation over the PRF, ``σ_s/f_r`` [1], ``>= 0`` (``inf``
        allowed: white clutter).
    mean_norm : array_like, optional
        Clutter mean Doppler over the PRF, ``μ_c/f_r`` [1].

    Returns
    -------
    ndarray, shape (F..., broadcast(spread_norm, mean_norm)), float, ``>= 0``
    """
    w = np.asarray(weights, dtype=np.complex128)
    s, mu = np.broadcast_arrays(
        np.asarray(spread_norm, np.float64), np.asarray(mean_norm, np.float64)
    )
    if np.any(s < 0):
        raise ValueError("spread_norm must be >= 0")
    n = w.shape[-1]
    lead = w.shape[:-1]
    s_flat, mu_flat = s.ravel(), mu.ravel()
    out = np.empty(lead + (s_flat.size,))
    narrow = s_flat * max(n - 1, 1) <= NARROW_SPREAD_TAPS
    idx = np.flatnonzero(narrow)
    if idx.size:
        nodes = mu_flat[idx, None] + np.sqrt(2.0) * s_flat[idx, None] * _GH_NODES
        out[..., idx] = filter_response(w, nodes) @ _GH_WEIGHTS
    idx = np.flatnonzero(~narrow)
    if idx.size:
        cov = clutter_lag_covariance(n, s_flat[idx], mu_flat[idx])
        out[..., idx] = np.maximum(quadratic_form_toeplitz(w, cov), 0.0)
    return out.reshape(lead + s.shape)


# ----------------------------------------------------------------------------- improvement
def _append_axes(a: NDArray, n_lead: int, ndim: int) -> NDArray:
    """Reshape (F..., P...) to (F..., 1.., P...) so that P... right-aligns to ``ndim`` dims."""
    lead, tail = a.shape[:n_lead], a.shape[n_lead:]
    return a.reshape(lead + (1,) * (ndim - len(tail)) + tail)


def _signal_and_clutter(
    weights: NDArray,
    spread_norm: ArrayLike,
    doppler_norm: ArrayLike,
    bandwidth_norm: ArrayLike,
    clutter_mean_norm: ArrayLike,
    stability_limit_db: float,
) -> tuple[NDArray, NDArray, NDArray, tuple[int, ...]]:
    """Signal and clutter output powers with the instability residue, aligned for broadcast."""
    eps = stability_residue(stability_limit_db)
    n_lead = weights.ndim - 1
    signal = signal_output_power(weights, doppler_norm, bandwidth_norm)
    clutter = clutter_output_power(weights, spread_norm, clutter_mean_norm)
    energy = np.sum(np.abs(weights) ** 2, axis=-1)
    full = np.broadcast_shapes(signal.shape[n_lead:], clutter.shape[n_lead:])
    ndim = len(full)
    e = energy.reshape(energy.shape + (1,) * ndim)
    signal = _append_axes(signal, n_lead, ndim) + eps * e
    clutter = _append_axes(clutter, n_lead, ndim) + eps * e
    return signal, clutter, e, full


def improvement_factor(
    weights: ArrayLike,
    spread_norm: ArrayLike,
    doppler_norm: ArrayLike,
    *,
    bandwidth_norm: ArrayLike = 0.0,
    clutter_mean_norm: ArrayLike = 0.0,
    stability_limit_db: float = DEFAULT_STABILITY_LIMIT_DB,
) -> NDArray:
    """Improvement factor of a transversal filter, seed [57] with [55]-[56].

    ``I_F = wᴴ(M_s + εI)w / wᴴ(M_c + εI)w`` with ``ε`` the instability residue (module
    docstring).

    Parameters
    ----------
    weights : array_like, shape (F..., N)
        Weights [1] of one filter (1-D) or of several (leading axes, e.g. a bank (F, N)).
    spread_norm : array_like
        Clutter spectrum standard deviation over the PRF, ``σ_s/f_r`` [1], ``>= 0``.
    doppler_norm : array_like
        Target Doppler (or band centre ``f_i``) over the PRF, ``f_d/f_r`` [1]; periodic.
    bandwidth_norm : array_like, optional
        Uniform Doppler band of the target over the PRF, ``B/f_r`` [1] ([50]-[55]); 0 (default)
        is a point target; 1 averages over all Dopplers (classical MTI improvement factor).
    clutter_mean_norm : array_like, optional
        Clutter mean Doppler over the PRF, ``μ_c/f_r`` [1]; 0 for a clutter-locked MTI ([58]).
    stability_limit_db : float, optional
        System-stability limit of the improvement factor [dB].

    Returns
    -------
    ndarray, shape (F..., broadcast of the other arguments), float
        ``I_F`` [1], linear, finite and positive.  As ``σ_s -> 0`` an MTI tends to
        ``|H(f)|²/(ε Σ|w|²)`` (the stability limit times the filter's coherent gain); a target
        whose spectrum equals the clutter's gets 1; at a blind speed about ``ε``.
    """
    w = np.asarray(weights)
    signal, clutter, _, _ = _signal_and_clutter(
        w, spread_norm, doppler_norm, bandwidth_norm, clutter_mean_norm, stability_limit_db
    )
    ratio: NDArray = signal / clutter
    return ratio


def bank_improvement_factor(
    bank_weights: ArrayLike,
    spread_norm: ArrayLike,
    doppler_norm: ArrayLike,
    *,
    pick: PickRule = "response",
    clutter_mean_norm: ArrayLike = 0.0,
    stability_limit_db: float = DEFAULT_STABILITY_LIMIT_DB,
) -> NDArray:
    """Improvement factor [57] of a point target read from one filter of a bank.

    Parameters
    ----------
    bank_weights : array_like, shape (F, N) or (N,)
        Weights [1] of the ``F`` filters (a 1-D vector is a one-filter bank, e.g. an MTI).
    spread_norm : array_like
        Clutter spectrum standard deviation over the PRF, ``σ_s/f_r`` [1], ``>= 0``.
    doppler_norm : array_like
        Target Doppler over the PRF, ``f_d/f_r`` [1]; periodic with period 1.
    pick : {"response", "best"}
        Which filter the target is read from.  ``"response"`` (default): the filter with the
        largest signal response ``|H_i(f_d)|²`` at the target Doppler, i.e. the filter whose
        passband holds it (ties go to the lowest index); the I_F is that filter's.
        ``"best"``: the filter with the largest I_F (detection in any filter, optimistic).
    clutter_mean_norm : array_like, optional
        Clutter mean Doppler over the PRF, ``μ_c/f_r`` [1].
    stability_limit_db : float, optional
        System-stability limit [dB].

    Returns
    -------
    ndarray, shape broadcast(spread_norm, clutter_mean_norm, doppler_norm), float
        ``I_F`` [1], linear, finite and positive.
    """
    w = np.atleast_2d(np.asarray(bank_weights))
    if w.ndim != 2:
        raise ValueError("bank_weights must have shape (F, N) or (N,)")
    signal, clutter, energy, full = _signal_and_clutter(
        w, spread_norm, doppler_norm, 0.0, clutter_mean_norm, stability_limit_db
    )
    return _pick_filter(signal, clutter, energy, full, pick)


def _pick_filter(
    signal: NDArray, clutter: NDArray, energy: NDArray, full: tuple[int, ...], pick: str
) -> NDArray:
    """Apply the filter-pick rule along axis 0 of broadcast-aligned signal/clutter powers."""
    n_filters = signal.shape[0]
    if pick == "response":
        # compare the responses per unit filter energy, so that the residue (∝ energy) and
        # filters of unequal gain do not bias the choice
        idx = np.argmax(signal / energy, axis=0)
        idx = np.broadcast_to(idx, full)[None]
        s = np.take_along_axis(np.broadcast_to(signal, (n_filters,) + full), idx, axis=0)
        c = np.take_along_axis(np.broadcast_to(clutter, (n_filters,) + full), idx, axis=0)
        picked: NDArray = (s / c)[0]
        return picked
    if pick == "best":
        best = np.zeros(full)
        for i in range(n_filters):
            best = np.maximum(best, signal[i] / clutter[i])
        return best
    raise ValueError(f"pick must be 'response' or 'best', got {pick!r}")


def staggered_improvement_factor(
    bank_weights: ArrayLike,
    spread_norm: ArrayLike,
    doppler_norm: ArrayLike,
    *,
    prf_hz: float,
    stagger_prf_hz: ArrayLike,
    pick: PickRule = "response",
    stability_limit_db: float = DEFAULT_STABILITY_LIMIT_DB,
) -> NDArray:
    """Improvement factor with staggered PRF, seed 5.1.4 (bounds of its Ref. 22).

    The staggered system is bounded by two constant-PRF systems, one at the lowest and one at
    the highest PRF of the stagger; the seed takes their average.  The average is taken in
    linear power: it fills the blind speeds of either PRF, as a staggered waveform does,
    whereas a dB average would keep the deeper null of the two.

    Parameters
    ----------
    bank_weights : array_like, shape (F, N) or (N,)
        Weights [1] of the filter(s), as in :func:`bank_improvement_factor`.
    spread_norm : array_like
        Clutter spread over the *reference* PRF ``prf_hz``, ``σ_s/f_r`` [1], ``>= 0``.
    doppler_norm : array_like
        Target Doppler over the reference PRF, ``f_d/f_r`` [1]; the result is periodic with
        the least common multiple of the two bounding PRFs, not with ``f_r``.
    prf_hz : float
        Reference PRF ``f_r`` that normalizes the two previous arguments [Hz], ``> 0``.
    stagger_prf_hz : array_like
        The PRFs of the stagger [Hz], all ``> 0``; only the lowest and highest matter.
    pick : {"response", "best"}
        Filter-pick rule of :func:`bank_improvement_factor`, applied to each bound.
    stability_limit_db : float, optional
        System-stability limit [dB].

    Returns
    -------
    ndarray, float
        ``(I_F(f_lo) + I_F(f_hi)) / 2`` [1], linear; lies between the two bounds.
    """
    prfs = np.asarray(stagger_prf_hz, dtype=np.float64).ravel()
    if prf_hz <= 0 or prfs.size == 0 or np.any(prfs <= 0):
        raise ValueError("prf_hz and every stagger PRF must be > 0")
    spread = np.asarray(spread_norm, np.float64)
    doppler = np.asarray(doppler_norm, np.float64)
    bounds: list[NDArray] = []
    for f_k in (prfs.min(), prfs.max()):
        scale = prf_hz / f_k
        bounds.append(
            bank_improvement_factor(
                bank_weights,
                spread * scale,
                doppler * scale,
                pick=pick,
                stability_limit_db=stability_limit_db,
            )
        )
    mean: NDArray = 0.5 * (bounds[0] + bounds[1])
    return mean


# ----------------------------------------------------------------------------- weights
def canceller_weights(n_pulses: int) -> NDArray[np.float64]:
    """Weights of an ``n_pulses``-pulse MTI canceller, seed [58].

    ``w_i = (-1)^(i-1) C(n, i-1)``, ``i = 1 .. n+1``, with ``n = n_pulses - 1`` delay stages;
    the response is ``|1 - exp(-j2πf)|^(2n) = (2 sin πf)^(2n)``, centred at ``f_r/2`` with
    nulls (blind speeds) at multiples of ``f_r``.

    Parameters
    ----------
    n_pulses : int
        Number of pulses the canceller processes [1], ``>= 2`` (2: single canceller).

    Returns
    -------
    ndarray, shape (n_pulses,), float (exact integers)
    """
    if int(n_pulses) != n_pulses or n_pulses < 2:
        raise ValueError(f"an MTI canceller processes at least 2 pulses, got {n_pulses}")
    n = int(n_pulses) - 1
    k = np.arange(n + 1)
    coefficients: NDArray[np.float64] = (-1.0) ** k * comb(n, k, exact=False)  # scipy is untyped
    return coefficients


def window_weights(
    name: str,
    n_taps: int,
    *,
    sidelobe_db: float | None = None,
    nbar: int = DEFAULT_TAYLOR_NBAR,
) -> NDArray[np.float64]:
    """Data window ``a(n)`` of seed [62], from ``scipy.signal.windows`` (symmetric form).

    Parameters
    ----------
    name : {"rectangular", "hann", "hamming", "taylor", "chebyshev"}
        Window family (Harris, Proc. IEEE 66(1), 1978).
    n_taps : int
        Number of taps [1], ``>= 1``.
    sidelobe_db : float, optional
        Design sidelobe level below the mainlobe [dB], positive: Taylor ``sll`` (default
        :data:`DEFAULT_TAYLOR_SIDELOBE_DB`, scipy's), Dolph-Chebyshev ``at`` (required).
        Ignored by the other windows.
    nbar : int, optional
        Taylor's number of nearly equal sidelobes [1].

    Returns
    -------
    ndarray, shape (n_taps,), float
        Symmetric (linear-phase) window; only its shape matters to [57].
    """
    n_taps = int(n_taps)
    if n_taps < 1:
        raise ValueError("a window needs at least one tap")
    if name == "rectangular":
        return np.ones(n_taps)
    # imported here: scipy.signal imports scipy.stats (0.3-0.7 s of a run's start-up)
    from scipy.signal import windows as _windows

    window: NDArray[np.float64]  # scipy.signal is untyped
    if name == "hann":
        window = _windows.hann(n_taps, sym=True)
    elif name == "hamming":
        window = _windows.hamming(n_taps, sym=True)
    elif name == "taylor":
        sll = DEFAULT_TAYLOR_SIDELOBE_DB if sidelobe_db is None else float(sidelobe_db)
        if sll <= 0:
            raise ValueError("Taylor sidelobe_db must be > 0 dB (a level below the mainlobe)")
        window = _windows.taylor(n_taps, nbar=int(nbar), sll=sll, norm=True, sym=True)
    elif name == "chebyshev":
        if sidelobe_db is None or sidelobe_db <= 0:
            raise ValueError("the Chebyshev window needs sidelobe_db > 0 dB")
        window = _windows.chebwin(n_taps, at=float(sidelobe_db), sym=True)
    else:
        raise ValueError(f"unknown window {name!r}; choose one of {WINDOWS}")
    return window


def filter_centres_norm(n_filters: int) -> NDArray[np.float64]:
    """Centres of the filters of a bank over the PRF, seed [60]: ``f_i = (i-1)/N``.

    Parameters
    ----------
    n_filters : int
        Number of filters ``N`` [1], ``>= 1``.

    Returns
    -------
    ndarray, shape (n_filters,)
        ``f_i/f_r`` [1] in ``[0, 1)``; filter 0 is centred on zero Doppler (the clutter).
    """
    if int(n_filters) < 1:
        raise ValueError("a bank needs at least one filter")
    return np.arange(int(n_filters)) / int(n_filters)


def bank_weights(
    n_taps: int,
    n_filters: int | None = None,
    *,
    window: str = "rectangular",
    sidelobe_db: float | None = None,
    nbar: int = DEFAULT_TAYLOR_NBAR,
) -> NDArray[np.complexfloating]:
    """Weights of a windowed bank of Doppler filters, seed [59]-[60] and [62].

    ``w_{i,n} = a(n) exp(-j2π f_i n)``, ``n = 0 .. n_taps-1``, ``f_i = i/n_filters``.  With
    ``n_filters == n_taps`` and a rectangular window this is the DFT bank [59]; otherwise an FIR
    bank of identical, shifted filters.

    Parameters
    ----------
    n_taps : int
        Number of pulses (taps) each filter processes [1], ``>= 1``.
    n_filters : int, optional
        Number of filters [1], default ``n_taps``.
    window, sidelobe_db, nbar
        The data window [62], see :func:`window_weights`.

    Returns
    -------
    ndarray, shape (n_filters, n_taps), complex
    """
    n_filters = int(n_taps) if n_filters is None else int(n_filters)
    a = window_weights(window, n_taps, sidelobe_db=sidelobe_db, nbar=nbar)
    f = filter_centres_norm(n_filters)
    n = np.arange(int(n_taps))
    rotation: NDArray[np.complex128] = np.exp(-2j * np.pi * np.mod(f[:, None] * n[None, :], 1.0))
    return a[None, :] * rotation


def cascade_weights(mti_weights: ArrayLike, bank: ArrayLike) -> NDArray:
    """Weights of an MTI canceller cascaded with a bank of filters, seed [61].

    SPEC §4 item 4: the dimensions of [61] as printed do not match; the cascade of two
    transversal filters is the convolution of their weights, ``w = a * b`` (length
    ``M + N_b - 1``), i.e. [61]'s banded matrix of the ``a`` with ``M + N_b - 1`` rows and
    ``N_b`` columns applied to ``b``.  Its response is the product of the two responses.

    Parameters
    ----------
    mti_weights : array_like, shape (M,)
        MTI weights ``a`` [1] (e.g. :func:`canceller_weights`).
    bank : array_like, shape (F, N_b) or (N_b,)
        Bank weights ``b`` [1], one row per filter.

    Returns
    -------
    ndarray, shape (F, M + N_b - 1) (or 1-D for a 1-D ``bank``)
    """
    a = np.asarray(mti_weights)
    b = np.asarray(bank)
    if a.ndim != 1:
        raise ValueError("mti_weights must be 1-D")
    if b.ndim == 1:
        return np.convolve(a, b)
    return np.stack([np.convolve(a, row) for row in b])


# ----------------------------------------------------------------------------- separation
def doppler_filter_index(fd_hz: ArrayLike, prf_hz: ArrayLike, n_filters: int) -> NDArray[np.int64]:
    """Index of the bank filter whose passband holds a Doppler (seed 2.2.1 separation).

    The Doppler is folded by the PRF (Doppler ambiguity) and assigned to the nearest filter
    centre ``f_i = i f_r / N`` [60], i.e. to the band ``[f_i - f_r/2N, f_i + f_r/2N)``.  Two
    targets in one range-azimuth cell are separated when their indices differ.  For banks whose
    filters overlap (DFT banks, ``n_filters >= n_taps``) this is also the filter of largest
    response, the table's pick rule.

    Parameters
    ----------
    fd_hz : array_like
        Target Doppler [Hz], finite, any sign (use the same reference, e.g. relative to the
        clutter mean, as for the improvement-factor lookup).
    prf_hz : array_like
        Pulse repetition frequency [Hz], ``> 0`` (the nominal one for a staggered radar).
    n_filters : int
        Number of Doppler filters [1], ``>= 1``.  An MTI-only radar has one filter: every
        Doppler gets index 0 and targets are never separated.

    Returns
    -------
    ndarray of int, in ``[0, n_filters)``
    """
    fd = np.asarray(fd_hz, dtype=np.float64)
    prf = np.asarray(prf_hz, dtype=np.float64)
    n = int(n_filters)
    if n < 1:
        raise ValueError("n_filters must be >= 1")
    # every fd finite exactly when its least and greatest are (NaN propagates through both)
    if (np.any(prf <= 0) or (fd.size and not (np.isfinite(fd.min()) and np.isfinite(fd.max())))
            or not np.all(np.isfinite(prf))):
        raise ValueError("fd_hz must be finite and prf_hz finite and > 0")
    # mod(floor(mod(fd / prf, 1) n + 0.5), n) on one temporary, without np.mod (~16 ns an
    # element; the clutter false alarms' millions pass here).  For finite q, q - floor(q) is
    # np.mod(q, 1.0) bit for bit (both the once-rounded exact fraction: fmod is exact, and
    # for q < 0 numpy adds 1 to it; a zero is +0.0 either way), and the rounded index is an
    # integer in [0, n], of which only n folds (to 0).
    q = np.asarray(fd / prf, dtype=np.float64)
    q -= np.floor(q)
    q *= n
    q += 0.5
    np.floor(q, out=q)
    index = q.astype(np.int64)
    if index.ndim == 1:
        # the indices equal to n (a Doppler just below a multiple of the PRF) set through
        # their positions: a boolean-mask assignment costs ~4 ns an element on a mask as
        # irregular as the clutter false alarms' (many just below zero Doppler)
        index[np.flatnonzero(index == n)] = 0
        return index
    index[index == n] = 0
    return index if index.ndim else index[()]


# ----------------------------------------------------------------------------- [63]-[65]
def distribution_loss_db(
    improvement_db: ArrayLike,
    median_mean_difference_db: ArrayLike,
    applies: ArrayLike = True,
) -> NDArray:
    """Clutter distribution loss ``L_d``, seed [63]-[64] (after Schleher's Fig. 1, Ref. 24).

    ``L_d0 = 15 (1 - exp(-d_mm/8.45)) - 5`` [64]; ``L_d = L_d0`` for ``I_F < 20 dB`` and
    ``L_d0 exp(-(I_F - 20)²/100)`` above [63] (continuous at 20 dB).  Edges:

    * [64] is negative for ``d_mm < 8.45 ln 1.5 ≈ 3.43 dB``, which would be a gain; it is
      clamped at 0 dB.  Rayleigh clutter (``d_mm = -10 log10(ln 2) ≈ 1.59 dB``) therefore has
      no loss, as it should.
    * [63] is stated for ``0 < I_F``; ``I_F <= 0 dB`` takes ``L_d0`` like the rest of the
      low branch.

    Parameters
    ----------
    improvement_db : array_like
        Improvement factor ``I_F`` [dB].
    median_mean_difference_db : array_like
        Mean minus median clutter return ``d_mm`` [dB], ``>= 0`` (from [30]); a negative value
        (a median above the mean) is a sign error and raises ``ValueError``.
    applies : array_like of bool, optional
        Where the loss applies: sea clutter dominant and a medium-to-high resolution radar
        (seed 4.1.2, 5.2).  Elsewhere ``L_d = 0 dB``.

    Returns
    -------
    ndarray
        ``L_d`` [dB], ``>= 0``.
    """
    i_db = np.asarray(improvement_db, dtype=np.float64)
    d_db = np.asarray(median_mean_difference_db, dtype=np.float64)
    if np.any(d_db < 0):
        raise ValueError("median_mean_difference_db is mean minus median and must be >= 0 dB")
    l0_db = np.maximum(
        -DISTRIBUTION_LOSS_AMPLITUDE_DB * np.expm1(-d_db / DISTRIBUTION_LOSS_SCALE_DB)
        - DISTRIBUTION_LOSS_OFFSET_DB,
        0.0,
    )
    excess_db = np.maximum(i_db - DISTRIBUTION_LOSS_KNEE_DB, 0.0)
    loss_db = l0_db * np.exp(-(excess_db**2) / DISTRIBUTION_LOSS_DECAY_DB2)
    return np.where(np.asarray(applies, dtype=bool), loss_db, 0.0)


def processing_gain(improvement: ArrayLike, distribution_loss: ArrayLike = 1.0) -> NDArray:
    """Processing gain of the video stage, seed [65]: ``G_p = I_F / L_d``.

    Parameters
    ----------
    improvement : array_like
        Improvement factor ``I_F`` [1], linear, ``> 0``.
    distribution_loss : array_like, optional
        Clutter distribution loss ``L_d`` [1], linear, ``>= 1`` (1 when it does not apply).

    Returns
    -------
    ndarray
        ``G_p`` [1], linear.
    """
    return np.asarray(improvement, dtype=np.float64) / np.asarray(
        distribution_loss, dtype=np.float64
    )


def processing_gain_db(improvement_db: ArrayLike, distribution_loss_db: ArrayLike = 0.0) -> NDArray:
    """Processing gain [65] in dB: ``G_p = I_F - L_d`` [dB].

    Parameters
    ----------
    improvement_db : array_like
        Improvement factor ``I_F`` [dB].
    distribution_loss_db : array_like, optional
        Clutter distribution loss ``L_d`` [dB] (:func:`distribution_loss_db`).

    Returns
    -------
    ndarray
        ``G_p`` [dB].
    """
    return np.asarray(improvement_db, dtype=np.float64) - np.asarray(
        distribution_loss_db, dtype=np.float64
    )
