"""ASTERIX output: bytes by hand, two independent decoders, midnight, SAC/SIC, UDP.

The decoders are the PyPI ``asterix-decoder`` (C++, its own XML category definitions) and
Wireshark's dissector (``tshark``); neither shares code or tables with sim/adapters/asterix.
"""

from __future__ import annotations

import datetime as dt
import math
import select
import socket
import subprocess
import sys
import threading

import numpy as np
import pytest
import yaml

from shipradar.sim.adapters.asterix import AsterixError, AsterixStream, encode_cat048
from shipradar.sim.adapters.asterix.encode import (
    Cat048Source,
    cat048_records,
    encode_cat034_north_marker,
    encode_cat034_sector_crossings,
    encode_cat048_slices,
    seconds_of_day,
    time_of_day_counts,
)
from shipradar.sim.adapters.asterix.stream import datagrams
from shipradar.sim.adapters.asterix.udp import parse_udp_url
from shipradar.sim.adapters.export import write_pcap
from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.world.scenario import ScenarioError, parse_scenario

from .asterix_helpers import MemorySender, scene, scene_dict, tshark_asterix
from .helpers import ROOT, quiet_radar

NM = 1852.0
PORT = 8600
#: The data source of the records written by hand: SAC 1, SIC 2, PRL 1°, N0' -100 dBm.
SOURCE = Cat048Source(sac=1, sic=2, start_sod_s=0.0, prl_deg=1.0, noise_power_dbm=-100.0)


# ----------------------------------------------------------------- bytes by hand
def test_cat048_record_bytes_by_hand():
    """One record written octet by octet from the CAT048 definitions (UAP, I048/010, 140,
    020, 040, 130, 042, 030): any error of bit layout, order or quantization shows."""
    plots = {"sensor": "r", "time_s": np.array([1.5, 1.5]),
             "range_m": np.array([10 * NM, 10 * NM]), "azimuth_rad": np.array([math.pi / 2] * 2),
             "snr_db": np.array([20.0, 20.0]), "interference": np.array([0, 1], np.uint8)}
    blocks = encode_cat048(plots, SOURCE)
    record = bytes.fromhex(
        "f308"  # FSPEC: 010 140 020 040 130 FX | 042
        "0102"  # I048/010 SAC 1 SIC 2
        "0000c0"  # I048/140 1.5 s = 192 / 128 s
        "30"  # I048/020 TYP 001 single PSR, SIM 1
        "0a004000"  # I048/040 RHO 10 NM = 2560/256, THETA 90° = 16384 * 360/2^16
        "1817b0"  # I048/130 PRL+PAM present; PRL 1° -> 23 * 360/2^13; PAM -80 dBm
        "05000000"  # I048/042 X 10 NM = 1280/128, Y 0
    )
    in_clutter = bytes.fromhex("f30940") + record[2:] + bytes.fromhex("1a")  # 030 code 13
    assert blocks == [bytes.fromhex("30002b") + record + in_clutter]


def test_cat048_i048_120_and_the_four_record_layouts_by_hand():
    """I048/120 subfield CAL (FRN20: FSPEC octet 3 bit 3, after I048/030 in FRN order): a
    primary subfield 0x80 (CAL only), then D (bit 16), 5 spare bits and the speed in 10
    bits of two's complement, 1 m/s. Plots without a range rate (NaN) have no I048/120."""
    plots = {"sensor": "r", "time_s": np.full(5, 1.5), "range_m": np.full(5, 10 * NM),
             "azimuth_rad": np.full(5, math.pi / 2), "snr_db": np.full(5, 20.0),
             "interference": np.array([0, 1, 0, 1, 0], np.uint8),
             "range_rate_mps": np.array([np.nan, np.nan, -3.4, 600.0, 2.5])}
    blocks = encode_cat048(plots, SOURCE)
    body = "01020000c0300a0040001817b005000000"  # I048/010 ... I048/042 as above
    records = [
        "f308" + body,  # neither
        "f30940" + body + "1a",  # I048/030 only (FRN16)
        "f30904" + body + "80" "03fd",  # I048/120 only (FRN20): CAL -3 m/s = 0x3fd, D 0
        "f30944" + body + "1a" "80" "81ff",  # both; 600 m/s clipped to 511, D = 1 doubtful
        "f30904" + body + "80" "0002",  # 2.5 m/s rounds half to even: 2
    ]
    rec = bytes.fromhex("".join(records))
    assert blocks == [bytes((48, 0, len(rec) + 3)) + rec]
    buf, offsets = cat048_records(
        plots["time_s"], plots["range_m"], plots["azimuth_rad"], source=SOURCE,
        snr_db=plots["snr_db"], clutter=plots["interference"] == 1,
        range_rate_mps=plots["range_rate_mps"])
    assert buf.tobytes() == rec
    assert np.diff(offsets).tolist() == [len(bytes.fromhex(r)) for r in records]
    # and the slices of a revolution give the same bytes
    assert encode_cat048_slices(plots, [0, 2], [2, 5], SOURCE) == [
        [bytes((48, 0, 3 + len(bytes.fromhex("".join(records[:2]))))) + bytes.fromhex(
            "".join(records[:2]))],
        [bytes((48, 0, 3 + len(bytes.fromhex("".join(records[2:]))))) + bytes.fromhex(
            "".join(records[2:]))]]


def test_cat034_bytes_by_hand():
    nm = encode_cat034_north_marker(
        2.0, sac=3, sic=4, start_sod_s=0.0, rotation_period_s=4.0, lat_deg=45.0,
        lon_deg=-90.0, height_m=-2.0)
    assert nm == bytes.fromhex(
        "22001b" "ef10" "0304" "01" "000100" "0200"  # 010, 000 north marker, 030 2 s, 041 4 s
        "900020" "900000"  # 050 COM + PSR (channel A), 060 COM + PSR (linear)
        "fffe" "200000" "c00000")  # 120 height -2 m, lat 45° = 2^21 LSB, lon -90° = -2^22
    sc = encode_cat034_sector_crossings([1.0], [math.pi], sac=3, sic=4, start_sod_s=0.0)
    assert sc == [bytes.fromhex("22000b" "f0" "0304" "02" "000080" "80")]  # 020: 180° -> 128


def test_time_of_day_wraps_at_midnight():
    sod = seconds_of_day(dt.datetime(2026, 6, 1, 23, 59, 59, 500000, tzinfo=dt.timezone.utc))
    assert sod == 86399.5
    counts = time_of_day_counts(np.array([0.0, 0.49, 0.499, 1.0, 86400.0]), sod)
    assert counts.tolist() == [11059136, 11059199, 0, 64, 11059136]
    # a start time given with an offset is converted to UTC
    eastern = dt.timezone(dt.timedelta(hours=-4))
    assert seconds_of_day(dt.datetime(2026, 6, 1, 20, 0, tzinfo=eastern)) == 0.0


def test_rho_beyond_256_nm_is_refused_not_wrapped():
    src = Cat048Source(sac=0, sic=1, start_sod_s=0.0)
    ok = cat048_records(np.array([0.0]), np.array([255.99 * NM]), np.array([0.0]),
                        source=src)[0]
    assert ok[8:10].tobytes() == (65533).to_bytes(2, "big")  # after FSPEC, 010, 140, 020
    with pytest.raises(AsterixError, match=r"47596\d m \(257.00 NM\).*\[0, 256\) NM"):
        cat048_records(np.array([0.0, 0.0]), np.array([1000.0, 257 * NM]), np.zeros(2),
                       source=src, sensor="far")
    with pytest.raises(AsterixError, match="non-finite"):
        cat048_records(np.array([0.0]), np.array([np.nan]), np.zeros(1), source=src)


def test_sac_sic_defaults_unique_and_duplicates_refused():
    d = scene_dict(radars=[quiet_radar(id="a"), quiet_radar(id="b", sic=1),
                           quiet_radar(id="c", sac=9)])
    assert parse_scenario(d).asterix_sources() == {"a": (0, 2), "b": (0, 1), "c": (9, 1)}
    d = scene_dict(radars=[quiet_radar(id="a", sac=3, sic=5), quiet_radar(id="b", sac=3, sic=5)])
    with pytest.raises(ScenarioError, match=r"platforms\[0\]\.radars\[1\]\.sic: SAC/SIC 3/5 is "
                                            r"already radar 'a'"):
        parse_scenario(d)
    # the record of a radar's CAT048 constants refuses a code outside the octet, in one line
    with pytest.raises(AsterixError, match=r"^I048/010, I034/010: SIC must be an integer in "
                                           r"\[0, 255\], got 256$"):
        Cat048Source(sac=0, sic=256, start_sod_s=0.0)
    assert Cat048Source(sac=np.uint8(3), sic=4, start_sod_s=0.0).sac.__class__ is int
    # a stream whose metadata repeats a code (hand-made messages) is refused too
    stream = AsterixStream()
    meta = {"sensor": "x", "radar": {}, "sac_sic": [1, 1], "start_time": "2026-01-01T00:00:00Z",
            "scan_period_s": 1.0, "sectors_per_scan": 4}
    stream.feed("meta", 0.0, meta)
    with pytest.raises(AsterixError, match="both have SAC/SIC 1/1"):
        stream.feed("meta", 0.0, {**meta, "sensor": "y"})


def test_udp_destination_rules():
    assert parse_udp_url("udp://127.0.0.1:8600") == ("127.0.0.1", 8600, False)
    assert parse_udp_url("udp://[::1]:9") == ("::1", 9, False)
    for url, words in (("udp://10.0.0.1:8600", "reachable from other machines"),
                       ("udp://239.1.2.3:8600", "multicast"),
                       ("udp://radar.example:8600", "host name"),
                       ("udp://127.0.0.1:70000", r"\[1, 65535\]"),
                       ("tcp://127.0.0.1:8600", "not udp://")):
        with pytest.raises(AsterixError, match=words):
            parse_udp_url(url)
    assert parse_udp_url("udp://239.1.2.3:8600", allow_remote=True)[2] is True


# ----------------------------------------------------------------- a short run
@pytest.fixture(scope="module")
def run():
    """Messages of a 8 s run across midnight, and the ASTERIX blocks they give."""
    s = scene(doppler=True)  # r1 with a Doppler bank (I048/120), r2 without
    msgs = list(Simulation(s).messages())
    stream = AsterixStream()
    blocks = [b for m in msgs for b in stream.feed(*m)]
    return s, msgs, blocks, stream


def _expected(s, msgs):
    """Per SIC: the plots, in stream order, and the eos and meta messages."""
    sources = s.asterix_sources()
    plots, eos, meta = {}, {}, {}
    for topic, _, p in msgs:
        if topic == "plots":
            plots.setdefault(p["sensor"], []).append(p)
        elif topic == "eos":
            eos.setdefault(p["sensor"], []).append(p)
        elif topic == "meta":
            meta.setdefault(p["sensor"], p)
    out = {}
    for sensor, (sac, sic) in sources.items():
        cols = {k: np.concatenate([p[k] for p in plots.get(sensor, [])])
                for k in ("time_s", "range_m", "azimuth_rad", "snr_db", "interference",
                          "range_rate_mps")}
        out[sic] = (sensor, sac, cols, eos[sensor], meta[sensor])
    return out


def _tod_diff(decoded_s, t, sod):
    d = np.asarray(decoded_s) - np.mod(sod + np.asarray(t), 86400.0)
    return np.abs((d + 43200.0) % 86400.0 - 43200.0)


def _az_diff_deg(a_deg, b_rad):
    d = np.asarray(a_deg) - np.degrees(b_rad)
    return np.abs((d + 180.0) % 360.0 - 180.0)


def _check_decoded(s, msgs, stream, recs048, recs034):
    """Compare decoded records (flattened dicts of plain numbers) with the stream."""
    sod = seconds_of_day(s.start_time)
    expected = _expected(s, msgs)
    n_plots = 0
    for sic, (sensor, sac, cols, eos, meta) in expected.items():
        got = [r for r in recs048 if r["sic"] == sic]
        n = cols["range_m"].size
        assert n > 5, "the scene must give plots to compare"
        assert len(got) == n, sensor
        n_plots += n
        g = {k: np.array([r[k] for r in got], dtype=float) for k in got[0]}
        assert np.all(g["sac"] == sac)
        assert np.all(g["sim"] == 1) and np.all(g["typ"] == 1)
        assert _tod_diff(g["tod"], cols["time_s"], sod).max() <= 1 / 256 + 1e-9
        assert np.abs(g["rho"] - cols["range_m"] / NM).max() <= 1 / 512 + 1e-9
        assert _az_diff_deg(g["theta"], cols["azimuth_rad"]).max() <= 360 / 2**17 + 1e-9
        rho = cols["range_m"] / NM
        assert np.abs(g["x"] - rho * np.sin(cols["azimuth_rad"])).max() <= 1 / 256 + 1e-9
        assert np.abs(g["y"] - rho * np.cos(cols["azimuth_rad"])).max() <= 1 / 256 + 1e-9
        pam = np.clip(cols["snr_db"] + meta["noise_power_dbm"], -128, 127)
        assert np.abs(g["pam"] - pam).max() <= 0.5 + 1e-9
        bw = meta["radar"]["beamwidth_az_deg"]
        assert np.abs(g["prl"] - bw).max() <= 360 / 2**14 + 1e-9
        # I048/120 CAL: the range rate within half its LSB (1 m/s), valid (D = 0); absent
        # (NaN) for a radar without a Doppler bank
        rr = cols["range_rate_mps"]
        if meta["radar"]["processor"]["type"] in ("dft_bank", "fir_bank", "mti_bank"):
            assert np.isfinite(rr).all() and np.abs(rr).max() > 1.0
            assert np.abs(g["cal"] - rr).max() <= 0.5 + 1e-9
            assert np.all(g["cal_d"] == 0)
        else:
            assert np.isnan(rr).all() and np.isnan(g["cal"]).all()
        # sector crossings: one per sector boundary from t = 0 to the end
        sector_s = meta["scan_period_s"] / meta["sectors_per_scan"]
        crossings = [r for r in recs034 if r["sic"] == sic and r["type"] == 2]
        assert len(crossings) == math.floor(s.duration_s / sector_s + 1e-9) + 1
        az0 = meta["radar"]["start_azimuth_deg"]
        t_x = np.arange(len(crossings)) * sector_s
        az_x = np.mod(az0 + 360.0 * t_x / meta["scan_period_s"], 360.0)
        sector = np.array([r["sector_deg"] for r in crossings])
        d = (az_x - sector + 180.0) % 360.0 - 180.0  # 8 MSBs of the azimuth: truncated
        assert d.min() >= -1e-6 and d.max() < 360 / 256 + 1e-6
        assert _tod_diff([r["tod"] for r in crossings], t_x, sod).max() <= 1 / 256 + 1e-9
        # north markers with the antenna's position (I034/120)
        markers = [r for r in recs034 if r["sic"] == sic and r["type"] == 1]
        period = meta["scan_period_s"]
        frac = ((360.0 - az0) % 360.0) / 360.0 or 1.0
        t_n = np.arange(frac * period, s.duration_s + 1e-9, period)
        assert len(markers) == t_n.size > 0
        assert _tod_diff([m["tod"] for m in markers], t_n, sod).max() <= 1 / 256 + 1e-9
        assert all(m["period"] == period for m in markers)
        lsb = 180.0 / 2**23
        for m, tn in zip(markers, t_n, strict=True):
            e = min(eos, key=lambda e, tn=tn: abs(e["time_s"] - tn))
            pos = e["position"]
            assert m["height"] == round(pos["alt_m"])
            if az0 == 0.0:  # north crossings are ends of scan: the eos position itself
                assert e["time_s"] == pytest.approx(tn, abs=1e-9)
                # half an LSB; asterix-decoder's LSB constant (0.00002145767) is 1e-7 short
                for k in ("lat", "lon"):
                    ref = pos[f"{k}_deg"]
                    assert abs(m[k] - ref) <= lsb / 2 + 1e-7 * abs(ref) + 1e-9, k
            else:  # dead-reckoned from an eos at most one revolution away: 10 m/s ship
                tol = 1.0 + 10.0 * period
                assert abs(m["lat"] - pos["lat_deg"]) * 111e3 <= tol
                assert abs(m["lon"] - pos["lon_deg"]) * 111e3 * 0.72 <= tol
    assert n_plots == stream.stats["cat048_records"]
    return n_plots


def test_two_independent_decoders_agree_with_the_stream(run, tmp_path):
    s, msgs, blocks, stream = run
    assert any(p["range_m"].size for t, _, p in msgs if t == "plots")
    # asterix-decoder (PyPI, C++ with its own XML definitions)
    import asterix

    recs048, recs034 = [], []
    for _, block in blocks:
        for r in asterix.parse(block):
            if r["category"] == 48:
                recs048.append({
                    "sac": r["I010"]["SAC"]["val"], "sic": r["I010"]["SIC"]["val"],
                    "tod": r["I140"]["ToD"]["val"], "typ": r["I020"]["TYP"]["val"],
                    "sim": r["I020"]["SIM"]["val"], "rho": r["I040"]["RHO"]["val"],
                    "theta": r["I040"]["THETA"]["val"], "x": r["I042"]["X"]["val"],
                    "y": r["I042"]["Y"]["val"], "prl": r["I130"]["PRLP"]["PRL"]["val"],
                    "pam": r["I130"]["PAMP"]["PAM"]["val"],
                    "cal": r["I120"]["CAL"]["CAL"]["val"] if "I120" in r else math.nan,
                    "cal_d": r["I120"]["CAL"]["D"]["val"] if "I120" in r else math.nan})
            else:
                rec = {"sic": r["I010"]["SIC"]["val"], "type": r["I000"]["MsgTyp"]["val"],
                       "tod": r["I030"]["ToD"]["val"]}
                if rec["type"] == 2:
                    rec["sector_deg"] = r["I020"]["Azi"]["val"]
                else:
                    p = r["I120"]
                    rec.update(period=r["I041"]["RotS"]["val"], height=p["Height"]["val"],
                               lat=p["LAT"]["val"], lon=p["Lon"]["val"])
                recs034.append(rec)
    n1 = _check_decoded(s, msgs, stream, recs048, recs034)

    # Wireshark's dissector, on a pcap of the same blocks
    pcap = tmp_path / "run.pcap"
    write_pcap(pcap, datagrams(blocks, 1400), stream.start_epoch_s, PORT)
    recs048, recs034 = [], []
    for blk in tshark_asterix(pcap, PORT):
        for m in blk["records"]:
            if blk["category"] == 48:
                i130 = m["asterix.048_130"]
                recs048.append({
                    "sac": int(m["asterix.048_010"]["asterix.048_010_SAC"], 16),
                    "sic": int(m["asterix.048_010"]["asterix.048_010_SIC"], 16),
                    "tod": float(m["asterix.048_140"]["asterix.048_140_VALUE"]),
                    "typ": int(m["asterix.048_020"]["asterix.048_020_TYP"]),
                    "sim": int(m["asterix.048_020"]["asterix.048_020_SIM"]),
                    "rho": float(m["asterix.048_040"]["asterix.048_040_RHO"]),
                    "theta": float(m["asterix.048_040"]["asterix.048_040_THETA"]),
                    "x": float(m["asterix.048_042"]["asterix.048_042_X"]),
                    "y": float(m["asterix.048_042"]["asterix.048_042_Y"]),
                    "prl": float(i130["asterix.048_130_PRL"]["asterix.048_130_PRL_VALUE"]),
                    "pam": float(i130["asterix.048_130_PAM"]["asterix.048_130_PAM_VALUE"]),
                    **_tshark_cal(m)})
            else:
                rec = {"sic": int(m["asterix.034_010"]["asterix.034_010_SIC"], 16),
                       "type": int(m["asterix.034_000"]["asterix.034_000_VALUE"]),
                       "tod": float(m["asterix.034_030"]["asterix.034_030_VALUE"])}
                if rec["type"] == 2:
                    rec["sector_deg"] = float(m["asterix.034_020"]["asterix.034_020_VALUE"])
                else:
                    p = m["asterix.034_120"]
                    rec.update(period=float(m["asterix.034_041"]["asterix.034_041_VALUE"]),
                               height=float(p["asterix.034_120_HGT"]),
                               lat=float(p["asterix.034_120_LAT"]),
                               lon=float(p["asterix.034_120_LON"]))
                recs034.append(rec)
    assert _check_decoded(s, msgs, stream, recs048, recs034) == n1


def _tshark_cal(m: dict) -> dict:
    """Wireshark's I048/120 CAL subfield of a record: speed [m/s] and D (NaN: absent)."""
    cal = m.get("asterix.048_120", {}).get("asterix.048_120_CAL")
    if cal is None:
        return {"cal": math.nan, "cal_d": math.nan}
    return {"cal": float(cal["asterix.048_120_CAL_CAL"]),
            "cal_d": int(cal["asterix.048_120_CAL_D"])}


def test_blocks_respect_the_size_and_the_bytes_are_deterministic(run):
    s, msgs, blocks, _ = run
    small = AsterixStream(max_block_bytes=64)
    again = [b for m in msgs for b in small.feed(*m)]
    assert max(len(b) for _, b in again) <= 64
    assert all(int.from_bytes(b[1:3], "big") == len(b) for _, b in again)
    # same records, cut differently: CAT048 bytes after the block headers are equal
    def body(bs, cat):
        return b"".join(b[3:] for _, b in bs if b[0] == cat)

    assert body(again, 48) == body(blocks, 48)
    same = AsterixStream()
    assert [b for m in msgs for b in same.feed(*m)] == blocks


def test_revolution_at_once_equals_message_by_message():
    """encode_cat048_slices (a run's revolution at once) gives each slice exactly the blocks
    of encode_cat048 on it: clutter and plain records mixed, blocks split, empty slices."""
    rng = np.random.default_rng(3)
    n = 200
    cols = {"time_s": np.sort(rng.uniform(0.0, 4.0, n)),
            "range_m": rng.uniform(0.0, 250 * NM, n),
            "azimuth_rad": rng.uniform(-1.0, 7.0, n), "snr_db": rng.normal(10.0, 30.0, n),
            "interference": rng.integers(0, 3, n).astype(np.uint8)}
    cols["snr_db"][:3] = (np.nan, np.inf, -np.inf)
    cols["interference"][100:150] = 0  # a stretch without clutter
    cuts = [0, 0, 1, 17, 17, 100, 150, 151, 200]
    starts, stops = cuts[:-1], cuts[1:]
    for kw in ({"prl_deg": 1.2, "noise_power_dbm": -95.0}, {}):
        src = Cat048Source(sac=7, sic=9, start_sod_s=86000.0, **kw)
        for mb in (64, 200, 1400):
            got = encode_cat048_slices(cols, starts, stops, src, max_block_bytes=mb)
            want = [encode_cat048({k: v[a:b] for k, v in cols.items()}, src,
                                  max_block_bytes=mb)
                    for a, b in zip(starts, stops, strict=True)]
            assert got == want
    # the CAT034 crossings: plain integers up to 64 records, numpy beyond, same blocks
    t = np.arange(70) * 0.1
    az = np.mod(t * 2.0, 2 * math.pi)
    many = encode_cat034_sector_crossings(t, az, sac=1, sic=2, start_sod_s=3.0,
                                          max_block_bytes=64)
    few = encode_cat034_sector_crossings(t[:63].tolist(), az[:63].tolist(), sac=1, sic=2,
                                         start_sod_s=3.0, max_block_bytes=64)
    assert few == many[:9] and len(many) == 10


def test_run_encoding_ahead_sends_what_the_stream_gives(run):
    """The engine hands the ASTERIX bus each revolution's plots ahead (plots_ahead) and its
    encoded frames: the datagrams are those of the stream fed message by message."""
    from shipradar.sim.adapters.asterix.udp import AsterixBus

    s, msgs, _, _ = run
    sender = MemorySender()
    bus = AsterixBus(None, sender)
    made = []
    encode_ahead = bus.stream.encode_ahead
    bus.stream.encode_ahead = lambda *a: made.append(encode_ahead(*a)) or made[-1]
    sim = Simulation(s, bus=bus)
    assert sim.encodes_ahead
    sim.run()
    assert sum(len(m) for m in made if m) > 5  # the revolutions' records were made ahead
    stream = AsterixStream()
    want = [d for m in msgs for _, d in datagrams(stream.feed(*m), 1400)]
    assert sender.sent == want and bus.stream.stats == stream.stats
    assert bus.pending_ahead == 0  # every sector made ahead was sent


# ----------------------------------------------------------------- UDP, CLI
def _receiver(sock, got, stop):
    while True:
        ready, _, _ = select.select([sock], [], [], 0.2)
        if ready:
            got.append(sock.recv(65536))
        elif stop.is_set():
            return


def _udp_listen():
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)
    sock.bind(("127.0.0.1", 0))  # a free port, chosen by the kernel
    return sock, sock.getsockname()[1]


def _cli_collect(argv, env):
    sock, port = _udp_listen()
    got, stop = [], threading.Event()
    th = threading.Thread(target=_receiver, args=(sock, got, stop), daemon=True)
    th.start()
    try:
        argv = [a.replace("PORT", str(port)) for a in argv]
        res = subprocess.run([sys.executable, "-m", "shipradar.sim.cli", *argv],
                             capture_output=True, text=True, cwd=ROOT, env=env, timeout=120)
    finally:
        stop.set()
        th.join(10)
        sock.close()
    return res, got


@pytest.mark.slow
def test_udp_run_and_replay_deliver_every_datagram(tmp_path, monkeypatch):
    import json
    import os

    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene_dict(duration_s=6.0)))
    env = dict(os.environ, SHIPRADAR_TABLES=str(tmp_path / "tables"))
    rec = tmp_path / "run.rec"
    res, got = _cli_collect(["run", str(path), "--quiet", "--record", str(rec),
                             "--asterix", "udp://127.0.0.1:PORT"], env)
    assert res.returncode == 0, res.stderr
    summary = json.loads(res.stdout.splitlines()[-1])
    ast = summary["asterix"]
    assert len(got) == ast["datagrams"] > 0
    plots = (summary["target_plots"] + summary["noise_false_alarms"]
             + summary["clutter_false_alarms"])
    assert plots > 10
    import asterix

    n048 = 0
    for d in got:
        assert len(d) <= 1400
        pos = 0
        while pos < len(d):  # whole data blocks back to back
            pos += int.from_bytes(d[pos + 1:pos + 3], "big")
        assert pos == len(d)
        n048 += sum(r["category"] == 48 for r in asterix.parse(d))
    assert n048 == plots == ast["cat048_records"]
    # the recording replays as the same datagrams
    res, again = _cli_collect(["replay", str(rec), "--fast", "--asterix",
                               "udp://127.0.0.1:PORT"], env)
    assert res.returncode == 0, res.stderr
    assert again == got


@pytest.mark.parametrize("argv, words", [
    (["--asterix", "udp://192.0.2.7:8600"], "--asterix: refusing 192.0.2.7"),
    (["--asterix", "udp://127.0.0.1:8600", "--asterix-max-datagram", "20"],
     r"--asterix-max-datagram must be an integer in \[64, 65507\] bytes, got '20'"),
])
def test_cli_bad_asterix_options_exit_2(argv, words, capsys, tmp_path, monkeypatch):
    from shipradar.sim.cli import main

    monkeypatch.setenv("SHIPRADAR_TABLES", str(tmp_path / "tables"))
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene_dict()))
    try:
        code = main(["run", str(path), "--quiet", *argv])
    except SystemExit as exc:  # argparse
        code = exc.code
    assert code == 2
    import re

    assert re.search(words, capsys.readouterr().err)


def test_cli_refuses_a_radar_beyond_rho(tmp_path, capsys, monkeypatch):
    from shipradar.sim.cli import main

    monkeypatch.setenv("SHIPRADAR_TABLES", str(tmp_path / "tables"))
    path = tmp_path / "far.yaml"
    path.write_text(yaml.safe_dump(scene_dict(radars=[quiet_radar(
        instrumented_range_m=480000.0, prf_hz=300)])))
    assert main(["run", str(path), "--asterix", "udp://127.0.0.1:8600"]) == 2
    assert "instrumented_range_m 480000 m reaches I048/040 RHO's bound of 256 NM" \
        in capsys.readouterr().err
