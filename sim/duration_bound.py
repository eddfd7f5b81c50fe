"""A lower bound on a program's planned duration, without planning it (sim.budget refuses a
program far beyond the simulation budget before its planning takes minutes).

Per move, the fastest speed it could have: its feed times the override, capped by the axis
speed limits along a straight move's direction, by their norm along a curve (a rapid at the
cap; the highest speed a Marlin M203 in the program sets counts).

Between two rests -- the start, the end, a dwell, and a reversal: two straight moves turning by
:data:`REVERSAL_RAD` or more, where every axis that turns back passes zero speed and the planner
stops -- the bound is the larger of the moves' times at those speeds and the fastest
rest-to-rest run of their length under the norms of the axis speed and acceleration limits (the
tangential acceleration never exceeds the acceleration's norm; no jerk limit, so it holds for
any). A Marlin M201 or M204 in the program drops that term (they may raise the acceleration),
and so does a G64 Q that could merge the stretch's moves (LinuxCNC's naive-CAM merge can fold
a short step back into a line, which removes the reversal and shortens the path); then a
reversal there is no rest either. Dwells add their time.

A back-and-forth of 600,000 one-millimetre G1 moves at F100000 is bounded at 18,000 s this way
(at least 0.03 s a move), against 1,200 s by the speeds alone: refused at once, where it was
refused after a 64 s plan.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # no numpy or config import when the CLI only builds its parser
    from gantry_sim.controller.config import MachineConfig

#: turn [rad] from which a junction of two straight moves is an exact stop in every mode (the
#: planner blends corners below 179 degrees only: controller/planner/blend.py MAX_TURN_RAD)
REVERSAL_RAD = math.radians(179.0)
#: moves this short [mm] have no direction (the planner drops them)
EPS_MM = 1e-9


def duration_lower_bound(
    items: Iterable[object], machine: MachineConfig, feed_override_pct: float = 100.0
) -> tuple[float, int | None, float]:
    """A lower bound [s] on the planned duration of ``items`` (moves and events; see the
    module docstring), and the line whose moves take longest at their speeds with that time
    [s] (a canned cycle's line makes many moves); (0, None, 0) without moves or dwells."""
    from gantry_sim.controller.moves import Arc, Dwell, Limits, Linear, Rapid, Spline
    from gantry_sim.controller.planner.path_control import control

    items = list(items)
    vmax = list(machine.limits.max_velocity_mm_per_s)
    accel_set = False
    for e in items:  # a Marlin M203 may raise an axis' speed: the fastest ever set bounds it
        if isinstance(e, Limits) and e.code == "M203":
            for axis, value in e.values:
                if axis in "XYZ" and math.isfinite(value):
                    i = "XYZ".index(axis)
                    vmax[i] = max(vmax[i], value)
        accel_set |= isinstance(e, Limits) and e.code in ("M201", "M204")
    norm = math.sqrt(sum(v * v for v in vmax))
    acc = math.inf if accel_set else math.hypot(*machine.limits.max_acceleration_mm_per_s2)
    scale = feed_override_pct / 100.0
    per_line: dict[int, float] = {}
    stretch = _Stretch(norm, acc)
    total = 0.0
    run_q = 0.0  # the largest G64 Q of the straight feed moves that could be merged so far
    prev_feed: float | None = None
    for m in items:
        if isinstance(m, Dwell):
            total += stretch.close() + m.seconds
            per_line[m.line] = per_line.get(m.line, 0.0) + m.seconds
            prev_feed = None
            continue
        if not isinstance(m, Rapid | Linear | Arc | Spline):
            continue
        length = m.length_mm
        feed = getattr(m, "feed_mm_per_min", None)
        c = control(m, machine.path) if isinstance(m, Linear) else None
        if c is not None and c.mode == "G64":
            joins = prev_feed is not None and feed == prev_feed  # the run may go on
            run_q = max(run_q, c.naive_cam_mm) if joins else c.naive_cam_mm
            merge = joins and run_q > 0
            prev_feed = feed
        else:
            run_q, merge, prev_feed = 0.0, False, None
        if isinstance(m, Rapid | Linear):
            d = [e - b for b, e in zip(m.start, m.end, strict=True)]
            cap = min(
                (v / abs(x) * length for v, x in zip(vmax, d, strict=True) if x), default=norm
            )
            if merge:
                stretch.mergeable = True
            elif length > EPS_MM and stretch.reverses(d, length):
                total += stretch.close()
        else:
            d, cap = None, norm
        speed = cap if feed is None else min(cap, feed * scale / 60.0)
        t = length / speed if speed > 0 else 0.0
        stretch.add(length, t, d)
        per_line[m.line] = per_line.get(m.line, 0.0) + t
    total += stretch.close()
    if not per_line:
        return 0.0, None, 0.0
    line = max(per_line, key=lambda k: per_line[k])
    return total, line, per_line[line]


class _Stretch:
    """The moves since the last rest: their length [mm], their times at their fastest speeds
    [s], the unit direction of the last straight move (None after a curve), and whether a G64
    Q merge could shorten them (``mergeable``)."""

    def __init__(self, speed_mm_per_s: float, acc_mm_per_s2: float) -> None:
        self.speed, self.acc = speed_mm_per_s, acc_mm_per_s2
        self.length = 0.0
        self.times: list[float] = []
        self.last: list[float] | None = None
        self.mergeable = False

    def reverses(self, d: list[float], length_mm: float) -> bool:
        """True when a straight move of displacement ``d`` [mm] turns back from the last one by
        :data:`REVERSAL_RAD` or more."""
        if self.last is None:
            return False
        cos = sum(a * b for a, b in zip(self.last, d, strict=True)) / length_mm
        return cos <= math.cos(REVERSAL_RAD)

    def add(self, length_mm: float, t_s: float, d: list[float] | None) -> None:
        """A move of ``length_mm`` taking at least ``t_s``; ``d``: a straight move's
        displacement [mm] (None: a curve)."""
        self.length += length_mm
        self.times.append(t_s)
        if length_mm > EPS_MM:
            self.last = None if d is None else [x / length_mm for x in d]

    def close(self) -> float:
        """The stretch's bound [s]; a new stretch starts."""
        moves = math.fsum(self.times)
        run = 0.0 if self.mergeable else rest_to_rest_s(self.length, self.speed, self.acc)
        self.length, self.times, self.last, self.mergeable = 0.0, [], None, False
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
