"""Per-radar constants of a scene: the quantities of [3], [17]-[20], [46] and [66]-[67] that
do not change during a run, shared by the on-line dwell model and the table builders.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from shipradar.sensors import antenna, detection, noise
from shipradar.sim.world.scenario import Radar, Scenario

__all__ = ["RadarConstants", "false_alarm_probability", "pulses_per_beamwidth",
           "radar_constants", "sky_temperature_args"]


@dataclass(frozen=True)
class RadarConstants:
    """Per-radar quantities that do not change during a run (shared with the table builders).

    Attributes: wavelength λ [m]; gain G and L_t/r (power ratios); K_r of [3] without the
    atmospheric loss [W m²]; T_a, T_s [K] ([17]-[18]); N0' [W] ([19]); B_N [Hz]; range cell
    C_R [m]; θ_b, φ_b and the elevation tilt [rad]; the losses L_x, L_c, L_CFAR, L_cd, L_B, L_r
    (power ratios).
    """

    wavelength: float
    gain: float
    l_tr: float
    k_r0: float
    t_a: float
    t_s: float
    n0: float
    bandwidth: float
    range_cell: float
    theta_b: float
    phi_b: float
    tilt: float
    l_x: float
    l_c: float
    l_cfar: float
    l_cd: float
    l_b: float
    l_r: float

    def elevation_pattern(self, radar: Radar) -> Callable[[ArrayLike], NDArray[np.float64]]:
        """The radar's elevation directivity g_el(elevation [rad]) (field) [8]-[14]."""
        pe = radar.pattern_el
        phi_b, tilt = self.phi_b, self.tilt

        def g(elevation_rad: ArrayLike) -> NDArray[np.float64]:
            return antenna.elevation_directivity(elevation_rad, phi_b, pe.type,
                                                 sidelobe_db=pe.sidelobe_db, tilt_rad=tilt)

        return g

    def pattern_key(self, radar: Radar) -> tuple:
        """Hashable description of :meth:`elevation_pattern` for table cache keys."""
        return (radar.pattern_el.type, self.phi_b, radar.pattern_el.sidelobe_db, self.tilt)


def sky_temperature_args(scenario: Scenario, radar: Radar) -> dict[str, Any]:
    """The arguments of :func:`shipradar.sensors.noise.sky_temperature_k` for a radar's T'_a.

    Blake's T'_a is for the beam axis: the sky model at the beam maximum, at least 0°, in the
    scene's surface weather.  Frequency [Hz], elevation [rad], temperature [K], pressure
    [hPa], water vapour [g/m³], antenna height [m].
    """
    env = scenario.environment
    phi_b = math.radians(radar.beamwidth_el_deg)
    pe = radar.pattern_el
    tilt = math.radians(pe.tilt_deg) if pe.tilt_deg is not None else 0.5 * phi_b
    return {"freq_hz": radar.frequency_hz, "elevation_rad": max(tilt, 0.0),
            "surface_temperature_k": env.temperature_c + 273.15,
            "pressure_hpa": env.pressure_hpa,
            "water_vapour_density_g_m3": env.water_vapour_g_m3,
            "antenna_height_m": radar.antenna_height_m}


def radar_constants(scenario: Scenario, radar: Radar, *,
                    sky_temperature_k: float | None = None) -> RadarConstants:
    """The :class:`RadarConstants` of a radar in a scene ([3], [17]-[20], [46], [66]-[67]).

    ``sky_temperature_k``: T'_a [K] of :func:`sky_temperature_args` when already known (the
    table store keeps it, :func:`shipradar.tables.sky.scene_radar_constants`: computing it
    imports itur, 0.3-0.6 s, and runs a nested quadrature); computed here otherwise.
    """
    wavelength = constants.c / radar.frequency_hz
    gain = float(noise.power_ratio(radar.gain_db))
    l_tr = float(noise.power_ratio(radar.loss_tr_db))
    los = radar.losses
    l_x = float(noise.processing_loss(los.range_gate_db, los.limiter_db, los.matching_db))
    phi_b = math.radians(radar.beamwidth_el_deg)
    pe = radar.pattern_el
    tilt = math.radians(pe.tilt_deg) if pe.tilt_deg is not None else 0.5 * phi_b
    l_r = float(noise.receive_loss(l_tr))
    bandwidth = float(noise.noise_bandwidth_hz(radar.pulse_width_s))
    if radar.antenna_temperature_k is not None:
        t_a = float(radar.antenna_temperature_k)
    else:
        t_sky = (noise.sky_temperature_k(**sky_temperature_args(scenario, radar))
                 if sky_temperature_k is None else sky_temperature_k)
        t_a = float(noise.antenna_temperature_k(t_sky))
    t_s = float(noise.system_noise_temperature_k(
        t_a, l_r, noise.power_ratio(radar.noise_figure_db)))
    return RadarConstants(
        wavelength=wavelength,
        gain=gain,
        l_tr=l_tr,
        # pulse compression (not in the seed, which takes P_t as given): the matched filter
        # gains τ/τ' on every echo, target or clutter cell, while B_N = 1/τ' [19] sets the noise
        k_r0=float(noise.radar_constant(radar.peak_power_w * radar.compression_ratio, gain,
                                        wavelength, l_tr)),
        t_a=t_a,
        t_s=t_s,
        n0=float(noise.noise_power_w(t_s, bandwidth)),
        bandwidth=bandwidth,
        range_cell=float(noise.range_cell_m(radar.pulse_width_s)),
        theta_b=math.radians(radar.beamwidth_az_deg),
        phi_b=phi_b,
        tilt=tilt,
        l_x=l_x,
        l_c=l_x * float(noise.power_ratio(los.clutter_extra_db)),
        l_cfar=float(noise.power_ratio(los.cfar_db)),
        l_cd=float(noise.power_ratio(los.clutter_distribution_db)),
        l_b=float(noise.power_ratio(los.beam_shape_db)),
        l_r=l_r,
    )


def false_alarm_probability(radar: Radar) -> float:
    """P_fa of a radar for one reported false alarm per t_fa [-], seed [68]-[72].

    :func:`shipradar.sensors.detection.pfa_from_false_alarm_time` over the reported decisions
    (N_ch channels in the range gates inside the instrumented range): the one P_fa that the
    dwell model, the P_fac map and the P_d table all use. The schema refuses a t_fa that
    would make it 1 or more.  Computed once per process and set of the seven numbers it
    depends on (~50 us of numpy a call, at every run's construction).
    """
    return _false_alarm_probability(
        radar.false_alarm_time_s, radar.beamwidth_az_deg, radar.scan_period_s, radar.prf_hz,
        radar.pulse_width_s, radar.n_channels, radar.instrumented_range_m)


@functools.lru_cache(maxsize=64)
def _false_alarm_probability(t_fa_s: float, beamwidth_az_deg: float, scan_period_s: float,
                             prf_hz: float, pulse_width_s: float, n_channels: int,
                             instrumented_range_m: float) -> float:
    """:func:`false_alarm_probability` of these radar fields: a pure function of them (the
    cache key is the values, not the radar object)."""
    return float(detection.pfa_from_false_alarm_time(
        t_fa_s, math.radians(beamwidth_az_deg), scan_period_s, prf_hz, pulse_width_s,
        n_channels=n_channels, instrumented_range_m=instrumented_range_m))


def pulses_per_beamwidth(radar: Radar) -> float:
    """N_n of a radar, pulses per beam sweep of a point target [-], seed [73], >= 1.

    The schema refuses fewer than one pulse (to 1e-9,
    :data:`shipradar.sim.world.scenario.PULSES_PER_BEAM_ULP`); exactly one, which θ_b t_scan f_r /
    2π can round to 1 - 1e-16, is one.
    """
    return max(1.0, float(detection.pulses_per_beam(
        math.radians(radar.beamwidth_az_deg), radar.scan_period_s, radar.prf_hz)))
