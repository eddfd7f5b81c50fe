"""Marlin's M201/M203/M204/M205 in a plan: the limits change from their line on.

A :class:`~gantry_sim.controller.moves.Limits` event splits the program there: the part before
is planned with the limits in effect, the part after with the new ones, and the plans are
joined end to end (each part ends and starts at rest, so the change is an exact stop; Marlin
itself applies the change to the moves it plans next, without stopping). What is applied:

* M201 X Y Z: the per-axis acceleration limits [mm/s^2];
* M203 X Y Z: the per-axis velocity limits [mm/s];
* M204 P (or S, its older form): the acceleration of feed moves [mm/s^2], applied as a cap on
  every axis' acceleration (min with M201's); R and T (retract, travel) are not modelled;
* M205 J: the junction deviation [mm], which is the G64 blend tolerance (:mod:`.blend`).

M205's X/Y/Z/E "jerk" (a junction speed jump in mm/s, not a jerk), B, S and T are not
modelled: the machine file's jerk limits stay.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from gantry_sim.controller.config import MachineConfig, Segmentation
from gantry_sim.controller.errors import ConfigError, GcodeError
from gantry_sim.controller.moves import Arc, Event, Limits, Linear, Move, Rapid, Spline
from gantry_sim.controller.planner.cubic import PiecewiseCubic
from gantry_sim.controller.planner.result import Plan
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
    items: Sequence[Move | Event], machine: MachineConfig
) -> list[tuple[list[Move | Event], MachineConfig]]:
    """The program cut at its Limits events: (items, machine in effect) per part with moves;
    the events of a part without moves go to the next part (the last one's to the one before)."""
    state = _LimitState(machine)
    parts: list[tuple[list[Move | Event], MachineConfig]] = [([], machine)]
    for item in items:
        if isinstance(item, Limits):
            try:
                parts.append(([], state.apply(item)))
            except ConfigError as exc:  # the program's value, not the machine file's
                raise GcodeError(
                    f"{item.code} on this line would set the machine's {exc.message}",
                    line=item.line,
                ) from None
        else:
            parts[-1][0].append(item)
    out: list[tuple[list[Move | Event], MachineConfig]] = []
    carry: list[Move | Event] = []
    for chunk, m in parts:
        if any(isinstance(i, Rapid | Linear | Arc | Spline) for i in chunk):
            out.append((carry + chunk, m))
            carry = []
        else:
            carry += chunk
    if carry and out:
        out[-1][0].extend(carry)
    return out or [(carry, machine)]


def concatenate(plans: Sequence[Plan], seg: Segmentation) -> Plan:
    """The plans one after the other (each starts where, and at rest as, the one before ends);
    ``seg``: the machine's segmentation (the same for every part), for the chord vertices."""
    offsets = np.concatenate(([0.0], np.cumsum([p.duration_s for p in plans])[:-1]))
    axes = []
    for i in range(3):
        cols = [p.curve.axes[i] for p in plans]
        t0 = np.concatenate([c[0] + off for c, off in zip(cols, offsets, strict=True)])
        rest = [np.concatenate([c[k] for c in cols]) for k in range(1, 5)]
        axes.append(_frozen(t0, *rest))

    def cat(name: str) -> tuple:
        return tuple(x for p in plans for x in getattr(p, name))

    starts = np.concatenate([p.move_start_s + off for p, off in zip(plans, offsets, strict=True)])
    lines = np.concatenate([p.move_lines for p in plans])
    first = np.concatenate(([0], np.cumsum([len(p.moves) for p in plans])[:-1]))

    def sources(name: str) -> np.ndarray:  # indices into each plan's moves -> into all
        own = [getattr(p, name) for p in plans]
        parts = [np.where(s >= 0, s + k, -1) for s, k in zip(own, first, strict=True)]
        return np.concatenate(parts).reshape(-1, 2).astype(np.int64)

    move_sources, path_sources = sources("move_sources"), sources("path_sources")
    for arr in (starts, lines, move_sources, path_sources):
        arr.setflags(write=False)
    last = plans[-1]
    moves = SpilledList(m for p in plans for m in p.moves)
    return replace(
        last,
        moves=moves,
        duration_s=float(sum(p.duration_s for p in plans)),
        segment_count=sum(p.segment_count for p in plans),
        vertices=ChordVertices(moves, seg),
        ruckig_piece_count=sum(p.ruckig_piece_count for p in plans),
        curve=PiecewiseCubic(tuple(axes)),
        move_start_s=starts,
        move_lines=lines,
        blends=cat("blends"),
        merges=cat("merges"),
        path_moves=cat("path_moves"),
        move_sources=move_sources,
        path_sources=path_sources,
    )


def _frozen(*arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    for a in arrays:
        a.setflags(write=False)
    return arrays
