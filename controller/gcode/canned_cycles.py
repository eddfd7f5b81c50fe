"""LinuxCNC's canned cycles G73, G74, G81-G89: the rapid and feed moves rs274 makes for them.

Semantics as LinuxCNC 2.9's rs274 runs them (interp_cycles.cc, read for reference and checked
program by program against ``rs274 -g``, tests/data/rs274/programs/cyc_*.ngc and gen_cyc_*):

- The plane selects the axes: G17 drills along Z at X/Y, G18 along Y at Z/X, G19 along X at Y/Z
  ("aa, bb" in the plane, "cc" the drilling axis).
- The first cycle of a series remembers the drilling-axis level it started from (the initial
  level); the series ends with any motion that is not a cycle (or G80). G98 retracts to the
  initial level (or R when that is higher), G99 (rs274's default) to R.
- G90: X/Y (and R, Z) are absolute; G91: X/Y are increments applied on every L repeat, R is an
  increment from the initial level and Z an increment from R.
- Before each repeat: a rapid in the plane (at the current level on the first repeat when it is
  above R, else at the clearance level), then down to R. If the initial level is below R, the
  tool first rapids straight up to R.
- Pecks (G73, G83) back off by 0.254 mm (0.010 inch, rs274's default peck clearance).
- G74/G84 (tapping) move at the programmed feed (the spindle synchronisation is not modelled);
  in the YZ and XZ planes rs274 swaps the coordinates of their two feed moves, and so does this.
- Dwells (P, seconds) are :class:`Dwell` events, G88's program stop (manual retract) a
  :class:`Stop` event with code "G88", when events are asked for.

Words are in program units; everything here is computed in program units (as rs274 does, so the
peck loop ends on the same step) and scaled to mm [x ``scale``] only when a move is made.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.frames import Frame, to_work
from gantry_sim.controller.moves import Dwell, Event, Linear, Move, Rapid, Stop, Vec3

#: cycle motion codes (tenths)
CYCLES = frozenset((730, 740, 810, 820, 830, 840, 850, 860, 870, 880, 890))
#: (aa, bb, cc) axis indices per plane: two in-plane axes, then the drilling axis.
_AXES = {"XY": (0, 1, 2), "YZ": (1, 2, 0), "XZ": (2, 0, 1)}
_DWELL_CYCLES = (820, 860, 880, 890)
_PECK_CLEARANCE_INCH = 0.010
#: the current point comes back from mm with rounding noise; rs274 keeps program units exactly
_EPS = 1e-9
#: The most holes x pecks one canned-cycle block expands into. rs274 has no bound, but
#: ``G81 L99999999`` (3e8 moves) or a 50 mm G73 in pecks of Q0.00001 (5e6 pecks) would take
#: hours and gigabytes to expand and plan; refused at once instead, naming the line.
MAX_CYCLE_STEPS = 1_000_000


@dataclass(frozen=True)
class CycleMemory:
    """What a cycle leaves for the next (rs274's cycle_* settings), program units.

    ``initial``: the drilling-axis level the series started from (None outside a series).
    """

    motion: int | None = None
    r: float = 0.0
    cc: float = 0.0
    p: float = 0.0
    q: float = 0.0
    ijk: tuple[float, float, float] = (0.0, 0.0, 0.0)
    initial: float | None = None
    retract_to_r: bool = True


def _name(code: int) -> str:
    return f"G{code // 10}"


class _Cycle:
    """One cycle block's moves; collects them so an error raised mid-cycle can keep them."""

    def __init__(self, line: int, plane: str, scale: float, frame: Frame, feed: float) -> None:
        self.line, self.scale, self.frame, self.feed = line, scale, frame, feed
        self.a, self.b, self.c = _AXES[plane]
        self.items: list[Move | Event] = []
        self.events: list[tuple[int, Event]] = []
        self.prog: Vec3 = (0.0, 0.0, 0.0)
        self.work: Vec3 = (0.0, 0.0, 0.0)

    def point(self, aa: float, bb: float, cc: float) -> Vec3:
        p = [0.0, 0.0, 0.0]
        p[self.a], p[self.b], p[self.c] = aa * self.scale, bb * self.scale, cc * self.scale
        return (p[0], p[1], p[2])

    def go(self, rapid: bool, end: Vec3) -> None:
        work = to_work(end, self.frame)
        if rapid:
            self.items.append(Rapid(self.line, self.work, work))
        else:
            self.items.append(Linear(self.line, self.work, work, self.feed))
        self.prog, self.work = end, work

    def traverse(self, aa: float, bb: float, cc: float) -> None:
        self.go(True, self.point(aa, bb, cc))

    def feed_to(self, aa: float, bb: float, cc: float) -> None:
        self.go(False, self.point(aa, bb, cc))

    def fail(self, message: str) -> GcodeError:
        exc = GcodeError(message)
        exc.partial = [m for m in self.items if isinstance(m, Rapid | Linear)]  # type: ignore[attr-defined]
        return exc


def run_cycle(
    line: int,
    motion: int,
    v: dict[str, float],
    *,
    position: Vec3,
    work: Vec3,
    plane: str,
    scale: float,
    incremental: bool,
    frame: Frame,
    feed_mm_per_min: float,
    inverse_time: bool,
    spindle: int,
    memory: CycleMemory,
) -> tuple[list[Move | Event], Vec3, CycleMemory]:
    """One canned-cycle block -> (moves and events, end point [mm, program frame], memory).

    ``v``: the block's words (program units); ``position``: current point [mm], program frame;
    ``spindle``: 1 clockwise, -1 counter-clockwise, 0 stopped.
    """
    if feed_mm_per_min == 0.0:
        raise GcodeError(f"cannot feed with zero feed rate in {_name(motion)}; set F first")
    if inverse_time:
        raise GcodeError("cannot use inverse time feed (G93) with canned cycles; use G94")
    same = memory.motion == motion
    if "R" in v:
        r_word = v["R"]
    elif same:
        r_word = memory.r
    else:
        raise GcodeError(f"R clearance plane unspecified in canned cycle {_name(motion)}")
    repeats = 1 if "L" not in v else round(v["L"])  # whole already: words.whole_number
    if repeats < 0:
        raise GcodeError(f"negative L word used (L{repeats}); L is the number of repeats, >= 1")
    if "L" in v and repeats == 0:
        raise GcodeError("cannot do zero repeats of a canned cycle (L0)")
    cyc = _Cycle(line, plane, scale, frame, feed_mm_per_min)
    letters = "XYZ"
    la, lb, lc = letters[cyc.a], letters[cyc.b], letters[cyc.c]
    if not same and lc not in v:
        raise GcodeError(
            f"{lc} value unspecified in {plane} plane canned cycle: the first "
            f"{_name(motion)} of a series needs the hole's bottom {lc}"
        )
    cc_word = v[lc] if lc in v else memory.cc
    cur = [c / scale for c in position]
    current_cc = cur[cyc.c]
    initial = memory.initial if memory.initial is not None else current_cc
    old_cc = initial
    a_inc = b_inc = r_inc = t_inc = 0.0
    polar = plane == "XY" and ("@" in v or "^" in v)
    if not incremental:
        r, cc = r_word, cc_word
        aa, bb = v.get(la, cur[cyc.a]), v.get(lb, cur[cyc.b])
        if polar:
            radius = v.get("@", math.hypot(cur[1], cur[0]))
            theta = math.radians(v["^"]) if "^" in v else math.atan2(cur[1], cur[0])
            aa, bb = radius * math.cos(theta), radius * math.sin(theta)
    else:
        a_inc, b_inc = v.get(la, 0.0), v.get(lb, 0.0)
        if polar:
            r_inc, t_inc = v.get("@", 0.0), math.radians(v.get("^", 0.0))
        r = r_word + old_cc
        cc = r + cc_word
        aa, bb = cur[cyc.a], cur[cyc.b]
    if r < cc:
        raise GcodeError(
            f"R less than {lc} in canned cycle in the {plane} plane: R {r:g} lies below the "
            f"hole's bottom {lc} {cc:g}"
        )
    cyc.prog, cyc.work = position, work
    if old_cc < r - _EPS:  # below R: straight up to R first
        up = list(cur)
        up[cyc.c] = r
        cyc.go(True, (up[0] * scale, up[1] * scale, up[2] * scale))
        old_cc = current_cc = r
    try:  # rs274 checks the cycle's own words after that first move
        p, q, ijk = _words(motion, v, memory, same)
    except GcodeError as exc:
        raise cyc.fail(exc.message) from None
    pecks = math.ceil((r - cc) / q) if motion in (730, 830) and q > 0.0 else 1
    if repeats * pecks > MAX_CYCLE_STEPS:
        raise cyc.fail(
            f"{_name(motion)} would make {repeats:,} hole(s) of {pecks:,} peck(s) each; "
            f"gantry-sim expands a canned cycle into at most {MAX_CYCLE_STEPS:,} holes x pecks "
            "(each a few moves to plan): lower L, or raise Q"
        )
    clear = r if memory.retract_to_r else old_cc
    for rep in range(repeats, 0, -1):
        aa, bb = aa + a_inc, bb + b_inc
        if r_inc or t_inc:
            if aa == 0.0 and bb == 0.0:
                raise cyc.fail(
                    "incremental motion with polar coordinates is indeterminate at the origin"
                )
            radius, theta = math.hypot(bb, aa) + r_inc, math.atan2(bb, aa) + t_inc
            aa, bb = radius * math.cos(theta), radius * math.sin(theta)
        if rep == repeats and current_cc > r + _EPS:
            cyc.traverse(aa, bb, current_cc)
            cyc.traverse(aa, bb, r)
        else:
            cyc.traverse(aa, bb, clear)
            if clear > r:
                cyc.traverse(aa, bb, r)
        _body(cyc, motion, aa, bb, r, clear, cc, p, q, ijk, incremental, spindle)
    end = cyc.point(aa, bb, clear) if repeats > 0 else position
    new = CycleMemory(motion, r_word, cc_word, p, q, ijk, initial, memory.retract_to_r)
    return cyc.items, end, new


def _words(
    motion: int, v: dict[str, float], memory: CycleMemory, same: bool
) -> tuple[float, float, tuple[float, float, float]]:
    """The cycle's P (dwell [s]), Q (peck, program units) and I/J/K (G87), checked.

    rs274 marks a missing P or Q with the value -1, so P-1 and Q-1 count as missing."""
    v = {k: x for k, x in v.items() if not (k in "PQ" and x == -1.0)}
    if motion in _DWELL_CYCLES and not same and "P" not in v:
        raise GcodeError(f"dwell time P word missing with {_name(motion)} (seconds)")
    if motion in (730, 830) and not same and "Q" not in v:
        raise GcodeError(f"Q word missing with {_name(motion)}: the peck depth")
    if motion == 870 and not same:
        for letter in "IJK":
            if letter not in v:
                raise GcodeError(f"{letter} word missing with G87 (back boring offset/height)")
    p = v.get("P", memory.p)
    q = v.get("Q", memory.q)
    ijk = (v.get("I", memory.ijk[0]), v.get("J", memory.ijk[1]), v.get("K", memory.ijk[2]))
    return p, q, ijk


def _body(
    cyc: _Cycle,
    motion: int,
    aa: float,
    bb: float,
    r: float,
    clear: float,
    bottom: float,
    p: float,
    q: float,
    ijk: tuple[float, float, float],
    incremental: bool,
    spindle: int,
) -> None:
    """The cycle proper, from (aa, bb, r) (rs274's convert_cycle_gNN)."""
    name = _name(motion)
    if motion in (860, 870, 880) and spindle == 0:
        raise cyc.fail(f"spindle not turning in {name}; start it with M3 or M4 first")
    if motion in (730, 830):
        if q <= 0.0:
            raise cyc.fail(f"negative or zero Q value used in {name}; Q is the peck depth, > 0")
        back = _PECK_CLEARANCE_INCH * 25.4 / cyc.scale
        depth = r - q
        while depth > bottom:
            cyc.feed_to(aa, bb, depth)
            if motion == 830:
                cyc.traverse(aa, bb, r)
            cyc.traverse(aa, bb, depth + back)
            depth -= q
        cyc.feed_to(aa, bb, bottom)
        cyc.traverse(aa, bb, clear)
    elif motion in (810, 820, 860):
        cyc.feed_to(aa, bb, bottom)
        _dwell(cyc, motion, p)
        cyc.traverse(aa, bb, clear)
    elif motion in (850, 890):
        cyc.feed_to(aa, bb, bottom)
        _dwell(cyc, motion, p)
        if motion == 850:
            cyc.feed_to(aa, bb, r)
            cyc.traverse(aa, bb, clear)
        else:
            cyc.feed_to(aa, bb, clear)
    elif motion == 880:
        cyc.feed_to(aa, bb, bottom)
        _dwell(cyc, motion, p)
        cyc.items.append(Stop(cyc.line, cyc.work, "G88"))  # the operator retracts by hand
    elif motion == 870:
        _back_bore(cyc, aa, bb, r, clear, bottom, ijk, incremental)
    else:
        _tap(cyc, motion, aa, bb, clear, bottom, p, spindle)


def _dwell(cyc: _Cycle, motion: int, p: float) -> None:
    if motion != 810 and motion != 850:  # a negative P waits no time (rs274: DWELL(-0.5))
        cyc.items.append(Dwell(cyc.line, cyc.work, max(0.0, p)))


def _back_bore(
    cyc: _Cycle,
    aa: float,
    bb: float,
    r: float,
    clear: float,
    bottom: float,
    ijk: tuple[float, float, float],
    incremental: bool,
) -> None:
    """G87: I/J/K name the offset (in-plane) and the counterbore's top (drilling axis)."""
    i, j, k = ijk
    off_a, off_b, middle = {(0, 1, 2): (i, j, k), (1, 2, 0): (j, k, i), (2, 0, 1): (k, i, j)}[
        (cyc.a, cyc.b, cyc.c)
    ]
    if incremental:
        middle = bottom + middle
    oa, ob = aa + off_a, bb + off_b
    cyc.traverse(oa, ob, r)
    cyc.traverse(oa, ob, bottom)
    cyc.traverse(aa, bb, bottom)
    cyc.feed_to(aa, bb, middle)
    cyc.feed_to(aa, bb, bottom)
    cyc.traverse(oa, ob, bottom)
    cyc.traverse(oa, ob, clear)
    cyc.traverse(aa, bb, clear)


def _tap(
    cyc: _Cycle,
    motion: int,
    aa: float,
    bb: float,
    clear: float,
    bottom: float,
    p: float,
    spindle: int,
) -> None:
    """G74 (left hand) / G84 (right hand) tapping: feed in, reverse, dwell P, feed out."""
    name = _name(motion)
    if spindle == 0:
        raise cyc.fail(f"spindle not turning in {name}; start it with M3 (G84) or M4 (G74)")
    if motion == 740 and spindle > 0:
        raise cyc.fail("spindle turning clockwise in G74 (left-hand tapping needs M4)")
    if motion == 840 and spindle < 0:
        raise cyc.fail("spindle turning counterclockwise in G84 (right-hand tapping needs M3)")
    for level in (bottom, clear):
        if (cyc.a, cyc.b) == (0, 1):
            cyc.feed_to(aa, bb, level)
        elif (cyc.a, cyc.b) == (1, 2):  # rs274's YZ call order: (level, aa, bb)
            cyc.feed_to(level, aa, bb)
        else:  # XZ: (bb, level, aa)
            cyc.feed_to(bb, level, aa)
        if level == bottom:
            cyc.items.append(Dwell(cyc.line, cyc.work, max(0.0, p)))
