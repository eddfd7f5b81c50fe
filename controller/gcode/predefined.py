"""LinuxCNC 2.9's predefined read-only named parameters (manual: "Predefined Named Parameters").

Each is computed from the interpreter's state when read, so it always shows the current value;
lengths are in the program's units. Names not listed here are ordinary globals.
"""

from __future__ import annotations

from gantry_sim.controller.gcode.parameters import COORD_INDEX, G92_ENABLED, Parameters
from gantry_sim.controller.gcode.state import ModalState
from gantry_sim.controller.planes import Vec3

_PLANES = {"XY": 170.0, "XZ": 180.0, "YZ": 190.0}
_SYSTEMS = (540.0, 550.0, 560.0, 570.0, 580.0, 590.0, 591.0, 592.0, 593.0)
#: names that read 0 in a 3-axis, non-lathe, override-free simulation
_ZERO = (
    "_a", "_b", "_c", "_u", "_v", "_w", "_abs_a", "_abs_b", "_abs_c", "_abs_u", "_abs_v",
    "_abs_w", "_lathe_diameter_mode", "_current_pocket", "_selected_pocket",
    "_remap_level", "_task",
)  # fmt: skip
#: names that read 1; ``_metric_machine``: the simulated machine's units are millimetres, as a
#: LinuxCNC machine's whose [TRAJ]LINEAR_UNITS is mm (init_named_parameters; rs274 -g run
#: without an INI file reads -1)
_ONE = ("_lathe_radius_mode", "_metric_machine")
#: M48-M53's switches, in the order of ModalState.overrides
_OVERRIDES = ("_feed_override", "_speed_override", "_adaptive_feed", "_feed_hold")


def predefined(
    name: str,
    s: ModalState,
    p: Parameters,
    line: int,
    retract_to_r: bool = True,
    comp_side: str | None = None,
    comp_centre: Vec3 | None = None,
) -> float | None:
    """The value of predefined parameter ``name`` (lower case), or None when it is not one.
    ``retract_to_r``: G99 in effect (G98: False); ``comp_side``: cutter compensation's side,
    "left" (G41), "right" (G42) or None (G40); ``comp_centre``: under compensation, the tool
    centre [mm, program frame], which rs274 reads as ``#<_x>`` and ``#<_y>``."""
    scale = s.scale
    match name:
        case "_vmajor":
            return 2.9  # measured: rs274 -g of LinuxCNC 2.9 reads 2.9 and _vminor 0
        case "_vminor":
            return 0.0
        case "_line":
            return float(line)
        case "_motion_mode":
            return 800.0 if s.motion is None else float(s.motion)
        case "_plane":
            return _PLANES[s.plane]
        case "_metric":
            return float(not s.inch)
        case "_imperial":
            return float(s.inch)
        case "_absolute":
            return float(not s.incremental)
        case "_incremental":
            return float(s.incremental)
        case "_inverse_time":
            return float(s.feed_mode == 930)
        case "_units_per_minute":
            return float(s.feed_mode == 940)
        case "_units_per_rev":
            return float(s.feed_mode == 950)
        case "_coord_system":
            return _SYSTEMS[int(p.mm(COORD_INDEX) or 1) - 1]
        case "_tool_offset":
            return float(any(s.tool_offset_mm))
        case "_ijk_absolute_mode":
            return float(s.arc_absolute)
        case "_spindle_on":
            return float(s.spindle != 0)
        case "_spindle_cw":  # rs274: the spindle turning clockwise (M3), not merely not M4
            return float(s.spindle == 1)
        case "_spindle_css_mode":
            return float(s.css)
        case "_spindle_rpm_mode":
            return float(not s.css)
        case "_ccomp":
            return {"left": 410.0, "right": 420.0}.get(comp_side or "", 400.0)
        case "_retract_r_plane":
            return float(retract_to_r)
        case "_retract_old_z":
            return float(not retract_to_r)
        case "_mist":
            return float(s.mist)
        case "_flood":
            return float(s.flood)
        case "_feed":  # rs274: the number as the F word gave it, whatever the units since
            return s.feed_number
        case "_rpm":
            return s.rpm
        case "_x" | "_y" | "_z":
            i = "xyz".index(name[1])
            if comp_centre is not None and i < 2:
                return comp_centre[i] / scale
            return s.position[i] / scale
        case "_abs_x" | "_abs_y" | "_abs_z":
            return s.work["xyz".index(name[-1])] / scale
        case "_current_tool":
            return float(s.tool)
        case "_selected_tool":
            return float(s.selected_tool)
        case "_call_level":
            return float(p.level)
        case "_g92_enabled":
            return p.mm(G92_ENABLED)
    if name in _OVERRIDES:
        return s.overrides[_OVERRIDES.index(name)]
    if name in _ZERO:
        return 0.0
    if name in _ONE:
        return 1.0
    return None
