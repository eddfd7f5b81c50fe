"""A G64 blend arc is laid within its own smoothing budget, not the machine's chord tolerance
(controller/planner/prepare.py, ``blend_chord_tolerances``): the reference may leave a blend
arc by what its tolerance P leaves after the blend's geometry, so the curvature jump where it
meets a straight move is absorbed over longer chords, and the junction is passed faster, while
the reference stays within P of the program and every limit holds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.moves import Arc
from gantry_sim.controller.planner import prepare
from gantry_sim.controller.planner.path_stream import path_plan
from gantry_sim.controller.planner.plan import plan
from tests.plan_helpers import assert_within_limits, move_entry_starts, program_deviation


def _surface_pass(p_mm: float, moves: int = 60) -> str:
    """A ball-nose finishing pass in G19: Y steps of 0.6-1.4 mm, Z over two waves (the shape of
    LinuxCNC's 3D_Chips.ngc passes, written here), at F6000 with G64 P and no Q merge."""
    y = np.cumsum(np.r_[0.0, 0.6 + 0.8 * (0.5 + 0.5 * np.sin(np.arange(moves - 1) * 0.7))])
    z = -5.0 + 3.0 * np.sin(y / 9.0) + 0.6 * np.sin(y / 2.3)
    body = "".join(f"G1 Y{a:.4f} Z{b:.4f}\n" for a, b in zip(y[1:], z[1:], strict=True))
    return f"G21 G90 G19 G64 P{p_mm} Q0\nG0 X0 Y0 Z{z[0]:.4f}\nF6000\n{body}M2\n"


def _random_polyline(seed: int, p_mm: float, feed: float, n: int = 30) -> str:
    """Moves of 0.3-5 mm turning 2-70 degrees either way, in XY."""
    rng = np.random.default_rng(seed)
    length = rng.uniform(0.3, 5.0, n)
    turn = np.radians(rng.uniform(2.0, 70.0, n)) * rng.choice([-1.0, 1.0], n)
    ang = np.cumsum(turn)
    pts = np.cumsum(np.c_[length * np.cos(ang), length * np.sin(ang)], axis=0)
    pts -= pts.mean(axis=0)
    body = "".join(f"G1 X{x:.4f} Y{y:.4f}\n" for x, y in pts[1:])
    return (
        f"G21 G90 G17 G64 P{p_mm} Q0\nG0 X{pts[0, 0]:.4f} Y{pts[0, 1]:.4f} Z0\nF{feed}\n{body}M2\n"
    )


def test_a_surface_pass_blends_faster_with_its_blends_own_chords(machine, monkeypatch):
    """Measured: 1.308 s against 1.792 s with every blend arc laid within 1 um."""
    moves = parse_program(_surface_pass(0.1))
    p = plan(moves, machine)
    monkeypatch.setattr(prepare, "BLEND_CHORD_SHARE", 0.0)
    machine_chords = plan(moves, machine)
    assert len(p.blends) == len(machine_chords.blends) == 58
    assert p.duration_s < 0.85 * machine_chords.duration_s
    tr = p.sample(1e-4)
    assert_within_limits(tr, machine, moves)
    assert program_deviation(tr, p.moves) <= 0.1


@pytest.mark.parametrize("p_mm", [0.02, 0.3, 1.0])
def test_each_blend_arc_gets_the_tolerance_its_budget_allows(machine, p_mm):
    ct = machine.segmentation.chord_tolerance_mm
    events = parse_program(_random_polyline(7, p_mm, 6000.0))
    path = path_plan(events, machine.path, ct)
    moves = list(path.moves)
    tolerances = prepare.blend_chord_tolerances(path, moves, ct)
    step = 2.0 ** (1.0 / prepare.TOLERANCE_STEPS)
    arcs = [k for k in path.blend_junction if isinstance(moves[k], Arc)]
    assert tolerances and set(tolerances) <= set(arcs)
    for k in arcs:
        arc = moves[k]
        sweep_sag = arc.radius * (1.0 - math.cos(0.5 * prepare.BLEND_CHORD_SWEEP_RAD))
        room = min(path.smoothing_mm[k], sweep_sag)
        if room < 2.0 * ct:  # no room for more than the machine's chords
            assert k not in tolerances
            continue
        tol = tolerances[k]
        assert room / step < tol <= room
        # the chord tolerance times a power of the step: blend arcs come in few batches
        power = math.log2(tol / ct) * prepare.TOLERANCE_STEPS
        assert power == pytest.approx(round(power), abs=1e-9)


@pytest.mark.parametrize(
    ("seed", "p_mm", "feed"),
    [(1, 1.0, 20000.0), (2, 0.3, 1500.0), (3, 0.3, 6000.0), (4, 0.1, 20000.0)],
)
def test_the_reference_stays_within_each_blends_budget(machine, seed, p_mm, feed):
    """On every blend arc the reference keeps within what P leaves after the blend's geometry
    (its distance from the corner, R (1 / cos(phi / 2) - 1) for a turn phi), so within P of the
    program; limits hold on every sample."""
    ct = machine.segmentation.chord_tolerance_mm
    # 60 moves: a third to a half of their corners are stops overlapped (shared_jerk.py)
    moves = parse_program(_random_polyline(seed, p_mm, feed, n=60))
    p = plan(moves, machine)
    tr = p.sample(1e-4)
    assert_within_limits(tr, machine, moves)
    assert program_deviation(tr, p.moves) <= p_mm
    # one start per path move (no zero-length move) besides the stops overlapped, which lie
    # between two straight moves, never next to an arc
    moving = move_entry_starts(p)
    assert len(moving) == len(p.path_moves)
    starts = np.append(moving, p.duration_s)
    t = np.arange(len(tr.pos)) * 1e-4
    arcs = 0
    for k, arc in enumerate(p.path_moves):
        if not isinstance(arc, Arc):
            continue
        arcs += 1
        on = (t >= starts[k]) & (t <= starts[k + 1])
        r = np.hypot(tr.pos[on, 0] - arc.center[0], tr.pos[on, 1] - arc.center[1])
        budget = p_mm - 0.25 * ct - arc.radius * (1.0 / math.cos(0.5 * arc.angle) - 1.0)
        assert np.abs(r - arc.radius).max() <= budget
    assert arcs > 10
