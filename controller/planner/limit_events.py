"""Marlin's M201/M203/M204/M205 in a plan: the limits change from their line on.

M204 sets the path acceleration of the moves after it [mm/s^2], as Marlin's planner makes it
each block's acceleration (limited per axis by M201): P for the moves that extrude, T for the
travels (the moves whose E word does not move the extruder, or that have none:
:mod:`~gantry_sim.controller.gcode.extruder`), S (its older form) both; it cuts nothing. A
travel runs under P while no T (or S) has been given (Marlin's own travel acceleration, a
firmware setting, is not known here), and a move of another dialect, which follows no
extruder, under P. Each move runs under the value in effect on its line (:class:`Part`, per
motion): the planner caps a straight move's acceleration along the path at it and chooses a
curve's limits with every axis' acceleration capped at it
(:func:`~gantry_sim.controller.planner.move_geometry.capped_geometries`); the junctions'
pieces keep the machine's own per-axis limits. R (retract acceleration) is not modelled: a
move of E alone does not move the tool. M204 P0 (T0) caps nothing.

The events that change the machine itself split the program there: the part before is planned
with the limits in effect, the part after with the new ones, and the plans are joined end to
end as they are planned (:class:`JoinedPlans`: each part ends and starts at rest, so the change
is an exact stop, which Marlin does not make; a plan counts them,
:attr:`~gantry_sim.controller.planner.result.Plan.limit_change_stops`):

* M201 X Y Z: the per-axis acceleration limits [mm/s^2];
* M203 X Y Z: the per-axis velocity limits [mm/s];
* M205 J: the junction deviation [mm], which is the G64 blend tolerance (:mod:`.blend`).

M205's X/Y/Z/E "jerk" (a junction speed jump in mm/s, not a jerk), B, S and T are not
modelled: the machine file's jerk limits stay, and the program is not cut there.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from gantry_sim.controller.config import Limits as AxisLimits
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
    """The Marlin limits in effect: the machine with M201's per-axis accelerations, M203's
    velocities and M205 J's tolerance, and apart from it M204's path acceleration [mm/s^2]
    (None: none)."""

    def __init__(self, machine: MachineConfig) -> None:
        self.machine = machine
        self.path_acc: float | None = None  #: M204 P (or S): the moves that extrude
        self.travel_acc: float | None = None  #: M204 T (or S): the travels
        self.travel_set = False  #: a T or S was given (until then travels run under P)

    def acc_for(self, move: Move) -> float:
        """The path acceleration [mm/s^2] ``move`` runs under (inf: none): T for a travel once
        one was given, else P."""
        travel = getattr(move, "extrudes", None) is False and self.travel_set
        acc = self.travel_acc if travel else self.path_acc
        return math.inf if acc is None else acc

    def apply(self, event: Limits) -> bool:
        """Apply ``event``; True when it changed the machine (a new part), False when it set
        the path acceleration or nothing that is modelled."""
        values = dict(event.values)
        m = self.machine
        if event.code == "M201":
            acc = m.limits.max_acceleration_mm_per_s2
            new = [values.get(a, v) for a, v in zip(_AXES, acc, strict=True)]
            self.machine = m.with_changes("limits", max_acceleration_mm_per_s2=new)
            return True
        if event.code == "M203":
            vel = m.limits.max_velocity_mm_per_s
            new = [values.get(a, v) for a, v in zip(_AXES, vel, strict=True)]
            self.machine = m.with_changes("limits", max_velocity_mm_per_s=new)
            return True
        if event.code == "M205" and "J" in values and values["J"] > 0:
            self.machine = m.with_changes("path", tolerance_mm=values["J"])
            return True
        if event.code == "M204":  # Marlin's M204(): S first, then P and T (and R) over it
            for key in ("S", "P", "T"):
                if key in values:
                    cap = _path_acc(values[key])
                    if key in "SP":
                        self.path_acc = cap
                    if key in "ST":
                        self.travel_acc, self.travel_set = cap, True
        return False


#: The M204 accelerations accepted besides 0 [mm/s^2]: the machine file's range for its axes'
#: (a path acceleration of 1e-45 left no profile Ruckig could plan: an internal error)
PATH_ACC_RANGE = (1.0, 1e6)


def _path_acc(value: float) -> float | None:
    """An M204 value [mm/s^2] as a cap (None: 0, none), or ConfigError."""
    acc = float(value)
    lo, hi = PATH_ACC_RANGE
    if not (acc == 0.0 or lo <= acc <= hi):
        raise ConfigError(
            f"path acceleration to {acc:g} mm/s^2; it must be 0 (none) or within {lo:g}..{hi:g} "
            "mm/s^2, as the machine file's accelerations"
        )
    return acc if acc > 0.0 else None


class LimitEvents(NamedTuple):
    """What a program's Limits events do (:func:`read_limits`): whether one changes the machine
    (so the program is planned in parts, :func:`split_at_limits`), and per motion of the
    program the M204 path acceleration [mm/s^2] in effect (:func:`capping`)."""

    cuts: bool
    path_acc_mm_per_s2: list[float] | None


def read_limits(items: Iterable[Move | Event], machine: MachineConfig) -> LimitEvents:
    """One pass over ``items`` that checks every Limits event (a value the machine cannot take
    is refused here, before anything is planned) and tells what they do."""
    state = _LimitState(machine)
    cuts = False
    acc: list[float] = []
    for item in items:
        if isinstance(item, Limits):
            cuts |= _apply(state, item)
        elif isinstance(item, Rapid | Linear | Arc | Spline):
            acc.append(state.acc_for(item))
    return LimitEvents(cuts, capping(acc))


def capping(path_acc_mm_per_s2: list[float]) -> list[float] | None:
    """Per motion the M204 path acceleration [mm/s^2] (inf: none), or None when none caps any
    (the planner then leaves every move's limits as they are)."""
    return path_acc_mm_per_s2 if any(a < math.inf for a in path_acc_mm_per_s2) else None


def split_at_limits(items: Iterable[Move | Event], machine: MachineConfig) -> Iterator[Part]:
    """The program cut where its Limits events change the machine (M201, M203, M205 J): per
    part with moves, its items (without the events), the machine in effect and, per motion
    among the items, the path acceleration [mm/s^2] in effect (M204 P, T or S; inf: none), which
    does not cut the program (Marlin applies it to the moves it plans next, as the planner
    does: :func:`~gantry_sim.controller.planner.prepare.prepare`). The events of a part without
    moves go to the next part (the last one's to the one before).

    The parts are made as they are asked for (a long print's items are read from disk part by
    part: memory holds a part, not the program); an event the machine cannot take raises when
    it is reached (the planner checks them all first: :func:`read_limits`).
    """
    pending: Part | None = None
    carry: list[Move | Event] = []
    for chunk, m, acc in _cut(items, machine):
        if acc:  # a motion among them
            if pending is not None:
                yield pending
            pending = Part(carry + chunk, m, acc)
            carry = []
        else:
            carry += chunk
    if pending is None:
        yield Part(carry, machine, [])
        return
    pending.items.extend(carry)
    yield pending


class Part(NamedTuple):
    """A program's part between changes of the machine's limits: its moves and events, the
    machine in effect, and per motion among them (G0/G1/G2/G3/G5.x, in order) the path
    acceleration [mm/s^2] that M204 sets (inf: none)."""

    items: list[Move | Event]
    machine: MachineConfig
    path_acc_mm_per_s2: list[float]


def _cut(
    items: Iterable[Move | Event], machine: MachineConfig
) -> Iterator[tuple[list[Move | Event], MachineConfig, list[float]]]:
    """The items between the Limits events that change the machine, each run with the machine
    in effect (the first with ``machine``) and its motions' path accelerations, without the
    events."""
    state = _LimitState(machine)
    chunk: list[Move | Event] = []
    acc: list[float] = []
    for item in items:
        if isinstance(item, Limits):
            before = state.machine
            if _apply(state, item):
                yield chunk, before, acc
                chunk, acc = [], []
        else:
            chunk.append(item)
            if isinstance(item, Rapid | Linear | Arc | Spline):
                acc.append(state.acc_for(item))
    yield chunk, state.machine, acc


def _apply(state: _LimitState, event: Limits) -> bool:
    """:meth:`_LimitState.apply`; a value the machine cannot take is the program's error, on
    the event's line."""
    try:
        return state.apply(event)
    except ConfigError as exc:  # the program's value, not the machine file's
        raise GcodeError(
            f"{event.code} on this line would set the machine's {exc.message}",
            line=event.line,
            file=event.file,
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
        self._overlaps: list[np.ndarray] = []
        self._duration_s = 0.0
        self._segments = 0
        self._ruckig = 0
        self._part_limits: list[tuple[int, AxisLimits]] = []
        self._last: Plan | None = None

    def add(self, plan: Plan, limits: AxisLimits) -> None:
        """Join ``plan`` (a part's, from the planner: its reference a
        :class:`~gantry_sim.controller.planner.segmented_curve.SegmentedCurve`), planned with
        ``limits``, after the parts added before."""
        if not isinstance(plan.curve, SegmentedCurve):
            raise TypeError(f"a part's reference must be a SegmentedCurve, not {plan.curve!r}")
        first_line = int(plan.move_lines[0]) if len(plan.move_lines) else 0
        self._part_limits.append((first_line, limits))
        for block in plan.curve.blocks():
            self._curve.extend([block])
        first = len(self._moves)  # sources index program moves, in both lists
        self._starts.append(plan.move_start_s + self._duration_s)
        self._overlaps.append(plan.overlaps_s + self._duration_s)
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
            np.concatenate(self._overlaps).reshape(-1, 2),
        )
        for arr in arrays:
            arr.setflags(write=False)
        starts, lines, move_sources, path_sources, overlaps = arrays
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
            overlaps_s=overlaps,
            part_limits=tuple(self._part_limits),
        )


def _shifted(sources: np.ndarray, first: int) -> np.ndarray:
    """(n, 2) indices into a part's moves as indices into all (-1: none, kept)."""
    return np.where(sources >= 0, sources + first, -1).astype(np.int64)
