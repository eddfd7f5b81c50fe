"""End-to-end benchmark of ``gantry run`` on CAM-like programs: stage times, peak memory, and the
wall time over MuJoCo alone stepping the same motion.

    python benchmarks/bench_run.py                  1k and 10k blocks of each kind (~20 min)
    python benchmarks/bench_run.py --big            and 100k blocks (about an hour more)
    python benchmarks/bench_run.py --sizes 1000 --kinds arcs --no-baseline     (quick)

Programs: benchmarks/programs.py (tangent arcs with S-bends, 0.05-0.5 mm G1 polylines, mixed
G0/G1/G2/G3 contours with corners), seeded. Each program runs in a fresh subprocess, through the
public API as ``gantry run`` does (run_program with plots=True, so the plot worker imports
matplotlib during the run, then write_run_outputs into a temporary folder);
the subprocess reports:

* stage times [s]: parse, plan, simulate, analyse, trace (report.json's timing_s; trace: a
  streamed run's trace.npz, the zip written around its arrays deflated during the run) and
  write (report.json, trace.npz and the PNGs written into a folder);
* peak memory: the subprocess' maximum resident set (getrusage ru_maxrss) right after the run,
  before anything else is measured; "child", the largest private memory its children held at
  once (a streamed run's analysis worker, sim.analysis_worker, a fresh interpreter holding the
  path tables and one range at a time; and while planning, the planner's forked processes,
  controller/forked.py); and "tree", the largest of the subprocess' peak and its resident set
  plus its children's private memory at one poll (benchmarks/memory_probe.py, every 0.1 s: a
  forked child's own resident set counts the pages it shares with its parent, and getrusage's
  RUSAGE_CHILDREN the run's resident set at the moment the worker was spawned);
* the run's own memory: "start", the resident set when planning returned (the plan and the
  moves the run holds), and "run", the largest resident set from there to the outputs written
  (the VmHWM reset when planning returns, Linux /proc/self/clear_refs): what the streamed run
  adds to what planning left, apart from the planner's own peak;
* MuJoCo alone: the same model stepped open loop through the same motion -- the run's held
  forces replayed from the same initial state by ``mujoco.rollout`` (as bench_sim.py does), in
  pieces of REPLAY_STEPS physics steps, with MuJoCo's profiler timers off as the run's servo
  loop has them (sim/mujoco_lib.py); every stage's time is printed over it (a second table),
  and the end-to-end ratio with and without the planning stage (the planner's own benchmark
  owns planning);
* before/after analysis: the analysis of THIS tree and that of git revision BASELINE_REV (the
  last one before the vectorised search: its sim/contour.py and sim/nearest.py are read with
  ``git show`` and imported from a temporary folder), timed on the very arguments the run passed
  to ``analyse``, and their results compared (err_um bit for bit, the report figures exactly).

Tried and not kept (no measurable win on the 2-core machine these figures come from, with other
jobs running; interleaved runs in one process, min / median of the wall time):
* simulating range k+1 in a background thread while range k is analysed (the C ticks release
  the GIL): 10k short G1, 4 pairs, 3.88 / 4.75 s threaded against 3.80 / 4.6 s in one thread;
  1k mixed, 12 pairs, 5.2 / 9.8 s against 7.4 / 9.3 s. The threaded simulation itself slowed by
  20-30 % (its Python part -- sampling, tool site, checks -- waits for the GIL the analysis holds)
  and the analysis doubled, eating the overlap;
* writing trace.npz in a background thread while the plots draw: 15 pairs, 1k arcs (142,733
  ticks) 0.611 / 1.100 s against 0.586 / 1.112 s; 300 mixed (200,102 ticks) 0.915 / 1.400 s
  against 0.876 / 1.361 s.

The growth law printed at the end is the exponent b of time ~ ticks^b (and of the peak memory
above the 1k run's) between the smallest and the largest size of each kind.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_env import compile_package, user_env

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

#: the revision whose analysis is the "before" (the parent of the vectorised search)
BASELINE_REV = "1834131"
#: physics steps per mujoco.rollout call when replaying (bounds the replay's state output)
REPLAY_STEPS = 200_000
KINDS = ("arcs", "poly", "mixed")
STAGES = ("parse", "plan", "simulate", "analyse", "trace", "write")
WIDTHS = (7, 8, 8, 8, 7, 7)


def _load_baseline(rev: str, folder: Path):
    """The analyse() of git revision ``rev``, imported from ``folder`` (None without git)."""
    import importlib.util

    sources = {}
    for name in ("nearest", "contour"):
        res = subprocess.run(
            ["git", "show", f"{rev}:sim/{name}.py"], cwd=ROOT, capture_output=True, text=True
        )
        if res.returncode != 0:
            return None
        sources[name] = res.stdout
    sources["contour"] = sources["contour"].replace(
        "from gantry_sim.sim.nearest import", "from baseline_nearest import"
    )
    sys.path.insert(0, str(folder))
    for name, text in sources.items():
        (folder / f"baseline_{name}.py").write_text(text)
    spec = importlib.util.spec_from_file_location(
        "baseline_contour", folder / "baseline_contour.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules["baseline_contour"] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module.analyse


def _replay_s(gantry, start_mm, force) -> float:
    """Wall time [s] of MuJoCo alone: the held forces (N, 3) [N], one row per servo tick,
    stepped open loop from rest at ``start_mm`` (work coordinates)."""
    import mujoco
    import numpy as np
    from mujoco import rollout

    from gantry_sim.sim.mujoco_lib import timers_off

    m = gantry.model
    d = mujoco.MjData(m)
    d.qpos[:] = gantry.joint_qpos_m(gantry.work_to_joint_mm(np.asarray(start_mm)[None])[0])
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state, spec)
    ticks = max(1, REPLAY_STEPS // gantry.substeps)
    wall = 0.0
    for lo in range(0, len(force), ticks):
        ctrl = np.zeros((min(ticks, len(force) - lo), m.nu))
        ctrl[:, list(gantry.actuator_id)] = force[lo : lo + ticks] / np.asarray(gantry.gear)
        ctrl = np.repeat(ctrl, gantry.substeps, axis=0)[None]
        with timers_off():  # as the servo loop steps (sim/mujoco_lib.py)
            t0 = time.perf_counter()
            states, _ = rollout.rollout(m, d, state[None], ctrl, nstep=ctrl.shape[1])
            wall += time.perf_counter() - t0
        state = states[0, -1]
    return wall


def _proc_status_bytes(field: str) -> int | None:
    """``field`` (VmRSS, VmHWM) of /proc/self/status [bytes]; None where there is none."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(field + ":"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def _reset_peak() -> bool:
    """Reset this process' VmHWM to its resident set (Linux: /proc/self/clear_refs 5)."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def child(kind: str, blocks: int, baseline_rev: str | None) -> dict:
    """Run one program; return the measurements (see the module docstring)."""
    import numpy as np

    from benchmarks.memory_probe import TreeMemory
    from benchmarks.programs import program
    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.models import DEFAULT_MACHINE
    from gantry_sim.sim import contour

    captured: dict = {}
    real_analyse = contour.analyse

    def analyse(*args, **kwargs):  # the arguments the run passes, kept for the before/after
        captured["args"], captured["kwargs"] = args, kwargs
        return real_analyse(*args, **kwargs)

    contour.analyse = analyse
    import importlib

    plan_module = importlib.import_module("gantry_sim.controller.planner.plan")  # the module

    real_plan = plan_module.plan

    def plan(*args, **kwargs):  # the run's own peak starts where planning ends
        planned = real_plan(*args, **kwargs)
        captured["run_start_bytes"] = _proc_status_bytes("VmRSS")
        captured["run_peak_reset"] = _reset_peak()
        return planned

    plan_module.plan = plan
    from gantry_sim.sim.api import run_program, write_run_outputs
    from gantry_sim.sim.budget import Budget
    from gantry_sim.sim.machine import load_gantry

    machine = load_machine_config(DEFAULT_MACHINE)
    text = program(kind, blocks)
    tree = TreeMemory()
    t0 = time.perf_counter()
    # 100k arcs and mixed run 4 and 16 hours of machine time: past the default budget, which
    # asks a user to confirm such runs with --max-sim-s / --max-physics-steps
    big = Budget(max_sim_s=1e9, max_physics_steps=1e15)
    result = run_program(text, file=f"{kind}_{blocks}.ngc", machine=machine, budget=big, plots=True)
    t1 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        write_run_outputs(result, Path(tmp) / "out")
        t2 = time.perf_counter()
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
        run_peak = _proc_status_bytes("VmHWM") if captured.get("run_peak_reset") else None
        children, tree_peak = tree.stop()
        with np.load(Path(tmp) / "out" / "trace.npz") as npz:  # every tick, streamed or not
            start, force = npz["ref"][0], npz["force_N"]
    contour.analyse = real_analyse
    timing = result.report["timing_s"]
    out = {
        "kind": kind,
        "blocks": blocks,
        "ticks": int(result.report["sim"]["steps"]) // load_gantry(machine).substeps,
        "streamed": result.streamed,
        "cycle_s": result.report["cycle_time_s"],
        **{k: float(timing[k]) for k in ("parse", "plan", "simulate", "analyse")},
        "trace": float(timing.get("trace", 0.0)),  # a streamed run's trace.npz assembled
        "write": t2 - t1,
        "wall": t2 - t0,
        "peak_bytes": peak,
        "run_start_bytes": captured.get("run_start_bytes"),
        "run_peak_bytes": run_peak,
        "children_bytes": children,
        "tree_bytes": max(peak, tree_peak),
    }
    out["mujoco"] = _replay_s(load_gantry(machine), start, force)
    if "args" not in captured:  # streamed: analysed range by range, no whole-trace call
        return out
    args, kwargs = captured["args"], captured["kwargs"]
    t3 = time.perf_counter()
    new = real_analyse(*args, **kwargs)
    out["analyse_after"] = time.perf_counter() - t3
    if baseline_rev:
        with tempfile.TemporaryDirectory() as tmp:
            old_analyse = _load_baseline(baseline_rev, Path(tmp))
            if old_analyse is not None:
                t4 = time.perf_counter()
                old = old_analyse(*args, **kwargs)
                out["analyse_before"] = time.perf_counter() - t4
                out["same"] = bool(
                    np.array_equal(old.err_um, new.err_um)
                    and old.blocks == new.blocks
                    and old.contour_um == new.contour_um
                    and old.parts_um == new.parts_um
                )
    return out


def _run_child(kind: str, blocks: int, baseline: str | None) -> dict:
    cmd = [sys.executable, __file__, "--child", kind, str(blocks)]
    cmd += ["--baseline-rev", baseline] if baseline else ["--no-baseline"]
    # as `gantry run` sets it (sim/cli.py): without it `import mujoco` probes for GLFW, 0.1 s
    # that no run of the command pays
    env = user_env(MUJOCO_GL=os.environ.get("MUJOCO_GL", "disable"))
    res = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=env)
    if res.returncode != 0:
        raise SystemExit(f"{kind} {blocks}: failed\n{res.stderr[-3000:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def _print_table(rows: list[dict]) -> None:
    print(
        f"{'program':<13}{'ticks':>9}{'cycle':>8} |{'parse':>7}{'plan':>8}{'sim':>8}"
        f"{'analyse':>8}{'trace':>7}{'write':>7}{'wall':>8} |{'mujoco':>7} |{'peak MB':>8}{'child':>7}{'tree':>7}"
        f"{'start':>7}{'run':>6} | "
        "analyse before -> after"
    )
    for r in rows:
        before, after = r.get("analyse_before"), r.get("analyse_after")
        if after is None:
            ba = "streamed (range by range)"
        elif before:
            ba = f"{before:7.2f} -> {after:.2f} s"
        else:
            ba = f"{after:.2f} s"
        if "same" in r:
            ba += "  identical" if r["same"] else "  DIFFERENT"
        print(
            f"{_name(r):<13}{r['ticks']:>9}{r['cycle_s'] / 60:>7.1f}m |"
            + "".join(f"{r.get(k, 0.0):>{w}.2f}" for k, w in zip(STAGES, WIDTHS, strict=True))
            + f"{r['wall']:>8.1f} |{r['mujoco']:>7.2f} |{r['peak_bytes'] / 2**20:>8.0f}"
            + f"{r['children_bytes'] / 2**20:>7.0f}{r['tree_bytes'] / 2**20:>7.0f}"
            + f"{_mb(r.get('run_start_bytes')):>7}{_mb(r.get('run_peak_bytes')):>6} | {ba}"
        )


def _mb(n: int | None) -> str:
    return "-" if n is None else f"{n / 2**20:.0f}"


def _print_ratios(rows: list[dict]) -> None:
    """Each stage's wall time over MuJoCo alone on the same motion, and the end-to-end ratio
    with and without planning (the planner's benchmark owns planning)."""
    print("\nwall time / MuJoCo alone, per stage")
    print(
        f"{'program':<13}{'streamed':>9} |{'parse':>7}{'plan':>8}{'sim':>8}{'analyse':>8}"
        f"{'trace':>7}{'write':>7} |{'wall':>7}{'-plan':>7}"
    )
    for r in rows:
        mj = r["mujoco"]
        print(
            f"{_name(r):<13}{'yes' if r['streamed'] else 'no':>9} |"
            + "".join(f"{r.get(k, 0.0) / mj:>{w}.2f}" for k, w in zip(STAGES, WIDTHS, strict=True))
            + f" |{r['wall'] / mj:>7.2f}{(r['wall'] - r['plan']) / mj:>7.2f}"
        )


def _name(r: dict) -> str:
    return f"{r['kind']} {r['blocks']}"


def _print_growth(rows: list[dict]) -> None:
    print("\ngrowth law, time ~ ticks^b (smallest -> largest size of each kind):")
    for kind in KINDS:
        runs = sorted((r for r in rows if r["kind"] == kind), key=lambda r: r["ticks"])
        if len(runs) < 2:
            continue
        a, b = runs[0], runs[-1]
        x = math.log(b["ticks"] / a["ticks"])
        exps = {
            k: math.log(max(b.get(k, 0.0), 1e-9) / max(a.get(k, 0.0), 1e-9)) / x
            for k in (*STAGES, "wall")
            if b.get(k, 0.0) > 0 and a.get(k, 0.0) > 0
        }
        mem = (b["peak_bytes"] - a["peak_bytes"]) / max(1, b["ticks"] - a["ticks"])
        run = ""
        if a.get("run_peak_bytes") and b.get("run_peak_bytes"):
            grew = (b["run_peak_bytes"] - a["run_peak_bytes"]) / 2**20
            held = (b["run_start_bytes"] - a["run_start_bytes"]) / 2**20
            run = f"; the run's own peak {grew:+.0f} MB, of which held from planning {held:+.0f} MB"
        print(
            f"  {kind:<6}"
            + " ".join(f"{k} {v:.2f}" for k, v in exps.items())
            + f" | peak memory +{mem:.0f} bytes per tick{run}"
        )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1000,10000", help="blocks per program, comma separated")
    ap.add_argument("--big", action="store_true", help="add 100,000-block programs")
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--baseline-rev", default=BASELINE_REV, help="git revision of the 'before'")
    ap.add_argument("--no-baseline", action="store_true", help="skip the before analysis")
    ap.add_argument("--child", nargs=2, metavar=("KIND", "BLOCKS"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    baseline = None if args.no_baseline else args.baseline_rev
    if args.child:
        print(json.dumps(child(args.child[0], int(args.child[1]), baseline)))
        return 0
    sizes = [int(s) for s in args.sizes.split(",")] + ([100_000] if args.big else [])
    compile_package()  # the runs start from bytecode, as a user's install does (bench_env)
    rows = []
    for kind in args.kinds.split(","):
        for n in sizes:
            print(f"running {kind} {n} ...", file=sys.stderr, flush=True)
            rows.append(_run_child(kind, n, baseline))
    print("times [s]; ratio: end-to-end wall / MuJoCo alone (-plan: without planning)")
    _print_table(rows)
    _print_ratios(rows)
    _print_growth(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
