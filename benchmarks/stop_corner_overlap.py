"""What overlapping the two moves at an exact-stop corner would save (a measurement, not a
feature): the gap to LinuxCNC's time on the peer pocket.

    python benchmarks/stop_corner_overlap.py [--only NAME ...]      (pocket: about a minute)

In G64 P0.01 the planner still stops at a sharp corner between two lines wherever its blend
arc would be slower than the stop (``controller/planner/blend_judge.py``): a jerk-limited
reference passes a small arc slowly, since the curvature jumps at the arc's ends. The peer
pocket (benchmarks/peer_programs.py) stops at its 352 corners between lines (its 0.5 mm linking
lines and plunges), and those stops are what keeps it at 1.063 x LinuxCNC's time, which blends
them with no jerk limit.

Another way through such a corner keeps every limit: superpose the two moves' own profiles.
The reference of the first move decelerating to rest at the corner C and that of the second
accelerating from rest are overlapped by tau seconds, r(t) = A(t_b - tau + t) + B(t_b + t) - C
for t in [0, tau]: position, velocity and acceleration stay continuous (both are at rest with
no acceleration at C), each axis' jerk is the sum of the two moves' along it, and the program
is tau shorter. This script plans each program with our planner, then, at every stop between
two straight feed moves, finds the largest tau on a 0.1 ms grid (by bisection, checked at the
answer) for which, sampled every 0.02 ms: every axis keeps its velocity, acceleration and jerk
limits (jerk by differences, 0.1 % slack for them), the path speed keeps the smaller feed, the
reference stays within P less the reference's share of the two segments, and the corner C lies
within that of the reference (LinuxCNC's meaning of P: the path passes within P of the
programmed corner). It prints the time saved and the cycle it would give against LinuxCNC's.

Measured (2026-11-29, `d0ed7e0`): the pocket would save 5.28 s (11-15 ms a corner, 2.7 %):
196.46 -> 191.17 s, 1.035 x LinuxCNC instead of 1.063. The zigzag saves 0.03 s: its corners
turn 30 degrees, so both moves' jerk lies along the same axes and their sum breaks the limit
(an overlap there needs the two profiles' tails planned with lower jerk, which costs back part
of the gain); only corners whose moves share no axis (the pocket's, and plunges into a cut)
overlap at full jerk. Building it means a corner decided after the profiles are planned: a
window must not end at such a corner, the overlap is a blend of its own in the plan's blends
and the run's reference split, and the per-block analysis sees two moves at once there.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
if str(HERE.parent) not in sys.path:  # run as a script: import the sibling benchmark module
    sys.path.insert(0, str(HERE.parent))

from benchmarks.peer_programs import MODES, programs  # noqa: E402
from gantry_sim.controller.config import load_machine_config  # noqa: E402
from gantry_sim.controller.gcode.interpreter import parse_program  # noqa: E402
from gantry_sim.controller.moves import Linear  # noqa: E402
from gantry_sim.controller.planner import Plan, plan  # noqa: E402
from gantry_sim.controller.planner.blend import REFERENCE_SHARE  # noqa: E402
from gantry_sim.models import DEFAULT_MACHINE  # noqa: E402

PEER = HERE / "data" / "linuxcnc_peer.json"
GRID_S = 1e-4  # tau's grid [s]
SAMPLE_S = 2e-5  # samples of the overlap [s]
JERK_SLACK = 1e-3  # jerk by differences of sampled accelerations


def _segment_distance(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = b - a
    u = np.clip(((q - a) @ d) / (d @ d), 0.0, 1.0)
    return np.linalg.norm(q - (a + np.outer(u, d)), axis=1)


def _fits(p: Plan, t_b: float, tau: float, a: Linear, b: Linear, limits, budget_mm: float) -> bool:
    """Whether the overlap of ``tau`` [s] at the stop at ``t_b`` [s] keeps every check (module
    docstring)."""
    t = np.arange(0.0, tau + SAMPLE_S / 2, SAMPLE_S)
    c = np.asarray(a.end, float)
    pa, va, aa = p.curve.evaluate(t_b - tau + t)
    pb, vb, ab = p.curve.evaluate(np.minimum(t_b + t, p.duration_s))
    r, v, acc = pa + pb - c, va + vb, aa + ab
    jerk = np.diff(acc, axis=0) / SAMPLE_S
    feed = min(a.feed_mm_per_min, b.feed_mm_per_min) / 60.0
    vmax, amax, jmax = (
        np.asarray(x)
        for x in (
            limits.max_velocity_mm_per_s,
            limits.max_acceleration_mm_per_s2,
            limits.max_jerk_mm_per_s3,
        )
    )
    if (np.abs(v) > vmax * (1 + 1e-9)).any() or (np.abs(acc) > amax * (1 + 1e-9)).any():
        return False
    if (np.abs(jerk) > jmax * (1 + JERK_SLACK)).any():
        return False
    if (np.linalg.norm(v, axis=1) > feed * (1 + 1e-9)).any():
        return False
    off = np.minimum(
        _segment_distance(r, np.asarray(a.start, float), c),
        _segment_distance(r, c, np.asarray(b.end, float)),
    )
    return bool(off.max() <= budget_mm and np.linalg.norm(r - c, axis=1).min() <= budget_mm)


def overlap_savings(text: str) -> tuple[float, int, list[float]]:
    """(cycle [s], stops between two straight feed moves, the largest overlap at each [s])."""
    machine = load_machine_config(DEFAULT_MACHINE)
    moves = parse_program(text)
    p = plan(moves, machine)
    tolerance_mm = 0.01  # the peer programs' G64 P0.01
    budget = tolerance_mm - REFERENCE_SHARE * machine.segmentation.chord_tolerance_mm
    path = list(p.path_moves or p.moves)
    starts = np.append(np.asarray(p.move_start_s), p.duration_s)
    found: list[float] = []
    for k in range(1, len(path)):
        a, b = path[k - 1], path[k]
        if not (isinstance(a, Linear) and isinstance(b, Linear)):
            continue
        t_b = float(starts[k])
        if np.linalg.norm(p.curve.evaluate(np.array([t_b]))[1]) > 1e-9:
            continue  # not a stop
        room = min(t_b - starts[k - 1], starts[k + 1] - t_b)  # within the two moves
        lo, hi = 0, int(room / GRID_S)  # grid steps: lo fits (0 always), hi does not
        hi += 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if _fits(p, t_b, mid * GRID_S, a, b, machine.limits, budget):
                lo = mid
            else:
                hi = mid
        found.append(lo * GRID_S)
    return p.duration_s, len(found), found


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", default=["pocket", "zigzag"], help="peer program names")
    args = ap.parse_args()
    peer = json.loads(PEER.read_text())["programs"]
    print("program   cycle s  stops  saved s  per stop ms (min/median/max)  cycle then  / LinuxCNC")
    for name in args.only:
        text = programs()[name].format(mode=MODES["g64"])
        cycle, stops, saved = overlap_savings(text)
        total = float(sum(saved))
        theirs = peer[name]["g64"]["cycle_s"]
        per = np.array(saved) * 1e3 if saved else np.zeros(1)
        print(
            f"{name:8s} {cycle:8.3f} {stops:6d} {total:8.3f}  "
            f"{per.min():6.1f} / {np.median(per):5.1f} / {per.max():5.1f}"
            f"          {cycle - total:8.3f}  {cycle / theirs:.3f} -> {(cycle - total) / theirs:.3f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
