"""Reading an input file within a size cap: a regular file, or a stream (a pipe, a FIFO, a
device such as ``/dev/stdin`` or ``/dev/zero``) read a chunk at a time.

Every file a command reads goes through here with the cap of its kind [bytes]: a regular file
larger than the cap is refused before a byte is read, a stream when it passes the cap (so
``/dev/zero`` or ``yes`` costs at most the cap of memory, never all of it). A FIFO is opened
without waiting for a writer: one that has none is refused at once instead of hanging (a
writer that stays and writes nothing, as a terminal on ``/dev/stdin``, is waited for, as any
reader waits). Errors are the caller's :class:`~gantry_sim.controller.errors.GantryError`
class, naming the file (exit 2).
"""

from __future__ import annotations

import errno
import os
import stat
from collections.abc import Iterator
from pathlib import Path

from gantry_sim.controller.errors import ConfigError, GantryError

#: one megabyte [bytes], as the messages count them
MB = 1_000_000
#: the cap [bytes] of the small kinds: a machine file (TOML; the bundled one is 7 KB, a
#: thousand tools in its [tools] some 100 KB), a LinuxCNC tool table (at most 1000 pockets
#: of ~100 bytes), INI file, #INCLUDE, parameter file (5400 parameters, ~100 KB) or grbl
#: settings (~2 KB): 40 times the largest, so that an overlong line is still read and
#: refused on its line
CONFIG_CAP_BYTES = 4 * MB
#: a report.json (about 180 bytes per block: 18 MB for a run of 100,000 blocks, read by
#: json.loads in about 1 s and 35 MB; this cap holds some 1.4 million blocks)
REPORT_CAP_BYTES = 256 * MB
#: an MJCF model or a file it references (a mesh, a height field): the bundled model is
#: 10 kB, a fine STL mesh some tens of MB
MODEL_CAP_BYTES = 256 * MB
#: a stream is read this many bytes at a time
READ_CHUNK_BYTES = 1 << 20


def input_chunks(
    path: Path,
    what: str,
    cap_bytes: int,
    error: type[GantryError] = ConfigError,
    chunk_bytes: int = READ_CHUNK_BYTES,
    advice: str = "more than any such file needs; is it the right file?",
) -> Iterator[bytes]:
    """The bytes of ``path`` in chunks of at most ``chunk_bytes``; ``error`` (naming the
    file, ``what`` naming its kind) where it cannot be read, is a directory, is a FIFO with no
    writer, or holds more than ``cap_bytes`` (a regular file refused before it is read; the
    message ends with ``advice``)."""
    fd = _open(path, what, error)
    try:
        info = os.fstat(fd)
        if stat.S_ISDIR(info.st_mode):
            raise error(f"{what} is a directory, expected a file", file=str(path))
        if stat.S_ISREG(info.st_mode) and info.st_size > cap_bytes:
            raise _too_large(path, what, cap_bytes, error, advice)
        first = (
            _first_of_fifo(fd, path, what, error, chunk_bytes)
            if stat.S_ISFIFO(info.st_mode)
            else b""
        )
        os.set_blocking(fd, True)
        size = 0
        chunk = first
        while chunk or (chunk := _read(fd, chunk_bytes, path, what, error)):
            size += len(chunk)
            if size > cap_bytes:
                raise _too_large(path, what, cap_bytes, error, advice)
            yield chunk
            chunk = b""
    finally:
        os.close(fd)


def check_model_file(path: Path, what: str, cap_bytes: int = MODEL_CAP_BYTES) -> None:
    """Raise ConfigError (naming ``path``; ``what`` names its kind) unless ``path`` is a
    regular file of at most ``cap_bytes`` [bytes]. For files MuJoCo opens itself, which it
    would wait on for ever (a FIFO with no writer) or read without end (a device)."""
    try:
        info = os.stat(path)
    except (OSError, ValueError) as exc:  # ValueError: a NUL byte in the path
        reason = getattr(exc, "strerror", None) or "not a valid path"
        raise ConfigError(f"cannot read {what}: {reason}", file=str(path)) from None
    if not stat.S_ISREG(info.st_mode):
        kind = "a directory" if stat.S_ISDIR(info.st_mode) else "not a regular file"
        raise ConfigError(
            f"{what} is {kind}, expected a regular (XML or mesh) file", file=str(path)
        )
    if info.st_size > cap_bytes:
        raise _too_large(path, what, cap_bytes, ConfigError, "more than a model needs")


def read_capped(
    path: Path, what: str, cap_bytes: int = CONFIG_CAP_BYTES, error: type[GantryError] = ConfigError
) -> bytes:
    """All bytes of ``path`` (see :func:`input_chunks`)."""
    return b"".join(input_chunks(path, what, cap_bytes, error))


def _open(path: Path, what: str, error: type[GantryError]) -> int:
    """A descriptor of ``path`` opened for reading without blocking (a FIFO with no writer
    would block ``open`` itself)."""
    try:
        return os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except FileNotFoundError:
        raise error(f"{what} not found", file=str(path)) from None
    except IsADirectoryError:
        raise error(f"{what} is a directory, expected a file", file=str(path)) from None
    except OSError as exc:
        raise error(f"cannot read the {what}: {exc.strerror}", file=str(path)) from None


def _first_of_fifo(
    fd: int, path: Path, what: str, error: type[GantryError], chunk_bytes: int
) -> bytes:
    """What a FIFO holds now (b"" while its writer has written nothing yet); ``error`` where
    it has no writer (a read without blocking gives end of file at once)."""
    try:
        first = os.read(fd, chunk_bytes)
    except BlockingIOError:
        return b""  # a writer, nothing written yet
    except OSError as exc:
        raise error(f"cannot read the {what}: {exc.strerror}", file=str(path)) from None
    if not first:
        raise error(
            f"{what} is a FIFO with no writer (nothing to read); start its writer first, or "
            "give a file",
            file=str(path),
        )
    return first


def _read(fd: int, size: int, path: Path, what: str, error: type[GantryError]) -> bytes:
    try:
        return os.read(fd, size)
    except OSError as exc:
        if exc.errno == errno.EISDIR:
            raise error(f"{what} is a directory, expected a file", file=str(path)) from None
        raise error(f"cannot read the {what}: {exc.strerror}", file=str(path)) from None


def _too_large(
    path: Path, what: str, cap_bytes: int, error: type[GantryError], advice: str
) -> GantryError:
    return error(f"{what} larger than {cap_bytes / MB:g} MB, {advice}", file=str(path))
