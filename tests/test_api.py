"""The public API of ``import shipradar``: the README's example as written, and the in-process
run (callback and iterator) against the stream a recording holds."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import shipradar

README = Path(__file__).resolve().parents[1] / "README.md"


def _readme_example() -> str:
    text = README.read_text(encoding="utf-8")
    section = text.split("## As a library", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_readme_library_example_runs_as_written(table_cache, capsys):
    exec(compile(_readme_example(), "README.md", "exec"), {})
    printed = capsys.readouterr().out.split()
    assert float(printed[0]) == pytest.approx(0.9, abs=0.002)
    assert float(printed[1]) == pytest.approx(21.14, abs=0.05)


def test_promised_names_resolve_and_version_comes_from_metadata():
    from importlib.metadata import version

    assert shipradar.__version__ == version("shipradar")
    for name in shipradar.__all__:
        assert getattr(shipradar, name) is not None
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        shipradar.nope  # noqa: B018


def test_callback_iterator_and_recording_carry_the_same_messages(table_cache, tmp_path):
    """run(on_message=...) and messages(...) give the messages a recorded run writes, in
    order, with equal payloads (the recording decoded)."""
    from shipradar.sim.engine.simulation import Simulation
    from shipradar.sim.stream.bus import Bus
    from shipradar.sim.stream.recording import Recorder

    scenario = shipradar.example("single_missile")
    tables = shipradar.build_tables(scenario)
    got = []
    summary = shipradar.run(scenario, tables=tables, duration_s=6,
                            on_message=lambda *m: got.append(m))
    iterated = list(shipradar.messages(scenario, tables=tables, duration_s=6))
    path = tmp_path / "run.rec"
    bus = Bus(None, Recorder(path))
    Simulation(scenario, bus=bus, duration_s=6, tables=tables).run()
    bus.close()
    with shipradar.read_recording(path) as reader:
        recorded = [shipradar.decode(frames) for _, frames in reader]
    assert summary["scans"] == 6 and summary["dwells"] >= 1
    assert len(got) == len(iterated) == len(recorded) > 12
    for (t1, s1, p1), (t2, s2, p2), (t3, s3, p3) in zip(got, iterated, recorded, strict=True):
        assert t1 == t2 == t3.decode()
        assert s1 == s2 == s3
        payload = {k: v for k, v in p3.items() if k not in ("v", "t")}
        _assert_same(p1, payload)
        _assert_same(p2, payload)


def _assert_same(mine, recorded):
    """Equal content: arrays element-wise, mappings and sequences recursively (msgpack
    turns tuples into lists)."""
    if isinstance(recorded, np.ndarray):
        np.testing.assert_array_equal(np.asarray(mine), recorded)
    elif isinstance(recorded, dict):
        assert set(mine) == set(recorded)
        for key in recorded:
            _assert_same(mine[key], recorded[key])
    elif isinstance(recorded, list):
        assert len(mine) == len(recorded)
        for a, b in zip(mine, recorded, strict=True):
            _assert_same(a, b)
    else:
        assert mine == recorded


def test_iterator_stops_the_run_when_the_consumer_stops(table_cache):
    scenario = shipradar.example("single_missile")
    tables = shipradar.build_tables(scenario)
    it = shipradar.messages(scenario, tables=tables)
    first = [next(it) for _ in range(3)]
    it.close()  # a consumer that breaks out early: no further step is computed
    assert first[0][0] == "meta" and first[0][1] == 0.0
