"""Sea clutter, seed section 4.1.1-4.1.3 and 4.1.6, equations [21]-[38] and [46].

Contents, in the seed's order:

* geometry on a spherical effective earth: grazing and depression angle, slant range and the
  inverse (ground range at a given grazing angle);
* the GIT mean reflectivity σ0 (Horst, Dyer & Tuley 1978), the model the seed names but does
  not give (SPEC §4 item 18);
* the seed's empirical ducting extension σ0* [22]-[29];
* the power of the clutter in a range cell [21];
* the Weibull skewness a [30]-[32] (VP), the HP heuristic of 4.1.2, the resolution condition
  and the median-mean difference used by the distribution loss [64];
* the clutter spectrum [33]-[38];
* S/C [46].

Units: SI and linear at every interface; the seed's kilometres and GHz ([22]-[29]) and its dB
([22], [30], [32]) are converted inside.  Every name holding a dB value ends in ``_db``.

The GIT model
-------------
Published by Horst, Dyer & Tuley, "Radar sea clutter model", Proc. IEEE/AP-S Int. Conf. on
Antennas and Propagation, 1978, and reproduced in Long, *Radar Reflectivity of Land and Sea*,
3rd ed. (Artech, 2001), in Antipov, *Simulation of Sea Clutter Returns*, DSTO-TR-0679 (1998),
and in Gregers-Hansen & Mital, *An Empirical Sea Clutter Model for Low Grazing Angles*, IEEE
Radar Conf. 2009 / NRL MR-5310-12-9346 (2012).  With λ [m], ψ the grazing angle [rad], φ the
look direction relative to the wind (0 = looking into the wind, upwind), V_w the wind speed
[m/s] and h_av the average wave height [m]:

    σ_φ = (14.4 λ + 5.5) ψ h_av / λ                      roughness
    A_i = σ_φ⁴ / (1 + σ_φ⁴)                              interference (multipath) factor

1-10 GHz::

    A_u = exp[0.2 cos φ (1 - 2.8 ψ) (λ + 0.015)^-0.4]    upwind/downwind factor
    A_w = [1.94 V_w / (1 + V_w/15.4)]^q,  q = 1.1 (λ + 0.015)^-0.4
    σ0_HH = 3.9e-6 λ ψ^0.4 A_i A_u A_w
    σ0_VV[dB] = σ0_HH[dB] - 1.05 ln(h_av + 0.015) + 1.09 ln λ + 1.27 ln(ψ + 1e-4) + 9.70
                (3-10 GHz)
    σ0_VV[dB] = σ0_HH[dB] - 1.73 ln(h_av + 0.015) + 3.76 ln λ + 2.46 ln(ψ + 1e-4) + 22.2
                (1-3 GHz)

10-100 GHz::

    A_u = exp[0.25 cos φ (1 - 2.8 ψ) λ^-0.33]
    A_w = [1.94 V_w / (1 + V_w/15.4)]^q,  q = 1.93 λ^-0.04
    σ0_HH = 5.78e-6 ψ^0.547 A_i A_u A_w
    σ0_VV[dB] = σ0_HH[dB] - 1.38 ln h_av + 3.43 ln λ + 1.31 ln ψ + 18.55

Choices where the model or the seed is ambiguous (docs/clutter.md repeats them):

* wave height: GIT takes the *average* wave height; the seed and the scenario give the
  *significant* wave height w_h.  For Rayleigh-distributed wave heights h_1/3 = 1.60 h_av, so
  h_av = w_h / 1.6.  Without a wave height, the GIT's fully developed sea V_w = 8.67 h_av^0.4
  gives h_av = (V_w / 8.67)^2.5.
* the published 1-10 / 10-100 GHz split is kept at exactly 10 GHz (the model steps there) and
  the VV correction switches at 3 GHz; outside 1-100 GHz a ValueError is raised.
* the fit covers grazing angles of about 0.1° to 10°.  Above 10° (the first cells of a ship's
  radar) ψ is held at 10°: the (1 - 2.8 ψ) factor would turn upwind into downwind at 20.5°.
  Below 0.1° the formula is still used (its A_i ∝ ψ⁴ is the physically right critical-angle
  fall), but the ducting extension takes over there (see :func:`ducted_reflectivity_db`).
* ψ ≤ 0 (behind the antenna's horizon), zero wind or zero waves give σ0 = 0 exactly.
* φ enters through cos φ, signed: downwind is below upwind, crosswind is in between.
* two variants of the published text circulate: Gregers-Hansen's NRL MATLAB re-implementation
  (``GTI_SigmaSea.m``, 2010) divides σ_φ by (λ + 0.015) instead of λ, uses |cos φ| (upwind equal
  to downwind) and moves the band split to 12 GHz.  We follow Horst et al. as reproduced by
  Long and by Antipov (σ_φ ∝ 1/λ, signed cos φ, split at 10 GHz).  The σ_φ variant matters only
  below the critical angle, where A_i ∝ σ_φ⁴: there it would lower σ0 by up to
  40 log10(1 + 0.015/λ), 6.9 dB at 9.8 GHz and 1.1 dB at 1.3 GHz.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants
from scipy.special import gammaln

from shipradar.sensors.geometry import EARTH_RADIUS_M, K_FACTOR

Polarization = Literal["H", "V"]

# --------------------------------------------------------------------------- reference values
#: Speed of light in vacuum c [m/s].
SPEED_OF_LIGHT_MPS: float = constants.c

#: Frequency range of the GIT model [Hz] (Horst et al. 1978).
GIT_MIN_FREQ_HZ = 1.0e9
#: Lowest frequency accepted [Hz]: between this and GIT_MIN_FREQ_HZ the GIT formulas, which are
#: continuous in λ, are extrapolated (UHF long-range radars such as the AN/SPS-49 at ~0.9 GHz);
#: the fit was made from 1 GHz up, so treat UHF sea clutter as indicative.
GIT_EXTRAPOLATION_MIN_FREQ_HZ = 0.5e9
GIT_MAX_FREQ_HZ = 100.0e9
#: The GIT's low-frequency (1-10 GHz) and high-frequency (10-100 GHz) formulas meet here [Hz].
GIT_HIGH_BAND_FREQ_HZ = 10.0e9
#: The low-frequency VV correction changes form at 3 GHz [Hz].
GIT_VV_SPLIT_FREQ_HZ = 3.0e9
#: Grazing angles covered by the GIT fit [rad] (about 0.1° to 10°).
GIT_MIN_GRAZING_RAD = float(np.deg2rad(0.1))
GIT_MAX_GRAZING_RAD = float(np.deg2rad(10.0))
#: Significant over average wave height, h_1/3 / h_av, for Rayleigh-distributed wave heights.
SIGNIFICANT_OVER_AVERAGE_WAVE_HEIGHT = 1.6
#: GIT fully developed sea: V_w = 8.67 h_av^0.4 (V_w [m/s], h_av [m]).
GIT_WIND_WAVE_COEFF = 8.67
GIT_WIND_WAVE_EXPONENT = 0.4
#: Upper limits of the Douglas sea states 0-8 by significant wave height [m] (WMO code 3700);
#: state 9 is anything above 14 m.
DOUGLAS_UPPER_WAVE_HEIGHT_M = (0.0, 0.1, 0.5, 1.25, 2.5, 4.0, 6.0, 9.0, 14.0)

#: [24]: R_H = 3.57 (√h_a + √h_e) km with heights in m; 3.57 = √(2 · 6371 km), the geometric
#: (k = 1) horizon constant.
HORIZON_KM_PER_SQRT_M = 3.57
#: h_e = 0.375 w_h, the effective wave height of [24] (Nathanson 2nd ed. p. 273).
EFFECTIVE_WAVE_HEIGHT_RATIO = 0.375
#: [23]: the smallest duct height that declares a ducting condition [m].
MIN_DUCT_HEIGHT_M = 1.0
#: [25]: R_tc = 7.1 - 3.6 log10(h_duct) [km].
TRANSITION_RANGE_INTERCEPT_KM = 7.1
TRANSITION_RANGE_SLOPE_KM = 3.6
#: [25] is used up to this duct height [m] (the schema's upper bound, above any measured
#: evaporation duct); higher ducts keep R_tc(60 m) = 0.70 km instead of reaching 0 at 94 m.
TRANSITION_RANGE_MAX_DUCT_M = 60.0
#: [26]: h_duct(opt) = 37 - 8.69 ln f(GHz) [m].
OPTIMAL_DUCT_INTERCEPT_M = 37.0
OPTIMAL_DUCT_SLOPE_M = 8.69
#: [28]: β° = 4 in standard conditions, 1 at the optimal duct, back to 4 at 30 m.
BETA_STANDARD = 4.0
BETA_OPTIMAL = 1.0
BETA_RECOVERY_DUCT_M = 30.0
#: [29]: clutter propagation loss without a duct [dB/km].
NO_DUCT_PROPAGATION_LOSS_DB_PER_KM = 3.6
#: [29] is applied below this frequency only [Hz].
PROPAGATION_LOSS_MAX_FREQ_HZ = 10.0e9
#: Reflectivities [dB] at or below this level mean "no clutter" (0 m²/m²); dB arrays are floored
#: here so that they stay finite and interpolable in tables.
DB_FLOOR = -400.0

#: [31]-[32] reference condition: X band, upwind, 3° grazing.
REFERENCE_FREQ_HZ = 9.8e9
REFERENCE_GRAZING_RAD = float(np.deg2rad(3.0))
#: [31]: a_ref = 3 log10(w_s).
WEIBULL_A_WIND_COEFF = 3.0
#: [32]: slope of a against σ0d [1/dB].
WEIBULL_A_SLOPE_PER_DB = 0.066
#: 4.1.2: a_max^HP, the HP skewness at the 3° reference range.
WEIBULL_A_MAX_HP = 3.0
#: Weibull parameter of Rayleigh clutter (exponential power).
RAYLEIGH_A = 1.0
#: 4.1.2: the HP skewness reaches a_min where the clutter power falls to this many N0'.
HP_NOISE_LIMIT_FACTOR = 2.0
#: 4.1.2: clutter is non-Rayleigh when X = θ_b[deg] τ'[µs] < 4 and τ' < 4 µs.
RESOLUTION_X_LIMIT_DEG_US = 4.0
RESOLUTION_PULSE_LIMIT_S = 4.0e-6
#: [35]: average radial velocity of the waves, "a few knots (0.5 m/s)" [m/s]; k_vw = 2·0.5/λ.
WAVE_DRIFT_SPEED_MPS = 0.5
#: [37]: σ_r = α / (5.35 θ_b) (Nathanson eq. 9.76).
ROTATION_SPREAD_DIVISOR = 5.35


# --------------------------------------------------------------------------- helpers
def _f(x: ArrayLike) -> NDArray[np.float64]:
    return np.asarray(x, dtype=np.float64)


def to_db(x: ArrayLike) -> NDArray[np.float64]:
    """10 log10(x), with x ≤ 0 mapped to :data:`DB_FLOOR` (no warning, always finite)."""
    x = _f(x)
    out = np.full(x.shape, DB_FLOOR)
    pos = x > 0.0
    np.log10(x, out=out, where=pos)
    out = np.where(pos, 10.0 * out, DB_FLOOR)
    level_db: NDArray[np.float64] = np.maximum(out, DB_FLOOR)
    return level_db


def from_db(x_db: ArrayLike) -> NDArray[np.float64]:
    """10^(x/10), with x ≤ :data:`DB_FLOOR` mapped to exactly 0."""
    x_db = _f(x_db)
    return np.where(x_db > DB_FLOOR, 10.0 ** (np.maximum(x_db, DB_FLOOR) / 10.0), 0.0)


def polarization_letter(polarization: str) -> Polarization:
    """The polarization as the models' letter, 'H' or 'V' (also accepts 'HH'/'horizontal',
    'VV'/'vertical', any case); ValueError naming the value otherwise."""
    p = str(polarization).upper()
    if p in ("H", "HH", "HORIZONTAL"):
        return "H"
    if p in ("V", "VV", "VERTICAL"):
        return "V"
    raise ValueError(f"polarization must be 'H' or 'V', got {polarization!r}")


# --------------------------------------------------------------------------- sea surface
def average_wave_height_m(wind_speed_mps: ArrayLike) -> NDArray[np.float64]:
    """GIT average wave height of a fully developed sea, h_av = (V_w / 8.67)^2.5.

    Horst, Dyer & Tuley (1978): V_w = 8.67 h_av^0.4.

    Parameters
    ----------
    wind_speed_mps : array_like
        Wind speed V_w [m/s], ≥ 0 (0 gives a flat sea, h_av = 0).

    Returns
    -------
    ndarray
        Average wave height h_av [m].
    """
    w = _f(wind_speed_mps)
    if np.any(w < 0.0):
        raise ValueError("wind speed must be >= 0")
    return (w / GIT_WIND_WAVE_COEFF) ** (1.0 / GIT_WIND_WAVE_EXPONENT)


def douglas_sea_state(wave_height_m: ArrayLike) -> NDArray[np.float64]:
    """Douglas sea state (0-9) of a significant wave height (WMO code table 3700).

    Band upper limits 0, 0.1, 0.5, 1.25, 2.5, 4, 6, 9, 14 m; a height on a limit belongs to the
    lower state; above 14 m the state is 9.

    Parameters
    ----------
    wave_height_m : array_like
        Significant wave height w_h [m], ≥ 0.

    Returns
    -------
    ndarray
        Sea state as float (integer values).
    """
    h = _f(wave_height_m)
    if np.any(h < 0.0):
        raise ValueError("wave height must be >= 0")
    return np.searchsorted(np.array(DOUGLAS_UPPER_WAVE_HEIGHT_M), h, side="left").astype(np.float64)


def _average_wave_height(
    wave_height_m: ArrayLike | None, wind_speed_mps: ArrayLike
) -> NDArray[np.float64]:
    """h_av from a significant wave height (NaN or None: from the wind)."""
    from_wind = average_wave_height_m(wind_speed_mps)
    if wave_height_m is None:
        return from_wind
    wh = _f(wave_height_m)
    if np.any(wh < 0.0):
        raise ValueError("wave height must be >= 0")
    return np.where(
        np.isnan(wh), from_wind, np.nan_to_num(wh) / SIGNIFICANT_OVER_AVERAGE_WAVE_HEIGHT
    )


def _significant_wave_height(
    wave_height_m: ArrayLike | None, wind_speed_mps: ArrayLike
) -> NDArray[np.float64]:
    return SIGNIFICANT_OVER_AVERAGE_WAVE_HEIGHT * _average_wave_height(
        wave_height_m, wind_speed_mps
    )


# --------------------------------------------------------------------------- geometry
def _effective_radius(k_factor: ArrayLike) -> NDArray[np.float64]:
    k = _f(k_factor)
    if np.any(k <= 0.0):
        raise ValueError("k_factor must be > 0")
    return k * EARTH_RADIUS_M


def slant_range_m(
    ground_range_m: ArrayLike, antenna_height_m: ArrayLike, k_factor: ArrayLike = K_FACTOR
) -> NDArray[np.float64]:
    """Slant range from an antenna to a sea patch on a spherical effective earth [m].

    R² = h² + 4 a_e (a_e + h) sin²(γ/2), γ = d / a_e (law of cosines, written without
    cancellation).  d = 0 gives R = h.

    Parameters
    ----------
    ground_range_m : array_like
        Ground (arc) range d along the effective earth [m], ≥ 0.
    antenna_height_m : array_like
        Antenna height h above the sea [m], > 0.
    k_factor : array_like, optional
        Effective earth radius factor k (a_e = k · ``EARTH_RADIUS_M``).
    """
    a = _effective_radius(k_factor)
    d, h = _f(ground_range_m), _f(antenna_height_m)
    s = np.sin(d / (2.0 * a))
    if isinstance(s, np.ndarray) and s.ndim and np.broadcast_shapes(s.shape, h.shape) == s.shape:
        # the same products and sum, in place on a copy of the first (the sea-clutter false
        # alarms' millions of points pass here): ((4 a (a + h)) s) s + h², sum in either order
        r2 = 4.0 * a * (a + h) * s
        r2 *= s
        r2 += h * h
        return np.sqrt(r2, out=r2)
    return np.sqrt(h * h + 4.0 * a * (a + h) * s * s)


def grazing_angle_rad(
    ground_range_m: ArrayLike, antenna_height_m: ArrayLike, k_factor: ArrayLike = K_FACTOR
) -> NDArray[np.float64]:
    """Grazing angle ψ at a sea patch seen from an antenna, spherical effective earth.

    sin ψ = [h - 2 (a_e + h) sin²(γ/2)] / R, γ = d / a_e (exact geometry; ≈ h/d - d/(2 a_e)).
    Positive inside the radar horizon, 0 on it, negative beyond (the patch is hidden);
    d = 0 gives π/2.

    Parameters
    ----------
    ground_range_m : array_like
        Ground range d [m], ≥ 0.
    antenna_height_m : array_like
        Antenna height h [m], > 0.
    k_factor : array_like, optional
        Effective earth radius factor k.

    Returns
    -------
    ndarray
        ψ [rad] in (-π/2, π/2].
    """
    a = _effective_radius(k_factor)
    d, h = _f(ground_range_m), _f(antenna_height_m)
    s = np.sin(d / (2.0 * a))
    r = slant_range_m(d, h, k_factor)
    return np.arcsin(np.clip((h - 2.0 * (a + h) * s * s) / r, -1.0, 1.0))


def depression_angle_rad(
    ground_range_m: ArrayLike, antenna_height_m: ArrayLike, k_factor: ArrayLike = K_FACTOR
) -> NDArray[np.float64]:
    """Depression angle ψ_d of a sea patch below the antenna's local horizontal.

    sin ψ_d = [h + 2 a_e sin²(γ/2)] / R; ψ_d = ψ + γ (always > ψ on a curved earth).  The
    elevation to put in an antenna pattern is -ψ_d.

    Parameters
    ----------
    ground_range_m : array_like
        Ground range d [m], ≥ 0.
    antenna_height_m : array_like
        Antenna height h [m], > 0.
    k_factor : array_like, optional
        Effective earth radius factor k.

    Returns
    -------
    ndarray
        ψ_d [rad] in (0, π/2].
    """
    a = _effective_radius(k_factor)
    d, h = _f(ground_range_m), _f(antenna_height_m)
    s = np.sin(d / (2.0 * a))
    r = slant_range_m(d, h, k_factor)
    return np.arcsin(np.clip((h + 2.0 * a * s * s) / r, -1.0, 1.0))


def ground_range_at_grazing_m(
    grazing_rad: ArrayLike, antenna_height_m: ArrayLike, k_factor: ArrayLike = K_FACTOR
) -> NDArray[np.float64]:
    """Ground range at which the grazing angle equals ψ, the inverse of :func:`grazing_angle_rad`.

    Law of sines in the triangle (earth centre, antenna, patch): cos ψ_d = a_e cos ψ / (a_e + h)
    and the central angle is γ = ψ_d - ψ, so d = a_e (arccos[a_e cos ψ / (a_e + h)] - ψ).
    ψ = 0 gives the radar horizon, ψ = π/2 gives 0.

    Parameters
    ----------
    grazing_rad : array_like
        ψ [rad] in [0, π/2].
    antenna_height_m : array_like
        Antenna height h [m], > 0.
    k_factor : array_like, optional
        Effective earth radius factor k.
    """
    a = _effective_radius(k_factor)
    psi, h = _f(grazing_rad), _f(antenna_height_m)
    if np.any((psi < 0.0) | (psi > np.pi / 2)):
        raise ValueError("grazing angle must be in [0, pi/2]")
    psi_d = np.arccos(np.clip(a * np.cos(psi) / (a + h), -1.0, 1.0))
    return a * np.maximum(psi_d - psi, 0.0)


# --------------------------------------------------------------------------- GIT
# long: 28 docstring lines; the GIT terms (A_i, A_u, A_w, H/V corrections) as published
def git_reflectivity(
    grazing_rad: ArrayLike,
    freq_hz: ArrayLike,
    wind_speed_mps: ArrayLike,
    wind_relative_azimuth_rad: ArrayLike,
    wave_height_m: ArrayLike | None = None,
    polarization: str = "H",
) -> NDArray[np.float64]:
    """Mean sea reflectivity σ0 of the GIT model (Horst, Dyer & Tuley 1978), HP or VP.

    Implements the formulas in the module docstring (interference factor A_i, upwind/downwind
    factor A_u, wind factor A_w; 1-10 GHz and 10-100 GHz forms; VV from HH by the published
    corrections); the seed's σ0 of [22] (SPEC §4 item 18).

    Parameters
    ----------
    grazing_rad : array_like
        Grazing angle ψ [rad].  ψ ≤ 0 (hidden patch) gives 0; ψ > 10° is evaluated at 10°.
    freq_hz : array_like
        Carrier frequency [Hz], within [1 GHz, 100 GHz] (ValueError outside).
    wind_speed_mps : array_like
        Wind speed V_w [m/s], ≥ 0; 0 gives σ0 = 0.
    wind_relative_azimuth_rad : array_like
        Look direction relative to the wind φ [rad]: 0 looking into the wind (upwind),
        π looking downwind, ±π/2 crosswind.
    wave_height_m : array_like or None, optional
        Significant wave height w_h [m] (h_av = w_h / 1.6); None or NaN: fully developed sea
        from the wind, h_av = (V_w / 8.67)^2.5.  0 gives σ0 = 0.
    polarization : {"H", "V"}
        Transmit/receive polarization (HH or VV).

    Returns
    -------
    ndarray
        σ0 [m²/m²], ≥ 0, broadcast shape of the inputs.
    """
    pol = polarization_letter(polarization)
    f = _f(freq_hz)
    if np.any(~((f >= GIT_EXTRAPOLATION_MIN_FREQ_HZ) & (f <= GIT_MAX_FREQ_HZ))):
        raise ValueError(
            f"the GIT sea clutter model is valid from 1 to 100 GHz (extrapolated down to "
            f"0.5 GHz); got {np.min(f):.4g}-{np.max(f):.4g} Hz"
        )
    w = _f(wind_speed_mps)
    if np.any(w < 0.0):
        raise ValueError("wind speed must be >= 0")
    psi_in = _f(grazing_rad)
    h_av = _average_wave_height(wave_height_m, w)
    cos_phi = np.cos(_f(wind_relative_azimuth_rad))
    psi_in, f, w, h_av, cos_phi = np.broadcast_arrays(psi_in, f, w, h_av, cos_phi)

    visible = (psi_in > 0.0) & (h_av > 0.0) & (w > 0.0)
    # Hidden, calm or windless patches are evaluated at harmless values and zeroed at the end.
    psi = np.where(visible, np.minimum(psi_in, GIT_MAX_GRAZING_RAD), GIT_MAX_GRAZING_RAD)
    hav = np.where(visible, h_av, 1.0)
    ws = np.where(visible, w, 1.0)
    lam = SPEED_OF_LIGHT_MPS / f

    sigma_phi = (14.4 * lam + 5.5) * psi * hav / lam
    s4 = sigma_phi**4
    a_i = s4 / (1.0 + s4)
    wind_base = 1.94 * ws / (1.0 + ws / 15.4)

    low = f < GIT_HIGH_BAND_FREQ_HZ
    lam15 = (lam + 0.015) ** -0.4
    a_u = np.where(
        low,
        np.exp(0.2 * cos_phi * (1.0 - 2.8 * psi) * lam15),
        np.exp(0.25 * cos_phi * (1.0 - 2.8 * psi) * lam**-0.33),
    )
    q = np.where(low, 1.1 * lam15, 1.93 * lam**-0.04)
    a_w = wind_base**q
    sigma_hh = np.where(low, 3.9e-6 * lam * psi**0.4, 5.78e-6 * psi**0.547) * a_i * a_u * a_w

    if pol == "H":
        sigma = sigma_hh
    else:
        vv_s = -1.73 * np.log(hav + 0.015) + 3.76 * np.log(lam) + 2.46 * np.log(psi + 1e-4) + 22.2
        vv_c = -1.05 * np.log(hav + 0.015) + 1.09 * np.log(lam) + 1.27 * np.log(psi + 1e-4) + 9.70
        vv_hi = -1.38 * np.log(hav) + 3.43 * np.log(lam) + 1.31 * np.log(psi) + 18.55
        delta_db = np.where(low, np.where(f < GIT_VV_SPLIT_FREQ_HZ, vv_s, vv_c), vv_hi)
        sigma = sigma_hh * 10.0 ** (delta_db / 10.0)
    return np.where(visible, sigma, 0.0)


# --------------------------------------------------------------------------- ducting [22]-[29]
def horizon_range_m(antenna_height_m: ArrayLike, wave_height_m: ArrayLike) -> NDArray[np.float64]:
    """Horizon range between the antenna and the effective wave height, R_H, seed [24].

    R_H = 3.57 (√h_a + √h_e) km with h_e = 0.375 w_h (the seed's geometric, k = 1, horizon).

    Parameters
    ----------
    antenna_height_m : array_like
        h_a [m], ≥ 0.
    wave_height_m : array_like
        Significant wave height w_h [m], ≥ 0.

    Returns
    -------
    ndarray
        R_H [m].
    """
    h_a, w_h = _f(antenna_height_m), _f(wave_height_m)
    if np.any(h_a < 0.0) or np.any(w_h < 0.0):
        raise ValueError("heights must be >= 0")
    h_e = EFFECTIVE_WAVE_HEIGHT_RATIO * w_h
    return 1000.0 * HORIZON_KM_PER_SQRT_M * (np.sqrt(h_a) + np.sqrt(h_e))


def transition_range_m(
    antenna_height_m: ArrayLike, wave_height_m: ArrayLike, duct_height_m: ArrayLike
) -> NDArray[np.float64]:
    """Transition range R_tr of the ducting extension, seed [23]-[25].

    R_tr = R_H [24] if h_duct < 1 m, else R_tc = 7.1 - 3.6 log10(h_duct) km [25], never beyond
    R_H (past R_H the GIT is outside its domain whatever the duct).

    SPEC §4 item 9: [25] reaches 0 at h_duct = 94 m and is negative above.  [25] is evaluated
    with h_duct capped at :data:`TRANSITION_RANGE_MAX_DUCT_M` (60 m), so R_tc ≥ 0.70 km.

    Parameters
    ----------
    antenna_height_m : array_like
        h_a [m].
    wave_height_m : array_like
        Significant wave height w_h [m].
    duct_height_m : array_like
        Evaporation duct height h_duct [m], ≥ 0 (0: no duct).

    Returns
    -------
    ndarray
        R_tr [m], > 0.
    """
    h_d = _f(duct_height_m)
    if np.any(h_d < 0.0):
        raise ValueError("duct height must be >= 0")
    r_h = horizon_range_m(antenna_height_m, wave_height_m)
    h_cap = np.clip(h_d, MIN_DUCT_HEIGHT_M, TRANSITION_RANGE_MAX_DUCT_M)
    r_tc = 1000.0 * (TRANSITION_RANGE_INTERCEPT_KM - TRANSITION_RANGE_SLOPE_KM * np.log10(h_cap))
    return np.where(h_d < MIN_DUCT_HEIGHT_M, r_h, np.minimum(r_tc, r_h))


def optimal_duct_height_m(freq_hz: ArrayLike) -> NDArray[np.float64]:
    """Optimal duct height h_duct(opt) = 37 - 8.69 ln f(GHz) m, seed [26].

    SPEC §4 item 10: [26] is negative above 70 GHz.  The result is floored at the smallest duct
    that declares ducting, 1 m ([23]), reached at 63 GHz: a thinner "optimal" duct would not be
    a duct.

    Parameters
    ----------
    freq_hz : array_like
        Frequency [Hz], > 0.

    Returns
    -------
    ndarray
        h_duct(opt) [m], ≥ 1.
    """
    f_ghz = _f(freq_hz) / 1.0e9
    if np.any(f_ghz <= 0.0):
        raise ValueError("frequency must be > 0")
    return np.maximum(
        OPTIMAL_DUCT_INTERCEPT_M - OPTIMAL_DUCT_SLOPE_M * np.log(f_ghz), MIN_DUCT_HEIGHT_M
    )


def reflectivity_decrease_beta(
    duct_height_m: ArrayLike, freq_hz: ArrayLike, sea_state: ArrayLike
) -> NDArray[np.float64]:
    """Reflectivity decrease coefficient β beyond the transition range, seed [26]-[28].

    β° = 4 - 3 h_duct / h_opt for h_duct ≤ h_opt, and 1 + 3 (h_duct - h_opt) / (30 - h_opt)
    above [28]; β = β° for S_sea < 2 and β° [(S_sea - 2)/4 + 1] otherwise [27].

    Choices at the edges (SPEC §4 item 10):

    * h_duct < 1 m is no duct ([23]): β° = 4 (standard conditions).
    * h_opt is floored at 1 m (:func:`optimal_duct_height_m`), so [28] never divides by a
      non-positive h_opt.
    * β° is kept within [1, 4], the range the seed states ("from 4 to about 1"); the second
      branch otherwise passes 4 above 30 m.
    * 30 - h_opt is 0 at 2.24 GHz and negative below (h_opt > 30 m, e.g. 34.7 m at 1.3 GHz):
      the seed's rise back to 4 at 30 m does not exist there, and ducts thicker than h_opt are
      held at the optimal β° = 1.  Just above 2.24 GHz the rise is steep but finite, and
      capped at 4.

    Parameters
    ----------
    duct_height_m : array_like
        h_duct [m], ≥ 0.
    freq_hz : array_like
        Frequency [Hz].
    sea_state : array_like
        Douglas sea state S_sea (≥ 0; non-integer values are accepted).

    Returns
    -------
    ndarray
        β, ≥ 1 (≤ 4 for S_sea ≤ 2).
    """
    h = _f(duct_height_m)
    s = _f(sea_state)
    if np.any(h < 0.0) or np.any(s < 0.0):
        raise ValueError("duct height and sea state must be >= 0")
    h_opt = optimal_duct_height_m(freq_hz)
    h, h_opt, s = np.broadcast_arrays(h, h_opt, s)
    below = BETA_STANDARD - (BETA_STANDARD - BETA_OPTIMAL) * h / h_opt
    span = BETA_RECOVERY_DUCT_M - h_opt
    has_span = span > 0.0
    safe_span = np.where(has_span, span, 1.0)
    above = np.where(
        has_span,
        BETA_OPTIMAL + (BETA_STANDARD - BETA_OPTIMAL) * (h - h_opt) / safe_span,
        BETA_OPTIMAL,
    )
    beta0 = np.where(h <= h_opt, below, above)
    beta0 = np.where(h < MIN_DUCT_HEIGHT_M, BETA_STANDARD, beta0)
    beta0 = np.clip(beta0, BETA_OPTIMAL, BETA_STANDARD)
    return np.where(s < 2.0, beta0, beta0 * ((s - 2.0) / 4.0 + 1.0))


def clutter_propagation_loss_db_per_km(
    duct_height_m: ArrayLike, freq_hz: ArrayLike, beta: ArrayLike
) -> NDArray[np.float64]:
    """Clutter propagation loss ℑ beyond the transition range, seed [29].

    ℑ = 3.6 dB/km without a duct (h_duct < 1 m); (β + 1)/4 · log10(9 - 0.9 f[GHz]) with a duct
    below 10 GHz; 0 with a duct at 10 GHz and above.

    SPEC §4 item 11: log10(9 - 0.9 f) is negative from 8.89 GHz (a clutter *gain*) and tends
    to -∞ at 10 GHz.  ℑ is clamped to ≥ 0, so it falls to 0 at 8.89 GHz and stays there; the
    logarithm is never evaluated at a non-positive argument.

    Parameters
    ----------
    duct_height_m : array_like
        h_duct [m], ≥ 0.
    freq_hz : array_like
        Frequency [Hz].
    beta : array_like
        β of [27].

    Returns
    -------
    ndarray
        ℑ [dB/km], ≥ 0 and finite.
    """
    h, f_hz, b = np.broadcast_arrays(_f(duct_height_m), _f(freq_hz), _f(beta))
    arg = 9.0 - 0.9 * f_hz / 1.0e9
    ok = (f_hz < PROPAGATION_LOSS_MAX_FREQ_HZ) & (arg > 1.0)
    ducted = (b + 1.0) / 4.0 * np.log10(np.where(ok, arg, 1.0))
    ducted = np.where(ok, np.maximum(ducted, 0.0), 0.0)
    return np.where(h < MIN_DUCT_HEIGHT_M, NO_DUCT_PROPAGATION_LOSS_DB_PER_KM, ducted)


def git_limit_range_m(
    antenna_height_m: ArrayLike, k_factor: ArrayLike = K_FACTOR
) -> NDArray[np.float64]:
    """Ground range where the spherical-earth grazing angle falls to the GIT's 0.1° [m].

    The seed's R_H [24] lies beyond the antenna's own horizon over the mean sea surface (it
    adds the horizon of the wave crests), where the grazing angle on the mean surface is
    negative and GIT undefined; :func:`ducted_reflectivity_db` hands over to the seed's
    extension no later than this range.

    Parameters
    ----------
    antenna_height_m : array_like
        h_a [m], > 0.
    k_factor : array_like, optional
        Effective earth radius factor k.
    """
    return ground_range_at_grazing_m(GIT_MIN_GRAZING_RAD, antenna_height_m, k_factor)


# long: 38 docstring lines; [22]-[29] in the seed's order, one chain
def ducted_reflectivity_db(
    ground_range_m: ArrayLike,
    antenna_height_m: ArrayLike,
    freq_hz: ArrayLike,
    wind_speed_mps: ArrayLike,
    wind_relative_azimuth_rad: ArrayLike,
    wave_height_m: ArrayLike | None = None,
    polarization: str = "H",
    duct_height_m: ArrayLike = 0.0,
    sea_state: ArrayLike | None = None,
    k_factor: ArrayLike = K_FACTOR,
) -> NDArray[np.float64]:
    """Sea reflectivity with the seed's ducting extension σ0* [dB], seed [22].

    σ0*(R) = σ0(R) for R ≤ R_tr, and σ0(R_tr) - 10 β log10(R/R_tr) - ℑ (R - R_tr) beyond
    (R in km), with σ0 the GIT (:func:`git_reflectivity`) at the spherical-earth grazing angle,
    R_tr of [23]-[25], β of [26]-[28] and ℑ of [29].  Continuous at R_tr by construction.

    R_tr is taken no further than :func:`git_limit_range_m` (grazing angle 0.1°, the lower edge
    of the GIT fit): without this the seed's R_H, which lies beyond the antenna's horizon over
    the mean surface, would make σ0(R_tr) zero.

    Parameters
    ----------
    ground_range_m : array_like
        Ground range of the clutter patch R*_sc [m], ≥ 0.
    antenna_height_m : array_like
        h_a [m], > 0.
    freq_hz : array_like
        Frequency [Hz], 1-100 GHz.
    wind_speed_mps : array_like
        Wind speed [m/s].
    wind_relative_azimuth_rad : array_like
        Look direction relative to the wind [rad] (0 upwind).
    wave_height_m : array_like or None, optional
        Significant wave height [m]; None: from the wind (see :func:`git_reflectivity`).
    polarization : {"H", "V"}
        Polarization.
    duct_height_m : array_like, optional
        Evaporation duct height [m]; below 1 m there is no duct ([23]).
    sea_state : array_like or None, optional
        Douglas sea state S_sea of [27]; None: from the wave height (:func:`douglas_sea_state`).
    k_factor : array_like, optional
        Effective earth radius factor of the grazing-angle geometry.

    Returns
    -------
    ndarray
        σ0* [dB], ≥ :data:`DB_FLOOR` (which stands for no clutter).
    """
    d = _f(ground_range_m)
    if np.any(d < 0.0):
        raise ValueError("ground range must be >= 0")
    w_h = _significant_wave_height(wave_height_m, wind_speed_mps)
    if sea_state is None:
        sea_state = douglas_sea_state(w_h)
    r_tr = np.minimum(
        transition_range_m(antenna_height_m, w_h, duct_height_m),
        git_limit_range_m(antenna_height_m, k_factor),
    )
    near = git_reflectivity(
        grazing_angle_rad(np.minimum(d, r_tr), antenna_height_m, k_factor),
        freq_hz,
        wind_speed_mps,
        wind_relative_azimuth_rad,
        w_h,
        polarization,
    )
    at_tr = git_reflectivity(
        grazing_angle_rad(r_tr, antenna_height_m, k_factor),
        freq_hz,
        wind_speed_mps,
        wind_relative_azimuth_rad,
        w_h,
        polarization,
    )
    beta = reflectivity_decrease_beta(duct_height_m, freq_hz, sea_state)
    loss = clutter_propagation_loss_db_per_km(duct_height_m, freq_hz, beta)
    ratio = np.maximum(d, r_tr) / r_tr
    far_db = (
        to_db(at_tr) - 10.0 * beta * np.log10(ratio) - loss * (np.maximum(d, r_tr) - r_tr) / 1e3
    )
    far_db = np.where(to_db(at_tr) <= DB_FLOOR, DB_FLOOR, far_db)
    return np.maximum(np.where(d <= r_tr, to_db(near), far_db), DB_FLOOR)


# --------------------------------------------------------------------------- power [21]
def illuminated_area_m2(
    slant_range_m: ArrayLike, beamwidth_rad: ArrayLike, range_cell_m: ArrayLike
) -> NDArray[np.float64]:
    """Illuminated sea area A = R_sc θ_b C_R [m²], seed [21].

    Parameters
    ----------
    slant_range_m : array_like
        R_sc [m].
    beamwidth_rad : array_like
        Azimuth 3 dB beamwidth θ_b [rad].
    range_cell_m : array_like
        C_R = c τ'/2 [m].
    """
    return _f(slant_range_m) * _f(beamwidth_rad) * _f(range_cell_m)


def sea_clutter_power_w(
    radar_constant_w_m2: ArrayLike,
    directivity: ArrayLike,
    slant_range_m: ArrayLike,
    beamwidth_rad: ArrayLike,
    range_cell_m: ArrayLike,
    sigma0: ArrayLike,
) -> NDArray[np.float64]:
    """Mean sea-clutter power at the RF input, P_sc = K_r g⁴ A σ0* / R_sc⁴, seed [21].

    Parameters
    ----------
    radar_constant_w_m2 : array_like
        K_r of [3] [W·m²].
    directivity : array_like
        Elevation field factor g at the depression angle (elevation -ψ_d), |g| ≤ 1.
    slant_range_m : array_like
        R_sc [m], > 0 (SPEC §4 item 13: R_sc ≥ h_a > 0 for a sea patch, so never 0).
    beamwidth_rad : array_like
        θ_b [rad].
    range_cell_m : array_like
        C_R [m].
    sigma0 : array_like
        σ0* [m²/m²] (linear).

    Returns
    -------
    ndarray
        P_sc [W], ≥ 0.
    """
    r = _f(slant_range_m)
    if np.any(r <= 0.0):
        raise ValueError("slant range must be > 0")
    area = illuminated_area_m2(r, beamwidth_rad, range_cell_m)
    return _f(radar_constant_w_m2) * _f(directivity) ** 4 * area * _f(sigma0) / r**4


# --------------------------------------------------------------------------- skewness [30]-[32]
def median_mean_difference_db(a: ArrayLike) -> NDArray[np.float64]:
    """Mean minus median of Weibull clutter power, d_mm = -10 a log10(ln 2) + 10 log10 Γ(1+a) [dB].

    From [30] (σ0^50 = σ0 - 1.6 a - 10 log10 Γ(1+a)) with the seed's 1.6 written exactly as
    -10 log10(ln 2) = 1.592 (SPEC §4 item 6).  For the power law of [94],
    P(x > Y) = exp(-ln 2 (Y/median)^(1/a)), the mean is median · Γ(1+a) / (ln 2)^a.
    a = 1 (Rayleigh) gives 1.59 dB.

    Parameters
    ----------
    a : array_like
        Weibull parameter a > 0.

    Returns
    -------
    ndarray
        d_mm [dB].
    """
    a = _f(a)
    if np.any(a <= 0.0):
        raise ValueError("Weibull parameter a must be > 0")
    d_mm: NDArray[np.float64] = (  # scipy is untyped
        -10.0 * a * np.log10(np.log(2.0)) + 10.0 * gammaln(1.0 + a) / np.log(10.0)
    )
    return d_mm


def median_reflectivity_db(mean_db: ArrayLike, a: ArrayLike) -> NDArray[np.float64]:
    """Median reflectivity σ0^50 = σ0 - 1.6 a - 10 log10 Γ(1+a), seed [30] [dB].

    Parameters
    ----------
    mean_db : array_like
        Mean reflectivity σ0 [dB].
    a : array_like
        Weibull parameter a > 0.
    """
    return _f(mean_db) - median_mean_difference_db(a)


def weibull_a_reference(
    wind_speed_mps: ArrayLike, a_min: ArrayLike = RAYLEIGH_A
) -> NDArray[np.float64]:
    """Weibull parameter at the reference condition, a_ref = max(a_min, 3 log10 w_s), seed [31].

    X band (9.8 GHz), upwind, 3° grazing.  SPEC §4 item 12: log10(w_s) → -∞ as w_s → 0; the
    max already gives a_min there, and the logarithm is never evaluated at w_s ≤ 0.

    Parameters
    ----------
    wind_speed_mps : array_like
        w_s [m/s], ≥ 0.
    a_min : array_like, optional
        a_min (the scenario's, default 1).

    Returns
    -------
    ndarray
        a_ref ≥ a_min, finite.
    """
    w = _f(wind_speed_mps)
    if np.any(w < 0.0):
        raise ValueError("wind speed must be >= 0")
    pos = w > 0.0
    a_w = WEIBULL_A_WIND_COEFF * np.log10(np.where(pos, w, 1.0))
    return np.maximum(_f(a_min), np.where(pos, a_w, -np.inf))


def reference_reflectivity(
    wind_speed_mps: ArrayLike, wave_height_m: ArrayLike | None = None
) -> NDArray[np.float64]:
    """σ0 at the reference condition of [31]-[32]: 9.8 GHz, VP, upwind, 3° grazing [m²/m²].

    Same wind and waves as the conditions under study (GIT, :func:`git_reflectivity`).

    Parameters
    ----------
    wind_speed_mps : array_like
        Wind speed [m/s].
    wave_height_m : array_like or None, optional
        Significant wave height [m]; None: from the wind.
    """
    return git_reflectivity(
        REFERENCE_GRAZING_RAD, REFERENCE_FREQ_HZ, wind_speed_mps, 0.0, wave_height_m, "V"
    )


def weibull_a_vp(
    sigma0_diff_db: ArrayLike, wind_speed_mps: ArrayLike, a_min: ArrayLike = RAYLEIGH_A
) -> NDArray[np.float64]:
    """Weibull parameter for VP, a = max(a_min, a_ref + 0.066 σ0d), seed [32] corrected.

    SPEC §4 item 2: the seed prints 0.066 σ0d - a_ref; at the reference condition (σ0d = 0) a
    must equal a_ref, so the sign of a_ref is +.

    Parameters
    ----------
    sigma0_diff_db : array_like
        σ0d = σ0 - σ0(reference) [dB] (:func:`reference_reflectivity`); very negative values
        (no clutter) give a_min.
    wind_speed_mps : array_like
        w_s [m/s].
    a_min : array_like, optional
        a_min.

    Returns
    -------
    ndarray
        a ≥ a_min.
    """
    a_ref = weibull_a_reference(wind_speed_mps, a_min)
    return np.maximum(_f(a_min), a_ref + WEIBULL_A_SLOPE_PER_DB * _f(sigma0_diff_db))


def weibull_a_hp(
    ground_range_m: ArrayLike,
    reference_range_m: ArrayLike,
    noise_limit_range_m: ArrayLike,
    a_min: ArrayLike = RAYLEIGH_A,
    a_max: ArrayLike = WEIBULL_A_MAX_HP,
) -> NDArray[np.float64]:
    """Weibull parameter for HP, the heuristic of seed 4.1.2.

    a = a_max (3.0) up to the reference range (grazing angle 3°), then a linear decrease to
    a_min at the range where the clutter power falls to 2 N0'; a_min beyond.  If the clutter is
    already below 2 N0' at the reference range, a = a_max inside the noise-limit range and
    a_min from it on (the seed is silent; there is no ramp to draw).

    Parameters
    ----------
    ground_range_m : array_like
        Ground range [m].
    reference_range_m : array_like
        Ground range of 3° grazing [m] (:func:`ground_range_at_grazing_m`).
    noise_limit_range_m : array_like
        Ground range where P_sc = 2 N0' [m].
    a_min, a_max : array_like, optional
        End values.

    Returns
    -------
    ndarray
        a in [a_min, a_max].
    """
    r, r0, r1 = np.broadcast_arrays(
        _f(ground_range_m), _f(reference_range_m), _f(noise_limit_range_m)
    )
    a_min, a_max = _f(a_min), _f(a_max)
    span = r1 - r0
    has_ramp = span > 0.0
    t = np.clip((r - r0) / np.where(has_ramp, span, 1.0), 0.0, 1.0)
    ramp = a_max + (a_min - a_max) * t
    step = np.where(r < r1, a_max, a_min)
    return np.where(has_ramp, ramp, step)


def is_medium_high_resolution(
    beamwidth_rad: ArrayLike, pulse_width_s: ArrayLike
) -> NDArray[np.bool_]:
    """Whether sea clutter is non-Rayleigh: X = θ_b[deg] τ'[µs] < 4 and τ' < 4 µs (seed 4.1.2).

    Parameters
    ----------
    beamwidth_rad : array_like
        Azimuth beamwidth θ_b [rad].
    pulse_width_s : array_like
        Compressed pulse width τ' [s].

    Returns
    -------
    ndarray of bool
    """
    tau = _f(pulse_width_s)
    x = np.rad2deg(_f(beamwidth_rad)) * tau * 1.0e6
    return (x < RESOLUTION_X_LIMIT_DEG_US) & (tau < RESOLUTION_PULSE_LIMIT_S)


# --------------------------------------------------------------------------- spectrum [33]-[38]
def clutter_spectrum_w_per_hz(
    freq_offset_hz: ArrayLike, power_w: ArrayLike, mean_hz: ArrayLike, spread_hz: ArrayLike
) -> NDArray[np.float64]:
    """Gaussian clutter spectrum P_c(f) = P_sc exp[-½ ((f - μ_c)/σ_s)²], seed [33].

    As printed, P_c(μ_c) = P_sc (a shape, not a density; the seed does not normalise it).

    Parameters
    ----------
    freq_offset_hz : array_like
        Doppler frequency f [Hz].
    power_w : array_like
        P_sc [W].
    mean_hz, spread_hz : array_like
        μ_c and σ_s [Hz], σ_s > 0.
    """
    s = _f(spread_hz)
    if np.any(s <= 0.0):
        raise ValueError("spectrum spread must be > 0")
    z = (_f(freq_offset_hz) - _f(mean_hz)) / s
    return _f(power_w) * np.exp(-0.5 * z * z)


def platform_doppler_hz(
    ship_speed_mps: ArrayLike,
    beam_relative_azimuth_rad: ArrayLike,
    depression_rad: ArrayLike,
    wavelength_m: ArrayLike,
) -> NDArray[np.float64]:
    """Doppler of the clutter patch centre from the platform motion, f1, seed [34] corrected.

    f1 = 2 (v_s/λ) cos θ_a cos ψ_d.  The seed prints sin ψ_d, which would give no Doppler at
    grazing incidence although its text defines f1 from "the closing velocity between the
    antenna and the centre of the clutter patch"; the closing velocity of a fixed patch is
    v_s cos θ_a cos ψ_d.

    Parameters
    ----------
    ship_speed_mps : array_like
        v_s [m/s].
    beam_relative_azimuth_rad : array_like
        θ_a, beam azimuth minus the velocity direction [rad].
    depression_rad : array_like
        ψ_d [rad].
    wavelength_m : array_like
        λ [m].
    """
    return (
        2.0
        * _f(ship_speed_mps)
        / _f(wavelength_m)
        * np.cos(_f(beam_relative_azimuth_rad))
        * np.cos(_f(depression_rad))
    )


def mean_clutter_doppler_hz(
    platform_doppler: ArrayLike,
    wind_relative_azimuth_rad: ArrayLike,
    wavelength_m: ArrayLike,
    motion_compensated: bool = False,
) -> NDArray[np.float64]:
    """Mean Doppler of the sea-clutter spectrum, μ_c = f1 - k_vw, seed [35].

    k_vw = 2 · 0.5 m/s / λ ≈ 1/λ, the waves' drift "of a few knots (0.5 m/s)".  The seed gives
    it one sign; the drift goes downwind, so we take its radial component:
    μ_c = f1 + (1/λ) cos φ (closing, positive, when looking upwind; 0 crosswind).
    Motion-compensated radars: μ_c = 0 (seed).

    Parameters
    ----------
    platform_doppler : array_like
        f1 [Hz] (:func:`platform_doppler_hz`).
    wind_relative_azimuth_rad : array_like
        Look direction relative to the wind φ [rad] (0 upwind).
    wavelength_m : array_like
        λ [m].
    motion_compensated : bool
        Platform motion removed: μ_c = 0.
    """
    f1, phi, lam = np.broadcast_arrays(
        _f(platform_doppler), _f(wind_relative_azimuth_rad), _f(wavelength_m)
    )
    if motion_compensated:
        return np.zeros(f1.shape)
    mean: NDArray[np.float64] = f1 + 2.0 * WAVE_DRIFT_SPEED_MPS / lam * np.cos(phi)
    return mean


def wind_spread_hz(
    wind_speed_mps: ArrayLike, wind_relative_azimuth_rad: ArrayLike, wavelength_m: ArrayLike
) -> NDArray[np.float64]:
    """Spectrum spread from the wind, σ1 = w_s |cos φ_w| / (2 λ), seed [36].

    The seed's φ_w is "the direction of the wind (with respect to true north)", which cannot
    set a spread by itself; we take φ_w as the wind direction relative to the beam (0 upwind),
    and |cos φ_w| since a standard deviation is ≥ 0.  Crosswind gives no wind spread in this
    model (the rotation spread [37] remains).

    Parameters
    ----------
    wind_speed_mps : array_like
        w_s [m/s].
    wind_relative_azimuth_rad : array_like
        φ_w, look direction relative to the wind [rad].
    wavelength_m : array_like
        λ [m].

    Returns
    -------
    ndarray
        σ1 [Hz], ≥ 0.
    """
    return (
        _f(wind_speed_mps)
        * np.abs(np.cos(_f(wind_relative_azimuth_rad)))
        / (2.0 * _f(wavelength_m))
    )


def rotation_spread_hz(
    rotation_rate_rad_s: ArrayLike, beamwidth_rad: ArrayLike
) -> NDArray[np.float64]:
    """Spectrum spread from the antenna scan, σ_r = α / (5.35 θ_b), seed [37].

    Nathanson, Radar Design Principles, eq. 9.76.

    Parameters
    ----------
    rotation_rate_rad_s : array_like
        α [rad/s], ≥ 0 (0: staring antenna, no spread).
    beamwidth_rad : array_like
        Azimuth beamwidth θ_b [rad], > 0.
    """
    b = _f(beamwidth_rad)
    if np.any(b <= 0.0):
        raise ValueError("beamwidth must be > 0")
    return np.abs(_f(rotation_rate_rad_s)) / (ROTATION_SPREAD_DIVISOR * b)


def clutter_spread_hz(*spreads_hz: ArrayLike) -> NDArray[np.float64]:
    """Total spread, the root sum of squares of independent spreads, σ_s = √(σ1² + σ_r²), [38].

    Parameters
    ----------
    *spreads_hz : array_like
        Component standard deviations [Hz].
    """
    total = np.zeros(np.broadcast_shapes(*[np.shape(s) for s in spreads_hz]))
    for s in spreads_hz:
        total = total + _f(s) ** 2
    return np.sqrt(total)


# --------------------------------------------------------------------------- S/C [46]
def signal_to_clutter(
    p_r: ArrayLike, p_sc: ArrayLike, p_wc: ArrayLike, l_c: ArrayLike
) -> NDArray[np.float64]:
    """Signal-to-clutter ratio at the IF output, S/C = P_r / ((P_sc + P_wc) L_c), seed [46].

    Linear.  No clutter (P_sc + P_wc = 0) gives +inf, without a division warning.

    Parameters
    ----------
    p_r : array_like
        Target echo power P_r [W] ([2]).
    p_sc, p_wc : array_like
        Sea and weather clutter powers [W] ([21], [39]), ≥ 0.
    l_c : array_like
        L_c, linear (L_x plus 1 dB in the seed), ≥ 1.

    Returns
    -------
    ndarray
        S/C (linear), ≥ 0.
    """
    p_r, clutter, l_c = np.broadcast_arrays(_f(p_r), _f(p_sc) + _f(p_wc), _f(l_c))
    if np.any(clutter < 0.0):
        raise ValueError("clutter powers must be >= 0")
    denom = clutter * l_c
    has = denom > 0.0
    return np.where(has, p_r / np.where(has, denom, 1.0), np.inf)
