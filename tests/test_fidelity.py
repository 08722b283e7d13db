"""``shipradar fidelity`` (sim/studies/fidelity.py, issue 18): common random numbers, the
comparison,
the recommendation and its tolerances, --apply, bad input, and ``validate --explain``.

Scenes are small (one X-band radar, 1 s scans, a few tens of seconds, one or two targets)
and share one private table cache for the module.
"""

from __future__ import annotations

import copy
import os

import numpy as np
import pytest
import yaml

from shipradar.sim.studies import fidelity as fi
from shipradar.sim.world.scenario import load_scenario, parse_scenario
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


@pytest.fixture(scope="module")
def ducted_study():
    return fi.run_fidelity_study(parse_scenario(DUCTED))


@pytest.fixture(scope="module")
def lit_study():
    return fi.run_fidelity_study(parse_scenario(LIT))


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
    clock = fi._TableClock()
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
    clock = fi._TableClock()
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
def test_recommendation_applied_and_rerun_is_inside_its_tolerances(ducted_study, tmp_path):
    study = ducted_study
    path = tmp_path / "ducted.yaml"
    path.write_text(yaml.safe_dump(DUCTED, sort_keys=False))
    out = tmp_path / "ducted-fast.yaml"
    fi.apply_fidelity(path, study.recommended, out)
    applied = load_scenario(out)
    assert applied.fidelity.model_dump() == fi.Fidelity(**study.recommended).model_dump()
    assert applied.targets == parse_scenario(DUCTED).targets
    s = parse_scenario(DUCTED)
    clock = fi._TableClock()
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
def test_recommendation_obeys_tolerances_and_is_the_cheapest(ducted_study):
    study = ducted_study
    rc = study.recommended_comparison
    assert rc is not None and rc.ok
    assert rc.result.setting.fidelity == study.recommended
    # no admissible alternative left out is cheaper, by the noise margin, than the value
    # the recommendation kept (unless the combination check sent that choice back)
    for c in study.comparisons:
        s = c.result.setting
        if s.kind == "alternative" and c.ok and study.recommended[s.choice] != s.value:
            kept = study.recommended[s.choice]
            kept_cost = (_comp(study, "reference").cost_s if kept == study.reference[s.choice]
                         else _comp(study, f"{s.choice}={fi._fmt(kept)}").cost_s)
            assert c.cost_s >= kept_cost - study.cost_margin_s or any(
                s.choice in n for n in study.notes)
    # violations make a setting inadmissible, and are reported
    bad = [c for c in study.comparisons if not c.ok]
    assert bad and all(c.violations for c in bad)


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
    assert fi.Fidelity(**yaml.safe_load(block)["fidelity"]).model_dump() == \
        fi.Fidelity(**lit_study.recommended).model_dump()
    per = fi.format_per_target(lit_study)
    assert "xr/high" in per and per.count("\n") == sum(len(c.rows) for c in lit_study.comparisons)
    fi.write_csv(lit_study, tmp_path / "f.csv")
    import csv

    rows = list(csv.DictReader(open(tmp_path / "f.csv", encoding="utf-8")))
    assert {r["setting"] for r in rows} >= {"reference", "propagation=two_ray"}
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
    fid = {**fi.Fidelity().model_dump(), "propagation": "two_ray"}
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
    assert fi._expected_first_range(np.array([1.0, 0.5]), np.array([10.0, 9.0])) == (10.0, 1.0)
    assert fi._expected_first_range(np.zeros(3), np.array([3.0, 2.0, 1.0]))[0] is None
    # two looks at 0.5: first at look 1 with 0.5, at look 2 with 0.25
    r, p = fi._expected_first_range(np.array([0.5, 0.5]), np.array([10.0, 8.0]))
    assert p == pytest.approx(0.75, abs=1e-15)
    assert r == pytest.approx((0.5 * 10 + 0.25 * 8) / 0.75, rel=1e-12)
