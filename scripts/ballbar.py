#!/usr/bin/env python3
"""A virtual ballbar test (ISO 230-4 circular test) on the simulated gantry, as a script.

    python scripts/ballbar.py --plane XY --radius 50 --feed 1000 --out ballbar_out/

Prints the figures per direction (G, F max/min, reversal spikes, centre offset), the
bidirectional deviation and the ellipse; writes ballbar.json, polar.png, ballbar.ngc and the
traces with --out. Uses the public API: gantry_sim.sim.circular.ballbar.run_ballbar / write_ballbar_outputs.
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
    parser.add_argument("--plane", choices=("XY", "XZ", "YZ"), default="XY")
    parser.add_argument("--radius", type=float, default=50.0, help="[mm]")
    parser.add_argument("--feed", type=float, default=1000.0, help="[mm/min]")
    parser.add_argument("--machine", type=Path, default=None, help="machine file (TOML)")
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args(argv)

    from gantry_sim.sim.circular.ballbar import run_ballbar, write_ballbar_outputs

    try:
        machine = load_machine_config(DEFAULT_MACHINE, args.machine)
        res = run_ballbar(machine, args.plane, args.radius, args.feed)
    except GantryError as exc:
        print(exc, file=sys.stderr)
        return 2
    if args.out is not None:
        write_ballbar_outputs(res, args.out)
    s = res.summary
    print(f"ballbar {s['plane']}  R {s['radius_mm']:g} mm  F {s['feed_mm_per_min']:g} mm/min")
    print(
        f"{'':4} {'G um':>7} {'F max':>7} {'F min':>7}  {'spikes um (0/90/180/270 deg)':<30}"
        f" {'centre um':>16}"
    )
    for d in ("ccw", "cw"):
        r = s[d]
        spikes = " ".join(f"{v:6.2f}" for v in r["reversal_spikes_um"])
        a, b = r["centre_offset_um"]
        print(
            f"{d.upper():4} {r['circular_deviation_um']:7.2f} "
            f"{r['radial_deviation_um']['max']:7.2f} {r['radial_deviation_um']['min']:7.2f}  "
            f"{spikes:<30} {a:7.2f} {b:7.2f}"
        )
    e = s["ellipse"]
    print(
        f"bidirectional deviation G(b) {s['bidirectional_deviation_um']:.2f} um; ellipse "
        f"{e['magnitude_um']:.2f} um at {e['axis_deg']:.1f} deg (CCW), "
        f"flips with direction: {e['flips_with_direction']}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
