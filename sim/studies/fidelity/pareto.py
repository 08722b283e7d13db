"""The Pareto plot of a study: error against cost, the front over the settings inside
the tolerances, labels placed apart.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from shipradar.sim.studies.fidelity.trade import Study
from shipradar.sim.studies.timing import (
    CONFIDENCE,
    SAVING_MIN,
)


def pareto_front(cost: Sequence[float], error: Sequence[float]) -> list[int]:
    """Indices of the non-dominated points (no other point is both cheaper and as accurate,
    or as cheap and more accurate), sorted by cost."""
    idx = sorted(range(len(cost)), key=lambda i: (cost[i], error[i]))
    front, best = [], math.inf
    for i in idx:
        if error[i] < best:
            front.append(i)
            best = error[i]
    return front


def tolerated_front(cost: Sequence[float], error: Sequence[float], ok: Sequence[bool]
                    ) -> list[int]:
    """:func:`pareto_front` over the points inside the tolerances only (indices into all)."""
    inside = [i for i, good in enumerate(ok) if good]
    return [inside[j] for j in pareto_front([cost[i] for i in inside],
                                            [error[i] for i in inside])]


def plot_pareto(study: Study, path: Path) -> None:
    """PNG: error (worst target's mean |ΔP_d|; |Δ first-detection range|) against cost (the
    objective's CPU over the reference's, with its interval), the Pareto front joined over
    the settings inside the tolerances only, the tolerances drawn, labels placed apart."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    comps = study.comparisons
    ratios = [study.ratio(c) for c in comps]
    cost = [1.0 if r is None else r.value for r in ratios]
    lo = [0.0 if r is None else r.value - r.low for r in ratios]
    hi = [0.0 if r is None else r.high - r.value for r in ratios]
    err_pd = [c.total["worst_target_mean_abs_dpd"] for c in comps]
    err_r = [c.total["max_abs_dfirst_m"] for c in comps]
    fig, axes = plt.subplots(1, 2, figsize=(14, 6), constrained_layout=True)
    for ax, err, tol, name in ((axes[0], err_pd, study.tolerances.pd,
                                "worst target's mean |ΔP_d| per look"),
                               (axes[1], err_r, study.tolerances.range_m,
                                "largest |Δ expected first-detection range| [m]")):
        finite = [e for e in err if 0 < e < math.inf]
        floor = min([tol, *finite]) / 3 if tol > 0 else min(finite, default=1.0) / 3
        ceiling = 3 * max([tol, *finite])
        # zero drawn at a floor below everything, "never detected by one side" above
        shown = [floor if e <= 0 else (ceiling if math.isinf(e) else e) for e in err]
        front = tolerated_front(cost, err, [c.ok for c in comps])
        for i, c in enumerate(comps):
            rec = c is study.recommended_comparison
            marker = "*" if rec else ("^" if math.isinf(err[i]) else
                                      ("v" if err[i] <= 0 else "o"))
            color = "tab:green" if rec else ("tab:blue" if c.ok else "tab:red")
            ax.errorbar(cost[i], shown[i], xerr=[[lo[i]], [hi[i]]], fmt="none",
                        ecolor=color, elinewidth=0.8, alpha=0.6, zorder=2)
            ax.scatter(cost[i], shown[i], s=110 if rec else 30, c=color, marker=marker,
                       zorder=3)
        labels = [("combined" if c.result.setting.kind == "combined"
                   else c.result.setting.label) for c in comps]
        ax.plot([cost[i] for i in front], [shown[i] for i in front], "k--", lw=1,
                label="Pareto front (inside the tolerances)")
        ax.axhline(tol, color="tab:orange", lw=1, label="tolerance")
        ax.axvline(1.0 - SAVING_MIN, color="0.6", lw=0.8, ls=":",
                   label=f"cheaper: interval left of {1 - SAVING_MIN:g}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"{study.objective} CPU / the reference's ({CONFIDENCE:.0%} interval)")
        ax.set_ylabel(name)
        ax.grid(True, which="both", alpha=0.3)
        # below the axes: the labels then have the whole plot
        ax.legend(fontsize=8, title="▼ zero, ▲ detected by one side only", title_fontsize=7,
                  loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2)
        place_labels(ax, cost, shown, labels)
    fig.suptitle(f"{study.scenario.name}: error against cost ({study.duration_s:g} s, "
                 f"{len(study.seeds)} run(s), {study.pairs} timing pairs; blue inside the "
                 "tolerances, red outside, star recommended)", fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)


#: Label offsets tried around a point, in points (nearest first).
_LABEL_OFFSETS = [(dx * r, dy * r) for r in (1, 1.6, 2.4, 3.5, 5, 7)
                  for dx, dy in ((5, 4), (5, -11), (-5, 4), (-5, -11), (0, 12), (0, -18))]


def place_labels(ax: Any, x: Sequence[float], y: Sequence[float], labels: Sequence[str]
                 ) -> list[Any]:
    """Annotate each point with its label where it overlaps no other label or point.

    Greedy: the offsets of :data:`_LABEL_OFFSETS` are tried nearest first, and a label
    goes to the first place whose box (as drawn) lies inside the axes and meets no placed
    label and no marker; a label with no free place takes the farthest, with a leader line.
    Points at the same place share one label. Returns the annotations.
    """
    fig = ax.figure
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    groups: dict[tuple[float, float], list[str]] = {}
    for xi, yi, lb in zip(x, y, labels, strict=True):
        groups.setdefault((xi, yi), []).append(lb)
    pts = ax.transData.transform(np.array(list(groups), dtype=float))
    dots = [matplotlib_bbox(px - 4, py - 4, px + 4, py + 4) for px, py in pts]
    frame = ax.get_window_extent(renderer)
    placed: list[Any] = []
    boxes: list[Any] = []
    for (xy, names) in groups.items():
        text = ", ".join(names)
        ann = None
        for k, (dx, dy) in enumerate(_LABEL_OFFSETS):
            far = k == len(_LABEL_OFFSETS) - 1
            ann = ax.annotate(text, xy, xytext=(dx, dy), textcoords="offset points",
                              fontsize=6.5, ha="left" if dx >= 0 else "right",
                              arrowprops={"arrowstyle": "-", "lw": 0.4, "color": "0.5"}
                              if abs(dx) > 10 or abs(dy) > 20 else None)
            box = text_box(ann, renderer).expanded(1.02, 1.1)
            inside = (frame.x0 <= box.x0 and box.x1 <= frame.x1 and frame.y0 <= box.y0
                      and box.y1 <= frame.y1)
            if far or (inside and not any(box.overlaps(b) for b in boxes + dots)):
                break
            ann.remove()
        assert ann is not None
        boxes.append(text_box(ann, renderer))
        placed.append(ann)
    return placed


def text_box(ann: Any, renderer: Any) -> Any:
    """The box of an annotation's text alone (its leader line left out) [display units]."""
    from matplotlib.text import Text

    ann.update_positions(renderer)  # what Annotation.get_window_extent does first
    return Text.get_window_extent(ann, renderer)


def matplotlib_bbox(x0: float, y0: float, x1: float, y1: float) -> Any:
    """A display-coordinate box (matplotlib's Bbox)."""
    from matplotlib.transforms import Bbox

    return Bbox([[x0, y0], [x1, y1]])
