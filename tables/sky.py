"""The sky temperature and the rain attenuation of a radar, kept in the table store, and the
radar constants built on them.

:func:`shipradar.sensors.radar.radar_constants` needs T'_a, the sky noise temperature at the
beam maximum ([18], ITU-R P.372 radiative transfer through P.676 gaseous absorption).  Computing
it imports itur (which imports astropy, scipy.stats and scipy.interpolate: 0.3-0.6 s) and runs
a nested quadrature, on every run, for the same few numbers.  A scene with rain needs γ_R, the
rain's specific attenuation at the radar's frequency ([16], P.838 through itur: the same
import).  The store keeps them under the hash of their inputs like any table (issue 27): a run
that finds them never imports itur.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import numpy as np

from shipradar.sensors import noise
from shipradar.sensors.radar import RadarConstants, radar_constants, sky_temperature_args
from shipradar.sim.world.scenario import Radar, Scenario
from shipradar.tables.atmosphere import itur_versions
from shipradar.tables.store import Table, cache_dir, cache_path, inputs_hash, load_cached

#: Table builder name and version (bump on any change of :func:`noise.sky_temperature_k`).
TABLE_NAME = "sky_temperature"
TABLE_VERSION = 2  # 2: the mean earth radius (issue 31)
#: The table's second elevation node above the beam maximum [rad] (a table axis has two
#: nodes at least; only the first, the beam maximum, is read).
SECOND_NODE_ABOVE_RAD = 0.5
#: γ_R's builder name and version (bump on any change of
#: :func:`shipradar.sensors.atmosphere.rain_specific_attenuation_db_per_km`), and the second
#: node of its rain-rate axis above the scene's rate [mm/h] (only the first is read).
RAIN_TABLE_NAME = "rain_attenuation"
RAIN_TABLE_VERSION = 1
RAIN_SECOND_NODE_ABOVE_MM_H = 1.0

#: Inputs of a table, hashable: its inputs dict's items in order.
_Inputs = tuple[tuple[str, Any], ...]


class _NotCached(LookupError):
    """No table of these inputs in the cache (or a damaged one): not remembered."""


@functools.lru_cache(maxsize=256)
def _cache_path_of(name: str, version: int, inputs: _Inputs, root: Path) -> Path:
    """``cache_path(name, inputs_hash(name, version, inputs), root)``: a pure function of its
    arguments, kept per process (the inputs' hash, ~15 us, once, not at every run's
    construction; a study's many scenes: the least recently used go first)."""
    return cache_path(name, inputs_hash(name, version, dict(inputs)), root)


def _table_path(name: str, version: int, inputs: dict[str, Any]) -> Path:
    """``cache_path(name, inputs_hash(name, version, inputs))`` in the cache directory of
    now, remembered per process."""
    return _cache_path_of(name, version, tuple(inputs.items()), cache_dir())


@functools.lru_cache(maxsize=64)
def _load_version(name: str, version: int, inputs: _Inputs, path: Path,
                  stamp: tuple[int, int, int]) -> Table:
    """The table of ``path`` as it was at ``stamp`` (inode, size, mtime), read once per
    process and file version: a run asks for each radar's T'_a a dozen times (the scene's
    table keys, the build estimates, the dwell model's preparation), a file read and CRC
    check each (~1 ms) before issue 27. A missing or damaged table raises
    :class:`_NotCached` (not remembered: asked, and warned about, again)."""
    table = load_cached(name, version, dict(inputs))
    if table is None:
        raise _NotCached(path)
    return table


def _read_cached(inputs: dict[str, Any], name: str = TABLE_NAME,
                 version: int = TABLE_VERSION) -> Table | None:
    """The cached table of these inputs (None: not in the cache, or damaged: then warned
    about by :func:`load_cached`), read once per process and file version."""
    path = _table_path(name, version, inputs)
    try:
        st = path.stat()
    except OSError:
        return None
    try:
        return _load_version(name, version, tuple(inputs.items()), path,
                             (st.st_ino, st.st_size, st.st_mtime_ns))
    except _NotCached:
        return None


def sky_temperature_table(args: dict[str, Any], store: bool = True) -> Table:
    """T'_a [K] at the beam maximum of :func:`sky_temperature_args`, from the store or built.

    A 1-D table over elevation [rad] whose first node is ``args["elevation_rad"]``, computed
    there by exactly the call :func:`radar_constants` makes (one scalar call per node, so the
    stored number is the same float).  ``store=False`` reads the store but does not write it.
    """
    inputs = {**{k: float(v) for k, v in args.items()}, **itur_versions()}
    el0 = float(args["elevation_rad"])
    elevations = np.array([el0, el0 + SECOND_NODE_ABOVE_RAD])

    def build() -> Table:
        values = np.array([float(noise.sky_temperature_k(**{**args, "elevation_rad": e}))
                           for e in (el0, float(elevations[1]))])
        return Table(name=TABLE_NAME, version=TABLE_VERSION, axes=(elevations,),
                     axis_names=("elevation_rad",), axis_units=("rad",), values=values,
                     value_name="sky_temperature_k", value_unit="K", inputs=inputs)

    table = _read_cached(inputs)
    if table is None:
        table = build()
        if store:
            table.save(cache_path(TABLE_NAME, table.key))
    return table


def scene_radar_constants(scenario: Scenario, radar: Radar, *,
                          store: bool = True) -> RadarConstants:
    """:func:`radar_constants` with its sky temperature read from the table store.

    A radar with a declared antenna temperature needs no sky model: nothing is read.
    ``store=False`` (the build estimates, which must not write the cache) computes a
    missing sky temperature without keeping it.
    """
    if radar.antenna_temperature_k is not None:
        return radar_constants(scenario, radar)
    args = sky_temperature_args(scenario, radar)
    t_sky = float(sky_temperature_table(args, store).values[0])
    return radar_constants(scenario, radar, sky_temperature_k=t_sky)


def rain_attenuation_db_per_km(freq_hz: float, rain_rate_mm_h: float, polarization: str,
                               store: bool = True) -> float:
    """γ_R [dB/km] on a horizontal path, from the store or computed and kept there.

    The number :func:`shipradar.sensors.atmosphere.rain_specific_attenuation_db_per_km`
    returns for ``(freq_hz, rain_rate_mm_h, polarization)`` (elevation 0), computed by exactly
    that call, so the stored float is the same; kept as a 1-D table over the rain rate whose
    first node is ``rain_rate_mm_h``.  ``store=False`` reads the store but does not write it.
    """
    rate = float(rain_rate_mm_h)
    inputs = {"freq_hz": float(freq_hz), "rain_rate_mm_h": rate,
              "polarization": str(polarization), **itur_versions()}
    table = _read_cached(inputs, RAIN_TABLE_NAME, RAIN_TABLE_VERSION)
    if table is None:
        from shipradar.sensors.atmosphere import rain_specific_attenuation_db_per_km

        rates = np.array([rate, rate + RAIN_SECOND_NODE_ABOVE_MM_H])
        values = np.array([float(rain_specific_attenuation_db_per_km(freq_hz, r, polarization))
                           for r in rates])
        table = Table(name=RAIN_TABLE_NAME, version=RAIN_TABLE_VERSION, axes=(rates,),
                      axis_names=("rain_rate_mm_h",), axis_units=("mm/h",), values=values,
                      value_name="rain_specific_attenuation_db_per_km", value_unit="dB/km",
                      inputs=inputs)
        if store:
            table.save(cache_path(RAIN_TABLE_NAME, table.key))
    return float(table.values[0])
