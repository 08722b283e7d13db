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

With ``--estimate-bias`` it also registers the radars (bias estimation,
:class:`BiasEstimator`): it pairs each plot of every other radar with the plot that last
updated a confirmed track of the first radar on the same target, estimates every radar's
range and azimuth biases by least squares over all the pairs so far, corrects the first
radar's plots with its estimates before tracking them, and publishes the estimates on the
``registration`` topic (docs/protocol.md section 4.8) before each ``tracks`` message.
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

# bias estimation (--estimate-bias)
WGS84_A, WGS84_F = 6_378_137.0, 1.0 / 298.257223563  # WGS-84 semi-major axis [m], flattening
K_EARTH = 4.0 / 3.0  # effective earth factor of the stream's slant ranges (protocol 4.0)
PAIR_GATE_M = 1500.0  # a plot and another radar's track on the same target: this close [m]
PAIR_AMBIGUITY = 2.0  # ... and the next track at least this many times farther
SIGMA_VELOCITY_MPS = 30.0  # 1σ of a track's velocity carrying a plot across a pair's gap
MIN_PAIRS = 40  # pairs before the first estimate is published
MAX_PAIRS = 2000  # the latest pairs kept (a fading memory for slowly drifting biases)
SOLVE_EVERY_S = 5.0  # the estimate is solved again this often (stream time) [s]
HEIGHT_MAX_M = 20_000.0  # target heights searched [m]
SIGMA_HEIGHT_M = 20_000.0  # weak prior on a target's height (about 0) [m]
CHI2_OUTLIER = 13.82  # a pair beyond this (chi², 2 dof, 0.1 %) is left out
MAX_SIGMA_RANGE_M, MAX_SIGMA_AZIMUTH_RAD = 50.0, 0.005  # publish only below these 1σ


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
        self.last = None  # the last plot's raw values (bias estimation)

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


def step(tracks, xy, t, clutter_ok, raw=None):
    """One scan: associate, update, initiate, delete; returns the tracks kept. ``raw``: per
    plot what the bias estimator needs of it, kept on the track it updates (``last``)."""
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
        if raw is not None:
            tracks[i].last = raw[j]
        done.add(i)
        used[j] = True
    for i, trk in enumerate(tracks):
        if i not in done:
            trk.misses += 1
    kept = [k for k in tracks if k.misses <= (MISSES if k.id else 1)]
    new = [Track(xy[j], t) for j in np.flatnonzero(~used & clutter_ok)]
    if raw is not None:
        for k, j in zip(new, np.flatnonzero(~used & clutter_ok), strict=True):
            k.last = raw[j]
    return kept + new


# ----------------------------------------------------------------- bias estimation (optional)
def local_frame(lat_deg):
    """The stream's local frame (docs/protocol.md section 4.0) at the origin's latitude:
    the Gaussian radius R = √(M N) of WGS-84 there [m], and the earth's axis in the origin's
    east/north/up axes (true north at any antenna follows from it)."""
    phi = np.radians(lat_deg)
    e2 = WGS84_F * (2.0 - WGS84_F)
    w = 1.0 - e2 * np.sin(phi) ** 2
    radius = np.sqrt(WGS84_A * (1.0 - e2) / w**1.5 * WGS84_A / np.sqrt(w))
    return radius, np.array([0.0, np.cos(phi), np.sin(phi)])


def plot_to_local(r, az, antenna, h, frame):
    """Local east, north [m] (n, 2) of plots: slant range ``r`` [m] over the 4/3 earth and
    true-north azimuth ``az`` [rad] from antennas at local ``antenna`` (n, 3: east, north,
    up [m]), for targets at height ``h`` [m]: the great circle from the antenna along the
    azimuth, projected onto the tangent plane (the recipe of docs/protocol.md section 4.0).
    NaN where no target at that height is that close."""
    radius, axis = frame
    a = K_EARTH * radius
    r1, r2 = a + antenna[:, 2], a + h
    s2 = (r * r - (r2 - r1) ** 2) / (4.0 * r1 * r2)
    s2 = np.where((s2 >= 0.0) & (s2 <= 1.0), s2, np.nan)
    sigma = K_EARTH * 2.0 * np.arcsin(np.sqrt(s2))
    u_a = np.stack([antenna[:, 0], antenna[:, 1], np.full(len(r), radius)], axis=1)
    u_a /= np.linalg.norm(u_a, axis=1)[:, None]
    east = np.cross(axis, u_a)
    east /= np.linalg.norm(east, axis=1)[:, None]
    north = np.cross(u_a, east)
    way = np.cos(az)[:, None] * north + np.sin(az)[:, None] * east
    u_t = np.cos(sigma)[:, None] * u_a + np.sin(sigma)[:, None] * way
    return radius * u_t[:, :2] / u_t[:, 2:3]


def inverse_2x2(m):
    """Inverses of 2 x 2 matrices (n, 2, 2), in closed form."""
    det = m[:, 0, 0] * m[:, 1, 1] - m[:, 0, 1] * m[:, 1, 0]
    out = np.stack([m[:, 1, 1], -m[:, 0, 1], -m[:, 1, 0], m[:, 0, 0]], axis=1)
    return (out / det[:, None]).reshape(-1, 2, 2)


class BiasEstimator:
    """Least-squares registration of radars with overlapping coverage.

    Each pair joins a plot of radar B with a plot of radar A on the same target, carried to
    B's plot time by the track's velocity ``v``. With each radar's range and azimuth biases
    (Δr, Δθ) taken off its plots and the target at height H, both plots must name the same
    point of the local plane (the registration equations of Dana, *Registration: a
    prerequisite for multiple sensor tracking*, in Bar-Shalom (ed.), Multitarget-Multisensor
    Tracking, Artech House, 1990)::

        p(r_A − Δr_A, θ_A − Δθ_A, H) + v (t_B − t_A) − p(r_B − Δr_B, θ_B − Δθ_B, H) = 0

    with p the plot's position over the 4/3 earth in the stream's frame
    (:func:`plot_to_local`). A 2-D radar does not measure H: each target (each track of
    radar A) has its own, held constant, estimated with the biases (a weak prior about 0,
    σ_H 20 km); a height per pair instead would leave a bias common to both radars' ranges
    nearly unobservable (a higher target also lengthens both slant ranges). The biases of
    every radar are the least-squares solution over all pairs so far,
    weighted by each pair's covariance (the plots' σ through p, and the velocity error
    across the time gap): the generalised least squares of Zhou, Leung & Yip, *An exact
    maximum likelihood registration algorithm for data fusion*, IEEE Trans. Signal
    Processing 45(6), 1997 (there with the targets' positions as the nuisances), solved by
    Gauss-Newton, pairs beyond χ² 13.8 (2 degrees of freedom, 0.1 %) left out. Two radars'
    range and azimuth biases are observable from pairs at two geometries or more. Not
    estimated: range scale, time offsets (a clock error common to both is not observable
    between two radars), navigation errors.
    """

    def __init__(self, frame):
        self.frame = frame
        self.sensors = []
        self.rows = []  # per pair: ia, ib, A (r θ σr σθ e n u), B (same), v (2), dt, target,
        # kept
        self.height = {}  # per target its height [m]
        self.beta = np.zeros(0)
        self.cov = None
        self.inliers = 0

    def index(self, sensor):
        if sensor not in self.sensors:
            self.sensors.append(sensor)
            self.beta = np.append(self.beta, [0.0, 0.0])
        return self.sensors.index(sensor)

    def add(self, sensor_a, a, sensor_b, b, v, dt, target):
        """One pair: ``a`` and ``b`` (t, r, θ, σr, σθ, east, north, up of the antenna at the
        plot's time), ``v`` the target's velocity (east, north) [m/s], ``dt`` = t_B − t_A,
        ``target`` a number naming the target (the track's id: its pairs share a height)."""
        ia, ib = self.index(sensor_a), self.index(sensor_b)
        self.rows.append([ia, ib, *a[1:8], *b[1:8], *v, dt, float(target), 1.0])
        del self.rows[:-MAX_PAIRS]

    def _side(self, m, col, idx, beta, h):
        """One side's position (n, 2) and its derivatives along r, θ (the plot's) and H."""
        r = m[:, col] - beta[2 * idx]
        az = m[:, col + 1] - beta[2 * idx + 1]
        ant = m[:, col + 4:col + 7]
        p = plot_to_local(r, az, ant, h, self.frame)
        d_r = (plot_to_local(r + 1.0, az, ant, h, self.frame) - p) / 1.0
        d_az = (plot_to_local(r, az + 1e-6, ant, h, self.frame) - p) / 1e-6
        d_h = (plot_to_local(r, az, ant, h + 1.0, self.frame) - p) / 1.0
        return p, d_r, d_az, d_h

    def _model(self, m, h, beta):
        """Per pair: y (n, 2), ∂y/∂H (n, 2), ∂y/∂β (n, 2, P), covariance C (n, 2, 2)."""
        n = len(m)
        ia, ib = m[:, 0].astype(int), m[:, 1].astype(int)
        pa, ra, ta, ha = self._side(m, 2, ia, beta, h)
        pb, rb, tb, hb = self._side(m, 9, ib, beta, h)
        y = pa + m[:, 16:18] * m[:, 18:19] - pb
        jac = np.zeros((n, 2, beta.size))
        rows = np.arange(n)
        jac[rows, :, 2 * ia] = -ra
        jac[rows, :, 2 * ia + 1] = -ta
        jac[rows, :, 2 * ib] = rb
        jac[rows, :, 2 * ib + 1] = tb
        cov = ((SIGMA_VELOCITY_MPS * m[:, 18]) ** 2)[:, None, None] * np.eye(2)
        for d, s in ((ra, m[:, 4]), (ta, m[:, 5]), (rb, m[:, 11]), (tb, m[:, 12])):
            cov = cov + (s**2)[:, None, None] * d[:, :, None] * d[:, None, :]
        return y, ha - hb, jac, cov

    def _highest(self, m):
        """Per pair the highest target height both slant ranges allow (an elevation of 64°
        at most from either antenna), and ``HEIGHT_MAX_M`` [m]."""
        top = np.minimum(0.9 * m[:, 2] + m[:, 8], 0.9 * m[:, 9] + m[:, 15])
        return np.minimum(top, HEIGHT_MAX_M)

    def _initial_heights(self, m, grp, n_groups, beta):
        """Per target the height of a grid (every 200 m) that fits its pairs best."""
        grid = np.arange(0.0, HEIGHT_MAX_M + 1.0, 200.0)
        cost = np.zeros((n_groups, grid.size))
        top = self._highest(m)
        ia, ib = m[:, 0].astype(int), m[:, 1].astype(int)
        for i, h in enumerate(grid):
            hh = np.full(len(m), h)
            pa = plot_to_local(m[:, 2] - beta[2 * ia], m[:, 3] - beta[2 * ia + 1], m[:, 6:9],
                               hh, self.frame)
            pb = plot_to_local(m[:, 9] - beta[2 * ib], m[:, 10] - beta[2 * ib + 1],
                               m[:, 13:16], hh, self.frame)
            y = pa + m[:, 16:18] * m[:, 18:19] - pb
            c = np.where((h <= top) & np.isfinite(y).all(1), (y**2).sum(1), np.inf)
            np.add.at(cost[:, i], grp, c)
        return grid[np.argmin(cost, axis=1)]

    def solve(self, iterations=None):
        """Gauss-Newton over the pairs (class docstring), ``iterations`` steps (default 6
        from the last estimate, 8 before the first); updates ``beta``, ``cov`` (None until
        the biases are observable) and ``inliers``."""
        if not self.rows:
            return
        if iterations is None:
            iterations = 8 if self.cov is None else 6
        m = np.array(self.rows, float)
        keys, grp = np.unique(m[:, 19], return_inverse=True)
        n_t, p = keys.size, self.beta.size
        h = np.array([self.height.get(k, np.nan) for k in keys])
        new = np.isnan(h)
        if new.any():
            sel = new[grp]
            _, sub = np.unique(grp[sel], return_inverse=True)
            h[new] = self._initial_heights(m[sel], sub, int(new.sum()), self.beta)
        top = np.full(n_t, HEIGHT_MAX_M)
        np.minimum.at(top, grp, self._highest(m))
        beta = self.beta.copy()
        keep = m[:, 20] > 0  # the last solution's inliers, and the new pairs
        prior = np.diag(np.tile([1.0 / 1e3**2, 1.0 / 0.2**2], len(self.sensors)))
        normal = prior
        use = keep
        for it in range(iterations):
            y, dd, jac, cov = self._model(m, h[grp], beta)
            good = np.isfinite(y).all(1) & np.isfinite(dd).all(1) & np.isfinite(cov).all((1, 2))
            wgt = np.zeros_like(cov)
            wgt[good] = inverse_2x2(cov[good])
            if it >= iterations // 2:  # outliers, once the fit has settled (a pair may
                # come back); until then the last solution's inliers and the new pairs
                chi2 = np.einsum("ni,nij,nj->n", np.where(good[:, None], y, 0.0), wgt,
                                 np.where(good[:, None], y, 0.0))
                keep = good & (chi2 < CHI2_OUTLIER)
            use = good & keep
            g, e, a, w, k = jac[use], -y[use], dd[use], wgt[use], grp[use]
            gt = g.transpose(0, 2, 1)
            wa = (w @ a[:, :, None])[:, :, 0]  # (n, 2)
            # the normal equations of (β, H): [[Nββ, Cᵀ], [C, D]], D diagonal (one height per
            # target), the heights eliminated (Schur complement): a P x P system
            cross = np.zeros((n_t, p))
            np.add.at(cross, k, (gt @ wa[:, :, None])[:, :, 0])
            diag = np.full(n_t, 1.0 / SIGMA_HEIGHT_M**2)
            np.add.at(diag, k, (a * wa).sum(1))
            rhs_h = -h / SIGMA_HEIGHT_M**2
            np.add.at(rhs_h, k, (wa * e).sum(1))
            normal = prior + (gt @ w @ g).sum(0) - cross.T @ (cross / diag[:, None])
            rhs = ((gt @ (w @ e[:, :, None]))[:, :, 0].sum(0) - prior @ beta
                   - cross.T @ (rhs_h / diag))
            step = np.linalg.solve(normal, rhs)
            beta = beta + step
            h = np.clip(h + (rhs_h - cross @ step) / diag, 0.0, top)
        m[:, 20] = use
        self.rows = m.tolist()
        self.height = dict(zip(keys.tolist(), h.tolist(), strict=True))
        self.beta = beta
        self.inliers = int(use.sum())
        cov = np.linalg.inv(normal)  # the heights marginalised (Schur complement)
        sig = np.sqrt(np.diag(cov))
        ok = (self.inliers >= MIN_PAIRS and np.all(sig[0::2] < MAX_SIGMA_RANGE_M)
              and np.all(sig[1::2] < MAX_SIGMA_AZIMUTH_RAD))
        self.cov = cov if ok else None

    def correction(self, sensor):
        """(range bias [m], azimuth bias [rad]) to subtract from ``sensor``'s plots; zeros
        until the estimate is published."""
        if self.cov is None or sensor not in self.sensors:
            return 0.0, 0.0
        i = self.sensors.index(sensor)
        return float(self.beta[2 * i]), float(self.beta[2 * i + 1])

    def messages(self, t):
        """The ``registration`` messages at ``t`` [s] (none before the first estimate)."""
        if self.cov is None:
            return []
        out = []
        for i, sensor in enumerate(self.sensors):
            body = {"v": 1, "t": float(t), "sensor": sensor, "time_s": float(t),
                    "source": "tracker_template least squares",
                    "range_bias_m": float(self.beta[2 * i]),
                    "azimuth_bias_rad": float(self.beta[2 * i + 1]),
                    "sigma_range_bias_m": float(np.sqrt(self.cov[2 * i, 2 * i])),
                    "sigma_azimuth_bias_rad": float(np.sqrt(self.cov[2 * i + 1, 2 * i + 1]))}
            out.append([b"registration", msgpack.packb(body)])
        return out


def pair_plots(estimator, sensor_a, tracks, sensor_b, plots_b, scan_a_s):
    """Pair each plot of radar B with the confirmed track of radar A nearest to it at its
    time (within ``PAIR_GATE_M``, the next track ``PAIR_AMBIGUITY`` times farther), whose
    last plot is less than a scan of A away; each track once. ``plots_b``: rows (t, r, θ,
    σr, σθ, east, north, up)."""
    cand = [k for k in tracks if k.id and k.moving and k.last is not None]
    if not cand or not len(plots_b):
        return 0
    ra, aa = estimator.correction(sensor_a)
    rb, ab = estimator.correction(sensor_b)
    rb, ab = estimator.correction(sensor_b)
    used, n = set(), 0
    for row in plots_b:
        t = row[0]
        xb = row[5:7] + (row[1] - rb) * np.array([np.sin(row[2] - ab), np.cos(row[2] - ab)])
        d = np.array([np.hypot(*(k.predict(t) - xb)) for k in cand])
        order = np.argsort(d)
        j = order[0]
        if d[j] > PAIR_GATE_M or (d.size > 1 and d[order[1]] < PAIR_AMBIGUITY * d[j]):
            continue
        k = cand[j]
        if j in used or abs(t - k.last[0]) > scan_a_s:
            continue
        used.add(j)
        estimator.add(sensor_a, k.last, sensor_b, row, k.x[2:], t - k.last[0], k.id)
        n += 1
    return n


def antenna_at(t, prev, cur):
    """Antenna (east, north, up) at times ``t``, linear between the scan's start ``prev``
    and end ``cur`` (each (time, east, north, up))."""
    if prev is None or cur[0] <= prev[0]:
        return np.tile(cur[1:], (len(t), 1))
    f = ((t - prev[0]) / (cur[0] - prev[0]))[:, None]
    return np.array(prev[1:]) + f * (np.array(cur[1:]) - np.array(prev[1:]))


def scan_plots(pending, prev, cur):
    """A scan's plots as rows (t, r, θ, σr, σθ, east, north, up of the antenna then)."""
    rows = np.concatenate(pending, axis=1).T if pending else np.zeros((0, 5))
    return np.concatenate([rows, antenna_at(rows[:, 0], prev, cur)], axis=1)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("plots", help="shipradar stream endpoint to subscribe to")
    ap.add_argument("tracks", help="endpoint to bind and publish the tracks topic on")
    ap.add_argument("--estimate-bias", action="store_true",
                    help="estimate the radars' range and azimuth biases from the plots of "
                         "common targets, correct the tracked radar's plots, publish the "
                         "estimates on the registration topic")
    a = ap.parse_args(argv)
    ctx = zmq.Context()
    pub = ctx.socket(zmq.PUB)
    pub.bind(a.tracks)
    sub = ctx.socket(zmq.SUB)
    sub.connect(a.plots)
    for topic in (b"meta", b"plots", b"eos"):
        sub.setsockopt(zmq.SUBSCRIBE, topic)
    sensor, r_max, scan_s, solved_t = None, 0.0, 0.0, -np.inf
    pending = {}  # per radar its scan's plots: (time, range, azimuth, σ range, σ azimuth)
    last_eos = {}  # per radar its last end of scan: (time, east, north, up)
    estimator = None
    tracks, ring_counts, scans = [], None, 0
    while sub.poll(30_000):  # the stream has no end message: stop after 30 s of silence
        topic, body = sub.recv_multipart()
        msg = decode_body(body)
        if topic == b"meta" and sensor is None:
            sensor, r_max = msg["sensor"], float(msg["radar"]["instrumented_range_m"])
            scan_s = float(msg["scan_period_s"])
            ring_counts = np.zeros(int(r_max // RING_M) + 2)
            if a.estimate_bias:
                estimator = BiasEstimator(local_frame(float(msg["origin"]["lat_deg"])))
        if sensor is None or (msg.get("sensor") != sensor and estimator is None):
            continue
        s = msg.get("sensor")
        if topic == b"plots":
            pending.setdefault(s, []).append(np.stack([
                msg["time_s"], msg["range_m"], msg["azimuth_rad"], msg["sigma_range_m"],
                msg["sigma_azimuth_rad"]]))
        elif topic == b"eos":
            p = msg["position"]
            t = float(msg["time_s"])
            eos = (t, float(p["east_m"]), float(p["north_m"]), float(p["up_m"]))
            rows = scan_plots(pending.pop(s, []), last_eos.get(s), eos)
            last_eos[s] = eos
            if s != sensor:  # another radar: its plots paired with the tracked radar's
                pair_plots(estimator, sensor, tracks, s, rows, scan_s)
                continue
            ship = np.array(eos[1:3])
            rb, ab = estimator.correction(sensor) if estimator is not None else (0.0, 0.0)
            rng, az = rows[:, 1] - rb, rows[:, 2] - ab
            xy = ship + np.stack([rng * np.sin(az), rng * np.cos(az)], axis=-1)
            ring = np.clip((rng // RING_M).astype(int), 0, ring_counts.size - 1)
            ring_counts += np.bincount(ring, minlength=ring_counts.size)
            scans += 1
            area_km2 = np.pi * ((ring + 1) ** 2 - ring**2) * (RING_M / 1e3) ** 2
            clutter_ok = ((ring_counts[ring] / scans / area_km2 <= MAX_INIT_DENSITY)
                          & (scans > LEARN_SCANS))
            tracks = step(tracks, xy, t, clutter_ok, raw=rows if estimator else None)
            confirmed = [k for k in tracks if k.id]
            out = []
            for k in confirmed:  # predicted to the end of scan
                c = Track.__new__(Track)
                c.id, c.sigma = k.id, k.sigma
                c.x = np.concatenate([k.predict(t), k.x[2:]])
                out.append(c)
            if estimator is not None:  # before the tracks: the harness waits on those
                if t >= solved_t + SOLVE_EVERY_S:
                    estimator.solve()
                    solved_t = t
                for frames in estimator.messages(t):
                    pub.send_multipart(frames)
            pub.send_multipart(encode_tracks(sensor, msg["scan"], t, out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
