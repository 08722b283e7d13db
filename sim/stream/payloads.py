"""The engine's non-sector messages shaped from what it knows: ``meta``, ``eos``,
``truth[sensors]``, ``end`` and the ``entities`` a run used.

The engine (:mod:`shipradar.sim.engine.simulation`) gathers values into the typed records
below (an antenna's state, a radar's description, a block's ends of scan, the sensor errors
at those ends) and this module decides the messages: which keys, their nesting and order (the
schema's, :mod:`shipradar.sim.stream.schema`), and how the messages that differ only in a few
values are packed from items packed once (:func:`shipradar.sim.stream.protocol.payload_items`,
:func:`~shipradar.sim.stream.protocol.float_rows`): the same bytes as encoding each payload.
The sector messages (``plots``, ``truth[plots]``, ``truth[targets]``) are
:mod:`shipradar.sim.stream.framing`'s.

Nothing here imports the engine: the records are plain values, the functions pure.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from shipradar.sim.stream import protocol
from shipradar.sim.stream.schema import END, ENTITIES, EOS, META, TRUTH_SENSORS, SchemaError

__all__ = [
    "AntennaState",
    "AntennaStates",
    "ClutterFalseAlarmMeta",
    "EndOfScanFrames",
    "PackedMeta",
    "SensorDescription",
    "SensorTruthRows",
    "end_of_scan_frames",
    "end_payload",
    "entities_payload",
    "eos_payload",
    "meta_payload",
    "pack_meta",
    "truth_sensors_frames",
    "truth_sensors_items",
    "truth_sensors_payload",
]


# ---------------------------------------------------------------------- the antenna's state
@dataclass(frozen=True)
class AntennaState:
    """The antenna at one time, as ``meta`` (a scan's start) and ``eos`` (its end) report it.

    Attributes
    ----------
    lat_deg, lon_deg : float
        Geodetic latitude and longitude, WGS-84 [deg].
    east_m, north_m, up_m : float
        Local frame [m]; ``up_m`` is the antenna's height above the sea (also ``alt_m``).
    velocity_enu_mps : tuple of float
        The platform's velocity east/north/up [m/s].
    heading_deg : float
        The platform's heading, true north, clockwise [deg].
    """

    lat_deg: float
    lon_deg: float
    east_m: float
    north_m: float
    up_m: float
    velocity_enu_mps: tuple[float, float, float]
    heading_deg: float

    def items(self) -> dict[str, Any]:
        """The keys ``position``, ``velocity_enu_mps``, ``heading_deg`` of ``meta`` and
        ``eos`` (:data:`shipradar.sim.stream.schema.META`'s ``position`` map)."""
        return {
            "position": {"lat_deg": self.lat_deg, "lon_deg": self.lon_deg, "alt_m": self.up_m,
                         "east_m": self.east_m, "north_m": self.north_m, "up_m": self.up_m},
            "velocity_enu_mps": list(self.velocity_enu_mps),
            "heading_deg": self.heading_deg,
        }


@dataclass(frozen=True)
class AntennaStates:
    """The antenna at several times (the ends of a block's revolutions), one row per time:
    the fields of :class:`AntennaState` as columns ((m,) each, ``velocity_enu_mps`` (m, 3))."""

    lat_deg: np.ndarray
    lon_deg: np.ndarray
    east_m: np.ndarray
    north_m: np.ndarray
    up_m: np.ndarray
    velocity_enu_mps: np.ndarray
    heading_deg: np.ndarray

    def float_columns(self) -> list[np.ndarray]:
        """The float leaves of :meth:`AntennaState.items` in packing order, as columns."""
        v = self.velocity_enu_mps
        return [self.lat_deg, self.lon_deg, self.up_m, self.east_m, self.north_m, self.up_m,
                v[:, 0], v[:, 1], v[:, 2], self.heading_deg]


# ---------------------------------------------------------------------- meta
@dataclass(frozen=True)
class ClutterFalseAlarmMeta:
    """A radar's expected sea-clutter false alarms (seed 7.2, from its P_fac map).

    Attributes
    ----------
    per_scan : float
        Expected per revolution.
    range_edges_m, per_ring : numpy.ndarray
        Ring edges in ground range [m] and the expected count per ring and scan.
    density : tuple of numpy.ndarray or None
        Slant-range ring edges [m], azimuth sector edges [rad] and the expected count per
        (ring, sector) and scan; None when the model gives none.
    """

    per_scan: float
    range_edges_m: np.ndarray
    per_ring: np.ndarray
    density: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def items(self) -> dict[str, Any]:
        """The ``meta`` keys of the clutter false alarms."""
        out: dict[str, Any] = {
            "clutter_false_alarms_per_scan": self.per_scan,
            "clutter_false_alarm_profile": {"range_edges_m": self.range_edges_m,
                                            "per_scan": self.per_ring}}
        if self.density is not None:
            r_edges, az_edges, cells = self.density
            out["clutter_false_alarm_density"] = {
                "range_edges_m": r_edges, "azimuth_edges_rad": az_edges, "per_scan": cells}
        return out


@dataclass(frozen=True)
class SensorDescription:
    """What ``meta`` says of a radar besides the scan and the antenna's state (the keys of
    :data:`shipradar.sim.stream.schema.META`; units there)."""

    sensor: str
    platform: str
    #: every radar parameter of the scenario, by name (its errors left out)
    radar: Mapping[str, Any]
    scan_period_s: float
    sectors_per_scan: int
    sector_s: float
    pfa: float
    noise_false_alarms_per_scan: float
    clutter: ClutterFalseAlarmMeta | None
    target_ids: Sequence[str]
    #: None when the targets are named by their ids (no traffic file, no live source)
    target_names: Sequence[str] | None
    origin_codes: Sequence[str]
    interference_codes: Sequence[str]
    origin: Mapping[str, Any]
    start_time: str
    sac_sic: Sequence[int]
    noise_power_dbm: float
    #: None for a radar without a Doppler bank
    range_rate_span_mps: float | None


def meta_payload(desc: SensorDescription, scan: int, state: AntennaState) -> dict[str, Any]:
    """``meta`` of revolution ``scan`` (0-based), the antenna at its start in ``state``."""
    return META.message(
        sensor=desc.sensor,
        platform=desc.platform,
        scan=scan,
        **state.items(),
        radar=desc.radar,
        scan_period_s=desc.scan_period_s,
        sectors_per_scan=desc.sectors_per_scan,
        sector_s=desc.sector_s,
        pfa=desc.pfa,
        noise_false_alarms_per_scan=desc.noise_false_alarms_per_scan,
        **(desc.clutter.items() if desc.clutter is not None else {}),
        target_ids=desc.target_ids,
        **({"target_names": list(desc.target_names)} if desc.target_names is not None
           else {}),
        origin_codes=list(desc.origin_codes),
        interference_codes=list(desc.interference_codes),
        origin=desc.origin,
        start_time=desc.start_time,
        sac_sic=list(desc.sac_sic),
        noise_power_dbm=desc.noise_power_dbm,
        **({"range_rate_span_mps": desc.range_rate_span_mps}
           if desc.range_rate_span_mps is not None else {}),
    )


def _scan_state_items(scan: int, state: Mapping[str, Any]) -> bytes:
    """The items of ``meta``'s ``scan`` and antenna state (``state``: its items)."""
    return protocol.payload_items(protocol.TOPIC_META, {"scan": scan, **state})


@dataclass(frozen=True)
class PackedMeta:
    """A radar's ``meta`` packed once but its scan and antenna state
    (:func:`pack_meta`): the items of the keys before ``scan`` and of those after the state."""

    n_items: int
    before: bytes
    after: bytes

    def encode(self, t_sim: float, scan_state: bytes) -> list[bytes]:
        """The frames of ``meta`` at ``t_sim`` [s] with ``scan_state``, the items of its scan
        and antenna state (:meth:`scan_state`, or :attr:`EndOfScanFrames.next_meta`)."""
        return protocol.encode_items(protocol.TOPIC_META, t_sim, self.n_items,
                                     (self.before, scan_state, self.after))

    @staticmethod
    def scan_state(scan: int, state: AntennaState) -> bytes:
        """The items of ``meta``'s ``scan`` and antenna ``state``."""
        return _scan_state_items(scan, state.items())


def pack_meta(desc: SensorDescription, scan: int, state: AntennaState) -> PackedMeta:
    """``meta`` (:func:`meta_payload`) split around its scan and antenna state, the rest
    packed once (the same bytes as encoding the payload)."""
    payload = meta_payload(desc, scan, state)
    keys = list(payload)
    k = keys.index("scan")
    n_state = 1 + len(state.items())
    topic = protocol.TOPIC_META
    return PackedMeta(len(keys), protocol.payload_items(topic, {c: payload[c] for c in keys[:k]}),
                      protocol.payload_items(topic, {c: payload[c]
                                                     for c in keys[k + n_state:]}))


# ---------------------------------------------------------------------- eos
def eos_payload(sensor: str, scan: int, time_s: float, state: AntennaState, complete: bool
                ) -> dict[str, Any]:
    """``eos`` of revolution ``scan`` ending at ``time_s`` [s], the antenna there in
    ``state``; ``complete``: the antenna completed the revolution."""
    return EOS.message(sensor=sensor, scan=scan, time_s=time_s, **state.items(),
                       complete=complete)


@dataclass(frozen=True)
class EndOfScanFrames:
    """The ``eos`` bodies of a block's revolutions, and the items of the next scan's ``meta``
    scan and antenna state after each (:meth:`PackedMeta.encode`)."""

    eos: list[bytes]
    next_meta: list[bytes]


def end_of_scan_frames(sensor: str, scan0: int, times: Sequence[float], states: AntennaStates,
                       complete: Sequence[bool]) -> EndOfScanFrames:
    """The ``eos`` of revolutions ``scan0``, ``scan0 + 1``, ... ending at ``times`` [s], the
    antenna there in ``states`` and ``complete`` each (:func:`eos_payload`, the same bytes),
    encoded at once: every eos is {sensor, scan, time_s, antenna state, complete} (checked
    with the first one), the states' items packed together
    (:func:`~shipradar.sim.stream.protocol.float_rows`), the rest per end."""
    first = AntennaState(
        float(states.lat_deg[0]), float(states.lon_deg[0]), float(states.east_m[0]),
        float(states.north_m[0]), float(states.up_m[0]),
        tuple(float(x) for x in states.velocity_enu_mps[0]),  # type: ignore[arg-type]
        float(states.heading_deg[0])).items()
    eos0 = EOS.message(sensor=sensor, scan=scan0, time_s=float(times[0]), **first,
                       complete=bool(complete[0]))
    if list(eos0) != ["sensor", "scan", "time_s", *first, "complete"]:
        raise SchemaError(f"eos keys {list(eos0)}: not this packing")
    topic = protocol.TOPIC_EOS
    rows = protocol.float_rows(protocol.TOPIC_META, first, states.float_columns())
    t_items = protocol.float_rows(topic, {"time_s": 0.0}, [np.asarray(times)])
    sensor_items = protocol.payload_items(topic, {"sensor": sensor})
    scan_items = [protocol.payload_items(topic, {"scan": s})
                  for s in range(scan0, scan0 + len(times) + 1)]
    done = {c: protocol.payload_items(topic, {"complete": c}) for c in (True, False)}
    eos = [protocol.encode_items(topic, t, len(eos0), (
        sensor_items, scan_items[j], t_items[j], rows[j], done[bool(complete[j])]))[1]
        for j, t in enumerate(times)]
    return EndOfScanFrames(eos, [scan_items[j + 1] + rows[j] for j in range(len(times))])


# ---------------------------------------------------------------------- truth[sensors]
def truth_sensors_payload(sensor: str, scan: int, time_s: float, errors: Mapping[str, float],
                          true_enu_m: tuple[float, float, float], true_heading_rad: float,
                          latency_s: float) -> dict[str, Any]:
    """``truth[sensors]`` at the end ``time_s`` [s] of revolution ``scan`` (issue 33): each
    error's value by its key, the antenna's true east/north/up [m] and heading [rad], the
    latency of the scan's last sector message [s] (NaN when it sent none)."""
    east, north, up = true_enu_m
    return TRUTH_SENSORS.message(
        sensor=sensor, scan=scan, time_s=time_s, **errors, true_east_m=east,
        true_north_m=north, true_up_m=up, true_heading_rad=true_heading_rad,
        latency_s=latency_s)


@dataclass(frozen=True)
class SensorTruthRows:
    """``truth[sensors]``'s values at a block's ends of scan, one row per end: times [s],
    each error's values by key, the antenna's true east/north/up [m] and heading [rad]."""

    time_s: Sequence[float]
    errors: Mapping[str, Sequence[float]]
    true_east_m: np.ndarray
    true_north_m: np.ndarray
    true_up_m: np.ndarray
    true_heading_rad: Sequence[float]


def truth_sensors_items(sensor: str, scan0: int, rows: SensorTruthRows) -> list[bytes]:
    """The items of each row's ``truth[sensors]`` (revolutions ``scan0``, ``scan0 + 1``, ...)
    but its last key, ``latency_s`` (:func:`truth_sensors_frames` adds it), packed at once:
    the same bytes as :func:`truth_sensors_payload`."""
    topic = protocol.TOPIC_TRUTH
    first = truth_sensors_payload(
        sensor, scan0, rows.time_s[0], {k: v[0] for k, v in rows.errors.items()},
        (float(rows.true_east_m[0]), float(rows.true_north_m[0]), float(rows.true_up_m[0])),
        rows.true_heading_rad[0], float("nan"))
    keys = list(first)
    if keys[:3] != ["sensor", "scan", "kind"] or keys[-1] != "latency_s":
        raise SchemaError(f"truth[sensors] keys {keys}: not this packing")
    floats = {k: first[k] for k in keys[3:-1]}
    columns = {"time_s": rows.time_s, **rows.errors, "true_east_m": rows.true_east_m,
               "true_north_m": rows.true_north_m, "true_up_m": rows.true_up_m,
               "true_heading_rad": rows.true_heading_rad}
    packed = protocol.float_rows(topic, floats, [np.asarray(columns[k]) for k in floats])
    sensor_items = protocol.payload_items(topic, {"sensor": sensor})
    kind = protocol.payload_items(topic, {"kind": TRUTH_SENSORS.kind})
    return [b"".join((sensor_items, protocol.payload_items(topic, {"scan": scan0 + i}), kind,
                      row)) for i, row in enumerate(packed)]


def truth_sensors_frames(items: bytes, latency_s: float, t_sim: float) -> list[bytes]:
    """The frames of ``truth[sensors]`` at ``t_sim`` [s] from a row's :func:`truth_sensors_items`
    and its ``latency_s`` [s]."""
    topic = protocol.TOPIC_TRUTH
    latency = protocol.payload_items(topic, {"latency_s": latency_s})
    return protocol.encode_items(topic, t_sim, len(TRUTH_SENSORS.fields), (items, latency))


# ---------------------------------------------------------------------- end, entities
def end_payload(time_s: float, sensors: Sequence[str], scans: Sequence[int]) -> dict[str, Any]:
    """``end``: the run's end [s], its radars and the scans each sent."""
    return END.message(time_s=time_s, sensors=list(sensors), scans=list(scans))


def entities_payload(used: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """One ``entities`` message of the entity-state batches a run applied (each with ``id``
    and the columns it carried): the required columns and ``active`` of every batch; an
    optional column when some batch has it, NaN (``heading_deg``: unknown), 0 (the rates:
    none) or ``""`` (``type``, ``name``) where another has not."""
    cols: dict[str, Any] = {"id": [i for u in used for i in u["id"]]}
    for key in ENTITIES.columns("n"):
        if ENTITIES[key].required or key == "active":
            cols[key] = np.concatenate([u[key] for u in used])
        elif key == "heading_deg":  # NaN (unknown) where a batch has none
            if any(key in u for u in used):
                cols[key] = np.concatenate([u.get(key, np.full(len(u["id"]), np.nan))
                                            for u in used])
        elif any(key in u for u in used):  # accelerations: 0 where a batch has none
            cols[key] = np.concatenate([u.get(key, np.zeros(len(u["id"]))) for u in used])
    for key in ("type", "name"):
        if any(key in u for u in used):
            cols[key] = [x for u in used for x in u.get(key, [""] * len(u["id"]))]
    return ENTITIES.message(**cols)
