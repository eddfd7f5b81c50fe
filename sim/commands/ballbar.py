"""``gantry ballbar``: the virtual ballbar (ISO 230-4 circular test), CCW and CW.

stdout: the JSON object when stdout is not a terminal (pipes, files, CI) or with ``--json``; the
human summary when it is a terminal or with ``--summary``. Exit 1 when ``--max-g-um`` fails
(the report and the files are still written).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from typing import TYPE_CHECKING

from gantry_sim.controller.errors import ConfigError, shown
from gantry_sim.sim.commands.common import (
    DEFAULT_OUT,
    add_budget,
    add_machine,
    budget_from,
    load_machine,
    path_arg,
)

if TYPE_CHECKING:
    from gantry_sim.sim.plot_worker import PlotWorker

HELP = (
    "circular test (virtual ballbar, ISO 230-4): run a full circle CCW and CW and report the "
    "circular deviation G, radial deviation F, reversal spikes, centre offset, ellipse and the "
    "diagnostics (servo mismatch, squareness, scaling, backlash, lateral play)"
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
    parser.add_argument(
        "--centre",
        default=None,
        metavar="A,B|X,Y,Z",
        help="circle centre in work coordinates [mm]: the plane's two coordinates in its order "
        "(XY: X,Y; XZ: X,Z; YZ: Y,Z), the normal axis at 0, or all three X,Y,Z (default 0,0,0); "
        "write a negative first value as --centre=-20,10",
    )
    parser.add_argument(
        "--max-g-um",
        type=float,
        default=None,
        metavar="UM",
        help="gate: exit 1 when the circular deviation G of either direction exceeds UM "
        "(the report is still written)",
    )
    add_machine(parser)
    parser.add_argument(
        "--out",
        type=path_arg,
        default=DEFAULT_OUT,
        metavar="DIR",
        help="write ballbar.json, polar.png, ballbar.ngc, trace_cw.npz, trace_ccw.npz here "
        f"(default: ./{DEFAULT_OUT})",
    )
    add_budget(parser)
    shown = parser.add_mutually_exclusive_group()
    shown.add_argument(
        "--json",
        action="store_true",
        help="print the JSON object (the default when stdout is not a terminal)",
    )
    shown.add_argument(
        "--summary",
        action="store_true",
        help="print the human summary (the default when stdout is a terminal)",
    )


def parse_centre(text: str | None, plane: str) -> tuple[float, float, float]:
    """``--centre`` -> (x, y, z) [mm]: two values in the plane's order, or three X,Y,Z."""
    from gantry_sim.controller.planes import PLANE_2D

    if text is None:
        return (0.0, 0.0, 0.0)
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) not in (2, 3) or not all(math.isfinite(v) for v in values):
        raise ConfigError(
            f"{shown(text)} must be two numbers A,B (the {plane} plane's coordinates) or three X,Y,Z",
            file="--centre",
        )
    if len(values) == 3:
        return (values[0], values[1], values[2])
    centre = [0.0, 0.0, 0.0]
    i1, i2 = PLANE_2D[plane]  # the plane's axes in the order it is named
    centre[i1], centre[i2] = values
    return (centre[0], centre[1], centre[2])


def run(args: argparse.Namespace) -> int:
    from gantry_sim.sim.plot_worker import started_plot_worker

    # polar.png's worker, started before this command's imports, which its import overlaps
    plotter = started_plot_worker() if args.out is not None else None
    try:
        return _run(args, plotter)
    finally:
        if plotter is not None:
            plotter.close()


def _run(args: argparse.Namespace, plotter: PlotWorker | None) -> int:
    from gantry_sim.sim.circular.ballbar import run_ballbar, write_ballbar_outputs
    from gantry_sim.sim.circular.summary import format_summary, g_gate
    from gantry_sim.sim.outdir import prepare_output_dir

    if args.max_g_um is not None and not (math.isfinite(args.max_g_um) and args.max_g_um >= 0):
        raise ConfigError(f"{args.max_g_um} must be a finite number >= 0 [um]", file="--max-g-um")
    centre = parse_centre(args.centre, args.plane)
    machine = load_machine(args.machine)
    label = str(args.machine) if args.machine is not None else "bundled (models/gantry.toml)"
    budget = budget_from(args)
    if args.out is not None:
        prepare_output_dir(args.out)  # fails now, not after the simulation
    result = run_ballbar(
        machine,
        args.plane,
        args.radius,
        args.feed,
        centre,
        progress=sys.stderr.isatty(),
        machine_label=label,
        budget=budget,
        plots_elsewhere=plotter is not None,
    )
    status = 0
    if args.max_g_um is not None:
        gate = g_gate(result.summary, args.max_g_um)
        result = dataclasses.replace(result, summary={**result.summary, "gate": gate})
        status = 0 if gate["passed"] else 1
        for reason in gate["reasons"]:
            print(f"gantry ballbar: gate failed: {reason}", file=sys.stderr)
    if args.out is not None:
        write_ballbar_outputs(result, args.out, plotter)
    human = args.summary or (not args.json and sys.stdout.isatty())
    if human:
        sys.stdout.write(format_summary(result.summary))
    else:
        sys.stdout.write(json.dumps(result.summary) + "\n")
    return status
