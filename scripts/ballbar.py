#!/usr/bin/env python3
"""A virtual ballbar test (ISO 230-4 circular test) on the simulated gantry, as a script.

    python scripts/ballbar.py --plane XY --radius 50 --feed 1000 --out ballbar_out/

Prints the human summary (G, F max/min and reversal spikes per direction, G(b), the
diagnostics: servo mismatch, squareness, scaling mismatch, backlash, lateral play, centre
offset); writes ballbar.json, polar.png, ballbar.ngc and the traces with --out; exits 1 when
--max-g-um fails. Uses the public API: gantry_sim.sim.circular.ballbar.run_ballbar /
write_ballbar_outputs and gantry_sim.sim.circular.summary.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.errors import GantryError
from gantry_sim.models import DEFAULT_MACHINE


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plane", choices=("XY", "XZ", "YZ"), default="XY")
    parser.add_argument("--radius", type=float, default=50.0, help="[mm]")
    parser.add_argument("--feed", type=float, default=1000.0, help="[mm/min]")
    parser.add_argument("--centre", type=float, nargs=3, default=(0.0, 0.0, 0.0), help="X Y Z [mm]")
    parser.add_argument("--max-g-um", type=float, default=None, help="gate on G [um]")
    parser.add_argument("--machine", type=Path, default=None, help="machine file (TOML)")
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args(argv)

    from gantry_sim.sim.circular.ballbar import run_ballbar, write_ballbar_outputs
    from gantry_sim.sim.circular.summary import format_summary, g_gate

    try:
        machine = load_machine_config(DEFAULT_MACHINE, args.machine)
        res = run_ballbar(machine, args.plane, args.radius, args.feed, tuple(args.centre))
    except GantryError as exc:
        print(exc, file=sys.stderr)
        return 2
    status = 0
    if args.max_g_um is not None:
        gate = g_gate(res.summary, args.max_g_um)
        res = dataclasses.replace(res, summary={**res.summary, "gate": gate})
        status = 0 if gate["passed"] else 1
    if args.out is not None:
        write_ballbar_outputs(res, args.out)
    sys.stdout.write(format_summary(res.summary))
    return status


if __name__ == "__main__":
    sys.exit(main())
