"""The atmospheric-loss table of a scene: one-way gas + fog loss of [16] against slant range and
elevation (off-line level), and its per-dwell lookup.

The physics (ITU-R P.676 / P.840 through ``itur``) is :mod:`shipradar.sensors.atmosphere`; rain
depends on the rain cell's geometry and is computed on-line there, not tabulated.
"""

from __future__ import annotations

import functools
import sys
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from shipradar.sensors import atmosphere as atm
from shipradar.tables.store import Table, get_or_build

__all__ = ["TABLE_NAME", "TABLE_VERSION", "atmospheric_loss_grid", "atmospheric_loss_inputs",
           "lookup_gas_fog_loss_db"]

#: Table builder name and version (bump on any change of the model in
#: :mod:`shipradar.sensors.atmosphere`).
TABLE_NAME = "atmospheric_loss"
TABLE_VERSION = 1

#: The ITU-R recommendation versions each itur release selects by default (P.676, P.840), so
#: that a table's key is computed without importing itur, which imports astropy, scipy.stats
#: and scipy.interpolate (0.3-0.6 s of a run's start-up that reads the table from the cache).
#: Another release, or an itur already imported (whose versions a caller may have changed with
#: ``change_version``), is asked itself; ``tests/test_atmosphere.py`` checks the entry.
ITUR_DEFAULT_VERSIONS: dict[str, tuple[int, int]] = {"0.4.0": (12, 7)}


@functools.cache
def _installed_release(name: str) -> str:
    """The installed release of a distribution ("" if none), read once per process: each
    look-up scans ``sys.path`` (~0.7 ms), and a run's table keys asked 18 times."""
    try:
        return version(name)
    except PackageNotFoundError:  # pragma: no cover - itur is a dependency
        return ""


def itur_versions() -> dict[str, str | int]:
    """The itur release and the P.676 and P.840 versions it uses, as keyed into the table."""
    if "itur" not in sys.modules:
        release = _installed_release("itur")
        if release in ITUR_DEFAULT_VERSIONS:
            p676, p840 = ITUR_DEFAULT_VERSIONS[release]
            return {"itur": release, "p676": p676, "p840": p840}
    import itur
    from itur.models import itu676, itu840

    return {"itur": itur.__version__, "p676": itu676.get_version(),
            "p840": itu840.get_version()}


def _build_grid(freq_hz, ranges_m, elevations_rad, inputs) -> Table:
    t, p, rho = inputs["temperature_k"], inputs["pressure_hpa"], inputs["water_vapour_density_g_m3"]
    go, gw = atm.gaseous_specific_attenuation_db_per_km(
        freq_hz, temperature_k=t, pressure_hpa=p, water_vapour_density_g_m3=rho
    )
    ho, hw = atm.gaseous_equivalent_heights_m(
        freq_hz, temperature_k=t, pressure_hpa=p, water_vapour_density_g_m3=rho
    )
    rr, ee = np.meshgrid(ranges_m, elevations_rad, indexing="ij")
    ha = inputs["antenna_height_m"]
    gas = atm.gaseous_loss_db(
        rr, ee, gamma_o_db_per_km=go, gamma_w_db_per_km=gw, h_o_m=ho, h_w_m=hw, antenna_height_m=ha
    )
    # Once the path has left the absorbing layer the quadrature of each range returns the
    # same total to within 1e-15 relative, in either direction: keep the table exactly
    # non-decreasing in range, as the loss is.
    gas = np.maximum.accumulate(gas, axis=0)
    if inputs["fog_lwc_g_m3"] > 0.0:
        gamma_fog = atm.fog_specific_attenuation_db_per_km(freq_hz, inputs["fog_lwc_g_m3"], t)
        fog = gamma_fog * atm.layer_path_length_m(rr, ee, inputs["fog_top_m"], ha) / constants.kilo
    else:
        fog = np.zeros_like(gas)
    return Table(
        name=TABLE_NAME,
        version=TABLE_VERSION,
        axes=(np.asarray(ranges_m, dtype=float), np.asarray(elevations_rad, dtype=float)),
        axis_names=("slant_range_m", "elevation_rad"),
        axis_units=("m", "rad"),
        values=gas + fog,
        value_name="one_way_gas_fog_loss_db",
        value_unit="dB",
        inputs=inputs,
        extra={"gaseous_db": gas, "fog_db": fog},
    )


def atmospheric_loss_grid(
    freq_hz: float,
    ranges_m: ArrayLike,
    elevations_rad: ArrayLike,
    *,
    temperature_k: float = atm.STANDARD_TEMPERATURE_K,
    pressure_hpa: float = atm.STANDARD_PRESSURE_HPA,
    water_vapour_density_g_m3: float = atm.STANDARD_WATER_VAPOUR_G_M3,
    fog_lwc_g_m3: float = 0.0,
    fog_top_m: float = atm.DEFAULT_FOG_TOP_M,
    antenna_height_m: float = 0.0,
    cache: bool = True,
    root: Path | None = None,
) -> Table:
    """Table of the one-way gaseous + fog loss of [16] against slant range and elevation.

    Built once per scene (off-line level), cached by :func:`shipradar.tables.store.get_or_build`
    under a hash of every input below plus the itur recommendation versions.

    Parameters
    ----------
    freq_hz : float
        Radar frequency [Hz].
    ranges_m : array_like, shape (n,)
        Slant-range axis [m], strictly increasing, ≥ 0 (include 0 and the instrumented range).
    elevations_rad : array_like, shape (m,)
        Elevation axis at the antenna [rad], strictly increasing (negative: below the
        antenna's horizontal).
    temperature_k, pressure_hpa, water_vapour_density_g_m3 : float, optional
        Surface air temperature [K], total pressure [hPa], water vapour density [g/m³].
    fog_lwc_g_m3 : float, optional
        Fog/low-cloud liquid water density [g/m³]; 0: no fog.
    fog_top_m : float, optional
        Top of the fog layer above the sea [m]; the fog fills the sea-to-top layer.
    antenna_height_m : float, optional
        Radar antenna height above the sea [m].
    cache : bool, optional
        Read/write the table cache (False: always build, nothing written).
    root : Path, optional
        Cache directory (default :func:`shipradar.tables.store.cache_dir`).

    Returns
    -------
    Table
        ``values[i, j]`` = one-way loss [dB] at ``(ranges_m[i], elevations_rad[j])``;
        ``extra["gaseous_db"]`` and ``extra["fog_db"]`` hold the two parts.  Rain is not in
        the table (it depends on the rain cell geometry): see
        :func:`shipradar.sensors.atmosphere.rain_loss_db`.
    """
    ranges = np.asarray(ranges_m, dtype=float)
    elevations = np.asarray(elevations_rad, dtype=float)
    inputs = atmospheric_loss_inputs(
        freq_hz, ranges, elevations, temperature_k=temperature_k, pressure_hpa=pressure_hpa,
        water_vapour_density_g_m3=water_vapour_density_g_m3, fog_lwc_g_m3=fog_lwc_g_m3,
        fog_top_m=fog_top_m, antenna_height_m=antenna_height_m)

    def build() -> Table:
        return _build_grid(float(freq_hz), ranges, elevations, inputs)

    if not cache:
        return build()
    table, _ = get_or_build(TABLE_NAME, TABLE_VERSION, inputs, build, root)
    return table


def atmospheric_loss_inputs(
    freq_hz: float,
    ranges_m: ArrayLike,
    elevations_rad: ArrayLike,
    *,
    temperature_k: float = atm.STANDARD_TEMPERATURE_K,
    pressure_hpa: float = atm.STANDARD_PRESSURE_HPA,
    water_vapour_density_g_m3: float = atm.STANDARD_WATER_VAPOUR_G_M3,
    fog_lwc_g_m3: float = 0.0,
    fog_top_m: float = atm.DEFAULT_FOG_TOP_M,
    antenna_height_m: float = 0.0,
) -> dict:
    """The inputs of :func:`atmospheric_loss_grid` that key its table (same arguments)."""
    ranges = np.asarray(ranges_m, dtype=float)
    elevations = np.asarray(elevations_rad, dtype=float)
    if np.any(ranges < 0.0):
        raise ValueError("slant ranges must be >= 0")
    return {
        "freq_hz": float(freq_hz),
        "ranges_m": ranges,
        "elevations_rad": elevations,
        "temperature_k": float(temperature_k),
        "pressure_hpa": float(pressure_hpa),
        "water_vapour_density_g_m3": float(water_vapour_density_g_m3),
        "fog_lwc_g_m3": float(fog_lwc_g_m3),
        "fog_top_m": float(fog_top_m),
        "antenna_height_m": float(antenna_height_m),
        **itur_versions(),
    }


def lookup_gas_fog_loss_db(
    table: Table, slant_range_m: ArrayLike, elevation_rad: ArrayLike
) -> NDArray[np.float64]:
    """One-way gas + fog loss [dB] from a table of :func:`atmospheric_loss_grid`, per dwell.

    Parameters
    ----------
    table : Table
        The scene's atmospheric-loss table.
    slant_range_m : array_like
        Slant range [m].
    elevation_rad : array_like
        Elevation of the ray at the antenna [rad], on the table's 4/3 earth: for a target
        use :func:`shipradar.sensors.atmosphere.ray_elevation_rad`.

    Returns
    -------
    ndarray
        Loss [dB], ≥ 0.  Elevations outside the axis are clamped to its ends; ranges beyond
        the last node are extrapolated with the last segment's dB/m slope (the loss keeps
        growing; build the table to the instrumented range to avoid it); ranges below the
        first node scale linearly to 0 at R = 0.
    """
    r_axis, e_axis = table.axes
    r = np.asarray(slant_range_m, dtype=float)
    el = np.clip(np.asarray(elevation_rad, dtype=float), e_axis[0], e_axis[-1])
    r, el = np.broadcast_arrays(r, el)
    rc = np.clip(r, r_axis[0], r_axis[-1])
    loss = table.lookup(rc, el)
    slope_end = np.interp(
        el, e_axis, (table.values[-1] - table.values[-2]) / (r_axis[-1] - r_axis[-2])
    )
    loss = loss + slope_end * np.maximum(r - r_axis[-1], 0.0)
    if r_axis[0] > 0.0:
        loss = np.where(r < r_axis[0], loss * np.maximum(r, 0.0) / r_axis[0], loss)
    return np.maximum(loss, 0.0)
