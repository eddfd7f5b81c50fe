"""The interpreter's modal state: what persists from one block to the next."""

from __future__ import annotations

from dataclasses import dataclass

from gantry_sim.controller.planes import Plane, Vec3
from gantry_sim.controller.units import MM_PER_INCH


@dataclass(frozen=True)
class ModalState:
    """What persists between blocks.

    Attributes:
        position: current point, program coordinates [mm].
        motion: active motion code in tenths (0, 10, 20, 30) or None (G80 / none yet).
        plane: active arc plane.
        inch: G20 in effect (words in inches).
        incremental: G91 in effect.
        arc_absolute: G90.1 in effect (IJK are absolute centre coordinates).
        feed_mm_per_min: current feed [mm/min]; 0 when none has been set.
    """

    position: Vec3 = (0.0, 0.0, 0.0)
    motion: int | None = None
    plane: Plane = "XY"
    inch: bool = False
    incremental: bool = False
    arc_absolute: bool = False
    feed_mm_per_min: float = 0.0

    @property
    def scale(self) -> float:
        """mm per program length unit."""
        return MM_PER_INCH if self.inch else 1.0
