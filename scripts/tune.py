#!/usr/bin/env python3
"""Find, per circle radius, the highest feed that keeps a full circle within a tolerance.

    python scripts/tune.py --radii 5,10,25,50 --tolerance-um 10

Bisection on simulations of the tune program (gantry_sim.sim.circular.tune); prints one row per radius and what
limited it. Uses the public API: gantry_sim.sim.circular.tune.tune.
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
    parser.add_argument("--radii", default="5,10,25,50", help="MM,MM,...")
    parser.add_argument("--tolerance-um", type=float, default=10.0)
    parser.add_argument("--plane", choices=("XY", "XZ", "YZ"), default="XY")
    parser.add_argument("--machine", type=Path, default=None, help="machine file (TOML)")
    args = parser.parse_args(argv)

    from gantry_sim.sim.circular.tune import tune

    try:
        radii = [float(v) for v in args.radii.split(",")]
        machine = load_machine_config(DEFAULT_MACHINE, args.machine)
        rows = tune(machine, radii, args.tolerance_um, args.plane)
    except GantryError as exc:
        print(exc, file=sys.stderr)
        return 2
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"tolerance {args.tolerance_um:g} um, plane {args.plane}")
    print(f"{'radius mm':>9} {'max feed mm/min':>16} {'runs at':>8} {'error um':>9}  limited by")
    for r in rows:
        feed = "-" if r.max_feed_mm_per_min is None else f"{r.max_feed_mm_per_min:.0f}"
        print(
            f"{r.radius_mm:9g} {feed:>16} {r.circle_feed_mm_per_min:8.0f} "
            f"{r.max_error_um:9.2f}  {r.limited_by}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
