"""A window's move geometries made at once (controller/planner/move_geometry.py
move_geometries): each straight move's and each arc's numbers are those of the move taken
alone by the scalar definitions (straight_limits, frenet, norm), bit for bit."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.arcs import arc_derivatives, frenet
from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.moves import Arc, Linear, Rapid
from gantry_sim.controller.planner.arc_batch import ARC_ENDS
from gantry_sim.controller.planner.limits import straight_limits
from gantry_sim.controller.planner.move_geometry import move_geometries
from gantry_sim.controller.units import mm_per_min_to_mm_per_s
from gantry_sim.controller.vector import norm
from gantry_sim.models import DEFAULT_MACHINE

MACHINE = load_machine_config(DEFAULT_MACHINE)

#: coordinates [mm], with repeats so that some moves keep an axis still (or do not move)
_coord = st.sampled_from([0.0, 1.5, -2.25]) | st.floats(-500.0, 500.0)
_point = st.tuples(_coord, _coord, _coord)


@st.composite
def _straight(draw: st.DrawFn) -> Linear | Rapid:
    start, end = draw(_point), draw(_point)
    if draw(st.booleans()):
        return Rapid(1, start, end)
    return Linear(1, start, end, draw(st.floats(0.01, 30_000.0)))


@settings(max_examples=60)
@given(st.lists(_straight(), min_size=1, max_size=25), st.sampled_from([1.0, 0.37, 1.5]))
def test_straight_moves_at_once_are_each_move_alone(moves, feed_scale):
    geoms = move_geometries(moves, MACHINE.limits, MACHINE.segmentation, feed_scale)
    for m, g in zip(moves, geoms, strict=True):
        verts = np.array([m.start, m.end], dtype=float)
        length = norm(verts[1] - verts[0])
        t = (verts[1] - verts[0]) / length if length > 0 else np.array([1.0, 0.0, 0.0])
        feed = (
            math.inf
            if isinstance(m, Rapid)
            else mm_per_min_to_mm_per_s(m.feed_mm_per_min) * feed_scale
        )
        assert g.move is m and not g.is_arc
        assert g.vertices.tolist() == verts.tolist() and not g.vertices.flags.writeable
        assert g.length_mm == length and g.feed_mm_per_s == feed
        assert g.tangent_in.tolist() == t.tolist() == g.tangent_out.tolist()
        assert g.curv_in.tolist() == [0.0, 0.0, 0.0] == g.curv_out.tolist()
        assert g.limits == straight_limits(t, length, feed, MACHINE.limits)


def test_arcs_at_once_are_each_arc_alone():
    """Arcs, helices and quarter circles in each plane, among straight moves: each arc's end
    tangents, curvatures and length are frenet's and norm's of its own end derivatives."""
    program = "\n".join(
        [
            "G21 G90 G17 G64 P0.01 F1200",
            "G1 X10 Y0 Z0",
            "G3 X0 Y10 I-10 J0",
            "G2 X-3 Y13 Z-2 I0 J3",  # a helix
            "G18 G2 X-3 Z-6 I0 K-2",
            "G19 G3 Y9 Z-10 J-2 K-2 P2",  # two turns and a bit
            "G17 G1 X0 Y0",
            "G2 X0.02 Y0 I0.01 J0",  # a small one
            "M2",
        ]
    )
    moves = [m for m in parse_program(program) if isinstance(m, Arc | Linear | Rapid)]
    geoms = move_geometries(moves, MACHINE.limits, MACHINE.segmentation, 1.0)
    arcs = [(m, g) for m, g in zip(moves, geoms, strict=True) if isinstance(m, Arc)]
    assert len(arcs) == 5
    for arc, g in arcs:
        d1, d2 = arc_derivatives(arc, ARC_ENDS)
        t_in, k_in = frenet(d1[0], d2[0])
        t_out, k_out = frenet(d1[1], d2[1])
        assert g.tangent_in.tolist() == t_in.tolist()
        assert g.tangent_out.tolist() == t_out.tolist()
        assert g.curv_in.tolist() == k_in.tolist()
        assert g.curv_out.tolist() == k_out.tolist()
        n = len(g.vertices) - 1
        assert g.u.tolist() == (np.arange(n + 1) / n).tolist() and not g.u.flags.writeable
        if not g.uneven:  # (a spiral's length is integrated)
            assert g.length_mm == 0.5 * (norm(d1[0]) + norm(d1[1]))
