"""The atmospheric-loss table of a scene: one-way gas + fog loss of [16] against slant range and
elevation (off-line level), and its per-dwell lookup.

The physics (ITU-R P.676 / P.840 through ``itur``) is :mod:`shipradar.sensors.atmosphere`; rain
depends on the rain cell's geometry and is computed on-line there, not tabulated.

What the lookup interpolates and what it evaluates (issue 36):

* the gaseous loss, a quadrature per point, is read bilinearly from the table;
* the fog loss is γ_f/c (one number per scene, kept in the table) times the length of the
  path below the fog top, a closed form (:func:`shipradar.sensors.atmosphere.layer_path_length_m`)
  evaluated per point: the length has a kink along the range where the ray leaves the layer,
  which moves by ~150 km per degree of elevation near the horizon, so no affordable
  elevation axis holds it (a 0.5° axis read 21.45 dB for 28.38 dB at 35 GHz in a 100 m fog);
* outside the table's axes (a range beyond the last node, an elevation below the first) the
  gaseous loss is the direct quadrature from the P.676 coefficients kept in the table: no
  clamp and no extrapolation.
"""

from __future__ import annotations

import functools
import sys
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from shipradar.sensors import atmosphere as atm
from shipradar.tables.store import Table, get_or_build

__all__ = ["TABLE_NAME", "TABLE_VERSION", "AtmosphericLossSpec", "atmospheric_loss_grid",
           "atmospheric_loss_inputs", "lookup_gas_fog_loss_db"]

#: Table builder name and version (bump on any change of the model in
#: :mod:`shipradar.sensors.atmosphere`).
TABLE_NAME = "atmospheric_loss"
TABLE_VERSION = 3  # 3: the mean earth radius (issue 31)

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
    gamma_fog = 0.0
    if inputs["fog_lwc_g_m3"] > 0.0:
        gamma_fog = float(atm.fog_specific_attenuation_db_per_km(freq_hz, inputs["fog_lwc_g_m3"],
                                                                 t))
    fog = _fog_loss_db(gamma_fog, rr, ee, inputs["fog_top_m"], ha)
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
        # what the lookup evaluates itself: the gas integral outside the axes, the fog
        attached={"gas_coefficients": np.array([float(go), float(gw), float(ho), float(hw)]),
                  "fog_db_per_km": np.array([gamma_fog])},
    )


def _fog_loss_db(gamma_fog_db_per_km: float, slant_range_m: ArrayLike, elevation_rad: ArrayLike,
                 fog_top_m: float, antenna_height_m: float) -> NDArray[np.float64]:
    """Fog loss [dB]: γ_f/c [dB/km] times the path length below the fog top [16] (exact)."""
    length = atm.layer_path_length_m(slant_range_m, elevation_rad, fog_top_m, antenna_height_m)
    return gamma_fog_db_per_km * length / constants.kilo


@dataclass(frozen=True)
class AtmosphericLossSpec:
    """What the atmospheric-loss table depends on: one declaration, read by the cache key
    (:meth:`inputs`) and by :func:`atmospheric_loss_grid`.

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
    """

    freq_hz: float
    ranges_m: ArrayLike
    elevations_rad: ArrayLike
    temperature_k: float = atm.STANDARD_TEMPERATURE_K
    pressure_hpa: float = atm.STANDARD_PRESSURE_HPA
    water_vapour_density_g_m3: float = atm.STANDARD_WATER_VAPOUR_G_M3
    fog_lwc_g_m3: float = 0.0
    fog_top_m: float = atm.DEFAULT_FOG_TOP_M
    antenna_height_m: float = 0.0

    def inputs(self) -> dict[str, Any]:
        """The table's inputs (its cache key and provenance), with the itur recommendation
        versions; the axes as float arrays."""
        ranges = np.asarray(self.ranges_m, dtype=float)
        elevations = np.asarray(self.elevations_rad, dtype=float)
        if np.any(ranges < 0.0):
            raise ValueError("slant ranges must be >= 0")
        return {
            "freq_hz": float(self.freq_hz),
            "ranges_m": ranges,
            "elevations_rad": elevations,
            "temperature_k": float(self.temperature_k),
            "pressure_hpa": float(self.pressure_hpa),
            "water_vapour_density_g_m3": float(self.water_vapour_density_g_m3),
            "fog_lwc_g_m3": float(self.fog_lwc_g_m3),
            "fog_top_m": float(self.fog_top_m),
            "antenna_height_m": float(self.antenna_height_m),
            **itur_versions(),
        }


def atmospheric_loss_grid(
    freq_hz: float,
    ranges_m: ArrayLike,
    elevations_rad: ArrayLike,
    *,
    cache: bool = True,
    root: Path | None = None,
    **conditions: Any,
) -> Table:
    """Table of the one-way gaseous + fog loss of [16] against slant range and elevation.

    Built once per scene (off-line level), cached by :func:`shipradar.tables.store.get_or_build`
    under a hash of every input (:class:`AtmosphericLossSpec`) plus the itur recommendation
    versions.

    Parameters
    ----------
    freq_hz, ranges_m, elevations_rad
        Frequency [Hz] and the axes: slant range [m] and elevation [rad]
        (:class:`AtmosphericLossSpec`).
    cache : bool, optional
        Read/write the table cache (False: always build, nothing written).
    root : Path, optional
        Cache directory (default :func:`shipradar.tables.store.cache_dir`).
    **conditions
        The other fields of :class:`AtmosphericLossSpec` (temperature, pressure, water
        vapour, fog, antenna height), by keyword.

    Returns
    -------
    Table
        ``values[i, j]`` = one-way loss [dB] at ``(ranges_m[i], elevations_rad[j])``;
        ``extra["gaseous_db"]`` and ``extra["fog_db"]`` hold the two parts.  Rain is not in
        the table (it depends on the rain cell geometry): see
        :func:`shipradar.sensors.atmosphere.rain_loss_db`.
    """
    inputs = AtmosphericLossSpec(freq_hz, ranges_m, elevations_rad, **conditions).inputs()

    def build() -> Table:
        return _build_grid(inputs["freq_hz"], inputs["ranges_m"], inputs["elevations_rad"],
                           inputs)

    if not cache:
        return build()
    table, _ = get_or_build(TABLE_NAME, TABLE_VERSION, inputs, build, root)
    return table


def atmospheric_loss_inputs(freq_hz: float, ranges_m: ArrayLike, elevations_rad: ArrayLike,
                            **conditions: Any) -> dict[str, Any]:
    """The inputs of :func:`atmospheric_loss_grid` that key its table (same arguments: the
    fields of :class:`AtmosphericLossSpec`)."""
    return AtmosphericLossSpec(freq_hz, ranges_m, elevations_rad, **conditions).inputs()


def lookup_gas_fog_loss_db(
    table: Table, slant_range_m: ArrayLike, elevation_rad: ArrayLike
) -> NDArray[np.float64]:
    """One-way gas + fog loss [dB] from a table of :func:`atmospheric_loss_grid`, per dwell.

    The gaseous loss is interpolated bilinearly on the table's grid, or, outside its axes,
    integrated directly (:func:`shipradar.sensors.atmosphere.gaseous_loss_db` with the P.676
    coefficients the table keeps: no clamp, no extrapolation); the fog loss is evaluated
    exactly at every point (see the module docstring).  Against the direct functions on the
    axes of :func:`shipradar.tables.scene.atmosphere_axes`: docs/accuracy.md.

    Parameters
    ----------
    table : Table
        The scene's atmospheric-loss table.
    slant_range_m : array_like
        Slant range [m] (below 0 read as 0).
    elevation_rad : array_like
        Elevation of the ray at the antenna [rad], on the table's 4/3 earth: for a target
        use :func:`shipradar.sensors.atmosphere.ray_elevation_rad`.

    Returns
    -------
    ndarray
        Loss [dB], ≥ 0.
    """
    r, el = np.broadcast_arrays(np.maximum(np.asarray(slant_range_m, dtype=float), 0.0),
                                np.asarray(elevation_rad, dtype=float))
    ha = float(table.inputs["antenna_height_m"])
    gas = table.lookup(r, el, array="gaseous_db")
    outside = np.isnan(gas) & ~np.isnan(r) & ~np.isnan(el)
    if outside.any():
        go, gw, ho, hw = (float(x) for x in table.attached["gas_coefficients"])
        gas[outside] = atm.gaseous_loss_db(r[outside], el[outside], gamma_o_db_per_km=go,
                                           gamma_w_db_per_km=gw, h_o_m=ho, h_w_m=hw,
                                           antenna_height_m=ha)
    gamma_fog = float(table.attached["fog_db_per_km"][0])
    if gamma_fog > 0.0:
        gas += _fog_loss_db(gamma_fog, r, el, float(table.inputs["fog_top_m"]), ha)
    return np.maximum(gas, 0.0)
