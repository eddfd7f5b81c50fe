"""Coordinate frames: program coordinates -> the machine's work frame, and back.

LinuxCNC's canonical layer places a program point p (mm) in the work frame as
``R(rotation) (p + g92) + g5x`` (emccanon.cc, rotate_and_offset_pos): the G92 offset is added in
the program frame, the XY rotation of the active G54..G59.3 system turns X/Y about that system's
origin, and the system's origin is added last. When G10 L2/L20 changes the origin or rotation
of the system in effect, rs274's interpreter re-expresses its current point as ``R p + g5x``
(without the G92 offset: convert_setup); :func:`interp_machine` and
:func:`from_interp_machine` follow that, so with a G92 offset and a new rotation the point it
believes differs from where the tool is (the next move starts at the tool). G54..G59.3, G92 and
tool offset changes keep the tool where it is.
With no offsets and no rotation every function is the identity, bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gantry_sim.controller.planes import Vec3

ZERO: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Frame:
    """The offsets in effect.

    Attributes:
        g5x: origin of the active coordinate system [mm], work frame.
        rotation_deg: XY rotation of the active system [deg], counter-clockwise seen from +Z.
        g92: G92 offset in effect [mm].
    """

    g5x: Vec3 = ZERO
    rotation_deg: float = 0.0
    g92: Vec3 = ZERO

    @property
    def identity(self) -> bool:
        return self.g5x == ZERO and self.g92 == ZERO and self.rotation_deg == 0.0


def rotate(p: Vec3, deg: float) -> Vec3:
    """``p`` turned by ``deg`` about Z (X/Y only)."""
    if deg == 0.0:
        return p
    t = math.radians(deg)
    c, s = math.cos(t), math.sin(t)
    return (p[0] * c - p[1] * s, p[0] * s + p[1] * c, p[2])


def add(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def to_work(p: Vec3, f: Frame) -> Vec3:
    """Program point [mm] -> work frame [mm] (what the machine does)."""
    if f.identity:
        return p
    return add(rotate(add(p, f.g92), f.rotation_deg), f.g5x)


def from_work(w: Vec3, f: Frame) -> Vec3:
    """Work frame point [mm] -> program point (emccanon.cc's unoffset_and_unrotate_pos)."""
    if f.identity:
        return w
    return sub(rotate(sub(w, f.g5x), -f.rotation_deg), f.g92)


def interp_machine(p: Vec3, f: Frame) -> Vec3:
    """Program point -> the interpreter's absolute point (rs274's bookkeeping)."""
    return add(add(rotate(p, f.rotation_deg), f.g92), f.g5x)


def from_interp_machine(m: Vec3, f: Frame) -> Vec3:
    """The interpreter's absolute point -> program point in frame ``f``."""
    return rotate(sub(sub(m, f.g92), f.g5x), -f.rotation_deg)


NO_OFFSETS = Frame()
