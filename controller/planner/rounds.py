"""Planning rounds: every chain's profile and pieces, re-planned until its junctions hold.

A round plans each chain (:mod:`~gantry_sim.controller.planner.chains`) between the junction
speeds the look-ahead gives: one 1-D Ruckig profile, cut at the moves' ends; straight moves are
that profile projected on the line, arcs are joined through their exact vertex states
(:class:`~gantry_sim.controller.planner.pieces.MovePieces`). Where a piece next to a moving
junction leaves the arc or needed Ruckig to stretch it, that junction's cap comes down by
:data:`JUNCTION_BACKOFF` and the program is planned again (:func:`replan_until_junctions_hold`).

Only what changed is planned again: a chain's pieces depend on nothing but the chain and the
speeds at its two ends, so each round reuses the chains whose ends kept their speeds. The
pieces of a chain are kept as arrays (a few bytes per phase, not Python floats).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import PlannerFailure, PlanningError
from gantry_sim.controller.moves import Dwell, Move
from gantry_sim.controller.planner.chains import chain_limits, chain_spans, split_profile
from gantry_sim.controller.planner.cubic import PiecewiseCubic, phases_from_chunks
from gantry_sim.controller.planner.junctions import EndState, JunctionState
from gantry_sim.controller.planner.limits import BlockLimits
from gantry_sim.controller.planner.lookahead import plan_junction_speeds
from gantry_sim.controller.planner.move_geometry import ArcGeometry, MoveGeometry
from gantry_sim.controller.planner.pieces import MovePieces, Pieces
from gantry_sim.controller.planner.profile import Profile1D
from gantry_sim.controller.planner.ruckig_solver import (
    ProfileReverses,
    RuckigRejected,
    RuckigSolver,
)
from gantry_sim.controller.planner.speedup import boosted_profile

__all__ = ["JUNCTION_BACKOFF", "MAX_ROUNDS", "Round", "replan_until_junctions_hold"]

#: Re-planning rounds (each lowers the offending junction caps by JUNCTION_BACKOFF); the last
#: round stops at the junctions still offending.
MAX_ROUNDS = 16
JUNCTION_BACKOFF = 0.9

#: Per axis, the phases (duration [s], position [mm], velocity [mm/s], acceleration [mm/s^2],
#: jerk [mm/s^3]) of a stretch of the reference, as arrays of equal length.
Chunk = tuple[tuple[np.ndarray, ...], ...]


@dataclass(frozen=True, eq=False)
class _Chain:
    """One chain's pieces: ``chunk``, its duration [s], each move's start [s] from the chain's
    start, the junctions whose pieces failed, Ruckig pieces used, and the profile's speed
    [mm/s] at the junctions inside the chain."""

    chunk: Chunk
    duration_s: float
    starts_s: tuple[float, ...]
    bad: frozenset[int]
    ruckig_pieces: int
    inner_speeds: np.ndarray


@dataclass
class Round:
    """One planning round: the reference, its duration [s], each move's (and dwell's) start
    time [s] and program line, the junctions whose neighbouring pieces left the arc (their
    speed must come down), and the Ruckig pieces used."""

    chunks: list[Chunk]
    duration_s: float
    move_start_s: list[float]
    bad_junctions: set[int]
    lines: list[int]
    ruckig_pieces: int

    def curve(self) -> PiecewiseCubic:
        """The reference as constant-jerk phases per axis."""
        return phases_from_chunks(self.chunks)


@dataclass(frozen=True)
class _Setup:
    """What every chain of a plan is planned with."""

    active: list[MoveGeometry]
    states: list[JunctionState]
    machine: MachineConfig
    solver: RuckigSolver
    arc_pieces: str
    smoothing: list[float]
    boost_cache: dict
    blend_arcs: frozenset[int]


def replan_until_junctions_hold(
    active: list[MoveGeometry],
    caps: np.ndarray,
    states: list[JunctionState],
    machine: MachineConfig,
    solver: RuckigSolver,
    arc_pieces: str,
    holds: dict[int, list[Dwell]],
    smoothing: list[float],
    blend_arcs: frozenset[int] = frozenset(),
) -> Round:
    """Plan the moves; while pieces next to moving junctions leave the arc, lower those
    junctions' caps (``caps`` [mm/s] is changed) by :data:`JUNCTION_BACKOFF` and plan again, at
    most :data:`MAX_ROUNDS` times; in the last round the junctions still offending become
    stops. ``holds``: dwells per junction (exact stops holding the reference for their time).
    ``blend_arcs``: ids of the G64 blend arcs among the moves (tolerance features: no
    saturated-ramp search, which costs tenths of a second and can save them microseconds)."""
    setup = _Setup(active, states, machine, solver, arc_pieces, smoothing, {}, blend_arcs)
    blocks = [g.limits for g in active]
    cache: dict[tuple[int, int, float, float], _Chain] = {}
    for rnd in range(MAX_ROUNDS + 1):
        spans = chain_spans(blocks, caps)
        chained = [chain_limits(blocks[first:stop]) for first, stop in spans]
        ends = [first for first, _ in spans] + [len(active)]
        speeds = np.full(len(active) + 1, np.nan)
        speeds[ends] = plan_junction_speeds(chained, caps[ends])
        done, cache = _plan_round(setup, spans, chained, speeds, holds, cache)
        if not done.bad_junctions:
            break
        for b in done.bad_junctions:
            caps[b] = 0.0 if rnd == MAX_ROUNDS - 1 else JUNCTION_BACKOFF * speeds[b]
    return done


def _plan_round(
    setup: _Setup,
    spans: list[tuple[int, int]],
    chained: list[BlockLimits],
    speeds: np.ndarray,
    holds: dict[int, list[Dwell]],
    cache: dict[tuple[int, int, float, float], _Chain],
) -> tuple[Round, dict[tuple[int, int, float, float], _Chain]]:
    """Every chain's pieces between the junction speeds ``speeds`` [mm/s] at the chains' ends
    (filled in here inside chains), reusing ``cache``'s chains planned for the same speeds;
    returns the round and the cache of its chains."""
    chunks: list[Chunk] = []
    clock, ruckig = 0.0, 0
    starts: list[float] = []
    lines: list[int] = []
    bad: set[int] = set()
    used: dict[tuple[int, int, float, float], _Chain] = {}

    def hold(b: int) -> None:
        nonlocal clock
        for dw in holds.get(b, ()):
            starts.append(clock)
            lines.append(dw.line)
            chunks.append(
                tuple(
                    tuple(np.array([x]) for x in (dw.seconds, dw.position[i], 0.0, 0.0, 0.0))
                    for i in range(3)
                )
            )
            clock += dw.seconds

    keys = [(first, stop, float(speeds[first]), float(speeds[stop])) for first, stop in spans]
    todo = [(k, lim) for k, lim in zip(keys, chained, strict=True) if k not in cache]
    fresh = _plan_chains(setup, todo, speeds)
    for (first, stop), key in zip(spans, keys, strict=True):
        hold(first)
        chain = cache.get(key) or fresh[key]
        used[key] = chain
        speeds[first + 1 : stop] = chain.inner_speeds
        starts.extend(clock + t for t in chain.starts_s)
        lines.extend(g.move.line for g in setup.active[first:stop])
        chunks.append(chain.chunk)
        clock += chain.duration_s
        bad |= chain.bad
        ruckig += chain.ruckig_pieces
    hold(len(setup.active))
    return Round(chunks, clock, starts, bad, lines, ruckig), used


#: Closed-form pieces computed in one vectorised batch (about this many pieces at most: the
#: batch's arrays take about 1 kB per piece).
BATCH_PIECES = 20_000

_Key = tuple[int, int, float, float]


def _plan_chains(
    setup: _Setup, todo: list[tuple[_Key, BlockLimits]], speeds: np.ndarray
) -> dict[_Key, _Chain]:
    """The chains ``todo`` (key (first, stop, speed in, speed out), limits), planned in batches:
    each chain's profile and arcs' candidate profiles first, then the closed-form pieces of
    the first candidate of every arc of the batch at once, then each chain's pieces."""
    out: dict[_Key, _Chain] = {}
    batch: list[tuple[_Key, BlockLimits, _Prep]] = []
    size = 0
    for key, lim in todo:
        prep = _chain_prep(setup, key[0], key[1], lim, speeds)
        batch.append((key, lim, prep))
        size += sum(g.u.size for _, g, *_ in prep.arcs)
        if size >= BATCH_PIECES:
            _finish_batch(setup, batch, speeds, out)
            batch, size = [], 0
    _finish_batch(setup, batch, speeds, out)
    return out


def _finish_batch(
    setup: _Setup,
    batch: list[tuple[_Key, BlockLimits, _Prep]],
    speeds: np.ndarray,
    out: dict[_Key, _Chain],
) -> None:
    """Plan the prepared chains of ``batch`` into ``out``."""
    requests = []
    for _key, _lim, prep in batch:
        for k, g, fast, s_in, s_out in prep.arcs:
            requests.append((g, fast[0] if fast else prep.parts[k], s_in, s_out))
    maker = MovePieces(
        setup.machine.limits,
        setup.machine.segmentation.chord_tolerance_mm,
        setup.arc_pieces,
        setup.solver,
    )
    found = iter(maker.closed_forms(requests)) if setup.arc_pieces == "jerk3" else None
    for key, lim, prep in batch:
        first = None if found is None else {k: next(found) for k, *_ in prep.arcs}
        out[key] = _plan_chain(setup, key[0], key[1], lim, speeds, prep, first)


#: Tries of a chain's profile with slower limits (each: :data:`SLOWER_CAP` of the speed cap,
#: :data:`SLOWER_RAMP` of the acceleration and jerk) when a Ruckig piece inside an arc with
#: no moving junction left the arc or exceeded the feed.
SLOWER_TRIES = 6
SLOWER_CAP = 0.995
SLOWER_RAMP = 0.8


def _plan_chain(
    setup: _Setup,
    first: int,
    stop: int,
    lim: BlockLimits,
    speeds: np.ndarray,
    prep: _Prep | None = None,
    pre: dict[int, Pieces] | None = None,
) -> _Chain:
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
    setup: _Setup, first: int, stop: int, lim: BlockLimits, speeds: np.ndarray
) -> _Prep:
    """The profile of moves ``first..stop-1`` under ``lim``, cut per move, and each arc's
    candidates and end states."""
    active, states, limits = setup.active, setup.states, setup.machine.limits
    prof = _path_profile(setup.solver, active[first].move, lim, speeds[first], speeds[stop])
    v = np.empty(stop - first + 1)
    acc_t = np.zeros(stop - first + 1)
    v[0], v[-1] = speeds[first], speeds[stop]
    if stop - first == 1:
        parts = [prof]
    else:
        lengths = [g.length_mm for g in active[first:stop]]
        parts, v[1:-1], acc_t[1:-1] = split_profile(prof, lengths)
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
    setup: _Setup, first: int, stop: int, prep: _Prep, pre: dict[int, Pieces] | None
) -> tuple[_Chain, int]:
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
    chain = _Chain(
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
