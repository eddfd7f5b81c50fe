#!/usr/bin/python3
"""The "display" of gantry_peer.ini: runs one G-code program through LinuxCNC and exits.

LinuxCNC's launcher starts it as ``peer_display.py -ini INIFILE`` once HAL, motion and task are
up, and shuts LinuxCNC down when it returns. It runs under Debian's /usr/bin/python3, whose
``linuxcnc`` module (from linuxcnc-uspace) talks to task. Environment:

* ``PEER_PROGRAM``: the .ngc file to run;
* ``PEER_OUT``: a folder for ``samples.txt`` (halsampler's output: one line per servo period,
  sample number, X Y Z [mm], path speed [mm/s], motion type, program line) and ``run.json``
  (wall-clock time from the run command to idle, the errors LinuxCNC reported).

Steps: estop reset, machine on, home all joints (they home where they stand, at 0), auto mode,
open the program; start halsampler and enable the sampler; run; poll stat every 1 ms until the
interpreter is idle and motion is in position, resuming at once where the program pauses (M0,
M1, M60); disable the sampler, let halsampler drain, stop.
"""

import json
import os
import subprocess
import sys
import time

import linuxcnc


def wait(stat, cond, timeout_s, what):
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        stat.poll()
        if cond(stat):
            return
        time.sleep(0.001)
    raise SystemExit(f"peer_display: timed out waiting for {what}")


def run_to_end(stat, cmd, timeout_s):
    """Wait for the program's end, resuming at once wherever it pauses (M0, M1, M60: an operator
    pressing cycle start without a wait); returns how many times it resumed."""
    t_end, resumes = time.monotonic() + timeout_s, 0
    while time.monotonic() < t_end:
        stat.poll()
        if stat.interp_state == linuxcnc.INTERP_IDLE and stat.inpos and stat.queue == 0:
            return resumes
        if stat.interp_state == linuxcnc.INTERP_PAUSED or stat.paused:
            cmd.auto(linuxcnc.AUTO_RESUME)
            resumes += 1
            time.sleep(0.005)  # (task takes the resume before stat shows it)
        time.sleep(0.001)
    raise SystemExit("peer_display: timed out waiting for program end")


def halcmd(*args):
    return subprocess.run(["halcmd", *args], check=True, capture_output=True, text=True).stdout


def main():
    program = os.path.abspath(os.environ["PEER_PROGRAM"])
    out = os.environ["PEER_OUT"]
    stat, cmd, errors = linuxcnc.stat(), linuxcnc.command(), linuxcnc.error_channel()
    wait(stat, lambda s: s.task_state != 0, 30, "task")
    cmd.state(linuxcnc.STATE_ESTOP_RESET)
    cmd.state(linuxcnc.STATE_ON)
    wait(stat, lambda s: s.task_state == linuxcnc.STATE_ON, 10, "machine on")
    cmd.mode(linuxcnc.MODE_MANUAL)
    cmd.wait_complete()
    cmd.home(-1)
    wait(stat, lambda s: all(s.homed[j] for j in range(s.joints)), 10, "homing")
    cmd.mode(linuxcnc.MODE_AUTO)
    cmd.wait_complete()
    cmd.program_open(program)
    cmd.wait_complete()
    with open(os.path.join(out, "samples.txt"), "w") as f:
        sampler = subprocess.Popen(["halsampler", "-t"], stdout=f)
        time.sleep(0.2)
        halcmd("setp", "sampler.0.enable", "1")
        time.sleep(0.05)
        t0 = time.monotonic()
        cmd.auto(linuxcnc.AUTO_RUN, 0)
        wait(stat, lambda s: s.interp_state != linuxcnc.INTERP_IDLE, 10, "program start")
        resumes = run_to_end(stat, cmd, 3600)
        wall_s = time.monotonic() - t0
        time.sleep(0.1)
        halcmd("setp", "sampler.0.enable", "0")
        wait(stat, lambda s: int(halcmd("getp", "sampler.0.curr-depth")) == 0, 10, "drain")
        time.sleep(0.2)
        sampler.terminate()
        sampler.wait()
    overruns = int(halcmd("getp", "sampler.0.overruns"))
    msgs, notes = [], []
    while (e := errors.poll()) is not None:
        # the program's own (MSG, ...) comments come as display texts, not as errors
        (msgs if e[0] in (linuxcnc.NML_ERROR, linuxcnc.OPERATOR_ERROR) else notes).append(e[1])
    with open(os.path.join(out, "run.json"), "w") as f:
        json.dump(
            {
                "wall_s": wall_s,
                "overruns": overruns,
                "errors": msgs,
                "messages": notes,
                "resumes": resumes,
            },
            f,
        )
    cmd.state(linuxcnc.STATE_OFF)
    return 0


if __name__ == "__main__":
    sys.exit(main())
