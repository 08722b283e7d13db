"""Target echo power, system noise and S/N at IF: seed [2]-[3] and [17]-[20].

Reference temperatures and the seed's typical losses are named once here; the other
modules import them.  Losses are power ratios ≥ 1 inside the functions; the ``_DB``
constants are the seed's values in dB (scenario defaults, see
``shipradar.sim.world.scenario.Losses``).

Choices where the seed is silent (SPEC §4 item 21)
-------------------------------------------------
T'_a, the sky temperature of Blake's Fig. 4.8, is computed, not read from a figure, by
radiative transfer through the model atmosphere of :mod:`shipradar.sensors.atmosphere` (ITU-R
P.372-16 §5: ``T_b = ∫ T(s) dA(s) + T_ext e^{-τ}``), with the ITU-R P.835 lapse rate for the air
temperature, the 2.725 K cosmic background and the median galactic noise of ITU-R P.372-16
eq. (13), ``F_am = 52 - 23 log10 f[MHz]`` dB above k T0 b, extended above 100 MHz with the
same power law (the straight galactic line of Blake 1986 Fig. 4.8; under 1 K above 3 GHz).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from shipradar.sensors import atmosphere

#: Reference temperature T0 of noise figures and of [17]-[18] [K].
T0_K = 290.0
#: Thermal temperature of the transmission line T_t of [17] (the seed: 290 K) [K].
T_LINE_K = T0_K
#: Cosmic microwave background temperature [K] (Fixsen 2009, ApJ 707, 916).
T_COSMIC_K = 2.725
#: ITU-R P.372-16 eq. (13): galactic noise F_am = A - B log10(f / 1 MHz) [dB].
GALACTIC_FAM_1MHZ_DB = 52.0
GALACTIC_FAM_SLOPE_DB = 23.0
#: ITU-R P.835-6 mean annual reference atmosphere: lapse rate [K/m] up to the tropopause [m].
LAPSE_RATE_K_PER_M = 6.5e-3
TROPOPAUSE_HEIGHT_M = 11_000.0
#: Height where the sky-noise integral stops (gases are negligible above) [m].
ATMOSPHERE_TOP_M = 100_000.0
#: Blake [18]: fraction of the pattern that sees the sky, and 0.124·290 K - 290 K = -254 K.
BLAKE_SKY_FRACTION = 0.876
BLAKE_OFFSET_K = 254.0

#: Seed 3.3 typical losses [dB]: range gate (Blake p. 414), limiter (Nathanson p. 477),
#: matching (Blake p. 334).
L_G_DB = 2.0
L_L_DB = 2.0
L_M_DB = 1.0
#: L_x = L_g L_l L_m of [20] [dB].
L_X_DB = L_G_DB + L_L_DB + L_M_DB
#: [46]: L_c = L_x + 1 dB in clutter [dB].
L_C_EXTRA_DB = 1.0
L_C_DB = L_X_DB + L_C_EXTRA_DB
#: [48]: L_j = L_x [dB].
L_J_DB = L_X_DB
#: [66]-[67]: CFAR loss, clutter distribution loss, beam-shape loss [dB].
L_CFAR_DB = 1.5
L_CD_DB = 2.0
L_B_DB = 1.6

#: Smallest range used by the R^-4 and R^-2 laws [m] (a numerical floor: the echo from
#: inside the eclipsed zone c τ/2 never reaches the detector, the dwell processor blanks it).
MIN_RANGE_M = 1.0


def power_ratio(value_db: ArrayLike) -> NDArray[np.float64]:
    """Linear power ratio of a value in dB: ``10^(x/10)``.

    Parameters
    ----------
    value_db : array_like
        Ratio [dB].
    """
    return 10.0 ** (np.asarray(value_db, dtype=np.float64) / 10.0)


#: Smallest power ratio :func:`db` takes the logarithm of: -300 dB, so zero powers stay finite.
DB_FLOOR = 1e-30


def db(x: ArrayLike) -> NDArray[np.float64]:
    """10 log10 of a power ratio [dB], floored at -300 dB so that zero powers stay finite."""
    return 10.0 * np.log10(np.maximum(x, DB_FLOOR))


def processing_loss(
    l_g_db: ArrayLike = L_G_DB, l_l_db: ArrayLike = L_L_DB, l_m_db: ArrayLike = L_M_DB
) -> NDArray[np.float64]:
    """L_x = L_g L_l L_m of [20] as a power ratio.

    Parameters
    ----------
    l_g_db, l_l_db, l_m_db : array_like, optional
        Range-gate, limiter/quantization and matching losses [dB] (seed: 2, 2, 1).
    """
    return power_ratio(np.asarray(l_g_db) + np.asarray(l_l_db) + np.asarray(l_m_db))


def receive_loss(l_tr: ArrayLike) -> NDArray[np.float64]:
    """Receive loss L_r of [17], "taken to be 1/2 L_tr".

    Read as half of the transmit/receive loss *in dB*, ``L_r(dB) = L_tr(dB)/2``, i.e.
    ``L_r = sqrt(L_tr)`` (a loss split evenly between the two ways); half of the linear
    ratio would be a gain below 3 dB.

    Parameters
    ----------
    l_tr : array_like
        L_t/r, two-way transmit/receive loss (power ratio ≥ 1).

    Returns
    -------
    ndarray
        L_r (power ratio ≥ 1).
    """
    return np.sqrt(np.asarray(l_tr, dtype=np.float64))


def system_noise_temperature_k(
    antenna_temperature_k: ArrayLike,
    l_r: ArrayLike,
    noise_figure: ArrayLike,
    t_line_k: ArrayLike = T_LINE_K,
) -> NDArray[np.float64]:
    """System noise temperature, seed [17] (Blake 1986 p. 152).

    ``T_s = T_a + T_t (L_r - 1) + L_r T0 (N_f - 1)``.

    Parameters
    ----------
    antenna_temperature_k : array_like
        T_a [K] ([18], :func:`antenna_temperature_k`).
    l_r : array_like
        Receive loss L_r (power ratio ≥ 1, :func:`receive_loss`).
    noise_figure : array_like
        Receiver noise figure N_f (power ratio ≥ 1).
    t_line_k : array_like, optional
        Line temperature T_t [K].

    Returns
    -------
    ndarray
        T_s [K]; equals T_a for a lossless line and a noiseless receiver.
    """
    lr = np.asarray(l_r, dtype=np.float64)
    return (
        np.asarray(antenna_temperature_k, dtype=np.float64)
        + np.asarray(t_line_k, dtype=np.float64) * (lr - 1.0)
        + lr * T0_K * (np.asarray(noise_figure, dtype=np.float64) - 1.0)
    )


def antenna_temperature_k(
    sky_temperature_k: ArrayLike, l_a: ArrayLike = 1.0
) -> NDArray[np.float64]:
    """Antenna noise temperature, seed [18] (Blake 1986 p. 172).

    ``T_a = (0.876 T'_a - 254)/L_a + 290``: 87.6 % of the pattern sees the sky at T'_a and
    12.4 % the sea at 290 K; an antenna dissipation loss L_a adds 290 (1 - 1/L_a).

    Parameters
    ----------
    sky_temperature_k : array_like
        T'_a [K] (:func:`sky_temperature_k`).
    l_a : array_like, optional
        Antenna dissipation loss L_a (power ratio ≥ 1; ≅ 1 for reflectors, seed).

    Returns
    -------
    ndarray
        T_a [K] (36 K + 0.876 T'_a for L_a = 1; tends to 290 K as L_a grows).
    """
    return (
        BLAKE_SKY_FRACTION * np.asarray(sky_temperature_k, dtype=np.float64) - BLAKE_OFFSET_K
    ) / (np.asarray(l_a, dtype=np.float64)) + T0_K


def galactic_noise_temperature_k(freq_hz: ArrayLike) -> NDArray[np.float64]:
    """Median galactic noise temperature, ITU-R P.372-16 eq. (13).

    ``T_gal = T0 10^{F_am/10}``, ``F_am = 52 - 23 log10(f/1 MHz)``.

    Parameters
    ----------
    freq_hz : array_like
        Frequency [Hz], > 0.  P.372 states the law up to ~100 MHz; it is extended with the
        same power law above (f^-2.3: 5.8 K at 1 GHz, 0.03 K at 10 GHz).

    Returns
    -------
    ndarray
        T_gal [K].
    """
    f_mhz = np.asarray(freq_hz, dtype=np.float64) / constants.mega
    fam_db = GALACTIC_FAM_1MHZ_DB - GALACTIC_FAM_SLOPE_DB * np.log10(f_mhz)
    return T0_K * power_ratio(fam_db)


# long: 35 docstring lines; the radiative-transfer integral and its quadrature in one place
def sky_temperature_k(
    freq_hz: float,
    elevation_rad: ArrayLike,
    *,
    surface_temperature_k: float = atmosphere.STANDARD_TEMPERATURE_K,
    pressure_hpa: float = atmosphere.STANDARD_PRESSURE_HPA,
    water_vapour_density_g_m3: float = atmosphere.STANDARD_WATER_VAPOUR_G_M3,
    lapse_rate_k_per_m: float = LAPSE_RATE_K_PER_M,
    antenna_height_m: float = 0.0,
    include_galactic: bool = True,
) -> NDArray[np.float64]:
    """Sky noise temperature T'_a seen by a lossless antenna (Blake's Fig. 4.8 quantity).

    ITU-R P.372-16 §5 radiative transfer along the slant path of
    :mod:`shipradar.sensors.atmosphere`: ``T'_a = ∫_0^S T(h(s)) κ(s) e^{-τ(s)} ds + (T_cosmic +
    T_gal) e^{-τ(S)}``, with κ the gaseous absorption (P.676 with the P.676 Annex 2 exponential
    profiles), τ its running integral, T(h) = T_surface - Γ min(h, 11 km) (ITU-R P.835), S the path
    to 100 km.

    Parameters
    ----------
    freq_hz : float
        Frequency [Hz].
    elevation_rad : array_like
        Beam elevation [rad].  Negative elevations are evaluated at 0: the part of the
        pattern that sees the sea is Blake's 12.4 % at 290 K in [18].
    surface_temperature_k, pressure_hpa, water_vapour_density_g_m3 : float, optional
        Surface meteorology [K], [hPa], [g/m³].
    lapse_rate_k_per_m : float, optional
        Temperature lapse rate Γ [K/m]; 0 gives an isothermal atmosphere, for which the
        result is exactly ``T_s (1 - 1/L) + T_ext/L`` (L the total one-way loss).
    antenna_height_m : float, optional
        Antenna height [m].
    include_galactic : bool, optional
        Add the galactic noise (False: cosmic background only).

    Returns
    -------
    ndarray
        T'_a [K], between the external temperature (zenith, transparent air) and the air
        temperature (opaque air, near 60 GHz or along the horizon at high frequencies).

    Notes
    -----
    Per scene, not per dwell: the nested quadrature holds 120 × 120 points per elevation.
    """
    el = np.maximum(np.asarray(elevation_rad, dtype=np.float64), 0.0)
    go, gw = atmosphere.gaseous_specific_attenuation_db_per_km(
        freq_hz,
        temperature_k=surface_temperature_k,
        pressure_hpa=pressure_hpa,
        water_vapour_density_g_m3=water_vapour_density_g_m3,
    )
    ho, hw = atmosphere.gaseous_equivalent_heights_m(
        freq_hz,
        temperature_k=surface_temperature_k,
        pressure_hpa=pressure_hpa,
        water_vapour_density_g_m3=water_vapour_density_g_m3,
    )
    # Absorption coefficient [Np/m of power] from dB/km.
    np_per_m_per_db_per_km = np.log(10.0) / 10.0 / constants.kilo

    def kappa(
        s: NDArray[np.float64], e: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        h: NDArray[np.float64] = np.maximum(atmosphere.path_height_m(s, e, antenna_height_m), 0.0)
        k: NDArray[np.float64] = (
            go * np.exp(-h / ho) + gw * np.exp(-h / hw)
        ) * np_per_m_per_db_per_km
        return k, h

    top = atmosphere.layer_path_length_m(1.0e9, el, ATMOSPHERE_TOP_M, antenna_height_m)
    s, w = atmosphere.path_quadrature(top)  # (..., n)
    k_s, h_s = kappa(s, el[..., None])
    # Optical depth from the antenna to every node: a nested quadrature on [0, s_i].
    s2, w2 = atmosphere.path_quadrature(s)  # (..., n, n)
    k_inner, _ = kappa(s2, el[..., None, None])
    tau_s = np.sum(w2 * k_inner, axis=-1)
    tau_total: NDArray[np.float64] = np.sum(w * k_s, axis=-1)
    t_air = surface_temperature_k - lapse_rate_k_per_m * np.minimum(h_s, TROPOPAUSE_HEIGHT_M)
    emission: NDArray[np.float64] = np.sum(w * t_air * k_s * np.exp(-tau_s), axis=-1)
    t_ext = T_COSMIC_K + (galactic_noise_temperature_k(freq_hz) if include_galactic else 0.0)
    return emission + t_ext * np.exp(-tau_total)


def noise_bandwidth_hz(compressed_pulse_width_s: ArrayLike) -> NDArray[np.float64]:
    """Noise bandwidth of [19], ``B_N = 1/τ'`` (seed 3.2).

    Parameters
    ----------
    compressed_pulse_width_s : array_like
        τ', compressed pulse width [s], > 0.
    """
    return 1.0 / np.asarray(compressed_pulse_width_s, dtype=np.float64)


def range_cell_m(compressed_pulse_width_s: ArrayLike) -> NDArray[np.float64]:
    """Range cell ``C_R = c τ'/2`` [m] (seed 4.1.4).

    Parameters
    ----------
    compressed_pulse_width_s : array_like
        τ', compressed pulse width [s], > 0.
    """
    c_r: NDArray[np.float64] = (  # scipy.constants is untyped
        constants.c * np.asarray(compressed_pulse_width_s, dtype=np.float64) / 2.0)
    return c_r


def noise_power_w(system_temperature_k: ArrayLike, bandwidth_hz: ArrayLike) -> NDArray[np.float64]:
    """Thermal noise power at the IF output, seed [19]: ``N0' = k T_s B_N``.

    Parameters
    ----------
    system_temperature_k : array_like
        T_s [K].
    bandwidth_hz : array_like
        B_N [Hz].

    Returns
    -------
    ndarray
        N0' [W] (k T0 B = -114 dBm for 290 K and 1 MHz).
    """
    n0: NDArray[np.float64] = (  # scipy.constants is untyped
        constants.k
        * np.asarray(system_temperature_k, dtype=np.float64)
        * np.asarray(bandwidth_hz, dtype=np.float64)
    )
    return n0


def radar_constant(
    p_t_w: ArrayLike,
    gain: ArrayLike,
    wavelength_m: ArrayLike,
    l_tr: ArrayLike,
    l_atm: ArrayLike = 1.0,
) -> NDArray[np.float64]:
    """Radar constant, seed [3]: ``K_r = P_t G² λ² / ((4π)³ L_t/r L_atm²)``.

    Parameters
    ----------
    p_t_w : array_like
        P_t, transmitted pulse power [W].
    gain : array_like
        G, maximum antenna gain (power ratio).
    wavelength_m : array_like
        λ [m].
    l_tr : array_like
        L_t/r, transmit/receive loss (power ratio ≥ 1).
    l_atm : array_like, optional
        One-way atmospheric loss L_atm of [16] (power ratio ≥ 1); squared for two ways.

    Returns
    -------
    ndarray
        K_r [W m²].
    """
    lam = np.asarray(wavelength_m, dtype=np.float64)
    g = np.asarray(gain, dtype=np.float64)
    return (
        np.asarray(p_t_w, dtype=np.float64)
        * g
        * g
        * lam
        * lam
        / (
            (4.0 * np.pi) ** 3
            * np.asarray(l_tr, dtype=np.float64)
            * np.asarray(l_atm, dtype=np.float64) ** 2
        )
    )


def received_power(
    k_r: ArrayLike,
    sigma_m2: ArrayLike,
    f: ArrayLike,
    range_m: ArrayLike,
    *,
    min_range_m: float = MIN_RANGE_M,
) -> NDArray[np.float64]:
    """Echo power at the RF input, seed [2]: ``P_r = K_r σ F⁴ / R⁴``.

    Parameters
    ----------
    k_r : array_like
        Radar constant [W m²] (:func:`radar_constant`).
    sigma_m2 : array_like
        σ [m²].
    f : array_like
        Propagation factor F (field ratio, includes the antenna directivity g, seed 3.1.2).
    range_m : array_like
        Slant range R [m].
    min_range_m : float, optional
        R is floored here (SPEC §4 item 13): [2] diverges at R -> 0, where it is meaningless
        anyway (near field, eclipsed zone).  The floor keeps the result finite; the dwell
        processor does not detect inside the eclipsed zone c τ/2.

    Returns
    -------
    ndarray
        P_r [W], finite, ∝ R⁻⁴ above the floor.
    """
    r = np.maximum(np.asarray(range_m, dtype=np.float64), min_range_m)
    f2 = np.asarray(f, dtype=np.float64) ** 2
    power: NDArray[np.float64] = (
        np.asarray(k_r, dtype=np.float64) * np.asarray(sigma_m2, dtype=np.float64) * f2 * f2 / r**4
    )
    return power


def signal_to_noise(
    p_r_w: ArrayLike, n0_w: ArrayLike, l_x: ArrayLike | None = None
) -> NDArray[np.float64]:
    """S/N at the IF output, seed [20]: ``S/N = P_r / (N0' L_x)``.

    Parameters
    ----------
    p_r_w : array_like
        P_r [W].
    n0_w : array_like
        N0' [W], > 0 (:func:`noise_power_w`).
    l_x : array_like, optional
        L_x = L_g L_l L_m (power ratio); default the seed's 5 dB (:data:`L_X_DB`).

    Returns
    -------
    ndarray
        S/N (power ratio).
    """
    lx = power_ratio(L_X_DB) if l_x is None else np.asarray(l_x, dtype=np.float64)
    return np.asarray(p_r_w, dtype=np.float64) / (np.asarray(n0_w, dtype=np.float64) * lx)
