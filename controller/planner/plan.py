"""The planner's orchestration: moves -> a jerk-limited reference, with look-ahead.

1. Geometry (:mod:`~gantry_sim.controller.planner.move_geometry`): chord vertices per move,
   tangents and curvatures at its ends, its 1-D limits (:mod:`~gantry_sim.controller.planner.limits`):
   the feed is a PATH-speed cap.
2. Junctions and look-ahead (:mod:`~gantry_sim.controller.planner.junctions`,
   :mod:`~gantry_sim.controller.planner.lookahead`): exact stops at corners, rapids and the end;
   tangent junctions keep their speed; backward and forward passes.
3. One 1-D Ruckig profile per move along its path s(t), from (0, v_in, 0) to (L, v_out, 0)
   (:class:`~gantry_sim.controller.planner.ruckig_solver.RuckigSolver`, built once per plan), and
   faster candidates for arcs that ramp (:mod:`~gantry_sim.controller.planner.speedup`).
4. Pieces (:mod:`~gantry_sim.controller.planner.pieces`): straight moves (G0/G1) are that profile
   projected on the line: exactly straight, and the feed holds along the diagonal. Arcs: the 1-D
   profile is sampled at the chord vertices (time, speed, tangential acceleration), each vertex
   gets the exact arc state (position on the arc, velocity v T, acceleration a_t T + v^2 k), and
   consecutive vertex states are joined by the closed-form constant-jerk piece of
   :mod:`~gantry_sim.controller.planner.jerk3` (the default: it stays far closer to the arc than
   Ruckig's ``minimum_duration`` profile, see README "Planning"). A piece that would break an
   axis limit or the feed is made instead by a 3-DoF Ruckig piece between the same states with
   ``minimum_duration`` = the profile's time (counted in :attr:`Plan.ruckig_piece_count`);
   ``plan(..., arc_pieces="ruckig")`` makes every arc piece that way.
5. All pieces are stored as constant-jerk phases (:mod:`~gantry_sim.controller.planner.cubic`)
   and sampled vectorised.

Steps 3-4 run in a re-planning loop (:func:`_replan_until_junctions_hold`): a piece next to a
moving junction that leaves the arc, or that Ruckig had to stretch, lowers that junction's speed
and the program is planned again. A Ruckig piece that fails even without ``minimum_duration``
raises :class:`PlanningError` naming the line: never a reference beyond the limits.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import ConfigError, PlanningError
from gantry_sim.controller.moves import Move
from gantry_sim.controller.planner.junctions import (
    JunctionState,
    feasible_junction_caps,
    junction_caps,
)
from gantry_sim.controller.planner.lookahead import plan_junction_speeds
from gantry_sim.controller.planner.move_geometry import (
    ArcGeometry,
    MoveGeometry,
    limits_for_junctions,
    move_geometry,
)
from gantry_sim.controller.planner.pieces import MovePieces
from gantry_sim.controller.planner.profile import Profile1D
from gantry_sim.controller.planner.result import Plan
from gantry_sim.controller.planner.ruckig_solver import (
    ProfileReverses,
    RuckigRejected,
    RuckigSolver,
)
from gantry_sim.controller.planner.speedup import boosted_profile
from gantry_sim.controller.planner.travel import check_travel

__all__ = ["Plan", "plan"]

#: Re-planning rounds (each lowers the offending junction caps by JUNCTION_BACKOFF); the last
#: round stops at the junctions still offending.
MAX_ROUNDS = 8
JUNCTION_BACKOFF = 0.6


def plan(
    moves: Sequence[Move],
    machine: MachineConfig,
    *,
    feed_override_pct: float = 100.0,
    arc_pieces: str = "jerk3",
) -> Plan:
    """Plan ``moves`` on ``machine`` (see the module docstring).

    Args:
        moves: the interpreter's moves; the machine is at rest at ``moves[0].start``.
        machine: limits, travel, segmentation.
        feed_override_pct: scales every programmed feed (not rapids) [%], > 0.
        arc_pieces: "jerk3" (default: closed-form constant-jerk pieces, Ruckig where they would
            break a limit) or "ruckig" (every arc piece by Ruckig; kept for comparison).

    Raises:
        ConfigError: a feed override that is not a finite number > 0.
        PlanningError: a move leaving the travel, an arc needing too many chords, or a piece
            Ruckig cannot plan (each names the line).
    """
    if not (np.isfinite(feed_override_pct) and feed_override_pct > 0):
        raise ConfigError(f"feed override must be a number > 0 %, got {feed_override_pct}")
    if arc_pieces not in ("jerk3", "ruckig"):
        raise ConfigError(f"arc_pieces must be 'jerk3' or 'ruckig', got {arc_pieces!r}")
    moves = tuple(moves)
    check_travel(moves, machine.travel)
    lim, seg = machine.limits, machine.segmentation
    geoms = [move_geometry(m, lim, seg, feed_override_pct / 100.0) for m in moves]
    active = [g for g in geoms if g.length_mm > 1e-9]
    caps, states = junction_caps(active, lim, seg.chord_tolerance_mm)
    active = limits_for_junctions(active, caps, lim)
    caps = feasible_junction_caps(active, caps, states, lim)
    solver = RuckigSolver(machine.limits)
    done = _replan_until_junctions_hold(active, caps, states, machine, solver, arc_pieces)
    end = np.array(moves[-1].end if moves else (0.0, 0.0, 0.0), dtype=float)
    move_start = np.asarray(done.move_start_s, dtype=float)
    lines = np.asarray([g.move.line for g in active], dtype=np.int64)
    for arr in (end, move_start, lines):
        arr.setflags(write=False)
    return Plan(
        moves=moves,
        duration_s=done.duration_s,
        segment_count=sum(len(g.vertices) - 1 for g in geoms),
        chord_tolerance_mm=machine.segmentation.chord_tolerance_mm,
        vertices=tuple(g.vertices for g in geoms),
        ruckig_piece_count=done.pieces.ruckig_pieces,
        curve=done.pieces.out.build(),
        move_start_s=move_start,
        move_lines=lines,
        end_mm=end,
    )


@dataclass
class _Round:
    """One planning round: the pieces, the duration [s], each move's start time [s], and the
    junctions whose neighbouring pieces left the arc (their speed must come down)."""

    pieces: MovePieces
    duration_s: float
    move_start_s: list[float]
    bad_junctions: set[int]


def _replan_until_junctions_hold(
    active: list[MoveGeometry],
    caps: np.ndarray,
    states: list[JunctionState],
    machine: MachineConfig,
    solver: RuckigSolver,
    arc_pieces: str,
) -> _Round:
    """Plan the moves; while pieces next to moving junctions leave the arc, lower those
    junctions' caps (``caps`` is changed) by :data:`JUNCTION_BACKOFF` and plan again, at most
    :data:`MAX_ROUNDS` times; in the last round the junctions still offending become stops."""
    for rnd in range(MAX_ROUNDS + 1):
        speeds = plan_junction_speeds([g.limits for g in active], caps)
        done = _plan_round(active, speeds, states, machine, solver, arc_pieces)
        if not done.bad_junctions:
            break
        for b in done.bad_junctions:
            caps[b] = 0.0 if rnd == MAX_ROUNDS - 1 else JUNCTION_BACKOFF * speeds[b]
    return done


def _plan_round(
    active: list[MoveGeometry],
    speeds: np.ndarray,
    states: list[JunctionState],
    machine: MachineConfig,
    solver: RuckigSolver,
    arc_pieces: str,
) -> _Round:
    """Every move's profile and pieces for the junction speeds ``speeds`` [mm/s]."""
    tol = machine.segmentation.chord_tolerance_mm
    pieces, bad = MovePieces(machine.limits, tol, arc_pieces, solver), set()
    boost_cache: dict = {}
    clock, starts = 0.0, []
    for b, g in enumerate(active):
        starts.append(clock)
        prof = _path_profile(solver, g, speeds[b], speeds[b + 1])
        if isinstance(g, ArcGeometry):
            fast = boosted_profile(
                g, speeds[b], speeds[b + 1], prof, machine.limits, solver, boost_cache
            )
            s_in, s_out = states[b].at(speeds[b]), states[b + 1].at(speeds[b + 1])
            dur, bad_in, bad_out = pieces.arc(g, prof, s_in, s_out, fast)
            clock += dur
            bad |= {b} if bad_in else set()
            bad |= {b + 1} if bad_out else set()
        else:
            clock += pieces.straight(g, prof)
    return _Round(pieces, clock, starts, bad)


def _path_profile(solver: RuckigSolver, g: MoveGeometry, v_in: float, v_out: float) -> Profile1D:
    """The move's 1-D profile from ``v_in`` to ``v_out`` [mm/s] under its block limits."""
    lim = g.limits
    try:
        return solver.profile(
            g.length_mm, v_in, v_out, lim.cap_mm_per_s, lim.acc_mm_per_s2, lim.jerk_mm_per_s3
        )
    except RuckigRejected as exc:
        raise PlanningError(
            f"Ruckig could not plan the speed profile ({exc.reason})", line=g.move.line
        ) from None
    except ProfileReverses:
        raise PlanningError(
            "the speed profile would reverse along the path", line=g.move.line
        ) from None
