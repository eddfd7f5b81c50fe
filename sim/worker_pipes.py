"""A run's helper processes: a fresh interpreter running one of this package's modules, talked to
over its stdin and stdout (sim.analysis_worker, sim.plot_worker).

A fresh interpreter, not a fork: a forked worker shares the run's heap copy-on-write, and its
allocations landing in pages the planner had freed copied them one by one (1.4 GB private to
the analysis worker at 100,000 mixed blocks); nor multiprocessing's spawn, which runs the
caller's main script again in the worker (a user's script without a ``__main__`` guard would
run twice). A worker ends when its stdin closes: when the run ends, or its process dies,
whatever the cause; an interrupted run also stops every worker it started before it exits
(:func:`stop_all`, called by sim.interrupts.leave), so none outlives it, even briefly.

This module imports nothing heavy (no numpy): a run starts its workers before its own imports.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
from multiprocessing.connection import Connection

from gantry_sim.sim.interrupts import deferred

__all__ = [
    "EARLY_WORKER_CHARS",
    "Pipes",
    "recv_out_of_band",
    "send_out_of_band",
    "serve_stdio",
    "stop_all",
    "worker_wanted",
]


#: A program of this many characters at least gets its analysis worker started before it is
#: parsed (sim.analysis_worker.early_worker), and its plot worker after (sim.plot_worker).
EARLY_WORKER_CHARS = 16_384


class Pipes:
    """``python -m MODULE`` started now, with a :class:`Connection` to its stdin (``out``) and
    one from its stdout (``inp``). The worker runs in a session of its own: a terminal's Ctrl-C
    goes to the run, which closes the worker's stdin."""

    def __init__(self, module: str) -> None:
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
        with deferred():  # started and listed whole: a Ctrl-C here leaves no unlisted worker
            self.proc = subprocess.Popen(
                [sys.executable, "-m", module],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                env=env,
                start_new_session=True,
            )
            assert self.proc.stdin is not None and self.proc.stdout is not None
            self.out = Connection(os.dup(self.proc.stdin.fileno()), readable=False)
            self.inp = Connection(os.dup(self.proc.stdout.fileno()), writable=False)
            self.proc.stdin.close()
            self.proc.stdout.close()
            _LIVE.add(self)

    def stop(self, *, kill: bool = True) -> None:
        """Close its stdin and end it: killed (``kill``: it has nothing left to do, and an
        interpreter tearing down its heap took 0.05-0.07 s), else terminated; then close its
        stdout. Idempotent."""
        if not self.out.closed:
            self.out.close()
        if self.proc.returncode is None:
            if kill:
                self.proc.kill()
            else:
                self.proc.terminate()
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if not self.inp.closed:
            self.inp.close()
        _LIVE.discard(self)


#: the workers started by this process and not stopped yet (:func:`stop_all`)
_LIVE: set[Pipes] = set()


def stop_all() -> None:
    """Stop every worker this process started that is still running (an interrupted run's last
    step: its workers are in sessions of their own, so a terminal's Ctrl-C does not reach
    them, and a busy one would notice its closed stdin only when it next reads)."""
    for pipes in list(_LIVE):
        pipes.stop()


def serve_stdio() -> tuple[Connection, Connection]:
    """In a worker (``python -m MODULE``): (input from stdin, output to stdout), with file
    descriptor 1 pointed at stderr, so a stray print goes to stderr, not into the replies."""
    stdin, stdout = os.dup(0), os.dup(1)
    os.dup2(2, 1)
    return Connection(stdin, writable=False), Connection(stdout, readable=False)


def worker_wanted(env_var: str) -> bool:
    """Whether a worker process can pay here: ``env_var`` not set to 0, a POSIX system, two
    or more cores, an interpreter to start (``sys.executable``: not in every embedding
    application), and not inside controller.forked.one_process (a sweep runs one point per
    core)."""
    from gantry_sim.controller.forked import in_one_process

    return (
        os.environ.get(env_var, "1") != "0"
        and os.name == "posix"
        and bool(sys.executable)
        and (os.cpu_count() or 1) >= 2
        and not in_one_process()
    )


def send_out_of_band(conn: Connection, obj: object) -> None:
    """Send ``obj`` pickled with its arrays' bytes out of band (pickle protocol 5): the pickle
    without them, their sizes, then each array's own memory, so no pickled copy of the arrays
    is ever made (at 100,000 moves the move tables are 57 MB, and pickling them in one piece
    held 126 MB more while it ran; each range's arrays go the same way). :func:`recv_out_of_band`
    reads it."""
    buffers: list[pickle.PickleBuffer] = []
    head = pickle.dumps(obj, protocol=5, buffer_callback=buffers.append)
    views = [b.raw() for b in buffers]
    conn.send((head, [v.nbytes for v in views]))
    for v in views:
        conn.send_bytes(v)


def recv_out_of_band(conn: Connection) -> object:
    """What :func:`send_out_of_band` sent; its arrays own writable memory of their own."""
    head, sizes = conn.recv()
    buffers = []
    for size in sizes:
        buf = bytearray(size)
        conn.recv_bytes_into(buf)
        buffers.append(buf)
    return pickle.loads(head, buffers=buffers)
