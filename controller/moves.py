"""The interpreter's output: exact moves, each with the source line that commanded it (and
:class:`Transition`, the planner's G2 transition, which lies only on the path it follows).

All positions are program (work) coordinates [mm]; feeds are [mm/min] along the 3-D path (for a
helix, along the helix). Moves are frozen value objects; ``to_json`` gives the exact
``gantry parse`` contract (see README, "gantry parse").
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

from gantry_sim.controller.planes import PLANE_AXES, Direction, Plane, Vec3

__all__ = [
    "Arc",
    "Direction",
    "Dwell",
    "Event",
    "Limits",
    "Linear",
    "Move",
    "PathControl",
    "PathMove",
    "Plane",
    "Rapid",
    "Spline",
    "Stop",
    "Transition",
    "Vec3",
]


@dataclass(frozen=True)
class PathControl:
    """The path control mode in effect for a move (LinuxCNC's G61, G61.1, G64 P Q). It governs
    the junction at the END of the move (as LinuxCNC's termination condition does).

    Attributes:
        mode: "G61" (exact path: exact stops at corners, tangent junctions keep their speed),
            "G61.1" (exact stop at every junction) or "G64" (blend corners).
        tolerance_mm: G64 P: how far the reference may leave the programmed path at a junction
            [mm]; None: the machine file's ``[path] tolerance_mm``.
        naive_cam_mm: G64 Q: consecutive straight feed moves within this distance of one line
            are merged into one [mm]; None or 0: no merging.
    """

    mode: str
    tolerance_mm: float | None = None
    naive_cam_mm: float | None = None


def _vec(v: Vec3) -> list[float]:
    return [float(c) for c in v]


def _motion_json(m: Rapid | Linear | Arc | Spline | Transition) -> dict:
    """The keys every motion's JSON starts with (``gantry parse``, CONTRACTS.md), and
    ``"file"`` where the line is a subroutine file's (``line`` counts in that file)."""
    out = {"line": m.line, "kind": m.kind, "start": _vec(m.start), "end": _vec(m.end)}
    file = getattr(m, "file", None)
    if file is not None:
        out["file"] = file
    return out


def _feed_json(m: Linear | Arc | Spline | Transition) -> dict:
    """:func:`_motion_json` and the feed [mm/min] of a feed move (and, where an extruder is
    followed, whether it extrudes)."""
    out = _motion_json(m) | {"feed": float(m.feed_mm_per_min)}
    extrudes = getattr(m, "extrudes", None)
    if extrudes is not None:
        out["extrudes"] = bool(extrudes)
    return out


@dataclass(frozen=True)
class Rapid:
    """G0: a straight traverse at the machine's rapid speed.

    Attributes:
        line: 1-based source line.
        start: start point [mm].
        end: end point [mm].
        path: the path control mode set by the program (None: none set, the machine file's
            default applies); it governs the junction at the rapid's end, as a feed move's
            does (LinuxCNC blends a corner between two rapids in G64).
        file: the subroutine file whose line this is (an ``o<name> call`` or ``M98`` found
            on the subroutine path); None: the program's own line.
    """

    line: int
    start: Vec3
    end: Vec3
    path: PathControl | None = None
    file: str | None = None

    kind = "rapid"

    @property
    def length_mm(self) -> float:
        """Straight-line length [mm]."""
        return math.dist(self.start, self.end)

    def to_json(self) -> dict:
        return _motion_json(self)


@dataclass(frozen=True)
class Linear:
    """G1: a straight feed move.

    Attributes:
        line: 1-based source line.
        start: start point [mm].
        end: end point [mm].
        feed_mm_per_min: programmed speed along the path [mm/min].
        path: the path control mode set by the program (None: none set, the machine file's
            default applies).
        extrudes: Marlin: whether the line's E word moves the extruder (Marlin plans such a
            move with the print acceleration, M204 P, and one that does not with the travel
            acceleration, M204 T); None where no extruder is followed (the other dialects).
        file: the subroutine file whose line this is (an ``o<name> call`` or ``M98`` found
            on the subroutine path); None: the program's own line.
    """

    line: int
    start: Vec3
    end: Vec3
    feed_mm_per_min: float
    path: PathControl | None = None
    extrudes: bool | None = None
    file: str | None = None

    kind = "linear"

    @property
    def length_mm(self) -> float:
        """Straight-line length [mm]."""
        return math.dist(self.start, self.end)

    def to_json(self) -> dict:
        return _feed_json(self)


@dataclass(frozen=True)
class Arc:
    """G2/G3: a circular arc or helix in one of the three principal planes.

    Geometry (see :mod:`gantry_sim.controller.arcs`): the in-plane radius goes linearly from ``radius`` (at
    ``start``) to the end point's distance from ``center`` (equal for an exact arc; LinuxCNC accepts
    a small mismatch and the path is then a gentle spiral), the polar angle sweeps ``angle``
    radians in ``direction``, and the normal-axis coordinate goes linearly from start to end.

    Attributes:
        line: 1-based source line.
        start: start point [mm].
        end: end point [mm], exactly as programmed (after dialect rules).
        feed_mm_per_min: programmed speed along the 3-D path [mm/min].
        plane: "XY" (G17), "XZ" (G18) or "YZ" (G19).
        direction: "cw" (G2) or "ccw" (G3), seen from the positive end of the plane's normal axis.
        center: arc centre [mm]; its normal-axis coordinate equals ``start``'s.
        radius: distance from ``center`` to ``start`` in the plane [mm], > 0.
        turns: the P word (1 when absent).
        angle: total swept angle [rad], > 0 (a full circle is 2*pi; P2 on a half circle is 3*pi).
        path: the path control mode set by the program (None: the machine file's default).
        extrudes: Marlin: whether the line's E word moves the extruder (Marlin plans such a
            move with the print acceleration, M204 P, and one that does not with the travel
            acceleration, M204 T); None where no extruder is followed (the other dialects).
        file: the subroutine file whose line this is (an ``o<name> call`` or ``M98`` found
            on the subroutine path); None: the program's own line.
    """

    line: int
    start: Vec3
    end: Vec3
    feed_mm_per_min: float
    plane: Plane
    direction: Direction
    center: Vec3
    radius: float
    turns: int
    angle: float
    path: PathControl | None = None
    extrudes: bool | None = None
    file: str | None = None

    kind = "arc"

    @property
    def length_mm(self) -> float:
        """Path length of the arc, helix or slight spiral [mm] (mean in-plane radius)."""
        i1, i2, n = PLANE_AXES[self.plane]
        r1 = math.hypot(self.end[i1] - self.center[i1], self.end[i2] - self.center[i2])
        return math.hypot(0.5 * (self.radius + r1) * self.angle, self.end[n] - self.start[n])

    def to_json(self) -> dict:
        return _feed_json(self) | {
            "plane": self.plane,
            "direction": self.direction,
            "center": _vec(self.center),
            "radius": float(self.radius),
            "turns": int(self.turns),
            "angle": float(self.angle),
        }


@dataclass(frozen=True)
class Spline:
    """G5 (cubic Bezier), G5.1 (quadratic Bezier) or G5.2/G5.3 (NURBS): a spline in the XY
    plane at constant Z, exactly as LinuxCNC defines it (every one is a NURBS curve; see
    :mod:`gantry_sim.controller.nurbs`).

    G5 ``I J P Q X Y``: control points start, start + (I, J), end + (P, Q), end; without I J,
    the first offset is the previous G5's -(P, Q). G5.1 ``I J X Y``: start, start + (I, J), end.
    G5.2 ``X Y P L`` lines and G5.3: the start and the listed points with their weights P, of
    order L (degree L - 1), on LinuxCNC's uniform clamped knots.

    Attributes:
        line: 1-based source line (G5.2/G5.3: the G5.3 line, where LinuxCNC moves).
        start: start point [mm] (the first control point).
        end: end point [mm] (the last control point).
        feed_mm_per_min: programmed speed along the path [mm/min].
        code: "G5", "G5.1" or "G5.2".
        control_points: every control point [mm], work frame, start and end included.
        weights: one weight per control point (> 0; 1 for G5 and G5.1).
        degree: polynomial degree (3 for G5, 2 for G5.1, L - 1 for G5.2).
        knots: the knot vector (len(control_points) + degree + 1 values).
        path: the path control mode set by the program (None: the machine file's default).
        extrudes: Marlin: whether the line's E word moves the extruder (Marlin plans such a
            move with the print acceleration, M204 P, and one that does not with the travel
            acceleration, M204 T); None where no extruder is followed (the other dialects).
        file: the subroutine file whose line this is (an ``o<name> call`` or ``M98`` found
            on the subroutine path); None: the program's own line.
    """

    line: int
    start: Vec3
    end: Vec3
    feed_mm_per_min: float
    code: str
    control_points: tuple[Vec3, ...]
    weights: tuple[float, ...]
    degree: int
    knots: tuple[float, ...]
    path: PathControl | None = None
    extrudes: bool | None = None
    file: str | None = None

    kind = "spline"

    @property
    def curve(self):  # -> SplineCurve (imported here: moves.py stays free of numpy)
        """The exact curve by arc length (:class:`~gantry_sim.controller.spline_curve.SplineCurve`),
        built once per move."""
        cached = _CURVES.get(self)
        if cached is None:
            from gantry_sim.controller.spline_curve import spline_curve

            cached = _CURVES[self] = spline_curve(self)
        return cached

    @property
    def length_mm(self) -> float:
        """Arc length of the curve [mm] (Gauss-Legendre quadrature, see spline_curve.py)."""
        return self.curve.length_mm

    def to_json(self) -> dict:
        return _feed_json(self) | {
            "code": self.code,
            "control_points": [_vec(p) for p in self.control_points],
            "weights": [float(w) for w in self.weights],
            "degree": int(self.degree),
            "knots": [float(k) for k in self.knots],
        }


#: one curve per distinct spline move (a move is a frozen value; equal moves share a curve)
_CURVES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

Move = Rapid | Linear | Arc | Spline


@dataclass(frozen=True, slots=True)
class Transition:
    """A G2-continuous transition the planner puts in place of a G64 tangent junction whose
    curvature jumps (never the interpreter's: it lies only on the path the planner follows,
    ``Plan.path_moves``; see :mod:`gantry_sim.controller.planner.transition`): a quintic
    Bezier curve from a point of the first move to a point of the second, matching position,
    unit tangent and curvature vector of each there. Compact (slots; the curve's numbers one
    packed buffer): the planner holds one per transition of the whole program.

    Attributes:
        line: the source line of the junction's first move.
        start: start point [mm] (a point of the first move; the first control point).
        end: end point [mm] (a point of the second move; the last control point).
        feed_mm_per_min: the smaller feed of the two moves [mm/min].
        plane: the principal plane both moves, and so the curve, lie in.
        row: the curve's numbers, packed as float64 (its control points, power coefficients,
            arc lengths, bounds and end frames: :meth:`QuinticCurve.rows
            <gantry_sim.controller.quintic_curve.QuinticCurve.rows>`).
        path: the path control mode of the first move (None: the machine file's default).
    """

    line: int
    start: Vec3
    end: Vec3
    feed_mm_per_min: float
    plane: Plane
    row: bytes
    path: PathControl | None = None

    kind = "transition"

    def __reduce__(self) -> tuple:
        """Pickled as its constructor's arguments: a slotted dataclass' default pickling calls
        ``dataclasses.fields`` per object (4.0 us to pickle and 3.7 to unpickle a transition,
        1.2 and 1.5 this way). A long run's path moves are pickled and read back several
        times: spilled to disk by the planner, read per streamed range, and sent to the
        analysis worker."""
        return (
            Transition,
            (
                self.line,
                self.start,
                self.end,
                self.feed_mm_per_min,
                self.plane,
                self.row,
                self.path,
            ),
        )

    @property
    def curve(self):  # -> QuinticCurve (imported here: moves.py stays free of numpy)
        """The exact curve (:class:`~gantry_sim.controller.quintic_curve.QuinticCurve`: points,
        derivatives, arc length, bounds), read from :attr:`row` without copying it."""
        from gantry_sim.controller.quintic_curve import QuinticCurve

        return QuinticCurve.from_row(self.row)

    @property
    def control_points(self) -> tuple[Vec3, ...]:
        """The six Bezier control points [mm], start and end included."""
        return tuple((p[0], p[1], p[2]) for p in self.curve.control_points.tolist())

    @property
    def length_mm(self) -> float:
        """Arc length of the curve [mm] (Gauss-Legendre quadrature, see quintic_curve.py)."""
        return self.curve.length_mm

    def to_json(self) -> dict:
        return _feed_json(self) | {
            "plane": self.plane,
            "control_points": [_vec(p) for p in self.control_points],
        }


#: What the planner's path is made of: the program's moves, blend arcs (Arc) and transitions.
PathMove = Move | Transition


@dataclass(frozen=True)
class Dwell:
    """G4: the machine stops exactly at ``position`` and waits ``seconds`` (not a motion).

    Attributes:
        line: 1-based source line.
        position: where the tool waits [mm], work frame.
        seconds: dwell time [s], >= 0 (LinuxCNC's P, a negative one waiting no time, as its
            DWELL(-3) does; Marlin's P [ms] and S [s] converted).
        file: the subroutine file whose line this is (an ``o<name> call`` or ``M98`` found
            on the subroutine path); None: the program's own line.
    """

    line: int
    position: Vec3
    seconds: float
    file: str | None = None

    kind = "dwell"

    def to_json(self) -> dict:
        return {
            "line": self.line,
            "kind": self.kind,
            "position": _vec(self.position),
            "seconds": float(self.seconds),
        }


@dataclass(frozen=True)
class Stop:
    """M0 (program stop), M1 (optional stop) or M60 (pallet shuttle and stop): an exact stop
    at ``position`` that waits for the operator (no time is modelled for the wait).

    Attributes:
        line: 1-based source line.
        position: where the tool stops [mm], work frame.
        code: "M0", "M1" or "M60".
        file: the subroutine file whose line this is (an ``o<name> call`` or ``M98`` found
            on the subroutine path); None: the program's own line.
    """

    line: int
    position: Vec3
    code: str
    file: str | None = None

    kind = "stop"

    def to_json(self) -> dict:
        return {
            "line": self.line,
            "kind": self.kind,
            "position": _vec(self.position),
            "code": self.code,
        }


@dataclass(frozen=True)
class Limits:
    """Marlin M201/M203/M204/M205: the planner's limits change from this line on, as Marlin
    applies them. ``values`` are the line's words as given (M201: max acceleration per axis
    [mm/s^2]; M203: max feedrate per axis [mm/s]; M204: P print, R retract, T travel
    acceleration [mm/s^2]; M205: X/Y/Z jerk [mm/s], J junction deviation [mm], S/T minimum
    feedrates [mm/s], B minimum segment time [us]).

    Attributes:
        file: the subroutine file whose line this is (an ``o<name> call`` or ``M98`` found
            on the subroutine path); None: the program's own line.
    """

    line: int
    code: str
    values: tuple[tuple[str, float], ...]
    file: str | None = None

    kind = "limits"

    def to_json(self) -> dict:
        return {
            "line": self.line,
            "kind": self.kind,
            "code": self.code,
            "values": {k: float(v) for k, v in self.values},
        }


Event = Dwell | Stop | Limits
