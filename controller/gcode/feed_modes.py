"""G93 inverse-time and G95 feed-per-revolution feeds, turned into path speed [mm/min].

rs274 (measured): in G93 every G1/G2/G3 needs its own F (its inverse time, 1/min: "F word
missing with inverse time g1 move") and the move's speed is its length times F; in G95 the
speed is F (units per revolution) times the spindle speed S, and a feed move with S0 is refused
("Cannot feed with zero spindle speed in feed per rev mode"). G0 is unaffected.
"""

from __future__ import annotations

import math
from dataclasses import replace

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.state import ModalState
from gantry_sim.controller.moves import Arc, Linear, Spline

INVERSE_TIME = 930
UNITS_PER_MINUTE = 940
PER_REVOLUTION = 950


def check_feed_mode(s: ModalState, what: str, v: dict[str, float]) -> None:
    """The feed words a feed move needs in the current feed mode."""
    if s.feed_mode == INVERSE_TIME and "F" not in v:
        raise GcodeError(
            f"F word missing with inverse time (G93) on {what}: give it an F (1/minute; rs274 "
            "needs one on every feed move in G93, g2core on the first after G93)"
        )
    if s.feed_mode == PER_REVOLUTION and s.rpm <= 0.0:
        raise GcodeError(
            f"cannot make {what} with zero spindle speed in feed per revolution (G95); set S"
        )


def path_feed(
    move: Linear | Arc | Spline,
    s: ModalState,
    v: dict[str, float],
    arc_segments_mm: float | None = None,
    inverse_time_floor_mm: float = 0.0,
) -> Linear | Arc | Spline:
    """``move`` with its path speed [mm/min] for the feed mode in effect, and Marlin's M220
    percentage. ``arc_segments_mm``: an arc in G93 runs at F times the segments it is cut into
    at this tolerance [mm] (grbl: :func:`grbl_inverse_time_arc`); None: F times its length, or
    ``inverse_time_floor_mm`` [mm/min] where that is more (rs274's inverse_time_rate_straight
    and _arc: at least 0.1 program units per minute, so a move of no length gets 0.1)."""
    if s.feed_mode == INVERSE_TIME:
        if arc_segments_mm is not None and isinstance(move, Arc):
            return grbl_inverse_time_arc(move, v["F"], arc_segments_mm)
        rate = max(inverse_time_floor_mm, move.length_mm * v["F"])
        return replace(move, feed_mm_per_min=rate)
    if s.feed_mode == PER_REVOLUTION:
        return replace(move, feed_mm_per_min=per_revolution(s.feed_mm_per_min, s.rpm))
    if s.feed_percent[0] != 100:
        return replace(move, feed_mm_per_min=move.feed_mm_per_min * (0.01 * s.feed_percent[0]))
    return move


def per_revolution(feed_mm_per_rev: float, rpm: float) -> float:
    """G95's path speed [mm/min]: F [mm/rev] x S [rev/min]; GcodeError where the product
    overflows (each may be up to 1e300)."""
    rate = feed_mm_per_rev * rpm
    if not math.isfinite(rate):
        raise GcodeError(
            f"feed per revolution (G95) F {feed_mm_per_rev:g} mm/rev x S {rpm:g} rev/min is not "
            "a finite feed; the path speed F x S must be a finite number of mm/min"
        )
    return rate


def grbl_inverse_time_arc(arc: Arc, f_per_min: float, tolerance_mm: float) -> Arc:
    """``arc`` (G93, F ``f_per_min`` [1/min]) as grbl 1.1 runs it: motion_control.c's mc_arc
    multiplies the inverse-time F by its segment count (``floor(|angle * radius / 2| /
    sqrt(tol * (2 radius - tol)))``, tol its $12 arc tolerance [mm]) and plans the segments
    at that many mm/min, the inverse-time flag cleared: F x segments, not F x length. An arc
    of no segment is one inverse-time line there, done in 1/F minutes: F x length."""
    segments = 0
    if 2.0 * arc.radius > tolerance_mm:
        chord_rise = math.sqrt(tolerance_mm * (2.0 * arc.radius - tolerance_mm))
        segments = math.floor(abs(0.5 * arc.angle * arc.radius) / chord_rise)
    return replace(arc, feed_mm_per_min=f_per_min * (segments or arc.length_mm))
