"""The Entity State PDU's fast decoder (``shipradar.sim.adapters.dis.decode_entity_states``)
against opendis: PDUs built by opendis (DIS 6 and 7, every dead-reckoning algorithm, with and
without articulation parameters) decode field by field to what opendis's own parser reads;
what does not have the fixed layout is left to opendis; and a receiver gives the same rows
whichever path a PDU takes."""

from __future__ import annotations

from io import BytesIO

import numpy as np
import pytest

pytest.importorskip("opendis")

from opendis.DataOutputStream import DataOutputStream  # noqa: E402
from opendis.dis7 import (  # noqa: E402
    EntityID,
    EntityStatePdu,
    EntityType,
    EulerAngles,
    FirePdu,
    VariableParameter,
    Vector3Double,
    Vector3Float,
)
from opendis.PduFactory import createPdu  # noqa: E402

from shipradar.sim.adapters.dis import (  # noqa: E402
    ESPDU_DTYPE,
    DisReceiver,
    decode_entity_states,
)
from shipradar.sim.world import geodesy  # noqa: E402
from shipradar.sim.world.kinematics import LocalFrame  # noqa: E402
from shipradar.sim.world.scenario import Origin  # noqa: E402

from .helpers import free_port  # noqa: E402

FRAME = LocalFrame(Origin(lat_deg=44.6, lon_deg=-63.0))


def _serialize(pdu, length: int | None = None) -> bytes:
    pdu.pduStatus = 0
    pdu.pduType, pdu.protocolFamily = type(pdu).pduType, type(pdu).protocolFamily
    buf = BytesIO()
    pdu.serialize(DataOutputStream(buf))
    data = bytearray(buf.getvalue())
    data[8:10] = (len(data) if length is None else length).to_bytes(2, "big")
    return bytes(data)


def _espdu(rng: np.random.Generator, version: int, algorithm: int, articulations: int,
           marking: str = "") -> bytes:
    """An Entity State PDU with every field drawn at random (opendis only)."""
    u = rng.integers
    p = EntityStatePdu()
    p.protocolVersion, p.exerciseID, p.timestamp = version, int(u(0, 256)), int(u(0, 2**32))
    p.entityID = EntityID(int(u(0, 65535)), int(u(0, 65535)), int(u(0, 65535)))
    p.forceId = int(u(0, 256))
    p.entityType = EntityType(*(int(u(0, 256)) for _ in range(2)), int(u(0, 65536)),
                              *(int(u(0, 256)) for _ in range(4)))
    p.alternativeEntityType = EntityType(*(int(u(0, 256)) for _ in range(2)),
                                         int(u(0, 65536)), *(int(u(0, 256)) for _ in range(4)))
    lat, lon = rng.uniform(-80, 80), rng.uniform(-180, 180)
    p.entityLocation = Vector3Double(*(float(c) for c in geodesy.geodetic2ecef(
        lat, lon, rng.uniform(0, 1e4))))
    p.entityLinearVelocity = Vector3Float(*rng.normal(0, 300, 3).tolist())
    p.entityOrientation = EulerAngles(*rng.uniform(-np.pi, np.pi, 3).tolist())
    p.entityAppearance = int(u(0, 2**32))
    drp = p.deadReckoningParameters
    drp.deadReckoningAlgorithm = algorithm
    drp.parameters = [int(u(0, 256)) for _ in range(15)]
    drp.entityLinearAcceleration = Vector3Float(*rng.normal(0, 10, 3).tolist())
    drp.entityAngularVelocity = Vector3Float(*rng.normal(0, 0.2, 3).tolist())
    p.marking.characterSet = int(u(0, 256))
    p.marking.setString(marking or "".join(chr(int(c)) for c in u(32, 127, int(u(0, 12)))))
    p.capabilities = int(u(0, 2**32))
    for _ in range(articulations):
        p.variableParameters.append(VariableParameter(
            int(u(0, 256)), float(rng.normal()), int(u(0, 2**32)), int(u(0, 65536)),
            int(u(0, 256))))
    return _serialize(p)


def _pdus(seed: int = 1) -> list[bytes]:
    rng = np.random.default_rng(seed)
    return [_espdu(rng, version, algorithm, art)
            for version in (6, 7) for algorithm in range(10) for art in (0, 1, 3)]


def _vec(v, names=("x", "y", "z")) -> list[float]:
    return [float(getattr(v, k)) for k in names]


def _type(t) -> list[int]:
    return [t.entityKind, t.domain, t.country >> 8, t.country & 0xFF, t.category,
            t.subcategory, t.specific, t.extra]


def test_fast_decoder_equals_opendis_field_by_field():
    data = _pdus()
    rec, index = decode_entity_states(data)
    assert index.tolist() == list(range(len(data)))
    assert ESPDU_DTYPE.itemsize == 144
    for r, d in zip(rec, data, strict=True):
        p = createPdu(d)
        assert [int(r[k]) for k in ("version", "exercise", "pdu_type", "family", "timestamp",
                                    "length")] == [p.protocolVersion, p.exerciseID, p.pduType,
                                                   p.protocolFamily, p.timestamp, len(d)]
        e = p.entityID
        assert (int(r["site"]), int(r["application"]), int(r["entity"])) == (
            e.siteID, e.applicationID, e.entityID)
        assert int(r["force"]) == p.forceId
        assert int(r["n_articulation"]) == len(p.variableParameters)
        assert r["type"].tolist() == _type(p.entityType)
        assert r["alternative_type"].tolist() == _type(p.alternativeEntityType)
        assert r["velocity"].tolist() == _vec(p.entityLinearVelocity)
        assert r["location"].tolist() == _vec(p.entityLocation)
        assert r["orientation"].tolist() == _vec(p.entityOrientation, ("psi", "theta", "phi"))
        assert int(r["appearance"]) == p.entityAppearance
        drp = p.deadReckoningParameters
        assert int(r["dr_algorithm"]) == drp.deadReckoningAlgorithm
        assert r["dr_parameters"].tolist() == list(drp.parameters)
        assert r["acceleration"].tolist() == _vec(drp.entityLinearAcceleration)
        assert r["angular_velocity"].tolist() == _vec(drp.entityAngularVelocity)
        assert int(r["character_set"]) == p.marking.characterSet
        assert r["marking"].astype(np.int8).tolist() == list(p.marking.characters)
        assert int(r["capabilities"]) == p.capabilities


def test_what_is_not_the_fixed_layout_is_left_to_opendis():
    """A length field that is not the datagram's size (opendis's own 0 included), a size
    that is not 144 + 16 per articulation parameter, another PDU type of 144 bytes, another
    protocol version, a truncated PDU: none is decoded by the fast path."""
    rng = np.random.default_rng(2)
    good = _espdu(rng, 7, 2, 0)
    art = _espdu(rng, 6, 4, 2)
    zero_length = good[:8] + b"\0\0" + good[10:]
    fire = FirePdu()
    fire.protocolVersion = 7
    fire_bytes = _serialize(fire)
    fire_bytes = fire_bytes + bytes(max(0, 144 - len(fire_bytes)))
    fire_bytes = fire_bytes[:8] + len(fire_bytes).to_bytes(2, "big") + fire_bytes[10:]
    old = bytes([4]) + good[1:]
    short = good[:100]
    miscount = art[:19] + bytes([1]) + art[20:]  # says one parameter, carries two
    data = [zero_length, good, art + b"", miscount, fire_bytes, old, short, art]
    _, index = decode_entity_states(data)
    assert index.tolist() == [1, 2, 7]


def _each_drained(batches: list[list[bytes]]) -> list[tuple[dict, dict]]:
    """Each batch of datagrams through a receiver of its own (as received 10 ms apart): the
    drained payload and the receiver's counts."""
    out = []
    for data in batches:
        rx = DisReceiver(f"udp://127.0.0.1:{free_port()}", FRAME)
        try:
            with rx._lock:
                rx._batch(data, [100.0 + 0.01 * i for i in range(len(data))])
            (payload,) = rx.drain(0.0)
            out.append((payload, rx.stats()))
        finally:
            rx.close()
    return out


def test_a_receiver_gives_the_same_rows_on_either_path():
    """The same Entity State PDUs (every algorithm, DIS 6 and 7, with articulation
    parameters, a non-ASCII marking) through the fast decoder and, with their length field
    zeroed, through opendis: the same ids, names, types, states, headings and heading rates,
    and the same counts."""
    rng = np.random.default_rng(3)
    data = [_espdu(rng, v, a, k, marking=m) for v in (6, 7) for a in range(10)
            for k, m in ((0, "ALPHA 1"), (2, ""))]
    p = EntityStatePdu()
    p.protocolVersion = 7
    p.entityLocation = Vector3Double(*(float(c) for c in geodesy.geodetic2ecef(44.6, -63, 0)))
    p.marking.characters = [65, -56] + [0] * 9  # 'A', then a byte that is not ASCII
    p.entityID = EntityID(9, 9, 9)
    p.entityAppearance = p.capabilities = 0
    data.append(_serialize(p))
    slow = [d[:8] + b"\0\0" + d[10:] for d in data]
    (fast, st_fast), (ref, st_ref) = _each_drained([data, slow])
    assert st_fast["entity_states"] == st_ref["entity_states"] == len(data)
    assert st_fast["ignored"] == st_ref["ignored"]
    assert st_fast["ignored"]["body-axis dead reckoning taken as FPW"] == 4 * 2 * 2
    assert fast["name"][-1] == "9:9:9"  # opendis cannot read that marking: the id
    # arrival times to simulated times by the wall clock at drain: compared as offsets
    np.testing.assert_allclose(np.diff(fast.pop("time_s")), np.diff(ref.pop("time_s")),
                               atol=1e-6)
    for key, v in ref.items():
        if isinstance(v, np.ndarray):  # one batch against one row at a time: to ~1 ulp
            np.testing.assert_allclose(fast[key], v, rtol=1e-12, atol=1e-9, err_msg=key)
        else:
            assert fast[key] == v, key


def test_only_the_latest_state_of_an_entity_is_handed_to_the_run():
    """Three states of one entity and one of another in a batch: the drain hands over the
    latest of each (the same row as that state alone gives), in the order the entities first
    appear, the two others counted ``superseded``."""
    rng = np.random.default_rng(4)
    a1, b, a2, a3 = (_espdu(rng, 7, 2, 0) for _ in range(4))
    a2, a3 = (a1[:18] + x[18:] for x in (a2, a3))  # a1's entity id (bytes 12-17)
    (payload, st), (alone, _) = _each_drained([[a1, b, a2, a3], [a3, b]])
    assert payload["id"] == alone["id"] and len(set(payload["id"])) == 2
    for key in ("east_m", "north_m", "up_m", "v_east_mps", "heading_deg"):
        assert payload[key] == pytest.approx(alone[key], rel=1e-12), key
    assert st["superseded"] == 2 and st["entity_states"] == 4
