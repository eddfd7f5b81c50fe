"""Our planned cycle time against LinuxCNC 2.9's planner on the same programs.

    python benchmarks/bench_peer.py [--only NAME ...]

Plans every program of benchmarks/peer/ (benchmarks/peer_programs.py) with
gantry_sim.controller.planner.plan on the bundled machine (models/gantry.toml) and prints, per
program and mode, our cycle time, LinuxCNC's (benchmarks/data/linuxcnc_peer.json, recorded by
benchmarks/linuxcnc_peer.py with the same per-axis velocity and acceleration limits, no jerk
limit) and their ratio. Issue 12's aim: ours / LinuxCNC <= 1.00 in G64 P0.01 while we also hold
the jerk limit. A LinuxCNC time recorded for a different version of the file is marked stale.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
if str(HERE.parent) not in sys.path:  # run as a script: import the sibling benchmark module
    sys.path.insert(0, str(HERE.parent))

from benchmarks.peer_programs import MODES, OUT, modes, programs  # noqa: E402
from gantry_sim.controller.config import load_machine_config  # noqa: E402
from gantry_sim.controller.gcode.interpreter import interpret_events  # noqa: E402
from gantry_sim.controller.planner import plan  # noqa: E402

MACHINE = load_machine_config(HERE.parent / "models" / "gantry.toml")
PEER = HERE / "data" / "linuxcnc_peer.json"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", nargs="*", default=[], help="program names (default: all)")
    args = ap.parse_args()
    peer = json.loads(PEER.read_text())
    print(f"LinuxCNC: {peer['version']} ({peer['package']}), recorded {peer['date']}:")
    print(f"  {peer['how_measured']}; resolution {peer['resolution_s'] * 1000:g} ms")
    jmax = MACHINE.limits.max_jerk_mm_per_s3
    head = f"{'program':12s} {'mode':14s} {'ours [s]':>9s} {'LinuxCNC [s]':>12s} {'ratio':>7s}"
    print(f"{head}  {'LC jerk/jmax':>12s}  plan")
    g64: dict[str, float] = {}
    for name in programs():
        if args.only and name not in args.only:
            continue
        for tag in modes(name):
            path = OUT / f"{name}.{tag}.ngc"
            text = path.read_text()
            t0 = time.perf_counter()
            # with the events, as gantry plan has them (dwells, and the stops LinuxCNC makes)
            ours = plan(list(interpret_events(text, file=path.name)), MACHINE).duration_s
            t_plan = time.perf_counter() - t0
            rec = peer["programs"].get(name, {}).get(tag)
            if rec is None:
                theirs, note = "      -", "no LinuxCNC record"
            else:
                stale = rec["sha256"] != hashlib.sha256(text.encode()).hexdigest()
                jerk = max(j / m for j, m in zip(rec["max_axis_jerk_mm_per_s3"], jmax, strict=True))
                theirs = f"{rec['cycle_s']:12.3f} {ours / rec['cycle_s']:7.3f}  {jerk:12.1f}"
                note = "STALE: the file changed since it was recorded" if stale else ""
                if tag == "g64":
                    g64[name] = ours / rec["cycle_s"]
            print(f"{name:12s} {MODES[tag]:14s} {ours:9.3f} {theirs}  {t_plan:5.1f} s {note}")
    if g64:
        over = sorted(n for n, r in g64.items() if r > 1.0)
        print(
            f"G64 P0.01: ours / LinuxCNC at most {max(g64.values()):.3f} (aim <= 1.00); "
            f"above 1.00: {', '.join(over) or 'none'}. LC jerk/jmax: LinuxCNC's largest axis "
            "jerk (third differences of its 1 ms positions) over our jerk limit."
        )


if __name__ == "__main__":
    main()
