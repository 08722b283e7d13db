"""Propagation over the sea: refractivity profiles, evaporation ducts, sea-surface reflection
and the standard (two-ray) multipath factor.

Seed section 3.1.2, equations [4]-[7].  The off-line parabolic-equation solver that uses these
profiles and surface properties lives in :mod:`shipradar.sensors.parabolic_equation` (its
tables in :mod:`shipradar.tables.propagation`); this module holds the
pure, vectorized physics and the on-line fallback :func:`two_ray_factor` that the seed's last
paragraph of 3.1.2 asks for ("a standard multipath factor calculation ... Ref. 8", Blake).

Conventions
-----------
* Heights are above the mean sea surface [m]; ranges are terrestrial (great-circle) ranges [m].
* Modified refractivity M [M units] is ``(m - 1) * 1e6`` with ``m = n + h / r`` (seed, below [5]).
* Complex permittivities follow the engineering ``exp(+j w t)`` convention of Blake:
  ``eps = eps' - j eps''`` (negative imaginary part for a lossy medium).  The PE solver, which
  uses the physics convention of the seed's [5], conjugates them.
* The propagation factor F is a linear *field* ratio (seed [4]); ``20 log10 F`` is its dB value.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import scipy.constants as sc
from numpy.typing import ArrayLike, NDArray
from scipy.special import i0e

from shipradar.sensors.geometry import EARTH_RADIUS_M, K_FACTOR

# array types of the private helpers' signatures
_Complexes = NDArray[np.complex128]
_Floats = NDArray[np.float64]

# --------------------------------------------------------------------------- reference values
#: Surface modified refractivity of the seed's default profile [M units] (seed, below [7]).
SURFACE_M_UNITS = 320.0
#: Gradient of modified refractivity in the standard atmosphere [M units / m]
#: (0.118 M/m is the 4/3-earth gradient, 1e6 / (4/3 * 6371 km) = 0.1177).
STANDARD_M_GRADIENT = 0.118
#: Neutral-stability slope of the log-linear evaporation-duct profile [M units / m]
#: (seed [7]; Paulus 1985, Radio Sci. 20(4) 887-896, c0 = 0.125 M/m).
EVAPORATION_DUCT_SLOPE = 0.125
#: Aerodynamic roughness length of the sea used in the duct profile [m] (seed, below [7]).
ROUGHNESS_LENGTH_M = 1.5e-4
#: Default sea-surface temperature [degC] and salinity [psu] for the sea-water permittivity.
SEA_TEMPERATURE_C = 15.0
SEA_SALINITY_PSU = 35.0
#: Significant wave height over rms surface height for a narrow-band Gaussian sea
#: (H_1/3 = 4 sigma_h; the seed's w_h is the significant wave height, symbols list).
SIGNIFICANT_TO_RMS_WAVE_HEIGHT = 4.0
#: End of the two-ray interference region, as a multiple of Fock's angular scale
#: (2 / (k a_e))^(1/3) (Fock 1965, ch. 10).  0.7 gave the smallest error of the whole
#: fallback against the PE (3 and 10 GHz, H and V; docs/propagation.md).
INTERFERENCE_LIMIT_FOCK_ANGLES = 0.7

#: Debye high-frequency permittivity of sea water (Klein & Swift 1977).
_EPS_INF_SEA = 4.9

_POLARIZATIONS = {"h": "H", "hp": "H", "horizontal": "H", "v": "V", "vp": "V", "vertical": "V"}


def normalize_polarization(polarization: str) -> str:
    """Return ``"H"`` or ``"V"`` for the accepted spellings (H, HP, horizontal, V, ...)."""
    try:
        return _POLARIZATIONS[str(polarization).strip().lower()]
    except KeyError:
        raise ValueError(f"polarization must be H or V, got {polarization!r}") from None


# =========================================================================== profiles [7]
def standard_profile(
    height_m: ArrayLike, m0: float = SURFACE_M_UNITS, gradient: float = STANDARD_M_GRADIENT
) -> NDArray[np.float64]:
    """Modified refractivity of a linear (standard) atmosphere.

    ``M(h) = m0 + gradient * h``; with the default gradient, the 4/3-earth atmosphere.

    Parameters
    ----------
    height_m : array_like
        Height above the sea surface [m], >= 0.
    m0 : float
        Surface modified refractivity [M units].
    gradient : float
        dM/dh [M units / m].

    Returns
    -------
    ndarray
        M [M units].  Heights below the surface raise ``ValueError``.
    """
    h = _heights(height_m)
    return m0 + gradient * h


def evaporation_duct_profile(
    height_m: ArrayLike,
    duct_height_m: ArrayLike,
    m0: float = SURFACE_M_UNITS,
    z0: float = ROUGHNESS_LENGTH_M,
) -> NDArray[np.float64]:
    """Log-linear evaporation-duct profile, seed [7] (Paulus 1985; Jeske 1973).

    ``M(h) = m0 + 0.125 * (h - delta * ln((h + z0) / z0))``.

    The seed writes ``ln(h / z0)``, which is -inf at the surface and makes M *increase* again
    below ``z0`` (SPEC section 4 item 8).  We use ``ln((h + z0) / z0)``: identical to the seed
    to within ``z0 / h`` (< 1e-4 above 1.5 m), equal to ``m0`` at ``h = 0``, finite and smooth
    down to the surface, with its minimum at ``h = delta - z0`` and a deficit of
    ``0.125 * (delta * ln((delta + z0) / z0) - delta)`` M units (27.0 M for delta = 20 m).
    ``delta = 0`` gives a linear profile of slope 0.125 M/m (the seed's no-duct case).

    Parameters
    ----------
    height_m : array_like
        Height above the sea surface [m], >= 0 (below the surface raises ``ValueError``).
    duct_height_m : array_like
        Evaporation duct height delta [m], >= 0.
    m0 : float
        Surface modified refractivity [M units].
    z0 : float
        Roughness length [m], > 0.

    Returns
    -------
    ndarray
        M [M units], broadcast over ``height_m`` and ``duct_height_m``.
    """
    h = _heights(height_m)
    delta = np.asarray(duct_height_m, dtype=np.float64)
    if np.any(delta < 0):
        raise ValueError("duct height must be >= 0")
    if z0 <= 0:
        raise ValueError("roughness length z0 must be > 0")
    return m0 + EVAPORATION_DUCT_SLOPE * (h - delta * np.log1p(h / z0))


def piecewise_profile(
    heights_m: ArrayLike, m_units: ArrayLike
) -> Callable[[ArrayLike], NDArray[np.float64]]:
    """A user-defined piecewise-linear M profile (surface-based or elevated ducts).

    Parameters
    ----------
    heights_m : array_like
        Strictly increasing break-point heights [m]; the first must be 0 (the surface).
    m_units : array_like
        Modified refractivity at the break points [M units].

    Returns
    -------
    callable
        ``profile(height_m) -> M``: linear interpolation between break points; above the last
        point, linear extrapolation with the slope of the last segment (so a profile that ends
        on a standard 0.118 M/m segment continues it).  Heights below 0 raise ``ValueError``.
    """
    z = np.asarray(heights_m, dtype=np.float64)
    m = np.asarray(m_units, dtype=np.float64)
    if z.ndim != 1 or z.shape != m.shape or z.size < 2:
        raise ValueError("heights_m and m_units must be 1-D of the same length >= 2")
    if z[0] != 0.0 or not np.all(np.diff(z) > 0):
        raise ValueError("heights_m must start at 0 and be strictly increasing")
    if not np.all(np.isfinite(m)):
        raise ValueError("m_units must be finite")
    top_slope = (m[-1] - m[-2]) / (z[-1] - z[-2])

    def profile(height_m: ArrayLike) -> NDArray[np.float64]:
        h = _heights(height_m)
        inside = np.interp(h, z, m)
        return np.where(h > z[-1], m[-1] + top_slope * (h - z[-1]), inside)

    return profile


def normalize_profile_spec(spec: Mapping[str, Any]) -> dict[str, Any]:
    """Fill the defaults of a profile description so that equal profiles hash equally.

    Kinds: ``{"kind": "standard", "m0", "gradient"}``,
    ``{"kind": "evaporation", "duct_height_m", "m0", "z0"}``,
    ``{"kind": "piecewise", "heights_m": [...], "m_units": [...]}``.
    """
    kind = str(spec.get("kind", "")).lower()
    if kind == "standard":
        out = {"kind": kind, "m0": SURFACE_M_UNITS, "gradient": STANDARD_M_GRADIENT}
    elif kind == "evaporation":
        out = {"kind": kind, "m0": SURFACE_M_UNITS, "z0": ROUGHNESS_LENGTH_M}
        if "duct_height_m" not in spec:
            raise ValueError("evaporation profile needs duct_height_m")
    elif kind == "piecewise":
        out = {"kind": kind}
        if "heights_m" not in spec or "m_units" not in spec:
            raise ValueError("piecewise profile needs heights_m and m_units")
    else:
        raise ValueError(f"unknown profile kind {spec.get('kind')!r}")
    for key, value in spec.items():
        if key == "kind":
            continue
        if key not in out and kind != "piecewise" and key != "duct_height_m":
            raise ValueError(f"unknown key {key!r} for a {kind} profile")
        if isinstance(value, (list, tuple, np.ndarray)):
            out[key] = [float(v) for v in value]
        else:
            out[key] = float(value)
    return out


def profile_from_spec(spec: Mapping[str, Any]) -> Callable[[ArrayLike], NDArray[np.float64]]:
    """Build the callable M profile [M units] of a description (:func:`normalize_profile_spec`)."""
    s = normalize_profile_spec(spec)
    if s["kind"] == "standard":
        return lambda h: standard_profile(h, s["m0"], s["gradient"])
    if s["kind"] == "evaporation":
        return lambda h: evaporation_duct_profile(h, s["duct_height_m"], s["m0"], s["z0"])
    return piecewise_profile(s["heights_m"], s["m_units"])


def _heights(height_m: ArrayLike) -> NDArray[np.float64]:
    h = np.asarray(height_m, dtype=np.float64)
    if np.any(h < 0):
        raise ValueError("heights must be >= 0 (above the sea surface)")
    return h


# =========================================================================== bulk duct model
#: von Karman constant.
_VON_KARMAN = 0.4
#: Gas constant of dry air [J/(kg K)] and its specific heat at constant pressure [J/(kg K)].
_R_DRY = 287.05
_CP_DRY = 1004.67
#: Charnock constant (Smith 1988) and smooth-flow coefficient for the momentum roughness.
_CHARNOCK = 0.011
_KINEMATIC_VISCOSITY_AIR = 1.5e-5  # [m^2/s] near 15 degC
#: Vapour-pressure reduction over sea water by salinity (Kraus & Businger 1994).
_SALINE_VAPOUR_FACTOR = 0.98
#: Lowest wind used by the bulk model [m/s] (calm is outside similarity theory).
_MIN_WIND_MPS = 0.5
#: Largest duct height returned [m]; above this, similarity theory in very stable air
#: is not trusted (Babin et al. 1997 sec. 5) and the profile would be mostly an elevated layer.
MAX_EVAPORATION_DUCT_HEIGHT_M = 40.0


def _saturation_vapour_pressure_hpa(t_c: NDArray[np.float64]) -> NDArray[np.float64]:
    """Buck (1981) saturation vapour pressure over water [hPa] at temperature [degC]."""
    return 6.1121 * np.exp(17.502 * t_c / (240.97 + t_c))


def _psi_m(zeta: NDArray[np.float64]) -> NDArray[np.float64]:
    """Momentum stability correction: Paulson (1970) unstable, Beljaars-Holtslag (1991) stable."""
    x = np.sqrt(np.sqrt(1.0 - 16.0 * np.minimum(zeta, 0.0)))
    unstable = 2 * np.log((1 + x) / 2) + np.log((1 + x * x) / 2) - 2 * np.arctan(x) + np.pi / 2
    zs = np.maximum(zeta, 0.0)
    stable = -(zs + (2 / 3) * (zs - 5 / 0.35) * np.exp(-0.35 * zs) + (2 / 3) * 5 / 0.35)
    return np.where(zeta < 0, unstable, stable)


def _psi_h(zeta: NDArray[np.float64]) -> NDArray[np.float64]:
    """Scalar stability correction: Paulson (1970) unstable, Beljaars-Holtslag (1991) stable."""
    y = np.sqrt(1.0 - 16.0 * np.minimum(zeta, 0.0))
    unstable = 2 * np.log((1 + y) / 2)
    zs = np.maximum(zeta, 0.0)
    stable = -(
        (1 + 2 * zs / 3) ** 1.5 + (2 / 3) * (zs - 5 / 0.35) * np.exp(-0.35 * zs)
        + (2 / 3) * 5 / 0.35 - 1
    )
    return np.where(zeta < 0, unstable, stable)


def _phi_h(zeta: NDArray[np.float64]) -> NDArray[np.float64]:
    """Dimensionless scalar gradient, phi_h = 1 - zeta dpsi_h/dzeta (same functions as _psi_h)."""
    unstable = 1.0 / np.sqrt(1.0 - 16.0 * np.minimum(zeta, 0.0))
    zs = np.maximum(zeta, 0.0)
    stable = 1 + zs * (np.sqrt(1 + 2 * zs / 3) + (2 / 3) * np.exp(-0.35 * zs) * (1 + 5 - 0.35 * zs))
    return np.where(zeta < 0, unstable, stable)


def surface_duct_height(heights_m: ArrayLike, m_units: ArrayLike) -> float:
    """Top [m] of a surface-based duct of a piecewise-linear M-profile, 0 if it has none.

    A layer traps down to the surface when the profile's minimum M is not above M(0); the
    duct then reaches from the sea to the height of that minimum (its trapping layer's top).
    An elevated duct (minimum above M(0)) and a profile whose minimum is at the surface give 0.

    Parameters
    ----------
    heights_m : array_like
        Heights of the profile's nodes [m], ascending from the surface.
    m_units : array_like
        Modified refractivity M at those heights [M units].

    Returns
    -------
    float
        Height of the duct's top [m], or 0.
    """
    m = np.asarray(m_units, dtype=float)
    i = int(np.argmin(m))
    return float(np.asarray(heights_m, dtype=float)[i]) if i > 0 and m[i] <= m[0] else 0.0


# long: 35 docstring lines; the bulk (NPS-type) model is one iteration over its stability functions
def evaporation_duct_height(
    air_temperature_c: ArrayLike,
    sea_temperature_c: ArrayLike,
    relative_humidity: ArrayLike,
    wind_speed_mps: ArrayLike,
    pressure_hpa: ArrayLike = 1013.25,
    *,
    measurement_height_m: float = 10.0,
    iterations: int = 30,
) -> NDArray[np.float64]:
    """Evaporation duct height from bulk meteorology (Monin-Obukhov similarity).

    The seed uses the unpublished WKD model (SPEC section 4 item 19).  This is a bulk
    Monin-Obukhov model of the kind of Babin, Young & Carton (1997), J. Appl. Meteor. 36,
    193-204, and the NPS model (Frederickson et al. 2000): surface-layer fluxes of potential
    temperature and specific humidity from the air-sea differences, with Paulson (1970) /
    Beljaars & Holtslag (1991) stability functions, Charnock (alpha = 0.011) momentum roughness
    and the seed's scalar roughness z0 = 1.5e-4 m; refractivity N = 77.6/T (P + 4810 e/T)
    (ITU-R P.453); the duct height is the lowest height where dM/dz = dN/dz + 1e6/a = 0.

    Parameters
    ----------
    air_temperature_c : array_like
        Air temperature at the measurement height [degC].
    sea_temperature_c : array_like
        Sea-surface temperature [degC].
    relative_humidity : array_like
        Relative humidity at the measurement height, a fraction in [0, 1] [1].
    wind_speed_mps : array_like
        Wind speed at the measurement height [m/s]; below 0.5 m/s, 0.5 m/s is used (calm is
        outside similarity theory).
    pressure_hpa : array_like
        Surface air pressure [hPa].
    measurement_height_m : float
        Height of the wind, temperature and humidity measurements [m].
    iterations : int
        Fixed-point iterations of the stability parameter.

    Returns
    -------
    ndarray
        Duct height [m] in [0, MAX_EVAPORATION_DUCT_HEIGHT_M].  0 when the air is at least as
        moist as the sea surface (no evaporation, no duct); the cap is reached in very stable
        air, where the similarity profiles (and BYC's model) are not trusted.
    """
    ta, ts, rh, u, p = np.broadcast_arrays(
        *[np.asarray(v, dtype=np.float64) for v in
          (air_temperature_c, sea_temperature_c, relative_humidity, wind_speed_mps, pressure_hpa)]
    )
    if np.any((rh < 0) | (rh > 1)):
        raise ValueError("relative_humidity is a fraction in [0, 1]")
    if np.any(p <= 0):
        raise ValueError("pressure must be > 0")
    z_r = float(measurement_height_m)
    g = sc.g
    gamma_d = g / _CP_DRY
    u = np.maximum(u, _MIN_WIND_MPS)
    e_air = rh * _saturation_vapour_pressure_hpa(ta)
    e_sea = _SALINE_VAPOUR_FACTOR * _saturation_vapour_pressure_hpa(ts)
    q_air = 0.622 * e_air / (p - 0.378 * e_air)
    q_sea = 0.622 * e_sea / (p - 0.378 * e_sea)
    t_air_k = ta + sc.zero_Celsius
    theta_air = t_air_k + gamma_d * z_r
    theta_sea = ts + sc.zero_Celsius
    d_theta = theta_air - theta_sea
    d_q = q_air - q_sea
    theta_v = theta_air * (1 + 0.608 * q_air)

    z0h = ROUGHNESS_LENGTH_M
    zeta = np.zeros_like(ta)
    u_star = _VON_KARMAN * u / np.log(z_r / 1e-4)
    for _ in range(iterations):
        z0m = _CHARNOCK * u_star**2 / g + 0.11 * _KINEMATIC_VISCOSITY_AIR / u_star
        u_star = _VON_KARMAN * u / (np.log(z_r / z0m) - _psi_m(zeta))
        denom_h = np.log(z_r / z0h) - _psi_h(zeta)
        theta_star = _VON_KARMAN * d_theta / denom_h
        q_star = _VON_KARMAN * d_q / denom_h
        thv_star = theta_star * (1 + 0.608 * q_air) + 0.608 * theta_air * q_star
        zeta_new = np.clip(_VON_KARMAN * g * z_r * thv_star / (theta_v * u_star**2), -10.0, 10.0)
        zeta = 0.5 * zeta + 0.5 * zeta_new  # damped: converges in stable air too
    obukhov = z_r / np.where(zeta == 0, 1e-12, zeta)

    # dN/dz from the flux-profile relations, coefficients at the measurement height.
    tv_air = t_air_k * (1 + 0.608 * q_air)
    dn_dt = -77.6 * p / t_air_k**2 - 2 * 3.732e5 * e_air / t_air_k**3
    dn_dp = 77.6 / t_air_k
    dn_de = 3.732e5 / t_air_k**2
    dp_dz = -p * g / (_R_DRY * tv_air)
    de_dq = 0.622 * p / (0.622 + 0.378 * q_air) ** 2

    def dm_dz(z: NDArray[np.float64]) -> NDArray[np.float64]:
        ph = _phi_h(z / obukhov)
        dtheta_dz = theta_star * ph / (_VON_KARMAN * z)
        dq_dz = q_star * ph / (_VON_KARMAN * z)
        de_dz = de_dq * dq_dz + e_air / p * dp_dz
        dn_dz: NDArray[np.float64] = dn_dt * (dtheta_dz - gamma_d) + dn_dp * dp_dz + dn_de * de_dz
        return dn_dz + 1e6 / EARTH_RADIUS_M

    lo = np.full_like(ta, np.log(1e-3))
    hi = np.full_like(ta, np.log(MAX_EVAPORATION_DUCT_HEIGHT_M))
    no_duct = dm_dz(np.exp(lo)) >= 0
    capped = dm_dz(np.exp(hi)) < 0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        neg = dm_dz(np.exp(mid)) < 0
        lo = np.where(neg, mid, lo)
        hi = np.where(neg, hi, mid)
    delta = np.exp(0.5 * (lo + hi))
    delta = np.where(capped, MAX_EVAPORATION_DUCT_HEIGHT_M, delta)
    return np.where(no_duct, 0.0, delta)


# =========================================================================== sea surface
def sea_water_permittivity(
    freq_hz: ArrayLike,
    temperature_c: ArrayLike = SEA_TEMPERATURE_C,
    salinity_psu: ArrayLike = SEA_SALINITY_PSU,
) -> NDArray[np.complex128]:
    """Complex relative permittivity of sea water, Klein & Swift (1977) Debye model.

    Klein, L. A. & Swift, C. T. (1977), IEEE Trans. Antennas Propag. 25(1), 104-111: single
    Debye relaxation with static permittivity and relaxation time fitted in temperature and
    salinity, plus the ionic conductivity of Stogryn (1971).  Stated for 1.4 GHz and below but
    widely used to ~10-40 GHz (Blake 1986 sec. 6.4); above ~20 GHz a double-Debye model
    (Meissner & Wentz 2004) is more accurate.

    Parameters
    ----------
    freq_hz : array_like
        Frequency [Hz], > 0.
    temperature_c : array_like
        Water temperature [degC], about -2 to 35.
    salinity_psu : array_like
        Salinity [psu], about 4 to 40.

    Returns
    -------
    ndarray of complex
        ``eps' - j eps''`` (engineering sign, eps'' >= 0 includes the conduction term
        sigma / (omega eps0)).
    """
    f = np.asarray(freq_hz, dtype=np.float64)
    if np.any(f <= 0):
        raise ValueError("frequency must be > 0")
    t = np.asarray(temperature_c, dtype=np.float64)
    s = np.asarray(salinity_psu, dtype=np.float64)
    eps_static = (87.134 - 1.949e-1 * t - 1.276e-2 * t**2 + 2.491e-4 * t**3) * (
        1.0 + 1.613e-5 * s * t - 3.656e-3 * s + 3.210e-5 * s**2 - 4.232e-7 * s**3
    )
    tau = (1.768e-11 - 6.086e-13 * t + 1.104e-14 * t**2 - 8.111e-17 * t**3) * (
        1.0 + 2.282e-5 * s * t - 7.638e-4 * s - 7.760e-6 * s**2 + 1.105e-8 * s**3
    )
    sigma = sea_water_conductivity(t, s)
    omega = 2 * np.pi * f
    # numpy's stubs type float array / complex array as an untyped ndarray
    relaxation: NDArray[np.complex128] = (eps_static - _EPS_INF_SEA) / (1 + 1j * omega * tau)
    debye = _EPS_INF_SEA + relaxation
    conduction: _Complexes = 1j * sigma / (omega * sc.epsilon_0)  # scipy.constants is untyped
    return debye - conduction


def sea_water_conductivity(temperature_c: ArrayLike, salinity_psu: ArrayLike) -> _Floats:
    """Ionic conductivity of sea water [S/m], Stogryn (1971) as used by Klein & Swift (1977).

    Parameters
    ----------
    temperature_c : array_like
        Water temperature [degC].
    salinity_psu : array_like
        Salinity [psu].

    Returns
    -------
    ndarray
        Conductivity [S/m]; 4.29 S/m at 15 degC, 35 psu (standard sea water).
    """
    t = np.asarray(temperature_c, dtype=np.float64)
    s = np.asarray(salinity_psu, dtype=np.float64)
    delta = 25.0 - t
    beta = (
        2.0333e-2 + 1.266e-4 * delta + 2.464e-6 * delta**2
        - s * (1.849e-5 - 2.551e-7 * delta + 2.551e-8 * delta**2)
    )
    sigma25 = s * (0.182521 - 1.46192e-3 * s + 2.09324e-5 * s**2 - 1.28205e-7 * s**3)
    return sigma25 * np.exp(-delta * beta)


def fresnel_reflection(
    grazing_rad: ArrayLike, permittivity: ArrayLike, polarization: str
) -> NDArray[np.complex128]:
    """Fresnel reflection coefficient of a smooth plane surface (Blake 1986 eq. 6.8-6.9).

    ``Gamma_H = (sin psi - sqrt(eps - cos^2 psi)) / (sin psi + sqrt(eps - cos^2 psi))``,
    ``Gamma_V = (eps sin psi - sqrt(eps - cos^2 psi)) / (eps sin psi + sqrt(eps - cos^2 psi))``.

    Parameters
    ----------
    grazing_rad : array_like
        Grazing angle psi [rad] in [0, pi/2].
    permittivity : array_like of complex
        Relative permittivity ``eps' - j eps''`` (e.g. :func:`sea_water_permittivity`);
        ``inf`` gives a perfect conductor (Gamma_H = -1, Gamma_V = +1 for psi > 0).
    polarization : str
        ``"H"`` or ``"V"``.

    Returns
    -------
    ndarray of complex
        Gamma; both polarizations tend to -1 at zero grazing, |Gamma_V| has its (pseudo-)
        Brewster minimum near sin psi = 1/sqrt(|eps|).
    """
    pol = normalize_polarization(polarization)
    psi = np.asarray(grazing_rad, dtype=np.float64)
    eps = np.asarray(permittivity, dtype=np.complex128)
    if np.any((psi < 0) | (psi > np.pi / 2 + 1e-12)):
        raise ValueError("grazing angle must be in [0, pi/2]")
    sin_psi = np.sin(psi)
    if np.all(np.isinf(eps.real)):
        ones = np.ones(np.broadcast(psi, eps).shape, dtype=np.complex128)
        return -ones if pol == "H" else np.where(sin_psi > 0, ones, -ones)
    root: NDArray[np.complex128] = np.sqrt(eps - np.cos(psi) ** 2)
    if pol == "H":
        return (sin_psi - root) / (sin_psi + root)
    return (eps * sin_psi - root) / (eps * sin_psi + root)


def rms_wave_height(wave_height_m: ArrayLike) -> NDArray[np.float64]:
    """RMS sea-surface height [m] from the significant wave height [m] (H_1/3 = 4 sigma_h)."""
    w = np.asarray(wave_height_m, dtype=np.float64)
    if np.any(w < 0):
        raise ValueError("wave height must be >= 0")
    return w / SIGNIFICANT_TO_RMS_WAVE_HEIGHT


def roughness_factor(
    grazing_rad: ArrayLike,
    wave_height_m: ArrayLike,
    freq_hz: ArrayLike,
    model: str = "miller-brown",
) -> NDArray[np.float64]:
    """Specular scattering (roughness) factor of a Gaussian sea.

    With ``g = 2 pi sigma_h sin(psi) / lambda`` (Rayleigh roughness parameter):
    ``"ament"`` (Ament 1953): ``rho = exp(-2 g^2)``;
    ``"miller-brown"`` (Miller, Brown & Vegh 1984, IEE Proc. 131H): ``rho = exp(-2 g^2) I0(2 g^2)``,
    computed as ``i0e(2 g^2)`` so that it stays finite for any roughness.

    Parameters
    ----------
    grazing_rad : array_like
        Grazing angle [rad].
    wave_height_m : array_like
        Significant wave height H_1/3 [m] (seed symbol w_h); sigma_h = H_1/3 / 4.
    freq_hz : array_like
        Frequency [Hz].
    model : str
        ``"miller-brown"`` (default) or ``"ament"``.

    Returns
    -------
    ndarray
        rho in (0, 1]; 1 for a calm sea or zero grazing.  Miller-Brown decays as
        ``1 / (2 g sqrt(pi))`` for very rough seas, Ament exponentially.
    """
    psi = np.asarray(grazing_rad, dtype=np.float64)
    lam = sc.c / np.asarray(freq_hz, dtype=np.float64)
    g = 2 * np.pi * rms_wave_height(wave_height_m) * np.sin(psi) / lam
    x = 2 * g**2
    name = model.lower()
    rho: NDArray[np.float64]
    if name == "ament":
        rho = np.exp(-x)
    elif name in ("miller-brown", "miller_brown", "millerbrown"):
        rho = i0e(x)  # scipy is untyped
    else:
        raise ValueError(f"unknown roughness model {model!r}")
    return rho


# =========================================================================== two-ray [4]
def _reflection_geometry(d: _Floats, h1: _Floats, h2: _Floats, a_e: float) -> _Floats:
    """Specular point on a sphere of radius a_e (Kerr 1951 / Blake 1986 eq. 6.33-6.35).

    Returns d1 (ground distance antenna -> specular point) [m].  Requires line of sight.
    """
    p = (2 / np.sqrt(3)) * np.sqrt(a_e * (h1 + h2) + d**2 / 4)
    # p = 0 only when d = h1 = h2 = 0 (both ends on the surface at one point): arg -> 0 there
    p3 = p**3
    arg = np.clip(np.divide(2 * a_e * (h1 - h2) * d, p3, out=np.zeros_like(p3), where=p3 > 0),
                  -1.0, 1.0)
    phi = np.arccos(arg)
    d1: NDArray[np.float64] = np.clip(d / 2 + p * np.cos((phi + np.pi) / 3), 0.0, d)
    return d1


def _chord(h_a: _Floats | float, h_b: _Floats | float, a_e: float, angle: _Floats) -> _Floats:
    """Straight-line distance between points at heights h_a, h_b separated by central angle."""
    return np.sqrt((h_a - h_b) ** 2 + 4 * (a_e + h_a) * (a_e + h_b) * np.sin(angle / 2) ** 2)


def _elevation(
    h_from: _Floats, h_to: _Floats, a_e: float, angle: _Floats, dist: _Floats
) -> _Floats:
    """Elevation angle [rad] at the point of height h_from of the chord to h_to."""
    num = (a_e + h_to) * np.cos(angle) - (a_e + h_from)
    return np.arcsin(np.clip(num / np.maximum(dist, 1e-9), -1.0, 1.0))


def horizon_range(h1: ArrayLike, h2: ArrayLike, k_factor: float = K_FACTOR) -> _Floats:
    """Radio-horizon range sqrt(2 a_e h1) + sqrt(2 a_e h2) [m] for heights h1, h2 [m]."""
    a_e = k_factor * EARTH_RADIUS_M
    return (np.sqrt(2 * a_e * np.asarray(h1, np.float64))
            + np.sqrt(2 * a_e * np.asarray(h2, np.float64)))


# params: two_ray_factor's geometry, sea and pattern inputs (its terms without the target)
def two_ray_terms(
    d: _Floats, h1: _Floats, h2: _Floats, freq: float, pol: str, wave: float,
    pattern: Callable[[NDArray[np.float64]], NDArray[np.float64]], tilt: float, k_factor: float,
    eps: NDArray[np.complex128] | complex, roughness_model: str,
) -> tuple[NDArray[np.float64], NDArray[np.complex128], NDArray[np.float64]]:
    """Direct and reflected complex terms of the interference-region multipath factor.

    The two terms of the two-ray pattern propagation factor at ground ranges ``d`` [m] between
    heights ``h1`` and ``h2`` [m] over a 4/3 earth of factor ``k_factor`` (``freq`` [Hz],
    ``pol`` 'H'/'V', ``wave`` the wave height [m], ``pattern`` the voltage pattern of the
    elevation [rad], ``tilt`` [rad], ``eps`` the sea's relative permittivity): the direct
    term, the reflected term (F = |direct + reflected|) and the grazing angle [rad] at the
    specular point. The dwell model evaluates them per target (the on-line multipath).
    """
    a_e = k_factor * EARTH_RADIUS_M
    lam = sc.c / freq
    d1 = _reflection_geometry(d, h1, h2, a_e)
    d2 = d - d1
    phi, phi1, phi2 = d / a_e, d1 / a_e, d2 / a_e
    r_direct = _chord(h1, h2, a_e, phi)
    r1 = _chord(h1, 0.0, a_e, phi1)
    r2 = _chord(0.0, h2, a_e, phi2)
    # grazing angle at the specular point, seen from the antenna leg
    num = (a_e + h1) * np.cos(phi1) - a_e
    psi = np.arcsin(np.clip(num / np.maximum(r1, 1e-9), 0.0, 1.0))
    psi = np.where(r1 > 1e-9, psi, np.arcsin(np.clip(((a_e + h2) * np.cos(phi2) - a_e)
                                                       / np.maximum(r2, 1e-9), 0.0, 1.0)))
    elev_direct = _elevation(h1, h2, a_e, phi, r_direct)
    elev_reflect = -np.arcsin(np.clip(((a_e + h1) - a_e * np.cos(phi1)) / np.maximum(r1, 1e-9),
                                      0.0, 1.0))
    elev_reflect = np.where(r1 > 1e-9, elev_reflect, -np.pi / 2)
    sin_psi = np.sin(psi)
    num_d = a_e * d * sin_psi
    den_d = num_d + 2 * d1 * d2
    divergence = np.sqrt(np.divide(num_d, den_d, out=np.ones_like(den_d), where=den_d > 0))
    gamma = fresnel_reflection(psi, eps, pol)
    rho = roughness_factor(psi, wave, freq, roughness_model)
    path_difference = (r1 + r2) - r_direct
    g_direct = pattern(elev_direct - tilt)
    g_reflect = pattern(elev_reflect - tilt)
    spread = np.divide(r_direct, r1 + r2, out=np.ones_like(r_direct), where=(r1 + r2) > 0)
    reflected = (g_reflect * rho * divergence * spread * gamma
                 * np.exp(-1j * 2 * np.pi * path_difference / lam))
    return g_direct, reflected, psi


def smooth_earth_diffraction_factor(
    range_m: ArrayLike,
    antenna_height_m: ArrayLike,
    target_height_m: ArrayLike,
    freq_hz: float,
    polarization: str,
    *,
    k_factor: float = K_FACTOR,
    permittivity: complex | None = None,
) -> NDArray[np.float64]:
    """Propagation factor beyond the horizon of a smooth sphere, first term of the residue series.

    ITU-R P.526-15 sec. 3.1.1.2: ``20 log F = F(X) + G(Y1) + G(Y2)`` with the normalized
    distance X and heights Y, and the surface admittance K of sea water (polarization).

    Parameters
    ----------
    range_m : array_like
        Terrestrial range [m], > 0.
    antenna_height_m, target_height_m : array_like
        Heights [m], >= 0.
    freq_hz : float
        Frequency [Hz].
    polarization : str
        ``"H"`` or ``"V"``.
    k_factor : float
        Effective-earth-radius factor.
    permittivity : complex, optional
        Surface permittivity ``eps' - j eps''``; default sea water at 15 degC, 35 psu;
        ``inf`` a perfect conductor (the limits K_H = 0, K_V = inf of P.526's admittance).

    Returns
    -------
    ndarray
        F (linear field factor).  Accurate at and beyond the radio horizon; inside the horizon
        the first term over-estimates F and :func:`two_ray_factor` does not use it there.
        Ranges below 1 micrometre are evaluated at 1 micrometre (X > 0 for the log of F(X)).
    """
    pol = normalize_polarization(polarization)
    eps = sea_water_permittivity(freq_hz) if permittivity is None else complex(permittivity)
    f_mhz = freq_hz / 1e6
    a_km = k_factor * EARTH_RADIUS_M / 1e3
    d_km = np.maximum(np.asarray(range_m, dtype=np.float64) / 1e3, 1e-9)
    eps_r = eps.real
    x60 = -eps.imag  # 60 lambda sigma = 18000 sigma / f_MHz in P.526 notation
    if np.isinf(eps_r) or np.isinf(x60):
        # a perfect conductor: K_H -> 0 and K_V -> inf (P.526's K_V = K_H |eps|), whose beta
        # limits are 1 and 0.67/1.53; neither has the small-K floor of G(Y)
        k_adm = 0.0 if pol == "H" else np.inf
        beta = 1.0 if pol == "H" else 0.67 / 1.53
    else:
        k_h = 0.36 * (a_km * f_mhz) ** (-1 / 3) * ((eps_r - 1) ** 2 + x60**2) ** (-0.25)
        k_adm = k_h if pol == "H" else k_h * np.sqrt(eps_r**2 + x60**2)
        beta = (1 + 1.6 * k_adm**2 + 0.67 * k_adm**4) / (1 + 4.5 * k_adm**2 + 1.53 * k_adm**4)
    floor_db = 2 + 20 * np.log10(k_adm) if 0.0 < k_adm < np.inf else -np.inf
    x = np.maximum(2.188 * beta * f_mhz ** (1 / 3) * a_km ** (-2 / 3) * d_km, 1e-12)
    f_x = np.where(
        x >= 1.6, 11 + 10 * np.log10(x) - 17.6 * x, -20 * np.log10(x) - 5.6488 * x**1.425
    )

    def g_y(h_m: ArrayLike) -> NDArray[np.float64]:
        b = (beta * 9.575e-3 * beta * f_mhz ** (2 / 3) * a_km ** (-1 / 3)
             * np.asarray(h_m, np.float64))
        excess = np.maximum(b - 1.1, 1e-12)
        high = 17.6 * np.sqrt(excess) - 5 * np.log10(excess) - 8
        low = 20 * np.log10(np.maximum(b + 0.1 * b**3, 1e-300))
        g_db: NDArray[np.float64] = np.maximum(np.where(b > 2, high, low), floor_db)
        return g_db

    loss_db: NDArray[np.float64] = f_x + g_y(antenna_height_m) + g_y(target_height_m)
    factor: NDArray[np.float64] = 10 ** (loss_db / 20)
    return factor


def interference_region_limit(
    antenna_height_m: ArrayLike,
    target_height_m: ArrayLike,
    freq_hz: float,
    k_factor: float = K_FACTOR,
    fock_angles: float | None = None,
) -> NDArray[np.float64]:
    """Largest range [m] of the two-ray interference region for the given heights [m].

    The range at which the grazing angle at the specular point falls to
    ``fock_angles * (2 / (k a_e))^(1/3)`` (Fock's angular scale, below which ray optics
    fails; default ``INTERFERENCE_LIMIT_FOCK_ANGLES``).  It is found by bisection: psi
    decreases with range at fixed heights.
    0 when a height is 0 (no specular reflection off the line of sight).

    Parameters
    ----------
    antenna_height_m, target_height_m : array_like
        Heights [m], >= 0.
    freq_hz : float
        Frequency [Hz].
    k_factor : float
        Effective-earth-radius factor.
    fock_angles : float, optional
        The limit in units of Fock's angular scale.

    Returns
    -------
    ndarray
        Range [m], below the radio horizon :func:`horizon_range`.
    """
    h1, h2 = np.broadcast_arrays(np.asarray(antenna_height_m, np.float64),
                                 np.asarray(target_height_m, np.float64))
    a_e = k_factor * EARTH_RADIUS_M
    k = 2 * np.pi * freq_hz / sc.c
    scale = INTERFERENCE_LIMIT_FOCK_ANGLES if fock_angles is None else fock_angles
    psi_limit = scale * (2 / (k * a_e)) ** (1 / 3)
    lo = np.zeros(h1.shape)
    hi = horizon_range(h1, h2, k_factor)
    for _ in range(48):
        mid = 0.5 * (lo + hi)
        d1 = _reflection_geometry(mid, h1, h2, a_e)
        r1 = _chord(h1, 0.0, a_e, d1 / a_e)
        sin_psi = np.divide((a_e + h1) * np.cos(d1 / a_e) - a_e, r1,
                            out=np.zeros_like(r1), where=r1 > 0)
        above = sin_psi > np.sin(psi_limit)
        lo = np.where(above, mid, lo)
        hi = np.where(above, hi, mid)
    return lo


# long: 51 docstring lines; 3.1.2's two-ray chain (divergence, Fresnel, roughness, diffraction)
# params: the geometry, the sea and the pattern of 3.1.2, each an input with its unit
def two_ray_factor(
    range_m: ArrayLike,
    antenna_height_m: ArrayLike,
    target_height_m: ArrayLike,
    freq_hz: float,
    polarization: str,
    *,
    wave_height_m: float = 0.0,
    elevation_pattern: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None,
    k_factor: float = K_FACTOR,
    tilt_rad: float = 0.0,
    permittivity: complex | None = None,
    roughness_model: str = "miller-brown",
) -> NDArray[np.float64]:
    """Standard multipath propagation factor over a spherical sea (seed [4], 3.1.2 last para).

    Interference region (Blake 1986 sec. 6.5-6.7; SPEC section 4 item 22)::

        F = | g(th_d) + g(th_r) rho D (R_d / (R_1 + R_2)) Gamma exp(-j k Delta) |

    with the specular point on an earth of radius ``k_factor * a`` (Kerr's cubic), the exact
    path difference Delta of the chords, the divergence factor
    ``D = (1 + 2 d1 d2 / (a_e d sin psi))^-1/2``, the Fresnel coefficient of sea water
    (:func:`fresnel_reflection`) and the Miller-Brown roughness factor (:func:`roughness_factor`).
    Each ray gets the pattern at its own elevation at the antenna (``g(elev - tilt)``).

    Beyond the horizon (range >= sqrt(2 a_e h1) + sqrt(2 a_e h2)) F is the smooth-earth
    diffraction factor (:func:`smooth_earth_diffraction_factor`, ITU-R P.526 first term) times
    the pattern at the antenna's horizon ray.  Ray optics needs the grazing angle to be well
    above Fock's angular scale ``(2 / (k a_e))^(1/3)`` (0.09 deg at 3 GHz); near the horizon
    D -> 0 would make the two-ray model tend wrongly to F = 1.  So between the range where
    psi falls to that scale and the horizon, F is interpolated linearly in dB against range
    (Blake 1986 sec. 6.9, "intermediate region").  Tropospheric scatter is not modelled.

    Parameters
    ----------
    range_m : array_like
        Terrestrial range [m], >= 0.
    antenna_height_m : array_like
        Antenna phase-centre height above the sea [m], >= 0.
    target_height_m : array_like
        Target height above the sea [m], >= 0.
    freq_hz : float
        Carrier frequency [Hz].
    polarization : str
        ``"H"`` or ``"V"``.
    wave_height_m : float
        Significant wave height [m] (seed w_h); 0 for a smooth sea.
    elevation_pattern : callable, optional
        ``g(elev_rad) -> field factor`` relative to its peak (1 on the peak); None: isotropic.
    k_factor : float
        Effective-earth-radius factor (4/3 standard atmosphere).
    tilt_rad : float
        Elevation of the beam axis [rad]; the pattern is evaluated at ``elev - tilt``.
    permittivity : complex, optional
        Surface permittivity ``eps' - j eps''``; default sea water 15 degC, 35 psu.
    roughness_model : str
        ``"miller-brown"`` or ``"ament"``.

    Returns
    -------
    ndarray
        F >= 0 (linear), broadcast over the array arguments; F -> g(elev) at short range with
        the reflected ray far down the pattern; F -> 0 at zero target height over a smooth sea.
    """
    pol = normalize_polarization(polarization)
    pattern = isotropic_pattern if elevation_pattern is None else elevation_pattern
    d, h1, h2 = np.broadcast_arrays(
        *[np.asarray(v, dtype=np.float64) for v in (range_m, antenna_height_m, target_height_m)]
    )
    if np.any(d < 0) or np.any(h1 < 0) or np.any(h2 < 0):
        raise ValueError("range and heights must be >= 0")
    freq = float(freq_hz)
    eps = sea_water_permittivity(freq) if permittivity is None else complex(permittivity)
    a_e = k_factor * EARTH_RADIUS_M
    d_h = horizon_range(h1, h2, k_factor)

    def two_ray(dd: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        gd, refl, psi = two_ray_terms(dd, h1, h2, freq, pol, wave_height_m, pattern, tilt_rad,
                                      k_factor, eps, roughness_model)
        return np.abs(gd + refl), psi

    d_lim = interference_region_limit(h1, h2, freq, k_factor)
    f_lim, _ = two_ray(d_lim)

    g_horizon = np.abs(pattern(-np.arccos(a_e / (a_e + h1)) - tilt_rad))
    diffraction = smooth_earth_diffraction_factor(
        np.maximum(d, d_h), h1, h2, freq, pol, k_factor=k_factor, permittivity=complex(eps)
    ) * g_horizon
    f_diff_horizon = smooth_earth_diffraction_factor(
        d_h, h1, h2, freq, pol, k_factor=k_factor, permittivity=complex(eps)
    ) * g_horizon

    f_inter, _ = two_ray(np.minimum(d, d_lim))
    tiny = 1e-30
    span = np.maximum(d_h - d_lim, 1e-9)
    w = np.clip((d - d_lim) / span, 0.0, 1.0)
    intermediate = np.exp(
        (1 - w) * np.log(np.maximum(f_lim, tiny)) + w * np.log(np.maximum(f_diff_horizon, tiny))
    )
    return np.where(d <= d_lim, f_inter, np.where(d < d_h, intermediate, diffraction))


def isotropic_pattern(elev_rad: NDArray[np.float64]) -> NDArray[np.float64]:
    """Voltage pattern 1 at every elevation [rad]: no pattern in the propagation factor."""
    return np.ones_like(np.asarray(elev_rad, dtype=np.float64))
