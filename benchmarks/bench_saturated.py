"""Saturated ramps on arcs from rest: what one costs to build and what it saves, in one run.

    python benchmarks/bench_saturated.py

Builds :func:`~gantry_sim.controller.planner.saturated_ramp.saturated_profile` for arcs from rest
to rest like those that took the planning time of arc-fitted prints (the bundled machine's
per-axis limits, and Marlin's M201 X500 Y500 and X20000 Y20000 over them; full circles and
arcs of 60-300 degrees, R 0.2-13 mm), each at its curvature cap, and prints per arc the time
to build it, its duration, and the duration of the cheaper profile under the tangent's limits
(:func:`~gantry_sim.controller.planner.tangent_limits.tangent_profile`, the baseline, built in
the same run; "-" where it finds none). Measured on this project's 2-core machine
(2026-11-28, after the ramps shared their up steps): 0.06-0.33 s an arc, 7-27 % faster than
the tangent's profile where it has one (it has none on the full circles at the bundled limits:
their cap is the curvature's, and its ramps meet it with acceleration left).
"""

from __future__ import annotations

import math
import time

from gantry_sim.controller.arcs import arc_frame
from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.moves import Arc
from gantry_sim.controller.planner.limits import curvature_speed_cap
from gantry_sim.controller.planner.ramp_bounds import CircleLimits
from gantry_sim.controller.planner.ruckig_solver import RuckigSolver
from gantry_sim.controller.planner.saturated_ramp import SHARE, saturated_profile
from gantry_sim.controller.planner.tangent_limits import tangent_profile
from gantry_sim.models import DEFAULT_MACHINE

#: (name, plane-axis accelerations [mm/s^2]); jerk stays the bundled machine's
ACCELERATIONS = (("bundled", None), ("M201 X500 Y500", (500.0, 500.0)), ("M201 X20000", None))
#: (radius [mm], sweep [deg], start angle [deg])
ARCS = (
    (0.21, 74.0, 172.0),
    (0.56, 84.0, 87.0),
    (1.0, 360.0, 30.0),
    (2.14, 103.0, 256.0),
    (5.0, 360.0, 57.0),
    (9.4, 274.0, 10.0),
    (13.0, 306.0, 200.0),
)


def _case(radius: float, sweep_deg: float, start_deg: float, acc: tuple[float, float], jerk):
    """(length [mm], cap [mm/s], frame, the two ramps' bounds) of a clockwise arc."""
    th0 = math.radians(start_deg)
    start = (radius * math.cos(th0), radius * math.sin(th0), 0.0)
    th1 = th0 - math.radians(sweep_deg)
    end = start if sweep_deg >= 360.0 else (radius * math.cos(th1), radius * math.sin(th1), 0.0)
    sweep = math.radians(sweep_deg)
    arc = Arc(1, start, end, 60000.0, "XY", "cw", (0.0, 0.0, 0.0), radius, 1, sweep)
    f = arc_frame(arc)
    length = arc.length_mm
    k = 1.0 / radius
    cap = curvature_speed_cap(1000.0, k, k * k, min(acc), min(jerk), SHARE)
    return length, cap, f, CircleLimits.ends(f, length, acc, jerk, SHARE)


def main() -> int:
    machine = load_machine_config(DEFAULT_MACHINE)
    lim = machine.limits
    solver = RuckigSolver(lim)
    jerk = tuple(lim.max_jerk_mm_per_s3[:2])
    print(
        f"{'limits':16s} {'R':>5s} {'sweep':>6s} {'cap':>7s} {'build [s]':>9s} "
        f"{'saturated [s]':>13s} {'tangent [s]':>11s} {'saturated/tangent':>17s}"
    )
    for name, acc in ACCELERATIONS:
        if acc is None:
            acc = tuple(lim.max_acceleration_mm_per_s2[:2]) if name == "bundled" else (2e4, 2e4)
        for radius, sweep, start in ARCS:
            length, cap, frame, lims = _case(radius, sweep, start, acc, jerk)
            t0 = time.perf_counter()
            sat = saturated_profile(length, 0.0, 0.0, cap, lims)
            built = time.perf_counter() - t0
            tang = tangent_profile(frame, length, 0.0, 0.0, cap, acc, jerk, solver)
            s = "-" if sat is None else f"{sat.duration_s:.5f}"
            t = "-" if tang is None else f"{tang.duration_s:.5f}"
            ratio = (
                "-" if sat is None or tang is None else f"{sat.duration_s / tang.duration_s:.4f}"
            )
            print(
                f"{name:16s} {radius:5.2f} {sweep:6.0f} {cap:7.2f} {built:9.3f} "
                f"{s:>13s} {t:>11s} {ratio:>17s}"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
