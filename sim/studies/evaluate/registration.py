"""Scores of a tracker's registration (sensor-bias) estimates against the truth (issue 33).

A tracker may publish, beside its ``tracks``, its estimates of each radar's errors on topic
``registration`` (docs/protocol.md section 4.8). Each estimated component is scored against
the radar's true error of ``truth[sensors]`` (section 4.4) over time:

- **truth at an estimate's time**: the radar's ``truth[sensors]`` values (one per end of
  scan) interpolated linearly at the estimate's ``time_s``, held at the first and last value
  outside them (a constant error is exact; a Gauss-Markov error's correlation time is many
  scans). ``azimuth_bias_rad`` is the whole azimuth bias of the radar's plots,
  ``truth[sensors]`` ``azimuth_bias_rad + heading_bias_rad`` (north alignment and gyro: the
  plots cannot tell them apart). A stream without ``truth[sensors]`` comes from a scene
  without errors: every true error is 0;
- **error** d_i = estimate_i − truth(t_i), in the component's unit (m, ppm, rad, s);
- **RMSE** sqrt(mean d_i²) over the estimates at or after the warm-up
  (:attr:`RegistrationConfig.warmup_s`, 0 s by default: every estimate), and the **mean
  error** over the same estimates;
- **time to converge** within a tolerance: the first estimate's time after which every
  |d_i| <= tolerance (the time of the estimate after the last one outside it; the first
  estimate's time when none is outside; NaN, *not converged*, when the last one is outside),
  in simulated seconds since the scenario start, over every estimate (no warm-up). Default
  tolerances (:data:`DEFAULT_TOLERANCES`): 20 m, 100 ppm, 0.05°, 10 ms.

The run's figures (one per radar and estimated component) go to ``per_run`` beside GOSPA as
``registration_<sensor>_rmse_<component>`` (the azimuth's in degrees:
``..._rmse_azimuth_bias_deg``) and ``registration_<sensor>_<component>_converge_s``; the rows
of :func:`score_registration` (in the components' own units) to ``registration.csv`` and
``registration_series.csv``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from shipradar.sim.stream.protocol import ProtocolError, decode
from shipradar.sim.stream.schema import REGISTRATION, TOPIC_REGISTRATION, TRUTH_SENSORS

__all__ = ["COMPONENTS", "DEFAULT_TOLERANCES", "MalformedRegistration", "RegistrationConfig",
           "RegistrationMessage", "RegistrationScores", "check_registration",
           "converge_name", "convergence_time", "registration_from_payload", "rmse_name",
           "run_metric_names", "score_registration", "truth_errors"]

#: The components a tracker may estimate, in the schema's order.
COMPONENTS: tuple[str, ...] = REGISTRATION.keys_of("range_bias_m", "range_scale_ppm",
                                                   "azimuth_bias_rad", "time_offset_s")
#: Their 1σ keys.
SIGMAS: tuple[str, ...] = REGISTRATION.keys_of("sigma_range_bias_m", "sigma_azimuth_bias_rad",
                                               "sigma_time_offset_s")
#: The kind of the ``truth`` messages that carry each radar's true errors.
TRUTH_SENSORS_KIND: str = TRUTH_SENSORS.kind or "sensors"
#: ``truth[sensors]`` keys read (the true errors).
TRUTH_KEYS: tuple[str, ...] = TRUTH_SENSORS.keys_of(
    "time_s", "range_bias_m", "range_scale_ppm", "azimuth_bias_rad", "heading_bias_rad",
    "time_offset_s")

#: Default tolerance of each component, in its unit: 20 m, 100 ppm (5 m at 50 km), 0.05°
#: [rad], 10 ms.
DEFAULT_TOLERANCES: dict[str, float] = {
    "range_bias_m": 20.0, "range_scale_ppm": 100.0,
    "azimuth_bias_rad": math.radians(0.05), "time_offset_s": 0.010}


@dataclass(frozen=True)
class RegistrationConfig:
    """Settings of the registration scores (``shipradar evaluate --reg-*``).

    Attributes
    ----------
    tolerance_range_bias_m : float
        Convergence tolerance of ``range_bias_m`` [m].
    tolerance_range_scale_ppm : float
        Of ``range_scale_ppm`` [ppm].
    tolerance_azimuth_bias_deg : float
        Of ``azimuth_bias_rad``, in degrees [deg].
    tolerance_time_offset_s : float
        Of ``time_offset_s`` [s].
    warmup_s : float
        Estimates before this simulated time are left out of the RMSE and mean error [s].
    """

    tolerance_range_bias_m: float = DEFAULT_TOLERANCES["range_bias_m"]
    tolerance_range_scale_ppm: float = DEFAULT_TOLERANCES["range_scale_ppm"]
    tolerance_azimuth_bias_deg: float = math.degrees(DEFAULT_TOLERANCES["azimuth_bias_rad"])
    tolerance_time_offset_s: float = DEFAULT_TOLERANCES["time_offset_s"]
    warmup_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("tolerance_range_bias_m", "tolerance_range_scale_ppm",
                     "tolerance_azimuth_bias_deg", "tolerance_time_offset_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be > 0, got {v}")
        if not (math.isfinite(self.warmup_s) and self.warmup_s >= 0):
            raise ValueError(f"warmup_s must be >= 0, got {self.warmup_s}")

    def tolerance(self, component: str) -> float:
        """The tolerance of ``component``, in its own unit (azimuth in [rad])."""
        return {"range_bias_m": self.tolerance_range_bias_m,
                "range_scale_ppm": self.tolerance_range_scale_ppm,
                "azimuth_bias_rad": math.radians(self.tolerance_azimuth_bias_deg),
                "time_offset_s": self.tolerance_time_offset_s}[component]


# ------------------------------------------------------------------ the tracker's messages
class MalformedRegistration(ValueError):
    """A ``registration`` message that cannot be scored; ``reason`` is a short class name
    (``registration: undecodable``, ``... missing key``, ``... unknown key``, ``... bad
    value``, ``... no estimate``, ``... unknown sensor``), ``str()`` the detail."""

    def __init__(self, reason: str, detail: str):
        super().__init__(f"{reason}: {detail}")
        self.reason = reason


def _refuse(reason: str, detail: str) -> MalformedRegistration:
    return MalformedRegistration(f"registration: {reason}", detail)


@dataclass(frozen=True)
class RegistrationMessage:
    """One valid ``registration`` message: the estimates of ``sensor``'s errors at
    ``time_s`` [s] (component -> value in its unit), their 1σ when given."""

    time_s: float
    sensor: str
    source: str
    estimates: Mapping[str, float]
    sigmas: Mapping[str, float] = field(default_factory=dict)
    recv_s: float = math.nan  #: wall time received [s], NaN in process


def _number(key: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise _refuse("bad value", f"{key} = {v!r} is not a number")
    x = float(v)
    if not math.isfinite(x):
        raise _refuse("bad value", f"{key} = {x} is not finite (leave a component out "
                                   f"instead)")
    return x


def registration_from_payload(p: Any, recv_s: float = math.nan) -> RegistrationMessage:
    """Check one decoded ``registration`` payload (docs/protocol.md section 4.8).

    Raises
    ------
    MalformedRegistration
        Naming what is wrong: not a map, ``sensor`` or ``time_s`` missing, a key the schema
        does not declare (a misspelt component would otherwise vanish unscored), a value
        that is not a finite number, no estimate at all.
    """
    if not isinstance(p, Mapping):
        raise _refuse("bad type", f"payload is {type(p).__name__}, not a map")
    missing = [k for k in REGISTRATION.keys if REGISTRATION[k].required and k not in p]
    if missing:
        raise _refuse("missing key", ", ".join(missing))
    unknown = sorted(set(p).difference(REGISTRATION.keys))
    if unknown:
        raise _refuse("unknown key", f"{', '.join(map(str, unknown))} (declared: "
                                     f"{', '.join(REGISTRATION.keys)})")
    if not isinstance(p["sensor"], str) or not p["sensor"]:
        raise _refuse("bad value", f"sensor = {p['sensor']!r} is not a radar id")
    source = p.get("source", "")
    if not isinstance(source, str):
        raise _refuse("bad value", f"source = {source!r} is not a string")
    t = _number("time_s", p["time_s"])
    estimates = {k: _number(k, p[k]) for k in COMPONENTS if k in p}
    if not estimates:
        raise _refuse("no estimate", f"none of {', '.join(COMPONENTS)}")
    sigmas = {k: _number(k, p[k]) for k in SIGMAS if k in p}
    return RegistrationMessage(t, p["sensor"], source, estimates, sigmas, recv_s)


def check_registration(frames: Sequence[bytes], recv_s: float = math.nan
                       ) -> RegistrationMessage:
    """Decode and check one ``registration`` message (``[topic, body]`` as received).

    Raises
    ------
    MalformedRegistration
        Naming what is wrong (:func:`registration_from_payload`).
    """
    try:
        topic, _, p = decode(frames)
    except ProtocolError as exc:
        raise _refuse("undecodable", str(exc)) from None
    if topic != TOPIC_REGISTRATION:
        raise _refuse("wrong topic", repr(topic))
    return registration_from_payload(p, recv_s)


# ------------------------------------------------------------------------------ scoring
def truth_errors(sensor_truth: Mapping[str, np.ndarray] | None, component: str,
                 t_s: np.ndarray) -> np.ndarray:
    """The true value of ``component`` at times ``t_s`` [s] (module docstring).

    Parameters
    ----------
    sensor_truth : mapping or None
        One radar's ``truth[sensors]`` columns (:data:`TRUTH_KEYS`, arrays over its ends of
        scan, ``time_s`` increasing); None: a scene without errors (all 0).
    component : str
        One of :data:`COMPONENTS`.
    t_s : ndarray
        Times [s].
    """
    t_s = np.asarray(t_s, float)
    if sensor_truth is None or np.size(sensor_truth["time_s"]) == 0:
        return np.zeros_like(t_s)
    v = np.asarray(sensor_truth[component], float)
    if component == "azimuth_bias_rad":
        v = v + np.asarray(sensor_truth["heading_bias_rad"], float)
    return np.interp(t_s, np.asarray(sensor_truth["time_s"], float), v)


def convergence_time(t_s: np.ndarray, error: np.ndarray, tolerance: float) -> float:
    """The first estimate time after which every |error| <= ``tolerance``.

    Parameters
    ----------
    t_s : ndarray
        Estimate times, increasing [s].
    error : ndarray
        Estimate − truth at those times (any unit).
    tolerance : float
        In the unit of ``error``.

    Returns
    -------
    float
        ``t_s`` of the estimate after the last one outside the tolerance; ``t_s[0]`` when
        none is outside; NaN when the last one is (not converged) or there is none [s].
    """
    out = np.flatnonzero(np.abs(np.asarray(error, float)) > tolerance)
    if len(t_s) == 0 or (out.size and out[-1] == len(t_s) - 1):
        return math.nan
    return float(t_s[0] if out.size == 0 else t_s[out[-1] + 1])


@dataclass
class RegistrationScores:
    """``run``: the per-run figures (to ``per_run``); ``rows``: one per radar and estimated
    component; ``series``: one per estimate (time, estimate, truth, error)."""

    run: dict[str, Any]
    rows: list[dict[str, Any]]
    series: list[dict[str, Any]]


def rmse_name(sensor: str, component: str) -> str:
    """The per-run RMSE figure of a radar's component (its unit the name's suffix: the
    azimuth's in degrees)."""
    shown = "azimuth_bias_deg" if component == "azimuth_bias_rad" else component
    return f"registration_{sensor}_rmse_{shown}"


def converge_name(sensor: str, component: str) -> str:
    """The per-run time-to-converge figure of a radar's component [s]."""
    return f"registration_{sensor}_{component}_converge_s"


def score_registration(messages: Sequence[RegistrationMessage],
                       sensor_truth: Mapping[str, Mapping[str, np.ndarray]],
                       config: RegistrationConfig = RegistrationConfig(),
                       seed: Any = None) -> RegistrationScores:
    """Score a run's registration messages (module docstring).

    Parameters
    ----------
    messages : sequence of RegistrationMessage
        The tracker's valid messages, any order.
    sensor_truth : mapping
        Per radar its ``truth[sensors]`` columns (:func:`truth_errors`); empty for a stream
        without them (every true error 0).
    config : RegistrationConfig
    seed : any
        The run's seed, copied into every row.
    """
    by: dict[tuple[str, str], list[tuple[float, float]]] = {}
    for m in messages:
        for k, v in m.estimates.items():
            by.setdefault((m.sensor, k), []).append((m.time_s, v))
    run: dict[str, Any] = {"registration_messages": len(messages)}
    rows, series = [], []
    for (sensor, comp), pts in sorted(by.items(), key=lambda kv: (
            kv[0][0], COMPONENTS.index(kv[0][1]))):
        pts.sort(key=lambda x: x[0])
        t = np.array([a for a, _ in pts])
        est = np.array([b for _, b in pts])
        truth = truth_errors(sensor_truth.get(sensor), comp, t)
        err = est - truth
        tol = config.tolerance(comp)
        after = t >= config.warmup_s
        rmse = float(np.sqrt(np.mean(err[after] ** 2))) if after.any() else math.nan
        mean_err = float(np.mean(err[after])) if after.any() else math.nan
        conv = convergence_time(t, err, tol)
        run[rmse_name(sensor, comp)] = (math.degrees(rmse) if comp == "azimuth_bias_rad"
                                        else rmse)
        run[converge_name(sensor, comp)] = conv
        rows.append({"seed": seed, "sensor": sensor, "component": comp,
                     "estimates": int(t.size), "scored": int(after.sum()),
                     "warmup_s": config.warmup_s, "rmse": rmse, "mean_error": mean_err,
                     "tolerance": tol, "converge_s": conv,
                     "final_error": float(err[-1]), "truth_final": float(truth[-1])})
        series += [{"seed": seed, "sensor": sensor, "component": comp, "t_s": float(a),
                    "estimate": float(b), "truth": float(c), "error": float(d)}
                   for a, b, c, d in zip(t, est, truth, err, strict=True)]
    return RegistrationScores(run, rows, series)


#: An RMSE and a time are not below 0: their intervals are clipped there, as the study's
#: other figures are (:data:`shipradar.sim.studies.evaluate.stats.BOUNDS`).
_BOUNDS = {"rmse": (0.0, math.inf), "converge_s": (0.0, math.inf)}
_FREE = (-math.inf, math.inf)


def summarise_run_metrics(per_run: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The summary rows (``metric``, ``mean``, ``low``, ``high``, ``runs``) of the
    registration figures of ``per_run`` (:func:`run_metric_names`), each interval clipped
    at 0."""
    from shipradar.sim.studies.evaluate.stats import mean_interval

    out = []
    for k in run_metric_names(per_run):
        m, lo, hi, n = mean_interval((r.get(k) for r in per_run), bounds=_BOUNDS["rmse"])
        out.append({"metric": k, "mean": m, "low": lo, "high": hi, "runs": n})
    return out


def run_metric_names(per_run: Sequence[Mapping[str, Any]]) -> tuple[str, ...]:
    """The registration figures present in ``per_run`` rows, for the study's summary: per
    radar and component (in :func:`score_registration`'s order) its RMSE, then its time to
    converge."""
    names: dict[str, None] = {}
    for r in per_run:
        for k in r:
            if k.startswith("registration_") and k != "registration_messages":
                names.setdefault(k, None)
    return tuple(names)


# ----------------------------------------------------------------------- study and report
def summarise_rows(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Per radar and component, over runs: RMSE, mean error and time to converge (mean and
    95 % interval over the runs that give it), and the runs that converged."""
    from shipradar.sim.studies.evaluate.stats import mean_interval

    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["sensor"], r["component"]), []).append(r)
    out = []
    for (sensor, comp), g in sorted(groups.items(), key=lambda kv: (
            kv[0][0], COMPONENTS.index(kv[0][1]))):
        row: dict[str, Any] = {"sensor": sensor, "component": comp, "runs": len(g),
                               "tolerance": g[0]["tolerance"], "warmup_s": g[0]["warmup_s"]}
        for k in ("rmse", "mean_error", "converge_s"):
            m, lo, hi, _ = mean_interval((r[k] for r in g), bounds=_BOUNDS.get(k, _FREE))
            row[k], row[f"{k}_low"], row[f"{k}_high"] = m, lo, hi
        row["converged_runs"] = sum(math.isfinite(r["converge_s"]) for r in g)
        out.append(row)
    return out


def report_section(out: Any, summary_rows: Sequence[Mapping[str, Any]],
                   series: Sequence[Mapping[str, Any]]) -> str:
    """The report's registration section (HTML) and its figure ``registration.svg`` in
    ``out``: each estimate's error against time for the first run, one panel per component,
    the tolerance as a band. Empty when no run has registration estimates."""
    import html
    from pathlib import Path

    if not summary_rows:
        return ""
    seed = series[0]["seed"] if series else None
    comps = [c for c in COMPONENTS if any(r["component"] == c for r in summary_rows)]
    from shipradar.sim.studies.evaluate.display import Quantity, format_value

    scale = {"azimuth_bias_rad": (math.degrees(1.0), "deg"), "time_offset_s": (1e3, "ms"),
             "range_bias_m": (1.0, "m"), "range_scale_ppm": (1.0, "ppm")}
    decimals = {"deg": 4, "ms": 1, "m": 1, "ppm": 1, "s": 0}
    if series:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(len(comps), 1, figsize=(8, 2.4 * len(comps)), sharex=True,
                                 squeeze=False)
        tol = {r["component"]: r["tolerance"] for r in summary_rows}
        for ax, comp in zip(axes[:, 0], comps, strict=True):
            f, unit = scale[comp]
            for sensor in sorted({r["sensor"] for r in series}):
                pts = [(r["t_s"], r["error"]) for r in series if r["seed"] == seed
                       and r["sensor"] == sensor and r["component"] == comp]
                if pts:
                    p = np.array(pts)
                    ax.plot(p[:, 0], p[:, 1] * f, ".-", ms=3, label=sensor)
            ax.axhspan(-tol[comp] * f, tol[comp] * f, color="g", alpha=0.12,
                       label="tolerance")
            ax.axhline(0.0, color="k", lw=0.5)
            ax.set_ylabel(f"{comp}\nerror [{unit}]", fontsize=8)
            ax.legend(fontsize=7)
        axes[-1, 0].set_xlabel("simulated time [s]")
        axes[0, 0].set_title(f"registration: estimate − truth, seed {seed}", fontsize=9)
        fig.tight_layout()
        fig.savefig(Path(out) / "registration.svg")
        plt.close(fig)

    def fmt(v: Any, f: float = 1.0, unit: str = "s") -> str:
        """Fixed notation (never 1e-05), the unit's decimals: the report's format_value."""
        return format_value(v, Quantity("", unit, decimals[unit], scale=f))

    head = ("<tr><th>sensor</th><th>component</th><th>unit</th><th>RMSE</th>"
            "<th>95 % interval</th><th>mean error</th><th>tolerance</th>"
            "<th>time to converge [s]</th><th>converged runs</th></tr>")
    body = ""
    for r in summary_rows:
        f, unit = scale[r["component"]]
        body += (f"<tr><td>{html.escape(r['sensor'])}</td><td>{r['component']}</td>"
                 f"<td>{unit}</td><td>{fmt(r['rmse'], f, unit)}</td>"
                 f"<td>{fmt(r['rmse_low'], f, unit)} – {fmt(r['rmse_high'], f, unit)}</td>"
                 f"<td>{fmt(r['mean_error'], f, unit)}</td><td>{fmt(r['tolerance'], f, unit)}"
                 f"</td><td>{fmt(r['converge_s'])}</td>"
                 f"<td>{r['converged_runs']} of {r['runs']}</td></tr>")
    warm = summary_rows[0]["warmup_s"]
    parts = [
        "<h2>Registration (the tracker's bias estimates against truth[sensors])</h2>",
        f"<p>RMSE over the estimates at or after {warm:g} s (warm-up), mean over runs with "
        "its 95 % interval; time to converge: the first estimate time after which every "
        "error stays within the tolerance (mean over the runs that converged). Azimuth: "
        "the plots' whole bias, north alignment + gyro.</p>",
        f"<table>{head}{body}</table>"]
    if series:
        parts.append("<img src='registration.svg' alt='registration.svg'>")
    return "\n".join(parts)
