"""Helpers of the fault-injection tests: run ``gantry`` as a real process, mount small tmpfs
file systems (root only; tests skip with the reason otherwise), kill -9 at chosen points.

``gantry_at(point, ...)`` runs gantry in a child Python that sends itself SIGKILL when the
program reaches ``point``: the kernel's kill -9, at a deterministic moment instead of a random
one (``"simulate"``: entering the simulation; ``"replace:N"``: before the N-th ``os.replace`` of
the output commit, N = 0, 1, ...; ``"write"``: when the output files are being written).
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

TRACEBACK = "Traceback (most recent call last)"
#: FILE:LINE: error: MESSAGE or FILE: error: MESSAGE (argparse's "gantry run: error:" too)
ERROR_LINE = re.compile(r"^[^\n]+?(:\d+)?: error: \S")

_KILLER = r"""
import os, signal, sys
point = sys.argv[1]
def die(*a, **k):
    os.kill(os.getpid(), signal.SIGKILL)
if point == "simulate":
    import gantry_sim.sim.runner as runner
    runner.simulate = die
elif point == "plan":
    import importlib  # the package re-exports plan(), which hides the module of that name
    importlib.import_module("gantry_sim.controller.planner.plan").plan = die
elif point == "write":  # a run that is not streamed writes its trace.npz with save_npz
    import gantry_sim.sim.trace_writer as trace_writer
    trace_writer.save_npz = die
elif point.startswith("replace:"):
    n = int(point.split(":")[1])
    real, count = os.replace, [0]
    def replace(src, dst, *a, **k):
        if "gantry-staging" in str(src) and not str(src).endswith(".complete.tmp"):
            if count[0] == n:
                die()
            count[0] += 1
        return real(src, dst, *a, **k)
    os.replace = replace
from gantry_sim.sim.cli import main
sys.exit(main(sys.argv[2:]))
"""


def gantry(
    *args: str, timeout: float = 120, prefix: tuple[str, ...] | list[str] = (), **kw
) -> subprocess.CompletedProcess:
    """``gantry ARGS`` as a process (this interpreter), text output captured."""
    return subprocess.run(
        [*prefix, sys.executable, "-m", "gantry_sim.sim.cli", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        **kw,
    )


def gantry_at(point: str, *args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """``gantry ARGS``, killed with SIGKILL when it reaches ``point`` (module docstring)."""
    return subprocess.run(
        [sys.executable, "-c", _KILLER, point, *args],
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def assert_clean_error(proc: subprocess.CompletedProcess, status: int = 2) -> str:
    """The contract of an error exit: the status, no traceback, FILE[:LINE]: error: on stderr."""
    assert TRACEBACK not in proc.stderr, proc.stderr
    assert proc.returncode == status, (proc.returncode, proc.stderr)
    assert any(ERROR_LINE.match(line) for line in proc.stderr.splitlines()), proc.stderr
    return proc.stderr


@contextlib.contextmanager
def tmpfs(path: Path, size: str = "1m", read_only: bool = False) -> Iterator[Path]:
    """A small tmpfs mounted at ``path`` (created); skip the test when mounting is not allowed."""
    path.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root (the fault tests run as root in CI)")
    opts = f"size={size}" + (",ro" if read_only else "")
    r = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(path)], capture_output=True, text=True
    )
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {r.stderr.strip()}")
    try:
        yield path
    finally:
        subprocess.run(["umount", "-l", str(path)], capture_output=True)


def unprivileged() -> list[str]:
    """A command prefix that drops root's power to ignore permission bits (CAP_DAC_OVERRIDE,
    CAP_DAC_READ_SEARCH) so EACCES can happen; [] when not root. Skips without setpriv."""
    if os.geteuid() != 0:
        return []
    if shutil.which("setpriv") is None:
        pytest.skip("as root, permission errors need setpriv to drop CAP_DAC_OVERRIDE")
    return ["setpriv", "--bounding-set", "-dac_override,-dac_read_search"]


def staging_left(folder: Path) -> list[str]:
    """Staging or temporary entries left in ``folder`` and its parent (debris)."""
    names = [p.name for p in folder.iterdir()] if folder.is_dir() else []
    names += [p.name for p in folder.parent.iterdir() if p.name.startswith(f".{folder.name}.")]
    return [n for n in names if "staging" in n or ".tmp" in n]
