"""Plot benchmark: path.png and error.png for a 100,000-block program.

Run:  python benchmarks/bench_plots.py [--blocks N]        (from the repository root)

The program is a real one, interpreted: N/2 short G1 steps alternating with N/2 G3 quarter
arcs (R 0.5 mm) along X. The trace is synthetic (the simulation of 100,000 blocks is bench_sim's
subject): 10 samples per block on the commanded geometry, displaced by a known error, so the
time measured here is drawing and writing only. Target: both PNGs in < 10 s at 100,000 blocks.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from gantry_sim.controller.arcs import arc_points
from gantry_sim.controller.gcode.interpreter import interpret
from gantry_sim.controller.moves import Arc
from gantry_sim.sim.contour import ContourStats
from gantry_sim.sim.error_plot import save_error_plot
from gantry_sim.sim.gates import ErrorLimit, Gates
from gantry_sim.sim.path_plot import save_path_plot
from gantry_sim.sim.trace import Trace

SAMPLES_PER_BLOCK = 10


def program(blocks: int) -> str:
    lines = ["G21 G17 G90 G94", "G0 X0 Y0 Z0", "G91"]
    for k in range(blocks // 2):
        lines.append("G1 X1 F3000")
        lines.append("G3 X0.5 Y0.5 I0 J0.5" if k % 2 == 0 else "G2 X0.5 Y-0.5 I0 J-0.5")
    lines.append("M2")
    return "\n".join(lines) + "\n"


def trace_on(moves, rng: np.random.Generator) -> Trace:
    u = np.linspace(0.0, 1.0, SAMPLES_PER_BLOCK, endpoint=False)
    pts, lines = [], []
    for mv in moves:
        if isinstance(mv, Arc):
            p = arc_points(mv, u)
        else:
            p = np.asarray(mv.start) + u[:, None] * (np.asarray(mv.end) - np.asarray(mv.start))
        pts.append(p)
        lines.append(np.full(len(u), mv.line))
    ref = np.vstack(pts)
    n = len(ref)
    # like a real run: arcs follow worse than lines, a few corners spike
    arc = np.repeat([isinstance(mv, Arc) for mv in moves], len(u))
    err_mm = np.where(arc, 0.0025, 0.0008) + rng.normal(0.0, 0.0002, n).clip(-0.0006, 0.0006)
    spikes = rng.choice(n, 6, replace=False)
    err_mm[spikes] += rng.uniform(0.001, 0.003, 6)
    pos = ref + np.column_stack([np.zeros(n), err_mm, np.zeros(n)])
    feed = np.ones(n, bool)
    return Trace(np.arange(n) * 1e-3, ref, pos, np.concatenate(lines), err_mm * 1e3, ref, feed,
                 np.zeros((n, 3)))  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", type=int, default=100_000)
    ap.add_argument("--out", type=Path, default=None, help="keep the PNGs in this folder")
    args = ap.parse_args()
    t0 = time.perf_counter()
    moves = tuple(interpret(program(args.blocks), "linuxcnc", "bench.ngc"))
    tr = trace_on(moves, np.random.default_rng(0))
    t1 = time.perf_counter()
    e = tr.err_um
    stats = ContourStats(float(e.max()), float(np.sqrt(np.mean(e**2))), float(np.percentile(e, 95)))
    gates = Gates((ErrorLimit(3.5), ErrorLimit(2.0, kind="arc")))
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.out or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        save_path_plot(folder / "path.png", moves, tr, "bench.ngc", stats)
        t2 = time.perf_counter()
        save_error_plot(folder / "error.png", tr, stats, gates, moves)
        t3 = time.perf_counter()
    print(f"{len(moves)} moves, {len(tr.t)} samples (built in {t1 - t0:.1f} s)")
    print(f"path.png  {t2 - t1:.2f} s")
    print(f"error.png {t3 - t2:.2f} s")


if __name__ == "__main__":
    main()
