"""The names of the ``plots`` columns the physics and the dwell produce, one home for each.

:data:`shipradar.sim.stream.schema.PLOTS` declares these columns (type, unit, meaning) by
these names; the producers (:mod:`shipradar.sensors.measurement`,
:mod:`shipradar.sensors.false_alarms`, :mod:`shipradar.sim.dwell.model`,
:mod:`shipradar.sim.dwell.false_alarm_model`) write them by the same names. The names live
here, below the stream, because the layers forbid the physics and the dwell to import it
(tests/test_layers.py).
"""

from __future__ import annotations

TIME_S = "time_s"
RANGE_M = "range_m"
AZIMUTH_RAD = "azimuth_rad"
SNR_DB = "snr_db"
SIGMA_RANGE_M = "sigma_range_m"
SIGMA_AZIMUTH_RAD = "sigma_azimuth_rad"
INTERFERENCE = "interference"
RANGE_RATE_MPS = "range_rate_mps"
SIGMA_RANGE_RATE_MPS = "sigma_range_rate_mps"
RANGE_RATE_REFERENCE_MPS = "range_rate_reference_mps"
