"""A long program planned a window of moves at a time, so planning's memory is the window's.

Planning holds about 10 kB per move while it works (geometry, junction states, a round's
chains and their batch arrays): a 100,000-block program took over 1 GB. A path of at most
:data:`~gantry_sim.controller.planner.window_cut.WINDOW_MOVES` moves is planned whole, as
before. A longer one is planned window by window, the way a controller's look-ahead queue
works, but with a look-ahead long enough that the cut does not change the motion:

1. A probe plans moves [lo, hi) (hi = lo + window, or the path's end) from the speed v_lo the
   window before left at junction lo (0 at the start), to rest at hi. The move before lo is
   given as context, so junction lo gets the cap, state and smoothing the whole path gives it
   (:mod:`~gantry_sim.controller.planner.prepare`; a window's preparation:
   :mod:`~gantry_sim.controller.planner.window_prep`).
2. Where hi is the path's end, every chain is kept. Otherwise the probe's chains are kept up to
   its last chain boundary c that leaves at least
   :data:`~gantry_sim.controller.planner.window_cut.MARGIN_MOVES` moves and
   :data:`~gantry_sim.controller.planner.window_cut.MARGIN_BRAKING` braking distances (from the
   fastest speed cap of the moves after c) before hi: the rest at hi, which the probe had to
   assume, slows nothing before c (no speed after c needs more than that distance to come to
   rest, so the look-ahead's backward pass from hi reaches c above every cap). Where a stop
   (a junction of cap 0) lies between c and hi, the braking distances are not needed: the
   speed there is 0 in every round, and nothing after it reaches back before it. A chain ends at
   its look-ahead speed with no tangential acceleration, so the next window starts at c from
   (v_c, 0): the reference is continuous in position, velocity and acceleration across the
   cut, and each side keeps every limit (the cut and the windows' keys:
   :mod:`~gantry_sim.controller.planner.window_cut`).
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

While this process settles a window, the other processes plan the next window's first round
and this one prepares the windows after it
(:mod:`~gantry_sim.controller.planner.window_ahead`).

A cut may fall at a G64 stop whose two moves' profiles overlap
(:mod:`~gantry_sim.controller.planner.stop_overlap`): the window keeps its last chain back
(:attr:`Planned.pending`: its timeline kept, its phases not yet written) and the next window
overlaps it with its own first chain, as the whole program does at that stop.

Each window's kept reference goes to a
:class:`~gantry_sim.controller.planner.segmented_curve.CurveBuilder`, which writes its full
blocks of segments to a temporary file (and reads them back when the window is sent back): the
finished plan's reference is held on disk, not in memory.
"""

from __future__ import annotations

import functools
import math
from array import array
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import NamedTuple

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.planner import window_cut
from gantry_sim.controller.planner.chain_plan import Chain, SeedKey
from gantry_sim.controller.planner.prepare import Prepared
from gantry_sim.controller.planner.rounds import Round, Settled, assemble, settle_chains
from gantry_sim.controller.planner.ruckig_solver import RuckigSolver
from gantry_sim.controller.planner.segmented_curve import CurveBuilder
from gantry_sim.controller.planner.stop_overlap import Overlapped, Pending
from gantry_sim.controller.planner.window_ahead import WindowsAhead
from gantry_sim.controller.planner.window_judge import JudgedPath
from gantry_sim.controller.planner.window_prep import blend_arcs, window_of

__all__ = ["Planned", "plan_path"]


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
    ahead = WindowsAhead(solver, arc_pieces)
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
    ahead: WindowsAhead,
    progress: Callable[[float], object] | None = None,
) -> Planned:
    """:func:`plan_path`'s windows, with ``ahead``'s work beside them."""
    out = Planned()
    # per kept window: where it started, its size, and ``out`` before it
    history: list[tuple[_Start, int, _Mark]] = []
    start, size = _Start(0, -1, (0.0,)), window_cut.WINDOW_MOVES
    while True:
        lo, ctx, starts = start
        v_lo = starts[0]  # (its first round's)
        n = len(src.path.moves)
        hi = src.window_stop(lo, size)
        seed: Mapping[SeedKey, Chain] = {}
        if prepared is not None and lo == 0 and hi == n:
            pre, arcs, base = prepared, blend_arcs(src.path, prepared), 0
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
                window = window_of(src, base, hi, ctx >= 0, machine, feed_override_pct, upto)
            pre, arcs, slow, judged_to = window
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
            arcs,
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
        cut = window_cut.cut(settled, pre.caps) if hi < n else (len(settled.spans), len(pre.active))
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
        size = window_cut.WINDOW_MOVES
        upto = src.upto if src.judging else None
        following = window_cut.key_after(start.ctx, start.lo, src.window_stop, upto)
        ahead.prepare_beyond(src, following, start.starts[0], machine, feed_override_pct)
        del settled, pre, caps, arcs, window


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
