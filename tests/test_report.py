"""The study report: every figure it lists is written, as a valid non-empty PNG."""

from __future__ import annotations

import csv
import struct
import zlib

import pytest

from shipradar.sim.studies import montecarlo as mc
from shipradar.sim.studies.report import build_report, cli_main
from shipradar.sim.world.scenario import load_scenario

from .helpers import ROOT

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def check_png(path):
    """PNG signature, a CRC-valid IHDR of non-zero size, and an IEND chunk."""
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE, path
    length, kind = struct.unpack(">I4s", data[8:16])
    assert kind == b"IHDR" and length == 13
    width, height = struct.unpack(">II", data[16:24])
    assert width > 0 and height > 0
    (crc,) = struct.unpack(">I", data[16 + length:20 + length])
    assert crc == zlib.crc32(data[12:16 + length])
    assert data[-12:] == b"\x00\x00\x00\x00IEND\xaeB`\x82"  # empty IEND chunk and its CRC
    return width, height


@pytest.fixture(scope="module")
def scene():
    return load_scenario(ROOT / "scenarios" / "single_missile.yaml")


@pytest.mark.slow
def test_report_writes_every_listed_figure(tmp_path, scene):
    # a fake study file beside the report: the report must find it and draw its points
    # (written by the csv module here, in the study's columns, not by the study's own writer)
    with open(tmp_path / "montecarlo_pd_range.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=mc.PD_COLUMNS, lineterminator="\n")
        w.writeheader()
        w.writerow({"sensor": "giraffe", "kind": "missile", "range_lo_m": 0.0,
                    "range_hi_m": 2000.0, "looks": 10, "detections": 9, "pd": 0.9,
                    "ci_lo": 0.6, "ci_hi": 0.98})
    res = build_report(scene, tmp_path, duration_s=30.0, fa_scans=20)
    names = [f["file"] for f in res["figures"]]
    # always drawn: model P_d, false alarms, PPI; I_F (the scene has an FIR bank), σ0* and
    # the P_fac map (clutter on, 1.8° × 0.25 µs: medium/high resolution)
    for required in ("pd_range.png", "false_alarms_range.png", "ppi.png",
                     "improvement_doppler.png", "pfac_map.png", "sigma0_range.png"):
        assert required in names
    assert len(names) == len(set(names))
    index = (tmp_path / "index.html").read_text()
    for name in names:
        check_png(tmp_path / name)
        assert f"src='{name}'" in index
    pd_caption = next(f["caption"] for f in res["figures"] if f["file"] == "pd_range.png")
    assert "montecarlo_pd_range.csv" in pd_caption
    fa_caption = next(f["caption"] for f in res["figures"]
                      if f["file"] == "false_alarms_range.png")
    assert "Fig. 8" in fa_caption
    # every caption a whole sentence: none cut at a docstring's line end, no raw Python
    for f in res["figures"]:
        caption = f["caption"].rstrip()
        assert not caption.endswith((",", " and", " has", " the", " of", " a", " where")), caption
        assert "{" not in caption and "': " not in caption, caption  # no dict repr
    if_caption = next(f["caption"] for f in res["figures"]
                      if f["file"] == "improvement_doppler.png")
    assert "8 filters of 8 pulses, chebyshev 50 dB window" in if_caption
    # two panels side by side (Fig. 8 a and b; PPI full range and zoomed): wider than tall
    for name in ("false_alarms_range.png", "ppi.png"):
        w, h = check_png(tmp_path / name)
        assert w > 1.5 * h, name
    for note in res["notes"]:  # every skipped figure is explained on the page
        assert note.split(":")[0] in index
    # nothing else was written
    assert {p.name for p in tmp_path.iterdir()} == set(names) | {
        "index.html", "montecarlo_pd_range.csv"}


@pytest.mark.slow
def test_report_without_study_notes_it(tmp_path, scene, capsys):
    out = tmp_path / "rep"
    assert cli_main([str(ROOT / "scenarios" / "single_missile.yaml"), "--out", str(out),
                     "--duration", "10", "--fa-scans", "5", "--montecarlo", ""]) == 0
    assert "index.html" in capsys.readouterr().out
    index = (out / "index.html").read_text()
    assert "no Monte Carlo study" in index
    check_png(out / "ppi.png")


def test_png_check_rejects_garbage(tmp_path):
    bad = tmp_path / "x.png"
    bad.write_bytes(b"GIF89a" + b"\0" * 40)
    with pytest.raises(AssertionError):
        check_png(bad)
