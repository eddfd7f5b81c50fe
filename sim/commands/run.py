"""``gantry run``: plan, simulate in MuJoCo, analyse; write report.json, trace.npz and plots.

``--no-trace`` leaves trace.npz out (report.json "files" and the summary say so).
``--progress`` / ``--no-progress``: per-stage bars on stderr (default: when it is a terminal).

Exit status: 0 done; 1 a gate failed (``--max-error-um``, ``--max-error-um-lines``,
``--max-cycle-time-s``, ``--baseline``; the outputs are still written, with the verdict in
report.json); 2 invalid program, machine file or option, or a diverged simulation (no report is
written, and stale outputs of an earlier run in DIR are removed first).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

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

if TYPE_CHECKING:  # the CLI starts without numpy: sim.report is imported by run()
    from gantry_sim.sim.plot_worker import PlotWorker
    from gantry_sim.sim.report import RunReport

HELP = "plan, simulate and analyse a program; write report.json, trace.npz and plots"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("program", type=path_arg, help="G-code program (.ngc)")
    add_dialect(parser)
    add_machine(parser)
    add_program_setup(parser)
    parser.add_argument(
        "--out",
        type=path_arg,
        default=DEFAULT_OUT,
        metavar="DIR",
        help=f"output folder (default: ./{DEFAULT_OUT}); created if needed",
    )
    parser.add_argument(
        "--feed-override",
        type=float,
        default=100.0,
        metavar="PCT",
        help="scale every programmed feed by PCT %% (default 100), as the machine's knob",
    )
    parser.add_argument(
        "--max-error-um",
        action="append",
        default=[],
        metavar="UM|KIND=UM,...",
        help="gate: exit 1 when a feed block's max contour error exceeds UM; 'arc=5,linear=8' "
        "sets a limit per motion kind (arc: G2/G3, linear: G1); repeatable",
    )
    parser.add_argument(
        "--max-error-um-lines",
        action="append",
        default=[],
        metavar="FIRST-LAST=UM,...",
        help="gate: limit for the blocks on program lines FIRST..LAST (or LINE=UM); repeatable",
    )
    parser.add_argument(
        "--max-cycle-time-s",
        type=float,
        default=None,
        metavar="S",
        help="gate: exit 1 when the planned cycle time exceeds S seconds",
    )
    parser.add_argument(
        "--baseline",
        type=path_arg,
        default=None,
        metavar="REPORT",
        help="gate: compare with an earlier report.json (or its folder) block by block, as "
        "`gantry compare` does with its default margins; exit 1 when error or time grew",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help="print the report.json object on stdout instead of the summary",
    )
    parser.add_argument(
        "--no-plots", action="store_true", help="skip path.png and error.png (faster)"
    )
    parser.add_argument(
        "--no-trace",
        action="store_true",
        help="do not write trace.npz (a streamed run's would be gigabytes); report.json, the "
        "per-block table and the plots are complete, and report.json 'files' says so",
    )
    parser.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="bars with ETA on stderr for the stages of a long run (parse, plan, simulate, "
        "analyse, write); default: only when stderr is a terminal",
    )
    parser.add_argument(
        "--deterministic",
        action="store_true",
        help="write the wall-clock fields of report.json (timing_s.*, sim.realtime_factor) as "
        "null, so the same input gives a byte-identical report.json; timing.json has them",
    )
    add_budget(parser)


def _summary(typed: RunReport, out_dir: Path, files: list[str]) -> str:
    report, timing = typed.to_json(blocks=False), typed.timing_json()
    ce, parts, sim = report["contour_error_um"], report["parts_um"], report["sim"]
    stops = report["limit_change_stops"]
    lines = [
        f"{report['program']} ({report['dialect']}): {report['moves']} moves, "
        f"cycle time {report['cycle_time_s']:.3f} s"
        + (
            f" (with {stops} exact stops at limit changes, which Marlin does not make)"
            if stops
            else ""
        ),
        f"contour error: max {ce['max']:.3f} um, rms {ce['rms']:.3f} um, p95 {ce['p95']:.3f} um"
        " (feed moves)"
        if typed.blocks
        else "contour error: none measured: the program has no feed moves (G1/G2/G3), so "
        "report.json carries 0 and the error gates pass",
        f"  parts: chord {parts['chord_max']:.3f} um, reference {parts['reference_max']:.3f} um, "
        f"tracking {parts['tracking_max']:.3f} um (max each)",
    ]
    if typed.program_limits:  # Marlin's M201/M203
        acc = [
            max(lim.max_acceleration_mm_per_s2[i] for _, lim in typed.program_limits)
            for i in range(3)
        ]
        vel = [
            max(lim.max_velocity_mm_per_s[i] for _, lim in typed.program_limits) for i in range(3)
        ]
        lines.append(
            f"  limits set by the program (M201/M203, {len(typed.program_limits)} part(s)): up to "
            f"{'/'.join(f'{a:g}' for a in acc)} mm/s^2, {'/'.join(f'{v:g}' for v in vel)} mm/s "
            "(X/Y/Z)"
        )
    worst = typed.worst_block()
    if worst is not None:
        lines.append(f"  worst block: {worst.where} ({worst.kind}) max {worst.max_error_um:.3f} um")
    lines.append(
        f"simulated {sim['steps']} steps of {sim['physics_timestep_s'] * 1e3:g} ms at "
        f"{timing['realtime_factor']:.0f}x real time; total {timing['timing_s']['total']:.2f} s "
        "(reading, simulating, analysing, plotting and writing)"
    )
    skipped = "" if "trace.npz" in files else " (no trace.npz: --no-trace)"
    lines.append(f"wrote {out_dir}/: {', '.join(files)}{skipped}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    started = time.perf_counter()
    from gantry_sim.sim.plot_worker import early_plot_worker

    # started before this command's imports, so that the worker's import overlaps them
    plotter = None if args.no_plots else early_plot_worker(args.program)
    try:
        return _run(args, started, plotter)
    finally:
        if plotter is not None:
            plotter.close()  # the run closed it, unless it failed before the run started


def _run(args: argparse.Namespace, started: float, plotter: PlotWorker | None) -> int:
    from gantry_sim.controller.errors import ConfigError
    from gantry_sim.sim.api import run_program, with_verdict, write_run_outputs
    from gantry_sim.sim.compare import Margins, compare, format_table, load_report
    from gantry_sim.sim.gates import gates_from_options, verdict_for
    from gantry_sim.sim.outdir import prepare_output_dir, remove_outputs
    from gantry_sim.sim.report import OUTPUT_FILES

    gates = gates_from_options(args.max_error_um, args.max_error_um_lines, args.max_cycle_time_s)
    if not (0 < args.feed_override < float("inf")):
        raise ConfigError(f"{args.feed_override}: must be a number > 0 [%]", file="--feed-override")
    budget = budget_from(args)
    baseline = load_report(args.baseline) if args.baseline is not None else None  # before clearing
    if args.out.exists() and not args.out.is_dir():
        raise ConfigError("--out must be a folder, not a file", file=str(args.out))
    machine = program_machine(args)
    text = read_program(args.program)
    # before the simulation: a folder that cannot take the outputs fails now, not after it
    prepare_output_dir(args.out)
    try:
        result = run_program(
            text,
            file=str(args.program),
            dialect=args.dialect,
            machine=machine,
            feed_override_pct=args.feed_override,
            progress=args.progress,
            budget=budget,
            search_path=search_path(args),
            max_iterations=max_iterations(args),
            keep_trace=not args.no_trace,
            plots=not args.no_plots,
            plot_worker=plotter,
        )
        comparison = None
        if baseline is not None:
            comparison = compare(baseline, result.report, Margins())
        verdict = verdict_for(
            result.run_report,
            gates,
            comparison.failures if comparison is not None else (),
            str(args.baseline) if args.baseline is not None else None,
        )
        result = with_verdict(result, verdict)
        result = write_run_outputs(
            result,
            args.out,
            plots=not args.no_plots,
            deterministic=args.deterministic,
            gates=gates,
            started=started,
            trace=not args.no_trace,
            progress=args.progress,
        )
    except Exception:  # an error, not an interruption: no older report beside it
        remove_outputs(args.out, OUTPUT_FILES, last="report.json")
        raise
    report = result.run_report
    files = list(report.files)
    if args.json:
        sys.stdout.write(json.dumps(report.to_json(args.deterministic)) + "\n")
    else:
        print(_summary(report, args.out, files))
    msg = sys.stderr if args.json else sys.stdout
    if comparison is not None:
        print(f"against {args.baseline}:", file=msg)
        print(format_table(comparison, Margins()), file=msg)
    for failure in verdict.failures:
        if not failure["gate"].startswith("baseline"):  # those are in the table above
            print(f"FAIL: {failure['message']}", file=msg)
    if verdict.passed and verdict.gates:
        print(f"PASS: {', '.join(verdict.gates)}", file=msg)
    return 0 if verdict.passed else 1
