"""DIS (IEEE 1278.1) input: entities of a running DIS simulation as live targets.

``shipradar run SCENARIO --dis udp://ADDRESS:PORT`` binds a UDP socket (loopback by default;
another address needs ``--allow-insecure-remote``: DIS has no security of its own) and
decodes the PDUs with ``opendis`` (PyPI; DIS 6 and 7 share the layouts used here) on its own
thread:

* **Entity State PDU** (type 1): one state of entity ``site:application:entity`` (its id in
  the truth topic; the marking text its name; its entity type as the text
  ``kind:domain:country:category:subcategory:specific:extra`` matched against the scenario's
  ``entity_types:`` patterns). World coordinates (geocentric ECEF) are carried into the
  scenario's local frame by the frame's own projection (position through WGS-84 geodetic
  coordinates, velocity and acceleration through the projection's Jacobian, a central
  difference). Dead reckoning by the PDU's algorithm: static (1): no motion; FPW (2) and
  RPW (3): constant velocity; RVW (4) and FVW (5): constant velocity and acceleration (the
  rotating variants differ only in orientation, which the radar does not use); the body-axis
  algorithms (6-9) as FPW (their body-frame acceleration is not used: counted). The
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
:mod:`shipradar.sim.world.live`.  Datagrams wait in a queue of ``queue_size`` rows (the
scenario's ``external.queue_size``), taken at each revolution start; beyond it they are
dropped and counted.
"""

from __future__ import annotations

import ipaddress
import math
import socket
import struct
import threading
import time
from typing import Any

import numpy as np

from shipradar.sim.world import geodesy
from shipradar.sim.world.errors import BadInputError
from shipradar.sim.world.kinematics import LocalFrame

__all__ = ["DEFAULT_PORT", "MAX_PDU_BYTES", "DisError", "DisReceiver", "parse_dis_url"]

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
_ZERO3 = (0.0, 0.0, 0.0)
#: Step of the central difference that carries an ECEF vector into the local frame [s].
_JACOBIAN_STEP = 0.5


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


def _ecef_to_local(frame: LocalFrame, xyz: np.ndarray) -> np.ndarray:
    """Local (east, north, up) [m] of ECEF points (N, 3) [m]: geodetic on WGS-84, then the
    frame's projection (up = height above the ellipsoid)."""
    from shipradar.sim.world.traffic import local_positions

    lat, lon, h = geodesy.ecef2geodetic(xyz[:, 0], xyz[:, 1], xyz[:, 2])
    lat, lon, h = (np.atleast_1d(np.asarray(a, float)) for a in (lat, lon, h))
    return np.column_stack([local_positions(frame, lat, lon), h])


def ecef_state_to_local(frame: LocalFrame, xyz: np.ndarray, vel: np.ndarray,
                        acc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position [m], velocity [m/s] and acceleration [m/s²] in the local frame of ECEF ones
    (N, 3) each: the position mapped, the vectors by the map's Jacobian (central difference
    of ±0.5 s along each)."""
    pos = _ecef_to_local(frame, xyz)
    h = _JACOBIAN_STEP

    def carry(w: np.ndarray) -> np.ndarray:
        return (_ecef_to_local(frame, xyz + w * h) - _ecef_to_local(frame, xyz - w * h)) / (2 * h)

    return pos, carry(vel), carry(acc)


def ecef_heading_deg(xyz: np.ndarray, psi_theta: np.ndarray) -> np.ndarray:
    """Heading [deg, true north, clockwise, in [0, 360)] of bodies at ECEF points (N, 3) [m]
    whose DIS orientation is (psi, theta) (N, 2) [rad] (IEEE 1278.1 Euler angles from the
    ECEF axes: yaw psi about z, then pitch theta about the new y): the body x axis,
    (cos θ cos ψ, cos θ sin ψ, −sin θ), on the local east and north.  North is taken at the
    geocentric latitude: for a level body the heading differs from the geodetic one by a
    factor cos δ (δ ≤ 0.19°) on one component, at most (1 − cos δ)/2 rad = 1.6e-4 deg.
    NaN where ψ or θ is."""
    psi, theta = psi_theta[:, 0], psi_theta[:, 1]
    x = np.column_stack([np.cos(theta) * np.cos(psi), np.cos(theta) * np.sin(psi),
                         -np.sin(theta)])
    lon = np.arctan2(xyz[:, 1], xyz[:, 0])
    lat = np.arctan2(xyz[:, 2], np.hypot(xyz[:, 0], xyz[:, 1]))
    east = x[:, 1] * np.cos(lon) - x[:, 0] * np.sin(lon)
    north = (-np.sin(lat) * (np.cos(lon) * x[:, 0] + np.sin(lon) * x[:, 1])
             + np.cos(lat) * x[:, 2])
    return np.degrees(np.arctan2(east, north)) % 360.0


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
        self._sock.settimeout(0.05)
        self._lock = threading.Lock()
        self._rows: list[dict[str, Any]] = []
        self._queued = 0
        self._last: dict[str, tuple[float, tuple[float, ...], tuple[float, ...],
                                    tuple[float, ...]]] = {}
        self.datagrams = 0
        self.entity_states = 0
        self.dropped = 0
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
        cpu0 = time.thread_time()
        while not self._stop.is_set():
            try:
                data = self._sock.recv(65536)
            except TimeoutError:
                continue
            except OSError:
                return
            received = time.monotonic()
            with self._lock:
                self.datagrams += 1
                self._datagram(data, received)
                self.cpu_s = time.thread_time() - cpu0

    def _datagram(self, data: bytes, received: float) -> None:
        """One datagram (under the lock): checked, decoded, queued or counted."""
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
        except Exception:  # noqa: BLE001 - any decoding failure is a bad datagram
            self._count(self.bad, "undecodable")
            return
        if pdu is None:
            self._count(self.bad, "undecodable")
            return
        if pdu_type == _PDU_ESPDU:
            self._entity_state(pdu, received)
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

    def _entity_state(self, pdu: Any, received: float) -> None:
        e, t = pdu.entityID, pdu.entityType
        eid = f"{e.siteID}:{e.applicationID}:{e.entityID}"
        loc, v = pdu.entityLocation, pdu.entityLinearVelocity
        drp = pdu.deadReckoningParameters
        algo = int(drp.deadReckoningAlgorithm)
        a = drp.entityLinearAcceleration
        # one PDU's numbers as Python floats: numpy's per-call overhead on 3-vectors was a
        # quarter of the receive path (benchmarks/dis_load.py); arrays are made per batch
        xyz = (float(loc.x), float(loc.y), float(loc.z))
        vel = (float(v.x), float(v.y), float(v.z))
        acc = (float(a.x), float(a.y), float(a.z))
        if not all(map(math.isfinite, (*xyz, *vel, *acc))):
            self._count(self.bad, "not finite")
            return
        if math.hypot(*xyz) < 6.0e6:  # the earth's centre, not a place on it
            self._count(self.bad, "inside the earth")
            return
        o = pdu.entityOrientation
        orient = (float(o.psi), float(o.theta))
        if algo == 1:
            vel = _ZERO3
        if algo not in (4, 5):
            if algo in (6, 7, 8, 9):
                self._count(self.ignored, "body-axis dead reckoning taken as FPW")
            elif algo not in (1, 2, 3):
                self._count(self.ignored, f"dead reckoning algorithm {algo} taken as FPW")
            acc = _ZERO3
        try:
            name = pdu.marking.charactersString().strip()
        except (UnicodeDecodeError, ValueError):
            name = ""
        appearance = int(pdu.entityAppearance) if isinstance(pdu.entityAppearance, int) else 0
        active = not appearance & DEACTIVATED_BIT
        type_text = (f"{t.entityKind}:{t.domain}:{t.country}:{t.category}:{t.subcategory}:"
                     f"{t.specific}:{t.extra}")
        self.entity_states += 1
        # kept in ECEF: the frame's conversion is done for a whole batch at once (drain)
        self._last[eid] = (received, xyz, vel, acc)
        self._queue_row(eid, received, xyz, vel, acc, type_text, name or eid, active, orient)
        if not self.first_entity.is_set():
            self.first_entity.set()

    def _remove(self, pdu: Any, received: float) -> None:
        r = pdu.receivingEntityID
        prefix = f"{r.siteID}:{r.applicationID}:"
        ids = ([k for k in self._last if k.startswith(prefix)] if r.entityID == ALL
               else [f"{prefix}{r.entityID}"])
        gone = 0
        for eid in ids:
            last = self._last.pop(eid, None)
            if last is None:
                continue
            t0, p3, v3, a3 = last  # dead-reckoned in ECEF, as DIS does, to the removal
            p, v, a = np.asarray(p3), np.asarray(v3), np.asarray(a3)
            dt = received - t0
            self._queue_row(eid, received, p + v * dt + 0.5 * a * dt * dt, v + a * dt, a,
                            None, None, False)
            gone += 1
        if not gone:
            self._count(self.ignored, "remove of an unknown entity")

    def _queue_row(self, eid, received, pos, vel, acc, type_text, name, active,
                   orient=(math.nan, math.nan)) -> None:
        if self._queued >= self.queue_size:
            self.dropped += 1
            return
        self._rows.append({"id": eid, "received": received, "pos": pos, "vel": vel,
                           "acc": acc, "type": type_text, "name": name, "active": active,
                           "orient": orient})
        self._queued += 1

    # ------------------------------------------------------------------ the run's side
    def drain(self, now_s: float) -> list[dict[str, Any]]:
        """The states received since the last call, as one ``entities`` payload (times: the
        simulated time of arrival, ``now_s`` less the wall time since; negative before the run's
        start)."""
        with self._lock:
            rows, self._rows, self._queued = self._rows, [], 0
        if not rows:
            return []
        wall = time.monotonic()
        # the ECEF states of the batch into the local frame at once (vectorized)
        xyz = np.array([r["pos"] for r in rows])
        pos, vel, acc = ecef_state_to_local(self.frame, xyz, np.array([r["vel"] for r in rows]),
                                            np.array([r["acc"] for r in rows]))
        heading = ecef_heading_deg(xyz, np.array([r["orient"] for r in rows]))
        return [{
            "source": "dis", "id": [r["id"] for r in rows],
            # received before the run started (--dis-wait-start, or before the first
            # revolution): a negative time, so the latest of them stands (not all at 0)
            "time_s": np.array([now_s - (wall - r["received"]) for r in rows]),
            "east_m": pos[:, 0], "north_m": pos[:, 1], "up_m": pos[:, 2],
            "v_east_mps": vel[:, 0], "v_north_mps": vel[:, 1], "v_up_mps": vel[:, 2],
            "a_east_mps2": acc[:, 0], "a_north_mps2": acc[:, 1], "a_up_mps2": acc[:, 2],
            "type": [r["type"] for r in rows], "name": [r["name"] for r in rows],
            "active": np.array([r["active"] for r in rows], bool), "heading_deg": heading}]

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
