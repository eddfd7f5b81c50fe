"""The figures tell the truth: path.png in the arcs' plane (three views otherwise), the worst
point labelled, a fixed magnification; error.png an envelope with the gates drawn, cheap at
100,000 blocks; tune and sweep plots with every point, faults marked, axes from 0."""

from __future__ import annotations

import math
import os
import sys
import threading
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.gcode.interpreter import interpret
from gantry_sim.sim.api import run_program
from gantry_sim.sim.circular.tune import TuneRow
from gantry_sim.sim.error_plot import ENVELOPE_BINS, error_figure
from gantry_sim.sim.gates import ErrorLimit, Gates
from gantry_sim.sim.path_plot import choose_views, path_figure
from gantry_sim.sim.search_plots import sweep_figures, tune_figure
from gantry_sim.sim.trace import Trace
from tests.conftest import ROOT


def moves_of(text):
    return tuple(interpret(text, "linuxcnc", "t.ngc"))


def test_views_follow_the_arcs_plane():
    side = (ROOT / "examples" / "side_planes.ngc").read_text()
    assert choose_views(moves_of(side)) == ["XY", "XZ", "YZ"]  # arcs in XZ and YZ
    xz = "G21 G18 G90\nG0 X0 Y0 Z0\nG1 X10 F500\nG2 X20 Z0 I5 K0\nG1 Y5\nM2\n"
    assert choose_views(moves_of(xz)) == ["XZ"]  # larger in Y than Z, drawn in the arcs' plane
    pocket = (ROOT / "examples" / "pocket_tangent_arcs.ngc").read_text()
    assert choose_views(moves_of(pocket)) == ["XY"]  # a shallow plunge stays one view
    helix = (ROOT / "examples" / "helix_bore.ngc").read_text()
    assert choose_views(moves_of(helix)) == ["XY", "XZ", "YZ"]  # 4.5 mm down a 14 mm bore


CIRCLE = "G21 G17 G90 G94\nG1 X5 F3000\nG3 I-5 J0\nG1 X0\nM2\n"


@pytest.fixture(scope="module")
def circle(machine):
    return run_program(CIRCLE, file="c.ngc", machine=machine)


def _texts(fig):
    return [t.get_text() for ax in fig.axes for t in ax.texts] + [ax.get_title() for ax in fig.axes]


def test_path_marks_the_worst_point_at_a_fixed_magnification(circle):
    rep = circle.run_report
    fig = path_figure(circle.moves, circle.trace, "c.ngc", rep.contour_error_um)
    worst = max(rep.blocks, key=lambda b: b.max_error_um)
    texts = " ".join(_texts(fig))
    assert f"line {worst.line}" in texts and f"max {worst.max_error_um:.2f} um" in texts
    assert "error x 1000 (1 um drawn as 1 mm)" in texts
    # the drawn deviation of the worst point is 1000 x its error, whatever the run
    tr = circle.trace
    k = int(np.flatnonzero(tr.feed)[np.argmax(tr.err_um[tr.feed])])
    ax = fig.axes[0]
    marker = next(ln for ln in ax.lines if ln.get_marker() == "o")
    x, y = marker.get_xdata()[0], marker.get_ydata()[0]
    drawn_mm = math.hypot(x - tr.nearest[k, 0], y - tr.nearest[k, 1])
    assert drawn_mm == pytest.approx(tr.err_um[k], rel=0.02)  # um of error = mm on the plot


def _big_trace(blocks: int, per_block: int = 20) -> Trace:
    n = blocks * per_block
    t = np.arange(n) * 1e-3
    line = np.repeat(np.arange(1, blocks + 1), per_block)
    rng = np.random.default_rng(1)
    err = rng.random(n) * 3.0
    err[n // 3] = 9.0
    ref = np.column_stack([t, np.zeros(n), np.zeros(n)])
    return Trace(t, ref, ref, line, err, ref, np.ones(n, bool), np.zeros((n, 3)))


def test_error_plot_is_an_envelope_with_gates_at_100k_blocks(circle):
    tr = _big_trace(100_000)
    gates = Gates((ErrorLimit(8.0), ErrorLimit(2.5, lines=(10, 5000))))
    t0 = time.perf_counter()
    fig = error_figure(tr, circle.run_report.contour_error_um, gates)
    fig.canvas.draw()
    elapsed = time.perf_counter() - t0
    ax = fig.axes[0]
    # drawn as few artists with bounded vertices, not one point per sample
    [poly] = ax.collections
    assert sum(len(p.vertices) for p in poly.get_paths()) < 8 * ENVELOPE_BINS
    labels = [ln.get_label() for ln in ax.lines]
    assert "--max-error-um 8" in labels and "--max-error-um-lines 10-5000=2.5" in labels
    worst_line = int(tr.line[np.argmax(tr.err_um)])
    assert f"line {worst_line}" in [t.get_text() for t in ax.texts]
    assert ax.get_ylim()[0] == 0
    assert elapsed < 30  # generous: a correctness guard, the speed target is in benchmarks/


def _worst_lines_by_sorting(lines, err, count):
    """error.png's labelled lines by their definition: every sample sorted by line, then by
    error (the earliest of equal ones first); each line's first; the lines by that peak."""
    order = np.lexsort((-err, lines))
    first = np.ones(order.size, dtype=bool)
    first[1:] = lines[order][1:] != lines[order][:-1]
    peaks = order[first]
    return peaks[np.argsort(-err[peaks], kind="stable")[:count]]


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(1, 40), st.sampled_from([0.0, 0.5, 1.0, 2.0, 3.5])), max_size=400
    ),
    st.lists(st.floats(0, 10, allow_nan=False), max_size=400),
    st.integers(1, 8),
)
def test_the_worst_lines_are_those_a_full_sort_finds(tied, spread, count):
    """The labelled samples (sim.error_plot.worst_lines, which sorts only the top errors) are
    those of sorting every sample, ties included: many equal errors, and spread ones."""
    from gantry_sim.sim.error_plot import worst_lines

    lines = np.array(
        [line for line, _ in tied] + [k % 7 + 1 for k in range(len(spread))], dtype=np.int64
    )
    err = np.array([e for _, e in tied] + spread, dtype=float)
    got = worst_lines(lines, err, count)
    assert np.array_equal(got, _worst_lines_by_sorting(lines, err, count))
    rng = np.random.default_rng(len(tied))  # past the first candidate set: 64 samples
    lines = rng.integers(1, 500, 5000)
    err = rng.integers(0, 3, 5000).astype(float)  # three values: the top 64 cut ties
    assert np.array_equal(
        worst_lines(lines, err, count), _worst_lines_by_sorting(lines, err, count)
    )


def test_tune_plot_uses_the_feed_actually_run():
    row = TuneRow(5.0, 24000.0, 3.0, 6538.0, "machine_limits", ((24000.0, 3.0),), (6538.0,))
    bad = TuneRow(1.0, None, 12.0, 100.0, "unreachable", ((24000.0, 20.0), (100.0, 12.0)),
                  (2900.0, 100.0))  # fmt: skip
    fig = tune_figure([row, bad], 10.0, "XY")
    left, right = fig.axes[:2]
    xs = {float(x) for ln in right.lines for x in ln.get_xdata()}
    assert 6538.0 in xs and 24000.0 not in xs
    assert left.get_ylim()[0] == 0 and right.get_ylim()[0] == 0
    assert "unreachable" in [t.get_text() for t in left.texts]


def test_sweep_plots_mark_faulted_points_on_honest_axes():
    def row(f, err, status="ok"):
        return {
            "feed_override_pct": f,
            "max_accel_mm_per_s2": None,
            "max_jerk_mm_per_s3": None,
            "cycle_time_s": 10.0 / f if status == "ok" else math.nan,
            "max_error_um": err,
            "status": status,
        }

    rows = [
        row(50, 4.00),
        row(100, 4.10),
        row(150, 4.17),
        row(200, math.nan, "simulation error: x"),
    ]
    by_feed, by_error = sweep_figures(rows)
    ax = by_feed.axes[0]
    assert ax.get_ylim()[0] == 0  # a 0.17 um spread is not blown up to fill the plot
    assert "spread 0.17 um" in ax.get_title()
    faulted = [ln for ln in ax.lines if ln.get_label() == "faulted (no result)"]
    assert faulted and list(faulted[0].get_xdata()) == [200]
    assert any("faulted (1)" in t.get_text() for t in by_feed.texts)
    ax2 = by_error.axes[0]
    assert ax2.get_xlim()[0] == 0 and ax2.get_ylim()[0] == 0
    assert any("faulted (1)" in t.get_text() for t in by_error.texts)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="forked children: Linux")
def test_error_png_is_drawn_by_a_child_and_here_when_the_child_fails(circle, tmp_path, monkeypatch):
    """write_outputs draws error.png in a forked child while it draws path.png; the same file
    is drawn here with one process, or when the child dies."""
    from gantry_sim.sim import error_plot
    from gantry_sim.sim.api import write_run_outputs

    real, here, log = error_plot.save_error_plot, os.getpid(), tmp_path / "pids"
    die_in_child = []

    def spy(path, *args, **kwargs):
        with open(log, "a") as f:
            f.write(f"{os.getpid()}\n")
        if die_in_child and os.getpid() != here:
            os._exit(3)
        return real(path, *args, **kwargs)

    def drawn_by(name):
        log.write_text("")
        write_run_outputs(circle, tmp_path / name)
        return [int(p) for p in log.read_text().split()]

    monkeypatch.setattr(error_plot, "save_error_plot", spy)
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "2")
    [child] = drawn_by("forked")
    assert child != here
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "1")
    assert drawn_by("here") == [here]
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "2")
    die_in_child.append(True)
    dead, redrawn = drawn_by("child died")
    assert dead != here and redrawn == here
    png = [
        (tmp_path / name / "error.png").read_bytes() for name in ("forked", "here", "child died")
    ]
    assert png[0][:8] == b"\x89PNG\r\n\x1a\n" and png[0] == png[1] == png[2]


def test_the_outline_computed_during_the_run_is_what_the_plot_draws(circle):
    """run_program computes path.png's commanded geometry in a thread during the run
    (sim.path_outline); the figure drawn from it is the figure drawn from the moves."""
    from gantry_sim.sim.path_outline import Outline, outline

    assert circle.outline is not None
    ready = circle.outline.result(timeout=30)
    assert isinstance(ready, Outline)
    again = outline(circle.moves)
    for name in ("lo", "hi", "feed", "rapid"):
        assert np.array_equal(getattr(ready, name), getattr(again, name), equal_nan=True)
    assert (
        (ready.planes, ready.pixel_mm) == (again.planes, again.pixel_mm) == ({"XY"}, again.pixel_mm)
    )
    rep = circle.run_report
    figs = [
        path_figure(circle.moves, circle.trace, "c.ngc", rep.contour_error_um, d)
        for d in (ready, None)
    ]
    lines = [[(ln.get_xdata(), ln.get_ydata()) for ln in f.axes[0].lines] for f in figs]
    assert len(lines[0]) == len(lines[1]) >= 3
    for (x0, y0), (x1, y1) in zip(*lines, strict=True):
        assert np.array_equal(x0, x1, equal_nan=True) and np.array_equal(y0, y1, equal_nan=True)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="per-thread nice: Linux")
def test_the_outline_is_computed_at_background_priority(monkeypatch):
    from gantry_sim.controller.forked import BACKGROUND_NICE
    from gantry_sim.sim import path_outline, plot_prep

    seen = []
    real = path_outline.outline

    def spy(moves):
        seen.append(os.getpriority(os.PRIO_PROCESS, threading.get_native_id()))
        return real(moves)

    monkeypatch.setattr(path_outline, "outline", spy)
    mine = os.getpriority(os.PRIO_PROCESS, 0)
    assert plot_prep.prepare_plots(moves_of(CIRCLE)).result(timeout=30) is not None
    assert plot_prep.prepare_plots(()).result(timeout=30) is None
    assert seen == [max(mine, BACKGROUND_NICE)] and os.getpriority(os.PRIO_PROCESS, 0) == mine


def test_an_error_in_the_outline_is_raised_where_the_plot_is_drawn(monkeypatch):
    from gantry_sim.sim import path_outline, plot_prep

    def broken(moves):
        raise ValueError("broken outline")

    monkeypatch.setattr(path_outline, "outline", broken)
    with pytest.raises(ValueError, match="broken outline"):
        plot_prep.prepare_plots(moves_of(CIRCLE)).result(timeout=30)
