"""Scenario schema: every example validates; bad inputs get exact one-line messages, exit 2."""

import copy
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from shipradar.sim.cli import main
from shipradar.sim.world.scenario import ScenarioError, load_scenario, parse_scenario

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


def _jammer(power_w):
    return [{"id": "j1", "waypoints": [{"east_m": 0, "north_m": 1e5}], "power_w": power_w,
             "gain_db": 10, "bandwidth_hz": 1e7}]


#: (mutation of the raid scenario, the exact and only line printed for it)
BAD = [
    (lambda d: d["targets"][2]["waypoints"][0].__setitem__("altitude_m", -5),
     "targets[2].waypoints[0].altitude_m: must be >= 0, got -5"),
    (lambda d: d.__setitem__("duration_s", 0), "duration_s: must be > 0, got 0"),
    (lambda d: d.pop("origin"), "origin: is required"),
    (lambda d: d["origin"].__setitem__("lat_deg", 95), "origin.lat_deg: must be <= 89, got 95"),
    (lambda d: d.__setitem__("seed", -1), "seed: must be >= 0, got -1"),
    (lambda d: d.__setitem__("start_time", "yesterday"),
     "start_time: input should be a valid datetime or date, input is too short, got 'yesterday'"),
    (lambda d: d["platforms"][0]["radars"][0].__setitem__("polarisation", "H"),
     "platforms[0].radars[0].polarisation: is not a known field (check its spelling)"),
    (lambda d: d["platforms"][0]["radars"][1].__setitem__("polarization", "X"),
     "platforms[0].radars[1].polarization: must be one of 'H' or 'V', got 'X'"),
    (lambda d: d["platforms"][0]["radars"][0].__setitem__("frequency_hz", 2e11),
     "platforms[0].radars[0].frequency_hz: must be <= 100000000000, got 200000000000"),
    (lambda d: d["platforms"][0]["radars"][1].__setitem__("pulse_width_s", 1e-4),
     "platforms[0].radars[1]: prf_hz * pulse_width_s must be < 0.25 so that N_rc [72] > 2, "
     "got 0.5"),
    (lambda d: d["platforms"][0]["radars"][0].__setitem__("prf_hz", "fast"),
     "platforms[0].radars[0].prf_hz: input should be a valid number, unable to parse string "
     "as a number, got 'fast'"),
    (lambda d: d["platforms"][0]["radars"][0].__setitem__("stagger_prf_hz", [1000, -5]),
     "platforms[0].radars[0].stagger_prf_hz: each PRF must be in [50, 500000] Hz, got -5.0"),
    (lambda d: d["platforms"][0]["radars"][0].__setitem__(
        "pattern_el", {"type": "cosec2", "sidelobe_db": 20, "tilt_deg": 50}),
     "platforms[0].radars[0].pattern_el.tilt_deg: must be <= 45, got 50"),
    (lambda d: d["targets"][0]["rcs"].__setitem__("length_m", -1),
     "targets[0].rcs.length_m: must be > 0, got -1"),
    (lambda d: d["targets"][0]["rcs"].pop("diameter_m"), "targets[0].rcs.diameter_m: is required"),
    (lambda d: d["targets"][1].__setitem__("rcs", {"type": "foo"}),
     "targets[1].rcs: type must be one of 'constant', 'missile', 'table', got 'foo'"),
    (lambda d: d["targets"][0].__setitem__("swerling", 5),
     "targets[0].swerling: must be <= 4, got 5"),
    (lambda d: d["targets"][0].__setitem__("waypoints", []),
     "targets[0].waypoints: must have at least 1 item(s), got 0"),
    (lambda d: d["targets"][3]["waypoints"][1].__setitem__("time_s", 0),
     "targets[3].waypoints: waypoint times must increase strictly, got 281.0 then 0.0"),
    (lambda d: d["targets"][0]["waypoints"][0].update({"lat_deg": 44.0, "lon_deg": -63.0}),
     "targets[0].waypoints[0]: give either east_m and north_m, or lat_deg and lon_deg"),
    (lambda d: d["targets"][1].__setitem__("id", d["targets"][0]["id"]),
     "(top level): ids must be unique across platforms, radars, targets and jammers: "
     "'missile01' repeats"),
    (lambda d: d["environment"].__setitem__("duct", {"type": "height", "height_m": 100}),
     "environment.duct.height_m: must be <= 60, got 100"),
    (lambda d: d["environment"].__setitem__("sea_state", 12),
     "environment.sea_state: must be <= 9, got 12"),
    (lambda d: d["environment"].__setitem__(
        "rain", {"rate_mm_h": 4, "region": {"east_m": 0, "north_m": 0, "radius_m": -3}}),
     "environment.rain.region.radius_m: must be > 0, got -3"),
    (lambda d: d.__setitem__("jammers", _jammer(-1)), "jammers[0].power_w: must be > 0, got -1"),
    (lambda d: d.setdefault("fidelity", {}).__setitem__("sectors_per_scan", 0),
     "fidelity.sectors_per_scan: must be >= 4, got 0"),
]


@pytest.mark.parametrize("mutate,message", BAD, ids=[m for _, m in BAD])
def test_bad_input_message(mutate, message):
    d = _raid()
    mutate(d)
    with pytest.raises(ScenarioError) as exc:
        parse_scenario(d)
    assert exc.value.lines == [message]


def test_bad_files_exact_message_and_exit_2(tmp_path, capsys):
    """The catalogue as files through the command line: exit 2, exactly one line each."""
    for i, (mutate, message) in enumerate(BAD):
        d = _raid()
        mutate(d)
        f = tmp_path / f"bad{i}.yaml"
        f.write_text(yaml.safe_dump(d, sort_keys=False))
        assert main(["validate", str(f)]) == 2, message
        out = capsys.readouterr()
        assert out.err == f"{f}: {message}\n" and out.out == ""


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
        proc = subprocess.run([sys.executable, "-m", "shipradar.sim.cli", *argv],
                              capture_output=True,
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


def _laughs(levels: int = 9) -> str:
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for i in range(1, levels):
        refs = ", ".join([f"*a{i - 1}"] * 10)
        lines.append(f"a{i}: &a{i} [{refs}]")
    return "\n".join(lines) + "\n"


FILE_PROBLEMS = [
    (None, "cannot read (No such file or directory)"),
    ("dir", "cannot read (Is a directory)"),
    (b"", "(top level): must be a mapping, got NoneType"),
    (b"\xff\xfe bad", "not UTF-8 text"),
    (b"name: [unclosed", "not valid YAML at line 1, column 16: expected ',' or ']', but got "
                         "'<stream end>'"),
    (b"!!python/object/apply:os.system ['echo hi']",
     "not valid YAML at line 1, column 1: could not determine a constructor for the tag "
     "'tag:yaml.org,2002:python/object/apply:os.system'"),
    (b"#" * (4 * 1024 * 1024 + 1), "file is 4194305 bytes, must be <= 4194304"),
    (_laughs().encode(), "YAML aliases expand to more than 2000000 nodes"),
]


@pytest.mark.parametrize("content,message", FILE_PROBLEMS, ids=[m[:30] for _, m in FILE_PROBLEMS])
def test_bad_file_exact_message_and_exit_2(tmp_path, capsys, content, message):
    f = tmp_path / "s.yaml"
    if content == "dir":
        f.mkdir()
    elif content is not None:
        f.write_bytes(content)
    assert main(["validate", str(f)]) == 2
    out = capsys.readouterr()
    assert out.err == f"{f}: {message}\n" and out.out == ""


def test_aliases_within_the_limit_are_fine(tmp_path):
    d = _raid()
    text = yaml.safe_dump(d, sort_keys=False)
    f = tmp_path / "a.yaml"
    f.write_text(_laughs(3) + text)  # 1000 'lol's: an unknown key, reported as such
    with pytest.raises(ScenarioError) as exc:
        load_scenario(f)
    assert exc.value.lines == [
        "a0: is not a known field (check its spelling)",
        "a1: is not a known field (check its spelling)",
        "a2: is not a known field (check its spelling)"]
