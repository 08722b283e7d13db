"""Off-line clutter maps: sea clutter [21]-[38] and weather clutter [39]-[45] over (range, azimuth).

One map per radar and environment (seed 4.1.1: "estimated in the radar domain (R, θ) and
stored in the clutter map file together with the calculated reflectivities").  Axes: ground
range from the radar [m] (0 to the instrumented range) and beam azimuth from true north [rad]
on [0, 2π] with both ends present, so any azimuth wrapped into [0, 2π) is inside the grid.

Sea map (:func:`build_sea_clutter_map`), values P_sc [W] at the RF input ([21]), extras on the
same grid, read on-line by S/C [46], the distribution loss [64] and the clutter false alarms
[94]-[96]:

* ``sigma0_db``: σ0* [dB] ([22], GIT with the ducting extension;
  :data:`shipradar.sensors.sea_clutter.DB_FLOOR` = none);
* ``sigma0_diff_db``: σ0d = σ0* - σ0(reference) [dB] ([32]);
* ``weibull_a``: a ([32] for VP, the 4.1.2 heuristic for HP; 1 (Rayleigh) when the radar is
  not of medium-to-high resolution);
* ``doppler_mean_hz``: μ_c [Hz] ([34]-[35], 0 when motion-compensated);
* ``doppler_spread_hz``: σ_s [Hz] ([36]-[38]).

Weather map (:func:`build_weather_clutter_map`, only for a scene with precipitation), values
P_wc [W] if the rain is everywhere, summed over the pulses in flight (the range-folding
erratum on [39]-[41], :mod:`shipradar.sensors.weather_clutter`), each trip through its own
two-way rain loss ([3], [16]); extras ``doppler_mean_hz``, ``doppler_spread_hz`` and
``single_trip_power_w`` (the cell alone, unattenuated: with a rain region the on-line side
sums the trips inside the region, each with its own loss through the region).  Its range
axis (:func:`weather_range_axis`) is the uniform one with nodes added where the sum jumps
or is steep: both sides of every multiple of the unambiguous range R_u (where the first
trip starts again at the antenna) and a fine run after each, so that the bilinear reader
equals the sum off the grid too.

Both depend on the ship's motion only through μ (when not motion-compensated); the table is
built for the given speed and heading, and the on-line side may recompute f1 [34] cheaply.

The cache key is the hash of every input that changes a value (the elevation pattern by its
hashable description, not by the callable), through :func:`shipradar.tables.store.get_or_build`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.constants import c as SPEED_OF_LIGHT_MPS

from shipradar.sensors import geometry
from shipradar.sensors import sea_clutter as sc
from shipradar.sensors import weather_clutter as wc
from shipradar.sensors.measurement import wrap_azimuth
from shipradar.sensors.noise import range_cell_m
from shipradar.tables.store import Table, get_or_build

SEA_MAP_NAME = "sea_clutter_map"
WEATHER_MAP_NAME = "weather_clutter_map"
#: Builder versions (part of the cache key): bump when the model changes.
SEA_MAP_VERSION = 3  # 3: the mean earth radius (issue 31)
WEATHER_MAP_VERSION = 4  # 4: the mean earth radius (issue 31)
#: Default grid: 1501 ranges (100 m steps at 150 km) and 1° in azimuth.
DEFAULT_N_RANGE = 1501
DEFAULT_N_AZIMUTH = 360

ElevationPattern = tuple[str, float, float, float]
Directivity = Callable[[NDArray[np.float64]], NDArray[np.float64]]


def map_axes(max_range_m: float, n_range: int, n_azimuth: int) -> tuple[np.ndarray, np.ndarray]:
    """Ground-range axis [0, R_max] [m] and azimuth axis [0, 2π] (n_azimuth + 1 points) [rad]."""
    if max_range_m <= 0.0 or n_range < 2 or n_azimuth < 2:
        raise ValueError("need max_range_m > 0, n_range >= 2 and n_azimuth >= 2")
    return np.linspace(0.0, max_range_m, n_range), np.linspace(0.0, 2.0 * np.pi, n_azimuth + 1)


def lookup_clutter(
    table: Table, ground_range_m: ArrayLike, azimuth_rad: ArrayLike, array: str | None = None
) -> NDArray[np.float64]:
    """Read a clutter map at ground ranges and (unwrapped) azimuths; NaN beyond the range axis.

    Parameters
    ----------
    table : Table
        A map from :func:`build_sea_clutter_map` or :func:`build_weather_clutter_map`.
    ground_range_m : array_like
        Ground range [m].
    azimuth_rad : array_like
        Beam azimuth from true north [rad], any real value.
    array : str, optional
        An extra (e.g. ``"weibull_a"``) instead of the power.
    """
    return table.lookup(ground_range_m, wrap_azimuth(azimuth_rad), array=array)


def _noise_limit_range(ranges: np.ndarray, power: np.ndarray, limit_w: float) -> np.ndarray:
    """Per azimuth, the last ground range where the power is above ``limit_w`` (0 if nowhere).

    Interpolated linearly in dB between the two grid points around the crossing.
    """
    above = power > limit_w
    n = len(ranges)
    # index of the last range above the limit, per column (-1 if none)
    last = n - 1 - np.argmax(above[::-1, :], axis=0)
    last = np.where(above.any(axis=0), last, -1)
    out = np.where(last < 0, 0.0, ranges[-1])
    inner = (last >= 0) & (last < n - 1)
    cols = np.nonzero(inner)[0]
    i = last[cols]
    p0 = sc.to_db(power[i, cols])
    p1 = sc.to_db(power[i + 1, cols])
    lim = sc.to_db(limit_w)
    t = np.clip((p0 - lim) / np.maximum(p0 - p1, 1e-12), 0.0, 1.0)
    out[cols] = ranges[i] + t * (ranges[i + 1] - ranges[i])
    return out


#: Plain-JSON conversion of a map spec's field by its declared type (see :func:`_field_inputs`).
_FIELD_TYPES: dict[str, Callable[[Any], Any]] = {"float": float, "int": int, "bool": bool,
                                                  "str": str}


def _field_inputs(spec: Any, **given: Any) -> dict[str, Any]:
    """Every field of a map spec, in declaration order, as a plain value of its declared type
    (``float | None``: None or a float), so that equal inputs give one cache key whatever
    their Python type (9_400_000_000 and 9.4e9); ``given`` supplies the fields of other
    types, already converted."""
    out: dict[str, Any] = {}
    for f in fields(spec):
        value = getattr(spec, f.name)
        if f.name in given:
            out[f.name] = given[f.name]
        elif value is None and str(f.type).endswith("| None"):
            out[f.name] = None
        else:
            out[f.name] = _FIELD_TYPES[str(f.type).split(" | ")[0]](value)
    return out


@dataclass(frozen=True)
class SeaClutterMapSpec:
    """What a sea-clutter map depends on: one declaration, read by the cache key
    (:meth:`inputs`) and by :func:`build_sea_clutter_map`, whose docstring gives each
    field's meaning and unit."""

    freq_hz: float
    polarization: str
    antenna_height_m: float
    beamwidth_az_rad: float
    pulse_width_s: float
    radar_constant_w_m2: float
    elevation_pattern: ElevationPattern
    noise_power_w: float
    rotation_rate_rad_s: float
    wind_speed_mps: float
    wind_direction_rad: float
    max_range_m: float
    wave_height_m: float | None = None
    sea_state: float | None = None
    duct_height_m: float = 0.0
    a_min: float = sc.RAYLEIGH_A
    motion_compensated: bool = True
    ship_speed_mps: float = 0.0
    ship_heading_rad: float = 0.0
    n_range: int = DEFAULT_N_RANGE
    n_azimuth: int = DEFAULT_N_AZIMUTH
    k_factor: float = geometry.K_FACTOR

    def inputs(self) -> dict[str, Any]:
        """The hashable inputs (the table's cache key and its provenance)."""
        kind, bw, sl, tilt = self.elevation_pattern
        return _field_inputs(
            self, polarization=sc.polarization_letter(self.polarization),
            elevation_pattern=[str(kind), float(bw), float(sl), float(tilt)])


def sea_clutter_map_inputs(**kwargs: Any) -> dict[str, Any]:
    """The hashable inputs of a sea-clutter map: the keywords are the fields of
    :class:`SeaClutterMapSpec` (the arguments of :func:`build_sea_clutter_map`)."""
    return SeaClutterMapSpec(**kwargs).inputs()



# long: 61 docstring lines (each field of SeaClutterMapSpec with its unit)
def build_sea_clutter_map(*, elevation_directivity: Directivity, **kwargs: Any) -> Table:
    """Build the sea-clutter map of one radar in one environment.

    Per cell (ground range d, beam azimuth θ): φ = θ - wind direction (the direction the wind
    blows *from*, so φ = 0 looks upwind); σ0*(d, φ) by [22]
    (:func:`shipradar.sensors.sea_clutter.ducted_reflectivity_db`, the duct ignored below 1 m);
    P_sc = K_r g⁴(-ψ_d) R θ_b C_R σ0* / R⁴ [21]; σ0d against the reference of [31]; a by [32]
    (VP) or the 4.1.2 heuristic (HP: 3 at the 3° range, linearly down to a_min at the last range
    where P_sc > 2 N0'), or 1 when the resolution is too coarse for non-Rayleigh clutter;
    μ_c [34]-[35] and σ_s [36]-[38].

    Parameters
    ----------
    elevation_directivity : callable
        g(elevation [rad]) → field factor, the radar's elevation pattern (negative elevations
        are below the horizon).  Must be the pattern that ``elevation_pattern`` describes.
    freq_hz : float
        Carrier frequency [Hz], 1-100 GHz.
    polarization : {"H", "V"}
        Polarization.
    antenna_height_m : float
        h_a [m].
    beamwidth_az_rad : float
        θ_b [rad].
    pulse_width_s : float
        τ' [s]; C_R = c τ'/2.
    radar_constant_w_m2 : float
        K_r of [3] [W·m²].
    elevation_pattern : tuple
        Hashable description (kind, beamwidth [rad], sidelobe [dB], tilt [rad]) of the callable.
    noise_power_w : float
        N0' of [19] [W] (HP skewness heuristic).
    rotation_rate_rad_s : float
        α [rad/s] ([37]).
    wind_speed_mps : float
        w_s [m/s].
    wind_direction_rad : float
        Direction the wind blows from, true north [rad].
    max_range_m : float
        Last ground range of the map [m].
    wave_height_m : float, optional
        Significant wave height [m]; None: from the wind.
    sea_state : float, optional
        Douglas sea state of [27]; None: from the wave height.
    duct_height_m : float, optional
        Evaporation duct height [m]; < 1 m: no duct.
    a_min : float, optional
        a_min.
    motion_compensated : bool, optional
        μ_c = 0 ([35]).
    ship_speed_mps, ship_heading_rad : float, optional
        Platform velocity for f1 [34] (speed [m/s], course from true north [rad]).
    n_range, n_azimuth : int, optional
        Grid size.
    k_factor : float, optional
        Effective earth radius factor.

    Returns
    -------
    Table
        Values P_sc [W]; extras as in the module docstring.
    """
    inputs = sea_clutter_map_inputs(**kwargs)
    p = inputs
    ranges = sea_map_ranges(p["max_range_m"], p["n_range"], p["antenna_height_m"])
    _, azimuths = map_axes(p["max_range_m"], p["n_range"], p["n_azimuth"])
    cells = sea_clutter_cells(ranges[:, None], azimuths[None, :], inputs, elevation_directivity)
    power = cells["power_w"]
    shape = power.shape
    if (p["polarization"] == "H"
            and bool(sc.is_medium_high_resolution(p["beamwidth_az_rad"], p["pulse_width_s"]))):
        r_ref = sc.ground_range_at_grazing_m(sc.REFERENCE_GRAZING_RAD, p["antenna_height_m"],
                                             p["k_factor"])
        r_noise = _noise_limit_range(ranges, power, sc.HP_NOISE_LIMIT_FACTOR * p["noise_power_w"])
        cells["weibull_a"] = sc.weibull_a_hp(ranges[:, None], r_ref, r_noise[None, :],
                                             p["a_min"])
    return Table(
        name=SEA_MAP_NAME,
        version=SEA_MAP_VERSION,
        axes=(ranges, azimuths),
        axis_names=("ground_range_m", "azimuth_rad"),
        axis_units=("m", "rad"),
        values=power,
        value_name="sea_clutter_power_w",
        value_unit="W",
        inputs=inputs,
        extra={name: np.broadcast_to(cells[name], shape).astype(float)
               for name in ("sigma0_db", "sigma0_diff_db", "weibull_a", "doppler_mean_hz",
                            "doppler_spread_hz")},
    )


#: Near-range nodes of the sea map (issue 36): from ``SEA_NEAR_FIRST`` h_a, geometric with
#: ratio ``SEA_NEAR_RATIO`` out to where that step reaches the uniform one.  Within a few
#: tens of h_a the depression angle, hence the pattern g⁴(-ψ_d) (its lobes and nulls below
#: the beam), the 1/R³ and f1's cos ψ_d [34], change by a large fraction within one 100 m
#: step (40.7 dB and 142 Hz read wrong there).
SEA_NEAR_FIRST = 0.01
SEA_NEAR_RATIO = 1.02
#: ... and no further than ``SEA_NEAR_LAST`` h_a (ψ_d = 1.4°: beyond, 100 m steps hold it).
SEA_NEAR_LAST = 40.0


def sea_map_ranges(max_range_m: float, n_range: int, antenna_height_m: float) -> np.ndarray:
    """Ground-range axis of the sea map [m]: the uniform nodes of :func:`map_axes`, and
    geometric nodes near the radar (from :data:`SEA_NEAR_FIRST` h_a, ratio
    :data:`SEA_NEAR_RATIO`) up to where that ratio's step reaches the uniform one; a
    geometric node closer than half its step to a uniform node is left out."""
    uniform, _ = map_axes(max_range_m, n_range, 2)
    d_end = min(float(uniform[1]) / (SEA_NEAR_RATIO - 1.0), SEA_NEAR_LAST * antenna_height_m,
                float(max_range_m))
    first = SEA_NEAR_FIRST * max(antenna_height_m, 1.0)
    if first >= d_end:
        return uniform
    n = int(np.ceil(np.log(d_end / first) / np.log(SEA_NEAR_RATIO)))
    near = np.geomspace(first, d_end, n + 1)[:-1]
    gap = np.min(np.abs(near[:, None] - uniform[None, :]), axis=1)
    near = near[gap >= 0.5 * (SEA_NEAR_RATIO - 1.0) * near]
    return np.sort(np.concatenate([near, uniform]))


def sea_clutter_cells(d: ArrayLike, azimuth: ArrayLike, inputs: dict[str, Any],
                      elevation_directivity: Directivity) -> dict[str, NDArray[np.float64]]:
    """The sea-clutter map's quantities evaluated directly at ground ranges and azimuths.

    What :func:`build_sea_clutter_map` tabulates, at any (broadcast) points: ``power_w``
    P_sc [W] [21], ``sigma0_db`` σ0* [dB] [22], ``sigma0_diff_db`` σ0d [dB], ``weibull_a``
    (VP [32]; Rayleigh at coarse resolution; for HP the 4.1.2 heuristic needs the map's
    noise-limit range, so the builder sets it and this returns ``nan``), ``doppler_mean_hz``
    μ_c [34]-[35] and ``doppler_spread_hz`` σ_s [36]-[38].

    Parameters
    ----------
    d : array_like
        Ground range [m], ≥ 0.
    azimuth : array_like
        Beam azimuth from true north [rad].
    inputs : dict
        :func:`sea_clutter_map_inputs`.
    elevation_directivity : callable
        The pattern ``inputs["elevation_pattern"]`` describes.
    """
    p = inputs
    d = np.asarray(d, dtype=float)
    az = np.asarray(azimuth, dtype=float)
    h_a, f, k = p["antenna_height_m"], p["freq_hz"], p["k_factor"]
    w_s, w_h = p["wind_speed_mps"], p["wave_height_m"]
    lam = SPEED_OF_LIGHT_MPS / f
    c_r = range_cell_m(p["pulse_width_s"])
    theta_b = p["beamwidth_az_rad"]
    phi = az - p["wind_direction_rad"]
    sigma0_db = sc.ducted_reflectivity_db(
        d, h_a, f, w_s, phi, w_h, p["polarization"], p["duct_height_m"], p["sea_state"], k
    )
    slant = sc.slant_range_m(d, h_a, k)
    depression = sc.depression_angle_rad(d, h_a, k)
    g = np.asarray(elevation_directivity(-depression), dtype=float)
    power = sc.sea_clutter_power_w(p["radar_constant_w_m2"], g, slant, theta_b, c_r,
                                   sc.from_db(sigma0_db))
    shape = np.shape(power)
    sigma0_diff_db = sigma0_db - sc.to_db(sc.reference_reflectivity(w_s, w_h))
    if not bool(sc.is_medium_high_resolution(theta_b, p["pulse_width_s"])):
        a = np.full(shape, sc.RAYLEIGH_A)
    elif p["polarization"] == "V":
        a = np.broadcast_to(sc.weibull_a_vp(sigma0_diff_db, w_s, p["a_min"]), shape)
    else:
        a = np.full(shape, np.nan)
    f1 = sc.platform_doppler_hz(p["ship_speed_mps"], az - p["ship_heading_rad"], depression, lam)
    mean = sc.mean_clutter_doppler_hz(f1, phi, lam, p["motion_compensated"])
    spread = sc.clutter_spread_hz(sc.wind_spread_hz(w_s, phi, lam) + np.zeros_like(d),
                                  sc.rotation_spread_hz(p["rotation_rate_rad_s"], theta_b))
    return {"power_w": np.broadcast_to(power, shape),
            "sigma0_db": np.broadcast_to(sigma0_db, shape),
            "sigma0_diff_db": np.broadcast_to(sigma0_diff_db, shape), "weibull_a": a,
            "doppler_mean_hz": np.broadcast_to(mean, shape),
            "doppler_spread_hz": np.broadcast_to(spread, shape)}


def sea_clutter_map(
    *, elevation_directivity: Directivity, root: Path | None = None, **kwargs: Any
) -> tuple[Table, bool]:
    """The sea-clutter map from the table cache, built if missing: ``(table, built)``.

    Same keyword arguments as :func:`build_sea_clutter_map`; ``root`` overrides the cache
    directory.
    """
    inputs = sea_clutter_map_inputs(**kwargs)
    return get_or_build(
        SEA_MAP_NAME,
        SEA_MAP_VERSION,
        inputs,
        lambda: build_sea_clutter_map(elevation_directivity=elevation_directivity, **kwargs),
        root,
    )


#: Fold and trip-end nodes sit this far either side of the jump [m]: the reader interpolates
#: across the jump only inside this gap (a delay within 1 mm of a pulse's transmission).
FOLD_NODE_GAP_M = 1.0e-3
#: After each multiple of R_u the first trip's near rain, P_1 ∝ r²/(r² + h_a²)², rises as r²,
#: peaks at r ≈ h_a and falls as r⁻²: a geometric run of nodes of ratio
#: :data:`NEAR_NODE_RATIO` from :data:`FOLD_NODE_GAP_M` (bilinear error of a power law r^n
#: ≈ n(n - 1)(ratio - 1)²/8: 0.25 % for r², 0.75 % for r⁻²) until the uniform step is fine
#: enough, at :data:`NEAR_NODES_END_STEPS` steps.
NEAR_NODE_RATIO = 1.1
NEAR_NODES_END_STEPS = 20
#: Most nodes added at the folds: beyond it (many folds, a high PRF over a long range:
#: ~54 folds of 148-node runs) the near runs are thinned, then the trip-end nodes dropped,
#: so a 500 kHz PRF over 1000 km (3335 folds) keeps 2 nodes a fold and a bounded map.
MAX_FOLD_NODES = 8000


def weather_range_axis(max_range_m: float, n_range: int, prf_hz: float) -> np.ndarray:
    """Ground-range axis of a weather-clutter map [m]: uniform, plus nodes at the folds.

    The trip sum P_wc(R) = Σ_k P_1(r + k R_u) ([39]-[41]) jumps at every multiple of R_u
    (r wraps to 0, the first trip starts again at the antenna) and where a trip passes the
    instrumented range (R = R_max - j R_u), and it is steep for r below ~2 km (the near
    rain, largest at r ≈ h_a).  Nodes: the uniform axis of ``n_range`` points on
    [0, R_max]; :data:`FOLD_NODE_GAP_M` either side of each jump; and after each multiple
    of R_u a geometric run (:data:`NEAR_NODE_RATIO`) up to :data:`NEAR_NODES_END_STEPS`
    uniform steps or the next fold.

    Parameters
    ----------
    max_range_m : float
        R_max, the instrumented range [m], > 0.
    n_range : int
        Points of the uniform axis, ≥ 2.
    prf_hz : float
        f_r [Hz], > 0 (R_u = c/(2 f_r)).

    Returns
    -------
    ndarray
        Strictly increasing ground ranges from 0 to R_max [m].
    """
    uniform = np.linspace(0.0, max_range_m, n_range)
    r_u = float(wc.unambiguous_range_m(prf_hz))
    step = max_range_m / (n_range - 1)
    near_end = min(r_u, NEAR_NODES_END_STEPS * step)
    n_near = int(np.ceil(np.log(near_end / FOLD_NODE_GAP_M) / np.log(NEAR_NODE_RATIO))) + 1
    near = np.geomspace(FOLD_NODE_GAP_M, near_end, max(n_near, 2))
    near = near[near < r_u - FOLD_NODE_GAP_M]  # the first is the right side of each fold
    folds = r_u * np.arange(0.0, np.floor(max_range_m / r_u) + 1.0)
    # where a trip leaves the instrumented range: r + j R_u = R_max
    ends = np.mod(max_range_m, r_u) + folds
    edges = [folds[1:] - FOLD_NODE_GAP_M, ends - FOLD_NODE_GAP_M, ends + FOLD_NODE_GAP_M]
    if folds.size * (near.size + 3) > MAX_FOLD_NODES:  # thin the runs, keep their start
        stride = int(np.ceil(folds.size * near.size / max(MAX_FOLD_NODES - 3 * folds.size,
                                                          folds.size)))
        near = near[::stride]
        if folds.size * (near.size + 3) > MAX_FOLD_NODES:
            edges = edges[:1]
    nodes = [uniform, (folds[:, None] + near[None, :]).ravel(), *edges]
    axis = np.unique(np.concatenate(nodes))
    axis = axis[(axis >= 0.0) & (axis <= max_range_m)]
    # drop accidental duplicates (a uniform node on a fold node, to rounding)
    keep = np.concatenate([[True], np.diff(axis) > 1.0e-3 * FOLD_NODE_GAP_M])
    return axis[keep]


@dataclass(frozen=True)
class WeatherClutterMapSpec:
    """What a weather-clutter map depends on: one declaration, read by the cache key
    (:meth:`inputs`) and by :func:`build_weather_clutter_map`, whose docstring gives each
    field's meaning and unit."""

    freq_hz: float
    antenna_height_m: float
    beamwidth_az_rad: float
    beamwidth_el_rad: float
    pulse_width_s: float
    prf_hz: float
    radar_constant_w_m2: float
    rain_rate_mm_h: float
    cloud_base_m: float
    rotation_rate_rad_s: float
    wind_speed_mps: float
    wind_direction_rad: float
    max_range_m: float
    precipitation: str = "rain"
    rain_attenuation_db_per_km: float = 0.0
    turbulence_spread_mps: float = wc.RAIN_TURBULENCE_SPREAD_MPS
    motion_compensated: bool = True
    ship_speed_mps: float = 0.0
    ship_heading_rad: float = 0.0
    n_range: int = DEFAULT_N_RANGE
    n_azimuth: int = DEFAULT_N_AZIMUTH
    k_factor: float = geometry.K_FACTOR

    def __post_init__(self) -> None:
        if self.rain_rate_mm_h <= 0.0:
            raise ValueError("a weather-clutter map needs precipitation (rain_rate_mm_h > 0)")
        if self.rain_attenuation_db_per_km < 0.0:
            raise ValueError(
                f"rain_attenuation_db_per_km must be >= 0, got {self.rain_attenuation_db_per_km}")

    def inputs(self) -> dict[str, Any]:
        """The hashable inputs (the table's cache key and its provenance)."""
        return _field_inputs(self)


def weather_clutter_map_inputs(**kwargs: Any) -> dict[str, Any]:
    """The hashable inputs of a weather-clutter map: the keywords are the fields of
    :class:`WeatherClutterMapSpec` (see :func:`build_weather_clutter_map`)."""
    return WeatherClutterMapSpec(**kwargs).inputs()



def weather_clutter_profile(
    ground_range_m: ArrayLike, inputs: dict[str, Any]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The weather map's range profile, evaluated directly at any ground ranges.

    What :func:`build_weather_clutter_map` tabulates at its nodes (and what its reader is
    tested against off the grid): the attenuated trip sum P_wc, its power-weighted rms
    spread, and the single unattenuated trip P_1, with rain everywhere (the map's power
    does not depend on the azimuth).

    Parameters
    ----------
    ground_range_m : array_like
        Ground ranges R [m], ≥ 0.
    inputs : dict
        :func:`weather_clutter_map_inputs` (its result).

    Returns
    -------
    tuple of ndarray
        P_wc [W], σ_wc [Hz], P_1 [W], each of the shape of ``ground_range_m``.
    """
    p = inputs
    ranges = np.asarray(ground_range_m, dtype=np.float64)
    h_a = p["antenna_height_m"]
    f = p["freq_hz"]
    lam = SPEED_OF_LIGHT_MPS / f
    theta_b, phi_b = p["beamwidth_az_rad"], p["beamwidth_el_rad"]
    h_cloud, gamma = p["cloud_base_m"], p["rain_attenuation_db_per_km"]

    eta = wc.rain_reflectivity(f, p["rain_rate_mm_h"], p["precipitation"])
    c_r = range_cell_m(p["pulse_width_s"])
    rotation = sc.rotation_spread_hz(p["rotation_rate_rad_s"], theta_b)

    def single_trip(x):
        slant = sc.slant_range_m(x, h_a, p["k_factor"])
        return wc.single_trip_power_w(
            p["radar_constant_w_m2"], eta, x, slant, theta_b, phi_b, h_cloud, c_r
        )

    def attenuated_trip(x):
        # [39] with K_r of [3]: each trip through its own two-way rain loss [16], rain
        # everywhere below h_cloud (the azimuth does not matter)
        path = wc.rain_path_to_cell_m(x, 0.0, np.zeros(2), h_a, phi_b, h_cloud)
        return single_trip(x) * wc.two_way_rain_transmission(gamma, path)

    def spread_at(x):
        return wc.weather_spread_hz(
            lam, wc.shear_spread_mps(x, phi_b, h_cloud), p["turbulence_spread_mps"], rotation
        )

    # [39]-[41] read consistently (module notes of shipradar.sensors.weather_clutter): the rain
    # of every pulse in flight, r + k R_u up to the instrumented range, each at its own range.
    r_max = p["max_range_m"]
    power = wc.range_folded_power_w(attenuated_trip, ranges, p["prf_hz"], r_max)
    # the trips share the mean Doppler (wind drift, f1); their spreads differ (shear ∝ range):
    # the mixture's spread is the power-weighted rms
    second = wc.range_folded_power_w(
        lambda x: attenuated_trip(x) * spread_at(x) ** 2, ranges, p["prf_hz"], r_max
    )
    own = spread_at(ranges)
    has = power > 0.0
    spread = np.where(has, np.sqrt(np.where(has, second, 0.0) / np.where(has, power, 1.0)), own)
    return power, spread, single_trip(ranges)


def build_weather_clutter_map(**kwargs: Any) -> Table:
    """Build the weather-clutter map of one radar in one precipitation (seed [39]-[45]).

    Per cell at ground range R: ϑ0 [42] (snow as rain-equivalent), and the rain of every
    pulse in flight that arrives with the echo of R, ``P_wc = Σ_k P_1(r + k R_u)``, r the
    range folded by the PRF [41], each term ``K_r ϑ0 x θ_b d_h(x) C_R / x_s⁴ / L_rain(x)²``
    with its own range x and its own two-way rain loss ([39] with K_r of [3] and the γ_r of
    [16], [40], [43]; :func:`shipradar.sensors.weather_clutter.range_folded_power_w`, up to
    the instrumented range), assuming rain everywhere, on the axis of
    :func:`weather_range_axis`.  This replaces the seed's volume at
    R_c over the true R⁴ (erratum, module notes of :mod:`shipradar.sensors.weather_clutter`).
    Spread [44]-[45] with the scan [37], the power-weighted rms over the trips; mean from the wind
    drift (and f1 [34] unless motion-compensated, the beam at the horizon).  Only call this
    when the scene has precipitation; multiply by the cell's rain fraction on-line (exact
    for rain everywhere; for a rain region the extra ``single_trip_power_w`` lets the
    on-line side weight each trip by its own rain fraction).

    Parameters
    ----------
    **kwargs
        As :func:`weather_clutter_map_inputs`: ``freq_hz`` [Hz], ``antenna_height_m`` [m],
        ``beamwidth_az_rad`` and ``beamwidth_el_rad`` [rad], ``pulse_width_s`` [s], ``prf_hz``
        [Hz], ``radar_constant_w_m2`` [W·m²], ``rain_rate_mm_h`` [mm/h], ``cloud_base_m`` [m],
        ``rotation_rate_rad_s`` [rad/s], ``wind_speed_mps`` [m/s], ``wind_direction_rad``
        (from, true north) [rad], ``max_range_m`` [m], ``precipitation`` ("rain", "dry_snow",
        "wet_snow"), ``rain_attenuation_db_per_km`` (γ_r one-way [dB/km], 0: none, e.g.
        with the atmosphere switched off), ``turbulence_spread_mps`` [m/s],
        ``motion_compensated``,
        ``ship_speed_mps`` [m/s], ``ship_heading_rad`` [rad], ``n_range``, ``n_azimuth``,
        ``k_factor``.

    Returns
    -------
    Table
        Values P_wc [W] (full rain, summed over trips, attenuated); extras
        ``doppler_mean_hz`` and ``doppler_spread_hz`` [Hz], ``single_trip_power_w`` P_1 [W]
        (the cell alone, without rain loss).
    """
    p = weather_clutter_map_inputs(**kwargs)
    _, azimuths = map_axes(p["max_range_m"], p["n_range"], p["n_azimuth"])
    ranges = weather_range_axis(p["max_range_m"], p["n_range"], p["prf_hz"])
    lam = SPEED_OF_LIGHT_MPS / p["freq_hz"]
    power, spread, single = weather_clutter_profile(ranges, p)

    phi = (azimuths - p["wind_direction_rad"])[None, :]
    f1: float | NDArray[np.float64] = 0.0
    if not p["motion_compensated"]:
        f1 = sc.platform_doppler_hz(
            p["ship_speed_mps"], azimuths[None, :] - p["ship_heading_rad"], 0.0, lam
        )
    mean = wc.weather_mean_doppler_hz(p["wind_speed_mps"], phi, lam, f1)
    shape = (len(ranges), len(azimuths))
    return Table(
        name=WEATHER_MAP_NAME,
        version=WEATHER_MAP_VERSION,
        axes=(ranges, azimuths),
        axis_names=("ground_range_m", "azimuth_rad"),
        axis_units=("m", "rad"),
        values=np.broadcast_to(power[:, None], shape).copy(),
        value_name="weather_clutter_power_w",
        value_unit="W",
        inputs=p,
        extra={
            "doppler_mean_hz": np.broadcast_to(mean, shape).copy(),
            "doppler_spread_hz": np.broadcast_to(spread[:, None], shape).copy(),
            # P_1 of the cell itself (no folding, no rain loss): with a rain *region*, the
            # on-line side needs each trip's own rain fraction and its own loss through the
            # region, Σ_k frac(x_k) P_1(x_k) / L_rain(x_k)², x_k = r + k R_u
            "single_trip_power_w": np.broadcast_to(single[:, None], shape).copy(),
        },
    )


def weather_clutter_map(*, root: Path | None = None, **kwargs: Any) -> tuple[Table, bool]:
    """The weather-clutter map from the table cache, built if missing: ``(table, built)``."""
    inputs = weather_clutter_map_inputs(**kwargs)
    return get_or_build(
        WEATHER_MAP_NAME,
        WEATHER_MAP_VERSION,
        inputs,
        lambda: build_weather_clutter_map(**kwargs),
        root,
    )
