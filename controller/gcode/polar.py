"""LinuxCNC's polar coordinates: ``@`` radius and ``^`` angle [degrees] in the XY plane.

Measured with ``rs274 -g``: in G90 the point is (@ cos ^, @ sin ^) about the program origin, a
missing word keeping the current point's radius or angle; in G91 both are added to the current
point's polar radius and angle. The plane selection does not matter (always X/Y), Z may be given,
and X or Y beside a polar word is an error.
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
