"""Outputs that are never half-written: write into a temporary sibling, then move it in."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def atomic_output_dir(out_dir: Path, last: str | None = None) -> Iterator[Path]:
    """Yield a temporary folder beside ``out_dir``; on success move its files into ``out_dir``.

    Each file lands by ``os.replace`` (atomic on one file system), so a reader sees either the
    previous file or the complete new one. If the body raises, nothing in ``out_dir`` changes.
    ``last`` names the file moved in after all others (a report whose presence means "done").
    """
    out_dir = Path(out_dir)
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.tmp-", dir=out_dir.parent))
    try:
        yield tmp
        out_dir.mkdir(exist_ok=True)
        for item in sorted(tmp.iterdir(), key=lambda p: (p.name == last, p.name)):
            os.replace(item, out_dir / item.name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@contextmanager
def atomic_file(path: Path, mode: str = "w", **open_kwargs) -> Iterator:
    """Open a temporary sibling of ``path`` (whose folder must exist) for writing; when the body
    succeeds it replaces ``path`` by ``os.replace``, when it raises it is removed and ``path`` is
    left as it was."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.tmp-", dir=path.parent)
    try:
        with os.fdopen(fd, mode, **open_kwargs) as fh:
            yield fh
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
