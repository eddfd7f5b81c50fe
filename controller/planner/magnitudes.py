"""Values no machine can follow, refused on their line before anything is planned.

rs274 and the firmwares take any number a line can spell (the interpreter does too: ``gantry
parse`` shows what rs274 makes of it), and a program that sends the tool 10^299 mm away is
refused by the machine's travel. Before that check the geometry is computed (an arc's radius
squared, a spline's weighted control points), and numbers that large overflow to infinity and
NaN: a hostile-input sweep found arcs of R 10^300, G91 arcs summing to 10^299 and NURBS weights
of 10^299 ending in internal errors. Each move is therefore checked first
(:func:`~gantry_sim.controller.planner.plan.plan`): every point it passes through a finite
number within :data:`MAX_COORDINATE_MM` (a thousand kilometres, beyond any machine's travel by
four orders of magnitude), an arc's turns at most :data:`MAX_TURNS` (a P of 10^299 overflowed
the same way before its chords were counted), and a spline's weights within
:data:`WEIGHT_RANGE`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TypeVar

from gantry_sim.controller.errors import PlanningError
from gantry_sim.controller.moves import Arc, Linear, Rapid, Spline
from gantry_sim.controller.planner.segment import MAX_CHORD_SWEEP_RAD, MAX_SEGMENTS_PER_ARC

__all__ = ["MAX_COORDINATE_MM", "MAX_TURNS", "WEIGHT_RANGE", "check_magnitudes"]

#: the largest |coordinate| of a move's points, an arc's centre and radius [mm]
MAX_COORDINATE_MM = 1e9
#: the NURBS weights (G5.2 P) accepted: their ratios reach the curve's coordinates squared
WEIGHT_RANGE = (1e-9, 1e9)
#: chords a full turn of an arc gets at least (none sweeps more than MAX_CHORD_SWEEP_RAD)
CHORDS_PER_TURN = round(2.0 * math.pi / MAX_CHORD_SWEEP_RAD)
#: the most turns an arc's P may ask for (more would need more chords than an arc may have)
MAX_TURNS = MAX_SEGMENTS_PER_ARC // CHORDS_PER_TURN

_AXES = "XYZ"
T = TypeVar("T")


def check_magnitudes(item: T) -> T:
    """Raise PlanningError (with the item's line) where a move's points, an arc's centre or
    radius, or a spline's control points lie beyond :data:`MAX_COORDINATE_MM` or are not
    finite, an arc's turns pass :data:`MAX_TURNS`, or a spline's weight lies outside
    :data:`WEIGHT_RANGE`; return ``item``. Anything else is returned unchecked. (Every move of
    every plan and run comes here, twice in a run: the numbers are first summed, and searched
    for one beyond the bound, to name it, only when the sum is beyond it.)"""
    try:
        return _checked(item)
    except PlanningError as exc:  # a subroutine file's line is named with its file
        file = getattr(item, "file", None)
        if file is not None:
            exc.located(file)
        raise


def _checked(item: T) -> T:
    """:func:`check_magnitudes`, its errors named by line only."""
    if isinstance(item, Rapid | Linear):
        if not _all_within((*item.start, *item.end)):
            _points(item.line, "move", (item.start, item.end))
    elif isinstance(item, Arc):
        if not _all_within((*item.start, *item.end, *item.center, item.radius)):
            _points(item.line, "arc", (item.start, item.end))
            _points(item.line, "arc's centre", (item.center,))
            _refuse(item.line, "arc's radius", item.radius)
        if item.turns > MAX_TURNS:
            raise PlanningError(
                f"the arc's P asks for {item.turns:.6g} turns: at most {MAX_TURNS:g} are planned "
                f"(an arc has at most {MAX_SEGMENTS_PER_ARC:,} chords, {CHORDS_PER_TURN} a turn "
                "at least)",
                line=item.line,
            )
    elif isinstance(item, Spline):
        _points(item.line, "spline's control point", item.control_points)
        lo, hi = WEIGHT_RANGE
        for w in item.weights:
            if not lo <= w <= hi:
                raise PlanningError(
                    f"spline weight {w:.6g}: NURBS weights (P) from {lo:g} to {hi:g} are "
                    "planned (wider ratios overflow the curve's arithmetic)",
                    line=item.line,
                )
    return item


def _all_within(values: tuple[float, ...]) -> bool:
    """Whether the values' magnitudes sum to at most :data:`MAX_COORDINATE_MM` (then each is
    within it; a NaN or an infinity makes the sum one): a third of the time of testing each."""
    return sum(map(abs, values)) <= MAX_COORDINATE_MM


def _points(line: int, what: str, points: Iterable[tuple[float, float, float]]) -> None:
    """Refuse the first coordinate of ``points`` beyond :data:`MAX_COORDINATE_MM`, if any."""
    for p in points:
        for axis, x in zip(_AXES, p, strict=True):
            if not abs(x) <= MAX_COORDINATE_MM:  # (NaN too)
                _refuse(line, f"{what} {axis}", x)


def _refuse(line: int, what: str, x: float) -> None:
    """Raise the PlanningError for value ``x`` of ``what`` (none where it is within)."""
    if abs(x) <= MAX_COORDINATE_MM:
        return
    if not math.isfinite(x):
        raise PlanningError(f"the {what} is not a finite number ({x})", line=line)
    raise PlanningError(
        f"the {what} reaches {x:.6g} mm: coordinates, arc centres and radii beyond "
        f"+-{MAX_COORDINATE_MM:g} mm are refused (no machine travels that far)",
        line=line,
    )
