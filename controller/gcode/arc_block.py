"""One G2/G3 block -> an :class:`~controller.moves.Arc`, validated under a dialect's rules.

Numbered checks, in rs274's order (grbl first asks for an axis word of the plane): (1) a
centre is given (IJK or R, not both); (2) P is a whole number of turns; (3) no offset of the
plane's normal axis; (4) R format: a plane axis word is given, the end differs from the start,
|R| reaches the end; IJK format: the offsets the dialect requires are present, neither radius
is zero, the end lies on the arc within the dialect's tolerance (or, Marlin, the arc ends on
its circle and the interpreter adds a straight move to the end point). Lengths are compared in
the program's units, so the inch tolerances apply to G20 programs exactly as rs274 applies
them.
"""

from __future__ import annotations

import math
import struct
from dataclasses import replace
from typing import Final, Literal

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.arc_centre import (
    Point2,
    centre_from_offsets,
    centre_from_radius,
    radius_mismatch,
    swept_angle,
)
from gantry_sim.controller.gcode.dialects import Dialect
from gantry_sim.controller.gcode.state import ModalState
from gantry_sim.controller.moves import Arc, Plane, Vec3
from gantry_sim.controller.planes import AXES, PLANE_AXES

_OFFSETS = "IJK"
P_INTEGER_TOL = 0.001  # rs274: |P - round(P)| above this is "P value not an integer"
#: Marlin: an end point off the start circle by at most this [mm] ends a spiral there (within
#: this of Marlin's circle and last segment); beyond it the arc keeps its circle and a straight
#: move goes on to the end point, as Marlin's plan_arc buffers its last segment to the target.
MARLIN_SPIRAL_MM = 0.005


#: Marlin's NEAR(): per plane axis, an end within this of the start [mm] is the start (a full
#: circle)
MARLIN_NEAR_MM = 1e-6


def _f32(x: float) -> float:
    """``x`` rounded to float32 (Marlin's float: each operation below rounds its result)."""
    return float(struct.unpack("f", struct.pack("f", x))[0])


def marlin_arc_start(
    start_mm: tuple[float, float], end_mm: tuple[float, float], offset_mm: tuple[float, float]
) -> str | None:
    """How Marlin's plan_arc (gcode/motion/G2_G3.cpp) opens an arc in centre format, in its
    float32 arithmetic [mm]: "full" when the end is NEAR() the start on both plane axes (a full
    circle); "none" when ``ATAN2(cross, dot)`` of the start and end radius vectors is exactly 0,
    the end on the start's ray (an end off the circle, straight out from the start): plan_arc
    returns and nothing moves, the position staying where it was; else None. An end at the
    centre (both products 0, where Marlin's result hangs on its rounding) is left to the
    arc."""
    (sp, sq), (ep, eq) = (_f32(v) for v in start_mm), (_f32(v) for v in end_mm)
    if abs(_f32(sp - ep)) < MARLIN_NEAR_MM and abs(_f32(sq - eq)) < MARLIN_NEAR_MM:
        return "full"
    ra, rb = -_f32(offset_mm[0]), -_f32(offset_mm[1])
    rt_x, rt_y = _f32(ep - _f32(sp - ra)), _f32(eq - _f32(sq - rb))
    cross = _f32(_f32(ra * rt_y) - _f32(rb * rt_x))
    dot = _f32(_f32(ra * rt_x) + _f32(rb * rt_y))
    return "none" if cross == 0.0 and dot > 0.0 else None  # dot 0: the end at the centre


def _turns(v: dict[str, float], d: Dialect) -> int:
    """Step 2: the Arc's turns (>= 1) from the P word (grbl's arcs take no P: a G4's P on the
    line is the dwell's)."""
    if "P" not in v or not d.arc_p_allowed:
        return 1
    p = v["P"]
    whole = round(p)
    if abs(p - whole) > P_INTEGER_TOL:
        raise GcodeError(f"P value {p:g} is not an integer; P is a whole number of turns")
    if d.max_p is not None and whole > d.max_p:
        raise GcodeError(f"P value {p:g} too large; the {d.name} dialect allows P0 to P{d.max_p}")
    if d.p_adds_circles:
        if whole < 0:
            raise GcodeError(f"P value {p:g}: P counts extra full circles and must be >= 0")
        return int(whole) + 1
    if whole < 1:
        raise GcodeError(f"P value {p:g}: P is the number of turns and must be 1 or greater")
    return int(whole)


#: :func:`arc_move`'s answer for an arc its dialect runs as one straight feed move to the end
#: (:attr:`~gantry_sim.controller.gcode.dialects.Dialect.zero_radius_straight`)
STRAIGHT: Final = "straight"


def arc_move(
    line: int, v: dict[str, float], s: ModalState, end: Vec3, ccw: bool, d: Dialect
) -> Arc | Literal["straight"] | None:
    """The arc of one block, or None when the dialect makes it move nothing (g2core: an end
    equal to the start; Marlin: an end on the start's ray, which also leaves the position where
    it was), or :data:`STRAIGHT` when it runs as one straight feed move to ``end`` (grbl: a
    centre on the start).

    Args:
        line: source line.
        v: the block's letter values (program units).
        s: the modal state the block runs under (new plane, units, modes) [mm inside].
        end: programmed end point [mm].
        ccw: True for G3.
        d: the dialect's rules.
    """
    i1, i2, n = PLANE_AXES[s.plane]
    a1, a2 = AXES[i1], AXES[i2]
    o1, o2, on = _OFFSETS[i1], _OFFSETS[i2], _OFFSETS[n]
    if d.arc_needs_plane_axis_word and a1 not in v and a2 not in v:
        # grbl checks the axis words before the centre (gcode.c: errors 26, then 32)
        if not any(a in v for a in AXES):
            raise GcodeError(
                f"G2/G3 with no axis word; {d.name} needs the arc's end point in the "
                f"{s.plane} plane ({a1} and/or {a2}), also for a full circle"
            )
        raise GcodeError(
            f"arc with neither {a1} nor {a2}; {d.name} needs the arc's end point in the "
            f"{s.plane} plane, also for a full circle"
        )
    has_r = "R" in v
    has_ijk = any(o in v for o in (o1, o2) if d.off_plane_offset_ignored) or (
        not d.off_plane_offset_ignored and any(o in v for o in _OFFSETS)
    )
    # Step 1: a centre, in one format.
    if not has_r and not has_ijk:
        if d.bad_arc_moves_nothing:
            return None
        raise GcodeError(
            f"arc has no centre; give offsets {o1}/{o2} (centre format) or R (radius format)"
        )
    # grbl's radius format consumes R only: an I, J or K is an unused word (gcode.c), found
    # after the radius' own checks
    unused_offsets = has_r and d.off_plane_offset_ignored and any(o in v for o in _OFFSETS)
    if has_r and has_ijk and not unused_offsets and not d.r_wins_over_offsets:
        raise GcodeError("R mixed with I/J/K on one arc; use either R or the offsets, not both")
    turns = _turns(v, d)  # Step 2
    # Step 3: offsets must belong to the plane (grbl consumes and ignores the other one).
    if on in v and not d.off_plane_offset_ignored:
        raise GcodeError(
            f"{on} word given for an arc in the {s.plane} plane; {s.plane} arcs take "
            f"{o1} ({a1} offset) and {o2} ({a2} offset)"
        )
    unit = s.scale  # mm per program unit: tolerances below are in program units
    start = s.position
    ps = (start[i1] / unit, start[i2] / unit)
    pe = (end[i1] / unit, end[i2] / unit)
    min_r = d.min_radius_in if s.inch else d.min_radius_mm
    # Step 4: the centre.
    if has_r:
        if d.bad_arc_moves_nothing and (v["R"] == 0.0 or ps == pe):
            return None  # Marlin finds no centre offset from them
        if a1 not in v and a2 not in v:
            raise GcodeError(
                f"radius-format arc with neither {a1} nor {a2}; give the end point in the "
                f"{s.plane} plane (a full circle needs I/J/K offsets)"
            )
        if v["R"] == 0.0 and d.r_short_is_semicircle:
            raise GcodeError("R0 gives no arc; R is the arc radius, non-zero")
        if abs(v["R"]) * unit < d.min_r_word_mm:
            raise GcodeError(
                f"R{v['R']:g} is below {d.name}'s smallest arc radius, {d.min_r_word_mm:g} mm "
                "(MIN_ARC_RADIUS)"
            )
        short = _short_r_passes(ps, pe, v["R"], s.inch, d)
        centre = centre_from_radius(ps, pe, v["R"], ccw, min_r, d.r_short_is_semicircle or short)
        if short and d.end_on_start_circle:
            centre, pe = _on_r_circle(ps, pe, abs(v["R"]))
        if unused_offsets:
            raise GcodeError(
                "I/J/K word on a radius-format (R) arc: the R format uses no offset words; use "
                "either R or the offsets"
            )
    else:
        need_both = s.arc_absolute or d.both_offsets_required
        for o in (o1, o2):
            if need_both and o not in v:
                why = "absolute-centre (G90.1) arcs" if s.arc_absolute else f"{d.name} arcs"
                raise GcodeError(
                    f"{o} word missing: {why} in the {s.plane} plane need both {o1} and {o2}"
                )
        if d.bad_arc_moves_nothing and v.get(o1, 0.0) == 0.0 and v.get(o2, 0.0) == 0.0:
            return None  # Marlin: a zero arc_offset
        centre = centre_from_offsets(ps, (v.get(o1, 0.0), v.get(o2, 0.0)), s.arc_absolute)
        if d.project_end_on_arc:  # Marlin: its NEAR() full circle, and an arc of angle 0
            offset = ((centre[0] - ps[0]) * unit, (centre[1] - ps[1]) * unit)
            opening = marlin_arc_start((start[i1], start[i2]), (end[i1], end[i2]), offset)
            if opening == "none":
                return None
            if opening == "full":
                pe = ps
        r0 = math.hypot(ps[0] - centre[0], ps[1] - centre[1])
        r1 = math.hypot(pe[0] - centre[0], pe[1] - centre[1])
        if r0 < min_r and d.zero_radius_straight and d.radius_check is not None:
            _check_radius(r0, r1, s.inch, d)
            return STRAIGHT  # grbl: a centre on the start is a straight move to the end
        if r0 < min_r or r1 < min_r:
            raise GcodeError(
                f"zero-radius arc (start radius {r0:.4f}, end radius {r1:.4f}); the centre must "
                f"be at least {min_r:g} from the start and end points"
            )
        if d.project_end_on_arc and abs(r1 - r0) * unit > MARLIN_SPIRAL_MM:
            # the arc turns on its start circle to the destination's angle; the move still
            # ends at the destination (the interpreter adds Marlin's last, straight, segment)
            k = r0 / r1
            pe = (centre[0] + (pe[0] - centre[0]) * k, centre[1] + (pe[1] - centre[1]) * k)
        elif d.radius_check is not None:
            _check_radius(r0, r1, s.inch, d)
            if d.end_on_start_circle and r1 != r0:  # g2core: the end's angle on the start circle
                k = r0 / r1
                pe = (centre[0] + (pe[0] - centre[0]) * k, centre[1] + (pe[1] - centre[1]) * k)
    if not d.explicit_end_full_circle and pe == ps and (a1 in v or a2 in v):
        return None  # g2core: an explicit end point equal to the start moves nothing
    angle = swept_angle(ps, pe, centre, ccw, turns, d.zero_angle_fuzz)
    end_mm = list(end)
    end_mm[i1], end_mm[i2] = pe[0] * unit, pe[1] * unit
    if d.project_end_on_arc or d.end_on_start_circle:
        end = (end_mm[0], end_mm[1], end_mm[2])
    c = list(start)
    c[i1], c[i2] = centre[0] * unit, centre[1] * unit
    radius = math.hypot(start[i1] - c[i1], start[i2] - c[i2])
    return Arc(
        line=line,
        start=start,
        end=end,
        feed_mm_per_min=s.feed_mm_per_min,
        plane=s.plane,
        direction="ccw" if ccw else "cw",
        center=(c[0], c[1], c[2]),
        radius=radius,
        turns=turns,
        angle=angle,
    )


def _short_r_passes(ps: Point2, pe: Point2, r: float, inch: bool, d: Dialect) -> bool:
    """Whether an R shorter than half the chord is the half circle by
    ``Dialect.r_short_checked_as_centre`` (GcodeError where half the chord fails the radius
    check against R); False where R reaches or the dialect has no such rule."""
    half = math.dist(ps, pe) / 2.0
    if not d.r_short_checked_as_centre or half <= abs(r) or d.radius_check is None:
        return False
    try:
        _check_radius(abs(r), half, inch, d)
    except GcodeError as exc:
        raise GcodeError(
            f"arc radius {abs(r):.4f} too small to reach the end point (half the chord is "
            f"{half:.4f}), beyond the half circle's tolerance: {exc.message}"
        ) from None
    return True


def _on_r_circle(ps: Point2, pe: Point2, r: float) -> tuple[Point2, Point2]:
    """(centre, end) of a half circle of radius ``r`` too short for its chord as g2core runs it
    (``Dialect.end_on_start_circle``): plan_arc.cpp ``_compute_arc`` puts the centre ``r`` from
    the start towards the chord's middle, and the last segment on that circle at the end's
    angle."""
    half = math.dist(ps, pe) / 2.0
    k = r / half
    centre = (ps[0] + (pe[0] - ps[0]) / 2.0 * k, ps[1] + (pe[1] - ps[1]) / 2.0 * k)
    k = r / math.dist(pe, centre)
    return centre, (centre[0] + (pe[0] - centre[0]) * k, centre[1] + (pe[1] - centre[1]) * k)


def _check_radius(r0: float, r1: float, inch: bool, d: Dialect) -> None:
    rc = d.radius_check
    assert rc is not None
    tol, cap = (rc.abs_tol_in, rc.abs_max_in) if inch else (rc.abs_tol_mm, rc.abs_max_mm)
    abs_err, rel_err = radius_mismatch(r0, r1)
    if rc.rel_to_start:
        rel_err = abs_err / r0 if r0 > 0.0 else (math.inf if abs_err > 0.0 else 0.0)
    if abs_err > cap or (abs_err > tol and rel_err > rc.rel_tol):
        unit = "in" if inch else "mm"
        raise GcodeError(
            f"radius to end of arc ({r1:.4f}) differs from radius to start ({r0:.4f}) by "
            f"{abs_err:.4g} {unit} ({rel_err * 100:.4f} %); the {d.name} dialect allows at most "
            f"{tol:g} {unit} (or {rc.rel_tol * 100:g} % of the radius, up to {cap:g} {unit})"
        )


def from_where_it_is(arc: Arc, fuzz: float = 1e-12) -> Arc:
    """``arc`` (work frame) run from its ``start`` as LinuxCNC's canonical layer runs it when the
    tool is not where the interpreter believes: after G10 L2 R changes the XY rotation while a
    G92 offset is in effect, rs274 re-expresses its current point without the G92 offset, so
    the next arc starts at the tool's real place. It goes from there to the programmed end about
    the programmed centre: a spiral whose radius runs from the start's distance to the end's,
    its angle measured from the real start (a full turn when both ends coincide)."""
    i1, i2, n = PLANE_AXES[arc.plane]
    start, end = (arc.start[i1], arc.start[i2]), (arc.end[i1], arc.end[i2])
    centre = (arc.center[i1], arc.center[i2])
    radius = math.hypot(start[0] - centre[0], start[1] - centre[1])
    angle = swept_angle(start, end, centre, arc.direction == "ccw", arc.turns, fuzz)
    c = list(arc.center)
    c[n] = arc.start[n]
    return replace(arc, center=(c[0], c[1], c[2]), radius=radius, angle=angle)


#: where an XY rotation by a quarter turn (1, 2, 3) takes an XZ/YZ arc: (plane, direction flips)
_QUARTER_TURNS: dict[tuple[str, int], tuple[Plane, bool]] = {
    ("XZ", 1): ("YZ", True),  # normal +Y -> -X
    ("XZ", 2): ("XZ", True),  # -> -Y
    ("XZ", 3): ("YZ", False),  # -> +X
    ("YZ", 1): ("XZ", False),  # normal +X -> +Y
    ("YZ", 2): ("YZ", True),  # -> -X
    ("YZ", 3): ("XZ", True),  # -> -Y
}


def turned_plane(arc: Arc, rotation_deg: float) -> Arc:
    """An XZ/YZ arc (already placed in the work frame) of a system turned by ``rotation_deg``
    about Z: LinuxCNC's canonical layer turns the arc's plane with the system, so a quarter
    turn gives another principal plane (its direction flips when the plane's normal now points
    the other way); any other angle gives a vertical plane that is not a principal one, which
    this model's arcs cannot represent: refused (rs274 accepts it)."""
    quarters = rotation_deg / 90.0
    q = round(quarters) % 4
    if abs(quarters - round(quarters)) > 1e-9:
        raise GcodeError(
            f"a {arc.plane} arc under an XY rotation of {rotation_deg:g} degrees lies in a "
            "vertical plane turned by the rotation (LinuxCNC runs it there), which is not "
            "supported: gantry-sim's arcs lie in XY, XZ or YZ; use G17 arcs, or rotations by "
            "multiples of 90 degrees"
        )
    if q == 0:
        return arc
    plane, flip = _QUARTER_TURNS[(arc.plane, q)]
    direction = arc.direction if not flip else ("ccw" if arc.direction == "cw" else "cw")
    return replace(arc, plane=plane, direction=direction)
