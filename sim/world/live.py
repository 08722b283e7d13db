"""Live entities as targets: a target list that grows during the run, dead-reckoned states.

A live source (a ZeroMQ feed, ``shipradar run --entities ENDPOINT``, or the ``entities``
topic of a recording) hands the run batches of entity states (:data:`shipradar.sim.stream.schema
.ENTITIES` columns).  :class:`LiveTargets` keeps each entity's latest state and is both the
scene's target catalogue (ids, names, kinds, RCS, Swerling, as
:class:`shipradar.sim.world.traffic.SceneTargets`) and its motion (the interface of
:class:`shipradar.sim.world.kinematics.Trajectories`):

* an entity is a target from its first state on; its row (the index in ``meta.target_ids``)
  never changes;
* between states it moves at the constant velocity of its latest state, or with its constant
  acceleration when the state has one (first- or second-order dead reckoning, DIS's FPW or
  FVW), evaluated at the exact time asked (a beam crossing);
* an update older than the entity's latest one is ignored (counted ``out_of_order``): a late
  or out-of-order update never moves an entity back in time;
* its height is held at 0 or above (the radar model's heights are above the sea; a ship's
  ellipsoid height or a dead-reckoned descent can dip below);
* it leaves at a state whose ``active`` is false, or ``timeout_s`` after its latest state
  (never extrapolated without bound); a later update brings it back.
"""

from __future__ import annotations

import fnmatch
import itertools
import operator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from shipradar.sim.world.scenario import (
    DEFAULT_ENTITY_RCS_M2,
    DEFAULT_ENTITY_SWERLING,
    ConstantRcs,
    External,
    Rcs,
    Scenario,
    swerling_case,
)
from shipradar.sim.world.traffic import MotionTable

__all__ = ["MACH_30_MPS", "LiveTargets", "RiddenPlatforms", "check_states", "take_rows"]

#: Fastest entity accepted [m/s]: Mach 30 at sea level (343 m/s); faster is "absurd".
MACH_30_MPS = 30.0 * 343.0
#: Lowest accepted height [m]: below it a state is "inside the earth".
MIN_UP_M = -500.0
#: Farthest accepted horizontal distance from the origin [m] (the local frame's reach).
MAX_FRAME_M = 2.0e6
#: Longest id [characters] (as a scenario id).
MAX_ID_CHARS = 64
_COLUMNS = ("time_s", "east_m", "north_m", "up_m", "v_east_mps", "v_north_mps", "v_up_mps")
#: Optional accelerations (second-order dead reckoning; 0 when absent).
_ACCEL = ("a_east_mps2", "a_north_mps2", "a_up_mps2")
#: Optional orientation columns (a ridden platform's heading, NaN: unknown; and its rate,
#: absent or NaN: 0).
_ORIENTATION = ("heading_deg", "heading_rate_dps")


def _pick(values: Any, keep: np.ndarray, n: int) -> list:
    """``values[i] for i in keep`` as a list (C-level gathers: no Python loop per row)."""
    if keep.size == n:
        return list(values)
    if keep.size == 0:
        return []
    got = operator.itemgetter(*keep.tolist())(values)
    return [got] if keep.size == 1 else list(got)


def _good_ids(ids: Any) -> np.ndarray:
    """Whether each id is a string of 1 to :data:`MAX_ID_CHARS` characters (bool (n,))."""
    n = len(ids)
    if set(map(type, ids)) <= {str}:  # the usual case: lengths at C speed
        lengths = np.fromiter(map(len, ids), np.int64, n)
        return (lengths > 0) & (lengths <= MAX_ID_CHARS)
    return np.array([isinstance(i, str) and 0 < len(i) <= MAX_ID_CHARS for i in ids], bool)


def _count(bad: dict[str, int], reason: str, k: int = 1) -> None:
    """Add ``k`` rows (or messages) to ``bad[reason]``."""
    if k:
        bad[reason] = bad.get(reason, 0) + k


def check_states(payload: dict[str, Any], bad: dict[str, int]) -> dict[str, Any] | None:
    """The usable rows of one ``entities`` payload as arrays, the others counted in ``bad``
    by reason; None when the message as a whole is unusable (counted).

    Returns a dict with ``id`` (list of str), the :data:`_COLUMNS` (float64 arrays),
    the accelerations (zero when absent; ``accelerated`` says whether they were given),
    ``state`` (m, 9) (positions, velocities, accelerations side by side),
    ``type`` and ``name`` (lists, None where absent), ``active`` (bool array) and, when the
    payload has them, ``heading_deg`` (and ``heading_rate_dps``) (float arrays, NaN where
    unusable).  Vectorized: no Python loop per row.
    """
    ids = payload.get("id")
    if not isinstance(ids, (list, tuple)):
        _count(bad, "no id column")
        return None
    n = len(ids)
    cols = _state_columns(payload, n, bad)
    if cols is None:
        return None
    for key in ("type", "name"):
        v = payload.get(key)
        if v is not None and (not isinstance(v, (list, tuple)) or len(v) != n):
            _count(bad, "columns of unequal lengths")
            return None
    act = payload.get("active")
    try:
        active = np.ones(n, bool) if act is None else np.asarray(act, dtype=bool).reshape(-1)
    except (TypeError, ValueError):
        _count(bad, "active not booleans")
        return None
    if active.size != n:
        _count(bad, "columns of unequal lengths")
        return None
    state = np.column_stack([cols[k] for k in (*_COLUMNS[1:], *_ACCEL)])
    keep = np.flatnonzero(_usable_rows(ids, cols, state, bad))
    out: dict[str, Any] = {k: cols[k][keep] for k in (*_COLUMNS, *_ACCEL)}
    out["state"] = state[keep]  # (m, 9): position, velocity, acceleration, for apply
    out["accelerated"] = any(payload.get(k) is not None for k in _ACCEL)
    out["id"] = _pick(ids, keep, n)
    for key in ("type", "name"):
        v = payload.get(key)
        out[key] = [None] * keep.size if v is None else _pick(v, keep, n)
    out["active"] = active[keep]
    for key in _ORIENTATION:
        v = payload.get(key)
        if v is None:
            continue
        try:
            h = np.asarray(v, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            h = np.full(n, np.nan)
        out[key] = h[keep] if h.size == n else np.full(keep.size, np.nan)
    return out


def _state_columns(payload: dict[str, Any], n: int, bad: dict[str, int]
                   ) -> dict[str, np.ndarray] | None:
    """The state columns :data:`_COLUMNS` (required) and the accelerations :data:`_ACCEL`
    (zero when absent) of a payload of ``n`` rows, as float64 arrays; None (counted in
    ``bad``) when a required one is missing, or one is not numbers or of another length."""
    cols: dict[str, np.ndarray] = {}
    for key in (*_COLUMNS, *_ACCEL):
        v = payload.get(key)
        if v is None and key in _COLUMNS:
            _count(bad, f"no {key} column")
            return None
        try:
            a = np.zeros(n) if v is None else np.asarray(v, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            _count(bad, f"{key} not numbers")
            return None
        if a.size != n:
            _count(bad, "columns of unequal lengths")
            return None
        cols[key] = a
    return cols


def _usable_rows(ids: Any, cols: dict[str, np.ndarray], state: np.ndarray,
                 bad: dict[str, int]) -> np.ndarray:
    """Whether each row is usable (bool (n,)): a good id, finite numbers, above
    :data:`MIN_UP_M`, within :data:`MAX_FRAME_M` and below :data:`MACH_30_MPS`; each other
    row counted in ``bad`` under its first reason."""
    ok = _good_ids(ids)
    _count(bad, "bad id", int(np.count_nonzero(~ok)))
    finite = np.isfinite(state).all(axis=1) & ~np.isinf(cols["time_s"])
    _count(bad, "not finite", int(np.count_nonzero(ok & ~finite)))
    ok &= finite
    with np.errstate(invalid="ignore"):
        under = cols["up_m"] < MIN_UP_M
        far = np.hypot(cols["east_m"], cols["north_m"]) > MAX_FRAME_M
        fast = np.sqrt(cols["v_east_mps"] ** 2 + cols["v_north_mps"] ** 2
                       + cols["v_up_mps"] ** 2) > MACH_30_MPS
    for mask, reason in ((under, "inside the earth"), (far, "beyond the frame"),
                         (fast, "faster than Mach 30")):
        _count(bad, reason, int(np.count_nonzero(ok & mask)))
        ok &= ~mask
    return ok


def take_rows(rows: dict[str, Any], mask: np.ndarray) -> dict[str, Any]:
    """The rows of checked ``rows`` (:func:`check_states`) where ``mask`` is true."""
    idx = np.flatnonzero(mask)
    n = mask.size
    out: dict[str, Any] = {}
    for key, v in rows.items():
        if isinstance(v, np.ndarray):
            out[key] = v[idx]
        elif isinstance(v, list):
            out[key] = _pick(v, idx, n)
        else:
            out[key] = v
    return out


@dataclass
class LiveTargets(MotionTable):
    """The entities of a live source: catalogue and dead-reckoned motion (module notes).

    Parameters
    ----------
    scenario : the scenario (its ``entity_types`` and ``external``)
    """

    scenario: Scenario
    ids: list[str] = field(default_factory=list)
    names: list[str] = field(default_factory=list)
    kinds: list[str] = field(default_factory=list)
    rcs: list[Rcs] = field(default_factory=list)
    bad: dict[str, int] = field(default_factory=dict)
    updates: int = 0
    outside_envelope: int = 0

    hold = False
    files: tuple = ()
    yaml_targets: tuple = ()
    traffic_rows = 0

    def __post_init__(self) -> None:
        self.external = self.scenario.external or External()
        self.timeout_s = self.external.timeout_s
        self._row: dict[str, int] = {}
        cap = 64
        self.swerling = np.zeros(0, np.int8)
        self._t_u = np.zeros(cap)
        self._p = np.zeros((cap, 3))
        self._v = np.zeros((cap, 3))
        self._a = np.zeros((cap, 3))
        self._t_first = np.zeros(cap)
        self._t_end = np.full(cap, np.inf)
        self._h = np.full(cap, np.nan)
        self._h_rate = np.zeros(cap)
        self._default = ConstantRcs(sigma_m2=DEFAULT_ENTITY_RCS_M2)

    # ------------------------------------------------------------------ catalogue
    @property
    def n(self) -> int:
        return len(self.ids)

    @property
    def from_files(self) -> int:
        return 0

    @property
    def dropped(self) -> dict[str, int]:
        return {}

    @property
    def max_altitude_m(self) -> float:
        return self.external.max_altitude_m

    def trajectories(self, frame: Any) -> LiveTargets:
        return self

    def swerling_cases(self) -> list[int]:
        """Every Swerling case an entity may get (the table's and the default)."""
        cases = {DEFAULT_ENTITY_SWERLING}
        for e in self.scenario.entity_types:
            cases.add(swerling_case(e.rcs, e.kind, e.swerling))
        return sorted(cases)

    def row_of(self, entity_id: str) -> int | None:
        """The row of entity ``entity_id`` (its index in ``ids``), None before its first state."""
        return self._row.get(entity_id)

    def heading_deg(self, row: int, t: float) -> float | None:
        """The heading [deg, in [0, 360)] at ``t`` [s] of the entity in ``row``, from its latest
        state: the orientation's heading h0 turned at the state's heading rate, h0 + ḣ (t − t0)
        (the orientation's dead reckoning, IEEE 1278.1 annex E, for a turn about the vertical;
        :func:`shipradar.sim.adapters.dis.ecef_heading_rate_dps`), held after the entity leaves;
        None before its first state or when its state has no orientation."""
        if t < float(self._t_first[row]):
            return None
        h = float(self._h[row])
        if not np.isfinite(h):
            return None
        dt = min(t, float(self.t_last[row])) - float(self._t_u[row])
        return (h + float(self._h_rate[row]) * dt) % 360.0

    def _classify(self, type_text: str | None) -> tuple[str, Rcs, int]:
        text = "" if type_text is None else str(type_text)
        for e in self.scenario.entity_types:
            if fnmatch.fnmatchcase(text, e.match):
                return e.kind, e.rcs, swerling_case(e.rcs, e.kind, e.swerling)
        return "other", self._default, DEFAULT_ENTITY_SWERLING

    # ------------------------------------------------------------------ updates
    def _grow(self, need: int) -> None:
        cap = self._t_u.size
        if need <= cap:
            return
        new = max(need, 2 * cap)

        def more(a: np.ndarray, fill: float) -> np.ndarray:
            b = np.full((new, *a.shape[1:]), fill, dtype=a.dtype)
            b[:cap] = a
            return b

        self._t_u, self._p, self._v = more(self._t_u, 0.0), more(self._p, 0.0), more(self._v, 0.0)
        self._a = more(self._a, 0.0)
        self._t_first, self._t_end = more(self._t_first, 0.0), more(self._t_end, np.inf)
        self._h = more(self._h, np.nan)
        self._h_rate = more(self._h_rate, 0.0)

    def _rows_of(self, ids: list[str], types: list, names: list, t: np.ndarray
                 ) -> np.ndarray:
        """Each id's row (int64 (m,)); an id not known yet becomes a new entity at its first
        row (catalogued: kind, RCS, Swerling by its type; its name), in order."""
        m = len(ids)
        r = np.fromiter(map(self._row.get, ids, itertools.repeat(-1, m)), np.int64, m)
        new = np.flatnonzero(r < 0)
        if not new.size:
            return r
        new_sw: list[int] = []
        for i in new.tolist():  # first appearances only: a loop over new entities
            eid = ids[i]
            k = self._row.get(eid)
            if k is None:
                k = self._row[eid] = len(self.ids)
                self._grow(k + 1)
                kind, model, case = self._classify(types[i])
                name = names[i]
                self.ids.append(eid)
                self.names.append(str(name).strip() if name else eid)
                self.kinds.append(kind)
                self.rcs.append(model)
                new_sw.append(case)
                self._t_first[k] = t[i]
                self._t_u[k] = -np.inf  # its first row is newer than anything
            r[i] = k
        self.swerling = np.concatenate([self.swerling, np.asarray(new_sw, np.int8)])
        return r

    def apply(self, rows: dict[str, Any], now: float) -> dict[str, Any]:
        """Apply checked rows (:func:`check_states`), in order; NaN times are ``now``.

        A row is applied when its time is later than its entity's latest state, that of the
        rows before it included (otherwise counted ``out_of_order``); each entity then takes
        its last applied row.  Vectorized: the rows are grouped by entity with a stable sort
        and the latest time before each row is a running maximum within its group.

        Returns the rows applied (the same columns, times resolved), for the recording.
        """
        ids = rows["id"]
        m = len(ids)
        t = np.where(np.isnan(rows["time_s"]), now, rows["time_s"])
        state = rows.get("state")
        if state is None:
            state = np.column_stack([rows[k] for k in (*_COLUMNS[1:], *_ACCEL)])
        r = self._rows_of(ids, rows["type"], rows["name"], t)
        # group the rows by entity, keeping their order within a group
        order = np.argsort(r, kind="stable")
        rs, ts = r[order], t[order]
        start = np.ones(m, bool)
        start[1:] = rs[1:] != rs[:-1]
        group = np.cumsum(start) - 1
        # the latest time of the rows before each one in its group: a running maximum of the
        # times' ranks, each group offset above the previous ones so that the maximum
        # restarts with every group
        by_time = np.argsort(ts, kind="stable")
        rank = np.empty(m, np.int64)
        rank[by_time] = np.arange(m)
        upto = np.maximum.accumulate(group * m + rank) - group * m
        before = np.full(m, -np.inf)
        before[1:] = ts[by_time][upto[:-1]]
        before[start] = -np.inf
        fresh = ts > np.maximum(self._t_u[rs], before)
        mask = np.zeros(m, bool)
        mask[order[fresh]] = True
        applied = np.flatnonzero(mask)
        late = m - applied.size
        if late:
            self.bad["out_of_order"] = self.bad.get("out_of_order", 0) + late
        # each entity's last applied row (the latest, applied times rising in a group)
        pos = np.flatnonzero(fresh)
        if pos.size:
            g = group[pos]
            last = pos[np.append(g[1:] != g[:-1], True)]
            rr, ii = rs[last], order[last]
            self._t_u[rr] = t[ii]
            self._p[rr] = state[ii, :3]
            self._v[rr] = state[ii, 3:6]
            self._a[rr] = state[ii, 6:]
            self._t_end[rr] = np.where(np.asarray(rows["active"], bool)[ii], np.inf, t[ii])
            if "heading_deg" in rows:
                self._h[rr] = rows["heading_deg"][ii]
                rate = rows.get("heading_rate_dps")
                self._h_rate[rr] = 0.0 if rate is None else np.nan_to_num(rate[ii], nan=0.0)
        self.updates += applied.size
        if applied.size:
            self.outside_envelope += int(np.count_nonzero(self.outside(state[applied, :3])))
        out: dict[str, Any] = {"id": _pick(ids, applied, m), "time_s": t[applied]}
        for j, k in enumerate(_COLUMNS[1:]):
            out[k] = state[applied, j]
        if rows.get("accelerated"):
            for j, k in enumerate(_ACCEL):
                out[k] = state[applied, 6 + j]
        for key in ("type", "name"):
            got = _pick(rows[key], applied, m)
            kinds = set(map(type, got))
            if kinds <= {str}:  # the usual case, checked at C speed
                if got:
                    out[key] = got
            elif kinds != {type(None)}:
                out[key] = ["" if x is None else str(x) for x in got]
        out["active"] = np.asarray(rows["active"], bool)[applied]
        for key in _ORIENTATION:
            if key in rows:
                out[key] = rows[key][applied]
        return out

    def outside(self, pos: np.ndarray) -> np.ndarray:
        """Whether positions (M, 3) [m] are outside the declared envelope (``external``):
        higher than ``max_altitude_m``, or farther than ``max_range_m`` from the origin
        (ground range) when it is set.  NaN positions are not outside."""
        ext = self.external
        with np.errstate(invalid="ignore"):
            over = pos[:, 2] > ext.max_altitude_m
            if ext.max_range_m is not None:
                over |= np.hypot(pos[:, 0], pos[:, 1]) > ext.max_range_m
        return over

    # ------------------------------------------------------------------ motion
    @property
    def t_first(self) -> np.ndarray:
        return self._t_first[:self.n]

    @property
    def t_last(self) -> np.ndarray:
        n = self.n
        return np.minimum(self._t_end[:n], self._t_u[:n] + self.timeout_s)

    @property
    def max_speed(self) -> np.ndarray:
        """A bound on each entity's horizontal speed [m/s] while it exists (the beam-crossing
        search's bound on its angular rate): |v| + |a| (timeout + the longest revolution,
        120 s at the schema's 0.5 rpm), the farthest from its latest state a revolution
        asks for."""
        n = self.n
        return (np.hypot(self._v[:n, 0], self._v[:n, 1])
                + np.hypot(self._a[:n, 0], self._a[:n, 1]) * (self.timeout_s + 120.0))

    def state_acc(self, t: ArrayLike, rows: ArrayLike | None = None, accel: bool = True
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
        """Positions (M, 3) [m], velocities (M, 3) [m/s], accelerations (M, 3) [m/s²] (zero:
        constant-velocity dead reckoning; None unless ``accel``) and activity (M,) at times
        ``t`` [s] (:meth:`MotionTable.state` without the accelerations)."""
        rows, t = self._rows_times(self.n, t, rows)
        dt = (t - self._t_u[rows])[:, None]
        acc = self._a[rows]
        pos = self._p[rows] + dt * (self._v[rows] + 0.5 * dt * acc)
        # the radar model's heights are above the sea (>= 0): a state a little below it (a
        # ship's ellipsoid height, a dead-reckoned descent) is seen at the surface
        np.maximum(pos[:, 2], 0.0, out=pos[:, 2])
        vel = self._v[rows] + dt * acc
        last = np.minimum(self._t_end[rows], self._t_u[rows] + self.timeout_s)
        active = (t >= self._t_first[rows]) & (t <= last)
        return pos, vel, (acc.copy() if accel else None), active

    def summary(self) -> dict[str, Any]:
        """The run summary's ``live`` item (the source's own counts added by the caller)."""
        return {"entities": self.n, "updates": self.updates,
                "outside_envelope": self.outside_envelope,
                "bad": dict(sorted(self.bad.items()))}


class RiddenPlatforms:
    """Platforms' motion where some ride on live entities (``platforms[].dis_entity``).

    Wraps the platforms' own trajectories (:class:`shipradar.sim.world.kinematics
    .Trajectories`, same interface): a riding platform follows its entity's dead-reckoned
    state (:class:`LiveTargets` ``entities``, a list of its own, so the radar's ship is not
    one of its targets) from the entity's first state on, its waypoints before; after the
    entity leaves (timeout, deactivated) it holds the entity's last position, at rest.

    Parameters
    ----------
    base : the platforms' own trajectories
    entities : the riding platforms' entities
    riders : platform index -> entity id
    """

    def __init__(self, base: Any, entities: LiveTargets, riders: dict[int, str]):
        self.base = base
        self.entities = entities
        self.riders = dict(riders)
        self.count = base.count
        #: a ridden platform manoeuvres (its velocity changes with every state)
        self.linear = False

    def _row(self, p: int) -> int | None:
        eid = self.riders.get(p)
        return None if eid is None else self.entities.row_of(eid)

    @property
    def max_speed(self) -> np.ndarray:
        """The platforms' bound on horizontal speed [m/s]: a ridden one's the larger of its
        waypoints' and its entity's (:attr:`LiveTargets.max_speed`)."""
        out = np.array(self.base.max_speed, dtype=float)
        bound = self.entities.max_speed
        for p in self.riders:
            r = self._row(p)
            if r is not None:
                out[p] = max(out[p], float(bound[r]))
        return out

    def state(self, t: ArrayLike, rows: ArrayLike | None = None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities, activity at ``t`` of platforms ``rows`` (as the base)."""
        pos, vel, active = self.base.state(t, rows)
        rows_a = np.broadcast_to(np.asarray(rows), np.shape(t)).reshape(-1)
        t_a = np.broadcast_to(np.asarray(t, dtype=float), np.shape(t)).reshape(-1)
        for p in self.riders:
            r = self._row(p)
            if r is None:
                continue
            sel = np.flatnonzero((rows_a == p) & (t_a >= self.entities.t_first[r]))
            if not sel.size:
                continue
            last = float(self.entities.t_last[r])
            tt = np.minimum(t_a[sel], last)
            epos, evel, _ = self.entities.state(tt, np.full(sel.size, r))
            evel[t_a[sel] > last] = 0.0
            pos[sel], vel[sel] = epos, evel
        return pos, vel, active

    def heading_deg(self, p: int, t: float) -> float | None:
        """Platform ``p``'s heading at ``t`` [deg] from its entity's latest state
        (:meth:`LiveTargets.heading_deg`); None when it has none (not riding, not yet seen,
        no orientation)."""
        r = self._row(p)
        return None if r is None else self.entities.heading_deg(r, t)
