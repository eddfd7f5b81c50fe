"""Marlin's limit changes: the parts' plans joined end to end (controller/planner/limit_events.py)."""

from __future__ import annotations

import importlib
import json
from dataclasses import replace

import numpy as np
import pytest

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.forked import one_process
from gantry_sim.controller.gcode.interpreter import interpret_events
from gantry_sim.controller.planner import segmented_curve
from gantry_sim.controller.planner.limit_events import JoinedPlans, split_at_limits
from gantry_sim.controller.planner.plan import plan
from gantry_sim.controller.planner.segmented_curve import SegmentedCurve

plan_module = importlib.import_module("gantry_sim.controller.planner.plan")

#: a program cut into parts by limit changes that change the machine: M201 (axis
#: accelerations) four times and an M205 J between, a travel among them
PROGRAM = (
    "G21 G90\nM201 X2000 Y2000\nG1 X5 Y0 F3000\nG1 X10 Y1\nG1 X15 Y3\n"
    "M201 X1500 Y1500\nG1 X20 Y6 F1800\nG1 X25 Y8\nG1 X30 Y9\n"
    "M201 X500 Y400\nG0 X40 Y10\nG1 X45 Y11 F1200\nG1 X50 Y13\n"
    "M205 J0.02\nG1 X55 Y16\nG1 X60 Y18\nM201 X1000 Y1000\nG1 X65 Y19\nG1 X70 Y19.5\nM2\n"
)


def _parts(machine):
    items = list(interpret_events(PROGRAM, dialect="marlin"))
    return items, [plan(part.items, part.machine) for part in split_at_limits(items, machine)]


def _assert_parts_end_to_end(joined, parts) -> None:
    """``joined`` runs ``parts`` one after the other: their references, moves and sources."""
    assert isinstance(joined.curve, SegmentedCurve)
    durations = [p.duration_s for p in parts]
    assert joined.duration_s == sum(durations)
    offsets = np.concatenate(([0.0], np.cumsum(durations)[:-1]))
    for part, off in zip(parts, offsets, strict=True):
        t = off + np.linspace(0.0, part.duration_s, 401)
        got = joined.curve.evaluate(t)
        want = part.curve.evaluate(t - off)
        # phase start times are running sums across the parts (a few ulp of a second from each
        # part's own plus its offset): position [mm], velocity [mm/s] and acceleration
        # [mm/s^2] agree to what the jerk times such a slip gives
        for g, w, tol in zip(got, want, (1e-9, 1e-7, 1e-4), strict=True):
            assert np.abs(g - w).max() <= tol
    starts = np.concatenate([p.move_start_s + o for p, o in zip(parts, offsets, strict=True)])
    assert np.array_equal(joined.move_start_s, starts)
    assert np.array_equal(joined.move_lines, np.concatenate([p.move_lines for p in parts]))
    assert list(joined.moves) == [m for p in parts for m in p.moves]
    first = np.concatenate(([0], np.cumsum([len(p.moves) for p in parts])[:-1]))
    for name in ("move_sources", "path_sources"):
        own = [getattr(p, name) for p in parts]
        want = np.concatenate(
            [np.where(s >= 0, s + k, -1) for s, k in zip(own, first, strict=True)]
        )
        assert np.array_equal(getattr(joined, name), want)
    assert list(joined.path_moves) == [m for p in parts for m in p.path_moves]
    assert list(joined.blends) == [b for p in parts for b in p.blends]
    assert joined.segment_count == sum(p.segment_count for p in parts)
    assert np.array_equal(joined.end_mm, parts[-1].end_mm)


def test_the_joined_plan_runs_the_parts_one_after_the_other(machine):
    items, parts = _parts(machine)
    assert len(parts) == 5
    assert [len(p.blends) for p in parts] == [2, 2, 2, 1, 1]  # every corner inside a part
    joined = plan(items, machine)
    _assert_parts_end_to_end(joined, parts)
    tr = joined.sample(machine.servo.period_s)
    assert np.array_equal(tr.pos[-1], [70.0, 19.5, 0.0])


def test_a_long_prints_joined_reference_is_held_on_disk(machine, monkeypatch):
    """Each part's blocks go to one builder as the parts are planned: its full blocks are
    written out, and the parts' small blocks are packed together again (blocks that span
    the parts' ends here)."""
    monkeypatch.setattr(segmented_curve, "BLOCK_PHASES", 64)
    items, parts = _parts(machine)
    joined = plan(items, machine)
    assert isinstance(joined.curve, SegmentedCurve)
    assert joined.curve.spilled_bytes > 0
    assert joined.curve.phase_counts == tuple(
        int(sum(c)) for c in zip(*(p.curve.phase_counts for p in parts), strict=True)
    )
    _assert_parts_end_to_end(joined, parts)


def test_a_joiner_takes_only_a_planners_parts(machine):
    _, parts = _parts(machine)
    joined = JoinedPlans(machine.segmentation)
    with pytest.raises(ValueError, match="no part"):
        joined.finish()
    with pytest.raises(TypeError, match="SegmentedCurve"):
        joined.add(replace(parts[0], curve=parts[0].curve.laid_out()), machine.limits)


@pytest.mark.parametrize("lone", [2, 10_000])
def test_parts_planned_over_the_cores_are_those_of_one_process(machine, monkeypatch, lone):
    """Batches of parts go to forked processes (controller/forked_runs.py), a part of
    LONE_PART_MOVES or more is planned alone: the plan is the one process' bit for bit."""
    items = list(interpret_events(PROGRAM, dialect="marlin"))
    with one_process():
        alone = plan(items, machine)
    monkeypatch.setattr(plan_module, "PART_BATCH_MOVES", 5)  # batches of two parts
    monkeypatch.setattr(plan_module, "LONE_PART_MOVES", lone)  # 2: the parts of 2 or 3 moves
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "2")
    batches: list[tuple[int, int]] = []  # (parts, processes) per batch
    real = plan_module.fork_runs

    def spy(fn, runs, processes, before=None):
        batches.append((len(runs), processes))
        return real(fn, runs, processes, before)

    monkeypatch.setattr(plan_module, "fork_runs", spy)
    shared = plan(items, machine)
    # 5 parts of 3, 3, 3, 2, 2 moves
    assert batches == ([] if lone == 2 else [(2, 2), (2, 2), (1, 2)])
    t = np.linspace(0.0, alone.duration_s, 1999)
    for a, b in zip(alone.curve.evaluate(t), shared.curve.evaluate(t), strict=True):
        assert np.array_equal(a, b)
    assert shared.duration_s == alone.duration_s
    for name in ("move_start_s", "move_lines", "move_sources", "path_sources", "end_mm"):
        assert np.array_equal(getattr(shared, name), getattr(alone, name))
    assert list(shared.moves) == list(alone.moves)
    assert list(shared.path_moves) == list(alone.path_moves)
    assert list(shared.blends) == list(alone.blends)


def test_events_of_a_part_without_moves_go_to_the_next_part(machine):
    text = "G1 X1 F600\nM201 X500\nG4 P10\nM201 X600\nG1 X2\nM201 X700\nG4 P5\n"
    items = list(interpret_events(text, dialect="marlin"))
    parts = list(split_at_limits(items, machine))
    assert [[i.line for i in part.items] for part in parts] == [[1], [3, 5, 7]]
    accs = [part.machine.limits.max_acceleration_mm_per_s2 for part in parts]
    assert accs[0] == machine.limits.max_acceleration_mm_per_s2
    assert accs[1][0] == 600.0  # the second part's machine: after M201 X600
    only_events = list(interpret_events("M201 X500\nG4 P1\n", dialect="marlin"))
    [part] = split_at_limits(only_events, machine)
    assert [i.line for i in part.items] == [2] and part.machine is machine


def test_a_bad_limit_late_in_a_print_is_refused_before_any_part_is_planned(machine, monkeypatch):
    planned: list[int] = []
    real = plan_module._plan_part

    def spy(items, *args, **kwargs):
        planned.append(len(items))
        return real(items, *args, **kwargs)

    monkeypatch.setattr(plan_module, "_plan_part", spy)
    monkeypatch.setattr(plan_module, "PART_BATCH_MOVES", 2)  # each part planned as it comes
    text = PROGRAM.replace("M201 X1000 Y1000\nG1 X65", "M204 S-100\nG1 X65")
    items = list(interpret_events(text, dialect="marlin"))
    with pytest.raises(GcodeError, match="M204 on this line") as err:
        plan(items, machine)
    assert err.value.line == text.splitlines().index("M204 S-100") + 1
    assert planned == []


def test_a_prints_parts_report_their_progress_batch_by_batch(machine, monkeypatch):
    monkeypatch.setattr(plan_module, "PART_BATCH_MOVES", 5)
    items = list(interpret_events(PROGRAM, dialect="marlin"))
    steps: list[int] = []
    plan(items, machine, advance=steps.append)
    assert sum(steps) == len(items)
    # 5 parts of 3, 3, 3, 2, 2 moves in batches of two, two and one: their items, then
    # the 5 limit events at the end
    parts = [len(part.items) for part in split_at_limits(items, machine)]
    assert steps[:3] == [parts[0] + parts[1], parts[2] + parts[3], parts[4]]
    assert steps[3:] == [len(items) - sum(parts)]


def test_the_stops_at_limit_changes_are_counted_in_the_plan_and_the_run(machine, tmp_path, capsys):
    """Each join of two parts is an exact stop Marlin does not make: `gantry plan` and `gantry
    run` say how many (report.json "limit_change_stops", and the run's summary line)."""
    from gantry_sim.sim.cli import main

    items = list(interpret_events(PROGRAM, dialect="marlin"))
    assert plan(items, machine).limit_change_stops == 4  # 5 parts
    path = tmp_path / "print.gcode"
    path.write_text(PROGRAM)
    assert main(["plan", "--dialect", "marlin", str(path)]) == 0
    planned = json.loads(capsys.readouterr().out)
    assert planned["limit_change_stops"] == 4
    # the limits each part ran under, from its first motion's line (M205 J changes no limit)
    assert [
        (p["from_line"], p["max_acceleration_mm_per_s2"][:2]) for p in planned["program_limits"]
    ] == [(3, [2000, 2000]), (7, [1500, 1500]), (11, [500, 400]), (15, [500, 400]),
          (18, [1000, 1000])]  # fmt: skip
    assert planned["limits"]["max_acceleration_mm_per_s2"] == list(
        machine.limits.max_acceleration_mm_per_s2
    )  # the machine file's, as before
    out = tmp_path / "out"
    assert main(["run", "--dialect", "marlin", "--no-plots", "--out", str(out), str(path)]) == 0
    summary = capsys.readouterr().out.splitlines()[0]
    assert summary.endswith("(with 4 exact stops at limit changes, which Marlin does not make)")
    assert json.loads((out / "report.json").read_text())["limit_change_stops"] == 4
    assert (
        json.loads((out / "report.json").read_text())["program_limits"] == planned["program_limits"]
    )
    plain = tmp_path / "plain.gcode"  # no limit change: no stop, and nothing said
    plain.write_text("G21 G90\nG1 X5 F3000\nG1 X10 Y1\nM2\n")
    assert main(["run", "--dialect", "marlin", "--no-plots", "--out", str(out), str(plain)]) == 0
    assert "limit changes" not in capsys.readouterr().out
    assert json.loads((out / "report.json").read_text())["limit_change_stops"] == 0
    assert json.loads((out / "report.json").read_text())["program_limits"] == []


def _path_acceleration(tr, line: int) -> tuple[np.ndarray, np.ndarray]:
    """The path speed [mm/s] and the acceleration along the path [mm/s^2] of the samples of
    ``line``."""
    sel = tr.line == line
    speed = np.linalg.norm(tr.vel[sel], axis=1)
    along = np.einsum("ij,ij->i", tr.acc[sel], tr.vel[sel]) / np.maximum(speed, 1e-12)
    return speed, along


def test_m204_sets_the_path_acceleration_of_the_moves_after_it_without_a_stop(machine):
    """Marlin's M204 P (or S) is the path acceleration of the blocks it plans next (its
    block->acceleration, limited per axis by M201): no part, no stop, and each straight move's
    acceleration along the path within the P in effect, reached where it binds."""
    text = "G21 G90\nM204 P1000\nG1 X20 F6000\nM204 P300\nG1 X40 Y1\nM204 S1000\nG1 X60 Y0\nM2\n"
    items = list(interpret_events(text, dialect="marlin"))
    planned = plan(items, machine)
    assert planned.limit_change_stops == 0
    tr = planned.sample(machine.servo.period_s / 10)
    for line, cap in ((3, 1000.0), (5, 300.0), (7, 1000.0)):
        speed, along = _path_acceleration(tr, line)
        assert np.abs(along).max() <= cap * (1 + 1e-9), line
        assert np.abs(along).max() >= 0.98 * cap, line  # the cap binds: the moves ramp at it
    speed, _ = _path_acceleration(tr, 5)
    assert speed.min() > 10.0  # no stop at either of its M204 lines
    # the same program in the machine's own limits: faster, its moves' acceleration above 1000
    without = "\n".join(x for x in text.splitlines() if not x.startswith("M204")) + "\n"
    free = plan(list(interpret_events(without, dialect="marlin")), machine)
    assert free.duration_s < planned.duration_s


def test_m204_bounds_a_curves_acceleration_and_p0_caps_nothing(machine):
    def arc(pre: str):
        text = f"G21 G90\nG1 X10 F3000\n{pre}G2 X20 Y0 I5 J0\nG1 X30\nM2\n"
        planned = plan(list(interpret_events(text, dialect="marlin")), machine)
        tr = planned.sample(machine.servo.period_s / 10)
        sel = tr.line == text.splitlines().index("G2 X20 Y0 I5 J0") + 1
        return planned, np.linalg.norm(tr.vel[sel], axis=1), np.abs(tr.acc[sel])

    free, _, free_acc = arc("")
    capped, speed, acc = arc("M204 P200\n")
    assert free_acc.max() > 1000.0  # R 5 at F3000: the centripetal acceleration alone is 500
    assert acc.max() <= 200.0 * (1 + 1e-9)  # every axis within P on the arc
    assert speed.max() <= np.sqrt(200.0 * 5.0)  # v^2 / R within P
    zero, _, zero_acc = arc("M204 P0\n")  # P0 caps nothing
    assert zero.duration_s == free.duration_s
    assert np.array_equal(zero_acc, free_acc)
    assert capped.limit_change_stops == zero.limit_change_stops == 0


def test_m204_t_is_the_travel_acceleration_and_s_sets_both(machine):
    """Marlin plans a move that extrudes with M204 P and a travel (no E movement) with T; S sets
    both, T0 caps nothing, and a travel runs under P until a T (or S) is given."""
    from gantry_sim.controller.planner.limit_events import read_limits

    text = (
        "G21 G90\nM83\nM204 P200\nG1 X20 E1 F6000\nG1 X0\n"  # lines 4, 5: P for both
        "M204 P300 T1000\nG1 X20 E1\nG1 X0\n"  # 7: P, 8: T
        "M204 P500\nG1 X20 E1\nG1 X0\n"  # 10: P, 11: T stays
        "M204 S800\nG1 X20 E1\nG1 X0\n"  # 13, 14: S both
        "M204 T0\nG1 X20 E1\nG1 X0\nM2\n"  # 16: P, 17: no cap
    )
    items = list(interpret_events(text, dialect="marlin"))
    caps = {4: 200, 5: 200, 7: 300, 8: 1000, 10: 500, 11: 1000, 13: 800, 14: 800, 16: 800}
    got = read_limits(items, machine).path_acc_mm_per_s2
    assert got == [*caps.values(), np.inf]
    planned = plan(items, machine)
    tr = planned.sample(machine.servo.period_s / 10)
    for line, cap in caps.items():  # each move from rest to rest (the reversals stop)
        _, along = _path_acceleration(tr, line)
        assert 0.98 * cap <= np.abs(along).max() <= cap * (1 + 1e-9), line
    _, along = _path_acceleration(tr, 17)
    assert np.abs(along).max() > 1000.0  # the machine's own limits
