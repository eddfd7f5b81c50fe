"""Tool offsets and G52 as LinuxCNC 2.9's rs274 makes them (controller/gcode/tool_offsets.py,
tool_entries.py, coords.py). Every expected number below is what `rs274 -g` printed for the same
program with tests/data/rs274/rs274_default_tools.tbl (tool 1: Z 12.9794 mm, tool 2: 2.54 mm);
the differential corpus (gen_tofs_*, gen_frame_*) checks the same rules on 240 programs."""

from __future__ import annotations

from pathlib import Path

import pytest

from gantry_sim.controller.gcode.interpreter import interpret
from gantry_sim.controller.gcode.tools import read_tool_table

TOOLS = read_tool_table(
    Path(__file__).parent / "data" / "rs274" / "rs274_default_tools.tbl", units_mm=25.4
)


def ends(program: str) -> list[tuple[float, float, float]]:
    return [m.end for m in interpret(program, tools=TOOLS)]


def test_g43_1_sets_given_components_and_its_axis_words_do_not_move():
    got = ends("G21 G90\nG43.1 Z2\nG0 X1\nG43.1 X1\nG0 X2\nG49\nG0 X3\nM2\n")
    # rs274: X1 Z-2, then (G43.1 X1 keeps Z2) X2 Z-2, then after G49 X3 Z0
    assert got == [(1.0, 0.0, -2.0), (2.0, 0.0, -2.0), (3.0, 0.0, 0.0)]


def test_g43_2_adds_the_tools_offset():
    got = ends("G21 G90\nG0 X1\nG43.2 H2\nG43.2 H2\nG0 X2\nM2\n")
    assert got[1] == pytest.approx((2.0, 0.0, -5.08))


def test_m61_does_not_load_the_tool_g43_on_a_later_line_reads_the_spindle():
    assert ends("M61 Q2\nG43\nG0 X1 Y1\nM2\n") == [(1.0, 1.0, 0.0)]
    # on the M61 line itself G43 reads the tool's pocket (2.54 mm), but rs274 re-reads its point
    # after the change, so the program's Z stays; G49 then takes the 2.54 mm off again
    got = ends("M61 Q2 G43\nG0 X1\nG49\nG0 X2\nM2\n")
    assert got[0] == (1.0, 0.0, 0.0) and got[1] == pytest.approx((2.0, 0.0, 2.54))
    # T0 M6 leaves tool 1 in the spindle; H0 is the spindle's entry
    got = ends("G21\nT1 M6\nG43 H0\nG0 X1\nT0 M6\nG43\nG0 X2\nM2\n")
    assert got[0] == pytest.approx((1.0, 0.0, -12.9794), abs=1e-4)
    assert got[1] == pytest.approx((2.0, 0.0, -12.9794), abs=1e-4)


def test_g10_l1_on_the_loaded_tool_changes_the_spindles_entry():
    got = ends("G21\nT1 M6\nG10 L1 P1 Z3\nG43\nG0 X1\nM61 Q2\nG43\nG0 X2\nM2\n")
    assert got[0] == pytest.approx((1.0, 0.0, -3.0)) and got[1] == pytest.approx((2.0, 0.0, -3.0))


def test_g10_l11_touches_off_in_g59_3_without_g92():
    # spindle at Z5 (no offsets); G59.3's origin Z1; G92 Z shift is ignored by L11
    program = "G21\nG10 L2 P9 Z1\nG0 Z5\nG92 Z0\nG10 L11 P2 Z2\nT2 M6 G43\nG0 X1\nM2\n"
    got = ends(program)
    # L11: length = (5 - 1) - 2 = 2 mm (rs274: SET_TOOL_TABLE_ENTRY ... 0.0787 in); the G43 on
    # the M6 line is undone when rs274 re-reads its point after the change: X1 at Z0 + G92 5
    assert got[-1] == pytest.approx((1.0, 0.0, 5.0))


def test_g52_sets_the_offset_itself_and_g92_1_clears_it():
    got = ends("G21 G90\nG0 X1 Y1\nG52 X10\nG0 X2\nG92 X5\nG0 X3\nG92.1\nG0 X5\nM2\n")
    # rs274: G52 X10 -> offset 10 (X2 is at 12); G92 X5 at program X2 -> offset 7 (X3 at 10)
    assert [e[0] for e in got] == pytest.approx([1.0, 12.0, 10.0, 5.0])


def test_xz_arc_in_a_system_turned_a_quarter_lies_in_yz():
    """G18 G2 from X10 to X20 about X15 bulges to Z-5 (clockwise seen from +Y); turned by 90
    degrees its X runs along Y: the same half circle in YZ, counter-clockwise seen from +X."""
    (_, arc) = list(interpret("G21\nG10 L2 P1 R90\nG0 X10\nG18 G2 X20 I5 K0 F100\nM2\n"))
    assert (arc.plane, arc.direction) == ("YZ", "ccw")
    assert arc.center == pytest.approx((0.0, 15.0, 0.0), abs=1e-12)
    assert arc.angle == pytest.approx(3.141592653589793)


def test_xz_arc_in_a_system_turned_by_other_angles_is_refused():
    from gantry_sim.controller.errors import GcodeError

    with pytest.raises(GcodeError, match="vertical plane turned by the rotation"):
        list(interpret("G21\nG10 L2 P1 R30\nG0 X10\nG18 G2 X20 I5 K0 F100\nM2\n"))


@pytest.mark.parametrize(
    "block", ["T2147483648", "T99999999999999999999 M6", "M61 Q2147483648", "G43 H2147483648"]
)
def test_a_tool_number_beyond_a_c_int_is_refused(block):
    """rs274 reads T, H and M61's Q into a C int: `rs274 -g` (LinuxCNC 2.9, 2026-12-02) refused
    each of these blocks ("Negative tool id", "Need non-negative Q-word", "Negative h word"),
    and looked T2147483647 up as any other tool."""
    from gantry_sim.controller.errors import GcodeError

    with pytest.raises(GcodeError, match="tool numbers are 0 to 2147483647") as err:
        list(interpret(f"G21\n{block}\nG1 X1 F100\nM2\n"))
    assert err.value.line == 2
    assert len(list(interpret("G21\nT2147483647 M6\nG1 X1 F100\nM2\n"))) == 1  # no table: any
