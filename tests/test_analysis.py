"""Contour error against the commanded geometry: arcs, helices, multi-turn, junctions, rapids."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.controller.arcs import arc_derivatives, arc_points
from gantry_sim.controller.gcode.interpreter import interpret
from gantry_sim.sim.contour import BlockError, analyse, distance_to_program
from gantry_sim.sim.nearest import nearest_on_arc
from gantry_sim.sim.tracking import distance_to_polyline_near


def _moves(text: str):
    return tuple(interpret(text + "M2\n", "linuxcnc", "t.ngc"))


def test_radial_offsets_from_a_circle_are_measured_exactly():
    (_, arc) = _moves("G17 G1 X10 F1000\nG3 I-10 J0\n")
    ang = np.linspace(0, 2 * np.pi, 37)
    off = np.linspace(-0.01, 0.01, 37)
    pts = np.column_stack([(10 + off) * np.cos(ang), (10 + off) * np.sin(ang), np.zeros(37)])
    q = nearest_on_arc(arc, pts)
    assert np.linalg.norm(q - pts, axis=1) == pytest.approx(np.abs(off), abs=1e-12)


def test_points_beyond_the_sweep_go_to_the_nearest_end():
    (_, arc) = _moves("G17 G1 X10 F1000\nG3 X0 Y10 I-10 J0\n")  # quarter arc, 0..90 degrees
    pts = np.array([[10 * math.cos(-0.3), 10 * math.sin(-0.3), 0.0], [-10.0, 0.0, 0.0]])
    q = nearest_on_arc(arc, pts)
    assert q[0] == pytest.approx([10.0, 0.0, 0.0])
    assert q[1] == pytest.approx([0.0, 10.0, 0.0], abs=1e-12)


@pytest.mark.parametrize("word", ["", " P3"])
def test_helix_offsets_are_perpendicular_distances(word):
    (_, helix) = _moves(f"G17 G1 X5 F1000\nG2 X5 Y0 Z-6 I-5 J0{word}\n")
    u = np.linspace(0.02, 0.98, 25)
    on = arc_points(helix, u)
    d1, _ = arc_derivatives(helix, u)
    # an offset normal to the tangent and to the radial direction is a true perpendicular offset
    radial = np.column_stack([on[:, 0], on[:, 1], np.zeros(len(u))])
    radial /= np.linalg.norm(radial, axis=1)[:, None]
    binormal = np.cross(d1 / np.linalg.norm(d1, axis=1)[:, None], radial)
    pts = on + 0.004 * binormal + 0.003 * radial
    q = nearest_on_arc(helix, pts)
    assert np.linalg.norm(q - pts, axis=1) == pytest.approx(np.full(len(u), 0.005), rel=1e-3)
    assert q == pytest.approx(on, abs=1e-3)  # on the right turn, not a neighbouring one


def test_near_a_junction_the_neighbouring_move_counts():
    moves = _moves("G1 X10 F1000\nG1 Y10\n")
    # executing line 2 (the second move) but still 1 um short of the corner, on the first move
    d, _ = distance_to_program(moves, np.array([2]), np.array([[9.999, 0.0, 0.0]]))
    assert d[0] == pytest.approx(0.0, abs=1e-12)


def test_rapids_do_not_count_and_blocks_are_per_feed_line():
    moves = _moves("G0 X5\nG1 X10 F1000\n")
    ref = np.array([[0, 0, 0], [5, 0, 0], [7, 0, 0], [10, 0, 0]], dtype=float)
    pos = ref + np.array([[0, 0.5, 0], [0, 0.5, 0], [0, 0.002, 0], [0, 0.001, 0]])
    res = analyse(moves, np.array([1, 1, 2, 2]), ref, pos)
    assert res.err_um == pytest.approx([500.0, 500.0, 2.0, 1.0])
    assert res.contour.max_um == pytest.approx(2.0)
    assert res.blocks == (
        BlockError(
            line=2,
            kind="linear",
            max_error_um=pytest.approx(2.0),
            rms_error_um=pytest.approx(math.sqrt(2.5)),
            ticks=2,
        ),
    )
    assert res.parts.reference_max_um == 0.0


def test_tracking_distance_to_the_reference_polyline_matches_brute_force():
    rng = np.random.default_rng(0)
    path = np.cumsum(rng.normal(size=(120, 3)), axis=0)
    pts = path + rng.normal(scale=0.3, size=path.shape)
    window = 4
    expect = []
    for k, p in enumerate(pts):
        best = np.inf
        for s in range(max(0, k - window), min(len(path) - 2, k + window - 1) + 1):
            a, d = path[s], path[s + 1] - path[s]
            u = np.clip((p - a) @ d / (d @ d), 0.0, 1.0)
            best = min(best, float(np.linalg.norm(a + u * d - p)))
        expect.append(best)
    assert distance_to_polyline_near(path, pts, window) == pytest.approx(expect, abs=1e-12)


@pytest.mark.parametrize("batch", [3, 4096])
def test_the_largest_tracking_distance_equals_the_full_search(monkeypatch, batch):
    from gantry_sim.sim import tracking

    monkeypatch.setattr(tracking, "MAX_BATCH", batch)  # 3: many passes of the pruned search
    rng = np.random.default_rng(1)
    t = np.linspace(0, 6 * np.pi, 3000)
    path = np.column_stack([np.cos(t), np.sin(3 * t), 0.1 * t])  # turns back on itself
    path[1000:1010] = path[1000]  # a stop: zero-length segments
    pts = path + rng.normal(scale=0.01, size=path.shape)
    pts[2000] += 0.5  # one far outlier, and a selection that leaves it out
    full = distance_to_polyline_near(path, pts, 50)
    select = rng.random(len(t)) < 0.7
    for sel in (select, np.ones(len(t), dtype=bool), select & (np.arange(len(t)) != 2000)):
        assert tracking.max_distance_to_polyline_near(path, pts, 50, sel) == full[sel].max()
    assert tracking.max_distance_to_polyline_near(path, pts, 50, np.zeros(len(t), bool)) == 0.0


@pytest.mark.parametrize("batch", [3, 4096])
def test_a_trace_lagging_its_reference_is_measured_as_the_full_search(monkeypatch, batch):
    """A trace that follows the reference 0-70 ticks late (beyond the window too), at speeds
    from a stop to fast, on a piece of a longer path (``shift``): the largest distance is the
    full search's, to the last bit."""
    from gantry_sim.sim import tracking

    monkeypatch.setattr(tracking, "MAX_BATCH", batch)
    rng = np.random.default_rng(2)
    n, w, shift = 4000, 50, 51
    s = np.cumsum(np.abs(np.sin(np.linspace(0, 9, n + 2 * shift + 1))) * 0.01)  # speed varies
    path = np.column_stack([np.cos(s), np.sin(2 * s), 0.05 * s])
    lag = (35 + 35 * np.sin(np.linspace(0, 20, n))).astype(int)
    pts = path[shift + np.arange(n) - lag] + rng.normal(scale=1e-6, size=(n, 3))
    piece = path[shift - w : shift + n + w + 1]  # pts[k] at its vertex k + w, the window whole
    padded = np.concatenate([np.zeros((w, 3)), pts, np.zeros((w + 1, 3))])
    full = distance_to_polyline_near(piece, padded, w)[w : w + n]
    assert np.count_nonzero(full[lag >= w] > 1e-3) > 100  # beyond the window: far
    select = rng.random(n) < 0.8
    got = tracking.max_distance_to_polyline_near(path, pts, w, select, shift=shift)
    assert got == full[select].max()
