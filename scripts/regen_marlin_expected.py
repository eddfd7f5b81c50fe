"""Regenerate tests/data/marlin/corpus.jsonl: Marlin's own reading of each program.

    python scripts/regen_marlin_expected.py --oracle PATH/oracle [--add FILE ...]
        [--name-prefix PREFIX] [--only-matching]

Runs the Marlin oracle (Marlin bugfix-2.1.x's line reader, GCodeParser and command handlers
built for the host, planner calls printed: tests/data/marlin/README.md says how) on every
program of the corpus and on each ``--add`` file (named PREFIX + the file's stem), and writes
per program what Marlin moved, in gantry-sim's terms (tests/test_marlin_corpus.py compares
them with the marlin dialect). With ``--only-matching`` a program the dialect reads otherwise
is left out of the corpus, and listed with its differences on stderr. A program whose run
reaches Marlin code the oracle does not model (the oracle exits 3 naming it) is left out,
saying why.

The oracle prints one JSON object per event, each with the file ``line`` of its command:
``{"ev": "line" | "seg", "x", "y", "z", "e", "f"}`` for each Planner::buffer_line /
buffer_segment call (mm, native coordinates; f in mm/s), ``{"ev": "pos", ...}`` for
Planner::set_position_mm, and ``{"ev": "done", "x", "y", "z", "e", "f", "pct"}`` after each
command (Marlin's current_position, feedrate_mm_s and feedrate_percentage).

Per line that moved, the corpus keeps ``{"line", "end" (current_position after the command),
"feed" (mm/min: the planner's scaled rate, the last call's), "extrudes" (E changed),
"homing" (G28: buffer_segment calls; no feed kept), "points" (on a line Marlin cut into
segments, an arc or a G5: up to 48 segment ends, evenly drawn, the last always)}``. A line
whose planner calls all go where the tool already is (within 1e-5 mm), E included (``G1
F300``, a bare ``F`` line, a bare ``G5``), is no motion: Marlin's planner makes no block of a move without steps.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / "tests" / "data" / "marlin" / "corpus.jsonl"
MAX_POINTS = 48
#: a planner call within this of where the tool is moves nothing: at Marlin's default
#: 80-500 steps/mm it is not a step (Planner::_populate_block makes no block without one)
STILL = 1e-5


def _events(text: str) -> list[dict]:
    return [json.loads(line) for line in text.splitlines() if line.strip()]


def _r(v: float) -> float:
    """A float32 value as printed (%.9g) is exact; keep it so."""
    return float(v)


def condense(events: list[dict]) -> list[dict]:
    """Per line that moved: where Marlin ended, its feed, whether E changed, its segments."""
    motions: list[dict] = []
    e_before = 0.0
    before = (0.0, 0.0, 0.0)
    moves: list[dict] = []
    for ev in events:
        if ev["ev"] in ("line", "seg"):
            moves.append(ev)
        elif ev["ev"] == "done":
            here = (*before, e_before)
            still = all(
                max(abs(a - b) for a, b in zip((m["x"], m["y"], m["z"], m["e"]), here, strict=True))
                <= STILL
                for m in moves
            )
            if moves and not still:
                homing = any(m["ev"] == "seg" for m in moves)
                row = {
                    "line": ev["line"],
                    "end": [_r(ev["x"]), _r(ev["y"]), _r(ev["z"])],
                    "feed": _r(moves[-1]["f"]) * 60.0,
                    "extrudes": ev["e"] != e_before,
                }
                if homing:
                    row["homing"] = True
                    del row["feed"], row["extrudes"]
                elif len(moves) > 1:
                    pts = [[_r(m["x"]), _r(m["y"]), _r(m["z"])] for m in moves]
                    if len(pts) > MAX_POINTS:
                        step = len(pts) / (MAX_POINTS - 1)
                        pts = [pts[int(k * step)] for k in range(MAX_POINTS - 1)] + [pts[-1]]
                    row["points"] = pts
                motions.append(row)
            moves = []
            e_before = ev["e"]
            before = (ev["x"], ev["y"], ev["z"])
    return motions


def run_oracle(oracle: str, text: str) -> list[dict] | str:
    with tempfile.NamedTemporaryFile("w", suffix=".gcode", delete=False, encoding="utf-8") as f:
        f.write(text)
        path = f.name
    try:
        run = subprocess.run([oracle, path], capture_output=True, text=True, timeout=120)
    finally:
        Path(path).unlink()
    if run.returncode:
        return run.stderr.strip() or f"oracle exit {run.returncode}"
    return condense(_events(run.stdout))


def _test_module():
    spec = importlib.util.spec_from_file_location("tmc", ROOT / "tests" / "test_marlin_corpus.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--oracle",
        required=True,
        help="the oracle program (the harness tests/data/marlin/README.md describes)",
    )
    ap.add_argument("--add", nargs="*", default=[], help="program files to add")
    ap.add_argument("--name-prefix", default="", help="prefix for the added programs' names")
    ap.add_argument("--only-matching", action="store_true", help="keep only programs the "
                    "marlin dialect reads as Marlin does")  # fmt: skip
    ap.add_argument("--out", default=str(CORPUS), help="corpus file to write")
    args = ap.parse_args(argv)

    rows = []
    if CORPUS.exists():
        rows = [json.loads(line) for line in CORPUS.read_text().splitlines()]
    programs = {r["name"]: r["program"] for r in rows}
    for path in map(Path, args.add):
        name = args.name_prefix + re.sub(r"[^A-Za-z0-9_.-]+", "_", path.stem)
        text = path.read_bytes().decode("utf-8", errors="replace")
        programs[name] = text if text.endswith("\n") else text + "\n"

    check = _test_module() if args.only_matching else None
    out, left = [], 0
    for name, text in programs.items():
        motions = run_oracle(args.oracle, text)
        if isinstance(motions, str):
            print(f"left out {name}: {motions}", file=sys.stderr)
            left += 1
            continue
        row = {"name": name, "program": text, "motions": motions}
        if check is not None:
            try:
                moves = check.parse_program(text, dialect="marlin", file="p.gcode")
                problems = check.differences(row, moves)
            except Exception as exc:  # a refusal is a difference too
                problems = [f"gantry-sim: {type(exc).__name__}: {exc}"]
            if problems:
                print(f"differs {name}: {problems[:3]}", file=sys.stderr)
                left += 1
                continue
        out.append(row)
    out.sort(key=lambda r: r["name"])
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "w") as f:
        for row in out:
            f.write(json.dumps(row, separators=(",", ":")) + "\n")
    print(f"{len(out)} programs written, {left} left out", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
