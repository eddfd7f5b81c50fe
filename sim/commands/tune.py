"""``gantry tune``: per radius, the highest feed whose full circle stays within a tolerance.

Exit status: 0 every radius has a passing feed; 1 some radius is unreachable (even the minimum
feed exceeds the tolerance; tune.json and tune.png are still written); 2 invalid input.
"""

from __future__ import annotations

import argparse
import json
import sys

from gantry_sim.controller.errors import ConfigError
from gantry_sim.sim.commands.common import (
    DEFAULT_OUT,
    add_budget,
    add_machine,
    budget_from,
    load_machine,
    path_arg,
)

#: the files ``gantry tune --out`` writes (sim.outdir.atomic_output_dir)
TUNE_FILES = ("tune.json", "tune.png")
HELP = (
    "find, per circle radius, the highest feed [mm/min] whose full circle keeps the max "
    "contour error within a tolerance (bisection on simulations)"
)
DEFAULT_RADII = "5,10,25,50"
DEFAULT_TOLERANCE_UM = 10.0


def _radii(text: str) -> list[float]:
    try:
        radii = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ConfigError(
            f"'{text}' is not a comma-separated list of radii in mm, e.g. 5,10,25", file="--radii"
        ) from None
    return radii


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--plane",
        choices=("XY", "XZ", "YZ"),
        default="XY",
        help="plane of the circles (default XY)",
    )
    parser.add_argument(
        "--radii",
        default=DEFAULT_RADII,
        metavar="MM,MM,...",
        help=f"circle radii [mm] (default {DEFAULT_RADII})",
    )
    parser.add_argument(
        "--tolerance-um",
        type=float,
        default=DEFAULT_TOLERANCE_UM,
        metavar="X",
        help=f"max contour error allowed on the circle [um] (default {DEFAULT_TOLERANCE_UM:g})",
    )
    parser.add_argument(
        "--feed-resolution",
        type=float,
        default=None,
        metavar="MM_PER_MIN",
        help="stop bisecting when the feed bracket is this narrow [mm/min] (default 20)",
    )
    add_machine(parser)
    parser.add_argument(
        "--out",
        type=path_arg,
        default=DEFAULT_OUT,
        metavar="DIR",
        help=f"write tune.json and tune.png here (default: ./{DEFAULT_OUT})",
    )
    add_budget(parser)


def run(args: argparse.Namespace) -> int:
    from gantry_sim.sim.circular.tune import DEFAULT_RESOLUTION_MM_PER_MIN, tune
    from gantry_sim.sim.outdir import atomic_output_dir, prepare_output_dir
    from gantry_sim.sim.search_plots import save_tune_plot

    machine = load_machine(args.machine)
    budget = budget_from(args)
    resolution = (
        DEFAULT_RESOLUTION_MM_PER_MIN if args.feed_resolution is None else args.feed_resolution
    )
    if args.out is not None:
        prepare_output_dir(args.out)  # fails now, not after the simulations

    def progress(msg: str) -> None:
        print(f"tune: {msg}", file=sys.stderr, flush=True)

    rows = tune(
        machine, _radii(args.radii), args.tolerance_um, args.plane, resolution, progress, budget
    )
    summary = {
        "tolerance_um": args.tolerance_um,
        "plane": args.plane,
        "feed_resolution_mm_per_min": resolution,
        "rows": [r.to_json() for r in rows],
    }
    if args.out is not None:
        with atomic_output_dir(args.out, last="tune.json", owns=TUNE_FILES) as tmp:
            (tmp / "tune.json").write_text(json.dumps(summary, indent=2) + "\n")
            save_tune_plot(tmp / "tune.png", rows, args.tolerance_um, args.plane)
    sys.stdout.write(json.dumps(summary) + "\n")
    unreachable = [r.radius_mm for r in rows if r.max_feed_mm_per_min is None]
    if unreachable:  # no feed down to the minimum passes: that radius has no answer
        radii = ", ".join(f"{r:g}" for r in unreachable)
        print(
            f"FAIL: no feed passes {args.tolerance_um:g} um for radius {radii} mm (unreachable)",
            file=sys.stderr,
        )
        return 1
    return 0
