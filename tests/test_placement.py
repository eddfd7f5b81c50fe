"""A program leaving the travel is told its extent and the work offset that fits it, and that
offset (option or machine file) places it without editing it."""

from __future__ import annotations

import json
import re

import pytest

from gantry_sim.controller.errors import PlanningError
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.planner.travel import check_travel
from gantry_sim.sim.cli import main

#: written around its own origin: a Z100 clearance plane and a part up to Y235 (real examples)
CLEARANCE = "G21 G90\nG0 Z100\nG0 X10 Y235\nG1 Z-5 F3000\nG1 X50\nG0 Z100\nM2\n"


def test_error_names_the_extent_and_the_offset_that_fits(machine):
    with pytest.raises(PlanningError) as info:
        check_travel(parse_program(CLEARANCE), machine.travel)
    msg = info.value.message
    assert info.value.line == 2 and "reaches Z100.0000, outside the machine's travel" in msg
    assert "the program spans X 0..50, Y 0..235, Z -5..100 mm (work frame)" in msg
    # the smallest shift per axis: Y down by 35 (235 -> 200), Z down by 25 (100 -> 75)
    assert "moved by 0,-35,-25 mm it fits: place it with --work-offset=0,-35,-25" in msg


def test_error_says_when_no_offset_can_fit(machine):
    # the machine rests at the work origin before the program: not part of the program's extent
    moves = parse_program("G0 X100 Y-250\nG0 X50 Y-220\nM2\n")
    with pytest.raises(PlanningError) as info:
        check_travel(moves, machine.travel)
    assert "spans X 50..100, Y -250..-220, Z 0..0 mm" in info.value.message
    assert "--work-offset=0,50,0 " in info.value.message
    with pytest.raises(PlanningError) as info:
        check_travel(parse_program("G0 X-350\nG0 X350\nM2\n"), machine.travel)
    msg = info.value.message
    assert "cannot be placed within the travel: it is 700 mm in X (travel 600)" in msg
    assert "--work-offset" not in msg


def test_the_suggested_offset_places_the_program(write_program, tmp_path, capsys):
    prog = write_program(CLEARANCE)
    assert main(["plan", str(prog)]) == 2
    err = capsys.readouterr().err
    offset = re.search(r"--work-offset=(\S+)", err)
    assert offset is not None
    assert main(["plan", str(prog), "--work-offset", offset.group(1)]) == 0
    assert json.loads(capsys.readouterr().out)["moves"] == 5
    machine = tmp_path / "placed.toml"
    machine.write_text("[work]\ng54_mm = [0.0, -35.0, -25.0]\n")
    assert main(["plan", str(prog), "--machine", str(machine)]) == 0
    capsys.readouterr()
    out = tmp_path / "run"
    args = ["run", str(prog), "--machine", str(machine), "--out", str(out), "--no-plots"]
    assert main(args) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["moves"] == 5


def test_the_suggestion_after_a_work_offset_is_g54s_whole_origin(write_program, capsys):
    """--work-offset sets G54's origin: a program still outside with one given is told the
    origin that places it (the given one moved), not the shift alone, which alternated
    between two offsets neither of which fitted (a 108,052-line LightBurn raster)."""
    prog = write_program("G21 G90\nG0 X350 Y250\nM2\n")
    assert main(["plan", str(prog), "--work-offset=-50,0,0"]) == 2
    err = capsys.readouterr().err
    assert "moved by 0,-50,0 mm it fits: place it with --work-offset=-50,-50,0 " in err
    assert "where it is -50,0,0 now" in err
    assert main(["plan", str(prog), "--work-offset=-50,-50,0"]) == 0


@pytest.mark.parametrize("command", ["plan", "run"])
def test_a_program_beyond_the_cost_bound_and_the_travel_is_told_the_travel_first(
    command, write_program, tmp_path, capsys
):  # type: ignore[no-untyped-def]
    """--max-sim-s lifts the cost bound; nothing lifts the travel, so a program past both
    (a real one: X680 on a 600 mm machine, then hours at a slow feed) is told the travel's
    line first. Within the travel, the bound's refusal stands."""
    out = ["--out", str(tmp_path / ("x.npz" if command == "plan" else "run"))]
    if command == "run":
        out.append("--no-plots")
    prog = write_program("G21 G90\nG0 X400\nG1 X0 F1\nM2\n")
    assert main([command, str(prog), *out]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{prog}:2: error: rapid move reaches X400.0000, outside the machine")
    assert "--work-offset=-100,0,0" in err and "simulated time" not in err
    inside = write_program("G21 G90\nG0 X200\nG1 X0 F1\nM2\n")
    assert main([command, str(inside), *out]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{inside}:3: error: the program takes at least 12000.4 s")
    assert not (tmp_path / "x.npz").exists() and not (tmp_path / "run").exists()


def test_the_suggested_work_offset_is_an_option_that_parses(tmp_path, capsys):  # type: ignore[no-untyped-def]
    """The hint must work as printed: "--work-offset -100,0,0" is read by argparse as an option
    with no value ("expected one argument"); "--work-offset=-100,0,0" is not."""
    import re

    from gantry_sim.sim.cli import main

    prog = tmp_path / "p.ngc"
    prog.write_text("G21 G90\nG0 X350 Y10\nG1 X390 F1000\nM2\n")
    assert main(["plan", str(prog)]) == 2
    hint = re.search(r"place it with (--work-offset=\S+)", capsys.readouterr().err)
    assert hint is not None and hint.group(1) == "--work-offset=-90,0,0"
    assert main(["plan", str(prog), hint.group(1)]) == 0


def test_the_suggested_offset_places_a_program_planned_in_parts(tmp_path, capsys):  # type: ignore[no-untyped-def]
    """Marlin's M201 splits the plan into parts (controller/planner/limit_events.py); the hint
    is the whole program's, so the printed offset places all of it (it was the first part's:
    a LulzBot print's start code reached Y258, its end Y280, and the offset given for 258 left
    the end outside)."""
    prog = tmp_path / "p.gcode"
    prog.write_text("G21 G90\nG1 X0 Y258 F3000\nM201 X500 Y500\nG1 Y100\nG1 Y280\n")
    assert main(["plan", str(prog), "--dialect", "marlin"]) == 2
    hint = re.search(r"place it with (--work-offset=\S+)", capsys.readouterr().err)
    assert hint is not None and hint.group(1) == "--work-offset=0,-80,0"
    assert main(["plan", str(prog), "--dialect", "marlin", hint.group(1)]) == 0


@pytest.mark.parametrize("command", ["plan", "run"])
def test_no_offset_is_suggested_where_the_program_sets_its_origin_from_the_tool(
    command, write_program, tmp_path, capsys
):
    """A gSender insole job (`G10 L20 P1 ... `) and a dxf2gcode file (`G92 X0 Y0`) set their
    origin from where the tool stands, which a work offset does not move: the offset the hint
    suggested failed the same way again. Set after a move, the origin moves with G54 and the
    hint holds."""
    out = ["--out", str(tmp_path / "o"), "--no-plots"] if command == "run" else []
    for setting in ("G10 L20 P1 X0 Y0 Z0", "G92 X0 Y0"):
        prog = write_program(f"G21 G90\n{setting}\nG0 X0 Y-250\nM2\n")
        assert main([command, str(prog), *out]) == 2
        err = capsys.readouterr().err
        assert "Y-250.0000, outside the machine's travel" in err
        assert "a work offset does not place it" in err and "--work-offset=" not in err
    prog = write_program("G21 G90\nG0 X10 Y10\nG92 X0 Y0\nG0 Y-250\nM2\n")
    assert main([command, str(prog), *out]) == 2
    hint = re.search(r"place it with (--work-offset=\S+)", capsys.readouterr().err)
    assert hint is not None and hint.group(1) == "--work-offset=0,40,0"
    assert main([command, str(prog), hint.group(1), *out]) == 0
