"""The geometry the whole model shares: the earth and the scan.

One home (issue 31) for the facts every layer needs and none may restate:

* the earth: the mean radius (IUGG R1) and the effective-earth factor k = 4/3 of the
  standard atmosphere (Blake 1986, sec. 6.3; ITU-R P.453), with the slant range and
  elevation between two heights a ground range apart on that 4/3 earth;
* the scan's timing geometry of seed [70]-[73]: the sweep time t_swp, the pulses per beam
  N_n, the range cells N_rc and the reported gates N_rep, and from them the shortest mean
  time between false alarms a radar can be asked for (P_fa = 1 in [68]).

It imports nothing of ours, so the scenario schema (layer 0) checks a radar's feasibility
with these functions and the motion of its objects uses this earth (tests/test_layers.py
places this module at layer 0, beside the schema; README, "Layers").
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

#: Mean earth radius [m] (IUGG mean radius R1), the one radius of every layer (the rounded
#: 6371 km of ITU-R P.834/P.676 and of [24]'s 3.57 km/√m is 1.4e-6 below it).
EARTH_RADIUS_M = 6_371_008.8
#: Effective earth-radius factor k of the standard atmosphere (gradient -40 N/km; Blake 1986,
#: sec. 6.3; ITU-R P.453): a_e = k · EARTH_RADIUS_M.
K_FACTOR = 4.0 / 3.0
#: [72]: N_rc = 1/(f_r τ') - 2: the two cells lost at each end of the interpulse period.
RANGE_CELLS_LOST = 2.0


# ----------------------------------------------------------------------------- the earth
def slant_range_elevation(
    ground_range_m: np.ndarray, h1_m: np.ndarray, h2_m: np.ndarray, k_factor: float = K_FACTOR,
    radius_m: float = EARTH_RADIUS_M,
) -> tuple[np.ndarray, np.ndarray]:
    """Slant range [m] and elevation [rad] between heights h1 and h2 a ground range apart.

    Spherical earth of effective radius k·a: central angle γ = R_t/(k a), law of cosines for
    the slant range, and elevation atan2((a_e+h2) cos γ - (a_e+h1), (a_e+h2) sin γ).  At zero
    ground range the elevation is ±90° (or 0 if the heights are equal, where R = 0).
    """
    a_e = k_factor * radius_m
    g = np.asarray(ground_range_m, dtype=float) / a_e
    r1 = a_e + np.asarray(h1_m, dtype=float)
    r2 = a_e + np.asarray(h2_m, dtype=float)
    # 2 r1 r2 (1 - cos γ) = 4 r1 r2 sin²(γ/2): no cancellation at short range
    slant = np.sqrt((r2 - r1) ** 2 + 4.0 * r1 * r2 * np.sin(0.5 * g) ** 2)
    elev = np.arctan2(r2 * np.cos(g) - r1, r2 * np.sin(g))
    return slant, elev


# ----------------------------------------------------------------------------- the scan
def range_cells(prf_hz: ArrayLike, pulse_width_s: ArrayLike) -> NDArray[np.float64]:
    """Number of range cells N_rc = 1/(f_r τ') - 2, seed [72].

    Parameters
    ----------
    prf_hz : array_like
        Pulse repetition frequency f_r [Hz].
    pulse_width_s : array_like
        Compressed pulse length τ' [s].

    Returns
    -------
    ndarray
        N_rc [-] (not rounded).

    Raises
    ------
    ValueError
        If f_r or τ' is not positive, or N_rc ≤ 0 (f_r τ' ≥ 1/2: no range cell left;
        SPEC §4 item 14).
    """
    f_r = np.asarray(prf_hz, dtype=np.float64)
    tau = np.asarray(pulse_width_s, dtype=np.float64)
    _require_positive("prf_hz", f_r)
    _require_positive("pulse_width_s", tau)
    n_rc = 1.0 / (f_r * tau) - RANGE_CELLS_LOST
    if np.any(~(n_rc > 0)):
        duty = np.broadcast_to(f_r * tau, n_rc.shape)[~(n_rc > 0)].flat[0]
        raise ValueError(
            f"range_cells: N_rc = 1/(f_r tau') - 2 must be > 0, i.e. prf_hz * pulse_width_s "
            f"must be < 0.5; got prf_hz * pulse_width_s = {duty:g}"
        )
    return n_rc


def sweep_time(beamwidth_rad: ArrayLike, scan_period_s: ArrayLike) -> NDArray[np.float64]:
    """Time for the beam to sweep a point target, t_swp = θ_b t_scan / (2π), seed [70].

    Parameters
    ----------
    beamwidth_rad : array_like
        Horizontal 3 dB beamwidth θ_b [rad], in (0, 2π].
    scan_period_s : array_like
        Time of one revolution t_scan [s], > 0.

    Returns
    -------
    ndarray
        t_swp [s].

    Raises
    ------
    ValueError
        If θ_b ∉ (0, 2π] or t_scan ≤ 0.
    """
    theta = np.asarray(beamwidth_rad, dtype=np.float64)
    t_scan = np.asarray(scan_period_s, dtype=np.float64)
    _require_positive("beamwidth_rad", theta)
    if np.any(theta > 2.0 * np.pi):
        raise ValueError(f"beamwidth_rad must be <= 2 pi, got {np.max(theta):g}")
    _require_positive("scan_period_s", t_scan)
    return theta / (2.0 * np.pi) * t_scan


def pulses_per_beam(
    beamwidth_rad: ArrayLike, scan_period_s: ArrayLike, prf_hz: ArrayLike
) -> NDArray[np.float64]:
    """Pulses hitting a point target in one beam sweep, N_n = t_swp f_r, seed [73].

    Parameters
    ----------
    beamwidth_rad : array_like
        Horizontal 3 dB beamwidth θ_b [rad].
    scan_period_s : array_like
        Time of one revolution [s].
    prf_hz : array_like
        Pulse repetition frequency f_r [Hz], > 0.

    Returns
    -------
    ndarray
        N_n [-] (not rounded; may be below 1 for a fast scan, see
        :func:`shipradar.sensors.detection.effective_pulses`).
    """
    f_r = np.asarray(prf_hz, dtype=np.float64)
    _require_positive("prf_hz", f_r)
    return sweep_time(beamwidth_rad, scan_period_s) * f_r


def reported_range_cells(
    prf_hz: ArrayLike, pulse_width_s: ArrayLike, instrumented_range_m: ArrayLike | None = None
) -> NDArray[np.float64]:
    """Range gates per sweep whose decisions can be reported, N_rep = min(N_rc, R_inst/C_R).

    The decisions of [71] that can give a reported plot: the N_rc gates of one interpulse
    period [72] that lie inside the instrumented range R_inst, with C_R = c τ'/2.  Erratum
    to [68]-[72] against [90] (issue 23 item 5a, module notes): a gate beyond R_inst is not
    reported, and a radar whose R_inst exceeds the unambiguous range c/(2 f_r) still decides
    in N_rc gates per pulse.

    Parameters
    ----------
    prf_hz : array_like
        Pulse repetition frequency f_r [Hz].
    pulse_width_s : array_like
        Compressed pulse length τ' [s].
    instrumented_range_m : array_like, optional
        R_inst [m], > 0.  None: every gate, N_rc of [72] (the seed's n_0).

    Returns
    -------
    ndarray
        N_rep [-] (not rounded), in (0, N_rc].

    Raises
    ------
    ValueError
        As :func:`range_cells`, or if R_inst is not positive.
    """
    n_rc = range_cells(prf_hz, pulse_width_s)
    if instrumented_range_m is None:
        return n_rc
    r_inst = np.asarray(instrumented_range_m, dtype=np.float64)
    _require_positive("instrumented_range_m", r_inst)
    c_r = constants.c * np.asarray(pulse_width_s, dtype=np.float64) / 2.0
    n_rep: NDArray[np.float64] = np.minimum(n_rc, r_inst / c_r)
    return n_rep


def shortest_false_alarm_time_s(
    beamwidth_rad: float, scan_period_s: float, prf_hz: float, pulse_width_s: float,
    n_channels: float, instrumented_range_m: float | None = None,
) -> float:
    """The t_fa at which P_fa of [68]-[72] reaches 1, t_swp / (N_ch N_rep) [s].

    A mean time between false alarms at or below it asks for more false alarms than the radar
    makes decisions (P_fa = t_swp / (N_ch N_rep t_fa) >= 1,
    :func:`shipradar.sensors.detection.pfa_from_false_alarm_time` with k = 1).

    Parameters
    ----------
    beamwidth_rad : float
        Horizontal 3 dB beamwidth θ_b [rad].
    scan_period_s : float
        Time of one revolution t_scan [s].
    prf_hz : float
        Pulse repetition frequency f_r [Hz].
    pulse_width_s : float
        Compressed pulse length τ' [s]; f_r τ' < 1/2 (:func:`range_cells`).
    n_channels : float
        Decision channels per range cell N_ch [-].
    instrumented_range_m : float, optional
        R_inst [m] (:func:`reported_range_cells`).
    """
    t_swp = float(sweep_time(beamwidth_rad, scan_period_s))
    n_rep = float(reported_range_cells(prf_hz, pulse_width_s, instrumented_range_m))
    return t_swp / (n_channels * n_rep)


def _require_positive(name: str, arr: np.ndarray) -> None:
    if np.any(~(arr > 0)) or np.any(~np.isfinite(arr)):
        bad = arr[~((arr > 0) & np.isfinite(arr))].flat[0] if arr.ndim else float(arr)
        raise ValueError(f"{name} must be finite and > 0, got {bad:g}")
