"""``shipradar plot SCENARIO geometry``: the scene on a map before running it.

Every target's and platform's trajectory (segments, rounded corners or waypoints, exactly as
the engine flies them: :mod:`shipradar.sim.world.trajectory`) in the origin's east/north frame [km],
with a tick and its time every ``tick_s`` seconds, and for each radar a coverage contour around its
platform's start for a chosen target height: the instrumented range cut by the 4/3-earth
radio horizon √(2 k a h_a) + √(2 k a h_t) (the geometric limit; ``plot coverage`` gives the
detection probability).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from shipradar.sensors.geometry import EARTH_RADIUS_M, K_FACTOR
from shipradar.sim.world.kinematics import LocalFrame
from shipradar.sim.world.scenario import Platform, Scenario, Target
from shipradar.sim.world.trajectory import trajectories


def horizon_range_m(antenna_height_m: float, target_height_m: float,
                    k_factor: float = K_FACTOR) -> float:
    """Radio horizon range between two heights on the k-earth [m]: √(2 k a h1) + √(2 k a h2)."""
    a_e = k_factor * EARTH_RADIUS_M
    return math.sqrt(2 * a_e * antenna_height_m) + math.sqrt(2 * a_e * max(target_height_m, 0))


def sampled_tracks(scenario: Scenario, step_s: float = 1.0):
    """``(kind, id, times (K,) [s], positions (K, 3) [m])`` of every platform and target,
    sampled every ``step_s`` over its existence within the scenario's duration."""
    frame = LocalFrame(scenario.origin)
    out = []
    groups: tuple[tuple[str, Sequence[Platform | Target], bool], ...] = (
        ("platform", scenario.platforms, True), ("target", scenario.targets, False))
    for kind, objs, hold in groups:
        if not objs:
            continue
        tr = trajectories(objs, frame, hold=hold)
        for i, o in enumerate(objs):
            t0 = 0.0 if hold else max(0.0, float(tr.t_first[i]))
            t1 = scenario.duration_s if hold else min(scenario.duration_s, float(tr.t_last[i]))
            t = np.append(np.arange(t0, t1, step_s), t1) if t1 > t0 else np.array([t0])
            pos, _, _ = tr.state(t, np.full(t.size, i))
            out.append((kind, o.id, t, pos))
    return out


def render_geometry(scenario: Scenario, out_dir: Path, *, height_m: float = 10.0,
                    tick_s: float | None = None, radar_id: str | None = None) -> list[Path]:
    """Write ``geometry.png`` (the scene's map) into ``out_dir``; returns the files written.

    Parameters
    ----------
    scenario : Scenario
        A validated scenario.
    out_dir : Path
        Output directory (created).
    height_m : float
        Target height of the coverage contours [m].
    tick_s : float, optional
        Time between ticks [s]; default about a tenth of the duration, rounded.
    radar_id : str, optional
        Only this radar's contour (default: every radar).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if tick_s is None:
        raw = scenario.duration_s / 10.0
        tick_s = min((s for s in (1, 2, 5, 10, 15, 20, 30, 60, 120, 300, 600, 1800, 3600)
                      if s >= raw), default=3600)
    fig, ax = plt.subplots(figsize=(9, 9))
    tracks = sampled_tracks(scenario, step_s=min(1.0, tick_s / 5.0))
    for kind, oid, t, pos in tracks:
        e, n = pos[:, 0] / 1e3, pos[:, 1] / 1e3
        style = {"color": "k", "lw": 2.0} if kind == "platform" else {"lw": 1.2}
        line, = ax.plot(e, n, **style, label=f"{oid} ({kind})")
        ax.plot(e[0], n[0], "o", color=line.get_color(), ms=5)
        ticks = np.arange(math.ceil(t[0] / tick_s) * tick_s, t[-1] + 1e-9, tick_s)
        if ticks.size:
            te = np.interp(ticks, t, e)
            tn = np.interp(ticks, t, n)
            ax.plot(te, tn, "|", color=line.get_color(), ms=8, mew=1.5)
            for x, y, s in zip(te, tn, ticks, strict=True):
                ax.annotate(f"{s:g}s", (x, y), fontsize=7, color=line.get_color(),
                            xytext=(3, 3), textcoords="offset points")
    tracks_by_id = {oid: pos for kind, oid, _, pos in tracks if kind == "platform"}
    theta = np.linspace(0, 2 * np.pi, 361)
    for platform, radar in scenario.radars():
        if radar_id is not None and radar.id != radar_id:
            continue
        start = tracks_by_id[platform.id][0]
        r = min(radar.instrumented_range_m,
                horizon_range_m(radar.antenna_height_m + start[2], height_m)) / 1e3
        ax.plot(start[0] / 1e3 + r * np.sin(theta), start[1] / 1e3 + r * np.cos(theta), "--",
                lw=0.8, label=f"{radar.id}: coverage at {height_m:g} m ({r:.1f} km)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east of origin [km]")
    ax.set_ylabel("north of origin [km]")
    ax.set_title(f"{scenario.name}: trajectories, ticks every {tick_s:g} s")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=7, loc="best")
    path = out / "geometry.png"
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return [path]
