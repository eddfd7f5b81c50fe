"""Machine files: defaults, overlay, and every validation error names the key and what is allowed."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from gantry_sim.controller.config import SCHEMA, load_machine_config
from gantry_sim.controller.errors import ConfigError
from gantry_sim.controller.machine_work import WORK_KEYS
from gantry_sim.models import DEFAULT_MACHINE, GANTRY_XML


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "machine.toml"
    path.write_text(text)
    return path


def test_bundled_defaults_set_every_key(machine):
    assert machine.limits.max_velocity_mm_per_s[0] > 0
    assert machine.segmentation.chord_tolerance_mm == pytest.approx(0.001)
    assert machine.servo.period_s == pytest.approx(0.001)
    assert Path(machine.sim.model) == GANTRY_XML
    # the bundled file itself names every key of every section of the schema, and no other;
    # [tools] (empty: no table) and [work] (controller/machine_work.py) have their own checks
    bundled = tomllib.loads(Path(DEFAULT_MACHINE).read_text())
    assert bundled.pop("tools") == {}
    assert set(bundled.pop("work")) <= set(WORK_KEYS)
    assert {s: set(keys) for s, keys in bundled.items()} == {
        s: set(keys) for s, keys in SCHEMA.items()
    }


def test_override_keeps_omitted_keys(tmp_path, machine):
    path = _write(tmp_path, "[limits]\nmax_jerk_mm_per_s3 = [1.0, 2.0, 3.0]\n")
    cfg = load_machine_config(DEFAULT_MACHINE, path)
    assert cfg.limits.max_jerk_mm_per_s3 == (1.0, 2.0, 3.0)
    assert cfg.limits.max_velocity_mm_per_s == machine.limits.max_velocity_mm_per_s
    assert cfg.servo == machine.servo
    assert cfg.source == str(path)


def test_machine_files_may_be_given_as_strings(tmp_path):
    """A script's ``load_machine_config("models/gantry.toml")`` used to fail with an
    AttributeError (a str has no ``.parent``) when resolving the model path."""
    path = _write(tmp_path, '[sim]\nmodel = "my.xml"\n')
    as_str = load_machine_config(str(DEFAULT_MACHINE), str(path))
    assert as_str == load_machine_config(DEFAULT_MACHINE, path)
    assert as_str.sim.model == str(tmp_path / "my.xml")
    assert load_machine_config(str(DEFAULT_MACHINE)) == load_machine_config(DEFAULT_MACHINE)


def test_model_path_is_relative_to_the_machine_file(tmp_path):
    path = _write(tmp_path, '[sim]\nmodel = "my.xml"\n')
    cfg = load_machine_config(DEFAULT_MACHINE, path)
    assert cfg.sim.model == str(tmp_path / "my.xml")


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            "[limits]\nmax_speed = 3\n",
            "unknown key 'max_speed' in [limits]; valid keys: max_velocity",
        ),
        ("[motor]\nx = 1\n", "unknown section [motor]; valid sections: [limits]"),
        ("[limits]\nmax_jerk_mm_per_s3 = [1, 2]\n", "list of 3 numbers"),
        ("[limits]\nmax_jerk_mm_per_s3 = [1, -2, 3]\n", "each > 0"),
        ("[limits]\nmax_jerk_mm_per_s3 = [1, nan, 3]\n", "each > 0"),
        ('[segmentation]\nmethod = "spline"\n', "one of 'chord', 'fixed'"),
        ("[segmentation]\nchord_tolerance_mm = 0\n", "a finite number > 0"),
        ("[segmentation]\nchord_tolerance_mm = true\n", "a finite number > 0"),
        ("[servo]\nff_gravity = -1\n", "a finite number >= 0"),
        (
            "[travel]\nmin_mm = [0, 0, 0]\nmax_mm = [0, 1, 1]\n",
            "x: min_mm (0.0) must be below max_mm",
        ),
        ("[sim]\nphysics_timestep_s = 0.01\n", "must not exceed [servo] period_s"),
        ("limits = 3\n", "'limits' must be a table"),
        ("[limits\n", "not valid TOML"),
    ],
)
def test_invalid_machine_files_name_the_problem(tmp_path, text, expected):
    path = _write(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_machine_config(DEFAULT_MACHINE, path)
    assert expected in info.value.message
    assert info.value.file == str(path)
    assert str(info.value).startswith(f"{path}: error: ")


def test_missing_machine_file(tmp_path):
    with pytest.raises(ConfigError, match="machine file not found"):
        load_machine_config(DEFAULT_MACHINE, tmp_path / "nope.toml")


def test_with_changes_validates(machine):
    cfg = machine.with_changes("limits", max_jerk_mm_per_s3=[5.0, 5.0, 5.0])
    assert cfg.limits.max_jerk_mm_per_s3 == (5.0, 5.0, 5.0)
    with pytest.raises(ConfigError, match="each > 0"):
        machine.with_changes("limits", max_jerk_mm_per_s3=[5.0, 0.0, 5.0])
