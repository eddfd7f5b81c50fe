"""``gantry``: a thin dispatcher over the subcommands in :mod:`gantry_sim.sim.commands`.

Exit status: 0 success; 1 a gate set on the command line failed; 2 invalid input or an output
that cannot be written, reported as ``FILE:LINE: error: MESSAGE`` (or ``FILE: error: MESSAGE``)
on stderr, never a traceback; 3 an internal error (a bug in gantry-sim): one line on stderr,
the traceback only with ``--debug`` or ``GANTRY_DEBUG=1``.
Start-up stays quick: each command module imports mujoco / matplotlib only inside ``run``.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import signal
import sys
import threading
import traceback
from collections.abc import Sequence

from gantry_sim.controller.errors import GantryError, one_line
from gantry_sim.sim.interrupts import Terminated, caught, on_signal, reset, run_command

#: subcommand -> module in sim.commands defining ``HELP``, ``add_arguments(parser)`` and
#: ``run(args) -> int``.
COMMANDS: dict[str, str] = {
    "parse": "gantry_sim.sim.commands.parse",
    "plan": "gantry_sim.sim.commands.plan",
    "run": "gantry_sim.sim.commands.run",
    "ballbar": "gantry_sim.sim.commands.ballbar",
    "tune": "gantry_sim.sim.commands.tune",
    "sweep": "gantry_sim.sim.commands.sweep",
    "machine": "gantry_sim.sim.commands.machine",
    "compare": "gantry_sim.sim.commands.compare",
}
#: exit statuses (README, "Exit status")
EXIT_OK, EXIT_GATE, EXIT_INPUT, EXIT_INTERNAL = 0, 1, 2, 3
#: MuJoCo's choice of OpenGL backend; "disable" skips it (gantry renders nothing)
MUJOCO_GL_ENV = "MUJOCO_GL"
#: environment variable that shows the traceback of an internal error (like --debug)
DEBUG_ENV = "GANTRY_DEBUG"
DEBUG_HELP = f"show the traceback of an internal error (also: {DEBUG_ENV}=1)"


def _version() -> str:
    """The installed gantry-sim's version (its distribution metadata)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("gantry-sim")
    except PackageNotFoundError:  # run from a source tree that is not installed
        return "unknown (not installed)"


class _VersionAction(argparse.Action):
    """``--version``, reading the metadata only when asked (importlib.metadata costs ~20 ms)."""

    def __init__(self, option_strings: Sequence[str], dest: str, help: str | None = None) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, help=help)

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: object,
        option_string: str | None = None,
    ) -> None:
        print(f"gantry {_version()}")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gantry",
        description="Simulate a 3-axis gantry through G-code arcs and measure how closely it follows them.",
    )
    parser.add_argument(
        "--version", action=_VersionAction, help="print gantry-sim's version and exit"
    )
    parser.add_argument("--debug", action="store_true", help=DEBUG_HELP)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module_name in COMMANDS.items():
        module = importlib.import_module(module_name)
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=DEBUG_HELP)
        p.set_defaults(_run=module.run)
    return parser


def _interrupted_by(exc: BaseException) -> str | None:
    """ "terminated" or "interrupted" when ``exc`` came from a SIGTERM or a Ctrl-C that an
    extension module turned into another exception (its cause or context chain), else None."""
    seen: set[int] = set()
    e: BaseException | None = exc
    while e is not None and id(e) not in seen:
        seen.add(id(e))
        if isinstance(e, Terminated):
            return "terminated"
        if isinstance(e, KeyboardInterrupt):
            return "interrupted"
        e = e.__cause__ or e.__context__
    signum = caught()
    if signum is None:
        return None
    return "terminated" if signum == signal.SIGTERM else "interrupted"


def _silence_stdout() -> None:
    """Point fd 1 at /dev/null so the interpreter's final flush cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)
        os.close(devnull)
    except OSError:
        pass


#: errno values of a write that found its file system full (never a bug in gantry-sim)
_FULL = frozenset({errno.ENOSPC, errno.EDQUOT})


def _full_temporary_folder(exc: OSError) -> str:
    """The message for a file system found full by a write to an open file: the outputs are
    written through paths (their errors name them), so this is a spill in the temporary
    folder (the plan's blocks and the moves: controller.spill; the trace's deflated arrays:
    sim.deflate_zip; the percentile's samples: sim.percentile; plan --out's spools:
    sim.plan_samples)."""
    import tempfile

    return (
        f"{tempfile.gettempdir()}: error: {exc.strerror} (the file system is full): "
        "gantry-sim spills a long run's data to the temporary folder while it runs; free "
        "space there, or point TMPDIR at a folder with room"
    )


def _stdout_error(exc: OSError) -> int:
    _silence_stdout()
    if exc.errno == errno.EPIPE:
        return EXIT_OK  # the reader went away (e.g. `gantry parse ... | head`): not our error
    print(f"<stdout>: error: cannot write the output: {exc.strerror}", file=sys.stderr)
    return EXIT_INPUT


def _internal_error(exc: BaseException, debug: bool) -> int:
    if debug:
        import traceback

        traceback.print_exception(exc, file=sys.stderr)
    where = ""
    tb = exc.__traceback__
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    if tb is not None:
        where = f" at {os.path.basename(tb.tb_frame.f_code.co_filename)}:{tb.tb_lineno}"
    detail = f"{type(exc).__name__}: {exc}".splitlines()[0][:300]
    hint = "" if debug else f"; rerun with --debug (or {DEBUG_ENV}=1) for the traceback"
    print(
        f"gantry: internal error ({detail}{where}), please report it with the command and its input files{hint}",
        file=sys.stderr,
    )
    return EXIT_INTERNAL


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``gantry`` with ``argv`` (default: sys.argv[1:]) and return the exit status."""
    if sys.stderr is None:  # started with stderr closed: messages go nowhere, but no crash
        sys.stderr = open(os.devnull, "w")  # lives as long as the process
    # gantry never renders with OpenGL: without this, `import mujoco` imports pyGLFW, which
    # starts `python -c` children to probe the GLFW library (0.1 s per import); a sweep worker
    # stopped mid-import orphaned one, whose BrokenPipeError traceback then reached the user's
    # stderr after "gantry: terminated". Set before any subcommand (or sweep worker, which
    # inherits the environment) imports mujoco; a value the user set is kept.
    os.environ.setdefault(MUJOCO_GL_ENV, "disable")
    args = build_parser().parse_args(argv)
    debug = bool(args.debug) or os.environ.get(DEBUG_ENV, "") not in ("", "0")
    if sys.stdout is None:
        print("<stdout>: error: standard output is closed", file=sys.stderr)
        return EXIT_INPUT
    real_stdout = sys.stdout
    sys.stdout = _GuardedStdout(real_stdout)
    previous = None
    reset()
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, on_signal)
    try:
        return _dispatch(args, debug)
    finally:
        sys.stdout = real_stdout
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        if "gantry_sim.sim.outdir" in sys.modules:  # only a command with --out imports it
            from gantry_sim.sim.outdir import remove_new_empty_folders

            remove_new_empty_folders()


def _dispatch(args: argparse.Namespace, debug: bool) -> int:
    try:
        status = int(args._run(args))
        sys.stdout.flush()
        return status
    except GantryError as exc:
        _flush_quietly()
        print(str(exc), file=sys.stderr)
        return EXIT_INPUT
    except StdoutError as exc:
        return _stdout_error(exc)
    except OSError as exc:
        if exc.filename is not None:  # a file-system error on a path we were given
            print(f"{one_line(str(exc.filename))}: error: {exc.strerror}", file=sys.stderr)
            return EXIT_INPUT
        if exc.errno in _FULL:  # writing an open file: the spills in the temporary folder
            _flush_quietly()
            print(_full_temporary_folder(exc), file=sys.stderr)
            return EXIT_INPUT
        return _internal_error(exc, debug)
    except KeyboardInterrupt:
        print("gantry: interrupted", file=sys.stderr)
        return 128 + signal.SIGINT
    except Terminated:
        print("gantry: terminated", file=sys.stderr)
        return 128 + signal.SIGTERM
    except Exception as exc:  # a bug: one line, exit 3 (README, "Exit status")
        why = _interrupted_by(exc)
        if why is not None:
            if debug:
                traceback.print_exc()
            print(f"gantry: {why}", file=sys.stderr)
            return 128 + (signal.SIGTERM if why == "terminated" else signal.SIGINT)
        return _internal_error(exc, debug)


def _flush_quietly() -> None:
    try:
        sys.stdout.flush()
    except OSError:
        _silence_stdout()


class StdoutError(OSError):
    """Writing to standard output failed (closed pipe, full device, I/O error)."""


class _GuardedStdout:
    """sys.stdout whose write/flush errors are :class:`StdoutError`, so they are told apart
    from errors on files (which carry their path)."""

    def __init__(self, stream) -> None:
        self._stream = stream

    def write(self, text: str) -> int:
        try:
            try:
                return self._stream.write(text)
            except UnicodeEncodeError:  # a lone surrogate read from a report, an ASCII stdout
                encoding = getattr(self._stream, "encoding", None) or "utf-8"
                return self._stream.write(
                    text.encode(encoding, "backslashreplace").decode(encoding)
                )
        except OSError as exc:
            raise StdoutError(exc.errno, exc.strerror) from None

    def flush(self) -> None:
        try:
            self._stream.flush()
        except OSError as exc:
            raise StdoutError(exc.errno, exc.strerror) from None

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


def entry() -> None:
    """``gantry`` with this module imported first; the console script is sim.console.entry,
    which installs the signal handling before this module's imports."""
    run_command(lambda: main)


if __name__ == "__main__":  # python -m gantry_sim.sim.cli
    entry()
