"""Argument helpers shared by the subcommands: dialect, machine file, program reading, and the
options that set up a program on the machine (placement, tools, subroutine files, loop bound)."""

from __future__ import annotations

import argparse
from pathlib import Path

from gantry_sim.controller.errors import shown
from gantry_sim.controller.gcode.dialects import DIALECTS
from gantry_sim.sim.program import read_program as read_program  # the commands read through it

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
        type=path_arg,
        default=None,
        metavar="FILE",
        help="machine file (TOML) laid over the bundled models/gantry.toml",
    )


def load_machine(path: Path | None):
    """The bundled machine file with ``path`` laid over it (ConfigError on bad input)."""
    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.models import DEFAULT_MACHINE

    return load_machine_config(DEFAULT_MACHINE, path)


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
            f"expected X,Y,Z in mm (three finite numbers, |v| < 1e6), got {shown(text)}"
        )
    return (values[0], values[1], values[2])


def add_work_offset(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--work-offset",
        type=work_offset,
        default=None,
        metavar="X,Y,Z",
        help="place the program: its G54 origin sits at X,Y,Z [mm] of the machine's work frame "
        "(overrides the machine file's [work] g54_mm)",
    )


def add_budget(parser: argparse.ArgumentParser, steps: bool = True) -> None:
    """--max-sim-s (and --max-physics-steps): the bounds of sim.budget, raised on request."""
    from gantry_sim.sim.budget import DEFAULT_MAX_PHYSICS_STEPS, DEFAULT_MAX_SIM_S

    cost = (
        "a run takes about 1 s, and its trace.npz 2-5 MB, per 2 simulated minutes"
        if steps
        else "--out writes 20-40 kB per simulated second"
    )
    parser.add_argument(
        "--max-sim-s",
        type=float,
        default=DEFAULT_MAX_SIM_S,
        metavar="S",
        help=f"refuse a program taking more than S seconds of simulated time (default "
        f"{DEFAULT_MAX_SIM_S:g}; {cost})",
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


def path_arg(text: str) -> Path:
    """A file or folder path (argparse type); an empty one is refused, not taken for the
    current folder (``--out "$OUT"`` with OUT unset wrote a run's files among the user's)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a path, got an empty one")
    return Path(text)


def folder_arg(text: str) -> Path:
    """An existing folder (argparse type): a file or a missing path is refused (a folder
    searched for subroutine files that is not one was passed over without a word)."""
    path = path_arg(text)
    if not path.is_dir():
        what = "a file" if path.exists() else "not found"
        raise argparse.ArgumentTypeError(f"{shown(text)}: expected a folder, {what}")
    return path


def positive_int(text: str) -> int:
    """An integer >= 1 (argparse type)."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {shown(text)}")
    return value


def add_program_setup(parser: argparse.ArgumentParser) -> None:
    """--work-offset, --tool-table, --subroutine-path, --max-iterations (parse, plan, run, sweep)."""
    add_work_offset(parser)
    parser.add_argument(
        "--tool-table",
        type=path_arg,
        default=None,
        metavar="FILE",
        help="LinuxCNC tool.tbl, lengths in mm (replaces the machine file's [tools]); without "
        "either every tool has zero length",
    )
    parser.add_argument(
        "--subroutine-path",
        type=folder_arg,
        action="append",
        default=[],
        metavar="DIR",
        help="folder searched for NAME.ngc subroutine files after the program's own (repeatable)",
    )
    parser.add_argument(
        "--max-iterations",
        type=positive_int,
        default=None,
        metavar="N",
        help="bound on O-word loop repetitions and calls (default 1000000); a tenth of it "
        "bounds the lines run in loops and subroutines without a move",
    )


def search_path(args: argparse.Namespace) -> tuple[Path, ...]:
    """Folders searched for subroutine files: the program's own, then --subroutine-path."""
    return (args.program.resolve().parent, *args.subroutine_path)


def max_iterations(args: argparse.Namespace) -> int:
    from gantry_sim.controller.gcode.control import DEFAULT_MAX_ITERATIONS

    return DEFAULT_MAX_ITERATIONS if args.max_iterations is None else args.max_iterations


def program_machine(args: argparse.Namespace):
    """The machine (--machine) set up for this program: --work-offset and --tool-table laid
    over its [work] and [tools], and the dialect's arc segmentation unless the file sets one."""
    from dataclasses import replace

    from gantry_sim.controller.gcode.dialects import with_segmentation_default

    machine = load_machine(args.machine)
    work = machine.work
    if args.work_offset is not None:
        work = work.placed(args.work_offset)
    if args.tool_table is not None:
        from gantry_sim.controller.gcode.tools import read_tool_table

        work = work.with_tools(read_tool_table(args.tool_table))
    return with_segmentation_default(replace(machine, work=work), args.dialect)
