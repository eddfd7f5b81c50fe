"""``gantry sweep``: one full simulation per grid point of feed override x accel x jerk.

Exit status: 0 at least one grid point ran; 1 every point faulted (e.g. a following-error fault
at every setting; sweep.csv and the plots are still written); 2 invalid input; 130 Ctrl-C (the
finished points stay in the journal: the same command resumes from them).
"""

from __future__ import annotations

import argparse
import shlex
import signal
import sys

from gantry_sim.controller.errors import ConfigError
from gantry_sim.sim.commands.common import (
    DEFAULT_OUT,
    add_budget,
    add_dialect,
    add_machine,
    add_program_setup,
    budget_from,
    max_iterations,
    path_arg,
    program_machine,
    read_program,
    search_path,
)

#: the files ``gantry sweep --out`` writes (sim.outdir.atomic_output_dir; the plots:
#: sim.search_plots.save_sweep_plots)
SWEEP_FILES = ("sweep.csv", "sweep_error_vs_feed.png", "sweep_cycle_vs_error.png")
HELP = (
    "simulate a program over a grid of feed overrides, max accelerations and max jerks "
    "(on local processes or a Dask cluster) and tabulate cycle time against contour error"
)


def _floats(option: str, unit: str):
    def parse(text: str) -> list[float]:
        try:
            values = [float(v) for v in text.split(",") if v.strip()]
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"'{text}' is not a comma-separated list of numbers [{unit}]"
            ) from None
        if not values or any(not (v > 0) or v == float("inf") for v in values):
            raise argparse.ArgumentTypeError(f"'{text}': each value must be a number > 0 [{unit}]")
        return values

    parse.__name__ = option
    return parse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("program", type=path_arg, help="G-code program (.ngc)")
    parser.add_argument(
        "--feed-override",
        type=_floats("--feed-override", "%"),
        default=[100.0],
        metavar="PCT,...",
        help="feed overrides [%%] (default 100)",
    )
    parser.add_argument(
        "--max-accel",
        type=_floats("--max-accel", "mm/s^2"),
        default=None,
        metavar="MM_PER_S2,...",
        help="max acceleration of all axes [mm/s^2] (default: the machine file's per-axis values)",
    )
    parser.add_argument(
        "--max-jerk",
        type=_floats("--max-jerk", "mm/s^3"),
        default=None,
        metavar="MM_PER_S3,...",
        help="max jerk of all axes [mm/s^3] (default: the machine file's per-axis values)",
    )
    parser.add_argument(
        "--executor",
        choices=("local", "dask"),
        default="local",
        help="local: processes on this machine (default); dask: a Dask distributed cluster "
        "(a LocalCluster, or the scheduler in --scheduler / DASK_SCHEDULER_ADDRESS)",
    )
    parser.add_argument(
        "--workers", type=int, default=None, help="worker processes (default: all cores)"
    )
    parser.add_argument(
        "--scheduler", default=None, metavar="ADDRESS", help="Dask scheduler, e.g. tcp://host:8786"
    )
    add_dialect(parser)
    add_machine(parser)
    add_program_setup(parser)
    parser.add_argument(
        "--out",
        type=path_arg,
        default=DEFAULT_OUT,
        metavar="DIR",
        help=f"write sweep.csv and the plots here (default: ./{DEFAULT_OUT}; a rerun resumes "
        "an interrupted sweep)",
    )
    add_budget(parser)


def run(args: argparse.Namespace) -> int:
    from gantry_sim.sim.outdir import atomic_output_dir, prepare_output_dir
    from gantry_sim.sim.search_plots import save_sweep_plots
    from gantry_sim.sim.sweep.grid import (
        JOURNAL,
        SweepInterrupted,
        check_points,
        grid,
        run_sweep,
        write_csv,
    )

    if args.workers is not None and not 1 <= args.workers <= 1024:
        raise ConfigError(f"{args.workers}: must be an integer from 1 to 1024", file="--workers")
    budget = budget_from(args)
    text = read_program(args.program)
    machine = program_machine(args)
    points = grid(args.feed_override, args.max_accel, args.max_jerk)
    check_points(machine, points)
    if args.out is not None:
        prepare_output_dir(args.out)  # fails now, not after the simulations
    try:
        rows = run_sweep(
            text,
            points,
            machine,
            file=str(args.program),
            dialect=args.dialect,
            executor=args.executor,
            workers=args.workers,
            scheduler=args.scheduler,
            out_dir=args.out,
            progress=sys.stderr.isatty(),
            budget=budget,
            search_path=search_path(args),
            max_iterations=max_iterations(args),
        )
    except SweepInterrupted as stop:
        print(_where_it_stopped(stop), file=sys.stderr)
        return 128 + signal.SIGINT
    if args.out is not None:  # one commit: the CSV (last), the plots, the journal removed
        with atomic_output_dir(
            args.out, last="sweep.csv", owns=SWEEP_FILES, replaces=(JOURNAL,)
        ) as tmp:
            with open(tmp / "sweep.csv", "w", newline="") as fh:
                write_csv(rows, fh)
            save_sweep_plots(rows, tmp)
    write_csv(rows, sys.stdout)
    if rows and not any(r["status"] == "ok" for r in rows):  # nothing to choose from: a failure
        print(
            f"FAIL: all {len(rows)} grid point(s) faulted (see the status column)", file=sys.stderr
        )
        return 1
    return 0


def _where_it_stopped(stop) -> str:
    """The Ctrl-C message: how far the sweep got and how to go on."""
    head = f"gantry: interrupted: {stop.done} of {stop.total} grid point(s) done"
    if stop.journal is None or not stop.done:
        return head + " (nothing kept)" if stop.journal is None else head
    again = shlex.join(["gantry", *sys.argv[1:]]) if sys.argv[1:2] == ["sweep"] else ""
    how = f": {again}" if again else " (same program, grid, machine and --out)"
    return f"{head}, kept in {stop.journal}; rerun the same sweep to resume{how}"
