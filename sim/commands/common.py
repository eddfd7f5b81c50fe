"""Argument helpers shared by the subcommands: dialect, machine file, program reading."""

from __future__ import annotations

import argparse
from pathlib import Path

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.dialects import DIALECTS

#: the one default output folder of every command that writes files (run, ballbar, tune, sweep);
#: their file names differ, so they can share it
DEFAULT_OUT = Path("out")


def add_dialect(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--dialect", choices=DIALECTS, default="linuxcnc", help="G-code dialect (default: linuxcnc)"
    )


def add_machine(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--machine",
        type=Path,
        default=None,
        metavar="FILE",
        help="machine file (TOML) laid over the bundled models/gantry.toml",
    )


def load_machine(path: Path | None):
    """The bundled machine file with ``path`` laid over it (ConfigError on bad input)."""
    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.models import DEFAULT_MACHINE

    return load_machine_config(DEFAULT_MACHINE, path)


def read_program(path: Path) -> str:
    """Read a G-code program as text; unreadable or non-text files are a GcodeError."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise GcodeError("program file not found", file=str(path)) from None
    except IsADirectoryError:
        raise GcodeError(
            "program path is a directory, expected a G-code file", file=str(path)
        ) from None
    except OSError as exc:
        raise GcodeError(f"cannot read program: {exc.strerror}", file=str(path)) from None
    if b"\x00" in data:
        raise GcodeError("not a G-code text file (it contains NUL bytes)", file=str(path))
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise GcodeError(
            "not a G-code text file (invalid UTF-8); programs are ASCII/UTF-8 text",
            file=str(path),
            line=line,
        ) from None


def work_offset(text: str) -> tuple[float, float, float]:
    """``X,Y,Z`` [mm] for ``--work-offset`` (argparse type: ArgumentTypeError on bad input)."""
    import math

    parts = text.split(",")
    try:
        values = [float(v) for v in parts]
    except ValueError:
        values = []
    if len(values) != 3 or not all(math.isfinite(v) and abs(v) < 1e6 for v in values):
        raise argparse.ArgumentTypeError(
            f"expected X,Y,Z in mm (three finite numbers, |v| < 1e6), got {text!r}"
        )
    return (values[0], values[1], values[2])


def add_work_offset(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--work-offset",
        type=work_offset,
        default=None,
        metavar="X,Y,Z",
        help="place the program: its G54 origin sits at X,Y,Z [mm] of the machine's work frame",
    )


def add_budget(parser: argparse.ArgumentParser, steps: bool = True) -> None:
    """--max-sim-s (and --max-physics-steps): the bounds of sim.budget, raised on request."""
    from gantry_sim.sim.budget import DEFAULT_MAX_PHYSICS_STEPS, DEFAULT_MAX_SIM_S

    parser.add_argument(
        "--max-sim-s",
        type=float,
        default=DEFAULT_MAX_SIM_S,
        metavar="S",
        help=f"refuse a program taking more than S seconds of simulated time (default "
        f"{DEFAULT_MAX_SIM_S:g}; memory grows by about 0.6 MB per simulated second)",
    )
    if steps:
        parser.add_argument(
            "--max-physics-steps",
            type=float,
            default=DEFAULT_MAX_PHYSICS_STEPS,
            metavar="N",
            help=f"refuse a simulation of more than N MuJoCo steps (default "
            f"{DEFAULT_MAX_PHYSICS_STEPS:.3g}, about a minute)",
        )


def budget_from(args: argparse.Namespace):
    """The sim.budget.Budget the options ask for (ConfigError naming the option if invalid)."""
    from gantry_sim.sim.budget import DEFAULT_MAX_PHYSICS_STEPS, Budget

    return Budget(args.max_sim_s, getattr(args, "max_physics_steps", DEFAULT_MAX_PHYSICS_STEPS))
