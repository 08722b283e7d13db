"""Antenna gain directivity factor g, seed section 3.1.3, equations [8]-[14].

``g`` is a FIELD (voltage) factor normalised to 1 on the beam axis: the one-way power
pattern is ``g**2`` and the two-way (clutter, [21]) power pattern is ``g**4``.  The seed's
[9] and [10]-[11] both give ``g = 1/sqrt(2)`` at ``±φ_b/2``, i.e. ``φ_b`` is the half-power
(3 dB) beamwidth of the power pattern.

Conventions
-----------
* ``directivity(angle, ...)`` takes the angle from the beam axis [rad] (azimuth offset, or
  elevation offset from the beam maximum).  Angles are wrapped to ``(-π, π]`` first, so any
  real angle is accepted and ``±π`` (behind the antenna) is finite.
* ``elevation_directivity(elevation, ...)`` takes the elevation above the horizon [rad],
  positive up, and applies the tilt ``φ_tilt`` (elevation of the beam maximum):
  ``g_el(φ) = directivity(φ - φ_tilt)``.  For the cosec² pattern [14] the cosec law is written
  in the elevation itself (not in the offset), so it needs the absolute elevation; the
  dispatcher passes ``angle + tilt`` to :func:`cosec2_directivity`.
* The sinc pattern is returned *signed* (the sidelobes alternate in sign, as the aperture's
  far field does); the parabolic-equation source needs the sign, the power users square it.
  ``|g| <= 1`` everywhere.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Pattern names accepted by :func:`directivity` (scenario ``type:`` values).
PATTERNS = ("isotropic", "gaussian", "sinc", "cosec2")
Pattern = Literal["isotropic", "gaussian", "sinc", "cosec2"]

#: x such that sin(x)/x = 1/sqrt(2): the 3 dB point of the sinc field pattern, [11].
SINC_HALF_POWER_X = 1.3916
#: First zero of sin(x)/x is x = π; [12] writes π / 1.3916 = 2.2575.
SINC_FIRST_NULL_RATIO = 2.2575
#: Level of the first sidelobe of sin(x)/x below the main beam [dB] (20 log10 0.21723).
SINC_NATURAL_SIDELOBE_DB = 13.26
#: Peak of the first sidelobe of sin(x)/x (field, at x = 4.4934), 10^(-13.26/20).
SINC_FIRST_SIDELOBE = 10.0 ** (-SINC_NATURAL_SIDELOBE_DB / 20.0)
#: Highest elevation of the cosec² coverage [rad], by default the zenith: [14] gives the law
#: with no upper end.  Where a real antenna's shaping stops is its own (20°-40° for a shaped
#: reflector, Skolnik, Radar Handbook 2nd ed., §6.7): a lower φ_max is a keyword of
#: :func:`cosec2_directivity`.
COSEC_MAX_ELEVATION_RAD = 0.5 * np.pi


def _wrap(angle_rad: ArrayLike) -> NDArray[np.float64]:
    """Wrap angles to (-π, π] [rad]."""
    a = np.asarray(angle_rad, dtype=np.float64)
    return np.pi - np.mod(np.pi - a, 2.0 * np.pi)


def isotropic_directivity(angle_rad: ArrayLike) -> NDArray[np.float64]:
    """Omnidirectional directivity factor, seed [8]: ``g = 1``.

    Parameters
    ----------
    angle_rad : array_like
        Angle from the beam axis [rad]; only its shape is used.

    Returns
    -------
    ndarray
        Ones, same shape as ``angle_rad``.
    """
    return np.ones_like(np.asarray(angle_rad, dtype=np.float64))


def gaussian_directivity(angle_rad: ArrayLike, beamwidth_rad: ArrayLike) -> NDArray[np.float64]:
    """Gaussian pencil-beam directivity factor, seed [9].

    ``g(φ) = exp(-4 φ² / φ_b² · ln √2)``, so that ``g(±φ_b/2)² = 1/2``.

    Parameters
    ----------
    angle_rad : array_like
        Angle from the beam axis [rad]; wrapped to (-π, π].
    beamwidth_rad : array_like
        Half-power beamwidth φ_b [rad], > 0.

    Returns
    -------
    ndarray
        Field factor in (0, 1]; even in angle.  Far off the axis it underflows to 0 (a
        Gaussian beam has no sidelobes: use the sinc pattern when sidelobes matter).
    """
    a = _wrap(angle_rad)
    bw = np.asarray(beamwidth_rad, dtype=np.float64)
    g: NDArray[np.float64] = np.exp(-4.0 * (a / bw) ** 2 * np.log(np.sqrt(2.0)))
    return g


def sinc_constant_k(beamwidth_rad: ArrayLike) -> NDArray[np.float64]:
    """Constant k of the sinc pattern, seed [11]: ``k = 1.3916 / sin(φ_b/2)``.

    Parameters
    ----------
    beamwidth_rad : array_like
        Half-power beamwidth φ_b [rad], in (0, π).
    """
    return SINC_HALF_POWER_X / np.sin(0.5 * np.asarray(beamwidth_rad, dtype=np.float64))


def sinc_first_null_rad(beamwidth_rad: ArrayLike) -> NDArray[np.float64]:
    """Angle of the first null of the sinc pattern, seed [12].

    ``φ_null = asin(2.2575 sin(φ_b/2))``.

    Parameters
    ----------
    beamwidth_rad : array_like
        Half-power beamwidth φ_b [rad].

    Returns
    -------
    ndarray
        φ_null [rad].  For beams wider than ``2 asin(1/2.2575)`` (about 52.6°) the argument
        exceeds 1 and the pattern has no null before the back of the antenna: π is returned,
        so the whole pattern is the main lobe [10] and no sidelobe factor is applied.
    """
    x = SINC_FIRST_NULL_RATIO * np.sin(0.5 * np.asarray(beamwidth_rad, dtype=np.float64))
    return np.where(x < 1.0, np.arcsin(np.minimum(x, 1.0)), np.pi)


def sinc_directivity(
    angle_rad: ArrayLike,
    beamwidth_rad: ArrayLike,
    sidelobe_db: ArrayLike = SINC_NATURAL_SIDELOBE_DB,
    *,
    envelope: bool = False,
) -> NDArray[np.float64]:
    """Sinc directivity factor with sidelobe reduction, seed [10]-[13].

    Inside the first null (|φ| < φ_null, [12]):
    ``g = (1 + cos φ)/2 · sin(k sin φ)/(k sin φ)`` [10] with k from [11];
    beyond it the same expression times ``10^(-0.05 (S_L - 13.26))`` [13], which puts the
    first sidelobe at ``-S_L`` dB (power) below the main beam.

    Parameters
    ----------
    angle_rad : array_like
        Angle from the beam axis [rad]; wrapped to (-π, π].
    beamwidth_rad : array_like
        Half-power beamwidth φ_b [rad], in (0, π).
    sidelobe_db : array_like, optional
        S_L, first sidelobe level below the main beam [dB]; 13.26 (the default) leaves the
        natural sinc sidelobes.  Values below 13.26 raise the sidelobes.
    envelope : bool, optional
        If True, the pattern's peak envelope instead of the oscillating pattern, for
        interference that must not fall into an exact pattern null ([47]'s jammer): the main
        lobe down to the first sidelobe's level ``-S_L``, that level across the first null
        and up to where ``1/|x|`` falls below it (x = 4.603), then the peaks' bound ``1/|x|``
        (``|sin|`` replaced by 1), all times the obliquity factor.  Non-negative, continuous,
        never increasing away from the axis, never below ``|g|`` in front of the antenna,
        and never above ``-S_L`` outside the main lobe (the plain bound ``1/|x|`` would put
        it 3.3 dB above the first sidelobe just past the null).  Behind the antenna, where
        ``k sin φ`` falls below π again, it stays at the first sidelobe's level times the
        obliquity factor, under the back lobe that [10]'s ``sin φ`` gives the pattern.

    Returns
    -------
    ndarray
        Signed field factor, ``|g| <= 1``, even in angle; ``g(0) = 1``; ``g(±π) = 0`` (the
        obliquity factor (1 + cos φ)/2 vanishes behind the antenna).
    """
    a = _wrap(angle_rad)
    bw = np.asarray(beamwidth_rad, dtype=np.float64)
    k = sinc_constant_k(bw)
    x = k * np.sin(a)
    obliquity = 0.5 * (1.0 + np.cos(a))
    core = np.sinc(x / np.pi)  # numpy's sinc is sin(πu)/(πu), finite at u = 0
    beyond = np.abs(a) >= sinc_first_null_rad(bw)
    reduction = 10.0 ** (
        -0.05 * (np.asarray(sidelobe_db, dtype=np.float64) - SINC_NATURAL_SIDELOBE_DB)
    )
    if envelope:
        # 1/|x| bounds |sin x / x| beyond the first null, but exceeds the first sidelobe's
        # peak 0.21723 up to x = 4.603: cap it there.  Inside the null, the main lobe is
        # floored at the same level, so the envelope has no null and no jump.  Near the
        # back, where sin φ -> 0 again, the cap holds it too.
        env = np.minimum(1.0 / np.maximum(np.abs(x), np.pi), SINC_FIRST_SIDELOBE) * reduction
        core = np.where(beyond, env, np.maximum(core, SINC_FIRST_SIDELOBE * reduction))
        peaks: NDArray[np.float64] = np.clip(obliquity * core, 0.0, 1.0)
        return peaks
    g = obliquity * core * np.where(beyond, reduction, 1.0)
    return np.clip(g, -1.0, 1.0)


def cosec2_directivity(
    elevation_rad: ArrayLike,
    beamwidth_rad: ArrayLike,
    tilt_rad: ArrayLike,
    sidelobe_db: ArrayLike = SINC_NATURAL_SIDELOBE_DB,
    *,
    cosec_max_rad: ArrayLike = COSEC_MAX_ELEVATION_RAD,
    envelope: bool = False,
) -> NDArray[np.float64]:
    """Cosecant-squared elevation directivity factor, seed [14].

    Let ``φ_j = φ_tilt + φ_b/2`` (the upper 3 dB point of the main beam).

    * ``φ < φ_j``: the sinc pattern [10]-[13] of beamwidth φ_b centred on ``φ_tilt``.
    * ``φ_j <= φ <= φ_max``: ``g = sin(φ_j)/√2 · csc(φ)`` [14] (power ∝ csc²φ), which joins
      the sinc at φ_j, where both equal 1/√2 (the 1/√2 is taken as the sinc's exact value
      there, so that the junction is continuous, see the code comment).
    * ``φ > φ_max``: the shaped coverage ends; the peak envelope of the sinc sidelobes
      about the tilt (``envelope=True`` of :func:`sinc_directivity`: no pattern null, whose
      depth would depend on the 5 digits of [11]), never above the cosec law.  ``φ_max``
      defaults to the zenith (:data:`COSEC_MAX_ELEVATION_RAD`), as [14] gives the law with
      no upper end: at 60°, φ_b = 4°, φ_tilt = 2°, g² = sin²(4°)/(2 sin²60°), -24.9 dB.  A
      junction above φ_max (``φ_tilt + φ_b/2 > φ_max``) leaves no cosec² part: the
      pattern is the sinc main beam up to φ_j (peak 1 at the tilt), capped above it.

    Parameters
    ----------
    elevation_rad : array_like
        Elevation above the horizon [rad]; clipped to [-π/2, π/2].
    beamwidth_rad : array_like
        Half-power beamwidth φ_b of the main beam [rad].
    tilt_rad : array_like
        φ_tilt, elevation of the pattern maximum [rad] (typically φ_b/2).  Must satisfy
        ``φ_tilt + φ_b/2 > 0`` (otherwise csc would be singular at the horizon).
    sidelobe_db : array_like, optional
        S_L of the sinc part [dB], see :func:`sinc_directivity`.
    cosec_max_rad : array_like, optional
        Upper end of the cosec² coverage φ_max [rad].
    envelope : bool, optional
        Sidelobe envelope instead of the oscillating sinc sidelobes.

    Returns
    -------
    ndarray
        Field factor, ``|g| <= 1`` (``sin φ_j / sin φ < 1`` above φ_j, so no cap is active in
        the cosec range; the result is clipped to [-1, 1] anyway).

    Raises
    ------
    ValueError
        If ``tilt_rad + beamwidth_rad/2 <= 0`` anywhere.
    """
    el = np.clip(np.asarray(elevation_rad, dtype=np.float64), -0.5 * np.pi, 0.5 * np.pi)
    bw = np.asarray(beamwidth_rad, dtype=np.float64)
    tilt = np.asarray(tilt_rad, dtype=np.float64)
    phi_j = tilt + 0.5 * bw
    if np.any(phi_j <= 0.0):
        raise ValueError(
            "cosec² pattern needs tilt + beamwidth/2 > 0 (its junction above the horizon)"
        )
    sinc = sinc_directivity(el - tilt, bw, sidelobe_db, envelope=envelope)
    # [14] writes the junction value as 1/sqrt(2), the sinc's nominal 3 dB value; the sinc
    # of [10]-[11] is 1/sqrt(2) there only to the obliquity factor and the 5 digits of
    # 1.3916 (0.03 % at φ_b = 4°).  We use the sinc's own value at φ_j so the pattern is
    # continuous at the junction.
    g_junction = sinc_directivity(0.5 * bw, bw)
    # csc evaluated only where φ >= φ_j > 0, so sin φ > 0 there; elsewhere a dummy 1.
    sin_el = np.where(el >= phi_j, np.sin(el), 1.0)
    cosec = g_junction * np.sin(phi_j) / sin_el
    # above φ_max the cosec law caps the sidelobe envelope, never the main beam below φ_j:
    # a beam whose junction is above φ_max has no cosec² part at all
    above_max = (el > np.asarray(cosec_max_rad, dtype=np.float64)) & (el >= phi_j)
    g = np.where(el < phi_j, sinc, cosec)
    if np.any(above_max):
        side = sinc_directivity(el - tilt, bw, sidelobe_db, envelope=True)
        g = np.where(above_max, np.minimum(side, cosec), g)
    return np.clip(g, -1.0, 1.0)


def directivity(
    angle_rad: ArrayLike,
    beamwidth_rad: ArrayLike,
    pattern: Pattern,
    *,
    sidelobe_db: ArrayLike = SINC_NATURAL_SIDELOBE_DB,
    tilt_rad: ArrayLike = 0.0,
    cosec_max_rad: ArrayLike = COSEC_MAX_ELEVATION_RAD,
    envelope: bool = False,
) -> NDArray[np.float64]:
    """Directivity factor g of a named pattern, seed [8]-[14], angle from the beam axis.

    Parameters
    ----------
    angle_rad : array_like
        Angle from the beam axis (the pattern maximum) [rad].
    beamwidth_rad : array_like
        Half-power beamwidth [rad].
    pattern : {"isotropic", "gaussian", "sinc", "cosec2"}
        [8], [9], [10]-[13], [14].  For "cosec2" the angle is the offset from the maximum
        and the absolute elevation ``angle + tilt_rad`` is used for the cosec law.
    sidelobe_db : array_like, optional
        S_L [dB] of the sinc pattern (also the sinc part of cosec²).
    tilt_rad : array_like, optional
        φ_tilt [rad], used by "cosec2" only.
    cosec_max_rad : array_like, optional
        Upper end of the cosec² coverage [rad], "cosec2" only.
    envelope : bool, optional
        Sidelobe peak envelope instead of the oscillating sidelobes (sinc, cosec2).

    Returns
    -------
    ndarray
        Field factor, broadcast shape of the inputs, ``|g| <= 1``.
    """
    if pattern == "isotropic":
        ones: NDArray[np.float64] = np.broadcast_to(
            isotropic_directivity(angle_rad),
            np.broadcast_shapes(np.shape(angle_rad), np.shape(beamwidth_rad)),
        ).copy()
        return ones
    if pattern == "gaussian":
        return gaussian_directivity(angle_rad, beamwidth_rad)
    if pattern == "sinc":
        return sinc_directivity(angle_rad, beamwidth_rad, sidelobe_db, envelope=envelope)
    if pattern == "cosec2":
        elevation = np.asarray(angle_rad, dtype=np.float64) + np.asarray(tilt_rad, dtype=np.float64)
        return cosec2_directivity(
            elevation,
            beamwidth_rad,
            tilt_rad,
            sidelobe_db,
            cosec_max_rad=cosec_max_rad,
            envelope=envelope,
        )
    raise ValueError(f"unknown antenna pattern {pattern!r}; expected one of {PATTERNS}")


def elevation_directivity(
    elevation_rad: ArrayLike,
    beamwidth_rad: ArrayLike,
    pattern: Pattern,
    *,
    sidelobe_db: ArrayLike = SINC_NATURAL_SIDELOBE_DB,
    tilt_rad: ArrayLike = 0.0,
    cosec_max_rad: ArrayLike = COSEC_MAX_ELEVATION_RAD,
    envelope: bool = False,
) -> NDArray[np.float64]:
    """Elevation directivity factor, elevation measured from the horizon, seed [8]-[14].

    ``g_el(φ) = directivity(φ - φ_tilt, ...)``: the beam maximum is at ``φ = tilt_rad``.
    For "cosec2" this is :func:`cosec2_directivity` at the elevation φ itself.

    Parameters
    ----------
    elevation_rad : array_like
        Elevation above the horizon [rad], positive up (targets below the antenna's horizon
        have negative elevation).
    beamwidth_rad : array_like
        Half-power elevation beamwidth φ_b [rad].
    pattern : {"isotropic", "gaussian", "sinc", "cosec2"}
        Pattern name.
    sidelobe_db : array_like, optional
        S_L [dB].
    tilt_rad : array_like, optional
        φ_tilt, elevation of the beam maximum [rad] (the seed's typical value is φ_b/2).
    cosec_max_rad : array_like, optional
        Upper end of the cosec² coverage [rad].
    envelope : bool, optional
        Sidelobe peak envelope instead of the oscillating sidelobes.

    Returns
    -------
    ndarray
        Field factor, ``|g| <= 1``.
    """
    offset = np.asarray(elevation_rad, dtype=np.float64) - np.asarray(tilt_rad, dtype=np.float64)
    return directivity(
        offset,
        beamwidth_rad,
        pattern,
        sidelobe_db=sidelobe_db,
        tilt_rad=tilt_rad,
        cosec_max_rad=cosec_max_rad,
        envelope=envelope,
    )
