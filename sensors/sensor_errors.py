"""Imperfect sensors (issue 33): registration biases, clock errors, reporting latency and
navigation errors, each drawn from its own random stream.

The seed (DREV-R-9429) describes a perfectly registered radar; its measurement noise
([84]-[89], :mod:`shipradar.sensors.measurement`) is the only error of a plot.  Fusion studies
need the others (a north misalignment, a range-zero error, a late clock, a ship whose
navigation is off): this module adds them on top of the seed's noise, with the sign
convention error = reported − true (docs/protocol.md, ``truth[sensors]``).

Each bias is a constant plus, optionally, a first-order Gauss-Markov process of stationary
standard deviation σ and correlation time T, sampled on a regular grid Δt with the exact
discretisation (Maybeck, *Stochastic Models, Estimation and Control*, vol. 1, 1979,
section 4.10; Gelb, *Applied Optimal Estimation*, 1974, table 3.8-1)

    x_{k+1} = e^{−Δt/T} x_k + σ √(1 − e^{−2Δt/T}) w_k,   w_k ~ N(0, 1),

started in its stationary distribution x_0 ~ N(0, σ²), so that every sample has variance σ²
and the autocorrelation at lag τ = m Δt is σ² e^{−τ/T} whatever Δt.  The value is held over
each grid step ((k Δt, (k + 1) Δt] carries x_k).

Every error draws from its own stream, a :class:`numpy.random.SeedSequence` of the run's seed
with a spawn key made of the owner's id (radar or platform) and the error's name
(:func:`error_stream`): enabling one error, or changing its σ, changes no other draw, neither
another error's nor the radar's own noise and false alarms (which use the radar's stream
spawned by index, a key of another length).
"""

from __future__ import annotations

import math
import zlib

import numpy as np
from scipy.signal import lfilter

from shipradar.sim.world.scenario import ErrorTerm, Navigation, SensorErrors

__all__ = [
    "GaussMarkov",
    "RadarErrors",
    "error_stream",
    "gauss_markov_path",
]

#: First element of every error stream's spawn key (issue 33): sets them apart from any
#: stream spawned by index.
_STREAM_TAG = 0x33E0
#: Grid steps a Gauss-Markov path is extended by at least, at once.
_CHUNK = 4096
#: Latencies drawn at once.
_LATENCY_CHUNK = 256
_TWO_PI = 2.0 * math.pi


def error_stream(seed: int, owner: str, error: str) -> np.random.Generator:
    """The random stream of one error: the run's ``seed`` with the spawn key (tag,
    CRC-32 of the ``owner``'s id, CRC-32 of the ``error``'s name), stable whatever the
    scenario's order or other errors."""
    key = (_STREAM_TAG, zlib.crc32(owner.encode()), zlib.crc32(error.encode()))
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=key))


def gauss_markov_path(x0: float, n: int, dt_s: float, sigma: float, tau_s: float,
                      rng: np.random.Generator) -> np.ndarray:
    """The next ``n`` samples x_1 ... x_n of a first-order Gauss-Markov process after x_0 =
    ``x0``, on a grid of ``dt_s`` [s], stationary 1σ ``sigma`` and correlation time
    ``tau_s`` [s] (exact discretisation, module docstring); ``n`` standard normal draws from
    ``rng``.  ``sigma`` = 0 gives zeros (and draws nothing)."""
    if sigma == 0.0 or n == 0:
        return np.zeros(n)
    a = math.exp(-dt_s / tau_s)
    b = sigma * math.sqrt(-math.expm1(-2.0 * dt_s / tau_s))
    w = rng.standard_normal(n)
    out, _ = lfilter([b], [1.0, -a], w, zi=[a * x0])
    return np.asarray(out, dtype=float)


class GaussMarkov:
    """One error (:class:`shipradar.sim.world.scenario.ErrorTerm`, scaled to SI by
    ``scale``) on a grid of ``dt_s`` [s]: its value at any time, the Gauss-Markov path drawn
    from ``rng`` as far as asked and forgotten behind (:meth:`forget_before`)."""

    def __init__(self, term: ErrorTerm, dt_s: float, rng: np.random.Generator,
                 scale: float = 1.0):
        self.mean = term.mean * scale
        self.sigma = term.sigma * scale
        self.tau_s = term.correlation_time_s
        self.dt_s = dt_s
        self.rng = rng
        self._k0 = 0  # grid index of _path[0]
        self._path = np.zeros(0)

    def index(self, t: np.ndarray | float) -> np.ndarray:
        """Grid step holding time ``t`` [s]: (k Δt, (k + 1) Δt] is step k (0 at and before
        the start)."""
        k = np.maximum(np.ceil(np.asarray(t, dtype=float) / self.dt_s) - 1, 0)
        return np.asarray(k, dtype=np.int64)

    def _extend(self, k_max: int) -> None:
        need = k_max + 1 - (self._k0 + self._path.size)
        if need <= 0:
            return
        if self._path.size == 0 and self._k0 == 0:  # x_0 from the stationary distribution
            first = self.sigma * float(self.rng.standard_normal()) if self.sigma else 0.0
            self._path = np.array([first])
            need -= 1
        if need > 0:
            more = gauss_markov_path(float(self._path[-1]), max(need, _CHUNK), self.dt_s,
                                     self.sigma, self.tau_s, self.rng)
            self._path = np.concatenate([self._path, more])

    def at_index(self, k: np.ndarray) -> np.ndarray:
        """The error at grid steps ``k`` (not before :meth:`forget_before`'s)."""
        k = np.asarray(k, dtype=np.int64)
        if self.sigma == 0.0:
            return np.full(k.shape, self.mean)
        if not k.size:
            return np.zeros(k.shape)
        self._extend(int(k.max()))
        rel = k - self._k0
        if rel.min() < 0:  # a negative index would wrap round, silently
            raise ValueError(f"grid step {int(k.min())} was forgotten (from {self._k0} on)")
        return np.asarray(self.mean + self._path[rel])

    def at(self, t: np.ndarray | float) -> np.ndarray:
        """The error at times ``t`` [s]."""
        if self.sigma == 0.0:
            return np.full(np.shape(t), self.mean)
        return self.at_index(self.index(t))

    def add_to(self, x: np.ndarray, k: np.ndarray) -> np.ndarray:
        """``x`` + the error at grid steps ``k`` (a constant added as a scalar)."""
        if self.sigma == 0.0:
            return np.asarray(x + self.mean) if self.mean else x
        return np.asarray(x + self.at_index(k))

    def forget_before(self, t: float) -> None:
        """Drop the path before the step holding ``t`` [s] (it is never asked again)."""
        if self.sigma == 0.0:
            return
        k = int(self.index(t))
        self._extend(k)
        drop = k - self._k0
        if drop > 0:
            self._path = self._path[drop:]
            self._k0 = k


class RadarErrors:
    """The errors of one radar (``errors``) and of its platform's navigation
    (``navigation``), for the engine: applied to its plots (:meth:`apply`), to its antenna
    state in ``meta`` and ``eos`` (:meth:`navigation_offset`, :meth:`heading_bias_rad`),
    reported in ``truth[sensors]`` (:meth:`values`), and the latency of its messages
    (:meth:`latencies_s`).

    The radar's errors are held per sector (``sector_s`` [s]); the navigation's per
    ``navigation.update_s``, keyed by the platform's id so that every radar on a ship sees
    the same realisation.
    """

    def __init__(self, errors: SensorErrors, navigation: Navigation, *, seed: int,
                 radar_id: str, platform_id: str, sector_s: float):
        self.config = errors
        self.navigation = navigation

        def own(name: str, term: ErrorTerm, scale: float = 1.0) -> GaussMarkov:
            return GaussMarkov(term, sector_s, error_stream(seed, radar_id, name), scale)

        def nav(name: str, term: ErrorTerm, scale: float = 1.0) -> GaussMarkov:
            return GaussMarkov(term, navigation.update_s, error_stream(seed, platform_id, name),
                               scale)

        self.range_bias = own("range_bias_m", errors.range_bias_m)
        self.range_scale = own("range_scale_ppm", errors.range_scale_ppm)
        self.azimuth_bias = own("azimuth_bias_deg", errors.azimuth_bias_deg, math.pi / 180.0)
        self.time_offset = own("time_offset_s", errors.time_offset_s)
        self.nav_east = nav("east_error_m", navigation.east_error_m)
        self.nav_north = nav("north_error_m", navigation.north_error_m)
        self.nav_up = nav("up_error_m", navigation.up_error_m)
        self.heading_bias = nav("heading_bias_deg", navigation.heading_bias_deg,
                                math.pi / 180.0)
        self._processes = (self.range_bias, self.range_scale, self.azimuth_bias,
                           self.time_offset, self.nav_east, self.nav_north, self.nav_up,
                           self.heading_bias)
        self.jitter_s = errors.time_jitter_s
        self._jitter_rng = error_stream(seed, radar_id, "time_jitter_s")
        latency = errors.latency
        self.latency_fixed_s = latency.fixed_s
        self.latency_mean_s = latency.random_mean_s
        self._latency_rng = error_stream(seed, radar_id, "latency")
        self._latencies = np.zeros(0)  # drawn ahead, a chunk at a time
        #: the plots change (some error other than navigation position or latency)
        self.touches_plots = not (errors.range_bias_m.is_zero and errors.range_scale_ppm.is_zero
                                  and errors.azimuth_bias_deg.is_zero
                                  and errors.time_offset_s.is_zero and errors.time_jitter_s == 0
                                  and navigation.heading_bias_deg.is_zero)
        self.navigates = not navigation.is_zero
        self.has_latency = not latency.is_zero

    def apply(self, plots: dict[str, np.ndarray]) -> None:
        """The errors on a block of ``plots`` (columns ``range_m``, ``azimuth_rad``,
        ``time_s``, in place), each plot's errors those of its true time ``time_s``:
        range × (1 + scale 10⁻⁶) + bias (not below 0), azimuth + alignment + heading bias
        (wrapped into [0, 2π)), time + offset + Gaussian jitter (one draw per plot)."""
        if not self.touches_plots:
            return
        t = plots["time_s"]
        if not t.size:
            return
        k = self.range_bias.index(t)  # every radar error is on the sector grid
        k_nav = self.heading_bias.index(t) if self.heading_bias.sigma else k
        r = plots["range_m"]
        scale = self.range_scale
        if scale.sigma or scale.mean:
            r = r * (1.0 + 1e-6 * scale.at_index(k))
        plots["range_m"] = np.maximum(self.range_bias.add_to(r, k), 0.0)
        az = self.heading_bias.add_to(self.azimuth_bias.add_to(plots["azimuth_rad"], k), k_nav)
        plots["azimuth_rad"] = np.mod(az, _TWO_PI)
        stamp = self.time_offset.add_to(t, k)
        if self.jitter_s:
            stamp = stamp + self.jitter_s * self._jitter_rng.standard_normal(t.size)
        plots["time_s"] = stamp

    def navigation_offset(self, t: np.ndarray) -> np.ndarray:
        """The navigation's position error east, north, up at times ``t`` (n,) [s]: (n, 3)
        [m]."""
        return np.stack([self.nav_east.at(t), self.nav_north.at(t), self.nav_up.at(t)],
                        axis=-1)

    def heading_bias_rad(self, t: np.ndarray | float) -> np.ndarray:
        """The gyro's heading bias at times ``t`` [rad]."""
        return self.heading_bias.at(t)

    def values(self, t: np.ndarray) -> dict[str, list[float]]:
        """Every error at times ``t`` (n,) [s], by its ``truth[sensors]`` key."""
        return {"range_bias_m": self.range_bias.at(t).tolist(),
                "range_scale_ppm": self.range_scale.at(t).tolist(),
                "azimuth_bias_rad": self.azimuth_bias.at(t).tolist(),
                "time_offset_s": self.time_offset.at(t).tolist(),
                "heading_bias_rad": self.heading_bias.at(t).tolist(),
                "nav_east_error_m": self.nav_east.at(t).tolist(),
                "nav_north_error_m": self.nav_north.at(t).tolist(),
                "nav_up_error_m": self.nav_up.at(t).tolist()}

    def latencies_s(self, n: int) -> np.ndarray:
        """The latencies of the next ``n`` sector messages [s]: the fixed delay plus one
        exponential draw of the stated mean each (drawn a chunk at a time: the same values
        however many are asked at once)."""
        if self.latency_mean_s == 0.0:
            return np.full(n, self.latency_fixed_s)
        have = self._latencies
        if have.size < n:
            chunks = -(-(n - have.size) // _LATENCY_CHUNK)
            more = self._latency_rng.exponential(self.latency_mean_s, chunks * _LATENCY_CHUNK)
            have = np.concatenate([have, self.latency_fixed_s + more])
        out, self._latencies = have[:n], have[n:]
        return out

    def forget_before(self, t: float) -> None:
        """The errors before ``t`` [s] are never asked again (a new block of revolutions)."""
        for p in self._processes:
            p.forget_before(t)
