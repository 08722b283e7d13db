"""One-way atmospheric loss along the radar-target path, seed section 3.1.5, equation [16].

``L_atm = L_wo + R_s (γ_f/c + γ_r + γ_ic)`` [16].  The seed's Ref. 2 (CARPET) is not
reproduced; SPEC §4 item 20 prescribes the ITU-R recommendations through the ``itur``
package:

* L_wo, oxygen and water vapour: ITU-R P.676-12 Annex 1 (line-by-line) specific
  attenuations at the surface, ``itur.models.itu676.gamma0_exact`` / ``gammaw_exact``, carried
  along the slant path by the exponential profiles of P.676-12 Annex 2 §2.2 (inclined
  paths): ``γ(h) = γ_o exp(-h/h_o) + γ_w exp(-h/h_w)`` with the equivalent heights h_o, h_w
  of P.676-12 Annex 2 eqs. (31)-(38).  The height along the path follows a straight ray over
  a 4/3 effective earth (standard refraction), so a horizontal path climbs as s²/(2 a_e)
  and a steep one leaves the absorbing layer: at high elevation the loss tends to
  ``(γ_o h_o + γ_w h_w)/sin(el)``, not ``R γ_surface``.  The integral is a composite
  Gauss-Legendre quadrature on panels growing geometrically with range.
* γ_f/c, fog or low cloud: ITU-R P.840 (``specific_attenuation_coefficients``, Rayleigh
  double-Debye) times the liquid water content, inside a fog layer from the sea to the fog
  top; the length of the curved path below the top is exact (:func:`layer_path_length_m`).
* γ_r, rain: ITU-R P.838-3, ``γ_R = k R^α``, over the part of the path inside the rain
  cylinder and below the rain top (:func:`rain_path_length_m`); geometry-dependent, so it is
  computed on-line from one specific attenuation per scene, not tabulated.
* γ_ic, ice cloud: neglected.  Ice has a dielectric loss factor two to three orders of
  magnitude below liquid water at microwave frequencies, so its specific attenuation is
  negligible below ~100 GHz (ITU-R P.840 §2 note; Blake 1986 §5.4 "ice clouds... negligible").

Gas and fog depend only on slant range and elevation: :mod:`shipradar.tables.atmosphere` tabulates
them once per scene from the functions here and the dwell model reads that table per look.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from shipradar.sensors.geometry import EARTH_RADIUS_M, K_FACTOR

#: Effective Earth radius of the standard atmosphere (gradient -40 N/km, ITU-R P.453) [m]:
#: k times the mean radius (shipradar.sensors.geometry).
EFFECTIVE_EARTH_RADIUS_M = K_FACTOR * EARTH_RADIUS_M
#: Mean annual global reference atmosphere at sea level, ITU-R P.835-6 §1.1 / P.676 Fig. 1.
STANDARD_TEMPERATURE_K = 288.15
STANDARD_PRESSURE_HPA = 1013.25
STANDARD_WATER_VAPOUR_G_M3 = 7.5
#: Default fog top [m] (a radiation/advection sea-fog layer; the scenario default).
DEFAULT_FOG_TOP_M = 100.0
#: Water vapour partial pressure from density: e = ρ T / 216.7 [hPa], ITU-R P.453 eq. (10).
_VAPOUR_PRESSURE_FACTOR = 216.7
#: P.838-3 coefficients are tabulated from 1 GHz (below, rain attenuation is negligible).
P838_MIN_FREQ_HZ = 1.0e9
#: P.676-12 Annex 2 equivalent heights, eqs. (31)-(38), hold from 1 to 350 GHz; below 1 GHz
#: the rational term t3 of eq. (33) has a pole at 0.715 GHz (h_o goes to ±inf and negative
#: between 0.6 and 0.715 GHz), so the heights are held at their 1 GHz values there.
P676_HEIGHTS_MIN_FREQ_HZ = 1.0e9
P676_HEIGHTS_MAX_FREQ_HZ = 350.0e9
#: Polarization tilt τ relative to the horizontal for P.838 [deg].
POLARIZATION_TILT_DEG = {"H": 0.0, "horizontal": 0.0, "V": 90.0, "vertical": 90.0, "circular": 45.0}


_GHZ: float = constants.giga
_KM: float = constants.kilo
# Composite Gauss-Legendre: panel edges at R·[0, 10^-4 ... 1] (geometric), nodes per panel.
_N_PANELS = 15
_N_NODES = 8
#: Segment components below this are treated as zero in the rain chord [m] (a subnormal
#: climb would overflow 1/d_up; a micrometre changes no path length that matters).
_SEGMENT_EPS_M = 1.0e-6
_PANEL_EDGES = np.concatenate(([0.0], np.geomspace(1.0e-4, 1.0, _N_PANELS)))
_GL_X, _GL_W = np.polynomial.legendre.leggauss(_N_NODES)


def _plain(x: Any) -> NDArray[np.float64]:
    """An itur result (astropy Quantity or ndarray) as a float ndarray of its value."""
    return np.asarray(getattr(x, "value", x), dtype=np.float64)


def _ghz(freq_hz: ArrayLike) -> NDArray[np.float64]:
    return np.asarray(freq_hz, dtype=np.float64) / _GHZ


def _dry_pressure_hpa(
    pressure_hpa: ArrayLike, water_vapour_density_g_m3: ArrayLike, temperature_k: ArrayLike
) -> NDArray[np.float64]:
    # P.676-12 Annex 1 takes the DRY air pressure p and e separately (total = p + e).
    e: NDArray[np.float64] = (
        np.asarray(water_vapour_density_g_m3) * np.asarray(temperature_k) / _VAPOUR_PRESSURE_FACTOR
    )
    return np.asarray(pressure_hpa, dtype=np.float64) - e


def gaseous_specific_attenuation_db_per_km(
    freq_hz: ArrayLike,
    *,
    temperature_k: ArrayLike = STANDARD_TEMPERATURE_K,
    pressure_hpa: ArrayLike = STANDARD_PRESSURE_HPA,
    water_vapour_density_g_m3: ArrayLike = STANDARD_WATER_VAPOUR_G_M3,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Surface specific attenuation of oxygen and of water vapour, ITU-R P.676-12 Annex 1.

    Parameters
    ----------
    freq_hz : array_like
        Frequency [Hz].  P.676-12 Annex 1 states 1 GHz to 1 THz; below 1 GHz (the schema
        goes down to 0.5 GHz) the line-by-line sum is extrapolated: it is a physical model
        (the lines' shapes and the non-resonant Debye spectrum of oxygen), finite and
        decreasing towards low frequency, and the loss it gives there is below 0.01 dB/km.
    temperature_k : array_like, optional
        Air temperature [K].
    pressure_hpa : array_like, optional
        Total barometric pressure [hPa]; the dry part p = P - e is passed to P.676.
    water_vapour_density_g_m3 : array_like, optional
        Water vapour density ρ [g/m³]; 0 gives dry air.

    Returns
    -------
    gamma_o_db_per_km, gamma_w_db_per_km : ndarray
        γ_o and γ_w [dB/km], ≥ 0.
    """
    f = _ghz(freq_hz)
    p = _dry_pressure_hpa(pressure_hpa, water_vapour_density_g_m3, temperature_k)
    rho = np.asarray(water_vapour_density_g_m3, dtype=np.float64)
    t = np.asarray(temperature_k, dtype=np.float64)
    from itur.models import itu676  # imported when used: itur imports astropy and scipy.stats

    # itur sums its spectral lines over the whole input array: call it point by point
    # (this runs once per scene, never per dwell).
    go = np.vectorize(lambda f_, p_, r_, t_: float(_plain(itu676.gamma0_exact(f_, p_, r_, t_))))
    gw = np.vectorize(lambda f_, p_, r_, t_: float(_plain(itu676.gammaw_exact(f_, p_, r_, t_))))
    return go(f, p, rho, t), np.where(rho > 0.0, gw(f, p, rho, t), 0.0)


def gaseous_equivalent_heights_m(
    freq_hz: ArrayLike,
    *,
    temperature_k: ArrayLike = STANDARD_TEMPERATURE_K,
    pressure_hpa: ArrayLike = STANDARD_PRESSURE_HPA,
    water_vapour_density_g_m3: ArrayLike = STANDARD_WATER_VAPOUR_G_M3,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Equivalent heights of oxygen and water vapour, ITU-R P.676-12 Annex 2 eqs. (31)-(38).

    Parameters
    ----------
    freq_hz : array_like
        Frequency [Hz].  P.676 Annex 2 states the fit for 1-350 GHz; outside it the heights
        are clamped to those at the nearer end (:data:`P676_HEIGHTS_MIN_FREQ_HZ`,
        :data:`P676_HEIGHTS_MAX_FREQ_HZ`).  Below 1 GHz the fit's eq. (33) has a pole at
        0.715 GHz and gives negative heights (an exponentially *growing* absorption with
        height); the physical scale heights of oxygen and water vapour do not depend on
        frequency away from their lines, so the 1 GHz values (5.5 km and 1.7 km) stand.
    temperature_k, pressure_hpa, water_vapour_density_g_m3 : array_like, optional
        Surface temperature [K], total pressure [hPa], water vapour density [g/m³].

    Returns
    -------
    h_o_m, h_w_m : ndarray
        h_o and h_w [m] (about 5 km and 1.7 km at 10 GHz), > 0 at every frequency.
    """
    p = _dry_pressure_hpa(pressure_hpa, water_vapour_density_g_m3, temperature_k)
    f = np.clip(
        np.asarray(_ghz(freq_hz), dtype=np.float64),
        P676_HEIGHTS_MIN_FREQ_HZ / _GHZ,
        P676_HEIGHTS_MAX_FREQ_HZ / _GHZ,
    )
    from itur.models import itu676  # imported when used: itur imports astropy and scipy.stats

    # itur 0.4 returns kilometres under a "m" unit label: take the value as km.
    ho_hw = itu676.slant_inclined_path_equivalent_height(
        f,
        p,
        np.asarray(water_vapour_density_g_m3, dtype=np.float64),
        np.asarray(temperature_k, dtype=np.float64),
    )
    h = _plain(ho_hw)
    return h[0] * _KM, h[1] * _KM


def path_height_m(
    slant_range_m: ArrayLike,
    elevation_rad: ArrayLike,
    antenna_height_m: ArrayLike = 0.0,
    earth_radius_m: float = EFFECTIVE_EARTH_RADIUS_M,
) -> NDArray[np.float64]:
    """Height above the sea along a straight ray over an effective earth.

    ``h(s) = sqrt(s² + 2 r0 s sin(el) + r0²) - a_e``, ``r0 = a_e + h_a`` (4/3 earth by
    default, i.e. standard refraction, Blake 1986 §3.1).

    Parameters
    ----------
    slant_range_m : array_like
        Distance along the ray [m], ≥ 0.
    elevation_rad : array_like
        Elevation of the ray at the antenna [rad].
    antenna_height_m : array_like, optional
        Antenna height above the sea [m].
    earth_radius_m : float, optional
        Effective earth radius [m].

    Returns
    -------
    ndarray
        Height [m]; can go negative for a downward ray that would enter the sea.
    """
    s = np.asarray(slant_range_m, dtype=np.float64)
    el = np.asarray(elevation_rad, dtype=np.float64)
    r0 = earth_radius_m + np.asarray(antenna_height_m, dtype=np.float64)
    r2 = s * s + 2.0 * r0 * s * np.sin(el) + r0 * r0
    return np.sqrt(np.maximum(r2, 0.0)) - earth_radius_m


def ray_elevation_rad(
    slant_range_m: ArrayLike,
    target_height_m: ArrayLike,
    antenna_height_m: ArrayLike = 0.0,
    earth_radius_m: float = EFFECTIVE_EARTH_RADIUS_M,
) -> NDArray[np.float64]:
    """Elevation at the antenna of the ray reaching a height at a slant range (inverse of
    :func:`path_height_m`): the elevation coordinate of the atmospheric-loss table.

    ``sin(el) = ((a_e + h_t)² - r0² - R²) / (2 R r0)``, ``r0 = a_e + h_a`` (cosine law in the
    triangle earth centre - antenna - target over the effective earth).

    Parameters
    ----------
    slant_range_m : array_like
        Slant range R [m]; R = 0 gives 0 (no direction).
    target_height_m : array_like
        Target height above the sea h_t [m].
    antenna_height_m : array_like, optional
        Antenna height h_a [m].
    earth_radius_m : float, optional
        Effective earth radius [m].

    Returns
    -------
    ndarray
        Elevation [rad] in [-π/2, π/2] (clipped when the heights and range are inconsistent).
    """
    r = np.asarray(slant_range_m, dtype=np.float64)
    r0 = earth_radius_m + np.asarray(antenna_height_m, dtype=np.float64)
    rt = earth_radius_m + np.asarray(target_height_m, dtype=np.float64)
    # (rt - r0)(rt + r0) avoids the cancellation of rt² - r0² for heights << a_e.
    num = (rt - r0) * (rt + r0) - r * r
    den = 2.0 * np.where(r > 0.0, r, 1.0) * r0
    return np.where(r > 0.0, np.arcsin(np.clip(num / den, -1.0, 1.0)), 0.0)


def path_quadrature(slant_range_m: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Nodes and weights to integrate a smooth function of distance along a path [0, R].

    Composite Gauss-Legendre (8 nodes) on 15 panels with edges ``R·[0, 10^-4, ..., 1]``
    spaced geometrically, so that both the first metres and the far end are resolved.

    Parameters
    ----------
    slant_range_m : array_like
        Path length R [m], ≥ 0 (R = 0 gives zero weights).

    Returns
    -------
    nodes_m, weights_m : ndarray, shape ``np.shape(R) + (120,)``
        ``∫_0^R f(s) ds ≈ sum(weights * f(nodes), axis=-1)`` [m].
    """
    r = np.asarray(slant_range_m, dtype=np.float64)[..., None, None]
    lo, hi = _PANEL_EDGES[:-1, None], _PANEL_EDGES[1:, None]
    half = 0.5 * (hi - lo)
    nodes = r * (lo + half * (_GL_X + 1.0))
    weights = r * half * _GL_W
    shape = nodes.shape[:-2] + (_N_PANELS * _N_NODES,)
    return nodes.reshape(shape), np.broadcast_to(weights, nodes.shape).reshape(shape)


def gaseous_loss_db(
    slant_range_m: ArrayLike,
    elevation_rad: ArrayLike,
    *,
    gamma_o_db_per_km: ArrayLike,
    gamma_w_db_per_km: ArrayLike,
    h_o_m: ArrayLike,
    h_w_m: ArrayLike,
    antenna_height_m: ArrayLike = 0.0,
) -> NDArray[np.float64]:
    """One-way gaseous loss L_wo of [16] along a slant path, P.676-12 Annex 2 profiles.

    ``L_wo = ∫_0^R [γ_o e^{-h(s)/h_o} + γ_w e^{-h(s)/h_w}] ds``, h(s) from
    :func:`path_height_m` (clipped at the sea surface for downward rays).

    Parameters
    ----------
    slant_range_m : array_like
        Slant range R [m], ≥ 0.
    elevation_rad : array_like
        Elevation of the path at the antenna [rad].
    gamma_o_db_per_km, gamma_w_db_per_km : array_like
        Sea-level specific attenuations [dB/km] (:func:`gaseous_specific_attenuation_db_per_km`).
    h_o_m, h_w_m : array_like
        Equivalent (scale) heights [m] (:func:`gaseous_equivalent_heights_m`).
    antenna_height_m : array_like, optional
        Antenna height [m].

    Returns
    -------
    ndarray
        Loss [dB], ≥ 0, 0 at R = 0, increasing with R.  At the zenith it equals
        ``γ_o h_o (e^{-h_a/h_o} - e^{-(h_a+R)/h_o}) + (same for w)``; for a short horizontal
        path ``≈ (γ_o + γ_w) R``.
    """
    r = np.asarray(slant_range_m, dtype=np.float64)
    el = np.asarray(elevation_rad, dtype=np.float64)
    r, el, ha = np.broadcast_arrays(r, el, np.asarray(antenna_height_m, dtype=np.float64))
    nodes, weights = path_quadrature(r)
    h = np.maximum(path_height_m(nodes, el[..., None], ha[..., None]), 0.0)
    go = np.asarray(gamma_o_db_per_km, dtype=np.float64)[..., None]
    gw = np.asarray(gamma_w_db_per_km, dtype=np.float64)[..., None]
    ho = np.asarray(h_o_m, dtype=np.float64)[..., None]
    hw = np.asarray(h_w_m, dtype=np.float64)[..., None]
    gamma = go * np.exp(-h / ho) + gw * np.exp(-h / hw)
    loss_db: NDArray[np.float64] = np.sum(weights * gamma, axis=-1) / _KM
    return loss_db


def layer_path_length_m(
    slant_range_m: ArrayLike,
    elevation_rad: ArrayLike,
    top_m: ArrayLike,
    antenna_height_m: ArrayLike = 0.0,
    earth_radius_m: float = EFFECTIVE_EARTH_RADIUS_M,
) -> NDArray[np.float64]:
    """Length of the path [0, R] that lies below a height ``top_m`` (exact, curved earth).

    The ray of :func:`path_height_m` is below the top for s between the roots of
    ``s² + 2 r0 sin(el) s + r0² - (a_e + top)² = 0``.

    Parameters
    ----------
    slant_range_m : array_like
        Path length R [m], ≥ 0.
    elevation_rad : array_like
        Elevation at the antenna [rad].
    top_m : array_like
        Layer top above the sea [m]; ≤ 0 gives 0.
    antenna_height_m : array_like, optional
        Antenna height [m] (an antenna above the top sees the layer only on a downward path).
    earth_radius_m : float, optional
        Effective earth radius [m].

    Returns
    -------
    ndarray
        Length [m] in [0, R].
    """
    r = np.asarray(slant_range_m, dtype=np.float64)
    el = np.asarray(elevation_rad, dtype=np.float64)
    top = np.asarray(top_m, dtype=np.float64)
    r0 = earth_radius_m + np.asarray(antenna_height_m, dtype=np.float64)
    rt = earth_radius_m + np.maximum(top, 0.0)
    b = r0 * np.sin(el)
    disc = rt * rt - (r0 * np.cos(el)) ** 2
    root = np.sqrt(np.maximum(disc, 0.0))
    s1 = np.clip(-b - root, 0.0, r)
    s2 = np.clip(-b + root, 0.0, r)
    return np.where((disc > 0.0) & (top > 0.0), s2 - s1, 0.0)


def fog_specific_attenuation_db_per_km(
    freq_hz: ArrayLike,
    liquid_water_g_m3: ArrayLike,
    temperature_k: ArrayLike = STANDARD_TEMPERATURE_K,
) -> NDArray[np.float64]:
    """Specific attenuation of fog or cloud γ_f/c of [16], ITU-R P.840-8 eq. (2).

    ``γ_c = K_l(f, T) M`` with K_l from the double-Debye model of liquid water.

    Parameters
    ----------
    freq_hz : array_like
        Frequency [Hz] (P.840: up to 1000 GHz, Rayleigh regime for fog droplets).
    liquid_water_g_m3 : array_like
        Liquid water density M [g/m³] (0.05 moderate fog, 0.5 thick fog), ≥ 0.
    temperature_k : array_like, optional
        Water temperature [K] (P.840 uses the cloud/fog temperature).

    Returns
    -------
    ndarray
        γ_f/c [dB/km], 0 for M = 0.
    """
    from itur.models import itu840  # imported when used: itur imports astropy and scipy.stats

    t_c = np.asarray(temperature_k, dtype=np.float64) - constants.zero_Celsius
    kl = np.vectorize(
        lambda f_, t_: float(_plain(itu840.specific_attenuation_coefficients(f_, t_)))
    )
    coefficient: NDArray[np.float64] = kl(_ghz(freq_hz), t_c)  # np.vectorize is untyped
    return coefficient * np.asarray(liquid_water_g_m3, dtype=np.float64)


# --------------------------------------------------------------------------- rain
def rain_specific_attenuation_db_per_km(
    freq_hz: ArrayLike,
    rain_rate_mm_h: ArrayLike,
    polarization: str,
    elevation_rad: ArrayLike = 0.0,
) -> NDArray[np.float64]:
    """Specific attenuation of rain γ_r of [16], ITU-R P.838-3: ``γ_R = k R^α``.

    Computed once per scene.

    Parameters
    ----------
    freq_hz : array_like
        Frequency [Hz].  P.838-3 is tabulated from 1 GHz: below it the 1 GHz coefficients
        are used (γ_R is then below 0.001 dB/km at 50 mm/h, and k falls with frequency, so
        this is a small upper bound).
    rain_rate_mm_h : array_like
        Rain rate R [mm/h], ≥ 0 (0 gives 0).  P.838 states no upper rate: the power law is
        extrapolated to the schema's 300 mm/h (66.7 dB/km at 100 GHz, HP).
    polarization : {"H", "V", "horizontal", "vertical", "circular"}
        Radar polarization (tilt τ = 0°, 90°, 45° in P.838).
    elevation_rad : array_like, optional
        Path elevation [rad] (P.838 combines the H and V coefficients with cos² el).

    Returns
    -------
    ndarray
        γ_R [dB/km], ≥ 0.
    """
    if polarization not in POLARIZATION_TILT_DEG:
        raise ValueError(f"polarization must be one of {sorted(POLARIZATION_TILT_DEG)}")
    from itur.models import itu838  # imported when used: itur imports astropy and scipy.stats

    tau = POLARIZATION_TILT_DEG[polarization]
    f = np.maximum(np.asarray(freq_hz, dtype=np.float64), P838_MIN_FREQ_HZ) / _GHZ
    rate = np.asarray(rain_rate_mm_h, dtype=np.float64)
    el_deg = np.rad2deg(np.asarray(elevation_rad, dtype=np.float64))
    g = np.vectorize(
        lambda r_, f_, e_: float(_plain(itu838.rain_specific_attenuation(r_, f_, e_, tau)))
    )
    return np.where(rate > 0.0, g(np.maximum(rate, 0.0), f, el_deg), 0.0)


def rain_path_length_m(
    radar_en_m: ArrayLike,
    target_en_m: ArrayLike,
    radar_up_m: ArrayLike,
    target_up_m: ArrayLike,
    centre_en_m: ArrayLike,
    radius_m: ArrayLike,
    rain_top_m: ArrayLike,
) -> NDArray[np.float64]:
    """Length of the radar-target segment inside a vertical cylinder of rain.

    The rain fills ``|p_en - c| <= radius`` from the sea (up = 0) to ``rain_top``.  The path
    is the straight segment between the two points in local east/north/up coordinates (the
    heights are above the sea; earth curvature between them is neglected, which is well
    inside the uncertainty of a rain cell's outline).

    Parameters
    ----------
    radar_en_m, target_en_m : array_like, shape (..., 2)
        East/north of the radar and of the target [m].
    radar_up_m, target_up_m : array_like, shape (...)
        Heights above the sea [m].
    centre_en_m : array_like, shape (..., 2)
        East/north of the cylinder axis [m].
    radius_m : array_like
        Cylinder radius [m]; ``np.inf`` for rain everywhere.
    rain_top_m : array_like
        Top of the rain [m] (the scenario's h_cloud).

    Returns
    -------
    ndarray, shape (...)
        Length [m] in [0, |segment|]: 0 when the segment misses the cylinder, the full 3-D
        length when both ends are inside.  A zero-length segment gives 0.
    """
    a_en = np.asarray(radar_en_m, dtype=np.float64)
    b_en = np.asarray(target_en_m, dtype=np.float64)
    a_up = np.asarray(radar_up_m, dtype=np.float64)
    b_up = np.asarray(target_up_m, dtype=np.float64)
    c_en = np.asarray(centre_en_m, dtype=np.float64)
    radius = np.asarray(radius_m, dtype=np.float64)
    top = np.asarray(rain_top_m, dtype=np.float64)
    d_en = b_en - a_en
    d_up = b_up - a_up
    length: NDArray[np.float64] = np.sqrt(np.sum(d_en * d_en, axis=-1) + d_up * d_up)

    # Horizontal: |a + t d - c|² <= r²  <=>  A t² + 2 B t + C <= 0.
    rel = a_en - c_en
    qa = np.sum(d_en * d_en, axis=-1)
    qb = np.sum(d_en * rel, axis=-1)
    finite_r = np.isfinite(radius)
    qc = np.sum(rel * rel, axis=-1) - np.where(finite_r, radius, 0.0) ** 2
    vertical = qa <= _SEGMENT_EPS_M**2  # no horizontal extent (to rounding)
    qa_safe = np.where(vertical, 1.0, qa)
    # Roots t0 ± sqrt((r² - d_min²)/A) about the closest approach t0 = -B/A, with d_min
    # formed directly (B² - A C cancels badly for a long chord tangent to the circle).
    t0 = -qb / qa_safe
    closest = rel + t0[..., None] * d_en
    margin = np.where(finite_r, radius, 0.0) ** 2 - np.sum(closest * closest, axis=-1)
    half = np.sqrt(np.maximum(margin, 0.0) / qa_safe)
    t_in = np.where(vertical, 0.0, t0 - half)
    t_out = np.where(vertical, 1.0, t0 + half)
    hits = np.where(vertical, qc <= 0.0, margin > 0.0)
    hits = hits | ~finite_r
    t_in = np.where(finite_r, t_in, 0.0)
    t_out = np.where(finite_r, t_out, 1.0)

    # Vertical: 0 <= a_up + t d_up <= top.
    flat = np.abs(d_up) <= _SEGMENT_EPS_M  # level path: no 1/d_up overflow
    d_safe = np.where(flat, 1.0, d_up)
    t_sea = (0.0 - a_up) / d_safe
    t_top = (top - a_up) / d_safe
    lo_h = np.where(flat, 0.0, np.minimum(t_sea, t_top))
    hi_h = np.where(flat, 1.0, np.maximum(t_sea, t_top))
    inside_h = np.where(flat, (a_up >= 0.0) & (a_up <= top), True)

    lo = np.maximum(np.maximum(t_in, lo_h), 0.0)
    hi = np.minimum(np.minimum(t_out, hi_h), 1.0)
    frac: NDArray[np.float64] = np.where(hits & inside_h, np.maximum(hi - lo, 0.0), 0.0)
    return frac * length


def rain_loss_db(
    specific_attenuation_db_per_km: ArrayLike, path_length_in_rain_m: ArrayLike
) -> NDArray[np.float64]:
    """One-way rain loss, the ``R_s γ_r`` term of [16] restricted to the rain.

    Parameters
    ----------
    specific_attenuation_db_per_km : array_like
        γ_r [dB/km] (:func:`rain_specific_attenuation_db_per_km`).
    path_length_in_rain_m : array_like
        Length of the path inside the rain [m] (:func:`rain_path_length_m`).

    Returns
    -------
    ndarray
        Loss [dB], ≥ 0, proportional to the path length; 0 without rain.
    """
    return (
        np.asarray(specific_attenuation_db_per_km, dtype=np.float64)
        * np.asarray(path_length_in_rain_m, dtype=np.float64)
        / _KM
    )
