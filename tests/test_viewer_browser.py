"""shipradar view in a real browser (headless Chromium through Playwright) on a recording.

Chromium is Debian's ``chromium`` package, installed by the session fixture when missing and
the process may install packages. Without it the tests skip, except under CI (``CI`` set)
where they fail.
"""

from __future__ import annotations

import pytest

from shipradar.sim.adapters.viewer.screenshot import find_chromium, launch_chromium, open_page, seek
from shipradar.sim.adapters.viewer.server import ViewerServer, ViewerThread
from tests.helpers import require_system_tool
from tests.test_viewer import demo_recording  # noqa: F401  (module fixture)

playwright_api = pytest.importorskip("playwright.sync_api")

TARGET_RGB = (0xFF, 0x3B, 0x30)  # --target in viewer.css
PLAIN_RGB = (0x5D, 0xFF, 0x6A)   # --plain


@pytest.fixture(scope="session")
def chromium():
    return require_system_tool(find_chromium, "chromium")


@pytest.fixture(scope="module")
def browser(chromium):
    with playwright_api.sync_playwright() as pw:
        b = launch_chromium(pw, chromium)
        yield b
        b.close()


@pytest.fixture
def page(browser, demo_recording):  # noqa: F811
    server = ViewerServer(str(demo_recording["path"]), port=0, autoplay=False)
    with ViewerThread(server):
        pg = open_page(browser, server.url)
        yield pg
        errors = list(pg.console_errors)
        pg.close()
    assert errors == [], errors


def pixels(page, sensor: str, x: float, y: float, half: int = 4):
    """RGBA of the canvas pixels in a (2 half + 1)² square around CSS pixel (x, y)."""
    return page.evaluate("""([id, x, y, h]) => {
        const c = document.querySelector(`canvas[data-sensor="${id}"]`);
        const d = window.devicePixelRatio || 1;
        const img = c.getContext('2d').getImageData(Math.round(x * d) - h, Math.round(y * d) - h,
                                                     2 * h + 1, 2 * h + 1).data;
        const out = [];
        for (let i = 0; i < img.length; i += 4) out.push([img[i], img[i + 1], img[i + 2]]);
        return out; }""", [sensor, x, y, half])


def near(rgb, ref, tol=40):
    return all(abs(a - b) <= tol for a, b in zip(rgb, ref, strict=True))


def test_page_counts_every_plot_of_every_scan(page, demo_recording):  # noqa: F811
    page.select_option("#speed", "100")
    page.click("#play")
    page.wait_for_function("() => window.shipradarViewer.state.clock.ended", timeout=30_000)
    sensors = {s for s, _ in demo_recording["per_scan"]}
    for sensor in sensors:
        shown = page.evaluate("(id) => window.shipradarViewer.perScan(id)", sensor)
        expected = {str(scan): dict(c) for (s, scan), c in demo_recording["per_scan"].items()
                    if s == sensor}
        got = {k: {n: v for n, v in c.items() if v} for k, c in shown.items()}
        assert got == {k: {n: v for n, v in c.items() if v} for k, c in expected.items()}
    assert page.evaluate("() => window.shipradarViewer.state.status.dropped") == 0
    # the status line says it too, for the last scan
    assert "0 dropped" in page.inner_text("#status")


def test_target_plot_drawn_where_its_range_and_azimuth_say(page, demo_recording, tmp_path):  # noqa: F811
    plot = demo_recording["targets"][len(demo_recording["targets"]) // 2]
    t = round(plot["t_msg"] + 0.05, 1)  # just after the plot's sector, replay paused
    seek(page, t)
    xy = page.evaluate("(p) => window.shipradarViewer.screenOf(p.sensor, p.range_m, "
                       "p.azimuth_rad, p.t_msg)", plot)
    around = pixels(page, plot["sensor"], xy["x"], xy["y"])
    assert any(near(px, TARGET_RGB) for px in around), around
    page.screenshot(path=str(tmp_path / "viewer.png"))
    assert (tmp_path / "viewer.png").stat().st_size > 10_000

    # truth colours off: the tracker's view, the same plot in the plain colour
    page.click("#truth-colours")
    page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
    around = pixels(page, plot["sensor"], xy["x"], xy["y"])
    assert not any(near(px, TARGET_RGB) for px in around)
    assert any(near(px, PLAIN_RGB) for px in around), around
    assert "target" not in page.inner_text("#status")


def test_slider_seeks_and_play_pause(page, demo_recording):  # noqa: F811
    seek(page, 60.0)
    scans = page.evaluate("""() => {
        const s = [...window.shipradarViewer.state.sensors.values()][0];
        return s.batches.map(b => b.scan); }""")
    fade = page.evaluate("() => window.shipradarViewer.state.fadeScans")
    # what a seek sends: the scans still fading at 60 s, none after
    assert scans and max(scans) <= 60 and min(scans) >= 60 - fade - 1
    seek(page, 20.0)  # backwards
    assert abs(page.evaluate("() => window.shipradarViewer.now()") - 20.0) < 0.15

    page.click("#play")  # x1
    page.wait_for_function("() => window.shipradarViewer.now() > 20.3", timeout=10_000)
    page.click("#play")  # pause
    page.wait_for_function("() => !window.shipradarViewer.state.clock.playing", timeout=10_000)
    t1 = page.evaluate("() => window.shipradarViewer.now()")
    page.wait_for_timeout(300)
    assert page.evaluate("() => window.shipradarViewer.now()") == t1
    # fade and toggles change what is drawn, not what is held
    page.fill("#fade", "2")
    page.dispatch_event("#fade", "change")
    assert page.evaluate("() => window.shipradarViewer.state.fadeScans") == 2
    page.click("#truth-tracks")
    assert page.evaluate("() => window.shipradarViewer.state.truthTracks") is False
