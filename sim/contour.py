"""Contour error: the traced tool tip against the COMMANDED geometry, and its parts.

Every sample k carries the program line being executed (the trajectory's ``line``). Its contour
error is the distance to the nearest point of that line's move(s) and their neighbours in program
order (near a block junction the tool may be just before or after it). Parts (all [um]):

* chord: how far the chords (the planner's vertices) leave the true arcs -- segmentation;
* reference: how far the reference samples leave the geometry -- planning;
* tracking: how far the traced points leave the reference path (a polyline through the reference
  samples, searched near the same instant) -- the servo and the machine.

Statistics cover the feed moves only (G1/G2/G3): rapids are not cutting.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.moves import Arc, Move
from gantry_sim.controller.units import UM_PER_MM
from gantry_sim.sim.nearest import distance_to_polyline_near, nearest_on_move

#: reference samples either side searched for the tracking part (50 ms at 1 kHz)
TRACKING_WINDOW = 50
#: points along each chord checked for the chord part (fractions of the chord)
CHORD_FRACTIONS = (0.25, 0.5, 0.75)


@dataclass(frozen=True)
class ContourStats:
    """Statistics of a set of contour errors [um]: largest, root mean square, 95th percentile."""

    max_um: float
    rms_um: float
    p95_um: float

    def to_json(self) -> dict[str, float]:
        return {"max": self.max_um, "rms": self.rms_um, "p95": self.p95_um}


@dataclass(frozen=True)
class ErrorParts:
    """The largest of each part of the contour error [um] (see the module docstring)."""

    chord_max_um: float
    reference_max_um: float
    tracking_max_um: float

    def to_json(self) -> dict[str, float]:
        return {
            "chord_max": self.chord_max_um,
            "reference_max": self.reference_max_um,
            "tracking_max": self.tracking_max_um,
        }


@dataclass(frozen=True)
class BlockError:
    """The contour error of one feed block (all samples executing its line) [um]."""

    line: int
    kind: str
    max_error_um: float
    rms_error_um: float

    def to_json(self) -> dict[str, int | str | float]:
        return {
            "line": self.line,
            "kind": self.kind,
            "max_error_um": self.max_error_um,
            "rms_error_um": self.rms_error_um,
        }


@dataclass(frozen=True)
class Analysis:
    """Contour error of a trace.

    Attributes:
        err_um: (N,) contour error of each traced point [um].
        nearest: (N, 3) the nearest commanded point to each traced point [mm].
        feed: (N,) True where the sample belongs to a feed move (G1/G2/G3).
        contour: statistics over the feed samples [um].
        parts: the largest chord, reference and tracking parts [um].
        blocks: per feed block in program order.
    """

    err_um: np.ndarray
    nearest: np.ndarray
    feed: np.ndarray
    contour: ContourStats
    parts: ErrorParts
    blocks: tuple[BlockError, ...]


def _candidate_ranges(moves: Sequence[Move], lines: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per sample, the first and last move index to compare with (its own moves +- 1)."""
    first: dict[int, int] = {}
    last: dict[int, int] = {}
    for j, mv in enumerate(moves):
        first.setdefault(mv.line, j)
        last[mv.line] = j
    uniq, inv = np.unique(lines, return_inverse=True)
    m = len(moves)
    lo_u = np.array([max(0, first[int(v)] - 1) if int(v) in first else 0 for v in uniq])
    hi_u = np.array([min(m - 1, last[int(v)] + 1) if int(v) in last else m - 1 for v in uniq])
    return lo_u[inv], hi_u[inv]


def distance_to_program(
    moves: Sequence[Move], lines: np.ndarray, pts: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Distance [mm] and nearest commanded point (n, 3) [mm] for points executing ``lines``."""
    n = len(pts)
    best = np.full(n, np.inf)
    nearest = np.array(pts, dtype=float, copy=True)
    if not moves or n == 0:
        return np.zeros(n), nearest
    lo, hi = _candidate_ranges(moves, np.asarray(lines))
    monotone = bool(np.all(np.diff(lo) >= 0) and np.all(np.diff(hi) >= 0))
    for j, mv in enumerate(moves):
        if monotone:  # samples comparing with move j form one contiguous run
            a, b = np.searchsorted(hi, j, "left"), np.searchsorted(lo, j, "right")
            idx = np.arange(a, max(a, b))
            idx = idx[lo[idx] <= j]
        else:
            idx = np.flatnonzero((lo <= j) & (j <= hi))
        if idx.size == 0:
            continue
        q = nearest_on_move(mv, pts[idx])
        dist = np.linalg.norm(q - pts[idx], axis=1)
        better = dist < best[idx]
        best[idx[better]] = dist[better]
        nearest[idx[better]] = q[better]
    return best, nearest


def _stats(err_um: np.ndarray) -> ContourStats:
    if err_um.size == 0:
        return ContourStats(0.0, 0.0, 0.0)
    return ContourStats(
        max_um=float(err_um.max()),
        rms_um=float(np.sqrt(np.mean(err_um**2))),
        p95_um=float(np.percentile(err_um, 95)),
    )


def chord_max_um(moves: Sequence[Move], vertices: Sequence[np.ndarray] | None) -> float:
    """Largest distance of the chords between each arc's vertices from the arc [um]."""
    worst = 0.0
    if vertices is None:
        return worst
    for mv, verts in zip(moves, vertices, strict=True):
        verts = np.asarray(verts, dtype=float).reshape(-1, 3)
        if not isinstance(mv, Arc) or len(verts) < 2:
            continue
        pts = np.concatenate([verts[:-1] + f * (verts[1:] - verts[:-1]) for f in CHORD_FRACTIONS])
        dist = np.linalg.norm(nearest_on_move(mv, pts) - pts, axis=1)
        worst = max(worst, float(dist.max()) * UM_PER_MM)
    return worst


def analyse(
    moves: Sequence[Move],
    line: np.ndarray,
    ref: np.ndarray,
    pos: np.ndarray,
    vertices: Sequence[np.ndarray] | None = None,
) -> Analysis:
    """Contour error of the trace ``pos`` (N, 3) [mm] following ``ref`` (N, 3) [mm].

    Args:
        moves: the interpreter's moves (the commanded geometry).
        line: (N,) program line executed at each sample.
        ref: (N, 3) reference samples [mm] (program coordinates).
        pos: (N, 3) traced tool tip [mm] (program coordinates).
        vertices: per move, the planner's chord vertices (k, 3) [mm], for the chord part.
    """
    line = np.asarray(line)
    kind_of = {mv.line: mv.kind for mv in moves}
    feed = np.array([kind_of.get(int(v), "rapid") != "rapid" for v in line], dtype=bool)
    dist, nearest = distance_to_program(moves, line, pos)
    err_um = dist * UM_PER_MM
    ref_um = distance_to_program(moves, line[feed], ref[feed])[0] * UM_PER_MM
    track_um = distance_to_polyline_near(ref, pos, TRACKING_WINDOW)[feed] * UM_PER_MM
    blocks: list[BlockError] = []
    seen: set[int] = set()
    for mv in moves:
        if mv.kind == "rapid" or mv.line in seen:
            continue
        seen.add(mv.line)
        e = err_um[line == mv.line]
        s = _stats(e)
        blocks.append(BlockError(int(mv.line), mv.kind, s.max_um, s.rms_um))
    parts = ErrorParts(
        chord_max_um=chord_max_um(moves, vertices),
        reference_max_um=float(ref_um.max()) if ref_um.size else 0.0,
        tracking_max_um=float(track_um.max()) if track_um.size else 0.0,
    )
    for arr in (err_um, nearest, feed):
        arr.setflags(write=False)
    return Analysis(err_um, nearest, feed, _stats(err_um[feed]), parts, tuple(blocks))
