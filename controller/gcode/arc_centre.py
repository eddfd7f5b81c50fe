"""Arc centres from IJK offsets or a radius R, and the swept angle, in plane coordinates.

All functions work on the plane's (first, second) coordinates (see controller.arcs.PLANE_AXES),
in any one length unit. Geometry first:

* Centre format: the centre is start + (i, j) (G91.1) or (i, j) itself (G90.1).
* Radius format: the centre lies on the perpendicular bisector of the chord start->end, at
  distance h = sqrt(r^2 - (d/2)^2) from the chord's midpoint, d the chord length. A positive R
  picks the centre that makes the arc at most a half circle, a negative R the other one; seen
  along the chord, a cw (G2) short arc has its centre on the right, a ccw (G3) one on the left.
* Swept angle: the polar angle from start to end about the centre, measured in the direction of
  travel, in (0, 2*pi]; an angle within ``fuzz`` of zero (end == start up to rounding) is a
  full circle; each extra turn adds 2*pi.
"""

from __future__ import annotations

import math

from gantry_sim.controller.errors import GcodeError

Point2 = tuple[float, float]


def centre_from_offsets(start: Point2, offsets: Point2, absolute: bool) -> Point2:
    """Centre [units] from IJK-style offsets: absolute (G90.1) or relative to ``start`` (G91.1)."""
    if absolute:
        return offsets
    return (start[0] + offsets[0], start[1] + offsets[1])


def centre_from_radius(
    start: Point2, end: Point2, radius: float, ccw: bool, short_tol: float, clamp: bool
) -> Point2:
    """Centre [units] of the arc of signed radius ``radius`` from ``start`` to ``end``.

    Args:
        start: start point in the plane [units].
        end: end point in the plane [units]; must differ from ``start``.
        radius: R word [units]; negative asks for the arc longer than a half circle.
        ccw: True for G3.
        short_tol: how far |R| may fall short of half the chord before it is an error [units];
            within it the arc is the exact half circle.
        clamp: any shortfall gives the half circle (Marlin) instead of an error.

    Raises:
        GcodeError: end equals start, or |R| too small to reach the end point.
    """
    if end == start:
        raise GcodeError(
            "radius-format arc ends where it starts, so its centre is undefined; give an end "
            "point that differs from the current point, or use I/J/K for a full circle"
        )
    abs_r = abs(radius)
    mid = ((start[0] + end[0]) / 2.0, (start[1] + end[1]) / 2.0)
    half = math.hypot(end[0] - mid[0], end[1] - mid[1])
    if half - abs_r > short_tol and not clamp:
        raise GcodeError(
            f"arc radius {abs_r:.4f} too small to reach the end point (half the chord is "
            f"{half:.4f}); |R| must be at least half the distance from start to end"
        )
    h = 0.0 if half >= abs_r else math.sqrt(abs_r * abs_r - half * half)
    chord_dir = math.atan2(end[1] - start[1], end[0] - start[0])
    # Right of the chord for a short cw arc or a long ccw one; left otherwise.
    right = (not ccw and radius > 0) or (ccw and radius < 0)
    side = chord_dir - math.pi / 2 if right else chord_dir + math.pi / 2
    return (mid[0] + h * math.cos(side), mid[1] + h * math.sin(side))


def swept_angle(
    start: Point2, end: Point2, centre: Point2, ccw: bool, turns: int, fuzz: float
) -> float:
    """Total swept angle [rad] > 0 from ``start`` to ``end`` about ``centre``.

    Args:
        turns: full or partial revolutions (LinuxCNC's P, >= 1): adds (turns - 1) * 2*pi.
        fuzz: a partial angle up to this [rad] counts as a full circle (plus the partial).
    """
    a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
    a1 = math.atan2(end[1] - centre[1], end[0] - centre[0])
    partial = (a1 - a0) if ccw else (a0 - a1)
    partial = math.fmod(partial, 2.0 * math.pi)
    if partial < 0.0:
        partial += 2.0 * math.pi
    if partial <= fuzz:
        partial += 2.0 * math.pi
    return partial + 2.0 * math.pi * (turns - 1)


def radius_mismatch(r_start: float, r_end: float) -> tuple[float, float]:
    """(absolute difference [units], relative difference to the larger radius [-])."""
    abs_err = abs(r_start - r_end)
    larger = max(r_start, r_end)
    return abs_err, abs_err / larger if larger > 0.0 else 0.0
