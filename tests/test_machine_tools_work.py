"""`gantry machine show` and `gantry machine import` cover the machine file's [tools] and [work];
Marlin's G28 goes to the machine's home ([work] g28_mm) and clears the homed axes' G92 shift."""

from __future__ import annotations

import json
import shutil
import tomllib
from pathlib import Path

import pytest

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.gcode.interpreter import interpret
from gantry_sim.controller.machine_import.common import Target
from gantry_sim.controller.machine_import.grbl_settings import import_grbl
from gantry_sim.controller.machine_import.linuxcnc_ini import import_linuxcnc
from gantry_sim.models import DEFAULT_MACHINE
from gantry_sim.sim.cli import main

DATA = Path(__file__).resolve().parent / "data" / "machine_import"
TARGET = Target(mass_kg=(17.0, 60.0, 9.0), joint_range_mm=((-300, 300), (-200, 200), (-75, 75)))

WORK_FILE = """
[tools]
1 = { length_mm = 12.5, diameter_mm = 6.0 }
4 = { length_mm = 40.0, diameter_mm = 10.0, x_mm = 0.5 }

[work]
g55_mm = [100.0, -20.0, -5.0]
g28_mm = [10.0, 20.0, 30.0]
"""


def test_show_lists_the_tool_table_and_the_offsets_set(tmp_path, capsys):
    mf = tmp_path / "m.toml"
    mf.write_text(WORK_FILE)
    assert main(["machine", "show", "--machine", str(mf), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["tools"] == [
        {"number": 1, "length_mm": 12.5, "diameter_mm": 6.0, "x_mm": 0.0, "y_mm": 0.0},
        {"number": 4, "length_mm": 40.0, "diameter_mm": 10.0, "x_mm": 0.5, "y_mm": 0.0},
    ]
    assert info["work"]["g55_mm"] == [100.0, -20.0, -5.0]
    assert info["work"]["g54_mm"] == [0.0, 0.0, 0.0]
    assert info["work"]["g28_mm"] == [10.0, 20.0, 30.0]
    assert main(["machine", "show", "--machine", str(mf)]) == 0
    out = capsys.readouterr().out
    assert "tools [mm]" in out and "40.0000" in out
    assert "g55_mm" in out and "g54_mm" not in out.split("tools [mm]")[1]


def test_show_says_when_there_is_no_tool_table(capsys):
    assert main(["machine", "show"]) == 0
    out = capsys.readouterr().out
    assert "none: every tool has zero length" in out and "all zero" in out


def _linuxcnc_config(tmp_path: Path, var: str) -> Path:
    """hm2_servo_5i20.ini names TOOL_TABLE = tool.tbl and PARAMETER_FILE = hm2-servo.var."""
    ini = tmp_path / "mill.ini"
    shutil.copy(DATA / "hm2_servo_5i20.ini", ini)
    (tmp_path / "tool.tbl").write_text(
        "T1 P1 Z0.511 D0.125 ;1/8 end mill\nT7 P2 X0.1 Z2 D0.5\nT0 P0 Z0 ;empty\n"
    )
    (tmp_path / "hm2-servo.var").write_text(var)
    return ini


def test_linuxcnc_import_reads_the_tool_table_and_the_parameter_file(tmp_path, capsys):
    """hm2_servo_5i20.ini is an inch machine: tool.tbl and linuxcnc.var are in inches."""
    var = "5161\t1.0\n5163\t2.0\n5210\t1\n5211\t0.5\n5221\t10\n5222\t-1\n5250\t30\n5241\t0\n"
    ini = _linuxcnc_config(tmp_path, var)
    imp = import_linuxcnc(ini, TARGET)
    tools = imp.values["tools"]
    assert tools["1"] == {"length_mm": pytest.approx(0.511 * 25.4), "diameter_mm": 3.175}
    assert tools["7"]["x_mm"] == pytest.approx(2.54) and "0" not in tools
    work = imp.values["work"]
    assert work["g54_mm"] == pytest.approx([254.0, -25.4, 0.0])
    assert work["g28_mm"] == pytest.approx([25.4, 0.0, 50.8])
    assert work["g92_mm"] == pytest.approx([12.7, 0.0, 0.0])
    assert "g55_mm" not in work  # all zero: not written
    assert any("G55 XY rotation 30" in n for n in imp.not_mapped)
    assert any("T0" in n for n in imp.not_mapped)
    out = tmp_path / "imported.toml"
    assert main(["machine", "import", "linuxcnc", str(ini), "--out", str(out)]) == 0
    machine = load_machine_config(DEFAULT_MACHINE, out)
    assert machine.work.tool_table()[7].x_mm == pytest.approx(2.54)
    assert machine.work.systems_mm[0] == pytest.approx((254.0, -25.4, 0.0))
    assert tomllib.loads(out.read_text())["tools"]["1"]["diameter_mm"] == 3.175


def test_linuxcnc_import_without_the_files_says_so(tmp_path):
    ini = _linuxcnc_config(tmp_path, "")
    (tmp_path / "hm2-servo.var").unlink()
    (tmp_path / "tool.tbl").unlink()
    imp = import_linuxcnc(ini, TARGET)
    assert "tools" not in imp.values and "work" not in imp.values
    assert any("TOOL_TABLE tool.tbl: no such file" in a for a in imp.assumed)
    assert any("PARAMETER_FILE hm2-servo.var: no such file" in a for a in imp.assumed)


def test_grbl_import_takes_the_offsets_report(tmp_path):
    dump = tmp_path / "grbl.txt"
    dump.write_text(
        (DATA / "grbl_1.1_generic.txt").read_text()
        + "[G54:-95.000,-102.500,-100.000]\n[G55:0.000,0.000,0.000]\n[G28:-99.000,-98.000,-103.000]\n"
        "[G92:0.000,0.000,0.000]\n[TLO:0.000]\n[PRB:0.000,0.000,0.000:0]\n"
    )
    work = import_grbl(dump, TARGET).values["work"]
    # grbl's $# positions are machine coordinates, -L..0 after homing (travel 200, 200, 200
    # mm, Z shortened to the model's 150 mm about its middle): + L/2 in the machine file's
    # -L/2..L/2 frame, L the whole $13x length; G55 at grbl's machine zero is the
    # travel's far corner, not the work origin (they had been taken as work coordinates)
    assert work == {
        "g54_mm": [5.0, -2.5, 0.0],
        "g55_mm": [100.0, 100.0, 100.0],
        "g28_mm": [1.0, 2.0, -3.0],
    }


def test_marlin_g28_goes_to_the_machines_home_and_clears_g92_of_homed_axes(tmp_path):
    """Marlin's set_axis_is_at_home: the axis is at its home position and its G92 shift is 0."""
    program = "G92 X5\nG1 X1 F100\nG28 X\nG1 X2 Y3\nG28\n"
    bundled = list(interpret(program, dialect="marlin"))
    assert bundled[1].end == (0.0, 0.0, 0.0)  # no g28_mm: the work origin
    assert bundled[2].end == (2.0, 3.0, 0.0)  # X's G92 shift is gone after homing X
    mf = tmp_path / "m.toml"
    mf.write_text("[work]\ng28_mm = [10.0, 20.0, 30.0]\n")
    machine = load_machine_config(DEFAULT_MACHINE, mf)
    moves = list(interpret(program, dialect="marlin", parameters=machine.work.parameters()))
    assert moves[0].end == (-4.0, 0.0, 0.0)
    assert moves[1].end == (10.0, 0.0, 0.0)  # only X homed, to its home
    assert moves[3].end == (10.0, 20.0, 30.0)


def test_m6_sets_the_tool_parameters_in_the_tables_units() -> None:
    """rs274's set_tool_parameters at M6: #5400 the tool, #5401-#5403 its offsets, #5410 its
    diameter, the tool table's own numbers (LinuxCNC's machine units: mm here), which G20/G21
    leave as they are (rs274 -g, whose table is in inches, reads 0.125 for T1's diameter in a
    G21 program: tests/data/rs274/programs/tool_parameters_in_table_units.ngc); M61 leaves
    them."""
    from gantry_sim.controller.gcode.interpreter import interpret
    from gantry_sim.controller.gcode.tools import Tool

    tools = {3: Tool(3, 25.4, 6.35, 1.0, -2.0)}

    def parse_program(text: str, tools: dict) -> list:
        return list(interpret(text, tools=tools))

    text = "G21\nT3 M6\nG0 X#5400 Y#5401 Z#5403\nG0 X#5402 Y#5410\nG20\nG0 Z#5403\nM2\n"
    moves = parse_program(text, tools=tools)
    assert [m.end for m in moves[:2]] == [(3.0, 1.0, 25.4), (-2.0, 6.35, 25.4)]
    assert moves[2].end[2] == pytest.approx(25.4 * 25.4)  # G20: #5403 still reads 25.4
    inch_table = {3: Tool(3, 25.4, 6.35, 1.0, -2.0, unit_mm=25.4)}
    moves = parse_program(text, tools=inch_table)
    assert moves[1].end == pytest.approx((-2.0 / 25.4, 6.35 / 25.4, 1.0))
    assert parse_program("M61 Q3\nG0 X#5400\nM2\n", tools=tools)[0].end == (0.0, 0.0, 0.0)
