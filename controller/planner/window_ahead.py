"""The work done beside a long program's windows
(:mod:`~gantry_sim.controller.planner.windows`): the window before kept, the next windows
prepared ahead, and the next window's first round planned ahead by the other processes
(:class:`WindowsAhead`)."""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from typing import NamedTuple

import numpy as np

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.forked import process_count
from gantry_sim.controller.planner.chain_plan import (
    Chain,
    ChainKey,
    ChainsAhead,
    ChainSetup,
    SeedKey,
)
from gantry_sim.controller.planner.limits import BlockLimits
from gantry_sim.controller.planner.prepare import Prepared
from gantry_sim.controller.planner.rounds import first_round, first_speeds, settle_onward
from gantry_sim.controller.planner.ruckig_solver import RuckigSolver
from gantry_sim.controller.planner.window_cut import WindowKey, next_key
from gantry_sim.controller.planner.window_judge import JudgedPath
from gantry_sim.controller.planner.window_prep import Window, window_of

__all__ = ["FirstRound", "WindowsAhead"]


class WindowsAhead:
    """Work done beside a window's rounds: the keeping of the window before
    (:meth:`keep_later`), the next windows prepared ahead
    (:func:`~gantry_sim.controller.planner.window_prep.window_of`), and the next window's
    first round planned ahead by the other processes.

    A probe's cut is its last chain boundary with the margins after it
    (:func:`~gantry_sim.controller.planner.window_cut.cut`), and its rounds only add chain
    boundaries (a junction cap they lower may split a chain, never join two), and add them
    near offending junctions: the cut that the first round's chains give is
    nearly always the probe's own (every window of the generated programs of
    ``benchmarks/programs.py`` at 20,000 blocks). A window prepared ahead is used only when
    the next window is exactly that stretch: the same call of
    :func:`~gantry_sim.controller.planner.window_prep.prepare_window`, so the same numbers bit
    for bit. Otherwise (another cut, a window sent back) it is dropped and the
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
        self._after: tuple[WindowKey, float, WindowKey, FirstRound] | None = None
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
        (:func:`window_of`), if that is one prepared, with the chains of its first round
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
            cut = next_key(pre, base, spans, src.window_stop, upto)
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
        cut = next_key(pre, key[0], spans, src.window_stop, upto)
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
            window = window_of(src, key[0], key[1], True, machine, feed_override_pct, key[3])
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
        ready: FirstRound | None = None,
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

    def _first_round(self, window: Window, v_start: float, machine: MachineConfig) -> FirstRound:
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
        return FirstRound(setup, caps, todo, speeds, v_start)


class FirstRound(NamedTuple):
    """A window's first round, ready to plan ahead: its chain setup, junction caps [mm/s]
    (the first one the window's start speed ``v_start`` [mm/s]), chains (key, limits) and the
    speeds [mm/s] at their ends (:func:`~gantry_sim.controller.planner.rounds.first_round`)."""

    setup: ChainSetup
    caps: np.ndarray
    todo: list[tuple[ChainKey, BlockLimits]]
    speeds: np.ndarray
    v_start: float
