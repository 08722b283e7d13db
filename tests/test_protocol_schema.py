"""The stream's schema (shipradar.sim.stream.schema) against the protocol document, the
engine's messages and the framing of sectors."""

from __future__ import annotations

import re

import numpy as np
import pytest

from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream import framing, protocol, schema
from shipradar.sim.stream.sink import MemorySink
from shipradar.sim.world.scenario import load_scenario
from tests.helpers import ROOT

DOC = ROOT / "docs/protocol.md"
_ROW = re.compile(r"^\| `([^`]+)` \| ([^|]+?) \|\s*([^|]*?)\s*\| (.+) \|$")


def _doc_tables() -> list[list[tuple[str, str, str, str]]]:
    text = DOC.read_text(encoding="utf-8")
    tables = []
    for a, b in schema.document_tables(text):
        rows = text[a:b].splitlines()
        assert rows[0] == "| key | type | unit | meaning |", rows[0]
        parsed = []
        for row in rows[2:]:
            m = _ROW.match(row)
            assert m, f"not one key per row: {row}"
            parsed.append(m.groups())
        tables.append(parsed)
    return tables


def test_every_section_4_table_is_a_payload_of_the_schema():
    tables = _doc_tables()
    assert len(tables) == len(schema.PAYLOADS)
    for rows, payload in zip(tables, schema.PAYLOADS, strict=True):
        doc_keys = [r[0] for r in rows]
        assert set(doc_keys) - set(payload.keys) == set(), f"{payload.name}: only in the doc"
        assert set(payload.keys) - set(doc_keys) == set(), f"{payload.name}: only in schema"
        assert doc_keys == list(payload.keys), f"{payload.name}: order"
        for key, type_, unit, meaning in rows:
            f = payload[key]
            assert (type_, unit.strip(), meaning) == (f.type, f.unit, f.meaning), key


def test_document_tables_are_generated_from_the_schema():
    text = DOC.read_text(encoding="utf-8")
    assert schema.write_document_tables(text) == text


def test_columns_have_numpy_dtypes():
    assert schema.PLOTS["range_m"].dtype == np.float64
    assert schema.PLOTS["interference"].dtype == np.uint8
    assert schema.TRUTH_PLOTS["contrib_offsets"].length == "n+1"
    assert schema.TRUTH_TARGETS["active"].dtype == np.bool_
    assert schema.EOS["position"].dtype is None
    assert "plot_id" not in schema.PLOT_COLUMNS
    assert schema.PLOT_TRUTH_COLUMNS == ("origin", "target", "true_range_m", "true_azimuth_rad",
                                         "true_range_rate_mps")


def test_message_orders_and_refuses():
    msg = schema.EOS.message(heading_deg=1.0, sensor="a", scan=0, time_s=2.0, position={},
                             velocity_enu_mps=[0.0, 0.0, 0.0], complete=True)
    assert list(msg) == list(schema.EOS.keys)
    with pytest.raises(schema.SchemaError, match="lacks"):
        schema.EOS.message(sensor="a")
    with pytest.raises(schema.SchemaError, match="no key"):
        schema.EOS.message(**msg, speed=3.0)
    with pytest.raises(schema.SchemaError):
        schema.PLOTS.keys_of("range_m", "rng_m")


@pytest.mark.parametrize("name", ["single_missile", "raid"])
def test_engine_messages_follow_the_schema(name):
    """Every message of a run: its payload's keys in the schema's order, columns of the
    declared dtypes (a Doppler-bank radar with clutter false alarms; two radars)."""
    s = load_scenario(ROOT / f"scenarios/{name}.yaml")
    bus = MemorySink()
    Simulation(s, bus=bus, duration_s=8.0, seed=1).run()
    kinds = {(p.topic, p.kind): p for p in schema.PAYLOADS}
    seen = set()
    for topic, _, payload in bus.messages:
        p = kinds[(topic, payload.get("kind") if topic == b"truth" else None)]
        p.check(payload)
        seen.add(p.name)
        # and the same once encoded and decoded
        _, _, back = protocol.decode(protocol.encode(topic, 0.0, payload))
        p.check(back)
    assert seen == {"meta", "plots", "eos", "end", "truth[plots]", "truth[targets]"}


def test_framed_payloads_are_the_framed_bodies():
    rng = np.random.default_rng(3)
    n = 40
    plots = {c: rng.normal(size=n) for c in schema.PLOT_COLUMNS}
    plots["interference"] = rng.integers(0, 3, n).astype(np.uint8)
    plots["origin"] = rng.integers(0, 3, n).astype(np.uint8)
    plots["target"] = rng.integers(-1, 5, n).astype(np.int32)
    for c in ("true_range_m", "true_azimuth_rad", "true_range_rate_mps"):
        plots[c] = rng.normal(size=n)
    counts = rng.integers(0, 3, n)
    plots["contrib_offsets"] = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    plots["contrib_targets"] = rng.integers(0, 5, int(counts.sum())).astype(np.int32)
    start = np.array([0, 5, 17, 30])
    stop = np.array([5, 17, 30, 40])
    which = np.array([0, 0, 1, 1])
    p, t = framing.sector_columns("r", [4, 5], plots, np.arange(100, 100 + n), start, stop,
                                  which)
    times = np.array([1.0, 2.0, 3.0, 4.0])
    for msgs, payload in ((p, schema.PLOTS), (t, schema.TRUTH_PLOTS)):
        bodies = msgs.encode(times)
        for j in range(len(msgs)):
            message = msgs.message(j)
            payload.check(message)
            assert protocol.encode(payload.topic, times[j], message)[1] == bodies[j]
    truth = t.message(1)
    assert truth["contrib_offsets"][0] == 0 and truth["scan"] == 4
    off = plots["contrib_offsets"]
    assert np.array_equal(truth["contrib_targets"], plots["contrib_targets"][off[5]:off[17]])
