#!/usr/bin/env python3
"""Run a G-code program on the simulated gantry and gate on its contour error (for CI).

    python scripts/run_and_gate.py examples/circle.ngc --max-error-um 10 --out out/

Prints the cycle time and the contour error, the worst blocks first; exits 1 when the max
contour error exceeds --max-error-um, 2 on invalid input, 0 otherwise. Uses the public API:
sim.api.run_program / write_run_outputs.
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
    parser.add_argument("--max-error-um", type=float, default=None, help="gate [um]")
    parser.add_argument("--machine", type=Path, default=None, help="machine file (TOML)")
    parser.add_argument("--dialect", default="linuxcnc")
    parser.add_argument("--out", type=Path, default=None, help="write report.json etc. here")
    args = parser.parse_args(argv)

    from gantry_sim.sim.api import run_program, write_run_outputs

    try:
        machine = load_machine_config(DEFAULT_MACHINE, args.machine)
        text = args.program.read_text()
        result = run_program(text, file=str(args.program), dialect=args.dialect, machine=machine)
    except GantryError as exc:
        print(exc, file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"{args.program}: error: {exc.strerror}", file=sys.stderr)
        return 2
    if args.out is not None:
        write_run_outputs(result, args.out)
    rep = result.report
    err = rep["contour_error_um"]
    print(
        f"{args.program}: cycle {rep['cycle_time_s']:.3f} s, contour error max "
        f"{err['max']:.2f} um, rms {err['rms']:.2f} um, p95 {err['p95']:.2f} um"
    )
    worst = sorted(rep["blocks"], key=lambda b: -b["max_error_um"])[:5]
    for b in worst:
        print(f"  line {b['line']:>4} {b['kind']:<6} max {b['max_error_um']:8.2f} um")
    if args.max_error_um is not None and err["max"] > args.max_error_um:
        print(f"FAIL: max contour error {err['max']:.2f} um > {args.max_error_um:g} um")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
