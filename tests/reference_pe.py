"""An independent parabolic-equation solver, the test oracle of the propagation tables.

Written from the literature, sharing no code with :mod:`shipradar.sensors.parabolic_equation` (a
split-step *Fourier* solver): this one is the split-step **Padé** method of Collins (1993,
J. Acoust. Soc. Am. 93(4) 1736-1742) on a finite-difference height grid, as in PyWaveProp and RAM:

* one-way equation ``u_x = i k (sqrt(1 + X) - 1) u`` with ``X = k^-2 d^2/dz^2 + (n^2 - 1)``,
  ``n^2 - 1 = 2 (M(z) - M(0)) 1e-6`` (earth flattening inside M);
* the range step ``exp(i k dx (sqrt(1 + X) - 1))`` by its [p/p] Padé approximant in X
  (Taylor series of the exponential of the binomial series, ``scipy.interpolate.pade``),
  factored into p rational factors, each one tridiagonal solve;
* d^2/dz^2 by Numerov's fourth-order compact scheme ``B^-1 A``, ``A = delta^2 / dz^2``,
  ``B = 1 + delta^2 / 12``, so every factor stays tridiagonal;
* a perfectly conducting sea for horizontal polarization: u = 0 at z = 0 (Dirichlet); an
  absorbing layer (imaginary n^2 rising as a square over the top third) and u = 0 at the top;
* the antenna: a Gaussian aperture ``exp(-(z - z_a)^2 / 2 w^2)`` minus its image, whose
  far-field pattern is ``g(theta) = exp(-(k w sin theta)^2 / 2)``; F = |u| sqrt(x) / (w sqrt(k))
  (stationary phase: F -> g on the beam axis in free space).
"""

from __future__ import annotations

import numpy as np
import scipy.constants as sc
from scipy.interpolate import pade
from scipy.linalg import solve_banded
from scipy.special import binom


def pade_factors(k_dx: float, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients a_j, b_j of exp(i k dx (sqrt(1+X) - 1)) ~ prod (1 + a_j X)/(1 + b_j X)."""
    n = 2 * order + 1
    g = np.array([0.0] + [binom(0.5, m) for m in range(1, n)], dtype=complex)
    c = 1j * k_dx * g
    e = np.zeros(n, dtype=complex)
    e[0] = 1.0
    for m in range(1, n):  # exponential of a power series
        e[m] = sum(j * c[j] * e[m - j] for j in range(1, m + 1)) / m
    # in the variable Y = k dx X the coefficients stay of order 1 (in X they grow as
    # (k dx)^m and the Padé system is singular); the roots scale back
    scale = 1.0 / k_dx
    num, den = pade(e * scale ** np.arange(n), order, order)
    a = -1.0 / (scale * np.roots(num.coeffs))
    b = -1.0 / (scale * np.roots(den.coeffs))
    return a, b


def gaussian_pattern(freq_hz: float, aperture_m: float):
    """Far-field field pattern g(theta) of the Gaussian aperture of 1/e half-width w [m]."""
    k = 2 * np.pi * freq_hz / sc.c
    return lambda theta: np.exp(-0.5 * (k * aperture_m * np.sin(np.asarray(theta))) ** 2)


def solve(freq_hz: float, antenna_height_m: float, aperture_m: float, m_profile,
          max_range_m: float, out_ranges_m: np.ndarray, out_heights_m: np.ndarray, *,
          top_m: float, dz: float = 0.05, dx: float = 20.0, order: int = 6) -> np.ndarray:
    """F on the grid (out_ranges_m x out_heights_m); out ranges must be multiples of dx.

    Parameters
    ----------
    freq_hz : float
        [Hz].
    antenna_height_m, aperture_m : float
        Aperture centre z_a and 1/e half-width w [m].
    m_profile : callable
        M [M units] of height [m].
    max_range_m : float
        [m].
    out_ranges_m, out_heights_m : ndarray
        Output grid [m]; heights below 2/3 of ``top_m``.
    top_m : float
        Domain top [m] (absorber over its upper third).
    dz, dx : float
        Height and range steps [m].
    order : int
        Padé order.
    """
    k = 2 * np.pi * freq_hz / sc.c
    n = int(round(top_m / dz))
    z = dz * np.arange(1, n)  # interior nodes; u = 0 at 0 and at the top
    nsq = 2e-6 * (np.asarray(m_profile(z), float) - float(np.asarray(m_profile(0.0))))
    z_abs = 2.0 * top_m / 3.0
    nsq = nsq + 1j * 0.01 * np.clip((z - z_abs) / (top_m - z_abs), 0, None) ** 2
    u = (np.exp(-0.5 * ((z - antenna_height_m) / aperture_m) ** 2)
         - np.exp(-0.5 * ((z + antenna_height_m) / aperture_m) ** 2)).astype(complex)
    a_coef, b_coef = pade_factors(k * dx, order)
    m = z.size

    def banded(c):
        # k^2 B + c (A + k^2 B diag(nsq)) as (upper, diagonal, lower) bands
        up = np.full(m, k * k / 12 + c / dz**2, dtype=complex)
        di = k * k * 10 / 12 - 2 * c / dz**2 + c * k * k * 10 / 12 * nsq
        lo = np.full(m, k * k / 12 + c / dz**2, dtype=complex)
        up[1:] += c * k * k / 12 * nsq[1:]
        lo[:-1] += c * k * k / 12 * nsq[:-1]
        return up, di, lo

    mats = []
    for a, b in zip(a_coef, b_coef, strict=True):
        ua, da, la = banded(a)
        ub, db, lb = banded(b)
        ab = np.zeros((3, m), dtype=complex)
        ab[0, 1:] = ub[1:]
        ab[1] = db
        ab[2, :-1] = lb[:-1]
        mats.append((ab, (ua, da, la)))
    steps = int(round(max_range_m / dx))
    want = {int(round(r / dx)): i for i, r in enumerate(out_ranges_m)}
    out = np.full((len(out_ranges_m), len(out_heights_m)), np.nan)
    for s in range(1, steps + 1):
        for ab, (ua, da, la) in mats:
            rhs = da * u
            rhs[:-1] += ua[1:] * u[1:]
            rhs[1:] += la[:-1] * u[:-1]
            u = solve_banded((1, 1), ab, rhs)
        if s in want:
            # the complex field is interpolated (|u| would fill a null between nodes)
            zz = np.concatenate([[0.0], z])
            uu = np.concatenate([[0.0], u])
            row = np.abs(np.interp(out_heights_m, zz, uu.real)
                         + 1j * np.interp(out_heights_m, zz, uu.imag))
            out[want[s]] = row * np.sqrt(s * dx) / (aperture_m * np.sqrt(k))
    return out
