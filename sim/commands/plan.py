"""``gantry plan``: interpret and plan a program; print the plan's summary as one JSON object and
optionally write the sampled reference (every servo period) as an npz file."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from gantry_sim.sim.commands.common import add_dialect, add_machine, load_machine, read_program

HELP = "plan a G-code program (segmentation, look-ahead, Ruckig) and print its summary as JSON"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("program", type=Path, help="G-code program (.ngc)")
    add_dialect(parser)
    add_machine(parser)
    parser.add_argument(
        "--out",
        type=Path,
        default=None,
        metavar="TRAJ.npz",
        help="write the reference sampled every servo period: arrays t, pos, vel, acc, line",
    )


def write_npz_atomically(path: Path, arrays: dict) -> None:
    """Write ``arrays`` to ``path`` atomically (:func:`gantry_sim.sim.outdir.atomic_file`)."""
    import numpy as np

    from gantry_sim.controller.errors import ConfigError
    from gantry_sim.sim.outdir import atomic_file

    if not path.parent.is_dir():
        raise ConfigError("output folder does not exist", file=str(path))
    with atomic_file(path, "wb") as fh:
        np.savez(fh, **arrays)


def blend_summary(blends: tuple) -> dict:
    """The G64 blends: how many, the largest deviation from the programmed corner [mm] and its
    line (null when none)."""
    worst = max(blends, key=lambda b: b.deviation_mm, default=None)
    return {
        "count": len(blends),
        "max_deviation_mm": worst.deviation_mm if worst else 0.0,
        "max_deviation_line": worst.line if worst else None,
    }


def run(args: argparse.Namespace) -> int:
    from gantry_sim.controller.errors import GantryError
    from gantry_sim.controller.gcode.interpreter import interpret_events
    from gantry_sim.controller.planner.plan import plan

    machine = load_machine(args.machine)
    text = read_program(args.program)
    file = str(args.program)
    try:
        moves = list(interpret_events(text, dialect=args.dialect, file=file))
        result = plan(moves, machine)
    except GantryError as exc:
        raise exc.located(file) from None
    period = machine.servo.period_s
    if args.out is not None:
        write_npz_atomically(args.out, result.sample(period).to_npz_dict())
    summary = {
        "duration_s": result.duration_s,
        "moves": len(result.moves),
        "segments": result.segment_count,
        "chord_tolerance_mm": result.chord_tolerance_mm,
        "servo_period_s": period,
        "limits": machine.limits.to_json(),
        "blends": blend_summary(result.blends),
    }
    sys.stdout.write(json.dumps(summary) + "\n")
    return 0
