"""Per-axis piecewise-cubic motion (constant jerk per phase) and its vectorised sampling.

Ruckig's profiles and the planner's straight moves are sequences of phases of constant jerk; each
phase is stored by its duration [s] and its start state (position [mm], velocity [mm/s],
acceleration [mm/s^2]) with its jerk [mm/s^3]. Phases follow each other without gaps, so a
phase's start time is the sum of the durations before it. Sampling is one ``searchsorted`` and a
cubic per axis: a 60 s program at 1 kHz samples in milliseconds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.planner.jerk3 import phase_starts


class Jerk3Run:
    """m closed-form pieces (:mod:`~gantry_sim.controller.planner.jerk3`) of three phases of
    length :attr:`h` (m,) [s], on all axes: each piece's start position [mm], velocity [mm/s],
    acceleration [mm/s^2] (m, 3) and its jerks [mm/s^3] (m, 3 phases, 3 axes). The later
    phases' start states are rebuilt (:func:`~gantry_sim.controller.planner.jerk3.phase_starts`,
    the same numbers) when the plan is built: held this way, a round's arcs take 19 numbers per
    piece instead of 45. The 19 numbers of a piece are one row of one (m, 19) array
    (:attr:`rows`: h, p, v, a, j): a plan holds tens of thousands of runs until the run ends,
    and five arrays a run took a third more memory than their numbers, in array headers."""

    __slots__ = ("rows",)

    def __init__(self, h, p, v, a, j) -> None:
        """A copy of the pieces given (``h`` (m,), ``p``, ``v``, ``a`` (m, 3), ``j`` (m, 3, 3))."""
        m = np.shape(h)[0]
        rows = np.empty((m, 19))
        rows[:, 0] = h
        rows[:, 1:4] = p
        rows[:, 4:7] = v
        rows[:, 7:10] = a
        rows[:, 10:] = np.reshape(j, (m, 9))
        self.rows = rows

    @classmethod
    def joined(cls, runs: list[Jerk3Run]) -> Jerk3Run:
        """The pieces of ``runs``, one after another, as one run."""
        out = cls.__new__(cls)
        out.rows = np.concatenate([r.rows for r in runs])
        return out

    @property
    def h(self) -> np.ndarray:
        return self.rows[:, 0]

    @property
    def p(self) -> np.ndarray:
        return self.rows[:, 1:4]

    @property
    def v(self) -> np.ndarray:
        return self.rows[:, 4:7]

    @property
    def a(self) -> np.ndarray:
        return self.rows[:, 7:10]

    @property
    def j(self) -> np.ndarray:
        return self.rows[:, 10:].reshape(-1, 3, 3)

    @property
    def fields(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(h, p, v, a, j), views of :attr:`rows`."""
        return self.h, self.p, self.v, self.a, self.j

    def axis_phases(self, axis: int) -> tuple[np.ndarray, ...]:
        """The phases of ``axis`` (duration [s], p, v, a, j), 3 m each."""
        h, p, v, a, j = self.fields
        ps, vs, as_ = phase_starts(p, v, a, j, h)
        cols = (ps[:, :, axis], vs[:, :, axis], as_[:, :, axis], j[:, :, axis])
        return (np.repeat(h, 3), *(c.ravel() for c in cols))


#: A stretch of phases: per axis one (5, n) array (rows duration [s], p, v, a, j; the axes may
#: have different phase counts: Ruckig's pieces do), indexed by axis: a tuple of three, or one
#: (3, 5, n) array where the counts are equal; or a :class:`Jerk3Run`.
Segment = tuple[np.ndarray, np.ndarray, np.ndarray] | np.ndarray | Jerk3Run
#: The phases of a chain (or a dwell), segment by segment in time order.
Chunk = tuple[Segment, ...]

#: A :data:`Segment`'s kind, as the packers store it (:mod:`.packed_block`, :mod:`.chain_batch`):
#: a :class:`Jerk3Run`, one (3, 5, n) array, three (5, n_i) arrays.
SEGMENT_RUN, SEGMENT_WHOLE, SEGMENT_PER_AXIS = 0, 1, 2


def segment_kind(seg: Segment) -> int:
    """:data:`SEGMENT_RUN`, :data:`SEGMENT_WHOLE` or :data:`SEGMENT_PER_AXIS`."""
    if isinstance(seg, Jerk3Run):
        return SEGMENT_RUN
    return SEGMENT_WHOLE if isinstance(seg, np.ndarray) else SEGMENT_PER_AXIS


class CubicBuilder:
    """Collects phases per axis in time order, as the arrays (or sequences) given."""

    def __init__(self) -> None:
        #: per axis, the phases added since the last segment: (5, n) arrays
        self.cols: list[list[np.ndarray]] = [[], [], []]
        self.segments: list[Segment] = []

    def add(self, axis: int, dur, p, v, a, j) -> None:
        """Append phases (sequences of equal length) to ``axis`` (one (5, n) array: a Ruckig
        piece adds 3 of them, not 15)."""
        self.cols[axis].append(np.array((dur, p, v, a, j), dtype=float))

    def add_jerk3(self, run: Jerk3Run) -> None:
        """Append closed-form pieces to every axis (a :class:`Jerk3Run` holds a copy of its
        pieces)."""
        self.flush()
        self.segments.append(run)

    def flush(self) -> None:
        """The phases added since the last segment, as one segment: per axis a (5, n) array
        (one array, not five, as a plan keeps tens of thousands of them until it is built),
        and where the axes have as many phases (all but some Ruckig pieces), one (3, 5, n)
        array whose ``[axis]`` is that axis' (5, n), in place of three."""
        if not any(self.cols):
            return
        sizes = [sum(x.shape[1] for x in c) for c in self.cols]
        if sizes[0] == sizes[1] == sizes[2]:
            whole = np.empty((3, 5, sizes[0]))
            out = [whole[0], whole[1], whole[2]]
        else:
            out = [np.empty((5, n)) for n in sizes]
        for c, arr, n in zip(self.cols, out, sizes, strict=True):
            if n:
                np.concatenate(c, axis=1, out=arr)
            c.clear()
        self.segments.append(whole if sizes[0] == sizes[1] == sizes[2] else tuple(out))

    def chunk(self) -> Chunk:
        """The phases collected, segment by segment."""
        self.flush()
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
