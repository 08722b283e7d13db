"""The table cache's file format (issue 27): uncompressed ``.npz`` read at disk speed.

A table survives the round trip whole (values, axes, extra arrays, provenance); a file of
the compressed layout written before is still read, and rewritten uncompressed; a damaged
file is rebuilt with a warning, never crashed on.
"""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

from shipradar.tables import store
from shipradar.tables.store import Table, TableCacheWarning, cache_path, get_or_build


def _table(scale: float = 1.0) -> Table:
    r = np.array([0.0, 1.5e3, 4.0e3, 1.0e4])
    az = np.linspace(0.0, 2 * np.pi, 5)
    values = scale * np.arange(20.0).reshape(4, 5) ** 1.5
    return Table(
        name="test_table", version=3, axes=(r, az), axis_names=("range_m", "azimuth_rad"),
        axis_units=("m", "rad"), values=values, value_name="sigma0", value_unit="1",
        inputs={"freq_hz": 9.4e9, "grid": [1, 2, 3], "model": "GIT", "scale": scale},
        extra={
            # a complex array and a Fortran-ordered one: both layouts of the .npy header
            "field": (values + 1j * values[::-1]).astype(np.complex128),
            "weibull_a": np.asfortranarray(np.sqrt(values) + 0.25),
        },
    )


def _assert_same(a: Table, b: Table) -> None:
    assert a.metadata() == b.metadata()  # provenance: names, units, inputs, key, format
    assert a.key == b.key
    for x, y in zip(a.axes, b.axes, strict=True):
        np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(a.values, b.values)
    assert a.extra.keys() == b.extra.keys()
    for k in a.extra:
        assert a.extra[k].dtype == b.extra[k].dtype
        np.testing.assert_array_equal(a.extra[k], b.extra[k])


def test_round_trip_keeps_values_axes_extra_and_provenance(tmp_path):
    t = _table()
    path = t.save(tmp_path / "t.npz")
    back = Table.load(path)
    _assert_same(t, back)
    # the arrays are the table's own: writable, aligned (no view of a closed file)
    assert back.values.flags.writeable and back.values.flags.aligned
    assert back.extra["weibull_a"].flags.f_contiguous
    # still a plain .npz: numpy reads it, and every member is stored, not deflated
    with zipfile.ZipFile(path) as zf:
        assert {i.compress_type for i in zf.infolist()} == {zipfile.ZIP_STORED}
    with np.load(path) as z:
        np.testing.assert_array_equal(z["values"], t.values)


def test_the_cache_keeps_its_hash_by_inputs_names(table_cache):
    t = _table()
    got, built = get_or_build(t.name, t.version, t.inputs, lambda: t)
    assert built
    path = cache_path(t.name, t.key)
    assert path.name == f"test_table-{store.inputs_hash(t.name, t.version, t.inputs)}.npz"
    again, built = get_or_build(t.name, t.version, t.inputs, lambda: pytest.fail("rebuilt"))
    assert not built
    _assert_same(t, again)


def test_a_compressed_file_of_the_old_layout_is_read_and_rewritten(table_cache):
    t = _table(2.0)
    path = cache_path(t.name, t.key)
    path.parent.mkdir(parents=True)
    # the writer before issue 27: np.savez_compressed of the same members
    meta = np.frombuffer(__import__("json").dumps(t.metadata()).encode(), dtype=np.uint8)
    arrays = {f"axis{i}": a for i, a in enumerate(t.axes)}
    np.savez_compressed(path, metadata=meta, values=t.values, **arrays,
                        **{f"extra_{k}": v for k, v in t.extra.items()})
    with zipfile.ZipFile(path) as zf:
        assert zipfile.ZIP_DEFLATED in {i.compress_type for i in zf.infolist()}
    got, built = get_or_build(t.name, t.version, t.inputs, lambda: pytest.fail("rebuilt"))
    assert not built
    _assert_same(t, got)
    with zipfile.ZipFile(path) as zf:  # rewritten for the next run
        assert {i.compress_type for i in zf.infolist()} == {zipfile.ZIP_STORED}
    _assert_same(t, Table.load(path))


def _truncate(path):
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def _flip_a_value_byte(path):
    # a byte inside the values array: only the CRC-32 can tell
    data = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo("values.npy")
    at = info.header_offset + 30 + len(info.filename) + len(info.extra) + info.file_size - 9
    data[at] ^= 0x10
    path.write_bytes(bytes(data))


def _garbage(path):
    path.write_bytes(b"not a table at all" * 10)


def _empty(path):
    path.write_bytes(b"")


@pytest.mark.parametrize("damage", [_truncate, _flip_a_value_byte, _garbage, _empty])
def test_a_damaged_file_is_rebuilt_not_crashed_on(table_cache, damage):
    t = _table(3.0)
    get_or_build(t.name, t.version, t.inputs, lambda: t)
    path = cache_path(t.name, t.key)
    damage(path)
    with pytest.raises((ValueError, OSError, zipfile.BadZipFile)):
        Table.load(path)
    calls = []

    def build():
        calls.append(1)
        return t

    with pytest.warns(TableCacheWarning, match="rebuilt"):
        got, built = get_or_build(t.name, t.version, t.inputs, build)
    assert built and calls == [1]
    _assert_same(t, got)
    _assert_same(t, Table.load(path))  # the cache holds a good file again


def test_a_file_whose_key_does_not_match_its_inputs_is_rebuilt(table_cache):
    t, other = _table(4.0), _table(5.0)
    path = cache_path(t.name, t.key)
    other.save(path)  # another table's contents under this key
    with pytest.warns(TableCacheWarning):
        got, built = get_or_build(t.name, t.version, t.inputs, lambda: t)
    assert built
    _assert_same(t, got)


def test_the_stacked_reader_interpolates_each_array_in_place():
    """StackedLookup2D: per point and array (real, complex, Fortran-ordered), the bilinear
    value Table.lookup gives (another formula: the same to rounding), NaN outside the grid,
    the azimuth wrapped; it reads the table's own arrays (no stacked copy, issue 27)."""
    t = _table()
    reader = store.StackedLookup2D(t, (None, "weibull_a", "field"), periodic1=True)
    r = np.array([0.0, 700.0, 1.5e3, 9.9e3, 1.0e4, -1.0, 2.0e4, np.nan])
    az = np.array([0.0, 1.0, 7.5, -0.3, 2 * np.pi, 0.5, 0.5, 0.5])
    got = reader(r, az)
    assert got.shape == (8, 3) and got.dtype == np.complex128
    wrapped = np.mod(az, 2 * np.pi)
    for k, name in enumerate(reader.names):
        want = t.lookup(r, wrapped, array=name)
        inside = np.isfinite(want)
        assert inside.tolist() == [True] * 5 + [False] * 3
        np.testing.assert_allclose(got[inside, k], want[inside], rtol=1e-12, atol=1e-12)
        assert np.isnan(got[~inside, k]).all()
    assert np.shares_memory(reader._flat[0], t.values)  # C-ordered: read in place
