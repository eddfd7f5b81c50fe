#!/usr/bin/env python3
"""Sweep the feed override of a program and print cycle time against contour error.

    python scripts/feed_sweep.py examples/circle.ngc --feed-override 50,100,150 --out sweep/

One full simulation per feed override, on local processes (or --executor dask). Writes
sweep.csv with --out. Uses the public API: sim.sweep.grid / run_sweep / write_csv_atomic.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.errors import GantryError
from gantry_sim.models import DEFAULT_MACHINE


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("program", type=Path)
    parser.add_argument("--feed-override", default="50,100,150", help="PCT,PCT,...")
    parser.add_argument("--machine", type=Path, default=None, help="machine file (TOML)")
    parser.add_argument("--executor", choices=("local", "dask"), default="local")
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args(argv)

    from gantry_sim.sim.sweep.grid import grid, run_sweep, write_csv_atomic

    try:
        overrides = [float(v) for v in args.feed_override.split(",")]
        machine = load_machine_config(DEFAULT_MACHINE, args.machine)
        rows = run_sweep(
            args.program.read_text(),
            grid(overrides),
            machine,
            file=str(args.program),
            executor=args.executor,
            workers=args.workers,
        )
    except GantryError as exc:
        print(exc, file=sys.stderr)
        return 2
    except (OSError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.out is not None:
        write_csv_atomic(rows, args.out / "sweep.csv")
    print(f"{'override %':>10} {'cycle s':>9} {'max um':>8} {'rms um':>8}  status")
    for r in rows:
        print(
            f"{r['feed_override_pct']:10.0f} {r['cycle_time_s']:9.3f} {r['max_error_um']:8.2f} "
            f"{r['rms_error_um']:8.2f}  {r['status']}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
