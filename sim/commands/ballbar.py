"""``gantry ballbar``: the virtual ballbar (ISO 230-4 circular test), CCW and CW."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from gantry_sim.sim.commands.common import add_budget, add_machine, budget_from, load_machine

HELP = (
    "circular test (virtual ballbar, ISO 230-4): run a full circle CCW and CW and report the "
    "circular deviation G, radial deviation F, reversal spikes, centre offset and ellipse"
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--plane", choices=("XY", "XZ", "YZ"), default="XY", help="plane of the circle (default XY)"
    )
    parser.add_argument(
        "--radius", type=float, default=50.0, metavar="MM", help="radius [mm] (default 50)"
    )
    parser.add_argument(
        "--feed",
        type=float,
        default=1000.0,
        metavar="MM_PER_MIN",
        help="feed along the circle [mm/min] (default 1000)",
    )
    add_machine(parser)
    parser.add_argument(
        "--out",
        type=Path,
        default=None,
        metavar="DIR",
        help="write ballbar.json, polar.png, ballbar.ngc, trace_cw.npz, trace_ccw.npz here",
    )
    add_budget(parser)


def run(args: argparse.Namespace) -> int:
    from gantry_sim.sim.circular.ballbar import run_ballbar, write_ballbar_outputs
    from gantry_sim.sim.outdir import prepare_output_dir

    machine = load_machine(args.machine)
    budget = budget_from(args)
    if args.out is not None:
        prepare_output_dir(args.out)  # fails now, not after the simulation
    result = run_ballbar(
        machine, args.plane, args.radius, args.feed, progress=sys.stderr.isatty(), budget=budget
    )
    if args.out is not None:
        write_ballbar_outputs(result, args.out)
    sys.stdout.write(json.dumps(result.summary) + "\n")
    return 0
