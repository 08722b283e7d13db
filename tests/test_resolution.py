"""Unresolved targets (seed 2.2.1, issue 37): contacts from looks the beam makes together,
resolution decided by separation, not by a grid.

Two looks are one contact only when their crossing times are within a dwell θ_b/ω, their
slant ranges within a range cell C_R, their azimuths within a beamwidth θ_b (across north
too) and they fall in one Doppler filter; every pair in a contact is so.  The scenes place
still targets so that pairs straddle the old grid's range-cell and azimuth-cell boundaries
and north, and the issue's scan-start case: start azimuth 183.35°, two targets in the old
azimuth cell 96 at 0.2 θ_b and 0.8 θ_b, crossed at 0.0016 s and 0.998 s.
"""

import math

import numpy as np
import pytest

from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream import protocol
from shipradar.sim.world.kinematics import wrap_pi
from shipradar.tables.scene import SceneTables

from .helpers import CaptureBus, bare_scene, quiet_radar


def _still(i, ground_m, az_deg, duration, sigma=1e4):
    e = ground_m * math.sin(math.radians(az_deg))
    n = ground_m * math.cos(math.radians(az_deg))
    return {"id": f"t{i}", "waypoints": [
        {"time_s": 0, "east_m": e, "north_m": n, "altitude_m": 20.0},
        {"time_s": duration, "east_m": e, "north_m": n, "altitude_m": 20.0}],
        "rcs": {"type": "constant", "sigma_m2": sigma}, "swerling": 0}


def _run(targets, start_deg=90.0, beam_deg=2.0, duration=1.0):
    radar = quiet_radar(rotation_rpm=60.0, start_azimuth_deg=start_deg, beamwidth_az_deg=beam_deg,
                        false_alarm_time_s=1e6)
    s = bare_scene(radar=radar, targets=targets, duration_s=duration)
    bus = CaptureBus()
    sim = Simulation(s, bus=bus, tables=SceneTables())
    looks = []
    model = sim.radars[0].model
    model.on_look.append(looks.append)
    sim.run()
    cat = {k: np.concatenate([getattr(lk, k) for lk in looks])
           for k in ("target", "time_s", "slant_range_m", "contact")}
    # a contact index is per call: make it global
    offs = np.cumsum([0] + [int(lk.contact.max()) + 1 for lk in looks[:-1]])
    cat["contact"] = np.concatenate([lk.contact + o for lk, o in zip(looks, offs, strict=True)])
    return sim, model, cat, bus


def _azimuths(sim, cat):
    geom, _, _ = sim.radars[0].geometry(cat["time_s"], cat["target"].astype(np.int64))
    return geom.azimuth


def _check_rule(sim, model, cat):
    """Every pair of looks: one contact iff unresolved (times, ranges, azimuths)."""
    az = _azimuths(sim, cat)
    dwell = model.theta_b * model.radar.scan_period_s / (2 * math.pi)
    t, r, c = cat["time_s"], cat["slant_range_m"], cat["contact"]
    n = t.size
    for i in range(n):
        for j in range(i + 1, n):
            close = (abs(t[i] - t[j]) <= dwell and abs(r[i] - r[j]) < model.range_cell
                     and abs(wrap_pi(az[i] - az[j])) < model.theta_b)
            if c[i] == c[j]:
                assert close, (i, j)
    return az


def test_pairs_straddling_the_old_range_and_azimuth_cells_are_one_contact():
    sim0, model, _, _ = _run([_still(0, 10000.0, 45.0, 1.0)])
    c_r, th = model.range_cell, math.degrees(model.theta_b)
    k = 70  # range cell boundary near 10.5 km
    targets = [
        _still(0, (k - 0.05) * c_r, 30.0, 1.0), _still(1, (k + 0.05) * c_r, 30.0, 1.0),
        _still(2, 20000.0, (100 - 0.05) * th, 1.0), _still(3, 20000.0, (100 + 0.05) * th, 1.0),
        _still(4, 30000.0, 359.9, 1.0), _still(5, 30000.0, 0.1, 1.0),   # across north
        _still(6, 40000.0, 120.0, 1.0), _still(7, 40000.0 + 1.1 * c_r, 120.0, 1.0),
        _still(8, 40000.0, 140.0, 1.0), _still(9, 40000.0, 140.0 + 1.1 * th, 1.0)]
    sim, model, cat, _ = _run(targets)
    az = _check_rule(sim, model, cat)
    contact = dict(zip(cat["target"].tolist(), cat["contact"].tolist(), strict=True))
    r = dict(zip(cat["target"].tolist(), cat["slant_range_m"].tolist(), strict=True))
    a = dict(zip(cat["target"].tolist(), az.tolist(), strict=True))
    # the old grid split these three pairs; they are one contact each now
    assert math.floor(r[0] / c_r) != math.floor(r[1] / c_r) and contact[0] == contact[1]
    assert math.floor(a[2] / model.theta_b) != math.floor(a[3] / model.theta_b)
    assert contact[2] == contact[3]
    assert contact[4] == contact[5]
    # a cell or a beamwidth and a tenth apart: resolved
    assert contact[6] != contact[7] and contact[8] != contact[9]
    assert sim.stats.merged_targets == 3


def test_the_scan_start_split_cell_gives_two_plots_at_their_own_crossings():
    """Start azimuth 183.35°, θ_b = 1.9°: two targets of the old azimuth cell 96, at 0.2 θ_b
    and 0.8 θ_b into it, same range, are crossed at 0.998 s and 0.0016 s: two looks a scan
    apart, two contacts, each plot at its own crossing (not one plot at 0.25 s)."""
    th = 1.9
    targets = [_still(0, 15000.0, 96.2 * th, 1.0), _still(1, 15000.0, 96.8 * th, 1.0, 3e3)]
    sim, model, cat, bus = _run(targets, start_deg=183.35, beam_deg=th)
    assert cat["contact"][0] != cat["contact"][1]
    t = dict(zip(cat["target"].tolist(), cat["time_s"].tolist(), strict=True))
    assert t[1] == pytest.approx(0.0016, abs=1e-4) and t[0] == pytest.approx(0.998, abs=1e-3)
    plots = np.concatenate([p["time_s"] for _, p in bus.of(protocol.TOPIC_PLOTS)])
    assert plots.size == 2 and sim.stats.merged_targets == 0
    assert np.sort(plots) == pytest.approx(sorted(t.values()), abs=1e-12)


def test_a_chain_of_close_targets_is_cut_where_a_pair_is_resolved():
    """Three targets 0.7 θ_b apart at one range, the middle one strongest: it leads a contact
    with the first; the third, within a beamwidth of the middle one but not of the first,
    is a contact of its own.  No contact holds two looks more than a dwell apart."""
    th = 2.0
    targets = [_still(0, 20000.0, 200.0, 1.0, 1e3), _still(1, 20000.0, 200.0 + 0.7 * th, 1.0),
               _still(2, 20000.0, 200.0 + 1.4 * th, 1.0, 5e2)]
    sim, model, cat, _ = _run(targets)
    _check_rule(sim, model, cat)
    c = dict(zip(cat["target"].tolist(), cat["contact"].tolist(), strict=True))
    assert c[0] == c[1] != c[2]


def test_looks_of_different_revolutions_or_far_in_time_never_merge():
    """One target, three revolutions: three looks, three contacts; and a random field of
    close targets: the rule holds for every pair."""
    sim, model, cat, _ = _run([_still(0, 10000.0, 10.0, 3.0)], duration=3.0)
    assert np.unique(cat["contact"]).size == cat["contact"].size == 3
    rng = np.random.default_rng(5)
    targets = [_still(i, rng.uniform(9000.0, 9600.0), rng.uniform(80.0, 100.0), 2.0)
               for i in range(40)]
    sim, model, cat, _ = _run(targets, duration=2.0)
    _check_rule(sim, model, cat)
    assert sim.stats.merged_targets > 0
