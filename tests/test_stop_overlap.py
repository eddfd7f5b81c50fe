"""G64 stops between two straight moves passed with their profiles overlapped
(controller/planner/stop_overlap.py): where, by how much, within which limits."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.gcode.interpreter import interpret_events
from gantry_sim.controller.moves import Linear
from gantry_sim.controller.planner import plan
from gantry_sim.controller.planner.blend import REFERENCE_SHARE
from gantry_sim.controller.planner.overlap_search import STEP_S
from tests.overlap_helpers import check_overlaps

HEAD = "G21 G90 G17 G64 P0.01\nG1 X5 F1200\n"


def _plan(text: str, machine):
    return plan(list(interpret_events(text)), machine)


def test_a_stop_between_x_and_y_moves_overlaps_and_the_program_is_that_much_shorter(machine):
    """The X move's stop and the Y move's start overlap by 10-20 ms (the ramps of a 20 mm/s
    stop last about 32 ms): the cycle is the G61 one (the same stop, not overlapped) less
    exactly that."""
    g64 = _plan(HEAD + "G1 X5 Y5\nM2\n", machine)
    g61 = _plan(HEAD.replace("G64 P0.01", "G61") + "G1 X5 Y5\nM2\n", machine)
    assert g64.overlaps_s.shape == (1, 2) and len(g61.overlaps_s) == 0
    tau = float(g64.overlaps_s[0, 1] - g64.overlaps_s[0, 0])
    assert 0.010 <= tau <= 0.020
    assert g61.duration_s - g64.duration_s == pytest.approx(tau, abs=1e-12)
    assert g64.move_lines.tolist() == [2, 2, 3]  # the X move, the overlap (its line), Y
    assert g64.overlap_entries().tolist() == [1]
    assert g64.move_start_s[1] == g64.overlaps_s[0, 0]
    check_overlaps(g64, machine)


def test_the_overlap_is_the_longest_that_keeps_p(machine):
    """Superposing the G61 plan's two profiles at its stop, as the overlap does: at the
    length found the corner lies within the budget of the reference, two grid steps longer
    it does not (at an X -> Y corner at F1200 the budget is what binds)."""
    text = HEAD + "G1 X5 Y5\nM2\n"
    g64 = _plan(text, machine)
    g61 = _plan(text.replace("G64 P0.01", "G61"), machine)
    tau = float(g64.overlaps_s[0, 1] - g64.overlaps_s[0, 0])
    t_stop = float(g61.move_start_s[1])
    corner = np.array([5.0, 0.0, 0.0])
    budget = 0.01 - REFERENCE_SHARE * machine.segmentation.chord_tolerance_mm

    def corner_distance(length_s: float) -> float:
        t = np.linspace(0.0, length_s, 4001)
        a = g61.curve.evaluate(t_stop - length_s + t)[0]
        b = g61.curve.evaluate(t_stop + t)[0]
        return float(np.linalg.norm(a + b - 2 * corner, axis=1).min())

    assert corner_distance(tau) <= budget
    assert corner_distance(tau + 2 * STEP_S) > budget


@pytest.mark.parametrize(
    "tail",
    [
        "G1 X10\n",  # straight on: no stop
        "G4 P0.1\nG1 X5 Y5\n",  # a dwell at the corner: the program asks to stop
        "M0\nG1 X5 Y5\n",  # a program stop likewise
        "G0 X5 Y5\n",  # a feed move then a rapid: LinuxCNC 2.9 stops there
        "G3 X7 Y2 I2 J0\n",  # an arc after the corner
        "G1 X0\n",  # a reversal: a stop in LinuxCNC and grbl (and sim.duration_bound)
    ],
)
def test_no_overlap_where_the_program_stops(machine, tail):
    """(Corners whose moves' jerks add: tests/test_shared_jerk.py.)"""
    p = _plan(HEAD + tail + "M2\n", machine)
    assert len(p.overlaps_s) == 0
    assert not any(b.kind == "overlap" for b in p.blends)


def test_a_rapid_then_a_feed_move_stays_a_stop(machine):
    p = _plan("G21 G90 G17 G64 P0.01\nG0 X5\nG1 X5 Y5 F1200\nM2\n", machine)
    assert len(p.overlaps_s) == 0


RAPIDS = "G21 G90 G17 {mode}\nG0 X10\n{after}G0 X10 Y10\nG0 Z5\nG0 X0 Y0\nM2\n"


def test_two_rapids_in_line_are_passed_through(machine):
    """LinuxCNC 2.9 (benchmarks/linuxcnc_peer.py's run_one, 2026-11-29) passes the junction of
    two rapids in line without stopping (G0 X10, G0 X20: 0.207 s, no period at rest): so does
    the planner, in every mode, as one rapid of their length."""
    one = _plan("G21 G90 G0 X20\nM2\n", machine)
    for mode in ("G64 P0.01", "G61"):
        two = _plan(f"G21 G90 {mode}\nG0 X10\nG0 X20\nM2\n", machine)
        assert two.duration_s == pytest.approx(one.duration_s, abs=1e-9)
        t = float(two.move_start_s[1])  # the junction
        assert np.linalg.norm(two.curve.evaluate(np.array([t]))[1]) > 100.0  # mm/s


@pytest.mark.parametrize(("after", "count"), [("", 3), ("G61.1\n", 1)])
def test_a_stop_between_two_rapids_overlaps_in_g64(machine, after, count):
    """LinuxCNC 2.9 blends a corner between two rapids in G64 (it stops between a rapid and a
    feed move): here the stops between rapids that share no axis overlap, within P and every
    limit, as between two feed moves; G61 keeps the stops. The mode of the rapid before a
    corner governs it: after a G61.1 on the second rapid, only the first corner overlaps."""
    g64 = _plan(RAPIDS.format(mode="G64 P0.01", after=after), machine)
    g61 = _plan(RAPIDS.format(mode="G61", after=after), machine)
    assert len(g64.overlaps_s) == count and len(g61.overlaps_s) == 0
    taus = g64.overlaps_s[:, 1] - g64.overlaps_s[:, 0]
    assert g61.duration_s - g64.duration_s == pytest.approx(taus.sum(), abs=1e-9)
    check_overlaps(g64, machine)


@pytest.mark.parametrize("after", ["G61.1\n", "G61\n", "G64 P0.001\n"])
def test_the_move_before_the_corner_governs_it(machine, after):
    """As LinuxCNC's termination condition: the mode and P of the move before a junction
    govern it, whatever the move after it sets. LinuxCNC 2.9 (its own planner, through
    benchmarks/linuxcnc_peer.py's run_one, 2026-11-29) passed a corner between a G64 P0.01
    move and a G61.1 one without stopping, and stopped when the G61.1 move came first."""
    g64 = _plan(HEAD + "G1 X5 Y5\nM2\n", machine)
    p = _plan(HEAD + after + "G1 X5 Y5\nM2\n", machine)
    assert len(g64.overlaps_s) == 1
    np.testing.assert_array_equal(p.overlaps_s, g64.overlaps_s)
    assert [b.tolerance_mm for b in p.blends] == [b.tolerance_mm for b in g64.blends]
    check_overlaps(p, machine)
    first = _plan(HEAD.replace("G64 P0.01", "G61.1") + "G64 P0.01\nG1 X5 Y5\nM2\n", machine)
    assert len(first.overlaps_s) == 0


def test_a_pocket_of_right_angle_corners_and_plunges_keeps_every_limit(machine):
    """Linking lines of 0.5 mm and less (shorter than the two overlaps at their ends could
    take), plunges along Z (another axis, other limits) and corners between moves of other
    feeds: every overlap keeps the limits and P, and no two overlaps share time."""
    text = (
        "G21 G90 G17 G64 P0.01\nG0 X0 Y0 Z1\nG1 Z-1 F300\nG1 X8 F1500\nG1 Y0.5\nG1 X0 F900\n"
        "G1 Y0.55\nG1 X8\nG1 Z-1.4 F300\nG1 Y-3 F1500\nG1 X0 Y-3\nG0 Z5\nM2\n"
    )
    p = _plan(text, machine)
    assert len(p.overlaps_s) >= 7
    check_overlaps(p, machine)
    starts, ends = p.overlaps_s[:, 0], p.overlaps_s[:, 1]
    assert (ends[:-1] <= starts[1:]).all()


@settings(max_examples=25, deadline=None)
@given(
    first=st.sampled_from([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, 0, -1)]),
    second=st.sampled_from([(0, 1, 0), (0, -1, 0), (1, 0, 0), (0, 0, 1), (-1, 0, 0)]),
    len_a=st.floats(0.05, 20.0),
    len_b=st.floats(0.05, 20.0),
    feeds=st.tuples(st.integers(100, 6000), st.integers(100, 6000)),
    tolerance=st.sampled_from([0.002, 0.01, 0.05, 0.5]),
)
def test_any_axis_corner_overlapped_keeps_every_limit_and_its_tolerance(
    machine, first, second, len_a, len_b, feeds, tolerance
):
    a_end = np.round(np.array(first, float) * len_a, 4)
    b_end = np.round(a_end + np.array(second, float) * len_b, 4)
    text = (
        f"G21 G90 G64 P{tolerance}\nG1 X{a_end[0]} Y{a_end[1]} Z{a_end[2]} F{feeds[0]}\n"
        f"G1 X{b_end[0]} Y{b_end[1]} Z{b_end[2]} F{feeds[1]}\nM2\n"
    )
    check_overlaps(_plan(text, machine), machine, tolerance)


def test_gantry_plan_counts_the_overlaps_and_the_run_reports_them_as_blends(
    write_program, tmp_path, capsys
):
    from gantry_sim.sim.cli import main

    prog = write_program(HEAD + "G1 X5 Y5\nG1 X0 Y5\nM2\n")
    assert main(["plan", str(prog)]) == 0
    blends = json.loads(capsys.readouterr().out)["blends"]
    assert blends["count"] == blends["overlaps"] == 2 and blends["transitions"] == 0
    assert 0 < blends["max_deviation_mm"] <= 0.01
    assert main(["run", str(prog), "--out", str(tmp_path / "o"), "--no-plots"]) == 0
    parts = json.loads((tmp_path / "o" / "report.json").read_text())["parts_um"]
    assert parts["reference_blend_max"] == pytest.approx(blends["max_deviation_mm"] * 1000)
    # the overlaps cut their corners by design: out of the planning part, which stays within
    # 0.25 x the 1 um chord tolerance
    assert parts["reference_planning_max"] < 0.25
    assert parts["reference_max"] <= parts["reference_blend_max"] + 1e-9


def test_planning_split_leaves_out_exactly_the_overlapped_samples():
    from gantry_sim.sim.blend_parts import in_overlaps

    windows = np.array([[1.0, 1.5], [2.0, 2.25]])
    t = np.array([0.5, 1.0, 1.2, 1.5, 1.9, 2.0, 2.249, 2.25, 3.0])
    assert in_overlaps(t, windows).tolist() == [0, 1, 1, 0, 0, 1, 1, 0, 0]
    assert not in_overlaps(t, np.zeros((0, 2))).any()


def _hairpin(feed: float) -> str:
    """A CAM-like hairpin in G64 P0.05 (its Q merges each leg into one move): a leg of 0.175 mm
    moves up, a rounded tip of 0.002 mm moves, a leg of 0.07 mm moves back down beside it; the
    tip is an exact stop whose two moves' profiles overlap."""
    up = [(0.0012 * y * y, y) for y in np.arange(0.175, 10.0, 0.175)]
    xt, yt = up[-1][0] + 0.012, up[-1][1] + 0.06
    tip = [(xt + dx, yt - 400.0 * dx * dx) for dx in np.arange(-0.012, 0.0121, 0.002)]
    bx, by = tip[-1]
    down = [(bx + 0.025 * k * 0.07, by - k * 0.07) for k in range(1, 45)]
    body = "".join(f"G1 X{x:.6f} Y{y:.6f}\n" for x, y in up + tip + down)
    return f"G21 G90 G17 G64 P0.05\nG0 X0 Y0 Z0\nF{feed}\n{body}M2\n"


@pytest.mark.parametrize("feed", [3000.0, 6000.0])
def test_an_overlapped_stop_is_measured_against_both_its_moves(machine, feed):
    """During the overlap the reference is on the end of one merged leg and the start of the
    other at once; its samples were measured against the tip's few program moves only (the
    last of the first leg, the first of the second, one either side), 0.2 mm from it: 95-106
    um of reference error where the reference is 42 um from the program (a CAMotics example
    read 176 um for 49). The overlap's entry now names both legs' program moves."""
    from tests.plan_helpers import polyline_distance, program_deviation

    moves = list(interpret_events(_hairpin(feed)))
    p = plan(moves, machine)
    assert len(p.overlaps_s) == 1 and len(p.merges) == 2
    tr = p.sample(machine.servo.period_s)
    program = [m for m in p.moves if isinstance(m, Linear)]
    nearest = polyline_distance(tr.pos[tr.line > 3], program).max()
    assert program_deviation(tr, p.moves) == pytest.approx(nearest, abs=1e-12)
    assert nearest <= 0.05
    (e,) = p.overlap_entries()
    assert p.move_sources[e].tolist() == [p.move_sources[e - 1][0], p.move_sources[e + 1][1]]
