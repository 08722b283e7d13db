"""The radar above the sea that a figure against range draws (one declaration for the
figures of :mod:`~shipradar.sim.studies.figures.clutter` and
:mod:`~shipradar.sim.studies.figures.propagation`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["SeaCase"]


@dataclass(frozen=True)
class SeaCase:
    """A radar over the sea, as the range figures read it.

    Parameters
    ----------
    freq_hz : float
        Carrier frequency [Hz].
    polarization : {"H", "V"}
        Transmit and receive polarization.
    antenna_height_m : float
        Antenna phase centre above the sea [m].
    wave_height_m : float
        Significant wave height [m].
    max_range_m : float
        Longest range drawn [m].
    """

    freq_hz: float
    polarization: str
    antenna_height_m: float
    wave_height_m: float
    max_range_m: float

    @classmethod
    def of_radar(cls, radar: Any, scenario: Any, max_range_m: float) -> SeaCase:
        """The case of a scenario's radar (its frequency, polarization and antenna height)
        over the scenario's sea (its wave height), drawn to ``max_range_m`` [m]."""
        return cls(freq_hz=radar.frequency_hz, polarization=radar.polarization,
                   antenna_height_m=radar.antenna_height_m,
                   wave_height_m=scenario.wave_height, max_range_m=max_range_m)
