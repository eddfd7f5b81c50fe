"""Segmentation: chord count (grbl formula), vertices exactly on the arc, fixed length (Marlin)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.controller.errors import ConfigError, PlanningError
from gantry_sim.controller.planes import PLANE_AXES
from gantry_sim.controller.planner.segment import MAX_SEGMENTS_PER_ARC, segment_arc, segment_count
from tests.plan_helpers import arc, helix


def _sagittas(a, verts) -> np.ndarray:
    """Distance of every chord midpoint from the true arc (radius and normal-axis error)."""
    i1, i2, _n = PLANE_AXES[a.plane]
    mid = 0.5 * (verts[1:] + verts[:-1])
    r = np.hypot(mid[:, i1] - a.center[i1], mid[:, i2] - a.center[i2])
    return np.abs(r - a.radius)


@pytest.mark.parametrize("radius", [0.5, 1.0, 10.0, 200.0])
@pytest.mark.parametrize("tol", [0.001, 0.01])
def test_chord_count_is_grbl_formula_and_within_tolerance(radius, tol):
    a = arc(1, (radius, 0.0, 0.0), (0.0, 0.0, 0.0), 2 * math.pi)
    verts = segment_arc(a, "chord", tol, 1.0)
    n = len(verts) - 1
    expected = math.ceil(2 * math.pi * radius / (2 * math.sqrt(tol * (2 * radius - tol))))
    assert n == max(expected, 4)
    assert _sagittas(a, verts).max() <= tol
    # one chord fewer would break the tolerance: the count is the fewest
    phi = 2 * math.pi / (n - 1)
    assert radius * (1 - math.cos(phi / 2)) > tol


@pytest.mark.parametrize("plane", ["XY", "XZ", "YZ"])
@pytest.mark.parametrize("direction", ["cw", "ccw"])
def test_vertices_exactly_on_the_arc_and_end_exact(plane, direction):
    start = [3.0, -2.0, 1.0]
    i1, i2, _ = PLANE_AXES[plane]
    center = list(start)
    center[i1] -= 7.0
    center[i2] += 1.0
    a = arc(5, start, center, 2.3, plane=plane, direction=direction)
    verts = segment_arc(a, "chord", 0.001, 1.0)
    r = np.hypot(verts[:, i1] - center[i1], verts[:, i2] - center[i2])
    assert np.max(np.abs(r - a.radius)) < 1e-12
    assert tuple(verts[0]) == a.start and tuple(verts[-1]) == a.end
    assert not verts.flags.writeable
    # vertices evenly spaced in angle (computed, not accumulated)
    th = np.unwrap(np.arctan2(verts[:, i2] - center[i2], verts[:, i1] - center[i1]))
    assert np.ptp(np.diff(th)) < 1e-12


def test_helix_vertices_rise_linearly_and_stay_within_tolerance():
    h = helix(1, (5.0, 0.0, 0.0), (0.0, 0.0, 0.0), dz=-6.0, turns=3)
    verts = segment_arc(h, "chord", 0.001, 1.0)
    dz = np.diff(verts[:, 2])
    assert np.allclose(dz, dz[0]) and verts[-1, 2] == -6.0
    assert _sagittas(h, verts).max() <= 0.001


def test_tiny_radius_arc_still_has_quarter_chords():
    a = arc(1, (0.0002, 0.0, 0.0), (0.0, 0.0, 0.0), 2 * math.pi)
    assert segment_count(a, "chord", 0.001, 1.0) == 4  # r < tol/2: at most 90 degrees per chord


def test_fixed_length_marlin_rules():
    big = arc(1, (50.0, 0.0, 0.0), (0.0, 0.0, 0.0), 2 * math.pi)
    assert segment_count(big, "fixed", 0.001, 1.0) == math.floor(2 * math.pi * 50)
    small = arc(1, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0), math.pi)
    assert segment_count(small, "fixed", 0.001, 1.0) == 36  # MIN_CIRCLE_SEGMENTS 72 per circle
    verts = segment_arc(big, "fixed", 0.001, 1.0)
    chords = np.linalg.norm(np.diff(verts, axis=0), axis=1)
    assert chords.max() <= 1.0 + 1e-3 and tuple(verts[-1]) == big.end


def test_absurd_turn_count_is_refused_with_its_line():
    h = helix(42, (10.0, 0.0, 0.0), (0.0, 0.0, 0.0), dz=1.0, turns=1_000_000)
    with pytest.raises(PlanningError) as exc:
        segment_arc(h, "chord", 0.001, 1.0)
    assert exc.value.line == 42 and str(MAX_SEGMENTS_PER_ARC) in exc.value.message


def test_unknown_method_is_a_config_error():
    a = arc(1, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1.0)
    with pytest.raises(ConfigError, match="chord, fixed"):
        segment_arc(a, "spline", 0.001, 1.0)
