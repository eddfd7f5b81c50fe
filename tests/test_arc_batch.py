"""Arcs in batches: the deviation of points checked against one arc gives what the rows of a
batch of arcs give (and what the arc's geometry gives piece by piece), and the points of many arcs at once are each arc's own, bit for bit (the
planner checks a Ruckig piece's samples one arc at a time, and moves the vertices of a round's
arcs all at once)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.arcs import arc_points
from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.moves import Arc
from gantry_sim.controller.planes import PLANE_AXES
from gantry_sim.controller.planner.arc_batch import (
    arc_deviation_many,
    arc_deviation_one,
    arc_points_many,
)
from gantry_sim.controller.planner.move_geometry import move_geometry
from gantry_sim.controller.planner.segment import segment_arc, segment_count
from gantry_sim.models import DEFAULT_MACHINE


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


MACHINE = load_machine_config(DEFAULT_MACHINE)


@settings(max_examples=60, deadline=None)
@given(
    plane=st.sampled_from(["XY", "XZ", "YZ"]),
    ccw=st.booleans(),
    radius=st.floats(0.05, 200.0),
    angle=st.floats(0.01, 3.0 * math.pi),
    rise=st.floats(-5.0, 5.0),
    spiral=st.floats(-1e-3, 1e-3),
    pieces=st.integers(1, 4),
    inside=st.booleans(),
    seed=st.integers(0, 2**31),
)
def test_points_near_one_arc_give_the_rows_of_a_batch(
    plane, ccw, radius, angle, rise, spiral, pieces, inside, seed
):
    arc = _arc(plane, ccw, radius, angle, rise, spiral)
    rng = np.random.default_rng(seed)
    hints = rng.uniform(-0.1, 1.1, pieces)
    u = np.clip(hints[:, None] + rng.uniform(-0.05, 0.05, (pieces, 25)), -0.2, 1.2)
    if inside:  # every point within the sweep: the overrun term is skipped
        u = np.clip(u, 0.0, 1.0)
    q = np.stack([arc_points(arc, row) for row in u]) + rng.normal(0.0, 1e-3, (pieces, 25, 3))
    one = arc_deviation_one(arc, q, hints.tolist())
    assert np.array_equal(one, arc_deviation_many([arc] * pieces, q, hints.tolist()))
    copies = [dataclasses.replace(arc) for _ in range(pieces)]  # equal, not the same: rows
    assert np.array_equal(one, arc_deviation_many(copies, q, hints.tolist()))
    assert one.shape == (pieces,) and np.all(one >= 0.0)
    geometry = move_geometry(arc, MACHINE.limits, MACHINE.segmentation, 1.0)
    assert one.tolist() == [geometry.deviation(row, h) for row, h in zip(q, hints, strict=True)]


@settings(max_examples=40, deadline=None)
@given(
    arcs=st.lists(
        st.tuples(
            st.sampled_from(["XY", "XZ", "YZ"]),
            st.booleans(),
            st.floats(0.05, 200.0),
            st.floats(0.01, 3.0 * math.pi),
            st.floats(-5.0, 5.0),
            st.floats(-1e-3, 1e-3),
            st.integers(0, 6),
        ),
        min_size=1,
        max_size=6,
    ),
    seed=st.integers(0, 2**31),
)
def test_points_of_many_arcs_at_once_are_each_arcs_own(arcs, seed):
    """The vertices moved onto a profile's phase switches, for a batch of arcs at once: each
    arc's points are its geometry's (u = 0 and 1: its start and end exactly)."""
    rng = np.random.default_rng(seed)
    moves = [_arc(*spec[:6]) for spec in arcs]
    us = [np.sort(np.concatenate(([0.0, 1.0], rng.random(spec[6])))) for spec in arcs]
    got = arc_points_many(moves, us)
    for move, u, pts in zip(moves, us, got, strict=True):
        geometry = move_geometry(move, MACHINE.limits, MACHINE.segmentation, 1.0)
        assert np.array_equal(pts, geometry.points(u))
        seg = MACHINE.segmentation  # the chords made in a batch: at u = i / n, the ends exact
        n = segment_count(move, seg.method, seg.chord_tolerance_mm, seg.segment_length_mm)
        own = arc_points(move, np.arange(n + 1) / n)
        own[0], own[-1] = move.start, move.end
        assert np.array_equal(geometry.vertices, own)
        assert np.array_equal(
            segment_arc(move, seg.method, seg.chord_tolerance_mm, seg.segment_length_mm), own
        )
        assert np.array_equal(pts[0], move.start) and np.array_equal(pts[-1], move.end)
