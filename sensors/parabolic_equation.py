"""Split-step Fourier parabolic-equation solver for the propagation factor F(R_t, h)
(seed [5]-[6]; SPEC section 3; issue 4).

The physics of the off-line propagation table: the table's grid, builder, cache and lookup
are :mod:`shipradar.tables.propagation`, which marches this solver (:func:`prepare_march`,
:func:`march`) and samples its field between nodes (:func:`interpolate_field`) with the
smooth phase removed (:func:`reference_phase`).

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
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.constants as sc
import scipy.fft as sfft
from numpy.typing import ArrayLike, NDArray

from shipradar.sensors import geometry
from shipradar.sensors import propagation as prop

#: Fidelity presets of the PE grid.  max_angle_deg: largest propagation angle carried (the
#: field is NaN beyond it); nyquist_factor: oversampling of the angular spectrum (Nyquist angle
#: over the end of the taper); boundary_kz_dz: largest k sin(max_angle) dz for the impedance
#: boundary of vertical polarization (the discrete condition reflects like the continuous one
#: at sin(p dz) / dz instead of p; see :func:`grid_steps`); phase_error_rad: allowed splitting
#: phase error at max_angle, which sets the range step.  The table's own sampling of each
#: preset is :data:`shipradar.tables.propagation.TABLE_SAMPLING`.
FIDELITY: dict[str, dict[str, float]] = {
    "coarse": {"max_angle_deg": 3.0, "nyquist_factor": 1.1, "boundary_kz_dz": 0.8,
               "phase_error_rad": 0.6},
    "standard": {"max_angle_deg": 5.0, "nyquist_factor": 1.2, "boundary_kz_dz": 0.45,
                 "phase_error_rad": 0.25},
    "fine": {"max_angle_deg": 8.0, "nyquist_factor": 1.5, "boundary_kz_dz": 0.3,
             "phase_error_rad": 0.08},
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
    profile: Callable[[ArrayLike], np.ndarray],
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
    grad = max(grad, 1e-6 / geometry.EARTH_RADIUS_M)
    dx = np.sqrt(2 * preset["phase_error_rad"] / (k * np.sin(theta) * grad))
    absorber_dx = _absorber_step(domain, theta)
    dx = float(min(dx, max_range_m * _MAX_STEP_FRACTION, absorber_dx))
    return {"dz": dz, "dx": dx, "n": n, "domain_m": domain, "max_angle_rad": theta,
            "absorber_dx": absorber_dx}


def trapping_layer(m_of_h: Callable[[ArrayLike], np.ndarray], max_height_m: float
                   ) -> tuple[float, float]:
    """The strongest trapping layer of an M-profile below ``max_height_m``: its largest
    trapped angle [rad] and the height of its M minimum [m] (0, 0 without a trapping layer).

    A ray at elevation θ turns back where M has risen by θ²/2 × 10^6 above its value at the
    launch height (Snell's law in the flat-earth M form, cos θ ∝ 1/m), so a layer where M falls
    by ΔM (the largest fall of M with height, from any height to any higher one) traps rays
    up to ``θ_trap = sqrt(2 ΔM × 10^-6)``, and the modes it carries interfere with vertical
    periods down to ``λ / (2 θ_trap)`` (5.6 m at 3 GHz for ΔM = 40).  The standard gradient
    and the bottom 1 mm of an evaporation duct's logarithm aside, every fall counts.

    Parameters
    ----------
    m_of_h : callable
        M profile [M units] of height [m].
    max_height_m : float
        Highest height examined [m].

    Returns
    -------
    theta_trap_rad, minimum_height_m : float
    """
    z = np.concatenate([[1e-3], np.linspace(0.01, max_height_m, 20001)])
    m = np.asarray(m_of_h(z), dtype=float)
    fall = np.maximum.accumulate(m) - m
    i = int(np.argmax(fall))
    if fall[i] <= 0.0:
        return 0.0, 0.0
    return float(np.sqrt(2e-6 * fall[i])), float(z[i])


def pe_top_height(max_height_m: float, max_range_m: float, antenna_height_m: float) -> float:
    """Top of the PE's free domain [m]: the wanted height, and at least SHADOW_MARGIN times
    the height of the antenna's shadow boundary at max range (4/3 earth).

    The field that diffracts into the shadow comes from just above its boundary: with the
    absorber at 1.1 times that height, F at 10 m, 50-60 km (5.6 GHz, antenna 25 m) was 14 dB
    off and had a false null; at 2 times up to 1 dB off, at 2.5 times within 0.2 dB of the
    converged field (5 times) (measured, docs/propagation.md).  The cost grows with it:
    (R - sqrt(2 a_e h_a))^2 / a_e.
    """
    a_e = geometry.K_FACTOR * geometry.EARTH_RADIUS_M
    beyond = max(max_range_m - float(prop.horizon_range(antenna_height_m, 0.0)), 0.0)
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
    return float(ABSORBER_FRACTION * domain_m
                 / (ABSORBER_STEPS * np.tan(TAPER_END * max_angle_rad)))


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
        # imported here: scipy.signal imports scipy.stats (0.3-0.7 s), which a run that only
        # reads the cached tables (and the build estimates' grid rules) never needs
        from scipy.signal import lfilter

        r = self.r
        n = w.size + 1
        x = np.zeros(n + 1, dtype=complex)
        x[2:] = 2 * self.dz * w  # v_j = r v_{j-1} + 2 dz w_{j-1}, w_0 = 0
        v = lfilter([1.0], [1.0, -r], x)
        y = np.zeros(n + 1, dtype=complex)
        y[1:] = r * v[::-1][:-1]  # u_{j-1} = -r u_j + r v_j, from u_N = 0 downwards
        s: np.ndarray = lfilter([1.0], [1.0, r], y)
        return s[::-1]


def _surface_alpha(freq_hz: float, pol: str, permittivity: complex) -> complex:
    """Leontovich impedance constant (physics convention) for sea water."""
    k = 2 * np.pi * freq_hz / sc.c
    eps = np.conj(permittivity)  # engineering eps' - j eps'' -> physics eps' + j eps''
    root = np.sqrt(eps - 1)
    return complex(1j * k * root if pol == "H" else 1j * k * root / eps)


def _plane_wave_gamma(p: np.ndarray, k: float, alpha: complex) -> np.ndarray:
    """Reflection coefficient of the impedance boundary for the plane wave of wavenumber |p|."""
    ip = 1j * np.abs(p)
    gamma: np.ndarray = (ip - alpha) / (ip + alpha)
    return gamma


def _rough_alpha(alpha: complex, psi: float, rho: float, k: float) -> complex:
    """Impedance whose plane-wave reflection at grazing psi is rho * Gamma(psi)."""
    if psi <= 0 or rho >= 1.0:
        return alpha
    ip = 1j * k * np.sin(psi)
    gamma = rho * (ip - alpha) / (ip + alpha)
    return complex(ip * (1 - gamma) / (1 + gamma))


# =========================================================================== solver
@dataclass(frozen=True, eq=False)
class MarchSetup:
    """Everything the march needs (:func:`prepare_march`): grid, boundary, starting field,
    propagators."""

    #: Polarization ``"H"``/``"V"`` and surface ``"sea"``/``"pec"``.
    pol: str
    surface: str
    #: The grid of :func:`grid_steps` (dz and n after ``step_scale``).
    steps: dict[str, float]
    #: Height step [m], height intervals, largest angle carried [rad].
    dz: float
    n: int
    theta_max: float
    #: Range step [m], range steps, and steps between output rows.
    dx: float
    n_steps: int
    every: int
    #: More than :data:`LARGE_GRID_WORK` (the rough boundary takes the faster powers).
    large: bool
    #: Wavelength [m] and wavenumber [rad/m].
    lam: float
    k: float
    #: Node heights [m] (n + 1) and the antenna height [m].
    z: np.ndarray
    z_a: float
    #: Impedance constant of the smooth sea (inf for a perfect conductor).
    alpha: complex
    #: Starting field on the nodes.
    u0: NDArray[np.complex128]
    #: Free-space propagators of the sine (nodes 1..n-1) and cosine (0..n) transforms.
    free_sine: NDArray[np.complex128]
    free_cos: NDArray[np.complex128]
    #: Refractive phase screen times the absorbing window, per range step.
    screen: NDArray[np.complex128]
    #: Rough sea: the boundary is rebuilt at every range step.
    rough: bool
    wave_height_m: float
    freq_hz: float


# long: the PE's set-up in its documented order: grid, starting field, surface, absorber, M
# params: every physical input and grid control of the PE, as solve_pe takes them
def prepare_march(
    freq_hz: float,
    antenna_height_m: float,
    *,
    polarization: str,
    elevation_pattern: Callable[[np.ndarray], np.ndarray] | None,
    profile: Callable[[ArrayLike], np.ndarray] | Mapping[str, Any],
    wave_height_m: float,
    max_range_m: float,
    max_height_m: float,
    fidelity: str,
    tilt_rad: float,
    surface: str,
    permittivity: complex | None,
    max_angle_rad: float | None,
    range_step_m: float | None,
    step_scale: float,
) -> MarchSetup:
    """Grid, boundary, starting field and propagators of a PE march (arguments of
    :func:`solve_pe`, every one given)."""
    pol = prop.normalize_polarization(polarization)
    if surface not in ("sea", "pec"):
        raise ValueError("surface must be 'sea' or 'pec'")
    if not 0 < antenna_height_m < max_height_m:
        raise ValueError("antenna height must be in (0, max_height_m)")
    if max_range_m <= 0:
        raise ValueError("max_range_m must be > 0")
    m_of_h = prop.profile_from_spec(profile) if isinstance(profile, Mapping) else profile
    pattern = elevation_pattern if elevation_pattern is not None else prop.isotropic_pattern
    steps = grid_steps(freq_hz, pe_top_height(max_height_m, max_range_m, antenna_height_m),
                       max_range_m, m_of_h, fidelity, max_angle_rad, polarization=pol,
                       surface=surface)
    if step_scale != 1.0:
        # a convergence study: the same domain with both steps scaled
        n_scaled = int(sfft.next_fast_len(int(np.ceil(steps["n"] / step_scale))))
        steps["dz"] = steps["domain_m"] / n_scaled
        steps["n"] = n_scaled
    dz, n, theta_max = steps["dz"], int(steps["n"]), steps["max_angle_rad"]
    if range_step_m is None:
        n_steps = int(np.ceil(max_range_m / (steps["dx"] * step_scale)))
        dx = max_range_m / n_steps
        every = 1
    else:
        every = int(np.ceil(range_step_m / (steps["dx"] * step_scale)))
        dx = range_step_m / every
        n_steps = every * int(np.ceil(max_range_m / range_step_m - 1e-9))
    lam = sc.c / freq_hz
    k = 2 * np.pi / lam
    z = dz * np.arange(n + 1)
    eps = prop.sea_water_permittivity(freq_hz) if permittivity is None else complex(permittivity)

    # ---- boundary
    alpha: complex
    gamma_of_p: Callable[[np.ndarray], np.ndarray]
    if surface == "pec":
        alpha = np.inf
        gamma_of_p = (lambda p: -np.ones_like(p)) if pol == "H" else (lambda p: np.ones_like(p))
    else:
        alpha = _surface_alpha(freq_hz, pol, complex(eps))
        gamma_of_p = lambda p: _plane_wave_gamma(p, k, alpha)  # noqa: E731

    # ---- starting field: angular spectrum of the pattern and its image (FFT over 2N samples)
    m_idx = np.fft.fftfreq(2 * n, d=1.0 / (2 * n))
    p = m_idx * np.pi / (n * dz)
    theta = np.arcsin(np.clip(p / k, -1.0, 1.0))
    taper = _angular_taper(np.abs(theta), theta_max) * (np.abs(p) < k)
    norm = np.sqrt(2 * np.pi / k)
    z_a = float(antenna_height_m)
    rho0 = (prop.roughness_factor(np.abs(theta), wave_height_m, freq_hz)
            if surface == "sea" else 1.0)
    spectrum = norm * taper * (
        pattern(theta - tilt_rad) * np.exp(-1j * p * z_a)
        + rho0 * gamma_of_p(p) * pattern(-theta - tilt_rad) * np.exp(1j * p * z_a)
    )
    dp = np.pi / (n * dz)
    u = (dp / (2 * np.pi)) * (2 * n) * np.fft.ifft(spectrum)[: n + 1]
    u[n] = 0.0

    # ---- propagators
    p_sine = np.arange(1, n) * np.pi / (n * dz)
    p_cos = np.arange(0, n + 1) * np.pi / (n * dz)
    m_surface = float(np.asarray(m_of_h(0.0)))
    screen = np.exp(1j * k * dx * (np.asarray(m_of_h(z), dtype=float) - m_surface) * 1e-6)
    z_abs = n * dz * (1 - ABSORBER_FRACTION)
    window = np.where(z <= z_abs, 1.0, 0.5 * (1 + np.cos(np.pi * (z - z_abs) / (n * dz - z_abs))))
    return MarchSetup(
        pol=pol, surface=surface, steps=steps, dz=dz, n=n, theta_max=theta_max, dx=dx,
        n_steps=n_steps, every=every, large=n * n_steps > LARGE_GRID_WORK, lam=lam, k=k, z=z,
        z_a=z_a, alpha=alpha, u0=u,
        free_sine=np.exp(1j * dx * (np.sqrt((k * k - p_sine**2).astype(complex)) - k)),
        free_cos=np.exp(1j * dx * (np.sqrt((k * k - p_cos**2).astype(complex)) - k)),
        # the Hanning window once per absorber step: the absorption per metre of range, not
        # per step, is fixed, so results do not depend on dx through the absorber
        screen=screen * window ** (dx / steps["absorber_dx"]),
        rough=surface == "sea" and wave_height_m > 0,
        wave_height_m=float(wave_height_m), freq_hz=float(freq_hz),
    )


def march(s: MarchSetup, sample: Callable[[float, np.ndarray], np.ndarray],
          progress: bool | None) -> tuple[np.ndarray, np.ndarray]:
    """Run the split-step march; ``sample(range_m, u)`` is called every ``s.every`` steps.

    Returns the output ranges [m] and the stacked rows that ``sample`` returned.
    """
    from tqdm import tqdm

    n, dx, pol = s.n, s.dx, s.pol
    u = s.u0.copy()
    a_e = geometry.K_FACTOR * geometry.EARTH_RADIUS_M
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
            assert boundary is not None  # built above: smooth sea once, rough sea per step
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
    if out is None:
        raise ValueError("the march has no output row (max_range_m below one output step)")
    return ranges, out


# long: 51 docstring lines (each input with its unit); the code is prepare_march + march
# params: the PE's physical inputs and grid controls; tables pass a PropagationTableSpec
def solve_pe(
    freq_hz: float,
    antenna_height_m: float,
    *,
    polarization: str,
    elevation_pattern: Callable[[np.ndarray], np.ndarray] | None,
    profile: Callable[[ArrayLike], np.ndarray] | Mapping[str, Any],
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
    s = prepare_march(freq_hz, antenna_height_m, polarization=polarization,
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
        row: np.ndarray = (np.abs(u[out_idx]) * np.sqrt(range_m)).astype(np.float32)
        return row

    ranges, out = march(s, sample, progress)
    # NaN where the image ray (the steeper one) leaves the angles carried by the grid
    out[_beyond_angle(ranges[:, None], heights[None, :], s.z_a, s.theta_max)] = np.nan
    return ranges, heights, out


def _beyond_angle(range_m: ArrayLike, height_m: ArrayLike, antenna_height_m: float,
                  max_angle_rad: float) -> NDArray[np.bool_]:
    """True where the image ray's elevation exceeds the largest angle the PE grid carries."""
    beyond: NDArray[np.bool_] = (
        np.arctan2(np.asarray(height_m) + antenna_height_m, range_m) > max_angle_rad)
    return beyond


def _angular_taper(abs_theta: np.ndarray, theta_max: float) -> np.ndarray:
    """1 up to theta_max, cosine roll-off to 0 at TAPER_END * theta_max."""
    t = np.clip((abs_theta - theta_max) / ((TAPER_END - 1) * theta_max), 0.0, 1.0)
    return 0.5 * (1 + np.cos(np.pi * t))


#: Half-width of the Lanczos kernel used to sample the PE field between its nodes.
LANCZOS_A = 3


def interpolate_field(u: np.ndarray, dz: float, heights_m: np.ndarray) -> np.ndarray:
    """u at arbitrary heights [m] by Lanczos (windowed-sinc) interpolation of complex u.

    The PE samples u at 2.4 points per shortest wavelength it carries with weight (the angle
    max_angle): linear interpolation of |u| there loses up to 2 dB between nodes, a 6-tap
    Lanczos kernel on the complex field about 0.05 dB (docs/propagation.md).  Within two
    nodes of the surface (or of the top) linear interpolation of u is used.

    Parameters
    ----------
    u : ndarray
        The field on the PE nodes ``j dz``, j = 0..N (complex).
    dz : float
        Node spacing [m].
    heights_m : ndarray
        Heights to sample [m], in [0, N dz].

    Returns
    -------
    ndarray
        u at ``heights_m`` (complex).
    """
    n = u.size - 1
    x = heights_m / dz
    i0 = np.floor(x).astype(np.intp)
    t = x - i0
    taps = np.arange(-LANCZOS_A + 1, LANCZOS_A + 1)
    idx = i0[:, None] + taps[None, :]
    d = t[:, None] - taps[None, :]
    w = np.sinc(d) * np.sinc(d / LANCZOS_A)
    w /= w.sum(axis=1, keepdims=True)
    edge = (idx[:, 0] < 0) | (idx[:, -1] > n)
    vals: np.ndarray = np.einsum("ij,ij->i", w, u[np.clip(idx, 0, n)])
    if np.any(edge):
        j = np.clip(i0[edge], 0, n - 1)
        te = t[edge]
        vals[edge] = (1 - te) * u[j] + te * u[j + 1]
    return vals


def reference_phase(
    freq_hz: float, antenna_height_m: float, m_of_h: Callable[[ArrayLike], np.ndarray],
    max_height_m: float,
) -> Callable[[ArrayLike, ArrayLike], NDArray[np.float64]]:
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
    what is left along range the table builder removes per row
    (:mod:`shipradar.tables.propagation`).

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

    def integral(z: NDArray[np.float64] | float) -> NDArray[np.float64] | float:
        value: NDArray[np.float64] | float = np.interp(z, zz, cum)
        return value

    def phase(range_m: ArrayLike, height_m: ArrayLike) -> NDArray[np.float64]:
        r, h = np.broadcast_arrays(np.asarray(range_m, float), np.asarray(height_m, float))
        span = h - za
        near = np.abs(span) < 1e-3
        direct = np.where(near, np.interp(h, zz, dm),
                          (integral(h) - integral(za)) / np.where(near, 1.0, span))
        reflected = (integral(za) + integral(h)) / (za + h)
        phi: NDArray[np.float64] = k * ((h * h + za * za) / (2 * r)
                                        + 0.5 * r * (direct + reflected)
                                        - gradient**2 * r**3 / 24)
        return phi

    return phase

