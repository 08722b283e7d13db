"""From the shipradar message stream to ASTERIX data blocks, in time order.

:class:`AsterixStream` is fed the messages of a run or a recording in stream order
(``meta``, ``plots``, ``eos``; ``truth`` is ignored: a tracker under test must not see it)
and returns the data blocks each message produces, with their simulated times:

- ``plots`` -> CAT048 blocks (:func:`sim.asterix.encode.encode_cat048`);
- the antenna's sector boundaries (``meta.sectors_per_scan`` per revolution, from
  ``radar.start_azimuth_deg``) -> CAT034 sector crossings (I034/000 = 2), each sent with
  the first message of that radar at or after it: right after the sector's plots when it has
  any, otherwise with the radar's next message (its end of scan at the latest);
- the antenna's true-north crossings -> CAT034 north markers (I034/000 = 1) with I034/120,
  the antenna's position then: the position of the latest ``eos``, dead-reckoned with its
  velocity to the crossing (exact when the radar starts at azimuth 0, the default, where
  every north crossing is an end of scan). A north crossing before the radar's first
  ``eos`` waits for it.

No socket here (STYLE lesson 7); :mod:`sim.asterix.udp` sends what this returns.
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from shipradar.sim.asterix.encode import (
    DEFAULT_MAX_BLOCK_BYTES,
    MAX_BLOCK_BYTES,
    MIN_BLOCK_BYTES,
    AsterixError,
    encode_cat034_north_marker,
    encode_cat034_sector_crossings,
    encode_cat048,
    seconds_of_day,
)

__all__ = ["AsterixStream", "datagrams", "scenario_problems"]

# WGS-84, for dead-reckoning the antenna between an end of scan and a north crossing
_A, _E2 = 6378137.0, 6.69437999014e-3
# Events within this of a message's time belong to it [s] (sector times are k * period / n).
_EPS_S = 1e-9


@dataclass
class _Source:
    sensor: str
    sac: int
    sic: int
    start_sod_s: float
    start_epoch_s: float
    period_s: float
    n_sectors: int
    beam0_rad: float
    prl_deg: float | None
    noise_power_dbm: float | None
    clutter_code: int
    circular: bool
    next_sector: int = 0
    next_north: int = 0
    eos: Mapping[str, Any] | None = None

    @property
    def sector_s(self) -> float:
        return self.period_s / self.n_sectors

    @property
    def first_north_s(self) -> float:
        # the antenna is at beam0 at t = 0 and turns clockwise at 2π/period; starting at
        # north is not a crossing, so the first one is then a revolution later
        frac = ((2.0 * math.pi - self.beam0_rad) % (2.0 * math.pi)) / (2.0 * math.pi)
        return (frac if frac > 0.0 else 1.0) * self.period_s

    def azimuth(self, t: np.ndarray) -> np.ndarray:
        return np.mod(self.beam0_rad + 2.0 * math.pi * t / self.period_s, 2.0 * math.pi)


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
            src = self._sources[payload["sensor"]]
            self._due(src, t_sim, out)
        elif topic == "plots":
            src = self._sources.get(payload["sensor"])
            if src is None:
                self.stats["plots_without_meta"] += len(payload["range_m"])
                return out
            blocks = encode_cat048(payload, sac=src.sac, sic=src.sic,
                                   start_sod_s=src.start_sod_s, prl_deg=src.prl_deg,
                                   noise_power_dbm=src.noise_power_dbm,
                                   max_block_bytes=self.max_block_bytes,
                                   clutter_code=src.clutter_code)
            self.stats["cat048_records"] += len(payload["range_m"])
            out.extend((t_sim, b) for b in blocks)
            self._due(src, t_sim, out)
        elif topic == "eos":
            src = self._sources.get(payload["sensor"])
            if src is not None:
                src.eos = payload
                self._due(src, t_sim, out)
        for _, block in out:
            self.stats["blocks"] += 1
            self.stats["bytes"] += len(block)
        return out

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
            sensor=sensor, sac=sac, sic=sic, start_sod_s=seconds_of_day(start),
            start_epoch_s=start.timestamp(), period_s=float(m["scan_period_s"]),
            n_sectors=int(m["sectors_per_scan"]),
            beam0_rad=math.radians(float(radar.get("start_azimuth_deg", 0.0))),
            # a plot's azimuth extent is the 3 dB beamwidth: the dwell integrates the pulses
            # of one beamwidth (seed [73]-[77])
            prl_deg=radar.get("beamwidth_az_deg"),
            noise_power_dbm=m.get("noise_power_dbm"),
            clutter_code=codes.index("clutter") if "clutter" in codes else -1,
            circular=False,
        )

    # ------------------------------------------------------------------ CAT034
    def _due(self, src: _Source, t: float, out: list[tuple[float, bytes]]) -> None:
        """Append the north markers and sector crossings of ``src`` up to time ``t``."""
        events: list[tuple[float, int, Any]] = []
        k = src.next_sector
        last = math.floor((t + _EPS_S) / src.sector_s)
        if last >= k:
            ks = np.arange(k, last + 1)
            times = ks * src.sector_s
            src.next_sector = last + 1
            events.append((float(times[0]), 1, times))
        if src.eos is not None:
            while True:
                tn = src.first_north_s + src.next_north * src.period_s
                if tn > t + _EPS_S:
                    break
                src.next_north += 1
                events.append((tn, 0, None))
        # north markers before the sector crossings they coincide with
        events.sort(key=lambda e: (e[0], e[1]))
        for t_ev, kind, times in events:
            if kind == 0:
                out.append((t_ev, self._north_marker(src, t_ev)))
                self.stats["north_markers"] += 1
            else:
                blocks = encode_cat034_sector_crossings(
                    times.tolist(), src.azimuth(times).tolist(), sac=src.sac, sic=src.sic,
                    start_sod_s=src.start_sod_s, max_block_bytes=self.max_block_bytes)
                out.extend((float(times[-1]), b) for b in blocks)
                self.stats["sector_crossings"] += times.size

    def _north_marker(self, src: _Source, t: float) -> bytes:
        e = src.eos
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
        # the model's sea surface is the WGS-84 ellipsoid (sim.kinematics.LocalFrame), so
        # the antenna's height above the sea is its ellipsoidal height
        return encode_cat034_north_marker(
            t, sac=src.sac, sic=src.sic, start_sod_s=src.start_sod_s,
            rotation_period_s=src.period_s, lat_deg=lat, lon_deg=lon,
            height_m=float(pos["alt_m"]), circular_polarization=src.circular)


def scenario_problems(scenario: Any) -> list[str]:
    """What in a scenario ASTERIX cannot carry, one line per radar (empty: all is well).

    Parameters
    ----------
    scenario : sim.scenario.Scenario
        A validated scenario.

    Returns
    -------
    list[str]
        A radar whose instrumented range reaches I048/040 RHO's 256 NM bound (its plots
        could not be encoded), or whose rotation period does not fit I034/041 (512 s).
    """
    from shipradar.sim.asterix.encode import NM_M, RHO_MAX_NM

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
