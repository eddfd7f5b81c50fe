"""The zip assembled around members deflated beforehand reads back with zipfile and numpy."""

from __future__ import annotations

import io
import itertools
import zipfile
import zlib

import numpy as np
import pytest

from gantry_sim.sim import deflate_zip
from gantry_sim.sim.deflate_zip import DeflatedMember, write_zip


def test_isal_deflates_where_installed():
    """isal is a dependency: its igzip deflates (zlib only where it cannot be imported)."""
    pytest.importorskip("isal")
    assert deflate_zip._deflate_lib.__name__ == "isal.isal_zlib"


@pytest.mark.parametrize("lib", ["isal", "zlib"])
def test_members_added_in_pieces_read_back_exactly(tmp_path, monkeypatch, lib):
    """... deflated by igzip or by zlib (where isal is missing), and their deflated bytes
    wait in anonymous files: nothing named in $TMPDIR."""
    import tempfile

    if lib == "isal":
        monkeypatch.setattr(deflate_zip, "_deflate_lib", pytest.importorskip("isal.isal_zlib"))
    else:
        monkeypatch.setattr(deflate_zip, "_deflate_lib", zlib)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    rng = np.random.default_rng(0)
    data = {
        "noise.bin": rng.normal(size=50_000).tobytes(),
        "zeros.bin": bytes(300_000),
        "empty.bin": b"",
    }
    members = [DeflatedMember(name) for name in data]
    cuts = [0, 1, 7, 4096, 100_000, 299_999, 400_000]
    for a, b in itertools.pairwise(cuts):
        for m in members:  # interleaved, in uneven pieces, as a run's ranges arrive
            m.add(data[m.name][a:b])
    assert list(tmp_path.iterdir()) == []
    out = io.BytesIO()
    out.write(b"ignored prefix")  # offsets are relative to the file, not to 0
    write_zip(members, out)
    again = io.BytesIO()
    again.write(b"ignored prefix")
    write_zip(members, again)  # a member can be written more than once
    assert again.getvalue() == out.getvalue()
    with zipfile.ZipFile(io.BytesIO(out.getvalue())) as z:
        assert z.testzip() is None  # every member's CRC-32 checks
        assert z.namelist() == list(data)
        for name, content in data.items():
            info = z.getinfo(name)
            assert info.compress_type == zipfile.ZIP_DEFLATED and info.file_size == len(content)
            assert z.read(name) == content
    assert members[1].compressed < 2000  # deflated, not stored
    members[0].release()
    with pytest.raises(ValueError, match=r"noise\.bin: released"):
        write_zip(members, io.BytesIO())


def test_an_npz_of_deflated_npy_members_loads_with_numpy(tmp_path):
    arrays = {"t": np.arange(1000) * 1e-3, "line": np.arange(1000, dtype=np.int64) // 7}
    members = []
    for name, values in arrays.items():
        buf = io.BytesIO()
        np.save(buf, values)
        m = DeflatedMember(f"{name}.npy")
        m.add(buf.getvalue())
        members.append(m)
    with open(tmp_path / "x.npz", "wb") as f:
        write_zip(members, f)
    with np.load(tmp_path / "x.npz") as npz:
        assert sorted(npz.files) == ["line", "t"]
        for name, values in arrays.items():
            assert npz[name].dtype == values.dtype and np.array_equal(npz[name], values)


def test_save_npz_reads_back_as_savez_compressed_does(tmp_path):
    """A run's trace.npz that was not streamed (sim.trace_writer.save_npz): every name, dtype,
    shape and value as numpy.savez_compressed writes them, 0-d, empty, Fortran-ordered and
    strided arrays included, every member's CRC-32 checking."""
    from gantry_sim.sim.trace_writer import save_npz

    rng = np.random.default_rng(3)
    arrays = {
        "t": np.arange(5_000) * 1e-3,
        "ref": rng.normal(size=(5_000, 3)),
        "line": np.arange(5_000, dtype=np.int64) // 7,
        "feed": rng.random(5_000) > 0.5,
        "empty": np.zeros((0, 3)),
        "scalar": np.float64(2.5),
        "single": rng.random(4).astype(np.float32),
        "fortran": np.asfortranarray(rng.random((4, 3))),
        "strided": rng.random((10, 6))[:, ::2],
    }
    save_npz(tmp_path / "ours.npz", arrays)
    np.savez_compressed(tmp_path / "numpy.npz", **arrays)
    with np.load(tmp_path / "ours.npz") as ours, np.load(tmp_path / "numpy.npz") as theirs:
        assert ours.files == theirs.files == list(arrays)
        for name in arrays:
            a, b = ours[name], theirs[name]
            assert (a.dtype, a.shape) == (b.dtype, b.shape) and np.array_equal(a, b), name
    with zipfile.ZipFile(tmp_path / "ours.npz") as z:
        assert z.testzip() is None


def test_the_member_deflates_with_the_library_chosen(monkeypatch):
    """Each library's own deflate stream (igzip's differs from zlib's), each inflating back."""
    isal_zlib = pytest.importorskip("isal.isal_zlib")
    data = np.random.default_rng(1).normal(size=20_000).round(3).tobytes()
    streams = {}
    for lib in (isal_zlib, zlib):
        monkeypatch.setattr(deflate_zip, "_deflate_lib", lib)
        m = DeflatedMember("x.bin")
        m.add(data)
        out = io.BytesIO()
        m.copy_to(out)
        streams[lib.__name__] = out.getvalue()
        assert zlib.decompress(streams[lib.__name__], -15) == data
        assert m.crc == zlib.crc32(data) and m.size == len(data)
        m.release()
    assert streams["isal.isal_zlib"] != streams["zlib"]
