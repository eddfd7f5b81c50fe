"""``gantry sweep``: one full simulation per grid point of feed override x accel x jerk."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from gantry_sim.controller.errors import ConfigError
from gantry_sim.sim.commands.common import (
    add_budget,
    add_dialect,
    add_machine,
    budget_from,
    load_machine,
    read_program,
)

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
    parser.add_argument("program", type=Path, help="G-code program (.ngc)")
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
    parser.add_argument(
        "--out",
        type=Path,
        default=None,
        metavar="DIR",
        help="write sweep.csv and the plots here (a rerun resumes an interrupted sweep)",
    )
    add_budget(parser)


def plot_sweep(rows: list[dict], out_dir: Path) -> None:
    """sweep_error_vs_feed.png and sweep_cycle_vs_error.png."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r["status"] == "ok"]
    combos = sorted(
        {(r["max_accel_mm_per_s2"], r["max_jerk_mm_per_s3"]) for r in ok},
        key=lambda c: (c[0] or 0.0, c[1] or 0.0),
    )

    def label(c) -> str:
        a = "machine file" if c[0] is None else f"{c[0]:g} mm/s^2"
        j = "machine file" if c[1] is None else f"{c[1]:g} mm/s^3"
        return f"accel {a}, jerk {j}"

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for c in combos:
        pts = sorted(
            (r["feed_override_pct"], r["max_error_um"])
            for r in ok
            if (r["max_accel_mm_per_s2"], r["max_jerk_mm_per_s3"]) == c
        )
        ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", ms=4, label=label(c))
    ax.set_xlabel("feed override [%]")
    ax.set_ylabel("max contour error [um]")
    ax.set_title("contour error against feed")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out_dir / "sweep_error_vs_feed.png", dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for c in combos:
        sel = [r for r in ok if (r["max_accel_mm_per_s2"], r["max_jerk_mm_per_s3"]) == c]
        ax.scatter(
            [r["max_error_um"] for r in sel], [r["cycle_time_s"] for r in sel], s=18, label=label(c)
        )
        for r in sel:
            ax.annotate(
                f"{r['feed_override_pct']:g}%",
                (r["max_error_um"], r["cycle_time_s"]),
                textcoords="offset points",
                xytext=(3, 3),
                fontsize=7,
            )
    ax.set_xlabel("max contour error [um]")
    ax.set_ylabel("cycle time [s]")
    ax.set_title("cycle time against contour error (lower left is better)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out_dir / "sweep_cycle_vs_error.png", dpi=110)
    plt.close(fig)


def run(args: argparse.Namespace) -> int:
    from gantry_sim.sim.outdir import atomic_output_dir, prepare_output_dir
    from gantry_sim.sim.sweep.grid import JOURNAL, check_points, grid, run_sweep, write_csv

    if args.workers is not None and not 1 <= args.workers <= 1024:
        raise ConfigError(f"{args.workers}: must be an integer from 1 to 1024", file="--workers")
    budget = budget_from(args)
    text = read_program(args.program)
    machine = load_machine(args.machine)
    points = grid(args.feed_override, args.max_accel, args.max_jerk)
    check_points(machine, points)
    if args.out is not None:
        prepare_output_dir(args.out)  # fails now, not after the simulations
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
    )
    if args.out is not None:  # one commit: the CSV (last), the plots, the journal removed
        with atomic_output_dir(args.out, last="sweep.csv", replaces=(JOURNAL,)) as tmp:
            with open(tmp / "sweep.csv", "w", newline="") as fh:
                write_csv(rows, fh)
            plot_sweep(rows, tmp)
    write_csv(rows, sys.stdout)
    return 0
