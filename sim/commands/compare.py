"""``gantry compare BASELINE RUN``: a run's report.json against a baseline's, block by block.

Exit status: 0 nothing grew beyond the margins; 1 a block's max contour error or time, or the
cycle time, grew by more than its margin (the table says which); 2 a report is missing or
unreadable.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import asdict

from gantry_sim.controller.errors import ConfigError
from gantry_sim.sim.commands.common import path_arg

HELP = (
    "compare a run's report.json with a baseline's block by block; exit 1 when a block's "
    "contour error or time, or the cycle time, grew by more than the margins"
)


#: the margins' defaults, as sim.compare's (not imported here: `gantry` starts without it; a
#: test checks they agree)
MARGINS = (
    ("--error-margin-um", 0.1, "UM", "absolute growth of a block's max error"),
    ("--error-margin-pct", 5.0, "PCT", "growth relative to the baseline's"),
    ("--time-margin-s", 0.001, "S", "absolute growth of a block's or the cycle time"),
    ("--time-margin-pct", 1.0, "PCT", "time growth relative to the baseline's"),
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("baseline", type=path_arg, help="baseline report.json or its folder")
    parser.add_argument("run", type=path_arg, help="the run's report.json or its folder")
    for option, default, metavar, what in MARGINS:
        parser.add_argument(
            option,
            type=float,
            default=default,
            metavar=metavar,
            help=f"{what}; a block fails beyond the larger of the two (default {default:g})",
        )
    parser.add_argument(
        "--json", action="store_true", help="print the comparison as one JSON object"
    )


def run(args: argparse.Namespace) -> int:
    from gantry_sim.sim.compare import Margins, compare, format_table, load_report

    for option in ("error_margin_um", "error_margin_pct", "time_margin_s", "time_margin_pct"):
        value = getattr(args, option)
        if not (math.isfinite(value) and value >= 0):
            raise ConfigError(
                f"{value}: must be a number >= 0", file="--" + option.replace("_", "-")
            )
    margins = Margins(
        args.error_margin_um, args.error_margin_pct, args.time_margin_s, args.time_margin_pct
    )
    base, new = load_report(args.baseline), load_report(args.run)
    cmp = compare(base, new, margins)
    if args.json:
        rows = [asdict(r) for r in cmp.rows if r.status != "ok"]
        obj = {"passed": cmp.passed, "failures": list(cmp.failures), "changed": rows}
        sys.stdout.write(json.dumps(obj) + "\n")
    else:
        print(f"{args.run} against {args.baseline}")
        for key in ("program", "dialect", "machine", "feed_override_pct"):
            if base.get(key) != new.get(key):  # blocks are matched by line: say what differs
                print(f"note: {key} differs: {base.get(key)} -> {new.get(key)}")
        print(format_table(cmp, margins))
    return 0 if cmp.passed else 1
