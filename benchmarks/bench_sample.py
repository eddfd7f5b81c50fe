"""Sampling a long plan's reference range by range, as a streamed run does: packed blocks against
the segments laid out one by one.

    python benchmarks/bench_sample.py                          10,000 blocks of each kind
    python benchmarks/bench_sample.py --blocks 30000 --kinds poly

Each program (benchmarks/programs.py, bundled machine) is planned once; then its reference is
sampled at 1 kHz in ranges of 65,536 ticks (``Plan.sample_range``, the streamed run's call) with
each block read back from the plan's temporary file and laid out (controller/planner/packed_block.py),
and again with the baseline in this run, the code before the blocks were packed: the same blocks
held as the pickled tuples of segments they were, unpickled and laid out a segment at a time (the
closed-form runs' phase states in one batch, as before). The blocks'
laid-out cache is emptied before each pass, so every block is read and laid out once per pass, as
in a run. Printed per kind: ticks, blocks, both times (best of three passes), their ratio, and
whether the samples are identical.
"""

from __future__ import annotations

import argparse
import pickle
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from programs import program

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.planner import plan
from gantry_sim.controller.planner.cubic import Jerk3Run
from gantry_sim.controller.planner.jerk3 import phase_starts
from gantry_sim.controller.planner.packed_block import PackedBlock
from gantry_sim.models import DEFAULT_MACHINE

RANGE_TICKS = 65_536
PERIOD_S = 1e-3


class _OneByOne:
    """The baseline block: its segments pickled as a tuple, laid out segment by segment."""

    def __init__(self, block: PackedBlock) -> None:
        self.data = pickle.dumps(block.segments(), protocol=pickle.HIGHEST_PROTOCOL)

    def layout(self, start_s: np.ndarray):
        """As ``SegmentedCurve._layout`` did before the blocks were packed: the runs' later
        phase states in one batch, then a row per segment and axis, concatenated."""
        segs = pickle.loads(self.data)
        runs = [s for s in segs if isinstance(s, Jerk3Run)]
        if runs:
            h, p0, v0, a0, js = Jerk3Run.joined(runs).fields
            ps, vs, as_ = phase_starts(p0, v0, a0, js, h)
            at = np.cumsum([0] + [3 * r.h.size for r in runs]).tolist()
        out = []
        for i in range(3):
            if runs:
                laid = (np.repeat(h, 3), *(x[:, :, i].ravel() for x in (ps, vs, as_, js)))
            rows, n = [], 0
            for seg in segs:
                if isinstance(seg, Jerk3Run):
                    rows.append(tuple(c[at[n] : at[n + 1]] for c in laid))
                    n += 1
                else:
                    rows.append(tuple(seg[i]))
            cols = [np.concatenate([r[c] for r in rows]) for c in range(5)]
            t0 = np.cumsum(np.concatenate(([start_s[i]], cols[0])))[:-1]
            out.append((t0, *cols[1:]))
        return tuple(out)


class _Blocks:
    """Stands in for the curve's BlockFile: block ``b`` is ``blocks[b]``."""

    def __init__(self, blocks: list) -> None:
        self.blocks = blocks

    def __getitem__(self, b: int):
        return self.blocks[b]


def _pass(p, ticks: int) -> tuple[float, list[np.ndarray]]:
    p.curve._cache.clear()
    out = []
    t0 = time.perf_counter()
    for k0 in range(0, ticks, RANGE_TICKS):
        out.append(p.sample_range(PERIOD_S, k0, k0 + RANGE_TICKS).pos)
    return time.perf_counter() - t0, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", type=int, default=10_000)
    ap.add_argument("--kinds", default="arcs,poly,mixed")
    args = ap.parse_args()
    machine = load_machine_config(DEFAULT_MACHINE)
    print(
        f"{'kind':6s} {'blocks':>7s} {'ticks':>9s} {'curve blocks':>12s} "
        f"{'packed s':>9s} {'one by one s':>12s} {'ratio':>6s}  identical"
    )
    for kind in args.kinds.split(","):
        p = plan(parse_program(program(kind, args.blocks)), machine)
        ticks = p.sample_count(PERIOD_S)
        curve = p.curve
        packed_file = curve._blocks
        count = len(packed_file)
        packed = min(_pass(p, ticks)[0] for _ in range(3))
        _, want = _pass(p, ticks)
        curve._blocks = _Blocks([_OneByOne(packed_file[b]) for b in range(count)])
        one = min(_pass(p, ticks)[0] for _ in range(3))
        _, got = _pass(p, ticks)
        curve._blocks = packed_file
        same = all(np.array_equal(a, b) for a, b in zip(want, got, strict=True))
        print(
            f"{kind:6s} {args.blocks:7d} {ticks:9d} {count:12d} {packed:9.3f} "
            f"{one:12.3f} {one / packed:6.2f}  {same}"
        )


if __name__ == "__main__":
    main()
