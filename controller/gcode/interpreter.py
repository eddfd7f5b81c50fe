"""G-code text + dialect -> exact moves (program coordinates, mm, mm/min), one block at a time.

In the style of grbl's gcode.c: each block is (1) read into words, (2) checked for words and
codes, (3) validated against a COPY of the modal state in numbered steps, and only when every
step succeeded is the new state committed and the block's move yielded. The first invalid block
raises :class:`~controller.errors.GcodeError` with its line; moves before it have been yielded.

Execution order inside a block follows rs274 (feed, then plane/units/distance modes, then motion,
then program end), so ``G20 G1 X1`` moves to 1 inch, and ``F10 G20`` keeps 10 mm/min.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator, Mapping
from functools import partial
from pathlib import Path
from typing import Any, NamedTuple

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.arc_block import (
    STRAIGHT,
    arc_move,
    from_where_it_is,
    turned_plane,
)
from gantry_sim.controller.gcode.canned_cycles import CYCLES, CycleMemory, run_cycle
from gantry_sim.controller.gcode.codes import (
    G_HANDLED,
    G_NO_PATH_EFFECT,
    G_REFUSED,
    M_PROGRAM_END,
    g_name,
)
from gantry_sim.controller.gcode.comments import abort_message
from gantry_sim.controller.gcode.comp_block import check_while_on, comp_move, switch
from gantry_sim.controller.gcode.control import DEFAULT_MAX_ITERATIONS, MAX_ERRORS, Runner
from gantry_sim.controller.gcode.coords import (
    SYSTEMS,
    g10,
    g92,
    home_point,
    select_system,
    store_home,
    system_frame,
)
from gantry_sim.controller.gcode.cutter_comp import CutterComp
from gantry_sim.controller.gcode.dialect_checks import (
    check_codes,
    check_jog,
    check_jog_after,
    check_plain,
    check_signs,
    jog_moves_as_g1,
)
from gantry_sim.controller.gcode.dialects import Dialect, coded, get_dialect
from gantry_sim.controller.gcode.expressions import Tree, evaluate
from gantry_sim.controller.gcode.extruder import Extruder
from gantry_sim.controller.gcode.feed_modes import (
    INVERSE_TIME,
    UNITS_PER_MINUTE,
    check_feed_mode,
    path_feed,
    per_revolution,
)
from gantry_sim.controller.gcode.frames import Frame, add, from_work, sub, to_work
from gantry_sim.controller.gcode.lexer import Block, LexRules
from gantry_sim.controller.gcode.modal_codes import (
    clears_feed,
    g2core_program_end,
    grbl_program_end,
    overrides,
    path_control,
    set_extruder,
    set_feed_percent,
)
from gantry_sim.controller.gcode.modal_save import restore
from gantry_sim.controller.gcode.motion_waits import motion_wait
from gantry_sim.controller.gcode.parameters import (
    COORD_INDEX,
    G28_HOME,
    G92_ENABLED,
    G92_OFFSET,
    POSITION,
    Parameters,
    g5x_base,
)
from gantry_sim.controller.gcode.plain_block import plain_letters, plain_motion
from gantry_sim.controller.gcode.polar import check_polar_plane, polar_end_point
from gantry_sim.controller.gcode.predefined import predefined
from gantry_sim.controller.gcode.printer_codes import MARLIN_BARE_OPENERS, OWN_LINES
from gantry_sim.controller.gcode.splines import (
    G5_2,
    G5_3,
    SPLINE_CODES,
    SPLINE_MOTIONS,
    NurbsPoints,
    check_spline_block,
    nurbs_point,
    spline_block,
)
from gantry_sim.controller.gcode.state import ModalState, evolve
from gantry_sim.controller.gcode.tool_entries import set_tool_entry
from gantry_sim.controller.gcode.tool_offsets import (
    ToolTable,
    after_tool_change,
    tool_parameters,
    tool_words,
)
from gantry_sim.controller.gcode.tools import Tool
from gantry_sim.controller.gcode.words import (
    Words,
    check_motion_axes,
    check_unused_words,
    check_words,
    read_words,
)
from gantry_sim.controller.moves import (
    Arc,
    Dwell,
    Event,
    Limits,
    Linear,
    Move,
    PathControl,
    Plane,
    Rapid,
    Spline,
    Stop,
    Vec3,
)
from gantry_sim.controller.units import MM_PER_INCH

_PLANES: dict[int, Plane] = {170: "XY", 180: "XZ", 190: "YZ"}
#: isinstance() classes as tuples: a ``Rapid | Linear`` union is built again at every call
_STRAIGHT = (Rapid, Linear)
_PATH_MOVES = (Rapid, Linear, Arc)
#: non-modal codes whose axis words are theirs, not a motion's: G10, G28, G30, G92, G52.
AXIS_NONMODAL = frozenset((100, 280, 300, 920, 520))
#: g2core's "next actions" (Dialect.next_action_stops_motion): G4, G10, G28, G28.1, G30,
#: G30.1, G92-G92.3; and the tool length codes G43, G43.2, G49
_NEXT_ACTIONS = frozenset((40, 100, 280, 281, 300, 301, 920, 921, 922, 923))
_NEXT_ACTION_LENGTHS = frozenset((430, 432, 490))


class Interpreter:
    """Runs blocks against a modal state for one dialect (see :func:`interpret`)."""

    def __init__(
        self, dialect: Dialect, tools: dict[int, Tool] | None = None, events: bool = False
    ) -> None:
        self.dialect = dialect
        self.table = ToolTable(tools)
        self.search_path: tuple[Path, ...] = ()
        #: per subroutine level: what M70/M73 saved
        self.saved: dict[int, _Saved] = {}
        self.events = events
        self.state = ModalState(
            feed_mm_per_min=dialect.default_feed_mm_per_min or 0.0,
            feed_number=dialect.default_feed_mm_per_min or 0.0,
            pocket=self.table.first,
            motion=dialect.initial_motion,
            extruder=Extruder() if dialect.extruder else None,
        )
        self.params = Parameters(self._predefined, lambda: self.state.scale)
        self.params.numbered[COORD_INDEX] = 1.0
        self.line = 0
        self.cycle = CycleMemory()
        self.comp = CutterComp()
        self.nurbs = NurbsPoints()
        #: the letters of plain motion blocks, which take :meth:`_plain_step`
        #: (controller/gcode/plain_block.py; none: every block takes the general step)
        self.plain = plain_letters(dialect)
        #: whether a subroutine or M98 subprogram is running (the Runner's; none: the main program)
        self.in_subprogram: Callable[[], bool] = lambda: False
        #: the axes a Marlin G28 has homed (G28 O homes only while one of X, Y, Z is not)
        self.homed: set[str] = set()

    def comment(self, block: Block) -> None:
        """A line's ``(abort, message)`` comment ends the program there, as in rs274
        (:mod:`~gantry_sim.controller.gcode.comments`)."""
        message = abort_message(block.text, self.params)
        if message is not None:
            raise GcodeError(f"(abort,) ends the program here:{message}")

    def step(self, block: Block) -> tuple[list[Move | Event], bool]:
        """Validate ``block`` on a copy of the state, commit, return (moves, program ended)."""
        self.line = self.comp.line = block.line
        self._refresh_system_parameters()
        d = self.dialect
        if not d.language:
            check_plain(block, d)
        elif d.one_sign:
            check_signs(block, d)
        if block.bare:
            bare = self._marlin_bare(block)
            if bare is None:
                return [], False
            block = bare
        if self.plain:
            plain = self._plain_step(block)
            if plain is not None:
                return plain, False
        if block.jog:
            return self._jog(block)
        if block.home:
            return self._printer_home(block), False
        if block.limits:
            return self._limits(block), False
        if block.extruder is not None:
            self.state = set_extruder(self.state, block.extruder)
            return [], False
        if block.feed_percent is not None:
            self.state = set_feed_percent(self.state, *block.feed_percent)
            return [], False
        w = read_words(block, self.params, d, self._create_named)
        if w.g.get("feed_mode", INVERSE_TIME) == INVERSE_TIME:
            self._inverse_time_f(w.values)
        s = self.state
        # Step 2: every code is one gantry-sim supports.
        self._check_codes(w)
        # Step 3: feed mode, then feed, tool, spindle, overrides, M70-M73, coolant.
        s, tool_changed = self._machine_codes(w, s)
        # Step 4: plane, units, coordinate system, distance modes, path control.
        s = self._frame_codes(w, s)
        dwell_held = w.g.get("nonmodal") == 40 and "P" in w.values and self.comp.holding
        if dwell_held:  # rs274 queues the dwell behind the held move: it waits where that ends
            self.comp.hold_dwell(w.line, w.values["P"])
        # a command LinuxCNC runs with motion stopped: a stop before this block's motion
        wait = motion_wait(w, self.state, d.motion_waits) if self.events else None
        if wait is not None and self.comp.holding:  # behind the held move, as a G4
            self.comp.hold_dwell(w.line, 0.0)
            wait = None
        # G40/G41/G42, before the motion; G41/G42 read rs274's tool_table[find_tool_index(D)]:
        # D0 and no D are the spindle's entry
        released = (
            switch(self.comp, w, s, partial(self.table.entry, s)) if "cutter_comp" in w.g else []
        )
        cycle = self.cycle
        if "retract" in w.g:
            cycle = evolve(cycle, retract_to_r=w.g["retract"] == 990)
        # Step 5: which motion this block makes, if any.
        nonmodal = w.g.get("nonmodal")
        axis_code = nonmodal in AXIS_NONMODAL
        grbl_order = d.read_order == "grbl"  # gcode.c's order of checks
        if grbl_order and nonmodal == 530 and w.g.get("motion", s.motion) not in (0, 10):
            # gcode.c: the non-modal G53's check (the block's motion mode, G80 included) comes
            # before the motion modes' checks
            raise GcodeError("G53 (machine coordinates) must be used with G0 or G1")
        has_axes = not _AXIS_LETTERS.isdisjoint(w.values)  # A/B/C: only 0 gets this far
        # Marlin: a bare line runs as the modal motion even with no axis word (E5: a G1 E5)
        has_axes = has_axes or (block.bare != "" and any(k != "F" for k in w.values))
        motion = w.g.get("motion")
        if motion == 800:
            if has_axes and not axis_code and not d.permissive_blocks:
                raise GcodeError("axis words with G80 (motion off); use G0, G1, G2 or G3")
            s, motion = evolve(s, motion=None), None
            cycle = evolve(cycle, initial=None)
        elif motion is not None:
            if nonmodal is not None and axis_code and has_axes and d.permissive_blocks:
                s, motion = evolve(s, motion=motion), None  # g2core: G92 takes the words
            elif nonmodal is not None and axis_code:  # rs274: with axis words or not
                raise GcodeError(
                    f"{g_name(nonmodal)} and {g_name(motion)} both use the axis words; put them "
                    "on separate lines"
                )
            if motion in (20, 30) and d.permissive_blocks and _ARC_WORDS.isdisjoint(w.values):
                motion = None  # g2core: cm_arc_feed returns before it stores the mode
            if motion in (50, 51) and not any(a in w.values for a in "XY@^"):
                raise GcodeError(f"{g_name(motion)} needs X or Y: all axes missing")
            # rs274: G5/G5.1 leave the motion mode as it was
            if motion == 50 and d.splines == "marlin":  # GCODE_MOTION_MODES: G5 is modal
                s = evolve(s, motion=motion)
            elif motion is not None and motion not in (50, 51) and motion != s.motion:
                s = evolve(s, motion=motion)
        elif axis_code:
            pass  # the axis words belong to G10/G28/G30/G92
        elif s.motion in (20, 30) and not grbl_order and _centre_words(w):
            motion = s.motion  # rs274: a centre word alone continues a modal G2/G3
        elif has_axes and w.g.get("tool_length") in d.tool_length_axis_codes:
            pass  # the axis words are G43.1's offsets (grbl: G49 takes them too, and moves none)
        elif has_axes and s.motion is None and d.permissive_blocks:
            pass  # g2core starts with motion cancelled: axis words alone move nothing
        elif has_axes:
            if s.motion is None:
                raise GcodeError("axis words with no motion mode; put G0, G1, G2 or G3 first")
            motion = s.motion
            if motion in (20, 30) and d.permissive_blocks and not _next_action(w):
                raise GcodeError(
                    f"axis words continue the modal {g_name(motion)} with no centre offset "
                    "(I, J, K) or radius (R); g2core raises an alarm on such a line "
                    "(plan_arc.cpp: arc offsets missing or zero): give the arc's centre, or "
                    "G0/G1 for a straight move"
                )
        if d.next_action_stops_motion and _next_action(w):
            # g2core: the mode stays, but G28/G30 move by cm_straight_traverse, which sets G0
            kept = 0 if nonmodal in (280, 300) else self.state.motion
            s, motion = evolve(s, motion=kept), None
        check_words(w, motion, d)
        if d.r_needs_arc_code_first and w.r_before_arc_code:
            raise GcodeError(
                f"on {d.name} controls R means an arc radius only after G2 or G3 on the same "
                "line (otherwise it is 'Repeat', not supported); write G2 ... R or G3 ... R"
            )
        # Step 6: the non-modal codes, then the move, validated against the new state.
        moves: list[Move | Event] = list(released)
        if released:  # G40 finished the held move: the tool stays at its offset point, while
            # rs274 goes on from the programmed point until a tool change re-reads the position
            s = evolve(s, work=self.comp.released_end)
        s = self._nonmodal_codes(w, s, moves)
        if d.strict_g80 and has_axes and s.motion is None:
            # grbl 1.1 (gcode.c, G80 errors, after its non-modal commands' own checks): with
            # motion off even G28, G92, G10 or G43.1 may not carry axis words
            raise GcodeError("axis words with G80 (motion off) in effect; use G0, G1, G2 or G3")
        machine_coords = nonmodal == 530
        if machine_coords and d.g53_g2core:
            machine_coords = not s.incremental  # g2core: G91 adds to the position as ever
        elif machine_coords:
            if motion not in (0, 10) and not grbl_order:  # grbl's is checked above
                raise GcodeError("G53 (machine coordinates) must be used with G0 or G1")
            if s.incremental and not d.g53_absolute_in_g91:
                raise GcodeError("G53 cannot be used in incremental distance mode (G91); use G90")
        if motion is not None and motion not in CYCLES and cycle.initial is not None:
            cycle = evolve(cycle, initial=None)  # a series of cycles ends with another motion
        extrudes: bool | None = None
        e_before = s.extruder  # Marlin: an arc that plans nothing leaves E where it was
        if s.extruder is not None and motion is not None:
            e = w.values.get("E")
            extrudes, ext = s.extruder.move(None if e is None else e * s.scale)
            s = evolve(s, extruder=ext)
        made = len(moves)
        nurbs = self.nurbs
        if nonmodal == G5_3:  # before the motion, as rs274's modal group 0
            s, cycle, nurbs = self._splines(w, s, G5_3, cycle, moves)
        if motion in SPLINE_MOTIONS:
            s, cycle, nurbs = self._splines(w, s, motion, cycle, moves, nurbs, nonmodal == G5_3)
        elif motion in CYCLES:
            if self.comp.side is not None:
                raise GcodeError(
                    f"cannot use canned cycles with cutter compensation on; G40 before "
                    f"{g_name(motion)}"
                )
            if machine_coords:
                raise GcodeError("G53 (machine coordinates) must be used with G0 or G1")
            s, cycle = self._cycle(w, s, motion, cycle, moves)
        elif motion is not None:
            if machine_coords:
                end = self._machine_end_point(w.values, s)
            else:
                end = self._end_point(w.values, s)
            if motion in (20, 30) and self.comp.arc_not_allowed:
                exc = GcodeError(
                    "the move just after exiting cutter compensation mode must be straight, "
                    "not an arc"
                )
                exc.partial = tuple(moves)  # type: ignore[attr-defined]  # G40 released them
                raise exc
            if motion in (0, 10):
                self.comp.arc_not_allowed = False
            if self.comp.active:
                s = self._comp_motion(w, s, motion, end, moves)
            elif motion in (0, 10) and d.permissive_blocks and not has_axes:
                if motion == 10:  # g2core: cm_straight_feed refuses feed 0 first
                    self._require_feed(s, "a G1 move", w.values)
                # (cm_straight_traverse/feed: "legal ... but we don't want to process it")
            elif motion == 0 and not d.g0_at_feed:
                s = self._emit(moves, s, Rapid(w.line, s.work, to_work(end, s.frame)), end)
            elif motion in (0, 10):  # G1, or a G0 where the controller moves it as one
                self._require_feed(s, "a G1 move", w.values)
                move = Linear(w.line, s.work, to_work(end, s.frame), s.feed_mm_per_min)
                s = self._emit(moves, s, self._fed_straight(move, s, w.values, end), end)
            else:
                self._require_feed(s, "an arc", w.values)
                arc = arc_move(w.line, w.values, s, end, motion == 30, d)
                if arc == STRAIGHT:  # grbl: mc_arc's one mc_line, straight to the end
                    line = Linear(w.line, s.work, to_work(end, s.frame), s.feed_mm_per_min)
                    s = self._emit(moves, s, self._fed(line, s, w.values), end)
                elif arc is not None:
                    per_segment = d.arc_tolerance_mm if d.g93_arc_per_segment else None
                    placed = self._fed(
                        self._arc_to_work(arc, s), s, w.values, per_segment, program=arc
                    )
                    s = self._emit(moves, s, placed, arc.end)  # arc.end: program frame
                    if arc.end != end and d.end_on_start_circle:
                        s = evolve(s, position=end)  # g2core: the next move starts off it
                    elif arc.end != end:  # Marlin: its last segment goes on to the end point
                        rest = Linear(w.line, s.work, to_work(end, s.frame), s.feed_mm_per_min)
                        s = self._emit(moves, s, self._fed(rest, s, w.values), end)
                elif e_before is not None:  # current_position, its E too, is not committed
                    s = evolve(s, extruder=e_before)
        if extrudes is not None:  # Marlin: whether this block's move runs at P or T (M204)
            moves[made:] = [
                evolve(m, extrudes=extrudes) if isinstance(m, Linear | Arc | Spline) else m
                for m in moves[made:]
            ]
        stop = w.m.get("stopping")
        if stop == 99 and self.in_subprogram():
            exc = GcodeError(
                "M99 after other words inside a subprogram: M99 returns only where it opens its "
                "line (rs274: Reached convert_stop() from M99 as subprogram return); in the main "
                "program it ends the program, as M2"
            )
            # rs274 has made the line's motion when it refuses the M99
            exc.partial = [m for m in moves if isinstance(m, Rapid | Linear | Arc)]  # type: ignore[attr-defined]
            raise exc
        if stop is not None and self.comp.side is not None:  # rs274 convert_stop: finish it
            if self.comp.active and not self.comp.first:
                moves.extend(self.comp.flush_at(self.comp.current[0], self.comp.current[1]))
                s = evolve(s, work=self.comp.released_end)
            if stop in M_PROGRAM_END:
                self.comp.side, self.comp.first = None, True
        if grbl_order:  # gcode.c: unused words are its step 3's last check
            check_unused_words(w, motion, d)
        # Step 7: commit; events after the block's motion (rs274 runs G4 before motion, so a
        # dwell on a motion line waits before it moves).
        if self.events:
            if nonmodal == 40 and "P" in w.values and not dwell_held:
                # rs274 prints DWELL(-3) for G4 P-3, which LinuxCNC's task ends at once
                moves.insert(0, Dwell(w.line, self.state.work, max(0.0, w.values["P"])))
            if wait is not None:
                moves.insert(0, Stop(w.line, self.state.work, wait))
            stop = w.m.get("stopping")
            if stop in (0, 1, 60) or (stop in M_PROGRAM_END and d.program_end_continues):
                moves.append(Stop(w.line, s.work, f"M{stop}"))  # grbl: M2/M30 stop, go on
        if s.path is not None:
            _set_path(moves, s.path)
        s = self._canon(s, moves)
        if tool_changed:
            s = after_tool_change(s)
        if w.m.get("tool_change") == 6 and s.selected_tool > 0:
            # rs274: M6 sets #5400-#5413 (M61 does not; after T0 M6 rs274 -g keeps them)
            loaded = self.table.lookup(s.selected_tool) or Tool(s.selected_tool, 0.0)
            self.params.numbered.update(tool_parameters(loaded))
        self.state = s
        self.cycle = cycle
        self.nurbs = nurbs
        for target, value in w.settings:
            if isinstance(target, str):
                self.params.set_named(target, value)
            else:
                self.params.set_number(target, value)
        ended = w.m.get("stopping") in M_PROGRAM_END
        if ended and d.program_end_continues:
            self.state = _PROGRAM_END[d.program_end_continues](self.state, self.params)
            return moves, False
        return moves, ended

    def _nonmodal_codes(self, w: Words, s: ModalState, moves: list[Move | Event]) -> ModalState:
        """Step 6a on ``s``: the block's group-0 code (G10, G92/G52, G28.1/G30.1, G28/G30, whose
        moves go to ``moves``), then G92.1-G92.3 where rs274 keeps them apart."""
        d = self.dialect
        code = w.g.get("nonmodal")
        if code == 100 and round(w.values.get("L", 0)) in (1, 10, 11) and d.g10_rotation:
            s = set_tool_entry(s, self.params, w.values, self.table)
        elif code == 100:
            s = g10(
                s,
                self.params,
                w.values,
                d.coordinate_systems,
                d.language,
                d.g10_p_truncated,
                d.g10_g2core,
            )
        elif code in (920, 921, 922, 923, 520):
            if code == 920 and d.permissive_blocks and _AXIS_LETTERS.isdisjoint(w.values):
                code = 923  # g2core: a bare G92 turns the G92 offsets back on
            s = g92(s, self.params, code, w.values)
            if code == 920 and s.extruder is not None and "E" in w.values:
                s = evolve(s, extruder=s.extruder.at(w.values["E"] * s.scale))
        elif code in (281, 301):
            store_home(s, self.params, code)
        elif code in (280, 300):
            s = self._home(w.line, w.values, s, code, moves)
        if "g92_reset" in w.g:  # rs274: after group 0's codes (G92 X3 G92.1 ends with none)
            s = g92(s, self.params, w.g["g92_reset"], w.values)
        return s

    def _marlin_bare(self, block: Block) -> Block | None:
        """A Marlin line of bare parameters (``X10 Y5``) as GCODE_MOTION_MODES reads it: the
        block with the words its modal motion reads, or None where Marlin runs nothing of it."""
        motion = self.state.motion
        modal = None if motion is None else MARLIN_BARE_OPENERS.get(motion)
        if modal is None or block.bare not in modal[0]:
            # Marlin (parser.cpp): no modal motion yet, or one that takes no such opener:
            # "Unknown command", and nothing of the line runs (its F neither)
            return None
        return dataclasses.replace(
            block, words=tuple(wd for wd in block.words if wd[0] in modal[1])
        )

    def _check_codes(self, w: Words) -> None:
        """Step 2: every code of ``w`` is one gantry-sim supports in this dialect, a user M code
        has its file, and the words a code needs are there (rs274's read-time checks)."""
        d = self.dialect
        check_codes(w, d)
        check_motion_axes(w, d)
        check_polar_plane(w.values, self.state)
        user = w.m.get("user")
        if user is not None and not any((f / f"M{user}").is_file() for f in self.search_path):
            raise GcodeError(
                f"unknown M code M{user}: a user M-code needs its program file M{user} in the "
                "program's folder or a --subroutine-path folder (LinuxCNC: USER_M_PATH)"
            )
        for code in w.g.values():
            if code in G_REFUSED:
                raise GcodeError(f"{g_name(code)} is not supported: {G_REFUSED[code]}")
            assert code in G_HANDLED or code in G_NO_PATH_EFFECT
            if code in CYCLES and not d.canned_cycles:
                raise GcodeError(f"{g_name(code)} is not supported: {d.name} has no canned cycles")
            if code in SPLINE_CODES and not d.splines:
                raise GcodeError(f"{g_name(code)} is not supported: {d.name} has no splines")
            if code in SPLINE_CODES and d.splines == "marlin" and code != 50:
                raise GcodeError(f"{g_name(code)} is not supported: Marlin's only spline is G5")
            if code in (410, 411, 420, 421) and not d.cutter_comp:
                raise GcodeError(
                    f"{g_name(code)} is not supported: {d.name} has no cutter radius compensation"
                )

    def _machine_codes(self, w: Words, s: ModalState) -> tuple[ModalState, bool]:
        """Step 3 on ``s``: feed mode, then feed (in the units in effect BEFORE this block's
        G20/G21, as rs274 does), tool words, S, G96/G97, overrides, spindle, M70-M73 and
        coolant; returns the state and whether the tool changed."""
        d = self.dialect
        if "feed_mode" in w.g:
            s = evolve(s, feed_mode=w.g["feed_mode"])
            if clears_feed(self.state.feed_mode, w.g["feed_mode"], d):
                s = evolve(s, feed_mm_per_min=0.0, feed_number=0.0)
        if "F" in w.values and not (d.positive_feed_only and w.values["F"] <= 0.0):
            if w.values["F"] < 0.0:
                raise GcodeError("negative F word; the feed must be >= 0 (units per minute)")
            scale = s.scale
            if d.feed_in_line_units and "units" in w.g:
                scale = MM_PER_INCH if w.g["units"] == 200 else 1.0
            s = evolve(s, feed_mm_per_min=w.values["F"] * scale, feed_number=w.values["F"])
        s, tool_changed = tool_words(s, w, self.table)
        if "S" in w.values and "S" not in d.ignored_letters:
            s = evolve(s, rpm=w.values["S"])
        if "spindle_mode" in w.g:
            s = evolve(s, css=w.g["spindle_mode"] == 960)
        if "override" in w.m and w.m["override"] != 56:
            s = evolve(s, overrides=overrides(s, w.m["override"], w.values, self.comp.side))
        if "spindle" in w.m:
            s = evolve(s, spindle={3: 1, 4: -1, 5: 0, 19: 0}[w.m["spindle"]])  # M19: stopped
        # M70-M73 (rs274's convert_m: after the spindle's codes, before coolant and the G
        # codes of this block, so "M72 G20" ends in G20 and "M70 G20" saves the units before)
        s = self._modal_state(w.m.get("modal_state"), s)
        if "coolant" in w.m:
            c = w.m["coolant"]
            s = evolve(s, mist=c == 7 or (s.mist and c == 8), flood=c == 8 or (s.flood and c == 7))
        return s, tool_changed

    def _frame_codes(self, w: Words, s: ModalState) -> ModalState:
        """Step 4 on ``s``: plane, units, coordinate system, distance modes and path control
        (after rs274's checks of what compensation forbids)."""
        d = self.dialect
        check_while_on(self.comp, w, self.state)
        if "plane" in w.g:
            s = evolve(s, plane=_PLANES[w.g["plane"]])
        if w.g.get("units") == 200 and not d.g20_is_inch:
            raise GcodeError(d.g20_refusal)
        if "units" in w.g:
            s = evolve(s, inch=w.g["units"] == 200)
        if "coordinate_system" in w.g:
            s = select_system(s, self.params, SYSTEMS[w.g["coordinate_system"]])
        if "distance" in w.g:
            s = evolve(s, incremental=w.g["distance"] == 910)
            if s.extruder is not None:  # Marlin: G90/G91 set E's mode too
                s = evolve(s, extruder=s.extruder.with_mode(w.g["distance"] == 910))
        if "arc_distance" in w.g:
            s = evolve(s, arc_absolute=w.g["arc_distance"] == 901)
        if "path_control" in w.g:
            s = evolve(s, path=path_control(w.g["path_control"], w.values, s.scale))
        return s

    def _plain_step(self, block: Block) -> list[Move | Event] | None:
        """:meth:`step` of a plain motion block (controller/gcode/plain_block.py) in a state
        where nothing else applies (cutter compensation off): what the general step does with
        such a block, its state changed in two copies instead of its five or six; None for any
        other block (the general step runs it, and says what is wrong with it)."""
        if (
            block.settings
            or block.jog
            or block.home
            or block.limits
            or block.extruder is not None
            or block.feed_percent is not None
        ):
            return None
        read = plain_motion(block.words, self.plain)
        comp, s, d = self.comp, self.state, self.dialect
        if read is None or comp.side is not None or comp.holding:
            return None
        motion, v = read
        if block.bare and (s.motion is None or _PLAIN_AXES.isdisjoint(v)):
            return None  # Marlin: a bare line before any G0-G3, or a bare E (the general step)
        if motion is not None and d.permissive_blocks and _PLAIN_AXES.isdisjoint(v):
            return None  # g2core: a G0/G1 with no axis word moves nothing (the general step)
        if motion is None and not _PLAIN_AXES.isdisjoint(v):
            motion = s.motion  # axis words alone: the modal motion
            if motion not in (0, 10):
                return None
        changes: dict[str, Any] = {}
        self._inverse_time_f(v)
        feed = v.get("F")
        if feed is not None and not (d.positive_feed_only and feed <= 0.0):
            if feed < 0.0:
                return None
            changes.update(feed_mm_per_min=feed * s.scale, feed_number=feed)
        if motion is None:  # an F alone
            self.state = evolve(s, **changes) if changes else s
            return []
        if motion != s.motion:
            if d.motion_waits == "grbl" and s.spindle == 1 and _PLAIN_AXES.isdisjoint(v):
                return None  # a laser's power change may wait for motion (motion_waits.py)
            changes["motion"] = motion
        extrudes: bool | None = None
        if s.extruder is not None:  # Marlin: whether the move runs at M204 P or T
            e = v.get("E")
            extrudes, changes["extruder"] = s.extruder.move(None if e is None else e * s.scale)
        if changes:
            s = evolve(s, **changes)
        if self.cycle.initial is not None:
            self.cycle = evolve(self.cycle, initial=None)  # a series of cycles ends here
        end = self._end_point(v, s)
        comp.arc_not_allowed = False
        move: Rapid | Linear
        if motion == 0 and not d.g0_at_feed:
            move = Rapid(block.line, s.work, to_work(end, s.frame), s.path)
        else:
            self._require_feed(s, "a G1 move", v)
            move = Linear(
                block.line, s.work, to_work(end, s.frame), s.feed_mm_per_min, s.path, extrudes
            )
            move = self._fed_straight(move, s, v, end)
        # _emit, then _canon: the tool at the move's end, and rs274's canonical point there
        self.state = evolve(s, position=end, work=move.end, canon=from_work(move.end, s.frame))
        return [move]

    def _cycle(
        self, w: Words, s: ModalState, motion: int, cycle: CycleMemory, moves: list[Move | Event]
    ) -> tuple[ModalState, CycleMemory]:
        """A canned cycle's moves (and, when asked for, its dwell and stop events)."""
        if self.state.motion != motion:
            cycle = evolve(cycle, motion=None)  # rs274: R, Z, P, Q... are needed again
        feed = s.feed_mm_per_min
        if s.feed_mode == 950:  # G95: F per revolution times S, as for G1
            if s.rpm <= 0.0 and feed > 0.0:
                raise GcodeError(
                    f"cannot feed {g_name(motion)} with zero spindle speed in feed per "
                    "revolution (G95); set S"
                )
            feed = per_revolution(feed, s.rpm)
        items, end, cycle = run_cycle(
            w.line,
            motion,
            w.values,
            position=s.position,
            work=s.work,
            plane=s.plane,
            scale=s.scale,
            incremental=s.incremental,
            frame=s.frame,
            feed_mm_per_min=feed,
            inverse_time=s.feed_mode == 930,
            spindle=s.spindle,
            memory=cycle,
        )
        moves.extend(m for m in items if self.events or isinstance(m, _STRAIGHT))
        work = next((m.end for m in reversed(items) if isinstance(m, _STRAIGHT)), s.work)
        return evolve(s, position=end, work=work), cycle

    def _comp_motion(
        self, w: Words, s: ModalState, motion: int, end: Vec3, moves: list[Move | Event]
    ) -> ModalState:
        """A G0/G1/G2/G3 under cutter compensation: its tool-centre path, released a block
        late (controller/gcode/comp_paths.py)."""
        programmed: Arc | None = None
        fed = s  # the state whose feed the tool-centre moves take
        if motion == 10:
            self._require_feed(s, "a G1 move", w.values)
            # G93/G95: the feed of the programmed move, from its own length (rs274's
            # inverse_time_rate_straight), not the compensated path's
            straight = Linear(w.line, s.position, end, s.feed_mm_per_min)
            fed = evolve(s, feed_mm_per_min=self._fed(straight, s, w.values).feed_mm_per_min)
        elif motion in (20, 30):
            self._require_feed(s, "an arc", w.values)
            arc = arc_move(w.line, w.values, s, end, motion == 30, self.dialect)
            if not isinstance(arc, Arc):  # None: nothing moves (no dialect with cutter
                return s  # compensation makes an arc straight)
            feed = self._fed(arc, s, w.values).feed_mm_per_min
            programmed = evolve(arc, feed_mm_per_min=feed)
            end = programmed.end
        released = comp_move(self.comp, motion, w.line, end, fed, programmed, "R" in w.values)
        moves.extend(released)
        return evolve(s, position=end, work=self.comp.released_end)

    def _splines(
        self,
        w: Words,
        s: ModalState,
        code: int,
        cycle: CycleMemory,
        moves: list[Move | Event],
        nurbs: NurbsPoints | None = None,
        ended: bool = False,
    ) -> tuple[ModalState, CycleMemory, NurbsPoints]:
        """G5/G5.1 (a move now), a G5.2 control point, or G5.3 (the NURBS move); see
        controller/gcode/splines.py."""
        if self.comp.side is not None:
            check_spline_block(code, w.values, s, comp_on=True)
        if code == G5_2:
            restart = self.state.motion != G5_2 or ended
            end = self._end_point(w.values, s)
            memory = self.nurbs if nurbs is None else nurbs
            return s, cycle, nurbs_point(w.values, s, memory, end, restart)
        marlin = self.dialect.splines == "marlin"
        v = {"I": 0.0, "J": 0.0, "P": 0.0, "Q": 0.0, **w.values} if marlin else w.values
        if code != G5_3:
            self._require_feed(s, "a spline", w.values)
            check_spline_block(code, v, s, comp_on=False, marlin=marlin)
        end = self._end_point(v, s) if code != G5_3 else s.position
        move, ij, end = spline_block(
            w.line,
            code,
            v,
            s,
            end,
            (0.0, 0.0) if marlin else (cycle.ijk[0], cycle.ijk[1]),
            self.nurbs,
            self.state.motion,
            w.g.get("motion"),
        )
        if code == G5_3:
            if s.feed_mode == 930:
                raise GcodeError(
                    "G5.3 under inverse time (G93) is not supported: give the NURBS a feed "
                    "in units per minute (G94)"
                )
            self._require_feed(s, "a NURBS (G5.3)", w.values)
            s = evolve(s, motion=None)
        cycle = evolve(cycle, ijk=(ij[0], ij[1], cycle.ijk[2]))
        placed = self._fed(move, s, w.values)
        s = self._emit(moves, s, placed, end)
        return s, cycle, NurbsPoints()

    @staticmethod
    def _emit(moves: list[Move | Event], s: ModalState, move: Move, end: Vec3) -> ModalState:
        moves.append(move)  # (its path control: _set_path, once the block's moves are made)
        return evolve(s, position=end, work=move.end)

    def _arc_to_work(self, arc: Arc, s: ModalState) -> Arc:
        """The arc (program coordinates) placed in the work frame, from where the tool is."""
        f = s.frame
        placed = arc
        if not f.identity:
            placed = evolve(
                arc, start=s.work, end=to_work(arc.end, f), center=to_work(arc.center, f)
            )
        if f.rotation_deg != 0.0 and arc.plane != "XY":
            placed = turned_plane(placed, f.rotation_deg)  # a quarter turn: another plane
        if max(abs(a - b) for a, b in zip(to_work(arc.start, f), s.work, strict=True)) > 1e-9:
            # rs274 re-expressed its point (G10 L2 R under G92, a tool offset change): the
            # canonical layer starts the arc where the tool is
            return from_where_it_is(evolve(placed, start=s.work))
        return placed

    def _home(
        self, line: int, v: dict[str, float], s: ModalState, code: int, moves: list[Move | Event]
    ) -> ModalState:
        """G28 / G30: rapid through the axis words' point (if any) to the stored point."""
        axes = {a for a in "XYZ" if a in v}
        if axes or self.dialect.home_first_move:
            mid = self._end_point(v, s)  # rs274 always makes the first move, even of length 0
            s = self._emit(moves, s, Rapid(line, s.work, to_work(mid, s.frame)), mid)
        if self.dialect.home_all_axes:
            axes = set()
        home = home_point(s, self.params, code, axes)
        return self._emit(moves, s, Rapid(line, s.work, to_work(home, s.frame)), home)

    def _machine_end_point(self, v: dict[str, float], s: ModalState) -> Vec3:
        """G53: axis words are machine coordinates: the work frame without offsets, rotation
        or tool length offset."""
        # rs274's find_ends: the unnamed axes stay at the interpreter's point; a named one is
        # the spindle's machine coordinate, so the tool offset comes off
        end = list(to_work(s.position, s.frame))
        for i, letter in enumerate("XYZ"):
            if letter in v:
                end[i] = v[letter] * s.scale - s.tool_offset_mm[i]
        return from_work((end[0], end[1], end[2]), s.frame)

    def preset(self, values: Mapping[int, float]) -> None:
        """Start from these numbered parameters (LinuxCNC's parameter file, lengths in mm): G54
        in effect with its origin from them, and their G92 offset when #5210 is 1; the tool
        stays at the work frame's origin."""
        self.params.numbered.update(values)
        p = self.params
        on = p.numbered.get(G92_ENABLED) == 1.0
        g92 = (p.mm(G92_OFFSET), p.mm(G92_OFFSET + 1), p.mm(G92_OFFSET + 2)) if on else (0.0,) * 3
        p.numbered[COORD_INDEX] = 1.0
        self._start_in(system_frame(p, 1, g92))

    def place(self, offset: Vec3) -> None:
        """Set G54's origin to ``offset`` [mm] and make it the frame in effect."""
        for i in range(3):
            self.params.numbered[g5x_base(1) + i] = offset[i]
        self.params.numbered[COORD_INDEX] = 1.0
        self._start_in(system_frame(self.params, 1, self.state.frame.g92))

    def _start_in(self, frame: Frame) -> None:
        """Before the first line: G54 in ``frame``, the tool where it is in the work frame."""
        position = from_work(self.state.work, frame)
        self.state = evolve(
            self.state, frame=frame, position=position, canon=position, coord_index=1
        )

    def _modal_state(self, code: int | None, s: ModalState) -> ModalState:
        """M70 save, M71 invalidate, M72 restore, M73 save and restore at the subroutine's
        return (controller/gcode/modal_save.py), per subroutine level."""
        level = self.params.level
        old = self.saved.get(level)
        if code in (70, 73):  # rs274 sets flags: an M70 after an M73 still restores at return
            on_return = (old is not None and old.on_return) or (code == 73 and level > 0)
            self.saved[level] = _Saved(s, on_return, True)
        elif code == 71 and old is not None:
            self.saved[level] = old._replace(valid=False)
        elif code == 72:
            if old is None or not old.valid:
                raise GcodeError("M72 with no state saved by M70 or M73 at this level")
            s = restore(old.state, s, self.params)
        return s

    def sub_returned(self, level: int) -> None:
        """A subroutine at ``level`` returned: an M73 there restores its saved state."""
        saved = self.saved.pop(level, None)
        if saved is not None and saved.on_return and saved.valid:
            self.state = restore(saved.state, self.state, self.params)

    def _canon(self, s: ModalState, moves: list[Move | Event]) -> ModalState:
        """Where rs274's canonical layer has the tool after this block (``ModalState.canon``):
        the last motion's end, else the old place shifted by the change of G5x and G92."""
        for last in reversed(moves):
            if isinstance(last, _PATH_MOVES):
                return evolve(s, canon=from_work(last.end, s.frame))
        old, new = self.state.frame, s.frame
        if old == new:
            return s
        shift = add(sub(old.g5x, new.g5x), sub(old.g92, new.g92))
        return evolve(s, canon=add(s.canon, shift))

    def _limits(self, block: Block) -> list:
        """Marlin M201/M203/M204/M205: a Limits event (when events are asked for)."""
        values = {k: evaluate(t, self.params) for k, t in block.words if k != "M"}
        if not self.events:
            return []
        return [Limits(block.line, block_code(block), tuple(sorted(values.items())))]

    def _printer_home(self, block: Block) -> list[Move | Event]:
        """Marlin G28: the named axes (all when none) go to the machine's home, the position
        its endstops give: the machine file's [work] g28_mm (default: the work origin). As
        Marlin's set_axis_is_at_home, homing also clears the G92 shift of every homed axis. With
        O, nothing happens once every axis has been homed (the program's G28s: a printer starts
        with none homed)."""
        s = self.state
        named = [a for a, _ in block.words if a in "XYZ"] or list("XYZ")
        if any(a == "O" for a, _ in block.words) and self.homed >= {"X", "Y", "Z"}:
            return []  # G28 O: "homing not needed, skip" (G28.cpp, axes_should_home)
        self.homed |= set(named)
        moves: list[Move | Event] = []
        raise_mm = next((t[1] for a, t in block.words if a == "R"), 0.0) * s.scale
        if raise_mm > 0.0:  # G28 R: Z up by R before any axis homes (do_z_clearance)
            up = (s.position[0], s.position[1], s.position[2] + raise_mm)
            s = self._emit(moves, s, Rapid(block.line, s.work, to_work(up, s.frame)), up)
        home = [self.params.mm(G28_HOME + i) for i in range(3)]
        target = tuple(home[i] if a in named else s.work[i] for i, a in enumerate("XYZ"))
        g92 = tuple(0.0 if a in named else s.frame.g92[i] for i, a in enumerate("XYZ"))
        for i, a in enumerate("XYZ"):
            if a in named:
                self.params.numbered[G92_OFFSET + i] = 0.0
        frame = evolve(s.frame, g92=(g92[0], g92[1], g92[2]))
        s = evolve(s, frame=frame)
        end = from_work((target[0], target[1], target[2]), frame)
        self.state = self._emit(moves, s, Rapid(block.line, s.work, to_work(end, frame)), end)
        if s.path is not None:
            _set_path(moves, s.path)
        return moves

    def _jog(self, block: Block) -> tuple[list[Move | Event], bool]:
        """grbl ``$J=``: a G1 in the jog's own modes and feed; the modal state is kept."""
        saved = self.state
        w = read_words(block, self.params, self.dialect)
        check_jog(w)
        if self.dialect.jog_units_per_minute and saved.feed_mode == INVERSE_TIME:
            self.state = evolve(saved, feed_mode=UNITS_PER_MINUTE)  # grbl's jog: F per minute
        head: tuple[tuple[str, Tree], ...] = (("G", ("num", 1.0)),) if jog_moves_as_g1(w) else ()
        if head and _AXIS_LETTERS.isdisjoint(w.values):
            # grbl 1.1h: a jog with no axis word keeps its block's target at 0 (gcode.c fills
            # in the current position only for a line with axis words): it goes to machine zero
            zero = ("num", 0.0)
            head = (*head, ("G", ("num", 53.0)), ("X", zero), ("Y", zero), ("Z", zero))
        g1 = Block(block.line, (*head, *block.words), (), False, block.text)
        try:
            moves, _ = self.step(g1)
            check_jog_after(w)
        finally:
            done = self.state
            self.state = evolve(saved, position=done.position, work=done.work)
        return moves, False

    def _create_named(self, name: str) -> None:
        """rs274 adds a named parameter as it reads its setting (add_named_param): the rest
        of the line reads a new one as 0; the value is set after the line."""
        if not self.params.exists(name):
            self.params.set_named(name, 0.0)

    def _predefined(self, name: str) -> float | None:
        comp = self.comp
        centre = comp.current if comp.active and not comp.first else None
        return predefined(
            name, self.state, self.params, self.line, self.cycle.retract_to_r, comp.side, centre
        )

    def _refresh_system_parameters(self) -> None:
        """#5420-#5422: the current X Y Z in program units (stored in mm)."""
        numbered, (x, y, z) = self.params.numbered, self.state.position
        numbered[POSITION], numbered[POSITION + 1], numbered[POSITION + 2] = x, y, z
        self.params.position_locked = self.comp.side is not None

    def _fed(
        self,
        move: Linear | Arc | Spline,
        s: ModalState,
        v: dict[str, float],
        arc_segments_mm: float | None = None,
        program: Linear | Arc | None = None,
    ) -> Linear | Arc | Spline:
        """:func:`~gantry_sim.controller.gcode.feed_modes.path_feed` with the dialect's least
        inverse-time rate (its ``g93_min_rate``, program units per minute). ``program``: the
        move in the program's frame, whose length an inverse-time feed takes (rs274's
        inverse_time_rate_straight/_arc: the first move after G43 changes the tool tip's Z in
        the machine, not the programmed Z)."""
        floor = self.dialect.g93_min_rate * s.scale
        if program is not None and s.feed_mode == INVERSE_TIME:
            fed = path_feed(program, s, v, arc_segments_mm, inverse_time_floor_mm=floor)
            return dataclasses.replace(move, feed_mm_per_min=fed.feed_mm_per_min)
        return path_feed(move, s, v, arc_segments_mm, inverse_time_floor_mm=floor)

    def _fed_straight(self, move: Linear, s: ModalState, v: dict[str, float], end: Vec3) -> Linear:
        """:meth:`_fed` of a straight feed move to ``end`` (program frame): in G93 its rate
        from the programmed length, from ``s.position`` to ``end`` (a program-frame move is
        made only then: this runs for every G1 of a long program)."""
        program = None
        if s.feed_mode == INVERSE_TIME:
            program = Linear(move.line, s.position, end, s.feed_mm_per_min)
        fed = self._fed(move, s, v, program=program)
        assert isinstance(fed, Linear)  # path_feed keeps a move's kind
        return fed

    @staticmethod
    def _end_point(v: dict[str, float], s: ModalState) -> Vec3:
        if "@" in v or "^" in v:
            return polar_end_point(v, s)
        end = list(s.position)
        for i, letter in enumerate("XYZ"):
            if letter in v:
                value = v[letter] * s.scale
                end[i] = s.position[i] + value if s.incremental else value
        return (end[0], end[1], end[2])

    def _inverse_time_f(self, values: dict[str, float]) -> None:
        """g2core (``Dialect.g93_f_stands``): a block started in G93 that stays in it and has no
        F runs with the last F given in G93 (``values`` gets it)."""
        s = self.state
        if self.dialect.g93_f_stands and s.feed_mode == INVERSE_TIME and "F" not in values:
            if s.feed_number > 0.0:
                values["F"] = s.feed_number

    @staticmethod
    def _require_feed(s: ModalState, what: str, values: dict[str, float]) -> None:
        """The feed a feed move needs (the block's words ``values``): GcodeError if none."""
        check_feed_mode(s, what, values)
        if s.feed_mm_per_min <= 0.0:
            raise GcodeError(
                f"cannot make {what} with zero feed rate; set F (units per minute, > 0) on this "
                "or an earlier line"
            )


def _centre_words(w: Words) -> bool:
    """Whether the line holds an arc's centre word (I, J, K, or R where no M19 takes it as its
    angle: rs274 orients the spindle on ``M19 R90`` after a G2, and moves nothing)."""
    r_taken = w.m.get("spindle") == 19
    return any(c in w.values for c in "IJK") or ("R" in w.values and not r_taken)


def _next_action(w: Words) -> bool:
    """Whether block ``w`` holds a g2core "next action" (gcode_parser.cpp), which takes the
    place of the block's motion."""
    return w.g.get("nonmodal") in _NEXT_ACTIONS or w.g.get("tool_length") in _NEXT_ACTION_LENGTHS


class _Saved(NamedTuple):
    """What M70/M73 saved at one call level (rs274's context flags beside the state)."""

    state: ModalState
    on_return: bool  # M73 (at a subroutine's level): restored at its return
    valid: bool  # M71 clears it; M72 needs it


def _set_path(moves: list[Move | Event], path: PathControl) -> None:
    """Give each motion of a block that has no path control of its own the block's ``path``:
    its G0-G3 and splines, a canned cycle's moves and cutter compensation's tool-centre moves
    alike (a move released a block late under compensation keeps the mode it was made in: rs274
    refuses a mode change while compensation is on)."""
    for k, m in enumerate(moves):
        if isinstance(m, _MOTIONS) and m.path is None:
            moves[k] = evolve(m, path=path)


_MOTIONS = (Rapid, Linear, Arc, Spline)
#: M2/M30 where the program goes on (Dialect.program_end_continues): the state after them
_PROGRAM_END = {"grbl": grbl_program_end, "g2core": g2core_program_end}
#: the axis words of a plain motion block
_PLAIN_AXES = frozenset("XYZ")
#: the words that move an axis (A/B/C: only a word of 0 gets as far as the motion)
_AXIS_LETTERS = frozenset("XYZ@^ABC")
#: the words that make a G2/G3 line an arc for g2core (plan_arc.cpp cm_arc_feed): an axis, an
#: offset, R or P; without one it returns before storing the motion mode
_ARC_WORDS = _AXIS_LETTERS | frozenset("IJKRP")


def interpret(
    text: str,
    dialect: str = "linuxcnc",
    file: str = "<program>",
    search_path: tuple[Path, ...] = (),
    max_iterations: int = DEFAULT_MAX_ITERATIONS,
    errors: list[GcodeError] | None = None,
    tools: dict[int, Tool] | None = None,
    work_offset: Vec3 | None = None,
    parameters: Mapping[int, float] | None = None,
) -> Iterator[Move]:
    """Yield the program's moves in order; GcodeError(file, line) at the first bad line.

    Args:
        text: the program.
        dialect: one of ``gantry_sim.controller.gcode.dialects.DIALECTS``.
        file: the program's name, for error messages.
        search_path: folders searched for ``NAME.ngc`` subroutine files, in order.
        max_iterations: bound on loop repetitions and subroutine calls (see control.py).
        errors: when given, refused lines are collected here (up to MAX_ERRORS) instead of
            raising at the first one (``gantry parse --all-errors``).
        tools: the tool table (tool number -> Tool) for T, M6, G43 H.
        work_offset: where program zero lies in the machine's work frame [mm].
        parameters: numbered parameters the program starts with (the machine file's [work]:
            stored offsets and positions, lengths in mm); ``work_offset`` then sets G54.
    """
    args = (text, dialect, file, search_path, max_iterations, errors, tools, work_offset)
    for item in interpret_events(*args, events=False, parameters=parameters):
        if isinstance(item, Rapid | Linear | Arc | Spline):  # no events made when not asked for
            yield item


def interpret_events(
    text: str,
    dialect: str = "linuxcnc",
    file: str = "<program>",
    search_path: tuple[Path, ...] = (),
    max_iterations: int = DEFAULT_MAX_ITERATIONS,
    errors: list[GcodeError] | None = None,
    tools: dict[int, Tool] | None = None,
    work_offset: Vec3 | None = None,
    events: bool = True,
    parameters: Mapping[int, float] | None = None,
) -> Iterator[Move | Event]:
    """:func:`interpret`, plus the program's events in their place among the moves: dwells
    (G4), program stops (M0/M1/M60) and Marlin's limit changes (M201-M205)."""
    rules: Dialect | None = None
    try:
        rules = get_dialect(dialect)
        interp = Interpreter(rules, tools, events)
        interp.search_path = search_path
        if parameters:
            interp.preset(parameters)
        if work_offset is not None:
            interp.place(work_offset)
        runner = Runner(
            text,
            file,
            interp.step,
            interp.params,
            search_path,
            max_iterations,
            lex_rules=LexRules(
                rules.system_lines,
                rules.line_number_words,
                rules.o_words,
                rules.language,
                rules.percent_delimits,
            ),
            owords=rules.language and rules.o_words,
            own_lines=OWN_LINES[rules.own_lines]() if rules.own_lines else None,
            realtime=rules.realtime_characters,
            checksums=rules.checksums,
            comments=rules.firmware_comments,
            percent_delimits=rules.percent_delimits,
            line_limit=rules.line_limit,
        )
        runner.errors = errors
        runner.on_return = interp.sub_returned
        interp.in_subprogram = runner.in_subprogram
        if rules.abort_comments:
            runner.on_comment = interp.comment
        yield from runner.run()
        if runner.ended or not rules.require_program_end:
            return
        raise GcodeError(
            "file ended with no program end; finish the program with M2 or M30 (or wrap it "
            "in '%' lines)",
            line=max(len(runner.main.lines), 1),
        )
    except GcodeError as exc:
        if errors is not None and len(errors) < MAX_ERRORS:
            errors.append(exc)
            return
        if rules is not None and rules.error_codes:
            exc.message = coded(exc.message, rules)
        raise exc.located(file) from None
    finally:
        if errors is not None:
            _finish(errors, rules, file)


def _finish(errors: list[GcodeError], rules: Dialect | None, file: str) -> None:
    """Give each collected error its file and the dialect's error number."""
    for exc in errors:
        if rules is not None and rules.error_codes and f"({rules.name} error " not in exc.message:
            exc.message = coded(exc.message, rules)
        exc.located(file)


def parse_program(text: str, dialect: str = "linuxcnc", file: str = "<program>") -> list[Move]:
    """All moves of a valid program, as a list (GcodeError on the first bad line)."""
    return list(interpret(text, dialect=dialect, file=file))


def block_code(block: Block) -> str:
    """The M code a Marlin limits line opens with (``M201``...)."""
    for letter, tree in block.words:
        if letter == "M" and tree[0] == "num":
            return f"M{tree[1]:g}"
    return "M?"
