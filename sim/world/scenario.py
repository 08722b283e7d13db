"""Scenario schema (pydantic v2) and safe YAML loading.

This module is the single declaration of every scenario parameter: type, default, unit (in
the field name or its description) and allowed range (STYLE lesson 5).  A scenario is
validated once, at load time, and handed inward as frozen, typed objects.  Variants (antenna
pattern, RCS model, Doppler processor, ...) are chosen by a ``type:`` field.

Symbols of the seed (DREV-R-9429, "list of symbols") are given in each field's description.
"""

from __future__ import annotations

import datetime as dt
import math
import re
from pathlib import Path
from typing import Annotated, Any, Literal

import yaml
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)
from pydantic_core import ErrorDetails

from shipradar.sensors.geometry import (
    EARTH_RADIUS_M,
    pulses_per_beam,
    shortest_false_alarm_time_s,
    sweep_time,
)

#: Largest scenario file we agree to read [bytes].
MAX_SCENARIO_BYTES = 4 * 1024 * 1024
#: Largest number of YAML nodes a scenario may expand to, aliases included.
MAX_YAML_NODES = 2_000_000


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)


# --------------------------------------------------------------------------- geometry
class Origin(_Model):
    """Geodetic origin of the scenario's local east/north/up frame (WGS-84)."""

    lat_deg: float = Field(ge=-89.0, le=89.0, description="latitude [deg]")
    lon_deg: float = Field(ge=-180.0, le=180.0, description="longitude [deg]")
    alt_m: float = Field(0.0, ge=-500.0, le=10_000.0, description="height above the ellipsoid [m]")


class Waypoint(_Model):
    """A timed position: local east/north from the origin, or latitude/longitude.

    Give either ``east_m`` and ``north_m`` or ``lat_deg`` and ``lon_deg``.  Motion between
    waypoints is at constant velocity in the origin's local frame.
    """

    time_s: float = Field(0.0, ge=0.0, le=1.0e7, description="time since scenario start [s]")
    east_m: float | None = Field(None, ge=-2.0e6, le=2.0e6, description="east of origin [m]")
    north_m: float | None = Field(None, ge=-2.0e6, le=2.0e6, description="north of origin [m]")
    lat_deg: float | None = Field(None, ge=-89.0, le=89.0, description="latitude [deg]")
    lon_deg: float | None = Field(None, ge=-180.0, le=180.0, description="longitude [deg]")
    altitude_m: float = Field(0.0, ge=0.0, le=30_000.0, description="height above the sea [m]")

    @model_validator(mode="after")
    def _one_position_form(self) -> Waypoint:
        enu = self.east_m is not None or self.north_m is not None
        geo = self.lat_deg is not None or self.lon_deg is not None
        if enu == geo:
            raise ValueError("give either east_m and north_m, or lat_deg and lon_deg")
        if enu and (self.east_m is None or self.north_m is None):
            raise ValueError("east_m and north_m must be given together")
        if geo and (self.lat_deg is None or self.lon_deg is None):
            raise ValueError("lat_deg and lon_deg must be given together")
        return self

    @property
    def east_north_m(self) -> tuple[float, float] | None:
        """(east, north) [m] of a waypoint given in the local frame, else None."""
        if self.east_m is None or self.north_m is None:
            return None
        return self.east_m, self.north_m

    @property
    def lat_lon_deg(self) -> tuple[float, float] | None:
        """(latitude, longitude) [deg] of a waypoint given in geodetic form, else None."""
        if self.lat_deg is None or self.lon_deg is None:
            return None
        return self.lat_deg, self.lon_deg


def _check_waypoint_times(waypoints: list[Waypoint]) -> list[Waypoint]:
    times = [w.time_s for w in waypoints]
    for i in range(1, len(times)):
        if times[i] <= times[i - 1]:
            raise ValueError(
                f"waypoint times must increase strictly, got {times[i - 1]} then {times[i]}"
            )
    return waypoints


# --------------------------------------------------------------------------- manoeuvres
#: Standard gravity [m/s²], the unit of the turn and acceleration loads (scipy.constants.g).
STANDARD_GRAVITY = 9.80665
#: Sharpest waypoint corner that smoothing rounds [deg] (a reversal has no tangent arc).
MAX_SMOOTHED_CORNER_DEG = 175.0


class StraightSegment(_Model):
    """Straight and level at the current speed and heading."""

    type: Literal["straight"] = "straight"
    duration_s: float = Field(gt=0.0, le=1.0e6, description="duration [s]")


class TurnSegment(_Model):
    """Coordinated level turn at constant speed: radius v²/(g n), rate g n / v.

    Give the load (``turn_g``, the horizontal acceleration in g; the bank angle's load factor
    is √(1 + n²)) or the rate, and where to stop (a heading or a duration).
    """

    type: Literal["turn"] = "turn"
    turn_g: float | None = Field(
        None, gt=0.0, le=60.0, description="n, horizontal acceleration v²/R in g [g]")
    turn_rate_deg_s: float | None = Field(
        None, gt=0.0, le=180.0, description="turn rate [deg/s] (instead of turn_g)")
    to_heading_deg: float | None = Field(
        None, ge=0.0, lt=360.0, description="heading at the end of the turn (true north) [deg]")
    duration_s: float | None = Field(
        None, gt=0.0, le=1.0e6, description="duration [s] (instead of to_heading_deg)")
    direction: Literal["shortest", "left", "right"] = Field(
        "shortest", description="turn direction; 'shortest' needs to_heading_deg")

    @model_validator(mode="after")
    def _one_of_each(self) -> TurnSegment:
        if (self.turn_g is None) == (self.turn_rate_deg_s is None):
            raise ValueError("give one of turn_g or turn_rate_deg_s")
        if (self.to_heading_deg is None) == (self.duration_s is None):
            raise ValueError("give one of to_heading_deg or duration_s")
        if self.duration_s is not None and self.direction == "shortest":
            raise ValueError("a turn for a duration needs direction: left or right")
        return self


class AccelerateSegment(_Model):
    """Straight and level, speed changing at a constant rate to a new speed."""

    type: Literal["accelerate"] = "accelerate"
    to_speed_mps: float = Field(ge=0.0, le=3000.0, description="speed at the end [m/s]")
    accel_g: float | None = Field(
        None, gt=0.0, le=100.0, description="|acceleration| [g] (or duration_s)")
    duration_s: float | None = Field(None, gt=0.0, le=1.0e6, description="duration [s]")

    @model_validator(mode="after")
    def _one_of(self) -> AccelerateSegment:
        if (self.accel_g is None) == (self.duration_s is None):
            raise ValueError("give one of accel_g or duration_s")
        return self


class ClimbSegment(_Model):
    """Climb or dive on a straight course at constant path speed, the altitude following
    half a cosine (vertical speed zero at both ends, so joins stay smooth)."""

    type: Literal["climb"] = "climb"
    to_altitude_m: float = Field(ge=0.0, le=30_000.0, description="altitude at the end [m]")
    duration_s: float = Field(gt=0.0, le=1.0e5, description="duration [s]")


class WeaveSegment(_Model):
    """Sinusoidal weave at constant speed: lateral offset A (1 - cos 2πτ/P) from the entry
    course, first to ``first_side``; back on the entry line and course after whole periods."""

    type: Literal["weave"] = "weave"
    amplitude_m: float = Field(gt=0.0, le=10_000.0, description="A, half the peak-to-peak "
                               "lateral excursion [m]")
    period_s: float = Field(gt=0.2, le=3600.0, description="P, weave period [s]")
    duration_s: float = Field(gt=0.0, le=1.0e6, description="duration [s] (whole periods "
                              "end on the entry course)")
    first_side: Literal["right", "left"] = "right"


class PopupSegment(_Model):
    """Terminal pop-up and dive: a half-cosine climb to the apex then a half-cosine dive,
    on a straight course at constant path speed."""

    type: Literal["popup"] = "popup"
    peak_altitude_m: float = Field(gt=0.0, le=30_000.0, description="apex altitude [m]")
    climb_s: float = Field(gt=0.0, le=1000.0, description="climb duration [s]")
    dive_s: float = Field(gt=0.0, le=1000.0, description="dive duration [s]")
    to_altitude_m: float | None = Field(
        None, ge=0.0, le=30_000.0,
        description="altitude at the end of the dive [m]; default the altitude before it")


Segment = Annotated[
    StraightSegment | TurnSegment | AccelerateSegment | ClimbSegment | WeaveSegment
    | PopupSegment, Field(discriminator="type")]


class Smoothing(_Model):
    """Round waypoint corners with coordinated turns instead of jumping."""

    turn_g: float = Field(gt=0.0, le=60.0, description="n, horizontal acceleration of the "
                          "corner turns and of the speed changes between legs [g]")


def _leg_length_m(a: Waypoint, b: Waypoint) -> float | None:
    """Horizontal distance between two waypoints of the same form [m] (haversine on the mean
    sphere for latitude/longitude, within 0.5 % of the ellipsoid); None for mixed forms."""
    ea, eb = a.east_north_m, b.east_north_m
    if ea is not None and eb is not None:
        return math.hypot(eb[0] - ea[0], eb[1] - ea[1])
    ga, gb = a.lat_lon_deg, b.lat_lon_deg
    if ga is not None and gb is not None:
        p1, p2 = math.radians(ga[0]), math.radians(gb[0])
        dl = math.radians(gb[1] - ga[1])
        h = math.sin(0.5 * (p2 - p1)) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(0.5 * dl) ** 2
        return 2.0 * EARTH_RADIUS_M * math.asin(min(1.0, math.sqrt(h)))
    return None


def _leg_course(a: Waypoint, b: Waypoint) -> float | None:
    """Course from a to b [rad, clockwise from north] (initial bearing for lat/lon); None for
    mixed forms."""
    ea, eb = a.east_north_m, b.east_north_m
    if ea is not None and eb is not None:
        return math.atan2(eb[0] - ea[0], eb[1] - ea[1])
    ga, gb = a.lat_lon_deg, b.lat_lon_deg
    if ga is not None and gb is not None:
        p1, p2 = math.radians(ga[0]), math.radians(gb[0])
        dl = math.radians(gb[1] - ga[1])
        return math.atan2(math.sin(dl) * math.cos(p2),
                          math.cos(p1) * math.sin(p2) - math.sin(p1) * math.cos(p2) * math.cos(dl))
    return None


def corner_needs(waypoints: list[Waypoint], turn_g: float) -> list[tuple[float, float]]:
    """Horizontal distance [m] that rounding each waypoint corner takes (before it on the
    incoming leg, after it on the outgoing leg), one pair per waypoint (0 at the ends).

    A corner between legs of horizontal speeds s1, s2 and courses differing by Δψ is a turn at
    s1 of radius R = s1²/(g n), tangent to both legs at R tan(|Δψ|/2) from the waypoint,
    followed by a speed change at n g on the outgoing leg (|s2² - s1²|/(2 n g)); a leg that
    stops or starts from rest has only the speed change (on the moving leg); the same
    geometry as :mod:`shipradar.sim.world.trajectory`, which builds the pieces.
    """
    g = STANDARD_GRAVITY * turn_g
    w = waypoints
    out = [(0.0, 0.0)] * len(w)
    for j in range(1, len(w) - 1):
        l1, l2 = _leg_length_m(w[j - 1], w[j]), _leg_length_m(w[j], w[j + 1])
        c1, c2 = _leg_course(w[j - 1], w[j]), _leg_course(w[j], w[j + 1])
        if l1 is None or l2 is None or c1 is None or c2 is None:  # legs of mixed forms
            continue
        s1 = l1 / (w[j].time_s - w[j - 1].time_s)
        s2 = l2 / (w[j + 1].time_s - w[j].time_s)
        before = after = 0.0
        if s1 > 0 and s2 > 0:
            dpsi = abs(math.remainder(c2 - c1, 2 * math.pi))
            d = s1 * s1 / g * math.tan(0.5 * dpsi)
            before, after = d, d
        speed_change = abs(s2 * s2 - s1 * s1) / (2.0 * g)
        if s2 > 0:
            after += speed_change
        else:
            before += speed_change
        out[j] = (before, after)
    return out


def _check_motion(obj: Target | Platform, prefix: str = "") -> None:
    """Segments and smoothing of a target or platform: consistent, and flyable at every
    point (weave and climb slopes below the speed, loads only when moving, corners that fit
    their legs).  Messages start with the field's path relative to the object."""
    segs, smooth = obj.segments, obj.smoothing
    if smooth is not None and segs:
        raise ValueError(".smoothing: rounds waypoint corners; segments are smooth already "
                         "(remove one)")
    if smooth is not None:
        wps = obj.waypoints
        for j in range(len(wps)):
            if j == 0 or j >= len(wps) - 1:
                continue
            c1 = _leg_course(wps[j - 1], wps[j])
            c2 = _leg_course(wps[j], wps[j + 1])
            if c1 is not None and c2 is not None and _leg_length_m(wps[j - 1], wps[j]) and \
                    _leg_length_m(wps[j], wps[j + 1]):
                turn = abs(math.degrees(math.remainder(c2 - c1, 2 * math.pi)))
                if turn > MAX_SMOOTHED_CORNER_DEG:
                    raise ValueError(
                        f".waypoints[{j}]: smoothing rounds corners up to "
                        f"{MAX_SMOOTHED_CORNER_DEG:g}° (a reversal has no tangent turn), "
                        f"got {turn:.1f}°")
        needs = corner_needs(wps, smooth.turn_g)
        for j in range(len(wps) - 1):
            length = _leg_length_m(wps[j], wps[j + 1])
            need = needs[j][1] + needs[j + 1][0]
            if length is None or need <= length * (1.0 + 1e-9):
                continue
            n_min = smooth.turn_g * need / length if length > 0 else math.inf
            raise ValueError(
                f".smoothing.turn_g: rounding the corners of leg waypoints[{j}] -> "
                f"waypoints[{j + 1}] takes {need:.0f} m, the leg is {length:.0f} m; must be "
                f">= {n_min:.3g} g (or space the waypoints), got {smooth.turn_g:g}")
        return
    if not segs:
        return
    if len(obj.waypoints) != 1:
        raise ValueError(f".waypoints: with segments, give exactly 1 waypoint (the start), "
                         f"got {len(obj.waypoints)}")
    if obj.speed_mps is None:
        raise ValueError(".speed_mps: is required with segments (the start speed [m/s])")
    v, z = obj.speed_mps, obj.waypoints[0].altitude_m
    for j, s in enumerate(segs):
        where = f".segments[{j}]"
        if s.type == "turn" and s.turn_g is not None and v <= 0.0:
            raise ValueError(f"{where}.turn_g: a turn by load needs a speed > 0 m/s (use "
                             f"turn_rate_deg_s to pivot), got speed {v:g} m/s")
        elif s.type == "accelerate":
            v = s.to_speed_mps
        elif s.type == "weave":
            lateral = s.amplitude_m * 2.0 * math.pi / s.period_s
            if lateral >= v:
                raise ValueError(
                    f"{where}.amplitude_m: a weave of period {s.period_s:g} s at "
                    f"{v:g} m/s must have amplitude < {v * s.period_s / (2 * math.pi):.4g} m "
                    f"(lateral speed 2πA/P below the speed), got {s.amplitude_m:g}")
        elif s.type in ("climb", "popup"):
            legs = ([(s.to_altitude_m, s.duration_s, "duration_s")] if s.type == "climb" else
                    [(s.peak_altitude_m, s.climb_s, "climb_s"),
                     (z if s.to_altitude_m is None else s.to_altitude_m, s.dive_s, "dive_s")])
            for z_to, dur, name in legs:
                vz = 0.5 * abs(z_to - z) * math.pi / dur
                if vz > 0.0 and v <= 0.0:
                    raise ValueError(
                        f"{where}.{name}: changing altitude {z:g} -> {z_to:g} m needs a path "
                        f"speed > 0 (the climb is along the course at the current speed; "
                        f"accelerate first), got speed {v:g} m/s")
                if vz >= v:
                    raise ValueError(
                        f"{where}.{name}: changing altitude {z:g} -> {z_to:g} m at {v:g} m/s "
                        f"must take > {0.5 * abs(z_to - z) * math.pi / v:.4g} s (peak "
                        f"vertical speed πΔh/2T below the speed), got {dur:g}")
                z = z_to


def _max_altitude(obj: Target | Platform | Jammer) -> float:
    """Highest altitude an object reaches [m]: its waypoints, climbs and pop-up apexes."""
    top = max(w.altitude_m for w in obj.waypoints)
    for s in getattr(obj, "segments", ()):
        if s.type == "climb":
            top = max(top, s.to_altitude_m)
        elif s.type == "popup":
            top = max(top, s.peak_altitude_m)
    return top


# --------------------------------------------------------------------------- radar
#: Slack on "at least one pulse per beamwidth" for the rounding of θ_b t_scan f_r / (2π): a
#: radar with exactly one pulse per beamwidth (0.9 deg, 90 rpm, 600 Hz gives 1 - 1.1e-16)
#: is accepted, and the dwell model counts it as one
#: (shipradar.sim.dwell.model.DwellModel.n_pulses).
PULSES_PER_BEAM_ULP = 1e-9
#: c [m/s] (scipy.constants.c; the schema imports nothing heavy)
SPEED_OF_LIGHT_MPS = 299_792_458.0

class AzimuthPattern(_Model):
    """Azimuth cut of the antenna directivity ([8]-[13])."""

    type: Literal["isotropic", "gaussian", "sinc"] = "sinc"
    sidelobe_db: float = Field(
        25.0, ge=13.26, le=60.0, description="S_L, sidelobe level below the main beam [dB] (sinc)"
    )
    jamming_sidelobe_db: float | None = Field(
        None, ge=3.0, le=90.0,
        description="L_sl of [47]: the azimuth sidelobe level below the main beam that a jammer "
        "outside the main beam sees, a floor under the pattern (far sidelobes, backlobe) [dB]; "
        "default S_L (sidelobe_db), the pattern's first sidelobe level, as the seed intends",
    )


class ElevationPattern(_Model):
    """Elevation cut of the antenna directivity ([8]-[14])."""

    type: Literal["isotropic", "gaussian", "sinc", "cosec2"] = "cosec2"
    sidelobe_db: float = Field(
        20.0, ge=13.26, le=60.0, description="S_L, sidelobe level below the main beam [dB]"
    )
    tilt_deg: float | None = Field(
        None, ge=-10.0, le=45.0,
        description="elevation of the beam maximum φ_tilt [deg]; default half the beamwidth",
    )


class Window(_Model):
    """Data window of a Doppler filter bank [62] (scipy.signal.windows)."""

    type: Literal["rectangular", "hann", "hamming", "taylor", "chebyshev"] = "hann"
    sidelobe_db: float = Field(
        40.0, ge=13.0, le=120.0, description="design sidelobe level [dB] (taylor, chebyshev)"
    )


class Processor(_Model):
    """Doppler processing (seed chapter 5): MTI [58], DFT/FIR bank [59]-[62], cascade [61]."""

    type: Literal["none", "mti", "dft_bank", "fir_bank", "mti_bank"] = "mti"
    mti_order: int = Field(2, ge=1, le=6, description="N_pc: MTI canceller order (pulses - 1)")
    n_coherent: int = Field(
        8, ge=2, le=256, description="N_c: pulses coherently integrated by the bank"
    )
    n_filters: int | None = Field(
        None, ge=1, le=256, description="filters in the bank; default N_c (a full DFT bank)"
    )
    window: Window = Window()
    motion_compensated: bool = Field(
        True, description="platform motion removed from the clutter Doppler (μ_c = 0, [35])"
    )

    @property
    def bank_taps(self) -> int:
        """Taps of the filter bank [1]: N_c, less the N_pc pulses the MTI of a cascade takes
        ([61]: the cascade's weights are the convolution of both, N_c taps in all)."""
        return self.n_coherent - (self.mti_order if self.type == "mti_bank" else 0)

    @model_validator(mode="after")
    def _bank_fits(self) -> Processor:
        # the rules the I_F builder (tables/improvement.py) and the bank's weights
        # (sensors/doppler_filters.py) need, checked here so that validate and run agree
        if self.type not in ("dft_bank", "fir_bank", "mti_bank"):
            return self
        taps = self.bank_taps
        if taps < 1:
            raise ValueError(
                f".n_coherent: an mti_bank's {self.n_coherent} pulses leave no tap for the bank "
                f"after its order-{self.mti_order} MTI (mti_order); n_coherent must be > "
                f"mti_order, got n_coherent {self.n_coherent}, mti_order {self.mti_order}")
        if self.type == "dft_bank" and self.n_filters is not None and self.n_filters != taps:
            raise ValueError(
                f".n_filters: a DFT bank has as many filters as taps (n_coherent {taps}); "
                f"leave n_filters out or use type fir_bank for another count, got "
                f"{self.n_filters}")
        if self.window.type == "hann" and taps == 2:
            # scipy's symmetric 2-point Hann window is [0, 0]: every filter's weights vanish
            # and the bank passes nothing (S/C and I_F 0/0)
            raise ValueError(
                ".window.type: a 2-tap Hann window is [0, 0] (no weight on either pulse); "
                "use another window (hamming, taylor, chebyshev, rectangular) or n_coherent "
                f">= {3 + (self.mti_order if self.type == 'mti_bank' else 0)}, got hann with "
                f"{taps} taps")
        return self


class Losses(_Model):
    """Named losses of [20], [46], [66]-[67] [dB]; the seed's typical values by default."""

    range_gate_db: float = Field(2.0, ge=0.0, le=20.0, description="L_g [dB]")
    limiter_db: float = Field(2.0, ge=0.0, le=20.0, description="L_l [dB]")
    matching_db: float = Field(1.0, ge=0.0, le=20.0, description="L_m [dB]")
    clutter_extra_db: float = Field(1.0, ge=0.0, le=20.0, description="L_c - L_x [dB] ([46])")
    cfar_db: float = Field(1.5, ge=0.0, le=20.0, description="L_CFAR [dB]")
    clutter_distribution_db: float = Field(2.0, ge=0.0, le=20.0, description="L_cd [dB]")
    beam_shape_db: float = Field(1.6, ge=0.0, le=20.0, description="L_B [dB]")


# --------------------------------------------------------------------------- sensor errors
class ErrorTerm(_Model):
    """One error of a sensor or of its platform's navigation (issue 33), in the unit of the
    field that holds it: a constant ``mean`` plus, with ``sigma`` > 0, a zero-mean
    first-order Gauss-Markov process of stationary standard deviation ``sigma`` and
    correlation time ``correlation_time_s`` (autocorrelation σ² exp(−|τ|/T)), drawn from its
    own random stream.  A bare number is a constant: ``range_bias_m: 150`` is ``{mean: 150}``.
    Sign convention: the error is (reported − true)."""

    mean: float = Field(0.0, description="constant part, in the unit of the field")
    sigma: float = Field(0.0, ge=0.0, description="stationary 1σ of the Gauss-Markov part, "
                         "in the unit of the field; 0: a constant")
    correlation_time_s: float = Field(
        600.0, gt=0.0, le=1.0e7, description="correlation time T of the Gauss-Markov part [s]")

    @model_validator(mode="before")
    @classmethod
    def _number_is_constant(cls, data: Any) -> Any:
        if isinstance(data, (int, float)) and not isinstance(data, bool):
            return {"mean": data}
        return data

    @property
    def is_zero(self) -> bool:
        return self.mean == 0.0 and self.sigma == 0.0


def _check_terms(obj: BaseModel, limits: dict[str, tuple[float, str]]) -> None:
    """Each :class:`ErrorTerm` field of ``obj`` within its limit: ``|mean| <= limit`` and
    ``sigma <= limit`` (``limits``: field -> (limit, unit)); the message names the field."""
    for name, (limit, unit) in limits.items():
        term = getattr(obj, name)
        for key, v in (("mean", term.mean), ("sigma", term.sigma)):
            if not math.isfinite(v) or abs(v) > limit:
                lo = "0" if key == "sigma" else f"{-limit:g}"
                raise ValueError(f".{name}.{key}: must be in [{lo}, {limit:g}] {unit}, "
                                 f"got {v:g}")


class Latency(_Model):
    """Reporting latency of a radar's messages (issue 33): each sector's ``plots`` message
    leaves ``fixed_s`` plus an exponentially distributed delay of mean ``random_mean_s``
    after its sector ends, drawn per message from the radar's own stream; a radar's link is
    first in, first out (a message never overtakes the one before it), so its own messages
    keep their order while those of different radars interleave by arrival."""

    fixed_s: float = Field(0.0, ge=0.0, le=600.0, description="fixed delay [s]")
    random_mean_s: float = Field(
        0.0, ge=0.0, le=600.0, description="mean of the exponential random delay [s]")

    @property
    def is_zero(self) -> bool:
        return self.fixed_s == 0.0 and self.random_mean_s == 0.0


class SensorErrors(_Model):
    """A radar's imperfections (issue 33; all zero by default): registration biases, clock
    errors and reporting latency.  ``meta`` does not show them; ``truth[sensors]`` does.

    reported range = true (1 + range_scale_ppm 10⁻⁶) + range_bias_m + noise;
    reported azimuth = true + azimuth_bias + the platform's heading bias + noise;
    reported time = true + time_offset_s + jitter (Gaussian, 1σ ``time_jitter_s``, per plot).
    Each bias is held over a sector (its value at the sector's end)."""

    range_bias_m: ErrorTerm = Field(
        ErrorTerm(), description="range bias [m] (a cable delay, a range-zero error)")
    range_scale_ppm: ErrorTerm = Field(
        ErrorTerm(), description="range scale error [ppm] (a clock frequency error)")
    azimuth_bias_deg: ErrorTerm = Field(
        ErrorTerm(), description="azimuth bias: north alignment of the antenna [deg]")
    time_offset_s: ErrorTerm = Field(
        ErrorTerm(), description="time-stamp offset of the radar's clock [s]")
    time_jitter_s: float = Field(
        0.0, ge=0.0, le=10.0, description="1σ of a Gaussian time-stamp jitter, per plot [s]")
    latency: Latency = Field(Latency(), description="reporting latency of its messages")

    @model_validator(mode="after")
    def _limits(self) -> SensorErrors:
        _check_terms(self, {"range_bias_m": (1.0e4, "m"), "range_scale_ppm": (1.0e4, "ppm"),
                            "azimuth_bias_deg": (180.0, "deg"), "time_offset_s": (600.0, "s")})
        return self

    @property
    def is_zero(self) -> bool:
        return (self.range_bias_m.is_zero and self.range_scale_ppm.is_zero
                and self.azimuth_bias_deg.is_zero and self.time_offset_s.is_zero
                and self.time_jitter_s == 0.0 and self.latency.is_zero)


class Navigation(_Model):
    """The errors of a platform's navigation (issue 33; all zero by default), shared by every
    radar on it: ``meta`` and ``eos`` report the navigated antenna position (true + error,
    local frame) and heading (true + heading bias); the gyro's heading bias adds to every
    radar's azimuth error.  Each error is held over ``update_s``."""

    east_error_m: ErrorTerm = Field(ErrorTerm(), description="east position error [m]")
    north_error_m: ErrorTerm = Field(ErrorTerm(), description="north position error [m]")
    up_error_m: ErrorTerm = Field(ErrorTerm(), description="up position error [m]")
    heading_bias_deg: ErrorTerm = Field(ErrorTerm(), description="heading (gyro) bias [deg]")
    update_s: float = Field(
        1.0, gt=0.0, le=3600.0, description="interval of the navigation solution: each "
        "error's Gauss-Markov part is drawn on this grid and held between [s]")

    @model_validator(mode="after")
    def _limits(self) -> Navigation:
        _check_terms(self, {"east_error_m": (1.0e4, "m"), "north_error_m": (1.0e4, "m"),
                            "up_error_m": (1.0e3, "m"), "heading_bias_deg": (180.0, "deg")})
        return self

    @property
    def is_zero(self) -> bool:
        return (self.east_error_m.is_zero and self.north_error_m.is_zero
                and self.up_error_m.is_zero and self.heading_bias_deg.is_zero)


class Radar(_Model):
    """A rotating pulse-MTI/Doppler search radar (seed: symbols related to radar inputs)."""

    id: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.-]+$")
    peak_power_w: float = Field(gt=0.0, le=1.0e8, description="P_t, transmitted pulse power [W]")
    gain_db: float = Field(ge=0.0, le=60.0, description="G, maximum antenna gain [dBi]")
    frequency_hz: float = Field(ge=5.0e8, le=1.0e11, description="f, carrier frequency [Hz]")
    polarization: Literal["H", "V"] = Field("H", description="H or V")
    antenna_height_m: float = Field(gt=0.0, le=200.0, description="h_a, above the sea [m]")
    beamwidth_az_deg: float = Field(gt=0.05, le=20.0, description="θ_b, azimuth 3 dB [deg]")
    beamwidth_el_deg: float = Field(gt=0.1, le=90.0, description="φ_b, elevation 3 dB [deg]")
    pattern_az: AzimuthPattern = AzimuthPattern()
    pattern_el: ElevationPattern = ElevationPattern()
    rotation_rpm: float = Field(gt=0.5, le=120.0, description="antenna rotation rate [rev/min]")
    prf_hz: float = Field(ge=50.0, le=5.0e5, description="f_r, pulse repetition frequency [Hz]")
    stagger_prf_hz: list[float] = Field(
        default_factory=list, max_length=16,
        description="PRFs of a staggered sequence [Hz]; empty for a constant PRF (5.1.4)",
    )
    pulse_width_s: float = Field(
        ge=1.0e-8, le=1.0e-3, description="τ', compressed pulse width [s]"
    )
    transmitted_pulse_width_s: float | None = Field(
        None, ge=1.0e-8, le=1.0e-3,
        description="τ, transmitted (uncompressed) pulse width [s]; None: no pulse compression "
        "(τ = τ'). The compression gain τ/τ' multiplies the echo power of targets and clutter "
        "(not noise or jamming); the seed takes P_t as given and has no such input",
    )
    noise_figure_db: float = Field(ge=0.0, le=20.0, description="N_f, receiver noise figure [dB]")
    loss_tr_db: float = Field(ge=0.0, le=20.0, description="L_t/r, transmit/receive loss [dB]")
    antenna_temperature_k: float | None = Field(
        None, ge=0.0, le=5000.0,
        description="T_a [K]; default: Blake's [18] with a sky-noise model for T'_a",
    )
    false_alarm_time_s: float = Field(
        ge=0.1, le=1.0e7, description="t_fa, mean time between false alarms [s]"
    )
    pulses_per_frequency: int = Field(
        1000000, ge=1, le=1000000,
        description="N_fc, pulses before a frequency change (large: no agility)",
    )
    processor: Processor = Processor()
    detector: Literal["square", "linear", "log"] = Field("square", description="detector law")
    integrator: Literal["uniform", "non_uniform", "single_loop", "double_loop"] = Field(
        "uniform", description="non-coherent integrator (Table I)"
    )
    h_range: float = Field(4.0, gt=0.0, le=100.0, description="H_r of [84]")
    h_azimuth: float = Field(4.0, gt=0.0, le=100.0, description="H_θ of [85]")
    instrumented_range_m: float = Field(gt=1000.0, le=1.0e6, description="R_inst [m]")
    n_channels: int = Field(2, ge=1, le=64, description="N_ch, decision channels per cell [71]")
    k_clutter: float = Field(1.0, ge=1.0, le=1.0e6, description="K_clutter of [96]")
    p_fac_max: float | None = Field(
        None, ge=1.0e-3, le=1.0e-2,
        description="P_facmax for HP clutter false alarms; default from VP with a = 3 (7.2)",
    )
    a_min: float = Field(1.0, ge=0.5, le=3.0, description="a_min, minimum Weibull parameter")
    losses: Losses = Losses()
    start_azimuth_deg: float = Field(
        0.0, ge=0.0, lt=360.0, description="beam azimuth (true north) at t = 0 [deg]"
    )
    sac: int | None = Field(
        None, ge=0, le=255,
        description="ASTERIX System Area Code of this radar (I048/010, I034/010); default 0",
    )
    sic: int | None = Field(
        None, ge=0, le=255,
        description="ASTERIX System Identification Code (I048/010, I034/010); default: the "
        "smallest code >= 1 that no other radar of the same SAC uses, in scenario order",
    )
    errors: SensorErrors = Field(
        SensorErrors(), description="registration biases, clock errors and reporting latency "
        "(issue 33); none by default")

    @field_validator("stagger_prf_hz")
    @classmethod
    def _stagger_range(cls, v: list[float]) -> list[float]:
        for p in v:
            if not 50.0 <= p <= 5.0e5:
                raise ValueError(f"each PRF must be in [50, 500000] Hz, got {p}")
        return v

    @model_validator(mode="after")
    def _range_cells_positive(self) -> Radar:
        prf = max([self.prf_hz, *self.stagger_prf_hz])
        duty = prf * self.pulse_width_s
        if duty >= 0.25:
            raise ValueError(
                f"prf_hz * pulse_width_s must be < 0.25 so that N_rc [72] > 2, got {duty:.3g}"
            )
        tau = self.transmitted_pulse_width_s
        if tau is not None and tau < self.pulse_width_s:
            raise ValueError(f"transmitted_pulse_width_s must be >= pulse_width_s "
                             f"({self.pulse_width_s:g} s), got {tau:g}")
        if tau is not None and prf * tau >= 0.5:
            raise ValueError(f"prf_hz * transmitted_pulse_width_s (the duty cycle) must be "
                             f"< 0.5, got {prf * tau:.3g}")
        return self

    @model_validator(mode="after")
    def _beam_and_dwell(self) -> Radar:
        # cosec² [14]: the cosec law joins the main beam at its upper 3 dB point, which must
        # be above the horizon (shipradar.sensors.antenna.cosec2_directivity refuses it otherwise)
        pe = self.pattern_el
        if pe.type == "cosec2" and pe.tilt_deg is not None:
            junction = pe.tilt_deg + self.beamwidth_el_deg / 2.0
            if not junction > 0.0:
                raise ValueError(
                    f".pattern_el.tilt_deg: a cosec2 beam's upper 3 dB point (tilt_deg + "
                    f"beamwidth_el_deg / 2 = {junction:g} deg) must be above the horizon; "
                    f"tilt_deg must be > {-self.beamwidth_el_deg / 2.0:g} with beamwidth_el_deg "
                    f"{self.beamwidth_el_deg:g}, got {pe.tilt_deg:g}")
        # [17]-[19]: T_s = 0 K (an antenna at 0 K, no loss and a noise figure of 0 dB) is a
        # receiver without noise: N0' = 0 and every S/N infinite
        if (self.antenna_temperature_k == 0.0 and self.noise_figure_db == 0.0
                and self.loss_tr_db == 0.0):
            raise ValueError(
                ".antenna_temperature_k: a receiver without noise (antenna_temperature_k 0 K, "
                "noise_figure_db 0 and loss_tr_db 0 give T_s = 0 K [18] and N0' = 0 [19]); "
                "give one of them > 0, got 0")
        # [73]: N_n = θ_b t_scan f_r / (2π) pulses hit a point target per sweep. Below one,
        # the target is lit by a pulse in some sweeps and missed in others, which [73]-[89]
        # (integration, error model) do not describe: refused, with the least PRF that gives
        # one pulse per beamwidth
        n_n = float(pulses_per_beam(math.radians(self.beamwidth_az_deg),
                                    self.scan_period_s, self.prf_hz))
        if not n_n >= 1.0 - PULSES_PER_BEAM_ULP:  # exactly one pulse, to rounding, is one
            need = self.prf_hz / n_n
            raise ValueError(
                f".prf_hz: fewer than one pulse per beamwidth (N_n [73] = beamwidth_az_deg "
                f"{self.beamwidth_az_deg:g} x prf_hz {self.prf_hz:g} / (6 x rotation_rpm "
                f"{self.rotation_rpm:g}) = {n_n:.3g}); needs prf_hz >= {math.ceil(need):d} for "
                f"this rotation and beamwidth (or a wider beam or a slower rotation), got "
                f"{self.prf_hz:g}")
        # [68]-[72] with the reported gates: a t_fa at or below one sweep's decisions asks for
        # P_fa >= 1, more false alarms than decisions. (N_rc > 0 is the duty-cycle rule below,
        # checked first when it fails.)
        if self.prf_hz * self.pulse_width_s < 0.5:
            t_min = shortest_false_alarm_time_s(
                math.radians(self.beamwidth_az_deg), self.scan_period_s, self.prf_hz,
                self.pulse_width_s, self.n_channels, self.instrumented_range_m)
            if not self.false_alarm_time_s > t_min:
                t_swp = float(sweep_time(math.radians(self.beamwidth_az_deg), self.scan_period_s))
                raise ValueError(
                    f".false_alarm_time_s: asks for more false alarms than the radar makes "
                    f"decisions (P_fa [68] would be >= 1): one sweep of {t_swp:.3g} s has "
                    f"{t_swp / t_min:.3g} decisions (n_channels x reported range "
                    f"cells), so false_alarm_time_s must be > {t_min:.3g} s, got "
                    f"{self.false_alarm_time_s:g}")
        return self

    @property
    def compression_ratio(self) -> float:
        """Pulse compression ratio τ/τ' [-] (1 without compression)."""
        tau = self.transmitted_pulse_width_s
        return 1.0 if tau is None else tau / self.pulse_width_s

    @property
    def wavelength_m(self) -> float:
        return SPEED_OF_LIGHT_MPS / self.frequency_hz

    @property
    def scan_period_s(self) -> float:
        return 60.0 / self.rotation_rpm


# --------------------------------------------------------------------------- targets
class ConstantRcs(_Model):
    type: Literal["constant"] = "constant"
    sigma_m2: float = Field(gt=0.0, le=1.0e6, description="σ [m²]")


class MissileRcs(_Model):
    """Missile model [15]."""

    type: Literal["missile"] = "missile"
    sigma_nose_m2: float = Field(gt=0.0, le=1.0e3, description="σ_n, nose-on RCS [m²]")
    length_m: float = Field(gt=0.0, le=50.0, description="L, missile length [m]")
    diameter_m: float = Field(gt=0.0, le=5.0, description="D, missile diameter [m]")


class TableRcs(_Model):
    """σ against aspect (angle off the nose), interpolated, symmetric about the axis."""

    type: Literal["table"] = "table"
    aspect_deg: list[float] = Field(min_length=2, max_length=3601)
    sigma_m2: list[float] = Field(min_length=2, max_length=3601)

    @model_validator(mode="after")
    def _consistent(self) -> TableRcs:
        if len(self.aspect_deg) != len(self.sigma_m2):
            raise ValueError("aspect_deg and sigma_m2 must have the same length")
        a = self.aspect_deg
        if (any(not 0.0 <= x <= 180.0 for x in a)
                or any(a[i] >= a[i + 1] for i in range(len(a) - 1))):
            raise ValueError("aspect_deg must increase strictly within [0, 180]")
        if any(not s > 0.0 for s in self.sigma_m2):
            raise ValueError("sigma_m2 values must be > 0")
        return self


Rcs = Annotated[ConstantRcs | MissileRcs | TableRcs, Field(discriminator="type")]


class Target(_Model):
    id: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.-]+$")
    kind: Literal["missile", "aircraft", "helicopter", "ship", "other"] = "other"
    waypoints: list[Waypoint] = Field(min_length=1, max_length=10_000)
    rcs: Rcs
    swerling: int | None = Field(
        None, ge=0, le=4, description="Swerling case 0-4; default 3 for a missile model, else 1"
    )
    heading_deg: float | None = Field(
        None, ge=0.0, lt=360.0, description="start heading of the segments (true north) [deg]")
    speed_mps: float | None = Field(
        None, ge=0.0, le=3000.0, description="start speed of the segments [m/s]")
    segments: list[Segment] = Field(
        default_factory=list, max_length=10_000,
        description="manoeuvres flown in order from the (single) waypoint; empty: waypoints")
    smoothing: Smoothing | None = Field(
        None, description="round waypoint corners with coordinated turns; None: jumps")

    _check_times = field_validator("waypoints")(
        classmethod(lambda cls, v: _check_waypoint_times(v)))

    @model_validator(mode="after")
    def _motion(self) -> Target:
        if self.segments and self.heading_deg is None:
            raise ValueError(".heading_deg: is required with segments (the start heading)")
        _check_motion(self)
        return self

    @property
    def max_altitude_m(self) -> float:
        """Highest altitude the target reaches [m] (waypoints, climbs, pop-ups)."""
        return _max_altitude(self)

    @property
    def swerling_case(self) -> int:
        return swerling_case(self.rcs, self.kind, self.swerling)


def swerling_case(rcs: Rcs, kind: str, swerling: int | None) -> int:
    """A target's Swerling case: the one given, else 3 for a missile RCS model or kind,
    else 1 (a YAML target's and a traffic file's alike)."""
    if swerling is not None:
        return swerling
    return 3 if rcs.type == "missile" or kind == "missile" else 1


# --------------------------------------------------------------------------- recorded traffic
#: Column names of each ``traffic[].preset`` (sim/world/traffic.py reads them):
#: ``plain`` (the project's own), ``ais`` (the public US AIS extracts of MarineCadastre /
#: NOAA: MMSI, BaseDateTime, LAT, LON, SOG [kn], COG [deg], Heading, VesselName, VesselType)
#: and ``adsb`` (OpenSky Network state vectors: time [unix s], icao24, lat, lon, geoaltitude
#: or baroaltitude [m], velocity [m/s], heading [deg, the true track], vertrate [m/s],
#: callsign).  ``None``: the preset has no such column.
TRAFFIC_PRESETS: dict[str, dict[str, Any]] = {
    "plain": {"time": "time", "time_s": "time_s", "id": "id", "name": "name",
              "lat": "lat_deg", "lon": "lon_deg", "alt": "alt_m", "speed": "speed_mps",
              "course": "course_deg", "vertical_rate": "vertical_rate_mps", "class_": "class",
              "speed_unit": "mps", "time_unit": "iso"},
    "ais": {"time": "BaseDateTime", "time_s": None, "id": "MMSI", "name": "VesselName",
            "lat": "LAT", "lon": "LON", "alt": None, "speed": "SOG", "course": "COG",
            "vertical_rate": None, "class_": "VesselType", "speed_unit": "knots",
            "time_unit": "iso"},
    "adsb": {"time": "time", "time_s": None, "id": "icao24", "name": "callsign",
             "lat": "lat", "lon": "lon", "alt": ["geoaltitude", "baroaltitude"],
             "speed": "velocity", "course": "heading", "vertical_rate": "vertrate",
             "class_": None, "speed_unit": "mps", "time_unit": "unix"},
}


class TrafficColumns(_Model):
    """Column names of a traffic file, overriding its preset's (None: the preset's)."""

    time: str | None = Field(None, description="absolute time column: ISO 8601 UTC text, or "
                             "unix seconds with time_unit: unix")
    time_s: str | None = Field(None, description="seconds since the scenario start [s] "
                               "(instead of time)")
    id: str | None = Field(None, description="target identity (MMSI, ICAO 24-bit address, ...)")
    name: str | None = Field(None, description="display name (vessel name, callsign)")
    lat: str | None = Field(None, description="latitude [deg] (WGS-84)")
    lon: str | None = Field(None, description="longitude [deg]")
    alt: str | None = Field(None, description="height above the sea [m]; none: 0")
    speed: str | None = Field(None, description="speed over ground (speed_unit)")
    course: str | None = Field(None, description="course over ground, true north [deg]")
    vertical_rate: str | None = Field(None, description="vertical speed [m/s]")
    class_: str | None = Field(None, alias="class", description="class column (AIS VesselType, "
                               "...) read by overrides[].classes")
    speed_unit: Literal["mps", "knots", "kmh"] | None = Field(
        None, description="unit of the speed column: m/s, knots or km/h")
    time_unit: Literal["iso", "unix"] | None = Field(
        None, description="time column as ISO 8601 text or unix seconds [s]")

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True,
                              populate_by_name=True)


class TrafficOverride(_Model):
    """RCS and Swerling case of some of a file's targets, by id or by class."""

    ids: list[str] = Field(default_factory=list, max_length=100_000,
                           description="ids this override applies to")
    classes: list[str] = Field(default_factory=list, max_length=1000,
                               description="values of the class column it applies to")
    kind: Literal["missile", "aircraft", "helicopter", "ship", "other"] | None = None
    rcs: Rcs | None = None
    swerling: int | None = Field(None, ge=0, le=4, description="Swerling case 0-4")

    @model_validator(mode="after")
    def _selects(self) -> TrafficOverride:
        if not self.ids and not self.classes:
            raise ValueError("give ids or classes (the targets this override applies to)")
        return self


class TrafficLimits(_Model):
    """What a traffic file may hold before it is refused (one line, before any run)."""

    max_rows: int = Field(2_000_000, ge=1, le=50_000_000, description="rows of the file")
    max_ids: int = Field(20_000, ge=1, le=100_000, description="distinct ids kept")
    max_bytes: int = Field(1 << 30, ge=1, le=1 << 34, description="file size [bytes]")


class Traffic(_Model):
    """A CSV or Parquet file of recorded positions of many targets (AIS, ADS-B, ...).

    Each id becomes a target that exists from its first fix to its last, except across a gap
    of more than ``max_gap_s`` between two fixes (never extrapolated); between fixes its path
    is a cubic Hermite curve, smooth in position and velocity (sim/world/traffic.py).
    """

    path: str = Field(min_length=1, max_length=4096, description="CSV (.csv, .csv.gz) or "
                      "Parquet (.parquet) file, relative to the scenario file")
    preset: Literal["plain", "ais", "adsb"] = Field("plain", description="column names")
    columns: TrafficColumns = TrafficColumns()
    kind: Literal["missile", "aircraft", "helicopter", "ship", "other"] | None = Field(
        None, description="kind of the targets; default ship (ais), aircraft (adsb), other")
    rcs: Rcs
    swerling: int | None = Field(
        None, ge=0, le=4, description="Swerling case 0-4; default 3 for a missile model, else 1")
    overrides: list[TrafficOverride] = Field(default_factory=list, max_length=1000,
                                             description="per-id or per-class RCS and Swerling "
                                             "(the first that matches)")
    ids: list[str] | None = Field(None, max_length=100_000,
                                  description="ids to keep; None: all")
    align: Literal["scenario_start", "first_fix"] = Field(
        "scenario_start", description="an absolute time maps to the scenario's start_time "
        "(scenario_start) or the file's first fix becomes t = 0 (first_fix); time_s columns "
        "are scenario time already")
    time_offset_s: float = Field(0.0, ge=-1.0e7, le=1.0e7,
                                 description="added to every time after the alignment [s]")
    window_start_s: float | None = Field(None, ge=-1.0e7, le=1.0e7,
                                         description="fixes before this scenario time are "
                                         "dropped [s]")
    window_end_s: float | None = Field(None, ge=-1.0e7, le=1.0e7,
                                       description="fixes after this scenario time are "
                                       "dropped [s]")
    max_gap_s: float = Field(600.0, gt=0.0, le=1.0e6, description="a target is inactive "
                             "between two fixes further apart than this [s]")
    id_prefix: str = Field("", max_length=32, pattern=r"^[A-Za-z0-9_.:-]*$",
                           description="prefixed to the file's ids in the truth topic (to "
                           "keep two files' ids apart)")
    limits: TrafficLimits = TrafficLimits()

    @model_validator(mode="after")
    def _window(self) -> Traffic:
        a, b = self.window_start_s, self.window_end_s
        if a is not None and b is not None and not b > a:
            raise ValueError(f".window_end_s: must be > window_start_s ({a:g}), got {b:g}")
        return self

    @property
    def resolved_kind(self) -> str:
        """The targets' kind, the preset's default resolved."""
        if self.kind is not None:
            return self.kind
        return {"ais": "ship", "adsb": "aircraft"}.get(self.preset, "other")

    def column_names(self) -> dict[str, Any]:
        """The preset's column names with ``columns`` applied (``None``: no such column)."""
        out = dict(TRAFFIC_PRESETS[self.preset])
        given = self.columns.model_dump(exclude_none=True)
        if "time_s" in given:
            out["time"] = None
        if "time" in given:
            out["time_s"] = None
        out.update(given)
        return out


# --------------------------------------------------------------------------- live entities
#: RCS and Swerling case of a live entity whose type no ``entity_types`` entry matches:
#: 10 m² (a small aircraft or a patrol boat seen broadside is 1-100 m²), Swerling 1.
DEFAULT_ENTITY_RCS_M2 = 10.0
DEFAULT_ENTITY_SWERLING = 1


class EntityType(_Model):
    """RCS model and Swerling case of the live entities (ZeroMQ ``--entities``) whose type
    matches ``match``: a shell-style pattern (``*`` any text, ``?`` one character) on the
    entity's type text (a ZeroMQ feed's ``type`` column, e.g. ``ship`` or ``aircraft:*``)."""

    match: str = Field(min_length=1, max_length=200, description="pattern on the type text")
    kind: Literal["missile", "aircraft", "helicopter", "ship", "other"] = "other"
    rcs: Rcs
    swerling: int | None = Field(
        None, ge=0, le=4, description="Swerling case 0-4; default 3 for a missile model, else 1")


class External(_Model):
    """The envelope of targets not known before the run (live entities): the tables are
    built for it (the PE table's height and range); a look outside falls back to the
    two-ray model, counted."""

    max_altitude_m: float = Field(
        1500.0, ge=0.0, le=30_000.0, description="highest altitude of an external target [m]; "
        "above the PE table's top (1500 m at most) the two-ray model answers")
    max_range_m: float | None = Field(
        None, gt=0.0, le=2.0e6, description="farthest ground range of an external target "
        "from the origin [m]; default each radar's instrumented range")
    timeout_s: float = Field(
        12.0, gt=0.0, le=3600.0, description="an entity with no update for this long leaves "
        "[s] (DIS's 5 s heartbeat x 2.4)")
    queue_size: int = Field(
        100_000, ge=100, le=10_000_000, description="entity updates held between two "
        "revolutions; beyond, updates are dropped and counted")


# --------------------------------------------------------------------------- platforms, jammers
class Platform(_Model):
    """A ship: stationary (one waypoint) or moving along timed waypoints."""

    id: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.-]+$")
    waypoints: list[Waypoint] = Field(min_length=1, max_length=10_000)
    heading_deg: float = Field(
        0.0, ge=0.0, lt=360.0,
        description="heading when stationary, and the start heading of segments (true north) "
        "[deg]; a moving ship heads along its velocity"
    )
    radars: list[Radar] = Field(min_length=1, max_length=8)
    speed_mps: float | None = Field(
        None, ge=0.0, le=100.0, description="start speed of the segments [m/s]")
    segments: list[Segment] = Field(
        default_factory=list, max_length=10_000,
        description="manoeuvres sailed in order from the (single) waypoint; empty: waypoints")
    smoothing: Smoothing | None = Field(
        None, description="round waypoint corners with coordinated turns; None: jumps")
    dis_entity: str | None = Field(
        None, pattern=r"^[0-9]{1,5}:[0-9]{1,5}:[0-9]{1,5}$",
        description="ride on this DIS entity (SITE:APP:ENTITY): with a live source its "
        "position, velocity and heading come from the entity's states (dead-reckoned at each "
        "crossing); the waypoints until its first state")
    navigation: Navigation = Field(
        Navigation(), description="errors of the ship's navigation (issue 33): position and "
        "heading; none by default")

    _check_times = field_validator("waypoints")(
        classmethod(lambda cls, v: _check_waypoint_times(v)))

    @model_validator(mode="after")
    def _motion(self) -> Platform:
        _check_motion(self)
        return self

    @property
    def max_altitude_m(self) -> float:
        """Highest altitude the platform reaches [m]."""
        return _max_altitude(self)


class Jammer(_Model):
    """Stand-off noise jammer ([47]-[48])."""

    id: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.-]+$")
    waypoints: list[Waypoint] = Field(min_length=1, max_length=10_000)
    power_w: float = Field(gt=0.0, le=1.0e6, description="P_jt, transmitted jammer power [W]")
    gain_db: float = Field(ge=-10.0, le=40.0, description="G_j, jammer antenna gain [dBi]")
    bandwidth_hz: float = Field(ge=1.0e5, le=1.0e10, description="B_j, jammer bandwidth [Hz]")

    _check_times = field_validator("waypoints")(
        classmethod(lambda cls, v: _check_waypoint_times(v)))

    @property
    def max_altitude_m(self) -> float:
        """Highest altitude of the jammer's waypoints [m]."""
        return _max_altitude(self)


# --------------------------------------------------------------------------- environment
class DuctGiven(_Model):
    type: Literal["height"] = "height"
    height_m: float = Field(ge=0.0, le=60.0, description="h_duct, evaporation duct height [m]")


class DuctBulk(_Model):
    """Evaporation duct height from bulk meteorology (a published bulk model)."""

    type: Literal["bulk"] = "bulk"
    air_temperature_c: float = Field(ge=-40.0, le=45.0, description="[°C]")
    sea_temperature_c: float = Field(ge=-2.0, le=35.0, description="[°C]")
    relative_humidity: float = Field(ge=0.05, le=1.0, description="[0-1]")
    pressure_hpa: float = Field(1013.25, ge=900.0, le=1080.0, description="[hPa]")


class DuctProfile(_Model):
    """A measured or forecast M-profile: piecewise linear (surface-based or elevated ducts).

    Above the last point the profile continues with the slope of its last segment, so end it
    on a standard-atmosphere segment (0.118 M/m) unless the layer above is known.
    """

    type: Literal["profile"] = "profile"
    heights_m: list[Annotated[float, Field(ge=0.0, le=20_000.0)]] = Field(
        min_length=2, max_length=500,
        description="break-point heights above the sea [m]; first 0, strictly increasing")
    m_units: list[Annotated[float, Field(ge=0.0, le=2_000.0)]] = Field(
        min_length=2, max_length=500,
        description="modified refractivity M at the break points [M units]")

    @model_validator(mode="after")
    def _check_points(self) -> DuctProfile:
        z = self.heights_m
        if len(self.m_units) != len(z):
            raise ValueError(f"m_units must have as many points as heights_m ({len(z)}), "
                             f"got {len(self.m_units)}")
        if z[0] != 0.0:
            raise ValueError(f"heights_m must start at 0 (the sea surface), got {z[0]}")
        for i in range(1, len(z)):
            if z[i] <= z[i - 1]:
                raise ValueError(f"heights_m must increase strictly, got {z[i - 1]} then {z[i]}")
        return self


Duct = Annotated[DuctGiven | DuctBulk | DuctProfile, Field(discriminator="type")]


class RainRegion(_Model):
    """A vertical cylinder of rain, centred in the origin's local frame."""

    east_m: float = Field(0.0, ge=-2.0e6, le=2.0e6, description="centre east of origin [m]")
    north_m: float = Field(0.0, ge=-2.0e6, le=2.0e6, description="centre north of origin [m]")
    radius_m: float = Field(gt=0.0, le=2.0e6, description="radius [m]")


class Rain(_Model):
    rate_mm_h: float = Field(gt=0.0, le=300.0, description="p_r, precipitation rate [mm/h]")
    kind: Literal["rain", "dry_snow", "wet_snow"] = "rain"
    cloud_base_m: float = Field(
        3000.0, gt=0.0, le=15_000.0, description="h_cloud, top of the rain volume [m]"
    )
    region: RainRegion | None = Field(None, description="rain cylinder; None: everywhere")


class Fog(_Model):
    liquid_water_g_m3: float = Field(gt=0.0, le=5.0, description="fog/cloud liquid water [g/m³]")
    top_m: float = Field(100.0, gt=0.0, le=10_000.0, description="fog top [m]")


class Environment(_Model):
    sea_state: int = Field(3, ge=0, le=9, description="S_sea, Douglas sea state")
    wind_speed_mps: float = Field(7.0, ge=0.0, le=40.0, description="w_s, wind speed [m/s]")
    wind_direction_deg: float = Field(
        0.0, ge=0.0, lt=360.0, description="direction the wind blows FROM (true north) [deg]"
    )
    wave_height_m: float | None = Field(
        None, ge=0.0, le=20.0,
        description="w_h, significant wave height [m]; default from sea state"
    )
    duct: Duct | None = Field(
        None, description="evaporation duct (height or bulk model) or an M-profile; "
        "None: standard atmosphere")
    rain: Rain | None = None
    fog: Fog | None = None
    temperature_c: float = Field(15.0, ge=-40.0, le=45.0, description="air temperature [°C]")
    pressure_hpa: float = Field(1013.25, ge=900.0, le=1080.0, description="[hPa]")
    water_vapour_g_m3: float = Field(7.5, ge=0.0, le=30.0, description="surface ρ_w [g/m³]")


# --------------------------------------------------------------------------- fidelity
class Fidelity(_Model):
    """Speed versus accuracy choices (docs/accuracy.md gives their measured error and cost)."""

    pd_method: Literal["exact", "seed", "table"] = Field(
        "exact", description="P_d: exact Swerling formulas, the seed's [78]-[83], or a "
        "table of the exact P_d against S/I and N_e built per radar and Swerling case "
        "(tables/pd.py; interpolation error in docs/accuracy.md)"
    )
    propagation: Literal["free_space", "two_ray", "pe"] = Field(
        "pe", description="F: free space (F = pattern), two-ray multipath, or PE table"
    )
    pe_grid: Literal["coarse", "standard", "fine"] = "standard"
    improvement_grid: Literal["coarse", "standard", "fine"] = "standard"
    sectors_per_scan: int = Field(
        36, ge=4, le=3600, description="dwell processing batches per antenna revolution"
    )
    clutter: bool = Field(True, description="sea/weather clutter and clutter false alarms")
    atmosphere: bool = Field(True, description="atmospheric attenuation [16]")
    clutter_fa_model: Literal["seed", "weibull_median"] = Field(
        "seed",
        description="sea-clutter false alarms [94]-[95]: 'seed' uses the mean σ0 for the "
        "median on both sides (P_fac depends on a alone); 'weibull_median' sets the Rayleigh "
        "CFAR threshold on the mean (Y = σ0 ln(1/P_fa)) and takes the Weibull median from "
        "[30] (σ_median = σ0 (ln 2)^a / Γ(1+a)): 9-14x lower P_fac at a = 1.5-3",
    )


# --------------------------------------------------------------------------- scenario
class Scenario(_Model):
    name: str = Field(min_length=1, max_length=200)
    description: str = ""
    start_time: dt.datetime = Field(
        dt.datetime(2026, 1, 1, tzinfo=dt.timezone.utc), description="UTC start (ISO 8601)"
    )
    duration_s: float = Field(gt=0.0, le=1.0e6, description="simulated duration [s]")
    seed: int = Field(0, ge=0, le=2**63 - 1, description="random seed")
    origin: Origin
    platforms: list[Platform] = Field(min_length=1, max_length=16)
    targets: list[Target] = Field(default_factory=list, max_length=100_000)
    jammers: list[Jammer] = Field(default_factory=list, max_length=64)
    traffic: list[Traffic] = Field(
        default_factory=list, max_length=64,
        description="recorded traffic files (AIS, ADS-B, ...): each id a target")
    entity_types: list[EntityType] = Field(
        default_factory=list, max_length=1000,
        description="RCS and Swerling case of live entities by type (the first match wins)")
    external: External | None = Field(
        None, description="the envelope of live entities the tables are built for, their "
        "timeout and queue; None: the tables cover the scene's own targets only, and the "
        "defaults of External for the rest")
    environment: Environment = Environment()
    fidelity: Fidelity = Fidelity()

    @model_validator(mode="after")
    def _exact_pd_needs_square_law(self) -> Scenario:
        # the exact Swerling P_d is the square-law detector's with uniform (equal-weight)
        # non-coherent integration; other laws and integrators are Table I's corrections,
        # which only the seed method has
        if self.fidelity.pd_method == "seed":  # "table" tabulates the exact P_d
            return self
        for i, p in enumerate(self.platforms):
            for j, r in enumerate(p.radars):
                for name, want in (("detector", "square"), ("integrator", "uniform")):
                    got = getattr(r, name)
                    if got != want:
                        raise ValueError(
                            f"platforms[{i}].radars[{j}].{name}: the exact P_d "
                            f"(fidelity.pd_method: exact) is for a {want!r} {name}; use "
                            f"fidelity.pd_method: seed for {got!r}, got {got!r}")
        return self

    @model_validator(mode="after")
    def _unique_ids(self) -> Scenario:
        seen: set[str] = set()
        ids = [p.id for p in self.platforms] + [t.id for t in self.targets]
        ids += [j.id for j in self.jammers] + [r.id for p in self.platforms for r in p.radars]
        for i in ids:
            if i in seen:
                raise ValueError("ids must be unique across platforms, radars, targets and "
                                 f"jammers: {i!r} repeats")
            seen.add(i)
        return self

    @model_validator(mode="after")
    def _unique_sac_sic(self) -> Scenario:
        # a receiver tells radars apart by SAC/SIC alone (I048/010): two radars with one
        # code would merge into one sensor in every tracker
        self.asterix_sources()
        return self

    def asterix_sources(self) -> dict[str, tuple[int, int]]:
        """ASTERIX data source (SAC, SIC) of every radar, defaults resolved.

        Returns
        -------
        dict[str, tuple[int, int]]
            Radar id -> (SAC, SIC). A radar without ``sac`` gets 0; one without ``sic`` the
            smallest code >= 1 not given explicitly to, nor already taken by, another radar of
            the same SAC (in scenario order), so the defaults are unique.

        Raises
        ------
        ValueError
            If two radars have the same (SAC, SIC), or no code is left.
        """
        radars = [(i, j, r) for i, p in enumerate(self.platforms) for j, r in enumerate(p.radars)]
        taken: dict[tuple[int, int], str] = {}
        for i, j, r in radars:
            if r.sic is None:
                continue
            key = (0 if r.sac is None else r.sac, r.sic)
            if key in taken:
                raise ValueError(f"platforms[{i}].radars[{j}].sic: SAC/SIC {key[0]}/{key[1]} "
                                 f"is already radar {taken[key]!r}'s; each radar needs its "
                                 f"own (SAC, SIC), got {r.sic}")
            taken[key] = r.id
        out: dict[str, tuple[int, int]] = {}
        for i, j, r in radars:
            sac = 0 if r.sac is None else r.sac
            sic = r.sic
            if sic is None:
                sic = next((c for c in range(1, 256) if (sac, c) not in taken), None)
                if sic is None:
                    raise ValueError(f"platforms[{i}].radars[{j}].sic: every SIC of SAC "
                                     f"{sac} is taken; give this radar another sac")
                taken[(sac, sic)] = r.id
            out[r.id] = (sac, sic)
        return out

    def radars(self) -> list[tuple[Platform, Radar]]:
        return [(p, r) for p in self.platforms for r in p.radars]

    @property
    def has_sensor_errors(self) -> bool:
        """True when some radar has a non-zero ``errors:`` or some platform a non-zero
        ``navigation:`` (issue 33): the run then publishes ``truth[sensors]``."""
        return any(not p.navigation.is_zero for p in self.platforms) or any(
            not r.errors.is_zero for _, r in self.radars())

    @property
    def wave_height(self) -> float:
        """Significant wave height w_h [m], given or from the sea state."""
        env = self.environment
        if env.wave_height_m is not None:
            return env.wave_height_m
        return DOUGLAS_WAVE_HEIGHT_M[env.sea_state]


#: Representative significant wave height [m] of each Douglas sea state 0-9 (mid-band values of
#: the WMO sea-state code table; state 9 "phenomenal" taken as 16 m).
DOUGLAS_WAVE_HEIGHT_M = (0.0, 0.05, 0.3, 0.875, 1.875, 3.25, 5.0, 7.5, 11.5, 16.0)


# --------------------------------------------------------------------------- loading
class ScenarioError(Exception):
    """Bad scenario input; ``lines`` holds one message per problem."""

    def __init__(self, lines: list[str]):
        super().__init__("\n".join(lines))
        self.lines = lines


def _fmt_value(v: Any) -> str:
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e15:
        return str(int(v))
    if isinstance(v, (dict, list)):
        s = repr(v)
        return s if len(s) <= 60 else s[:57] + "..."
    return repr(v) if isinstance(v, str) else str(v)


def _path(loc: tuple, data: Any) -> str:
    """``('targets', 2, 'rcs', 'missile', 'length_m')`` -> ``targets[2].rcs.length_m``.

    Discriminated unions add their tag to the location; it is dropped when the input at that
    point carries it as its ``type``.
    """
    out = ""
    cur = data
    for item in loc:
        if isinstance(item, int):
            out += f"[{item}]"
            cur = cur[item] if isinstance(cur, list) and -len(cur) <= item < len(cur) else None
            continue
        if isinstance(cur, dict) and item not in cur and cur.get("type") == item:
            continue  # union tag
        if item.startswith("function-") or item in ("constrained-str", "list"):
            continue
        out += f".{item}" if out else str(item)
        cur = cur.get(item) if isinstance(cur, dict) else None
    return out or "(top level)"


_BOUND_WORDS = {
    "greater_than": ">",
    "greater_than_equal": ">=",
    "less_than": "<",
    "less_than_equal": "<=",
}


def _message(err: ErrorDetails) -> str:
    typ = err["type"]
    ctx = err.get("ctx") or {}
    inp = err.get("input")
    if typ in _BOUND_WORDS:
        bound = next(iter(ctx.values()))
        return f"must be {_BOUND_WORDS[typ]} {_fmt_value(bound)}, got {_fmt_value(inp)}"
    if typ == "missing":
        return "is required"
    if typ == "extra_forbidden":
        return "is not a known field (check its spelling)"
    if typ == "literal_error":
        return f"must be one of {ctx.get('expected')}, got {_fmt_value(inp)}"
    if typ in ("too_short", "too_long"):
        word = "at least" if typ == "too_short" else "at most"
        n = ctx.get("min_length", ctx.get("max_length"))
        return f"must have {word} {n} item(s), got {ctx.get('actual_length')}"
    if typ == "string_pattern_mismatch":
        return f"must match {ctx.get('pattern')}, got {_fmt_value(inp)}"
    if typ == "union_tag_invalid":
        return f"type must be one of {ctx.get('expected_tags')}, got {_fmt_value(ctx.get('tag'))}"
    if typ == "union_tag_not_found":
        return "needs a 'type' field, one of the allowed kinds"
    if typ == "value_error":
        return str(ctx.get("error", err["msg"]))
    if typ.endswith("_parsing") or typ.endswith("_type"):
        return f"{err['msg'][0].lower()}{err['msg'][1:]}, got {_fmt_value(inp)}"
    return f"{err['msg']}, got {_fmt_value(inp)}"


#: A whole-scenario check that names its own field path starts its message with it.
_OWN_PATH = re.compile(r"^[A-Za-z_][\w.\[\]]*: ")
#: An object's check that names a field inside it starts with ``.field[i].sub: ``.
_REL_PATH = re.compile(r"^\.[A-Za-z_][\w.\[\]]*: ")


def format_validation_error(exc: ValidationError, data: Any) -> list[str]:
    """One line per problem: ``path.to.field: message, got value``."""
    lines = []
    for e in exc.errors():
        path, message = _path(tuple(e["loc"]), data), _message(e)
        own = path == "(top level)" and _OWN_PATH.match(message)
        if _REL_PATH.match(message):  # a check of an object naming a field inside it
            lines.append(f"{path}{message}")
            continue
        lines.append(message if own else f"{path}: {message}")
    return lines


def parse_scenario(data: Any) -> Scenario:
    """Validate already-parsed YAML/JSON data; raise :class:`ScenarioError` on bad input."""
    if not isinstance(data, dict):
        raise ScenarioError([f"(top level): must be a mapping, got {type(data).__name__}"])
    try:
        return Scenario.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(format_validation_error(exc, data)) from None


def _expanded_nodes(node: yaml.Node, memo: dict[int, int]) -> int:
    """Nodes of a composed YAML graph once aliases are expanded (shared nodes counted at each
    use), computed in time linear in the distinct nodes."""
    key = id(node)
    if key in memo:
        return memo[key]
    memo[key] = 1  # a recursive structure counts once per cycle (it is refused later anyway)
    if isinstance(node, yaml.MappingNode):
        total = 1 + sum(_expanded_nodes(k, memo) + _expanded_nodes(v, memo)
                        for k, v in node.value)
    elif isinstance(node, yaml.SequenceNode):
        total = 1 + sum(_expanded_nodes(v, memo) for v in node.value)
    else:
        total = 1
    memo[key] = total
    return total


def _safe_load_checked(text: str) -> Any:
    """``yaml.safe_load(text)``, the document composed once: its node graph is checked for
    alias expansion (:data:`MAX_YAML_NODES`) and then constructed by the same loader (safe
    constructor, safe resolver).  Composed by libyaml (``CSafeLoader``) when PyYAML has it,
    ~10x faster than the pure-Python parser; a document libyaml refuses is parsed again by the
    pure-Python loader, so that the error (line, column, problem) is PyYAML's own."""
    fast = getattr(yaml, "CSafeLoader", None)
    loader_cls = fast if fast is not None else yaml.SafeLoader
    try:
        return _load_with(loader_cls, text)
    except yaml.YAMLError:
        if loader_cls is yaml.SafeLoader:
            raise
    return _load_with(yaml.SafeLoader, text)


def _load_with(loader_cls: Any, text: str) -> Any:
    loader = loader_cls(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        if _expanded_nodes(node, {}) > MAX_YAML_NODES:
            raise ScenarioError([f"YAML aliases expand to more than {MAX_YAML_NODES} nodes"])
        return loader.construct_document(node)
    finally:
        loader.dispose()


def load_scenario(path: str | Path) -> Scenario:
    """Read a scenario YAML file safely and validate it.

    Safety: the file is size-checked (:data:`MAX_SCENARIO_BYTES`) before it is read, parsed
    with ``yaml.safe_load`` (no Python tags), and refused when its aliases would expand to
    more than :data:`MAX_YAML_NODES` nodes (the "billion laughs" pattern). Error lines do not
    repeat the path: the command line prefixes it.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise ScenarioError([f"cannot read ({exc.strerror})"]) from None
    if size > MAX_SCENARIO_BYTES:
        raise ScenarioError([f"file is {size} bytes, must be <= {MAX_SCENARIO_BYTES}"])
    try:
        text = path.read_text(encoding="utf-8")
        data = _safe_load_checked(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", exc)
        raise ScenarioError([f"not valid YAML{where}: {problem}"]) from None
    except UnicodeDecodeError:
        raise ScenarioError(["not UTF-8 text"]) from None
    except OSError as exc:
        raise ScenarioError([f"cannot read ({exc.strerror})"]) from None
    return parse_scenario(_traffic_paths_resolved(data, path.parent))


def _traffic_paths_resolved(data: Any, base: Path) -> Any:
    """``data`` with each ``traffic[].path`` made absolute against the scenario's folder
    (a traffic file is named relative to the scenario file that uses it)."""
    if not isinstance(data, dict) or not isinstance(data.get("traffic"), list):
        return data
    entries = []
    for e in data["traffic"]:
        if isinstance(e, dict) and isinstance(e.get("path"), str) and e["path"] \
                and not Path(e["path"]).is_absolute():
            e = {**e, "path": str((base / e["path"]).resolve())}
        entries.append(e)
    return {**data, "traffic": entries}
