"""Figures of one scenario's tables, for ``shipradar plot SCENARIO WHAT``.

``render(scenario, what, out_dir)`` writes PNG files and returns their paths:

* ``propagation``: F against range at one target height for each radar, standard atmosphere
  and the scene's duct (the seed's Fig. 4 layout);
* ``coverage``: the range-height coverage diagram of each radar's PE table (when the scene
  has one);
* ``clutter``: the seed's Fig. 6 case (σ0* with and without a 10 m duct, 9.8 GHz VP), the same
  picture at each radar's own frequency, polarization, antenna height, wind, waves and duct,
  and PPI pictures of each radar's sea-clutter map (power, Weibull a) and, when it rains, of
  its weather-clutter map;
* ``improvement``: the seed's Fig. 7 (five FIR filters of 32 Hann taps) and each radar's own
  I_F table against normalized Doppler at a few clutter spreads;
* ``all``: everything above.

Tables come from the table cache (built when missing) through :mod:`shipradar.tables.scene`, so the
pictures show exactly what a run reads.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from shipradar.sim.world.scenario import Scenario

WHATS = ("propagation", "coverage", "clutter", "improvement")


def _scene_tables(scenario: Scenario, kinds: Iterable[str], radar_id: str | None):
    """``{(radar_id, kind): table}`` for the requested kinds, from the cache or built."""
    from shipradar.tables.scene import table_specs

    kinds = set(kinds)
    out = {}
    for spec in table_specs(scenario):
        if spec.kind in kinds and (radar_id is None or spec.radar_id == radar_id):
            out[spec.radar_id, spec.kind] = spec.make()
    return out


def _radars(scenario: Scenario, radar_id: str | None):
    radars = [r for _, r in scenario.radars() if radar_id is None or r.id == radar_id]
    if radar_id is not None and not radars:
        known = ", ".join(r.id for _, r in scenario.radars())
        raise ValueError(f"no radar {radar_id!r} in the scenario (radars: {known})")
    return radars


def _clutter(scenario: Scenario, out: Path, radar_id: str | None) -> list[Path]:
    from shipradar.sensors import sea_clutter as sc
    from shipradar.sim.studies.figures.case import SeaCase
    from shipradar.sim.studies.figures.clutter import plot_clutter_ppi, plot_ducting_reflectivity
    from shipradar.tables.scene import duct_height_m

    written = [plot_ducting_reflectivity(out / "fig6_seed_ducting_reflectivity.png")]
    env = scenario.environment
    duct = duct_height_m(scenario)
    for radar in _radars(scenario, radar_id):
        if not (sc.GIT_EXTRAPOLATION_MIN_FREQ_HZ <= radar.frequency_hz <= sc.GIT_MAX_FREQ_HZ):
            continue
        written.append(plot_ducting_reflectivity(
            out / f"{radar.id}_ducting_reflectivity.png",
            SeaCase.of_radar(radar, scenario, min(radar.instrumented_range_m, 100e3)),
            duct_height_m=duct if duct >= sc.MIN_DUCT_HEIGHT_M else 10.0,
            wind_speed_mps=env.wind_speed_mps,
        ))
    if not scenario.fidelity.clutter:
        return written
    tables = _scene_tables(scenario, ("sea_clutter", "weather_clutter"), radar_id)
    for (rid, kind), table in sorted(tables.items()):
        written.append(plot_clutter_ppi(out / f"{rid}_{kind}_ppi.png", table))
        if kind == "sea_clutter":
            written.append(plot_clutter_ppi(out / f"{rid}_{kind}_weibull_a_ppi.png", table,
                                            array="weibull_a"))
    return written


def _improvement(scenario: Scenario, out: Path, radar_id: str | None) -> list[Path]:
    from shipradar.sim.studies.figures.doppler import (
        plot_improvement_table,
        plot_improvement_vs_doppler,
    )
    from shipradar.tables.scene import improvement_kwargs

    written = [plot_improvement_vs_doppler(out / "fig7_seed_improvement_vs_doppler.png")]
    from shipradar.tables.improvement import improvement_table

    for radar in _radars(scenario, radar_id):
        kw = improvement_kwargs(scenario, radar)
        if kw is None:
            continue
        table, _ = improvement_table(radar.processor.type, **kw)
        written.append(plot_improvement_table(
            out / f"{radar.id}_improvement_vs_doppler.png", table, title=radar.id))
    return written


def _propagation(scenario: Scenario, out: Path, radar_id: str | None,
                 height_m: float) -> list[Path]:
    from shipradar.sim.studies.figures.case import SeaCase
    from shipradar.sim.studies.figures.propagation import plot_factor_vs_range
    from shipradar.tables.scene import duct_height_m

    duct = duct_height_m(scenario)
    ducts = (0.0,) if duct < 1.0 else (0.0, duct)
    written = []
    for radar in _radars(scenario, radar_id):
        written.append(plot_factor_vs_range(
            out / f"{radar.id}_factor_vs_range.png",
            SeaCase.of_radar(radar, scenario, min(radar.instrumented_range_m, 60e3)),
            target_height_m=height_m,
            duct_heights_m=ducts,
        ))
    return written


def _coverage(scenario: Scenario, out: Path, radar_id: str | None) -> list[Path]:
    from shipradar.sim.studies.figures.propagation import plot_coverage

    tables = _scene_tables(scenario, ("propagation",), radar_id)
    return [plot_coverage(out / f"{rid}_coverage.png", table)
            for (rid, _), table in sorted(tables.items())]


def render(scenario: Scenario, what: str, out_dir: Path, *, radar_id: str | None = None,
           height_m: float = 10.0) -> list[Path]:
    """Write the PNG figures ``what`` (one of :data:`WHATS` or ``"all"``) into ``out_dir``.

    Parameters
    ----------
    scenario : Scenario
        A validated scenario.
    what : str
        ``"propagation"``, ``"coverage"``, ``"clutter"``, ``"improvement"`` or ``"all"``.
    out_dir : Path
        Output directory (created).
    radar_id : str, optional
        Only this radar (default: every radar).
    height_m : float
        Target height of the F-against-range picture [m].

    Returns
    -------
    list of Path
        The files written.
    """
    if what != "all" and what not in WHATS:
        raise ValueError(f"what must be one of {WHATS + ('all',)}, got {what!r}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    todo = WHATS if what == "all" else (what,)
    written: list[Path] = []
    for item in todo:
        if item == "propagation":
            written += _propagation(scenario, out, radar_id, height_m)
        elif item == "coverage":
            written += _coverage(scenario, out, radar_id)
        elif item == "clutter":
            written += _clutter(scenario, out, radar_id)
        else:
            written += _improvement(scenario, out, radar_id)
    return written
