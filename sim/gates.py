"""Gates on one run's report: contour-error limits (all feed moves, per motion kind, per line
range) and a cycle-time limit. The verdict lands in report.json ("verdict"); exit 1 when failed.

Limits are written as on the command line (``gantry run --help``)::

    --max-error-um 8                 every feed block (the max over all feed moves) <= 8 um
    --max-error-um arc=5,linear=8    arcs (G2/G3) <= 5 um, straight feeds (G1) <= 8 um
    --max-error-um-lines 10-40=3     blocks on program lines 10..40 (inclusive) <= 3 um
    --max-cycle-time-s 20            the planned cycle time <= 20 s

Every limit applies to each block in its scope (a block = the samples executing one program
line); a run passes when no block exceeds any limit that covers it. Baseline comparison (a run
against an earlier report.json) is :mod:`gantry_sim.sim.compare`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

from gantry_sim.controller.errors import ConfigError
from gantry_sim.sim.block_files import place

#: the motion kinds a limit may name (controller.moves' feed moves)
KINDS = ("linear", "arc", "spline")
#: lines listed per failure at most (a 100,000-block program must not flood report.json)
MAX_LINES_LISTED = 20


@dataclass(frozen=True)
class ErrorLimit:
    """A max contour error [um] for the feed blocks in a scope.

    Attributes:
        limit_um: the largest block max error allowed [um].
        kind: "linear", "arc" or "spline" only; None: every feed block.
        lines: (first, last) program lines, inclusive; None: every line.
    """

    limit_um: float
    kind: str | None = None
    lines: tuple[int, int] | None = None

    def covers(self, line: int, kind: str, file: str | None = None) -> bool:
        """Whether the limit applies to the block of program ``line`` of motion ``kind`` (in
        the subroutine file ``file``: lines FIRST-LAST are the program's own, not the file's)."""
        if self.kind is not None and kind != self.kind:
            return False
        if self.lines is None:
            return True
        return file is None and self.lines[0] <= line <= self.lines[1]

    def label(self) -> str:
        """The limit as the option that sets it, e.g. ``--max-error-um arc=5``."""
        if self.lines is not None:
            a, b = self.lines
            span = f"{a}" if a == b else f"{a}-{b}"
            return f"--max-error-um-lines {span}={self.limit_um:g}"
        if self.kind is not None:
            return f"--max-error-um {self.kind}={self.limit_um:g}"
        return f"--max-error-um {self.limit_um:g}"


class LineKind(Protocol):
    """A move's source line and kind ("linear", "arc", ...): controller.moves.Move."""

    @property
    def line(self) -> int: ...

    @property
    def kind(self) -> str: ...


@dataclass(frozen=True)
class Gates:
    """Every limit set for a run (empty: the run always passes)."""

    errors: tuple[ErrorLimit, ...] = ()
    max_cycle_time_s: float | None = None

    def line_kinds(self, moves: Iterable[LineKind]) -> dict[int, str]:
        """{line: the kind of its move} of ``moves`` for the limits on a kind of move (error.png
        draws them where those moves run); {} when no limit names a kind."""
        if all(lim.kind is None for lim in self.errors):
            return {}
        return {mv.line: mv.kind for mv in moves}

    def labels(self) -> list[str]:
        out = [e.label() for e in self.errors]
        if self.max_cycle_time_s is not None:
            out.append(f"--max-cycle-time-s {self.max_cycle_time_s:g}")
        return out


def _limit(text: str, option: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise ConfigError(f"'{text}' must be a number >= 0", file=option)
    return value


def parse_error_limits(text: str) -> list[ErrorLimit]:
    """``8`` or ``arc=5,linear=8`` (``--max-error-um``) -> limits [um] (ConfigError if bad)."""
    option = "--max-error-um"
    out: list[ErrorLimit] = []
    for item in (p.strip() for p in text.split(",")):
        if "=" not in item:
            out.append(ErrorLimit(_limit(item, option)))
            continue
        kind, value = (s.strip() for s in item.split("=", 1))
        if kind not in KINDS:
            raise ConfigError(
                f"'{item}': the kind must be one of {', '.join(KINDS)} (e.g. arc=5)", file=option
            )
        out.append(ErrorLimit(_limit(value, option), kind=kind))
    return out


def parse_line_limits(text: str) -> list[ErrorLimit]:
    """``10-40=3`` or ``12=2.5,50-60=4`` (``--max-error-um-lines``) -> limits [um]."""
    option = "--max-error-um-lines"
    out: list[ErrorLimit] = []
    for item in (p.strip() for p in text.split(",")):
        span, sep, value = item.partition("=")
        first, _, last = span.partition("-")
        try:
            a = int(first)
            b = int(last) if last.strip() else a
        except ValueError:
            a = b = -1
        if not sep or a < 1 or b < a:
            raise ConfigError(
                f"'{item}' is not FIRST-LAST=UM or LINE=UM (program lines, e.g. 10-40=3)",
                file=option,
            )
        out.append(ErrorLimit(_limit(value, option), lines=(a, b)))
    return out


def gates_from_options(
    max_error_um: Iterable[str] = (),
    max_error_um_lines: Iterable[str] = (),
    max_cycle_time_s: float | None = None,
) -> Gates:
    """The gates of ``gantry run``'s options (each error option may be given several times)."""
    errors = [lim for t in max_error_um for lim in parse_error_limits(t)]
    errors += [lim for t in max_error_um_lines for lim in parse_line_limits(t)]
    if max_cycle_time_s is not None:
        _limit(str(max_cycle_time_s), "--max-cycle-time-s")
    return Gates(tuple(errors), max_cycle_time_s)


class BlockLike(Protocol):
    """A feed block's figures as a typed report gives them (sim.contour.BlockError)."""

    @property
    def line(self) -> int: ...

    @property
    def kind(self) -> str: ...

    @property
    def max_error_um(self) -> float: ...

    @property
    def file(self) -> str | None: ...


class ReportLike(Protocol):
    """A typed report (sim.report.RunReport): its blocks and cycle time [s]."""

    @property
    def blocks(self) -> Sequence[BlockLike]: ...

    @property
    def cycle_time_s(self) -> float: ...


def _blocks(
    report: Mapping[str, Any] | ReportLike,
) -> Iterator[tuple[int, str, float, str | None]]:
    """(line, kind, max error [um], subroutine file or None) per feed block of a report.json
    object or a typed report (read as they come: a 100,000-block report is not made into dicts
    for this)."""
    if isinstance(report, Mapping):
        for b in report["blocks"]:
            yield int(b["line"]), b["kind"], b["max_error_um"], b.get("file")
    else:
        for t in report.blocks:
            yield t.line, t.kind, t.max_error_um, t.file


def evaluate(report: Mapping[str, Any] | ReportLike, gates: Gates) -> list[dict[str, Any]]:
    """The failures of ``report`` (report.json's object, or the typed report) against
    ``gates``, one per limit exceeded: {"gate", "value", "limit", "unit", "line" (the worst
    block), "blocks_over", "lines" (the first 20 over), "message"}, and "file" where the worst
    block is a subroutine file's line."""
    failures: list[dict[str, Any]] = []
    for lim in gates.errors:
        over = [b for b in _blocks(report) if lim.covers(b[0], b[1], b[3]) and b[2] > lim.limit_um]
        if not over:
            continue
        line, kind, value, file = max(over, key=lambda b: b[2])
        failure = {
            "gate": lim.label(),
            "value": value,
            "limit": lim.limit_um,
            "unit": "um",
            "line": line,
            "blocks_over": len(over),
            "lines": [b[0] for b in over[:MAX_LINES_LISTED]],
            "message": f"{place(line, file)} ({kind}): max contour error "
            f"{value:.3f} um > {lim.limit_um:g} um ({lim.label()}; "
            f"{len(over)} block(s) over)",
        }
        if file is not None:
            failure["file"] = file
        failures.append(failure)
    cap = gates.max_cycle_time_s
    cycle = report["cycle_time_s"] if isinstance(report, Mapping) else report.cycle_time_s
    if cap is not None and cycle > cap:
        failures.append(
            {
                "gate": f"--max-cycle-time-s {cap:g}",
                "value": cycle,
                "limit": cap,
                "unit": "s",
                "line": None,
                "blocks_over": 0,
                "lines": [],
                "message": f"cycle time {cycle:.3f} s > {cap:g} s (--max-cycle-time-s)",
            }
        )
    return failures


@dataclass(frozen=True)
class Verdict:
    """report.json "verdict": passed, the gates set (as their options), and why it failed.

    Attributes:
        passed: no gate failed (True when no gate was set).
        gates: every gate set, as the option that set it (``--max-error-um arc=5``, ...).
        failures: one object per limit exceeded (see :func:`evaluate`).
        baseline: the baseline report compared with, or None.
    """

    passed: bool = True
    gates: tuple[str, ...] = ()
    failures: tuple[dict[str, Any], ...] = ()
    baseline: str | None = None

    def to_json(self) -> dict[str, Any]:
        return {
            "passed": self.passed,
            "gates": list(self.gates),
            "failures": [dict(f) for f in self.failures],
            "baseline": self.baseline,
        }


def verdict_for(
    report: Mapping[str, Any] | ReportLike,
    gates: Gates,
    baseline_failures: Sequence[dict[str, Any]] = (),
    baseline: str | None = None,
) -> Verdict:
    """The verdict of ``report`` (report.json's object, or the typed report) on ``gates`` and,
    when compared with a baseline, that comparison's failures
    (:func:`gantry_sim.sim.compare.compare`)."""
    failures = evaluate(report, gates) + list(baseline_failures)
    labels = gates.labels() + ([f"--baseline {baseline}"] if baseline is not None else [])
    return Verdict(not failures, tuple(labels), tuple(failures), baseline)
