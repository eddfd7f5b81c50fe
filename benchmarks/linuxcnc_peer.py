"""Run the peer programs through LinuxCNC 2.9's own trajectory planner; record its cycle times.

    python benchmarks/linuxcnc_peer.py [--only NAME ...]  -> benchmarks/data/linuxcnc_peer.json

Needs LinuxCNC 2.9 installed (Debian's linuxcnc-uspace: /usr/bin/linuxcnc, halsampler, the
``linuxcnc`` module of /usr/bin/python3); CI machines do not have it, so this is run by hand and
its output committed. Each program of benchmarks/peer/ (benchmarks/peer_programs.py) runs alone:
LinuxCNC starts from a scratch copy of benchmarks/linuxcnc/ (gantry_peer.ini: the bundled
gantry's per-axis limits, servo period 1 ms, a simulated machine with its positions looped
back), its display peer_display.py homes, runs the program and exits. Runs are serialised with
``flock /tmp/rs274.lock`` (LinuxCNC and rs274 share /tmp state and must not run at once).

How the cycle time is measured: a HAL ``sampler`` in the servo thread records motion's
``current-vel`` (the planner's path speed) and the commanded joint positions every servo
period; halsampler writes every sample, numbered, so a lost one would show. The cycle time is
the number of servo periods from the first period with a non-zero planned speed to the last one,
inclusive, times the 1 ms period: the planner's own clock, not the wall clock, from motion's
start to idle. Resolution: 1 ms. ``stopped_periods`` counts the periods at zero planned speed
in between (exact stops). The per-axis maxima of velocity, acceleration and jerk are differences
of the commanded positions (after motion's joint interpolator), to show which limits bound. ``cycle_pos_s`` counts the periods in which the commanded
positions change instead (it includes the joint interpolator's few-period smoothing at the
ends). ``wall_s`` is the wall-clock time from the run command to idle as stat polling saw it
(it adds the interpreter's start-up and LinuxCNC's task latency).

Running as root: rtapi_app refuses to run as root unless RTAPI_UID names a fallback user; this
script sets RTAPI_UID=65534 (nobody) and a socket path it can bind (RTAPI_FIFO_PATH).
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
CONFIG = HERE / "linuxcnc"
PROGRAMS = HERE / "peer"
OUT = HERE / "data" / "linuxcnc_peer.json"
PERIOD_S = 0.001
LOCK = "/tmp/rs274.lock"


def linuxcnc_version() -> dict[str, str]:
    module = subprocess.run(
        ["/usr/bin/python3", "-c", "import linuxcnc; print(linuxcnc.version)"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    package = subprocess.run(
        ["dpkg-query", "-W", "-f", "${Package} ${Version}", "linuxcnc-uspace"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    return {"version": module, "package": package}


def cycle_times(samples: np.ndarray) -> dict[str, float | int]:
    """From halsampler's lines (sample number, x, y, z [mm], speed [mm/s], motion type, line)."""
    num = samples[:, 0].astype(np.int64)
    if np.any(np.diff(num) != 1):
        raise RuntimeError("halsampler lost samples: the cycle time would be wrong")
    moving = np.nonzero(samples[:, 4] != 0.0)[0]
    changed = np.nonzero(np.any(np.diff(samples[:, 1:4], axis=0) != 0.0, axis=1))[0]
    if len(moving) == 0:
        raise RuntimeError("no motion was sampled")
    inside = samples[moving[0] : moving[-1] + 1, 4]
    pos = samples[:, 1:4]
    vel = np.diff(pos, axis=0) / PERIOD_S
    acc = np.diff(vel, axis=0) / PERIOD_S
    jerk = np.diff(acc, axis=0) / PERIOD_S
    return {
        "cycle_s": round((moving[-1] - moving[0] + 1) * PERIOD_S, 6),
        "cycle_pos_s": round((changed[-1] - changed[0] + 1) * PERIOD_S, 6),
        "stopped_periods": int(np.count_nonzero(inside == 0.0)),
        "max_speed_mm_per_s": round(float(samples[:, 4].max()), 4),
        # per axis, by differences of the commanded positions (6 decimals: jerk +-1e3 mm/s^3)
        "max_axis_velocity_mm_per_s": np.abs(vel).max(axis=0).round(3).tolist(),
        "max_axis_acceleration_mm_per_s2": np.abs(acc).max(axis=0).round(1).tolist(),
        "max_axis_jerk_mm_per_s3": np.abs(jerk).max(axis=0).round(-3).tolist(),
        "samples": len(samples),
    }


#: Tools 1-99 in pockets 1-99, of zero length and diameter: what gantry-sim's machine without a
#: [tools] table reads for every tool, so programs with T, M6, G43 H or G10 L1 run on both.
PEER_TOOLS = "".join(f"T{n} P{n} Z0 D0 ;\n" for n in range(1, 100))


def run_one(program: Path, timeout_s: float) -> dict[str, object]:
    with tempfile.TemporaryDirectory(prefix="linuxcnc_peer_") as tmp:
        work = Path(tmp)
        os.chmod(work, 0o755)  # the fallback user must reach fifo/ (mkdtemp makes it 0700)
        for f in CONFIG.iterdir():
            shutil.copy2(f, work / f.name)
        (work / "peer.tbl").write_text(PEER_TOOLS)
        (work / "fifo").mkdir()
        os.chmod(work / "fifo", 0o777)  # rtapi_app binds its socket as the fallback user
        (work / "out").mkdir()
        env = dict(
            os.environ,
            PEER_PROGRAM=str(program),
            PEER_OUT=str(work / "out"),
            RTAPI_UID="65534",
            RTAPI_FIFO_PATH=str(work / "fifo" / "rtapi_fifo"),
        )
        cmd = ["flock", LOCK, "linuxcnc", "gantry_peer.ini"]
        subprocess.run(cmd, cwd=work, env=env, timeout=timeout_s, check=False)
        run_file = work / "out" / "run.json"
        if not run_file.exists():
            raise RuntimeError(f"{program.name}: LinuxCNC did not finish the run (no run.json)")
        run = json.loads(run_file.read_text())
        samples = np.loadtxt(work / "out" / "samples.txt", ndmin=2)
    if run["overruns"] or run["errors"]:
        raise RuntimeError(f"{program.name}: {run}")
    return {**cycle_times(samples), "wall_s": round(run["wall_s"], 3), "resumes": run["resumes"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", nargs="*", default=[], help="program names (default: all)")
    ap.add_argument("--timeout", type=float, default=1200.0, help="per run [s]")
    ap.add_argument("--out", type=Path, default=OUT, help=f"default: {OUT.relative_to(ROOT)}")
    args = ap.parse_args()
    out = args.out
    data = json.loads(out.read_text()) if out.exists() and args.only else {"programs": {}}
    today = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d")
    data.update(
        {
            "origin": "LinuxCNC's own trajectory planner (tpmod), run by benchmarks/linuxcnc_peer.py",
            **linuxcnc_version(),
            # the whole file's; an entry recorded later (--only) carries its own
            "date": data.get("date", today),
            "ini": "benchmarks/linuxcnc/gantry_peer.ini",
            "hal": "benchmarks/linuxcnc/gantry_peer.hal",
            "limits": "per axis as models/gantry.toml: v [500, 400, 200] mm/s, a [3000, 2500, "
            "3000] mm/s^2; [TRAJ] path limits set above them (700 mm/s, 5000 mm/s^2)",
            "jerk_limit": "none: LinuxCNC 2.9's planner limits velocity and acceleration only",
            "arc_blend": "ARC_BLEND_ENABLE 1, FALLBACK_ENABLE 0, OPTIMIZATION_DEPTH 50, "
            "GAP_CYCLES 4, RAMP_FREQ 100 (LinuxCNC 2.9's defaults)",
            "how_measured": "HAL sampler in the servo thread, every period: cycle_s = servo "
            "periods from the first to the last with motion.current-vel != 0, inclusive",
            "servo_period_s": PERIOD_S,
            "resolution_s": PERIOD_S,
        }
    )
    for program in sorted(PROGRAMS.glob("*.ngc")):
        name, mode = program.name.removesuffix(".ngc").split(".")
        if args.only and name not in args.only:
            continue
        result = run_one(program, args.timeout)
        sha = hashlib.sha256(program.read_bytes()).hexdigest()
        entry = {"file": program.relative_to(ROOT).as_posix(), "sha256": sha, **result}
        if args.only:
            entry["date"] = today
        data["programs"].setdefault(name, {})[mode] = entry
        print(f"{name:12s} {mode:6s} {result['cycle_s']:9.3f} s  (wall {result['wall_s']:.3f} s)")
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
