"""Per-axis piecewise-cubic motion (constant jerk per phase) and its vectorised sampling.

Ruckig's profiles and the planner's straight moves are sequences of phases of constant jerk; each
phase is stored by its duration [s] and its start state (position [mm], velocity [mm/s],
acceleration [mm/s^2]) with its jerk [mm/s^3]. Phases follow each other without gaps, so a
phase's start time is the sum of the durations before it. Sampling is one ``searchsorted`` and a
cubic per axis: a 60 s program at 1 kHz samples in milliseconds.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from gantry_sim.controller.planner.jerk3 import phase_starts


class Jerk3Run(NamedTuple):
    """m closed-form pieces (:mod:`~gantry_sim.controller.planner.jerk3`) of three phases of
    length ``h`` (m,) [s], on all axes: each piece's start position [mm], velocity [mm/s],
    acceleration [mm/s^2] (m, 3) and its jerks [mm/s^3] (m, 3 phases, 3 axes). The later
    phases' start states are rebuilt (:func:`~gantry_sim.controller.planner.jerk3.phase_starts`,
    the same numbers) when the plan is built: held this way, a round's arcs take 19 numbers per
    piece instead of 45."""

    h: np.ndarray
    p: np.ndarray
    v: np.ndarray
    a: np.ndarray
    j: np.ndarray

    def axis_phases(self, axis: int) -> tuple[np.ndarray, ...]:
        """The phases of ``axis`` (duration [s], p, v, a, j), 3 m each."""
        ps, vs, as_ = phase_starts(self.p, self.v, self.a, self.j, self.h)
        cols = (ps[:, :, axis], vs[:, :, axis], as_[:, :, axis], self.j[:, :, axis])
        return (np.repeat(self.h, 3), *(c.ravel() for c in cols))


#: A stretch of phases: per axis one (5, n) array (rows duration [s], p, v, a, j; the axes may
#: have different phase counts: Ruckig's pieces do), or a :class:`Jerk3Run`.
Segment = tuple[np.ndarray, np.ndarray, np.ndarray] | Jerk3Run
#: The phases of a chain (or a dwell), segment by segment in time order.
Chunk = tuple[Segment, ...]


class CubicBuilder:
    """Collects phases per axis in time order, as the arrays (or sequences) given."""

    def __init__(self) -> None:
        self.cols: list[tuple[list[np.ndarray], ...]] = [([], [], [], [], []) for _ in range(3)]
        self.segments: list[Segment] = []

    def add(self, axis: int, dur, p, v, a, j) -> None:
        """Append phases (sequences of equal length) to ``axis``."""
        c = self.cols[axis]
        for col, x in zip(c, (dur, p, v, a, j), strict=True):
            col.append(np.asarray(x, dtype=float).ravel())

    def add_jerk3(self, run: Jerk3Run) -> None:
        """Append closed-form pieces to every axis (copied: ``run`` may view larger arrays)."""
        self._flush()
        self.segments.append(Jerk3Run(*(np.array(x) for x in run)))

    def _flush(self) -> None:
        """The phases added since the last segment, as one segment (per axis a (5, n) array:
        one array, not five, as a plan keeps tens of thousands of them until it is built)."""
        if not any(c[0] for c in self.cols):
            return
        out = []
        for c in self.cols:
            n = sum(x.size for x in c[0])
            arr = np.empty((5, n))
            if n:
                for row, x in zip(arr, c, strict=True):
                    np.concatenate(x, out=row)
            out.append(arr)
            for col in c:
                col.clear()
        self.segments.append((out[0], out[1], out[2]))

    def chunk(self) -> Chunk:
        """The phases collected, segment by segment."""
        self._flush()
        return tuple(self.segments)


@dataclass(frozen=True)
class PiecewiseCubic:
    """Phases per axis: ``axes[i] = (t0, p, v, a, j)``, arrays of equal length, t0 ascending."""

    axes: tuple[tuple[np.ndarray, ...], ...]

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity, acceleration (N, 3) at times ``t`` (N,) [s] (inside the motion)."""
        pos = np.empty((t.size, 3))
        vel = np.empty((t.size, 3))
        acc = np.empty((t.size, 3))
        for i, (t0, p, v, a, j) in enumerate(self.axes):
            if t0.size == 0:
                pos[:, i], vel[:, i], acc[:, i] = 0.0, 0.0, 0.0
                continue
            k = np.clip(np.searchsorted(t0, t, side="right") - 1, 0, t0.size - 1)
            dt = t - t0[k]
            jk, ak = j[k], a[k]
            pos[:, i] = p[k] + dt * (v[k] + dt * (0.5 * ak + dt * jk / 6.0))
            vel[:, i] = v[k] + dt * (ak + 0.5 * dt * jk)
            acc[:, i] = ak + dt * jk
        return pos, vel, acc
