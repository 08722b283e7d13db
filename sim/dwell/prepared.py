"""What the runs of one radar on one scene's tables share, prepared once and passed explicitly.

A :class:`shipradar.sim.dwell.model.DwellModel` is made per run (its random streams, its
observers and its target list are the run's own), but much of what it reads depends on the
scene's radar and tables alone, and is only read afterwards: the clutter maps' stacked readers
(a copy of the maps' arrays), the PE table's reader, the two-ray fallback's terms per target
height, the P_fac map's false-alarm generator, the clutter spectrum at the map's sectors, the
expected clutter false-alarm density and range profile that ``meta`` publishes. A study that
runs one scene many times on the same tables (Monte Carlo replications, evaluate runs, a
fidelity setting's seeds) keeps a :class:`PreparedScene` and passes it to each run
(``Simulation(..., prepared=...)``); a run given none makes its own, as a new process does.

One :class:`PreparedRadar` per radar, made by its :class:`PreparedScene` at the first run that
asks; each part is built at its first use (a scene computes only what it contains). The
preparation is tied to the scenario and the table objects it was made from (identity): a
run on another scenario or other tables must not be given it (:meth:`PreparedScene.check`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from shipradar.sensors import geometry
from shipradar.sensors.radar import RadarConstants, false_alarm_probability, pulses_per_beamwidth
from shipradar.sensors.weather_clutter import rain_equivalent_rate_mm_h
from shipradar.sim.dwell.false_alarm_model import Spectrum, clutter_false_alarm_density
from shipradar.sim.world.scenario import Platform, Radar, Scenario
from shipradar.tables.sky import rain_attenuation_db_per_km, scene_radar_constants
from shipradar.tables.store import StackedLookup2D

if TYPE_CHECKING:
    from shipradar.sensors.false_alarms import ClutterFalseAlarms
    from shipradar.tables.scene import RadarTables, SceneTables

__all__ = ["PreparedRadar", "PreparedScene", "TwoRayFallback"]

#: A clutter map's arrays read together (None: the table's values): the sea map's power,
#: spread and Weibull a; the weather map's power, mean and spread; the one-trip rain power;
#: the sea spectrum's spread alone.
_SEA_ARRAYS = (None, "doppler_spread_hz", "weibull_a")
_WEATHER_ARRAYS = (None, "doppler_mean_hz", "doppler_spread_hz")
_TRIP_ARRAYS = ("single_trip_power_w",)
_SEA_SPECTRUM_ARRAYS = ("doppler_spread_hz",)

#: (range edges [m], expected count per ring [-], their sum [-]) of a P_fac map.
RangeProfile = tuple[np.ndarray, np.ndarray, float]
#: (range edges [m], azimuth edges [rad], expected count per cell [-]).
Density = tuple[np.ndarray, np.ndarray, np.ndarray]


def _read_only(*arrays: np.ndarray) -> None:
    """Freeze arrays the runs of a preparation share."""
    for a in arrays:
        a.setflags(write=False)


class PreparedRadar:
    """What the runs of one radar on one scene's tables share (see the module note).

    Parameters
    ----------
    scenario : Scenario
        The scene (its environment: the sky, the sea, the rain, the wind).
    platform : Platform
        The radar's platform.
    radar : Radar
        The radar.
    tables : RadarTables
        The radar's tables (``SceneTables.for_radar(radar.id)``).
    """

    def __init__(self, scenario: Scenario, platform: Platform, radar: Radar,
                 tables: RadarTables) -> None:
        self.scenario = scenario
        self.platform = platform
        self.radar = radar
        self.tables = tables
        #: the radar's constants, T'_a from the table store
        #: (:func:`shipradar.tables.sky.scene_radar_constants`)
        self.constants: RadarConstants = scene_radar_constants(scenario, radar)
        #: g_el (field) of the elevation [rad] [8]-[14]
        self.elevation_pattern = self.constants.elevation_pattern(radar)
        self._densities: dict[tuple[float, int], Density | None] = {}
        self._sector_spectrum: Spectrum | None = None

    # ------------------------------------------------------------------ the clutter maps
    @functools.cached_property
    def sea_reader(self) -> StackedLookup2D | None:
        """The sea-clutter map's power, spread and Weibull a at (ground range, azimuth);
        None without a map."""
        sea = self.tables.sea_clutter
        return None if sea is None else StackedLookup2D(sea, _SEA_ARRAYS, periodic1=True)

    @functools.cached_property
    def weather_reader(self) -> StackedLookup2D | None:
        """The weather-clutter map's power, Doppler mean and spread; None without a map."""
        wx = self.tables.weather_clutter
        return None if wx is None else StackedLookup2D(wx, _WEATHER_ARRAYS, periodic1=True)

    @functools.cached_property
    def weather_trip_reader(self) -> StackedLookup2D | None:
        """The weather map's one-trip power, read and summed trip by trip [39]-[41] when the
        rain has a region; None otherwise."""
        wx, rain = self.tables.weather_clutter, self.scenario.environment.rain
        if wx is None or rain is None or rain.region is None:
            return None
        return StackedLookup2D(wx, _TRIP_ARRAYS, periodic1=True)

    @functools.cached_property
    def sea_spectrum_reader(self) -> StackedLookup2D | None:
        """The sea-clutter spectrum's spread alone (the Doppler of a scan's thousands of
        sea-clutter false alarms); None without a map."""
        sea = self.tables.sea_clutter
        return (None if sea is None
                else StackedLookup2D(sea, _SEA_SPECTRUM_ARRAYS, periodic1=True))

    # ------------------------------------------------------------------ propagation
    @functools.cached_property
    def two_ray(self) -> TwoRayFallback:
        """The two-ray fallback of this antenna over the scene's sea, its per-height terms
        kept for the runs."""
        return TwoRayFallback(self.radar, self.scenario.wave_height, self.elevation_pattern)

    @functools.cached_property
    def pe_lookup(self) -> Callable[[np.ndarray, np.ndarray], np.ndarray] | None:
        """F of the PE table at (ground range, height) [m], NaN where the table has none
        (:func:`shipradar.tables.propagation.propagation_lookup`); None without a table."""
        table = self.tables.propagation
        if table is None:
            return None
        from shipradar.tables.propagation import propagation_lookup

        return propagation_lookup(table)

    @functools.cached_property
    def rain_gamma_db_per_km(self) -> float:
        """γ_R [dB/km] of the scene's rain at the radar's frequency ([16], P.838, from the
        table store); 0 without rain or with the atmosphere off."""
        rain = self.scenario.environment.rain
        if rain is None or not self.scenario.fidelity.atmosphere:
            return 0.0
        rate = float(rain_equivalent_rate_mm_h(rain.rate_mm_h, rain.kind))  # seed 4.1.4
        return rain_attenuation_db_per_km(self.radar.frequency_hz, rate, self.radar.polarization)

    # ------------------------------------------------------------------ false alarms
    @functools.cached_property
    def clutter_generator(self) -> ClutterFalseAlarms | None:
        """The P_fac map's per-scan generator
        (:func:`shipradar.tables.pfac.clutter_false_alarm_generator`), the template whose
        twins (:meth:`~shipradar.sensors.false_alarms.ClutterFalseAlarms.shared`) the runs draw
        with; None without a map."""
        pfac = self.tables.pfac
        if pfac is None:
            return None
        from shipradar.tables.pfac import clutter_false_alarm_generator

        r = self.radar
        return clutter_false_alarm_generator(
            pfac, pfa=false_alarm_probability(r), n_channels=r.n_channels,
            n_pulses=pulses_per_beamwidth(r), h_range=r.h_range, h_azimuth=r.h_azimuth)

    @functools.cached_property
    def clutter_range_profile(self) -> RangeProfile | None:
        """The P_fac map's expected sea-clutter false alarms per scan in 250 m rings and
        their total (:func:`shipradar.tables.pfac.clutter_range_profile`); None without a
        map."""
        pfac = self.tables.pfac
        if pfac is None:
            return None
        from shipradar.tables.pfac import clutter_range_profile

        edges, per_scan = clutter_range_profile(pfac)
        _read_only(edges, per_scan)
        return edges, per_scan, float(per_scan.sum())

    def clutter_false_alarm_density(self, ring_m: float, azimuth_sectors: int
                                    ) -> Density | None:
        """:func:`shipradar.sim.dwell.false_alarm_model.clutter_false_alarm_density` of the
        map's generator, computed once per (``ring_m`` [m], ``azimuth_sectors``); None
        without a map."""
        key = (float(ring_m), int(azimuth_sectors))
        if key not in self._densities:
            gen = self.clutter_generator
            out = None
            if gen is not None:
                out = clutter_false_alarm_density(gen, *key)
                _read_only(*out)
            self._densities[key] = out
        return self._densities[key]

    def sector_spectrum(self, spectrum_reference: Callable[[np.ndarray, np.ndarray], Spectrum]
                        ) -> Spectrum:
        """(reference, spread) [Hz] of the Doppler bank at the centre of every P_fac sector,
        from ``spectrum_reference(ground_range [m], azimuth [rad])`` (the dwell model's, a
        function of the scene's radar, platform, wind and sea map alone) at the first call,
        then kept. Read with a map only."""
        if self._sector_spectrum is None:
            gen = self.clutter_generator
            if gen is None:
                raise RuntimeError("the sector spectrum is read with a P_fac map only")
            centre_r = 0.5 * (gen.r_min_m + gen.r_max_m)
            centre_az = np.mod(0.5 * (gen.az_min_rad + gen.az_max_rad), 2.0 * math.pi)
            spectrum = spectrum_reference(centre_r, centre_az)
            _read_only(*spectrum)
            self._sector_spectrum = spectrum
        return self._sector_spectrum


class PreparedScene:
    """The :class:`PreparedRadar` of each radar of one scenario on one set of scene tables.

    Made by a :class:`shipradar.sim.engine.simulation.Simulation` given none (its
    ``prepared``); a study that runs the scene again on the same tables passes it to the next
    run (``Simulation(scenario, tables=tables, prepared=sim.prepared)``).
    """

    def __init__(self, scenario: Scenario, tables: SceneTables) -> None:
        self.scenario = scenario
        self.tables = tables
        self._radars: dict[str, PreparedRadar] = {}

    def check(self, scenario: Scenario, tables: SceneTables) -> None:
        """Raise ValueError unless this preparation is of ``scenario`` and ``tables`` (the
        same objects)."""
        if scenario is not self.scenario:
            raise ValueError("prepared: made for another scenario object (prepare each "
                             "scenario on its own)")
        if tables is not self.tables:
            raise ValueError("prepared: made for other scene tables (pass the tables it "
                             "was prepared with, or no preparation)")

    def radar(self, platform: Platform, radar: Radar) -> PreparedRadar:
        """The preparation of ``radar`` on ``platform``, made at its first request."""
        prepared = self._radars.get(radar.id)
        if prepared is None:
            prepared = self._radars[radar.id] = PreparedRadar(
                self.scenario, platform, radar, self.tables.for_radar(radar.id))
        return prepared


class TwoRayFallback:
    """:func:`shipradar.sensors.propagation.two_ray_factor` of one radar, with the per-height
    terms kept.

    For a given antenna (height, frequency, polarization, pattern) and sea, the two-ray
    factor's limit of the interference region (a 48-step bisection), F at that limit and the
    diffraction factor at the horizon depend on the target height alone.  They are computed
    once per distinct height (targets fly at a few constant altitudes) instead of at every
    call; per point only the two-ray terms inside the limit, the smooth-earth diffraction
    beyond the horizon and the dB interpolation between them remain.  The combination is
    that of :func:`shipradar.sensors.propagation.two_ray_factor`, which
    ``tests/test_dwell_fallback.py`` checks this against.
    """

    #: Most heights remembered (a climbing target gives a new height at every dwell).
    MAX_HEIGHTS = 4096

    def __init__(self, radar: Radar, wave_height_m: float,
                 elevation_pattern: Callable[[ArrayLike], np.ndarray]) -> None:
        from shipradar.sensors import propagation  # scipy.special: when a scene needs it

        self._prop = propagation
        self.h1 = float(radar.antenna_height_m)
        self.freq = float(radar.frequency_hz)
        self.pol = propagation.normalize_polarization(radar.polarization)
        self.wave = float(wave_height_m)
        self.pattern = elevation_pattern
        self.k_factor = geometry.K_FACTOR
        self.eps = complex(propagation.sea_water_permittivity(self.freq))
        a_e = self.k_factor * geometry.EARTH_RADIUS_M
        self.g_horizon = float(np.abs(elevation_pattern(
            -np.arccos(np.array([a_e / (a_e + self.h1)]))))[0])
        self._cache: dict[float, tuple[float, float, float, float]] = {}

    def _terms(self, d: np.ndarray, h2: np.ndarray) -> np.ndarray:
        gd, refl, _ = self._prop.two_ray_terms(
            d, np.full(d.shape, self.h1), h2, self.freq, self.pol, self.wave, self.pattern, 0.0,
            self.k_factor, self.eps, "miller-brown")
        return np.abs(gd + refl)

    def _per_height(self, heights: list[float]) -> dict[float, tuple[float, float, float, float]]:
        """(horizon range, interference limit, F there, diffraction F at the horizon) [m, -]."""
        prop = self._prop
        h2 = np.array(heights, dtype=float)
        h1 = np.full(h2.shape, self.h1)
        d_h = prop.horizon_range(h1, h2, self.k_factor)
        d_lim = prop.interference_region_limit(h1, h2, self.freq, self.k_factor)
        f_lim = self._terms(d_lim, h2)
        f_diff_h = prop.smooth_earth_diffraction_factor(
            d_h, h1, h2, self.freq, self.pol, k_factor=self.k_factor,
            permittivity=self.eps) * self.g_horizon
        return {h: (d_h[i], d_lim[i], f_lim[i], f_diff_h[i]) for i, h in enumerate(heights)}

    def __call__(self, range_m: np.ndarray, height_m: np.ndarray) -> np.ndarray:
        """F (field ratio, pattern included) at terrestrial ranges and target heights [m]."""
        d = np.asarray(range_m, dtype=float)
        h2 = np.asarray(height_m, dtype=float)
        if d.size == 0:
            return np.zeros(d.shape)
        if (d < 0).any() or (h2 < 0).any():
            raise ValueError("range and heights must be >= 0")
        cache = self._cache
        # the distinct heights only (sorted): one dict lookup per height, not per target
        uniq, inverse = np.unique(h2.ravel(), return_inverse=True)
        keys = uniq.tolist()
        missing = [h for h in keys if h not in cache]
        if missing:
            new = self._per_height(missing)
            if len(cache) + len(new) <= self.MAX_HEIGHTS:
                cache.update(new)
            else:  # full (the runs of a preparation share it): emptied for the next calls
                self._cache = {}  # (pure values: forgetting them changes no result)
                cache = {**cache, **new}
        per = np.array([cache[h] for h in keys], dtype=float).reshape(-1, 4)[inverse.ravel()]
        d_h, d_lim, f_lim, f_diff_h = (per[:, i] for i in range(4))
        # each branch is evaluated only when some point needs it (its other values unused)
        beyond = d >= d_h
        diffraction = np.zeros(d.shape)
        if beyond.any():
            diffraction = self._prop.smooth_earth_diffraction_factor(
                np.maximum(d, d_h), np.full(d.shape, self.h1), h2, self.freq, self.pol,
                k_factor=self.k_factor, permittivity=self.eps) * self.g_horizon
        inside = d <= d_lim
        f_inter = self._terms(np.minimum(d, d_lim), h2) if inside.any() else np.zeros(d.shape)
        tiny = 1e-30
        span = np.maximum(d_h - d_lim, 1e-9)
        w = np.clip((d - d_lim) / span, 0.0, 1.0)
        intermediate = np.exp((1 - w) * np.log(np.maximum(f_lim, tiny))
                              + w * np.log(np.maximum(f_diff_h, tiny)))
        return np.where(inside, f_inter, np.where(beyond, diffraction, intermediate))
