"""``gantry run`` on short programs, as users and CI scripts call it many times: the wall time of
the whole command (the interpreter's start and imports included) with the plots drawn by the
plot worker (sim.plot_worker, the default) against the same command drawing them in its own
process (``GANTRY_PLOT_WORKER=0``), and against ``--no-plots``.

Run:  python benchmarks/bench_cli_run.py [--repeat 7] [--programs circle,pocket_tangent_arcs]

Each program runs as a fresh ``python -m gantry_sim.sim.cli run`` process, the three variants
interleaved (worker, in-process, no plots, worker, ...) so that a slow moment of a shared
machine falls on all three; the table gives the minimum and the median of the wall times, and
the ratios of the medians. Also checked: the worker's path.png and error.png are the
in-process ones byte for byte.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_env import compile_package, user_env

ROOT = Path(__file__).resolve().parent.parent
VARIANTS = {
    "worker": ({"GANTRY_PLOT_WORKER": "1"}, []),
    "in-process": ({"GANTRY_PLOT_WORKER": "0"}, []),
    "no plots": ({"GANTRY_PLOT_WORKER": "1"}, ["--no-plots"]),
}


def _run(program: Path, out: Path, env: dict[str, str], extra: list[str]) -> float:
    cmd = [sys.executable, "-m", "gantry_sim.sim.cli", "run", str(program), "--out", str(out)]
    t0 = time.perf_counter()
    subprocess.run([*cmd, *extra], env=user_env(**env), check=True, capture_output=True)
    return time.perf_counter() - t0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--programs", default="circle,pocket_tangent_arcs")
    args = parser.parse_args()
    compile_package()  # each run starts from bytecode, as a user's install does (bench_env)
    print(f"{'program':<22} {'variant':<11} {'min s':>7} {'median s':>9} {'/ in-process':>13}")
    for name in args.programs.split(","):
        program = ROOT / "examples" / f"{name}.ngc"
        times: dict[str, list[float]] = {v: [] for v in VARIANTS}
        with tempfile.TemporaryDirectory() as tmp:
            for k in range(args.repeat):
                for variant, (env, extra) in VARIANTS.items():
                    out = Path(tmp) / f"{variant}-{k}"
                    times[variant].append(_run(program, out, env, extra))
            same = all(
                (Path(tmp) / "worker-0" / png).read_bytes()
                == (Path(tmp) / "in-process-0" / png).read_bytes()
                for png in ("path.png", "error.png")
            )
        base = statistics.median(times["in-process"])
        for variant, t in times.items():
            med = statistics.median(t)
            print(f"{name:<22} {variant:<11} {min(t):7.2f} {med:9.2f} {med / base:13.2f}")
        print(f"{'':<22} plots the same byte for byte: {'yes' if same else 'NO'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
