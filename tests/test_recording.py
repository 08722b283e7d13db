"""Recording file: round trip, truncation after a crash, overwrite refusal, corruption,
format 1 still read. Damage and resynchronisation: tests/test_recording_damage.py."""

from __future__ import annotations

import os
import signal
import struct
import subprocess
import sys
import textwrap
import zlib
from pathlib import Path

import numpy as np
import pytest

from shipradar.sim.stream.protocol import SCHEMA_VERSION, TOPIC_EOS, TOPIC_PLOTS, decode, encode
from shipradar.sim.stream.recording import (
    FORMAT_VERSION,
    HEADER_BYTES,
    MAGIC,
    MAX_FRAMES,
    MAX_RECORD_BYTES,
    REC2_HEADER_BYTES,
    SYNC,
    Recorder,
    RecordingError,
    RecordingExistsError,
    RecordingReader,
    read_recording,
)


def messages(n: int) -> list[tuple[float, list[bytes]]]:
    out = []
    for i in range(n):
        t = 0.25 * i
        if i % 3 == 2:
            out.append((t, encode(TOPIC_EOS, t, {"sensor": "s", "scan": i})))
        else:
            out.append((t, encode(TOPIC_PLOTS, t, {"range_m": np.arange(i, dtype=float)})))
    return out


def write(path: Path, msgs) -> list[int]:
    """Write a recording; return the file offset at the end of each record."""
    ends = []
    with Recorder(path) as rec:
        for t, frames in msgs:
            rec.write(t, frames)
            rec.flush()
            ends.append(path.stat().st_size)
    return ends


def test_round_trip_preserves_times_and_bytes(tmp_path):
    path = tmp_path / "run.srrec"
    msgs = messages(20)
    with Recorder(path) as rec:
        for t, frames in msgs:
            rec.write(t, frames)
        assert rec.records == 20
    assert rec.closed
    assert rec.bytes_written == path.stat().st_size
    with read_recording(path) as reader:
        got = list(reader)
        assert reader.format_version == FORMAT_VERSION
        assert reader.schema_version == SCHEMA_VERSION
        assert reader.records == 20
        assert not reader.truncated and reader.bytes_ignored == 0
    assert got == msgs
    assert all(type(f) is bytes for _, frames in got for f in frames)
    assert decode(got[5][1])[1] == 1.25


def test_header_layout(tmp_path):
    path = tmp_path / "run.srrec"
    Recorder(path).close()
    data = path.read_bytes()
    assert len(data) == HEADER_BYTES == 16
    head = MAGIC + struct.pack("<HHH", FORMAT_VERSION, SCHEMA_VERSION, 0)
    assert data == head + struct.pack("<H", zlib.crc32(head) & 0xFFFF)
    assert FORMAT_VERSION == 2
    reader = RecordingReader(path)
    assert list(reader) == [] and not reader.truncated
    reader.close()


def test_record_layout_matches_documentation(tmp_path):
    path = tmp_path / "run.srrec"
    with Recorder(path) as rec:
        rec.write(1.5, [b"eos", b"\x80"])
    rec_bytes = path.read_bytes()[HEADER_BYTES:]
    payload = struct.pack("<dH", 1.5, 2) + struct.pack("<I", 3) + b"eos"
    payload += struct.pack("<I", 1) + b"\x80"
    mid = struct.pack("<IHHQI", len(payload), 0, 0, 0, zlib.crc32(payload))
    assert REC2_HEADER_BYTES == 32
    assert rec_bytes == SYNC + mid + struct.pack("<I", zlib.crc32(mid)) + payload


def test_reading_while_writer_is_open_sees_flushed_records(tmp_path):
    path = tmp_path / "live.srrec"
    msgs = messages(6)
    with Recorder(path) as rec:
        for t, frames in msgs[:4]:
            rec.write(t, frames)
        rec.flush(fsync=True)
        with read_recording(path) as reader:
            assert list(reader) == msgs[:4]
            assert not reader.truncated


def test_every_cut_point_replays_every_whole_record(tmp_path):
    path = tmp_path / "full.srrec"
    msgs = messages(7)
    ends = write(path, msgs)
    data = path.read_bytes()
    cut_path = tmp_path / "cut.srrec"
    for cut in range(len(data) + 1):
        cut_path.write_bytes(data[:cut])
        with read_recording(cut_path) as reader:
            got = list(reader)
            whole = sum(1 for e in ends if e <= cut)
            assert got == msgs[:whole], cut
            last_end = ends[whole - 1] if whole else min(cut, HEADER_BYTES)
            if cut < HEADER_BYTES:
                assert reader.truncated == (cut < HEADER_BYTES)
                assert reader.bytes_ignored == cut
            else:
                assert reader.truncated == (cut != last_end), cut
                assert reader.bytes_ignored == cut - last_end, cut


def test_truncated_mid_header_is_an_empty_truncated_recording(tmp_path):
    path = tmp_path / "h.srrec"
    path.write_bytes(MAGIC[:5])
    reader = read_recording(path)
    assert list(reader) == []
    assert reader.truncated and reader.bytes_ignored == 5
    assert reader.schema_version is None
    reader.close()


def test_survives_kill_9_up_to_the_last_flushed_record(tmp_path):
    path = tmp_path / "killed.srrec"
    # The child flushes every 10 records ("end of scan"), writes a few more without
    # flushing, then is killed with SIGKILL (no atexit, no buffer flush).
    code = textwrap.dedent(
        f"""
        import os, signal
        import numpy as np
        from shipradar.sim.stream.protocol import encode, TOPIC_PLOTS
        from shipradar.sim.stream.recording import Recorder
        rec = Recorder({str(path)!r}, buffer_bytes=4096)
        for i in range(205):
            rec.write(float(i), encode(TOPIC_PLOTS, float(i), {{"r": np.full(50, float(i))}}))
            if i % 10 == 9:
                rec.flush()
        os.kill(os.getpid(), signal.SIGKILL)
        """
    )
    proc = subprocess.run([sys.executable, "-c", code], timeout=60, check=False)
    assert proc.returncode == -signal.SIGKILL
    with read_recording(path) as reader:
        got = list(reader)
    assert len(got) >= 200  # every flushed scan, possibly more
    for i, (t, frames) in enumerate(got):
        assert t == float(i)
        np.testing.assert_array_equal(decode(frames)[2]["r"], np.full(50, float(i)))
    # 4 KiB buffer, ~450-byte records: the unflushed tail was cut mid-record or not at all.
    assert reader.truncated == (reader.bytes_ignored > 0)


def test_refuses_to_overwrite_and_keeps_the_old_file(tmp_path):
    path = tmp_path / "keep.srrec"
    write(path, messages(3))
    before = path.read_bytes()
    with pytest.raises(RecordingExistsError, match="already exists"):
        Recorder(path)
    assert path.read_bytes() == before
    with Recorder(path, overwrite=True) as rec:
        rec.write(9.0, [b"eos", b"x"])
    with read_recording(path) as reader:
        assert list(reader) == [(9.0, [b"eos", b"x"])]


def test_refuses_to_overwrite_any_existing_file(tmp_path):
    path = tmp_path / "notes.txt"
    path.write_text("precious")
    with pytest.raises(FileExistsError):
        Recorder(path)
    assert path.read_text() == "precious"


def test_wrong_magic_is_rejected(tmp_path):
    path = tmp_path / "x.srrec"
    path.write_bytes(b"PK\x03\x04" + bytes(40))
    with pytest.raises(RecordingError, match="not a shipradar recording"):
        RecordingReader(path)
    path.write_bytes(b"PK")  # short and wrong: not mistaken for a truncated header
    with pytest.raises(RecordingError, match="not a shipradar recording"):
        RecordingReader(path)


def test_unsupported_format_version_is_rejected(tmp_path):
    path = tmp_path / "x.srrec"
    path.write_bytes(MAGIC + struct.pack("<HHI", 99, SCHEMA_VERSION, 0))
    with pytest.raises(RecordingError, match="format version 99"):
        RecordingReader(path)


def _append_record(path, payload, *, n=None, seq=0, flags=0):
    mid = struct.pack("<IHHQI", len(payload) if n is None else n, flags, 0, seq,
                      zlib.crc32(payload))
    with path.open("ab") as f:
        f.write(SYNC + mid + struct.pack("<I", zlib.crc32(mid)) + payload)


def test_oversized_record_length_is_rejected_before_reading(tmp_path):
    path = tmp_path / "x.srrec"
    write(path, messages(2))
    _append_record(path, b"junk", n=MAX_RECORD_BYTES + 1, seq=2)
    path.open("ab").write(b"more junk that is not a record")
    reader = read_recording(path, strict=True)
    it = iter(reader)
    assert len([next(it), next(it)]) == 2
    with pytest.raises(RecordingError, match="over the .*maximum"):
        next(it)
    reader.close()
    with read_recording(path) as reader:
        assert len(list(reader)) == 2
        assert len(reader.damaged) == 1 and "maximum" in reader.damaged[0].reason
        assert not reader.truncated


def test_corrupted_record_fails_its_crc(tmp_path):
    path = tmp_path / "x.srrec"
    msgs = messages(3)
    ends = write(path, msgs)
    data = bytearray(path.read_bytes())
    data[ends[0] + REC2_HEADER_BYTES + 12] ^= 0xFF  # inside the second record's payload
    path.write_bytes(bytes(data))
    with read_recording(path, strict=True) as reader, pytest.raises(RecordingError, match="CRC"):
        list(reader)
    with read_recording(path) as reader:  # default: skip it, go on
        assert list(reader) == [msgs[0], msgs[2]]
        (region,) = reader.damaged
        assert (region.start, region.end, region.records) == (ends[0], ends[1], 1)
        assert reader.bytes_skipped == ends[1] - ends[0] and reader.records_skipped == 1


def test_record_with_inconsistent_frames_is_rejected(tmp_path):
    path = tmp_path / "x.srrec"
    Recorder(path).close()
    _append_record(path, struct.pack("<dH", 0.0, 1) + struct.pack("<I", 50) + b"short")
    with read_recording(path, strict=True) as reader, pytest.raises(RecordingError,
                                                                    match="malformed"):
        list(reader)
    with read_recording(path) as reader:
        assert list(reader) == []
        assert "malformed" in reader.damaged[0].reason


def test_writer_limits(tmp_path):
    with Recorder(tmp_path / "x.srrec") as rec:
        with pytest.raises(RecordingError, match="frames"):
            rec.write(0.0, [b"a"] * (MAX_FRAMES + 1))
        assert rec.records == 0


def test_iterating_twice_reads_the_file_twice(tmp_path):
    path = tmp_path / "x.srrec"
    msgs = messages(4)
    write(path, msgs)
    with read_recording(path) as reader:
        assert list(reader) == msgs
        assert list(reader) == msgs


def test_recorder_accepts_path_strings(tmp_path):
    path = os.path.join(tmp_path, "s.srrec")
    with Recorder(path) as rec:
        rec.write(0.0, [b"eos", b"\x80"])
    assert len(list(read_recording(path))) == 1


def test_format_1_is_still_read():
    """A file written by the format-1 writer (tests/data, generated by that code path)."""
    import msgpack

    path = Path(__file__).parent / "data" / "recording_v1.srrec"
    expected = [(0.5 * i, [b"eos", msgpack.packb({"v": 1, "t": 0.5 * i, "sensor": "s1",
                                                   "scan": i})]) for i in range(4)]
    expected.append((2.0, [b"a", b"b", b"c"]))
    with read_recording(path, strict=True) as reader:
        assert list(reader) == expected
        assert reader.format_version == 1 and reader.schema_version == 1
        assert not reader.truncated and not reader.damaged
    data = path.read_bytes()
    for cut in (len(data) - 3, len(data) - 20):
        short = Path(os.environ.get("TMPDIR", "/tmp")) / f"v1cut-{os.getpid()}.srrec"
        try:
            short.write_bytes(data[:cut])
            with read_recording(short) as reader:
                assert list(reader) == expected[:4] and reader.truncated
            short.write_bytes(data + bytes(64))  # zero-filled tail: a truncation
            with read_recording(short) as reader:
                assert list(reader) == expected and reader.truncated
                assert reader.bytes_ignored == 64 and not reader.damaged
            bad = bytearray(data)
            bad[16 + 8 + 20] ^= 0x01  # first record's body: nothing after it can be trusted
            short.write_bytes(bytes(bad))
            with read_recording(short) as reader:
                assert list(reader) == []
                assert reader.damaged[0].end == len(data)
            with read_recording(short, strict=True) as reader, pytest.raises(RecordingError):
                list(reader)
        finally:
            short.unlink(missing_ok=True)


def test_compressed_round_trip_and_layout(tmp_path):
    path = tmp_path / "z.srrec"
    msgs = messages(30)
    with Recorder(path, compress="zstd") as rec:
        for t, frames in msgs:
            rec.write(t, frames)
        rec.write(99.0, [b"plots", bytes(20000)])  # compresses well
    with read_recording(path, strict=True) as reader:
        got = list(reader)
        assert reader.compressed is True
    assert got == [*msgs, (99.0, [b"plots", bytes(20000)])]
    assert path.stat().st_size < 20000
    with pytest.raises(RecordingError, match="compression must be one of none, zstd"):
        Recorder(tmp_path / "y.srrec", compress="gzip")


def test_compressed_recording_is_deterministic(tmp_path):
    msgs = messages(40)
    blobs = []
    for name in ("a", "b"):
        with Recorder(tmp_path / f"{name}.srrec", compress="zstd") as rec:
            for t, frames in msgs:
                rec.write(t, frames)
        blobs.append((tmp_path / f"{name}.srrec").read_bytes())
    assert blobs[0] == blobs[1]


def test_oversized_file_is_refused_when_a_limit_is_given(tmp_path):
    path = tmp_path / "x.srrec"
    write(path, messages(3))
    with pytest.raises(RecordingError, match="over the 100-byte limit"):
        read_recording(path, max_bytes=100)
