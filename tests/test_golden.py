"""Golden recordings rerun and compared by value (issue 34; tests/golden/README.md).

Each case of ``tests/golden/cases.py`` is run again with the command line and compared with
its committed recording message by message: the same messages (topics, times, keys, shapes,
dtypes), the same plot ids, origins, targets, scans and every other integer and text, and
every float within ``RTOL``; on the golden files' own install and CPU (the lock's, recorded in
``made_with.json``) the bytes must be equal too. A deliberate change of the stream
regenerates them with ``make golden``.
"""

from __future__ import annotations

import pytest

from shipradar.sim.stream.compare import compare_recordings, plot_ids, recording_messages
from tests.golden.cases import CASES, RTOL, Case, bytes_expected, record

REGENERATE = ("if the change of the stream is deliberate, regenerate: make golden "
              "(tests/golden/README.md)")


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.scene)
def test_a_golden_run_gives_the_same_messages_within_the_tolerance(case: Case, tmp_path):
    out = tmp_path / case.file.name
    record(case, out)
    result = compare_recordings(case.file, out, rtol=RTOL)
    assert result.equal, f"{case.scene}: {result}; {REGENERATE}"
    same_install, why = bytes_expected()
    if same_install:
        assert out.read_bytes() == case.file.read_bytes(), (
            f"{case.scene}: on the golden files' own install the bytes differ although every "
            f"value is within rtol={RTOL:g} ({result}); {REGENERATE}")
    else:
        print(f"{case.scene}: values compared, bytes not required ({why})")


def test_the_golden_runs_hold_target_plots_and_false_alarms():
    """The cases exercise what they are there for: detections of targets and false alarms."""
    origins = set()
    for case in CASES:
        for topic, _, payload in recording_messages(case.file):
            if topic == "truth" and payload["kind"] == "plots":
                origins.update(int(o) for o in payload["origin"])
    assert origins == {0, 1, 2}
    assert all(plot_ids(recording_messages(c.file)) for c in CASES)
