"""One re-planning round's chains: profile, cut, candidates, and pieces, in vectorised batches.

A chain (:mod:`~gantry_sim.controller.planner.chains`) is planned from the speeds at its two
ends: its 1-D Ruckig profile, cut at its moves' ends; straight moves are that profile projected
on the line, arcs are joined through their exact vertex states
(:class:`~gantry_sim.controller.planner.pieces.MovePieces`), trying each single arc's faster
candidates first (:mod:`~gantry_sim.controller.planner.speedup`).

The work of many chains is done at once (:func:`plan_chains`): their profiles are cut in one
inversion, and the vertex states, closed-form pieces and limit checks of every arc's first
candidate are computed in one batch of about :data:`BATCH_PIECES` pieces; what stays per arc is
the choice among its results. Every number is computed element by element as when planned
alone, so batching does not change the plan by a bit.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import PlannerFailure, PlanningError
from gantry_sim.controller.moves import Move
from gantry_sim.controller.planner.chains import move_bounds, split_profile
from gantry_sim.controller.planner.cubic import Chunk
from gantry_sim.controller.planner.junctions import EndState, JunctionState
from gantry_sim.controller.planner.limits import BlockLimits
from gantry_sim.controller.planner.move_geometry import ArcGeometry, MoveGeometry
from gantry_sim.controller.planner.pieces import MovePieces, Pieces
from gantry_sim.controller.planner.profile import Profile1D, invert_many
from gantry_sim.controller.planner.ruckig_solver import (
    ProfileReverses,
    RuckigRejected,
    RuckigSolver,
)
from gantry_sim.controller.planner.speedup import boosted_profile

__all__ = ["BATCH_PIECES", "Chain", "ChainKey", "ChainSetup", "Chunk", "plan_chains"]


@dataclass(frozen=True, eq=False)
class Chain:
    """One chain's pieces: ``chunk``, its duration [s], each move's start [s] from the chain's
    start, the junctions whose pieces failed, Ruckig pieces used, and the profile's speed
    [mm/s] at the junctions inside the chain."""

    chunk: Chunk
    duration_s: float
    starts_s: tuple[float, ...]
    bad: frozenset[int]
    ruckig_pieces: int
    inner_speeds: np.ndarray


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


#: Closed-form pieces computed in one vectorised batch (about this many pieces at most: the
#: batch's arrays take about 1 kB per piece).
BATCH_PIECES = 20_000

#: A chain by (first move, stop, speed in [mm/s], speed out [mm/s]).
ChainKey = tuple[int, int, float, float]


def plan_chains(
    setup: ChainSetup, todo: list[tuple[ChainKey, BlockLimits]], speeds: np.ndarray
) -> dict[ChainKey, Chain]:
    """The chains ``todo`` (key (first, stop, speed in, speed out), limits), planned in batches
    of about :data:`BATCH_PIECES` pieces: the chains' profiles first, cut at their moves' ends
    all at once, then the closed-form pieces of the first candidate of every arc of the batch
    at once, then each chain's pieces."""
    out: dict[ChainKey, Chain] = {}
    batch: list[tuple[ChainKey, BlockLimits]] = []
    size = 0
    for key, lim in todo:
        batch.append((key, lim))
        size += 1 + sum(
            g.u.size for g in setup.active[key[0] : key[1]] if isinstance(g, ArcGeometry)
        )
        if size >= BATCH_PIECES:
            _plan_batch(setup, batch, speeds, out)
            batch, size = [], 0
    _plan_batch(setup, batch, speeds, out)
    return out


def _plan_batch(
    setup: ChainSetup,
    batch: list[tuple[ChainKey, BlockLimits]],
    speeds: np.ndarray,
    out: dict[ChainKey, Chain],
) -> None:
    """Plan the chains of ``batch`` into ``out``."""
    preps = _chain_preps(setup, [(key[0], key[1], lim) for key, lim in batch], speeds)
    requests = []
    for prep in preps:
        for k, g, fast, s_in, s_out in prep.arcs:
            requests.append((g, fast[0] if fast else prep.parts[k], s_in, s_out))
    maker = MovePieces(
        setup.machine.limits,
        setup.machine.segmentation.chord_tolerance_mm,
        setup.arc_pieces,
        setup.solver,
    )
    found = iter(maker.closed_forms(requests)) if setup.arc_pieces == "jerk3" else None
    for (key, lim), prep in zip(batch, preps, strict=True):
        first = None if found is None else {k: next(found) for k, *_ in prep.arcs}
        out[key] = _plan_chain(setup, key[0], key[1], lim, speeds, prep, first)


#: Tries of a chain's profile with slower limits (each: :data:`SLOWER_CAP` of the speed cap,
#: :data:`SLOWER_RAMP` of the acceleration and jerk) when a Ruckig piece inside an arc with
#: no moving junction left the arc or exceeded the feed.
SLOWER_TRIES = 6
SLOWER_CAP = 0.995
SLOWER_RAMP = 0.8


def _plan_chain(
    setup: ChainSetup,
    first: int,
    stop: int,
    lim: BlockLimits,
    speeds: np.ndarray,
    prep: _Prep | None = None,
    pre: dict[int, Pieces] | None = None,
) -> Chain:
    """The pieces of moves ``first..stop-1`` (one chain with the limits ``lim``) from
    ``speeds[first]`` to ``speeds[stop]`` [mm/s]; slower (:data:`SLOWER_TRIES`) while a piece
    inside an arc with no moving junction leaves the arc or exceeds the feed. ``prep`` and
    ``pre``: the chain's preparation for ``lim`` and the closed-form pieces of each arc's first
    candidate, when already made."""
    floor = max(float(speeds[first]), float(speeds[stop]))
    for _ in range(SLOWER_TRIES):
        if prep is None:
            prep = _chain_prep(setup, first, stop, lim, speeds)
        chain, off = _chain_pieces(setup, first, stop, prep, pre)
        if not off:
            break
        lim = replace(
            lim,
            cap_mm_per_s=max(SLOWER_CAP * lim.cap_mm_per_s, floor),
            acc_mm_per_s2=SLOWER_RAMP * lim.acc_mm_per_s2,
            jerk_mm_per_s3=SLOWER_RAMP * lim.jerk_mm_per_s3,
        )
        prep, pre = None, None
    return chain


@dataclass(frozen=True, eq=False)
class _Prep:
    """A chain's profile cut at its moves' ends (``parts``), the speeds [mm/s] and tangential
    accelerations [mm/s^2] at its junctions, and per arc (its index in the chain, its
    geometry, its faster candidate profiles, its end states)."""

    parts: list[Profile1D]
    speeds: np.ndarray
    acc_t: np.ndarray
    arcs: list[tuple[int, ArcGeometry, tuple[Profile1D, ...], EndState, EndState]]


def _chain_prep(
    setup: ChainSetup, first: int, stop: int, lim: BlockLimits, speeds: np.ndarray
) -> _Prep:
    """The profile of moves ``first..stop-1`` under ``lim``, cut per move, and each arc's
    candidates and end states."""
    return _chain_preps(setup, [(first, stop, lim)], speeds)[0]


def _chain_preps(
    setup: ChainSetup, chains: list[tuple[int, int, BlockLimits]], speeds: np.ndarray
) -> list[_Prep]:
    """:func:`_chain_prep` of several chains (first, stop, limits); their profiles are cut at
    their moves' ends in one vectorised inversion."""
    active = setup.active
    profs = [
        _path_profile(setup.solver, active[first].move, lim, speeds[first], speeds[stop])
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
) -> _Prep:
    """One chain's :class:`_Prep` from its profile ``prof`` (``cut``: its inversion at the
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
        fast = (
            boosted_profile(
                g,
                v[k],
                v[k + 1],
                part,
                limits,
                setup.solver,
                setup.boost_cache,
                saturated=id(g.move) not in setup.blend_arcs,
            )
            if stop - first == 1
            else ()
        )
        arcs.append(
            (k, g, fast, states[b].at(v[k], acc_t[k]), states[b + 1].at(v[k + 1], acc_t[k + 1]))
        )
    return _Prep(parts, v, acc_t, arcs)


def _chain_pieces(
    setup: ChainSetup, first: int, stop: int, prep: _Prep, pre: dict[int, Pieces] | None
) -> tuple[Chain, int]:
    """One try of :func:`_plan_chain`: the chain, and how many pieces were off."""
    active = setup.active
    tol = setup.machine.segmentation.chord_tolerance_mm
    pieces = MovePieces(setup.machine.limits, tol, setup.arc_pieces, setup.solver)
    arcs = {k: (fast, s_in, s_out) for k, _, fast, s_in, s_out in prep.arcs}
    clock, starts, bad = 0.0, [], set()
    for k, part in enumerate(prep.parts):
        b, g = first + k, active[first + k]
        starts.append(clock)
        if not isinstance(g, ArcGeometry):
            clock += pieces.straight(g, part)
            continue
        fast, s_in, s_out = arcs[k]
        known = None if pre is None else pre[k]
        dur, bad_in, bad_out = pieces.arc(g, part, s_in, s_out, fast, setup.smoothing[b], known)
        clock += dur
        bad |= {b} if bad_in else set()
        bad |= {b + 1} if bad_out else set()
    chain = Chain(
        pieces.out.chunk(),
        clock,
        tuple(starts),
        frozenset(bad),
        pieces.ruckig_pieces,
        prep.speeds[1:-1],
    )
    return chain, pieces.off_pieces


def _path_profile(
    solver: RuckigSolver, move: Move, lim: BlockLimits, v_in: float, v_out: float
) -> Profile1D:
    """The 1-D profile of a block (one move, or a chain starting with ``move``) from ``v_in``
    to ``v_out`` [mm/s] under its limits."""
    try:
        return solver.profile(
            lim.length_mm, v_in, v_out, lim.cap_mm_per_s, lim.acc_mm_per_s2, lim.jerk_mm_per_s3
        )
    except RuckigRejected as exc:
        raise PlannerFailure(
            f"no speed profile along this {move.kind} move fits the machine's limits "
            f"(Ruckig: {exc.reason})",
            move.line,
        ) from None
    except ProfileReverses:
        raise PlanningError(
            "the speed profile would reverse along the path", line=move.line
        ) from None
