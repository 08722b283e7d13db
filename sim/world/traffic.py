"""Recorded traffic as targets, and the scene's target catalogue.

A scenario's ``traffic:`` entries (:class:`shipradar.sim.world.scenario.Traffic`) name CSV or
Parquet files of timed positions of many targets: the public US AIS extracts (MarineCadastre),
OpenSky's ADS-B state vectors, or the project's ``plain`` columns.  Each id of a file becomes a
target, beside the scenario's own ``targets:``; :func:`scene_targets` gives every target of a
scene (ids, names, kinds, RCS models, Swerling cases) and their motion in one
:class:`SceneTargets`.

Motion between fixes (the issue's "smooth in position and velocity"):

* a cubic Hermite curve on each interval between two fixes of an id, matching the two fixes'
  positions and velocities, so position and velocity are continuous at every fix;
* the horizontal velocity at a fix is the reported speed and course (AIS SOG/COG, ADS-B
  velocity/heading) where the file has them; where it does not (``plain`` files, AIS's
  "not available" codes 102.3 kn and 360°), the derivative of the monotone piecewise-cubic
  interpolant (Fritsch & Carlson 1980; the derivatives of
  ``scipy.interpolate.PchipInterpolator``, computed here for every id at once and tested
  against it), which keeps each coordinate between its neighbouring fixes;
* the altitude uses the reported vertical rate (ADS-B vertrate) limited to Fritsch and
  Carlson's monotone region (zero where the neighbouring slopes change sign, at most three
  times the smaller one), else the same monotone derivative: a climb never overshoots its
  fixes, and a target never goes below the lowest fix around it (the sea for ships);
* two fixes further apart than ``max_gap_s`` leave the target inactive between them (it is
  neither seen nor drawn; the truth topic shows it inactive), and nothing is extrapolated
  before the first fix or after the last.

The positions are those of the scenario's local frame
(:class:`shipradar.sim.world.kinematics.LocalFrame`); a reported velocity (true north/east at
the fix) is carried into it by the frame's own projection (a central difference of half a
second each side, exact to ~1e-9 relative).
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from shipradar.sim.world import geodesy
from shipradar.sim.world.errors import BadInputError
from shipradar.sim.world.kinematics import (
    LINEAR,
    LocalFrame,
    Trajectories,
    piece_state,
    pieces_max_speed,
)
from shipradar.sim.world.scenario import Rcs, Scenario, Target, Traffic, swerling_case

if TYPE_CHECKING:
    import pyarrow as pa

__all__ = ["CUBIC", "MotionTable", "PieceTable", "SceneTargets", "TrafficError",
           "hermite_coefficients", "monotone_slopes", "scene_targets"]

#: Piece kind of :class:`PieceTable` beside kinematics' LINEAR/ARC/SINE: p0 + v0 τ + c2 τ²
#: + c3 τ³ (a cubic Hermite interval between two fixes).
CUBIC = 3
#: Knot [m/s] (exactly 1852 m per hour).
KNOT_MPS = 1852.0 / 3600.0
#: AIS "speed not available" (ITU-R M.1371: SOG 1023 in 0.1 kn) and above [kn].
AIS_SOG_NOT_AVAILABLE_KN = 102.3
#: AIS "course not available" (COG 3600 in 0.1°) [deg].
AIS_COG_NOT_AVAILABLE_DEG = 360.0
#: Half-step of the central difference that carries a reported velocity into the local
#: frame [s].
_VELOCITY_STEP_S = 0.5
_SPEED_UNITS = {"mps": 1.0, "knots": KNOT_MPS, "kmh": 1000.0 / 3600.0}


class TrafficError(ValueError, BadInputError):
    """A traffic file that cannot be used: one line naming the field, the value and what is
    allowed (the command line prints it and exits 2)."""


# --------------------------------------------------------------------------- interpolation
def monotone_slopes(t: np.ndarray, y: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Derivatives at the knots of the monotone piecewise-cubic interpolant (Fritsch-Carlson).

    The same derivatives as ``scipy.interpolate.PchipInterpolator`` (its ``derivative()`` at
    the knots; tests/test_traffic.py compares them): at an interior knot the weighted
    harmonic mean of the two neighbouring slopes (Fritsch and Butland), 0 where they differ
    in sign or one is 0; at an end the one-sided three-point estimate, shape-preserving
    (:func:`_edge_slope`); a run of two knots gets the chord's slope.

    Parameters
    ----------
    t : (K,) knot times [s], increasing strictly within each run
    y : (K, D) values at the knots (any unit)
    starts : (R + 1,) index of each run's first knot and K at the end; runs of >= 2 knots

    Returns
    -------
    (K, D) derivatives [unit/s]

    References: F. N. Fritsch and R. E. Carlson, "Monotone piecewise cubic interpolation",
    SIAM J. Numer. Anal. 17 (2), 238-246 (1980); F. N. Fritsch and J. Butland, "A method for
    constructing local monotone piecewise cubic interpolants", SIAM J. Sci. Stat. Comput. 5
    (2), 300-304 (1984).
    """
    k = t.size
    d = np.zeros_like(y)
    if k < 2:
        return d
    h = np.diff(t)
    delta = np.diff(y, axis=0) / h[:, None]
    first = np.zeros(k, dtype=bool)
    first[starts[:-1]] = True
    last = np.zeros(k, dtype=bool)
    last[starts[1:] - 1] = True
    interior = ~first & ~last
    # interior knots i: slopes delta[i-1], delta[i], steps h[i-1], h[i]
    i = np.flatnonzero(interior)
    if i.size:
        m0, m1 = delta[i - 1], delta[i]
        h0, h1 = h[i - 1][:, None], h[i][:, None]
        w1, w2 = 2.0 * h1 + h0, h1 + 2.0 * h0
        same = (np.sign(m0) == np.sign(m1)) & (m0 != 0.0) & (m1 != 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = (w1 / np.where(same, m0, 1.0) + w2 / np.where(same, m1, 1.0)) / (w1 + w2)
            d[i] = np.where(same, 1.0 / inv, 0.0)
    # ends: runs of two knots take the chord; longer runs the three-point edge formula
    n_run = np.diff(starts)
    two = n_run == 2
    s2 = starts[:-1][two]
    d[s2] = delta[s2]
    d[s2 + 1] = delta[s2]
    longer = ~two
    a = starts[:-1][longer]  # first knots
    if a.size:
        d[a] = _edge_slope(h[a], h[a + 1], delta[a], delta[a + 1])
    b = starts[1:][longer] - 1  # last knots
    if b.size:
        d[b] = _edge_slope(h[b - 1], h[b - 2], delta[b - 1], delta[b - 2])
    return d


def _edge_slope(h0: np.ndarray, h1: np.ndarray, m0: np.ndarray, m1: np.ndarray) -> np.ndarray:
    """The derivative at the end knot of a run of >= 3: the non-centred three-point formula
    d = ((2 h0 + h1) m0 - h0 m1)/(h0 + h1), with h0, m0 the step [s] and slope of the end
    interval and h1, m1 those of its neighbour; set to 0 when its sign differs from m0's,
    and to 3 m0 when m0 and m1 differ in sign and |d| > 3 |m0| (shape-preserving).

    C. Moler, *Numerical Computing with MATLAB* (SIAM, 2004), ch. 3 (``pchiptx``'s
    ``pchipend``); the end rule of scipy's ``PchipInterpolator``, which cites it.
    """
    h0, h1 = h0[:, None], h1[:, None]
    d = ((2.0 * h0 + h1) * m0 - h0 * m1) / (h0 + h1)
    wrong = np.sign(d) != np.sign(m0)
    over = (np.sign(m0) != np.sign(m1)) & (np.abs(d) > 3.0 * np.abs(m0))
    return np.where(wrong, 0.0, np.where(over, 3.0 * m0, d))


def limited_slopes(t: np.ndarray, y: np.ndarray, given: np.ndarray,
                   starts: np.ndarray) -> np.ndarray:
    """Reported derivatives ``given`` (NaN: not reported) limited to Fritsch and Carlson's
    monotone region: 0 at a knot whose neighbouring slopes differ in sign or vanish, else
    the sign of the slopes and at most 3 times the smaller (their sufficient condition, so
    the Hermite curve stays between its fixes); a NaN takes :func:`monotone_slopes`.

    ``t`` (K,), ``y`` (K,), ``given`` (K,), ``starts`` as in :func:`monotone_slopes`.
    """
    pchip = monotone_slopes(t, y[:, None], starts)[:, 0]
    out = np.where(np.isnan(given), pchip, given)
    if t.size < 2:
        return out
    delta = np.diff(y) / np.diff(t)
    first = np.zeros(t.size, dtype=bool)
    first[starts[:-1]] = True
    last = np.zeros(t.size, dtype=bool)
    last[starts[1:] - 1] = True
    left = np.where(first, np.nan, np.concatenate([[np.nan], delta]))
    right = np.where(last, np.nan, np.concatenate([delta, [np.nan]]))
    left = np.where(np.isnan(left), right, left)
    right = np.where(np.isnan(right), left, right)
    same = (np.sign(left) == np.sign(right)) & (left != 0.0)
    bound = 3.0 * np.minimum(np.abs(left), np.abs(right))
    limited = np.where(same, np.sign(left) * np.clip(np.sign(left) * out, 0.0, bound), 0.0)
    return np.where(np.isnan(given), pchip, limited)


def hermite_coefficients(p0: np.ndarray, p1: np.ndarray, v0: np.ndarray, v1: np.ndarray,
                         h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """c2, c3 of the cubic p0 + v0 τ + c2 τ² + c3 τ³ on [0, h] with end position ``p1`` and
    end velocity ``v1``: c2 = (3 Δ/h - 2 v0 - v1)/h, c3 = (v0 + v1 - 2 Δ/h)/h², Δ = p1 - p0.

    ``p0, p1`` (M, 3) [m], ``v0, v1`` (M, 3) [m/s], ``h`` (M,) [s] > 0.
    """
    hh = h[:, None]
    chord = (p1 - p0) / hh
    return (3.0 * chord - 2.0 * v0 - v1) / hh, (v0 + v1 - 2.0 * chord) / (hh * hh)


# --------------------------------------------------------------------------- the piece table
class MotionTable:
    """The motion interface shared by the target tables that compute their accelerations
    with their states (:class:`PieceTable`, :class:`shipradar.sim.world.live.LiveTargets`):
    :meth:`state` is :meth:`state_acc` without the accelerations."""

    def state(self, t: ArrayLike, rows: ArrayLike | None = None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions (M, 3) [m], velocities (M, 3) [m/s] and activity (M,) of objects
        ``rows`` (all when None) at times ``t`` [s] (a scalar or one per row)."""
        pos, vel, _, active = self.state_acc(t, rows, accel=False)
        return pos, vel, active

    def state_acc(self, t: ArrayLike, rows: ArrayLike | None = None, accel: bool = True
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
        """:meth:`state` with the accelerations (M, 3) [m/s²] third (None unless ``accel``)."""
        raise NotImplementedError

    @staticmethod
    def _rows_times(n: int, t: ArrayLike, rows: ArrayLike | None
                    ) -> tuple[np.ndarray, np.ndarray]:
        """``rows`` as an index array (all ``n`` objects when None) and ``t`` broadcast
        to it."""
        rows = np.arange(n) if rows is None else np.asarray(rows, dtype=np.int64)
        return rows, np.broadcast_to(np.asarray(t, dtype=float), rows.shape)


class PieceTable(MotionTable):
    """Trajectories of N objects, each a ragged list of pieces, evaluated for all at once.

    The interface of :class:`shipradar.sim.world.kinematics.Trajectories` (``n``, ``hold``,
    ``t_first``, ``t_last``, :meth:`state`, :meth:`state_acc`) over flat arrays: object i
    owns pieces ``offsets[i]:offsets[i + 1]``, so a file with one long track and many short
    ones costs its rows, not objects × the longest track.  A piece is :data:`CUBIC` (p0 + v0
    τ + c2 τ² + c3 τ³, ``par`` = c2, c3) or one of kinematics' LINEAR/ARC/SINE (evaluated by
    :func:`shipradar.sim.world.kinematics.piece_state`); a piece with ``live`` False is a gap:
    the object moves on it (linearly, so the beam-crossing search stays smooth) but is
    inactive.  Targets only (not held outside their times).
    """

    hold = False

    def __init__(self, offsets: np.ndarray, t0: np.ndarray, dt: np.ndarray, p0: np.ndarray,
                 v0: np.ndarray, kind: np.ndarray, par: np.ndarray, live: np.ndarray):
        self.offsets = np.asarray(offsets, dtype=np.int64)
        self.n = self.offsets.size - 1
        self.t0, self.dt = np.asarray(t0, float), np.asarray(dt, float)
        self.p0, self.v0 = np.asarray(p0, float), np.asarray(v0, float)
        self.kind = np.asarray(kind, np.int8)
        self.par, self.live = np.asarray(par, float), np.asarray(live, bool)
        last = self.offsets[1:] - 1
        self.t_first = self.t0[self.offsets[:-1]] if self.n else np.zeros(0)
        self.t_last = self.t0[last] + self.dt[last] if self.n else np.zeros(0)
        self._only_cubic = bool(np.all((self.kind == CUBIC) | (self.kind == LINEAR)))
        self.max_pieces = int(np.diff(self.offsets).max()) if self.n else 0
        #: a bound on each object's horizontal speed [m/s] (the beam-crossing search's bound
        #: on its angular rate): a cubic piece's |v0| + 2|c2| dt + 3|c3| dt²
        speed = pieces_max_speed(self.kind, self.v0, self.par, self.dt)
        c2, c3 = np.hypot(self.par[:, 0], self.par[:, 1]), np.hypot(self.par[:, 3], self.par[:, 4])
        cubic = np.hypot(self.v0[:, 0], self.v0[:, 1]) + self.dt * (2.0 * c2 + 3.0 * self.dt * c3)
        speed = np.where(self.kind == CUBIC, cubic, speed)
        self.max_speed = (np.maximum.reduceat(speed, self.offsets[:-1]) if self.n and speed.size
                          else np.zeros(self.n))

    @property
    def nbytes(self) -> int:
        """Memory of the arrays [bytes]."""
        return sum(a.nbytes for a in (self.offsets, self.t0, self.dt, self.p0, self.v0,
                                      self.kind, self.par, self.live))

    def piece_index(self, t: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """The piece of each object ``rows`` at times ``t``: the last one starting at or
        before t (the first before the track), found by a vectorized bisection."""
        lo = self.offsets[rows].copy()
        hi = self.offsets[rows + 1] - 1
        todo = np.flatnonzero(lo < hi)
        while todo.size:
            mid = (lo[todo] + hi[todo] + 1) // 2
            ok = self.t0[mid] <= t[todo]
            lo[todo] = np.where(ok, mid, lo[todo])
            hi[todo] = np.where(ok, hi[todo], mid - 1)
            todo = todo[lo[todo] < hi[todo]]
        return lo

    def state_acc(self, t: ArrayLike, rows: ArrayLike | None = None, accel: bool = True
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
        """:meth:`state` with the accelerations (M, 3) [m/s²] third (None unless ``accel``)."""
        rows, t = self._rows_times(self.n, t, rows)
        j = self.piece_index(t, rows)
        tau = np.minimum(np.maximum(t - self.t0[j], 0.0), self.dt[j])
        p0, v0, par = self.p0[j], self.v0[j], self.par[j]
        kind = self.kind[j]
        c2, c3 = par[:, :3], par[:, 3:]
        cub = (kind == CUBIC)[:, None]
        tt = tau[:, None]
        pos = p0 + tt * (v0 + tt * np.where(cub, c2 + tt * c3, 0.0))
        vel = v0 + np.where(cub, tt * (2.0 * c2 + 3.0 * tt * c3), 0.0)
        acc = np.where(cub, 2.0 * c2 + 6.0 * tt * c3, 0.0) if accel else None
        if not self._only_cubic:
            other = np.flatnonzero((kind != CUBIC) & (kind != LINEAR))
            if other.size:
                p, v, a = piece_state(p0[other], v0[other], kind[other], par[other],
                                      tau[other], accel=accel)
                pos[other], vel[other] = p, v
                if acc is not None:
                    acc[other] = a
        active = (t >= self.t_first[rows]) & (t <= self.t_last[rows]) & self.live[j]
        return pos, vel, acc, active


def _yaml_piece_rows(targets: list[Target], frame: LocalFrame) -> dict[str, list]:
    """The scenario's own targets as rows of a :class:`PieceTable` (their analytic pieces,
    :func:`shipradar.sim.world.trajectory.object_pieces`)."""
    from shipradar.sim.world.trajectory import object_pieces

    out: dict[str, list] = {k: [] for k in ("count", "t0", "dt", "p0", "v0", "kind", "par")}
    for target in targets:
        pieces = object_pieces(target, frame)
        out["count"].append(len(pieces))
        for p in pieces:
            out["t0"].append(p.t0)
            out["dt"].append(p.dt)
            out["p0"].append(p.p0)
            out["v0"].append(p.vel)
            out["kind"].append(p.kind)
            out["par"].append(p.par)
    return out


# --------------------------------------------------------------------------- reading a file
@dataclass
class TrafficTracks:
    """The targets of one traffic file, as flat arrays (the pieces of a :class:`PieceTable`).

    ``ids``, ``names``, ``classes`` one per target; ``offsets`` (N + 1,) its pieces; ``t0``,
    ``dt``, ``p0``, ``v0``, ``kind``, ``par``, ``live`` one per piece; ``max_altitude_m`` the
    highest fix [m]; ``dropped`` rows left out, by reason; ``rows`` rows read.
    """

    ids: list[str]
    names: list[str]
    classes: list[str | None]
    offsets: np.ndarray
    t0: np.ndarray
    dt: np.ndarray
    p0: np.ndarray
    v0: np.ndarray
    kind: np.ndarray
    par: np.ndarray
    live: np.ndarray
    max_altitude_m: float
    rows: int
    dropped: dict[str, int] = field(default_factory=dict)
    fixes_en: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))


def _where(index: int, key: str) -> str:
    return f"traffic[{index}].{key}"


def _read_table(entry: Traffic, index: int, names: dict[str, Any]) -> pa.Table:
    """The file's columns that ``names`` asks for, as a pyarrow Table (limits checked)."""
    import pyarrow as pa

    path = Path(entry.path)
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise TrafficError(f"{_where(index, 'path')}: cannot read {entry.path!r} "
                           f"({exc.strerror})") from None
    lim = entry.limits
    if size > lim.max_bytes:
        raise TrafficError(f"{_where(index, 'path')}: {entry.path!r} is {size} bytes, must be "
                           f"<= limits.max_bytes {lim.max_bytes}")
    wanted: list[str] = []
    for v in names.values():
        for c in (v if isinstance(v, list) else [v]):
            if c is not None and c not in wanted:
                wanted.append(c)
    parquet = path.suffix.lower() in (".parquet", ".pq")
    try:
        if parquet:
            import pyarrow.parquet as pq

            meta = pq.ParquetFile(path)
            if meta.metadata.num_rows > lim.max_rows:
                raise TrafficError(
                    f"{_where(index, 'path')}: {entry.path!r} has {meta.metadata.num_rows} "
                    f"rows, must be <= limits.max_rows {lim.max_rows}")
            present = set(meta.schema_arrow.names)
            table = pq.read_table(path, columns=[c for c in wanted if c in present])
        else:
            import pyarrow.csv as pcsv

            text_cols = [names[k] for k in ("id", "name", "class_") if names.get(k)]
            if names.get("time") and names["time_unit"] == "iso":
                text_cols.append(names["time"])
            header = _csv_header(path)
            present = set(header)
            types = {c: pa.string() for c in text_cols if c in present}
            table = pcsv.read_csv(path, convert_options=pcsv.ConvertOptions(
                include_columns=[c for c in wanted if c in present], column_types=types,
                strings_can_be_null=True))
    except TrafficError:
        raise
    except (OSError, pa.ArrowInvalid, pa.ArrowTypeError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise TrafficError(f"{_where(index, 'path')}: {entry.path!r} is not a readable "
                           f"{'Parquet' if parquet else 'CSV'} file ({first})") from None
    if table.num_rows > lim.max_rows:
        raise TrafficError(f"{_where(index, 'path')}: {entry.path!r} has {table.num_rows} "
                           f"rows, must be <= limits.max_rows {lim.max_rows}")
    for key in ("id", "lat", "lon"):
        if names.get(key) not in present:
            raise TrafficError(
                f"{_where(index, 'columns.' + key)}: column {names.get(key)!r} is not in "
                f"{entry.path!r} (its columns: {', '.join(sorted(present))[:200]})")
    if not ((names.get("time") in present) or (names.get("time_s") in present)):
        want = names.get("time") or names.get("time_s")
        raise TrafficError(
            f"{_where(index, 'columns.time')}: column {want!r} is not in {entry.path!r} (give "
            f"columns.time or columns.time_s; its columns: {', '.join(sorted(present))[:200]})")
    return table


def _csv_header(path: Path) -> list[str]:
    """The column names of a CSV file (its first line, through pyarrow's own parser)."""
    import pyarrow.csv as pcsv

    reader = pcsv.open_csv(path, read_options=pcsv.ReadOptions(block_size=1 << 16))
    return list(reader.schema.names)


def _float_column(table: pa.Table, name: str | None, where: str = "") -> np.ndarray | None:
    """A numeric column as float64 (NaN where missing); None when the file lacks it.

    Raises
    ------
    TrafficError
        If the column holds text that is not a number (``where`` names the field).
    """
    import pyarrow as pa
    import pyarrow.compute as pc

    if name is None or name not in table.column_names:
        return None
    col = table.column(name)
    if not (pa.types.is_floating(col.type) or pa.types.is_integer(col.type)):
        try:
            col = pc.cast(col, pa.float64(), safe=False)
        except (pa.ArrowInvalid, pa.ArrowNotImplementedError) as exc:
            first = str(exc).strip().splitlines()[0][:120]
            raise TrafficError(f"{where}: column {name!r} must hold numbers ({first})"
                               ) from None
    return np.asarray(col.to_numpy(zero_copy_only=False), dtype=float)


def _text_column(table: pa.Table, name: str | None) -> np.ndarray | None:
    import pyarrow as pa
    import pyarrow.compute as pc

    if name is None or name not in table.column_names:
        return None
    col = table.column(name)
    if not pa.types.is_string(col.type):
        col = pc.cast(col, pa.string())
    return np.asarray(col.to_numpy(zero_copy_only=False), dtype=object)


def _times_s(table: pa.Table, entry: Traffic, index: int, names: dict[str, Any],
             scenario: Scenario) -> np.ndarray:
    """Scenario time of each row [s] (NaN where missing), alignment and offset applied."""
    import pyarrow as pa
    import pyarrow.compute as pc

    if names.get("time_s") in table.column_names:
        t = _float_column(table, names["time_s"], _where(index, "columns.time_s"))
        assert t is not None
        return t + entry.time_offset_s
    name = names["time"]
    col = table.column(name)
    start_ns = int(scenario.start_time.timestamp()) * 10**9 + \
        scenario.start_time.microsecond * 1000
    if names["time_unit"] == "unix" and not pa.types.is_timestamp(col.type):
        t = _float_column(table, name, _where(index, "columns.time"))
        assert t is not None
        t = t - start_ns / 1e9
    else:
        if not pa.types.is_timestamp(col.type):
            col = pc.cast(col, pa.string())
            try:
                col = pc.cast(col, pa.timestamp("ns"))
            except pa.ArrowInvalid:
                try:
                    col = pc.cast(col, pa.timestamp("ns", tz="UTC"))
                except pa.ArrowInvalid as exc:
                    raise TrafficError(
                        f"{_where(index, 'columns.time')}: column {name!r} must hold ISO 8601 "
                        f"UTC times (2026-06-01T12:00:00 or with Z); {str(exc)[:160]}"
                    ) from None
        ns = pc.cast(pc.cast(col, pa.timestamp("ns", tz=col.type.tz)), pa.int64())
        missing = np.asarray(pc.is_null(ns).to_numpy(zero_copy_only=False), dtype=bool)
        whole = np.asarray(pc.fill_null(ns, 0).to_numpy(zero_copy_only=False), dtype=np.int64)
        # the difference in integer nanoseconds first: 1.7e18 ns as a float is 256 ns coarse
        t = np.where(missing, np.nan, (whole - start_ns).astype(float) / 1e9)
    if entry.align == "first_fix":
        ok = np.isfinite(t)
        if ok.any():
            t = t - t[ok].min()
    return t + entry.time_offset_s


def local_positions(frame: LocalFrame, lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """East/north [m] in the scenario frame of latitudes, longitudes [deg] (the projection of
    :meth:`LocalFrame.en_of_geodetic`, for arrays)."""
    x = np.column_stack(geodesy.geodetic2ecef(lat, lon, np.zeros_like(lat))) - frame.centre
    u = x / np.linalg.norm(x, axis=1, keepdims=True)
    t = u * (frame.radius / (u @ frame.up0))[:, None]
    return np.column_stack([t @ frame.east0, t @ frame.north0])


def _reported_velocity(frame: LocalFrame, lat: np.ndarray, lon: np.ndarray,
                       v_east: np.ndarray, v_north: np.ndarray) -> np.ndarray:
    """A velocity reported in true east/north at a fix [m/s], carried into the scenario
    frame's east/north by the frame's projection (central difference over ±0.5 s along the
    ellipsoid's meridian and prime-vertical radii)."""
    a, b = geodesy.WGS84_A_M, geodesy.WGS84_B_M
    e2 = 1.0 - (b / a) ** 2
    phi = np.radians(lat)
    w = 1.0 - e2 * np.sin(phi) ** 2
    m = a * (1.0 - e2) / w**1.5
    n = a / np.sqrt(w)
    h = _VELOCITY_STEP_S
    dlat = np.degrees(v_north * h / m)
    dlon = np.degrees(v_east * h / (n * np.cos(phi)))
    fwd = local_positions(frame, lat + dlat, lon + dlon)
    back = local_positions(frame, lat - dlat, lon - dlon)
    return (fwd - back) / (2.0 * h)


def read_traffic(entry: Traffic, index: int, scenario: Scenario,
                 frame: LocalFrame) -> TrafficTracks:
    """The targets of traffic entry ``index`` of ``scenario``: read, filtered, and turned
    into Hermite pieces in ``frame``.

    Raises
    ------
    TrafficError
        On a missing or unreadable file, a missing column, a file over its ``limits``.
    """
    names = entry.column_names()
    table = _read_table(entry, index, names)
    columns = _file_columns(table, entry, index, names, scenario)
    dropped: dict[str, int] = {}
    rows, code = _kept_rows(columns, entry, index, dropped)
    runs = _runs(columns, rows, code, frame, entry.max_gap_s, dropped)
    v = _fix_velocities(columns, runs, frame, names["speed_unit"])
    return _tracks(entry, columns, runs, v, table.num_rows, dropped)


@dataclass(frozen=True)
class _Columns:
    """What :func:`read_traffic` reads of a file, one entry per row: ``ids`` (object, None
    where missing), scenario time ``t`` [s], ``lat``, ``lon`` [deg], ``alt`` [m] (NaN where
    missing); ``speed`` [the file's unit], ``course`` [deg], ``vrate`` [m/s] and the
    ``name_text`` and ``class_text``, None when the file has no such column."""

    ids: np.ndarray
    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    alt: np.ndarray
    speed: np.ndarray | None
    course: np.ndarray | None
    vrate: np.ndarray | None
    name_text: np.ndarray | None
    class_text: np.ndarray | None


@dataclass(frozen=True)
class _Runs:
    """The fixes kept, by id then time, in runs of >= 2 (an id's fixes split where two are
    more than ``max_gap_s`` apart): each fix's file ``rows``, time ``t`` [s] and position
    ``pos`` (K, 3) [m]; ``new_id`` marks an id's first fix, ``gap`` the first after a gap;
    ``starts`` (R + 1,) each run's first fix and K."""

    rows: np.ndarray
    t: np.ndarray
    pos: np.ndarray
    new_id: np.ndarray
    gap: np.ndarray
    starts: np.ndarray


def _count_dropped(dropped: dict[str, int], kept: np.ndarray, reason: str) -> None:
    """Count the rows ``kept`` is false for in ``dropped[reason]``."""
    k = int(np.count_nonzero(~kept))
    if k:
        dropped[reason] = dropped.get(reason, 0) + k


def _file_columns(table: pa.Table, entry: Traffic, index: int, names: dict[str, Any],
                  scenario: Scenario) -> _Columns:
    """The columns of ``table`` that ``names`` asks for (numbers as float64, NaN where
    missing), times in the scenario's time [s]."""
    ids = _text_column(table, names["id"])
    t = _times_s(table, entry, index, names, scenario)
    lat = _float_column(table, names["lat"], _where(index, "columns.lat"))
    lon = _float_column(table, names["lon"], _where(index, "columns.lon"))
    assert ids is not None and lat is not None and lon is not None  # checked by _read_table
    return _Columns(
        ids=ids, t=t, lat=lat, lon=lon, alt=_altitudes(table, entry, index, names),
        speed=_float_column(table, names.get("speed"), _where(index, "columns.speed")),
        course=_float_column(table, names.get("course"), _where(index, "columns.course")),
        vrate=_float_column(table, names.get("vertical_rate"),
                            _where(index, "columns.vertical_rate")),
        name_text=_text_column(table, names.get("name")),
        class_text=_text_column(table, names.get("class_")))


def _altitudes(table: pa.Table, entry: Traffic, index: int, names: dict[str, Any]
               ) -> np.ndarray:
    """Each row's altitude [m]: 0 when the preset has no altitude, else the first of its
    altitude columns that has a value (ADS-B: geo-, then barometric), NaN where none has."""
    alt_names = names.get("alt")
    if alt_names is None:
        return np.zeros(table.num_rows)
    alt_names = alt_names if isinstance(alt_names, list) else [alt_names]
    cols = [_float_column(table, c, _where(index, "columns.alt")) for c in alt_names
            if c in table.column_names]
    if not cols:
        raise TrafficError(f"{_where(index, 'columns.alt')}: no column {alt_names!r} in "
                           f"{entry.path!r}")
    alt = np.full(table.num_rows, np.nan)
    for c in cols:
        assert c is not None
        alt = np.where(np.isnan(alt), c, alt)
    return alt


def _kept_rows(c: _Columns, entry: Traffic, index: int, dropped: dict[str, int]
               ) -> tuple[np.ndarray, np.ndarray]:
    """The rows kept (usable, within the entry's ids and window, one per id and time),
    sorted by id then time, and each one's id code; the others counted in ``dropped``.

    Raises
    ------
    TrafficError
        When more ids than ``limits.max_ids`` are left.
    """
    keep = np.array([v is not None for v in c.ids], dtype=bool)
    _count_dropped(dropped, keep, "no id")
    for ok, reason in (
            (np.isfinite(c.t), "no time"),
            (np.isfinite(c.lat) & np.isfinite(c.lon) & (np.abs(c.lat) <= 90.0)
             & (np.abs(c.lon) <= 180.0), "no position"),
            (np.isfinite(c.alt) & (c.alt >= -500.0) & (c.alt <= 30_000.0),
             "altitude missing or outside [-500, 30000] m")):
        _count_dropped(dropped, ok | ~keep, reason)  # each row counted for its first reason
        keep &= ok
    if entry.ids is not None:
        wanted = set(entry.ids)
        keep &= np.array([v in wanted for v in c.ids], dtype=bool)
    if entry.window_start_s is not None:
        keep &= c.t >= entry.window_start_s
    if entry.window_end_s is not None:
        keep &= c.t <= entry.window_end_s
    rows = np.flatnonzero(keep)
    uniq, code = np.unique(c.ids[rows].astype(str), return_inverse=True)
    if uniq.size > entry.limits.max_ids:
        raise TrafficError(f"{_where(index, 'path')}: {entry.path!r} has {uniq.size} ids "
                           f"after its filters, must be <= limits.max_ids "
                           f"{entry.limits.max_ids}")
    order = np.lexsort((c.t[rows], code))
    rows, code = rows[order], code[order]
    tr = c.t[rows]
    # one fix per (id, time): a repeated time keeps the file's first row
    dup = np.zeros(rows.size, dtype=bool)
    dup[1:] = (code[1:] == code[:-1]) & (tr[1:] == tr[:-1])
    _count_dropped(dropped, ~dup, "repeated time")
    return rows[~dup], code[~dup]


def _run_marks(code: np.ndarray, t: np.ndarray, max_gap_s: float
               ) -> tuple[np.ndarray, np.ndarray]:
    """Of fixes sorted by id ``code`` then time ``t`` [s]: an id's first fix, and the first
    fix after a gap longer than ``max_gap_s`` [s] (bool (K,) each)."""
    new_id = np.ones(code.size, dtype=bool)
    new_id[1:] = code[1:] != code[:-1]
    gap = np.zeros(code.size, dtype=bool)
    gap[1:] = ~new_id[1:] & (np.diff(t) > max_gap_s)
    return new_id, gap


def _runs(c: _Columns, rows: np.ndarray, code: np.ndarray, frame: LocalFrame,
          max_gap_s: float, dropped: dict[str, int]) -> _Runs:
    """The kept ``rows`` (id ``code``) in ``frame``, cut into runs of consecutive fixes of
    one id no more than ``max_gap_s`` [s] apart; lone fixes counted in ``dropped``."""
    tr = c.t[rows]
    # heights above the sea (>= 0) for the radar model: a fix a little below the surface
    # (an ellipsoid height, a barometric offset) is at the surface
    alt = np.maximum(c.alt[rows], 0.0)
    en = local_positions(frame, c.lat[rows], c.lon[rows]) if rows.size else np.zeros((0, 2))
    pos = np.column_stack([en, alt]) if rows.size else np.zeros((0, 3))
    new_id, gap = _run_marks(code, tr, max_gap_s)
    run_start = np.flatnonzero(new_id | gap)
    run_len = np.diff(np.append(run_start, rows.size))
    lone = np.repeat(run_len == 1, run_len)
    _count_dropped(dropped, ~lone, "lone fix (no neighbour within max_gap_s)")
    # the pieces are built on runs of >= 2 fixes; lone fixes leave (and the marks are
    # derived again: a lone fix may have separated two gaps)
    sel = ~lone
    rows, code, tr, pos = rows[sel], code[sel], tr[sel], pos[sel]
    new_id, gap = _run_marks(code, tr, max_gap_s)
    starts = np.append(np.flatnonzero(new_id | gap), rows.size)
    return _Runs(rows, tr, pos, new_id, gap, starts)


def _fix_velocities(c: _Columns, runs: _Runs, frame: LocalFrame, speed_unit: str
                    ) -> np.ndarray:
    """The velocity (K, 3) [m/s] at each fix of ``runs``: the reported speed and course where
    the file has them (AIS's "not available" codes excepted), else the monotone derivative;
    the vertical rate limited to the monotone region (module notes)."""
    rows, tr, pos, starts = runs.rows, runs.t, runs.pos, runs.starts
    if not rows.size:
        return np.zeros((0, 3))
    vel = monotone_slopes(tr, pos[:, :2], starts)
    if c.speed is not None and c.course is not None:
        s = c.speed[rows] * _SPEED_UNITS[speed_unit]
        course = c.course[rows]
        if speed_unit == "knots":  # AIS "not available" codes
            s = np.where(c.speed[rows] >= AIS_SOG_NOT_AVAILABLE_KN, np.nan, s)
            course = np.where(course >= AIS_COG_NOT_AVAILABLE_DEG, np.nan, course)
        has = np.isfinite(s) & np.isfinite(course) & (s >= 0.0)
        if has.any():
            cr = np.radians(course[has])
            vel[has] = _reported_velocity(frame, c.lat[rows][has], c.lon[rows][has],
                                          s[has] * np.sin(cr), s[has] * np.cos(cr))
    vz = limited_slopes(tr, pos[:, 2], c.vrate[rows] if c.vrate is not None else
                        np.full(rows.size, np.nan), starts)
    return np.column_stack([vel, vz])


def _tracks(entry: Traffic, c: _Columns, runs: _Runs, v: np.ndarray, n_rows: int,
            dropped: dict[str, int]) -> TrafficTracks:
    """The targets of ``runs`` (fix velocities ``v`` (K, 3) [m/s]): a Hermite piece between
    consecutive fixes of an id, a linear piece that is not live across a gap; ids, names
    and classes from the file."""
    rows, tr, pos, new_id = runs.rows, runs.t, runs.pos, runs.new_id
    same_id = ~new_id[1:] if rows.size else np.zeros(0, dtype=bool)
    a = np.flatnonzero(same_id)
    h = tr[a + 1] - tr[a]
    is_gap = runs.gap[a + 1]
    c2, c3 = hermite_coefficients(pos[a], pos[a + 1], v[a], v[a + 1], h)
    chord = (pos[a + 1] - pos[a]) / h[:, None]
    v0 = np.where(is_gap[:, None], chord, v[a])
    par = np.where(is_gap[:, None], 0.0, np.column_stack([c2, c3]))
    kind = np.where(is_gap, LINEAR, CUBIC).astype(np.int8)
    n_targets = int(new_id.sum()) if rows.size else 0
    target_of_piece = np.cumsum(new_id)[a] - 1 if rows.size else np.zeros(0, np.int64)
    counts = np.bincount(target_of_piece, minlength=n_targets)
    offsets = np.concatenate([[0], np.cumsum(counts)])
    first_rows = rows[new_id] if rows.size else rows
    out_ids = [entry.id_prefix + str(x) for x in c.ids[first_rows]]
    out_classes: list[str | None] = ([None] * n_targets if c.class_text is None else
                                     [None if x is None else str(x).strip()
                                      for x in c.class_text[first_rows]])
    return TrafficTracks(
        ids=out_ids, names=_first_names(c.name_text, rows, new_id, out_ids), classes=out_classes,
        offsets=offsets, t0=tr[a], dt=h, p0=pos[a], v0=v0, kind=kind, par=par, live=~is_gap,
        max_altitude_m=float(pos[:, 2].max()) if rows.size else 0.0, rows=n_rows,
        dropped=dropped, fixes_en=pos[:, :2])


def _first_names(name_col: np.ndarray | None, rows: np.ndarray, new_id: np.ndarray,
                 ids: list[str]) -> list[str]:
    """Each target's name: its first non-empty name in the file, else its id."""
    if name_col is None or not rows.size:
        return list(ids)
    target = np.cumsum(new_id) - 1
    out: list[str | None] = [None] * len(ids)
    for k, r in zip(target, rows, strict=True):
        if out[k] is None:
            v = name_col[r]
            if v is not None and str(v).strip():
                out[k] = str(v).strip()
    return [o if o is not None else i for o, i in zip(out, ids, strict=True)]


# --------------------------------------------------------------------------- the catalogue
@dataclass
class SceneTargets:
    """Every target of a scene: the scenario's own ``targets:`` first, then each traffic
    file's, in file order and, within a file, by id.

    ``ids`` (the truth topic's ``meta.target_ids``), ``names`` (display names: a YAML
    target's id, a file's vessel name or callsign), ``kinds``, ``rcs`` (a scenario RCS model
    each) and ``swerling`` (int8) one per target; ``max_altitude_m`` the highest any reaches
    [m]; ``traffic_rows`` and ``dropped`` what the files held and what was left out, by reason.
    """

    ids: list[str]
    names: list[str]
    kinds: list[str]
    rcs: list[Rcs]
    swerling: np.ndarray
    max_altitude_m: float
    yaml_targets: list[Target]
    files: list[TrafficTracks]
    traffic_rows: int = 0
    dropped: dict[str, int] = field(default_factory=dict)

    @property
    def n(self) -> int:
        return len(self.ids)

    @property
    def from_files(self) -> int:
        """Targets that came from traffic files."""
        return self.n - len(self.yaml_targets)

    def trajectories(self, frame: LocalFrame) -> Trajectories | PieceTable:
        """The targets' motion: the scenario's own targets alone as before
        (:func:`shipradar.sim.world.trajectory.trajectories`, the same recordings), or every
        target in one :class:`PieceTable` when files add some."""
        from shipradar.sim.world.trajectory import trajectories

        if not self.files:
            return trajectories(self.yaml_targets, frame, hold=False)
        y = _yaml_piece_rows(self.yaml_targets, frame)
        counts = [np.asarray(y["count"], np.int64)] + [np.diff(f.offsets) for f in self.files]
        offsets = np.concatenate([[0], np.cumsum(np.concatenate(counts))])

        def cat(key: str, yaml_rows: Any, width: int | None) -> np.ndarray:
            parts = [np.asarray(yaml_rows).reshape((-1,) if width is None else (-1, width))]
            parts += [getattr(f, key) for f in self.files]
            return np.concatenate(parts)

        return PieceTable(
            offsets, cat("t0", y["t0"], None), cat("dt", y["dt"], None),
            cat("p0", y["p0"], 3), cat("v0", y["v0"], 3),
            cat("kind", np.asarray(y["kind"], np.int8), None), cat("par", y["par"], 6),
            np.concatenate([np.ones(len(y["t0"]), bool), *[f.live for f in self.files]]))

    def max_ground_range_m(self, east_north: np.ndarray) -> float:
        """Largest horizontal distance [m] from ``east_north`` (2,) to any fix of the files
        (the Hermite curve between two fixes stays near them; the PE table's margin covers
        the rest, and a look beyond falls back to the two-ray model, counted)."""
        best = 0.0
        for f in self.files:
            if f.fixes_en.size:
                d = np.hypot(f.fixes_en[:, 0] - east_north[0], f.fixes_en[:, 1] - east_north[1])
                best = max(best, float(d.max()))
        return best


def scene_targets(scenario: Scenario) -> SceneTargets:
    """Every target of ``scenario`` (its own and its traffic files'), built anew at each call:
    whoever runs the scene builds it once and hands it on (the engine gives its own to each
    radar's dwell model).  The files are read once per process (:func:`_cached_read`).

    Raises
    ------
    TrafficError
        On a traffic file that cannot be used (one line: field, value, allowed range).
    """
    frame = LocalFrame(scenario.origin)
    own = list(scenario.targets)
    ids = [t.id for t in own]
    names = list(ids)
    kinds: list[str] = [t.kind for t in own]
    rcs: list[Rcs] = [t.rcs for t in own]
    sw = [t.swerling_case for t in own]
    top = max((t.max_altitude_m for t in own), default=0.0)
    files: list[TrafficTracks] = []
    dropped: dict[str, int] = {}
    total = 0
    seen = set(ids) | {p.id for p in scenario.platforms} | {j.id for j in scenario.jammers}
    for i, entry in enumerate(scenario.traffic):
        tracks = _cached_read(entry, i, scenario, frame)
        clash = next((tid for tid in tracks.ids if tid in seen), None)
        if clash is not None:
            raise TrafficError(
                f"{_where(i, 'id_prefix')}: id {clash!r} of {entry.path!r} is already a "
                f"scenario or traffic id; ids must be unique (give an id_prefix), got "
                f"{entry.id_prefix!r}")
        seen.update(tracks.ids)
        for kind, model, case in _file_catalogue(entry, tracks):
            kinds.append(kind)
            rcs.append(model)
            sw.append(case)
        ids += tracks.ids
        names += tracks.names
        files.append(tracks)
        total += tracks.rows
        for reason, count in tracks.dropped.items():
            dropped[reason] = dropped.get(reason, 0) + count
        top = max(top, tracks.max_altitude_m)
    return SceneTargets(ids, names, kinds, rcs, np.asarray(sw, dtype=np.int8), top, own, files,
                        total, dropped)


def _file_catalogue(entry: Traffic, tracks: TrafficTracks) -> list[tuple[str, Rcs, int]]:
    """Kind, RCS model and Swerling case of each target of a file: the entry's, or those of
    the first of its ``overrides`` that names the target's id (without the prefix) or
    class."""
    by_id = [set(o.ids) for o in entry.overrides]
    by_class = [set(o.classes) for o in entry.overrides]
    cut = len(entry.id_prefix)
    choice: dict[int | None, tuple[str, Rcs, int]] = {}
    out = []
    for tid, cls in zip(tracks.ids, tracks.classes, strict=True):
        j = next((j for j in range(len(by_id)) if tid[cut:] in by_id[j]
                  or (cls is not None and cls in by_class[j])), None)
        got = choice.get(j)
        if got is None:
            over = None if j is None else entry.overrides[j]
            kind = over.kind if over is not None and over.kind else entry.resolved_kind
            model = over.rcs if over is not None and over.rcs is not None else entry.rcs
            case = (over.swerling if over is not None and over.swerling is not None
                    else entry.swerling)
            got = choice[j] = (kind, model, swerling_case(model, kind, case))
        out.append(got)
    return out


#: The files read in this process, by value: the cost of a run with traffic is its files'
#: reading (a CSV parse, the frame's projection), and every input of it is in the key
#: (:func:`_cached_read`), so an equal entry of an equal scene, or of another scene of a
#: study, reuses the tracks; a few files at most.
_READ_CACHE: OrderedDict[tuple, TrafficTracks] = OrderedDict()
_READ_CACHE_SIZE = 8


def _cached_read(entry: Traffic, index: int, scenario: Scenario,
                 frame: LocalFrame) -> TrafficTracks:
    """:func:`read_traffic`, remembered per process by what it depends on: the entry, the
    frame's origin, the scenario's start time and the file's size and modification time."""
    try:
        st = Path(entry.path).stat()
        stamp: tuple = (st.st_size, st.st_mtime_ns)
    except OSError:
        stamp = ()
    key = (entry.model_dump_json(), scenario.origin.model_dump_json(),
           scenario.start_time.isoformat(), index, stamp)
    hit = _READ_CACHE.get(key)
    if hit is not None:
        _READ_CACHE.move_to_end(key)
        return hit
    tracks = read_traffic(entry, index, scenario, frame)
    _READ_CACHE[key] = tracks
    while len(_READ_CACHE) > _READ_CACHE_SIZE:
        _READ_CACHE.popitem(last=False)
    return tracks
