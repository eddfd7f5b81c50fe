"""``gantry tune``: per radius, the highest feed whose full circle stays within a tolerance."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from gantry_sim.controller.errors import ConfigError
from gantry_sim.sim.commands.common import add_budget, add_machine, budget_from, load_machine

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
        "--out", type=Path, default=None, metavar="DIR", help="write tune.json and tune.png here"
    )
    add_budget(parser)


def plot_tune(summary: dict, rows: list, path: Path) -> None:
    """tune.png: max feed against radius (left); each simulated (feed, error) per radius (right)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
    ok = [r for r in rows if r.max_feed_mm_per_min is not None]
    ax1.plot([r.radius_mm for r in ok], [r.max_feed_mm_per_min for r in ok], "o-")
    for r in ok:
        ax1.annotate(
            f"{r.max_feed_mm_per_min:.0f}",
            (r.radius_mm, r.max_feed_mm_per_min),
            textcoords="offset points",
            xytext=(4, 4),
            fontsize=8,
        )
    ax1.set_xlabel("circle radius [mm]")
    ax1.set_ylabel("max feed [mm/min]")
    ax1.set_title(f"highest feed within {summary['tolerance_um']:g} um ({summary['plane']})")
    ax1.grid(alpha=0.3)
    for r in rows:
        pts = sorted(r.tried)
        ax2.plot(
            [p[0] for p in pts], [p[1] for p in pts], "o-", ms=3, label=f"R {r.radius_mm:g} mm"
        )
    ax2.axhline(summary["tolerance_um"], color="k", ls="--", lw=0.8, label="tolerance")
    ax2.set_xlabel("programmed feed [mm/min]")
    ax2.set_ylabel("circle max contour error [um]")
    ax2.set_title("every simulation of the search")
    ax2.grid(alpha=0.3)
    ax2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(args: argparse.Namespace) -> int:
    from gantry_sim.sim.circular.tune import DEFAULT_RESOLUTION_MM_PER_MIN, tune
    from gantry_sim.sim.outdir import atomic_output_dir, prepare_output_dir

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
        with atomic_output_dir(args.out, last="tune.json") as tmp:
            (tmp / "tune.json").write_text(json.dumps(summary, indent=2) + "\n")
            plot_tune(summary, rows, tmp / "tune.png")
    sys.stdout.write(json.dumps(summary) + "\n")
    return 0
