"""Per-process memos of a run's construction (issue 27, sparse scenes): the same numbers and
paths as the uncached calls."""

from __future__ import annotations

import math

import pytest

from shipradar.sensors import detection
from shipradar.sensors.radar import false_alarm_probability
from shipradar.sim.world.scenario import load_scenario
from shipradar.tables import sky
from shipradar.tables.store import cache_path, inputs_hash

SCENES = ["scenarios/single_missile.yaml", "scenarios/raid.yaml", "scenarios/stress.yaml"]


@pytest.mark.parametrize("scene", SCENES)
def test_false_alarm_probability_is_the_uncached_number(scene):
    for _, radar in load_scenario(scene).radars():
        want = float(detection.pfa_from_false_alarm_time(
            radar.false_alarm_time_s, math.radians(radar.beamwidth_az_deg),
            radar.scan_period_s, radar.prf_hz, radar.pulse_width_s,
            n_channels=radar.n_channels, instrumented_range_m=radar.instrumented_range_m))
        for _ in range(2):  # computed, then remembered
            assert false_alarm_probability(radar) == want
        other = radar.model_copy(update={"false_alarm_time_s": 2.0 * radar.false_alarm_time_s})
        assert false_alarm_probability(other) == pytest.approx(0.5 * want, rel=1e-12)


def test_table_path_follows_the_cache_directory(tmp_path, monkeypatch):
    inputs = {"freq_hz": 9.4e9, "elevation_rad": 0.01, "polarization": "H"}
    for root in (tmp_path / "a", tmp_path / "b"):
        monkeypatch.setenv("SHIPRADAR_TABLES", str(root))
        want = cache_path("sky_temperature", inputs_hash("sky_temperature", 1, inputs))
        assert want.parent == root
        assert sky._table_path("sky_temperature", 1, inputs) == want
        assert sky._table_path("sky_temperature", 1, dict(inputs)) == want
    assert sky._table_path("sky_temperature", 2, inputs) == cache_path(
        "sky_temperature", inputs_hash("sky_temperature", 2, inputs))
