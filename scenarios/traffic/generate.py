"""Write the small traffic sample files of each shape (deterministic; from the repository root).

    python scenarios/traffic/generate.py

Made by the project, not downloaded: made-up ships and aircraft around the demo's frigate
(``scenarios/single_missile.yaml``: origin 44.6 N 63.0 W, start 2026-06-01T12:00:00Z), in the
column layouts of

* ``missile_plain.csv``: the project's ``plain`` preset (time_s, id, lat_deg, lon_deg, alt_m),
  the demo's sea-skimmer sampled once a second along its two waypoints;
* ``ais_sample.csv``: a public US AIS extract of MarineCadastre (MMSI, BaseDateTime, LAT, LON,
  SOG [kn], COG [deg], Heading, VesselName, IMO, CallSign, VesselType, Status, Length, Width,
  Draft, Cargo, TransceiverClass): six vessels reporting every 10 s with some jitter, one
  with "speed not available" (SOG 102.3) on some reports and one silent for 4 minutes;
* ``adsb_sample.csv``: OpenSky Network state vectors (time [unix s], icao24, lat, lon,
  velocity [m/s], heading [deg], vertrate [m/s], callsign, onground, alert, spi, squawk,
  baroaltitude, geoaltitude [m], lastposupdate, lastcontact): three aircraft every 10 s,
  one climbing.

The reported speeds and courses are the true ones (true north at each fix), so a reader can
check its interpolation against the generating motion.
"""

from __future__ import annotations

import csv
import datetime as dt
import math
from pathlib import Path

import numpy as np

from shipradar.sim.world.geodesy import WGS84_A_M, WGS84_B_M
from shipradar.sim.world.kinematics import LocalFrame
from shipradar.sim.world.scenario import Origin

HERE = Path(__file__).resolve().parent
ORIGIN = Origin(lat_deg=44.6, lon_deg=-63.0)
START = dt.datetime(2026, 6, 1, 12, 0, 0, tzinfo=dt.timezone.utc)
KNOT = 1852.0 / 3600.0


def circle(t: np.ndarray, e0: float, n0: float, course_deg: float, speed: float,
           turn_deg_s: float) -> np.ndarray:
    """(east, north) [m] in the local frame of a constant-speed turn (0: straight)."""
    psi0 = math.radians(course_deg)
    w = math.radians(turn_deg_s)
    if w == 0.0:
        return np.column_stack([e0 + speed * t * math.sin(psi0),
                                n0 + speed * t * math.cos(psi0)])
    r = speed / w
    psi = psi0 + w * t
    return np.column_stack([e0 + r * (np.cos(psi0) - np.cos(psi)),
                            n0 + r * (np.sin(psi) - np.sin(psi0))])


def geodetic_motion(frame: LocalFrame, en_of, t: np.ndarray, alt_of):
    """Latitude, longitude [deg], altitude [m] and the true speed [m/s], course [deg] and
    vertical rate [m/s] at times ``t`` of a motion given in the local frame."""
    def geo(tt):
        en = en_of(tt)
        # the frame's ground point (a height moves along the frame's vertical, which the
        # reader's inverse at height 0 would not undo to the last millimetre)
        lat, lon, _ = frame.geodetic(np.column_stack([en, np.zeros(len(en))]))
        return lat, lon

    lat, lon = geo(t)
    h = 0.01
    la1, lo1 = geo(t + h)
    la0, lo0 = geo(t - h)
    e2 = 1.0 - (WGS84_B_M / WGS84_A_M) ** 2
    phi = np.radians(lat)
    w = 1.0 - e2 * np.sin(phi) ** 2
    m, n = WGS84_A_M * (1.0 - e2) / w**1.5, WGS84_A_M / np.sqrt(w)
    vn = np.radians(la1 - la0) / (2 * h) * m
    ve = np.radians(lo1 - lo0) / (2 * h) * n * np.cos(phi)
    vz = (alt_of(t + h) - alt_of(t - h)) / (2 * h)
    return (lat, lon, alt_of(t), np.hypot(ve, vn),
            np.degrees(np.arctan2(ve, vn)) % 360.0, vz)


def missile(frame: LocalFrame) -> None:
    t = np.arange(0.0, 105.0 + 0.5, 1.0)
    a, b = np.array([21000.0, 21000.0]), np.array([0.0, 840.0])
    en = a + (b - a) * (t / 105.0)[:, None]
    lat, lon, _ = frame.geodetic(np.column_stack([en, np.zeros(t.size)]))
    with open(HERE / "missile_plain.csv", "w", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(["time_s", "id", "lat_deg", "lon_deg", "alt_m"])
        for k in range(t.size):
            out.writerow([f"{t[k]:g}", "missile1", f"{lat[k]:.9f}", f"{lon[k]:.9f}", "5"])


SHIPS = [  # MMSI, name, type, east, north [m], course [deg], speed [kn], turn [deg/s]
    (316001001, "ATLANTIC SPIRIT", 70, 12000.0, -8000.0, 20.0, 14.0, 0.0),
    (316001002, "BEDFORD TRADER", 70, -15000.0, 9000.0, 95.0, 11.0, 0.0),
    (316001003, "SABLE FISHER", 30, 6000.0, 14000.0, 200.0, 8.0, 0.05),
    (316001004, "HALIFAX PILOT", 50, -3000.0, -5000.0, 300.0, 16.0, -0.2),
    (316001005, "NORTHERN STAR", 80, 22000.0, 18000.0, 250.0, 12.5, 0.0),
    (316001006, "CAPE SPLIT", 31, -9000.0, -16000.0, 45.0, 9.5, 0.1),
]


def ais(frame: LocalFrame) -> None:
    rng = np.random.default_rng(20260601)
    rows = []
    for k, (mmsi, name, vtype, e0, n0, course, kn, turn) in enumerate(SHIPS):
        t = np.arange(0.0, 180.0, 10.0) + rng.uniform(0.0, 3.0, 18)
        if k == 3:  # silent for 4 minutes: the reader's max_gap_s (here 120 s) makes a gap
            t = np.concatenate([t[t < 40.0], t[t < 40.0] + 280.0])
        speed = kn * KNOT
        lat, lon, _, sog, cog, _ = geodetic_motion(
            frame, lambda tt, e0=e0, n0=n0, c=course, s=speed, w=turn: circle(tt, e0, n0, c, s,
                                                                             w),
            t, lambda tt: np.zeros_like(tt))
        for j in range(t.size):
            when = START + dt.timedelta(seconds=float(np.round(t[j], 3)))
            sog_kn = sog[j] / KNOT
            na = k == 1 and j % 4 == 2  # "not available" on some reports
            rows.append([mmsi, when.strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3], f"{lat[j]:.7f}",
                         f"{lon[j]:.7f}", "102.3" if na else f"{sog_kn:.3f}",
                         "360.0" if na else f"{cog[j]:.3f}", f"{round(cog[j]) % 360}", name,
                         f"IMO{9000000 + k}", f"CF{k:04d}", vtype, 0, 120 + 10 * k, 20, 7.5,
                         vtype, "A"])
    rows.sort(key=lambda r: (r[1], r[0]))  # as an extract is: by time
    with open(HERE / "ais_sample.csv", "w", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(["MMSI", "BaseDateTime", "LAT", "LON", "SOG", "COG", "Heading",
                      "VesselName", "IMO", "CallSign", "VesselType", "Status", "Length",
                      "Width", "Draft", "Cargo", "TransceiverClass"])
        out.writerows(rows)


AIRCRAFT = [  # icao24, callsign, east, north [m], course, speed [m/s], alt0 [m], climb [m/s]
    ("c0ffee", "ACA870  ", -40000.0, 30000.0, 120.0, 220.0, 9000.0, 0.0),
    ("c0a5e1", "WJA231  ", 35000.0, -25000.0, 300.0, 180.0, 3000.0, 12.0),
    ("c07f00", "PCO301  ", 5000.0, 40000.0, 180.0, 120.0, 1500.0, 0.0),
]


def adsb(frame: LocalFrame) -> None:
    rows = []
    t0 = START.timestamp()
    for icao, call, e0, n0, course, speed, z0, climb in AIRCRAFT:
        t = np.arange(0.0, 180.0, 10.0)
        lat, lon, alt, v, hdg, vz = geodetic_motion(
            frame, lambda tt, e0=e0, n0=n0, c=course, s=speed: circle(tt, e0, n0, c, s, 0.0),
            t, lambda tt, z0=z0, c=climb: z0 + c * np.minimum(tt, 120.0))  # level at 120 s
        for j in range(t.size):
            rows.append([int(t0 + t[j]), icao, f"{lat[j]:.7f}", f"{lon[j]:.7f}", f"{v[j]:.2f}",
                         f"{hdg[j]:.3f}", f"{vz[j]:.2f}", call, "False", "False", "False",
                         "1000", f"{alt[j] - 40.0:.1f}", f"{alt[j]:.1f}",
                         f"{t0 + t[j] - 0.3:.3f}", f"{t0 + t[j] - 0.1:.3f}"])
    rows.sort(key=lambda r: (r[0], r[1]))
    with open(HERE / "adsb_sample.csv", "w", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(["time", "icao24", "lat", "lon", "velocity", "heading", "vertrate",
                      "callsign", "onground", "alert", "spi", "squawk", "baroaltitude",
                      "geoaltitude", "lastposupdate", "lastcontact"])
        out.writerows(rows)


if __name__ == "__main__":
    frame = LocalFrame(ORIGIN)
    missile(frame)
    ais(frame)
    adsb(frame)
