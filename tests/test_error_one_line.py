"""An error is one line even when a file name holds a newline or another control character
(review: ``gantry parse 'bad<newline>name.ngc'`` printed ``bad``, then ``name.ngc:2: error:``
on a line of its own, which no ``FILE:LINE: error:`` reader can match)."""

from __future__ import annotations

from gantry_sim.controller.errors import GantryError
from gantry_sim.sim.cli import main


def test_a_control_character_in_a_file_name_is_escaped():
    assert str(GantryError("m", file="a\nb\x00\x7f\tc", line=3)) == "a\\nb\\x00\\x7f\tc:3: error: m"


def test_a_program_and_a_machine_file_named_with_a_newline(tmp_path, capsys):
    prog = tmp_path / "bad\nname.ngc"
    prog.write_text("G1 X1 F100\nG2 X0 Y0 R0\nM2\n")
    assert main(["parse", str(prog)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"{tmp_path}/bad\\nname.ngc:2: error: "), err
    assert main(["parse", str(prog), "--machine", str(tmp_path / "no\nsuch.toml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no\\nsuch.toml: error: " in err, err
