"""Contour error: the traced tool tip against the COMMANDED geometry, and its parts.

Every sample k carries the program line being executed (the trajectory's ``line``). Its contour
error is the distance to the nearest point of that line's move(s) and their neighbours in program
order (near a block junction the tool may be just before or after it), and of the moves within
LAG_REACH x |pos - ref| of path beyond them (a tool lagging several short moves): see
sim/program_distance.py. Parts (all [um]):

* chord: how far the chords (the planner's vertices) leave the true arcs -- segmentation;
* reference: how far the reference samples leave the geometry -- planning;
* tracking: how far the traced points leave the reference path (a polyline through the reference
  samples, searched near the same instant) -- the servo and the machine.

Statistics cover the feed moves only (G1/G2/G3): rapids are not cutting. Where the plan says
which moves a sample executes (Trajectory.source), that is per move: a canned cycle's plunges
count, its rapids do not.

In pieces: :func:`analyse_chunk` analyses any run of consecutive samples given the reference
TRACKING_WINDOW samples either side of it (:func:`reference_context`); :func:`combine` joins the
pieces into exactly the :class:`Analysis` of the whole trace (:func:`joined`, when the per-sample
arrays were filled in place, as a streamed run does). What a streaming run carries from
piece to piece is only the move table, the running maxima of the reference and tracking parts,
and each sample's err_um and line (for the rms, p95 and per-block figures at the end).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.moves import Move
from gantry_sim.controller.units import UM_PER_MM
from gantry_sim.sim.block_files import block_keys, place, split_key, tick_keys
from gantry_sim.sim.error_tally import ErrorTally
from gantry_sim.sim.move_table import MoveTable, move_table
from gantry_sim.sim.nearest import nearest_on_moves
from gantry_sim.sim.program_distance import distance_to_moves, distance_to_program, line_ranges
from gantry_sim.sim.tracking import max_distance_to_polyline_near

__all__ = [
    "Analysis",
    "BlockError",
    "ChunkAnalysis",
    "ContourStats",
    "ErrorParts",
    "analyse",
    "analyse_chunk",
    "block_stats",
    "chord_max_um",
    "combine",
    "distance_to_moves",
    "distance_to_program",
    "feed_samples",
    "reference_context",
    "tally_figures",
]

#: reference samples either side searched for the tracking part (50 ms at 1 kHz)
TRACKING_WINDOW = 50
#: path searched beyond a sample's own moves, per mm the tool is from the reference
LAG_REACH = 2.0
#: points along each chord checked for the chord part (fractions of the chord)
CHORD_FRACTIONS = (0.25, 0.5, 0.75)
#: chords checked at once by :func:`chord_max_um` (bounds its memory: ~30 MB)
CHORD_BATCH = 16384
#: moves laid out at a time for the chord check (a long program's moves come from disk)
CHORD_MOVES = 4096


@dataclass(frozen=True)
class ContourStats:
    """Statistics of a set of contour errors [um]: largest, root mean square, 95th percentile."""

    max_um: float
    rms_um: float
    p95_um: float

    def to_json(self) -> dict[str, float]:
        return {"max": self.max_um, "rms": self.rms_um, "p95": self.p95_um}


@dataclass(frozen=True)
class ErrorParts:
    """The largest of each part of the contour error [um] (see the module docstring)."""

    chord_max_um: float
    reference_max_um: float
    tracking_max_um: float

    def to_json(self) -> dict[str, float]:
        return {
            "chord_max": self.chord_max_um,
            "reference_max": self.reference_max_um,
            "tracking_max": self.tracking_max_um,
        }


@dataclass(frozen=True, slots=True)
class BlockError:
    """The contour error of one feed block (all samples executing its line) [um], and how many
    samples execute it (``ticks``: report.json gives ticks x servo period as its time);
    ``file``: the subroutine file the line is in (None: the program's own; sim.block_files)."""

    line: int
    kind: str
    max_error_um: float
    rms_error_um: float
    ticks: int = 0
    file: str | None = None

    def to_json(self) -> dict[str, int | str | float]:
        out: dict[str, int | str | float] = {
            "line": self.line,
            "kind": self.kind,
            "max_error_um": self.max_error_um,
            "rms_error_um": self.rms_error_um,
        }
        if self.file is not None:
            out["file"] = self.file
        return out

    @property
    def where(self) -> str:
        """The block's place: "line N", and "of FILE" for a subroutine file's line."""
        return place(self.line, self.file)


@dataclass(frozen=True)
class Analysis:
    """Contour error of a trace.

    Attributes:
        err_um: (N,) contour error of each traced point [um].
        nearest: (N, 3) the nearest commanded point to each traced point [mm].
        feed: (N,) True where the sample belongs to a feed move (G1/G2/G3).
        contour: statistics over the feed samples [um].
        parts: the largest chord, reference and tracking parts [um].
        blocks: per feed block in program order.
    """

    err_um: np.ndarray
    nearest: np.ndarray
    feed: np.ndarray
    contour: ContourStats
    parts: ErrorParts
    blocks: tuple[BlockError, ...]


def chord_max_um(
    moves: Sequence[Move], vertices: Sequence[np.ndarray] | None, tab: MoveTable | None = None
) -> float:
    """Largest distance of the chords between each curve's (arc's, spline's) vertices from the
    curve [um], checked at CHORD_FRACTIONS of every chord, CHORD_BATCH chords at a time (the
    points of 100,000 arcs at once took 4 GB). Without ``tab`` the moves are laid out
    CHORD_MOVES at a time (a long program's come from disk)."""
    if vertices is None:
        return 0.0
    if tab is not None:
        return _chord_max_mm(tab, _vertex_block(vertices, 0, len(moves))) * UM_PER_MM
    worst_mm = 0.0
    for k in range(0, len(moves), CHORD_MOVES):
        block = moves[k : k + CHORD_MOVES]
        verts = _vertex_block(vertices, k, k + len(block))
        worst_mm = max(worst_mm, _chord_max_mm(move_table(block), verts))
    return worst_mm * UM_PER_MM


def _vertex_block(vertices: Sequence[np.ndarray], lo: int, hi: int) -> Sequence[np.ndarray]:
    """``vertices[lo:hi]``: a plan's (controller.planner.vertices.ChordVertices, not imported
    here: the analysis worker does not need the planner) made in batches."""
    block = getattr(vertices, "block", None)
    return block(lo, hi) if block is not None else vertices[lo:hi]


def _chord_max_mm(tab: MoveTable, vertices: Sequence[np.ndarray]) -> float:
    """:func:`chord_max_um` [mm] of the moves of ``tab``, whose vertices are ``vertices``."""
    worst_mm = 0.0
    batch: list[tuple[int, np.ndarray]] = []
    chords = 0
    for j in range(len(tab)):
        if not (tab.arc[j] or tab.spline[j]):
            continue
        verts = np.asarray(vertices[j], dtype=float).reshape(-1, 3)
        if len(verts) < 2:
            continue
        batch.append((j, verts))
        chords += len(verts) - 1
        if chords >= CHORD_BATCH:
            worst_mm = max(worst_mm, _chord_batch_max_mm(tab, batch))
            batch, chords = [], 0
    if batch:
        worst_mm = max(worst_mm, _chord_batch_max_mm(tab, batch))
    return worst_mm


def _chord_batch_max_mm(tab: MoveTable, batch: list[tuple[int, np.ndarray]]) -> float:
    """The largest distance [mm] of the chords of (move index, vertices) from their moves."""
    pts = [v[:-1] + f * (v[1:] - v[:-1]) for _, v in batch for f in CHORD_FRACTIONS]
    owner = [np.full(len(CHORD_FRACTIONS) * (len(v) - 1), j) for j, v in batch]
    p = np.concatenate(pts)
    return float(np.linalg.norm(nearest_on_moves(tab, np.concatenate(owner), p) - p, axis=1).max())


def feed_samples(
    tab: MoveTable,
    line: np.ndarray,
    source: np.ndarray | None = None,
    found: np.ndarray | None = None,
) -> np.ndarray:
    """(N,) True where the sample executes a feed move: with ``source`` (N, 2) (the moves it
    executes, Trajectory.source), where they are all feed moves (a G64 blend arc: the two of
    its corner) and its line has moves (a dwell's has none); else where its line's last move
    is one (a canned cycle's line, its retract a rapid, then counts as no feed). ``found``
    (N,): whether each line has moves, where ``tab`` holds only some of the program's rows
    (sim.range_rows)."""
    _, last, has_moves = line_ranges(tab, line)
    found = has_moves if found is None else found
    if source is None:
        return found & tab.feed[last]
    source = np.asarray(source).reshape(-1, 2)
    known = (source[:, 0] >= 0) & (source[:, 1] < len(tab))
    a, b = np.where(known, source[:, 0], last), np.where(known, source[:, 1], last)
    return found & tab.feed[a] & tab.feed[b]


def block_stats(tab: MoveTable, line: np.ndarray, err_um: np.ndarray) -> tuple[BlockError, ...]:
    """Per feed line in program order: its largest and rms error over the samples executing it
    (0 when none do), and their count (sim.error_tally: linear in the samples). Every sample
    counts; a run's own table counts only its feed samples (:class:`ErrorTally`)."""
    tally = ErrorTally(tab, spill=False)
    tally.add(line, err_um, np.ones(np.shape(line), dtype=bool))
    return tally_figures(tally)[1]


def tally_figures(
    tally: ErrorTally, files: tuple[str, ...] = ()
) -> tuple[ContourStats, tuple[BlockError, ...]]:
    """The statistics over the feed samples and the per-block figures of a finished tally
    (``files``: the subroutine files of its block keys, sim.block_files; none: keyed by
    line)."""
    (peak, rms, p95), blocks = tally.finish()
    out = []
    for key, kind, peak_um, rms_um, ticks in blocks:
        line, file = split_key(key, files) if files else (key, None)
        out.append(BlockError(line, kind, peak_um, rms_um, ticks, file))
    return ContourStats(peak, rms, p95), tuple(out)


@dataclass(frozen=True)
class ChunkAnalysis:
    """The analysis of consecutive samples of a run.

    Attributes:
        err_um: (n,) contour error [um]; nearest: (n, 3) nearest commanded point [mm];
        feed: (n,) feed samples; reference_max_um, tracking_max_um: the parts' maxima over
        the chunk's feed samples [um] (0 when none).
    """

    err_um: np.ndarray
    nearest: np.ndarray
    feed: np.ndarray
    reference_max_um: float
    tracking_max_um: float


def reference_context(lo: int, hi: int, total: int) -> tuple[int, int]:
    """The reference samples [start, stop) that :func:`analyse_chunk` needs for samples
    lo..hi-1 of a run of ``total``: TRACKING_WINDOW before and TRACKING_WINDOW + 1 after."""
    return max(0, lo - TRACKING_WINDOW), min(total, hi + TRACKING_WINDOW + 1)


def analyse_chunk(
    tab: MoveTable,
    line: np.ndarray,
    pos: np.ndarray,
    ref_context: np.ndarray,
    offset: int,
    source: np.ndarray | None = None,
    found: np.ndarray | None = None,
) -> ChunkAnalysis:
    """Analyse n consecutive samples: ``line`` (n,), ``pos`` (n, 3) [mm]; the reference of
    sample k is ref_context[offset + k] [mm], the context as :func:`reference_context` gives it;
    ``source`` (n, 2): the moves each sample executes (Trajectory.source, rows of ``tab``), if
    known; ``found`` (n,): whether each line has moves, where ``tab`` holds only the rows the
    samples reach (sim.range_rows). Every figure is that of :func:`analyse` on the whole trace,
    for these samples."""
    line = np.asarray(line)
    pos = np.asarray(pos, dtype=float)
    ref_context = np.asarray(ref_context, dtype=float)
    ref = ref_context[offset : offset + len(pos)]
    if len(tab.line) == 0:  # a program without moves (a dwell alone): nothing commanded
        n = len(pos)
        return ChunkAnalysis(np.zeros(n), pos.copy(), np.zeros(n, dtype=bool), 0.0, 0.0)
    feed = feed_samples(tab, line, source, found)
    lag_mm = LAG_REACH * np.linalg.norm(pos - ref, axis=1)
    dist, nearest = distance_to_moves(tab, line, pos, lag_mm, source)
    own = None if source is None else np.asarray(source)[feed]
    ref_um = distance_to_moves(tab, line[feed], ref[feed], window=own)[0] * UM_PER_MM
    track_mm = max_distance_to_polyline_near(ref_context, pos, TRACKING_WINDOW, feed, shift=offset)
    return ChunkAnalysis(
        err_um=dist * UM_PER_MM,
        nearest=nearest,
        feed=feed,
        reference_max_um=float(ref_um.max()) if ref_um.size else 0.0,
        tracking_max_um=track_mm * UM_PER_MM,
    )


def combine(
    tab: MoveTable,
    line: np.ndarray,
    chunks: Sequence[ChunkAnalysis],
    chord_max: float,
    keys: np.ndarray | None = None,
    files: tuple[str, ...] = (),
) -> Analysis:
    """The :class:`Analysis` of a whole trace from its chunks in order (``line``: (N,) all
    samples' lines, or their block keys with ``keys``, per move of ``tab``, and ``files``:
    sim.block_files; ``chord_max``: :func:`chord_max_um` [um])."""
    err_um = np.concatenate([c.err_um for c in chunks]) if chunks else np.zeros(0)
    nearest = np.concatenate([c.nearest for c in chunks]) if chunks else np.zeros((0, 3))
    feed = np.concatenate([c.feed for c in chunks]) if chunks else np.zeros(0, dtype=bool)
    parts = ErrorParts(
        chord_max_um=chord_max,
        reference_max_um=max((c.reference_max_um for c in chunks), default=0.0),
        tracking_max_um=max((c.tracking_max_um for c in chunks), default=0.0),
    )
    return joined(tab, line, err_um, nearest, feed, parts, keys, files)


def joined(
    tab: MoveTable,
    line: np.ndarray,
    err_um: np.ndarray,
    nearest: np.ndarray,
    feed: np.ndarray,
    parts: ErrorParts,
    keys: np.ndarray | None = None,
    files: tuple[str, ...] = (),
) -> Analysis:
    """The :class:`Analysis` of a whole trace from its per-sample arrays, already joined (a
    streamed run fills them range by range: no second copy), and its parts [um] (``line``,
    ``keys``, ``files``: as :func:`combine`)."""
    tally = ErrorTally(tab, spill=False, keys=keys)
    tally.add(line, err_um, feed)
    contour, blocks = tally_figures(tally, files)
    for arr in (err_um, nearest, feed):
        arr.setflags(write=False)
    return Analysis(err_um, nearest, feed, contour, parts, blocks)


def analyse(
    moves: Sequence[Move],
    line: np.ndarray,
    ref: np.ndarray,
    pos: np.ndarray,
    vertices: Sequence[np.ndarray] | None = None,
    source: np.ndarray | None = None,
) -> Analysis:
    """Contour error of the trace ``pos`` (N, 3) [mm] following ``ref`` (N, 3) [mm].

    Args:
        moves: the interpreter's moves (the commanded geometry).
        line: (N,) program line executed at each sample.
        ref: (N, 3) reference samples [mm] (program coordinates).
        pos: (N, 3) traced tool tip [mm] (program coordinates).
        vertices: per move, the planner's chord vertices (k, 3) [mm], for the chord part.
        source: (N, 2) the moves each sample executes (Trajectory.source), where known: the
            search is then linear in the moves too (else it takes every move of the line).
    """
    tab = move_table(moves)
    whole = analyse_chunk(tab, line, pos, ref, 0, source)
    keys, files = block_keys(tab.line, [mv.file for mv in moves])
    ticks = tick_keys(line, source, keys, files)  # a subroutine file's lines: blocks apart
    return combine(tab, ticks, [whole], chord_max_um(moves, vertices, tab), keys, files)
