"""Tests of shipradar.tables.improvement: the I_F table, its cache and its on-line lookup."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shipradar.sensors import doppler_filters as df
from shipradar.tables import improvement as imp
from shipradar.tables.store import Table, inputs_hash

PROCESSORS = {
    "mti3": dict(processor="mti", mti_pulses=3),
    "dft16": dict(processor="dft_bank", n_pulses=16),
    "fir5x32hann": dict(processor="fir_bank", n_pulses=32, n_filters=5, window="hann"),
    "mti2+cheb": dict(
        processor="mti_bank", n_pulses=17, mti_pulses=2, window="chebyshev", window_sidelobe_db=60
    ),
    "mti3-stagger": dict(processor="mti", mti_pulses=3, prf_hz=1000.0, stagger_prf_hz=[900, 1100]),
}


@pytest.fixture(scope="module")
def tables():
    return {k: imp.build_improvement_table(**v, resolution="coarse") for k, v in PROCESSORS.items()}


def test_no_processing_builds_nothing_and_reads_zero_db():
    assert imp.build_improvement_table("none") is None
    assert imp.improvement_table("none") == (None, False)
    got = imp.improvement_factor_db(None, np.array([0.0, 0.1]), np.array([[0.2], [0.7]]))
    np.testing.assert_array_equal(got, np.zeros((2, 2)))
    assert np.isnan(imp.improvement_factor_db(None, np.nan, 0.1))


@pytest.mark.parametrize("name", list(PROCESSORS))
def test_grid_values_are_the_physics_at_the_grid_points(tables, name):
    table = tables[name]
    inputs = table.inputs
    w = imp.processor_weights(inputs)
    ax_s, ax_d = table.axes
    rng = np.random.default_rng(7)
    i = rng.integers(0, len(ax_s), 12)
    j = rng.integers(0, len(ax_d), 12)
    spread, dop = 10.0 ** ax_s[i], ax_d[j]
    # a stagger table holds its weights' constant-PRF I_F, which the lookup reads at each
    # bounding PRF (tests/test_table_offgrid_improvement.py checks that reading)
    expected = df.bank_improvement_factor(w, spread, dop)
    np.testing.assert_allclose(table.values[i, j], 10 * np.log10(expected), rtol=1e-12, atol=1e-9)
    if "stagger_prf_hz" in inputs:
        return
    # the grid points read back exactly through the fast lookup
    np.testing.assert_allclose(
        imp.improvement_factor_db(table, spread, dop), table.values[i, j], rtol=0, atol=1e-9
    )


@pytest.mark.parametrize("name", [k for k in PROCESSORS if "stagger" not in k])
def test_fast_lookup_equals_the_generic_store_interpolation(tables, name):
    table = tables[name]
    rng = np.random.default_rng(11)
    log_s = rng.uniform(imp.LOG10_SPREAD_MIN, imp.LOG10_SPREAD_MAX, 2000)
    dop = rng.uniform(0.0, table.axes[1][-1], 2000)
    fast = imp.improvement_factor_db(table, 10.0**log_s, dop)
    generic = table.lookup(log_s, dop)
    # identical except in the cells where the picked filter changes (crossover < 1), which
    # the generic interpolation smears, and in the steep cells and the cells with a null
    # inside, which the fast lookup reads with the exact filter response; the same for the
    # coherent gain
    cell = np.minimum((dop / table.axes[1][1]).astype(int), len(table.axes[1]) - 2)
    plain = table.extra["crossover"][0, cell] == 1.0
    if "signal_db" in table.extra:
        sig = table.extra["signal_db"][0]
        plain &= np.abs(sig[cell + 1] - sig[cell]) <= imp.STEEP_CELL_DB
        plain &= ~table.attached["exact_cells"][cell]
    assert plain.mean() > 0.3
    np.testing.assert_allclose(fast[plain], generic[plain], rtol=0, atol=1e-9)
    fast_gain = imp.improvement_factor_db(table, 10.0**log_s, dop, array="coherent_gain_db")
    np.testing.assert_allclose(
        fast_gain[plain], table.lookup(log_s, dop, array="coherent_gain_db")[plain],
        rtol=0, atol=1e-9)


@pytest.mark.parametrize("name", list(PROCESSORS))
def test_lookup_is_periodic_in_doppler(tables, name):
    table = tables[name]
    period = imp.doppler_period(table.inputs)
    rng = np.random.default_rng(5)
    spread = 10.0 ** rng.uniform(-6, -0.5, 500)
    dop = rng.uniform(0.0, period, 500)
    base = imp.improvement_factor_db(table, spread, dop)
    for k in (-3, -1, 1, 7):
        np.testing.assert_allclose(
            imp.improvement_factor_db(table, spread, dop + k * period), base, atol=1e-6
        )


def test_constant_prf_period_is_one_and_stagger_period_is_the_lcm(tables):
    assert imp.doppler_period(tables["mti3"].inputs) == 1.0
    # lcm(900 Hz, 1100 Hz) = 9900 Hz = 9.9 f_r with f_r = 1000 Hz
    assert imp.doppler_period(tables["mti3-stagger"].inputs) == pytest.approx(9.9, rel=1e-12)
    # lcm(1000 Hz, 1000.5 Hz) = 2001 kHz: no table over the period could hold it; every
    # table's Doppler axis is one period of a bound
    long = imp.improvement_table_inputs(
        "mti", mti_pulses=2, prf_hz=1000.0, stagger_prf_hz=[1000.0, 1000.5]
    )
    assert imp.doppler_period(long) == pytest.approx(2001.0, rel=1e-12)
    assert all(t.axes[1][0] == 0.0 and t.axes[1][-1] == 1.0 for t in tables.values())


def test_mti_table_doppler_mean_is_the_classical_improvement_factor(tables):
    # Parseval: the mean over one PRF of the point-target I_F is the B = f_r (Doppler-averaged)
    # I_F, here the 3-pulse canceller's closed form 3 (1 + ε) / (3 - 4ρ + ρ⁴ + 3ε).
    table = tables["mti3"]
    eps = 10.0 ** (-table.inputs["stability_limit_db"] / 10.0)
    spread = 10.0 ** table.axes[0]
    linear_mean = np.mean(10.0 ** (table.values[:, :-1] / 10.0), axis=1)  # period excluded
    x = 2.0 * (np.pi * spread) ** 2
    closed = 6.0 * (1.0 + eps) / (-8.0 * np.expm1(-x) + 2.0 * np.expm1(-4.0 * x) + 6.0 * eps)
    np.testing.assert_allclose(linear_mean, closed, rtol=1e-9)


def test_spread_is_clamped_to_the_axis_above_and_evaluated_below(tables):
    table = tables["dft16"]
    dop = np.linspace(0, 1, 9)
    # below the axis the clutter output is evaluated: the DFT filters' exact nulls at zero
    # Doppler put them at the stability limit times their gain, 10 log10(16 / ε) [dB]
    # (0.45 dB above the first row, 1e-7), the clutter filter at 0 dB
    below = imp.improvement_factor_db(table, 0.0, dop)
    eps = 10.0 ** (-table.inputs["stability_limit_db"] / 10.0)
    np.testing.assert_allclose(below[[0, -1]], 0.0, atol=1e-9)
    np.testing.assert_allclose(below[1:-1], 10 * np.log10(16.0 * (1 + eps) / eps), atol=1e-6)
    assert np.all(below[1:-1] > imp.improvement_factor_db(table, 1e-7, dop)[1:-1])
    np.testing.assert_allclose(
        imp.improvement_factor_db(table, np.inf, dop), imp.improvement_factor_db(table, 1.0, dop)
    )
    # the white end of the axis is the coherent gain: 10 log10 16 at a filter centre
    assert imp.improvement_factor_db(table, 1.0, 0.25) == pytest.approx(
        10 * np.log10(16.0), abs=1e-6
    )
    with pytest.raises(ValueError):
        imp.improvement_factor_db(table, -0.01, 0.1)
    out = imp.improvement_factor_db(table, np.array([np.nan, 0.1, 0.1]), [0.1, np.nan, np.inf])
    assert np.all(np.isnan(out))


def test_fine_table_interpolates_the_physics_within_a_tenth_of_a_db():
    # smooth region of a 3-pulse canceller (away from the blind speed's logarithmic null)
    table = imp.build_improvement_table("mti", mti_pulses=3, resolution="fine")
    rng = np.random.default_rng(2)
    spread = 10.0 ** rng.uniform(-4, -0.5, 3000)
    dop = rng.uniform(0.1, 0.9, 3000)
    exact = 10 * np.log10(df.bank_improvement_factor(df.canceller_weights(3), spread, dop))
    np.testing.assert_allclose(imp.improvement_factor_db(table, spread, dop), exact, atol=0.1)


def test_staggered_table_fills_the_blind_speeds_of_the_reference_prf(tables):
    constant, stagger = tables["mti3"], tables["mti3-stagger"]
    for k in (1, 2, 3):
        assert imp.improvement_factor_db(constant, 0.01, k) < -40.0
        assert imp.improvement_factor_db(stagger, 0.01, k) > 20.0
    # and lies between its bounds (to the coarse grid's interpolation), both Doppler signs
    w = df.canceller_weights(3)
    rng = np.random.default_rng(4)
    s = 10.0 ** rng.uniform(-6, 0, 2000)
    d = rng.uniform(-25, 25, 2000)
    lo = 10 * np.log10(df.bank_improvement_factor(w, s * 1000 / 900, d * 1000 / 900))
    hi = 10 * np.log10(df.bank_improvement_factor(w, s * 1000 / 1100, d * 1000 / 1100))
    got = imp.improvement_factor_db(stagger, s, d)
    assert np.all(got >= np.minimum(lo, hi) - 0.5)
    assert np.all(got <= np.maximum(lo, hi) + 0.5)


def test_bank_table_reads_the_filter_holding_the_doppler(tables):
    table = tables["dft16"]
    bank = imp.processor_weights(table.inputs)
    centres = df.filter_centres_norm(16)
    for spread in (1e-3, 0.02, 0.2):
        own = df.improvement_factor(bank, spread, centres)  # (filter, target)
        np.testing.assert_allclose(
            imp.improvement_factor_db(table, spread, centres),
            10 * np.log10(np.diag(own)),
            atol=0.5,  # interpolation along the spread axis of the coarse grid
        )


def test_cache_builds_once_and_keys_on_what_changes_the_table(table_cache):
    kwargs = dict(n_pulses=8, window="taylor", window_sidelobe_db=35.0, resolution="coarse")
    t1, built1 = imp.improvement_table("dft_bank", **kwargs)
    t2, built2 = imp.improvement_table("dft_bank", **kwargs)
    assert built1 and not built2
    np.testing.assert_array_equal(t1.values, t2.values)
    assert isinstance(t2, Table) and t2.inputs == t1.inputs
    # the PRF does not change a constant-PRF table; the window level does
    same = imp.improvement_table_inputs("dft_bank", prf_hz=3000.0, **kwargs)
    other = imp.improvement_table_inputs("dft_bank", **{**kwargs, "window_sidelobe_db": 40.0})
    key = inputs_hash(imp.BUILDER_NAME, imp.BUILDER_VERSION, t1.inputs)
    assert inputs_hash(imp.BUILDER_NAME, imp.BUILDER_VERSION, same) == key
    assert inputs_hash(imp.BUILDER_NAME, imp.BUILDER_VERSION, other) != key
    _, built3 = imp.improvement_table("dft_bank", **{**kwargs, "window_sidelobe_db": 40.0})
    assert built3
    assert len(list(table_cache.glob("improvement_factor-*.npz"))) == 2


def test_invalid_processors_raise():
    bad = [
        dict(processor="kalman"),
        dict(processor="dft_bank"),  # no n_pulses
        dict(processor="dft_bank", n_pulses=8, n_filters=4),
        dict(processor="fir_bank", n_pulses=8, window="chebyshev"),
        dict(processor="mti", mti_pulses=1),
        dict(processor="mti_bank", n_pulses=2, mti_pulses=3),
        dict(processor="mti", stagger_prf_hz=[900, 1100]),  # no reference PRF
        dict(processor="mti", resolution="ultra"),
        dict(processor="mti", stability_limit_db=0.0),
    ]
    for kw in bad:
        with pytest.raises(ValueError):
            imp.improvement_table_inputs(**kw)


@settings(max_examples=40, deadline=None)
@given(
    name=st.sampled_from(list(PROCESSORS)),
    spread=st.one_of(st.just(0.0), st.floats(0.0, 1e3)),
    doppler=st.floats(-1e4, 1e4),
)
def test_lookup_is_finite_and_bounded(tables, name, spread, doppler):
    table = tables[name]
    got = imp.improvement_factor_db(table, spread, doppler)
    assert np.isfinite(got)
    # bounded by the tabulated values, including the neighbouring filter's response that the
    # lookup follows up to the crossover inside a cell (extras "ahead_db"/"behind_db")
    parts = [table.values] + [table.extra[k] for k in ("ahead_db", "behind_db")
                              if k in table.extra]
    lo = min(p.min() for p in parts)
    hi = max(p.max() for p in parts)
    if spread < 10.0**imp.LOG10_SPREAD_MIN:
        # below the axis the clutter output is evaluated, not clamped: up to the Rayleigh
        # bound (N + ε)/ε of an N-tap filter
        eps = 10.0 ** (-table.inputs["stability_limit_db"] / 10.0)
        n_taps = imp.processor_weights(table.inputs).shape[-1]
        hi = max(hi, 10 * np.log10((n_taps + eps) / eps))
    assert lo - 1e-9 <= got <= hi + 1e-9


def test_lookup_keeps_the_pick_rule_jumps_sharp(tables):
    # DFT bank, response pick: I_F jumps where the picked filter changes (e.g. between the
    # clutter filter 0 and filter 1).  Inside those cells the lookup follows each filter's
    # own I_F; a plain bilinear interpolation smears the jump over the cell.
    table = tables["dft16"]
    step = table.axes[1][1]
    cells = np.flatnonzero(table.extra["crossover"][0, :-1] < 1.0)
    assert cells.size == 16  # one crossover between each pair of the 16 filters
    rng = np.random.default_rng(9)
    cell = rng.choice(cells, 3000)
    dop = (cell + rng.uniform(0, 1, cell.size)) * step
    log_s = rng.uniform(-5.0, -0.5, cell.size)
    exact = 10 * np.log10(
        df.bank_improvement_factor(imp.processor_weights(table.inputs), 10.0**log_s, dop)
    )
    fast = imp.improvement_factor_db(table, 10.0**log_s, dop)
    smeared = table.lookup(log_s, dop)
    # within each filter the coarse grid interpolates to ~1 dB (a 4-point-per-bin mainlobe)
    assert np.max(np.abs(fast - exact)) < 1.5
    assert np.max(np.abs(smeared - exact)) > 10.0


@pytest.mark.parametrize("name", ["mti3", "fir5x32hann", "mti2+cheb"])
def test_steep_cells_are_read_with_the_exact_response(tables, name):
    # near the nulls of the picked filter (MTI blind speed, sidelobe nulls between FIR
    # filters) the dB chord of a cell reads tens of dB low; the lookup evaluates the picked
    # filter's response exactly there and keeps only the clutter part from the grid
    table = tables[name]
    w = imp.processor_weights(table.inputs)
    rng = np.random.default_rng(21)
    # at the spread nodes the clutter part is exact: only the Doppler matters
    i = rng.integers(0, len(table.axes[0]), 4000)
    spread = 10.0 ** table.axes[0][i]
    dop = rng.uniform(0.0, 1.0, 4000)
    exact = 10 * np.log10(df.bank_improvement_factor(w, spread, dop))
    got = imp.improvement_factor_db(table, spread, dop)
    cell = np.minimum((dop / table.axes[1][1]).astype(int), len(table.axes[1]) - 2)
    sig = table.extra["signal_db"][0]
    # the steep cells without a crossover (in a crossover cell each side's own filter decides)
    steep = (np.abs(sig[cell + 1] - sig[cell]) > imp.STEEP_CELL_DB) & (
        table.extra["crossover"][0, cell] == 1.0
    )
    assert steep.sum() > 20
    np.testing.assert_allclose(got[steep], exact[steep], atol=1e-6)
    # the blind speed of the canceller itself: a chord from the null node would read far low
    if name == "mti3":
        near = np.array([1e-3, 3e-3, 0.005, 0.995])
        np.testing.assert_allclose(
            imp.improvement_factor_db(table, 0.01, near),
            10 * np.log10(df.bank_improvement_factor(w, 0.01, near)),
            atol=0.3,  # the clutter part interpolated in spread (6 points per decade)
        )
