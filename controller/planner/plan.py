"""The planner: moves -> a jerk-limited reference, with look-ahead. The only ruckig import.

1. Geometry (:mod:`gantry_sim.controller.planner.move_geometry`): chord vertices per move, tangents and curvatures at its
   ends, its 1-D limits (:mod:`gantry_sim.controller.planner.limits`): the feed is a PATH-speed cap.
2. Look-ahead: junction speeds (exact stops at corners, rapids and the end; tangent junctions
   keep their speed), backward and forward passes.
3. One 1-D Ruckig profile per move along its path s(t), from (0, v_in, 0) to (L, v_out, 0).
4. Pieces (:mod:`gantry_sim.controller.planner.pieces`): straight moves (G0/G1) are that profile projected on
   the line: exactly straight, and the feed holds along the diagonal. Arcs: the 1-D profile is
   sampled at the chord vertices (time, speed, tangential acceleration), each vertex gets the exact
   arc state (position on the arc, velocity v T, acceleration a_t T + v^2 k), and consecutive
   vertex states are joined by the closed-form constant-jerk piece of :mod:`gantry_sim.controller.planner.jerk3`
   (the default: it stays far closer to the arc than Ruckig's ``minimum_duration`` profile, see
   README "Planning"). A piece that would break an axis limit or the feed is made instead by a
   3-DoF Ruckig ``calculate`` between the same states with ``minimum_duration`` = the profile's
   time (counted in :attr:`Plan.ruckig_piece_count`); ``plan(..., arc_pieces="ruckig")`` makes
   every arc piece that way. Never ``intermediate_positions`` (the free Ruckig would send them to
   a cloud service).
5. All pieces are stored as constant-jerk phases (:mod:`gantry_sim.controller.planner.cubic`) and sampled vectorised.

If Ruckig rejects a piece, it is retried without ``minimum_duration`` (plain time-optimal,
synchronised); those retries are counted in :attr:`Plan.fallback_count`. A piece that still
fails raises :class:`PlanningError` naming the line: never a reference beyond the limits.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import ruckig

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import ConfigError, PlanningError
from gantry_sim.controller.moves import Move
from gantry_sim.controller.planner.junctions import feasible_junction_caps, junction_caps
from gantry_sim.controller.planner.lookahead import plan_junction_speeds
from gantry_sim.controller.planner.move_geometry import (
    MoveGeometry,
    limits_for_junctions,
    move_geometry,
)
from gantry_sim.controller.planner.pieces import MovePieces
from gantry_sim.controller.planner.profile import Profile1D
from gantry_sim.controller.planner.result import Plan
from gantry_sim.controller.planner.speedup import boosted_profile
from gantry_sim.controller.planner.travel import check_travel

__all__ = ["Plan", "plan"]

_OK = (ruckig.Result.Working, ruckig.Result.Finished)
#: Re-planning rounds (each lowers the offending junction caps by JUNCTION_BACKOFF); the last
#: round stops at the junctions still offending.
MAX_ROUNDS = 8
JUNCTION_BACKOFF = 0.6


def _calculate(otg: ruckig.Ruckig, inp: ruckig.InputParameter, traj: ruckig.Trajectory):
    """``otg.calculate``; Ruckig raises RuckigError on some numerically hard inputs: a failure."""
    try:
        return otg.calculate(inp, traj)
    except ruckig.RuckigError as exc:
        return f"RuckigError: {str(exc).strip().splitlines()[0]}"


def _profile_phases(traj: ruckig.Trajectory, dof: int) -> tuple[list, list, list, list, list]:
    """Constant-jerk phases (dur, p, v, a, j) of one DoF of a Ruckig trajectory."""
    prof = traj.profiles[0][dof]
    dur, p, v, a, j = list(prof.t), prof.p[:7], prof.v[:7], prof.a[:7], list(prof.j)
    brake = prof.brake
    if brake.duration > 0:
        dur = list(brake.t) + dur
        p, v, a, j = brake.p[:2] + p, brake.v[:2] + v, brake.a[:2] + a, list(brake.j) + j
    return dur, p, v, a, j


class _Planner(MovePieces):
    """:class:`MovePieces` with Ruckig: the 1-D profiles and the pieces the closed form fails."""

    def __init__(self, machine: MachineConfig, pieces: str) -> None:
        super().__init__(machine, pieces)
        lim = machine.limits
        self.r1, self.in1, self.tr1 = (
            ruckig.Ruckig(1),
            ruckig.InputParameter(1),
            ruckig.Trajectory(1),
        )
        self.r3, self.in3, self.tr3 = (
            ruckig.Ruckig(3),
            ruckig.InputParameter(3),
            ruckig.Trajectory(3),
        )
        self.in3.max_velocity = list(lim.max_velocity_mm_per_s)
        self.in3.max_acceleration = list(lim.max_acceleration_mm_per_s2)
        self.in3.max_jerk = list(lim.max_jerk_mm_per_s3)
        self.boost_cache: dict = {}

    def path_profile(self, g: MoveGeometry, v_in: float, v_out: float) -> Profile1D:
        """1-D profile along the move."""
        inp, lim = self.in1, g.limits
        inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [v_in], [0.0]
        inp.target_position, inp.target_velocity, inp.target_acceleration = (
            [g.length_mm],
            [v_out],
            [0.0],
        )
        inp.max_velocity = [lim.cap_mm_per_s]
        inp.max_acceleration = [lim.acc_mm_per_s2]
        inp.max_jerk = [lim.jerk_mm_per_s3]
        res = _calculate(self.r1, inp, self.tr1)
        if res not in _OK:
            raise PlanningError(
                f"Ruckig could not plan the speed profile ({res})", line=g.move.line
            )
        ph = np.array(_profile_phases(self.tr1, 0), dtype=float).T
        if ph[:, 2].min() < -1e-9 * max(lim.cap_mm_per_s, 1.0):
            raise PlanningError("the speed profile would reverse along the path", line=g.move.line)
        return Profile1D(ph)

    def boosted_profile(self, g: MoveGeometry, v_in: float, v_out: float, ph: Profile1D):
        """Faster 1-D profiles for an arc that ramps, fastest first (see :mod:`gantry_sim.controller.planner.speedup`)."""
        return boosted_profile(g, v_in, v_out, ph, self.limits, self.profile_1d, self.boost_cache)

    def profile_1d(self, length, v_in, v_out, cap, acc, jerk) -> Profile1D | None:
        """A 1-D profile from and to zero acceleration, or None on failure."""
        inp = self.in1
        inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [v_in], [0.0]
        inp.target_position, inp.target_velocity = [length], [v_out]
        inp.target_acceleration = [0.0]
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = [cap], [acc], [jerk]
        if _calculate(self.r1, inp, self.tr1) not in _OK:
            return None
        ph = np.array(_profile_phases(self.tr1, 0), dtype=float).T
        return Profile1D(ph) if ph[:, 2].min() >= -1e-9 * max(cap, 1.0) else None

    def ruckig_piece(self, g, p0, v0, a0, p1, v1, a1, min_duration: float) -> float:
        """One 3-DoF Ruckig state-to-state piece (time synchronised); returns its duration [s]."""
        inp, tr = self.in3, self.tr3
        inp.current_position, inp.current_velocity = p0.tolist(), v0.tolist()
        inp.current_acceleration = a0.tolist()
        inp.target_position, inp.target_velocity = p1.tolist(), v1.tolist()
        inp.target_acceleration = a1.tolist()
        inp.minimum_duration = float(min_duration)
        res = _calculate(self.r3, inp, tr)
        if res not in _OK:
            self.fallbacks += 1
            inp.minimum_duration = None
            res = _calculate(self.r3, inp, tr)
            if res not in _OK:
                raise PlanningError(
                    f"Ruckig could not join two chord vertices ({res}) even without a "
                    "minimum duration; lower the feed or check the machine limits",
                    line=g.move.line,
                )
        dur = tr.duration
        if dur > min_duration * (1 + 1e-6) + 1e-9:
            self.stretched += 1
        for i in range(3):
            self.out.add(i, *_profile_phases(tr, i))
        return dur

    def piece_samples(self, duration: float) -> tuple[np.ndarray, np.ndarray]:
        """Positions [mm] and velocities [mm/s] (25, 3) of the last Ruckig piece over its
        ``duration`` [s]."""
        pv = [self.tr3.at_time(t) for t in np.linspace(0.0, duration, 25)]
        return np.array([x[0] for x in pv]), np.array([x[1] for x in pv])


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
    seg = machine.segmentation
    geoms = [move_geometry(m, machine, feed_override_pct / 100.0) for m in moves]
    active = [g for g in geoms if g.length_mm > 1e-9]
    caps, states = junction_caps(active, machine)
    active = limits_for_junctions(active, caps, machine)
    caps = feasible_junction_caps(active, caps, states, machine)
    for rnd in range(MAX_ROUNDS + 1):
        speeds = plan_junction_speeds([g.limits for g in active], caps)
        pl, bad = _Planner(machine, arc_pieces), set()
        clock, starts = 0.0, []
        for b, g in enumerate(active):
            starts.append(clock)
            ph = pl.path_profile(g, speeds[b], speeds[b + 1])
            if g.is_arc:
                s_in, s_out = states[b].at(speeds[b]), states[b + 1].at(speeds[b + 1])
                fast = pl.boosted_profile(g, speeds[b], speeds[b + 1], ph)
                dur, bad_in, bad_out = pl.arc(g, ph, s_in, s_out, fast)
                clock += dur
                bad |= {b} if bad_in else set()
                bad |= {b + 1} if bad_out else set()
            else:
                clock += pl.straight(g, ph)
        if not bad:
            break
        for b in bad:  # lower the offending junctions; in the last round, stop there
            caps[b] = 0.0 if rnd == MAX_ROUNDS - 1 else JUNCTION_BACKOFF * speeds[b]
    end = np.array(moves[-1].end if moves else (0.0, 0.0, 0.0), dtype=float)
    move_start = np.asarray(starts, dtype=float)
    lines = np.asarray([g.move.line for g in active], dtype=np.int64)
    for arr in (end, move_start, lines):
        arr.setflags(write=False)
    return Plan(
        moves=moves,
        duration_s=clock,
        segment_count=sum(len(g.vertices) - 1 for g in geoms),
        chord_tolerance_mm=seg.chord_tolerance_mm,
        vertices=tuple(g.vertices for g in geoms),
        fallback_count=pl.fallbacks,
        stretched_count=pl.stretched,
        ruckig_piece_count=pl.ruckig_pieces,
        curve=pl.out.build(),
        move_start_s=move_start,
        move_lines=lines,
        end_mm=end,
    )
