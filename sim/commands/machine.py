"""``gantry machine``: the effective machine, and machine files from LinuxCNC or grbl settings.

  gantry machine show [--machine F] [--json]
  gantry machine import linuxcnc INI [--out FILE]
  gantry machine import grbl SETTINGS [--out FILE]

``show`` prints per axis the limits, travel, the MJCF's masses, damping, friction and drive
limits, the servo gains (force-loop PID and the equivalent Kv), and the sampled loop's figures
(sim.machine_info). ``import`` writes a machine file (TOML) with the keys that map, to FILE or to
stdout, and lists what it assumed and what it could not map (on stdout with --out, else on
stderr); the file is loaded on the bundled model before it is written (atomically).
Exit status: 0 done; 2 an unreadable or malformed input (``FILE:LINE: error: ...``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from gantry_sim.sim.commands.common import add_machine, load_machine, path_arg

HELP = "show the effective machine; import LinuxCNC INI or grbl $$ settings as a machine file"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="machine_command", required=True, metavar="ACTION")
    show = sub.add_parser(
        "show",
        help="print the effective machine: limits, masses, gains, Kv, bandwidth, stability margin",
    )
    add_machine(show)
    show.add_argument("--json", action="store_true", help="print one JSON object instead")
    imp = sub.add_parser("import", help="write a machine file from a LinuxCNC INI or grbl $$ dump")
    imp.add_argument("format", choices=("linuxcnc", "grbl"), help="what FILE is")
    imp.add_argument("file", type=path_arg, metavar="FILE", help="LinuxCNC .ini or grbl $$ output")
    imp.add_argument(
        "--out",
        type=path_arg,
        default=None,
        metavar="FILE",
        help="machine file to write (default: stdout)",
    )


def run(args: argparse.Namespace) -> int:
    if args.machine_command == "show":
        return _show(args)
    return _import(args)


def _show(args: argparse.Namespace) -> int:
    from gantry_sim.sim.machine import load_gantry
    from gantry_sim.sim.machine_info import effective_machine, format_table

    machine = load_machine(args.machine)
    info = effective_machine(machine, load_gantry(machine))
    info.update(work_info(machine.work))
    print(json.dumps(info, indent=2) if args.json else format_table(info) + work_table(info))
    return 0


def work_info(work) -> dict:
    """The machine file's ``[tools]`` and ``[work]`` (controller/machine_work.py), in mm."""
    from gantry_sim.controller.machine_work import SYSTEM_KEYS

    tools = None
    if work.tools is not None:
        tools = [
            {
                "number": t.number,
                "length_mm": t.z_mm,
                "diameter_mm": t.diameter_mm,
                "x_mm": t.x_mm,
                "y_mm": t.y_mm,
            }
            for t in work.tools
        ]
    stored = {key: list(v) for key, v in zip(SYSTEM_KEYS, work.systems_mm, strict=True)}
    stored.update(g92_mm=list(work.g92_mm), g28_mm=list(work.g28_mm), g30_mm=list(work.g30_mm))
    return {"tools": tools, "work": stored}


def work_table(info: dict) -> str:
    """``[tools]`` and the non-zero ``[work]`` entries as lines for people (leading newline)."""
    lines = ["", "tools [mm]"]
    if info["tools"] is None:
        lines.append(
            "  none: every tool has zero length (a [tools] section or --tool-table sets them)"
        )
    else:
        lines.append(f"  {'T':>5} {'length':>10} {'diameter':>10} {'x':>8} {'y':>8}")
        for t in info["tools"]:
            lines.append(
                f"  {t['number']:>5} {t['length_mm']:>10.4f} {t['diameter_mm']:>10.4f} "
                f"{t['x_mm']:>8.4f} {t['y_mm']:>8.4f}"
            )
    lines.append("work offsets and stored positions at program start [mm, work frame]")
    set_ = {k: v for k, v in info["work"].items() if any(v)}
    if not set_:
        lines.append("  all zero: programs start in G54 at the work origin, no G92, G28/G30 at 0")
    for key, v in set_.items():
        lines.append(f"  {key:<9} {v[0]:>10.4f} {v[1]:>10.4f} {v[2]:>10.4f}")
    return "\n".join(lines)


def _same_file(a: Path, b: Path) -> bool:
    """Whether ``a`` and ``b`` name one existing file."""
    try:
        return a.samefile(b)
    except OSError:  # either is missing, or not a path to compare (standard input)
        return False


def _import(args: argparse.Namespace) -> int:
    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.controller.errors import ConfigError
    from gantry_sim.controller.machine_import.grbl_settings import import_grbl
    from gantry_sim.controller.machine_import.linuxcnc_ini import import_linuxcnc
    from gantry_sim.controller.machine_import.machine_toml import to_toml
    from gantry_sim.models import DEFAULT_MACHINE
    from gantry_sim.sim.machine import load_gantry
    from gantry_sim.sim.machine_info import effective_machine, import_target

    bundled = load_machine(None)
    target = import_target(load_gantry(bundled))
    reader = import_linuxcnc if args.format == "linuxcnc" else import_grbl
    imported = reader(args.file, target)
    text = to_toml(imported)
    if args.out is not None and (args.out.is_dir() or not args.out.parent.is_dir()):
        raise ConfigError("--out must be a file in an existing folder", file=str(args.out))
    if args.out is not None and _same_file(args.out, args.file):
        raise ConfigError(
            "--out is the file being imported; write the machine file elsewhere",
            file=str(args.out),
        )
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:  # the file must load and run on the bundled model
        check = Path(tmp) / "imported.toml"
        check.write_text(text)
        try:
            machine = load_machine_config(DEFAULT_MACHINE, check)
            info = effective_machine(machine, load_gantry(machine))
        except ConfigError as exc:
            raise ConfigError(
                f"it maps to an invalid machine file: {exc.message}", file=str(args.file)
            ) from None
    if args.out is not None:
        from gantry_sim.sim.outdir import atomic_file

        with atomic_file(args.out) as fh:
            fh.write(text)
    notes = sys.stdout if args.out is not None else sys.stderr
    if args.out is None:
        sys.stdout.write(text)
    print(
        f"imported {imported.kind} {imported.source}" + (f" -> {args.out}" if args.out else ""),
        file=notes,
    )
    for title, items in (("assumed", imported.assumed), ("not mapped", imported.not_mapped)):
        if items:
            print(f"{title}:", file=notes)
            for item in items:
                print(f"  - {item}", file=notes)
    unstable = [
        a.upper()
        for a, ax in info["axes"].items()
        if (ax["gain_margin"] is not None and ax["gain_margin"] < 1.0)
    ]
    if unstable:
        print(
            f"WARNING: with these gains the sampled loop is unstable on {', '.join(unstable)} at "
            f"{machine.servo.period_s * 1e3:g} ms (gantry machine show --machine FILE)",
            file=notes,
        )
    return 0
