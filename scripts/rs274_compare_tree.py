"""Run every ``*.ngc`` under a folder through ``rs274 -g`` and gantry-sim's interpreter; compare.

For programs that are not in the corpus (e.g. all of LinuxCNC's ``nc_files/``, whatever their
length): per program one line, ``MATCH`` when both accept and make the same motions (kinds and
geometry within the corpus' tolerances; lines are not compared, rs274 prints none), else what
differs: which side refuses (with both messages), a motion count, or the first differing motion.
rs274 runs one program at a time under ``flock /tmp/rs274.lock``, in the program's folder (so
its subroutine files are found there, as gantry-sim's ``--subroutine-path``), with rs274's
built-in tool table (``tests/data/rs274/rs274_default_tools.tbl``, inches).

    python scripts/rs274_compare_tree.py FOLDER [--max-bytes N]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "tests"))

import regen_rs274_expected as regen  # noqa: E402
from test_rs274_corpus import _check_motion  # noqa: E402

from gantry_sim.controller.errors import GcodeError  # noqa: E402
from gantry_sim.controller.gcode.interpreter import interpret  # noqa: E402
from gantry_sim.controller.gcode.tools import read_tool_table  # noqa: E402

TOOLS = read_tool_table(ROOT / "tests" / "data" / "rs274" / "rs274_default_tools.tbl", 25.4)


def compare(path: Path) -> str:
    """One program -> "MATCH" or what differs."""
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        return "not UTF-8"
    proc = subprocess.run(
        ["flock", regen.LOCK, "rs274", "-g", str(path)],
        capture_output=True,
        text=True,
        cwd=path.parent,
        timeout=300,
    )
    try:
        want, unit = regen.parse_canon(proc.stdout)
    except RuntimeError as exc:
        return f"rs274 output not understood: {exc}"
    rs_error = regen.error_message(proc.stderr) if proc.returncode else None
    got: list[dict] = []
    error: GcodeError | None = None
    try:
        for move in interpret(text, file=path.name, tools=TOOLS, search_path=(path.parent,)):
            got.append(move.to_json())
    except GcodeError as exc:
        error = exc
    notes = []
    if error is not None and rs_error is None:
        notes.append(f"gantry-sim refuses, rs274 accepts: {error}")
    elif error is None and rs_error is not None:
        notes.append(f"rs274 refuses, gantry-sim accepts: {rs_error}")
    elif error is not None:
        notes.append(f"both refuse: rs274 {rs_error!r}, gantry-sim {error}")
    elif len(got) != len(want):
        notes.append(f"{len(got)} motions, rs274 {len(want)}")
    for i, (g, w) in enumerate(zip(got, want, strict=False)):
        if w["kind"] == "other":
            notes.append(f"motion {i}: rs274 makes {w['call']}")
            break
        bad = _check_motion(i, {**g, "line": None}, {**w, "line": None}, unit)
        if bad:
            notes.append(bad[0])
            break
    return "; ".join(notes) or "MATCH"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder", type=Path)
    ap.add_argument("--max-bytes", type=int, default=60000, help="skip larger programs")
    args = ap.parse_args()
    results = {}
    for path in sorted(args.folder.rglob("*.ngc")):
        if path.stat().st_size <= args.max_bytes:
            results[path] = compare(path)
    for path, result in results.items():
        print(f"{path.relative_to(args.folder)}: {result}")
    matched = sum(r == "MATCH" for r in results.values())
    print(f"{matched} of {len(results)} programs match rs274", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
