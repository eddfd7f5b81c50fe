"""``gantry parse`` end to end through sim.cli.main: JSON Lines, exit status, error format."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import pytest

from gantry_sim.sim import program
from gantry_sim.sim.cli import main


def test_parse_prints_the_contract_keys(write_program, capsys) -> None:
    path = write_program("G21 G17 G90\nG0 X0 Y0\nG2 X1 Y1 I1 F10\nG1 X2 F60\nM2\n")
    assert main(["parse", str(path)]) == 0
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["kind"] for r in rows] == ["rapid", "arc", "linear"]
    arc = rows[1]
    assert set(arc) == {
        "line",
        "kind",
        "start",
        "end",
        "feed",
        "plane",
        "direction",
        "center",
        "radius",
        "turns",
        "angle",
    }
    assert arc["line"] == 3 and arc["center"] == [1.0, 0.0, 0.0]
    assert arc["angle"] == pytest.approx(math.pi / 2)


@pytest.mark.parametrize("dialect", ["linuxcnc", "g2core", "marlin", "laserdyne"])
def test_parse_accepts_every_dialect(write_program, capsys, dialect: str) -> None:
    path = write_program("G0 X0 Y0\nG2 X0 Y4 I0 J2 F100\nM2\n")
    assert main(["parse", str(path), "--dialect", dialect]) == 0
    assert json.loads(capsys.readouterr().out.splitlines()[1])["radius"] == 2.0


def test_parse_error_exits_2_with_file_and_line(write_program, capsys) -> None:
    path = write_program("G0 X1\nG1 X2\nM2\n")
    assert main(["parse", str(path)]) == 2
    out, err = capsys.readouterr()
    assert json.loads(out)["end"] == [1.0, 0.0, 0.0]  # the move before the bad line
    assert err.startswith(f"{path}:2: error: cannot make a G1 move with zero feed rate")
    assert "Traceback" not in err


#: megabyte lines: LinuxCNC refuses a line of more than 252 characters before it reads it, so
#: the reader's own defences are tried under a dialect that reads the same language unlimited
_MEGABYTE_LINES = [
    (b"G0 X" + b"1" * 1_000_000 + b"\nM2\n", "not a finite number"),
    (b"G1 F10 X" + b"1 " * 500_000 + b"\nM2\n", "finite"),
    (b"(" + b"x" * 1_000_000 + b"\nM2\n", "unclosed comment"),
    (b"G0 X" + b"[" * 1_000_000 + b"\nM2\n", "nested more than"),
    (b"G0 X" + b"-" * 1_000_000 + b"1\nM2\n", "nested more than"),
]


@pytest.mark.parametrize(
    ("content", "fragment", "dialect"),
    [
        (b"", "no program end", "linuxcnc"),
        (b"\x00\x01\x02garbage", "NUL bytes", "linuxcnc"),
        (b"\xff\xfe\xfa binary", "bad character", "linuxcnc"),  # read as Latin-1: not words
        # as Windows PowerShell's `>` writes a program: UTF-16 with its byte-order mark
        ("G21\nG1 X1 F600\nM2\n".encode("utf-16"), "UTF-16 text", "linuxcnc"),
        ("G21\nG1 X1 F600\nM2\n".encode("utf-16-be").join([b"\xfe\xff", b""]), "UTF-16", "grbl"),
        (b"G0 Xnan\nM2\n", "bad value", "linuxcnc"),
        (b"G0 X1e400\nM2\n", "E word", "linuxcnc"),
        (b"\x1b[31m\nM2\n", "bad character", "linuxcnc"),
        *[(content, "Command too long", "linuxcnc") for content, _ in _MEGABYTE_LINES],
        # 600,000 comments before an abort comment (each searched the rest of the line for a
        # ";": 27 s at 800,000 before the line's length was bounded)
        (b"G0 X1" + b" (c)" * 600_000 + b" (abort, x)\nM2\n", "Command too long", "linuxcnc"),
        *[(content, fragment, "laserdyne") for content, fragment in _MEGABYTE_LINES],
    ],
)
def test_bad_input_is_a_clear_error_fast(
    tmp_path, capsys, content: bytes, fragment: str, dialect: str
) -> None:
    path = tmp_path / "bad.ngc"
    path.write_bytes(content)
    t0 = time.perf_counter()
    assert main(["parse", "--dialect", dialect, str(path)]) == 2
    assert time.perf_counter() - t0 < 5.0
    err = capsys.readouterr().err
    assert err.startswith(f"{path}") and ": error: " in err and fragment in err
    assert "Traceback" not in err


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="no /dev/zero here")
def test_an_endless_stream_is_refused_at_its_first_chunk(capsys) -> None:
    assert main(["parse", "/dev/zero"]) == 2
    assert (
        capsys.readouterr().err
        == "/dev/zero: error: not a G-code text file (it contains NUL bytes)\n"
    )


def test_nul_padding_after_the_program_is_ignored_and_a_nul_inside_named_by_line(
    tmp_path, capsys
) -> None:
    """synthetos/TinyG's gcode_samples/_untested/DIASQU.txt ends with two NUL bytes after its
    closing '%': rs274 runs it. A NUL with text after it is refused on its line."""
    path = tmp_path / "padded.ngc"
    path.write_bytes(b"%\nG21 G90\nG1 X10 F100\n%\n\x00\x00")
    assert main(["parse", str(path)]) == 0
    assert json.loads(capsys.readouterr().out)["end"] == [10.0, 0.0, 0.0]
    path.write_bytes(b"G21 G90\nG1 X10 F100\nG1 X\x002\nM2\n")
    assert main(["parse", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{path}:3: error: not a G-code text file (it contains NUL bytes")


def test_a_stream_is_checked_chunk_by_chunk(tmp_path, monkeypatch, capsys) -> None:
    """A NUL byte after the first chunk, and a program past the size bound, are refused as
    they are read (the bound made small here: the real one is 2 GiB)."""
    monkeypatch.setattr(program, "READ_CHUNK_BYTES", 16)
    path = tmp_path / "late.ngc"
    path.write_bytes(b"G0 X1\n" * 30 + b"\x00\nM2\n")
    assert main(["parse", str(path)]) == 2
    assert "NUL bytes" in capsys.readouterr().err
    path.write_bytes(b"".join(b"G0 X%d\n" % i for i in range(30)) + b"M2\n")
    assert main(["parse", str(path)]) == 0  # read whole from its chunks
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["end"][0] for r in rows] == list(range(30))
    monkeypatch.setattr(program, "MAX_PROGRAM_BYTES", 100)
    assert main(["parse", str(path)]) == 2
    assert "program larger than" in capsys.readouterr().err


def test_huge_p_is_one_move_and_instant(write_program, capsys) -> None:
    path = write_program("F100\nG2 I5 P1000000\nM2\n")
    t0 = time.perf_counter()
    assert main(["parse", str(path)]) == 0
    assert time.perf_counter() - t0 < 2.0
    (row,) = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert row["turns"] == 1_000_000 and row["angle"] == pytest.approx(2e6 * math.pi)


def test_bundled_examples_parse(capsys) -> None:
    from pathlib import Path

    examples = sorted((Path(__file__).resolve().parent.parent / "examples").glob("*.ngc"))
    assert len(examples) >= 4
    for path in examples:
        assert main(["parse", str(path)]) == 0, path
    assert "arc" in capsys.readouterr().out


def test_a_latin1_comment_is_read_as_controllers_read_it(tmp_path, capsys) -> None:
    # CAM posts on Windows write comments in a one-byte code page ("(Fräser 8)" in Latin-1):
    # the words are ASCII, and controllers skip comments byte by byte
    path = tmp_path / "latin1.ngc"
    path.write_bytes(b"G21 G90\n(Fr\xe4s 8)\nG0 X1 ; \xb0\nM2\n")
    assert main(["parse", str(path)]) == 0
    assert json.loads(capsys.readouterr().out)["end"] == [1.0, 0.0, 0.0]
    path.write_bytes(b"G21 G90\n\xe4G0 X1\nM2\n")  # outside a comment: not a word
    assert main(["parse", str(path)]) == 2
    assert capsys.readouterr().err.startswith(f"{path}:2: error: bad character")
