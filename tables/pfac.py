"""Off-line P_fac map: sea-clutter false-alarm probability per (range, azimuth) sector, seed 7.2.

Seed 7.2: "the probability P_fac can then be evaluated for all sectors as defined in the
clutter map" and the 7.1 technique draws the false alarms of each sector on-line.  The map is
built from the sea-clutter map (:mod:`shipradar.tables.clutter`) of the same radar and environment:

* VP: [94] with the map's mean σ0 standing for the median, the threshold [95] (SPEC §4 item 6:
  Y_R in dB, [94] takes the linear ratio, 1.6 dB = -10 log10(ln 2)), divided by K_clutter
  [96] (:func:`shipradar.sensors.false_alarms.clutter_fa_probability`);
* HP: the seed's heuristic, P_facmax up to the 3° grazing range, a raised-cosine decrease to 0
  where a reaches a_min or P_sc falls to 2 N0' (per azimuth), P_facmax the user's
  (``radar.p_fac_max``) or VP's at a = 3
  (:func:`shipradar.sensors.false_alarms.hp_clutter_fa_probability`);
* both: P_fac = 0 wherever a ≤ a_min or P_sc < 2 N0'.

``clutter_fa_model`` (the scenario's ``fidelity.clutter_fa_model``) picks the [94]-[95] reading:
"seed" (default, the mean σ0 for the median) or "weibull_median" (threshold on the mean, the
median of [30]; 9-14x lower P_fac at a = 1.5-3), in VP and in the HP default P_facmax
(:func:`shipradar.sensors.false_alarms.clutter_fa_probability`).  The table carries the choice to
the on-line generator (spike S/I, :func:`clutter_false_alarm_generator`).

Only for medium-to-high-resolution radars (X = θ_b[deg] τ'[µs] < 4 and τ' < 4 µs): the
builder refuses the others and the scene (:mod:`shipradar.tables.scene`) asks for no table.

Sectors
-------
By default the clutter map's own cells: range bins of the map's step (100 m for the default
grid, so P_fac, which falls from its maximum to 0 within a few km, is not a staircase) by the
map's azimuth step (1°, which resolves the upwind/downwind term of the GIT model).  Coarser
sectors are a keyword away (``range_sector_m``, ``azimuth_sector_rad``); they are equal-width
and tile [0, R_max] × [0, 2π).  The P_fac of a sector is the mean of the node-wise P_fac over
the sector (trapezoid rule), so η = P_fac × cells is the expected count of the sector; cells
= ΔR/C_R × Δθ/θ_b.  The on-line cost depends only on the number of sectors with P_fac > 0.

Table: axes the sector centres (ground range [m], azimuth [rad]); values P_fac [-]; extras
``cells`` [-], ``expected_count`` (η per scan) [-] and ``weibull_a`` (sector mean) [-].  The cache
key holds exactly what changes it: the sea-map builder version and its inputs except the four
that change only its Doppler extras, P_fa (unless HP with a user P_facmax), K_clutter, P_facmax
(HP only), the sector counts and, only when it is not "seed", the P_fac model (so that the keys
of seed-model tables do not move with it; with a user HP P_facmax the model changes only the
spike S/I, yet it is kept in the key, as the table carries it to the generator).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from shipradar.sensors import false_alarms as fa
from shipradar.sensors import sea_clutter as sc
from shipradar.sensors.noise import range_cell_m
from shipradar.tables.clutter import SEA_MAP_VERSION
from shipradar.tables.store import Table, get_or_build

PFAC_MAP_NAME = "pfac_map"
#: Builder version (part of the cache key): bump when the model changes.
PFAC_MAP_VERSION = 1  # (the sea map's version is in its inputs: the radius of issue 31 moved it)
#: Sea-map inputs that change only the Doppler extras (not P_sc, σ0 or a): not in the key.
DOPPLER_ONLY_INPUTS = ("rotation_rate_rad_s", "motion_compensated", "ship_speed_mps",
                       "ship_heading_rad")


def pfac_map_inputs(
    sea_map_inputs: dict[str, Any],
    *,
    pfa: float,
    k_clutter: float = 1.0,
    p_fac_max: float | None = None,
    range_sector_m: float | None = None,
    azimuth_sector_rad: float | None = None,
    clutter_fa_model: fa.ClutterFaModel = fa.DEFAULT_CLUTTER_FA_MODEL,
) -> dict[str, Any]:
    """The hashable inputs of a P_fac map (see :func:`build_pfac_map`)."""
    sea = {k: v for k, v in sea_map_inputs.items() if k not in DOPPLER_ONLY_INPUTS}
    max_range = float(sea["max_range_m"])
    if range_sector_m is None:
        n_r = int(sea["n_range"]) - 1
    else:
        if not range_sector_m > 0.0:
            raise ValueError("range_sector_m must be > 0")
        n_r = max(2, int(round(max_range / range_sector_m)))
    if azimuth_sector_rad is None:
        n_az = int(sea["n_azimuth"])
    else:
        if not 0.0 < azimuth_sector_rad <= math.pi:
            raise ValueError("azimuth_sector_rad must be in (0, π]")
        n_az = max(2, int(round(2.0 * math.pi / azimuth_sector_rad)))
    if not 0.0 < pfa <= 1.0:
        raise ValueError("pfa must be in (0, 1]")
    if not k_clutter >= 1.0:
        raise ValueError("k_clutter must be >= 1")
    if clutter_fa_model not in fa.CLUTTER_FA_MODELS:
        raise ValueError(f"clutter_fa_model must be one of {fa.CLUTTER_FA_MODELS}")
    hp = sea["polarization"] == "H"
    user_max = hp and p_fac_max is not None
    inputs: dict[str, Any] = {
        "sea_map": sea,
        # the map is made from the sea map's nodes: a new sea-map builder makes a new P_fac map
        # (version 2's near-range nodes moved the sector means while the key stood still)
        "sea_map_version": SEA_MAP_VERSION,
        # P_fa sets [95] (VP) and the default P_facmax (HP); not a user P_facmax
        "pfa": None if user_max else float(pfa),
        "k_clutter": float(k_clutter),
        "p_fac_max": float(p_fac_max) if user_max and p_fac_max is not None else None,
        "n_range_sectors": n_r,
        "n_azimuth_sectors": n_az,
    }
    if clutter_fa_model != fa.DEFAULT_CLUTTER_FA_MODEL:
        # only then: the seed-model keys stay those of the tables already cached
        inputs["clutter_fa_model"] = clutter_fa_model
    return inputs


def _bin_mean(x: np.ndarray, f: np.ndarray, edges: np.ndarray, axis: int) -> np.ndarray:
    """Mean of the piecewise-linear f(x) over each bin [edges[i], edges[i+1]] along ``axis``.

    The cumulative trapezoid integral, interpolated at the edges (exact when the edges are
    nodes of x, as for the default sectors).
    """
    g = np.moveaxis(f, axis, 0)
    dx = np.diff(x).reshape((-1,) + (1,) * (g.ndim - 1))
    cum = np.concatenate([np.zeros((1,) + g.shape[1:]),
                          np.cumsum(0.5 * (g[1:] + g[:-1]) * dx, axis=0)])
    i = np.clip(np.searchsorted(x, edges, side="right") - 1, 0, len(x) - 2)
    t = ((edges - x[i]) / (x[i + 1] - x[i])).reshape((-1,) + (1,) * (g.ndim - 1))
    at = (1.0 - t) * cum[i] + t * cum[i + 1]
    out = np.diff(at, axis=0) / np.diff(edges).reshape((-1,) + (1,) * (g.ndim - 1))
    return np.moveaxis(out, 0, axis)


def sector_edges(table: Table) -> tuple[np.ndarray, np.ndarray]:
    """Ground-range [m] and azimuth [rad] sector edges of a P_fac map (from its centres)."""
    out = []
    for ax in table.axes:
        step = (ax[-1] - ax[0]) / (len(ax) - 1)
        out.append(np.linspace(ax[0] - 0.5 * step, ax[-1] + 0.5 * step, len(ax) + 1))
    # the first range centre is half a step out, so its inner edge is 0 but for rounding
    # (-3.6e-15 m at R_inst = 6931.68 m), which the false-alarm generator refuses
    return np.maximum(out[0], 0.0), out[1]


def node_pfac(sea_map: Table, *, pfa: float | None, k_clutter: float = 1.0,
              p_fac_max: float | None = None,
              clutter_fa_model: fa.ClutterFaModel = fa.DEFAULT_CLUTTER_FA_MODEL) -> np.ndarray:
    """P_fac at the nodes of a sea-clutter map (before the sector average) [-].

    Parameters
    ----------
    sea_map : Table
        A sea-clutter map of :mod:`shipradar.tables.clutter`.
    pfa : float or None
        P_fa [-] (may be None only for HP with ``p_fac_max``).
    k_clutter : float, optional
        K_clutter ≥ 1 [96].
    p_fac_max : float, optional
        HP P_facmax [-]; None: VP's at a = 3.
    clutter_fa_model : {"seed", "weibull_median"}, optional
        The [94]-[95] reading (VP, and the HP default P_facmax).
    """
    si = sea_map.inputs
    ranges = sea_map.axes[0]
    a = sea_map.extra["weibull_a"]
    power = sea_map.values
    a_min, n0 = float(si["a_min"]), float(si["noise_power_w"])
    if si["polarization"] == "V":
        if pfa is None:
            raise ValueError("a VP map needs pfa")
        return fa.clutter_fa_probability(a, pfa, a_min, k_clutter, power, n0,
                                         model=clutter_fa_model)
    off = (a <= a_min) | (power < fa.NOISE_LIKE_FACTOR * n0)
    r_ref = float(sc.ground_range_at_grazing_m(sc.REFERENCE_GRAZING_RAD,
                                               si["antenna_height_m"], si["k_factor"]))
    # per azimuth, the first range beyond R_ref where a = a_min or P_sc < 2 N0'; the map's
    # last range if neither happens inside it (the taper then ends at the instrumented range)
    beyond = off & (ranges[:, None] > r_ref)
    first = np.argmax(beyond, axis=0)
    r_end = np.where(beyond.any(axis=0), ranges[first], ranges[-1])
    if p_fac_max is not None:
        p_max = float(p_fac_max)
    elif pfa is not None:
        p_max = float(fa.default_p_fac_max(pfa, a_min, clutter_fa_model))
    else:
        raise ValueError("pfa may be None only for HP with p_fac_max")
    p = fa.hp_clutter_fa_probability(ranges[:, None], r_ref, r_end[None, :], p_max, k_clutter)
    return np.where(off, 0.0, p)


def build_pfac_map(
    sea_map: Table,
    *,
    pfa: float,
    k_clutter: float = 1.0,
    p_fac_max: float | None = None,
    range_sector_m: float | None = None,
    azimuth_sector_rad: float | None = None,
    clutter_fa_model: fa.ClutterFaModel = fa.DEFAULT_CLUTTER_FA_MODEL,
) -> Table:
    """Build the P_fac map of one radar from its sea-clutter map, seed 7.2 [94]-[96].

    Parameters
    ----------
    sea_map : Table
        The radar's sea-clutter map (:func:`shipradar.tables.clutter.sea_clutter_map`).
    pfa : float
        P_fa per cell [-] of [68]-[72]
        (:func:`shipradar.sensors.detection.pfa_from_false_alarm_time`, the same call as the radar's
        model, R_inst included, so that the map's threshold [95] is the model's; issue 23 item 5a:
        P_fa = 1/n', not the seed's 0.69/n').
    k_clutter : float, optional
        K_clutter ≥ 1 [96].
    p_fac_max : float, optional
        HP only: P_facmax [-]; None: [94]-[95] at a = 3.
    range_sector_m, azimuth_sector_rad : float, optional
        Sector size [m], [rad]; None: the clutter map's steps.
    clutter_fa_model : {"seed", "weibull_median"}, optional
        The [94]-[95] reading (:func:`shipradar.sensors.false_alarms.clutter_fa_probability`).

    Returns
    -------
    Table
        Values P_fac [-] per sector; extras ``cells``, ``expected_count``, ``weibull_a``.

    Raises
    ------
    ValueError
        If the radar is not of medium-to-high resolution (no clutter false alarms then).
    """
    inputs = pfac_map_inputs(sea_map.inputs, pfa=pfa, k_clutter=k_clutter, p_fac_max=p_fac_max,
                             range_sector_m=range_sector_m, azimuth_sector_rad=azimuth_sector_rad,
                             clutter_fa_model=clutter_fa_model)
    si = sea_map.inputs
    theta_b, tau = float(si["beamwidth_az_rad"]), float(si["pulse_width_s"])
    if not bool(sc.is_medium_high_resolution(theta_b, tau)):
        raise ValueError("P_fac map: the radar is not of medium-to-high resolution "
                         "(X >= 4 deg-us or tau' >= 4 us): no sea-clutter false alarms")
    ranges, azimuths = sea_map.axes
    p_node = node_pfac(sea_map, pfa=pfa, k_clutter=k_clutter, p_fac_max=p_fac_max,
                       clutter_fa_model=clutter_fa_model)
    r_edges = np.linspace(0.0, float(si["max_range_m"]), inputs["n_range_sectors"] + 1)
    az_edges = np.linspace(0.0, 2.0 * np.pi, inputs["n_azimuth_sectors"] + 1)

    def sector_mean(f: np.ndarray) -> np.ndarray:
        return _bin_mean(azimuths, _bin_mean(ranges, f, r_edges, 0), az_edges, 1)

    p = np.clip(sector_mean(p_node), 0.0, 1.0)
    a = np.maximum(sector_mean(sea_map.extra["weibull_a"]), float(si["a_min"]))
    cells = fa.sector_cells(np.diff(r_edges)[:, None], np.diff(az_edges)[None, :],
                            float(range_cell_m(tau)), theta_b)
    cells = np.broadcast_to(cells, p.shape).copy()
    return Table(
        name=PFAC_MAP_NAME,
        version=PFAC_MAP_VERSION,
        axes=(0.5 * (r_edges[1:] + r_edges[:-1]), 0.5 * (az_edges[1:] + az_edges[:-1])),
        axis_names=("ground_range_m", "azimuth_rad"),
        axis_units=("m", "rad"),
        values=p,
        value_name="p_fac",
        value_unit="1",
        inputs=inputs,
        extra={"cells": cells, "expected_count": p * cells, "weibull_a": a},
    )


def pfac_map(sea_map: Table, *, root: Path | None = None, **kwargs: Any) -> tuple[Table, bool]:
    """The P_fac map from the table cache, built if missing: ``(table, built)``.

    Same keywords as :func:`build_pfac_map`; ``root`` overrides the cache directory.
    """
    inputs = pfac_map_inputs(sea_map.inputs, **kwargs)
    return get_or_build(PFAC_MAP_NAME, PFAC_MAP_VERSION, inputs,
                        lambda: build_pfac_map(sea_map, **kwargs), root)


def clutter_range_profile(table: Table, ring_m: float = 250.0) -> tuple[np.ndarray, np.ndarray]:
    """Expected sea-clutter false alarms per scan in range rings, from a P_fac map.

    What a tracker needs for its clutter density (the radar's own false-alarm rate, 7.2):
    the map's η = P_fac × cells summed over azimuth and regrouped into rings of ``ring_m``
    (each sector's η split between rings in proportion to the overlap, η being uniform in
    ground range inside a sector), out to the last ring holding any.

    Parameters
    ----------
    table : Table
        A P_fac map (:func:`build_pfac_map`).
    ring_m : float, optional
        Ring width [m], > 0.

    Returns
    -------
    edges_m : ndarray
        Ring edges in ground range [m], from 0 (length n + 1; n = 0 for a map without any).
    per_scan : ndarray
        Expected false alarms per scan in each ring [-] (sums to Σ η).
    """
    if not ring_m > 0.0:
        raise ValueError("ring_m must be > 0")
    r_edges, _ = sector_edges(table)
    eta_r = np.asarray(table.extra["expected_count"], dtype=float).sum(axis=1)
    nz = np.nonzero(eta_r > 0.0)[0]
    if nz.size == 0:
        return np.zeros(1), np.zeros(0)
    n = int(math.ceil(r_edges[nz[-1] + 1] / ring_m))
    edges = ring_m * np.arange(n + 1, dtype=float)
    # cumulative η, linear in range inside each sector, read at the ring edges
    cum = np.concatenate([[0.0], np.cumsum(eta_r)])
    at = np.interp(edges, r_edges, cum)
    return edges, np.diff(at)


def clutter_false_alarm_generator(
    table: Table,
    *,
    pfa: float,
    n_channels: int,
    n_pulses: float,
    h_range: float = 4.0,
    h_azimuth: float = 4.0,
) -> fa.ClutterFalseAlarms:
    """The on-line per-scan generator (:class:`shipradar.sensors.false_alarms.ClutterFalseAlarms`)
    of a
    P_fac map.

    Parameters
    ----------
    table : Table
        A P_fac map of :func:`build_pfac_map`.
    pfa : float
        The model's P_fa [-] (the threshold [95] of the spike S/I, under the map's
        ``clutter_fa_model``, read from its inputs).
    n_channels : int
        N_ch.
    n_pulses : float
        Pulses integrated [-].
    h_range, h_azimuth : float, optional
        H_r, H_θ of [84]-[85].
    """
    si = table.inputs["sea_map"]
    r_edges, az_edges = sector_edges(table)
    shape = table.values.shape
    r0 = np.broadcast_to(r_edges[:-1, None], shape)
    r1 = np.broadcast_to(r_edges[1:, None], shape)
    a0 = np.broadcast_to(az_edges[None, :-1], shape)
    a1 = np.broadcast_to(az_edges[None, 1:], shape)
    tau = float(si["pulse_width_s"])
    model = table.inputs.get("clutter_fa_model", fa.DEFAULT_CLUTTER_FA_MODEL)
    return fa.ClutterFalseAlarms(
        r0, r1, a0, a1, table.values, table.extra["cells"], table.extra["weibull_a"],
        threshold_ratio=float(fa.clutter_threshold_ratio(pfa, float(si["a_min"]), model)),
        n_channels=n_channels, n_pulses=n_pulses,
        range_cell_m=float(range_cell_m(tau)),
        beamwidth_rad=float(si["beamwidth_az_rad"]),
        antenna_height_m=float(si["antenna_height_m"]), k_factor=float(si["k_factor"]),
        h_range=h_range, h_azimuth=h_azimuth, clutter_fa_model=model)
