"""Marlin's M201/M203/M204/M205 in a plan: the limits change from their line on.

A :class:`~gantry_sim.controller.moves.Limits` event splits the program there: the part before
is planned with the limits in effect, the part after with the new ones, and the plans are
joined end to end as they are planned (:class:`JoinedPlans`: each part ends and starts at rest,
so the change is an exact stop; Marlin itself applies the change to the moves it plans next,
without stopping). What is applied:

* M201 X Y Z: the per-axis acceleration limits [mm/s^2];
* M203 X Y Z: the per-axis velocity limits [mm/s];
* M204 P (or S, its older form): the acceleration of feed moves [mm/s^2], applied as a cap on
  every axis' acceleration (min with M201's); R and T (retract, travel) are not modelled;
* M205 J: the junction deviation [mm], which is the G64 blend tolerance (:mod:`.blend`).

M205's X/Y/Z/E "jerk" (a junction speed jump in mm/s, not a jerk), B, S and T are not
modelled: the machine file's jerk limits stay.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import replace

import numpy as np

from gantry_sim.controller.config import MachineConfig, Segmentation
from gantry_sim.controller.errors import ConfigError, GcodeError
from gantry_sim.controller.moves import Arc, Event, Limits, Linear, Move, PathMove, Rapid, Spline
from gantry_sim.controller.planner.blend_types import Blend
from gantry_sim.controller.planner.cubic import PiecewiseCubic
from gantry_sim.controller.planner.path_control import Merge
from gantry_sim.controller.planner.result import Plan
from gantry_sim.controller.planner.segmented_curve import CurveBuilder, SegmentedCurve
from gantry_sim.controller.planner.vertices import ChordVertices
from gantry_sim.controller.spill import SpilledList

_AXES = "XYZ"


class _LimitState:
    """The Marlin limits in effect: M201's per-axis accelerations, M204's path acceleration."""

    def __init__(self, machine: MachineConfig) -> None:
        self.machine = machine
        self.axis_acc = list(machine.limits.max_acceleration_mm_per_s2)
        self.path_acc: float | None = None

    def apply(self, event: Limits) -> MachineConfig:
        values = dict(event.values)
        m = self.machine
        if event.code == "M201":
            self.axis_acc = [values.get(a, v) for a, v in zip(_AXES, self.axis_acc, strict=True)]
        elif event.code == "M203":
            vel = m.limits.max_velocity_mm_per_s
            new = tuple(values.get(a, v) for a, v in zip(_AXES, vel, strict=True))
            m = m.with_changes("limits", max_velocity_mm_per_s=list(new))
        elif event.code == "M204" and ("P" in values or "S" in values):
            self.path_acc = values.get("P", values.get("S"))
        elif event.code == "M205" and "J" in values and values["J"] > 0:
            m = m.with_changes("path", tolerance_mm=values["J"])
        acc = [min(a, self.path_acc) if self.path_acc else a for a in self.axis_acc]
        self.machine = m.with_changes("limits", max_acceleration_mm_per_s2=acc)
        return self.machine


def split_at_limits(
    items: Iterable[Move | Event], machine: MachineConfig
) -> Iterator[tuple[list[Move | Event], MachineConfig]]:
    """The program cut at its Limits events: (items, without the events; machine in effect)
    per part with moves; the events of a part without moves go to the next part (the last
    one's to the one before).

    The parts are made as they are asked for (a long print's items are read from disk part by
    part: memory holds a part, not the program), after a first pass over ``items`` that checks
    every Limits event: a value the machine cannot take is refused before anything is planned.
    """
    check = _LimitState(machine)
    for item in items:
        if isinstance(item, Limits):
            _apply(check, item)
    pending: tuple[list[Move | Event], MachineConfig] | None = None
    carry: list[Move | Event] = []
    for chunk, m in _cut(items, machine):
        if any(isinstance(i, Rapid | Linear | Arc | Spline) for i in chunk):
            if pending is not None:
                yield pending
            pending = (carry + chunk, m)
            carry = []
        else:
            carry += chunk
    if pending is None:
        yield carry, machine
        return
    pending[0].extend(carry)
    yield pending


def _cut(
    items: Iterable[Move | Event], machine: MachineConfig
) -> Iterator[tuple[list[Move | Event], MachineConfig]]:
    """The items between Limits events, each run with the machine in effect (the first with
    ``machine``), without the events."""
    state = _LimitState(machine)
    chunk: list[Move | Event] = []
    for item in items:
        if isinstance(item, Limits):
            yield chunk, state.machine
            chunk = []
            _apply(state, item)
        else:
            chunk.append(item)
    yield chunk, state.machine


def _apply(state: _LimitState, event: Limits) -> None:
    """``state`` with ``event`` applied; a value the machine cannot take is the program's
    error, on the event's line."""
    try:
        state.apply(event)
    except ConfigError as exc:  # the program's value, not the machine file's
        raise GcodeError(
            f"{event.code} on this line would set the machine's {exc.message}", line=event.line
        ) from None


class JoinedPlans:
    """The plans of a program's parts joined end to end as they are planned (each starts where,
    and at rest as, the one before ends), in the memory of one part: each part's reference
    goes into one :class:`~gantry_sim.controller.planner.segmented_curve.CurveBuilder` (to
    disk as its blocks fill, so a long print's reference is never laid out in memory) and its
    moves, path moves and blends into lists kept on disk; a part is not held once added.

    The joined reference's phase start times are the running sums of all the phases'
    durations, as one plan's are; its moves' start times are each part's plus the durations
    of the parts before it."""

    def __init__(self, seg: Segmentation) -> None:
        """``seg``: the machine's segmentation (the same for every part), for the chord
        vertices."""
        self._seg = seg
        self._curve = CurveBuilder()
        self._moves: SpilledList[Move] = SpilledList()
        self._path_moves: SpilledList[PathMove] = SpilledList()
        self._blends: SpilledList[Blend] = SpilledList()
        self._merges: list[Merge] = []
        self._starts: list[np.ndarray] = []
        self._lines: list[np.ndarray] = []
        self._move_sources: list[np.ndarray] = []
        self._path_sources: list[np.ndarray] = []
        self._duration_s = 0.0
        self._segments = 0
        self._ruckig = 0
        self._parts = 0
        self._last: Plan | None = None

    def add(self, plan: Plan) -> None:
        """Join ``plan`` (a part's, from the planner: its reference a
        :class:`~gantry_sim.controller.planner.segmented_curve.SegmentedCurve`) after the
        parts added before."""
        if not isinstance(plan.curve, SegmentedCurve):
            raise TypeError(f"a part's reference must be a SegmentedCurve, not {plan.curve!r}")
        for block in plan.curve.blocks():
            self._curve.extend([block])
        first = len(self._moves)  # sources index program moves, in both lists
        self._starts.append(plan.move_start_s + self._duration_s)
        self._lines.append(plan.move_lines)
        self._move_sources.append(_shifted(plan.move_sources, first))
        self._path_sources.append(_shifted(plan.path_sources, first))
        self._moves.extend(plan.moves)
        self._path_moves.extend(plan.path_moves)
        self._blends.extend(plan.blends)
        self._merges.extend(plan.merges)
        self._duration_s += plan.duration_s
        self._segments += plan.segment_count
        self._ruckig += plan.ruckig_piece_count
        self._parts += 1
        # the last part's own fields (end, tolerance) are the joined plan's; its reference and
        # lists are not kept
        self._last = replace(plan, curve=PiecewiseCubic(()), moves=(), path_moves=(), blends=())

    def finish(self) -> Plan:
        """The joined plan (the joiner is left empty)."""
        if self._last is None:
            raise ValueError("no part was added")
        arrays = (
            np.concatenate(self._starts),
            np.concatenate(self._lines),
            np.concatenate(self._move_sources).reshape(-1, 2),
            np.concatenate(self._path_sources).reshape(-1, 2),
        )
        for arr in arrays:
            arr.setflags(write=False)
        starts, lines, move_sources, path_sources = arrays
        moves = self._moves
        return replace(
            self._last,
            moves=moves,
            duration_s=self._duration_s,
            segment_count=self._segments,
            vertices=ChordVertices(moves, self._seg),
            ruckig_piece_count=self._ruckig,
            curve=self._curve.finish(),
            move_start_s=starts,
            move_lines=lines,
            blends=self._blends,
            merges=tuple(self._merges),
            path_moves=self._path_moves,
            move_sources=move_sources,
            path_sources=path_sources,
            limit_change_stops=self._parts - 1,
        )


def _shifted(sources: np.ndarray, first: int) -> np.ndarray:
    """(n, 2) indices into a part's moves as indices into all (-1: none, kept)."""
    return np.where(sources >= 0, sources + first, -1).astype(np.int64)
