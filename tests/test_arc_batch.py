"""The batched arc deviation: points checked against one arc give what the rows of a batch of
arcs give, bit for bit (the planner checks a Ruckig piece's samples one arc at a time)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.arcs import arc_points
from gantry_sim.controller.moves import Arc
from gantry_sim.controller.planes import PLANE_AXES
from gantry_sim.controller.planner.arc_batch import arc_deviation_many


def _arc(plane: str, ccw: bool, radius: float, angle: float, rise: float, spiral: float) -> Arc:
    """An arc (helix, spiral) of ``plane`` about the origin starting on its first axis."""
    i1, i2, n = PLANE_AXES[plane]
    sigma = 1.0 if ccw else -1.0
    start, end = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
    start[i1] = radius
    end[i1] = radius * (1.0 + spiral) * math.cos(sigma * angle)
    end[i2] = radius * (1.0 + spiral) * math.sin(sigma * angle)
    end[n] = rise
    return Arc(
        line=1,
        start=(start[0], start[1], start[2]),
        end=(end[0], end[1], end[2]),
        feed_mm_per_min=1200.0,
        plane=plane,  # type: ignore[arg-type]
        direction="ccw" if ccw else "cw",
        center=(0.0, 0.0, 0.0),
        radius=radius,
        turns=1,
        angle=angle,
    )


@settings(max_examples=60, deadline=None)
@given(
    plane=st.sampled_from(["XY", "XZ", "YZ"]),
    ccw=st.booleans(),
    radius=st.floats(0.05, 200.0),
    angle=st.floats(0.01, 3.0 * math.pi),
    rise=st.floats(-5.0, 5.0),
    spiral=st.floats(-1e-3, 1e-3),
    pieces=st.integers(1, 4),
    seed=st.integers(0, 2**31),
)
def test_points_near_one_arc_give_the_rows_of_a_batch(
    plane, ccw, radius, angle, rise, spiral, pieces, seed
):
    arc = _arc(plane, ccw, radius, angle, rise, spiral)
    rng = np.random.default_rng(seed)
    hints = rng.uniform(-0.1, 1.1, pieces)
    u = np.clip(hints[:, None] + rng.uniform(-0.05, 0.05, (pieces, 25)), -0.2, 1.2)
    q = np.stack([arc_points(arc, row) for row in u]) + rng.normal(0.0, 1e-3, (pieces, 25, 3))
    one = arc_deviation_many([arc] * pieces, q, hints.tolist())
    copies = [dataclasses.replace(arc) for _ in range(pieces)]  # equal, not the same: rows
    assert np.array_equal(one, arc_deviation_many(copies, q, hints.tolist()))
    assert one.shape == (pieces,) and np.all(one >= 0.0)
