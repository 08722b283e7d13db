"""Fly a few entities over DIS (IEEE 1278.1) for ``shipradar run SCENARIO --dis udp://...``.

Only opendis (PyPI) and the standard library: what any DIS simulation would send.

    python examples/dis_sender.py [--host 127.0.0.1] [--port 3000] [--seconds 60] [--rate 5]
        [--exercise 1] [--freeze-at S --resume-at S] [--remove-at S] [--junk]

Three entities around 44.6 N 63.0 W (the shipped scenes' origin), each an Entity State PDU
``--rate`` times a second (DIS's heartbeat is 5 s; a moving entity sends more often):

* 1:1:1 "FRIGATE 2", a surface ship (kind 1, domain 3) at 12 kn due north, dead reckoning FPW;
* 1:1:2 "SKIMMER", a sea-skimming missile (kind 2 munition, domain 6 anti-ship) inbound at
  280 m/s, FVW with a small acceleration;
* 1:1:3 "PATROL", an aircraft (kind 1, domain 2) circling at 3000 m, RVW; its last PDU has
  the appearance's "deactivated" bit (bit 23) set.

``--freeze-at``/``--resume-at`` send a Stop/Freeze and a Start/Resume PDU to all sites and
applications; ``--remove-at`` a Remove Entity PDU for 1:1:2; ``--junk`` adds a truncated
datagram, a datagram of another protocol version and a Fire PDU (counted and ignored by the
receiver).
"""

from __future__ import annotations

import argparse
import math
import socket
import time
from io import BytesIO

from opendis.DataOutputStream import DataOutputStream
from opendis.dis7 import (
    EntityID,
    EntityStatePdu,
    EntityType,
    EulerAngles,
    FirePdu,
    RemoveEntityPdu,
    StartResumePdu,
    StopFreezePdu,
    Vector3Double,
    Vector3Float,
)

A, B = 6378137.0, 6356752.31424518  # WGS-84 semi-axes [m]
ORIGIN = (44.6, -63.0)
KNOT = 1852.0 / 3600.0
DEACTIVATED = 1 << 23
ALL = 0xFFFF


def geodetic_to_ecef(lat_deg: float, lon_deg: float, h: float) -> tuple[float, float, float]:
    lat, lon = math.radians(lat_deg), math.radians(lon_deg)
    n = A * A / math.hypot(A * math.cos(lat), B * math.sin(lat))
    return ((n + h) * math.cos(lat) * math.cos(lon), (n + h) * math.cos(lat) * math.sin(lon),
            (n * (B / A) ** 2 + h) * math.sin(lat))


def enu_to_ecef_vector(lat_deg: float, lon_deg: float, e: float, n: float, u: float):
    lat, lon = math.radians(lat_deg), math.radians(lon_deg)
    sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
    return (-so * e - sl * co * n + cl * co * u, co * e - sl * so * n + cl * so * u,
            cl * n + sl * u)


def offset(east_m: float, north_m: float) -> tuple[float, float]:
    """Latitude, longitude [deg] a small east/north offset from the origin."""
    lat0, lon0 = ORIGIN
    return (lat0 + math.degrees(north_m / 6_367_000.0),
            lon0 + math.degrees(east_m / (6_388_000.0 * math.cos(math.radians(lat0)))))


def orientation(lat: float, lon: float, heading_deg: float) -> EulerAngles:
    """DIS Euler angles (psi, theta; phi 0) [rad] of a level body heading ``heading_deg``
    (true north, clockwise) at lat/lon [deg]: its x axis in ECEF."""
    h = math.radians(heading_deg)
    x, y, z = enu_to_ecef_vector(lat, lon, math.sin(h), math.cos(h), 0.0)
    return EulerAngles(math.atan2(y, x), -math.asin(max(-1.0, min(1.0, z))), 0.0)


def entity_state(exercise: int, number: int, kind: tuple[int, ...], marking: str,
                 lat: float, lon: float, h: float, vel_enu, acc_enu, algorithm: int,
                 appearance: int = 0) -> bytes:
    pdu = EntityStatePdu()
    pdu.protocolVersion = 7
    pdu.exerciseID = exercise
    pdu.entityID = EntityID(1, 1, number)
    pdu.entityType = EntityType(*kind)
    pdu.entityLocation = Vector3Double(*geodetic_to_ecef(lat, lon, h))
    pdu.entityLinearVelocity = Vector3Float(*enu_to_ecef_vector(lat, lon, *vel_enu))
    # the body heads along its horizontal velocity (north when at rest)
    pdu.entityOrientation = orientation(
        lat, lon, math.degrees(math.atan2(vel_enu[0], vel_enu[1])) % 360.0)
    pdu.deadReckoningParameters.deadReckoningAlgorithm = algorithm
    pdu.deadReckoningParameters.entityLinearAcceleration = Vector3Float(
        *enu_to_ecef_vector(lat, lon, *acc_enu))
    pdu.marking.setString(marking)
    pdu.entityAppearance = appearance
    pdu.capabilities = 0
    return serialize(pdu)


def serialize(pdu) -> bytes:
    pdu.pduStatus = 0  # opendis's default is a record object its writer cannot write
    # opendis 1.0's constructors set the instance's type and family to 0 over the class's own
    pdu.pduType = type(pdu).pduType
    pdu.protocolFamily = type(pdu).protocolFamily
    buf = BytesIO()
    pdu.serialize(DataOutputStream(buf))
    data = bytearray(buf.getvalue())
    data[8:10] = len(data).to_bytes(2, "big")  # the PDU length field (opendis leaves 0)
    return bytes(data)


def management(cls, exercise: int) -> bytes:
    pdu = cls()
    pdu.protocolVersion = 7
    pdu.exerciseID = exercise
    pdu.originatingEntityID = EntityID(9, 9, 0)
    pdu.receivingEntityID = EntityID(ALL, ALL, 0)
    return serialize(pdu)


def remove(exercise: int, number: int) -> bytes:
    pdu = RemoveEntityPdu()
    pdu.protocolVersion = 7
    pdu.exerciseID = exercise
    pdu.originatingEntityID = EntityID(9, 9, 0)
    pdu.receivingEntityID = EntityID(1, 1, number)
    return serialize(pdu)


def junk(exercise: int) -> list[bytes]:
    fire = FirePdu()
    fire.protocolVersion = 7
    fire.exerciseID = exercise
    try:
        fire_bytes = serialize(fire)
    except Exception:  # noqa: BLE001 - a PDU opendis cannot write: a hand-made header
        fire_bytes = bytes([7, exercise, 2, 2]) + bytes(92)
    return [b"\x07\x01", bytes([99, exercise, 1, 1]) + bytes(140), fire_bytes]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--host", default="127.0.0.1")
    ap.add_argument("--port", type=int, default=3000)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--rate", type=float, default=5.0, help="PDUs per entity per second")
    ap.add_argument("--exercise", type=int, default=1)
    ap.add_argument("--freeze-at", type=float, default=None)
    ap.add_argument("--resume-at", type=float, default=None)
    ap.add_argument("--remove-at", type=float, default=None)
    ap.add_argument("--junk", action="store_true")
    args = ap.parse_args()
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    to = (args.host, args.port)
    ex = args.exercise
    t0 = time.monotonic()
    sent_freeze = sent_resume = sent_remove = False
    removed = False
    if args.junk:
        for d in junk(ex):
            sock.sendto(d, to)
    k = 0
    while True:
        t = time.monotonic() - t0
        if t >= args.seconds:
            break
        last = t + 1.0 / args.rate >= args.seconds
        # the frigate: 12 kn due north from 6 km east
        v = 12 * KNOT
        lat, lon = offset(6000.0, 2000.0 + v * t)
        sock.sendto(entity_state(ex, 1, (1, 3, 39, 3, 4, 0, 0), "FRIGATE 2", lat, lon, 0.0,
                                 (0.0, v, 0.0), (0.0, 0.0, 0.0), 2), to)
        if not removed:  # the missile: inbound from the north-east, 5 m up
            s = 280.0 + 0.5 * t
            d = 20000.0 - (280.0 * t + 0.25 * t * t)
            lat, lon = offset(d / math.sqrt(2), d / math.sqrt(2))
            u = -1 / math.sqrt(2)
            sock.sendto(entity_state(ex, 2, (2, 6, 222, 1, 1, 0, 0), "SKIMMER", lat, lon, 5.0,
                                     (s * u, s * u, 0.0), (0.5 * u, 0.5 * u, 0.0), 5), to)
        w = 2 * math.pi / 120.0  # the patrol: a 120 s circle of 4 km radius, 3000 m up
        lat, lon = offset(-10000.0 + 4000.0 * math.cos(w * t), 8000.0 + 4000.0 * math.sin(w * t))
        vel = (-4000.0 * w * math.sin(w * t), 4000.0 * w * math.cos(w * t), 0.0)
        acc = (-4000.0 * w * w * math.cos(w * t), -4000.0 * w * w * math.sin(w * t), 0.0)
        sock.sendto(entity_state(ex, 3, (1, 2, 39, 1, 1, 0, 0), "PATROL", lat, lon, 3000.0,
                                 vel, acc, 4, DEACTIVATED if last else 0), to)
        if args.freeze_at is not None and t >= args.freeze_at and not sent_freeze:
            sock.sendto(management(StopFreezePdu, ex), to)
            sent_freeze = True
        if args.resume_at is not None and t >= args.resume_at and not sent_resume:
            sock.sendto(management(StartResumePdu, ex), to)
            sent_resume = True
        if args.remove_at is not None and t >= args.remove_at and not sent_remove:
            sock.sendto(remove(ex, 2), to)
            sent_remove = removed = True
        k += 1
        time.sleep(max(0.0, t0 + k / args.rate - time.monotonic()))
    sock.close()


if __name__ == "__main__":
    main()
