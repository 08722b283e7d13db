"""DIS (IEEE 1278.1) input: entities of a running DIS simulation as live targets.

``shipradar run SCENARIO --dis udp://ADDRESS:PORT`` binds a UDP socket (loopback by default;
another address needs ``--allow-insecure-remote``: DIS has no security of its own) and
decodes the PDUs on its own thread, in batches (the datagrams that arrive within 10 ms).  The
Entity State PDUs of the standard's fixed layout (DIS 6 and 7 share it) are decoded at once
by :func:`decode_entity_states` (``np.frombuffer`` over the batch with the big-endian
:data:`ESPDU_DTYPE`; tested field by field against opendis); every other PDU, and an Entity
State PDU that does not have that layout, by ``opendis`` (PyPI), one at a time:

* **Entity State PDU** (type 1): one state of entity ``site:application:entity`` (its id in
  the truth topic; the marking text its name; its entity type as the text
  ``kind:domain:country:category:subcategory:specific:extra`` matched against the scenario's
  ``entity_types:`` patterns). World coordinates (geocentric ECEF) are carried into the
  scenario's local frame by the frame's own projection (position through WGS-84 geodetic
  coordinates, velocity and acceleration through the projection's exact derivative,
  :func:`ecef_state_to_local`). Dead reckoning by the PDU's algorithm: static (1): no
  motion; FPW (2) and RPW (3): constant velocity; RVW (4) and FVW (5): constant velocity and
  acceleration; the body-axis algorithms (6-9) as FPW (their body-frame acceleration is not
  used: counted).  The rotating ones (RPW, RVW, RPB, RVB) turn the orientation with the
  angular velocity (IEEE 1278.1 annex E): the heading of a ridden platform follows it
  (:func:`ecef_heading_rate_dps`). The
  extrapolation is straight in the local frame, not in ECEF: over the 12 s timeout at
  300 m/s the two differ by ~1 m of height (the earth's curvature over 3.6 km).
  Appearance bit 23 ("deactivated", the standard's final PDU of an entity) makes it leave.
* **Remove Entity PDU** (12): the entity ``receivingEntityID`` leaves (entity number 65535:
  every entity of that site and application).
* **Start/Resume** (13) and **Stop/Freeze** (14) PDUs addressed to the radar's
  ``site:application`` (``--dis-site-app``) or to all (65535): freeze and resume the run's
  clock (the run waits, then resumes where it stopped).
* other PDU types, other exercises (``--dis-exercise``), and datagrams that are truncated,
  oversized (> 8192 bytes, DIS's largest PDU), of another protocol version (not 5-7) or that
  do not decode are counted by reason, never fatal.

PDU time stamps are not used: the time of an update is its arrival (DIS applications'
clocks are rarely synchronised); late or out-of-order arrivals are handled by
:mod:`shipradar.sim.world.live`.  Decoded states wait, already in the local frame, in a
queue of ``queue_size`` rows (the scenario's ``external.queue_size``), taken at each
revolution start; beyond it they are dropped and counted.
"""

from __future__ import annotations

import ipaddress
import itertools
import operator
import select
import socket
import struct
import threading
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from shipradar.sim.world import geodesy
from shipradar.sim.world.errors import BadInputError
from shipradar.sim.world.kinematics import LocalFrame

__all__ = ["DEFAULT_PORT", "ESPDU_DTYPE", "MAX_PDU_BYTES", "DisError", "DisReceiver",
           "decode_entity_states", "parse_dis_url"]

#: DIS's customary UDP port.
DEFAULT_PORT = 3000
#: Largest DIS PDU [bytes] (IEEE 1278.1: the PDU length field's maximum used in practice;
#: the standard's MTU guidance is 1400-8192).
MAX_PDU_BYTES = 8192
#: A PDU header [bytes].
HEADER_BYTES = 12
#: "All sites", "all applications", "all entities".
ALL = 0xFFFF
#: Entity State PDU appearance: bit 23 is the state, 1 = deactivated (IEEE 1278.1 / SISO-REF-010).
DEACTIVATED_BIT = 1 << 23
_PDU_ESPDU, _PDU_REMOVE, _PDU_START, _PDU_STOP = 1, 12, 13, 14
#: A distance from the earth's centre below which a location is not a place on it [m].
_INSIDE_EARTH_M = 6.0e6

#: The Entity State PDU's fixed part, big-endian (IEEE 1278.1-1995 5.3.3.1 and 1278.1-2012
#: 7.2.2 share it: DIS 6 and 7; 7 names the header's byte 10 the PDU status), 144 bytes,
#: followed by ``n_articulation`` 16-byte articulation (variable) parameters.
ESPDU_DTYPE = np.dtype([
    ("version", "u1"), ("exercise", "u1"), ("pdu_type", "u1"), ("family", "u1"),
    ("timestamp", ">u4"), ("length", ">u2"), ("status", "u1"), ("padding", "u1"),
    ("site", ">u2"), ("application", ">u2"), ("entity", ">u2"),
    ("force", "u1"), ("n_articulation", "u1"),
    ("type", "u1", (8,)), ("alternative_type", "u1", (8,)),
    ("velocity", ">f4", (3,)), ("location", ">f8", (3,)), ("orientation", ">f4", (3,)),
    ("appearance", ">u4"), ("dr_algorithm", "u1"), ("dr_parameters", "u1", (15,)),
    ("acceleration", ">f4", (3,)), ("angular_velocity", ">f4", (3,)),
    ("character_set", "u1"), ("marking", "u1", (11,)), ("capabilities", ">u4")])
#: Bytes of the Entity State PDU's fixed part, and of one articulation parameter.
ESPDU_BYTES, ARTICULATION_BYTES = 144, 16
assert ESPDU_DTYPE.itemsize == ESPDU_BYTES
#: Dead-reckoning algorithms whose orientation rotates with the angular velocity (RPW, RVW,
#: RPB, RVB; IEEE 1278.1 annex E); the others hold it.
ROTATING = (3, 4, 7, 8)
#: Algorithms whose position uses the linear acceleration (RVW, FVW).
ACCELERATED = (4, 5)
#: Datagrams taken at once by the receiving thread: up to this many, or those that arrive
#: within :data:`BATCH_S` of the first [s] (the run takes them at a revolution's start).
BATCH_MAX, BATCH_S = 1024, 0.01


def decode_entity_states(datagrams: Sequence[bytes]) -> tuple[np.ndarray, np.ndarray]:
    """The Entity State PDUs among ``datagrams`` that have the fixed layout, decoded at once.

    A datagram is taken when its header says protocol version 5-7 and PDU type 1, its
    length field equals its size and its size is 144 bytes plus 16 per articulation
    parameter; its fixed part is read through :data:`ESPDU_DTYPE` (``np.frombuffer`` over
    the batch).  The articulation parameters are not read (the radar does not use them).

    Returns
    -------
    records : the decoded fixed parts (:data:`ESPDU_DTYPE`, big-endian fields)
    index : the position of each in ``datagrams``; the others are for opendis
    """
    n = len(datagrams)
    sizes = np.fromiter(map(len, datagrams), np.int64, n)
    cand = np.flatnonzero(sizes >= ESPDU_BYTES)
    if not cand.size:
        return np.zeros(0, ESPDU_DTYPE), cand
    heads = b"".join([datagrams[i][:ESPDU_BYTES] for i in cand.tolist()])
    rec = np.frombuffer(heads, ESPDU_DTYPE)
    size = sizes[cand]
    ok = ((rec["pdu_type"] == _PDU_ESPDU) & (rec["version"] >= 5) & (rec["version"] <= 7)
          & (rec["length"] == size)
          & (size == ESPDU_BYTES + ARTICULATION_BYTES * rec["n_articulation"].astype(np.int64)))
    return rec[ok], cand[ok]


def espdu_record(pdu: Any) -> np.ndarray:
    """One :data:`ESPDU_DTYPE` record of an Entity State PDU decoded by opendis (the path of
    the PDUs that do not have the fixed layout)."""
    r = np.zeros(1, ESPDU_DTYPE)
    r["version"], r["exercise"] = pdu.protocolVersion, pdu.exerciseID
    r["pdu_type"], r["family"] = pdu.pduType, pdu.protocolFamily
    r["timestamp"], r["length"] = pdu.timestamp, pdu.length
    e, t, a = pdu.entityID, pdu.entityType, pdu.alternativeEntityType
    r["site"], r["application"], r["entity"] = e.siteID, e.applicationID, e.entityID
    r["force"], r["n_articulation"] = pdu.forceId, len(pdu.variableParameters)
    for key, y in (("type", t), ("alternative_type", a)):
        r[key] = [y.entityKind, y.domain, (y.country >> 8) & 0xFF, y.country & 0xFF,
                  y.category, y.subcategory, y.specific, y.extra]
    v, loc, o = pdu.entityLinearVelocity, pdu.entityLocation, pdu.entityOrientation
    r["velocity"], r["location"] = (v.x, v.y, v.z), (loc.x, loc.y, loc.z)
    r["orientation"] = (o.psi, o.theta, o.phi)
    r["appearance"] = int(pdu.entityAppearance) & 0xFFFFFFFF
    drp = pdu.deadReckoningParameters
    r["dr_algorithm"], r["dr_parameters"] = drp.deadReckoningAlgorithm, drp.parameters
    la, w = drp.entityLinearAcceleration, drp.entityAngularVelocity
    r["acceleration"], r["angular_velocity"] = (la.x, la.y, la.z), (w.x, w.y, w.z)
    r["character_set"] = pdu.marking.characterSet
    r["marking"] = [c & 0xFF for c in pdu.marking.characters]
    r["capabilities"] = int(pdu.capabilities) & 0xFFFFFFFF
    return r


def marking_text(raw: np.ndarray) -> str:
    """The marking's text: its non-zero characters (as opendis's ``charactersString``),
    stripped; empty when one is not ASCII (opendis reads them as signed bytes and fails)."""
    chars = bytes(int(c) for c in raw if c)
    if any(c >= 0x80 for c in chars):
        return ""
    return chars.decode("ascii").strip()


def type_text(raw: np.ndarray) -> str:
    """``kind:domain:country:category:subcategory:specific:extra`` of the 8 type bytes."""
    b = [int(c) for c in raw]
    return f"{b[0]}:{b[1]}:{(b[2] << 8) | b[3]}:{b[4]}:{b[5]}:{b[6]}:{b[7]}"


class DisError(ValueError, BadInputError):
    """A ``--dis`` argument that cannot be used (one line)."""


def parse_dis_url(url: str, *, allow_remote: bool = False) -> tuple[str, int, bool]:
    """``udp://ADDRESS[:PORT]`` -> (address, port, insecure remote).

    Raises
    ------
    DisError
        A malformed URL, a port outside 1-65535, or a non-loopback address without
        ``allow_remote``.
    """
    scheme, sep, rest = url.partition("://")
    if scheme != "udp" or not sep or not rest:
        raise DisError(f"--dis: expected udp://ADDRESS:PORT (e.g. udp://127.0.0.1:3000), "
                       f"got {url!r}")
    host, colon, port_text = rest.rpartition(":")
    if not colon:
        host, port_text = rest, str(DEFAULT_PORT)
    try:
        port = int(port_text)
    except ValueError:
        raise DisError(f"--dis: port must be an integer in [1, 65535], got {port_text!r}"
                       ) from None
    if not 1 <= port <= 65535:
        raise DisError(f"--dis: port must be in [1, 65535], got {port}")
    host = host.strip("[]") or "127.0.0.1"
    loopback = host == "localhost"
    if not loopback:
        try:
            loopback = ipaddress.ip_address(host).is_loopback
        except ValueError:
            loopback = False
    if not loopback and not allow_remote:
        raise DisError(f"--dis: refusing to listen on {host!r}, which other machines can "
                       f"reach (DIS has no security of its own); use 127.0.0.1 or add "
                       f"--allow-insecure-remote")
    return host, port, not loopback


def ecef_state_to_local(frame: LocalFrame, xyz: np.ndarray, vel: np.ndarray,
                        acc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position [m], velocity [m/s] and acceleration [m/s²] in the scenario's local frame of
    ECEF ones (N, 3) each.

    The position: geodetic (WGS-84) latitude, longitude and height h, the foot point on the
    ellipsoid (x − h n̂) projected by the frame's own projection
    (:class:`shipradar.sim.world.kinematics.LocalFrame`: from the centre of its sphere onto
    its tangent plane, t = R y / (y · up₀), y the foot point from that centre); up = h.  A
    vector w is carried by the exact derivative of that map: the foot point moves by
    ê (w·ê) N/(N + h) + n̂_N (w·n̂_N) M/(M + h) (M, N the meridian and prime-vertical radii
    of curvature), the plane point by R (dy/(y·up₀) − y (dy·up₀)/(y·up₀)²), and up by w·n̂.
    """
    lat, lon, h = geodesy.ecef2geodetic(xyz[:, 0], xyz[:, 1], xyz[:, 2])
    phi = np.radians(np.atleast_1d(np.asarray(lat, float)))
    lam = np.radians(np.atleast_1d(np.asarray(lon, float)))
    h = np.atleast_1d(np.asarray(h, float))
    sp, cp, sl, cl = np.sin(phi), np.cos(phi), np.sin(lam), np.cos(lam)
    up = np.column_stack([cp * cl, cp * sl, sp])
    east = np.column_stack([-sl, cl, np.zeros_like(sl)])
    north = np.column_stack([-sp * cl, -sp * sl, cp])
    y = xyz - h[:, None] * up - frame.centre
    d = y @ frame.up0
    t = (frame.radius / d)[:, None] * y
    pos = np.column_stack([t @ frame.east0, t @ frame.north0, h])
    e2 = 1.0 - (geodesy.WGS84_B_M / geodesy.WGS84_A_M) ** 2
    w2 = 1.0 - e2 * sp**2
    n_r = geodesy.WGS84_A_M / np.sqrt(w2)
    m_r = n_r * (1.0 - e2) / w2
    k_e, k_n = n_r / (n_r + h), m_r / (m_r + h)

    def carry(w: np.ndarray) -> np.ndarray:
        dy = (east * (np.sum(w * east, axis=1) * k_e)[:, None]
              + north * (np.sum(w * north, axis=1) * k_n)[:, None])
        dt = (frame.radius / d)[:, None] * (dy - y * ((dy @ frame.up0) / d)[:, None])
        return np.column_stack([dt @ frame.east0, dt @ frame.north0, np.sum(w * up, axis=1)])

    return pos, carry(vel), carry(acc)


def _body_axes(euler: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A body's x, y, z axes in ECEF (N, 3) each of its DIS Euler angles (psi, theta, phi)
    (N, 3) [rad] (IEEE 1278.1: yaw psi about z, pitch theta about the new y, roll phi about
    the new x, from the ECEF axes)."""
    cy, sy = np.cos(euler[:, 0]), np.sin(euler[:, 0])
    cp, sp = np.cos(euler[:, 1]), np.sin(euler[:, 1])
    cr, sr = np.cos(euler[:, 2]), np.sin(euler[:, 2])
    x = np.column_stack([cp * cy, cp * sy, -sp])
    y = np.column_stack([sr * sp * cy - cr * sy, sr * sp * sy + cr * cy, sr * cp])
    z = np.column_stack([cr * sp * cy + sr * sy, cr * sp * sy - sr * cy, cr * cp])
    return x, y, z


def _geocentric_east_north(xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit east and north (ECEF, (N, 3) each) at ECEF points, north at the geocentric
    latitude."""
    lon = np.arctan2(xyz[:, 1], xyz[:, 0])
    lat = np.arctan2(xyz[:, 2], np.hypot(xyz[:, 0], xyz[:, 1]))
    east = np.column_stack([-np.sin(lon), np.cos(lon), np.zeros(len(xyz))])
    north = np.column_stack([-np.sin(lat) * np.cos(lon), -np.sin(lat) * np.sin(lon),
                             np.cos(lat)])
    return east, north


def ecef_heading_deg(xyz: np.ndarray, psi_theta: np.ndarray) -> np.ndarray:
    """Heading [deg, true north, clockwise, in [0, 360)] of bodies at ECEF points (N, 3) [m]
    whose DIS orientation is (psi, theta) (N, 2) [rad] (IEEE 1278.1 Euler angles from the
    ECEF axes: yaw psi about z, then pitch theta about the new y): the body x axis,
    (cos θ cos ψ, cos θ sin ψ, −sin θ), on the local east and north.  North is taken at the
    geocentric latitude: for a level body the heading differs from the geodetic one by a
    factor cos δ (δ ≤ 0.19°) on one component, at most (1 − cos δ)/2 rad = 1.6e-4 deg.
    NaN where ψ or θ is."""
    euler = np.column_stack([psi_theta[:, 0], psi_theta[:, 1], np.zeros(len(psi_theta))])
    x = _body_axes(euler)[0]
    east, north = _geocentric_east_north(xyz)
    return np.degrees(np.arctan2(np.sum(x * east, axis=1), np.sum(x * north, axis=1))) % 360.0


def ecef_heading_rate_dps(xyz: np.ndarray, euler: np.ndarray, omega: np.ndarray
                          ) -> np.ndarray:
    """Rate of the heading (:func:`ecef_heading_deg`) [deg/s] of bodies at ECEF points
    (N, 3) [m] with DIS orientation ``euler`` (psi, theta, phi) (N, 3) [rad] turning at the
    angular velocity ``omega`` (N, 3) [rad/s], in body axes as the Entity State PDU gives it.

    IEEE 1278.1 annex E dead-reckons a rotating entity's orientation by the rotation of
    angle |ω| Δt about ω: the body x axis moves at ẋ = ω_w × x (ω_w = ω in ECEF axes), and
    the heading h = atan2(x·ê, x·n̂) at ḣ = ((ẋ·ê)(x·n̂) − (ẋ·n̂)(x·ê)) / ((x·ê)² + (x·n̂)²).
    For a body turning about the local vertical (a ship's or a level aircraft's turn, any
    bank) the rotation keeps ḣ constant, so h0 + ḣ Δt is the annex's orientation exactly;
    a tilted ω (pitch or roll rates) adds a term of second order in Δt."""
    bx, by, bz = _body_axes(euler)
    w = omega[:, 0:1] * bx + omega[:, 1:2] * by + omega[:, 2:3] * bz
    dx = np.cross(w, bx)
    east, north = _geocentric_east_north(xyz)
    xe, xn = np.sum(bx * east, axis=1), np.sum(bx * north, axis=1)
    de, dn = np.sum(dx * east, axis=1), np.sum(dx * north, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.degrees((de * xn - dn * xe) / (xe**2 + xn**2))


class DisReceiver:
    """Entities from DIS Entity State PDUs received on a UDP socket (module notes).

    Parameters
    ----------
    url : ``udp://ADDRESS:PORT``
    frame : the scenario's local frame
    exercise_id : keep only this exercise (None: any)
    site_app : the radar's own (site, application), for simulation management PDUs
    queue_size : rows held until the run takes them
    allow_remote : accept a non-loopback address
    wait_start : hold the run's start until a Start/Resume PDU addressed to it (the
        testbed's simulation manager starts the radar); entity states are received meanwhile
    timeout_s : how long an entity lives without a PDU [s] (the Remove rows' dead reckoning)
    """

    def __init__(self, url: str, frame: LocalFrame, *, exercise_id: int | None = None,
                 site_app: tuple[int, int] | None = None, queue_size: int = 100_000,
                 allow_remote: bool = False, wait_start: bool = False):
        try:
            from opendis.PduFactory import createPdu
        except ImportError:
            raise DisError("--dis needs the opendis package (pip install --no-deps "
                           "opendis, or make install)") from None
        self._create = createPdu
        host, port, self.insecure_remote = parse_dis_url(url, allow_remote=allow_remote)
        self.endpoint = url
        self.frame = frame
        self.exercise_id = exercise_id
        self.site_app = site_app
        self.queue_size = int(queue_size)
        self._sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET,
                                   socket.SOCK_DGRAM)
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
        try:
            self._sock.bind((host, port))
        except OSError as exc:
            self._sock.close()
            raise DisError(f"--dis: cannot listen on {host}:{port} ({exc.strerror})") from None
        self.port = self._sock.getsockname()[1]
        self._sock.setblocking(False)  # the thread waits in select(), then drains the socket
        self._lock = threading.Lock()
        #: decoded batches (column dicts, local frame) until the run takes them
        self._chunks: list[dict[str, Any]] = []
        self._queued = 0
        # one slot per entity seen: its key (site, application, entity in one integer), id,
        # type and marking (their texts made once, again only when they change), and its
        # last state in ECEF (a Remove Entity PDU dead-reckons it to the removal)
        self._slot: dict[int, int] = {}
        self._slot_id: list[str] = []
        self._slot_type: list[str] = []
        self._slot_name: list[str] = []
        self._slot_raw = np.zeros((0, 2), np.uint64)  # type bytes, marking bytes (low 8)
        self._slot_mark_hi = np.zeros(0, np.uint32)   # marking bytes 9-12
        self._slot_key = np.zeros(0, np.uint64)
        self._last_t = np.zeros(0)
        self._last_state = np.zeros((0, 9))
        self._alive = np.zeros(0, bool)
        self.datagrams = 0
        self.entity_states = 0
        self.dropped = 0
        #: states replaced by a later one of the same entity before the run took them
        self.superseded = 0
        self.bad: dict[str, int] = {}
        self.ignored: dict[str, int] = {}
        self.freezes = 0
        self.frozen_s = 0.0
        #: CPU time of the receiving thread so far [s] (the receive path's cost)
        self.cpu_s = 0.0
        #: set while a Stop/Freeze holds the clock; cleared by Start/Resume
        self.frozen = threading.Event()
        self._running = threading.Event()  # the converse of frozen, to wait on
        self._running.set()
        #: the run waits for a Start/Resume before it starts (:meth:`wait_for_start`)
        self.wait_start = bool(wait_start)
        #: wall seconds the run's start waited for Start/Resume
        self.start_wait_s = 0.0
        if self.wait_start:
            self.frozen.set()
            self._running.clear()
        #: set at the first Entity State PDU received (tests wait on it)
        self.first_entity = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._receive, name="dis", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ receiving
    def _count(self, table: dict[str, int], reason: str) -> None:
        table[reason] = table.get(reason, 0) + 1

    def _receive(self) -> None:
        """The receiving thread: datagrams taken in batches (:data:`BATCH_MAX` or
        :data:`BATCH_S`), each stamped with its arrival, then checked and decoded at once."""
        cpu0 = time.thread_time()
        sock, mono = self._sock, time.monotonic
        recv = sock.recv
        while not self._stop.is_set():
            try:
                if not select.select([sock], [], [], 0.05)[0]:
                    continue
            except (OSError, ValueError):
                return
            batch: list[bytes] = []
            times: list[float] = []
            t_end = mono() + BATCH_S
            while len(batch) < BATCH_MAX:
                try:
                    batch.append(recv(65536))
                except BlockingIOError:
                    left = t_end - mono()
                    if left <= 0 or not select.select([sock], [], [], left)[0]:
                        break
                    continue
                except OSError:
                    return
                times.append(mono())
            with self._lock:
                self._batch(batch, times)
                self.cpu_s = time.thread_time() - cpu0

    def _batch(self, batch: list[bytes], times: list[float]) -> None:
        """One batch of datagrams (under the lock), in order: runs of Entity State PDUs of
        the fixed layout decoded at once (:func:`decode_entity_states`), every other datagram
        on its own (:meth:`_datagram`, opendis)."""
        self.datagrams += len(batch)
        rec, index = decode_entity_states(batch)
        if self.exercise_id is not None and index.size:
            mine = rec["exercise"] == self.exercise_id
            if not mine.all():
                rec, index = rec[mine], index[mine]  # the others counted by _datagram
        received = np.asarray(times)
        if index.size == len(batch):
            self._entity_states(rec, received)
            return
        fast = np.zeros(len(batch), bool)
        fast[index] = True
        # where the batch switches between the two paths
        cuts = np.flatnonzero(fast[1:] != fast[:-1]) + 1
        done = 0
        for lo, hi in zip(np.r_[0, cuts].tolist(), np.r_[cuts, len(batch)].tolist(),
                          strict=True):
            if fast[lo]:
                self._entity_states(rec[done:done + hi - lo], received[lo:hi])
                done += hi - lo
            else:
                for i in range(lo, hi):
                    self._datagram(batch[i], times[i])

    def _datagram(self, data: bytes, received: float) -> None:
        """One datagram off the fast path (under the lock): checked, decoded by opendis,
        applied or counted."""
        if len(data) < HEADER_BYTES:
            self._count(self.bad, "truncated")
            return
        if len(data) > MAX_PDU_BYTES:
            self._count(self.bad, "oversized")
            return
        version, exercise, pdu_type, _family, _stamp, length = struct.unpack(
            ">BBBBIH", data[:10])
        if version not in (5, 6, 7):
            self._count(self.bad, "protocol version")
            return
        if length > len(data):
            self._count(self.bad, "truncated")
            return
        if self.exercise_id is not None and exercise != self.exercise_id:
            self._count(self.ignored, "other exercise")
            return
        if pdu_type not in (_PDU_ESPDU, _PDU_REMOVE, _PDU_START, _PDU_STOP):
            self._count(self.ignored, f"pdu type {pdu_type}")
            return
        try:
            pdu = self._create(bytes(data))
            rec = espdu_record(pdu) if pdu_type == _PDU_ESPDU and pdu is not None else None
        except Exception:  # noqa: BLE001 - any decoding failure is a bad datagram
            self._count(self.bad, "undecodable")
            return
        if pdu is None:
            self._count(self.bad, "undecodable")
            return
        if rec is not None:
            self._entity_states(rec, np.array([received]))
        elif pdu_type == _PDU_REMOVE:
            self._remove(pdu, received)
        elif self._for_me(pdu.receivingEntityID):
            if pdu_type == _PDU_STOP and not self.frozen.is_set():
                self.freezes += 1
                self._running.clear()
                self.frozen.set()
            elif pdu_type == _PDU_START:
                self.frozen.clear()
                self._running.set()
        else:
            self._count(self.ignored, "management for another application")

    def _for_me(self, eid: Any) -> bool:
        if eid.siteID == ALL and eid.applicationID == ALL:
            return True
        if self.site_app is None:
            return False
        site, app = self.site_app
        return eid.siteID in (site, ALL) and eid.applicationID in (app, ALL)

    def _slots_of(self, rec: np.ndarray) -> np.ndarray:
        """Each record's entity slot (int64); a new entity gets one, and the texts of its id,
        type and marking are made when it is new or its type or marking bytes changed."""
        keys = ((rec["site"].astype(np.uint64) << np.uint64(32))
                | (rec["application"].astype(np.uint64) << np.uint64(16))
                | rec["entity"].astype(np.uint64))
        m = keys.size
        slots = np.fromiter(map(self._slot.get, keys.tolist(), itertools.repeat(-1, m)),
                            np.int64, m)
        raw = np.column_stack([rec["type"].copy().view(">u8")[:, 0],
                               rec["marking"][:, :8].copy().view(">u8")[:, 0]]
                              ).astype(np.uint64)
        hi = np.zeros((m, 4), np.uint8)
        hi[:, :3] = rec["marking"][:, 8:]
        mark_hi = hi.view(">u4")[:, 0].astype(np.uint32)
        new = np.flatnonzero(slots < 0)
        if new.size:
            for i in new.tolist():  # new entities only
                key = int(keys[i])
                k = self._slot.get(key)
                if k is None:
                    k = self._slot[key] = len(self._slot_id)
                    e = (key >> 32, (key >> 16) & 0xFFFF, key & 0xFFFF)
                    self._slot_id.append(f"{e[0]}:{e[1]}:{e[2]}")
                    self._slot_type.append("")
                    self._slot_name.append("")
                slots[i] = k
            grow = len(self._slot_id) - self._slot_key.size
            self._slot_key = np.concatenate([self._slot_key, np.zeros(grow, np.uint64)])
            self._slot_raw = np.concatenate([self._slot_raw, np.zeros((grow, 2), np.uint64)])
            self._slot_mark_hi = np.concatenate([self._slot_mark_hi,
                                                 np.zeros(grow, np.uint32)])
            self._last_t = np.concatenate([self._last_t, np.zeros(grow)])
            self._last_state = np.concatenate([self._last_state, np.zeros((grow, 9))])
            self._alive = np.concatenate([self._alive, np.zeros(grow, bool)])
            self._slot_key[slots] = keys
        fresh = np.zeros(m, bool)
        fresh[new] = True
        changed = np.flatnonzero((self._slot_raw[slots] != raw).any(axis=1)
                                 | (self._slot_mark_hi[slots] != mark_hi) | fresh)
        for i in changed.tolist():  # new entities, or a new type or marking
            k = int(slots[i])
            self._slot_type[k] = type_text(rec["type"][i])
            self._slot_name[k] = marking_text(rec["marking"][i]) or self._slot_id[k]
            self._slot_raw[k] = raw[i]
            self._slot_mark_hi[k] = mark_hi[i]
        return slots

    def _entity_states(self, rec: np.ndarray, received: np.ndarray) -> None:
        """Entity State PDUs (:data:`ESPDU_DTYPE` records, in arrival order, under the lock):
        checked, dead-reckoning algorithm applied, carried into the local frame and queued
        (vectorized: a loop only over entities not seen before)."""
        xyz = rec["location"].astype(float)
        vel = rec["velocity"].astype(float)
        acc = rec["acceleration"].astype(float)
        finite = np.isfinite(xyz).all(axis=1) & np.isfinite(vel).all(axis=1) & np.isfinite(
            acc).all(axis=1)
        inside = finite & (np.linalg.norm(np.where(finite[:, None], xyz, 0.0), axis=1)
                           < _INSIDE_EARTH_M)  # the earth's centre, not a place on it
        for mask, reason in ((~finite, "not finite"), (inside, "inside the earth")):
            if mask.any():
                self.bad[reason] = self.bad.get(reason, 0) + int(np.count_nonzero(mask))
        ok = finite & ~inside
        if not ok.all():
            rec, received, xyz, vel, acc = rec[ok], received[ok], xyz[ok], vel[ok], acc[ok]
        m = rec.size
        if not m:
            return
        algo = rec["dr_algorithm"]
        vel[algo == 1] = 0.0  # static
        acc[~np.isin(algo, ACCELERATED)] = 0.0
        if not np.isin(algo, (1, 2, 3, 4, 5)).all():
            body = int(np.count_nonzero((algo >= 6) & (algo <= 9)))
            if body:
                self._count_n(self.ignored, "body-axis dead reckoning taken as FPW", body)
            for a, k in zip(*np.unique(algo[(algo < 1) | (algo > 9)], return_counts=True),
                            strict=True):
                self._count_n(self.ignored, f"dead reckoning algorithm {a} taken as FPW",
                              int(k))
        slots = self._slots_of(rec)
        self.entity_states += m
        # each entity's last state (in ECEF), for a Remove Entity PDU
        last = m - 1 - np.unique(slots[::-1], return_index=True)[1]
        ls = slots[last]
        self._last_t[ls] = received[last]
        self._last_state[ls] = np.column_stack([xyz, vel, acc])[last]
        self._alive[ls] = True
        euler = rec["orientation"].astype(float)
        omega = np.where(np.isin(algo, ROTATING)[:, None],
                         rec["angular_velocity"].astype(float), 0.0)
        active = (rec["appearance"] & DEACTIVATED_BIT) == 0
        self._queue(slots, received, xyz, vel, acc, active, euler, omega)
        if not self.first_entity.is_set():
            self.first_entity.set()

    def _count_n(self, table: dict[str, int], reason: str, k: int) -> None:
        table[reason] = table.get(reason, 0) + k

    def _remove(self, pdu: Any, received: float) -> None:
        """A Remove Entity PDU: its entity (entity 65535: every entity of that site and
        application) leaves at its last state dead-reckoned in ECEF, as DIS does, to now."""
        r = pdu.receivingEntityID
        prefix = (r.siteID << 16) | r.applicationID
        if r.entityID == ALL:
            slots = np.flatnonzero(self._alive & ((self._slot_key >> np.uint64(16))
                                                  == np.uint64(prefix)))
        else:
            k = self._slot.get((prefix << 16) | r.entityID)
            slots = np.array([] if k is None or not self._alive[k] else [k], np.int64)
        if not slots.size:
            self._count(self.ignored, "remove of an unknown entity")
            return
        self._alive[slots] = False
        st = self._last_state[slots]
        p, v, a = st[:, :3], st[:, 3:6], st[:, 6:]
        dt = (received - self._last_t[slots])[:, None]
        nan3 = np.full((slots.size, 3), np.nan)
        self._queue(slots, np.full(slots.size, received), p + v * dt + 0.5 * a * dt * dt,
                    v + a * dt, a, np.zeros(slots.size, bool), nan3, nan3)

    def _queue(self, slots: np.ndarray, received: np.ndarray, xyz: np.ndarray,
               vel: np.ndarray, acc: np.ndarray, active: np.ndarray, euler: np.ndarray,
               omega: np.ndarray) -> None:
        """Queue rows (ECEF states) carried into the local frame, as far as the queue has
        room (:attr:`queue_size` rows; the rest dropped and counted)."""
        room = self.queue_size - self._queued
        if slots.size > room:
            self.dropped += slots.size - room
            if room <= 0:
                return
            slots, received, xyz, vel, acc = (slots[:room], received[:room], xyz[:room],
                                              vel[:room], acc[:room])
            active, euler, omega = active[:room], euler[:room], omega[:room]
        n = slots.size
        pos, v, a = ecef_state_to_local(self.frame, xyz, vel, acc)
        pick = operator.itemgetter(*slots.tolist())
        ids = [pick(self._slot_id)] if n == 1 else list(pick(self._slot_id))
        # a Remove Entity's row too carries the entity's type and name (its row may be the
        # first the run sees of an entity new in the batch: the drain keeps the last)
        types = [pick(self._slot_type)] if n == 1 else list(pick(self._slot_type))
        names = [pick(self._slot_name)] if n == 1 else list(pick(self._slot_name))
        self._chunks.append({
            "slot": slots, "id": ids, "received": received, "pos": pos, "vel": v, "acc": a,
            "type": types, "name": names, "active": active,
            "heading_deg": ecef_heading_deg(xyz, euler[:, :2]),
            "heading_rate_dps": ecef_heading_rate_dps(xyz, euler, omega)})
        self._queued += n

    # ------------------------------------------------------------------ the run's side
    def drain(self, now_s: float) -> list[dict[str, Any]]:
        """The states received since the last call, as one ``entities`` payload (times: the
        simulated time of arrival, ``now_s`` less the wall time since; negative before the run's
        start): each entity's latest only, in the order the entities first appear (the run
        applies them all at ``now_s``, where an earlier state of the same entity would be
        replaced unused; counted ``superseded``)."""
        with self._lock:
            chunks, self._chunks, self._queued = self._chunks, [], 0
        if not chunks:
            return []
        wall = time.monotonic()
        # an entity's states are applied at once at the revolution's start, where only its
        # latest (arrival times rise) moves it: the others are superseded, counted, not sent
        slots = np.concatenate([c["slot"] for c in chunks])
        n = slots.size
        # each entity's last row, in the order the entities first appear (a new entity's
        # row in the target list is its first appearance's)
        first = np.unique(slots, return_index=True)[1]
        keep = (n - 1 - np.unique(slots[::-1], return_index=True)[1])[np.argsort(first)]
        if keep.size < n:
            with self._lock:
                self.superseded += n - keep.size
        every = keep.size == n

        def cat(key: str) -> np.ndarray:
            a = np.concatenate([c[key] for c in chunks])
            return a if every else a[keep]

        def join(key: str) -> list:
            a = [x for c in chunks for x in c[key]] if len(chunks) > 1 else chunks[0][key]
            if every:
                return a
            got = operator.itemgetter(*keep.tolist())(a)
            return [got] if keep.size == 1 else list(got)

        pos, vel, acc = cat("pos"), cat("vel"), cat("acc")
        return [{
            "source": "dis", "id": join("id"),
            # received before the run started (--dis-wait-start, or before the first
            # revolution): a negative time, so the latest of them stands (not all at 0)
            "time_s": now_s - (wall - cat("received")),
            "east_m": pos[:, 0], "north_m": pos[:, 1], "up_m": pos[:, 2],
            "v_east_mps": vel[:, 0], "v_north_mps": vel[:, 1], "v_up_mps": vel[:, 2],
            "a_east_mps2": acc[:, 0], "a_north_mps2": acc[:, 1], "a_up_mps2": acc[:, 2],
            "type": join("type"), "name": join("name"), "active": cat("active"),
            "heading_deg": cat("heading_deg"), "heading_rate_dps": cat("heading_rate_dps")}]

    def wait_for_start(self) -> float:
        """Block until a Start/Resume PDU addressed to this radar (or to all) when the
        receiver was made with ``wait_start`` (at once otherwise, or after :meth:`close`);
        returns the wall seconds waited (``start_wait_s``)."""
        if not self.wait_start:
            return 0.0
        t0 = time.monotonic()
        while not self._running.wait(0.05) and not self._stop.is_set():
            pass
        self.start_wait_s = time.monotonic() - t0
        return self.start_wait_s

    def wait_while_frozen(self) -> float:
        """Block while a Stop/Freeze holds the clock (until Start/Resume, or close());
        returns the wall seconds waited."""
        if not self.frozen.is_set():
            return 0.0
        t0 = time.monotonic()
        while not self._running.wait(0.2) and not self._stop.is_set():
            pass
        waited = time.monotonic() - t0
        self.frozen_s += waited
        return waited

    def stats(self) -> dict[str, Any]:
        with self._lock:
            return {"endpoint": self.endpoint, "port": self.port, "datagrams": self.datagrams,
                    "entity_states": self.entity_states, "dropped": self.dropped,
                    "superseded": self.superseded,
                    "bad_datagrams": dict(sorted(self.bad.items())),
                    "ignored": dict(sorted(self.ignored.items())),
                    "freezes": self.freezes, "frozen_s": round(self.frozen_s, 3),
                    **({"start_wait_s": round(self.start_wait_s, 3)} if self.wait_start
                       else {}),
                    "cpu_s": round(self.cpu_s, 3)}

    def close(self) -> None:
        self._stop.set()
        self._running.set()
        self._thread.join(timeout=2.0)
        self._sock.close()
