"""``gantry parse``: the interpreter's moves as JSON Lines (the contract's keys, mm, mm/min)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from gantry_sim.sim.commands.common import add_dialect, read_program

HELP = "interpret a G-code program and print its motions as JSON Lines"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("program", type=Path, help="G-code program (.ngc)")
    add_dialect(parser)


def run(args: argparse.Namespace) -> int:
    from gantry_sim.controller.errors import GantryError
    from gantry_sim.controller.gcode.interpreter import interpret

    text = read_program(args.program)
    out = sys.stdout
    try:
        for move in interpret(text, dialect=args.dialect, file=str(args.program)):
            out.write(json.dumps(move.to_json()) + "\n")
    except GantryError:
        out.flush()
        raise
    out.flush()
    return 0
