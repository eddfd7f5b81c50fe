"""A long program planned window by window gives the whole-program plan (planner/windows.py).

The windows are made small here (tens of moves) so that short programs cross several of them;
the plan of each is compared with the same program planned whole, number for number.
"""

from __future__ import annotations

import math
import pickle
import random
import sys
import time
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pytest

from benchmarks.programs import program
from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.gcode.interpreter import interpret_events
from gantry_sim.controller.planner import (
    chains,
    plan,
    rounds,
    segmented_curve,
    window_ahead,
    window_cut,
    window_judge,
    window_prep,
    windows,
)
from gantry_sim.controller.planner.path_stream import path_plan
from gantry_sim.controller.planner.prepare import prepare, sub_path
from gantry_sim.models import DEFAULT_MACHINE
from tests.plan_helpers import blend_arcs, blending, count_fork_map_parts


def _program() -> str:
    """Polylines with sharp corners (slow blends: exact stops) and gentle ones, a dwell, a
    G61.1 stretch, rapids, and tangent arcs."""
    out = ["G21 G90 G17 G64 P0.01", "G0 X0 Y0 Z-1", "F2400"]
    x = y = 0.0
    for k in range(70):  # a polyline: mostly gentle turns, a right angle every 9th
        ang = math.radians(90.0 if k % 9 == 8 else 4.0 * ((k % 5) - 2))
        length = 0.3 + 0.2 * (k % 3)
        heading = ang * (k + 1) if k % 9 != 8 else math.radians(90.0) * (k // 9 + 1)
        x, y = x + length * math.cos(heading), y + length * math.sin(heading)
        out.append(f"G1 X{x:.4f} Y{y:.4f}")
        if k == 30:
            out.append("G4 P0.05")
        if k == 45:
            out.append("G61.1")
        if k == 55:
            out.append("G64 P0.01")
    out.append("G0 Z2")
    out.append("G0 X20 Y0")
    out.append("G1 Z-1")
    x, y = 20.0, 0.0
    for k in range(60):  # tangent arcs: quarter circles alternating direction (S-bends)
        r = 1.0 + 0.5 * (k % 3)
        ccw = k % 2 == 0
        nx, ny = (x + r, y + r) if ccw else (x + r, y - r)
        i, j = (0.0, r) if ccw else (0.0, -r)
        out.append(f"{'G3' if ccw else 'G2'} X{nx:.4f} Y{ny:.4f} I{i:.4f} J{j:.4f}")
        x, y = nx, ny
    out.append("M2")
    return "\n".join(out) + "\n"


def _whole_and_windowed(text: str, monkeypatch, window: int, margin: int):
    events = tuple(interpret_events(text))
    whole = plan(events, load_machine_config(DEFAULT_MACHINE))
    return (whole, *_windowed(events, monkeypatch, window, margin))


def _plan_whole(text: str):
    return plan(tuple(interpret_events(text)), load_machine_config(DEFAULT_MACHINE))


def _windowed(events: tuple, monkeypatch, window: int, margin: int, machine=None):
    """The plan of ``events`` in windows of ``window`` moves, and the sizes of the runs of
    chains the windows settled (one per probe); ``machine``: the bundled one by default."""
    probes = _small_windows(monkeypatch, window, margin)
    return plan(events, machine or load_machine_config(DEFAULT_MACHINE)), probes


def _small_windows(monkeypatch, window: int, margin: int) -> list[int]:
    """From here on the planner plans windows of ``window`` moves with ``margin`` planned
    again, and writes the reference to the temporary file in small blocks; returns the list
    the sizes of the runs of chains the windows settle go to (one per probe)."""
    probes: list[int] = []
    real = windows.settle_chains

    def counted(*args, **kwargs):
        probes.append(len(args[0]))
        return real(*args, **kwargs)

    monkeypatch.setattr(windows, "settle_chains", counted)
    monkeypatch.setattr(window_cut, "WINDOW_MOVES", window)
    monkeypatch.setattr(window_cut, "MARGIN_MOVES", margin)
    # small blocks: the windows' reference goes to the temporary file, and a window sent back
    # takes back blocks written there
    monkeypatch.setattr(segmented_curve, "BLOCK_PHASES", 40)
    return probes


def _assert_same(a, b) -> None:
    assert a.duration_s == b.duration_s
    assert a.ruckig_piece_count == b.ruckig_piece_count
    names = ("move_start_s", "move_lines", "move_sources", "path_sources", "end_mm", "overlaps_s")
    for name in names:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    for axis_a, axis_b in zip(a.curve.axes, b.curve.axes, strict=True):
        for col_a, col_b in zip(axis_a, axis_b, strict=True):
            np.testing.assert_array_equal(col_a, col_b)
    assert len(a.vertices) == len(b.vertices)
    for va, vb in zip(a.vertices, b.vertices, strict=True):
        np.testing.assert_array_equal(va, vb)
    assert a.blends == b.blends and a.path_moves == b.path_moves


def test_a_program_planned_in_windows_is_the_whole_program_plan(monkeypatch):
    whole, windowed, probes = _whole_and_windowed(_program(), monkeypatch, 40, 8)
    assert len(whole.path_moves) > 3 * 40  # blends inserted: several windows
    assert len(probes) >= 4, probes
    assert max(probes) <= 80  # no window grew to the whole program
    assert windowed.curve.spilled_bytes > 0  # the reference went to the temporary file
    _assert_same(whole, windowed)


def test_a_cut_whose_speed_came_down_in_later_rounds_gives_the_whole_program_plan(monkeypatch):
    """The generated polyline (benchmarks/programs.py, 1,500 blocks) in windows of 500 and
    800 moves: at some cut the probe's speed came down over its rounds. A window that started
    every round from the last of those speeds backed off the junctions just after the cut
    otherwise than the whole program's rounds (the cycle differed by about 1e-5 s); it now
    replays them (windows._replay), and the plan is the whole program's, number for number.
    (One test for both sizes: the whole program is planned once.)"""
    text = program("poly", 1500)
    whole, windowed, probes = _whole_and_windowed(text, monkeypatch, 500, 60)
    assert len(probes) >= 3, probes
    _assert_same(whole, windowed)
    windowed, probes = _windowed(tuple(interpret_events(text)), monkeypatch, 800, 60)
    assert len(probes) >= 3, probes
    _assert_same(whole, windowed)


def _tangent_program() -> str:
    """Half circles of R 3-5 along X, alternating G3 and G2 (S-bends), a straight move after
    every fifth (line-arc junctions), in G64 P0.01: a G2 transition at each junction; the feed
    changes every tenth move (F3000, F2400), where the chains end (windows cut there)."""
    out = ["G21 G90 G17 G64 P0.01", "G0 X-240 Y0", "F3000"]
    x, y = -240.0, 0.0
    for k in range(60):
        r = 3.0 + (k % 3)
        x += 2 * r
        feed = f" F{3000 if k // 10 % 2 == 0 else 2400}" if k % 10 == 0 else ""
        out.append(f"G{3 if k % 2 == 0 else 2} X{x:.4f} Y{y:.4f} I{r:.4f}{feed}")
        if k % 5 == 4:
            y += 3.0 if k % 2 == 0 else -3.0
            out.append(f"G1 Y{y:.4f}")
    return "\n".join([*out, "M2"]) + "\n"


def test_g2_transitions_planned_in_windows_give_the_whole_program_plan(monkeypatch):
    whole, windowed, probes = _whole_and_windowed(_tangent_program(), monkeypatch, 20, 4)
    assert sum(b.kind == "transition" for b in whole.blends) >= 60
    assert len(probes) >= 4 and max(probes) < len(whole.path_moves), probes  # windows cut
    _assert_same(whole, windowed)


def test_a_window_whose_next_start_cannot_be_kept_is_planned_again_wider(monkeypatch):
    """The next probe lowering the speed where the window before was cut sends the planner
    back to that window, twice as wide; the plan is still the whole program's."""
    real = rounds.settle_chains
    calls = {"n": 0}

    def refuse_second_start(active, caps, *args, **kwargs):
        calls["n"] += 1
        settled = real(active, caps, *args, **kwargs)
        if calls["n"] == 2:  # the second window's probe: as if its look-ahead needed less
            settled.speeds[0] = 0.5 * settled.speeds[0] if settled.speeds[0] > 0 else -1.0
        return settled

    whole = _plan_whole(_program())
    _small_windows(monkeypatch, 40, 8)
    monkeypatch.setattr(windows, "settle_chains", refuse_second_start)
    windowed = plan(interpret_events(_program()), load_machine_config(DEFAULT_MACHINE))
    assert calls["n"] >= 4
    assert windowed.curve.spilled_bytes > 0
    _assert_same(whole, windowed)


def test_a_chain_longer_than_the_window_widens_it_to_the_chain(monkeypatch):
    """Arcs of one circle, end to end, are one chain (no junction binds): there is nowhere to
    cut inside it, so the window grows until the chain fits."""
    text = "G21 G90 G17 G64 P0.01\nG0 X10 Y0 Z-1\nF3000\n"
    text += "G3 X0 Y10 I-10 J0\nG3 X-10 Y0 I0 J-10\nG3 X0 Y-10 I10 J0\nG3 X10 Y0 I0 J10\n" * 20
    text += "G0 Z5\nM2\n"
    whole, windowed, probes = _whole_and_windowed(text, monkeypatch, 16, 4)
    assert max(probes) >= 80, probes
    _assert_same(whole, windowed)


def test_a_chain_cut_in_parts_keeps_the_windows_small(monkeypatch):
    """Collinear moves are one chain; cut every SPLIT_MOVES moves (planner/chains.py) it gives
    the windows places to cut, so they no longer widen to the whole chain (900,000 such moves
    took 3.2 GB), and the plan in windows is the whole program's."""
    monkeypatch.setattr(chains, "SPLIT_MOVES", 12)
    text = "G21 G91 F3000\nG1 X0.5\n" + "G1 X0.5 Y0.0001\nG1 X0.5 Y-0.0001\n" * 100 + "M2\n"
    whole, windowed, probes = _whole_and_windowed(text, monkeypatch, 40, 8)
    assert len(probes) >= 5 and max(probes) <= 40, probes
    _assert_same(whole, windowed)


def _circles_program() -> str:
    """Full circles of R 5 (158 chords each at the bundled 1 um), each after a short line, in
    G64 P0.01: few moves, many chords."""
    out = ["G21 G90 G17 G64 P0.01", "G0 X-100 Y0 Z-1", "F3000"]
    for k in range(24):
        x = -100.0 + 12.0 * (k + 1)
        out += [f"G1 X{x:.4f} Y0", f"G2 X{x:.4f} Y0 I5 J0"]
    return "\n".join([*out, "G0 Z5", "M2"]) + "\n"


def test_a_window_holds_the_moves_whose_chords_fit_its_budget(monkeypatch):
    """Arcs of many chords fill a window before its moves do: each probe (but one sent back
    wider) holds at most WINDOW_CHORDS chords past its first move, a window cut short keeps a
    quarter of its moves as margin, and the plan is the whole program's, number for number."""
    events = tuple(interpret_events(_circles_program()))
    machine = load_machine_config(DEFAULT_MACHINE)
    whole = plan(events, machine)
    seg = machine.segmentation
    chords = [window_cut.chord_count(m, seg) for m in whole.path_moves]
    assert sum(chords) > 3_000 and max(chords) == 158
    probes: list[tuple[int, int]] = []  # (first path move, moves) of each probe
    real = windows.window_of

    def counted(src, base, hi, context, *args, **kwargs):
        probes.append((base + context, hi - base - context))
        return real(src, base, hi, context, *args, **kwargs)

    monkeypatch.setattr(windows, "window_of", counted)
    monkeypatch.setattr(window_cut, "WINDOW_CHORDS", 1_000)
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "1")  # every window prepared here, counted
    windowed = plan(events, machine)
    assert len(probes) >= 4, probes
    for lo, size in probes[:-1]:
        held = sum(chords[lo : lo + size])
        assert held - chords[lo] <= 1_000 < held + chords[lo + size], (lo, size, held)
    _assert_same(whole, windowed)


def test_blends_are_judged_in_stretches_whose_chords_fit_a_window(monkeypatch):
    """blends_to_skip judges a long path's blends in stretches from a blend on, bounded by
    chords as the windows are: the slow blends found are those of stretches of moves alone."""
    machine = load_machine_config(DEFAULT_MACHINE)
    seg = machine.segmentation
    path = path_plan(
        tuple(interpret_events(_circles_program())), machine.path, seg.chord_tolerance_mm
    )
    assert len(path.blend_junction) >= 40  # the corners into and out of every circle
    spans: list[tuple[int, int]] = []
    real = window_judge.judge_stretch

    def spy(path, lo, hi, *args):
        spans.append((lo, hi))
        return real(path, lo, hi, *args)

    monkeypatch.setattr(window_judge, "judge_stretch", spy)
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "1")  # judged here, spied
    by_moves = window_judge.blends_to_skip(path, machine, 100.0)
    assert len(spans) == 1
    spans.clear()
    monkeypatch.setattr(window_cut, "WINDOW_CHORDS", 1_000)
    assert window_judge.blends_to_skip(path, machine, 100.0) == by_moves
    assert len(spans) >= 4 and spans[-1][1] == len(path.moves)
    chords = [window_cut.chord_count(m, seg) for m in path.moves]
    blends = {k for k in path.blend_junction}
    for (lo, hi), (nxt, _) in zip(spans, [*spans[1:], (len(path.moves), 0)], strict=True):
        assert lo in blends and sum(chords[lo + 1 : hi]) <= 1_000 and hi <= nxt
        assert not blends & set(range(hi, nxt))  # every blend in a stretch


def test_window_stop_counts_chords_and_grows_with_the_window():
    """window_stop: the moves before the first one past the chord budget (one at least); a
    window sent back twice as wide gets twice the budget; lines count one chord."""
    machine = load_machine_config(DEFAULT_MACHINE)
    seg = machine.segmentation
    moves = [m for m in interpret_events(_circles_program()) if hasattr(m, "end")]
    circles = [k for k, m in enumerate(moves) if window_cut.chord_count(m, seg) > 1]
    assert [window_cut.chord_count(moves[k], seg) for k in circles[:2]] == [158, 158]
    first = circles[0]
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(window_cut, "WINDOW_CHORDS", 300)
        assert window_cut.window_stop(moves, first, 5_000, seg) == first + 2  # 158 + 1 + 158 > 300
        assert window_cut.window_stop(moves, first, 10_000, seg) == first + 6  # 635 > 600
        mp.setattr(window_cut, "WINDOW_CHORDS", 10)
        assert window_cut.window_stop(moves, first, 5_000, seg) == first + 1  # one move at least
        assert window_cut.window_stop(moves, len(moves) - 1, 5_000, seg) == len(moves)
    assert window_cut.window_stop(moves, 0, 5_000, seg) == len(moves)  # all 3,818 chords fit


def test_windows_cut_before_their_last_stop_need_no_braking_margin(monkeypatch):
    """A rapid asks for twice its braking distance (over 100 mm) of path after a cut, far
    more than a window of 0.1 mm moves holds; but a cut before a stop needs none (speed 0
    there in every round: nothing after it reaches back). The windows keep all but their
    margin, instead of widening to the whole program, and give the whole program's plan.
    The program: benchmarks/programs.py's adaptive clearing, loops of 0.05-0.12 mm chords
    joined by two short rapids at depth."""
    text = program("adaptive", 300)
    whole, windowed, probes = _whole_and_windowed(text, monkeypatch, 120, 40)
    assert len(whole.path_moves) > 3 * 120
    assert len(probes) >= 4 and max(probes) <= 120, probes
    _assert_same(whole, windowed)


def _pocket_program() -> str:
    """A zigzag of X lines joined by 0.5 mm Y steps at right angles, in G64 P0.01: every
    corner an exact stop (its blend arc slower) whose two moves share no axis, so each is
    overlapped (planner/stop_overlap.py); every chain one move, so windows cut at them."""
    out = ["G21 G90 G17 G64 P0.01", "G0 X0 Y0 Z-1", "G1 F2400"]
    for k in range(40):
        out.append(f"X{0.0 if k % 2 else 6.0 + 0.1 * (k % 3):.4f}")
        out.append(f"Y{0.5 * (k + 1):.4f}")
    return "\n".join([*out, "G0 Z5", "M2"]) + "\n"


@pytest.mark.parametrize("window", [9, 14])
def test_stops_overlapped_across_window_cuts_give_the_whole_program_plan(monkeypatch, window):
    """A window cut at an overlapped stop holds its last chain back for the next window's
    first (windows.Planned.pending): the plan is the whole program's, overlaps included."""
    whole, windowed, probes = _whole_and_windowed(_pocket_program(), monkeypatch, window, 2)
    assert len(whole.overlaps_s) >= 75  # 79 corners between lines
    assert len(probes) >= 5, probes
    _assert_same(whole, windowed)


def _random_corners(seed: int) -> str:
    """Axis moves of 0.05-8 mm at F300-F6000 turning by right angles (stops that overlap),
    with some oblique moves, straight runs, short arcs, a dwell and a G61.1 stretch."""
    rng = random.Random(seed)
    out = ["G21 G90 G17 G64 P0.01", "G0 X0 Y0 Z-1"]
    x = y = z = 0.0
    for _ in range(60):
        r = rng.random()
        if r < 0.06:
            out.append("G4 P0.02")
        elif r < 0.1:
            out.append(rng.choice(["G61.1", "G64 P0.01", "G64 P0.05"]))
        step = rng.choice([0.05, 0.3, 1.0, 3.0, 8.0])
        feed = rng.choice([300, 1200, 3000, 6000])
        kind = rng.random()
        if kind < 0.1:  # a quarter arc turning left
            out.append(f"G3 X{x + 1:.4f} Y{y + 1:.4f} I0 J1 F{feed}")
            x, y = x + 1, y + 1
            continue
        if kind < 0.55:
            x += rng.choice([-1, 1]) * step
        elif kind < 0.9:
            y += rng.choice([-1, 1]) * step
        elif kind < 0.95:
            z += rng.choice([-1, 1]) * min(step, 1.0)
        else:
            x, y = x + step * 0.6, y + step * 0.8
        out.append(f"G1 X{x:.4f} Y{y:.4f} Z{z:.4f} F{feed}")
    return "\n".join([*out, "G0 Z5", "M2"]) + "\n"


@pytest.mark.parametrize("seed", range(6))
def test_random_corners_planned_in_windows_give_the_whole_program_plan(monkeypatch, seed):
    """Stops overlapped at random cuts, beside dwells, G61.1 stops, arcs and rapids: the
    windows (of 10-20 moves: four or more, now that a window cut before a stop keeps all but
    its margin) hold back and overlap as the whole program does. (A margin of 4 moves: with 2,
    a kept move can be trimmed for a blend its window could not judge yet, at its end, which a
    later window finds slow: the production margin is 250.)"""
    window = 10 + 2 * seed
    whole, windowed, probes = _whole_and_windowed(_random_corners(seed), monkeypatch, window, 4)
    assert len(whole.overlaps_s) >= 5
    assert len(probes) >= 4, probes
    _assert_same(whole, windowed)


@pytest.mark.parametrize("window", [25, 60])
def test_slow_blends_are_judged_the_same_in_windows(monkeypatch, window):
    """Right-angle corners at P0.01 are slow blends (exact stops); judged window by window,
    the same corners are found as in the whole program."""
    whole, windowed, _ = _whole_and_windowed(_program(), monkeypatch, window, 5)
    assert len(whole.blends) < 69  # some corners were not blended
    assert windowed.blends == whole.blends


#: Found by a seeded fuzz of windowed against whole plans: tangent arcs of R 2 and R 5, lines and
#: a dwell in G64 P0.05 Q0, whose last corner is judged slower as a blend than as an exact stop
#: only with the time the stop's overlap saves (prepare.stop_credit_s).
_CREDITED_CORNER = (Path(__file__).parent / "data" / "windows" / "credited_corner.ngc").read_text()


def test_a_windows_blends_are_judged_with_their_stops_overlap_credit(monkeypatch):
    """A window with a move of context judged its blends without the stop credits (the window's
    preparation left them out): the last corner kept its blend in windows, 2.0896 s against the
    whole program's overlapped stop, 2.0873 s."""
    whole, windowed, probes = _whole_and_windowed(_CREDITED_CORNER, monkeypatch, 60, 6)
    assert len(probes) == 2, probes
    assert [b.kind for b in whole.blends if b.line == 42] == ["overlap"]
    _assert_same(whole, windowed)


def test_a_cut_keeps_at_least_the_moves_a_later_judge_reaches_back(monkeypatch):
    """Cuts before a stop with 6 moves after them (windows of 30, a margin of 6 asked for):
    the window after a cut judged a blend slow near the cut and made the path again, and an arc
    kept before the cut had its last piece 1e-12 apart from the whole program's. A cut before a
    stop keeps MARGIN_MOVES_MIN (8) moves at least, and the plan is the whole program's."""
    path = Path(__file__).parent / "data" / "windows" / "judged_near_cut.ngc"
    whole, windowed, probes = _whole_and_windowed(path.read_text(), monkeypatch, 30, 6)
    assert len(probes) >= 8, probes
    _assert_same(whole, windowed)


def test_a_window_with_context_is_its_stretch_prepared_less_the_first_move():
    """Every field of a window's preparation is the stretch's, less the context move: lists
    from the second move on, maps by active move shifted down by one (a field left out of the
    window's copy takes its default)."""
    machine = load_machine_config(DEFAULT_MACHINE)
    filled: set[str] = set()  # the maps found with entries, across the two programs
    # corners out of every principal plane stay stops (stop_corners), and their moves overlap
    skew = "G21 G90 G64 P0.01\nG0 X0 Y0 Z0\nF1200\nG1 X5 Y1 Z1\nG1 X6 Y5 Z-1\nG1 X10 Y6 Z2\n"
    skew += "G1 X12 Y1 Z0\nM2\n"
    for text, first in ((_CREDITED_CORNER, 40), (_random_corners(1), 2), (skew, 0)):
        path = path_plan(tuple(interpret_events(text)), machine.path, 0.001)
        stretch = sub_path(path, first, len(path.moves), first + 1)
        whole = prepare(stretch, machine, 100.0, {})
        window = window_prep.prepare_window(stretch, machine, 100.0, True)
        for name in type(whole)._fields:
            a, b = getattr(whole, name), getattr(window, name)
            if a is None:
                assert b is None, name
            elif isinstance(a, Mapping):
                assert _dumped(b) == _dumped({k - 1: v for k, v in a.items() if k >= 1}), name
                filled |= {name} if any(k >= 1 for k in a) else set()
            elif name == "geoms":  # every move of the stretch, the context's too
                assert _dumped(b) == _dumped(a)
            else:
                assert _dumped(b) == _dumped(a[1:]), name
    assert filled == {"holds", "stop_corners", "stop_credit_s"}  # each map tested on entries


def _dumped(x) -> bytes:
    """``x`` pickled: equal bytes for equal numbers, arrays and dataclasses (no ``==`` on
    arrays inside them)."""
    return pickle.dumps(dict(x) if isinstance(x, Mapping) else list(x))


def test_a_window_sent_back_again_comes_back_wider_each_time(monkeypatch):
    """Each time the same window is sent back it is planned twice as wide as the last time
    (planning it at the same width again would give the same cut and the same refusal)."""
    real_settle, real_mark = windows.settle_chains, windows._mark
    calls: list[tuple[int, bool]] = []  # (moves planned, refused) per call
    kept: list[int] = []  # the calls whose window was kept

    def refuse_probes(active, caps, *args, **kwargs):
        settled = real_settle(active, caps, *args, **kwargs)
        # a probe after a kept window (not the window sent back itself): refused, 3 at most
        refuse = bool(kept) and sum(r for _, r in calls) < 3 and not (calls and calls[-1][1])
        calls.append((len(active), refuse))
        if refuse:
            settled.speeds[0] = 0.5 * settled.speeds[0] if settled.speeds[0] > 0 else -1.0
        return settled

    def mark(out):
        kept.append(len(calls) - 1)
        return real_mark(out)

    whole = _plan_whole(_program())
    _small_windows(monkeypatch, 16, 4)
    monkeypatch.setattr(windows, "settle_chains", refuse_probes)
    monkeypatch.setattr(windows, "_mark", mark)
    windowed = plan(interpret_events(_program()), load_machine_config(DEFAULT_MACHINE))
    refused = [i for i, (_, r) in enumerate(calls) if r]
    assert len(refused) >= 2, calls
    for i in refused:
        before = calls[max(k for k in kept if k < i)][0]  # the window sent back
        again = calls[i + 1][0]
        last = i + 1 == len(calls) - 1  # the rest of the path, if narrower than twice
        assert again == 2 * before or (last and before < again < 2 * before), calls
    _assert_same(whole, windowed)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="forks on Linux only")
def test_the_next_window_is_prepared_while_the_chains_are_planned(monkeypatch):
    """Each window after the first is prepared ahead (window_ahead.WindowsAhead), and its first round
    planned ahead by the other process: what is taken is what preparing it then gives, number
    for number, with the chains of its first round, and the plan is the whole program's."""
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "2")
    taken, paths, seeds = [], [], []
    real_take, real_job = window_ahead.WindowsAhead.take, window_ahead.WindowsAhead.job
    machine = load_machine_config(DEFAULT_MACHINE)

    def job(self, src, *args):
        paths.append(src.path)
        return real_job(self, src, *args)

    def take(self, key, start_after=None):
        got = real_take(self, key, start_after)
        if got is not None:
            pre = got[0][0]
            taken.append(pre)
            seeds.append(len(got[1]))
            path = paths[-1]  # the path being planned
            fresh = window_prep.prepare_window(
                sub_path(path, key[0], key[1], key[0] + 1), machine, 100.0, True
            )
            np.testing.assert_array_equal(pre.caps, fresh.caps)
            assert pre.path_index == fresh.path_index and pre.sources == fresh.sources
            assert [g.limits for g in pre.active] == [g.limits for g in fresh.active]
            for a, b in zip(pre.states, fresh.states, strict=True):
                np.testing.assert_array_equal(a.direction, b.direction)
                np.testing.assert_array_equal(a.curvature_per_mm, b.curvature_per_mm)
        return got

    monkeypatch.setattr(window_ahead.WindowsAhead, "take", take)
    monkeypatch.setattr(window_ahead.WindowsAhead, "job", job)
    whole, windowed, probes = _whole_and_windowed(_program(), monkeypatch, 40, 8)
    assert len(probes) >= 4 and len(taken) >= len(probes) // 2, (len(taken), probes)
    assert sum(n > 0 for n in seeds) >= len(seeds) // 2, seeds
    _assert_same(whole, windowed)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="forks on Linux only")
@pytest.mark.parametrize("guess", [0.8, 1.25])
def test_a_first_round_planned_ahead_from_another_speed_gives_the_same_plan(monkeypatch, guess):
    """The next window's first round is planned ahead from the speed the cut has in this
    window's first round; where the window ends up starting otherwise, its first chains have
    other keys and are planned again: the plan is still the whole program's."""
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "2")
    real_start, real_take = window_ahead.WindowsAhead._start, window_ahead.WindowsAhead.take
    started, seeds = [], []

    def start(self, window, key, v_start, machine, ready=None):
        started.append(v_start)
        return real_start(self, window, key, guess * v_start, machine, ready)

    def take(self, key, start_after=None):
        got = real_take(self, key, start_after)
        if got is not None:
            seeds.append(len(got[1]))
        return got

    monkeypatch.setattr(window_ahead.WindowsAhead, "_start", start)
    monkeypatch.setattr(window_ahead.WindowsAhead, "take", take)
    # its windows are cut where the feed changes, moving
    whole, windowed, _ = _whole_and_windowed(_tangent_program(), monkeypatch, 20, 4)
    assert any(v > 0 for v in started) and any(n > 0 for n in seeds), (started, seeds)
    _assert_same(whole, windowed)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="forks on Linux only")
def test_the_rounds_after_the_first_planned_ahead_are_taken_and_give_the_same_plan(monkeypatch):
    """The process that planned a window's first round ahead goes on with its next rounds
    until the window is taken (rounds.settle_onward): with time for it (the taking delayed),
    the chains of those rounds come with the seed, and the plan is the whole program's."""
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "2")
    real_take = window_ahead.WindowsAhead.take
    later_rounds = []

    def take(self, key, start_after=None):
        time.sleep(0.3)  # the other process plans the next rounds meanwhile
        got = real_take(self, key, start_after)
        if got is not None:
            later_rounds.append(sum(not sat for _, _, sat in got[1]))
        return got

    monkeypatch.setattr(window_ahead.WindowsAhead, "take", take)
    # right angles among gentle turns: their stops (overlapped) bring speeds down round after
    # round in every window
    whole, windowed, _ = _whole_and_windowed(_gentle_then_sharp(0), monkeypatch, 40, 8)
    assert any(n > 0 for n in later_rounds), later_rounds
    _assert_same(whole, windowed)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="forks on Linux only")
def test_the_window_after_the_next_starts_as_soon_as_the_next_is_taken(monkeypatch):
    """When a window is taken, the first round of the one after it starts over the other
    processes at once (window_ahead.WindowsAhead.start_after), before this process settles the window
    taken, from the speed that window's first round gives its cut (that round made ready
    while the window before settled: prepare_beyond): its own first round then starts
    nothing again, and the plan is the whole program's."""
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "2")
    real_start, real_take = window_ahead.WindowsAhead._start, window_ahead.WindowsAhead.take
    events = []

    def start(self, window, key, v_start, machine, ready=None):
        events.append(("start", key, v_start, ready is not None))
        return real_start(self, window, key, v_start, machine, ready)

    def take(self, key, start_after=None):
        events.append(("take", key, None, False))
        got = real_take(self, key, start_after)
        events.append(("taken", key, None, False))
        return got

    monkeypatch.setattr(window_ahead.WindowsAhead, "_start", start)
    monkeypatch.setattr(window_ahead.WindowsAhead, "take", take)
    # windows of 30: four or more over the program's moves (its stops overlapped take fewer
    # path moves than the blends they replace, and windows of 40 gave three)
    whole, windowed, _ = _whole_and_windowed(_program(), monkeypatch, 30, 6)
    starts = [(key, v) for kind, key, v, _ in events if kind == "start"]
    assert len(starts) >= 3 and len({key for key, _ in starts}) == len(starts), starts
    inside = ready = 0
    taking = False
    for kind, _, _, made in events:
        taking = kind == "take" or (taking and kind != "taken")
        inside += kind == "start" and taking
        ready += kind == "start" and taking and made
    assert inside >= len(starts) - 2, events  # all but the first one or two
    assert ready >= inside - 1, events  # its first round made while the next window settled
    _assert_same(whole, windowed)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="forks on Linux only")
def test_a_window_whose_preparation_ahead_fails_is_prepared_again(monkeypatch):
    """The job preparing the next window ahead never raises: the window is prepared where it
    is used (an error there is raised in the order a plan without the job meets it)."""
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "2")
    real = window_ahead.window_of
    failed = []

    def window_of(*args, **kwargs):
        if sys._getframe(1).f_code.co_name == "_prepare":
            failed.append(True)
            raise RuntimeError("prepared ahead")
        return real(*args, **kwargs)

    monkeypatch.setattr(window_ahead, "window_of", window_of)
    whole, windowed, _ = _whole_and_windowed(_program(), monkeypatch, 40, 8)
    assert failed
    _assert_same(whole, windowed)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="forks on Linux only")
def test_slow_blends_judged_over_processes_are_the_ones_judged_in_one(monkeypatch):
    """Once a window finds a slow blend, the rest of the path is judged in stretches that go to
    forked processes, a wave at a time: the corners found, and so the plan, are those of the
    whole program in one process."""
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "1")
    whole = _plan_whole(_program())
    _small_windows(monkeypatch, 25, 5)
    monkeypatch.setattr(window_judge, "JUDGE_MOVES", 25)
    waves = count_fork_map_parts(monkeypatch, window_judge)
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "3")
    windowed = plan(interpret_events(_program()), load_machine_config(DEFAULT_MACHINE))
    assert len(waves) > 1 and max(waves) == 3, waves  # several waves of three processes
    assert len(whole.blends) < 69  # some corners were judged slow
    _assert_same(whole, windowed)


def test_a_windows_blends_are_found_by_bisection_as_by_a_scan():
    """PathPlan.blends_between gives the blend arcs of moves lo..hi-1 (keys from lo) that a
    scan of the whole dict gives, and follows a dict replaced or grown since it last looked."""
    from gantry_sim.controller.planner.blend import PathPlan

    rng = np.random.default_rng(3)
    path = PathPlan()
    path.blend_junction = {int(k): int(k) + 7 for k in np.unique(rng.integers(0, 500, 120))}

    def scan(lo, hi):
        return {k - lo: j for k, j in path.blend_junction.items() if lo <= k < hi}

    for lo, hi in [(0, 500), (0, 0), (17, 18), (100, 260), (499, 600), (250, 120)]:
        assert path.blends_between(lo, hi) == scan(lo, hi)
    path.blend_junction[700] = 1  # grown
    assert path.blends_between(600, 800) == {100: 1} == scan(600, 800)
    path.blend_junction = {5: 2}  # replaced
    assert path.blends_between(0, 10) == {5: 2} == scan(0, 10)


def _gentle_then_sharp(sharp_from: int) -> str:
    """A polyline of 2-5 degree turns (every blend kept), with right angles (slow blends:
    exact stops) every 7th move from move ``sharp_from`` on (none: past its end), in G64 P0.01
    without naive-CAM merging."""
    out = ["G21 G90 G17 G64 P0.01 Q0", "G0 X0 Y0 Z-1", "F2400"]
    x = y = heading = 0.0
    for k in range(150):
        sharp = k >= sharp_from and k % 7 == 6
        heading += math.radians(90.0 if sharp else 2.0 + 3.0 * ((k * 5) % 7) / 6)
        length = 0.3 + 0.2 * (k % 3)
        x, y = x + length * math.cos(heading), y + length * math.sin(heading)
        out.append(f"G1 X{x:.4f} Y{y:.4f}")
    return "\n".join([*out, "M2"]) + "\n"


def _judged_up_front(monkeypatch) -> None:
    """Make a long path's blends be judged all before planning (as before window_judge), and
    the path made again at once where some are slow."""
    init = window_judge.JudgedPath.__init__

    def up_front(self, path, remake_path, machine, feed_override_pct):
        if remake_path is not None and path.blend_junction:
            slow = window_judge.blends_to_skip(path, machine, feed_override_pct)
            path = remake_path(slow) if slow else path
        init(self, path, None, machine, feed_override_pct)

    monkeypatch.setattr(window_judge.JudgedPath, "__init__", up_front)


@pytest.mark.parametrize("sharp_from", [1000, 120, 0])
def test_blends_judged_as_the_windows_go_are_those_judged_first(monkeypatch, sharp_from):
    """Each window judges its blends on its own preparation (window_judge.JudgedPath). Without
    a slow blend nothing else is judged; at the first window with one (late or at once), the
    rest of the path is judged and the path made again, once. The plan is the one of judging
    every blend before planning, number for number."""
    text = _gentle_then_sharp(sharp_from)
    judged_apart = []
    real = window_judge.blends_to_skip

    def spy(path, machine, feed, start=0, stop=None):
        judged_apart.append(start)
        return real(path, machine, feed, start, stop)

    monkeypatch.setattr(window_judge, "blends_to_skip", spy)
    remade = []
    remake = window_judge.JudgedPath.remake

    def counted(self, found, judged_to):
        remade.append((len(found), judged_to))
        return remake(self, found, judged_to)

    monkeypatch.setattr(window_judge.JudgedPath, "remake", counted)
    judged: list[int] = []  # the junctions of the blends judged, as slow_blends gets them
    slow_blends = window_judge.slow_blends

    def each(path, prepared, jerk):
        judged.extend(path.blend_junction.values())
        return slow_blends(path, prepared, jerk)

    monkeypatch.setattr(window_judge, "slow_blends", each)
    blend = blending(load_machine_config(DEFAULT_MACHINE))  # corner blends, not the G64 fit
    windowed, probes = _windowed(tuple(interpret_events(text)), monkeypatch, 40, 8, blend)
    assert len(judged) == len(set(judged)) == 149  # every blend judged, once
    assert len(probes) >= 4, probes
    if sharp_from >= 150:
        assert remade == [] and judged_apart == []
        assert len(windowed.blends) == 149  # every corner blended
    else:
        assert len(remade) == 1 and judged_apart == [remade[0][1]] and remade[0][0] > 0
        assert len(blend_arcs(windowed)) < 149  # the others: stops, some overlapped
        if sharp_from > 100:  # found late: the windows before judged their own blends
            assert remade[0][1] > 80
    _judged_up_front(monkeypatch)
    first = plan(interpret_events(text), blend)
    _assert_same(first, windowed)


def test_a_long_plan_reports_its_progress_window_by_window(monkeypatch):
    """plan(advance=...) gets the items planned as the windows are: increasing, in several
    steps, adding up to all the items (a progress bar's updates: sim/progress.py)."""
    events = tuple(interpret_events(_program()))
    machine = load_machine_config(DEFAULT_MACHINE)
    monkeypatch.setattr(window_cut, "WINDOW_MOVES", 30)  # four or more windows (as above)
    monkeypatch.setattr(window_cut, "MARGIN_MOVES", 6)
    steps: list[int] = []
    planned = plan(events, machine, advance=steps.append)
    assert sum(steps) == len(events)
    assert len(steps) >= 4 and min(steps) > 0  # one per window kept, the rest at the end
    assert steps[-1] < len(events) / 2  # not all at the end
    assert planned.duration_s == plan(events, machine).duration_s
