"""The last check on what the interpreter makes: every number of a move or event is finite.

Each value a program gives is bounded (:data:`~gantry_sim.controller.gcode.expressions.
MAX_MAGNITUDE`), but what is computed from them may still overflow a double: G95's feed (F per
revolution x S), an arc's centre from a huge R, coordinates scaled by G20 and summed with
offsets. Such a number is refused on its line (GcodeError), never handed on: ``gantry parse``
would print ``Infinity``, which is not JSON, and the planner would plan nonsense.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.moves import Arc, Dwell, Limits, Linear, Rapid, Spline, Stop


def _numbers(item: object) -> Iterator[tuple[str, float]]:
    """(name, value) of every number ``item`` carries (positions [mm], feeds [mm/min],
    radii [mm], angles [rad], times [s], weights and knots [1])."""
    if isinstance(item, Rapid | Linear | Arc | Spline):
        for axis, v in zip("XYZ", item.start, strict=True):
            yield f"start {axis}", v
        for axis, v in zip("XYZ", item.end, strict=True):
            yield f"end {axis}", v
        if not isinstance(item, Rapid):
            yield "feed [mm/min]", item.feed_mm_per_min
    if isinstance(item, Arc):
        for axis, v in zip("XYZ", item.center, strict=True):
            yield f"centre {axis}", v
        yield "radius", item.radius
        yield "swept angle", item.angle
    elif isinstance(item, Spline):
        for k, point in enumerate(item.control_points):
            for axis, v in zip("XYZ", point, strict=True):
                yield f"control point {k + 1} {axis}", v
        for k, w in enumerate(item.weights):
            yield f"weight {k + 1}", w
        for k, knot in enumerate(item.knots):
            yield f"knot {k + 1}", knot
    elif isinstance(item, Dwell | Stop):
        for axis, v in zip("XYZ", item.position, strict=True):
            yield f"position {axis}", v
        if isinstance(item, Dwell):
            yield "dwell time [s]", item.seconds
    elif isinstance(item, Limits):
        yield from item.values


def _sum(item: object) -> float:
    """The sum of a straight move's numbers (most moves), or NaN for the rest: they are
    checked one by one."""
    if isinstance(item, Linear):
        a, b = item.start, item.end
        return a[0] + a[1] + a[2] + b[0] + b[1] + b[2] + item.feed_mm_per_min
    if isinstance(item, Rapid):
        a, b = item.start, item.end
        return a[0] + a[1] + a[2] + b[0] + b[1] + b[2]
    return math.nan


def check_finite(items: Iterable[object]) -> None:
    """GcodeError naming the first number of ``items`` that is not finite (the line is the
    caller's). A straight move costs one sum: a finite sum proves each number finite (an
    infinity or a NaN makes the sum infinite or NaN); a sum that is not (it may merely have
    overflowed) and every other kind are searched number by number."""
    for item in items:
        if math.isfinite(_sum(item)):
            continue
        for name, v in _numbers(item):
            if not math.isfinite(v):
                kind = getattr(item, "kind", "")
                what = f"{kind} move's" if isinstance(item, Rapid | Linear | Arc | Spline) else kind
                raise GcodeError(
                    f"the {what} {name} is not a finite number ({v}): the line's numbers "
                    "overflow a double; "
                    "every position, feed, radius and time must be a finite number: keep "
                    "the values and what they multiply (G20's 25.4, G95's S) smaller"
                )
