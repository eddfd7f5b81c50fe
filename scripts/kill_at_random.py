"""kill -9 at random moments (issue 15, defect 8): does an output folder always hold one whole
run, and does no debris outlive the next write?

    python scripts/kill_at_random.py --kills 20 --seed 1

Per command (run, ballbar, tune, sweep): time one full write into a folder, then repeatedly
start the same command with other inputs into that folder and SIGKILL it at a uniformly random
moment of that duration. After each kill: the marker file (report.json, ballbar.json,
tune.json, sweep.csv) is either absent or belongs to one whole run whose other files match it,
and nothing is left beside the folder. At the end one more run must succeed and leave no
staging folder inside. Prints the counts per command; exit 1 on any violation.
"""

from __future__ import annotations

import argparse
import collections
import csv
import json
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

CIRCLE = "G21 G90 G17\nG0 X3 Y0\nG3 I-3 J0 F2400\nM2\n"
LINE = "G21 G90\nG1 X2 F1200\nM2\n"


def whole(command: str, out: Path) -> str:
    """'none' (no marker), 'whole', or what is wrong."""
    if command == "run":
        if not (out / "report.json").exists():
            return "none"
        rep = json.loads((out / "report.json").read_text())
        with np.load(out / "trace.npz") as tr:
            if rep["sim"]["steps"] != 2 * tr["t"].size:
                return "report.json and trace.npz of different runs"
        ok = all((out / f).exists() for f in ("path.png", "error.png"))
        return "whole" if ok else "plots missing"
    if command == "ballbar":
        if not (out / "ballbar.json").exists():
            return "none"
        radius = json.loads((out / "ballbar.json").read_text())["radius_mm"]
        if f"radius {radius:g} mm" not in (out / "ballbar.ngc").read_text():
            return "ballbar.json and ballbar.ngc of different runs"
        for d in ("cw", "ccw"):
            with np.load(out / f"trace_{d}.npz") as tr:
                if abs(np.linalg.norm(tr["pos"][:, :2], axis=1).max() - radius) > 0.05:
                    return f"trace_{d}.npz of another run"
        return "whole"
    if command == "tune":
        if not (out / "tune.json").exists():
            return "none"
        json.loads((out / "tune.json").read_text())
        return "whole" if (out / "tune.png").exists() else "tune.png missing"
    if not (out / "sweep.csv").exists():
        return "none"
    rows = list(csv.DictReader((out / "sweep.csv").open()))
    ok = rows and all(r["status"] == "ok" for r in rows)
    return "whole" if ok and (out / "sweep_error_vs_feed.png").exists() else "partial sweep"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kills", type=int, default=20, help="kills per command (default 20)")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="gantry-kill-") as tmp:  # removed however it ends
        return _kill(args, Path(tmp))


def _kill(args: argparse.Namespace, work: Path) -> int:
    """Every command killed ``args.kills`` times in ``work``; the exit status."""
    rng = random.Random(args.seed)
    (work / "circle.ngc").write_text(CIRCLE)
    (work / "line.ngc").write_text(LINE)
    base = [sys.executable, "-m", "gantry_sim.sim.cli"]
    variants = {
        "run": [["run", str(work / p), "--out"] for p in ("circle.ngc", "line.ngc")],
        "ballbar": [["ballbar", "--feed", "3000", "--radius", r, "--out"] for r in ("5", "6")],
        "tune": [["tune", "--radii", r, "--out"] for r in ("5", "6")],
        "sweep": [
            ["sweep", str(work / "line.ngc"), "--workers", "1", "--feed-override", f, "--out"]
            for f in ("100", "100,120")
        ],
    }
    bad = 0
    for command, argvs in variants.items():
        out = work / command
        counts: collections.Counter = collections.Counter()
        t0 = time.monotonic()
        subprocess.run([*base, *argvs[0], str(out)], capture_output=True, check=True)
        full = time.monotonic() - t0
        for k in range(args.kills):
            proc = subprocess.Popen(
                [*base, *argvs[(k + 1) % 2], str(out)],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
            time.sleep(rng.uniform(0.0, full))
            proc.kill()
            proc.wait()
            state = whole(command, out)
            debris = [p.name for p in work.glob(f".{command}.tmp-*")]
            if state not in ("none", "whole") or debris:
                counts["VIOLATION"] += 1
                print(f"  {command} kill {k}: {state} {debris}")
            else:
                counts[f"killed, marker {state}" if proc.returncode == -9 else "finished"] += 1
        done = subprocess.run([*base, *argvs[0], str(out)], capture_output=True)
        left = [p.name for p in out.glob(".gantry-staging-*")]
        if done.returncode != 0 or whole(command, out) != "whole" or left:
            counts["VIOLATION after the final run"] += 1
        bad += counts["VIOLATION"] + counts["VIOLATION after the final run"]
        print(f"{command}: one write {full:.1f} s; " + ", ".join(f"{k} {v}" for k, v in
              sorted(counts.items())), flush=True)  # fmt: skip
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
