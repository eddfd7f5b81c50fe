"""A block of segments packed into a few arrays gives back the segments and lays out the phases
of the segments one by one, bit for bit (planner/packed_block.py)."""

from __future__ import annotations

import numpy as np
import pytest

from gantry_sim.controller.planner.cubic import Jerk3Run
from gantry_sim.controller.planner.packed_block import PackedBlock
from tests.plan_helpers import plan_with_chunks
from tests.test_segmented_curve import PROGRAM


@pytest.fixture(scope="module")
def segments():
    """Every segment of PROGRAM's plan: closed-form runs, (3, 5, n) arrays and per-axis
    tuples (test_segmented_curve checks all three are there)."""
    _, chunks = plan_with_chunks(PROGRAM)
    return [s for c in chunks for s in c]


def _one_by_one(segments, axis: int, start_s: float):
    """The phases of ``axis`` laid out segment by segment, as before the blocks were packed."""
    rows = [s.axis_phases(axis) if isinstance(s, Jerk3Run) else tuple(s[axis]) for s in segments]
    dur, p, v, a, j = (np.concatenate([r[k] for r in rows]) for k in range(5))
    t0 = np.cumsum(np.concatenate(([start_s], dur)))[:-1]
    return t0, p, v, a, j


def _same_segment(a, b) -> None:
    assert type(a) is type(b)
    if isinstance(a, Jerk3Run):
        assert np.array_equal(a.rows, b.rows)
    elif isinstance(a, np.ndarray):
        assert a.shape == b.shape and np.array_equal(a, b)
    else:
        for x, y in zip(a, b, strict=True):
            assert x.shape == y.shape and np.array_equal(x, y)


@pytest.mark.parametrize("part", [slice(None), slice(0, 1), slice(2, 9), slice(5, None, 3)])
def test_a_packed_block_gives_back_its_segments(segments, part) -> None:
    segs = segments[part]
    back = PackedBlock(segs).segments()
    assert len(back) == len(segs)
    for a, b in zip(segs, back, strict=True):
        _same_segment(a, b)


@pytest.mark.parametrize("part", [slice(None), slice(0, 1), slice(2, 9), slice(5, None, 3)])
def test_a_packed_block_lays_out_the_phases_of_its_segments(segments, part) -> None:
    segs = segments[part]
    start = np.array([0.25, 1.5, 3.0])
    block = PackedBlock(segs)
    laid = block.layout(start)
    for i in range(3):
        want = _one_by_one(segs, i, float(start[i]))
        for got, expected in zip(laid[i], want, strict=True):
            assert got.dtype == np.float64
            assert np.array_equal(got, expected)
        assert np.array_equal(
            np.cumsum(np.concatenate(([start[i]], block.durations(i))))[:-1], want[0]
        )


def test_only_runs_or_no_runs(segments) -> None:
    """A block of closed-form runs alone, and one without any."""
    runs = [s for s in segments if isinstance(s, Jerk3Run)]
    rest = [s for s in segments if not isinstance(s, Jerk3Run)]
    for segs in (runs, rest):
        laid = PackedBlock(segs).layout(np.zeros(3))
        for i in range(3):
            for got, expected in zip(laid[i], _one_by_one(segs, i, 0.0), strict=True):
                assert np.array_equal(got, expected)
