"""Bounds on the cost of a simulation, checked after planning and before anything is sampled.

A simulation's wall time grows with its servo ticks and MuJoCo physics steps (about 300,000
steps per second on one core for the bundled model: a run takes about a second per two
simulated minutes), and so does its trace.npz (15-40 kB per simulated second, deflated: 111 MB
for 7,000 s of one slow move, 324 MB for a 8,430 s print; ``gantry plan --out``'s file, deflated
the same way, 19-34 kB a second on a pocket and a print). Its memory does not: a run past
65,536 ticks is streamed (7,000 s of one slow move peaked at 253 MB for the process tree, 700 s
at 238 MB); what grows is the plan, with the moves (about 0.7 kB a move, measured on 100,000
short G1, benchmarks/bench_run.py). A program such as ``G1 X1 F0.0001`` (600,000 s) or a
machine file with a tiny physics timestep would run for hours and fill the disk with its trace;
it is refused up front instead, with the figures and the option that raises the bound
(``--max-sim-s``, ``--max-physics-steps``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from gantry_sim.controller.errors import ConfigError, PlanningError
from gantry_sim.sim.duration_bound import duration_lower_bound

if TYPE_CHECKING:  # no numpy or config import when the CLI only builds its parser
    from gantry_sim.controller.config import MachineConfig

DEFAULT_MAX_SIM_S = 7200.0
DEFAULT_MAX_PHYSICS_STEPS = 20_000_000
#: servo ticks allowed per second of --max-sim-s: the memory bound is stated at 1 kHz
TICKS_PER_BUDGET_S = 1000.0


class BudgetError(PlanningError):
    """The simulation would exceed its :class:`Budget`. ``summary``: the message without
    reference to a program line (for programs gantry writes itself, e.g. the ballbar's)."""

    def __init__(
        self, message: str, summary: str = "", file: str | None = None, line: int | None = None
    ) -> None:
        super().__init__(message, file=file, line=line)
        self.summary = summary or message


@dataclass(frozen=True)
class Budget:
    """The largest simulation run without asking: simulated time [s] and MuJoCo steps;
    ``action``: what the bound holds back, as its messages say it ("simulate", or "plan" for
    ``gantry plan --out``, which writes the reference sampled every servo period)."""

    max_sim_s: float = DEFAULT_MAX_SIM_S
    max_physics_steps: float = DEFAULT_MAX_PHYSICS_STEPS
    action: str = "simulate"

    def __post_init__(self) -> None:
        for name, value in (
            ("--max-sim-s", self.max_sim_s),
            ("--max-physics-steps", self.max_physics_steps),
        ):
            if not (isinstance(value, (int, float)) and value > 0) or math.isnan(value):
                raise ConfigError(f"{value}: must be a number > 0", file=name)


def _longest_move(plan) -> tuple[int | None, float]:
    """(line, duration [s]) of the plan's longest move (None when it has no moves)."""
    import numpy as np

    starts = np.asarray(plan.move_start_s, dtype=float)
    lines = np.asarray(plan.move_lines)
    if starts.size == 0:
        return None, 0.0
    ends = np.append(starts[1:], plan.duration_s)
    k = int(np.argmax(ends - starts))
    return int(lines[k]), float(ends[k] - starts[k])


def check_budget(plan, machine: MachineConfig, budget: Budget, file: str) -> None:
    """Raise PlanningError (on the longest move's line) if simulating ``plan`` would exceed
    ``budget``; the message gives the estimate, the bound and the option to raise it."""
    line, longest = _longest_move(plan)
    _check_duration(float(plan.duration_s), line, longest, machine, budget, file, "")


def check_lower_bound(
    items: Iterable[object],
    machine: MachineConfig,
    budget: Budget,
    file: str,
    feed_override_pct: float = 100.0,
) -> None:
    """Raise the error of :func:`check_budget` before planning when even
    :func:`duration_lower_bound` exceeds ``budget`` (the plan would be refused after it).

    A program beyond the bound that also leaves the machine's travel is refused for the
    travel (PlanningError, as planning would refuse it): an option lifts the bound, none
    makes the program fit, so that is the first thing to tell. ``items`` is read again then,
    so it must be a sequence or a list kept on disk, not an iterator."""
    duration, where, longest = duration_lower_bound(items, machine, feed_override_pct)
    _check_bound(duration, where, longest, items, machine, budget, file)


def _check_bound(
    duration: float,
    where: tuple[int, str | None] | None,
    longest: float,
    items: Iterable[object],
    machine: MachineConfig,
    budget: Budget,
    file: str,
    partial: bool = False,
) -> None:
    """:func:`check_lower_bound`'s checks on a bound [s], its longest line (line, subroutine
    file) and that line's time [s]; ``items``: the program read so far, for the travel
    (``partial``: only a first part of it, which a travel error then says)."""
    line, sub_file = where if where is not None else (None, None)
    try:
        _check_duration(duration, line, longest, machine, budget, sub_file or file, "at least ")
    except BudgetError:
        from gantry_sim.controller.planner.travel import TravelError, check_program_travel

        try:
            check_program_travel(items, machine.travel, machine.work.systems_mm[0])
        except TravelError as exc:
            if partial:  # the whole program's extent is not known: no offset to suggest
                exc.offset_mm = None
                exc.message = exc.where_and_extent + (
                    " (in the part read before its duration bound stopped the reading: that "
                    "part alone is beyond the simulation budget too)"
                )
            raise
        raise


class ParseBound:
    """:func:`check_lower_bound` taken as the program is read (called with each item and the
    items so far: sim.program.interpret_program's ``watch``), so that a program whose first
    items already take longer than ``budget`` is refused then, not after the whole of it is
    read: ``G81 ... L1000000`` (3 million moves) was read for 64 s before its refusal, 10 s
    now (the cycle's moves are made before the first is seen).

    Every :data:`EVERY` items the bound of the stretches closed so far (a lower bound on the
    whole program, sim.duration_bound.BoundWalk) is checked, the travel of the items so far
    first, as :func:`check_lower_bound` does. A stretch closes at a rest (a dwell, a stop, a
    reversal), so a program that runs on without one is checked whole once read (an open
    stretch's figure can still fall: a naive-CAM merge replaces its moves by their chord). A
    program of fewer items (read in a second or two) is checked whole after its reading, so
    its message gives the whole program's bound. Off for the rest of the program at a Marlin
    M201-M205 (a later M203 may raise the speed cap the bound assumed) and at an item whose
    numbers the planner refuses (the whole-program check says why). :meth:`check` then makes
    the whole-program check, from the bound taken while reading where it stayed on."""

    #: items read between two checks (about 1.5 s of reading)
    EVERY = 65_536

    def __init__(
        self, machine: MachineConfig, budget: Budget, file: str, feed_override_pct: float = 100.0
    ) -> None:
        from gantry_sim.controller.moves import Limits
        from gantry_sim.controller.planner.magnitudes import check_magnitudes
        from gantry_sim.sim.duration_bound import BoundWalk

        self.machine, self.budget, self.file = machine, budget, file
        self.feed_override_pct = feed_override_pct
        vmax = list(machine.limits.max_velocity_mm_per_s)
        self._walk = BoundWalk(machine, feed_override_pct, vmax, accel_set=False)
        self._limits, self._check_magnitudes = Limits, check_magnitudes
        self.on = True
        self._count = 0

    def __call__(self, item: object, so_far: Iterable[object]) -> None:
        if not self.on:
            return
        if isinstance(item, self._limits):
            self.on = False
            return
        try:
            self._check_magnitudes(item)
        except PlanningError:
            self.on = False
            return
        self._walk.add(item)
        self._count += 1
        if self._count % self.EVERY == 0:
            where, longest = self._walk.longest()
            total = self._walk.total_s
            _check_bound(
                total, where, longest, so_far, self.machine, self.budget, self.file, partial=True
            )

    def check(self, items: Iterable[object]) -> None:
        """:func:`check_lower_bound` of the whole program ``items`` (the items given so far)."""
        if not self.on:
            check_lower_bound(items, self.machine, self.budget, self.file, self.feed_override_pct)
            return
        duration, where, longest = self._walk.finish()
        self.on = False
        _check_bound(duration, where, longest, items, self.machine, self.budget, self.file)


def _option_value(x: float) -> str:
    """``x`` rounded up, as an option to pass: a whole number up to 1e15, beyond that three
    significant digits (a feed of 1e-300 mm/min asked for a 303-digit --max-sim-s)."""
    if x <= 1e15:
        return str(math.ceil(x))
    return f"{x * 1.01:.3g}"  # 3 digits move it by at most 0.5 %: still above x


def _check_duration(
    duration: float,
    line: int | None,
    longest: float,
    machine: MachineConfig,
    budget: Budget,
    file: str,
    at_least: str,
) -> None:
    """The checks of :func:`check_budget` on a duration [s] (``at_least``: "at least " when
    it is a lower bound) and the longest move's line and duration."""
    ticks = duration / machine.servo.period_s
    substeps = max(1, round(machine.servo.period_s / machine.sim.physics_timestep_s))
    steps = ticks * substeps
    above = "above " if at_least else ""  # a lower bound: that much would not do either
    # a line's moves or its dwell: "this line alone" says both (a G4 P1 line is no move)
    on_line = f" (this line alone takes {at_least}{longest:.6g} s)" if line is not None else ""
    if duration > budget.max_sim_s:
        # (a feed of 1e-320 mm/min makes the time infinite: no bound simulates that)
        anyway = (
            f", or pass --max-sim-s {above}{_option_value(duration)} to {budget.action} it anyway"
            if math.isfinite(duration)
            else ""
        )
        cost = (
            "the time to simulate it and the trace written grow with it: about 1 s and 2-5 MB "
            "per 2 simulated minutes"
            if budget.action == "simulate"
            else "the reference written grows with it: 20-40 kB per simulated second"
        )
        bound = (
            f", beyond the bound of {budget.max_sim_s:g} s ({cost}); check the feeds (F is in "
            f"mm/min) and dwells{anyway}"
        )
        raise BudgetError(
            f"the program takes {at_least}{duration:.6g} s of simulated time{on_line}{bound}",
            f"it takes {at_least}{duration:.6g} s of simulated time{bound}",
            file=file,
            line=line,
        )
    if ticks > budget.max_sim_s * TICKS_PER_BUDGET_S:
        need = _option_value(ticks / TICKS_PER_BUDGET_S)
        message = (
            f"simulating it takes {at_least}{ticks:.3g} servo ticks ({duration:.6g} s at "
            f"[servo] period_s = {machine.servo.period_s:g}), beyond the bound of "
            f"{budget.max_sim_s * TICKS_PER_BUDGET_S:.3g} (--max-sim-s counts 1000 ticks a "
            f"second); pass --max-sim-s {above}{need} to {budget.action} it anyway"
        )
        raise BudgetError(message, message, file=file)
    if steps > budget.max_physics_steps:
        message = (
            f"simulating it takes {at_least}{steps:.3g} MuJoCo physics steps ({duration:.6g} s "
            f"at [sim] physics_timestep_s = {machine.sim.physics_timestep_s:g}), beyond the "
            f"bound of {budget.max_physics_steps:.3g} (about a minute of computing); use a "
            f"larger physics timestep, or pass --max-physics-steps {above}{_option_value(steps)} to "
            "simulate it anyway"
        )
        raise BudgetError(message, message, file=file)
