"""Issue 23, item 1: every scene that validates runs; the rest is refused by `validate`.

Each failure mode of the issue's two tables has its own regression test. A refused scene:
exit 2 from both ``validate`` and ``run``, one line naming the field, the value and the
reason, and nothing built. A scene just inside the rule runs to the end with finite plots.
"""

from __future__ import annotations

import copy
import json
import math
import warnings

import numpy as np
import pytest
import yaml

from shipradar.sim.cli import main
from shipradar.sim.stream.protocol import decode
from shipradar.sim.stream.recording import read_recording, verify_recording
from shipradar.sim.world.scenario import ScenarioError, parse_scenario

from .helpers import example

BASE = example("single_missile")


def _scene(radar: dict | None = None, *, processor: dict | None = None, duration_s: float = 3.0,
           **fidelity) -> dict:
    d = copy.deepcopy(BASE)
    d["duration_s"] = duration_s
    r = d["platforms"][0]["radars"][0]
    r.update(radar or {})
    if processor is not None:
        r["processor"] = processor
    d["fidelity"] = {"propagation": "two_ray", **fidelity}
    return d


def _refusal(data: dict) -> str:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(data)
    assert len(info.value.lines) == 1, info.value.lines
    return info.value.lines[0]


def _write(tmp_path, data: dict):
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _cli_refuses(tmp_path, capsys, data: dict, field: str) -> str:
    """validate and run both exit 2 with the same single line, and build nothing."""
    path = _write(tmp_path, data)
    assert main(["validate", str(path)]) == 2
    err_validate = capsys.readouterr().err
    assert main(["run", str(path), "--record", str(tmp_path / "x.rec")]) == 2
    err_run = capsys.readouterr().err
    assert err_validate == err_run
    assert err_run.count("\n") == 1 and "Traceback" not in err_run
    assert f"{field}: " in err_run
    assert not (tmp_path / "x.rec").exists()
    assert not any((tmp_path / "tables").rglob("*.np*"))
    return err_run


def _runs_clean(tmp_path, capsys, data: dict) -> dict:
    """run exits 0, stderr without traceback or warning, plots finite, recording clean."""
    path = _write(tmp_path, data)
    rec = tmp_path / "run.rec"
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        code = main(["run", str(path), "--record", str(rec), "--overwrite"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "Traceback" not in err and "Warning" not in err
    summary = json.loads(out.strip().splitlines()[-1])
    assert summary["scans"] >= 1
    assert verify_recording(rec)["status"] == "clean"
    with read_recording(rec) as reader:
        messages = [decode(frames) for _, frames in reader]
    for topic, _, cols in messages:
        if topic != b"plots":
            continue
        for name in ("range_m", "azimuth_rad", "time_s", "snr_db", "sigma_range_m",
                     "sigma_azimuth_rad"):
            assert np.all(np.isfinite(np.asarray(cols[name], dtype=float))), name
        az = np.asarray(cols["azimuth_rad"])
        assert np.all((az >= 0) & (az < 2 * math.pi))
        assert np.all(np.asarray(cols["sigma_range_m"]) > 0)
        assert np.all(np.asarray(cols["sigma_azimuth_rad"]) > 0)
    return summary


@pytest.fixture(autouse=True)
def _private_tables(table_cache):
    return table_cache


# -- fewer than one pulse per beamwidth [73] -------------------------------------------------
@pytest.mark.parametrize("radar", [
    {"beamwidth_az_deg": 0.05 * (1 + 1e-6)},  # just above its bound: 0.69 pulses
    {"prf_hz": 50},  # 0.25 pulses
    {"rotation_rpm": 120, "beamwidth_az_deg": 1.8, "prf_hz": 360},  # 0.9 pulses
])
def test_fewer_than_one_pulse_per_beamwidth_is_refused(tmp_path, capsys, radar):
    err = _cli_refuses(tmp_path, capsys, _scene(radar), "platforms[0].radars[0].prf_hz")
    assert "fewer than one pulse per beamwidth" in err
    # the least PRF named is the one that gives one pulse: 6 rpm / beamwidth [Hz]
    r = {**BASE["platforms"][0]["radars"][0], **radar}
    need = math.ceil(6 * r["rotation_rpm"] / r["beamwidth_az_deg"] - 1e-9)
    assert f"needs prf_hz >= {need} " in err


@pytest.mark.parametrize("radar", [
    {"rotation_rpm": 120, "beamwidth_az_deg": 1.8, "prf_hz": 400},
    {"rotation_rpm": 90, "beamwidth_az_deg": 0.9, "prf_hz": 600},
    {"prf_hz": 50},
])
def test_schema_pulses_per_beam_rule_is_the_physics_one(radar):
    """scenario.Radar checks N_n [73] with sensors.geometry.pulses_per_beam (issue 31): its
    bound is N_n >= 1 (to the schema's slack)."""
    from shipradar.sensors.detection import pulses_per_beam
    from shipradar.sim.world.scenario import PULSES_PER_BEAM_ULP

    r = {**BASE["platforms"][0]["radars"][0], **radar}
    n_n = float(pulses_per_beam(math.radians(r["beamwidth_az_deg"]),
                                60.0 / r["rotation_rpm"], r["prf_hz"]))
    if n_n >= 1.0 - PULSES_PER_BEAM_ULP:
        parse_scenario(_scene(radar))
    else:
        with pytest.raises(ScenarioError, match="fewer than one pulse per beamwidth"):
            parse_scenario(_scene(radar))


@pytest.mark.parametrize("radar", [
    {"rotation_rpm": 120, "beamwidth_az_deg": 1.8, "prf_hz": 400},  # exactly 1.0
    {"rotation_rpm": 90, "beamwidth_az_deg": 0.9, "prf_hz": 600},  # 1 - 1.1e-16 by rounding
])
def test_exactly_one_pulse_per_beamwidth_runs(tmp_path, capsys, radar):
    _runs_clean(tmp_path, capsys, _scene(radar, duration_s=2.0))


# -- the PE table's top and the antenna --------------------------------------------------------
def test_antenna_above_the_highest_target_runs_with_pe(tmp_path, capsys):
    d = _scene({"antenna_height_m": 200, "instrumented_range_m": 20000}, duration_s=2.0,
               propagation="pe", pe_grid="coarse")
    _runs_clean(tmp_path, capsys, d)


def test_pe_table_top_covers_antenna_and_targets():
    from shipradar.tables.scene import PE_MAX_HEIGHT_M, pe_table_height_m

    s = parse_scenario(_scene({"antenna_height_m": 200}))
    radar = s.platforms[0].radars[0]
    assert pe_table_height_m(s, radar) == pytest.approx(1.2 * 200 + 20, rel=1e-12)
    s = parse_scenario(_scene({"antenna_height_m": 101}))  # sea-skimmer at 5 m
    assert pe_table_height_m(s, s.platforms[0].radars[0]) > 101
    d = _scene()
    d["targets"][0]["waypoints"][0]["altitude_m"] = 5000
    s = parse_scenario(d)
    assert pe_table_height_m(s, s.platforms[0].radars[0]) == PE_MAX_HEIGHT_M


# -- cosec² tilt against the elevation beamwidth [14] ------------------------------------------
def test_cosec2_junction_below_horizon_is_refused(tmp_path, capsys):
    d = _scene({"pattern_el": {"type": "cosec2", "sidelobe_db": 20, "tilt_deg": -10}})
    err = _cli_refuses(tmp_path, capsys, d, "platforms[0].radars[0].pattern_el.tilt_deg")
    assert "must be > -10 with beamwidth_el_deg 20, got -10" in err


def test_cosec2_junction_just_above_horizon_runs(tmp_path, capsys):
    d = _scene({"pattern_el": {"type": "cosec2", "sidelobe_db": 20, "tilt_deg": -9.9}},
               duration_s=2.0)
    _runs_clean(tmp_path, capsys, d)


def test_negative_tilt_of_other_patterns_is_fine():
    parse_scenario(_scene({"pattern_el": {"type": "sinc", "sidelobe_db": 20, "tilt_deg": -10}}))


# -- the processor's counts and window ------------------------------------------------------
@pytest.mark.parametrize(("processor", "field", "words"), [
    ({"type": "mti_bank", "mti_order": 6, "n_coherent": 2}, "processor.n_coherent",
     "n_coherent must be > mti_order, got n_coherent 2, mti_order 6"),
    ({"type": "mti_bank", "mti_order": 2, "n_coherent": 2}, "processor.n_coherent",
     "n_coherent must be > mti_order"),
    ({"type": "dft_bank", "n_coherent": 2, "n_filters": 256}, "processor.n_filters",
     "a DFT bank has as many filters as taps (n_coherent 2)"),
    ({"type": "dft_bank", "n_coherent": 256, "n_filters": 1}, "processor.n_filters",
     "got 1"),
    ({"type": "dft_bank", "n_coherent": 2}, "processor.window.type", "2-tap Hann"),
    ({"type": "fir_bank", "n_coherent": 2}, "processor.window.type", "2-tap Hann"),
    ({"type": "mti_bank", "mti_order": 1, "n_coherent": 3}, "processor.window.type",
     "n_coherent >= 4"),
])
def test_processor_rules_are_refused(tmp_path, capsys, processor, field, words):
    err = _cli_refuses(tmp_path, capsys, _scene(processor=processor),
                       f"platforms[0].radars[0].{field}")
    assert words in err


@pytest.mark.parametrize("processor", [
    {"type": "dft_bank", "n_coherent": 2, "window": {"type": "hamming"}},
    {"type": "fir_bank", "n_coherent": 3},  # Hann [0, 1, 0]: one pulse weighted, still finite
    {"type": "dft_bank", "n_coherent": 4, "n_filters": 4},
    {"type": "mti_bank", "mti_order": 6, "n_coherent": 7, "window": {"type": "rectangular"}},
    {"type": "fir_bank", "n_coherent": 2, "n_filters": 16, "window": {"type": "taylor"}},
])
def test_processor_just_inside_the_rules_runs(tmp_path, capsys, processor):
    _runs_clean(tmp_path, capsys, _scene(processor=processor, duration_s=2.0))


def test_hann_window_of_two_taps_is_all_zero():
    """The reason for the rule, from scipy itself: nothing of ours in between."""
    from scipy.signal.windows import hann

    assert np.all(hann(2, sym=True) == 0.0)
    assert np.any(hann(3, sym=True) > 0.0)


# -- a false-alarm time shorter than one sweep's decisions [68]-[72] -------------------------
_SHORT_TFA = {"false_alarm_time_s": 0.1, "beamwidth_az_deg": 20, "rotation_rpm": 0.6,
              "prf_hz": 249, "pulse_width_s": 1e-3, "transmitted_pulse_width_s": None,
              "n_channels": 1}


def test_false_alarm_time_below_one_per_decision_is_refused(tmp_path, capsys):
    err = _cli_refuses(tmp_path, capsys, _scene(_SHORT_TFA),
                       "platforms[0].radars[0].false_alarm_time_s")
    assert "must be > 13.9 s, got 0.1" in err


@pytest.mark.parametrize("radar", [
    _SHORT_TFA,
    {**_SHORT_TFA, "pulse_width_s": 1e-6, "prf_hz": 50, "n_channels": 3},
    {"false_alarm_time_s": 0.1, "beamwidth_az_deg": 20, "rotation_rpm": 0.6},
])
def test_schema_false_alarm_time_bound_is_the_physics_one(radar):
    """Just above the schema's least t_fa, P_fa of [68]-[72] is < 1; just below, >= 1."""
    from shipradar.sensors.detection import pfa_from_false_alarm_time

    base = {**BASE["platforms"][0]["radars"][0], **radar}
    d = _scene(radar)
    try:
        parse_scenario(d)
        line = None
    except ScenarioError as exc:
        line = exc.lines[0]
    t_swp = math.radians(base["beamwidth_az_deg"]) / (2 * math.pi) * 60 / base["rotation_rpm"]
    args = (t_swp * 2 * math.pi / math.radians(base["beamwidth_az_deg"]),)

    def pfa(t_fa: float) -> float:
        return float(pfa_from_false_alarm_time(
            t_fa, math.radians(base["beamwidth_az_deg"]), *args, base["prf_hz"],
            base["pulse_width_s"], n_channels=base.get("n_channels", 2),
            instrumented_range_m=base["instrumented_range_m"]))

    if line is None:  # accepted: the physics agrees
        assert 0 < pfa(base["false_alarm_time_s"]) < 1
        return
    t_min = float(line.split("must be > ")[1].split(" s,")[0])
    above = dict(radar, false_alarm_time_s=t_min * 1.01)
    parse_scenario(_scene(above))
    assert 0 < pfa(t_min * 1.01) < 1
    with pytest.raises(ValueError, match="must be in"):
        pfa(t_min * 0.99)
    with pytest.raises(ScenarioError):
        parse_scenario(_scene(dict(radar, false_alarm_time_s=t_min * 0.99)))


# -- found by the extremes campaign (tests/extremes.py) --------------------------------------
def test_climb_from_rest_is_refused_not_divided_by_zero(tmp_path, capsys):
    d = _scene()
    d["targets"][0] = {"id": "m", "kind": "missile", "heading_deg": 0, "speed_mps": 0,
                       "waypoints": [{"east_m": 5000, "north_m": 0, "altitude_m": 5}],
                       "segments": [{"type": "climb", "to_altitude_m": 200, "duration_s": 10}],
                       "rcs": {"type": "constant", "sigma_m2": 1.0}}
    err = _cli_refuses(tmp_path, capsys, d, "targets[0].segments[0].duration_s")
    assert "needs a path speed > 0" in err


def test_receiver_without_noise_is_refused(tmp_path, capsys):
    d = _scene({"antenna_temperature_k": 0.0, "noise_figure_db": 0.0, "loss_tr_db": 0.0})
    err = _cli_refuses(tmp_path, capsys, d, "platforms[0].radars[0].antenna_temperature_k")
    assert "T_s = 0 K" in err


def test_receiver_with_one_noise_source_runs(tmp_path, capsys):
    d = _scene({"antenna_temperature_k": 0.0, "noise_figure_db": 0.0, "loss_tr_db": 0.01},
               duration_s=2.0)
    _runs_clean(tmp_path, capsys, d)


def test_opaque_jammer_path_is_held_finite(tmp_path, capsys):
    """A jammer 2800 km away at 100 GHz in fog: over 3000 dB of one-way loss, held at
    MAX_ATMOSPHERIC_LOSS_DB (10^(x/10) overflowed), and so no jamming at all."""
    d = _scene({"frequency_hz": 1e11}, duration_s=2.0)
    d["environment"]["fog"] = {"liquid_water_g_m3": 1.0}
    d["jammers"] = [{"id": "j", "waypoints": [{"east_m": -2e6, "north_m": 2e6,
                                               "altitude_m": 3000}],
                     "power_w": 1e6, "gain_db": 40, "bandwidth_hz": 1e8}]
    summary = _runs_clean(tmp_path, capsys, d)
    assert summary["dominant_interference"]["jamming"] == 0


def test_pfac_sector_edges_never_below_zero_range():
    """R_inst = 6931.684596912009 m put the first ground-range edge at -3.6e-15 m."""
    from shipradar.tables.pfac import sector_edges
    from shipradar.tables.store import Table

    n = 37
    step = 6931.684596912009 / n
    centres = (np.arange(n) + 0.5) * step
    table = Table("pfac", 1, (centres, np.linspace(0, 2 * np.pi, 10)),
                  ("ground_range_m", "azimuth_rad"), ("m", "rad"), np.zeros((n, 10)),
                  "p_fac", "1")
    edges, _ = sector_edges(table)
    assert edges[0] == 0.0 and np.all(np.diff(edges) > 0)


def test_instrumented_range_with_a_rounding_edge_runs(tmp_path, capsys):
    d = _scene({"instrumented_range_m": 6931.684596912009}, duration_s=2.0)
    _runs_clean(tmp_path, capsys, d)
