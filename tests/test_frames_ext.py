"""The compiled per-message byte work (shipradar/_frames.c) and its pure-Python twin
(shipradar/_frames_py.py, used without a compiler) against what others wrote.

The CRC-32 is zlib's; the bodies are msgpack's (the reference encoder packs the same payload
with the msgpack library) and :func:`shipradar.sim.stream.protocol.encode`'s; the records are those
of one :meth:`Recorder.write` per message (a Python path) and read back by the reader.  The
tests of the stream's functions run once per implementation (the ``impl`` fixture); the
compiled one's are skipped where it was not built.
"""

from __future__ import annotations

import zlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from shipradar import _frames_py
from shipradar.sim.stream import protocol, recording
from shipradar.sim.stream.protocol import ProtocolError, encode, encode_slices
from shipradar.sim.stream.recording import Recorder, read_recording

try:
    from shipradar import _frames
except ImportError:  # not built (an install without a C compiler): its own tests skip
    _frames = None
compiled = pytest.mark.skipif(_frames is None, reason="shipradar._frames was not built")


@pytest.fixture(params=["compiled", "pure"])
def impl(request, monkeypatch):
    """The stream's byte work by each implementation in turn (as shipradar._framing would
    choose it): the compiled extension, then the pure-Python twin."""
    if request.param == "compiled" and _frames is None:
        pytest.skip("shipradar._frames was not built")
    module = _frames if request.param == "compiled" else _frames_py
    monkeypatch.setattr(protocol, "_frames", module)
    monkeypatch.setattr(recording, "_frames", module)
    return module


@compiled
@settings(max_examples=200, deadline=None)
@given(data=st.binary(max_size=300), skip=st.integers(0, 7), crc=st.integers(0, 2**32 - 1))
def test_crc32_is_zlibs(data, skip, crc):
    # every alignment of the start (slicing by 8 reads whole words) and any running CRC
    view = memoryview(data)[min(skip, len(data)):]
    assert _frames.crc32(view, crc) == zlib.crc32(view, crc)
    assert _frames.crc32(bytes(view)) == zlib.crc32(bytes(view))
    # the table the module falls back on when zlib's shared library is not found
    assert _frames.crc32(view, crc, True) == zlib.crc32(view, crc)


@compiled
def test_crc32_is_zlibs_own_here():
    # Python's zlib module is built on the shared zlib, which _frames finds and uses
    assert _frames.uses_zlib()


@pytest.mark.parametrize("n", [0, 1, 239, 240, 241, 65519, 65520, 65521, 70000])
def test_column_slices_at_the_msgpack_ext_size_boundaries(n, impl):
    # a uint8 column of n elements is an extension of 16 + n bytes: fixext 16 at n = 0,
    # ext 8 up to 255 bytes, ext 16 up to 65535, ext 32 beyond
    col = (np.arange(n + 3) % 251).astype(np.uint8)
    wide = np.arange(n + 3, dtype=np.float64)
    bodies = encode_slices(b"plots", [1.25, 2.5], {"sensor": "s", "scan": 300},
                           {"u8": (col, [0, 3], [n, n + 3]), "f8": (wide, [0, 3], [n, n + 3])})
    for j, (i0, i1) in enumerate([(0, n), (3, n + 3)]):
        payload = {"sensor": "s", "scan": 300, "u8": col[i0:i1], "f8": wide[i0:i1]}
        t = [1.25, 2.5][j]
        assert bodies[j] == encode(b"plots", t, payload)[1]
        assert bodies[j] == protocol.encode_reference(b"plots", t, payload)[1]


# the impl fixture sets the same module for every example
@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cuts=st.lists(st.integers(0, 40), min_size=1, max_size=12),
       times=st.floats(-1e9, 1e9, allow_nan=False))
def test_encode_slices_is_the_msgpack_reference(cuts, times, impl):
    cuts = sorted(cuts)
    n = cuts[-1]
    rng = np.random.default_rng(len(cuts))
    cols = {"a": rng.random(n), "b": rng.integers(-5, 5, n).astype(np.int32),
            "c": rng.integers(0, 2, n).astype(bool)}
    start, stop = [0, *cuts[:-1]], cuts
    t = [times + k for k in range(len(cuts))]
    bodies = encode_slices(b"truth", t, {"kind": "plots"},
                           {k: (v, start, stop) for k, v in cols.items()})
    for j, body in enumerate(bodies):
        payload = {"kind": "plots", **{k: v[start[j]:stop[j]] for k, v in cols.items()}}
        assert body == protocol.encode_reference(b"truth", t[j], payload)[1]


def test_encode_slices_refuses_bad_slices_and_oversized_bodies(monkeypatch, impl):
    col = np.arange(10.0)
    with pytest.raises(ProtocolError, match="slice"):
        encode_slices(b"plots", [0.0], {}, {"x": (col, [0], [11])})
    with pytest.raises(ProtocolError, match="slice"):
        encode_slices(b"plots", [0.0], {}, {"x": (col, [5], [4])})
    with pytest.raises(ProtocolError, match="one start and stop"):
        encode_slices(b"plots", [0.0, 1.0], {}, {"x": (col, [0], [1])})
    monkeypatch.setattr(protocol, "MAX_BODY_BYTES", 100)
    with pytest.raises(ProtocolError, match="over the 100-byte maximum"):
        encode_slices(b"plots", [0.0], {}, {"x": (col, [0], [10])})


def test_frame_records_are_write_per_message_and_read_back(tmp_path, impl):
    # times of every type the engine hands over (float, numpy float64, int)
    msgs = [(0.5, [b"plots", b"abc" * 100]), (np.float64(0.75), (b"truth", b"")),
            (2, [b"eos", bytes(range(256))])]
    one, many = Recorder(tmp_path / "one"), Recorder(tmp_path / "many")
    for t, frames in msgs:
        one.write(t, frames)
    many.write_many(msgs)
    one.close()
    many.close()
    assert (tmp_path / "one").read_bytes() == (tmp_path / "many").read_bytes()
    back = list(read_recording(tmp_path / "many"))
    assert [(float(t), [bytes(f) for f in frames]) for t, frames in back] == [
        (float(t), list(frames)) for t, frames in msgs]


@compiled
def test_frame_records_leaves_other_messages_to_python():
    assert _frames.frame_records([(0.0, [b"a", b"b", b"c"])], 0, 1 << 20, 0) is None
    assert _frames.frame_records([(0.0, [b"a", "text"])], 0, 1 << 20, 0) is None
    blob, ends, raw, done = _frames.frame_records([(0.0, [b"a", b"b"])], 5, 1 << 20, 100)
    assert (len(blob), ends, raw, done) == (32 + 20, [152], 20, 1)


@compiled
def test_the_pure_twin_gives_the_compiled_bodies_with_several_fixed_parts(monkeypatch):
    # a block of revolutions: one fixed part per scan, columns of every wire dtype family
    rng = np.random.default_rng(7)
    n = 300
    cols = {"f8": rng.random(n), "f4": rng.random(n).astype(np.float32),
            "i8": rng.integers(-9, 9, n), "u2": rng.integers(0, 9, n).astype(np.uint16),
            "b": rng.integers(0, 2, n).astype(bool), "be": rng.random(n).astype(">f8"),
            "c16": rng.random(n) + 1j * rng.random(n)}
    cuts = np.sort(rng.integers(0, n, 40))
    start, stop = np.r_[0, cuts[:-1]], cuts
    times = np.cumsum(rng.random(40))
    fixed = [{"sensor": "giraffe", "scan": k} for k in (7, 8, 9)]
    which = np.repeat([0, 1, 2], [10, 20, 10])
    args = (b"plots", times, fixed, {k: (v, start, stop) for k, v in cols.items()}, which)
    monkeypatch.setattr(protocol, "_frames", _frames)
    bodies = encode_slices(*args)
    monkeypatch.setattr(protocol, "_frames", _frames_py)
    assert encode_slices(*args) == bodies
    assert len(bodies) == 40
