"""The reference part of the contour error, split into the G64 blends and the planning.

``reference_max`` (:mod:`gantry_sim.sim.contour`) is how far the reference leaves the
programmed geometry. In G64 part of that is intended: the blends replace corners by arcs. The
split (both [um], added to ``parts_um`` of report.json beside the existing keys):

* ``reference_blend_max``: how far the blended path leaves the programmed corners (the largest
  blend deviation of the plan; 0 with no blend);
* ``reference_planning_max``: how far the reference samples of the feed moves leave the path
  the planner followed (the blended one): chords, junction smoothing, pieces.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

from gantry_sim.controller.planner.result import Plan
from gantry_sim.controller.trajectory import Trajectory
from gantry_sim.controller.units import UM_PER_MM
from gantry_sim.sim.contour import Analysis, ErrorParts, distance_to_program
from gantry_sim.sim.move_table import move_table
from gantry_sim.sim.program_distance import distance_to_moves


@dataclass(frozen=True)
class BlendedParts(ErrorParts):
    """:class:`ErrorParts` with the reference part split (see the module docstring) [um]."""

    reference_blend_max_um: float = 0.0
    reference_planning_max_um: float = 0.0

    def to_json(self) -> dict[str, float]:
        out = super().to_json()
        out["reference_blend_max"] = self.reference_blend_max_um
        out["reference_planning_max"] = self.reference_planning_max_um
        return out


#: reference samples taken at a time when the run is streamed (see split_reference_by_ranges)
RANGE_TICKS = 65536


def split_reference(analysis: Analysis, planned: Plan, traj: Trajectory) -> Analysis:
    """``analysis`` with its parts split into blend and planning (see the module docstring)."""
    feed = analysis.feed
    path = planned.path_moves or planned.moves
    dist = distance_to_program(path, traj.line[feed], traj.pos[feed])[0]
    planning_um = float(dist.max()) * UM_PER_MM if dist.size else 0.0
    return _with_split(analysis, planned, planning_um)


def split_reference_by_ranges(analysis: Analysis, planned: Plan, period_s: float) -> Analysis:
    """:func:`split_reference` for a streamed run: the reference sampled range by range
    (bounded memory), the same largest distance as over the whole trajectory."""
    tab = move_table(planned.path_moves or planned.moves)  # once: 0.65 s at 100k moves
    n = planned.sample_count(period_s)
    planning_mm = 0.0
    for k0 in range(0, n, RANGE_TICKS):
        traj = planned.sample_range(period_s, k0, k0 + RANGE_TICKS)
        feed = analysis.feed[k0 : k0 + len(traj.t)]
        dist = distance_to_moves(tab, traj.line[feed], traj.pos[feed])[0]
        if dist.size:
            planning_mm = max(planning_mm, float(dist.max()))
    return _with_split(analysis, planned, planning_mm * UM_PER_MM)


def _with_split(analysis: Analysis, planned: Plan, planning_um: float) -> Analysis:
    blend_um = max((b.deviation_mm for b in planned.blends), default=0.0) * UM_PER_MM
    base = {f.name: getattr(analysis.parts, f.name) for f in fields(ErrorParts)}
    parts = BlendedParts(
        **base, reference_blend_max_um=blend_um, reference_planning_max_um=planning_um
    )
    return replace(analysis, parts=parts)


__all__ = ["BlendedParts", "split_reference", "split_reference_by_ranges"]
