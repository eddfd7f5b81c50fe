"""One re-planning round's chains: profile, cut, candidates, and pieces, in vectorised batches.

A chain (:mod:`~gantry_sim.controller.planner.chains`) is planned from the speeds at its two
ends: its profile, cut per move, and each arc's candidates come from
:mod:`~gantry_sim.controller.planner.chain_prep`; straight moves are that profile projected on
the line, arcs are joined through their exact vertex states
(:class:`~gantry_sim.controller.planner.pieces.MovePieces`), trying each single arc's faster
candidates first.

The work of many chains is done at once (:func:`plan_chains`): the vertex states, closed-form
pieces and limit checks of every arc's first candidate are computed in one batch of about
:data:`BATCH_PIECES` pieces; what stays per arc is the choice among its results. Every number
is computed element by element as when planned alone, so batching does not change the plan by
a bit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import cast

import numpy as np

from gantry_sim.controller.forked import process_count
from gantry_sim.controller.forked_runs import RunsAhead, fork_runs
from gantry_sim.controller.planner.chain_batch import ChainBatch
from gantry_sim.controller.planner.chain_prep import ChainPrep, ChainSetup, chain_prep, chain_preps
from gantry_sim.controller.planner.chains import Chain
from gantry_sim.controller.planner.cubic import Chunk
from gantry_sim.controller.planner.limits import BlockLimits
from gantry_sim.controller.planner.move_geometry import ArcGeometry
from gantry_sim.controller.planner.pieces import MovePieces, Pieces, loose_patterns

__all__ = [
    "BATCH_PIECES",
    "Chain",
    "ChainKey",
    "ChainSetup",
    "ChainsAhead",
    "Chunk",
    "Onward",
    "SeedKey",
    "plan_chains",
    "plan_chains_forked",
    "plan_chains_sending",
]


#: Closed-form pieces computed in one vectorised batch (about this many pieces at most: the
#: batch's arrays take about 1 kB per piece).
BATCH_PIECES = 20_000

#: A chain by (first move, stop, speed in [mm/s], speed out [mm/s]).
ChainKey = tuple[int, int, float, float]
#: A chain planned elsewhere by everything its pieces depend on: its key, its limits (lowered
#: where a round softened its moves) and the round's ``ChainSetup.saturated_moving``.
SeedKey = tuple[ChainKey, BlockLimits, bool]


def plan_chains(
    setup: ChainSetup, todo: list[tuple[ChainKey, BlockLimits]], speeds: np.ndarray
) -> dict[ChainKey, Chain]:
    """The chains ``todo`` (key (first, stop, speed in, speed out), limits), planned in batches
    of about :data:`BATCH_PIECES` pieces: the chains' profiles first, cut at their moves' ends
    all at once, then the closed-form pieces of the first candidate of every arc of the batch
    at once, then each chain's pieces. A :class:`ChainBatch`: sent from a forked child, it
    pickles packed."""
    out: ChainBatch[ChainKey] = ChainBatch()
    batch: list[tuple[ChainKey, BlockLimits]] = []
    size = 0
    for key, lim in todo:
        batch.append((key, lim))
        size += _pieces(setup, key)
        if size >= BATCH_PIECES:
            _plan_batch(setup, batch, speeds, out)
            batch, size = [], 0
    _plan_batch(setup, batch, speeds, out)
    return out


def plan_chains_forked(
    setup: ChainSetup,
    todo: list[tuple[ChainKey, BlockLimits]],
    speeds: np.ndarray,
    before: Callable[[], object] | None = None,
) -> dict[ChainKey, Chain]:
    """:func:`plan_chains`, split over :func:`~gantry_sim.controller.forked.process_count`
    processes (:func:`~gantry_sim.controller.forked_runs.fork_runs`) when its work (:func:`_work`) is
    at least :data:`FORK_WORK`, or when this process has a job of its own to do first
    (``before``, called once: the next window's preparation,
    :mod:`~gantry_sim.controller.planner.windows`), so that the other processes plan the chains
    meanwhile. The chains go in waves, contiguous stretches of about :data:`WAVE_WORK` per
    process (a forked child's private memory, the pages it copies on writing and what it plans,
    grows with its share: one wave for all took 1.1 GB besides the parent's 1.4 GB at 100,000
    arcs); a wave's chains go in runs (:func:`_runs`), each taken by whichever process is free
    next. A chain's pieces depend on nothing but the chain and its end speeds, so the plan is
    the same bit for bit."""
    n = process_count()
    work = [_work(setup, key) for key, _ in todo]
    if n <= 1 or (sum(work) < FORK_WORK and (before is None or not todo)):
        if before is not None:
            before()
        return plan_chains(setup, todo, speeds)
    out: dict[ChainKey, Chain] = {}
    first, size = 0, 0
    for i, w in enumerate(work):
        size += w
        if size >= n * WAVE_WORK or i == len(todo) - 1:
            runs = _runs(todo[first : i + 1], work[first : i + 1])
            for done in fork_runs(lambda run: plan_chains(setup, run, speeds), runs, n, before):
                out.update(done)
            first, size, before = i + 1, 0, None
    return out


def plan_chains_sending(
    setup: ChainSetup,
    todo: list[tuple[ChainKey, BlockLimits]],
    speeds: np.ndarray,
    send: Callable[[dict[SeedKey, Chain]], None],
) -> dict[ChainKey, Chain]:
    """:func:`plan_chains` in this process, run by run (:func:`_runs`), each run's chains
    given to ``send`` as soon as they are planned, by :data:`SeedKey`."""
    out: dict[ChainKey, Chain] = {}
    for run in _runs(todo, [_work(setup, key) for key, _ in todo]):
        done = plan_chains(setup, run, speeds)
        send(_by_seed_key(run, done, setup.saturated_moving))
        out.update(done)
    return out


def _by_seed_key(
    todo: list[tuple[ChainKey, BlockLimits]], done: dict[ChainKey, Chain], sat: bool
) -> dict[SeedKey, Chain]:
    """The chains ``todo`` (key, limits) planned as ``done`` by :data:`SeedKey` (``sat``: the
    round's ``ChainSetup.saturated_moving``)."""
    return ChainBatch({(key, lim, sat): done[key] for key, lim in todo})


#: What a child of :class:`ChainsAhead` does with the first round once it has planned all of
#: it: given its chains (by :data:`SeedKey`) and a function sending more of them.
Onward = Callable[[dict[SeedKey, Chain], Callable[[dict[SeedKey, Chain]], None]], object]


class ChainsAhead:
    """:func:`plan_chains` of ``todo`` started now over the forked children of
    :func:`~gantry_sim.controller.forked.process_count` (they hold their cores meanwhile), and
    finished by :meth:`finish`, where this process takes the chains left (the next window's
    first round, planned while this process plans the rounds left of the window it is in:
    :mod:`~gantry_sim.controller.planner.windows`). ``onward``: where one child planned the
    whole of ``todo``, it goes on with ``onward`` (the window's next rounds) until
    :meth:`finish` stops it, and the chains it sent come with the others."""

    def __init__(
        self,
        setup: ChainSetup,
        todo: list[tuple[ChainKey, BlockLimits]],
        speeds: np.ndarray,
        onward: Onward | None = None,
    ) -> None:
        runs = _runs(todo, [_work(setup, key) for key, _ in todo])
        self._todo, self._sat = todo, setup.saturated_moving

        def then(mine: dict[int, dict[ChainKey, Chain]], send: Callable[[object], None]) -> None:
            if onward is not None and len(mine) == len(runs):  # the whole first round is here
                onward(self._seeds([mine[i] for i in range(len(runs))]), send)

        self._ahead = RunsAhead(
            lambda run: plan_chains(setup, run, speeds), runs, process_count(), then=then
        )

    def _seeds(self, results: list[dict[ChainKey, Chain]]) -> dict[SeedKey, Chain]:
        done: dict[ChainKey, Chain] = {}
        for chains in results:
            done.update(chains)
        return _by_seed_key(self._todo, done, self._sat)

    def finish(self, meanwhile: Callable[[], object] | None = None) -> dict[SeedKey, Chain]:
        """Every chain of the first round, and those planned onward, by :data:`SeedKey`;
        ``meanwhile``: called once the children are stopped, before their chains are read
        (:meth:`~gantry_sim.controller.forked_runs.RunsAhead.finish`)."""
        out = self._seeds(self._ahead.finish(meanwhile))
        for extra in self._ahead.extras:
            out.update(cast(dict[SeedKey, Chain], extra))  # what onward sent
        return out

    def close(self) -> None:
        """Stop the children (the chains are no longer wanted)."""
        self._ahead.close()


#: A chain's planning work besides its pieces, in pieces (measured in the first round of
#: 10,000-block programs: about 0.14 ms a chain, 20 us an arc piece).
CHAIN_WORK = 8
#: :func:`plan_chains_forked` splits a round of this much work over processes (about 0.2 s of
#: planning; a fork of a planner holding 1 GB costs about 20 ms) in waves of WAVE_WORK per
#: process (about 2 s), each wave's chains taken in contiguous runs of RUN_WORK (about 50 ms:
#: a run is planned in batches of its own, and a batch of a few hundred pieces costs more per
#: piece: polylines' chains of one or two pieces planned 1.8 x slower in batches of 300, while
#: a long run holds a process at the end of a wave, and its result waits for the parent).
FORK_WORK = 10_000
WAVE_WORK = 100_000
RUN_WORK = 2_000
#: An arc of more chords than this has its closed-form pieces made when its chain is planned,
#: not with its batch's: a batch's are held until its last chain is planned (a chain of ten
#: 6,000-turn helices held all their 6 million pieces at once).
BATCH_ARC_CHORDS = 16_384


def _runs(
    chains: list[tuple[ChainKey, BlockLimits]], work: list[int]
) -> list[list[tuple[ChainKey, BlockLimits]]]:
    """``chains`` (of planning ``work`` each) cut into contiguous runs of at least
    :data:`RUN_WORK` (the last one may be less)."""
    runs = []
    k = 0
    while k < len(chains):
        stop, size = k + 1, work[k]
        while stop < len(chains) and size < RUN_WORK:
            size += work[stop]
            stop += 1
        runs.append(chains[k:stop])
        k = stop
    return runs


def _work(setup: ChainSetup, key: ChainKey) -> int:
    """Chain ``key``'s planning work (:data:`CHAIN_WORK` and its pieces)."""
    return CHAIN_WORK + _pieces(setup, key)


def _pieces(setup: ChainSetup, key: ChainKey) -> int:
    """Chain ``key``'s size as its planning work goes: one, and one per chord vertex of its
    arcs."""
    return 1 + sum(g.u.size for g in setup.active[key[0] : key[1]] if isinstance(g, ArcGeometry))


def _plan_batch(
    setup: ChainSetup,
    batch: list[tuple[ChainKey, BlockLimits]],
    speeds: np.ndarray,
    out: dict[ChainKey, Chain],
) -> None:
    """Plan the chains of ``batch`` into ``out``."""
    preps = chain_preps(setup, [(key[0], key[1], lim) for key, lim in batch], speeds)
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
    if setup.arc_pieces != "jerk3":
        for (key, lim), prep in zip(batch, preps, strict=True):
            out[key] = _plan_chain(setup, key[0], key[1], lim, speeds, prep)
        return
    # a large arc's pieces are made when its chain is planned, one arc at a time
    small = [i for i, r in enumerate(requests) if r[0].u.size <= BATCH_ARC_CHORDS]
    firsts = dict(zip(small, maker.closed_forms([requests[i] for i in small]), strict=True))
    # the loose tries the arcs with one candidate may make, made beforehand all at once (one by
    # one they were 37 % of planning a polyline whose corners are blend arcs of a chord or two)
    single = [
        (not fast, maker.junction_deviation_mm(setup.smoothing[key[0] + k]))
        for (key, _), prep in zip(batch, preps, strict=True)
        for k, _, fast, _, _ in prep.arcs
    ]
    tries: list[tuple[int, tuple[bool, bool]]] = []
    for i in small:
        (g, prof, s_in, s_out), (one, dev) = requests[i], single[i]
        if one:
            patterns = loose_patterns(g, prof, firsts[i], s_in, s_out, dev)
            tries.extend((i, ends) for ends in patterns)
    made = maker.closed_forms([requests[i] for i, _ in tries], [ends for _, ends in tries])
    loose: dict[int, dict[tuple[bool, bool], Pieces]] = {}
    for (i, ends), pieces in zip(tries, made, strict=True):
        loose.setdefault(i, {})[ends] = pieces
    at = 0
    for (key, lim), prep in zip(batch, preps, strict=True):
        idx = {k: at + n for n, (k, *_) in enumerate(prep.arcs)}
        at += len(prep.arcs)
        first = {k: firsts[i] for k, i in idx.items() if i in firsts}
        tried = {k: loose[i] for k, i in idx.items() if i in loose}
        out[key] = _plan_chain(setup, key[0], key[1], lim, speeds, prep, first, tried)


#: Tries of a chain's profile with slower limits (each: :data:`SLOWER_CAP` of the speed cap,
#: and where the chain starts and ends at rest :data:`SLOWER_RAMP` of the acceleration and
#: jerk) when a Ruckig piece inside an arc left the arc or exceeded the feed (next to a moving
#: junction: while the cap is above the chain's ends, see :func:`_plan_chain`).
SLOWER_TRIES = 6
SLOWER_CAP = 0.995
SLOWER_RAMP = 0.8


def _plan_chain(
    setup: ChainSetup,
    first: int,
    stop: int,
    lim: BlockLimits,
    speeds: np.ndarray,
    prep: ChainPrep | None = None,
    pre: dict[int, Pieces] | None = None,
    pre_loose: dict[int, dict[tuple[bool, bool], Pieces]] | None = None,
) -> Chain:
    """The pieces of moves ``first..stop-1`` (one chain with the limits ``lim``) from
    ``speeds[first]`` to ``speeds[stop]`` [mm/s]; slower (:data:`SLOWER_TRIES`) while a piece
    inside an arc leaves the arc or exceeds the feed, where the arc has no moving junction, or
    has one and the speed cap is still above the chain's end speeds. The junction is marked bad
    too (its speed comes down next round) if the slower tries do not help: a lower junction
    speed leaves the profile cruising at the cap between the junctions, so where a piece there
    exceeds the feed only a lower cap helps (G5.1 glyphs at F100, LinuxCNC's
    nc_files/systems.ngc: Ruckig's pieces between the vertices of a profile cruising at 0.9999
    of the feed passed it by up to 0.8 %, and 44 junctions were backed off over 16 rounds).
    A chain with a moving end keeps its acceleration and jerk: its end speeds may need all of
    them. ``prep`` and ``pre``: the chain's preparation for ``lim`` and the closed-form pieces
    of its arcs' first candidates, by arc, where already made (not a large arc's);
    ``pre_loose``: loose tries of those, by arc and ends."""
    floor = max(float(speeds[first]), float(speeds[stop]))
    ramp = 1.0 if floor > 0.0 else SLOWER_RAMP  # a moving end may need every bit of the ramp
    for _ in range(SLOWER_TRIES):
        if prep is None:
            prep = chain_prep(setup, first, stop, lim, speeds)
        chain, off, inner_off = _chain_pieces(setup, first, stop, prep, pre, pre_loose)
        if not off and not (inner_off and lim.cap_mm_per_s > floor):
            break
        lim = replace(
            lim,
            cap_mm_per_s=max(SLOWER_CAP * lim.cap_mm_per_s, floor),
            acc_mm_per_s2=ramp * lim.acc_mm_per_s2,
            jerk_mm_per_s3=ramp * lim.jerk_mm_per_s3,
        )
        prep, pre, pre_loose = None, None, None
    return chain


def _chain_pieces(
    setup: ChainSetup,
    first: int,
    stop: int,
    prep: ChainPrep,
    pre: dict[int, Pieces] | None,
    pre_loose: dict[int, dict[tuple[bool, bool], Pieces]] | None = None,
) -> tuple[Chain, int, int]:
    """One try of :func:`_plan_chain`: the chain, and how many pieces were off inside arcs
    with no moving junction, and inside arcs with one (away from it)."""
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
        known = None if pre is None else pre.get(k)
        tried = None if pre_loose is None else pre_loose.get(k)
        dur, bad_in, bad_out = pieces.arc(
            g, part, s_in, s_out, fast, setup.smoothing[b], known, tried
        )
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
    return chain, pieces.off_pieces, pieces.inner_off_pieces
