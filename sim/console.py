"""The ``gantry`` console script (pyproject's ``[project.scripts]``): Ctrl-C and SIGTERM handled
from its first step, then sim.cli.

The handlers are installed before sim.cli and its command modules are imported (about 0.1-0.2
s on a loaded machine), so a signal at any moment of the process's own code exits 130 with
``gantry: interrupted`` or 143 with ``gantry: terminated``, never with a traceback or killed
by the signal (sim.interrupts). A signal that arrives before the interpreter runs this module
(its own start-up, some tens of milliseconds, where no Python program can handle one) ends the
process by its default action, which a shell reports as 130 or 143 too.
"""

from __future__ import annotations

from collections.abc import Callable

from gantry_sim.sim.interrupts import run_command


def _main() -> Callable[[], int]:
    """sim.cli.main, imported once the handlers are installed."""
    from gantry_sim.sim.cli import main

    return main


def entry() -> None:
    """Run ``gantry`` and exit with its status (sim.interrupts.run_command)."""
    run_command(_main)


if __name__ == "__main__":  # python -m gantry_sim.sim.console
    entry()
