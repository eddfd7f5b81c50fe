"""The README documents the program-setup options, the machine file's [tools] and [work], each
dialect's column and segmentation default, and shows the travel error as gantry prints it."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pytest

from gantry_sim.controller.errors import PlanningError
from gantry_sim.controller.gcode.dialects import DIALECTS
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.machine_work import SYSTEM_KEYS, TOOL_KEYS, WORK_KEYS
from gantry_sim.controller.planner.travel import check_travel
from gantry_sim.sim.commands.common import add_program_setup

README = (Path(__file__).resolve().parent.parent / "README.md").read_text()


def _squash(text: str) -> str:
    return " ".join(text.split())


def test_every_program_setup_option_is_in_the_options_table():
    parser = argparse.ArgumentParser(add_help=False)
    add_program_setup(parser)
    options = [o for a in parser._actions for o in a.option_strings if o.startswith("--")]
    assert len(options) == 4
    for option in options:
        assert re.search(rf"^\| `{option}[ `]", README, flags=re.M), option


def test_tools_and_work_keys_are_in_the_machine_file_table():
    row = next(r for r in README.splitlines() if r.startswith("| `[tools]` |"))
    for key in TOOL_KEYS:
        assert f"{key}" in row, key
    assert f"| `[work]` | `{SYSTEM_KEYS[0]}` .. `{SYSTEM_KEYS[-1]}` | mm |" in README
    for key in WORK_KEYS[len(SYSTEM_KEYS) :]:
        assert f"`{key}`" in README.split("| `[work]`", 1)[1].split("\n\n", 1)[0], key


def test_dialect_table_has_every_dialect_and_the_segmentation_row():
    table = README.split("## Dialects", 1)[1].split("\n\n", 3)[2]
    header = table.splitlines()[0]
    assert all(f"`{name}`" in header for name in DIALECTS)
    rows = table.splitlines()
    assert all(r.startswith("|") for r in rows)
    # one table to its last row: no blank line cuts the later rows off into a header-less table
    assert rows[-1].startswith("| controller's own lines |")
    assert any("arc segmentation default" in r and "0.002 mm" in r and "1 mm" in r for r in rows)


def test_the_travel_error_shown_is_the_one_gantry_prints(machine):
    shown = README.split("### Placement and frame", 1)[1].split("```\n", 2)[1].split("```", 1)[0]
    program = "G21 G90\nG0 Z100\nG0 X10 Y235\nG1 Z-5 F3000\nG1 X50\nG0 Z100\nM2\n"
    with pytest.raises(PlanningError) as info:
        check_travel(parse_program(program), machine.travel)
    err = info.value
    assert _squash(shown) == _squash(f"part.ngc:{err.line}: error: {err.message}")
