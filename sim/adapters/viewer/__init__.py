"""Live plan position indicator (PPI) in the browser: ``shipradar view SOURCE``.

:mod:`.wire` turns stream messages into the compact batches the page reads;
:mod:`.server` serves the page and pushes those batches over a WebSocket, from a live
ZeroMQ stream or from a recording it replays itself; :mod:`.screenshot` renders the page
with headless Chromium. The page itself is ``static/`` (plain HTML, JS and canvas, no build
step, no network). docs/viewer.md is the user's guide.
"""

__all__ = ["wire", "server"]
