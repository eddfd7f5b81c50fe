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
from gantry_sim.controller.moves import Limits
from gantry_sim.controller.planner import segmented_curve
from gantry_sim.controller.planner.limit_events import JoinedPlans, split_at_limits
from gantry_sim.controller.planner.plan import plan
from gantry_sim.controller.planner.segmented_curve import SegmentedCurve

plan_module = importlib.import_module("gantry_sim.controller.planner.plan")

#: a small print's pattern: perimeters at two accelerations (PrusaSlicer's M204 P800 / P1000
#: around its external perimeters), a travel, an M201 and an M205 J between them
PROGRAM = (
    "G21 G90\nM204 P1000\nG1 X5 Y0 F3000\nG1 X10 Y1\nG1 X15 Y3\n"
    "M204 P800\nG1 X20 Y6 F1800\nG1 X25 Y8\nG1 X30 Y9\n"
    "M201 X500 Y400\nG0 X40 Y10\nG1 X45 Y11 F1200\nG1 X50 Y13\n"
    "M205 J0.02\nG1 X55 Y16\nG1 X60 Y18\nM204 P1000\nG1 X65 Y19\nG1 X70 Y19.5\nM2\n"
)


def _parts(machine):
    items = list(interpret_events(PROGRAM, dialect="marlin"))
    return items, [
        plan([i for i in chunk if not isinstance(i, Limits)], m)
        for chunk, m in split_at_limits(items, machine)
    ]


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
        joined.add(replace(parts[0], curve=parts[0].curve.laid_out()))


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
    text = "G1 X1 F600\nM204 P500\nG4 P10\nM204 P600\nG1 X2\nM204 P700\nG4 P5\n"
    items = list(interpret_events(text, dialect="marlin"))
    parts = list(split_at_limits(items, machine))
    assert [[i.line for i in chunk] for chunk, _ in parts] == [[1], [3, 5, 7]]
    accs = [m.limits.max_acceleration_mm_per_s2 for _, m in parts]
    assert accs[0] == machine.limits.max_acceleration_mm_per_s2
    assert accs[1] == (600.0, 600.0, 600.0)  # the second part's machine: after M204 P600
    only_events = list(interpret_events("M204 P500\nG4 P1\n", dialect="marlin"))
    [(chunk, m)] = split_at_limits(only_events, machine)
    assert [i.line for i in chunk] == [2] and m is machine


def test_a_bad_limit_late_in_a_print_is_refused_before_any_part_is_planned(machine, monkeypatch):
    planned: list[int] = []
    real = plan_module._plan_part

    def spy(items, *args, **kwargs):
        planned.append(len(items))
        return real(items, *args, **kwargs)

    monkeypatch.setattr(plan_module, "_plan_part", spy)
    monkeypatch.setattr(plan_module, "PART_BATCH_MOVES", 2)  # each part planned as it comes
    text = PROGRAM.replace("M204 P1000\nG1 X65", "M204 S-100\nG1 X65")
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
    parts = [len(chunk) for chunk, _ in split_at_limits(items, machine)]
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
    assert json.loads(capsys.readouterr().out)["limit_change_stops"] == 4
    out = tmp_path / "out"
    assert main(["run", "--dialect", "marlin", "--no-plots", "--out", str(out), str(path)]) == 0
    summary = capsys.readouterr().out.splitlines()[0]
    assert summary.endswith("(with 4 exact stops at limit changes, which Marlin does not make)")
    assert json.loads((out / "report.json").read_text())["limit_change_stops"] == 4
    plain = tmp_path / "plain.gcode"  # no limit change: no stop, and nothing said
    plain.write_text("G21 G90\nG1 X5 F3000\nG1 X10 Y1\nM2\n")
    assert main(["run", "--dialect", "marlin", "--no-plots", "--out", str(out), str(plain)]) == 0
    assert "limit changes" not in capsys.readouterr().out
    assert json.loads((out / "report.json").read_text())["limit_change_stops"] == 0
