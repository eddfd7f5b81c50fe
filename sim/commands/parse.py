"""``gantry parse``: the interpreter's moves as JSON Lines (the contract's keys, mm, mm/min)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from gantry_sim.sim.commands.common import add_dialect, add_work_offset, read_program

HELP = "interpret a G-code program and print its motions as JSON Lines"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("program", type=Path, help="G-code program (.ngc)")
    add_dialect(parser)
    add_work_offset(parser)
    parser.add_argument(
        "--subroutine-path",
        type=Path,
        action="append",
        default=[],
        metavar="DIR",
        help="folder searched for NAME.ngc subroutine files after the program's own (repeatable)",
    )
    parser.add_argument(
        "--tool-table",
        type=Path,
        default=None,
        metavar="FILE",
        help="LinuxCNC tool.tbl (lengths in mm); without it every tool has zero length",
    )
    parser.add_argument(
        "--events",
        action="store_true",
        help='also print G4 dwells ("kind": "dwell", "seconds") and M0/M1/M60 stops '
        '("kind": "stop", "code") as JSON lines, in program order',
    )
    parser.add_argument(
        "--all-errors",
        action="store_true",
        help="interpret the whole program, skipping refused lines, and list every one of them "
        "(FILE:LINE: error: ...) on stderr; exit 2 when there is any",
    )
    parser.add_argument(
        "--max-iterations",
        type=int,
        default=None,
        metavar="N",
        help="bound on O-word loop repetitions and calls (default 1000000)",
    )


def run(args: argparse.Namespace) -> int:
    from gantry_sim.controller.errors import ConfigError, GantryError
    from gantry_sim.controller.gcode.control import DEFAULT_MAX_ITERATIONS
    from gantry_sim.controller.gcode.interpreter import interpret_events

    text = read_program(args.program)
    limit = DEFAULT_MAX_ITERATIONS if args.max_iterations is None else args.max_iterations
    if limit < 1:
        raise ConfigError(f"--max-iterations {limit}: must be 1 or more")
    search = (args.program.resolve().parent, *args.subroutine_path)
    tools = None
    if args.tool_table is not None:
        from gantry_sim.controller.gcode.tools import read_tool_table

        tools = read_tool_table(args.tool_table)
    out = sys.stdout
    errors: list | None = [] if args.all_errors else None
    try:
        for move in interpret_events(
            text,
            dialect=args.dialect,
            file=str(args.program),
            search_path=search,
            max_iterations=limit,
            errors=errors,
            tools=tools,
            work_offset=args.work_offset,
            events=args.events,
        ):
            out.write(json.dumps(move.to_json()) + "\n")
    except GantryError:
        out.flush()
        raise
    out.flush()
    if errors:
        for exc in errors:
            sys.stderr.write(f"{exc}\n")
        sys.stderr.write(f"{args.program}: {len(errors)} refused line(s)\n")
        return 2
    return 0
