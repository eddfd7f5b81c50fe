"""LinuxCNC-style real values: numbers, parameters and ``[expressions]``.

A value is read from a line (spaces already removed, letters upper-cased) into a small tree that
the interpreter evaluates later against its parameters, because every parameter read on a line
sees the values from *before* that line's settings (rs274 semantics).

Trees are nested tuples: ``("num", 1.5)``, ``("par", tree)`` (numbered ``#n``), ``("name", "x")``
(named ``#<x>``, lower case), ``("exists", "x")``, ``("exists_n", tree)`` (``EXISTS[#n]``: 1 where
n is a parameter number), ``("neg", tree)``, ``("fn", "SIN", tree)``,
``("atan", a, b)`` and ``("chain", values, ops)`` for ``[a op b op c ...]``, reduced by rs274's
operator precedence when evaluated. Chains are evaluated without recursion, so an expression of
any number of terms is fine; brackets, signs and ``#`` may nest at most :data:`MAX_NESTING` deep.
Trig functions work in degrees, as in rs274.
"""

from __future__ import annotations

import functools
import math
import re
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    import numpy as np

from gantry_sim.controller.errors import GcodeError, shown
from gantry_sim.controller.gcode.parameters import INTEGER_TOL, MAX_PARAMETER

Tree = tuple

#: binary operators by precedence (higher binds tighter), as in rs274's read_real_expression.
# fmt: off
_BINARY: dict[str, int] = {
    "**": 4,
    "*": 3, "/": 3, "MOD": 3,
    "+": 2, "-": 2,
    "EQ": 1, "NE": 1, "GT": 1, "GE": 1, "LT": 1, "LE": 1,
    "AND": 0, "OR": 0, "XOR": 0,
}
_OPERATORS = sorted(_BINARY, key=len, reverse=True)
_FUNCTIONS = (
    "ABS", "ACOS", "ASIN", "COS", "EXP", "FIX", "FUP", "LN", "ROUND", "SIN", "SQRT", "TAN"
)
# fmt: on
_NUM_CHARS = "0123456789."
#: the longest run of ``_NUM_CHARS`` (a number's characters, read in one match)
_NUMBER = re.compile(r"[0-9.]*")
MAX_NESTING = 64  # brackets, signs and # per value: deeper is refused (no recursion blow-up)
#: the largest magnitude a number or result may have; beyond it values are refused as not finite
MAX_MAGNITUDE = 1e300


#: rs274 turns degrees into radians and back through C's long double M_PIl
#: (interp_execute.cc: ``cos((x * M_PIl) / 180.0)`` calls cosl; ``(r * 180.0) / M_PIl``), so
#: COS[90] is -2.5e-20, not the 6.1e-17 of double arithmetic (on x86-64 Linux, where long
#: double has 64 mantissa bits; where it is a double, the two agree)
@functools.cache
def _long_double() -> tuple[type[np.longdouble], np.longdouble, np.longdouble]:
    """numpy's long double type, M_PIl and 180 in it (numpy imported at the first use: the
    lexer is imported by every ``gantry`` command, ``--version`` too)."""
    import numpy

    ld = numpy.longdouble
    return ld, ld("3.14159265358979323846264338327950288"), ld(180.0)


def _radians_l(degrees: float) -> np.longdouble:
    ld, pi, half_turn = _long_double()
    return ld(degrees) * pi / half_turn


def _degrees_l(radians: float) -> float:
    ld, pi, half_turn = _long_double()
    return float(ld(radians) * half_turn / pi)


def _trig(name: str, degrees: float) -> float:
    """COS, SIN or TAN of ``degrees`` as rs274 computes them (long double)."""
    import numpy

    return float(getattr(numpy, name)(_radians_l(degrees)))


class ParameterReader(Protocol):
    """What evaluation needs: numbered and named parameter values."""

    def number(self, index: float) -> float: ...

    def named(self, name: str) -> float: ...

    def exists(self, name: str) -> bool: ...


class Reader:
    """Reads values from one line of text (no spaces, upper case) starting at ``pos``."""

    def __init__(self, text: str, pos: int = 0) -> None:
        self.text = text
        self.pos = pos
        self.depth = 0

    def peek(self) -> str:
        return self.text[self.pos] if self.pos < len(self.text) else ""

    def real_value(self) -> Tree:
        """A number, ``#``-parameter, ``[expression]`` or unary function call."""
        self.depth += 1
        try:
            if self.depth > MAX_NESTING:
                raise GcodeError(f"value nested more than {MAX_NESTING} deep; simplify it")
            return self._real_value()
        finally:
            self.depth -= 1

    def name(self) -> str:
        """``<name>`` at ``pos`` (the ``<`` included) -> the name, lower case."""
        end = self.text.find(">", self.pos)
        if end < 0:
            raise GcodeError("named parameter not terminated; write #<name>")
        name = self.text[self.pos + 1 : end].lower()
        if not name or "(" in name:
            raise GcodeError("named parameter #<> has no name")
        self.pos = end + 1
        return name

    def _real_value(self) -> Tree:
        c = self.peek()
        if c == "[":
            return self.expression()
        if c == "#":
            self.pos += 1
            if self.peek() == "<":
                return ("name", self.name())
            return ("par", self.real_value())
        if c in "+-" and c:
            self.pos += 1
            inner = self.real_value()
            return ("neg", inner) if c == "-" else inner
        if c and c in _NUM_CHARS:
            return self.number()
        for name in (*_FUNCTIONS, "ATAN", "EXISTS"):
            if self.text.startswith(name, self.pos):
                self.pos += len(name)
                if self.peek() != "[":
                    raise GcodeError(f"function {name} must be followed by [expression]")
                if name == "EXISTS":
                    return self._exists()
                arg = self.expression()
                if name == "ATAN":
                    if self.peek() != "/":
                        raise GcodeError("ATAN needs two arguments: ATAN[y]/[x]")
                    self.pos += 1
                    if self.peek() != "[":
                        raise GcodeError("ATAN needs two arguments: ATAN[y]/[x]")
                    return ("atan", arg, self.expression())
                return ("fn", name, arg)
        if not c:
            raise GcodeError("missing value at end of line; expected a number, #n or [expression]")
        raise GcodeError(f"bad value starting with {c!r}; expected a number, #n or [expression]")

    def _exists(self) -> Tree:
        """``EXISTS[#<name>]``, or ``EXISTS[#n]`` with n any integer value (rs274's
        read_bracketed_parameter: ``EXISTS[#1]``, ``EXISTS[##2]``, ``EXISTS[#[1+1]]``), from
        its ``[``."""
        self.pos += 1
        if self.peek() != "#":
            raise GcodeError("EXISTS takes a parameter: EXISTS[#<name>] or EXISTS[#n]")
        self.pos += 1
        tree = ("exists", self.name()) if self.peek() == "<" else ("exists_n", self.real_value())
        if self.peek() != "]":
            raise GcodeError("EXISTS takes one parameter: EXISTS[#<name>] or EXISTS[#n]")
        self.pos += 1
        return tree

    def number(self) -> Tree:
        start = self.pos
        self.pos = _NUMBER.match(self.text, start).end()  # type: ignore[union-attr]
        raw = self.text[start : self.pos]
        if raw.count(".") > 1:
            number = raw[: raw.index(".", raw.index(".") + 1)]
            if any(c.isdigit() for c in number):  # grbl reads the number and stops there
                raise GcodeError(
                    f"bad number format {shown(raw)}: a second '.' after the number {number}; "
                    "expected digits with at most one '.'"
                )
            raise GcodeError(
                f"bad number format {shown(raw)}; expected digits with at most one '.'"
            )
        if raw == ".":
            raise GcodeError("bad number format '.'; expected at least one digit")
        value = float(raw)
        if value > MAX_MAGNITUDE:
            raise GcodeError(
                f"number {raw[:12]}... ({len(raw)} characters) is not a finite number below "
                f"{MAX_MAGNITUDE:g}"
            )
        return ("num", value)

    def expression(self) -> Tree:
        """``[ value (op value)* ]``; precedence is applied when evaluated (no deep trees)."""
        assert self.peek() == "["
        self.pos += 1
        values = [self.real_value()]
        ops: list[str] = []
        while True:
            if self.peek() == "]":
                self.pos += 1
                break
            ops.append(self._operator())
            values.append(self.real_value())
        if not ops:
            return values[0]
        return ("chain", tuple(values), tuple(ops))

    def _operator(self) -> str:
        for op in _OPERATORS:
            if self.text.startswith(op, self.pos):
                self.pos += len(op)
                return op
        if not self.peek():
            raise GcodeError("unclosed expression: expected ']'")
        raise GcodeError(
            f"unknown operator at {self.text[self.pos : self.pos + 6]!r}; allowed: + - * / MOD ** "
            "EQ NE GT GE LT LE AND OR XOR"
        )


def evaluate(tree: Tree, params: ParameterReader) -> float:
    """Evaluate ``tree`` against ``params``; GcodeError for any value that is not finite."""
    value = _evaluate(tree, params)
    if not -MAX_MAGNITUDE <= value <= MAX_MAGNITUDE:
        raise GcodeError(f"value {value:g} is not a finite number within +-{MAX_MAGNITUDE:g}")
    return value


def _evaluate(tree: Tree, params: ParameterReader) -> float:
    kind = tree[0]
    if kind == "num":
        return tree[1]
    if kind == "neg":
        return -_evaluate(tree[1], params)
    if kind == "par":
        return params.number(evaluate(tree[1], params))
    if kind == "name":
        return params.named(tree[1])
    if kind == "exists":
        return float(params.exists(tree[1]))
    if kind == "exists_n":
        return float(_parameter_number(_evaluate(tree[1], params)))
    if kind == "atan":
        return _degrees_l(math.atan2(_evaluate(tree[1], params), _evaluate(tree[2], params)))
    if kind == "fn":
        return _function(tree[1], _evaluate(tree[2], params))
    return _chain([_evaluate(v, params) for v in tree[1]], tree[2])


def _parameter_number(value: float) -> bool:
    """Whether ``value`` names a numbered parameter (rs274: 1 <= n < RS274NGC_MAX_PARAMETERS);
    it must be a whole number, as rs274's read_integer_value reads it."""
    n = round(value) if math.isfinite(value) else 0
    if not math.isfinite(value) or abs(value - n) > INTEGER_TOL:
        raise GcodeError(f"EXISTS[#{value:g}]: a parameter number is a whole number")
    return 1 <= n <= MAX_PARAMETER


def _chain(values: list[float], ops: tuple[str, ...]) -> float:
    """Reduce ``v0 op0 v1 op1 v2 ...`` by precedence, left to right within one level."""
    out: list[float] = [values[0]]
    pending: list[str] = []
    for op, value in zip(ops, values[1:], strict=True):
        while pending and _BINARY[pending[-1]] >= _BINARY[op]:
            b, a = out.pop(), out.pop()
            out.append(_binary(pending.pop(), a, b))
        pending.append(op)
        out.append(value)
    while pending:
        b, a = out.pop(), out.pop()
        out.append(_binary(pending.pop(), a, b))
    return out[0]


def _function(name: str, x: float) -> float:
    try:
        match name:
            case "ABS":
                return abs(x)
            case "ACOS":
                return _degrees_l(math.acos(x))
            case "ASIN":
                return _degrees_l(math.asin(x))
            case "COS":
                return _trig("cos", x)
            case "EXP":
                return math.exp(x)
            case "FIX":
                return float(math.floor(x))
            case "FUP":
                return float(math.ceil(x))
            case "LN":
                return math.log(x)
            case "ROUND":  # rs274: (int)(x + 0.5), or - 0.5 below 0: halves away from zero
                return _c_int(x + (-0.5 if x < 0.0 else 0.5))
            case "SIN":
                return _trig("sin", x)
            case "SQRT":
                return math.sqrt(x)
            case _:
                return _trig("tan", x)
    except (ValueError, OverflowError):
        raise GcodeError(f"{name}[{x:g}] is out of the function's domain") from None


def _c_int(x: float) -> float:
    """C's ``(int) x`` as rs274 computes it on x86-64: truncated toward zero; a value beyond
    a 32-bit int gives INT_MIN there (the processor's "integer indefinite")."""
    if -2147483649.0 < x < 2147483648.0:
        return float(math.trunc(x))
    return -2147483648.0


def _binary(op: str, a: float, b: float) -> float:
    try:
        match op:
            case "+":
                return a + b
            case "-":
                return a - b
            case "*":
                return a * b
            case "/":
                if b == 0.0:
                    raise GcodeError("attempt to divide by zero")
                return a / b
            case "MOD":
                if b == 0.0:
                    raise GcodeError("attempt to take MOD by zero")
                r = math.fmod(a, b)
                return r if r >= 0 else r + abs(b)
            case "**":
                result = a**b
                if isinstance(result, complex):
                    raise GcodeError(f"{a:g} ** {b:g} has no real value")
                return float(result)
            case "EQ":
                return float(a == b)
            case "NE":
                return float(a != b)
            case "GT":
                return float(a > b)
            case "GE":
                return float(a >= b)
            case "LT":
                return float(a < b)
            case "LE":
                return float(a <= b)
            case "AND":
                return float(a != 0.0 and b != 0.0)
            case "OR":
                return float(a != 0.0 or b != 0.0)
            case _:
                return float((a != 0.0) != (b != 0.0))
    except (OverflowError, ZeroDivisionError, TypeError, ValueError):
        raise GcodeError(f"{a:g} {op} {b:g} has no finite real value") from None
