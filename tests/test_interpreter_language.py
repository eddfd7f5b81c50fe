"""The wider LinuxCNC language: named parameters, O-words, coordinate systems, and the input
defects of issue 15 (#5 huge expressions and numbers, #12 bare CR line ends, #15 a UTF-8 BOM).

Expected values come from ``rs274 -g`` (LinuxCNC 2.9) on the same programs where rs274 defines
them; the differential corpus (tests/test_rs274_corpus.py) covers many more.
"""

from __future__ import annotations

import pytest

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.interpreter import interpret, interpret_events, parse_program
from gantry_sim.controller.gcode.lexer import split_lines


def ends(text: str) -> list[tuple[float, ...]]:
    return [tuple(round(c, 9) for c in m.end) for m in parse_program(text)]


def error_of(text: str, **kw) -> GcodeError:
    with pytest.raises(GcodeError) as info:
        list(interpret(text, file="p.ngc", **kw))
    return info.value


# issue 15 #5: no RecursionError, OverflowError or ValueError from any value -----------------
#: a dialect that reads the LinuxCNC language with rs274's reader but no limit on a line's
#: length (LinuxCNC refuses a line of more than 252 characters before reading it)
UNLIMITED = "laserdyne"


def test_an_expression_of_thousands_of_terms_evaluates() -> None:
    terms = "+".join(["1"] * 5000)
    text = f"G0 X[{terms}]\nM2\n"
    assert [m.end for m in parse_program(text, dialect=UNLIMITED)] == [(5000.0, 0.0, 0.0)]
    mixed = "-".join(["2"] * 3001)  # left to right: 2 - 2 - ... = 2 - 3000 * 2
    moves = parse_program(f"G0 Y[{mixed}]\nM2\n", dialect=UNLIMITED)
    assert [m.end for m in moves] == [(0.0, -5998.0, 0.0)]
    assert "LinuxCNC reads at most 252" in error_of(text).message


def test_a_line_of_252_characters_is_read_and_253_refused() -> None:
    # measured: rs274 -g of LinuxCNC 2.9 reads a line of 252 characters and refuses 253
    # ("Command too long"), comments counted
    pad = 252 - len("G0 X1 ()")
    assert ends(f"G0 X1 ({'c' * pad})\nM2\n") == [(1.0, 0.0, 0.0)]
    err = error_of(f"G0 X1\nG0 X2 ({'c' * (pad + 1)})\nM2\n")
    assert err.line == 2 and "line of 253 characters" in err.message


@pytest.mark.parametrize(
    "text",
    [
        "G" + "1" * 308 + " X1",
        "M" + "9" * 400,
        "G0 X#[10**300*10**300]",
        "G0 X#[[10**300*10**300]-[10**300*10**300]]",
        "#[10**300*10**300]=1",
        "G0 X[" + "9" * 400 + " MOD 2]",
        "G0 X[[10**300*10**300] MOD 2]",
        "G0 X[[10**300*10**300]]",
        "G0 X[-8**0.5]",
        "#1=[10**300*10**300]",
    ],
)
def test_huge_and_undefined_values_are_clean_errors(text: str) -> None:
    err = error_of(text + "\nM2\n")
    assert err.line == 1 and str(err).startswith("p.ngc:1: error: ")


@pytest.mark.parametrize(
    ("text", "quoted"),
    [
        ("G0 X" + "1." * 50_000, "bad number format '1.1.1."),
        ("G0 X#<" + "b" * 100_000 + ">", "named parameter #<bbbb"),
        ("o<" + "a" * 100_000 + "> call", "subroutine o<aaaa"),
        ("o" + "7" * 300 + " sub x", "after o777"),
    ],
)
def test_a_hostile_word_is_quoted_short(text: str, quoted: str) -> None:
    # a megabyte-long word made a megabyte-long message: it is quoted to 40 characters
    err = error_of(text + "\nM2\n", dialect=UNLIMITED)
    assert len(str(err)) < 300 and quoted in str(err) and "..." in str(err)
    assert len(str(error_of(text + "\nM2\n"))) < 300  # LinuxCNC: the line is too long


def test_deep_nesting_is_refused_not_a_recursion_error() -> None:
    err = error_of("G0 X" + "[" * 2000 + "1" + "]" * 2000 + "\nM2\n", dialect=UNLIMITED)
    assert "nested" in err.message


# issue 15 #12: a bare CR ends a line (never merges two lines) -------------------------------
def test_bare_cr_is_a_line_end() -> None:
    moves = parse_program("G0 X10\rY10\rM2\r")
    assert [(m.line, m.end) for m in moves] == [(1, (10.0, 0.0, 0.0)), (2, (10.0, 10.0, 0.0))]
    assert [m.line for m in parse_program("G0 X1\r\nG0 X2\rG0 X3\nM2\n")] == [1, 2, 3]
    assert error_of("G0 X1\rG0 G1 X2\rM2").line == 2


def test_cr_cr_lf_is_one_line_end() -> None:
    # line ends converted twice (a PyCAM file): LinuxCNC, editors and grep count one line each
    assert [m.line for m in parse_program("G0 X1\r\r\nG0 X2\r\r\nG0 X3\r\r\nM2\r\r\n")] == [1, 2, 3]
    assert error_of("G21\r\r\nG0 X1\r\r\nG0 G1 X2\r\r\nM2\r\r\n").line == 3
    assert [m.line for m in parse_program("G0 X1\r\rG0 X2\nM2\n")] == [1, 3]  # bare CRs: two


def test_line_ends_split_as_the_rule_says() -> None:
    # every text of up to 6 characters of "a", CR and LF: LF, CRs then LF, or a bare CR
    import itertools
    import re

    rule = re.compile(r"\r*\n|\r")  # the rule, on texts too short for its backtracking to cost
    for n in range(7):
        for chars in itertools.product("a\r\n", repeat=n):
            text = "".join(chars)
            want = rule.split(text)
            if want and want[-1] == "":
                want.pop()
            assert split_lines(text) == want, repr(text)


def test_long_run_of_bare_crs_is_read_in_linear_time() -> None:
    # hostile-input review: 200,000 CRs and no LF took 18 s to split (a regular expression
    # scanned the CR run again from each CR); now a few milliseconds
    text = "\r" * 200_000 + "G0 X1\rM2\r"
    assert len(split_lines(text)) == 200_002
    assert [m.line for m in parse_program(text)] == [200_001]


# issue 15 #15: a UTF-8 byte order mark opens the file ---------------------------------------
def test_utf8_bom_is_accepted(tmp_path) -> None:
    from gantry_sim.sim.cli import main

    path = tmp_path / "bom.ngc"
    path.write_bytes(b"\xef\xbb\xbfG0 X1\nM2\n")
    assert main(["parse", str(path)]) == 0
    assert ends("\ufeffG0 X1\nM2\n") == [(1.0, 0.0, 0.0)]


# named parameters ---------------------------------------------------------------------------
def test_named_parameters_local_global_and_predefined() -> None:
    text = (
        "#<depth>=2 #<_safe>=5\nG0 X#<depth> Y#<_safe>\nG20\nG0 Z[#<_x>*25.4 + #<_metric>]\n"
        "G21\nG0 X[EXISTS[#<depth>] + EXISTS[#<nope>]*10]\nM2\n"
    )
    assert ends(text) == [(2.0, 5.0, 0.0), (2.0, 5.0, 50.8), (1.0, 5.0, 50.8)]
    assert "not defined" in error_of("G0 X#<a>\nM2\n").message
    # a millimetre machine's, as LinuxCNC defines it from [TRAJ]LINEAR_UNITS (QtDragon's tool
    # probe macro reads it; rs274 -g run without an INI file reads -1)
    assert ends("G20\nG0 X#<_metric_machine>\nM2\n") == [(25.4, 0.0, 0.0)]


def test_exists_of_a_numbered_parameter_says_whether_the_number_is_one() -> None:
    """rs274's read_bracketed_parameter: EXISTS[#n] is 1 where n (any integer value, read as
    #n's index) is a parameter number, 1..5601 (LinuxCNC's tests/interp/exists: its expected
    canonical calls, STRAIGHT_TRAVERSE(1, 0, 1) then (1, 0, 0)); EXISTS[##2] reads #2 for the
    number, and ###2 reads #(#2) for it, which is an error where #2 is no parameter number."""
    text = (
        "#<a>=999\nG0 X EXISTS[#1] Y EXISTS[#99999] Z EXISTS[#<a>]\n"
        "#1=2\n#2=99999\nG0 X EXISTS[##1] Y EXISTS[##2] Z EXISTS[#[2*1]]\nM2\n"
    )
    assert ends(text) == [(1.0, 0.0, 1.0), (1.0, 0.0, 1.0)]
    for bad, why in [
        ("G0 X EXISTS[1]\nM2\n", "EXISTS takes a parameter"),
        ("G0 X EXISTS[#1+#2]\nM2\n", "EXISTS takes one parameter"),
        ("#2=99999\nG0 X EXISTS[###2]\nM2\n", "parameter number 99999 out of range"),
        ("G0 X EXISTS[#1.5]\nM2\n", "a parameter number is a whole number"),
    ]:
        assert why in error_of(bad).message, bad


def test_an_abort_comment_ends_the_program_with_its_message() -> None:
    """rs274's convert_comment acts on a line's last ( ) comment: "(abort," (any case, after
    blanks) ends the program with the rest as the error, parameters filled in as %f and an
    unset name as ######; a ; comment and a skipped branch do nothing. The texts and lines
    are rs274 2.9's (rs274 -g on the same programs; LinuxCNC's tests/interp/abort-hot-comment
    too)."""
    text = (
        "G0 X1 (abort, first) (note)\nG0 X2 ; (abort, after semicolon)\n#1=3\n"
        "o1 if [0]\n(abort, skipped)\no1 endif\nG0 X3 (note) (AbOrT,last #1 #<_nope>)\nM2\n"
    )
    err = error_of(text)
    assert (err.line, err.message) == (7, "(abort,) ends the program here:last 3.000000 ######")
    made = []
    with pytest.raises(GcodeError):
        made.extend(m.end[0] for m in interpret(text))
    assert made == [1.0, 2.0]  # the moves before it
    err = error_of("G0 X1\n( Abort, stop at #<_x>)\nG0 X2\nM2\n")
    assert (err.line, err.message) == (2, "(abort,) ends the program here: stop at 1.000000")
    assert ends("(abortx, not one)\nG0 X1\nM2\n") == [(1.0, 0.0, 0.0)]
    motions = [m for m in interpret_events("(abort, x)\nG0 X1\nM2\n", "grbl") if m.kind != "stop"]
    assert [m.end for m in motions] == [(1.0, 0.0, 0.0)]  # LinuxCNC's alone


# O-words ------------------------------------------------------------------------------------
def test_subroutines_with_arguments_return_values_and_loops() -> None:
    text = """o<sq> sub
  G0 X[#1*#1]
  o<sq> return [#1*2]
o<sq> endsub
#1=7
o<sq> call [3]
G0 Y#<_value> Z#1
#<i>=0
o10 while [#<i> LT 3]
  #<i>=[#<i>+1]
  o11 if [#<i> EQ 2]
    o10 continue
  o11 elseif [#<i> EQ 3]
    G0 Y30
  o11 else
    G0 Y10
  o11 endif
o10 endwhile
o20 repeat [2]
  G91 G0 Z1
o20 endrepeat
G90
o30 do
  o30 break
  G0 X99
o30 while [1]
M2
"""
    assert ends(text) == [
        (9.0, 0.0, 0.0),
        (9.0, 6.0, 7.0),
        (9.0, 10.0, 7.0),
        (9.0, 30.0, 7.0),
        (9.0, 30.0, 8.0),
        (9.0, 30.0, 9.0),
    ]


def test_a_call_may_compute_its_o_number() -> None:
    """rs274 reads a call's O number as any integer value: a parameter (LinuxCNC's
    tests/interp/oword-bug315-p2) or an expression (tests/interp/m98m99/14-o-expression-call),
    evaluated when the call runs."""
    text = """o1 sub
  G0 X1
o1 endsub
o2 sub
  G0 X2 Y#1
o2 endsub
o100 sub
  G0 X100
o100 endsub
#<sub> = 2
o#<sub> call [5]
#2 = 10
O[#2 * 10] call
#<sub> = 1.00001
o#<sub> call
M2
"""
    assert ends(text) == [(2.0, 5.0, 0.0), (100.0, 5.0, 0.0), (1.0, 5.0, 0.0)]


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ("#1=1.5\no#1 call\nM2\n", "not an integer"),
        ("#1=-1\no#1 call\nM2\n", "a whole number >= 0"),
        ("#1=3\no#1 call\nM2\n", "o3 not found"),
        ("#1=1\no#1 sub\no1 endsub\nM2\n", "supported with call only"),
    ],
)
def test_a_computed_o_number_is_refused_where_rs274_refuses_it(text: str, why: str) -> None:
    with pytest.raises(GcodeError, match=why):
        parse_program(text)


def test_runaway_loops_and_recursion_stop_with_their_line() -> None:
    err = error_of("o1 while [1]\no1 endwhile\nM2\n", max_iterations=1000)
    assert err.line == 1 and "more than 1000" in err.message
    err = error_of("o1 sub\no1 call\no1 endsub\no1 call\nM2\n")
    assert err.line == 2 and "too many subroutine levels" in err.message
    # M98's L repeats count at the call (they ran without bound: found by a hostile sweep)
    sub = "M2\nO100\nG1 X1\nG1 X0\nM99\n"
    err = error_of(f"G21 F1000\nM98 P100 L99999999\n{sub}", max_iterations=1000)
    assert err.line == 2 and "more than 1000" in err.message
    assert len(list(interpret(f"G21 F1000\nM98 P100 L500\n{sub}", max_iterations=500))) == 1000


def test_a_loop_that_never_moves_is_refused_after_a_bounded_number_of_lines(tmp_path, capsys):
    # hostile-input review: refused only at 1,000,000 repetitions, 45-150 s for a body of a
    # few lines (this one: about 60 s); now after 100,000 lines without a move (about 1 s)
    from gantry_sim.sim.cli import main

    prog = tmp_path / "spin.ngc"
    prog.write_text("#1=0\no100 while [1]\n#1=[#1+1]\n#2=[#1*2]\no100 endwhile\nM2\n")
    assert main(["parse", str(prog)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{prog}:2: error: 100002 lines run in loops and subroutines without a ")
    assert "At most 100000 are run (a tenth of --max-iterations)" in err
    err = error_of("o1 sub\n#1=1\no1 call\no1 endsub\no1 call\nM2\n", max_iterations=100)
    assert err.line == 3 and "too many subroutine levels" in err.message  # (levels first)
    # M98's L repeats of a subprogram that never moves: refused at its M99
    err = error_of("M98 P100 L900000\nM2\nO100\n#1=1\n#2=2\nM99\n")
    assert err.line == 6 and "without a move (at M99 repeating O100;" in err.message


@pytest.mark.parametrize("body", ["G1 X0 F100", "G4 P0", "M1", "G64 P0.01"])
def test_a_loop_of_moves_that_go_nowhere_is_refused_as_one_that_never_moves(body):
    """A million zero-length G1s, G4 P0s or M1s reset the bound at each line: they took
    minutes to parse and plan for no motion at all; now they count as lines without one."""
    err = error_of(f"o1 repeat [1000000]\n{body}\no1 endrepeat\nM2\n")
    assert err.line == 3 and "without a move (at o1 endrepeat; a move of no" in err.message


def test_big_loops_that_move_still_run() -> None:
    # 10,000 repetitions that move, and nested loops whose inner loop computes 50 lines
    # between moves: the bound counts lines since the last move, so none of them meets it
    moves = parse_program("F1000\no1 repeat [10000]\nG91 G1 X0.01\no1 endrepeat\nM2\n")
    assert len(moves) == 10_000
    nested = (
        "F1000 G91\n#1=0\no1 repeat [50]\no2 repeat [100]\no3 repeat [25]\n#1=[#1+1]\n"
        "o3 endrepeat\nG1 X0.001\no2 endrepeat\no1 endrepeat\nM2\n"
    )
    # 265,000 lines run without a move in all (the bound is 100,000 in a row)
    assert len(parse_program(nested)) == 5000


def test_subroutine_files_on_the_search_path(tmp_path) -> None:
    (tmp_path / "peck.ngc").write_text("o<peck> sub\nG0 Z[-#1]\no<peck> endsub\nM2\n")
    moves = list(interpret("o<peck> call [2]\nM2\n", search_path=(tmp_path,)))
    assert [m.end for m in moves] == [(0.0, 0.0, -2.0)]
    assert "not found" in error_of("o<peck> call\nM2\n").message
    (tmp_path / "bad.ngc").write_text("o<bad> sub\nG0 G1 X1\no<bad> endsub\n")
    err = error_of("o<bad> call\nM2\n", search_path=(tmp_path,))
    assert err.file == str(tmp_path / "bad.ngc") and err.line == 2


def test_an_m98_subprogram_in_its_own_file(tmp_path) -> None:
    """rs274 looks an M98 P<n> not in the program up as it looks up o<n> call: n.ngc on the
    search path, holding ``O<n>`` ... ``M99`` (rs274 -g on these files, 2026-11-30: X5, then
    Y3; a file holding an ``o2000 sub`` is refused by both)."""
    (tmp_path / "2000.ngc").write_text("O2000\nG0 X5\nM99\n")
    main = "G21\nM98 P2000 L2\nG0 Y3\nM30\n"
    moves = list(interpret(main, search_path=(tmp_path,)))
    assert [(m.line, m.end) for m in moves] == [
        (2, (5.0, 0.0, 0.0)),
        (2, (5.0, 0.0, 0.0)),
        (3, (5.0, 3.0, 0.0)),
    ]
    assert "or a file 2000.ngc" in error_of(main).message  # not on the search path
    (tmp_path / "2000.ngc").write_text("o2000 sub\nG0 X5\no2000 endsub\n")
    assert "no subprogram O2000" in error_of(main, search_path=(tmp_path,)).message


def test_the_lines_read_while_seeking_a_subroutine_are_checked(tmp_path) -> None:
    """rs274 reads every line it passes over (read_text): a nested comment in a subroutine
    file's header, before its ``sub`` line, is refused there (a Mazak retrofit's M6 remap
    file), naming that file; a line whose words are bad, passed over, is not."""
    (tmp_path / "tc.ngc").write_text(
        "(header)\n( (ATC doc) notes )\no<tc> sub\nG0 X1\no<tc> endsub\n"
    )
    err = error_of("o<tc> call\nM2\n", search_path=(tmp_path,))
    assert (err.file, err.line) == (str(tmp_path / "tc.ngc"), 2) and "nested comment" in err.message
    (tmp_path / "ok.ngc").write_text("G0 $$ Q)\no<ok> sub\nG0 X1\no<ok> endsub\n")
    moves = list(interpret("o<ok> call\nM2\n", search_path=(tmp_path,)))
    assert [m.end for m in moves] == [(1.0, 0.0, 0.0)]


def test_a_subroutine_defined_inside_another_is_refused(tmp_path) -> None:
    """rs274: "Nested subroutine definition", on the inner sub's line, whether the outer one
    is in the program (LinuxCNC's tests/interp/bad/nested.ngc: line 6) or in a file
    (tests/interp/nested-sub-error)."""
    text = "G21\n\nO1 sub\nG1 X0\n\n  O2 sub\n  G1 Y0\n  O2 endsub\n\nO1 endsub\nO1 call\nM30\n"
    err = error_of(text)
    assert err.line == 6 and "o2 sub inside the definition of o1" in err.message
    (tmp_path / "outer.ngc").write_text(
        "o<outer> sub\no100 sub\nG0 X1\no100 endsub\no100 call\no<outer> endsub\nM2\n"
    )
    err = error_of("o<outer> call\nM2\n", search_path=(tmp_path,))
    assert (err.file, err.line) == (str(tmp_path / "outer.ngc"), 2), err
    assert "o100 sub inside the definition of o<outer>" in err.message


def test_a_subroutine_after_the_closing_percent_is_not_read() -> None:
    """rs274 reads nothing after a program's closing % line: a sub defined there is not
    found (LinuxCNC's tests/interp/m98m99/11-main-program-oword: "Failed to find sub 'O2'
    before EOF"); after M2, with no %, it is."""
    after = "O2 sub\nG0 Z3\nO2 endsub\n"
    err = error_of("%\nG0 X1\nO2 call\n%\n" + after)
    assert err.line == 3 and "before its closing '%'" in err.message
    assert ends("G0 X1\nO2 call\nM2\n" + after) == [(1.0, 0.0, 0.0), (1.0, 0.0, 3.0)]


# coordinate systems -------------------------------------------------------------------------
def test_offsets_place_moves_in_the_work_frame() -> None:
    # rs274 prints G0 X2 at program (2, 0) with G92 offset (1, 1): the tool goes to (3, 1).
    text = "G0 X1 Y1\nG92 X0 Y0\nG0 X2\nG92.1\nG0 X0 Y0\nG10 L2 P2 X10 Y20\nG55 G0 X1 Y1\nM2\n"
    assert ends(text) == [(1.0, 1.0, 0.0), (3.0, 1.0, 0.0), (0.0, 0.0, 0.0), (11.0, 21.0, 0.0)]
    # G28.1 stores the absolute point, G28 returns to it through the given axes' point.
    moves = parse_program("G0 X5 Y5\nG28.1\nG0 X0 Y0\nG28 X1\nM2\n")
    assert [m.end for m in moves][-2:] == [(1.0, 0.0, 0.0), (5.0, 0.0, 0.0)]


def test_parse_cli_subroutine_path_and_iteration_bound(tmp_path, capsys) -> None:
    from gantry_sim.sim.cli import main

    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "hop.ngc").write_text("o<hop> sub\nG0 Z#1\no<hop> endsub\n")
    prog = tmp_path / "p.ngc"
    prog.write_text("o<hop> call [3]\nM2\n")
    assert main(["parse", str(prog)]) == 2
    assert "not found" in capsys.readouterr().err
    assert main(["parse", str(prog), "--subroutine-path", str(lib)]) == 0
    assert '"end": [0.0, 0.0, 3.0]' in capsys.readouterr().out
    prog.write_text("o1 repeat [50]\nG91 G0 X1\no1 endrepeat\nM2\n")
    assert main(["parse", str(prog), "--max-iterations", "10"]) == 2
    assert f"{prog}:3: error: more than 10" in capsys.readouterr().err


def test_all_errors_lists_every_refused_line(tmp_path, capsys) -> None:
    from gantry_sim.sim.cli import main

    prog = tmp_path / "p.ngc"
    prog.write_text("G0 X1\nG0 G1 X2\nG81 X1 Z-1 R1\nG0 X3\nG1 X4\nM2\n")
    assert main(["parse", str(prog), "--all-errors"]) == 2
    captured = capsys.readouterr()
    assert [ln.split(": error")[0] for ln in captured.err.splitlines()[:3]] == [
        f"{prog}:2",
        f"{prog}:3",
        f"{prog}:5",
    ]
    assert "3 refused line(s)" in captured.err
    assert captured.out.count('"kind"') == 2  # the accepted lines' motions: X1 and X3
    assert main(["parse", str(prog)]) == 2  # without the option: the first error only
    assert capsys.readouterr().err.count("error:") == 1


def test_linuxcnc_io_m_codes_are_accepted() -> None:
    # rs274: M61 Q1, M62-M65 P, M66 P L, M67/M68 E Q move nothing; #5599 may be set.
    text = "#5599=1\nM61 Q1\nM62 P0\nM63 P0\nM64 P0\nM65 P0\nM66 P0 L0\nM67 E0 Q1\nM68 E0 Q1\nG0 X1\nM2\n"
    assert ends(text) == [(1.0, 0.0, 0.0)]
    assert "Q word" in error_of("M61\nM2\n").message


def test_tool_table_and_length_offsets(tmp_path, capsys) -> None:
    from gantry_sim.controller.gcode.tools import parse_tool_table
    from gantry_sim.sim.cli import main

    tools = parse_tool_table("T1 P1 Z10 D6 ;end mill\n\nT2 P2 Z25.5\n")
    assert tools[1].z_mm == 10.0 and tools[1].diameter_mm == 6.0 and tools[2].z_mm == 25.5
    # rs274: G43 on a later line re-expresses Z (the tip stays, Z reads -length); G49 undoes it
    text = "T1 M6\nG43 H1\nG0 X1\nG49\nG0 X2\nG53 G0 Z0\nT3\nM2\n"
    err = error_of(text, tools=tools)
    assert err.line == 7 and "tool 3 not found" in err.message
    assert "which holds T1, T2 (give it in the --tool-table file" in err.message
    moves = list(interpret(text.replace("T3\n", ""), tools=tools))
    assert [m.end for m in moves] == [(1.0, 0.0, -10.0), (2.0, 0.0, 0.0), (2.0, 0.0, 0.0)]
    with pytest.raises(GcodeError) as info:
        parse_tool_table("T1 Z1\nhello\n", "t.tbl")
    assert (info.value.file, info.value.line) == ("t.tbl", 2)
    table = tmp_path / "tool.tbl"
    table.write_text("T1 P1 Z10\n")
    prog = tmp_path / "p.ngc"
    prog.write_text("T1 M6\nG43\nG0 X1\nM2\n")
    assert main(["parse", str(prog), "--tool-table", str(table)]) == 0
    assert '"end": [1.0, 0.0, -10.0]' in capsys.readouterr().out


def test_inverse_time_and_feed_per_revolution_become_path_speed() -> None:
    # rs274: G93 F2 on a 10 mm line is SET_FEED_RATE(20); G95 F0.5 at S100 is 50 mm/min.
    moves = parse_program("G93 G1 X10 F2\nG2 X0 I-5 F1\nG94 G1 X1 F100\nM2\n")
    assert [round(m.feed_mm_per_min, 9) for m in moves] == [
        20.0,
        round(5 * 3.141592653589793, 9),
        100.0,
    ]
    assert parse_program("G95 S100 G1 X10 F0.5\nM2\n")[0].feed_mm_per_min == 50.0
    assert error_of("G93 G1 X10 F2\nG1 X20\nM2\n").line == 2
    assert "zero spindle speed" in error_of("G95 G1 X10 F0.5\nM2\n").message


def test_inverse_time_under_cutter_compensation_takes_the_programmed_length() -> None:
    """rs274 2.9 (rs274 -g on this program): G93 F6 on a programmed 20 mm line is
    SET_FEED_RATE(120) for the compensated line, F3 on 10 mm is 30, F4 on a quarter circle of
    R10 is 62.8319; before, the compensated moves took F itself as mm/min (LinuxCNC's
    tests/interp/inverse-time-with-comp)."""
    text = (
        "G21 G17 G90\nG0 X0 Y0\nG41.1 D4\nG93 G1 X20 F6\nG1 Y10 F3\n"
        "G3 X10 Y20 I-10 J0 F4\nG94 G40 G1 X0 Y30 F600\nM2\n"
    )
    feeds = [m.feed_mm_per_min for m in parse_program(text) if m.kind != "rapid"]
    assert [round(f, 4) for f in feeds] == [120.0, 30.0, 62.8319, 600.0]


def test_dwell_and_stops_are_events_when_asked(tmp_path, capsys) -> None:
    from gantry_sim.sim.cli import main

    text = "G1 X1 F100\nG4 P0.5 G1 X2\nM0\nM1\nG0 X3\nM60\nM2\n"
    plain = parse_program(text)
    assert [m.kind for m in plain] == ["linear", "linear", "rapid"]  # motions only by default
    got = [(m.line, m.kind) for m in interpret_events(text)]
    assert got == [
        (1, "linear"),
        (2, "dwell"),  # rs274 dwells before the line's motion
        (2, "linear"),
        (3, "stop"),
        (4, "stop"),
        (5, "rapid"),
        (6, "stop"),
    ]
    dwell = list(interpret_events(text))[1]
    assert dwell.to_json() == {
        "line": 2,
        "kind": "dwell",
        "position": [1.0, 0.0, 0.0],
        "seconds": 0.5,
    }
    prog = tmp_path / "p.ngc"
    prog.write_text(text)
    assert main(["parse", str(prog), "--events"]) == 0
    assert '"kind": "stop", "position": [2.0, 0.0, 0.0], "code": "M0"' in capsys.readouterr().out


def test_a_negative_dwell_waits_no_time_as_in_linuxcnc() -> None:
    # rs274 -g (LinuxCNC 2.9) prints DWELL(-3.0000) for "G4 P-3", and LinuxCNC's task ends a
    # negative delay at once (bantamtools/omctest's G04_negative.nc: refused here before);
    # G4 with no P stays an error, as rs274's "Dwell time missing with g4"
    text = "G21 G90\nG4 P-3\nG0 X1\n#1 = -0.5\nG4 P#1\nM2\n"
    dwells = [m for m in interpret_events(text) if m.kind == "dwell"]
    assert [(d.line, d.seconds) for d in dwells] == [(2, 0.0), (5, 0.0)]
    with pytest.raises(GcodeError, match="G4 \\(dwell\\) needs a P word") as err:
        list(interpret_events("G21\nG4\nM2\n"))
    assert err.value.line == 2


def test_work_offset_places_the_program(tmp_path, capsys) -> None:
    from gantry_sim.sim.cli import main

    moves = list(
        interpret("G0 X0 Y0\nG1 X10 F100\nG0 Z[#5223]\nM2\n", work_offset=(100.0, 50.0, -5.0))
    )
    assert [m.end for m in moves] == [
        (100.0, 50.0, 0.0),
        (110.0, 50.0, 0.0),
        (100.0 + 10, 50.0, -10.0),
    ]
    assert moves[0].start == (0.0, 0.0, 0.0)  # the tool starts at the work frame's origin
    prog = tmp_path / "p.ngc"
    prog.write_text("G0 X1 Y0 Z0\nM2\n")  # unnamed axes would stay where the tool is
    assert main(["parse", str(prog), "--work-offset", "10,20,30"]) == 0
    assert '"end": [11.0, 20.0, 30.0]' in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["parse", str(prog), "--work-offset", "10,20"])


def test_m70_m72_m73_save_and_restore_modal_state() -> None:
    text = """o<inch> sub
M73
G20 G91 F5
G0 X1
o<inch> endsub
G21 G90 F200 M3 M8
M70
G20 G91
M72
G0 X1 Y[#<_metric>*10 + #<_spindle_on> + #<_flood>]
o<inch> call
G0 X[#<_feed>] Y[#<_absolute>]
M2
"""
    got = ends(text)
    # M72 restored G21 G90 (X1 absolute, Y = 10 + 1 + 1); the sub's G20 G91 moved 1 inch;
    # M73 restored mm, absolute and F200 at its return.
    assert got == [(1.0, 12.0, 0.0), (26.4, 12.0, 0.0), (200.0, 1.0, 0.0)]
    assert "M72 with no state saved" in error_of("M72\nM2\n").message


def test_user_m_codes_need_their_program_file(tmp_path) -> None:
    # rs274 without the file: "Unknown m code used: M100"; LinuxCNC runs USER_M_PATH/M100.
    assert "M101" in error_of("M101 P1 Q2\nM2\n").message
    (tmp_path / "M101").write_text("#!/bin/sh\n")
    moves = list(interpret("M101 P1 Q2\nG0 X1\nM2\n", search_path=(tmp_path,)))
    assert [m.end for m in moves] == [(1.0, 0.0, 0.0)]


def test_a_subroutine_name_too_long_for_a_file_is_refused_on_its_line(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    """A 300-character o<name> call: looking for NAME.ngc failed with ENAMETOOLONG, reported
    on the file name alone, with no program line (a hostile-input sweep's find)."""
    from gantry_sim.sim.cli import main

    prog = tmp_path / "p.ngc"
    prog.write_text("G1 X1 F100\no<" + "a" * 300 + "> call\nM2\n")
    assert main(["parse", "--dialect", "laserdyne", str(prog)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{prog}:2: error: subroutine o<aaaa") and "File name too long" in err


LONG_LOOP = (
    """G21 G90 G17 F600
o<edge> sub
  G1 X[#1] Y[#1 * 2]
  G2 X[#1 + 1] Y[#1 * 2 + 1] I0.5 J0.5
o<edge> endsub
#<k> = 0
o10 while [#<k> LT 3]
"""
    + "".join(f"  G1 X[#<k> + {i / 10}] Y{i % 3}\n" for i in range(12))
    + """\
  o<edge> call [#<k> * 3]
  o20 if [#<k> EQ 1]
    G1 Z-1
  o20 endif
  #<k> = [#<k> + 1]
o10 endwhile
M98 P100 L2
M2
O100
  G91 G1 X1
  G90
M99
"""
)


def test_a_source_keeps_the_lines_it_lexed_last_only():
    from gantry_sim.controller.gcode import control

    lines = [f"G1 X{i} Y{i % 7}" for i in range(3 * control.LEXED_LINES_KEPT)]
    source = control.Source("p", lines)
    for i in range(len(lines)):
        assert source.block(i).line == i + 1
    assert len(source.blocks) == control.LEXED_LINES_KEPT
    assert min(source.blocks) == len(lines) - control.LEXED_LINES_KEPT
    assert source.block(0).line == 1  # lexed again, the same


def test_loops_and_calls_longer_than_the_lexed_lines_kept_run_the_same(monkeypatch):
    """A loop body, subroutine and M98 subprogram run again after their lines were dropped
    from the lexed ones: lexed again, the same moves (line numbers and all)."""
    from gantry_sim.controller.gcode import control

    kept = parse_program(LONG_LOOP)
    assert len(kept) == 3 * (12 + 2) + 1 + 2  # the 12 lines and the sub's 2, Z-1 once, M98
    monkeypatch.setattr(control, "LEXED_LINES_KEPT", 2)
    assert parse_program(LONG_LOOP) == kept


def test_messages_name_what_is_wrong_and_how_to_go_on() -> None:
    """A word whose value cannot be read names its letter (LinuxCNC's lathe/boring.ngc: text
    after a comment reads as an M word starting with 'A'); an INI or HAL parameter, which no
    simulation has, says so and how to give it; an O-word line with no keyword quotes the name
    as written and points at a forgotten call."""
    err = error_of("G0 X1\n(MSG, Press Cycle Start) Macro\nM2\n")
    assert err.line == 2 and err.message.startswith("M word: bad value starting with 'A'")
    err = error_of("G0 Z#<_ini[axis_z]max_limit>\nM2\n")
    assert "reads it from its INI file" in err.message
    assert "#<_ini[axis_z]max_limit> = ..." in err.message
    assert "from a HAL pin" in error_of("F#<_hal[plasmac.cut-feed-rate]>\nM2\n").message
    assert "set it before reading it" in error_of("G0 X#<depth>\nM2\n").message
    err = error_of("o<drill_man> [1] [2]\nM2\n")
    assert "after o<drill_man>: found '[1][2]'" in err.message
    assert "(a call reads o<drill_man> call [...])" in err.message
