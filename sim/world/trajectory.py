"""Trajectories of the scenario's objects as analytic pieces (segments, rounded corners).

A target or platform moves either along timed waypoints (constant velocity between them, as
before) or, with ``segments``, from its single waypoint through a chain of manoeuvres:
straight, coordinated turn, speed change, cosine climb/dive, sinusoidal weave and the
terminal pop-up-and-dive.  ``smoothing: {turn_g: n}`` keeps the waypoints but rounds each
corner with a coordinated turn at n g and joins leg speeds with a speed change at n g.  Each
manoeuvre becomes one or two :class:`shipradar.sim.world.kinematics.Piece` with a closed form
(:func:`shipradar.sim.world.kinematics.piece_state`): no numerical integration, and the pieces of
all objects are evaluated together by :class:`shipradar.sim.world.kinematics.Trajectories`.

Continuity: position and velocity are continuous at every join of a segment chain and of a
smoothed track (each piece starts where the previous one ends, with its velocity); the
acceleration is continuous inside each piece and jumps at a join when the manoeuvre changes
(entering a turn, starting a weave: a real airframe takes a fraction of a second there).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from pydantic import BaseModel
from pydantic.fields import FieldInfo

from shipradar.sim.world.kinematics import (
    ARC,
    LATERAL,
    SINE,
    VERTICAL,
    LocalFrame,
    Piece,
    Trajectories,
    linear_pieces,
    waypoint_enu,
)
from shipradar.sim.world.scenario import STANDARD_GRAVITY, Jammer, Platform, Scenario, Target

TWO_PI = 2.0 * math.pi
#: Course changes below this are not rounded [rad].
_MIN_CORNER_RAD = 1e-9


def _given(value: float | None, what: str) -> float:
    """A field the schema's cross-field rules guarantee at this point of a validated scenario."""
    if value is None:
        raise ValueError(f"{what} is missing: build trajectories from a validated scenario")
    return value


def _heading_vector(psi: float) -> np.ndarray:
    return np.array([math.sin(psi), math.cos(psi), 0.0])


def _arc(t0: float, p0: np.ndarray, psi: float, v: float, dt: float, *, a: float = 0.0,
         w: float = 0.0, vz: float = 0.0, az: float = 0.0) -> Piece:
    return Piece(t0, dt, np.asarray(p0, float), np.zeros(3), ARC,
                 np.array([psi, v, a, w, vz, az], dtype=float))


def _sine(t0: float, p0: np.ndarray, psi: float, v: float, dt: float, amplitude: float,
          k: float, plane: int) -> Piece:
    m = (amplitude * k / v) ** 2
    return Piece(t0, dt, np.asarray(p0, float), np.zeros(3), SINE,
                 np.array([psi, v, amplitude, k, plane, m], dtype=float))


def segment_pieces(obj: Target | Platform, frame: LocalFrame) -> list[Piece]:
    """The pieces of an object flying ``segments`` from its single waypoint.

    Parameters
    ----------
    obj : Target or Platform
        Validated (``_check_motion`` in the schema: slopes below the speed, loads only when
        moving).
    frame : LocalFrame
        The scenario's frame (a latitude/longitude start is converted once).
    """
    start = waypoint_enu(obj.waypoints, frame)[0]
    t, pos = float(start[0]), start[1:].copy()
    psi = math.radians(obj.heading_deg or 0.0)
    v = float(_given(obj.speed_mps, "speed_mps"))
    out: list[Piece] = []

    def add(piece: Piece) -> None:
        nonlocal t, pos
        out.append(piece)
        pos, vel = piece.end()
        t = piece.t0 + piece.dt

    for s in obj.segments:
        if s.type == "straight":
            add(Piece(t, s.duration_s, pos, v * _heading_vector(psi)))
        elif s.type == "turn":
            rate = (STANDARD_GRAVITY * s.turn_g / v if s.turn_g is not None
                    else math.radians(_given(s.turn_rate_deg_s, "turn_rate_deg_s")))
            if s.to_heading_deg is not None:
                delta = math.remainder(math.radians(s.to_heading_deg) - psi, TWO_PI)
                if s.direction == "right":
                    delta %= TWO_PI
                elif s.direction == "left":
                    delta = -((-delta) % TWO_PI)
                if abs(delta) < _MIN_CORNER_RAD:
                    continue
                w = math.copysign(rate, delta)
                dt = abs(delta) / rate
            else:
                w = rate if s.direction == "right" else -rate
                dt = _given(s.duration_s, "duration_s")
            add(_arc(t, pos, psi, v, dt, w=w))
            psi = (psi + w * dt) % TWO_PI
        elif s.type == "accelerate":
            dv = s.to_speed_mps - v
            if s.duration_s is not None:
                dt, a = s.duration_s, dv / s.duration_s
            elif dv == 0.0:
                continue
            else:
                a = math.copysign(STANDARD_GRAVITY * _given(s.accel_g, "accel_g"), dv)
                dt = dv / a
            add(_arc(t, pos, psi, v, dt, a=a))
            v = s.to_speed_mps
        elif s.type == "weave":
            sign = 1.0 if s.first_side == "right" else -1.0
            k = TWO_PI / s.period_s
            piece = _sine(t, pos, psi, v, s.duration_s, sign * s.amplitude_m, k, LATERAL)
            add(piece)
            # the course at the end: back to the entry course after whole periods
            _, vel = piece.end()
            psi = math.atan2(vel[0], vel[1]) % TWO_PI
        else:  # climb, popup: half-cosine altitude changes on a straight course
            z = pos[2]
            if s.type == "climb":
                legs = [(s.to_altitude_m, s.duration_s)]
            else:
                legs = [(s.peak_altitude_m, s.climb_s),
                        (z if s.to_altitude_m is None else s.to_altitude_m, s.dive_s)]
            for z_to, dt in legs:
                if z_to == pos[2]:
                    add(Piece(t, dt, pos, v * _heading_vector(psi)))
                    continue
                add(_sine(t, pos, psi, v, dt, 0.5 * (z_to - pos[2]), math.pi / dt, VERTICAL))
                pos[2] = z_to  # exactly (the closed form ends there within rounding)
    if not out:
        out.append(Piece(t, 0.0, pos, np.zeros(3)))
    return out


def _legs(track: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Velocity (L, 3) [m/s], horizontal speed (L,) [m/s] and course (L,) [rad, clockwise
    from north] of each leg of a ``(W, 4)`` track (L = W - 1); a leg at rest takes the
    course of the next moving leg, else of the previous one (0 when none moves)."""
    dt_leg = np.diff(track[:, 0])
    dpos = np.diff(track[:, 1:], axis=0)
    vel = dpos / dt_leg[:, None]
    speed = np.hypot(vel[:, 0], vel[:, 1])
    course = np.arctan2(vel[:, 0], vel[:, 1])
    nleg = len(dt_leg)
    for i in range(nleg):
        if speed[i] == 0.0:
            j = next((j for j in (*range(i + 1, nleg), *range(i - 1, -1, -1)) if speed[j] > 0),
                     None)
            course[i] = course[j] if j is not None else 0.0
    return vel, speed, course


def smoothed_pieces(obj: Target | Platform, frame: LocalFrame) -> list[Piece]:
    """The pieces of a waypoint track whose corners are rounded at ``smoothing.turn_g``.

    Each leg is flown at its own constant velocity.  At a corner between legs of horizontal
    speeds s1, s2 and courses ψ1, ψ2, the object turns at s1 with radius R = s1²/(g n),
    tangent to both legs (it leaves the incoming leg R tan(|Δψ|/2) before the waypoint),
    then changes speed to s2 at n g along the outgoing leg (on the incoming leg, ending at
    the waypoint, when s2 = 0).  The vertical speed changes linearly over the corner's first
    piece (or over |Δv_z|/(n g) when the corner has no turn and no speed change).  The
    object reaches the later waypoints slightly earlier than their times (the rounded
    corners are shorter than the legs they replace).
    """
    track = waypoint_enu(obj.waypoints, frame)
    if len(track) < 3:
        return linear_pieces(track)
    if obj.smoothing is None:
        raise ValueError("smoothed_pieces needs a smoothing")
    g = STANDARD_GRAVITY * obj.smoothing.turn_g
    vel, speed, course = _legs(track)
    nleg = len(speed)
    t, pos = float(track[0, 0]), track[0, 1:].copy()
    out: list[Piece] = []

    def add(piece: Piece) -> None:
        nonlocal t, pos
        if piece.dt <= 0.0:
            return
        out.append(piece)
        pos, _ = piece.end()
        t = piece.t0 + piece.dt

    def straight_to(leg: int, point: np.ndarray) -> None:
        """Fly leg ``leg`` at its velocity to the horizontal ``point``."""
        s = speed[leg]
        if s == 0.0:
            add(Piece(t, max(float(track[leg + 1, 0]) - t, 0.0), pos, vel[leg]))
            return
        rest = float(np.dot(point[:2] - pos[:2], _heading_vector(course[leg])[:2]))
        if rest < 0.0:
            raise ValueError(f"smoothing: corners overlap on leg waypoints[{leg}] -> "
                             f"waypoints[{leg + 1}]; raise smoothing.turn_g")
        add(Piece(t, rest / s, pos, vel[leg]))

    for j in range(1, nleg):
        s1, s2 = speed[j - 1], speed[j]
        c1, c2 = course[j - 1], course[j]
        vz1, vz2 = vel[j - 1, 2], vel[j, 2]
        corner = track[j, 1:]
        dpsi = math.remainder(c2 - c1, TWO_PI) if s1 > 0 and s2 > 0 else 0.0
        d = s1 * s1 / g * math.tan(0.5 * abs(dpsi)) if abs(dpsi) > _MIN_CORNER_RAD else 0.0
        if s2 == 0.0 and s1 > 0.0:
            # stop on the incoming leg, at the waypoint
            brake = s1 * s1 / (2.0 * g)
            straight_to(j - 1, corner - brake * _heading_vector(c1))
            dt = s1 / g
            add(_arc(t, pos, c1, s1, dt, a=-g, vz=vz1, az=(vz2 - vz1) / dt))
            continue
        straight_to(j - 1, corner - d * _heading_vector(c1))
        blended = False
        if d > 0.0:
            w = math.copysign(g / s1, dpsi)
            dt = abs(dpsi) / abs(w)
            add(_arc(t, pos, c1, s1, dt, w=w, vz=vz1, az=(vz2 - vz1) / dt))
            blended = True
        if s1 != s2:
            a = math.copysign(g, s2 - s1)
            dt = (s2 - s1) / a
            vz_in = vz2 if blended else vz1
            add(_arc(t, pos, c2, s1, dt, a=a, vz=vz_in, az=(vz2 - vz_in) / dt))
            blended = True
        if not blended and vz1 != vz2:
            dt = abs(vz2 - vz1) / g
            add(_arc(t, pos, c2, s2, dt, vz=vz1, az=(vz2 - vz1) / dt))
    straight_to(nleg - 1, track[-1, 1:])
    return out or linear_pieces(track)


def object_pieces(obj: Target | Platform | Jammer, frame: LocalFrame) -> list[Piece]:
    """The pieces of any scenario object: segments, a smoothed track or plain waypoints."""
    if not isinstance(obj, Jammer):  # a jammer flies its waypoints
        if obj.segments:
            return segment_pieces(obj, frame)
        if obj.smoothing is not None:
            return smoothed_pieces(obj, frame)
    return linear_pieces(waypoint_enu(obj.waypoints, frame))


def trajectories(objects: Sequence[Target | Platform | Jammer], frame: LocalFrame,
                 hold: bool) -> Trajectories:
    """:class:`shipradar.sim.world.kinematics.Trajectories` of scenario objects.

    Objects that only have waypoints are built exactly as before (same arithmetic, same
    recordings); segments and smoothing give analytic pieces.
    """
    if not any(getattr(o, "segments", None) or getattr(o, "smoothing", None) is not None
               for o in objects):
        return Trajectories([waypoint_enu(o.waypoints, frame) for o in objects], hold=hold)
    return Trajectories(None, hold=hold, pieces=[object_pieces(o, frame) for o in objects])


# --------------------------------------------------------------------------- explain
_UNIT = __import__("re").compile(r"\[([^\[\]]+)\]\s*$")


def _unit(field: FieldInfo) -> str:
    """The unit at the end of a field's description (``[m/s]``), or the field name's suffix."""
    m = _UNIT.search(field.description or "")
    if m:
        return m.group(1)
    return ""


def _walk(model: BaseModel, indent: int, lines: list[str]) -> None:
    pad = "  " * indent
    for name, field in type(model).model_fields.items():
        value = getattr(model, name)
        unit = _unit(field)
        if isinstance(value, BaseModel):
            lines.append(f"{pad}{name}:")
            _walk(value, indent + 1, lines)
        elif isinstance(value, list) and value and isinstance(value[0], BaseModel):
            lines.append(f"{pad}{name}:")
            for i, item in enumerate(value):
                lines.append(f"{pad}  - [{i}]")
                _walk(item, indent + 2, lines)
        else:
            shown = "null" if value is None else value
            if hasattr(shown, "isoformat"):
                shown = shown.isoformat()
            lines.append(f"{pad}{name}: {shown}" + (f"  [{unit}]" if unit else ""))


def motion_summary(scenario: Scenario) -> list[str]:
    """One line per platform and target: how it moves, when, how far, how hard (the pieces
    the engine will fly: segments, rounded corners or plain waypoints)."""
    frame = LocalFrame(scenario.origin)
    lines = []
    groups: tuple[tuple[str, Sequence[Target | Platform], bool], ...] = (
        ("platforms", scenario.platforms, True), ("targets", scenario.targets, False))
    for label, objs, hold in groups:
        for i, o in enumerate(objs):
            pieces = object_pieces(o, frame)
            tr = Trajectories(None, hold=hold, pieces=[pieces])
            t0, t1 = float(tr.t_first[0]), float(tr.t_last[0])
            t = np.linspace(t0, t1, max(2, min(20_000, int((t1 - t0) * 10) + 2)))
            pos, vel, acc, _ = tr.state_acc(t, np.zeros(t.size, dtype=int))
            assert acc is not None  # asked for (accel=True)
            length = float(np.sum(np.linalg.norm(np.diff(pos, axis=0), axis=1)))
            how = ("segments" if o.segments else
                   f"waypoints rounded at {o.smoothing.turn_g:g} g"
                   if o.smoothing is not None else "waypoints (straight legs)")
            a = float(np.linalg.norm(acc, axis=1).max())
            lines.append(
                f"{label}[{i}] {o.id}: {how}, {len(pieces)} piece(s), {t0:g}-{t1:.1f} s, path "
                f"{length / 1e3:.2f} km, speed <= {np.linalg.norm(vel, axis=1).max():.1f} m/s, "
                f"|a| <= {a:.1f} m/s² ({a / STANDARD_GRAVITY:.1f} g), altitude "
                f"{pos[:, 2].min():.0f}-{pos[:, 2].max():.0f} m")
    return lines


def resolved_scene_lines(scenario: Scenario) -> list[str]:
    """The scene as the simulator will use it (``shipradar validate --explain``): every field
    with its default filled in and its unit, then how each object moves."""
    lines = ["resolved scene (every default filled in, units in brackets):"]
    _walk(scenario, 1, lines)
    lines.append("motion:")
    lines += ["  " + s for s in motion_summary(scenario)]
    return lines
