"""Marlin's and g2core's own lines, sorted before the shared block step.

Marlin (marlinfw.org "G-code index"): an M or T line carries that command's parameters (``M104
S200``, ``M201 X500 Y500``, ``M117 text``), never a motion, and Marlin answers an M code it does not
know with "Unknown command" and goes on: every M and T line is accepted without motion. G-codes
of Marlin's own that do not move the tool are accepted (G4 dwell in P ms or S s, G10/G11 firmware
retract, G29-G35 and G76 probing and calibration, G60 save position, G80, G92 with E alone);
G28 homes the named axes (all when none) to the machine file's work origin; the ones that move
in ways this machine does not model are refused with a reason (G6 direct stepper,
G12 nozzle clean, G26 mesh print, G27 park, G42 mesh point, G61 restore position after a G60,
G38 probe; a G61 before any G60 does nothing, as in Marlin).
A bare ``G26`` is skipped: Marlin's default configuration leaves G26_MESH_VALIDATION off (an
unknown command there), and LulzBot's Marlin clears a failed probe with it (every LulzBot
Cura start code opens with it); the mesh validation print takes parameters.
A line that opens with no command (a stray number, ``% text``, a Klipper macro) or with a G
code Marlin does not know (``G392``: gcode.cpp's ``default: unknown_command_warning()``) gets
Marlin's "Unknown command" and is skipped, and so is a bare ``G5`` (every parameter defaults to
zero: a curve of no length; Cura's Anycubic start code has one); G, M and T words after a G
command are its parameters, which it ignores (``G90 M107`` is G90, ``G0 G90 X20`` a G0 to X20
in the distance mode in effect); G20, G21, G90 and G91 read no word at all (``G91 G0 Z5`` is a
G91 alone, ``G90 X10`` moves nothing): Marlin runs one command a line.

g2core: a line opening with ``{`` is JSON: its ``gc`` pair runs as a G-code line, its other
pairs (configuration, status requests) move nothing; a line that is one ``({...})`` active
comment is read as that JSON line. M100 (JSON in a G-code line), M100.1 and M101 (wait for
inputs) move nothing; G28.2 (homing) and G28.4
are accepted without motion, and leave the motion mode cancelled, as g2core's homing ends
(cycle_homing.cpp ``_homing_finalize_exit``). G28.3 (set the absolute origin) makes the named
axes read the words' values where the tool is, without moving it (canonical_machine.cpp
``cm_set_absolute_origin``): it runs as a G92 with the same words, the one offset that shifts
every later position without moving the tool (a later G92.1 clears it, where g2core's origin
stays). A line opening with ``?``, ``$``, ``H`` or ``h`` is a text-mode command (status report,
settings, help: controller.cpp ``_dispatch_kernel``), no motion. ``~`` (cycle start) and ENQ are
single-character controls: at a line's very start each is split off as a line of its own and
what follows is read as the next line (xio.cpp ``_scanBuffer``); after blanks, the control takes
the whole line. A ``!`` (feedhold) there is refused: g2core acts on it when it arrives, ahead
of the moves queued before it, and holds until the operator's cycle start, so where the machine
stops depends on the sender's timing, which a file does not give.
"""

from __future__ import annotations

import re
from collections.abc import Callable

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.codes import G_GROUPS

#: M codes with free text after them (M117 message, M118 serial echo, SD file names).
_TEXT = re.compile(r"^\s*(?:N\d+\s*)?M\s*0*(117|118|23|28|30|32|33|928)(?!\d)", re.IGNORECASE)
_HEAD = re.compile(r"^\s*(?:N\d+\s*)?([GMT])\s*([0-9]+(?:\.[0-9]+)?)", re.IGNORECASE)

#: Marlin M codes that wait for the moves buffered before them to end (each calls
#: ``planner.synchronize()``): M0/M1 (stop), M18/M84 (steppers off), M226 (wait for a pin),
#: M400 (finish moves). Each is an exact stop, of no time.
MARLIN_SYNC_M = frozenset((0.0, 1.0, 18.0, 84.0, 226.0, 400.0))
#: Marlin G codes (tenths) accepted with no tool motion here.
MARLIN_QUIET_G = frozenset((40, 100, 110, 290, 291, 292, 293, 300, 310, 320, 330, 340, 350, 760))
#: Marlin G codes (tenths) accepted with no motion when they come with no word: a bare G5
#: (every parameter defaults to zero: a curve of no length) and a bare G26 (LulzBot's "clear
#: probe fail"; Marlin's default configuration has no G26; with words it is the mesh
#: validation print, refused below).
MARLIN_BARE_QUIET_G = frozenset((50, 260))
#: Marlin G codes (tenths) that read no word: G17-G19, G20, G21, G54-G59.3, G80, G90, G91 (the
#: rest of a line is theirs to ignore: :func:`marlin_command_alone`; each handler reads no
#: parameter, and only G53 runs a second command of a line, parser.cpp's ``chain``).
MARLIN_NO_WORDS_G = frozenset(
    (170, 180, 190, 200, 210, 540, 550, 560, 570, 580, 590, 591, 592, 593, 800, 900, 910)
)
#: The G commands of Marlin's dispatch (gcode.cpp ``process_parsed_command``, bugfix-2.1.x,
#: whole numbers; some only in builds with their feature). A line opening with any other G
#: (LinuxCNC's G40, G43, G52, G64, G81, G93, G94...) is an "Unknown command": Marlin runs
#: nothing of it, neither the code nor a motion after it.
MARLIN_G_COMMANDS = frozenset((
    0, 1, 2, 3, 4, 5, 6, 10, 11, 12, 17, 18, 19, 20, 21, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35,
    38, 42, 53, 54, 55, 56, 57, 58, 59, 60, 61, 76, 80, 90, 91, 92, 425, 800,
))  # fmt: skip
#: Marlin G commands whose subcode means something (G38.2-G38.5 probing, G59.1-G59.3): every
#: other command drops it (parser.cpp reads the code number alone, or the subcode where
#: USE_GCODE_SUBCODES is on, which only these handlers read; the default build's G92.1 is a
#: G92).
MARLIN_SUBCODE_G = frozenset((38, 59))
#: Marlin G codes refused, with why.
MARLIN_REFUSED_G: dict[int, str] = {
    60: "G6 (direct stepper moves) is not supported",
    120: "G12 (nozzle clean) moves in a pattern gantry-sim does not model",
    260: "G26 (mesh validation print) is not supported",
    270: "G27 (park the nozzle) moves to a firmware-configured point gantry-sim does not know",
    420: "G42 (move to a mesh point) needs the printer's mesh, which gantry-sim does not have",
    **dict.fromkeys((382, 383, 384, 385), "probing moves (G38.x) are not supported"),
    4250: "G425 (backlash calibration) is not supported",
}


def marlin_line(raw: str) -> str | None:
    """What a Marlin line is before the shared step: "quiet" (accepted, no motion), "home" (G28),
    "dwell" (G4 P<ms> or S<s>), "wait" (an M code of :data:`MARLIN_SYNC_M`), "limits"
    (M201/M203/M204/M205), "extruder" (M82, M83, or G92 with E alone:
    :func:`marlin_extruder`), "feed_percent" (M220: :func:`marlin_feed_percent`),
    "parameters" (a G line with G, M or T words, which Marlin reads as parameters the command
    ignores), "command_alone" (a G of :data:`MARLIN_NO_WORDS_G` with words:
    :func:`marlin_command_alone`),
    "motion" (G0-G3, G5, G92: :func:`marlin_motion`), "save" (G60) and "restore" (G61),
    which :class:`MarlinLines` reads, "subcode" (a G whose
    subcode Marlin drops: :func:`marlin_without_subcode`), "line_number" (a signed line
    number, which Marlin skips as it skips N10: :func:`marlin_without_line_number`), or None
    (a shared G-code line). GcodeError for a refused G code."""
    if _SIGNED_LINE_NUMBER.match(raw):
        return "line_number"
    if _TEXT.match(raw):
        return "quiet"
    code = raw.split(";", 1)[0]
    if _BARE_WORDS.match(code):
        return "bare_motion"
    if _NOT_A_COMMAND.match(code):
        return "quiet"  # Marlin: "Unknown command", and on to the next line
    head = _HEAD.match(code)
    if head is None:
        return None
    letter, number = head.group(1).upper(), head.group(2)
    if letter == "M":
        number = number.split(".", 1)[0]  # M220.5 is M220, M83.5 an M83: no M reads a subcode
    if letter == "M" and number.lstrip("0") in ("201", "203", "204", "205"):
        return "limits"
    if letter == "M" and number.lstrip("0") in ("82", "83"):
        return "extruder"
    if letter == "M" and float(number) in MARLIN_SYNC_M:
        return "wait"
    if letter == "M" and number.lstrip("0") == "220":
        return "feed_percent"
    if letter in "MT":
        return "quiet"
    whole = int(float(number))
    if whole not in MARLIN_G_COMMANDS:
        return "quiet"  # Marlin: unknown_command_warning(), and on to the next line
    if "." in number and whole not in MARLIN_SUBCODE_G:
        return "subcode"  # G91.1 is G91, G1.5 a G1, G28.1 a G28: marlin_without_subcode
    tenths = round(float(number) * 10)
    if tenths == 280:
        return "home"
    if tenths in (600, 610):  # G60 save, G61 restore: MarlinLines keeps the saved state
        return "save" if tenths == 600 else "restore"
    if tenths == 40:
        return "dwell"
    words = code[head.end() :]
    if tenths in MARLIN_BARE_QUIET_G and not _WORD.search(_PARAMETER_GMT.sub("", words)):
        return "quiet"
    if tenths in MARLIN_REFUSED_G:
        raise GcodeError(f"{MARLIN_REFUSED_G[tenths]} (Marlin G{number})")
    if tenths == 920 and _g92_sets_no_axis(words):
        return "extruder" if _E_WORD.search(_PAREN.sub("", code[head.end() :])) else "quiet"
    if tenths in MARLIN_QUIET_G:
        return "quiet"
    if tenths == 530 and not _G53_CHAINED_MOVE.search(words):
        # G53 with no G0/G1 to chain (parser.cpp ``chain``): the build followed has no G53
        # and skips the line (G53 G11 too); with CNC_COORDINATE_SYSTEMS it leaves the
        # workspace offsets, and nothing moves
        return "quiet"
    if tenths not in G_GROUPS:
        return "quiet"  # a subcode it does not know (G38.6) or G800, its parser's debug
    if tenths in MARLIN_NO_WORDS_G and _PAREN.sub("", words).strip():
        return "command_alone"  # anything after it, words or not (G21 %, G90 PRINT_START)
    if tenths in _MOTION_READS:
        # most printer lines need no reading of Marlin's own: the shared step reads them alike
        if tenths <= 10 and _PLAIN_G01_WORDS.fullmatch(words):
            letters = words.translate(_NOT_LETTERS)
            if len(set(letters)) == len(letters):  # no letter twice
                return None
        return "motion"
    if _PARAMETER_GMT.search(words):
        return "parameters"
    return None


#: A line number with a sign, ``N-3``: GCodeParser::parse skips an N followed by a digit or
#: a sign, then digits and spaces (the shared lexer's N takes digits only).
_SIGNED_LINE_NUMBER = re.compile(r" *[Nn][-+][0-9]* *")


def marlin_without_line_number(raw: str) -> str:
    """A "line_number" line (:func:`marlin_line`) without its signed line number and the
    spaces after it, as Marlin's parser goes on from there: ``N-3 G1 X2`` is a G1."""
    found = _SIGNED_LINE_NUMBER.match(raw)
    return raw if found is None else raw[found.end() :]


def marlin_without_subcode(raw: str) -> str:
    """A "subcode" line (:func:`marlin_line`) with its command's subcode dropped, as Marlin
    runs it: ``G91.1`` is a G91, ``G1.5 X3`` a G1, ``G28.1`` homes."""
    _, head = _command(raw)
    return raw[: head.start(2)] + str(int(float(head.group(2)))) + raw[head.end(2) :]


#: The parameters each Marlin command of a "motion" line reads, by its code in tenths:
#: G0/G1 (get_destination_from_command: the axes, E, F), G2/G3 (and I, J, K, R, P:
#: G2_G3.cpp), G5 (I, J, P, Q: G5.cpp), G92 (the axes and E). Every other word of the line is
#: set by the parser and read by no one (``G1 X5 I2 S100 T1``: a G1 X5).
_MOTION_READS = {
    0: "XYZEF",
    10: "XYZEF",
    20: "XYZEFIJKRP",
    30: "XYZEFIJKRP",
    50: "XYZEFIJPQ",
    920: "XYZE",
}
#: The words of a G0/G1 line that Marlin and the shared step read alike: X Y Z E F, each with
#: a number, spaces between (a repeated letter is checked apart); anything else is read by
#: :func:`marlin_motion`.
_PLAIN_G01_WORDS = re.compile(r"(?: *[XYZEF] *[-+]?(?:\d+\.?\d*|\.\d+))* *")
_NOT_LETTERS = str.maketrans("", "", "0123456789.+- ")
#: One step of GCodeParser::parse's parameter loop (parser.cpp, FASTER_GCODE_PARSER): a letter,
#: the spaces after it and the run of [0-9.+-] there (its value, if it is a number), then
#: spaces; or any other character, then such a run and spaces (passed over).
_MARLIN_STEP = re.compile(r"([A-Za-z]) *([0-9.+-]*) *|.[0-9.+-]* *", re.DOTALL)
#: valid_float: a value starts [-+]?.?[0-9]; value_float: strtof's number from there (it stops
#: at a space, E or X, as Marlin cuts it before calling strtof)
_MARLIN_VALUE = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)")


def marlin_motion(raw: str) -> str:
    """A "motion" line (:func:`marlin_line`) as Marlin reads it, written as the shared step
    reads it: its command, then each parameter the command reads with the value of its last
    occurrence (Marlin's parser keeps one pointer a letter, the last one set), left out where
    that occurrence has no value (``G0 Z8 F`` keeps the feed; ``G1 X5 X`` moves no X) and,
    on an arc with a radius, its I, J and K (G2_G3.cpp reads R first). A value ends where its
    number does: ``Y1 0`` is Y1, ``X1.5.5`` X1.5. ``( )`` comments are dropped, as the
    PAREN_COMMENTS build's reader drops them (the default build reads their words)."""
    code, head = _command(raw)
    tenths = round(float(head.group(2)) * 10)
    reads = _MOTION_READS[tenths]
    params = _marlin_parameters(code[head.end() :])
    if tenths in (20, 30) and params.get("R") is not None:  # G5 reads no R
        params.update(dict.fromkeys("IJK"))
    words = " ".join(f"{k}{v}" for k, v in params.items() if v is not None and k in reads)
    if tenths == 920 and not words:
        return ""  # a G92 of no axis and no E reports the position; nothing changes
    return f"{head.group()} {words}"


def marlin_bare_motion(raw: str) -> str:
    """A "bare_motion" line (:func:`marlin_line`: parameters with no command, ``X10 Y5``) as
    GCODE_MOTION_MODES reads it: every parameter a modal G0-G3 or G5 may read (X, Y, Z, E, F,
    I, J, K, P, Q, R), each read as :func:`marlin_motion` reads it (a slicer template's
    valueless ``X[x] Y5`` is a Y5), for the interpreter to keep those its modal motion reads
    (:func:`marlin_bare_opener`); nothing where no value is left."""
    params = _marlin_parameters(raw.split(";", 1)[0])
    return " ".join(f"{k}{v}" for k, v in params.items() if v is not None and k in _BARE_READ)


def marlin_bare_opener(raw: str) -> str:
    """The letter a "bare_motion" line opens with (upper case): parser.cpp runs the line as
    the modal motion only where that motion takes it (:data:`MARLIN_BARE_OPENERS`)."""
    found = _BARE_WORDS.match(raw.split(";", 1)[0])
    assert found is not None
    return found.group(1).upper()


#: the parameters a bare line may carry for a modal motion
_BARE_READ = "XYZEFIJKPQR"
#: GCODE_MOTION_MODES (parser.cpp): the modal motion (tenths) -> the letters a bare line may
#: open with to run as that motion, and the parameters that motion reads. An R opens a G2/G3
#: line; I, J, P and Q never open one: their cases fall through to R's, which returns unless
#: the motion is G2/G3, and before it Q's, which returns unless it is G5 (checked on Marlin
#: built for the host: ``I5 J0 X30`` after a G5 moves nothing)
MARLIN_BARE_OPENERS: dict[int, tuple[str, str]] = {
    0: ("XYZEF", "XYZEF"),
    10: ("XYZEF", "XYZEF"),
    20: ("XYZEFR", "XYZEFIJKPR"),
    30: ("XYZEFR", "XYZEFIJKPR"),
    50: ("XYZEF", "XYZEFIJPQ"),
}


def _marlin_parameters(text: str) -> dict[str, str | None]:
    """The parameters of ``text`` (a line after its command) as GCodeParser::parse sets them:
    each letter (upper case) with the value of its last occurrence, None where that has no
    number; ``( )`` comments dropped, as the PAREN_COMMENTS build's reader drops them (the
    Marlin dialect's lines come here without them: lexer.firmware_comments)."""
    params: dict[str, str | None] = {}
    for step in _MARLIN_STEP.finditer(_PAREN.sub("", text)):
        letter = step.group(1)
        if letter is not None:
            value = _MARLIN_VALUE.match(step.group(2))
            params[letter.upper()] = value.group() if value else None
    return params


def _command(raw: str) -> tuple[str, re.Match[str]]:
    """A Marlin line that :func:`marlin_line` sorted: its text before any ``;`` comment, and
    the match of its command (:data:`_HEAD`)."""
    code = raw.split(";", 1)[0]
    head = _HEAD.match(code)
    assert head is not None  # marlin_line found it
    return code, head


def marlin_home_words(raw: str) -> tuple[tuple[str, tuple[str, float]], ...]:
    """A G28 line's words as GcodeSuite::G28 reads them: each of X, Y, Z named (with or without
    a value: the letter names the axis), O (home only what is not homed) and R with its value
    (raise Z by R before homing: ``seenval('R')``), upper case, for the interpreter's home."""
    code, head = _command(raw)
    params = _marlin_parameters(code[head.end() :])
    words: list[tuple[str, tuple[str, float]]] = [(a, ("num", 0.0)) for a in "XYZO" if a in params]
    r = params.get("R")
    if r is not None:
        words.append(("R", ("num", float(r))))
    return tuple(words)


def _g92_sets_no_axis(words: str) -> bool:
    """Whether a G92's words (after its command) set no X, Y or Z: an E alone (or the axes
    Marlin's default build lacks, A B C U V W), which sets the extruder or nothing. Its other
    letters are parameters G92 does not read (``G92 E0 M400``); a letter with no value sets
    nothing (GcodeSuite::G92 reads ``seenval``)."""
    params = _marlin_parameters(words)
    return all(params.get(a) is None for a in "XYZ")


def marlin_command_alone(raw: str) -> str:
    """A "command_alone" line (:func:`marlin_line`) cut after its command: Marlin runs one
    command a line, and G17-G19, G20, G21, G54-G59, G80, G90 and G91 read none of the words
    after them (``G91 G0 Z5`` is a G91 alone, ``G90 X10`` and ``G17 G2 X10 I5`` move
    nothing)."""
    code, head = _command(raw)
    return code[: head.end()]


#: A ( ) comment (one left open runs to the end of the line).
_PAREN = re.compile(r"\([^)]*\)?")
#: An E word, and its value (none, or a sign alone: 0, as Marlin's parser reads it).
_E_WORD = re.compile(r"E\s*([-+]?(?:\d+\.?\d*|\.\d+)?)", re.IGNORECASE)


def marlin_extruder(raw: str) -> tuple[str, float]:
    """An "extruder" line's setting (:attr:`~gantry_sim.controller.gcode.lexer.Block.extruder`):
    ("relative", 1.0) for M83, ("relative", 0.0) for M82, ("position", E) for G92 E (its last
    E word, in the program's units)."""
    code, head = _command(raw)
    if head.group(1).upper() == "M":
        number = head.group(2).split(".", 1)[0]  # M83.5 is an M83
        return ("relative", 1.0 if number.lstrip("0") == "83" else 0.0)
    value = _E_WORD.findall(_PAREN.sub("", code[head.end() :]))[-1]
    return ("position", float(value) if value.lstrip("+-") else 0.0)


#: A parameter as Marlin's parser reads it: a letter, spaces, and the value if one follows.
_PARAMETER = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))?", re.IGNORECASE)
#: strtol's reading of a number: its sign and whole part (none: 0)
_WHOLE = re.compile(r"[-+]?\d*")
#: Marlin keeps M220's percentage in an int16_t
FEED_PERCENT_MAX = 32767


def marlin_feed_percent(raw: str) -> tuple[bool, bool, int | None]:
    """An M220 line (gcode/config/M220.cpp): (R, restore the percentage backed up; B, back up
    the one in effect before this line; S, the new percentage, or None). As Marlin reads them:
    R first, then B, then S; S is read as a whole number (``strtol``: ``S75.9`` is 75), a
    letter's presence is enough for R and B. The percentage scales the feed of every G0, G1,
    G2, G3 and G5 that follows (motion.h ``MMS_SCALED``), not homing."""
    code, head = _command(raw)
    words = {m.group(1).upper(): m.group(2) for m in _PARAMETER.finditer(code[head.end() :])}
    s = words.get("S")
    whole = None if s is None else _WHOLE.match(s)
    percent = None if whole is None else int(whole.group().rstrip("+-") or 0)
    return "R" in words, "B" in words, percent


#: A line Marlin answers with "Unknown command" (GCodeParser::parse: after spaces and a line
#: number, a command letter G, M or T and its digits): one that opens with no letter (a stray
#: number, a block delete ``/`` or a ``#``, which Marlin has not, or a tab: its reader skips
#: spaces only), with a letter that is no command (an O-word, LinuxCNC's ``o100 sub`` or a
#: program number ``O1001``, whose lines between then run; ``S100``), with a word (a Klipper
#: macro such as ``KLIPPER_MACRO``), with ``%`` and text, with a G, M or T and no digits after
#: its spaces (a slicer's unfilled ``T[next_extruder]``, ``G{x}``, ``T-1``), with an N and
#: no digit or sign right after it (``N 5 G1``), or with a second line number. Lines that
#: open with a parameter a modal motion may take (:data:`_BARE_WORDS`, checked first: ``X10
#: Y5``, ``P5``, ``PRINT_START``) are the interpreter's to run or skip by the motion in
#: effect, and a lone ``%`` is read on. The line number is taken whole (an atomic group):
#: ``N10 G1`` is not ``N1`` and a stray ``0``.
_NOT_A_COMMAND = re.compile(
    r"^ *[Nn]\d+ *[Nn]|"  # a second line number: its letter N is no command
    r"^ *(?>[Nn]\d+ *)?"
    r"(?:[^GMTNXYZEFgmtnxyzef( %]|%.*\S|[A-Za-z][A-Za-z_]|[GgMmTt] *+(?![0-9])|[Nn](?![-+0-9]))"
)
#: A line that opens with a parameter letter a modal motion may take (X, Y, Z, E, F, and I,
#: J, P, Q, R): GCODE_MOTION_MODES runs it as the modal motion where that motion takes its
#: opener (:data:`MARLIN_BARE_OPENERS`; Marlin's default build answers "Unknown command")
_BARE_WORDS = re.compile(r"^ *(?>N\d+ *)?([XYZEFIJPQRxyzefijpqr])")
#: A G0 or G1 after a G53 (parser.cpp chains it); any other command after G53 runs nothing
_G53_CHAINED_MOVE = re.compile(r"G\s*0*[01](?:\.0*)?(?![0-9.])", re.IGNORECASE)
#: Any word (a letter and a value).
_WORD = re.compile(r"[A-Z]\s*[-+]?[.\d]", re.IGNORECASE)
#: An M or T word after a G command: a parameter to Marlin, which that command ignores.
_PARAMETER_GMT = re.compile(r"[GMT]\s*[-+]?(?:\d+\.?\d*|\.\d+)", re.IGNORECASE)


#: A ( ) comment, kept as it is, or a G, M or T word outside one.
_COMMENT_OR_GMT = re.compile(r"\([^)]*\)?|" + _PARAMETER_GMT.pattern, re.IGNORECASE)


def without_marlin_parameters(raw: str) -> str:
    """A G line without the G, M and T words after its command (see :func:`marlin_line`'s
    "parameters"), each replaced by an empty comment (a word boundary: ``F100 M3.5.5`` must not
    become ``F100.5``); comments are kept as they are."""
    code, sep, comment = raw.partition(";")
    head = _HEAD.match(code)
    start = head.end() if head is not None else 0
    rest = _COMMENT_OR_GMT.sub(
        lambda m: m.group() if m.group().startswith("(") else "()", code[start:]
    )
    return code[:start] + rest + sep + comment


_G2CORE_QUIET = re.compile(r"^\s*(?:N\d+\s*)?M\s*0*10[01](?:\.\d)?(?!\d)", re.IGNORECASE)
_G2CORE_HOMING = re.compile(r"^\s*(?:N\d+\s*)?G\s*0*28\s*\.\s*[24](?!\d)", re.IGNORECASE)


_G2CORE_SET_ORIGIN = re.compile(r"^(\s*(?:N\d+\s*)?)G\s*0*28\s*\.\s*3(?!\d)", re.IGNORECASE)


#: g2core's single-character controls run through here: cycle start, enquiry (module
#: docstring; a feedhold, ``!``, is refused)
G2CORE_CONTROLS = "~\x05"
_FEEDHOLD = (
    "'!' is g2core's feedhold: it acts when the controller receives it, ahead of the moves "
    "queued before it, and holds until the operator's cycle start ('~'), so where the machine "
    "stops depends on the sender's timing; remove it to simulate the program"
)


def g2core_line(raw: str) -> str | None:
    """ "quiet" for a g2core JSON or text-mode line, M100/M101, or a control after blanks;
    "controls" for a line opening with single-character controls (:func:`after_controls`);
    "json_gcode" for a JSON line of G-code, ``{"gc":"g1x10f300"}`` (:func:`g2core_json_gcode`);
    "active_json" for a line that is one ``({...})`` comment (:func:`g2core_active_json`);
    "set_origin" for G28.3; "homing" for G28.2/G28.4 (:func:`homing_end`); "characters" for a
    G-code line holding a character g2core drops
    (:func:`g2core_characters`); None otherwise."""
    if raw.lstrip(" \t" + G2CORE_CONTROLS)[:1] == "!":
        raise GcodeError(_FEEDHOLD)
    if raw[:1] and raw[0] in G2CORE_CONTROLS:
        return "controls"
    if _G2CORE_GC.match(raw):
        return "json_gcode"
    if _G2CORE_ACTIVE_JSON.match(raw):
        return "active_json"
    if _G2CORE_SET_ORIGIN.match(raw):
        return "set_origin"
    if _G2CORE_HOMING.match(raw):
        return "homing"
    head = raw.lstrip(" \t")[:1]
    if (head and head in "{?$Hh" + G2CORE_CONTROLS) or _G2CORE_QUIET.match(raw):
        return "quiet"
    words = _PAREN.sub("", raw)
    if _G2CORE_DROPPED.search(words) or _G2CORE_NO_DIGITS.search(words):
        return "characters"
    return None


#: What g2core's _normalize_gcode_block (gcode_parser.cpp) copies of a G-code line outside
#: its comments: letters, digits, "-" and "."; blanks end a word; anything else is dropped
#: (a "+", a "#", a U+2028 LINE SEPARATOR some editors leave in a file).
_G2CORE_DROPPED = re.compile(r"[^A-Za-z0-9.\- \t\r\n\f\v()]")  # isspace() of C: ASCII
#: A value of a sign or a point and no digit (``X-``, ``X.``, blanks dropped as g2core drops
#: them): c_atof (util.h) reads it as 0 where it ends before the next letter
_G2CORE_NO_DIGITS = re.compile(r"(?<=[A-Za-z])[ \t]*(?:-[ \t]*\.?|\.)(?=[ \t]*(?:[A-Za-z(]|$))")
_G2CORE_COMMENT_OR_DROPPED = re.compile(
    r"\([^)]*\)?|" + _G2CORE_DROPPED.pattern + "|" + _G2CORE_NO_DIGITS.pattern
)


def g2core_characters(raw: str) -> str:
    """A "characters" line (:func:`g2core_line`; its comments closed by
    lexer.firmware_comments) as g2core parses it: the characters its normalizer drops left out
    (``X+5`` is X5), a value with no digit read as 0 (``X-`` and ``X.`` are X0: c_atof), its
    comments kept."""
    return _G2CORE_COMMENT_OR_DROPPED.sub(_g2core_kept, raw)


def _g2core_kept(m: re.Match[str]) -> str:
    text = m.group()
    if text[0] == "(":
        return text
    return "" if _G2CORE_DROPPED.fullmatch(text) else "0"  # a dropped character, or X-


#: One pair of a flat JSON object: a key (quoted, or bare as g2core's relaxed JSON allows) and a
#: string, number, true, false or null
_JSON_PAIR = r'\s*"?\w+"?\s*:\s*(?:"(?:[^"\\]|\\.)*"|[^,"{}]*?)\s*'
#: A JSON line of G-code: the ``gc`` key and a string, which g2core runs as a G-code line
#: (config_app.cpp ``gc``: gc_run_gc), among other pairs json_parser runs in order (status
#: requests and settings: nothing modelled)
_G2CORE_GC = re.compile(
    rf'\s*\{{(?:{_JSON_PAIR},)*?\s*"?gc"?\s*:\s*"((?:[^"\\]|\\.)*)"\s*(?:,{_JSON_PAIR})*\}}\s*$',
    re.IGNORECASE,
)


def g2core_json_gcode(raw: str) -> str:
    """A "json_gcode" line (:func:`g2core_line`): its G-code string, unescaped."""
    found = _G2CORE_GC.match(raw)
    assert found is not None  # g2core_line matched it
    return re.sub(r"\\(.)", r"\1", found.group(1))


#: A line that is one active comment of JSON, ``({gc:"g0x10"})``: g2core's normalizer keeps a
#: comment opening ``({`` as the block's active comment, and a block with no G-code besides
#: passes it to json_parser (gcode_parser.cpp ``gcode_parser``)
_G2CORE_ACTIVE_JSON = re.compile(r"^[ \t]*\((\{.*?)\)?[ \t]*$")


def g2core_active_json(raw: str) -> str:
    """An "active_json" line (:func:`g2core_line`): its JSON, run as a JSON line."""
    found = _G2CORE_ACTIVE_JSON.match(raw)
    assert found is not None  # g2core_line matched it
    return found.group(1)


def after_controls(raw: str) -> str:
    """A "controls" line (:func:`g2core_line`) less the controls that open it: the line g2core
    reads after them."""
    return raw.lstrip(G2CORE_CONTROLS)


def homing_end(raw: str) -> str:
    """A g2core G28.2/G28.4 line (homing, no motion modelled) as the state it leaves: motion
    cancelled (cycle_homing.cpp ``_homing_finalize_exit``), a G80."""
    return "G80"


def as_g92(raw: str) -> str:
    """A g2core G28.3 line written as the G92 it runs as (:func:`g2core_line`)."""
    return _G2CORE_SET_ORIGIN.sub(lambda m: m.group(1) + "G92", raw, count=1)


class MarlinLines:
    """:func:`marlin_line` with the one state it needs: whether a G60 has saved a position.
    A G61 before any G60 does nothing, as Marlin's G61 returns when its slot holds no saved
    position (gcode/feature/pause/G61.cpp); CAM posts write LinuxCNC's G61 (exact path) into
    laser and printer files. After a G60 it would move there: refused, as before."""

    def __init__(self) -> None:
        self.saved = False

    def __call__(self, raw: str) -> str | None:
        kind = marlin_line(raw)
        if kind == "save":
            self.saved = True
        elif kind == "restore" and self.saved:
            raise GcodeError("G61 (return to a saved position) is not supported (Marlin G61)")
        return "quiet" if kind in ("save", "restore") else kind


def _g2core_lines() -> Callable[[str], str | None]:
    return g2core_line


#: each dialect's own line reader, made afresh for every program (Marlin's holds G60's state)
OWN_LINES: dict[str, Callable[[], Callable[[str], str | None]]] = {
    "marlin": MarlinLines,
    "g2core": _g2core_lines,
}


_DWELL_WORD = re.compile(r"([PS])\s*([0-9]*\.?[0-9]+)", re.IGNORECASE)


def marlin_dwell_seconds(raw: str) -> float:
    """Marlin G4: P in milliseconds, S in seconds (S wins when both are given), else 0."""
    body = raw.split(";", 1)[0]
    body = body[body.upper().find("G") :]
    words = {k.upper(): float(v) for k, v in _DWELL_WORD.findall(body[2:])}
    if "S" in words:
        return words["S"]
    return words.get("P", 0.0) / 1000.0
