"""A chain's preparation: its 1-D profile, cut at its moves' ends, and each arc's candidates.

:func:`chain_preps` prepares many chains (:mod:`~gantry_sim.controller.planner.chains`) at
once: each chain's Ruckig profile from the speeds at its ends, then all profiles cut at their
moves' ends in one vectorised inversion (the same numbers as one by one), then per arc its
faster candidate profiles (:mod:`~gantry_sim.controller.planner.speedup`, single-arc chains)
and its end states. :mod:`~gantry_sim.controller.planner.chain_plan` makes the pieces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import PlannerFailure, PlanningError
from gantry_sim.controller.moves import PathMove
from gantry_sim.controller.planner.chains import move_bounds, split_profile
from gantry_sim.controller.planner.junctions import EndState, JunctionState
from gantry_sim.controller.planner.limits import BlockLimits
from gantry_sim.controller.planner.move_geometry import ArcGeometry, MoveGeometry
from gantry_sim.controller.planner.profile import Profile1D, invert_many
from gantry_sim.controller.planner.ramp_family import advance
from gantry_sim.controller.planner.ruckig_solver import (
    RUCKIG_MAX_DURATION_S,
    ProfileReverses,
    RuckigRejected,
    RuckigSolver,
    too_slow_for_ruckig,
)
from gantry_sim.controller.planner.speedup import boosted_profile

__all__ = ["ChainPrep", "ChainSetup", "chain_prep", "chain_preps"]


@dataclass(frozen=True)
class ChainSetup:
    """What every chain of a plan is planned with."""

    active: list[MoveGeometry]
    states: list[JunctionState]
    machine: MachineConfig
    solver: RuckigSolver
    arc_pieces: str
    smoothing: list[float]
    boost_cache: dict
    blend_arcs: frozenset[int]
    #: whether an arc whose ends are not both at rest may try the saturated ramps (the first
    #: round only: see :func:`~gantry_sim.controller.planner.rounds.settle_chains`)
    saturated_moving: bool = True


@dataclass(frozen=True, eq=False)
class ChainPrep:
    """A chain's profile cut at its moves' ends (``parts``), the speeds [mm/s] and tangential
    accelerations [mm/s^2] at its junctions, and per arc (its index in the chain, its
    geometry, its faster candidate profiles, its end states)."""

    parts: list[Profile1D]
    speeds: np.ndarray
    acc_t: np.ndarray
    arcs: list[tuple[int, ArcGeometry, tuple[Profile1D, ...], EndState, EndState]]


def chain_prep(
    setup: ChainSetup, first: int, stop: int, lim: BlockLimits, speeds: np.ndarray
) -> ChainPrep:
    """The profile of moves ``first..stop-1`` under ``lim``, cut per move, and each arc's
    candidates and end states."""
    return chain_preps(setup, [(first, stop, lim)], speeds)[0]


def chain_preps(
    setup: ChainSetup, chains: list[tuple[int, int, BlockLimits]], speeds: np.ndarray
) -> list[ChainPrep]:
    """:func:`_chain_prep` of several chains (first, stop, limits); their profiles are cut at
    their moves' ends in one vectorised inversion."""
    active = setup.active
    profs = [
        _chain_profile(setup.solver, active[first:stop], lim, speeds[first], speeds[stop])
        for first, stop, lim in chains
    ]
    lengths = [[g.length_mm for g in active[first:stop]] for first, stop, _ in chains]
    multi = [i for i, (first, stop, _) in enumerate(chains) if stop - first > 1]
    cuts = dict(
        zip(
            multi,
            invert_many([(profs[i], move_bounds(lengths[i])[1:-1]) for i in multi]),
            strict=True,
        )
    )
    return [
        _prep_one(setup, first, stop, prof, ls, speeds, cuts.get(i))
        for i, ((first, stop, _), prof, ls) in enumerate(zip(chains, profs, lengths, strict=True))
    ]


def _prep_one(
    setup: ChainSetup,
    first: int,
    stop: int,
    prof: Profile1D,
    lengths: list[float],
    speeds: np.ndarray,
    cut: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
) -> ChainPrep:
    """One chain's :class:`ChainPrep` from its profile ``prof`` (``cut``: its inversion at the
    inner junctions)."""
    active, states, limits = setup.active, setup.states, setup.machine.limits
    v = np.empty(stop - first + 1)
    acc_t = np.zeros(stop - first + 1)
    v[0], v[-1] = speeds[first], speeds[stop]
    if stop - first == 1:
        parts = [prof]
    else:
        parts, v[1:-1], acc_t[1:-1] = split_profile(prof, lengths, cut)
    arcs = []
    for k, part in enumerate(parts):
        b, g = first + k, active[first + k]
        if not isinstance(g, ArcGeometry):
            continue
        # no faster candidates for a G64 blend arc (a chord or two at a polyline's corner):
        # on 3,000 polyline blocks whose corners all blend, they cost 3.0 of 13.5 s of
        # planning and gained 0.15 % of the cycle
        fast = (
            boosted_profile(
                g,
                v[k],
                v[k + 1],
                part,
                limits,
                setup.solver,
                setup.boost_cache,
                saturated=setup.saturated_moving or v[k] == v[k + 1] == 0.0,
            )
            if stop - first == 1 and id(g.move) not in setup.blend_arcs
            else ()
        )
        arcs.append(
            (k, g, fast, states[b].at(v[k], acc_t[k]), states[b + 1].at(v[k + 1], acc_t[k + 1]))
        )
    return ChainPrep(parts, v, acc_t, arcs)


#: A chain with a curved move, moving at both ends, whose speed cap is at most this share above
#: its faster end keeps to that end's speed (:func:`_chain_profile`).
NEAR_CAP_SHARE = 0.01
#: End speeds this close (a share of the larger) are one speed where the profile between them
#: would reverse (:func:`_path_profile`): 1e-9 covered a few nanometres of a blended line; 0.1 um
#: of an ArcWelder arc left between the blends of its two corners (a Slic3r Benchy, line 61)
#: had end speeds 4e-8 apart, the most its length allows, and Ruckig's profile went back.
SAME_SPEED_SHARE = 1e-6
#: How far [share] the acceleration of a direct ramp over a block's exact length may pass the
#: limit, and its end position and speed may miss (rounding: :func:`_direct_ramp`).
EDGE_ACC_SHARE = 1e-9
#: The cap a profile that starts or ends at it is given again where Ruckig's profile would
#: reverse, as a share above it (rounding: :func:`_path_profile`).
CAP_HAIR = 1e-12


def _chain_profile(
    solver: RuckigSolver, moves: list[MoveGeometry], lim: BlockLimits, v_in: float, v_out: float
) -> Profile1D:
    """The 1-D profile of the chain ``moves`` from ``v_in`` to ``v_out`` [mm/s] under ``lim``.

    Where the chain has a curved move, is moving at both ends and its cap is at most
    :data:`NEAR_CAP_SHARE` above the faster end, the profile keeps to that end's speed instead
    of bumping up to the cap in between: the bump gains at most that share of the chain's time,
    and it costs the junctions. Its phase switches lie fractions of a millisecond from the
    junctions, and each becomes a vertex (the pieces follow the profile exactly), so the piece
    next to a junction had that long to smooth the junction's curvature jump; and a bump up to
    the feed leaves the smoothing no room below it. A junction's cap is found for pieces at a
    constant speed (:func:`~gantry_sim.controller.planner.junctions.feasible_junction_caps`),
    which its bisection leaves a hair below the cap: on a 3-D finishing raster in G64 (CAMotics'
    flower mold, 3,000 lines), 2,894 of 4,790 junctions offended in the first round and were
    backed off over five rounds to 0.73 of their speed; 190 offend now, the cycle 0.45 %
    shorter. A profile that cannot keep to that speed (the ends too far apart for the chain's
    length under the lower cap) is planned to the cap as before.
    """
    top = max(v_in, v_out)
    near = min(v_in, v_out) > 0.0 and top < lim.cap_mm_per_s <= top * (1.0 + NEAR_CAP_SHARE)
    if near and any(isinstance(g, ArcGeometry) for g in moves):
        try:
            return solver.profile(
                lim.length_mm, v_in, v_out, top, lim.acc_mm_per_s2, lim.jerk_mm_per_s3
            )
        except (ProfileReverses, RuckigRejected):
            pass
    return _path_profile(solver, moves[0].move, lim, v_in, v_out)


def _path_profile(
    solver: RuckigSolver, move: PathMove, lim: BlockLimits, v_in: float, v_out: float
) -> Profile1D:
    """The 1-D profile of a block (one move, or a chain starting with ``move``) from ``v_in``
    to ``v_out`` [mm/s] under its limits."""
    try:
        return solver.profile(
            lim.length_mm, v_in, v_out, lim.cap_mm_per_s, lim.acc_mm_per_s2, lim.jerk_mm_per_s3
        )
    except RuckigRejected as exc:
        cruise_s = lim.length_mm / lim.cap_mm_per_s if lim.cap_mm_per_s > 0 else math.inf
        if cruise_s > RUCKIG_MAX_DURATION_S:  # a feed of 1e-300, where Ruckig finds none
            raise too_slow_for_ruckig(f"the {move.kind} move", cruise_s, move.line) from None
        raise PlannerFailure(
            f"no speed profile along this {move.kind} move fits the machine's limits "
            f"(Ruckig: {exc.reason})",
            move.line,
        ) from None
    except ProfileReverses:
        cap = lim.cap_mm_per_s
        if max(v_in, v_out) >= cap * (1.0 - CAP_HAIR) and lim.length_mm > 0:
            # an end at the cap, the other as low as the block's length allows (the look-ahead
            # keeps 1e-9 of it in reserve): Ruckig 0.19 took a start exactly at its velocity
            # limit for one beyond it and went back along the path (a transition of 1.6 mm
            # shedding 2.7 of 50 mm/s at 155 mm/s^2); with the limit a hair above, its profile
            # decelerates at once, and its top speed is the cap to rounding (2e-14 of 50 mm/s)
            try:
                return solver.profile(
                    lim.length_mm,
                    v_in,
                    v_out,
                    cap * (1.0 + CAP_HAIR),
                    lim.acc_mm_per_s2,
                    lim.jerk_mm_per_s3,
                )
            except (ProfileReverses, RuckigRejected):
                pass
        if v_out != v_in and abs(v_out - v_in) <= SAME_SPEED_SHARE * max(v_in, v_out):
            # a few nanometres left of a blended line between its blends: the look-ahead's
            # end speeds differ in their last digits (3e-11 of 52 mm/s over 1.8 nm), which no
            # profile can change with zero acceleration at both ends (Ruckig's went back
            # 52 mm/s and took 0.13 s); at one speed it is a cruise of 34 ns (the next block
            # starts 1e-6 of the speed away at most: 5e-5 mm/s at 50 mm/s)
            return _path_profile(solver, move, lim, v_in, v_in)
        ramp = _direct_ramp(lim, v_in, v_out)
        if ramp is not None:
            return ramp
        raise PlanningError(
            "the speed profile would reverse along the path",
            line=move.line,
            file=getattr(move, "file", None),  # (a Transition is the program's)
        ) from None


def _direct_ramp(lim: BlockLimits, v_in: float, v_out: float) -> Profile1D | None:
    """One jerk-limited ramp from ``v_in`` to ``v_out`` [mm/s] over exactly the block's length,
    where the look-ahead gave the block the most change of speed its length allows and Ruckig's
    profile went back along the path instead (its direct ramp overshot the length by rounding:
    on a machine file with 31 mm/s^2 and 3.2e6 mm/s^3 on X, a G5.2 ramping from 0.012 to 4.5
    mm/s over 2.29 mm at 4.42 mm/s^2). The ramp's acceleration is the one whose ramp covers
    the length exactly (within :data:`EDGE_ACC_SHARE` of the limit); None where there is none
    (another shape of profile, or a change the length does not allow)."""
    dv, length = abs(v_out - v_in), lim.length_mm
    mean = 0.5 * (v_in + v_out)
    jerk = lim.jerk_mm_per_s3
    if dv == 0.0 or mean <= 0.0 or max(v_in, v_out) > lim.cap_mm_per_s:
        return None
    # a trapezoidal ramp of peak acceleration a covers mean (dv / a + a / j): the smaller root
    # of a^2 / j - q a + dv = 0, in the form without cancellation
    q = length / mean
    disc = q * q - 4.0 * dv / jerk
    if disc < 0.0:
        return None
    acc = 2.0 * dv / (q + math.sqrt(disc))
    if not 0.0 < acc <= lim.acc_mm_per_s2 * (1.0 + EDGE_ACC_SHARE) or dv * jerk < acc * acc:
        return None
    acc = min(acc, lim.acc_mm_per_s2)
    sign = 1.0 if v_out > v_in else -1.0
    t_jerk, t_flat = acc / jerk, dv / acc - acc / jerk
    rows = []
    s, v, a = 0.0, v_in, 0.0
    for dur, j in ((t_jerk, sign * jerk), (t_flat, 0.0), (t_jerk, -sign * jerk)):
        rows.append((dur, s, v, a, j))
        s, v, a = advance(dur, s, v, a, j)
    if abs(s - length) > EDGE_ACC_SHARE * length or abs(v - v_out) > EDGE_ACC_SHARE * dv:
        return None
    return Profile1D(np.array(rows, dtype=float))
