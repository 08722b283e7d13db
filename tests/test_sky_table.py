"""The sky temperature kept in the table store (issue 27): read once per process and file.

A run asks for each radar's T'_a a dozen times (the scene's table keys, the build estimates,
the dwell model); the file is read and CRC-checked once, and again only when it is replaced.
"""

from __future__ import annotations

import numpy as np

from shipradar.tables import sky
from shipradar.tables.atmosphere import itur_versions
from shipradar.tables.store import Table, cache_path

#: Arguments of noise.sky_temperature_k; the tests store the table, nothing computes it.
ARGS = {"freq_hz": 3.0e9, "elevation_rad": 0.01, "surface_temperature_k": 288.15,
        "pressure_hpa": 1013.25, "water_vapour_density_g_m3": 7.5, "antenna_height_m": 20.0}


def _store(t_sky: float) -> None:
    inputs = {**ARGS, **itur_versions()}
    el0 = ARGS["elevation_rad"]
    table = Table(name=sky.TABLE_NAME, version=sky.TABLE_VERSION,
                  axes=(np.array([el0, el0 + sky.SECOND_NODE_ABOVE_RAD]),),
                  axis_names=("elevation_rad",), axis_units=("rad",),
                  values=np.array([t_sky, 0.5 * t_sky]), value_name="sky_temperature_k",
                  value_unit="K", inputs=inputs)
    table.save(cache_path(table.name, table.key))


def test_the_sky_table_is_read_once_per_file_version(table_cache, monkeypatch):
    _store(123.0)
    reads = []
    load = sky.load_cached

    def counted(*a, **k):
        reads.append(1)
        return load(*a, **k)

    monkeypatch.setattr(sky, "load_cached", counted)
    for store in (True, False, True):
        assert sky.sky_temperature_table(dict(ARGS), store).values[0] == 123.0
    assert len(reads) == 1
    _store(124.0)  # replaced (a new file: another inode and time)
    assert sky.sky_temperature_table(dict(ARGS)).values[0] == 124.0
    assert len(reads) == 2
