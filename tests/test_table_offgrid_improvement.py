"""The I_F table and its coherent gain read off the grid against the functions they cache.

Issue 36 (and STYLE lesson 15): a table is a cache of a physics function, so it is tested as
one, at random points off its grid: on the axis edges, on both signs of the Doppler, past one
period (of the reference PRF and of a stagger) and beyond the spread axis, for every processor
type with a constant and a staggered PRF (a stagger whose Doppler period is short, one whose
period is long, and the shipped scenes' processors), with the "response" pick and the "best".
The reference is the direct evaluation of :mod:`shipradar.sensors.doppler_filters`
(``bank_improvement_factor``, ``staggered_improvement_factor``; ``σ_s = ∞`` for the coherent
gain), with the table's own stability limit and pick rule, both read through
:func:`improvement_and_gain_db` (the dwell's reader).

Tolerance (issue 36's "done when"): at most 0.5 % of the points more than 1 dB from the
function and none more than 6 dB.  There is no exempt point: the exact ties of the pick rule
(two filters of equal response at the target's Doppler) have the same I_F when the two filters
are mirror images (the bank is symmetric), and a tie between unrelated filters is a set of
measure zero that random points do not hit (the test would show it).

``benchmarks/improvement_offgrid.py`` prints the same errors (fraction over 1 dB, p95, max)
per processor for docs/accuracy.md.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from shipradar.sensors import doppler_filters as df
from shipradar.tables import improvement as imp

#: Processors (keywords of ``build_improvement_table``) whose tables are read here.  The
#: "capped" staggers have a period of hundreds of f_r (lcm(950, 1050.5 Hz) = 399.19 f_r;
#: lcm(499, 500 kHz) = 499 f_r), the others a short true period (9.9 and 19.95 f_r).
CASES: dict[str, dict[str, Any]] = {
    # constant PRF
    "mti 2-pulse": dict(processor="mti", mti_pulses=2),
    "mti 3-pulse": dict(processor="mti", mti_pulses=3),
    "dft 16": dict(processor="dft_bank", n_pulses=16),
    "fir 5x32 hann": dict(processor="fir_bank", n_pulses=32, n_filters=5, window="hann"),
    "fir 8 cheb50 (single_missile)": dict(
        processor="fir_bank", n_pulses=8, window="chebyshev", window_sidelobe_db=50),
    "mti2+7 cheb50 (raid giraffe)": dict(
        processor="mti_bank", n_pulses=8, mti_pulses=2, window="chebyshev",
        window_sidelobe_db=50),
    # staggered PRF, short true period
    "mti3 950/1050 (raid sps49)": dict(
        processor="mti", mti_pulses=3, prf_hz=1000.0, stagger_prf_hz=[950.0, 1050.0]),
    "mti3 900/1100": dict(
        processor="mti", mti_pulses=3, prf_hz=1000.0, stagger_prf_hz=[900.0, 1100.0]),
    "dft 16 900/1100": dict(
        processor="dft_bank", n_pulses=16, prf_hz=1000.0, stagger_prf_hz=[900.0, 1100.0]),
    "mti2+7 cheb50 950/1050": dict(
        processor="mti_bank", n_pulses=8, mti_pulses=2, window="chebyshev",
        window_sidelobe_db=50, prf_hz=1000.0, stagger_prf_hz=[950.0, 1050.0]),
    # staggered PRF, long (formerly capped) period
    "mti2 950/1050.5": dict(
        processor="mti", mti_pulses=2, prf_hz=1000.0, stagger_prf_hz=[950.0, 1050.5]),
    "dft 16 950/1050.5": dict(
        processor="dft_bank", n_pulses=16, prf_hz=1000.0, stagger_prf_hz=[950.0, 1050.5]),
    "fir 5x32 hann 950/1050.5": dict(
        processor="fir_bank", n_pulses=32, n_filters=5, window="hann", prf_hz=1000.0,
        stagger_prf_hz=[950.0, 1050.5]),
    "mti2+7 cheb50 950/1050.5": dict(
        processor="mti_bank", n_pulses=8, mti_pulses=2, window="chebyshev",
        window_sidelobe_db=50, prf_hz=1000.0, stagger_prf_hz=[950.0, 1050.5]),
    "fir 32 hann 499/500 kHz": dict(
        processor="fir_bank", n_pulses=32, window="hann", prf_hz=5e5,
        stagger_prf_hz=[499e3, 500e3]),
    # the "best" pick (the largest I_F over the filters; an API option, no scene uses it)
    "dft 16, best pick": dict(processor="dft_bank", n_pulses=16, pick="best"),
    "fir 5x32 hann, best pick": dict(
        processor="fir_bank", n_pulses=32, n_filters=5, window="hann", pick="best"),
    "mti2+7 cheb50 950/1050.5, best pick": dict(
        processor="mti_bank", n_pulses=8, mti_pulses=2, window="chebyshev",
        window_sidelobe_db=50, prf_hz=1000.0, stagger_prf_hz=[950.0, 1050.5], pick="best"),
}
#: The cases run in ``make check``; the others are marked slow.
QUICK = ("mti 2-pulse", "mti2+7 cheb50 (raid giraffe)", "mti3 950/1050 (raid sps49)",
         "mti2 950/1050.5", "dft 16, best pick")
#: Allowed fraction of points more than :data:`TOLERANCE_DB` off, and the largest error [dB].
ALLOWED_FRACTION = 0.005
TOLERANCE_DB = 1.0
MAX_ERROR_DB = 6.0


def blind_speeds_norm(inputs: dict[str, Any]) -> np.ndarray:
    """Doppler multiples [1] where a response of the processor has its nulls or switches:
    the integers (of each bound's PRF for a stagger, over the reference PRF)."""
    if "stagger_prf_hz" not in inputs:
        return np.array([1.0])
    return np.asarray(inputs["stagger_prf_hz"], float) / inputs["prf_hz"]


def offgrid_points(inputs: dict[str, Any], n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` points ``(σ_s/f_r, f_d/f_r)`` [1]: off the grid, on its edges and beyond it.

    Spread: log-uniform over the axis and 0.3 decade beyond both ends (10 %: the axis ends
    and 0).  Doppler: 35 % uniform over ±1.5 f_r, 20 % uniform over ±1000 f_r (past every
    period, both signs), 30 % within f_r/64 of a blind speed of either bound (offsets
    log-uniform down to 1e-7 f_r, both sides) at multiples up to ±1000, 15 % on the edges
    (0, ±1/2, ±1 and each bound's PRF, exactly).
    """
    rng = np.random.default_rng(seed)
    log_s = rng.uniform(imp.LOG10_SPREAD_MIN - 0.3, imp.LOG10_SPREAD_MAX + 0.3, n)
    s = 10.0**log_s
    edge = rng.random(n) < 0.1
    s[edge] = rng.choice([0.0, 10.0**imp.LOG10_SPREAD_MIN, 10.0**imp.LOG10_SPREAD_MAX],
                         edge.sum())
    kind = rng.choice(4, n, p=[0.35, 0.2, 0.3, 0.15])
    d = np.empty(n)
    d[kind == 0] = rng.uniform(-1.5, 1.5, (kind == 0).sum())
    d[kind == 1] = rng.uniform(-1000.0, 1000.0, (kind == 1).sum())
    blind = blind_speeds_norm(inputs)
    m = (kind == 2).sum()
    mult = np.where(rng.random(m) < 0.7, rng.integers(-3, 4, m), rng.integers(-1000, 1001, m))
    offset = rng.choice([-1.0, 1.0], m) * 10.0 ** rng.uniform(-7, np.log10(1 / 64), m)
    d[kind == 2] = mult * rng.choice(blind, m) + offset
    m = (kind == 3).sum()
    d[kind == 3] = rng.choice(np.concatenate([[0.0, 0.5, 1.0], blind]), m) * rng.choice(
        [-1.0, 1.0], m)
    return s, d


def direct_db(inputs: dict[str, Any], spread: np.ndarray, doppler: np.ndarray) -> np.ndarray:
    """The function the table caches, at the points [dB] (``spread = inf``: coherent gain)."""
    w = imp.processor_weights(inputs)
    common = dict(pick=inputs.get("pick", "response"),
                  stability_limit_db=inputs["stability_limit_db"])
    if "stagger_prf_hz" in inputs:
        i_f = df.staggered_improvement_factor(
            w, spread, doppler, prf_hz=inputs["prf_hz"],
            stagger_prf_hz=inputs["stagger_prf_hz"], **common)
    else:
        i_f = df.bank_improvement_factor(w, spread, doppler, **common)
    return 10.0 * np.log10(i_f)


def table_errors_db(table, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """|table - function| [dB] of the I_F and of the coherent gain at :func:`offgrid_points`."""
    s, d = offgrid_points(table.inputs, n, seed)
    i_f, gain = imp.improvement_and_gain_db(table, s, d, "coherent_gain_db")
    err_if = np.abs(i_f - direct_db(table.inputs, s, d))
    err_gain = np.abs(gain - direct_db(table.inputs, np.full(n, np.inf), d))
    return err_if, err_gain


def _check(err: np.ndarray, what: str) -> None:
    over = np.mean(err > TOLERANCE_DB)
    assert over <= ALLOWED_FRACTION, f"{what}: {100 * over:.2f} % of points over 1 dB"
    assert err.max() <= MAX_ERROR_DB, f"{what}: max error {err.max():.2f} dB"


@pytest.mark.parametrize(
    "name",
    [pytest.param(k, marks=() if k in QUICK else pytest.mark.slow) for k in CASES])
def test_table_reads_its_function_off_the_grid(name):
    table = imp.build_improvement_table(**CASES[name], resolution="standard")
    err_if, err_gain = table_errors_db(table, 3000, seed=36)
    assert np.all(np.isfinite(err_if)) and np.all(np.isfinite(err_gain))
    _check(err_if, f"{name} I_F")
    _check(err_gain, f"{name} coherent gain")


@pytest.mark.slow
@pytest.mark.parametrize("name", ["mti 3-pulse", "dft 16", "mti2+7 cheb50 950/1050.5"])
def test_coarse_table_reads_its_function_off_the_grid(name):
    table = imp.build_improvement_table(**CASES[name], resolution="coarse")
    err_if, err_gain = table_errors_db(table, 3000, seed=37)
    _check(err_if, f"{name} I_F (coarse)")
    _check(err_gain, f"{name} coherent gain (coarse)")


def test_the_audit_examples_read_their_function():
    """Issue 36's two examples: a receding target at d = -0.002 in a 32-tap Hann bank staggered
    499/500 kHz (read 62.8 dB where the function gives 0.47 dB), and a 2-pulse MTI's
    coherent gain at d = 0.002 (read -81.9 dB against -41.0 dB)."""
    bank = imp.build_improvement_table(**CASES["fir 32 hann 499/500 kHz"], resolution="standard")
    s = 10.0 ** np.linspace(-7, 0, 29)
    for d in (-0.002, 0.002, -0.5, -3.7, -499.002):
        got = imp.improvement_factor_db(bank, s, d)
        np.testing.assert_allclose(got, direct_db(bank.inputs, s, np.full_like(s, d)),
                                   rtol=0, atol=0.5)
    mti = imp.build_improvement_table(**CASES["mti 2-pulse"], resolution="standard")
    d = np.array([0.002, -0.002, 1.002, 1e-5, -0.5])
    got = imp.improvement_factor_db(mti, 1.0, d, array="coherent_gain_db")
    np.testing.assert_allclose(got, direct_db(mti.inputs, np.full(d.size, np.inf), d),
                               rtol=0, atol=0.05)
