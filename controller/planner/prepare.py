"""What the rounds plan from: the geometry, junction caps and states, dwells and smoothing
budgets of a path's moves, and the G64 blends too slow to keep.

:func:`prepare` works on a :class:`~gantry_sim.controller.planner.blend.PathPlan` or a stretch
of one (:func:`sub_path`, for the windows of a long program:
:mod:`~gantry_sim.controller.planner.windows`): every number it gives a junction depends only
on the moves either side of it and their other junctions, so a stretch with a move of context
before and after its moves of interest gives them what the whole path gives them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Hashable, Mapping, Sequence
from dataclasses import replace
from functools import partial
from types import MappingProxyType
from typing import NamedTuple

import numpy as np

from gantry_sim.controller.config import Limits, MachineConfig
from gantry_sim.controller.moves import Arc, Dwell, PathMove
from gantry_sim.controller.planner.blend import MAX_TURN_RAD, PathPlan, corner_budget_mm
from gantry_sim.controller.planner.blend_judge import blend_faster_many
from gantry_sim.controller.planner.junctions import (
    JunctionState,
    feasible_junction_caps,
    junction_caps,
    smoothing_cap,
)
from gantry_sim.controller.planner.move_geometry import (
    MoveGeometry,
    capped_geometries,
    limits_for_junctions,
    move_geometries,
)
from gantry_sim.controller.planner.shared_jerk import (
    overlap_estimate,
    share_jerk_at_stops,
    stop_credit_s,
)
from gantry_sim.controller.planner.stop_overlap import overlappable
from gantry_sim.controller.planner.transition import CHORD_FIT_REACHED

__all__ = ["Prepared", "prepare", "slow_blends", "stop_corners", "sub_path"]


class Prepared(NamedTuple):
    """A path's moves made ready for the rounds: ``geoms`` per move of the path; ``active``
    the ones with length (zero-length moves dropped) and ``path_index`` their indices in the
    path;
    junction ``caps`` [mm/s] and ``states`` (len(active) + 1); dwells (``holds``), smoothing
    budgets [mm] and program ``sources`` per active junction or move; per active move the
    M204 path acceleration [mm/s^2] it runs under (inf: none; None: none anywhere); and the
    ``stop_corners``: junction -> G64 budget [mm] of each exact stop between two straight feed
    moves that the path control would have blended (:func:`stop_corners`), where the two
    moves' profiles may overlap (:mod:`~gantry_sim.controller.planner.stop_overlap`); and
    ``stop_credit_s``: active blend arc -> the time [s] an overlap would save at an exact stop
    in its place (:func:`_stop_credits`), which :func:`slow_blends` counts."""

    geoms: list[MoveGeometry]
    active: list[MoveGeometry]
    path_index: list[int]
    caps: np.ndarray
    states: list[JunctionState]
    holds: dict[int, list[Dwell]]
    smoothing: list[float]
    sources: list[tuple[int, int]]
    path_acc_mm_per_s2: list[float] | None = None
    stop_corners: Mapping[int, float] = MappingProxyType({})
    stop_credit_s: Mapping[int, float] = MappingProxyType({})


#: A G64 blend arc's chords are laid within this share of its smoothing budget, rounded down
#: to the chord tolerance times a power of 2^(1/TOLERANCE_STEPS) (blend arcs then come in a
#: few batches of geometry, and take 0.96-1 of it).
BLEND_CHORD_SHARE = 1.0
TOLERANCE_STEPS = 16
#: ... and so that no chord sweeps more than this [rad]: a margin, as the closed-form pieces
#: between exact arc states keep a smaller share of the sagitta where a chord turns little (on
#: random polylines at P 0.02-1 the reference left its blend arcs by up to 0.64 of their budget
#: with chords of up to 40 degrees, 0.40 at 15).
BLEND_CHORD_SWEEP_RAD = math.radians(15.0)


def blend_chord_tolerances(
    path: PathPlan, moves: Sequence[PathMove], chord_tolerance_mm: float
) -> dict[int, float]:
    """The chord tolerance [mm] of each G64 blend arc of ``path`` (by index in ``moves``, the
    path's moves) whose smoothing budget allows more than twice ``chord_tolerance_mm``.

    A blend arc is the planner's path, not the program's: the reference may leave it by its
    smoothing budget (P less the reference's share and what the blend took from the corner),
    and its pieces between vertices by :data:`~gantry_sim.controller.planner.pieces.JUNCTION_DEVIATION_MAX`
    of the tolerance they were laid within, so the blend stays within P. Laid within the
    machine's chord tolerance, the jump of curvature where it meets a straight move had to be
    absorbed within its first chord, 0.4 mm on an R23 blend at 1 um: that capped the junction
    near 80 mm/s, and a 3-D surfacing pass in G64 P0.1 (LinuxCNC's 3D_Chips at F3000) ran
    111.2 s where its blends' chords within the budget let it run 96.6 s."""
    out: dict[int, float] = {}
    for k in path.blend_junction:
        m, room = moves[k], BLEND_CHORD_SHARE * path.smoothing_mm[k]
        if not isinstance(m, Arc):
            continue
        room = min(room, m.radius * (1.0 - math.cos(0.5 * BLEND_CHORD_SWEEP_RAD)))
        if room >= 2.0 * chord_tolerance_mm:
            steps = math.floor(TOLERANCE_STEPS * math.log2(room / chord_tolerance_mm))
            out[k] = chord_tolerance_mm * 2.0 ** (steps / TOLERANCE_STEPS)
    return out


def sub_path(path: PathPlan, lo: int, hi: int, first_junction: int) -> PathPlan:
    """Moves ``lo:hi`` of ``path`` as a path of their own, with the dwells of junctions
    ``first_junction`` .. ``hi - 1`` (a junction j is before move j), and those after the
    last move when ``hi`` is the path's end."""
    out = PathPlan()
    out.moves = path.moves[lo:hi]
    out.stop_after = path.stop_after[lo:hi]
    last = hi if hi == len(path.moves) else hi - 1
    out.holds = {j - lo: d for j, d in path.holds.items() if first_junction <= j <= last}
    out.smoothing_mm = path.smoothing_mm[lo:hi]
    out.sources = path.sources[lo:hi]
    out.blend_junction = path.blends_between(lo, hi)
    out.path_acc_mm_per_s2 = path.path_acc_mm_per_s2  # by program move: the same indices
    return out


def prepare(
    path: PathPlan, machine: MachineConfig, feed_override_pct: float, known: dict
) -> Prepared:
    """Geometry, junction caps and states, dwells and smoothing budgets per junction of the
    moves of ``path`` (zero-length moves dropped); ``known``: geometry by move (equal moves
    have equal geometry), filled here, so planning again after :func:`slow_blends` only
    computes the moves that changed."""
    lim, seg = machine.limits, machine.segmentation
    moves = list(path.moves)
    loose = blend_chord_tolerances(path, moves, seg.chord_tolerance_mm)
    # a blend arc's geometry is known by (arc, its chord tolerance): an equal arc elsewhere
    # may have another budget
    keys: list[Hashable] = [(m, loose[k]) if k in loose else m for k, m in enumerate(moves)]
    new: dict[float, dict[Hashable, PathMove]] = {}  # by chord tolerance, each once, in order
    for k, (key, m) in enumerate(zip(keys, moves, strict=True)):
        if key not in known:
            new.setdefault(loose.get(k, seg.chord_tolerance_mm), {})[key] = m
    for tol, group in new.items():
        laid = seg if tol == seg.chord_tolerance_mm else replace(seg, chord_tolerance_mm=tol)
        made = move_geometries(list(group.values()), lim, laid, feed_override_pct / 100.0)
        known.update(zip(group, made, strict=True))
    geoms = []
    for key, m in zip(keys, moves, strict=True):
        g = known[key]
        geoms.append(g if g.move is m else replace(g, move=m))
    keep = [g.length_mm > 1e-9 for g in geoms]
    active = [g for g, k in zip(geoms, keep, strict=True) if k]
    at = np.concatenate(([0], np.cumsum(keep))).astype(int)  # planned junction -> active
    stops = {int(at[i + 1]) for i, stop in enumerate(path.stop_after) if stop}
    holds: dict[int, list[Dwell]] = {}
    for j, dwells in path.holds.items():
        holds.setdefault(int(at[j]), []).extend(dwells)
    smoothing = [e for e, k in zip(path.smoothing_mm, keep, strict=True) if k]
    sources = [s for s, k in zip(path.sources, keep, strict=True) if k]
    path_acc = _active_path_acc(path.path_acc_mm_per_s2, sources)
    if path_acc is not None:  # Marlin's M204: each move's own limits under it
        active = capped_geometries(active, path_acc, lim)
    caps, states = junction_caps(active, lim, seg.chord_tolerance_mm, smoothing)
    for b in stops | set(holds):
        caps[b] = 0.0
    active = limits_for_junctions(active, caps, lim, path_acc)
    caps = feasible_junction_caps(active, caps, states, lim)
    where = [i for i, k in enumerate(keep) if k]
    budget_of = partial(
        corner_budget_mm, settings=machine.path, chord_tolerance_mm=seg.chord_tolerance_mm
    )
    corners = stop_corners(active, caps, stops | set(holds), budget_of)
    active, shared = share_jerk_at_stops(active, corners, lim)
    credits = _stop_credits(path, at, active, budget_of, lim, shared)
    return Prepared(
        geoms, active, where, caps, states, holds, smoothing, sources, path_acc, corners, credits
    )


def _stop_credits(
    path: PathPlan,
    at: np.ndarray,
    active: Sequence[MoveGeometry],
    budget_of: Callable[[PathMove], float],
    limits: Limits,
    shared: Collection[int],
) -> dict[int, float]:
    """Active blend arc -> the time [s] an overlap is estimated to save at the exact stop that
    would replace it (:func:`~gantry_sim.controller.planner.shared_jerk.overlap_estimate`), where
    the moves either side are straight (feed moves or rapids) and would meet at such a stop
    (``at``: path junction -> active; ``budget_of``: the G64 budget [mm] of the move before
    a junction; ``shared``: the junctions of the stops whose moves share their jerk), as
    :func:`~gantry_sim.controller.planner.shared_jerk.stop_credit_s` counts it: a move's ramp
    at its other end is paid for by a blend arc there (in a chain of blends judged slow, a
    stop that shares too), a stop that shares, or the path's end (where the judge of a zigzag
    of 6 degree turns otherwise kept its first and last blends: 0.5 % slower), not by a plain
    stop. Each side's move takes half the blend's length back, as the stop's estimate does
    (blend_judge)."""
    jmax = np.asarray(limits.per_axis()[2], dtype=float)
    out: dict[int, float] = {}
    # the blend arcs with a length, by their index among the active moves
    arcs = {int(at[k]) for k in path.blend_junction if int(at[k + 1]) == int(at[k]) + 1}
    for b in sorted(arcs):
        if not 0 < b < len(active) - 1:
            continue  # no move either side
        ga, arc, gb = active[b - 1], active[b], active[b + 1]
        if not overlappable(ga.move, gb.move):
            continue
        half = 0.5 * arc.length_mm
        la = replace(ga.limits, length_mm=ga.limits.length_mm + half)
        lb = replace(gb.limits, length_mm=gb.limits.length_mm + half)
        e = overlap_estimate(la, lb, ga.tangent_out, gb.tangent_in, budget_of(ga.move), jmax)
        pays = (
            b < 2 or b - 2 in arcs or b - 1 in shared,
            b + 2 >= len(active) or b + 2 in arcs or b + 2 in shared,
        )
        credit = stop_credit_s(e, pays)
        if credit > 0.0:
            out[b] = credit
    return out


def stop_corners(
    active: Sequence[MoveGeometry],
    caps: np.ndarray,
    exact: set[int],
    budget_of: Callable[[PathMove], float],
) -> dict[int, float]:
    """Junction -> budget [mm] of each stop (``caps`` 0) between two straight feed moves, or
    two rapids, whose first is in G64 (its ``budget_of`` > 0: its G64 corner budget,
    :func:`~gantry_sim.controller.planner.blend.corner_budget_mm`; the mode and P of the move
    before a junction govern it, as LinuxCNC's termination condition does, and as the corner
    blends take it: LinuxCNC 2.9 passes a corner between a G64 P0.01 move and a G61.1 one, and
    between two rapids, without stopping) that the program does not ask for (junctions
    ``exact``: G61.1, program stops, dwells), turning by less than
    :data:`~gantry_sim.controller.planner.blend.MAX_TURN_RAD` (a reversal stays a stop, as in
    LinuxCNC and grbl, and as sim.duration_bound counts it). A rapid and a feed move stay a
    stop (LinuxCNC 2.9 stops there)."""
    out = {}
    for b in (np.flatnonzero(caps[1 : len(active)] == 0.0) + 1).tolist():
        a = active[b - 1].move
        if (
            overlappable(a, active[b].move)
            and b not in exact
            and float(active[b - 1].tangent_out @ active[b].tangent_in) > _COS_MAX_TURN
            and (budget := budget_of(a)) > 0.0
        ):
            out[b] = budget
    return out


_COS_MAX_TURN = math.cos(MAX_TURN_RAD)


def _active_path_acc(
    by_program_move: Sequence[float] | None, sources: list[tuple[int, int]]
) -> list[float] | None:
    """Per active move, the M204 path acceleration [mm/s^2] it runs under: the smallest over
    the program moves it comes from (a blend arc: the two of its junction); None when no
    program move has one."""
    if by_program_move is None:
        return None
    return [min(by_program_move[a : b + 1], default=math.inf) for a, b in sources]


def slow_blends(path: PathPlan, prepared: Prepared, jerk_mm_per_s3: float) -> frozenset[int]:
    """Junctions whose blend is estimated slower than an exact stop
    (:func:`~gantry_sim.controller.planner.blend_judge.blend_faster_many`): a jerk-limited pass of
    a sharp corner's blend is slow, and its path long against what the stop costs, so those
    corners stay exact stops. The blend arc is entered and left at the junction caps the
    planner's pieces reach in the end (:func:`_reached_cap`), with ``jerk_mm_per_s3`` the
    machine's smallest axis jerk. The stop's estimate is less the time its overlap would save
    (``prepared.stop_credit_s``). A blend at either end of the active moves is not judged (a
    stretch's neighbours are not known there)."""
    geoms, active, caps, smoothing = (
        prepared.geoms,
        prepared.active,
        prepared.caps,
        prepared.smoothing,
    )
    index = {id(g.move): b for b, g in enumerate(active)}
    judged: list[tuple[int, int]] = []  # (junction, the blend's active move)
    for k, junction in path.blend_junction.items():
        b = index.get(id(geoms[k].move))
        if b is not None and 0 < b < len(active) - 1:
            judged.append((junction, b))
    ends = [
        (
            _reached_cap(active, b, float(caps[b]), smoothing, jerk_mm_per_s3),
            _reached_cap(active, b + 1, float(caps[b + 1]), smoothing, jerk_mm_per_s3),
        )
        for _, b in judged
    ]
    faster = blend_faster_many(
        ends,
        [active[b].limits for _, b in judged],
        [active[b - 1].limits for _, b in judged],
        [active[b + 1].limits for _, b in judged],
        [prepared.stop_credit_s.get(b, 0.0) for _, b in judged],
    )
    return frozenset(j for (j, _), fast in zip(judged, faster.tolist(), strict=True) if not fast)


def _reached_cap(
    active: list[MoveGeometry],
    b: int,
    cap: float,
    smoothing: list[float],
    jerk_mm_per_s3: float,
) -> float:
    """Junction ``b``'s speed cap [mm/s] as the rounds leave it where a curvature jump is
    smoothed within a chord (``cap``: the first guess, at
    :data:`~gantry_sim.controller.planner.junctions.CHORD_FIT_BLEND`; the pieces reach a fit of
    about :data:`~gantry_sim.controller.planner.transition.CHORD_FIT_REACHED`, and a judge
    taking the first guess kept blends of 14 and 30 degree corners that ran slower than exact
    stops); ``cap`` itself where nothing jumps. Junction ``b`` has the blend arc on one side."""
    budget = min(smoothing[b - 1], smoothing[b])
    if budget <= 0.0:
        return cap
    reached = smoothing_cap(
        active[b - 1], active[b], 0.0, budget, jerk_mm_per_s3, CHORD_FIT_REACHED
    )
    return min(cap, reached)
