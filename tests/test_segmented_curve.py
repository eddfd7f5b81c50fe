"""A plan's reference held segment by segment samples as the laid-out phases do, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from gantry_sim.controller.planner import segmented_curve as sc
from gantry_sim.controller.planner.cubic import Jerk3Run, PiecewiseCubic
from tests.plan_helpers import plan_with_chunks

#: lines and corners (straight phases), tangent arcs with curvature jumps (closed-form pieces and,
#: in G61, where a line meets an arc with no G2 transition, a Ruckig piece), a helix, a dwell (a
#: hold), a rapid
PROGRAM = """G21 G17 G90 G64 P0.01 F3000
G0 X0 Y0 Z0
G1 X5
G1 X10 Y0.3
G1 X10.2 Y0.3
G2 X14 Y4.1 I3.8 J0
G3 X18 Y8.1 I0 J4
G4 P0.2
G61
G1 X18 Y12
G2 X22 Y16 I4 J0
G64 P0.01
G1 X20 Y5 F800
G3 X20 Y5 Z-1 I-3 J0
G0 Z5
G1 X0 Y0 F2000
M2
"""


@pytest.fixture(scope="module")
def planned_and_chunks():
    """The plan of PROGRAM and a copy of the chunks its curve was made of."""
    return plan_with_chunks(PROGRAM)


def _laid_out_once(chunks) -> PiecewiseCubic:
    """The phases laid out in one pass: every duration summed in order from 0 (the layout the
    plan had before it kept segments)."""
    axes = []
    for i in range(3):
        rows = [
            s.axis_phases(i) if isinstance(s, Jerk3Run) else tuple(s[i]) for c in chunks for s in c
        ]
        dur, p, v, a, j = (np.concatenate([r[k] for r in rows]) for k in range(5))
        t0 = np.concatenate(([0.0], np.cumsum(dur)[:-1]))
        axes.append((t0, p, v, a, j))
    return PiecewiseCubic(tuple(axes))


def _times(curve: PiecewiseCubic, end_s: float) -> np.ndarray:
    """Every phase start, points between, and times before 0 and past the end."""
    starts = np.concatenate([ax[0] for ax in curve.axes])
    rng = np.random.default_rng(3)
    return np.concatenate(
        (starts, rng.uniform(-0.1, end_s + 0.1, 5000), np.arange(0, end_s, 1e-3), [-1.0, end_s])
    )


def test_the_program_has_every_kind_of_segment(planned_and_chunks) -> None:
    p, chunks = planned_and_chunks
    segs = [s for c in chunks for s in c]
    assert any(isinstance(s, Jerk3Run) for s in segs)
    assert any(isinstance(s, np.ndarray) for s in segs)  # axes with as many phases: one array
    assert any(isinstance(s, tuple) for s in segs)  # a Ruckig piece's axes differ in phases
    assert p.ruckig_piece_count > 0
    assert len(p.blends) > 0


@pytest.mark.parametrize("block_phases", [1, 7, 50, 10**9])
def test_blocks_of_any_size_sample_as_the_laid_out_phases(
    planned_and_chunks, block_phases, monkeypatch
) -> None:
    p, chunks = planned_and_chunks
    monkeypatch.setattr(sc, "BLOCK_PHASES", block_phases)
    monkeypatch.setattr(sc, "CACHED_BLOCKS", 1)
    curve = sc.SegmentedCurve(list(chunks))
    once = _laid_out_once(chunks)
    for got, want in zip(curve.axes, once.axes, strict=True):
        for g, w in zip(got, want, strict=True):
            assert np.array_equal(g, w)
    t = _times(once, p.duration_s)
    for order in (np.arange(t.size), np.random.default_rng(5).permutation(t.size)):
        got = curve.evaluate(t[order])
        want = once.evaluate(t[order])
        for g, w in zip(got, want, strict=True):
            assert np.array_equal(g, w)


def test_the_plan_samples_from_its_segments(planned_and_chunks) -> None:
    p, chunks = planned_and_chunks
    assert isinstance(p.curve, sc.SegmentedCurve)
    assert p.curve.phase_counts == tuple(ax[0].size for ax in _laid_out_once(chunks).axes)
    tr = p.sample(1e-3)
    pos, vel, _ = _laid_out_once(chunks).evaluate(tr.t)
    inside = tr.t < p.duration_s
    assert np.array_equal(tr.pos[inside], pos[inside])
    assert np.array_equal(tr.vel[inside], vel[inside])
    assert np.allclose(tr.pos[-1], p.end_mm) and not np.any(tr.vel[-1])


def test_an_empty_curve_is_at_the_origin() -> None:
    curve = sc.SegmentedCurve([])
    pos, vel, acc = curve.evaluate(np.array([0.0, 1.0]))
    assert curve.phase_counts == (0, 0, 0)
    assert not pos.any() and not vel.any() and not acc.any()
