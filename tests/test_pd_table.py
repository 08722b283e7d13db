"""Tests of shipradar.tables.pd: the tabulated P_d against the exact method (the independent
oracle)."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shipradar.sensors.detection import probability_of_detection
from shipradar.tables.pd import PdTable, PdTables, build_pd_table, pd_table_axes, pd_table_inputs

#: Largest |P_d(table) - P_d(exact)| accepted, as docs/accuracy.md states for the default
#: grid (0.1 dB, 12 points per e-fold of N_e).
TOLERANCE = 1e-3
PFA = 3.6e-8
N_MAX = 25.0


@functools.cache
def reader(swerling: int, pfa: float = PFA, n_max: float = N_MAX) -> PdTable:
    return PdTable(build_pd_table(pfa, swerling, n_max))


@pytest.mark.slow
@pytest.mark.parametrize("swerling", range(5))
def test_table_within_tolerance_of_exact(swerling):
    rng = np.random.default_rng(swerling)
    snr = rng.uniform(-20.0, 45.0, 3000)
    n = np.exp(rng.uniform(0.0, np.log(N_MAX), snr.size))
    n[:100] = N_MAX  # the noise-dominated N_e: the table's top row
    n[100:200] = rng.integers(1, int(N_MAX) + 1, 100)  # integer N (Swerling 4's binomial form)
    got = reader(swerling)(snr, n)
    exact = probability_of_detection(snr, PFA, n, swerling)
    assert np.max(np.abs(got - exact)) < TOLERANCE


@pytest.mark.parametrize("swerling", range(5))
def test_extremes(swerling):
    r = reader(swerling)
    n = np.array([1.0, 3.7, N_MAX])
    # no signal: P_fa exactly; far below the grid: between P_fa and the grid's bottom
    np.testing.assert_allclose(r(np.full(3, -np.inf), n), PFA, rtol=1e-12)
    low = r(np.full(3, -300.0), n)
    assert np.all(low >= PFA) and np.all(low <= r(np.full(3, -40.0), n))
    exact = probability_of_detection(np.full(3, -60.0), PFA, n, swerling)
    np.testing.assert_allclose(r(np.full(3, -60.0), n), exact, atol=1e-9)
    # saturated: 1 within 1e-6 above the grid's top (100 dB), and never above 1
    high = r(np.full(3, 300.0), n)
    assert np.all(high <= 1.0) and np.all(high > 1.0 - 1e-6)
    # N_e outside the grid (not produced for this radar): the exact method
    out = np.array([0.5 * N_MAX, 2.0 * N_MAX])
    np.testing.assert_allclose(r(np.array([10.0, 10.0]), out)[1],
                               probability_of_detection(10.0, PFA, 2.0 * N_MAX, swerling),
                               rtol=1e-12)
    with pytest.raises(ValueError):
        r(np.array([np.nan]), np.array([2.0]))


@settings(max_examples=60, deadline=None)
@given(
    swerling=st.integers(0, 4),
    snr=st.lists(st.floats(-400.0, 400.0), min_size=2, max_size=40),
    n=st.floats(1.0, N_MAX),
)
def test_property_probability_and_monotone(swerling, snr, n):
    s = np.sort(np.array(snr))
    pd = reader(swerling)(s, np.full(s.size, n))
    assert np.all(np.isfinite(pd)) and np.all(pd >= PFA) and np.all(pd <= 1.0)
    assert np.all(np.diff(pd) >= 0.0)  # exactly: the module notes' construction


def test_axes_inputs_and_cached_reader(table_cache):
    inputs = pd_table_inputs(PFA, 1, N_MAX)
    n_axis, snr = pd_table_axes(inputs)
    assert n_axis[0] == 1.0 and n_axis[-1] == pytest.approx(N_MAX, rel=1e-12)
    assert snr[0] == -40.0 and snr[-1] == 100.0 and np.allclose(np.diff(snr), 0.1)
    with pytest.raises(ValueError):
        pd_table_inputs(1.5, 1, N_MAX)
    with pytest.raises(ValueError):
        pd_table_inputs(PFA, 5, N_MAX)
    tables = PdTables(PFA, N_MAX, [1, 3, 3])
    assert len(list(table_cache.glob("pd-*.npz"))) == 2
    snr_db = np.array([5.0, 12.0, 12.0, -np.inf])
    n_e = np.array([2.0, 25.0, 9.5, 1.0])
    sw = np.array([1, 3, 1, 3])
    got = tables(snr_db, n_e, sw)
    np.testing.assert_allclose(got, probability_of_detection(snr_db, PFA, n_e, sw),
                               atol=TOLERANCE)
    # a second reader loads the same files (no rebuild)
    again = PdTables(PFA, N_MAX, [1, 3])
    np.testing.assert_array_equal(again(snr_db, n_e, sw), got)


def test_run_with_table_matches_exact(table_cache):
    # wiring: fidelity.pd_method "table" goes through the dwell model; the draws use the same
    # uniforms, so only a P_d within the tolerance of a uniform can change a detection
    from shipradar.sim.engine.simulation import Simulation
    from shipradar.sim.world.scenario import load_scenario
    from tests.helpers import ROOT

    s = load_scenario(ROOT / "scenarios/single_missile.yaml")
    runs = {}
    for method in ("exact", "table"):
        sc = s.model_copy(update={"fidelity": s.fidelity.model_copy(
            update={"pd_method": method})})
        runs[method] = Simulation(sc, seed=3, duration_s=60.0).run()
    assert runs["table"]["dwells"] == runs["exact"]["dwells"] > 0
    assert abs(runs["table"]["target_plots"] - runs["exact"]["target_plots"]) <= 1
