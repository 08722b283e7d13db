"""Damaged recordings: resynchronisation, truncation versus damage, verify and repair.

The property: whatever the damage (byte flips, deletions, insertions, a region written
twice, a cut, a zero-filled tail), the reader never raises outside strict mode, yields only
records that were written, in their order, each at most once, and yields every record the
damage did not touch.
"""

from __future__ import annotations

import io
import json
import os
import struct
import zlib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from shipradar.sim.cli import main
from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream.bus import Bus, ReplaySettings, replay
from shipradar.sim.stream.recording import (
    HEADER_BYTES,
    REC2_HEADER_BYTES,
    SYNC,
    Recorder,
    RecordingError,
    RecordingExistsError,
    read_recording,
    repair_recording,
    verify_recording,
)

from .helpers import bare_scene, quiet_radar

_TARGETS = [
    {"id": f"t{i}", "kind": "aircraft", "rcs": {"type": "constant", "sigma_m2": 10.0},
     "waypoints": [{"east_m": 8000.0 + 3000 * i, "north_m": 5000.0 * i, "altitude_m": 300,
                    "time_s": 0}, {"east_m": 9000.0 + 3000 * i, "north_m": 5000.0 * i + 800,
                                   "altitude_m": 300, "time_s": 20}]}
    for i in range(3)
]


def _record(path: Path, compress: str = "none") -> None:
    """A real recording: a short free-space scene with three aircraft."""
    scene = bare_scene(quiet_radar(), targets=_TARGETS, duration_s=6.0, seed=7)
    with Bus(recorder=Recorder(path, compress=compress)) as bus:
        Simulation(scene, bus=bus).run()


@pytest.fixture(scope="module")
def real(tmp_path_factory):
    """(bytes, records, [start, end) of each record) of a real recording."""
    path = tmp_path_factory.mktemp("rec") / "real.srrec"
    _record(path)
    with read_recording(path, strict=True) as reader:
        records = list(reader)
    data = path.read_bytes()
    spans = []
    pos = HEADER_BYTES
    while pos < len(data):
        (n,) = struct.unpack_from("<I", data, pos + 8)
        spans.append((pos, pos + REC2_HEADER_BYTES + n))
        pos += REC2_HEADER_BYTES + n
    assert len(spans) == len(records) > 20
    assert {f[0] for _, f in records} == {b"meta", b"plots", b"truth", b"eos", b"end"}
    return data, records, spans


def _read(data: bytes, tmp_path: Path, *, strict: bool = False):
    path = tmp_path / f"damaged-{os.getpid()}.srrec"
    path.write_bytes(data)
    with read_recording(path, strict=strict) as reader:
        got = list(reader)
    return got, reader


def _check(got, records, intact):
    """got is an in-order, repeat-free subsequence of records that contains every intact one."""
    j = 0
    matched = []
    for item in got:
        while j < len(records) and records[j] != item:
            j += 1
        assert j < len(records), "a record that was never written (or out of order) was yielded"
        matched.append(j)
        j += 1
    missing = set(intact) - set(matched)
    assert not missing, f"intact records not recovered: {sorted(missing)[:10]}"


def _overlapping(spans, a, b):
    """Indices of records whose bytes intersect [a, b) (for b == a: that strictly contain a)."""
    if b == a:
        return {i for i, (s, e) in enumerate(spans) if s < a < e}
    return {i for i, (s, e) in enumerate(spans) if s < b and e > a}


damage = st.one_of(
    st.tuples(st.just("flip"), st.lists(st.tuples(st.floats(0, 1, exclude_max=True),
                                                   st.integers(1, 255)), min_size=1, max_size=4)),
    st.tuples(st.just("delete"), st.floats(0, 1, exclude_max=True), st.integers(1, 300)),
    st.tuples(st.just("insert"), st.floats(0, 1), st.binary(min_size=1, max_size=300)),
    st.tuples(st.just("duplicate"), st.floats(0, 1, exclude_max=True), st.integers(1, 2000)),
    st.tuples(st.just("truncate"), st.floats(0, 1)),
    st.tuples(st.just("zero_tail"), st.floats(0, 1)),
    st.tuples(st.just("zero_block"), st.floats(0, 1, exclude_max=True), st.integers(1, 4096)),
)


def _apply(data: bytes, spans, op) -> tuple[bytes, set[int], bool]:
    """Damaged bytes, indices of the records touched, whether only the tail was touched."""
    kind = op[0]
    n = len(data)
    if kind == "flip":
        buf = bytearray(data)
        touched = set()
        for frac, mask in op[1]:
            p = int(frac * n)
            buf[p] ^= mask
            touched |= _overlapping(spans, p, p + 1)
        return bytes(buf), touched, False
    if kind == "delete":
        a = int(op[1] * n)
        b = min(n, a + op[2])
        return data[:a] + data[b:], _overlapping(spans, a, b), False
    if kind == "insert":
        p = int(op[1] * n)
        return data[:p] + op[2] + data[p:], _overlapping(spans, p, p), False
    if kind == "duplicate":  # a region written twice in a row (a rewritten block)
        a = int(op[1] * n)
        b = min(n, a + op[2])
        return data[:b] + data[a:b] + data[b:], _overlapping(spans, b, b), False
    if kind == "truncate":
        p = int(op[1] * n)
        return data[:p], _overlapping(spans, p, n), True
    if kind == "zero_tail":
        p = int(op[1] * n)
        return data[:p] + bytes(n - p), _overlapping(spans, p, n), True
    a = int(op[1] * n)
    b = min(n, a + op[2])
    return data[:a] + bytes(b - a) + data[b:], _overlapping(spans, a, b), False


@settings(max_examples=300, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(op=damage)
def test_damage_never_raises_never_invents_and_recovers_every_intact_record(real, tmp_path, op):
    data, records, spans = real
    damaged, touched, tail_only = _apply(data, spans, op)
    intact = set(range(len(records))) - touched
    got, reader = _read(damaged, tmp_path)
    _check(got, records, intact)
    assert reader.records == len(got)
    if tail_only:  # a cut or a zero-filled tail is a truncation, never damage
        assert not reader.damaged, reader.damaged
        assert reader.truncated or len(damaged) in {HEADER_BYTES, *(e for _, e in spans)}
    if not touched and op[0] == "flip":  # only the file header was hit
        assert got == records
    # strict mode: stops at the first damage with RecordingError, never anything else
    try:
        strict_got, _ = _read(damaged, tmp_path, strict=True)
    except RecordingError:
        pass
    else:
        _check(strict_got, records, intact)


def test_one_flipped_byte_costs_one_record(real, tmp_path):
    data, records, spans = real
    k = len(spans) // 2
    buf = bytearray(data)
    buf[spans[k][0] + REC2_HEADER_BYTES + 5] ^= 0x40
    got, reader = _read(bytes(buf), tmp_path)
    assert got == records[:k] + records[k + 1:]
    (region,) = reader.damaged
    assert (region.start, region.end, region.records) == (*spans[k], 1)
    assert "CRC" in region.reason and not reader.truncated


def test_flipped_length_is_not_trusted(real, tmp_path):
    data, records, spans = real
    k = 5
    buf = bytearray(data)
    buf[spans[k][0] + 8 + 2] ^= 0x10  # the length: the header CRC catches it
    got, reader = _read(bytes(buf), tmp_path)
    assert got == records[:k] + records[k + 1:]
    assert reader.damaged[0].reason == "record header fails its CRC check"


def test_four_zero_bytes_at_the_tail_are_a_truncation(real, tmp_path):
    data, records, _ = real
    got, reader = _read(data + bytes(4), tmp_path)
    assert got == records and reader.truncated and reader.bytes_ignored == 4
    assert not reader.damaged
    got, reader = _read(data[:-100] + bytes(100), tmp_path)  # last record zero-filled
    assert got == records[:-1] and reader.truncated and not reader.damaged


def test_lost_and_repeated_records_are_counted_exactly(real, tmp_path):
    data, records, spans = real
    s3, e4 = spans[3][0], spans[4][1]
    gone = data[:s3] + data[e4:]  # two whole records cut out cleanly
    got, reader = _read(gone, tmp_path)
    assert got == records[:3] + records[5:]
    assert reader.records_skipped == 2 and reader.bytes_skipped == 0
    twice = data[:e4] + data[s3:e4] + data[e4:]  # two records written again
    got, reader = _read(twice, tmp_path)
    assert got == records
    assert reader.damaged[0].reason.startswith("record #3 repeats")
    assert reader.bytes_skipped == e4 - s3


def test_damaged_file_header_is_recovered(real, tmp_path):
    data, records, _ = real
    buf = bytearray(data)
    buf[0] ^= 0xFF  # the magic
    got, reader = _read(bytes(buf), tmp_path)
    assert got == records and reader.damaged[0].reason == "file header is damaged"
    with pytest.raises(RecordingError, match="header is damaged"):
        _read(bytes(buf), tmp_path, strict=True)


def test_not_a_recording_is_still_refused(tmp_path):
    for content in (b"PK\x03\x04" + bytes(500), os.urandom(5000), SYNC * 3):
        path = tmp_path / "x.bin"
        path.write_bytes(content)
        with pytest.raises(RecordingError, match="not a shipradar recording"):
            read_recording(path)


def test_compressed_recording_damage_is_per_record(tmp_path):
    path = tmp_path / "z.srrec"
    _record(path, compress="zstd")
    with read_recording(path, strict=True) as reader:
        records = list(reader)
    assert reader.compressed
    data = bytearray(path.read_bytes())
    starts = [i for i in range(len(data)) if data.startswith(SYNC, i)]
    k = len(starts) // 2
    data[starts[k] + REC2_HEADER_BYTES + 3] ^= 0x01
    got, reader = _read(bytes(data), tmp_path)
    assert got == records[:k] + records[k + 1:] and reader.records_skipped == 1


# -- verify, repair, replay ------------------------------------------------------------------
def test_verify_reports_clean_truncated_damaged_and_unreadable(real, tmp_path, capsys):
    data, records, spans = real
    clean = tmp_path / "clean.srrec"
    clean.write_bytes(data)
    assert main(["recording", "verify", str(clean)]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["status"] == "clean" and rep["records"] == len(records)
    assert rep["frames"] == 2 * len(records) and rep["sensors"] == ["r1"]
    assert rep["t_first"] == 0.0 and rep["t_last"] == records[-1][0]
    assert rep["records_by_topic"]["eos"] >= 6 and rep["format_version"] == 2

    cut = tmp_path / "cut.srrec"
    cut.write_bytes(data[:-10])
    assert main(["recording", "verify", str(cut)]) == 1
    out = capsys.readouterr()
    rep = json.loads(out.out)
    assert rep["status"] == "truncated" and rep["bytes_ignored"] == spans[-1][1] - spans[-1][0] - 10
    assert "truncated" in out.err

    bad = tmp_path / "bad.srrec"
    buf = bytearray(data)
    buf[spans[7][0] + 40] ^= 1
    bad.write_bytes(bytes(buf))
    assert main(["recording", "verify", str(bad)]) == 1
    out = capsys.readouterr()
    rep = json.loads(out.out)
    assert rep["status"] == "damaged" and rep["records_skipped"] == 1
    assert rep["damage"] == [{"start": spans[7][0], "end": spans[7][1], "records": 1,
                              "reason": "record fails its CRC check"}]
    assert f"damaged region at bytes {spans[7][0]}-{spans[7][1]}" in out.err

    junk = tmp_path / "junk.srrec"
    junk.write_bytes(b"hello")
    assert main(["recording", "verify", str(junk)]) == 2
    assert capsys.readouterr().err == f"{junk} is not a shipradar recording (bad magic)\n"
    assert main(["recording", "verify", str(tmp_path / "nope.srrec")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_repair_writes_every_valid_record_and_never_touches_the_input(real, tmp_path, capsys):
    data, records, spans = real
    bad = tmp_path / "bad.srrec"
    buf = bytearray(data)
    buf[spans[2][0] + 50] ^= 4
    damaged = bytes(buf) + bytes(7)
    bad.write_bytes(damaged)
    out = tmp_path / "fixed.srrec"
    assert main(["recording", "repair", str(bad), str(out)]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["records_written"] == len(records) - 1 and rep["records_skipped"] == 1
    assert bad.read_bytes() == damaged
    with read_recording(out, strict=True) as reader:
        assert list(reader) == records[:2] + records[3:]
    assert main(["recording", "verify", str(out)]) == 0
    capsys.readouterr()
    # OUT exists: refused without --overwrite, and never the input itself
    before = out.read_bytes()
    assert main(["recording", "repair", str(bad), str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err and out.read_bytes() == before
    assert main(["recording", "repair", str(bad), str(bad), "--overwrite"]) == 2
    assert "is the input file itself" in capsys.readouterr().err
    assert bad.read_bytes() == damaged
    assert main(["recording", "repair", str(bad), str(out), "--overwrite",
                 "--compress", "zstd"]) == 0
    capsys.readouterr()
    with read_recording(out, strict=True) as reader:
        assert list(reader) == records[:2] + records[3:] and reader.compressed


def test_repair_converts_format_1(tmp_path):
    v1 = Path(__file__).parent / "data" / "recording_v1.srrec"
    out = tmp_path / "v2.srrec"
    rep = repair_recording(v1, out)
    assert rep["records_written"] == 5
    with read_recording(out) as a, read_recording(v1) as b:
        assert list(a) == list(b) and a.format_version == 2
    with pytest.raises(RecordingExistsError):
        repair_recording(v1, out)


def test_replay_goes_past_damage_and_strict_stops(real, tmp_path, capsys):
    data, records, spans = real
    bad = tmp_path / "bad.srrec"
    buf = bytearray(data)
    for k in (4, 9):
        buf[spans[k][0] + 40] ^= 1
    bad.write_bytes(bytes(buf))
    out = io.StringIO()
    summary = replay(str(bad), ReplaySettings(fast=True), out=out)
    assert summary["frames"] == len(records) - 2
    assert summary["damaged_regions"] == 2 and summary["records_skipped"] == 2
    assert summary["bytes_skipped"] == sum(spans[k][1] - spans[k][0] for k in (4, 9))
    assert len(out.getvalue().splitlines()) == len(records) - 2
    assert main(["replay", str(bad), "--fast"]) == 0
    cap = capsys.readouterr()
    assert json.loads(cap.out.splitlines()[-1])["records_skipped"] == 2
    assert (f"warning: {bad} is damaged: 2 region(s), {summary['bytes_skipped']} byte(s) and "
            f"2 record(s) skipped; {len(records) - 2} valid record(s) replayed") in cap.err
    assert main(["replay", str(bad), "--fast", "--strict"]) == 2
    cap = capsys.readouterr()
    assert f"record fails its CRC check at byte {spans[4][0]}" in cap.err
    assert len(cap.out.splitlines()) == 4  # the records before the damage, then the stop


def test_verify_checks_the_crc_of_every_record_quickly(real):
    """Guard against a verify that only looks at headers: a payload flip must be found."""
    data, _records, spans = real
    buf = bytearray(data)
    buf[spans[-2][1] - 1] ^= 0x80
    path = Path(os.environ.get("TMPDIR", "/tmp")) / f"v-{os.getpid()}.srrec"
    try:
        path.write_bytes(bytes(buf))
        assert verify_recording(path)["status"] == "damaged"
    finally:
        path.unlink()
    assert zlib.crc32(b"") == 0  # why a zero-filled format-1 prefix looks valid (see reader)


def test_same_scene_and_seed_give_identical_bytes_with_and_without_compression(tmp_path):
    for comp in ("none", "zstd"):
        a, b = tmp_path / f"a-{comp}.srrec", tmp_path / f"b-{comp}.srrec"
        _record(a, compress=comp)
        _record(b, compress=comp)
        assert a.read_bytes() == b.read_bytes(), comp
    with read_recording(tmp_path / "a-none.srrec") as r1, \
            read_recording(tmp_path / "a-zstd.srrec") as r2:
        assert list(r1) == list(r2)
    assert (tmp_path / "a-zstd.srrec").stat().st_size < (tmp_path / "a-none.srrec").stat().st_size
