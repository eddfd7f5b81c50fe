"""Run one program through LinuxCNC's own interpreter as its ``gcode`` Python module (the one
AXIS previews with) and print, as JSON, every feed and traverse with its source line.

Run with the system Python that has LinuxCNC's module (Debian ``linuxcnc-uspace``:
``/usr/bin/python3``), one program at a time (the interpreter is not safe in parallel), e.g.
``flock /tmp/rs274.lock /usr/bin/python3 scripts/rs274_spline_probe.py FILE.ngc``.

Why: ``rs274 -g`` prints a spline only as ``NURBS_FEED(k, ...)``; the module's NURBS_FEED
(gcodemodule.cc) evaluates LinuxCNC's own NURBS at u = j * umax / (15 k) and hands each point
to ``straight_feed``, so these are exact points of rs274's curve at known parameters. Positions
are printed in the module's unit (inches) and program frame, with the offsets and rotation
the module reports (``set_g5x_offset``, ``set_g92_offset``, ``set_xy_rotation``).
"""

from __future__ import annotations

import json
import sys

import gcode  # type: ignore[import-not-found]  # LinuxCNC's module (system Python only)


class Canon:
    parameter_file = ""

    def __init__(self) -> None:
        self.line = 0
        self.out: list[dict] = []
        self.g5x = [0.0, 0.0, 0.0]
        self.g92 = [0.0, 0.0, 0.0]
        self.rotation = 0.0

    def __getattr__(self, name: str):
        if name.startswith("__"):
            raise AttributeError(name)
        return lambda *args: None

    def next_line(self, state) -> None:
        self.line = state.sequence_number

    def _move(self, kind: str, args) -> None:
        self.out.append(
            {
                "line": self.line,
                "kind": kind,
                "p": list(args[:3]),
                "g5x": list(self.g5x),
                "g92": list(self.g92),
                "rotation_deg": self.rotation,
            }
        )

    def straight_feed(self, *args) -> None:
        self._move("feed", args)

    def straight_traverse(self, *args) -> None:
        self._move("traverse", args)

    def arc_feed(self, *args) -> None:
        self.out.append({"line": self.line, "kind": "arc"})

    def set_g5x_offset(self, index, x, y, z, *rest) -> None:
        self.g5x = [x, y, z]

    def set_g92_offset(self, x, y, z, *rest) -> None:
        self.g92 = [x, y, z]

    def set_xy_rotation(self, theta) -> None:
        self.rotation = theta

    def get_external_length_units(self) -> float:
        return 1.0

    def get_external_angular_units(self) -> float:
        return 1.0

    def get_axis_mask(self) -> int:
        return 7

    def get_block_delete(self) -> bool:
        return False

    def check_abort(self) -> bool:
        return False

    def get_tool(self, index):
        return (-1, *([0.0] * 12), 0)


def main() -> None:
    canon = Canon()
    # G21 first: rs274 -g starts in mm (the module alone would start in inches)
    result, line = gcode.parse(sys.argv[1], canon, "G21", "")
    error = None
    if result > gcode.MIN_ERROR:
        error = {"line": line, "message": gcode.strerror(result)}
    print(json.dumps({"moves": canon.out, "error": error}))


if __name__ == "__main__":
    main()
