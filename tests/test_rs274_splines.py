"""Splines (G5, G5.1, G5.2/G5.3) against LinuxCNC's own interpreter, program for program.

``tests/data/rs274_splines`` (``scripts/make_rs274_spline_corpus.py``): per program, rs274 -g's
NURBS_FEED control-point counts and error, and the points of LinuxCNC's own NURBS evaluation at
u = j * umax / (15 k) as its ``gcode`` module hands them out (work frame, mm). The interpreter
must refuse the same programs on the same line (with a message of the same meaning), make the
same moves, and its exact curves must pass through every one of rs274's points at the same
parameter (1e-9 mm: the points are exact evaluations on both sides), so end points and end
tangents agree too (the tangents are checked against rs274's points by second-order differences).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.interpreter import interpret
from gantry_sim.controller.moves import Rapid, Spline

DATA = Path(__file__).parent / "data" / "rs274_splines"
PROGRAMS = sorted((DATA / "programs").glob("*.ngc"))
TOL_MM = 1e-9

#: rs274's message -> what ours must say (the same meaning in gantry-sim's words)
MEANING = {
    "P word with no": "p word",
    "Splines must be in the XY plane": "xy plane",
    "Must specify both I and J with G5.1": "both i and j",
    "Cannot convert spline with cutter radius compensation": "cutter radius compensation",
    "Must specify both I and J, or neither": "both i and j, or neither",
    "F word missing with inverse time": "inverse time",
    "K word with no": "k word",
    "All axes missing with motion code": "axes missing",
    "Must specify both P and Q with G5": "both p and q",
    "Splines may not have motion in Z": "motion in z",
    "Cannot use axis values without a g code": "no motion mode",
    "Cannot use G5.3 without G5.2 first": "without g5.2 first",
    "Between G5.2 and G5.3 codes": "between g5.2 and g5.3",
    "Must specify positive weight P": "positive weight p",
    "Can specify P without X and Y only for the first": "only on the first control point",
    "You must specify a number of control points at least equal to the order": "order l = 5",
    "You must specify both X and Y coordinates": "both x and y",
}


def test_the_corpus_is_there() -> None:
    assert len(PROGRAMS) >= 122
    assert {p.stem for p in PROGRAMS} >= {"own_nurbs_outline", "own_g51_engraving"}


def _run(text: str) -> tuple[list, GcodeError | None]:
    moves: list = []
    try:
        for m in interpret(text):
            moves.append(m)
    except GcodeError as exc:
        return moves, exc
    return moves, None


def _rs274_parameters(k: int, umax: float) -> list[float]:
    """gcodemodule.cc NURBS_FEED's parameters, in its own float arithmetic."""
    div = k * 15
    u, out = 0.0, []
    while u + umax / div < umax:
        out.append(u + umax / div)
        u = u + umax / div
    return out


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


@pytest.mark.parametrize("path", PROGRAMS, ids=[p.stem for p in PROGRAMS])
def test_matches_rs274(path: Path) -> None:
    expected = json.loads((DATA / "expected" / f"{path.stem}.json").read_text())
    moves, error = _run(path.read_text())
    exp_err = expected["error"]
    if exp_err is None:
        assert error is None, f"rs274 accepts it; gantry-sim: {error}"
    else:
        assert error is not None, f"rs274 refuses line {exp_err['line']}: {exp_err['message']}"
        assert error.line == exp_err["line"], (str(error), exp_err)
        want = next(v for k, v in MEANING.items() if exp_err["message"].startswith(k))
        assert want in error.message.lower(), (error.message, exp_err["message"])
    splines = [m for m in moves if isinstance(m, Spline)]
    assert [len(s.control_points) for s in splines] == expected["nurbs_feeds"]
    rs = expected["moves"]
    k = 0
    for m in moves:
        if not isinstance(m, Spline):
            e = rs[k]
            assert e[:2] == [m.line, "traverse" if isinstance(m, Rapid) else "feed"]
            assert np.allclose(e[2:], m.end, rtol=0, atol=TOL_MM), (m, e)
            k += 1
            continue
        nurbs = m.curve.nurbs
        u = _rs274_parameters(len(m.control_points), nurbs.t_max)
        got = rs[k : k + len(u) + 1]
        k += len(u) + 1
        assert all(e[:2] == [m.line, "feed"] for e in got)
        pts = np.array([e[2:] for e in got], dtype=float)
        ours = nurbs.points(np.array(u))
        assert np.abs(ours - pts[:-1]).max() <= TOL_MM
        assert np.abs(np.array(m.end) - pts[-1]).max() <= TOL_MM
        # end tangents: rs274's first (last) two points away from the end and the end point,
        # differentiated through their parabola (error b c / 6 max |C'''|, b and c their
        # parameter distances from the end); where C' vanishes (I0 J0) only the direction is
        # defined
        t_in, _, t_out, _ = m.curve.end_frames
        uu = np.array(u)
        h = nurbs.t_max / (15 * len(m.control_points))
        for end_u, tangent, f0 in ((0.0, t_in, np.array(m.start)), (nurbs.t_max, t_out, pts[-1])):
            near = np.argsort(np.abs(uu - end_u))
            i1, i2 = [int(i) for i in near if abs(uu[i] - end_u) > 0.5 * h][:2]
            b, c = uu[i1] - end_u, uu[i2] - end_u
            w0, w1, w2 = -(b + c) / (b * c), c / (b * (c - b)), -b / (c * (c - b))
            est = w0 * f0 + w1 * pts[i1] + w2 * pts[i2]
            span = np.linspace(end_u, end_u + c, 9)
            third = np.linalg.norm(nurbs.derivatives(span, 3)[3], axis=1).max()
            exact = nurbs.derivatives(np.array([end_u]), 1)[1][0]
            if np.linalg.norm(exact) > 1e-9:
                assert np.linalg.norm(est - exact) <= 1.5 * abs(b * c) / 6 * third + 1e-9
                assert np.allclose(tangent, _unit(exact), atol=1e-12)
    assert k == len(rs), f"rs274 made {len(rs) - k} more moves"
