"""A plan's reference built window by window (blocks written to a temporary file, windows
taken back) is the curve of the chunks kept, bit for bit (planner/segmented_curve.py,
spill.py)."""

from __future__ import annotations

import os
import pickle
import tempfile

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.planner import segmented_curve as sc
from gantry_sim.controller.planner.cubic import Jerk3Run
from tests.plan_helpers import plan_with_chunks
from tests.test_segmented_curve import PROGRAM

_PHASES = 9  # phases per block in these tests: a few segments each


@pytest.fixture(scope="module")
def chunks():
    """The chunks of PROGRAM's plan (every kind of segment)."""
    _, seen = plan_with_chunks(PROGRAM)
    assert any(isinstance(s, Jerk3Run) for c in seen for s in c)
    return tuple(seen)


def _assert_same(a: sc.SegmentedCurve, b: sc.SegmentedCurve) -> None:
    assert a.phase_counts == b.phase_counts
    for axis_a, axis_b in zip(a.axes, b.axes, strict=True):
        for col_a, col_b in zip(axis_a, axis_b, strict=True):
            assert np.array_equal(col_a, col_b)
    end = max(float(ax[0][-1]) if ax[0].size else 0.0 for ax in b.axes) + 0.1
    t = np.linspace(-0.05, end, 3001)
    for x, y in zip(a.evaluate(t), b.evaluate(t), strict=True):
        assert np.array_equal(x, y)


def _steps():
    """Add the next 1-4 chunks, or take back 0-5 of those added."""
    return st.lists(
        st.one_of(
            st.tuples(st.just("add"), st.integers(1, 4)),
            st.tuples(st.just("back"), st.integers(0, 5)),
        ),
        min_size=1,
        max_size=20,
    )


@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(steps=_steps())
def test_chunks_added_and_taken_back_build_the_curve_of_those_kept(chunks, steps) -> None:
    """Windows are kept and sent back in any order: the curve is that of the chunks kept,
    whether the chunks taken back were in the open block or in blocks on disk."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sc, "BLOCK_PHASES", _PHASES)
        builder = sc.CurveBuilder()
        kept: list = []
        nxt = 0
        for what, k in steps:
            if what == "add":
                new = list(chunks[nxt % len(chunks) : nxt % len(chunks) + k])
                nxt += k
                kept.extend(new)
                builder.extend(new)
            else:
                keep = max(0, len(kept) - k)
                del kept[keep:]
                builder.truncate(keep)
            assert len(builder) == len(kept)
        built = builder.finish()
        _assert_same(built, sc.SegmentedCurve(list(kept)))


def test_full_blocks_go_to_the_temporary_file_and_come_back(chunks, monkeypatch) -> None:
    monkeypatch.setattr(sc, "BLOCK_PHASES", _PHASES)
    monkeypatch.setattr(sc, "CACHED_BLOCKS", 1)
    curve = sc.SegmentedCurve(list(chunks))
    assert curve.spilled_bytes > 0
    monkeypatch.setattr(sc, "BLOCK_PHASES", 10**9)  # one block, never written
    whole = sc.SegmentedCurve(list(chunks))
    assert whole.spilled_bytes == 0
    _assert_same(curve, whole)


@pytest.mark.parametrize("failing", ["create", "write"])
def test_without_a_writable_temporary_file_the_blocks_stay_in_memory(
    chunks, monkeypatch, failing
) -> None:
    """No temporary folder, or a disk that fills up during the plan: the same curve, in memory."""

    def refuse(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(sc, "BLOCK_PHASES", _PHASES)
    if failing == "create":
        monkeypatch.setattr(tempfile, "TemporaryFile", refuse)
    else:
        monkeypatch.setattr(os, "pwrite", refuse)
    curve = sc.SegmentedCurve(list(chunks))
    assert curve.spilled_bytes == 0
    monkeypatch.undo()
    _assert_same(curve, sc.SegmentedCurve(list(chunks)))


def test_a_spilled_curve_pickles_whole(chunks, monkeypatch) -> None:
    """A plan sent to another process carries its blocks, not a file descriptor."""
    monkeypatch.setattr(sc, "BLOCK_PHASES", _PHASES)
    curve = sc.SegmentedCurve(list(chunks))
    copy = pickle.loads(pickle.dumps(curve))
    assert copy.spilled_bytes == 0
    _assert_same(copy, curve)
