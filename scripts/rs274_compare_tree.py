"""Run every ``*.ngc`` under a folder through ``rs274 -g`` and gantry-sim's interpreter; compare.

For programs that are not in the corpus (e.g. all of LinuxCNC's ``nc_files/``, whatever their
length): per program one line, ``MATCH`` when both accept and make the same motions (kinds and
geometry within the corpus' tolerances; lines are not compared, rs274 prints none), else what
differs: which side refuses (with both messages), a motion count, or the first differing motion.
Canonical output the harness does not read (a plane it does not know, such as G17.1's
``CANON_PLANE_UNKNOWN``, with an arc in it, or a call new to it) is reported on that line, and the
rest is still compared; an error in the harness itself is reported for that program only. A
spline (NURBS_FEED: rs274 prints no end point) is passed over, and the next motion is compared by
its end alone; a user M-code rs274 refuses only for want of an INI is said to be one.
rs274 runs one program at a time under ``flock /tmp/rs274.lock``, in the program's folder (so
its subroutine files are found there, as gantry-sim's ``--subroutine-path``), with rs274's
built-in tool table (``tests/data/rs274/rs274_default_tools.tbl``, inches).

    python scripts/rs274_compare_tree.py FOLDER [--max-bytes N]
"""

from __future__ import annotations

import argparse
import itertools
import re
import resource
import subprocess
import sys
import tempfile
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


#: rs274's output read at most (a program looping for ever prints for ever: the whole of it was
#: read into memory once, 24 GB, until the kernel killed the script)
MAX_OUTPUT_BYTES = 64 << 20
#: gantry-sim's moves run at most past rs274's when rs274 refuses (to see whether it refuses too)
MOVES_PAST_REFUSAL = 2_000_000
#: rs274 -g's refusal of a user M-code (M100-M199)
USER_M_RE = re.compile(r"Unknown m code used: M(1\d\d)$")
#: rs274's run time at most [s]
RS274_S = 60


def _cap_output() -> None:
    """In rs274's process: files it writes stop at MAX_OUTPUT_BYTES (SIGXFSZ ends it)."""
    resource.setrlimit(resource.RLIMIT_FSIZE, (MAX_OUTPUT_BYTES, MAX_OUTPUT_BYTES))


def compare(path: Path) -> str:
    """One program -> "MATCH" or what differs."""
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        return "not UTF-8"
    with tempfile.TemporaryFile() as out:
        try:
            # rs274 runs under timeout, inside the lock: killed, it frees the lock (a timeout
            # of subprocess.run killed flock only, and the looping rs274 kept the lock)
            rs274 = ["timeout", "-s", "KILL", str(RS274_S), "rs274", "-g", str(path)]
            proc = subprocess.run(
                ["flock", regen.LOCK, *rs274],
                stdout=out,
                stderr=subprocess.PIPE,
                text=True,
                cwd=path.parent,
                timeout=900,  # includes waiting for the lock (another rs274 user)
                preexec_fn=_cap_output,
            )
        except subprocess.TimeoutExpired:
            return "the rs274 lock was held for over 900 s"
        if proc.returncode == 137:
            return f"rs274 ran over {RS274_S} s (a runaway loop?)"
        if out.tell() >= MAX_OUTPUT_BYTES:
            return f"rs274 wrote over {MAX_OUTPUT_BYTES >> 20} MB (a runaway loop?)"
        out.seek(0)
        stdout = out.read().decode("utf-8", "replace")
    return judge(text, path, stdout, proc.returncode, proc.stderr)


def judge(text: str, path: Path, stdout: str, returncode: int, stderr: str) -> str:
    """rs274's output for the program ``text`` (at ``path``) against gantry-sim's run -> "MATCH"
    or what differs. Canonical calls the harness does not know (an arc in a UVW plane, a call
    new to it) are reported, and the motions it did read are still compared."""
    # (print,...) comments print to stdout among the canonical calls: not motions
    canon = "\n".join(x for x in stdout.splitlines() if regen.CANON_RE.match(x))
    unknown: list[str] = []
    want, unit = regen.parse_canon(canon, unknown)
    rs_error = regen.error_message(stderr) if returncode else None
    got: list[dict] = []
    error: GcodeError | None = None
    try:
        moves = interpret(text, file=path.name, tools=TOOLS, search_path=(path.parent,))
        # one more than rs274's tells a longer run; when rs274 refuses, run on (bounded) to
        # tell whether gantry-sim refuses further on
        limit = len(want) + (1 if rs_error is None else MOVES_PAST_REFUSAL)
        for k, move in enumerate(itertools.islice(moves, limit)):
            if k <= len(want):
                got.append(move.to_json())
    except GcodeError as exc:
        error = exc
    notes = []
    if error is not None and rs_error is None:
        notes.append(f"gantry-sim refuses, rs274 accepts: {error}")
    elif error is None and rs_error is not None:
        notes.append(f"rs274 refuses, gantry-sim accepts: {rs_error}{_user_m_note(path, rs_error)}")
    elif error is not None:
        notes.append(f"both refuse: rs274 {rs_error!r}, gantry-sim {error}")
    elif len(got) != len(want):
        notes.append(f"{len(got)} motions, rs274 {len(want)}")
    after_spline = False
    for i, (g, w) in enumerate(zip(got, want, strict=False)):
        if w["kind"] == "other" and w["call"] == "NURBS_FEED" and g["kind"] == "spline":
            after_spline = True  # rs274 prints no end point for a spline: not compared
            continue
        if w["kind"] == "other":
            notes.append(f"motion {i}: rs274 makes {w['call']}")
            break
        if after_spline:  # its start is the spline's end, unknown: compare the end only
            bad = _end_differs(i, g, w, unit)
        else:
            bad = _check_motion(i, {**g, "line": None}, {**w, "line": None}, unit)
        after_spline = False
        if bad:
            notes.append(bad[0])
            break
    if unknown:
        shown = "; ".join(unknown[:3]) + (
            f"; and {len(unknown) - 3} more" if len(unknown) > 3 else ""
        )
        notes.append(f"rs274 output the harness does not read ({shown})")
    return "; ".join(notes) or "MATCH"


def _end_differs(i: int, got: dict, want: dict, unit_mm: float) -> list[str]:
    """The motion after a spline: kind and end [mm] only (tolerance as the corpus')."""
    tol = 1e-4 * unit_mm + 1e-7
    if got["kind"] != want["kind"]:
        return [f"motion {i}: kind {got['kind']!r} != rs274 {want['kind']!r}"]
    if any(abs(a - b) > tol for a, b in zip(got["end"], want["end"], strict=True)):
        return [f"motion {i}: end {got['end']} != rs274 {want['end']} (tol {tol:g} mm)"]
    return []


def _user_m_note(path: Path, rs_error: str) -> str:
    """Why rs274 refuses a user M-code whose program sits beside the program (else "")."""
    m = USER_M_RE.match(rs_error)
    if m is None or not (path.parent / f"M{m.group(1)}").is_file():
        return ""
    return (
        f" (not a difference: M{m.group(1)} is in the program's folder, and rs274 -g reads no"
        " INI, so it has no USER_M_PATH; LinuxCNC with USER_M_PATH = . runs it, as gantry-sim)"
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder", type=Path)
    ap.add_argument("--max-bytes", type=int, default=60000, help="skip larger programs")
    args = ap.parse_args()
    results = {}
    for path in sorted(args.folder.rglob("*.ngc")):
        if path.is_file() and path.stat().st_size <= args.max_bytes:
            try:
                results[path] = compare(path)
            except Exception as exc:  # one program's trouble does not end the survey
                results[path] = f"not compared: harness error ({type(exc).__name__}: {exc})"
            print(f"{path.relative_to(args.folder)}: {results[path]}", flush=True)
    matched = sum(r == "MATCH" for r in results.values())
    print(f"{matched} of {len(results)} programs match rs274", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
