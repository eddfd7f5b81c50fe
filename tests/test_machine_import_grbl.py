"""`gantry machine import grbl`: the `$#` report placed in the machine file's frame (and read in
inches with `$13=1`), grbl 0.8 dumps refused, console captures with grbl's welcome banner and
unused axes (`$132=0`) read. The dumps are our own text, in grbl 1.1 / 0.8c's formats."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.errors import ConfigError
from gantry_sim.controller.machine_import.common import Target
from gantry_sim.controller.machine_import.grbl_settings import import_grbl
from gantry_sim.models import DEFAULT_MACHINE
from gantry_sim.sim.cli import main

TARGET = Target(mass_kg=(17.0, 60.0, 9.0), joint_range_mm=((-300, 300), (-200, 200), (-75, 75)))

#: a 838 x 838 x 80 mm machine; G54 in the middle of X/Y, 7.5 mm above Z's bottom; G28 5 mm
#: (Z 1 mm) short of the home switches; a G92 shift of X 1 mm
BIG_MACHINE = (
    "$110=5000\n$111=5000\n$112=500\n$120=500\n$121=500\n$122=50\n"
    "$130=838\n$131=838\n$132=80\n"
    "[G54:-419.000,-419.000,-72.500]\n[G28:-5.000,-5.000,-1.000]\n[G92:1.000,0.000,0.000]\n"
)


def _dump(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "grbl.txt"
    path.write_text(text)
    return path


def test_offsets_report_is_moved_from_grbl_machine_coordinates_into_the_frame(tmp_path):
    """grbl's machine space is -L..0 ($130-$132); [travel] is -L/2..L/2: m -> m + L/2. X and Y
    (838 mm) are shortened to the model's joint range about their middle, which keeps the frame:
    the shift stays L/2 = 419 mm, not the shortened travel's half."""
    imp = import_grbl(_dump(tmp_path, BIG_MACHINE), TARGET)
    v = imp.values
    assert v["travel"] == {"min_mm": [-300.0, -200.0, -40.0], "max_mm": [300.0, 200.0, 40.0]}
    assert "sim" not in v  # the travel's middle is the joint range's: origin unchanged
    assert v["work"]["g54_mm"] == pytest.approx([0.0, 0.0, -32.5])
    assert v["work"]["g28_mm"] == pytest.approx([414.0, 414.0, 39.0])
    assert v["work"]["g92_mm"] == pytest.approx([1.0, 0.0, 0.0])  # a work offset: as printed
    assert any("+ L/2" in a for a in imp.assumed)
    # G28 at X 414 lies beyond the shortened X travel (300): said, not hidden
    assert any(a.startswith("g28_mm") and "outside [travel]" in a for a in imp.assumed)


def test_offsets_at_grbl_machine_zero_are_written(tmp_path):
    """grbl's unset G55 and G30 are machine zero, the home corner: L/2 in the frame, not the
    bundled zero (the travel's middle)."""
    dump = "$130=200\n$131=100\n$132=60\n[G55:0.000,0.000,0.000]\n[G30:0.000,0.000,0.000]\n"
    work = import_grbl(_dump(tmp_path, dump), TARGET).values["work"]
    assert work == {"g55_mm": [100.0, 50.0, 30.0], "g30_mm": [100.0, 50.0, 30.0]}


def test_offsets_without_the_travel_are_not_placed_but_g92_is(tmp_path):
    dump = "$130=200\n$131=200\n[G54:-100.000,-100.000,-5.000]\n[G92:0.000,2.000,0.000]\n"
    imp = import_grbl(_dump(tmp_path, dump), TARGET)
    assert imp.values["work"] == {"g92_mm": [0.0, 2.0, 0.0]}
    assert "travel" not in imp.values
    assert any("G54-G59, G28, G30 not written" in a for a in imp.assumed)


def test_offsets_report_in_inches_with_13_set(tmp_path):
    """$13=1: grbl prints the $# values in inches (4 decimals), its $$ settings in mm."""
    dump = "$13=1\n$130=200\n$131=200\n$132=100\n[G54:-3.9370,-1.9685,-0.3937]\n"
    imp = import_grbl(_dump(tmp_path, dump), TARGET)
    # machine mm (-100, -50, -10), + L/2 = (100, 100, 50); 4 inch decimals are 0.00254 mm steps,
    # rounded to grbl's 3 mm decimals
    assert imp.values["work"]["g54_mm"] == [0.0, 50.0, 40.0]
    note = next(n for n in imp.not_mapped if n.startswith("$13=1"))
    assert "inches" in note and "display only" not in note


@pytest.mark.parametrize(
    ("text", "line", "what"),
    [
        # grbl 0.8c's dump, as its report.c prints it
        ("$0=755.906 (x, step/mm)\n$1=755.906 (y, step/mm)\n", 1, "$0"),
        ("$8=50.000 (acceleration, mm/sec^2)\n$9=0.050 (junction deviation, mm)\n", 1, "$8"),
        ("$9=0.050 (junction deviation, mm)\n", 1, "$9"),
        ("$11=0.010\n$10=0.100 (arc, mm/segment)\n", 2, "$10"),
        ("$11=25 (n-arc correction, int)\n", 1, "$11"),
        ("$12=3 (n-decimals, int)\n", 1, "$12"),
        # grbl 0.7 / 0.8 alpha
        ("$0 = 755.906 (steps/mm x)\n", 1, "$0"),
        ("$6 = 0.1 (mm/arc segment)\n", 1, "$6"),
    ],
)
def test_a_grbl_0_8_dump_is_refused_at_its_line(tmp_path, capsys, text, line, what):
    path = _dump(tmp_path, text)
    assert main(["machine", "import", "grbl", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}:{line}: error: {what} " in err and "Traceback" not in err
    assert "grbl 0.8" in err and "gantry-sim reads grbl 0.9 and 1.1" in err


@pytest.mark.parametrize(
    "text",
    [
        "$11=0\n$12=0.002\n",  # no descriptions, no $100+
        # grbl 0.9g's descriptions
        "$11=0.010 (junction deviation, mm)\n$12=0.002 (arc tolerance, mm)\n"
        "$100=250.000 (x, step/mm)\n",
        "$100=80 (X steps/mm)\n$11=0.02 (Junction deviation)\n$12=0.002 (Arc tolerance)\n",
    ],
)
def test_grbl_0_9_and_1_1_dumps_with_or_without_descriptions_are_read(tmp_path, text):
    assert "path" in import_grbl(_dump(tmp_path, text), TARGET).values


@pytest.mark.parametrize(
    "banner",
    [
        "Grbl 1.1h ['$' for help]",
        "Grbl 0.9j ['$' for help]",
        "GrblHAL 1.1f ['$' or '$HELP' for help]",
        "grbl 1.1f ['$' for help]",
    ],
)
def test_a_console_capture_with_the_welcome_banner_is_read(tmp_path, banner):
    dump = f"\n{banner}\n$110=600.000\n$111=600.000\n$112=300.000\nok\n"
    imp = import_grbl(_dump(tmp_path, dump), TARGET)
    assert imp.values["limits"]["max_velocity_mm_per_s"] == [10.0, 10.0, 5.0]


def test_a_line_that_only_looks_like_a_banner_is_still_refused(tmp_path):
    with pytest.raises(ConfigError, match="not a grbl setting line") as info:
        import_grbl(_dump(tmp_path, "$110=600\nGrbl 1.1h\n"), TARGET)
    assert info.value.line == 2


def test_an_unused_axis_set_to_zero_keeps_its_group_bundled(tmp_path):
    """A 2-axis laser: $112, $122, $132 = 0 (grbl accepts 0): those groups are not written."""
    dump = (
        "$110=6000.000\n$111=6000.000\n$112=0.000\n$120=800.000\n$121=800.000\n$122=0.000\n"
        "$130=400.000\n$131=300.000\n$132=0.000\n$11=0.010\n"
    )
    imp = import_grbl(_dump(tmp_path, dump), TARGET)
    assert "limits" not in imp.values and "travel" not in imp.values
    assert imp.values["path"] == {"mode": "G64", "tolerance_mm": 0.01}
    for n in (112, 122, 132):
        assert any(f"${n}=0" in a and "unused" in a for a in imp.assumed), n
    assert not any("incomplete" in a for a in imp.assumed)


def test_a_setting_number_too_long_for_int_is_a_malformed_line(tmp_path, capsys):
    """5000 digits: int() refuses more than 4300 (it was an internal error, not exit 2)."""
    path = _dump(tmp_path, "$110=500\n$" + "1" * 5000 + "=5\n")
    assert main(["machine", "import", "grbl", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}:2: error: not a grbl setting line" in err and "internal error" not in err


def test_a_negative_rate_is_still_refused(tmp_path, capsys):
    path = _dump(tmp_path, "$110=500\n$111=500\n$112=-5\n")
    assert main(["machine", "import", "grbl", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}:3: error: $112 = -5: must be > 0" in err and "Traceback" not in err


def test_cli_writes_the_offsets_the_machine_file_loads(tmp_path, capsys):
    """End to end: the file written loads, with the $# offsets in the machine file's frame."""
    src = _dump(tmp_path, BIG_MACHINE + "[TLO:0.000]\n[PRB:0.000,0.000,0.000:0]\nok\n")
    out = tmp_path / "imported.toml"
    assert main(["machine", "import", "grbl", str(src), "--out", str(out)]) == 0
    machine = load_machine_config(DEFAULT_MACHINE, out)
    assert machine.work.systems_mm[0] == pytest.approx((0.0, 0.0, -32.5))
    assert machine.work.g28_mm == pytest.approx((414.0, 414.0, 39.0))
    assert machine.work.g92_mm == pytest.approx((1.0, 0.0, 0.0))
    assert machine.work.g30_mm == (0.0, 0.0, 0.0)  # not in the report: bundled
    assert tomllib.loads(out.read_text())["travel"]["max_mm"] == [300.0, 200.0, 40.0]
    assert "+ L/2" in capsys.readouterr().out  # the printed notes say how they were placed


@pytest.mark.parametrize(
    ("text", "line", "what"),
    [
        ("$110=500\n$111=1e308\n$112=500\n", 2, "$111=1e+308 gives [limits] max_velocity_mm_per_s"),
        ("$120=5\n$121=5\n$122=1e-9\n", 3, "$122=1e-09 gives [limits] max_acceleration_mm_per_s2"),
        ("$12=100\n", 1, "$12=100 gives [segmentation] chord_tolerance_mm = 100, which must be"),
        ("$11=50\n", 1, "$11=50 gives [path] tolerance_mm = 50, which must be"),
    ],
)
def test_a_setting_the_machine_file_cannot_hold_is_an_error_at_its_line(
    tmp_path, capsys, text, line, what
):
    # it had been "it maps to an invalid machine file", naming no line or setting
    path = _dump(tmp_path, text)
    assert main(["machine", "import", "grbl", str(path)]) == 2
    assert f"{path}:{line}: error: {what}" in capsys.readouterr().err


def test_a_huge_bad_value_is_shown_cut_short(tmp_path, capsys):
    # a million-digit value had been echoed whole: a 1 MB error message
    path = _dump(tmp_path, "$110=" + "9" * 1_000_000 + "x\n")
    assert main(["machine", "import", "grbl", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}:1: error: $110 = " in err and len(err) < 400


def test_an_offset_no_machine_file_holds_is_an_error_at_its_line(tmp_path, capsys):
    # it had been refused only as the written file was loaded back, naming no line
    path = _dump(tmp_path, "$130=200\n$131=200\n$132=200\n[G54:1e300,0.000,0.000]\n")
    assert main(["machine", "import", "grbl", str(path)]) == 2
    assert f"{path}:4: error: [G54:...]: each number must be within" in capsys.readouterr().err
