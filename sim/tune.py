"""Feed tuning: per radius, the highest feed whose full circle stays within a contour tolerance.

The test program per radius is sim.ballbar_program's (CCW only): a tangent lead-in semicircle,
one full circle, a tangent lead-out. The error counted is the circle block's own max contour
error (report.json "blocks"), so lead-in and lead-out transients do not count.

Search. The error is assumed to grow with the feed (true of a servo loop whose lags and
overshoots grow with speed and acceleration; once the planner's v^2/R <= a cap binds, raising
the feed no longer changes the motion and the error stops growing). Bracket first: from
``start_feed`` double until the circle fails or the cap is reached (the feed at which the
plane's slower axis reaches its max velocity), or halve until it passes (down to
``min_feed``). Then bisect the bracket [pass, fail] until it is no wider than the feed
resolution; the answer is the highest feed that was simulated and passed, so it is within one
resolution step below the true limit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from controller.arcs import PLANE_AXES
from controller.config import MachineConfig
from controller.errors import ConfigError
from controller.units import mm_per_s_to_mm_per_min
from sim.ballbar_program import circle_test_program

DEFAULT_RESOLUTION_MM_PER_MIN = 20.0
DEFAULT_START_FEED_MM_PER_MIN = 1000.0
DEFAULT_MIN_FEED_MM_PER_MIN = 100.0


@dataclass(frozen=True)
class TuneRow:
    """One radius's answer.

    Attributes:
        radius_mm: circle radius [mm].
        max_feed_mm_per_min: highest passing feed found [mm/min]; None when even the minimum
            feed fails.
        max_error_um: the circle block's max contour error at that feed [um] (at the minimum
            feed when none passes).
        limited_by: "tolerance" (the bisection's answer), "max_velocity" (the cap passes) or
            "unreachable" (the minimum feed fails).
        tried: every (feed [mm/min], max error [um]) simulated, in the order tried.
    """

    radius_mm: float
    max_feed_mm_per_min: float | None
    max_error_um: float
    limited_by: str
    tried: tuple[tuple[float, float], ...]

    def to_json(self) -> dict:
        return {
            "radius_mm": self.radius_mm,
            "max_feed_mm_per_min": self.max_feed_mm_per_min,
            "max_error_um": self.max_error_um,
            "limited_by": self.limited_by,
            "simulations": len(self.tried),
        }


def circle_error_um(
    machine: MachineConfig, plane: str, radius_mm: float, feed_mm_per_min: float
) -> float:
    """Max contour error [um] of the full-circle block of the tune program at this feed."""
    from sim.api import run_program

    program = circle_test_program(plane, radius_mm, feed_mm_per_min, ("ccw",))
    result = run_program(program.text, file=f"tune_r{radius_mm:g}.ngc", machine=machine)
    line = program.circle_line("ccw")
    errors = [b["max_error_um"] for b in result.report["blocks"] if b["line"] == line]
    if not errors:
        raise RuntimeError(f"the report has no block for the circle's line {line}")
    return float(max(errors))


def feed_cap_mm_per_min(machine: MachineConfig, plane: str) -> float:
    """The feed at which the plane's slower axis would reach its max velocity [mm/min]."""
    i1, i2, _ = PLANE_AXES[plane]
    v = machine.limits.max_velocity_mm_per_s
    return mm_per_s_to_mm_per_min(min(v[i1], v[i2]))


def max_feed_for_radius(
    radius_mm: float,
    tolerance_um: float,
    error_at: Callable[[float], float],
    cap_mm_per_min: float,
    resolution_mm_per_min: float = DEFAULT_RESOLUTION_MM_PER_MIN,
    start_feed_mm_per_min: float = DEFAULT_START_FEED_MM_PER_MIN,
    min_feed_mm_per_min: float = DEFAULT_MIN_FEED_MM_PER_MIN,
) -> TuneRow:
    """Bracket, then bisect, the highest feed with ``error_at(feed) <= tolerance_um``.

    Args:
        radius_mm: the radius (reported only) [mm].
        tolerance_um: the contour tolerance [um].
        error_at: feed [mm/min] -> the circle's max contour error [um] (one simulation).
        cap_mm_per_min: the highest feed tried [mm/min].
        resolution_mm_per_min: the bisection stops when the bracket is this narrow [mm/min].
        start_feed_mm_per_min: the first feed tried [mm/min].
        min_feed_mm_per_min: the lowest feed tried while bracketing [mm/min].
    """
    seen: dict[float, float] = {}

    def passes(feed: float) -> bool:
        if feed not in seen:
            seen[feed] = error_at(feed)
        return seen[feed] <= tolerance_um

    def row(feed: float | None, at: float, why: str) -> TuneRow:
        tried = tuple((float(f), float(e)) for f, e in seen.items())
        return TuneRow(float(radius_mm), feed, float(seen[at]), why, tried)

    feed = min(start_feed_mm_per_min, cap_mm_per_min)
    if passes(feed):
        lo = feed
        while True:
            if lo >= cap_mm_per_min:
                return row(lo, lo, "max_velocity")
            up = min(2.0 * lo, cap_mm_per_min)
            if not passes(up):
                hi = up
                break
            lo = up
    else:
        hi = feed
        while True:
            down = max(hi / 2.0, min_feed_mm_per_min)
            if down >= hi:
                return row(None, hi, "unreachable")
            if passes(down):
                lo = down
                break
            hi = down
    while hi - lo > resolution_mm_per_min:
        mid = 0.5 * (lo + hi)
        if passes(mid):
            lo = mid
        else:
            hi = mid
    return row(lo, lo, "tolerance")


def tune(
    machine: MachineConfig,
    radii_mm: list[float],
    tolerance_um: float,
    plane: str = "XY",
    resolution_mm_per_min: float = DEFAULT_RESOLUTION_MM_PER_MIN,
    progress: Callable[[str], None] | None = None,
) -> list[TuneRow]:
    """The highest feed per radius whose full circle keeps its max contour error within
    ``tolerance_um`` [um] on ``machine`` (see the module docstring for the search)."""
    if not radii_mm or any(not (r > 0) for r in radii_mm):
        raise ConfigError(f"radii {radii_mm} must be numbers > 0 [mm]", file="--radii")
    if not tolerance_um > 0:
        raise ConfigError(f"tolerance {tolerance_um} um must be > 0", file="--tolerance-um")
    if not resolution_mm_per_min > 0:
        raise ConfigError("feed resolution must be > 0 mm/min", file="--feed-resolution")
    cap = feed_cap_mm_per_min(machine, plane)
    rows = []
    for radius in radii_mm:

        def error_at(feed: float, radius: float = radius) -> float:
            err = circle_error_um(machine, plane, radius, feed)
            if progress is not None:
                progress(f"R {radius:g} mm  F {feed:.0f} mm/min  max error {err:.2f} um")
            return err

        rows.append(max_feed_for_radius(radius, tolerance_um, error_at, cap, resolution_mm_per_min))
    return rows
