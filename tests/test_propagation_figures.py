"""Propagation pictures (sim/studies/figures/propagation.py) and ``shipradar plot SCENARIO
propagation|coverage``: PNGs are written, and what they draw is what the on-line model reads."""

from pathlib import Path

import matplotlib
import numpy as np
import pytest
import yaml

from shipradar.sim import cli
from shipradar.sim.studies.figures import propagation as fig
from shipradar.tables import propagation as tp

matplotlib.use("Agg")

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def small_table():
    return tp.build_propagation_table(
        5.6e9, 25.0, polarization="V", elevation_pattern=None,
        profile={"kind": "evaporation", "duct_height_m": 10.0}, max_range_m=30e3,
        max_height_m=100.0, fidelity="coarse", progress=False)


def _png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == PNG_MAGIC
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def test_coverage_and_factor_pictures(tmp_path, small_table):
    cov = fig.plot_coverage(tmp_path / "cov.png", small_table)
    w, h = _png_size(cov)
    assert w > 500 and h > 300
    f_r = fig.plot_table_factor_vs_range(tmp_path / "f.png", small_table, height_m=10.0)
    assert _png_size(f_r)[0] > 500


def test_coverage_picture_reads_the_lookup(tmp_path, small_table, monkeypatch):
    """The diagram is the table's lookup on a regular (range, height) grid: capture it."""
    seen = {}
    real = tp.propagation_factor

    def spy(table, r, h):
        out = real(table, r, h)
        seen["r"], seen["h"], seen["f"] = np.broadcast_arrays(r, h, out)
        return out

    monkeypatch.setattr(tp, "propagation_factor", spy)
    fig.plot_coverage(tmp_path / "cov.png", small_table, n_ranges=300, n_heights=200)
    f = seen["f"]
    assert f.shape == (200, 300)
    assert seen["h"].max() == pytest.approx(100.0)
    # steep angles at short range fall back (NaN, drawn grey); the rest is the PE
    assert np.isnan(f[-1, 0]) and np.isfinite(f[-1, -1])
    assert np.isfinite(f).mean() > 0.9


@pytest.mark.slow
def test_cli_plot_propagation_and_coverage(tmp_path, table_cache, capsys):
    scenario = yaml.safe_load(Path("scenarios/single_missile.yaml").read_text())
    scenario.setdefault("fidelity", {})["pe_grid"] = "coarse"
    scenario["fidelity"]["propagation"] = "pe"
    for radar in (r for p in scenario["platforms"] for r in p.get("radars", [])):
        radar["instrumented_range_m"] = 30000
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scenario))
    out = tmp_path / "figs"
    written = []
    for what in ("propagation", "coverage"):
        assert cli.main(["plot", str(path), what, "--out", str(out), "--height", "10"]) == 0
        written += [Path(line) for line in capsys.readouterr().out.split()]
    assert len(written) >= 2
    for p in written:
        assert p.exists() and _png_size(p)[0] > 500
    assert any("coverage" in p.name for p in written)
