"""``gantry parse``: the interpreter's moves as JSON Lines (the contract's keys, mm, mm/min)."""

from __future__ import annotations

import argparse
import json
import sys

from gantry_sim.sim.commands.common import (
    add_dialect,
    add_machine,
    add_program_setup,
    max_iterations,
    path_arg,
    program_machine,
    read_program,
    search_path,
)

HELP = "interpret a G-code program and print its motions as JSON Lines"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("program", type=path_arg, help="G-code program (.ngc)")
    add_dialect(parser)
    add_machine(parser)
    add_program_setup(parser)
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


def run(args: argparse.Namespace) -> int:
    from gantry_sim.controller.errors import GantryError
    from gantry_sim.controller.gcode.interpreter import interpret_events

    machine = program_machine(args)
    text = read_program(args.program)
    out = sys.stdout
    errors: list | None = [] if args.all_errors else None
    try:
        for move in interpret_events(
            text,
            dialect=args.dialect,
            file=str(args.program),
            search_path=search_path(args),
            max_iterations=max_iterations(args),
            errors=errors,
            tools=machine.work.tool_table(),
            events=args.events,
            parameters=machine.work.parameters(),
        ):
            out.write(json.dumps(move.to_json(), allow_nan=False) + "\n")  # JSON only
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
