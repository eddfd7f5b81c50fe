"""One move's 1-D profile -> the reference's constant-jerk phases
(:mod:`gantry_sim.controller.planner.cubic`).

Straight moves (G0/G1) are the profile projected on the line. Arcs: the profile is sampled at
the vertices (:func:`gantry_sim.controller.planner.arc_states.vertex_states`: exact arc states,
positions [mm], velocities [mm/s], accelerations [mm/s^2]) and consecutive states are joined by
closed-form constant-jerk pieces (:mod:`gantry_sim.controller.planner.jerk3`); the pieces that
would break a limit are made by the
:class:`~gantry_sim.controller.planner.ruckig_solver.RuckigSolver` passed in. Pieces next to a
moving junction are checked against the arc.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from gantry_sim.controller.config import Limits
from gantry_sim.controller.errors import PlannerFailure
from gantry_sim.controller.moves import Arc, Transition
from gantry_sim.controller.planner.arc_batch import (
    arc_deviation_many,
    arc_deviation_one,
    piece_points_many,
)
from gantry_sim.controller.planner.arc_states import (
    LOOSE_END_CHORDS,
    VertexStates,
    vertex_states_many,
)
from gantry_sim.controller.planner.cubic import CubicBuilder, Jerk3Run
from gantry_sim.controller.planner.jerk3 import (
    PiecePhases,
    jerk3_pairs,
    jerk3_points,
    piece_limits_ok,
)
from gantry_sim.controller.planner.junctions import EndState
from gantry_sim.controller.planner.move_geometry import ArcGeometry, MoveGeometry
from gantry_sim.controller.planner.piece_speed import speed_exceeds
from gantry_sim.controller.planner.profile import Profile1D
from gantry_sim.controller.planner.ruckig_solver import (
    RUCKIG_MAX_DURATION_S,
    RuckigPiece,
    RuckigRejected,
    RuckigSolver,
    too_slow_for_ruckig,
)
from gantry_sim.controller.planner.transition_geometry import transition_deviation_many

#: Largest distance of a piece next to a moving junction from the arc, in chord tolerances;
#: beyond it the junction's speed is lowered and the program planned again. The check samples 25
#: points per piece; 0.23 leaves 0.02 below the 0.25 the benchmark allows (measured on 0.1 ms
#: samples: 0.201 worst), and lets S-bends keep 26 mm/s instead of backing off to 16.
JUNCTION_DEVIATION_MAX = 0.23
#: A Ruckig piece next to a moving junction may last this much longer than the profile gives
#: it, when its samples stay within the junction's deviation budget and it keeps the feed (as
#: every other Ruckig piece must); stretched further, the junction's speed comes down. Measured
#: on 20,000 generated tangent arcs: the end pieces Ruckig stretched came in two groups, by
#: 1.001-1.01 (about a third: each one planned again at 0.9 of its speed, a round of its own,
#: when 1.001 was the limit) and by 14-2,400 (an end state out of reach); 1.02 planned them in
#: 13.9 s instead of 16.8, with a 0.45 % shorter cycle and a reference no farther from the path.
END_STRETCH_MAX = 1.02
#: An arc whose end offends is tried again with the profile's phase switches near that end
#: dropped (:func:`~gantry_sim.controller.planner.arc_states.vertex_states_many`), unless its
#: profile comes within this share of the feed: a closed-form piece across a switch up to the
#: feed overshoots it (by 0.05 % on CAMotics' cameo relief, where 461 retries of 2,508 blend
#: arcs all failed so, and took a third of the plan's time).
LOOSE_FEED_ROOM = 2e-3
#: Samples of a Ruckig piece checked against the arc (its speed is checked exactly against the feed).
PIECE_SAMPLES = 25
#: closed-form pieces made and checked at once (their temporaries take about 1 KB a piece: a
#: chain of ten 6,000-turn helices, 6 million chords, held 7 GB at once); the numbers are the
#: same whatever the block (each piece is its own row)
PIECE_BLOCK = 16_384


@dataclass(frozen=True, eq=False)
class Pieces:
    """An arc's vertex states and the closed-form pieces between them.

    Attributes:
        states: the exact arc states the pieces join.
        phases: the closed-form pieces (None when every piece goes to Ruckig).
        ok: (k - 1,) True where the closed-form piece keeps every limit.
        end_dev_mm: the distance [mm] from the arc of the end pieces next to a moving
            junction, by piece index, where already measured (:meth:`MovePieces.closed_forms`).
    """

    states: VertexStates
    phases: PiecePhases | None
    ok: np.ndarray
    end_dev_mm: dict[int, float] = field(default_factory=dict)


class MovePieces:
    """Collects the reference's phases, move by move, and counts the pieces by kind.

    ``limits``: the machine's per-axis limits; ``chord_tolerance_mm``: scales the deviation
    allowed next to junctions; ``pieces``: "jerk3" (closed-form pieces, Ruckig where they break
    a limit) or "ruckig"; ``solver`` makes the Ruckig pieces.
    """

    def __init__(
        self, limits: Limits, chord_tolerance_mm: float, pieces: str, solver: RuckigSolver
    ) -> None:
        self.limits = limits
        self.pieces = pieces
        self.solver = solver
        self.chord_tolerance_mm = chord_tolerance_mm
        self.dev_max = JUNCTION_DEVIATION_MAX * chord_tolerance_mm
        self.out = CubicBuilder()
        self.ruckig_pieces = 0
        #: Ruckig pieces that left the arc or exceeded the feed on an arc with no moving
        #: junction (lowering a junction's speed cannot help: the planner slows the profile).
        self.off_pieces = 0
        #: Such pieces inside an arc with a moving junction, away from it: that junction is
        #: marked bad, and the planner first slows the profile where its ends leave it room.
        self.inner_off_pieces = 0

    def junction_deviation_mm(self, smoothing_mm: float) -> float:
        """The deviation [mm] allowed the pieces next to an arc's moving junctions: the
        default, or the arc's smoothing budget ``smoothing_mm`` (a G64 blend arc's) where
        larger."""
        return max(self.dev_max, smoothing_mm)

    def inner_deviation_mm(self, g: ArcGeometry) -> float:
        """The deviation [mm] allowed the pieces of ``g`` away from its moving junctions:
        :data:`JUNCTION_DEVIATION_MAX` of the chord tolerance its vertices were laid within."""
        return max(self.dev_max, JUNCTION_DEVIATION_MAX * g.chord_tolerance_mm)

    def straight(self, g: MoveGeometry, profile: Profile1D) -> float:
        """The profile projected on the straight move; its duration [s]."""
        for i in range(3):
            d = g.tangent_in[i]
            self.out.add(
                i,
                profile.dur,
                g.start[i] + d * profile.s,
                d * profile.v,
                d * profile.a,
                d * profile.j,
            )
        return profile.duration_s

    def arc(
        self,
        g: ArcGeometry,
        profile: Profile1D,
        state_in: EndState,
        state_out: EndState,
        fast: Sequence[Profile1D] = (),
        dev_max_mm: float = 0.0,
        known: Pieces | None = None,
        loose_known: dict[tuple[bool, bool], Pieces] | None = None,
    ) -> tuple[float, bool, bool]:
        """Pieces between the exact arc states at the vertices: of the first profile in ``fast``
        (faster candidates, fastest first) whose closed-form pieces all keep the limits, else of
        ``profile``. ``dev_max_mm``: the deviation allowed next to its junctions when larger than
        the default (a G64 blend arc's smoothing budget) [mm]. ``known``: the
        :meth:`closed_form` of the first candidate (``fast[0]``, else ``profile``), when
        already made (:meth:`closed_forms`); ``loose_known``: its loose tries by ends, when
        already made (:func:`loose_patterns`; with no ``fast`` only).

        Returns:
            (duration [s], bad_in, bad_out): bad_* when the piece next to a moving junction
            leaves the arc by more than :data:`JUNCTION_DEVIATION_MAX` of the chord tolerance or
            needed Ruckig to stretch it beyond :data:`END_STRETCH_MAX` (the junction speed must
            then come down).
        """
        dev_max = self.junction_deviation_mm(dev_max_mm)
        pieces, used = None, profile
        for i, cand in enumerate(() if self.pieces == "ruckig" else fast):
            found = known if i == 0 and known is not None else None
            found = found or self.closed_form(g, cand, state_in, state_out)
            ok = found.ok
            if ok[1:-1].all() and (ok[0] or state_in.moving) and (ok[-1] or state_out.moving):
                pieces, used = found, cand
                break
        if pieces is None:
            if known is not None and not fast:
                pieces = known
            else:
                pieces = self.closed_form(g, profile, state_in, state_out)
        mark = self._mark()
        done = self._emit(g, pieces, state_in, state_out, dev_max)
        if self.pieces == "ruckig" or not (done[1] or done[2]):
            return done
        if _near_feed(g, used):
            return done  # a piece across a switch up to the feed passes it: no use trying
        # the offending ends again without the profile's phase switches near them: where there
        # are some, an extra vertex within LOOSE_END_CHORDS of the end (most have none: 2,100
        # of 2,457 tries on a print made the same vertices again, 2.8 s of a 8.3 s plan)
        near = _near_switches(g, pieces)
        loose_ends = (done[1] and near[0], done[2] and near[1])
        if not any(loose_ends):
            return done
        loose = (loose_known or {}).get(loose_ends) or self.closed_form(
            g, used, state_in, state_out, loose=loose_ends
        )
        first = self._cut(mark)
        again = self._emit(g, loose, state_in, state_out, dev_max)
        if again[1] + again[2] < done[1] + done[2]:
            return again
        self._cut(mark)
        self._paste(first)
        return done

    def _inner_off(
        self, g: ArcGeometry, pieces: Pieces, lo: int, hi: int, ends: list[int], moving: bool
    ) -> bool:
        """Whether a closed-form piece ``lo`` .. ``hi - 1`` of ``g`` other than its ``ends``
        leaves it by more than :meth:`inner_deviation_mm`, counted as a Ruckig piece off the
        arc is. Measured only on a curve laid within more than the machine's chord tolerance
        (a G64 blend arc's): the pieces between vertices laid within that one are left
        unmeasured as before (random arcs from rest to rest in G61: 0.24 x the chord tolerance
        at most, sampled at 0.1 ms)."""
        if not g.chord_tolerance_mm > self.chord_tolerance_mm:
            return False
        limit = self.inner_deviation_mm(g)
        if not any(_deviation(g, pieces, k) > limit for k in range(lo, hi) if k not in ends):
            return False
        if moving:
            self.inner_off_pieces += 1
        else:
            self.off_pieces += 1
        return True

    def _mark(self) -> tuple[int, int, int, int]:
        """Where the output and the counters stand (:meth:`_cut` goes back there)."""
        self.out.flush()
        return len(self.out.segments), self.ruckig_pieces, self.off_pieces, self.inner_off_pieces

    def _cut(self, mark: tuple[int, int, int, int]) -> tuple[list, int, int, int]:
        """Take back what was added since ``mark``: its segments and counts, returned."""
        self.out.flush()
        at, ruckig, off, inner = mark
        taken = (
            self.out.segments[at:],
            self.ruckig_pieces - ruckig,
            self.off_pieces - off,
            self.inner_off_pieces - inner,
        )
        del self.out.segments[at:]
        self.ruckig_pieces, self.off_pieces, self.inner_off_pieces = ruckig, off, inner
        return taken

    def _paste(self, taken: tuple[list, int, int, int]) -> None:
        """Add back what :meth:`_cut` took."""
        segments, ruckig, off, inner = taken
        self.out.segments.extend(segments)
        self.ruckig_pieces += ruckig
        self.off_pieces += off
        self.inner_off_pieces += inner

    def _emit(
        self,
        g: ArcGeometry,
        pieces: Pieces,
        state_in: EndState,
        state_out: EndState,
        dev_max: float,
    ) -> tuple[float, bool, bool]:
        """Add the arc's pieces (Ruckig's where a closed form breaks a limit); returns
        (duration [s], bad_in, bad_out) as :meth:`arc` does."""
        st, ok = pieces.states, pieces.ok
        u, verts, vel, acc, mins = (
            st.u,
            st.positions,
            st.velocities,
            st.accelerations,
            st.durations,
        )
        n = mins.size
        mv_in, mv_out = state_in.moving, state_out.moving
        # the end pieces next to a moving junction (one piece: next to both ends)
        ends = [k for k, moving in ((0, mv_in), (n - 1, mv_out)) if moving]
        bad_in = bad_out = False
        phases = pieces.phases  # None only in "ruckig" mode, where no piece is ok
        if ok.all() and phases is not None:
            self._add_closed(phases, mins, 0, n)
            off_at = {k: _deviation(g, pieces, k) > dev_max for k in set(ends)}
            inner = self._inner_off(g, pieces, 0, n, ends, mv_in or mv_out)
            bad_in = mv_in and (off_at[0] or inner)
            bad_out = mv_out and (off_at[n - 1] or inner)
            return float(mins.sum()), bad_in, bad_out
        total = 0.0
        k = 0
        sampled: list[tuple[np.ndarray, float, RuckigPiece, bool, bool]] = []  # checked below
        while k < n:
            at_in, at_out = k == 0 and mv_in, k == n - 1 and mv_out
            if ok[k] and phases is not None:  # a run of closed-form pieces, added at once
                e = k + 1
                while e < n and ok[e]:
                    e += 1
                self._add_closed(phases, mins, k, e)
                for x in mins[k:e].tolist():  # summed in order, as piece by piece
                    total += x
                for c in {k, e - 1} & set(ends):
                    off = _deviation(g, pieces, c) > dev_max
                    bad_in |= c == 0 and mv_in and off
                    bad_out |= c == n - 1 and mv_out and off
                if self._inner_off(g, pieces, k, e, ends, mv_in or mv_out):
                    bad_in |= mv_in
                    bad_out |= mv_out
                k = e
                continue
            if self.pieces != "ruckig":
                self.ruckig_pieces += 1
            start, end = (verts[k], vel[k], acc[k]), (verts[k + 1], vel[k + 1], acc[k + 1])
            # a piece next to a moving junction that Ruckig stretched beyond END_STRETCH_MAX
            # makes that junction bad whatever its shape: it needs no samples, nor checks
            stretch_s = mins[k] * END_STRETCH_MAX + 1e-9
            try:
                piece = self.ruckig_piece(
                    g, start, end, mins[k], stretch_s if at_in or at_out else math.inf
                )
            except PlannerFailure:
                if not (at_in or at_out) or phases is None:
                    raise
                # no piece joins these states at all (under a jerk limit of some 1e6 mm/s^3 an
                # end piece lasts tens of microseconds, in which an axis cannot turn the
                # acceleration the arc asks of it): as a piece stretched without end, the
                # junction is bad and comes down; the closed form holds its place meanwhile
                # (a round with a bad junction is planned again, so it is never kept)
                self._add_closed(phases, mins, k, k + 1)
                total += float(mins[k])
                bad_in |= at_in
                bad_out |= at_out
                k += 1
                continue
            d = piece.duration_s
            total += d
            stretched = d > stretch_s
            if stretched and (at_in or at_out):
                bad_in |= at_in
                bad_out |= at_out
            elif piece.positions is not None:
                sampled.append((piece.positions, float(u[k]), piece, at_in, at_out))
            k += 1
        # the sampled Ruckig pieces against the arc, at once (each as g.deviation measures it)
        devs = _piece_deviations(g, [(q, uk) for q, uk, *_ in sampled])
        for (_, _, piece, at_in, at_out), dev in zip(sampled, devs, strict=True):
            # the smoothing budget is for the jumps at moving junctions only; inside, what the
            # vertices' own tolerance allows (a G64 blend arc's may exceed the machine's)
            near = dev_max if at_in or at_out else self.inner_deviation_mm(g)
            # the speed exactly: a short bulge falls between samples
            off = dev > near or speed_exceeds(piece.phases, g.feed_mm_per_s)
            bad_in |= at_in and off
            bad_out |= at_out and off
            if off and not (at_in or at_out):
                if mv_in or mv_out:  # their speeds must come down, unless a slower profile
                    bad_in |= mv_in  # helps (the planner tries that first)
                    bad_out |= mv_out
                    self.inner_off_pieces += 1
                else:  # no junction speed to lower: the profile must change
                    self.off_pieces += 1
        return total, bad_in, bad_out

    def _add_closed(
        self, phases: tuple[np.ndarray, ...], mins: np.ndarray, first: int, stop: int
    ) -> None:
        """Add the closed-form pieces ``first`` .. ``stop`` - 1 (``phases``: the pieces'
        phase starts and jerks; ``mins``: their durations [s], three phases each)."""
        ps, vs, as_, js = phases
        run = (ps[first:stop, 0], vs[first:stop, 0], as_[first:stop, 0], js[first:stop])
        self.out.add_jerk3(Jerk3Run(mins[first:stop] / 3.0, *run))

    def closed_form(
        self,
        g: ArcGeometry,
        profile: Profile1D,
        state_in: EndState,
        state_out: EndState,
        loose: tuple[bool, bool] = (False, False),
    ) -> Pieces:
        """Vertex states and closed-form pieces for ``profile``, and which keep the limits.
        ``loose``: whether the start and the end drop the profile's phase switches near them
        (:func:`~gantry_sim.controller.planner.arc_states.vertex_states_many`)."""
        return self.closed_forms([(g, profile, state_in, state_out)], [loose])[0]

    def closed_forms(
        self,
        requests: list[tuple[ArcGeometry, Profile1D, EndState, EndState]],
        loose: list[tuple[bool, bool]] | None = None,
    ) -> list[Pieces]:
        """:meth:`closed_form` of several (arc, profile, state in, state out) at once: the
        states, pieces and limit checks of all of them in a few vectorised calls (each number
        as when computed alone: the work is row by row)."""
        states = vertex_states_many(requests, loose)
        if self.pieces == "ruckig":
            return [Pieces(st, None, np.zeros(st.durations.size, bool)) for st in states]
        if not states:
            return []
        counts = [st.durations.size for st in states]
        pos = np.concatenate([st.positions for st in states])
        vel = np.concatenate([st.velocities for st in states])
        acc = np.concatenate([st.accelerations for st in states])
        mins = np.concatenate([st.durations for st in states])
        first = np.concatenate(([0], np.cumsum([c + 1 for c in counts])[:-1]))
        start = np.repeat(first - np.concatenate(([0], np.cumsum(counts)[:-1])), counts)
        start += np.arange(mins.size)  # each piece's first vertex in the stacked states
        feed = np.repeat([r[0].feed_mm_per_s for r in requests], counts)
        ok = mins > 1e-9
        safe = np.where(ok, mins, 1.0)
        phases, kept = pieces_between(pos, vel, acc, start, safe, self.limits, feed)
        ok &= kept
        stop = np.cumsum(counts)
        devs = _end_deviations(requests, states, phases, mins, stop - counts)
        out = []
        for st, lo, hi, dev in zip(states, stop - counts, stop, devs, strict=True):
            ph = PiecePhases(*(x[lo:hi] for x in phases))
            out.append(Pieces(st, ph, ok[lo:hi], dev))
        return out

    def ruckig_piece(
        self,
        g: MoveGeometry,
        start: tuple[np.ndarray, np.ndarray, np.ndarray],
        end: tuple[np.ndarray, np.ndarray, np.ndarray],
        min_duration_s: float,
        sampled_within_s: float = math.inf,
    ) -> RuckigPiece:
        """One 3-DoF state-to-state piece by Ruckig (see
        :meth:`~gantry_sim.controller.planner.ruckig_solver.RuckigSolver.piece`), added to
        :attr:`out`, with :data:`PIECE_SAMPLES` samples to check it if it lasts at most
        ``sampled_within_s`` [s]."""
        if min_duration_s > RUCKIG_MAX_DURATION_S:
            raise too_slow_for_ruckig(
                "one piece of its path (between two chord vertices)", min_duration_s, g.move.line
            )
        try:
            piece = self.solver.piece(start, end, min_duration_s, PIECE_SAMPLES, sampled_within_s)
        except RuckigRejected as exc:
            raise PlannerFailure(
                f"no jerk-limited piece joins two chord vertices of this {g.move.kind} move "
                f"within the machine's limits (Ruckig: {exc.reason})",
                g.move.line,
            ) from None
        for i in range(3):
            self.out.add(i, *piece.phases[i])
        return piece


def pieces_between(
    pos: np.ndarray,
    vel: np.ndarray,
    acc: np.ndarray,
    start: np.ndarray,
    dur: np.ndarray,
    limits: Limits,
    feed: np.ndarray,
) -> tuple[PiecePhases, np.ndarray]:
    """The closed-form pieces from the states ``start`` to ``start + 1`` (indices (n,) into the
    stacked states ``pos``, ``vel``, ``acc`` (m, 3) [mm], [mm/s], [mm/s^2]) lasting ``dur``
    (n,) [s], and (n,) whether each keeps every axis' ``limits`` and its ``feed`` (n,) [mm/s]
    (:func:`~gantry_sim.controller.planner.jerk3.jerk3_pairs`,
    :func:`~gantry_sim.controller.planner.jerk3.piece_limits_ok`): :data:`PIECE_BLOCK` pieces
    at a time, each piece its own row, so any block gives the same numbers."""
    n = dur.size
    phases = PiecePhases(*(np.empty((n, 3, 3)) for _ in range(4)))
    ok = np.empty(n, dtype=bool)
    for lo in range(0, n, PIECE_BLOCK):
        hi = min(n, lo + PIECE_BLOCK)
        a, b = start[lo:hi], start[lo:hi] + 1
        block = jerk3_pairs(pos[a], vel[a], acc[a], pos[b], vel[b], acc[b], dur[lo:hi])
        for whole, part in zip(phases, block, strict=True):
            whole[lo:hi] = part
        ok[lo:hi] = piece_limits_ok(
            block.v, block.a, block.j, dur[lo:hi], acc[b], *limits.per_axis(), feed[lo:hi]
        )
    return phases, ok


def _piece_deviations(g: ArcGeometry, pieces: list[tuple[np.ndarray, float]]) -> list[float]:
    """:meth:`ArcGeometry.deviation` [mm] of each (points (k, 3), sweep fraction near them):
    an arc's in one batch (:func:`arc_deviation_one`, the same numbers), a spline's one by
    one."""
    if not pieces:
        return []
    if not isinstance(g.move, Arc) or len({q.shape for q, _ in pieces}) > 1:
        return [g.deviation(q, uh) for q, uh in pieces]
    q = np.stack([q for q, _ in pieces])
    return arc_deviation_one(g.move, q, [uh for _, uh in pieces]).tolist()


def _near_feed(g: ArcGeometry, profile: Profile1D) -> bool:
    """Whether ``profile`` comes within :data:`LOOSE_FEED_ROOM` of the arc's feed (no loose
    try then)."""
    return float(profile.rows[:, 2].max()) >= (1.0 - LOOSE_FEED_ROOM) * g.feed_mm_per_s


def _near_switches(g: ArcGeometry, pieces: Pieces) -> tuple[bool, bool]:
    """Whether ``pieces`` have a vertex other than the arc's own chord vertices (a profile's
    phase switch) within :data:`LOOSE_END_CHORDS` of its start and of its end."""
    m, u = g.u.size - 1, pieces.states.u
    return 0.0 < u[1] * m < LOOSE_END_CHORDS, 0.0 < (1.0 - u[-2]) * m < LOOSE_END_CHORDS


def loose_patterns(
    g: ArcGeometry,
    profile: Profile1D,
    pieces: Pieces,
    state_in: EndState,
    state_out: EndState,
    dev_max_mm: float,
) -> list[tuple[bool, bool]]:
    """The loose tries :meth:`MovePieces.arc` may make of an arc with the single candidate
    ``profile`` (whose closed form is ``pieces``; ``dev_max_mm``: the deviation allowed next
    to its moving junctions, as :meth:`MovePieces.arc` takes it), by the ends they loosen:
    those that may offend (:func:`_may_offend`) with a phase switch near them, alone and
    together (which it makes depends on which ends do offend); none where the profile comes
    near the feed. For making them beforehand, many arcs at once
    (:meth:`MovePieces.closed_forms`): every try the arc can need is among them, and no
    other (most arcs of a polyline have switches near both ends and offend at neither: making
    all three tries for each, two of three were never used, a tenth of planning)."""
    if _near_feed(g, profile):
        return []
    near = _near_switches(g, pieces)
    may = _may_offend(pieces, state_in.moving, state_out.moving, dev_max_mm)
    ends = (may[0] and near[0], may[1] and near[1])
    if ends[0] and ends[1]:
        return [(True, False), (False, True), (True, True)]
    return [ends] if any(ends) else []


def _may_offend(
    pieces: Pieces, moving_in: bool, moving_out: bool, dev_max_mm: float
) -> tuple[bool, bool]:
    """Whether :meth:`MovePieces._emit` of ``pieces`` can find the start and the end
    offending: an end next to a moving junction whose closed-form end piece goes to Ruckig
    or leaves the arc by more than ``dev_max_mm``, or, for both moving ends, any other piece
    that goes to Ruckig (one off the arc makes them both offend)."""
    ok = pieces.ok
    last = ok.size - 1
    ends = [k for k, moving in ((0, moving_in), (last, moving_out)) if moving]
    others = np.ones(ok.size, dtype=bool)
    others[ends] = False
    shared = bool((~ok[others]).any())

    def may(k: int, moving: bool) -> bool:
        if not moving:
            return False
        if shared or not ok[k]:
            return True
        return k not in pieces.end_dev_mm or pieces.end_dev_mm[k] > dev_max_mm

    return may(0, moving_in), may(last, moving_out)


def _deviation(g: ArcGeometry, pieces: Pieces, k: int) -> float:
    """Distance [mm] from the arc of the closed-form piece ``k`` (measured on 25 points)."""
    if k in pieces.end_dev_mm:
        return pieces.end_dev_mm[k]
    ps, vs, as_, js = pieces.phases  # type: ignore[misc]
    q = jerk3_points(ps[k], vs[k], as_[k], js[k], pieces.states.durations[k])
    return g.deviation(q, pieces.states.u[k])


def _end_deviations(
    requests: list[tuple[ArcGeometry, Profile1D, EndState, EndState]],
    states: list[VertexStates],
    phases: PiecePhases,
    mins: np.ndarray,
    first: np.ndarray,
) -> list[dict[int, float]]:
    """:func:`_deviation` of each arc's and transition's end pieces next to a moving junction,
    a batch of each (splines: left to :func:`_deviation`)."""
    out: list[dict[int, float]] = [{} for _ in requests]
    for kind in (Arc, Transition):
        at: list[tuple[int, int]] = []  # (request, piece)
        for i, ((g, _, s_in, s_out), st) in enumerate(zip(requests, states, strict=True)):
            if isinstance(g.move, kind):
                n = st.durations.size
                at += [(i, k) for k, moving in ((0, s_in.moving), (n - 1, s_out.moving)) if moving]
        if not at:
            continue
        rows = np.array([first[i] + k for i, k in at], dtype=np.intp)
        q = piece_points_many(
            phases.p[rows], phases.v[rows], phases.a[rows], phases.j[rows], mins[rows]
        )
        hints = [states[i].u[k] for i, k in at]
        if kind is Arc:
            arcs = [m for m in (requests[i][0].move for i, _ in at) if isinstance(m, Arc)]
            dev = arc_deviation_many(arcs, q, hints).tolist()
        else:
            steps = [requests[i][0] for i, _ in at]
            moves = [m for m in (g.move for g in steps) if isinstance(m, Transition)]
            windows = [2.0 / max(g.u.size - 1, 1) for g in steps]
            ends = [states[i].u[k + 1] for i, k in at]
            dev = transition_deviation_many(moves, q, hints, windows, ends).tolist()
        for (i, k), d in zip(at, dev, strict=True):
            out[i][k] = d
    return out
