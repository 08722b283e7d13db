"""A scene builds only the tables it reads (SPEC §2), and finds them again in the cache."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from shipradar.sim.world.scenario import parse_scenario
from shipradar.tables import scene as scene_mod
from shipradar.tables.scene import build_scene_tables, load_scene_tables, table_specs
from shipradar.tables.store import inputs_hash
from tests.helpers import bare_scene, example, quiet_radar


def _kinds(scenario) -> set[tuple[str, str]]:
    return {(s.radar_id, s.kind) for s in table_specs(scenario)}


def _with(data: dict, **env) -> dict:
    d = copy.deepcopy(data)
    d.setdefault("environment", {}).update(env)
    return d


def test_quiet_scene_needs_no_table():
    # free space, no clutter, no atmosphere, no processor: nothing off-line at all
    assert table_specs(bare_scene()) == []


def test_each_fidelity_switch_adds_exactly_its_table():
    r = quiet_radar(processor={"type": "mti", "mti_order": 2})
    assert _kinds(bare_scene(r, atmosphere=True)) == {("r1", "atmosphere")}
    assert _kinds(bare_scene(r, propagation="pe")) == {("r1", "propagation")}
    assert _kinds(bare_scene(r, propagation="two_ray")) == set()
    # clutter on: sea map, the processor's I_F table; this radar (1 µs, 2°: X = 2 °·µs) is
    # medium resolution, so its P_fac map too
    assert _kinds(bare_scene(r, clutter=True)) == {
        ("r1", "sea_clutter"), ("r1", "improvement"), ("r1", "pfac")}


def test_no_processor_no_improvement_table_low_resolution_no_pfac():
    low = quiet_radar(pulse_width_s=5e-6)  # τ' ≥ 4 µs: low resolution, clutter is Rayleigh
    assert _kinds(bare_scene(low, clutter=True)) == {("r1", "sea_clutter")}


def test_weather_map_only_when_it_rains():
    data = example("single_missile")
    dry = _kinds(parse_scenario(data))
    assert not any(k == "weather_clutter" for _, k in dry)
    wet = _kinds(parse_scenario(_with(data, rain={"rate_mm_h": 4.0})))
    assert wet - dry == {("giraffe", "weather_clutter")}


def test_every_radar_of_the_raid_gets_its_own_tables():
    specs = table_specs(parse_scenario(example("raid")))
    radars = {s.radar_id for s in specs}
    assert len(radars) == 2
    for r in radars:
        kinds = {s.kind for s in specs if s.radar_id == r}
        assert {"atmosphere", "sea_clutter", "propagation"} <= kinds


def test_pe_table_reaches_the_highest_target_or_jammer(monkeypatch):
    """The PE table's top follows whichever flies highest, targets or jammers."""
    seen = []

    def fake_table(**kw):
        seen.append(kw["max_height_m"])
        raise _Stop

    class _Stop(Exception):
        pass

    import shipradar.tables.propagation as tp
    monkeypatch.setattr(tp, "get_propagation_table", fake_table)

    def target(alt):
        return {"id": "t", "waypoints": [{"east_m": 9000, "north_m": 0, "altitude_m": alt}],
                "rcs": {"type": "constant", "sigma_m2": 1.0}}

    def jammer(alt):
        return {"id": "j", "waypoints": [{"east_m": 40000, "north_m": 0, "altitude_m": alt}],
                "power_w": 100, "gain_db": 10, "bandwidth_hz": 1e8}

    cases = (([target(50)], [], 50), ([target(50)], [jammer(800)], 800),
             ([target(800)], [jammer(50)], 800), ([], [], 0))
    for targets, jammers, top in cases:
        d = bare_scene(targets=targets, propagation="pe").model_dump(mode="json")
        (spec,) = table_specs(parse_scenario({**d, "jammers": jammers}))
        with pytest.raises(_Stop):
            spec.make()
        expect = 1.2 * top + 20
        assert seen[-1] == pytest.approx(max(100.0, expect), rel=1e-12)


def test_build_then_run_reads_the_same_files(table_cache):
    """`tables build` ahead of a run and the run itself agree on every key (cache hit)."""
    s = bare_scene(quiet_radar(processor={"type": "mti", "mti_order": 1}), clutter=True,
                   atmosphere=True)
    report = build_scene_tables(s, log=None)
    files = {row["file"] for row in report["tables"]}
    assert len(files) == len(report["tables"]) >= 3
    mtimes = {f: (table_cache / f.rsplit("/", 1)[1]).stat().st_mtime_ns for f in files}
    loaded = load_scene_tables(s)
    tables = loaded.for_radar("r1")
    for row in report["tables"]:
        t = getattr(tables, row["kind"])
        assert t is not None and t.key == row["key"]
    # nothing was rebuilt: the files are untouched
    assert {f: (table_cache / f.rsplit("/", 1)[1]).stat().st_mtime_ns for f in files} == mtimes


def test_key_follows_the_inputs_not_the_order():
    a = inputs_hash("x", 1, {"f_hz": 5.6e9, "h_m": 25.0, "axis": np.arange(3.0)})
    b = inputs_hash("x", 1, {"axis": [0.0, 1.0, 2.0], "h_m": 25.0, "f_hz": 5.6e9})
    assert a == b
    assert inputs_hash("x", 1, {"f_hz": 5.6e9, "h_m": 25.000001, "axis": [0, 1, 2]}) != a
    assert inputs_hash("x", 2, {"f_hz": 5.6e9, "h_m": 25.0, "axis": [0, 1, 2]}) != a


def test_duct_height_given_or_from_bulk_model():
    data = example("single_missile")
    assert scene_mod.duct_height_m(parse_scenario(data)) == 10.0
    bulk = _with(data, duct={"type": "bulk", "air_temperature_c": 20.0,
                             "sea_temperature_c": 22.0, "relative_humidity": 0.7})
    h = scene_mod.duct_height_m(parse_scenario(bulk))
    # unstable air, 7 m/s wind, 70 % humidity: a typical open-ocean duct of several metres
    assert 3.0 < h < 30.0
    assert scene_mod.refractivity_profile(parse_scenario(bulk)) == {
        "kind": "evaporation", "duct_height_m": h}
    calm = _with(data, duct=None)
    assert scene_mod.refractivity_profile(parse_scenario(calm)) == {"kind": "standard"}


# a surface-based duct: M falls 20 M units over the first 150 m, standard above
SURFACE_DUCT = {"type": "profile", "heights_m": [0.0, 150.0, 1000.0],
                "m_units": [330.0, 310.0, 310.0 + 0.118 * 850.0]}
# an elevated duct: trapping layer 800-850 m, its minimum above M(0)
ELEVATED_DUCT = {"type": "profile", "heights_m": [0.0, 800.0, 850.0, 2000.0],
                 "m_units": [330.0, 424.4, 404.4, 404.4 + 0.118 * 1150.0]}


def test_profile_duct_reaches_the_pe_table_and_the_clutter_horizon():
    data = example("single_missile")
    surface = parse_scenario(_with(data, duct=SURFACE_DUCT))
    assert scene_mod.refractivity_profile(surface) == {
        "kind": "piecewise", **{k: SURFACE_DUCT[k] for k in ("heights_m", "m_units")}}
    assert scene_mod.duct_height_m(surface) == 150.0
    assert scene_mod.duct_height_m(parse_scenario(_with(data, duct=ELEVATED_DUCT))) == 0.0


@pytest.mark.parametrize(("duct", "line"), [
    ({**SURFACE_DUCT, "heights_m": [5.0, 150.0, 1000.0]},
     "environment.duct: heights_m must start at 0 (the sea surface), got 5.0"),
    ({**SURFACE_DUCT, "heights_m": [0.0, 150.0, 150.0]},
     "environment.duct: heights_m must increase strictly, got 150.0 then 150.0"),
    ({**SURFACE_DUCT, "m_units": [330.0, 310.0]},
     "environment.duct: m_units must have as many points as heights_m (3), "
     "got 2"),
    ({**SURFACE_DUCT, "m_units": [330.0, -1.0, 400.0]},
     "environment.duct.m_units[1]: must be >= 0, got -1"),
])
def test_bad_profile_gets_one_clear_line(duct, line):
    from shipradar.sim.world.scenario import ScenarioError

    with pytest.raises(ScenarioError) as err:
        parse_scenario(_with(example("single_missile"), duct=duct))
    assert line in err.value.lines


def test_surface_duct_profile_traps_beyond_the_horizon(table_cache):
    """Through the scene to the PE table: a 150 m surface duct lifts F far past the horizon."""
    from shipradar.tables.propagation import propagation_factor

    data = _with(example("single_missile"), duct=SURFACE_DUCT)
    data["fidelity"] = {"pe_grid": "coarse", "clutter": False, "atmosphere": False}
    f_db = {}
    for name, duct in (("standard", None), ("duct", SURFACE_DUCT)):
        (spec,) = table_specs(parse_scenario(_with(data, duct=duct)))
        table = spec.make()
        assert table.inputs["profile"]["kind"] == ("piecewise" if duct else "standard")
        f = propagation_factor(table, np.array([50e3]), np.array([20.0]))
        f_db[name] = 20 * np.log10(f[0])
    # 25 m antenna and 20 m target: the smooth-earth horizon is ~39 km, 50 km is deep in the
    # diffraction region (tens of dB down); a trapping layer this strong keeps F near 0 dB
    assert f_db["standard"] < -25.0
    assert f_db["duct"] > f_db["standard"] + 20.0
