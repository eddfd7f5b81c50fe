"""LinuxCNC's polar coordinates: ``@`` radius and ``^`` angle [degrees] in the XY plane.

Measured with ``rs274 -g``: in G90 the point is (@ cos ^, @ sin ^) about the program origin, a
missing word keeping the current point's radius or angle; in G91 both are added to the current
point's polar radius and angle. They are allowed only while the plane in effect before their
line is G17 (a G17 on the same line is too late, as rs274 checks them on reading the line),
Z may be given, and X or Y beside a polar word is an error. At the origin (X0 Y0) the angle is
undefined: in G90 ^ must be given, and in G91 rs274 refuses the move.
"""

from __future__ import annotations

import math

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.state import ModalState
from gantry_sim.controller.planes import Vec3


def polar_end_point(v: dict[str, float], s: ModalState) -> Vec3:
    """The block's end point [mm] from its @/^ words (program units) and Z."""
    for letter in "XY":
        if letter in v:
            raise GcodeError(
                f"cannot give both polar coordinates (@, ^) and an {letter} word on one line"
            )
    x, y, z = s.position
    if x == 0.0 and y == 0.0 and (s.incremental or "^" not in v):
        raise GcodeError(
            "incremental motion with polar coordinates is indeterminate at the origin (X0 Y0); "
            "move off it first or use G90 with an angle (^)"
            if s.incremental
            else "polar coordinates at the origin (X0 Y0) need the angle: give ^ (degrees) with @"
        )
    r = math.hypot(x, y) / s.scale
    angle = math.degrees(math.atan2(y, x))
    if s.incremental:
        r += v.get("@", 0.0)
        angle += v.get("^", 0.0)
    else:
        r = v.get("@", r)
        angle = v.get("^", angle)
    if "Z" in v:
        z = z + v["Z"] * s.scale if s.incremental else v["Z"] * s.scale
    t = math.radians(angle)
    return (r * math.cos(t) * s.scale, r * math.sin(t) * s.scale, z)


def check_polar_plane(v: dict[str, float], before: ModalState) -> None:
    """Polar words only while the plane in effect before the line is XY (rs274: "Cannot use
    polar coordinate except in G17 plane", checked before the line's own G17)."""
    if ("@" in v or "^" in v) and before.plane != "XY":
        raise GcodeError(
            f"polar coordinates (@, ^) only in the XY plane: the plane in effect is "
            f"{before.plane}; select G17 on a line before this one"
        )
