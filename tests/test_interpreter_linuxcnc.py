"""The linuxcnc dialect: seed examples, modal behaviour, arcs, units and every error path.

Expected behaviours marked "rs274" were measured with ``rs274 -g`` (LinuxCNC 2.9.0~pre1,
Debian linuxcnc-uspace) on the same program text.
"""

from __future__ import annotations

import math

import pytest

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.interpreter import interpret, parse_program
from gantry_sim.controller.moves import Arc, Linear, Rapid


def run(text: str, dialect: str = "linuxcnc"):
    return parse_program(text + "\nM2\n", dialect=dialect)


def error_of(text: str, dialect: str = "linuxcnc") -> GcodeError:
    with pytest.raises(GcodeError) as info:
        parse_program(text + "\nM2\n", dialect=dialect, file="p.ngc")
    assert info.value.file == "p.ngc"
    return info.value


# --- seed 001 examples --------------------------------------------------------------------------


def test_seed_quarter_arc_cw() -> None:
    rapid, arc = run("G0 X0 Y0\nG2 X1 Y1 I1 F10")
    assert isinstance(rapid, Rapid) and isinstance(arc, Arc)
    assert arc.center == (1.0, 0.0, 0.0) and arc.radius == 1.0
    assert arc.direction == "cw" and arc.plane == "XY" and arc.turns == 1
    assert arc.angle == pytest.approx(math.pi / 2)
    assert arc.end == (1.0, 1.0, 0.0) and arc.feed_mm_per_min == 10.0


def test_seed_helix_example_is_rejected_like_rs274() -> None:
    # rs274: "Radius to end of arc differs from radius to start ... r1=5.0000 r2=13.8924".
    err = error_of("G0 X0 Y0 Z0\nF100\nG17 G2 X10 Y16 I3 J4 Z-1")
    assert err.line == 3
    assert "13.8924" in err.message and "5.0000" in err.message


def test_seed_p2_helix() -> None:
    _, arc = run("G0 X0 Y0 Z0\nG2 X0 Y1 Z-1 I1 J0.5 P2 F25")
    assert arc.turns == 2 and arc.end == (0.0, 1.0, -1.0) and arc.center == (1.0, 0.5, 0.0)
    r = math.hypot(1.0, 0.5)
    # start angle atan2(-0.5,-1), end angle atan2(0.5,-1); cw partial = their difference.
    partial = math.atan2(-0.5, -1.0) - math.atan2(0.5, -1.0) + 2 * math.pi
    assert arc.radius == pytest.approx(r)
    assert arc.angle == pytest.approx(partial + 2 * math.pi)


# --- full circles, P, helices, planes -----------------------------------------------------------


@pytest.mark.parametrize("text", ["F10\nG2 I1", "F10\nG2 X0 Y0 I1", "F10\nG2 X0 I1 J0"])
def test_full_circle_with_or_without_end_point(text: str) -> None:
    (arc,) = run(text)
    assert arc.angle == pytest.approx(2 * math.pi) and arc.end == arc.start


def test_p_on_half_circle_is_three_pi_and_one_move() -> None:
    (arc,) = run("F10\nG3 X2 I1 P2")
    assert arc.angle == pytest.approx(3 * math.pi) and arc.direction == "ccw"
    (big,) = run("F10\nG3 I1 P1000000")
    assert big.turns == 1_000_000 and big.angle == pytest.approx(2e6 * math.pi)


def test_p_integer_tolerance_matches_rs274() -> None:
    assert run("F10\nG2 X2 I1 P2.0009")[0].turns == 2  # rs274 accepts
    assert error_of("F10\nG2 X2 I1 P2.0011").line == 2  # rs274: P value not an integer
    assert "integer" in error_of("F10\nG2 X2 I1 P1.5").message
    assert "1 or greater" in error_of("F10\nG2 X2 I1 P0").message


def test_xz_and_yz_planes_use_right_handed_axes() -> None:
    # rs274: G18 G2 X2 I1 -> ARC_FEED(first=Z 0, second=X 2, centre Z0 X1, -1)
    (xz,) = run("G18 F1\nG2 X2 I1")
    assert xz.plane == "XZ" and xz.center == (1.0, 0.0, 0.0) and xz.end == (2.0, 0.0, 0.0)
    assert xz.angle == pytest.approx(math.pi)
    (yz,) = run("G19 F1\nG3 Y2 Z0 J1 X5")
    assert yz.plane == "YZ" and yz.center == (0.0, 1.0, 0.0) and yz.end == (5.0, 2.0, 0.0)


def test_helix_centre_keeps_start_normal_coordinate() -> None:
    _, arc = run("G0 X10 Z2\nG2 X0 Y0 I-5 J0 Z3 F100")
    assert arc.center == (5.0, 0.0, 2.0) and arc.end[2] == 3.0


# --- modes --------------------------------------------------------------------------------------


def test_motion_is_modal_and_feed_is_modal() -> None:
    moves = run("G1 X1 F100\nY2\nG0 Z1\nX3")
    assert [type(m) for m in moves] == [Linear, Linear, Rapid, Rapid]
    assert moves[1].end == (1.0, 2.0, 0.0) and moves[1].feed_mm_per_min == 100.0


def test_g80_beside_another_motion_code_is_ignored_like_rs274() -> None:
    # rs274: "G0 X1 G80" traverses to X1; "G2 X3 I1 G80" is an arc and G2 stays modal.
    moves = run("G0 X1 G80\nG80 G1 X2 F1\nG2 X4 I1 G80\nX6 I1")
    assert [m.kind for m in moves] == ["rapid", "linear", "arc", "arc"]
    assert moves[3].end == (6.0, 0.0, 0.0)


def test_centre_word_alone_continues_a_modal_arc_like_rs274() -> None:
    # rs274: "G2 X10 I5" then "J1" alone is a full circle about (10, 1); "P2" alone is an error.
    moves = run("F10\nG2 X10 I5\nJ1")
    assert moves[1].center == (10.0, 1.0, 0.0) and moves[1].angle == pytest.approx(2 * math.pi)
    assert error_of("F10\nG2 X10 I5\nP2").line == 3
    assert error_of("F10\nG1 X10\nI1").line == 3


def test_tiny_arc_of_huge_radius_is_not_a_full_circle() -> None:
    (arc,) = run("F500\nG2 X0.01 R10000")
    assert arc.angle == pytest.approx(1e-6, rel=1e-6)


def test_g91_incremental_and_g90_1_absolute_centres() -> None:
    # rs274: ARC_FEED(3, 1, 2, 1, -2, -1) for the arc on line 3.
    moves = run("G91 F1\nG0 X1 Y1\nG2 X2 Z-1 I1 P2")
    assert moves[1].end == (3.0, 1.0, -1.0) and moves[1].center == (2.0, 1.0, 0.0)
    (arc,) = run("G90.1 F1\nG2 X2 Y0 I1 J0")
    assert arc.center == (1.0, 0.0, 0.0)
    assert "J word missing" in error_of("G90.1 F1\nG2 X2 I1").message


def test_g20_converts_positions_centres_and_feed() -> None:
    (arc,) = run("G20\nF10\nG2 X2 I1")
    assert arc.end == pytest.approx((50.8, 0.0, 0.0)) and arc.radius == pytest.approx(25.4)
    assert arc.feed_mm_per_min == pytest.approx(254.0)
    # rs274 sets F before G20 on the same line: F10 there is 10 mm/min.
    (line,) = run("G20 F10 G1 X1")
    assert line.feed_mm_per_min == 10.0 and line.end[0] == pytest.approx(25.4)


def test_inch_radius_tolerance_is_not_the_mm_one_converted() -> None:
    # rs274: G20 accepts |dr| = 0.0028 in (0.071 mm, above the mm limit), rejects 0.0029 in.
    assert run("G20 F1\nG2 X0.2028 I0.1")
    assert error_of("G20 F1\nG2 X0.2029 I0.1").line == 2


@pytest.mark.parametrize(
    ("end_x", "centre_i", "ok"),
    [
        (20.0282, 10, True),  # |dr| 0.0282 <= 0.028284
        (20.0283, 10, False),  # > 0.028284 and > 0.1 %
        (10002.828, 5000, True),  # 0.057 % of r: only the 2.8284 mm cap applies
        (10002.829, 5000, False),
        (200.05, 100, True),  # 0.05 mm is 0.05 % of r
    ],
)
def test_mm_radius_mismatch_thresholds(end_x: float, centre_i: float, ok: bool) -> None:
    text = f"F1\nG2 X{end_x} I{centre_i}"
    if ok:
        assert run(text)[0].end[0] == end_x
    else:
        assert "differs from radius to start" in error_of(text).message


def test_radius_format_signs_and_semicircle_tolerance() -> None:
    (short,) = run("F1\nG2 X10 R5")
    assert short.center == pytest.approx((5.0, 0.0, 0.0)) and short.angle == pytest.approx(math.pi)
    (pos,) = run("F1\nG2 X10 Y10 R10")
    (neg,) = run("F1\nG2 X10 Y10 R-10")
    assert pos.angle == pytest.approx(math.pi / 2) and neg.angle == pytest.approx(1.5 * math.pi)
    assert pos.center == pytest.approx((10.0, 0.0, 0.0))
    assert run("F1\nG2 X10 R4.9988")[0].center == pytest.approx((5.0, 0.0, 0.0))  # rs274 ok
    assert "too small" in error_of("F1\nG2 X10 R4.9985").message  # rs274 rejects


# --- errors -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "line", "fragment"),
    [
        ("G1 X1", 1, "zero feed rate"),
        ("G0 X1\nG2 X1 Y0 I1", 2, "zero feed rate"),
        ("F1\nG2 X1", 2, "no centre"),
        ("F1\nG2 X2 I1 K1", 2, "K word given"),
        ("G18 F1\nG2 X2 I1 J0", 2, "J word given"),
        ("F1\nG2 R4", 2, "neither X nor Y"),
        ("F1\nG2 X0 R4", 2, "ends where it starts"),
        ("F1\nG2 X1 R0", 2, "too small"),
        ("F1\nG2 X1 R1 I1", 2, "R mixed with I/J/K"),
        ("F1\nG2 X0.002 I0.001", 2, "zero-radius"),
        ("G0 G1 X1", 1, "two G codes"),
        ("M3 M4", 1, "two M codes"),
        ("G1 F10 X1 X2", 1, "multiple X words"),
        ("X1", 1, "no motion mode"),
        ("G80 X1", 1, "G80"),
        ("G1 X1 F10 I1", 1, "I word with no code"),
        ("G0 X1 R1", 1, "R word with no code"),
        ("G1 F1 X1 P1", 1, "P word"),
        ("G0 X1 E5", 1, "E word"),
        ("G1 X1 A1 F10", 1, "A axis word on a 3-axis machine"),
        ("W1", 1, "W axis word"),
        ("G92", 1, "G92 needs at least one axis word"),
        ("G10 L11 P0 Z1", 1, "P value out of range with G10 L11"),
        ("G10 L1 P1", 1, "G10 L1 without offsets has no effect"),
        ("G43.2", 1, "G43.2: no axes specified and H word missing"),
        ("G43.2 H1 Z1", 1, "cannot have both H and axis words"),
        ("G10 L12 P1 Z1", 1, "G10 L12 is not supported"),
        ("G10 L2 X1", 1, "G10 needs a P word"),
        ("G52", 1, "G52 needs at least one axis word"),
        ("G91 G53 G0 X1", 1, "incremental distance mode (G91)"),
        ("F1\nG53 G2 X1 I1", 2, "must be used with G0 or G1"),
        ("G19 G41 D1", 1, "only possible in the XY or XZ plane"),
        ("G41.1", 1, "G41.1 with no D word"),
        ("G81 X1 Y1 Z-1 R1", 1, "zero feed rate in G81"),
        ("F10 G81 X1 Y1 R1", 1, "Z value unspecified"),
        ("G4", 1, "G4 (dwell) needs a P"),
        ("G0 X1 S-1", 1, "negative S"),
        ("T-1", 1, "negative T"),
        ("M100", 1, "user M-code needs its program file M100"),
        ("G12", 1, "unknown G code"),
        ("G0 X1 (a (b) c)", 1, "nested comment"),
        ("G0 X1 (abc", 1, "unclosed comment"),
        ("G0 X(c)10", 1, "bad value"),
        ("G0 X1 N10", 1, "line numbers must open the line"),
        ("G0 X1.2.3", 1, "bad number"),
        ("G0 Xnan", 1, "bad value"),
        ("O100 sub", 1, "without o100 endsub"),
        ("O100 foo", 1, "unknown O-word keyword"),
        ("G0 X#<depth>", 1, "#<depth> not defined"),
        ("#<_x>=1", 1, "read-only"),
        ("o100 call", 1, "subroutine o100 not found"),
        ("o100 endsub", 1, "outside a subroutine"),
        ("F-1", 1, "negative F"),
        ("G0 X[1/0]", 1, "divide by zero"),
        ("G0 X" + "9" * 400, 1, "LinuxCNC reads at most 252"),
        ("G0 X[10**400]", 1, "finite"),
    ],
)
def test_errors_name_the_line_and_what_is_allowed(text: str, line: int, fragment: str) -> None:
    err = error_of(text)
    assert err.line == line
    assert fragment.lower() in err.message.lower()
    assert str(err).startswith(f"p.ngc:{line}: error: ")


def test_moves_before_the_error_are_yielded() -> None:
    gen = interpret("G0 X1\nG0 X2\nG1 X3\nM2\n", file="p.ngc")
    assert next(gen).end == (1.0, 0.0, 0.0)
    assert next(gen).end == (2.0, 0.0, 0.0)
    with pytest.raises(GcodeError) as info:
        next(gen)
    assert info.value.line == 3


def test_missing_program_end_is_an_error_on_the_last_line() -> None:
    # rs274: "File ended with no percent sign or program end", also for an empty file.
    with pytest.raises(GcodeError) as info:
        parse_program("G0 X1\n\n")
    assert info.value.line == 2
    with pytest.raises(GcodeError) as info:
        parse_program("")
    assert info.value.line == 1
    assert parse_program("%\nG0 X1\n%\nthis is never read\n")[0].end == (1.0, 0.0, 0.0)
    assert len(parse_program("G0 X1\nM30\nG0 X5 garbage\n")) == 1


def test_g53_axis_words_are_absolute_for_one_block() -> None:
    """rs274 with zero work offsets: G53 words are absolute (machine = work), the mode stays."""
    moves = parse_program("G21 F500\nG0 X5\nG53 G1 X10 Y3\nX20\nM2\n")
    assert [m.end for m in moves] == [(5.0, 0.0, 0.0), (10.0, 3.0, 0.0), (20.0, 3.0, 0.0)]
    assert [m.kind for m in moves] == ["rapid", "linear", "linear"]
