"""Memory the off-line tables of a scene will take, checked before anything is built.

A PE table grows with the frequency (its height step is a fraction of a wavelength) times
the instrumented range (its range steps), and a scene with a millimetre-wave radar and a long
range can ask for tens of gigabytes: the run would thrash or be killed by the kernel after
minutes of work. :func:`check_memory_budget` estimates each table from the same grid rules
the builders use and refuses the scene at once, naming the field that drives the size.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from shipradar.sim.scenario import Scenario

__all__ = [
    "DEFAULT_MEMORY_BUDGET_MIB",
    "MemoryBudgetError",
    "TableEstimate",
    "check_memory_budget",
    "estimate_tables",
    "memory_budget_bytes",
]

#: Default budget for the tables of one scene [MiB]; ``--memory-budget`` or the environment
#: variable ``SHIPRADAR_MEMORY_BUDGET_MIB`` change it.
DEFAULT_MEMORY_BUDGET_MIB: int = 4096
# Bytes per PE output cell while the table is built: the float32 rows, their stacked copy
# and the boolean "beyond the angles carried" mask (tables.propagation.solve_pe).
_PE_BYTES_PER_CELL = 4 + 4 + 1
# Bytes per clutter-map cell: eight float64 fields (power, sigma0, sigma0_diff, a, Doppler
# mean and spread, ...) and as many temporaries while they are computed.
_CLUTTER_BYTES_PER_CELL = 2 * 8 * 8


class MemoryBudgetError(ValueError):
    """The scene's tables would not fit in the memory budget (one line, field and size)."""


@dataclass(frozen=True)
class TableEstimate:
    """Estimated peak memory of one table while it is built [bytes], and why."""

    radar_index: tuple[int, int]
    radar_id: str
    kind: str
    bytes: int
    field: str
    detail: str


def memory_budget_bytes(mib: float | None = None) -> int:
    """The budget [bytes]: ``mib`` if given, else the environment's, else the default."""
    if mib is None:
        env = os.environ.get("SHIPRADAR_MEMORY_BUDGET_MIB")
        if env:
            try:
                mib = float(env)
            except ValueError:
                raise MemoryBudgetError(
                    f"SHIPRADAR_MEMORY_BUDGET_MIB must be a number of MiB, got {env!r}") from None
            if not mib > 0:
                raise MemoryBudgetError(f"SHIPRADAR_MEMORY_BUDGET_MIB must be > 0, got {env}")
        else:
            mib = DEFAULT_MEMORY_BUDGET_MIB
    return int(mib * 2**20)


def _fmt(n: float) -> str:
    for unit, size in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if n >= size:
            return f"{n / size:.1f} {unit}"
    return f"{n:.0f} B"


def estimate_tables(scenario: Scenario) -> list[TableEstimate]:
    """Estimated build memory of each PE table and clutter map of the scene.

    Uses the builders' own grid rules (:func:`tables.propagation.grid_steps`,
    :func:`tables.scene.clutter_grid_size`) without building anything; the estimate covers
    the output arrays and their temporaries, not the PE's working field (a few columns).
    """
    import numpy as np
    import scipy.constants as sc

    from shipradar.sensors import propagation as prop
    from shipradar.tables.propagation import grid_steps, pe_top_height
    from shipradar.tables.scene import (
        clutter_grid_size,
        pe_table_height_m,
        refractivity_profile,
    )

    out: list[TableEstimate] = []
    fid = scenario.fidelity
    profile = None
    for pi, platform in enumerate(scenario.platforms):
        for ri, radar in enumerate(platform.radars):
            where = f"platforms[{pi}].radars[{ri}]"
            if fid.propagation == "pe":
                if profile is None:
                    profile = prop.profile_from_spec(refractivity_profile(scenario))
                max_height = pe_table_height_m(scenario, radar)
                steps = grid_steps(
                    radar.frequency_hz,
                    pe_top_height(max_height, radar.instrumented_range_m,
                                  radar.antenna_height_m),
                    radar.instrumented_range_m, profile, fid.pe_grid,
                    polarization=radar.polarization)
                lam = sc.c / radar.frequency_hz
                decim = max(1, round(lam / (4 * np.sin(steps["max_angle_rad"])) / steps["dz"]))
                n_h = int(max_height / (decim * steps["dz"])) + 2
                n_r = int(math.ceil(radar.instrumented_range_m / steps["dx"]))
                # which axis makes the table big: heights follow the wavelength, ranges the
                # instrumented range
                field = "frequency_hz" if n_h >= n_r else "instrumented_range_m"
                out.append(TableEstimate(
                    (pi, ri), radar.id, "propagation", n_r * n_h * _PE_BYTES_PER_CELL,
                    f"{where}.{field}",
                    f"PE table {n_r} ranges x {n_h} heights (frequency_hz "
                    f"{radar.frequency_hz:g} Hz, instrumented_range_m "
                    f"{radar.instrumented_range_m:g} m, heights to {max_height:g} m, "
                    f"pe_grid {fid.pe_grid!r})"))
            if fid.clutter:
                n_range, n_az = clutter_grid_size(radar)
                maps = 2 if scenario.environment.rain is not None else 1
                out.append(TableEstimate(
                    (pi, ri), radar.id, "clutter", maps * n_range * n_az
                    * _CLUTTER_BYTES_PER_CELL, f"{where}.instrumented_range_m",
                    f"clutter map{'s' if maps > 1 else ''} {n_range} ranges x {n_az} azimuths"))
    return out


def check_memory_budget(scenario: Scenario, budget_bytes: int | None = None) -> int:
    """Refuse a scene whose tables would exceed the memory budget, before any work.

    Parameters
    ----------
    scenario : Scenario
        The validated scene.
    budget_bytes : int or None, optional
        The budget [bytes]; default :func:`memory_budget_bytes`.

    Returns
    -------
    int
        The estimated total [bytes].

    Raises
    ------
    MemoryBudgetError
        One line naming the field that drives the largest table, the estimated total and
        the budget.
    """
    budget = memory_budget_bytes() if budget_bytes is None else int(budget_bytes)
    estimates = estimate_tables(scenario)
    total = sum(e.bytes for e in estimates)
    if total > budget:
        worst = max(estimates, key=lambda e: e.bytes)
        raise MemoryBudgetError(
            f"{worst.field}: the scene's tables need an estimated {_fmt(total)}, over the "
            f"memory budget of {_fmt(budget)} (--memory-budget); the largest is radar "
            f"{worst.radar_id!r}'s {worst.detail} at {_fmt(worst.bytes)}; lower that field, "
            f"use a coarser fidelity (pe_grid, propagation: two_ray) or raise the budget")
    return total
