"""The machine file's ``[sim] model``: a path MuJoCo opens itself, so gantry checks it first
(review: a FIFO hung ``gantry run`` and ``machine show`` for ever, a NUL in the path exited 3,
a directory gave MuJoCo's "empty file" after a "File size over 2GB" warning)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from gantry_sim.sim.cli import main


def _machine(tmp_path: Path, model: str) -> str:
    toml = tmp_path / "m.toml"
    toml.write_text(f'[sim]\nmodel = "{model}"\n')
    return str(toml)


@pytest.mark.parametrize(
    ("model", "what"),
    [
        ("fifo.xml", "the MJCF model is not a regular file"),
        (".", "the MJCF model is a directory"),
        ("a\\u0000b.xml", "a non-empty file path without NUL characters"),
        ("missing.xml", "cannot read the MJCF model: No such file"),
    ],
)
def test_a_model_that_is_no_regular_file_is_refused(tmp_path, capsys, model, what):
    os.mkfifo(tmp_path / "fifo.xml")
    assert main(["machine", "show", "--machine", _machine(tmp_path, model)]) == 2
    err = capsys.readouterr().err
    assert ": error: " in err and what in err and "Traceback" not in err, err
