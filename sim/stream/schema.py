"""The stream's payloads declared once: every key of every topic, its type, unit and meaning.

One :class:`Field` per key, one :class:`Payload` (fields in the order a message carries them)
per topic and kind: :data:`META`, :data:`PLOTS`, :data:`EOS`, :data:`END`, :data:`TRUTH_PLOTS`,
:data:`TRUTH_TARGETS`, and :data:`TRACKS` and :data:`REGISTRATION` (published back by a
tracker). Everything else derives from this module (STYLE lesson 12):

- the engine (:mod:`shipradar.sim.engine.simulation`) gathers values and the stream shapes
  its messages with :meth:`Payload.message` (keys in this order, none missing, none
  unknown): the sectors in :mod:`shipradar.sim.stream.framing`, ``meta``, ``eos``,
  ``truth[sensors]``, ``end`` and ``entities`` in :mod:`shipradar.sim.stream.payloads`; the
  engine takes its plot columns (:data:`PLOT_COLUMNS`, :data:`PLOT_TRUTH_COLUMNS`) and their
  dtypes from here;
- the readers name the keys they read with :meth:`Payload.keys_of`, which refuses a key
  this module does not declare (the Stone Soup reader, export, ASTERIX, the viewer's wire
  format);
- ``docs/protocol.md`` section 4's tables are :func:`markdown_table` of these payloads
  (``tests/test_protocol_schema.py`` compares them; ``python -m
  shipradar.sim.stream.schema docs/protocol.md`` rewrites them).

The wire format of each value (a numpy column as a typed little-endian array, the rest as
msgpack) is :mod:`shipradar.sim.stream.protocol`'s; this module says what the keys are.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from shipradar.sensors import plot_columns as pc

__all__ = [
    "END",
    "ENTITIES",
    "EOS",
    "META",
    "PAYLOADS",
    "PLOTS",
    "PLOT_COLUMNS",
    "PLOT_TRUTH_COLUMNS",
    "REGISTRATION",
    "TOPIC_ENTITIES",
    "TOPIC_REGISTRATION",
    "TOPIC_TRACKS",
    "TRACKS",
    "TRUTH_PLOTS",
    "TRUTH_SENSORS",
    "TRUTH_TARGETS",
    "Field",
    "Payload",
    "SchemaError",
    "empty_plots",
    "markdown_table",
]


class SchemaError(KeyError):
    """A key, or a set of keys, that the schema does not declare for that payload."""


# numpy names of the column element types used on the wire (docs/protocol.md section 3)
_COLUMN = re.compile(r"^(bool|u?int(8|16|32|64)|float(32|64))\[(n|n\+1|m|k)\]$")


@dataclass(frozen=True)
class Field:
    """One key of a payload.

    Attributes
    ----------
    key : str
        The key, as it appears in the msgpack map.
    type : str
        Its type as documented: ``str``, ``int``, ``float``, ``map``, ``list[str]``, ...; a
        numpy column is ``DTYPE[LEN]`` (``float64[n]``: one element per plot, ``int64[n+1]``,
        ``int32[m]``, ``float64[k]``: one per target).
    unit : str
        Unit of the value (``""`` when it has none: ids, codes, counts, maps).
    meaning : str
        What the value is (markdown, as the protocol document shows it).
    required : bool
        False for a key a reader must do without (absent for some radars, or from streams
        recorded before it was added without a schema bump).
    required_since : int or None
        For a key that is not ``required``: the schema version from which every message of
        its payload carries it (2 for the keys version 2 added, docs/protocol.md section 2),
        so a reader of that version may rely on it; None when some messages of the current
        version lack it too.
    keys : tuple of Field
        For a ``map``: its keys (each with type, unit and meaning; all present), when the map
        has a fixed set of them.
    """

    key: str
    type: str
    unit: str
    meaning: str
    required: bool = True
    required_since: int | None = None
    keys: tuple[Field, ...] = ()

    @property
    def dtype(self) -> np.dtype | None:
        """The numpy dtype of a column (None for a value that is not a column)."""
        m = _COLUMN.match(self.type)
        return None if m is None else np.dtype(m.group(1))

    @property
    def length(self) -> str | None:
        """The length of a column: ``"n"`` (one per plot), ``"n+1"``, ``"m"``, ``"k"``; None
        for a value that is not a column."""
        m = _COLUMN.match(self.type)
        return None if m is None else m.group(4)


@dataclass(frozen=True)
class Payload:
    """The keys of one topic (and kind), in the order a message carries them."""

    topic: bytes
    kind: str | None
    fields: tuple[Field, ...]

    def __post_init__(self) -> None:
        keys = [f.key for f in self.fields]
        if len(set(keys)) != len(keys):
            raise ValueError(f"{self.name}: a key is declared twice")

    @property
    def name(self) -> str:
        """``topic`` or ``topic[kind]``."""
        t = self.topic.decode()
        return t if self.kind is None else f"{t}[{self.kind}]"

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(f.key for f in self.fields)

    def __getitem__(self, key: str) -> Field:
        for f in self.fields:
            if f.key == key:
                return f
        raise SchemaError(f"{self.name} has no key {key!r}")

    def __contains__(self, key: object) -> bool:
        return any(f.key == key for f in self.fields)

    def keys_of(self, *keys: str) -> tuple[str, ...]:
        """``keys``, checked: what a reader reads, each one a key of this payload.

        Raises
        ------
        SchemaError
            If a key is not declared here.
        """
        for k in keys:
            self[k]
        return keys

    def columns(self, length: str | None = None) -> tuple[str, ...]:
        """Keys of the numpy columns (of that ``length`` only, when given), in order."""
        return tuple(f.key for f in self.fields
                     if f.length is not None and (length is None or f.length == length))

    def message(self, **values: Any) -> dict[str, Any]:
        """A payload of this topic: ``values`` in the schema's key order.

        ``kind`` is filled in for a truth payload. Every required key must be given and no
        undeclared one.

        Raises
        ------
        SchemaError
            On a missing required key or an unknown key.
        """
        if self.kind is not None:
            values.setdefault("kind", self.kind)
        unknown = set(values).difference(self.keys)
        if unknown:
            raise SchemaError(f"{self.name} has no key {sorted(unknown)}")
        missing = [f.key for f in self.fields if f.required and f.key not in values]
        if missing:
            raise SchemaError(f"{self.name} message lacks {missing}")
        return {f.key: values[f.key] for f in self.fields if f.key in values}

    def check(self, payload: Mapping[str, Any]) -> None:
        """Require ``payload``'s keys to be this payload's (all required ones present, in
        order, no other); numpy columns of the declared dtype.

        Raises
        ------
        SchemaError
            Naming the first difference.
        """
        keys = [k for k in self.keys if k in payload]
        if list(payload) != keys:
            raise SchemaError(f"{self.name}: keys {list(payload)}, expected {keys}")
        missing = [f.key for f in self.fields if f.required and f.key not in payload]
        if missing:
            raise SchemaError(f"{self.name}: lacks {missing}")
        for f in self.fields:
            v = payload.get(f.key)
            if f.dtype is not None and isinstance(v, np.ndarray) and v.dtype != f.dtype:
                raise SchemaError(f"{self.name}: {f.key!r} is {v.dtype}, expected {f.dtype}")


def _f(key: str, type_: str, unit: str, meaning: str, required: bool = True,
       since: int | None = None, keys: tuple[Field, ...] = ()) -> Field:
    return Field(key, type_, unit, meaning, required, since, keys)


#: The keys of an antenna ``position`` map (``meta``, ``eos``).
_POSITION_KEYS = (
    _f("lat_deg", "float", "deg", "geodetic latitude, WGS-84"),
    _f("lon_deg", "float", "deg", "geodetic longitude, WGS-84"),
    _f("alt_m", "float", "m", "antenna height above the sea surface"),
    _f("east_m", "float", "m", "east, local frame"),
    _f("north_m", "float", "m", "north, local frame"),
    _f("up_m", "float", "m", "up, local frame (equal to `alt_m`)"),
)
#: The keys of ``meta.origin``.
_ORIGIN_KEYS = (
    _f("lat_deg", "float", "deg", "geodetic latitude of the local frame's origin, WGS-84"),
    _f("lon_deg", "float", "deg", "geodetic longitude, WGS-84"),
    _f("alt_m", "float", "m", "altitude of the origin above the sea surface"),
)


_SENSOR = _f("sensor", "str", "", "radar id")
_SCAN = _f("scan", "int", "", "scan number")

#: Topic of the tracks a tracker publishes back (read by ``shipradar view --tracks``).
TOPIC_TRACKS: bytes = b"tracks"

#: ``meta``: sensor metadata, at t = 0 and at the start of every scan.
META = Payload(b"meta", None, (
    _f("sensor", "str", "", "radar id, unique in the scenario (e.g. `sps49`)"),
    _f("platform", "str", "", "id of the platform (ship) carrying it"),
    _f("scan", "int", "", "scan number that starts now (0-based)"),
    _f("position", "map", "", "antenna position at the start of the scan (`t`), as in `eos`: "
       "`lat_deg`, `lon_deg`, `alt_m`, `east_m`, `north_m`, `up_m` (below)",
       required=False, since=2,
       keys=_POSITION_KEYS),
    _f("velocity_enu_mps", "list[3] float", "m/s", "platform velocity at `t`, east/north/up",
       required=False, since=2),
    _f("heading_deg", "float", "deg", "platform heading at `t`, true north, clockwise",
       required=False, since=2),
    _f("radar", "map", "", "every radar parameter of the scenario, by its scenario name and "
       "unit (`peak_power_w`, `frequency_hz`, `beamwidth_az_deg`, `rotation_rpm`, `prf_hz`, "
       "`instrumented_range_m`, …)"),
    _f("scan_period_s", "float", "s", "antenna revolution period"),
    _f("sectors_per_scan", "int", "", "sectors (hence `plots` messages at most) per revolution"),
    _f("sector_s", "float", "s", "sector length, `scan_period_s / sectors_per_scan`: a `plots` "
       "message at `t` holds plots with `t − sector_s < time_s ≤ t` (below)",
       required=False, since=2),
    _f("pfa", "float", "", "probability of false alarm per cell from t_fa, DREV-R-9429 [68]-[72]"),
    _f("noise_false_alarms_per_scan", "float", "", "expected noise false alarms per "
       "revolution"),
    _f("clutter_false_alarms_per_scan", "float", "", "expected sea-clutter false alarms per "
       "revolution, from the radar's P_fac map (seed 7.2); absent when the radar draws none "
       "(clutter off, or a low-resolution radar)", required=False),
    _f("clutter_false_alarm_profile", "map", "", "with the above: `range_edges_m` (float64 "
       "array, ring edges in ground range from 0, 250 m apart) and `per_scan` (float64 array, "
       "expected sea-clutter false alarms per scan in each ring): what a tracker needs for a "
       "range-dependent clutter density", required=False, keys=(
           _f("range_edges_m", "float64[r+1]", "m", "ring edges in ground range from 0"),
           _f("per_scan", "float64[r]", "", "expected sea-clutter false alarms per scan in "
              "each ring"))),
    _f("clutter_false_alarm_density", "map", "", "with the above, per slant-range ring and "
       "azimuth sector: `range_edges_m` (float64[r+1], ring edges in slant range, 250 m apart), "
       "`azimuth_edges_rad` (float64[a+1], 36 sectors of 10° from 0 to 2π, true north), "
       "`per_scan` "
       "(float64[r, a], expected sea-clutter false alarms per scan in each cell; the plots' "
       "`range_m` and `azimuth_rad` fall in these cells)", required=False, keys=(
           _f("range_edges_m", "float64[r+1]", "m", "ring edges in slant range"),
           _f("azimuth_edges_rad", "float64[a+1]", "rad", "sector edges, true north"),
           _f("per_scan", "float64[r, a]", "", "expected sea-clutter false alarms per scan "
              "in each cell (ring, sector)"))),
    _f("target_ids", "list[str]", "", "scenario target ids; `truth` refers to targets by index "
       "in this list. Fixed for the run, except with a live source (`--entities`): then new "
       "ids are appended at a scan's `meta` (an index never changes its id; each list extends "
       "the one before), and `truth` refers to the list of the sensor's latest `meta`"),
    _f("target_names", "list[str]", "", "display names of the targets, in the order of "
       "`target_ids` (a traffic file's vessel name or callsign, else the id); present when "
       "the scenario has `traffic:` files", required=False),
    _f("origin_codes", "list[str]", "", "names of the `truth` origin codes: `[\"target\", "
       "\"noise\", \"sea_clutter\"]`"),
    _f("interference_codes", "list[str]", "", "names of the `plots` interference codes: "
       "`[\"noise\", \"clutter\", \"jamming\"]`"),
    _f("origin", "map", "", "geodetic origin of the local frame (`lat_deg`, `lon_deg`, "
       "`alt_m`)", keys=_ORIGIN_KEYS),
    _f("start_time", "str", "", "scenario start, ISO 8601 (simulated time 0)"),
    _f("sac_sic", "list[2] int", "", "the radar's ASTERIX data source (SAC, SIC), defaults "
       "resolved (docs/asterix.md)"),
    _f("noise_power_dbm", "float", "dBm", "receiver noise power N0' (DREV-R-9429 [19]): S/I + "
       "this is the plot's power above the noise floor (ASTERIX I048/130 PAM)"),
    _f("range_rate_span_mps", "float", "m/s", "unambiguous span S = λ f_r / 2 of "
       "`plots.range_rate_mps` (f_r the nominal `prf_hz`; the first blind speed); the "
       "filter spacing is S / N. Absent for a radar without a Doppler bank (section 4.2)",
       required=False),
))

#: ``plots``: one message per sensor and sector that has any plot.
PLOTS = Payload(b"plots", None, (
    _SENSOR,
    _SCAN,
    _f("plot_id", "int64[n]", "", "unique per sensor over the run, increasing; key into "
       "`truth`"),
    _f(pc.TIME_S, "float64[n]", "s", "time of the plot (when the beam crossed it), since "
       "scenario start"),
    _f(pc.RANGE_M, "float64[n]", "m", "measured slant range, noisy (DREV-R-9429 [84]-[89])"),
    _f(pc.AZIMUTH_RAD, "float64[n]", "rad", "measured azimuth, true north, noisy"),
    _f(pc.SNR_DB, "float64[n]", "dB",
       "signal to interference ratio S/I of the plot (DREV-R-9429 [66])"),
    _f(pc.SIGMA_RANGE_M, "float64[n]", "m", "expected 1σ range error"),
    _f(pc.SIGMA_AZIMUTH_RAD, "float64[n]", "rad", "expected 1σ azimuth error"),
    _f(pc.INTERFERENCE, "uint8[n]", "", "dominant interference, index into "
       "`meta.interference_codes`"),
    _f(pc.RANGE_RATE_MPS, "float64[n]", "m/s", "measured radial velocity relative to the ship, "
       "positive receding (below); NaN for a radar without a Doppler bank (`processor.type` "
       "none or mti)", required=False),
    _f(pc.SIGMA_RANGE_RATE_MPS, "float64[n]", "m/s", "its expected 1σ, (λ/2) f_r / (N √12) for "
       "N filters; NaN without a bank", required=False),
    _f(pc.RANGE_RATE_REFERENCE_MPS, "float64[n]", "m/s", "the velocity the Doppler bank's "
       "filters are indexed from at the plot (the clutter mean μ_c, plus f1 when "
       "motion-compensated, as a range rate): `range_rate_mps` lies in (reference − S/2, "
       "reference + S/2], S = `meta.range_rate_span_mps`, so the true rate is `range_rate_mps` "
       "+ k S for an integer k (below); NaN without a bank", required=False),
))

#: ``eos``: end of scan, with the antenna's position and heading.
EOS = Payload(b"eos", None, (
    _SENSOR,
    _f("scan", "int", "", "scan number that ended"),
    _f("time_s", "float", "s", "end of scan (equal to `t`)"),
    _f("position", "map", "", "antenna position: `lat_deg`, `lon_deg` (WGS-84), `alt_m` "
       "(antenna height above the sea surface [m]) and `east_m`, `north_m`, `up_m` (local "
       "frame [m]; `up_m` equals `alt_m`)", keys=_POSITION_KEYS),
    _f("velocity_enu_mps", "list[3] float", "m/s", "platform velocity, east/north/up"),
    _f("heading_deg", "float", "deg", "platform heading, true north, clockwise"),
    _f("complete", "bool", "", "true when the antenna completed the revolution; false on a "
       "run's last scan cut short by the end of the run (its plots cover the azimuths swept "
       "until `time_s` only)", required=False, since=2),
))

#: ``end``: the end of the run, once, after every radar's last messages.
END = Payload(b"end", None, (
    _f("time_s", "float", "s", "end of the run, the scenario's duration (equal to `t`; with a "
       "radar's reporting latency, `t` is the last message's publication, section 4.5)"),
    _f("sensors", "list[str]", "", "the radars of the run, whose messages all came before"),
    _f("scans", "list[int]", "", "scans each of them sent (its last `eos` `scan` + 1), in "
       "the order of `sensors`"),
))

#: ``truth``, kind ``plots``: the origin of each plot of the ``plots`` message before it.
TRUTH_PLOTS = Payload(b"truth", "plots", (
    _f("sensor", "str", "", "as in the `plots` message"),
    _f("scan", "int", "", "as in the `plots` message"),
    _f("kind", "str", "", "`\"plots\"`"),
    _f("plot_id", "int64[n]", "", "the plots described, same order as in `plots`"),
    _f("origin", "uint8[n]", "", "index into `meta.origin_codes`: 0 target, 1 noise, 2 sea "
       "clutter"),
    _f("target", "int32[n]", "", "index into `meta.target_ids` of the (strongest) target, -1 "
       "for false alarms; the plot's origin reads `\"target:\" + target_ids[target]`"),
    _f("true_range_m", "float64[n]", "m", "true slant range of the plot's strongest "
       "contributor (`target`) at the plot's `time_s`, the geometry the plot measures: "
       "`plots.range_m − true_range_m` is the range error; NaN for false alarms",
       required=False, since=2),
    _f("true_azimuth_rad", "float64[n]", "rad", "its true azimuth at `time_s`, true north "
       "(wrap the difference into [−π, π)); NaN for false alarms", required=False, since=2),
    _f("true_range_rate_mps", "float64[n]", "m/s", "its true range rate relative to the "
       "antenna at "
       "`time_s`, positive receding, not folded (the measured one is folded by the PRF); NaN "
       "for false alarms", required=False, since=2),
    _f("contrib_offsets", "int64[n+1]", "", "plot i's contributors are "
       "`contrib_targets[contrib_offsets[i]:contrib_offsets[i+1]]`"),
    _f("contrib_targets", "int32[m]", "", "target indices of every target merged into each "
       "plot (targets in one resolution cell, not separated by the Doppler filters, seed "
       "2.2.1); empty range for false alarms"),
))

#: ``truth``, kind ``targets``: every target's state at an end of scan.
TRUTH_TARGETS = Payload(b"truth", "targets", (
    _f("sensor", "str", "", "the radar whose scan ended"),
    _f("scan", "int", "", "the scan that ended"),
    _f("kind", "str", "", "`\"targets\"`"),
    _f("time_s", "float", "s", "time of the states"),
    _f("east_m", "float64[k]", "m", "east positions, local frame"),
    _f("north_m", "float64[k]", "m", "north positions, local frame"),
    _f("up_m", "float64[k]", "m", "up positions, local frame"),
    _f("v_east_mps", "float64[k]", "m/s", "east velocities"),
    _f("v_north_mps", "float64[k]", "m/s", "north velocities"),
    _f("v_up_mps", "float64[k]", "m/s", "up velocities"),
    _f("a_east_mps2", "float64[k]", "m/s²", "east accelerations (turns, weaves, speed changes, "
       "climbs; 0 on straight legs)"),
    _f("a_north_mps2", "float64[k]", "m/s²", "north accelerations"),
    _f("a_up_mps2", "float64[k]", "m/s²", "up accelerations"),
    _f("active", "bool[k]", "", "target exists at that time (between its first and last "
       "waypoint); the states of a target that does not are NaN (schema 2; schema 1 held "
       "frozen values)"),
    _f("in_coverage", "bool[k]", "", "the radar `sensor` can see it at `time_s`: active, ground "
       "range from the antenna within `instrumented_range_m`, and inside the radio horizon "
       "over the 4/3 earth, √(2 a_e h_a) + √(2 a_e h_t)", required=False, since=2),
    _f("look_time_s", "float64[k]", "s", "time of the target's last look by this radar (the "
       "beam's crossing, at or before `time_s`); NaN before any look",
       required=False, since=2),
    _f("pd", "float64[k]", "", "expected probability of detection of that look (of the "
       "contact it was in when unresolved from others); NaN before any look",
       required=False, since=2),
    _f("snr_db", "float64[k]", "dB", "S/I of that look (DREV-R-9429 [66]-[67]); NaN before "
       "any look", required=False, since=2),
    _f("interference", "int8[k]", "", "dominant interference of that look, index into "
       "`meta.interference_codes`; −1 before any look", required=False, since=2),
    _f("outside_envelope", "bool[k]", "", "with a live source only (`--dis`, `--entities`): "
       "the target is active and outside the scenario's `external` envelope at `time_s` "
       "(higher than `max_altitude_m`, or farther than `max_range_m` from the origin when "
       "set); its looks there use the documented fallback (the two-ray model beyond the PE "
       "table). Absent without a live source", required=False),
))

#: ``truth``, kind ``sensors``: each radar's errors at an end of scan (issue 33), published
#: only when the scenario gives some radar a non-zero ``errors:`` or some platform a
#: non-zero ``navigation:``.  Every error is (reported − true).
TRUTH_SENSORS = Payload(b"truth", "sensors", (
    _f("sensor", "str", "", "the radar whose scan ended"),
    _f("scan", "int", "", "the scan that ended"),
    _f("kind", "str", "", "`\"sensors\"`"),
    _f("time_s", "float", "s", "true time of the values (the end of scan, `eos.time_s`)"),
    _f("range_bias_m", "float", "m", "range bias: reported range = true (1 + "
       "`range_scale_ppm` 10⁻⁶) + `range_bias_m` + noise"),
    _f("range_scale_ppm", "float", "ppm", "range scale error"),
    _f("azimuth_bias_rad", "float", "rad", "the radar's north alignment error: reported "
       "azimuth = true + `azimuth_bias_rad` + `heading_bias_rad` + noise"),
    _f("time_offset_s", "float", "s", "time-stamp offset: a plot's `time_s` = true time + "
       "`time_offset_s` + jitter (Gaussian, per plot)"),
    _f("heading_bias_rad", "float", "rad", "the platform's heading (gyro) bias: `meta` and "
       "`eos` report true heading + this"),
    _f("nav_east_error_m", "float", "m", "the platform's navigation error east: `meta` and "
       "`eos` report the antenna at its true position + these"),
    _f("nav_north_error_m", "float", "m", "navigation error north"),
    _f("nav_up_error_m", "float", "m", "navigation error up"),
    _f("true_east_m", "float", "m", "the antenna's true position east, local frame"),
    _f("true_north_m", "float", "m", "true position north"),
    _f("true_up_m", "float", "m", "true position up (antenna height above the sea)"),
    _f("true_heading_rad", "float", "rad", "the platform's true heading, true north, "
       "clockwise"),
    _f("latency_s", "float", "s", "latency of the scan's last sector message (its `t` minus "
       "its sector's end, queueing included, section 4.5); NaN when the scan sent none"),
))

#: ``tracks``: a tracker's tracks (published by the tracker, not by shipradar).
TRACKS = Payload(TOPIC_TRACKS, None, (
    _f("sensor", "str", "", "the radar the tracker last processed"),
    _f("scan", "int", "", "the scan the tracker last processed"),
    _f("time_s", "float", "s", "time of the estimates, since scenario start"),
    _f("track_id", "list[str]", "", "track identifiers, stable over a track's life"),
    _f("east_m", "float64[n]", "m", "estimated east positions, local frame"),
    _f("north_m", "float64[n]", "m", "estimated north positions, local frame"),
    _f("v_east_mps", "float64[n]", "m/s", "estimated east velocities"),
    _f("v_north_mps", "float64[n]", "m/s", "estimated north velocities"),
    _f("sigma_east_m", "float64[n]", "m", "1σ east position error (covariance diagonal)"),
    _f("sigma_north_m", "float64[n]", "m", "1σ north position error (covariance diagonal)"),
    _f("up_m", "float64[n]", "m", "estimated height above the sea, local frame (optional: "
       "when given, `shipradar evaluate` associates tracks with truths in three dimensions, "
       "so targets crossing at different heights keep their tracks; docs/studies.md)",
       required=False),
    _f("sigma_up_m", "float64[n]", "m", "1σ height error (optional, not scored)",
       required=False),
))

#: Topic of the entity states a program feeds in (``shipradar run --entities ENDPOINT``).
TOPIC_ENTITIES: bytes = b"entities"

#: ``entities``: entity states fed in by another program (an input of shipradar), and the
#: updates a run used, as its recording holds them.
ENTITIES = Payload(TOPIC_ENTITIES, None, (
    _f("source", "str", "", "name of the sending program", required=False),
    _f("id", "list[str]", "", "entity ids, one per row, stable over an entity's life (1 to 64 "
       "characters); a new id is a new target"),
    _f("time_s", "float64[n]", "s", "time of each state, since the run's start (the `t` of "
       "shipradar's own messages); NaN: the time shipradar receives it. An update older than "
       "the entity's last one is ignored (counted)"),
    _f("east_m", "float64[n]", "m", "east position, local frame (`meta.origin`)"),
    _f("north_m", "float64[n]", "m", "north position, local frame"),
    _f("up_m", "float64[n]", "m", "height above the sea"),
    _f("v_east_mps", "float64[n]", "m/s", "east velocity: the entity moves at constant "
       "velocity from its state until the next (dead reckoning)"),
    _f("v_north_mps", "float64[n]", "m/s", "north velocity"),
    _f("v_up_mps", "float64[n]", "m/s", "up velocity"),
    _f("a_east_mps2", "float64[n]", "m/s²", "east acceleration: with it the dead reckoning "
       "is second order (DIS FVW/RVW); absent: 0", required=False),
    _f("a_north_mps2", "float64[n]", "m/s²", "north acceleration", required=False),
    _f("a_up_mps2", "float64[n]", "m/s²", "up acceleration", required=False),
    _f("type", "list[str]", "", "entity type, matched against the scenario's "
       "`entity_types[].match` for its RCS and Swerling case", required=False),
    _f("name", "list[str]", "", "display name (`meta.target_names`)", required=False),
    _f("active", "bool[n]", "", "false: the entity leaves at `time_s` (its last state)",
       required=False),
    _f("heading_deg", "float64[n]", "deg", "heading of the entity's body (true north, "
       "clockwise; DIS: from the Entity State PDU's orientation); used for a platform that "
       "rides on the entity (`platforms[].dis_entity`); NaN or absent: unknown",
       required=False),
    _f("heading_rate_dps", "float64[n]", "deg/s", "rate of the heading (clockwise "
       "positive): between states the ridden platform's heading turns at it (DIS: the "
       "orientation turned by the angular velocity of a rotating dead-reckoning algorithm, "
       "RPW, RVW, RPB, RVB); NaN or absent: 0", required=False),
))

#: Topic of the sensor-bias estimates a tracker publishes back (scored by ``shipradar
#: evaluate``, docs/protocol.md section 4.8).
TOPIC_REGISTRATION: bytes = b"registration"

#: ``registration``: a tracker's estimates of a radar's errors (published by the tracker on
#: the endpoint of its ``tracks``, not by shipradar). Each estimate has the name, unit and
#: sign of the error it estimates in ``truth[sensors]`` (reported − true).
REGISTRATION = Payload(TOPIC_REGISTRATION, None, (
    _f("sensor", "str", "", "the radar whose errors are estimated"),
    _f("time_s", "float", "s", "time of the estimates, since scenario start"),
    _f("source", "str", "", "name of the tracker (or its estimator)", required=False),
    _f("range_bias_m", "float", "m", "estimated range bias: reported range = true (1 + "
       "`range_scale_ppm` 10⁻⁶) + `range_bias_m` + noise", required=False),
    _f("range_scale_ppm", "float", "ppm", "estimated range scale error", required=False),
    _f("azimuth_bias_rad", "float", "rad", "estimated azimuth bias of the radar's plots "
       "(reported − true azimuth, true north): scored against `truth[sensors]` "
       "`azimuth_bias_rad` + `heading_bias_rad`, the two errors the plots cannot tell apart",
       required=False),
    _f("time_offset_s", "float", "s", "estimated time-stamp offset: a plot's `time_s` − its "
       "true time", required=False),
    _f("sigma_range_bias_m", "float", "m", "1σ of `range_bias_m`", required=False),
    _f("sigma_azimuth_bias_rad", "float", "rad", "1σ of `azimuth_bias_rad`", required=False),
    _f("sigma_time_offset_s", "float", "s", "1σ of `time_offset_s`", required=False),
))

#: Every payload, in the order docs/protocol.md section 4 shows their tables.
PAYLOADS: tuple[Payload, ...] = (META, PLOTS, EOS, END, TRUTH_PLOTS, TRUTH_TARGETS,
                                 TRUTH_SENSORS, TRACKS, ENTITIES, REGISTRATION)

#: The per-plot columns the radar model makes (the ``plots`` columns but ``plot_id``, which
#: the engine numbers when a sector is framed), in message order.
PLOT_COLUMNS: tuple[str, ...] = tuple(k for k in PLOTS.columns("n") if k != "plot_id")
#: The per-plot truth columns the engine carries with each plot (``origin``, ``target``);
#: the contributors (``contrib_offsets``, ``contrib_targets``) are a ragged pair beside them.
PLOT_TRUTH_COLUMNS: tuple[str, ...] = tuple(k for k in TRUTH_PLOTS.columns("n")
                                            if k != "plot_id")


def empty_plots() -> dict[str, np.ndarray]:
    """No plots: every per-plot column (:data:`PLOT_COLUMNS`, :data:`PLOT_TRUTH_COLUMNS`) of
    length 0 in its dtype, and the contributors (``contrib_offsets`` ``[0]``, no
    ``contrib_targets``)."""
    out = {k: np.zeros(0, PLOTS[k].dtype) for k in PLOT_COLUMNS}
    out.update({k: np.zeros(0, TRUTH_PLOTS[k].dtype) for k in PLOT_TRUTH_COLUMNS})
    out["contrib_offsets"] = np.zeros(1, TRUTH_PLOTS["contrib_offsets"].dtype)
    out["contrib_targets"] = np.zeros(0, TRUTH_PLOTS["contrib_targets"].dtype)
    return out


# ------------------------------------------------------------------------ the document
_TABLE_HEAD = "| key | type | unit | meaning |\n|---|---|---|---|\n"


def markdown_table(payload: Payload) -> str:
    """The payload's table in docs/protocol.md: one row per key (key, type, unit, meaning)."""
    rows = [f"| `{f.key}` | {f.type} |{f' {f.unit} ' if f.unit else ' '}| {f.meaning} |"
            for f in payload.fields]
    return _TABLE_HEAD + "\n".join(rows) + "\n"


_TABLE = re.compile(r"^\|[^\n]*\n\|[-| ]+\|\n(?:\|[^\n]*\n)*", re.MULTILINE)


def document_tables(text: str) -> list[tuple[int, int]]:
    """Spans ``(start, end)`` of the markdown tables of section 4 of the protocol document
    (``## 4.`` to the next ``## ``), in order."""
    start = text.index("\n## 4.")
    end = text.index("\n## ", start + 1)
    return [(start + m.start(), start + m.end()) for m in _TABLE.finditer(text[start:end])]


def write_document_tables(text: str) -> str:
    """``text`` (docs/protocol.md) with section 4's tables replaced by :func:`markdown_table`
    of :data:`PAYLOADS`, in order; the prose unchanged."""
    spans = document_tables(text)
    if len(spans) != len(PAYLOADS):
        raise ValueError(f"section 4 has {len(spans)} tables, expected {len(PAYLOADS)}")
    out, pos = [], 0
    for (a, b), payload in zip(spans, PAYLOADS, strict=True):
        out += [text[pos:a], markdown_table(payload)]
        pos = b
    return "".join([*out, text[pos:]])


if __name__ == "__main__":  # python -m shipradar.sim.stream.schema docs/protocol.md
    path = sys.argv[1]
    with open(path, encoding="utf-8") as fh:
        doc = fh.read()
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(write_document_tables(doc))
