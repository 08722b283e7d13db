"""EUROCONTROL ASTERIX output: CAT048 target reports and CAT034 service messages.

``encode`` builds the bytes (pure, vectorized per sector), ``stream`` turns the shipradar
message stream (``meta``, ``plots``, ``eos``) into data blocks with their times, and ``udp``
owns the socket of ``shipradar run|replay --asterix udp://HOST:PORT``. What each item
carries, from which model quantity and with which quantization: docs/asterix.md.
"""

from shipradar.sim.adapters.asterix.encode import (
    DEFAULT_MAX_BLOCK_BYTES,
    RHO_MAX_NM,
    AsterixError,
    encode_cat034_north_marker,
    encode_cat034_sector_crossings,
    encode_cat048,
    seconds_of_day,
    time_of_day_counts,
)
from shipradar.sim.adapters.asterix.stream import AsterixStream

__all__ = [
    "DEFAULT_MAX_BLOCK_BYTES",
    "RHO_MAX_NM",
    "AsterixError",
    "AsterixStream",
    "encode_cat034_north_marker",
    "encode_cat034_sector_crossings",
    "encode_cat048",
    "seconds_of_day",
    "time_of_day_counts",
]
