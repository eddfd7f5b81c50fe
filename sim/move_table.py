"""The commanded moves laid out as arrays, one row per move in program order, for the vectorised
nearest-point search (sim/nearest.py) and the analysis (sim/contour.py).

Every derived number is computed here exactly as controller.arcs computes it for one move (the
same Python float operations in the same order), so the vectorised search gives, point for point,
the numbers the one-move functions give. Coordinates [mm], angles [rad].
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.arcs import arc_frame
from gantry_sim.controller.moves import Arc, Move, PathMove, Spline, Transition

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
    from their start."""
    m = len(moves)
    start = np.array([mv.start for mv in moves], dtype=float).reshape(m, 3)
    end = np.array([mv.end for mv in moves], dtype=float).reshape(m, 3)
    seg_d = end - start
    length2 = np.array([float(d @ d) for d in seg_d])
    axes = np.zeros((m, 3), dtype=np.intp)
    cols = {name: np.zeros(m) for name in _ARC_FIELDS}
    turns = np.zeros(m, dtype=np.intp)
    newton = np.zeros(m, dtype=bool)
    box_lo, box_hi = np.minimum(start, end), np.maximum(start, end)
    arc_rows: list[int] = []  # per arc: its row, its fields, its box
    arc_cols: list[tuple[float, ...]] = []
    arc_boxes: list[tuple[float, ...]] = []
    for j, mv in enumerate(moves):
        if isinstance(mv, Spline | Transition):
            lo_j, hi_j = _spline_box(mv)
            box_lo[j] = np.minimum(box_lo[j], lo_j)
            box_hi[j] = np.maximum(box_hi[j], hi_j)
        if not isinstance(mv, Arc):
            continue
        i1, i2, n, theta0, sigma, r0, r1, h0, h1 = arc_frame(mv)
        axes[j] = (i1, i2, n)
        s_angle = sigma * mv.angle
        dr = r1 - r0
        row = (mv.center[i1], mv.center[i2], theta0, sigma, mv.angle, s_angle, r0, dr, h0)
        arc_rows.append(j)
        arc_cols.append((*row, h1 - h0, 2.0 * dr * s_angle))
        turns[j] = math.ceil(mv.angle / (2.0 * math.pi))
        newton[j] = h1 != h0 or r1 != r0
        arc_boxes.append(_arc_box(mv, i1, i2, theta0, sigma, r0, r1))
    arcs = np.array(arc_rows, dtype=np.intp)
    is_arc = np.zeros(m, dtype=bool)
    is_arc[arcs] = True
    arc_start = start.copy()
    if arcs.size:  # the arcs' fields and boxes written at once (min and max are exact)
        for name, column in zip(_ARC_FIELDS, np.array(arc_cols).T, strict=True):
            cols[name][arcs] = column
        boxes = np.array(arc_boxes).reshape(-1, 2, 3)
        box_lo[arcs] = np.minimum(box_lo[arcs], boxes[:, 0])
        box_hi[arcs] = np.maximum(box_hi[arcs], boxes[:, 1])
        # arc_points at u = 0, the same operations vectorised
        u0 = np.zeros(arcs.size)
        theta = cols["theta0"][arcs] + cols["s_angle"][arcs] * u0
        r = cols["r0"][arcs] + cols["dr"][arcs] * u0
        rows = np.arange(arcs.size)
        at = arc_start[arcs]
        at[rows, axes[arcs, 0]] = cols["c1"][arcs] + r * np.cos(theta)
        at[rows, axes[arcs, 1]] = cols["c2"][arcs] + r * np.sin(theta)
        at[rows, axes[arcs, 2]] = cols["h0"][arcs] + cols["dh"][arcs] * u0
        arc_start[arcs] = at
    return MoveTable(
        line=np.array([mv.line for mv in moves], dtype=np.int64),
        feed=np.array([mv.kind != "rapid" for mv in moves], dtype=bool),
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
        cum_len=_cum_len(moves) if cum_len is None else np.asarray(cum_len, dtype=float),
        spline=np.array([isinstance(mv, Spline | Transition) for mv in moves], dtype=bool),
        curves=tuple(mv.curve if isinstance(mv, Spline | Transition) else None for mv in moves),
        **cols,
    )


def _cum_len(moves: Sequence[PathMove]) -> np.ndarray:
    """(len(moves) + 1,) path length [mm] before each move, and in all."""
    return np.concatenate([[0.0], np.cumsum([mv.length_mm for mv in moves])])


@dataclass(frozen=True)
class ProgramIndex:
    """What the whole-run figures need of every move of a long program, in compact arrays (a
    :class:`MoveTable` is about 300 bytes a move; this 35): per move its line, whether it is a
    feed move, an arc or a spline (:class:`~gantry_sim.sim.error_tally.ErrorTally`'s blocks), and
    the path length [mm] before each move (len + 1,), counted as :func:`move_table` counts it,
    so a table of some of its rows (``move_table(moves[a:b], index.cum_len[a:b + 1])``) has the
    whole table's numbers."""

    line: np.ndarray
    feed: np.ndarray
    arc: np.ndarray
    spline: np.ndarray
    cum_len: np.ndarray

    def __len__(self) -> int:
        return len(self.line)

    @classmethod
    def of(cls, moves: Sequence[Move], block: int = 4096) -> ProgramIndex:
        """The index of ``moves``, read ``block`` moves at a time (a long program's come from
        disk: :class:`~gantry_sim.controller.spill.SpilledList`)."""
        lines: list[int] = []
        kinds: list[str] = []
        lengths: list[float] = []
        for k in range(0, len(moves), block):
            for mv in moves[k : k + block]:
                lines.append(mv.line)
                kinds.append(mv.kind)
                lengths.append(mv.length_mm)
        kind = np.array(kinds)
        return cls(
            line=np.array(lines, dtype=np.int64),
            feed=kind != "rapid",
            arc=kind == "arc",
            spline=kind == "spline",
            cum_len=np.concatenate([[0.0], np.cumsum(np.array(lengths, dtype=float))]),
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


def _arc_box(
    arc: Arc, i1: int, i2: int, theta0: float, sigma: float, r0: float, r1: float
) -> tuple[float, ...]:
    """A box [mm] holding the arc (with its start and end: the caller's box has them too): in
    the plane, the box of the annular sector the arc sweeps between its smaller and larger
    radius -- the sector's extremes lie at its two end angles and at every quadrant angle
    (theta = k pi / 2) the sweep passes, each at either radius (a spiral's radius goes
    between r0 and r1, so a point just before the end may lie beyond the end point: the box
    of the start, end and quadrant points widened by |r1 - r0| about the start missed it by
    38 nm on an R 34 arc of 1 degree whose radius shrank by 4 um). (lo x y z, hi x y z), in
    Python floats (numpy's small arrays cost more than the arithmetic)."""
    radii = (r0, r1)
    lo, hi = list(arc.start), list(arc.start)
    c1, c2 = arc.center[i1], arc.center[i2]
    theta1 = theta0 + sigma * arc.angle
    at = [(math.cos(theta0), math.sin(theta0)), (math.cos(theta1), math.sin(theta1))]
    full = arc.angle >= 2 * math.pi
    for phi, cos_k, sin_k in _QUADRANTS:
        if full or (sigma * (phi - theta0)) % (2 * math.pi) <= arc.angle:
            at.append((cos_k, sin_k))
    for cos_a, sin_a in at:
        for r in radii:
            v1, v2 = c1 + r * cos_a, c2 + r * sin_a
            lo[i1], hi[i1] = min(lo[i1], v1), max(hi[i1], v1)
            lo[i2], hi[i2] = min(lo[i2], v2), max(hi[i2], v2)
    return (*lo, *hi)


def box_distance(tab: MoveTable, idx: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """A lower bound [mm] on the distance from pts (n, 3) to moves ``idx`` (n,): the distance
    to their boxes."""
    gap = np.maximum(np.maximum(tab.box_lo[idx] - pts, pts - tab.box_hi[idx]), 0.0)
    return np.sqrt(np.einsum("ij,ij->i", gap, gap))
