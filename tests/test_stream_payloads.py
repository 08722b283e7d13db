"""The stream's non-sector messages (:mod:`shipradar.sim.stream.payloads`): each packed form
gives the bytes of encoding its payload, and the payloads are what the schema declares."""

from __future__ import annotations

import math

import numpy as np
import pytest

from shipradar.sim.stream import protocol
from shipradar.sim.stream.payloads import (
    AntennaState,
    AntennaStates,
    ClutterFalseAlarmMeta,
    PackedMeta,
    SensorDescription,
    SensorTruthRows,
    end_of_scan_frames,
    end_payload,
    entities_payload,
    eos_payload,
    meta_payload,
    pack_meta,
    truth_sensors_frames,
    truth_sensors_items,
    truth_sensors_payload,
)
from shipradar.sim.stream.schema import END, ENTITIES, EOS, META, TRUTH_SENSORS


def _states(rng: np.random.Generator, m: int) -> AntennaStates:
    return AntennaStates(rng.uniform(-80, 80, m), rng.uniform(-180, 180, m),
                         rng.normal(0, 1e4, m), rng.normal(0, 1e4, m), rng.uniform(0, 40, m),
                         rng.normal(0, 10, (m, 3)), rng.uniform(0, 360, m))


def _row(s: AntennaStates, j: int) -> AntennaState:
    v = s.velocity_enu_mps[j]
    return AntennaState(float(s.lat_deg[j]), float(s.lon_deg[j]), float(s.east_m[j]),
                        float(s.north_m[j]), float(s.up_m[j]),
                        (float(v[0]), float(v[1]), float(v[2])), float(s.heading_deg[j]))


def _description(clutter: bool, names: bool, span: bool) -> SensorDescription:
    fa = None
    if clutter:
        fa = ClutterFalseAlarmMeta(12.5, np.arange(5.0) * 250.0, np.array([1.0, 2, 3, 4]),
                                   (np.arange(3.0), np.linspace(0, 2 * math.pi, 4),
                                    np.ones((2, 3))))
    return SensorDescription(
        sensor="r1", platform="ship", radar={"peak_power_w": 1e6}, scan_period_s=4.0,
        sectors_per_scan=8, sector_s=0.5, pfa=1e-6, noise_false_alarms_per_scan=0.3,
        clutter=fa, target_ids=["a", "b"], target_names=["A", "B"] if names else None,
        origin_codes=("target", "noise"), interference_codes=("noise",),
        origin={"lat_deg": 1.0, "lon_deg": 2.0, "alt_m": 0.0}, start_time="2020-01-01T00:00:00",
        sac_sic=(1, 2), noise_power_dbm=-100.0, range_rate_span_mps=30.0 if span else None)


@pytest.mark.parametrize("clutter, names, span", [(False, False, False), (True, True, True)])
def test_meta_packed_once_is_the_payload_encoded(clutter, names, span):
    rng = np.random.default_rng(1)
    desc = _description(clutter, names, span)
    states = _states(rng, 3)
    packed = pack_meta(desc, 0, _row(states, 0))
    for scan in range(3):
        state = _row(states, scan)
        payload = meta_payload(desc, scan, state)
        META.check(payload)
        assert ("target_names" in payload) is names
        assert ("clutter_false_alarm_density" in payload) is clutter
        assert ("range_rate_span_mps" in payload) is span
        assert payload["position"]["alt_m"] == payload["position"]["up_m"] == state.up_m
        want = protocol.encode(protocol.TOPIC_META, 7.5, payload)
        assert packed.encode(7.5, PackedMeta.scan_state(scan, state)) == want


@pytest.mark.parametrize("m", [1, 4])
def test_ends_of_scan_packed_at_once_are_each_payload_encoded(m):
    rng = np.random.default_rng(m)
    states = _states(rng, m)
    states.heading_deg[0] = np.nan  # a NaN kept bit for bit
    desc = _description(False, False, False)
    times = np.cumsum(rng.uniform(1, 5, m)).tolist()
    complete = [True] * (m - 1) + [False]
    frames = end_of_scan_frames("r1", 10, times, states, complete)
    meta = pack_meta(desc, 11, _row(states, 0))
    for j, t in enumerate(times):
        payload = eos_payload("r1", 10 + j, t, _row(states, j), complete[j])
        EOS.check(payload)
        assert frames.eos[j] == protocol.encode(protocol.TOPIC_EOS, t, payload)[1]
        # the next scan's meta starts where this one ended
        assert meta.encode(t, frames.next_meta[j]) == protocol.encode(
            protocol.TOPIC_META, t, meta_payload(desc, 11 + j, _row(states, j)))


def test_truth_sensors_packed_at_once_are_each_payload_encoded():
    rng = np.random.default_rng(3)
    m = 3
    keys = [f.key for f in TRUTH_SENSORS.fields][4:12]  # the errors, in the schema's order
    errors = {k: rng.normal(size=m).tolist() for k in keys}
    rows = SensorTruthRows([1.0, 2.0, 3.0], errors, rng.normal(size=m), rng.normal(size=m),
                           rng.normal(size=m), rng.uniform(0, 6, m).tolist())
    items = truth_sensors_items("r1", 4, rows)
    for j, latency in enumerate([0.25, math.nan, 0.0]):
        payload = truth_sensors_payload(
            "r1", 4 + j, rows.time_s[j], {k: v[j] for k, v in errors.items()},
            (float(rows.true_east_m[j]), float(rows.true_north_m[j]),
             float(rows.true_up_m[j])), rows.true_heading_rad[j], latency)
        TRUTH_SENSORS.check(payload)
        assert truth_sensors_frames(items[j], latency, 9.0) == protocol.encode(
            protocol.TOPIC_TRUTH, 9.0, payload)


def test_end_and_entities_payloads_follow_the_schema():
    END.check(end_payload(60.0, ["a", "b"], [15, 6]))
    used = [{"id": ["x"], **{k: np.zeros(1) for k in ENTITIES.columns("n")
                             if ENTITIES[k].required}, "active": np.ones(1, bool),
             "heading_deg": np.array([90.0]), "type": ["ship"]},
            {"id": ["y", "z"], **{k: np.ones(2) for k in ENTITIES.columns("n")
                                  if ENTITIES[k].required}, "active": np.ones(2, bool),
             "a_east_mps2": np.array([1.0, 2.0])}]
    p = entities_payload(used)
    ENTITIES.check(p)
    assert p["id"] == ["x", "y", "z"]
    np.testing.assert_array_equal(p["heading_deg"], [90.0, np.nan, np.nan])
    np.testing.assert_array_equal(p["a_east_mps2"], [0.0, 1.0, 2.0])
    assert p["type"] == ["ship", "", ""] and "name" not in p
