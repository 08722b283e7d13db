"""Monte Carlo studies: reproducibility on a two-worker cluster, P_d against the model."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("distributed")

from shipradar.sim.studies import montecarlo as mc  # noqa: E402
from shipradar.sim.world.scenario import load_scenario  # noqa: E402

from .helpers import ROOT  # noqa: E402

#: Replications of the two same-seed studies (≈1300 looks each, enough for the P_d check).
RUNS = 12


# --------------------------------------------------------------------------- statistics
def test_wilson_interval_literature_values():
    # Newcombe (1998), Stat. Med. 17, 857, Table I: 81/263 -> 0.2553, 0.3662 (95 %)
    lo, hi = mc.wilson_interval(81, 263)
    assert (lo, hi) == pytest.approx((0.2553, 0.3662), abs=1e-4)
    # 0/10 -> (0, 0.2775); 10/10 -> (0.7225, 1)
    assert mc.wilson_interval(0, 10) == pytest.approx((0.0, 0.2775), abs=1e-4)
    assert mc.wilson_interval(10, 10) == pytest.approx((0.7225, 1.0), abs=1e-4)


def test_poisson_interval_literature_values():
    # Garwood exact 95 % limits: k=0 -> (0, 3.689); k=10 -> (4.795, 18.39)
    assert mc.poisson_interval(0, 1.0) == pytest.approx((0.0, 3.6889), abs=1e-3)
    assert mc.poisson_interval(10, 2.0) == pytest.approx((4.7954 / 2, 18.390 / 2), abs=1e-3)


def test_run_seeds_are_spawned_children():
    kids = np.random.SeedSequence(5).spawn(3)
    seeds = [mc.run_seed(k) for k in kids]
    assert len(set(seeds)) == 3 and all(0 <= s < 2**63 for s in seeds)
    assert seeds == [mc.run_seed(k) for k in np.random.SeedSequence(5).spawn(3)]


def test_reduce_run_counts_looks_misses_and_false_alarms():
    sc = load_scenario(ROOT / "scenarios" / "single_missile.yaml")
    meta = {"sensor": "s", "radar": {"instrumented_range_m": 10000.0}}

    def eos(k):
        return (b"eos", k + 1.0, {"sensor": "s", "scan": k, "time_s": k + 1.0,
                                  "position": {"east_m": 0.0, "north_m": 0.0}})

    def targets(k, east, active=True):
        return (b"truth", k + 1.0, {"sensor": "s", "scan": k, "kind": "targets",
                                    "east_m": np.array([east]), "north_m": np.array([0.0]),
                                    "active": np.array([active])})

    def plots(k, origin, target):
        origin = np.array(origin, np.uint8)
        target = np.array(target, np.int32)
        lead = target[target >= 0]
        return (b"truth", k + 0.5, {"sensor": "s", "scan": k, "kind": "plots",
                                    "origin": origin, "target": target,
                                    "contrib_targets": lead.astype(np.int32)})

    msgs = [(b"meta", 0.0, meta),
            plots(0, [1], [-1]), eos(0), targets(0, 12000.0),          # out of range: no look
            plots(1, [0, 1, 2], [0, -1, -1]), eos(1), targets(1, 9000.0),  # detected
            eos(2), targets(2, 8000.0),                                 # missed
            plots(3, [0], [0]), eos(3), targets(3, 7000.0, False)]      # detected, then gone
    out = mc.reduce_run(msgs, sc, run=4, seed=9)
    (row,) = out["results"]
    assert (row["looks"], row["detections"], row["misses"]) == (3, 2, 1)
    assert row["first_detection_range_m"] == 9000.0 and row["first_detection_time_s"] == 2.0
    assert (row["noise_false_alarms"], row["sea_clutter_false_alarms"]) == (2, 1)
    assert [lk["detected"] for lk in out["looks"]] == [1, 0, 1]


# --------------------------------------------------------------------------- studies
@pytest.fixture(scope="module")
def studies(tmp_path_factory):
    """Two studies with the same seed and a smaller one with another, on a local two-worker
    cluster (processes, closed on exit)."""
    from distributed import Client, LocalCluster

    sc = load_scenario(ROOT / "scenarios" / "single_missile.yaml")
    base = tmp_path_factory.mktemp("mc")
    out = {}
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        for name, seed, runs, duration in (("a", None, RUNS, None), ("b", None, RUNS, None),
                                           ("c", 12345, 4, None)):
            out[name] = mc.run_study(sc, runs, seed=seed, out=base / name / "study.csv",
                                     progress=False, client=client, duration_s=duration)
    return sc, out


@pytest.mark.slow
def test_same_seed_same_files(studies):
    _sc, out = studies
    assert out["a"]["worker_pids"] == 2  # both workers ran replications
    assert out["a"]["tables_from_cache_files"]
    for key in ("results", "looks", "pd_range", "false_alarms"):
        a = open(out["a"]["files"][key], "rb").read()
        b = open(out["b"]["files"][key], "rb").read()
        assert len(a) > 0 and a == b, key
    # and the seed matters (otherwise the check above proves nothing): study c (another
    # seed, 4 runs) has other run seeds and other per-run draws than the first 4 runs of a
    rows_a, rows_c = _read(out["a"]["files"]["results"])[:4], _read(out["c"]["files"]["results"])
    assert len(rows_c) == 4
    assert not {r["seed"] for r in rows_a} & {r["seed"] for r in rows_c}
    assert [r["sea_clutter_false_alarms"] for r in rows_a] != \
        [r["sea_clutter_false_alarms"] for r in rows_c]


def _read(path):
    import csv

    with open(path) as f:
        return list(csv.DictReader(f))


@pytest.mark.slow
def test_empirical_pd_agrees_with_model(studies):
    """Each replication draws detection at crossing j with the model's P_d p_j (crossings
    depend on kinematics only). Per range bin, detections ~ Poisson-binomial with mean
    Σp_j and variance Σp_j(1-p_j); each bin must lie within 3.3 σ (two-sided 0.1 %), plus a
    continuity half-count, and the whole curve within a chi-square bound."""
    sc, out = studies
    model = mc.model_pd_looks(sc)
    assert model, "the model never saw the target"
    pd_of = {(m["sensor"], m["target"], m["scan"]): m["pd"] for m in model}
    looks = _read(out["a"]["files"]["looks"])
    bins: dict[int, list[float]] = {}
    matched = 0
    for lk in looks:
        p = pd_of.get((lk["sensor"], lk["target"], int(lk["scan"])))
        if p is None:
            assert lk["detected"] == "0", "a detection where the model has no crossing"
            continue
        matched += 1
        acc = bins.setdefault(int(float(lk["range_m"]) // 2000.0), [0.0, 0.0, 0.0, 0])
        acc[0] += int(lk["detected"])
        acc[1] += p
        acc[2] += p * (1.0 - p)
        acc[3] += 1
    assert matched >= 0.9 * len(looks)
    chi2 = 0.0
    informative = 0
    for b, (x, mean, var, n) in sorted(bins.items()):
        assert abs(x - mean) <= 3.3 * math.sqrt(var) + 0.5, (b, x, mean, var, n)
        if var > 1.0:
            chi2 += (x - mean) ** 2 / var
            informative += 1
    assert informative >= 2  # the curve has a transition, not only P_d = 0 or 1
    from scipy.stats import chi2 as chi2_dist

    assert chi2 <= chi2_dist.ppf(0.999, informative)
    # and the aggregated file holds the same counts with Wilson bounds around them
    agg = _read(out["a"]["files"]["pd_range"])
    assert sum(int(r["looks"]) for r in agg) == len(looks)
    for r in agg:
        pd, lo, hi = float(r["pd"]), float(r["ci_lo"]), float(r["ci_hi"])
        assert lo <= pd <= hi


@pytest.mark.slow
def test_false_alarms_per_scan_agree_with_meta_rate(studies):
    """Noise false alarms per scan: the exact Poisson interval of the study covers the
    radar's stated rate (meta: noise_false_alarms_per_scan), widened to 99.9 %."""
    from shipradar.sim.engine.simulation import Simulation

    sc, out = studies
    rate = Simulation(sc).radars[0].model.noise_false_alarms_per_scan
    rows = {r["origin"]: r for r in _read(out["a"]["files"]["false_alarms"])}
    k, scans = int(rows["noise"]["false_alarms"]), int(rows["noise"]["scans"])
    assert scans == RUNS * math.ceil(sc.duration_s / sc.platforms[0].radars[0].scan_period_s)
    lo, hi = mc.poisson_interval(k, scans, confidence=0.999)
    assert lo <= rate <= hi


@pytest.mark.slow
def test_cli_local_cluster_is_closed(tmp_path, capsys):
    """``shipradar montecarlo`` with its own local cluster: the files appear, the summary line
    is printed, and the worker processes are gone afterwards (no hang, nothing left)."""
    import json
    import multiprocessing

    before = {p.pid for p in multiprocessing.active_children()}
    out = tmp_path / "cli.csv"
    assert mc.cli_main([str(ROOT / "scenarios" / "single_missile.yaml"), "--runs", "2",
                        "--workers", "1", "--duration", "5", "--out", str(out),
                        "--no-progress"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["runs"] == 2 and summary["n_workers"] == 1
    for path in mc.study_paths(out).values():
        assert path.exists() and path.stat().st_size > 0
    left = {p.pid for p in multiprocessing.active_children()} - before
    assert not left


@pytest.mark.slow
def test_sea_clutter_false_alarms_per_scan_agree_with_pfac_map(studies):
    """Sea-clutter false alarms per scan: the study's exact Poisson interval (99.9 %) covers
    the P_fac map's expected count Σ P_fac × cells (≈388 per scan for this scene at K_clutter
    = 1, ≈39 with the file's 10; the count
    of a scan is a sum of per-sector normal/Poisson/Bernoulli draws, variance ≤ mean, so the
    Poisson interval is, if anything, conservative)."""
    from shipradar.tables.scene import load_scene_tables

    sc, out = studies
    tab = load_scene_tables(sc).for_radar(sc.platforms[0].radars[0].id).pfac
    expected = float(tab.extra["expected_count"].sum())
    assert 350.0 < expected * tab.inputs["k_clutter"] < 430.0  # tests/test_pfac_hand.py
    rows = {r["origin"]: r for r in _read(out["a"]["files"]["false_alarms"])}
    k, scans = int(rows["sea_clutter"]["false_alarms"]), int(rows["sea_clutter"]["scans"])
    lo, hi = mc.poisson_interval(k, scans, confidence=0.999)
    assert lo <= expected <= hi
    assert float(rows["sea_clutter"]["ci_lo"]) <= k / scans <= float(rows["sea_clutter"]["ci_hi"])


def test_cli_existing_scheduler(tmp_path, capsys):
    """``--scheduler ADDRESS``: the study runs on an existing cluster (here an in-process one
    with a thread worker) and leaves it running."""
    import json

    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=":0") as cluster:
        out = tmp_path / "remote.csv"
        assert mc.cli_main([str(ROOT / "scenarios" / "single_missile.yaml"), "--runs", "2",
                            "--duration", "5", "--out", str(out), "--no-progress",
                            "--scheduler", cluster.scheduler_address]) == 0
        summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
        assert summary["runs"] == 2 and summary["n_workers"] == 1
        with Client(cluster.scheduler_address) as client:  # still up
            assert len(client.scheduler_info()["workers"]) == 1
    assert len(_read(out)) == 2


def test_studies_never_share_a_task_key():
    """Dask hands back the future of a key it still holds, whatever the function and
    arguments (the hazard, checked on an in-process cluster), so each study's keys carry a
    part of their own: two studies with the same seed in one client get their own runs."""
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        first = client.submit(abs, -1, key="k", pure=False)
        again = client.submit(abs, -2, key="k", pure=False)
        assert first.result() == again.result() == 1  # the second call's -2 never ran
    a, b = mc.task_keys("run", 7, 3), mc.task_keys("run", 7, 3)
    assert len(set(a)) == 3 and not set(a) & set(b)
    assert all(k.startswith(f"shipradar-run-7-{i}-") for i, k in enumerate(a))
