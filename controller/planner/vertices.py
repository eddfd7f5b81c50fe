"""The programmed moves' chord vertices, made when asked: a long plan holds none of them.

Every programmed move's chords are a function of the move and the machine's segmentation only
(:func:`~gantry_sim.controller.planner.segment.segment_arc`): arcs and splines by their chord
rule, straight moves (and curves of no length) by their two ends. A plan used to keep them all,
0.17 KB for a straight move and about 2 KB for an arc, for the one pass the run's chord check
makes over them; :class:`ChordVertices` makes each when it is read instead (20,000 arcs in
0.3 s), and keeps the splines' (whose chord count is searched for: :func:`segment_spline`).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import cast, overload

import numpy as np

from gantry_sim.controller.config import Segmentation
from gantry_sim.controller.moves import Arc, Move, Spline
from gantry_sim.controller.planner.segment import segment_arc, segment_arcs, segment_count

__all__ = ["ChordVertices", "chord_count", "move_vertices"]


def move_vertices(m: Move, seg: Segmentation) -> np.ndarray:
    """Read-only (k, 3) chord vertices [mm] of programmed move ``m`` (first = start, last = end):
    an arc's or spline's chords, else (a straight move, a curve of no length such as a G5 whose
    control points all lie at its start) its two ends."""
    if isinstance(m, Arc | Spline) and m.length_mm > 0.0:
        return segment_arc(m, seg.method, seg.chord_tolerance_mm, seg.segment_length_mm)
    verts = np.array([m.start, m.end], dtype=float)
    verts.setflags(write=False)
    return verts


def chord_count(m: Move, seg: Segmentation) -> int:
    """``len(move_vertices(m, seg)) - 1``, without making an arc's vertices."""
    if isinstance(m, Arc) and m.length_mm > 0.0:
        return segment_count(m, seg.method, seg.chord_tolerance_mm, seg.segment_length_mm)
    return len(move_vertices(m, seg)) - 1


class ChordVertices(Sequence[np.ndarray]):
    """Per move of ``moves``, :func:`move_vertices` under ``seg``, made when read (splines'
    kept once made)."""

    __slots__ = ("_splines", "moves", "seg")

    def __init__(self, moves: Sequence[Move], seg: Segmentation) -> None:
        self.moves = moves
        self.seg = seg
        self._splines: dict[int, np.ndarray] = {}

    def __len__(self) -> int:
        return len(self.moves)

    @overload
    def __getitem__(self, index: int) -> np.ndarray: ...

    @overload
    def __getitem__(self, index: slice) -> list[np.ndarray]: ...

    def __getitem__(self, index: int | slice) -> np.ndarray | list[np.ndarray]:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        i = index + len(self) if index < 0 else index
        return self._of(i, self.moves[i])

    def __iter__(self) -> Iterator[np.ndarray]:
        for i, m in enumerate(self.moves):
            yield self._of(i, m)

    def block(self, lo: int, hi: int) -> list[np.ndarray]:
        """``self[lo:hi]``, the arcs' vertices made in batches (segment_arcs: the same numbers;
        one arc at a time, 10,000 arcs took 0.79 s of the run's chord check, in batches
        0.1 s)."""
        moves = self.moves[lo:hi]
        seg = self.seg
        arcs = [k for k, m in enumerate(moves) if isinstance(m, Arc) and m.length_mm > 0.0]
        made = segment_arcs(
            [cast(Arc, moves[k]) for k in arcs],
            seg.method,
            seg.chord_tolerance_mm,
            seg.segment_length_mm,
        )
        out: list[np.ndarray | None] = [None] * len(moves)
        for k, verts in zip(arcs, made, strict=True):
            out[k] = verts
        return [
            self._of(lo + k, m) if v is None else v
            for k, (m, v) in enumerate(zip(moves, out, strict=True))
        ]

    def chord_total(self) -> int:
        """Chords of every move (``sum(len(v) - 1 for v in self)``, without making the arcs'
        vertices)."""
        return sum(
            len(self._of(i, m)) - 1 if isinstance(m, Spline) else chord_count(m, self.seg)
            for i, m in enumerate(self.moves)
        )

    def _of(self, i: int, m: Move) -> np.ndarray:
        if not isinstance(m, Spline):
            return move_vertices(m, self.seg)
        verts = self._splines.get(i)
        if verts is None:
            verts = self._splines[i] = move_vertices(m, self.seg)
        return verts
