"""A leading UTF-8 byte-order mark (Windows Notepad writes one) is no text: machine files,
LinuxCNC INI and grbl imports and report.json read past it, as programs already did (review:
a machine file with a BOM was 'not valid TOML: Invalid statement (at line 1, column 1)', an
INI line 'not inside a [SECTION]', a report 'Unexpected UTF-8 BOM')."""

from __future__ import annotations

import json

from gantry_sim.sim.cli import main

BOM = b"\xef\xbb\xbf"


def test_files_with_a_leading_bom_are_read(tmp_path, capsys):
    toml = tmp_path / "m.toml"
    toml.write_bytes(BOM + b"[servo]\nperiod_s = 0.001\n")
    assert main(["machine", "show", "--machine", str(toml)]) == 0
    ini = tmp_path / "a.ini"
    ini.write_bytes(BOM + b"[AXIS_X]\nMAX_VELOCITY = 10\n")
    assert main(["machine", "import", "linuxcnc", str(ini)]) == 0
    grbl = tmp_path / "g.txt"
    grbl.write_bytes(BOM + b"$110=500\n")
    assert main(["machine", "import", "grbl", str(grbl)]) == 0
    report = {"cycle_time_s": 1.0, "blocks": [{"line": 2, "max_error_um": 1.0, "time_s": 0.5}]}
    plain, marked = tmp_path / "a.json", tmp_path / "b.json"
    plain.write_text(json.dumps(report))
    marked.write_bytes(BOM + json.dumps(report).encode())
    assert main(["compare", str(plain), str(marked)]) == 0
    assert ": error:" not in capsys.readouterr().err
