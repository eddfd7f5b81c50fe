"""The commanded moves laid out as arrays, one row per move in program order, for the vectorised
nearest-point search (sim/nearest.py) and the analysis (sim/contour.py).

Every derived number is computed here exactly as controller.arcs computes it for one move (the
same float operations on the same operands in the same order), so the vectorised search gives,
point for point, the numbers the one-move functions give. Coordinates [mm], angles [rad].

The table is built for all moves at once: numpy's +, -, *, / and % on float64 round as Python's
float operations do, and the transcendental functions (atan2, hypot, cos, sin) are Python's
``math`` ones, mapped over the rows' values (numpy's may round differently). The one-move
definitions are the test's oracles (tests/test_move_table_batch.py keeps the loop this
replaced, and the one-arc box).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from itertools import chain
from operator import attrgetter
from typing import NamedTuple, cast

import numpy as np

from gantry_sim.controller.moves import Arc, Linear, Move, PathMove, Rapid, Spline, Transition
from gantry_sim.controller.planes import PLANE_AXES
from gantry_sim.controller.quintic_curve import (
    BERNSTEIN,
    ROW,
    QuinticCurve,
    packed_rows,
    row_cells,
    row_coefficients,
    row_ends,
)
from gantry_sim.sim.block_files import block_keys

#: slack added to every move's bounding box [mm] (rounding in the box, not geometry)
BOX_SLACK_MM = 1e-9


@dataclass(frozen=True)
class MoveTable:
    """Per move (M rows). Segments (G0/G1) use start, seg_d, length2; arcs the rest (zeros on
    segment rows); splines (G5, G5.1, G5.2) and the planner's G2 transitions (on a path the
    planner followed, Plan.path_moves) their exact curve in ``curves``.

    Attributes:
        line: (M,) source line.
        feed: (M,) True for G1/G2/G3, False for G0.
        arc: (M,) True for G2/G3.
        start, end: (M, 3) programmed start and end points.
        seg_d: (M, 3) end - start; length2: (M,) its squared length [mm^2].
        axes: (M, 3) the plane's (first, second, normal) axis indices.
        c1, c2: centre coordinates on the first and second plane axes.
        theta0: polar angle of the start about the centre; sigma: +1 ccw, -1 cw; angle: sweep A
        (> 0); s_angle: sigma * A.
        r0, dr: in-plane radius at the start and its change to the end; h0, dh: normal-axis
        coordinate at the start and its change; k2: 2 dr s_angle (in d2p/du2).
        turns: ceil(A / 2 pi), the angle-projection candidates past the first.
        newton: True where the radius or height changes (helix or spiral: Newton refinement).
        box_lo, box_hi: (M, 3) an axis-aligned box holding the move (with BOX_SLACK_MM).
        arc_start: (M, 3) an arc's point at u = 0 as controller.arcs.arc_points computes it
        (the start on segment rows).
        spline: (M,) True for G5/G5.1/G5.2 and transitions (their ``arc`` is False).
        curves: (M,) per spline row its SplineCurve (controller/spline_curve.py), per
            transition row its QuinticCurve (controller/quintic_curve.py), else None; each
            gives ``nearest_points``.
        cum_len: (M + 1,) path length [mm] before each move (cum_len[M]: the whole program).
    """

    line: np.ndarray
    feed: np.ndarray
    arc: np.ndarray
    start: np.ndarray
    end: np.ndarray
    seg_d: np.ndarray
    length2: np.ndarray
    axes: np.ndarray
    c1: np.ndarray
    c2: np.ndarray
    theta0: np.ndarray
    sigma: np.ndarray
    angle: np.ndarray
    s_angle: np.ndarray
    r0: np.ndarray
    dr: np.ndarray
    h0: np.ndarray
    dh: np.ndarray
    k2: np.ndarray
    turns: np.ndarray
    newton: np.ndarray
    box_lo: np.ndarray
    box_hi: np.ndarray
    arc_start: np.ndarray
    cum_len: np.ndarray
    spline: np.ndarray
    curves: tuple

    def __len__(self) -> int:
        return len(self.line)


_ARC_FIELDS = ("c1", "c2", "theta0", "sigma", "angle", "s_angle", "r0", "dr", "h0", "dh", "k2")


def move_table(moves: Sequence[PathMove], cum_len: np.ndarray | None = None) -> MoveTable:
    """Lay out ``moves`` (the interpreter's, in program order, or a plan's path) as a
    :class:`MoveTable`; ``cum_len`` (len(moves) + 1,) [mm]: the path length before each move
    when the moves are rows of a longer program (its :class:`ProgramIndex`'s), else counted
    from their start (each move's ``length_mm``, as :func:`_lengths` computes it)."""
    if not isinstance(moves, list | tuple):  # a plan's path on disk (SpilledList): read once
        moves = list(moves)
    m = len(moves)
    start, end = _points(moves, "start"), _points(moves, "end")
    seg_d = end - start
    # float(d @ d) of every row d: matmul of (m, 1, 3) by (m, 3, 1) runs, row by row, the very
    # loop d @ d runs (numpy's dot of two 3-vectors, BLAS ddot, which may fuse multiply-adds,
    # so the plain sum of the products, as einsum takes it, may differ in the last bit)
    length2 = np.matmul(seg_d[:, None, :], seg_d[:, :, None]).reshape(m)
    is_arc, is_spline, straight, feed = _classes(moves)
    axes = np.zeros((m, 3), dtype=np.intp)
    cols = {name: np.zeros(m) for name in _ARC_FIELDS}
    turns = np.zeros(m, dtype=np.intp)
    newton = np.zeros(m, dtype=bool)
    box_lo, box_hi = np.minimum(start, end), np.maximum(start, end)
    splines = np.flatnonzero(is_spline).tolist()
    spline_moves = cast(list[Spline | Transition], [moves[j] for j in splines])
    steps = [j for j, mv in zip(splines, spline_moves, strict=True) if isinstance(mv, Transition)]
    step_rows = _TransitionRows(moves, steps)
    if steps:  # G2 transitions and G64 fits' pieces (thousands on a CAM polyline): at once
        ctrl = step_rows.control_points
        box_lo[steps] = np.minimum(box_lo[steps], ctrl.min(axis=1))
        box_hi[steps] = np.maximum(box_hi[steps], ctrl.max(axis=1))
    for j, mv in zip(splines, spline_moves, strict=True):  # NURBS: rare, one at a time
        if not isinstance(mv, Transition):
            lo_j, hi_j = _spline_box(mv)
            box_lo[j] = np.minimum(box_lo[j], lo_j)
            box_hi[j] = np.maximum(box_hi[j], hi_j)
    arcs = np.flatnonzero(is_arc)
    arc_start = start.copy()
    frames = None
    if arcs.size:  # the arcs' fields and boxes written at once (min and max are exact)
        arc_moves = cast(list[Arc], [moves[j] for j in arcs.tolist()])
        frames = _arc_frames(arc_moves, start[arcs], end[arcs])
        i1, i2, _ = frames.axes.T
        rows = np.arange(arcs.size)
        s_angle = frames.sigma * frames.angle
        dr = frames.r1 - frames.r0
        values = {
            "c1": frames.center[rows, i1],
            "c2": frames.center[rows, i2],
            "theta0": frames.theta0,
            "sigma": frames.sigma,
            "angle": frames.angle,
            "s_angle": s_angle,
            "r0": frames.r0,
            "dr": dr,
            "h0": frames.h0,
            "dh": frames.h1 - frames.h0,
            "k2": 2.0 * dr * s_angle,
        }
        for name in _ARC_FIELDS:
            cols[name][arcs] = values[name]
        axes[arcs] = frames.axes
        turns[arcs] = _ceil(frames.angle / (2.0 * math.pi))
        newton[arcs] = (frames.h1 != frames.h0) | (frames.r1 != frames.r0)
        lo, hi = _arc_boxes(start[arcs], frames)
        box_lo[arcs] = np.minimum(box_lo[arcs], lo)
        box_hi[arcs] = np.maximum(box_hi[arcs], hi)
        # arc_points at u = 0, the same operations vectorised
        u0 = np.zeros(arcs.size)
        theta = cols["theta0"][arcs] + cols["s_angle"][arcs] * u0
        r = cols["r0"][arcs] + cols["dr"][arcs] * u0
        at = arc_start[arcs]
        at[rows, axes[arcs, 0]] = cols["c1"][arcs] + r * np.cos(theta)
        at[rows, axes[arcs, 1]] = cols["c2"][arcs] + r * np.sin(theta)
        at[rows, axes[arcs, 2]] = cols["h0"][arcs] + cols["dh"][arcs] * u0
        arc_start[arcs] = at
    if cum_len is None:
        length = _lengths(moves, seg_d, straight, arcs, frames, steps, step_rows)
        cum_len = np.concatenate([[0.0], np.cumsum(length)])
    curves: list[object] = [None] * m
    for j, c in zip(steps, step_rows.curves, strict=True):
        curves[j] = c
    for j, mv in zip(splines, spline_moves, strict=True):
        if not isinstance(mv, Transition):
            curves[j] = mv.curve
    return MoveTable(
        line=np.array(list(map(attrgetter("line"), moves)), dtype=np.int64),
        feed=feed,
        arc=is_arc,
        start=start,
        end=end,
        seg_d=seg_d,
        length2=length2,
        axes=axes,
        turns=turns,
        newton=newton,
        box_lo=box_lo - BOX_SLACK_MM,
        box_hi=box_hi + BOX_SLACK_MM,
        arc_start=arc_start,
        cum_len=np.asarray(cum_len, dtype=float),
        spline=is_spline,
        curves=tuple(curves),
        **cols,
    )


def _points(moves: Sequence[PathMove], name: str) -> np.ndarray:
    """(len(moves), 3) every move's point ``name`` ("start" or "end") [mm]."""
    coords = chain.from_iterable(map(attrgetter(name), moves))
    return np.array(list(coords), dtype=float).reshape(len(moves), 3)


def _classes(moves: Sequence[PathMove]) -> np.ndarray:
    """(4, len(moves)) bool: per move whether it is an :class:`Arc`, a :class:`Spline` or
    :class:`Transition`, a :class:`Linear` or :class:`Rapid`, and a feed move (its ``kind`` is
    not "rapid"), each asked once per class (isinstance asks the same of an object's class:
    moves do not fake theirs; ``kind`` is a class attribute)."""
    types = cast(list[type[PathMove]], list(map(type, moves)))
    code = {t: i for i, t in enumerate(dict.fromkeys(types))}  # the classes present
    of_class = [
        (
            issubclass(t, Arc),
            issubclass(t, Spline | Transition),
            issubclass(t, Linear | Rapid),
            t.kind != "rapid",
        )
        for t in code
    ]
    index = np.fromiter(map(code.__getitem__, types), dtype=np.intp, count=len(types))
    return np.array(of_class, dtype=bool).reshape(-1, 4)[index].T


def _lengths(
    moves: Sequence[PathMove],
    seg_d: np.ndarray,
    straight: np.ndarray,
    arcs: np.ndarray,
    frames: _ArcFrames | None,
    steps: Sequence[int] = (),
    step_rows: _TransitionRows | None = None,
) -> np.ndarray:
    """(len(moves),) every move's ``length_mm`` [mm], the numbers controller/moves.py gives: a
    straight move's math.dist(start, end) is math.hypot of its seg_d (both take |p - q| per
    axis into the same norm), an arc's math.hypot(0.5 * (r0 + r1) * A, h1 - h0) with its
    frame's numbers (Arc.length_mm's own), a transition's the last of its row's arc lengths
    (``steps``: their rows, ``step_rows``), any other move's (a spline's) its own property."""
    length = np.zeros(len(moves))
    rows = np.flatnonzero(straight)
    length[rows] = _map(math.hypot, *seg_d[rows].T)
    if frames is not None:
        in_plane = 0.5 * (frames.r0 + frames.r1) * frames.angle
        length[arcs] = _map(math.hypot, in_plane, frames.h1 - frames.h0)
    rest = ~straight
    rest[arcs] = False
    if steps and step_rows is not None:
        length[list(steps)] = step_rows.length_mm
        rest[list(steps)] = False
    for j in np.flatnonzero(rest).tolist():
        length[j] = moves[j].length_mm
    return length


class _TransitionRows:
    """The packed rows of some :class:`Transition` moves, read once: their control points
    (m, 6, 3) [mm] (as ``Transition.control_points``: ends exact), arc lengths [mm] and curves."""

    def __init__(self, moves: Sequence[PathMove], at: Sequence[int]) -> None:
        packed = [cast(Transition, moves[j]).row for j in at]
        self.rows = packed_rows(packed) if packed else np.zeros((0, ROW))

    @property
    def control_points(self) -> np.ndarray:
        rows = self.rows
        ctrl = np.einsum("ij,mjk->mik", BERNSTEIN, row_coefficients(rows))
        ctrl[:, [0, 5]] = row_ends(rows)
        return ctrl

    @property
    def length_mm(self) -> np.ndarray:
        return row_cells(self.rows)[:, -1].copy()

    @property
    def curves(self) -> list[QuinticCurve]:
        return [QuinticCurve.from_row(r) for r in self.rows]


@dataclass(frozen=True)
class ProgramIndex:
    """What the whole-run figures need of every move of a long program, in compact arrays (a
    :class:`MoveTable` is about 300 bytes a move; this 35): per move its line, whether it is a
    feed move, an arc or a spline (:class:`~gantry_sim.sim.error_tally.ErrorTally`'s blocks), and
    the path length [mm] before each move (len + 1,), counted as :func:`move_table` counts it,
    so a table of some of its rows (``move_table(moves[a:b], index.cum_len[a:b + 1])``) has the
    whole table's numbers; and per move its block key, with the subroutine files' names
    (sim.block_files: a subroutine file's lines are blocks of their own)."""

    line: np.ndarray
    feed: np.ndarray
    arc: np.ndarray
    spline: np.ndarray
    cum_len: np.ndarray
    key: np.ndarray
    files: tuple[str, ...] = ()

    def __len__(self) -> int:
        return len(self.line)

    @classmethod
    def of(cls, moves: Sequence[Move], block: int = 4096) -> ProgramIndex:
        """The index of ``moves``, read ``block`` moves at a time (a long program's come from
        disk: :class:`~gantry_sim.controller.spill.SpilledList`)."""
        lines: list[int] = []
        kinds: list[str] = []
        lengths: list[float] = []
        files: list[str | None] = []
        for k in range(0, len(moves), block):
            for mv in moves[k : k + block]:
                lines.append(mv.line)
                kinds.append(mv.kind)
                lengths.append(mv.length_mm)
                files.append(mv.file)
        kind = np.array(kinds)
        line = np.array(lines, dtype=np.int64)
        key, names = block_keys(line, files)
        return cls(
            line=line,
            feed=kind != "rapid",
            arc=kind == "arc",
            spline=kind == "spline",
            cum_len=np.concatenate([[0.0], np.cumsum(np.array(lengths, dtype=float))]),
            key=key,
            files=names,
        )


def _spline_box(spline: Spline | Transition) -> tuple[np.ndarray, np.ndarray]:
    """A box [mm] holding the spline: its control points' box (a NURBS with positive weights,
    and a transition's Bezier curve, lie in their convex hull); with a negative weight
    (rs274's first G5.2 point without P), dense samples widened by
    :data:`SAMPLED_BOX_SLACK_MM`."""
    pts = np.asarray(spline.control_points, dtype=float)
    if isinstance(spline, Transition) or min(spline.weights) > 0:
        return pts.min(axis=0), pts.max(axis=0)
    c = spline.curve
    t = np.linspace(c.nurbs.t_min, c.nurbs.t_max, 4096 * len(pts))
    on = c.nurbs.points(t)
    return on.min(axis=0) - SAMPLED_BOX_SLACK_MM, on.max(axis=0) + SAMPLED_BOX_SLACK_MM


#: slack on a sampled spline box [mm] (far above curvature * step^2 / 8 of the samples)
SAMPLED_BOX_SLACK_MM = 1e-3


#: the quadrant angles k pi / 2, k = 0..3, with their cosine and sine rounded to the exact -1, 0, 1
_QUADRANTS = tuple(
    (k * math.pi / 2, round(math.cos(k * math.pi / 2)), round(math.sin(k * math.pi / 2)))
    for k in range(4)
)


class _ArcFrames(NamedTuple):
    """:func:`controller.arcs.arc_frame <gantry_sim.controller.arcs.arc_frame>` of k arcs, as
    arrays, with the arcs' centres and sweeps."""

    axes: np.ndarray  #: (k, 3) the plane's (first, second, normal) axis indices
    center: np.ndarray  #: (k, 3) arc centre [mm]
    angle: np.ndarray  #: (k,) sweep A [rad]
    theta0: np.ndarray  #: (k,) polar angle of the start about the centre [rad]
    sigma: np.ndarray  #: (k,) +1 counter-clockwise (G3), -1 clockwise (G2)
    r0: np.ndarray  #: (k,) in-plane radius at the start [mm] (the programmed radius)
    r1: np.ndarray  #: (k,) in-plane radius at the end [mm]
    h0: np.ndarray  #: (k,) normal-axis coordinate at the start [mm]
    h1: np.ndarray  #: (k,) normal-axis coordinate at the end [mm]


#: each plane's row in _PLANE_AXES, PLANE_AXES as a (3, 3) array
_PLANE_ROW = {plane: row for row, plane in enumerate(PLANE_AXES)}
_PLANE_AXES = np.array(list(PLANE_AXES.values()), dtype=np.intp)


def _arc_frames(arcs: Sequence[Arc], start: np.ndarray, end: np.ndarray) -> _ArcFrames:
    """The frames of ``arcs`` (k >= 1), each number as controller.arcs._arc_frame computes it
    (its differences of the arcs' float coordinates, taken here in numpy, round alike);
    ``start``, ``end`` (k, 3): the arcs' start and end points [mm] as floats."""
    k = len(arcs)
    fields = map(attrgetter("plane", "direction", "center", "radius", "angle"), arcs)
    plane, direction, center, radius, angle = zip(*fields, strict=True)
    axes = _PLANE_AXES[np.fromiter(map(_PLANE_ROW.__getitem__, plane), dtype=np.intp, count=k)]
    centre = np.array(list(chain.from_iterable(center)), dtype=float).reshape(k, 3)
    rows = np.arange(k)
    i1, i2, n = axes.T
    c1, c2 = centre[rows, i1], centre[rows, i2]
    return _ArcFrames(
        axes=axes,
        center=centre,
        angle=np.array(angle, dtype=float),
        theta0=_map(math.atan2, start[rows, i2] - c2, start[rows, i1] - c1),
        sigma=np.array([1.0 if d == "ccw" else -1.0 for d in direction]),
        r0=np.array(radius, dtype=float),
        r1=_map(math.hypot, end[rows, i1] - c1, end[rows, i2] - c2),
        h0=start[rows, n],
        h1=end[rows, n],
    )


def _arc_boxes(start: np.ndarray, frames: _ArcFrames) -> tuple[np.ndarray, np.ndarray]:
    """A box [mm] holding each of k arcs (with its start and end: the caller's box has them
    too): in the plane, the box of the annular sector the arc sweeps between its smaller and
    larger radius -- the sector's extremes lie at its two end angles and at every quadrant
    angle (theta = k pi / 2) the sweep passes, each at either radius (a spiral's radius goes
    between r0 and r1, so a point just before the end may lie beyond the end point: the box
    of the start, end and quadrant points widened by |r1 - r0| about the start missed it by
    38 nm on an R 34 arc of 1 degree whose radius shrank by 4 um). (k, 3) lo and hi [mm];
    ``start`` (k, 3): the arcs' start points [mm], ``frames``: theirs. The same numbers as the
    one-arc box taken in Python floats (tests/test_move_table_batch.py ``_arc_box``).

    The one-arc box's ``min(lo, v)`` is v where v < lo, else lo (so the first of 0.0 and -0.0, and lo
    beside a NaN): np.where(v < lo, v, lo) is that exactly (np.minimum is not, with signed
    zeros or NaN); likewise max. A quadrant point counts only for the arcs whose sweep passes
    it."""
    rows = np.arange(len(start))
    i1, i2 = frames.axes[:, 0], frames.axes[:, 1]
    c1, c2 = frames.center[rows, i1], frames.center[rows, i2]
    lo1 = hi1 = start[rows, i1]
    lo2 = hi2 = start[rows, i2]
    theta0, sigma, angle = frames.theta0, frames.sigma, frames.angle
    theta1 = theta0 + sigma * angle
    # (cos, sin, the arcs it counts for: None for all), in the one-arc box's order
    at: list[tuple[np.ndarray | int, np.ndarray | int, np.ndarray | None]] = [
        (_map(math.cos, theta0), _map(math.sin, theta0), None),
        (_map(math.cos, theta1), _map(math.sin, theta1), None),
    ]
    full = angle >= 2 * math.pi
    # Python's float % is numpy's: fmod (exact), then + 2 pi where the signs differ
    for phi, cos_k, sin_k in _QUADRANTS:
        at.append((cos_k, sin_k, full | ((sigma * (phi - theta0)) % (2 * math.pi) <= angle)))
    for cos_a, sin_a, counts in at:
        for r in (frames.r0, frames.r1):
            v1, v2 = c1 + r * cos_a, c2 + r * sin_a
            lo1, hi1 = _take(v1 < lo1, counts, v1, lo1), _take(v1 > hi1, counts, v1, hi1)
            lo2, hi2 = _take(v2 < lo2, counts, v2, lo2), _take(v2 > hi2, counts, v2, hi2)
    lo, hi = start.copy(), start.copy()
    lo[rows, i1], hi[rows, i1] = lo1, hi1
    lo[rows, i2], hi[rows, i2] = lo2, hi2
    return lo, hi


def _take(
    better: np.ndarray, counts: np.ndarray | None, new: np.ndarray, old: np.ndarray
) -> np.ndarray:
    """``new`` where it is ``better`` (and ``counts``, unless None), else ``old``."""
    return np.where(better if counts is None else better & counts, new, old)


def _ceil(x: np.ndarray) -> np.ndarray:
    """math.ceil of every x, as integers: np.ceil rounds exactly (as every correct ceil does),
    and so does the conversion of an integral float below 2**30; past that (or inf, NaN) the
    Python ints, so the same numbers, or math.ceil's error."""
    up = np.ceil(x)
    if np.all(np.abs(up) < 2.0**30):
        return up.astype(np.intp)
    return np.array([math.ceil(v) for v in x.tolist()])


def _map(func: Callable[..., float], *columns: np.ndarray) -> np.ndarray:
    """``func`` (a ``math`` function) of the columns' values, row by row, as a float array: the
    Python floats the one-move code computes."""
    values = map(func, *(c.tolist() for c in columns))
    return np.fromiter(values, dtype=float, count=len(columns[0]))


def box_distance(tab: MoveTable, idx: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """A lower bound [mm] on the distance from pts (n, 3) to moves ``idx`` (n,): the distance
    to their boxes."""
    gap = np.maximum(np.maximum(tab.box_lo[idx] - pts, pts - tab.box_hi[idx]), 0.0)
    return np.sqrt(np.einsum("ij,ij->i", gap, gap))
