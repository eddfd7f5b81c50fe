"""Ruckig behind one small object: the only module of the project that imports ``ruckig``.

:class:`RuckigSolver` is built once per :func:`gantry_sim.controller.planner.plan.plan` from the
machine's per-axis limits and passed to the steps that need it. It does two things:

* :meth:`RuckigSolver.profile`: the time-optimal 1-D profile along a move's path, from
  (0, v_in, 0) to (L, v_out, 0) under a speed cap, tangential acceleration and jerk limits;
* :meth:`RuckigSolver.piece`: a 3-DoF state-to-state piece under the axis limits, time
  synchronised, lasting at least a given time; where Ruckig rejects that, it is retried without
  the minimum duration (plain time-optimal), then with the axes it cannot plan (barely moving,
  or rejected even alone) following the closed-form piece between their states.

Failures are typed (:class:`RuckigRejected`, :class:`ProfileReverses`); the callers turn them
into a :class:`~gantry_sim.controller.errors.PlanningError` naming the line, or try something
else. Never ``intermediate_positions`` (the free Ruckig would send them to a cloud service).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import ruckig

from gantry_sim.controller.config import Limits
from gantry_sim.controller.errors import PlanningError
from gantry_sim.controller.planner.jerk3 import PiecePhases, jerk3_pairs, phase_speeds
from gantry_sim.controller.planner.profile import Profile1D
from gantry_sim.controller.planner.spaced import spaced

_OK = (ruckig.Result.Working, ruckig.Result.Finished)
#: an axis whose piece moves less than this, this slowly (or that Ruckig finds no profile for
#: alone) is planned in closed form when Ruckig rejects the piece (see
#: RuckigSolver._piece_with_closed_form_axes) [mm], [mm/s], [mm/s^2]
TINY_AXIS_MM = 1e-6
TINY_AXIS_MM_PER_S = 1e-2
TINY_AXIS_MM_PER_S2 = 10.0
#: Ruckig 0.19 rejects some 1-D profiles that lie exactly on the boundary between two of its
#: profile shapes (a 0.20000000000000284 mm move from rest to rest at acceleration 1000 mm/s^2
#: and jerk 100,000 mm/s^3, a Marlin printer's travel move, fails in its step 1 while 0.2 mm and
#: 0.2000000000001 mm plan). Such a profile is planned again with the acceleration and jerk
#: limits lowered by these shares, in turn: lower limits are still kept, and the profile is
#: longer by about the same share.
LIMIT_RETRY_SHARES = (1e-9, 1e-6)
#: How far [share of a limit] a piece whose states lie on the edge of the limits may pass them,
#: where Ruckig refuses it under the limits themselves (_calculate_to_the_edge;
#: 1e-11 and less gave one such piece a detour of 0.36 s instead of its 2 ms).
ROUNDING_BEYOND_LIMIT = 1e-10

#: The state at either end of a piece: position [mm], velocity [mm/s] and acceleration
#: [mm/s^2], each (3,).
State = tuple[np.ndarray, np.ndarray, np.ndarray]
#: Doublings of a piece's duration tried for an axis planned in closed form beside Ruckig's
#: (see RuckigSolver._piece_with_closed_form_axes), then bisection steps on that duration.
CLOSED_FORM_DOUBLINGS = 40
CLOSED_FORM_BISECTIONS = 40

#: Constant-jerk phases of one axis: durations [s] and each phase's start position [mm],
#: velocity [mm/s], acceleration [mm/s^2], and its jerk [mm/s^3].
AxisPhases = tuple[list[float], list[float], list[float], list[float], list[float]]


class SolverFailure(Exception):
    """The solver could not make the profile or piece asked for."""


class RuckigRejected(SolverFailure):
    """Ruckig returned an error result, or raised; ``reason`` says which (for messages)."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


class ProfileReverses(SolverFailure):
    """The 1-D profile Ruckig found would move backwards along the path somewhere."""


@dataclass(frozen=True, eq=False)
class RuckigPiece:
    """A 3-DoF piece.

    Attributes:
        duration_s: its duration [s] (longer than asked for where Ruckig needed more time).
        phases: per axis, its constant-jerk phases (:data:`AxisPhases`).
        positions: (n, 3) samples at n evenly spaced times from 0 to the duration [mm], when
            asked for (else None; the speed is checked exactly from the phases:
            :func:`~gantry_sim.controller.planner.piece_speed.peak_speed`).
    """

    duration_s: float
    phases: tuple[AxisPhases, AxisPhases, AxisPhases]
    positions: np.ndarray | None = None


def _calculate(otg: ruckig.Ruckig, inp: ruckig.InputParameter, traj: ruckig.Trajectory) -> None:
    """``otg.calculate`` into ``traj``. Raises :class:`RuckigRejected` on an error result, and
    for the RuckigError Ruckig raises on some numerically hard inputs."""
    try:
        res = otg.calculate(inp, traj)
    except ruckig.RuckigError as exc:
        raise RuckigRejected(f"RuckigError: {str(exc).strip().splitlines()[0]}") from None
    except ValueError as exc:  # a result code the binding's Result enum lacks (-101: duration)
        raise RuckigRejected(f"Ruckig result {str(exc).split(' ', 1)[0]}") from None
    if res not in _OK:
        raise RuckigRejected(f"{res}")


def _calculate_to_the_edge(
    otg: ruckig.Ruckig, inp: ruckig.InputParameter, traj: ruckig.Trajectory
) -> None:
    """:func:`_calculate`; where Ruckig refuses, again under limits raised by
    :data:`ROUNDING_BEYOND_LIMIT` (restored after). Where a state lies on the edge of what an
    axis can do, to the last bit (its velocity or acceleration beyond the limit by rounding,
    or reaching the velocity limit exactly on the way to the target), Ruckig refuses the
    piece; with the state put back onto the limit it took a detour fifty times as long. A hair
    more room gives the piece the states describe."""
    try:
        _calculate(otg, inp, traj)
        return
    except RuckigRejected:
        pass
    limits = inp.max_velocity, inp.max_acceleration, inp.max_jerk
    raised = 1.0 + ROUNDING_BEYOND_LIMIT
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = (
        [x * raised for x in lim] for lim in limits
    )
    try:
        _calculate(otg, inp, traj)
    finally:
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = limits


def _phases(prof: ruckig.Profile) -> AxisPhases:
    """Constant-jerk phases of one DoF's profile of a Ruckig trajectory (its brake phases first;
    ``Trajectory.profiles`` copies every profile each time it is read: read it once)."""
    dur, p, v, a, j = list(prof.t), prof.p[:7], prof.v[:7], prof.a[:7], list(prof.j)
    brake = prof.brake
    if brake.duration > 0:
        dur = list(brake.t) + dur
        p, v, a, j = brake.p[:2] + p, brake.v[:2] + v, brake.a[:2] + a, list(brake.j) + j
    return dur, p, v, a, j


#: The longest trajectory Ruckig computes [s]: above it a multi-DoF calculation returns
#: ErrorTrajectoryDuration (-101; ruckig/calculator_target.hpp, ``duration > 7.6e3``).
RUCKIG_MAX_DURATION_S = 7.6e3


def lowest_speed(rows: np.ndarray) -> float:
    """The lowest speed [mm/s] of a 1-D profile's phases ``rows`` (k, 5: duration, s, v, a, j
    at each phase's start): at the phases' ends and where a phase's acceleration passes zero
    inside it (v is quadratic in a phase). Ruckig's profile between two speeds a hair apart
    over a sliver of a line (0.1 nm left between an arc corner's blend and a line's) passed
    every phase start at 0 mm/s or more and went 0.38 mm back along the path in between."""
    low = math.inf
    for dur, _s, v, a, j in rows.tolist():  # floats: numpy costs more than the sums on 7 rows
        tau = min(max(-a / j, 0.0), dur) if j != 0.0 else 0.0  # jerk3.phase_speeds, scalar
        low = min(low, v, v + tau * (a + 0.5 * tau * j), v + dur * (a + 0.5 * dur * j))
    return low


def too_slow_for_ruckig(what: str, duration_s: float, line: int) -> PlanningError:
    """The error for ``what`` (a piece, a move) lasting ``duration_s`` [s] at its line's feed,
    beyond :data:`RUCKIG_MAX_DURATION_S`: the program's feed, not the planner, is at fault."""
    return PlanningError(
        f"at this line's feed {what} takes {duration_s:.4g} s; a jerk-limited profile can last "
        f"at most {RUCKIG_MAX_DURATION_S:g} s (Ruckig's numerical limit): raise the F",
        line=line,
    )


class RuckigSolver:
    """One 1-D and one 3-DoF Ruckig instance, reused for every profile and piece of a plan."""

    def __init__(self, limits: Limits) -> None:
        self._otg1 = ruckig.Ruckig(1)
        self._in1 = ruckig.InputParameter(1)
        self._tr1 = ruckig.Trajectory(1)
        self._otg3 = ruckig.Ruckig(3)
        self._in3 = ruckig.InputParameter(3)
        self._tr3 = ruckig.Trajectory(3)
        self._in3.max_velocity = list(limits.max_velocity_mm_per_s)
        self._in3.max_acceleration = list(limits.max_acceleration_mm_per_s2)
        self._in3.max_jerk = list(limits.max_jerk_mm_per_s3)

    def profile(
        self,
        length_mm: float,
        v_in: float,
        v_out: float,
        cap_mm_per_s: float,
        acc_mm_per_s2: float,
        jerk_mm_per_s3: float,
    ) -> Profile1D:
        """The time-optimal 1-D profile over ``length_mm`` from speed ``v_in`` to ``v_out``
        [mm/s], zero acceleration at both ends, under the cap and the tangential limits.

        Raises:
            RuckigRejected: Ruckig found no profile.
            ProfileReverses: the profile would move backwards somewhere.
        """
        inp = self._in1
        inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [v_in], [0.0]
        inp.target_position, inp.target_velocity = [length_mm], [v_out]
        inp.target_acceleration = [0.0]
        inp.max_velocity = [cap_mm_per_s]
        for share in (0.0, *LIMIT_RETRY_SHARES):  # see LIMIT_RETRY_SHARES
            inp.max_acceleration = [acc_mm_per_s2 * (1.0 - share)]
            inp.max_jerk = [jerk_mm_per_s3 * (1.0 - share)]
            try:
                _calculate(self._otg1, inp, self._tr1)
                break
            except RuckigRejected:
                if share == LIMIT_RETRY_SHARES[-1]:
                    raise
        rows = np.array(_phases(self._tr1.profiles[0][0]), dtype=float).T
        if lowest_speed(rows) < -1e-9 * max(cap_mm_per_s, 1.0):
            raise ProfileReverses()
        return Profile1D(rows)

    def piece(
        self,
        start: tuple[np.ndarray, np.ndarray, np.ndarray],
        end: tuple[np.ndarray, np.ndarray, np.ndarray],
        min_duration_s: float,
        samples: int = 0,
        sampled_within_s: float = math.inf,
    ) -> RuckigPiece:
        """The time-synchronised piece from state ``start`` to ``end`` (position [mm], velocity
        [mm/s], acceleration [mm/s^2], each (3,)) lasting at least ``min_duration_s``; where
        Ruckig rejects that, the time-optimal piece. ``samples``: how many evenly spaced
        positions to return with it (0: none) when it lasts at most ``sampled_within_s`` [s]
        (a caller that rejects longer pieces needs no samples of them).

        Raises:
            RuckigRejected: Ruckig found no piece even without the minimum duration.
        """
        inp, tr = self._in3, self._tr3
        inp.current_position, inp.current_velocity = start[0].tolist(), start[1].tolist()
        inp.current_acceleration = start[2].tolist()
        inp.target_position, inp.target_velocity = end[0].tolist(), end[1].tolist()
        inp.target_acceleration = end[2].tolist()
        inp.minimum_duration = float(min_duration_s)
        try:
            _calculate_to_the_edge(self._otg3, inp, tr)
        except RuckigRejected:
            inp.minimum_duration = None
            try:
                _calculate_to_the_edge(self._otg3, inp, tr)
            except RuckigRejected:
                return self._piece_with_closed_form_axes(
                    start, end, min_duration_s, samples, sampled_within_s
                )
        dur = tr.duration
        if dur > sampled_within_s:
            samples = 0
        profs = tr.profiles[0]
        phases = (_phases(profs[0]), _phases(profs[1]), _phases(profs[2]))
        if not samples:
            return RuckigPiece(dur, phases)
        pos = [tr.at_time(t)[0] for t in spaced(dur, samples).tolist()]
        return RuckigPiece(dur, phases, np.array(pos))

    def _piece_with_closed_form_axes(
        self,
        start: tuple[np.ndarray, np.ndarray, np.ndarray],
        end: tuple[np.ndarray, np.ndarray, np.ndarray],
        min_duration_s: float,
        samples: int,
        sampled_within_s: float,
    ) -> RuckigPiece:
        """The piece when Ruckig rejects it because an axis barely moves (on an arc near a
        quadrant point one axis may move 1e-8 mm at 1e-5 mm/s, below Ruckig's numerical
        resolution), or because one axis alone is a state pair Ruckig finds no profile for
        (a blend arc's last chord: 5e-8 mm while turning 16 mm/s^2 of acceleration to rest,
        from FlatCAM grbl output). Ruckig plans the other axes, and each such axis follows the
        closed-form three-phase constant-jerk piece between its states over the same time,
        which must keep its limits. Where it would not (the others' piece is short, and the
        axis must still change its acceleration), the piece is made longer: the shortest
        duration the closed-form axes fit in (:meth:`_closed_form_duration`), which the caller
        sees as a stretched piece and answers by slowing the junction. Where Ruckig cannot
        synchronise the axes it plans to the others' time (an axis a hair below its top
        speed whose time-optimal piece is 16 ns shorter than the piece: "error in step 2"),
        or no axis is tiny, every axis follows the closed form (:meth:`_every_axis_closed`).
        Raises RuckigRejected when that fails too."""
        p0, v0, a0 = start
        p1, v1, a1 = end
        tiny = (
            (np.abs(p1 - p0) < TINY_AXIS_MM)
            & (np.maximum(np.abs(v0), np.abs(v1)) < TINY_AXIS_MM_PER_S)
            & (np.maximum(np.abs(a0), np.abs(a1)) < TINY_AXIS_MM_PER_S2)
        )
        inp, tr = self._in3, self._tr3
        vmax, amax, jmax = self._limits3()
        for i in np.flatnonzero(~tiny):
            tiny[i] = not self._axis_plans(
                (p0[i], v0[i], a0[i]), (p1[i], v1[i], a1[i]), vmax[i], amax[i], jmax[i]
            )
        if tiny.all() or not tiny.any():  # no Ruckig piece to set the duration, or none made
            return self._every_axis_closed(start, end, min_duration_s, (samples, sampled_within_s))
        closed_form = _closed_form_fit(start, end, tiny, vmax, amax, jmax)
        inp.enabled = [not bool(t) for t in tiny]
        try:
            inp.minimum_duration = float(min_duration_s)
            _calculate_to_the_edge(self._otg3, inp, tr)
            closed, ok = closed_form(tr.duration)
            if not ok:  # longer, so that the tiny axes keep their limits (the caller sees it)
                longer = self._closed_form_duration(tr.duration, closed_form)
                inp.minimum_duration = longer
                _calculate_to_the_edge(self._otg3, inp, tr)
                closed, ok = closed_form(tr.duration)
        except RuckigRejected:  # the other axes not synchronised: none from Ruckig
            return self._every_axis_closed(start, end, min_duration_s, (samples, sampled_within_s))
        finally:
            inp.enabled = [True, True, True]
        if not ok:
            raise RuckigRejected("no piece: an axis planned in closed form would exceed its limits")
        dur = tr.duration
        return _assemble(dur, closed, tiny, tr, samples if dur <= sampled_within_s else 0)

    def _every_axis_closed(
        self, start: State, end: State, min_duration_s: float, samples: tuple[int, float]
    ) -> RuckigPiece:
        """The piece with every axis on the closed-form three-phase constant-jerk piece
        between its states, over ``min_duration_s`` [s] (at least 1 ns) or the shortest
        longer duration whose piece keeps every axis' limits (as :func:`_closed_form_fit`
        checks them); ``samples``: how many positions to return with it, if it lasts at most
        how long [s]. Raises RuckigRejected when none does."""
        every = np.ones(3, dtype=bool)
        closed_form = _closed_form_fit(start, end, every, *self._limits3())
        dur = max(float(min_duration_s), 1e-9)
        closed, ok = closed_form(dur)
        if not ok:
            dur = self._closed_form_duration(dur, closed_form)
            closed, ok = closed_form(dur)
        if not ok:
            raise RuckigRejected("no piece: no closed-form piece keeps the limits")
        return _assemble(dur, closed, every, None, samples[0] if dur <= samples[1] else 0)

    def _limits3(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The 3-DoF input's velocity, acceleration and jerk limits, as arrays (3,)."""
        inp = self._in3
        vmax, amax, jmax = (
            np.asarray(x) for x in (inp.max_velocity, inp.max_acceleration, inp.max_jerk)
        )
        return vmax, amax, jmax

    def _axis_plans(
        self,
        start: tuple[float, float, float],
        end: tuple[float, float, float],
        vmax: float,
        amax: float,
        jmax: float,
    ) -> bool:
        """Whether Ruckig plans one axis alone from ``start`` to ``end`` (position [mm],
        velocity [mm/s], acceleration [mm/s^2]) under its limits, time-optimally."""
        inp = self._in1
        inp.current_position, inp.current_velocity, inp.current_acceleration = (
            [float(x)] for x in start
        )
        inp.target_position, inp.target_velocity, inp.target_acceleration = (
            [float(x)] for x in end
        )
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = [vmax], [amax], [jmax]
        try:
            _calculate_to_the_edge(self._otg1, inp, self._tr1)
        except RuckigRejected:
            return False
        return True

    @staticmethod
    def _closed_form_duration(start_s: float, closed_form) -> float:
        """The shortest duration [s] from ``start_s`` on (to within 2^-CLOSED_FORM_BISECTIONS of
        it) over which ``closed_form(duration)[1]`` holds: the closed-form axes' piece keeps
        their limits (its jerks fall as the piece gets longer); ``start_s`` if none is found."""
        lo, hi = start_s, start_s
        for _ in range(CLOSED_FORM_DOUBLINGS):
            hi *= 2.0
            if closed_form(hi)[1]:
                break
            lo = hi
        else:
            return start_s
        for _ in range(CLOSED_FORM_BISECTIONS):
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if closed_form(mid)[1] else (mid, hi)
        return hi


def _closed_form_fit(
    start: State,
    end: State,
    axes: np.ndarray,
    vmax: np.ndarray,
    amax: np.ndarray,
    jmax: np.ndarray,
) -> Callable[[float], tuple[PiecePhases, bool]]:
    """``closed_form(duration_s)``: the closed-form three-phase constant-jerk piece from state
    ``start`` to ``end`` (position [mm], velocity [mm/s], acceleration [mm/s^2], each (3,))
    over ``duration_s`` [s], and whether it keeps the limits of the ``axes`` (bool (3,)):
    velocity (at each phase's ends and where its acceleration crosses zero), acceleration
    (at each phase's ends: it is linear in between) and jerk, each to
    :data:`ROUNDING_BEYOND_LIMIT` of the limit (a state may lie beyond it by rounding, as
    :func:`_calculate_to_the_edge` allows Ruckig's)."""
    p0, v0, a0 = start
    p1, v1, a1 = end
    raised = 1.0 + ROUNDING_BEYOND_LIMIT
    lim = vmax[axes] * raised, amax[axes] * raised, jmax[axes] * raised

    def closed_form(duration_s: float) -> tuple[PiecePhases, bool]:
        c = jerk3_pairs(
            p0[None], v0[None], a0[None], p1[None], v1[None], a1[None], np.array([duration_s])
        )
        h = duration_s / 3.0
        v, a, j = (x[0][:, axes] for x in (c.v, c.a, c.j))  # (3 phases, axes)
        speeds = [v, *phase_speeds(v, a, j, h)]
        ok = (
            all(np.all(np.abs(x) <= lim[0]) for x in speeds)
            and np.all(np.abs(a) <= lim[1])
            and np.all(np.abs(a + h * j) <= lim[1])
            and np.all(np.abs(j) <= lim[2])
        )
        return c, bool(ok)

    return closed_form


def _assemble(
    dur: float,
    closed: PiecePhases,
    tiny: np.ndarray,
    tr: ruckig.Trajectory | None,
    samples: int,
) -> RuckigPiece:
    """The piece of duration ``dur`` [s] whose ``tiny`` axes follow the closed-form phases
    ``closed`` and the others Ruckig's trajectory ``tr`` (None: every axis is tiny)."""
    h = dur / 3.0
    profs = None if tr is None else tr.profiles[0]
    phases = tuple(
        ([h, h, h], *(closed[q][0, :, i].tolist() for q in range(4)))
        if tiny[i] or profs is None
        else _phases(profs[i])
        for i in range(3)
    )
    if not samples:
        return RuckigPiece(dur, phases)  # type: ignore[arg-type]
    times = spaced(dur, samples)
    pos = np.zeros((samples, 3))
    if tr is not None:
        pos = np.array([tr.at_time(t)[0] for t in times.tolist()])
    k = np.minimum((times / h).astype(int), 2)
    tau = times - k * h
    for i in np.flatnonzero(tiny):
        cp, cv, ca, cj = (closed[q][0, k, i] for q in range(4))
        pos[:, i] = cp + cv * tau + ca * tau**2 / 2 + cj * tau**3 / 6
    return RuckigPiece(dur, phases, pos)  # type: ignore[arg-type]
