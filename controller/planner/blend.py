"""Path control (G61, G61.1, G64 P Q): the moves the planner follows, and where it must stop.

The mode in effect for a move (its ``path``, else the machine file's ``[path]``) governs the
junction at the move's END, as LinuxCNC's termination condition does:

* G61.1: an exact stop at that junction, even a tangent one.
* G61: today's rule of :mod:`~gantry_sim.controller.planner.junctions` (exact stops at corners,
  tangent junctions keep their speed).
* G64 P: a corner between two straight feed moves is replaced by an arc tangent to both (the
  "tangent arc blend" of LinuxCNC 2.7+; grbl's junction deviation uses the same circle). For a
  turn of angle phi, a blend of radius R leaves the corner by d = R (1/cos(phi/2) - 1) and uses
  L = R tan(phi/2) of each move; R is the largest with d <= P - the planner's own deviation from
  an arc (0.25 x chord tolerance, the G61 promise), and L at most half of each move, so the
  reference stays within P of the programmed corner. Where the blends at both ends of a
  straight move can use all of it between them (:data:`MEET_SHARE`), they do: a regular polygon
  becomes one chain of equal arcs with no curvature jump left. Blends need both moves in one principal
  plane (XY, XZ or YZ; the planner's arcs live there); other corners stay exact stops.
* G64 P, tangent junctions whose curvature jumps (line -> arc, S-bends, arcs of two radii): a
  G2 transition within P (:mod:`~gantry_sim.controller.planner.transition`), a curve that
  leaves the first move and joins the second with their tangent and curvature, in place of the
  jump the planner would otherwise smooth within one chord (and pass slowly).
* G64 Q: consecutive straight feed moves at one feed whose end points lie within Q of one line
  are merged into that line first (LinuxCNC's naive-CAM detector:
  :mod:`~gantry_sim.controller.planner.path_control`, which also resolves each move's mode).

Events: a dwell (G4) is an exact stop plus its time; a program stop (M0/M1/M60) an exact stop.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from gantry_sim.controller.config import PathSettings
from gantry_sim.controller.moves import Arc, Dwell, Linear, PathMove, Rapid
from gantry_sim.controller.planes import PLANE_AXES, Plane, Vec3, plane_of
from gantry_sim.controller.planner.blend_types import Blend, Blended
from gantry_sim.controller.planner.corner_blend import (
    ArcCorner,
    CornerCut,
    arc_corner,
    arc_end_tangents,
    blend_tangent_mm,
    end_tangent,
    trimmed_arc,
)
from gantry_sim.controller.planner.path_control import EPS_MM, Merge, control
from gantry_sim.controller.planner.transition import (
    TransitionCut,
    TransitionMachine,
    size_transitions,
    transition_site,
)
from gantry_sim.controller.vector import norm

#: Share of the chord tolerance the planner's reference may leave an arc by (the G61 promise);
#: a blend keeps this much of the tolerance for it.
REFERENCE_SHARE = 0.25
#: Share of a blend's budget (P - the reference's share) its geometry may use; the rest is for
#: smoothing the curvature jumps where the blend meets its straight moves.
GEOMETRY_SHARE = 0.8
#: Turns (rad) below which two straight moves count as collinear (no blend needed) and above
#: which the blend would be a near-reversal (an exact stop instead).
MIN_TURN_RAD = 1e-6
MAX_TURN_RAD = math.radians(179.0)
#: A straight move left between two blends shorter than this times the smaller blend radius is
#: absorbed: both blends run on to its midpoint (a spiral by rest^2 / (8 R), a kink by rest / R,
#: both negligible), so a polygon of nearly equal short moves becomes one chain of arcs without
#: the curvature jumps the rounding of its points would otherwise leave.
ABSORB_PER_MM = 2e-4
#: Share of a blend's budget its geometry may use when that lets it meet the next blend: nothing
#: of the straight move between them is left, so there is no line-to-arc curvature jump there to
#: smooth (the 1 % left covers the small jump between two nearly equal blends). A regular
#: polygon then becomes one chain of equal arcs, passed like a circle.
MEET_SHARE = 0.99


@dataclass
class PathPlan:
    """What the planner follows.

    Attributes:
        moves: the moves, blend arcs and transitions inserted, zero-length moves dropped (a
            :class:`~gantry_sim.controller.spill.SpilledList` when made by
            :func:`~gantry_sim.controller.planner.path_stream.path_plan`: on disk).
        stop_after: per move, True where the junction after it must be an exact stop.
        holds: junction index (0: before the first move, k: after move k-1) -> dwells there.
        blends: every blended corner and transition.
        blend_junction: index in ``moves`` of each blend arc -> its junction (for ``skip``).
        smoothing_mm: per move, how far the smoothing of a curvature jump at its ends may take
            the reference from it [mm] (blend arcs: what their tolerance leaves; 0 elsewhere:
            the planner's own budget).
        sources: per move, the first and last program move it comes from (indices among the
            program's motions, zero-length ones counted): a move's own index twice, a G64 Q
            merge its run, a blend arc or a transition the two moves of its junction.
        merges: every G64 Q merge (line, deviation from the programmed points, Q).
    """

    moves: Sequence[PathMove] = field(default_factory=list)
    stop_after: list[bool] = field(default_factory=list)
    holds: dict[int, list[Dwell]] = field(default_factory=dict)
    blends: Sequence[Blend] = field(default_factory=list)
    smoothing_mm: Sequence[float] = field(default_factory=list)
    blend_junction: dict[int, int] = field(default_factory=dict)
    sources: Sequence[tuple[int, int]] = field(default_factory=list)
    merges: Sequence[Merge] = field(default_factory=list)
    #: per program move (the indices of ``sources``), Marlin's M204 path acceleration [mm/s^2]
    #: in effect (inf: none); None: none anywhere (set by the planner, not by path_plan)
    path_acc_mm_per_s2: Sequence[float] | None = None
    #: blend_junction's keys in order, for the dict (by id) and size they were taken from
    _blend_keys: tuple[int, int, list[int]] | None = field(
        default=None, init=False, repr=False, compare=False
    )

    def blends_between(self, lo: int, hi: int) -> dict[int, int]:
        """The entries of :attr:`blend_junction` of moves ``lo`` .. ``hi - 1``, their keys
        counted from ``lo``: found by bisection in its keys (a long program's windows each took
        the whole dict's tenth of a second at 100,000 blocks)."""
        d = self.blend_junction
        if self._blend_keys is None or self._blend_keys[:2] != (id(d), len(d)):
            self._blend_keys = (id(d), len(d), sorted(d))
        keys = self._blend_keys[2]
        first, stop = bisect.bisect_left(keys, lo), bisect.bisect_left(keys, hi)
        return {k - lo: d[k] for k in keys[first:stop]}


def smoothing_budget(m: PathMove, settings: PathSettings, chord_tolerance_mm: float) -> float:
    """The deviation a G64 move's junction smoothing may use: P less the reference's share
    (0 in G61/G61.1 and for rapids: the planner's own budget)."""
    if isinstance(m, Rapid):
        return 0.0
    return corner_budget_mm(m, settings, chord_tolerance_mm)


def corner_budget_mm(m: PathMove, settings: PathSettings, chord_tolerance_mm: float) -> float:
    """The deviation [mm] the junction after ``m`` (a feed move or a rapid: its mode and P
    govern that junction) may take from the corner: P less the reference's share in G64, 0 in
    G61 and G61.1."""
    c = control(m, settings)
    if c.mode != "G64":
        return 0.0
    return max(c.tolerance_mm - REFERENCE_SHARE * chord_tolerance_mm, 0.0)


def _direction(m: PathMove) -> np.ndarray:
    d = np.asarray(m.end, float) - np.asarray(m.start, float)
    return d / norm(d)


#: Arc corners' blends by site (junction among the merged moves, budget [mm]).
CornerSites = dict[tuple[int, float], CornerCut | None]


class CornerMemo:
    """The blends of a path's arc corners (:func:`~gantry_sim.controller.planner.corner_blend.
    arc_corner`, or None: not blended) by site: the corner's junction among the program's
    merged moves and its budget [mm]. The path made again without its slow blends
    (:mod:`~gantry_sim.controller.planner.window_judge`) has the same merged moves, so a corner
    it still blends is the same moves meeting with the same budget, and its blend is the first
    path's: the search (about 40 candidate blends a corner, a tenth of planning a PrusaSlicer
    print whose path is made twice) is made once.

    ``known``: the entries of earlier calls; ``made``: those this view found (a forked child's
    go back to the parent with its moves, :meth:`view` then :meth:`take`)."""

    def __init__(self, known: CornerSites | None = None) -> None:
        self.known: CornerSites = {} if known is None else known
        self.made: CornerSites = {}

    def view(self) -> CornerMemo:
        """A memo reading this one's entries, with none made yet."""
        return CornerMemo(self.known)

    def take(self, made: CornerSites) -> None:
        """Keep the entries a view made."""
        self.known.update(made)

    def cut(
        self,
        key: tuple[int, float],
        m0: Linear | Arc,
        m1: Linear | Arc,
        corner: ArcCorner,
        chord_tolerance_mm: float,
        tangents: dict[int, tuple[np.ndarray, np.ndarray]],
    ) -> CornerCut | None:
        """The corner's blend: the known one, else searched and kept."""
        if key in self.known:
            return self.known[key]
        if key not in self.made:
            self.made[key] = arc_corner(m0, m1, corner, chord_tolerance_mm, tangents)
        return self.made[key]


def blend_corners(
    stretch: PathPlan,
    settings: PathSettings,
    chord_tolerance_mm: float,
    skip: frozenset[int],
    jerk_mm_per_s3: float = math.inf,
    machine: TransitionMachine | None = None,
    sized: dict | None = None,
    base: int = 0,
    corners: CornerMemo | None = None,
) -> list[Blended]:
    """What each move of ``stretch`` (moves, stop_after, holds, smoothing_mm and sources set;
    G64 Q merged) becomes once its G64 corners are blended, and, with ``machine`` (its limits
    and segmentation), its G64 tangent junctions whose curvature jumps get G2 transitions (see
    the module docstring); ``skip``: junctions (indices among the stretch's moves) left exact
    stops. A move's result depends on the moves up to three either side of it only, so a long
    path is blended stretch by stretch
    (:func:`~gantry_sim.controller.planner.path_stream.path_plan`). ``sized``: transitions
    sized by an earlier call for the same program, by site (filled here; None: none kept);
    ``base``: the index of the stretch's first move in the whole path, which keys them and
    ``corners``' entries (the arc corners' blends of an earlier call; None: none kept)."""
    moves = list(stretch.moves)
    holds = stretch.holds
    n = len(moves)
    use = [0.0] * (n + 1)  # length each junction takes from its neighbours [mm]
    turn: list[tuple[float, Plane] | None] = [None] * (n + 1)
    budgets = [0.0] * (n + 1)  # line-line corners: P less the reference's share [mm]
    cuts: dict[int, CornerCut] = {}  # corners with an arc on one side
    tangent: list[tuple[int, float]] = []  # (junction, budget) that may get a transition
    tangents = arc_end_tangents(moves)
    for b in range(1, n):
        m0, m1 = moves[b - 1], moves[b]
        c = control(m0, settings)
        if stretch.stop_after[b - 1] or b in holds or c.mode != "G64" or b in skip:
            continue
        budget = c.tolerance_mm - REFERENCE_SHARE * chord_tolerance_mm
        if isinstance(m0, Linear | Arc) and isinstance(m1, Linear | Arc) and budget > 0:
            if isinstance(m0, Arc) or isinstance(m1, Arc):
                corner = ArcCorner(budget, GEOMETRY_SHARE, MAX_TURN_RAD, jerk_mm_per_s3)
                if corners is None:
                    cut = arc_corner(m0, m1, corner, chord_tolerance_mm, tangents)
                else:
                    site = (b + base, budget)
                    cut = corners.cut(site, m0, m1, corner, chord_tolerance_mm, tangents)
                if cut is not None:
                    cuts[b] = cut
                elif machine is not None:
                    tangent.append((b, budget))
                continue
        if not (isinstance(m0, Linear) and isinstance(m1, Linear)):
            continue
        d0, d1 = _direction(m0), _direction(m1)
        phi = math.acos(float(np.clip(d0 @ d1, -1.0, 1.0)))
        plane = plane_of(d0, d1)
        if not (MIN_TURN_RAD < phi < MAX_TURN_RAD) or plane is None or budget <= 0:
            continue
        use[b] = blend_tangent_mm(GEOMETRY_SHARE * budget, phi, m0.length_mm, m1.length_mm)
        turn[b] = (phi, plane)
        budgets[b] = budget
    if any(use) or cuts:
        _meet_neighbours(moves, use, turn, budgets)
    trans: dict[int, TransitionCut] = {}
    if machine is not None and tangent:
        trans = _transitions(moves, tangent, cuts, use, tangents, machine, sized, base)
    if not any(use) and not cuts and not trans:  # nothing blended: every move as it is
        return [
            Blended(holds.get(i, []), [m], [stop], [e], [src], [None])
            for i, (m, stop, e, src) in enumerate(
                zip(moves, stretch.stop_after, stretch.smoothing_mm, stretch.sources, strict=True)
            )
        ]
    before = [_cut(k, cuts, trans, use, True) for k in range(n + 1)]
    after = [_cut(k, cuts, trans, use, False) for k in range(n + 1)]
    # Trimmed straight moves: their new end points (a vanishing move: its midpoint, shared), as
    # the tuples the path's moves hold: a blend arc holds the very tuples of the lines it joins,
    # and a move left whole keeps its own.
    keep: list[bool] = []
    start_pts: list[Vec3] = []
    end_pts: list[Vec3] = []
    for i, m in enumerate(moves):
        if isinstance(m, Arc) and (after[i] or before[i + 1]):
            moves[i] = m = _meeting(trimmed_arc(m, after[i], before[i + 1]), i, trans)
        a, e = np.asarray(m.start, float), np.asarray(m.end, float)
        a_pt, e_pt = m.start, m.end
        if isinstance(m, Linear) and (after[i] or before[i + 1]):
            d = _direction(m)
            a, e = a + d * after[i], e - d * before[i + 1]
            rest = m.length_mm - after[i] - before[i + 1]
            radii = [use[k] / math.tan(0.5 * t[0]) for k in (i, i + 1) if (t := turn[k])]
            if _used_up(rest, radii):
                a = e = 0.5 * (a + e)  # the blends meet: they absorb what is left
            a_pt = _v3(a)
            e_pt = a_pt if e is a else _v3(e)
            # a transition's very end points (the same points, to rounding)
            a_pt = trans[i].move.end if i in trans else a_pt
            e_pt = trans[i + 1].move.start if i + 1 in trans else e_pt
        start_pts.append(a_pt)
        end_pts.append(e_pt)
        # a curve by its length: a full circle or a closed spline ends where it starts
        straight = isinstance(m, Rapid | Linear)
        keep.append((norm(e - a) if straight else m.length_mm) > EPS_MM)
    out: list[Blended] = []
    sources = stretch.sources
    for i, m in enumerate(moves):
        made = Blended(holds.get(i, []))
        out.append(made)
        if keep[i]:
            made.moves.append(_trimmed(m, start_pts[i], end_pts[i]))
            made.stops.append(stretch.stop_after[i])
            made.smoothing.append(stretch.smoothing_mm[i])
            made.sources.append(sources[i])
            made.blend_at.append(None)
        # a blend arc's sources: every program move of its two moves (a move merged by G64 Q
        # stands for several, and a blend that eats most of it passes several of them)
        between = (sources[i][0], sources[min(i + 1, n - 1)][1])
        arc, dev = None, 0.0
        if i + 1 in cuts:
            arc, dev = cuts[i + 1].arc, cuts[i + 1].deviation_mm
        elif (t := turn[i + 1]) is not None:
            nxt = moves[i + 1]
            arc, dev = _blend_arc(m, nxt, end_pts[i], start_pts[i + 1], t[0], t[1])  # type: ignore[arg-type]
        if arc is not None:
            tol = control(m, settings).tolerance_mm
            made.moves.append(arc)
            made.stops.append(False)
            made.smoothing.append(max(tol - REFERENCE_SHARE * chord_tolerance_mm - dev, 0.0))
            made.sources.append(between)
            made.blend_at.append(i + 1)
            made.blends.append(Blend(m.line, dev, tol, file=getattr(m, "file", None)))
        if i + 1 in trans:
            tc = trans[i + 1]
            tol = control(m, settings).tolerance_mm
            made.moves.append(tc.move)
            made.stops.append(False)
            made.smoothing.append(
                max(tol - REFERENCE_SHARE * chord_tolerance_mm - tc.deviation_mm, 0.0)
            )
            made.sources.append(between)
            made.blend_at.append(None)
            made.blends.append(
                Blend(m.line, tc.deviation_mm, tol, "transition", getattr(m, "file", None))
            )
    return out


def _transitions(
    moves: Sequence[PathMove],
    junctions: Sequence[tuple[int, float]],
    cuts: dict[int, CornerCut],
    use: Sequence[float],
    tangents: dict[int, tuple[np.ndarray, np.ndarray]],
    machine: TransitionMachine,
    sized: dict | None,
    base: int,
) -> dict[int, TransitionCut]:
    """The G2 transitions at the tangent ``junctions`` (junction, budget [mm]), by junction:
    each move's room is its length less the corner cut at its other end (``cuts``, ``use``);
    ``sized``: results by site (junction + ``base``, budget, rooms) of an earlier call for the
    same program, and filled (None: not kept)."""
    sites = []
    found: dict[int, TransitionCut] = {}
    for b, budget in junctions:
        m0, m1 = moves[b - 1], moves[b]
        if not (isinstance(m0, Linear | Arc) and isinstance(m1, Linear | Arc)):
            continue
        room0 = m0.length_mm - (cuts[b - 1].after_mm if b - 1 in cuts else use[b - 1])
        room1 = m1.length_mm - (cuts[b + 1].before_mm if b + 1 in cuts else use[b + 1])
        ends = (end_tangent(m0, True, tangents), end_tangent(m1, False, tangents))
        site = transition_site(m0, m1, b, budget, ends, (room0, room1))
        if site is None:
            continue
        key = (b + base, budget, site.room_mm)  # the same moves in every call for one program
        if sized is not None and key in sized:
            if sized[key] is not None:
                found[b] = sized[key]
        else:
            sites.append(site)
    new = size_transitions(sites, machine)
    if sized is not None:
        sized.update(
            ((s.junction + base, s.budget_mm, s.room_mm), new.get(s.junction)) for s in sites
        )
    return found | new


def _cut(
    k: int,
    cuts: dict[int, CornerCut],
    trans: dict[int, TransitionCut],
    use: Sequence[float],
    before: bool,
) -> float:
    """Path length [mm] junction ``k`` takes from the end of the move before it (``before``)
    or from the start of the move after it: a corner blend's, a transition's or a line-line
    blend's."""
    if k in cuts:
        return cuts[k].before_mm if before else cuts[k].after_mm
    if k in trans:
        return trans[k].cut_mm
    return use[k]


def _meeting(arc: Arc, i: int, trans: dict[int, TransitionCut]) -> Arc:
    """The trimmed arc ``i`` with the very end points of the transitions it meets (the same
    points, to rounding): the path stays continuous bit for bit."""
    start = trans[i].move.end if i in trans else arc.start
    end = trans[i + 1].move.start if i + 1 in trans else arc.end
    if start is arc.start and end is arc.end:
        return arc
    return replace(arc, start=start, end=end)


def _meet_neighbours(
    moves: Sequence[PathMove],
    use: list[float],
    turn: Sequence[tuple[float, Plane] | None],
    budgets: Sequence[float],
) -> None:
    """Lengthen blends (up to :data:`MEET_SHARE` of their budget) where the two blends of a
    straight move can then use all of it between them; ``use`` [mm] is updated in place.

    Only corners whose straight move is used up this way are lengthened: elsewhere the larger
    geometry share would take smoothing budget from a line-to-arc junction for nothing."""
    n = len(moves)
    reach = [0.0] * (n + 1)
    for b in range(1, n):
        t = turn[b]
        if t is None:
            continue
        reach[b] = blend_tangent_mm(
            MEET_SHARE * budgets[b], t[0], moves[b - 1].length_mm, moves[b].length_mm
        )
    for i in range(1, n - 1):  # move i lies between corners i and i + 1
        ends = [(reach[k], t[0]) for k in (i, i + 1) if (t := turn[k]) is not None]
        if len(ends) < 2:
            continue
        rest = moves[i].length_mm - ends[0][0] - ends[1][0]
        if _used_up(rest, [r / math.tan(0.5 * phi) for r, phi in ends]):
            use[i] = max(use[i], reach[i])
            use[i + 1] = max(use[i + 1], reach[i + 1])


def _used_up(rest_mm: float, radii_mm: Sequence[float]) -> bool:
    """True when the blends at a straight move's ends leave nothing of it (``rest_mm``), or,
    with a blend at both ends (``radii_mm``), a sliver they absorb (:data:`ABSORB_PER_MM`)."""
    return rest_mm <= EPS_MM or (len(radii_mm) == 2 and rest_mm <= ABSORB_PER_MM * min(radii_mm))


def _v3(a: np.ndarray) -> Vec3:
    return (float(a[0]), float(a[1]), float(a[2]))


def _trimmed(m: PathMove, start: Vec3, end: Vec3) -> PathMove:
    """``m`` between ``start`` and ``end`` [mm]: a straight move trimmed (``m`` itself when both
    are its own)."""
    if not isinstance(m, Linear) or (start is m.start and end is m.end):
        return m
    return replace(m, start=start, end=end)


def _blend_arc(
    m0: Linear, m1: Linear, start: Vec3, end: Vec3, phi: float, plane: Plane
) -> tuple[Arc, float]:
    """The arc tangent to ``m0`` at ``start`` and to ``m1`` at ``end`` (its corner: m0.end; the
    very tuples the trimmed lines hold), and its largest distance from the corner [mm]."""
    p0, p1 = np.asarray(start, float), np.asarray(end, float)
    d0, d1 = _direction(m0), _direction(m1)
    corner = np.asarray(m0.end, float)
    half = 0.5 * phi
    length = 0.5 * (norm(corner - p0) + norm(p1 - corner))
    radius = length / math.tan(half)
    bis = (d1 - d0) / norm(d1 - d0)
    center = corner + bis * (radius / math.cos(half))
    i1, i2, n = PLANE_AXES[plane]
    center[n] = p0[n]
    r0 = math.hypot(p0[i1] - center[i1], p0[i2] - center[i2])
    ccw = d0[i1] * d1[i2] - d0[i2] * d1[i1] > 0
    e0 = (p0[i1] - center[i1], p0[i2] - center[i2])
    e1 = (p1[i1] - center[i1], p1[i2] - center[i2])
    sweep = abs(math.atan2(e0[0] * e1[1] - e0[1] * e1[0], e0[0] * e1[0] + e0[1] * e1[1]))
    arc = Arc(
        line=m0.line,
        start=start,
        end=end,
        feed_mm_per_min=min(m0.feed_mm_per_min, m1.feed_mm_per_min),
        plane=plane,
        direction="ccw" if ccw else "cw",
        center=_v3(center),
        radius=r0,
        turns=1,
        angle=sweep,
        path=m0.path,
    )
    return arc, radius * (1.0 / math.cos(half) - 1.0)
