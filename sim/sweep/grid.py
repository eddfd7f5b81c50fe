"""Parameter sweeps: one full simulation per grid point, on local processes or a Dask cluster.

A grid point sets the feed override [%] and, optionally, the max acceleration [mm/s^2] and
max jerk [mm/s^3] of all three axes (MachineConfig.with_changes on [limits]); a value left out
of the sweep keeps the machine file's per-axis values (an empty cell in sweep.csv).

Executors (:mod:`gantry_sim.sim.sweep.executors`): ``local`` processes or ``dask``. Each point is a
deterministic simulation of the same inputs, so the numbers do not depend on the executor.

Never half-written: each finished point is appended to a journal (DIR/sweep.partial.jsonl)
tagged with a fingerprint of the program, dialect and machine; a rerun of the same sweep reuses
the journal's points (resume), and sweep.csv appears, by rename, only when every point is done.
"""

from __future__ import annotations

import csv
import hashlib
import itertools
import json
import math
import sys
from collections.abc import Generator, Sequence
from pathlib import Path
from typing import TextIO

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.gcode.control import DEFAULT_MAX_ITERATIONS
from gantry_sim.sim.budget import Budget
from gantry_sim.sim.outdir import atomic_file
from gantry_sim.sim.sweep.executors import dask_map, local_map
from gantry_sim.sim.sweep.point import ProgramSetup, SweepPoint, machine_for, run_point

__all__ = ["SweepPoint", "machine_for", "run_point"]  # re-exported: where they were

COLUMNS = (
    "feed_override_pct",
    "max_accel_mm_per_s2",
    "max_jerk_mm_per_s3",
    "cycle_time_s",
    "max_error_um",
    "rms_error_um",
    "p95_error_um",
    "status",
)
JOURNAL = "sweep.partial.jsonl"


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C stopped a sweep: queued points cancelled, running ones terminated, the finished
    ones journaled. ``done`` of ``total`` grid points have a row; ``journal`` holds them (None
    without an output folder: nothing kept)."""

    def __init__(self, done: int, total: int, journal: Path | None) -> None:
        super().__init__(f"{done} of {total} grid point(s) done")
        self.done = done
        self.total = total
        self.journal = journal


def grid(
    feed_overrides_pct: Sequence[float],
    max_accels_mm_per_s2: Sequence[float] | None = None,
    max_jerks_mm_per_s3: Sequence[float] | None = None,
) -> list[SweepPoint]:
    """The full grid (feed override x accel x jerk), in that nesting order."""
    accels: Sequence[float | None] = max_accels_mm_per_s2 or [None]
    jerks: Sequence[float | None] = max_jerks_mm_per_s3 or [None]
    combos = itertools.product(feed_overrides_pct, accels, jerks)
    return [
        SweepPoint(float(f), None if a is None else float(a), None if j is None else float(j))
        for f, a, j in combos
    ]


def fingerprint(text: str, dialect: str, machine: MachineConfig, setup: ProgramSetup = ()) -> str:
    """Identifies the sweep's fixed inputs, so a journal is only resumed by the same sweep
    (the machine includes its tools and offsets; ``setup`` the subroutine folders and bound)."""
    inputs = (text, dialect, machine) + ((setup,) if setup else ())
    return hashlib.sha256(repr(inputs).encode()).hexdigest()[:16]


def _journal_record(raw: bytes) -> dict | None:
    """One journal line as {"fingerprint", "key", "row"}, or None when it is damaged (cut
    short by an interruption, not UTF-8, not JSON, or not a record of this shape)."""
    try:
        rec = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError):
        return None
    if not (
        isinstance(rec, dict)
        and isinstance(rec.get("fingerprint"), str)
        and isinstance(rec.get("key"), str)
        and isinstance(rec.get("row"), dict)
        and all(c in rec["row"] for c in COLUMNS)
    ):
        return None
    return rec


def read_journal(path: Path, tag: str) -> tuple[dict[str, dict], int]:
    """The rows of ``path`` recorded by the sweep ``tag`` (key -> row), and how many damaged
    lines were skipped. A damaged journal never blocks a sweep: a bad line (not UTF-8, not
    JSON, not a record) is skipped and counted; a last line without its newline is an
    interrupted write, skipped without being counted."""
    done: dict[str, dict] = {}
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return done, 0
    except OSError as exc:
        from gantry_sim.sim.outdir import os_error

        raise os_error(exc, path, "cannot read the sweep journal") from None
    lines = data.split(b"\n")
    bad = 0
    for i, raw in enumerate(lines):
        if not raw.strip():
            continue
        rec = _journal_record(raw)
        if rec is None:
            bad += i < len(lines) - 1  # the unterminated last line: cut short, not damage
            continue
        if rec["fingerprint"] == tag:
            done[rec["key"]] = rec["row"]
    return done, bad


def run_sweep(
    text: str,
    points: Sequence[SweepPoint],
    machine: MachineConfig,
    *,
    file: str = "<program>",
    dialect: str = "linuxcnc",
    executor: str = "local",
    workers: int | None = None,
    scheduler: str | None = None,
    out_dir: Path | None = None,
    progress: bool = False,
    budget: Budget | None = None,
    search_path: Sequence[Path] = (),
    max_iterations: int = DEFAULT_MAX_ITERATIONS,
) -> list[dict]:
    """Simulate every point; return the rows in grid order.

    Args:
        text: the G-code program.
        points: the grid (see ``grid``).
        machine: the base machine.
        file: the program's name for error messages.
        dialect: G-code dialect.
        executor: "local" (processes) or "dask".
        workers: processes / Dask workers (default: all cores).
        scheduler: a Dask scheduler address (dask only; default: a LocalCluster).
        out_dir: where the journal lives (resume); None: no journal.
        progress: show a tqdm progress bar on stderr.
        budget: each simulation's bounds (sim.budget.Budget; default Budget()).
        search_path: folders searched for subroutine files (the program's own first).
        max_iterations: bound on O-word loop repetitions and subroutine calls.

    Raises:
        SweepInterrupted: Ctrl-C; it comes within a second (queued points cancelled, running
            simulations terminated), the finished points are in the journal.
    """
    if executor not in ("local", "dask"):
        from gantry_sim.controller.errors import ConfigError

        raise ConfigError(f"executor {executor!r}: must be 'local' or 'dask'", file="--executor")
    folders = tuple(Path(p) for p in search_path)
    setup: ProgramSetup = ()
    if folders or max_iterations != DEFAULT_MAX_ITERATIONS:
        setup = (folders, max_iterations)
    tag = fingerprint(text, dialect, machine, setup)
    journal = out_dir / JOURNAL if out_dir is not None else None
    done: dict[str, dict] = {}
    if journal is not None:
        done, bad = read_journal(journal, tag)
        if bad:
            print(
                f"{journal}: warning: skipped {bad} damaged line(s) of the sweep journal "
                "(their points are simulated again)",
                file=sys.stderr,
            )
    todo = [p for p in points if p.key() not in done]
    if journal is not None and len(todo) < len(points):
        print(
            f"{journal}: resuming: {len(points) - len(todo)} of {len(points)} grid point(s) "
            "already done",
            file=sys.stderr,
        )
    if todo:
        rows: Generator[dict, None, None]
        if executor == "local":
            args = [(text, file, dialect, machine, p, budget, setup) for p in todo]
            rows = local_map(run_point, args, workers)
        else:  # no path of this host's on a worker: the model's files go as data
            from gantry_sim.sim.sweep.model_bundle import bundle_model
            from gantry_sim.sim.sweep.remote import run_shipped_point

            model = bundle_model(machine.sim.model)
            shared = (text, file, dialect, machine, budget, model, setup)
            rows = dask_map(run_shipped_point, shared, todo, workers, scheduler)
        from tqdm import tqdm

        if journal is not None:
            _end_last_line(journal)
        bar = tqdm(
            total=len(points),
            initial=len(points) - len(todo),
            disable=not progress,
            desc="sweep",
            unit="sim",
        )
        try:
            with bar:
                for row in rows:
                    key = SweepPoint(
                        row["feed_override_pct"],
                        row["max_accel_mm_per_s2"],
                        row["max_jerk_mm_per_s3"],
                    ).key()
                    done[key] = row
                    if journal is not None:
                        _append(journal, {"fingerprint": tag, "key": key, "row": row})
                    bar.update(1)
        except BaseException as stop:
            # stop the executor now: queued points cancelled, workers terminated (SIGTERM or
            # an error too: left to the garbage collector, its pool outlived the sweep)
            rows.close()
            if not isinstance(stop, KeyboardInterrupt):
                raise
            wanted = {p.key() for p in points}
            raise SweepInterrupted(len(wanted & done.keys()), len(wanted), journal) from None
    return [done[p.key()] for p in points]


def _end_last_line(journal: Path) -> None:
    """End a line an interruption cut short, so the next record starts on its own line."""
    try:
        journal.parent.mkdir(parents=True, exist_ok=True)
        if journal.exists() and not journal.read_bytes().endswith(b"\n"):
            with open(journal, "a") as fh:
                fh.write("\n")
    except OSError as exc:
        from gantry_sim.sim.outdir import os_error

        raise os_error(exc, journal, "cannot write the sweep journal") from None


def _append(journal: Path, record: dict) -> None:
    try:
        with open(journal, "a") as fh:
            fh.write(json.dumps(record) + "\n")
    except OSError as exc:
        from gantry_sim.sim.outdir import os_error

        raise os_error(exc, journal, "cannot write the sweep journal") from None


def _cell(v: object) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return "nan" if math.isnan(v) else repr(v)
    return str(v)


def write_csv(rows: Sequence[dict], fh: TextIO) -> None:
    """Write the rows as CSV (header COLUMNS) to an open text file."""
    w = csv.writer(fh, lineterminator="\n")
    w.writerow(COLUMNS)
    for row in rows:
        w.writerow([_cell(row[c]) for c in COLUMNS])


def write_csv_atomic(rows: Sequence[dict], path: Path) -> None:
    """Write sweep.csv atomically (:func:`gantry_sim.sim.outdir.atomic_file`), creating its folder."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_file(path, "w", newline="") as fh:
        write_csv(rows, fh)


#: most grid points one sweep runs (each is a full simulation)
MAX_POINTS = 10_000


def check_points(machine: MachineConfig, points: Sequence[SweepPoint]) -> None:
    """Refuse, before any simulation, a grid too large or a value the machine file's ranges
    refuse (the error names the option: --max-accel, --max-jerk or --feed-override)."""
    from gantry_sim.controller.errors import ConfigError

    if len(points) > MAX_POINTS:
        raise ConfigError(
            f"the grid has {len(points)} points, beyond the bound of {MAX_POINTS} simulations "
            "per sweep; split it into several sweeps",
            file="--feed-override",
        )
    for p in points:
        try:
            machine_for(machine, p)
        except ConfigError as exc:
            option = "--max-accel" if "acceleration" in exc.message else "--max-jerk"
            raise ConfigError(exc.message, file=option) from None
