"""``shipradar fidelity`` (sim/studies/fidelity/, issues 18 and 38): common random
numbers, the comparison, the recommendation, its tolerances and its costs (a cost model in
place of the clock: :class:`CostModel`), --apply, bad input, and ``validate --explain``.

Scenes are small (one X-band radar, 1 s scans, a few tens of seconds, one or two targets)
and share one private table cache for the module. The accuracy runs are deterministic
(common random numbers), so a study run again in this module reuses them (:func:`_memo_runs`).
"""

from __future__ import annotations

import copy
import math
import os
from pathlib import Path

import numpy as np
import pytest
import yaml

from shipradar.sim.studies import fidelity as fi
from shipradar.sim.studies import timing as ti
from shipradar.sim.world.scenario import Fidelity, load_scenario, parse_scenario
from tests.helpers import quiet_radar

# an X-band variant of the tests' quiet radar
RADAR = quiet_radar(id="xr", peak_power_w=25000, gain_db=32, frequency_hz=10e9,
                    beamwidth_az_deg=3.3, pulse_width_s=2e-6, instrumented_range_m=40000)


def scene(targets, *, duct=None, wave_height=None, duration=20.0, radar=None, fidelity=None,
          rain=None, seed=5):
    env = {"sea_state": 2}
    if duct is not None:
        env["duct"] = {"type": "height", "height_m": duct}
    if wave_height is not None:
        env["wave_height_m"] = wave_height
    if rain is not None:
        env["rain"] = rain
    return {
        "name": "fidelity-test", "duration_s": duration, "seed": seed,
        "origin": {"lat_deg": 44.6, "lon_deg": -63.0},
        "platforms": [{"id": "ship", "waypoints": [{"east_m": 0, "north_m": 0}],
                       "radars": [copy.deepcopy(radar or RADAR)]}],
        "targets": targets,
        "environment": env,
        **({"fidelity": fidelity} if fidelity else {}),
    }


def target(tid, start_km, end_km, alt, sigma=1.0, duration=20.0):
    return {"id": tid, "kind": "missile", "swerling": 1,
            "waypoints": [{"time_s": 0, "east_m": 0, "north_m": start_km * 1e3,
                           "altitude_m": alt},
                          {"time_s": duration, "east_m": 0, "north_m": end_km * 1e3,
                           "altitude_m": alt}],
            "rcs": {"type": "constant", "sigma_m2": sigma}}


#: A low target in a 20 m evaporation duct, beyond the 4/3-earth horizon (27.6 km for a 20 m
#: antenna and 5 m target): the duct carries it, the two-ray model's diffraction does not.
DUCTED = scene([target("skimmer", 36, 30, 5.0, sigma=10.0)], duct=20.0,
               radar={**RADAR, "peak_power_w": 200000})
#: A target at 1000 m, 30-22 km, over a rough sea (2 m waves: Miller-Brown rho ~ 0 at these
#: 2-3 deg grazing angles): the sea reflection is gone, free-space-like.
LIT = scene([target("high", 30, 22, 1000.0, sigma=20.0)], wave_height=2.0)


@pytest.fixture(scope="module", autouse=True)
def _private_cache(tmp_path_factory):
    root = tmp_path_factory.mktemp("tables")
    old = os.environ.get("SHIPRADAR_TABLES")
    os.environ["SHIPRADAR_TABLES"] = str(root)
    yield root
    if old is None:
        os.environ.pop("SHIPRADAR_TABLES", None)
    else:
        os.environ["SHIPRADAR_TABLES"] = old


class CostModel:
    """A test double of the study's clock (:class:`shipradar.sim.studies.timing.SampleTimer`):
    each setting's CPU is ``base_s`` times the factors of the values it sets, times seeded
    log-normal noise (``noise``, the spread of a loaded machine), the same on load, first
    and warm run."""

    def __init__(self, factors=None, *, base_s=0.1, noise=0.05, seed=0):
        self.factors = factors or {}
        self.base_s = base_s
        self.noise = noise
        self.rng = np.random.default_rng(seed)
        self.calls = 0

    def __call__(self, fid, seed):
        self.calls += 1
        f = math.prod(v for (choice, value), v in self.factors.items()
                      if fid[choice] == value)
        n = self.rng.lognormal(0.0, self.noise, size=3)
        return ti.Sample(0.2 * self.base_s * f * n[0], self.base_s * f * n[1],
                         self.base_s * f * n[2])


@pytest.fixture(scope="module", autouse=True)
def _memo_runs():
    """Accuracy runs keyed by (scene, setting, seeds, duration): identical when repeated."""
    memo = {}
    real = fi.run_setting

    def run(scenario, setting, seeds, duration_s, clock, *, crn=True):
        key = (scenario.model_dump_json(), repr(sorted(setting.fidelity.items())),
               tuple(seeds), duration_s, crn)
        if key not in memo:
            memo[key] = real(scenario, setting, seeds, duration_s, clock, crn=crn)
        return copy.copy(memo[key]) if memo[key].setting == setting else \
            fi.RunResult(**{**memo[key].__dict__, "setting": setting})

    mp = pytest.MonkeyPatch()
    mp.setattr(fi.trade, "run_setting", run)  # where the study calls it
    yield
    mp.undo()


#: LIT's costs in the test double: both cheaper propagation models 3x cheaper per run.
LIT_COSTS = {("propagation", "two_ray"): 1 / 3, ("propagation", "free_space"): 1 / 3}


@pytest.fixture(scope="module")
def ducted_study():
    return fi.run_fidelity_study(parse_scenario(DUCTED), timer=CostModel(), pairs=4)


@pytest.fixture(scope="module")
def lit_study():
    return fi.run_fidelity_study(parse_scenario(LIT), timer=CostModel(LIT_COSTS), pairs=4)


def _comp(study, label):
    return next(c for c in study.comparisons if c.result.setting.label == label)


# ----------------------------------------------------------------------------- CRN
@pytest.mark.slow
def test_reference_against_itself_is_exactly_zero():
    """Two separate runs of the reference: the same dice per look, so nothing differs; a
    setting the scene does not read (improvement_grid, no processor) is zero as well and
    reported as not exercised."""
    s = parse_scenario(DUCTED)
    ref_fid, settings, skipped = fi.plan_settings(s, include_unexercised=True)
    clock = fi.TableClock()
    seeds = [11, 12]
    a = fi.run_setting(s, settings[0], seeds, 15.0, clock)
    b = fi.run_setting(s, settings[0], seeds, 15.0, clock)
    tol = fi.Tolerances(latency_s=1.0)
    c = fi.compare(a, b, s, tol)
    assert c.total["looks"] > 10 and c.total["detections"] > 0
    assert c.total["zero"] and c.ok
    assert c.total["max_abs_dpd"] == 0.0 and c.total["d_detections"] == 0
    np.testing.assert_array_equal(a.looks["pd"], b.looks["pd"])
    np.testing.assert_array_equal(a.looks["hit"], b.looks["hit"])
    # not exercised: run on request, zero, flagged
    assert dict(skipped)["improvement_grid"].endswith("no processor")
    unused = next(x for x in settings if x.label == "improvement_grid=coarse")
    assert not unused.exercised
    u = fi.compare(a, fi.run_setting(s, unused, seeds, 15.0, clock), s, tol)
    assert u.total["zero"] and u.ok
    # and the dice are not all equal: another seed gives other detections
    other = fi.run_setting(s, settings[0], [13, 14], 15.0, clock)
    assert not np.array_equal(other.looks["hit"], a.looks["hit"])


@pytest.mark.slow
def test_common_random_numbers_survive_other_draws(monkeypatch):
    """The sea-clutter false-alarm model changes how many numbers each scan draws, not any
    target's P_d: with common random numbers every look keeps its outcome; on the engine's
    sequential stream (crn=False) the looks of later blocks of revolutions (2 s here) have
    their dice moved (so this test can fail)."""
    from shipradar.sim.engine import simulation as engine

    monkeypatch.setattr(engine, "_BLOCK_S", 2.0)
    radar = {**RADAR, "pulse_width_s": 0.25e-6, "instrumented_range_m": 30000}
    s = parse_scenario(scene([target("t1", 26, 20, 300.0, sigma=20.0, duration=30.0),
                              target("t2", 28, 22, 100.0, sigma=5.0, duration=30.0)],
                             radar=radar, duration=30.0, duct=None))
    ref_fid, settings, _ = fi.plan_settings(s)
    alt = next(x for x in settings if x.label == "clutter_fa_model=seed")
    clock = fi.TableClock()
    outcome = {}
    for crn in (True, False):
        a = fi.run_setting(s, settings[0], [3], 30.0, clock, crn=crn)
        b = fi.run_setting(s, alt, [3], 30.0, clock, crn=crn)
        assert b.drawn_fa["sea_clutter"] > 3 * a.drawn_fa["sea_clutter"] > 0
        np.testing.assert_array_equal(a.looks["pd"], b.looks["pd"])
        assert 0.1 < a.looks["pd"].mean() < 0.9
        outcome[crn] = np.array_equal(a.looks["hit"], b.looks["hit"])
    assert outcome == {True: True, False: False}


def test_look_uniforms_are_a_function_of_the_look():
    u = fi.look_uniforms(7, 0, 1.0)
    rows = np.array([0, 1, 0, 2])
    t = np.array([0.5, 0.5, 1.5, 0.5])
    x = u(rows, t)
    assert np.all((x >= 0) & (x < 1))
    assert len(set(x.tolist())) == 4
    # same (target, scan) at another time inside the scan: the same number
    assert u(np.array([0]), np.array([0.9]))[0] == x[0]
    # another radar or seed: other numbers
    assert fi.look_uniforms(7, 1, 1.0)(rows, t)[0] != x[0]
    assert fi.look_uniforms(8, 0, 1.0)(rows, t)[0] != x[0]
    # uniform: a Kolmogorov-Smirnov test on 20 000 looks
    from scipy.stats import kstest

    big = u(np.arange(20000) % 50, (np.arange(20000) // 50).astype(float) + 0.5)
    assert kstest(big, "uniform").pvalue > 1e-3


def test_default_run_is_unchanged_by_the_hooks():
    """The hooks are opt-in: a normal run draws from the engine's stream as before (same
    result twice; the look_uniforms path is not taken)."""
    from shipradar.sim.engine.simulation import Simulation

    s = parse_scenario(scene([target("t", 20, 15, 50.0)],
                             fidelity={"propagation": "two_ray", "atmosphere": False,
                                       "clutter": False}))
    runs = []
    for _ in range(2):
        sim = Simulation(s, duration_s=10.0)
        assert all(r.model.look_uniforms is None for r in sim.radars)
        runs.append(sim.run())
    keys = ("target_plots", "missed_detections", "noise_false_alarms")
    assert [runs[0][k] for k in keys] == [runs[1][k] for k in keys]


# ----------------------------------------------------------------------------- physics
@pytest.mark.slow
def test_ducted_low_target_rejects_two_ray(ducted_study):
    """The duct carries the target beyond the horizon; two-ray's diffraction does not:
    a large ΔP_d and no recommendation of two_ray."""
    two = _comp(ducted_study, "propagation=two_ray")
    assert two.total["worst_target_mean_abs_dpd"] > 0.2
    assert two.total["d_detections"] < -3
    assert not two.ok
    assert ducted_study.recommended["propagation"] == "pe"
    # a deliberately coarse PE grid is not identical to the fine reference
    coarse = _comp(ducted_study, "pe_grid=coarse")
    assert coarse.total["max_abs_dpd"] > 0.0


@pytest.mark.slow
def test_free_space_like_geometry_accepts_two_ray(lit_study):
    two = _comp(lit_study, "propagation=two_ray")
    assert two.ok, two.violations
    assert two.total["worst_target_mean_abs_dpd"] <= lit_study.tolerances.pd
    # the PE table is not worth its cost there
    assert lit_study.recommended["propagation"] in ("two_ray", "free_space")


@pytest.mark.slow
def test_recommendation_applied_and_rerun_is_inside_its_tolerances(lit_study, tmp_path):
    """The block written by --apply (unread choices left out: the schema's defaults stand
    for them) runs inside the tolerances, against the reference run again."""
    study = lit_study
    path = tmp_path / "lit.yaml"
    path.write_text(yaml.safe_dump(LIT, sort_keys=False))
    out = tmp_path / "lit-fast.yaml"
    fi.apply_fidelity(path, study.recommended, out, unread=study.unread)
    applied = load_scenario(out)
    read = set(Fidelity.model_fields) - set(study.unread)
    assert "pe_grid" not in read and "pe_grid:" not in out.read_text()
    assert applied.fidelity.model_dump(include=read) == \
        Fidelity(**study.recommended).model_dump(include=read)
    assert applied.targets == parse_scenario(LIT).targets
    s = parse_scenario(LIT)
    clock = fi.TableClock()
    ref = fi.run_setting(s, fi.Setting("reference", None, None, study.reference, True,
                                       "reference"), study.seeds, study.duration_s, clock)
    again = fi.run_setting(s, fi.Setting("applied", None, None,
                                         applied.fidelity.model_dump(), True, "combined"),
                           study.seeds, study.duration_s, clock)
    c = fi.compare(ref, again, s, study.tolerances)
    assert c.ok, c.violations
    for row in c.rows:
        assert row["mean_abs_dpd"] <= study.tolerances.pd
        assert row["abs_dfirst_m"] <= study.tolerances.range_m


@pytest.mark.slow
def test_equal_costs_keep_the_reference_twice(ducted_study):
    """Every setting costs the same (10 % noise, two noise seeds): nothing is measurably
    cheaper, so the same command twice recommends the reference both times, and says so."""
    study = ducted_study
    again = fi.run_fidelity_study(parse_scenario(DUCTED), timer=CostModel(noise=0.1, seed=9),
                                  pairs=4)
    for st in (study, again):
        assert st.recommended == st.reference
        assert st.recommended_comparison is st.comparisons[0]
        assert "recommended: the reference (no setting" in fi.format_report(st)
        # no alternative is called cheaper
        assert not any(ti.is_cheaper(st.ratio(c)) for c in st.comparisons[1:])
    # violations make a setting inadmissible, and are reported
    bad = [c for c in study.comparisons if not c.ok]
    assert bad and all(c.violations for c in bad)


@pytest.mark.slow
def test_a_three_times_cheaper_setting_is_found(lit_study):
    """two_ray and free_space 3x cheaper per run (the cost model), both inside the
    tolerances: the more accurate of the two is recommended, re-timed as a whole at 1/3 of
    the reference within its interval; pe_grid, unread beside two_ray, is left out."""
    study = lit_study
    assert study.recommended["propagation"] == "two_ray"
    assert _diff_label(study) == "propagation=two_ray"
    two, free = _comp(study, "propagation=two_ray"), _comp(study, "propagation=free_space")
    assert two.ok and free.ok
    assert fi.error_score(two, study.tolerances) < fi.error_score(free, study.tolerances)
    cost = study.recommended_cost
    assert cost is not None and cost.warm_ratio.n == 4
    assert cost.warm_ratio.low < 1 / 3 < cost.warm_ratio.high
    assert ti.is_cheaper(cost.warm_ratio)
    assert "pe_grid" in study.unread
    text = fi.format_report(study)
    assert "recommended (cheapest by per-run CPU" in text
    assert "  pe_grid:" not in text.split("recommended (")[1]
    assert "not read by this scene with this block: pe_grid" in text
    # and the more accurate one loses when the other is clearly cheaper
    other = fi.run_fidelity_study(parse_scenario(LIT), pairs=4, timer=CostModel(
        {**LIT_COSTS, ("propagation", "free_space"): 1 / 6}))
    assert other.recommended["propagation"] == "free_space"


@pytest.mark.slow
def test_combined_block_is_retimed_and_dropped_when_not_cheaper():
    """Each of two changes is 2x cheaper alone, but together they cost the reference's
    (the cost model's interaction): the block re-timed as a whole is not cheaper, so the
    change with the smaller saving goes back; the printed block is then a single change
    whose own fresh timing is the saving printed."""

    class Interacting(CostModel):
        def __call__(self, fid, seed):
            both = fid["propagation"] == "two_ray" and fid["atmosphere"] is False
            self.factors = ({} if both else
                            {("propagation", "two_ray"): 0.5, ("atmosphere", False): 0.45})
            return super().__call__(fid, seed)

    study = fi.run_fidelity_study(parse_scenario(LIT), pairs=4, timer=Interacting())
    assert any("re-timed as a whole" in n and "propagation back to pe" in n
               for n in study.notes), study.notes
    assert _diff_label(study) == "atmosphere=false"
    assert study.recommended_cost.warm_ratio.low < 0.45 < study.recommended_cost.warm_ratio.high


@pytest.mark.slow
def test_same_command_twice_with_the_real_clock():
    """The real clock on the lit scene: two studies recommend the same block, or each
    choice on which they differ is reported as within noise by one of them."""
    studies = [fi.run_fidelity_study(parse_scenario(LIT), pairs=3) for _ in range(2)]
    a, b = (st.recommended for st in studies)
    differ = {k for k in a if a[k] != b[k]}
    noisy = {u.split("=")[0] for st in studies for u in st.undecided}
    assert differ <= noisy, (a, b, [st.undecided for st in studies])


@pytest.mark.slow
def test_shortened_study_warns(capsys):
    study = fi.run_fidelity_study(parse_scenario(LIT), duration_s=10.0, timer=CostModel(),
                                  pairs=2)
    assert study.shortened
    text = fi.format_report(study)
    assert text.count("WARNING: shortened study (10 s of the scene's 20 s)") == 2
    assert "holds for the first 10 s only" in text
    assert not fi.run_fidelity_study(parse_scenario(LIT), timer=CostModel(), pairs=2).shortened


def test_apply_refuses_a_shortened_study(tmp_path, capsys):
    """--apply with --duration below the scene's refuses before any work, naming the flag
    that allows it."""
    src = tmp_path / "s.yaml"
    src.write_text(yaml.safe_dump(LIT))
    out = tmp_path / "o.yaml"
    assert fi.cli_main([str(src), "--duration", "5", "--apply", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--duration 5 s is shorter than the scene's 20 s" in err
    assert "--allow-shortened" in err and not out.exists()


def _diff_label(study):
    return fi.diff_label(study.recommended, study.reference)


@pytest.mark.slow
def test_scene_without_rain_or_jammer_skips_those_rows(ducted_study):
    skipped = dict(ducted_study.skipped)
    # low-resolution radar (3.3 deg x 2 us): no sea-clutter false alarms, no P_fac model row
    assert "clutter_fa_model" in skipped and "low resolution" in skipped["clutter_fa_model"]
    assert "improvement_grid" in skipped and "no processor" in skipped["improvement_grid"]
    labels = {c.result.setting.label for c in ducted_study.comparisons}
    assert not any(lb.startswith(("clutter_fa_model", "improvement_grid")) for lb in labels)
    parts = {(p.name, p.radar): p for p in fi.explain(parse_scenario(DUCTED))}
    assert not parts[("weather clutter [39]-[45]", "xr")].exercised
    assert parts[("weather clutter [39]-[45]", "xr")].reason == "no rain"
    assert not parts[("stand-off jamming [47]-[48]", None)].exercised
    assert "no jammer" in parts[("stand-off jamming [47]-[48]", None)].reason


def test_explain_with_rain_processor_high_target():
    radar = {**RADAR, "pulse_width_s": 0.25e-6, "processor": {"type": "mti", "mti_order": 2}}
    s = parse_scenario(scene([target("low", 20, 15, 10.0), target("jet", 30, 25, 3000.0)],
                             radar=radar, rain={"rate_mm_h": 4.0}))
    parts = {(p.name, p.radar): p for p in fi.explain(s)}
    assert parts[("weather clutter [39]-[45]", "xr")].exercised
    assert parts[("Doppler processor, I_F table [49]-[62]", "xr")].exercised
    assert parts[("sea-clutter false alarms [94]-[96]", "xr")].exercised
    two = parts[("two-ray fallback (3.1.2)", None)]
    assert "jet" in two.reason and "low" not in two.reason
    text = "\n".join(fi.explain_lines(s))
    assert "skipped:" in text and "no jammer" in text


# ----------------------------------------------------------------------------- output
@pytest.mark.slow
def test_report_csv_png(lit_study, tmp_path):
    text = fi.format_report(lit_study)
    assert "recommended" in text and "fidelity:\n  pd_method:" in text
    block = text[text.index("fidelity:\n"):].split("\n\n")[0]
    read = set(Fidelity.model_fields) - set(lit_study.unread)
    assert Fidelity(**yaml.safe_load(block)["fidelity"]).model_dump(include=read) == \
        Fidelity(**lit_study.recommended).model_dump(include=read)
    assert set(yaml.safe_load(block)["fidelity"]) == read
    per = fi.format_per_target(lit_study)
    assert "xr/high" in per and per.count("\n") == sum(len(c.rows) for c in lit_study.comparisons)
    fi.write_csv(lit_study, tmp_path / "f.csv")
    import csv

    rows = list(csv.DictReader(open(tmp_path / "f.csv", encoding="utf-8")))
    assert {r["setting"] for r in rows} >= {"reference", "propagation=two_ray"}
    two = next(r for r in rows if r["setting"] == "propagation=two_ray" and r["target"] == "*")
    assert float(two["warm_run_ratio_low"]) < 1 / 3 < float(two["warm_run_ratio_high"])
    assert two["cheaper"] == "True" and float(two["build_estimated_s"]) >= 0
    assert any(r["target"] == "*" for r in rows) and any(r["target"] == "high" for r in rows)
    fi.plot_pareto(lit_study, tmp_path / "f.png")
    assert (tmp_path / "f.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_pareto_front():
    assert fi.pareto_front([1, 2, 3, 4], [0.5, 0.1, 0.2, 0.0]) == [0, 1, 3]
    assert fi.pareto_front([1, 1, 2], [0.3, 0.2, 0.2]) == [1]


def test_apply_keeps_the_file_and_refuses_to_overwrite(tmp_path):
    src = tmp_path / "s.yaml"
    body = yaml.safe_dump(LIT, sort_keys=False)
    src.write_text("# my comment\n" + body + "fidelity:\n  pe_grid: fine  # old\n\n# tail\n")
    fid = {**Fidelity().model_dump(), "propagation": "two_ray"}
    out = tmp_path / "o.yaml"
    assert fi.apply_fidelity(src, fid, out) is None
    text = out.read_text()
    assert text.startswith("# my comment\n") and text.rstrip().endswith("# tail")
    assert "pe_grid: fine  # old" not in text and "propagation: two_ray" in text
    assert load_scenario(out).fidelity.propagation == "two_ray"
    with pytest.raises(FileExistsError):
        fi.apply_fidelity(src, fid, out)
    before = out.read_bytes()
    backup = fi.apply_fidelity(src, {**fid, "propagation": "pe"}, out, overwrite=True)
    assert backup is not None and backup.read_bytes() == before
    assert load_scenario(out).fidelity.propagation == "pe"
    # a second overwrite keeps both earlier versions
    backup2 = fi.apply_fidelity(src, fid, out, overwrite=True)
    assert backup2 != backup and backup.exists() and backup2.exists()


@pytest.mark.parametrize("argv, words", [
    (["--tolerance-pd", "2"], ["--tolerance-pd", "[0, 1]", "'2'"]),
    (["--tolerance-range-m", "-5"], ["--tolerance-range-m", "-5"]),
    (["--runs", "0"], ["--runs", "[1, 1000]", "'0'"]),
    (["--duration", "abc"], ["--duration", "'abc'"]),
    (["--tolerance-fa", "nan"], ["--tolerance-fa", "[0, 100]", "'nan'"]),
    (["--max-build-s", "inf"], ["--max-build-s", "'inf'"]),
    (["--pairs", "2.5"], ["--pairs", "an integer", "'2.5'"]),
])
def test_bad_input_exits_2_naming_option_value_and_range(argv, words, capsys, tmp_path):
    src = tmp_path / "s.yaml"
    src.write_text(yaml.safe_dump(LIT))
    assert fi.cli_main([str(src), *argv]) == 2
    err = capsys.readouterr().err
    for w in words:
        assert w in err


def test_cli_refuses_existing_apply_target_and_missing_scenario(tmp_path, capsys):
    src = tmp_path / "s.yaml"
    src.write_text(yaml.safe_dump(LIT))
    out = tmp_path / "o.yaml"
    out.write_text("keep me")
    assert fi.cli_main([str(src), "--apply", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err and out.read_text() == "keep me"
    assert fi.cli_main([str(tmp_path / "nope.yaml")]) == 2
    assert fi.cli_main([]) == 2


def test_validate_explain_cli(capsys):
    from shipradar.sim.cli import main

    assert main(["validate", "--example", "single_missile", "--explain"]) == 0
    out = capsys.readouterr().out
    assert "exercised:" in out and "skipped:" in out
    assert "stand-off jamming [47]-[48]: no jammer" in out
    assert "weather clutter [39]-[45] (giraffe): no rain" in out


def test_expected_first_detection_range():
    # certain detection at the first look: its range; never: None
    assert fi.expected_first_range(np.array([1.0, 0.5]), np.array([10.0, 9.0])) == (10.0, 1.0)
    assert fi.expected_first_range(np.zeros(3), np.array([3.0, 2.0, 1.0]))[0] is None
    # two looks at 0.5: first at look 1 with 0.5, at look 2 with 0.25
    r, p = fi.expected_first_range(np.array([0.5, 0.5]), np.array([10.0, 8.0]))
    assert p == pytest.approx(0.75, abs=1e-15)
    assert r == pytest.approx((0.5 * 10 + 0.25 * 8) / 0.75, rel=1e-12)


# ----------------------------------------------------------------------------- costs
def test_ratio_interval_covers_the_true_ratio():
    """Paired log-normal costs with a common load factor per pair (a shared machine): the
    95 % interval of the ratio covers the true ratio in 95 % of 4000 seeded experiments
    (binomial spread: 0.95 ± 0.007), and the load factor cancels."""
    rng = np.random.default_rng(38)
    true = 0.7
    hits = 0
    for _ in range(4000):
        load = rng.lognormal(0.0, 0.5, size=6)  # both sides of a pair slowed alike
        ref = 0.2 * load * rng.lognormal(0.0, 0.08, size=6)
        cand = true * 0.2 * load * rng.lognormal(0.0, 0.08, size=6)
        r = ti.ratio_interval(cand, ref)
        hits += r.low <= true <= r.high
    assert hits / 4000 == pytest.approx(0.95, abs=0.025)
    # exact ratios: zero width
    r = ti.ratio_interval([1.0, 2.0, 4.0], [2.0, 4.0, 8.0])
    assert (r.value, r.low, r.high) == pytest.approx((0.5, 0.5, 0.5), rel=1e-12)


def test_is_cheaper_needs_the_whole_interval_below_the_margin():
    assert ti.is_cheaper(ti.Interval(0.5, 0.4, 0.6, 5))
    assert not ti.is_cheaper(ti.Interval(0.9, 0.8, 1 - ti.SAVING_MIN, 5))
    assert not ti.is_cheaper(ti.Interval(0.5, 0.5, 0.5, 1))  # one pair says nothing
    m = ti.mean_interval([1.0, 2.0, 3.0])
    # t(0.975, 2) = 4.303; s = 1
    assert (m.low, m.high) == pytest.approx((2 - 4.303 / 3**0.5, 2 + 4.303 / 3**0.5), rel=1e-3)


def test_paired_costs_alternate_the_order():
    """Reference first in even pairs, second in odd ones, the same seed in a pair."""
    calls = []

    def timer(fid, seed):
        calls.append((fid["name"], seed))
        return ti.Sample(0.0, 1.0, 1.0)

    ti.paired_costs(timer, {"name": "ref"}, [{"name": "a"}, {"name": "b"}], [7, 8], 2)
    assert calls == [("ref", 7), ("a", 7), ("ref", 7), ("b", 7),
                     ("b", 8), ("ref", 8), ("a", 8), ("ref", 8)]


def test_unread_choices_and_the_block_without_them():
    s = parse_scenario(LIT)
    ref = fi.reference_fidelity(s)
    assert fi.unread_choices(s, ref) == ("improvement_grid", "clutter_fa_model")
    assert fi.unread_choices(s, {**ref, "propagation": "two_ray"}) == (
        "pe_grid", "improvement_grid", "clutter_fa_model")
    block = fi.fidelity_yaml({**ref, "propagation": "two_ray"}, ("pe_grid",))
    assert "pe_grid:" not in block and "# not read by this scene with this block: pe_grid" in block


def test_labels_do_not_collide():
    """Twelve labels on points close together: every label finds a place that meets no
    other label."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    x = [1.0, 1.02, 1.04, 0.98, 1.0, 0.5, 0.52, 0.5, 2.0, 2.0, 1.01, 0.99]
    y = [0.01, 0.011, 0.0105, 0.0102, 0.012, 0.001, 0.001, 0.0011, 0.1, 0.1, 0.0101, 0.0099]
    ax.scatter(x, y)
    ax.set_xscale("log")
    ax.set_yscale("log")
    labels = [f"setting_{i}=value" for i in range(len(x))]
    anns = fi.place_labels(ax, x, y, labels)
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    boxes = [fi.text_box(a, r) for a in anns]
    assert len(anns) == 11  # the two points at (2.0, 0.1) share one label
    assert any(", " in a.get_text() for a in anns)
    for i in range(len(boxes)):
        for j in range(i):
            assert not boxes[i].overlaps(boxes[j]), (anns[i].get_text(), anns[j].get_text())
    plt.close(fig)


def test_pareto_front_is_drawn_over_points_inside_the_tolerances():
    ok = [True, False, True, True]
    cost = [1.0, 0.2, 0.5, 0.3]
    err = [0.0, 0.001, 0.01, 0.05]
    assert fi.tolerated_front(cost, err, ok) == [3, 2, 0]


def test_saving_in_seconds_does_not_depend_on_a_shared_cost():
    """The same candidate measured in a bare process and in one that pays 1 s more on both
    sides (a fresh process's imports): the ratio moves towards 1, the saving does not."""
    ref = [ti.Sample(0.1, 0.2, 0.05), ti.Sample(0.1, 0.22, 0.05)]
    cand = [ti.Sample(0.05, 0.1, 0.05), ti.Sample(0.05, 0.12, 0.05)]
    plus = [ti.Sample(s.load_s + 1.0, s.first_run_s, s.warm_run_s) for s in ref]
    cand_plus = [ti.Sample(s.load_s + 1.0, s.first_run_s, s.warm_run_s) for s in cand]
    a, b = ti.PairedCost(ref, cand), ti.PairedCost(plus, cand_plus)
    assert a.saving_s("first_s").value == pytest.approx(0.15, rel=1e-12)
    assert b.saving_s("first_s").value == pytest.approx(0.15, rel=1e-12)
    assert a.first_ratio.value < 0.55 < 0.85 < b.first_ratio.value


def test_table_choices_name_every_fidelity_field_a_table_depends_on(table_cache):
    """A table kind shared across settings (TABLE_CHOICES) must not depend on another field:
    on the jammed_squall (rain, so every kind), change one field at a time and compare each
    table's cache key (the weather map holds the rain's γ_r only with the atmosphere on)."""
    from shipradar.tables.scene import table_specs
    from shipradar.tables.store import inputs_hash

    d = yaml.safe_load((Path(__file__).resolve().parents[1] / "scenarios"
                        / "jammed_squall.yaml").read_text())
    base = parse_scenario(d)

    def keys(scene):
        return {(s.radar_id, s.kind): inputs_hash(*s.key()) for s in table_specs(scene)}

    ref = keys(base)
    for field, value in (("pd_method", "seed"), ("propagation", "two_ray"),
                         ("pe_grid", "standard"), ("improvement_grid", "coarse"),
                         ("clutter_fa_model", "weibull_median"), ("atmosphere", False),
                         ("sectors_per_scan", 4)):
        dd = copy.deepcopy(d)
        dd["fidelity"] = {**dd.get("fidelity", {}), field: value}
        for kind_key, key in keys(parse_scenario(dd)).items():
            kind = kind_key[1]
            if kind_key in ref and key != ref[kind_key]:
                assert field in fi.TABLE_CHOICES[kind], (kind, field)
