"""Each dialect's documented rules (seeds 000 g2core, 002/003 Marlin, 004 Laserdyne)."""

from __future__ import annotations

import dataclasses
import math

import pytest

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode import lexer
from gantry_sim.controller.gcode.dialects import DIALECTS, MARLIN, get_dialect
from gantry_sim.controller.gcode.interpreter import interpret_events, parse_program
from gantry_sim.controller.moves import Arc, Linear, Rapid


def run(text: str, dialect: str):
    return parse_program(text, dialect=dialect)


def error_of(text: str, dialect: str) -> GcodeError:
    with pytest.raises(GcodeError) as info:
        parse_program(text, dialect=dialect, file="p.ngc")
    return info.value


def test_dialects_are_frozen_data() -> None:
    assert set(DIALECTS) == {"linuxcnc", "g2core", "marlin", "laserdyne", "grbl"}
    with pytest.raises(dataclasses.FrozenInstanceError):
        MARLIN.default_feed_mm_per_min = 1.0  # type: ignore[misc]
    with pytest.raises(
        GcodeError, match="choose one of: linuxcnc, g2core, marlin, laserdyne, grbl"
    ):
        get_dialect("fanuc")


# --- g2core (seed 000) --------------------------------------------------------------------------


def test_g2core_explicit_end_equal_to_start_moves_nothing() -> None:
    moves = run("F10\nG2 X0 Y0 I1\nG2 I1\nG1 X1", "g2core")
    assert [m.line for m in moves] == [3, 4]  # line 2 moved nothing
    assert moves[0].angle == pytest.approx(2 * math.pi)  # offsets only: full circle
    assert moves[1].start == (0.0, 0.0, 0.0)


def test_g2core_radius_mismatch_thresholds() -> None:
    """Seed 000 (the dialect's specification) decides, not the firmware's plan_arc.h
    ARC_RADIUS_ERROR_MAX (1.0 mm)."""
    # Seed 000: more than 0.5 mm, or more than 0.005 mm AND 0.1 % of the radius.
    assert run("F10\nG2 X2.004 I1", "g2core")
    assert error_of("F10\nG2 X2.006 I1", "g2core").line == 2
    assert run("F10\nG2 X2000.4 I1000", "g2core")  # 0.04 %, below 0.5 mm
    assert error_of("F10\nG2 X2000.6 I1000", "g2core").line == 2


def test_g2core_refuses_r_below_its_min_arc_radius() -> None:
    """plan_arc.cpp cm_arc_feed refuses an R below plan_arc.h's MIN_ARC_RADIUS, 0.1 mm (seed
    000 is silent on it)."""
    assert error_of("F10\nG2 X0.1 R0.05", "g2core").line == 2
    assert run("F10\nG2 X0.1 R0.1", "g2core")


def test_g2core_reads_what_its_normalizer_and_canonical_machine_leave() -> None:
    """gcode_parser.cpp's _normalize_gcode_block copies letters, digits, - and . only (a U+2028
    an editor left in bantamtools/omctest's ReorderingWords.nc, a +, a #: dropped); a bare G92
    turns the G92 offsets back on (cm_set_g92_offsets, as G92.3: omctest's G92 tests); a block
    started in G93 takes F 0 unless it has one, so the G94 after G93 leaves no feed."""
    moves = run("G21 G90\nG1 X10 F600\n\u2028G1 X+20 Y#5\n", "g2core")
    assert [m.end for m in moves] == [(10.0, 0.0, 0.0), (20.0, 5.0, 0.0)]
    # _verify_checksum ends the line at its first *, before normalizing (not X5100; and in a
    # comment too, which then runs to the line's end)
    moves = run("G21 F600\nN1 G1 X5*100\nN2 G1 Y2 (a*8) X3\n", "g2core")
    assert [m.end for m in moves] == [(5.0, 0.0, 0.0), (5.0, 2.0, 0.0)]
    moves = run("G21 G90\nG1 X10 F600\nG92 X0\nG92.2\nG92\nG1 X5\n", "g2core")
    assert moves[-1].end == (15.0, 0.0, 0.0)
    assert error_of("G92\nM2\n", "linuxcnc").line == 1
    refused = error_of("G21\nG1 X1 F600\nG93\nG1 X2 F2\nG94\nG1 X3\n", "g2core")
    assert refused.line == 6 and "zero feed" in refused.message


def test_g2core_has_32_tools() -> None:
    """g2core.h TOOLS = 32: cm_select_tool (STAT_T_WORD_IS_INVALID), cm_set_tl_offset
    (STAT_H_WORD_IS_INVALID) and cm_set_g10_data (STAT_P_WORD_IS_INVALID) refuse more;
    synthetos/tg_pytest's g43-tool-offset.json expects status 181 for T33. The linuxcnc
    dialect takes them: with no tool table every tool number is accepted (ToolTable)."""
    for line in ("T33 M6", "G43 H33", "G10 L1 P33 Z1", "G10 L10 P0 Z1"):
        err = error_of(f"G21\n{line}\nG0 X1\n", "g2core")
        assert err.line == 2 and ("tools 0 to 32" in err.message or "1 to 32" in err.message)
        assert run(f"G21\n{line.replace('P0', 'P1')}\nG0 X1\nM2\n", "linuxcnc")
    assert run("G21\nT32 M6\nG43 H32\nG10 L1 P32 Z1\nG0 X1\n", "g2core")


def test_g2core_reads_one_sign_before_a_number() -> None:
    """util.cpp c_atof reads one sign; the next word then starts at the second, which is no
    letter: STAT_INVALID_OR_MALFORMED_COMMAND, and nothing of the line runs. rs274 reads
    X--5 as -(-5) = 5 (checked with rs274 -g, 2026-12-02), which gantry had done for g2core."""
    err = error_of("G21\nG0 X--5\n", "g2core")
    assert err.line == 2 and "one sign" in err.message
    assert run("G21\nG0 X-5 Y+2 (-- a comment --)\n", "g2core")[0].end == (-5.0, 2.0, 0.0)
    assert run("G21\nG0 X--5\nM2\n", "linuxcnc")[0].end == (5.0, 0.0, 0.0)


def test_g2core_reads_an_m_code_by_its_whole_number() -> None:
    """gcode_parser.cpp: ``switch ((uint8_t)value)`` for M words, so M3.5 is M3; M50 reads its
    point (.0 feed, .1 traverse override control, which _execute_gcode_block leaves unrun;
    others STAT_GCODE_COMMAND_UNSUPPORTED). Both had been refused here."""
    assert run("G21\nM3.5 S1000\nM50.1\nG0 X1\n", "g2core")[0].end == (1.0, 0.0, 0.0)
    assert "unsupported M code M50.2" in error_of("G21\nM50.2\nG0 X1\n", "g2core").message
    assert "M3.5" in error_of("G21\nM3.5 S1000\nG0 X1\nM2\n", "linuxcnc").message


def test_g2core_takes_the_last_of_repeated_words() -> None:
    """g2core's parser stores each word as it reads it (gcode_parser.cpp _parse_gcode_block,
    SET_NON_MODAL / SET_MODAL) and checks neither repeats nor modal groups: the last wins.
    (The TinyG test file test_001.gcode has "N82 Y0 Y0".) rs274 and grbl refuse both."""
    text = "G21 G90\nG0 X1 Y5 Y0\nG0 G1 X3 F600 F1200\nM3 M5\nG1 X4"
    moves = run(text, "g2core")
    assert [(type(m), m.end) for m in moves] == [
        (Rapid, (1.0, 0.0, 0.0)),
        (Linear, (3.0, 0.0, 0.0)),
        (Linear, (4.0, 0.0, 0.0)),
    ]
    assert moves[1].feed_mm_per_min == 1200.0
    for dialect in ("linuxcnc", "grbl"):
        assert error_of(text, dialect).line == 2


def test_g2core_needs_feed_and_integer_p() -> None:
    assert "zero feed rate" in error_of("G2 I1", "g2core").message
    assert "integer" in error_of("F1\nG2 I1 P1.5", "g2core").message


# --- Marlin (seeds 002, 003) --------------------------------------------------------------------


def test_marlin_ij_and_r_forms_give_the_same_arc() -> None:
    # Seed 002: starting at [9, 6], "G3 X2 Y7 I-4 J-3" or "G3 X2 Y7 R5".
    (_, ij) = run("G0 X9 Y6\nG3 X2 Y7 I-4 J-3", "marlin")
    (_, r) = run("G0 X9 Y6\nG3 X2 Y7 R5", "marlin")
    for a, b in ((ij.center, r.center), (ij.end, r.end)):
        assert a == pytest.approx(b)
    assert ij.angle == pytest.approx(r.angle) == pytest.approx(math.pi / 2)
    assert ij.feed_mm_per_min == 1500.0  # Marlin's default feedrate, F not required


def test_marlin_does_not_check_the_end_point() -> None:
    # Seed 002: the end point is not error-checked, the arc ends based on the destination's
    # angle, and the move ends at the given XYZ (plan_arc buffers its last segment to the
    # target): the arc turns on the start-radius circle, then a straight move, same line.
    (_, arc, rest) = run("G0 X9 Y6\nG3 X3 Y7 Z-1 I-4 J-3\nG1 Y10", "marlin")[:3]
    c = (5.0, 3.0)
    assert math.hypot(arc.end[0] - c[0], arc.end[1] - c[1]) == pytest.approx(5.0)
    assert math.atan2(arc.end[1] - 3, arc.end[0] - 5) == pytest.approx(math.atan2(4, -2))
    assert arc.end[2] == -1.0  # the helix is done on the circle
    assert isinstance(rest, Linear) and rest.line == arc.line == 2
    assert rest.start == arc.end and rest.end == (3.0, 7.0, -1.0)
    assert run("G0 X9 Y6\nG3 X3 Y7 Z-1 I-4 J-3\nG1 Y10", "marlin")[3].start == (3.0, 7.0, -1.0)
    with pytest.raises(GcodeError):
        run("F1\nG0 X9 Y6\nG3 X3 Y7 I-4 J-3", "linuxcnc")


def test_marlin_ends_a_spiral_at_an_end_point_off_its_circle_by_rounding() -> None:
    # Within 0.005 mm of the start circle (a slicer's rounding) the arc ends at the end point,
    # a spiral within that of Marlin's circle and last segment: no sliver of a straight move.
    (_, arc) = run("G0 X9 Y6\nG3 X2.003 Y7.001 I-4 J-3", "marlin")
    assert arc.end == (2.003, 7.001, 0.0) and arc.radius == pytest.approx(5.0)
    (_, far, rest) = run("G0 X9 Y6\nG3 X2.01 Y7 I-4 J-3", "marlin")
    assert math.hypot(far.end[0] - 5.0, far.end[1] - 3.0) == pytest.approx(5.0)
    assert isinstance(rest, Linear) and rest.end == (2.01, 7.0, 0.0)


def test_marlin_rules() -> None:
    # G2_G3.cpp reads R first: the I of an arc with a radius is ignored
    assert run("G0 X9 Y6\nG3 X2 Y7 R5 I1", "marlin") == run("G0 X9 Y6\nG3 X2 Y7 R5", "marlin")
    (arc,) = run("G2 I20 J20 E3 S100", "marlin")  # seed: complete circle; E and S ignored
    assert arc.angle == pytest.approx(2 * math.pi)
    (extra,) = run("G2 X2 I1 P1", "marlin")  # P adds complete circles
    assert extra.angle == pytest.approx(3 * math.pi) and extra.turns == 2
    assert "P0 to P100" in error_of("G2 X2 I1 P101", "marlin").message
    (short,) = run("G2 X10 R2", "marlin")  # R too short: Marlin takes the half circle
    assert short.center == pytest.approx((5.0, 0.0, 0.0))
    assert "E word" in error_of("G0 X1 E3\nM2", "linuxcnc").message


def test_marlin_reads_nested_and_open_comments_without_error() -> None:
    """Skeinforge writes "(<setting> ... Jump_Space_(mm): 2.0 </setting>)": Marlin skips such
    a line (rs274 refuses it); a comment left open runs to the line's end. Marlin's reader
    (queue.cpp, PAREN_COMMENTS) drops a comment up to its first ``)``, and its parser reads
    what is left: ``c)`` of ``(a (b) c)`` is a valueless C the G1 does not read, and the
    Skeinforge line's rest opens with ``:``, an unknown command."""
    text = (
        "(<setting> comb Running_Jump_Space_(mm): 2.0 </setting>)\n"
        "G1 X1 F600 (a (b) c)\nG1 X2 (open\nG1 X3 (a) Y2 (b) ; done\n"
    )
    assert [m.end for m in run(text, "marlin")] == [(1, 0, 0), (2, 0, 0), (3, 2, 0)]
    assert "nested comment" in error_of(text + "M2", "linuxcnc").message
    assert lexer.firmware_comments("G1 (a (b) c) X1 (d", "marlin") == "G1  c) X1 "
    assert lexer.firmware_comments("G1 X1 ) Y2", "marlin") == "G1 X1  Y2"  # a stray ) skipped
    assert lexer.firmware_comments("G1 X1 (a;b) Y2 ; c", "marlin") == "G1 X1  Y2 "
    assert lexer.firmware_comments("M117 a\\(b\\) (c)", "marlin") == "M117 a(b) "
    # a hostile line of 100,000 valueless letters is read in one pass (each ")" once looked
    # back over the whole line kept so far: minutes for such a line)
    assert lexer.firmware_comments("G1 " + "X)" * 100_000, "marlin") == "G1 " + "X)" * 100_000


def test_marlin_ignores_the_axis_letters_its_default_build_lacks() -> None:
    """MakerBot files write their extruders as A and B: Marlin's G0/G1 read X Y Z E F and its
    parser takes any letter, so the move runs and the letter is ignored (LinuxCNC refuses)."""
    moves = run("G1 X1 F600 A1.5\nG1 X2 B2 C1\nG2 X4 I1 A2\nG1 Y1 U1 V2 W3", "marlin")
    assert [m.end for m in moves] == [(1, 0, 0), (2, 0, 0), (4, 0, 0), (4, 1, 0)]
    assert "A axis word on a 3-axis machine" in error_of("G1 X1 F600 A1.5\nM2", "linuxcnc").message


# --- Laserdyne (seed 004) -----------------------------------------------------------------------


def test_laserdyne_seed_examples() -> None:
    (circle, quarter) = run("F10\nG17 G2 I0 J2\nG17 G2 I0J2 X-2Y2", "laserdyne")
    assert circle.angle == pytest.approx(2 * math.pi) and circle.radius == 2.0
    assert quarter.end == (-2.0, 2.0, 0.0) and quarter.angle == pytest.approx(math.pi / 2)
    assert isinstance(quarter, Arc) and quarter.direction == "cw"


def test_laserdyne_rules() -> None:
    assert "need both I and J" in error_of("F10\nG17 G2 J2", "laserdyne").message
    assert run("F10\nG17 G2 J2\nM2", "linuxcnc")[0].center == (0.0, 2.0, 0.0)
    # End point must lie on the arc: 0.005 mm tolerance (documented choice).
    assert run("F10\nG2 X4.004 I2 J0", "laserdyne")
    assert error_of("F10\nG2 X4.006 I2 J0", "laserdyne").line == 2
    # Seed 004: G2/G3 must be on the line of the R word and before it (else R is "Repeat").
    (r_arc,) = run("F10\nG2 X4 R2", "laserdyne")
    assert r_arc.center == pytest.approx((2.0, 0.0, 0.0))
    assert "Repeat" in error_of("F10\nG2 X4 R2\nX8 R2", "laserdyne").message
    assert "Repeat" in error_of("F10\nR2 G2 X4", "laserdyne").message
    err = error_of("G20\nG1 X1", "laserdyne")
    assert err.line == 1 and "plane rotation" in err.message


def test_only_linuxcnc_requires_a_program_end() -> None:
    for name in ("g2core", "marlin", "laserdyne"):
        assert run("G0 X1", name)[0].end == (1.0, 0.0, 0.0)
        assert run("", name) == []
    assert "M2 or M30" in error_of("G0 X1", "linuxcnc").message


# --- grbl 1.1 (gnea/grbl gcode.c) ---------------------------------------------------------------


def test_grbl_needs_no_program_end_and_reads_system_lines_and_jogs() -> None:
    text = "$H\n$$\n$X\n$110=5000\nG21 G90\nG0 X10 Y10\n$J=G91 X5 F500\nG1 X20 F300\n"
    moves = run(text, "grbl")
    assert [(m.line, m.kind, m.end) for m in moves] == [
        (6, "rapid", (10.0, 10.0, 0.0)),
        (7, "linear", (15.0, 10.0, 0.0)),  # the jog: G91 for itself only
        (8, "linear", (20.0, 10.0, 0.0)),  # back in G90
    ]
    assert moves[1].feed_mm_per_min == 500.0
    assert error_of("$J=X5\n", "grbl").message.endswith("(grbl error 22)")
    # linuxcnc reads $ as the spindle-selection word: $H has no number (rs274: "Unknown word where
    # unary operation could be")
    assert "bad value starting with 'H'" in error_of("$H\n", "linuxcnc").message


# The codes are grbl 1.1h's own answers: gnea/grbl's gcode.c built for the host, each line fed
# to gc_execute_line (session 62's differential run against gantry-sim's grbl dialect).
@pytest.mark.parametrize(
    ("text", "code"),
    [
        ("G0 X#1", 2),  # read_float finds no number after X
        ("G0 X[1+2]", 2),
        ("# laser power 10%", 1),  # a '#' comment (no grbl has them): not a parameter's '='
        ("#1", 1),  # a '#' where a word's letter is expected
        ("G1 X1", 22),
        ("G59.1", 23),  # G59 is grbl's: its decimal part is "not an integer"
        ("G1.5 X1", 23),
        ("G1.05 X1", 23),  # a decimal part no code has: not read as G1
        ("M3.5", 23),
        ("G28.2", 20),  # G28's other decimal parts are unsupported commands
        ("G61.1", 20),
        ("G90.1", 20),
        ("o100 sub", 20),
        ("G0 A1", 20),
        ("M100", 20),
        ("G5 G1 X1", 20),  # the first word decides: G5 is not grbl's
        ("G0 G1 X1", 24),  # two axis commands, before the modal group
        ("G28 G92", 24),
        ("G92 X1 G0 X2", 24),
        ("G0 X1 G80", 21),  # rs274 ignores the G80; grbl's modal group 1 holds both
        ("G0 X1 X2", 25),
        ("G4 P-1", 4),
        ("T-1", 4),
        ("G2 X2 I1 P2 F10", 36),
        ("G2 X10 R5 K1 F10", 36),  # the R format consumes no offset word
        ("G2 X10 R5 I5 F10", 36),
        ("G10 L2 P7 X1", 29),
        ("G10 P1 X1", 20),  # L0: unsupported
        ("G10 X1", 28),  # neither L nor P
        ("G10 L2 P1", 26),  # no axis word to set
        ("G92", 26),
        ("G80\nG28 X1", 31),  # grbl's strict G80: no axis word even for G28, G92, G10, G43.1
        ("T256", 38),
        ("G43.1", 37),  # G43.1 takes Z alone
        ("G43.1 Z1 G0 X1", 24),  # and is an axis command
        ("G0 X1 %", 1),
        ("N-1 G0 X1", 4),
        ("G2 X1 I0 J0 F10", 33),  # a centre on the start: the end's radius is off by 1 mm
        ("G2 X2.1 I1 F10", 33),
        ("G2 X3 R1 F10", 34),
        ("G2 I-1.1 F300", 26),  # grbl traces no full circle from offsets alone (gcode.c)
        ("G2 Z-1 I-1.1 F300", 32),
        ("G18 G2 Y1 I1 F300", 32),  # XZ plane: Y is not its axis
        ("G2 X1 F10", 35),
        ("G80\nX1", 31),  # after G80 grbl has no motion mode for axis words alone
        ("M98 P1", 20),
    ],
)
def test_grbl_refuses_what_grbl_refuses_with_its_error_number(text: str, code: int) -> None:
    err = error_of(text + "\n", "grbl")
    assert err.line == text.count("\n") + 1, err.message
    assert err.message.endswith(f"(grbl error {code})"), err.message
    assert "M48" not in err.message  # an M code's message lists grbl's codes, not LinuxCNC's


def test_grbl_reads_feed_arcs_g53_and_g10_as_grbl_does() -> None:
    """Each against grbl 1.1h's own gcode.c and motion_control.c, built for the host."""
    # F is converted in the units the line selects (rs274: the units before the line)
    assert run("G20 G1 X1 F10\n", "grbl")[0].feed_mm_per_min == 254.0
    assert run("G20\nG21 G1 X1 F10\n", "grbl")[0].feed_mm_per_min == 10.0
    assert run("G20 G1 X1 F10\nM2\n", "linuxcnc")[0].feed_mm_per_min == 10.0
    assert run("$J=G20 X1 F10\n", "grbl")[0].feed_mm_per_min == 254.0
    assert run("G93\n$J=X10 F100\n", "grbl")[0].feed_mm_per_min == 100.0  # a jog is G94
    # mc_arc: a travel within ARC_ANGULAR_TRAVEL_EPSILON (5e-7 rad) of zero is a full circle
    ccw, cw = run("G0 X100\nG3 X100 Y0.00004 I-100 F100\nG2 X100 Y0 I-100\n", "grbl")[1:]
    assert ccw.angle == pytest.approx(2 * math.pi + 4e-7, abs=1e-12)
    assert cw.angle == pytest.approx(2 * math.pi + 4e-7, abs=1e-12)
    far = run("G0 X100\nG3 X100 Y0.0002 I-100 F100\n", "grbl")[1]
    assert far.angle == pytest.approx(2e-6, rel=1e-6)  # beyond it: the short arc
    # the 0.1 % of the radius check is of the start radius (200.2001 against 200: 0.10005 %)
    assert "grbl error 33" in error_of("G0 X400\nG2 X400.2001 I-200 F100\n", "grbl").message
    # G53 takes machine coordinates in G91 too; rs274 refuses it
    assert run("G91\nG53 G0 X1\n", "grbl")[0].end == (1.0, 0.0, 0.0)
    assert "G91" in error_of("G91\nG53 G0 X1\nM2\n", "linuxcnc").message
    # M2/M30: an exact stop, G1 G17 G90 G94 G54 M5 M9, and the stream goes on (gcode.c step 21)
    text = "G55\nG10 L2 P1 X10\nG91 G0 X1 F100\nM30\nX2\nG2 X4 I1\n"
    moves = list(interpret_events(text, dialect="grbl"))
    assert [(m.line, m.kind) for m in moves] == [
        (1, "stop"), (2, "stop"), (3, "rapid"), (4, "stop"), (5, "linear"), (6, "arc")
    ]  # fmt: skip
    assert moves[4].end == (12.0, 0.0, 0.0)  # G90 in G54, whose origin G10 set at X10
    assert moves[4].feed_mm_per_min == 100.0  # F stays
    assert [m.kind for m in run(text, "grbl")] == ["rapid", "linear", "arc"]  # motions alone
    assert len(run("G1 X1 F100\nM2\nX2\nM2\n", "linuxcnc")) == 1  # rs274: M2 ends it
    # protocol.c drops comments, '/', spaces and control characters before gcode.c reads
    ends = [m.end[0] for m in run("G0 X-(c)4\nG0 X/2\nG0 X 1 0\nG0 X\x0c3\n", "grbl")]
    assert ends == [-4.0, 2.0, 10.0, 3.0]
    # a G4's P beside an arc is the dwell's (grbl's arcs take no P; rs274 refuses the line)
    assert [m.kind for m in run("G4 P0.5 G2 X2 I1 F100\n", "grbl")] == ["arc"]
    # G10's P is cut to its whole part, and is the system in effect when absent
    moves = run("G10 L2 P1.5 X5\nG0 X0\nG55\nG10 L2 X7\nG0 X0\n", "grbl")
    assert [m.end for m in moves] == [(5.0, 0.0, 0.0), (7.0, 0.0, 0.0)]


def test_grbl_starts_in_g0_and_takes_realtime_characters_out() -> None:
    # svenhb/GRBL-Plotter's gcode_relative.nc opens "G21 G91 / Z2": grbl's parser state starts
    # zeroed, and motion mode 0 is G0; marcio-pessoa/Escriba's programs carry "?  ; status"
    text = "G21 G91\nZ2\n?  ; View current status\nG0 X-10 Y-10 ~\n\u00b0!X1 F100 G1\n"
    moves = run(text, "grbl")
    assert [(m.line, m.kind, m.end) for m in moves] == [
        (2, "rapid", (0.0, 0.0, 2.0)),
        (4, "rapid", (-10.0, -10.0, 2.0)),
        (5, "linear", (-9.0, -10.0, 2.0)),
    ]
    assert "no motion mode" in error_of("G21 G91\nZ2\nM2\n", "linuxcnc").message  # rs274
    assert "bad character '?'" in error_of("G21\n?\nM2\n", "linuxcnc").message
    # g2core's serial layer takes '!' (a Synthetos feed-hold test ends with it): refused here,
    # naming it (nothing in a program resumes a hold)
    held = error_of("G21\nG1 X1 F100\n!\nM2\n", "g2core")
    assert held.line == 3 and "feedhold" in held.message


def test_marlin_reads_line_numbers_of_any_length() -> None:
    """Marlin's parser skips N and its digits. An N of two digits or more made the line look
    like "N1" and a stray "0" (a line Marlin skips), so numbered lines did not move (found by
    running Marlin bugfix-2.1.x's own parser on the host)."""
    text = "G21 G90\nG1 X1 Y1 F1200\nN10 G1 X2 Y2\nN12345 G1 X3\nN7 G1 X4\nN10 PRINT_START\n"
    moves = run(text, "marlin")
    assert [(m.line, m.end[0]) for m in moves] == [(2, 1.0), (3, 2.0), (4, 3.0), (5, 4.0)]


def test_marlin_cuts_a_line_at_its_checksum() -> None:
    # Marlin's GCodeParser::parse nullifies the '*' of a host's checksum and what follows
    # (N12 G1 X5*97, as OctoPrint and Pronterface send and some saved files keep); a '*' in a
    # comment stays a comment; rs274 and grbl read '*' as a bad character
    text = (
        "G21 G90\nN1 G1 X10 Y5 F1200*89\nN2 G1 X12.5 Y5 *33 ; c*x\nN3 G1 X1 (a*b) Y2*12\n"
        "N4 M117 hi*45\nN5 G1 X3*\nN6 G1 X4 (a;b) *7 Y9\nM2\n"
    )
    plain = "G21 G90\nG1 X10 Y5 F1200\nG1 X12.5 Y5\nG1 X1 Y2\nM117 hi\nG1 X3\nG1 X4\nM2\n"
    assert [(m.line, m.end, m.feed_mm_per_min) for m in run(text, "marlin")] == [
        (m.line, m.end, m.feed_mm_per_min) for m in run(plain, "marlin")
    ] == [(2, (10.0, 5.0, 0.0), 1200.0), (3, (12.5, 5.0, 0.0), 1200.0),
          (4, (1.0, 2.0, 0.0), 1200.0), (6, (3.0, 2.0, 0.0), 1200.0),
          (7, (4.0, 2.0, 0.0), 1200.0)]  # fmt: skip
    for other in ("linuxcnc", "grbl"):
        err = error_of(text, other)
        assert err.line == 2 and "bad character '*'" in err.message


def test_a_full_circle_from_offsets_alone_is_linuxcncs_not_grbls() -> None:
    # rs274 draws it (tests/data/rs274: gen_frame_075, "G17 G2 I2.184 J-0.7"); grbl 1.1 fails
    # the block with error 26 before it reads the offsets
    text = "G21 G90\nG0 X0 Y0\nG2 I-1.1 F300\nM2\n"
    (arc,) = [m for m in parse_program(text) if isinstance(m, Arc)]
    assert arc.turns == 1 and abs(arc.angle) == pytest.approx(2 * math.pi)
    assert error_of(text, "grbl").line == 3


def test_grbl_reads_one_sign_before_a_number() -> None:
    """grbl's read_float takes one + or - and then digits: X+-1 is error 2 (LinuxCNC reads the
    signs as unary operators: -1)."""
    for text in ("G1 X+-1 F100\n", "G1 X-+1 F100\n", "G1 X++1 F100\n"):
        err = error_of(text, "grbl")
        assert err.line == 1 and "(grbl error 2)" in str(err), text
    assert run("G1 X-1 F+100 (a -- b)\n", "grbl")[0].end == (-1.0, 0.0, 0.0)
    assert run("G1 X+-1 F100\nM2\n", "linuxcnc")[0].end == (-1.0, 0.0, 0.0)


def test_grbl_arcs_homing_and_offsets() -> None:
    # a K word on a G17 arc is consumed and ignored; 0.004 mm radius mismatch is within 0.005 mm
    arc = run("G2 X2.004 Y0 I1 K5 F100\n", "grbl")[0]
    assert isinstance(arc, Arc) and arc.end == (2.004, 0.0, 0.0)
    # G28 with axis words: the intermediate point, then the named axes to the stored point
    # (grbl 1.1's gcode.c: "Move only the axes specified in secondary move"); without axis
    # words every axis goes there, with no intermediate move
    moves = run("G0 X5 Y5 Z5\nG28.1\nG0 X1 Y1 Z1\nG28 X2\nG28\nG28 G91 Z0\n", "grbl")
    assert [m.end for m in moves[2:5]] == [(2.0, 1.0, 1.0), (5.0, 1.0, 1.0), (5.0, 5.0, 5.0)]
    assert [m.line for m in moves[2:5]] == [4, 4, 5]
    # Fusion 360's grbl post: `G28 G91 Z0` lifts Z alone to its home
    lift = run("G0 X5 Y5 Z5\nG28.1\nG0 X1 Y1 Z1\nG28 G91 Z0\n", "grbl")
    assert [m.end for m in lift[2:]] == [(1.0, 1.0, 1.0), (1.0, 1.0, 5.0)]
    # g2core sends every axis home after the move through the words' point
    g2 = run("G0 X5 Y5 Z5\nG28.1\nG0 X1 Y1 Z1\nG28 X2\nG28\n", "g2core")
    assert [m.end for m in g2[2:]] == [(2.0, 1.0, 1.0), (5.0, 5.0, 5.0), (5.0, 5.0, 5.0)]
    assert [m.line for m in g2[2:]] == [4, 4, 5]
    assert run("G10 L20 P1 X0\nG0 X1\n", "grbl")[0].end == (1.0, 0.0, 0.0)
    assert get_dialect("grbl").arc_tolerance_mm == 0.002


# --- Marlin printer lines and g2core's own lines -----------------------------------------------


def test_marlin_printer_codes_are_accepted_without_motion() -> None:
    text = (
        "M82\nM104 S200 T0\nM140 S60\nM190 S60\nM109 S200\nM106 S255\nM107\nM84\nM400\n"
        "M117 Layer 1: X10 (text\nM118 E1 done\nM73 P10 R20\nM201 X500 Y500 Z100 E5000\n"
        "M203 X300 Y300\nM204 P500 R1000 T500\nM205 X8 Y8 Z0.4 E5\nT1\nG29\nG10\nG11\n"
        "G4 S1\nG4 P500\nG92 E0\nM9999\nG1 X10 Y10 F1500 E1.2\n"
    )
    moves = run(text, "marlin")
    assert [(m.line, m.end) for m in moves] == [(25, (10.0, 10.0, 0.0))]


def test_marlin_skips_lines_it_does_not_know_and_ignores_m_t_words_after_g() -> None:
    """Marlin answers a line with no command "Unknown command" and goes on, and reads the M and
    T words of a G line as parameters the command ignores (found in real printer files: a stray
    "1", a "% text" banner, Klipper macros, "G90 M107"); a block delete "/", a "#" and a line
    opening with a tab are unknown commands too (its reader skips spaces only), and "Y#1" is a
    Y with no value: no Y move (the host-built oracle buffers these moves, the zero-length one
    too)."""
    text = (
        "G21\n1\n% print start\nPRINT_START BED=60 EXTRUDER=210\nEXCLUDE_OBJECT_DEFINE NAME=a\n"
        "G90 M107\nG1 X5 F600 T1 ; M3 in a comment\n/G1 X7\n#1=2\nG1 Y#1\n\tG1 X9\n"
    )
    moves = run(text, "marlin")
    assert [(m.line, m.end) for m in moves] == [(7, (5.0, 0.0, 0.0)), (10, (5.0, 0.0, 0.0))]
    # the M word is a parameter G1 does not read (M3.5.5 is no F100.5), and a comment's M is
    # the comment's
    moves = run("G21\nG1 X1 F100 M3.5.5\n", "marlin")
    assert [(m.end, m.feed_mm_per_min) for m in moves] == [((1.0, 0.0, 0.0), 100.0)]
    moves = run("G21\nG1 X1 (M3 note) F100 M5\n", "marlin")
    assert [(m.end, m.feed_mm_per_min) for m in moves] == [((1.0, 0.0, 0.0), 100.0)]
    # bare axis words or F before any G0-G3: Marlin's parser has no motion mode to apply
    # (parser.cpp, motion_mode_codenum < 0) and skips the line as an unknown command, F too
    moves = run("G21\nX5 F100\nG1 X1\n", "marlin")
    assert [(m.line, m.end, m.feed_mm_per_min) for m in moves] == [(3, (1.0, 0.0, 0.0), 1500.0)]
    # LinuxCNC keeps refusing these
    assert error_of("G21\nPRINT_START\nM2\n", "linuxcnc").line == 2
    assert error_of("G90 M107\nM2\n", "linuxcnc").line == 1


def test_marlin_skips_unknown_g_codes_and_a_bare_g5() -> None:
    """Marlin's gcode.cpp ends its G switch with ``default: unknown_command_warning()`` and goes
    on (Bambu Studio's G392, G380); its G5 defaults every parameter to zero, so a bare G5 (in
    Cura's Anycubic i3 Mega start code) makes a curve of no length. G codes it knows but that
    move as gantry-sim does not model stay refused."""
    moves = run("G21\nG392 S0\nG380 S2 Z-0.04 F1200\nG5\nG1 X5 F600\n", "marlin")
    assert [(m.line, m.end) for m in moves] == [(5, (5.0, 0.0, 0.0))]
    assert error_of("G21\nG38.2 Z-5 F100\n", "marlin").line == 2
    assert error_of("G21\nG392\nM2\n", "linuxcnc").line == 2


def test_marlin_skips_a_bare_g26_and_refuses_the_mesh_validation_print() -> None:
    """LulzBot's Cura start code opens with "G26 ; clear potential 'probe fail' condition"
    (its Marlin's meaning); Marlin's default configuration has no G26 (G26_MESH_VALIDATION
    off: an unknown command, skipped). With parameters it is the mesh validation print."""
    moves = run(
        "G26                          ; clear potential 'probe fail' condition\nG1 X5 F600\n",
        "marlin",
    )
    assert [(m.line, m.end) for m in moves] == [(2, (5.0, 0.0, 0.0))]
    assert "mesh validation" in error_of("G26 C P5\n", "marlin").message


def test_marlin_g0_is_a_g1_at_the_modal_feed() -> None:
    """Marlin's G0_G1 command: in a printer build G0 moves at the feed rate G1 uses, and an F
    on a G0 line sets it for both (Cura writes its travel as "G0 F9000 X.. Y..")."""
    moves = run("G1 X1 F600\nG0 X10\nG0 X20 F3000\nG1 X30\n", "marlin")
    assert [(type(m), m.feed_mm_per_min) for m in moves] == [
        (Linear, 600.0),
        (Linear, 600.0),
        (Linear, 3000.0),
        (Linear, 3000.0),
    ]
    assert isinstance(run("G0 X10\n", "marlin")[0], Linear)  # Marlin's default 1500 mm/min
    assert isinstance(run("G0 X10\nM2\n", "linuxcnc")[0], Rapid)


#: A program and the feed [mm/min] Marlin gives each of its moves' planner blocks: Marlin
#: bugfix-2.1.x (thinkyhead/Marlin 3639c90e, default configuration, host build whose
#: Planner::buffer_line printed MMS_SCALED(feedrate_mm_s) * 60, in float32), 2026-11-30.
M220_PROGRAM = (
    "G21 G90\nG1 X10 F600\nM220 S50\nG1 X20\nG0 X30\nG2 X40 I5 F1200\nM220 B\n"
    "M220 S200\nG1 X50\nM220 R\nG1 X60\nM220 S75.9\nG1 X90\nG1 X5 F0\nG1 X6 F-5\n"
    "G5 I5 J5 P-5 Q-5 X20 Y10\n"
)
M220_MARLIN_FEEDS = {
    2: 599.999939,
    4: 299.999969,
    5: 299.999969,
    6: 599.999939,
    9: 2399.99976,
    11: 599.999939,
    13: 899.999939,
    14: 899.999939,
    15: 899.999939,
    16: 899.999939,
}


def test_marlin_m220_scales_the_feed_of_every_move_after_it() -> None:
    """M220 S sets the percentage (read as a whole number), B backs up the one in effect, R
    restores it; the F words stay as written (line 6's F1200 at 50 % is 600). An F of 0 or
    less is passed over (line 14, 15), as Marlin reads F only above 0."""
    moves = run(M220_PROGRAM, "marlin")
    got = {m.line: m.feed_mm_per_min for m in moves}
    assert got.keys() == M220_MARLIN_FEEDS.keys()
    for line, feed in M220_MARLIN_FEEDS.items():
        assert got[line] == pytest.approx(feed, rel=1e-6), line
    for bad in ("M220 S0", "M220 S-10", "M220 S40000"):
        assert "feed percentage must be 1 to 32767" in error_of(f"{bad}\nG1 X1\n", "marlin").message
    assert run("M220\nM220 B R\nG1 X1 F600\n", "marlin")[0].feed_mm_per_min == 600.0
    with pytest.raises(GcodeError, match="negative F"):
        run("G1 X1 F-5\nM2\n", "linuxcnc")


def test_grbl_runs_a_g93_arc_at_f_times_its_segments() -> None:
    """grbl 1.1h (gnea/grbl bfb67f0 built for the host, 2026-11-30) cuts `G2 X10 I5` into 55
    segments at $12 = 0.002 mm and plans them at 3 x 55 = 165 mm/min (mc_arc); an arc of no
    segment is one inverse-time line, done in 1/F minutes; LinuxCNC runs F times the length."""
    text = "G21 G90\nG93 G2 X10 I5 F3\nG2 X10.0005 I0.00025 F2\nG3 X20 Z2 I5 F4\n"
    feeds = [m.feed_mm_per_min for m in run(text, "grbl")]
    assert feeds[0] == 165.0 and feeds[2] == 220.0  # the helix: 55 segments too
    assert feeds[1] == pytest.approx(2 * math.pi * 0.00025)
    linuxcnc = run("G21 G90\nG93 G2 X10 I5 F3\nM2\n", "linuxcnc")[0]
    assert linuxcnc.feed_mm_per_min == pytest.approx(3 * 5 * math.pi)


def test_marlin_moves_nothing_for_an_arc_ending_on_its_start_ray() -> None:
    """Marlin's plan_arc returns when ATAN2 of the start and end radius vectors is exactly 0
    (the end straight out from the start, off the circle): nothing moves and the position stays
    (Marlin bugfix-2.1.x built for the host, 2026-11-30: ``G2 X20 Y0 I-10`` from X10 buffers no
    line, and the next move starts at X10; Printrun's arc_test.gcode opens with four such
    helices). An end within 1e-6 mm of the start (NEAR) is a full circle."""
    moves = run("G1 X10 F600\nG2 X20 Y0 I-10 J0\nG91\nG3 X5 I-10\nG1 X5\n", "marlin")
    assert [(m.line, m.start, m.end) for m in moves] == [
        (1, (0.0, 0.0, 0.0), (10.0, 0.0, 0.0)),
        (5, (10.0, 0.0, 0.0), (15.0, 0.0, 0.0)),
    ]
    near = run("G1 X10 F600\nG2 X10.0000004 Y0.0000003 I-10\n", "marlin")[1]
    assert isinstance(near, Arc) and near.angle == 2 * math.pi


@pytest.mark.parametrize(
    "arc", ["G2 X10 Y10", "G2 X10 Y10 R0", "G2 R5", "G2 X1 Y0 R5", "G2 X10 Y10 I0 J0", "G3 X10 I0"]
)
def test_marlin_moves_nothing_for_an_arc_with_no_centre_and_goes_on(arc: str) -> None:
    """G2_G3.cpp plans the arc only ``if (arc_offset)``: with no I/J and no R, an R of 0, both
    offsets 0, or an R arc whose end is its start (no offset is computed for it), Marlin answers
    "G2/G3 bad parameters" and the print goes on from where the tool stands, the line's F kept
    (get_destination_from_command ran first). It had been an error here (exit 2)."""
    moves = run(f"G1 X1 F600\n{arc} F900\nG1 X5\n", "marlin")
    assert [(m.line, m.start, m.end, m.feed_mm_per_min) for m in moves] == [
        (1, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 600.0),
        (3, (1.0, 0.0, 0.0), (5.0, 0.0, 0.0), 900.0),
    ]
    # LinuxCNC has no such leniency: the same arcs are errors there
    assert error_of(f"G1 X1 F600\n{arc}\nM2", "linuxcnc").line == 2


def test_marlin_runs_one_command_a_line() -> None:
    """Marlin reads a line's first command and the rest as its parameters: G20, G21, G90 and
    G91 read none (``G90 X10`` moves nothing, ``G91 G0 Z5`` is a G91 alone, ``G21 G91`` a G21
    alone), and a G word after a motion's G is ignored (``G0 G90 X20`` goes 20 further in G91).
    Marlin bugfix-2.1.x built for the host (2026-11-30) buffers exactly these lines."""
    text = (
        "G21\nG1 X5 F600\nG90 X10\nG91 G0 Z5\nG21 G91\nG1 X1\nG0 G90 X20\nG1 X30 G91\n"
        "G90 (absolute) ; comment\nG1 X0\n"
    )
    assert [(m.line, m.end) for m in run(text, "marlin")] == [
        (2, (5.0, 0.0, 0.0)),
        (6, (6.0, 0.0, 0.0)),
        (7, (26.0, 0.0, 0.0)),
        (8, (56.0, 0.0, 0.0)),
        (10, (0.0, 0.0, 0.0)),
    ]


def test_marlin_runs_nothing_of_a_line_its_first_g_does_not_move() -> None:
    """G17-G19, G54-G59 and G80 read no word either (``G17 G2 X10 I5`` sets the plane and
    moves nothing), and a G code Marlin does not have (LinuxCNC's G40, G43, G52, G64, G81,
    G93, G94...) is an "Unknown command": nothing of its line runs, not even an F; so is a
    "%" line, and a G53 with no command to chain moves nothing either. Marlin
    bugfix-2.1.x built for the host, default configuration and with CNC_WORKSPACE_PLANES
    (2026-11-30), buffers exactly these moves; a Fusion 360 post's ``G17 G2 ... I26.987 F3048``
    (richcreations/Ghettotator) was refused for its I word."""
    lines = [
        "G40", "G43 H1", "G93", "G81 X1 Y1 Z-1 R1 F100", "G7", "G94 G1 X10",
        "G17 G2 X10 Y0 I5", "G54 X10", "G52 X5", "G41 D1", "G18 G1 X7", "G80 G1 X3",
        "G59 X3", "G64 P0.1 G1 X4", "G40 G0 X9 Y9", "G98 X2", "G95 G1 Y3", "%", "G53",
        "G53 X10",
    ]  # fmt: skip
    text = "G21\nG90\nG1 X0 Y0 F1000\n" + "".join(
        f"{line}\nG1 X{k} Y{k % 3}\n" for k, line in enumerate(lines, start=1)
    )
    moves = run(text, "marlin")
    assert [(m.line, m.end) for m in moves] == [(3, (0.0, 0.0, 0.0))] + [
        (3 + 2 * k, (float(k), float(k % 3), 0.0)) for k in range(1, len(lines) + 1)
    ]
    assert {m.feed_mm_per_min for m in moves} == {1000.0}
    assert {m.kind for m in moves} == {"linear"}


def test_marlin_drops_the_subcode_of_a_command_that_reads_none() -> None:
    """Marlin's dispatch reads a G command's number alone (its subcode only for G38 and G59):
    G92.1 X5 is a G92 X5, G91.1 a G91, G90.1 a G90, G1.5 a G1, G61.1 a G61 (nothing saved:
    nothing moves), G28.1 X homes X. Marlin bugfix-2.1.x built for the host (no Z raise after
    homing, 2026-11-30) buffers exactly these moves."""
    text = (
        "G21\nG90\nG1 X10 Y5 F1000\nG92.1 X5\nG1 X6\nG91.1\nG1 X1 Y1\nG90.1\n"
        "G1.5 X3 Y3\nG61.1\nG1 X4\nG28.1 X\nG1 Y7\n"
    )
    assert [(m.line, m.kind, m.end) for m in run(text, "marlin")] == [
        (3, "linear", (10.0, 5.0, 0.0)),
        (5, "linear", (11.0, 5.0, 0.0)),  # X6 after G92 X5 at X10
        (7, "linear", (12.0, 6.0, 0.0)),
        (9, "linear", (8.0, 3.0, 0.0)),
        (11, "linear", (9.0, 3.0, 0.0)),
        (12, "rapid", (0.0, 3.0, 0.0)),
        (13, "linear", (0.0, 7.0, 0.0)),  # homing cleared X's G92 shift
    ]


def test_line_numbers_are_read_as_each_controller_reads_them() -> None:
    """Marlin's GCodeParser::parse skips an N followed by a digit or a sign, then digits and
    spaces (``N-3 G1 X2`` is a G1; ``N5.5 G1 X4`` leaves ``.5 G1 X4``, an unknown command);
    the host-built Marlin (2026-11-30) buffers exactly these moves. g2core's parser reads N as
    a word anywhere, the last one kept (gcode_parser.cpp ``case 'N'``); rs274 takes one only
    where it opens the line (grbl's rule, also anywhere, is in tests/data/grbl/corpus.jsonl:
    the ``lineno_*`` programs)."""
    text = (
        "G21\nG90\nG1 X1 F600\nN-3 G1 X2\nN+4 G1 X3\nN5.5 G1 X4\nN6G1X5\nN7 M117 hi\n"
        "N-8 G92 X0\nG1 X1 N9\nN-\n"
    )
    assert [(m.line, m.end) for m in run(text, "marlin")] == [
        (3, (1.0, 0.0, 0.0)),
        (4, (2.0, 0.0, 0.0)),
        (5, (3.0, 0.0, 0.0)),
        (7, (5.0, 0.0, 0.0)),
        (10, (6.0, 0.0, 0.0)),  # X1 after G92 X0 at X5
    ]
    g2 = "G21 G90 F600\nG1 X1 N5\nN-5 G1 X2\nN5 N6 G1 X3\nN7\n"
    assert [(m.line, m.end) for m in run(g2, "g2core")] == [
        (2, (1.0, 0.0, 0.0)),
        (3, (2.0, 0.0, 0.0)),
        (4, (3.0, 0.0, 0.0)),
    ]
    refused = error_of("G1 X1 F100 N5\nM2\n", "linuxcnc")
    assert refused.line == 1 and "line numbers must open the line" in refused.message
    assert "N must be followed" in error_of("N-3 G1 X1 F100\nM2\n", "linuxcnc").message


def test_marlin_skips_a_command_letter_without_its_number() -> None:
    """GCodeParser::parse takes G, M or T as a command only with a digit after its spaces: a
    slicer script's unfilled ``T[next_extruder]`` (PrusaSlicer's tool-change template), ``T``,
    ``T?``, ``T-1``, ``M[x]``, ``G{x} X9`` are unknown commands and the next lines run; the
    host-built Marlin (2026-11-30) buffers exactly these moves."""
    text = (
        "G21\nG90\nG1 X1 F600\nT[next_extruder]\nG1 X2\nT\nT?\nT-1\nM[x]\nG{x} X9\nG1 X3\n"
        "M 104 S0\nG 1 X4\nT 0\n"
    )
    assert [(m.line, m.end[0]) for m in run(text, "marlin")] == [
        (3, 1.0),
        (5, 2.0),
        (11, 3.0),
        (13, 4.0),
    ]
    # a line that opens with a parameter letter: P, I, S... are unknown commands to Marlin;
    # bare axis, E and F words take the modal motion (GCODE_MOTION_MODES; Marlin's default
    # build answers "Unknown command"), read as its parser reads a value (none in [x])
    bare = "G21\nG90\nG1 X1 F600\nX10 Y5\nE[x]\nP5\nS100\nX[x] Y7\nG1 X2\n"
    assert [(m.line, m.end) for m in run(bare, "marlin")] == [
        (3, (1.0, 0.0, 0.0)),
        (4, (10.0, 5.0, 0.0)),
        (8, (10.0, 7.0, 0.0)),
        (9, (2.0, 7.0, 0.0)),
    ]
    # an N is skipped with the digits right after it: N alone, NX5 and N 5 G1 are unknown
    numbered = "G21\nG90\nG1 X1 F600\nn10 G1 X2\nN\nNX5\nN10 P5\nN 5 G1 X9\nN10 G1 X3\n"
    assert [(m.line, m.end[0]) for m in run(numbered, "marlin")] == [(3, 1.0), (4, 2.0), (9, 3.0)]


def test_o_words_are_linuxcncs_alone() -> None:
    """Marlin's parser takes G, M and T as command letters: an O-word line is an "Unknown
    command" and the lines between them run, the host-built Marlin (2026-11-30) buffering
    exactly these moves; g2core's parser has no case for O (STAT_GCODE_COMMAND_UNSUPPORTED),
    grbl's neither (error 20: tests/data/grbl/corpus.jsonl, the ``oword_*`` programs)."""
    text = (
        "G21\nG90\nG1 X1 F600\nO100 sub\nG1 X2\nO100 endsub\nO1001\no100 call\nG1 X3\n"
        "N5 O7\nO100 if [1]\nG1 X4\n"
    )
    assert [(m.line, m.end[0]) for m in run(text, "marlin")] == [
        (3, 1.0),
        (5, 2.0),
        (9, 3.0),
        (12, 4.0),
    ]
    for dialect, line in (("g2core", 4), ("grbl", 4)):
        refused = error_of(text, dialect)
        assert refused.line == line and "an O word is not supported" in refused.message


def test_marlin_reads_a_motions_parameters_as_its_parser_does() -> None:
    """GCodeParser::parse keeps one value a letter, its last occurrence's, none where that has
    no number (``G00 Z8.0000 F``, Estlcam 11's line, keeps the feed; ``G1 X14 X`` moves no X),
    ends a value where its number ends (``Y1 0`` is Y1), and a command reads only its own
    parameters (I, J, R on a G1, K on an XY arc, S T H D L are ignored; an arc's R wins over
    I and J, and a valueless R leaves them; a G92 left with nothing reports the position).
    The host-built oracle buffers exactly these moves
    (2026-11-30); each line was refused before."""
    text = (
        "G21\nG90\nG00 Z8.0000 F\nG1 X5 F600 F1200\nG1 X6 I2 J3 R4\nG2 X10 Y0 I2 K3\n"
        "G1 X12 Y1 0\nG1 X13 E\nG1 X14 X\nG1 X15 Y2 S100 T1 H3 D2 L1\nG2 X20 Y2 R I2.5 J0\n"
        "G1 X21 F\nG92 S5\n"
    )
    moves = run(text, "marlin")
    assert [(m.line, m.end, m.feed_mm_per_min) for m in moves] == [
        (3, (0.0, 0.0, 8.0), 1500.0),  # Marlin's feed before any F
        (4, (5.0, 0.0, 8.0), 1200.0),
        (5, (6.0, 0.0, 8.0), 1200.0),
        (6, (10.0, 0.0, 8.0), 1200.0),
        (7, (12.0, 1.0, 8.0), 1200.0),
        (8, (13.0, 1.0, 8.0), 1200.0),
        (9, (13.0, 1.0, 8.0), 1200.0),
        (10, (15.0, 2.0, 8.0), 1200.0),
        (11, (20.0, 2.0, 8.0), 1200.0),
        (12, (21.0, 2.0, 8.0), 1200.0),
    ]
    assert moves[3].center == pytest.approx((8.0, 0.0, 8.0))  # I2: K3 ignored
    assert moves[8].center == pytest.approx((17.5, 2.0, 8.0))  # R with no value: I J


def test_marlin_g28_homes_named_axes_and_g92_sets_the_position() -> None:
    moves = run("G1 X3 Y4 Z5 F100\nG28 X\nG28\nG1 X5\nG92 X0\nG1 X1\n", "marlin")
    assert [(m.line, m.kind, m.end) for m in moves] == [
        (1, "linear", (3.0, 4.0, 5.0)),
        (2, "rapid", (0.0, 4.0, 5.0)),
        (3, "rapid", (0.0, 0.0, 0.0)),
        (4, "linear", (5.0, 0.0, 0.0)),
        (6, "linear", (6.0, 0.0, 0.0)),  # G92 X0 at X5: X1 is 6 in the work frame
    ]
    for code in ("G12", "G27", "G60\nG61"):
        assert "not" in error_of(code + "\n", "marlin").message
    # with no position saved (no G60) Marlin's G61 returns at once: a CAM post's "exact path"
    # G61 in a laser file (blackjetrock's front_panel_62mm_name_recess_only.gcode) moves nothing
    moves = run("G21\nG90\nG61\nG1 X10 F600\nG60\nG1 X12\n", "marlin")
    assert [(m.line, m.end) for m in moves] == [(4, (10.0, 0.0, 0.0)), (6, (12.0, 0.0, 0.0))]
    assert error_of("G60\nG1 X10 F600\nG61 X Y\n", "marlin").line == 3


def test_grbl_and_g2core_read_comments_as_their_firmware_does() -> None:
    # grbl's protocol.c and g2core's _normalize_gcode_block skip a "(" comment up to its first
    # ")" or the line's end, a "(" inside it being text; g2core also ends a line at "%" (a "%"
    # line is an empty line) and skips a line opening with "/" (block delete always on); a "%"
    # line is nothing to grbl (error 1 from the firmware, dropped by the senders); rs274
    # refuses an open or nested comment (the TinyG test programs have "(" lines left open)
    text = (
        "%\nG21 G90\n( ASSUMPTIONS\nG1 X1 F100 (open (nested\n/G1 X5\nG1 X2 ; c\n%\n"
        "G1 Y1 (a (b) c)\n"
    )
    lines = text.replace("(a (b) c)", "(a b c)")
    grbl = [(m.line, m.end) for m in run(lines, "grbl")]
    assert grbl == [(4, (1.0, 0.0, 0.0)), (5, (5.0, 0.0, 0.0)), (6, (2.0, 0.0, 0.0)),
                    (8, (2.0, 1.0, 0.0))]  # fmt: skip
    g2core = [(m.line, m.end) for m in run(lines + "G1 X7 % c\n", "g2core")]
    assert g2core == [(4, (1.0, 0.0, 0.0)), (6, (2.0, 0.0, 0.0)), (8, (2.0, 1.0, 0.0)),
                      (9, (7.0, 1.0, 0.0))]  # fmt: skip
    # after its first ")" a comment is over: " c)" is read as words, in both firmwares
    for dialect in ("grbl", "g2core"):
        assert error_of(text, dialect).line == 8
    assert "unclosed comment" in error_of(lines + "M2\n", "linuxcnc").message
    assert "nested comment" in error_of("G1 X1 F1 (a (b)\nM2\n", "linuxcnc").message
    assert "'%'" in error_of("G1 X1 F1\n%\n", "linuxcnc").message
    # grbl's reader takes a "%" among words as any character that is not a letter (error 1),
    # not as a program delimiter misplaced; a "%" alone on a line is nothing
    for text in ("G1 X1 F1 % c\n", "G1 X1 F1\n% note\nM2\n"):
        message = error_of(text, "grbl").message
        assert "bad character '%'" in message and "grbl error 1" in message, message
        assert "opening and closing" not in message
    assert [m.line for m in run("G1 X1 F1\n%\nG1 X2\n", "grbl")] == [1, 3]
    assert "opening and closing" in error_of("%\nG1 X1 F1 % c\n%\n", "linuxcnc").message


def test_g2core_json_lines_and_homing_codes_move_nothing() -> None:
    text = '{"xvm":1000}\n{sr:n}\nG28.2 X0 Y0\nG28.3 X0\nG0 X1\n'
    assert [(m.line, m.end) for m in run(text, "g2core")] == [(5, (1.0, 0.0, 0.0))]
    assert "bad character" in error_of('{"xvm":1000}\n', "linuxcnc").message


def test_marlin_g4_dwells_in_milliseconds_or_seconds() -> None:
    from gantry_sim.controller.gcode.interpreter import interpret_events

    got = list(interpret_events("G1 X1\nG4 P500\nG4 S2\nG4\n", "marlin"))
    assert [(m.kind, getattr(m, "seconds", None)) for m in got] == [
        ("linear", None),
        ("dwell", 0.5),
        ("dwell", 2.0),
        ("dwell", 0.0),
    ]


def test_g2core_runs_the_gcode_of_a_json_gc_line() -> None:
    """g2core runs a JSON line's ``gc`` string as a G-code line (config_app.cpp ``gc``:
    gc_run_gc), in strict or relaxed JSON (a TinyG milling robot's generator writes whole
    programs so); other JSON lines move nothing."""
    text = (
        'G21 G90\n{"gc":"g90g1f100z2"}\n{gc:"g1 x5 y5 f300"}\n{"xvm":1000}\n'
        '{"gc":"g0x+1"}\nG1 X10 F300\n'
    )
    assert [(m.line, m.end) for m in run(text, "g2core")] == [
        (2, (0.0, 0.0, 2.0)),
        (3, (5.0, 5.0, 2.0)),
        (5, (1.0, 5.0, 2.0)),  # its normalizer drops the +, as on any G-code line
        (6, (10.0, 5.0, 2.0)),
    ]


def test_g2core_m100_and_text_mode_lines_move_nothing() -> None:
    text = "$xvm=1000\nM100 ({xvm:1000})\nM100.1 ({zvm:100})\nM101 ({in1:1})\nG0 X1\n"
    assert [(m.line, m.end) for m in run(text, "g2core")] == [(5, (1.0, 0.0, 0.0))]


def test_g2core_single_character_controls_and_status_lines_move_nothing() -> None:
    """g2core's xio splits ``~`` (cycle start) off a line's start and reads the rest as the
    next line; after blanks the control takes the line; ``?``, ``H`` and ``h`` open text-mode
    lines (a status report, help). A feedhold, ``!``, is refused wherever it stands, naming
    why (synthetos/tg_pytest's feedhold-multi-line.nc ends with one)."""
    text = "G21 G90 F600\n~\n?\nH\nh\n~~G1 X5\n  ~G1 X9\nG1 X6\n"
    assert [(m.line, m.end) for m in run(text, "g2core")] == [
        (6, (5.0, 0.0, 0.0)),
        (8, (6.0, 0.0, 0.0)),
    ]
    for held in ("!", "~!G1 X5", "  !"):
        refused = error_of(f"G1 X1 F100\n{held}\nG1 X2\n", "g2core")
        assert refused.line == 2 and "feedhold" in refused.message and "sender" in refused.message
    # not at the start, a ~ is part of the G-code line, whose normalizer drops it
    assert [m.end for m in run("G1 X3 F100 ~\n", "g2core")] == [(3.0, 0.0, 0.0)]
    assert "real-time commands" in error_of("~\nM2\n", "linuxcnc").message


def test_unsupported_codes_say_why() -> None:
    for code, why in (
        ("G33 X1 K1", "simulates no spindle"),
        ("G38.2 Z-1 F10", "probe"),
        ("G7", "diameter"),
    ):
        assert why in error_of(code + "\nM2\n", "linuxcnc").message
    assert run("G8 G0 X1\nM2\n", "linuxcnc")[0].end == (1.0, 0.0, 0.0)


def test_marlin_limit_changes_are_events_from_their_line_on() -> None:
    from gantry_sim.controller.gcode.interpreter import interpret_events

    text = "G1 X1\nM201 X500 Y500 Z100 E5000\nM204 P500 T800\nM205 J0.02\nM203 X\nG1 X2\n"
    got = [m.to_json() for m in interpret_events(text, "marlin")]
    assert [g["kind"] for g in got] == ["linear", "limits", "limits", "limits", "linear"]
    assert got[1] == {
        "line": 2,
        "kind": "limits",
        "code": "M201",
        "values": {"E": 5000.0, "X": 500.0, "Y": 500.0, "Z": 100.0},
    }
    assert got[3]["values"] == {"J": 0.02}
    assert [m.kind for m in run(text, "marlin")] == ["linear", "linear"]  # motions only


# --- a sixth collection of real programs (2026-11-30): what each firmware lets through -------


def test_g2core_runs_blocks_rs274_refuses_as_g2core_runs_them() -> None:
    # synthetos/g2 gcode_circles2.h: G92 takes the axis words, G0 only sets the mode
    moves = run("g21 g90\ng0 x5\ng92 g0 x0 y0 z0\ng1 x10 f100\nm2\n", "g2core")
    assert [(m.line, m.start, m.end) for m in moves[1:]] == [(4, (5.0, 0.0, 0.0), (15.0, 0.0, 0.0))]
    assert "both use the axis words" in error_of("G92 G0 X0\nM2\n", "linuxcnc").message
    # gcode_mudflap.h (SuperCam): axis words before any motion code move nothing
    moves = run("g21 g90 f100\nx10 y5\ng1 x20\nm2\n", "g2core")
    assert [(m.line, m.start, m.end) for m in moves] == [(3, (0.0, 0.0, 0.0), (20.0, 0.0, 0.0))]
    assert "no motion mode" in error_of("G21 F100\nX10\nM2\n", "linuxcnc").message
    assert "no centre" in error_of("G21 F100\nG2 I5\nX5\nM2\n", "linuxcnc").message


def test_g2core_refuses_a_modal_arc_line_without_centre() -> None:
    """cncjs full-circle-without-xyz: ``x5`` after ``g2 i5``. plan_arc.cpp ``cm_arc_feed``'s
    "no G2/G3 word" test reads gp.modals[MODAL_GROUP_G1], which gcode_parser.cpp never clears,
    so the line goes on to the zero-offset test and ``cm_alarm(STAT_ARC_OFFSETS_MISSING_FOR_
    SELECTED_PLANE)`` (h4 reproducer modal_arc_without_centre; the arc harness gives ALARM
    157). A next action on the line (G4) takes the motion's place: no alarm."""
    refused = error_of("g21 g90 f100\ng2 i5\nx5\ng1 y5\n", "g2core")
    assert refused.line == 3 and refused.file == "p.ngc"
    assert "modal G2 with no centre offset (I, J, K) or radius (R)" in refused.message
    assert "alarm" in error_of("G21 F100\nG3 X2 I1\nZ5\n", "g2core").message
    assert [m.line for m in run("G21 F100\nG2 I5\nG4 P1 X5\nF200\n", "g2core")] == [2]


def test_g2core_g28_3_sets_the_origin_where_the_tool_is() -> None:
    # TinyG's own ArcTests: the named axes read the words' values without moving
    moves = run(
        "g21 g90\ng0 x150 y150 z-25\ng28.3 x0 y0 z0\ng0 x10\ng28.3 y7\ng0 y8\nm2\n", "g2core"
    )
    assert [(m.line, m.end) for m in moves] == [
        (2, (150.0, 150.0, -25.0)),
        (4, (160.0, 150.0, -25.0)),
        (6, (160.0, 151.0, -25.0)),
    ]


def test_marlin_waits_for_its_moves_at_m400_and_ignores_g92_of_other_axes() -> None:
    from gantry_sim.controller.gcode.interpreter import interpret_events
    from gantry_sim.controller.moves import Dwell

    text = "G21\nG1 X10 F600\nM400\nG1 X20\nM0\nG1 X30\nM84\nG92 U0\nG1 X40\nM117 hi\n"
    items = list(interpret_events(text, dialect="marlin"))
    assert [(i.line, i.seconds) for i in items if isinstance(i, Dwell)] == [
        (3, 0.0),
        (5, 0.0),
        (7, 0.0),
    ]
    assert [m.end[0] for m in items if isinstance(m, Linear)] == [10.0, 20.0, 30.0, 40.0]


def test_grbl_line_buffer_and_feed_after_inverse_time() -> None:
    # 79 characters kept (spaces and comments are not kept) are read, 80 are error 11
    words = "G1X1.0000000000000000000000000000000000000Y1.000000000000000000000000000000F100"
    assert len(words) == 79
    assert run(words + " (a comment of any length " + "c" * 100 + ")\n", "grbl")
    err = error_of("G1 X0 F100\n" + words + "0\n", "grbl")
    assert err.line == 2 and "(grbl error 11)" in err.message
    # G94 after G93 leaves the feed undefined (error 22 at the next G1 without F); G94 after
    # G94 keeps it, as does G93 from G94 (whose every move has its F)
    assert "(grbl error 22)" in error_of("G1 X1 F100\nG93 G1 X2 F10\nG94\nG1 X3\n", "grbl").message
    assert run("G1 X1 F100\nG94\nG1 X3\n", "grbl")[-1].feed_mm_per_min == 100.0
    assert run("G1 X1 F100\nG93 G1 X2 F10\nG94 G1 X3 F50\n", "grbl")[-1].feed_mm_per_min == 50.0


def test_g2core_program_end_resets_modes_and_reads_on() -> None:
    """g2core's M2/M30 stop nothing: canonical_machine.cpp ``_exec_program_stop_end`` (with
    ``_exec_program_finalize``) suspends the G92 offsets (G92.2), selects $gco (G54), $gpl
    (G17), $gdi (G90), G91.1 and G94 and cancels the motion mode (not G1, "Safer"); the units
    and F stay, and gcode_parser reads the next line (h4 reproducers m2_then_lines,
    m30_g92_suspended)."""
    moves = run("G21 G90\nG1 X5 F100\nM2\nG0 X20\nG1 X30\n", "g2core")
    assert [(m.line, m.end[0]) for m in moves] == [(2, 5.0), (4, 20.0), (5, 30.0)]
    assert moves[-1].feed_mm_per_min == 100.0
    moves = run("G21 G90\nG0 X10\nG92 X0\nM30\nG0 X1\nG92.3\nG0 X2\n", "g2core")
    assert [m.end[0] for m in moves] == [10.0, 1.0, 12.0]  # suspended, then restored
    text = "G20 G91 G55 G18 G90.1 G1 X1 F10\nM2\nX2\nG0 X1 Y1\n"
    moves = run(text, "g2core")
    assert [m.line for m in moves] == [1, 4]  # X2 alone: motion cancelled
    assert moves[-1].end == pytest.approx((25.4, 25.4, 0.0))  # G90 G54, still inches
    events = list(interpret_events("G1 X1 F10\nM30\nG1 X2\n", "g2core"))
    assert [type(e).__name__ for e in events] == ["Linear", "Stop", "Linear"]


def test_g2core_next_action_codes_take_the_place_of_the_motion() -> None:
    """gcode_parser.cpp ``_execute_gcode_block`` runs G0-G3 (and stores their motion mode,
    through cm_straight_traverse / cm_straight_feed / cm_arc_feed) only in ``case
    NEXT_ACTION_DEFAULT``: G4, G10, G28.x, G30.x, G43, G43.2, G49 and G92.x on a line leave no
    motion and the mode before it (h4 reproducers g43_with_axis_words, g4_with_axis_words,
    g28_1_with_axis_words, g92_1_with_axis_words, g49_with_g0_leaves_mode,
    g92_with_g0_keeps_mode, g10_with_g0_keeps_mode)."""
    tools = "G21 G90\nG0 G43 Z15 H1\nG0 X10\n"
    assert [m.end for m in run(tools, "g2core")] == [(10.0, 0.0, 0.0)]  # Z not lifted
    moves = run("G21 G90\nG1 X1 F100\nG4 P0.5 X10\nG28.1 X3\nG92.1 X7\n", "g2core")
    assert [m.line for m in moves] == [2]
    moves = run("G21 G90\nG1 X5 F100\nG92 G0 X0 Y0\nX3\n", "g2core")
    assert isinstance(moves[-1], Linear) and moves[-1].end == (8.0, 0.0, 0.0)
    assert [m.line for m in run("G21 G90\nG0 G49\nX10\nG0 G10 L2 P1 X5\nX1\n", "g2core")] == []
    # G28 still makes its own moves
    assert [m.line for m in run("G21 G90\nG0 X5\nG1 G28 X1 F100\n", "g2core")] == [2, 3, 3]


def test_g2core_checks_checksums() -> None:
    """gcode_parser.cpp ``_verify_checksum``, run on the raw line (its leading blanks gone:
    controller.cpp) before anything else: a ``*`` anywhere, a comment's too, starts a checksum,
    the XOR of the characters before it, which must match (STAT_CHECKSUM_MATCH_FAILED) on a
    line opening with N (STAT_MISSING_LINE_NUMBER_WITH_CHECKSUM), numbered one more than the
    last such line (canonical_machine.cpp cm_check_linenum, from _execute_gcode_block). h4
    reproducers
    checksum_wrong, checksum_in_comment, checksum_without_n; g2core's own
    gcode_debug_tests.h ``(***HT!***)`` lines fail it too."""
    moves = run("G21 G90 F100\n  N1 G1 X5*100\nG1 Y1\nN2 G1 Y2 (a*8)\n", "g2core")
    assert [m.end for m in moves] == [(5.0, 0.0, 0.0), (5.0, 1.0, 0.0), (5.0, 2.0, 0.0)]
    wrong = error_of("G21 G90 F100\nN1 G1 X5*97\n", "g2core")
    assert wrong.line == 2 and "XOR to 100, the number after it is 97" in wrong.message
    # cm_check_linenum: each checksummed N one more than the last one's, N1 first
    assert "N1 here" in error_of("G21 G90 F100\nN12 G1 X5 Y2*29\n", "g2core").message
    assert error_of("F100\nN1 G1 X5*100\nN1 G1 X5*100\n", "g2core").line == 3
    assert "STAT_CHECKSUM_MATCH_FAILED" in error_of("G1 X5 (a*b) Y2 F1\n", "g2core").message
    no_n = error_of("G21 F100\nG1 X5 Y2*112\n", "g2core")
    assert no_n.line == 2 and "does not open with an N" in no_n.message
    assert run("{sr:n}*\n$x*\n", "g2core") == []  # not G-code lines


@pytest.mark.parametrize(
    ("line", "says"),
    [
        ("G52 X10", "G52 is not supported: g2core has no G52"),
        ("G43.1 Z5", "g2core has no G43.1"),
        ("G95 G1 X10 F0.1", "g2core has no G95"),
        ("G96 S50", "g2core has no G96"),
        ("G97 S1000 M3", "g2core has no G97"),
        ("G98", "g2core has no G98"),
        ("G99", "g2core has no G99"),
        ("G10 L11 P1 Z5", "g2core has no G10 L11"),
        ("G10 L2 P0 X5", "g2core has no P0"),
        ("G10 L20 P7 X5", "g2core has no P7"),
        ("G10 L2 P9 X5", "g2core has no P9"),
        ("M19 R0", "g2core has no M19"),
        ("M52 P1", "g2core has no M52"),
        ("M53 P1", "g2core has no M53"),
        ("M61 Q1", "g2core has no M61"),
        ("M62 P1", "g2core has no M62"),
        ("M66 P1 L0", "g2core has no M66"),
        ("M68 E0 Q1", "g2core has no M68"),
        ("M70", "g2core has no M70"),
        ("M73", "g2core has no M73"),
        ("M98 P100", "g2core has no M98"),
        ("M99", "g2core has no M99"),
    ],
)
def test_g2core_refuses_the_codes_it_lacks(line: str, says: str) -> None:
    """gcode_parser.cpp ``_parse_gcode_block``'s switches have no case for these codes
    (STAT_GCODE_COMMAND_UNSUPPORTED / STAT_MCODE_COMMAND_UNSUPPORTED; G95 is commented out),
    and canonical_machine.cpp ``cm_set_g10_data`` refuses L11 ("not supported atm") and an
    L2/L20 P below G54 or above its 6 systems (STAT_P_WORD_IS_INVALID). h4 reproducers g95,
    g96_g97, g98_g99, g52, g43_1, m19, m62_m68, m52_m53, m98_subprogram, m99_in_main,
    g10_l11, g10_p0, g10_p7."""
    refused = error_of(f"G21 G90 F100\nM3 S1000\n{line}\nG0 X2\n", "g2core")
    assert refused.line == 3 and says in refused.message
    if not line.startswith(("M98", "M99")):  # (LinuxCNC: a call, a return)
        assert run(f"G21 G90 F100\nM3 S1000\n{line}\nG0 X2\nM2\n", "linuxcnc")


def test_g2core_g93_block_without_f_keeps_the_last_inverse_time() -> None:
    """gcode_parser.cpp gives every block started in G93 ``F_word = 0`` unless it has an F;
    canonical_machine.cpp ``cm_set_feed_rate`` returns STAT_FEEDRATE_NOT_SPECIFIED for it in
    G93 *before* changing the feed, and EXEC_FUNC only stores that status, which the move's
    replaces: a G1 without F runs with the last G93 F (TinyG's test_009_inverse_time.h relies
    on it). A G93 move with no G93 F before it (g2core: the old mm/min number read as minutes)
    stays refused, and G94 after G93 leaves no feed."""
    moves = run("G21 G90\nG1 X10 F100\nG93\nG1 X11 F2\nG1 X12\nG0 X0\nG1 X1\n", "g2core")
    assert [(m.line, m.feed_mm_per_min if isinstance(m, Linear) else None) for m in moves] == [
        (2, 100.0),
        (4, 2.0),
        (5, 2.0),
        (6, None),
        (7, 2.0),
    ]
    assert error_of("G21\nG1 X1 F100\nG93 G1 X10\n", "g2core").line == 3
    assert error_of("G21\nG93 G1 X1 F2\nG94\nG1 X3\n", "g2core").line == 4
    assert error_of("G21\nG93 G1 X1 F2\nG1 X3\nM2\n", "linuxcnc").line == 3


def test_g2core_r_wins_over_offsets() -> None:
    """plan_arc.cpp ``cm_arc_feed`` reads I/J/K only when no R is given (``if (!radius_f)``),
    and the R arc's centre comes from ``_compute_arc_offsets_from_radius``: R with I/J is an
    R arc (h4 reproducer arc_r_with_i; the arc harness gives the same arc for both)."""
    arc = run("G21 G90 G17 F300\nG0 X10 Y0\nG2 X20 Y0 R6 I5\n", "g2core")[-1]
    assert arc.center == pytest.approx((15.0, -math.sqrt(11.0), 0.0))
    assert "R mixed" in error_of("G21 F300\nG0 X10\nG2 X20 R6 I5\nM2\n", "linuxcnc").message


def test_g2core_short_r_is_a_half_circle_within_the_radius_tolerance() -> None:
    """plan_arc.cpp ``_compute_arc_offsets_from_radius``: a negative discriminant (R shorter
    than half the chord) puts the centre at the chord's middle, and ``_compute_arc``'s radius
    check then decides (h4 reproducer arc_r_short: R99.95 for a 200 mm chord runs, the arc
    harness refuses R99.85), here with seed 000's tolerance."""
    arc = run("G21 G90 G17 F300\nG2 X200 Y0 R99.95\n", "g2core")[0]
    assert arc.angle == pytest.approx(math.pi)
    # the centre R from the start along the chord, the last segment on that circle (the arc
    # harness: centre 99.95, last segment at 199.9)
    assert arc.center == pytest.approx((99.95, 0.0, 0.0))
    assert arc.end == pytest.approx((199.9, 0.0, 0.0))
    refused = error_of("G21 G90 G17 F300\nG2 X200 Y0 R99.85\n", "g2core")
    assert refused.line == 2 and "too small to reach" in refused.message
    assert "too small" in error_of("G21 F300\nG2 X200 Y0 R99.95\nM2\n", "linuxcnc").message


def test_g2core_reads_a_subcode_it_does_not_check_as_the_whole_code() -> None:
    """gcode_parser.cpp ``_parse_gcode_block`` switches on ``(uint8_t)value`` and asks
    ``_point(value)`` only for G28, G30, G38, G43, G61, G90, G91 and G92: G1.5 is G1, G17.1
    G17, G59.1 G59 (h4 reproducers g1_5, g17_1, g59_1; the lexical oracle gives G1.5 as
    "uint8 1, point 5")."""
    text = "G21 G90\nG10 L2 P6 X20\nG1.5 X10 F100\nG17.1 G59.1\nG0 X10\n"
    moves = run(text, "g2core")
    assert [(type(m), m.end) for m in moves] == [
        (Linear, (10.0, 0.0, 0.0)),
        (Rapid, (30.0, 0.0, 0.0)),  # G59's X20
    ]
    assert "unknown G code G61.2" in error_of("G61.2\n", "g2core").message
    assert "G43.1" in error_of("G43.1 Z1\n", "g2core").message


def test_g2core_g10_ignores_r_and_leaves_g92_out_of_l20() -> None:
    """canonical_machine.cpp ``cm_set_g10_data``: L2 sets only the axes' offsets (R is read
    as an arc radius and not used: no rotation), and L20's offset is the machine position less
    the value and the tool offset, G92 left out ("Should L20 take into account G92
    offsets?"). h4 reproducers g10_r, g10_l20_with_g92."""
    assert run("G21 G90\nG10 L2 P1 R90\nG0 X10\n", "g2core")[0].end == (10.0, 0.0, 0.0)
    text = "G21 G90\nG0 X10\nG92 X0\nG10 L20 P1 X0\nG0 X0\n"
    assert run(text, "g2core")[-1].end == (20.0, 0.0, 0.0)  # G54 10, G92 still 10
    assert run(text + "M2\n", "linuxcnc")[-1].end == (10.0, 0.0, 0.0)


def test_g2core_motion_mode_after_g28_homing_and_a_bare_g2() -> None:
    """G28/G30 go through canonical_machine.cpp ``cm_straight_traverse`` (from
    ``_goto_stored_position``), which stores G0 as the motion mode; homing ends with it
    cancelled (cycle_homing.cpp ``_homing_finalize_exit``); a G2/G3 with no axis, offset, R or
    P word returns from plan_arc.cpp ``cm_arc_feed`` before it stores the mode (h4 reproducers
    g28_leaves_g0_mode, g28_2_cancels_mode, g2_without_words)."""
    moves = run("G21 G90\nG1 X5 F100\nG28\nX3\n", "g2core")
    assert isinstance(moves[-1], Rapid) and moves[-1].end == (3.0, 0.0, 0.0)
    assert [m.line for m in run("G21 G90\nG1 X5 F100\nG28.2 X0\nX10\n", "g2core")] == [2]
    moves = run("G21 G90\nG1 X5 F100\nG2\nG3 F50\nX10\n", "g2core")
    assert isinstance(moves[-1], Linear) and moves[-1].feed_mm_per_min == 50.0


def test_g2core_ignores_words_no_code_on_the_line_uses() -> None:
    """gcode_parser.cpp ``_parse_gcode_block`` stores I, J, K, R, P, L, H in ``gv`` and only
    the codes that need them read them (h4 reproducers unused_i_on_g1, unused_p_on_g0); a
    letter it does not know (Q, D, E) stays an error."""
    moves = run("G21 G90\nG1 X10 I5 F100\nG0 X12 P5 L2 H1 R3\n", "g2core")
    assert [m.end for m in moves] == [(10.0, 0.0, 0.0), (12.0, 0.0, 0.0)]
    assert "Q word" in error_of("G21\nG0 X1 Q5\n", "g2core").message
    assert "I word" in error_of("G21\nG1 X10 I5 F100\nM2\n", "linuxcnc").message


def test_g2core_drops_a_stray_paren_and_deletes_a_block_after_blanks() -> None:
    """gcode_parser.cpp ``_normalize_gcode_block`` keeps letters, digits, - and . only, so a
    ``)`` left after a comment is dropped (h4 reproducers paren_after_comment,
    msg_comment_with_paren; the lexical oracle reads ``G0X1Y5Y2`` as G0 X1 Y2); controller.cpp
    ``_dispatch_kernel`` strips a line's leading blanks before ``gcode_parser`` tests its first
    character for ``/`` (block_delete_after_blanks)."""
    text = "G21 G90\nG0 X1 (a (b) Y5) Y2\n(msg hello (x) G0 X5)\n   /G0 X9\n\t/G0 Y9\n"
    assert [m.end for m in run(text, "g2core")] == [(1.0, 2.0, 0.0), (5.0, 2.0, 0.0)]


def test_g2core_g0_or_g1_without_axis_words_moves_nothing() -> None:
    """canonical_machine.cpp ``cm_straight_traverse`` / ``cm_straight_feed``: "it's legal for
    a G0 to have no axis words but we don't want to process it": the motion mode is set, no
    move is planned (G1 refuses a zero feed first). h4 reproducer g0_without_axes."""
    moves = run("G21 G90\nG0 X5\nG0\nG1 F100\nX6\n", "g2core")
    assert [(m.line, type(m)) for m in moves] == [(2, Rapid), (5, Linear)]
    assert error_of("G21 G90\nG1\n", "g2core").line == 2  # no feed yet


def test_g2core_reads_a_long_line_up_to_511_characters() -> None:
    """xio.cpp ``_scanBuffer``/``readline`` (RX_BUFFER_SIZE 512) pass on a line's first 511
    characters and skip the rest of it (h4 reproducer long_line: the Z5 after a 500-character
    comment is lost, the comment left open)."""
    line = "G0 X1 Y2 (" + "c" * 500 + ") Z5"
    assert run(f"G21 G90\n{line}\n", "g2core")[0].end == (1.0, 2.0, 0.0)
    assert run(f"G21 G90\n{line[:511]}Z7\n", "g2core")[0].end == (1.0, 2.0, 0.0)
    short = "G0 X1 Y2 (" + "c" * 400 + ") Z5"
    assert run(f"G21 G90\n{short}\n", "g2core")[0].end == (1.0, 2.0, 5.0)


def test_g2core_runs_a_line_that_is_one_active_json_comment() -> None:
    """gcode_parser.cpp: ``_normalize_gcode_block`` keeps a comment opening ``({`` as the
    active comment, and ``gcode_parser`` hands it to json_parser when the block has no G-code
    besides it, so ``({gc:"g0x10"})`` moves (h4 reproducer active_comment_gc; the parser
    harness shows ``json_parser({gc:"g0x10"})``); other active JSON sets nothing modelled."""
    text = 'G21 G90\n({gc:"g0x10"})\n  ({xvm:1000})\n(a comment)\n'
    assert [m.end for m in run(text, "g2core")] == [(10.0, 0.0, 0.0)]


def test_g2core_g53_is_an_absolute_override_for_any_move() -> None:
    """canonical_machine.cpp: under G53 ``cm_get_combined_offset`` is 0 and
    ``cm_set_model_target`` still adds G91 words to the position, so G53 in G91 is an
    increment, and an arc (``cm_arc_feed`` takes the same target) ends in machine coordinates
    (h4 reproducers g53_in_g91, g53_with_arc)."""
    moves = run("G21 G91\nG10 L2 P1 X100\nG0 X10\nG53 G0 X5\n", "g2core")
    assert [m.end for m in moves] == [(10.0, 0.0, 0.0), (15.0, 0.0, 0.0)]
    arc = run("G21 G90\nG10 L2 P1 X100\nG0 X10\nG53 G2 X120 Y0 I5 F100\n", "g2core")[-1]
    assert isinstance(arc, Arc) and arc.end == (120.0, 0.0, 0.0)
    assert "G53" in error_of("G21 G91\nG53 G0 X5\nM2\n", "linuxcnc").message


def test_g2core_reads_a_sign_or_point_without_digits_as_zero() -> None:
    """gcode_parser.cpp ``_get_next_gcode_word`` reads a value with util.h ``c_atof``, which
    consumes a ``-`` or ``.`` with no digits and gives 0 (h4 reproducer sign_without_digits;
    the lexical oracle shows ``word X -0``): ``X-`` and ``X.`` are X0."""
    text = "G21 G90\nG0 X5 Y5\nG0 X- Y1\nG0 X. Y - \nG0 X-.5 Y.5\n"
    assert [m.end for m in run(text, "g2core")][1:] == [
        (0.0, 1.0, 0.0),
        (0.0, 0.0, 0.0),
        (-0.5, 0.5, 0.0),
    ]
    assert "bad value" in error_of("G0 X- Y1\nM2\n", "linuxcnc").message


def test_g2core_g80_on_a_motion_line_is_the_last_motion_code() -> None:
    """gcode_parser.cpp sets G0-G3 and G80 in one ``motion_mode`` (SET_MODAL, the last one
    read wins) and the NEXT_ACTION_DEFAULT case stores MOTION_MODE_CANCEL_MOTION_MODE for G80
    with no move, axis words or not (h4 reproducer g80_after_g1_on_line: both harnesses show
    no canonical call for ``G1 X5 G80`` nor for the ``X10`` after it)."""
    assert run("G21 G90 F100\nG1 X5 G80\nX10\nG80 X3\n", "g2core") == []
    moves = run("G21 G90 F100\nG80 G1 X5\nX6\n", "g2core")
    assert [m.end[0] for m in moves] == [5.0, 6.0]


def test_g2core_runs_the_gc_pair_of_a_json_line_with_other_pairs() -> None:
    """json_parser.cpp ``_json_parser_execute`` runs a line's pairs in order, and its ``gc``
    pair runs the G-code (config_app.cpp gc_run_gc) whatever pairs stand beside it (h4
    reproducer json_two_keys); the other pairs set nothing modelled."""
    text = 'G21\n{"gc":"g0x10","sr":null}\n{"sr":null,"gc":"g0y3","xvm":1000}\n{"sr":{"posx":1}}\n'
    assert [m.end for m in run(text, "g2core")] == [(10.0, 0.0, 0.0), (10.0, 3.0, 0.0)]


def test_g2core_runs_m50_1_as_it_does_and_says_what_it_lacks() -> None:
    """gcode_parser.cpp ``_parse_gcode_block`` has M50.1 (``case 50``, ``_point`` 1: the
    traverse override switch, its execution commented out): accepted and nothing done, as
    g2core does (it had been refused here, h4 reproducer m50_1); M19 it lacks."""
    assert run("G21\nM50.1 P1\nG0 X1\n", "g2core")[0].end == (1.0, 0.0, 0.0)
    assert "g2core has no M19" in error_of("M19\n", "g2core").message


def test_g2core_arc_ends_on_its_start_circle_and_the_next_move_takes_up_the_rest() -> None:
    """plan_arc.cpp ``cm_arc_callback`` puts every segment's end on the start radius, the last
    at the end's angle, while the model takes the programmed end; the planner's next move
    starts where the last segment ended (plan_line.cpp ``mp_aline``). h4 reproducer
    arc_end_off_circle: the arc harness's last segment is at X10.0000, the G1 goes to X10.0049
    Y5."""
    moves = run("G21 G90 G17 F300\nG2 X10.0049 Y0 I5\nG1 Y5\n", "g2core")
    assert moves[0].end == pytest.approx((10.0, 0.0, 0.0))
    assert moves[1].start == moves[0].end and moves[1].end == pytest.approx((10.0049, 5.0, 0.0))
    moves = run("G21 G91 G17 F300\nG2 X10.0049 Y0 I5\nG1 Y5\n", "g2core")
    assert moves[1].end == pytest.approx((10.0049, 5.0, 0.0))  # from the programmed end
