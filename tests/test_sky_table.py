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


def test_rain_attenuation_is_itur_and_kept(table_cache):
    """γ_R from the store is the very float the direct P.838 call gives; the second call
    reads the store (a stored value is what comes back, whatever the model would say), and
    store=False writes nothing."""
    from shipradar.sensors.atmosphere import rain_specific_attenuation_db_per_km

    direct = float(rain_specific_attenuation_db_per_km(5.6e9, 8.0, "H"))
    assert sky.rain_attenuation_db_per_km(5.6e9, 8.0, "H", store=False) == direct
    assert not list(table_cache.glob(f"{sky.RAIN_TABLE_NAME}-*"))
    assert sky.rain_attenuation_db_per_km(5.6e9, 8.0, "H") == direct
    (path,) = table_cache.glob(f"{sky.RAIN_TABLE_NAME}-*")
    kept = Table.load(path)
    # P.838-3's H rows at 5 and 6 GHz (k 2.162e-4, α 1.6969; k 7.056e-4, α 1.5900) give
    # 0.0074 and 0.0193 dB/km at 8 mm/h: 5.6 GHz lies between
    assert 0.2162e-3 * 8**1.6969 < kept.values[0] < 0.7056e-3 * 8**1.5900
    kept.values[0] = 0.125  # the store is read, not the model
    kept.save(path)
    sky._load_version.cache_clear()
    assert sky.rain_attenuation_db_per_km(5.6e9, 8.0, "H") == 0.125
    assert sky.rain_attenuation_db_per_km(5.6e9, 0.0, "H") == 0.0  # no rain, no loss
