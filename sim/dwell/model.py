"""The dwell processor: from the targets a beam crosses to plots (seed chapters 3-7, on-line).

One :class:`DwellModel` per radar and run. Everything that does not change during a run is
computed once in its constructor (radar constant, system noise, P_fa, pulses per beam, the
false-alarm rate, pattern and RCS parameters), and what depends on the radar and its tables
alone is read from its :class:`shipradar.sim.dwell.prepared.PreparedRadar`, which the runs of
a study on the same tables share (the clutter maps' readers, the two-ray fallback, the
false-alarm generator and density);
:meth:`DwellModel.process_targets` is then vectorized over all the targets the beam crosses
in one sector, a chain of named steps (:mod:`shipradar.sim.dwell.look`: geometry,
propagation, target power, clutter, jamming, processing, S/I, N_e, P_d, measurement) whose
intermediate results reach the observers of ``DwellModel.on_look`` as one
:class:`shipradar.sim.dwell.look.LookResults` per call:

1. cross section σ ([15], a table against aspect, or a constant);
2. propagation factor F (the PE table [5]-[7], the two-ray fallback, or free space — each
   including the elevation directivity, [4]) and the one-way atmospheric loss [16];
3. echo power [2]-[3] and S/N [17]-[20];
4. sea and weather clutter power at the target's cell [21], [39], S/C [46];
5. stand-off jamming through the radar pattern [47], S/J [48];
6. the dominant interference and S/I [66]-[67], processing gain [57], [63]-[65];
7. unresolved targets (2.2.1): targets sharing a range-azimuth cell and a Doppler filter add
   their powers into one contact;
8. effective number of pulses [73]-[77], P_d [78]-[83] or exact, the detection draw, and the
   noisy measurements [84]-[89].

Interference codes: :class:`shipradar.sensors.detection.Interference`.

Dominance rule (SPEC §4 item 5: the seed's conditions overlap and leave gaps).  With N = N0',
C = P_sc + P_wc and J = Σ P_j, all at the RF input: jamming dominates when J > 2 (C + N)
(the seed's own condition, checked first); otherwise clutter dominates when C >= N/2 (the
seed: "when these three sources are competing, clutter is taken as being the dominant one");
otherwise noise.  The three cases cover every (N, C, J) exactly once.  Jamming is noise-like
(seed 6.1): S/I = S/(N + J) with the noise formula [66].
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from shipradar.sensors import (
    antenna,
    detection,
    doppler_filters,
    false_alarms,
    geometry,
    jamming,
    measurement,
    noise,
    rcs,
    sea_clutter,
    weather_clutter,
)
from shipradar.sensors import plot_columns as pc
from shipradar.sensors.detection import INTERFERENCE_NAMES, Interference
from shipradar.sensors.noise import DB_FLOOR, db
from shipradar.sensors.radar import (
    false_alarm_probability,
    pulses_per_beamwidth,
)
from shipradar.sim.dwell.false_alarm_model import FalseAlarmModel
from shipradar.sim.dwell.look import (
    Contacts,
    Decision,
    Look,
    LookObserver,
    LookResults,
    Propagation,
    TargetPower,
)
from shipradar.sim.dwell.prepared import PreparedRadar
from shipradar.sim.world.kinematics import Geometry, wrap_pi
from shipradar.sim.world.scenario import Platform, Radar, Scenario

if TYPE_CHECKING:
    from shipradar.sim.world.live import LiveTargets
    from shipradar.sim.world.traffic import SceneTargets
    from shipradar.tables.scene import SceneTables

#: The clutter at each target's cell (:meth:`DwellModel.clutter_at`): arrays by name.
Clutter = dict[str, np.ndarray]

_RCS_CONSTANT, _RCS_MISSILE, _RCS_TABLE = 0, 1, 2
#: Resolution of the common aspect grid on which RCS tables are resampled [deg].
_RCS_TABLE_STEP_DEG = 0.1


@dataclass(frozen=True)
class _Jammers:
    """Per-jammer constants (arrays over jammers)."""

    rows: np.ndarray
    power_w: np.ndarray
    gain: np.ndarray
    bandwidth_hz: np.ndarray


#: Largest one-way atmospheric loss used [dB]: 10^100, an echo or a jammer 1000 dB down is
#: nothing against any receiver's noise, and L_atm² (two ways) stays finite in float64.
MAX_ATMOSPHERIC_LOSS_DB = 1000.0


class DwellModel:
    """On-line radar model of one radar in one scene.

    ``prepared`` is what the runs of this radar on these tables share
    (:class:`shipradar.sim.dwell.prepared.PreparedRadar`: the clutter maps' readers, the
    two-ray fallback, the false-alarm generator, spectrum and density); None: made here.
    """

    INTERFERENCE_NAMES = INTERFERENCE_NAMES

    def __init__(self, scenario: Scenario, platform: Platform, radar: Radar,
                 tables: SceneTables, targets: SceneTargets | LiveTargets | None = None,
                 prepared: PreparedRadar | None = None) -> None:
        from shipradar.sim.world.traffic import scene_targets

        radar_tables = tables.for_radar(radar.id)
        if prepared is None:
            prepared = PreparedRadar(scenario, platform, radar, radar_tables)
        elif (prepared.scenario is not scenario or prepared.radar is not radar
              or prepared.tables is not radar_tables):
            raise ValueError(f"prepared: made for another scenario, radar or tables than "
                             f"radar {radar.id!r} of this run")
        #: what the runs of this radar on these tables share
        #: (:class:`shipradar.sim.dwell.prepared.PreparedRadar`)
        self.prepared = prepared
        self.scenario = scenario
        #: every target of the scene, its own and its traffic files'
        #: (:class:`shipradar.sim.world.traffic.SceneTargets`)
        self.targets = scene_targets(scenario) if targets is None else targets
        self.platform = platform
        self.radar = radar
        self.tables = radar_tables
        self.method = scenario.fidelity.pd_method
        #: Observers of every look (:class:`shipradar.sim.dwell.look.LookObserver`): each call
        #: of :meth:`process_targets` hands each of them one
        #: :class:`~shipradar.sim.dwell.look.LookResults` after the detection draw (empty in a
        #: normal run, which then never builds it).
        self.on_look: list[LookObserver] = []
        #: Opt-in common random numbers (:func:`shipradar.sim.studies.fidelity.look_uniforms`;
        #: None in a normal run, whose stream is then unchanged): ``look_uniforms(target_rows,
        #: t_s) -> u`` replaces the detection draw by one uniform per look derived from the
        #: look itself, so two fidelity settings see the same dice per look.
        self.look_uniforms: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
        self.k = k = prepared.constants  # T'_a from the table store
        self.wavelength, self.gain, self.k_r0 = k.wavelength, k.gain, k.k_r0
        self.l_x, self.l_c, self.l_r = k.l_x, k.l_c, k.l_r
        self.l_cfar, self.l_cd, self.l_b = k.l_cfar, k.l_cd, k.l_b
        self.theta_b, self.phi_b, self.tilt = k.theta_b, k.phi_b, k.tilt
        self.range_cell, self.bandwidth = k.range_cell, k.bandwidth
        self.t_a, self.t_s, self.n0 = k.t_a, k.t_s, k.n0
        self.elevation_pattern = prepared.elevation_pattern
        self.high_resolution = bool(sea_clutter.is_medium_high_resolution(
            self.theta_b, radar.pulse_width_s))
        self._prepare_detection(radar)
        self._prepare_targets()
        self._prepare_jammers(scenario)
        self._prepare_propagation(scenario)
        self._prepare_compensation(platform, radar)
        # the clutter maps' readers (None where the scene has no map)
        self._sea_reader = prepared.sea_reader
        self._wx_reader = prepared.weather_reader
        self._wx_trip_reader = prepared.weather_trip_reader
        self._sea_spectrum_reader = prepared.sea_spectrum_reader
        #: the noise and sea-clutter false alarms and their density
        #: (:class:`shipradar.sim.dwell.false_alarm_model.FalseAlarmModel`)
        self.false_alarms = FalseAlarmModel(self)
        # P.838 through itur, kept in the table store (itur's import: 0.6 s of start-up)
        self.rain_gamma_db_per_km = prepared.rain_gamma_db_per_km

    # ------------------------------------------------------------------ set-up
    def _prepare_detection(self, radar: Radar) -> None:
        """P_fa, pulses per beam, resolution cells, the noise false alarms' rate, and the
        P_d tables when the fidelity reads them."""
        # false alarms and pulses [68]-[73], [90]: P_fa for one reported false alarm per
        # t_fa and the count over the same decisions, so the noise false alarms come at 1/t_fa
        # (the seed's [68] and [90] disagree; detection and false_alarms module notes)
        self.pfa = false_alarm_probability(radar)
        self.n_pulses = pulses_per_beamwidth(radar)
        self.n_cells = float(false_alarms.resolution_cells(
            radar.instrumented_range_m, self.theta_b, self.range_cell))
        self.noise_false_alarms_per_scan = float(false_alarms.noise_false_alarms_per_scan(
            self.pfa, self.theta_b, radar.prf_hz, radar.pulse_width_s,
            radar.instrumented_range_m, radar.n_channels))
        if self.method == "table":
            # the exact P_d tabulated against (N_e, S/I) for this P_fa, N_e in [1, N_n]
            from shipradar.tables.pd import PdTables

            cases = (self.targets.swerling_cases() if hasattr(self.targets, "swerling_cases")
                     else [int(c) for c in self.targets.swerling])  # live: any case it may get
            self._pd_tables = PdTables(self.pfa, self.n_pulses, cases)

    def refresh_targets(self) -> None:
        """Take the scene's target list again (a live source's grew)."""
        self._prepare_targets()

    def _prepare_targets(self) -> None:
        n = self.targets.n
        self.rcs_kind = np.zeros(n, dtype=np.int8)
        self.rcs_const = np.zeros(n)
        self.rcs_missile = np.zeros((n, 3))
        self.swerling = np.zeros(n, dtype=np.int8)
        tables: list[np.ndarray] = []
        self.rcs_table_row = np.full(n, -1)
        grid = np.arange(0.0, 180.0 + 0.5 * _RCS_TABLE_STEP_DEG, _RCS_TABLE_STEP_DEG)
        self.swerling[:] = self.targets.swerling
        table_rows: dict[int, int] = {}  # a model shared by many traffic targets: one table
        for i, model in enumerate(self.targets.rcs):
            if model.type == "constant":
                self.rcs_kind[i] = _RCS_CONSTANT
                self.rcs_const[i] = model.sigma_m2
            elif model.type == "missile":
                self.rcs_kind[i] = _RCS_MISSILE
                self.rcs_missile[i] = (model.sigma_nose_m2, model.length_m, model.diameter_m)
            else:
                self.rcs_kind[i] = _RCS_TABLE
                row = table_rows.get(id(model))
                if row is None:
                    row = table_rows[id(model)] = len(tables)
                    tables.append(rcs.tabulated_rcs(np.radians(model.aspect_deg),
                                                    np.asarray(model.sigma_m2),
                                                    np.radians(grid)))
                self.rcs_table_row[i] = row
        self.rcs_tables = np.array(tables) if tables else np.zeros((0, grid.size))
        self.rcs_grid_step = math.radians(_RCS_TABLE_STEP_DEG)

    def _prepare_jammers(self, scenario: Scenario) -> None:
        js = scenario.jammers
        self.jam = _Jammers(
            rows=np.arange(len(js)),
            power_w=np.array([j.power_w for j in js]),
            gain=noise.power_ratio(np.array([j.gain_db for j in js])),
            bandwidth_hz=np.array([j.bandwidth_hz for j in js]),
        )
        # L_sl of [47]: the constant azimuth sidelobe level a jammer outside the main beam
        # sees; a floor under the pattern (a real antenna's far sidelobes and backlobe), so a
        # jammer behind the antenna or off a Gaussian beam does not vanish
        pa = self.radar.pattern_az
        self.jam_sidelobe_floor = float(noise.power_ratio(-(
            pa.sidelobe_db if pa.jamming_sidelobe_db is None else pa.jamming_sidelobe_db)))

    def _prepare_compensation(self, platform: Platform, radar: Radar) -> None:
        # The platform motion the processor removes ([35], motion_compensated): the same
        # ship speed and course as the clutter tables' f1 [34]
        # (shipradar.sim.world.kinematics.ship_motion), so the target Doppler relative to the
        # clutter is the same with and without it.
        from shipradar.sim.world.kinematics import ship_motion

        speed, course = ship_motion(platform)
        self._table_motion = (speed, course)
        self.compensation = (speed, course) if (
            radar.processor.motion_compensated and speed > 0.0) else None

    def _platform_doppler_hz(self, speed: float | np.ndarray, course: float | np.ndarray,
                             azimuth: np.ndarray, ground_range: np.ndarray | None = None
                             ) -> np.ndarray:
        """f1 [34] of the clutter patch along each beam [Hz] for a ship at ``speed`` [m/s] on
        ``course`` [rad]; at the sea patch's depression angle at ``ground_range`` [m], or
        horizontal (the weather map's convention) when None."""
        depression = 0.0 if ground_range is None else sea_clutter.depression_angle_rad(
            ground_range, self.radar.antenna_height_m)
        return sea_clutter.platform_doppler_hz(speed, azimuth - course, depression,
                                               self.wavelength)

    def _instantaneous_f1(self, geom: Geometry, platform_vel: np.ndarray, sea: bool = True
                          ) -> tuple[np.ndarray, np.ndarray]:
        """f1 [34] from the platform's instantaneous velocity (N, 3) [m/s] (a turning or
        accelerating ship), and the same from the clutter tables' motion, to swap one for
        the other in the clutter mean [35] and in the motion compensation."""
        speed = np.hypot(platform_vel[:, 0], platform_vel[:, 1])
        course = np.arctan2(platform_vel[:, 0], platform_vel[:, 1])
        rng = geom.ground_range if sea else None
        return (self._platform_doppler_hz(speed, course, geom.azimuth, rng),
                self._platform_doppler_hz(*self._table_motion, geom.azimuth, rng))

    def _sea_clutter_mean_hz(self, ground_range: np.ndarray, azimuth: np.ndarray,
                             platform_vel: np.ndarray | None = None) -> np.ndarray:
        """μ_c [35] of the sea patch at ``ground_range`` [m] and ``azimuth`` [rad] [Hz]: f1
        [34] plus the waves' drift, 0 when motion-compensated; f1 from the platform's
        instantaneous velocity ``platform_vel`` (N, 3) [m/s] when given, else from the
        clutter tables' ship motion.

        The Doppler bank's reference where sea clutter leads (its filters are indexed from
        it): the processor's, so it is computed from the ship's motion and the wind whatever
        ``fidelity.clutter`` says, never read from the clutter map (whose ``doppler_mean_hz``
        is the same function on its grid): switching the clutter's power off leaves every
        reported range rate where it was.
        """
        if self.radar.processor.motion_compensated:
            return np.zeros(np.shape(ground_range))
        if platform_vel is None:
            speed, course = self._table_motion
        else:
            speed = np.hypot(platform_vel[:, 0], platform_vel[:, 1])
            course = np.arctan2(platform_vel[:, 0], platform_vel[:, 1])
        f1 = self._platform_doppler_hz(speed, course, azimuth, ground_range)
        wind = math.radians(self.scenario.environment.wind_direction_deg)
        return sea_clutter.mean_clutter_doppler_hz(f1, azimuth - wind, self.wavelength)

    def _relative_doppler_hz(self, geom: Geometry, clutter: Clutter | None,
                             platform_vel: np.ndarray | None = None) -> np.ndarray:
        """Each target's Doppler relative to the bank's reference [Hz], which picks its filter:
        ``clutter["doppler_relative_hz"]`` (:meth:`clutter_at`: relative to the dominant
        clutter's mean) or, without modelled clutter (``clutter`` None), f_d' - μ_c of the sea
        (:meth:`_sea_clutter_mean_hz`), as where sea clutter leads."""
        if clutter is not None:
            return clutter["doppler_relative_hz"]
        return self.target_doppler_hz(geom, platform_vel) - self._sea_clutter_mean_hz(
            geom.ground_range, geom.azimuth, platform_vel)

    @property
    def has_doppler_bank(self) -> bool:
        """True for a DFT/FIR bank (alone or behind an MTI): plots carry a range rate."""
        return self.radar.processor.type in ("dft_bank", "fir_bank", "mti_bank")

    @property
    def n_doppler_filters(self) -> int:
        """Filters of the bank, by default as many as it has taps: N_c for a DFT or FIR bank,
        N_c - N_pc behind an N_pc-order canceller (as the I_F table is built,
        :func:`shipradar.tables.scene.improvement_kwargs`); 1 without a bank."""
        proc = self.radar.processor
        if not self.has_doppler_bank:
            return 1
        taps = proc.n_coherent - (proc.mti_order if proc.type == "mti_bank" else 0)
        return proc.n_filters if proc.n_filters is not None else taps

    @property
    def range_rate_sigma_mps(self) -> float:
        """Expected 1σ of the reported range rate [m/s]: the filter spacing f_r/N as a
        uniform quantisation, (λ/2) f_r / (N √12); NaN without a bank."""
        if not self.has_doppler_bank:
            return math.nan
        return 0.5 * self.wavelength * self.radar.prf_hz / (self.n_doppler_filters
                                                            * math.sqrt(12.0))

    @property
    def range_rate_span_mps(self) -> float:
        """Unambiguous span of the reported range rate [m/s], λ f_r / 2 (the first blind
        speed; f_r the nominal PRF, as :meth:`range_rate_from_filter` folds): a plot's
        ``range_rate_mps`` lies in (v_ref - S/2, v_ref + S/2] about its reference; NaN
        without a bank."""
        if not self.has_doppler_bank:
            return math.nan
        return 0.5 * self.wavelength * self.radar.prf_hz

    def range_rate_from_filter(self, filter_index: np.ndarray,
                               reference_hz: float | np.ndarray) -> np.ndarray:
        """Measured range rate [m/s] (positive receding) of contacts detected in bank filters
        ``filter_index``: the filter centre i f_r/N [60], folded into [-f_r/2, f_r/2) (the
        Doppler ambiguity: blind and ambiguous speeds beyond ±f_r λ/4), plus the bank's
        reference ``reference_hz`` [Hz] (the clutter mean μ_c the filters are indexed from,
        and f1 [34] when motion-compensated: both known to the processor), as -λ f/2.

        Staggered PRFs: the filters are on the nominal ``prf_hz`` grid (as the model picks
        them), so the fold is by ``prf_hz``; the stagger moves the blind speeds of the
        improvement factor, not the ambiguity of one coherent dwell's filter centre.
        """
        index = np.asarray(filter_index)
        n = self.n_doppler_filters
        if (index.dtype == np.int64 and index.size > n and index.min() >= 0
                and index.max() < n):
            # the formula below, once per filter; -λ/2 (centre + reference) formed in place
            # (a sum and a product are the same whichever operand comes first)
            rate = self._filter_centres_hz.take(index)
            if np.broadcast_shapes(rate.shape, np.shape(reference_hz)) == rate.shape:
                rate += reference_hz
                rate *= -0.5 * self.wavelength
                rate += 0.0  # filter 0 at a zero reference: 0.0, not -0.0
                return rate
            return -0.5 * self.wavelength * (rate + reference_hz) + 0.0
        centre = self._filter_centre_hz(index)
        return -0.5 * self.wavelength * (centre + reference_hz) + 0.0

    def _filter_centre_hz(self, filter_index: np.ndarray) -> np.ndarray:
        """Centre of filters ``filter_index`` folded into [-f_r/2, f_r/2) [Hz]."""
        n = self.n_doppler_filters
        return (np.mod(np.asarray(filter_index) / n + 0.5, 1.0) - 0.5) * self.radar.prf_hz

    @functools.cached_property
    def _filter_centres_hz(self) -> np.ndarray:
        """:meth:`_filter_centre_hz` of every filter of the bank."""
        return self._filter_centre_hz(np.arange(self.n_doppler_filters, dtype=np.int64))

    def reference_mps(self, reference_hz: float | np.ndarray) -> np.ndarray:
        """The bank's reference as a range rate [m/s], -λ f/2 (the rate of filter 0: docs/
        protocol.md 4.2), +0.0 rather than -0.0 at a zero reference."""
        return -0.5 * self.wavelength * np.asarray(reference_hz) + 0.0

    def spectrum_reference(self, range_m: np.ndarray, azimuth_rad: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray]:
        """The Doppler bank's reference (the sea-clutter mean μ_c, plus f1 [34] when
        motion-compensated) and the clutter spread σ_s at ground ranges and azimuths [Hz];
        a spread of 0 without a sea-clutter map."""
        reference = self._sea_clutter_mean_hz(range_m, azimuth_rad)
        spread = np.zeros(np.shape(range_m))
        if self._sea_spectrum_reader is not None:
            spread = np.nan_to_num(self._sea_spectrum_reader(range_m, azimuth_rad))[:, 0]
        if self.compensation is not None:
            reference = reference + self._platform_doppler_hz(*self.compensation,
                                                              azimuth_rad, range_m)
        return reference, spread

    def _prepare_propagation(self, scenario: Scenario) -> None:
        self.propagation_mode = scenario.fidelity.propagation
        self.wave_height = scenario.wave_height
        # its per-height terms: shared by the runs of the preparation
        self._two_ray = self.prepared.two_ray

    def azimuth_pattern(self, offset_rad: np.ndarray, envelope: bool = False) -> np.ndarray:
        """Azimuth directivity factor g_az (field) at an angle from the beam axis [8]-[13].

        ``envelope``: beyond the first null, the sidelobe peak envelope instead of the sinc.
        """
        pa = self.radar.pattern_az
        return antenna.directivity(offset_rad, self.theta_b, pa.type, sidelobe_db=pa.sidelobe_db,
                                   envelope=envelope)

    # ------------------------------------------------------------------ physics pieces
    def cross_section(self, rows: np.ndarray, los_enu: np.ndarray, vel_enu: np.ndarray
                      ) -> np.ndarray:
        """σ [m²] of targets ``rows`` seen along ``los_enu`` (radar to target)."""
        kind = self.rcs_kind[rows]
        sigma = self.rcs_const[rows].copy()
        m = kind == _RCS_MISSILE
        tab = kind == _RCS_TABLE
        if (m | tab).any():
            theta, phi = rcs.aspect_angles(los_enu, vel_enu)
            if m.any():
                p = self.rcs_missile[rows[m]]
                sigma[m] = rcs.missile_rcs(p[:, 0], p[:, 1], p[:, 2], theta[m], phi[m])
            if tab.any():
                off = rcs.off_nose_angle(theta[tab], phi[tab])
                x = np.clip(off / self.rcs_grid_step, 0, self.rcs_tables.shape[1] - 1.000001)
                i = np.floor(x).astype(int)
                w = x - i
                tr = self.rcs_table_row[rows[tab]]
                sigma[tab] = (1 - w) * self.rcs_tables[tr, i] + w * self.rcs_tables[tr, i + 1]
        return sigma

    def propagation_factor(self, ground_range: np.ndarray, target_height: np.ndarray,
                           elevation: np.ndarray) -> tuple[np.ndarray, int]:
        """F (field ratio, includes g_el) and the number of points that fell back [4]-[7]."""
        mode = self.propagation_mode
        if mode == "free_space":
            return np.abs(self.elevation_pattern(elevation)), 0
        two_ray = self._two_ray
        pe_lookup = self.prepared.pe_lookup  # None without a PE table
        if mode == "two_ray" or pe_lookup is None:
            return two_ray(ground_range, target_height), 0
        f = pe_lookup(ground_range, target_height)
        bad = ~np.isfinite(f)
        if bad.any():
            f = f.copy()
            f[bad] = two_ray(ground_range[bad], target_height[bad])
        return f, int(np.count_nonzero(bad))

    def atmospheric_loss(self, slant_range: np.ndarray, elevation: np.ndarray,
                         radar_en: np.ndarray, target_en: np.ndarray, target_up: np.ndarray
                         ) -> np.ndarray:
        """One-way atmospheric loss L_atm [16] (power ratio >= 1).

        Held at :data:`MAX_ATMOSPHERIC_LOSS_DB`: a path through more is opaque (a jammer
        2800 km away at 100 GHz in fog is over 3000 dB, which 10^(x/10) overflows).
        """
        if self.tables.atmosphere is None:
            return np.ones_like(slant_range)
        from shipradar.tables.atmosphere import lookup_gas_fog_loss_db

        loss_db = lookup_gas_fog_loss_db(self.tables.atmosphere, slant_range, elevation)
        rain = self.scenario.environment.rain
        if rain is not None and self.rain_gamma_db_per_km > 0.0:
            from shipradar.sensors.atmosphere import rain_loss_db, rain_path_length_m

            region = rain.region
            centre = np.zeros(2) if region is None else np.array([region.east_m, region.north_m])
            radius = np.inf if region is None else region.radius_m
            length = rain_path_length_m(radar_en, target_en, self.radar.antenna_height_m,
                                        target_up, centre, radius, rain.cloud_base_m)
            loss_db = loss_db + rain_loss_db(self.rain_gamma_db_per_km, length)
        return noise.power_ratio(np.minimum(loss_db, MAX_ATMOSPHERIC_LOSS_DB))

    def jamming_power(self, beam_azimuth: np.ndarray, jam_geom: Geometry | None,
                      jam_pos: np.ndarray | None = None, antenna_en: np.ndarray | None = None
                      ) -> np.ndarray:
        """Total jamming power P_j [W] at each beam azimuth [47] (0 without jammers).

        One-way to each jammer: the propagation factor F_j of the scene's model (PE table,
        two-ray or free space; it holds the elevation pattern, as for targets) at the jammer's
        height, and the atmospheric loss [16] along the path.  The azimuth pattern toward the
        jammer is the sidelobe envelope beyond the first null ([13]), so S/J does not swing
        tens of dB between beam positions in the sinc nulls, floored at the seed's constant
        sidelobe level L_sl (``pattern_az.jamming_sidelobe_db``, default S_L): g_az² ≥ L_sl.

        Parameters
        ----------
        beam_azimuth : (N,) beam azimuths [rad, true north]
        jam_geom : Geometry of the M jammers from the antenna, or None: arrays of M entries
            (one geometry for every beam position), or of N M entries, beam position after
            beam position, jammer after jammer (the jammers where they are at each look's
            own time, as the engine gives them)
        jam_pos : (M, 3) or (N M, 3) jammer east/north/up in the origin frame [m]; None: F_j
            from a jammer at the sea surface and no atmospheric loss (unit tests)
        antenna_en : (2,) or (N M, 2) the antenna's east/north [m] (rain path); None: the
            origin
        """
        if jam_geom is None:
            return np.zeros_like(beam_azimuth)
        m = self.jam.power_w.size
        # (1, M) or (N, M): one row per beam position when each look has its own geometry
        jam_az = jam_geom.azimuth.reshape(-1, m)
        off = beam_azimuth[:, None] - jam_az
        off = np.mod(off + np.pi, 2.0 * np.pi) - np.pi
        g_az = self.azimuth_pattern(off, envelope=True)
        height = np.zeros(jam_geom.ground_range.shape) if jam_pos is None else jam_pos[:, 2]
        f_j, _ = self.propagation_factor(jam_geom.ground_range, height, jam_geom.elevation)
        l_atm = np.ones_like(f_j)
        if jam_pos is not None:
            radar_en = np.broadcast_to(np.zeros(2) if antenna_en is None else antenna_en,
                                       (height.size, 2))
            l_atm = self.atmospheric_loss(jam_geom.slant_range, jam_geom.elevation, radar_en,
                                          jam_pos[:, :2], height)
        p = jamming.jammer_power_w(
            self.jam.power_w[None, :], self.jam.gain[None, :], self.gain, g_az, 1.0,
            self.wavelength, jam_geom.slant_range.reshape(-1, m), self.bandwidth,
            self.jam.bandwidth_hz[None, :], f_j=f_j.reshape(-1, m), l_r=self.l_r,
            l_atm=l_atm.reshape(-1, m), sidelobe_floor=self.jam_sidelobe_floor)
        return p.sum(axis=1)

    def target_doppler_hz(self, geom: Geometry, platform_vel: np.ndarray | None = None
                          ) -> np.ndarray:
        """Target Doppler after the processor [Hz]: f_d = -2 v_r/λ, minus f1 when compensated.

        A motion-compensated processor ([35]: μ_c = 0) shifts everything it receives in the
        beam by the platform Doppler f1 [34] of the clutter patch at that range and azimuth,
        so the target is shifted too: f_d' = -2 v_r/λ - f1 (v_r the range rate relative to
        the ship, positive receding).  f_d' - μ_c is then the same with and without
        compensation, up to the wave-drift term of [35].  f1 uses the clutter tables' ship
        speed and course and the sea patch's depression angle at the target's ground range.

        Parameters
        ----------
        geom : Geometry
            Targets seen from the antenna (``radial_velocity`` [m/s], ``azimuth`` [rad],
            ``ground_range`` [m]).
        platform_vel : (N, 3) ndarray, optional
            The platform's instantaneous velocity [m/s] at each look: f1 then follows a
            turning or accelerating ship; None: the clutter tables' (first-leg) motion.
        """
        fd = -2.0 * geom.radial_velocity / self.wavelength
        if platform_vel is not None and self.radar.processor.motion_compensated:
            return fd - self._instantaneous_f1(geom, platform_vel)[0]
        if self.compensation is None:
            return fd
        return fd - self._platform_doppler_hz(*self.compensation, geom.azimuth,
                                              geom.ground_range)

    def clutter_at(self, geom: Geometry, tpos: np.ndarray, antenna_en: np.ndarray,
                   platform_vel: np.ndarray | None = None) -> Clutter | None:
        """Clutter at each target's cell and what the processor does to it.

        Returns None when the scene has no clutter tables; otherwise a dict of arrays:
        ``power_w`` P_sc + P_wc at the RF input [21], [39]; ``improvement`` I_F [57] of the
        Doppler processor at the target's Doppler relative to the clutter mean; its
        ``distribution_loss`` L_d [63]-[64] (sea clutter dominant and medium/high resolution);
        ``spread_mps`` the clutter velocity spread σ_s' for [74]; ``doppler_relative_hz``
        the target's Doppler relative to the clutter mean, f_d' - μ_c
        (:meth:`target_doppler_hz`), which indexes I_F and picks the filter.
        """
        if self._sea_reader is None and self._wx_reader is None:
            return None
        n = geom.ground_range.size
        zero = np.zeros(n)
        p_sc = mean_sc = spread_sc = a = zero
        if self._sea_reader is not None:
            v = np.nan_to_num(self._sea_reader(geom.ground_range, geom.azimuth))
            p_sc, spread_sc, a = v[:, 0], v[:, 1], v[:, 2]
            mean_sc = self._sea_clutter_mean_hz(geom.ground_range, geom.azimuth, platform_vel)
        p_wc = mean_wc = spread_wc = zero
        if self._wx_reader is not None:
            v = np.nan_to_num(self._wx_reader(geom.ground_range, geom.azimuth))
            p_wc = v[:, 0] if self._wx_trip_reader is None else \
                self._folded_rain_power(geom, antenna_en)
            mean_wc, spread_wc = v[:, 1], v[:, 2]
        if platform_vel is not None and not self.radar.processor.motion_compensated:
            # the weather map's mean holds f1 [34] of the first leg: swap in the ship's
            # instantaneous velocity (a turning frigate sweeps its clutter Doppler; the sea's
            # μ_c is computed with it already)
            if self._wx_reader is not None:
                f1, f1_table = self._instantaneous_f1(geom, platform_vel, sea=False)
                mean_wc = mean_wc + (f1 - f1_table)
        sea_dom = p_sc >= p_wc
        mean = np.where(sea_dom, mean_sc, mean_wc)
        spread = np.where(sea_dom, spread_sc, spread_wc)
        relative = self.target_doppler_hz(geom, platform_vel) - mean
        from shipradar.tables.improvement import improvement_and_gain_db

        prf = self.radar.prf_hz
        # I_F, and the same filter's gain against white noise: what thermal noise gets
        # through the processor while the clutter filters are on (the I_F table's
        # sigma -> inf limit); both read at the same cells, located once
        i_f_db, cg_db = improvement_and_gain_db(self.tables.improvement, spread / prf,
                                                relative / prf, "coherent_gain_db")
        l_d = np.ones(n)
        if self._sea_reader is not None and self.high_resolution:
            d_mm = sea_clutter.median_mean_difference_db(a)
            l_d = np.where(sea_dom, noise.power_ratio(
                doppler_filters.distribution_loss_db(i_f_db, d_mm)), 1.0)
        return {
            "power_w": p_sc + p_wc,
            "improvement": noise.power_ratio(i_f_db),
            "distribution_loss": l_d,
            "spread_mps": spread * self.wavelength / 2.0,
            "doppler_mean_hz": mean,
            "doppler_relative_hz": relative,
            "coherent_gain": noise.power_ratio(cg_db),
        }

    def _folded_rain_power(self, geom: Geometry, antenna_en: np.ndarray) -> np.ndarray:
        """Weather clutter P_wc at each target's delay with a rain region [W], [39]-[41].

        The rain of every pulse in flight, at ground ranges r + k R_u along the target's
        azimuth (:func:`shipradar.sensors.weather_clutter.range_folded_power_w`), each trip's cell
        counted only when it is inside the rain region, and through its own two-way loss
        along the part of its way inside the region ([39] with K_r of [3], γ_r of [16];
        :func:`shipradar.sensors.weather_clutter.rain_path_to_cell_m`). The weather clutter
        of [40] fills the cell's beam from the surface up to d_h = min(h_cloud, R_c φ_b)
        [43] whatever the target's own height, so only a cell's horizontal position decides
        (seed 4.1.4: "only inside the rain region"). Without a region every cell is in the
        rain and the map's own (attenuated) trip sum is read instead.
        """
        rain = self.scenario.environment.rain
        region = None if rain is None else rain.region
        reader = self._wx_trip_reader
        if rain is None or region is None or reader is None:
            raise RuntimeError("the folded rain power is read only with a rain region")
        az = geom.azimuth
        east0, north0 = antenna_en[:, 0], antenna_en[:, 1]
        sin_az, cos_az = np.sin(az), np.cos(az)

        gamma = self.rain_gamma_db_per_km
        centre = np.array([region.east_m, region.north_m])

        def one_trip(x: np.ndarray) -> np.ndarray:
            inside = np.hypot(east0 + x * sin_az - region.east_m,
                              north0 + x * cos_az - region.north_m) <= region.radius_m
            p = np.where(inside, np.nan_to_num(reader(x, az)[:, 0]), 0.0)
            if gamma > 0.0:
                path = weather_clutter.rain_path_to_cell_m(
                    x, az, antenna_en, self.radar.antenna_height_m, self.phi_b,
                    rain.cloud_base_m, centre, region.radius_m)
                p = p * weather_clutter.two_way_rain_transmission(gamma, path)
            return p

        return weather_clutter.range_folded_power_w(
            one_trip, geom.ground_range, self.radar.prf_hz, self.radar.instrumented_range_m)

    # ------------------------------------------------------------------ dwell
    def signal_to_interference(self, p_r: np.ndarray, clutter_w: np.ndarray,
                               jam_w: np.ndarray, improvement: np.ndarray | float,
                               dist_loss: np.ndarray | float,
                               coherent_gain: np.ndarray | float = 1.0
                               ) -> tuple[np.ndarray, np.ndarray]:
        """Per-pulse S/I [linear] and the dominant interference code [66]-[67].

        Clutter dominant: [67] gives the clutter residue after the processor, S/C G_p; the
        noise (and jamming) that passes the same filter, with its coherent gain against white
        noise, is added to it: S/I = 1 / (1/(S/C G_p ...) + 1/(S/N CG ...)).  Without this a
        target in clutter with I_F = 60 dB would read 60 dB above the same target in noise
        just outside the clutter; the sum keeps S/I below the filter's noise limit.
        """
        n = self.n0
        code = np.where(jam_w > 2.0 * (clutter_w + n), Interference.JAMMING,
                        np.where(clutter_w >= 0.5 * n, Interference.CLUTTER,
                                 Interference.NOISE)).astype(np.uint8)
        noise_like = p_r / ((n + jam_w) * self.l_x * self.l_cfar)
        # [67]: L_B is a loss (divides), as its name and Blake's 1.6 dB say
        residue_si = (p_r / (np.maximum(clutter_w, DB_FLOOR) * self.l_c)
                      * improvement / dist_loss / (self.l_cfar * self.l_cd * self.l_b))
        noise_after = noise_like * coherent_gain
        clutter_si = residue_si * noise_after / np.maximum(residue_si + noise_after, DB_FLOOR)
        si = np.where(code == Interference.CLUTTER, clutter_si, noise_like)
        return si, code

    def process_targets(self, geom: Geometry, rows: np.ndarray, t: np.ndarray,
                        tpos: np.ndarray, rng: np.random.Generator, *,
                        antenna_en: np.ndarray | None = None, jam_geom: Geometry | None = None,
                        jam_power_w: np.ndarray | None = None, batch: np.ndarray | None = None,
                        platform_vel: np.ndarray | None = None) -> dict:
        """Plots of the targets ``rows`` crossed by the beam at times ``t`` [s].

        ``geom`` is their :class:`shipradar.sim.world.kinematics.Geometry`, ``tpos`` their
        origin-frame positions (N, 3) [m] and ``antenna_en`` the platform's origin-frame east/north
        at each crossing (N, 2) [m] (default: the origin).  Returns the plot columns of the
        detected contacts, the truth links, and the counts ``missed``, ``merged`` and
        ``fallbacks``.

        ``jam_power_w`` (N,) [W], when given, replaces the jamming computed from ``jam_geom``
        (the engine computes it with the jammers where they are at each look's time), and
        ``batch`` (N,) integers keep targets of different batches (revolutions) from ever
        being merged as unresolved; contacts come out ordered by batch.  ``platform_vel``
        (N, 3) [m/s], the platform's instantaneous velocity at each look, moves the clutter
        mean and the motion compensation with a manoeuvring ship ([33]-[38]).

        With a Doppler bank each plot carries ``range_rate_mps``, the centre of the filter
        its strongest target is detected in, folded by the PRF
        (:meth:`range_rate_from_filter`), and ``sigma_range_rate_mps``; both NaN otherwise.

        The look runs as a chain of named steps (:mod:`shipradar.sim.dwell.look`), each a
        method a subclass may replace; after the detection draw every callback of
        :attr:`on_look` receives the look's :class:`~shipradar.sim.dwell.look.LookResults`.
        """
        look = self.look_geometry(geom, rows, t, tpos, antenna_en=antenna_en, batch=batch,
                                  platform_vel=platform_vel)
        prop = self.look_propagation(look)
        power = self.target_power(look, prop)
        clutter = self.clutter_at(geom, tpos, look.antenna_en, platform_vel)
        jam_w = self.look_jamming(look, jam_geom, jam_power_w)
        contacts = self.processing(look, power, clutter)
        lead = contacts.lead
        clutter_w = np.zeros(look.size) if clutter is None else clutter["power_w"]
        si, code = self.signal_to_interference(
            contacts.power_w, clutter_w[lead], jam_w[lead], contacts.improvement,
            contacts.distribution_loss, contacts.coherent_gain)
        n_e = self.effective_pulses(clutter, lead, code)
        si_db = db(si)
        pd = self.detection_probability(si_db, n_e, self.swerling[rows[lead]])
        hit = self.detection_draw(look, lead, pd, rng)
        decision = Decision(si, si_db, code, n_e, pd, hit)
        if self.on_look:
            results = self._look_results(look, prop, power, clutter_w, jam_w, contacts,
                                         decision)
            for observer in self.on_look:
                observer(results)
        return self.measurement(look, power, clutter, contacts, decision, rng,
                                fallbacks=prop.fallbacks)

    # ------------------------------------------------------------------ the look's steps
    def look_geometry(self, geom: Geometry, rows: np.ndarray, t: np.ndarray,
                      tpos: np.ndarray, *, antenna_en: np.ndarray | None = None,
                      batch: np.ndarray | None = None,
                      platform_vel: np.ndarray | None = None) -> Look:
        """The geometry step: the look's targets and where the antenna is (default: at the
        origin), as one :class:`~shipradar.sim.dwell.look.Look`."""
        radar_en = np.zeros((rows.size, 2)) if antenna_en is None else antenna_en
        return Look(geom, rows, t, tpos, radar_en, batch, platform_vel)

    def look_propagation(self, look: Look) -> Propagation:
        """The propagation step: F of every target [4]-[7] (:meth:`propagation_factor`) and
        the one-way atmospheric loss [16] (:meth:`atmospheric_loss`)."""
        geom, tpos = look.geom, look.position_m
        f, fallbacks = self.propagation_factor(geom.ground_range, tpos[:, 2], geom.elevation)
        l_atm = self.atmospheric_loss(geom.slant_range, geom.elevation, look.antenna_en,
                                      tpos[:, :2], tpos[:, 2])
        return Propagation(f, l_atm, fallbacks)

    def target_power(self, look: Look, prop: Propagation) -> TargetPower:
        """The target-power step: σ [15] (:meth:`cross_section`) and the echo power S at the
        RF input [2]-[3], with the two-way atmospheric loss L_atm² [16]."""
        geom = look.geom
        sigma = self.cross_section(look.rows, geom.los_enu, geom.velocity_enu)
        p_r = noise.received_power(self.k_r0 / prop.atmospheric_loss**2, sigma, prop.f,
                                   geom.slant_range)
        return TargetPower(sigma, p_r)

    def look_jamming(self, look: Look, jam_geom: Geometry | None = None,
                     jam_power_w: np.ndarray | None = None) -> np.ndarray:
        """The jamming step: P_j [W] at each target's beam azimuth [47]; ``jam_power_w`` when
        the caller computed it (the engine: the jammers at each look's time), else
        :meth:`jamming_power` from ``jam_geom``."""
        if jam_power_w is None:
            return self.jamming_power(look.geom.azimuth, jam_geom)
        return np.asarray(jam_power_w, dtype=float)

    def processing(self, look: Look, power: TargetPower, clutter: Clutter | None) -> Contacts:
        """The processing step: unresolved targets (2.2.1, :meth:`_resolution_groups`: looks
        of one dwell, within a range cell, a beamwidth and one Doppler filter of each other),
        each contact led by its strongest target, whose Doppler sets the processor's I_F
        [57], L_d [63]-[64] and coherent gain for the contact."""
        p_r = power.received_power_w
        group, n_groups = self._resolution_groups(look.geom, clutter, look.batch,
                                                  look.platform_vel, look.time_s, p_r)
        p_sum = np.bincount(group, weights=p_r, minlength=n_groups)
        lead = argmax_by_group(group, p_r, n_groups)
        if clutter is None:
            one = np.ones(n_groups)
            return Contacts(group, n_groups, lead, p_sum, one, one, one)
        return Contacts(group, n_groups, lead, p_sum, clutter["improvement"][lead],
                        clutter["distribution_loss"][lead], clutter["coherent_gain"][lead])

    def effective_pulses(self, clutter: Clutter | None, lead: np.ndarray,
                         code: np.ndarray) -> np.ndarray:
        """The N_e step: effective number of pulses [73]-[77] of each contact
        (:func:`shipradar.sensors.detection.effective_pulses`), clutter-dominated where the
        dominant interference ``code`` is clutter."""
        return np.asarray(detection.effective_pulses(
            self.n_pulses, clutter_dominated=code == Interference.CLUTTER,
            **self._pulse_args(clutter, lead)))

    def detection_probability(self, si_db: np.ndarray, n_e: np.ndarray,
                              swerling: np.ndarray) -> np.ndarray:
        """The P_d step: P_d of each contact at per-pulse S/I ``si_db`` [dB] over ``n_e``
        pulses, by the fidelity's ``pd_method``: the seed's [78]-[83], the exact Swerling
        P_d, or the exact P_d's table (:class:`shipradar.tables.pd.PdTables`)."""
        if self.method == "table":
            return np.asarray(self._pd_tables(si_db, n_e, swerling))
        return np.asarray(detection.probability_of_detection(
            si_db, self.pfa, n_e, swerling, method=self.method,
            integrator=self.radar.integrator, detector=self.radar.detector))

    def detection_draw(self, look: Look, lead: np.ndarray, pd: np.ndarray,
                       rng: np.random.Generator) -> np.ndarray:
        """Which contacts are detected: one uniform per contact below its P_d, from ``rng``
        or, when set, from :attr:`look_uniforms` (common random numbers, keyed on the lead
        target and its crossing time)."""
        if self.look_uniforms is None:
            return rng.random(pd.size) < pd
        return self.look_uniforms(look.rows[lead], look.time_s[lead]) < pd

    def measurement(self, look: Look, power: TargetPower, clutter: Clutter | None,
                    contacts: Contacts, decision: Decision, rng: np.random.Generator, *,
                    fallbacks: int = 0) -> dict:
        """The measurement step: the plot columns of the detected contacts [84]-[89].

        Each detected contact (``decision.hit``) is reported at the power-weighted range,
        azimuth and time of its targets (a single target: its own), measured with noise from
        its S/I and N_e (:func:`shipradar.sensors.measurement.measure`), with its
        range rate (:meth:`_range_rate_columns`), its lead target and every contributor (the
        truth links), and the counts ``missed``, ``merged`` and ``fallbacks``.
        """
        geom, rows, t = look.geom, look.rows, look.time_s
        group, n_groups, lead = contacts.group, contacts.n_groups, contacts.lead
        p_r, p_sum = power.received_power_w, contacts.power_w
        si, code, hit = decision.si, decision.interference, decision.hit
        w = p_r / np.maximum(p_sum[group], DB_FLOOR)
        r_true = np.bincount(group, weights=w * geom.slant_range, minlength=n_groups)
        az_c = np.bincount(group, weights=w * np.cos(geom.azimuth), minlength=n_groups)
        az_s = np.bincount(group, weights=w * np.sin(geom.azimuth), minlength=n_groups)
        az_true = np.mod(np.arctan2(az_s, az_c), 2.0 * np.pi)
        t_c = np.bincount(group, weights=w * t, minlength=n_groups)
        sel = np.flatnonzero(hit)
        meas = measurement.measure(
            r_true[sel], az_true[sel], si[sel], decision.n_e[sel], self.range_cell,
            self.theta_b, rng, h_range=self.radar.h_range, h_azimuth=self.radar.h_azimuth)
        # contributors of each reported contact
        counts = np.bincount(group, minlength=n_groups)
        if group.size == n_groups:  # one target per contact: the sort is the inverse
            order = np.empty(group.size, dtype=np.int64)
            order[group] = np.arange(group.size)
        else:
            order = np.argsort(group, kind="stable")
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        c_counts = counts[sel]
        c_off = np.concatenate([[0], np.cumsum(c_counts)]).astype(np.int64)
        gather = np.repeat(starts[sel], c_counts) + (
            np.arange(c_off[-1]) - np.repeat(c_off[:-1], c_counts))
        batch = look.batch
        return {
            pc.TIME_S: t_c[sel],
            pc.RANGE_M: meas[pc.RANGE_M],
            pc.AZIMUTH_RAD: meas[pc.AZIMUTH_RAD],
            pc.SNR_DB: decision.si_db[sel],
            pc.SIGMA_RANGE_M: meas[pc.SIGMA_RANGE_M],
            pc.SIGMA_AZIMUTH_RAD: meas[pc.SIGMA_AZIMUTH_RAD],
            pc.INTERFERENCE: code[sel],
            **self._range_rate_columns(geom, clutter, lead[sel], look.platform_vel),
            "target": rows[lead[sel]].astype(np.int32),
            "contrib_offsets": c_off,
            "contrib_targets": rows[order[gather]].astype(np.int32),
            **({} if batch is None else {"batch": np.asarray(batch)[lead[sel]]}),
            "missed": int(n_groups - sel.size),
            "merged": int(look.size - n_groups),
            "fallbacks": fallbacks,
        }

    def _look_results(self, look: Look, prop: Propagation, power: TargetPower,
                      clutter_w: np.ndarray, jam_w: np.ndarray, contacts: Contacts,
                      decision: Decision) -> LookResults:
        """The steps' results as one :class:`~shipradar.sim.dwell.look.LookResults`, every
        contact's value given to each of its targets."""
        group, d = contacts.group, decision
        geom = look.geom
        n = look.size
        return LookResults(
            radar=self.radar.id, target=look.rows, time_s=look.time_s,
            slant_range_m=geom.slant_range, ground_range_m=geom.ground_range,
            height_m=look.position_m[:, 2], sigma_m2=power.sigma_m2, f=prop.f,
            atmospheric_loss=prop.atmospheric_loss, received_power_w=power.received_power_w,
            noise_w=np.full(n, self.n0), clutter_w=clutter_w,
            jamming_w=np.broadcast_to(jam_w, (n,)).copy(),
            improvement=contacts.improvement[group], si=d.si[group], si_db=d.si_db[group],
            interference=d.interference[group], n_e=d.n_e[group], pd=d.pd[group],
            hit=d.hit[group], contact=group,
            merged=np.bincount(group, minlength=contacts.n_groups)[group] > 1,
            batch=None if look.batch is None else np.asarray(look.batch))

    def _range_rate_columns(self, geom: Geometry, clutter: Clutter | None, lead: np.ndarray,
                            platform_vel: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """``range_rate_mps``, ``sigma_range_rate_mps`` and ``range_rate_reference_mps`` of
        the contacts led by targets ``lead`` (NaN without a Doppler bank): the filter the
        model picks for the lead target (:meth:`doppler_filter` of its Doppler relative to
        the bank's reference, :meth:`_relative_doppler_hz`), reported at its centre plus the
        reference f_d - (f_d' - μ_c), which is published too."""
        if not self.has_doppler_bank:
            nan = np.full(lead.size, np.nan)
            return {pc.RANGE_RATE_MPS: nan, pc.SIGMA_RANGE_RATE_MPS: nan.copy(),
                    pc.RANGE_RATE_REFERENCE_MPS: nan.copy()}
        rel = self._relative_doppler_hz(geom, clutter, platform_vel)[lead]
        reference = -2.0 * geom.radial_velocity[lead] / self.wavelength - rel
        return {pc.RANGE_RATE_MPS: self.range_rate_from_filter(self.doppler_filter(rel),
                                                              reference),
                pc.SIGMA_RANGE_RATE_MPS: np.full(lead.size, self.range_rate_sigma_mps),
                pc.RANGE_RATE_REFERENCE_MPS: self.reference_mps(reference)}

    def _resolution_groups(self, geom: Geometry, clutter: Clutter | None,
                           batch: np.ndarray | None = None,
                           platform_vel: np.ndarray | None = None,
                           time_s: np.ndarray | float | None = None,
                           power_w: np.ndarray | None = None) -> tuple[np.ndarray, int]:
        """Contact index of each look and the number of contacts (seed 2.2.1).

        Two looks are unresolved when the beam makes them together and nothing tells them
        apart: crossing times within a dwell t_ot = θ_b/ω, slant ranges within a range cell
        C_R, azimuths within a beamwidth θ_b (across north too), the same Doppler filter
        and the same batch (revolution).  Contacts are formed greedily, strongest look
        first (``power_w``): a look joins the first contact, in the order they were opened,
        with every member of which it is unresolved, else opens one; so no contact holds
        two looks more than a dwell, a cell or a beamwidth apart.  Without ``time_s`` every
        look is taken as made at once.  Contacts are numbered (and so draw their random
        numbers) in the order of their lead look's (batch, range cell, azimuth cell,
        filter), then of the lead look itself.
        """
        n = geom.slant_range.size
        if n == 1:
            return np.zeros(1, dtype=np.int64), 1
        fc = self.doppler_filter(self._relative_doppler_hz(geom, clutter, platform_vel))
        t = np.zeros(n) if time_s is None else np.broadcast_to(np.asarray(time_s, float), (n,))
        bt = (np.zeros(n, dtype=np.int64) if batch is None
              else np.asarray(batch, dtype=np.int64))
        pairs = self._unresolved_pairs(geom.slant_range, geom.azimuth, fc, t, bt)
        group = np.arange(n, dtype=np.int64)
        if pairs[0].size:
            p = (np.ones(n) if power_w is None else np.asarray(power_w, float))
            group = _greedy_contacts(n, pairs, p)
        # numbered by the lead look's (batch, range cell, azimuth cell, filter), then by the
        # lead itself: contacts are numbered by their first look, the strongest, so a stable
        # sort on one integer key does it (the numbers the grid gave when no two looks merge)
        n_groups = int(group.max()) + 1
        lead = (np.arange(n) if n_groups == n
                else argmax_by_group(group, np.ones(n) if power_w is None
                                      else np.asarray(power_w, float), n_groups))
        rc = np.floor(geom.slant_range[lead] / self.range_cell).astype(np.int64)
        ac = np.floor(geom.azimuth[lead] / self.theta_b).astype(np.int64)
        f = fc[lead]
        n_ac, n_fc = int(ac.max()) + 1, int(f.max()) + 1
        keys = (rc * n_ac + ac) * n_fc + f
        if batch is not None:
            keys = bt[lead] * (int(keys.max()) + 1) + keys
        order = np.argsort(keys, kind="stable")
        rank = np.empty(n_groups, dtype=np.int64)
        rank[order] = np.arange(n_groups)
        return rank[group], n_groups

    def _unresolved_pairs(self, range_m: np.ndarray, azimuth_rad: np.ndarray,
                          filt: np.ndarray, t: np.ndarray, batch: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray]:
        """The pairs (i, j), i < j, of looks the radar cannot tell apart (see
        :meth:`_resolution_groups`): found among the looks within a dwell of each other in
        time, sorted."""
        t_ot = float(geometry.sweep_time(self.theta_b, self.radar.scan_period_s))
        # one line of time, the batches apart by more than a dwell
        t0 = float(t.min())
        key = batch * (float(t.max()) - t0 + 2.0 * t_ot + 1.0) + (t - t0)
        order = np.argsort(key, kind="stable")
        key = key[order]
        end = np.searchsorted(key, key + t_ot, side="right")
        count = end - np.arange(key.size) - 1
        if not count.any():
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        a = np.repeat(np.arange(key.size), count)
        b = a + 1 + (np.arange(a.size) - np.repeat(np.cumsum(count) - count, count))
        i, j = order[a], order[b]
        near = ((batch[i] == batch[j]) & (np.abs(t[i] - t[j]) <= t_ot)
                & (np.abs(range_m[i] - range_m[j]) < self.range_cell)
                & (np.abs(wrap_pi(azimuth_rad[i] - azimuth_rad[j])) < self.theta_b)
                & (filt[i] == filt[j]))
        i, j = i[near], j[near]
        return np.minimum(i, j), np.maximum(i, j)

    def doppler_filter(self, doppler_hz: np.ndarray) -> np.ndarray:
        """Doppler filter index of each target (0 for a radar without a filter bank).

        The bank has ``n_filters`` filters, by default as many as it has taps: N_c for a DFT
        or FIR bank, N_c - N_pc behind an N_pc-order canceller (as the I_F table is built,
        :func:`shipradar.tables.scene.improvement_kwargs`).  ``doppler_hz`` is the target's Doppler
        after motion compensation relative to the clutter mean [Hz], the reference of the
        I_F table (:meth:`target_doppler_hz`, ``clutter_at(...)["doppler_relative_hz"]``).
        """
        if not self.has_doppler_bank:
            return np.zeros(np.shape(doppler_hz), dtype=np.int64)
        return np.asarray(doppler_filters.doppler_filter_index(
            doppler_hz, self.radar.prf_hz, self.n_doppler_filters), dtype=np.int64)

    def _pulse_args(self, clutter: Clutter | None, lead: np.ndarray) -> dict[str, Any]:
        """Keyword arguments of :func:`shipradar.sensors.detection.effective_pulses` for [74]-[77]:
        ``mti_order`` N_pc for an MTI (alone or feeding a bank), ``n_coherent`` N_c for a
        bank (an ``mti_bank``'s N_c counts the whole cascade, N_pc + its bank's taps, as
        ``effective_pulses`` expects)."""
        proc = self.radar.processor
        spread = np.zeros(lead.size) if clutter is None else clutter["spread_mps"][lead]
        return {
            "clutter_velocity_spread_mps": spread,
            "wavelength_m": self.wavelength,
            "prf_hz": self.radar.prf_hz,
            "beamwidth_rad": self.theta_b,
            "rotation_rate_rad_s": 2.0 * math.pi / self.radar.scan_period_s,
            "pulses_per_frequency": self.radar.pulses_per_frequency,
            "mti_order": proc.mti_order if proc.type in ("mti", "mti_bank") else 0,
            "n_coherent": proc.n_coherent if proc.type in ("dft_bank", "fir_bank", "mti_bank")
            else 1,
        }

def _greedy_contacts(n: int, pairs: tuple[np.ndarray, np.ndarray],
                     power: np.ndarray) -> np.ndarray:
    """Contact index of each of ``n`` looks given the ``pairs`` (i, j) the radar cannot tell
    apart: strongest look first (then by index), each joins the first contact opened whose
    every member it is paired with, else opens one.  Looks in no pair are contacts of
    their own; only the others are visited one by one."""
    group = np.arange(n, dtype=np.int64)
    i, j = pairs
    linked = np.unique(np.concatenate([i, j]))
    with_: dict[int, set[int]] = {int(k): set() for k in linked}
    for a, b in zip(i.tolist(), j.tolist(), strict=True):
        with_[a].add(b)
        with_[b].add(a)
    contacts: list[list[int]] = []
    contact_of: dict[int, int] = {}
    for k in linked[np.lexsort((linked, -power[linked]))].tolist():
        near = with_[k]
        # a contact k may join holds one of its pairs at least: the first opened of those
        for c in sorted({contact_of[m] for m in near if m in contact_of}):
            if near.issuperset(contacts[c]):
                contacts[c].append(k)
                contact_of[k] = c
                group[k] = contacts[c][0]
                break
        else:
            contact_of[k] = len(contacts)
            contacts.append([k])
    # contiguous numbers 0..m-1, in the order of the looks' first member
    _, group = np.unique(group, return_inverse=True)
    return group.ravel().astype(np.int64)


def argmax_by_group(group: np.ndarray, value: np.ndarray, n_groups: int) -> np.ndarray:
    """Index of the largest ``value`` in each group (the first of equals; groups numbered
    0 .. n_groups - 1, each with a member)."""
    out = np.empty(n_groups, dtype=np.int64)
    counts = np.bincount(group, minlength=n_groups)
    alone = counts.take(group) == 1
    if alone.all():  # every target its own contact (nothing unresolved): no sort
        out[group] = np.arange(group.size)
        return out
    # the sort by (group, -value) only over the members of shared groups: a group's order,
    # hence its first, is the same among its own members as among all targets
    single = np.flatnonzero(alone)
    out[group.take(single)] = single
    shared = np.flatnonzero(~alone)
    order = shared.take(np.lexsort((-value.take(shared), group.take(shared))))
    g = group.take(order)
    first = np.ones(order.size, dtype=bool)
    first[1:] = g[1:] != g[:-1]
    out[g[first]] = order[first]
    return out
