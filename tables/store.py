"""Table file format, content-addressed cache and vectorized lookup.

A :class:`Table` is an N-dimensional array sampled on a rectilinear grid (one 1-D, strictly
increasing axis per dimension), with the axis names and units, the builder's name and version
and a dictionary of the inputs it was built from.  The cache key is a SHA-256 of exactly those
inputs (canonical JSON), the builder name and its version, so that a change of any input, or of
the builder, gives a new file and nothing stale is ever read (STYLE lesson 8).

Files are ``.npz`` (numpy's zip of arrays, any ``np.load`` reads them) with the metadata as a
JSON string; they are written to a temporary file and renamed, so a crash never leaves half a
table behind.  Since issue 27 every table is written *uncompressed* (zip "stored" members) and
read by :func:`_read_stored`: one ``readinto`` per array at its offset in the file and a CRC-32
check, at disk (page-cache) speed: the raid's ten tables (122 MB of arrays) load in about 0.04 s
instead of 0.3 s of zlib (docs/performance.md, "Start-up and table loading").  Files of the
compressed layout written before are still read (with ``np.load``) and rewritten uncompressed by
the cache (:func:`load_cached`); a damaged or unreadable cache file is rebuilt, with a
:class:`TableCacheWarning`.
"""

from __future__ import annotations

import hashlib
import json
import os
import struct
import tempfile
import warnings
import zipfile
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

#: Bump when the file layout changes.
FORMAT_VERSION = 1
#: Largest table file we agree to read [bytes] (files from outside are size-checked).
MAX_TABLE_BYTES = 2 * 1024**3




class TableCacheWarning(UserWarning):
    """A cached table file could not be read (damaged, truncated, foreign) and is rebuilt."""


def _savez_stored(path: str, arrays: dict[str, np.ndarray]) -> None:
    """``np.savez`` (uncompressed; the .npz layout, read by ``np.load`` and :func:`_read_stored`).

    Uncompressed because loading is what a run pays, every run: zlib took 0.2-0.7 s of the
    raid's start-up (and 21 s of the 28 s build of a 128-pulse stagger I_F table), zstd
    level 3 would still take 0.14 s; the file is as large as its arrays (at most
    MAX_TABLE_BYTES is read back).
    """
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_STORED, allowZip64=True) as zf:
        for name, arr in arrays.items():
            with zf.open(f"{name}.npy", "w", force_zip64=True) as f:
                np.lib.format.write_array(f, np.asanyarray(arr), allow_pickle=False)


def _read_stored(path: Path) -> dict[str, np.ndarray] | None:
    """The arrays of an uncompressed ``.npz``, each read once at its offset and CRC-checked.

    Returns ``None`` when a member is compressed (a file of the layout before issue 27: the
    caller reads it with ``np.load``).  Raises ``ValueError`` (or ``zipfile.BadZipFile``,
    ``OSError``) on anything damaged: a bad local header, an array header that does not
    match the member's size, a CRC-32 that does not match, an object dtype.
    """
    fmt = np.lib.format
    out: dict[str, np.ndarray] = {}
    with open(path, "rb") as f, zipfile.ZipFile(f) as zf:
        infos = zf.infolist()
        if any(i.compress_type != zipfile.ZIP_STORED for i in infos):
            return None
        for info in infos:
            if not info.filename.endswith(".npy"):
                raise ValueError(f"{path}: unexpected member {info.filename!r}")
            f.seek(info.header_offset)
            local = f.read(30)
            if len(local) != 30 or local[:4] != b"PK\x03\x04":
                raise ValueError(f"{path}: bad local header of {info.filename!r}")
            name_len, extra_len = struct.unpack("<HH", local[26:30])
            start = info.header_offset + 30 + name_len + extra_len
            f.seek(start)
            version = fmt.read_magic(f)
            read_header = fmt.read_array_header_1_0 if version == (1, 0) else \
                fmt.read_array_header_2_0
            shape, fortran, dtype = read_header(f)
            if dtype.hasobject:
                raise ValueError(f"{path}: {info.filename!r} holds Python objects")
            head = f.tell() - start
            count = int(np.prod(shape, dtype=np.int64))
            if head + count * dtype.itemsize != info.file_size:
                raise ValueError(f"{path}: {info.filename!r} is {info.file_size} bytes, its "
                                 f"header says {head + count * dtype.itemsize}")
            # one copy from the page cache into a buffer the array owns (writable, aligned:
            # numpy pads the header to 64 bytes)
            buf = np.empty(info.file_size, dtype=np.uint8)
            f.seek(start)
            if f.readinto(buf.data) != info.file_size:
                raise ValueError(f"{path}: {info.filename!r} is truncated")
            if zlib.crc32(buf.data) != info.CRC:
                raise ValueError(f"{path}: {info.filename!r} fails its CRC-32")
            arr = buf[head:].view(dtype)
            out[info.filename[:-4]] = arr.reshape(shape, order="F" if fortran else "C")
    return out


def _canonical(obj: Any) -> Any:
    """Turn numpy scalars/arrays and tuples into plain JSON types, recursively."""
    if isinstance(obj, dict):
        return {str(k): _canonical(v) for k, v in sorted(obj.items())}
    if isinstance(obj, (list, tuple)):
        return [_canonical(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [_canonical(v) for v in obj.tolist()]
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, float):
        # repr round-trips exactly; avoids 0.1+0.2 style drift between equal inputs
        return float(repr(obj))
    return obj


def inputs_hash(builder: str, version: int | str, inputs: dict[str, Any]) -> str:
    """SHA-256 (hex, first 20 characters) of a builder name, its version and its inputs."""
    doc = json.dumps(
        {"builder": builder, "version": str(version), "inputs": _canonical(inputs)},
        sort_keys=True,
        separators=(",", ":"),
    )
    return hashlib.sha256(doc.encode()).hexdigest()[:20]


@dataclass(frozen=True)
class Table:
    """A gridded table with provenance.

    Attributes
    ----------
    name : str
        Builder name, e.g. ``"propagation_factor"``.
    version : int
        Builder version; part of the cache key.
    axes : tuple of ndarray
        One strictly increasing 1-D axis per dimension of ``values``.
    axis_names, axis_units : tuple of str
        Names and units of the axes, e.g. ``("range_m", "height_m")``, ``("m", "m")``.
    values : ndarray
        The tabulated quantity, ``values.shape == tuple(len(a) for a in axes)``.
    value_name, value_unit : str
        Name and unit of the tabulated quantity.
    inputs : dict
        The inputs the table was built from (JSON-able); hashed into :attr:`key`.
    extra : dict of ndarray
        Further arrays on the same grid (e.g. the Weibull parameter beside σ0).
    attached : dict of ndarray
        Arrays of any shape the builder keeps beside the grid, for the lookups' own use (e.g.
        the processor's filter weights an I_F table was computed from).
    """

    name: str
    version: int
    axes: tuple[np.ndarray, ...]
    axis_names: tuple[str, ...]
    axis_units: tuple[str, ...]
    values: np.ndarray
    value_name: str
    value_unit: str
    inputs: dict[str, Any] = field(default_factory=dict)
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    attached: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not (len(self.axes) == len(self.axis_names) == len(self.axis_units)):
            raise ValueError("axes, axis_names and axis_units must have the same length")
        shape = tuple(len(a) for a in self.axes)
        if self.values.shape != shape:
            raise ValueError(f"values shape {self.values.shape} does not match axes {shape}")
        for arr_name, arr in self.extra.items():
            if arr.shape != shape:
                raise ValueError(f"extra[{arr_name!r}] shape {arr.shape} does not match {shape}")
        for n, a in zip(self.axis_names, self.axes, strict=True):
            if a.ndim != 1 or len(a) < 2 or not np.all(np.diff(a) > 0):
                raise ValueError(f"axis {n!r} must be 1-D, of length >= 2, strictly increasing")

    @property
    def key(self) -> str:
        """Cache key: hash of builder name, version and inputs."""
        return inputs_hash(self.name, self.version, self.inputs)

    def metadata(self) -> dict[str, Any]:
        return {
            "format_version": FORMAT_VERSION,
            "name": self.name,
            "version": self.version,
            "key": self.key,
            "axis_names": list(self.axis_names),
            "axis_units": list(self.axis_units),
            "value_name": self.value_name,
            "value_unit": self.value_unit,
            "inputs": _canonical(self.inputs),
            "extra": sorted(self.extra),
            "attached": sorted(self.attached),
        }

    # ------------------------------------------------------------------ file format
    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write atomically (temporary file + rename) and return the path."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays = {f"axis{i}": a for i, a in enumerate(self.axes)}
        arrays["values"] = self.values
        arrays.update({f"extra_{k}": v for k, v in self.extra.items()})
        arrays.update({f"attached_{k}": v for k, v in self.attached.items()})
        meta = np.frombuffer(json.dumps(self.metadata()).encode(), dtype=np.uint8)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp.npz")
        os.close(fd)
        try:
            _savez_stored(tmp, {"metadata": meta, **arrays})
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
        return path

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Table:
        """Read a table file written by :meth:`save` (size-checked, no pickles).

        Uncompressed files are read by :func:`_read_stored`; compressed ones (written before
        issue 27) by ``np.load``.
        """
        return cls._load(Path(path))[0]

    @classmethod
    def _load(cls, path: Path) -> tuple[Table, bool]:
        """:meth:`load`, and whether the file was of the compressed layout."""
        size = path.stat().st_size
        if size > MAX_TABLE_BYTES:
            raise ValueError(f"{path}: table file is {size} bytes, larger than {MAX_TABLE_BYTES}")
        z = _read_stored(path)
        compressed = z is None
        if z is None:
            with np.load(path, allow_pickle=False) as npz:
                z = {k: np.array(npz[k]) for k in npz.files}
        meta = json.loads(bytes(z["metadata"]).decode())
        if meta.get("format_version") != FORMAT_VERSION:
            raise ValueError(f"{path}: table format {meta.get('format_version')} not supported")
        n = len(meta["axis_names"])
        table = cls(
            name=meta["name"],
            version=int(meta["version"]),
            axes=tuple(z[f"axis{i}"] for i in range(n)),
            axis_names=tuple(meta["axis_names"]),
            axis_units=tuple(meta["axis_units"]),
            values=z["values"],
            value_name=meta["value_name"],
            value_unit=meta["value_unit"],
            inputs=meta["inputs"],
            extra={k: z[f"extra_{k}"] for k in meta["extra"]},
            attached={k: z[f"attached_{k}"] for k in meta.get("attached", [])},
        )
        if table.key != meta["key"]:
            raise ValueError(f"{path}: stored key {meta['key']} does not match its inputs")
        return table, compressed

    # ------------------------------------------------------------------ lookup
    def lookup(self, *coords: ArrayLike, array: str | None = None) -> np.ndarray:
        """Multilinear interpolation at broadcast coordinates; NaN outside the grid.

        Vectorized and O(1) per point (binary search on each axis).  ``array`` picks an
        entry of :attr:`extra` instead of :attr:`values`.
        """
        data = self.values if array is None else self.extra[array]
        return interp_grid(self.axes, data, *coords)

    def inside(self, *coords: ArrayLike) -> np.ndarray:
        """Boolean mask of the broadcast coordinates that lie inside the grid."""
        pts = np.broadcast_arrays(*[np.asarray(c, dtype=float) for c in coords])
        ok = np.ones(pts[0].shape, dtype=bool)
        for ax, p in zip(self.axes, pts, strict=True):
            ok &= (p >= ax[0]) & (p <= ax[-1])
        return ok


def interp_grid(axes: Sequence[np.ndarray], data: np.ndarray, *coords: ArrayLike) -> np.ndarray:
    """Multilinear interpolation of ``data`` on the rectilinear grid ``axes``.

    Points outside the grid (or NaN) give NaN, so that the caller can fall back to another
    model and count it.  Works for any number of dimensions and complex or real data.
    """
    if len(coords) != len(axes):
        raise ValueError(f"expected {len(axes)} coordinates, got {len(coords)}")
    pts = np.broadcast_arrays(*[np.asarray(c, dtype=float) for c in coords])
    shape = pts[0].shape
    flat = [p.ravel() for p in pts]
    n = flat[0].size
    outside = np.zeros(n, dtype=bool)
    idx = []
    frac = []
    for ax, p in zip(axes, flat, strict=True):
        bad = ~((p >= ax[0]) & (p <= ax[-1]))
        outside |= bad
        pc = np.where(bad, ax[0], p)
        i = np.clip(np.searchsorted(ax, pc, side="right") - 1, 0, len(ax) - 2)
        t = (pc - ax[i]) / (ax[i + 1] - ax[i])
        idx.append(i)
        frac.append(t)
    out = np.zeros(n, dtype=np.result_type(data.dtype, float))
    ndim = len(axes)
    for corner in range(1 << ndim):
        w = np.ones(n)
        sel = []
        for d in range(ndim):
            bit = (corner >> d) & 1
            w = w * (frac[d] if bit else 1.0 - frac[d])
            sel.append(idx[d] + bit)
        out += w * data[tuple(sel)]
    out[outside] = np.nan
    return out.reshape(shape)


def cache_dir() -> Path:
    """Directory of the table cache: ``$SHIPRADAR_TABLES`` or ``~/.cache/shipradar/tables``."""
    env = os.environ.get("SHIPRADAR_TABLES")
    if env:
        return Path(env)
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "shipradar" / "tables"


def cache_path(name: str, key: str, root: Path | None = None) -> Path:
    return (root or cache_dir()) / f"{name}-{key}.npz"


def is_cached(name: str, version: int, inputs: dict[str, Any], root: Path | None = None) -> bool:
    """Whether the table keyed by these inputs is in the cache (the key :func:`get_or_build`
    reads), without loading it."""
    return cache_path(name, inputs_hash(name, version, inputs), root).exists()


#: What reading a damaged cache file can raise (a truncated zip, a bad header, a CRC, bad
#: JSON, a missing member, a shape that does not match its axes).
_DAMAGED = (OSError, EOFError, ValueError, KeyError, zipfile.BadZipFile, json.JSONDecodeError)


def load_cached(name: str, version: int, inputs: dict[str, Any], root: Path | None = None):
    """Return the cached table for these inputs, or ``None`` if it has not been built.

    A file of the compressed layout (before issue 27) is rewritten uncompressed, so that the
    next run reads it at disk speed; a file that cannot be read is reported with a
    :class:`TableCacheWarning` and treated as absent (:func:`get_or_build` rebuilds it).
    """
    key = inputs_hash(name, version, inputs)
    path = cache_path(name, key, root)
    if not path.exists():
        return None
    try:
        table, compressed = Table._load(path)
        if table.key != key:
            raise ValueError(f"it holds the table of key {table.key}")
    except _DAMAGED as exc:
        warnings.warn(f"table cache file {path} cannot be read ({exc}); it is rebuilt",
                      TableCacheWarning, stacklevel=2)
        return None
    if compressed:
        try:
            table.save(path)
        except OSError:  # a read-only cache still serves the compressed file
            pass
    return table


def get_or_build(name: str, version: int, inputs: dict[str, Any], build, root: Path | None = None):
    """Load the table keyed by ``inputs`` from the cache, or call ``build()`` and store it.

    ``build`` is a zero-argument callable returning a :class:`Table` whose ``name``,
    ``version`` and ``inputs`` equal the arguments (checked, so the key cannot lie).
    Returns ``(table, built)`` where ``built`` tells whether the builder ran.
    """
    cached = load_cached(name, version, inputs, root)
    if cached is not None:
        return cached, False
    table = build()
    if table.key != inputs_hash(name, version, inputs):
        raise RuntimeError(f"builder for {name!r} returned a table with other inputs")
    table.save(cache_path(name, table.key, root))
    return table, True


class StackedLookup2D:
    """Bilinear interpolation of several arrays of one 2-D table at once.

    The on-line level reads several quantities of a clutter map at the same cells (power,
    spectrum mean and spread, Weibull a); computing the cell indices and weights once and
    gathering every array at them is several times cheaper than one :meth:`Table.lookup`
    per array.  Points outside the grid give NaN.

    The arrays are read where the table holds them, each gathered on its own: a stacked
    ``(n0, n1, k)`` copy, one row of k values per cell, cost 20-130 ms of the raid's start-up
    (60 MB for its two maps) while a whole run reads them at a few tens of thousands of
    points (1-3 ms of gathers either way).

    Parameters
    ----------
    table : a 2-D :class:`Table`
    arrays : names of the arrays to read, ``None`` for ``values``
    periodic1 : wrap the second coordinate into the axis span (azimuth tables)
    """

    def __init__(self, table: Table, arrays: Sequence[str | None], periodic1: bool = False):
        if len(table.axes) != 2:
            raise ValueError("StackedLookup2D needs a 2-D table")
        self.names = tuple(arrays)
        self.ax0, self.ax1 = table.axes
        self.periodic1 = periodic1
        # flat (n0 n1,) views of the table's arrays (a copy only of a Fortran-ordered one)
        self._flat = tuple(np.ravel(table.values if a is None else table.extra[a])
                           for a in self.names)
        self._dtype = np.result_type(float, *self._flat)

    def __call__(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        """``(N, len(arrays))`` interpolated values at the points (x0, x1)."""
        a0, a1 = self.ax0, self.ax1
        x0 = np.asarray(x0, dtype=float).ravel()
        x1 = np.asarray(x1, dtype=float).ravel()
        if self.periodic1:
            x1 = a1[0] + np.mod(x1 - a1[0], a1[-1] - a1[0])
        outside = ~((x0 >= a0[0]) & (x0 <= a0[-1]) & (x1 >= a1[0]) & (x1 <= a1[-1]))
        x0c = np.where(outside, a0[0], x0)
        x1c = np.where(outside, a1[0], x1)
        i = np.clip(np.searchsorted(a0, x0c, side="right") - 1, 0, len(a0) - 2)
        j = np.clip(np.searchsorted(a1, x1c, side="right") - 1, 0, len(a1) - 2)
        t = (x0c - a0[i]) / (a0[i + 1] - a0[i])
        u = (x1c - a1[j]) / (a1[j + 1] - a1[j])
        # the four corners of every point as (4, N) flat indices, gathered from each array
        # (``take`` on its flat view), one column of the result per array
        n1 = len(a1)
        f = i * n1 + j
        corners = np.stack((f, f + 1, f + n1, f + (n1 + 1)))
        t1, u1 = 1 - t, 1 - u
        out = np.empty((x0.size, len(self._flat)), dtype=self._dtype)
        for k, a in enumerate(self._flat):
            c = a.take(corners)
            out[:, k] = t1 * (u1 * c[0] + u * c[1]) + t * (u1 * c[2] + u * c[3])
        out[outside] = np.nan
        return out
