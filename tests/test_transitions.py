"""G2 transitions at G64 tangent junctions whose curvature jumps (controller/planner/transition.py):
where they go and where not, within the tolerance, curvature-continuous at both ends, within
every limit and the feed in each principal plane, faster than the chord smoothing, and through
`gantry run`."""

from __future__ import annotations

import dataclasses
import importlib
import itertools
import json
import math
import pickle

import numpy as np
import pytest

from benchmarks.junction_floor import C_TWO_SIDED
from gantry_sim.controller.gcode.interpreter import interpret_events, parse_program
from gantry_sim.controller.moves import Arc, Transition
from gantry_sim.controller.planes import PLANE_AXES
from gantry_sim.controller.planner.move_geometry import move_geometry
from gantry_sim.controller.planner.plan import plan
from tests.plan_helpers import (
    assert_phases_within_limits,
    assert_within_limits,
    program_deviation,
)

transition = importlib.import_module("gantry_sim.controller.planner.transition")

P = 0.01  # mm: the programs' G64 P, the bundled machine's default too
WORDS = {"XY": ("G17", "X", "Y", "I", "J"), "XZ": ("G18", "Z", "X", "K", "I"),
         "YZ": ("G19", "Y", "Z", "J", "K")}  # fmt: skip


def s_bends(plane: str, mode: str = f"G64 P{P}", feed: int = 6000, n: int = 4) -> str:
    """``n`` R5 half circles along the plane's first axis, alternating G3/G2 (S-bends)."""
    g, a, _, i, _ = WORDS[plane]
    body = "".join(f"G{3 if k % 2 == 0 else 2} {a}{10 * (k + 1)} {i}5\n" for k in range(n))
    return f"G21 G90 {g} {mode}\nG0 X0 Y0 Z0\nF{feed}\n{body}M2\n"


def line_arc(plane: str, mode: str = f"G64 P{P}", feed: int = 3000) -> str:
    """A line, a tangent R3 quarter circle, a line: two line-arc junctions."""
    g, a, b, _, j = WORDS[plane]
    return f"G21 G90 {g} {mode}\nG0 X0 Y0 Z0\nF{feed}\nG1 {a}10\nG3 {a}13 {b}3 {j}3\nG1 {b}13\nM2\n"


def _transitions(p) -> list[Transition]:
    return [m for m in p.path_moves if isinstance(m, Transition)]


def _fine(p):
    return p.sample(1e-4)


@pytest.mark.parametrize("plane", ["XY", "XZ", "YZ"])
@pytest.mark.parametrize("shape", [s_bends, line_arc], ids=["s-bends", "line-arc"])
def test_transitions_keep_the_tolerance_every_limit_and_the_feed(machine, plane, shape):
    moves = parse_program(shape(plane))
    p = plan(moves, machine)
    steps = _transitions(p)
    assert len(steps) == (3 if shape is s_bends else 2)
    assert [b.kind for b in p.blends].count("transition") == len(steps)
    n = PLANE_AXES[plane][2]
    assert all(ctrl[n] == 0.0 for t in steps for ctrl in t.control_points)  # in the plane
    budget = P - 0.25 * machine.segmentation.chord_tolerance_mm
    assert all(0.0 < b.deviation_mm <= budget for b in p.blends)
    tr = p.sample(machine.servo.period_s)
    assert_within_limits(tr, machine, moves)  # per axis, and the path speed <= F
    assert_phases_within_limits(p, machine)
    assert program_deviation(_fine(p), moves) <= P


@pytest.mark.parametrize("shape", [s_bends, line_arc], ids=["s-bends", "line-arc"])
def test_curvature_is_continuous_where_a_transition_meets_its_moves(machine, shape):
    p = plan(parse_program(shape("XY")), machine)
    lim, seg = machine.limits, machine.segmentation
    path = list(p.path_moves)
    for k, m in enumerate(path):
        if not isinstance(m, Transition):
            continue
        before, after = (move_geometry(x, lim, seg, 1.0) for x in (path[k - 1], path[k + 1]))
        own = move_geometry(m, lim, seg, 1.0)
        assert path[k - 1].end == m.start and m.end == path[k + 1].start  # the same points
        np.testing.assert_allclose(own.tangent_in, before.tangent_out, atol=1e-12)
        np.testing.assert_allclose(own.tangent_out, after.tangent_in, atol=1e-12)
        np.testing.assert_allclose(own.curv_in, before.curv_out, atol=1e-10)  # [1/mm]
        np.testing.assert_allclose(own.curv_out, after.curv_in, atol=1e-10)
        assert np.linalg.norm(before.curv_out - after.curv_in) > 0.1  # a jump it replaces


def test_a_pickled_transition_keeps_every_field(machine):
    """Transition.__reduce__ lists the constructor's arguments by hand (the spill and the
    analysis worker pickle thousands): every field must come back, a field added later too."""
    p = plan(parse_program(line_arc("XY")), machine)
    (t, *_) = _transitions(p)
    back = pickle.loads(pickle.dumps(t, protocol=pickle.HIGHEST_PROTOCOL))
    assert back == t and back.row == t.row and back.path == t.path
    assert len(t.__reduce__()[1]) == len(dataclasses.fields(Transition))
    names = [f.name for f in dataclasses.fields(Transition)]
    assert list(t.__reduce__()[1]) == [getattr(t, name) for name in names]


@pytest.mark.parametrize(
    "mode", ["G61", "G61.1", "G64 P0"], ids=["exact-path", "exact-stop", "no-tolerance"]
)
def test_no_transition_outside_g64_with_a_tolerance(machine, mode):
    p = plan(parse_program(s_bends("XY", mode)), machine)
    assert not _transitions(p) and not p.blends


def test_no_transition_at_a_dwell_nor_where_the_chord_smoothing_is_as_fast(machine):
    text = s_bends("XY").replace("G2 X20", "G4 P0.1\nG2 X20")  # a dwell at the first S-bend
    p = plan(list(interpret_events(text)), machine)
    assert len(_transitions(p)) == 2  # the other two S-bends
    slow = plan(parse_program(s_bends("XY", feed=300)), machine)  # 5 mm/s: nothing binds
    assert not _transitions(slow)


def test_moves_too_short_for_a_transition_keep_the_chord_smoothing(machine):
    def program(gap: float) -> str:
        return (
            f"G21 G90 G17 G64 P{P}\nG0 X0 Y0\nF6000\nG3 X10 Y0 I5\n"
            f"G1 Y{gap}\nG2 X20 Y{gap} I5\nM2\n"
        )

    short = plan(parse_program(program(0.002)), machine)  # a 2 um line between the arcs
    assert not _transitions(short)
    long = plan(parse_program(program(5.0)), machine)
    assert len(_transitions(long)) == 2
    for p in (short, long):
        assert_within_limits(p.sample(machine.servo.period_s), machine, parse_program(program(5)))


def test_a_short_move_between_two_transitions_keeps_a_tenth_and_the_path_stays_continuous(
    machine,
):
    text = (
        f"G21 G90 G17 G64 P{P}\nG0 X0 Y0\nF6000\nG3 X10 Y0 I5\n"
        "G2 X10.4 Y0 I0.2\nG3 X20.4 Y0 I5\nM2\n"
    )  # an R0.2 half circle (0.63 mm) between two R5 ones: cut from both ends
    moves = parse_program(text)
    p = plan(moves, machine)
    path = list(p.path_moves)
    assert len(_transitions(p)) == 2
    assert all(a.end == b.start for a, b in itertools.pairwise(path))
    small = next(m for m in path if isinstance(m, Arc) and m.radius < 1.0)
    assert small.length_mm >= 0.1 * moves[2].length_mm - 1e-12  # what the transitions left
    assert_within_limits(p.sample(machine.servo.period_s), machine, moves)
    assert program_deviation(_fine(p), moves) <= P


def test_s_bends_pass_faster_than_the_chord_smoothing_and_below_any_planners_ceiling(
    machine, monkeypatch
):
    moves = parse_program(s_bends("XY"))
    with_transitions = plan(moves, machine)
    monkeypatch.setattr(transition, "GAIN", math.inf)  # none pays: the chord smoothing
    chord = plan(moves, machine)
    assert not _transitions(chord)
    assert with_transitions.duration_s < 0.92 * chord.duration_s
    jerk = float(min(machine.limits.max_jerk_mm_per_s3[:2]))
    ceiling = math.sqrt(C_TWO_SIDED * (P * jerk * jerk) ** (1.0 / 3.0) / 0.4)  # |dk| = 2 / 5
    lowest = []
    for p in (with_transitions, chord):
        speed = np.linalg.norm(_fine(p).vel, axis=1)
        mid = (speed > 1.0) & (np.arange(speed.size) > speed.argmax())  # past the first ramp
        lowest.append(speed[mid][: int(0.6 * mid.sum())].min())  # the S-bends' dips
    assert lowest[0] > 1.8 * lowest[1]  # 26 -> 62 mm/s
    assert lowest[0] <= ceiling


def test_gantry_plan_and_run_count_the_transitions(write_program, tmp_path, capsys):
    from gantry_sim.sim.cli import main

    prog = write_program(s_bends("XY", n=3))
    assert main(["plan", str(prog)]) == 0
    blends = json.loads(capsys.readouterr().out)["blends"]
    assert blends["count"] == blends["transitions"] == 2
    assert 0.0 < blends["max_deviation_mm"] <= P
    out = tmp_path / "o"
    assert main(["run", str(prog), "--out", str(out), "--no-plots", "--no-trace"]) == 0
    parts = json.loads((out / "report.json").read_text())["parts_um"]
    assert parts["reference_blend_max"] == pytest.approx(1000 * blends["max_deviation_mm"])
    assert parts["reference_planning_max"] < 0.25  # 0.25 x the 1 um chord tolerance
    assert parts["reference_max"] <= parts["reference_blend_max"] + parts["reference_planning_max"]
    assert parts["reference_max"] <= 1000 * P


def test_a_transition_is_one_of_the_arcs_it_joins_for_the_analysis(machine):
    """A transition's samples are measured against both programmed moves it replaces, and its
    curve is a move of the path the analysis searches (sim.move_table)."""
    from gantry_sim.sim.move_table import move_table
    from gantry_sim.sim.nearest import nearest_on_moves

    p = plan(parse_program(s_bends("XY", n=2)), machine)
    tab = move_table(p.path_moves)
    k = next(i for i, m in enumerate(p.path_moves) if isinstance(m, Transition))
    assert tab.spline[k] and not tab.arc[k]
    step = p.path_moves[k]
    on = step.curve.points(np.linspace(0.0, 1.0, 7))
    near = nearest_on_moves(tab, np.full(7, k), on + np.array([0.0, 0.0, 0.5]))
    np.testing.assert_allclose(near, on, atol=1e-9)
    assert tuple(p.path_sources[k]) == (1, 2)  # the two half circles (after the G0)
    arcs = [m for m in p.moves if isinstance(m, Arc)]
    assert step.line == arcs[0].line


def test_small_jumps_on_curvature_limited_arcs_are_not_slower_than_the_chord_smoothing(
    machine, monkeypatch
):
    """Quarter arcs R 1-3 of a spiral at F6000 (each at its curvature cap, jumps of 5 %): the
    transitions are as slow as the arcs' own |p'''| makes any curve, and the arcs beside them
    keep the limits to ramp through them (1 % slower, before either rule)."""
    from benchmarks.bench_planner import spiral_chain

    moves = spiral_chain(40, 1.0, 0.05, 6000.0)
    with_transitions = plan(moves, machine)
    assert _transitions(with_transitions)
    assert_within_limits(with_transitions.sample(machine.servo.period_s), machine, moves)
    monkeypatch.setattr(transition, "GAIN", math.inf)
    assert with_transitions.duration_s < 0.99 * plan(moves, machine).duration_s
