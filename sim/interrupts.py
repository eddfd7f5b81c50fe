"""Ctrl-C and SIGTERM in the ``gantry`` process: one interruption, unwound once, never a commit
cut in half.

:func:`install` (the console script's first step, sim.console) points SIGINT and SIGTERM at
:func:`on_signal`, which raises ``KeyboardInterrupt`` or :class:`Terminated` for the first
signal only: a second Ctrl-C while the first unwinds (staging folders removed, workers
stopped) is ignored, so the clean-up is never cut short and no traceback reaches the user; a
third ends the process at once (a clean-up that hangs, an interruption something swallowed).
Inside :func:`deferred` (an output folder's commit, a worker's start) a signal is held and
raised when the block ends, so the block runs whole or not at all; so is every import of the
main thread (a compiled module interrupted in its initialisation aborted the process).

This module imports nothing beyond the standard library's core: the console script installs
it before anything else is imported.
"""

from __future__ import annotations

import atexit
import builtins
import gc
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from functools import partial
from types import FrameType, ModuleType

__all__ = [
    "EXIT_INTERRUPTED",
    "EXIT_TERMINATED",
    "Terminated",
    "caught",
    "deferred",
    "install",
    "leave",
    "on_signal",
    "reset",
    "run_command",
    "status_of",
]

#: exit statuses of an interrupted command (README, "Exit status")
EXIT_INTERRUPTED = 128 + signal.SIGINT
EXIT_TERMINATED = 128 + signal.SIGTERM
#: the signals handled
SIGNALS = (signal.SIGINT, signal.SIGTERM)
#: the stderr line for each exit status of an interruption
MESSAGES = {EXIT_INTERRUPTED: "gantry: interrupted", EXIT_TERMINATED: "gantry: terminated"}


class Terminated(BaseException):
    """SIGTERM arrived: unwind (staging folders removed, sweep workers stopped), exit 143."""


#: the signal being unwound (None: none yet)
_caught: int | None = None
#: signals held by :func:`deferred` (the first only), raised when the outermost block ends
_held: list[int] = []
#: signals that came while the first one unwound
_repeats = 0
#: that many of them end the process at once (a third Ctrl-C)
FORCE_AFTER = 2
#: how deep the main thread is in :func:`deferred` blocks
_depth = 0
#: once the command has ended: a signal exits at once (no exception in the interpreter's
#: finalisation)
_leaving = False


def _exception(signum: int) -> BaseException:
    return Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


def on_signal(signum: int, frame: FrameType | None) -> None:
    """The handler of SIGINT and SIGTERM (see the module docstring)."""
    global _caught, _repeats
    if _leaving:
        leave(128 + signum, clean=False)
    if _caught is not None:
        _repeats += 1
        if _repeats >= FORCE_AFTER:  # the clean-up hangs, or something swallowed the first
            leave(128 + _caught, clean=False)
        return  # the first interruption is unwinding: let its clean-up finish
    if _depth:
        if not _held:
            _held.append(signum)
        return
    _caught = signum
    raise _exception(signum)


def caught() -> int | None:
    """The signal this command is unwinding from (None: none)."""
    return _caught


def reset() -> None:
    """Forget an earlier interruption (a new command starts in this process: sim.cli.main)."""
    global _caught, _repeats
    _caught = None
    _repeats = 0
    _held.clear()


def install() -> None:
    """Handle SIGINT (unless it was ignored when the process started, as in a background job)
    and SIGTERM with :func:`on_signal`, then unblock both: a signal that arrived while a parent
    held them blocked (the mask passes through ``exec``) is raised now, inside the handling."""
    if threading.current_thread() is not threading.main_thread():
        return
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    atexit.register(_ignore_at_exit)  # registered first: called last
    builtins.__import__ = _whole_import
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, SIGNALS)


def _ignore_at_exit() -> None:
    """The last exit handler: ignore both signals for the interpreter's last steps, where it
    would put back their default action (a signal there killed a finished run: status -2,
    no message). Ignored, not blocked: a library's threads (numpy's BLAS) would take a
    signal blocked in this one. One that comes then is lost with the process, which exits
    with its status."""
    for signum in SIGNALS:
        signal.signal(signum, signal.SIG_IGN)


@contextmanager
def deferred() -> Iterator[None]:
    """Run the block whole: a Ctrl-C or SIGTERM that arrives inside it (with :func:`on_signal`
    installed) is raised when the block ends. A no-op outside the main thread."""
    if threading.get_ident() != _MAIN_THREAD:
        yield
        return
    _hold()
    try:
        yield
    finally:
        _release()


def _hold() -> None:
    """Enter a block run whole (:func:`deferred`): signals are held from now on."""
    global _depth
    _depth += 1


def _release() -> None:
    """Leave a block run whole: the outermost one raises the signal held in it, if any."""
    global _depth
    _depth -= 1
    if not _depth and _held:
        _raise_held()


def _raise_held() -> None:
    """Raise the signal :func:`on_signal` held (unless one is unwinding already)."""
    global _caught
    signum = _held.pop()
    _held.clear()
    if _caught is None:
        _caught = signum
        raise _exception(signum)


def _whole_import(
    name: str,
    globals: Mapping[str, object] | None = None,
    locals: Mapping[str, object] | None = None,
    fromlist: Sequence[str] | None = (),
    level: int = 0,
) -> ModuleType:
    """``builtins.__import__`` with the main thread's imports held whole (:func:`deferred`):
    an exception raised inside a compiled module's initialisation (pybind11's: mujoco,
    ruckig) aborted the process (status -6, a fatal error's dump) or left it half set up; the
    signal is raised once the outermost import is done."""
    if threading.get_ident() != _MAIN_THREAD:
        return _REAL_IMPORT(name, globals, locals, fromlist, level)
    _hold()
    try:
        return _REAL_IMPORT(name, globals, locals, fromlist, level)
    finally:
        _release()


_REAL_IMPORT = builtins.__import__
_MAIN_THREAD = threading.main_thread().ident


def status_of(exc: BaseException) -> int | None:
    """The exit status of an interruption (130 for Ctrl-C, 143 for SIGTERM), else None."""
    if isinstance(exc, Terminated):
        return EXIT_TERMINATED
    if isinstance(exc, KeyboardInterrupt):
        return EXIT_INTERRUPTED
    return None


def leaving() -> None:
    """The command has ended: from now on a signal ends the process at once with its status
    and message (sim.console, before the interpreter's finalisation)."""
    global _leaving
    _leaving = True


def leave(status: int, clean: bool = True, message: bool = True) -> None:
    """End the process now with ``status`` (an interruption's): its message on stderr, and
    with ``clean`` the clean-up an unwound command does last (empty output folders it made,
    helper processes still running). Without the interpreter's finalisation: a signal that
    arrived inside ``import mujoco`` leaves that extension half set up, and tearing it down
    aborted the process (exit 134 after "gantry: terminated")."""
    global _caught, _leaving
    _leaving = False
    _caught = _caught or signal.SIGINT  # nothing below is interrupted again
    if clean:
        _clean_up()
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except BaseException:  # a closed or full stream: ending anyway
            pass
    if message:
        try:
            os.write(2, (MESSAGES.get(status, "gantry: interrupted") + "\n").encode())
        except OSError:
            pass
    os._exit(status)


def _clean_up() -> None:
    """What an interrupted command leaves to do: the output folders it made while empty
    (sim.outdir), its helper processes (sim.worker_pipes), where those modules were used, and
    the objects whose finalizers release something outside the process."""
    outdir = sys.modules.get("gantry_sim.sim.outdir")
    pipes = sys.modules.get("gantry_sim.sim.worker_pipes")
    mp_util = sys.modules.get("multiprocessing.util")
    for step in (
        getattr(pipes, "stop_all", None),
        getattr(outdir, "remove_new_empty_folders", None),
        gc.collect,  # multiprocessing's semaphores unlinked by their finalizers (a sweep's)
        # and those of the ones still referenced, as the interpreter's exit runs them (a
        # sweep's pool queues: left to the resource tracker, they were "leaked semaphore
        # objects" on stderr after "gantry: terminated")
        partial(mp_util._run_finalizers, 0) if mp_util is not None else None,
    ):
        if step is not None:
            try:
                step()
            except Exception:  # best effort: the interruption is what is reported
                pass


def run_command(load_main: Callable[[], Callable[[], int]]) -> None:
    """Install the handlers, then run ``load_main()()`` (sim.cli.main, imported by
    ``load_main`` inside the handling) and exit with its status. After an interruption the
    process ends by :func:`leave`; everything gantry cleans up has been cleaned by then (the
    interruption unwinds through it)."""
    status: int | str | None
    try:
        install()
        status = load_main()()
    except SystemExit as exc:  # argparse's --help, --version and usage errors
        status = exc.code
    except BaseException as exc:
        code = status_of(exc)
        if code is None:
            raise
        leave(code)  # raised outside sim.cli's own handling (imports, parsing)
        return
    leaving()
    if status in (EXIT_INTERRUPTED, EXIT_TERMINATED):
        leave(int(status), message=False)  # sim.cli said how it stopped
    sys.exit(status)
