"""shipradar export: raw ASTERIX, pcap (opened by tshark), CSV and Parquet tables."""

from __future__ import annotations

import json
import subprocess

import pyarrow.csv as pcsv
import pyarrow.parquet as pq
import pytest

from shipradar.sim.cli import main
from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream.bus import Bus
from shipradar.sim.stream.recording import Recorder

from .asterix_helpers import scene, tshark_asterix, tshark_path


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """A recorded 8 s run and its summary."""
    path = tmp_path_factory.mktemp("export") / "run.rec"
    s = scene()
    with Recorder(path) as rec:
        summary = Simulation(s, bus=Bus(None, rec)).run()
    plots = summary["target_plots"] + summary["noise_false_alarms"] + \
        summary["clutter_false_alarms"]
    return path, summary, plots, s


def _export(capsys, *argv):
    code = main(["export", *map(str, argv)])
    out = capsys.readouterr()
    return code, (json.loads(out.out) if code == 0 else None), out.err


def test_tables_have_one_row_per_plot_with_truth(recording, tmp_path, capsys):
    path, summary, plots, s = recording
    assert plots > 10
    code, info, _ = _export(capsys, path, "--format", "csv", "--out", tmp_path / "p.csv")
    assert code == 0 and info["plots"] == plots
    csv = pcsv.read_csv(tmp_path / "p.csv").to_pandas()
    assert len(csv) == plots
    assert set(csv["origin"]) <= {"target", "noise", "sea_clutter"}
    assert (csv["origin"] == "target").sum() == summary["target_plots"]
    assert set(csv.loc[csv["origin"] == "target", "target"]) == {"m1"}
    code, info, _ = _export(capsys, path, "--format", "parquet", "--out", tmp_path / "p.parquet")
    assert code == 0
    par = pq.read_table(tmp_path / "p.parquet").to_pandas()
    assert len(par) == plots
    assert list(par["plot_id"]) == list(csv["plot_id"])
    # target states: one row per (sensor, end of scan, target)
    targets = pq.read_table(tmp_path / "p.targets.parquet").to_pandas()
    assert len(targets) == summary["scans"] * len(s.targets) == info["target_states"]
    assert set(targets["target"]) == {"m1"}


def test_pcap_opens_in_tshark_and_ast_is_the_same_blocks(recording, tmp_path, capsys):
    path, _, plots, _ = recording
    tshark_path()
    code, info, _ = _export(capsys, path, "--format", "pcap", "--out", tmp_path / "a.pcap",
                            "--port", 4000)
    assert code == 0 and info["cat048_records"] == plots
    blocks = tshark_asterix(tmp_path / "a.pcap", 4000)
    assert len(blocks) == info["blocks"]
    assert sum(len(b["records"]) for b in blocks if b["category"] == 48) == plots
    # tshark's own summary line of each frame names the protocol
    res = subprocess.run([tshark_path(), "-r", str(tmp_path / "a.pcap"), "-d",
                          "udp.port==4000,asterix"], capture_output=True, text=True, check=True)
    assert len(res.stdout.splitlines()) == info["datagrams"]
    assert res.stdout.count("ASTERIX") >= info["datagrams"]
    code, info2, _ = _export(capsys, path, "--format", "asterix", "--out", tmp_path / "a.ast")
    assert code == 0 and info2["bytes"] == info["bytes"]
    import asterix

    records = asterix.parse((tmp_path / "a.ast").read_bytes())
    assert sum(r["category"] == 48 for r in records) == plots
    # same recording, same bytes
    code, _, _ = _export(capsys, path, "--format", "pcap", "--out", tmp_path / "b.pcap",
                         "--port", 4000)
    assert (tmp_path / "b.pcap").read_bytes() == (tmp_path / "a.pcap").read_bytes()


def test_export_bad_input_exit_2(recording, tmp_path, capsys):
    path, *_ = recording
    (tmp_path / "x.csv").write_text("keep")
    code, _, err = _export(capsys, path, "--format", "csv", "--out", tmp_path / "x.csv")
    assert code == 2 and "--out" in err and "--overwrite" in err
    assert (tmp_path / "x.csv").read_text() == "keep"
    code, _, err = _export(capsys, tmp_path / "none.rec", "--format", "csv", "--out",
                           tmp_path / "y.csv")
    assert code == 2 and "does not exist" in err
    with pytest.raises(SystemExit) as exc:
        main(["export", str(path), "--format", "pcap", "--out", str(tmp_path / "z"),
              "--port", "0"])
    assert exc.value.code == 2
    assert "--port must be an integer in [1, 65535], got '0'" in capsys.readouterr().err
