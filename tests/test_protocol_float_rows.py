"""protocol.float_rows: the items of many payloads that differ only in their float leaves,
packed at once, are payload_items of each payload, byte for byte."""

from __future__ import annotations

import numpy as np
import pytest

from shipradar.sim.stream import protocol


def _filled(value, floats):
    """``value`` with its float leaves replaced, in packing order, by ``floats`` (an
    iterator)."""
    if type(value) is float:
        return next(floats)
    if isinstance(value, dict):
        return {k: _filled(v, floats) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_filled(v, floats) for v in value]
    return value


def _leaves(value):
    """The float leaves of ``value``, in packing order."""
    if type(value) is float:
        yield value
    elif isinstance(value, dict):
        for v in value.values():
            yield from _leaves(v)
    elif isinstance(value, (list, tuple)):
        for v in value:
            yield from _leaves(v)


TEMPLATES = [
    {"position": {"lat_deg": 1.0, "lon_deg": 2.0, "alt_m": 3.0, "east_m": 4.0,
                  "north_m": 5.0, "up_m": 6.0},
     "velocity_enu_mps": [1.0, 2.0, 3.0], "heading_deg": 7.0},
    {"time_s": 0.0},
    # non-float values stay the template's: str, int (fix and wide), bool, None, tuple
    {"sensor": "radar-1", "scan": 300, "n": 5, "x": 1.5, "ok": True, "none": None,
     "pair": (2.5, "b", -7), "deep": {"a": [{"b": 0.25}, 3]}, "z": -1.0},
]


@pytest.mark.parametrize("template", TEMPLATES)
def test_rows_are_payload_items_of_each_payload(template):
    marks: list[float] = []
    protocol._float_marks(template, marks)
    leaves = list(_leaves(template))
    rng = np.random.default_rng(len(leaves))
    n = 41
    columns = [rng.normal(0.0, 1e3, n) for _ in leaves]
    special = [np.nan, -0.0, 0.0, np.inf, -np.inf, 5e-324, -2.2250738585072014e-308,
               1.7976931348623157e308, float.fromhex("0x1.fffffffffffffp-1")]
    for i, c in enumerate(columns):
        c[i % n: i % n + len(special)] = special[: n - i % n]
    columns[0][-1] = marks[0]  # a value that is one of the marks: still its own bytes
    got = protocol.float_rows(protocol.TOPIC_EOS, template, columns)
    assert len(got) == n
    for j in range(n):
        want = protocol.payload_items(protocol.TOPIC_EOS,
                                      _filled(template, iter([c[j].item() for c in columns])))
        assert got[j] == want


def test_no_rows_and_wrong_columns():
    assert protocol.float_rows(protocol.TOPIC_EOS, {"time_s": 0.0}, [np.zeros(0)]) == []
    with pytest.raises(protocol.ProtocolError, match="float leaves"):
        protocol.float_rows(protocol.TOPIC_EOS, {"time_s": 0.0}, [np.zeros(2), np.zeros(2)])
    with pytest.raises(protocol.ProtocolError, match="one length"):
        protocol.float_rows(protocol.TOPIC_EOS, {"a": 0.0, "b": 1.0}, [np.zeros(2), np.zeros(3)])


def test_a_mark_in_the_template_falls_back_to_each_payload():
    marks: list[float] = []
    protocol._float_marks({"a": 0.0}, marks)
    # the mark's bytes inside a bytes value: the places of the floats are found otherwise
    template = {"blob": b"\xcb" + np.float64(marks[0]).astype(">f8").tobytes(), "a": 0.0}
    got = protocol.float_rows(protocol.TOPIC_EOS, template, [np.array([1.0, np.nan])])
    assert got == [protocol.payload_items(protocol.TOPIC_EOS, {**template, "a": v})
                   for v in (1.0, np.nan)]


def test_flat_items_are_encodes_items_or_none():
    # a message's fixed part packed without encode(): its bytes, or None when encode() must
    # pack it (a key or string not packed before, other value types)
    protocol.encode(protocol.TOPIC_PLOTS, 0.0, {"sensor": "r-1", "scan": 1, "kind": "plots"})
    for payload in ({"sensor": "r-1", "scan": 0}, {"sensor": "r-1", "scan": 127, "kind": "plots"},
                    {"scan": 3, "x": 1.5}, {"x": float("nan"), "y": -0.0}, {}):
        flat = protocol._flat_items(payload)
        want = protocol.payload_items(protocol.TOPIC_PLOTS, payload)
        assert flat is None or flat == want
        if payload and all(k in ("sensor", "scan", "kind") for k in payload):
            assert flat == want
    for payload in ({"sensor": "never-packed-id", "scan": 1}, {"scan": 128}, {"scan": -1},
                    {"scan": True}, {"sensor": None}, {"never_packed_key": 1},
                    {"scan": [1, 2]}):
        assert protocol._flat_items(payload) is None
