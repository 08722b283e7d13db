"""Target radar cross section σ, seed section 3.1.4, equation [15], or a table against aspect.

Aspect angles
-------------
The aspect is the direction of the radar seen from the target, expressed in the target's
velocity frame: x along the velocity (the nose), y horizontal to the right of the nose, z
perpendicular to both, upward (in the vertical plane holding the velocity).
θ' (bearing) is the azimuth of that direction about z measured from the nose, φ' (elevation)
its elevation above the x-y plane.  A target flying straight at the radar is seen nose-on
(θ' = φ' = 0); one flying away is seen tail-on (θ' = π).

Zero-velocity targets (and a target at the radar) have no nose: they are given the nose-on
aspect θ' = φ' = 0.  With [15], σ_n is the smallest σ whenever 4L/(πD) > 1 (every real
missile), so an undefined orientation never makes a target easier to detect, and it is the
value a missile approaching the radar (the threat aspect) presents.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Speeds below this are treated as zero (no defined nose direction) [m/s].
MIN_SPEED_M_S = 1.0e-6


def aspect_angles(
    los_enu: ArrayLike, velocity_enu: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Aspect angles θ' (bearing) and φ' (elevation) of the radar seen from the target.

    The angles of seed [15] between the line of sight and the target velocity vector.

    Parameters
    ----------
    los_enu : array_like, shape (..., 3)
        Line of sight from the radar to the target, east/north/up [m] (any length).
    velocity_enu : array_like, shape (..., 3)
        Target velocity, east/north/up [m/s].

    Returns
    -------
    theta_rad : ndarray, shape (...)
        θ' in (-π, π] [rad]: 0 nose-on, ±π/2 broadside, π tail-on.
    phi_rad : ndarray, shape (...)
        φ' in [-π/2, π/2] [rad]: positive when the radar is above the target's velocity
        plane.

    Notes
    -----
    A speed below :data:`MIN_SPEED_M_S` or a zero line of sight gives θ' = φ' = 0 (nose-on;
    see the module docstring).  A vertical velocity has no horizontal heading: the heading
    is then taken as north, which only rotates θ' about the nose, and σ of [15] depends on
    θ' and φ' only through the distance from the nose.
    """
    los = np.asarray(los_enu, dtype=np.float64)
    vel = np.asarray(velocity_enu, dtype=np.float64)
    los, vel = np.broadcast_arrays(los, vel)
    los_norm = np.linalg.norm(los, axis=-1)
    speed = np.linalg.norm(vel, axis=-1)
    defined = (speed >= MIN_SPEED_M_S) & (los_norm > 0.0)
    # Direction from the target to the radar.
    d = -los / np.where(los_norm > 0.0, los_norm, 1.0)[..., None]
    heading = np.arctan2(vel[..., 0], vel[..., 1])  # from north, clockwise
    pitch = np.arctan2(vel[..., 2], np.hypot(vel[..., 0], vel[..., 1]))
    sh, ch = np.sin(heading), np.cos(heading)
    forward_h = d[..., 0] * sh + d[..., 1] * ch
    right = d[..., 0] * ch - d[..., 1] * sh
    up = d[..., 2]
    sp, cp = np.sin(pitch), np.cos(pitch)
    x = forward_h * cp + up * sp
    z = -forward_h * sp + up * cp
    theta = np.arctan2(right, x)
    phi = np.arcsin(np.clip(z, -1.0, 1.0))
    return np.where(defined, theta, 0.0), np.where(defined, phi, 0.0)


def off_nose_angle(theta_rad: ArrayLike, phi_rad: ArrayLike) -> NDArray[np.float64]:
    """True angle between the nose and the direction of the radar, ``acos(cos θ' cos φ')``.

    Exact cone angle for the aspect angles of :func:`aspect_angles` (spherical cosine law);
    this is the aspect of RCS tables (:func:`tabulated_rcs`) and of the missile model
    (:func:`missile_rcs`).  [15] as printed combines the two angles as
    ``sqrt(θ'² + φ'²)``, which equals it when either angle is zero.

    Parameters
    ----------
    theta_rad, phi_rad : array_like
        θ' and φ' [rad].

    Returns
    -------
    ndarray
        Angle off the nose in [0, π] [rad].
    """
    c = np.cos(np.asarray(theta_rad, dtype=np.float64)) * np.cos(
        np.asarray(phi_rad, dtype=np.float64)
    )
    angle: NDArray[np.float64] = np.arccos(np.clip(c, -1.0, 1.0))
    return angle


#: How :func:`missile_rcs` combines θ' and φ' into the angle off the nose ψ.
MISSILE_ASPECTS = ("off_nose", "seed")
MissileAspect = Literal["off_nose", "seed"]


def missile_rcs(
    sigma_nose_m2: ArrayLike,
    length_m: ArrayLike,
    diameter_m: ArrayLike,
    theta_rad: ArrayLike,
    phi_rad: ArrayLike,
    *,
    aspect: MissileAspect = "off_nose",
) -> NDArray[np.float64]:
    """Missile cross section against aspect, seed [15].

    ``σ = σ_n {cos ψ + 4L/(πD) sin ψ}``, ψ the angle between the nose and the radar.

    Parameters
    ----------
    sigma_nose_m2 : array_like
        σ_n, nose-on cross section [m²], > 0.
    length_m : array_like
        L, target length [m], > 0.
    diameter_m : array_like
        D, target diameter [m], > 0.
    theta_rad : array_like
        θ', bearing of the line of sight from the velocity [rad].
    phi_rad : array_like
        φ', elevation of the line of sight from the velocity [rad].
    aspect : {"off_nose", "seed"}, optional
        How ψ is formed from θ' and φ'.  ``"off_nose"`` (the default): the true cone angle
        ``acos(cos θ' cos φ')`` (:func:`off_nose_angle`), the aspect RCS tables use too.
        ``"seed"``: [15] as printed, ``ψ = sqrt(θ'² + φ'²)``, kept to reproduce the seed's
        numbers.  The two agree where either angle is zero, and within a few degrees near
        the nose, but not for a target seen from behind and above or below: tail-on
        (θ' ≈ π) any φ' pushes the printed ψ past π and σ swings back toward σ_n although
        the radar is far from the nose (a missile receding at 150 m/s and diving at 260 m/s,
        seen on the horizon, is 120° off its nose: 1.85 dBsm, and -4.11 dBsm as printed,
        for σ_n = 0.1 m², L = 4.7 m, D = 0.35 m).

    Returns
    -------
    ndarray
        σ [m²], ≥ σ_n·min(1, 4L/(πD)) > 0.

    Notes
    -----
    Beyond 90° off the nose [15] as printed goes negative (cos ψ < 0), which is not a cross
    section.  The body is taken as fore-aft symmetric, the only symmetry the model's two
    terms (a nose cap and a cylinder) have: ``σ(ψ) = σ(π - ψ)``, i.e.
    ``σ = σ_n (|cos ψ| + 4L/(πD) |sin ψ|)``.  Tail-on gives σ_n, broadside the seed's
    σ_n·4L/(πD); the result is identical to [15] for ψ ≤ π/2 and continuous everywhere.
    With ``aspect="seed"`` ψ can exceed π (a large θ' and φ' together) and follows the
    same rule.
    """
    theta = np.asarray(theta_rad, dtype=np.float64)
    phi = np.asarray(phi_rad, dtype=np.float64)
    if aspect == "off_nose":
        psi = off_nose_angle(theta, phi)
    elif aspect == "seed":
        psi = np.hypot(theta, phi)
    else:
        raise ValueError(f"aspect: must be one of {MISSILE_ASPECTS}, got {aspect!r}")
    ratio = (
        4.0
        * np.asarray(length_m, dtype=np.float64)
        / (np.pi * np.asarray(diameter_m, dtype=np.float64))
    )
    return np.asarray(sigma_nose_m2, dtype=np.float64) * (
        np.abs(np.cos(psi)) + ratio * np.abs(np.sin(psi))
    )


def tabulated_rcs(
    aspect_axis_rad: ArrayLike, sigma_axis_m2: ArrayLike, aspect_rad: ArrayLike
) -> NDArray[np.float64]:
    """σ interpolated in a table against aspect (angle off the nose), symmetric about the axis.

    The seed (3.1.4) allows a measured table of σ instead of [15].

    Parameters
    ----------
    aspect_axis_rad : array_like, shape (n,)
        Table aspects, angles off the nose [rad], strictly increasing within [0, π].
    sigma_axis_m2 : array_like, shape (n,)
        σ at those aspects [m²], ≥ 0.
    aspect_rad : array_like
        Aspects to evaluate [rad], any real value.

    Returns
    -------
    ndarray
        σ [m²], linear interpolation in m² (exact at the nodes).

    Notes
    -----
    The aspect is folded to [0, π] (``|wrap(a)|``), so σ(-a) = σ(a) and σ(a + 2π) = σ(a).
    Between the table's ends and 0 or π, σ is held at the nearest end value.
    """
    axis = np.asarray(aspect_axis_rad, dtype=np.float64)
    sig = np.asarray(sigma_axis_m2, dtype=np.float64)
    if axis.ndim != 1 or axis.shape != sig.shape or axis.size < 2:
        raise ValueError("aspect and sigma tables must be 1-D, of equal length >= 2")
    if np.any(np.diff(axis) <= 0.0) or axis[0] < 0.0 or axis[-1] > np.pi:
        raise ValueError("table aspects must increase strictly within [0, π]")
    a = np.asarray(aspect_rad, dtype=np.float64)
    folded = np.abs(np.pi - np.mod(np.pi - a, 2.0 * np.pi))
    return np.interp(folded, axis, sig)
