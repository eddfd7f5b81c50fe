"""Exact arc states along a move's 1-D profile: where the reference passes through the arc.

The :class:`~gantry_sim.controller.planner.profile.Profile1D` is inverted at the vertices' arc
lengths, and each vertex gets the arc's exact state (position [mm], velocity [mm/s],
acceleration [mm/s^2]; :func:`vertex_states`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.moves import Arc, Transition
from gantry_sim.controller.planner.arc_batch import arc_derivatives_many, arc_points_many
from gantry_sim.controller.planner.junctions import EndState
from gantry_sim.controller.planner.knots import union_sorted
from gantry_sim.controller.planner.move_geometry import ArcGeometry
from gantry_sim.controller.planner.profile import Profile1D, invert_many
from gantry_sim.controller.planner.transition_geometry import (
    transition_derivatives_many,
    transition_lengths_many,
    transition_parameters_many,
    transition_speed_rates_many,
)

#: Extra vertices at 1/2, 1/4, ... of the first (last) chord of an arc that starts (ends) at rest.
STOP_REFINEMENT = 8
#: A loose end (:func:`vertex_states_many`) drops the profile's phase switches within this many
#: chords of it.
LOOSE_END_CHORDS = 0.5


@dataclass(frozen=True, eq=False)
class VertexStates:
    """The reference's states at k vertices along an arc.

    Attributes:
        u: sweep fractions (k,), 0 first and 1 last.
        positions: (k, 3) [mm], on the arc.
        velocities: (k, 3) [mm/s]; first and last: the move's end states.
        accelerations: (k, 3) [mm/s^2]; likewise.
        durations: (k - 1,) times between consecutive vertices [s].
    """

    u: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray
    durations: np.ndarray


def vertex_states(
    g: ArcGeometry, profile: Profile1D, state_in: EndState, state_out: EndState
) -> VertexStates:
    """Exact arc states where the reference passes through the arc (see
    :func:`vertex_states_many`)."""
    return vertex_states_many([(g, profile, state_in, state_out)])[0]


def vertex_states_many(
    requests: list[tuple[ArcGeometry, Profile1D, EndState, EndState]],
    loose: list[tuple[bool, bool]] | None = None,
) -> list[VertexStates]:
    """Exact arc states where the reference passes through each arc ``g`` along its
    ``profile``, between its end states: the profiles are inverted in one vectorised solve.

    Vertices: the chord vertices, plus the points where ``profile`` switches phase (within one
    phase the motion is smooth), plus, next to a stop, points at 1/2, 1/4, ... of the end chord
    (there the speed grows like s^(2/3); a piece across the whole chord would start along a
    straight line), the end chord first cut in steps of ``g.stop_step_u`` where longer.

    ``loose``: per request, whether its start and its end drop the phase switches within
    :data:`LOOSE_END_CHORDS` of a moving end. The piece next to a moving junction absorbs the
    junction's jumps (of curvature: the acceleration's direction), and a phase switch a
    millisecond from the junction left it a millisecond to do it: a blend arc of a Slic3r
    print whose profile ramps its tangential acceleration at full jerk there needed 250 times
    that. Without it the piece joins the junction to the next vertex in one closed form,
    across the switch (the planner checks it against the limits, the feed and the arc as any
    end piece). The planner tries it where the end offends with the switches kept.
    """
    if not requests:
        return []
    geoms = [r[0] for r in requests]
    knots = _per_curve(geoms, [r[1].s[1:] for r in requests], "u_at", transition_parameters_many)
    ends = loose or [(False, False)] * len(requests)
    made = [
        _fractions(g, s_in, s_out, kn, free)
        for (g, _, s_in, s_out), kn, free in zip(requests, knots, ends, strict=True)
    ]
    fractions = [u for u, _ in made]
    moved = [changed for _, changed in made]
    inner = [u[1:-1] for u in fractions]
    lengths = _per_curve(geoms, inner, "s_at", transition_lengths_many)
    inverted = invert_many([(r[1], s) for r, s in zip(requests, lengths, strict=True)])
    d1, d2 = _derivatives(geoms, inner)
    speed_u = np.linalg.norm(d1, axis=1)
    v_k = np.concatenate([inv[1] for inv in inverted])
    a_k = np.concatenate([inv[2] for inv in inverted])
    ud = (v_k / speed_u)[:, None]
    udd = (a_k / speed_u)[:, None]
    rates = _per_curve(geoms, inner, "speed_rate", transition_speed_rates_many)
    lo = 0
    for g, u, rate in zip(geoms, inner, rates, strict=True):
        if g.uneven:  # u'' = (a - v^2 d|dp/du|/du / |dp/du|) / |dp/du|: |dp/du| changes with u
            k = slice(lo, lo + u.size)
            udd[k, 0] -= v_k[k] ** 2 * rate / speed_u[k] ** 3
        lo += u.size
    vel_in = d1 * ud
    acc_in = d2 * ud * ud + d1 * udd
    # every arc's states in one table of rows: its end states first and last, the inner
    # vertices' between (each arc gets views of its rows: the same numbers as its own arrays)
    sizes = np.array([u.size for u in fractions], dtype=np.intp)
    stop = np.cumsum(sizes)
    first, last = stop - sizes, stop - 1
    inside = np.ones(int(stop[-1]), dtype=bool)
    inside[first], inside[last] = False, False
    vel, acc, times = np.empty((inside.size, 3)), np.empty((inside.size, 3)), np.empty(inside.size)
    vel[inside], acc[inside] = vel_in, acc_in
    vel[first] = [r[2].vel_mm_per_s for r in requests]
    vel[last] = [r[3].vel_mm_per_s for r in requests]
    acc[first] = [r[2].acc_mm_per_s2 for r in requests]
    acc[last] = [r[3].acc_mm_per_s2 for r in requests]
    times[inside] = np.concatenate([inv[0] for inv in inverted])
    times[first] = 0.0
    times[last] = [r[1].duration_s for r in requests]
    durations = np.maximum(np.diff(times), 0.0)  # across two arcs: never read
    verts = _vertices(geoms, fractions, moved)
    return [
        VertexStates(u, pts, vel[a:b], acc[a:b], durations[a : b - 1])
        for u, pts, a, b in zip(fractions, verts, first.tolist(), stop.tolist(), strict=True)
    ]


def _vertices(
    geoms: list[ArcGeometry], fractions: list[np.ndarray], moved: list[bool]
) -> list[np.ndarray]:
    """The points of each curve at its vertex parameters ``fractions[i]``: its own chord
    vertices where they are those (``moved[i]`` False: :func:`_fractions` changed none, or
    made the same ones again), else the curve's points there (arcs: in one batch, the same
    numbers as :meth:`ArcGeometry.points`)."""
    moved_to = [
        i
        for i, (g, u, changed) in enumerate(zip(geoms, fractions, moved, strict=True))
        if changed and not np.array_equal(u, g.u)
    ]
    arcs = [i for i in moved_to if isinstance(geoms[i].move, Arc)]
    moves = [m for m in (geoms[i].move for i in arcs) if isinstance(m, Arc)]
    points = dict(zip(arcs, arc_points_many(moves, [fractions[i] for i in arcs]), strict=True))
    for i in moved_to:
        if i not in points:  # a spline's or a transition's
            points[i] = geoms[i].points(fractions[i])
    return [points.get(i, g.vertices) for i, g in enumerate(geoms)]


def _per_curve(
    geoms: list[ArcGeometry],
    values: list[np.ndarray],
    method: str,
    many: Callable[[list[Transition], list[np.ndarray]], np.ndarray],
) -> list[np.ndarray]:
    """``g.<method>(values[i])`` of each curve (``s_at``, ``u_at``, ``speed_rate``), the
    transitions' in one batch (``many``: the same numbers for all at once); a curve that
    needs none (``speed_rate`` where u is its arc-length fraction) gets an empty array."""
    out: list[np.ndarray] = [np.zeros(0)] * len(geoms)
    at = [i for i, g in enumerate(geoms) if isinstance(g.move, Transition)]
    if at:
        moves = [m for m in (geoms[i].move for i in at) if isinstance(m, Transition)]
        flat = many(moves, [values[i] for i in at])
        cuts = np.cumsum([np.size(values[i]) for i in at])[:-1]
        for i, part in zip(at, np.split(flat, cuts), strict=True):
            out[i] = part
    for i, g in enumerate(geoms):
        if not isinstance(g.move, Transition) and (method != "speed_rate" or g.uneven):
            out[i] = getattr(g, method)(values[i])
    return out


def _derivatives(geoms: list[ArcGeometry], us: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Each curve's dp/du and d2p/du2 at its fractions ``us[i]``, stacked (the arcs' in one
    batch, the transitions' in another)."""
    counts = np.array([u.size for u in us], dtype=np.intp)
    start = np.concatenate(([0], np.cumsum(counts)[:-1])).astype(np.intp)
    d1 = np.empty((int(counts.sum()), 3))
    d2 = np.empty_like(d1)
    arcs = [i for i, g in enumerate(geoms) if isinstance(g.move, Arc)]
    if arcs:
        rows = np.concatenate([np.arange(start[i], start[i] + counts[i]) for i in arcs])
        moves = [m for m in (geoms[i].move for i in arcs) if isinstance(m, Arc)]
        a1, a2 = arc_derivatives_many(moves, [us[i] for i in arcs])
        d1[rows], d2[rows] = a1, a2
    steps = [i for i, g in enumerate(geoms) if isinstance(g.move, Transition)]
    if steps:
        rows = np.concatenate([np.arange(start[i], start[i] + counts[i]) for i in steps])
        curves = [m for m in (geoms[i].move for i in steps) if isinstance(m, Transition)]
        d1[rows], d2[rows] = transition_derivatives_many(curves, [us[i] for i in steps])
    for i, g in enumerate(geoms):
        if not isinstance(g.move, Arc | Transition):
            d1[start[i] : start[i] + counts[i]], d2[start[i] : start[i] + counts[i]] = (
                g.derivatives(us[i])
            )
    return d1, d2


def _fractions(
    g: ArcGeometry,
    state_in: EndState,
    state_out: EndState,
    knots: np.ndarray,
    loose: tuple[bool, bool] = (False, False),
) -> tuple[np.ndarray, bool]:
    """The parameters of the vertices (see :func:`vertex_states_many`), and whether they may
    differ from the chord vertices' ``g.u``; ``knots``: the parameters where the profile
    switches phase (``g.u_at(profile.s[1:])``); ``loose``: whether the start and the end drop
    those within :data:`LOOSE_END_CHORDS` of them."""
    # Each knot of the 1-D profile becomes a vertex: the nearest chord vertex moves onto it when
    # within a quarter chord (a piece much shorter than a chord would let rounding dominate its
    # jerk), or it is added. The reference only passes through exact arc states, so moving a
    # vertex along the arc does not move the reference off the arc.
    m = g.u.size - 1
    lo = LOOSE_END_CHORDS if loose[0] and state_in.moving else 0.0
    hi = m - LOOSE_END_CHORDS if loose[1] and state_out.moving else m
    snaps: dict[int, float] = {}
    extra: list[float] = []
    for uk in knots.tolist():  # Python floats: the same numbers, without a NumPy scalar each
        if not 0.0 < uk < 1.0 or not lo <= uk * m <= hi:
            continue
        i = round(uk * m)
        if 0 < i < m and abs(uk * m - i) < 0.25 and i not in snaps:
            snaps[i] = uk
        elif (
            abs(uk * m - i) > 1e-3
            # next to a stop every switch is kept: a ramp to a crawl ends within a thousandth
            # of a chord (F0.03 on a 0.1 um arc), and one piece over it and the cruise
            # overshot the feed by a third
            or (i == 0 and not state_in.moving)
            or (i == m and not state_out.moving)
        ):
            extra.append(uk)
    if not snaps and not extra and state_in.moving and state_out.moving and isinstance(g.move, Arc):
        return g.u.copy(), False  # an arc's u is arange(n + 1) / n: the steps below keep it
    u = g.u.copy()
    for i, uk in snaps.items():
        u[i] = uk
    u = union_sorted(u, extra)
    if not state_in.moving:
        u = _with_stop_steps(u, g.u[1], g.stop_step_u, 1.0)
        u = union_sorted(u, u[1] * _HALVES)
    if not state_out.moving:
        u = _with_stop_steps(u, 1.0 - g.u[-2], g.stop_step_u, -1.0)
        u = union_sorted(u, 1.0 - (1.0 - u[-2]) * _HALVES)
    apart = np.diff(u) > 1e-12
    if not apart.all():  # (union_sorted gave a new array: changed in place below)
        u = u[np.concatenate(([True], apart))]
    u[-1] = 1.0
    return u, True


#: 1/2, 1/4, ... of the end chord next to a stop (:data:`STOP_REFINEMENT` of them).
_HALVES = 0.5 ** np.arange(1, STOP_REFINEMENT + 1)
_HALVES.flags.writeable = False
#: Most equal steps an end chord next to a stop is cut into (:func:`_with_stop_steps`).
MAX_STOP_STEPS = 64


def _with_stop_steps(u: np.ndarray, chord_u: float, step_u: float, side: float) -> np.ndarray:
    """``u`` (sorted) with the end chord next to a stop cut in equal steps of at most
    ``step_u`` (ArcGeometry.stop_step_u; at most :data:`MAX_STOP_STEPS`), where the chord is
    longer: ``chord_u`` its length in u, ``side`` 1 at the start, -1 at the end. A step within a
    quarter step of a vertex already there (a phase switch) is left out: a piece much shorter
    than the others fails the limits on its closed form's rounding (a saturated ramp of an R2
    arc lost 12 ms so)."""
    if step_u >= chord_u:
        return u
    k = min(math.ceil(chord_u / step_u - 1e-9), MAX_STOP_STEPS)
    h = chord_u / k
    steps = h * np.arange(1, k) if side > 0 else 1.0 - h * np.arange(k - 1, 0, -1)
    at = np.clip(np.searchsorted(u, steps), 1, u.size - 1)
    near = np.minimum(np.abs(u[at] - steps), np.abs(steps - u[at - 1]))
    return union_sorted(u, steps[near >= 0.25 * h])
