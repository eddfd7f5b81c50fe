"""`gantry machine import`: LinuxCNC configurations with the figures of LinuxCNC's sample
configurations, and a grbl $$ dump (tests/data/machine_import/README.md: our own text, whose
numbers follow the sources it names)."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import pytest

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.errors import ConfigError
from gantry_sim.controller.machine_import.common import Target
from gantry_sim.controller.machine_import.gains import ZETA
from gantry_sim.controller.machine_import.grbl_settings import import_grbl
from gantry_sim.controller.machine_import.linuxcnc_ini import import_linuxcnc
from gantry_sim.models import DEFAULT_MACHINE
from gantry_sim.sim.cli import main

DATA = Path(__file__).resolve().parent / "data" / "machine_import"
TARGET = Target(mass_kg=(17.0, 60.0, 9.0), joint_range_mm=((-300, 300), (-200, 200), (-75, 75)))
INCH = 25.4


def test_mesa_servo_config_maps_limits_travel_period_and_kv():
    imp = import_linuxcnc(DATA / "hm2_servo_5i20.ini", TARGET)
    v = imp.values
    assert v["limits"]["max_velocity_mm_per_s"] == pytest.approx([1.0 * INCH] * 3)
    assert v["limits"]["max_acceleration_mm_per_s2"] == pytest.approx([4.0 * INCH] * 3)
    # X and Y -3..10 inch fit the model (placed about the joint range's middle); Z +-3 inch
    # is 2.4 mm longer than the model's 150 mm and is shortened, and said so
    assert v["travel"]["min_mm"] == pytest.approx([-3 * INCH, -3 * INCH, -75.0])
    assert v["travel"]["max_mm"] == pytest.approx([10 * INCH, 10 * INCH, 75.0])
    assert v["sim"]["work_origin_joint_mm"] == pytest.approx([-3.5 * INCH, -3.5 * INCH, 0.0])
    assert any("travel Z" in a and "shortened" in a for a in imp.assumed)
    assert v["servo"]["period_s"] == pytest.approx(0.001)
    assert v["servo"]["max_following_error_mm"] == pytest.approx(0.010 * INCH)
    # P = 100 1/s is Kv: kp / kd = P, and the PD loop has the design damping ratio
    for m, kp, kd in zip(
        TARGET.mass_kg, v["servo"]["kp_N_per_mm"], v["servo"]["kd_N_s_per_mm"], strict=True
    ):
        assert kp / kd == pytest.approx(100.0)
        assert kd / (2 * math.sqrt(kp * m * 1e-3)) == pytest.approx(ZETA)
    assert v["servo"]["ff_acceleration"] == [0.0, 0.0, 0.0]  # FF2 = 0
    assert "ki_N_per_mm_s" not in v["servo"]  # I = 0
    assert any(n.startswith("DEADBAND") for n in imp.not_mapped)
    assert any("jerk" in a for a in imp.assumed)


def test_pid_with_integral_and_derivative_maps_through_the_velocity_loop():
    """univstep: P 150, I 100, D 0.1: kd = Kvel (1 + D), ki = Kvel I, kp = Kvel P."""
    v = import_linuxcnc(DATA / "pico_univstep.ini", TARGET).values["servo"]
    for i, m in enumerate(TARGET.mass_kg):
        kvel = 2 * ZETA * (2 * ZETA * 150.0) * m * 1e-3
        assert v["kp_N_per_mm"][i] == pytest.approx(kvel * 150.0)
        assert v["kd_N_s_per_mm"][i] == pytest.approx(kvel * 1.1)
        assert v["ki_N_per_mm_s"][i] == pytest.approx(kvel * 100.0)


def test_simulator_config_in_mm_without_pid_keeps_the_bundled_servo():
    imp = import_linuxcnc(DATA / "sim_axis_mm.ini", TARGET)
    assert "kp_N_per_mm" not in imp.values["servo"]
    assert any("no PID P gains" in a for a in imp.assumed)
    assert imp.values["limits"]["max_velocity_mm_per_s"][0] > 10.0  # mm, not inch


def test_grbl_defaults_map_rates_acceleration_travel_and_arc_tolerance():
    imp = import_grbl(DATA / "grbl_1.1_generic.txt", TARGET)
    v = imp.values
    assert v["limits"]["max_velocity_mm_per_s"] == [500.0 / 60.0] * 3
    assert v["limits"]["max_acceleration_mm_per_s2"] == [10.0] * 3
    assert v["travel"] == {"min_mm": [-100.0, -100.0, -75.0], "max_mm": [100.0, 100.0, 75.0]}
    assert v["segmentation"] == {"method": "chord", "chord_tolerance_mm": 0.002}
    assert "servo" not in v
    assert v["path"] == {"mode": "G64", "tolerance_mm": 0.01}  # $11 junction deviation
    assert not any(n.startswith("$11") for n in imp.not_mapped)
    assert any(n.startswith("$13=0") for n in imp.not_mapped)
    assert any("jerk" in a for a in imp.assumed)


@pytest.mark.parametrize(
    ("fmt", "name"),
    [
        ("linuxcnc", "hm2_servo_5i20.ini"),
        ("linuxcnc", "pico_univstep.ini"),
        ("grbl", "grbl_1.1_generic.txt"),
    ],
)
def test_cli_writes_a_machine_file_that_loads_and_lists_what_did_not_map(
    tmp_path, capsys, fmt, name
):
    out = tmp_path / "imported.toml"
    assert main(["machine", "import", fmt, str(DATA / name), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "not mapped:" in printed and "assumed:" in printed
    machine = load_machine_config(DEFAULT_MACHINE, out)
    written = tomllib.loads(out.read_text())
    assert machine.limits.max_velocity_mm_per_s == tuple(written["limits"]["max_velocity_mm_per_s"])
    # every value the import mapped is in the file (grbl's [path] from $11 had been left out)
    reader = import_grbl if fmt == "grbl" else import_linuxcnc
    mapped = reader(DATA / name, TARGET).values
    for section, keys in mapped.items():
        for key in keys:
            assert key in written.get(section, {}), f"[{section}] {key} not written"
    if fmt == "grbl":
        assert written["path"] == {"mode": "G64", "tolerance_mm": 0.01}
        assert machine.path.mode == "G64" and machine.path.tolerance_mm == 0.01


def test_grbl_junction_deviation_zero_is_exact_stop_at_corners(tmp_path):
    dump = tmp_path / "grbl.txt"
    dump.write_text("$11=0\n$12=0.002\n")
    assert import_grbl(dump, TARGET).values["path"] == {"mode": "G61"}


def test_cli_prints_the_file_on_stdout_and_the_notes_on_stderr(capsys):
    assert main(["machine", "import", "grbl", str(DATA / "grbl_1.1_generic.txt")]) == 0
    cap = capsys.readouterr()
    assert tomllib.loads(cap.out)["limits"]["max_acceleration_mm_per_s2"] == [10.0] * 3
    assert "$13=0" in cap.err  # what did not map is listed on stderr


def test_stiff_stepper_pid_is_imported_with_an_instability_warning(tmp_path, capsys):
    """ppmc: P = 800 1/s; through the velocity loop wn = 1120 rad/s, wn T = 1.1 at 1 ms."""
    out = tmp_path / "ppmc.toml"
    assert (
        main(["machine", "import", "linuxcnc", str(DATA / "pico_ppmc.ini"), "--out", str(out)]) == 0
    )
    assert (
        "WARNING: with these gains the sampled loop is unstable on X, Y, Z"
        in capsys.readouterr().out
    )


def test_include_and_continuation_lines(tmp_path):
    (tmp_path / "axes.inc").write_text(
        "[AXIS_X]\nMAX_VELOCITY = 10\nMAX_ACCELERATION = 100\n"
        "[AXIS_Y]\nMAX_VELOCITY = 11\nMAX_ACCELERATION = 110\n"
        "[AXIS_Z]\nMAX_VELOCITY = \\\n   12\nMAX_ACCELERATION = 120\n"
    )
    ini = tmp_path / "m.ini"
    ini.write_text("[TRAJ]\nLINEAR_UNITS = mm\nCOORDINATES = X Y Z\n#INCLUDE axes.inc\n")
    v = import_linuxcnc(ini, TARGET).values
    assert v["limits"]["max_velocity_mm_per_s"] == [10.0, 11.0, 12.0]


@pytest.mark.parametrize(
    ("fmt", "text", "where", "what"),
    [
        ("grbl", "$110=500\n$111 500\n", ":2: error:", "not a grbl setting line"),
        ("grbl", "$110=500\n$120=fast\n", ":2: error:", "expected a number"),
        ("grbl", "$110=500\n$111=-1\n$112=5\n", ":2: error:", "must be > 0"),  # 0: unused
        ("grbl", "$110=500\n$11=-0.01\n", ":2: error:", "must be >= 0"),
        ("grbl", "hello\n", ":1: error:", "not a grbl setting line"),
        (
            "linuxcnc",
            "[TRAJ]\nLINEAR_UNITS = furlong\n[AXIS_X]\nMAX_VELOCITY = 1\n",
            ":2: error:",
            "LINEAR_UNITS",
        ),
        (
            "linuxcnc",
            "[AXIS_X]\nMAX_VELOCITY = 1\nMAX_ACCELERATION = quick\n",
            ":3: error:",
            "expected a number",
        ),
        ("linuxcnc", "MAX_VELOCITY = 1\n", ":1: error:", "not inside a [SECTION]"),
        (  # a megabyte of value: the message quotes 40 characters of it
            "linuxcnc",
            "[TRAJ]\nLINEAR_UNITS = mm" + " " * 10**6 + "x\n[AXIS_X]\nMAX_VELOCITY = 1\n",
            ":2: error:",
            "   ...: expected one of mm, metric",
        ),
        (
            "linuxcnc",
            "[AXIS_X]\nMAX_VELOCITY = 1" + "9" * 10**6 + "x\n",
            ":2: error:",
            "9...: expected a number",
        ),
        ("linuxcnc", "[EMC]\n#INCLUDE nosuch.inc\n", ":2: error:", "#INCLUDE nosuch.inc"),
        ("linuxcnc", "[EMC]\nMACHINE = x\n", ": error:", "not a LinuxCNC machine configuration"),
    ],
)
def test_malformed_inputs_exit_2_with_file_and_line(tmp_path, capsys, fmt, text, where, what):
    path = tmp_path / "input.txt"
    path.write_text(text)
    assert main(["machine", "import", fmt, str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}{where}" in err and what in err and "Traceback" not in err
    assert len(err) < 500 + len(str(path))


def test_unreadable_inputs_exit_2(tmp_path, capsys):
    assert main(["machine", "import", "linuxcnc", str(tmp_path / "missing.ini")]) == 2
    assert (
        f"{tmp_path / 'missing.ini'}: error: LinuxCNC INI file not found" in capsys.readouterr().err
    )
    binary = tmp_path / "b.txt"
    binary.write_bytes(b"$0=1\x00\xff")
    assert main(["machine", "import", "grbl", str(binary)]) == 2
    assert "binary" in capsys.readouterr().err
    with pytest.raises(ConfigError, match="is a directory"):
        import_grbl(tmp_path, TARGET)


def test_an_input_that_maps_to_an_invalid_machine_file_is_an_error_about_the_input(
    tmp_path, capsys
):
    # a number the machine file cannot hold is refused at its INI line, naming the key it
    # becomes (it had been "it maps to an invalid machine file", with no line or INI key)
    ini = tmp_path / "m.ini"
    ini.write_text(
        "[TRAJ]\nLINEAR_UNITS = mm\n"
        + "".join(f"[JOINT_{j}]\nFERROR = {5000 if j == 1 else 1}\n" for j in range(3))
    )
    out = tmp_path / "out.toml"
    assert main(["machine", "import", "linuxcnc", str(ini), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert (
        f"{ini}:6: error: [JOINT_1] FERROR = '5000' gives [servo] max_following_error_mm = 5000,"
        " which must be a finite number > 0 within 0.0001..1000 mm" in err
    )
    assert not out.exists()
    assert (
        main(
            [
                "machine",
                "import",
                "linuxcnc",
                str(DATA / "sim_axis_mm.ini"),
                "--out",
                str(tmp_path / "no" / "x.toml"),
            ]
        )
        == 2
    )
    assert "--out must be a file in an existing folder" in capsys.readouterr().err
