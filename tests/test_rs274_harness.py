"""The rs274 comparison scripts read what they do not know without crashing.

``scripts/regen_rs274_expected.py``'s ``parse_canon`` once raised KeyError on
``SELECT_PLANE(CANON_PLANE_UNKNOWN)`` (rs274's plane for G17.1-G19.1), and
``scripts/rs274_compare_tree.py`` then gave up on the program. Needs no LinuxCNC: rs274's output
is given as recorded.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))

import regen_rs274_expected as regen  # noqa: E402
import rs274_compare_tree as tree  # noqa: E402

#: ``rs274 -g`` (LinuxCNC 2.9.0~pre1+git20230208.f1270d6ed7-1+deb12u2) on UVW_PROGRAM, exit 0
UVW_PROGRAM = "G21 G17.1 F100\nG1 X1\nG17\nM2\n"
UVW_CANON = """\
    1 N..... USE_LENGTH_UNITS(CANON_UNITS_MM)
    2 N..... SET_G5X_OFFSET(1, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000)
    3 N..... SET_G92_OFFSET(0.0000, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000)
    4 N..... SET_XY_ROTATION(0.0000)
    5 N..... SET_FEED_REFERENCE(CANON_XYZ)
    6 N..... ON_RESET()
    7 N..... SET_FEED_RATE(100.0000)
    8 N..... SELECT_PLANE(CANON_PLANE_UNKNOWN)
    9 N..... USE_LENGTH_UNITS(CANON_UNITS_MM)
   10 N..... STRAIGHT_FEED(1.0000, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000)
   11 N..... SELECT_PLANE(CANON_PLANE_XY)
   12 N..... SET_G5X_OFFSET(1, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000)
   13 N..... SET_XY_ROTATION(0.0000)
   14 N..... SET_FEED_MODE(0, 0)
   15 N..... SET_FEED_RATE(0.0000)
   16 N..... STOP_SPINDLE_TURNING(0)
   17 N..... SET_SPINDLE_MODE(0 0.0000)
   18 N..... PROGRAM_END()
   19 N..... ON_RESET()
   20 N..... ON_RESET()
"""
#: made up: an arc in an unknown plane and a call the harness has never seen
ODD_CANON = """\
    1 N..... SELECT_PLANE(CANON_PLANE_UNKNOWN)
    2 N..... ARC_FEED(1.0000, 0.0000, 0.5000, 0.0000, 1, 0.0000, 0.0000, 0.0000, 0.0000)
    3 N..... SET_SOMETHING_NEW(1, 2)
    4 N..... STRAIGHT_FEED(1.0000, 2.0000, 0.0000, 0.0000, 0.0000, 0.0000)
"""


def test_straight_moves_in_an_unknown_plane_are_read() -> None:
    motions, unit = regen.parse_canon(UVW_CANON)
    assert unit == 1.0
    assert [(m["kind"], m["end"], m["feed"]) for m in motions] == [
        ("linear", [1.0, 0.0, 0.0], 100.0)
    ]


def test_what_an_expectation_cannot_hold_is_refused_loudly() -> None:
    with pytest.raises(RuntimeError, match="CANON_PLANE_UNKNOWN"):
        regen.parse_canon(ODD_CANON)


def test_with_a_list_unknown_calls_are_noted_and_the_rest_read() -> None:
    unknown: list[str] = []
    motions, _ = regen.parse_canon(ODD_CANON, unknown)
    assert [m["kind"] for m in motions] == ["other", "linear"]
    assert motions[1]["end"] == [1.0, 2.0, 0.0]
    assert len(unknown) == 2
    assert "CANON_PLANE_UNKNOWN" in unknown[0] and "SET_SOMETHING_NEW(1, 2)" in unknown[1]


def test_compare_tree_reports_a_uvw_plane_program(tmp_path: Path) -> None:
    path = tmp_path / "uvw.ngc"
    path.write_text(UVW_PROGRAM)
    verdict = tree.judge(UVW_PROGRAM, path, UVW_CANON + "(print, ...)\n", 0, "")
    assert verdict.startswith("gantry-sim refuses, rs274 accepts")
    assert "UVW planes" in verdict


def test_compare_tree_notes_unknown_calls_and_goes_on(tmp_path: Path) -> None:
    text = "G21 F100\nG1 X1\nM2\n"
    path = tmp_path / "odd.ngc"
    path.write_text(text)
    verdict = tree.judge(text, path, ODD_CANON, 0, "")
    assert "rs274 makes ARC_FEED" in verdict
    assert "does not read" in verdict and "SET_SOMETHING_NEW" in verdict


#: ``rs274 -g`` (LinuxCNC 2.9, as above) on SPLINE_PROGRAM, exit 0, setup calls left out
SPLINE_PROGRAM = "G21 F100\nG5.1 X4 Y2 I1 J3\nG1 X0\nM2\n"
SPLINE_CANON = """\
    7 N..... SET_FEED_RATE(100.0000)
    8 N..... USE_LENGTH_UNITS(CANON_UNITS_MM)
    9 N..... NURBS_FEED(3, ...)
   10 N..... STRAIGHT_FEED(0.0000, 2.0000, 0.0000, 0.0000, 0.0000, 0.0000)
   17 N..... PROGRAM_END()
"""


def test_compare_tree_passes_over_a_spline_and_checks_the_next_end(tmp_path: Path) -> None:
    path = tmp_path / "spline.ngc"
    path.write_text(SPLINE_PROGRAM)
    assert tree.judge(SPLINE_PROGRAM, path, SPLINE_CANON, 0, "") == "MATCH"
    moved = SPLINE_PROGRAM.replace("G1 X0", "G1 X1")
    assert "motion 1: end" in tree.judge(moved, path, SPLINE_CANON, 0, "")


def test_compare_tree_says_why_rs274_refuses_a_user_m_code(tmp_path: Path) -> None:
    """rs274 -g reads no INI, so it refuses M100-M199 even with the program beside it."""
    text = "G21 F100\nG1 X1\nM111\nM2\n"
    path = tmp_path / "user_m.ngc"
    path.write_text(text)
    canon = (
        "    7 N..... SET_FEED_RATE(100.0000)\n"
        "   10 N..... STRAIGHT_FEED(1.0000, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000)\n"
    )
    stderr = "executing\nUnknown m code used: M111\nM111\n"
    (tmp_path / "M111").write_text("#!/bin/sh\nexit 0\n")
    verdict = tree.judge(text, path, canon, 1, stderr)
    assert "rs274 refuses, gantry-sim accepts" in verdict and "no USER_M_PATH" in verdict
    assert "motion" not in verdict  # the move before it was compared and agrees


def test_compare_tree_runs_on_after_rs274_refuses(tmp_path: Path) -> None:
    """gantry-sim refusing a later line than rs274 is "both refuse", not "accepts" (its run
    was once cut one motion after rs274's last)."""
    text = "G21 F100\nG1 X1\nG1 X2\nG1 X3\nG1 X4 A5\nM2\n"
    path = tmp_path / "later.ngc"
    path.write_text(text)
    canon = (
        "    7 N..... SET_FEED_RATE(100.0000)\n"
        "   10 N..... STRAIGHT_FEED(1.0000, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000)\n"
    )
    verdict = tree.judge(text, path, canon, 1, "executing\nSome refusal\nG1 X2\n")
    assert verdict.startswith("both refuse: rs274 'Some refusal'") and ":5:" in verdict
