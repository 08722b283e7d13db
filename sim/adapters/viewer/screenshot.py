"""Render the viewer's page on a recording with headless Chromium and save a PNG.

Used by ``make viewer-screenshot`` (docs/viewer.png) and by the tests::

    python -m shipradar.sim.adapters.viewer.screenshot out/demo.rec docs/viewer.png --at 95

Chromium is the system's (Debian package ``chromium``), driven by Playwright for Python
through ``executable_path``: nothing is downloaded.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
from pathlib import Path
from typing import Any

__all__ = ["CHROMIUM_ARGS", "find_chromium", "launch_chromium", "open_page", "render",
           "seek"]

#: Command-line flags of a quiet, offline headless Chromium.
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]


def find_chromium() -> str | None:
    """Path of a Chromium executable: ``$SHIPRADAR_CHROMIUM``, else ``chromium`` or
    ``chromium-browser`` on the PATH; None if there is none."""
    env = os.environ.get("SHIPRADAR_CHROMIUM")
    if env:
        return env if Path(env).is_file() else None
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    return None


def launch_chromium(playwright: Any, executable: str | None = None):
    """Launch the system Chromium headless through Playwright.

    Parameters
    ----------
    playwright : playwright.sync_api.Playwright
        A started Playwright (``sync_playwright().start()``).
    executable : str or None, optional
        Chromium's path; default :func:`find_chromium`.

    Returns
    -------
    playwright.sync_api.Browser

    Raises
    ------
    FileNotFoundError
        If no Chromium is installed.
    """
    path = executable or find_chromium()
    if path is None:
        raise FileNotFoundError("no chromium found: install the 'chromium' package "
                                "(apt-get install chromium) or set SHIPRADAR_CHROMIUM")
    return playwright.chromium.launch(executable_path=path, args=CHROMIUM_ARGS, headless=True)


def open_page(browser: Any, url: str, *, width: int = 1280, height: int = 800,
              timeout_s: float = 20.0):
    """Open the viewer's page and wait until it has the source's info and a radar's meta.

    Returns
    -------
    playwright.sync_api.Page
        With ``page.console_errors``: the console errors and page errors seen so far (a
        list, kept up to date).
    """
    page = browser.new_page(viewport={"width": width, "height": height})
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.console_errors = errors
    page.goto(url)
    page.wait_for_function(
        "() => { const v = window.shipradarViewer; if (!v || !v.state.info) return false;"
        " for (const s of v.state.sensors.values()) if (s.meta) return true; return false; }",
        timeout=timeout_s * 1000)
    return page


def seek(page: Any, t: float, *, timeout_s: float = 20.0) -> None:
    """Drag the time slider to ``t`` [s] (as a user would) and wait for the page to be there."""
    page.evaluate("""(t) => { const s = document.getElementById('slider');
                     s.value = t; s.dispatchEvent(new Event('input'));
                     s.dispatchEvent(new Event('change')); }""", t)
    step = float(page.evaluate("() => Number(document.getElementById('slider').step)"))
    page.wait_for_function(
        "([t, tol]) => { const v = window.shipradarViewer;"
        " return !v.state.clock.playing && Math.abs(v.state.displayT - t) <= tol; }",
        arg=[t, step], timeout=timeout_s * 1000)
    # two animation frames: the canvas shows the new state
    page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")


def render(recording: str | Path, out: str | Path, *, at_s: float | None = None,
           fade_scans: int = 10, zoom: float = 1.0, width: int = 1280,
           height: int = 800) -> Path:
    """Screenshot of the page replaying ``recording``, paused at ``at_s``.

    Parameters
    ----------
    recording : str or Path
        A shipradar recording.
    out : str or Path
        PNG to write.
    at_s : float or None, optional
        Simulated time shown [s]; default 85 % of the recording.
    fade_scans : int, optional
        Scans over which plots fade (the page's "fade" control).
    zoom : float, optional
        Zoom of every scope (1: the instrumented range fills it).
    width, height : int, optional
        Viewport [CSS px].

    Returns
    -------
    Path
        ``out``.
    """
    from playwright.sync_api import sync_playwright

    from shipradar.sim.adapters.viewer.server import ViewerServer, ViewerThread

    server = ViewerServer(str(recording), port=0, autoplay=False)
    assert server.recording is not None  # a recording's path, never a live endpoint
    t0, t1 = server.recording.t0, server.recording.t1
    at = t0 + 0.85 * (t1 - t0) if at_s is None else min(max(at_s, t0), t1)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with ViewerThread(server) as viewer, sync_playwright() as pw:
        browser = launch_chromium(pw)
        try:
            url = viewer.server.url
            assert url is not None  # set when the thread started the server
            page = open_page(browser, url, width=width, height=height)
            page.fill("#fade", str(fade_scans))
            page.dispatch_event("#fade", "change")
            page.evaluate("""(z) => { const v = window.shipradarViewer;
                             for (const id of v.state.sensors.keys()) v.setView(id, z); }""",
                          zoom)
            seek(page, at)
            page.screenshot(path=str(out))
            if page.console_errors:
                raise RuntimeError(f"console errors on the page: {page.console_errors}")
        finally:
            browser.close()
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recording")
    ap.add_argument("out")
    ap.add_argument("--at", type=float, default=None, help="simulated time shown [s]")
    ap.add_argument("--fade", type=int, default=10, help="fade over N scans")
    ap.add_argument("--zoom", type=float, default=1.0, help="zoom of the scopes")
    ap.add_argument("--size", default="1280x800", help="viewport WIDTHxHEIGHT [px]")
    a = ap.parse_args(argv)
    try:
        w, h = (int(v) for v in a.size.lower().split("x"))
    except ValueError:
        print(f"--size must be WIDTHxHEIGHT, got {a.size!r}", file=sys.stderr)
        return 2
    print(render(a.recording, a.out, at_s=a.at, fade_scans=a.fade, zoom=a.zoom, width=w, height=h))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
