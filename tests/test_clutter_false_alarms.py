"""Sea-clutter-induced false alarms, seed 7.2 [94]-[96]: functions, P_fac map, generator, engine."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from shipradar.sensors import false_alarms as fa
from shipradar.sensors import sea_clutter as sc
from shipradar.sim.dwell.model import DwellModel
from shipradar.sim.engine.simulation import ORIGIN_SEA_CLUTTER, Simulation
from shipradar.sim.stream import protocol
from shipradar.sim.world.scenario import parse_scenario
from shipradar.tables.clutter import map_axes
from shipradar.tables.pfac import (
    PFAC_MAP_NAME,
    build_pfac_map,
    clutter_false_alarm_generator,
    clutter_range_profile,
    pfac_map_inputs,
    sector_edges,
)
from shipradar.tables.scene import load_scene_tables, table_specs

from .helpers import CaptureBus, quiet_radar


# --------------------------------------------------------------------------- helpers
def clutter_scene(env=None, fid=None, duration_s=5.0, seed=1, **radar_over):
    """A C-band 0.25 µs VP radar (X = 0.45 °·µs: medium/high resolution) at sea state 5."""
    r = quiet_radar(**{"polarization": "V", "pulse_width_s": 0.25e-6, "beamwidth_az_deg": 1.8,
                       "instrumented_range_m": 20000, **radar_over})
    f = {"propagation": "free_space", "atmosphere": False, "clutter": True,
         "sectors_per_scan": 8}
    f.update(fid or {})
    e = {"sea_state": 5, "wind_speed_mps": 12.0, "wind_direction_deg": 0.0}
    e.update(env or {})
    return parse_scenario({
        "name": "clutter", "duration_s": duration_s, "seed": seed,
        "origin": {"lat_deg": 44.6, "lon_deg": -63.0},
        "platforms": [{"id": "ship", "waypoints": [{"east_m": 0, "north_m": 0}],
                       "radars": [r]}],
        "environment": e, "fidelity": f,
    })


def specs_of(scenario):
    return {s.kind: s for s in table_specs(scenario)}


def pfac_table(scenario):
    return specs_of(scenario)["pfac"].make()


def model_of(scenario):
    platform, radar = scenario.radars()[0]
    return DwellModel(scenario, platform, radar, load_scene_tables(scenario))


def range_profile(table):
    """Expected count per scan in each range sector (summed over azimuth) and the centres."""
    return table.extra["expected_count"].sum(axis=1), table.axes[0]


# --------------------------------------------------------------------------- [94]-[96]
@pytest.mark.parametrize("pfa", [1e-12, 1e-8, 3.6e-8, 1e-6, 1e-4, 1e-2, 0.5])
@pytest.mark.parametrize("a_min", [0.5, 0.8, 1.0, 1.7])
def test_threshold_at_a_min_gives_pfa(pfa, a_min):
    """[95] is the threshold for which clutter with a = a_min exceeds it with probability P_fa.

    Independent closed form: [94] is a Weibull survival function with shape 1/a and scale
    σ0 (ln 2)^-a (scipy's weibull_min); the threshold comes from the dB form of [95].
    """
    y_db = fa.clutter_threshold_db(pfa, a_min)
    y = 10.0 ** (y_db / 10.0)
    sf = stats.weibull_min(c=1.0 / a_min, scale=math.log(2.0) ** -a_min).sf(y)
    assert sf == pytest.approx(pfa, rel=1e-9)
    assert fa.weibull_exceedance(y, a_min) == pytest.approx(pfa, rel=1e-9)
    assert fa.clutter_threshold_ratio(pfa, a_min) == pytest.approx(y, rel=1e-12)


def test_rayleigh_threshold_by_hand():
    """a = a_min = 1: exponential power with mean σ0 exceeds σ0 ln(1/P_fa) w.p. P_fa; the
    seed's 1.6 dB is -10 log10(ln 2)."""
    assert fa.LN2_DB == pytest.approx(1.6, abs=0.01)
    pfa = 1e-6
    # Y/σ0 = ln(1/P_fa)/ln 2 (the mean stands for the median in [94]-[95])
    assert fa.clutter_threshold_ratio(pfa) == pytest.approx(math.log(1e6) / math.log(2.0),
                                                            rel=1e-12)
    assert fa.clutter_threshold_db(pfa) == pytest.approx(
        10 * math.log10(math.log(1e6)) + 1.5917, abs=1e-4)


@pytest.mark.parametrize("a", [0.8, 1.5, 2.0, 3.0, 5.0])
def test_weibull_exceedance_is_weibull_survival(a):
    y = np.geomspace(1e-3, 1e3, 50)
    ref = stats.weibull_min(c=1.0 / a, scale=math.log(2.0) ** -a).sf(y)
    assert fa.weibull_exceedance(y, a) == pytest.approx(ref, rel=1e-9, abs=1e-300)
    # σ0 stands for the median: half the returns exceed it
    assert fa.weibull_exceedance(1.0, a) == pytest.approx(0.5, rel=1e-12)


def test_pfac_zero_at_a_min_and_noise_like_clutter():
    a = np.array([0.9, 1.0, 1.0 + 1e-9, 2.0, 2.0, 2.0])
    pw = np.array([3.0, 3.0, 3.0, 1.0, 1.99, 2.01])
    p = fa.clutter_fa_probability(a, 1e-6, 1.0, 1.0, pw, 1.0)
    assert p[0] == 0.0 and p[1] == 0.0  # a <= a_min: the CFAR copes
    assert p[2] == pytest.approx(1e-6, rel=1e-6)  # just above a_min: ≈ P_fa
    assert p[3] == 0.0 and p[4] == 0.0  # P_sc < 2 N0'
    assert p[5] == pytest.approx(fa.weibull_exceedance(fa.clutter_threshold_ratio(1e-6), 2.0))


def test_k_clutter_divides_pfac():
    a = np.linspace(1.1, 4.0, 30)
    p1 = fa.clutter_fa_probability(a, 1e-6)
    for k in (1.0, 3.0, 1e3):
        assert fa.clutter_fa_probability(a, 1e-6, k_clutter=k) == pytest.approx(p1 / k, rel=1e-12)
    with pytest.raises(ValueError):
        fa.clutter_fa_probability(a, 1e-6, k_clutter=0.5)


def test_pfac_extremes_finite():
    a = np.array([1.0 + 1e-12, 1.5, 3.0, 50.0, 1e6])
    # P_fa -> 0: threshold -> ∞, P_fac -> 0 (underflow is quiet)
    p = fa.clutter_fa_probability(a, 1e-300)
    assert np.all(np.isfinite(p)) and np.all(p >= 0) and p[0] == pytest.approx(0.0, abs=1e-290)
    # P_fa -> 1: threshold -> 0, P_fac -> 1
    p = fa.clutter_fa_probability(a, 1.0 - 1e-12)
    assert np.all(p <= 1.0) and p[:3] == pytest.approx(1.0, abs=1e-4)
    assert fa.clutter_fa_probability(3.0, 1.0) == 1.0
    # a -> ∞: (Y/σ0)^(1/a) -> 1, P_fac -> P(x > median) = 1/2 for any finite threshold
    assert fa.clutter_fa_probability(1e9, 1e-6) == pytest.approx(0.5, abs=1e-6)
    for bad in (0.0, -1e-3, 1.5, np.nan):
        with pytest.raises(ValueError):
            fa.clutter_fa_probability(2.0, bad)


@settings(max_examples=200, deadline=None)
@given(a1=st.floats(0.5, 20.0), a2=st.floats(0.5, 20.0),
       pfa=st.floats(1e-15, 1.0), a_min=st.floats(0.5, 3.0),
       k=st.floats(1.0, 1e6))
def test_pfac_properties(a1, a2, pfa, a_min, k):
    p1, p2 = fa.clutter_fa_probability([a1, a2], pfa, a_min, k)
    assert 0.0 <= p1 <= 1.0 / k and 0.0 <= p2 <= 1.0 / k
    if a1 <= a2 and pfa < 0.5:
        # longer tails, more spikes (for a threshold above the median, Y/σ0 > 1)
        assert p1 <= p2 * (1 + 1e-12) + 1e-300


def test_hp_taper():
    r = np.linspace(0.0, 10_000.0, 1001)
    p = fa.hp_clutter_fa_probability(r, 1000.0, 6000.0, 5e-3)
    assert np.all(p[r <= 1000.0] == 5e-3)
    assert np.all(p[r >= 6000.0] == 0.0)
    assert np.all(np.diff(p) <= 0.0)
    assert p[np.searchsorted(r, 3500.0)] == pytest.approx(2.5e-3, rel=1e-9)  # half way
    # smooth: zero slope at both ends of the ramp
    d = np.diff(p) / np.diff(r)
    assert abs(d[100]) < 0.01 * abs(d[350]) and abs(d[599]) < 0.01 * abs(d[350])
    assert fa.hp_clutter_fa_probability(r, 1000.0, 6000.0, 5e-3, 10.0) == pytest.approx(p / 10)
    # no ramp (clutter below 2 N0' before the 3° range)
    q = fa.hp_clutter_fa_probability(r, 1000.0, 500.0, 5e-3)
    assert np.all(q[r < 500.0] == 5e-3) and np.all(q[r >= 500.0] == 0.0)


def test_spike_excess_is_the_conditional_tail():
    rng = np.random.default_rng(4)
    a, y = 2.0, fa.clutter_threshold_ratio(1e-6)
    x = fa.spike_excess(y, np.full(40_000, a), rng)
    assert np.all(x >= y)
    # P(x > z | x > y) = P_W(z) / P_W(y)
    dist = stats.weibull_min(c=1.0 / a, scale=math.log(2.0) ** -a)
    cdf = lambda z: 1.0 - dist.sf(z) / dist.sf(y)  # noqa: E731
    assert stats.kstest(x, cdf).pvalue > 1e-3
    # the generator's per-sector path (its threshold terms computed once per sector)
    # draws from the same tail, checked against scipy's Weibull, not against spike_excess
    n = 3
    gen = fa.ClutterFalseAlarms(
        np.zeros(n), np.full(n, 1e4), np.zeros(n), np.full(n, 0.1), np.full(n, 0.01),
        np.full(n, 100.0), np.array([0.5, a, 3.0]), threshold_ratio=y, n_channels=2,
        n_pulses=10.0, range_cell_m=30.0, beamwidth_rad=0.03, antenna_height_m=20.0)
    xg = gen.spike_excess(np.full(40_000, 1), np.random.default_rng(9))
    assert np.all(xg >= y) and stats.kstest(xg, cdf).pvalue > 1e-3


# --------------------------------------------------------------------------- P_fac map
def test_no_pfac_table_or_clutter_false_alarms_for_low_resolution(table_cache):
    for over in ({"pulse_width_s": 5e-6}, {"beamwidth_az_deg": 5.0, "pulse_width_s": 1e-6}):
        s = clutter_scene(duration_s=3.0, **over)
        assert not bool(sc.is_medium_high_resolution(math.radians(s.radars()[0][1]
                                                                  .beamwidth_az_deg),
                                                     s.radars()[0][1].pulse_width_s))
        kinds = specs_of(s)
        assert "sea_clutter" in kinds and "pfac" not in kinds
        bus = CaptureBus()
        sim = Simulation(s, bus=bus)
        assert sim.radars[0].model.tables.pfac is None
        sim.run()
        assert sim.stats.clutter_false_alarms == 0
        assert not list(table_cache.glob(f"{PFAC_MAP_NAME}-*"))
        with pytest.raises(ValueError, match="resolution"):
            build_pfac_map(kinds["sea_clutter"].make(), pfa=1e-6)


def test_no_pfac_table_without_clutter(table_cache):
    assert "pfac" not in specs_of(clutter_scene(fid={"clutter": False}))


def test_pfac_table_cached_and_keyed(table_cache):
    s = clutter_scene()
    t1 = pfac_table(s)
    files = list(table_cache.glob(f"{PFAC_MAP_NAME}-*"))
    assert len(files) == 1
    t2 = pfac_table(s)
    assert t2.key == t1.key and np.array_equal(t1.values, t2.values)
    # K_clutter changes the key; the ship's speed (Doppler extras only) does not
    assert pfac_table(clutter_scene(k_clutter=2.0)).key != t1.key
    sea = specs_of(s)["sea_clutter"].make()
    moved = dict(sea.inputs, ship_speed_mps=9.0, motion_compensated=False)
    assert pfac_map_inputs(moved, pfa=1e-6) == pfac_map_inputs(sea.inputs, pfa=1e-6)
    # VP ignores a P_facmax; HP with a user P_facmax ignores P_fa
    assert pfac_map_inputs(sea.inputs, pfa=1e-6, p_fac_max=5e-3)["p_fac_max"] is None
    hp = dict(sea.inputs, polarization="H")
    assert (pfac_map_inputs(hp, pfa=1e-6, p_fac_max=5e-3)
            == pfac_map_inputs(hp, pfa=1e-7, p_fac_max=5e-3))


def test_pfac_map_follows_the_seed(table_cache):
    s = clutter_scene()
    sea = specs_of(s)["sea_clutter"].make()
    model = model_of(s)
    tab = pfac_table(s)
    p = tab.values
    assert np.all(np.isfinite(p)) and p.min() >= 0.0 and 0.0 < p.max() <= 1.0
    # sectors = the clutter map's cells; node-wise [94]-[96] averaged over each sector
    # (the map's uniform range nodes; the near-range nodes it adds below 20 steps, issue 36,
    # make the first sectors' means trapezoid integrals over more nodes)
    r_e, az_e = sector_edges(tab)
    uniform, _ = map_axes(sea.inputs["max_range_m"], sea.inputs["n_range"], 2)
    assert np.allclose(r_e, uniform) and np.allclose(az_e, sea.axes[1])
    far = np.isin(sea.axes[0], uniform) & (sea.axes[0] >= r_e[20])
    node = fa.clutter_fa_probability(sea.extra["weibull_a"][far], model.pfa, 1.0, 1.0,
                                     sea.values[far], model.n0)
    mean4 = 0.25 * (node[:-1, :-1] + node[1:, :-1] + node[:-1, 1:] + node[1:, 1:])
    assert p[20:] == pytest.approx(mean4, rel=1e-9, abs=1e-15)
    # zero beyond the range where a reaches a_min everywhere
    a_max = sea.extra["weibull_a"].max(axis=1)
    beyond = np.nonzero(a_max <= 1.0)[0]
    assert beyond.size and np.all(p[beyond[0]:] == 0.0)
    # cells per sector: ΔR/C_R × Δθ/θ_b
    c_r = 3e8 * 0.25e-6 / 2
    assert tab.extra["cells"][0, 0] == pytest.approx(100.0 / c_r * 1.0 / 1.8, rel=1e-3)


def test_k_clutter_scales_expected_count(table_cache):
    base = pfac_table(clutter_scene())
    for k in (4.0, 100.0):
        t = pfac_table(clutter_scene(k_clutter=k))
        assert t.extra["expected_count"].sum() == pytest.approx(
            base.extra["expected_count"].sum() / k, rel=1e-12)
    # and in draws: 300 scans with K = 4 against K = 1
    model = model_of(clutter_scene())
    g1 = clutter_false_alarm_generator(base, pfa=model.pfa, n_channels=2, n_pulses=10)
    g4 = clutter_false_alarm_generator(pfac_table(clutter_scene(k_clutter=4.0)),
                                       pfa=model.pfa, n_channels=2, n_pulses=10)
    rng = np.random.default_rng(11)
    n1 = sum(int(g1.draw(rng)[0].sum()) for _ in range(300))
    n4 = sum(int(g4.draw(rng)[0].sum()) for _ in range(300))
    e1, e4 = 300 * g1.expected_per_scan, 300 * g4.expected_per_scan
    assert e4 == pytest.approx(e1 / 4, rel=1e-12)
    assert abs(n1 - e1) < 5 * math.sqrt(e1) and abs(n4 - e4) < 5 * math.sqrt(e4)
    assert n4 / n1 == pytest.approx(0.25, rel=10 * math.sqrt(1 / e4))


def test_upwind_more_than_downwind_following_the_map(table_cache):
    for wind_deg in (0.0, 90.0):
        tab = pfac_table(clutter_scene(env={"wind_direction_deg": wind_deg}))
        per_az = tab.extra["expected_count"].sum(axis=0)
        az = np.degrees(tab.axes[1])
        up = np.abs((az - wind_deg + 180) % 360 - 180) < 30
        down = np.abs((az - wind_deg) % 360 - 180) < 30
        assert per_az[up].sum() > 1.3 * per_az[down].sum()
        # the peak is upwind
        smooth = np.convolve(np.r_[per_az, per_az[:30]], np.ones(31), "valid")[:360]
        peak = az[(np.argmax(smooth) + 15) % 360]
        assert abs((peak - wind_deg + 180) % 360 - 180) < 20
        # generated false alarms: same ratio
        g = clutter_false_alarm_generator(tab, pfa=1e-6, n_channels=2, n_pulses=10)
        rng = np.random.default_rng(2)
        azs = np.degrees(np.concatenate([g.draw(rng)[2] for _ in range(50)]))
        n_up = np.count_nonzero(np.abs((azs - wind_deg + 180) % 360 - 180) < 30)
        n_down = np.count_nonzero(np.abs((azs - wind_deg) % 360 - 180) < 30)
        assert n_up / n_down == pytest.approx(per_az[up].sum() / per_az[down].sum(), rel=0.1)


def test_hp_against_vp(table_cache):
    """7.2: HP P_fac is P_facmax at the 3° range for any wind, falls more slowly with range than
    VP, and barely depends on the sea state while VP grows by orders of magnitude."""
    tot, flat = {}, {}
    r_ref = float(sc.ground_range_at_grazing_m(sc.REFERENCE_GRAZING_RAD, 20.0))
    for pol in "VH":
        for ss, w in ((2, 4.0), (5, 12.0)):
            tab = pfac_table(clutter_scene(polarization=pol,
                                           env={"sea_state": ss, "wind_speed_mps": w}))
            prof, r = range_profile(tab)
            last = r[np.nonzero(prof)[0].max()]
            tot[pol, ss] = prof.sum()
            flat[pol, ss] = (prof * r).sum() / prof.sum() / last
            if pol == "H":
                near = tab.values[r + 50.0 <= r_ref]
                model = model_of(clutter_scene(polarization="H"))
                np.testing.assert_allclose(near, fa.default_p_fac_max(model.pfa), rtol=1e-9)
    for ss in (2, 5):
        assert flat["H", ss] > flat["V", ss]
        assert tot["H", ss] > tot["V", ss]
    assert tot["V", 5] / tot["V", 2] > 30.0
    assert tot["H", 5] / tot["H", 2] < 10.0
    # a user P_facmax, divided by K_clutter
    tab = pfac_table(clutter_scene(polarization="H", p_fac_max=5e-3, k_clutter=2.0))
    assert tab.values.max() == pytest.approx(2.5e-3, rel=1e-12)
    assert tab.values[tab.axes[0] + 50.0 <= r_ref] == pytest.approx(2.5e-3, rel=1e-12)


@pytest.mark.parametrize("env", [
    {"sea_state": 0, "wind_speed_mps": 0.0},   # calm sea: no clutter, no spikes
    {"sea_state": 0, "wind_speed_mps": 0.5},
    {"sea_state": 9, "wind_speed_mps": 40.0},  # very rough sea
])
@pytest.mark.parametrize("pol", ["V", "H"])
def test_extreme_seas_finite(table_cache, env, pol):
    s = clutter_scene(env=env, polarization=pol)
    tab = pfac_table(s)
    for arr in (tab.values, *tab.extra.values()):
        assert np.all(np.isfinite(arr))
    assert tab.values.min() >= 0.0 and tab.values.max() <= 1.0
    if env["wind_speed_mps"] == 0.0:
        assert tab.values.max() == 0.0
        assert clutter_false_alarm_generator(tab, pfa=1e-6, n_channels=2,
                                             n_pulses=10).scan(0, 1, 0, 2 * math.pi,
                                                               np.random.default_rng()) is None
    if env["sea_state"] == 9:
        assert tab.values.max() > 0.01


# --------------------------------------------------------------------------- generator
def test_sector_counts_match_pfac_times_cells(table_cache):
    tab = pfac_table(clutter_scene())
    g = clutter_false_alarm_generator(tab, pfa=1e-6, n_channels=2, n_pulses=10)
    eta = g.eta
    assert eta.size > 1000
    # three regimes present
    lim = float(fa.bernoulli_limit(2))
    assert np.any(eta < lim) and np.any(eta >= lim)
    n = 1500
    rng = np.random.default_rng(3)
    total = np.zeros(eta.size)
    for _ in range(n):
        c, r, az = g.draw(rng)
        total += c
    var = np.where(eta < lim, eta * (1.0 - eta), eta)
    # sectors with enough expected hits: each within 5.5 σ (normal approximation)
    big = n * eta >= 30
    assert big.sum() > 500
    z = (total[big] - n * eta[big]) / np.sqrt(n * var[big])
    assert np.abs(z).max() < 5.5
    assert abs(z.mean()) < 4.0 / math.sqrt(z.size)
    assert np.mean(z**2) == pytest.approx(1.0, abs=0.15)
    # the sparse sectors, pooled in decades of η
    small = ~big
    for lo in 10.0 ** np.arange(-7, 0):
        sel = small & (eta >= lo) & (eta < 10 * lo)
        if sel.any():
            e, v = n * eta[sel].sum(), n * var[sel].sum()
            assert abs(total[sel].sum() - e) < 5 * math.sqrt(v) + 1
    # wrong η (P_fac without the cells) would fail: the cells matter
    z_wrong = (total[big] - n * g.p_fac[big]) / np.sqrt(n * var[big])
    assert np.mean(z_wrong**2) > 3.0


def test_positions_inside_sectors_and_times(table_cache):
    tab = pfac_table(clutter_scene())
    g = clutter_false_alarm_generator(tab, pfa=1e-6, n_channels=2, n_pulses=10,
                                      h_range=4.0, h_azimuth=4.0)
    rng = np.random.default_rng(8)
    c, r, az = g.draw(rng)
    idx = np.repeat(np.arange(c.size), c)
    assert np.all((r >= g.r_min_m[idx]) & (r < g.r_max_m[idx]))
    assert np.all((az >= g.az_min_rad[idx]) & (az < g.az_max_rad[idx]))
    omega, start, t0 = 2 * math.pi, 1.0, 10.0
    out = g.scan(t0, t0 + 0.5, start, omega, rng)  # half a revolution left in the run
    assert np.all((out["time_s"] >= t0) & (out["time_s"] < t0 + 0.5))
    beam = start + omega * (out["time_s"] - t0)
    d = np.abs(np.mod(beam - out["azimuth_rad"] + math.pi, 2 * math.pi) - math.pi)
    assert d.max() < 1e-9
    full = g.scan(t0, t0 + 1.0, start, omega, rng)
    assert out["range_m"].size < 0.7 * full["range_m"].size
    # S/I above the Rayleigh CFAR threshold's excess; slant range just above ground range
    y = float(fa.clutter_threshold_ratio(1e-6))
    assert np.all(full["snr_db"] >= 10 * math.log10(y - 1.0) - 1e-9)
    assert np.all(full["range_m"] >= full["ground_range_m"])
    assert np.all(full["interference"] == 1)
    for k in ("sigma_range_m", "sigma_azimuth_rad", "snr_db", "range_m"):
        assert np.all(np.isfinite(full[k]))


def test_clutter_density_falls_with_range_noise_uniform(table_cache):
    s = clutter_scene()
    model = model_of(s)
    tab = model.tables.pfac
    g = clutter_false_alarm_generator(tab, pfa=model.pfa, n_channels=2, n_pulses=10)
    rng = np.random.default_rng(5)
    r = np.concatenate([g.draw(rng)[1] for _ in range(5)])
    r_max = s.radars()[0][1].instrumented_range_m
    assert stats.kstest(r / r_max, "uniform").pvalue < 1e-12
    # the histogram falls: each km holds fewer than the one before (over the first 3 km)
    h, _ = np.histogram(r, bins=np.arange(0, 4001, 1000))
    assert np.all(np.diff(h[:3]) < 0)
    # and follows the P_fac map: the CDF of the expected count, linear inside each sector
    prof, centres = range_profile(tab)
    edges = sector_edges(tab)[0]
    cdf_nodes = np.r_[0.0, np.cumsum(prof)] / prof.sum()
    assert stats.kstest(r, lambda x: np.interp(x, edges, cdf_nodes)).pvalue > 1e-3
    # noise false alarms stay uniform in range (t_fa = 0.1 s: about one per scan)
    noisy = model_of(clutter_scene(false_alarm_time_s=0.1))
    rn = np.concatenate([noisy.false_alarms.noise_false_alarms(rng)["range_m"] for _ in range(400)])
    assert rn.size > 100
    assert stats.kstest(rn / r_max, "uniform").pvalue > 1e-3


@pytest.mark.parametrize("p_fac,cells", [(1.0, 50.0), (1.0, 0.05), (1e-300, 1.0), (0.5, 1e4)])
def test_generator_extremes_finite(p_fac, cells):
    g = fa.ClutterFalseAlarms(
        [0.0, 100.0], [100.0, 200.0], [0.0, 0.1], [0.1, 0.2], [p_fac, p_fac], [cells, cells],
        [2.0, 3.0], threshold_ratio=20.0, n_channels=2, n_pulses=10, range_cell_m=37.5,
        beamwidth_rad=0.03, antenna_height_m=20.0)
    rng = np.random.default_rng(0)
    counts = np.array([g.draw(rng)[0] for _ in range(400)])
    assert counts.mean() == pytest.approx(p_fac * cells, rel=0.1, abs=0.05)
    out = g.scan(0.0, 1.0, 0.0, 2 * math.pi, rng)
    for v in out.values():
        assert np.all(np.isfinite(v))


# --------------------------------------------------------------------------- engine
def test_engine_run_emits_sea_clutter_plots(table_cache):
    s = clutter_scene(duration_s=3.0, rotation_rpm=60)
    bus = CaptureBus()
    sim = Simulation(s, bus=bus)
    assert sim.radars[0].model.tables.pfac is not None
    sim.run()
    # the run's count is the generator's: 3 revolutions of Σ η (var Σ η for the normal and
    # Poisson regimes, less for Bernoulli), within 5 σ
    expected = 3 * sim.radars[0].model.tables.pfac.extra["expected_count"].sum()
    assert expected > 1000
    assert abs(sim.stats.clutter_false_alarms - expected) < 5 * math.sqrt(expected)
    plots = bus.of(protocol.TOPIC_PLOTS)
    truth = [p for _, p in bus.of(protocol.TOPIC_TRUTH) if p["kind"] == "plots"]
    assert len(plots) == len(truth)
    origin = np.concatenate([t["origin"] for t in truth])
    assert np.count_nonzero(origin == ORIGIN_SEA_CLUTTER) == sim.stats.clutter_false_alarms
    # same columns as every other plot, no origin on the plot topic
    keys = {frozenset(p) for _, p in plots}
    assert len(keys) == 1 and "origin" not in next(iter(keys))
    rng_ = np.concatenate([p["range_m"] for _, p in plots])
    is_c = origin == ORIGIN_SEA_CLUTTER
    assert rng_[is_c].max() < 12_000.0  # clutter false alarms stay near the ship
    inter = np.concatenate([p["interference"] for _, p in plots])
    assert np.all(inter[is_c] == 1)
    # each plot is emitted when the beam sweeps it
    omega = 2 * math.pi / s.radars()[0][1].scan_period_s
    for _, p in plots:
        beam = np.mod(omega * p["time_s"], 2 * math.pi)
        d = np.abs(np.mod(beam - p["azimuth_rad"] + math.pi, 2 * math.pi) - math.pi)
        assert d.max() < 1e-9


@pytest.mark.slow
def test_figures_write_png(tmp_path, table_cache):
    from shipradar.sim.studies.figures.false_alarms import (
        clutter_extent_m,
        generated_false_alarms,
        plot_false_alarm_histograms,
        plot_pfac_map,
        plot_ppi_by_origin,
    )

    s = clutter_scene()
    fa_ = generated_false_alarms(s, scans=3, seed=2, min_noise=200)
    noise, clutter = fa_["origin"] == 1, fa_["origin"] == 2
    assert noise.sum() > 100 and clutter.sum() > 100
    assert np.all(fa_["scan"][noise & (fa_["scan"] >= 0)] < 3)
    p1 = plot_false_alarm_histograms(tmp_path / "fig8.png", fa_["range_m"][noise],
                                     fa_["range_m"][clutter], max_range_m=fa_["max_range_m"])
    first = fa_["scan"] == 0
    p2 = plot_ppi_by_origin(tmp_path / "ppi.png", fa_["range_m"][first],
                            fa_["azimuth_rad"][first], fa_["origin"][first], wind_from_rad=0.0)
    # the extra noise draw stands for min_noise/η scans
    model = model_of(s)
    assert fa_["noise_scans"] == pytest.approx(3 + 200 / model.noise_false_alarms_per_scan)
    zoom = clutter_extent_m(fa_["range_m"], fa_["origin"])
    assert fa_["range_m"][clutter].max() <= zoom * 1.5 and zoom < 0.5 * fa_["max_range_m"]
    p3 = plot_ppi_by_origin(tmp_path / "ppi2.png", fa_["range_m"][first],
                            fa_["azimuth_rad"][first], fa_["origin"][first],
                            max_range_m=fa_["max_range_m"], zoom_range_m=zoom,
                            tracks=[(np.array([0.1, 0.2]), np.array([5e3, 6e3]))])
    p4 = plot_pfac_map(tmp_path / "pfac.png", pfac_table(s), wind_from_rad=0.0)
    calm = pfac_table(clutter_scene(env={"sea_state": 0, "wind_speed_mps": 0.0}))
    p5 = plot_pfac_map(tmp_path / "pfac0.png", calm)  # all zero: still a figure
    for p in (p1, p2, p3, p4, p5):
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_clutter_range_profile(table_cache):
    """Per-ring expected false alarms (the radar's rate a tracker can use): sums to Σ η,
    equals the sector sums on sector edges, falls with range, and is empty without any."""
    tab = pfac_table(clutter_scene())
    prof, _ = range_profile(tab)
    edges, per = clutter_range_profile(tab, ring_m=100.0)  # = the sectors
    assert per.sum() == pytest.approx(prof.sum(), rel=1e-12)
    assert per == pytest.approx(prof[:per.size], rel=1e-9, abs=1e-12)
    assert np.all(prof[per.size:] == 0.0)
    e2, p2 = clutter_range_profile(tab, ring_m=1000.0)
    assert p2.sum() == pytest.approx(prof.sum(), rel=1e-12)
    assert np.all(np.diff(p2[1:]) < 0.0)  # beyond the first km, fewer in each ring
    assert e2[0] == 0.0 and np.all(np.diff(e2) == 1000.0)
    calm = pfac_table(clutter_scene(env={"sea_state": 0, "wind_speed_mps": 0.0}))
    e0, p0 = clutter_range_profile(calm)
    assert p0.size == 0 and e0.size == 1
    with pytest.raises(ValueError):
        clutter_range_profile(tab, ring_m=0.0)
