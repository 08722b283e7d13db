"""``shipradar fidelity``: the speed/accuracy trade measured on the user's own scene (issue 18).

The scene is run under each fidelity choice that applies to it (``fidelity:`` in the scenario,
:class:`shipradar.sim.world.scenario.Fidelity`) and compared with the most accurate setting, the
*reference*, with **common random numbers**: every look (one radar, one target, one scan) gets one
uniform number derived from (run seed, radar, target, scan) alone, and is detected when it is below
that look's P_d (the dwell model's opt-in ``look_uniforms``, which a normal run leaves at
None); each look's P_d is read by an observer of the model's looks (``on_look``,
:class:`shipradar.sim.dwell.look.LookResults`). Two settings therefore differ only where their
P_d differ: the reference against itself gives exactly zero, and a change that the scene never
reads gives exactly zero too.

What is measured per setting, per (radar, target) and in total
---------------------------------------------------------------
* mean |ΔP_d| per look and its maximum (P_d of the same look under both settings);
* the change in detections: expected (Σ P_d over the looks, dice-free) and realized (looks
  whose uniform falls below P_d);
* the change in first-detection range [m]: expected, E[R_1 | detected] with
  P(first at look i) = p_i Π_{j<i}(1 - p_j) over the looks in order (slant range), and
  realized (the first detected look; it moves by a whole scan when one look's outcome
  flips, 1.5 km for a Mach-0.9 target and a 5 s scan, so the tolerance reads the expected);
* false alarms per scan by origin: the model's expected count per scan (noise: cells × P_fa
  [90]; sea clutter: Σ η of the P_fac map, seed 7.2), exact and dice-free, and the counts the
  run drew;
* the cost, as a user pays it (:mod:`shipradar.sim.studies.timing`): the run's CPU, warm
  (a Monte Carlo study's later replications) and first (table load + the first run of a
  process), each as the ratio to the reference's over alternating pairs with its interval;
  the table load [s] per process and the table build [s] per cache (measured with
  ``--cold``, else the cost model's estimate).

Tolerances (the recommendation keeps every (radar, target) inside all of them): mean |ΔP_d|
per look ≤ ``--tolerance-pd``; |Δ expected first-detection range| ≤ ``--tolerance-range-m``,
and a target detected (probability ≥ 5 %) under one setting but not the other is outside;
expected false alarms per scan of each radar and origin within ``--tolerance-fa``
(relative to the reference's count, or to 5 per scan if fewer); the latency added by fewer
sectors per scan (one sector, the scan period over ``sectors_per_scan``) ≤
``--max-latency-s`` (default: the scene's own).

Recommendation (the last step of :func:`run_fidelity_study`): it minimises one
stated cost, ``--optimise per-run`` (default) or ``first-run``. A value is taken only when
it is inside the tolerances and its cost ratio's whole interval lies below
1 - :data:`shipradar.sim.studies.timing.SAVING_MIN`;
the combination is then run as a whole, for accuracy and, in fresh alternating pairs, for
cost, and changes go back to the reference until both hold. Choices the block makes unread
(``pe_grid`` beside ``propagation: two_ray``) are left out of it. A study shortened with
``--duration`` says that its recommendation holds for the simulated span only, and
``--apply`` refuses it unless ``--allow-shortened``.

The parts of the model a scene exercises, and those it skips with the reason, are
:func:`explain` (also ``shipradar validate --explain``).

The modules, one job each: ``explain`` (what a scene exercises), ``plan`` (the
settings), ``runs`` (one setting with common random numbers), ``compare`` (against
the reference, the tolerances), ``trade`` (the study and its recommendation),
``report`` (text, CSV, the ``fidelity:`` block), ``pareto`` (the plot),
``apply`` (``--apply``) and ``cli`` (the command line). The names below are the
package's public ones.
"""

from shipradar.sim.studies.fidelity.apply import apply_fidelity
from shipradar.sim.studies.fidelity.cli import build_parser, cli_main
from shipradar.sim.studies.fidelity.compare import (
    Comparison,
    Tolerances,
    compare,
    expected_first_range,
)
from shipradar.sim.studies.fidelity.explain import Part, explain, explain_lines
from shipradar.sim.studies.fidelity.pareto import (
    pareto_front,
    place_labels,
    plot_pareto,
    text_box,
    tolerated_front,
)
from shipradar.sim.studies.fidelity.plan import (
    CHOICES,
    Setting,
    diff_label,
    plan_settings,
    reference_fidelity,
)
from shipradar.sim.studies.fidelity.report import (
    CSV_COLUMNS,
    fidelity_yaml,
    format_per_target,
    format_report,
    write_csv,
)
from shipradar.sim.studies.fidelity.runs import (
    TABLE_CHOICES,
    RunResult,
    TableClock,
    look_uniforms,
    run_setting,
)
from shipradar.sim.studies.fidelity.trade import (
    Cost,
    Study,
    error_score,
    run_fidelity_study,
    unread_choices,
)

__all__ = [
    "CHOICES",
    "CSV_COLUMNS",
    "TABLE_CHOICES",
    "Comparison",
    "Cost",
    "Part",
    "RunResult",
    "Setting",
    "Study",
    "TableClock",
    "Tolerances",
    "apply_fidelity",
    "build_parser",
    "cli_main",
    "compare",
    "diff_label",
    "error_score",
    "expected_first_range",
    "explain",
    "explain_lines",
    "fidelity_yaml",
    "format_per_target",
    "format_report",
    "look_uniforms",
    "pareto_front",
    "place_labels",
    "plan_settings",
    "plot_pareto",
    "reference_fidelity",
    "run_fidelity_study",
    "run_setting",
    "text_box",
    "tolerated_front",
    "unread_choices",
    "write_csv",
]
