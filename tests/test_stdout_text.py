"""Text on stdout that its encoding cannot hold: a lone surrogate read from a report.json
(``"\\ud800"`` is valid JSON), or any non-ASCII text on an ASCII stdout, is written with
backslash escapes instead of exiting 3 with UnicodeEncodeError (review: gantry compare)."""

from __future__ import annotations

import json
import os

from tests.fault_helpers import gantry


def _report(path, dialect: str) -> str:
    blocks = [{"line": 2, "kind": "arc", "max_error_um": 1.0, "time_s": 0.5}]
    path.write_text(json.dumps({"dialect": dialect, "cycle_time_s": 1.0, "blocks": blocks}))
    return str(path)


def test_unencodable_report_text_is_escaped_not_an_internal_error(tmp_path):
    base = _report(tmp_path / "a.json", "linuxcnc")
    odd = _report(tmp_path / "b.json", "\ud800")
    proc = gantry("compare", base, odd)
    assert proc.returncode == 0, proc.stderr
    assert "dialect differs: linuxcnc -> \\ud800" in proc.stdout
    env = {**os.environ, "PYTHONIOENCODING": "ascii"}
    proc = gantry("compare", base, _report(tmp_path / "c.json", "\xe9"), env=env)
    assert proc.returncode == 0 and "-> \\xe9" in proc.stdout, proc.stderr
