"""The reference part of the contour error, split into the G64 blends and the planning.

``reference_max`` (:mod:`gantry_sim.sim.contour`) is how far the reference leaves the
programmed geometry. In G64 part of that is intended: the blends replace corners by arcs. The
split (both [um], added to ``parts_um`` of report.json beside the existing keys):

* ``reference_blend_max``: how far the path the planner follows leaves the programmed one
  where the program's path control asks it to: the largest deviation of the plan's G64 blends
  (from the corners they cut) and G64 Q merges (from the points they merge away); 0 with
  neither;
* ``reference_planning_max``: how far the reference samples of the feed moves leave the path
  the planner followed (the blended one): chords, junction smoothing, pieces. The samples of a
  stop whose two moves' profiles overlap (``Plan.overlaps_s``) are left out: there the
  reference cuts the corner by design, and that overlap's deviation is a blend's.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from gantry_sim.controller.planner.result import Plan
from gantry_sim.controller.trajectory import Trajectory
from gantry_sim.controller.units import UM_PER_MM
from gantry_sim.sim.contour import Analysis, ErrorParts
from gantry_sim.sim.move_table import MoveTable, move_table
from gantry_sim.sim.program_distance import distance_to_moves, path_window


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


def split_reference(analysis: Analysis, planned: Plan, traj: Trajectory) -> Analysis:
    """``analysis`` with its parts split into blend and planning (see the module docstring)."""
    tab = move_table(planned.path_moves or planned.moves)
    window = path_windows(known_path_sources(planned), traj.source)
    feed = analysis.feed & ~in_overlaps(traj.t, planned.overlaps_s)
    planning_mm = planning_distance_mm(tab, traj.line, traj.pos, feed, window)
    return with_planning_split(analysis, planned, planning_mm * UM_PER_MM)


def in_overlaps(t: np.ndarray, overlaps_s: np.ndarray) -> np.ndarray:
    """Per time ``t`` (n,) [s], whether it falls in one of the overlapped stops
    ``overlaps_s`` ((k, 2) start and end [s], in order, not overlapping each other; a start
    counts in, an end out)."""
    t = np.asarray(t, dtype=float)
    if not len(overlaps_s):
        return np.zeros(t.shape, dtype=bool)
    k = np.searchsorted(overlaps_s[:, 0], t, side="right") - 1
    inside = k >= 0
    inside[inside] = t[inside] < overlaps_s[k[inside], 1]
    return inside


def known_path_sources(planned: Plan) -> np.ndarray | None:
    """``planned.path_sources`` where they give the program moves of every path move (a plan
    built without them: None)."""
    if planned.path_moves and len(planned.path_sources) == len(planned.path_moves):
        return planned.path_sources
    return None


def path_windows(path_sources: np.ndarray | None, source: np.ndarray | None) -> np.ndarray | None:
    """Per sample executing the program moves ``source`` (Trajectory.source), the path moves
    they come from (sim.program_distance.path_window, on :func:`known_path_sources`); None
    where either is not known."""
    if source is None or path_sources is None:
        return None
    return path_window(path_sources, source)


def planning_distance_mm(
    path_tab: MoveTable,
    line: np.ndarray,
    ref: np.ndarray,
    feed: np.ndarray,
    window: np.ndarray | None = None,
) -> float:
    """The largest distance [mm] of the reference samples ``ref`` (n, 3) [mm] executing
    ``line`` (n,) and flagged ``feed`` (n,) from the path the planner followed (``path_tab``:
    the move table of ``Plan.path_moves``; ``window`` (n, 2): the rows of it each sample comes
    from, if known: :func:`path_windows`); 0 with no feed sample. A streamed run (sim.stream)
    takes it range by range."""
    own = None if window is None else window[feed]
    dist = distance_to_moves(path_tab, line[feed], ref[feed], window=own)[0]
    return float(dist.max()) if dist.size else 0.0


def blend_max_um(planned: Plan) -> float:
    """The plan's largest G64 blend or merge deviation [um] (0 with neither): the blends are
    read from disk (controller.spill; 0.034 s at 10,000 polyline blocks)."""
    deviations = [b.deviation_mm for b in planned.blends] + [m.deviation_mm for m in planned.merges]
    return max(deviations, default=0.0) * UM_PER_MM


def with_planning_split(
    analysis: Analysis, planned: Plan, planning_um: float, blend_um: float | None = None
) -> Analysis:
    """``analysis`` with its parts split: the plan's largest blend (or merge) deviation
    (``blend_um`` when computed already: :func:`blend_max_um`), and ``planning_um`` [um]
    (:func:`planning_distance_mm` over the run)."""
    blend_um = blend_max_um(planned) if blend_um is None else blend_um
    base = {f.name: getattr(analysis.parts, f.name) for f in fields(ErrorParts)}
    parts = BlendedParts(
        **base, reference_blend_max_um=blend_um, reference_planning_max_um=planning_um
    )
    return replace(analysis, parts=parts)


__all__ = [
    "BlendedParts",
    "blend_max_um",
    "in_overlaps",
    "known_path_sources",
    "path_windows",
    "planning_distance_mm",
    "split_reference",
    "with_planning_split",
]
