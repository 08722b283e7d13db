"""ASTERIX bytes: CAT048 monoradar target reports and CAT034 monoradar service messages.

Pure functions, vectorized: a sector's plots become one ``(n, width)`` byte matrix, filled
column by column from the plot columns, then cut into data blocks of whole records. No
Python object is made per plot.

References (the standard's facts; layouts checked against two decoders we did not write,
``asterix-decoder`` and Wireshark, in tests/test_asterix.py):

- EUROCONTROL-SPEC-0149-4, ASTERIX Category 048 "Monoradar Target Reports" (edition 1.21
  and later; the items used here have not changed since): I048/010, I048/020, I048/030,
  I048/040, I048/042, I048/120 (subfield CAL), I048/130, I048/140 and the standard User
  Application Profile.
- EUROCONTROL-SPEC-0149-2b, ASTERIX Category 034 "Monoradar Service Messages" (edition
  1.27 and later): I034/000, I034/010, I034/020, I034/030, I034/041, I034/050, I034/060,
  I034/120.
- EUROCONTROL-SPEC-0149 Part 1: data block = CAT (1 octet), LEN (2 octets, big-endian,
  the whole block) and records; a record = FSPEC then the items in FRN order.

Bit numbering follows the standard: bit 8 is an octet's most significant bit.
"""

from __future__ import annotations

import datetime as dt
import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from shipradar.sim.world.errors import BadInputError

__all__ = [
    "CAT034",
    "CAT048",
    "DEFAULT_MAX_BLOCK_BYTES",
    "NM_M",
    "RHO_MAX_NM",
    "AsterixError",
    "Cat048Source",
    "cat048_records",
    "encode_cat034_north_marker",
    "encode_cat034_sector_crossings",
    "encode_cat048",
    "encode_cat048_slices",
    "pack_blocks",
    "seconds_of_day",
    "time_of_day_counts",
]

CAT048, CAT034 = 48, 34
#: International nautical mile [m].
NM_M = 1852.0
#: Largest data block (so UDP payload) by default [bytes]: under a 1500-byte Ethernet MTU
#: with IPv4/IPv6 and UDP headers and some tunnel overhead.
DEFAULT_MAX_BLOCK_BYTES = 1400
#: Smallest and largest block size accepted [bytes] (the largest: a UDP/IPv4 payload).
MIN_BLOCK_BYTES, MAX_BLOCK_BYTES = 64, 65507

#: I048/040 RHO: 16 bits, LSB 1/256 NM, so RHO < 256 NM (the standard's own bound).
RHO_MAX_NM = 256.0
#: I048/040 THETA and I034/020: LSB 360°/2^16 (I034/020 keeps the 8 most significant bits).
THETA_COUNTS = 1 << 16
#: I048/140, I034/030: LSB 1/128 s, elapsed since the last UTC midnight.
TOD_PER_S = 128
TOD_PER_DAY = 86400 * TOD_PER_S
#: I048/042 X, Y: signed 16 bits, LSB 1/128 NM.
XY_PER_NM = 128
#: I048/130 PRL: LSB 360°/2^13 (0.044°), 8 bits, so at most 11.2°.
PRL_PER_DEG = (1 << 13) / 360.0
#: I034/041: antenna rotation period, LSB 1/128 s, 16 bits.
PERIOD_PER_S = 128
#: I034/120 latitude/longitude: signed 24 bits, LSB 180°/2^23.
LATLON_PER_DEG = (1 << 23) / 180.0
#: I048/120 CAL: calculated Doppler speed, 10-bit two's complement, LSB 1 m/s, so
#: [-512, 511] m/s; a speed beyond is sent clipped with D = 1 ("doubtful").
CAL_MIN_MPS, CAL_MAX_MPS = -512, 511

# I048/020 first octet: TYP = 1 (single PSR detection, bits 8-6 = 001), SIM = 1 (bit 5:
# these reports are simulated), RDP/SPI/RAB = 0, FX = 0.
_I048_020 = 0x30
# I048/030 first octet: code 13 "target in clutter area" in bits 8-2, FX = 0.
_I048_030_CLUTTER = 13 << 1
# CAT048 FSPEC (standard UAP): octet 1 FRN1 010, FRN2 140, FRN3 020, FRN4 040, FRN5 070,
# FRN6 090, FRN7 130, FX; octet 2 FRN8 220 ... FRN12 042 (bit 4), FX; octet 3 FRN15 210,
# FRN16 030 (bit 7), FRN17 080, FRN18 100, FRN19 110, FRN20 120 (bit 3), FRN21 230, FX.
_FS1_BASE = 0x80 | 0x40 | 0x20 | 0x10 | 0x01  # 010, 140, 020, 040, FX
_FS1_130 = 0x02
_FS2_042 = 0x08
_FS3_030 = 0x40
_FS3_120 = 0x04
# I048/120 primary subfield: CAL present (bit 8), RDS absent, FX = 0.
_I120_CAL = 0x80
# I048/120 CAL: D (bit 16) "Doppler speed is doubtful".
_CAL_DOUBTFUL = 0x8000
# I048/130 primary subfield: PRL present (bit 5), PAM present (bit 4), FX = 0.
_I130_PRL, _I130_PAM = 0x10, 0x08
# CAT034 message types (I034/000).
MSG_NORTH_MARKER, MSG_SECTOR_CROSSING = 1, 2
# Up to this many sector crossings are encoded with plain integers (numpy beyond).
_CROSSINGS_IN_PYTHON = 64


class AsterixError(ValueError, BadInputError):
    """A value that the ASTERIX item cannot carry (refused, never wrapped or clipped)."""


def seconds_of_day(start_time: dt.datetime) -> float:
    """UTC seconds since the midnight before ``start_time``.

    Parameters
    ----------
    start_time : datetime.datetime
        Scenario start (simulated time 0); naive means UTC.

    Returns
    -------
    float
        Seconds in [0, 86400) [s].
    """
    if start_time.tzinfo is not None:
        start_time = start_time.astimezone(dt.timezone.utc).replace(tzinfo=None)
    midnight = start_time.replace(hour=0, minute=0, second=0, microsecond=0)
    return (start_time - midnight).total_seconds()


def time_of_day_counts(t_s: np.ndarray | float, start_sod_s: float) -> np.ndarray:
    """I048/140 and I034/030: time of day in 1/128 s, wrapping at midnight.

    Parameters
    ----------
    t_s : array_like
        Simulated times [s since scenario start], finite.
    start_sod_s : float
        UTC seconds of day of the scenario start [s] (:func:`seconds_of_day`).

    Returns
    -------
    numpy.ndarray of uint32
        ``round((start_sod_s + t) * 128) mod 86400*128``: rounded to the nearest count
        (error at most 1/256 s), zero at every midnight (so 23:59:59.999 rounds to 0).
    """
    t = np.asarray(t_s, dtype=float)
    if not np.all(np.isfinite(t)):
        raise AsterixError("time of day (I048/140, I034/030): times must be finite")
    counts = np.rint((start_sod_s + t) * TOD_PER_S).astype(np.int64)
    return np.mod(counts, TOD_PER_DAY).astype(np.uint32)


def _be(values: np.ndarray, nbytes: int) -> list[np.ndarray]:
    """Big-endian byte columns (most significant first) of non-negative integers."""
    v = values.astype(np.uint32, copy=False)
    return [((v >> (8 * k)) & 0xFF).astype(np.uint8) for k in range(nbytes - 1, -1, -1)]


def check_sac_sic(sac: int, sic: int) -> None:
    """Refuse a System Area Code or System Identification Code outside [0, 255]
    (AsterixError naming it)."""
    for name, v in (("SAC", sac), ("SIC", sic)):
        if not (isinstance(v, (int, np.integer)) and 0 <= v <= 255):
            raise AsterixError(f"I048/010, I034/010: {name} must be an integer in [0, 255], "
                               f"got {v!r}")


@dataclass(frozen=True)
class Cat048Source:
    """What every CAT048 record of one radar carries besides its plot: the radar's constants.

    Parameters
    ----------
    sac, sic : int
        System Area Code and System Identification Code -> I048/010, each in [0, 255]
        (checked here: AsterixError naming the code).
    start_sod_s : float
        UTC seconds of day of the scenario start [s] (:func:`seconds_of_day`), the origin of
        I048/140.
    prl_deg : float or None, optional
        Azimuth extent of a plot [deg] -> I048/130 PRL (360°/2^13, at most 11.2°).
    noise_power_dbm : float or None, optional
        Receiver noise power N0' [dBm], the reference of I048/130 PAM.
    """

    sac: int
    sic: int
    start_sod_s: float
    prl_deg: float | None = None
    noise_power_dbm: float | None = None

    def __post_init__(self) -> None:
        check_sac_sic(self.sac, self.sic)
        # numpy integers accepted, kept as int (the layout cache's key, the record's bytes)
        object.__setattr__(self, "sac", int(self.sac))
        object.__setattr__(self, "sic", int(self.sic))

    @functools.cached_property
    def prl_counts(self) -> int | None:
        """I048/130 PRL in counts of 360°/2^13, clipped to the item's 8 bits (None: absent)."""
        if self.prl_deg is None:
            return None
        return int(min(max(round(float(self.prl_deg) * PRL_PER_DEG), 0), 255))


# ----------------------------------------------------------------- CAT048 record layout
# Every plot field is computed into one float64 matrix (one row per plot, one column per
# field), rounded once, converted once to big-endian int64, and its bytes picked by one
# gather with the byte positions of the record variant: a handful of numpy calls per batch,
# whatever its size (a raid sector holds ~15 plots, where per-call overhead is everything).
# Columns of that matrix (EXT: FSPEC octet 3 and I048/120 CAL, 3 bytes):
_COL_TOD, _COL_RHO, _COL_THETA, _COL_PAM, _COL_X, _COL_Y, _COL_FS2, _COL_EXT, _COL_CONST = (
    range(9))
_NCOL = 9


def _byte(col: int, k: int, nbytes: int) -> int:
    """Position, in a row of big-endian int64 columns, of byte k (0: most significant) of
    the low ``nbytes`` bytes of column ``col``."""
    return 8 * col + 8 - nbytes + k


# the constant column's 8 bytes: FSPEC octet 1, I048/120 primary subfield, SAC, SIC,
# I048/020, I048/130 primary subfield, PRL, I048/030
_K_FS1, _K_120, _K_SAC, _K_SIC, _K_020, _K_130, _K_PRL, _K_030 = (
    _byte(_COL_CONST, k, 8) for k in range(8))
#: Octets each record variant adds to a plain record, by variant code clutter + 2 doppler:
#: none; FSPEC octet 3 + I048/030; FSPEC octet 3 + I048/120 (3 octets); all four.
_VARIANT_EXTRA = np.array([0, 2, 4, 5], dtype=np.int64)


@functools.lru_cache(maxsize=64)
def _cat048_layout(sac: int, sic: int, prl: int | None, has_pam: bool):
    """Constant bytes (as a signed int64) and byte gathers of a CAT048 record variant.

    Returns ``(const, plain, full, keep, width)``: ``plain`` picks the ``width`` bytes of a
    record without FSPEC octet 3 (no I048/030, no I048/120); ``full`` the ``width + 5``
    bytes of one with both (FSPEC octet 3, I048/030 and the 3 octets of I048/120 CAL);
    ``keep[c]`` which of ``full``'s bytes a record of variant ``c`` keeps (``c`` = clutter
    + 2 doppler, the four record layouts; :data:`_VARIANT_EXTRA` their extra octets).
    """
    i130 = (_I130_PRL if prl is not None else 0) | (_I130_PAM if has_pam else 0)
    const = bytes((_FS1_BASE | (_FS1_130 if i130 else 0), _I120_CAL, sac, sic, _I048_020,
                   i130, 0 if prl is None else prl, _I048_030_CLUTTER))
    head = [_K_FS1, _byte(_COL_FS2, 0, 1)]
    items = [_K_SAC, _K_SIC, *(_byte(_COL_TOD, k, 3) for k in range(3)), _K_020,
             _byte(_COL_RHO, 0, 2), _byte(_COL_RHO, 1, 2),
             _byte(_COL_THETA, 0, 2), _byte(_COL_THETA, 1, 2)]
    if i130:
        items.append(_K_130)
        if prl is not None:
            items.append(_K_PRL)
        if has_pam:
            items.append(_byte(_COL_PAM, 0, 1))
    items += [_byte(_COL_X, 0, 2), _byte(_COL_X, 1, 2), _byte(_COL_Y, 0, 2),
              _byte(_COL_Y, 1, 2)]
    plain = np.array(head + items, dtype=np.intp)
    # in FRN order: FSPEC octet 3 after octet 2, I048/030 (FRN16) before I048/120 (FRN20)
    full = np.array(head + [_byte(_COL_EXT, 0, 3)] + items
                    + [_K_030, _K_120, _byte(_COL_EXT, 1, 3), _byte(_COL_EXT, 2, 3)],
                    dtype=np.intp)
    width = plain.size
    keep = np.ones((4, width + 5), dtype=bool)
    keep[0, 2] = False  # plain: neither FSPEC octet 3 nor the items it announces
    keep[(0, 2), width + 1] = False  # no I048/030
    keep[:2, width + 2:] = False  # no I048/120
    for c in range(4):
        assert keep[c].sum() == width + _VARIANT_EXTRA[c]
    return int.from_bytes(const, "big", signed=True), plain, full, keep, width


def _cat048_bytes(source: Cat048Source, time_s: Any, range_m: Any, azimuth_rad: Any,
                  snr_db: Any = None, clutter: Any = None, range_rate_mps: Any = None,
                  sensor: str = "?") -> tuple[np.ndarray, np.ndarray | None, int]:
    """The records of :func:`cat048_records` back to back, the per-record variant codes
    (clutter + 2 doppler, :func:`_cat048_layout`; None: every record is plain, without
    FSPEC octet 3) and the width of a plain record."""
    r = np.asarray(range_m, dtype=float)
    az = np.asarray(azimuth_rad, dtype=float)
    t = np.asarray(time_s, dtype=float)
    n0_dbm = source.noise_power_dbm
    has_pam = n0_dbm is not None and snr_db is not None
    const, plain, full, keep, w = _cat048_layout(source.sac, source.sic, source.prl_counts,
                                                 has_pam)
    # one contiguous row per field (fast whatever n), transposed by the integer conversion
    v = np.empty((_NCOL, r.size))
    _position_columns(v, t, r, az, source.start_sod_s, sensor)
    if n0_dbm is not None and snr_db is not None:
        _pam_column(v[_COL_PAM], snr_db, n0_dbm)
    else:
        v[_COL_PAM] = 0.0
    variant = _variant_columns(v, clutter, range_rate_mps)
    b = _record_bytes(v, const)
    if variant is None:
        return b.take(plain, axis=1).reshape(-1), None, w
    # FSPEC octet 3 and, in FRN order, I048/030 code 13 (clutter-dominated plots) and
    # I048/120 CAL (plots with a range rate) at the end: one of four layouts per record
    rows = b.take(full, axis=1)
    return rows[keep[variant]], variant, w


def _position_columns(v: np.ndarray, t: np.ndarray, r: np.ndarray, az: np.ndarray,
                      start_sod_s: float, sensor: str) -> None:
    """Fill I048/140 (time of day), I048/040 (RHO, THETA) and I048/042 (X, Y) of ``v`` in
    counts, unrounded; refuse (AsterixError) a plot those items cannot carry."""
    tod = v[_COL_TOD]
    np.add(t, start_sod_s, out=tod)
    tod *= TOD_PER_S
    rho = v[_COL_RHO]
    np.multiply(r, 256.0 / NM_M, out=rho)
    np.multiply(az, THETA_COUNTS / (2.0 * math.pi), out=v[_COL_THETA])
    # one test, before anything else is computed from them, for NaN, inf and out of range:
    # NaN compares False and a NaN or inf among times, ranges and azimuths makes the sum so
    # (rint(x) is in [0, 2^16) exactly when x is in [-0.5, 65535.5)); the rare bad plot is
    # then found and named
    if r.size and not (np.minimum.reduce(rho) >= -0.5 and np.maximum.reduce(rho) < 65535.5
                       and math.isfinite(np.add.reduce(v[:_COL_THETA + 1], axis=None))):
        _cat048_refuse(t, r, az, sensor)
    # I048/042 in the radar's own frame: X east, Y north of the antenna, from the slant
    # range (the radar measures no elevation); |X|, |Y| < 256 NM, so at most 32767 counts
    xy = v[_COL_X:_COL_Y + 1]
    np.sin(az, out=v[_COL_X])
    np.cos(az, out=v[_COL_Y])
    xy *= r * (XY_PER_NM / NM_M)


def _pam_column(pam: np.ndarray, snr_db: Any, noise_power_dbm: float) -> None:
    """I048/130 PAM [dBm] = S/I + N0' into ``pam``: S/I of -inf (no signal) or NaN reads as
    the item's floor, +inf as its ceiling."""
    np.add(np.asarray(snr_db, dtype=float), float(noise_power_dbm), out=pam)
    np.fmax(pam, -128.0, out=pam)
    np.fmin(pam, 127.0, out=pam)


def _variant_columns(v: np.ndarray, clutter: Any,
                     range_rate_mps: Any) -> np.ndarray | None:
    """Fill FSPEC octet 2 and the EXT column (FSPEC octet 3, I048/120 CAL) of ``v``; return
    each record's variant code (clutter + 2 doppler), None when every record is plain."""
    in_clutter = None
    if clutter is not None:
        in_clutter = np.asarray(clutter, dtype=bool)
        if not np.count_nonzero(in_clutter):
            in_clutter = None
    doppler = None
    if range_rate_mps is not None:
        rr = np.asarray(range_rate_mps, dtype=float)
        doppler = np.isfinite(rr)  # NaN: a radar without a Doppler bank, no I048/120
        if not np.count_nonzero(doppler):
            doppler = None
    if in_clutter is None and doppler is None:
        v[_COL_FS2] = _FS2_042
        v[_COL_EXT] = 0.0
        return None
    variant = np.zeros(v.shape[1], dtype=np.uint8)
    if in_clutter is not None:
        variant += in_clutter.view(np.uint8)
    if doppler is not None:
        variant += 2 * doppler.view(np.uint8)
    # FX of FSPEC octet 2 when octet 3 follows
    np.add(variant != 0, float(_FS2_042), out=v[_COL_FS2])
    ext = v[_COL_EXT]
    ext[:] = 0.0
    if in_clutter is not None:
        ext += in_clutter * float(_FS3_030 << 16)
    if doppler is not None:
        ext += doppler * (_cal_counts(rr, doppler) + float(_FS3_120 << 16))
    return variant


def _cal_counts(rr: np.ndarray, doppler: np.ndarray) -> np.ndarray:
    """I048/120 CAL: the range rate (positive receding) to 1 m/s, two's complement in 10
    bits; beyond [-512, 511] m/s clipped and marked doubtful (D); 0 where not ``doppler``."""
    cal = np.rint(np.where(doppler, rr, 0.0))
    doubtful = (cal < CAL_MIN_MPS) | (cal > CAL_MAX_MPS)
    np.clip(cal, CAL_MIN_MPS, CAL_MAX_MPS, out=cal)
    np.mod(cal, 1024.0, out=cal)
    cal += doubtful * float(_CAL_DOUBTFUL)
    return cal


def _record_bytes(v: np.ndarray, const: int) -> np.ndarray:
    """The fields of ``v`` rounded once and wrapped to their items, as the big-endian bytes
    of one int64 per field and plot (``(n, 8 * _NCOL)`` uint8), the constant bytes in
    column :data:`_COL_CONST`."""
    v[_COL_CONST] = 0.0
    np.rint(v, out=v)
    xy = v[_COL_X:_COL_Y + 1]
    np.minimum(xy, 32767.0, out=xy)
    tod = v[_COL_TOD]
    np.mod(tod, TOD_PER_DAY, out=tod)
    vi = v.T.astype(">i8", order="C")
    vi[:, _COL_CONST] = const
    return vi.view(np.uint8)


def _cat048_refuse(t, r, az, sensor) -> None:
    """Raise for the first plot that I048/040 or I048/140 cannot carry (if any)."""
    bad = ~(np.isfinite(r) & np.isfinite(az))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise AsterixError(f"radar {sensor}: plot {i} has a non-finite range or azimuth "
                           f"({r[i]!r} m, {az[i]!r} rad); I048/040 cannot carry it")
    rho = np.rint(r * (256.0 / NM_M))
    out = (rho >= THETA_COUNTS) | (rho < 0.0)
    if out.any():
        i = int(np.flatnonzero(out)[0])
        raise AsterixError(
            f"radar {sensor}: plot {i} at range {r[i]:.0f} m ({r[i] / NM_M:.2f} NM) is outside "
            f"I048/040 RHO's range [0, {RHO_MAX_NM:g}) NM (16 bits of 1/256 NM); ASTERIX "
            f"CAT048 cannot carry it (refused, not wrapped)")
    if not np.isfinite(t).all():
        raise AsterixError("time of day (I048/140, I034/030): times must be finite")


def _offsets(n: int, variant: np.ndarray | None, w: int) -> np.ndarray:
    if variant is None:
        return np.arange(n + 1, dtype=np.int64) * w
    offsets = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(w + _VARIANT_EXTRA[variant], out=offsets[1:])
    return offsets


def cat048_records(
    time_s: np.ndarray,
    range_m: np.ndarray,
    azimuth_rad: np.ndarray,
    *,
    source: Cat048Source,
    snr_db: np.ndarray | None = None,
    clutter: np.ndarray | None = None,
    range_rate_mps: np.ndarray | None = None,
    sensor: str = "?",
) -> tuple[np.ndarray, np.ndarray]:
    """CAT048 records of a batch of plots, as one byte buffer and the record offsets.

    Parameters
    ----------
    time_s : numpy.ndarray
        Plot times [s since scenario start] -> I048/140 (1/128 s, UTC, wraps at midnight).
    range_m : numpy.ndarray
        Measured slant ranges [m] -> I048/040 RHO (1/256 NM); must be in [0, 256) NM.
    azimuth_rad : numpy.ndarray
        Measured azimuths from true north, clockwise [rad] -> I048/040 THETA (360°/2^16);
        with the range also -> I048/042 X (east), Y (north) in the radar's frame (1/128 NM).
    source : Cat048Source
        The radar's constants: SAC/SIC -> I048/010, the scenario start's UTC second of day,
        the plot's azimuth extent -> I048/130 PRL, the noise power (PAM's reference).
    snr_db : numpy.ndarray or None, optional
        S/I of each plot [dB]; with ``source.noise_power_dbm`` -> I048/130 PAM = S/I + N0'
        [dBm] (1 dBm, clipped to the item's [-128, 127] dBm).
    clutter : numpy.ndarray of bool or None, optional
        Plots whose dominant interference is clutter -> I048/030 code 13 "target in clutter
        area" (the item is absent for the others).
    range_rate_mps : numpy.ndarray or None, optional
        Measured range rate of each plot, positive receding [m/s] (the stream's
        ``range_rate_mps``) -> I048/120 subfield CAL (10-bit two's complement, LSB 1 m/s,
        rounded: error at most 0.5 m/s); a speed outside [-512, 511] m/s is clipped with D =
        1 ("doubtful"), D = 0 otherwise. NaN (a radar without a Doppler bank): no I048/120.
    sensor : str, optional
        Radar id, for error messages.

    Returns
    -------
    buf : numpy.ndarray of uint8
        The records, back to back.
    offsets : numpy.ndarray of int64
        ``n + 1`` offsets: record i is ``buf[offsets[i]:offsets[i + 1]]``.

    Raises
    ------
    AsterixError
        A range or azimuth that is not finite, a negative range, or a range at or beyond
        256 NM (RHO's bound; such a plot is refused, never wrapped).

    Notes
    -----
    Every record has I048/010, I048/140, I048/020 (single PSR detection, SIM set),
    I048/040 and I048/042; I048/130 when ``source.prl_deg`` or PAM is known; I048/030 on
    clutter-dominated plots; I048/120 on plots with a finite range rate. So four record
    layouts (FSPEC ``F3 08``, with I048/030 ``F3 09 40``, with I048/120 ``F3 09 04``, with
    both ``F3 09 44``). I048/170 and the other track items are absent: these are plots.
    The standard does not state the sign of CAL; shipradar sends the range rate as it is,
    positive for a receding target.
    """
    buf, variant, w = _cat048_bytes(source, time_s, range_m, azimuth_rad, snr_db, clutter,
                                    range_rate_mps, sensor)
    return buf, _offsets(int(np.size(range_m)), variant, w)


def pack_blocks(category: int, buf: np.ndarray, offsets: np.ndarray,
                max_block_bytes: int = DEFAULT_MAX_BLOCK_BYTES) -> list[bytes]:
    """Cut records into data blocks of whole records, each at most ``max_block_bytes``.

    Parameters
    ----------
    category : int
        ASTERIX category (48, 34).
    buf : numpy.ndarray of uint8
        Records back to back.
    offsets : numpy.ndarray of int64
        Record boundaries (``n + 1``).
    max_block_bytes : int, optional
        Largest block, its 3-octet CAT/LEN header included [bytes].

    Returns
    -------
    list[bytes]
        Data blocks: CAT, LEN (big-endian, whole block), records. Empty for no record.
    """
    if not MIN_BLOCK_BYTES <= max_block_bytes <= MAX_BLOCK_BYTES:
        raise AsterixError(f"block size must be in [{MIN_BLOCK_BYTES}, {MAX_BLOCK_BYTES}] "
                           f"bytes, got {max_block_bytes}")
    room = max_block_bytes - 3
    n = offsets.size - 1
    total = int(offsets[-1])
    if 0 < total <= room:  # the usual sector: one block
        return [bytes((category, (total + 3) >> 8, (total + 3) & 0xFF)) + buf.tobytes()]
    blocks = []
    s = 0
    data = buf.tobytes()
    off = offsets.tolist()
    while s < n:
        # the last record that still ends within this block (one search per block)
        e = int(np.searchsorted(offsets, off[s] + room, side="right")) - 1
        if e <= s:
            raise AsterixError(f"a CAT{category:03d} record of {off[s + 1] - off[s]} bytes "
                               f"does not fit a {max_block_bytes}-byte block")
        size = off[e] - off[s] + 3
        blocks.append(bytes((category, size >> 8, size & 0xFF)) + data[off[s]:off[e]])
        s = e
    return blocks


def encode_cat048(plots: Mapping[str, Any], source: Cat048Source, *,
                  max_block_bytes: int = DEFAULT_MAX_BLOCK_BYTES,
                  clutter_code: int = 1) -> list[bytes]:
    """CAT048 data blocks of one ``plots`` message.

    Parameters
    ----------
    plots : dict
        The payload of a ``plots`` message (docs/protocol.md 4.2): ``time_s``, ``range_m``,
        ``azimuth_rad``, ``snr_db``, ``interference``, ``range_rate_mps`` (optional: NaN or
        absent, no I048/120) columns and ``sensor``.
    source : Cat048Source
        The radar's constants (I048/010, the start's second of day, I048/130 PRL, PAM's
        reference).
    max_block_bytes : int, optional
        Largest data block [bytes].
    clutter_code : int, optional
        The ``interference`` code of clutter (``meta.interference_codes``).

    Returns
    -------
    list[bytes]
        Data blocks in plot order (see :func:`cat048_records` for the items).
    """
    interference = plots.get("interference")
    buf, variant, w = _cat048_bytes(
        source, plots["time_s"], plots["range_m"], plots["azimuth_rad"], plots.get("snr_db"),
        None if interference is None else np.asarray(interference) == clutter_code,
        plots.get("range_rate_mps"), str(plots.get("sensor", "?")))
    total = buf.size
    if 0 < total <= max_block_bytes - 3 and max_block_bytes <= MAX_BLOCK_BYTES:
        # the usual sector: one block
        return [bytes((CAT048, (total + 3) >> 8, (total + 3) & 0xFF)) + buf.tobytes()]
    n = total // w if variant is None else variant.size
    return pack_blocks(CAT048, buf, _offsets(n, variant, w), max_block_bytes)


def encode_cat048_slices(plots: Mapping[str, Any], starts: Sequence[int],
                         stops: Sequence[int], source: Cat048Source, *,
                         max_block_bytes: int = DEFAULT_MAX_BLOCK_BYTES,
                         clutter_code: int = 1) -> list[list[bytes]]:
    """CAT048 data blocks of many ``plots`` messages that slice the same columns at once.

    Message ``j`` holds the plots ``starts[j]:stops[j]`` of the columns of ``plots``; its
    blocks are exactly ``encode_cat048`` of that slice. For the engine's sectors, which are
    the slices of one revolution's arrays: the records of the whole revolution are built by
    one pass of :func:`cat048_records`'s numpy calls, and a sector costs a bytes slice.

    Parameters
    ----------
    plots : Mapping
        The columns (``time_s``, ``range_m``, ``azimuth_rad``, optionally ``snr_db``,
        ``interference`` and ``range_rate_mps``) and optionally ``sensor``, as in
        :func:`encode_cat048`.
    starts, stops : Sequence[int]
        The slice of each message (ascending, not overlapping).
    source, max_block_bytes, clutter_code
        As :func:`encode_cat048`.

    Returns
    -------
    list[list[bytes]]
        The data blocks of each message.

    Raises
    ------
    AsterixError
        As :func:`encode_cat048`, for any plot of the slices' span.
    """
    if not MIN_BLOCK_BYTES <= max_block_bytes <= MAX_BLOCK_BYTES:
        raise AsterixError(f"block size must be in [{MIN_BLOCK_BYTES}, {MAX_BLOCK_BYTES}] "
                           f"bytes, got {max_block_bytes}")
    if not len(starts):
        return []
    lo, hi = min(starts), max(stops)

    def span(key):
        col = plots.get(key)
        return None if col is None else np.asarray(col)[lo:hi]

    interference = span("interference")
    buf, variant, w = _cat048_bytes(
        source, span("time_s"), span("range_m"), span("azimuth_rad"), span("snr_db"),
        None if interference is None else interference == clutter_code,
        span("range_rate_mps"), str(plots.get("sensor", "?")))
    data = buf.tobytes()
    if variant is None:
        bounds = None
    else:
        offsets = _offsets(hi - lo, variant, w)
        bounds = offsets.tolist()
    room = max_block_bytes - 3
    out: list[list[bytes]] = []
    for i0, i1 in zip(starts, stops, strict=True):
        i0 -= lo
        i1 -= lo
        if bounds is None:
            a, b = i0 * w, i1 * w
        else:
            a, b = bounds[i0], bounds[i1]
        total = b - a
        if total <= 0:
            out.append([])
        elif total <= room:
            out.append([bytes((CAT048, (total + 3) >> 8, (total + 3) & 0xFF)) + data[a:b]])
        else:
            off = (np.arange(i0, i1 + 1, dtype=np.int64) * w if bounds is None
                   else offsets[i0:i1 + 1]) - a
            out.append(pack_blocks(CAT048, buf[a:b], off, max_block_bytes))
    return out


def _azimuth_counts(azimuth_rad: np.ndarray) -> np.ndarray:
    a = np.asarray(azimuth_rad, dtype=float)
    return np.mod(np.rint(a * (THETA_COUNTS / (2.0 * math.pi))).astype(np.int64), THETA_COUNTS)


def encode_cat034_sector_crossings(
    time_s: Sequence[float] | np.ndarray, azimuth_rad: Sequence[float] | np.ndarray, *,
    sac: int, sic: int, start_sod_s: float,
    max_block_bytes: int = DEFAULT_MAX_BLOCK_BYTES,
) -> list[bytes]:
    """CAT034 sector crossing messages (I034/000 = 2), one record per crossing.

    Parameters
    ----------
    time_s : array_like
        When the antenna crossed each sector's start azimuth [s since scenario start]
        -> I034/030 (1/128 s, UTC).
    azimuth_rad : array_like
        That azimuth, from true north [rad] -> I034/020, the 8 most significant bits of
        the 16-bit azimuth (360°/2^8 = 1.40625° per count, truncated as the standard says).
    sac, sic : int
        Data source (I034/010).
    start_sod_s : float
        UTC seconds of day of the scenario start [s].
    max_block_bytes : int, optional
        Largest data block [bytes].

    Returns
    -------
    list[bytes]
        Data blocks; records are FSPEC 0xF0 (010, 000, 030, 020), 8 octets each.
    """
    check_sac_sic(sac, sic)
    if len(time_s) <= _CROSSINGS_IN_PYTHON:
        # the usual call (one boundary per plots message, a few after quiet sectors): plain
        # integers beat numpy's per-call overhead here; same rounding (half to even) and
        # the same blocks (as many whole records as fit) as the vectorized path
        if not MIN_BLOCK_BYTES <= max_block_bytes <= MAX_BLOCK_BYTES:
            raise AsterixError(f"block size must be in [{MIN_BLOCK_BYTES}, {MAX_BLOCK_BYTES}] "
                               f"bytes, got {max_block_bytes}")
        head = bytes((0xF0, sac, sic, MSG_SECTOR_CROSSING))
        recs = []
        for t, az in zip(time_s, azimuth_rad, strict=True):
            if not (math.isfinite(t) and math.isfinite(az)):
                raise AsterixError("I034/030, I034/020: times and azimuths must be finite")
            c = round((start_sod_s + t) * TOD_PER_S) % TOD_PER_DAY
            sector = (round(az * (THETA_COUNTS / (2.0 * math.pi))) % THETA_COUNTS) >> 8
            recs.append(head + bytes((c >> 16, (c >> 8) & 0xFF, c & 0xFF, sector)))
        per_block = (max_block_bytes - 3) // 8
        blocks = []
        for i in range(0, len(recs), per_block):
            part = recs[i:i + per_block]
            size = 3 + 8 * len(part)
            blocks.append(bytes((CAT034, size >> 8, size & 0xFF)) + b"".join(part))
        return blocks
    tod = time_of_day_counts(np.asarray(time_s, dtype=float), start_sod_s)
    n = tod.size
    # 16-bit count first, then its top byte: the rounding happens once, at the LSB
    sector = (_azimuth_counts(np.asarray(azimuth_rad, dtype=float)) >> 8).astype(np.uint8)

    def const(v: int) -> np.ndarray:
        return np.full(n, v, dtype=np.uint8)

    mat = np.stack([const(0xF0), const(sac), const(sic), const(MSG_SECTOR_CROSSING),
                    *_be(tod, 3), sector], axis=1) if n else np.zeros((0, 8), np.uint8)
    offsets = np.arange(n + 1, dtype=np.int64) * mat.shape[1]
    return pack_blocks(CAT034, mat.reshape(-1), offsets, max_block_bytes)


def encode_cat034_north_marker(
    t_s: float, *, sac: int, sic: int, start_sod_s: float, rotation_period_s: float,
    lat_deg: float, lon_deg: float, height_m: float, circular_polarization: bool = False,
) -> bytes:
    """One CAT034 north marker message (I034/000 = 1) in its own data block.

    Parameters
    ----------
    t_s : float
        When the antenna crossed true north [s since scenario start] -> I034/030.
    sac, sic : int
        Data source (I034/010).
    start_sod_s : float
        UTC seconds of day of the scenario start [s].
    rotation_period_s : float
        Antenna rotation period [s] -> I034/041 (1/128 s, below 512 s).
    lat_deg, lon_deg : float
        WGS-84 position of the antenna at ``t_s`` [deg] -> I034/120 (180°/2^23, about
        2.4 m of latitude).
    height_m : float
        Height of the antenna above the WGS-84 ellipsoid [m] -> I034/120 (1 m, signed
        16 bits).
    circular_polarization : bool, optional
        I034/060 PSR POL bit (0: linear, shipradar's H and V).

    Returns
    -------
    bytes
        A data block of one record: FSPEC 0xEF 0x10 (010, 000, 030, 041, 050, 060; 120),
        26 octets with its header.

    Notes
    -----
    I034/050 says: COM NOGO 0 (operational), RDPC 0, no overload, time source valid; PSR
    channel A, no overload. I034/060: no reduction step, STC map 0, POL as given.
    """
    check_sac_sic(sac, sic)
    if not 0.0 < rotation_period_s < 65536 / PERIOD_PER_S:
        raise AsterixError(f"I034/041: rotation period must be in (0, 512) s, got "
                           f"{rotation_period_s}")
    if not (math.isfinite(lat_deg) and math.isfinite(lon_deg) and math.isfinite(height_m)):
        raise AsterixError("I034/120: the position must be finite")
    if not -32768 <= round(height_m) <= 32767:
        raise AsterixError(f"I034/120: height must be in [-32768, 32767] m, got {height_m}")
    if not math.isfinite(t_s):
        raise AsterixError("time of day (I048/140, I034/030): times must be finite")
    # time_of_day_counts with plain numbers (Python's round is numpy's rint: half to even)
    tod = round((start_sod_s + t_s) * TOD_PER_S) % TOD_PER_DAY
    period = round(rotation_period_s * PERIOD_PER_S)
    lat = round(lat_deg * LATLON_PER_DEG)
    # +180° is -180°: the same meridian, and the only value past the signed 24-bit range
    lon = (round(lon_deg * LATLON_PER_DEG) + (1 << 23)) % (1 << 24) - (1 << 23)
    lat = min(lat, (1 << 23) - 1)
    record = bytes((
        0xEF, 0x10,  # FSPEC: FRN 1-7 but 020; FX; FRN 11 (120)
        sac, sic,  # I034/010
        MSG_NORTH_MARKER,  # I034/000
        (tod >> 16) & 0xFF, (tod >> 8) & 0xFF, tod & 0xFF,  # I034/030
        (period >> 8) & 0xFF, period & 0xFF,  # I034/041
        0x90, 0x00, 0x20,  # I034/050: COM + PSR subfields; COM all clear; PSR channel A
        0x90, 0x00, 0x80 if circular_polarization else 0x00,  # I034/060: COM + PSR
    )) + int(round(height_m)).to_bytes(2, "big", signed=True) \
        + lat.to_bytes(3, "big", signed=True) + lon.to_bytes(3, "big", signed=True)
    size = len(record) + 3
    return bytes((CAT034, size >> 8, size & 0xFF)) + record
