"""Weather (precipitation) clutter, seed sections 4.1.4-4.1.5, equations [39]-[45].

The seed follows CARPET (TNO, ref. 2 of the seed) for a surveillance radar whose beam is at
the horizon: a volume cell ϑ = ϑ0 R_c θ_b d_h C_R [40] at the folded range R_c [41], filled
with rain of reflectivity ϑ0 = K f⁴ p_r^1.6 [42] up to the cloud base h_cloud [43], and a
Gaussian spectrum whose spread combines wind shear, turbulence [44]-[45] and the antenna
scan [37].

Units: SI and linear at the interface.  In [42] the frequency is in Hz: with K = 7e-48 this is
the Rayleigh reflectivity η = π⁵ |K_w|² Z / λ⁴ of the Marshall-Palmer rain Z = 200 p_r^1.6
mm⁶/m³ with |K_w|² = 0.93 (π⁵ · 0.93 · 200e-18 / c⁴ = 7.0e-48 s⁴/m); the tests check this.

Weather clutter exists only inside the rain region: every power here is "if the cell is full
of rain"; the caller multiplies by the rain fraction of the cell
(:func:`rain_cylinder_fraction` for the scenario's cylinder).

Range folding: the seed's [39]-[41] and the erratum on [41]
-----------------------------------------------------------
The seed computes the volume ϑ of [40] at the folded range R_c = mod(R, c/(2 f_r)) of [41]
but divides by the *true* range R⁴ in [39].  That mixes two cells: the resolution volume
of one cell and the R⁻⁴ of another: at 170 km, for the jammed_squall radar (f_r = 5 kHz,
R_u = 30 km) with rain everywhere, it gave -106.5 dBm where the rain folded onto that delay
gives -69.0 dBm, 37.5 dB more (issue 23 item 5(c); docs/stability.md §5c; SPEC §4 item 3
already fixes the f of [41] as the PRF).  What the receiver sees at the delay of a target
at true range R is the sum of the echoes of every pulse still in flight: rain at r + k R_u,
k = 0, 1, 2, ..., with r = R mod R_u and R_u = c/(2 f_r), each with its own volume and its
own R⁻⁴::

    P_wc(R) = Σ_k P_1(r + k R_u),  P_1(x) = K_r ϑ0 x θ_b d_h(x) C_R / x_s⁴   ([39], [40], [43])

(x_s the slant range of the cell at ground range x).  :func:`single_trip_power_w` is P_1
and :func:`range_folded_power_w` the sum; the sum stops at the instrumented range (the
clutter map's range axis): each further trip is below the first by (r/(r + k R_u))³ or
more.  The first-trip echo of rain at r (k = 0) usually dominates: at R ≥ R_u it is what
the seed's volume at R_c stood for, now with its own (R_c)⁻⁴.  With R ≤ R_u and
R_inst ≤ R_u the sum is the single cell of the seed.  Folding is done in ground range (the
seed's "terrestrial range" R_r); slant and ground range differ by millimetres at these
heights.

Rain attenuation on the clutter ([39] with [3] and [16])
--------------------------------------------------------
[39] uses K_r "as previously defined", i.e. [3] with L_atm², and L_atm holds the rain's
R_s γ_r ([16]).  Each trip carries its own two-way loss through the rain on the way to its
own cell (:func:`rain_path_to_cell_m`, :func:`two_way_rain_transmission`), not the
target's: ``P_wc(R) = Σ_k P_1(x_k) / L_rain(x_k)²``, x_k = r + k R_u, the path ending at
the centre of the [43] cell (height d_h/2; with rain everywhere and the antenna below
h_cloud that is the whole slant range, inside a rain cylinder only the part inside it).
The gases and fog of [16] are left out of the clutter, as for the sea clutter [21] (a few
tenths of a dB at C band over 30 km).  Without it the Giraffe (5.6 GHz) in 16 mm/h of rain
everywhere overstated its weather clutter by 0.5/1.2/1.8 dB at 10/20/29.9 km and by
3.4/7.0/10.5 dB at 50 mm/h (issue 35).

Earth curvature
---------------
[43] is flat-earth, and so is this module: the cell holds rain from the sea up to
d_h = min(h_cloud, R φ_b) whatever the range.  Over the 4/3 earth the rain layer at ground
range R sits R/(2 k a) lower in elevation than over a flat earth (0.67° at 200 km); the
seed's cell weighs no beam pattern, so an 11-20° fan beam holds that layer whole either way.
An audit that weighs the cell by the beam over the curved earth finds the SPS-49 (L band,
11°) 1.1-5.9 dB below this at 120-200 km (issue 35).  That model is outside the seed and is
not applied: far rain is the seed's flat-earth cell, an upper bound.

Spectrum spread [44]-[45] and the rain layer
--------------------------------------------
[45] prints σ_shear = 0.42 k R θ_b.  The shear is vertical, so the angle is the beam's
*vertical* extent (Nathanson's φ), and the velocities the beam sees are those of the rain it
holds: a layer of depth h_cloud under a shear k spans k h_cloud in all (10 m/s for 2.5 km at
the seed's 4e-3 s⁻¹), a uniformly filled layer has the standard deviation k h_cloud/√12
(2.9 m/s).  :func:`shear_spread_mps` takes the seed's Gaussian-beam value with φ_b while
the beam is thinner than the layer and that of the layer once the beam is wider:
``min(0.42 k R φ_b, k h_cloud/√12)``, so the spread never exceeds what the rain layer can
make (with φ_b alone an 11-20° fan beam gave 20-48 m/s far out).  The seed's literal θ_b
(the azimuth beamwidth) is not used: the azimuth extent of the cell sees no shear; for a
pencil beam θ_b = φ_b and the seed's form is the first branch.  Turbulence [44] and the
scan [37] are added as the seed says.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

Precipitation = Literal["rain", "dry_snow", "wet_snow"]

#: Speed of light in vacuum c [m/s].
SPEED_OF_LIGHT_MPS: float = constants.c
#: [42]: K below 6 GHz and above 35 GHz [s⁴/m] (ϑ0 in m²/m³ with f in Hz and p_r in mm/h).
K_LOW = 7.0e-48
K_HIGH = 13.0e-48
K_LOW_FREQ_HZ = 6.0e9
K_HIGH_FREQ_HZ = 35.0e9
#: [42]: exponent of the precipitation rate (Marshall-Palmer Z = 200 p_r^1.6).
RAIN_RATE_EXPONENT = 1.6
#: 4.1.4: snow rate over rain-equivalent rate: 10 for dry snow, 5 for wet (melting) snow.
SNOW_TO_RAIN_DIVISOR = {"rain": 1.0, "dry_snow": 10.0, "wet_snow": 5.0}
#: [45]: σ_shear = 0.42 k R φ (Nathanson); 0.42 = 1/√(8 ln 2), the standard deviation of a
#: Gaussian beam of 3 dB width φ.
SHEAR_SPREAD_FACTOR = 0.42
#: Standard deviation of a uniform distribution over a unit width, 1/√12: the shear spread
#: of a rain layer the beam holds whole, over the layer's velocity span k h_cloud.
UNIFORM_LAYER_FACTOR = 1.0 / np.sqrt(12.0)
#: [45]: wind shear gradient k = 4 m/s per km (the seed's 4e-3) [1/s].
WIND_SHEAR_PER_S = 4.0e-3
#: Largest two-way rain loss applied to a clutter cell [dB]: beyond it the cell is nothing
#: against any receiver noise, and 10^(-x/10) stays a normal float (300 mm/h at 100 GHz,
#: 67 dB/km, over 1000 km is 1.3e5 dB).
MAX_TWO_WAY_RAIN_LOSS_DB = 2000.0
#: [44]: turbulence spread of rain, σ_turb ≈ 1 m/s (Nathanson, Radar Design Principles, 2nd ed.,
#: ch. 6; Nathanson & Reilly 1968) [m/s].
RAIN_TURBULENCE_SPREAD_MPS = 1.0


def _f(x: ArrayLike) -> NDArray[np.float64]:
    return np.asarray(x, dtype=np.float64)


def rain_equivalent_rate_mm_h(
    rate_mm_h: ArrayLike, kind: Precipitation = "rain"
) -> NDArray[np.float64]:
    """Rain-equivalent precipitation rate (seed 4.1.4): dry snow ÷ 10, wet snow ÷ 5.

    Parameters
    ----------
    rate_mm_h : array_like
        Precipitation rate [mm/h], ≥ 0.
    kind : {"rain", "dry_snow", "wet_snow"}
        Type of precipitation.

    Returns
    -------
    ndarray
        Rain-equivalent p_r [mm/h].
    """
    if kind not in SNOW_TO_RAIN_DIVISOR:
        raise ValueError(
            f"precipitation kind must be one of {sorted(SNOW_TO_RAIN_DIVISOR)}, got {kind!r}"
        )
    p = _f(rate_mm_h)
    if np.any(p < 0.0):
        raise ValueError("precipitation rate must be >= 0")
    return p / SNOW_TO_RAIN_DIVISOR[kind]


def reflectivity_constant(freq_hz: ArrayLike) -> NDArray[np.float64]:
    """K of [42]: 7e-48 up to 6 GHz, 13e-48 from 35 GHz, linear in frequency between [s⁴/m].

    Parameters
    ----------
    freq_hz : array_like
        Frequency [Hz], > 0.  The seed gives K at 6 and 35 GHz only; outside 6-35 GHz K is
        held at its end value (clamp), so [42] keeps its f⁴ Rayleigh law with the end
        constant: above 35 GHz, where large drops leave the Rayleigh regime, this
        over-estimates ϑ0 (a conservative clutter level).  Refused at f ≤ 0.

    Returns
    -------
    ndarray
        K [s⁴/m], in [7e-48, 13e-48].
    """
    f = _f(freq_hz)
    if np.any(f <= 0.0):
        raise ValueError("frequency must be > 0")
    return np.interp(f, [K_LOW_FREQ_HZ, K_HIGH_FREQ_HZ], [K_LOW, K_HIGH])


def rain_reflectivity(
    freq_hz: ArrayLike, rate_mm_h: ArrayLike, kind: Precipitation = "rain"
) -> NDArray[np.float64]:
    """Volume reflectivity of precipitation ϑ0 = K f⁴ p_r^1.6, seed [42] [m²/m³].

    Parameters
    ----------
    freq_hz : array_like
        Frequency f [Hz].
    rate_mm_h : array_like
        Precipitation rate [mm/h], ≥ 0 (0: no rain, ϑ0 = 0); snow is converted to its
        rain-equivalent rate (:func:`rain_equivalent_rate_mm_h`).
    kind : {"rain", "dry_snow", "wet_snow"}
        Type of precipitation.

    Returns
    -------
    ndarray
        ϑ0 [m²/m³ = 1/m].
    """
    p = rain_equivalent_rate_mm_h(rate_mm_h, kind)
    f = _f(freq_hz)
    return reflectivity_constant(f) * f**4 * p**RAIN_RATE_EXPONENT


def folded_range_m(range_m: ArrayLike, prf_hz: ArrayLike) -> NDArray[np.float64]:
    """Range folded into the unambiguous interval, R_c = mod(R_r, c/(2 f_r)), seed [41].

    SPEC §4 item 3: the f of [41] is the pulse repetition frequency.

    Parameters
    ----------
    range_m : array_like
        Terrestrial range R_r [m], ≥ 0.
    prf_hz : array_like
        f_r [Hz], > 0.

    Returns
    -------
    ndarray
        R_c in [0, c/(2 f_r)) [m].
    """
    prf = _f(prf_hz)
    if np.any(prf <= 0.0):
        raise ValueError("PRF must be > 0")
    return np.mod(_f(range_m), SPEED_OF_LIGHT_MPS / (2.0 * prf))


def unambiguous_range_m(prf_hz: ArrayLike) -> NDArray[np.float64]:
    """Unambiguous range R_u = c/(2 f_r) [m] (the period of the folding of [41]).

    Parameters
    ----------
    prf_hz : array_like
        f_r [Hz], > 0.
    """
    prf = _f(prf_hz)
    if np.any(prf <= 0.0):
        raise ValueError("PRF must be > 0")
    return SPEED_OF_LIGHT_MPS / (2.0 * prf)


def volume_height_m(
    folded_range: ArrayLike, elevation_beamwidth_rad: ArrayLike, cloud_base_m: ArrayLike
) -> NDArray[np.float64]:
    """Height of the volume cell d_h = min(h_cloud, R_c φ_b), seed [43].

    Parameters
    ----------
    folded_range : array_like
        R_c [m].
    elevation_beamwidth_rad : array_like
        φ_b [rad].
    cloud_base_m : array_like
        h_cloud, top of the rain volume [m].
    """
    return np.minimum(_f(cloud_base_m), _f(folded_range) * _f(elevation_beamwidth_rad))


def volume_cross_section_m2(
    reflectivity: ArrayLike,
    folded_range: ArrayLike,
    beamwidth_rad: ArrayLike,
    elevation_beamwidth_rad: ArrayLike,
    cloud_base_m: ArrayLike,
    range_cell_m: ArrayLike,
) -> NDArray[np.float64]:
    """Cross-section of the rain in a volume cell ϑ = ϑ0 R_c θ_b d_h C_R, seed [40] with [43].

    Parameters
    ----------
    reflectivity : array_like
        ϑ0 [m²/m³].
    folded_range : array_like
        R_c [m] ([41]).
    beamwidth_rad : array_like
        Azimuth beamwidth θ_b [rad].
    elevation_beamwidth_rad : array_like
        φ_b [rad].
    cloud_base_m : array_like
        h_cloud [m].
    range_cell_m : array_like
        C_R = c τ'/2 [m].

    Returns
    -------
    ndarray
        ϑ [m²]; 0 at R_c = 0.
    """
    d_h = volume_height_m(folded_range, elevation_beamwidth_rad, cloud_base_m)
    return _f(reflectivity) * _f(folded_range) * _f(beamwidth_rad) * d_h * _f(range_cell_m)


def weather_clutter_power_w(
    radar_constant_w_m2: ArrayLike,
    cross_section_m2: ArrayLike,
    slant_range_m: ArrayLike,
    rain_fraction: ArrayLike = 1.0,
) -> NDArray[np.float64]:
    """Weather clutter power at the RF input P_wc = K_r ϑ / R_wc⁴, seed [39].

    Times the fraction of the cell inside the rain region (0 outside: no rain, no clutter).

    Parameters
    ----------
    radar_constant_w_m2 : array_like
        K_r of [3] [W·m²].
    cross_section_m2 : array_like
        ϑ [m²] ([40]).
    slant_range_m : array_like
        R_wc [m], > 0 (SPEC §4 item 13: R → 0 is refused, not silently infinite).
    rain_fraction : array_like, optional
        Fraction of the cell in rain, in [0, 1].

    Returns
    -------
    ndarray
        P_wc [W], ≥ 0.
    """
    r = _f(slant_range_m)
    if np.any(r <= 0.0):
        raise ValueError("slant range must be > 0")
    frac = _f(rain_fraction)
    if np.any((frac < 0.0) | (frac > 1.0)):
        raise ValueError("rain fraction must be in [0, 1]")
    return _f(radar_constant_w_m2) * _f(cross_section_m2) * frac / r**4


def single_trip_power_w(
    radar_constant_w_m2: ArrayLike,
    reflectivity: ArrayLike,
    ground_range_m: ArrayLike,
    slant_range_m: ArrayLike,
    beamwidth_rad: ArrayLike,
    elevation_beamwidth_rad: ArrayLike,
    cloud_base_m: ArrayLike,
    range_cell_m: ArrayLike,
) -> NDArray[np.float64]:
    """Power of the rain in one cell at its own range, P_1 = K_r ϑ0 R θ_b d_h C_R / R_s⁴ [W].

    Seed [39] with [40] and [43], the volume and the R⁻⁴ both at the cell's true range (the
    one-trip term of :func:`range_folded_power_w`; see the module notes on [41]).

    Parameters
    ----------
    radar_constant_w_m2 : array_like
        K_r of [3] [W·m²].
    reflectivity : array_like
        ϑ0 [m²/m³] ([42]).
    ground_range_m : array_like
        Ground range of the cell R [m], ≥ 0 (the volume's range).
    slant_range_m : array_like
        Slant range of the cell R_s [m], > 0 (≥ the antenna height for a cell at sea level).
    beamwidth_rad, elevation_beamwidth_rad : array_like
        θ_b and φ_b [rad].
    cloud_base_m : array_like
        h_cloud [m].
    range_cell_m : array_like
        C_R [m].

    Returns
    -------
    ndarray
        P_1 [W], ≥ 0; 0 at R = 0 (no volume); largest near R ≈ h_a, where R θ_b R φ_b / R_s⁴
        peaks (the seed's horizon beam does not hold there, but the value stays finite).
    """
    vol = volume_cross_section_m2(
        reflectivity, ground_range_m, beamwidth_rad, elevation_beamwidth_rad, cloud_base_m,
        range_cell_m,
    )
    return weather_clutter_power_w(radar_constant_w_m2, vol, slant_range_m)


def trip_count(prf_hz: ArrayLike, max_range_m: ArrayLike) -> int:
    """Largest number of pulses in flight whose rain echoes can overlap up to R_max.

    ``floor(R_max / R_u) + 1`` (trips k = 0 .. floor(R_max / R_u)).

    Parameters
    ----------
    prf_hz : array_like
        f_r [Hz], > 0.
    max_range_m : array_like
        R_max [m], ≥ 0.
    """
    r_max = _f(max_range_m)
    if np.any(r_max < 0.0):
        raise ValueError("max range must be >= 0")
    return int(np.max(np.floor(r_max / unambiguous_range_m(prf_hz)))) + 1


def range_folded_power_w(
    single_trip: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    ground_range_m: ArrayLike,
    prf_hz: float,
    max_range_m: ArrayLike,
) -> NDArray[np.float64]:
    """Rain clutter at the delay of range R, summed over the pulses in flight [W].

    ``P_wc(R) = Σ_k P_1(r + k R_u)`` for k ≥ 0 with ``r + k R_u ≤ max(R_max, R)``,
    ``r = R mod R_u`` ([41], module notes): the consistent reading of [39]-[41] for second-
    and later-trip echoes.

    Parameters
    ----------
    single_trip : callable
        ``single_trip(x)`` -> P_1 at ground ranges x [m] (same shape as x), e.g.
        :func:`single_trip_power_w` with its other arguments bound, times the rain fraction
        of the cell at x along the beam when the rain is a region.
    ground_range_m : array_like
        True ground range R of the cell where the target is [m], ≥ 0.
    prf_hz : float
        f_r [Hz], > 0.
    max_range_m : array_like
        R_max [m]: rain beyond it (and beyond R) is not counted (the instrumented range).

    Returns
    -------
    ndarray
        P_wc [W], ≥ 0, periodic in R with period R_u where R ≤ R_max; equal to
        ``single_trip(R)`` when R_max < R_u.
    """
    r_true = _f(ground_range_m)
    if np.any(r_true < 0.0):
        raise ValueError("ground range must be >= 0")
    r_u = float(unambiguous_range_m(prf_hz))
    limit = np.maximum(_f(max_range_m), r_true)
    r = np.mod(r_true, r_u)
    total = np.zeros(np.broadcast(r, limit).shape)
    for k in range(trip_count(prf_hz, np.max(limit, initial=0.0))):
        x = r + k * r_u
        inside = x <= limit
        if not np.any(inside):
            break
        total = total + np.where(inside, single_trip(np.where(inside, x, r)), 0.0)
    return total


def rain_path_to_cell_m(
    ground_range_m: ArrayLike,
    azimuth_rad: ArrayLike,
    antenna_en_m: ArrayLike,
    antenna_height_m: ArrayLike,
    elevation_beamwidth_rad: ArrayLike,
    cloud_base_m: ArrayLike,
    centre_en_m: ArrayLike = (0.0, 0.0),
    radius_m: ArrayLike = np.inf,
) -> NDArray[np.float64]:
    """Length of the way from the antenna to a weather-clutter cell inside the rain [m].

    The cell at ground range x along the beam azimuth holds rain from the sea up to
    d_h = min(h_cloud, x φ_b) ([43]); the path ends at its centre, d_h/2 up, and is cut by
    the rain (:func:`shipradar.sensors.atmosphere.rain_path_length_m`, flat earth as [43]):
    the whole slant distance with rain everywhere and the antenna below h_cloud, the part
    inside the cylinder for a rain region.

    Parameters
    ----------
    ground_range_m : array_like
        Ground range x of the cell [m], ≥ 0.
    azimuth_rad : array_like
        Beam azimuth from true north [rad].
    antenna_en_m : array_like, shape (..., 2)
        Antenna east/north in the rain's frame [m].
    antenna_height_m : array_like
        h_a [m].
    elevation_beamwidth_rad : array_like
        φ_b [rad].
    cloud_base_m : array_like
        h_cloud [m].
    centre_en_m : array_like, shape (..., 2), optional
        Centre of the rain cylinder [m].
    radius_m : array_like, optional
        Radius of the rain cylinder [m]; ``np.inf`` (default): rain everywhere.

    Returns
    -------
    ndarray
        Path length inside the rain [m], in [0, distance to the cell centre].
    """
    from shipradar.sensors.atmosphere import rain_path_length_m

    x = _f(ground_range_m)
    az = _f(azimuth_rad)
    a_en = _f(antenna_en_m)
    cell_en = np.stack(np.broadcast_arrays(a_en[..., 0] + x * np.sin(az),
                                           a_en[..., 1] + x * np.cos(az)), axis=-1)
    centre = 0.5 * volume_height_m(x, elevation_beamwidth_rad, cloud_base_m)
    path: NDArray[np.float64] = rain_path_length_m(
        a_en, cell_en, antenna_height_m, centre, centre_en_m, radius_m, cloud_base_m)
    return path


def two_way_rain_transmission(
    specific_attenuation_db_per_km: ArrayLike, path_in_rain_m: ArrayLike
) -> NDArray[np.float64]:
    """Two-way power transmission through rain, 1/L_rain² = 10^(-2 γ_r L / 10) ([3], [16]).

    Parameters
    ----------
    specific_attenuation_db_per_km : array_like
        γ_r one-way [dB/km] (ITU-R P.838,
        :func:`shipradar.sensors.atmosphere.rain_specific_attenuation_db_per_km`), ≥ 0.
    path_in_rain_m : array_like
        One-way path inside the rain [m] (:func:`rain_path_to_cell_m`), ≥ 0.

    Returns
    -------
    ndarray
        Factor in (0, 1]; 1 without rain on the way.
    """
    loss_db = 2.0 * _f(specific_attenuation_db_per_km) * _f(path_in_rain_m) / 1000.0
    return 10.0 ** (-np.minimum(loss_db, MAX_TWO_WAY_RAIN_LOSS_DB) / 10.0)


def shear_spread_mps(
    range_m: ArrayLike,
    elevation_beamwidth_rad: ArrayLike,
    cloud_base_m: ArrayLike,
    shear_per_s: ArrayLike = WIND_SHEAR_PER_S,
) -> NDArray[np.float64]:
    """Radial-velocity spread from wind shear over the rain in the beam, seed [45] [m/s].

    ``σ_shear = min(0.42 k R φ_b, k h_cloud/√12)``: the seed's (Nathanson's) Gaussian-beam
    spread with the beam's vertical extent R φ_b while the beam is thinner than the rain
    layer, and the spread of the layer itself, uniformly filled, once the beam holds it
    whole (module notes: the seed prints θ_b; the shear is vertical).  The seed calls the
    result Hz; it is a velocity (it is multiplied by 2/λ in [44]).

    Parameters
    ----------
    range_m : array_like
        R [m], ≥ 0.
    elevation_beamwidth_rad : array_like
        φ_b [rad].
    cloud_base_m : array_like
        h_cloud, top of the rain layer [m] (the [43] cell's height cap).
    shear_per_s : array_like, optional
        Wind shear k [(m/s)/m]; the seed's 4e-3 by default.

    Returns
    -------
    ndarray
        σ_shear [m/s], ≥ 0, at most k h_cloud/√12 (≈ 0.29 of the layer's span k h_cloud).
    """
    k = _f(shear_per_s)
    beam = SHEAR_SPREAD_FACTOR * k * _f(range_m) * _f(elevation_beamwidth_rad)
    spread: NDArray[np.float64] = np.minimum(beam, UNIFORM_LAYER_FACTOR * k * _f(cloud_base_m))
    return spread


def weather_spread_hz(
    wavelength_m: ArrayLike,
    shear_spread: ArrayLike,
    turbulence_spread_mps: ArrayLike = RAIN_TURBULENCE_SPREAD_MPS,
    rotation_spread: ArrayLike = 0.0,
) -> NDArray[np.float64]:
    """Weather clutter spectrum spread, σ_wc = (2/λ) √(σ_shear² + σ_turb²), seed [44], with [37].

    The antenna-scan spread σ_r [Hz] of [37] is added in quadrature as the seed says
    (4.1.5, last sentence).

    Parameters
    ----------
    wavelength_m : array_like
        λ [m].
    shear_spread : array_like
        σ_shear [m/s] (:func:`shear_spread_mps`).
    turbulence_spread_mps : array_like, optional
        σ_turb [m/s].
    rotation_spread : array_like, optional
        σ_r [Hz] (:func:`shipradar.sensors.sea_clutter.rotation_spread_hz`).

    Returns
    -------
    ndarray
        σ [Hz], ≥ 0.
    """
    v = np.sqrt(_f(shear_spread) ** 2 + _f(turbulence_spread_mps) ** 2)
    return np.sqrt((2.0 * v / _f(wavelength_m)) ** 2 + _f(rotation_spread) ** 2)


def weather_mean_doppler_hz(
    wind_speed_mps: ArrayLike,
    wind_relative_azimuth_rad: ArrayLike,
    wavelength_m: ArrayLike,
    platform_doppler: ArrayLike = 0.0,
) -> NDArray[np.float64]:
    """Mean Doppler of rain carried by the wind, 2 w_s cos φ / λ + f1 [Hz].

    The seed gives only the spread of the weather spectrum; its mean is taken as the radial
    component of the (surface) wind the drops drift with, plus the platform term f1 of [34]
    (0 for a motion-compensated radar).  φ is the look direction relative to the wind (0 into
    the wind: the rain approaches, positive Doppler).

    Parameters
    ----------
    wind_speed_mps : array_like
        w_s [m/s].
    wind_relative_azimuth_rad : array_like
        φ [rad].
    wavelength_m : array_like
        λ [m].
    platform_doppler : array_like, optional
        f1 [Hz].
    """
    return 2.0 * _f(wind_speed_mps) * np.cos(_f(wind_relative_azimuth_rad)) / _f(wavelength_m) + _f(
        platform_doppler
    )


def rain_cylinder_fraction(
    east_m: ArrayLike,
    north_m: ArrayLike,
    centre_east_m: float | None = None,
    centre_north_m: float | None = None,
    radius_m: float | None = None,
) -> NDArray[np.float64]:
    """Rain fraction of points for the scenario's rain cylinder: 1 inside, 0 outside.

    No cylinder (radius None) means rain everywhere.

    Parameters
    ----------
    east_m, north_m : array_like
        Cell position in the scenario's local frame [m].
    centre_east_m, centre_north_m : float, optional
        Centre of the cylinder [m].
    radius_m : float, optional
        Radius of the cylinder [m].
    """
    e, n = np.broadcast_arrays(_f(east_m), _f(north_m))
    if radius_m is None:
        return np.ones(e.shape)
    de = e - (centre_east_m or 0.0)
    dn = n - (centre_north_m or 0.0)
    return (de * de + dn * dn <= radius_m * radius_m).astype(np.float64)
