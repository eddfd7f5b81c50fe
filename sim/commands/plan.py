"""``gantry plan``: interpret and plan a program; print the plan's summary as one JSON object and
optionally write the sampled reference (every servo period) as an npz file."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from typing import Any

from gantry_sim.sim.commands.common import (
    add_budget,
    add_dialect,
    add_machine,
    add_program_setup,
    budget_from,
    max_iterations,
    path_arg,
    program_machine,
    read_program,
    search_path,
)

HELP = "plan a G-code program (segmentation, look-ahead, Ruckig) and print its summary as JSON"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("program", type=path_arg, help="G-code program (.ngc)")
    add_dialect(parser)
    add_machine(parser)
    add_program_setup(parser)
    parser.add_argument(
        "--out",
        type=path_arg,
        default=None,
        metavar="TRAJ.npz",
        help="write the reference sampled every servo period: arrays t, pos, vel, acc, line "
        "and feed_mm_per_min (the programmed feed bounding each sample's path speed, NaN on "
        "rapids) (a new file, or a regular file that is replaced atomically)",
    )
    parser.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="bars with ETA on stderr for parsing and planning a long program; default: only "
        "when stderr is a terminal",
    )
    add_budget(parser, steps=False)


def deviation_summary(blends: Sequence[Any]) -> dict:
    """The G64 blends (or G64 Q merges): how many, the largest deviation from the programmed
    path (the merged-away points) [mm] and its line (null when none); for blends also how many
    are G2 transitions at tangent junctions (``transitions``), how many are stops whose two
    moves' profiles overlap (``overlaps``: controller/planner/stop_overlap.py) and how many are
    pieces of G64 fits of short moves (``fits``: controller/planner/polyline_fit.py)."""
    worst = None
    kinds: dict[str | None, int] = {}
    for b in blends:  # one pass: a long program's blends are read from disk
        if worst is None or b.deviation_mm > worst.deviation_mm:
            worst = b
        kind = getattr(b, "kind", None)
        kinds[kind] = kinds.get(kind, 0) + 1
    out = {
        "count": len(blends),
        "max_deviation_mm": worst.deviation_mm if worst else 0.0,
        "max_deviation_line": worst.line if worst else None,
    }
    if worst is not None and getattr(worst, "file", None) is not None:
        out["max_deviation_file"] = worst.file  # a subroutine file's line
    if set(kinds) != {None}:  # blends (which have kinds), or none at all
        out["transitions"] = kinds.get("transition", 0)
        out["overlaps"] = kinds.get("overlap", 0)
        out["fits"] = kinds.get("fit", 0)
    return out


def run(args: argparse.Namespace) -> int:
    from gantry_sim.controller.errors import GantryError
    from gantry_sim.controller.planner.plan import plan
    from gantry_sim.sim.budget import Budget, check_budget, check_lower_bound
    from gantry_sim.sim.outdir import check_output_file
    from gantry_sim.sim.program import checked_placement, interpret_program
    from gantry_sim.sim.progress import stage, wanted
    from gantry_sim.sim.report import program_limits_json

    budget = budget_from(args)
    machine = program_machine(args)
    text = read_program(args.program)
    file = str(args.program)
    if args.out is not None:
        check_output_file(args.out)  # before planning: a device or folder is refused now
    shown = wanted(args.progress)
    try:
        with stage("parse", text.count("\n") + 1, "line", shown) as advance:
            moves = interpret_program(
                text,
                dialect=args.dialect,
                file=file,
                machine=machine,
                search_path=search_path(args),
                max_iterations=max_iterations(args),
                events=True,
                advance=advance,
            )
        if args.out is not None:  # before planning: far beyond the bound is refused now
            check_lower_bound(moves, machine, Budget(budget.max_sim_s, float("inf"), "plan"), file)
        with stage("plan", len(moves), "move", shown, ticking=True) as advance:
            result = plan(moves, machine, advance=advance)
    except GantryError as exc:
        exc = checked_placement(
            exc,
            text,
            dialect=args.dialect,
            machine=machine,
            search_path=search_path(args),
            max_iterations=max_iterations(args),
        )
        raise exc.located(file) from None
    period = machine.servo.period_s
    if args.out is not None:  # the file's size: the same bound as a simulation's
        from gantry_sim.sim.plan_samples import write_samples_npz

        check_budget(result, machine, Budget(budget.max_sim_s, float("inf"), "plan"), file)
        write_samples_npz(args.out, result, period)
    summary = {
        "duration_s": result.duration_s,
        "moves": len(result.moves),
        "segments": result.segment_count,
        "chord_tolerance_mm": result.chord_tolerance_mm,
        "servo_period_s": period,
        "limits": machine.limits.to_json(),
        "blends": deviation_summary(result.blends),
        "merges": deviation_summary(result.merges),
        "limit_change_stops": result.limit_change_stops,
        "program_limits": program_limits_json(result.part_limits),
    }
    sys.stdout.write(json.dumps(summary) + "\n")
    return 0
