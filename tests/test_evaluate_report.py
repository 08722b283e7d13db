"""The ``shipradar evaluate`` report's numbers: fixed notation at each quantity's precision,
a unit for every figure, intervals cut at a quantity's bounds (the page itself is checked in
Chromium by tests/test_evaluate_report_browser.py)."""

from __future__ import annotations

import math
import re

import pytest
from hypothesis import given
from hypothesis import strategies as st

from shipradar.sim.studies.evaluate import stats
from shipradar.sim.studies.evaluate.report import (
    QUANTITIES,
    bounded,
    format_value,
    quantity,
)

FIXED = re.compile(r"^-?\d{1,3}(,\d{3})*(\.\d+)?$")


@pytest.mark.parametrize(("value", "name", "text"), [
    (20_650.4, "gospa", "20,650"),          # the 2.065e+04
    (142_900.0, "first_track_range_m", "142.9"),  # shown in km
    (0.002425, "siap_track_number_change_rate", "8.73"),  # 1/s shown per hour
    (0.91875, "held_fraction", "0.919"),
    (1.0e-7, "latency_median_s", "0.000"),
    (-1.0e-7, "latency_median_s", "0.000"),  # no "-0.000"
    (-241.0, "false_tracks_per_hour", "-241"),
    (2, "runs", "2"),
    (float("nan"), "gospa", "–"),
    (None, "gospa", "–"),
    (float("inf"), "gospa", "∞"),
])
def test_format_value_examples(value, name, text):
    assert format_value(value, quantity(name)) == text


def test_format_value_without_quantity():
    assert format_value(1.0) == "1"
    assert format_value(1.5) == "1.5"
    assert format_value(1.0e-9) == "0"
    assert format_value(12_345) == "12,345"
    assert format_value("a<b") == "a&lt;b"


@given(v=st.floats(min_value=-1e12, max_value=1e12, allow_nan=False),
       name=st.sampled_from(sorted(QUANTITIES)))
def test_format_value_is_fixed_notation_and_round_trips(v, name):
    """Any value of any quantity: digits with comma groups and the quantity's decimals,
    never an exponent, and the shown number is the value to within half its last digit."""
    q = QUANTITIES[name]
    s = format_value(v, q)
    assert FIXED.match(s), s
    assert len(s.partition(".")[2]) == q.decimals
    shown = float(s.replace(",", ""))
    assert shown == pytest.approx(v * q.scale, abs=0.5 * 10.0 ** -q.decimals * (1 + 1e-9),
                                  rel=1e-12)


def test_every_summarised_metric_has_a_declared_unit():
    """A figure the report shows per run, per target or per scan is declared in QUANTITIES
    (a unit and a precision chosen, not guessed from its name)."""
    names = set(stats.RUN_METRICS) | set(stats.TARGET_METRICS) | set(stats.SCAN_METRICS)
    assert names - set(QUANTITIES) == set()
    assert all(QUANTITIES[n].unit for n in names)


def test_gospa_parts_in_metres_to_the_p():
    assert quantity("gospa", 2.0).unit == "m"
    assert quantity("missed", 1.0).unit == "m"
    assert quantity("missed", 2.0).unit == "m^2"
    assert quantity("localisation", 1.5).unit == "m^1.5"


def test_unknown_name_by_its_suffix():
    assert quantity("longest_unbroken_m").unit == "m"
    assert quantity("some_speed_mps").unit == "m/s"
    assert quantity("a_ratio").unit == "1"


def test_bounded_cuts_at_the_figure_bounds():
    assert bounded(-0.2316, 1.357, "held_fraction") == (0.0, 1.0)
    assert bounded(0.2, 0.8, "held_fraction") == (0.2, 0.8)
    assert bounded(-975.5, 1142.0, "false") == (0.0, 1142.0)
    assert bounded(0.83, 1.199, "siap_ambiguity") == (1.0, 1.199)
    assert bounded(-67.06, 187.1, "first_track_delay_s") == (0.0, 187.1)
    lo, hi = bounded(math.nan, math.nan, "held_fraction")
    assert math.isnan(lo) and math.isnan(hi)
    assert bounded(-5.0, 5.0, "an_unbounded_figure") == (-5.0, 5.0)


def test_every_shown_interval_has_bounds():
    """Every figure the tables show with an interval is bounded (stats.BOUNDS), so the
    report never prints a value it cannot take."""
    names = set(stats.RUN_METRICS) | set(stats.TARGET_METRICS) | set(stats.SCAN_METRICS)
    assert names - set(stats.BOUNDS) == set()


def test_compare_page_has_units(tmp_path):
    from shipradar.sim.studies.evaluate.report import write_compare

    rows = [{"study": "a", "kind": "mean", "metric": "gospa", "mean": 20_650.4,
             "low": -3.0e4, "high": 7.1e4, "runs": 2},
            {"study": "b", "kind": "minus a", "metric": "false_tracks_per_hour",
             "mean": -241.0, "low": -1.2e3, "high": 700.0, "runs": 2}]
    page = write_compare(tmp_path, ["a", "b"], [{"tracker": "x", "metrics": {"p": 1.0}}] * 2,
                         rows).read_text()
    assert "<th class='l'>unit</th>" in page and "<td class='l'>1/h</td>" in page
    assert "20,650" in page and not re.search(r"\de[+-]?\d", page)
    assert "<td>0</td><td>71,000</td>" in page  # a mean's interval cut at 0
    assert "<td>-1,200</td>" in page  # a difference is not bounded


def test_coverage_legend_lists_ids_in_natural_order_and_counts_the_rest(tmp_path):
    from shipradar.sim.studies.evaluate import report

    ids = [f"T{k}" for k in range(1, 51)]
    holding = [{"seed": 1, "scan": i, "t_s": float(i), "target": f"tgt{i % 2}",
                "track_id": ids[i] if i < 50 else None} for i in range(60)]
    svg = report._coverage_svg(tmp_path / "c.svg", holding, 1, report._track_colours(ids),
                               "c = 2,000 m")
    legend = svg[svg.index('id="legend-coverage"'):]
    shown = re.findall(r">track (T\d+)<", legend)
    assert shown == ids[:report.LEGEND_IDS]
    assert f"… {50 - report.LEGEND_IDS} more track ids" in legend
    assert "no track held it" in legend


def test_registration_section_fixed_notation_and_bounded(tmp_path):
    """The registration section (registration.report_section) follows the report's rules:
    numbers through format_value, an RMSE's interval not below 0."""
    from shipradar.sim.studies.evaluate.registration import report_section, summarise_rows

    rows = [{"sensor": "giraffe", "component": comp, "seed": seed, "tolerance": tol,
             "warmup_s": 0.0, "rmse": rmse, "mean_error": -rmse, "converge_s": conv}
            for comp, tol, values in (("range_bias_m", 20.0, (10.0, 30.0)),
                                      ("range_scale_ppm", 100.0, (12_345.0, 23_456.0)),
                                      ("azimuth_bias_rad", 8.7e-4, (1.2e-7, 3.4e-7)),
                                      ("time_offset_s", 0.01, (2.5e-5, 7.5e-5)))
            for seed, rmse, conv in zip((1, 2), values, (12.0, math.nan), strict=True)]
    summary = summarise_rows(rows)
    by_comp = {r["component"]: r for r in summary}
    assert by_comp["range_bias_m"]["rmse_low"] == 0.0  # Student t alone: 20 - 127 m
    assert by_comp["range_bias_m"]["mean_error_low"] < 0.0  # a mean error has either sign
    page = report_section(tmp_path, summary, [])
    assert not re.search(r"\d[eE][+-]?\d", page), page
    assert "<td>20.0</td>" in page and "17,900.5" in page and "0.0000" in page
