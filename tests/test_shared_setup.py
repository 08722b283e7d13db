"""What a run sets up from the radar and its tables alone is prepared once and shared by the
runs given the same preparation (issues 27 and 31: :class:`PreparedScene`, passed explicitly):
the P_fac generator (each run a twin that shares its arrays and per-thread scratch), the
clutter spectrum at its sectors and the two-ray fallback's terms. Sharing changes no draw:
twins draw as fresh generators, interleaved or in threads, and a scene run again in one
process, with the first run's preparation or on freshly loaded tables with a new one, gives
the same bytes.
"""

from __future__ import annotations

import hashlib
import threading

import numpy as np
import pytest

from shipradar.sim.dwell.prepared import PreparedScene
from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream.bus import Bus
from shipradar.sim.stream.recording import Recorder
from shipradar.sim.world.scenario import load_scenario
from shipradar.tables.scene import SceneTables, load_scene_tables
from tests.helpers import ROOT, random_clutter_generator

TWO_PI = 2.0 * np.pi


def _generator(seed=0, n=4000):
    rng = np.random.default_rng(seed)
    # Bernoulli (< 0.1725 for 2 channels), Poisson and a few normal (>= 9) sectors
    eta = rng.permutation(np.concatenate([rng.uniform(0.0, 0.17, n // 2),
                                          rng.uniform(0.18, 8.9, n // 3),
                                          rng.uniform(9.0, 30.0, 5)]))
    return random_clutter_generator(eta, rng)


def _scans(gen, seed, revolutions):
    rng = np.random.default_rng(seed)
    t_a = 2.0 * np.arange(revolutions)
    out = gen.scans(t_a, t_a + 2.0, rng.uniform(0.0, TWO_PI, revolutions), np.pi, rng)
    assert out is not None
    return {k: v.tobytes() for k, v in out.items()}, rng.bit_generator.state


def test_twins_draw_as_fresh_generators():
    template = _generator()
    twins = [template.shared(), template.shared()]
    # blocks of growing and shrinking sizes, the twins interleaved in one thread (the
    # scratch arrays are shared and re-used, their first rows only when a block is smaller)
    for seed, revolutions in ((1, 7), (2, 40), (3, 1), (4, 23), (5, 40)):
        want = _scans(_generator(), seed, revolutions)
        for twin in twins:
            assert _scans(twin, seed, revolutions) == want
    for a in (template.eta, template.r_min_m, template._hit_below, template._pois_cdf_cols,
              twins[0].weibull_a, twins[1]._spike_terms[0]):
        assert not a.flags.writeable
        assert any(a is b for b in (*vars(twins[0]).values(), *twins[0]._spike_terms))


def test_twins_in_threads_draw_as_fresh_generators():
    template = _generator(seed=1)
    want = {seed: _scans(_generator(seed=1), seed, 30) for seed in range(8)}
    got: dict[int, tuple] = {}

    def work(seed):
        twin = template.shared()
        for _ in range(3):
            got[seed] = _scans(twin, seed, 30)

    threads = [threading.Thread(target=work, args=(s,)) for s in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert got == want


def _recording(scenario, tables, path, prepared=None):
    bus = Bus(None, Recorder(path, overwrite=True))
    sim = Simulation(scenario, bus=bus, duration_s=30.0, tables=tables, prepared=prepared)
    sim.run()
    bus.close()
    return hashlib.sha256(path.read_bytes()).hexdigest(), sim


@pytest.mark.slow
def test_runs_given_one_preparation_share_its_set_up_and_give_the_same_bytes(tmp_path):
    sc = load_scenario(ROOT / "scenarios" / "single_missile.yaml")
    tables = load_scene_tables(sc)
    first, sim_a = _recording(sc, tables, tmp_path / "a.rec")  # prepares its own
    again, sim_b = _recording(sc, tables, tmp_path / "b.rec", prepared=sim_a.prepared)
    fresh, sim_c = _recording(sc, load_scene_tables(sc), tmp_path / "c.rec")
    assert first == again == fresh
    a, b, c = (s.radars[0].model for s in (sim_a, sim_b, sim_c))
    assert sim_b.prepared is sim_a.prepared and b.prepared is a.prepared
    assert a.false_alarms.generator is not b.false_alarms.generator  # a twin per run
    assert a.false_alarms.generator.eta is b.false_alarms.generator.eta  # its arrays shared
    assert a.false_alarms.sector_spectrum is b.false_alarms.sector_spectrum
    assert a._two_ray is b._two_ray and a._sea_reader is b._sea_reader
    # a run given no preparation makes its own: nothing kept by the process
    assert c.prepared is not a.prepared and c._two_ray is not a._two_ray
    assert c.false_alarms.generator.eta is not a.false_alarms.generator.eta


def test_a_preparation_is_for_its_own_scenario_and_tables():
    sc = load_scenario(ROOT / "scenarios" / "single_missile.yaml")
    tables = SceneTables()
    prepared = PreparedScene(sc, tables)
    sim = Simulation(sc, tables=tables, prepared=prepared, duration_s=1.0)
    assert sim.prepared is prepared
    assert sim.radars[0].model.prepared is prepared.radar(*next(iter(sc.radars())))
    with pytest.raises(ValueError, match="prepared: made for other scene tables"):
        Simulation(sc, tables=SceneTables(), prepared=prepared)
    other = load_scenario(ROOT / "scenarios" / "single_missile.yaml")  # equal, not the same
    with pytest.raises(ValueError, match="prepared: made for another scenario"):
        Simulation(other, tables=tables, prepared=prepared)


@pytest.mark.parametrize(("kind", "divisor"), [("rain", 1.0), ("dry_snow", 10.0),
                                               ("wet_snow", 5.0)])
def test_rain_loss_of_a_preparation_at_the_rain_equivalent_rate(kind, divisor):
    """γ_R [16] on the targets' paths is P.838 at the rain-equivalent rate (seed 4.1.4: dry
    snow ÷ 10, wet snow ÷ 5), the number the weather map's trips carry too."""
    from shipradar.sim.world.scenario import Rain
    from shipradar.tables.scene import weather_rain_attenuation_db_per_km
    from shipradar.tables.sky import rain_attenuation_db_per_km

    sc = load_scenario(ROOT / "scenarios" / "single_missile.yaml")
    env = sc.environment.model_copy(update={"rain": Rain(kind=kind, rate_mm_h=20.0)})
    sc = sc.model_copy(update={"environment": env})
    platform, radar = next(iter(sc.radars()))
    gamma = PreparedScene(sc, SceneTables()).radar(platform, radar).rain_gamma_db_per_km
    assert gamma == rain_attenuation_db_per_km(radar.frequency_hz, 20.0 / divisor,
                                               radar.polarization)
    assert gamma == weather_rain_attenuation_db_per_km(sc, radar) > 0.0
