"""Extremes campaign (issue 23, item 2): every scenario field at the bounds its schema declares.

The cases are generated from the scenario schema itself
(:class:`shipradar.sim.world.scenario.Scenario` and every model under it, their ``Field(ge=, gt=,
le=, lt=)`` metadata and ``Literal`` choices), so a field added to the schema is covered without
editing this file. Each case starts from ``scenarios/single_missile.yaml`` made cheap
(:data:`CHEAP`), sets one field (or, for the interacting groups of :func:`interaction_cases`, a few)
and runs ``shipradar run`` in-process.
Every case must end in one of two ways:

* **ran**: exit 0, no traceback, no ``RuntimeWarning``, a finite summary JSON, and a recording
  that verifies clean and whose every message decodes to finite, documented values
  (:func:`check_recording`);
* **refused**: exit 2 with exactly one line on stderr that names a field of the schema.

Anything else (a traceback, exit 1, a warning, a NaN) is a **failure**, reported with the
exception's last frames so that it can be reproduced from the table alone.

Fields inside optional sub-models that the base scene does not set (rain, fog, jammers, duct
variants, processor types, pattern types, manoeuvre segments, ...) are reached through the
documented minimal sub-objects of :data:`VARIANTS`; a model that no variant and no base value
reaches makes :func:`coverage_gaps` non-empty, which the test suite asserts against.

Run it alone::

    python -m tests.extremes [--quick | --all] [--out report.json] [--only TEXT]

``--quick`` runs the single-field bounds only; the default adds the interacting groups (what
``tests/test_extremes.py`` runs); ``--all`` adds the heavy cases (tables estimated to take
long to build), which are expected to run or be refused up front by the build-time limit.
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import functools
import io
import json
import math
import os
import re
import sys
import tempfile
import time
import traceback
import types
import typing
import warnings
import zlib
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

import annotated_types
import numpy as np
import yaml
from pydantic import BaseModel

from shipradar.sim.world import scenario as schema

ROOT = Path(__file__).resolve().parents[1]
#: The scene every case starts from.
BASE_SCENE = ROOT / "scenarios" / "single_missile.yaml"
#: Longest simulated time of a case [s]: the point is the value of each field, not the
#: length of the scene; three revolutions of the base radar.
CASE_DURATION_S = 3.0

Path_ = tuple[str | int, ...]

#: What makes the base scene cheap. A case about propagation puts ``fidelity.propagation``
#: back to ``pe`` (:func:`needs_pe`); every other case uses the two-ray model, which needs
#: no PE table, so that only the cases that change a PE input build one.
#: The missile starts where the base scene has it at t = 70 s (same course and speed, 10 km
#: out), so that three seconds hold target plots and not only false alarms; the instrumented
#: range is halved to 30 km, which halves a PE table's cost (cases about the range set it).
CHEAP: dict[Path_, Any] = {
    ("duration_s",): CASE_DURATION_S,
    ("fidelity", "propagation"): "two_ray",
    ("fidelity", "sectors_per_scan"): 8,
    ("platforms", 0, "radars", 0, "instrumented_range_m"): 30000.0,
    ("targets", 0, "waypoints"): [
        {"time_s": 0, "east_m": 7000.0, "north_m": 7560.0, "altitude_m": 5},
        {"time_s": 35, "east_m": 0.0, "north_m": 840.0, "altitude_m": 5}],
}

#: Field names whose value is an input of the PE table (shipradar.tables.scene._propagation_specs:
#: frequency, antenna height, polarisation, elevation pattern, M-profile, wave height,
#: instrumented range, the table's top from the highest target or jammer, the PE grid).
PE_FIELDS = frozenset({
    "frequency_hz", "antenna_height_m", "polarization", "beamwidth_el_deg",
    "instrumented_range_m", "pe_grid", "sea_state", "wave_height_m", "altitude_m",
    "to_altitude_m", "peak_altitude_m",
})
#: Sub-models all of whose fields are PE inputs.
PE_MODELS = ("pattern_el", "duct")


# =========================================================================== cases
@dataclass(frozen=True)
class Case:
    """One scene of the campaign: the cheap base scene with ``edits`` applied in order.

    Attributes
    ----------
    id : str
        ``path=value`` of the edits that make the case (a variant's label in brackets).
    group : str
        ``bound`` (one field at one bound), ``choice`` (a Literal or bool value),
        ``variant`` (a documented minimal sub-object as it is), ``interaction`` (a listed
        combination of interacting fields) or ``companion`` (a bound that other fields refuse
        in the base scene, with the fields that let it run).
    edits : tuple
        ``(path, value)`` pairs; a path is a tuple of mapping keys and list indices.
    pe : bool
        Whether the case keeps ``fidelity.propagation: pe``.
    heavy : str
        Why the case is expected to be slow ('' for a cheap case): heavy cases are run by
        ``--all`` and the slow test only.
    fields : tuple
        ``Model.field`` names this case exercises at a value of its own (for coverage).
    """

    id: str
    group: str
    edits: tuple[tuple[Path_, Any], ...]
    pe: bool = False
    heavy: str = ""
    fields: tuple[str, ...] = ()


def fmt_path(path: Path_) -> str:
    """``('platforms', 0, 'radars', 0, 'prf_hz')`` -> ``platforms[0].radars[0].prf_hz``."""
    out = ""
    for k in path:
        out += f"[{k}]" if isinstance(k, int) else (f".{k}" if out else k)
    return out


def fmt_value(v: Any) -> str:
    """A short, exact rendering of a case value (floats by repr, so they reproduce)."""
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, (dict, list)):
        s = json.dumps(v, separators=(",", ":"))
        return s if len(s) <= 80 else s[:77] + "..."
    return str(v)


def set_path(data: dict, path: Path_, value: Any) -> None:
    """Set ``data[path] = value``, creating missing mappings on the way.

    Raises
    ------
    KeyError
        If a list index on the path does not exist (a case that names an absent element).
    """
    cur: Any = data
    for k in path[:-1]:
        if isinstance(k, int):
            cur = cur[k]
        else:
            if cur.get(k) is None:
                cur[k] = {}
            cur = cur[k]
    last = path[-1]
    if isinstance(last, int) and last == -1 and isinstance(cur, list):
        cur[-1] = copy.deepcopy(value)
    else:
        cur[last] = copy.deepcopy(value)


def get_path(data: Any, path: Path_) -> Any:
    """``data[path]``, or None when a key on the way is absent."""
    cur = data
    for k in path:
        if isinstance(k, int):
            if not isinstance(cur, list) or not -len(cur) <= k < len(cur):
                return None
            cur = cur[k]
        else:
            if not isinstance(cur, dict) or k not in cur:
                return None
            cur = cur[k]
    return cur


def base_scene() -> dict:
    """The base scene as parsed YAML, before the cheapening edits."""
    return yaml.safe_load(BASE_SCENE.read_text())


def needs_pe(edits: Sequence[tuple[Path_, Any]]) -> bool:
    """Whether any edit changes a PE-table input (then the case runs the PE)."""
    for path, _ in edits:
        names = [k for k in path if isinstance(k, str)]
        if names and names[-1] in PE_FIELDS:
            return True
        if any(m in names for m in PE_MODELS):
            return True
        if names[-1:] == ["propagation"]:
            return True
    return False


def scene_for(case: Case) -> dict:
    """The scene dictionary of a case: base, cheapening, then the case's edits."""
    data = base_scene()
    for path, value in CHEAP.items():
        set_path(data, path, value)
    if case.pe:
        set_path(data, ("fidelity", "propagation"), "pe")
    for path, value in case.edits:
        set_path(data, path, value)
    return data


# --------------------------------------------------------------------------- schema walk
@dataclass(frozen=True)
class Leaf:
    """What the schema says about one field: its kind and bounds."""

    kind: str  # number, int, literal, bool, model, union, list, other
    lo: float | None = None
    lo_open: bool = False
    hi: float | None = None
    hi_open: bool = False
    choices: tuple[Any, ...] = ()
    models: tuple[type[BaseModel], ...] = ()
    item: Leaf | None = None


def _bounds(metadata: Sequence[Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for m in metadata:
        if isinstance(m, annotated_types.Ge):
            out.update(lo=m.ge, lo_open=False)
        elif isinstance(m, annotated_types.Gt):
            out.update(lo=m.gt, lo_open=True)
        elif isinstance(m, annotated_types.Le):
            out.update(hi=m.le, hi_open=False)
        elif isinstance(m, annotated_types.Lt):
            out.update(hi=m.lt, hi_open=True)
        elif isinstance(m, annotated_types.Interval):
            for name in ("ge", "gt", "le", "lt"):
                v = getattr(m, name)
                if v is not None:
                    out.update(_bounds([getattr(annotated_types, name.capitalize())(v)]))
    return out


def classify(annotation: Any, metadata: Sequence[Any] = ()) -> Leaf:
    """The :class:`Leaf` of a field annotation (Optional, Annotated and lists unwrapped)."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        inner, *extra = typing.get_args(annotation)
        meta = list(metadata)
        for e in extra:
            meta.extend(getattr(e, "metadata", None) or [e])
        return classify(inner, meta)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        if len(args) == 1:
            return classify(args[0], metadata)
        models = tuple(a for a in args if isinstance(a, type) and issubclass(a, BaseModel))
        if len(models) == len(args):
            return Leaf("union", models=models)
        return Leaf("other")
    if origin is Literal:
        return Leaf("literal", choices=typing.get_args(annotation))
    if origin is list:
        (item,) = typing.get_args(annotation)
        return Leaf("list", item=classify(item))
    if annotation is bool:
        return Leaf("bool", choices=(False, True))
    if annotation in (int, float):
        return Leaf("int" if annotation is int else "number", **_bounds(metadata))
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return Leaf("model", models=(annotation,))
    return Leaf("other")


def field_leaf(model: type[BaseModel], name: str) -> Leaf:
    """The :class:`Leaf` of ``model.name``."""
    info = model.model_fields[name]
    return classify(info.annotation, info.metadata)


def member_for(models: Sequence[type[BaseModel]], data: Any) -> type[BaseModel] | None:
    """The member of a discriminated union that ``data`` (a mapping with ``type``) selects."""
    if len(models) == 1:
        return models[0]
    tag = data.get("type") if isinstance(data, dict) else None
    for m in models:
        leaf = field_leaf(m, "type") if "type" in m.model_fields else None
        if leaf is not None and leaf.kind == "literal" and tag in leaf.choices:
            return m
    return None


# --------------------------------------------------------------------------- variants
@dataclass(frozen=True)
class Variant:
    """A documented minimal sub-object that reaches fields the base scene leaves unset.

    Attributes
    ----------
    label : str
        Short name shown in case ids.
    at : tuple
        Path of the object the patch is merged into (the parent of the new sub-object).
    patch : dict
        Keys set on that object (whole sub-objects replace the base's).
    walk : tuple
        The patched keys whose fields the campaign then walks (default: every key of the
        patch).
    why : str
        Why this sub-object and not another: the smallest valid one, chosen so the scene
        still runs a few seconds cheaply.
    """

    label: str
    at: Path_
    patch: dict[str, Any]
    walk: tuple[str, ...] = ()
    why: str = ""

    @property
    def walked(self) -> tuple[str, ...]:
        return self.walk or tuple(self.patch)


_RADAR: Path_ = ("platforms", 0, "radars", 0)
_TARGET: Path_ = ("targets", 0)
_PLATFORM: Path_ = ("platforms", 0)
_ENV: Path_ = ("environment",)
#: The missile's start, as a single waypoint for its segments (the base's first waypoint).
_MISSILE_START = {"time_s": 0, "east_m": 7000.0, "north_m": 7560.0, "altitude_m": 5}
_SEGMENT_TARGET = {"waypoints": [_MISSILE_START], "heading_deg": 225.0, "speed_mps": 280.0}
#: What a segment variant walks: the segment, and the speed it starts at (0 reaches the
#: rules that divide by it).
_SEG_WALK = ("segments", "speed_mps")
_SHIP_START = {"waypoints": [{"time_s": 0, "east_m": 0, "north_m": 0}], "heading_deg": 0.0,
               "speed_mps": 8.0}

#: Minimal valid sub-objects for everything the base scene leaves unset. Each is the
#: smallest object of its kind that validates, with values in the middle of their ranges,
#: so that the field walked inside it is the only extreme of the case.
VARIANTS: tuple[Variant, ...] = (
    # -- environment
    Variant("rain", _ENV, {"rain": {"rate_mm_h": 10.0, "region": {"radius_m": 20000.0}}},
            why="rain over a 20 km cylinder: the weather map and the rain loss are built"),
    Variant("fog", _ENV, {"fog": {"liquid_water_g_m3": 0.3}}, why="moderate fog"),
    Variant("duct-bulk", _ENV, {"duct": {"type": "bulk", "air_temperature_c": 15.0,
                                         "sea_temperature_c": 17.0,
                                         "relative_humidity": 0.8}},
            why="a bulk duct from typical mid-latitude air and sea"),
    Variant("duct-profile", _ENV, {"duct": {"type": "profile", "heights_m": [0.0, 30.0, 300.0],
                                            "m_units": [330.0, 320.0, 352.0]}},
            why="a 30 m surface duct ending on a standard-slope segment"),
    # -- jammers
    Variant("jammer", (), {"jammers": [{
        "id": "jam1", "waypoints": [{"time_s": 0, "east_m": 30000, "north_m": 10000,
                                     "altitude_m": 3000}],
        "power_w": 100.0, "gain_db": 10.0, "bandwidth_hz": 1.0e8}]},
        why="one stand-off noise jammer at 32 km, 3 km up"),
    # -- radar: pattern types, processors, windows, optional numbers
    Variant("az-gaussian", _RADAR, {"pattern_az": {"type": "gaussian"}}),
    Variant("az-isotropic", _RADAR, {"pattern_az": {"type": "isotropic"}}),
    Variant("el-sinc", _RADAR, {"pattern_el": {"type": "sinc", "sidelobe_db": 20.0}}),
    Variant("el-gaussian", _RADAR, {"pattern_el": {"type": "gaussian"}}),
    Variant("proc-none", _RADAR, {"processor": {"type": "none"}}),
    Variant("proc-mti", _RADAR, {"processor": {"type": "mti", "mti_order": 2}}),
    # windows other than Hann, so that 2 taps are a valid bank (a 2-tap Hann is all zeros)
    Variant("proc-dft", _RADAR, {"processor": {"type": "dft_bank", "n_coherent": 16,
                                               "window": {"type": "hamming"}}}),
    Variant("proc-fir-filters", _RADAR, {"processor": {
        "type": "fir_bank", "n_coherent": 16, "n_filters": 16, "window": {"type": "hamming"}}},
        why="a FIR bank with its own filter count (a DFT bank's is its tap count)"),
    Variant("proc-mti_bank", _RADAR, {"processor": {"type": "mti_bank", "mti_order": 2,
                                                    "n_coherent": 16,
                                                    "window": {"type": "hamming"}}}),
    Variant("window-taylor", _RADAR, {"processor": {"type": "fir_bank", "n_coherent": 8,
                                                    "window": {"type": "taylor"}}}),
    Variant("stagger", _RADAR, {"stagger_prf_hz": [4800.0, 5000.0, 5200.0]},
            why="a three-PRF stagger around the base PRF"),
    # -- targets: RCS models, manoeuvres, smoothing, geodetic waypoints
    Variant("rcs-constant", _TARGET, {"rcs": {"type": "constant", "sigma_m2": 1.0}}),
    Variant("rcs-table", _TARGET, {"rcs": {"type": "table", "aspect_deg": [0.0, 90.0, 180.0],
                                           "sigma_m2": [0.1, 5.0, 0.5]}}),
    Variant("seg-straight", _TARGET, {**_SEGMENT_TARGET,
                                      "segments": [{"type": "straight", "duration_s": 20.0}]},
            walk=("segments", "heading_deg", "speed_mps")),
    Variant("seg-turn-g", _TARGET, {**_SEGMENT_TARGET, "segments": [
        {"type": "turn", "turn_g": 5.0, "to_heading_deg": 180.0}]}, walk=_SEG_WALK),
    Variant("seg-turn-rate", _TARGET, {**_SEGMENT_TARGET, "segments": [
        {"type": "turn", "turn_rate_deg_s": 10.0, "duration_s": 5.0, "direction": "left"}]},
        walk=_SEG_WALK),
    Variant("seg-accelerate", _TARGET, {**_SEGMENT_TARGET, "segments": [
        {"type": "accelerate", "to_speed_mps": 400.0, "accel_g": 2.0}]}, walk=_SEG_WALK),
    Variant("seg-accelerate-time", _TARGET, {**_SEGMENT_TARGET, "segments": [
        {"type": "accelerate", "to_speed_mps": 400.0, "duration_s": 5.0}]},
        walk=_SEG_WALK),
    Variant("seg-climb", _TARGET, {**_SEGMENT_TARGET, "segments": [
        {"type": "climb", "to_altitude_m": 200.0, "duration_s": 10.0}]}, walk=_SEG_WALK),
    Variant("seg-weave", _TARGET, {**_SEGMENT_TARGET, "segments": [
        {"type": "weave", "amplitude_m": 100.0, "period_s": 10.0, "duration_s": 20.0}]},
        walk=_SEG_WALK),
    Variant("seg-popup", _TARGET, {**_SEGMENT_TARGET, "segments": [
        {"type": "popup", "peak_altitude_m": 300.0, "climb_s": 4.0, "dive_s": 4.0,
         "to_altitude_m": 5.0}]}, walk=_SEG_WALK),
    Variant("smoothing", _TARGET, {"waypoints": [
        {"time_s": 0, "east_m": 7000, "north_m": 7560, "altitude_m": 5},
        {"time_s": 20, "east_m": 4000, "north_m": 6000, "altitude_m": 5},
        {"time_s": 40, "east_m": 0, "north_m": 840, "altitude_m": 5}],
        "smoothing": {"turn_g": 5.0}}, walk=("smoothing",),
        why="a dog-leg path whose corner a 5 g turn rounds"),
    Variant("geodetic", _TARGET, {"waypoints": [
        {"time_s": 0, "lat_deg": 44.668, "lon_deg": -62.9117, "altitude_m": 5},
        {"time_s": 35, "lat_deg": 44.6076, "lon_deg": -63.0, "altitude_m": 5}]},
        why="the missile's path by latitude and longitude"),
    # -- recorded traffic: the AIS sample file (scenarios/traffic/), every field of an entry
    Variant("traffic", (), {"traffic": [{
        "path": str(Path(__file__).resolve().parents[1] / "scenarios" / "traffic"
                    / "ais_sample.csv"),
        "preset": "ais", "rcs": {"type": "constant", "sigma_m2": 500.0}, "swerling": 1,
        "max_gap_s": 120.0, "time_offset_s": 0.0, "window_start_s": 0.0,
        "window_end_s": 170.0,
        "overrides": [{"ids": ["316001001"], "kind": "ship", "swerling": 2,
                       "rcs": {"type": "constant", "sigma_m2": 50.0}}],
        "columns": {"speed_unit": "knots", "time_unit": "iso"}, "limits": {}}]},
        why="six AIS ships around the frigate from the shipped sample file"),
    # -- live entities: the type table and the envelope (a run without --entities keeps
    # the scene's own targets; the envelope sizes the PE table)
    Variant("entity-types", (), {"entity_types": [
        {"match": "ship*", "kind": "ship", "swerling": 1,
         "rcs": {"type": "constant", "sigma_m2": 1000.0}}]},
        why="one entity type (read only by a live run; the scene must still validate)"),
    Variant("external", (), {"external": {"max_altitude_m": 1000.0, "max_range_m": 40000.0,
                                          "timeout_s": 12.0, "queue_size": 100000}},
            why="the envelope of live entities: the PE table covers 1000 m and 40 km"),
    # -- platform: manoeuvres and smoothing of the ship
    Variant("ship-turn", _PLATFORM, {**_SHIP_START, "segments": [
        {"type": "turn", "turn_rate_deg_s": 3.0, "duration_s": 10.0, "direction": "right"}]},
        walk=_SEG_WALK),
    Variant("ship-smoothing", _PLATFORM, {"waypoints": [
        {"time_s": 0, "east_m": 0, "north_m": 0},
        {"time_s": 300, "east_m": 0, "north_m": 2400},
        {"time_s": 600, "east_m": 2400, "north_m": 2400}],
        "smoothing": {"turn_g": 0.05}}, walk=("smoothing",)),
)


@dataclass(frozen=True)
class Slot:
    """An object of the scene the campaign walks: its model, where it is, the edits (a
    variant's patch) that put it there, and which of its fields to walk (None: all)."""

    model: type[BaseModel]
    path: Path_
    data: dict
    prefix: tuple[tuple[Path_, Any], ...]
    label: str
    only: tuple[str, ...] | None = None


def _field_value(model: type[BaseModel], data: dict, name: str) -> Any:
    """A field's value as the scene gives it, or its default (a default model as ``{}``)."""
    if name in data:
        return data[name]
    info = model.model_fields[name]
    if info.is_required():
        return None
    default = info.get_default(call_default_factory=True)
    if isinstance(default, BaseModel):
        return {}
    return default


def _sub_slots(model: type[BaseModel], path: Path_, data: dict, name: str,
               prefix: tuple[tuple[Path_, Any], ...], label: str) -> Iterator[Slot]:
    """The slots of the sub-model(s) held by ``model.name`` (lists: the first element)."""
    leaf = field_leaf(model, name)
    value = _field_value(model, data, name)
    if value is None:
        return
    if leaf.kind == "list" and leaf.item is not None and leaf.item.kind in ("model", "union"):
        if value:
            sub = member_for(leaf.item.models, value[0])
            if sub is not None:
                yield from _slots(sub, (*path, name, 0), value[0], prefix, label)
    elif leaf.kind in ("model", "union"):
        sub = member_for(leaf.models, value)
        if sub is not None:
            yield from _slots(sub, (*path, name), value, prefix, label)


def _slots(model: type[BaseModel], path: Path_, data: dict,
           prefix: tuple[tuple[Path_, Any], ...], label: str) -> Iterator[Slot]:
    """``model`` at ``path`` and every sub-model reachable from it in ``data``."""
    yield Slot(model, path, data, prefix, label)
    for name in model.model_fields:
        yield from _sub_slots(model, path, data, name, prefix, label)


def all_slots(data: dict | None = None) -> list[Slot]:
    """Every object of the cheap base scene, then what each variant adds: the sub-objects it
    sets and, restricted to the variant's keys, its parent's plain fields."""
    if data is None:
        data = scene_for(Case("base", "base", ()))
    out = list(_slots(schema.Scenario, (), data, (), "base"))
    for v in VARIANTS:
        parent_model = _model_at(data, v.at)
        parent_data = copy.deepcopy(get_path(data, v.at) if v.at else data)
        parent_data.update(copy.deepcopy(v.patch))
        prefix = tuple(((*v.at, k), val) for k, val in v.patch.items())
        plain = tuple(k for k in v.walked if field_leaf(parent_model, k).kind in (
            "number", "int", "literal", "bool"))
        if plain:
            out.append(Slot(parent_model, v.at, parent_data, prefix, v.label, plain))
        for k in v.walked:
            out.extend(_sub_slots(parent_model, v.at, parent_data, k, prefix, v.label))
    return out


def _model_at(data: dict, path: Path_) -> type[BaseModel]:
    """The schema model of the object at ``path`` in a scene."""
    model: type[BaseModel] = schema.Scenario
    cur: Any = data
    i = 0
    while i < len(path):
        name = path[i]
        leaf = field_leaf(model, name)
        cur = cur.get(name) if isinstance(cur, dict) else None
        if leaf.kind == "list":
            i += 1
            cur = cur[path[i]] if cur else None
            leaf = leaf.item
        model = member_for(leaf.models, cur) or leaf.models[0]
        i += 1
    return model


# --------------------------------------------------------------------------- bound values
#: Relative step inside an open bound: far enough that float rounding in a unit conversion
#: (deg -> rad -> deg) does not cross it, close enough to stay "at" the bound.
OPEN_STEP = 1.0e-6
#: An open bound at 0 is approached to this fraction of the field's upper bound: nine
#: decades below the largest value allowed, small for any unit, never a subnormal.
OPEN_ZERO_FRACTION = 1.0e-9


def bound_values(leaf: Leaf) -> list[tuple[str, float | int]]:
    """``[("lower", v), ("upper", v)]`` for a numeric leaf, just inside an open bound."""
    out: list[tuple[str, float | int]] = []
    if leaf.lo is not None:
        lo = leaf.lo
        if leaf.kind == "int":
            out.append(("lower", int(lo) + (1 if leaf.lo_open else 0)))
        elif not leaf.lo_open:
            out.append(("lower", float(lo)))
        elif lo == 0:
            hi = leaf.hi if leaf.hi is not None and leaf.hi > 0 else 1.0
            out.append(("lower", float(hi) * OPEN_ZERO_FRACTION))
        else:
            out.append(("lower", float(lo) + abs(float(lo)) * OPEN_STEP))
    if leaf.hi is not None:
        hi = leaf.hi
        if leaf.kind == "int":
            out.append(("upper", int(hi) - (1 if leaf.hi_open else 0)))
        elif not leaf.hi_open:
            out.append(("upper", float(hi)))
        elif hi == 0:
            lo = abs(leaf.lo) if leaf.lo else 1.0
            out.append(("upper", -float(lo) * OPEN_ZERO_FRACTION))
        else:
            out.append(("upper", float(hi) - abs(float(hi)) * OPEN_STEP))
    return out


def _qualname(model: type[BaseModel], name: str) -> str:
    return f"{model.__name__}.{name}"


def _set_somewhere(slots: Sequence[Slot]) -> set[str]:
    """``Model.field`` names some slot gives a value (so slots where it is None skip it)."""
    out = set()
    for s in slots:
        for name in s.model.model_fields:
            if s.data.get(name) is not None:
                out.add(_qualname(s.model, name))
    return out


def field_cases(slots: Sequence[Slot] | None = None) -> list[Case]:
    """Single-field cases: every numeric field at both bounds, every Literal choice and bool
    value, in every slot; and each variant's minimal sub-object as it is."""
    if slots is None:
        slots = all_slots()
    given = _set_somewhere(slots)
    cases: list[Case] = []
    seen: set[tuple] = set()
    members = _union_members()

    def kinds(label: str) -> tuple[str, ...]:
        # a union member's `type` is exercised by any case that puts that member in the scene
        return tuple(sorted({_qualname(s.model, "type") for s in slots
                             if s.label == label and s.model in members}))

    cases.append(Case("base", "variant", (), fields=kinds("base")))
    for v in VARIANTS:
        edits = tuple(((*v.at, k), val) for k, val in v.patch.items())
        cases.append(Case(f"[{v.label}]", "variant", edits, pe=needs_pe(edits),
                          fields=kinds(v.label)))
    for s in slots:
        for name in s.model.model_fields:
            if s.only is not None and name not in s.only:
                continue
            leaf = field_leaf(s.model, name)
            value = _field_value(s.model, s.data, name)
            q = _qualname(s.model, name)
            if leaf.kind in ("number", "int"):
                if value is None and q in given:
                    continue  # another slot sets it; here it belongs to a one-of group
                values: list[tuple[str, Any]] = list(bound_values(leaf))
                path = (*s.path, name)
            elif leaf.kind == "list" and leaf.item is not None and leaf.item.kind in (
                    "number", "int") and value:
                values = list(bound_values(leaf.item))
                path = (*s.path, name, len(value) - 1)
            elif leaf.kind in ("literal", "bool"):
                values = [(repr(c), c) for c in leaf.choices if c != value]
                path = (*s.path, name)
                if name == "type" and (_is_union_tag(s) or s.label != "base"):
                    continue  # a variant's kind: the base walks the choices, once
            else:
                continue
            for _label, v in values:
                key = (json.dumps(s.prefix, default=str), path, repr(v))
                if key in seen:
                    continue
                seen.add(key)
                edits = (*s.prefix, (path, v))
                tag = "" if s.label == "base" else f"[{s.label}] "
                cases.append(Case(f"{tag}{fmt_path(path)}={fmt_value(v)}",
                                  "bound" if leaf.kind in ("number", "int", "list")
                                  else "choice", edits, pe=needs_pe(edits), fields=(q,)))
    return cases


def _is_union_tag(s: Slot) -> bool:
    """Whether ``s.model.type`` discriminates a union (its other choices are other models,
    reached through :data:`VARIANTS`)."""
    return s.model in _union_members()


@functools.cache
def _union_members() -> frozenset[type[BaseModel]]:
    """Models that are members of a union of several models somewhere in the schema."""
    return frozenset(m for parent in _all_models() for n in parent.model_fields
                     for leaf in [_unwrap_items(field_leaf(parent, n))]
                     if leaf.kind == "union" for m in leaf.models)


def _unwrap_items(leaf: Leaf) -> Leaf:
    return leaf.item if leaf.kind == "list" and leaf.item is not None else leaf


@functools.cache
def _all_models() -> tuple[type[BaseModel], ...]:
    """Every model class reachable from :class:`Scenario`."""
    out: list[type[BaseModel]] = []
    todo: list[type[BaseModel]] = [schema.Scenario]
    while todo:
        m = todo.pop()
        if m in out:
            continue
        out.append(m)
        for n in m.model_fields:
            leaf = _unwrap_items(field_leaf(m, n))
            todo.extend(leaf.models)
    return tuple(out)


def schema_fields() -> set[str]:
    """``Model.field`` of every numeric, Literal or bool field in the schema (what the
    campaign must exercise)."""
    out = set()
    for m in _all_models():
        for n in m.model_fields:
            leaf = _unwrap_items(field_leaf(m, n))
            if leaf.kind in ("number", "int", "literal", "bool"):
                if leaf.kind in ("number", "int") and leaf.lo is None and leaf.hi is None:
                    continue  # no declared bound (checked by a validator): see interactions
                out.add(_qualname(m, n))
    return out


def coverage_gaps(cases: Sequence[Case]) -> set[str]:
    """Schema fields that no case sets to a value of its own."""
    covered = {f for c in cases for f in c.fields}
    return schema_fields() - covered


# --------------------------------------------------------------------------- interactions
def _radar(**fields: Any) -> tuple[tuple[Path_, Any], ...]:
    return tuple(((*_RADAR, k), v) for k, v in fields.items())


def _just_above(x: float) -> float:
    return x * (1.0 + OPEN_STEP)


def interaction_cases() -> list[Case]:
    """The combinations of fields that interact (issue 23, item 2), listed explicitly."""
    out: list[Case] = []

    def add(group_name: str, edits: tuple[tuple[Path_, Any], ...], heavy: str = "",
            pe: bool | None = None) -> None:
        # `heavy` is the reason known beforehand, used when shipradar.tables.budget has no estimate
        label = ", ".join(f"{fmt_path(p).removeprefix('platforms[0].radars[0].')}"
                          f"={fmt_value(v)}" for p, v in edits)
        pe = needs_pe(edits) if pe is None else pe
        reason = heavy_reason(edits, pe)
        if not _has_build_estimate():
            reason = reason or heavy
        out.append(Case(f"{group_name}: {label}", "interaction", edits, pe=pe, heavy=reason))

    # rotation x beamwidth x PRF: pulses per beamwidth N = f_r θ_b / (6 rpm), from far below
    # one to thousands (the seed's [73]-[77] and the error model [84]-[89] need N >= 1)
    for rpm in (_just_above(0.5), 60.0, 120.0):
        for bw in (_just_above(0.05), 1.8, 20.0):
            for prf in (50.0, 5000.0, 20000.0):
                add("rotation x beamwidth x prf",
                    _radar(rotation_rpm=rpm, beamwidth_az_deg=bw, prf_hz=prf))
    add("rotation x beamwidth x prf", _radar(rotation_rpm=120.0, beamwidth_az_deg=1.8,
                                             prf_hz=360.0))  # 0.9 pulse per beamwidth
    add("rotation x beamwidth x prf", _radar(rotation_rpm=120.0, beamwidth_az_deg=1.8,
                                             prf_hz=400.0))  # exactly 1.0
    for proc in ("none", "mti"):
        add("rotation x beamwidth x prf", (*_radar(rotation_rpm=120.0, beamwidth_az_deg=1.8,
                                                   prf_hz=360.0),
                                           ((*_RADAR, "processor"), {"type": proc})))

    # antenna height x target altitude x duct height (the PE table's top, the duct's trap)
    tiny_h = 200.0 * OPEN_ZERO_FRACTION
    for h_a, alt, duct in ((101.0, 1.0, 40.0), (200.0, 0.0, 60.0), (200.0, 30000.0, 0.0),
                           (tiny_h, 0.0, 0.0), (tiny_h, 30000.0, 60.0), (1.0, 1.0, 60.0),
                           (25.0, 0.0, 60.0), (200.0, 1.0, 0.0), (1.0, 1500.0, 20.0)):
        add("antenna height x target altitude x duct", (
            *_radar(antenna_height_m=h_a),
            ((*_TARGET, "waypoints", 0, "altitude_m"), alt),
            ((*_TARGET, "waypoints", 1, "altitude_m"), alt),
            (("environment", "duct"), {"type": "height", "height_m": duct})))

    # frequency x instrumented range x PE grid (the PE table's size)
    for f in (5.0e8, 1.0e11):
        for rng in (_just_above(1000.0), 60000.0, 1.0e6):
            for grid in ("coarse", "standard", "fine"):
                edits = (*_radar(frequency_hz=f, instrumented_range_m=rng),
                         (("fidelity", "pe_grid"), grid))
                add("frequency x range x pe_grid", edits)

    # wind 0 x sea state 9 and the other corners of the sea
    for wind, state, wave in ((0.0, 9, None), (40.0, 0, None), (0.0, 9, 0.0), (0.0, 0, 20.0),
                              (40.0, 9, 20.0), (0.0, 0, 0.0)):
        edits = ((("environment", "wind_speed_mps"), wind), (("environment", "sea_state"), state))
        if wave is not None:
            edits = (*edits, (("environment", "wave_height_m"), wave))
        add("wind x sea state", edits, pe=False)

    # rain rate x range (x frequency, kind): the rain loss and the weather map's folding
    for rate in (300.0 * OPEN_ZERO_FRACTION, 300.0):
        for rng in (_just_above(1000.0), 60000.0, 1.0e6):
            add("rain rate x range", (
                (("environment", "rain"), {"rate_mm_h": rate}),
                *_radar(instrumented_range_m=rng)), pe=False)
    for kind in ("rain", "dry_snow", "wet_snow"):
        add("rain rate x range", (
            (("environment", "rain"), {"rate_mm_h": 300.0, "kind": kind,
                                       "region": {"radius_m": 2.0e6}}),
            *_radar(instrumented_range_m=1.0e6, frequency_hz=3.5e10)), pe=False)

    # jammer power x sidelobe level (the floor L_sl under the azimuth pattern)
    for power in (1.0e6 * OPEN_ZERO_FRACTION, 1.0e6):
        for jsl in (3.0, 90.0):
            for sl in (13.26, 60.0):
                add("jammer power x sidelobe", (
                    (("jammers",), [{"id": "jam1", "waypoints": [
                        {"time_s": 0, "east_m": 30000, "north_m": 10000, "altitude_m": 3000}],
                        "power_w": 1.0, "gain_db": 40.0, "bandwidth_hz": 1.0e5}]),
                    (("jammers", 0, "power_w"), power),
                    ((*_RADAR, "pattern_az"), {"type": "sinc", "sidelobe_db": sl,
                                               "jamming_sidelobe_db": jsl})))

    # jammer range x frequency x fog/rain: the one-way loss of a jammer far beyond the
    # horizon at millimetre wave reaches thousands of dB
    far = {"id": "jam1", "waypoints": [{"time_s": 0, "east_m": -2.0e6, "north_m": 2.0e6,
                                        "altitude_m": 3000.0}],
           "power_w": 1000.0, "gain_db": 0.0, "bandwidth_hz": 1.0e5}
    for f, weather in ((1.0e11, {"fog": {"liquid_water_g_m3": 1.0}}),
                       (1.0e11, {"fog": {"liquid_water_g_m3": 5.0, "top_m": 10000.0}}),
                       (3.5e10, {"rain": {"rate_mm_h": 300.0, "region": {"radius_m": 2.0e6}}}),
                       (1.0e11, {})):
        add("jammer range x frequency x weather", (
            (("jammers",), [far]), *_radar(frequency_hz=f),
            *((("environment", k), v) for k, v in weather.items())), pe=False)

    # values that are not at any bound, found by the random scenes (scene_strategy)
    add("found", _radar(instrumented_range_m=6931.684596912009))  # P_fac edge at -3.6e-15 m

    # receiver noise: noise figure x antenna temperature x transmit/receive loss (all three
    # at 0 make a noiseless receiver, T_s = 0 K)
    for nf, ta, ltr in ((0.0, 0.0, 0.0), (0.0, 0.0, 20.0), (20.0, 5000.0, 20.0),
                        (0.0, 5000.0, 0.0)):
        add("receiver noise", _radar(noise_figure_db=nf, antenna_temperature_k=ta,
                                     loss_tr_db=ltr))

    # sectors per scan x rotation (sector length from 0.1 ms to 30 s)
    for sectors in (4, 3600):
        for rpm in (_just_above(0.5), 120.0):
            add("sectors x rotation", ((("fidelity", "sectors_per_scan"), sectors),
                                       *_radar(rotation_rpm=rpm)))

    # processor: n_coherent vs n_filters vs mti_order vs window (incl. the 2-tap Hann)
    procs: list[dict[str, Any]] = []
    for typ in ("dft_bank", "fir_bank"):
        for win in ("rectangular", "hann", "hamming", "taylor", "chebyshev"):
            procs.append({"type": typ, "n_coherent": 2, "window": {"type": win}})
        rect = {"type": "rectangular"}
        procs += [{"type": typ, "n_coherent": 2, "n_filters": 256, "window": rect},
                  {"type": typ, "n_coherent": 256, "n_filters": 1},
                  {"type": typ, "n_coherent": 256, "n_filters": 256},
                  {"type": typ, "n_coherent": 2, "n_filters": 1, "window": rect},
                  {"type": typ, "n_coherent": 2, "n_filters": 2, "window": rect},
                  {"type": typ, "n_coherent": 256,
                   "window": {"type": "chebyshev", "sidelobe_db": 120.0}},
                  {"type": typ, "n_coherent": 256, "window": {"type": "taylor",
                                                              "sidelobe_db": 13.0}}]
    procs += [{"type": "mti_bank", "mti_order": 6, "n_coherent": 2},
              {"type": "mti_bank", "mti_order": 6, "n_coherent": 7},
              {"type": "mti_bank", "mti_order": 6, "n_coherent": 8},
              {"type": "mti_bank", "mti_order": 6, "n_coherent": 8,
               "window": {"type": "rectangular"}},
              {"type": "mti_bank", "mti_order": 6, "n_coherent": 9},
              {"type": "mti_bank", "mti_order": 1, "n_coherent": 2},
              {"type": "mti_bank", "mti_order": 6, "n_coherent": 256, "n_filters": 256},
              {"type": "mti_bank", "mti_order": 1, "n_coherent": 256, "n_filters": 1},
              {"type": "mti_bank", "mti_order": 2, "n_coherent": 8, "window": {"type": "hann"}},
              {"type": "mti", "mti_order": 6}, {"type": "mti", "mti_order": 1}]
    for p in procs:
        add("processor", (((*_RADAR, "processor"), p),))
    # staggered PRFs against the bank (the I_F table integrates over the stagger)
    add("processor x stagger", _radar(stagger_prf_hz=[50.0, 60.0], prf_hz=50.0,
                                      transmitted_pulse_width_s=None))
    add("processor x stagger", _radar(stagger_prf_hz=[4999.0 + i for i in range(16)]))
    add("processor x stagger", _radar(
        stagger_prf_hz=[499000.0, 500000.0], prf_hz=500000.0, pulse_width_s=1.0e-8,
        transmitted_pulse_width_s=None,
        processor={"type": "fir_bank", "n_coherent": 256}),
        heavy="a 256-tap FIR bank's I_F table over a 499/500 kHz stagger (77 s in issue 23)")

    out.extend(companion_cases())
    return out


def companion_cases() -> list[Case]:
    """Bounds that a cross-field rule refuses in the base scene, with the other fields set
    so that the bound itself runs (each companion documented inline)."""
    out: list[Case] = []

    def add(q: str, edits: tuple[tuple[Path_, Any], ...], why: str) -> None:
        label = ", ".join(f"{fmt_path(p)}={fmt_value(v)}" for p, v in edits)
        out.append(Case(f"companion ({why}): {label}", "companion", edits,
                        pe=needs_pe(edits), fields=(q,)))

    # the duty cycles f_r τ' < 0.25 and f_r τ < 0.5 refuse these with the base's pulses
    add("Radar.prf_hz", _radar(prf_hz=5.0e5, pulse_width_s=1.0e-8,
                               transmitted_pulse_width_s=None), "10 ns pulse")
    add("Radar.pulse_width_s", _radar(pulse_width_s=1.0e-3, prf_hz=200.0,
                                      transmitted_pulse_width_s=None), "200 Hz PRF")
    add("Radar.transmitted_pulse_width_s", _radar(transmitted_pulse_width_s=1.0e-3,
                                                  prf_hz=200.0), "200 Hz PRF")
    # waypoint times must increase: the last waypoint at the upper bound
    add("Waypoint.time_s", (((*_TARGET, "waypoints", 1, "time_s"), 1.0e7),), "last waypoint")
    add("Radar.transmitted_pulse_width_s", _radar(transmitted_pulse_width_s=1.0e-8,
                                                  pulse_width_s=1.0e-8), "10 ns pulse")
    # manoeuvres: a bound is flyable only with the other fields of its segment to match
    seg = (*_TARGET, "segments")
    start = tuple(((*_TARGET, k), v) for k, v in _SEGMENT_TARGET.items())
    add("ClimbSegment.to_altitude_m", (*start, (seg, [
        {"type": "climb", "to_altitude_m": 30000.0, "duration_s": 200.0}])), "a 200 s climb")
    add("ClimbSegment.duration_s", (*start, (seg, [
        {"type": "climb", "to_altitude_m": 5.00001, "duration_s": 1.0e-4}])), "a 10 um climb")
    add("PopupSegment.peak_altitude_m", (*start, (seg, [
        {"type": "popup", "peak_altitude_m": 30000.0, "climb_s": 200.0, "dive_s": 200.0}])),
        "200 s up and down")
    add("PopupSegment.climb_s", (*start, (seg, [
        {"type": "popup", "peak_altitude_m": 5.00001, "climb_s": 1.0e-6, "dive_s": 1.0e-6}])),
        "a 10 um pop-up")
    add("WeaveSegment.amplitude_m", (*start, (seg, [
        {"type": "weave", "amplitude_m": 10000.0, "period_s": 3600.0, "duration_s": 20.0}])),
        "an hour's period")
    add("WeaveSegment.period_s", (*start, (seg, [
        {"type": "weave", "amplitude_m": 1.0, "period_s": 0.2000002, "duration_s": 20.0}])),
        "a 1 m weave")
    # the exact P_d is for a square-law detector with uniform integration
    for det in ("linear", "log"):
        add("Radar.detector", (*_radar(detector=det), (("fidelity", "pd_method"), "seed")),
            "seed P_d")
    for integ in ("non_uniform", "single_loop", "double_loop"):
        add("Radar.integrator", (*_radar(integrator=integ), (("fidelity", "pd_method"), "seed")),
            "seed P_d")
    return out


def pe_work(scene: schema.Scenario) -> list[tuple[str, float]]:
    """Split-step work of each radar's PE table: height points x range steps [-].

    From the builder's own grid rules
    (:func:`shipradar.sensors.parabolic_equation.grid_steps` over the PE domain
    :func:`shipradar.sensors.parabolic_equation.pe_top_height`, as
    :mod:`shipradar.tables.budget` does); the demo's 60 km C-band table is ~3e6 and builds in
    about a second on one core.
    """
    from shipradar.sensors import propagation as prop
    from shipradar.sensors.parabolic_equation import grid_steps, pe_top_height
    from shipradar.tables.scene import pe_table_height_m, refractivity_profile

    if scene.fidelity.propagation != "pe":
        return []
    profile = prop.profile_from_spec(refractivity_profile(scene))
    out = []
    for _, r in scene.radars():
        top = pe_top_height(pe_table_height_m(scene, r), r.instrumented_range_m,
                            r.antenna_height_m)
        steps = grid_steps(r.frequency_hz, top, r.instrumented_range_m, profile,
                           scene.fidelity.pe_grid, polarization=r.polarization)
        out.append((r.id, steps["n"] * math.ceil(r.instrumented_range_m / steps["dx"])))
    return out


#: PE work above which a case is heavy (about ten seconds of building or more), when the
#: build-time estimate of shipradar.tables.budget is not there to ask.
HEAVY_PE_WORK = 3.0e7
#: Estimated build time above which a case is heavy [s] (the estimate of shipradar.tables.budget).
HEAVY_BUILD_S = 10.0


def _has_build_estimate() -> bool:
    try:
        from shipradar.tables.budget import estimate_build  # noqa: F401
    except ImportError:
        return False
    return True


def heavy_reason(edits: Sequence[tuple[Path_, Any]], pe: bool | None = None) -> str:
    """Why a case's tables are expected to take long to build ('' when they should not).

    Asks the build-time estimate of :mod:`shipradar.tables.budget` (issue 23, item 4) when it
    exists, else the PE grid rules (:func:`pe_work`): a case is heavy above :data:`HEAVY_BUILD_S`.
    """
    from shipradar.sim.world.scenario import ScenarioError, parse_scenario

    data = scene_for(Case("probe", "probe", tuple(edits),
                          pe=needs_pe(edits) if pe is None else pe))
    try:
        scene = parse_scenario(data)
    except (ScenarioError, ArithmeticError):
        return ""
    try:
        from shipradar.tables.budget import estimate_build
    except ImportError:
        estimate_build = None
    if estimate_build is not None:
        slow = [e for e in estimate_build(scene) if e.seconds > HEAVY_BUILD_S]
        return "; ".join(f"radar {e.radar_id}'s {e.kind} table, ~{e.seconds:.0f} s estimated "
                         f"({e.detail})" for e in slow)
    for radar_id, work in pe_work(scene):
        if work > HEAVY_PE_WORK:
            return f"radar {radar_id}'s PE table: {work:.2g} height points x range steps"
    return ""


def all_cases(mode: str = "default") -> list[Case]:
    """The campaign: ``quick`` (single fields), ``default`` (+ interactions, no heavy case),
    ``all`` (+ heavy cases), ``heavy`` (the heavy cases alone)."""
    cases = field_cases()
    cases = [c if c.heavy or not c.pe else _with_heavy(c) for c in cases]
    if mode != "quick":
        cases += interaction_cases()
    if mode == "heavy":
        return [c for c in cases if c.heavy]
    if mode != "all":
        cases = [c for c in cases if not c.heavy]
    return cases


def _with_heavy(c: Case) -> Case:
    reason = heavy_reason(c.edits, c.pe)
    return Case(c.id, c.group, c.edits, c.pe, reason, c.fields) if reason else c


# =========================================================================== random scenes
#: What the random scenes hold fixed, for cost: a few simulated seconds, and no PE (its
#: cost is set by the PE inputs and reaches minutes at some corners; the campaign's PE cases
#: cover it). Everything else is drawn.
RANDOM_DURATION_S = (0.5, 2.0)
RANDOM_PROPAGATION = ("free_space", "two_ray")
_MISSING = object()


def variant_groups() -> list[list[Variant]]:
    """The variants, grouped so that two that patch a key of the same object (two
    processors, two duct kinds, a segment and smoothing) are in one group."""
    groups: list[list[Variant]] = []
    for v in VARIANTS:
        keys = {(v.at, k) for k in v.patch}
        hit = [g for g in groups if any({(w.at, k) for k in w.patch} & keys for w in g)]
        groups = [g for g in groups if g not in hit] + [[w for g in hit for w in g] + [v]]
    return groups


def _draw_number(draw: Any, st: Any, leaf: Leaf) -> float | int:
    """A value inside a field's bounds: a bound itself, uniform, or log-uniform when the
    range spans decades above 0 (so that 1e-3 and 1e6 are both drawn), never a subnormal;
    an unbounded float is drawn in [−1e6, 1e6] as an unbounded int is."""
    if leaf.kind == "int":
        lo = int(leaf.lo) + (1 if leaf.lo_open else 0) if leaf.lo is not None else -10**6
        hi = int(leaf.hi) - (1 if leaf.hi_open else 0) if leaf.hi is not None else 10**6
        return draw(st.integers(lo, hi))
    # a field bounded by its container's rule instead of its own (ErrorTerm.mean: each
    # sensor-error field sets its limit), drawn in the ints' default span; _repair puts
    # back what the container refuses
    bounds = [v for _, v in bound_values(leaf)] or [-1.0e6, 0.0, 1.0e6]
    lo, hi = min(bounds), max(bounds)
    options = [st.sampled_from(bounds), st.floats(lo, hi, allow_nan=False)]
    if lo > 0 and hi / lo > 100:
        options.append(st.floats(math.log10(lo), math.log10(hi)).map(
            lambda x: min(max(10.0 ** x, lo), hi)))
    return draw(st.one_of(options))


def _parent(path: str) -> str:
    m = re.match(r"^(.*)(\.[A-Za-z_]\w*|\[\d+\])$", path)
    return m.group(1) if m else ""


def _repair(data: dict, original: dict[Path_, Any]) -> bool:
    """Put drawn fields back to their original value until the schema accepts the scene.

    A cross-field rule (duty cycle, pulses per beamwidth, waypoint order, a segment's slope)
    names a path; the drawn fields under it go back first, then those under its parent.
    Returns False when the scene still does not validate.
    """
    from shipradar.sim.world.scenario import ScenarioError, parse_scenario

    for _ in range(12):
        try:
            parse_scenario(data)
            return True
        except ScenarioError as exc:
            lines = exc.lines
        except Exception:  # noqa: BLE001 - the schema crashed: let run_scene report it
            return True
        reset: list[Path_] = []
        for line in lines:
            m = _FIELD_LINE.match(line)
            named = m.group("path") if m else ""
            while True:
                under = [k for k in original if not named or fmt_path(k) == named
                         or fmt_path(k).startswith((named + ".", named + "["))]
                if under or not named:
                    break
                named = _parent(named)
            reset += under
        if not reset:
            return False
        for k in set(reset):
            value = original.pop(k)
            if value is _MISSING:
                parent = get_path(data, k[:-1])
                if isinstance(parent, dict):
                    parent.pop(k[-1], None)
            else:
                set_path(data, k, value)
    return False


def scene_strategy() -> Any:
    """Hypothesis strategy over whole valid scenes, ``(scene dict, drawn {path: value})``.

    The cheap base scene, a random choice among each group of :func:`variant_groups` (or
    none), then a value drawn for every numeric, Literal and bool field the scene then has
    (optional numbers drawn or left unset), except the fixed :data:`RANDOM_DURATION_S`,
    :data:`RANDOM_PROPAGATION` and the kind of a union member. Draws that a cross-field rule
    refuses are put back (:func:`_repair`); scenes that still do not validate are rejected.
    """
    from hypothesis import reject
    from hypothesis import strategies as st

    groups = variant_groups()
    members = _union_members()

    @st.composite
    def scenes(draw: Any) -> tuple[dict, dict[str, Any]]:
        data = scene_for(Case("random", "random", ()))
        for g in groups:
            v = draw(st.sampled_from([None, *g]))
            if v is not None:
                for k, val in v.patch.items():
                    set_path(data, (*v.at, k), val)
        original: dict[Path_, Any] = {}
        for slot in list(_slots(schema.Scenario, (), copy.deepcopy(data), (), "random")):
            for name in slot.model.model_fields:
                path = (*slot.path, name)
                leaf = field_leaf(slot.model, name)
                given = name in slot.data and slot.data[name] is not None
                if name == "type" and slot.model in members:
                    continue
                if leaf.kind in ("number", "int"):
                    if not given and slot.model.model_fields[name].default is None and not draw(
                            st.booleans()):
                        continue
                    value: Any = _draw_number(draw, st, leaf)
                elif leaf.kind in ("literal", "bool"):
                    value = draw(st.sampled_from(leaf.choices))
                else:
                    continue
                if path == ("duration_s",):
                    value = draw(st.floats(*RANDOM_DURATION_S))
                elif path == ("fidelity", "propagation"):
                    value = draw(st.sampled_from(RANDOM_PROPAGATION))
                original[path] = copy.deepcopy(get_path(data, path)) if name in (
                    get_path(data, slot.path) or {}) else _MISSING
                set_path(data, path, value)
        if not _repair(data, original):
            reject()
        return data, {fmt_path(k): get_path(data, k) for k in original}

    return scenes()


# =========================================================================== running
@dataclass
class Outcome:
    """What one case did."""

    case: str
    group: str
    status: str  # ran, refused, failed
    exit_code: int | None
    wall_s: float
    detail: str = ""
    plots: int = 0
    messages: int = 0
    stage: str = ""  # for a refusal: validate (schema) or run (budget, build limit)
    problems: list[str] = field(default_factory=list)


#: A refusal names a field path: ``a.b[0].c: ...`` (after the scene file's own path).
_FIELD_LINE = re.compile(r"^(?P<path>[A-Za-z_][\w]*(?:\[\d+\]|\.[A-Za-z_]\w*)*): ")


def _known_names() -> set[str]:
    return {n for m in _all_models() for n in m.model_fields}


def check_refusal(stderr: str, scene_path: str) -> list[str]:
    """Problems with a refusal's stderr: exactly one line, naming a schema field."""
    lines = stderr.splitlines()
    if len(lines) != 1:
        return [f"refusal has {len(lines)} stderr lines, want 1: {stderr[-600:]!r}"]
    line = lines[0].removeprefix(f"{scene_path}: ")
    m = _FIELD_LINE.match(line)
    if m is None:
        return [f"refusal does not start with a field path: {line!r}"]
    names = re.findall(r"[A-Za-z_]\w*", m.group("path"))
    if not set(names) <= _known_names():
        return [f"refusal names {m.group('path')!r}, not a schema field path: {line!r}"]
    return []


def _finite_json(text: str) -> Any:
    def bad(token: str) -> Any:
        raise ValueError(f"non-finite number {token} in the summary")

    return json.loads(text, parse_constant=bad)


def _nonfinite_numbers(obj: Any, where: str = "") -> list[str]:
    """Paths of non-finite floats (scalars or arrays) inside a decoded message."""
    out: list[str] = []
    if isinstance(obj, dict):
        for k, v in obj.items():
            out += _nonfinite_numbers(v, f"{where}.{k}")
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            out += _nonfinite_numbers(v, f"{where}[{i}]")
    elif isinstance(obj, float) and not math.isfinite(obj):
        out.append(f"{where}={obj}")
    elif isinstance(obj, np.ndarray) and obj.dtype.kind in "fc" and obj.size:
        bad = ~np.isfinite(obj)
        if bad.any():
            out.append(f"{where}: {int(bad.sum())} of {obj.size} non-finite "
                       f"(first {obj[bad][0]})")
    return out


#: Plot columns that are NaN by design for a radar without a Doppler bank (docs/protocol.md).
DOPPLER_COLUMNS = ("range_rate_mps", "sigma_range_rate_mps", "range_rate_reference_mps")
#: Processor types without a Doppler bank.
NO_BANK = ("none", "mti")


#: truth[plots] columns that are NaN by design for a false alarm (docs/protocol.md §4.4).
TRUE_PLOT_COLUMNS = ("true_range_m", "true_azimuth_rad", "true_range_rate_mps")
#: truth[targets] columns that are NaN by design: the states of an inactive target, and the
#: last look's results before any look (docs/protocol.md §4.4).
STATE_COLUMNS = ("east_m", "north_m", "up_m", "v_east_mps", "v_north_mps", "v_up_mps",
                 "a_east_mps2", "a_north_mps2", "a_up_mps2")
LOOK_COLUMNS = ("look_time_s", "pd", "snr_db")
#: truth[sensors] keys that are NaN by design: the latency of a scan that sent no ``plots``
#: message (docs/protocol.md §4.4).
SENSOR_NAN_KEYS = ("latency_s",)


def _truth_problems(body: dict[str, Any]) -> list[str]:
    """Non-finite truth values, except where the protocol makes them NaN: a false alarm's
    true geometry, an inactive target's state, a target's last look before it had one, the
    latency of a scan that sent no plots."""
    if body.get("kind") == "sensors":
        return [p for key, v in body.items() if key not in SENSOR_NAN_KEYS
                for p in _nonfinite_numbers(v, f".{key}")]
    if body.get("kind") == "plots":
        target = np.asarray(body["origin"]) == 0
        out = []
        for key, col in body.items():
            if key in TRUE_PLOT_COLUMNS:
                if np.isfinite(np.asarray(col)[~target]).any():
                    out.append(f".{key}: a false alarm's is not NaN")
                col = np.asarray(col)[target]
            out += _nonfinite_numbers(col, f".{key}")
        return out
    active = np.asarray(body.get("active", []), dtype=bool)
    looked = np.isfinite(np.asarray(body.get("look_time_s", np.zeros(active.size)),
                                    dtype=np.float64))
    out = []
    for key, col in body.items():
        if key in STATE_COLUMNS:
            col = np.asarray(col)[active]
        elif key in LOOK_COLUMNS:
            col = np.asarray(col)[looked]
        out += _nonfinite_numbers(col, f".{key}")
    return out


def check_recording(path: Path, scene: schema.Scenario) -> tuple[list[str], int, int]:
    """Decode every message of a recording and check it (issue 23, item 2).

    Returns
    -------
    problems, plots, messages
        One line per problem (at most a few per kind), the plot count and message count.
    """
    from shipradar.sim.stream.protocol import decode
    from shipradar.sim.stream.recording import read_recording, verify_recording

    banks = {r.id: r.processor.type not in NO_BANK for _, r in scene.radars()}
    problems: list[str] = []
    plots = messages = 0
    report = verify_recording(path)
    if report["status"] != "clean":
        problems.append(f"recording {report['status']}: {report['damage']}")
    two_pi = 2.0 * math.pi
    with read_recording(path, strict=True) as reader:
        for _t, frames in reader:
            topic, t_msg, body = decode(frames)
            messages += 1
            if not math.isfinite(t_msg):
                problems.append(f"{topic!r} message time {t_msg}")
            if topic == b"plots":
                n = len(body["plot_id"])
                plots += n
                bank = banks.get(body["sensor"], True)
                for key, col in body.items():
                    if not isinstance(col, np.ndarray) or col.dtype.kind != "f":
                        continue
                    if key in DOPPLER_COLUMNS and not bank:
                        if not np.isnan(col).all():
                            problems.append(f"plots.{key}: not NaN without a Doppler bank")
                        continue
                    problems += [f"plots{p}" for p in _nonfinite_numbers(col, f".{key}")]
                az = body["azimuth_rad"]
                if ((az < 0) | (az >= two_pi)).any():
                    problems.append(f"plots.azimuth_rad outside [0, 2pi): "
                                    f"{az[(az < 0) | (az >= two_pi)][:3]}")
                for key in ("sigma_range_m", "sigma_azimuth_rad") + (
                        ("sigma_range_rate_mps",) if bank else ()):
                    s = body[key]
                    if (~(s > 0)).any():
                        problems.append(f"plots.{key} not > 0: {s[~(s > 0)][:3]}")
                t = body["time_s"]
                # a radar's clock errors (issue 33) stamp plots up to its offset and jitter
                # (6 sigma) outside the run
                slack = 1e-6 + max(abs(e.time_offset_s.mean) + 6.0 * (
                    e.time_offset_s.sigma + e.time_jitter_s)
                    for e in (r.errors for _, r in scene.radars()))
                if ((t < -slack) | (t > scene.duration_s + slack)).any():
                    problems.append("plots.time_s outside the run")
            elif topic == b"truth":
                problems += [f"truth{p}" for p in _truth_problems(body)]
            else:
                problems += [f"{topic.decode()}{p}" for p in _nonfinite_numbers(body)]
    # one line per kind of problem is enough to reproduce it
    seen: dict[str, str] = {}
    for p in problems:
        seen.setdefault(re.sub(r"\[\d+\]|\d+ of \d+.*", "", p), p)
    return list(seen.values()), plots, messages


def _cli_accepts(option: str) -> bool:
    from shipradar.sim.cli import build_parser

    return option in build_parser().format_help() or option in _run_help()


def _run_help() -> str:
    from shipradar.sim.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices["run"].format_help()


#: Build-time limit passed to ``run`` when it has the option [s] (issue 23, item 4): a heavy
#: case is then refused up front instead of building for minutes.
MAX_BUILD_S = 30.0


def run_case(case: Case, workdir: Path) -> Outcome:
    """Run one case in-process and classify it (ran / refused / failed)."""
    try:
        data = scene_for(case)
    except (KeyError, IndexError, TypeError) as exc:
        return Outcome(case.id, case.group, "failed", None, 0.0,
                       f"case does not apply to the base scene: {exc!r}")
    return run_scene(data, case.id, case.group, workdir)


def run_scene(data: dict, name: str, group: str, workdir: Path,
              max_build_s: float | None = None) -> Outcome:
    """Write a scene, run ``shipradar run`` on it in-process, check what it did.

    numpy floating-point errors raise and every warning is recorded while it runs: an
    exception, a ``RuntimeWarning``, an exit code other than 0 and 2, a refusal that is not
    one line naming a field, or a run whose summary or recording holds a non-finite or
    undocumented value makes the outcome ``failed``, with the problems listed.
    """
    from shipradar.sim.cli import main
    from shipradar.sim.world.scenario import ScenarioError, parse_scenario

    safe = re.sub(r"[^\w.=-]+", "_", name)[:80] + f"-{zlib.crc32(name.encode()):08x}"
    scene_path = workdir / f"{safe}.yaml"
    rec_path = workdir / f"{safe}.rec"
    scene_path.write_text(yaml.safe_dump(data, sort_keys=False))
    try:
        scene = parse_scenario(data)
        stage = "run"
    except ScenarioError:
        scene, stage = None, "validate"
    except Exception:  # noqa: BLE001 - the schema itself crashed; main() will show where
        scene, stage = None, "validate"
    validate_code, validate_err, validate_exc = _call_main(["validate", str(scene_path)])
    argv = ["run", str(scene_path), "--record", str(rec_path), "--overwrite", "--quiet"]
    if scene is not None and scene.duration_s > CASE_DURATION_S:
        argv += ["--duration", repr(CASE_DURATION_S)]
    if _has_max_build():
        argv += ["--max-build-s", repr(MAX_BUILD_S if max_build_s is None else max_build_s)]
    out, err = io.StringIO(), io.StringIO()
    old = np.seterr(all="raise", under="ignore")
    t0 = time.perf_counter()
    exc_text = ""
    code: int | None = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                code = main(argv)
        except SystemExit as exc:  # argparse
            code = exc.code if isinstance(exc.code, int) else 1
        except Exception as exc:  # noqa: BLE001 - any exception is the finding
            exc_text = _last_frames(exc)
        finally:
            np.seterr(**old)
    wall = time.perf_counter() - t0
    o = Outcome(name, group, "failed", code, round(wall, 3))
    runtime = [w for w in caught if issubclass(w.category, RuntimeWarning)]
    if runtime:
        w = runtime[0]
        o.problems.append(f"RuntimeWarning at {_short(w.filename)}:{w.lineno}: {w.message}"
                          + (f" (+{len(runtime) - 1} more)" if len(runtime) > 1 else ""))
    if exc_text:
        o.problems.append(exc_text)
    if validate_exc and validate_exc != exc_text:
        o.problems.append(f"validate: {validate_exc}")
    elif validate_code == 2 and code == 2 and validate_err != err.getvalue():
        o.problems.append(f"validate and run refuse differently: {validate_err.strip()!r} vs "
                          f"{err.getvalue().strip()!r}")
    elif validate_code in (0, 2) and code in (0, 2) and validate_code != code and stage != "run":
        o.problems.append(f"validate exits {validate_code}, run exits {code}")
    stderr = err.getvalue()
    if "Traceback" in stderr:
        o.problems.append(f"traceback on stderr: {stderr[-800:]}")
    if code == 2 and not exc_text:
        o.stage = stage
        o.problems += check_refusal(stderr, str(scene_path))
        o.detail = stderr.strip().removeprefix(f"{scene_path}: ")
        if not o.problems:
            o.status = "refused"
    elif code == 0 and not exc_text and scene is None:
        o.problems.append("run accepted a scene that the schema refuses")
    elif code == 0 and not exc_text:
        lines = out.getvalue().strip().splitlines()
        try:
            summary = _finite_json(lines[-1])
            o.detail = (f"{summary.get('scans')} scans, {summary.get('target_plots')} target "
                        f"plots, {summary.get('noise_false_alarms')}+"
                        f"{summary.get('clutter_false_alarms')} false alarms")
        except (ValueError, IndexError) as exc:
            o.problems.append(f"summary: {exc}")
        try:
            problems, o.plots, o.messages = check_recording(rec_path, scene)
            o.problems += problems
        except Exception as exc:  # noqa: BLE001
            o.problems.append(f"reading the recording: {_last_frames(exc)}")
        other = [ln for ln in stderr.splitlines() if not re.match(
            r"^(note: |building |\S+: \w+ table ready in )", ln)]
        if other:
            o.problems.append(f"unexpected stderr: {other[:3]}")
        if not o.problems:
            o.status = "ran"
    elif code is not None and not exc_text:
        o.problems.append(f"exit {code}: {stderr.strip()[-400:]}")
    for p in (scene_path, rec_path):
        if o.status != "failed":
            p.unlink(missing_ok=True)
    return o


def _call_main(argv: list[str]) -> tuple[int | None, str, str]:
    """``shipradar ARGV`` in-process: exit code, stderr, and the exception if one escaped."""
    from shipradar.sim.cli import main

    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            return main(argv), err.getvalue(), ""
    except SystemExit as exc:
        return (exc.code if isinstance(exc.code, int) else 1), err.getvalue(), ""
    except Exception as exc:  # noqa: BLE001 - reported by the caller
        return None, err.getvalue(), _last_frames(exc)


_MAX_BUILD: bool | None = None


def _has_max_build() -> bool:
    global _MAX_BUILD
    if _MAX_BUILD is None:
        _MAX_BUILD = "--max-build-s" in _run_help()
    return _MAX_BUILD


def _short(filename: str) -> str:
    return str(Path(filename).resolve()).removeprefix(str(ROOT) + os.sep)


def _last_frames(exc: BaseException, n: int = 3) -> str:
    """``Type: message`` and the last ``n`` frames as ``file:line in func``."""
    frames = traceback.extract_tb(exc.__traceback__)[-n:]
    where = " <- ".join(f"{_short(f.filename)}:{f.lineno} in {f.name}" for f in reversed(frames))
    return f"{type(exc).__name__}: {str(exc)[:300]} at {where}"


def run_campaign(cases: Sequence[Case], workdir: Path | None = None,
                 progress: bool = False) -> list[Outcome]:
    """Run cases in order in one table cache (``$SHIPRADAR_TABLES`` as set by the caller)."""
    outcomes = []
    with contextlib.ExitStack() as stack:
        if workdir is None:
            workdir = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="extremes-")))
        for i, case in enumerate(cases):
            o = run_case(case, workdir)
            outcomes.append(o)
            if progress:
                print(f"[{i + 1}/{len(cases)}] {o.status:7s} {o.wall_s:6.2f}s {case.id}",
                      file=sys.stderr, flush=True)
    return outcomes


def table(outcomes: Sequence[Outcome]) -> str:
    """A plain-text table of every case and its outcome."""
    rows = [f"{'status':8s} {'exit':>4s} {'wall s':>7s} {'plots':>6s}  case -> detail"]
    for o in outcomes:
        detail = "; ".join(o.problems) if o.problems else o.detail
        stage = f"[{o.stage}] " if o.status == "refused" else ""
        rows.append(f"{o.status:8s} {o.exit_code!s:>4s} {o.wall_s:7.2f} {o.plots:6d}  "
                    f"{o.case} -> {stage}{detail}")
    counts = {s: sum(o.status == s for o in outcomes) for s in ("ran", "refused", "failed")}
    rows.append(f"{len(outcomes)} cases: {counts['ran']} ran, {counts['refused']} refused, "
                f"{counts['failed']} failed; {sum(o.wall_s for o in outcomes):.1f} s in runs")
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    """``python -m tests.extremes``: run the campaign, print its table, exit 1 on a failure."""
    p = argparse.ArgumentParser(prog="python -m tests.extremes", description=__doc__.split(
        "\n\n")[0])
    g = p.add_mutually_exclusive_group()
    g.add_argument("--quick", action="store_const", const="quick", dest="mode",
                   help="single-field bounds and choices only")
    g.add_argument("--all", action="store_const", const="all", dest="mode",
                   help="also the heavy cases (long table builds)")
    p.add_argument("--out", default=None, help="write every outcome as JSON here")
    p.add_argument("--only", default=None, help="run the cases whose id contains this text")
    p.add_argument("--list", action="store_true", help="list the cases and stop")
    p.add_argument("--progress", action="store_true", help="a line per case on stderr")
    args = p.parse_args(argv)
    cases = all_cases(args.mode or "default")
    if args.only:
        cases = [c for c in cases if args.only in c.id]
    if args.list:
        for c in cases:
            print(f"{c.group:11s} {'pe ' if c.pe else '   '}{c.id}"
                  + (f"  [heavy: {c.heavy}]" if c.heavy else ""))
        print(f"{len(cases)} cases")
        return 0
    gaps = coverage_gaps(all_cases("all"))
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="extremes-tables-") as tables:
        os.environ.setdefault("SHIPRADAR_TABLES", tables)
        outcomes = run_campaign(cases, progress=args.progress)
    wall = time.perf_counter() - t0
    print(table(outcomes))
    print(f"campaign wall time {wall:.1f} s")
    if gaps:
        print(f"fields no case exercises: {sorted(gaps)}")
    if args.out:
        Path(args.out).write_text(json.dumps({"wall_s": round(wall, 1),
                                              "uncovered": sorted(gaps),
                                              "outcomes": [asdict(o) for o in outcomes]},
                                             indent=1))
    return 1 if any(o.status == "failed" for o in outcomes) or gaps else 0


if __name__ == "__main__":
    sys.exit(main())
