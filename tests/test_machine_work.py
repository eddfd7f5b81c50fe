"""The machine file's [tools] and [work]: read, validated, and used by parse/plan/run unless a
command-line option overrides them."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.errors import ConfigError
from gantry_sim.controller.gcode.tools import Tool
from gantry_sim.controller.machine_work import NO_WORK
from gantry_sim.models import DEFAULT_MACHINE
from gantry_sim.sim.api import run_program
from gantry_sim.sim.cli import main

WORK = """[tools]
1 = { length_mm = 10.0, diameter_mm = 6.0 }
7 = { length_mm = 25.5 }

[work]
g54_mm = [100.0, -50.0, -20.0]
g55_mm = [1.0, 2.0, 3.0]
g28_mm = [0.0, 0.0, 40.0]
"""


def _machine_file(tmp_path: Path, text: str = WORK) -> Path:
    path = tmp_path / "machine.toml"
    path.write_text(text)
    return path


def _ends(capsys) -> list[list[float]]:
    return [json.loads(line)["end"] for line in capsys.readouterr().out.splitlines()]


def test_bundled_machine_has_no_tools_and_no_offsets(machine):
    assert machine.work == NO_WORK and machine.work.tool_table() is None
    assert set(machine.work.parameters().values()) == {0.0}


def test_tools_and_work_are_read_and_laid_over_the_bundled_file(tmp_path):
    cfg = load_machine_config(DEFAULT_MACHINE, _machine_file(tmp_path))
    assert cfg.work.tool_table() == {1: Tool(1, 10.0, 6.0), 7: Tool(7, 25.5, 0.0)}
    assert cfg.work.systems_mm[:2] == ((100.0, -50.0, -20.0), (1.0, 2.0, 3.0))
    assert cfg.work.g28_mm == (0.0, 0.0, 40.0) and cfg.work.g92_mm == (0.0, 0.0, 0.0)
    params = cfg.work.parameters()
    assert [params[5221 + i] for i in range(3)] == [100.0, -50.0, -20.0]  # G54
    assert [params[5241 + i] for i in range(3)] == [1.0, 2.0, 3.0]  # G55
    assert params[5163] == 40.0 and params[5210] == 0.0  # G28 Z; no G92 in effect


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("[tools]\nT1 = { length_mm = 1.0 }\n", "[tools] 'T1': a tool's key is its number"),
        ("[tools]\n0 = { length_mm = 1.0 }\n", "integer 1..99999"),
        ("[tools]\n1 = 5.0\n", "[tools] 1 must be a table { length_mm = L, diameter_mm = D }"),
        (
            "[tools]\n1 = { length_mm = 1.0, radius_mm = 2 }\n",
            "unknown key 'radius_mm' in [tools] 1",
        ),
        (
            "[tools]\n1 = { length_mm = 1.0, diameter_mm = -2 }\n",
            "diameter_mm = -2: must be a finite number [mm], >= 0",
        ),
        ("[tools]\n1 = { length_mm = nan }\n", "length_mm = nan: must be a finite number"),
        ("[work]\ng54_mm = [1, 2]\n", "[work] g54_mm = [1, 2]: must be a list of 3 finite numbers"),
        ("[work]\ng52_mm = [1, 2, 3]\n", "unknown key 'g52_mm' in [work]; valid keys: g54_mm"),
        ("work = 3\n", "'work' must be a table [work]"),
        (
            "[offsets]\n",
            "valid sections: [limits], [travel], [segmentation], [path], [servo], [sim], [tools], [work]",
        ),
    ],
)
def test_bad_tools_and_work_name_the_key(tmp_path, text, fragment):
    with pytest.raises(ConfigError) as info:
        load_machine_config(DEFAULT_MACHINE, _machine_file(tmp_path, text))
    assert fragment in info.value.message
    assert info.value.file == str(tmp_path / "machine.toml")


def test_parse_uses_the_machine_file_unless_an_option_overrides_it(write_program, tmp_path, capsys):
    machine = _machine_file(tmp_path)
    prog = write_program("T7 M6\nG43\nG0 X1 Y0\nG55 G0 X0 Y0 Z0\nG28\nM2\n")
    assert main(["parse", str(prog), "--machine", str(machine)]) == 0
    # G54 at (100, -50, -20); G43 with tool 7: the tip reads Z - 25.5; G28 goes to the stored
    # spindle position, the tip 25.5 below it (after rs274's zero-length intermediate move)
    home = [[1.0, 2.0, 3.0], [0.0, 0.0, 14.5]]
    assert _ends(capsys) == [[101.0, -50.0, -25.5], [1.0, 2.0, 3.0], *home]
    table = tmp_path / "tool.tbl"
    table.write_text("T7 P1 Z2\n")
    args = ["parse", str(prog), "--machine", str(machine), "--tool-table", str(table)]
    assert main([*args, "--work-offset", "0,0,0"]) == 0
    assert _ends(capsys) == [[1.0, 0.0, -2.0], [1.0, 2.0, 3.0], [1.0, 2.0, 3.0], [0.0, 0.0, 38.0]]


def test_g92_and_g30_from_the_machine_file(write_program, tmp_path, capsys):
    machine = _machine_file(tmp_path, "[work]\ng92_mm = [1.0, 2.0, 3.0]\ng30_mm = [9, 8, 7]\n")
    prog = write_program("G0 X0 Y0 Z0\nG92.1\nG0 X0 Y0 Z0\nG92.3\nG0 X5\nG30\nM2\n")
    assert main(["parse", str(prog), "--machine", str(machine)]) == 0
    # the G92 offset is in effect from the start; G92.1 clears it and G92.3 finds nothing left
    ends = _ends(capsys)
    assert ends == [[1.0, 2.0, 3.0], [0.0, 0.0, 0.0], [5.0, 0.0, 0.0], [5.0, 0.0, 0.0], [9, 8, 7]]


def test_plan_and_run_use_the_machine_files_placement_and_tools(write_program, tmp_path, capsys):
    machine_file = _machine_file(
        tmp_path, "[tools]\n3 = { length_mm = 5.0 }\n[work]\ng54_mm = [0.0, 0.0, -60.0]\n"
    )
    prog = write_program("G0 Z100\nT3 M6\nG43\nG0 X10\nG1 Y5 F3000\nM2\n")
    assert main(["plan", str(prog)]) == 2  # Z100 leaves the bundled travel (Z up to 75)
    capsys.readouterr()
    assert main(["plan", str(prog), "--machine", str(machine_file)]) == 0
    assert json.loads(capsys.readouterr().out)["moves"] == 3
    cfg = load_machine_config(DEFAULT_MACHINE, machine_file)
    result = run_program(prog, machine=cfg)
    assert [m.end for m in result.moves] == [
        (0.0, 0.0, 40.0),
        (10.0, 0.0, 35.0),  # G43 with tool 3: the tip reads Z - 5
        (10.0, 5.0, 35.0),
    ]
    assert result.trace.ref[-1] == pytest.approx([10.0, 5.0, 35.0])


def test_sweep_fingerprint_of_a_machine_file_is_stable_across_processes(tmp_path):
    """A resumed sweep runs in a new process (another hash seed): the machine's repr, and so the
    journal's fingerprint, must not depend on set order."""
    import subprocess
    import sys

    path = _machine_file(tmp_path, WORK + "[segmentation]\nchord_tolerance_mm = 0.002\n")
    code = (
        "import sys; from pathlib import Path; "
        "from gantry_sim.controller.config import load_machine_config; "
        "from gantry_sim.models import DEFAULT_MACHINE; "
        "from gantry_sim.sim.sweep.grid import fingerprint; "
        "print(fingerprint('G0 X1', 'linuxcnc', "
        "load_machine_config(DEFAULT_MACHINE, Path(sys.argv[1])), ((Path('lib'),), 10)))"
    )
    tags = {
        subprocess.run(
            [sys.executable, "-c", code, str(path)],
            env={"PYTHONHASHSEED": str(seed), "PATH": ""},
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        for seed in range(6)
    }
    assert len(tags) == 1 and len(tags.pop().strip()) == 16


def test_ballbar_ignores_the_machine_files_offsets(tmp_path, machine):
    """The ballbar program is written in the work frame around --centre; [work] offsets must
    not move the circle away from the centre its analysis uses."""
    from gantry_sim.sim.circular.ballbar import run_ballbar

    shifted = load_machine_config(
        DEFAULT_MACHINE, _machine_file(tmp_path, "[work]\ng54_mm = [40.0, 0.0, 0.0]\n")
    )
    plain = run_ballbar(machine, "XY", 10.0, 2000.0)
    moved = run_ballbar(shifted, "XY", 10.0, 2000.0)
    assert moved.ccw.circular_deviation_um == pytest.approx(plain.ccw.circular_deviation_um)
    assert plain.ccw.circular_deviation_um < 50.0
