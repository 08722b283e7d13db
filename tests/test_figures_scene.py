"""Smoke and content tests of the scenario figures behind ``shipradar plot``
(shipradar.sim.studies.figures.scene)."""

from pathlib import Path

import numpy as np
import pytest

from shipradar.sim.studies.figures import scene as figs
from shipradar.sim.world.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def single_missile():
    return load_scenario(SCENARIOS / "single_missile.yaml")


def test_clutter_and_improvement_figures(tmp_path, table_cache, single_missile):
    written = figs.render(single_missile, "clutter", tmp_path)
    names = {p.name for p in written}
    assert {
        "fig6_seed_ducting_reflectivity.png",
        "giraffe_ducting_reflectivity.png",
        "giraffe_sea_clutter_ppi.png",
        "giraffe_sea_clutter_weibull_a_ppi.png",
    } <= names
    written += figs.render(single_missile, "improvement", tmp_path, radar_id="giraffe")
    assert "giraffe_improvement_vs_doppler.png" in {p.name for p in written}
    assert "fig7_seed_improvement_vs_doppler.png" in {p.name for p in written}
    for p in written:
        assert p.read_bytes()[:8] == PNG
    # the tables were built through the scene's cache: the PPI shows what a run reads
    assert list(table_cache.glob("sea_clutter_map-*.npz"))
    assert list(table_cache.glob("improvement_factor-*.npz"))


def test_render_refuses_unknown_radar_and_kind(tmp_path, single_missile):
    with pytest.raises(ValueError, match="no radar"):
        figs.render(single_missile, "improvement", tmp_path, radar_id="nope")
    with pytest.raises(ValueError):
        figs.render(single_missile, "weather", tmp_path)


def test_improvement_table_picture_reads_the_table(tmp_path):
    from shipradar.sim.studies.figures.doppler import plot_improvement_table
    from shipradar.tables.improvement import build_improvement_table, improvement_factor_db

    table = build_improvement_table("mti", mti_pulses=3, resolution="coarse")
    out = plot_improvement_table(tmp_path / "t.png", table, n_points=201)
    assert out.read_bytes()[:8] == PNG
    # what it draws: the 3-pulse canceller's blind speed at 0 and its peak at f_r/2
    assert improvement_factor_db(table, 0.01, 0.5) > improvement_factor_db(table, 0.01, 0.02)
    assert np.isfinite(improvement_factor_db(table, 0.01, np.linspace(0, 1, 201))).all()
