"""From the shipradar message stream to ASTERIX data blocks, in time order.

:class:`AsterixStream` is fed the messages of a run or a recording in stream order
(``meta``, ``plots``, ``eos``; ``truth`` is ignored: a tracker under test must not see it)
and returns the data blocks each message produces, with their simulated times:

- ``plots`` -> CAT048 blocks (:func:`shipradar.sim.adapters.asterix.encode.encode_cat048`);
- the antenna's sector boundaries (``meta.sectors_per_scan`` per revolution, from
  ``radar.start_azimuth_deg``) -> CAT034 sector crossings (I034/000 = 2), each sent with
  the first message of that radar at or after it: right after the sector's plots when it has
  any, otherwise with the radar's next message (its end of scan at the latest);
- the antenna's true-north crossings -> CAT034 north markers (I034/000 = 1) with I034/120,
  the antenna's position then: the position of the latest ``eos``, dead-reckoned with its
  velocity to the crossing (exact when the radar starts at azimuth 0, the default, where
  every north crossing is an end of scan). A north crossing before the radar's first
  ``eos`` waits for it.

No socket here (STYLE lesson 7); :mod:`shipradar.sim.adapters.asterix.udp` sends what this returns.
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from shipradar.sim.adapters.asterix.encode import (
    CAT034,
    DEFAULT_MAX_BLOCK_BYTES,
    MAX_BLOCK_BYTES,
    MIN_BLOCK_BYTES,
    MSG_SECTOR_CROSSING,
    THETA_COUNTS,
    TOD_PER_DAY,
    TOD_PER_S,
    AsterixError,
    Cat048Source,
    check_sac_sic,
    encode_cat034_north_marker,
    encode_cat034_sector_crossings,
    encode_cat048,
    encode_cat048_slices,
    seconds_of_day,
)
from shipradar.sim.stream.schema import EOS, META, PLOTS

__all__ = ["AsterixStream", "datagrams", "scenario_problems"]

# The stream keys this adapter reads (here and in encode_cat048), checked against the schema
# (shipradar.sim.stream.schema) when the module is imported.
META.keys_of("sensor", "radar", "sac_sic", "start_time", "interference_codes",
             "scan_period_s", "sectors_per_scan", "noise_power_dbm")
PLOTS.keys_of("sensor", "time_s", "range_m", "azimuth_rad", "snr_db", "interference",
              "range_rate_mps")
EOS.keys_of("sensor", "time_s", "position", "velocity_enu_mps")

# WGS-84, for dead-reckoning the antenna between an end of scan and a north crossing
_A, _E2 = 6378137.0, 6.69437999014e-3
# Events within this of a message's time belong to it [s] (sector times are k * period / n).
_EPS_S = 1e-9
# CAT, LEN of a data block of one sector crossing record (8 octets)
_CROSSING_BLOCK_HEAD = bytes((CAT034, 0, 11))


@dataclass
class _Source:
    sensor: str
    cat048: Cat048Source  # SAC/SIC (CAT034's too), the start's second of day, PRL, PAM's N0'
    start_epoch_s: float
    period_s: float
    n_sectors: int
    beam0_rad: float
    clutter_code: int
    circular: bool
    next_sector: int = 0
    next_north: int = 0
    eos: Mapping[str, Any] | None = None

    def __post_init__(self) -> None:
        self.sector_s = self.period_s / self.n_sectors
        # the antenna is at beam0 at t = 0 and turns clockwise at 2π/period; starting at
        # north is not a crossing, so the first one is then a revolution later
        frac = ((2.0 * math.pi - self.beam0_rad) % (2.0 * math.pi)) / (2.0 * math.pi)
        self.first_north_s = (frac if frac > 0.0 else 1.0) * self.period_s
        # I034/010 + I034/000 of a sector crossing record, after its FSPEC
        self.crossing_head = bytes((0xF0, self.cat048.sac, self.cat048.sic,
                                    MSG_SECTOR_CROSSING))


class AsterixStream:
    """Turns shipradar messages into ASTERIX data blocks (CAT048 plots, CAT034 service).

    Parameters
    ----------
    max_block_bytes : int, optional
        Largest data block (one UDP datagram) [bytes], in [64, 65507].

    Attributes
    ----------
    stats : dict
        ``blocks``, ``bytes``, ``cat048_records`` (= plots encoded), ``north_markers``,
        ``sector_crossings``, ``plots_without_meta`` (plots of a radar whose ``meta`` was
        not seen, not encoded).
    start_epoch_s : float or None
        POSIX time of the scenario start [s] (from ``meta.start_time``), once known.

    Notes
    -----
    Same messages -> same bytes: nothing depends on the wall clock.
    """

    def __init__(self, max_block_bytes: int = DEFAULT_MAX_BLOCK_BYTES) -> None:
        if not MIN_BLOCK_BYTES <= max_block_bytes <= MAX_BLOCK_BYTES:
            raise AsterixError(f"ASTERIX datagram size must be in [{MIN_BLOCK_BYTES}, "
                               f"{MAX_BLOCK_BYTES}] bytes, got {max_block_bytes}")
        self.max_block_bytes = max_block_bytes
        self._sources: dict[str, _Source] = {}
        self._codes: dict[tuple[int, int], str] = {}
        self.start_epoch_s: float | None = None
        self.stats = {"blocks": 0, "bytes": 0, "cat048_records": 0, "north_markers": 0,
                      "sector_crossings": 0, "plots_without_meta": 0}

    # ------------------------------------------------------------------ messages
    def feed(self, topic: bytes | str, t_sim: float,
             payload: Mapping[str, Any]) -> list[tuple[float, bytes]]:
        """Data blocks produced by one message, in the order to send them.

        Parameters
        ----------
        topic : bytes or str
            Message topic (``meta``, ``plots``, ``eos``, ``truth``).
        t_sim : float
            Message time [s since scenario start].
        payload : Mapping
            Decoded payload (docs/protocol.md section 4).

        Returns
        -------
        list[tuple[float, bytes]]
            ``(t_sim, block)`` pairs; ``t_sim`` is the simulated time the block stands for
            (a pcap stamps it with that).

        Raises
        ------
        AsterixError
            A plot the CAT048 items cannot carry, or two radars with one SAC/SIC.
        """
        topic = topic.decode() if isinstance(topic, bytes) else topic
        out: list[tuple[float, bytes]] = []
        if topic == "meta":
            self._meta(payload)
            self._due(self._sources[payload["sensor"]], t_sim, out)
        elif topic == "plots":
            src = self._sources.get(payload["sensor"])
            if src is None:
                self.stats["plots_without_meta"] += len(payload["range_m"])
                return out
            blocks = encode_cat048(payload, src.cat048, max_block_bytes=self.max_block_bytes,
                                   clutter_code=src.clutter_code)
            return self._plots(src, t_sim, len(payload["range_m"]), blocks)
        elif topic == "eos":
            eos_src = self._sources.get(payload["sensor"])
            if eos_src is not None:
                eos_src.eos = payload
                self._due(eos_src, t_sim, out)
        self._count(out)
        return out

    def encode_ahead(self, sensor: str, plots: Mapping[str, Any], starts: Sequence[int],
                     stops: Sequence[int]) -> list[list[bytes]] | None:
        """The CAT048 blocks of radar ``sensor``'s coming ``plots`` messages, made at once.

        For a producer that knows a revolution's sectors in advance (the engine): message
        ``j`` holds the plots ``starts[j]:stops[j]`` of ``plots``' columns. Nothing is sent
        or counted: hand each message's blocks to :meth:`feed_encoded` at its time, in
        stream order, which then returns exactly what :meth:`feed` would.

        Parameters
        ----------
        sensor : str
            Radar id (its ``meta`` must have been fed).
        plots : Mapping
            The revolution's plot columns (``time_s``, ``range_m``, ``azimuth_rad``,
            ``snr_db``, ``interference``, ``range_rate_mps``).
        starts, stops : Sequence[int]
            Each message's slice.

        Returns
        -------
        list[list[bytes]] or None
            Each message's CAT048 blocks; None when the radar's ``meta`` was not seen.

        Raises
        ------
        AsterixError
            A plot that the CAT048 items cannot carry.
        """
        src = self._sources.get(sensor)
        if src is None:
            return None
        return encode_cat048_slices(
            {**plots, "sensor": sensor}, starts, stops, src.cat048,
            max_block_bytes=self.max_block_bytes, clutter_code=src.clutter_code)

    def feed_encoded(self, sensor: str, t_sim: float, n_plots: int,
                     blocks: list[bytes]) -> list[tuple[float, bytes]]:
        """:meth:`feed` of a ``plots`` message whose CAT048 blocks :meth:`encode_ahead` made.

        Parameters
        ----------
        sensor : str
            Radar id.
        t_sim : float
            Message time [s since scenario start].
        n_plots : int
            Plots in the message.
        blocks : list[bytes]
            Its CAT048 blocks.

        Returns
        -------
        list[tuple[float, bytes]]
            As :meth:`feed`.
        """
        src = self._sources.get(sensor)
        if src is None:
            self.stats["plots_without_meta"] += n_plots
            return []
        return self._plots(src, t_sim, n_plots, blocks)

    def _plots(self, src: _Source, t_sim: float, n_plots: int,
               blocks: list[bytes]) -> list[tuple[float, bytes]]:
        stats = self.stats
        stats["cat048_records"] += n_plots
        out = [(t_sim, b) for b in blocks]
        self._due(src, t_sim, out)
        stats["blocks"] += len(out)
        stats["bytes"] += sum([len(b) for _, b in out])
        return out

    def _count(self, out: list[tuple[float, bytes]]) -> None:
        stats = self.stats
        stats["blocks"] += len(out)
        stats["bytes"] += sum([len(b) for _, b in out])

    def _meta(self, m: Mapping[str, Any]) -> None:
        sensor = m["sensor"]
        if sensor in self._sources:
            return  # repeated every scan for late joiners; nothing changes
        radar = m.get("radar") or {}
        pair = m.get("sac_sic")
        if pair is None:
            # a recording made before SAC/SIC existed: the scenario's default rule
            taken = {c for s, c in self._codes if s == 0}
            pair = (0, next(c for c in range(1, 256) if c not in taken))
        check_sac_sic(pair[0], pair[1])
        sac, sic = int(pair[0]), int(pair[1])
        other = self._codes.get((sac, sic))
        if other is not None and other != sensor:
            raise AsterixError(f"radars {other!r} and {sensor!r} both have SAC/SIC "
                               f"{sac}/{sic}; each radar needs its own")
        self._codes[(sac, sic)] = sensor
        start = dt.datetime.fromisoformat(m["start_time"])
        if start.tzinfo is None:
            start = start.replace(tzinfo=dt.timezone.utc)
        if self.start_epoch_s is None:
            self.start_epoch_s = start.timestamp()
        codes = list(m.get("interference_codes") or ["noise", "clutter", "jamming"])
        self._sources[sensor] = _Source(
            sensor=sensor,
            cat048=Cat048Source(
                sac=sac, sic=sic, start_sod_s=seconds_of_day(start),
                # a plot's azimuth extent is the 3 dB beamwidth: the dwell integrates the
                # pulses of one beamwidth (seed [73]-[77])
                prl_deg=radar.get("beamwidth_az_deg"),
                noise_power_dbm=m.get("noise_power_dbm")),
            start_epoch_s=start.timestamp(), period_s=float(m["scan_period_s"]),
            n_sectors=int(m["sectors_per_scan"]),
            beam0_rad=math.radians(float(radar.get("start_azimuth_deg", 0.0))),
            clutter_code=codes.index("clutter") if "clutter" in codes else -1,
            circular=False,
        )

    # ------------------------------------------------------------------ CAT034
    def _due(self, src: _Source, t: float, out: list[tuple[float, bytes]]) -> None:
        """Append the north markers and sector crossings of ``src`` up to time ``t``.

        North markers come before the sector crossings that they coincide with; the
        crossings due at once travel together, placed by the first one's time.
        """
        horizon = t + _EPS_S
        north: list[float] = []
        if src.eos is not None:
            while True:
                tn = src.first_north_s + src.next_north * src.period_s
                if tn > horizon:
                    break
                src.next_north += 1
                north.append(tn)
        k = src.next_sector
        last = math.floor(horizon / src.sector_s)
        if last < k:
            if not north:
                return
            for tn in north:
                self._add_north_marker(src, tn, out)
            return
        src.next_sector = last + 1
        t0 = k * src.sector_s
        i = 0
        while i < len(north) and north[i] <= t0:
            self._add_north_marker(src, north[i], out)
            i += 1
        if last == k:
            # the usual case, one crossing: plain integers (numpy's per-call overhead is
            # the whole cost here); the same arithmetic as encode_cat034_sector_crossings
            az = (src.beam0_rad + 2.0 * math.pi * t0 / src.period_s) % (2.0 * math.pi)
            c = round((src.cat048.start_sod_s + t0) * TOD_PER_S) % TOD_PER_DAY
            sector = (round(az * (THETA_COUNTS / (2.0 * math.pi))) % THETA_COUNTS) >> 8
            out.append((t0, _CROSSING_BLOCK_HEAD + src.crossing_head
                        + bytes((c >> 16, (c >> 8) & 0xFF, c & 0xFF, sector))))
            self.stats["sector_crossings"] += 1
        else:
            times = [j * src.sector_s for j in range(k, last + 1)]
            turn = 2.0 * math.pi
            azimuths = [(src.beam0_rad + turn * tj / src.period_s) % turn for tj in times]
            blocks = encode_cat034_sector_crossings(
                times, azimuths, sac=src.cat048.sac, sic=src.cat048.sic,
                start_sod_s=src.cat048.start_sod_s,
                max_block_bytes=self.max_block_bytes)
            out.extend((times[-1], b) for b in blocks)
            self.stats["sector_crossings"] += len(times)
        for tn in north[i:]:
            self._add_north_marker(src, tn, out)

    def _add_north_marker(self, src: _Source, t: float, out: list[tuple[float, bytes]]) -> None:
        out.append((t, self._north_marker(src, t)))
        self.stats["north_markers"] += 1

    def _north_marker(self, src: _Source, t: float) -> bytes:
        e = src.eos
        assert e is not None  # north markers are due only once the radar's eos is known
        pos = e["position"]
        lat, lon = float(pos["lat_deg"]), float(pos["lon_deg"])
        dt_s = t - float(e["time_s"])
        if dt_s != 0.0:
            ve, vn = float(e["velocity_enu_mps"][0]), float(e["velocity_enu_mps"][1])
            s = math.sin(math.radians(lat))
            w = math.sqrt(1.0 - _E2 * s * s)
            r_n = _A / w  # prime vertical radius of curvature
            r_m = _A * (1.0 - _E2) / w**3  # meridian radius of curvature
            lat += math.degrees(vn * dt_s / r_m)
            lon += math.degrees(ve * dt_s / (r_n * math.cos(math.radians(lat))))
        # the model's sea surface is the WGS-84 ellipsoid
        # (shipradar.sim.world.kinematics.LocalFrame), so the antenna's height above the sea is its
        # ellipsoidal height
        return encode_cat034_north_marker(
            t, sac=src.cat048.sac, sic=src.cat048.sic, start_sod_s=src.cat048.start_sod_s,
            rotation_period_s=src.period_s, lat_deg=lat, lon_deg=lon,
            height_m=float(pos["alt_m"]), circular_polarization=src.circular)


def scenario_problems(scenario: Any) -> list[str]:
    """What in a scenario ASTERIX cannot carry, one line per radar (empty: all is well).

    Parameters
    ----------
    scenario : shipradar.sim.world.scenario.Scenario
        A validated scenario.

    Returns
    -------
    list[str]
        A radar whose instrumented range reaches I048/040 RHO's 256 NM bound (its plots
        could not be encoded), or whose rotation period does not fit I034/041 (512 s).
    """
    from shipradar.sim.adapters.asterix.encode import NM_M, RHO_MAX_NM

    lines = []
    for _, radar in scenario.radars():
        if radar.instrumented_range_m >= RHO_MAX_NM * NM_M:
            lines.append(f"radar {radar.id}: instrumented_range_m {radar.instrumented_range_m:g} "
                         f"m reaches I048/040 RHO's bound of {RHO_MAX_NM:g} NM "
                         f"({RHO_MAX_NM * NM_M:g} m); ASTERIX CAT048 cannot carry such plots")
        if radar.scan_period_s >= 512.0:
            lines.append(f"radar {radar.id}: rotation period {radar.scan_period_s:g} s is "
                         "beyond I034/041's 512 s")
    return lines


def datagrams(blocks: list[tuple[float, bytes]], max_bytes: int) -> list[tuple[float, bytes]]:
    """Pack consecutive data blocks into UDP payloads of at most ``max_bytes``.

    Parameters
    ----------
    blocks : list of (float, bytes)
        ``(t_sim, block)`` in sending order, each block at most ``max_bytes``.
    max_bytes : int
        Largest payload [bytes].

    Returns
    -------
    list of (float, bytes)
        ``(t_sim of the last block, payload)``: whole data blocks back to back (ASTERIX
        allows several blocks per datagram; a sector's CAT048 block and the CAT034 sector
        crossing after it then travel together, one system call instead of two).
    """
    out: list[tuple[float, bytes]] = []
    parts: list[bytes] = []
    size = 0
    t_last = 0.0
    for t, block in blocks:
        if parts and size + len(block) > max_bytes:
            out.append((t_last, b"".join(parts)))
            parts, size = [], 0
        parts.append(block)
        size += len(block)
        t_last = t
    if parts:
        out.append((t_last, b"".join(parts)))
    return out
