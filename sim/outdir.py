"""Outputs that are never half-written, never mixed, on any file system.

An output folder (``gantry run/ballbar/tune/sweep --out DIR``) always holds one whole run, old
or new. The files are written into a hidden staging folder *inside* DIR (so on DIR's own file
system: a mount point, a container volume or a symlink to another disk works, and the final
moves are ``rename``s), under an exclusive lock on DIR held from staging to commit (two runs
into one folder take turns), then committed:

1. a ``.complete`` manifest is added to the staging folder by rename: from here on the run is
   committed and the next writer finishes an interrupted commit instead of discarding it; it
   names the command's files (``owns``) that the new run did not write (``--no-plots``);
2. the old marker (``last``: report.json, ballbar.json, ...) is removed first, then the old
   files the new run replaces and those the manifest names;
3. the new files are moved in, the marker last; the staging folder is removed.

Files that are not the command's (the user's, another command's) are never touched. Steps 1-3,
and the staging folder's creation, are held whole against Ctrl-C and SIGTERM
(sim.interrupts.deferred): a signal then is raised when they are done.

So the marker's presence means "one whole run is here". A writer killed at any moment leaves a
staging folder that the next writer into DIR (holding the lock, so it is stale) either removes
(not committed) or completes (committed). File modes follow the user's umask. Any OSError is
raised as :class:`OutputError` naming the path: exit 2, never a traceback.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
import stat
import tempfile
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from gantry_sim.controller.errors import GantryError
from gantry_sim.sim.interrupts import deferred

STAGE_PREFIX = ".gantry-staging-"
MANIFEST = ".complete"
#: how long a writer waits for another gantry process writing into the same folder [s]
LOCK_WAIT_S = 120.0
#: earlier versions staged in DIR's parent as .DIR.tmp-*; one older than this is debris [s]
LEGACY_STAGE_AGE_S = 3600.0


class OutputError(GantryError):
    """An output path cannot be written (permissions, read-only or full file system, ...)."""


def os_error(exc: OSError, path: Path | str, doing: str = "cannot write") -> OutputError:
    """``exc`` as an OutputError on ``exc.filename`` (or ``path``), with what was attempted."""
    where = exc.filename if isinstance(exc.filename, str) else str(path)
    reason = exc.strerror or type(exc).__name__
    if exc.errno == errno.ENOSPC:
        reason += " (the file system is full)"
    return OutputError(f"{doing}: {reason}", file=where)


def umask() -> int:
    """The process's file-creation mask (read without changing it for longer than a call)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


#: The folders :func:`ensure_dir` created in this process, parents first: a run that fails
#: before writing its outputs leaves none of them behind (:func:`remove_new_empty_folders`).
_CREATED: list[Path] = []


def ensure_dir(out_dir: Path) -> None:
    """Create ``out_dir`` (and its parents) or raise OutputError saying why it cannot be."""
    try:
        if out_dir.exists() and not out_dir.is_dir():
            raise OutputError("--out must be a folder, but this is a file", file=str(out_dir))
        if out_dir.is_symlink() and not out_dir.exists():
            raise OutputError(
                "--out must be a folder, but this is a symbolic link to nothing that exists (a "
                "missing target, or links that lead back to themselves)",
                file=str(out_dir),
            )
        missing = [p for p in (out_dir, *out_dir.parents) if not p.exists()]
        out_dir.mkdir(parents=True, exist_ok=True)
        _CREATED.extend(reversed(missing))
    except OSError as exc:
        raise os_error(exc, out_dir, "cannot create the output folder") from None


def remove_new_empty_folders() -> None:
    """Remove the folders :func:`ensure_dir` created in this process that are still empty,
    deepest first (``gantry`` calls it as it ends): a run that failed before writing, or was
    interrupted, leaves no empty output folder it made; a folder with anything in it, or one
    that was there before, stays."""
    while _CREATED:
        folder = _CREATED.pop()
        with contextlib.suppress(OSError):
            folder.rmdir()  # only an empty folder goes


@contextmanager
def locked(out_dir: Path) -> Iterator[None]:
    """Hold an exclusive flock on the folder itself (no lock file left behind)."""
    import fcntl

    try:
        fd = os.open(out_dir, os.O_RDONLY | os.O_DIRECTORY)
    except OSError as exc:
        raise os_error(exc, out_dir, "cannot open the output folder") from None
    try:
        deadline = time.monotonic() + LOCK_WAIT_S
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() > deadline:
                    raise OutputError(
                        f"another gantry process has been writing here for {LOCK_WAIT_S:g} s",
                        file=str(out_dir),
                    ) from None
                time.sleep(0.05)
            except OSError:
                break  # a file system without flock (some network mounts): write unlocked
        yield
    finally:
        os.close(fd)


def _manifest(stage: Path) -> dict | None:
    """The staging folder's manifest {"last": name or None, "replaces": [names]}, or None."""
    try:
        meta = json.loads((stage / MANIFEST).read_text())
    except (OSError, ValueError):
        return None
    ok = (
        isinstance(meta, dict)
        and (meta.get("last") is None or isinstance(meta.get("last"), str))
        and isinstance(meta.get("replaces"), list)
        and all(isinstance(n, str) and "/" not in n for n in meta["replaces"])
    )
    return meta if ok else None


def _commit(stage: Path, out_dir: Path) -> None:
    """Steps 2-3 of the module docstring for a staging folder holding a manifest; idempotent,
    so it also completes a commit a killed writer left half done. A name that is a folder in
    ``out_dir`` is refused before anything is removed."""
    meta = _manifest(stage)
    if meta is None:  # unreadable: treat as never committed
        shutil.rmtree(stage, ignore_errors=True)
        return
    last, replaces = meta["last"], meta["replaces"]
    pending = sorted(p.name for p in stage.iterdir() if p.name != MANIFEST)
    names = list(dict.fromkeys([*pending, *replaces]))
    for name in names:
        target = out_dir / name
        if target.is_dir() and not target.is_symlink():
            raise OutputError(f"'{name}' in the output folder is a folder", file=str(target))
    if last is not None:
        (out_dir / last).unlink(missing_ok=True)  # first: no marker beside a partial run
    for name in names:
        (out_dir / name).unlink(missing_ok=True)
    for name in sorted(pending, key=lambda n: (n == last, n)):
        os.replace(stage / name, out_dir / name)
    shutil.rmtree(stage)


def recover(out_dir: Path) -> None:
    """Complete committed staging folders left by killed writers; remove the others.

    Call with the folder's lock held: then no live writer owns any staging folder."""
    for stage in sorted(out_dir.glob(STAGE_PREFIX + "*")):
        if not stage.is_dir() or stage.is_symlink():
            continue
        if (stage / MANIFEST).is_file():
            _commit(stage, out_dir)
        else:
            shutil.rmtree(stage, ignore_errors=True)


def clean_legacy_stages(out_dir: Path) -> None:
    """Remove ``.DIR.tmp-*`` folders that earlier versions left beside DIR when killed (only
    those older than LEGACY_STAGE_AGE_S: no live writer takes that long to write)."""
    now = time.time()
    try:
        for stage in out_dir.parent.glob(f".{out_dir.name}.tmp-*"):
            if stage.is_dir() and not stage.is_symlink():
                if now - stage.stat().st_mtime > LEGACY_STAGE_AGE_S:
                    shutil.rmtree(stage, ignore_errors=True)
    except OSError:
        pass  # best effort: never a reason to fail a run


def prepare_output_dir(out_dir: Path) -> None:
    """Check early (before a long simulation) that ``out_dir`` can take outputs: create it,
    clean stale staging folders, and probe that a file can be created in it. An earlier run's
    files stay: a run interrupted before its commit leaves them whole."""
    out_dir = Path(out_dir)
    ensure_dir(out_dir)
    clean_legacy_stages(out_dir)
    with locked(out_dir), deferred():
        try:
            recover(out_dir)
            Path(tempfile.mkdtemp(prefix=STAGE_PREFIX, dir=out_dir)).rmdir()
        except OSError as exc:
            raise os_error(exc, out_dir) from None


def remove_outputs(out_dir: Path, names: Sequence[str], last: str) -> None:
    """Remove an earlier run's files ``names`` from ``out_dir``, its marker ``last`` first (so
    no moment shows a marker beside a partial run), under the folder's lock: what a run that
    failed does, so that its error is not read beside an older run's report. Best effort: a
    folder that cannot be changed keeps them, and the run's own error is what is reported."""
    out_dir = Path(out_dir)
    if not out_dir.is_dir():
        return
    try:
        with locked(out_dir), deferred():
            for name in sorted(names, key=lambda n: n != last):
                (out_dir / name).unlink(missing_ok=True)
    except (OSError, OutputError):
        pass


@contextmanager
def atomic_output_dir(
    out_dir: Path, last: str, owns: Sequence[str], replaces: Sequence[str] = ()
) -> Iterator[Path]:
    """Yield a staging folder inside ``out_dir``; when the body succeeds, commit its files.

    Args:
        out_dir: the output folder (created if needed; files that are not the command's
            are left alone).
        last: the marker file, removed first and moved in last (its presence = a whole run).
        owns: every file the command can write (``last`` included): the commit removes those
            of an earlier run that this one did not write (``gantry run --no-plots`` after a
            run with plots: no old path.png beside the new report.json). Staging a file not
            listed is a bug (RuntimeError).
        replaces: more names to remove from ``out_dir`` at the commit (e.g. a journal).

    If the body raises, or a Ctrl-C or SIGTERM comes before the commit, ``out_dir`` is
    unchanged; one that comes during the commit is raised after it (sim.interrupts.deferred:
    the new run is whole). OSErrors become :class:`OutputError`.
    """
    out_dir = Path(out_dir)
    ensure_dir(out_dir)
    with locked(out_dir):  # held from staging to commit: no other writer removes our stage
        stage: Path | None = None
        try:
            with deferred():
                try:
                    recover(out_dir)  # stale folders of killed writers
                    stage = Path(tempfile.mkdtemp(prefix=STAGE_PREFIX, dir=out_dir))
                except OSError as exc:
                    raise os_error(exc, out_dir) from None
            try:
                yield stage
                staged = _check_owned(stage, last, owns)
                # the earlier run's files this one does not replace, named now: a commit
                # completed by the next writer (sim.outdir.recover) removes these, never a
                # new file it finds moved in already
                stale = [n for n in dict.fromkeys([*owns, *replaces]) if n not in staged]
                with deferred():
                    manifest = stage / (MANIFEST + ".tmp")
                    manifest.write_text(json.dumps({"last": last, "replaces": stale}))
                    os.replace(manifest, stage / MANIFEST)
                    _commit(stage, out_dir)
            except OSError as exc:
                raise os_error(exc, out_dir) from None
        finally:
            if stage is not None:
                shutil.rmtree(stage, ignore_errors=True)


def _check_owned(stage: Path, last: str, owns: Sequence[str]) -> set[str]:
    """The names staged; RuntimeError (a bug) when one is a file ``owns`` omits: a later run
    without it could not remove it."""
    staged = {p.name for p in stage.iterdir()}
    extra = sorted(staged - {last, *owns})
    if extra:
        raise RuntimeError(f"staged files not listed as the command's outputs: {extra}")
    return staged


def check_output_file(path: Path) -> None:
    """Raise OutputError now if ``path`` cannot be an output file (see ``_writable_target``)."""
    _writable_target(Path(path))


def _writable_target(path: Path) -> Path:
    """The file to replace for ``--out path``: a new path or an existing regular file (through
    symlinks); anything else (a device such as /dev/null, a folder, a FIFO) is refused."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        if path.is_symlink():
            raise OutputError("is a dangling symbolic link", file=str(path)) from None
        if not path.parent.is_dir():
            raise OutputError("output folder does not exist", file=str(path)) from None
        return path
    except OSError as exc:
        raise os_error(exc, path) from None
    if stat.S_ISDIR(st.st_mode):
        raise OutputError("is a folder; give a file name", file=str(path))
    if not stat.S_ISREG(st.st_mode):
        raise OutputError(
            "is not a regular file (a device, FIFO or socket); gantry only replaces regular "
            "files or creates new ones",
            file=str(path),
        )
    return Path(os.path.realpath(path))


@contextmanager
def atomic_file(path: Path, mode: str = "w", **open_kwargs) -> Iterator:
    """Open a temporary sibling of ``path`` for writing; when the body succeeds it replaces
    ``path`` (a new path or a regular file, see ``_writable_target``) by ``os.replace`` with
    the umask's permissions; when it raises, it is removed and ``path`` is left as it was."""
    target = _writable_target(Path(path))
    tmp: str | None = None
    try:
        with deferred():  # the temporary file is named in ``tmp`` before any interruption
            try:
                fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.tmp-", dir=target.parent)
            except OSError as exc:
                raise os_error(exc, target) from None
        try:
            os.fchmod(fd, 0o666 & ~umask())
            with os.fdopen(fd, mode, **open_kwargs) as fh:
                yield fh
            with deferred():
                os.replace(tmp, target)
                tmp = None
        except OSError as exc:
            raise os_error(exc, target) from None
    finally:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
