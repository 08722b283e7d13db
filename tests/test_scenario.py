"""Scenario schema: every example validates; bad inputs get exact one-line messages, exit 2."""

import copy
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from sim.cli import main
from sim.scenario import ScenarioError, load_scenario, parse_scenario

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "scenarios").glob("*.yaml"))


def test_examples_exist():
    names = {p.stem for p in EXAMPLES}
    assert {"single_missile", "raid", "stress"} <= names


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_every_example_validates(path, capsys):
    assert main(["validate", str(path)]) == 0
    assert "valid" in capsys.readouterr().out


def test_raid_and_stress_sizes():
    raid = load_scenario(ROOT / "scenarios/raid.yaml")
    assert len(raid.targets) >= 20
    assert {t.kind for t in raid.targets} >= {"missile", "aircraft"}
    assert len(raid.platforms[0].radars) == 2
    bands = sorted(r.frequency_hz for _, r in raid.radars())
    assert bands[0] < 2e9 and 4e9 < bands[1] < 8e9  # L-band-like and C-band
    stress = load_scenario(ROOT / "scenarios/stress.yaml")
    assert len(stress.targets) >= 200 and stress.environment.sea_state >= 5


def test_generated_examples_are_current(tmp_path):
    """scenarios/raid.yaml and stress.yaml are exactly what scenarios/generate.py writes."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("gen", ROOT / "scenarios/generate.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    for name, doc in (("raid", gen.raid()), ("stress", gen.stress())):
        on_disk = yaml.safe_load((ROOT / f"scenarios/{name}.yaml").read_text())
        assert on_disk == yaml.safe_load(yaml.safe_dump(doc, sort_keys=False))


def _raid():
    return yaml.safe_load((ROOT / "scenarios/raid.yaml").read_text())


BAD = [
    (lambda d: d["targets"][2]["waypoints"][0].__setitem__("altitude_m", -5),
     "targets[2].waypoints[0].altitude_m: must be >= 0, got -5"),
    (lambda d: d.__setitem__("duration_s", 0), "duration_s: must be > 0, got 0"),
    (lambda d: d.pop("origin"), "origin: is required"),
    (lambda d: d["platforms"][0]["radars"][0].__setitem__("polarisation", "H"),
     "platforms[0].radars[0].polarisation: is not a known field (check its spelling)"),
    (lambda d: d["platforms"][0]["radars"][1].__setitem__("polarization", "X"),
     "platforms[0].radars[1].polarization: must be one of 'H' or 'V', got 'X'"),
    (lambda d: d["targets"][0]["rcs"].__setitem__("length_m", -1),
     "targets[0].rcs.length_m: must be > 0, got -1"),
    (lambda d: d["targets"][1].__setitem__("rcs", {"type": "foo"}),
     "targets[1].rcs: type must be one of 'constant', 'missile', 'table', got 'foo'"),
    (lambda d: d["environment"].__setitem__("duct", {"type": "height", "height_m": 100}),
     "environment.duct.height_m: must be <= 60, got 100"),
    (lambda d: d["targets"][3]["waypoints"][1].__setitem__("time_s", 0),
     "targets[3].waypoints: waypoint times must increase strictly"),
    (lambda d: d["platforms"][0]["radars"][0].__setitem__("frequency_hz", 2e11),
     "platforms[0].radars[0].frequency_hz: must be <= 100000000000, got 200000000000"),
    (lambda d: d["targets"][0].__setitem__("swerling", 5),
     "targets[0].swerling: must be <= 4, got 5"),
    (lambda d: d["platforms"][0]["radars"][1].__setitem__("pulse_width_s", 1e-4),
     "platforms[0].radars[1]: prf_hz * pulse_width_s must be < 0.25"),
    (lambda d: d["targets"][1].__setitem__("id", d["targets"][0]["id"]),
     "(top level): ids must be unique"),
    (lambda d: d["targets"][0]["waypoints"][0].update({"lat_deg": 44.0, "lon_deg": -63.0}),
     "targets[0].waypoints[0]: give either east_m and north_m, or lat_deg and lon_deg"),
    (lambda d: d["platforms"][0]["radars"][0].__setitem__("prf_hz", "fast"),
     "platforms[0].radars[0].prf_hz: input should be a valid number"),
]


@pytest.mark.parametrize("mutate,message", BAD, ids=[m for _, m in BAD])
def test_bad_input_message(mutate, message):
    d = _raid()
    mutate(d)
    with pytest.raises(ScenarioError) as exc:
        parse_scenario(d)
    assert any(line.startswith(message) for line in exc.value.lines), exc.value.lines


def test_several_problems_one_line_each():
    d = _raid()
    d["duration_s"] = -1
    d["targets"][0]["waypoints"][0]["altitude_m"] = -1
    d["environment"]["wind_speed_mps"] = 99
    with pytest.raises(ScenarioError) as exc:
        parse_scenario(d)
    assert len(exc.value.lines) == 3


def test_cli_bad_file_exit_2_and_nothing_run(tmp_path):
    d = _raid()
    d["targets"][2]["waypoints"][0]["altitude_m"] = -5
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(d))
    rec = tmp_path / "out.rec"
    for argv in (["validate", str(bad)], ["run", str(bad), "--record", str(rec)]):
        proc = subprocess.run([sys.executable, "-m", "sim.cli", *argv], capture_output=True,
                              text=True, cwd=ROOT, timeout=120)
        assert proc.returncode == 2
        assert "targets[2].waypoints[0].altitude_m: must be >= 0, got -5" in proc.stderr
    assert not rec.exists()


@pytest.mark.parametrize("text,expect", [
    ("name: [unclosed", "not valid YAML at line 1"),
    ("- just\n- a list\n", "(top level): must be a mapping"),
    ("!!python/object/apply:os.system ['echo hi']", "not valid YAML"),
])
def test_yaml_problems(tmp_path, text, expect):
    f = tmp_path / "s.yaml"
    f.write_text(text)
    with pytest.raises(ScenarioError) as exc:
        load_scenario(f)
    assert expect in exc.value.lines[0]


def test_oversized_file_rejected(tmp_path):
    f = tmp_path / "big.yaml"
    f.write_text("#" * (4 * 1024 * 1024 + 1))
    with pytest.raises(ScenarioError, match="must be <="):
        load_scenario(f)


def test_defaults_and_swerling():
    d = _raid()
    s = parse_scenario(d)
    missiles = [t for t in s.targets if t.kind == "missile"]
    assert all(t.swerling_case == 3 for t in missiles)  # seed 6.4: case 3 for missiles
    d2 = copy.deepcopy(d)
    d2["targets"][0]["swerling"] = 0
    assert parse_scenario(d2).targets[0].swerling_case == 0
