"""Regenerate tests/data/grbl/corpus.jsonl: grbl 1.1h's own reading of each program.

    python scripts/regen_grbl_expected.py --oracle PATH/grbl_oracle [--add FILE.gcode ...]

Runs the grbl oracle (grbl 1.1h's gcode.c built for the host: tests/data/grbl/README.md says
how) on every program of the corpus, and on each ``--add`` file, and writes per program what
grbl did: the first line it answered with ``error:N`` (or none) and the motions before it, in
gantry-sim's terms (tests/test_grbl_corpus.py compares them with the grbl dialect). A program
whose run needs what the oracle does not model (probing, alarms, resets, $SLP, $C check mode)
is left out, saying why.

The oracle prints one JSON object per event: ``{"ev": "line", "file_line", "kind": "rapid" |
"feed" | "jog", "end": [x, y, z] (machine mm), "feed" (mm/min, or 1/min with "inverse_time":
1), "tlo" (G43.1's offset on Z)}``, ``{"ev": "arc", "file_line", "dir": "cw" | "ccw", "end",
"centre", "radius", "plane": [axis0, axis1, linear], "angular_travel" (rad, signed),
"segments", "feed", "inverse_time", "tlo"}``, ``{"ev": "status", "file_line", "ok": 0 | 1,
"error": N}``, and others: dwell, sync (grbl empties its planner), probe, alarm, reset, sleep,
end. Events not named here, and fields not used, are ignored; a probe, alarm, reset or sleep
event, or an event with ``"check_mode": 1``, leaves its program out.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / "tests" / "data" / "grbl" / "corpus.jsonl"
#: oracle events that mean the run went where the oracle does not model grbl
UNMODELLED = {"probe": "probing", "alarm": "an alarm", "reset": "a reset", "sleep": "$SLP"}
_PLANES = {(0, 1, 2): "XY", (2, 0, 1): "XZ", (1, 2, 0): "YZ"}


def _events(text: str) -> list[dict]:
    """printf's nan/inf as JSON's NaN/Infinity, one event per line."""
    out = []
    for line in text.splitlines():
        if line.strip():
            line = re.sub(r"(?<=[\[,:])-?nan\b", "NaN", line)
            line = re.sub(r"(?<=[\[,:])(-?)inf\b", lambda m: m.group(1) + "Infinity", line)
            out.append(json.loads(line))
    return out


def condense(events: list[dict]) -> dict | str:
    """What grbl did, as the corpus keeps it, or why the program cannot be kept."""
    for e in events:
        if e["ev"] in UNMODELLED:
            return UNMODELLED[e["ev"]]
        if e.get("check_mode"):
            return "$C check mode"
    first_error = next(([e["file_line"], e["error"]] for e in events if e["ev"] == "status"
                        and not e["ok"]), None)  # fmt: skip
    limit = first_error[0] if first_error else math.inf
    motions: list[dict] = []
    before = [0.0, 0.0, 0.0]  # machine position
    for e in events:
        if e["ev"] not in ("line", "arc") or e["file_line"] >= limit:
            continue
        tlo = e.get("tlo") or 0.0
        tip = [e["end"][0], e["end"][1], e["end"][2] - tlo]  # gantry-sim reports the tool tip
        m: dict = {"line": e["file_line"], "end": tip}
        if e["ev"] == "line":
            m["kind"] = "rapid" if e["kind"] == "rapid" else "linear"
            if m["kind"] == "linear":  # planner.c: in G93 the rate is F times the length
                length = math.dist(before, e["end"])
                m["feed"] = e["feed"] * length if e.get("inverse_time") else e["feed"]
        elif e["radius"] == 0.0 and not e.get("inverse_time"):
            # a centre on the start: mc_arc cuts it into no segment, its closing mc_line goes
            # straight to the end at the feed
            m.update(kind="linear", feed=e["feed"])
        else:
            feed = e["feed"]
            if e.get("inverse_time"):  # mc_arc: the segments run at F times their count
                if not e["segments"]:
                    return "a G93 arc of no segment (one inverse-time line to its end)"
                feed = e["feed"] * e["segments"]
            m.update(
                kind="arc", direction=e["dir"], plane=_PLANES[tuple(e["plane"])],
                center=[e["centre"][0], e["centre"][1], e["centre"][2] - tlo],
                radius=e["radius"], angle=abs(e["angular_travel"]), feed=feed,
            )  # fmt: skip
        before = e["end"]
        motions.append(m)
    return {"first_error": first_error, "motions": motions}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--oracle", required=True, type=Path, help="the grbl_oracle binary")
    ap.add_argument("--add", nargs="*", type=Path, default=[], help="programs to add")
    args = ap.parse_args()
    programs: dict[str, str] = {}
    if CORPUS.exists():
        for line in CORPUS.read_text().splitlines():
            row = json.loads(line)
            programs[row["name"]] = row["program"]
    for path in args.add:
        programs[path.stem] = path.read_text()
    rows = []
    tmp = CORPUS.parent / ".program.gcode"
    try:
        for name, text in sorted(programs.items()):
            tmp.write_text(text)
            run = subprocess.run([str(args.oracle), str(tmp)], capture_output=True, text=True)
            kept = condense(_events(run.stdout))
            if isinstance(kept, str):
                print(f"{name}: left out ({kept})", file=sys.stderr)
                continue
            try:
                rows.append(json.dumps({"name": name, "program": text, **kept}, allow_nan=False))
            except ValueError:  # grbl's float32 arithmetic made a NaN (an R arc's centre)
                print(f"{name}: left out (a non-finite number)", file=sys.stderr)
    finally:
        tmp.unlink(missing_ok=True)
    CORPUS.write_text("\n".join(rows) + "\n")
    print(f"{len(rows)} programs in {CORPUS.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
