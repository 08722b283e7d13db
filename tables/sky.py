"""The sky temperature of a radar, kept in the table store, and the radar constants built on it.

:func:`shipradar.sensors.radar.radar_constants` needs T'_a, the sky noise temperature at the
beam maximum ([18], ITU-R P.372 radiative transfer through P.676 gaseous absorption).  Computing
it imports itur (which imports astropy, scipy.stats and scipy.interpolate: 0.3-0.6 s) and runs
a nested quadrature, on every run, for the same few numbers.  The store keeps them under the
hash of their inputs like any table (issue 27): a run that finds them never imports itur.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from shipradar.sensors import noise
from shipradar.sensors.radar import RadarConstants, radar_constants, sky_temperature_args
from shipradar.sim.world.scenario import Radar, Scenario
from shipradar.tables.atmosphere import itur_versions
from shipradar.tables.store import Table, cache_path, inputs_hash, load_cached

#: Table builder name and version (bump on any change of :func:`noise.sky_temperature_k`).
TABLE_NAME = "sky_temperature"
TABLE_VERSION = 1
#: The table's second elevation node above the beam maximum [rad] (a table axis has two
#: nodes at least; only the first, the beam maximum, is read).
SECOND_NODE_ABOVE_RAD = 0.5

#: The tables read in this process, by file, with the (inode, size, mtime) they were read at:
#: a run asks for each radar's T'_a a dozen times (the scene's table keys, the build
#: estimates, the dwell model), a file read and CRC check each (~1 ms) before issue 27.
_READ: dict[Path, tuple[tuple[int, int, int], Table]] = {}


def _read_cached(inputs: dict[str, Any]) -> Table | None:
    """The cached table of these inputs (None: not in the cache, or damaged: then warned
    about by :func:`load_cached`), read once per process and file version."""
    path = cache_path(TABLE_NAME, inputs_hash(TABLE_NAME, TABLE_VERSION, inputs))
    try:
        st = path.stat()
    except OSError:
        return None
    stamp = (st.st_ino, st.st_size, st.st_mtime_ns)
    seen = _READ.get(path)
    if seen is not None and seen[0] == stamp:
        return seen[1]
    table = load_cached(TABLE_NAME, TABLE_VERSION, inputs)
    if table is not None:
        _READ[path] = (stamp, table)
    return table


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
