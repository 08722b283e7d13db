"""How a figure is shown in a study's pages: its :class:`Quantity` (label, unit, precision)
and :func:`format_value`, the one function every number of ``index.html``, ``compare.html``
and their sections goes through (fixed notation, never ``2.065e+04``). The catalogue of the
figures' quantities is :data:`shipradar.sim.studies.evaluate.report.QUANTITIES`.
"""

from __future__ import annotations

import html
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Quantity", "format_value"]


@dataclass(frozen=True)
class Quantity:
    """How a stored figure is shown: label, unit and precision (its bounds are
    :data:`shipradar.sim.studies.evaluate.stats.BOUNDS`).

    Attributes
    ----------
    label : str
        What it is, for a reader.
    unit : str
        Unit of the shown value ("1": a dimensionless ratio).
    decimals : int
        Digits after the decimal point, fixed notation.
    scale : float
        Shown value = stored value × scale (stored in SI: m → km is 1e-3).
    """

    label: str
    unit: str
    decimals: int
    scale: float = 1.0


def format_value(value: Any, q: Quantity | None = None) -> str:
    """A number as the report shows it: fixed notation (never ``2.065e+04``), ``q``'s
    decimals after scaling, thousands grouped with commas; "–" for None or NaN.

    Parameters
    ----------
    value : float, int, None or str
        Stored value (a string is returned escaped, as it is).
    q : Quantity or None
        Its quantity; None: an integer as it is, a float with up to 6 decimals and no
        trailing zeros.
    """
    if value is None:
        return "–"
    if isinstance(value, str):
        return html.escape(value)
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    v = float(value)
    if math.isnan(v):
        return "–"
    if math.isinf(v):
        return "∞" if v > 0 else "-∞"
    if q is None:
        s = f"{v:,.6f}".rstrip("0").rstrip(".")
    else:
        s = f"{v * q.scale:,.{q.decimals}f}"
    if s.lstrip("-").strip("0.,") == "":
        s = s.lstrip("-")  # no "-0.000"
    return s
