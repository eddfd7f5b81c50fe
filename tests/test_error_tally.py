"""Whole-run error figures in bounded memory: the tally fed range by range, the exact
percentile from values spilled to disk."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.sim import percentile
from gantry_sim.sim.error_tally import ErrorTally
from gantry_sim.sim.move_table import move_table
from gantry_sim.sim.percentile import ValueSpill, percentile_linear


def _tab():
    return move_table(parse_program("G1 X5 F1000\nG0 X6\nG1 X8\nG2 X10 I1 J0\nG1 X12\nM2\n"))


def _ticks(seed: int, n: int):
    rng = np.random.default_rng(seed)
    line = np.sort(rng.choice([1, 2, 3, 4, 5], size=n, p=[0.3, 0.1, 0.2, 0.3, 0.1]))
    line = np.concatenate([line, [4, 4, 1, 2]])  # lines executed again later
    err = rng.gamma(2.0, 1.5, size=line.size)
    # line 2 is a rapid; some ticks of line 3 are not feed either (a canned cycle's line runs
    # rapids between its feed moves)
    return line, err, (line != 2) & ~((line == 3) & (rng.random(line.size) < 0.3))


@pytest.mark.parametrize("seed", [0, 1])
def test_the_tally_does_not_depend_on_how_the_run_is_cut(seed):
    line, err, feed = _ticks(seed, 5000)
    whole = ErrorTally(_tab(), spill=False, tile_ticks=256)
    whole.add(line, err, feed)
    expect = whole.finish()
    rng = np.random.default_rng(seed)
    cuts = np.unique(np.concatenate([[0, line.size], rng.integers(0, line.size, 40)]))
    cut = ErrorTally(_tab(), spill=True, tile_ticks=256)
    for lo, hi in itertools.pairwise(cuts.tolist()):
        cut.add(line[lo:hi], err[lo:hi], feed[lo:hi])
    assert cut.finish() == expect  # bit for bit, on disk or in memory
    (peak, rms, p95), blocks = expect
    fe = err[feed]
    assert peak == fe.max() and p95 == np.percentile(fe, 95)
    assert rms == pytest.approx(np.sqrt(np.mean(fe**2)), rel=1e-14)  # tiles sum in another order
    assert [b[0] for b in blocks] == [1, 3, 4, 5]
    for ln, kind, bmax, brms, ticks in blocks:
        e = err[(line == ln) & feed]  # a block's figures are its feed ticks'
        assert bmax <= peak
        assert (bmax, ticks) == (e.max(), e.size)
        assert brms == pytest.approx(np.sqrt(np.mean(e**2)), rel=1e-14)
        assert kind == ("arc" if ln == 4 else "linear")


def test_one_tile_gives_numpys_figures_exactly():
    line, err, feed = _ticks(3, 3000)
    err[np.flatnonzero((line == 3) & ~feed)[0]] = 100.0  # the line's worst tick: not feed
    tally = ErrorTally(_tab(), spill=False)
    tally.add(line, err, feed)
    (peak, rms, p95), blocks = tally.finish()
    fe = err[feed]
    assert (peak, rms, p95) == (fe.max(), np.sqrt(np.mean(fe**2)), np.percentile(fe, 95))
    assert blocks[0][3] == np.sqrt(np.mean(err[line == 1] ** 2))
    assert blocks[1][2] == err[(line == 3) & feed].max() < peak < 100.0


def test_short_and_long_blocks_give_numpys_figures_exactly():
    """Blocks of fewer than 8 ticks in a tile are summed as columns, longer ones one by one
    (sim/error_tally.py SHORT_BLOCK_TICKS): both are numpy's mean and max of the block, bit for
    bit, and a block cut by a tile boundary sums its tiles."""
    prog = "".join(f"G1 X{k + 1} F1000\n" for k in range(90)) + "M2\n"
    tab = move_table(parse_program(prog))
    rng = np.random.default_rng(5)
    counts = rng.integers(1, 13, size=90)  # 1..12 ticks: both sides of 8
    line = np.repeat(np.unique(tab.line), counts)
    err = rng.gamma(2.0, 1.5, size=line.size) * 10.0 ** rng.uniform(-3, 3, size=line.size)
    for tile in (1 << 16, 64):
        tally = ErrorTally(tab, spill=False, tile_ticks=tile)
        tally.add(line, err, np.ones(line.size, dtype=bool))
        (_, _, _), blocks = tally.finish()
        for ln, _, bmax, brms, ticks in blocks:
            e = err[line == ln]
            assert bmax == e.max() and ticks == e.size
            if np.unique(np.flatnonzero(line == ln) // tile).size == 1:  # in one tile
                assert brms == np.sqrt(np.mean(e**2))
            else:  # tiles' sums added
                assert brms == pytest.approx(np.sqrt(np.mean(e**2)), rel=1e-14)


@pytest.mark.parametrize("n", [1, 2, 19, 20, 21, 1000, 12345])
def test_percentile_linear_is_numpys_bit_for_bit(n):
    values = np.random.default_rng(n).lognormal(size=n)
    ordered = np.sort(values)
    for q in (0.0, 5.0, 50.0, 95.0, 99.9, 100.0):
        assert percentile_linear(lambda k: ordered[k], n, q) == np.percentile(values, q)


def test_order_statistics_from_disk_in_several_passes(monkeypatch):
    monkeypatch.setattr(percentile, "READ_VALUES", 1000)  # many chunks a pass
    monkeypatch.setattr(percentile, "GATHER_VALUES", 50)  # several radix passes
    rng = np.random.default_rng(5)
    values = np.concatenate([rng.gamma(2.0, 1.5, 20_000), np.full(300, 2.5), [0.0, 1e-300]])
    rng.shuffle(values)
    ordered = np.sort(values)
    with ValueSpill(on_disk=True) as spill:
        for part in np.array_split(values, 7):
            spill.add(part)
        assert spill.count == values.size
        for k in (0, 1, 150, 10_000, 10_100, 19_000, values.size - 1):
            assert spill.kth(k) == ordered[k], k
        with pytest.raises(IndexError):
            spill.kth(values.size)


def test_a_pass_over_the_disk_holds_about_two_chunks(monkeypatch):
    """Selecting from disk holds a chunk read and its digits, not four chunk-sized arrays (at
    3.5 million feed ticks the 95th percentile took 96 MB more than the run held)."""
    import tracemalloc

    chunk = 1 << 18  # 2 MB, beside the radix counts' 3 x 0.5 MB
    monkeypatch.setattr(percentile, "READ_VALUES", chunk)
    monkeypatch.setattr(percentile, "GATHER_VALUES", 1000)
    values = np.random.default_rng(2).lognormal(size=6 * chunk)
    with ValueSpill(on_disk=True) as spill:
        spill.add(values)
        tracemalloc.start()
        try:
            got = spill.kth(values.size // 2)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
    assert got == np.partition(values, values.size // 2)[values.size // 2]
    assert peak < 2 * 8 * chunk + 2**21, peak


def test_negative_values_are_refused():
    with ValueSpill(on_disk=False) as spill, pytest.raises(ValueError, match=">= 0"):
        spill.add(np.array([1.0, -1e-9]))
