"""The false alarms of one radar (seed chapter 7, on-line): noise [90]-[93] and sea clutter
[94]-[96], their plot columns and the expected clutter density ``meta`` publishes.

One :class:`FalseAlarmModel` per :class:`shipradar.sim.dwell.model.DwellModel` (its
``false_alarms``), reading the radar's constants (P_fa, N_n, the resolution cell, the Doppler
bank and its reference) from it. What a run sets up from the radar and its tables alone (the
P_fac map's generator, the clutter spectrum at its sectors, the density) is kept by the
model's :class:`shipradar.sim.dwell.prepared.PreparedRadar`, which the runs of a study on the
same tables share.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from shipradar.sensors import false_alarms, geometry, measurement, sea_clutter
from shipradar.sensors import plot_columns as pc
from shipradar.sensors.detection import Interference
from shipradar.sensors.noise import db
from shipradar.sim.world.scenario import Radar

if TYPE_CHECKING:
    from shipradar.tables.scene import RadarTables

#: (reference, spread) [Hz] of the Doppler bank at the P_fac map's sectors.
Spectrum = tuple[np.ndarray, np.ndarray]


class SharedSetUp(Protocol):
    """What the false alarms read of their radar's preparation
    (:class:`shipradar.sim.dwell.prepared.PreparedRadar`; a protocol: it imports this
    module)."""

    @property
    def clutter_generator(self) -> false_alarms.ClutterFalseAlarms | None: ...

    def clutter_false_alarm_density(self, ring_m: float, azimuth_sectors: int
                                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None: ...

    def sector_spectrum(self, spectrum_reference: Callable[[np.ndarray, np.ndarray], Spectrum]
                        ) -> Spectrum: ...



class DwellConstants(Protocol):
    """What the false alarms read of their radar's
    :class:`shipradar.sim.dwell.model.DwellModel` (a protocol: the model imports this
    module)."""

    radar: Radar
    tables: RadarTables

    @property
    def prepared(self) -> SharedSetUp: ...
    pfa: float
    n_pulses: float
    range_cell: float
    theta_b: float
    wavelength: float
    noise_false_alarms_per_scan: float
    compensation: tuple[float, float] | None

    @property
    def has_doppler_bank(self) -> bool: ...

    @property
    def n_doppler_filters(self) -> int: ...

    @property
    def range_rate_sigma_mps(self) -> float: ...

    def range_rate_from_filter(self, filter_index: Any, reference_hz: Any) -> np.ndarray: ...

    def reference_mps(self, reference_hz: Any) -> np.ndarray: ...

    def spectrum_reference(self, range_m: Any, azimuth_rad: Any
                           ) -> tuple[np.ndarray, np.ndarray]: ...

    def doppler_filter(self, doppler_hz: Any) -> np.ndarray: ...


class FalseAlarmModel:
    """Noise and sea-clutter false alarms of the radar of one
    :class:`shipradar.sim.dwell.model.DwellModel`."""

    def __init__(self, dwell: DwellConstants) -> None:
        self.dwell = dwell
        # the false alarms' Doppler draws: a child of the radar's generator, spawned at the
        # first draw so that the parent's stream, hence every other draw, is unchanged
        self._doppler_rng: np.random.Generator | None = None

    def _doppler_draw_rng(self, rng: np.random.Generator) -> np.random.Generator:
        """A child of the radar's generator for the false alarms' Doppler draws (spawned
        once: the parent's stream, hence every other draw, is unchanged)."""
        if self._doppler_rng is None:
            self._doppler_rng = rng.spawn(1)[0]
        return self._doppler_rng

    def _false_alarm_range_rate(self, range_m: Any, azimuth_rad: Any,
                                rng: np.random.Generator, clutter: bool,
                                spectrum: tuple[np.ndarray, np.ndarray] | None = None
                                ) -> dict[str, np.ndarray]:
        """Range-rate columns of false alarms: the filter of a noise alarm is uniform over the
        bank; a sea-clutter alarm's Doppler is drawn from the clutter spectrum [33] (Gaussian
        about μ_c with σ_s), then reported as a target's would be.  The bank's reference and
        the spread are read from the clutter map at each alarm's cell, or given as
        ``spectrum`` (reference, spread) (the sea-clutter alarms: their P_fac sector's, see
        :attr:`sector_spectrum`)."""
        n = np.size(range_m)
        if not self.dwell.has_doppler_bank or n == 0:
            nan = np.full(n, np.nan)
            return {pc.RANGE_RATE_MPS: nan, pc.SIGMA_RANGE_RATE_MPS: nan.copy(),
                    pc.RANGE_RATE_REFERENCE_MPS: nan.copy()}
        draw = self._doppler_draw_rng(rng)
        if spectrum is not None:
            reference, spread = spectrum
        else:
            reference, spread = self.dwell.spectrum_reference(np.asarray(range_m),
                                                         np.asarray(azimuth_rad))
        if clutter:
            # standard_normal: normal(0, 1)'s draws (0 + 1 z is z, but for the sign of a zero,
            # which no filter index sees), without its loc + scale z per element
            doppler = draw.standard_normal(n)
            doppler *= spread
            index = self.dwell.doppler_filter(doppler)
        else:
            index = draw.integers(0, self.dwell.n_doppler_filters, n)
        return {pc.RANGE_RATE_MPS: self.dwell.range_rate_from_filter(index, reference),
                pc.SIGMA_RANGE_RATE_MPS: np.full(n, self.dwell.range_rate_sigma_mps),
                pc.RANGE_RATE_REFERENCE_MPS: np.broadcast_to(
                    self.dwell.reference_mps(reference), (n,)).copy()}

    @functools.cached_property
    def generator(self) -> false_alarms.ClutterFalseAlarms | None:
        """The P_fac map's per-scan generator
        (:func:`shipradar.tables.pfac.clutter_false_alarm_generator`), made at its first use; None
        without a P_fac map (each run a twin of its preparation's,
        :attr:`shipradar.sim.dwell.prepared.PreparedRadar.clutter_generator`)."""
        template = self.dwell.prepared.clutter_generator
        return None if template is None else template.shared()

    def clutter_false_alarm_density(self, ring_m: float = 250.0, azimuth_sectors: int = 36
                                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Expected sea-clutter false alarms per scan in each slant-range ring and azimuth
        sector, as the plots report them (seed 7.2, the generator's own sectors).

        The generator (:class:`shipradar.sensors.false_alarms.ClutterFalseAlarms`) draws each
        P_fac sector's η = P_fac × cells alarms uniform in ground range and azimuth inside
        it, and reports the slant range of the sea point (the antenna height over the k-earth,
        :func:`shipradar.sensors.sea_clutter.slant_range_m`) and the azimuth, with no noise
        added. So each sector's η splits between the cells in proportion to its overlap in
        ground range (the ring's slant edges mapped to ground range by the inverse of
        ``slant_range_m``) and in azimuth: the cell values are exact expectations.

        Parameters
        ----------
        ring_m : float, optional
            Ring width in slant range [m], > 0; rings start at 0 and end at the last holding
            any.
        azimuth_sectors : int, optional
            Azimuth sectors, equal, from true north (36: 10° each; a P_fac map's own 1°
            sectors would make the ``meta`` message ten times larger for a wind dependence
            that is smooth over tens of degrees).

        Returns
        -------
        (range_edges_m, azimuth_edges_rad, per_scan) or None
            Ring edges in slant range [m] (r + 1), sector edges [rad] (a + 1, from 0 to 2π),
            the expected count per scan in
            each cell (r, a) [-], summing to the generator's η total. None without a P_fac
            map.
        """
        if self.dwell.tables.pfac is None:
            return None
        if not ring_m > 0.0 or azimuth_sectors < 1:
            raise ValueError("ring_m must be > 0 and azimuth_sectors >= 1")
        return self.dwell.prepared.clutter_false_alarm_density(ring_m, int(azimuth_sectors))

    @functools.cached_property
    def sector_spectrum(self) -> Spectrum:
        """(reference, spread) [Hz] of
        :meth:`shipradar.sim.dwell.model.DwellModel.spectrum_reference` at the centre of every
        active P_fac sector, for the sea-clutter false alarms' Doppler: the P_fac sector is
        the resolution of the clutter false-alarm model (count, position bounds and spike
        S/I are the sector's), and the spectrum changes little across one."""
        return self.dwell.prepared.sector_spectrum(self.dwell.spectrum_reference)

    def noise_false_alarms(self, rng: np.random.Generator, revolutions: int | None = None
                           ) -> dict:
        """Noise-induced false alarms [90]-[93]: count, uniform R and θ.  One revolution's,
        or with ``revolutions`` those of that many revolutions drawn together (every count
        first, then all ranges and all azimuths) with the ``revolution`` index of each."""
        per_scan, channels = self.dwell.noise_false_alarms_per_scan, self.dwell.radar.n_channels
        r_max = self.dwell.radar.instrumented_range_m
        if revolutions is None:
            count = int(false_alarms.false_alarm_count(per_scan, channels, rng))
            r, az = false_alarms.uniform_positions(count, 0.0, r_max, 0.0, 2.0 * math.pi, rng)
            return {pc.RANGE_M: np.asarray(r, dtype=float),
                    pc.AZIMUTH_RAD: np.asarray(az, dtype=float)}
        counts = false_alarms.false_alarm_count(per_scan, channels, rng, size=revolutions)
        r, az = false_alarms.uniform_positions(counts, 0.0, r_max, 0.0, 2.0 * math.pi, rng)
        return {pc.RANGE_M: np.asarray(r, dtype=float),
                pc.AZIMUTH_RAD: np.asarray(az, dtype=float),
                "revolution": np.repeat(np.arange(revolutions), counts)}

    def false_alarm_plots(self, range_m: np.ndarray, azimuth_rad: np.ndarray,
                          time_s: np.ndarray, rng: np.random.Generator
                          ) -> dict[str, np.ndarray]:
        """Plot columns for noise false alarms at the given positions and times.

        The reported S/I is drawn consistently with a threshold crossing: the integrated
        square-law noise statistic of N_n pulses is Gamma(N_n, 1); conditioned on exceeding
        the P_fa threshold it is drawn by inverse CDF in the tail, and reported as the
        per-pulse excess over the mean noise.
        """
        from scipy.special import gammainccinv

        n = range_m.size
        u = rng.random(n)
        x = gammainccinv(self.dwell.n_pulses, self.dwell.pfa * u)
        si = np.maximum(x / self.dwell.n_pulses - 1.0, 1e-3)
        n_e = np.full(n, self.dwell.n_pulses)
        errs = measurement.expected_errors(si, n_e, self.dwell.range_cell, self.dwell.theta_b,
                                           h_range=self.dwell.radar.h_range,
                                           h_azimuth=self.dwell.radar.h_azimuth)
        return {
            pc.TIME_S: time_s,
            pc.RANGE_M: range_m,
            pc.AZIMUTH_RAD: azimuth_rad,
            pc.SNR_DB: db(si),
            pc.SIGMA_RANGE_M: errs[0] / measurement.SIGMAS_PER_ERROR,
            pc.SIGMA_AZIMUTH_RAD: errs[1] / measurement.SIGMAS_PER_ERROR,
            pc.INTERFERENCE: np.full(n, Interference.NOISE, dtype=np.uint8),
            **self._false_alarm_range_rate(range_m, azimuth_rad, rng, clutter=False),
        }

    def clutter_false_alarms(self, t_a: Any, t_b: Any, beam_start: Any, omega: float,
                             rng: np.random.Generator) -> dict[str, np.ndarray] | None:
        """Sea-clutter-induced false alarms of one revolution [t_a, t_b) (seed 7.2, [94]-[96]),
        or of several drawn together when ``t_a``, ``t_b`` and ``beam_start`` are arrays (one
        element per revolution; the plots then carry their ``revolution`` index).

        Per P_fac-map sector: a count by [91]-[93] from η = P_fac × cells, uniform positions,
        times when the beam (at ``beam_start`` [rad] at t_a, ``omega`` [rad/s]) sweeps them
        (:class:`shipradar.sensors.false_alarms.ClutterFalseAlarms`).  None without a P_fac map.
        """
        gen = self.generator
        if gen is None:
            return None
        many = np.ndim(t_a) > 0
        out = (gen.scans if many else gen.scan)(t_a, t_b, beam_start, omega, rng)
        if out is not None:
            spectrum = None
            if self.dwell.has_doppler_bank:
                reference, spread = self.sector_spectrum
                spectrum = (reference.take(out["sector"]), spread.take(out["sector"]))
            out.update(self._false_alarm_range_rate(out[pc.RANGE_M], out[pc.AZIMUTH_RAD], rng,
                                                    clutter=True, spectrum=spectrum))
        return out


def clutter_false_alarm_density(gen: false_alarms.ClutterFalseAlarms, ring_m: float, n_az: int
                                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:meth:`FalseAlarmModel.clutter_false_alarm_density` of the generator ``gen``, in rings
    of ``ring_m`` [m] and ``n_az`` azimuth sectors, computed."""
    az_edges = np.linspace(0.0, 2.0 * math.pi, n_az + 1)
    if gen.eta.size == 0:
        return np.zeros(1), az_edges, np.zeros((0, n_az))
    h, a_e = gen.antenna_height_m, gen.k_factor * geometry.EARTH_RADIUS_M
    r_top = float(sea_clutter.slant_range_m(gen.r_max_m.max(), h, gen.k_factor))
    edges = ring_m * np.arange(int(math.ceil(r_top / ring_m)) + 1, dtype=float)
    # slant R -> ground d: R² = h² + 4 a_e (a_e + h) sin²(d / 2 a_e), inverted
    s2 = np.clip((edges**2 - h * h) / (4.0 * a_e * (a_e + h)), 0.0, 1.0)
    g_edges = 2.0 * a_e * np.arcsin(np.sqrt(s2))
    frac_r = _overlap_fraction(g_edges, gen.r_min_m, gen.r_max_m)
    # azimuth intervals may pass 2π (az_max ≤ az_min + 2π): the bins shifted by ±2π too
    frac_az = np.add.reduce([_overlap_fraction(az_edges + shift, gen.az_min_rad,
                                               gen.az_max_rad)
                             for shift in (-2.0 * math.pi, 0.0, 2.0 * math.pi)])
    per_scan = sum_over_sectors(frac_r * gen.eta, frac_az)
    last = np.flatnonzero(per_scan.sum(axis=1) > 0.0)
    n = 0 if last.size == 0 else int(last[-1]) + 1
    return edges[:n + 1], az_edges, per_scan[:n]


def sum_over_sectors(by_ring: np.ndarray, by_azimuth: np.ndarray) -> np.ndarray:
    """``by_ring @ by_azimuth.T`` (rings × sectors, azimuth cells × sectors -> rings × cells)
    in a fixed order, without BLAS: a sector overlaps one or two azimuth cells, so each cell
    sums the columns of its own sectors, in sector order (``np.add.reduceat``).

    A BLAS product's bits depend on its thread count (OpenBLAS splits the sum differently
    with one thread than with two): the ``meta`` message's density, hence the recording,
    differed between machines and between a run and a Dask worker (one thread). This sum is
    the same on every machine, and ~100 times faster for a P_fac map of 11,608 sectors.
    """
    n_cells = by_azimuth.shape[0]
    cell, sector = np.nonzero(by_azimuth)  # row-major: by cell, then by sector
    terms = by_ring[:, sector] * by_azimuth[cell, sector]
    out = np.zeros((by_ring.shape[0], n_cells))
    cells, first = np.unique(cell, return_index=True)
    if cells.size:
        out[:, cells] = np.add.reduceat(terms, first, axis=1)
    return out


def _overlap_fraction(edges: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Fraction of each interval [lo_j, hi_j] inside each bin [edges_i, edges_i+1] (bins ×
    intervals); an interval of zero width counts whole in the bin holding it."""
    a, b = edges[:-1, None], edges[1:, None]
    span = hi - lo
    inside = np.clip(np.minimum(b, hi) - np.maximum(a, lo), 0.0, None)
    point = ((lo >= a) & (lo < b)).astype(float)
    return np.where(span > 0.0, inside / np.where(span > 0.0, span, 1.0), point)
