"""Coordinate-system codes: G54..G59.3, G10 L2/L20, the G92 family, G28/G30 and their storage.

Offsets live where rs274 keeps them, in the numbered parameters (G54 at #5221.., rotation at
#5230, G92 at #5211.., G28 at #5161.., G30 at #5181..; stored in mm here, read in program units).
The offsets in effect are the state's :class:`~gantry_sim.controller.gcode.frames.Frame`. When an
offset in effect changes, the current point is re-expressed so that the tool does not move, the
way rs274 does it (see :mod:`gantry_sim.controller.gcode.frames`).
"""

from __future__ import annotations

import math
from dataclasses import replace

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.frames import (
    Frame,
    from_interp_machine,
    from_work,
    interp_machine,
    rotate,
    sub,
    to_work,
)
from gantry_sim.controller.gcode.parameters import (
    COORD_INDEX,
    G28_HOME,
    G30_HOME,
    G92_ENABLED,
    G92_OFFSET,
    Parameters,
    g5x_base,
)
from gantry_sim.controller.gcode.state import ModalState
from gantry_sim.controller.planes import Vec3

#: coordinate-system codes (tenths) -> index 1..9
SYSTEMS: dict[int, int] = {540: 1, 550: 2, 560: 3, 570: 4, 580: 5, 590: 6, 591: 7, 592: 8, 593: 9}
_AXES = "XYZ"


def _vec(values: list[float]) -> Vec3:
    return (values[0], values[1], values[2])


def reframe(s: ModalState, frame: Frame) -> ModalState:
    """Switch to ``frame`` keeping the tool where it is (rs274's bookkeeping)."""
    m = interp_machine(s.position, s.frame)
    return replace(s, frame=frame, position=from_interp_machine(m, frame))


def system_frame(p: Parameters, index: int, g92: Vec3) -> Frame:
    base = g5x_base(index)
    return Frame(_vec([p.mm(base + i) for i in range(3)]), p.mm(base + 9), g92)


def select_system(s: ModalState, p: Parameters, index: int) -> ModalState:
    """G54..G59.3: make system ``index`` the one in effect; the tool stays where it is
    (rs274's find_current_in_system: the point through every offset and back)."""
    p.numbered[COORD_INDEX] = float(index)
    if index == s.coord_index:
        return s
    frame = system_frame(p, index, s.frame.g92)
    position = from_work(to_work(s.position, s.frame), frame)
    return replace(s, frame=frame, position=position, coord_index=index)


def rs274_system_number(p_word: float) -> tuple[bool, int]:
    """(accepted, the system number) of G10 L2/L20's P as rs274 reads it: its check refuses a
    P more than 0.0001 above the whole number nearest to it (check_g_codes), and the system
    is P + 0.0001 truncated (convert_setup): P1.5 is system 1, P1.3 is refused."""
    nearest = math.trunc(p_word + 0.5) if p_word >= 0 else math.trunc(p_word - 0.5)
    used = math.trunc(p_word + 0.0001)
    return (p_word + 0.0001) - nearest <= 0.0002 and 0 <= nearest <= 9, used


def g10(
    s: ModalState,
    p: Parameters,
    v: dict[str, float],
    systems: int = 9,
    rs274_p: bool = True,
    p_truncated: bool = False,
    g2core: bool = False,
) -> ModalState:
    """G10 L2 (set a system's origin, R its XY rotation) and L20 (origin so the point reads v).
    ``rs274_p``: P is read as rs274 reads it (:func:`rs274_system_number`); else P must be a
    whole number. ``p_truncated`` (grbl's gcode.c): P is cut to its whole part and is 0 (the
    system in effect) when absent; only a G10 with neither L nor P is refused for a missing
    word. ``g2core`` (canonical_machine.cpp ``cm_set_g10_data``): R is ignored (it is read as
    an arc radius), and L20 leaves the G92 offset out ("Should L20 take into account G92
    offsets?")."""
    if g2core:
        v = {k: value for k, value in v.items() if k != "R"}
    if p_truncated and "L" not in v and "P" in v:
        raise GcodeError("G10 without L is not supported; use L2 or L20")
    if "L" not in v:
        raise GcodeError("G10 needs an L word: L2 or L20 (coordinate systems)")
    if "P" not in v and not p_truncated:
        raise GcodeError(
            "G10 needs a P word: the coordinate system, 1 (G54) .. 9 (G59.3), 0 current"
        )
    if p_truncated and not any(a in v for a in _AXES):
        raise GcodeError(f"G10 L{v['L']:g} with no axis word: give the axes to set")
    p_value = v.get("P", 0.0)
    level, number = round(v["L"]), round(p_value)
    if level not in (2, 20):
        raise GcodeError(f"G10 L{v['L']:g} is not supported; use L2 or L20")
    if rs274_p and ("I" in v or "J" in v):  # rs274's check_g_codes (I J are L1's tool words)
        raise GcodeError(f"I J words not allowed with G10 L{level}: it sets a coordinate system")
    whole = abs(p_value - number) <= 1e-4
    if p_truncated:
        whole, number = True, math.trunc(p_value)
    elif rs274_p:
        whole, number = rs274_system_number(p_value)
    if not whole or not 0 <= number <= systems:
        raise GcodeError(
            f"G10 P{p_value:g}: P must be one of the {systems} coordinate systems 1..{systems} "
            "or 0 (the current)"
        )
    if p_truncated and level == 2 and "R" in v:  # grbl's gcode.c, after P; an L20's R is unused
        raise GcodeError("G10 L2 R (a rotated coordinate system) is not supported")
    index = number or s.coord_index
    base = g5x_base(index)
    scale = s.scale
    if level == 2:
        for i, a in enumerate(_AXES):
            if a in v:
                p.numbered[base + i] = v[a] * scale
        if "R" in v:
            p.numbered[base + 9] = v["R"]
    else:
        if "R" in v and not p_truncated:  # grbl: an unused word, checked last (error 36)
            raise GcodeError("G10 L20 takes no R word; set the rotation with G10 L2 R")
        # rs274: the current point in system ``index`` (find_current_in_system), and the
        # origin that makes it read v there, X/Y turned by the system's rotation
        origin = (p.mm(base), p.mm(base + 1), p.mm(base + 2))
        r = p.numbered.get(base + 9, 0.0)
        g92 = (0.0, 0.0, 0.0) if g2core else _param_g92(p)
        c = sub(rotate(sub(to_work(s.position, s.frame), origin), -r), g92)
        want = tuple(v[a] * scale if a in v else c[i] for i, a in enumerate(_AXES))
        old_xy, new_xy = rotate(c, r), rotate((want[0], want[1], want[2]), r)
        for i, a in enumerate(_AXES):
            if a in v or i < 2:  # rs274 sets X and Y together (a turned X moves both)
                p.numbered[base + i] = old_xy[i] + origin[i] - new_xy[i]
    if index != s.coord_index:
        return s
    return reframe(s, system_frame(p, index, s.frame.g92))


def g92(s: ModalState, p: Parameters, code: int, v: dict[str, float]) -> ModalState:
    """G92 (offset so the point reads v), G92.1 (clear and zero), G92.2 (clear), G92.3 (restore),
    G52 (520: the offset itself is v; LinuxCNC 2.9 keeps it as G92's, in #5211.. with #5210)."""
    offset = list(s.frame.g92)
    if code in (920, 520):
        if not any(a in v for a in "XYZABC"):  # (A/B/C words reach here only as 0: no-ops)
            raise GcodeError(
                f"{'G92' if code == 920 else 'G52'} needs at least one axis word"
                + (": the value the current point gets" if code == 920 else ": the offset")
            )
        for i, a in enumerate(_AXES):
            if a in v:
                value = v[a] * s.scale
                offset[i] = value if code == 520 else s.position[i] + s.frame.g92[i] - value
                p.numbered[G92_OFFSET + i] = offset[i]
        p.numbered[G92_ENABLED] = 1.0
    elif code == 921:
        offset = [0.0, 0.0, 0.0]
        for i in range(3):
            p.numbered[G92_OFFSET + i] = 0.0
        p.numbered[G92_ENABLED] = 0.0
    elif code == 922:
        offset = [0.0, 0.0, 0.0]
        p.numbered[G92_ENABLED] = 0.0
    else:
        offset = [p.mm(G92_OFFSET + i) for i in range(3)]
        p.numbered[G92_ENABLED] = 1.0
    frame = replace(s.frame, g92=_vec(offset))
    # rs274 shifts the current point by the change of offset alone (no rotation involved).
    pos = _vec([s.position[i] + s.frame.g92[i] - offset[i] for i in range(3)])
    return replace(s, frame=frame, position=pos)


def _param_g92(p: Parameters) -> Vec3:
    """The G92 offset rs274 takes out of a point expressed in a system: #5211.. when #5210."""
    if not p.numbered.get(G92_ENABLED, 0.0):
        return (0.0, 0.0, 0.0)
    return _vec([p.mm(G92_OFFSET + i) for i in range(3)])


def spindle_point(s: ModalState) -> Vec3:
    """Where the interpreter has the spindle (current point, every offset, the tool's too)."""
    w = to_work(s.position, s.frame)
    t = s.tool_offset_mm
    return (w[0] + t[0], w[1] + t[1], w[2] + t[2])


def store_home(s: ModalState, p: Parameters, code: int) -> None:
    """G28.1 / G30.1: store the current absolute point (rs274's convert_savehome)."""
    base = G28_HOME if code == 281 else G30_HOME
    point = spindle_point(s)
    for i in range(3):
        p.numbered[base + i] = point[i]


def home_point(s: ModalState, p: Parameters, code: int, axes: set[str]) -> Vec3:
    """G28 / G30: the stored point in program coordinates for ``axes`` (all when empty), the
    other axes where they are (rs274's convert_home: find_relative of every axis, then the
    named ones taken). Stored points are the spindle's, as G53: the tool offset comes off."""
    base = G28_HOME if code == 280 else G30_HOME
    stored = _vec([p.mm(base + i) for i in range(3)])
    home = from_work(sub(stored, s.tool_offset_mm), s.frame)
    return _vec([home[i] if not axes or a in axes else s.position[i] for i, a in enumerate(_AXES)])
