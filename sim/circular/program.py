"""G-code for circular tests: the ballbar program and the per-radius tune program.

The machine moves at rapid to the start point P, on the circle 180 degrees before the measured
start S, and runs, per direction, three arc blocks on the same circle (centre C, radius R):

    lead-in   a 180-degree run-in arc from P to S: the machine accelerates from rest to the
              feed on the circle itself, so the measured block starts at full speed with the
              circle's own curvature (an arc of another radius joining the circle would make
              the planner slow down at the junction, as any curvature jump does);
    circle    one full 360-degree circle from S back to S (the measured block; written with
              centre offsets and no end point, a full circle in LinuxCNC and g2core alike);
    lead-out  a 180-degree run-out arc from S to P, where the machine stops.

Every block is tangent to the next (same circle, same sense). S lies at 45 degrees between the
plane's axes so that the four quadrant crossings (where one axis reverses) lie inside the data
arc, 45 degrees from its ends; P at 225 degrees. After the last direction the machine returns
to C at rapid. Valid LinuxCNC G-code (G21 mm, G90 absolute, G94 feed per minute); comments
explain each block, for users who run it on a real machine. This is the run-in / run-out
layout that ballbar software uses (180-degree overshoot arcs around a 360-degree data arc).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from gantry_sim.controller.errors import ConfigError
from gantry_sim.controller.planes import AXES, PLANE_AXES, PLANE_WORDS, Vec3
from gantry_sim.controller.planner.magnitudes import MAX_COORDINATE_MM

_OFFSET_LETTER = "IJK"
#: angle of the measured circle's start S about the centre [deg]
START_DEG = 45.0
#: travel of the run-in and of the run-out arc [deg]
LEAD_DEG = 180.0
#: least feed [mm/min]: the program writes numbers to 6 decimals (F1e-9 was written F0 and
#: refused as "zero feed rate" on --radius), and this keeps F within 0.1 % of what was asked
MIN_FEED_MM_PER_MIN = 0.001


@dataclass(frozen=True)
class CircleTestProgram:
    """A circular-test program and where its blocks are.

    Attributes:
        text: the G-code.
        plane: "XY", "XZ" or "YZ".
        radius_mm: circle radius [mm].
        feed_mm_per_min: programmed feed [mm/min].
        centre_mm: circle centre, work coordinates [mm].
        directions: the directions run, in program order ("cw" G2, "ccw" G3).
        lines: direction -> (lead-in line, circle line, lead-out line), 1-based.
    """

    text: str
    plane: str
    radius_mm: float
    feed_mm_per_min: float
    centre_mm: Vec3
    directions: tuple[str, ...]
    lines: dict[str, tuple[int, int, int]]

    def circle_line(self, direction: str) -> int:
        """1-based line of the measured full-circle block of ``direction``."""
        return self.lines[direction][1]


def _num(v: float) -> str:
    s = f"{v:.6f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _point(centre: Vec3, plane: str, radius: float, angle_rad: float) -> list[float]:
    i1, i2, _ = PLANE_AXES[plane]
    p = list(centre)
    p[i1] += radius * math.cos(angle_rad)
    p[i2] += radius * math.sin(angle_rad)
    return [round(c, 6) for c in p]


def _arc_block(
    g: str, plane: str, start: Sequence[float], end: Sequence[float] | None, centre: Sequence[float]
) -> str:
    """An arc block: end axis words (omitted for a full circle) and in-plane centre offsets."""
    i1, i2, _ = PLANE_AXES[plane]
    axes = sorted((i1, i2))
    words = [g]
    if end is not None:
        words += [f"{AXES[a]}{_num(end[a])}" for a in axes]
    words += [f"{_OFFSET_LETTER[a]}{_num(centre[a] - start[a])}" for a in axes]
    return " ".join(words)


def circle_test_program(
    plane: str = "XY",
    radius_mm: float = 50.0,
    feed_mm_per_min: float = 1000.0,
    directions: tuple[str, ...] = ("ccw", "cw"),
    centre_mm: Vec3 = (0.0, 0.0, 0.0),
) -> CircleTestProgram:
    """Write the circular-test program (see the module docstring).

    Args:
        plane: "XY" (G17), "XZ" (G18) or "YZ" (G19).
        radius_mm: circle radius [mm], > 0.
        feed_mm_per_min: feed along the path [mm/min], >= :data:`MIN_FEED_MM_PER_MIN`.
        directions: "ccw" (G3) and/or "cw" (G2), run in this order, each returning to the centre.
        centre_mm: circle centre in work coordinates [mm].

    Raises:
        ConfigError: an invalid plane, radius, feed, centre or direction (the message says
            what is allowed, and names the option: ``--radius``, ``--centre``...).
    """
    if plane not in PLANE_WORDS:
        raise ConfigError(f"plane {plane!r} is not one of XY, XZ, YZ", file="--plane")
    if not (math.isfinite(radius_mm) and radius_mm > 0):
        raise ConfigError(f"radius {radius_mm} mm must be a finite number > 0", file="--radius")
    if not (math.isfinite(feed_mm_per_min) and feed_mm_per_min >= MIN_FEED_MM_PER_MIN):
        raise ConfigError(
            f"feed {feed_mm_per_min:g} mm/min must be a finite number >= "
            f"{MIN_FEED_MM_PER_MIN:g} mm/min",
            file="--feed",
        )
    if not (radius_mm <= MAX_COORDINATE_MM):
        raise ConfigError(
            f"radius {radius_mm:g} mm: at most {MAX_COORDINATE_MM:g} mm (no machine travels "
            "that far)",
            file="--radius",
        )
    if not all(math.isfinite(v) and abs(v) <= MAX_COORDINATE_MM for v in centre_mm):
        shown_centre = ",".join(f"{v:g}" for v in centre_mm)
        raise ConfigError(
            f"centre {shown_centre} mm: each coordinate must be a finite number within "
            f"+-{MAX_COORDINATE_MM:g} mm (no machine travels that far)",
            file="--centre",
        )
    bad = [d for d in directions if d not in ("cw", "ccw")]
    if bad or not directions:
        raise ConfigError(f"directions {directions!r}: each must be 'cw' or 'ccw'")
    cx, cy, cz = (round(v, 6) for v in centre_mm)
    c: Vec3 = (cx, cy, cz)
    theta_s = math.radians(START_DEG)
    s = _point(c, plane, radius_mm, theta_s)
    p = _point(c, plane, radius_mm, theta_s + math.pi)
    axes = sorted(PLANE_AXES[plane][:2])
    at_c = " ".join(f"{AXES[a]}{_num(c[a])}" for a in range(3))
    at_p = " ".join(f"{AXES[a]}{_num(p[a])}" for a in axes)
    out = [
        "(gantry-sim circular test, ISO 230-4 style: what a ballbar measures)",
        f"(plane {plane}, radius {_num(radius_mm)} mm, feed {_num(feed_mm_per_min)} mm/min,"
        f" centre {at_c})",
        "(per direction, all on the circle and in one sense: a 180 deg run-in arc from rest,)",
        "(one full circle - the measured block, at full feed - and a 180 deg run-out arc)",
        f"G21 G90 G94 {PLANE_WORDS[plane]} (mm, absolute, feed per minute, {plane} plane)",
        f"G0 {at_c} (the centre of the circle)",
        f"G0 {at_p} (the start point on the circle, 180 deg before the measured start)",
    ]
    lines: dict[str, tuple[int, int, int]] = {}
    for d in directions:
        g = "G3" if d == "ccw" else "G2"
        sense = "counter-clockwise" if d == "ccw" else "clockwise"
        out.append(f"({sense}, {g}, seen from the positive end of the plane's normal axis)")
        lead_in = len(out) + 1
        out.append(f"{_arc_block(g, plane, p, s, c)} F{_num(feed_mm_per_min)} (run-in, 180 deg)")
        out.append(f"{_arc_block(g, plane, s, None, c)} (measured circle, 360 deg)")
        out.append(f"{_arc_block(g, plane, s, p, c)} (run-out, 180 deg, stop)")
        lines[d] = (lead_in, lead_in + 1, lead_in + 2)
    out.append(f"G0 {at_c} (back to the centre)")
    out.append("M2 (end of program)")
    return CircleTestProgram(
        text="\n".join(out) + "\n",
        plane=plane,
        radius_mm=float(radius_mm),
        feed_mm_per_min=float(feed_mm_per_min),
        centre_mm=(float(c[0]), float(c[1]), float(c[2])),
        directions=tuple(directions),
        lines=lines,
    )
