"""G2 transitions: a G64 tangent junction whose curvature jumps, passed on a curve of continuous
curvature within the path tolerance.

Where two moves meet tangentially with a jump of curvature (line -> arc, an S-bend, arcs of two
radii), the reference's acceleration would have to jump by v^2 |k1 - k0|. Without a transition
the planner smooths that jump within one chord next to the junction
(:func:`~gantry_sim.controller.planner.junctions.junction_cap`), and the chords are short (0.2
mm on R 5 at 1 um), so the junction is passed slowly (an S-bend of R 5: 26 of 100 mm/s). Here
the junction is replaced instead: ``h`` mm are cut from the end of the first move and from the
start of the second, and the cut points A and B are joined by the quintic Bezier curve

    P0 = A,  P1 = A + al/5 TA,  P2 = A + 2 al/5 TA + al^2/20 KA,
    P3 = B - 2 al/5 TB + al^2/20 KB,  P4 = B - al/5 TB,  P5 = B,      al = 2 h

(T: unit tangents, K: curvature vectors [1/mm] of the moves at A and B; the curve:
:mod:`~gantry_sim.controller.quintic_curve`). Then C'(0) = al TA and C''(0) = al^2 KA: the curve
leaves A along TA with the curvature KA, and meets B likewise, so position, tangent and
curvature are continuous at both ends (G2) and nothing is left to smooth there. With al = 2 h
the curve's parametric speed is nearly constant; other al (0.8-1.2 x), tangential terms in P2
and P3, and unequal cuts, scanned on an S-bend of R 5, a line into R 5 and into R 0.5, and R 5
into R 20, were all slower within the same deviation, or faster by 3 % at most.

The curvature then changes over the curve's length instead of at a point: passed at speed v,
the curve needs v^2 |k| <= a and v^3 |p'''| <= j of its plane's axes (the planner's speed cap
of any curve, :func:`~gantry_sim.controller.planner.limits.curvature_speed_cap`). |p'''| falls
like 1/h (about 2.25 |k1 - k0| / (2 h) while h |k| is small) and the deviation from the
programmed moves grows like h^2 (about 0.011 |k1 - k0| h^2), so the speed a transition allows
within a tolerance e grows like (e / |dk|)^(1/6): an S-bend of R 5 (|dk| = 0.4/mm) at P0.01
allows 64 mm/s, above the ceiling of a linear curvature ramp, v^2 |dk| = (48 e J^2)^(1/3)
(60 mm/s), below the two-sided ceiling any planner has (73 mm/s, benchmarks/junction_floor.py).

Which junctions (:func:`transition_site`): in G64 with a tolerance (the first move's P, or
``[path] tolerance_mm``), not an exact stop (G61.1, a dwell, a program stop), between two feed
moves (G1, G2/G3; never a rapid) of which one at least is an arc, both in one principal plane
(an arc with no helix; a slight spiral is fine), turning by less than 1 degree
(:data:`~gantry_sim.controller.planner.corner_blend.ARC_CORNER_MIN_RAD`, the planner's corner
angle). Splines are not cut (cutting a NURBS needs knot insertion and the general spline
machinery this curve is here to avoid), nor helices (a tangent junction with a helix is rare:
ramps meet their moves at corners; and the transition would leave the plane whose limits its
speed caps use); their junctions keep the chord smoothing. Of those, only the junctions whose
cap with the chord smoothing is below what the two moves allow (:func:`move_speed_cap`: the
feed, the axis speeds, an arc's curvature caps) are sized; that cap is
:func:`~gantry_sim.controller.planner.junctions.junction_cap` at the chord fit the planner's
pieces reach in the end, :data:`CHORD_FIT_REACHED` (its first guess, at 1.5, found the
pocket's line-arc junctions free at 20 mm/s, where they end at 8-17).

How long (:func:`size_transitions`): the shortest cut whose curve, at the target speed v (what
the two moves allow), takes at most :data:`JERK_SHARE` of its plane's jerk for its curvature
change beyond what the moves' own take (its |p'''| less the larger of theirs, k^2 on a
circle; a curve joining two arcs of nearly the same radius needs no length to be nearly as
smooth as they are, and cut as long as its room allowed it ate the arcs whole: a spiral of
quarter arcs R 1-11 at F6000 ran 1 % slower than with the chord smoothing): the rest stays
for the profile's tangential jerk (a transition within a chain sets the chain's jerk, and its
limits are chosen for that: limits._arc_batch); but no longer than the tolerance allows (its
measured deviation within P less the reference's share,
:data:`~gantry_sim.controller.planner.blend.REFERENCE_SHARE` of the chord tolerance), and at
most :data:`LENGTH_SHARE` of either move's room (its length less a corner blend's cut at its
other end), so that a move keeps some of itself between two transitions. The cut is found from a first guess by the deviation's power law in
:data:`SEARCH_STEPS` steps on log h (the deviation and |p'''| are close to power laws of h;
their exponents come from the last two measurements), measuring the curve each time, then
measured on more points and shrunk until the deviation is within the budget. A transition is
kept where its speed cap is at least :data:`GAIN` x the junction's chord-smoothing cap. Jerk
shares tried (cycle time of the pocket peer program / a 3-arc S-chain at F3000 / 1,000
generated arcs): 0.5 196.50 / 0.8994 / 131.05 s, 0.25 196.76 / 0.8928 / 131.02 s, 0.15 197.04
/ 0.8918 / 131.01 s.

The deviation is measured, not assumed (``_Batch.final``): the largest distance of the curve's
65 bound samples (:data:`~gantry_sim.controller.quintic_curve.BOUND_SAMPLES`) from the two
programmed moves (the segment; an arc's in-plane radius error at the point's polar angle, with
how far the point lies past the arc's end: exact on an arc, an upper bound on a slight spiral),
and of :data:`CUT_SAMPLES` points of each cut-away part from the curve (nearest points by Newton
steps), the larger, each refined between the samples next to its largest by golden-section
steps (without them, 65 samples missed 0.2 % of it, and `gantry run` measured 9.671 um of a
transition reported at 9.652). Sites are sized :data:`SIZE_BATCH` at a time, all of a batch in
a few numpy calls.

Conventions: mm, s; an arc's sweep fraction u runs from 0 at its start to 1 at its end; h is
path length cut from each move [mm]; tangents are unit vectors in the direction of motion.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.arcs import arc_frame
from gantry_sim.controller.config import Limits, Segmentation
from gantry_sim.controller.moves import Arc, Linear, Transition
from gantry_sim.controller.planes import PLANE_AXES, Plane
from gantry_sim.controller.planner.corner_blend import ARC_CORNER_MIN_RAD, in_plane
from gantry_sim.controller.planner.junctions import junction_cap
from gantry_sim.controller.planner.limits import curvature_speed_cap, path_feed_mm_per_s
from gantry_sim.controller.planner.segment import segment_count
from gantry_sim.controller.quintic_curve import (
    BOUND_SAMPLES,
    QuinticCurve,
    curvature_bounds,
    derivatives,
    dot_rows,
    nearest_parameters,
    power_coefficients,
)

#: Share of the plane's jerk the transition's curvature change may take at the target speed.
JERK_SHARE = 0.25
#: Share of the plane's acceleration and jerk the speed caps are taken at (the planner's first
#: curvature margin, limits.CURVATURE_MARGINS[0]).
CAP_MARGIN = 0.99
#: A transition is kept only where its speed cap is at least this times the junction's cap
#: with the chord smoothing (below, the chord smoothing is as good, and one move fewer).
GAIN = 1.05
#: The chord smoothing's cap (junctions.junction_cap) with this chord fit: what the planner's
#: pieces reach in the end. Its first guess uses 1.5 (CHORD_FIT_BLEND), and the rounds lower it:
#: the pocket's line-arc junctions (R 0.5-3 at F1200) end at 7.9-17.4 mm/s, a fit of 5.1-7.1.
CHORD_FIT_REACHED = 6.0
#: Largest share of either move's room a transition may cut: a move between two transitions
#: keeps a tenth of itself (at a half, two could leave a sliver of 0.1 um, over which the
#: look-ahead's speeds, a hair apart, could not be joined: planning failed on 100,000
#: generated arcs).
LENGTH_SHARE = 0.45
#: Share of the deviation budget kept free of the sizing (what lies between the samples).
DEVIATION_MARGIN = 0.01
#: Points of the curve measured (deviation and bounds) while the cut is searched (the cut
#: found is measured on the curve's own bound samples, quintic_curve.BOUND_SAMPLES), and points
#: of each cut-away part measured from the curve.
SEARCH_SAMPLES = 17
CUT_SAMPLES = 17
#: Golden-section steps refining the largest deviation between samples (0.618^12: to 0.3 %
#: of the sample spacing).
GOLDEN_STEPS = 12
#: Steps of the search on log h after its first guess, and steps shrinking a cut whose
#: deviation is still over the budget.
SEARCH_STEPS = 2
SHRINK_STEPS = 8
#: Sites sized at once (bounds the search's arrays: about 30 KB a site).
SIZE_BATCH = 1024
#: First guess of the deviation per |k1 - k0| h^2 (measured: 0.0108 while h |k| is small).
DEVIATION_PER_DK_H2 = 0.0108


@dataclass(frozen=True)
class TransitionMachine:
    """What sizing transitions needs of the machine: its per-axis limits, its segmentation
    (the chords the chord smoothing would use) and the feed override's scale [1]."""

    limits: Limits
    segmentation: Segmentation
    feed_scale: float = 1.0


@dataclass(frozen=True)
class TransitionSite:
    """A junction that may get a transition: its index (between moves ``junction - 1`` and
    ``junction``), its two moves, their plane, the deviation budget [mm] (P less the
    reference's share), and how much of each move [mm] the transition may share with one at
    its other end (its length less a corner blend's cut there; the transition takes at most
    :data:`LENGTH_SHARE` of it)."""

    junction: int
    first: Linear | Arc
    second: Linear | Arc
    plane: Plane
    budget_mm: float
    room_mm: tuple[float, float]


@dataclass(frozen=True)
class TransitionCut:
    """A transition made: the path length cut from the end of the first move and from the
    start of the second [mm], the curve, its largest distance from the programmed moves [mm]
    (measured), and the speed caps [mm/s] it was sized for: ``target_mm_per_s`` what the moves
    allow, ``cap_mm_per_s`` the curve's, ``chord_cap_mm_per_s`` the junction's without it."""

    cut_mm: float
    move: Transition
    deviation_mm: float
    target_mm_per_s: float
    cap_mm_per_s: float
    chord_cap_mm_per_s: float


def transition_site(
    m0: object,
    m1: object,
    junction: int,
    budget_mm: float,
    tangents: tuple[np.ndarray, np.ndarray],
    room_mm: tuple[float, float],
) -> TransitionSite | None:
    """The :class:`TransitionSite` of the junction between ``m0`` and ``m1`` (unit tangents
    ``tangents`` = (end of m0, start of m1)), or None: not two feed moves with an arc among
    them, in one principal plane with no helix, turning by less than 1 degree, with a budget."""
    if not (isinstance(m0, Linear | Arc) and isinstance(m1, Linear | Arc)) or budget_mm <= 0:
        return None
    if not (isinstance(m0, Arc) or isinstance(m1, Arc)):
        return None
    planes = {m.plane for m in (m0, m1) if isinstance(m, Arc)}
    if len(planes) != 1:
        return None
    plane = planes.pop()
    if not (in_plane(m0, plane) and in_plane(m1, plane)):
        return None
    cos = float(np.clip(tangents[0] @ tangents[1], -1.0, 1.0))
    if math.acos(cos) > ARC_CORNER_MIN_RAD:
        return None
    return TransitionSite(junction, m0, m1, plane, budget_mm, room_mm)


def size_transitions(
    sites: Sequence[TransitionSite], machine: TransitionMachine
) -> dict[int, TransitionCut]:
    """The transitions worth making at ``sites``, by junction (see the module docstring), sized
    :data:`SIZE_BATCH` sites at a time."""
    found: dict[int, TransitionCut] = {}
    for lo in range(0, len(sites), SIZE_BATCH):
        found |= _size(sites[lo : lo + SIZE_BATCH], machine)
    return found


def _size(sites: Sequence[TransitionSite], machine: TransitionMachine) -> dict[int, TransitionCut]:
    """:func:`size_transitions` of one batch of sites."""
    batch = _Batch(sites, machine)
    keep = np.flatnonzero(batch.chord_cap < batch.target * (1.0 - 1e-9))
    if not keep.size:
        return {}
    batch = batch.subset(keep)
    h = _search(batch)
    budget = np.array([s.budget_mm for s in batch.sites])
    ctrl, dev, k, dk = batch.final(h)
    for _ in range(SHRINK_STEPS):  # measured on more points than the search: shrink the few over
        over = np.flatnonzero(dev > budget)
        if not over.size:
            break
        h[over] *= (1.0 - DEVIATION_MARGIN) * np.sqrt(budget[over] / dev[over])
        ctrl[over], dev[over], k[over], dk[over] = batch.subset(over).final(h[over])
    cap = batch.curve_cap(k, dk)
    good = np.flatnonzero((dev <= budget) & (cap >= GAIN * batch.chord_cap))
    rows = QuinticCurve.rows(ctrl[good])
    found: dict[int, TransitionCut] = {}
    for i, row in zip(good.tolist(), rows, strict=True):
        site = batch.sites[i]
        found[site.junction] = TransitionCut(
            float(h[i]),
            _transition(site.first, site.second, site.plane, ctrl[i], row),
            float(dev[i]),
            float(batch.target[i]),
            float(cap[i]),
            float(batch.chord_cap[i]),
        )
    return found


def _transition(
    m0: Linear | Arc, m1: Linear | Arc, plane: Plane, ctrl: np.ndarray, row: np.ndarray
) -> Transition:
    """The :class:`Transition` from ``m0`` to ``m1`` with control points ``ctrl`` (6, 3) [mm],
    its curve's packed ``row`` (:meth:`QuinticCurve.rows`)."""
    return Transition(
        line=m0.line,
        start=(float(ctrl[0, 0]), float(ctrl[0, 1]), float(ctrl[0, 2])),
        end=(float(ctrl[5, 0]), float(ctrl[5, 1]), float(ctrl[5, 2])),
        feed_mm_per_min=min(m0.feed_mm_per_min, m1.feed_mm_per_min),
        plane=plane,
        row=row.tobytes(),
        path=m0.path,
    )


def _search(batch: _Batch) -> np.ndarray:
    """The cut h [mm] per site (module docstring): from a first guess by the deviation's
    power law, :data:`SEARCH_STEPS` steps that aim at the shorter of the cut that meets the
    budget and the one that meets the jerk share, each measuring the curve, the exponents of
    both laws taken from the last two measurements (2 and 1 at first)."""
    budget = np.array([s.budget_mm for s in batch.sites]) * (1.0 - DEVIATION_MARGIN)
    # |p'''| beyond the moves' own (a circle's is k^2): its curvature change's share of the jerk
    target = JERK_SHARE * batch.plane_limits[:, 2] / batch.target**3
    own = batch.dk_own
    h_max = batch.length_cap
    h = np.minimum(np.sqrt(budget / (DEVIATION_PER_DK_H2 * np.maximum(batch.jump, 1e-12))), h_max)
    now = (h, *batch.measure(h, SEARCH_SAMPLES)[1:])
    p_dev, p_dk = np.full(len(h), 2.0), np.ones(len(h))
    before = None
    for _ in range(SEARCH_STEPS):
        h_b, dev_b, _, dk_b = now
        excess_b = np.maximum(dk_b - own, 1e-300)
        if before is not None:
            h_a, dev_a, _, dk_a = before
            span = np.log(h_a / h_b)
            with np.errstate(divide="ignore", invalid="ignore"):
                new_dev = np.log(dev_a / dev_b) / span
                new_dk = np.log(excess_b / np.maximum(dk_a - own, 1e-300)) / span
            p_dev = np.where(np.isfinite(new_dev), np.clip(new_dev, 0.5, 4.0), p_dev)
            p_dk = np.where(np.isfinite(new_dk), np.clip(new_dk, 0.2, 4.0), p_dk)
        by_dev = h_b * (budget / np.maximum(dev_b, 1e-300)) ** (1.0 / p_dev)
        by_jerk = h_b * (excess_b / target) ** (1.0 / p_dk)
        new = np.minimum(np.minimum(by_dev, by_jerk), h_max)
        before, now = now, (new, *batch.measure(new, SEARCH_SAMPLES)[1:])
    return now[0]


class _Side:
    """One side of each junction of a batch: the first move's end (``at_end``) or the second
    move's start, as arrays (lines and arcs; an arc's frame as :func:`arc_frame` gives it)."""

    def __init__(self, moves: Sequence[Linear | Arc], at_end: bool) -> None:
        n = len(moves)
        self.at_end = at_end
        self.arc = np.array([isinstance(m, Arc) for m in moves], dtype=bool)
        self.length = np.array([m.length_mm for m in moves])
        self.start = np.array([m.start for m in moves], dtype=float).reshape(n, 3)
        self.end = np.array([m.end for m in moves], dtype=float).reshape(n, 3)
        d = self.end - self.start
        norm = np.linalg.norm(d, axis=1)
        self.direction = d / np.where(norm > 0, norm, 1.0)[:, None]
        self.axes = np.zeros((n, 3), dtype=np.intp)
        self.c = np.zeros((n, 2))
        cols = np.zeros((n, 6))  # theta0, sigma * angle, r0, r1, normal coordinate, angle
        for i, m in enumerate(moves):
            if isinstance(m, Arc):
                f = arc_frame(m)
                self.axes[i] = (f.i1, f.i2, f.n)
                self.c[i] = (m.center[f.i1], m.center[f.i2])
                cols[i] = (f.theta0_rad, f.sigma * m.angle, f.r0_mm, f.r1_mm, f.h0_mm, m.angle)
        self.theta0, self.s_angle, self.r0, self.r1, self.hn, self.angle = cols.T

    def subset(self, idx: np.ndarray) -> _Side:
        out = object.__new__(_Side)
        out.__dict__ = {
            k: (v[idx] if isinstance(v, np.ndarray) else v) for k, v in vars(self).items()
        }
        return out

    def fraction(self, s_mm: np.ndarray) -> np.ndarray:
        """Sweep fractions (n,) of the arcs at path length ``s_mm`` from the junction (as
        corner_blend.trimmed_arc cuts them)."""
        return 1.0 - s_mm / self.length if self.at_end else s_mm / self.length

    def frame(self, s_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(point [mm], unit tangent, curvature vector [1/mm]) (n, 3) at path length ``s_mm``
        (n,) from the junction, in the direction of motion."""
        n = len(s_mm)
        if self.at_end:
            p = self.end - self.direction * s_mm[:, None]
        else:
            p = self.start + self.direction * s_mm[:, None]
        t = self.direction.copy()
        k = np.zeros((n, 3))
        a = np.flatnonzero(self.arc)
        if a.size:
            u = self.fraction(s_mm)[a]
            s_ang, r0, dr = self.s_angle[a], self.r0[a], self.r1[a] - self.r0[a]
            theta = self.theta0[a] + s_ang * u
            r = r0 + dr * u
            cos_t, sin_t = np.cos(theta), np.sin(theta)
            rows = np.arange(a.size)
            i1, i2, nn = self.axes[a, 0], self.axes[a, 1], self.axes[a, 2]
            pa = np.empty((a.size, 3))
            pa[rows, i1] = self.c[a, 0] + r * cos_t
            pa[rows, i2] = self.c[a, 1] + r * sin_t
            pa[rows, nn] = self.hn[a]
            d1 = np.zeros((a.size, 3))
            d2 = np.zeros((a.size, 3))
            d1[rows, i1] = dr * cos_t - r * s_ang * sin_t
            d1[rows, i2] = dr * sin_t + r * s_ang * cos_t
            d2[rows, i1] = -2.0 * dr * s_ang * sin_t - r * s_ang * s_ang * cos_t
            d2[rows, i2] = 2.0 * dr * s_ang * cos_t - r * s_ang * s_ang * sin_t
            v2 = np.einsum("ij,ij->i", d1, d1)
            ta = d1 / np.sqrt(v2)[:, None]
            ka = (d2 - np.einsum("ij,ij->i", d2, ta)[:, None] * ta) / v2[:, None]
            p[a], t[a], k[a] = pa, ta, ka
        return p, t, k

    def distance(self, q: np.ndarray) -> np.ndarray:
        """Distance [mm] (n, k) of points ``q`` (n, k, 3) from each whole move: a segment's
        exact; an arc's in-plane radius error at the point's polar angle (unwrapped near the
        junction) with the normal-axis error and how far along the arc the point lies past
        its ends (exact on an arc, an upper bound on a spiral)."""
        n, k = q.shape[0], q.shape[1]
        out = np.empty((n, k))
        ln = np.flatnonzero(~self.arc)
        if ln.size:
            a, d, length = self.start[ln], self.direction[ln], self.length[ln]
            rel = q[ln] - a[:, None, :]
            s = np.clip(np.einsum("nkj,nj->nk", rel, d), 0.0, length[:, None])
            off = rel - s[:, :, None] * d[:, None, :]
            out[ln] = np.sqrt(np.einsum("nkj,nkj->nk", off, off))
        ar = np.flatnonzero(self.arc)
        if ar.size:
            qa = q[ar]
            q1, q2, qn = (
                np.take_along_axis(qa, self.axes[ar, j][:, None, None], axis=2)[:, :, 0]
                for j in range(3)
            )
            c1, c2 = self.c[ar, 0][:, None], self.c[ar, 1][:, None]
            theta0, s_ang = self.theta0[ar][:, None], self.s_angle[ar][:, None]
            hint = theta0 + (s_ang if self.at_end else 0.0)
            th = np.arctan2(q2 - c2, q1 - c1)
            th = th - 2.0 * np.pi * np.round((th - hint) / (2.0 * np.pi))
            u = (th - theta0) / s_ang
            r0, r1 = self.r0[ar][:, None], self.r1[ar][:, None]
            d_r = np.hypot(q1 - c1, q2 - c2) - (r0 + (r1 - r0) * u)
            d_n = qn - self.hn[ar][:, None]
            over = np.maximum(np.maximum(u - 1.0, -u), 0.0)
            d_t = over * (r0 + (r1 - r0) * np.clip(u, 0.0, 1.0)) * self.angle[ar][:, None]
            out[ar] = np.sqrt(d_r * d_r + d_n * d_n + d_t * d_t)
        return out


class _Batch:
    """The sites being sized, as arrays: both sides, the plane's limits, the speeds."""

    def __init__(self, sites: Sequence[TransitionSite], machine: TransitionMachine) -> None:
        self.sites = list(sites)
        self.first = _Side([s.first for s in sites], at_end=True)
        self.second = _Side([s.second for s in sites], at_end=False)
        vmax, amax, jmax = machine.limits.per_axis()
        lim = []
        for s in sites:
            i1, i2, _ = PLANE_AXES[s.plane]
            lim.append((min(vmax[i1], vmax[i2]), min(amax[i1], amax[i2]), min(jmax[i1], jmax[i2])))
        self.plane_limits = np.array(lim, dtype=float).reshape(len(sites), 3)
        feed = [
            path_feed_mm_per_s(
                min(s.first.feed_mm_per_min, s.second.feed_mm_per_min), machine.feed_scale
            )
            for s in sites
        ]
        self.feed = np.minimum(np.array(feed, dtype=float), self.plane_limits[:, 0])
        caps = [
            min(move_speed_cap(s.first, machine), move_speed_cap(s.second, machine)) for s in sites
        ]
        self.target = np.minimum(self.feed, np.array(caps, dtype=float))
        zero = np.zeros(len(sites))
        _, t0, k0 = self.first.frame(zero)
        _, t1, k1 = self.second.frame(zero)
        self.jump = np.linalg.norm(k1 - k0, axis=1)
        self.dk_own = np.maximum(dot_rows(k0, k0), dot_rows(k1, k1))  # the moves' own |p'''|
        jerk = float(min(machine.limits.max_jerk_mm_per_s3))
        chord = [_chord_cap(s, machine.segmentation, jerk) for s in sites]
        kink = np.arccos(np.clip(np.einsum("ij,ij->i", t0, t1), -1.0, 1.0))
        self.chord_cap = np.array(
            [c(float(kink[i]), float(self.jump[i])) for i, c in enumerate(chord)], dtype=float
        ).reshape(len(sites))
        rooms = np.array([s.room_mm for s in sites], dtype=float).reshape(len(sites), 2)
        self.length_cap = LENGTH_SHARE * rooms.min(axis=1)

    def __len__(self) -> int:
        return len(self.sites)

    def subset(self, idx: np.ndarray) -> _Batch:
        out = object.__new__(_Batch)
        out.sites = [self.sites[i] for i in idx]
        out.first, out.second = self.first.subset(idx), self.second.subset(idx)
        for name in ("plane_limits", "feed", "target", "jump", "dk_own", "chord_cap", "length_cap"):
            setattr(out, name, getattr(self, name)[idx])
        return out

    def control_points(self, h: np.ndarray) -> np.ndarray:
        """The quintics' control points (n, 6, 3) [mm] for cuts ``h`` (n,) [mm]."""
        a, ta, ka = self.first.frame(h)
        b, tb, kb = self.second.frame(h)
        al = (2.0 * h)[:, None]
        ctrl = np.stack(
            [
                a,
                a + al / 5.0 * ta,
                a + 2.0 * al / 5.0 * ta + al * al / 20.0 * ka,
                b - 2.0 * al / 5.0 * tb + al * al / 20.0 * kb,
                b - al / 5.0 * tb,
                b,
            ],
            axis=1,
        )
        return ctrl

    def measure(
        self, h: np.ndarray, samples: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(control points (n, 6, 3), deviation of ``samples`` curve points from the two
        moves [mm], largest |p''| [1/mm] and |p'''| [1/mm^2] on as many points) for cuts ``h``
        (n,) [mm]."""
        ctrl = self.control_points(h)
        coef = power_coefficients(ctrl)
        t = np.broadcast_to(np.linspace(0.0, 1.0, samples), (len(h), samples))
        dev = self._from_moves(coef, t).max(axis=1)
        k, dk, _ = curvature_bounds(coef, samples)
        return ctrl, dev, k, dk

    def final(self, h: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`measure` on the curve's own bound samples, its deviation the larger of the
        curve's from the moves and the cut-away parts' from the curve, each refined near its
        largest sample (:func:`_refined_max`)."""
        ctrl = self.control_points(h)
        coef = power_coefficients(ctrl)
        grid = np.linspace(0.0, 1.0, BOUND_SAMPLES)
        d = self._from_moves(coef, np.broadcast_to(grid, (len(h), grid.size)))
        fwd = _refined_max(lambda t: self._from_moves(coef, t[:, None])[:, 0], grid, d)
        k, dk, _ = curvature_bounds(coef)
        return ctrl, np.maximum(fwd, self._to_curve(coef, h)), k, dk

    def _from_moves(self, coef: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Distance [mm] (n, k) of the curves' points at ``t`` (n, k) from the nearer of the
        two moves."""
        q = derivatives(coef, t, 0)[0]
        return np.minimum(self.first.distance(q), self.second.distance(q))

    def _to_curve(self, coef: np.ndarray, h: np.ndarray) -> np.ndarray:
        """Largest distance [mm] (n,) of the cut-away parts of both moves from the curves:
        :data:`CUT_SAMPLES` points of each, then refined near the largest."""
        n, k = len(h), CUT_SAMPLES
        share = np.linspace(0.0, 1.0, k)  # of the cut, from the junction
        # the curve runs over both parts at a nearly even pace: a cut-away point's nearest
        # parameter is near its share of the way (the first part runs back from t = 0.5)
        guess = np.concatenate([0.5 - 0.5 * share, 0.5 + 0.5 * share])
        zeros, ones = np.zeros(n), np.ones(n)

        def at(x: np.ndarray, first: np.ndarray) -> np.ndarray:
            """The cut-away points (n, 3) at shares ``x`` (n,) of the first or second part."""
            a, b = self.first.frame(x * h)[0], self.second.frame(x * h)[0]
            return np.where(first[:, None], a, b)

        cols = [at(np.full(n, x), np.full(n, side == 0)) for side in (0, 1) for x in share]
        q = np.stack(cols, axis=1)
        t = nearest_parameters(coef, q, zeros, ones, t_start=np.broadcast_to(guess, (n, 2 * k)))
        off = derivatives(coef, t, 0)[0] - q
        d = np.sqrt(dot_rows(off, off))
        first = d.argmax(axis=1) < k
        part = np.where(first[:, None], d[:, :k], d[:, k:])
        near = np.where(first[:, None], t[:, :k], t[:, k:])[np.arange(n), part.argmax(axis=1)]

        def gap(x: np.ndarray) -> np.ndarray:
            p = at(x, first)[:, None, :]
            tt = nearest_parameters(coef, p, zeros, ones, t_start=near[:, None])
            off = derivatives(coef, tt, 0)[0] - p
            return np.sqrt(dot_rows(off, off))[:, 0]

        return np.maximum(d.max(axis=1), _refined_max(gap, share, part))

    def curve_cap(self, k: np.ndarray, dk: np.ndarray) -> np.ndarray:
        """The curves' speed caps [mm/s] (n,) from their curvature bounds (:func:`curvature_speed_cap`
        at :data:`CAP_MARGIN`, under the feed and the plane's axis speeds)."""
        return np.array(
            [
                curvature_speed_cap(
                    float(self.feed[i]),
                    float(k[i]),
                    float(dk[i]),
                    float(self.plane_limits[i, 1]),
                    float(self.plane_limits[i, 2]),
                    CAP_MARGIN,
                )
                for i in range(len(k))
            ],
            dtype=float,
        ).reshape(len(k))


def _refined_max(
    f: Callable[[np.ndarray], np.ndarray], grid: np.ndarray, values: np.ndarray
) -> np.ndarray:
    """The largest of ``values`` (n, S), sampled on ``grid`` (S,), refined per row by
    :data:`GOLDEN_STEPS` golden-section steps of ``f`` (parameters (n,) -> values (n,))
    between the neighbours of its largest sample (a largest value between two samples
    would otherwise be missed: 0.2 % of a transition's deviation on 65 samples)."""
    i = values.argmax(axis=1)
    lo = grid[np.maximum(i - 1, 0)]
    hi = grid[np.minimum(i + 1, grid.size - 1)]
    best = values.max(axis=1)
    r = 0.5 * (math.sqrt(5.0) - 1.0)
    x1, x2 = hi - r * (hi - lo), lo + r * (hi - lo)
    f1, f2 = f(x1), f(x2)
    for _ in range(GOLDEN_STEPS):
        best = np.maximum(best, np.maximum(f1, f2))
        left = f1 > f2  # the largest lies in [lo, x2]
        hi, lo = np.where(left, x2, hi), np.where(left, lo, x1)
        x_new = np.where(left, hi - r * (hi - lo), lo + r * (hi - lo))
        f_new = f(x_new)
        x1, x2 = np.where(left, x_new, x2), np.where(left, x1, x_new)
        f1, f2 = np.where(left, f_new, f2), np.where(left, f1, f_new)
    return np.maximum(best, np.maximum(f1, f2))


def move_speed_cap(m: Linear | Arc, machine: TransitionMachine) -> float:
    """The highest speed [mm/s] ``m`` allows anywhere: its feed (times the override) and the
    axis speeds along it; an arc also its curvature caps v^2/R and v^3/R^2 against its plane's
    acceleration and jerk (at :data:`CAP_MARGIN`, with its smaller radius)."""
    vmax, amax, jmax = machine.limits.per_axis()
    feed = path_feed_mm_per_s(m.feed_mm_per_min, machine.feed_scale)
    if isinstance(m, Linear):
        d = np.subtract(m.end, m.start) / m.length_mm
        return min([feed] + [v / abs(x) for v, x in zip(vmax, d.tolist(), strict=True) if x])
    f = arc_frame(m)
    i1, i2 = f.i1, f.i2
    k = 1.0 / min(f.r0_mm, f.r1_mm)
    cap = min(feed, vmax[i1], vmax[i2])
    return curvature_speed_cap(
        cap, k, k * k, min(amax[i1], amax[i2]), min(jmax[i1], jmax[i2]), CAP_MARGIN
    )


def _chord_cap(site: TransitionSite, seg: Segmentation, jerk: float):
    """The junction's cap without a transition, as a function of (kink [rad], curvature jump
    [1/mm]): :func:`junction_cap` within the G64 budget and the shortest chord next to it, at
    :data:`CHORD_FIT_REACHED` (the planner halves the jump between two arcs: each side smooths
    half)."""
    chords = [_first_chord_mm(m, seg) for m in (site.first, site.second) if isinstance(m, Arc)]
    both = isinstance(site.first, Arc) and isinstance(site.second, Arc)

    def cap(kink: float, jump: float) -> float:
        return junction_cap(
            kink, 0.5 * jump if both else jump, site.budget_mm, jerk, min(chords), CHORD_FIT_REACHED
        )

    return cap


def _first_chord_mm(arc: Arc, seg: Segmentation) -> float:
    """Length [mm] of the chords of ``arc`` as the segmentation cuts it."""
    n = segment_count(arc, seg.method, seg.chord_tolerance_mm, seg.segment_length_mm)
    f = arc_frame(arc)
    return 2.0 * max(f.r0_mm, f.r1_mm) * math.sin(0.5 * arc.angle / n)


__all__ = [
    "TransitionCut",
    "TransitionMachine",
    "TransitionSite",
    "move_speed_cap",
    "size_transitions",
    "transition_site",
]
