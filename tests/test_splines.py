"""Splines: the geometry against LinuxCNC's documented definitions, the curve's own numbers
(derivatives, arc length, nearest points) against independent computations, and the planner,
analysis and CLI taking them (rs274 itself: tests/test_rs274_splines.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.moves import Spline
from gantry_sim.controller.nurbs import Nurbs, linuxcnc_knots
from gantry_sim.controller.planner.move_geometry import move_geometry
from gantry_sim.controller.planner.segment import segment_spline
from gantry_sim.sim.cli import main
from gantry_sim.sim.nearest import nearest_on_move

HEAD = "G21 G17 G90 F600\nG0 X0 Y0\nG1 X1 Y0\n"


def splines(text: str, dialect: str = "linuxcnc") -> list[Spline]:
    return [m for m in parse_program(text, dialect) if isinstance(m, Spline)]


def bezier(ctrl: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Bernstein form, straight from the definition."""
    from math import comb

    n = len(ctrl) - 1
    basis = np.array([comb(n, i) * t**i * (1 - t) ** (n - i) for i in range(n + 1)])
    return basis.T @ ctrl


def cox_de_boor(i: int, k: int, u: float, t: list[float]) -> float:
    """N_{i,k}(u), order k, half-open spans (the last span closed), by the recursion."""
    if k == 1:
        last = t[i + 1] == t[-1] and t[i] < t[i + 1]
        return 1.0 if t[i] <= u < t[i + 1] or (last and u == t[-1]) else 0.0
    out = 0.0
    if t[i + k - 1] > t[i]:
        out += (u - t[i]) / (t[i + k - 1] - t[i]) * cox_de_boor(i, k - 1, u, t)
    if t[i + k] > t[i + 1]:
        out += (t[i + k] - u) / (t[i + k] - t[i + 1]) * cox_de_boor(i + 1, k - 1, u, t)
    return out


def test_g5_is_linuxcncs_cubic_bezier_and_consecutive_g5s_mirror_p_q() -> None:
    a, b = splines(HEAD + "G5 I1 J2 P-1 Q2 X5 Y0\nG5 P-2 Q-1 X9 Y1\nM2\n")
    # P0, P0 + (I, J), P1 + (P, Q), P1 (LinuxCNC G-code reference, G5)
    assert a.control_points == ((1, 0, 0), (2, 2, 0), (4, 2, 0), (5, 0, 0))
    # without I J: the negation of the previous P Q
    assert b.control_points == ((5, 0, 0), (6, -2, 0), (7, 0, 0), (9, 1, 0))
    t = np.linspace(0, 1, 11)
    for s in (a, b):
        pts = s.curve.nurbs.points(t)
        assert np.abs(pts - bezier(np.array(s.control_points, float), t)).max() < 1e-12
        assert s.degree == 3 and s.weights == (1.0,) * 4 and s.code == "G5"
    # the mirror makes the chain tangent-continuous
    assert np.allclose(a.curve.end_frames[2], b.curve.end_frames[0], atol=1e-12)


def test_g51_is_a_quadratic_bezier() -> None:
    (s,) = splines(HEAD + "G5.1 I1 J3 X4 Y0\nM2\n")
    assert s.control_points == ((1, 0, 0), (2, 3, 0), (4, 0, 0)) and s.degree == 2
    t = np.linspace(0, 1, 7)
    assert (
        np.abs(s.curve.nurbs.points(t) - bezier(np.array(s.control_points, float), t)).max() < 1e-12
    )


def test_nurbs_uses_linuxcncs_knots_and_the_rational_de_boor_curve() -> None:
    # knot_vector_creator: 0 for i < k, i - k + 1 up to n, n - k + 2 beyond
    assert linuxcnc_knots(5, 3) == (0, 0, 0, 1, 2, 3, 3, 3)
    assert linuxcnc_knots(6, 4) == (0, 0, 0, 0, 1, 2, 3, 3, 3, 3)
    text = HEAD + "G5.2 X2 Y1 P1 L4\nX3 Y-1 P2.5\nX5 Y2 P0.5\nX6 Y0 P1\nX8 Y1 P3\nG5.3\nM2\n"
    (s,) = splines(text)
    assert s.code == "G5.2" and s.degree == 3 and s.line == 9
    assert s.weights == (1.0, 1.0, 2.5, 0.5, 1.0, 3.0)
    ctrl, w, t = np.array(s.control_points), np.array(s.weights), list(s.knots)
    for u in np.linspace(0, t[-1], 13):
        n = np.array([cox_de_boor(i, 4, u, t) for i in range(len(ctrl))]) * w
        assert np.abs(s.curve.nurbs.points(np.array([u]))[0] - n @ ctrl / n.sum()).max() < 1e-12


def test_derivatives_match_finite_differences() -> None:
    ctrl = np.array([[0, 0, 0], [1, 2, 0], [3, -1, 0], [4, 3, 0], [6, 0, 0.0]])
    nb = Nurbs.build(ctrl, np.array([1, 2, 0.5, 1.5, 1]), np.array(linuxcnc_knots(5, 3)), 2)
    u = np.linspace(0.1, 2.9, 9)
    h = 1e-5
    c = nb.derivatives(u, 3)
    for order in (1, 2, 3):
        lo, hi = nb.derivatives(u - h, 3)[order - 1], nb.derivatives(u + h, 3)[order - 1]
        assert np.abs((hi - lo) / (2 * h) - c[order]).max() < 1e-5 * max(1, np.abs(c[order]).max())


def test_arc_length_and_its_inverse() -> None:
    (s,) = splines(HEAD + "G5 I3 J8 P-6 Q5 X9 Y1\nM2\n")
    c = s.curve
    fine = s.curve.nurbs.points(np.linspace(0, 1, 400_001))
    polyline = np.linalg.norm(np.diff(fine, axis=0), axis=1).sum()
    assert c.length_mm == pytest.approx(polyline, rel=1e-9)
    target = np.linspace(0, c.length_mm, 37)
    assert np.abs(c.s_of_t(c.t_of_s(target)) - target).max() < 1e-10


def test_the_inversions_kept_are_those_computed_afresh() -> None:
    """SplineCurve.t_of_s keeps its last results (the planner asks for the same arc lengths
    each time it plans a chain again): a kept result is the fresh one bit for bit, a caller
    changing its copy changes nothing kept, and the oldest goes first when full."""
    import importlib

    (s,) = splines(HEAD + "G5 I3 J8 P-6 Q5 X9 Y1\nM2\n")
    c = s.curve
    curve_module = importlib.import_module("gantry_sim.controller.spline_curve")
    x = np.linspace(0, c.length_mm, 9)
    first = c.t_of_s(x)
    first[:] = -1.0
    again = c.t_of_s(x)
    assert np.array_equal(again, c._t_of_s_new(x)) and (again >= 0.0).all()
    for k in range(curve_module.T_OF_S_KEPT):
        c.t_of_s(np.array([k * 1e-3]))
    assert len(c._t_of_s) == curve_module.T_OF_S_KEPT and x.tobytes() not in c._t_of_s


def test_nearest_points_beat_brute_force() -> None:
    (s,) = splines(HEAD + "G5 I3 J8 P-6 Q5 X9 Y1\nM2\n")
    rng = np.random.default_rng(3)
    q = s.curve.nurbs.points(rng.uniform(0, 1, 200)) + rng.normal(0, 0.3, (200, 3))
    near = nearest_on_move(s, q)
    dense = s.curve.nurbs.points(np.linspace(0, 1, 200_001))
    brute = np.min(np.linalg.norm(q[:, None, :] - dense[None, ::10, :], axis=2), axis=1)
    got = np.linalg.norm(q - near, axis=1)
    assert (got <= brute + 1e-9).all()
    # and they lie on the curve: their own nearest point is themselves
    assert np.abs(nearest_on_move(s, near) - near).max() < 1e-9


def test_offsets_rotation_and_inches_move_the_control_points_like_x_y() -> None:
    text = "G20 G17 G90 F20\nG10 L2 P1 X10 Y5 R90\nG0 X0 Y0\nG5.1 I0.1 J0 X0.2 Y0\nM2\n"
    (s,) = splines(text)
    # the G54 origin is X10 Y5 inches; the 90 degree rotation turns +X into +Y
    expect = ((254, 127, 0), (254, 127 + 2.54, 0), (254, 127 + 5.08, 0))
    assert np.allclose(s.control_points, expect, atol=1e-12)


@pytest.mark.parametrize(
    ("text", "line", "why"),
    [
        (HEAD + "G41.1 D1 G1 X2 Y1\nG5 I1 J1 P1 Q1 X4 Y1\nM2\n", 5, "cutter radius compensation"),
        (HEAD + "G18\nG5 I1 J1 P1 Q1 X4 Y1\nM2\n", 5, "XY plane"),
        (HEAD + "G5 I1 J1 P1 Q1 X4 Y1 Z1\nM2\n", 4, "motion in Z"),
        (HEAD + "G5.2 X2 Y1\nX3 Y0 P-1\nG5.3\nM2\n", 5, "positive weight"),
        (HEAD + "G5.2 X2 Y1\nX3 Y0 P0.1\nX4 Y1 P0.1\nG5.3\nM2\n", 7, "infinity"),
    ],
)
def test_refusals_name_line_and_reason(text: str, line: int, why: str) -> None:
    with pytest.raises(GcodeError) as err:
        parse_program(text)
    assert err.value.line == line and why in err.value.message


def test_dialects_without_splines_refuse_them() -> None:
    for dialect, why in (("grbl", "grbl has no G5"), ("g2core", "no splines")):
        with pytest.raises(GcodeError, match=why):
            parse_program("G21 G1 X1 F100\nG5 I1 J1 P1 Q1 X4 Y1\nM2\n", dialect)


def test_chords_stay_within_the_tolerance_and_the_planner_sees_a_curve(machine) -> None:
    (s,) = splines(HEAD + "G5 I3 J8 P-6 Q5 X9 Y1\nM2\n")
    seg = machine.segmentation
    verts = segment_spline(s, "chord", seg.chord_tolerance_mm, seg.segment_length_mm)
    mids = (
        verts[:-1, None, :]
        + np.linspace(0, 1, 21)[None, :, None] * np.diff(verts, axis=0)[:, None, :]
    )
    mids = mids.reshape(-1, 3)
    assert np.linalg.norm(nearest_on_move(s, mids) - mids, axis=1).max() <= seg.chord_tolerance_mm
    g = move_geometry(s, machine.limits, seg, 1.0)
    assert g.length_mm == pytest.approx(s.length_mm) and np.array_equal(g.vertices, verts)
    d1, d2 = g.derivatives(np.linspace(0, 1, 9))
    assert np.allclose(np.linalg.norm(d1, axis=1), g.length_mm)  # arc-length parameter
    assert np.abs(np.einsum("ij,ij->i", d1, d2)).max() < 1e-6 * g.length_mm**3
    k = np.linalg.norm(d2, axis=1) / g.length_mm**2
    assert k.max() <= g.follow.curvature_per_mm  # the bound holds where sampled


def test_parse_reports_splines_with_their_control_points(write_program, capsys) -> None:
    path = write_program(HEAD + "G5 I1 J2 P-1 Q2 X5 Y0\nG5.1 I1 J3 X7 Y0\nM2\n")
    assert main(["parse", str(path)]) == 0
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    g5, g51 = rows[2], rows[3]
    assert set(g5) == {
        "line", "kind", "start", "end", "feed",
        "code", "control_points", "weights", "degree", "knots",
    }  # fmt: skip
    assert (g5["kind"], g5["code"], g51["code"]) == ("spline", "G5", "G5.1")
    assert g5["control_points"] == [[1, 0, 0], [2, 2, 0], [4, 2, 0], [5, 0, 0]]
    assert g51["knots"] == [0, 0, 0, 1, 1, 1] and g51["degree"] == 2


def test_a_spline_program_runs_end_to_end_against_the_curve(machine) -> None:
    from gantry_sim.sim.api import run_program

    text = HEAD.replace("F600", "F1800") + "G5 I4 J6 P-4 Q6 X15 Y0\nG5 P-3 Q-5 X25 Y2\nG1 X27\nM2\n"
    res = run_program(text, file="s.ngc", machine=machine)
    rep = res.report
    kinds = {b["line"]: b["kind"] for b in rep["blocks"]}
    assert kinds[4] == kinds[5] == "spline"
    assert rep["parts_um"]["chord_max"] <= machine.segmentation.chord_tolerance_mm * 1000 + 1e-9
    assert rep["parts_um"]["reference_max"] < 0.5  # the reference follows the curve itself
    assert 0.0 < rep["contour_error_um"]["max"] < 10.0
    # the error is measured against the curve: every nearest point lies on a spline or line
    a = splines(text)[0]
    on = res.trace.line == 4
    near = res.trace.nearest[on]
    assert np.abs(nearest_on_move(a, near) - near).max() < 1e-9


def test_marlins_g5_is_the_same_bezier_with_i_j_p_q_defaulting_to_zero() -> None:
    text = "G21\nG1 X1 F600\nG5 I1 J2 P-1 Q2 X5 Y0 E3\nG5 X9 Y1 P1 Q1\n"
    a, b = splines(text, "marlin")
    assert a.control_points == ((1, 0, 0), (2, 2, 0), (4, 2, 0), (5, 0, 0))
    # no mirror in Marlin: I J default to 0 (G5.cpp, parser.linearval)
    assert b.control_points == ((5, 0, 0), (5, 0, 0), (10, 2, 0), (9, 1, 0))
    with pytest.raises(GcodeError, match="Z move"):
        parse_program("G21\nG1 X1 F600\nG5 X4 Y1 Z2\n", "marlin")
    # Marlin drops the subcode (its dispatch reads the code number): G5.1 is a G5 there
    (c,) = splines("G21\nG1 X1 F600\nG5.1 I1 J1 X4 Y1\n", "marlin")
    assert c.control_points == ((1, 0, 0), (2, 1, 0), (4, 1, 0), (4, 1, 0))


def test_a_cusp_is_refused_by_the_planner_with_its_line(write_program, capsys) -> None:
    path = write_program(HEAD + "G5 I0 J0 P1 Q0 X9 Y0\nM2\n")  # x overshoots 9 and turns back
    assert main(["plan", str(path)]) == 2
    assert f"{path}:4: error: this G5 spline reverses its direction" in capsys.readouterr().err


def test_error_gates_name_the_spline_kind() -> None:
    from gantry_sim.sim.gates import parse_error_limits

    (limit,) = parse_error_limits("spline=5")
    assert limit.covers(4, "spline") and not limit.covers(4, "arc")


def test_the_reference_keeps_the_limits_and_the_curve(machine) -> None:
    """Including zero-speed ends (a first G5 without I J, P0 Q0), whose curvature is unbounded
    at the end point."""
    from gantry_sim.controller.gcode.interpreter import interpret_events
    from gantry_sim.controller.planner.plan import plan
    from tests.plan_helpers import assert_within_limits

    text = (
        "G21 G17 G90\nG0 X0 Y0\nG1 X5 F12000\nG5 P-20 Q60 X60 Y0\nG5 P0 Q0 X65 Y5\n"
        "G5 I20 J60 P-20 Q60 X100 Y0\n"
        "G5 P-10 Q-30 X130 Y0\nG5.1 I5 J-40 X140 Y0\nG5.2 X150 Y10 P1 L4\nX160 Y-10 P3\n"
        "X170 Y10 P1\nX180 Y0 P1\nG5.3\nG1 X200\nM2\n"
    )
    items = list(interpret_events(text))
    traj = plan(items, machine).sample(1e-4)
    moves = [m for m in items if hasattr(m, "kind")]
    assert_within_limits(traj, machine, moves)
    tol = machine.segmentation.chord_tolerance_mm
    for s in (m for m in moves if isinstance(m, Spline)):
        on = traj.pos[traj.line == s.line]
        assert np.linalg.norm(nearest_on_move(s, on) - on, axis=1).max() <= tol


def test_nearest_points_next_to_a_zero_speed_end() -> None:
    """C'(0) = 0 (first control point = start): f'(t) = 0 at the end itself, so the search must
    not stop there (it once reported every point near the start as nearest to the start)."""
    (s,) = splines(HEAD + "G5 P-2 Q2 X20 Y0\nM2\n")  # the first G5 without I J: (1,0) twice
    t = np.linspace(1e-4, 2e-2, 40)
    on = s.curve.nurbs.points(t)
    q = on + np.array([0.0, 0.0, 1e-4])  # 0.1 um above the curve (its plane is XY)
    assert np.abs(np.linalg.norm(nearest_on_move(s, q) - q, axis=1) - 1e-4).max() < 1e-9


def test_a_g5_of_no_length_plans_without_numpy_warnings(machine) -> None:  # type: ignore[no-untyped-def]
    """Every control point at the start (a hostile-input sweep's find): rs274 emits its
    NURBS_FEED; the planner took its chord vertices from the curve's tangent, 0/0."""
    import warnings

    from gantry_sim.controller.planner.plan import plan as plan_moves

    moves = parse_program("G21 G90\nG5 I0 J0 P0 Q0 X0 Y0 F100\nM2\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        p = plan_moves(moves, machine)
    assert p.duration_s == 0.0 and len(p.moves) == 1


def test_a_hook_next_to_a_zero_speed_start_gets_its_chords(machine) -> None:
    """A first G5 without I J starts with zero speed and here turns back within 7 um of its
    start (a fuzz's find): 16 equal-arc-length samples on one chord missed the hook, the whole
    curve was the "end chord" whose bounds are left out, and the exact states there broke the
    acceleration limit (an internal error). The chord count now also samples the parameter."""
    from gantry_sim.controller.gcode.interpreter import interpret_events
    from gantry_sim.controller.planner.plan import plan
    from tests.plan_helpers import assert_phases_within_limits, assert_within_limits

    text = (
        "G21 G17 G90\nG0 X0 Y0\nF600\nG1 X0.023 Y0.0261\nG5 P0.4704 Q0.0581 X-0.371 Y-0.0238\nM2\n"
    )
    (s,) = splines(text)
    verts = segment_spline(s, "chord", 0.001, 1.0)
    assert len(verts) > 2
    t = np.linspace(s.curve.nurbs.t_min, s.curve.nurbs.t_max, 20_001)
    on = s.curve.nurbs.points(t)
    a, b = verts[:-1], verts[1:]  # every point within the tolerance of some chord
    d = b - a
    u = np.clip(
        np.einsum("mij,ij->mi", on[:, None, :] - a[None], d) / np.einsum("ij,ij->i", d, d), 0, 1
    )
    near = a[None] + u[:, :, None] * d[None]
    assert np.linalg.norm(on[:, None, :] - near, axis=2).min(axis=1).max() <= 0.001
    items = list(interpret_events(text))
    p = plan(items, machine)
    assert_within_limits(p.sample(1e-4), machine, [m for m in items if hasattr(m, "kind")])
    assert_phases_within_limits(p, machine)
