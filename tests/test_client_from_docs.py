"""A tracker client written from docs/protocol.md and the JSON Schemas only
(``tests/client_from_docs.py``, no ``shipradar`` import) against a live ``shipradar run
--publish``: it places the plots with the sensor state carried in the stream and reproduces
the truth within the declared sigma (docs/protocol.md section 4.2, measurement errors)."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
import threading

import numpy as np
import pytest

from tests import client_from_docs
from tests.helpers import ROOT, free_port

CONTRACT = ROOT / "sim/stream/contract"


def test_the_client_imports_no_shipradar():
    tree = ast.parse((ROOT / "tests/client_from_docs.py").read_text(encoding="utf-8"))
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, "no relative import"
            imported.add((node.module or "").split(".")[0])
    assert imported <= {"__future__", "json", "struct", "dataclasses", "pathlib", "typing",
                        "msgpack", "numpy", "zmq"}, imported


@pytest.mark.slow
@pytest.mark.parametrize("use_meta_position", [True, False], ids=["meta", "eos"])
def test_client_from_docs_reproduces_the_truth_within_sigma(use_meta_position):
    """Raid (two radars, aircraft up to high altitude, a moving ship), 120 simulated s; the
    antenna state from ``meta`` at each scan start (when the stream has it), or from the
    last ``eos`` only."""
    endpoint = f"tcp://127.0.0.1:{free_port()}"
    proc = subprocess.Popen(
        [sys.executable, "-m", "shipradar.sim.cli", "run", "--example", "raid",
         "--duration", "120", "--quiet", "--publish", endpoint, "--wait-subscribers", "1",
         "--wait-timeout", "60"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    client = client_from_docs.Client(CONTRACT, use_meta_position=use_meta_position)
    try:
        worker = threading.Thread(
            target=client.run, args=(endpoint, 5.0, lambda: proc.poll() is None), daemon=True)
        worker.start()
        worker.join(timeout=240)
        assert not worker.is_alive(), "the client did not finish"
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err[-2000:]
    summary = json.loads(out.strip().splitlines()[-1])
    sent = summary["bus"]["publisher"]["sent_by_topic"]
    assert summary["bus"]["publisher"]["dropped"] == 0
    assert client.counts == sent, (client.counts, sent)  # every message heard
    assert client.ended == ("end" in sent)  # stopped on the end marker when there is one
    z = client.normalised_errors()
    n = z["range"].size
    assert n >= 150, n
    # plots placed with the state the stream carried
    assert set(client.placed_with) <= ({"meta", "eos"} if use_meta_position else {"eos"})
    for name in ("range", "azimuth"):
        mean, std = float(z[name].mean()), float(z[name].std(ddof=1))
        print(f"{name}: n={n} z mean {mean:+.3f} std {std:.3f}; placed with "
              f"{client.placed_with}")
        assert abs(mean) < 4.0 / np.sqrt(n), (name, mean)  # a few sigma / sqrt(n)
        assert 0.7 < std < 1.3, (name, std)  # within ~30 % of the declared sigma
    # placing a plot in the local frame and measuring it back is exact
    assert float(z["roundtrip"].max()) < 1e-3
