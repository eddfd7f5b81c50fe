"""Regenerate the rs274 differential corpus's expectations from LinuxCNC's own interpreter.

For every ``tests/data/rs274/programs/NAME.ngc`` this runs ``rs274 -g`` (Debian package
``linuxcnc-uspace``), keeps its raw output in ``tests/data/rs274/raw/NAME.txt`` and writes
``tests/data/rs274/expected/NAME.json``: the motions in the exact shape of ``gantry parse``'s JSON
(mm, mm/min; G20 values converted with 25.4) and the error, if rs274 rejected the program.

Source lines: rs274 prints none, so they are derived from rs274 itself. The program's first k lines
(k = 1..n) are run as a program of their own; the motions that appear when line k is added belong to
line k, and the error belongs to the first prefix rs274 rejects. A prefix that merely ends without
``M2``/``M30``/``%`` makes rs274 report "File ended with no percent sign [or program end]" after
executing every line; for prefixes that message is not an error. For the whole program it is: a
program without an end is rejected by rs274, and the error is put on the file's last line (line 1
for an empty file).

Programs whose every non-blank line opens with ``N<its line number>`` (all O-word programs: a
prefix would cut a loop or subroutine) are run once: rs274 prints each motion's N word and the
failing block's text, which give the lines directly.

Frame: rs274 prints program-frame positions plus SET_G5X_OFFSET, SET_G92_OFFSET and
SET_XY_ROTATION; motions are recorded in the machine's work frame as LinuxCNC's canonical layer
places them, ``R(rotation) (p + g92) + g5x`` (emccanon.cc), each motion starting where the last
one ended.

rs274 is not safe to run in parallel: programs are run one at a time. Usage::

    python scripts/regen_rs274_expected.py [NAME ...]
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data" / "rs274"
INCH_MM = 25.4
#: rs274 is not safe to run twice at once: every run takes this lock (``flock``)
LOCK = "/tmp/rs274.lock"
EOF_MESSAGES = ("File ended with no percent sign", "File ended with no percent sign or program end")
CANON_RE = re.compile(r"^\s*\d+\s+N(\S*)\s+([A-Z_0-9.]+)\((.*)\)\s*$")
N_LINE_RE = re.compile(r"^\s*N(\d+)", re.IGNORECASE)
#: Canonical calls that do not move the tool (everything else that appears is refused loudly).
QUIET_CALLS = {
    "USE_LENGTH_UNITS",
    "SET_G5X_OFFSET",
    "SET_G92_OFFSET",
    "SET_XY_ROTATION",
    "SET_FEED_REFERENCE",
    "ON_RESET",
    "SELECT_PLANE",
    "SET_FEED_RATE",
    "SET_FEED_MODE",
    "STOP_SPINDLE_TURNING",
    "SET_SPINDLE_MODE",
    "PROGRAM_END",
    "PROGRAM_STOP",
    "FINISH",
    "COMMENT",
    "MESSAGE",
    "SET_MOTION_CONTROL_MODE",
    "SET_NAIVECAM_TOLERANCE",
    "START_SPINDLE_CLOCKWISE",
    "START_SPINDLE_COUNTERCLOCKWISE",
    "SET_SPINDLE_SPEED",
    "FLOOD_ON",
    "FLOOD_OFF",
    "MIST_ON",
    "MIST_OFF",
    "DWELL",
    "CHANGE_TOOL",
    "SELECT_TOOL",
    "START_CHANGE",
    "USE_TOOL_LENGTH_OFFSET",
    "ENABLE_FEED_OVERRIDE",
    "ENABLE_SPEED_OVERRIDE",
    "ENABLE_ADAPTIVE_FEED",
    "ENABLE_FEED_HOLD",
    "DISABLE_FEED_OVERRIDE",
    "DISABLE_SPEED_OVERRIDE",
    "OPTIONAL_PROGRAM_STOP",
    "PALLET_SHUTTLE",
    "SET_TRAVERSE_RATE",
    "SET_CUTTER_RADIUS_COMPENSATION",
    "STOP_CUTTER_RADIUS_COMPENSATION",
    "TURN_PROBE_ON",
    "TURN_PROBE_OFF",
    "ORIENT_SPINDLE",
    "WAIT_SPINDLE_ORIENT_COMPLETE",
    "SPINDLE.0.WAIT_ORIENT_COMPLETE",  # M19 (rs274 2.9 prints the spindle's number in the name)
    "USE_NO_SPINDLE_FORCE",
    "USE_SPINDLE_FORCE",
    "SET_TOOL_TABLE_ENTRY",
    "SPINDLE_RETRACT",
    "SPINDLE_RETRACT_TRAVERSE",
    "SET_MOTION_OUTPUT_BIT",
    "CLEAR_MOTION_OUTPUT_BIT",
    "SET_AUX_OUTPUT_BIT",
    "CLEAR_AUX_OUTPUT_BIT",
    "SET_MOTION_OUTPUT_VALUE",
    "SET_AUX_OUTPUT_VALUE",
    "WAIT",
    "START_SPEED_FEED_SYNCH",
    "START_SPEED_FEED_SYNC",
    "STOP_SPEED_FEED_SYNC",
    "STOP_SPEED_FEED_SYNCH",
    "DISABLE_ADAPTIVE_FEED",
    "DISABLE_FEED_HOLD",
    "UPDATE_TAG",
    "SELECT_POCKET",
    "CHANGE_TOOL_NUMBER",
    "LOGOPEN",
    "LOGAPPEND",
    "LOGCLOSE",
    "LOG",
    "PLUGIN_CALL",
    "IO_PLUGIN_CALL",
}
#: canonical motions gantry-sim does not make (probing, tapping, splines): recorded as kind
#: "other" with their end point, so that a refusal of that line can be checked against them.
OTHER_MOTIONS = {"STRAIGHT_PROBE", "RIGID_TAP", "NURBS_FEED", "SPLINE_FEED"}
LINES_DERIVED = (
    "rs274 prints no source lines: motions appearing when line k is added to the program's "
    "first k-1 lines belong to line k; the error belongs to the first prefix rs274 rejects "
    "(an end-of-file without M2/M30/% is an error only for the whole program, then on its "
    "last line)"
)
PLANES = {"CANON_PLANE_XY": "XY", "CANON_PLANE_XZ": "XZ", "CANON_PLANE_YZ": "YZ"}
#: ARC_FEED(first_end, second_end, first_centre, second_centre, rotation, normal_end, ...):
#: indices (first, second, normal) into [x, y, z] per plane (checked against rs274 by the corpus).
PLANE_AXES = {"XY": (0, 1, 2), "XZ": (2, 0, 1), "YZ": (1, 2, 0)}


def rs274_version() -> str:
    out = subprocess.run(
        ["dpkg-query", "-W", "-f=${Version}", "linuxcnc-uspace"],
        capture_output=True,
        text=True,
        check=True,
    )
    return out.stdout.strip()


def run_rs274(text: str) -> tuple[int, str, str]:
    """Run ``rs274 -g`` on ``text`` -> (exit status, stdout, stderr).

    rs274 occasionally dies from a signal when another rs274 runs at the same time (shared
    state); such runs are retried, a crash that persists is an error.
    """
    for attempt in range(8):
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "prog.ngc"
            path.write_bytes(text.encode("utf-8"))
            # another rs274 user on this machine takes the same lock (rs274 shares state)
            proc = subprocess.run(
                ["flock", LOCK, "rs274", "-g", str(path)],
                capture_output=True,
                text=True,
                cwd=tmp,
                timeout=900,  # includes waiting for the lock (another rs274 user)
            )
        if proc.returncode >= 0:
            return proc.returncode, proc.stdout, proc.stderr
        time.sleep(0.5 * (attempt + 1))
    raise RuntimeError(f"rs274 keeps crashing (signal {-proc.returncode})")


def error_message(stderr: str) -> str | None:
    """rs274's error text: the line after ``executing`` on stderr (None when there is none)."""
    lines = stderr.splitlines()
    if "executing" in lines:
        rest = lines[lines.index("executing") + 1 :]
    else:
        rest = lines
    for ln in rest:
        if ln.strip():
            return ln.strip()
    return None


def _nums(args: str) -> list[float]:
    return [float(a) for a in args.split(",")]


def _sweep(
    plane: str,
    start: list[float],
    end: list[float],
    center: list[float],
    rotation: int,
    unit_mm: float,
) -> float:
    i1, i2, _ = PLANE_AXES[plane]
    a0 = math.atan2(start[i2] - center[i2], start[i1] - center[i1])
    a1 = math.atan2(end[i2] - center[i2], end[i1] - center[i1])
    d = (a1 - a0) if rotation > 0 else (a0 - a1)
    d %= 2.0 * math.pi
    # Equal ends make a full circle. Both are rs274's 4-decimal prints (0.5e-4 unit each); the
    # start may come back through a rotated frame into another (at most 0.71e-4 unit per
    # coordinate), so ends closer than 1.5e-4 unit are the same point: no program in the corpus
    # has an arc shorter than that, and rs274 itself decides a full circle from exact numbers.
    tol = 1.5e-4 * unit_mm
    if abs(start[i1] - end[i1]) < tol and abs(start[i2] - end[i2]) < tol:
        d = 2.0 * math.pi
    return d + 2.0 * math.pi * (abs(rotation) - 1)


def _turned_plane(plane: str, ccw: bool, rot_deg: float) -> tuple[str, bool]:
    """An arc's plane and direction in the work frame when its system is turned by ``rot_deg``
    about Z (LinuxCNC's canon turns the plane's basis): the plane's normal turned, which must
    lie along a principal axis; a normal that ends up pointing the negative way flips the
    direction as seen from the positive end. Otherwise the plane is "tilted"."""
    normal = {"XY": (0.0, 0.0, 1.0), "XZ": (0.0, 1.0, 0.0), "YZ": (1.0, 0.0, 0.0)}[plane]
    t = math.radians(rot_deg)
    n = (
        normal[0] * math.cos(t) - normal[1] * math.sin(t),
        normal[0] * math.sin(t) + normal[1] * math.cos(t),
        normal[2],
    )
    for axis, name in ((0, "YZ"), (1, "XZ"), (2, "XY")):
        if abs(abs(n[axis]) - 1.0) < 1e-9:
            return name, ccw if n[axis] > 0 else not ccw
    return "tilted", ccw


def _to_work(p: list[float], g5x: list[float], g92: list[float], rot_deg: float) -> list[float]:
    """Program point [mm] -> work frame [mm], as emccanon.cc's rotate_and_offset_pos."""
    if not any(g5x) and not any(g92) and rot_deg == 0.0:
        return p
    x, y, z = p[0] + g92[0], p[1] + g92[1], p[2] + g92[2]
    if rot_deg != 0.0:
        t = math.radians(rot_deg)
        x, y = x * math.cos(t) - y * math.sin(t), x * math.sin(t) + y * math.cos(t)
    return [x + g5x[0], y + g5x[1], z + g5x[2]]


def _from_work(w: list[float], g5x: list[float], g92: list[float], rot_deg: float) -> list[float]:
    """Work frame point [mm] -> program point (emccanon.cc's unoffset_and_unrotate_pos)."""
    if not any(g5x) and not any(g92) and rot_deg == 0.0:
        return w
    x, y, z = w[0] - g5x[0], w[1] - g5x[1], w[2] - g5x[2]
    if rot_deg != 0.0:
        t = -math.radians(rot_deg)
        x, y = x * math.cos(t) - y * math.sin(t), x * math.sin(t) + y * math.cos(t)
    return [x - g92[0], y - g92[1], z - g92[2]]


def parse_canon(stdout: str, unknown: list[str] | None = None) -> tuple[list[dict], float]:
    """Canonical calls -> motions (without lines; ``n``: the block's N word or None) in the work
    frame [mm], and the largest print unit used [mm].

    A plane other than XY/XZ/YZ (rs274 prints ``CANON_PLANE_UNKNOWN`` for G17.1-G19.1) is
    remembered: straight moves do not need it, an arc in it does. What this cannot read (a call
    not in QUIET_CALLS nor a motion, an arc in an unknown plane) raises RuntimeError, as an
    expectation must not miss a motion; with ``unknown`` given, it is noted there instead (one
    text per call) and the run goes on (an arc in an unknown plane then becomes kind "other",
    its end unknown: the position is kept).
    """

    def not_read(what: str) -> None:
        if unknown is None:
            raise RuntimeError(what)
        unknown.append(what)

    scale, plane, feed = 1.0, "XY", 0.0
    # G95: rs274 passes F per revolution (SET_FEED_MODE(spindle, 1)) and LinuxCNC's motion
    # multiplies it by the spindle speed; gantry-sim's feed is that path speed [mm/min]
    per_rev, rpm = False, 0.0
    pos = [0.0, 0.0, 0.0]  # work frame
    g5x, g92, rot = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 0.0
    unit_max = 1.0
    motions: list[dict] = []
    for raw in stdout.splitlines():
        m = CANON_RE.match(raw)
        if not m:
            if raw.strip():
                raise RuntimeError(f"unrecognised rs274 output line: {raw!r}")
            continue
        nword, name, args = m.groups()
        n = int(nword) if nword.isdigit() else None
        if name == "SET_G5X_OFFSET":
            g5x = [v * scale for v in _nums(args)[1:4]]
        elif name == "SET_G92_OFFSET":
            g92 = [v * scale for v in _nums(args)[0:3]]
        elif name == "SET_XY_ROTATION":
            rot = _nums(args)[0]
        elif name == "USE_LENGTH_UNITS":
            scale = INCH_MM if "INCHES" in args else 1.0
        elif name == "SELECT_PLANE":
            plane = PLANES.get(args.strip(), args.strip())
        elif name == "SET_FEED_MODE":
            per_rev = int(_nums(args)[1]) == 1
        elif name == "SET_SPINDLE_SPEED":
            rpm = _nums(args)[1]
        elif name == "SET_FEED_RATE":
            feed = _nums(args)[0] * scale
        elif name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            v = _nums(args)
            prog = [v[0] * scale, v[1] * scale, v[2] * scale]
            end = _to_work(prog, g5x, g92, rot)
            mo = {
                "n": n,
                "kind": "rapid" if name == "STRAIGHT_TRAVERSE" else "linear",
                "start": pos,
                "end": end,
            }
            if name == "STRAIGHT_FEED":
                mo["feed"] = feed * rpm if per_rev else feed
            motions.append(mo)
            pos = end
            unit_max = max(unit_max, scale)
        elif name == "ARC_FEED" and plane not in PLANE_AXES:
            not_read(f"ARC_FEED({args}) in plane {plane}, whose axes are not known")
            motions.append({"n": n, "kind": "other", "start": pos, "end": pos, "call": name})
        elif name == "ARC_FEED":
            v = _nums(args)
            prog = _from_work(pos, g5x, g92, rot)  # offsets may have changed since the last move
            i1, i2, k = PLANE_AXES[plane]
            rotation = int(v[4])
            end = [0.0, 0.0, 0.0]
            end[i1], end[i2], end[k] = v[0] * scale, v[1] * scale, v[5] * scale
            center = [0.0, 0.0, 0.0]
            center[i1], center[i2], center[k] = v[2] * scale, v[3] * scale, prog[k]
            work_plane, ccw = _turned_plane(plane, rotation > 0, rot)
            motions.append(
                {
                    "n": n,
                    "kind": "arc",
                    "start": pos,
                    "end": _to_work(end, g5x, g92, rot),
                    "feed": feed * rpm if per_rev else feed,
                    "plane": work_plane,
                    "direction": "ccw" if ccw else "cw",
                    "center": _to_work(center, g5x, g92, rot),
                    "radius": math.hypot(prog[i1] - center[i1], prog[i2] - center[i2]),
                    "turns": abs(rotation),
                    "angle": _sweep(plane, prog, end, center, rotation, scale),
                }
            )
            pos = motions[-1]["end"]
            unit_max = max(unit_max, scale)
        elif name in OTHER_MOTIONS:
            v = _nums(args) if name != "NURBS_FEED" else [*pos]
            end = [v[0] * scale, v[1] * scale, v[2] * scale]
            motions.append({"n": n, "kind": "other", "start": pos, "end": end, "call": name})
            pos = end
        elif name not in QUIET_CALLS:
            not_read(f"unexpected canonical call {name}({args})")
    return motions, unit_max


def _strip_n(m: dict) -> dict:
    return {kk: vv for kk, vv in m.items() if kk not in ("line", "n")}


def numbered(text: str) -> bool:
    """Every non-blank line opens with N<its line number>."""
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    for k, ln in enumerate(lines, 1):
        if ln.strip() in ("", "%"):
            continue
        m = N_LINE_RE.match(ln)
        if not m or int(m.group(1)) != k:
            return False
    return True


def derive_numbered(text: str) -> tuple[list[dict], dict | None, float, str]:
    """One run; lines from the N words of the motions and of the failing block."""
    rc, out, err = run_rs274(text)
    raw = f"# rs274 -g exit status {rc}\n# --- stdout\n{out}# --- stderr\n{err}"
    full, unit = parse_canon(out)
    motions = []
    for m in full:
        if m["n"] is None:
            raise RuntimeError("a motion without an N word in a numbered program")
        motions.append({"line": m["n"], **_strip_n(m)})
    error = None
    if rc != 0:
        msg = error_message(err)
        n_lines = max(1, len(text.split("\n")) - (1 if text.endswith("\n") else 0))
        tail = [ln for ln in err.splitlines() if ln.strip()]
        found = N_LINE_RE.match(tail[-1]) if tail else None
        if msg in EOF_MESSAGES or found is None:
            line = n_lines
        else:
            line = int(found.group(1))
        error = {"line": line, "message": msg or f"rs274 exit status {rc}"}
    return motions, error, unit, raw


def derive(text: str) -> tuple[list[dict], dict | None, float, str]:
    """Run the program and its prefixes -> (motions with lines, error or None, unit [mm], raw)."""
    if numbered(text):
        return derive_numbered(text)
    rc, out, err = run_rs274(text)
    raw = f"# rs274 -g exit status {rc}\n# --- stdout\n{out}# --- stderr\n{err}"
    full, unit = parse_canon(out)
    full = [_strip_n(m) for m in full]
    full_msg = error_message(err) if rc != 0 else None
    # physical lines, split on "\n" only, each keeping its own ending ("\r\n" stays intact)
    lines = re.findall(r"[^\n]*\n|[^\n]+$", text)
    motions: list[dict] = []
    error = None
    for k in range(1, len(lines) + 1):
        prc, pout, perr = run_rs274("".join(lines[:k]))
        pm, _ = parse_canon(pout)
        pm = [_strip_n(m) for m in pm]
        if pm[: len(motions)] != [_strip_n(m) for m in motions]:
            raise RuntimeError(f"prefix {k} changed earlier motions")
        for m in pm[len(motions) :]:
            motions.append({"line": k, **m})
        msg = error_message(perr) if prc != 0 else None
        if prc != 0 and msg not in EOF_MESSAGES:
            error = {"line": k, "message": msg or f"rs274 exit status {prc}"}
            break
    if error is None and rc != 0:
        error = {"line": max(1, len(lines)), "message": full_msg or f"rs274 exit status {rc}"}
    if error is not None and (full_msg or "").split(":")[0] != error["message"].split(":")[0]:
        raise RuntimeError(f"prefix error {error} differs from the whole program's {full_msg!r}")
    if [_strip_n(m) for m in motions] != full:
        raise RuntimeError("prefix motions differ from the whole program's")
    return motions, error, unit, raw


def main(names: list[str]) -> int:
    version = rs274_version()
    programs = sorted((DATA / "programs").glob("*.ngc"))
    if names:
        programs = [p for p in programs if p.stem in names]
    (DATA / "expected").mkdir(parents=True, exist_ok=True)
    (DATA / "raw").mkdir(parents=True, exist_ok=True)
    live = {p.stem for p in sorted((DATA / "programs").glob("*.ngc"))}
    for stale in list((DATA / "expected").glob("*.json")) + list((DATA / "raw").glob("*.txt")):
        if stale.stem not in live:
            stale.unlink()
    for prog in programs:
        motions, error, unit, raw = derive(prog.read_bytes().decode("utf-8"))
        doc = {
            "program": prog.name,
            "origin": f"rs274 -g, LinuxCNC {version}, generated by scripts/regen_rs274_expected.py",
            "lines_derived": LINES_DERIVED,
            "print_unit_mm": unit,
            "motions": motions,
            "error": error,
        }
        (DATA / "expected" / f"{prog.stem}.json").write_text(json.dumps(doc, indent=1) + "\n")
        (DATA / "raw" / f"{prog.stem}.txt").write_text(raw)
        status = f"error line {error['line']}: {error['message']}" if error else "ok"
        print(f"{prog.stem}: {len(motions)} motions, {status}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
