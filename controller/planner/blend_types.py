"""The records of G64 blending: a blended junction (:class:`Blend`) and what one move of a stretch
becomes (:class:`Blended`, :func:`~gantry_sim.controller.planner.blend.blend_corners`)."""

from __future__ import annotations

from dataclasses import dataclass, field

from gantry_sim.controller.moves import Dwell, PathMove

__all__ = ["Blend", "Blended"]


@dataclass(frozen=True, slots=True)
class Blend:
    """One blended junction: the program line of the move ending there, the blend's largest
    distance from the programmed path [mm], the tolerance it was given [mm], and its kind:
    "corner" (a blend arc), "transition" (a G2 transition at a tangent junction,
    :mod:`~gantry_sim.controller.planner.transition`) or "overlap" (an exact stop between two
    straight moves or two rapids whose profiles overlap,
    :mod:`~gantry_sim.controller.planner.stop_overlap`); ``file``: the subroutine file the
    line is in (None: the program's own). Slotted: a long program of tangent arcs has one per
    junction."""

    line: int
    deviation_mm: float
    tolerance_mm: float
    kind: str = "corner"
    file: str | None = None

    def __reduce__(self) -> tuple:
        """Pickled as its constructor's arguments (the spill keeps one per junction; a slotted
        dataclass' default pickling calls ``dataclasses.fields`` per object)."""
        return (Blend, (self.line, self.deviation_mm, self.tolerance_mm, self.kind, self.file))


@dataclass
class Blended:
    """What one move of a stretch becomes in the path (:func:`blend_corners`): the dwells at
    the junction before it, its trimmed self (none where blends use it up) and the blend arc
    or transition at its end, each with its stop, smoothing budget [mm] and program sources; ``blend_at``: per
    move made, the junction a blend arc replaces (an index among the stretch's moves; None for
    a trimmed move or a transition: not skipped); ``blends``: the blend at its end, if any."""

    holds: list[Dwell] = field(default_factory=list)
    moves: list[PathMove] = field(default_factory=list)
    stops: list[bool] = field(default_factory=list)
    smoothing: list[float] = field(default_factory=list)
    sources: list[tuple[int, int]] = field(default_factory=list)
    blend_at: list[int | None] = field(default_factory=list)
    blends: list[Blend] = field(default_factory=list)
