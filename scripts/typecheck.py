#!/usr/bin/env python3
"""Type-check the source tree under its installed names with mypy.

    python scripts/typecheck.py [extra mypy arguments]

The repository keeps the user's folders (`controller/`, `sim/`, `models/`) while the installed
package is `gantry_sim` (pyproject.toml maps them). mypy resolves imports from files, not from
setuptools' mapping, so this lays a `gantry_sim/` folder of symbolic links to the three folders
in `.mypy_cache/tree/` (ignored by git; a fixed place, so mypy's cache makes reruns quick) and
checks `gantry_sim.controller` and `gantry_sim.sim` there: the same names the code imports, in
an editable or a regular install alike. Exit status is mypy's.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FOLDERS = ("controller", "sim", "models")


def main(argv: list[str] | None = None) -> int:
    extra = list(sys.argv[1:] if argv is None else argv)
    tree = ROOT / ".mypy_cache" / "tree"
    package = tree / "gantry_sim"
    if package.exists():
        shutil.rmtree(package)
    package.mkdir(parents=True)
    for folder in FOLDERS:
        (package / folder).symlink_to(ROOT / folder, target_is_directory=True)
    env = {**os.environ, "MYPYPATH": str(tree)}
    command = [
        sys.executable,
        "-m",
        "mypy",
        "--config-file",
        str(ROOT / "pyproject.toml"),
        "--cache-dir",
        str(ROOT / ".mypy_cache" / "cache"),
        "-p",
        "gantry_sim.controller",
        "-p",
        "gantry_sim.sim",
        *extra,
    ]
    return subprocess.run(command, cwd=tree, env=env).returncode


if __name__ == "__main__":
    sys.exit(main())
