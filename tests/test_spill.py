"""SpilledList (controller/spill.py): a list kept on disk in blocks reads back what was appended,
by index, slice and in order, across closed and open blocks, after truncation and pickling."""

from __future__ import annotations

import os
import pickle

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.moves import Linear
from gantry_sim.controller.pickled_slice import DecodedBlocks, SliceView
from gantry_sim.controller.spill import SpilledList


def _moves(n: int) -> list[Linear]:
    return [Linear(i + 1, (i, 0.0, 0.0), (i + 1.0, 0.5, 0.0), 600.0) for i in range(n)]


#: a list of n moves in blocks of ``block`` items, on disk or not, cut back to ``cut`` items
LISTS = {
    "n": st.integers(0, 40),
    "block": st.integers(1, 7),
    "spill": st.booleans(),
    "cut": st.integers(0, 45),
}


@settings(max_examples=60, deadline=None)
@given(
    **LISTS,
    lo=st.integers(-50, 50),
    hi=st.integers(-50, 50),
    step=st.sampled_from([1, 2, 3, -1]),
)
def test_reads_back_what_was_appended(n, block, spill, cut, lo, hi, step):
    items = _moves(n)
    s = SpilledList(items, block_items=block, spill=spill)
    assert len(s) == n
    assert list(s) == items
    assert s[lo:hi:step] == items[lo:hi:step]
    for i in range(-n, n):
        assert s[i] == items[i]
    s.truncate(cut)
    del items[cut:]
    assert list(s) == items and len(s) == len(items)
    s.extend(_moves(3))
    items.extend(_moves(3))
    assert list(s) == items and s[-3:] == items[-3:]


@settings(max_examples=60, deadline=None)
@given(
    **LISTS,
    spans=st.lists(st.tuples(st.integers(-5, 50), st.integers(-5, 50)), max_size=6),
)
def test_pickled_slices_decode_to_the_slice_with_one_cache(n, block, spill, cut, spans):
    """A slice sent as its pickled blocks (controller/pickled_slice.py) decodes to the list's
    slice, with a reader's cache kept across slices, and across a truncate and new items that
    put other items in the cached blocks' places."""
    items = _moves(n)
    s = SpilledList(items, block_items=block, spill=spill)
    cache = DecodedBlocks(size=3)
    for lo, hi in spans:
        part = pickle.loads(pickle.dumps(s.pickled(lo, hi)))  # as a worker gets it
        assert part.items(cache) == items[lo:hi] == part.items()
        assert len(part) == len(items[lo:hi])
        view, want = SliceView(part), items[lo:hi]  # read block by block
        assert len(view) == len(want) and view[0 : len(want)] == want
        assert [view[i] for i in range(-len(want), len(want))] == want + want
        assert view[1::2] == want[1::2] and view[len(want) // 2 :] == want[len(want) // 2 :]
    s.truncate(cut)
    del items[cut:]
    fresh = [Linear(1000 + i, (0.0, i, 0.0), (1.0, i, 0.0), 900.0) for i in range(n - len(items))]
    s.extend(fresh)
    items += fresh
    for lo, hi in [*spans, (0, n)]:
        assert s.pickled(lo, hi).items(cache) == items[lo:hi]


def test_equal_to_a_list_of_equal_items_not_to_a_tuple():
    s = SpilledList(_moves(9), block_items=4)
    assert s == _moves(9) and s == SpilledList(_moves(9), block_items=2)
    assert s != _moves(8) and s != _moves(9)[::-1] and s != tuple(_moves(9))


def test_index_errors_name_the_range():
    s = SpilledList([1, 2, 3], block_items=2)
    with pytest.raises(IndexError, match="out of range for 3 items"):
        s[3]
    with pytest.raises(IndexError):
        s[-4]


def test_closed_blocks_live_on_disk_not_in_memory(tmp_path, monkeypatch):
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)
    s = SpilledList(range(10_000), block_items=1000)
    assert len(s._file) == 10 and s._file.spilled_bytes > 10_000
    assert s._tail == [] and len(s._cache) == 0
    assert sum(s) == sum(range(10_000))
    assert len(s._cache) <= 2  # a few decoded blocks only
    assert os.listdir(tmp_path) == []  # anonymous: nothing named in $TMPDIR


def test_pickled_it_carries_its_items():
    s = SpilledList(_moves(10), block_items=3)
    back = pickle.loads(pickle.dumps(s))
    assert list(back) == list(s) and len(back) == 10


def test_block_items_must_be_positive():
    with pytest.raises(ValueError, match="block_items"):
        SpilledList([], block_items=0)
