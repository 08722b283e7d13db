"""The ``shipradar evaluate`` report (``index.html``) in a real browser: headless Chromium
through Playwright, set up as tests/test_viewer_browser.py does (Debian's ``chromium``,
installed when missing; the tests skip without it, and fail under CI).

The study is built in process on the manoeuvres scene with a tracker object of known
behaviour (tracks on the scene's trajectories with seeded noise, an id change, a gap and a
false track in some runs), plus a failed run with a long stderr line; the page is loaded at
1,400 px.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from shipradar.sim.adapters.viewer.screenshot import find_chromium, launch_chromium
from tests.helpers import ROOT, require_system_tool

playwright_api = pytest.importorskip("playwright.sync_api")

MANOEUVRES = ROOT / "scenarios" / "manoeuvres.yaml"
WIDTH = 1400
RUNS = 3
DURATION_S = 40.0
# a number in scientific notation: a digit, an exponent, a digit ("2.065e+04", "1E5")
SCIENTIFIC = re.compile(r"\d\.?\d*[eE][+-]?\d")


class _NoisyTracker:
    """Tracks on the scene's trajectories (it is handed them, as a good tracker would
    estimate them; it never reads the truth topic), 150 m of seeded noise; run-dependent
    behaviour: target 0's id changes at 20 s, target 1 is dropped from 15 to 25 s in run 0,
    a false track stands 30 km north-east of the origin in runs 1 and 2."""

    def __init__(self, scenario, run: int):
        from shipradar.sim.world.kinematics import LocalFrame
        from shipradar.sim.world.trajectory import trajectories

        self.traj = trajectories(scenario.targets, LocalFrame(scenario.origin), hold=False)
        self.n = len(scenario.targets)
        self.run = run
        self.rng = np.random.default_rng(run)
        self.sensor = None

    def on_message(self, topic, t, payload):
        if topic != "eos":
            return None
        if self.sensor is None:
            self.sensor = payload["sensor"]
        if payload["sensor"] != self.sensor:
            return None
        pos, vel, _, active = self.traj.state_acc(np.full(self.n, t), np.arange(self.n))
        keep = active.copy()
        if self.run == 0 and 15.0 <= t <= 25.0:
            keep[1] = False
        idx = np.flatnonzero(keep)
        ids = [f"T{j + 1}" + ("b" if j == 0 and t >= 20.0 else "") for j in idx]
        e = pos[idx, 0] + self.rng.normal(0.0, 150.0, idx.size)
        nn = pos[idx, 1] + self.rng.normal(0.0, 150.0, idx.size)
        ve, vn = vel[idx, 0], vel[idx, 1]
        if self.run > 0:
            ids.append("F1")
            e, nn = np.append(e, 21_000.0), np.append(nn, 21_000.0)
            ve, vn = np.append(ve, 0.0), np.append(vn, 0.0)
        return {"sensor": payload["sensor"], "scan": payload["scan"], "time_s": t,
                "track_id": ids, "east_m": e, "north_m": nn, "v_east_mps": ve,
                "v_north_mps": vn}


def build_study(out: Path) -> Path:
    """A study directory with its report: RUNS scored runs and one failed run."""
    from shipradar.sim.studies.evaluate.metrics import DEFAULT_METRICS, score_run
    from shipradar.sim.studies.evaluate.runner import run_tracker_object
    from shipradar.sim.studies.evaluate.study import (
        run_dir_name,
        study_seeds,
        write_results,
    )
    from shipradar.sim.world.scenario import load_scenario

    s = load_scenario(MANOEUVRES)
    seeds = study_seeds(1, RUNS)
    results = []
    for k, sd in enumerate(seeds):
        data = run_tracker_object(s, _NoisyTracker(s, k), seed=sd, duration_s=DURATION_S,
                                  run_dir=out / "runs" / run_dir_name(sd))
        assert data.info["status"] == "ok", data.info
        results.append((data.info, score_run(data, DEFAULT_METRICS)))
    results.append(({"seed": 99, "status": "failed", "error": "tracker exited with code 3",
                     "exit_code": 3, "stderr_tail": "Traceback: " + "x" * 3000}, None))
    # a long command without spaces must wrap too
    settings = {"scenario": str(MANOEUVRES), "scenario_name": s.name,
                "tracker": "/opt/" + "a-very-long-directory-name/" * 20 + "tracker",
                "runs": RUNS + 1, "seed": 1, "seeds": seeds + [99],
                "duration_s": DURATION_S, "metrics": DEFAULT_METRICS.as_dict()}
    summary = write_results(out, results, settings)
    return Path(summary["report"])


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    return build_study(tmp_path_factory.mktemp("study"))


@pytest.fixture(scope="module")
def chromium():
    return require_system_tool(find_chromium, "chromium")


@pytest.fixture(scope="module")
def page(chromium, report):
    with playwright_api.sync_playwright() as pw:
        browser = launch_chromium(pw, chromium)
        pg = browser.new_page(viewport={"width": WIDTH, "height": 900})
        errors: list[str] = []
        pg.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.goto(report.as_uri())
        pg.wait_for_load_state("load")
        yield pg
        pg.close()
        browser.close()
    assert errors == [], errors


def test_nothing_overflows_at_1400_px(page, tmp_path):
    assert page.evaluate("() => document.documentElement.scrollWidth") <= WIDTH
    # every element, the per-target tables' in particular, inside the viewport
    wide = page.evaluate("""(w) => [...document.body.querySelectorAll('*')]
        .filter(e => { const r = e.getBoundingClientRect();
                       return r.width > 0 && (r.right > w + 0.5 || r.left < -0.5); })
        .map(e => e.tagName + '.' + e.className)""", WIDTH)
    assert wide == []
    boxes = page.evaluate("""() => [...document.querySelectorAll('table.targets')]
        .map(t => { const r = t.getBoundingClientRect(); return [r.left, r.right]; })""")
    assert boxes and all(0 <= lo and hi <= WIDTH for lo, hi in boxes), boxes
    page.screenshot(path=str(tmp_path / "report.png"), full_page=True)
    assert (tmp_path / "report.png").stat().st_size > 50_000


def test_every_table_has_units(page):
    tables = page.evaluate("""() => [...document.querySelectorAll('table')].map(t => {
        const head = [...t.rows[0].cells].map(c => c.innerText.trim());
        const unitRow = [...t.querySelectorAll('tr.unit')].map(
            r => [...r.cells].map(c => c.innerText.trim()));
        const col = head.indexOf('unit');
        const units = col < 0 ? [] : [...t.rows].slice(1).map(r => r.cells[col].innerText.trim());
        return {cls: t.className, head, unitRow, units}; })""")
    assert {t["cls"] for t in tables} == {"metrics", "targets"}
    for t in tables:
        if t["cls"] == "metrics":  # a unit column, one unit per metric (GOSPA rows included)
            assert t["units"] and all(t["units"]), t
            assert "m" in t["units"][:4]
        else:  # a unit row under the header, a unit per column
            (row,) = t["unitRow"]
            assert row[0] == "unit" and len(row) == len(t["head"]) and all(row), t


def test_no_scientific_notation(page):
    text = page.evaluate("() => document.body.innerText")
    svg_text = page.evaluate(
        "() => [...document.querySelectorAll('svg text')].map(e => e.textContent).join(' ')")
    assert svg_text.strip()  # the figures' text is text
    for where in (text, svg_text):
        assert not SCIENTIFIC.search(where), SCIENTIFIC.search(where)
    # a range at first track is in km with one decimal, GOSPA in whole metres
    assert re.search(r"\b\d+\.\d\b", text)


def test_intervals_within_bounds(page):
    """Every figure in the tables is non-negative and every fraction at most 1: no interval
    printed past its bound."""
    cells = page.evaluate("""() => [...document.querySelectorAll('table td')]
        .map(c => c.innerText)""")
    numbers = [float(x.replace(",", "")) for c in cells
               for x in re.findall(r"-?[\d,]*\d(?:\.\d+)?", c)]
    assert numbers and min(numbers) >= 0.0
    fractions = page.evaluate("""() => { const t = document.querySelector('table.metrics');
        return [...t.rows].slice(1).filter(r => r.cells[2].innerText.trim() === '1'
            && !r.cells[0].innerText.includes('ambiguity'))
          .map(r => [...r.cells].slice(3, 6).map(c => c.innerText)); }""")
    assert fractions
    assert all(float(v) <= 1.0 for row in fractions for v in row if v != "–")


def test_legends_and_the_association_distance(page, report):
    import pandas as pd

    def legend(gid):
        return page.evaluate(
            "(g) => [...document.querySelectorAll(`g#${g} text`)].map(e => e.textContent)",
            gid)

    assert {"gospa", "localisation", "missed", "false"} <= set(legend("legend-gospa"))
    holding = pd.read_parquet(report.parent / "holding.parquet")
    first = holding[holding["seed"] == holding["seed"].iloc[0]]
    held_ids = set(first["track_id"].dropna())
    assert {"T1", "T1b"} <= held_ids
    coverage = " ".join(legend("legend-coverage"))
    assert "no track held it" in coverage and "not counted" in coverage
    assert all(f"track {tid}" in coverage for tid in held_ids), coverage
    ppi = " ".join(legend("legend-ppi"))
    assert "truth" in ppi and "radar" in ppi
    assert all(f"track {tid}" in ppi for tid in held_ids), ppi
    # c = 2 km, stated beside every figure and table that uses it
    captions = page.evaluate(
        "() => [...document.querySelectorAll('figcaption')].map(e => e.innerText)")
    assert len(captions) == 3 and all("c = 2,000 m" in c for c in captions), captions
    notes = page.evaluate("""() => [...document.querySelectorAll('table')].map(t => {
        let e = t.previousElementSibling;
        while (e && e.tagName === 'TABLE') e = e.previousElementSibling;
        return e ? e.innerText : ''; })""")
    assert all("c = 2,000 m" in n and "position accuracy" in n for n in notes), notes
