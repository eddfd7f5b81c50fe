"""``gantry run``: plan, simulate in MuJoCo, analyse; write report.json, trace.npz and plots.

Exit status: 0 done; 1 ``--max-error-um X`` was set and the max contour error exceeds X (the
outputs are still written); 2 invalid program, machine file or option, or a diverged simulation
(no report is written, and stale outputs of an earlier run in DIR are removed first).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from gantry_sim.sim.commands.common import (
    add_budget,
    add_dialect,
    add_machine,
    budget_from,
    load_machine,
    read_program,
)

HELP = "plan, simulate and analyse a program; write report.json, trace.npz and plots"
DEFAULT_OUT = Path("out")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("program", type=Path, help="G-code program (.ngc)")
    add_dialect(parser)
    add_machine(parser)
    parser.add_argument(
        "--out",
        type=Path,
        default=DEFAULT_OUT,
        metavar="DIR",
        help=f"output folder (default: ./{DEFAULT_OUT}); created if needed",
    )
    parser.add_argument(
        "--max-error-um",
        type=float,
        default=None,
        metavar="X",
        help="exit 1 when the max contour error exceeds X micrometres (report still written)",
    )
    add_budget(parser)


def _summary(report: dict, out_dir: Path) -> str:
    ce, parts, sim = report["contour_error_um"], report["parts_um"], report["sim"]
    lines = [
        f"{report['program']} ({report['dialect']}): {report['moves']} moves, "
        f"cycle time {report['cycle_time_s']:.3f} s",
        f"contour error: max {ce['max']:.3f} um, rms {ce['rms']:.3f} um, p95 {ce['p95']:.3f} um"
        " (feed moves)",
        f"  parts: chord {parts['chord_max']:.3f} um, reference {parts['reference_max']:.3f} um, "
        f"tracking {parts['tracking_max']:.3f} um (max each)",
    ]
    if report["blocks"]:
        worst = max(report["blocks"], key=lambda b: b["max_error_um"])
        lines.append(
            f"  worst block: line {worst['line']} ({worst['kind']}) "
            f"max {worst['max_error_um']:.3f} um"
        )
    lines.append(
        f"simulated {sim['steps']} steps of {sim['physics_timestep_s'] * 1e3:g} ms at "
        f"{sim['realtime_factor']:.0f}x real time; total {report['timing_s']['total']:.2f} s"
    )
    from gantry_sim.sim.report import OUTPUT_FILES

    lines.append(f"wrote {out_dir}/: {', '.join(OUTPUT_FILES)}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from gantry_sim.controller.errors import ConfigError
    from gantry_sim.sim.api import run_program, write_run_outputs
    from gantry_sim.sim.outdir import prepare_output_dir
    from gantry_sim.sim.report import OUTPUT_FILES

    gate = args.max_error_um
    if gate is not None and not (math.isfinite(gate) and gate >= 0):
        raise ConfigError(f"{gate}: must be a number >= 0 [um]", file="--max-error-um")
    budget = budget_from(args)
    machine = load_machine(args.machine)
    text = read_program(args.program)
    # before the simulation: a folder that cannot take the outputs fails now, not after it;
    # a failing run must not leave an earlier run's report behind
    prepare_output_dir(args.out, clear=OUTPUT_FILES)
    result = run_program(
        text,
        file=str(args.program),
        dialect=args.dialect,
        machine=machine,
        progress=sys.stderr.isatty(),
        budget=budget,
    )
    write_run_outputs(result, args.out)
    print(_summary(result.report, args.out))
    worst = result.report["contour_error_um"]["max"]
    if gate is not None and worst > gate:
        print(f"FAIL: max contour error {worst:.3f} um > --max-error-um {gate:g}")
        return 1
    return 0
