"""A minimal stand-alone tracker for shipradar, the template to copy into your own language.

It imports nothing of shipradar: pyzmq, msgpack and numpy only, with the decoder of
docs/protocol.md section 5 and the matching encoder for the ``tracks`` topic (section 4.6).
Run it under ``shipradar evaluate``::

    shipradar evaluate scenarios/single_missile.yaml --runs 10 \\
        --tracker "python examples/tracker_template.py {plots} {tracks}"

or beside a run::

    python examples/tracker_template.py tcp://127.0.0.1:5555 tcp://127.0.0.1:5560 &
    shipradar run scenarios/single_missile.yaml --publish tcp://127.0.0.1:5555 --wait 1

What it does, per end of scan of the first radar it hears (everything a real tracker does,
in its simplest form):

1. the scan's plots, from range/azimuth (true north, clockwise) to local east/north around
   the antenna position of the ``eos`` message (the slant range taken as ground range);
2. a clutter map: plots per scan and km² in 500 m range rings around the ship, learned from
   the stream; no track starts where it exceeds ``MAX_INIT_DENSITY``, nor in the first
   ``LEARN_SCANS`` scans;
3. association: each track's prediction takes the nearest plot within its gate, greedily,
   nearest pairs first;
4. an alpha-beta filter per track (constant velocity);
5. initiation from two plots at most ``MAX_SPEED`` apart, confirmation after ``CONFIRM``
   hits, deletion after ``MISSES`` scans without a hit;
6. one ``tracks`` message with the confirmed tracks at the end-of-scan time.
"""

from __future__ import annotations

import argparse
import itertools
import struct

import msgpack
import numpy as np
import zmq

ALPHA, BETA = 0.5, 0.3  # alpha-beta gains
GATE_M = 600.0  # association gate around a prediction [m]
MAX_SPEED = 700.0  # fastest target a two-plot initiation accepts [m/s]
CONFIRM = 4  # hits in a row to confirm
MISSES = 5  # scans without a hit before deletion (tentative tracks: 1)
RING_M = 500.0  # clutter-map ring width [m]
MAX_INIT_DENSITY = 0.05  # plots per scan and km² above which no track starts
LEARN_SCANS = 3  # scans the clutter map learns before any track starts


# ----------------------------------------------------------- protocol (docs/protocol.md)
def ext_hook(code, data):
    """msgpack ext type 1 -> numpy array (section 3)."""
    if code != 1:
        return msgpack.ExtType(code, data)
    ndim, lts = data[0], data[1]
    dtype = np.dtype(data[2:2 + lts].decode("ascii"))
    pos = (2 + lts + 7) // 8 * 8
    shape = struct.unpack_from(f"<{ndim}Q", data, pos)
    return np.frombuffer(data, dtype, offset=pos + 8 * ndim).reshape(shape)


def ext_array(a):
    """numpy array -> msgpack ext type 1 (section 3): ndim, type string, pad, shape, data."""
    a = np.ascontiguousarray(a, dtype="<f8")
    head = bytes([a.ndim, 3]) + b"<f8" + bytes(3) + struct.pack(f"<{a.ndim}Q", *a.shape)
    return msgpack.ExtType(1, head + a.tobytes())


def decode_body(body):
    msg = msgpack.unpackb(body, ext_hook=ext_hook)
    if msg["v"] not in (1, 2):  # docs/protocol.md section 2: 2 since issue 25
        raise ValueError(f"unsupported schema version {msg['v']}")
    return msg


def encode_tracks(sensor, scan, t, tracks):
    body = {"v": 1, "t": float(t), "sensor": sensor, "scan": int(scan), "time_s": float(t),
            "track_id": [str(k.id) for k in tracks]}
    for key, col in (("east_m", 0), ("north_m", 1), ("v_east_mps", 2), ("v_north_mps", 3)):
        body[key] = ext_array([k.x[col] for k in tracks])
    for key in ("sigma_east_m", "sigma_north_m"):
        body[key] = ext_array([k.sigma for k in tracks])
    return [b"tracks", msgpack.packb(body)]


# ------------------------------------------------------------------------------ tracker
class Track:
    ids = itertools.count(1)

    def __init__(self, xy, t):
        self.id = 0
        self.x = np.array([xy[0], xy[1], 0.0, 0.0])  # east, north, v_east, v_north
        self.t = t
        self.hits, self.misses, self.moving = 1, 0, False
        self.sigma = GATE_M / 3

    def predict(self, t):
        return self.x[:2] + self.x[2:] * (t - self.t)

    def update(self, xy, t):
        dt = t - self.t
        pred = self.predict(t)
        r = xy - pred
        if not self.moving:  # second plot: velocity from the two
            self.x[2:] = (xy - self.x[:2]) / max(dt, 1e-3)
            self.x[:2] = xy
            self.moving = True
        else:
            self.x[:2] = pred + ALPHA * r
            self.x[2:] += BETA * r / max(dt, 1e-3)
        self.t = t
        self.hits += 1
        self.misses = 0
        if self.hits >= CONFIRM and not self.id:
            self.id = next(Track.ids)


def step(tracks, xy, t, clutter_ok):
    """One scan: associate, update, initiate, delete; returns the tracks kept."""
    used = np.zeros(len(xy), bool)
    pairs = []
    for i, trk in enumerate(tracks):
        if len(xy):
            d = np.hypot(*(xy - trk.predict(t)).T)
            gate = GATE_M if trk.moving else MAX_SPEED * (t - trk.t) + GATE_M
            for j in np.flatnonzero(d <= gate):
                pairs.append((d[j], i, j))
    done = set()
    for _, i, j in sorted(pairs):  # nearest pairs first
        if i in done or used[j]:
            continue
        tracks[i].update(xy[j], t)
        done.add(i)
        used[j] = True
    for i, trk in enumerate(tracks):
        if i not in done:
            trk.misses += 1
    kept = [k for k in tracks if k.misses <= (MISSES if k.id else 1)]
    kept += [Track(xy[j], t) for j in np.flatnonzero(~used & clutter_ok)]
    return kept


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("plots", help="shipradar stream endpoint to subscribe to")
    ap.add_argument("tracks", help="endpoint to bind and publish the tracks topic on")
    a = ap.parse_args(argv)
    ctx = zmq.Context()
    pub = ctx.socket(zmq.PUB)
    pub.bind(a.tracks)
    sub = ctx.socket(zmq.SUB)
    sub.connect(a.plots)
    for topic in (b"meta", b"plots", b"eos"):
        sub.setsockopt(zmq.SUBSCRIBE, topic)
    sensor, r_max = None, 0.0
    pending = []  # the scan's plots: (time, range, azimuth)
    tracks, ring_counts, scans = [], None, 0
    while sub.poll(30_000):  # the stream has no end message: stop after 30 s of silence
        topic, body = sub.recv_multipart()
        msg = decode_body(body)
        if topic == b"meta" and sensor is None:
            sensor, r_max = msg["sensor"], float(msg["radar"]["instrumented_range_m"])
            ring_counts = np.zeros(int(r_max // RING_M) + 2)
        if sensor is None or msg.get("sensor") != sensor:
            continue
        if topic == b"plots":
            pending.append(np.stack([msg["time_s"], msg["range_m"], msg["azimuth_rad"]]))
        elif topic == b"eos":
            p = msg["position"]
            ship = np.array([p["east_m"], p["north_m"]])
            t_r_az = np.concatenate(pending, axis=1) if pending else np.zeros((3, 0))
            pending = []
            rng, az = t_r_az[1], t_r_az[2]
            xy = ship + np.stack([rng * np.sin(az), rng * np.cos(az)], axis=-1)
            ring = np.minimum((rng // RING_M).astype(int), ring_counts.size - 1)
            ring_counts += np.bincount(ring, minlength=ring_counts.size)
            scans += 1
            area_km2 = np.pi * ((ring + 1) ** 2 - ring**2) * (RING_M / 1e3) ** 2
            clutter_ok = ((ring_counts[ring] / scans / area_km2 <= MAX_INIT_DENSITY)
                          & (scans > LEARN_SCANS))
            t = float(msg["time_s"])
            tracks = step(tracks, xy, t, clutter_ok)
            confirmed = [k for k in tracks if k.id]
            out = []
            for k in confirmed:  # predicted to the end of scan
                c = Track.__new__(Track)
                c.id, c.sigma = k.id, k.sigma
                c.x = np.concatenate([k.predict(t), k.x[2:]])
                out.append(c)
            pub.send_multipart(encode_tracks(sensor, msg["scan"], t, out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
