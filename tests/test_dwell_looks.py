"""The dwell model's look hook (``DwellModel.on_look``) and what reads it."""

from __future__ import annotations

import numpy as np
import pytest

from shipradar.sim.studies import montecarlo as mc
from shipradar.sim.world.scenario import Scenario, load_scenario

from .helpers import ROOT

#: |ΔP_d| allowed between methods on one look: the table is within 4.6e-4 of the exact P_d
#: (docs/accuracy.md); the seed's approximation [78]-[83] is 0.033 from it at worst here.
PD_TOL = {"table": 5e-4, "seed": 0.05}


def _with_pd_method(scenario: Scenario, method: str) -> Scenario:
    data = scenario.model_dump(mode="python")
    data["fidelity"]["pd_method"] = method
    return Scenario.model_validate(data)


def test_model_pd_looks_sees_every_pd_method():
    """The recorder reads the look hook, so every P_d method is seen (the former swap of the
    dwell model's ``detection`` module saw nothing under ``pd_method: table``)."""
    sc = load_scenario(ROOT / "scenarios" / "single_missile.yaml")
    looks = {m: mc.model_pd_looks(_with_pd_method(sc, m), duration_s=120.0)
             for m in ("exact", "seed", "table")}
    exact = looks["exact"]
    assert len(exact) > 50
    pd_exact = np.array([r["pd"] for r in exact])
    # enough looks between certain miss and certain detection to compare the methods
    assert np.count_nonzero((pd_exact > 0.05) & (pd_exact < 0.95)) >= 10
    for method in ("seed", "table"):
        rows = looks[method]
        assert len(rows) == len(exact), method
        assert [(r["target"], r["scan"]) for r in rows] == \
            [(r["target"], r["scan"]) for r in exact], method
        pd = np.array([r["pd"] for r in rows])
        assert np.all((pd >= 0.0) & (pd <= 1.0))
        assert np.max(np.abs(pd - pd_exact)) == pytest.approx(0.0, abs=PD_TOL[method]), method


def test_on_look_reports_every_look_of_a_run():
    """Every call's LookResults: one element per crossing, the contacts' detections are the
    run's target plots, each interference as counted by the engine, S/I in dB its own."""
    from shipradar.sim.dwell.look import LookResults
    from shipradar.sim.engine.simulation import Simulation

    sc = load_scenario(ROOT / "scenarios" / "jammed_squall.yaml")
    sim = Simulation(sc, duration_s=20.0, seed=7)
    seen: list[LookResults] = []
    for rp in sim.radars:
        rp.model.on_look.append(seen.append)
    sim.run()
    assert seen
    assert sum(lk.size for lk in seen) == sim.stats.dwells
    plots = 0
    by_code = np.zeros(3, dtype=int)
    for lk in seen:
        for name in ("time_s", "f", "received_power_w", "clutter_w", "jamming_w", "si", "pd",
                     "n_e", "hit", "interference", "contact", "merged"):
            assert getattr(lk, name).shape == (lk.size,), name
        assert np.all((lk.pd >= 0.0) & (lk.pd <= 1.0))
        assert np.all(lk.n_e >= 1.0)
        assert lk.si_db == pytest.approx(10.0 * np.log10(lk.si), rel=1e-12, abs=1e-9)
        model = next(rp.model for rp in sim.radars if rp.radar.id == lk.radar)
        assert np.all(lk.noise_w == model.n0)
        # one row per contact: its detection and its dominant interference
        _, first = np.unique(lk.contact, return_index=True)
        plots += int(np.count_nonzero(lk.hit[first]))
        by_code += np.bincount(lk.interference[first][lk.hit[first]], minlength=3)
    assert plots == sim.stats.target_plots > 0
    assert by_code.tolist() == [sim.stats.by_interference[n]
                                for n in ("noise", "clutter", "jamming")]
    # the scene's squall and jammer reach the looks
    assert max(float(lk.clutter_w.max()) for lk in seen) > 0.0
    assert max(float(lk.jamming_w.max()) for lk in seen) > 0.0
