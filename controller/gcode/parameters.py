"""The parameter table: numbered ``#n``, named local ``#<x>`` and global ``#<_x>`` parameters.

Numbered parameters ``#1``..``#5601`` read 0 until set (rs274 without a parameter file);
``#1``..``#5399`` can be set; ``#1``..``#30`` are the arguments of a subroutine call and local to
it. Named parameters must be set before they are read (rs274: "Named parameter #<x> not
defined"); names starting with ``_`` are global, the others local to the subroutine level that set
them. LinuxCNC's predefined read-only names (``#<_x>``, ``#<_metric>``, ...) come from a function
the interpreter supplies, so they always show the current state.
"""

from __future__ import annotations

from collections.abc import Callable

from gantry_sim.controller.errors import GcodeError, cut

#: rs274's parameter table: #1..#5601 can be read; #1..#5399 can be set (#5400+ are read-only).
MAX_PARAMETER = 5601
MAX_SETTABLE_PARAMETER = 5399
#: read-only range exceptions rs274 lets a program set (#5599: the (DEBUG,) output flag;
#: #5600, #5601: the toolchanger fault and its reason)
DEBUG_OUTPUT = 5599
TOOLCHANGER_FAULT = frozenset((5600, 5601))
SETTABLE_SYSTEM = frozenset((DEBUG_OUTPUT,)) | TOOLCHANGER_FAULT
#: subroutine arguments #1..#30 are local to each call.
ARGUMENTS = 30
#: rs274's read_integer_value: a value within this of a whole number is that number
INTEGER_TOL = 0.0001

Predefined = Callable[[str], float | None]

#: numbered system parameters (rs274's layout, LinuxCNC 2.9 manual "Numbered Parameters").
G28_HOME = 5161  # 5161-5163: G28 stored X Y Z
G30_HOME = 5181  # 5181-5183: G30 stored X Y Z
G92_ENABLED = 5210  # 1 while a G92 offset is applied
G92_OFFSET = 5211  # 5211-5213: G92 offset X Y Z
COORD_INDEX = 5220  # active system, 1 (G54) .. 9 (G59.3)
TOOL_NUMBER = 5400  # the tool M6 loaded (0: none)
TOOL_OFFSET = 5401  # 5401-5409: its offsets X Y Z A B C U V W
TOOL_DIAMETER = 5410  # then its front angle, back angle and orientation (5411-5413)
POSITION = 5420  # 5420-5422: current X Y Z (program frame)


def g5x_base(index: int) -> int:
    """First parameter (X) of coordinate system ``index`` (1 = G54 -> 5221); rotation is +9."""
    return 5201 + 20 * index


#: parameters holding lengths: stored in mm, read and written in the program's units. Not the
#: tool parameters #5401-#5410: rs274 copies them from the tool table in its machine units and
#: leaves them so under G20 and G21 (``tool_offsets.tool_parameters``).
LENGTH_PARAMETERS = frozenset(
    {G28_HOME + i for i in range(3)}
    | {G30_HOME + i for i in range(3)}
    | {G92_OFFSET + i for i in range(3)}
    | {g5x_base(k) + i for k in range(1, 10) for i in range(3)}
    | {POSITION + i for i in range(3)}
)


def parameter_index(value: float) -> int:
    """``#value`` -> the parameter number; GcodeError when not a whole number in range."""
    if not -1e9 < value < 1e9:
        raise GcodeError(
            f"parameter number {value:g} out of range; allowed: integers 1..{MAX_PARAMETER}"
        )
    index = round(value)
    if abs(value - index) > INTEGER_TOL or not 1 <= index <= MAX_PARAMETER:
        raise GcodeError(
            f"parameter number {value:g} out of range; allowed: integers 1..{MAX_PARAMETER}"
        )
    return index


class Parameters:
    """Numbered and named parameters, with subroutine scopes."""

    def __init__(
        self, predefined: Predefined | None = None, scale: Callable[[], float] = lambda: 1.0
    ) -> None:
        # lengths in LENGTH_PARAMETERS are in mm; #5599 (print (DEBUG,) comments) starts at 1
        self.numbered: dict[int, float] = {DEBUG_OUTPUT: 1.0}
        self.scale = scale
        #: cutter compensation is on: rs274 refuses to read #5420-#5428 then
        self.position_locked = False
        self.globals: dict[str, float] = {
            "_value": 0.0,
            "_value_returned": 0.0,
        }  # rs274: 0 at start
        self.scopes: list[dict[str, float]] = [{}]
        self.saved_args: list[dict[int, float]] = []
        self.predefined: Predefined = predefined or (lambda name: None)

    # reading -------------------------------------------------------------------------------
    def number(self, index: float) -> float:
        i = parameter_index(index)
        if self.position_locked and POSITION <= i <= POSITION + 8:
            raise GcodeError(
                f"cannot read the current position (#{i}) with cutter radius compensation on "
                "(rs274 refuses it); read it after G40"
            )
        value = self.numbered.get(i, 0.0)
        return value / self.scale() if i in LENGTH_PARAMETERS else value

    def mm(self, index: int) -> float:
        """A parameter's stored value (mm for lengths)."""
        return self.numbered.get(index, 0.0)

    def named(self, name: str) -> float:
        value = self._lookup(name)
        if value is None:
            raise GcodeError(f"named parameter #<{cut(name)}> not defined; " + _how_to_set(name))
        return value

    def exists(self, name: str) -> bool:
        return self._lookup(name) is not None

    def _lookup(self, name: str) -> float | None:
        if name.startswith("_"):
            value = self.predefined(name)
            return value if value is not None else self.globals.get(name)
        return self.scopes[-1].get(name)

    # writing -------------------------------------------------------------------------------
    def set_number(self, index: int, value: float) -> None:
        """Set ``#index`` to ``value`` in program units (#5600/#5601, the toolchanger's
        fault and reason, take the setting and read 0 after it, as rs274 -g does: its
        toolchanger refreshes them)."""
        if index in TOOLCHANGER_FAULT:
            return
        self.numbered[index] = value * self.scale() if index in LENGTH_PARAMETERS else value

    def set_named(self, name: str, value: float) -> None:
        if name.startswith("_"):
            if self.predefined(name) is not None:
                raise GcodeError(f"#<{cut(name)}> is a read-only predefined parameter")
            self.globals[name] = value
        else:
            self.scopes[-1][name] = value

    # subroutine scopes ---------------------------------------------------------------------
    def enter(self, args: list[float]) -> None:
        """A subroutine call: new local scope, #1..#30 saved and set from ``args`` (rest 0)."""
        self.saved_args.append({i: self.numbered.get(i, 0.0) for i in range(1, ARGUMENTS + 1)})
        for i in range(1, ARGUMENTS + 1):
            self.numbered[i] = args[i - 1] if i <= len(args) else 0.0
        self.scopes.append({})

    def leave(self) -> None:
        """Return from a subroutine: its locals are gone, #1..#30 restored."""
        self.numbered.update(self.saved_args.pop())
        self.scopes.pop()

    @property
    def level(self) -> int:
        """Subroutine call depth (0 in the main program)."""
        return len(self.saved_args)


def _how_to_set(name: str) -> str:
    """What a message about an undefined named parameter tells the user to do: LinuxCNC fills
    ``#<_ini[section]name>`` from its INI file and ``#<_hal[pin]>`` from HAL, neither of which
    a simulation has; a program may set them itself (rs274 lets it)."""
    source = {"_ini[": "its INI file", "_hal[": "a HAL pin"}.get(name[:5])
    if source is None:
        return "set it before reading it"
    return (
        f"LinuxCNC reads it from {source}, which gantry-sim does not have: set it at the "
        f"program's start to your machine's value (#<{cut(name)}> = ...)"
    )
