"""A block of the plan's segments packed into a few arrays: what is written to disk, read back
and laid out when the run samples it.

A block of a polyline program holds about 9,000 segments (a straight move's profile is one
(3, 5, n) array of a few phases), each one array: pickling and unpickling them one by one, and
laying them out with a Python loop per segment and axis, was about 7 % of a streamed run of
short G1 moves (``Plan.sample_range``). :class:`PackedBlock` keeps the same numbers as one
(m, 19) array of every closed-form run's pieces (:class:`~gantry_sim.controller.planner.cubic.Jerk3Run`),
one (5, n) array per axis of every other segment's phases, and per segment its kind and phase
counts; :meth:`PackedBlock.layout` interleaves them again with array operations. The phases laid
out, and the segments given back by :meth:`PackedBlock.segments`, are the ones packed, bit for bit.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gantry_sim.controller.planner.cubic import (
    SEGMENT_RUN,
    SEGMENT_WHOLE,
    Jerk3Run,
    Segment,
    segment_kind,
)
from gantry_sim.controller.planner.jerk3 import phase_starts

__all__ = ["PackedBlock", "Phases"]

#: One axis' phases: start time [s], position [mm], velocity [mm/s], acceleration [mm/s^2],
#: jerk [mm/s^3], arrays of equal length.
Phases = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


class PackedBlock:
    """Segments in time order (see the module docstring)."""

    __slots__ = ("counts", "kinds", "other", "runs")

    def __init__(self, segments: Sequence[Segment]) -> None:
        kinds = np.empty(len(segments), dtype=np.int8)
        counts = np.empty((len(segments), 3), dtype=np.int64)
        runs: list[np.ndarray] = []
        other: list[list[np.ndarray]] = [[], [], []]
        for k, seg in enumerate(segments):
            kinds[k] = segment_kind(seg)
            if isinstance(seg, Jerk3Run):
                counts[k] = 3 * seg.rows.shape[0]
                runs.append(seg.rows)
                continue
            for i in range(3):
                counts[k, i] = seg[i].shape[1]
                other[i].append(seg[i])
        #: per segment its kind (cubic.segment_kind)
        self.kinds = kinds
        #: (segments, 3) phases per segment and axis
        self.counts = counts
        #: (pieces, 19): every run's rows, one run after another
        self.runs = np.concatenate(runs) if runs else np.empty((0, 19))
        #: per axis (5, n): the other segments' phases, one after another
        self.other = tuple(np.concatenate(o, axis=1) if o else np.empty((5, 0)) for o in other)

    def __len__(self) -> int:
        return int(self.kinds.size)

    def segments(self) -> tuple[Segment, ...]:
        """The segments packed (fresh arrays holding the same numbers)."""
        run_at = np.cumsum(self.counts[:, 0] * (self.kinds == SEGMENT_RUN) // 3)
        other_at = np.cumsum(self.counts * (self.kinds != SEGMENT_RUN)[:, None], axis=0)
        out: list[Segment] = []
        for k, kind in enumerate(self.kinds.tolist()):
            if kind == SEGMENT_RUN:
                run = Jerk3Run.__new__(Jerk3Run)
                m = int(self.counts[k, 0]) // 3
                run.rows = self.runs[int(run_at[k]) - m : int(run_at[k])].copy()
                out.append(run)
                continue
            x, y, z = (
                self.other[i][:, int(other_at[k, i] - self.counts[k, i]) : int(other_at[k, i])]
                for i in range(3)
            )
            out.append(
                np.stack((x, y, z)) if kind == SEGMENT_WHOLE else (x.copy(), y.copy(), z.copy())
            )
        return tuple(out)

    def durations(self, axis: int) -> np.ndarray:
        """The durations [s] of the phases on ``axis``, in time order."""
        return _merged(self._from_runs(axis), np.repeat(self.runs[:, 0], 3), self.other[axis][0])

    def layout(self, start_s: np.ndarray) -> tuple[Phases, Phases, Phases]:
        """Per axis the phases, their start times counted from ``start_s[axis]`` [s] (the
        running sum of the durations, added one at a time): the closed-form runs' later phase
        states rebuilt in one batch (:func:`~gantry_sim.controller.planner.jerk3.phase_starts`,
        each row as alone)."""
        rows = self.runs
        h = rows[:, 0]
        j = rows[:, 10:].reshape(-1, 3, 3)
        if h.size:
            ps, vs, as_ = phase_starts(rows[:, 1:4], rows[:, 4:7], rows[:, 7:10], j, h)
        else:  # no runs: their columns are empty, as j (0, 3, 3) is
            ps = vs = as_ = j
        dur = np.repeat(h, 3)
        out = []
        for i in range(3):
            mine, from_runs = self.other[i], self._from_runs(i)
            cols = [_merged(from_runs, dur, mine[0])]
            for c, laid in enumerate((ps, vs, as_, j), start=1):
                cols.append(_merged(from_runs, laid[:, :, i].ravel(), mine[c]))
            t0 = np.cumsum(np.concatenate(([start_s[i]], cols[0])))[:-1]
            phases = (t0, cols[1], cols[2], cols[3], cols[4])
            for arr in phases:
                arr.setflags(write=False)
            out.append(phases)
        return out[0], out[1], out[2]

    def _from_runs(self, axis: int) -> np.ndarray:
        """Per phase of ``axis`` in time order, whether a closed-form run holds it."""
        return np.repeat(self.kinds == SEGMENT_RUN, self.counts[:, axis])


def _merged(from_runs: np.ndarray, run_values: np.ndarray, other_values: np.ndarray) -> np.ndarray:
    """One column of an axis' phases in time order: ``run_values`` where ``from_runs`` (see
    :meth:`PackedBlock._from_runs`), ``other_values`` elsewhere, each in order."""
    if other_values.size == 0:
        return run_values.copy()
    if run_values.size == 0:
        return other_values.copy()
    out = np.empty(from_runs.size)
    out[from_runs] = run_values
    out[~from_runs] = other_values
    return out
