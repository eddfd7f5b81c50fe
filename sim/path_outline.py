"""path.png's commanded geometry, computed while the run simulates: the feed moves' box, the arcs'
planes, the drawing's pixel and the feed and rapid moves as NaN-separated polylines
(:class:`Outline`). None of it needs the run's results, and at 30,000 moves it took 0.5 s (two
passes over the moves, read from disk a block at a time) after the run, on its critical path;
sim.plot_prep computes it during the run.

No matplotlib here: importing this module does not import it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.arcs import arc_points
from gantry_sim.controller.moves import Arc, Move, Spline

__all__ = ["BLOCK_MOVES", "Outline", "extent", "outline"]


@dataclass(frozen=True)
class Outline:
    """The commanded geometry path.png draws.

    Attributes:
        lo, hi: (3,) the box of the feed moves' end points [mm] (of every move's when none is a
            feed move).
        planes: the planes of the arcs ("XY", "XZ", "YZ").
        pixel_mm: the drawing's resolution: 1/4000 of the largest extent of every move [mm].
        feed, rapid: (k, 3) the feed and the rapid moves as polylines, NaN rows between the
            pieces that do not join [mm].
    """

    lo: np.ndarray
    hi: np.ndarray
    planes: frozenset[str]
    pixel_mm: float
    feed: np.ndarray
    rapid: np.ndarray


def outline(moves: Sequence[Move]) -> Outline:
    """The :class:`Outline` of ``moves`` (at least one)."""
    lo, hi, planes, pixel_mm = extent(moves)
    feed, rapid = _polylines(moves, pixel_mm)
    return Outline(lo, hi, frozenset(planes), pixel_mm, feed, rapid)


#: moves read at a time (a long program's moves come from disk in blocks)
BLOCK_MOVES = 4096


def extent(moves: Sequence[Move]) -> tuple[np.ndarray, np.ndarray, set[str], float]:
    """One pass over ``moves``, a block at a time: the box (lo, hi) of the feed moves' end
    points (of every move's when none is a feed move), the planes of the arcs, and the drawing's
    pixel [mm]: 1/4000 of the largest extent of every move's end points."""
    inf = np.full(3, np.inf)
    feed_box, every_box = [inf, -inf], [inf, -inf]
    planes: set[str] = set()
    for k in range(0, len(moves), BLOCK_MOVES):
        block = moves[k : k + BLOCK_MOVES]
        ends = np.array([[mv.start, mv.end] for mv in block], dtype=float)
        feed = np.array([mv.kind != "rapid" for mv in block])
        planes |= {mv.plane for mv in block if isinstance(mv, Arc)}
        for box, rows in ((feed_box, ends[feed]), (every_box, ends)):
            if rows.size:
                pts = rows.reshape(-1, 3)
                box[0] = np.minimum(box[0], pts.min(axis=0))
                box[1] = np.maximum(box[1], pts.max(axis=0))
    pixel_mm = max(float((every_box[1] - every_box[0]).max()), 1e-6) / 4000.0
    lo, hi = feed_box if np.isfinite(feed_box[0]).all() else every_box
    return lo, hi, planes, pixel_mm


class _Points:
    """The points of one kind of move, in a growing array: consecutive moves that join (one
    starts where the last ended) drawn as one polyline, NaN rows between the others."""

    def __init__(self) -> None:
        self.rows = np.empty((1024, 3))
        self.n = 0
        self.last: tuple[float, ...] | None = None

    def add(self, start: tuple[float, ...], pts: np.ndarray | None, end: tuple[float, ...]) -> None:
        """A move from ``start`` to ``end`` [mm] through ``pts`` (its drawn points, ends
        included; None: a straight move)."""
        count = 2 if pts is None else len(pts)
        self._room(count + 1)
        if self.last is None or self.last != tuple(start):
            if self.n:  # a gap: a move that does not start where the last one ended
                self.rows[self.n] = np.nan
                self.n += 1
            self.rows[self.n] = start
            self.n += 1
        if pts is None:
            self.rows[self.n] = end
            self.n += 1
        else:
            self.rows[self.n : self.n + count - 1] = pts[1:]
            self.n += count - 1
        self.last = tuple(end)

    def _room(self, k: int) -> None:
        if self.n + k > len(self.rows):
            grown = np.empty((max(2 * len(self.rows), self.n + k), 3))
            grown[: self.n] = self.rows[: self.n]
            self.rows = grown

    def array(self) -> np.ndarray:
        """The points, without the growth's spare rows (the outline is kept through the run)."""
        return self.rows[: self.n].copy()


def _polylines(moves: Sequence[Move], pixel_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """(feed, rapid) geometry as one (k, 3) [mm] array each: moves that join drawn as one
    polyline, NaN rows between the others (one Line2D draws them all). Arcs get about one point
    per degree, fewer where the figure cannot show more: enough that the chord's sagitta stays
    under a quarter of ``pixel_mm``; an arc below that is drawn as its chord. Splines: their
    curve, sampled. The moves are read a block at a time."""
    feed, rapid = _Points(), _Points()
    for k in range(0, len(moves), BLOCK_MOVES):
        for mv in moves[k : k + BLOCK_MOVES]:
            pts = None
            if isinstance(mv, Arc):
                # sagitta of n chords over the angle: R (1 - cos(angle / 2n)) ~ R angle^2 / (8 n^2)
                n_fine = np.ceil(np.degrees(mv.angle))
                n = int(min(n_fine, np.ceil(mv.angle * np.sqrt(mv.radius / (8.0 * pixel_mm)))))
                if n > 1:
                    pts = arc_points(mv, np.linspace(0.0, 1.0, max(n, 8) + 1))
            elif isinstance(mv, Spline):  # the exact curve, ~ one point per quarter pixel
                c = mv.curve
                n = int(min(max(c.length_mm / (4.0 * pixel_mm), 8), 4096))
                pts = c.nurbs.points(np.linspace(c.nurbs.t_min, c.nurbs.t_max, n + 1))
            (rapid if mv.kind == "rapid" else feed).add(mv.start, pts, mv.end)
    return feed.array(), rapid.array()
