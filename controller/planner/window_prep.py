"""A window of a long program prepared for planning
(:mod:`~gantry_sim.controller.planner.windows`): its stretch of the path with the move before
it as context, its geometry, junction caps and states
(:func:`~gantry_sim.controller.planner.prepare.prepare`), its G64 blend arcs, and the slow
blends it judges (:mod:`~gantry_sim.controller.planner.window_judge`)."""

from __future__ import annotations

import math

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.planner.blend import PathPlan
from gantry_sim.controller.planner.move_geometry import ArcGeometry
from gantry_sim.controller.planner.prepare import Prepared, prepare, sub_path
from gantry_sim.controller.planner.window_judge import JudgedPath

__all__ = ["Window", "blend_arcs", "prepare_window", "window_of"]

#: A window prepared (:func:`window_of`): its preparation, its G64 blend arcs, the slow blends
#: it judged and the path move it judged them up to (None: not judged).
Window = tuple[Prepared, frozenset[int], frozenset[int], int]


def window_of(
    src: JudgedPath,
    base: int,
    hi: int,
    context: bool,
    machine: MachineConfig,
    feed_override_pct: float,
    upto: int | None,
) -> Window:
    """The window of path moves ``base:hi`` (the first one ``context``) prepared
    (:func:`prepare_window`), its G64 blend arcs (:func:`blend_arcs`), and, from path move
    ``upto`` on (None: none), the blends it judges slow
    (:meth:`~gantry_sim.controller.planner.window_judge.JudgedPath.judge`)."""
    stretch = sub_path(src.path, base, hi, base + context)
    pre = prepare_window(stretch, machine, feed_override_pct, context)
    arcs = blend_arcs(stretch, pre)
    if upto is None:
        return pre, arcs, frozenset(), 0
    return pre, arcs, *src.judge(stretch, pre, base, hi, upto)


def blend_arcs(stretch: PathPlan, pre: Prepared) -> frozenset[int]:
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


def prepare_window(
    stretch: PathPlan, machine: MachineConfig, feed_override_pct: float, context: bool
) -> Prepared:
    """:func:`prepare` of a window's ``stretch``, less its first move when that is ``context``
    (the move before the window; ``path_index`` stays counted from the stretch's start)."""
    pre = prepare(stretch, machine, feed_override_pct, {})
    if not context:
        return pre
    if not (pre.path_index and pre.path_index[0] == 0):
        raise AssertionError("a window's context must be a move with length")
    # every field by name: one left out takes its default (the stop credits once did, and the
    # windows judged blends as if no stop there would overlap)
    return Prepared(
        geoms=pre.geoms,
        active=pre.active[1:],
        path_index=pre.path_index[1:],
        caps=pre.caps[1:],
        states=pre.states[1:],
        holds={b - 1: d for b, d in pre.holds.items() if b >= 1},
        smoothing=pre.smoothing[1:],
        sources=pre.sources[1:],
        path_acc_mm_per_s2=None if pre.path_acc_mm_per_s2 is None else pre.path_acc_mm_per_s2[1:],
        stop_corners={b - 1: e for b, e in pre.stop_corners.items() if b >= 1},
        stop_credit_s={b - 1: c for b, c in pre.stop_credit_s.items() if b >= 1},
    )
