"""Lexer and expression reading: comments, spaces, case, N words, %, parameters, expressions.

Expected values from ``rs274 -g`` (LinuxCNC 2.9) on the same lines.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.gcode.lexer import Block, _lex_text, lex, lex_line, strip_line


def ends(text: str) -> list[tuple[float, float, float]]:
    return [m.end for m in parse_program(text + "\nM2\n")]


def test_strip_line_drops_comments_spaces_and_case() -> None:
    assert strip_line("g0 x 2 . 5 (move) y- 1 ; rest") == "G0X2.5(Y-1"
    assert [b.line for b in lex("(a)\n\n(b)\r\n")] == [1, 2, 3]


def test_words_spaces_case_line_numbers_block_delete() -> None:
    # rs274: "G0 X 2 . 5 Y- 1" -> (2.5, -1); "n10 g1 x1 f10 ; hi" -> (1, 0); "/G0 X5" runs.
    assert ends("G0 X 2 . 5 Y- 1\nn10 g1 x1 f10 ; hi\nN10.5 G0 X1. Y.5 Z+1\n/G0 X5") == [
        (2.5, -1.0, 0.0),
        (1.0, -1.0, 0.0),
        (1.0, 0.5, 1.0),
        (5.0, 0.5, 1.0),
    ]


def test_blank_and_comment_lines_and_percent_delimiters() -> None:
    assert ends("\n(only a comment)\n; another\n\nG0 X1") == [(1.0, 0.0, 0.0)]
    assert [m.line for m in parse_program("\n%\nG0 X1\n%\n")] == [3]
    with pytest.raises(GcodeError) as info:
        parse_program("G0 X1\n%\nM2\n")
    assert info.value.line == 2


def test_parameters_and_expressions_match_rs274() -> None:
    # rs274: the #1 read on a line is the value from before that line's #1=...
    text = (
        "#1=2\n#1=5 G0 X#1\nG0 X[2+3*4] Y[2**3**2] Z[7 MOD 3]\n"
        "G0 X[SIN[30]] Y[ATAN[1]/[1]] Z[-2+1]\nG0 X-#1 Y[FIX[-2.5]] Z[ROUND[2.5]]\n"
        "G0 X[1 LT 2] Y[-7 MOD 3]\n#2=[#1*2]\nG0 X#2"
    )
    got = ends(text)
    want = [(2, 0, 0), (14, 64, 1), (0.5, 45, -1), (-5, -3, 3), (1, 2, 3), (10, 2, 3)]
    assert got == [pytest.approx(w) for w in want]


@pytest.mark.skipif(
    np.finfo(np.longdouble).nmant <= 52, reason="this platform's long double is a double"
)
def test_degrees_go_through_long_double_pi_as_in_rs274() -> None:
    """rs274 computes cos((x * M_PIl) / 180.0) in long double: COS[90] is -2.5e-20, and a
    program raising it to a small power (lagun-linuxcnc's spquircle_boss.ngc) lands where
    LinuxCNC lands. Expected values: `rs274 -g` of LinuxCNC 2.9 on these lines."""
    text = (
        "G1 X[ABS[COS[90]]**0.075] Y[ABS[SIN[180]]**0.075] Z[ABS[TAN[180]]**0.075] F100\n"
        "G1 X[ATAN[1]/[1]] Y[ACOS[0]] Z[ASIN[1]]\nG1 X[COS[60]] Y[SIN[30]] Z[TAN[45]]\n"
    )
    got = ends(text)
    want = [(0.0339, 0.0357, 0.0357), (45, 90, 90), (0.5, 0.5, 1)]
    assert got == [pytest.approx(w, abs=5e-5) for w in want]


@pytest.mark.parametrize(
    "text", ["G0 X##3", "G0 X[1+", "G0 X[1 FOO 2]", "G0 X[SQRT[-1]]", "#1 G0", "G0 X"]
)
def test_bad_values_are_gcode_errors(text: str) -> None:
    with pytest.raises(GcodeError) as info:
        parse_program(text + "\nM2\n")
    assert info.value.line == 1 and info.value.message


def _general(raw: str, line: int = 1) -> Block | str:
    """The general reader's block of ``raw`` (no plain-line shortcut), or its error."""
    try:
        return _lex_text(strip_line(raw), raw, line)
    except GcodeError as exc:
        return exc.message


def _lexed(raw: str, line: int = 1) -> Block | str:
    try:
        return lex_line(raw, line)
    except GcodeError as exc:
        return exc.message


@pytest.mark.parametrize(
    "raw",
    [
        "G1 X0.2582 Y0.0115 F3000",
        "g1x-.5y+1.z-0",
        "N10 G0 X1",
        "/N10.5.5 G1 X-1. Y.25",
        "/",
        "",
        "X1.2.3",
        "X.",
        "X-",
        "X--1",
        "N G1",
        "G1 X1" + "0" * 400,
        "G1 X" + "9" * 301,
        "G1 X" + "9" * 300 + ".5",
        "O100 SUB",
        "G1 X1 (c)",
        "$0 M3",
        "@1^90",
    ],
)
def test_plain_lines_lex_as_the_general_reader_does(raw: str) -> None:
    # lines of plain words take a shortcut (two regular expressions); its blocks, and the
    # errors of lines it leaves to the general reader, must be the general reader's
    assert _lexed(raw, 7) == _general(raw, 7)


def test_a_long_line_of_digit_words_that_is_not_plain_fails_the_shortcut_at_once() -> None:
    # a printer's checksum after 30 words of 10 digits: with an ambiguous number pattern the
    # shortcut's regular expression tried 10^30 splits of the digit runs before giving up (a
    # hang); its quantifiers are possessive, and the general reader says what is wrong
    raw = "G1" + "X1111111111" * 30 + "*71"
    assert _lexed(raw) == _general(raw) == _general("*")
    assert "bad character '*'" in _lexed(raw)


_PLAIN_CHARS = "GXYZNIJKFP0123456789.+-/ \tgxy*E"


@given(st.text(alphabet=_PLAIN_CHARS, max_size=40))
@settings(max_examples=400, deadline=None)
def test_any_line_of_word_characters_lexes_as_the_general_reader_does(raw: str) -> None:
    assert _lexed(raw) == _general(raw)


_COMMENT_CHARS = "G1X2(;)%/ ab"


@given(st.text(alphabet=_COMMENT_CHARS, max_size=30), st.sampled_from(["grbl", "g2core"]))
@settings(max_examples=400, deadline=None)
def test_firmware_comments_leave_what_rs274_reads_and_keep_the_words(raw: str, rules: str):
    from gantry_sim.controller.gcode.lexer import firmware_comments

    kept = firmware_comments(raw, rules)
    # every comment closed and holding no "(": rs274's reader never refuses a comment of it
    try:
        strip_line(kept)
    except GcodeError as exc:
        pytest.fail(f"{raw!r} -> {kept!r}: {exc}")
    # outside the comments, the words up to the first ";" (g2core: or "%") are the line's own
    words, depth = [], False
    for ch in raw:
        if depth:
            depth = ch != ")"
        elif ch == "(":
            depth = True
        elif ch == ";" or (rules == "g2core" and ch == "%"):
            break
        elif not (rules == "g2core" and ch == ")"):  # g2core's normalizer drops a stray ")"
            words.append(ch)
    if rules == "g2core" and raw.lstrip(" \t").startswith("/"):
        words = []  # g2core's block delete (after the blanks controller.cpp strips)
    if rules == "grbl":
        words = [ch for ch in words if ch != "/"]  # grbl's protocol.c drops every '/'
    want = "".join(words).replace(" ", "").upper()
    assert strip_line(kept).replace("(", "") == want, (raw, kept)
