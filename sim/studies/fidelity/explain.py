"""The parts of the model a scene exercises and those it skips, each with its reason.

Decided from the scenario alone (``shipradar validate --explain``); the fidelity study
runs the alternatives of a choice only where a part it changes is exercised.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from shipradar.sim.world.scenario import Jammer, Radar, Scenario, Target


@dataclass(frozen=True)
class Part:
    """One part of the radar model and whether the scene exercises it.

    Attributes
    ----------
    name : str
        The part (e.g. ``"weather clutter [39]-[45]"``).
    exercised : bool
        True when the scene reads it.
    reason : str
        Why it is exercised or skipped.
    radar : str or None
        The radar it concerns, None for the whole scene.
    choice : str or None
        The ``fidelity`` choice it makes relevant, if any.
    """

    name: str
    exercised: bool
    reason: str
    radar: str | None = None
    choice: str | None = None


def explain(scenario: Scenario) -> list[Part]:
    """The parts of the model the scene exercises and those it skips, each with its reason.

    Decided from the scenario alone (nothing is run): no rain, no weather clutter; no jammer,
    no jamming; a low-resolution radar, no sea-clutter false alarms; targets above the PE
    table's top, the two-ray model for them; and so on.

    Parameters
    ----------
    scenario : Scenario
        The validated scene.

    Returns
    -------
    list of Part
        The targets' parts, propagation, atmosphere, jamming, then each radar's parts.
    """
    out = _target_parts(scenario)
    out += _propagation_parts(scenario)
    out.append(_atmosphere_part(scenario))
    n_j = len(scenario.jammers)
    out.append(Part("stand-off jamming [47]-[48]", n_j > 0,
                    f"{n_j} jammer(s)" if n_j else "no jammer: S/J not computed"))
    for _platform, radar in scenario.radars():
        out += _radar_parts(scenario, radar)
    return out


def _movers(scenario: Scenario) -> list[Target | Jammer]:
    """The scene's targets and jammers (what propagation and the atmosphere are read for)."""
    return [*scenario.targets, *scenario.jammers]


def _target_parts(scenario: Scenario) -> list[Part]:
    """The echo, S/I and P_d chain, and unresolved targets."""
    n_t = len(scenario.targets)
    name = "target echo, S/I and P_d [2]-[3], [66]-[83]"
    if n_t:
        cases = sorted({t.swerling_case for t in scenario.targets})
        echo = Part(name, True, f"{n_t} target(s), Swerling {cases}; P_d method "
                                f"{scenario.fidelity.pd_method!r}", choice="pd_method")
    else:
        echo = Part(name, False, "no targets: only false alarms are drawn", choice="pd_method")
    merge = Part("unresolved targets (2.2.1)", n_t > 1,
                 f"{n_t} targets may share a cell" if n_t > 1 else
                 "fewer than two targets: nothing to merge")
    return [echo, merge]


def _propagation_parts(scenario: Scenario) -> list[Part]:
    """The PE table and the two-ray fallback: which movers are inside the PE table's height
    (:data:`shipradar.tables.scene.PE_MAX_HEIGHT_M`) and which above it."""
    from shipradar.tables.scene import PE_MAX_HEIGHT_M

    fid = scenario.fidelity
    movers = _movers(scenario)
    if not movers:
        return [Part("propagation factor F [4]-[7]", False, "no targets or jammers",
                     choice="propagation")]
    if fid.propagation != "pe":
        other = "two-ray model" if fid.propagation == "two_ray" else "pattern alone"
        return [Part("PE table [5]-[7]", False,
                     f"fidelity.propagation is {fid.propagation!r}: F by the {other}",
                     choice="propagation")]
    top = PE_MAX_HEIGHT_M
    # highest altitude including climbs and pop-ups where the schema knows them
    above = sorted(m.id for m in movers if min(w.altitude_m for w in m.waypoints) > top)
    partly = sorted(m.id for m in movers if m.max_altitude_m > top and m.id not in above)
    inside = [m.id for m in movers if m.id not in above]
    if inside:
        pe = Part("PE table [5]-[7]", True,
                  f"{len(inside)} target(s)/jammer(s) at or below its {top:g} m top; "
                  f"{_refractivity_description(scenario)}; grid {fid.pe_grid!r}",
                  choice="pe_grid")
    else:
        pe = Part("PE table [5]-[7]", False,
                  f"every target is above the PE table's {top:g} m top: two-ray",
                  choice="pe_grid")
    if above or partly:
        what = []
        if above:
            what.append(f"always above {top:g} m: {', '.join(above)}")
        if partly:
            what.append(f"partly above: {', '.join(partly)}")
        why = "targets above the PE domain use two-ray (" + "; ".join(what) + ")"
    else:
        why = ("only for points outside the PE table (steep angles, beyond its range), "
               "counted as propagation_fallbacks")
    return [pe, Part("two-ray fallback (3.1.2)", True, why, choice="propagation")]


def _refractivity_description(scenario: Scenario) -> str:
    """The scene's M-profile in words (standard, a profile, an evaporation duct)."""
    from shipradar.tables.scene import duct_height_m

    duct = scenario.environment.duct
    if duct is None:
        return "standard atmosphere"
    if duct.type == "profile":
        return f"M-profile of {len(duct.heights_m)} points"
    return f"evaporation duct {duct_height_m(scenario):.3g} m" + (
        " (bulk model)" if duct.type == "bulk" else "")


def _atmosphere_part(scenario: Scenario) -> Part:
    """Atmospheric attenuation [16]: gases, fog and rain."""
    name = "atmospheric attenuation [16]"
    env = scenario.environment
    if not _movers(scenario):
        return Part(name, False, "no targets or jammers", choice="atmosphere")
    if not scenario.fidelity.atmosphere:
        return Part(name, False, "fidelity.atmosphere is false", choice="atmosphere")
    bits = ["gases (ITU-R P.676)", "fog (P.840)" if env.fog else "no fog",
            "rain (P.838)" if env.rain else "no rain"]
    return Part(name, True, ", ".join(bits), choice="atmosphere")


def _radar_parts(scenario: Scenario, r: Radar) -> list[Part]:
    """One radar's clutter, processor and false-alarm parts."""
    from shipradar.sensors.radar import radar_constants
    from shipradar.sensors.sea_clutter import is_medium_high_resolution

    fid, env = scenario.fidelity, scenario.environment
    clutter_off = "fidelity.clutter is false"
    k = radar_constants(scenario, r)
    hi_res = bool(is_medium_high_resolution(k.theta_b, r.pulse_width_s))
    x = math.degrees(k.theta_b) * r.pulse_width_s * 1e6
    out = []
    sea = "sea clutter [21]-[38]"
    out.append(Part(sea, False, clutter_off, r.id, "clutter") if not fid.clutter else
               Part(sea, True, f"sea state {env.sea_state}, wave height "
                               f"{scenario.wave_height:g} m", r.id, "clutter"))
    wx = "weather clutter [39]-[45]"
    if env.rain is None:
        out.append(Part(wx, False, "no rain", r.id))
    elif not fid.clutter:
        out.append(Part(wx, False, clutter_off, r.id))
    else:
        out.append(Part(wx, True, f"rain {env.rain.rate_mm_h:g} mm/h ({env.rain.kind})", r.id))
    proc = r.processor.type
    dop = "Doppler processor, I_F table [49]-[62]"
    if proc == "none":
        out.append(Part(dop, False, "no processor", r.id, "improvement_grid"))
    elif not fid.clutter:
        out.append(Part(dop, False, f"{clutter_off} (I_F is read only against clutter)",
                        r.id, "improvement_grid"))
    else:
        out.append(Part(dop, True, f"{proc}; grid {fid.improvement_grid!r}", r.id,
                        "improvement_grid"))
    cfa = "sea-clutter false alarms [94]-[96]"
    if not hi_res:
        out.append(Part(cfa, False, f"low resolution (θ_b τ' = {x:.2g} deg µs, τ' = "
                                    f"{r.pulse_width_s * 1e6:.3g} µs: Rayleigh clutter, seed "
                                    "4.1.2)", r.id, "clutter_fa_model"))
    elif not fid.clutter:
        out.append(Part(cfa, False, clutter_off, r.id, "clutter_fa_model"))
    else:
        out.append(Part(cfa, True, f"medium/high resolution (θ_b τ' = {x:.2g} deg µs); model "
                                   f"{fid.clutter_fa_model!r}, K_clutter {r.k_clutter:g}",
                        r.id, "clutter_fa_model"))
    out.append(Part("noise false alarms [90]-[93]", True,
                    f"t_fa = {r.false_alarm_time_s:g} s", r.id))
    return out


def explain_lines(scenario: Scenario) -> list[str]:
    """:func:`explain` as text lines, exercised parts first."""
    parts = explain(scenario)
    lines = ["exercised:"]
    for p in parts:
        if p.exercised:
            lines.append(f"  + {p.name}{f' ({p.radar})' if p.radar else ''}: {p.reason}")
    lines.append("skipped:")
    skipped = [p for p in parts if not p.exercised]
    for p in skipped:
        lines.append(f"  - {p.name}{f' ({p.radar})' if p.radar else ''}: {p.reason}")
    if not skipped:
        lines.append("  (nothing: the scene exercises every part)")
    return lines
