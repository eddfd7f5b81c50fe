"""Subroutine files, tool tables, placement and the loop bound work in plan, run and sweep as in
parse; a refused program says how to list every refused line."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from gantry_sim.sim.cli import main

#: a program whose motions live in a subroutine file; G43 H1 makes the tip read Z - length, so
#: the rapid that names no Z goes down by tool 1's length (as rs274 does it); G61, so that the
#: reference passes through every programmed point (in G64 the corner between two rapids is
#: cut within P)
MAIN = "G61\nT1 M6\nG43 H1\nG0 X1\no<square> call [4]\nG49\nM2\n"
SQUARE = "o<square> sub\nG0 X0 Y0 Z0\nG1 X#1 F1200\nG1 Y#1\nG1 X0\nG1 Y0\no<square> endsub\n"


@pytest.fixture
def setup_files(tmp_path: Path) -> tuple[Path, Path, Path]:
    """(program, subroutine folder, tool table): tool 1 is 10 mm long."""
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "square.ngc").write_text(SQUARE)
    prog = tmp_path / "part.ngc"
    prog.write_text(MAIN)
    table = tmp_path / "tool.tbl"
    table.write_text("T1 P1 Z10 D6 ;end mill\n")
    return prog, lib, table


def _options(lib: Path, table: Path) -> list[str]:
    return ["--subroutine-path", str(lib), "--tool-table", str(table), "--work-offset", "5,6,7"]


def test_plan_takes_subroutine_path_tool_table_and_work_offset(setup_files, tmp_path, capsys):
    prog, lib, table = setup_files
    assert main(["plan", str(prog)]) == 2
    assert "subroutine o<square> not found" in capsys.readouterr().err
    out = tmp_path / "traj.npz"
    assert main(["plan", str(prog), *_options(lib, table), "--out", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["moves"] == 6
    pos = np.load(out)["pos"]
    # G54 at (5, 6, 7): the square is X 5..9, Y 6..10 at Z 7, ending at its corner; the rapid
    # before it went down to Z 0 - 10 (tool 1's length)
    assert np.allclose(pos[-1], [5.0, 6.0, 7.0])
    assert np.isclose(pos[:, 0].max(), 9.0) and np.isclose(pos[:, 1].max(), 10.0)
    assert np.isclose(pos[:, 2].min(), -10.0)


def test_plan_and_run_take_the_iteration_bound(setup_files, tmp_path, capsys):
    prog, _, _ = setup_files
    prog.write_text("o1 repeat [50]\nG91 G0 X1\no1 endrepeat\nM2\n")
    for command in (["plan"], ["run", "--out", str(tmp_path / "o")], ["sweep"]):
        args = [*command, str(prog), "--max-iterations", "10"]
        if command == ["sweep"]:
            args += ["--out", str(tmp_path / "s"), "--workers", "1"]
        assert main(args) == 2
        assert f"{prog}:3: error: more than 10" in capsys.readouterr().err
    with pytest.raises(SystemExit) as info:
        main(["plan", str(prog), "--max-iterations", "0"])
    assert info.value.code == 2
    assert "expected an integer >= 1" in capsys.readouterr().err


def test_run_and_sweep_take_the_same_options(setup_files, tmp_path, capsys):
    prog, lib, table = setup_files
    out = tmp_path / "run"
    args = ["run", str(prog), *_options(lib, table), "--out", str(out), "--no-plots", "--json"]
    assert main(args) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["moves"] == 6
    ref = np.load(out / "trace.npz")["ref"]
    assert np.allclose(ref[-1], [5.0, 6.0, 7.0]) and np.isclose(ref[:, 2].min(), -10.0)
    sweep_out = tmp_path / "sweep"
    args = ["sweep", str(prog), *_options(lib, table), "--out", str(sweep_out), "--workers", "1"]
    assert main(args) == 0
    capsys.readouterr()
    rows = list(csv.DictReader((sweep_out / "sweep.csv").open()))
    assert [r["status"] for r in rows] == ["ok"]
    assert float(rows[0]["cycle_time_s"]) == pytest.approx(report["cycle_time_s"])


def test_refused_program_says_how_to_list_every_refused_line(write_program, tmp_path, capsys):
    several = write_program("G0 X1\nG0 G1 X2\nG81 X1 Z-1 R1\nG1 X4\nM2\n")
    for command in (["plan"], ["run", "--out", str(tmp_path / "o")]):
        assert main([*command, str(several)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith(f"{several}:2: error: ")
        assert "(2 more line(s) refused; `gantry parse --all-errors`" in err
        assert len(err.splitlines()) == 1
    assert main(["parse", "--all-errors", str(several)]) == 2
    assert "3 refused line(s)" in capsys.readouterr().err
    one = write_program("G0 X1\nG0 G1 X2\nM2\n", "one.ngc")
    assert main(["plan", str(one)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{one}:2: error: ") and "--all-errors" not in err


def test_the_count_of_refused_lines_stops_at_a_loop_the_refusal_made_endless(write_program, capsys):
    """Past a refused setting the count reads its parameter as never set: a loop counting by
    it never ends. The count stops at COUNT_MAX_ITERATIONS, not at --max-iterations (a real
    program reading an unset #<_td> took minutes of `gantry plan` to report line 2)."""
    from gantry_sim.sim import program

    text = (
        "G21 G90 F600\n#<step> = [#<_td> * 0.4]\n#<r> = 0\no100 while [#<r> LT 5]\n"
        "G1 X#<r>\n#<r> = [#<r> + #<step>]\no100 endwhile\nM2\n"
    )
    path = write_program(text)
    assert program.COUNT_MAX_ITERATIONS < 1_000_000  # the default --max-iterations
    assert main(["plan", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"{path}:2: error: ") and "_td" in err
    # the count stopped at the loop bound; the loop's own refusals after it are not counted
    assert "_td> not defined; set it before reading it\n" in err + "\n"


def test_run_program_searches_the_programs_folder_then_search_path(setup_files, machine):
    from dataclasses import replace

    from gantry_sim.controller.errors import GcodeError
    from gantry_sim.controller.gcode.tools import read_tool_table
    from gantry_sim.sim.api import run_program

    prog, lib, table = setup_files
    with pytest.raises(GcodeError, match="subroutine o<square> not found"):
        run_program(prog, machine=machine)
    placed = replace(
        machine, work=machine.work.placed((5.0, 6.0, 7.0)).with_tools(read_tool_table(table))
    )
    result = run_program(prog, machine=placed, search_path=[lib])
    assert result.moves[-1].end == (5.0, 6.0, 7.0)
    assert min(m.end[2] for m in result.moves) == -10.0
    (prog.parent / "square.ngc").write_text(SQUARE.replace("#1", "[#1 * 2]"))
    result = run_program(prog, machine=placed, search_path=[lib])  # its own folder first
    assert max(m.end[0] for m in result.moves) == 5.0 + 8.0


def test_a_runaway_loop_is_reported_without_a_second_pass(write_program, capsys):
    prog = write_program("o1 while [1]\nG91 G0 X1\no1 endwhile\nM2\n")
    assert main(["plan", str(prog), "--max-iterations", "100"]) == 2
    err = capsys.readouterr().err
    assert "more than 100 loop repetitions" in err and "--all-errors" not in err


@pytest.mark.parametrize("command", ["plan", "run"])
@pytest.mark.parametrize(
    ("sub", "fragment"),
    [
        # hostile-input review: these named the main program with the subroutine file's line
        ("o<far> sub\nG1 X1 F100\nG1 X5000\no<far> endsub\n", "outside the machine's travel"),
        ("o<far> sub\nG1 X1 F100\nG1 X[10**300]\no<far> endsub\n", "reaches 1e+300 mm"),
        ("o<far> sub\nG1 X1 F100\nG2 X1 I1 P[10**8]\no<far> endsub\n", "turns"),
    ],
)
def test_a_later_error_on_a_subroutine_files_line_names_that_file(
    tmp_path, capsys, command, sub, fragment
):
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "far.ngc").write_text(sub)
    prog = tmp_path / "part.ngc"
    prog.write_text("G21 G90\nG1 X0 F100\nG1 X2\no<far> call\nM2\n")
    out = ["--out", str(tmp_path / "out"), "--no-plots"] if command == "run" else []
    assert main([command, str(prog), "--subroutine-path", str(lib), *out]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{lib / 'far.ngc'}:3: error: ") and fragment in err, err


def test_the_simulated_time_bound_names_a_subroutine_files_line(tmp_path, capsys):
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "slow.ngc").write_text("o<slow> sub\nG1 X1 F100\nG1 X200 F0.01\no<slow> endsub\n")
    prog = tmp_path / "part.ngc"
    prog.write_text("G21 G90\nG1 X0 F100\nG1 X2\nG1 X3\no<slow> call\nM2\n")
    args = ["run", str(prog), "--subroutine-path", str(lib), "--out", str(tmp_path / "out")]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{lib / 'slow.ngc'}:3: error: the program takes at least "), err


def test_moves_of_a_subroutine_file_carry_its_name(setup_files):
    from gantry_sim.controller.gcode.interpreter import interpret

    prog, lib, _ = setup_files
    moves = list(interpret(MAIN, file=str(prog), search_path=(lib,)))
    assert [m.file for m in moves] == [None] + [str(lib / "square.ngc")] * 5
    assert [m.line for m in moves] == [4, 2, 3, 4, 5, 6]


def test_parse_names_the_subroutine_file_of_its_moves(setup_files, capsys):
    """`gantry parse` adds "file" to the motions whose line is a subroutine file's (the line
    counts in that file); the program's own motions have no such key, as before."""
    prog, lib, table = setup_files
    assert main(["parse", str(prog), *_options(lib, table)]) == 0
    rows = [json.loads(r) for r in capsys.readouterr().out.splitlines()]
    motions = [r for r in rows if r["kind"] in ("rapid", "linear")]
    assert [(r.get("file"), r["line"]) for r in motions] == [(None, 4)] + [
        (str(lib / "square.ngc"), k) for k in range(2, 7)
    ]


@pytest.mark.parametrize("kind", ["file", "missing"])
def test_a_subroutine_path_that_is_no_folder_is_refused(setup_files, tmp_path, capsys, kind):
    """--subroutine-path names a folder: a file, or a path that does not exist, is refused
    on the option (exit 2), where it was passed over without a word."""
    prog, _, table = setup_files
    where = table if kind == "file" else tmp_path / "no-such-folder"
    with pytest.raises(SystemExit) as info:  # argparse's refusal of an option
        main(["parse", str(prog), "--subroutine-path", str(where)])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "--subroutine-path" in err and "expected a folder" in err, err
    assert "Traceback" not in err
