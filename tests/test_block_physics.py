"""The physics of a block of revolutions computed with fewer passes and imports (issue 27, item 4)
gives the numbers of the straightforward code, bit for bit: the recording's bytes depend on it.

Each fast path is checked against the plain form it replaces (kept here as the reference), on
random inputs and on the edges (empty arrays, every regime of [91]-[93], angles on the wrap).
"""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from shipradar.sensors import doppler_filters as df
from shipradar.sensors.geometry import EARTH_RADIUS_M

ROOT = Path(__file__).resolve().parents[1]


def _same_bits(a, b) -> None:
    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype == b.dtype and a.shape == b.shape
    assert a.tobytes() == b.tobytes()


def test_steep_cells_read_the_tables_weights_without_scipy_signal(tmp_path):
    """The I_F table keeps the weights it was computed from (scipy's windows, at build
    time): a run's exact steep-cell reads use them and import no window function.
    scipy.signal's import (0.3-0.45 s) used to fall inside the stress scene's loop, at its
    first steep I_F cell."""
    from shipradar.tables import improvement as imp

    kw = dict(processor="mti_bank", n_pulses=25, mti_pulses=2, n_filters=8,
              window="chebyshev", window_sidelobe_db=50.0, resolution="coarse")
    table = imp.build_improvement_table(**kw)
    _same_bits(table.attached["weights"], imp.processor_weights(table.inputs))
    path = table.save(tmp_path / "if.npz")
    doppler = np.linspace(0.0, 1.0, 4001)
    code = ("import sys, numpy as np; from shipradar.tables.store import Table; "
            "from shipradar.tables import improvement as imp; "
            f"t = Table.load({str(path)!r}); "
            "d = np.linspace(0.0, 1.0, 4001); "
            "v = imp.improvement_factor_db(t, np.full(d.shape, 3e-3), d); "
            "np.save(sys.stdout.buffer, v); "
            "sys.stderr.write(repr(sorted(m for m in sys.modules if 'scipy.signal' in m)))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, cwd=ROOT,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stderr.decode().strip().splitlines()[-1] == "[]"
    got = np.load(io.BytesIO(proc.stdout))
    # steep cells were read (the grid's response jumps somewhere by more than the threshold)
    sig = table.extra["signal_db"][0]
    assert np.any(np.abs(np.diff(sig)) > imp.STEEP_CELL_DB)
    # the loaded table's weights read as the built table's
    _same_bits(got, imp.improvement_factor_db(table, np.full(doppler.shape, 3e-3), doppler))


# ----------------------------------------------------------------------------- false alarms
from scipy import special  # noqa: E402

from shipradar.sensors import false_alarms as fa  # noqa: E402
from shipradar.sensors import sea_clutter as sc  # noqa: E402
from shipradar.sensors.measurement import expected_errors  # noqa: E402
from tests.helpers import random_clutter_generator  # noqa: E402

TWO_PI = 2.0 * np.pi


def _mod_reference(x):
    """The first bit-exact form of np.mod(x, 2π) on [-2π, 4π) (the code before issue 27
    item 4's second pass)."""
    lo, hi = x.min(), x.max()
    if not (lo >= -TWO_PI and hi < 2.0 * TWO_PI):
        return np.mod(x, TWO_PI)
    out = np.where(x < 0.0, TWO_PI, 0.0)
    if hi >= TWO_PI:
        out[x >= TWO_PI] = -TWO_PI
    out += x
    return out


def _draw_reference(gen, rng, revolutions):
    """ClutterFalseAlarms._draw as it was: divmod, masks by regime, repeat, np.where."""
    n = gen.eta.size
    u = rng.random((revolutions, n))
    hit = np.flatnonzero((u < gen._hit_below) | (u > gen._hit_above))
    revolution, sector = np.divmod(hit, n)
    u = u.ravel()[hit]
    counts = np.ones(hit.size, dtype=np.int64)
    regime = gen._regime[sector]
    normal = regime == 2
    if normal.any():
        e = gen.eta[sector[normal]]
        x = e + np.sqrt(e) * special.ndtri(u[normal])
        counts[normal] = np.rint(np.maximum(x, 0.0)).astype(np.int64)
    pois = np.flatnonzero(regime == 1)
    if pois.size:
        rows, up = gen._pois_row[sector[pois]], u[pois]
        for k in range(1, gen._pois_cdf.shape[1]):
            more = up > gen._pois_cdf[rows, k]
            if not more.any():
                break
            pois, rows, up = pois[more], rows[more], up[more]
            counts[pois] += 1
    revolution, sector = np.repeat(revolution, counts), np.repeat(sector, counts)
    r = gen.r_min_m[sector] + gen._r_span[sector] * rng.random(sector.size)
    az = gen.az_min_rad[sector] + gen._az_span[sector] * rng.random(sector.size)
    az = _mod_reference(az) if az.size else az
    per_sector = np.zeros((revolutions, n), dtype=np.int64)
    per_sector.ravel()[hit] = counts
    return per_sector, sector, revolution, r, np.where(az >= TWO_PI, 0.0, az)


def _scans_reference(gen, t_scan, t_end, beam, omega, rng):
    """ClutterFalseAlarms.scans as it was: gathers by revolution, a temporary per step."""
    t_scan, t_end, beam = (np.atleast_1d(np.asarray(v, dtype=np.float64))
                           for v in (t_scan, t_end, beam))
    _, sector, revolution, ground, az = _draw_reference(gen, rng, t_scan.size)
    off = az - beam[revolution]
    t = t_scan[revolution] + (_mod_reference(off) if off.size else off) / omega
    keep = t < t_end[revolution]
    ground, az, t, revolution = ground[keep], az[keep], t[keep], revolution[keep]
    sector = sector[keep]
    base, ln_m = gen._spike_terms
    e = rng.standard_exponential(sector.shape)
    x = fa._spike_from_terms(base[sector], None if ln_m is None else ln_m[sector],
                             gen.weibull_a[sector], e)
    si = np.maximum(x - 1.0, 1e-3)
    eps_r, eps_t = expected_errors(si, gen.n_pulses, gen.range_cell_m, gen.beamwidth_rad,
                                   h_range=gen.h_range, h_azimuth=gen.h_azimuth)
    d = ground
    a = gen.k_factor * EARTH_RADIUS_M
    h = gen.antenna_height_m
    s = np.sin(d / (2.0 * a))
    slant = np.sqrt(h * h + 4.0 * a * (a + h) * s * s)
    n = t.size
    return {"time_s": t, "range_m": slant, "azimuth_rad": az, "snr_db": 10.0 * np.log10(si),
            "sigma_range_m": np.broadcast_to(eps_r / 3.0, (n,)).copy(),
            "sigma_azimuth_rad": np.broadcast_to(eps_t / 3.0, (n,)).copy(),
            "interference": np.ones(n, dtype=np.uint8), "ground_range_m": ground,
            "revolution": revolution, "sector": sector}


def _generator(eta, *, contiguous: bool, model="seed", seed=0):
    """Sectors of all three regimes of [91]-[93], interleaved at random or in long runs
    (the two ways ClutterFalseAlarms finds the hits), azimuths across north."""
    rng = np.random.default_rng(seed)
    eta = np.sort(eta) if contiguous else rng.permutation(eta)
    return random_clutter_generator(eta, rng, model)


def _etas(n, seed=1):
    rng = np.random.default_rng(seed)
    # Bernoulli (< 0.1725 for 2 channels), Poisson, a few normal (>= 9), and zeros dropped
    return np.concatenate([rng.uniform(0.0, 0.17, n // 2), rng.uniform(0.18, 8.9, n // 3),
                           rng.uniform(9.0, 30.0, 5), np.zeros(7)])


@pytest.mark.parametrize("contiguous", [True, False])
@pytest.mark.parametrize("model", ["seed", "weibull_median"])
def test_block_draws_are_the_plain_codes(contiguous, model):
    gen = _generator(_etas(3000), contiguous=contiguous, model=model)
    # the runs path needs few runs per uniform: sorted etas give 3, shuffled ones thousands
    assert (len(gen._pois_runs) * 4096 <= 40 * gen.eta.size) == contiguous
    for seed, revolutions in ((1, 40), (2, 1), (3, 7)):
        got = gen._draw(np.random.default_rng(seed), revolutions)
        ref = _draw_reference(gen, np.random.default_rng(seed), revolutions)
        for g, r in zip(got, ref, strict=True):
            _same_bits(g, r)
        period, k = 2.0, 40
        t_a = np.arange(k) * period
        t_b = t_a + period
        t_b[-1] = t_a[-1] + 0.7  # the run ends inside its last revolution
        beam = np.random.default_rng(seed).uniform(0.0, TWO_PI, k)
        rng_a, rng_b = np.random.default_rng(seed), np.random.default_rng(seed)
        got = gen.scans(t_a, t_b, beam, TWO_PI / period, rng_a)
        ref = _scans_reference(gen, t_a, t_b, beam, TWO_PI / period, rng_b)
        assert got is not None and list(got) == list(ref)
        for c in ref:
            _same_bits(got[c], ref[c])
        assert rng_a.bit_generator.state == rng_b.bit_generator.state


def test_block_draws_with_no_hit_and_bernoulli_only():
    gen = _generator(np.full(50, 1e-9), contiguous=True)
    got = gen.scans([0.0, 2.0], [2.0, 4.0], [0.1, 0.2], np.pi, np.random.default_rng(4))
    ref = _scans_reference(gen, [0.0, 2.0], [2.0, 4.0], [0.1, 0.2], np.pi,
                           np.random.default_rng(4))
    assert got is not None and got["time_s"].size == 0
    for c in ref:
        _same_bits(got[c], ref[c])
    gen = _generator(np.random.default_rng(5).uniform(0.0, 0.17, 500), contiguous=False)
    assert gen._pois_cdf.shape[0] == 0 and not gen._any_normal
    for seed in range(3):
        got = gen._draw(np.random.default_rng(seed), 9)
        ref = _draw_reference(gen, np.random.default_rng(seed), 9)
        for g, r in zip(got, ref, strict=True):
            _same_bits(g, r)


def test_mod_two_pi_in_place_is_np_mod():
    rng = np.random.default_rng(6)
    near = np.pi / 32 * np.arange(-64, 128)
    x = np.concatenate([rng.uniform(-TWO_PI, 2 * TWO_PI, 10_000), near,
                        np.nextafter(near, np.inf), np.nextafter(near, -np.inf),
                        [0.0, -0.0, TWO_PI, -TWO_PI, 5e-324, -5e-324]])
    x = x[(x >= -TWO_PI) & (x < 2 * TWO_PI)]
    for v in (x, x[x >= 0.0], x[x < TWO_PI], np.append(x, np.nan), np.append(x, 20.0)):
        ref = np.mod(v, TWO_PI)
        _same_bits(fa._mod_two_pi(v), ref)
        w = v.copy()
        assert fa._mod_two_pi(w, out=w) is w
        _same_bits(w, ref)


@pytest.mark.parametrize("shape", [(), (1,), (1000,)])
def test_slant_range_in_place_is_the_formula(shape):
    rng = np.random.default_rng(7)
    d = rng.uniform(0.0, 2e5, shape)
    for h, k in ((25.0, 4.0 / 3.0), (rng.uniform(1.0, 50.0, shape), 1.0),
                 (np.array(12.0), np.array([1.2, 4.0 / 3.0])[:1] if shape else 1.2)):
        a = np.asarray(k, dtype=float) * EARTH_RADIUS_M
        hh = np.asarray(h, dtype=float)
        s = np.sin(d / (2.0 * a))
        ref = np.sqrt(hh * hh + 4.0 * a * (a + hh) * s * s)
        got = sc.slant_range_m(d, h, k)
        assert type(got) is type(ref)
        _same_bits(got, ref)


def test_doppler_filter_index_is_the_plain_formula():
    rng = np.random.default_rng(8)
    fd = np.concatenate([rng.normal(0.0, 50.0, 20_000), rng.uniform(-5e3, 5e3, 20_000),
                         [0.0, -0.0, -1e-300, 1e3, -1e3, 999.9999999]])
    for n in (1, 7, 16):
        ref = np.mod(np.floor(np.mod(fd / 1e3, 1.0) * n + 0.5), n).astype(np.int64)
        _same_bits(df.doppler_filter_index(fd, 1e3, n), ref)
        _same_bits(df.doppler_filter_index(fd.reshape(2, -1), 1e3, n), ref.reshape(2, -1))
        assert int(df.doppler_filter_index(-1e-9, 1e3, n)) == 0
    with pytest.raises(ValueError):
        df.doppler_filter_index(np.array([1.0, np.nan]), 1e3, 7)
    with pytest.raises(ValueError):
        df.doppler_filter_index(np.array([np.inf, 1.0]), 1e3, 7)


# ----------------------------------------------------------------------------- the looks
def test_threshold_once_per_distinct_n_is_gammainccinv():
    from shipradar.sensors import detection

    rng = np.random.default_rng(9)
    few = rng.choice([1.0, 7.5, 12.0, 12.000000000000002], 5000)
    many = rng.uniform(1.0, 30.0, 5000)
    for n in (few, many, few[:63], np.append(few, np.nan)):
        for pfa in (np.full(n.size, 1e-6), rng.uniform(1e-8, 1e-3, n.size)):
            with np.errstate(invalid="ignore"):
                _same_bits(detection._threshold(n, pfa), special.gammainccinv(n, pfa))


def test_argmax_by_group_is_the_full_sort():
    from shipradar.sim.dwell.model import argmax_by_group

    def reference(group, value, n_groups):
        order = np.lexsort((-value, group))
        first = np.ones(order.size, dtype=bool)
        first[1:] = group[order][1:] != group[order][:-1]
        out = np.empty(n_groups, dtype=np.int64)
        out[group[order][first]] = order[first]
        return out

    rng = np.random.default_rng(10)
    for n, n_groups in ((1, 1), (500, 500), (500, 480), (500, 40), (3, 1)):
        group = np.concatenate([np.arange(n_groups), rng.integers(0, n_groups, n - n_groups)])
        group = rng.permutation(group)
        value = rng.choice([0.0, 1.0, 2.5, np.nan], n) * rng.choice([1.0, 1e-30], n)
        _same_bits(argmax_by_group(group, value, n_groups), reference(group, value, n_groups))


def test_propagation_lookup_field_is_the_expression():
    from shipradar.tables import propagation as tp

    class _Table:  # the parts of a Table PropagationLookup reads
        axes = (np.linspace(1e3, 1e5, 40), np.concatenate([np.linspace(0.0, 1e-3, 31),
                                                          1e-3 + 2e-3 * np.arange(1, 20)]))
        inputs: dict = {"max_height_m": 1e4}
        values = None
        extra: dict = {}

    rng = np.random.default_rng(11)
    re = rng.normal(size=(40, 50)).astype(np.float32)
    im = rng.normal(size=(40, 50)).astype(np.float32)
    for a, frac in ((re, 0.1), (im, 0.1)):
        a[rng.random(a.shape) < frac] = np.nan
    re[rng.random(re.shape) < 0.05] = -0.0
    im[rng.random(im.shape) < 0.05] = -0.0
    re[0, :3] = [np.inf, -np.inf, 0.0]
    im[0, :3] = [0.0, np.inf, -np.inf]
    _Table.extra = {"field_re": re, "field_im": im}
    with np.errstate(invalid="ignore"):  # 0 x inf in the imaginary unit's product
        v = re + 1j * im
        ref = np.where(np.isnan(v), np.complex64(tp._SENTINEL), v).astype(np.complex64).ravel()
        got = tp.PropagationLookup(_Table()).flat  # type: ignore[arg-type]
    _same_bits(got, ref)


def test_range_rate_from_filter_fast_path_is_the_formula():
    from shipradar.sim.dwell.model import DwellModel

    class _Bank(DwellModel):  # the parts range_rate_from_filter reads, no scene needed
        def __init__(self):
            self.wavelength = 0.0583

        n_doppler_filters = 7
        radar = type("R", (), {"prf_hz": 1234.5})()

    m = _Bank()
    rng = np.random.default_rng(12)
    index = rng.integers(0, 7, 5000)
    for reference in (rng.normal(0.0, 80.0, 5000), 12.5, rng.normal(0.0, 80.0, (3, 1))):
        centre = (np.mod(index / 7 + 0.5, 1.0) - 0.5) * 1234.5
        _same_bits(m.range_rate_from_filter(index, reference),
                   -0.5 * 0.0583 * (centre + reference))
