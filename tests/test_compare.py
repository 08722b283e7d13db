"""sim.stream.compare: two streams compared by value find what changed, where, and by how much.

The streams are a golden recording's messages and copies changed by hand by a known amount, so
the expected answer (message, key, relative difference) is known independently of the code.
"""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest

from shipradar.sim.stream.compare import (
    compare_streams,
    plot_ids,
    recording_messages,
    relative_difference,
)
from tests.golden.cases import CASES

GOLDEN = CASES[1].file  # manoeuvres: target plots with Doppler, and false alarms


@pytest.fixture(scope="module")
def stream():
    return list(recording_messages(GOLDEN))


def _first_plots(stream, at_least=2):
    return next(i for i, (t, _, p) in enumerate(stream)
                if t == "plots" and len(p["plot_id"]) >= at_least)


def _changed(stream, index, key, j, factor):
    other = copy.deepcopy(stream)
    topic, t, payload = other[index]
    column = np.array(payload[key])
    column[j] *= factor
    payload = dict(payload, **{key: column})
    other[index] = (topic, t, payload)
    return other


def test_a_stream_equals_itself_with_no_difference(stream):
    result = compare_streams(stream, stream, rtol=0.0)
    assert result.equal
    assert result.messages == len(stream)
    assert result.max_rel == 0.0


@pytest.mark.parametrize("rel", [1e-12, 1e-3])
def test_a_range_moved_by_a_known_fraction_is_found_with_its_size(stream, rel):
    i = _first_plots(stream)
    other = _changed(stream, i, "range_m", 1, 1.0 + rel)
    loose = compare_streams(stream, other, rtol=1e-6)
    assert loose.max_rel == pytest.approx(rel / (1.0 + rel), rel=1e-3)
    assert loose.worst == f"message {i}, plots.range_m[1]"
    if rel < 1e-6:
        assert loose.equal
        assert loose.by_key == {"plots.range_m": loose.max_rel}
    else:
        assert loose.first is not None
        assert (loose.first.index, loose.first.where, loose.first.kind) == (i, "range_m[1]",
                                                                            "value")
        assert loose.first.rel == pytest.approx(rel / (1.0 + rel), rel=1e-3)
        assert loose.messages == i + 1
        assert "range_m[1]" in str(loose) and "relative difference 0.000999" in str(loose)


def test_a_missing_plot_is_a_difference_of_structure(stream):
    i = _first_plots(stream)
    other = copy.deepcopy(stream)
    topic, t, payload = other[i]
    other[i] = (topic, t, {k: (v[1:] if isinstance(v, np.ndarray) else v)
                           for k, v in payload.items()})
    result = compare_streams(stream, other, rtol=1.0)
    assert result.first is not None
    assert (result.first.index, result.first.kind) == (i, "structure")
    assert result.first.where == "plot_id"
    assert len(plot_ids(other)) == len(plot_ids(stream)) - 1


def test_another_plot_id_or_origin_is_a_difference_whatever_the_tolerance(stream):
    i = _first_plots(stream)
    other = copy.deepcopy(stream)
    topic, t, payload = other[i]
    ids = np.array(payload["plot_id"])
    ids[0] += 1
    other[i] = (topic, t, dict(payload, plot_id=ids))
    result = compare_streams(stream, other, rtol=math.inf)
    assert result.first is not None and result.first.where == "plot_id[0]"
    truth = next(j for j, (t, _, p) in enumerate(stream) if t == "truth" and p["kind"] == "plots")
    other = copy.deepcopy(stream)
    topic, t, payload = other[truth]
    origin = np.array(payload["origin"])
    origin[0] = (origin[0] + 1) % 3
    other[truth] = (topic, t, dict(payload, origin=origin))
    result = compare_streams(stream, other, rtol=math.inf)
    assert result.first is not None and result.first.where == "origin[0]"


def test_a_stream_cut_short_differs_at_its_end(stream):
    result = compare_streams(stream, stream[:-3], rtol=1.0)
    assert result.first is not None
    assert result.first.index == len(stream) - 3
    assert "(no message)" in result.first.detail


def test_relative_difference_at_the_edges():
    a = np.array([1.0, 0.0, np.nan, np.inf, -np.inf, 2.0, np.nan, 1.0, -1.0])
    b = np.array([1.0, 0.0, np.nan, np.inf, np.inf, 1.0, 1.0, np.inf, 1.0])
    np.testing.assert_array_equal(relative_difference(a, b),
                                  [0.0, 0.0, 0.0, 0.0, np.inf, 0.5, np.inf, np.inf, 2.0])


def test_levels_in_db_differ_by_the_powers_they_stand_for():
    a = np.array([0.0, 10.0, -200.0, -np.inf, 30.0])
    b = np.array([10.0, 10.0 * np.log10(2.0), -199.5, -np.inf, np.inf])
    expected = [0.9, 0.8, 1.0 - 10.0 ** -0.05, 0.0, np.inf]
    np.testing.assert_allclose(relative_difference(a, b, db=True), expected, rtol=1e-9)


def test_an_snr_near_0_db_is_compared_as_a_power(stream):
    i = _first_plots(stream)
    other = copy.deepcopy(stream)
    topic, t, payload = other[i]
    snr = np.array(payload["snr_db"])
    snr[0] += 1e-7  # a relative power change of 2.3e-8, whatever snr_db itself is
    other[i] = (topic, t, dict(payload, snr_db=snr))
    result = compare_streams(stream, other, rtol=1e-6)
    assert result.equal
    assert result.by_key["plots.snr_db"] == pytest.approx(1e-7 * math.log(10.0) / 10.0,
                                                          rel=1e-6)


def test_the_command_line_compares_two_recordings(tmp_path, capsys):
    from shipradar.sim.cli import main

    same = tmp_path / "same.rec"
    same.write_bytes(GOLDEN.read_bytes())
    assert main(["recording", "compare", str(GOLDEN), str(same)]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["same_bytes"] and report["equal"] and report["first_difference"] is None
    other = CASES[0].file  # another scene: its meta differs from the first message
    assert main(["recording", "compare", str(GOLDEN), str(other), "--rtol", "1"]) == 1
    out = capsys.readouterr()
    report = json.loads(out.out)
    assert not report["equal"] and report["first_difference"]["message"] == 0
    assert report["first_difference"]["kind"] == "structure"
    assert "message 0 (meta at t=0.0 s) differs" in out.err
    assert main(["recording", "compare", str(GOLDEN), str(tmp_path / "nope.rec")]) == 2
    assert main(["recording", "compare", str(GOLDEN), str(same), "--rtol", "-1"]) == 2
    assert "--rtol must be >= 0, got -1.0" in capsys.readouterr().err
