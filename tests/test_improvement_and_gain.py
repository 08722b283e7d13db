"""improvement_and_gain_db: the I_F and another array of the table read at cells located once,
the same numbers as two improvement_factor_db calls (the dwell model's clutter_at)."""

from __future__ import annotations

import numpy as np
import pytest

from shipradar.tables import improvement as imp

PROCESSORS = {
    "mti3": dict(processor="mti", mti_pulses=3),
    "dft16": dict(processor="dft_bank", n_pulses=16),
    "mti2+cheb": dict(
        processor="mti_bank", n_pulses=17, mti_pulses=2, window="chebyshev", window_sidelobe_db=60
    ),
}


@pytest.fixture(scope="module")
def tables():
    return {k: imp.build_improvement_table(**v, resolution="coarse") for k, v in PROCESSORS.items()}


def _points(seed, n=400):
    rng = np.random.default_rng(seed)
    spread = 10.0 ** rng.uniform(-5.0, 1.0, n)
    doppler = rng.uniform(-3.0, 3.0, n)
    spread[:5] = [0.0, np.nan, 1e9, 1e-12, 0.3]
    doppler[5:12] = [np.nan, np.inf, -np.inf, 0.0, -0.0, 0.5, 1.0]
    return spread, doppler


@pytest.mark.parametrize("name", list(PROCESSORS))
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_both_arrays_are_the_two_lookups_bit_for_bit(tables, name, seed):
    table = tables[name]
    spread, doppler = _points(seed)
    with np.errstate(invalid="ignore"):
        i_f, cg = imp.improvement_and_gain_db(table, spread, doppler, "coherent_gain_db")
        want_if = imp.improvement_factor_db(table, spread, doppler)
        want_cg = imp.improvement_factor_db(table, spread, doppler, array="coherent_gain_db")
    assert i_f.tobytes() == want_if.tobytes()
    assert cg.tobytes() == want_cg.tobytes()


def test_scalar_broadcast_and_no_table(tables):
    table = tables["mti3"]
    i_f, cg = imp.improvement_and_gain_db(table, 0.01, np.array([0.1, 0.2]), "coherent_gain_db")
    assert i_f.shape == cg.shape == (2,)
    assert i_f.tobytes() == imp.improvement_factor_db(table, 0.01, [0.1, 0.2]).tobytes()
    a, b = imp.improvement_and_gain_db(None, [0.1, np.nan], [0.0, 0.0], "coherent_gain_db")
    assert list(a[:1]) == list(b[:1]) == [0.0] and np.isnan(a[1]) and np.isnan(b[1])
    with pytest.raises(ValueError, match="spread_norm"):
        imp.improvement_and_gain_db(table, -1.0, 0.0, "coherent_gain_db")
