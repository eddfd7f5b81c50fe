"""M70/M72/M73: the modal state LinuxCNC saves and restores (manual, "M70 Save Modal State").

Saved: units (G20/G21), plane, distance modes (G90/G91, G90.1/G91.1), feed mode (G93/G94/G95),
coordinate system (G54-G59.3), tool length offset (G43/G49), F and S, spindle M3/M4/M5, coolant
M7/M8. Not saved: the position and the motion mode.
"""

from __future__ import annotations

from dataclasses import replace

from gantry_sim.controller.gcode.coords import select_system
from gantry_sim.controller.gcode.parameters import Parameters
from gantry_sim.controller.gcode.state import ModalState
from gantry_sim.controller.gcode.tool_offsets import apply_tool_offset


def restore(saved: ModalState, now: ModalState, params: Parameters) -> ModalState:
    """``now`` with the modal settings of ``saved`` (the tool stays where it is)."""
    s = replace(
        now,
        inch=saved.inch,
        plane=saved.plane,
        incremental=saved.incremental,
        arc_absolute=saved.arc_absolute,
        feed_mode=saved.feed_mode,
        feed_mm_per_min=saved.feed_mm_per_min,
        feed_number=saved.feed_number,
        rpm=saved.rpm,
        spindle=saved.spindle,
        mist=saved.mist,
        flood=saved.flood,
    )
    if saved.coord_index != s.coord_index:
        s = select_system(s, params, saved.coord_index)
    if saved.tool_offset_mm != s.tool_offset_mm:
        s = apply_tool_offset(s, saved.tool_offset_mm)
    return s
