"""Feed tuning: per radius, the highest feed whose full circle stays within a contour tolerance.

The test program per radius is sim.circular.program's (CCW only): a tangent 180-degree run-in arc,
one full circle, a tangent run-out arc. The error counted is the circle block's own max contour
error (the run report's block for its line), so lead-in and lead-out transients do not count.

Search, from the top. The cap is the feed at which the plane's slower axis reaches its max
velocity; if the circle passes there, that is the answer ("machine_limits": the machine's
velocity, acceleration and jerk limits, not the tolerance, bound the circle's speed; the row's
circle_feed_mm_per_min says how fast the planner actually ran it). Otherwise halve the
feed until a circle passes (down to ``min_feed``: "unreachable" if even that fails), then
bisect the bracket [pass, fail] until it is no wider than the feed resolution. The answer is
the highest feed simulated that passed, within one resolution step below the limit. Going down
from the top finds the highest passing feed even where the error is not monotonic in the feed
(Coulomb friction and chord following weigh more at low feeds; and once the planner's
v^2/R <= a cap binds, a higher feed no longer changes the motion); it assumes only that the
error does not dip back under the tolerance inside the final bracket. High feeds are also the
cheap simulations.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import ConfigError, GantryError
from gantry_sim.controller.machine_work import NO_WORK
from gantry_sim.controller.planes import PLANE_AXES
from gantry_sim.controller.units import mm_per_s_to_mm_per_min
from gantry_sim.sim.circular.program import circle_test_program

DEFAULT_RESOLUTION_MM_PER_MIN = 20.0
DEFAULT_MIN_FEED_MM_PER_MIN = 100.0
#: the finest feed resolution accepted [mm/min]: each halving of the bracket is a simulation
MIN_RESOLUTION_MM_PER_MIN = 0.01
#: most radii per tune (each costs about 10-20 simulations)
MAX_RADII = 100
#: hard bound on the simulations of one radius's search (the loops below never exceed it)
MAX_HALVINGS = 64
MAX_BISECTIONS = 64


@dataclass(frozen=True)
class TuneRow:
    """One radius's answer.

    Attributes:
        radius_mm: circle radius [mm].
        max_feed_mm_per_min: highest passing feed found [mm/min]; None when even the minimum
            feed fails.
        max_error_um: the circle block's max contour error at that feed [um] (at the minimum
            feed when none passes).
        circle_feed_mm_per_min: the path speed the planner actually ran that circle at
            [mm/min]; below the programmed feed where v^2/R <= a (or jerk) binds.
        limited_by: "tolerance" (the bisection's answer), "machine_limits" (the cap passes) or
            "unreachable" (the minimum feed fails).
        tried: every (feed [mm/min], max error [um]) simulated, in the order tried.
        run_feeds: for each of ``tried``, the path speed the circle actually ran at [mm/min]
            (what tune.png plots).
    """

    radius_mm: float
    max_feed_mm_per_min: float | None
    max_error_um: float
    circle_feed_mm_per_min: float
    limited_by: str
    tried: tuple[tuple[float, float], ...]
    run_feeds: tuple[float, ...] = ()

    def to_json(self) -> dict:
        return {
            "radius_mm": self.radius_mm,
            "max_feed_mm_per_min": self.max_feed_mm_per_min,
            "max_error_um": self.max_error_um,
            "circle_feed_mm_per_min": self.circle_feed_mm_per_min,
            "limited_by": self.limited_by,
            "simulations": len(self.tried),
        }


def circle_error_um(
    machine: MachineConfig,
    plane: str,
    radius_mm: float,
    feed_mm_per_min: float,
    budget: Any = None,
) -> tuple[float, float]:
    """Simulate the tune program at this feed.

    Returns:
        (the full-circle block's max contour error [um], the reference's median path speed on
        that block [mm/min]: the feed actually run, below the programmed one where the
        planner's acceleration or jerk caps bind).
    """
    import numpy as np

    from gantry_sim.sim.api import run_program
    from gantry_sim.sim.circular.ballbar import option_error

    file = f"tune_r{radius_mm:g}.ngc"
    what = f"the R {radius_mm:g} mm circle at F {feed_mm_per_min:.6g} mm/min ({plane})"
    try:
        program = circle_test_program(plane, radius_mm, feed_mm_per_min, ("ccw",))
        bare = replace(machine, work=NO_WORK)  # the circle is written in the work frame
        result = run_program(program.text, file=file, machine=bare, budget=budget)
    except GantryError as exc:
        raise option_error(exc, file, what, "--radii", None, machine.source) from None
    line = program.circle_line("ccw")
    block = result.run_report.block(line)
    if block is None:
        raise RuntimeError(f"the report has no block for the circle's line {line}")
    tr = result.trace
    on = np.asarray(tr.line) == line
    ref, t = np.asarray(tr.ref)[on], np.asarray(tr.t)[on]
    speed = np.linalg.norm(np.diff(ref, axis=0), axis=1) / np.diff(t)
    return block.max_error_um, mm_per_s_to_mm_per_min(float(np.median(speed)))


def feed_cap_mm_per_min(machine: MachineConfig, plane: str) -> float:
    """The feed at which the plane's slower axis would reach its max velocity [mm/min]."""
    i1, i2, _ = PLANE_AXES[plane]
    v = machine.limits.max_velocity_mm_per_s
    return mm_per_s_to_mm_per_min(min(v[i1], v[i2]))


def max_feed_for_radius(
    radius_mm: float,
    tolerance_um: float,
    evaluate: Callable[[float], tuple[float, float]],
    cap_mm_per_min: float,
    resolution_mm_per_min: float = DEFAULT_RESOLUTION_MM_PER_MIN,
    min_feed_mm_per_min: float = DEFAULT_MIN_FEED_MM_PER_MIN,
) -> TuneRow:
    """Bracket from the cap down, then bisect, the highest feed whose error <= ``tolerance_um``.

    Args:
        radius_mm: the radius (reported only) [mm].
        tolerance_um: the contour tolerance [um].
        evaluate: feed [mm/min] -> (the circle's max contour error [um], the feed run
            [mm/min]); one simulation.
        cap_mm_per_min: the highest feed tried [mm/min].
        resolution_mm_per_min: the bisection stops when the bracket is this narrow [mm/min].
        min_feed_mm_per_min: the lowest feed tried while bracketing [mm/min].
    """
    seen: dict[float, tuple[float, float]] = {}

    def passes(feed: float) -> bool:
        if feed not in seen:
            seen[feed] = evaluate(feed)
        return seen[feed][0] <= tolerance_um

    def row(feed: float | None, at: float, why: str) -> TuneRow:
        tried = tuple((float(f), float(e)) for f, (e, _) in seen.items())
        run_feeds = tuple(float(rf) for _, rf in seen.values())
        err, run_feed = seen[at]
        return TuneRow(float(radius_mm), feed, float(err), float(run_feed), why, tried, run_feeds)

    hi = cap_mm_per_min
    if passes(hi):
        return row(hi, hi, "machine_limits")
    for _ in range(MAX_HALVINGS):
        down = max(hi / 2.0, min_feed_mm_per_min)
        if down >= hi:
            return row(None, hi, "unreachable")
        if passes(down):
            lo = down
            break
        hi = down
    else:
        return row(None, hi, "unreachable")
    for _ in range(MAX_BISECTIONS):
        mid = 0.5 * (lo + hi)
        if hi - lo <= resolution_mm_per_min or not lo < mid < hi:
            break  # narrow enough, or no float between the bracket's ends
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
    budget: Any = None,
) -> list[TuneRow]:
    """The highest feed per radius whose full circle keeps its max contour error within
    ``tolerance_um`` [um] on ``machine`` (see the module docstring for the search)."""
    if not radii_mm or any(not (0 < r < float("inf")) for r in radii_mm):
        raise ConfigError(f"radii {radii_mm} must be finite numbers > 0 [mm]", file="--radii")
    if len(radii_mm) > MAX_RADII:
        raise ConfigError(
            f"{len(radii_mm)} radii: at most {MAX_RADII} per tune (each costs 10-20 "
            "simulations); split the list",
            file="--radii",
        )
    if not tolerance_um > 0:
        raise ConfigError(f"tolerance {tolerance_um} um must be > 0", file="--tolerance-um")
    if not MIN_RESOLUTION_MM_PER_MIN <= resolution_mm_per_min < float("inf"):
        raise ConfigError(
            f"{resolution_mm_per_min:g} mm/min: must be a finite number >= "
            f"{MIN_RESOLUTION_MM_PER_MIN:g} mm/min (each halving of the feed bracket costs "
            "one simulation)",
            file="--feed-resolution",
        )
    cap = feed_cap_mm_per_min(machine, plane)
    rows = []
    for radius in radii_mm:

        def evaluate(feed: float, radius: float = radius) -> tuple[float, float]:
            err, run_feed = circle_error_um(machine, plane, radius, feed, budget)
            if progress is not None:
                progress(
                    f"R {radius:g} mm  F {feed:.0f} mm/min (runs at {run_feed:.0f})  "
                    f"max error {err:.2f} um"
                )
            return err, run_feed

        rows.append(max_feed_for_radius(radius, tolerance_um, evaluate, cap, resolution_mm_per_min))
    return rows
