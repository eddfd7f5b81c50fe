"""Running a program: lines in order, with O-word subroutines, loops and conditionals.

LinuxCNC 2.9's O-words (``o100`` or ``o<name>``): ``sub``/``endsub``/``call``/``return`` with
arguments #1..#30 (local to the call) and a return value in ``#<_value>``
(``#<_value_returned>`` says whether one was given); ``while``/``endwhile``, ``do``/``while``,
``if``/``elseif``/``else``/``endif``, ``repeat``/``endrepeat``, ``break``, ``continue``. A
subroutine may be defined before or after its call (rs274 searches forward for it) or in a file
``NAME.ngc`` on the subroutine search path (the program's folder, then ``--subroutine-path``).

Bounds, so that no program hangs: at most :data:`MAX_CALL_LEVELS` nested calls (rs274: "Too
many subroutine levels" on the 10th), ``max_iterations`` loop repetitions and calls in all
(default :data:`DEFAULT_MAX_ITERATIONS`, ``--max-iterations``), and a tenth of that
(:func:`idle_lines_bound`) of lines run in loops and subroutines since the last move or event;
past any of them the run stops with an error on the loop or call line that went too far.
LinuxCNC has no bound. The iteration bound alone let a loop that never moves spin for 45-150 s
(1,000,000 repetitions of a few lines at 4-25 us a line) before it was refused; the bound on
lines without motion refuses it within 0.4-2.5 s, and no loop that moves ever meets it.
"""

from __future__ import annotations

import math
import re
from collections import OrderedDict
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from gantry_sim.controller.errors import GcodeError, cut
from gantry_sim.controller.gcode.expressions import Tree, evaluate
from gantry_sim.controller.gcode.fanuc_subs import fanuc_code, find_program
from gantry_sim.controller.gcode.finite import check_finite
from gantry_sim.controller.gcode.lexer import (
    G2CORE_MAX_LINE,
    RS274_LEX,
    Block,
    LexRules,
    OWord,
    TextError,
    decode_program,
    firmware_comments,
    g2core_checksum,
    lex_line,
    lex_passed_oword,
    line_too_long,
    split_lines,
    strip_line,
    without_checksum,
    without_realtime,
)
from gantry_sim.controller.gcode.printer_codes import (
    after_controls,
    as_g92,
    g2core_active_json,
    g2core_characters,
    g2core_json_gcode,
    homing_end,
    marlin_bare_motion,
    marlin_bare_opener,
    marlin_command_alone,
    marlin_dwell_seconds,
    marlin_extruder,
    marlin_feed_percent,
    marlin_home_words,
    marlin_motion,
    marlin_without_line_number,
    marlin_without_subcode,
    without_marlin_parameters,
)
from gantry_sim.controller.gcode.state import evolve
from gantry_sim.controller.gcode.words import whole_number
from gantry_sim.controller.input_files import MB, read_capped
from gantry_sim.controller.moves import Event, Move

MAX_CALL_LEVELS = 9
MAX_ERRORS = 1000  # --all-errors stops collecting (and raises) after this many
DEFAULT_MAX_ITERATIONS = 1_000_000
#: the least bound on lines run in loops and subroutines without a move (:func:`idle_lines_bound`)
MIN_IDLE_LINES = 1000
#: the largest subroutine file read [bytes] (a subroutine's body: a few KB; a whole program's
#: cap would do as well, but a file of this size is no subroutine)
MAX_SUB_FILE_BYTES = 50 * MB


#: Lexed lines a :class:`Source` keeps (the latest lexed), for loops and subroutines that run
#: them again: a line lexed again gives the same block. Keeping every line held about 0.75 KB a
#: line until the program was read (75 MB at 100,000 lines, kept by the process' heap after).
#: They are kept in an OrderedDict, whose oldest entry is dropped in constant time: a plain
#: dict's first key is found by scanning past the slots its deletions left, which was 14 % of
#: reading a 100,000-line program.
LEXED_LINES_KEPT = 8192


#: Own-line kinds (printer_codes) whose line is classified again once rewritten: g2core's
#: controls split off a line's start, Marlin's subcode dropped (G91.1 is a G91).
_READ_AGAIN: dict[str, Callable[[str], str]] = {
    "controls": after_controls,
    "json_gcode": g2core_json_gcode,  # g2core: {"gc":"g1x10"} runs its G-code
    "active_json": g2core_active_json,  # g2core: ({gc:"g1x10"}) alone is a JSON line
    "subcode": marlin_without_subcode,
    "line_number": marlin_without_line_number,
}
#: Own-line kinds read by the shared lexer once rewritten as the controller reads them.
_REWRITTEN: dict[str, Callable[[str], str]] = {
    "set_origin": as_g92,  # g2core G28.3: a G92 of its words
    "homing": homing_end,  # g2core G28.2/G28.4: motion cancelled after homing
    "command_alone": marlin_command_alone,  # Marlin: G17-G21, G54-G59, G80, G90, G91 read no word
    "characters": g2core_characters,  # g2core: the characters its normalizer drops left out
    "motion": marlin_motion,  # Marlin: G0-G3, G5, G92 read as its parser reads them
    "bare_motion": marlin_bare_motion,  # Marlin: parameters with no command (X10 Y5)
    "parameters": without_marlin_parameters,  # Marlin: G, M, T words after a G command
}


@dataclass(eq=False)
class Source:
    """One file's lines, lexed on first use (a lexing error is raised only when the line runs);
    the last :data:`LEXED_LINES_KEPT` lexed are kept."""

    name: str
    lines: list[str]
    lex_rules: LexRules = RS274_LEX
    own_lines: Callable[[str], str | None] | None = None
    realtime: bool = False
    checksums: str = ""
    comments: str = ""
    line_limit: str = ""  # whose line length limit applies (lexer.line_too_long)
    checksummed: int = 0  # g2core: the N of the last line with a checksum (lexer.g2core_checksum)
    blocks: OrderedDict[int, Block | GcodeError] = field(default_factory=OrderedDict)

    def block(self, i: int) -> Block:
        got = self.blocks.get(i)
        if got is None:
            try:
                got = self._lex(i)
            except GcodeError as exc:
                if exc.line is None:
                    exc.line = i + 1
                got = exc
            if len(self.blocks) >= LEXED_LINES_KEPT:
                self.blocks.popitem(last=False)  # the one lexed first
            self.blocks[i] = got
        if isinstance(got, GcodeError):
            raise got
        return got

    def _lex(self, i: int) -> Block:
        raw = without_realtime(self.lines[i]) if self.realtime else self.lines[i]
        if self.line_limit == "g2core":
            raw = raw[:G2CORE_MAX_LINE]  # xio.cpp: the rest of a longer line is skipped
        elif self.line_limit:
            too_long = line_too_long(raw, self.line_limit)
            if too_long is not None:
                raise TextError(too_long)
        if self.checksums == "marlin" and "*" in raw:
            raw = without_checksum(raw)
        elif self.checksums == "g2core" and "*" in raw:  # the first * anywhere, checked
            raw, self.checksummed = g2core_checksum(raw, self.checksummed)
        if self.comments:
            raw = firmware_comments(raw, self.comments)
        kind = self.own_lines(raw) if self.own_lines is not None else None
        while kind in _READ_AGAIN:
            raw = _READ_AGAIN[kind](raw)
            kind = self.own_lines(raw) if self.own_lines is not None else None
        if kind == "quiet":
            return Block(i + 1, (), (), False, raw)
        rewrite = _REWRITTEN.get(kind) if kind is not None else None
        if rewrite is not None:
            block = lex_line(rewrite(raw), i + 1, self.lex_rules)
            return replace(block, bare=marlin_bare_opener(raw)) if kind == "bare_motion" else block
        if kind in ("dwell", "wait"):  # Marlin G4: the shared G4 with P in seconds; M400...
            seconds = marlin_dwell_seconds(raw) if kind == "dwell" else 0.0
            return Block(i + 1, (("G", ("num", 4.0)), ("P", ("num", seconds))), (), False, raw)
        if kind == "extruder":  # Marlin M82/M83, G92 E: the extruder's mode or position
            return Block(i + 1, (), (), False, raw, extruder=marlin_extruder(raw))
        if kind == "feed_percent":  # Marlin M220
            return Block(i + 1, (), (), False, raw, feed_percent=marlin_feed_percent(raw))
        if kind == "limits":
            try:
                return replace(lex_line(raw, i + 1), limits=True)
            except GcodeError:  # Marlin reads what it can and ignores the rest
                return Block(i + 1, (), (), False, raw)
        if kind == "home":  # Marlin G28 [X] [Y] [Z] [O] [R]: the axes to home, O and R
            return Block(i + 1, marlin_home_words(raw), (), False, raw, home=True)
        return lex_line(raw, i + 1, self.lex_rules)

    def lexed(self, i: int) -> Block | None:
        """Line ``i`` lexed, or None where its words cannot be read (searches pass over such
        lines, as rs274 does not parse the lines it skips: the error is raised where the line
        runs). Its text refused (:class:`~gantry_sim.controller.gcode.lexer.TextError`) or an
        O-word line refused is raised here: rs274 reads every line it passes over, and reads
        each O-word line to find the one it seeks."""
        try:
            return self.block(i)
        except GcodeError as exc:
            o_line = _O_LINE.match(self.lines[i]) is not None
            if o_line and not isinstance(exc, TextError):
                try:  # rs274 reads a passed-over O-word line's name and keyword only
                    return lex_passed_oword(self.lines[i], i + 1, self.lex_rules)
                except GcodeError as again:
                    exc = again
            if o_line or isinstance(exc, TextError):
                if exc.file is None:
                    exc.file = self.name
                raise exc from None
            return None

    def oword(self, i: int) -> OWord | None:
        block = self.lexed(i)
        return None if block is None else block.oword

    def find(
        self,
        start: int,
        name: str,
        keywords: tuple[str, ...],
        labels: Labels | None = None,
        body_of: str | None = None,
        until_percent: bool = False,
    ) -> int | None:
        """The first line from ``start`` on with O-word ``name`` and one of ``keywords``;
        ``labels``: check the lines passed that open a construct with the same label (rs274,
        skipping a body, refuses those as duplicates; other labels in it are not recorded, so
        an if and its else may each hold an ``o2 if``). ``body_of``: the lines passed are the
        body of subroutine ``body_of``, where rs274 refuses another ``sub`` line ("Nested
        subroutine definition"). ``until_percent``: the search ends at a ``%`` line (the end
        of a program that opened with one: rs274 reads nothing after it)."""
        i = start
        while i < len(self.lines):
            block = self.lexed(i)
            if until_percent and block is not None and block.percent:
                return None
            o = None if block is None else block.oword
            if o is not None and o.name == name and o.keyword in keywords:
                return i
            if o is not None and labels is not None and o.name == name:
                if o.keyword in _CLOSERS:  # rs274 reads it while skipping: another construct's
                    raise GcodeError(
                        f"no matching label: o{_show(name)} {o.keyword} does not close the "
                        f"o{_show(name)} construct being skipped (it ends at o{_show(name)} "
                        f"{' or '.join(keywords)})",
                        line=i + 1,
                    )
                labels.note(self, i, o)
            if o is not None and body_of is not None and o.keyword == "sub":
                raise _nested(o.name, body_of, file=self.name, line=i + 1)
            i += 1
        return None


#: the words an M98 line may carry, which rs274 reads as a block's and moves nothing with: P
#: and L, a G code, axis words, M codes, F, S, T (others, Q, H, R, I, J, K..., no code takes)
_M98_WORDS = frozenset("PLGMFSTNXYZABCUVW")
#: an O-word line: ``o100 ...``, after an optional block delete and line number
_O_LINE = re.compile(r"\s*/?\s*(?:[Nn][0-9.\s]*)?[Oo]")

OPENERS = ("if", "while", "do", "repeat")
#: lines that close (or continue) one kind of construct
_CLOSERS = ("endif", "else", "elseif", "endwhile", "endrepeat")


def _opened(f: Frame, o: OWord, kinds: tuple[str, ...]) -> None:
    """The construct ``o`` (a closing or inner line run) belongs to was opened at this call
    level by one of ``kinds``, as rs274 looks its label up (control_find_oword)."""
    known = f.labels.lines.get(o.name)
    line = f"o{_show(o.name)} {o.keyword}"
    if known is None:
        opener = " or ".join(f"o{_show(o.name)} {k}" for k in kinds)
        raise GcodeError(f"undefined O-word label: {line} with no {opener} open before it")
    if known[2] not in kinds:
        raise GcodeError(
            f"no matching label: {line} does not close or belong to the o{_show(o.name)} "
            f"{known[2]} on line {known[1] + 1} (it belongs to {' or '.join(kinds)})"
        )


@dataclass
class Labels:
    """Control labels of one call level: each may open a construct on one line only (rs274:
    "duplicate O-word label"); a ``while`` with the label of a ``do`` closes it."""

    lines: dict[str, tuple[Source, int, str]] = field(default_factory=dict)

    def note(self, src: Source, i: int, o: OWord) -> None:
        if o.keyword not in OPENERS:
            return
        known = self.lines.get(o.name)
        if known is None:
            self.lines[o.name] = (src, i, o.keyword)
            return
        k_src, k_i, k_kw = known
        if (k_src, k_i) == (src, i) or (o.keyword == "while" and k_kw == "do"):
            return
        raise GcodeError(
            f"duplicate O-word label o{_show(o.name)}: already opens a construct on line "
            f"{k_i + 1}; give each if/while/do/repeat its own label",
            line=i + 1,
        )


@dataclass
class Loop:
    name: str
    kind: str  # "while", "do" or "repeat"
    start: int  # index of the opening line
    remaining: int = 0


@dataclass
class Frame:
    source: Source
    index: int
    loops: list[Loop] = field(default_factory=list)
    sub: str | None = None
    labels: Labels = field(default_factory=Labels)
    fanuc: tuple[int, int] | None = None  # M98 subprogram: (its O line, calls still to make)


class Runner:
    """Executes one program's lines through ``step`` (the interpreter's block step)."""

    def __init__(
        self,
        text: str,
        file: str,
        step: Callable[[Block], tuple[list[Move | Event], bool]],
        params,  # Parameters
        search_path: tuple[Path, ...] = (),
        max_iterations: int = DEFAULT_MAX_ITERATIONS,
        lex_rules: LexRules = RS274_LEX,
        owords: bool = True,
        own_lines: Callable[[str], str | None] | None = None,
        realtime: bool = False,
        checksums: str = "",
        comments: str = "",
        percent_delimits: bool = True,
        line_limit: str = "",
    ) -> None:
        self.main = Source(
            file,
            split_lines(text),
            lex_rules,
            own_lines,
            realtime,
            checksums,
            comments,
            line_limit,
        )
        #: a ``%`` line opens and ends the program (rs274); False: it is nothing
        self.percent_delimits = percent_delimits
        self.owords = owords
        self.step = step
        self.params = params
        self.search_path = search_path
        self.max_iterations = max_iterations
        self.iterations = 0
        self.max_idle_lines = idle_lines_bound(max_iterations)
        #: lines run in a loop or a subroutine since the last move or event
        self.idle_lines = 0
        self.subs: dict[str, tuple[Source, int]] = {}
        self.fanuc_files: dict[int, Source] = {}  # M98 subprograms found in files, by number
        self.searched: set[tuple[Source, int]] = set()  # definitions found by a forward search
        self.frames: list[Frame] = [Frame(self.main, 0)]
        self.ended = False
        self.on_return: Callable[[int], None] | None = None  # M73's restore
        #: called with every line run that holds a comment, comment-only lines too, before
        #: anything else of it runs (LinuxCNC's ``(abort,``)
        self.on_comment: Callable[[Block], None] | None = None
        self.errors: list[GcodeError] | None = None  # collect instead of raising (--all-errors)
        self.seen = False  # a line with content has been run
        self.percent_open = False

    def run(self) -> Iterator[Move | Event]:
        """Yield moves until the program ends; GcodeError (with file and line) on a bad line."""
        while not self.ended:
            f = self.frames[-1]
            if f.index >= len(f.source.lines):
                if f.fanuc is not None:
                    raise GcodeError(
                        f"file ended inside subprogram O{f.sub}; end it with M99",
                        file=f.source.name,
                        line=len(f.source.lines),
                    )
                if f.sub is not None:
                    raise GcodeError(
                        f"file ended inside subroutine o{_show(f.sub)}; close it with "
                        f"o{_show(f.sub)} endsub",
                        file=f.source.name,
                        line=len(f.source.lines),
                    )
                return
            i = f.index
            depth = len(self.frames)
            if f.loops or depth > 1 or f.fanuc is not None:
                self.idle_lines += 1
            try:
                block = self._block(f.source, i)
                if block.oword is not None:  # (a reader without O-words refused it: LexRules)
                    self.seen = True
                    self._oword(f, block.oword)
                    continue
                f.index += 1
                if block.percent:
                    if f.source is self.main and self.percent_delimits:
                        self.on_percent(block)
                    continue
                if self.on_comment is not None and "(" in block.text:
                    self.on_comment(block)
                if block.empty:
                    continue
                self.on_block(block)
                code = fanuc_code(block) if self.owords else None
                if code is not None:
                    self._fanuc(f, block, code)
                    continue
                moves, ended = self.step(block)
                check_finite(moves)
            except GcodeError as exc:
                if exc.line is None:
                    exc.line = i + 1
                if exc.file is None and f.source is not self.main:
                    exc.file = f.source.name
                if self.errors is None or len(self.errors) >= MAX_ERRORS:
                    # moves a block made before it failed (a canned cycle positions the tool
                    # before it checks the spindle or Q, as rs274 does)
                    yield from getattr(exc, "partial", ())
                    raise
                self.errors.append(exc)  # --all-errors: note it, skip the line, go on
                if len(self.frames) == depth and f.index == i:
                    f.index = i + 1
                continue
            if moves:
                if _progress(moves):
                    self.idle_lines = 0
                if f.source is not self.main:  # errors found later name this file
                    moves = [evolve(m, file=f.source.name) for m in moves]
            yield from moves
            self.ended = ended

    def in_subprogram(self) -> bool:
        """Whether the line running is in a subroutine or an M98 subprogram (not the main
        program's own lines)."""
        return len(self.frames) > 1 or self.frames[-1].fanuc is not None

    def on_percent(self, block: Block) -> None:
        """A ``%`` line of the main program: opens it (its first line that is not blank: rs274's
        Interp::open, so not after a comment or an O number) or ends it."""
        if not self.seen:
            if any(line.strip() for line in self.main.lines[: block.line - 1]):
                raise GcodeError(
                    "'%' opens a program only as its first line that is not blank (a comment "
                    "or a program number before it makes the '%' a bad character to rs274); "
                    "move it to the top, or remove it"
                )
            self.percent_open = self.seen = True
        elif self.percent_open:
            self.ended = True
        else:
            raise GcodeError("'%' ends a program only when the program also starts with a '%' line")

    def on_block(self, block: Block) -> None:
        self.seen = True

    # O-words ---------------------------------------------------------------------------------
    def _value(self, o: OWord, k: int = 0) -> float:
        if len(o.args) <= k:
            raise GcodeError(f"o{_show(o.name)} {o.keyword} needs a [value]")
        return evaluate(o.args[k], self.params)

    def _tick(self, o: OWord) -> None:
        self.iterations += 1
        if self.iterations > self.max_iterations:
            raise GcodeError(
                f"more than {self.max_iterations} loop repetitions and calls (at o{_show(o.name)} "
                f"{o.keyword}); a runaway loop or recursion? Raise the bound with "
                "--max-iterations if the program is right"
            )
        self._check_idle(f"o{_show(o.name)} {o.keyword}")

    def _check_idle(self, where: str) -> None:
        """Refuse a loop or call (``where``) made after more than ``max_idle_lines`` lines run
        in loops and subroutines without a move that goes somewhere or a dwell that lasts."""
        if self.idle_lines > self.max_idle_lines:
            raise GcodeError(
                f"{self.idle_lines} lines run in loops and subroutines without a move (at "
                f"{where}; a move of no length, G4 P0 or a stop is none): a loop that never "
                f"ends? At most {self.max_idle_lines} are run (a tenth of --max-iterations); "
                "raise --max-iterations if the program is right"
            )

    def _block(self, source: Source, i: int) -> Block:
        """Line ``i`` of ``source`` lexed. Where the program has no LinuxCNC language (grbl)
        and a line it cannot lex holds a ``#`` or ``[`` outside comments (a parameter setting,
        an expression, a ``#`` taken for a comment), the error says the dialect has none,
        instead of what LinuxCNC's lexer expected next: where a word's letter belongs, grbl
        expects a command letter (error 1); after a letter, a number (``Z#GMAZ``, a sender's
        placeholder: bad number format, error 2)."""
        try:
            return source.block(i)
        except GcodeError as exc:
            text = _uncommented(source.lines[i])
            first = min((k for k in (text.find("#"), text.find("[")) if k >= 0), default=-1)
            if self.owords or first < 0:
                raise
            if first > 0 and text[first - 1].isalpha():
                raise GcodeError(
                    f"bad number format after {text[first - 1].upper()}: grbl reads a plain "
                    "number ('#' parameters and [expressions] are LinuxCNC's, grbl has none)",
                    line=exc.line,
                ) from None
            raise GcodeError(
                "'#' parameters and [expressions] are not grbl features; grbl expects a "
                "command letter followed by a number",
                line=exc.line,
            ) from None

    def _oword(self, f: Frame, o: OWord) -> None:
        src, i = f.source, f.index
        name, kw = o.name, o.keyword
        f.labels.note(src, i, o)
        if kw == "sub":
            if f.sub is not None:  # a subroutine's body run from a file, unscanned
                raise _nested(name, f.sub)
            end = src.find(i + 1, name, ("endsub",), body_of=name)
            if end is None:
                raise GcodeError(f"o{_show(name)} sub without o{_show(name)} endsub")
            known = self.subs.get(name)
            if known is not None and known != (src, i):
                raise GcodeError(f"o{_show(name)} sub redefines a subroutine already defined")
            if known is not None and (src, i) in self.searched:
                raise GcodeError(
                    f"o{_show(name)} sub reached after it was called from above; rs274 calls this "
                    "an illegal location: define subroutines before their call or after M2"
                )
            self.subs[name] = (src, i)
            f.index = end + 1
        elif kw in ("endsub", "return"):
            if f.sub is None:
                raise GcodeError(f"o{_show(name)} {kw} outside a subroutine")
            self._returned(self._value(o) if o.args else None)
            level = self.params.level
            self.params.leave()
            self.frames.pop()
            if self.on_return is not None:
                self.on_return(level)
        elif kw == "call":
            self._call(f, o)
        elif kw == "if":
            f.index = i + 1 if self._value(o) != 0.0 else self._next_branch(src, i, name)
        elif kw in ("elseif", "else"):
            _opened(f, o, ("if",))
            if kw == "elseif":
                self._value(o)  # rs274 reads the condition, then skips: its errors count
            end = src.find(i + 1, name, ("endif",))
            if end is None:
                raise GcodeError(f"o{_show(name)} {kw} without o{_show(name)} endif")
            f.index = end + 1  # a branch was taken: skip the rest
        elif kw == "endif":
            _opened(f, o, ("if",))
            f.index = i + 1
        elif kw == "do":
            self._tick(o)
            f.loops.append(Loop(name, "do", i))
            f.index = i + 1
        elif kw == "while":
            self._while(f, o)
        elif kw == "endwhile":
            _opened(f, o, ("while",))
            loop = self._loop(f, o, ("while",))
            f.loops.pop()
            f.index = loop.start
        elif kw == "repeat":
            count = round(self._value(o))
            if count <= 0:
                f.index = self._end_of(src, i, name, "endrepeat", True) + 1
            else:
                f.loops.append(Loop(name, "repeat", i, count))
                f.index = i + 1
        elif kw == "endrepeat":
            _opened(f, o, ("repeat",))
            loop = self._loop(f, o, ("repeat",))
            loop.remaining -= 1
            if loop.remaining > 0:
                self._tick(o)
                f.index = loop.start + 1
            else:
                f.loops.pop()
                f.index = i + 1
        elif kw in ("break", "continue"):
            _opened(f, o, ("while", "do"))
            self._break_continue(f, o)

    def _returned(self, value: float | None) -> None:
        """A subroutine returns (endsub, return, M99): ``#<_value>`` is its value (0 without
        one) and ``#<_value_returned>`` says whether it gave one, as rs274 sets them at every
        return (a call leaves both as they were)."""
        self.params.globals["_value"] = 0.0 if value is None else value
        self.params.globals["_value_returned"] = 0.0 if value is None else 1.0

    def _next_branch(self, src: Source, i: int, name: str) -> int:
        """After a false condition at line ``i``: the line to run next."""
        j = i
        while True:
            j2 = src.find(j + 1, name, ("elseif", "else", "endif"), self.frames[-1].labels)
            if j2 is None:
                raise GcodeError(f"o{_show(name)} if without o{_show(name)} endif")
            o = src.oword(j2)
            assert o is not None
            if o.keyword == "elseif":
                try:
                    if self._value(o) != 0.0:
                        return j2 + 1
                except GcodeError as exc:
                    exc.line = j2 + 1
                    raise
                j = j2
                continue
            return j2 + 1

    def _end_of(self, src: Source, i: int, name: str, keyword: str, skip: bool) -> int:
        """The closing line; ``skip``: the body is skipped, its labels are read on the way."""
        end = src.find(i + 1, name, (keyword,), self.frames[-1].labels if skip else None)
        if end is None:
            raise GcodeError(f"o{_show(name)} without o{_show(name)} {keyword}")
        return end

    def _loop(self, f: Frame, o: OWord, kinds: tuple[str, ...]) -> Loop:
        if not f.loops or f.loops[-1].name != o.name or f.loops[-1].kind not in kinds:
            raise GcodeError(f"o{_show(o.name)} {o.keyword} without its opening line")
        return f.loops[-1]

    def _while(self, f: Frame, o: OWord) -> None:
        i = f.index
        top = f.loops[-1] if f.loops else None
        if top is not None and top.name == o.name and top.kind == "do":
            if self._value(o) != 0.0:
                self._tick(o)
                f.index = top.start + 1
            else:
                f.loops.pop()
                f.index = i + 1
            return
        if self._value(o) != 0.0:
            self._tick(o)
            f.loops.append(Loop(o.name, "while", i))
            f.index = i + 1
        else:
            f.index = self._end_of(f.source, i, o.name, "endwhile", True) + 1

    def _break_continue(self, f: Frame, o: OWord) -> None:
        while f.loops and f.loops[-1].name != o.name:
            f.loops.pop()
        if not f.loops:
            raise GcodeError(f"o{_show(o.name)} {o.keyword} outside a loop named o{_show(o.name)}")
        loop = f.loops[-1]
        src, start = f.source, loop.start
        closing = {"while": "endwhile", "do": "while", "repeat": "endrepeat"}[loop.kind]
        end = src.find(start + 1, o.name, (closing,))
        if end is None:
            raise GcodeError(f"o{_show(o.name)} loop without o{_show(o.name)} {closing}")
        if o.keyword == "break":
            f.loops.pop()
            f.index = end + 1
        elif loop.kind == "while":
            f.loops.pop()
            f.index = start
        else:
            f.index = end  # do: test the condition; repeat: count this pass

    def _call(self, f: Frame, o: OWord) -> None:
        if o.number is not None:
            o = replace(o, name=self._computed_name(o.number), number=None)
        args = [evaluate(a, self.params) for a in o.args]
        if len(args) > 30:
            raise GcodeError(f"o{_show(o.name)} call with {len(args)} arguments; at most 30")
        found = self.subs.get(o.name)
        if found is None:
            found = self._find_sub(f.source, f.index, o.name)
        if len(self.frames) > MAX_CALL_LEVELS:
            raise GcodeError(
                f"too many subroutine levels (more than {MAX_CALL_LEVELS} nested calls, as in "
                "LinuxCNC); a runaway recursion?"
            )
        self._tick(o)
        src, at = found
        f.index += 1
        self.params.enter(args)
        self.frames.append(Frame(src, at + 1, sub=o.name))

    def _computed_name(self, number: Tree) -> str:
        """The O number ``number`` evaluates to now, as an O-word's name: rs274 reads it as
        an integer value (:func:`whole_number`), and O numbers are not negative."""
        value = evaluate(number, self.params)
        if not math.isfinite(value) or value < 0:
            raise GcodeError(f"O{value:g} call: an O number is a whole number >= 0")
        return str(int(whole_number("O", value)))

    def _fanuc(self, f: Frame, block: Block, code: int) -> None:
        """M98 P<n> [L<count>] / M99 (controller/gcode/fanuc_subs.py); ``f.index`` is already
        past the line."""
        others = [letter for letter, _ in block.words[1:]]
        if code == 99:
            if f.fanuc is None and len(self.frames) == 1:
                if "P" in others:  # rs274 reads it as a block: no code here takes P
                    raise GcodeError(
                        "P word with no code that uses it on M99 (other controls' M99 P returns "
                        "to a line; LinuxCNC's does not)"
                    )
                self.ended = True  # rs274 -g: M99 in the main program ends it
                return
            if others and f.fanuc is not None:
                raise GcodeError(
                    f"unexpected {others[0]} word after M99: M99 ends a subprogram and takes "
                    "no word (rs274: Unexpected character after O-word)"
                )
            if f.fanuc is None:
                raise GcodeError(
                    "M99 in an o-word subroutine; 'O.... endsub' or 'O.... return' must follow "
                    "'O.... sub'"
                )
            at, left = f.fanuc
            if left > 1:  # counted in ``iterations`` by the call
                self._check_idle(f"M99 repeating O{f.sub}")
                f.fanuc, f.index, f.loops = (at, left - 1), at + 1, []
                return
            passed = {i: self.params.numbered.get(i, 0.0) for i in range(1, 31)}
            self._returned(None)
            self.params.leave()
            self.params.numbered.update(passed)  # M98: #1..#30 are the caller's, not restored
            self.frames.pop()
            return
        words = dict(block.words[1:])
        if "P" not in words:
            raise GcodeError("found M98 with no P word: the number of the O subprogram to call")
        unused = next((k for k in others if k not in _M98_WORDS), None)
        if unused is not None:
            raise GcodeError(
                f"{unused} word with no code that uses it on M98 (P the subprogram, L the count)"
            )
        p = evaluate(words["P"], self.params)
        number = round(p)
        if abs(p - number) > 0.0001:
            raise GcodeError(f"M98 P{p:g}: the subprogram number must be a whole number")
        count = int(whole_number("L", evaluate(words["L"], self.params))) if "L" in words else 1
        if count <= 0:
            return  # L0: no call
        source: Source | None = f.source
        found = find_program(f.source.lines, f.index, number)
        if found is None:  # rs274 looks it up as an o<n> call: n.ngc in the search path
            source = self.fanuc_files.get(number) or self._sub_file(str(number))
            found = None if source is None else find_program(source.lines, 0, number)
        if source is None or found is None:
            raise GcodeError(
                f"M98 P{number}: no subprogram O{number} in {f.source.name} or a file "
                f"{number}.ngc in the subroutine path (a line 'O{number}' starts it, M99 ends it)"
            )
        if source is not f.source:
            self.fanuc_files[number] = source
        if len(self.frames) > MAX_CALL_LEVELS:
            raise GcodeError(
                f"too many subroutine levels (more than {MAX_CALL_LEVELS} nested calls, as in "
                "LinuxCNC); a runaway recursion?"
            )
        self.iterations += count  # its L repeats, counted at once: M98 P1 L99999999 stops here
        if self.iterations > self.max_iterations:
            raise GcodeError(
                f"more than {self.max_iterations} loop repetitions and calls (at M98 P{number})"
                "; raise the bound with --max-iterations if the program is right"
            )
        self.params.enter([self.params.numbered.get(i, 0.0) for i in range(1, 31)])
        self.frames.append(Frame(source, found + 1, sub=str(number), fanuc=(found, count)))

    def _sub_file(self, name: str) -> Source | None:
        """``NAME.ngc`` in the first folder of the search path that has one, read (rs274's
        lookup of an ``o<name> call`` and of an ``M98 P<n>`` not in the program), or None."""
        for folder in self.search_path:
            path = folder / f"{name}.ngc"
            try:
                found = path.is_file()
            except OSError as exc:  # a name longer than the file system allows, ...
                raise GcodeError(
                    f"subroutine o{_show(cut(name))} cannot be "
                    f"looked up as a file in {folder}: {exc.strerror}"
                ) from None
            if found:
                data = read_capped(path, "subroutine file", MAX_SUB_FILE_BYTES, GcodeError)
                return Source(
                    str(path),
                    split_lines(decode_program(data)),
                    comments=self.main.comments,
                    line_limit=self.main.line_limit,
                    lex_rules=self.main.lex_rules,
                )
        return None

    def _find_sub(self, src: Source, i: int, name: str) -> tuple[Source, int]:
        at = src.find(i + 1, name, ("sub",), until_percent=src is self.main and self.percent_open)
        if at is not None:
            self.subs[name] = (src, at)
            self.searched.add((src, at))
            return src, at
        sub_src = self._sub_file(name)
        if sub_src is not None:
            at = sub_src.find(0, name, ("sub",))
            if at is None:
                raise GcodeError(f"subroutine file {sub_src.name} has no o<{cut(name)}> sub line")
            self.subs[name] = (sub_src, at)
            return sub_src, at
        where = ", ".join(str(p) for p in self.search_path) or "no search path"
        closed = " before its closing '%' (nothing after it is read)" if self.percent_open else ""
        raise GcodeError(
            f"subroutine o{_show(cut(name))} not found: not defined in the program{closed} and "
            f"no {cut(name)}.ngc in the subroutine path ({where}); add --subroutine-path DIR"
        )


def _progress(moves: Sequence[object]) -> bool:
    """Whether ``moves`` take the machine anywhere or take time: a move of positive length
    [mm] or a dwell of positive seconds. A zero-length G1, G4 P0, M1 or a mode change does
    not: a loop of a million of them took minutes to parse and plan, for nothing."""
    for m in moves:
        length = getattr(m, "length_mm", None)
        if (length is not None and length > 0) or getattr(m, "seconds", 0.0) > 0:
            return True
    return False


def idle_lines_bound(max_iterations: int) -> int:
    """Lines a program may run in loops and subroutines without a move or event: a tenth of
    ``max_iterations`` (100,000 by default: 0.4-2.5 s at 4-25 us a line), at least
    :data:`MIN_IDLE_LINES`. Each repetition of a loop that moves resets the count, so only a
    loop that computes without moving meets it: of the 185 programs LinuxCNC 2.9 ships
    (``ncfiles``) and the test corpora, none runs more than 97 such lines in a row (the
    recursion of flowsnake.ngc) nor more than 4,095 repetitions and calls."""
    return max(max_iterations // 10, MIN_IDLE_LINES)


def _nested(inner: str, outer: str, file: str | None = None, line: int | None = None) -> GcodeError:
    """rs274's "Nested subroutine definition": ``o<inner> sub`` within ``o<outer>``'s body."""
    return GcodeError(
        f"o{_show(inner)} sub inside the definition of o{_show(outer)}: subroutines cannot be "
        "nested; define it outside",
        file=file,
        line=line,
    )


def _uncommented(raw: str) -> str:
    """``raw`` without its comments (as :func:`strip_line` gives it; the raw line where that
    fails: an unclosed or nested comment)."""
    try:
        return strip_line(raw)
    except GcodeError:
        return raw


def _show(name: str) -> str:
    return name if name.isdigit() else f"<{name}>"
