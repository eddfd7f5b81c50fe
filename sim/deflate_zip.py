"""A .zip file assembled from members deflated beforehand (APPNOTE.TXT 6.3: local headers,
data, central directory, ZIP64 end records).

Python's zipfile compresses a member while writing it, one member after the other; a streamed
run's trace.npz has six members whose bytes arrive interleaved, range by range, for minutes. So
each member is deflated as its bytes arrive (:class:`DeflatedMember`: raw deflate, CRC-32 and
sizes kept), and :func:`write_zip` then writes the container around the deflated bytes, copying
them. Every entry carries ZIP64 sizes and offsets (version 4.5), whatever its size, so the one
path that writes multi-gigabyte traces is the one the tests read back with zipfile and numpy.

The deflating is ISA-L's (``isal``, igzip at level 1): the same raw deflate stream that zlib
writes and every zip reader reads, made about 4 x faster at the same size (6,000 ticks of
traced polylines: 12 ms against 46 ms at zlib's level 1, 1.753 against 1.756 x smaller). On
two cores the thread deflating a streamed run's trace shares the second core with the
analysis worker, and what spills over takes the servo loop's time. Where ``isal`` cannot be
imported, zlib deflates at its level 1, with the same arrays read back.

A member's deflated bytes wait in an anonymous temporary file (``tempfile.TemporaryFile`` in
``$TMPDIR``: no name in any folder, so the system frees it when the process ends, however it
ends: a sweep worker terminated mid-run leaves nothing behind).
"""

from __future__ import annotations

import io
import shutil
import struct
import tempfile
import zlib
from types import ModuleType
from typing import Any, BinaryIO

_deflate_lib: ModuleType
try:  # see the module docstring
    from isal import isal_zlib as _deflate_lib
except ImportError:  # pragma: no cover - isal is a dependency; a platform without its wheel
    _deflate_lib = zlib

#: deflate level: 1, as trace.npz was written (fast; float data deflates little more at 9);
#: igzip's and zlib's level 1 give files within 1 % of each other's size
LEVEL = 1
_MAX32 = 0xFFFFFFFF
_VERSION = 45  # ZIP64
_DOS_TIME, _DOS_DATE = 0, (1980 - 1980) << 9 | 1 << 5 | 1  # 1980-01-01 00:00, as numpy's savez


class DeflatedMember:
    """One member's bytes, deflated as they are added into an anonymous temporary file (kept
    until :meth:`release`, or until the member is garbage-collected)."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.crc, self.size, self.compressed = 0, 0, 0
        self._file: BinaryIO | None = tempfile.TemporaryFile()
        self._deflate: Any = _deflate_lib.compressobj(LEVEL, zlib.DEFLATED, -15)

    def add(self, data: bytes | memoryview) -> None:
        assert self._deflate is not None, "member already finished"
        self.crc = _deflate_lib.crc32(data, self.crc)
        self.size += len(data)
        self._write(self._deflate.compress(data))

    def finish(self) -> None:
        """End the deflate stream: no more bytes are added (idempotent)."""
        if self._deflate is not None:
            self._write(self._deflate.flush())
            self._deflate = None

    def copy_to(self, out: BinaryIO) -> None:
        """Write the deflated bytes to ``out`` (the member finished)."""
        self.finish()
        if self._file is None:
            raise ValueError(f"{self.name}: released")
        self._file.seek(0)
        shutil.copyfileobj(self._file, out, 1 << 20)

    def release(self) -> None:
        """Free the deflated bytes (idempotent)."""
        self._deflate = None
        if self._file is not None:
            self._file.close()
            self._file = None

    def _write(self, chunk: bytes) -> None:
        assert self._file is not None
        self._file.write(chunk)
        self.compressed += len(chunk)


def _entry_fields(m: DeflatedMember, name: bytes, extra: bytes) -> bytes:
    """The fields the local header and the central directory entry share (APPNOTE 4.3.7 and
    4.3.12): version needed, flags, method, time, date, CRC-32, sizes (in the ZIP64 extra
    field, so 0xFFFFFFFF here), name and extra field lengths."""
    return struct.pack(
        "<HHHHHIIIHH",
        _VERSION,
        0,
        zlib.DEFLATED,
        _DOS_TIME,
        _DOS_DATE,
        m.crc,
        _MAX32,
        _MAX32,
        len(name),
        len(extra),
    )


def npy_member(name: str, shape: tuple[int, ...], dtype: Any) -> DeflatedMember:
    """The member ``name.npy`` of an .npz, its ``.npy`` header for a C-ordered array of
    ``shape`` and ``dtype`` written; the array's bytes are added after it."""
    import numpy as np
    from numpy.lib import format as npy

    member = DeflatedMember(f"{name}.npy")
    header = {"descr": npy.dtype_to_descr(np.dtype(dtype)), "fortran_order": False}
    head = io.BytesIO()
    npy.write_array_header_1_0(head, header | {"shape": shape})
    member.add(head.getvalue())
    return member


def write_zip(members: list[DeflatedMember], out: BinaryIO) -> None:
    """Write a zip of ``members`` (each finished first) to ``out``, their deflated bytes
    copied."""
    central = []
    for m in members:
        m.finish()  # its sizes and CRC are final
        offset = out.tell()
        name = m.name.encode()
        extra = struct.pack("<HHQQ", 1, 16, m.size, m.compressed)
        out.write(struct.pack("<I", 0x04034B50) + _entry_fields(m, name, extra) + name + extra)
        m.copy_to(out)
        extra = struct.pack("<HHQQQ", 1, 24, m.size, m.compressed, offset)
        made_by = 3 << 8 | _VERSION  # Unix (the external attributes are its mode)
        # comment length, disk, internal attributes, external attributes, offset (in extra)
        tail = struct.pack("<HHHII", 0, 0, 0, 0o644 << 16, _MAX32)
        head = struct.pack("<IH", 0x02014B50, made_by)
        central.append(head + _entry_fields(m, name, extra) + tail + name + extra)
    start = out.tell()
    for entry in central:
        out.write(entry)
    end = out.tell()
    n, size = len(central), end - start
    out.write(
        struct.pack("<IQHHIIQQQQ", 0x06064B50, 44, _VERSION, _VERSION, 0, 0, n, n, size, start)
    )
    out.write(struct.pack("<IIQI", 0x07064B50, 0, end, 1))
    out.write(struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, n, n, _MAX32, _MAX32, 0))
