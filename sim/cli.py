"""``gantry``: a thin dispatcher over the subcommands in :mod:`gantry_sim.sim.commands`.

Exit status: 0 success; 1 a gate set on the command line failed; 2 invalid input, reported as
``FILE:LINE: error: MESSAGE`` (or ``FILE: error: MESSAGE``) on stderr, never a traceback.
Start-up stays quick: each command module imports mujoco / matplotlib only inside ``run``.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from gantry_sim.controller.errors import GantryError

#: subcommand -> module in sim.commands defining ``HELP``, ``add_arguments(parser)`` and
#: ``run(args) -> int``.
COMMANDS: dict[str, str] = {
    "parse": "gantry_sim.sim.commands.parse",
    "plan": "gantry_sim.sim.commands.plan",
    "run": "gantry_sim.sim.commands.run",
    "ballbar": "gantry_sim.sim.commands.ballbar",
    "tune": "gantry_sim.sim.commands.tune",
    "sweep": "gantry_sim.sim.commands.sweep",
    "machine": "gantry_sim.sim.commands.machine",
    "compare": "gantry_sim.sim.commands.compare",
}


def _version() -> str:
    """The installed gantry-sim's version (its distribution metadata)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("gantry-sim")
    except PackageNotFoundError:  # run from a source tree that is not installed
        return "unknown (not installed)"


class _VersionAction(argparse.Action):
    """``--version``, reading the metadata only when asked (importlib.metadata costs ~20 ms)."""

    def __init__(self, option_strings: Sequence[str], dest: str, help: str | None = None) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, help=help)

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: object,
        option_string: str | None = None,
    ) -> None:
        print(f"gantry {_version()}")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gantry",
        description="Simulate a 3-axis gantry through G-code arcs and measure how closely it follows them.",
    )
    parser.add_argument(
        "--version", action=_VersionAction, help="print gantry-sim's version and exit"
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module_name in COMMANDS.items():
        module = importlib.import_module(module_name)
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``gantry`` with ``argv`` (default: sys.argv[1:]) and return the exit status."""
    args = build_parser().parse_args(argv)
    try:
        return int(args._run(args))
    except GantryError as exc:
        print(str(exc), file=sys.stderr)
        return 2
    except BrokenPipeError:
        # The reader went away (e.g. `gantry parse ... | head`): not an error of ours.
        sys.stderr.close()
        return 0
    except KeyboardInterrupt:
        print("gantry: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
