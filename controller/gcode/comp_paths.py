"""The compensated path of one G0/G1/G2/G3 block (rs274's convert_straight_comp1/2 and
convert_arc_comp1/2); the state and queue are in :mod:`cutter_comp`. Program frame, mm.

Angles [rad], counter-clockwise from +X; ``turn`` > 0 is counter-clockwise (G3).
"""

from __future__ import annotations

import math

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.cutter_comp import (
    _EQUAL,
    _GOUGE,
    _SMALL,
    CutterComp,
    _Held,
    find_turn,
)
from gantry_sim.controller.gcode.frames import Frame
from gantry_sim.controller.moves import Dwell, Move, Vec3

_HALF = math.pi / 2


def _inside(side: str, turn: int) -> bool:
    """rs274 TOOL_INSIDE_ARC: the tool runs on the arc's inner side."""
    return (side == "left" and turn > 0) or (side == "right" and turn < 0)


def straight(
    c: CutterComp, rapid: bool, line: int, p: Vec3, feed: float, frame: Frame
) -> list[Move | Dwell]:
    """A compensated G0/G1 to the programmed point ``p``; returns the moves it releases."""
    kind = "rapid" if rapid else "linear"
    r, side = c.radius, c.side or "left"
    cx, cy, _ = c.current
    px, py, pz = p
    out: list[Move | Dwell] = []
    if c.first:
        if math.hypot(px - cx, py - cy) <= r:
            raise GcodeError(
                "length of cutter compensation entry move is not greater than the tool radius"
            )
        alpha = math.atan2(py - cy, px - cx) + (_HALF if side == "left" else -_HALF)
        end = (px + r * math.cos(alpha), py + r * math.sin(alpha), pz)
        c.endpoint = (cx, cy)
        c._hold(_Held(kind, line, list(end), feed, frame, (math.cos(alpha), math.sin(alpha))))
        c.first = False
        c.current, c.programmed = end, p
        return out
    opx, opy, _ = c.programmed
    end = (cx, cy, pz)
    if px == opx and py == opy:  # no XY motion: held like any other move
        c._hold(_Held(kind, line, list(end), feed, frame))
    else:
        theta = math.atan2(cy - opy, cx - opx)
        alpha = math.atan2(py - opy, px - opx)
        if side == "left":
            if theta < alpha:
                theta += 2 * math.pi
            beta, gamma = theta - alpha - _HALF, _HALF
        else:
            if alpha < theta:
                alpha += 2 * math.pi
            beta, gamma = alpha - theta - _HALF, -_HALF
        end = (px + r * math.cos(alpha + gamma), py + r * math.sin(alpha + gamma), pz)
        mid = (opx + r * math.cos(alpha + gamma), opy + r * math.sin(alpha + gamma))
        front = c.queue[0] if c.queue else None
        front_arc = front is not None and front.kind == "arc"
        concave = beta < -_SMALL or beta > math.pi + _SMALL
        if not concave and beta > math.pi - _SMALL and front_arc:
            assert front is not None
            concave = (side == "right" and front.turn > 0) or (side == "left" and front.turn < 0)
        if not concave and beta > _SMALL:  # outside corner: round it about the corner
            out += c.flush_at(cx, cy)
            if rapid:
                c._hold(_Held("rapid", line, [mid[0], mid[1], c.current[2]], feed, frame))
            else:
                turn = -1 if side == "left" else 1
                c._hold(
                    _Held(
                        "arc",
                        line,
                        [mid[0], mid[1], c.current[2]],
                        feed,
                        frame,
                        (0.0, 0.0),
                        (opx, opy),
                        turn,
                    )
                )
            out += c.release()
            c.endpoint = mid
        elif concave:
            if not front_arc:
                half = (beta + math.pi) / 2.0
                if half == 0.0:
                    raise GcodeError("zero degree inside corner is invalid for cutter compensation")
                retreat = r / math.tan(half)
                mx = cx + retreat * math.cos(theta + gamma)
                my = cy + retreat * math.sin(theta + gamma)
            else:
                assert front is not None
                mx, my = _line_after_arc(front, side, r, (opx, opy), (px, py))
            out += c.flush_at(mx, my)
        else:
            out += c.release()
            c.endpoint = (cx, cy)
        c._hold(_Held(kind, line, list(end), feed, frame, (px - opx, py - opy)))
    c.current, c.programmed = end, p
    return out


def _line_after_arc(
    prev: _Held, side: str, r: float, op: tuple[float, float], p: tuple[float, float]
) -> tuple[float, float]:
    """Where the tool leaves an arc for a line at an inside corner."""
    pcx, pcy = prev.center
    oldrad = math.hypot(pcy - prev.end[1], pcx - prev.end[0])
    base = math.atan2(p[1] - op[1], p[0] - op[0])
    theta = base + _HALF if prev.turn > 0 else base - _HALF
    phi = math.atan2(pcy - op[1], pcx - op[0])
    inside = _inside(side, prev.turn)
    uncomp = oldrad + r if inside else oldrad - r
    d = uncomp * math.cos(theta - phi)
    ratio = (d - r if inside else d + r) / oldrad
    if ratio > 1.0 or ratio < -1.0:
        raise GcodeError(
            "arc to straight motion makes a corner the compensated tool can't fit in without "
            "gouging"
        )
    sign = (-1 if prev.turn > 0 else 1) if inside else (1 if prev.turn > 0 else -1)
    angle = sign * math.acos(ratio) + theta + math.pi
    return pcx + oldrad * math.cos(angle), pcy + oldrad * math.sin(angle)


def arc(
    c: CutterComp,
    line: int,
    end_p: Vec3,
    center: tuple[float, float],
    turn: int,
    r_format: bool,
    feed: float,
    frame: Frame,
) -> list[Move | Dwell]:
    """A compensated G2/G3 (programmed ``center`` and signed ``turn``) to ``end_p``."""
    r, side = c.radius, c.side or "left"
    cx, cy, cz = c.current
    ex, ey, ez = end_p
    ccw = turn > 0
    out: list[Move | Dwell] = []
    arc_r = math.hypot(center[0] - ex, center[1] - ey)
    tool_inside = (side == "left" and ccw) or (side == "right" and not ccw)
    if c.first:
        if r_format:
            raise GcodeError(
                "an R-format arc as the cutter compensation entry move is not supported; "
                "enter with a line or an I/J arc"
            )
        if math.hypot(ex - cx, ey - cy) <= r:
            raise GcodeError(
                "radius of cutter compensation entry arc is not greater than the tool radius"
            )
        if math.hypot(center[0] - cx, center[1] - cy) <= r and tool_inside:
            raise GcodeError("tool radius not less than arc radius with cutter compensation")
        if _inside(side, turn):
            gamma = math.atan2(center[1] - ey, center[0] - ex)
        else:
            gamma = math.atan2(ey - center[1], ex - center[0])
        c.first = False
        c.programmed = end_p
        nx, ny = ex + r * math.cos(gamma), ey + r * math.sin(gamma)
        b_len = math.hypot(cy - ny, cx - nx) / 2.0
        ab = math.atan2(center[1] - ny, center[0] - nx)
        a_ang = math.atan2(cy - ny, cx - nx) - ab
        if abs(math.cos(a_ang)) < _EQUAL:
            raise GcodeError("tool radius not less than arc radius with cutter compensation")
        c_len = b_len / math.cos(a_ang)
        ncx, ncy = nx + c_len * math.cos(ab), ny + c_len * math.sin(ab)
        sweep = find_turn(cx, cy, ncx, ncy, turn, nx, ny)
        c._hold(_Held("arc", line, [nx, ny, ez], feed, frame, (0.0, 0.0), (ncx, ncy), turn, sweep))
        c.current = (nx, ny, ez)
        return out
    opx, opy, _ = c.programmed
    theta = math.atan2(cy - opy, cx - opx)
    theta = theta - _HALF if side == "left" else theta + _HALF
    delta = math.atan2(center[1] - opy, center[0] - opx)
    alpha = delta - _HALF if ccw else delta + _HALF
    beta = theta - alpha if side == "left" else alpha - theta
    if beta > 1.5 * math.pi:
        beta -= 2 * math.pi
    elif beta < -_HALF:
        beta += 2 * math.pi
    if tool_inside:
        gamma = math.atan2(center[1] - ey, center[0] - ex)
        if arc_r <= r:
            raise GcodeError("tool radius not less than arc radius with cutter compensation")
    else:
        gamma = math.atan2(ey - center[1], ex - center[0])
        delta += math.pi
    nx, ny = ex + r * math.cos(gamma), ey + r * math.sin(gamma)
    sweep = find_turn(opx, opy, center[0], center[1], turn, ex, ey)
    main = _Held("arc", line, [nx, ny, ez], feed, frame, (0.0, 0.0), center, turn, sweep)
    inside = _inside(side, turn)
    if beta < -_SMALL or beta > math.pi + _SMALL or (abs(beta - math.pi) < _SMALL and not inside):
        front = c.queue[0] if c.queue else None
        if front is None or front.kind != "arc":
            cy_ = arc_r * math.sin(beta - _HALF)
            dist = arc_r - r if inside else arc_r + r
            ratio = (cy_ + r if inside else cy_ - r) / dist
            if ratio > 1.0 or ratio < -1.0:
                raise GcodeError(f"arc move in concave corner {_GOUGE}")
            if inside:
                angle = theta + math.asin(ratio) if turn > 0 else theta - math.asin(ratio)
            else:
                angle = (
                    theta + math.pi - math.asin(ratio)
                    if turn > 0
                    else theta + math.pi + math.asin(ratio)
                )
            mx, my = center[0] + dist * math.cos(angle), center[1] + dist * math.sin(angle)
        else:
            mx, my = _arc_after_arc(front, side, r, arc_r, center, turn, inside)
        out += c.flush_at(mx, my)
        c._hold(main)
    elif beta > _SMALL:  # outside corner: an arc about the corner, then the arc
        mid = (opx + r * math.cos(delta), opy + r * math.sin(delta))
        out += c.release()
        turn_c = -1 if side == "left" else 1
        c._hold(
            _Held("arc", line, [mid[0], mid[1], cz], feed, frame, (0.0, 0.0), (opx, opy), turn_c)
        )
        out += c.release()
        c.endpoint = mid
        c._hold(main)
    else:
        out += c.release()
        c.endpoint = (cx, cy)
        c._hold(main)
    c.current, c.programmed = (nx, ny, ez), end_p
    return out


def _arc_after_arc(
    prev: _Held,
    side: str,
    r: float,
    arc_r: float,
    center: tuple[float, float],
    turn: int,
    inside: bool,
) -> tuple[float, float]:
    pcx, pcy = prev.center
    oldrad = math.hypot(pcy - prev.end[1], pcx - prev.end[0])
    newrad = arc_r - r if inside else arc_r + r
    arc_cc = math.hypot(pcy - center[1], pcx - center[0])
    if oldrad == 0.0 or arc_cc == 0.0:
        raise GcodeError("arc to arc motion is invalid because the arcs have the same center")
    a = (oldrad**2 + arc_cc**2 - newrad**2) / (2 * oldrad * arc_cc)
    if a > 1.0 or a < -1.0:
        raise GcodeError(
            "arc to arc motion makes a corner the compensated tool can't fit in without gouging"
        )
    pull = math.acos(a)
    cc_dir = math.atan2(center[1] - pcy, center[0] - pcx)
    if _inside(side, prev.turn):
        d = cc_dir + pull if turn > 0 else cc_dir - pull
    else:
        d = cc_dir - pull if turn > 0 else cc_dir + pull
    return pcx + oldrad * math.cos(d), pcy + oldrad * math.sin(d)
