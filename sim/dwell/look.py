"""What one beam crossing computes: the inputs of a look, the results of its named steps, and
the public record of them, :class:`LookResults`.

:meth:`shipradar.sim.dwell.model.DwellModel.process_targets` runs a look as a chain of named
steps (the way pvlib's ``ModelChain`` runs named, swappable steps and keeps their results);
each step is a method of the model, named after what it returns, and each returns one of the
small frozen records below:

1. geometry: :meth:`~shipradar.sim.dwell.model.DwellModel.look_geometry` -> :class:`Look`;
2. propagation: :meth:`~shipradar.sim.dwell.model.DwellModel.look_propagation` ->
   :class:`Propagation` (F [4]-[7], L_atm [16]);
3. target power: :meth:`~shipradar.sim.dwell.model.DwellModel.target_power` ->
   :class:`TargetPower` (σ [15], S [2]-[3]);
4. clutter: :meth:`~shipradar.sim.dwell.model.DwellModel.clutter_at` -> dict or None
   ([21], [39], I_F [57]);
5. jamming: :meth:`~shipradar.sim.dwell.model.DwellModel.look_jamming` -> (N,) [W] ([47]);
6. processing: :meth:`~shipradar.sim.dwell.model.DwellModel.processing` -> :class:`Contacts`
   (unresolved targets 2.2.1, the processor at each contact [57], [63]-[65]);
7. S/I: :meth:`~shipradar.sim.dwell.model.DwellModel.signal_to_interference` -> S/I and the
   dominant interference ([66]-[67]);
8. N_e: :meth:`~shipradar.sim.dwell.model.DwellModel.effective_pulses` ([73]-[77]);
9. P_d: :meth:`~shipradar.sim.dwell.model.DwellModel.detection_probability` ([78]-[83], exact
   or tabulated), then :meth:`~shipradar.sim.dwell.model.DwellModel.detection_draw`;
10. measurement: :meth:`~shipradar.sim.dwell.model.DwellModel.measurement` -> the plot
    columns ([84]-[89]).

A study that needs a look's intermediate results registers a callback on the model's
``on_look`` list (:class:`LookObserver`); after the detection draw, each call of
``process_targets`` hands every observer one :class:`LookResults`. It is never built when
the list is empty, so a normal run pays nothing for it and its stream is unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

if TYPE_CHECKING:
    from shipradar.sim.world.kinematics import Geometry

__all__ = ["Contacts", "Decision", "Look", "LookObserver", "LookResults", "Propagation",
           "TargetPower"]


@dataclass(frozen=True)
class Look:
    """The geometry step: the N targets one call of ``process_targets`` sees.

    Attributes
    ----------
    geom : Geometry
        The targets seen from the antenna (:class:`shipradar.sim.world.kinematics.Geometry`).
    rows : (N,) int
        Scenario target index of each.
    time_s : (N,) float
        Beam-crossing time of each [s].
    position_m : (N, 3) float
        Origin-frame east/north/up of each target [m].
    antenna_en : (N, 2) float
        Origin-frame east/north of the antenna at each crossing [m].
    batch : (N,) int or None
        Revolution of each crossing when several are processed at once (never merged).
    platform_vel : (N, 3) float or None
        The platform's instantaneous velocity at each crossing [m/s]; None: the tables'.
    """

    geom: Geometry
    rows: np.ndarray
    time_s: np.ndarray
    position_m: np.ndarray
    antenna_en: np.ndarray
    batch: np.ndarray | None
    platform_vel: np.ndarray | None

    @property
    def size(self) -> int:
        """Number of targets N."""
        return int(self.rows.size)


@dataclass(frozen=True)
class Propagation:
    """The propagation step (N,): F [4]-[7] and the one-way atmospheric loss [16].

    Attributes
    ----------
    f : (N,) float
        Propagation factor F (field ratio, the elevation pattern included) [-].
    atmospheric_loss : (N,) float
        One-way atmospheric loss L_atm (power ratio >= 1) [-].
    fallbacks : int
        Points outside the PE table computed by the two-ray model.
    """

    f: np.ndarray
    atmospheric_loss: np.ndarray
    fallbacks: int


@dataclass(frozen=True)
class TargetPower:
    """The target-power step (N,): cross section [15] and echo power S [2]-[3].

    Attributes
    ----------
    sigma_m2 : (N,) float
        Radar cross section σ [m²].
    received_power_w : (N,) float
        Echo power S at the RF input [W].
    """

    sigma_m2: np.ndarray
    received_power_w: np.ndarray


@dataclass(frozen=True)
class Contacts:
    """The processing step: unresolved targets (2.2.1) grouped into contacts, and what the
    Doppler processor does to the clutter of each contact's strongest (lead) target.

    Attributes
    ----------
    group : (N,) int
        Contact of each target (same batch, range cell, beam and Doppler filter).
    n_groups : int
        Number of contacts M.
    lead : (M,) int
        Index (into the N targets) of each contact's strongest target.
    power_w : (M,) float
        Echo power of each contact, the sum of its targets' [W].
    improvement : (M,) float
        Improvement factor I_F [57] at the lead target's Doppler (1 without clutter) [-].
    distribution_loss : (M,) float
        L_d [63]-[64] (1 unless sea clutter at medium/high resolution) [-].
    coherent_gain : (M,) float
        The same filter's gain against white noise [-].
    """

    group: np.ndarray
    n_groups: int
    lead: np.ndarray
    power_w: np.ndarray
    improvement: np.ndarray
    distribution_loss: np.ndarray
    coherent_gain: np.ndarray


@dataclass(frozen=True)
class Decision:
    """The S/I, N_e, P_d and detection steps, one element per contact (M,).

    Attributes
    ----------
    si : (M,) float
        Per-pulse S/I [66]-[67] (linear).
    si_db : (M,) float
        The same [dB].
    interference : (M,) uint8
        The dominant interference: 0 noise, 1 clutter, 2 jamming.
    n_e : (M,) float
        Effective number of pulses [73]-[77].
    pd : (M,) float
        Probability of detection [-].
    hit : (M,) bool
        The detection draw.
    """

    si: np.ndarray
    si_db: np.ndarray
    interference: np.ndarray
    n_e: np.ndarray
    pd: np.ndarray
    hit: np.ndarray


@dataclass(frozen=True)
class LookResults:
    """The intermediate results of one call of ``process_targets``: one element per target
    the beam crossed (N), in the order the engine gave them.

    What is evaluated per target (geometry, F, σ, S, each interference) is the target's own;
    what is evaluated per contact (S/I, the dominant interference, N_e, P_d, the detection)
    is that of the contact the target belongs to (``contact``; ``merged`` when it holds
    several targets, seed 2.2.1), computed with its lead target's clutter, jamming and I_F.

    Attributes
    ----------
    radar : str
        The radar's id.
    target : (N,) int
        Scenario target index (``scenario.targets[i]``).
    time_s : (N,) float
        Beam-crossing time [s].
    slant_range_m, ground_range_m, height_m : (N,) float
        Slant and ground range from the antenna, target height [m].
    sigma_m2 : (N,) float
        Radar cross section σ [15] [m²].
    f : (N,) float
        Propagation factor F [4]-[7] (field ratio, elevation pattern included) [-].
    atmospheric_loss : (N,) float
        One-way atmospheric loss L_atm [16] (power ratio) [-].
    received_power_w : (N,) float
        Echo power S [2]-[3] at the RF input [W].
    noise_w : (N,) float
        Receiver noise N0' referred to the RF input [W].
    clutter_w : (N,) float
        Sea plus weather clutter P_sc + P_wc at the target's cell [21], [39] [W].
    jamming_w : (N,) float
        Stand-off jamming through the radar pattern [47] [W].
    improvement : (N,) float
        Improvement factor I_F [57] of the processor for the target's contact [-].
    si : (N,) float
        Per-pulse S/I [66]-[67] of the contact (linear).
    si_db : (N,) float
        The same [dB].
    interference : (N,) uint8
        Dominant interference of the contact: 0 noise, 1 clutter, 2 jamming
        (:data:`shipradar.sim.dwell.model.INTERFERENCE_NAMES`).
    n_e : (N,) float
        Effective number of pulses [73]-[77] of the contact.
    pd : (N,) float
        Probability of detection of the contact (the fidelity's ``pd_method``) [-].
    hit : (N,) bool
        The detection draw: the contact is reported.
    contact : (N,) int
        Contact index of each target within this call.
    merged : (N,) bool
        True when the target's contact holds several targets.
    batch : (N,) int or None
        Revolution of each crossing among those the call processed together (the engine's
        block of revolutions, ``process_targets(batch=...)``); None when not given.
    """

    radar: str
    target: np.ndarray
    time_s: np.ndarray
    slant_range_m: np.ndarray
    ground_range_m: np.ndarray
    height_m: np.ndarray
    sigma_m2: np.ndarray
    f: np.ndarray
    atmospheric_loss: np.ndarray
    received_power_w: np.ndarray
    noise_w: np.ndarray
    clutter_w: np.ndarray
    jamming_w: np.ndarray
    improvement: np.ndarray
    si: np.ndarray
    si_db: np.ndarray
    interference: np.ndarray
    n_e: np.ndarray
    pd: np.ndarray
    hit: np.ndarray
    contact: np.ndarray
    merged: np.ndarray
    batch: np.ndarray | None = None

    @property
    def size(self) -> int:
        """Number of targets N."""
        return int(self.target.size)


class LookObserver(Protocol):
    """A callback of ``DwellModel.on_look``: receives each call's :class:`LookResults`."""

    def __call__(self, look: LookResults, /) -> Any: ...
