"""A lower bound on a program's planned duration, without planning it (sim.budget refuses a
program far beyond the simulation budget before its planning takes minutes).

Per move, the fastest speed it could have: its feed times the override, capped by the axis
speed limits along a straight move's direction, by their norm along a curve (a rapid at the
cap; the highest speed a Marlin M203 in the program sets counts).

Between two rests -- the start, the end, a dwell, a program stop (M0, M1, M60), a Marlin limit
change (M201-M205: the planner plans the parts either side from rest to rest), and a reversal:
two straight moves turning by :data:`REVERSAL_RAD` or more, where every axis that turns back
passes zero speed and the planner stops -- the bound is the larger of the moves' times at
those speeds and the fastest rest-to-rest run of their length under the norms of the axis
speed and acceleration limits (the tangential acceleration never exceeds the acceleration's
norm; no jerk limit, so it holds for any). A Marlin M201 or M204 in the program drops that
term (they may raise the acceleration). Dwells add their time.

G64 shortens the path, and the bound takes that off:

* a blend of a corner between two straight moves (feed moves or rapids: the planner may overlap
  the stop between two of either, which it keeps within P as a blend), turning by phi, within
  P of the corner: its radius R has R (sec(phi/2) - 1) <= P and uses R tan(phi/2) of each
  move, at most the shorter move, and it is R (2 tan(phi/2) - phi) shorter than the corner (up
  to 2 P as phi nears 180 degrees); a corner with an arc: at most 2 P, and at most the two
  moves' lengths;
* a G64 fit of short moves (controller/planner/polyline_fit.py) passes a corner between two
  of them at most 2 P tan(phi/2) shorter (4 P tan(phi/2) is taken off);
* a G64 Q merge (LinuxCNC's naive-CAM detector) replaces a run of straight moves at one feed by
  the line from its start to its end, which can fold steps back along the line and remove a
  reversal: the runs are found by the planner's own rule
  (:func:`~gantry_sim.controller.planner.path_control.extends_run`), and each counts as that
  line, at its feed, with no rest inside. (Counting every run of straight moves at one feed as
  its chord, as this bound first did, made a G64 P back-and-forth loop, which no merge
  shortens, a bound near 0: 600,000 such moves were refused only after an 84 s plan.)

Each junction's saving is taken off the stretch's length, and at the slower of its two moves'
speeds off their time.

A back-and-forth of 600,000 one-millimetre G1 moves at F100000 is bounded at 17,100 s this way
(at least 0.0285 s a move), against 1,200 s by the speeds alone: refused at once, where it was
refused after a 64 s plan. On 88 real and benchmark programs planned, the bound is up to
0.9997 of the plan.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # no numpy or config import when the CLI only builds its parser
    from gantry_sim.controller.config import MachineConfig
    from gantry_sim.controller.moves import Arc, Move
    from gantry_sim.controller.planner.path_control import Control

#: turn [rad] from which a junction of two straight moves is an exact stop in every mode (the
#: planner blends corners below 179 degrees only: controller/planner/blend.py MAX_TURN_RAD)
REVERSAL_RAD = math.radians(179.0)
#: moves this short [mm] have no direction (the planner drops them)
EPS_MM = 1e-9
#: a program line: (line, the subroutine file it is in; None: the program's own)
Where = tuple[int, str | None]
_COS_REVERSAL = math.cos(REVERSAL_RAD)


def duration_lower_bound(
    items: Iterable[object], machine: MachineConfig, feed_override_pct: float = 100.0
) -> tuple[float, Where | None, float]:
    """A lower bound [s] on the planned duration of ``items`` (moves and events; see the
    module docstring), and the line whose moves take longest at their speeds, as (line, the
    subroutine file it is in or None), with that time [s] (a canned cycle's line makes many
    moves); (0, None, 0) without moves or dwells."""
    from gantry_sim.controller.moves import Limits
    from gantry_sim.controller.planner.magnitudes import check_magnitudes

    items = items if isinstance(items, Sequence) else list(items)  # read twice
    vmax = list(machine.limits.max_velocity_mm_per_s)
    accel_set = False
    for e in items:  # a Marlin M203 may raise an axis' speed: the fastest ever set bounds it
        check_magnitudes(e)  # as the planner will, before numbers of 1e300 overflow here
        if isinstance(e, Limits) and e.code == "M203":
            for axis, value in e.values:
                if axis in "XYZ" and math.isfinite(value):
                    i = "XYZ".index(axis)
                    vmax[i] = max(vmax[i], value)
        accel_set |= isinstance(e, Limits) and e.code in ("M201", "M204")
    walk = BoundWalk(machine, feed_override_pct, vmax, accel_set)
    for m in items:
        walk.add(m)
    return walk.finish()


class BoundWalk:
    """:func:`duration_lower_bound`'s pass over the items, an item at a time (:meth:`add`),
    under the axis speeds ``vmax`` [mm/s] (the machine's, raised by any M203 of the program)
    and the machine's accelerations unless ``accel_set`` (an M201 or M204 in the program).
    :attr:`total_s` is the bound of the stretches closed so far: a lower bound on any program
    that starts with the items added, when no later item raises ``vmax`` (sim.budget's
    ParseBound checks it as the program is read)."""

    def __init__(
        self,
        machine: MachineConfig,
        feed_override_pct: float,
        vmax: list[float],
        accel_set: bool,
    ) -> None:
        from gantry_sim.controller.moves import Arc, Dwell, Limits, Linear, Rapid, Spline, Stop
        from gantry_sim.controller.planner.path_control import control, extends_run, starts_run
        from gantry_sim.controller.planner.polyline_fit import MAX_MOVE_MM, MAX_TURN_RAD

        # held here, not imported at every item (the walk runs once per move of the program)
        self._control, self._extends_run, self._starts_run = control, extends_run, starts_run

        self._stops, self._motions = (Dwell, Stop, Limits), (Rapid, Linear, Arc, Spline)
        # their mode governs the junction after them (G64: blended)
        self._governed = (Rapid, Linear, Arc)
        self._straights = (Rapid, Linear)
        self._arc, self._dwell, self._limits = Arc, Dwell, Limits
        self._fit = (MAX_MOVE_MM, MAX_TURN_RAD)
        # per path-control object (moves share theirs): the object, held so that its id stays
        # its own while the moves read from disk come and go, and its Control
        self._controls: dict[int, tuple[object, Control]] = {}
        self.vmax = vmax
        self.norm = math.sqrt(sum(v * v for v in vmax))
        acc = math.inf if accel_set else math.hypot(*machine.limits.max_acceleration_mm_per_s2)
        self.acc = acc
        self.scale = feed_override_pct / 100.0
        self.per_line: dict[Where, float] = {}  # (line, file): a subroutine file's lines apart
        self._stretch = _Stretch(self.norm, acc)
        self.total_s = 0.0
        self._run: list[Move] = []  # the naive-CAM run under way, as the planner's merge makes it
        self._prev: _Prev | None = None  # the last feed move (Linear or Arc) of non-zero length
        self._path = machine.path

    def _control_of(self, m: Move) -> Control:
        """``control(m, path)``, made once per path-control object."""
        pc = getattr(m, "path", None)
        hit = self._controls.get(id(pc))
        if hit is None:
            hit = self._controls[id(pc)] = (pc, self._control(m, self._path))
        return hit[1]

    def add(self, m: object) -> None:
        """The next item (a move or an event; anything else is passed over)."""
        stretch, per_line = self._stretch, self.per_line
        if isinstance(m, self._stops):  # an exact stop (and the dwell's time)
            if isinstance(m, self._limits) and m.code == "M205":  # J: blend tolerance from here
                j = dict(m.values).get("J", 0.0)
                self._path = replace(self._path, tolerance_mm=j) if j > 0 else self._path
                self._controls.clear()
            seconds = m.seconds if isinstance(m, self._dwell) else 0.0
            self.total_s += stretch.close() + seconds
            if seconds:
                at = (m.line, m.file)
                per_line[at] = per_line.get(at, 0.0) + seconds
            self._prev, self._run = None, []
            return
        if not isinstance(m, self._motions):
            return
        length = m.length_mm
        if length <= EPS_MM:  # the planner drops it: no junction, no time
            return
        feed = getattr(m, "feed_mm_per_min", None)
        c = self._control_of(m) if isinstance(m, self._governed) else None
        d = None
        cap = self.norm
        if isinstance(m, self._straights):
            (x0, y0, z0), (x1, y1, z1) = m.start, m.end
            d = [x1 - x0, y1 - y0, z1 - z0]
            cap = _straight_cap(self.vmax, d, length, self.norm)
        speed = cap if feed is None else min(cap, feed * self.scale / 60.0)
        t = length / speed if speed > 0 else 0.0
        if isinstance(m, self._arc) and c is not None:
            t += _curvature_time_s(m, length, speed, self.acc, c.tolerance_mm)
        at = (m.line, m.file)
        here = None if c is None else _Prev(at, feed, speed, t, c, d, length, m.start)
        run, prev = self._run, self._prev
        joins = bool(run) and self._extends_run(run, m, self._path)
        if joins:
            run.append(m)
        else:
            self._run = [m] if c is not None and self._starts_run(m, self._path, c) else []
        if joins and prev is not None and here is not None:  # a naive-CAM run takes m
            if prev.dropped:
                stretch.extend_run(m.end)
            else:  # the run starts at the move before: no shorter than its chord
                stretch.drop_last()
                per_line[prev.at] = max(per_line.get(prev.at, 0.0) - prev.t, 0.0)
                chord_speed = (
                    min(self.norm, feed * self.scale / 60.0) if feed is not None else self.norm
                )
                stretch.start_run(prev.start, m.end, chord_speed)
            here.dropped = True
            self._prev = here
            return
        if d is not None and stretch.reverses(d, length):
            self.total_s += stretch.close()
        elif prev is not None and here is not None and prev.g64:
            saved = _blend_saving_mm(prev, d, length, self._fit)
            saved_s = saved / min(prev.speed, speed) if saved > 0 else 0.0
            stretch.shorten(saved, saved_s)
            per_line[prev.at] = max(per_line.get(prev.at, 0.0) - saved_s, 0.0)
        stretch.add(length, t, d)
        per_line[at] = per_line.get(at, 0.0) + t
        self._prev = here

    def longest(self) -> tuple[Where | None, float]:
        """The (line, file) whose moves take longest so far, and that time [s]."""
        if not self.per_line:
            return None, 0.0
        where = max(self.per_line, key=lambda k: self.per_line[k])
        return where, self.per_line[where]

    def finish(self) -> tuple[float, Where | None, float]:
        """:func:`duration_lower_bound`'s result, the last stretch closed (call once)."""
        self.total_s += self._stretch.close()
        where, longest = self.longest()
        if where is None:
            return 0.0, None, 0.0
        return self.total_s, where, longest


def _curvature_time_s(
    arc: Arc, length_mm: float, speed_mm_per_s: float, acc_mm_per_s2: float, tolerance_mm: float
) -> float:
    """The time [s] ``arc`` takes beyond its ``length_mm`` at ``speed_mm_per_s``, from its
    curvature: on a circle or helix of radius R and rise c per radian, |a| >= v^2 k with
    k = R / (R^2 + c^2), and |a| <= ``acc_mm_per_s2`` (the norm of the axes' limits), so
    v <= sqrt(acc / k). Counted on the arc less a quarter turn at each end, where a G64
    blend or transition may replace it, and only where the arc cannot be cut across within
    the blend tolerance (R > 2 ``tolerance_mm``); a spiral (the planner's
    :func:`~gantry_sim.controller.arcs.is_spiral`) gets none, and an arc within its rounding
    of a circle the smaller curvature of its two radii. (10,000 circles of R 0.05 mm and 100
    turns each were planned for 194 s at 11 GB before a run refused their 53,901 s; they are
    now refused first.)"""
    middle = length_mm * max(0.0, arc.angle - math.pi) / arc.angle
    if middle <= 0.0 or not math.isfinite(acc_mm_per_s2) or arc.radius <= 2 * tolerance_mm:
        return 0.0  # (most arcs of CAM output turn by less than half a turn)
    from gantry_sim.controller.arcs import arc_frame, is_spiral

    if is_spiral(arc):
        return 0.0
    f = arc_frame(arc)
    rise = (f.h1_mm - f.h0_mm) / arc.angle  # [mm/rad]
    curvature = min(r / (r * r + rise * rise) for r in (f.r0_mm, f.r1_mm))
    cap = math.sqrt(acc_mm_per_s2 / curvature)
    if not cap < speed_mm_per_s:
        return 0.0
    return middle / cap - middle / speed_mm_per_s


class _Prev:
    """A feed move (G1, G2, G3): its (line, file), feed [mm/min], fastest speed [mm/s] and time [s],
    its path control's P and Q [mm] and whether it is G64 (its end junction is blended), its
    displacement (None: an arc), length and start point [mm], and whether a naive-CAM run took
    it (``dropped``)."""

    __slots__ = (
        "at",
        "direction",
        "dropped",
        "feed",
        "g64",
        "length",
        "p",
        "q",
        "speed",
        "start",
        "t",
    )

    def __init__(
        self,
        at: Where,
        feed: float | None,
        speed: float,
        t: float,
        control: Control,
        d: list[float] | None,
        length: float,
        start: Sequence[float],
    ) -> None:
        self.at, self.feed, self.speed, self.t = at, feed, speed, t
        self.p, self.q, self.g64 = control.tolerance_mm, control.naive_cam_mm, control.mode == "G64"
        self.direction, self.length, self.start = d, length, start
        self.dropped = False


def _straight_cap(vmax: list[float], d: list[float], length_mm: float, norm: float) -> float:
    """The fastest speed [mm/s] along a straight move of displacement ``d`` and ``length_mm``
    under the axis speeds ``vmax``: the least of ``v / |x| * length`` over the axes it moves
    along (in X, Y, Z order), ``norm`` when it moves along none."""
    cap = None
    for v, x in zip(vmax, d, strict=True):
        if x:
            c = v / abs(x) * length_mm
            cap = c if cap is None or c < cap else cap
    return norm if cap is None else cap


def _blend_saving_mm(
    prev: _Prev, d: list[float] | None, length_mm: float, fit: tuple[float, float]
) -> float:
    """How much shorter [mm] a G64 blend of the corner after ``prev`` into a move of
    displacement ``d`` (None: an arc) and ``length_mm`` can make the path (module docstring);
    ``fit``: the longest move [mm] and largest turn [rad] a G64 fit takes
    (controller/planner/polyline_fit.py)."""
    p = prev.p
    if prev.dropped:  # the end of a naive-CAM run: its merged line is not known
        return 2.0 * p
    if prev.direction is None or d is None:
        return min(2.0 * p, prev.length + length_mm)
    cos = _dot(prev.direction, d) / (prev.length * length_mm)
    phi = math.acos(max(-1.0, min(1.0, cos)))
    if phi <= 0.0:
        return 0.0
    half = 0.5 * phi
    sec_less_1 = 1.0 / math.cos(half) - 1.0
    by_tolerance = p / sec_less_1 if sec_less_1 > 0 else math.inf
    tan = math.tan(half)
    radius = min(by_tolerance, min(prev.length, length_mm) / tan)
    saving = max(radius * (2.0 * tan - phi), 0.0)
    if max(prev.length, length_mm) <= fit[0] and phi <= fit[1]:
        # a G64 fit may take the two moves (controller/planner/polyline_fit.py): a curve within
        # P of both passes the corner at most 2 P tan(phi/2) shorter (the inner offset lines at
        # P); twice that, for any rounding of that argument
        saving = max(saving, 4.0 * p * tan)
    return saving


class _Stretch:
    """The moves since the last rest: their lengths [mm], their times at their fastest speeds
    [s], the unit direction of the last straight move (None after a curve), and what G64
    blends may save of them (``saved_mm``, ``saved_s``)."""

    def __init__(self, speed_mm_per_s: float, acc_mm_per_s2: float) -> None:
        self.speed, self.acc = speed_mm_per_s, acc_mm_per_s2
        self.length = 0.0
        self.lengths: list[float] = []
        self.times: list[float] = []
        self.last: list[float] | None = None
        self.saved_mm = self.saved_s = 0.0
        self.run: tuple[tuple[float, ...], tuple[float, ...], float] | None = None

    def shorten(self, length_mm: float, t_s: float) -> None:
        """A G64 junction inside the stretch may shorten it by up to ``length_mm``, saving up
        to ``t_s``."""
        self.saved_mm += length_mm
        self.saved_s += t_s

    def reverses(self, d: list[float], length_mm: float) -> bool:
        """True when a straight move of displacement ``d`` [mm] turns back from the last one by
        :data:`REVERSAL_RAD` or more."""
        if self.last is None:
            return False
        cos = _dot(self.last, d) / length_mm
        return cos <= _COS_REVERSAL

    def start_run(self, start: Sequence[float], end: Sequence[float], speed: float) -> None:
        """A naive-CAM run from ``start`` to ``end`` [mm] at most at ``speed`` [mm/s]."""
        self._flush()
        self.run = (tuple(start), tuple(end), speed)
        self.last = None  # the merged lines' directions are not known

    def extend_run(self, end: Sequence[float]) -> None:
        if self.run is not None:
            self.run = (self.run[0], tuple(end), self.run[2])

    def _flush(self) -> None:
        """The run so far as its chord (its merged lines are no shorter)."""
        if self.run is None:
            return
        a, b, speed = self.run
        chord = math.dist(a, b)
        self.length += chord
        self.lengths.append(chord)
        self.times.append(chord / speed if speed > 0 else 0.0)
        self.run = None

    def drop_last(self) -> None:
        """The last move counts for nothing (a naive-CAM run took it)."""
        if self.times:
            self.length -= self.lengths.pop()
            self.times.pop()

    def add(self, length_mm: float, t_s: float, d: list[float] | None) -> None:
        """A move of ``length_mm`` taking at least ``t_s``; ``d``: a straight move's
        displacement [mm] (None: a curve)."""
        if self.run is not None:
            self._flush()
        self.length += length_mm
        self.lengths.append(length_mm)
        self.times.append(t_s)
        if d is not None:
            self.last = [d[0] / length_mm, d[1] / length_mm, d[2] / length_mm]
        elif length_mm > EPS_MM:
            self.last = None

    def close(self) -> float:
        """The stretch's bound [s]; a new stretch starts."""
        self._flush()
        moves = max(math.fsum(self.times) - self.saved_s, 0.0)
        length = max(self.length - self.saved_mm, 0.0)
        run = rest_to_rest_s(length, self.speed, self.acc)
        self.length, self.lengths, self.times, self.last = 0.0, [], [], None
        self.saved_mm = self.saved_s = 0.0
        return max(moves, run)


def rest_to_rest_s(length_mm: float, speed_mm_per_s: float, acc_mm_per_s2: float) -> float:
    """The fastest run [s] of ``length_mm`` from rest to rest with |v| <= ``speed_mm_per_s``
    and |a| <= ``acc_mm_per_s2`` (0 for an infinite acceleration or no length)."""
    if length_mm <= 0 or not math.isfinite(acc_mm_per_s2):
        return 0.0
    v, a = speed_mm_per_s, acc_mm_per_s2
    if length_mm <= v * v / a:  # triangular: the speed is never reached
        return 2.0 * math.sqrt(length_mm / a)
    return length_mm / v + v / a


def _dot(a: Sequence[float], b: Sequence[float]) -> float:
    """a . b of two 3-vectors, summed as ``sum()`` sums them (from 0, left to right)."""
    return 0 + a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
