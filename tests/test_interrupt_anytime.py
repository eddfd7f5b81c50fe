"""Ctrl-C and SIGTERM at any moment of a real ``gantry`` process (the console script): exit 130
with ``gantry: interrupted`` or 143 with ``gantry: terminated``, no traceback, no outputs half
written, no helper process or temporary file left behind.

Before, a signal during the first ~0.2 s (the modules importing) printed a traceback and the
process died by the signal (-2, -15). Outcomes are asserted, never times: each delay only
moves where the signal lands (interpreter start-up, imports, parsing, simulating).

The child starts with both signals blocked (``preexec_fn``): a signal sent while the
interpreter itself starts (before it runs a line of gantry, where no Python program can
handle one) stays pending until sim.interrupts.install unblocks it, which is what makes a
0 s delay deterministic on a loaded machine; every later delay lands in gantry's own code.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc, signals")

#: about 200 s of machine time: still simulating long after every early delay
LONG = "G21 G90\nG1 X100 F60\nG1 X0\nM2\n"
CONTRACT = {
    signal.SIGINT: (130, "gantry: interrupted\n"),
    signal.SIGTERM: (143, "gantry: terminated\n"),
}


def _console_script() -> list[str]:
    """The installed ``gantry`` script beside this interpreter, else the same entry by -m."""
    script = Path(sys.executable).with_name("gantry")
    if script.is_file():
        return [sys.executable, str(script)]
    return [sys.executable, "-m", "gantry_sim.sim.console"]


def _block_signals() -> None:
    # as a terminal's job: Ctrl-C delivered (a test runner started in the background by a
    # non-interactive shell passes SIGINT on ignored, which gantry respects)
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})


def _start(
    tmp_path: Path, *args: str, workers: bool = False, group: bool = False
) -> subprocess.Popen:
    env = dict(os.environ, TMPDIR=str(tmp_path / "tmp"))
    if workers:  # the run's plot worker and a streamed run's analysis worker
        env.update(GANTRY_PLOT_WORKER="1", GANTRY_ANALYSIS_WORKER="1")
    (tmp_path / "tmp").mkdir(exist_ok=True)
    return subprocess.Popen(
        [*_console_script(), *args],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_block_signals,
        start_new_session=group,  # a group of its own, as a terminal's foreground job
    )


def _gantry_processes(folder: Path) -> list[str]:
    """gantry processes (the run, its workers, forked children) working in ``folder``."""
    found = []
    for proc in Path("/proc").glob("[0-9]*"):
        try:
            cmd = (proc / "cmdline").read_bytes()
            if b"gantry" in cmd and (proc / "cwd").resolve() == folder.resolve():
                found.append(cmd.replace(b"\0", b" ").decode(errors="replace"))
        except OSError:
            continue
    return found


def _assert_contract(proc: subprocess.Popen, sig: int, tmp_path: Path) -> None:
    _, err = proc.communicate(timeout=120)
    assert (proc.returncode, err) == CONTRACT[sig]
    out = tmp_path / "out"
    assert not out.exists() or sorted(os.listdir(out)) == []  # nothing half-written
    assert list((tmp_path / "tmp").iterdir()) == []  # no spill file in TMPDIR
    deadline = time.monotonic() + 30  # forked children die with their parent (PDEATHSIG)
    while _gantry_processes(tmp_path) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert _gantry_processes(tmp_path) == []


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["INT", "TERM"])
@pytest.mark.parametrize("delay_s", [0.0, 0.05, 0.1, 0.3])
def test_a_signal_while_gantry_starts(tmp_path, sig, delay_s):
    (tmp_path / "long.ngc").write_text(LONG)
    proc = _start(tmp_path, "run", "long.ngc", "--out", "out")
    time.sleep(delay_s)
    proc.send_signal(sig)
    _assert_contract(proc, sig, tmp_path)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["INT", "TERM"])
def test_a_signal_mid_run_stops_the_workers_and_leaves_no_spill(tmp_path, sig):
    """A streamed run (its analysis worker, its plot worker, the trace spilled to TMPDIR),
    signalled once its output folder exists (it is made just before the simulation)."""
    (tmp_path / "long.ngc").write_text(LONG)
    proc = _start(tmp_path, "run", "long.ngc", "--out", "out", workers=True)
    while not (tmp_path / "out").exists() and proc.poll() is None:
        time.sleep(0.01)
    time.sleep(0.3)
    proc.send_signal(sig)
    _assert_contract(proc, sig, tmp_path)


def test_ctrl_c_pressed_twice_to_the_process_group_mid_run(tmp_path):
    """A terminal's Ctrl-C reaches the whole foreground group (the run and any child it forked
    to plan); pressed twice, the second does not cut the first one's clean-up short: one
    message, exit 130."""
    (tmp_path / "long.ngc").write_text(LONG)
    proc = _start(tmp_path, "run", "long.ngc", "--out", "out", workers=True, group=True)
    while not (tmp_path / "out").exists() and proc.poll() is None:
        time.sleep(0.01)
    for _ in range(2):
        try:
            os.killpg(proc.pid, signal.SIGINT)
        except ProcessLookupError:  # it ended at the first
            break
    _assert_contract(proc, signal.SIGINT, tmp_path)


def _python(code: str, cwd) -> subprocess.CompletedProcess:
    """``python -c code`` run in ``cwd``, its output captured as text."""
    return subprocess.run(
        [sys.executable, "-c", code], cwd=cwd, capture_output=True, text=True, timeout=60
    )


def test_a_signal_inside_an_import_is_raised_once_the_import_is_done(tmp_path):
    """A compiled module (pybind11's: mujoco, ruckig) interrupted in its initialisation
    aborted the process (-6, a fatal error's dump): the main thread's imports are held whole
    (sim.interrupts), and the signal is raised at the import statement once it is done."""
    (tmp_path / "signalled.py").write_text(
        "import os, signal\nos.kill(os.getpid(), signal.SIGTERM)\nDONE = True\n"
    )
    code = (
        "import sys\nfrom gantry_sim.sim import interrupts\ninterrupts.install()\n"
        "try:\n    import signalled\nexcept interrupts.Terminated:\n"
        "    print(sys.modules['signalled'].DONE)\n"
    )
    out = _python(code, tmp_path)
    assert (out.returncode, out.stdout, out.stderr) == (0, "True\n", "")


def test_a_third_ctrl_c_ends_gantry_even_when_the_first_was_swallowed(tmp_path):
    """The second is ignored (the first one's clean-up goes on); if that clean-up hangs, or
    a library swallowed the first KeyboardInterrupt, the third ends the process: 130."""
    code = (
        "import os, signal, time\nfrom gantry_sim.sim import interrupts\n"
        "signal.signal(signal.SIGINT, signal.SIG_DFL)\ninterrupts.install()\n"
        "try:\n    os.kill(os.getpid(), signal.SIGINT)\nexcept KeyboardInterrupt:\n    pass\n"
        "os.kill(os.getpid(), signal.SIGINT)\nprint('ignored', flush=True)\n"
        "os.kill(os.getpid(), signal.SIGINT)\ntime.sleep(60)\nprint('not reached')\n"
    )
    out = _python(code, tmp_path)
    assert (out.returncode, out.stdout, out.stderr) == (130, "ignored\n", "gantry: interrupted\n")
