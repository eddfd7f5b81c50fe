"""The rows of the move tables one streamed range's analysis can reach: the analysis in memory
bounded by the range, not the program.

A streamed run (sim.stream) analyses a range of ticks against the commanded program and the path
the planner followed. The search for a tick (sim.program_distance.distance_to_moves) measures
the moves it executes (its Trajectory.source), one move either side, and the moves within
LAG_REACH x |pos - ref| of path beyond them; the reference's distance from the path followed
measures the path moves its program moves became, one either side. So a range needs only the
rows from its first executed move, less the path its largest lag reaches back, to its last, plus
that reach forward: :class:`RowPicker` finds them from compact whole-program arrays
(:class:`~gantry_sim.sim.move_table.ProgramIndex`, Plan.path_sources) and hands the analysis
those moves, which it lays out as tables of their own (the path lengths taken from the whole
program's, so every number is the whole table's: tests/test_stream.py). Before, both whole
tables went to the analysis (about 600 bytes a move: 70 MB at 100,000 polyline blocks).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.moves import Move, PathMove
from gantry_sim.controller.pickled_slice import DecodedBlocks, PickledSlice
from gantry_sim.controller.spill import SpilledList
from gantry_sim.controller.trajectory import Trajectory
from gantry_sim.sim.contour import LAG_REACH
from gantry_sim.sim.move_table import ProgramIndex
from gantry_sim.sim.program_distance import path_window

__all__ = ["MARGIN_ROWS", "RangeTables", "RowPicker"]

#: rows added either side of those the search can reach (rounding of the reach's bounds)
MARGIN_ROWS = 2


@dataclass(frozen=True)
class RangeTables:
    """The moves one range is analysed against.

    Attributes:
        moves: the program's moves r0 .. r0 + len(moves) - 1 (a PickledSlice of them when
            they go to a worker process: :meth:`listed` lists them).
        cum_len: (len(moves) + 1,) the whole program's path length before each of them [mm].
        r0: the program index of ``moves[0]`` (Trajectory.source counts from the program's
            first move).
        path_moves: the moves of the path the planner followed that the range comes from
            (the whole path when ``path_window`` is None; a PickledSlice, as ``moves``).
        found: (n,) per tick, whether its line has moves anywhere in the program.
        path_window: (n, 2) per tick, the rows of ``path_moves`` its program moves became;
            None: searched by line.
    """

    moves: list[Move] | PickledSlice
    cum_len: np.ndarray
    r0: int
    path_moves: list[PathMove] | PickledSlice
    found: np.ndarray
    path_window: np.ndarray | None

    def listed(self, cache: DecodedBlocks | None = None) -> tuple[list[Move], list[PathMove]]:
        """:attr:`moves` and :attr:`path_moves` as lists (pickled blocks decoded, through
        ``cache`` when given)."""
        moves, path = self.moves, self.path_moves
        return (
            moves.items(cache) if isinstance(moves, PickledSlice) else moves,
            path.items(cache) if isinstance(path, PickledSlice) else path,
        )


class RowPicker:
    """Picks each range's :class:`RangeTables` (see the module docstring) from the program's
    ``moves``, the path followed (``path_moves``), the program's :class:`ProgramIndex` and
    ``path_sources`` (Plan.path_sources; None where not known: the whole path is searched).
    ``pickled``: the tables go to another process: lists kept on disk are handed over as the
    pickled blocks that hold the rows (controller/pickled_slice.py), not read and pickled again.
    """

    def __init__(
        self,
        moves: Sequence[Move],
        path_moves: Sequence[PathMove],
        index: ProgramIndex,
        path_sources: np.ndarray | None,
        *,
        pickled: bool = False,
    ) -> None:
        self.moves, self.path_moves, self.index = moves, path_moves, index
        self.pickled = pickled
        self.path_sources = path_sources
        self._lines = np.unique(index.line)  # the lines that have moves, sorted

    def tables(
        self, piece: Trajectory, context_pos: np.ndarray, offset: int, pos: np.ndarray
    ) -> RangeTables:
        """The moves the range of reference ``piece`` (its samples are
        ``context_pos[offset:offset + n]`` [mm]) traced at ``pos`` (n, 3) [mm] can reach."""
        line = np.asarray(piece.line)
        at = np.minimum(np.searchsorted(self._lines, line), max(len(self._lines) - 1, 0))
        found = self._lines[at] == line if len(self._lines) else np.zeros(len(line), bool)
        src = None if piece.source is None else np.asarray(piece.source).reshape(-1, 2)
        m = len(self.index)
        if src is None or not len(src) or (src < 0).any() or not m:  # searched by line
            r0, r1 = 0, m
        else:
            ref = context_pos[offset : offset + len(pos)]
            reach = float((LAG_REACH * np.linalg.norm(pos - ref, axis=1)).max())
            r0, r1 = self._program_rows(int(src[:, 0].min()), int(src[:, 1].max()), reach)
        window = None
        q0, q1 = 0, len(self.path_moves)
        if src is not None and len(src) and self.path_sources is not None and (src >= 0).all():
            w = path_window(self.path_sources, src)
            q0 = max(0, int(w.min()) - 1 - MARGIN_ROWS)
            q1 = min(q1, int(w.max()) + 2 + MARGIN_ROWS)
            window = w - q0
        return RangeTables(
            moves=self._rows(self.moves, r0, r1),
            cum_len=self.index.cum_len[r0 : r1 + 1].copy(),
            r0=r0,
            path_moves=self._rows(self.path_moves, q0, q1),
            found=found,
            path_window=window,
        )

    def _rows(self, seq: Sequence, lo: int, hi: int) -> list | PickledSlice:
        if self.pickled and isinstance(seq, SpilledList):
            return seq.pickled(lo, hi)
        return list(seq[lo:hi])

    def _program_rows(self, first: int, last: int, reach_mm: float) -> tuple[int, int]:
        """Rows [r0, r1) holding moves ``first`` .. ``last`` (executed), one either side, and
        every move the search walks to within ``reach_mm`` of path of them: back while the path
        between a move's end and ``first`` is shorter than the reach, forward while the path
        between ``last``'s end and a move's start is."""
        cum, m = self.index.cum_len, len(self.index)
        if not np.isfinite(reach_mm):  # a reach past the program: every row
            return 0, m
        back = int(np.searchsorted(cum, cum[first] - reach_mm, side="right")) - 1
        ahead = int(np.searchsorted(cum, cum[last + 1] + reach_mm, side="left")) - 1
        r0 = max(0, min(first - 1, back) - MARGIN_ROWS)
        r1 = min(m, max(last + 2, ahead + 1) + MARGIN_ROWS)
        return r0, r1
