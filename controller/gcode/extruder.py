"""Marlin's extruder axis, followed only as far as the planner needs it: which moves extrude.

Marlin plans a block that moves the extruder with the print acceleration (M204 P) and one that
does not with the travel acceleration (M204 T) (Marlin's planner.cpp: ``esteps ?
settings.acceleration : settings.travel_acceleration``). A move extrudes when its line's E word
moves E: in relative mode (M83, or G91, which makes every axis relative) any E other than 0; in
absolute mode (M82, G90: Marlin's default) an E other than the extruder's position, which every E
word sets and ``G92 E`` sets without moving. Marlin counts whole motor steps, so a change below
one step is a travel there and an extrusion here (slicers write E to five decimals: a change of
0.00001 mm, under a step of every common extruder, is not written). G10/G11 (firmware retract)
move E without changing the position the program sees, as in Marlin. E is in mm here (the
interpreter converts a G20 program's E as it converts X, Y and Z).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

__all__ = ["Extruder"]


@dataclass(frozen=True)
class Extruder:
    """The extruder's mode and position as a Marlin program sets them (part of the interpreter's
    modal state: a block that fails changes neither)."""

    relative: bool = False  #: M83 or G91 in effect (M82 and G90: absolute)
    position_mm: float = 0.0  #: E position [mm]

    def with_mode(self, relative: bool) -> Extruder:
        """M82/M83, G90/G91."""
        return replace(self, relative=relative)

    def at(self, e_mm: float) -> Extruder:
        """``G92 E``: the extruder is at ``e_mm`` from now on; nothing moves."""
        return replace(self, position_mm=e_mm)

    def move(self, e_mm: float | None) -> tuple[bool, Extruder]:
        """A move's E word [mm] (None: none): whether it moves the extruder, and the extruder
        after it."""
        if e_mm is None:
            return False, self
        if self.relative:
            return e_mm != 0.0, replace(self, position_mm=self.position_mm + e_mm)
        return e_mm != self.position_mm, replace(self, position_mm=e_mm)
