"""The environment of a benchmark's fresh processes: a user's, with the modules' bytecode.

A user's install runs from compiled bytecode: pip compiles what it installs into site-packages,
and Python writes an editable checkout's ``__pycache__`` on its first import. A machine whose
environment sets ``PYTHONDONTWRITEBYTECODE`` (the machines these benchmarks were run on do)
compiles every module of ``gantry_sim`` from its source in every fresh process instead: 0.3-0.4
s of CPU, measured on 2026-12-01 as ``gantry run examples/circle.ngc --no-plots`` in 0.83-0.88
s against 0.46-0.56 s from bytecode. That is no cost of the program's run, and a benchmark that
times fresh processes (a short run's fixed costs, the end-to-end ratio to MuJoCo alone) would
count it as one. :func:`user_env` drops that setting for the benchmark's children, and
:func:`compile_package` writes the package's bytecode first (into ``__pycache__`` folders next
to the sources, which git ignores), so that the first child does not pay for it either.
"""

from __future__ import annotations

import compileall
import os
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: the package's source folders (the checkout is the package, gantry_sim)
PACKAGE_DIRS = ("controller", "sim", "models")


def user_env(**extra: str) -> dict[str, str]:
    """This process' environment without ``PYTHONDONTWRITEBYTECODE``, with ``extra`` set."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.update(extra)
    return env


def compile_package() -> None:
    """Write the bytecode of every module of the package (quietly; a folder that cannot be
    written is left to compile in each process, as before)."""
    for name in PACKAGE_DIRS:
        compileall.compile_dir(ROOT / name, quiet=2)
    compileall.compile_file(ROOT / "__init__.py", quiet=2)
