"""The propagation-factor table F(R_t, h) of the off-line level: its grid and axes, builder,
cache glue and lookup (seed [5]-[7]; SPEC section 3; issue 4).

The field comes from the split-step Fourier parabolic-equation solver
:mod:`shipradar.sensors.parabolic_equation` (the method and its choices are described there,
the reasoning and the measured errors in docs/propagation.md).  This module decides where
the table samples it:

* Table: F on (range, w = h / R) (:func:`table_axes`), where the direct/reflected-ray lobes
  are straight lines along range, sampled from the PE nodes by windowed-sinc interpolation
  of the complex field (:func:`shipradar.sensors.parabolic_equation.interpolate_field`) with
  its smooth phase removed (:func:`shipradar.sensors.parabolic_equation.reference_phase`,
  :func:`_align_rows`); :func:`propagation_factor` looks it up at (R, h) in O(1).
* Ducts: where the M-profile has a trapping layer
  (:func:`shipradar.sensors.parabolic_equation.trapping_layer`), the fine w segment samples the
  trapped modes' shortest vertical period ``lambda / (2 theta_trap)`` :data:`MODE_SAMPLES`
  times at max range, up to :data:`TRAP_EXTENT` times the layer's height (issue 36: the
  two-ray/diffraction sampling read surface-based and elevated ducts p95 3-6 dB off the PE,
  with false nulls; now p95 <= 0.26 dB in every height band, docs/propagation.md).
* The PE domain reaches one w cell above the wanted height (:func:`table_pe_height`), and
  :func:`table_grid` gives the grid without building anything (for the cost budget).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.constants as sc
from numpy.typing import ArrayLike

from shipradar.sensors import geometry
from shipradar.sensors import parabolic_equation as pe
from shipradar.sensors import propagation as prop
from shipradar.tables.store import Table, get_or_build

#: Builder name and version (part of the cache key; bump on any change of results).
TABLE_NAME = "propagation_factor"
TABLE_VERSION = 6

#: The table's sampling in h / R for each PE fidelity preset
#: (:data:`shipradar.sensors.parabolic_equation.FIDELITY`): lobe_samples, samples per
#: interference lobe, and surface_step_m, the height step near the surface at max range
#: (see :func:`table_axes`).
TABLE_SAMPLING: dict[str, dict[str, float]] = {
    "coarse": {"lobe_samples": 16, "surface_step_m": 1.0},
    "standard": {"lobe_samples": 32, "surface_step_m": 0.5},
    "fine": {"lobe_samples": 48, "surface_step_m": 0.25},
}


def _align_rows(values: np.ndarray) -> np.ndarray:
    """Rotate each row of a complex table (range rows) onto the previous one.

    A phase common to a whole row is free (only |F| is read) and is what the ray-optical
    reference phase leaves along range (ray bending in ducts, mode phase speeds): each row
    is turned by the argument of its magnitude-weighted correlation with the row before.
    """
    out = values.copy()
    theta = 0.0
    for i in range(1, out.shape[0]):
        prod = values[i] * np.conj(values[i - 1])
        c = np.sum(prod[np.isfinite(prod)])
        theta += float(np.angle(c)) if abs(c) > 0 else 0.0
        out[i] = values[i] * np.exp(-1j * theta)
    return out



# =========================================================================== table grid
def table_axes(
    freq_hz: float,
    antenna_height_m: float,
    max_range_m: float,
    max_height_m: float,
    range_step_m: float,
    max_angle_rad: float,
    fidelity: str = "standard",
    trap: tuple[float, float] = (0.0, 0.0),
) -> tuple[np.ndarray, np.ndarray]:
    """Axes of a propagation table: terrestrial range [m] and height over range w = h / R [1].

    Why h / R: over the sea F is dominated by the interference of the direct and the
    sea-reflected rays, whose phase difference ``2 k h_a h / R`` is (to O((h/R)^2)) a
    function of w alone.  On a (R, h) grid the lobes are 20 m long in range at 5 km and
    300 m in height (the default PE output, range step ~ 175 m, missed them: 5 dB rms
    between range nodes inside 20 km); on a (R, w) grid they are straight lines along R.
    The w axis has two uniform segments (both looked up by index arithmetic):

    * below ``w_low = h_low / R_max``: step ``surface_step / R_max``, so that near the
      surface at long range (ducts, the diffraction zone) heights are sampled every
      ``surface_step`` metres or finer; ``h_low = max(LOW_LAYER_M, 3 h_a)``;
    * above it up to ``tan(max_angle)``: ``lambda / (2 h_a lobe_samples)`` (the lobe
      period in w sampled ``lobe_samples`` times), and no coarser than ``DIFFRACTION_STEP``
      times the natural height unit ``(a_e lambda^2 / (8 pi^2))^(1/3)`` at max range.

    With a trapping layer (``trap``) the fine segment reaches at least ``TRAP_EXTENT`` times
    the layer's M-minimum height and its step is at most ``lambda / (2 theta_trap
    MODE_SAMPLES)`` at max range: the trapped modes interfere with vertical periods down to
    ``lambda / (2 theta_trap)`` (5.6 m at 3 GHz, 1.7 m at 10 GHz for an M deficit of 40),
    and the straight-ray reference phase does not follow their phase, so the complex field
    must be sampled finely enough to be interpolated with its modal phase in it.

    Parameters
    ----------
    freq_hz : float
        [Hz].
    antenna_height_m, max_range_m, max_height_m : float
        [m].
    range_step_m : float
        Range step of the table [m] (the PE step).
    max_angle_rad : float
        Largest propagation angle the PE carries [rad].
    fidelity : str
        Preset of :data:`TABLE_SAMPLING` (``lobe_samples``, ``surface_step_m``).
    trap : (float, float)
        The profile's largest trapped angle [rad] and the height of its trapping layer's M
        minimum [m] (:func:`shipradar.sensors.parabolic_equation.trapping_layer`); (0, 0)
        without a trapping layer.

    Returns
    -------
    ranges_m, w : ndarray
        Range axis (uniform, from ``range_step_m``) and the w axis (0 first).
    """
    preset = TABLE_SAMPLING[fidelity]
    lam = sc.c / freq_hz
    a_e = geometry.K_FACTOR * geometry.EARTH_RADIUS_M
    height_unit = (a_e * lam**2 / (8 * np.pi**2)) ** (1 / 3)
    dw_coarse = min(lam / (2 * antenna_height_m * preset["lobe_samples"]),
                    DIFFRACTION_STEP * height_unit / max_range_m)
    surface_step = preset["surface_step_m"]
    theta_trap, trap_height = trap
    h_low = max(LOW_LAYER_M, 3 * antenna_height_m)
    if theta_trap > 0.0:
        # trapped modes: their shortest vertical period sampled MODE_SAMPLES times at max
        # range, through the trapping layer and TRAP_EXTENT times its height
        surface_step = min(surface_step, lam / (2 * theta_trap * MODE_SAMPLES))
        h_low = max(h_low, TRAP_EXTENT * trap_height)
    dw_fine = min(dw_coarse, surface_step / max_range_m)
    w_max = np.tan(max_angle_rad)
    h_low = min(h_low, max_height_m)
    n_fine = int(np.ceil(h_low / max_range_m / dw_fine))
    w_low = n_fine * dw_fine
    n_coarse = max(1, int(np.ceil((w_max - w_low) / dw_coarse)))
    w = np.concatenate([np.arange(n_fine) * dw_fine, w_low + np.arange(n_coarse + 1) * dw_coarse])
    n_r = int(np.ceil(max_range_m / range_step_m - 1e-9))
    ranges = range_step_m * np.arange(1, n_r + 1)
    return ranges, w


#: Lowest height [m] whose w interval is sampled with the fine (surface) step at max range.
LOW_LAYER_M = 100.0
#: Largest step of the w axis at max range, in natural height units (a_e lambda^2/8pi^2)^(1/3).
DIFFRACTION_STEP = 0.5
#: Samples per shortest trapped-mode period lambda / (2 theta_trap) at max range, and the
#: extent of that fine sampling in heights, in units of the trapping layer's M-minimum height.
MODE_SAMPLES = 8.0
TRAP_EXTENT = 4.0


def table_pe_height(freq_hz: float, antenna_height_m: float,
                    m_of_h: Callable[[ArrayLike], np.ndarray], *, max_range_m: float,
                    max_height_m: float, fidelity: str = "standard",
                    max_angle_rad: float | None = None, polarization: str = "H",
                    surface: str = "sea") -> float:
    """Height [m] the PE of a table must reach: ``max_height_m`` and one w cell above it.

    The w axis needs the PE's range step and angle, the PE domain needs the w axis: the
    first grid is the one of ``max_height_m``, and every height up to it lies in a complete
    cell of the table (:func:`build_propagation_table`).
    """
    first = pe.grid_steps(freq_hz, max_height_m, max_range_m, m_of_h, fidelity, max_angle_rad,
                       polarization=polarization, surface=surface)
    _, w_probe = table_axes(freq_hz, antenna_height_m, max_range_m, max_height_m,
                            first["dx"], first["max_angle_rad"], fidelity,
                            pe.trapping_layer(m_of_h, max_height_m))
    return max_height_m + max_range_m * float(np.max(np.diff(w_probe)))


def table_grid(freq_hz: float, antenna_height_m: float, *, polarization: str,
               profile: Mapping[str, Any] | Callable[[ArrayLike], np.ndarray],
               wave_height_m: float = 0.0, max_range_m: float, max_height_m: float,
               fidelity: str = "standard", max_angle_rad: float | None = None,
               surface: str = "sea") -> dict[str, Any]:
    """The grid :func:`build_propagation_table` would use, without building anything.

    The same rules as the builder (:func:`table_pe_height`,
    :func:`shipradar.sensors.parabolic_equation.pe_top_height`,
    :func:`shipradar.sensors.parabolic_equation.grid_steps`, :func:`table_axes`);
    :mod:`shipradar.tables.budget` reads it to estimate a
    table's memory and build time before any work.

    Returns
    -------
    dict
        ``n`` (PE height intervals), ``n_steps`` (PE range steps), ``dx`` [m], ``dz`` [m],
        ``n_ranges`` and ``n_w`` (the table's shape), ``sampled`` (table cells inside the
        PE's domain and angles, the ones interpolated from the field), ``rough`` (the
        boundary is rebuilt at every step).
    """
    pol = prop.normalize_polarization(polarization)
    m_of_h = prop.profile_from_spec(profile) if isinstance(profile, Mapping) else profile
    top = table_pe_height(freq_hz, antenna_height_m, m_of_h, max_range_m=max_range_m,
                          max_height_m=max_height_m, fidelity=fidelity,
                          max_angle_rad=max_angle_rad, polarization=pol, surface=surface)
    steps = pe.grid_steps(freq_hz, pe.pe_top_height(top, max_range_m, antenna_height_m),
                       max_range_m, m_of_h, fidelity, max_angle_rad, polarization=pol,
                       surface=surface)
    n_steps = int(np.ceil(max_range_m / steps["dx"]))
    dx = max_range_m / n_steps
    ranges, w = table_axes(freq_hz, antenna_height_m, max_range_m, max_height_m, dx,
                           steps["max_angle_rad"], fidelity,
                           pe.trapping_layer(m_of_h, max_height_m))
    # the cells build_propagation_table's sample() interpolates: h <= top, image ray carried
    limit = np.minimum(top / ranges, np.tan(steps["max_angle_rad"]) - antenna_height_m / ranges)
    sampled = int(np.searchsorted(w, limit, side="right").sum())
    return {"n": int(steps["n"]), "n_steps": n_steps, "dx": dx, "dz": float(steps["dz"]),
            "n_ranges": int(ranges.size), "n_w": int(w.size), "sampled": sampled,
            "top_m": top, "rough": surface == "sea" and wave_height_m > 0}


# =========================================================================== table
@dataclass(frozen=True)
class PropagationTableSpec:
    """What a PE table F(R_t, h) depends on: one declaration, read by the cache key
    (:meth:`inputs`) and by the builder (:func:`build_propagation_table`).

    Attributes
    ----------
    freq_hz : float
        Carrier frequency [Hz].
    antenna_height_m : float
        Antenna height above the surface [m].
    polarization : str
        ``"H"`` or ``"V"`` (:func:`shipradar.sensors.propagation.normalize_polarization`).
    profile : Mapping
        M-profile description (:func:`shipradar.sensors.propagation.normalize_profile_spec`).
    max_range_m, max_height_m : float
        The table's last range and highest height [m].
    pattern_description : Mapping
        Hashable description of the elevation pattern (``{"kind": "gaussian",
        "beamwidth_rad": ..., "sidelobe_db": ...}``); isotropic by default.
    wave_height_m : float
        Significant wave height (Miller-Brown roughness) [m].
    fidelity : str
        PE grid, ``"coarse"``, ``"standard"`` or ``"fine"``.
    tilt_rad : float
        Elevation tilt of the beam [rad].
    surface : str
        ``"sea"`` or another surface of :mod:`shipradar.sensors.parabolic_equation`.
    sea_temperature_c, salinity_psu : float
        Sea water for the permittivity [°C], [psu] (in the key only over the sea).
    max_angle_rad : float or None
        Widest propagation angle carried [rad]; None: the PE's own.
    """

    freq_hz: float
    antenna_height_m: float
    polarization: str
    profile: Mapping[str, Any]
    max_range_m: float
    max_height_m: float
    pattern_description: Mapping[str, Any] = field(
        default_factory=lambda: {"kind": "isotropic"})
    wave_height_m: float = 0.0
    fidelity: str = "standard"
    tilt_rad: float = 0.0
    surface: str = "sea"
    sea_temperature_c: float = prop.SEA_TEMPERATURE_C
    salinity_psu: float = prop.SEA_SALINITY_PSU
    max_angle_rad: float | None = None

    def inputs(self) -> dict[str, Any]:
        """Exactly the inputs that change the table (hashed into its cache key)."""
        sea = self.surface == "sea"
        return {
            "freq_hz": float(self.freq_hz),
            "antenna_height_m": float(self.antenna_height_m),
            "polarization": prop.normalize_polarization(self.polarization),
            "pattern": dict(self.pattern_description),
            "tilt_rad": float(self.tilt_rad),
            "profile": prop.normalize_profile_spec(self.profile),
            "wave_height_m": float(self.wave_height_m),
            "max_range_m": float(self.max_range_m),
            "max_height_m": float(self.max_height_m),
            "fidelity": str(self.fidelity),
            "surface": str(self.surface),
            "sea_temperature_c": float(self.sea_temperature_c) if sea else None,
            "salinity_psu": float(self.salinity_psu) if sea else None,
            "max_angle_rad": None if self.max_angle_rad is None else float(self.max_angle_rad),
        }


def _spec_of(freq_hz: float, antenna_height_m: float, elevation_pattern: object,
             kwargs: dict[str, Any]) -> PropagationTableSpec:
    """The spec of a builder's keywords; a callable pattern must come with its description
    (only the isotropic pattern may go without)."""
    if kwargs.get("pattern_description") is None:
        if elevation_pattern is not None:
            raise ValueError("a callable elevation_pattern needs its pattern_description")
        kwargs = {k: v for k, v in kwargs.items() if k != "pattern_description"}
    return PropagationTableSpec(freq_hz, antenna_height_m, **kwargs)


def propagation_table_inputs(freq_hz: float, antenna_height_m: float, **kwargs: Any
                             ) -> dict[str, Any]:
    """Exactly the inputs that change a propagation table (hashed into its cache key): the
    keywords are the fields of :class:`PropagationTableSpec`."""
    return PropagationTableSpec(freq_hz, antenna_height_m, **kwargs).inputs()


def build_propagation_table(
    freq_hz: float,
    antenna_height_m: float,
    *,
    elevation_pattern: Callable[[np.ndarray], np.ndarray] | None,
    progress: bool | None = None,
    **kwargs: Any,
) -> Table:
    """Build the table F(R_t, h) with the PE (no cache; see :func:`get_propagation_table`).

    The field is stored on the (range, w = h / R) grid of :func:`table_axes`, sampled from
    the PE nodes by :func:`shipradar.sensors.parabolic_equation.interpolate_field`: |F| as
    ``values`` and the complex field with its smooth phase removed
    (:func:`shipradar.sensors.parabolic_equation.reference_phase`, :func:`_align_rows`) as the extra
    arrays ``field_re`` and ``field_im``; :func:`propagation_factor` interpolates the latter
    at (R, h), so a null between nodes stays a null.
    The PE domain reaches one w cell above ``max_height_m`` so that every height up to
    ``max_height_m`` lies in a complete cell.

    The callable pattern cannot be hashed: ``pattern_description`` (e.g. ``{"kind":
    "gaussian", "beamwidth_rad": ..., "sidelobe_db": ...}``) stands for it in the provenance
    and must describe it completely; it may be omitted only for the isotropic pattern.
    ``profile`` is a description dict (see
    :func:`shipradar.sensors.propagation.normalize_profile_spec`). The other keywords are
    the fields of :class:`PropagationTableSpec`.

    Returns
    -------
    Table
        Axes ``("range_m", "height_over_range")`` in ``("m", "1")``; values: linear F
        (float32), NaN where the PE does not apply (steep angles, above the domain).
    """
    t = _spec_of(freq_hz, antenna_height_m, elevation_pattern, kwargs)
    inputs = t.inputs()
    eps = prop.sea_water_permittivity(t.freq_hz, t.sea_temperature_c, t.salinity_psu)
    m_of_h = prop.profile_from_spec(inputs["profile"])
    top = table_pe_height(t.freq_hz, t.antenna_height_m, m_of_h, max_range_m=t.max_range_m,
                          max_height_m=t.max_height_m, fidelity=t.fidelity,
                          max_angle_rad=t.max_angle_rad, polarization=t.polarization,
                          surface=t.surface)
    s = pe.prepare_march(t.freq_hz, t.antenna_height_m, polarization=t.polarization,
                         elevation_pattern=elevation_pattern, profile=m_of_h,
                         wave_height_m=t.wave_height_m, max_range_m=t.max_range_m,
                         max_height_m=top, fidelity=t.fidelity, tilt_rad=t.tilt_rad,
                         surface=t.surface, permittivity=complex(eps),
                         max_angle_rad=t.max_angle_rad, range_step_m=None, step_scale=1.0)
    ranges, w = table_axes(t.freq_hz, t.antenna_height_m, t.max_range_m, t.max_height_m, s.dx,
                           s.theta_max, t.fidelity, pe.trapping_layer(m_of_h, t.max_height_m))
    tan_max = np.tan(s.theta_max)
    phase = pe.reference_phase(t.freq_hz, t.antenna_height_m, m_of_h, top)

    def sample(range_m: float, u: np.ndarray) -> np.ndarray:
        row = np.full(w.size, np.nan + 0j, dtype=np.complex64)
        h = w * range_m
        # nodes inside the domain and the carried angles (image ray, as solve_pe)
        ok = (h <= top) & (h + s.z_a <= tan_max * range_m)
        row[ok] = (pe.interpolate_field(u, s.dz, h[ok]) * np.sqrt(range_m)
                   * np.exp(-1j * phase(range_m, h[ok])))
        return row

    r_pe, field = pe.march(s, sample, progress)
    if not np.allclose(r_pe, ranges, rtol=1e-9, atol=1e-6):
        raise RuntimeError("PE ranges do not match the table axis")
    field = _align_rows(field)
    values = np.abs(field).astype(np.float32)
    return Table(
        name=TABLE_NAME,
        version=TABLE_VERSION,
        axes=(ranges, w),
        axis_names=("range_m", "height_over_range"),
        axis_units=("m", "1"),
        values=values,
        value_name="propagation_factor",
        value_unit="1 (linear field ratio)",
        inputs=inputs,
        # the field itself, its smooth phase removed (reference_phase, _align_rows): the
        # lookup interpolates it and keeps the interference nulls
        extra={"field_re": field.real.astype(np.float32),
               "field_im": field.imag.astype(np.float32)},
    )


def get_propagation_table(
    freq_hz: float, antenna_height_m: float, *, root=None, **kwargs: Any
) -> tuple[Table, bool]:
    """:func:`build_propagation_table` through the cache
    (:func:`shipradar.tables.store.get_or_build`).

    Same arguments as :func:`build_propagation_table`, plus ``root`` (cache directory; default
    ``$SHIPRADAR_TABLES``).  Returns ``(table, built)``; ``built`` is False on a cache hit.
    """
    spec = {k: v for k, v in kwargs.items() if k not in ("elevation_pattern", "progress")}
    inputs = _spec_of(freq_hz, antenna_height_m, kwargs.get("elevation_pattern"), spec).inputs()
    return get_or_build(
        TABLE_NAME, TABLE_VERSION, inputs,
        lambda: build_propagation_table(freq_hz, antenna_height_m, **kwargs), root=root,
    )


# =========================================================================== lookup
#: Stands for NaN inside the lookup's copy of the table: a corner of zero weight adds
#: exactly 0 * SENTINEL = 0, any positive weight makes the result negative (F >= 0), so one
#: sign test replaces a NaN mask per corner.
_SENTINEL = np.float32(-1e30)
#: Bound on |F| of any real field in a table: an interpolated real part below its negative
#: comes from a NaN corner (sentinel) of positive weight.
_FIELD_LIMIT = 1e3


class PropagationLookup:
    """Bilinear lookup of F at (range [m], height [m]) in a table of :func:`table_axes`.

    O(1) per point and vectorized: both axes are uniform (w in two uniform segments), so
    cell indices are computed, not searched; the four corners are gathered from one flat
    complex64 array (the field with its smooth phase removed, ``field_re``/``field_im``)
    and F is the modulus of their bilinear combination, which keeps the interference nulls
    between nodes (a table without the field: float32 |F|, bilinear).  Against a NaN
    corner of positive weight the sentinel -1e30 drives the real part below -_FIELD_LIMIT.
    NaN outside the table's domain (range outside the axis, height < 0 or above
    ``max_height_m``) and where any corner of positive weight is NaN (steep angles):
    the caller falls back to :func:`shipradar.sensors.propagation.two_ray_factor` and counts it.
    """

    def __init__(self, table: Table):
        r_axis, w_axis = table.axes
        self.nr, self.nw = len(r_axis), len(w_axis)
        self.r0 = float(r_axis[0])
        self.inv_dr = (self.nr - 1) / float(r_axis[-1] - r_axis[0])
        dw = np.diff(w_axis)
        if w_axis[0] != 0.0:
            raise ValueError("the w axis must start at 0")
        change = np.nonzero(~np.isclose(dw, dw[0], rtol=1e-6, atol=0))[0]
        n_fine = int(change[0]) if change.size else self.nw - 1
        rest = dw[n_fine:]
        if (not np.allclose(np.diff(r_axis), 1 / self.inv_dr, rtol=1e-6, atol=0)
                or (rest.size and not np.allclose(rest, rest[0], rtol=1e-6, atol=0))):
            raise ValueError("a propagation table needs uniform axes (w in two segments)")
        self.inv_fine = 1.0 / float(dw[0])
        self.inv_coarse = 1.0 / float(rest[0]) if rest.size else self.inv_fine
        self.w_low = float(w_axis[n_fine])
        self.n_fine = n_fine
        self.max_height = float(table.inputs.get("max_height_m", np.inf))
        if "field_re" in table.extra:
            # the complex field (smooth phase removed): bilinear in re and im keeps a null
            # that falls between nodes, where bilinear in |F| fills it (issue 18, item 5)
            # re + 1j im with NaN -> the sentinel, formed in one complex64 array (once per
            # table and process, but inside the first run: each fresh 10 MB copy of the
            # giraffe's field costs page faults); the same numbers as the expression
            v = np.multiply(np.asarray(table.extra["field_im"], dtype=np.float32),
                            np.complex64(1j))
            v += np.asarray(table.extra["field_re"], dtype=np.float32)
            v[np.isnan(v)] = np.complex64(_SENTINEL)
            self.flat = v.ravel()
            self.complex = True
        else:
            v = np.asarray(table.values, dtype=np.float32)
            self.flat = np.where(np.isnan(v), _SENTINEL, v).ravel()
            self.complex = False

    def __call__(self, range_m: np.ndarray, height_m: np.ndarray) -> np.ndarray:
        r, h = np.broadcast_arrays(np.asarray(range_m, dtype=float),
                                   np.asarray(height_m, dtype=float))
        shape = r.shape
        r = r.ravel()
        h = h.ravel()
        out = np.empty(r.size)
        # blocks of LOOKUP_BLOCK points: the temporaries stay in cache and below the size at
        # which malloc maps fresh pages for each of them (2600 page faults per 1e5 points)
        for s in range(0, r.size, LOOKUP_BLOCK):
            self._block(r[s:s + LOOKUP_BLOCK], h[s:s + LOOKUP_BLOCK], out[s:s + LOOKUP_BLOCK])
        return out.reshape(shape)

    def _block(self, r: np.ndarray, h: np.ndarray, out: np.ndarray) -> None:
        x = r - self.r0
        x *= self.inv_dr
        # index along w: two uniform segments in one expression (no branch per point); at
        # R = 0, w is inf or NaN and the point is outside
        with np.errstate(divide="ignore", invalid="ignore"):
            w = h / r
            y = w - self.w_low
            np.maximum(y, 0.0, out=y)
            y *= self.inv_coarse - self.inv_fine
            w *= self.inv_fine
            y += w
        eps = 1e-9  # index rounding: a point on the last node is on that node
        inside = x >= -eps
        inside &= x <= self.nr - 1 + eps
        inside &= h >= 0.0
        inside &= h <= self.max_height
        inside &= y <= self.nw - 1 + eps
        outside = ~inside
        x[outside] = 0.0
        y[outside] = 0.0
        np.clip(x, 0.0, self.nr - 1, out=x)
        np.clip(y, 0.0, self.nw - 1, out=y)
        i = x.astype(np.intp)
        np.minimum(i, self.nr - 2, out=i)
        j = y.astype(np.intp)
        np.minimum(j, self.nw - 2, out=j)
        x -= i  # now the weight of the upper range node
        y -= j  # and of the upper w node
        i *= self.nw
        i += j  # flat index of the lower-left corner
        f = self.flat
        lo = f.take(i) * (1.0 - y)
        lo += f.take(i + 1) * y
        i += self.nw
        hi = f.take(i) * (1.0 - y)
        hi += f.take(i + 1) * y
        hi *= x
        lo *= 1.0 - x
        if self.complex:
            lo += hi
            # a NaN corner of positive weight (>= 1e-13: index rounding) drives the real part
            # below -1e17; a real field has |F| of a few units at most
            outside |= lo.real < -_FIELD_LIMIT
            np.abs(lo, out=out)
        else:
            np.add(lo, hi, out=out)
            outside |= out < 0.0
        out[outside] = np.nan


#: Points per block of :meth:`PropagationLookup.__call__` (64 KiB float64 temporaries).
LOOKUP_BLOCK = 8192


def _plain_lookup(table: Table, range_m: np.ndarray, height_m: np.ndarray) -> np.ndarray:
    """F of a plain (range, height) table at ranges and heights [m]."""
    return table.lookup(*np.broadcast_arrays(np.asarray(range_m, float),
                                             np.asarray(height_m, float)))


def propagation_lookup(table: Table) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """The reader of F in a propagation table, ``reader(range_m, height_m)`` [m] (see
    :func:`propagation_factor`), made anew: whoever reads a table many times keeps it (the
    dwell model's :class:`shipradar.sim.dwell.prepared.PreparedRadar`; the complex field's
    copy is ~10 MB for the largest tables)."""
    if table.axis_names[1] == "height_m":  # a plain (range, height) table
        return functools.partial(_plain_lookup, table)
    return PropagationLookup(table)


def propagation_factor(table: Table, range_m: np.ndarray, height_m: np.ndarray) -> np.ndarray:
    """Linear F at terrestrial ranges [m] and heights [m] from a propagation table.

    Bilinear interpolation on the table's (range, h / R) grid by :class:`PropagationLookup`
    (made at each call: :func:`propagation_lookup` gives one to keep); O(1) per point.  NaN
    outside the table's domain and where the table holds NaN (steep angles): the caller falls
    back to :func:`shipradar.sensors.propagation.two_ray_factor` and counts it.
    """
    return propagation_lookup(table)(range_m, height_m)
