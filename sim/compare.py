"""A run against a baseline report.json, block by block: did the error or the time grow?

Blocks are matched by program line (report.json "blocks"). A block fails when its max contour
error grows by more than ``max(error_margin_um, error_margin_pct % of the baseline's)``, or its
time (report.json blocks[].time_s: servo ticks executing the line x servo period) grows by more
than ``max(time_margin_s, time_margin_pct % of the baseline's)``; the run fails when its cycle
time grows by more than the same time margin. Blocks in only one report are listed, not failed
(the program changed there). The simulation is deterministic: an unchanged program on an
unchanged machine gives exactly the baseline's numbers, so the margins only absorb changes a
user accepts.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from gantry_sim.controller.errors import ConfigError, shown
from gantry_sim.controller.input_files import REPORT_CAP_BYTES, read_capped
from gantry_sim.sim.block_files import place
from gantry_sim.sim.gates import MAX_LINES_LISTED

#: default margins (``gantry compare --help``)
ERROR_MARGIN_UM = 0.1
ERROR_MARGIN_PCT = 5.0
TIME_MARGIN_S = 0.001
TIME_MARGIN_PCT = 1.0
#: a change smaller than this is "unchanged" in the table (float noise, not a change)
_EPS_UM, _EPS_S = 5e-4, 5e-7


@dataclass(frozen=True)
class Margins:
    """How much a block may grow before it fails: the larger of the absolute and the relative
    margin (error [um] or [%]; time [s] or [%])."""

    error_um: float = ERROR_MARGIN_UM
    error_pct: float = ERROR_MARGIN_PCT
    time_s: float = TIME_MARGIN_S
    time_pct: float = TIME_MARGIN_PCT

    def error_allowed(self, base_um: float) -> float:
        return max(self.error_um, self.error_pct / 100.0 * base_um)

    def time_allowed(self, base_s: float) -> float:
        return max(self.time_s, self.time_pct / 100.0 * base_s)

    def describe(self) -> str:
        return (
            f"error +max({self.error_um:g} um, {self.error_pct:g}%), "
            f"time +max({self.time_s:g} s, {self.time_pct:g}%)"
        )


@dataclass(frozen=True)
class Row:
    """One block of the comparison (None where a report has no such block or no time)."""

    line: int
    kind: str
    base_error_um: float | None
    run_error_um: float | None
    base_time_s: float | None
    run_time_s: float | None
    status: str  # "ok", "changed", "FAIL error", "FAIL time", "FAIL error+time", "new", "gone"
    file: str | None = None  # the subroutine file the line is in (None: the program's own)

    @property
    def where(self) -> str:
        """The block's place: "line N", and "of FILE" for a subroutine file's line."""
        return place(self.line, self.file)


@dataclass(frozen=True)
class Comparison:
    rows: tuple[Row, ...]
    base_cycle_s: float
    run_cycle_s: float
    failures: tuple[dict[str, Any], ...]

    @property
    def passed(self) -> bool:
        return not self.failures


def load_report(path: Path) -> dict[str, Any]:
    """report.json, or the report.json inside folder ``path`` (ConfigError naming the file:
    missing, larger than :data:`~gantry_sim.controller.input_files.REPORT_CAP_BYTES`, not
    JSON, nested too deep, or not shaped as a report)."""
    path = Path(path)
    file = path / "report.json" if path.is_dir() else path
    if not file.exists() and not file.is_symlink():
        raise ConfigError("no report.json here (run `gantry run --out DIR` first)", file=str(file))
    raw = read_capped(file, "report", REPORT_CAP_BYTES)
    try:
        data = json.loads(raw.decode("utf-8-sig"))
    except RecursionError:  # [[[[... a thousand deep: json's decoder recurses per level
        raise ConfigError(
            "not a readable report.json: arrays or objects nested too deep", file=str(file)
        ) from None
    except (UnicodeDecodeError, ValueError) as exc:  # (json.JSONDecodeError is a ValueError)
        raise ConfigError(
            f"not a readable report.json: {shown(str(exc), 200)}", file=str(file)
        ) from None
    if not isinstance(data, dict) or not {"blocks", "cycle_time_s"} <= data.keys():
        raise ConfigError("not a gantry report.json (no blocks / cycle_time_s)", file=str(file))
    problem = _schema_problem(data)
    if problem:
        raise ConfigError(f"not a gantry report.json ({problem})", file=str(file))
    return data


def _number(x: Any) -> bool:
    """A finite JSON number >= 0 (not a bool) within the float range: report.json's times
    and errors are magnitudes (an integer of 400 digits exited 3: math.isfinite raised
    OverflowError on it; a negative time compared as if it were one)."""
    if not isinstance(x, int | float) or isinstance(x, bool):
        return False
    try:
        return math.isfinite(float(x)) and x >= 0
    except OverflowError:
        return False


def _schema_problem(data: dict[str, Any]) -> str:
    """What :func:`compare` would trip on in a report (empty when nothing): the cycle time a
    number, each block an object with an integer line, a number max_error_um and time_s a
    number or null."""
    if not _number(data["cycle_time_s"]):
        return f"cycle_time_s is {shown(data['cycle_time_s'])}, not a number >= 0 [s]"
    if not isinstance(data["blocks"], list):
        return "blocks is not a list"
    for i, b in enumerate(data["blocks"]):
        if not isinstance(b, dict):
            return f"blocks[{i}] is not an object"
        if not (isinstance(b.get("line"), int) and not isinstance(b.get("line"), bool)):
            return f"blocks[{i}].line is {shown(b.get('line'))}, not a line number"
        if b.get("file") is not None and not isinstance(b["file"], str):
            return f"blocks[{i}].file is {shown(b['file'])}, not a file name"
        if not _number(b.get("max_error_um")):
            return f"blocks[{i}].max_error_um is {shown(b.get('max_error_um'))}, not a number >= 0 [um]"
        if b.get("time_s") is not None and not _number(b["time_s"]):
            return f"blocks[{i}].time_s is {shown(b['time_s'])}, not a number >= 0 [s] or null"
    return ""


def _grew(base: float | None, run: float | None, allowed: float) -> bool:
    return base is not None and run is not None and run - base > allowed


def compare(base: dict[str, Any], run: dict[str, Any], margins: Margins) -> Comparison:
    """Compare report.json objects ``run`` against ``base`` block by block (module docstring)."""
    # a block is its line in its file: the program's own first ("" sorts first), then each
    # subroutine file's (sim.block_files)
    b_blocks = {(b.get("file") or "", int(b["line"])): b for b in base["blocks"]}
    r_blocks = {(b.get("file") or "", int(b["line"])): b for b in run["blocks"]}
    rows: list[Row] = []
    for key in sorted(b_blocks.keys() | r_blocks.keys()):
        b, r = b_blocks.get(key), r_blocks.get(key)
        file, line = key[0] or None, key[1]
        be = None if b is None else float(b["max_error_um"])
        re_ = None if r is None else float(r["max_error_um"])
        bt = None if b is None or b.get("time_s") is None else float(b["time_s"])
        rt = None if r is None or r.get("time_s") is None else float(r["time_s"])
        if b is None or r is None:
            status = "new" if b is None else "gone"
        else:
            err_fail = _grew(be, re_, margins.error_allowed(be or 0.0))
            time_fail = _grew(bt, rt, margins.time_allowed(bt or 0.0))
            if err_fail or time_fail:
                status = "FAIL " + "+".join(
                    w for w, f in (("error", err_fail), ("time", time_fail)) if f
                )
            elif abs((re_ or 0) - (be or 0)) > _EPS_UM or (
                bt is not None and rt is not None and abs(rt - bt) > _EPS_S
            ):
                status = "changed"
            else:
                status = "ok"
        kind = str((r or b or {}).get("kind", "?"))
        rows.append(Row(line, kind, be, re_, bt, rt, status, file))
    failures = _failures(rows, margins)
    bc, rc = float(base["cycle_time_s"]), float(run["cycle_time_s"])
    if _grew(bc, rc, margins.time_allowed(bc)):
        failures.append(
            {
                "gate": "baseline cycle time",
                "value": rc,
                "limit": bc + margins.time_allowed(bc),
                "unit": "s",
                "line": None,
                "blocks_over": 0,
                "lines": [],
                "message": f"cycle time {rc:.4f} s grew from {bc:.4f} s by more than "
                f"{margins.time_allowed(bc):.4g} s",
            }
        )
    return Comparison(tuple(rows), bc, rc, tuple(failures))


def _failures(rows: Sequence[Row], margins: Margins) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    for what, unit in (("error", "um"), ("time", "s")):
        bad = [r for r in rows if r.status.startswith("FAIL") and what in r.status]
        if not bad:
            continue

        def growth(r: Row, what: str = what) -> float:
            if what == "error":
                return (r.run_error_um or 0.0) - (r.base_error_um or 0.0)
            return (r.run_time_s or 0.0) - (r.base_time_s or 0.0)

        worst = max(bad, key=growth)
        base = worst.base_error_um if what == "error" else worst.base_time_s
        run = worst.run_error_um if what == "error" else worst.run_time_s
        allowed = (margins.error_allowed if what == "error" else margins.time_allowed)(base or 0.0)
        failure: dict[str, Any] = {
            "gate": f"baseline block {what}",
            "value": run,
            "limit": (base or 0.0) + allowed,
            "unit": unit,
            "line": worst.line,
            "blocks_over": len(bad),
            "lines": [r.line for r in bad[:MAX_LINES_LISTED]],
            "message": f"{worst.where} ({worst.kind}): block {what} {run:.4g} {unit} "
            f"grew from {base:.4g} {unit} by more than {allowed:.4g} {unit} "
            f"({len(bad)} block(s) over)",
        }
        if worst.file is not None:
            failure["file"] = worst.file
        out.append(failure)
    return out


def _num(v: float | None, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def _delta(a: float | None, b: float | None, fmt: str) -> str:
    return "-" if a is None or b is None else format(b - a, "+" + fmt)


def format_table(cmp: Comparison, margins: Margins, max_rows: int = 40) -> str:
    """The blocks that changed (failures first), then the cycle time and the verdict."""
    changed = [r for r in cmp.rows if r.status != "ok"]
    changed.sort(key=lambda r: (not r.status.startswith("FAIL"), r.file or "", r.line))
    head = (
        f"{'line':>6} {'kind':<6} {'base um':>9} {'run um':>9} {'d um':>8} "
        f"{'base s':>9} {'run s':>9} {'d s':>9}  status"
    )
    out = [f"margins: {margins.describe()}", head]
    for r in changed[:max_rows]:
        out.append(
            f"{r.line:>6} {r.kind:<6} {_num(r.base_error_um, '9.3f')} "
            f"{_num(r.run_error_um, '9.3f')} {_delta(r.base_error_um, r.run_error_um, '8.3f')} "
            f"{_num(r.base_time_s, '9.4f')} {_num(r.run_time_s, '9.4f')} "
            f"{_delta(r.base_time_s, r.run_time_s, '9.4f')}  {r.status}"
            + ("" if r.file is None else f"  ({r.file})")
        )
    if len(changed) > max_rows:
        out.append(f"... {len(changed) - max_rows} more changed block(s)")
    same = len(cmp.rows) - len(changed)
    out.append(f"{len(changed)} block(s) changed, {same} unchanged")
    out.append(
        f"cycle time: {cmp.base_cycle_s:.4f} s -> {cmp.run_cycle_s:.4f} s "
        f"({cmp.run_cycle_s - cmp.base_cycle_s:+.4f} s)"
    )
    out += [f"FAIL: {f['message']}" for f in cmp.failures]
    out.append("PASS" if cmp.passed else "FAIL")
    return "\n".join(out)
