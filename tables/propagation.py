"""Split-step Fourier parabolic-equation solver for the propagation factor F(R_t, h), and the
table builder and lookup of the off-line level (seed [5]-[7]; SPEC section 3; issue 4).

Method (docs/propagation.md has the reasoning and the measured errors)
-----------------------------------------------------------------------
* Equation: the seed's [5], ``u_hh + 2 j k u_R + k^2 (m^2 - 1) u = 0`` (physics time convention
  ``exp(-j w t)``, field ``E = u exp(j k R) / sqrt(R)``), with the *wide-angle* Feit-Fleck
  free-space propagator ``exp(j dx (sqrt(k^2 - p^2) - k))`` (exact in a homogeneous medium
  for every angle the grid carries) and the phase screen ``exp(j k dx (M(h) - M(0)) 1e-6)``.
  Earth curvature is inside M (``m = n + h / r``).
* Surface: sea water through the Leontovich impedance condition ``u_h + alpha u = 0``,
  ``alpha_H = j k sqrt(eps - 1)``, ``alpha_V = j k sqrt(eps - 1) / eps``, solved with the
  discrete mixed Fourier transform (Dockery & Kuttler 1996, IEEE TAP 44(12) 1592-1599).
  Roughness (Miller-Brown) enters as an effective impedance per range step: the reflection
  coefficient rho(psi) Gamma(psi) is matched at the grazing angle psi of the ray that leaves the
  antenna and meets the sea at that range (4/3 earth), the approach of Barrios (1994)/APM.
  ``surface="pec"`` gives a perfect conductor: Dirichlet (sine transform) for H, Neumann
  (cosine transform) for V.
* Starting field: the angular spectrum of the elevation pattern, ``g(theta - tilt)``, at the
  antenna height plus its image weighted by the plane-wave reflection coefficient of the same
  boundary, tapered in angle (flat to ``max_angle``, cosine roll-off to 2 ``max_angle``).
* Top: Hanning absorbing window over the upper third of the domain.
* F = |u| sqrt(R_t) (seed [6]); the spectrum is scaled by sqrt(2 pi / k), so that by stationary
  phase F -> g(theta) in free space, i.e. F = 1 on the beam peak.
* Points whose image-ray elevation exceeds ``max_angle`` hold NaN: the PE grid does not carry
  those angles and the on-line model falls back to
  :func:`shipradar.sensors.propagation.two_ray_factor`.
* Domain: at least 2.5 times the height of the antenna's shadow boundary at max range
  (:func:`pe_top_height`), whatever height the caller wants.
* Table: F on (range, w = h / R) (:func:`table_axes`), where the direct/reflected-ray lobes
  are straight lines along range, sampled from the PE nodes by windowed-sinc interpolation
  of the complex field; :func:`propagation_factor` looks it up at (R, h) in O(1).
"""

from __future__ import annotations

import math
import sys
import weakref
from collections.abc import Callable, Mapping
from types import SimpleNamespace
from typing import Any

import numpy as np
import scipy.constants as sc
import scipy.fft as sfft
from scipy.signal import lfilter

from shipradar.sensors import propagation as prop
from shipradar.tables.store import Table, get_or_build

#: Builder name and version (part of the cache key; bump on any change of results).
TABLE_NAME = "propagation_factor"
TABLE_VERSION = 5

#: Fidelity presets.  max_angle_deg: largest propagation angle carried (the table is NaN
#: beyond it); nyquist_factor: oversampling of the angular spectrum (Nyquist angle over the
#: end of the taper); boundary_kz_dz: largest k sin(max_angle) dz for the impedance boundary
#: of vertical polarization (the discrete condition reflects like the continuous one at
#: sin(p dz) / dz instead of p; see :func:`grid_steps`); phase_error_rad: allowed splitting
#: phase error at max_angle, which sets the range step; lobe_samples and surface_step_m: the
#: table's sampling in h / R (see :func:`table_axes`).
FIDELITY = {
    "coarse": {"max_angle_deg": 3.0, "nyquist_factor": 1.1, "boundary_kz_dz": 0.8,
               "phase_error_rad": 0.6, "lobe_samples": 16, "surface_step_m": 1.0},
    "standard": {"max_angle_deg": 5.0, "nyquist_factor": 1.2, "boundary_kz_dz": 0.45,
                 "phase_error_rad": 0.25, "lobe_samples": 32, "surface_step_m": 0.5},
    "fine": {"max_angle_deg": 8.0, "nyquist_factor": 1.5, "boundary_kz_dz": 0.3,
             "phase_error_rad": 0.08, "lobe_samples": 48, "surface_step_m": 0.25},
}
#: End of the cosine roll-off of the starting spectrum, in units of max_angle.
TAPER_END = 2.0
#: Fraction of the computational domain, at the top, taken by the absorbing window.
ABSORBER_FRACTION = 1.0 / 3.0
#: The steepest wave of the starting spectrum must be seen at least this many times inside
#: the absorbing layer on its way up (else it reaches the top, is reflected and comes back).
ABSORBER_STEPS = 4
#: Heights over which the refractive gradient is sampled for the range step [m]: the bottom
#: metre of an evaporation duct (gradient -> -inf at the surface) is excluded.
_GRADIENT_FLOOR_M = 1.0
#: Largest range step, as a fraction of the maximum range.
_MAX_STEP_FRACTION = 1.0 / 50.0


# =========================================================================== grid
def grid_steps(
    freq_hz: float,
    max_height_m: float,
    max_range_m: float,
    profile: Callable[[np.ndarray], np.ndarray],
    fidelity: str = "standard",
    max_angle_rad: float | None = None,
    *,
    polarization: str = "H",
    surface: str = "sea",
) -> dict[str, float]:
    """PE grid from frequency, height, range, maximum angle and the refractive gradient.

    * Height step: Nyquist of the angular spectrum, ``dz = lambda / (2 sin theta_N)`` with
      ``sin theta_N = nyquist_factor * sin(TAPER_END * max_angle)``.  For vertical
      polarization over the sea also ``k sin(max_angle) dz <= boundary_kz_dz``: the discrete
      impedance condition reflects a wave of vertical wavenumber p like the continuous one
      at ``sin(p dz) / dz``, and |Gamma_V| varies quickly with angle below the Brewster angle.
      (Gamma_H is -1 to within a few per cent at these angles, so H needs no such refinement.)
    * Range step: the split-step error is the phase lost by a ray at ``max_angle`` whose angle
      changes by ``dx |dm/dz|`` inside one step, ``k sin(theta) |dm/dz| dx^2 / 2``; it is held
      to ``phase_error_rad``.  |dm/dz| is the largest gradient of M above 1 m (and at least the
      earth-curvature 0.157e-6 / m).  Capped at max_range / 50, and so that the steepest
      wave of the starting spectrum is seen ABSORBER_STEPS times crossing the absorber.
    * Domain: ``max_height / (1 - 1/3)`` with the absorber above max_height.

    Parameters
    ----------
    freq_hz : float
        Frequency [Hz].
    max_height_m, max_range_m : float
        Extent of the wanted table [m].
    profile : callable
        M profile [M units] of height [m].
    fidelity : str
        ``"coarse"``, ``"standard"`` or ``"fine"`` (:data:`FIDELITY`).
    max_angle_rad : float, optional
        Overrides the preset's maximum propagation angle [rad].

    Returns
    -------
    dict
        ``dz``, ``dx``, ``n`` (intervals in height), ``domain_m``, ``max_angle_rad``.
    """
    if fidelity not in FIDELITY:
        raise ValueError(f"fidelity must be one of {sorted(FIDELITY)}, got {fidelity!r}")
    preset = FIDELITY[fidelity]
    theta = np.radians(preset["max_angle_deg"]) if max_angle_rad is None else float(max_angle_rad)
    if not 0 < theta * TAPER_END < np.pi / 2:
        raise ValueError("max_angle_rad must be in (0, 0.8 * pi/2)")
    lam = sc.c / freq_hz
    k = 2 * np.pi / lam
    sin_nyq = min(preset["nyquist_factor"] * np.sin(TAPER_END * theta), 1.0)
    dz_target = lam / (2 * sin_nyq)
    if surface == "sea" and prop.normalize_polarization(polarization) == "V":
        dz_target = min(dz_target, preset["boundary_kz_dz"] / (k * np.sin(theta)))
    domain = max_height_m / (1 - ABSORBER_FRACTION)
    n = int(sfft.next_fast_len(int(np.ceil(domain / dz_target))))
    dz = domain / n
    z = np.linspace(min(_GRADIENT_FLOOR_M, max_height_m / 2), max_height_m, 2048)
    grad = np.abs(np.gradient(np.asarray(profile(z), dtype=float), z)).max() * 1e-6
    grad = max(grad, 1e-6 / prop.EARTH_RADIUS_M)
    dx = np.sqrt(2 * preset["phase_error_rad"] / (k * np.sin(theta) * grad))
    absorber_dx = _absorber_step(domain, theta)
    dx = float(min(dx, max_range_m * _MAX_STEP_FRACTION, absorber_dx))
    return {"dz": dz, "dx": dx, "n": n, "domain_m": domain, "max_angle_rad": theta,
            "absorber_dx": absorber_dx}


def pe_top_height(max_height_m: float, max_range_m: float, antenna_height_m: float) -> float:
    """Top of the PE's free domain [m]: the wanted height, and at least SHADOW_MARGIN times
    the height of the antenna's shadow boundary at max range (4/3 earth).

    The field that diffracts into the shadow comes from just above its boundary: with the
    absorber at 1.1 times that height, F at 10 m, 50-60 km (5.6 GHz, antenna 25 m) was 14 dB
    off and had a false null; at 2 times up to 1 dB off, at 2.5 times within 0.2 dB of the
    converged field (5 times) (measured, docs/propagation.md).  The cost grows with it:
    (R - sqrt(2 a_e h_a))^2 / a_e.
    """
    a_e = prop.STANDARD_K_FACTOR * prop.EARTH_RADIUS_M
    beyond = max(max_range_m - np.sqrt(2 * a_e * antenna_height_m), 0.0)
    return float(max(max_height_m, SHADOW_MARGIN * beyond**2 / (2 * a_e)))


#: PE work (height nodes x range steps) above which a grid is "large": its rough-sea
#: boundary takes the faster powers (:class:`_ImpedanceBoundary`) and a scene's table stops
#: at the farthest range its targets and jammers reach
#: (:func:`shipradar.tables.scene.pe_table_range_m`). Below it (every shipped scene: at most 2.3e7,
#: the raid's C-band radar) tables are built exactly as before, byte for byte.
LARGE_GRID_WORK = 5e7

#: The PE domain reaches at least this many times the shadow-boundary height at max range.
SHADOW_MARGIN = 2.5


def _absorber_step(domain_m: float, max_angle_rad: float) -> float:
    """Range over which the steepest carried wave climbs a quarter of the absorbing layer [m]."""
    return ABSORBER_FRACTION * domain_m / (ABSORBER_STEPS * np.tan(TAPER_END * max_angle_rad))


# =========================================================================== boundary
def _mode_prefix(r: complex, n: int) -> np.ndarray:
    """``r ** j`` for j = 0 .. n, or for a prefix that holds every |r^j| > 1e-30 (|r| < 1).

    The prefix ends :data:`_MODE_MARGIN` nodes past the last significant one, so that the
    caller's cut (the last node above 1e-30) is the one it makes on the whole array.
    """
    a = abs(r)
    if a >= 1.0 or a == 0.0:
        return r ** np.arange(n + 1)
    last = math.log(1e-30) / math.log(a)
    stop = min(n + 1, int(last) + _MODE_MARGIN)
    while True:
        phi = r ** np.arange(stop)
        if stop == n + 1 or not np.any(np.abs(phi[-_MODE_MARGIN // 2:]) > 1e-30):
            return phi
        stop = min(n + 1, 2 * stop)


#: Nodes computed past the estimated end of a surface mode (:func:`_mode_prefix`).
_MODE_MARGIN = 64


class _ImpedanceBoundary:
    """Discrete mixed Fourier transform for ``u_z + alpha u = 0`` (Dockery & Kuttler 1996).

    ``w_j = (u_{j+1} - u_{j-1}) / (2 dz) + alpha u_j`` vanishes at the surface, so w is
    propagated with the sine transform; the one-dimensional null space of that map,
    ``phi_j ~ r^j`` with ``r^2 + 2 alpha dz r - 1 = 0``, |r| < 1 (a surface mode), is carried
    separately.  The mode amplitude is the projection ``sum' phi_j u_j / sum' phi_j^2``
    (bilinear, half weight at the surface), under which the discrete Laplacian with the
    impedance condition is symmetric, so that the continuous-spectrum eigenfunctions have no
    mode component.  ``u`` is rebuilt from w by two first-order recursions run in their
    stable directions (forward with r, backward with -r), then cleared of its mode component.
    """

    def __init__(self, alpha: complex, dz: float, n: int, k: float, dx: float,
                 fast: bool = False):
        a = alpha * dz
        root = np.sqrt(a * a + 1)
        r1, r2 = -a + root, -a - root
        if abs(r1) > abs(r2):
            r1, r2 = r2, r1
        self.r = r1
        self.dz = dz
        self.alpha = alpha
        # phi_j = r^j minus the growing root's share that makes phi_N = 0 (exact null vector)
        with np.errstate(under="ignore"):
            if abs(r1) ** n > 1e-300 and fast:
                # a large grid (LARGE_GRID_WORK): the powers as exponentials of j ln r, 25
                # times cheaper than complex powers and within 1e-12 of them; a rough sea's
                # march rebuilds this boundary at every step, where it took half the time
                j = np.arange(n + 1)
                log_r = np.log(r1)
                sign = np.where((n + j) % 2 == 1, -1.0, 1.0)
                self.phi = np.exp(j * log_r) - sign * np.exp((2 * n - j) * log_r)
            elif abs(r1) ** n > 1e-300:
                j = np.arange(n + 1)
                tail = (-1.0) ** ((n + j) % 2) * r1 ** (2 * n - j)
                self.phi = r1**j - tail
            else:
                # no tail: |phi_j| = |r|^j falls below 1e-30 after about ln(1e-30)/ln|r|
                # nodes, and only those are kept below; computing just that prefix (with a
                # margin) gives the same values and saves the complex powers of the rest,
                # which dominated a rough sea's march (the boundary is rebuilt every step)
                self.phi = _mode_prefix(r1, n)
        # keep the mode only where it is not negligible: subnormal numbers are slow
        significant = np.nonzero(np.abs(self.phi) > 1e-30)[0]
        self.m = int(significant[-1]) + 1 if significant.size else 1
        self.phi = self.phi[: self.m]
        weights = np.ones(self.m)
        weights[0] = 0.5
        if self.m == n + 1:
            weights[n] = 0.0
        self.weighted_phi = weights * self.phi / np.sum(weights * self.phi**2)
        # the mode's propagator, continuous-equivalent wavenumber p^2 = -(ln r / dz)^2
        kz2 = (np.log(r1) / dz) ** 2
        prop_mode = np.exp(1j * dx * (np.sqrt(k * k + kz2) - k))
        # a mode that would grow is not a physical surface wave: drop it
        self.mode_propagator = prop_mode if abs(prop_mode) <= 1.0 else 0.0

    def forward(self, u: np.ndarray) -> tuple[np.ndarray, complex]:
        """u (j = 0..N, u_N = 0) -> (w on j = 1..N-1, mode amplitude)."""
        w = (u[2:] - u[:-2]) / (2 * self.dz) + self.alpha * u[1:-1]
        return w, np.dot(self.weighted_phi, u[: self.m])

    def inverse(self, w: np.ndarray, mode: complex) -> np.ndarray:
        """(w on j = 1..N-1, mode amplitude) -> u on j = 0..N."""
        u = self._solve(w)
        u[: self.m] += (mode - np.dot(self.weighted_phi, u[: self.m])) * self.phi
        return u

    def _solve(self, w: np.ndarray) -> np.ndarray:
        """Particular solution of T u = w with v_0 = 0 and u_N = 0."""
        r = self.r
        n = w.size + 1
        x = np.zeros(n + 1, dtype=complex)
        x[2:] = 2 * self.dz * w  # v_j = r v_{j-1} + 2 dz w_{j-1}, w_0 = 0
        v = lfilter([1.0], [1.0, -r], x)
        y = np.zeros(n + 1, dtype=complex)
        y[1:] = r * v[::-1][:-1]  # u_{j-1} = -r u_j + r v_j, from u_N = 0 downwards
        s = lfilter([1.0], [1.0, r], y)
        return s[::-1]


def _surface_alpha(freq_hz: float, pol: str, permittivity: complex) -> complex:
    """Leontovich impedance constant (physics convention) for sea water."""
    k = 2 * np.pi * freq_hz / sc.c
    eps = np.conj(permittivity)  # engineering eps' - j eps'' -> physics eps' + j eps''
    root = np.sqrt(eps - 1)
    return 1j * k * root if pol == "H" else 1j * k * root / eps


def _plane_wave_gamma(p: np.ndarray, k: float, alpha: complex) -> np.ndarray:
    """Reflection coefficient of the impedance boundary for the plane wave of wavenumber |p|."""
    ip = 1j * np.abs(p)
    return (ip - alpha) / (ip + alpha)


def _rough_alpha(alpha: complex, psi: float, rho: float, k: float) -> complex:
    """Impedance whose plane-wave reflection at grazing psi is rho * Gamma(psi)."""
    if psi <= 0 or rho >= 1.0:
        return alpha
    ip = 1j * k * np.sin(psi)
    gamma = rho * (ip - alpha) / (ip + alpha)
    return ip * (1 - gamma) / (1 + gamma)


# =========================================================================== solver
def _prepare(
    freq_hz, antenna_height_m, *, polarization, elevation_pattern, profile, wave_height_m,
    max_range_m, max_height_m, fidelity, tilt_rad, surface, permittivity, max_angle_rad,
    range_step_m, step_scale,
) -> SimpleNamespace:
    """Everything the march needs: grid, boundary, starting field, propagators (solve_pe)."""
    pol = prop.normalize_polarization(polarization)
    if surface not in ("sea", "pec"):
        raise ValueError("surface must be 'sea' or 'pec'")
    if not 0 < antenna_height_m < max_height_m:
        raise ValueError("antenna height must be in (0, max_height_m)")
    if max_range_m <= 0:
        raise ValueError("max_range_m must be > 0")
    m_of_h = prop.profile_from_spec(profile) if isinstance(profile, Mapping) else profile
    pattern = elevation_pattern if elevation_pattern is not None else prop._isotropic
    steps = grid_steps(freq_hz, pe_top_height(max_height_m, max_range_m, antenna_height_m),
                       max_range_m, m_of_h, fidelity, max_angle_rad, polarization=pol,
                       surface=surface)
    if step_scale != 1.0:
        # a convergence study: the same domain with both steps scaled
        n_scaled = int(sfft.next_fast_len(int(np.ceil(steps["n"] / step_scale))))
        steps["dz"] = steps["domain_m"] / n_scaled
        steps["n"] = n_scaled
    s = SimpleNamespace()
    s.pol, s.surface, s.steps = pol, surface, steps
    dz, n, theta_max = steps["dz"], steps["n"], steps["max_angle_rad"]
    if range_step_m is None:
        n_steps = int(np.ceil(max_range_m / (steps["dx"] * step_scale)))
        dx = max_range_m / n_steps
        every = 1
    else:
        every = int(np.ceil(range_step_m / (steps["dx"] * step_scale)))
        dx = range_step_m / every
        n_steps = every * int(np.ceil(max_range_m / range_step_m - 1e-9))
    s.dz, s.n, s.theta_max, s.dx, s.n_steps, s.every = dz, n, theta_max, dx, n_steps, every
    s.large = n * n_steps > LARGE_GRID_WORK
    lam = sc.c / freq_hz
    k = 2 * np.pi / lam
    s.lam, s.k = lam, k
    z = dz * np.arange(n + 1)
    s.z = z
    eps = prop.sea_water_permittivity(freq_hz) if permittivity is None else complex(permittivity)

    # ---- boundary
    if surface == "pec":
        alpha = np.inf
        gamma_of_p = (lambda p: -np.ones_like(p)) if pol == "H" else (lambda p: np.ones_like(p))
    else:
        alpha = _surface_alpha(freq_hz, pol, eps)
        gamma_of_p = lambda p: _plane_wave_gamma(p, k, alpha)  # noqa: E731
    s.alpha = alpha

    # ---- starting field: angular spectrum of the pattern and its image (FFT over 2N samples)
    m_idx = np.fft.fftfreq(2 * n, d=1.0 / (2 * n))
    p = m_idx * np.pi / (n * dz)
    theta = np.arcsin(np.clip(p / k, -1.0, 1.0))
    taper = _angular_taper(np.abs(theta), theta_max) * (np.abs(p) < k)
    norm = np.sqrt(2 * np.pi / k)
    z_a = float(antenna_height_m)
    s.z_a = z_a
    rho0 = (prop.roughness_factor(np.abs(theta), wave_height_m, freq_hz)
            if surface == "sea" else 1.0)
    spectrum = norm * taper * (
        pattern(theta - tilt_rad) * np.exp(-1j * p * z_a)
        + rho0 * gamma_of_p(p) * pattern(-theta - tilt_rad) * np.exp(1j * p * z_a)
    )
    dp = np.pi / (n * dz)
    u = (dp / (2 * np.pi)) * (2 * n) * np.fft.ifft(spectrum)[: n + 1]
    u[n] = 0.0
    s.u0 = u

    # ---- propagators
    p_sine = np.arange(1, n) * np.pi / (n * dz)
    p_cos = np.arange(0, n + 1) * np.pi / (n * dz)
    s.free_sine = np.exp(1j * dx * (np.sqrt((k * k - p_sine**2).astype(complex)) - k))
    s.free_cos = np.exp(1j * dx * (np.sqrt((k * k - p_cos**2).astype(complex)) - k))
    m_surface = float(np.asarray(m_of_h(0.0)))
    screen = np.exp(1j * k * dx * (np.asarray(m_of_h(z), dtype=float) - m_surface) * 1e-6)
    z_abs = n * dz * (1 - ABSORBER_FRACTION)
    window = np.where(z <= z_abs, 1.0, 0.5 * (1 + np.cos(np.pi * (z - z_abs) / (n * dz - z_abs))))
    # the Hanning window once per absorber step: the absorption per metre of range, not per
    # step, is fixed, so results do not depend on dx through the absorber
    s.screen = screen * window ** (dx / steps["absorber_dx"])
    s.rough = surface == "sea" and wave_height_m > 0
    s.wave_height_m, s.freq_hz = float(wave_height_m), float(freq_hz)
    return s


def _march(s: SimpleNamespace, sample: Callable[[float, np.ndarray], np.ndarray],
           progress: bool | None):
    """Run the split-step march; ``sample(range_m, u)`` is called every ``s.every`` steps.

    Returns the output ranges [m] and the stacked rows that ``sample`` returned.
    """
    from tqdm import tqdm

    n, dx, pol = s.n, s.dx, s.pol
    u = s.u0.copy()
    a_e = prop.STANDARD_K_FACTOR * prop.EARTH_RADIUS_M
    boundary = None
    if s.surface == "sea" and not s.rough:
        boundary = _ImpedanceBoundary(s.alpha, s.dz, n, s.k, dx)
    keep = np.arange(s.every, s.n_steps + 1, s.every)
    ranges = keep * dx
    out = None
    show = sys.stderr.isatty() if progress is None else progress
    for step in tqdm(range(1, s.n_steps + 1), disable=not show, desc="PE", unit="step",
                     leave=False):
        x_mid = (step - 0.5) * dx
        if s.surface == "pec" and pol == "H":
            u[1:n] = sfft.idst(sfft.dst(u[1:n], type=1, norm="ortho") * s.free_sine, type=1,
                               norm="ortho")
            u[0] = 0.0
        elif s.surface == "pec":
            u = sfft.idct(sfft.dct(u, type=1) * s.free_cos, type=1)
        else:
            if s.rough:
                psi_x = float(np.arctan(s.z_a / x_mid) - x_mid / (2 * a_e))
                rho_x = float(prop.roughness_factor(max(psi_x, 0.0), s.wave_height_m, s.freq_hz))
                boundary = _ImpedanceBoundary(_rough_alpha(s.alpha, psi_x, rho_x, s.k), s.dz, n,
                                              s.k, dx, fast=s.large)
            w, mode = boundary.forward(u)
            w = sfft.idst(sfft.dst(w, type=1, norm="ortho") * s.free_sine, type=1, norm="ortho")
            u = boundary.inverse(w, mode * boundary.mode_propagator)
        u = u * s.screen
        u[n] = 0.0
        if step % s.every == 0:
            row = sample(step * dx, u)
            if out is None:
                out = np.empty((keep.size, row.size), dtype=row.dtype)
            out[step // s.every - 1] = row
    return ranges, out


def solve_pe(
    freq_hz: float,
    antenna_height_m: float,
    *,
    polarization: str,
    elevation_pattern: Callable[[np.ndarray], np.ndarray] | None,
    profile: Callable[[np.ndarray], np.ndarray] | Mapping[str, Any],
    wave_height_m: float = 0.0,
    max_range_m: float,
    max_height_m: float,
    fidelity: str = "standard",
    tilt_rad: float = 0.0,
    surface: str = "sea",
    permittivity: complex | None = None,
    max_angle_rad: float | None = None,
    range_step_m: float | None = None,
    height_step_m: float | None = None,
    step_scale: float = 1.0,
    progress: bool | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Propagation factor F(R_t, h) by the split-step Fourier PE (seed [5]-[6]), on PE nodes.

    Parameters
    ----------
    freq_hz : float
        Carrier frequency [Hz].
    antenna_height_m : float
        Antenna phase-centre height above the sea [m], in (0, max_height_m).
    polarization : str
        ``"H"`` or ``"V"``.
    elevation_pattern : callable or None
        ``g(theta_rad)``: field pattern relative to its peak, as a function of the angle from
        the beam axis (the beam axis is at elevation ``tilt_rad``).  None: isotropic.
    profile : callable or dict
        M profile [M units] of height [m], or a description for
        :func:`shipradar.sensors.propagation.profile_from_spec`.
    wave_height_m : float
        Significant wave height [m] (Miller-Brown roughness); 0: smooth sea.
    max_range_m, max_height_m : float
        Extent of the output grid [m].
    fidelity : str
        ``"coarse"``, ``"standard"`` or ``"fine"`` (see :func:`grid_steps`).
    tilt_rad : float
        Elevation of the beam axis [rad].
    surface : str
        ``"sea"`` (impedance of sea water) or ``"pec"`` (perfect conductor).
    permittivity : complex, optional
        Sea permittivity ``eps' - j eps''``; default sea water at 15 degC, 35 psu.
    max_angle_rad : float, optional
        Overrides the fidelity's largest propagation angle [rad].
    range_step_m, height_step_m : float, optional
        Output grid steps [m]; default the PE range step and the height step that samples the
        finest interference period, lambda / (2 sin max_angle), twice (heights are PE nodes,
        the step is rounded to a multiple of dz).  With range_step_m the PE step is the
        largest divisor of it below the grid's step, and the last range is max_range_m
        rounded up to a multiple of it.
    step_scale : float
        Multiplies both PE steps (dz, dx) for convergence studies; 1 in production.
    progress : bool, optional
        tqdm progress bar; default when stderr is a terminal.

    Returns
    -------
    ranges_m : ndarray
        Terrestrial ranges of the output grid [m], from the first range step.
    heights_m : ndarray
        Heights of the output grid [m], from 0 to >= max_height_m.
    F : ndarray
        Linear propagation factor, shape (len(ranges_m), len(heights_m)), float32; NaN where
        the image ray's elevation exceeds the largest angle carried (use the two-ray model).
    """
    s = _prepare(freq_hz, antenna_height_m, polarization=polarization,
                 elevation_pattern=elevation_pattern, profile=profile,
                 wave_height_m=wave_height_m, max_range_m=max_range_m,
                 max_height_m=max_height_m, fidelity=fidelity, tilt_rad=tilt_rad,
                 surface=surface, permittivity=permittivity, max_angle_rad=max_angle_rad,
                 range_step_m=range_step_m, step_scale=step_scale)
    if height_step_m is None:
        height_step_m = s.lam / (4 * np.sin(s.theta_max))
    decim = max(1, int(round(height_step_m / s.dz)))
    out_idx = np.arange(0, s.n + 1, decim)
    out_idx = out_idx[: np.searchsorted(s.z[out_idx], max_height_m) + 1]
    heights = s.z[out_idx]

    def sample(range_m: float, u: np.ndarray) -> np.ndarray:
        return (np.abs(u[out_idx]) * np.sqrt(range_m)).astype(np.float32)

    ranges, out = _march(s, sample, progress)
    # NaN where the image ray (the steeper one) leaves the angles carried by the grid
    out[_beyond_angle(ranges[:, None], heights[None, :], s.z_a, s.theta_max)] = np.nan
    return ranges, heights, out


def _beyond_angle(range_m, height_m, antenna_height_m, max_angle_rad):
    """True where the image ray's elevation exceeds the largest angle the PE grid carries."""
    return np.arctan2(height_m + antenna_height_m, range_m) > max_angle_rad


def _angular_taper(abs_theta: np.ndarray, theta_max: float) -> np.ndarray:
    """1 up to theta_max, cosine roll-off to 0 at TAPER_END * theta_max."""
    t = np.clip((abs_theta - theta_max) / ((TAPER_END - 1) * theta_max), 0.0, 1.0)
    return 0.5 * (1 + np.cos(np.pi * t))


def _lanczos_abs(u: np.ndarray, dz: float, heights_m: np.ndarray) -> np.ndarray:
    """|u| at arbitrary heights [m]: the modulus of :func:`_lanczos_complex`."""
    return np.abs(_lanczos_complex(u, dz, heights_m))


def _lanczos_complex(u: np.ndarray, dz: float, heights_m: np.ndarray) -> np.ndarray:
    """u at arbitrary heights [m] by Lanczos (windowed-sinc) interpolation of complex u.

    The PE samples u at 2.4 points per shortest wavelength it carries with weight (the angle
    max_angle): linear interpolation of |u| there loses up to 2 dB between nodes, a 6-tap
    Lanczos kernel on the complex field about 0.05 dB (docs/propagation.md).  Within two
    nodes of the surface (or of the top) linear interpolation of u is used.
    """
    n = u.size - 1
    x = heights_m / dz
    i0 = np.floor(x).astype(np.intp)
    t = x - i0
    taps = np.arange(-_LANCZOS_A + 1, _LANCZOS_A + 1)
    idx = i0[:, None] + taps[None, :]
    d = t[:, None] - taps[None, :]
    w = np.sinc(d) * np.sinc(d / _LANCZOS_A)
    w /= w.sum(axis=1, keepdims=True)
    edge = (idx[:, 0] < 0) | (idx[:, -1] > n)
    vals = np.einsum("ij,ij->i", w, u[np.clip(idx, 0, n)])
    if np.any(edge):
        j = np.clip(i0[edge], 0, n - 1)
        te = t[edge]
        vals[edge] = (1 - te) * u[j] + te * u[j + 1]
    return vals


def reference_phase(freq_hz: float, antenna_height_m: float,
                    m_of_h: Callable[[np.ndarray], np.ndarray], max_height_m: float):
    """The smooth part of the PE field's phase, removed before the table stores the field.

    Over the sea the field is the sum of a direct and a sea-reflected wave of phases
    ``phi_d`` and ``phi_r``; their mean ``phi_c = (phi_d + phi_r) / 2`` varies by tens of
    radians between table nodes, their difference (the lobes) slowly along the table's
    (R, w = h / R) axes. With ``phi_c`` removed, the complex field can be interpolated
    bilinearly and keeps its interference nulls (interpolating |F| fills them: a null
    between two nodes at -10 dB reads -16 dB).  ``phi_c`` of the paraxial equation [5]
    (``u_R = (j / 2k) u_hh + j k (m - 1) u``) is taken ray-optically: the free-space term
    ``k (h^2 + h_a^2) / (2 R)`` (the mean of ``k (h -+ h_a)^2 / (2 R)``) plus the phase the
    refractive screen ``k (M(z) - M(0)) 1e-6`` adds along each straight ray (the mean of M
    over the direct path h_a -> h and over the reflected path h_a -> 0 -> h, from the
    cumulative integral of M), minus the ray-bending term ``k g^2 R^3 / 24`` of a linear
    M-gradient g (Schrödinger propagator in a linear potential).  Measured on 10 GHz,
    antenna 20 m, standard atmosphere: the phase step between neighbouring nodes where
    F >= -10 dB falls from p50 0.8 / 1.3 rad (along w / R, raw field) to 0.004 / 0.019 rad;
    what is left along range is removed per row by :func:`_align_rows`.

    Parameters
    ----------
    freq_hz : float
        [Hz].
    antenna_height_m : float
        h_a [m].
    m_of_h : callable
        M profile [M units] of height [m].
    max_height_m : float
        Highest height the phase is needed at [m].

    Returns
    -------
    callable
        ``phase(range_m, height_m)`` [rad], broadcasting.
    """
    k = 2 * np.pi * freq_hz / sc.c
    za = float(antenna_height_m)
    top = float(max_height_m) + za + 10.0
    zz = np.linspace(0.0, top, max(2001, int(top / 0.05) + 1))
    dm = (np.asarray(m_of_h(zz), dtype=float) - float(np.asarray(m_of_h(0.0)))) * 1e-6
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (dm[1:] + dm[:-1]) * np.diff(zz))])
    gradient = (float(np.asarray(m_of_h(top))) - float(np.asarray(m_of_h(top - 1.0)))) * 1e-6

    def integral(z):
        return np.interp(z, zz, cum)

    def phase(range_m, height_m):
        r, h = np.broadcast_arrays(np.asarray(range_m, float), np.asarray(height_m, float))
        span = h - za
        near = np.abs(span) < 1e-3
        direct = np.where(near, np.interp(h, zz, dm),
                          (integral(h) - integral(za)) / np.where(near, 1.0, span))
        reflected = (integral(za) + integral(h)) / (za + h)
        return k * ((h * h + za * za) / (2 * r) + 0.5 * r * (direct + reflected)
                    - gradient**2 * r**3 / 24)

    return phase


def _align_rows(values: np.ndarray) -> np.ndarray:
    """Rotate each row of a complex table (range rows) onto the previous one.

    A phase common to a whole row is free (only |F| is read) and is what the ray-optical
    reference phase leaves along range (ray bending in ducts, mode phase speeds): each row
    is turned by the argument of its magnitude-weighted correlation with the row before.
    """
    out = values.copy()
    theta = 0.0
    for i in range(1, out.shape[0]):
        prod = values[i] * np.conj(values[i - 1])
        c = np.sum(prod[np.isfinite(prod)])
        theta += float(np.angle(c)) if abs(c) > 0 else 0.0
        out[i] = values[i] * np.exp(-1j * theta)
    return out


#: Half-width of the Lanczos kernel used to sample the PE field between its nodes.
_LANCZOS_A = 3


# =========================================================================== table grid
def table_axes(
    freq_hz: float,
    antenna_height_m: float,
    max_range_m: float,
    max_height_m: float,
    range_step_m: float,
    max_angle_rad: float,
    fidelity: str = "standard",
) -> tuple[np.ndarray, np.ndarray]:
    """Axes of a propagation table: terrestrial range [m] and height over range w = h / R [1].

    Why h / R: over the sea F is dominated by the interference of the direct and the
    sea-reflected rays, whose phase difference ``2 k h_a h / R`` is (to O((h/R)^2)) a
    function of w alone.  On a (R, h) grid the lobes are 20 m long in range at 5 km and
    300 m in height (the default PE output, range step ~ 175 m, missed them: 5 dB rms
    between range nodes inside 20 km); on a (R, w) grid they are straight lines along R.
    The w axis has two uniform segments (both looked up by index arithmetic):

    * below ``w_low = h_low / R_max``: step ``surface_step / R_max``, so that near the
      surface at long range (ducts, the diffraction zone) heights are sampled every
      ``surface_step`` metres or finer; ``h_low = max(LOW_LAYER_M, 3 h_a)``;
    * above it up to ``tan(max_angle)``: ``lambda / (2 h_a lobe_samples)`` (the lobe
      period in w sampled ``lobe_samples`` times), and no coarser than ``DIFFRACTION_STEP``
      times the natural height unit ``(a_e lambda^2 / (8 pi^2))^(1/3)`` at max range.

    Parameters
    ----------
    freq_hz : float
        [Hz].
    antenna_height_m, max_range_m, max_height_m : float
        [m].
    range_step_m : float
        Range step of the table [m] (the PE step).
    max_angle_rad : float
        Largest propagation angle the PE carries [rad].
    fidelity : str
        Preset of :data:`FIDELITY` (``lobe_samples``, ``surface_step_m``).

    Returns
    -------
    ranges_m, w : ndarray
        Range axis (uniform, from ``range_step_m``) and the w axis (0 first).
    """
    preset = FIDELITY[fidelity]
    lam = sc.c / freq_hz
    a_e = prop.STANDARD_K_FACTOR * prop.EARTH_RADIUS_M
    height_unit = (a_e * lam**2 / (8 * np.pi**2)) ** (1 / 3)
    dw_coarse = min(lam / (2 * antenna_height_m * preset["lobe_samples"]),
                    DIFFRACTION_STEP * height_unit / max_range_m)
    dw_fine = min(dw_coarse, preset["surface_step_m"] / max_range_m)
    w_max = np.tan(max_angle_rad)
    h_low = min(max(LOW_LAYER_M, 3 * antenna_height_m), max_height_m)
    n_fine = int(np.ceil(h_low / max_range_m / dw_fine))
    w_low = n_fine * dw_fine
    n_coarse = max(1, int(np.ceil((w_max - w_low) / dw_coarse)))
    w = np.concatenate([np.arange(n_fine) * dw_fine, w_low + np.arange(n_coarse + 1) * dw_coarse])
    n_r = int(np.ceil(max_range_m / range_step_m - 1e-9))
    ranges = range_step_m * np.arange(1, n_r + 1)
    return ranges, w


#: Lowest height [m] whose w interval is sampled with the fine (surface) step at max range.
LOW_LAYER_M = 100.0
#: Largest step of the w axis at max range, in natural height units (a_e lambda^2/8pi^2)^(1/3).
DIFFRACTION_STEP = 0.5


def table_pe_height(freq_hz: float, antenna_height_m: float,
                    m_of_h: Callable[[np.ndarray], np.ndarray], *, max_range_m: float,
                    max_height_m: float, fidelity: str = "standard",
                    max_angle_rad: float | None = None, polarization: str = "H",
                    surface: str = "sea") -> float:
    """Height [m] the PE of a table must reach: ``max_height_m`` and one w cell above it.

    The w axis needs the PE's range step and angle, the PE domain needs the w axis: the
    first grid is the one of ``max_height_m``, and every height up to it lies in a complete
    cell of the table (:func:`build_propagation_table`).
    """
    first = grid_steps(freq_hz, max_height_m, max_range_m, m_of_h, fidelity, max_angle_rad,
                       polarization=polarization, surface=surface)
    _, w_probe = table_axes(freq_hz, antenna_height_m, max_range_m, max_height_m,
                            first["dx"], first["max_angle_rad"], fidelity)
    return max_height_m + max_range_m * float(np.max(np.diff(w_probe)))


def table_grid(freq_hz: float, antenna_height_m: float, *, polarization: str,
               profile: Mapping[str, Any] | Callable[[np.ndarray], np.ndarray],
               wave_height_m: float = 0.0, max_range_m: float, max_height_m: float,
               fidelity: str = "standard", max_angle_rad: float | None = None,
               surface: str = "sea") -> dict[str, Any]:
    """The grid :func:`build_propagation_table` would use, without building anything.

    The same rules as the builder (:func:`table_pe_height`, :func:`pe_top_height`,
    :func:`grid_steps`, :func:`table_axes`); :mod:`shipradar.tables.budget` reads it to estimate a
    table's memory and build time before any work.

    Returns
    -------
    dict
        ``n`` (PE height intervals), ``n_steps`` (PE range steps), ``dx`` [m], ``dz`` [m],
        ``n_ranges`` and ``n_w`` (the table's shape), ``sampled`` (table cells inside the
        PE's domain and angles, the ones interpolated from the field), ``rough`` (the
        boundary is rebuilt at every step).
    """
    pol = prop.normalize_polarization(polarization)
    m_of_h = prop.profile_from_spec(profile) if isinstance(profile, Mapping) else profile
    top = table_pe_height(freq_hz, antenna_height_m, m_of_h, max_range_m=max_range_m,
                          max_height_m=max_height_m, fidelity=fidelity,
                          max_angle_rad=max_angle_rad, polarization=pol, surface=surface)
    steps = grid_steps(freq_hz, pe_top_height(top, max_range_m, antenna_height_m),
                       max_range_m, m_of_h, fidelity, max_angle_rad, polarization=pol,
                       surface=surface)
    n_steps = int(np.ceil(max_range_m / steps["dx"]))
    dx = max_range_m / n_steps
    ranges, w = table_axes(freq_hz, antenna_height_m, max_range_m, max_height_m, dx,
                           steps["max_angle_rad"], fidelity)
    # the cells build_propagation_table's sample() interpolates: h <= top, image ray carried
    limit = np.minimum(top / ranges, np.tan(steps["max_angle_rad"]) - antenna_height_m / ranges)
    sampled = int(np.searchsorted(w, limit, side="right").sum())
    return {"n": int(steps["n"]), "n_steps": n_steps, "dx": dx, "dz": float(steps["dz"]),
            "n_ranges": int(ranges.size), "n_w": int(w.size), "sampled": sampled,
            "top_m": top, "rough": surface == "sea" and wave_height_m > 0}


# =========================================================================== table
def propagation_table_inputs(
    freq_hz: float,
    antenna_height_m: float,
    *,
    polarization: str,
    pattern_description: Mapping[str, Any],
    profile: Mapping[str, Any],
    wave_height_m: float = 0.0,
    max_range_m: float,
    max_height_m: float,
    fidelity: str = "standard",
    tilt_rad: float = 0.0,
    surface: str = "sea",
    sea_temperature_c: float = prop.SEA_TEMPERATURE_C,
    salinity_psu: float = prop.SEA_SALINITY_PSU,
    max_angle_rad: float | None = None,
) -> dict[str, Any]:
    """Exactly the inputs that change a propagation table (hashed into its cache key)."""
    return {
        "freq_hz": float(freq_hz),
        "antenna_height_m": float(antenna_height_m),
        "polarization": prop.normalize_polarization(polarization),
        "pattern": dict(pattern_description),
        "tilt_rad": float(tilt_rad),
        "profile": prop.normalize_profile_spec(profile),
        "wave_height_m": float(wave_height_m),
        "max_range_m": float(max_range_m),
        "max_height_m": float(max_height_m),
        "fidelity": str(fidelity),
        "surface": str(surface),
        "sea_temperature_c": float(sea_temperature_c) if surface == "sea" else None,
        "salinity_psu": float(salinity_psu) if surface == "sea" else None,
        "max_angle_rad": None if max_angle_rad is None else float(max_angle_rad),
    }


def build_propagation_table(
    freq_hz: float,
    antenna_height_m: float,
    *,
    polarization: str,
    elevation_pattern: Callable[[np.ndarray], np.ndarray] | None,
    pattern_description: Mapping[str, Any] | None = None,
    profile: Mapping[str, Any],
    wave_height_m: float = 0.0,
    max_range_m: float,
    max_height_m: float,
    fidelity: str = "standard",
    tilt_rad: float = 0.0,
    surface: str = "sea",
    sea_temperature_c: float = prop.SEA_TEMPERATURE_C,
    salinity_psu: float = prop.SEA_SALINITY_PSU,
    max_angle_rad: float | None = None,
    progress: bool | None = None,
) -> Table:
    """Build the table F(R_t, h) with the PE (no cache; see :func:`get_propagation_table`).

    The field is stored on the (range, w = h / R) grid of :func:`table_axes`, sampled from
    the PE nodes by :func:`_lanczos_complex`: |F| as ``values`` and the complex field with
    its smooth phase removed (:func:`reference_phase`, :func:`_align_rows`) as the extra
    arrays ``field_re`` and ``field_im``; :func:`propagation_factor` interpolates the latter
    at (R, h), so a null between nodes stays a null.
    The PE domain reaches one w cell above ``max_height_m`` so that every height up to
    ``max_height_m`` lies in a complete cell.

    The callable pattern cannot be hashed: ``pattern_description`` (e.g. ``{"kind":
    "gaussian", "beamwidth_rad": ..., "sidelobe_db": ...}``) stands for it in the provenance
    and must describe it completely; it may be omitted only for the isotropic pattern.
    ``profile`` is a description dict (see
    :func:`shipradar.sensors.propagation.normalize_profile_spec`).

    Returns
    -------
    Table
        Axes ``("range_m", "height_over_range")`` in ``("m", "1")``; values: linear F
        (float32), NaN where the PE does not apply (steep angles, above the domain).
    """
    if pattern_description is None:
        if elevation_pattern is not None:
            raise ValueError("a callable elevation_pattern needs its pattern_description")
        pattern_description = {"kind": "isotropic"}
    inputs = propagation_table_inputs(
        freq_hz, antenna_height_m, polarization=polarization,
        pattern_description=pattern_description, profile=profile, wave_height_m=wave_height_m,
        max_range_m=max_range_m, max_height_m=max_height_m, fidelity=fidelity, tilt_rad=tilt_rad,
        surface=surface, sea_temperature_c=sea_temperature_c, salinity_psu=salinity_psu,
        max_angle_rad=max_angle_rad,
    )
    eps = prop.sea_water_permittivity(freq_hz, sea_temperature_c, salinity_psu)
    m_of_h = prop.profile_from_spec(inputs["profile"])
    top = table_pe_height(freq_hz, antenna_height_m, m_of_h, max_range_m=max_range_m,
                          max_height_m=max_height_m, fidelity=fidelity,
                          max_angle_rad=max_angle_rad, polarization=polarization,
                          surface=surface)
    s = _prepare(freq_hz, antenna_height_m, polarization=polarization,
                 elevation_pattern=elevation_pattern, profile=m_of_h,
                 wave_height_m=wave_height_m, max_range_m=max_range_m, max_height_m=top,
                 fidelity=fidelity, tilt_rad=tilt_rad, surface=surface,
                 permittivity=complex(eps), max_angle_rad=max_angle_rad, range_step_m=None,
                 step_scale=1.0)
    ranges, w = table_axes(freq_hz, antenna_height_m, max_range_m, max_height_m, s.dx,
                           s.theta_max, fidelity)
    tan_max = np.tan(s.theta_max)
    phase = reference_phase(freq_hz, antenna_height_m, m_of_h, top)

    def sample(range_m: float, u: np.ndarray) -> np.ndarray:
        row = np.full(w.size, np.nan + 0j, dtype=np.complex64)
        h = w * range_m
        # nodes inside the domain and the carried angles (image ray, as solve_pe)
        ok = (h <= top) & (h + s.z_a <= tan_max * range_m)
        row[ok] = (_lanczos_complex(u, s.dz, h[ok]) * np.sqrt(range_m)
                   * np.exp(-1j * phase(range_m, h[ok])))
        return row

    r_pe, field = _march(s, sample, progress)
    if not np.allclose(r_pe, ranges, rtol=1e-9, atol=1e-6):
        raise RuntimeError("PE ranges do not match the table axis")
    field = _align_rows(field)
    values = np.abs(field).astype(np.float32)
    return Table(
        name=TABLE_NAME,
        version=TABLE_VERSION,
        axes=(ranges, w),
        axis_names=("range_m", "height_over_range"),
        axis_units=("m", "1"),
        values=values,
        value_name="propagation_factor",
        value_unit="1 (linear field ratio)",
        inputs=inputs,
        # the field itself, its smooth phase removed (reference_phase, _align_rows): the
        # lookup interpolates it and keeps the interference nulls
        extra={"field_re": field.real.astype(np.float32),
               "field_im": field.imag.astype(np.float32)},
    )


def get_propagation_table(
    freq_hz: float, antenna_height_m: float, *, root=None, **kwargs: Any
) -> tuple[Table, bool]:
    """:func:`build_propagation_table` through the cache
    (:func:`shipradar.tables.store.get_or_build`).

    Same arguments as :func:`build_propagation_table`, plus ``root`` (cache directory; default
    ``$SHIPRADAR_TABLES``).  Returns ``(table, built)``; ``built`` is False on a cache hit.
    """
    spec = {k: v for k, v in kwargs.items() if k not in ("elevation_pattern", "progress")}
    if spec.get("pattern_description") is None:
        if kwargs.get("elevation_pattern") is not None:
            raise ValueError("a callable elevation_pattern needs its pattern_description")
        spec["pattern_description"] = {"kind": "isotropic"}
    inputs = propagation_table_inputs(freq_hz, antenna_height_m, **spec)
    return get_or_build(
        TABLE_NAME, TABLE_VERSION, inputs,
        lambda: build_propagation_table(freq_hz, antenna_height_m, **kwargs), root=root,
    )


# =========================================================================== lookup
#: Stands for NaN inside the lookup's copy of the table: a corner of zero weight adds
#: exactly 0 * SENTINEL = 0, any positive weight makes the result negative (F >= 0), so one
#: sign test replaces a NaN mask per corner.
_SENTINEL = np.float32(-1e30)
#: Bound on |F| of any real field in a table: an interpolated real part below its negative
#: comes from a NaN corner (sentinel) of positive weight.
_FIELD_LIMIT = 1e3


class PropagationLookup:
    """Bilinear lookup of F at (range [m], height [m]) in a table of :func:`table_axes`.

    O(1) per point and vectorized: both axes are uniform (w in two uniform segments), so
    cell indices are computed, not searched; the four corners are gathered from one flat
    complex64 array (the field with its smooth phase removed, ``field_re``/``field_im``)
    and F is the modulus of their bilinear combination, which keeps the interference nulls
    between nodes (a table without the field: float32 |F|, bilinear).  Against a NaN
    corner of positive weight the sentinel -1e30 drives the real part below -_FIELD_LIMIT.
    NaN outside the table's domain (range outside the axis, height < 0 or above
    ``max_height_m``) and where any corner of positive weight is NaN (steep angles):
    the caller falls back to :func:`shipradar.sensors.propagation.two_ray_factor` and counts it.
    """

    def __init__(self, table: Table):
        r_axis, w_axis = table.axes
        self.nr, self.nw = len(r_axis), len(w_axis)
        self.r0 = float(r_axis[0])
        self.inv_dr = (self.nr - 1) / float(r_axis[-1] - r_axis[0])
        dw = np.diff(w_axis)
        if w_axis[0] != 0.0:
            raise ValueError("the w axis must start at 0")
        change = np.nonzero(~np.isclose(dw, dw[0], rtol=1e-6, atol=0))[0]
        n_fine = int(change[0]) if change.size else self.nw - 1
        rest = dw[n_fine:]
        if (not np.allclose(np.diff(r_axis), 1 / self.inv_dr, rtol=1e-6, atol=0)
                or (rest.size and not np.allclose(rest, rest[0], rtol=1e-6, atol=0))):
            raise ValueError("a propagation table needs uniform axes (w in two segments)")
        self.inv_fine = 1.0 / float(dw[0])
        self.inv_coarse = 1.0 / float(rest[0]) if rest.size else self.inv_fine
        self.w_low = float(w_axis[n_fine])
        self.n_fine = n_fine
        self.max_height = float(table.inputs.get("max_height_m", np.inf))
        if "field_re" in table.extra:
            # the complex field (smooth phase removed): bilinear in re and im keeps a null
            # that falls between nodes, where bilinear in |F| fills it (issue 18, item 5)
            v = (np.asarray(table.extra["field_re"], dtype=np.float32)
                 + 1j * np.asarray(table.extra["field_im"], dtype=np.float32))
            self.flat = np.where(np.isnan(v), np.complex64(_SENTINEL), v).astype(
                np.complex64).ravel()
            self.complex = True
        else:
            v = np.asarray(table.values, dtype=np.float32)
            self.flat = np.where(np.isnan(v), _SENTINEL, v).ravel()
            self.complex = False

    def __call__(self, range_m: np.ndarray, height_m: np.ndarray) -> np.ndarray:
        r, h = np.broadcast_arrays(np.asarray(range_m, dtype=float),
                                   np.asarray(height_m, dtype=float))
        shape = r.shape
        r = r.ravel()
        h = h.ravel()
        out = np.empty(r.size)
        # blocks of LOOKUP_BLOCK points: the temporaries stay in cache and below the size at
        # which malloc maps fresh pages for each of them (2600 page faults per 1e5 points)
        for s in range(0, r.size, LOOKUP_BLOCK):
            self._block(r[s:s + LOOKUP_BLOCK], h[s:s + LOOKUP_BLOCK], out[s:s + LOOKUP_BLOCK])
        return out.reshape(shape)

    def _block(self, r: np.ndarray, h: np.ndarray, out: np.ndarray) -> None:
        x = r - self.r0
        x *= self.inv_dr
        # index along w: two uniform segments in one expression (no branch per point); at
        # R = 0, w is inf or NaN and the point is outside
        with np.errstate(divide="ignore", invalid="ignore"):
            w = h / r
            y = w - self.w_low
            np.maximum(y, 0.0, out=y)
            y *= self.inv_coarse - self.inv_fine
            w *= self.inv_fine
            y += w
        eps = 1e-9  # index rounding: a point on the last node is on that node
        inside = x >= -eps
        inside &= x <= self.nr - 1 + eps
        inside &= h >= 0.0
        inside &= h <= self.max_height
        inside &= y <= self.nw - 1 + eps
        outside = ~inside
        x[outside] = 0.0
        y[outside] = 0.0
        np.clip(x, 0.0, self.nr - 1, out=x)
        np.clip(y, 0.0, self.nw - 1, out=y)
        i = x.astype(np.intp)
        np.minimum(i, self.nr - 2, out=i)
        j = y.astype(np.intp)
        np.minimum(j, self.nw - 2, out=j)
        x -= i  # now the weight of the upper range node
        y -= j  # and of the upper w node
        i *= self.nw
        i += j  # flat index of the lower-left corner
        f = self.flat
        lo = f.take(i) * (1.0 - y)
        lo += f.take(i + 1) * y
        i += self.nw
        hi = f.take(i) * (1.0 - y)
        hi += f.take(i + 1) * y
        hi *= x
        lo *= 1.0 - x
        if self.complex:
            lo += hi
            # a NaN corner of positive weight (>= 1e-13: index rounding) drives the real part
            # below -1e17; a real field has |F| of a few units at most
            outside |= lo.real < -_FIELD_LIMIT
            np.abs(lo, out=out)
        else:
            np.add(lo, hi, out=out)
            outside |= out < 0.0
        out[outside] = np.nan


#: Points per block of :meth:`PropagationLookup.__call__` (64 KiB float64 temporaries).
LOOKUP_BLOCK = 8192


_LOOKUPS: dict[int, tuple[weakref.ref, PropagationLookup]] = {}


def _lookup_for(table: Table) -> PropagationLookup:
    """The (cached) lookup of a table; the cache entry dies with the table."""
    entry = _LOOKUPS.get(id(table))
    if entry is not None and entry[0]() is table:
        return entry[1]
    lookup = PropagationLookup(table)
    key = id(table)
    _LOOKUPS[key] = (weakref.ref(table, lambda _ref: _LOOKUPS.pop(key, None)), lookup)
    return lookup


def propagation_factor(table: Table, range_m: np.ndarray, height_m: np.ndarray) -> np.ndarray:
    """Linear F at terrestrial ranges [m] and heights [m] from a propagation table.

    Bilinear interpolation on the table's (range, h / R) grid by :class:`PropagationLookup`
    (built once per table and cached); O(1) per point.  NaN outside the table's domain and
    where the table holds NaN (steep angles): the caller falls back to
    :func:`shipradar.sensors.propagation.two_ray_factor` and counts it.
    """
    if table.axis_names[1] == "height_m":  # a plain (range, height) table
        return table.lookup(*np.broadcast_arrays(np.asarray(range_m, float),
                                                 np.asarray(height_m, float)))
    return _lookup_for(table)(range_m, height_m)
