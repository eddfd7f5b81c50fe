"""Planning rounds: every chain's profile and pieces, re-planned until its junctions hold.

A round plans each chain (:mod:`~gantry_sim.controller.planner.chains`) between the junction
speeds the look-ahead gives: one 1-D Ruckig profile, cut at the moves' ends; straight moves are
that profile projected on the line, arcs are joined through their exact vertex states
(:class:`~gantry_sim.controller.planner.pieces.MovePieces`; the chains of a round are planned
in batches by :mod:`~gantry_sim.controller.planner.chain_plan`). Where a piece next to a moving
junction leaves the arc or needed Ruckig to stretch it (beyond
:data:`~gantry_sim.controller.planner.pieces.END_STRETCH_MAX`), that junction's cap comes
down (by :data:`JUNCTION_BACKOFF`, more each time) and the program is planned again
(:func:`settle_chains`).

Only what changed is planned again: a chain's pieces depend on nothing but the chain and the
speeds at its two ends, so each round reuses the chains whose ends kept their speeds. The
pieces of a chain are kept as arrays (a few bytes per phase, not Python floats).
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.moves import Dwell
from gantry_sim.controller.planner.chain_plan import (
    Chain,
    ChainKey,
    ChainSetup,
    Chunk,
    Onward,
    SeedKey,
    plan_chains_forked,
    plan_chains_sending,
)
from gantry_sim.controller.planner.chains import chain_limits, chain_spans
from gantry_sim.controller.planner.junctions import JunctionState
from gantry_sim.controller.planner.limits import BlockLimits
from gantry_sim.controller.planner.lookahead import Passes, junction_speeds_again
from gantry_sim.controller.planner.move_geometry import MoveGeometry
from gantry_sim.controller.planner.ruckig_solver import RuckigSolver
from gantry_sim.controller.planner.stop_overlap import (
    Overlapped,
    Pending,
    first_move_s,
    last_move_s,
    overlap_at,
)

__all__ = [
    "JUNCTION_BACKOFF",
    "MAX_ROUNDS",
    "Round",
    "Settled",
    "assemble",
    "first_round",
    "first_speeds",
    "settle",
    "settle_chains",
    "settle_onward",
]

#: Re-planning rounds that lower the offending junction caps; from then on each round softens
#: (below) or stops the junctions still offending, until none does (a stop never offends).
MAX_ROUNDS = 16
#: A junction offending for the k-th time (k = 1, 2, ...) comes down to JUNCTION_BACKOFF ** k
#: of its speed: 0.95, then 0.9025, 0.857... (0.9 each time until 2026-11-29). Lowering a
#: junction lowers its neighbours' speeds too (short moves cannot ramp back within their
#: length), and their arcs, now ramping, offend next round: a first step smaller than 0.9
#: disturbs fewer of them, and the steps that grow keep the few junctions that need much less
#: speed within MAX_ROUNDS (from the fourth step on they come down further than by 0.9 each).
#: 10,000 polyline blocks planned 24,705 chains instead of 28,374, in a cycle of 159.24 s
#: instead of 162.10 s; tangent arcs and mixed programs within 1.2 % of the chains, slightly
#: faster; 48 real programs within -0.2 % and +0.1 % of their cycle times.
JUNCTION_BACKOFF = 0.95
#: After those rounds a junction still offending first has the tangential acceleration and
#: jerk of its two moves lowered by SOFTEN, up to SOFTEN_TRIES times, then becomes a stop.
SOFTEN = 0.7
SOFTEN_TRIES = 3


@dataclass
class Round:
    """One planning round: the reference, its duration [s], each move's (and dwell's, and
    overlapped stop's) start time [s] and program line, the junctions whose neighbouring
    pieces left the arc (their speed must come down), the Ruckig pieces used, and per move
    (and dwell, and overlap) the first and last of the planned moves it is (a move: its index
    twice) or lies between (a dwell or an overlap at junction b: b - 1 and b; -1 or the move
    count past either end)."""

    chunks: list[Chunk]
    duration_s: float
    move_start_s: list[float]
    bad_junctions: set[int]
    lines: list[int]
    ruckig_pieces: int
    entries: list[tuple[int, int]]
    #: the stops overlapped (:mod:`~gantry_sim.controller.planner.stop_overlap`)
    overlaps: list[Overlapped] = field(default_factory=list)
    #: the last chain, held back for an overlap with the next window's first (its chunk is
    #: not in ``chunks``)
    pending: Pending | None = None


@dataclass
class Settled:
    """The chains of the last round, when no junction offends any more: ``spans`` (first,
    stop) over ``setup.active``, their ``chains``, and ``speeds`` [mm/s] (len(active) + 1) at
    the chains' ends, as the look-ahead gave them (NaN inside the chains)."""

    setup: ChainSetup
    spans: list[tuple[int, int]]
    chains: list[Chain]
    speeds: np.ndarray
    #: per round, the look-ahead's speeds [mm/s] at the chains' ends (NaN inside them)
    round_speeds: list[np.ndarray] = field(default_factory=list)
    #: the first round's chain spans (rounds only add chain boundaries: each of these is a
    #: boundary in every round)
    first_spans: list[tuple[int, int]] = field(default_factory=list)


def settle_chains(
    active: list[MoveGeometry],
    caps: np.ndarray,
    states: list[JunctionState],
    machine: MachineConfig,
    solver: RuckigSolver,
    arc_pieces: str,
    smoothing: list[float],
    blend_arcs: frozenset[int] = frozenset(),
    ahead: Callable[[list[tuple[int, int]], np.ndarray], Callable[[], object] | None] | None = None,
    seed: Mapping[SeedKey, Chain] | None = None,
    plan_round: RoundPlanner = plan_chains_forked,
    starts: Sequence[float] | None = None,
) -> Settled:
    """Plan the moves' chains (not yet assembled into a timeline: :func:`assemble`; a window of a
    long program keeps only a prefix of them, :mod:`~gantry_sim.controller.planner.windows`);
    while pieces next to moving junctions leave the arc, lower those junctions' caps (``caps``
    [mm/s] is changed; the k-th time to :data:`JUNCTION_BACKOFF` ** k of the speed) and plan
    again, at most :data:`MAX_ROUNDS` times; after that a junction still offending has its two
    moves' tangential acceleration and jerk lowered by :data:`SOFTEN` (at most
    :data:`SOFTEN_TRIES` times), then becomes a stop, round by round, until none offends: the
    plan kept never has a piece off its path next to a moving junction (lowering one junction changes its neighbours' speeds, so a junction may
    first offend in a late round). Softening helps where the chain's profile ends a ramp at its
    full tangential jerk right at a junction whose curvature changes (a blend arc of a polyline
    of 0.035 mm steps): the axes need that jerk plus the curvature's, and no lower junction
    speed frees it. ``blend_arcs``: ids of the G64 blend arcs among the moves (tolerance
    features: no faster candidate profiles, boosted or saturated, which cost far more than
    they save them; :mod:`~gantry_sim.controller.planner.chain_prep`). ``ahead``: given the
    first round's chain spans and the speeds [mm/s] at their ends, a job for this process to do
    while other processes plan that round's chains (or None: see
    :func:`~gantry_sim.controller.planner.chain_plan.plan_chains_forked`).

    ``seed``: chains planned already for these moves (by other processes, ahead:
    :func:`first_round`, :func:`settle_onward`; a chain's pieces depend on nothing but the
    chain, its limits, its end speeds and whether the round lets its arcs try the saturated
    ramps, so a chain of the same :data:`SeedKey` is the same chain); they are used wherever a
    round needs them. ``plan_round``: plans a round's chains (:func:`settle_onward` sends
    them as they come)."""
    setup = ChainSetup(active, states, machine, solver, arc_pieces, smoothing, {}, blend_arcs)
    return settle(setup, caps, ahead, seed, plan_round, starts)


def settle(
    setup: ChainSetup,
    caps: np.ndarray,
    ahead: Callable[[list[tuple[int, int]], np.ndarray], Callable[[], object] | None] | None = None,
    seed: Mapping[SeedKey, Chain] | None = None,
    plan_round: RoundPlanner = plan_chains_forked,
    starts: Sequence[float] | None = None,
) -> Settled:
    """:func:`settle_chains` of the moves, states and machine of ``setup`` (its ``boost_cache``
    fresh, and ``saturated_moving`` set, as a new setup has them). ``starts``: the speed
    [mm/s] at the first junction in each round (``caps[0]`` of round k is ``starts[k]``, the
    last one from then on; the rounds go on at least as many times): a window of a long
    program replays the rounds the window before gave its cut, so that its own rounds are
    those of the whole program (:mod:`~gantry_sim.controller.planner.windows`)."""
    blocks = [g.limits for g in setup.active]
    cache: dict[ChainKey, Chain] = {}
    reach_memo: dict = {}
    chain_memo: dict[tuple[int, int], BlockLimits] = {}  # chain_limits by span, across rounds
    softened: dict[int, int] = {}
    backed: dict[int, int] = {}  # times each junction was lowered
    history: list[np.ndarray] = []
    passes: Passes | None = None  # the round before's look-ahead
    first_spans: list[tuple[int, int]] = []
    for rnd in itertools.count():
        if starts:
            caps[0] = starts[min(rnd, len(starts) - 1)]
        spans, chained, speeds, passes = _round_speeds(blocks, caps, chain_memo, reach_memo, passes)
        history.append(speeds.copy())
        first_spans = first_spans or spans
        before = ahead(spans, speeds) if ahead is not None and rnd == 0 else None
        # after the first round, an arc's moving end is a junction being backed off, whose
        # speed changes round by round: the saturated ramps (tenths of a second) would be
        # built again each time (one arc of a Bambu Studio print in G61: 11 times, 7.1 s of a
        # 7.7 s plan), so there only an arc from and to rest tries them
        now = setup if rnd == 0 else replace(setup, saturated_moving=False)
        chains, cache = _plan_round(now, spans, chained, speeds, cache, before, seed, plan_round)
        bad: set[int] = set()
        for (first, stop), chain in zip(spans, chains, strict=True):
            if chain.bad:
                bad |= chain.bad
                speeds[first + 1 : stop] = chain.inner_speeds
        if not bad and (not starts or rnd >= len(starts) - 1):
            break
        touched: set[int] = set()  # moves whose limits were softened this round
        for b in sorted(bad):  # only moving junctions are ever bad: each stop makes one fewer
            if rnd < MAX_ROUNDS - 1:
                backed[b] = backed.get(b, 0) + 1
                caps[b] = JUNCTION_BACKOFF ** backed[b] * speeds[b]
            elif softened.get(b, 0) < SOFTEN_TRIES:
                softened[b] = softened.get(b, 0) + 1
                touched |= {m for m in (b - 1, b) if 0 <= m < len(blocks)}
            else:
                caps[b] = 0.0
        _soften(blocks, touched, cache, chain_memo)
        chains.clear()  # the chains replaced next round are freed before it plans new ones
    return Settled(setup, spans, chains, speeds, history, first_spans)


#: Plans a round's chains: (setup, chains to plan (key, limits), speeds [mm/s] at the chains'
#: ends, a job of this process' own to do first or None) -> the chains by key.
RoundPlanner = Callable[
    [ChainSetup, list[tuple[ChainKey, BlockLimits]], np.ndarray, Callable[[], object] | None],
    dict[ChainKey, Chain],
]


def settle_onward(setup: ChainSetup, caps: np.ndarray) -> Onward:
    """For :class:`~gantry_sim.controller.planner.chain_plan.ChainsAhead`: given the chains of
    the first round of :func:`settle_chains` with ``setup``'s moves and ``caps`` [mm/s] (as
    :func:`first_round` gives it), the rounds after it, each chain sent as it is planned (the
    process planning the window takes them as its seed: the same calls, so the same rounds
    where it starts at the same speed)."""

    def onward(seed: dict[SeedKey, Chain], send: Callable[[dict[SeedKey, Chain]], None]) -> None:
        def plan_round(
            now: ChainSetup,
            todo: list[tuple[ChainKey, BlockLimits]],
            speeds: np.ndarray,
            before: Callable[[], object] | None,
        ) -> dict[ChainKey, Chain]:
            return plan_chains_sending(now, todo, speeds, send)

        settle(replace(setup, boost_cache={}), caps.copy(), seed=seed, plan_round=plan_round)

    return onward


def _round_speeds(
    blocks: list[BlockLimits],
    caps: np.ndarray,
    chain_memo: dict[tuple[int, int], BlockLimits],
    reach_memo: dict,
    before: Passes | None = None,
) -> tuple[list[tuple[int, int]], list[BlockLimits], np.ndarray, Passes]:
    """A round's chains: their spans, their limits (memoised by span in ``chain_memo``) and the
    look-ahead's speeds [mm/s] at their ends (NaN inside them) under the junction ``caps``,
    and that look-ahead (computed again only where it can differ from ``before``, the round
    before's: :func:`~gantry_sim.controller.planner.lookahead.junction_speeds_again`)."""
    spans = chain_spans(blocks, caps)
    chained = []
    for span in spans:
        lim = chain_memo.get(span)
        if lim is None:
            lim = chain_memo[span] = chain_limits(blocks[span[0] : span[1]])
        chained.append(lim)
    ends = np.array([first for first, _ in spans] + [len(blocks)])
    passes = junction_speeds_again(chained, caps[ends], ends, reach_memo, before)
    speeds = np.full(len(blocks) + 1, np.nan)
    speeds[ends] = passes.speeds
    return spans, chained, speeds, passes


def first_round(
    setup: ChainSetup, caps: np.ndarray
) -> tuple[list[tuple[ChainKey, BlockLimits]], np.ndarray]:
    """What the first round of :func:`settle` of ``setup`` and ``caps`` [mm/s] plans: its
    chains (key, limits) and the speeds [mm/s] at their ends, to plan them ahead (the chains
    planned are a seed of that call)."""
    spans, chained, speeds, _ = _round_speeds([g.limits for g in setup.active], caps, {}, {})
    return list(zip(_chain_keys(spans, speeds), chained, strict=True)), speeds


def first_speeds(
    blocks: list[BlockLimits], caps: np.ndarray
) -> tuple[list[tuple[int, int]], np.ndarray]:
    """The chains of the first round of :func:`settle` of moves of limits ``blocks`` under
    the junction ``caps`` [mm/s]: their spans, and the look-ahead's speeds [mm/s] at their
    ends (NaN inside them)."""
    spans, _, speeds, _ = _round_speeds(blocks, caps, {}, {})
    return spans, speeds


def _chain_keys(spans: list[tuple[int, int]], speeds: np.ndarray) -> list[ChainKey]:
    """Each chain's key: (first, stop, speed in, speed out [mm/s]), from the speeds at the
    chains' ends."""
    at = speeds.tolist()  # Python floats: the same numbers, without a NumPy scalar per chain
    return [(first, stop, at[first], at[stop]) for first, stop in spans]


def _soften(
    blocks: list[BlockLimits],
    moves: set[int],
    cache: dict[ChainKey, Chain],
    chain_memo: dict[tuple[int, int], BlockLimits],
) -> None:
    """Lower the tangential acceleration and jerk of ``moves`` by :data:`SOFTEN` (``blocks``
    is changed) and drop the cached chains, and the chains' limits, holding any of them."""
    if not moves:
        return
    for m in moves:
        lim = blocks[m]
        blocks[m] = replace(
            lim,
            acc_mm_per_s2=SOFTEN * lim.acc_mm_per_s2,
            jerk_mm_per_s3=SOFTEN * lim.jerk_mm_per_s3,
        )
    order = sorted(moves)

    def holds_one(first: int, stop: int) -> bool:  # a softened move in [first, stop)
        i = bisect.bisect_left(order, first)
        return i < len(order) and order[i] < stop

    for key in [k for k in cache if holds_one(k[0], k[1])]:
        del cache[key]
    for span in [k for k in chain_memo if holds_one(*k)]:
        del chain_memo[span]


def _plan_round(
    setup: ChainSetup,
    spans: list[tuple[int, int]],
    chained: list[BlockLimits],
    speeds: np.ndarray,
    cache: dict[ChainKey, Chain],
    before: Callable[[], object] | None = None,
    seed: Mapping[SeedKey, Chain] | None = None,
    plan_round: RoundPlanner = plan_chains_forked,
) -> tuple[list[Chain], dict[ChainKey, Chain]]:
    """Every chain's pieces between the junction speeds ``speeds`` [mm/s] at the chains' ends,
    reusing ``cache``'s chains planned for the same speeds (the others are dropped from it
    first, so a plan holds about one round's phases) and ``seed``'s; returns the chains, in
    order, and the cache of this round's chains. ``before``: a job of this process' own, done
    while other processes plan the chains; ``plan_round``: plans the chains left."""
    keys = _chain_keys(spans, speeds)
    known = seed or {}
    sat = setup.saturated_moving
    found: list[Chain | None] = []  # each key looked up once (a round has thousands)
    todo = []
    for k, lim in zip(keys, chained, strict=True):
        got = cache.get(k)
        if got is None and known:
            got = known.get((k, lim, sat))
        if got is None:
            todo.append((k, lim))
        found.append(got)
    cache.clear()  # the chains no longer needed are freed before new ones are planned
    fresh = plan_round(setup, todo, speeds, before)
    chains = [fresh[k] if got is None else got for k, got in zip(keys, found, strict=True)]
    return chains, dict(zip(keys, chains, strict=True))


def assemble(
    settled: Settled,
    holds: dict[int, list[Dwell]],
    count: int,
    *,
    end_hold: bool,
    start_s: float = 0.0,
    corners: Mapping[int, float] | None = None,
    path_acc: Sequence[float] | None = None,
    before: Pending | None = None,
    hold_last: bool = False,
) -> Round:
    """The timeline of the first ``count`` chains of ``settled``: their phases in order, with
    the dwells of ``holds`` at their junctions (the one after the last chain only with
    ``end_hold``), each move's start time and line (once, for the round that is kept: the
    rounds before only needed their chains' failed junctions). Times count from ``start_s``
    [s] (a window's: the one before it ended there), and ``duration_s`` is the end's.

    At each stop of ``corners`` (junction -> the G64 budget [mm] there) the two chains'
    profiles are overlapped where that keeps every limit
    (:mod:`~gantry_sim.controller.planner.stop_overlap`; ``path_acc``: per move, Marlin's M204
    path acceleration [mm/s^2], or None): the overlap is an entry of the timeline of its own
    (lying between the two moves, as a dwell does) and the chains after it start earlier.
    ``before``: the window before's last chain, held back for junction 0; ``hold_last``: hold
    this window's last chain back likewise (:attr:`Round.pending`)."""
    setup = settled.setup
    spans, chains = settled.spans[:count], settled.chains[:count]
    chunks: list[Chunk] = []
    clock, ruckig = start_s, 0
    starts: list[float] = []
    lines: list[int] = []
    entries: list[tuple[int, int]] = []
    bad: set[int] = set()
    overlaps: list[Overlapped] = []
    corners = corners or {}
    last: Pending | None = before

    def hold(b: int) -> None:
        nonlocal clock
        for dw in holds.get(b, ()):
            starts.append(clock)
            lines.append(dw.line)
            entries.append((b - 1, b))
            axes = [
                np.array([[dw.seconds], [dw.position[i]], [0.0], [0.0], [0.0]]) for i in range(3)
            ]
            chunks.append(((axes[0], axes[1], axes[2]),))
            clock += dw.seconds

    for (first, stop), chain in zip(spans, chains, strict=True):
        chunk, tau = chain.chunk, 0.0
        if last is not None and first in corners and first not in holds:
            acc = math.inf if path_acc is None else path_acc[first]
            met = Pending(chunk, first_move_s(chain), setup.active[first], acc)
            cut = overlap_at(last, met, corners[first], setup.machine.limits)
            if cut is not None:
                ahead, chunk, found = cut
                tau, line = found.tau_s, last.geometry.move.line
                last = replace(last, chunk=ahead)
                clock -= tau  # the chains from here on start tau earlier
                starts.append(clock)
                lines.append(line)
                entries.append((first - 1, first))
                file = getattr(last.geometry.move, "file", None)
                overlaps.append(
                    Overlapped(clock, tau, line, found.deviation_mm, corners[first], file)
                )
        if last is not None:
            chunks.append(last.chunk)
        hold(first)
        starts.extend(clock + t for t in chain.starts_s)
        if tau > 0.0:  # the overlap's entry holds the first move's first tau seconds
            starts[len(starts) - len(chain.starts_s)] = clock + tau
        lines.extend(g.move.line for g in setup.active[first:stop])
        entries.extend((b, b) for b in range(first, stop))
        acc = math.inf if path_acc is None else path_acc[stop - 1]
        last = Pending(chunk, last_move_s(chain, tau), setup.active[stop - 1], acc)
        clock += chain.duration_s
        bad |= chain.bad
        ruckig += chain.ruckig_pieces
    pending = None
    if last is not None:
        if hold_last and spans:
            pending = last
        else:
            chunks.append(last.chunk)
    if end_hold:
        hold(spans[-1][1] if spans else len(setup.active))
    return Round(chunks, clock, starts, bad, lines, ruckig, entries, overlaps, pending)
