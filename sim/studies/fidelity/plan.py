"""The settings a fidelity study runs: the reference (the most accurate value of every
choice), one change at a time, and the scene's own block.
"""

from __future__ import annotations

import typing
from dataclasses import dataclass
from typing import Any

from shipradar.sim.studies.fidelity.explain import explain
from shipradar.sim.world.scenario import Fidelity, Scenario

#: Choices of ``fidelity:`` the command varies, in report order.
CHOICES = ("pd_method", "propagation", "pe_grid", "improvement_grid", "clutter_fa_model",
           "clutter", "atmosphere", "sectors_per_scan")
#: Sectors per scan tried below the scene's own (cost only: the model is unchanged).
SECTOR_CHOICES = (4, 12, 36)


@dataclass(frozen=True)
class Setting:
    """A fidelity setting to run: a label, the choice it changes and the full block."""

    label: str
    choice: str | None
    value: Any
    fidelity: dict[str, Any]
    exercised: bool = True
    kind: str = "alternative"  # "reference", "alternative", "scene", "combined"


def with_fidelity(scenario: Scenario, fid: dict[str, Any]) -> Scenario:
    """The scenario with another fidelity block, validated again (the exact P_d's check)."""
    data = scenario.model_dump(mode="python")
    data["fidelity"] = dict(fid)
    return Scenario.model_validate(data)


def _exact_pd_allowed(scenario: Scenario) -> bool:
    return all(r.detector == "square" and r.integrator == "uniform"
               for _, r in scenario.radars())


def reference_fidelity(scenario: Scenario) -> dict[str, Any]:
    """The most accurate setting of every choice (sectors per scan: the scene's own)."""
    return {
        "pd_method": "exact" if _exact_pd_allowed(scenario) else "seed",
        "propagation": "pe",
        "pe_grid": "fine",
        "improvement_grid": "fine",
        "sectors_per_scan": scenario.fidelity.sectors_per_scan,
        "clutter": True,
        "atmosphere": True,
        "clutter_fa_model": "weibull_median",
    }


def plan_settings(scenario: Scenario, *, include_unexercised: bool = False
                  ) -> tuple[dict[str, Any], list[Setting], list[tuple[str, str]]]:
    """The reference, the one-at-a-time alternatives and the choices skipped with reasons.

    Parameters
    ----------
    scenario : Scenario
        The scene.
    include_unexercised : bool
        Also run the alternatives of choices the scene does not exercise (they must then
        show zero differences; a test of the common random numbers). Sectors-per-scan
        values below the scene's are always run (their latency is judged by
        :class:`shipradar.sim.studies.fidelity.compare.Tolerances`).

    Returns
    -------
    reference : dict
        The reference fidelity block.
    settings : list of Setting
        The reference first, then the alternatives, then the scene's own setting when it
        differs from the reference.
    skipped : list of (choice, reason)
    """
    ref = reference_fidelity(scenario)
    parts = explain(scenario)

    def used(choice: str) -> tuple[bool, str]:
        rel = [p for p in parts if p.choice == choice]
        if any(p.exercised for p in rel):
            return True, ""
        return False, "; ".join(sorted({f"{p.radar + ': ' if p.radar else ''}{p.reason}"
                                        for p in rel})) or "not read by this scene"

    has_movers = bool(scenario.targets or scenario.jammers)
    alternatives: dict[str, list[Any]] = {
        # every other P_d method the schema offers (the seed's; a tabulated exact P_d)
        "pd_method": ([v for v in typing.get_args(Fidelity.model_fields["pd_method"].annotation)
                       if v != "exact"] if ref["pd_method"] == "exact" else []),
        "propagation": ["two_ray", "free_space"],
        "pe_grid": ["standard", "coarse"],
        "improvement_grid": ["standard", "coarse"],
        "clutter_fa_model": ["seed"],
        "clutter": [False],
        "atmosphere": [False],
        "sectors_per_scan": [n for n in SECTOR_CHOICES if n < ref["sectors_per_scan"]],
    }
    reasons = {
        "pd_method": (bool(scenario.targets), "no targets"),
        "propagation": (has_movers, "no targets or jammers"),
        "pe_grid": used("pe_grid"),
        "improvement_grid": used("improvement_grid"),
        "clutter_fa_model": used("clutter_fa_model"),
        "clutter": (True, ""),
        "atmosphere": (has_movers, "no targets or jammers"),
        "sectors_per_scan": (True, ""),
    }
    if not alternatives["pd_method"] and scenario.targets:
        reasons["pd_method"] = (False, "a radar's detector/integrator needs the seed method "
                                       "(the exact P_d is for square-law, uniform)")
    settings = [Setting("reference", None, None, ref, True, "reference")]
    skipped: list[tuple[str, str]] = []
    for choice in CHOICES:
        exercised, why = reasons[choice]
        values = alternatives[choice]
        if not values:
            if choice == "sectors_per_scan":
                why = f"already {ref['sectors_per_scan']} (no cheaper value tried)"
            skipped.append((choice, why or "no alternative"))
            continue
        if not exercised:
            skipped.append((choice, why))
            if not include_unexercised:
                continue
        for v in values:
            fid = {**ref, choice: v}
            settings.append(Setting(f"{choice}={format_value(v)}", choice, v, fid, exercised))
    own = scenario.fidelity.model_dump()
    if own != ref:
        settings.append(Setting("scene's own", None, None, own, True, "scene"))
    return ref, settings, skipped


def format_value(v: Any) -> str:
    return str(v).lower() if isinstance(v, bool) else str(v)



def diff_label(fid: dict[str, Any], ref: dict[str, Any]) -> str:
    d = [f"{k}={format_value(v)}" for k, v in fid.items() if ref.get(k) != v]
    return ", ".join(d) if d else "reference"
