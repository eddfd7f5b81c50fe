"""The planner's result: a frozen :class:`Plan` (re-exported by :mod:`gantry_sim.controller.planner.plan`) whose
reference is stored as constant-jerk phases and sampled vectorised."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from gantry_sim.controller.config import Limits
from gantry_sim.controller.errors import ConfigError
from gantry_sim.controller.moves import Move, PathMove, Rapid
from gantry_sim.controller.planner.blend import Blend
from gantry_sim.controller.planner.cubic import PiecewiseCubic
from gantry_sim.controller.planner.path_control import Merge
from gantry_sim.controller.planner.segmented_curve import SegmentedCurve
from gantry_sim.controller.trajectory import Trajectory


@dataclass(frozen=True)
class Plan:
    """A planned program.

    Attributes:
        moves: the moves planned, in order (a :class:`~gantry_sim.controller.spill.SpilledList`
            for a program planned by :func:`~gantry_sim.controller.planner.plan.plan`: a long
            one is kept on disk).
        duration_s: time from rest at the first move's start to rest at the last move's end [s].
        segment_count: chords and straight pieces planned.
        chord_tolerance_mm: the machine's chord tolerance [mm].
        vertices: per move, read-only (k, 3) chord vertices [mm] (first = start, last = end),
            made when read (:class:`~gantry_sim.controller.planner.vertices.ChordVertices`).
        ruckig_piece_count: arc pieces given to Ruckig because the closed-form piece would have
            broken a limit (typically next to a junction with a curvature jump).
        curve: the reference, as constant-jerk phases per axis (a planned program's held
            segment by segment, :mod:`~gantry_sim.controller.planner.segmented_curve`).
        move_start_s: read-only (m,) start time [s] of each move of non-zero length.
        move_lines: read-only (m,) their program lines.
        end_mm: read-only (3,) the program's end point [mm].
        blends: every corner blended in G64 (line, deviation from the corner, tolerance).
        path_moves: the moves the reference follows (blend arcs and transitions inserted, G64 Q
            merged).
        move_sources: read-only (m, 2) per move of ``move_start_s``, the first and last index
            in ``moves`` it comes from (a dwell: the two moves it lies between; -1 for none):
            which program moves a sample is executing, for the contour error's search.
        path_sources: read-only (p, 2) the same per move of ``path_moves``.
        merges: every G64 Q merge (line, largest distance of the merged-away programmed points
            from the merged line, Q).
        limit_change_stops (a property): Marlin limit changes (M201, M203, M205 J) planned as
            exact stops between the program's parts, the joins of ``part_limits``
            (:mod:`~gantry_sim.controller.planner.limit_events`; Marlin itself does not stop
            there).
        part_limits: for a program that Marlin's M201/M203 cut into parts, per part the
            first program line of its first motion and the per-axis limits it was planned
            with (the machine file's, as the program changed them); empty for one part.
        overlaps_s: read-only (k, 2) start and end [s] of each G64 stop whose two moves'
            profiles overlap (:mod:`~gantry_sim.controller.planner.stop_overlap`; each is
            also in ``blends``, kind "overlap"): there the reference cuts the corner, as a
            blend does.
    """

    moves: Sequence[Move]
    duration_s: float
    segment_count: int
    chord_tolerance_mm: float
    vertices: Sequence[np.ndarray]
    ruckig_piece_count: int
    curve: PiecewiseCubic | SegmentedCurve = field(repr=False)
    move_start_s: np.ndarray = field(repr=False)
    move_lines: np.ndarray = field(repr=False)
    end_mm: np.ndarray = field(repr=False)
    blends: Sequence[Blend] = ()
    path_moves: Sequence[PathMove] = ()
    move_sources: np.ndarray = field(repr=False, default_factory=lambda: _no_pairs(np.int64))
    path_sources: np.ndarray = field(repr=False, default_factory=lambda: _no_pairs(np.int64))
    merges: tuple[Merge, ...] = ()
    part_limits: tuple[tuple[int, Limits], ...] = ()
    overlaps_s: np.ndarray = field(repr=False, default_factory=lambda: _no_pairs(float))

    @property
    def limit_change_stops(self) -> int:
        """The joins between the parts of ``part_limits``: one exact stop each."""
        return max(len(self.part_limits) - 1, 0)

    def sample(self, period_s: float) -> Trajectory:
        """The reference every ``period_s`` [s] from 0 to the end; the last sample is at rest at
        the program's end exactly (time ceil(duration / period) * period)."""
        return self.sample_range(period_s, 0, self.sample_count(period_s))

    def feeds_mm_per_min(self, source: np.ndarray) -> np.ndarray:
        """Per sample (``source`` (n, 2): :attr:`Trajectory.source`, the program moves each
        sample comes from), the programmed feed [mm/min] that bounds its path speed: the
        smallest feed of those moves (a blend between two moves runs at the smaller feed; a
        dwell's samples, at rest, get the smaller of its two moves'); moves of no length (a
        printer's E-only retraction) bound nothing; NaN where no feed applies (a rapid, or no
        move)."""
        feed = np.fromiter(
            (
                np.nan if isinstance(m, Rapid) else m.feed_mm_per_min if m.length_mm > 0 else np.inf
                for m in self.moves
            ),
            dtype=float,
            count=len(self.moves),
        )
        src = np.asarray(source, dtype=np.int64).reshape(-1, 2)
        if not len(src):
            return np.empty(0)
        pairs, inverse = np.unique(src, axis=0, return_inverse=True)
        per_pair = np.full(len(pairs), np.nan)
        for k, (a, b) in enumerate(pairs.tolist()):
            if 0 <= a <= b < len(feed):
                per_pair[k] = feed[a : b + 1].min()  # NaN when one of them is a rapid
        per_pair[np.isinf(per_pair)] = np.nan  # only moves of no length
        return per_pair[inverse.reshape(-1)]

    def overlap_entries(self) -> np.ndarray:
        """Indices into :attr:`move_start_s` (and :attr:`move_lines`, :attr:`move_sources`) of
        the entries of the stops overlapped, one per row of :attr:`overlaps_s`, in order: an
        overlap is an entry of its own between its two moves, so the moves after it are one
        entry further on."""
        return overlap_entries(self.move_start_s, self.overlaps_s)

    def sample_count(self, period_s: float) -> int:
        """How many samples :meth:`sample` takes every ``period_s`` [s]."""
        if not period_s > 0:
            raise ConfigError(f"sampling period must be > 0 s, got {period_s}")
        return int(np.ceil(self.duration_s / period_s - 1e-9)) + 1

    def sample_range(self, period_s: float, k0: int, k1: int) -> Trajectory:
        """Samples k0..k1-1 of :meth:`sample` (clipped to its length), the same numbers bit for
        bit (each sample is a function of its own time only; tests/test_stream.py checks), for
        runs that take the reference range by range instead of all at once."""
        n = self.sample_count(period_s)
        t = np.arange(max(0, k0), min(n, k1)) * period_s
        pos, vel, acc = self.curve.evaluate(t)
        done = t >= self.duration_s
        pos[done], vel[done], acc[done] = self.end_mm, 0.0, 0.0
        source = None
        if self.move_lines.size:
            k = np.clip(np.searchsorted(self.move_start_s, t, side="right") - 1, 0, None)
            line = self.move_lines[k]
            if len(self.move_sources) == len(self.move_lines):
                source = self.move_sources[k]
        else:
            line = np.zeros(t.size, dtype=np.int64)
        return Trajectory(
            t=t, pos=pos, vel=vel, acc=acc, line=line, period_s=period_s, source=source
        )


def overlap_entries(move_start_s: np.ndarray, overlaps_s: np.ndarray) -> np.ndarray:
    """:meth:`Plan.overlap_entries` of a plan's entries starting at ``move_start_s`` [s] and
    its overlapped stops ``overlaps_s`` ((k, 2) start and end [s])."""
    return np.searchsorted(move_start_s, overlaps_s[:, 0], side="right") - 1


def _no_pairs(dtype: type) -> np.ndarray:
    """A read-only (0, 2) array: no rows of sources (int64) or of overlaps [s] (float)."""
    out: np.ndarray = np.zeros((0, 2), dtype=dtype)
    out.setflags(write=False)
    return out
