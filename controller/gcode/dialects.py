"""The four G-code dialects' rules, as data.

The interpreter reads these fields and never tests a dialect's name. Sources (copied facts):

- ``linuxcnc``: LinuxCNC 2.9's rs274 interpreter, measured with ``rs274 -g`` (Debian
  linuxcnc-uspace 2.9.0~pre1): centre-format arcs are refused when
  ``|r_end - r_start| > 100 * tol`` or (``> tol`` and ``> 0.1 %`` of the larger radius), with
  tol = 0.028284 mm in G21 and 0.0028284 inch in G20 (the inch value is NOT the mm value
  converted: 0.0028284 in = 0.0718 mm); a radius below 0.00127 mm (0.00005 in) is a zero-radius
  arc; an R arc may fall short of the end by that same amount (it becomes the exact semicircle);
  P must be within 0.001 of an integer and >= 1; the program must end with M2/M30 or ``%``.
- ``g2core``: g2core's G2/G3 page (seed 000, the dialect's specification): an explicit end point
  equal to the start moves nothing (a full circle needs the plane axes omitted; the firmware's
  plan_arc.cpp turns a G2 so into a full circle and refuses a G3); radius mismatch refused
  above .5 mm (.05 inch), or above .005 mm (.0005 inch) and 0.1 % of the radius, as the page
  says (the firmware's plan_arc.h: ARC_RADIUS_ERROR_MAX 1.0 mm, in mm whatever the units).
  Where the page is silent the dialect follows the firmware (synthetos/g2 edge-preview
  1fb59404: gcode_parser.cpp, canonical_machine.cpp, plan_arc.cpp).
- ``marlin``: Marlin's G2/G3 page (segments of MM_PER_ARC_SEGMENT = 1 mm, the dialect's
  segmentation default): the end point is not checked, the arc ends on the start-radius
  circle at the destination's angle and the move at the destination (plan_arc's last segment
  goes to the target: a straight move is added, or the arc is a spiral when the end is within
  ``arc_block.MARLIN_SPIRAL_MM`` of the circle); ``R`` with ``I``/``J`` is an error; F is
  modal with Marlin's default feed 1500 mm/min (feedrate_mm_s = 25 mm/s); P (ARC_P_CIRCLES)
  adds P complete circles; E (extrusion) words move no axis here, but tell which moves extrude
  (controller/gcode/extruder.py), and S (laser power) is ignored; an R too short for the chord
  gives the semicircle (Marlin clamps the centre offset to zero).
- ``grbl``: grbl 1.1's gcode.c (gnea/grbl): its G and M codes only (G38.x probing is refused
  here), no parameters, expressions or O-words, ``$`` system lines (``$J=`` jogs move as
  G1 in their own modes), six coordinate systems, G10 L2/L20 without R, G28/G30 send every axis
  home, no program end needed; an offset arc is refused when its radii differ by more than
  0.005 mm and (more than 0.5 mm or 0.1 % of the radius), always in mm; an R arc must reach its
  end exactly; a K word on a G17 arc (any offset off the plane) is consumed and ignored; P is
  not an arc word; default arc tolerance $12 = 0.002 mm. Errors carry grbl's numbered codes.
  Checked against grbl 1.1h itself (gcode.c and motion_control.c built for the host, lines fed
  to gc_execute_line): F in the line's own units, a near-zero arc travel (5e-7 rad) is a full
  circle, G53 ignores G91, G10's P is truncated, an N word may stand anywhere on a line (up to
  10,000,000), and the first offending word names the error.
- ``laserdyne``: Prima Power Laserdyne's note: both centre offsets of the plane are required,
  the end point must lie on the arc (checked here to 0.005 mm, a documented choice: 0.0002 in,
  twice the rounding of a 4-decimal inch program), G20 means plane rotation and is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import GcodeError


@dataclass(frozen=True)
class RadiusCheck:
    """When the end point's radius may differ from the start's (centre-format arcs).

    Refuse when ``abs_err > abs_max`` or (``abs_err > abs_tol`` and ``abs_err / r > rel_tol``),
    r the larger of the two radii (``rel_to_start``: the start's radius, as grbl's gcode.c
    takes it). Lengths are in the program's units at the time: ``*_mm`` in G21, ``*_in`` in
    G20 [inch].
    """

    abs_tol_mm: float
    abs_max_mm: float
    abs_tol_in: float
    abs_max_in: float
    rel_tol: float
    rel_to_start: bool = False


@dataclass(frozen=True)
class Dialect:
    """One controller's reading of G2/G3 and its neighbours.

    Attributes:
        name: the ``--dialect`` value.
        explicit_end_full_circle: an arc whose programmed end equals its start is a full circle
            (False: it moves nothing, g2core).
        radius_check: centre-format end point tolerance, or None for no check.
        project_end_on_arc: the arc ends on the start-radius circle at the destination's angle
            (Marlin), and a straight move on to the destination (a spiral there when the end
            is within ``arc_block.MARLIN_SPIRAL_MM`` of the circle).
        end_on_start_circle: a centre-format arc whose end passes ``radius_check`` off the
            start circle ends on that circle at the end's angle, and the next move starts from
            there towards its own end point, the programmed end being where the program is
            (g2core: plan_arc.cpp ``cm_arc_callback`` puts every segment's end, the last one
            too, on the start radius, while the model takes the programmed end; the planner's
            next move starts where the last segment ended, plan_line.cpp ``mp_aline``).
        both_offsets_required: IJK arcs need both in-plane offsets even in G91.1 (Laserdyne).
        p_adds_circles: P counts extra full circles (Marlin) instead of total turns (LinuxCNC).
        default_feed_mm_per_min: feed before any F word, or None when F is required.
        g20_is_inch: G20 selects inches; False: G20 is something else and is refused.
        g20_refusal: the message for G20 when ``g20_is_inch`` is False.
        unused_words_ignored: these letters are ignored on a line where no code uses them
            (g2core: gcode_parser.cpp stores every word in ``gv`` and only the codes that need
            one read it: ``G1 X10 I5``, ``G0 X10 P5`` move); other letters: an error (rs274).
        ignored_letters: words accepted that move no axis and set nothing of the shared state
            (Marlin's E, which its extruder reads, S, and the axis letters its default build
            lacks: A B C U V W).
        min_radius_mm / min_radius_in: smaller radii are zero-radius arcs; also how far an R
            arc may fall short of reaching its end point [mm / inch].
        r_short_is_semicircle: an R too small to reach the end always gives the semicircle.
        r_short_checked_as_centre: an R too small to reach the end gives the semicircle when
            half the chord passes ``radius_check`` against R (g2core: plan_arc.cpp
            ``_compute_arc_offsets_from_radius`` puts the centre at the chord's middle when
            its discriminant is negative, then ``_compute_arc`` checks the radii).
        r_wins_over_offsets: an R arc's I, J, K words are ignored (g2core: plan_arc.cpp reads
            the offsets only without R); False: R mixed with I/J/K is an error (rs274).
        require_program_end: the text must end with M2/M30 or a closing ``%`` (rs274).
        r_needs_arc_code_first: R is an arc radius only after G2/G3 on the same line
            (Laserdyne: otherwise R means "Repeat", which is refused).
        max_p: the largest P word allowed, or None (Marlin: 100, ``WITHIN(circles_to_do, 0, 100)``).
        zero_angle_fuzz: a swept angle up to this [rad] is a full circle more (end == start up
            to rounding; a 1e-6 rad arc of R10000 is an arc, as rs274 outputs it; grbl's
            ARC_ANGULAR_TRAVEL_EPSILON, 5e-7 rad, makes ``G3 X100 Y0.00004 I-100`` from X100 Y0
            a full circle and 4e-7 rad more).
        language: numbered/named parameters, [expressions] and O-words are part of the dialect.
        g_codes / m_codes: the codes (G in tenths) the controller knows; None: LinuxCNC's.
        g_point_codes: the whole G codes (tenths) whose decimal part the controller reads; any
            other G word is read as its whole number (g2core: ``switch ((uint8_t)value)`` in
            gcode_parser.cpp, ``_point`` consulted for G28, G30, G38, G43, G61, G90, G91 and
            G92 only: G59.1 is G59, G1.5 G1, G17.1 G17); None: every decimal part counts.
        one_sign: a number takes one sign at most (g2core's c_atof reads one, and the word
            after it is malformed: ``X--5`` is refused, nothing of the line runs); a dialect
            without the language always checks this (grbl).
        m_whole_codes: M codes are read by their whole part (g2core's ``switch ((uint8_t)value)``:
            M3.5 is M3), except M50, whose .1 (traverse override control, not modelled) is
            accepted and does nothing and whose other decimals are refused; False: an M code
            is a whole number (rs274's read_integer_value).
        letters: the word letters the controller knows; None: LinuxCNC's.
        system_lines: ``$`` lines are system commands (grbl); ``$J=`` is a jog.
        home_all_axes: G28/G30 send every axis home, axis words only add a first move (g2core's
            _goto_stored_position); False: with axis words only the named axes go home (rs274,
            and grbl 1.1's gcode.c: "Move only the axes specified in secondary move").
        home_first_move: G28/G30 always make their first move, to the axis words' point, even
            with none (a move of length 0: rs274); False: only with axis words (grbl, g2core).
        arc_p_allowed: P (turns) is an arc word.
        off_plane_offset_ignored: an offset word of the plane's normal axis on an arc is
            consumed and ignored (grbl) instead of an error.
        arc_needs_plane_axis_word: every G2/G3 needs an axis word of its plane, in either
            format (grbl: no full circle from the offsets alone).
        initial_motion: the motion mode (tenths) at program start, which axis words alone
            continue; None: none until the program sets one (rs274 refuses them). grbl: G0
            (gc_init zeroes the parser state, and MOTION_MODE_SEEK is 0).
        realtime_characters: the serial layer takes ``?``, ``~``, ``!``, ctrl-X and every byte
            above 0x7F out of the stream before a line is parsed (grbl's realtime commands:
            status, cycle start, feed hold, reset, and the extended-ASCII overrides), so they
            may stand anywhere in a line.
        checksums: whose rule ends a line at a ``*`` (a host's checksum, ``N12 G1 X5*97``):
            ``"marlin"``, its first ``*`` outside a comment (GCodeParser::parse; lexer.py
            ``without_checksum``); ``"g2core"``, its first ``*`` anywhere, the checksum checked
            (gcode_parser.cpp ``_verify_checksum``, before the line is normalized; lexer.py
            ``g2core_checksum``); ``""``: none.
        g10_rotation: G10 L2 takes R (the XY rotation).
        g10_g2core: G10 L2/L20 as g2core's cm_set_g10_data runs them: R ignored (no rotation),
            and L20 leaves the G92 offset out of the point it makes read the words.
        g10_levels: the G10 L numbers the controller has; None: LinuxCNC's (1, 2, 10, 11, 20).
        g10_p0_current: G10 L2/L20 P0 is the system in effect (rs274); False: P0 (or no P) is
            refused (g2core's cm_set_g10_data: "you can't set G53").
        coordinate_systems: how many of G54..G59.3 exist (grbl: 6).
        error_codes: (message fragment, firmware error number) pairs; the first match is
            appended to a message as ``(grbl error N)``.
        arc_tolerance_mm: the controller's default arc segmentation tolerance [mm], or None.
        arc_segment_mm: the controller's fixed arc segment length [mm], or None.
        own_lines: the controller's own line rules in controller/gcode/printer_codes.py
            ("marlin": M/T lines and printer G codes; "g2core": JSON lines, G28.2/G28.3), or "".
        canned_cycles: G73, G74, G81-G89 (and G98/G99) run as LinuxCNC runs them
            (controller/gcode/canned_cycles.py); False: refused, the firmware has none.
        cutter_comp: G41/G42/G41.1/G42.1 run as LinuxCNC runs them (controller/gcode/
            cutter_comp.py); False: refused (G40 is accepted everywhere).
        g0_at_feed: G0 is a G1 (the modal feed, joined to its neighbours like any move), as
            Marlin runs it in a printer build (its G0_G1 command; only laser and CNC builds
            move G0 at the axes' top speed).
        integer_words: letters read as whole numbers as rs274's read_integer_value reads them
            (within 0.0001 of one; else an error), not rounded.
        splines: "linuxcnc": G5, G5.1, G5.2/G5.3 run as LinuxCNC runs them; "marlin": G5 alone,
            as Marlin's BEZIER_CURVE_SUPPORT runs it (controller/gcode/splines.py); "": refused,
            the firmware has none.
        last_word_wins: a letter given twice on a line, or two G (M) codes of one modal group,
            take the last one (g2core's parser stores each word as it reads it and checks
            neither); False: an error (rs274, grbl's error 25).
        abort_comments: a line whose comment starts ``(abort,`` stops the program there with
            that message, its parameters filled in (rs274's convert_comment).
        extruder: E words are followed as Marlin's extruder axis (M82/M83, G90/G91, G92 E):
            each move tells whether it extrudes (controller/gcode/extruder.py).
        firmware_comments: whose line reader takes the comments (controller/gcode/lexer.py
            ``firmware_comments``): ``"grbl"`` and ``"g2core"`` end a comment left open at the
            line's end and take a ``(`` inside one as text; g2core also ends a line at ``%``
            and skips a line opening with ``/``; ``"marlin"`` nests them, a comment left open
            running to the line's end; ``""``: rs274's reader (both are errors).
        percent_delimits: a ``%`` line opens and ends the program (rs274); False: a ``%`` line
            is nothing (grbl answers it with error 1 and goes on, and the senders that stream
            CAM files drop it; g2core reads it as a comment; Marlin: "Unknown command").
        motion_waits: whose rules say which machine commands the controller runs with motion
            stopped (spindle, coolant, offsets, outputs), each an exact stop before its block
            ("linuxcnc", "grbl", "g2core"; "": none modelled; controller/gcode/
            motion_waits.py).
        feed_mode_clears_feed: whose rule sets the feed to 0 at a feed mode word, before the
            line's F is read: ``"linuxcnc"``, every G94 and G95 (rs274's convert_feed_mode,
            even in the mode already in effect); ``"grbl"``, G94 after G93 (the feed is
            undefined after leaving inverse time); ``"g2core"``, G94 after G93 as grbl, and G93
            after G94 (g2core would read the old feed number as minutes; refused here until a
            G93 F is given); ``""``: the feed is kept.
        g93_f_stands: in G93 a block without F runs with the last F given in G93 (g2core: each
            block started in G93 takes F 0, which ``cm_set_feed_rate`` refuses without changing
            the feed, and that status is overwritten by the move's); False: every G93 feed move
            needs its own F (rs274).
        min_r_word_mm: an R word (radius-format arc) below this [mm, whatever the units] is
            refused (g2core's MIN_ARC_RADIUS); 0: none.
        permissive_blocks: blocks rs274 refuses that g2core's parser lets through run as it runs
            them (gcode_parser.cpp, canonical_machine.cpp, plan_arc.cpp): a G92/G10/G28/G30
            beside G0-G3 takes the axis words (``next_action_stops_motion``: the motion code
            sets nothing); axis words with no motion mode (g2core starts with motion
            cancelled) move nothing; a G92 with no axis word turns the G92 offsets back on
            (cm_set_g92_offsets: as G92.3). Axis words continuing a modal G2/G3 with no centre
            offset or radius are refused: g2core alarms (plan_arc.cpp ``cm_arc_feed`` reads
            gp.modals[], which its parser never clears, and reaches "arc offsets missing").
        next_action_stops_motion: a block holding a code g2core runs as its "next action" (G4,
            G10, G28, G28.1, G30, G30.1, G43, G43.2, G49, G92-G92.3) makes no G0-G3 motion and
            stores no motion mode: gcode_parser.cpp ``_execute_gcode_block`` runs the motion
            only for NEXT_ACTION_DEFAULT (``G0 G43 Z15 H1`` lifts nothing, ``G92 G0 X0``
            leaves the mode before it; G28/G30 still make their own moves).
        feed_in_line_units: F is read in the units this line selects (grbl's gcode.c converts
            F after taking the line's G20/G21: ``G20 G1 X1 F10`` is 254 mm/min); False: in the
            units in effect before the line (rs274: that line's F is 10 mm/min).
        jog_units_per_minute: a ``$J=`` jog's F is units per minute even under G93 (grbl).
        g10_p_truncated: G10's P is cut to its whole part (``P1.5`` is G54) and is 0, the
            system in effect, when absent (grbl's gcode.c); False: rs274's reading.
        program_end_continues: whose M2/M30 reset some modes, the program going on with the
            next line (controller/gcode/modal_codes.py): ``"grbl"``, grbl 1.1's (its senders
            stream every line of a file; gcode.c step 21); ``"g2core"``, g2core's
            (canonical_machine.cpp ``_exec_program_stop_end``: nothing stops its reading, and
            its own sender, node-g2core-api, streams every line); ``""``: M2/M30 end the
            program (rs274).
        g93_min_rate: the least rate of a move in G93 [program units per minute] (rs274's
            inverse_time_rate_straight and _arc: 0.1, so a move of no length or a very short
            one runs at 0.1 a minute); 0: F times the move's length.
        rs274_code_numbers: G and M numbers are read as rs274's read_g and read_integer_value
            read them: a G within 0.001 of a tenth (ten times its value: G0.0001 is G0, G0.0002
            out of range), an M within 0.0001 of a whole number (M5.0001 is M5); False: exact.
        g92_resets_apart: G92.1, G92.2 and G92.3 are a modal group of their own, run after
            group 0's codes on the same line (rs274 2.9: ``G10 L2 P1 X1 G92.1`` runs both, and
            ``G92 X3 G92.1`` ends with no offset); False: they are group 0's.
        tool_length_axis_codes: the tool-length codes (tenths) that take the line's axis words,
            which then move nothing: G43.1 (its offset); grbl's G49 too (gcode.c consumes them
            with AXIS_COMMAND_TOOL_LENGTH_OFFSET).
        strict_g80: no axis word while G80 (motion off) is in effect, not even for G10, G28,
            G30, G92 or G43.1 (grbl's "strict" G80 error 31); False: those take their words.
        read_order: whose order of checks names a line's first error (``"grbl"``: gcode.c's,
            its reading loop's word by word (controller/gcode/dialect_checks.py), then a G53's
            motion mode before the G80 axis-word error, and words no code uses last, after the
            block's motion; a centre word alone is such a word, not a modal arc's); ``""``:
            rs274's.
        g53_g2core: G53 as g2core's absolute override (canonical_machine.cpp
            ``cm_get_combined_offset`` returns 0 under it): with any motion (an arc's end in
            machine coordinates) or none, and in G91 the words are increments as ever.
        g53_absolute_in_g91: G53's axis words are machine coordinates in G91 too (grbl's
            gcode.c applies no distance mode under G53); False: G53 in G91 is refused (rs274).
        zero_radius_straight: a centre-format arc whose centre is its start (I and J 0), with its
            end within the radius check of the centre, is one straight feed move to the end
            (grbl 1.1: gcode.c sets no least radius, and mc_arc cuts a radius of 0 into no
            segment, so its closing mc_line goes straight there); False: refused as a
            zero-radius arc.
        max_tool_number: the largest tool number of T, H and G10 L1/L10 P (g2core: its
            tool table's TOOLS, 32: cm_select_tool, cm_set_tl_offset and cm_set_g10_data
            refuse more); None: rs274's C int (words.MAX_TOOL_NUMBER).
        bad_arc_moves_nothing: a G2/G3 with no centre (no offset and no R, an R of 0, both
            offsets 0, or an R whose end is its start) moves nothing and the program goes on,
            its F kept (Marlin: G2_G3.cpp plans only ``if (arc_offset)``, else answers "G2/G3
            bad parameters"); else it is an error.
        g93_arc_per_segment: a G93 arc runs at its F times the segments it is cut into at
            ``arc_tolerance_mm`` [mm/min] (grbl 1.1's mc_arc: :func:`~gantry_sim.controller.
            gcode.feed_modes.grbl_inverse_time_arc`); False: at F times its length (rs274).
        positive_feed_only: an F of 0 or less is passed over and the feed in effect kept
            (Marlin's get_destination_from_command reads F only when it is above 0); False:
            F0 sets a feed of 0, which no feed move takes, and a negative F is an error
            (rs274).
        line_limit: whose longest line applies (controller/gcode/lexer.py ``line_too_long``:
            ``"linuxcnc"`` 252 characters, ``"grbl"`` 79 kept in its line buffer; ``"g2core"``:
            a line is cut to its first 511 characters, as xio.cpp's readline passes them on);
            ``""``: none.
        line_number_words: N is a word read anywhere on the line, as grbl's gcode.c and
            g2core's parser read it (a number, truncated; a second N is a repeated word); False:
            an N line number may only open the line (rs274).
        o_words: O-words (program numbers, subroutines, control flow) are read (rs274); False:
            an O is refused where it stands, as a letter the controller does not support
            (grbl's error 20, g2core's STAT_GCODE_COMMAND_UNSUPPORTED).
    """

    name: str
    explicit_end_full_circle: bool
    radius_check: RadiusCheck | None
    project_end_on_arc: bool
    both_offsets_required: bool
    p_adds_circles: bool
    default_feed_mm_per_min: float | None
    g20_is_inch: bool
    g20_refusal: str
    ignored_letters: frozenset[str]
    min_radius_mm: float
    min_radius_in: float
    r_short_is_semicircle: bool
    require_program_end: bool
    max_p: int | None = None
    r_short_checked_as_centre: bool = False
    r_wins_over_offsets: bool = False
    end_on_start_circle: bool = False
    unused_words_ignored: frozenset[str] = frozenset()
    r_needs_arc_code_first: bool = False
    zero_angle_fuzz: float = 1e-12
    language: bool = True
    g_codes: frozenset[int] | None = None
    m_codes: frozenset[int] | None = None
    g_point_codes: frozenset[int] | None = None
    m_whole_codes: bool = False
    one_sign: bool = False
    letters: frozenset[str] | None = None
    system_lines: bool = False
    home_all_axes: bool = False
    home_first_move: bool = True
    arc_p_allowed: bool = True
    off_plane_offset_ignored: bool = False
    arc_needs_plane_axis_word: bool = False
    initial_motion: int | None = None
    realtime_characters: bool = False
    checksums: str = ""
    g10_rotation: bool = True
    g10_levels: frozenset[int] | None = None
    g10_g2core: bool = False
    g10_p0_current: bool = True
    coordinate_systems: int = 9
    error_codes: tuple[tuple[str, int], ...] = ()
    arc_tolerance_mm: float | None = None
    arc_segment_mm: float | None = None
    own_lines: str = ""
    canned_cycles: bool = False
    cutter_comp: bool = False
    splines: str = ""
    integer_words: frozenset[str] = frozenset()
    g0_at_feed: bool = False
    last_word_wins: bool = False
    abort_comments: bool = False
    extruder: bool = False
    firmware_comments: str = ""
    percent_delimits: bool = True
    motion_waits: str = ""
    feed_mode_clears_feed: str = ""
    g93_f_stands: bool = False
    line_limit: str = ""
    feed_in_line_units: bool = False
    jog_units_per_minute: bool = False
    g53_absolute_in_g91: bool = False
    g53_g2core: bool = False
    read_order: str = ""
    program_end_continues: str = ""
    strict_g80: bool = False
    tool_length_axis_codes: frozenset[int] = frozenset({431})
    g92_resets_apart: bool = False
    rs274_code_numbers: bool = False
    g93_min_rate: float = 0.0
    positive_feed_only: bool = False
    g93_arc_per_segment: bool = False
    zero_radius_straight: bool = False
    bad_arc_moves_nothing: bool = False
    max_tool_number: int | None = None
    g10_p_truncated: bool = False
    permissive_blocks: bool = False
    next_action_stops_motion: bool = False
    min_r_word_mm: float = 0.0
    line_number_words: bool = False
    o_words: bool = True


_TOL_MM = 2 * 0.01 * math.sqrt(2.0)  # 0.028284 mm, rs274 CENTER_ARC_RADIUS_TOLERANCE_MM
_TOL_IN = 2 * 0.001 * math.sqrt(2.0)  # 0.0028284 in, rs274 CENTER_ARC_RADIUS_TOLERANCE_INCH

LINUXCNC = Dialect(
    name="linuxcnc",
    g92_resets_apart=True,
    rs274_code_numbers=True,
    g93_min_rate=0.1,
    explicit_end_full_circle=True,
    radius_check=RadiusCheck(_TOL_MM, 100 * _TOL_MM, _TOL_IN, 100 * _TOL_IN, 0.001),
    project_end_on_arc=False,
    both_offsets_required=False,
    p_adds_circles=False,
    default_feed_mm_per_min=None,
    g20_is_inch=True,
    g20_refusal="",
    ignored_letters=frozenset(),
    min_radius_mm=0.00127,
    min_radius_in=0.00005,
    r_short_is_semicircle=False,
    require_program_end=True,
    integer_words=frozenset("HLT"),
    canned_cycles=True,
    cutter_comp=True,
    splines="linuxcnc",
    motion_waits="linuxcnc",
    feed_mode_clears_feed="linuxcnc",
    line_limit="linuxcnc",
    abort_comments=True,
)

# fmt: off
#: g2core's codes (gcode_parser.cpp _parse_gcode_block, tenths; G28.2-G28.4 and M100/M101 are
#: its own lines, printer_codes.py; G38.x are refused where they are read)
_G2CORE_G = frozenset((
    0, 10, 20, 30, 40, 100, 170, 180, 190, 200, 210, 280, 281, 282, 283, 284, 300, 301, 382,
    383, 384, 385, 400, 430, 432, 490, 530, 540, 550, 560, 570, 580, 590, 610, 611, 640, 800,
    900, 901, 910, 911, 920, 921, 922, 923, 930, 940,
    # refused where they are read, saying what g2core lacks: canned cycles, cutter
    # compensation, splines
    730, 740, 810, 820, 830, 840, 850, 860, 870, 880, 890, 410, 411, 420, 421, 50, 51, 52, 53,
))
_G2CORE_M = frozenset((0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 30, 48, 49, 50, 51, 60))
# fmt: on
G2CORE = Dialect(
    name="g2core",
    explicit_end_full_circle=False,
    # seed 000: more than .5 mm (.05 inch), or .005 mm (.0005 inch) and 0.1 % of the radius
    # (the firmware's plan_arc.h ARC_RADIUS_ERROR_MAX is 1.0 mm, in mm whatever the units)
    radius_check=RadiusCheck(0.005, 0.5, 0.0005, 0.05, 0.001),
    project_end_on_arc=False,
    both_offsets_required=False,
    p_adds_circles=False,
    default_feed_mm_per_min=None,
    g20_is_inch=True,
    g20_refusal="",
    ignored_letters=frozenset(),
    min_radius_mm=0.00127,
    min_radius_in=0.00005,
    r_short_is_semicircle=False,
    require_program_end=False,
    system_lines=True,
    line_number_words=True,
    o_words=False,
    own_lines="g2core",
    last_word_wins=True,
    home_all_axes=True,
    home_first_move=False,
    permissive_blocks=True,
    next_action_stops_motion=True,
    firmware_comments="g2core",
    percent_delimits=False,
    # a block started in G93 takes F 0 unless it gives one (gcode_parser.cpp): the G94 after
    # G93 leaves no feed; in G93 that F 0 is refused and the last F stands
    feed_mode_clears_feed="g2core",
    g93_f_stands=True,
    motion_waits="g2core",  # every queued command (mp_queue_command) stops the planner
    arc_tolerance_mm=0.01,  # settings_default.h CHORDAL_TOLERANCE ($ct)
    line_limit="g2core",
    g53_g2core=True,
    min_r_word_mm=0.1,  # plan_arc.h MIN_ARC_RADIUS
    r_wins_over_offsets=True,
    unused_words_ignored=frozenset("HIJKLPR"),
    r_short_checked_as_centre=True,
    end_on_start_circle=True,
    checksums="g2core",
    program_end_continues="g2core",
    g_codes=_G2CORE_G,
    m_codes=_G2CORE_M,
    g_point_codes=frozenset((280, 300, 380, 430, 610, 900, 910, 920)),
    m_whole_codes=True,
    one_sign=True,
    coordinate_systems=6,  # g2core.h COORDS
    g10_levels=frozenset((1, 2, 10, 20)),  # cm_set_g10_data: "L11 not supported atm"
    g10_p0_current=False,  # cm_set_g10_data: P below G54 is STAT_P_WORD_IS_INVALID
    g10_g2core=True,
    max_tool_number=32,  # g2core.h TOOLS
)

MARLIN = Dialect(
    name="marlin",
    explicit_end_full_circle=True,
    radius_check=None,
    project_end_on_arc=True,
    both_offsets_required=False,
    p_adds_circles=True,
    default_feed_mm_per_min=1500.0,
    g20_is_inch=True,
    g20_refusal="",
    # E and S, and the axes its default build has not (G0/G1 read X Y Z E F only; its parser
    # takes any letter: MakerBot files write their extruders as A and B)
    ignored_letters=frozenset("ESABCUVW"),
    min_radius_mm=1e-6,
    min_radius_in=1e-6 / 25.4,
    r_short_is_semicircle=True,
    require_program_end=False,
    max_p=100,
    arc_segment_mm=1.0,  # Marlin 2.x MAX_ARC_SEGMENT_MM (formerly MM_PER_ARC_SEGMENT)
    own_lines="marlin",
    splines="marlin",
    g0_at_feed=True,
    checksums="marlin",
    extruder=True,
    # queue.cpp process_stream_char (PAREN_COMMENTS) drops a comment up to its first ): one
    # left open or holding a ( is no error (lexer._marlin_stream); its default build reads no
    # ( comments and skips a line that opens with one as an unknown command
    firmware_comments="marlin",
    positive_feed_only=True,
    # a "%" line is an "Unknown command" to Marlin (GCodeParser::parse), and on to the next
    percent_delimits=False,
    # G2_G3.cpp reads the plane's two offsets only (I J in G17): a K there is ignored
    off_plane_offset_ignored=True,
    bad_arc_moves_nothing=True,
)

LASERDYNE_ON_ARC_TOL_MM = 0.005
LASERDYNE = Dialect(
    name="laserdyne",
    g92_resets_apart=True,
    rs274_code_numbers=True,
    g93_min_rate=0.1,
    explicit_end_full_circle=True,
    radius_check=RadiusCheck(
        LASERDYNE_ON_ARC_TOL_MM,
        LASERDYNE_ON_ARC_TOL_MM,
        LASERDYNE_ON_ARC_TOL_MM / 25.4,
        LASERDYNE_ON_ARC_TOL_MM / 25.4,
        0.0,
    ),
    project_end_on_arc=False,
    both_offsets_required=True,
    p_adds_circles=False,
    default_feed_mm_per_min=None,
    g20_is_inch=False,
    g20_refusal=(
        "G20 is plane rotation on Laserdyne controls, which is not supported; "
        "programs are read in mm (G21)"
    ),
    ignored_letters=frozenset(),
    min_radius_mm=0.00127,
    min_radius_in=0.00005,
    r_short_is_semicircle=False,
    require_program_end=False,
    r_needs_arc_code_first=True,
)

# fmt: off
#: grbl 1.1's codes (gcode.c); G38.2-G38.5 (probing) are refused where they are read.
_GRBL_G = frozenset((
    0, 10, 20, 30, 40, 100, 170, 180, 190, 200, 210, 280, 281, 300, 301, 382, 383, 384, 385,
    400, 431, 490, 530, 540, 550, 560, 570, 580, 590, 610, 800, 900, 910, 911, 920, 921, 930, 940,
))
#: grbl's status codes (report.c / the grbl 1.1 wiki "Error codes"), matched on our messages.
_GRBL_ERRORS = (
    # a second '.' after a number: grbl's read_float ends the number there, and '.' is no
    # command letter
    ("invalid jog command", 16),
    ("takes no decimal part", 23), ("axis command conflict", 24),
    ("a second '.' after the number", 1),
    ("expects a command letter", 1), ("not grbl features", 20), ("bad number format", 2),
    ("bad number format", 2), ("bad character", 1), ("bad value", 2), ("negative", 4),
    ("unknown g code", 20), ("unsupported m code", 20), ("is not supported", 20),
    ("two g codes from one modal group", 21),
    ("two m codes from one modal group", 21), ("zero feed rate", 22),
    ("both use the axis words", 24), ("multiple", 25), ("with no axis word", 26),
    ("g10 needs", 28),
    ("dwell) needs a p", 28), ("coordinate systems", 29), ("g53", 30), ("g80", 31),
    ("neither", 32), ("ends where it starts", 33), ("radius to end of arc", 33),
    ("too small to reach", 34), ("has no centre", 35), ("missing value", 2),
    ("f word missing", 22), ("uses no offset words", 36),
    ("with no code that uses it", 36), ("axis word on a 3-axis machine", 20),
    ("axis words with no motion mode", 31), ("max characters per line", 11),
    ("g92 needs at least one axis word", 26), ("largest tool number", 38),
    ("g43.1 on grbl", 37), ("zero-radius arc", 33), ("'%' is only allowed", 1),
    ("invalid line number", 27),
)
# fmt: on
GRBL = Dialect(
    name="grbl",
    explicit_end_full_circle=True,
    radius_check=RadiusCheck(0.005, 0.5, 0.005 / 25.4, 0.5 / 25.4, 0.001, rel_to_start=True),
    project_end_on_arc=False,
    both_offsets_required=False,
    p_adds_circles=False,
    default_feed_mm_per_min=None,
    g20_is_inch=True,
    g20_refusal="",
    ignored_letters=frozenset(),
    min_radius_mm=1e-6,
    min_radius_in=1e-6 / 25.4,
    r_short_is_semicircle=False,
    require_program_end=False,
    language=False,
    g_codes=_GRBL_G,
    m_codes=frozenset((0, 1, 2, 30, 3, 4, 5, 7, 8, 9, 56)),
    letters=frozenset("FGIJKLMNPRSTXYZ"),
    system_lines=True,
    line_number_words=True,
    o_words=False,
    arc_p_allowed=False,
    off_plane_offset_ignored=True,
    arc_needs_plane_axis_word=True,
    initial_motion=0,
    realtime_characters=True,
    g10_rotation=False,
    coordinate_systems=6,
    error_codes=_GRBL_ERRORS,
    arc_tolerance_mm=0.002,
    firmware_comments="grbl",
    percent_delimits=False,
    motion_waits="grbl",
    feed_mode_clears_feed="grbl",
    home_first_move=False,
    line_limit="grbl",
    zero_angle_fuzz=5e-7,
    feed_in_line_units=True,
    jog_units_per_minute=True,
    g53_absolute_in_g91=True,
    read_order="grbl",
    program_end_continues="grbl",
    strict_g80=True,
    tool_length_axis_codes=frozenset({431, 490}),
    g93_arc_per_segment=True,
    zero_radius_straight=True,
    g10_p_truncated=True,
)

DIALECTS: dict[str, Dialect] = {d.name: d for d in (LINUXCNC, G2CORE, MARLIN, LASERDYNE, GRBL)}


def coded(message: str, d: Dialect) -> str:
    """``message`` with the dialect's firmware error number appended, when one matches; in a
    dialect without LinuxCNC's language, a value is a number alone (the shared reader's
    message also offers ``#n`` and ``[expression]``)."""
    if not d.language:
        message = message.replace("expected a number, #n or [expression]", "expected a number")
    low = message.lower()
    for fragment, code in d.error_codes:
        if fragment in low:
            return f"{message} ({d.name} error {code})"
    return message


def with_segmentation_default(machine: MachineConfig, dialect: str) -> MachineConfig:
    """``machine`` segmenting arcs as the dialect's controller does by default -- grbl: chords
    within its arc tolerance ($12, 0.002 mm); g2core: chords within its chordal tolerance
    ($ct, 0.01 mm); marlin: fixed segments of 1 mm -- unless the
    user's machine file (or ``with_changes``) set a [segmentation] of its own."""
    d = get_dialect(dialect)
    if "segmentation" in machine.user_sections:
        return machine
    if d.arc_segment_mm is not None:
        return machine.with_changes(
            "segmentation", method="fixed", segment_length_mm=d.arc_segment_mm
        )
    if d.arc_tolerance_mm is not None:
        return machine.with_changes(
            "segmentation", method="chord", chord_tolerance_mm=d.arc_tolerance_mm
        )
    return machine


def get_dialect(name: str) -> Dialect:
    """The dialect called ``name``; GcodeError listing the valid names otherwise."""
    try:
        return DIALECTS[name]
    except KeyError:
        raise GcodeError(
            f"unknown dialect {name!r}; choose one of: {', '.join(DIALECTS)}"
        ) from None
