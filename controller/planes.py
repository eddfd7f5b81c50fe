"""The one table of planes and axes, shared by every stage.

Axis indices: 0 = X, 1 = Y, 2 = Z. A plane's *right-handed triple* (first, second, normal) is the
order in which counter-clockwise, seen from the positive end of the normal axis, turns the first
axis towards the second: G17 XY (normal +Z), G18 ZX (normal +Y), G19 YZ (normal +X). Reports and
plots show a plane with its axes in alphabetical order instead (XZ: X across, Z up), which for
G18 is the reverse of the right-handed order; both are given here so no module rebuilds them.
"""

from __future__ import annotations

from typing import Any, Literal

Vec3 = tuple[float, float, float]
"""A point or vector in the work frame [mm unless named otherwise]."""

Plane = Literal["XY", "XZ", "YZ"]
Direction = Literal["cw", "ccw"]

#: the three principal planes, in G17, G18, G19 order
PLANES: tuple[Plane, ...] = ("XY", "XZ", "YZ")

#: axis letters in index order
AXES = "XYZ"

#: (first, second, normal) axis indices per plane: a right-handed triple (G17 XY, G18 ZX, G19 YZ).
PLANE_AXES: dict[str, tuple[int, int, int]] = {"XY": (0, 1, 2), "XZ": (2, 0, 1), "YZ": (1, 2, 0)}

#: the plane's two axes in alphabetical order (as reports and plots show them).
PLANE_2D: dict[str, tuple[int, int]] = {"XY": (0, 1), "XZ": (0, 2), "YZ": (1, 2)}

#: the G-code word that selects each plane.
PLANE_WORDS: dict[str, str] = {"XY": "G17", "XZ": "G18", "YZ": "G19"}


def plane_of(d0: Any, d1: Any) -> Plane | None:
    """The principal plane holding both directions ``d0`` and ``d1`` (3-vectors with no
    normal-axis part, to 1e-12), the first of XY, XZ, YZ that does; None when there is none."""
    for plane in PLANES:
        n = PLANE_AXES[plane][2]
        if abs(d0[n]) <= 1e-12 and abs(d1[n]) <= 1e-12:
            return plane
    return None
