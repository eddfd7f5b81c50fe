"""The circular-test G-code: block layout, geometry of the tangent lead-in/lead-out, errors."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from gantry_sim.controller.errors import ConfigError
from gantry_sim.sim.circular.program import circle_test_program


def words(line: str) -> dict[str, float | str]:
    """The words of one block (comments stripped): letter -> number; 'G' -> motion G word."""
    code = re.sub(r"\(.*?\)", "", line).upper()
    out: dict[str, float | str] = {}
    for letter, value in re.findall(r"([A-Z])\s*([-+]?[0-9.]+)", code):
        out[letter] = value if letter == "G" else float(value)
    return out


@pytest.mark.parametrize(
    "plane,axes,offs", [("XY", "XY", "IJ"), ("XZ", "XZ", "IK"), ("YZ", "YZ", "JK")]
)
@pytest.mark.parametrize("direction", ["cw", "ccw"])
def test_run_in_circle_run_out_lie_on_the_circle(plane, axes, offs, direction):
    radius = 20.0
    centre = (1.5, -2.0, 3.0)
    prog = circle_test_program(plane, radius, 1500.0, (direction,), centre)
    lines = prog.text.splitlines()
    lead_in, circle, lead_out = (words(lines[n - 1]) for n in prog.lines[direction])
    g = "2" if direction == "cw" else "3"
    assert lead_in["G"] == circle["G"] == lead_out["G"] == g
    assert lead_in["F"] == 1500.0
    assert "(measured circle" in lines[prog.circle_line(direction) - 1]
    c = np.array([centre["XYZ".index(a)] for a in axes])
    # The rapid to the start point P just before the run-in.
    rapid = words(lines[prog.lines[direction][0] - 3])
    assert rapid["G"] == "0"
    p = np.array([rapid[a] for a in axes])
    s = np.array([lead_in[a] for a in axes])  # run-in end = circle start
    # Run-in: from P about C (offsets from P) to S, diametrically opposite.
    assert np.allclose(p + np.array([lead_in[o] for o in offs]), c, atol=1e-6)
    assert np.allclose(p + s, 2 * c, atol=1e-6)
    # The circle: no end point (a full circle), centre offsets from S to C.
    assert not any(a in circle for a in axes)
    assert np.allclose(s + np.array([circle[o] for o in offs]), c, atol=1e-6)
    assert np.linalg.norm(s - c) == pytest.approx(radius, abs=1e-5)
    # Run-out: from S about C back to P.
    assert np.allclose([lead_out[a] for a in axes], p, atol=1e-6)
    assert np.allclose(s + np.array([lead_out[o] for o in offs]), c, atol=1e-6)
    # S at 45 deg: the quadrant crossings are 45 deg from the data arc's ends.
    d = s - c
    assert abs(abs(d[0]) - abs(d[1])) < 1e-5 and d[0] > 0 and d[1] > 0


def test_ballbar_program_runs_ccw_then_cw_and_ends():
    prog = circle_test_program()
    assert prog.directions == ("ccw", "cw")
    assert prog.lines["ccw"][2] < prog.lines["cw"][0]
    lines = prog.text.splitlines()
    assert lines[-1].startswith("M2")
    assert words(lines[prog.circle_line("ccw") - 1])["I"] == pytest.approx(
        -50 / math.sqrt(2), abs=1e-6
    )
    assert any(line.startswith("G21 G90 G94 G17") for line in lines)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"plane": "ZX"}, "XY, XZ, YZ"),
        ({"radius_mm": 0.0}, "> 0"),
        ({"feed_mm_per_min": -5.0}, ">= 0.001"),
        ({"directions": ("up",)}, "'cw' or 'ccw'"),
    ],
)
def test_invalid_options_are_config_errors(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        circle_test_program(**kwargs)


@pytest.mark.parametrize("plane", ["XY", "XZ", "YZ"])
def test_interpreter_reads_tangent_arcs_of_one_circle(plane):
    from gantry_sim.controller.arcs import arc_derivatives
    from gantry_sim.controller.gcode.interpreter import parse_program

    prog = circle_test_program(plane, 20.0, 1500.0, ("ccw", "cw"), (5.0, -5.0, 2.0))
    arcs = {
        m.line: m for m in parse_program(prog.text, "linuxcnc", "ballbar.ngc") if m.kind == "arc"
    }
    for d in ("ccw", "cw"):
        lead_in, circle, lead_out = (arcs[n] for n in prog.lines[d])
        assert {lead_in.direction, circle.direction, lead_out.direction} == {d}
        assert circle.angle == pytest.approx(2 * math.pi)
        assert lead_in.angle == pytest.approx(math.pi) and lead_out.angle == pytest.approx(math.pi)
        for arc in (lead_in, circle, lead_out):
            assert arc.radius == pytest.approx(20.0, abs=1e-5)
            assert np.allclose(arc.center, (5.0, -5.0, 2.0), atol=1e-6)
        assert np.allclose(circle.center, (5.0, -5.0, 2.0), atol=1e-6)
        # The unit tangents agree where the blocks meet: no corner, so no stop.
        for a, b in ((lead_in, circle), (circle, lead_out)):
            ta = arc_derivatives(a, 1.0)[0][0]
            tb = arc_derivatives(b, 0.0)[0][0]
            assert np.allclose(ta / np.linalg.norm(ta), tb / np.linalg.norm(tb), atol=1e-6)


@pytest.mark.parametrize("radius,feed", [(5.0, 2400.0), (50.0, 12000.0)])
def test_the_measured_circle_runs_at_the_programmed_feed(machine, radius, feed):
    """The run-in brings the planner to full feed before the measured block, and the run-out
    starts its stop after it: the circle's reference moves at the feed all the way round."""
    from gantry_sim.controller.gcode.interpreter import parse_program
    from gantry_sim.controller.planner.plan import plan

    prog = circle_test_program("XY", radius, feed, ("ccw",))
    traj = plan(parse_program(prog.text, "linuxcnc", "b.ngc"), machine).sample(0.001)
    on = traj.line == prog.circle_line("ccw")
    speed_mm_per_min = np.linalg.norm(traj.vel[on], axis=1) * 60.0
    assert speed_mm_per_min.min() > 0.995 * feed
    assert speed_mm_per_min.max() < 1.005 * feed
