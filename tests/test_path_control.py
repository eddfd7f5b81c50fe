"""Path control (G61, G61.1, G64 P Q): the interpreter carries the mode on each move, the
planner stops or blends at each junction accordingly, and a blend keeps the limits, the feed
and the tolerance."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from gantry_sim.controller.gcode.dialects import with_segmentation_default
from gantry_sim.controller.gcode.interpreter import interpret_events, parse_program
from gantry_sim.controller.moves import Arc, Dwell, Linear, PathControl, Stop
from gantry_sim.controller.planner.plan import plan
from tests.plan_helpers import (
    assert_within_limits,
    blend_arcs,
    blending,
    move_entry_starts,
    polyline_distance,
)


def _sample(moves, machine):
    p = plan(moves, machine)
    return p, p.sample(machine.servo.period_s)


def _speed_at(p, t):
    return float(np.linalg.norm(p.curve.evaluate(np.array([t]))[1]))


def _corner_program(mode: str) -> str:
    return f"G21 G90 G17 {mode}\nG1 X20 F3000\nG1 X40 Y0.7\nG1 X60 Y0\nM2"


def test_interpreter_carries_g61_g611_and_g64_p_q_in_program_units():
    moves = parse_program(
        "G20 G64 P0.001 Q0.002 F10\nG1 X1\nG61.1\nG1 Y1\nG61 G1 X0\nG64\nG1 Y0\nM2"
    )
    assert moves[0].path == PathControl("G64", 0.0254, 0.0508)
    assert moves[1].path == PathControl("G61.1")
    assert moves[2].path == PathControl("G61")
    assert moves[3].path == PathControl("G64", None, None)
    # rs274 -g: "G64 P0.01" prints SET_NAIVECAM_TOLERANCE(0.0100): Q defaults to P
    assert parse_program("G21 G64 P0.01\nG1 X1 F100\nM2")[0].path == PathControl("G64", 0.01, 0.01)
    assert parse_program("G1 X1 F100\nM2")[0].path is None


def test_every_motion_carries_the_programs_mode_rapids_cycles_and_compensation_too(machine):
    """Rapids, a canned cycle's moves and cutter compensation's tool-centre moves carry the
    program's path control as G1/G2/G3 do (they were planned in the machine file's default
    G64: a G61 program's compensated square got four blends)."""
    text = (
        "G21 G90 G17 G61\nT1 M6\nG10 L1 P1 R1\nF600\nG0 X-5 Y-5\nG41 D1\nG1 X0 Y0\n"
        "G1 X20\nG1 Y20\nG1 X0\nG1 Y0\nG40\nG0 X-10 Y-10\nG81 X5 Y5 Z-1 R2\nG80\nM2\n"
    )
    moves = parse_program(text)
    kinds = {type(m).__name__ for m in moves}
    assert kinds == {"Rapid", "Linear", "Arc"}
    assert all(m.path == PathControl("G61") for m in moves)
    assert not plan(moves, machine).blends


def test_g64_blends_a_corner_within_p_and_keeps_every_limit(machine):
    moves = parse_program(_corner_program("G64 P0.01"))
    p, tr = _sample(moves, machine)
    assert len(p.blends) == 2
    assert all(0 < b.deviation_mm <= 0.01 for b in p.blends)
    assert_within_limits(tr, machine, moves)
    dev = polyline_distance(tr.pos, moves)
    assert dev.max() <= 0.01
    speed = np.linalg.norm(tr.vel, axis=1)
    near = np.linalg.norm(tr.pos - np.array([20.0, 0.0, 0.0]), axis=1) < 0.05
    assert speed[near].min() > 30.0  # the corner is passed moving, not at rest
    g61 = plan(parse_program(_corner_program("G61")), machine)
    assert p.duration_s < g61.duration_s
    assert np.array_equal(tr.pos[-1], moves[-1].end)


def test_a_sharp_corner_gets_no_blend_arc_where_it_would_crawl(machine):
    # 90 degrees within 0.01 mm: a jerk-limited blend passes at ~1.4 mm/s, slower than
    # stopping; the stop's two moves overlap instead (planner/stop_overlap.py), which the
    # G61 plan of the same corner does not
    text = "G21 G64 P0.01\nG1 X20 F3000\nG1 Y20\nM2"
    p = plan(parse_program(text), machine)
    assert [b.kind for b in p.blends] == ["overlap"]
    assert not any(isinstance(m, Arc) for m in p.path_moves)
    g61 = plan(parse_program(text.replace("G64 P0.01", "G61")), machine)
    assert not g61.blends and _speed_at(g61, g61.move_start_s[1]) < 1e-6
    tau = float(p.overlaps_s[0, 1] - p.overlaps_s[0, 0])
    assert p.duration_s == pytest.approx(g61.duration_s - tau, abs=1e-12)


def test_g61_stops_at_corners_and_g611_at_every_junction(machine):
    p61 = plan(parse_program(_corner_program("G61")), machine)
    assert not p61.blends
    assert _speed_at(p61, p61.move_start_s[1]) < 1e-6
    collinear = "G1 X10 F3000\nG1 X20\nM2"
    free = plan(parse_program("G61\n" + collinear), machine)
    assert _speed_at(free, free.move_start_s[1]) == pytest.approx(50.0, rel=1e-9)
    stop = plan(parse_program("G61.1\n" + collinear), machine)
    assert _speed_at(stop, stop.move_start_s[1]) < 1e-6


def test_the_machine_file_sets_the_mode_when_the_program_sets_none(machine):
    moves = parse_program(_corner_program(""))
    assert plan(moves, machine).blends  # bundled default: G64
    exact = plan(moves, machine.with_changes("path", mode="G61"))
    assert not exact.blends
    wide = plan(moves, machine.with_changes("path", tolerance_mm=0.05))
    assert max(b.deviation_mm for b in wide.blends) > 0.02
    assert all(b.deviation_mm <= 0.05 for b in wide.blends)


def test_polygon_circle_blends_within_p_faster_than_exact_stops(machine):
    pts = [
        (10 * math.cos(2 * math.pi * k / 72), 10 * math.sin(2 * math.pi * k / 72))
        for k in range(73)
    ]
    body = "".join(f"G1 X{x:.4f} Y{y:.4f}\n" for x, y in pts[1:])
    head = f"G21 G90 G17\nG0 X{pts[0][0]:.4f} Y{pts[0][1]:.4f}\nF3000\n"
    blended = parse_program(head.replace("G17", "G17 G64 P0.01") + body + "M2")
    exact = parse_program(head.replace("G17", "G17 G61") + body + "M2")
    pb, tr = _sample(blended, machine)
    pe = plan(exact, machine)
    assert pb.duration_s < 0.7 * pe.duration_s
    assert_within_limits(tr, machine, blended)
    feed = tr.line > 3
    assert polyline_distance(tr.pos[feed], blended[1:]).max() <= 0.01


def _polygon(n: int, mode: str, r: float = 10.0) -> str:
    pts = [
        (r * math.cos(2 * math.pi * k / n), r * math.sin(2 * math.pi * k / n)) for k in range(n + 1)
    ]
    body = "".join(f"G1 X{x:.4f} Y{y:.4f}\n" for x, y in pts[1:])
    return f"G21 G90 G17 {mode}\nG0 X{pts[0][0]:.4f} Y{pts[0][1]:.4f}\nF3000\n{body}M2"


def test_blends_of_a_regular_polygon_meet_and_pass_it_like_a_circle(machine):
    """Blends that can use up the straight moves between them take up to 0.99 of the budget
    (P less the reference's share): no line-to-arc curvature jump is left, so the 72-gon runs
    at the feed like the G3 circle (it ran at about 0.55 F with blends of 0.8 of the budget)."""
    machine = blending(machine)  # blends corner by corner, not the G64 fit
    moves = parse_program(_polygon(72, "G64 P0.01"))
    p, tr = _sample(moves, machine)
    g3 = plan(parse_program("G21 G90 G17\nG0 X10 Y0\nG3 X10 Y0 I-10 J0 F3000\nM2"), machine)
    assert p.duration_s <= 1.03 * g3.duration_s
    budget = 0.01 - 0.25 * machine.segmentation.chord_tolerance_mm
    inner = p.blends[1:-1]
    assert len(inner) == 69
    assert all(0.8 * budget < b.deviation_mm <= 0.99 * budget for b in inner)
    speed = np.linalg.norm(tr.vel, axis=1)
    mid = slice(len(speed) // 4, 3 * len(speed) // 4)
    assert speed[mid].min() >= 0.999 * 50.0
    assert_within_limits(tr, machine, moves)
    feed = tr.line > 3
    assert polyline_distance(tr.pos[feed], moves[1:]).max() <= 0.01


def test_blends_that_cannot_meet_keep_their_smoothing_share(machine):
    """A 72-gon of R50 turns 5 degrees at each corner like the R10 one, but its sides are too
    long for its blends to meet within P: each keeps 0.8 of the budget for geometry and the rest
    for smoothing its line-to-arc curvature jumps."""
    moves = parse_program(_polygon(72, "G64 P0.01", r=50.0))
    p, tr = _sample(moves, machine)
    budget = 0.01 - 0.25 * machine.segmentation.chord_tolerance_mm
    assert len(p.blends) == 71  # every corner blended, or a stop overlapped (shared_jerk.py)
    arcs = blend_arcs(p)
    assert len(arcs) >= 35
    assert all(b.deviation_mm == pytest.approx(0.8 * budget, rel=1e-6) for b in arcs)
    assert_within_limits(tr, machine, moves)
    assert polyline_distance(tr.pos[tr.line > 3], moves[1:]).max() <= 0.01


#: A 3-D finishing raster in XZ (CAMotics' flower mold example, lines 2001-2011; G20, F20 in/min):
#: small turns, each blended by a short arc whose junctions the look-ahead leaves a hair below
#: the feed.
FINISHING_RASTER = """G90 G20
G0 X1.7151 Y0.4879 Z-0.2683
G1 F20 X1.7348 Y0.4879 Z-0.2564
G1 X1.7572 Y0.4879 Z-0.2507
G1 X1.8050 Y0.4879 Z-0.2500
G1 X1.8078 Y0.4879 Z-0.2430
G1 X1.8219 Y0.4879 Z-0.1046
G1 X1.8303 Y0.4879 Z-0.0603
G1 X1.8444 Y0.4879 Z-0.0336
G1 X1.8612 Y0.4879 Z-0.0181
G1 X1.8865 Y0.4879 Z-0.0059
G1 X1.9118 Y0.4879 Z-0.0007
G1 X2.2490 Y0.4879 Z0.0000
M2
"""


def test_blend_arcs_a_hair_below_the_feed_are_passed_at_their_junction_speed(machine):
    """Each blend arc's profile used to bump from its junctions' speed (0.999 F) up to F and
    back: its phase switches, 0.3 ms from the junctions, left the pieces there no time to
    smooth the line-to-arc curvature jump, and the junctions were backed off round after round
    to 0.73-0.90 F. A curved chain that close to its cap keeps its end speed."""
    moves = parse_program(FINISHING_RASTER)
    p, tr = _sample(moves, machine)
    feed = 20 * 25.4 / 60
    arcs = [k for k, m in enumerate(p.path_moves) if isinstance(m, Arc)]
    assert len(arcs) == len(blend_arcs(p)) == 9  # the tenth corner: a stop overlapped
    at = move_entry_starts(p)[arcs]
    speeds = np.linalg.norm(p.curve.evaluate(at)[1], axis=1)
    assert speeds.min() >= 0.99 * feed
    assert_within_limits(tr, machine, moves)
    assert polyline_distance(tr.pos[tr.line > 2], moves[1:]).max() <= 0.01


#: A print's perimeter (Slic3r 1.2.0, cncjs' sample file lines 25-40, after its start code):
#: 15 short G1 moves turning 8-15 degrees, blended under Marlin's M204 S130.
PERIMETER = """G21
G90
M82
G92 E0
G1 Z0.350 F15000.000
G1 X-0.036 Y14.223
M204 S130
G1 X-11.690 Y14.193 E5.05973 F1080.000
G1 X-12.984 Y14.023 E5.17842
G1 X-14.655 Y13.575 E5.33566
G1 X-15.861 Y13.076 E5.45435
G1 X-17.358 Y12.211 E5.61158
G1 X-18.394 Y11.417 E5.73027
G1 X-19.617 Y10.193 E5.88758
G1 X-20.411 Y9.158 E6.00627
G1 X-21.276 Y7.660 E6.16349
G1 X-21.776 Y6.454 E6.28218
G1 X-22.223 Y4.784 E6.43942
G1 X-22.393 Y3.490 E6.55811
G1 X-22.393 Y1.760 E6.71539
G1 X-22.223 Y0.466 E6.83408
G1 X-21.789 Y-1.172 E6.98820
"""


def test_a_blend_arc_ramping_at_its_junction_drops_the_phase_switch_there(machine):
    """Each blend arc's profile ramps its tangential acceleration at full jerk for the first
    and last 1.2 ms (a bump towards the feed): the switches became vertices, and the piece
    from the junction to the first had 1.2 ms to smooth the line-to-arc curvature jump
    (Ruckig stretched it 250 times), so the junctions were backed off round after round to
    0.49-0.60 F. An offending end is tried again without the switches near it: one closed
    form from the junction to the next chord vertex, checked as every end piece is."""
    machine = blending(machine)  # blends corner by corner, not the G64 fit
    machine = with_segmentation_default(machine, "marlin")
    moves = list(interpret_events(PERIMETER, "marlin"))
    p, tr = _sample(moves, machine)
    arcs = [k for k, m in enumerate(p.path_moves) if isinstance(m, Arc)]
    assert len(arcs) == sum(b.kind == "corner" for b in p.blends) == 14
    starts = move_entry_starts(p)[arcs]
    speeds = np.linalg.norm(p.curve.evaluate(starts)[1], axis=1)
    assert speeds.min() >= 0.75 * 1080.0 / 60.0
    assert_within_limits(tr, machine, moves)
    lines = [m for m in moves if isinstance(m, Linear)]
    assert polyline_distance(tr.pos, lines).max() <= 0.01


#: A finishing raster's row in XZ (CAMotics' flower mold example, lines 1631-1638, G20, F20
#: in/min): the blend arcs at lines 7 and 8 offend, and their tries without the phase switches
#: near the offending ends are kept (they offend less).
RASTER_ROW = """G90 G20
G0 X0.5096 Y0.4504 Z-0.2509
F20
G1X0.5321Y0.4504Z-0.2571
G1X0.5518Y0.4504Z-0.2695
G1X0.5686Y0.4504Z-0.2899
G1X0.5799Y0.4504Z-0.3159
G1X0.5827Y0.4504Z-0.3192
G1X0.6220Y0.4504Z-0.3283
G1X0.6754Y0.4504Z-0.3346
G1X0.7344Y0.4504Z-0.3366
M2
"""


def _emitted_lines(monkeypatch) -> list[int]:
    """The program lines of the arcs whose pieces are emitted (a first try or a loose one)."""
    from gantry_sim.controller.planner import pieces

    emitted: list[int] = []
    emit = pieces.MovePieces._emit

    def counted(self, *args):
        emitted.append(args[0].move.line)
        return emit(self, *args)

    monkeypatch.setattr(pieces.MovePieces, "_emit", counted)
    return emitted


def test_loose_tries_made_beforehand_are_the_ones_made_one_by_one(machine, monkeypatch):
    """The loose tries a batch of chains may need are made at once beforehand
    (chain_plan._plan_batch); the plan is the one made trying them one by one, bit for bit."""
    from gantry_sim.controller.planner import chain_plan, pieces

    moves = parse_program(RASTER_ROW)
    emitted = _emitted_lines(monkeypatch)
    ahead = plan(moves, machine)
    tries = len(emitted)
    emitted.clear()
    monkeypatch.setattr(chain_plan, "loose_patterns", lambda *args: [])
    one_by_one = plan(moves, machine)
    assert len(emitted) == tries > 0
    assert ahead.duration_s == one_by_one.duration_s
    a, b = ahead.sample(0.0005), one_by_one.sample(0.0005)
    assert np.array_equal(a.pos, b.pos) and np.array_equal(a.acc, b.acc)
    monkeypatch.setattr(pieces, "LOOSE_FEED_ROOM", 1.0)  # no loose tries: a slower plan
    assert plan(moves, machine).duration_s > ahead.duration_s


def test_a_loose_try_that_is_no_better_leaves_the_plan_as_without_it(machine, monkeypatch):
    """A loose try that offends as much as the first changes nothing: the junction is backed
    off as without it, and the plan is the one made without loose tries, bit for bit. (Most
    loose tries on real programs made the same vertices as the first try again, before those
    were no longer tried; here every loose try is made so.)"""
    from gantry_sim.controller.planner import chain_plan, pieces

    closed_form = pieces.MovePieces.closed_form

    def same_as_first(self, g, profile, state_in, state_out, loose=(False, False)):
        return closed_form(self, g, profile, state_in, state_out)

    monkeypatch.setattr(pieces.MovePieces, "closed_form", same_as_first)
    monkeypatch.setattr(chain_plan, "loose_patterns", lambda *args: [])
    moves = parse_program(RASTER_ROW)
    emitted = _emitted_lines(monkeypatch)
    with_try = plan(moves, machine)
    tried = list(emitted)
    emitted.clear()
    monkeypatch.setattr(pieces, "LOOSE_FEED_ROOM", 1.0)  # no profile is far enough below F
    without = plan(moves, machine)
    assert len(tried) > len(emitted)  # the loose tries, each emitted and taken back
    assert with_try.duration_s == without.duration_s
    assert with_try.ruckig_piece_count == without.ruckig_piece_count
    a, b = with_try.sample(0.0005), without.sample(0.0005)
    assert np.array_equal(a.pos, b.pos) and np.array_equal(a.acc, b.acc)


def _bent_polyline() -> str:
    """60 G1 steps of 0.1-0.4 mm turning 1-6 degrees either way at F3000 (a CAM surface's
    polyline), blended in G64 P0.01 with no naive-CAM merging."""
    x = y = heading = 0.0
    lines = ["G21 G90 G17 G64 P0.01 Q0 F3000", "G1 X0 Y0"]
    for k in range(60):
        heading += math.radians((1 + 5 * ((k * 7) % 11) / 10) * (1 if k % 9 < 5 else -1))
        step = 0.1 + 0.3 * ((k * 5) % 13) / 12
        x, y = x + step * math.cos(heading), y + step * math.sin(heading)
        lines.append(f"G1 X{x:.4f} Y{y:.4f}")
    return "\n".join([*lines, "M2"])


def test_the_loose_tries_made_beforehand_hold_every_one_used_and_only_those_that_may_be(
    machine, monkeypatch
):
    """A batch makes beforehand only the loose tries of the ends that can offend (an end
    piece that goes to Ruckig or leaves the arc, or any other Ruckig piece): every try an arc
    then uses was made beforehand (none is made on its own), and fewer are made than one per
    moving end with a switch near it."""
    machine = blending(machine)  # blends corner by corner, not the G64 fit
    from gantry_sim.controller.planner import chain_plan, pieces

    made, alone = [], []
    closed_forms, closed_form = pieces.MovePieces.closed_forms, pieces.MovePieces.closed_form
    patterns = pieces.loose_patterns

    def count_batch(self, requests, loose=None):
        if loose is not None:
            made.extend(loose)
        return closed_forms(self, requests, loose)

    def count_alone(self, g, profile, state_in, state_out, loose=(False, False)):
        if any(loose):
            alone.append(loose)
        return closed_form(self, g, profile, state_in, state_out, loose)

    every = []

    def every_pattern(g, profile, pcs, s_in, s_out, dev_max_mm):
        every.extend(patterns(g, profile, pcs, s_in, s_out, -1.0))  # as if every end offends
        return patterns(g, profile, pcs, s_in, s_out, dev_max_mm)

    monkeypatch.setattr(pieces.MovePieces, "closed_forms", count_batch)
    monkeypatch.setattr(pieces.MovePieces, "closed_form", count_alone)
    monkeypatch.setattr(chain_plan, "loose_patterns", every_pattern)
    emitted = _emitted_lines(monkeypatch)
    arc = pieces.MovePieces.arc
    used = []

    def tried(self, *args, **kwargs):  # an arc whose pieces are emitted twice: a loose try
        before = len(emitted)
        out = arc(self, *args, **kwargs)
        used.extend([1] if len(emitted) - before > 1 else [])
        return out

    monkeypatch.setattr(pieces.MovePieces, "arc", tried)
    for text in (RASTER_ROW, _bent_polyline()):
        moves = parse_program(text)
        assert any(isinstance(m, Arc) for m in plan(moves, machine).path_moves)
    assert alone == []
    assert 0 < len(used) <= len(made) < len(every)
    zig = "".join(f"G1 X{k} Y{0.001 * (k % 2):.3f}\n" for k in range(1, 11))
    merged = plan(parse_program("G21 G64 P0.01 Q0.002 F3000\n" + zig + "M2"), machine)
    plain = plan(parse_program("G21 G64 P0.01 Q0 F3000\n" + zig + "M2"), machine)
    # rs274: a P without Q is also the naive-CAM tolerance, so G64 P0.01 merges this zigzag too
    by_p = plan(parse_program("G21 G64 P0.01 F3000\n" + zig + "M2"), machine)
    assert by_p.move_lines.tolist() == [2] and not by_p.blends
    assert not merged.blends and len(plain.blends) == 9
    assert merged.move_lines.tolist() == [2]
    assert merged.duration_s < plain.duration_s


def test_a_blend_between_merged_moves_names_every_program_move_it_passes(machine):
    # a 360-gon in G64 P0.01: Q (= P) merges five sides at a time, and the blends of the
    # merged moves meet, each passing most of ten sides. A blend named only the two sides at
    # its corner, so the contour error searched the wrong sides for its samples: 87 um from
    # them where the path is 9.6 um from the polygon.
    machine = blending(machine)  # blends corner by corner, not the G64 fit
    from gantry_sim.sim.program_distance import distance_to_program

    sides = "".join(
        f"G1 X{10 * math.cos(math.radians(a)):.4f} Y{10 * math.sin(math.radians(a)):.4f}\n"
        for a in range(1, 361)
    )
    p = plan(parse_program(f"G21 G90 G17 G64 P0.01\nG0 X10 Y0\nF3000\n{sides}M2\n"), machine)
    assert len(p.merges) > 50 and len(p.blends) > 50
    tr = p.sample(machine.servo.period_s)
    feed = tr.line > 3
    dist, _ = distance_to_program(p.moves, tr.line[feed], tr.pos[feed], window=tr.source[feed])
    assert dist.max() <= 0.01


def test_g64_q_merges_report_how_far_they_leave_the_programmed_points(machine, tmp_path):
    """The zigzag's inner points lie 1 um off its merged line: `gantry plan` reports the merge,
    and the run's reference part is split to it (before, a merge counted as neither blend nor
    planning, and the reference part was unexplained)."""
    machine = blending(machine)  # Q merges: the fit would take these moves first
    import json

    from gantry_sim.sim.cli import main

    zig = "".join(f"G1 X{k} Y{0.001 * (k % 2):.3f}\n" for k in range(1, 11))
    text = "G21 G90 G64 P0.01 Q0.002 F3000\n" + zig + "G1 Y5\nG1 X0 Y5.0015\nG1 X-10 Y5\nM2\n"
    p = plan(parse_program(text), machine)
    assert [(m.line, m.tolerance_mm) for m in p.merges] == [(2, 0.002), (13, 0.002)]
    assert p.merges[0].deviation_mm == pytest.approx(0.001, abs=1e-9)
    assert p.merges[1].deviation_mm == pytest.approx(0.0015, abs=1e-9)
    prog = tmp_path / "zig.ngc"
    prog.write_text(text)
    blend = tmp_path / "blend.toml"
    blend.write_text('[path]\nshort_moves = "blend"\n')
    assert main(["plan", str(prog), "--machine", str(blend)]) == 0
    out = tmp_path / "o"
    run = ["run", str(prog), "--machine", str(blend), "--out", str(out), "--no-plots"]
    assert main([*run, "--no-trace"]) == 0
    parts = json.loads((out / "report.json").read_text())["parts_um"]
    # the merges' 1.5 um, or the stops overlapped at the square corners of lines 12-14
    # (planner/stop_overlap.py), whichever is larger
    overlaps = [b.deviation_mm * 1000.0 for b in p.blends if b.kind == "overlap"]
    assert len(overlaps) == 2
    assert parts["reference_blend_max"] == pytest.approx(max([1.5, *overlaps]), abs=1e-6)
    assert parts["reference_max"] <= parts["reference_blend_max"] + parts["reference_planning_max"]


def test_gantry_plan_reports_the_merges(tmp_path, capsys):
    import json

    from gantry_sim.sim.cli import main

    prog = tmp_path / "zig.ngc"
    prog.write_text("G21 G64 P0.01 Q0.002 F3000\nG1 X1\nG1 X2 Y0.001\nG1 X3 Y0\nM2\n")
    assert main(["plan", str(prog)]) == 0
    merges = json.loads(capsys.readouterr().out)["merges"]
    assert merges["count"] == 1 and merges["max_deviation_line"] == 2
    assert merges["max_deviation_mm"] == pytest.approx(0.001, abs=1e-9)


def test_a_corner_outside_the_principal_planes_gets_no_blend_arc(machine):
    """No blend arc outside XY, XZ, YZ: the corner is a stop, whose two moves overlap
    (planner/stop_overlap.py: they share only Z, a tenth of each move, so the jerks add
    within its limit)."""
    moves = [
        Linear(1, (0.0, 0.0, 0.0), (10.0, 0.0, 1.0), 3000.0, PathControl("G64", 0.01)),
        Linear(2, (10.0, 0.0, 1.0), (10.0, 10.0, 2.0), 3000.0, PathControl("G64", 0.01)),
    ]
    p = plan(moves, machine)
    assert [b.kind for b in p.blends] == ["overlap"]
    assert not any(isinstance(m, Arc) for m in p.path_moves)


def test_a_dwell_is_an_exact_stop_that_holds_still_for_its_time(machine):
    text = "G21 G61 F3000\nG1 X10\nG4 P0.5\nG1 X20\nM0\nG1 X30\nM2"
    items = list(interpret_events(text))
    assert any(isinstance(i, Dwell) for i in items)
    p, tr = _sample(items, machine)
    moves_only = plan([i for i in items if not isinstance(i, Dwell | Stop)], machine)
    # the dwell stops at X10 (else a free collinear junction) and waits 0.5 s there; M0 stops
    assert p.duration_s > moves_only.duration_s + 0.5
    held = tr.line == 3
    assert held.sum() >= 499
    assert np.allclose(tr.pos[held], [10.0, 0.0, 0.0]) and not tr.vel[held].any()
    stop_t = p.move_start_s[list(p.move_lines).index(6)]
    assert _speed_at(p, stop_t) < 1e-6
    assert _speed_at(moves_only, moves_only.move_start_s[1]) > 49.0
    assert_within_limits(tr, machine, [i for i in items if isinstance(i, Linear)])


def test_a_dwell_at_the_program_start_and_end_adds_its_time(machine):
    items = list(interpret_events("G21 F600\nG4 P0.2\nG1 X5\nG4 P0.3\nM2"))
    p, tr = _sample(items, machine)
    bare = plan([i for i in items if isinstance(i, Linear)], machine)
    assert p.duration_s == pytest.approx(bare.duration_s + 0.5, abs=1e-9)
    assert (tr.line == 2).sum() >= 199 and np.array_equal(tr.pos[-1], [5.0, 0.0, 0.0])


def test_gantry_plan_reports_blends_and_plans_dwells(write_program, tmp_path, capsys):
    from gantry_sim.sim.cli import main

    text = "G21 G64 P0.01 F3000\nG1 X20\nG1 X40 Y0.7\nG4 P0.25\nG1 X60 Y0\nM2\n"
    out = tmp_path / "traj.npz"
    assert main(["plan", str(write_program(text)), "--out", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["blends"]["count"] == 1 and summary["blends"]["max_deviation_line"] == 2
    assert 0 < summary["blends"]["max_deviation_mm"] <= 0.01
    line = np.load(out)["line"]
    assert (line == 4).sum() >= 249  # the reference holds still during the dwell


def test_gantry_run_splits_the_reference_part_into_blend_and_planning(write_program, tmp_path):
    from gantry_sim.sim.cli import main

    text = "G21 G64 P0.01 F3000\nG1 X10\nG1 X20 Y0.35\nG1 X30 Y0\nM2\n"
    assert main(["run", str(write_program(text)), "--out", str(tmp_path / "o")]) == 0
    parts = json.loads((tmp_path / "o" / "report.json").read_text())["parts_um"]
    assert {"chord_max", "reference_max", "tracking_max"} <= set(parts)
    assert 0 < parts["reference_blend_max"] <= 10.0
    assert parts["reference_planning_max"] < 0.25  # 0.25 x the 1 um chord tolerance
    assert parts["reference_max"] <= parts["reference_blend_max"] + parts["reference_planning_max"]


def test_marlin_limit_codes_apply_from_their_line_on(machine):
    text = (
        "G21\nG1 X50 F6000\nM201 X200 Y200\nM203 X20\nG1 X100\n"
        "M205 J0.05\nG1 X110 Y0.5\nG1 X120 Y0\nM2"
    )
    items = list(interpret_events(text, dialect="marlin"))
    p = plan(items, machine)
    tr = p.sample(machine.servo.period_s)
    before, after = tr.line == 2, np.isin(tr.line, [5, 7, 8])
    assert np.abs(tr.vel[before, 0]).max() == pytest.approx(100.0)  # F6000 before M203
    assert np.abs(tr.vel[after, 0]).max() <= 20.0 * (1 + 1e-9)  # M203 X20
    assert np.abs(tr.acc[after, :2]).max() <= 200.0 * (1 + 1e-9)  # M201 X200 Y200
    assert np.abs(tr.acc[before, 0]).max() > 2000.0
    assert [b.tolerance_mm for b in p.blends] == [0.05]  # M205 J: the junction deviation
    assert 0.01 < p.blends[0].deviation_mm <= 0.05
    assert np.array_equal(tr.pos[-1], [120.0, 0.0, 0.0])
    assert list(p.moves) == [i for i in items if isinstance(i, Linear)]


# Corners with an arc on one side, 3 degrees (line -> R10 arc, arc -> line, arc -> arc).
ARC_CORNERS = {
    "line-arc": "G1 X20 F3000\nG3 X29.4629 Y10.5097 I-0.5234 J9.9863\nG1 Y30",
    "arc-line": "G1 X20 F3000\nG3 X29.4629 Y10.5097 I-0.5234 J9.9863\nG1 X28.9 Y30",
    "arc-arc": "G1 X20 F3000\nG3 X29.4629 Y10.5097 I-0.5234 J9.9863\nG2 X38.3626 Y21.4999 I9.945 J1.045",
}


def _program_distance(points: np.ndarray, moves) -> np.ndarray:
    """Distance [mm] of each point from the programmed path (moves sampled every ~0.5 um)."""
    from gantry_sim.controller.arcs import arc_points
    from gantry_sim.controller.moves import Arc

    dense = []
    for m in moves:
        k = max(2, int(m.length_mm / 5e-4))
        u = np.linspace(0.0, 1.0, k)
        dense.append(
            arc_points(m, u)
            if isinstance(m, Arc)
            else np.outer(1 - u, m.start) + np.outer(u, m.end)
        )
    path = np.vstack(dense)
    out = np.empty(len(points))
    for i in range(0, len(points), 256):
        d = np.linalg.norm(points[i : i + 256, None, :2] - path[None, :, :2], axis=2)
        out[i : i + 256] = d.min(axis=1)
    return out


@pytest.mark.parametrize("name", sorted(ARC_CORNERS))
def test_g64_blends_corners_with_arcs_within_p(machine, name):
    body = ARC_CORNERS[name]
    moves = parse_program(f"G21 G90 G17 G64 P0.01\n{body}\nM2")
    p = plan(moves, machine)
    g61 = plan(parse_program(f"G21 G90 G17 G61\n{body}\nM2"), machine)
    assert len(p.blends) == 2 and all(0 < b.deviation_mm <= 0.01 for b in p.blends)
    assert p.duration_s < g61.duration_s  # the corners are passed moving
    tr = p.sample(machine.servo.period_s)
    assert_within_limits(tr, machine, moves)
    near = np.linalg.norm(tr.pos[:, :2] - np.array([20.0, 0.0]), axis=1) < 0.2
    assert _program_distance(tr.pos[near], moves).max() <= 0.01
    assert np.linalg.norm(tr.vel, axis=1)[near].min() > 10.0
    assert np.array_equal(tr.pos[-1], moves[-1].end)


def test_a_blended_arc_is_trimmed_on_its_own_circle(machine):
    from gantry_sim.controller.arcs import arc_frame
    from gantry_sim.controller.moves import Arc

    moves = parse_program(f"G21 G90 G17 G64 P0.01\n{ARC_CORNERS['arc-arc']}\nM2")
    p = plan(moves, machine)
    arcs = [m for m in p.path_moves if isinstance(m, Arc)]
    programmed = [m for m in moves if isinstance(m, Arc)]
    assert len(arcs) == 4  # two programmed arcs (trimmed) and two blends
    for trimmed, orig in ((arcs[1], programmed[0]), (arcs[3], programmed[1])):
        assert trimmed.center == orig.center and trimmed.direction == orig.direction
        f = arc_frame(orig)
        for q in (trimmed.start, trimmed.end):
            # on the programmed arc (a slight spiral: its end radii differ by rounding)
            th = math.atan2(q[1] - orig.center[1], q[0] - orig.center[0])
            u = (f.sigma * (th - f.theta0_rad)) % (2 * math.pi) / orig.angle
            r = math.hypot(q[0] - orig.center[0], q[1] - orig.center[1])
            assert 0 <= u <= 1 + 1e-12
            assert r == pytest.approx(f.r0_mm + (f.r1_mm - f.r0_mm) * u, abs=1e-9)
        assert trimmed.angle < orig.angle


#: Corners of an arc into a line from a printed part (ArcWelder output of a Slic3r Benchy,
#: its arcs' ends as Marlin projects them onto the arc), where the search for the blend's
#: join on the line stopped at rounding: the two tangent lengths agreed to 1.003e-12 of the
#: cut, against the 1e-12 asked, so no blend was found and the corner was an exact stop
#: (100 of 2,329 corners with arcs in the first 6,000 lines).
ROUNDING_CORNERS = (
    (
        "G2 X102.76897259031863 Y102.9829932932381 I-1.889 J-1.087 F1200\nG1 X102.85 Y102.705",
        (102.541, 103.552),
    ),
    (
        "G3 X75.25298986119597 Y93.21760229723526 I1.213 J0.096 F84.6555\nG1 X98.995 Y91.567",
        (74.071, 94.338),
    ),
    (
        "G3 X75.04000347483688 Y93.69706682378597 I0.497 J-0.06 F128.951\nG1 X98.847 Y91.938",
        (74.569, 94.257),
    ),
)


@pytest.mark.parametrize(("body", "start"), ROUNDING_CORNERS)
def test_arc_corners_whose_search_stops_at_rounding_are_blended(machine, body, start):
    text = f"G21 G90 G17 G64 P0.01\nG0 X{start[0]} Y{start[1]} Z1\n{body}\nM2"
    moves = parse_program(text)
    p = plan(moves, machine)
    assert len(p.blends) == 1 and 0 < p.blends[0].deviation_mm <= 0.01
    assert p.duration_s < plan(parse_program(text.replace("G64 P0.01", "G61")), machine).duration_s
    tr = p.sample(machine.servo.period_s)
    assert_within_limits(tr, machine, moves)
    arc, line = moves[1], moves[2]
    near = tr.pos[np.linalg.norm(tr.pos[:, :2] - np.array(arc.end[:2]), axis=1) < 0.3]
    dist = np.minimum(_arc_distance(near, arc), polyline_distance(near, [line]))
    assert len(near) > 10 and dist.max() <= 0.01


def _arc_distance(q: np.ndarray, a) -> np.ndarray:
    """Exact distance [mm] of points (k, 3) from the XY arc ``a`` (no helix, no spiral)."""
    from gantry_sim.controller.arcs import arc_frame

    f = arc_frame(a)
    rel = q[:, :2] - np.array(a.center[:2])
    swept = (f.sigma * (np.arctan2(rel[:, 1], rel[:, 0]) - f.theta0_rad)) % (2 * np.pi)
    ends = np.minimum(
        np.linalg.norm(q - np.array(a.start), axis=1), np.linalg.norm(q - np.array(a.end), axis=1)
    )
    on = np.hypot(np.abs(np.hypot(rel[:, 0], rel[:, 1]) - a.radius), q[:, 2] - a.start[2])
    return np.where(swept <= a.angle, on, ends)


def test_a_blended_path_shares_its_points_and_keeps_whole_moves():
    """The path's moves hold the junction points once: a blend arc starts on the very tuple
    that ends the line before it and ends on the one that starts the line after; a line no
    blend trims is the program's move itself (a path took 1.3 KB a move, 127 MB at 100,000
    polyline blocks, held through the run)."""
    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.controller.moves import Arc
    from gantry_sim.controller.planner.path_stream import path_plan
    from gantry_sim.models import DEFAULT_MACHINE

    machine = load_machine_config(DEFAULT_MACHINE)
    program = "G21 G90 G64 P0.01 F3000\nG1 X10\nG1 X20 Y1\nG1 X30 Y-1\nG61\nG1 X40\nG1 Y10\nM2\n"
    items = tuple(interpret_events(program, "linuxcnc", "t"))
    path = path_plan(items, machine.path, machine.segmentation.chord_tolerance_mm)
    arcs = [k for k, m in enumerate(path.moves) if isinstance(m, Arc)]
    assert arcs == [1, 3, 5]  # a G64 move's end blends; G1 X40 (in G61) stops at its end
    for k in arcs:
        before, arc, after = path.moves[k - 1], path.moves[k], path.moves[k + 1]
        assert arc.start is before.end and arc.end is after.start
    lines = [m for m in items if isinstance(m, Linear)]
    assert path.moves[-1] is lines[-1]  # G1 Y10: neither end blended, the program's move
