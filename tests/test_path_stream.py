"""The path made stretch by stretch (planner/path_stream.py) is the path made whole: the same
moves, stops, dwells, smoothing budgets, sources, blends and merges, whatever the stretch."""

from __future__ import annotations

import functools
import math

import pytest

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.gcode.interpreter import interpret_events
from gantry_sim.controller.planner.blend import PathPlan
from gantry_sim.controller.planner.path_stream import path_plan
from gantry_sim.models import DEFAULT_MACHINE


def _program() -> str:
    """Every kind of junction the path control decides: polyline corners blended and met,
    slivers absorbed, G64 Q runs merged (and broken by a dwell and a feed change), dwells,
    M0, G61.1 and G61 stretches, corners between lines and arcs, tangent arcs, rapids."""
    out = ["G21 G90 G17 G64 P0.01 Q0.005", "G4 P0.1", "G0 X0 Y0 Z-1", "F2400"]
    x = y = 0.0
    for k in range(90):
        heading = math.radians(3.0 * (k % 7) + (90.0 if k % 11 == 10 else 0.0) * (k // 11))
        length = 0.2 + 0.15 * (k % 4)
        x, y = x + length * math.cos(heading), y + length * math.sin(heading)
        out.append(f"G1 X{x:.4f} Y{y:.4f}" + (" F1800" if k == 40 else ""))
        if k in (20, 21):
            out.append("G4 P0.05")
        if k == 33:
            out.append("M0")
        if k == 50:
            out.append("G61.1")
        if k == 58:
            out.append("G61")
        if k == 64:
            out.append("G64 P0.02")
    for k in range(30):  # collinear pieces: one G64 Q run, then arcs meeting lines at corners
        x += 0.1
        out.append(f"G1 X{x:.4f} Y{y + (0.001 if k % 2 else 0.0):.4f}")
    for k in range(20):
        r = 1.0 + 0.5 * (k % 3)
        out.append(f"G{2 + k % 2} X{x + r:.4f} Y{y + r:.4f} R{r:.4f}")
        x, y = x + r, y + r
        out.append(f"G1 X{x + 0.5:.4f} Y{y + 0.2 * (k % 2):.4f}")
        x, y = x + 0.5, y + 0.2 * (k % 2)
    out += ["G0 Z2", "G4 P0.2", "M2"]
    return "\n".join(out) + "\n"


@functools.cache
def _made_whole() -> tuple[PathPlan, PathPlan, frozenset[int]]:
    """The program's path made in one stretch, and again with every fifth blend skipped (the
    junctions skipped): made once for all the stretch sizes compared with them."""
    machine = load_machine_config(DEFAULT_MACHINE)
    items = tuple(interpret_events(_program()))
    tol = machine.segmentation.chord_tolerance_mm
    whole = path_plan(items, machine.path, tol, stretch_moves=10**6)
    skip = frozenset(list(whole.blend_junction.values())[::5])
    return whole, path_plan(items, machine.path, tol, skip, stretch_moves=10**6), skip


@pytest.mark.parametrize("stretch", [1, 3, 5, 13, 64])  # below, at and above a blend's reach
def test_a_path_made_in_stretches_is_the_path_made_whole(stretch):
    machine = load_machine_config(DEFAULT_MACHINE)
    items = tuple(interpret_events(_program()))
    tol = machine.segmentation.chord_tolerance_mm
    whole, skipped, skip = _made_whole()
    assert len(whole.blends) > 50 and len(whole.merges) >= 2 and len(whole.holds) >= 3
    for s, a in ((frozenset(), whole), (skip, skipped)):
        b = path_plan(items, machine.path, tol, s, stretch_moves=stretch)
        assert list(b.moves) == list(a.moves)
        assert b.stop_after == a.stop_after and b.holds == a.holds
        assert list(b.smoothing_mm) == list(a.smoothing_mm)
        assert list(b.sources) == list(a.sources) and b.blend_junction == a.blend_junction
        assert list(b.blends) == list(a.blends) and list(b.merges) == list(a.merges)
    assert len(path_plan(items, machine.path, tol, skip).blends) < len(whole.blends)


def test_dwells_before_the_first_and_after_the_last_move_are_kept():
    machine = load_machine_config(DEFAULT_MACHINE)
    text = "G21 G90 G64 P0.01 F600\nG4 P0.5\nG1 X1\nG1 X2 Y1\nG4 P0.25\nM2\n"
    path = path_plan(tuple(interpret_events(text)), machine.path, 0.001, stretch_moves=1)
    assert [d.seconds for d in path.holds[0]] == [0.5]
    assert [d.seconds for d in path.holds[len(path.moves)]] == [0.25]
    assert path.stop_after[-1]  # the dwell after the last move stops it


def _tangent_chain() -> str:
    """Tangent arcs of several radii with S-bends, lines into arcs, a corner, a dwell: G2
    transitions at most junctions (program shaped like benchmarks/programs.py's arcs)."""
    out = ["G21 G90 G17 G64 P0.01", "G0 X0 Y0 Z-1", "F3000"]
    x = 0.0
    for k in range(24):
        r = 2.0 + (k % 3)
        out.append(f"G{2 + k % 2} X{x + 2 * r:.4f} Y0 I{r:.4f} J0")
        x += 2 * r
        if k % 5 == 4:
            out.append(f"G1 X{x + 3:.4f}")
            x += 3
        if k == 11:
            out.append("G4 P0.1")
        if k == 17:
            out.append(f"G1 X{x:.4f} Y2")  # a corner
            out.append(f"G1 X{x + 1:.4f} Y2")
            out.append(f"G1 X{x + 1:.4f} Y0")
            x += 1
    out += ["G0 Z2", "M2"]
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("stretch", [1, 4, 7, 16])
def test_transitions_made_in_stretches_are_the_transitions_made_whole(stretch, monkeypatch):
    from gantry_sim.controller.planner import blend
    from gantry_sim.controller.planner.transition import TransitionMachine

    machine = load_machine_config(DEFAULT_MACHINE)
    sizing = TransitionMachine(machine.limits, machine.segmentation)
    items = tuple(interpret_events(_tangent_chain()))
    tol = machine.segmentation.chord_tolerance_mm
    jerk = float(min(machine.limits.max_jerk_mm_per_s3))
    whole = path_plan(items, machine.path, tol, frozenset(), jerk, sizing, stretch_moves=10**6)
    kinds = [b.kind for b in whole.blends]
    assert kinds.count("transition") >= 15 and "corner" in kinds
    sized: dict = {}
    parts = path_plan(
        items, machine.path, tol, frozenset(), jerk, sizing, sized, stretch_moves=stretch
    )
    assert len(sized) >= 18  # every site sized, by its junction in the whole path
    real, sized_sites = blend.size_transitions, []

    def spy(sites, m):  # type: ignore[no-untyped-def]
        sized_sites.extend(sites)
        return real(sites, m)

    monkeypatch.setattr(blend, "size_transitions", spy)
    again = path_plan(
        items, machine.path, tol, frozenset(), jerk, sizing, sized, stretch_moves=stretch
    )
    assert sized_sites == []  # made again: every transition from ``sized``
    for b in (parts, again):
        assert list(b.moves) == list(whole.moves)
        assert list(b.smoothing_mm) == list(whole.smoothing_mm)
        assert list(b.sources) == list(whole.sources) and list(b.blends) == list(whole.blends)
        assert b.stop_after == whole.stop_after and b.holds == whole.holds


@pytest.mark.parametrize("workers", [2, 3])
def test_stretches_blended_in_forked_waves_are_the_path_made_whole(workers, monkeypatch):
    """Past the transitions kept for a path made again, stretches are blended a wave at a time,
    one per process: the same path as one process makes, move for move."""
    from gantry_sim.controller.planner import path_stream
    from gantry_sim.controller.planner.transition import TransitionMachine

    machine = load_machine_config(DEFAULT_MACHINE)
    sizing = TransitionMachine(machine.limits, machine.segmentation)
    tol = machine.segmentation.chord_tolerance_mm
    jerk = float(min(machine.limits.max_jerk_mm_per_s3))
    real, waves = path_stream.fork_map, []

    def spy(fn, parts):  # type: ignore[no-untyped-def]
        waves.append(len(parts))
        return real(fn, parts)

    for text in (_program(), _tangent_chain()):
        items = tuple(interpret_events(text))
        whole = path_plan(items, machine.path, tol, frozenset(), jerk, sizing, stretch_moves=10**6)
        skip = frozenset(list(whole.blend_junction.values())[::4])
        for s in (frozenset(), skip):
            monkeypatch.setenv("GANTRY_PLAN_WORKERS", "1")
            one = path_plan(items, machine.path, tol, s, jerk, sizing, stretch_moves=10**6)
            monkeypatch.setenv("GANTRY_PLAN_WORKERS", str(workers))
            monkeypatch.setattr(path_stream, "fork_map", spy)
            waves.clear()
            many = path_plan(items, machine.path, tol, s, jerk, sizing, stretch_moves=5)
            monkeypatch.setattr(path_stream, "fork_map", real)
            assert max(waves) == workers  # stretches went to children
            assert list(many.moves) == list(one.moves)
            assert many.stop_after == one.stop_after and many.holds == one.holds
            assert list(many.smoothing_mm) == list(one.smoothing_mm)
            assert list(many.sources) == list(one.sources)
            assert many.blend_junction == one.blend_junction
            assert list(many.blends) == list(one.blends) and list(many.merges) == list(one.merges)


def _arc_polygon(sides: int = 24, radius: float = 20.0, bulge: float = 40.0) -> str:
    """A polygon whose sides are G3 arcs of radius ``bulge`` and lines in turn: every vertex
    is a corner between an arc and a line that G64 P0.01 blends."""
    out = ["G21 G90 G17 G64 P0.01", f"G0 X{radius:.4f} Y0", "F2400"]
    for k in range(1, sides + 1):
        a = 2 * math.pi * k / sides
        x, y = radius * math.cos(a), radius * math.sin(a)
        out.append(f"G3 X{x:.4f} Y{y:.4f} R{bulge:.4f}" if k % 2 else f"G1 X{x:.4f} Y{y:.4f}")
    return "\n".join([*out, "M2"]) + "\n"


@pytest.mark.parametrize("workers", [1, 2])
def test_a_path_made_again_reuses_the_arc_corners_of_the_first(workers, monkeypatch):
    """The arc corners' blends found while a path is made (in forked children too) are kept
    by site (blend.CornerMemo); the path made again without some blends searches none of the
    corners it still blends and is the path made without the memo, move for move."""
    from gantry_sim.controller.planner import blend
    from gantry_sim.controller.planner.blend import CornerMemo

    machine = load_machine_config(DEFAULT_MACHINE)
    items = tuple(interpret_events(_arc_polygon()))
    tol = machine.segmentation.chord_tolerance_mm
    jerk = float(min(machine.limits.max_jerk_mm_per_s3))
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", str(workers))
    real, searched = blend.arc_corner, []

    def spy(m0, m1, *args):  # type: ignore[no-untyped-def]
        searched.append((m0, m1))
        return real(m0, m1, *args)

    monkeypatch.setattr(blend, "arc_corner", spy)
    memo = CornerMemo()
    first = path_plan(items, machine.path, tol, frozenset(), jerk, corners=memo, stretch_moves=5)
    assert sum(c is not None for c in memo.known.values()) == len(first.blends) == 23
    skip = frozenset(list(first.blend_junction.values())[::3])
    searched.clear()
    again = path_plan(items, machine.path, tol, skip, jerk, corners=memo, stretch_moves=5)
    assert searched == []  # every arc corner's blend came from the memo
    monkeypatch.setattr(blend, "arc_corner", real)
    fresh = path_plan(items, machine.path, tol, skip, jerk, stretch_moves=10**6)
    assert len(fresh.blends) == 23 - len(skip)
    assert list(again.moves) == list(fresh.moves) and list(again.blends) == list(fresh.blends)
    assert again.blend_junction == fresh.blend_junction
    assert list(again.sources) == list(fresh.sources) and again.stop_after == fresh.stop_after
