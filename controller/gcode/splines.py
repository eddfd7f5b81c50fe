"""G5, G5.1, G5.2 and G5.3: splines, as LinuxCNC 2.9's rs274 reads them (interp_convert.cc,
convert_spline and convert_nurbs; the behaviour below was measured with ``rs274 -g``).

* G5 ``I J P Q X Y`` (cubic Bezier): control points start, start + (I, J), end + (P, Q), end.
  I and J come both or neither; without them the offset is rs274's ``cycle_i, cycle_j``, which
  the previous G5 set to -(P, Q) (so consecutive G5s join smoothly) and a G87 sets to its I, J
  (0, 0 at the start: the first control point is then the start). P and Q are required.
* G5.1 ``I J X Y`` (quadratic Bezier): control points start, start + (I, J), end.
* Both: the XY plane only (G17), no Z word, not with cutter compensation, a feed (in G93 an F
  on the line). G5 and G5.1 do NOT become the modal motion: the motion mode before them stays
  (``G5 ... X5 Y0`` then ``X9`` is a G1 to X9 after a G1).
* G5.2 ``X Y P L`` ... G5.3 (NURBS): the current point (weight 1, or P when the first G5.2 line
  has P and no X Y) and every G5.2 line's X Y with its weight P are the control points; L > 3 on
  any G5.2 line sets the order (degree + 1; 3 otherwise); G5.2 is the modal motion until G5.3,
  which moves along the curve (its line) and leaves no motion mode. The tool does not move
  before G5.3, so G91 points are relative to the point where G5.2 began. X and Y are read in any
  plane (2.9 checks none) and a Z word is ignored, as in rs274.
Marlin's G5 (``BEZIER_CURVE_SUPPORT``, G5.cpp and planner_bezier.cpp: the same cubic Bezier
from the current point through current + (I, J) and target + (P, Q)): every one of I J P Q
defaults to 0 (Marlin keeps no previous P Q), the plane must be XY; a Z move along it (Marlin
interpolates Z linearly in t) is refused. Marlin has no G5.1, G5.2 or G5.3.
I, J, P, Q are offsets in program units (not affected by G90/G91 or G90.1); every control point is
placed in the work frame like X/Y (offsets, G92, XY rotation: an affine map, which maps the
curve onto the curve of the mapped control points). Z stays at the current height.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.frames import to_work
from gantry_sim.controller.gcode.state import ModalState
from gantry_sim.controller.moves import Spline, Vec3

if TYPE_CHECKING:
    import numpy as np

G5, G5_1, G5_2, G5_3 = 50, 51, 52, 53
#: the spline motion codes (G5.3 is non-modal: it ends a G5.2 curve)
SPLINE_MOTIONS = frozenset((G5, G5_1, G5_2))
SPLINE_CODES = SPLINE_MOTIONS | {G5_3}
_NAMES = {G5: "G5", G5_1: "G5.1", G5_2: "G5.2"}


@dataclass(frozen=True)
class NurbsPoints:
    """The G5.2 control points so far (program frame [mm], weight) and the order."""

    points: tuple[tuple[Vec3, float], ...] = ()
    order: int = 3


def check_spline_block(
    motion: int, v: dict[str, float], s: ModalState, comp_on: bool, marlin: bool = False
) -> None:
    """rs274's checks on a G5 or G5.1 block, in its order (``marlin``: Marlin's G5, whose
    I J P Q default to 0)."""
    if comp_on:
        raise GcodeError(
            "cannot make a spline (G5, G5.1, G5.2/G5.3) with cutter radius compensation on; "
            "G40 first"
        )
    if s.plane != "XY":
        raise GcodeError(f"splines must be in the XY plane (G17); the plane is {s.plane}")
    if marlin:
        if "Z" in v and v["Z"] * s.scale != (0.0 if s.incremental else s.position[2]):
            raise GcodeError(
                "Marlin's G5 with a Z move (Z linear in the curve's parameter) is not supported; "
                "move Z on its own line"
            )
        return
    if "Z" in v:
        raise GcodeError("splines may not have motion in Z: G5 and G5.1 move in X and Y only")
    if motion == G5_1 and not ("I" in v and "J" in v):
        raise GcodeError("G5.1 needs both I and J: the control point's offset from the start")
    if motion == G5 and ("I" in v) != ("J" in v):
        raise GcodeError(
            "G5 needs both I and J, or neither (then the previous G5's end direction is taken)"
        )
    if motion == G5 and not ("P" in v and "Q" in v):
        raise GcodeError("G5 needs both P and Q: the second control point's offset from the end")


def bezier_control_points(
    motion: int, v: dict[str, float], s: ModalState, end: Vec3, cycle_ij: tuple[float, float]
) -> tuple[list[Vec3], tuple[float, float]]:
    """Program-frame control points [mm] of a G5/G5.1 and rs274's new ``cycle_i, cycle_j``
    (program units)."""
    x0, y0, z0 = s.position
    k = s.scale
    i, j = (v["I"], v["J"]) if "I" in v else cycle_ij
    first = (x0 + i * k, y0 + j * k, z0)
    last = (end[0], end[1], z0)
    if motion == G5_1:
        return [s.position, first, last], cycle_ij
    second = (end[0] + v["P"] * k, end[1] + v["Q"] * k, z0)
    return [s.position, first, second, last], (-v["P"], -v["Q"])


def nurbs_point(
    v: dict[str, float], s: ModalState, memory: NurbsPoints, end: Vec3, restart: bool
) -> NurbsPoints:
    """One G5.2 block added to ``memory`` (``restart``: the motion mode was not G5.2, so a new
    curve begins at the current point). ``end``: the block's X Y as an end point [mm]."""
    has_x, has_y = "X" in v, "Y" in v
    p = v.get("P", -1.0)
    pts = () if restart else memory.points
    order = 3 if restart else memory.order
    if has_x != has_y:
        raise GcodeError("G5.2 needs both X and Y for a control point")
    if not has_x and p > 0 and pts:
        raise GcodeError("G5.2 P without X and Y is allowed only on the first control point line")
    if p <= 0 and pts:
        raise GcodeError("G5.2 needs a positive weight P for every control point")
    if s.feed_mode == 940 and s.feed_mm_per_min == 0.0:
        raise GcodeError("cannot make a NURBS (G5.2) with zero feed rate; set F")
    if not pts:
        weight = p if (not has_x and p > 0) else 1.0
        pts = ((s.position, weight),)
    if "L" in v and round(v["L"]) > 3:
        order = round(v["L"])  # rs274 keeps order 3 for L <= 3
    if has_x:
        pts = (*pts, ((end[0], end[1], s.position[2]), p))
    return NurbsPoints(pts, order)


def nurbs_order_check(memory: NurbsPoints) -> None:
    if len(memory.points) < memory.order:
        raise GcodeError(
            f"G5.3: a NURBS needs at least as many control points as its order L = "
            f"{memory.order}; it has {len(memory.points)}"
        )


def spline_move(
    line: int,
    code: str,
    points: list[Vec3],
    weights: list[float],
    order: int,
    s: ModalState,
    feed_mm_per_min: float,
) -> Spline:
    """The :class:`Spline` through program-frame control ``points`` placed in the work frame."""
    import numpy as np

    from gantry_sim.controller.nurbs import linuxcnc_knots  # numpy: only where splines are

    work = (s.work, *(to_work(p, s.frame) for p in points[1:]))
    knots = linuxcnc_knots(len(points), order)
    _check_weights(np.array(weights), knots, order - 1)
    return Spline(
        line=line,
        start=s.work,
        end=work[-1],
        feed_mm_per_min=feed_mm_per_min,
        code=code,
        control_points=work,
        weights=tuple(float(w) for w in weights),
        degree=order - 1,
        knots=knots,
    )


def _check_weights(weights: np.ndarray, knots: tuple[float, ...], degree: int) -> None:
    """rs274 takes weight -1 for the first G5.2 point when its line has no P: the curve is
    finite only while the weighted sum W(t) stays positive (sampled densely)."""
    if (weights > 0).all():
        return
    import numpy as np

    from gantry_sim.controller.nurbs import BSpline

    w = BSpline(weights[:, None], np.array(knots), degree)
    t = np.linspace(knots[0], knots[-1], 64 * len(weights) + 1)
    if not (w(t)[:, 0] > 1e-9 * np.abs(weights).max()).all():
        raise GcodeError(
            "this NURBS's weights make it pass through infinity (its weighted sum of basis "
            "functions reaches zero); give every G5.2 point a positive weight P, the first one too"
        )


def spline_block(
    line: int,
    code: int,
    v: dict[str, float],
    s: ModalState,
    end: Vec3,
    cycle_ij: tuple[float, float],
    nurbs: NurbsPoints,
    motion_before: int | None,
    line_motion: int | None,
) -> tuple[Spline, tuple[float, float], Vec3]:
    """The move of a G5, G5.1 or G5.3 block: (move, rs274's new cycle_i/j, program-frame end)."""
    if code == G5_3:
        if line_motion is not None and line_motion != G5_2:
            raise GcodeError("between G5.2 and G5.3 only G5.2 codes may stand; put G5.3 alone")
        if motion_before != G5_2:
            raise GcodeError("G5.3 without G5.2 first: G5.3 ends a NURBS begun with G5.2")
        nurbs_order_check(nurbs)
        points = [p for p, _ in nurbs.points]
        weights = [w for _, w in nurbs.points]
        move = spline_move(line, "G5.2", points, weights, nurbs.order, s, s.feed_mm_per_min)
        return move, cycle_ij, points[-1]
    points, ij = bezier_control_points(code, v, s, end, cycle_ij)
    order = 4 if code == G5 else 3
    move = spline_move(line, _NAMES[code], points, [1.0] * order, order, s, s.feed_mm_per_min)
    return move, ij, points[-1]
