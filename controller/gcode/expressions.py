"""LinuxCNC-style real values: numbers, ``#n`` parameters and ``[expressions]``.

A value is read from a line (spaces already removed, letters upper-cased) into a small tree that
the interpreter evaluates later against its parameter table, because every ``#n`` read on a line
sees the values from *before* that line's ``#n=...`` settings (rs274 semantics).

Trees are nested tuples: ``("num", 1.5)``, ``("par", tree)``, ``("neg", tree)``,
``("fn", "SIN", tree)``, ``("atan", a, b)``, ``("bin", "+", a, b)``. Trig functions work in
degrees, as in rs274. Named parameters (``#<name>``) and O-word subroutines are not supported.
"""

from __future__ import annotations

import math

from gantry_sim.controller.errors import GcodeError

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
_FUNCTIONS = (
    "ABS", "ACOS", "ASIN", "COS", "EXP", "FIX", "FUP", "LN", "ROUND", "SIN", "SQRT", "TAN"
)
# fmt: on
_NUM_CHARS = "0123456789."
MAX_NESTING = 64  # brackets, signs and # per value: deeper is refused (no recursion blow-up)
NAMED_PARAMETERS = "named parameters (#<name>) are not supported; use numbered parameters #1..#5399"


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

    def _real_value(self) -> Tree:
        c = self.peek()
        if c == "[":
            return self.expression()
        if c == "#":
            self.pos += 1
            if self.peek() == "<":
                raise GcodeError(NAMED_PARAMETERS)
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
                    raise GcodeError("EXISTS[] needs named parameters, which are not supported")
                arg = self.expression()
                if name == "ATAN":
                    if self.peek() != "/":
                        raise GcodeError("ATAN needs two arguments: ATAN[y]/[x]")
                    self.pos += 1
                    return ("atan", arg, self.expression())
                return ("fn", name, arg)
        if not c:
            raise GcodeError("missing value at end of line; expected a number, #n or [expression]")
        raise GcodeError(f"bad value starting with {c!r}; expected a number, #n or [expression]")

    def number(self) -> Tree:
        start = self.pos
        while self.peek() and self.peek() in _NUM_CHARS:
            self.pos += 1
        raw = self.text[start : self.pos]
        if raw.count(".") > 1:
            raise GcodeError(f"bad number format {raw!r}; expected digits with at most one '.'")
        if raw == ".":
            raise GcodeError("bad number format '.'; expected at least one digit")
        return ("num", float(raw))

    def expression(self) -> Tree:
        """``[ value (op value)* ]`` with rs274's operator precedence."""
        assert self.peek() == "["
        self.pos += 1
        values = [self.real_value()]
        ops: list[str] = []
        while True:
            if self.peek() == "]":
                self.pos += 1
                break
            op = self._operator()
            while ops and _BINARY[ops[-1]] >= _BINARY[op]:
                b, a = values.pop(), values.pop()
                values.append(("bin", ops.pop(), a, b))
            ops.append(op)
            values.append(self.real_value())
        while ops:
            b, a = values.pop(), values.pop()
            values.append(("bin", ops.pop(), a, b))
        return values[0]

    def _operator(self) -> str:
        for op in sorted(_BINARY, key=len, reverse=True):
            if self.text.startswith(op, self.pos):
                self.pos += len(op)
                return op
        if not self.peek():
            raise GcodeError("unclosed expression: expected ']'")
        raise GcodeError(
            f"unknown operator at {self.text[self.pos : self.pos + 6]!r}; allowed: + - * / MOD ** "
            "EQ NE GT GE LT LE AND OR XOR"
        )


def evaluate(tree: Tree, params: dict[int, float]) -> float:
    """Evaluate ``tree`` with numbered parameters ``params`` (unset ones read 0, as in rs274)."""
    kind = tree[0]
    if kind == "num":
        return tree[1]
    if kind == "neg":
        return -evaluate(tree[1], params)
    if kind == "par":
        index = evaluate(tree[1], params)
        return params.get(_parameter_index(index), 0.0)
    if kind == "atan":
        return math.degrees(math.atan2(evaluate(tree[1], params), evaluate(tree[2], params)))
    if kind == "fn":
        return _function(tree[1], evaluate(tree[2], params))
    a, b = evaluate(tree[2], params), evaluate(tree[3], params)
    return _binary(tree[1], a, b)


#: rs274's parameter table: #1..#5601 can be read; #1..#5399 can be set (#5400+ are read-only).
MAX_PARAMETER = 5601
MAX_SETTABLE_PARAMETER = 5399


def _parameter_index(value: float) -> int:
    index = round(value)
    if abs(value - index) > 1e-4 or not 1 <= index <= MAX_PARAMETER:
        raise GcodeError(
            f"parameter number {value:g} out of range; allowed: integers 1..{MAX_PARAMETER}"
        )
    return index


def _function(name: str, x: float) -> float:
    try:
        match name:
            case "ABS":
                return abs(x)
            case "ACOS":
                return math.degrees(math.acos(x))
            case "ASIN":
                return math.degrees(math.asin(x))
            case "COS":
                return math.cos(math.radians(x))
            case "EXP":
                return math.exp(x)
            case "FIX":
                return float(math.floor(x))
            case "FUP":
                return float(math.ceil(x))
            case "LN":
                return math.log(x)
            case "ROUND":
                return float(math.floor(x + 0.5))
            case "SIN":
                return math.sin(math.radians(x))
            case "SQRT":
                return math.sqrt(x)
            case _:
                return math.tan(math.radians(x))
    except (ValueError, OverflowError):
        raise GcodeError(f"{name}[{x:g}] is out of the function's domain") from None


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
                return math.fmod(a, b) if math.fmod(a, b) >= 0 else math.fmod(a, b) + abs(b)
            case "**":
                return float(a**b)
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
    except (OverflowError, ZeroDivisionError, TypeError):
        raise GcodeError(f"{a:g} {op} {b:g} has no finite real value") from None
