"""Message envelope: round trips, determinism, limits and errors (shipradar.sim.stream.protocol)."""

from __future__ import annotations

import json
import math
import struct

import msgpack
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from shipradar.sim.stream import protocol
from shipradar.sim.stream.protocol import (
    EXT_NDARRAY,
    MAX_BODY_BYTES,
    SCHEMA_VERSION,
    TOPIC_END,
    TOPIC_EOS,
    TOPIC_META,
    TOPIC_PLOTS,
    TOPIC_TRUTH,
    TOPICS,
    ProtocolError,
    decode,
    decode_array,
    encode,
    encode_array,
    to_jsonable,
)


def plot_payload(n: int = 5) -> dict:
    rng = np.random.default_rng(1)
    return {
        "sensor": "sps49",
        "scan": 12,
        "time_s": np.linspace(10.0, 10.5, n),
        "range_m": rng.uniform(1e3, 1e5, n),
        "azimuth_rad": rng.uniform(0, 2 * np.pi, n),
        "snr_db": rng.normal(15.0, 3.0, n),
        "sigma_range_m": np.full(n, 15.0),
        "sigma_azimuth_rad": np.full(n, 0.003),
        "interference": np.arange(n, dtype=np.uint8) % 3,
    }


def assert_same(a, b) -> None:
    """Deep equality where arrays compare by dtype, shape and values (NaN equal to NaN)."""
    if isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray)
        assert b.dtype == a.dtype.newbyteorder("<") or b.dtype == a.dtype
        assert b.shape == a.shape
        np.testing.assert_array_equal(b, a)
    elif isinstance(a, dict):
        assert isinstance(b, dict)
        assert list(a) == list(b)  # insertion order kept
        for k in a:
            assert_same(a[k], b[k])
    elif isinstance(a, (list, tuple)):
        assert isinstance(b, list) and len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            assert_same(x, y)
    elif isinstance(a, float) and math.isnan(a):
        assert isinstance(b, float) and math.isnan(b)
    else:
        assert type(b) is type(a) and b == a


def test_topics_are_distinct_and_not_prefixes_of_each_other():
    assert TOPICS == (TOPIC_META, TOPIC_PLOTS, TOPIC_EOS, TOPIC_TRUTH, TOPIC_END)
    for a in TOPICS:
        for b in TOPICS:
            if a is not b:
                assert not b.startswith(a)  # ZeroMQ subscriptions match by prefix


def test_plot_message_round_trip():
    payload = plot_payload()
    frames = encode(TOPIC_PLOTS, 10.25, payload)
    assert len(frames) == 2 and frames[0] == b"plots"
    topic, t, out = decode(frames)
    assert topic == TOPIC_PLOTS
    assert t == 10.25
    assert_same(payload, out)


def test_body_envelope_is_plain_msgpack():
    frames = encode(TOPIC_EOS, 3.0, {"sensor": "s", "scan": 1})
    body = msgpack.unpackb(frames[1])
    assert list(body) == ["v", "t", "sensor", "scan"]
    assert body["v"] == SCHEMA_VERSION and body["t"] == 3.0


@pytest.mark.parametrize(
    "dtype",
    ["float64", "float32", "float16", "int8", "int16", "int32", "int64", "uint8", "uint16",
     "uint32", "uint64", "bool", "complex64", "complex128"],
)  # fmt: skip
@pytest.mark.parametrize("shape", [(0,), (7,), (3, 4), (), (2, 0, 3)])
def test_array_round_trip_every_dtype_and_shape(dtype, shape):
    rng = np.random.default_rng(7)
    a = np.asarray(rng.uniform(-100, 100, size=shape) * 1.7).astype(dtype)
    _, _, out = decode(encode(TOPIC_PLOTS, 0.0, {"a": a}))
    b = out["a"]
    assert b.dtype == np.dtype(dtype) and b.shape == a.shape
    np.testing.assert_array_equal(b, a)
    assert not b.flags.writeable  # a view on the received bytes


def test_nan_inf_and_extreme_floats_survive():
    a = np.array([np.nan, np.inf, -np.inf, -0.0, 5e-324, 1.7976931348623157e308])
    _, _, out = decode(encode(TOPIC_PLOTS, 0.0, {"a": a, "x": float("nan"), "y": -np.inf}))
    np.testing.assert_array_equal(out["a"], a)
    assert np.signbit(out["a"][3])
    assert math.isnan(out["x"]) and out["y"] == -math.inf


def test_big_endian_and_non_contiguous_arrays_are_sent_little_endian():
    big = np.arange(6, dtype=">i4")
    strided = np.arange(20.0).reshape(4, 5)[:, ::2]
    fortran = np.asfortranarray(np.arange(12.0).reshape(3, 4))
    _, _, out = decode(encode(TOPIC_PLOTS, 0.0, {"big": big, "s": strided, "f": fortran}))
    assert out["big"].dtype == np.dtype("<i4")
    np.testing.assert_array_equal(out["big"], big)
    np.testing.assert_array_equal(out["s"], strided)
    np.testing.assert_array_equal(out["f"], fortran)


def test_nested_structures_strings_bytes_and_numpy_scalars():
    payload = {
        "sensor": "sea giraffe ✓",
        "raw": b"\x00\xff",
        "none": None,
        "flag": True,
        "targets": [
            {"id": "target:7", "pos_m": np.array([1.0, 2.0, 3.0]), "tags": ("a", "b")},
            {"id": "target:8", "contributors": []},
        ],
        "nested": {"deeper": {"n": np.int64(5), "x": np.float32(0.5), "b": np.bool_(False)}},
    }
    _, _, out = decode(encode(TOPIC_TRUTH, 1.0, payload))
    assert out["sensor"] == "sea giraffe ✓" and out["raw"] == b"\x00\xff"
    assert out["none"] is None and out["flag"] is True
    np.testing.assert_array_equal(out["targets"][0]["pos_m"], [1.0, 2.0, 3.0])
    assert out["targets"][0]["tags"] == ["a", "b"]
    assert out["targets"][1] == {"id": "target:8", "contributors": []}
    deeper = out["nested"]["deeper"]
    assert deeper == {"n": 5, "x": 0.5, "b": False}
    assert type(deeper["n"]) is int and type(deeper["b"]) is bool


def test_same_input_same_bytes_and_key_order_matters():
    a = encode(TOPIC_PLOTS, 12.5, plot_payload())
    b = encode(TOPIC_PLOTS, 12.5, plot_payload())
    assert a == b
    p = plot_payload()
    reordered = dict(reversed(list(p.items())))
    assert encode(TOPIC_PLOTS, 12.5, reordered)[1] != a[1]


def test_integer_time_and_float_time_encode_identically():
    assert encode(TOPIC_EOS, 3, {"scan": 1}) == encode(TOPIC_EOS, 3.0, {"scan": 1})


def test_golden_bytes_pin_the_wire_format():
    # Changing these bytes breaks every subscriber: bump SCHEMA_VERSION and update the doc.
    frames = encode(TOPIC_EOS, 2.5, {"scan": 3, "r": np.array([1.0], dtype="<f4")})
    expected = (
        b"\x84\xa1v\x02\xa1t\xcb\x40\x04\x00\x00\x00\x00\x00\x00"
        b"\xa4scan\x03\xa1r"
        b"\xc7\x14\x01"  # ext 8, 20 bytes, type 1
        b"\x01\x03<f4\x00\x00\x00"  # ndim 1, typestr '<f4', padding to 8
        b"\x01\x00\x00\x00\x00\x00\x00\x00"  # shape (1,)
        b"\x00\x00\x80\x3f"  # 1.0f little-endian
    )
    assert frames == [b"eos", expected]


def test_array_extension_layout_is_aligned():
    data = encode_array(np.arange(3, dtype=np.float64))
    ndim, lts = struct.unpack_from("<BB", data)
    assert (ndim, lts) == (1, 3)
    assert data[2:5] == b"<f8"
    assert struct.unpack_from("<Q", data, 8) == (3,)
    assert len(data) == 16 + 24
    np.testing.assert_array_equal(decode_array(data), [0.0, 1.0, 2.0])


@pytest.mark.parametrize(
    ("topic", "t", "payload", "match"),
    [
        (b"", 0.0, {}, "topic"),
        ("plots", 0.0, {}, "topic"),
        (b"x" * 256, 0.0, {}, "topic"),
        (TOPIC_PLOTS, float("nan"), {}, "finite"),
        (TOPIC_PLOTS, float("inf"), {}, "finite"),
        (TOPIC_PLOTS, 0.0, {"v": 2}, "reserved"),
        (TOPIC_PLOTS, 0.0, {"t": 2}, "reserved"),
        (TOPIC_PLOTS, 0.0, {1: 2}, "keys must be str"),
        (TOPIC_PLOTS, 0.0, {"a": {"b": {3: 1}}}, "keys must be str"),
        (TOPIC_PLOTS, 0.0, {"a": {1, 2}}, "set"),
        (TOPIC_PLOTS, 0.0, {"a": 1 + 2j}, "complex"),
        (TOPIC_PLOTS, 0.0, {"a": np.array(["x", "y"])}, "dtype"),
        (TOPIC_PLOTS, 0.0, {"a": np.array([object()])}, "dtype"),
        (TOPIC_PLOTS, 0.0, {"a": np.array(["2020-01-01"], dtype="datetime64[D]")}, "dtype"),
        (TOPIC_PLOTS, 0.0, {"a": 2**64}, "cannot be encoded"),
        (TOPIC_PLOTS, 0.0, [("a", 1)], "mapping"),
    ],
)
def test_encode_rejects_with_clear_error(topic, t, payload, match):
    with pytest.raises(ProtocolError, match=match):
        encode(topic, t, payload)
    # The shared packer is clean after a failure: the next message is unaffected.
    assert encode(TOPIC_EOS, 1.0, {"scan": 1}) == encode(TOPIC_EOS, 1.0, {"scan": 1})
    assert decode(encode(TOPIC_EOS, 1.0, {"scan": 1}))[2] == {"scan": 1}


def test_encode_refuses_body_over_maximum():
    big = np.zeros(MAX_BODY_BYTES // 8 + 1)
    with pytest.raises(ProtocolError, match="maximum"):
        encode(TOPIC_PLOTS, 0.0, {"range_m": big})
    ok = np.zeros(MAX_BODY_BYTES // 8 - 16)
    assert len(encode(TOPIC_PLOTS, 0.0, {"range_m": ok})[1]) <= MAX_BODY_BYTES


def test_decode_refuses_body_over_maximum_before_parsing():
    with pytest.raises(ProtocolError, match="maximum"):
        decode([TOPIC_PLOTS, bytes(MAX_BODY_BYTES + 1)])


def _body(obj) -> bytes:
    return msgpack.packb(obj, use_bin_type=True)


@pytest.mark.parametrize(
    ("frames", "match"),
    [
        ([TOPIC_PLOTS], "2 frames"),
        ([TOPIC_PLOTS, _body({"v": 1, "t": 0.0}), b""], "2 frames"),
        ([TOPIC_PLOTS, b"\xc1"], "not valid msgpack"),
        ([TOPIC_PLOTS, _body({"v": 1, "t": 0.0}) + b"\x00"], "not valid msgpack"),
        ([TOPIC_PLOTS, _body([1, 2])], "envelope"),
        ([TOPIC_PLOTS, _body({"t": 0.0})], "envelope"),
        ([TOPIC_PLOTS, _body({"v": 99, "t": 0.0})], "schema version 99"),
        ([TOPIC_PLOTS, _body({"v": 1, "t": "now"})], "number"),
        ([TOPIC_PLOTS, _body({"v": 1, "t": 0.0, "a": msgpack.ExtType(9, b"")})], "extension"),
        ([TOPIC_PLOTS, _body({"v": 1, "t": 0.0, 5: 1})], "not valid msgpack"),
    ],
)
def test_decode_rejects_with_clear_error(frames, match):
    with pytest.raises(ProtocolError, match=match):
        decode(frames)


@pytest.mark.parametrize(
    ("data", "match"),
    [
        (b"\x01", "too short"),
        (b"\x01\x03<f8", "malformed"),
        (b"\x01\x03<O8\x00\x00\x00" + struct.pack("<Q", 1) + bytes(8), "unsupported element"),
        (b"\x01\x03<f8\x00\x00\x00" + struct.pack("<Q", 2) + bytes(8), "expected 16"),
        (b"\x01\x03<f8\x00\x00\x00" + struct.pack("<Q", 2**62) + bytes(8), "expected"),
        (b"\x21\x03<f8\x00\x00\x00", "malformed"),
    ],
)
def test_malformed_array_columns_are_rejected(data, match):
    with pytest.raises(ProtocolError, match=match):
        decode([TOPIC_PLOTS, _body({"v": 1, "t": 0.0, "a": msgpack.ExtType(EXT_NDARRAY, data)})])


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=200))
def test_decode_of_arbitrary_bytes_raises_only_protocol_error(body):
    try:
        decode([TOPIC_PLOTS, body])
    except ProtocolError:
        pass


@settings(max_examples=100, deadline=None)
@given(
    hnp.arrays(
        dtype=st.one_of(
            hnp.floating_dtypes(), hnp.integer_dtypes(), hnp.unsigned_integer_dtypes(),
            hnp.boolean_dtypes(),
        ),
        shape=hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=5),
    ),
    st.floats(allow_nan=False, allow_infinity=False),
)  # fmt: skip
def test_any_numeric_array_round_trips(a, t):
    topic, t_out, out = decode(encode(TOPIC_PLOTS, t, {"a": a}))
    assert t_out == t
    assert out["a"].shape == a.shape
    assert out["a"].dtype == a.dtype.newbyteorder("<") or out["a"].dtype == a.dtype
    np.testing.assert_array_equal(out["a"], a)


def test_to_jsonable_gives_strict_json():
    payload = {
        "sensor": "sps49",
        "raw": b"abc",
        "bin": b"\xff\x00",
        "snr_db": np.array([1.5, np.nan, np.inf]),
        "n": np.int64(3),
        "grid": np.arange(4, dtype=np.uint8).reshape(2, 2),
        "ok": np.array([True, False]),
        "z": np.array([1 + 2j]),
        "x": float("nan"),
        "tup": (1, 2.5),
    }
    _, _, out = decode(encode(TOPIC_PLOTS, 0.0, payload))
    js = to_jsonable(out)
    assert js == {
        "sensor": "sps49",
        "raw": "abc",
        "bin": "0xff00",
        "snr_db": [1.5, None, None],
        "n": 3,
        "grid": [[0, 1], [2, 3]],
        "ok": [True, False],
        "z": [[1.0, 2.0]],
        "x": None,
        "tup": [1, 2.5],
    }
    json.dumps(js, allow_nan=False)  # raises if any NaN/inf slipped through


def test_decode_accepts_zero_copy_buffers():
    frames = encode(TOPIC_PLOTS, 1.0, plot_payload())
    topic, t, out = decode([memoryview(frames[0]), memoryview(frames[1])])
    assert topic == TOPIC_PLOTS and t == 1.0
    np.testing.assert_array_equal(out["range_m"], plot_payload()["range_m"])


def test_maximum_is_documented_value():
    assert protocol.MAX_BODY_BYTES == 64 * 1024 * 1024


def test_decoding_snippet_in_the_documentation_reads_our_bytes():
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[1] / "docs" / "protocol.md").read_text()
    snippet = doc.split("```python\n", 1)[1].split("```", 1)[0]
    namespace: dict = {}
    exec(compile(snippet, "docs/protocol.md", "exec"), namespace)  # defines, does not listen
    payload = plot_payload(4)
    payload["grid"] = np.arange(6, dtype=np.int16).reshape(2, 3)
    payload["flags"] = np.array([True, False])
    msg = namespace["decode_body"](encode(TOPIC_PLOTS, 7.5, payload)[1])
    assert msg.pop("v") == SCHEMA_VERSION and msg.pop("t") == 7.5
    assert_same(payload, msg)


@pytest.mark.parametrize("n", [0, 1, 2, 29, 30, 31, 8189, 8190, 8191])
def test_fast_encoder_matches_msgpack_for_every_extension_size(n):
    """encode writes the map itself; its bytes must be msgpack's own (fixext 16 for an empty
    column, ext 8/16/32 around their 256 and 65536-byte limits, fixmap/map16)."""
    payload = {"a": np.arange(n, dtype="<f8"), "b": np.zeros(n, dtype=np.uint8),
               "z": np.float64(2.5), "i": np.int32(-3), "nested": {"k": [np.arange(2), 1]}}
    payload.update({f"k{i}": i for i in range(16)})  # 21 keys: a map 16 header
    assert encode(TOPIC_PLOTS, 1.5, payload) == protocol.encode_reference(
        TOPIC_PLOTS, 1.5, payload)
    strided = {"every_other": np.arange(2 * n + 1, dtype=np.float64)[::2],
               "reversed": np.arange(n, dtype=np.int32)[::-1], "big_endian": np.ones(n, ">f8")}
    assert encode(TOPIC_PLOTS, 1.5, strided) == protocol.encode_reference(
        TOPIC_PLOTS, 1.5, strided)
    small = {"x": np.array(1.0), "y": np.array(True), "s": "text", "b": b"\x00\x01"}
    assert encode(TOPIC_EOS, 0.0, small) == protocol.encode_reference(TOPIC_EOS, 0.0, small)


@settings(max_examples=60, deadline=None)
@given(hnp.arrays(dtype=st.sampled_from(["<f8", "<f4", "|u1", "<i4", "<i8", "|b1", ">f8"]),
                  shape=hnp.array_shapes(min_dims=0, max_dims=3, max_side=40)),
       st.floats(allow_nan=False, allow_infinity=False))
def test_fast_encoder_matches_reference_encoder(array, t):
    payload = {"sensor": "s", "scan": 3, "col": array, "meta": {"x": [1.0, None]}}
    assert encode(TOPIC_PLOTS, t, payload) == protocol.encode_reference(TOPIC_PLOTS, t, payload)


def test_fast_encoder_errors_are_the_documented_ones():
    with pytest.raises(ProtocolError, match="keys must be str"):
        encode(TOPIC_PLOTS, 0.0, {1: 2})
    with pytest.raises(ProtocolError, match="keys must be str"):
        encode(TOPIC_PLOTS, 0.0, {"a": {"b": {3: 4}}})
    with pytest.raises(ProtocolError, match="reserved"):
        encode(TOPIC_PLOTS, 0.0, {"t": 1})
    with pytest.raises(ProtocolError, match="cannot be encoded"):
        encode(TOPIC_PLOTS, 0.0, {"a": object()})
    with pytest.raises(ProtocolError, match="cannot be encoded"):
        encode(TOPIC_PLOTS, 0.0, {"a": 2**70})
    with pytest.raises(ProtocolError, match="cannot be encoded"):
        encode(TOPIC_PLOTS, 0.0, {"a": "\udc80"})
    for v in (0, 127, 128, -1, 2**40, True, None, 1.5, "x" * 100):  # fixint and str shortcuts
        assert encode(TOPIC_EOS, 1.0, {"v1": v}) == protocol.encode_reference(
            TOPIC_EOS, 1.0, {"v1": v})
    # the packer is left clean after an error
    assert encode(TOPIC_EOS, 1.0, {"scan": 1}) == protocol.encode_reference(
        TOPIC_EOS, 1.0, {"scan": 1})


def test_encode_slices_same_bytes_as_encode():
    # the engine's sector frames: each message is encode() of the sliced columns
    from shipradar.sim.stream.protocol import encode, encode_slices

    rng = np.random.default_rng(3)
    n = 50
    cols = {
        "plot_id": np.arange(100, 100 + n, dtype=np.int64),
        "range_m": rng.random(n) * 1e5,
        "origin": rng.integers(0, 3, n).astype(np.uint8),
        "target": rng.integers(-1, 9, n).astype(np.int32),
        "big": rng.random(n).astype(">f8"),  # converted once, as encode_array does
    }
    cuts = [0, 0, 7, 7, 30, 49, 50]  # empty, short and single-row slices
    start, stop = cuts[:-1], cuts[1:]
    times = [0.5 * (k + 1) for k in range(len(start))]
    fixed = {"sensor": "sps49", "scan": 3, "kind": "plots", "meta": {"a": [1, 2.5, None]}}
    bodies = encode_slices(b"truth", times, fixed,
                           {k: (v, start, stop) for k, v in cols.items()})
    for j, body in enumerate(bodies):
        payload = dict(fixed)
        payload.update({k: v[start[j]:stop[j]] for k, v in cols.items()})
        assert body == encode(b"truth", times[j], payload)[1]
    with pytest.raises(ProtocolError):
        encode_slices(b"plots", [0.0], {"scan": 1}, {"scan": (cols["plot_id"], [0], [1])})
    with pytest.raises(ProtocolError):
        encode_slices(b"plots", [float("nan")], {}, {"x": (cols["plot_id"], [0], [1])})


@pytest.mark.parametrize("scan", [0, 1, 127, 128, 255, 256, 65535, 65536, 2**32, 2**40])
def test_encode_items_is_encode_of_the_merged_payload(scan):
    # the engine's metadata: packed once around the one key that changes (same bytes)
    before = {"sensor": "r1", "platform": "ship", "nested": {"a": [1, 2.5, None]}}
    after = {"ids": ["t1", "t2"], "profile": np.arange(5.0), "pfa": 1e-6, "x": -3}
    payload = {**before, "scan": scan, **after}
    t = 12.375
    want = protocol.encode(protocol.TOPIC_META, t, payload)
    items = (protocol.payload_items(protocol.TOPIC_META, before),
             protocol.payload_items(protocol.TOPIC_META, {"scan": scan}),
             protocol.payload_items(protocol.TOPIC_META, after))
    got = protocol.encode_items(protocol.TOPIC_META, t, len(payload), items)
    assert got == want
    with pytest.raises(ProtocolError, match="finite"):
        protocol.encode_items(protocol.TOPIC_META, math.nan, len(payload), items)
