"""Sweeps: the grid, per-point machines, executors giving the same numbers, resume, CSV."""

from __future__ import annotations

import csv
import json

import pytest

from gantry_sim.sim.cli import main
from gantry_sim.sim.sweep.grid import (
    COLUMNS,
    JOURNAL,
    SweepPoint,
    fingerprint,
    grid,
    machine_for,
    run_sweep,
    write_csv_atomic,
)

# A tiny program: a 3 mm circle at 2400 mm/min (about 0.6 s simulated); up to 150 % the
# circle's v^2/R stays well below the accel limits, so a higher override finishes sooner.
TINY = "G21 G90 G17\nG0 X3 Y0\nG3 I-3 J0 F2400\nM2\n"


def test_grid_is_the_full_product_in_order():
    pts = grid([50, 100], [1000.0, 2000.0], None)
    assert [(p.feed_override_pct, p.max_accel_mm_per_s2, p.max_jerk_mm_per_s3) for p in pts] == [
        (50.0, 1000.0, None),
        (50.0, 2000.0, None),
        (100.0, 1000.0, None),
        (100.0, 2000.0, None),
    ]
    assert len(grid([100], [1.0, 2.0], [3.0, 4.0, 5.0])) == 6


def test_machine_for_sets_all_axes_and_keeps_the_rest(machine):
    m = machine_for(machine, SweepPoint(100.0, 1234.0, None))
    assert m.limits.max_acceleration_mm_per_s2 == (1234.0, 1234.0, 1234.0)
    assert m.limits.max_jerk_mm_per_s3 == machine.limits.max_jerk_mm_per_s3
    assert machine_for(machine, SweepPoint(50.0)) is machine


@pytest.mark.slow  # starts a Dask LocalCluster: 7-16 s, the slowest test here
def test_local_and_dask_executors_give_the_same_numbers(machine):
    pytest.importorskip("dask.distributed")
    pts = grid([100.0, 150.0], [2000.0], None)
    local = run_sweep(TINY, pts, machine, executor="local", workers=2)
    dask = run_sweep(TINY, pts, machine, executor="dask", workers=2)
    assert local == dask
    assert [r["feed_override_pct"] for r in local] == [100.0, 150.0]
    assert all(r["status"] == "ok" for r in local)
    # A faster feed finishes sooner.
    assert local[1]["cycle_time_s"] < local[0]["cycle_time_s"]


def test_resume_reuses_the_journal_of_the_same_sweep_only(machine, tmp_path):
    pts = grid([100.0], None, None)
    tag = fingerprint(TINY, "linuxcnc", machine)
    sentinel = {c: None for c in COLUMNS} | {"feed_override_pct": 100.0, "status": "from journal"}
    other = dict(sentinel, status="other sweep")
    with open(tmp_path / JOURNAL, "w") as fh:
        fh.write(json.dumps({"fingerprint": "0" * 16, "key": pts[0].key(), "row": other}) + "\n")
        fh.write(json.dumps({"fingerprint": tag, "key": pts[0].key(), "row": sentinel}) + "\n")
        fh.write('{"fingerprint": "cut sho')  # an interrupted write
    rows = run_sweep(TINY, pts, machine, out_dir=tmp_path, workers=1)
    assert rows == [sentinel]
    # A new point is simulated and journaled; the old one is still reused.
    pts2 = grid([100.0, 120.0], None, None)
    rows2 = run_sweep(TINY, pts2, machine, out_dir=tmp_path, workers=1)
    assert rows2[0] == sentinel and rows2[1]["status"] == "ok"
    journal = [json.loads(line) for line in (tmp_path / JOURNAL).read_text().splitlines()[3:]]
    assert [(r["fingerprint"], r["key"]) for r in journal] == [(tag, pts2[1].key())]


def test_a_simulation_fault_is_a_row_not_a_crash(tmp_path, machine):
    strict = tmp_path / "strict.toml"
    strict.write_text("[servo]\nmax_following_error_mm = 0.0001\n")
    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.models import DEFAULT_MACHINE

    rows = run_sweep(TINY, grid([100.0]), load_machine_config(DEFAULT_MACHINE, strict), workers=1)
    assert rows[0]["status"].startswith("simulation error")
    assert rows[0]["max_error_um"] != rows[0]["max_error_um"]  # NaN


def test_csv_is_written_whole(tmp_path):
    rows = [{c: None for c in COLUMNS} | {"feed_override_pct": 100.0, "status": "ok"}]
    write_csv_atomic(rows, tmp_path / "sweep.csv")
    assert [p.name for p in tmp_path.iterdir()] == ["sweep.csv"]
    with open(tmp_path / "sweep.csv") as fh:
        read = list(csv.DictReader(fh))
    assert list(read[0]) == list(COLUMNS)
    assert read[0]["feed_override_pct"] == "100.0" and read[0]["max_accel_mm_per_s2"] == ""


def test_cli_writes_csv_and_plots(tmp_path, write_program, capsys):
    prog = write_program(TINY)
    out = tmp_path / "out"
    rc = main(
        [
            "sweep",
            str(prog),
            "--feed-override",
            "80,120",
            "--max-jerk",
            "100000",
            "--workers",
            "1",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    with open(out / "sweep.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [(r["feed_override_pct"], r["max_jerk_mm_per_s3"]) for r in rows] == [
        ("80.0", "100000.0"),
        ("120.0", "100000.0"),
    ]
    assert {"cycle_time_s", "max_error_um", "rms_error_um"} <= set(rows[0])
    assert (out / "sweep_error_vs_feed.png").stat().st_size > 0
    assert (out / "sweep_cycle_vs_error.png").stat().st_size > 0
    assert not (out / JOURNAL).exists()
    assert capsys.readouterr().out.startswith("feed_override_pct,")


@pytest.mark.parametrize(
    "args",
    [["--feed-override", "fast"], ["--max-accel", "0"], ["--executor", "spark"]],
)
def test_cli_rejects_bad_options_with_status_2(write_program, args):
    with pytest.raises(SystemExit) as exc:
        main(["sweep", str(write_program(TINY)), *args])
    assert exc.value.code == 2


def test_cli_reports_a_bad_program_as_file_line(write_program, tmp_path, capsys):
    prog = write_program("G21\nG3 X1 Y1 F100\nM2\n")
    assert main(["sweep", str(prog), "--workers", "1", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"{prog}:2: error:" in err
