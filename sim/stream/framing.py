"""Sector framing: which plots go in which ``plots``/``truth`` message, with which keys.

The engine sends each sector's plots as a ``plots`` message and its ``truth[plots]`` right
after. :func:`sector_columns` is the one place that decides what those messages hold (keys
from :mod:`shipradar.sim.stream.schema`, in its order): for a block of plots and the
``[start, stop)`` rows of each message, the fixed keys of each message and the slices of
every column. The engine then either encodes every message at once
(:meth:`Slices.encode`, :func:`shipradar.sim.stream.protocol.encode_slices` in compiled
code) for a bus that takes frames, or hands a bus that takes payloads each message as a dict
(:meth:`Slices.message`): the same keys and values, hence the same bytes once encoded.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from shipradar.sim.stream import protocol
from shipradar.sim.stream.schema import PLOTS, TRUTH_PLOTS, TRUTH_TARGETS, Payload, SchemaError

__all__ = ["Slices", "sector_columns", "target_columns"]

#: (array, start of each message's slice, stop of each message's slice)
Column = tuple[np.ndarray, np.ndarray, np.ndarray]


@dataclass(frozen=True)
class Slices:
    """Messages of one payload that share their keys and slice the same columns.

    Message ``j`` is ``{**fixed[index[j]], **{key: array[start[j]:stop[j]] for key, (array,
    start, stop) in columns.items()}}``, the contract of
    :func:`shipradar.sim.stream.protocol.encode_slices`.
    """

    payload: Payload
    fixed: Sequence[Mapping[str, Any]]
    index: np.ndarray
    columns: Mapping[str, Column]

    def __post_init__(self) -> None:
        keys = (*self.fixed[0], *self.columns) if self.fixed else tuple(self.columns)
        # the declared keys in order; an optional one may be left out (none missing that is
        # required, none unknown)
        declared = tuple(f.key for f in self.payload.fields
                         if f.key in keys or f.required)
        if keys != declared:
            raise SchemaError(f"{self.payload.name}: framed keys {keys}, declared "
                              f"{self.payload.keys}")

    def __len__(self) -> int:
        return len(self.index)

    def message(self, j: int) -> dict[str, Any]:
        """The payload of message ``j``."""
        out = dict(self.fixed[self.index[j]])
        for key, (array, start, stop) in self.columns.items():
            out[key] = array[start[j]:stop[j]]
        return out

    def encode(self, times: np.ndarray) -> list[bytes]:
        """The bodies of every message, message ``j`` at time ``times[j]`` [s] (the same
        bytes as ``protocol.encode(topic, times[j], self.message(j))[1]``)."""
        return protocol.encode_slices(self.payload.topic, times, self.fixed, self.columns,
                                      self.index)


def _fixed(payload: Payload, **values: Sequence[Any]) -> list[dict[str, Any]]:
    """The keys of ``payload`` that are not columns, in its order (all of them given), one
    mapping per message: message ``j``'s value of ``key`` is ``values[key][j]``."""
    keys = tuple(f.key for f in payload.fields if f.length is None)
    if set(values) != set(keys):
        raise SchemaError(f"{payload.name}: fixed keys {sorted(values)}, declared {keys}")
    return [dict(zip(keys, row, strict=True))
            for row in zip(*(values[k] for k in keys), strict=True)]


def sector_columns(sensor: str, scans: Sequence[int], plots: Mapping[str, np.ndarray],
                   plot_id: np.ndarray, start: np.ndarray, stop: np.ndarray,
                   which: np.ndarray) -> tuple[Slices, Slices]:
    """The ``plots`` and ``truth[plots]`` messages of a block of plots, one per sector.

    Parameters
    ----------
    sensor : str
        The radar id.
    scans : Sequence[int]
        Scan numbers of the block's revolutions.
    plots : Mapping[str, numpy.ndarray]
        The block's plots, sorted as they are sent: every per-plot column of
        :data:`shipradar.sim.stream.schema.PLOT_COLUMNS` and
        :data:`~shipradar.sim.stream.schema.PLOT_TRUTH_COLUMNS`, and the contributors
        (``contrib_offsets``, one more than the plots, and ``contrib_targets``).
    plot_id : numpy.ndarray
        The id of every plot of the block (int64).
    start, stop : numpy.ndarray
        Rows ``start[j]:stop[j]`` of ``plots`` make message ``j`` (int64, non-empty).
    which : numpy.ndarray
        Index in ``scans`` of message ``j``'s revolution.

    Returns
    -------
    plots, truth : Slices
        The ``plots`` messages and their ``truth[plots]`` messages.
    """
    rows = {"plot_id": plot_id, **plots}
    sensors = [sensor] * len(scans)
    plot_msgs = Slices(PLOTS, _fixed(PLOTS, sensor=sensors, scan=scans), which,
                       {key: (rows[key], start, stop) for key in PLOTS.columns()})
    # each message's contributor offsets start at 0: one array of every message's rebased
    # offsets (n + 1 per message), sliced per message
    off = plots["contrib_offsets"]
    length = stop - start + 1
    first = np.cumsum(length) - length
    idx = np.repeat(start - first, length) + np.arange(int(length.sum()))
    rebased = (off[idx] - np.repeat(off[start], length)).astype(
        TRUTH_PLOTS["contrib_offsets"].dtype, copy=False)
    truth_cols: dict[str, Column] = {key: (rows[key], start, stop)
                                     for key in TRUTH_PLOTS.columns("n")}
    truth_cols["contrib_offsets"] = (rebased, first, first + length)
    truth_cols["contrib_targets"] = (plots["contrib_targets"], off[start], off[stop])
    truth_msgs = Slices(TRUTH_PLOTS, _fixed(TRUTH_PLOTS, sensor=sensors, scan=scans,
                                            kind=["plots"] * len(scans)), which, truth_cols)
    return plot_msgs, truth_msgs


def target_columns(sensor: str, scans: Sequence[int], times: Sequence[float],
                   columns: Mapping[str, np.ndarray], targets: int) -> Slices:
    """The ``truth[targets]`` messages of a block of ends of scan, one per revolution.

    Parameters
    ----------
    sensor : str
        The radar id.
    scans : Sequence[int]
        Scan numbers of the revolutions that end.
    times : Sequence[float]
        Their ends [s] (each message's ``time_s``).
    columns : Mapping[str, numpy.ndarray]
        The columns of :data:`shipradar.sim.stream.schema.TRUTH_TARGETS` (every required one;
        an optional one left out is not sent), ``targets`` rows
        per revolution: revolution ``j``'s in rows ``j targets:(j + 1) targets``.
    targets : int
        Targets of the scene.
    """
    start = np.arange(len(scans), dtype=np.int64) * targets
    stop = start + targets
    fixed = _fixed(TRUTH_TARGETS, sensor=[sensor] * len(scans), scan=scans,
                   kind=["targets"] * len(scans), time_s=times)
    return Slices(TRUTH_TARGETS, fixed, np.arange(len(scans)),
                  {key: (columns[key], start, stop) for key in TRUTH_TARGETS.columns()
                   if key in columns})
