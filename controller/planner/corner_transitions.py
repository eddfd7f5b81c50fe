"""G2 transitions at the ends of G64 corner blend arcs.

A corner blend (:mod:`~gantry_sim.controller.planner.blend`,
:mod:`~gantry_sim.controller.planner.corner_blend`) is a circular arc tangent to the moves it
joins, so the curvature still jumps where it meets them: from 0 to 1/R where it meets a
straight move. A jerk-limited reference can pass such a jump only slowly (the chord smoothing
of :func:`~gantry_sim.controller.planner.junctions.junction_cap`, within the blend's share of
the tolerance it leaves, P less the reference's share less the arc's own deviation): a 5 degree
corner of two 5 mm moves at P0.01 and F3000 passed at 27.4 of 50 mm/s, a 72-gon of R 50 at
0.45 F. Here each such junction gets a G2 transition
(:mod:`~gantry_sim.controller.planner.transition`: a quintic that leaves the first move and
joins the second with their tangent and curvature), sized as every transition is, with the
deviation the blend arc leaves: its deviation budget is the smaller of the two moves' smoothing
budgets, so a point of the transition lies within the arc's deviation plus the transition's of
the programmed path, and the corner's :class:`~gantry_sim.controller.planner.blend.Blend`
records that sum. A junction whose transition is not faster than its chord smoothing keeps the
chord smoothing (the transition's own rule, ``GAIN``).

Which junctions: a blend arc's start and end where it meets a line or an arc of the program (a
straight move's trimmed rest, or a program arc a corner cut) with no exact stop or dwell between
them; never a junction with another transition, and never the ends of blend arcs that meet
another (the blends of a polygon that meet are one chain of equal arcs, with nothing to smooth
between them; a transition at the chain's end, from the move before the polygon, lowers the
tangential limits the whole chain ramps with: a 72-gon of R 10 at F3000 ran 1.553 s instead of
1.477).
A move's room is its length as the blends left it: each transition takes at most
``transition.LENGTH_SHARE`` of it, so the two at the ends of one move never overlap.

Conventions: mm; sites are keyed by their index in the flattened sequence of the stretch's
moves (the junction before that move).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

from gantry_sim.controller.moves import Arc, Linear, PathMove
from gantry_sim.controller.planner.blend_types import Blend, Blended
from gantry_sim.controller.planner.corner_blend import end_tangent, trimmed_arc
from gantry_sim.controller.planner.transition import (
    TransitionCut,
    TransitionMachine,
    TransitionSite,
    size_transitions,
    transition_site,
)

__all__ = ["add_corner_transitions"]


def add_corner_transitions(made: Sequence[Blended], machine: TransitionMachine) -> None:
    """Put G2 transitions at the ends of the corner blend arcs in ``made`` (what each move of a
    stretch became, :func:`~gantry_sim.controller.planner.blend.blend_corners`), in place: the
    moves either side of a transition are trimmed, the transition goes in after the first of
    them (in that move's :class:`Blended`), and the corner's blend record takes the
    transition's deviation."""
    flat = [(k, j) for k, b in enumerate(made) for j in range(len(b.moves))]
    sites = _sites(made, flat)
    if not sites:
        return
    cuts = size_transitions(sites, machine)
    if cuts:
        _apply(made, flat, cuts)


def _sites(made: Sequence[Blended], flat: list[tuple[int, int]]) -> list[TransitionSite]:
    """The junctions next to a blend arc that may get a transition, keyed by the flat index of
    the move after them."""
    sites: list[TransitionSite] = []
    arcs = {f for f, (k, j) in enumerate(flat) if made[k].blend_at[j] is not None}
    for f in sorted(arcs):
        if f - 1 in arcs or f + 1 in arcs:  # blends that meet: a chain of equal arcs
            continue
        for g in (f, f + 1):  # the junction before the blend arc, and the one after it
            if g == 0 or g >= len(flat):
                continue
            (k0, j0), (k1, j1) = flat[g - 1], flat[g]
            m0, m1 = made[k0].moves[j0], made[k1].moves[j1]
            if made[k0].stops[j0] or (k1 != k0 and made[k1].holds):
                continue
            if not (isinstance(m0, Linear | Arc) and isinstance(m1, Linear | Arc)):
                continue
            budget = min(made[k0].smoothing[j0], made[k1].smoothing[j1])
            ends = (end_tangent(m0, True), end_tangent(m1, False))
            site = transition_site(m0, m1, g, budget, ends, (m0.length_mm, m1.length_mm))
            if site is not None:
                sites.append(site)
    return sites


def _apply(
    made: Sequence[Blended], flat: list[tuple[int, int]], cuts: dict[int, TransitionCut]
) -> None:
    """Trim the moves either side of every transition in ``cuts`` (by flat index of the move
    after it), insert the transitions and widen the corners' blend records."""
    extra: dict[int, tuple[float, int]] = {}  # per Blended of a blend arc: its transitions'
    for f, cut in cuts.items():  # largest deviation, and how many
        for g in (f - 1, f):
            k, j = flat[g]
            if made[k].blend_at[j] is not None:
                dev, count = extra.get(k, (0.0, 0))
                extra[k] = (max(dev, cut.deviation_mm), count + 1)
    touched = sorted({flat[g][0] for f in cuts for g in (f - 1, f)})
    first = {}  # flat index of each Blended's first move
    for g, (k, j) in enumerate(flat):
        if j == 0:
            first[k] = g
    for k in touched:
        b = made[k]
        out = Blended(b.holds, blends=b.blends)
        for j, m in enumerate(b.moves):
            g = first[k] + j
            before, after = cuts.get(g), cuts.get(g + 1)
            out.moves.append(_trimmed(m, before, after))
            out.stops.append(b.stops[j])
            out.smoothing.append(b.smoothing[j])
            out.sources.append(b.sources[j])
            out.blend_at.append(b.blend_at[j])
            if after is not None:
                k1, j1 = flat[g + 1]
                nxt = made[k1]
                arc_first = b.blend_at[j] is not None
                out.moves.append(after.move)
                out.stops.append(False)
                budget = min(b.smoothing[j], nxt.smoothing[j1])
                out.smoothing.append(max(budget - after.deviation_mm, 0.0))
                out.sources.append(b.sources[j] if arc_first else nxt.sources[j1])
                out.blend_at.append(None)
        b.moves, b.stops, b.smoothing = out.moves, out.stops, out.smoothing
        b.sources, b.blend_at = out.sources, out.blend_at
    for k, (dev, count) in extra.items():
        made[k].blends = [_widened(x, dev, count) for x in made[k].blends]


def _trimmed(m: PathMove, before: TransitionCut | None, after: TransitionCut | None) -> PathMove:
    """``m`` less what the transitions before and after it cut from it, ending at their very
    end points (the path stays continuous bit for bit)."""
    if before is None and after is None:
        return m
    assert isinstance(m, Linear | Arc)  # sites join lines and arcs only
    start = before.move.end if before is not None else m.start
    end = after.move.start if after is not None else m.end
    if isinstance(m, Arc):
        cut0 = before.cut_mm if before is not None else 0.0
        cut1 = after.cut_mm if after is not None else 0.0
        return replace(trimmed_arc(m, cut0, cut1), start=start, end=end)
    return replace(m, start=start, end=end)


def _widened(blend: Blend, extra_mm: float, transitions: int) -> Blend:
    """A corner's blend record with its ``transitions`` and their largest deviation
    (``extra_mm``) added to its own."""
    if blend.kind != "corner":
        return blend
    return replace(blend, deviation_mm=blend.deviation_mm + extra_mm, transitions=transitions)
