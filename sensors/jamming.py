"""Stand-off noise jamming, seed section 4.2, equations [47]-[48].

[47] as printed: ``P_j = P_jt G_r G_j L_sl B λ² F_j² / ((4π)² R_j² L_r L_atm B_j)``.

Choices (the seed is terse or wrong here)
----------------------------------------
* ``G_r L_sl``, the receive gain times a constant azimuth sidelobe level, becomes the
  radar's actual pattern toward the jammer: ``G g_az(Δθ)² g_el(φ_j)²`` with the field
  factors of :mod:`shipradar.sensors.antenna` (Δθ the azimuth from the beam axis to the jammer, φ_j
  the jammer's elevation).  When the rotating beam sweeps across the jammer the same
  formula gives main-beam jamming, with no special case.  ``sidelobe_floor`` (a power ratio
  relative to the main beam) keeps the seed's constant L_sl as a lower bound, so a Gaussian
  pattern (no sidelobes) or an exact sinc null does not make the jammer vanish; pass
  antenna factors computed with ``envelope=True`` for the sidelobe peak envelope.
* ``B``, printed "radar beamwidth", is the radar receiver (noise) bandwidth B_N = 1/τ': the
  ratio B/B_j is the fraction of the jammer's noise that falls in the receiver, which only
  makes sense for two bandwidths.  The ratio is capped at 1: a jammer narrower than the
  receiver (spot jamming) puts all its power in the band, not more.
* F_j is the one-way propagation factor (field), L_atm the one-way atmospheric loss, L_r the
  receive loss of [17] (:func:`shipradar.sensors.noise.receive_loss`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shipradar.sensors.noise import L_J_DB, MIN_RANGE_M, power_ratio


def bandwidth_ratio(
    radar_bandwidth_hz: ArrayLike, jammer_bandwidth_hz: ArrayLike
) -> NDArray[np.float64]:
    """Fraction of the jammer's noise power inside the radar receiver, ``min(B/B_j, 1)``.

    Parameters
    ----------
    radar_bandwidth_hz : array_like
        B, radar receiver noise bandwidth [Hz] (1/τ').
    jammer_bandwidth_hz : array_like
        B_j, jammer noise bandwidth [Hz], > 0.

    Returns
    -------
    ndarray
        Ratio in (0, 1].
    """
    return np.minimum(
        np.asarray(radar_bandwidth_hz, dtype=np.float64)
        / np.asarray(jammer_bandwidth_hz, dtype=np.float64),
        1.0,
    )


# long: 42 docstring lines; [47]'s factors in one expression
# params: [47]'s physical factors, each an input with its unit
def jammer_power_w(
    p_jt_w: ArrayLike,
    g_j: ArrayLike,
    gain: ArrayLike,
    g_az: ArrayLike,
    g_el: ArrayLike,
    wavelength_m: ArrayLike,
    range_m: ArrayLike,
    radar_bandwidth_hz: ArrayLike,
    jammer_bandwidth_hz: ArrayLike,
    *,
    f_j: ArrayLike = 1.0,
    l_r: ArrayLike = 1.0,
    l_atm: ArrayLike = 1.0,
    sidelobe_floor: ArrayLike = 0.0,
    min_range_m: float = MIN_RANGE_M,
) -> NDArray[np.float64]:
    """Noise jamming power received from a stand-off jammer, seed [47].

    ``P_j = P_jt G_j G max(g_az² g_el², L_sl) min(B/B_j, 1) λ² F_j² / ((4π)² R_j² L_r L_atm)``.

    Vectorized: broadcast jammers against dwells (e.g. shape (n_dwell, n_jammer)) and sum
    over the jammer axis for the total.

    Parameters
    ----------
    p_jt_w : array_like
        P_jt, jammer transmitted power [W].
    g_j : array_like
        G_j, jammer antenna gain toward the radar (power ratio).
    gain : array_like
        G, radar maximum antenna gain (power ratio).
    g_az, g_el : array_like
        Radar directivity FIELD factors toward the jammer, azimuth and elevation
        (:func:`shipradar.sensors.antenna.directivity`,
        :func:`~shipradar.sensors.antenna.elevation_directivity`).
    wavelength_m : array_like
        λ [m].
    range_m : array_like
        R_j, radar-jammer range [m]; floored at ``min_range_m``.
    radar_bandwidth_hz, jammer_bandwidth_hz : array_like
        B and B_j [Hz] (:func:`bandwidth_ratio`).
    f_j : array_like, optional
        One-way propagation factor radar-jammer (field ratio).
    l_r : array_like, optional
        Receive loss L_r (power ratio ≥ 1).
    l_atm : array_like, optional
        One-way atmospheric loss (power ratio ≥ 1).
    sidelobe_floor : array_like, optional
        L_sl, lowest two-axis power pattern level relative to the main beam (power ratio,
        e.g. ``power_ratio(-40)``); 0: the pattern alone.
    min_range_m : float, optional
        Range floor [m] (SPEC §4 item 13).

    Returns
    -------
    ndarray
        P_j [W], ≥ 0, ∝ R_j⁻².
    """
    pattern = np.maximum(
        np.asarray(g_az, dtype=np.float64) ** 2 * np.asarray(g_el, dtype=np.float64) ** 2,
        np.asarray(sidelobe_floor, dtype=np.float64),
    )
    lam = np.asarray(wavelength_m, dtype=np.float64)
    r = np.maximum(np.asarray(range_m, dtype=np.float64), min_range_m)
    return (
        np.asarray(p_jt_w, dtype=np.float64)
        * np.asarray(g_j, dtype=np.float64)
        * np.asarray(gain, dtype=np.float64)
        * pattern
        * bandwidth_ratio(radar_bandwidth_hz, jammer_bandwidth_hz)
        * lam
        * lam
        * np.asarray(f_j, dtype=np.float64) ** 2
        / (
            (4.0 * np.pi) ** 2
            * r
            * r
            * np.asarray(l_r, dtype=np.float64)
            * np.asarray(l_atm, dtype=np.float64)
        )
    )


def signal_to_jamming(
    p_r_w: ArrayLike, p_j_w: ArrayLike, l_j: ArrayLike | None = None
) -> NDArray[np.float64]:
    """Signal-to-jamming ratio at the IF output, seed [48]: ``S/J = P_r / (P_j L_j)``.

    Parameters
    ----------
    p_r_w : array_like
        P_r, target echo power [W].
    p_j_w : array_like
        P_j, total jamming power [W] (sum over jammers); 0 gives ``inf`` (no jamming).
    l_j : array_like, optional
        L_j = L_x (power ratio); default the seed's 5 dB.

    Returns
    -------
    ndarray
        S/J (power ratio), ``inf`` where P_j = 0.
    """
    lj = power_ratio(L_J_DB) if l_j is None else np.asarray(l_j, dtype=np.float64)
    pr = np.asarray(p_r_w, dtype=np.float64)
    pj = np.asarray(p_j_w, dtype=np.float64) * lj
    pr, pj = np.broadcast_arrays(pr, pj)
    out = np.full(pr.shape, np.inf)
    np.divide(pr, pj, out=out, where=pj > 0.0)
    return out
