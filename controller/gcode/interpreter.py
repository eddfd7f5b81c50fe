"""G-code text + dialect -> exact moves (program coordinates, mm, mm/min), one block at a time.

In the style of grbl's gcode.c: each block is (1) read into words, (2) checked for words and
codes, (3) validated against a COPY of the modal state in numbered steps, and only when every
step succeeded is the new state committed and the block's move yielded. The first invalid block
raises :class:`~controller.errors.GcodeError` with its line; moves before it have been yielded.

Execution order inside a block follows rs274 (feed, then plane/units/distance modes, then motion,
then program end), so ``G20 G1 X1`` moves to 1 inch, and ``F10 G20`` keeps 10 mm/min.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.arc_block import arc_move
from gantry_sim.controller.gcode.codes import (
    G_HANDLED,
    G_NO_PATH_EFFECT,
    G_REFUSED,
    M_PROGRAM_END,
    g_name,
)
from gantry_sim.controller.gcode.dialects import Dialect, get_dialect
from gantry_sim.controller.gcode.lexer import Block, lex
from gantry_sim.controller.gcode.state import ModalState
from gantry_sim.controller.gcode.words import check_words, read_words
from gantry_sim.controller.moves import Linear, Move, Plane, Rapid, Vec3

_PLANES: dict[int, Plane] = {170: "XY", 180: "XZ", 190: "YZ"}


class Interpreter:
    """Runs blocks against a modal state for one dialect (see :func:`interpret`)."""

    def __init__(self, dialect: Dialect) -> None:
        self.dialect = dialect
        self.state = ModalState(feed_mm_per_min=dialect.default_feed_mm_per_min or 0.0)
        self.params: dict[int, float] = {}

    def step(self, block: Block) -> tuple[list[Move], bool]:
        """Validate ``block`` on a copy of the state, commit, return (moves, program ended)."""
        self._refresh_system_parameters()
        w = read_words(block, self.params)
        s, d = self.state, self.dialect
        # Step 2: every code is one gantry-sim supports.
        for code in w.g.values():
            if code in G_REFUSED:
                raise GcodeError(f"{g_name(code)} is not supported: {G_REFUSED[code]}")
            assert code in G_HANDLED or code in G_NO_PATH_EFFECT
        # Step 3: feed (in the units in effect BEFORE this block's G20/G21, as rs274 does).
        if "F" in w.values:
            if w.values["F"] < 0.0:
                raise GcodeError("negative F word; the feed must be >= 0 (units per minute)")
            s = replace(s, feed_mm_per_min=w.values["F"] * s.scale)
        # Step 4: plane, units, distance modes.
        if "plane" in w.g:
            s = replace(s, plane=_PLANES[w.g["plane"]])
        if w.g.get("units") == 200 and not d.g20_is_inch:
            raise GcodeError(d.g20_refusal)
        if "units" in w.g:
            s = replace(s, inch=w.g["units"] == 200)
        if "distance" in w.g:
            s = replace(s, incremental=w.g["distance"] == 910)
        if "arc_distance" in w.g:
            s = replace(s, arc_absolute=w.g["arc_distance"] == 901)
        # Step 5: which motion this block makes, if any.
        has_axes = any(a in w.values for a in "XYZ")
        motion = w.g.get("motion")
        if motion == 800:
            if has_axes:
                raise GcodeError("axis words with G80 (motion off); use G0, G1, G2 or G3")
            s, motion = replace(s, motion=None), None
        elif motion is not None:
            s = replace(s, motion=motion)
        elif s.motion in (20, 30) and any(c in w.values for c in "IJKR"):
            motion = s.motion  # rs274: a centre word alone continues a modal G2/G3
        elif has_axes:
            if s.motion is None:
                raise GcodeError("axis words with no motion mode; put G0, G1, G2 or G3 first")
            motion = s.motion
        check_words(w, motion, d)
        if d.r_needs_arc_code_first and w.r_before_arc_code:
            raise GcodeError(
                f"on {d.name} controls R means an arc radius only after G2 or G3 on the same "
                "line (otherwise it is 'Repeat', not supported); write G2 ... R or G3 ... R"
            )
        # Step 6: the move, validated against the new state.
        moves: list[Move] = []
        machine_coords = w.g.get("nonmodal") == 530
        if machine_coords:
            if motion not in (0, 10):
                raise GcodeError("G53 (machine coordinates) must be used with G0 or G1")
            if s.incremental:
                raise GcodeError("G53 cannot be used in incremental distance mode (G91); use G90")
        if motion is not None:
            end = self._end_point(w.values, replace(s, incremental=False) if machine_coords else s)
            if motion == 0:
                moves.append(Rapid(w.line, s.position, end))
            elif motion == 10:
                self._require_feed(s, "a G1 move")
                moves.append(Linear(w.line, s.position, end, s.feed_mm_per_min))
            else:
                self._require_feed(s, "an arc")
                arc = arc_move(w.line, w.values, s, end, motion == 30, d)
                if arc is not None:
                    moves.append(arc)
                    end = arc.end
                else:
                    end = s.position
            s = replace(s, position=end)
        # Step 7: commit.
        self.state = s
        self.params.update(w.settings)
        return moves, w.m.get("stopping") in M_PROGRAM_END

    def _refresh_system_parameters(self) -> None:
        """The read-only parameters rs274 keeps that programs use: #5220 the coordinate system
        (1 = G54, the only one here) and #5420-#5422 the current X Y Z in program units. Every
        other parameter up to #5601 reads 0 until set, as in rs274 without a parameter file."""
        scale = self.state.scale
        x, y, z = self.state.position
        self.params.update({5220: 1.0, 5420: x / scale, 5421: y / scale, 5422: z / scale})

    @staticmethod
    def _end_point(v: dict[str, float], s: ModalState) -> Vec3:
        end = list(s.position)
        for i, letter in enumerate("XYZ"):
            if letter in v:
                value = v[letter] * s.scale
                end[i] = s.position[i] + value if s.incremental else value
        return (end[0], end[1], end[2])

    def _require_feed(self, s: ModalState, what: str) -> None:
        if s.feed_mm_per_min <= 0.0:
            raise GcodeError(
                f"cannot make {what} with zero feed rate; set F (units per minute, > 0) on this "
                "or an earlier line"
            )


def interpret(text: str, dialect: str = "linuxcnc", file: str = "<program>") -> Iterator[Move]:
    """Yield the program's moves in order; GcodeError(file, line) at the first bad line.

    Args:
        text: the program.
        dialect: one of ``gantry_sim.controller.gcode.dialects.DIALECTS``.
        file: the program's name, for error messages.
    """
    try:
        rules = get_dialect(dialect)
        interp = Interpreter(rules)
        percent_open = False
        seen = False
        last = 0
        for block in lex(text):
            last = block.line
            if block.percent:
                if not seen:
                    percent_open = seen = True
                    continue
                if percent_open:
                    return
                raise GcodeError(
                    "'%' ends a program only when the program also starts with a '%' line",
                    line=block.line,
                )
            if block.empty:
                continue
            seen = True
            try:
                moves, ended = interp.step(block)
            except GcodeError as exc:
                if exc.line is None:
                    exc.line = block.line
                raise
            yield from moves
            if ended:
                return
        if rules.require_program_end:
            raise GcodeError(
                "file ended with no program end; finish the program with M2 or M30 (or wrap it "
                "in '%' lines)",
                line=max(last, 1),
            )
    except GcodeError as exc:
        raise exc.located(file) from None


def parse_program(text: str, dialect: str = "linuxcnc", file: str = "<program>") -> list[Move]:
    """All moves of a valid program, as a list (GcodeError on the first bad line)."""
    return list(interpret(text, dialect=dialect, file=file))
