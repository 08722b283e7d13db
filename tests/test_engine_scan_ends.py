"""The ends of scan are computed per block of revolutions (``RadarProcess._scan_end_states``:
states, coverage and last looks of every end of scan of a block at once) and give what one
computation per end of scan gives; a radar alone on the batched path resumes once per
revolution and gives SimPy's recording byte for byte."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from shipradar.sim.engine.plot_blocks import ABSENT, PLOT_DTYPES, merge_plot_batches
from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream.bus import Bus
from shipradar.sim.stream.recording import Recorder
from shipradar.sim.stream.sink import MemorySink
from shipradar.sim.world.kinematics import LocalFrame, antenna_azimuth
from shipradar.sim.world.scenario import Origin, load_scenario
from tests.helpers import ROOT


def test_antenna_azimuth_of_many_antennas_is_one_call_per_antenna():
    # one antenna row per object (the ends of a block's revolutions) gives, bit for bit, one
    # call per antenna position
    frame = LocalFrame(Origin(lat_deg=44.6, lon_deg=-63.0))
    rng = np.random.default_rng(11)
    ant = np.column_stack([rng.uniform(-40e3, 40e3, (300, 2)), rng.uniform(0.0, 30.0, 300)])
    obj = np.column_stack([rng.uniform(-90e3, 90e3, (300, 2)), rng.uniform(0.0, 9e3, 300)])
    obj[:5] = ant[:5]  # the antenna's own position: zero range
    az, ground = antenna_azimuth(ant, obj, frame)
    for i in range(300):
        az1, ground1 = antenna_azimuth(ant[i], obj[i:i + 1], frame)
        assert az1[0] == az[i]
        assert ground1[0] == ground[i]


@pytest.mark.parametrize("scene, duration", [("raid", 13.7), ("manoeuvres", 21.0)])
def test_truth_targets_per_block_is_one_computation_per_end_of_scan(scene, duration):
    s = load_scenario(ROOT / f"scenarios/{scene}.yaml")
    bus = MemorySink(skip={b"plots"})
    sim = Simulation(s, bus=bus, duration_s=duration, seed=3)
    sim.run()
    radars = {r.radar.id: r for r in sim.radars}
    n = sim.targets.n
    seen = 0
    for topic, t, p in bus.messages:
        if topic != b"truth" or p["kind"] != "targets":
            continue
        seen += 1
        radar = radars[p["sensor"]]
        pos, _ = radar.platform_state(np.array([t]))
        tpos, tvel, tacc, active = sim.targets.state_acc(np.full(n, t), np.arange(n))
        assert p["time_s"] == t
        np.testing.assert_array_equal(p["active"], active)
        assert np.array_equal(p["in_coverage"], radar.in_coverage(pos[0], tpos, active))
        for key, col in (("east_m", tpos[:, 0]), ("up_m", tpos[:, 2]),
                         ("v_north_mps", tvel[:, 1]), ("a_east_mps2", tacc[:, 0])):
            np.testing.assert_array_equal(p[key], np.where(active, col, np.nan))
    assert seen == sum(r.scans_in_run for r in sim.radars)


class _SimPyLoop(Simulation):
    batched = False


def _recording(cls, scenario, path, **kw):
    bus = Bus(None, Recorder(path))
    sim = cls(scenario, bus=bus, **kw)
    summary = sim.run()
    bus.close()
    return hashlib.sha256(path.read_bytes()).hexdigest(), summary["sectors"], sim


@pytest.mark.parametrize("duration", [13.7, 12.0])
def test_a_radar_alone_resumes_per_revolution_with_simpys_bytes(tmp_path, duration):
    # 13.7 s ends inside a revolution, 12 s at the end of one
    s = load_scenario(ROOT / "scenarios/single_missile.yaml")
    fast, sectors_fast, sim = _recording(Simulation, s, tmp_path / "fast.rec",
                                         duration_s=duration, seed=3)
    assert sim.batched and len(sim.radars) == 1
    slow, sectors_slow, sim = _recording(_SimPyLoop, s, tmp_path / "slow.rec",
                                         duration_s=duration, seed=3)
    assert not sim.batched
    assert (fast, sectors_fast) == (slow, sectors_slow)


def _reference_merge(parts):
    """The merge written plainly: concatenate, then a stable sort by (revolution, time)."""
    cat = {c: np.concatenate([p[c] if c in p else np.full(p["range_m"].size, ABSENT[c])
                              for p in parts]).astype(dt) for c, dt in PLOT_DTYPES.items()}
    rev = np.concatenate([p["revolution"] for p in parts])
    order = np.lexsort((cat["time_s"], rev))
    counts = np.concatenate([np.diff(p["contrib_offsets"]) if "contrib_offsets" in p
                             else np.zeros(p["range_m"].size, int) for p in parts])
    pool = [list(p["contrib_targets"][a:b]) for p in parts if "contrib_offsets" in p
            for a, b in zip(p["contrib_offsets"][:-1], p["contrib_offsets"][1:], strict=True)]
    lists, it = [], iter(pool)
    for p in parts:
        lists += ([next(it) for _ in range(p["range_m"].size)] if "contrib_offsets" in p
                  else [[] for _ in range(p["range_m"].size)])
    out = {c: a[order] for c, a in cat.items()}
    out["revolution"] = rev[order]
    out["contrib_offsets"] = np.concatenate([[0], np.cumsum(counts[order])])
    out["contrib_targets"] = np.array([x for i in order for x in lists[i]], dtype=np.int32)
    return out


@pytest.mark.parametrize("seed", range(6))
def test_merge_plot_batches_is_a_stable_sort_by_revolution_and_time(seed):
    rng = np.random.default_rng(seed)

    def part(n, targets):
        rev = np.sort(rng.integers(0, 3, n))
        p = {c: rng.normal(size=n).astype(dt) for c, dt in PLOT_DTYPES.items()}
        # times on a coarse grid (ties between and within batches); a plot may sort a hair
        # before its revolution's start (below the previous revolution's last ones)
        p["time_s"] = rev + rng.integers(0, 8, n) / 8.0 - (seed % 2) * 0.2
        p["revolution"] = rev
        if targets:
            off = np.concatenate([[0], np.cumsum(rng.integers(1, 3, n))])
            p.update(contrib_offsets=off, contrib_targets=rng.integers(0, 9, off[-1]))
        else:
            for c in ("target", "true_range_m", "true_azimuth_rad", "true_range_rate_mps"):
                del p[c]
        return p

    parts = [part(40, True), part(300, False), part(7, False)]
    got, want = merge_plot_batches(parts), _reference_merge(parts)
    assert got.keys() == want.keys()
    for c in got:
        np.testing.assert_array_equal(got[c], want[c])
        assert got[c].dtype == (PLOT_DTYPES.get(c) or got[c].dtype)


@pytest.mark.parametrize("dip", [False, True])
def test_sector_cuts_of_a_block_are_each_revolutions_own(dip):
    # a block's plots sorted by (revolution, time); with ``dip`` a plot a hair before its
    # revolution's start sorts below the previous revolution's last plots
    s = load_scenario(ROOT / "scenarios/single_missile.yaml")
    radar = Simulation(s, duration_s=30.0).radars[0]
    n, period = radar.n_sectors, radar.radar.scan_period_s
    rng = np.random.default_rng(2)
    scan0, times, edges = 4, [], [0]
    for r in range(5):
        t_a = (scan0 + r) * period
        t = np.sort(rng.uniform(t_a, t_a + period, 200))
        t[:3] = t_a + np.arange(3) * radar.sector_s  # on sector boundaries
        t = np.sort(t)
        if dip and r == 1:
            t[-1] = t_a + period - 1e-8
        if dip and r == 2:
            t = np.sort(np.concatenate([[t_a - 1e-7], t]))
        times.append(t)
        edges.append(edges[-1] + t.size)
    block = np.concatenate(times)
    assert bool(np.all(np.diff(block) >= 0)) is not dip
    cuts = radar.sector_cuts(scan0, block, edges)
    for r, t in enumerate(times):
        ends = radar.sector_end((scan0 + r) * n + np.arange(n - 1))
        want = edges[r] + np.append(np.searchsorted(t, ends, side="left"), t.size)
        np.testing.assert_array_equal(cuts[r], want)
