"""The study as text and tables: the stdout report, the per-target lines, the
ready-to-paste ``fidelity:`` block and the CSV.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from shipradar.sim.studies.fidelity.compare import Comparison, format_range_m
from shipradar.sim.studies.fidelity.plan import diff_label, format_value
from shipradar.sim.studies.fidelity.trade import Study
from shipradar.sim.studies.timing import (
    CONFIDENCE,
    SAVING_MIN,
    is_cheaper,
    mean_interval,
)
from shipradar.sim.world.scenario import Fidelity


def fidelity_yaml(fid: dict[str, Any], unread: Sequence[str] = ()) -> str:
    """A ready-to-paste ``fidelity:`` block (every choice explicit, schema order); the
    choices in ``unread`` (the scene does not read them under this block) are left out,
    named in a comment."""
    block = Fidelity(**fid).model_dump()
    lines = ["fidelity:"]
    for k, v in block.items():
        if k not in unread:
            lines.append(f"  {k}: {format_value(v)}")
    if unread:
        lines.append(f"  # not read by this scene with this block: {', '.join(unread)}")
    return "\n".join(lines) + "\n"


def format_per_target(study: Study) -> str:
    """One line per setting and (radar, target): the per-target columns of the CSV."""
    out = ["per target (mean|ΔPd|, max|ΔPd|, E[det] ref -> setting, |ΔE[R1]| m, "
           "realized detections ref -> setting):"]
    for c in study.comparisons:
        label = c.result.setting.label
        for r in c.rows:
            out.append(
                f"  {label:28.28s} {r['radar'] + '/' + r['target']:24.24s} "
                f"{r['mean_abs_dpd']:.4f} {r['max_abs_dpd']:.3f}  "
                f"{r['expected_detections_ref']:6.1f} -> {r['expected_detections']:6.1f}  "
                f"{'inf' if math.isinf(r['abs_dfirst_m']) else format(r['abs_dfirst_m'], '.0f'):>6}"
                f"  {r['detections_ref']:5.1f} -> {r['detections']:5.1f}")
    return "\n".join(out)


def _cost_cells(study: Study, c: Comparison) -> tuple[str, str, str, str]:
    """Warm run CPU and first run as ratios to the reference, table load [s], build [s]."""
    cost = study.cost(c)
    if cost is None:
        return "-", "-", "-", "-"
    p = cost.paired
    if p is None:  # the reference: its own seconds, over every pair
        ref = study.costs
        samples = [s for k in ref.values() if k.paired is not None for s in k.paired.reference]
        warm = mean_interval([s.warm_run_s for s in samples])
        first = mean_interval([s.first_s for s in samples])
        load = mean_interval([s.load_s for s in samples])
        run = f"{warm.fmt(3)} s"
        first_s = f"{first.fmt(3)} s"
    else:
        run = p.warm_ratio.fmt() + "x" + ("*" if is_cheaper(p.warm_ratio) else "")
        first_s = p.first_ratio.fmt() + "x" + ("*" if is_cheaper(p.first_ratio) else "")
        load = p.seconds("load_s")
    build = (cost.build.fmt(2) if cost.build is not None else
             f"~{cost.build_estimate_s:.2g} est.")
    return run, first_s, load.fmt(3), build


def format_report(study: Study) -> str:
    """The stdout table, the skipped choices and the recommendation."""
    s = study.scenario
    tol = study.tolerances
    out = [f"shipradar fidelity: {s.name}, {study.duration_s:g} s simulated x "
           f"{len(study.seeds)} run(s); reference {diff_label(study.reference, {})}",
           f"tolerances: mean |ΔP_d| per look <= {tol.pd:g} per target; |Δ expected "
           f"first-detection range| <= {tol.range_m:g} m; expected FA/scan within "
           f"{tol.fa_rel:.0%}; latency <= {tol.latency_s:.3g} s",
           f"cost: CPU seconds, {study.pairs} alternating pairs (reference, setting) per "
           f"setting, {CONFIDENCE:.0%} intervals; the recommendation minimises the "
           + ("per-run CPU (warm: the 2nd and later runs of a Monte Carlo study)"
              if study.objective == "per-run" else
              "first run's CPU (table load + the first run of a process)"), ""]
    if study.shortened:
        out[-1:] = [_shortened_warning(study), ""]
    head = ("setting", "mean|ΔPd|", "max|ΔPd|", "worst tgt", "ΔE[det]", "Δdet",
            "max|ΔE[R1]|m", "max|ΔR1|m", "FA/scan n+c", "run CPU (warm)", "first run",
            "load s", "build s", "ok")
    rows = []
    for c in study.comparisons:
        t, r = c.total, c.result
        label = r.setting.label if r.setting.kind != "combined" else (
            "combined: " + diff_label(r.setting.fidelity, study.reference))
        if not r.setting.exercised:
            label += " (not exercised)"
        rows.append((
            label, f"{t['mean_abs_dpd']:.4f}", f"{t['max_abs_dpd']:.3f}",
            f"{t['worst_target_mean_abs_dpd']:.4f}", f"{t['d_expected_detections']:+.2f}",
            f"{t['d_detections']:+.1f}",
            "inf" if math.isinf(t["max_abs_dfirst_m"]) else f"{t['max_abs_dfirst_m']:.0f}",
            ("inf" if math.isinf(t["max_realized_abs_dfirst_m"])
             else f"{t['max_realized_abs_dfirst_m']:.0f}"),
            f"{t['noise_fa_per_scan']:.3g}+{t['clutter_fa_per_scan']:.3g}",
            *_cost_cells(study, c), "yes" if c.ok else "no"))
    widths = [max(len(h), *(len(x[i]) for x in rows)) for i, h in enumerate(head)]
    out.append("  ".join(h.ljust(w) if i == 0 else h.rjust(w)
                         for i, (h, w) in enumerate(zip(head, widths, strict=True))))
    for x in rows:
        out.append("  ".join(v.ljust(w) if i == 0 else v.rjust(w)
                             for i, (v, w) in enumerate(zip(x, widths, strict=True))))
    out.append("(E[...]: expected from the looks' P_d, dice-free; Δdet, |ΔR1|: realized with "
               "common random numbers. FA/scan: expected noise + sea-clutter false alarms per "
               "scan, all radars. run CPU (warm), first run: the setting's CPU over the "
               "reference's, geometric mean of the pairs [interval], * measurably cheaper "
               f"(whole interval below {1 - SAVING_MIN:g}); the reference's row in seconds. "
               "first run = table load + the first run on the loaded tables; load s: the "
               "tables read from the cache, once per process; build s: once per cache, "
               + ("measured (--cold)" if study.builds_measured else
                  "the cost model's estimate (--cold measures it)") + ")")
    if study.skipped:
        out.append("")
        out.append("not run (the scene does not exercise them):")
        for choice, why in study.skipped:
            out.append(f"  {choice}: {why}")
    bad = [c for c in study.comparisons if not c.ok and c.result.setting.kind != "reference"]
    if bad:
        out.append("")
        out.append("outside the tolerances:")
        for c in bad:
            out.append(f"  {c.result.setting.label}: {'; '.join(c.violations[:3])}"
                       + (f" (+{len(c.violations) - 3} more)" if len(c.violations) > 3 else ""))
    if study.undecided:
        out.append("")
        out.append(f"within noise (inside the tolerances; the {study.objective} interval "
                   f"straddles {1 - SAVING_MIN:g}x, so neither cheaper nor not: more --pairs "
                   "may decide):")
        for u in study.undecided:
            out.append(f"  {u}x")
    for n in study.notes:
        out.append(f"note: {n}")
    out.append("")
    out += _recommendation_lines(study)
    out.append("")
    out.append(f"command: {len(study.comparisons)} settings in {study.wall_s:.1f} s wall")
    return "\n".join(out)


def _shortened_warning(study: Study) -> str:
    return (f"WARNING: shortened study ({study.duration_s:g} s of the scene's "
            f"{study.scenario.duration_s:g} s): the recommendation holds for the first "
            f"{study.duration_s:g} s only; --apply refuses it unless --allow-shortened")


def _recommendation_lines(study: Study) -> list[str]:
    out = []
    rc = study.recommended_comparison
    label = diff_label(study.recommended, study.reference)
    if label == "reference":
        out.append("recommended: the reference (no setting inside the tolerances is "
                   f"measurably cheaper by {study.objective} CPU)")
    else:
        out.append(f"recommended (cheapest by {study.objective} CPU inside the tolerances; "
                   f"{label}):")
    cost = study.recommended_cost
    if cost is not None:
        warm, first = cost.saving_s("warm_run_s"), cost.saving_s("first_s")
        out.append(f"  the block re-timed as a whole ({cost.warm_ratio.n} fresh alternating "
                   f"pairs): run CPU (warm) {cost.warm_ratio.fmt()}x the reference's, saving "
                   f"{warm.fmt(3)} s per run (reference "
                   f"{cost.seconds('warm_run_s', 'reference').fmt(3)} s); first run (table "
                   f"load + run) {cost.first_ratio.fmt()}x, saving {first.fmt(3)} s per "
                   f"process (reference {cost.seconds('first_s', 'reference').fmt(3)} s; a "
                   "process's start-up and imports, the same for both, are not in these "
                   "seconds: the saving carries over to a whole process, the ratio does not)")
    if rc is not None and rc.result.setting.kind != "reference":
        t = rc.total
        out.append(f"  accuracy of the block as a whole: mean |ΔP_d| {t['mean_abs_dpd']:.4f}, "
                   f"worst target {t['worst_target_mean_abs_dpd']:.4f}, largest "
                   f"|Δ expected first-detection range| {format_range_m(t['max_abs_dfirst_m'])}")
    if study.shortened:
        out.append("  " + _shortened_warning(study))
    out.append("")
    out.append(fidelity_yaml(study.recommended, study.unread).rstrip())
    return out


CSV_COLUMNS = ("setting", "kind", "choice", "value", "exercised", "radar", "target", "looks",
               "mean_abs_dpd", "max_abs_dpd", "mean_pd_ref", "mean_pd",
               "expected_detections_ref", "expected_detections", "d_expected_detections",
               "detections_ref", "detections", "d_detections", "p_detected_ref", "p_detected",
               "expected_first_range_ref_m", "expected_first_range_m", "abs_dfirst_m",
               "first_range_ref_m", "first_range_m", "realized_abs_dfirst_m",
               "expected_noise_fa_per_scan",
               "expected_clutter_fa_per_scan", "drawn_noise_fa_per_scan",
               "drawn_clutter_fa_per_scan", "latency_s", "pairs",
               "warm_run_ratio", "warm_run_ratio_low", "warm_run_ratio_high",
               "first_run_ratio", "first_run_ratio_low", "first_run_ratio_high",
               "warm_run_s", "first_run_s", "warm_saving_s", "warm_saving_s_low",
               "warm_saving_s_high", "first_saving_s", "first_saving_s_low",
               "first_saving_s_high", "load_s", "load_s_low", "load_s_high",
               "build_s", "build_s_low", "build_s_high", "build_estimated_s",
               "cheaper", "within_tolerance")


def _cost_columns(study: Study, c: Comparison) -> dict[str, Any]:
    """The CSV's cost columns of one setting (ratios to the reference with their
    intervals; the reference's own rows hold its seconds)."""
    cost = study.cost(c)
    out: dict[str, Any] = {"pairs": study.pairs}
    if cost is None:
        return out
    if cost.build is not None:
        out.update(build_s=cost.build.value, build_s_low=cost.build.low,
                   build_s_high=cost.build.high)
    out["build_estimated_s"] = cost.build_estimate_s
    p = cost.paired
    if p is None:
        samples = [s for k in study.costs.values() if k.paired is not None
                   for s in k.paired.reference]
        out["warm_run_s"] = mean_interval([s.warm_run_s for s in samples]).value
        out["first_run_s"] = mean_interval([s.first_s for s in samples]).value
        load = mean_interval([s.load_s for s in samples])
    else:
        for name, r in (("warm_run_ratio", p.warm_ratio), ("first_run_ratio", p.first_ratio)):
            out.update({name: r.value, f"{name}_low": r.low, f"{name}_high": r.high})
        out["warm_run_s"] = p.seconds("warm_run_s").value
        out["first_run_s"] = p.seconds("first_s").value
        for name, what in (("warm_saving_s", "warm_run_s"), ("first_saving_s", "first_s")):
            d = p.saving_s(what)
            out.update({name: d.value, f"{name}_low": d.low, f"{name}_high": d.high})
        out["cheaper"] = is_cheaper(p.ratio(study.objective))
        load = p.seconds("load_s")
    out.update(load_s=load.value, load_s_low=load.low, load_s_high=load.high)
    return out


def write_csv(study: Study, path: Path) -> None:
    """One row per setting and (radar, target), and one ``*`` total row per setting."""
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(CSV_COLUMNS)
        for c in study.comparisons:
            r, t = c.result, c.total
            s = r.setting
            common = {
                "setting": s.label if s.kind != "combined" else
                "combined: " + diff_label(s.fidelity, study.reference),
                "kind": s.kind, "choice": s.choice or "", "value": "" if s.value is None
                else format_value(s.value), "exercised": s.exercised,
                "latency_s": t["latency_s"], **_cost_columns(study, c),
                "within_tolerance": c.ok,
            }
            for row in c.rows:
                e = t["expected_fa"]
                full = {**common, **row,
                        "expected_noise_fa_per_scan": e.get(f"{row['radar']}:noise", ""),
                        "expected_clutter_fa_per_scan": e.get(f"{row['radar']}:sea_clutter",
                                                              "")}
                w.writerow([_csv(full.get(k, "")) for k in CSV_COLUMNS])
            tot = {**common, "radar": "*", "target": "*", "looks": t["looks"],
                   "mean_abs_dpd": t["mean_abs_dpd"], "max_abs_dpd": t["max_abs_dpd"],
                   "detections": t["detections"], "d_detections": t["d_detections"],
                   "d_expected_detections": t["d_expected_detections"],
                   "abs_dfirst_m": t["max_abs_dfirst_m"],
                   "realized_abs_dfirst_m": t["max_realized_abs_dfirst_m"],
                   "expected_noise_fa_per_scan": t["noise_fa_per_scan"],
                   "expected_clutter_fa_per_scan": t["clutter_fa_per_scan"],
                   "drawn_noise_fa_per_scan": t["drawn_noise_fa_per_scan"],
                   "drawn_clutter_fa_per_scan": t["drawn_clutter_fa_per_scan"]}
            w.writerow([_csv(tot.get(k, "")) for k in CSV_COLUMNS])


def _csv(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return "inf" if math.isinf(v) else repr(v)
    return str(v)
