"""`gantry machine import linuxcnc` on what real configurations hold (found on 144 INIs from 20
public repositories): limits that leave out 0, inline comments, #INCLUDE inside a section,
Latin-1 comments, values the machine file cannot hold, gantries' second joints, external
offsets' share, LinuxCNC 2.7's [TRAJ] keys, S-curve jerk, old tool tables, stored start-up
state. Every INI here is our own text, written to show one rule."""

from __future__ import annotations

from pathlib import Path

import pytest

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.errors import ConfigError
from gantry_sim.controller.machine_import.common import Target
from gantry_sim.controller.machine_import.linuxcnc_ini import import_linuxcnc
from gantry_sim.models import DEFAULT_MACHINE
from gantry_sim.sim.cli import main

TARGET = Target(mass_kg=(17.0, 60.0, 9.0), joint_range_mm=((-300, 300), (-200, 200), (-75, 75)))
AXES3 = "".join(
    f"[AXIS_{a}]\nMAX_VELOCITY = 100\nMAX_ACCELERATION = 1000\nMIN_LIMIT = -50\nMAX_LIMIT = 50\n"
    for a in "YZ"
)


def _ini(tmp_path: Path, text: str, name: str = "m.ini") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _x(limits: str, more: str = "") -> str:
    return f"[TRAJ]\nLINEAR_UNITS = mm\n[AXIS_X]\n{limits}{more}" + AXES3


def _x_vel(v: float) -> str:
    return f"MAX_VELOCITY = {v}\nMAX_ACCELERATION = 1000\nMIN_LIMIT = -50\nMAX_LIMIT = 50\n"


def test_travel_keeps_the_work_origin_where_the_machine_starts(tmp_path):
    # 0..1000 on a 600 mm joint had been cut about its middle to 200..800: the machine starts
    # at rest at X0, outside it, so no program could run
    imp = import_linuxcnc(_ini(tmp_path, _x("MIN_LIMIT = 0\nMAX_LIMIT = 1000\n")), TARGET)
    assert (imp.values["travel"]["min_mm"][0], imp.values["travel"]["max_mm"][0]) == (0.0, 600.0)
    assert imp.values["sim"]["work_origin_joint_mm"][0] == -300.0  # X0 at the joint's end
    # limits that leave 0 out (a machine homed at 61 mm) are widened to it, and said so
    imp = import_linuxcnc(_ini(tmp_path, _x("MIN_LIMIT = 61\nMAX_LIMIT = 400\n")), TARGET)
    assert (imp.values["travel"]["min_mm"][0], imp.values["travel"]["max_mm"][0]) == (0.0, 400.0)
    assert any("does not hold 0" in a and "widened to 0..400" in a for a in imp.assumed)


def test_soft_limits_that_mean_none_are_shortened_to_the_model(tmp_path):
    # LinuxCNC's own sample (ja_tests/xyzx_mpg) writes MIN_LIMIT = -1e10: fitted, not refused
    imp = import_linuxcnc(_ini(tmp_path, _x("MIN_LIMIT = -1e10\nMAX_LIMIT = 1e10\n")), TARGET)
    assert (imp.values["travel"]["min_mm"][0], imp.values["travel"]["max_mm"][0]) == (-300, 300)


def test_a_machine_file_whose_travel_leaves_out_the_work_origin_is_refused(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text("[travel]\nmin_mm = [200, -100, -50]\nmax_mm = [800, 100, 50]\n")
    with pytest.raises(ConfigError, match=r"\[travel\] x: 200..800 mm does not hold 0"):
        load_machine_config(DEFAULT_MACHINE, path)


def test_a_limit_beyond_the_machine_files_reads_as_none(tmp_path):
    # LinuxCNC's idiom for no limit (1e99, its own default of MAX_LINEAR_VELOCITY; its
    # sim/axis/db_demo configurations): refused before, now the largest the file holds
    imp = import_linuxcnc(
        _ini(tmp_path, _x("MAX_VELOCITY = 1e99\nMAX_ACCELERATION = 1e308\n", "MAX_JERK = 1\n")),
        TARGET,
    )
    assert imp.values["limits"]["max_velocity_mm_per_s"][0] == 1e5
    assert imp.values["limits"]["max_acceleration_mm_per_s2"][0] == 1e6
    assert any("MAX_VELOCITY = 1e+99 read as no limit" in a for a in imp.assumed)


def test_a_number_is_its_leading_number_as_linuxcnc_reads_it(tmp_path):
    imp = import_linuxcnc(
        _ini(tmp_path, _x("MAX_VELOCITY = 100 # mm/s\nMAX_ACCELERATION = 1000mm\n")), TARGET
    )
    assert imp.values["limits"]["max_velocity_mm_per_s"][0] == 100.0
    assert imp.values["limits"]["max_acceleration_mm_per_s2"][0] == 1000.0
    assert any(
        "m.ini:4: [AXIS_X] MAX_VELOCITY = '100 # mm/s' read as 100" in a for a in imp.assumed
    )
    with pytest.raises(ConfigError, match="expected a number") as err:
        import_linuxcnc(_ini(tmp_path, _x("MAX_VELOCITY = fast\n")), TARGET)
    assert err.value.line == 4
    # glibc's strtod reads hexadecimal too: 0x10 is 16 (it had been 0, "x10" ignored)
    imp = import_linuxcnc(_ini(tmp_path, _x("MAX_VELOCITY = 0x10\n")), TARGET)
    assert imp.values["limits"]["max_velocity_mm_per_s"][0] == 16.0


def test_an_include_stands_in_its_section(tmp_path):
    (tmp_path / "x.inc").write_text("MAX_VELOCITY = 77\nMAX_ACCELERATION = 700\n")
    (tmp_path / "yz.inc").write_text(AXES3)
    text = (
        "[TRAJ]\nLINEAR_UNITS = mm\n[AXIS_X]\n#INCLUDE x.inc\nMIN_LIMIT = -5\nMAX_LIMIT = 5\n"
        "#INCLUDE yz.inc\nMIN_LIMIT = -60\n"  # after it, the last section it opened goes on
    )
    imp = import_linuxcnc(_ini(tmp_path, text), TARGET)
    assert imp.values["limits"]["max_velocity_mm_per_s"] == [77.0, 100.0, 100.0]
    assert imp.values["travel"]["min_mm"][0] == -5.0
    assert imp.values["travel"]["min_mm"][2] == -50.0  # the first of Z's MIN_LIMITs wins


def test_only_the_word_include_includes(tmp_path):
    # LinuxCNC's own sample configuration (tests/trajectory-planner/circular-arcs) comments
    # "#Includes acceleration / velocity": a comment, which had been read as an #INCLUDE
    text = _x("#Includes acceleration / velocity\nMAX_VELOCITY = 5\n#INCLUDEd\n")
    assert import_linuxcnc(_ini(tmp_path, text), TARGET).values["limits"][
        "max_velocity_mm_per_s"
    ] == [5.0, 100.0, 100.0]


def test_an_include_cycle_or_an_empty_include_is_an_error_at_its_line(tmp_path):
    (tmp_path / "a.inc").write_text("[AXIS_Y]\n#INCLUDE m.ini\n")
    with pytest.raises(ConfigError, match=r"included more than 9 deep \(an include cycle\?\)"):
        import_linuxcnc(_ini(tmp_path, "[AXIS_X]\n#INCLUDE a.inc\n"), TARGET)
    with pytest.raises(ConfigError, match="no file name") as err:
        import_linuxcnc(_ini(tmp_path, "[AXIS_X]\nMAX_VELOCITY = 1\n#INCLUDE\n"), TARGET)
    assert err.value.line == 3


def test_an_include_bomb_is_refused_quickly(tmp_path):
    # three levels of 100 includes of one line had read 10**6 files (30 s; each level 100 x)
    (tmp_path / "l0.inc").write_text("K = 1\n")
    for level in (1, 2, 3):
        (tmp_path / f"l{level}.inc").write_text(f"#INCLUDE l{level - 1}.inc\n" * 100)
    with pytest.raises(ConfigError, match="more than 1000 #INCLUDE files") as err:
        import_linuxcnc(_ini(tmp_path, "[AXIS_X]\n#INCLUDE l3.inc\n"), TARGET)
    assert err.value.file == str(tmp_path / "l1.inc")


def test_text_that_is_not_utf8_is_refused_only_where_linuxcnc_reads_it(tmp_path):
    path = tmp_path / "m.ini"
    path.write_bytes(b"# Fr\xe4se, Ma\xdfe in mm\n" + _x("MAX_VELOCITY = 10\n").encode())
    assert import_linuxcnc(path, TARGET).values["limits"]["max_velocity_mm_per_s"][0] == 10.0
    path.write_bytes(_x("MAX_VELOCITY = 10\n").encode() + b"[DISPLAY]\nTITLE = Fr\xe4se\n")
    with pytest.raises(ConfigError, match="invalid UTF-8") as err:
        import_linuxcnc(path, TARGET)
    assert err.value.line == 16


@pytest.mark.parametrize(
    ("text", "line", "what"),
    [
        (  # below the machine file's 0.01 mm/s: no idiom for "none"
            _x("MAX_VELOCITY = 1e-9\n").replace("LINEAR_UNITS = mm", "LINEAR_UNITS = inch"),
            4,
            "[AXIS_X] MAX_VELOCITY = '1e-9' gives [limits] max_velocity_mm_per_s = 2.54e-08",
        ),
        (
            _x("MIN_LIMIT = -1e308\nMAX_LIMIT = 1\n").replace("= mm", "= inch"),
            4,
            "[AXIS_X] MIN_LIMIT = '-1e308' gives [travel] min_mm = -inf",
        ),
        (
            _x("") + "".join(f"[JOINT_{j}]\nP = {1e200 if j == 0 else 50}\n" for j in range(3)),
            15,
            "[JOINT_0] P = '1e+200' gives [servo] kp_N_per_mm = inf",
        ),
        (
            _x("") + "[EMCMOT]\nSERVO_PERIOD = 1e9\n",
            15,
            "[EMCMOT] SERVO_PERIOD = '1e9' gives [servo] period_s = 1, which must be a finite "
            "number > 0 within 1e-05..0.1 s",
        ),
    ],
)
def test_a_number_the_machine_file_cannot_hold_is_an_error_at_its_ini_line(
    tmp_path, capsys, text, line, what
):
    ini = _ini(tmp_path, text)
    out = tmp_path / "out.toml"
    assert main(["machine", "import", "linuxcnc", str(ini), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{ini}:{line}: error: {what}" in err, err
    assert "internal error" not in err and not out.exists()


def test_a_traj_cap_is_held_to_the_ranges_only_where_it_binds(tmp_path):
    # 4000 in/s (101.6 m/s) is how configurations say "no cap": it had refused the import
    def ini(cap: str) -> str:
        axes = "".join(f"[AXIS_{a}]\n{_x_vel(2)}" for a in "XYZ")
        return f"[TRAJ]\nLINEAR_UNITS = inch\nMAX_LINEAR_VELOCITY = {cap}\n" + axes

    imp = import_linuxcnc(_ini(tmp_path, ini("4000")), TARGET)
    assert imp.values["limits"]["max_velocity_mm_per_s"] == pytest.approx([2 * 25.4] * 3)
    with pytest.raises(ConfigError, match=r"\[TRAJ\] MAX_LINEAR_VELOCITY = '1e-5' gives") as err:
        import_linuxcnc(_ini(tmp_path, ini("1e-5")), TARGET)
    assert err.value.line == 3


def test_every_joint_of_a_gantry_axis_counts_for_the_following_error(tmp_path):
    text = "[TRAJ]\nLINEAR_UNITS = mm\n[KINS]\nKINEMATICS = trivkins coordinates=XYYZ\n" + "".join(
        f"[JOINT_{j}]\nFERROR = {0.05 if j == 2 else 1.0}\n" for j in range(4)
    )
    imp = import_linuxcnc(_ini(tmp_path, text), TARGET)
    assert imp.values["servo"]["max_following_error_mm"] == 0.05  # joint 2: Y's second


def test_external_offsets_keep_their_share_of_velocity_and_acceleration(tmp_path):
    # LinuxCNC's planner has (1 - OFFSET_AV_RATIO) of them (iniaxis.cc); beyond 0.9 it uses 0.1
    imp = import_linuxcnc(_ini(tmp_path, _x(_x_vel(100), "OFFSET_AV_RATIO = 0.5\n")), TARGET)
    assert imp.values["limits"]["max_velocity_mm_per_s"] == [50.0, 100.0, 100.0]
    assert imp.values["limits"]["max_acceleration_mm_per_s2"] == [500.0, 1000.0, 1000.0]
    imp = import_linuxcnc(_ini(tmp_path, _x(_x_vel(100), "OFFSET_AV_RATIO = 0.95\n")), TARGET)
    assert imp.values["limits"]["max_velocity_mm_per_s"][0] == pytest.approx(90.0)
    assert any("outside 0..0.9: 0.1 used" in a for a in imp.assumed)


def test_linuxcnc_2_7_traj_maxima_cap_the_axes_and_2_8_ignores_them(tmp_path):
    traj = "[TRAJ]\nLINEAR_UNITS = mm\nMAX_VELOCITY = 70\nMAX_ACCELERATION = 500\n"
    old = traj + "".join(f"[AXIS_{j}]\n{_x_vel(80)}" for j in range(3))
    imp = import_linuxcnc(_ini(tmp_path, old), TARGET)
    assert imp.values["limits"]["max_velocity_mm_per_s"] == [70.0] * 3
    assert imp.values["limits"]["max_acceleration_mm_per_s2"] == [500.0] * 3
    # 2.8 renamed them MAX_LINEAR_*: a 2.8 configuration's [TRAJ] MAX_VELOCITY is not read
    new = traj + "".join(f"[AXIS_{a}]\n{_x_vel(80)}[JOINT_{j}]\n" for j, a in enumerate("XYZ"))
    imp = import_linuxcnc(_ini(tmp_path, new), TARGET)
    assert imp.values["limits"]["max_velocity_mm_per_s"] == [80.0] * 3


def test_jerk_is_read_where_linuxcnc_plans_with_it(tmp_path):
    jerk = "MAX_JERK = 8000\n"
    scurve = _x("", jerk).replace("[TRAJ]\n", "[TRAJ]\nPLANNER_TYPE = 1\nMAX_LINEAR_JERK = 9000\n")
    imp = import_linuxcnc(_ini(tmp_path, scurve), TARGET)
    # X its own, Y and Z (MAX_JERK unset: LinuxCNC's default 0) the [TRAJ] one
    assert imp.values["limits"]["max_jerk_mm_per_s3"] == [8000.0, 9000.0, 9000.0]
    # the trapezoidal planner (2.9, and 2.10's type 0) has no jerk limit: the bundled stays
    imp = import_linuxcnc(_ini(tmp_path, _x("", jerk)), TARGET)
    assert "max_jerk_mm_per_s3" not in imp.values.get("limits", {})
    assert any("MAX_JERK/MAX_LINEAR_JERK in AXIS_X" in a for a in imp.assumed)


def test_a_limit_of_zero_is_not_set_rather_than_an_error(tmp_path):
    # the checks against the machine file's ranges leave 0 to the rules that were there
    text = _x("MAX_VELOCITY = 0\nMAX_JERK = 0\n").replace(
        "[TRAJ]\n", "[TRAJ]\nPLANNER_TYPE = 1\nMAX_LINEAR_JERK = 5000\n"
    )
    imp = import_linuxcnc(_ini(tmp_path, text), TARGET)
    assert "max_velocity_mm_per_s" not in imp.values.get("limits", {})
    assert any("MAX_VELOCITY not set for X" in a for a in imp.assumed)
    assert imp.values["limits"]["max_jerk_mm_per_s3"] == [5000.0] * 3


def test_tool_table_lines_linuxcnc_skips_are_skipped(tmp_path):
    (tmp_path / "tool.tbl").write_text(
        "TOOLNO POCKET LENGTH DIAMETER COMMENT\nT1 P1 Z0.5 D0.125 ;end mill\n"
    )
    text = _x("") + "[EMCIO]\nTOOL_TABLE = tool.tbl\n"
    imp = import_linuxcnc(_ini(tmp_path, text), TARGET)
    assert imp.values["tools"] == {"1": {"length_mm": 0.5, "diameter_mm": 0.125}}
    assert any("tool.tbl:1: 'TOOLNO POCKET" in a and "skipped" in a for a in imp.assumed)


def test_stored_start_up_state_linuxcnc_would_apply_is_said(tmp_path):
    (tmp_path / "linuxcnc.var").write_text("5210 1\n5211 10\n5220 2\n5241 50\n")
    text = _x("") + (
        "[RS274NGC]\nPARAMETER_FILE = linuxcnc.var\nDISABLE_G92_PERSISTENCE = 1\n"
        "RS274NGC_STARTUP_CODE = G21 G90 G92.1\n"
    )
    imp = import_linuxcnc(_ini(tmp_path, text), TARGET)
    assert imp.values["work"] == {"g55_mm": [50.0, 0.0, 0.0]}  # no G92: cleared at start-up
    assert any("DISABLE_G92_PERSISTENCE" in a for a in imp.assumed)
    assert any("#5220 = 2" in n and "G55" in n for n in imp.not_mapped)
    assert any("RS274NGC_STARTUP_CODE" in n for n in imp.not_mapped)


@pytest.mark.parametrize("value", ["1e999", "-1e999", "nan", "inf", "2e6"])
def test_a_stored_offset_no_machine_file_holds_is_an_error_at_its_var_line(tmp_path, value):
    # 1e999 had been exit 3 (a non-finite TOML value), nan and inf dropped without a word
    (tmp_path / "m.var").write_text(f"5220 {value}\n5221\t{value}\n")
    text = _x("") + "[RS274NGC]\nPARAMETER_FILE = m.var\n"
    with pytest.raises(ConfigError, match="a stored offset must be a finite number") as err:
        import_linuxcnc(_ini(tmp_path, text), TARGET)
    assert (err.value.file, err.value.line) == (str(tmp_path / "m.var"), 2)


def test_a_following_error_of_zero_is_left_to_the_bundled_value(tmp_path):
    # LinuxCNC's own simulated sample configurations (db_demo) set FERROR = 0
    text = _x("") + "".join(f"[JOINT_{j}]\nFERROR = 0\n" for j in range(3))
    imp = import_linuxcnc(_ini(tmp_path, text), TARGET)
    assert "max_following_error_mm" not in imp.values.get("servo", {})
    assert any("[JOINT_0] FERROR = 0" in a for a in imp.assumed)


def test_out_may_not_be_the_file_being_imported(tmp_path, capsys):
    # it had silently replaced the INI with the machine file
    ini = _ini(tmp_path, _x(""))
    before = ini.read_text()
    assert main(["machine", "import", "linuxcnc", str(ini), "--out", str(ini)]) == 2
    assert "--out is the file being imported" in capsys.readouterr().err
    assert ini.read_text() == before


def test_a_tool_table_that_is_no_regular_file_is_said_so(tmp_path):
    (tmp_path / "tools").mkdir()
    imp = import_linuxcnc(_ini(tmp_path, _x("") + "[EMCIO]\nTOOL_TABLE = tools\n"), TARGET)
    assert any("TOOL_TABLE tools: not a regular file beside the INI" in a for a in imp.assumed)


def test_a_stored_origin_beyond_the_shortened_travel_is_said(tmp_path):
    # a mill of +-600 mm X on the model's 600 mm: its G54 at X -456 is off the written travel
    (tmp_path / "m.var").write_text("5221 -456\n")
    text = _x("MIN_LIMIT = -600\nMAX_LIMIT = 600\n") + "[RS274NGC]\nPARAMETER_FILE = m.var\n"
    imp = import_linuxcnc(_ini(tmp_path, text), TARGET)
    assert imp.values["travel"]["min_mm"][0] == -300.0
    assert any(
        a.startswith("g54_mm [-456.0, 0.0, 0.0] lies outside [travel]") and "in G54" in a
        for a in imp.assumed
    )
