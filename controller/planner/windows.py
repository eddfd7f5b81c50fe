"""A long program planned a window of moves at a time, so planning's memory is the window's.

Planning holds about 10 kB per move while it works (geometry, junction states, a round's
chains and their batch arrays): a 100,000-block program took over 1 GB. A path of at most
:data:`WINDOW_MOVES` moves is planned whole, as before. A longer one is planned window by
window, the way a controller's look-ahead queue works, but with a look-ahead long enough that
the cut does not change the motion:

1. A probe plans moves [lo, hi) (hi = lo + window, or the path's end) from the speed v_lo the
   window before left at junction lo (0 at the start), to rest at hi. The move before lo is
   given as context, so junction lo gets the cap, state and smoothing the whole path gives it
   (:mod:`~gantry_sim.controller.planner.prepare`).
2. Where hi is the path's end, every chain is kept. Otherwise the probe's chains are kept up to
   its last chain boundary c that leaves at least :data:`MARGIN_MOVES` moves and
   :data:`MARGIN_BRAKING` braking distances (from the fastest speed cap of the moves after c)
   before hi: the rest at hi, which the probe had to assume, slows nothing before c (no speed
   after c needs more than that distance to come to rest, so the look-ahead's backward pass
   from hi reaches c above every cap). A chain ends at its look-ahead speed with no tangential
   acceleration, so the next window starts at c from (v_c, 0): the reference is continuous in
   position, velocity and acceleration across the cut, and each side keeps every limit.
3. The next probe must keep v_c at its start (its look-ahead may not need it lower). If it
   does (a junction after c offending in the next probe lowered it), the window before is
   planned again with twice the moves, keeping more; at worst the rest of the path is one
   window. A probe whose chains leave no boundary to cut at is widened the same way.
4. The rounds are replayed across the cut. The speed at c may come down over the probe's
   rounds (a junction before c backed off), and the whole program's rounds see the moves
   after c entered at each of those speeds in turn: which junctions after c offend, and how
   far each is backed off, depends on them. So c is a chain boundary of the probe's first
   round (rounds only add boundaries: it is one in every round), and the next probe's round
   k starts from the probe's round-k speed at c (:func:`_replay`; the rounds go on at least
   that long). Started from the last speed alone, 50,000 polyline blocks in windows of 5,000
   planned an 811.2844 s cycle where the whole program's is 811.2864 s.

Where the margin holds, every kept chain is planned from the end speeds the whole program
gives it, so the windows give the whole-program plan bit for bit: the generated programs of
``benchmarks/programs.py`` at 5,000 blocks in windows of 1,000
(``benchmarks/bench_plan_windows.py``), and ``tests/test_plan_windows.py``'s program in
windows of 16-60 moves.

A cut may fall at a G64 stop whose two moves' profiles overlap
(:mod:`~gantry_sim.controller.planner.stop_overlap`): the window keeps its last chain back
(:attr:`Planned.pending`: its timeline kept, its phases not yet written) and the next window
overlaps it with its own first chain, as the whole program does at that stop.

Each window's kept reference goes to a :class:`~gantry_sim.controller.planner.segmented_curve.CurveBuilder`,
which writes its full blocks of segments to a temporary file (and reads them back when the
window is sent back): the finished plan's reference is held on disk, not in memory.
"""

from __future__ import annotations

import functools
import math
from array import array
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.forked import process_count
from gantry_sim.controller.planner.blend import PathPlan
from gantry_sim.controller.planner.chain_plan import (
    Chain,
    ChainKey,
    ChainsAhead,
    ChainSetup,
    SeedKey,
)
from gantry_sim.controller.planner.limits import BlockLimits
from gantry_sim.controller.planner.move_geometry import ArcGeometry, MoveGeometry
from gantry_sim.controller.planner.prepare import Prepared, prepare, sub_path
from gantry_sim.controller.planner.rounds import (
    Round,
    Settled,
    assemble,
    first_round,
    first_speeds,
    settle_chains,
    settle_onward,
)
from gantry_sim.controller.planner.ruckig_solver import RuckigSolver
from gantry_sim.controller.planner.segmented_curve import CurveBuilder
from gantry_sim.controller.planner.stop_overlap import Overlapped, Pending
from gantry_sim.controller.planner.window_judge import JudgedPath

__all__ = [
    "MARGIN_BRAKING",
    "MARGIN_MOVES",
    "WINDOW_MOVES",
    "Planned",
    "plan_path",
]

#: Path moves planned at a time (a path up to this long is planned whole): about 50 MB of
#: planning's working set.
WINDOW_MOVES = 5_000
#: Moves of a probe after the kept part, at least ...
MARGIN_MOVES = 250
#: ... and this many braking distances (from the probe's fastest speed cap to rest) [1].
MARGIN_BRAKING = 2.0


@dataclass
class Planned:
    """A path planned: its timeline, in compact arrays (a long program's take 40 bytes a move
    instead of 300 as Python objects).

    Attributes:
        duration_s: the end's time [s].
        ruckig_pieces: arc pieces Ruckig made.
        move_start_s: per entry of the timeline (a move, or a dwell), its start time [s].
        lines: per entry, its program line.
        entries: per entry, flattened pairs: the first and last active move of the whole path
            it is (a move: its index twice) or lies between (a dwell).
        sources: per active move, flattened pairs: the first and last program move it comes
            from.
        curve: the reference of the windows kept.
        overlaps: the stops overlapped
            (:mod:`~gantry_sim.controller.planner.stop_overlap`).
        pending: the last window's last chain, held back for an overlap with the next
            window's first (its timeline entries are kept; its phases not yet in ``curve``).
    """

    duration_s: float = 0.0
    ruckig_pieces: int = 0
    move_start_s: array = field(default_factory=lambda: array("d"))
    lines: array = field(default_factory=lambda: array("q"))
    entries: array = field(default_factory=lambda: array("q"))
    sources: array = field(default_factory=lambda: array("q"))
    curve: CurveBuilder = field(default_factory=CurveBuilder)
    overlaps: list[Overlapped] = field(default_factory=list)
    pending: Pending | None = None


def plan_path(
    src: JudgedPath,
    machine: MachineConfig,
    feed_override_pct: float,
    arc_pieces: str,
    solver: RuckigSolver,
    prepared: Prepared | None = None,
    progress: Callable[[float], object] | None = None,
) -> Planned:
    """Plan ``src.path`` (see the module docstring), judging its blends window by window while
    ``src`` does (:mod:`~gantry_sim.controller.planner.window_judge`: at the first window with
    a slow blend, ``src`` makes the path again and that window is planned again on it);
    ``prepared``: its :func:`prepare` when made already (a path planned whole, judged).
    ``progress``: called with the share of the path planned (0 to 1) as each window is planned
    (a window may still be planned again, so the share can come back)."""
    ahead = _Ahead(solver, arc_pieces)
    try:
        return _plan_windows(
            src, machine, feed_override_pct, arc_pieces, solver, prepared, ahead, progress
        )
    finally:
        ahead.drop()  # chains still planned ahead (an error, their window not used) stopped


def _plan_windows(
    src: JudgedPath,
    machine: MachineConfig,
    feed_override_pct: float,
    arc_pieces: str,
    solver: RuckigSolver,
    prepared: Prepared | None,
    ahead: _Ahead,
    progress: Callable[[float], object] | None = None,
) -> Planned:
    """:func:`plan_path`'s windows, with ``ahead``'s work beside them."""
    out = Planned()
    # per kept window: where it started, its size, and ``out`` before it
    history: list[tuple[_Start, int, _Mark]] = []
    start, size = _Start(0, -1, (0.0,)), WINDOW_MOVES
    while True:
        lo, ctx, starts = start
        v_lo = starts[0]  # (its first round's)
        n = len(src.path.moves)
        hi = min(n, lo + size)
        seed: Mapping[SeedKey, Chain] = {}
        if prepared is not None and lo == 0 and hi == n:
            pre, blend_arcs, base = prepared, _blend_arcs(src.path, prepared), 0
        else:
            base = ctx if ctx >= 0 else lo
            upto = src.upto if src.judging else None
            key = (base, hi, ctx >= 0, upto)
            taken = ahead.take(
                key,
                functools.partial(
                    ahead.start_after,
                    src,
                    key=key,
                    v_lo=v_lo,
                    machine=machine,
                    feed_override_pct=feed_override_pct,
                ),
            )
            if taken is not None:
                window, seed = taken
            else:
                window = _window_of(src, base, hi, ctx >= 0, machine, feed_override_pct, upto)
            pre, blend_arcs, slow, judged_to = window
            if slow:  # the path is made again without them: this window again, on it
                src.remake(slow, judged_to)
                ahead.drop()
                continue
            src.upto = max(src.upto, judged_to)
        caps = pre.caps.copy()
        settled = settle_chains(
            pre.active,
            caps,
            pre.states,
            machine,
            solver,
            arc_pieces,
            pre.smoothing,
            blend_arcs,
            ahead.job(src, pre, base, hi, machine, feed_override_pct),
            seed,
            starts=starts,
        )
        del seed
        ahead.keep_now()  # the window before is kept by now (it may be taken back next)
        if settled.speeds[0] != starts[-1] and history:  # the window before must keep less speed
            start, used, mark = history.pop()
            _truncate(out, mark)
            size = 2 * used  # each time it comes back, wider: at worst the rest of the path
            continue
        cut = _cut(settled) if hi < n else (len(settled.spans), len(pre.active))
        if cut is None:  # no chain boundary to cut at: a wider window
            size *= 2
            continue
        count, c = cut
        history.append((start, size, _mark(out)))
        keep = functools.partial(_assemble_and_keep, out, settled, pre, count, c, hi == n)
        if hi == n:
            keep()
            if out.pending is not None:
                raise AssertionError("the last window held a chain back")
            return out
        ahead.keep_later(keep)
        start = _Start(base + pre.path_index[c], base + pre.path_index[c - 1], _replay(settled, c))
        if progress is not None:
            progress(start.lo / n)
        size = WINDOW_MOVES
        following = _key_after(start.ctx, start.lo, n, src.upto if src.judging else None)
        ahead.prepare_beyond(src, following, start.starts[0], machine, feed_override_pct)
        del settled, pre, caps, blend_arcs, window


class _Start(NamedTuple):
    """Where a window starts: its first path move, the move before it (context; -1: none) and
    the speed [mm/s] at the junction between in each round of the window before (the last:
    the speed its kept chains end at; :func:`_replay`)."""

    lo: int
    ctx: int
    starts: tuple[float, ...]


def _replay(settled: Settled, c: int) -> tuple[float, ...]:
    """The speeds [mm/s] at the cut ``c`` (a chain boundary in every round) in each round of
    ``settled``, less the repeats at the end: the next window's rounds start from them
    (:func:`~gantry_sim.controller.planner.rounds.settle`'s ``starts``), so that its chains
    after the cut see, round by round, the speeds the whole program's rounds give them. From
    the last speed alone, the junctions just after a cut whose speed came down in later rounds
    were backed off otherwise than in the whole program (50,000 polyline blocks in windows of
    5,000: 2 ms of an 811 s cycle)."""
    out = [float(h[c]) for h in settled.round_speeds]
    if any(math.isnan(v) for v in out):
        raise AssertionError("a window's cut must be a chain boundary in every round")
    while len(out) > 1 and out[-1] == out[-2]:
        out.pop()
    return tuple(out)


class _Mark(NamedTuple):
    """The lengths of a :class:`Planned` before a window was kept (to take it back)."""

    entries: int
    chunks: int
    ruckig_pieces: int
    duration_s: float
    sources: int  # flattened: twice the moves
    overlaps: int
    pending: Pending | None


def _mark(out: Planned) -> _Mark:
    return _Mark(
        len(out.lines),
        len(out.curve),
        out.ruckig_pieces,
        out.duration_s,
        len(out.sources),
        len(out.overlaps),
        out.pending,
    )


def _truncate(out: Planned, mark: _Mark) -> None:
    """Take back what was kept after ``mark``."""
    del out.move_start_s[mark.entries :], out.lines[mark.entries :]
    del out.entries[2 * mark.entries :], out.sources[mark.sources :]
    out.curve.truncate(mark.chunks)
    out.ruckig_pieces, out.duration_s = mark.ruckig_pieces, mark.duration_s
    del out.overlaps[mark.overlaps :]
    out.pending = mark.pending


#: A window by (its first stretch move, its stop, whether the first is context, the path move
#: its judging starts from or None).
WindowKey = tuple[int, int, bool, int | None]
#: A window prepared (:func:`_window_of`): its preparation, its G64 blend arcs, the slow blends
#: it judged and the path move it judged them up to (None: not judged).
Window = tuple[Prepared, frozenset[int], frozenset[int], int]


def _window_of(
    src: JudgedPath,
    base: int,
    hi: int,
    context: bool,
    machine: MachineConfig,
    feed_override_pct: float,
    upto: int | None,
) -> Window:
    """The window of path moves ``base:hi`` (the first one ``context``) prepared
    (:func:`_window`), its G64 blend arcs (:func:`_blend_arcs`), and, from path move ``upto``
    on (None: none), the blends it judges slow
    (:meth:`~gantry_sim.controller.planner.window_judge.JudgedPath.judge`)."""
    stretch = sub_path(src.path, base, hi, base + context)
    pre = _window(stretch, machine, feed_override_pct, context)
    arcs = _blend_arcs(stretch, pre)
    if upto is None:
        return pre, arcs, frozenset(), 0
    return pre, arcs, *src.judge(stretch, pre, base, hi, upto)


def _blend_arcs(stretch: PathPlan, pre: Prepared) -> frozenset[int]:
    """The G64 blend arcs of a window, by id of its own moves (a path on disk reads back
    copies), and its curves under Marlin's M204 path acceleration: neither tries the faster
    profiles (boosted, saturated), which take the axes' own limits, not the path's."""
    arcs = {id(pre.geoms[k].move) for k in stretch.blend_junction}
    acc = pre.path_acc_mm_per_s2
    if acc is not None:
        arcs |= {
            id(g.move)
            for g, a in zip(pre.active, acc, strict=True)
            if isinstance(g, ArcGeometry) and a < math.inf
        }
    return frozenset(arcs)


class _Ahead:
    """Work done beside a window's rounds: the keeping of the window before
    (:meth:`keep_later`), the next windows' :func:`_window` prepared ahead, and the next
    window's first round planned ahead by the other processes.

    A probe's cut is its last chain boundary with the margins after it (:func:`_cut`), and its
    rounds only add chain boundaries (a junction cap they lower may split a chain, never join
    two), and add them near offending junctions: the cut that the first round's chains give is
    nearly always the probe's own (every window of the generated programs of
    ``benchmarks/programs.py`` at 20,000 blocks). A window prepared ahead is used only when
    the next window is exactly that stretch: the same call of :func:`_window`, so the same
    numbers bit for bit. Otherwise (another cut, a window sent back) it is dropped and the
    window prepared as usual. Preparing never raises here: an error in that stretch is raised
    where the window is prepared for use, in the order a plan without it meets it.

    The pipeline, window by window: at a window's first round (its cut known), the next
    window's first round is started over the other processes
    (:class:`~gantry_sim.controller.planner.chain_plan.ChainsAhead`, from the speed the cut
    has in this first round; that window prepared now if it was not yet), while this process
    plans the rounds left of its window (alone: the others hold their cores), keeps it, and
    prepares the window after the next one (its cut is that of the next window's first round,
    whose caps are known once this window's end speed is). Where one other process planned
    the whole first round, it goes on with that window's next rounds
    (:func:`~gantry_sim.controller.planner.rounds.settle_onward`: the calls this process will
    make, from the same speed) until the window is taken. The next window then takes the
    chains planned ahead as its seed
    (:func:`~gantry_sim.controller.planner.rounds.settle_chains`), with this process taking
    the chains still left: a chain of the same seed key is the same chain, so the plan is the
    same bit for bit, and where the window's start speed came out otherwise (a junction near
    the cut backed off), the chains that speed reaches are planned then. Before, this process
    was busy the whole plan while the other cores waited through the rounds after the first,
    the look-ahead and the bookkeeping between them. Only where the chains are planned over
    several processes: in one process it would just come earlier.

    The window after the next one is started over the other processes the moment they are
    stopped (:meth:`take` calls :meth:`start_after`: the next window's first-round look-ahead
    from its start speed gives that cut and its speed, as the first round will), before this
    process reads the chains they sent and keeps the window before; :meth:`prepare_beyond`
    makes both look-aheads and that first round while the others still plan ahead. When the
    next window's rounds were started only at its first round, the other cores waited
    0.10-0.25 s a window (30,000 polyline blocks, 11 windows); they now wait about 0.01 s."""

    def __init__(self, solver: RuckigSolver, arc_pieces: str) -> None:
        self._solver, self._arc_pieces = solver, arc_pieces
        self._ready: dict[WindowKey, Window] = {}
        #: the window whose first round is planned ahead, from what speed [mm/s], and by whom
        self._chains: tuple[WindowKey, float, ChainsAhead] | None = None
        #: for the next window (its key, entered at what speed [mm/s]): the window after it,
        #: and that one's first round ready to start (:meth:`prepare_beyond`)
        self._after: tuple[WindowKey, float, WindowKey, _FirstRound] | None = None
        self._keep: Callable[[], None] | None = None

    def keep_later(self, keep: Callable[[], None]) -> None:
        """Keep the window just planned (assemble its timeline, write its reference) while the
        next window's first round is planned by the other processes, or at once where there
        are none (one process, or the others busy with the next window already)."""
        self._keep = keep
        if process_count() <= 1:
            self.keep_now()

    def keep_now(self) -> None:
        """The keeping of :meth:`keep_later`, if not done yet."""
        keep, self._keep = self._keep, None
        if keep is not None:
            keep()

    def take(
        self, key: WindowKey, start_after: Callable[[Window], object] | None = None
    ) -> tuple[Window, Mapping[SeedKey, Chain]] | None:
        """The window prepared ahead for (first stretch move, stop, with context, judged from)
        (:func:`_window_of`), if that is one prepared, with the chains of its first round
        planned ahead (this process plans those left); otherwise nothing prepared is kept.
        ``start_after(window)``: called with the window taken as soon as the processes that
        planned ahead for it are stopped, before their chains are read (:meth:`start_after`:
        the other cores go on with the window after it at once)."""
        window = self._ready.pop(key, None)
        if window is None:
            self.drop()
            return None
        chains, self._chains = self._chains, None
        if chains is not None and chains[0] != key:
            chains[2].close()
            chains = None
        meanwhile = None if start_after is None else functools.partial(start_after, window)
        if chains is None:
            if meanwhile is not None:
                meanwhile()
            return window, {}
        return window, chains[2].finish(meanwhile)

    def drop(self) -> None:
        """Forget the windows prepared ahead (their path was made again, or a window was
        sent back) and stop the planning of a first round ahead."""
        self._ready.clear()
        self._after = None
        chains, self._chains = self._chains, None
        if chains is not None:
            chains[2].close()

    def job(
        self,
        src: JudgedPath,
        pre: Prepared,
        base: int,
        hi: int,
        machine: MachineConfig,
        feed_override_pct: float,
    ) -> Callable[[list[tuple[int, int]], np.ndarray], Callable[[], object] | None] | None:
        """For :func:`~gantry_sim.controller.planner.rounds.settle_chains`: from the first
        round's chain spans and speeds [mm/s], the job starting the next window's first round
        (None: the last window, no cut, or one process)."""
        n = len(src.path.moves)
        if hi >= n or process_count() <= 1:
            return None
        upto = src.upto if src.judging else None  # as the next window will judge

        def after(spans: list[tuple[int, int]], speeds: np.ndarray) -> Callable[[], object] | None:
            cut = _next_key(pre, base, spans, n, upto)
            if cut is None:
                return None
            key, v_cut = cut[0], float(speeds[cut[1]])

            def start_next() -> None:
                self.keep_now()
                self._start_next(src, key, v_cut, machine, feed_override_pct)

            return start_next

        return after

    def start_after(
        self,
        src: JudgedPath,
        window: Window,
        key: WindowKey,
        v_lo: float,
        machine: MachineConfig,
        feed_override_pct: float,
    ) -> None:
        """Start the first round of the window after ``window`` (``key``, entered at ``v_lo``
        [mm/s]) over the other processes now, as the first round of
        :func:`~gantry_sim.controller.planner.rounds.settle_chains` on ``window`` would
        (:meth:`job`: the same cut, from the same speed), so that they do not wait for this
        process to read what they planned for ``window`` and to start that round (ready since
        :meth:`prepare_beyond` where it was entered at that speed). Nothing where ``window``
        blends a corner slowly (its path is made again) or is the last."""
        if window[2] or key[1] >= len(src.path.moves) or process_count() <= 1:
            return
        after, self._after = self._after, None
        beyond = None if after is None else self._ready.get(after[2])
        if after is not None and beyond is not None and after[:2] == (key, v_lo):
            self._start(beyond, after[2], after[3].v_start, machine, after[3])
        else:
            cut = self._cut_after(src, window, key, v_lo)
            if cut is None:
                return
            self._start_next(src, cut[0], cut[1], machine, feed_override_pct)
        self.keep_now()  # the window before, while the others plan

    def _cut_after(
        self, src: JudgedPath, window: Window, key: WindowKey, v_lo: float
    ) -> tuple[WindowKey, float] | None:
        """The key of the window after ``window`` (``key``, entered at ``v_lo`` [mm/s]) and
        its start speed [mm/s], as the first round of ``window`` will find them (None: no
        cut)."""
        pre, _, _, judged_to = window
        caps = pre.caps.copy()
        caps[0] = v_lo
        spans, speeds = first_speeds([g.limits for g in pre.active], caps)
        upto = max(src.upto, judged_to) if src.judging else None
        cut = _next_key(pre, key[0], spans, len(src.path.moves), upto)
        return None if cut is None else (cut[0], float(speeds[cut[1]]))

    def _start_next(
        self,
        src: JudgedPath,
        key: WindowKey,
        v_cut: float,
        machine: MachineConfig,
        feed_override_pct: float,
    ) -> None:
        """Plan the first round of window ``key`` from ``v_cut`` [mm/s] over the other
        processes (prepared now if it is not yet), unless they do so already."""
        if self._chains is not None and self._chains[:2] == (key, v_cut):
            return
        window = self._ready.get(key) or self._prepare(src, key, machine, feed_override_pct)
        if window is not None and not window[2]:
            self._start(window, key, v_cut, machine)

    def prepare_beyond(
        self,
        src: JudgedPath,
        key: WindowKey,
        v_start: float,
        machine: MachineConfig,
        feed_override_pct: float,
    ) -> None:
        """Prepare the window after the next one (``key``, starting at ``v_start`` [mm/s]), if
        that one is prepared, blends none of its corners slowly and is not the last, and make
        its first round ready to start (:meth:`start_after`: when the next window is taken,
        the other processes go on with it at once)."""
        window = self._ready.get(key)
        n = len(src.path.moves)
        if window is None or window[2] or key[1] >= n or self._chains is None:
            return  # (nothing planned ahead: the next window's first round prepares it)
        cut = self._cut_after(src, window, key, v_start)
        if cut is None:
            return
        beyond = self._ready.get(cut[0]) or self._prepare(src, cut[0], machine, feed_override_pct)
        if beyond is not None and not beyond[2]:
            ready = self._first_round(beyond, cut[1], machine)
            self._after = (key, v_start, cut[0], ready)

    def _prepare(
        self,
        src: JudgedPath,
        key: WindowKey,
        machine: MachineConfig,
        feed_override_pct: float,
    ) -> Window | None:
        try:
            window = _window_of(src, key[0], key[1], True, machine, feed_override_pct, key[3])
        except Exception:  # raised again where the window is prepared for use
            return None
        self._ready[key] = window
        return window

    def _start(
        self,
        window: Window,
        key: WindowKey,
        v_start: float,
        machine: MachineConfig,
        ready: _FirstRound | None = None,
    ) -> None:
        """Plan the first round of ``window`` from ``v_start`` [mm/s] over the other
        processes (``ready``: that round, if made already from that speed)."""
        if self._chains is not None:
            self._chains[2].close()
            self._chains = None
        if ready is None or ready.v_start != v_start:
            ready = self._first_round(window, v_start, machine)
        setup, caps, todo, speeds, _ = ready
        ahead = ChainsAhead(setup, todo, speeds, settle_onward(setup, caps))
        self._chains = (key, v_start, ahead)

    def _first_round(self, window: Window, v_start: float, machine: MachineConfig) -> _FirstRound:
        """The first round of ``window`` entered at ``v_start`` [mm/s], to plan ahead."""
        pre, blend_arcs, _, _ = window
        caps = pre.caps.copy()
        caps[0] = v_start
        setup = ChainSetup(
            pre.active,
            pre.states,
            machine,
            self._solver,
            self._arc_pieces,
            pre.smoothing,
            {},
            blend_arcs,
        )
        todo, speeds = first_round(setup, caps)
        return _FirstRound(setup, caps, todo, speeds, v_start)


class _FirstRound(NamedTuple):
    """A window's first round, ready to plan ahead: its chain setup, junction caps [mm/s]
    (the first one the window's start speed ``v_start`` [mm/s]), chains (key, limits) and the
    speeds [mm/s] at their ends (:func:`~gantry_sim.controller.planner.rounds.first_round`)."""

    setup: ChainSetup
    caps: np.ndarray
    todo: list[tuple[ChainKey, BlockLimits]]
    speeds: np.ndarray
    v_start: float


def _next_key(
    pre: Prepared,
    base: int,
    spans: list[tuple[int, int]],
    n: int,
    upto: int | None,
) -> tuple[WindowKey, int] | None:
    """The key of the window after the cut that ``spans`` give a window (path moves from
    ``base``, prepared as ``pre``; the path has ``n`` moves) -- its first stretch move (the
    context), its stop, True, and the move its judging starts from -- and the cut's active
    move; None: no cut."""
    cut = _cut_at(pre.active, spans)
    if cut is None:
        return None
    c = cut[1]
    return _key_after(base + pre.path_index[c - 1], base + pre.path_index[c], n, upto), c


def _key_after(ctx: int, lo: int, n: int, upto: int | None) -> WindowKey:
    """The key of the window that starts at path move ``lo`` after its context ``ctx``, on a
    path of ``n`` moves, judging its blends from ``upto``."""
    return (ctx, min(n, lo + WINDOW_MOVES), True, upto)


def _window(
    stretch: PathPlan, machine: MachineConfig, feed_override_pct: float, context: bool
) -> Prepared:
    """:func:`prepare` of a window's ``stretch``, less its first move when that is ``context``
    (the move before the window; ``path_index`` stays counted from the stretch's start)."""
    pre = prepare(stretch, machine, feed_override_pct, {})
    if not context:
        return pre
    if not (pre.path_index and pre.path_index[0] == 0):
        raise AssertionError("a window's context must be a move with length")
    return Prepared(
        pre.geoms,
        pre.active[1:],
        pre.path_index[1:],
        pre.caps[1:],
        pre.states[1:],
        {b - 1: d for b, d in pre.holds.items() if b >= 1},
        pre.smoothing[1:],
        pre.sources[1:],
        None if pre.path_acc_mm_per_s2 is None else pre.path_acc_mm_per_s2[1:],
        {b - 1: e for b, e in pre.stop_corners.items() if b >= 1},
    )


def _cut(settled: Settled) -> tuple[int, int] | None:
    """Where a probe is cut: (chains kept, the active move after them), at its last chain
    boundary of the first round (a boundary in every round, :func:`_replay`) with the margins
    of the module docstring after it; None where there is none."""
    cut = _cut_at(settled.setup.active, settled.first_spans)
    if cut is None:
        return None
    c = cut[1]
    return next(k for k, (first, _) in enumerate(settled.spans) if first == c), c


def _cut_at(active: list[MoveGeometry], spans: list[tuple[int, int]]) -> tuple[int, int] | None:
    """:func:`_cut` of chains ``spans`` over the moves ``active``."""
    lengths = np.array([g.limits.length_mm for g in active])
    behind = np.concatenate((np.cumsum(lengths[::-1])[::-1], [0.0]))  # path length to the end
    braking = np.array([_braking_mm(g.limits) for g in active] + [0.0])
    needed = MARGIN_BRAKING * np.maximum.accumulate(braking[::-1])[::-1]  # from here on
    for k in range(len(spans) - 1, 0, -1):
        first = spans[k][0]
        if len(active) - first >= MARGIN_MOVES and behind[first] >= needed[first]:
            return k, first
    return None


def _braking_mm(lim: BlockLimits) -> float:
    """Distance [mm] to come to rest from a block's speed cap with its acceleration and jerk:
    an upper bound, v^2 / 2a + v a / j (the jerk-limited stop takes v^2 / 2a + v a / 2j, or
    v sqrt(v / j) when v < a^2 / j; inf for a block without a finite cap)."""
    v, a, j = lim.cap_mm_per_s, lim.acc_mm_per_s2, lim.jerk_mm_per_s3
    return v * v / (2.0 * a) + v * a / j if np.isfinite(v) else math.inf


def _assemble_and_keep(
    out: Planned, settled: Settled, pre: Prepared, count: int, c: int, end: bool
) -> None:
    """:func:`_keep` the timeline of the first ``count`` chains of ``settled`` (with the end's
    dwells when ``end``), its times counting from where ``out`` ends."""
    kept = assemble(
        settled,
        pre.holds,
        count,
        end_hold=end,
        start_s=out.duration_s,
        corners=pre.stop_corners,
        path_acc=pre.path_acc_mm_per_s2,
        before=out.pending,
        hold_last=not end and c in pre.stop_corners,
    )
    _keep(out, pre, kept, c)


def _keep(out: Planned, pre: Prepared, kept: Round, moves: int) -> None:
    """Append a window's kept timeline (of its first ``moves`` active moves) to ``out``: its
    entries moved to the whole path's active moves (its times already count from the path's
    start)."""
    base = len(out.sources) // 2
    out.curve.extend(kept.chunks)
    out.move_start_s.extend(kept.move_start_s)
    out.lines.extend(kept.lines)
    out.entries.extend(k + base for pair in kept.entries for k in pair)
    out.ruckig_pieces += kept.ruckig_pieces
    out.duration_s = kept.duration_s  # counted from the path's start
    out.overlaps.extend(kept.overlaps)
    out.pending = kept.pending
    out.sources.extend(k for pair in pre.sources[:moves] for k in pair)
