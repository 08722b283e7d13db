"""Which implementation of the stream's per-message byte work this process uses.

``shipradar._frames`` (compiled from ``shipradar/_frames.c``, an optional extension: built
when the installing machine has a C compiler and the Python headers) or its pure-Python
twin ``shipradar._frames_py`` (the same bytes, slower: docs/performance.md section 15).
The compiled one is taken when it imports, unless the environment variable
``SHIPRADAR_PURE_PYTHON`` is set to anything but ``""`` or ``0`` when shipradar is first
imported (to compare the two, or to rule the extension out).
"""

from __future__ import annotations

import os
from types import ModuleType

__all__ = ["COMPILED", "PURE_PYTHON_VARIABLE", "frames"]

#: The environment variable that switches the compiled extension off.
PURE_PYTHON_VARIABLE = "SHIPRADAR_PURE_PYTHON"


def _load() -> ModuleType:
    if os.environ.get(PURE_PYTHON_VARIABLE, "") not in ("", "0"):
        from shipradar import _frames_py

        return _frames_py
    try:
        from shipradar import _frames
    except ImportError:  # not built (no compiler at install time)
        from shipradar import _frames_py

        return _frames_py
    return _frames


#: The implementation in use: ``shipradar._frames`` or ``shipradar._frames_py``.
frames: ModuleType = _load()
#: True when the compiled extension is in use.
COMPILED: bool = frames.__name__ == "shipradar._frames"
