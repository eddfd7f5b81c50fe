"""sim/move_table.py builds its table for all moves at once (numpy, and Python's math functions
mapped over the rows); every field of every row must be, bit for bit, what the one-move loop it
replaced gives: :func:`_reference_table` below, a copy of that loop, is the definition."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.arcs import arc_frame
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.moves import Arc, Linear, PathMove, Rapid, Spline, Transition
from gantry_sim.controller.planes import PLANE_AXES
from gantry_sim.sim.move_table import (
    _ARC_FIELDS,
    _QUADRANTS,
    BOX_SLACK_MM,
    MoveTable,
    _arc_boxes,
    _arc_frames,
    _lengths,
    _spline_box,
    move_table,
)


def _arc_box(
    arc: Arc, i1: int, i2: int, theta0: float, sigma: float, r0: float, r1: float
) -> tuple[float, ...]:
    """A box [mm] holding the arc (with its start and end: the caller's box has them too): in
    the plane, the box of the annular sector the arc sweeps between its smaller and larger
    radius -- the sector's extremes lie at its two end angles and at every quadrant angle
    (theta = k pi / 2) the sweep passes, each at either radius (a spiral's radius goes
    between r0 and r1, so a point just before the end may lie beyond the end point: the box
    of the start, end and quadrant points widened by |r1 - r0| about the start missed it by
    38 nm on an R 34 arc of 1 degree whose radius shrank by 4 um). (lo x y z, hi x y z), in
    Python floats: the box sim/move_table.py took arc by arc, and the definition its
    ``_arc_boxes`` must give bit for bit."""
    radii = (r0, r1)
    lo, hi = list(arc.start), list(arc.start)
    c1, c2 = arc.center[i1], arc.center[i2]
    theta1 = theta0 + sigma * arc.angle
    at = [(math.cos(theta0), math.sin(theta0)), (math.cos(theta1), math.sin(theta1))]
    full = arc.angle >= 2 * math.pi
    for phi, cos_k, sin_k in _QUADRANTS:
        if full or (sigma * (phi - theta0)) % (2 * math.pi) <= arc.angle:
            at.append((cos_k, sin_k))
    for cos_a, sin_a in at:
        for r in radii:
            v1, v2 = c1 + r * cos_a, c2 + r * sin_a
            lo[i1], hi[i1] = min(lo[i1], v1), max(hi[i1], v1)
            lo[i2], hi[i2] = min(lo[i2], v2), max(hi[i2], v2)
    return (*lo, *hi)


def _reference_table(moves: list[PathMove], cum_len: np.ndarray | None = None) -> MoveTable:
    """move_table as it was, one move at a time (arc_frame and _arc_box per arc): the oracle."""
    m = len(moves)
    start = np.array([mv.start for mv in moves], dtype=float).reshape(m, 3)
    end = np.array([mv.end for mv in moves], dtype=float).reshape(m, 3)
    seg_d = end - start
    length2 = np.array([float(d @ d) for d in seg_d])
    axes = np.zeros((m, 3), dtype=np.intp)
    cols = {name: np.zeros(m) for name in _ARC_FIELDS}
    turns = np.zeros(m, dtype=np.intp)
    newton = np.zeros(m, dtype=bool)
    box_lo, box_hi = np.minimum(start, end), np.maximum(start, end)
    arc_rows: list[int] = []
    arc_cols: list[tuple[float, ...]] = []
    arc_boxes: list[tuple[float, ...]] = []
    for j, mv in enumerate(moves):
        if isinstance(mv, Spline | Transition):
            lo_j, hi_j = _spline_box(mv)
            box_lo[j] = np.minimum(box_lo[j], lo_j)
            box_hi[j] = np.maximum(box_hi[j], hi_j)
        if not isinstance(mv, Arc):
            continue
        i1, i2, n, theta0, sigma, r0, r1, h0, h1 = arc_frame(mv)
        axes[j] = (i1, i2, n)
        s_angle = sigma * mv.angle
        dr = r1 - r0
        row = (mv.center[i1], mv.center[i2], theta0, sigma, mv.angle, s_angle, r0, dr, h0)
        arc_rows.append(j)
        arc_cols.append((*row, h1 - h0, 2.0 * dr * s_angle))
        turns[j] = math.ceil(mv.angle / (2.0 * math.pi))
        newton[j] = h1 != h0 or r1 != r0
        arc_boxes.append(_arc_box(mv, i1, i2, theta0, sigma, r0, r1))
    arcs = np.array(arc_rows, dtype=np.intp)
    is_arc = np.zeros(m, dtype=bool)
    is_arc[arcs] = True
    arc_start = start.copy()
    if arcs.size:
        for name, column in zip(_ARC_FIELDS, np.array(arc_cols).T, strict=True):
            cols[name][arcs] = column
        boxes = np.array(arc_boxes).reshape(-1, 2, 3)
        box_lo[arcs] = np.minimum(box_lo[arcs], boxes[:, 0])
        box_hi[arcs] = np.maximum(box_hi[arcs], boxes[:, 1])
        u0 = np.zeros(arcs.size)
        theta = cols["theta0"][arcs] + cols["s_angle"][arcs] * u0
        r = cols["r0"][arcs] + cols["dr"][arcs] * u0
        rows = np.arange(arcs.size)
        at = arc_start[arcs]
        at[rows, axes[arcs, 0]] = cols["c1"][arcs] + r * np.cos(theta)
        at[rows, axes[arcs, 1]] = cols["c2"][arcs] + r * np.sin(theta)
        at[rows, axes[arcs, 2]] = cols["h0"][arcs] + cols["dh"][arcs] * u0
        arc_start[arcs] = at
    if cum_len is None:
        cum_len = np.concatenate([[0.0], np.cumsum([mv.length_mm for mv in moves])])
    return MoveTable(
        line=np.array([mv.line for mv in moves], dtype=np.int64),
        feed=np.array([mv.kind != "rapid" for mv in moves], dtype=bool),
        arc=is_arc,
        start=start,
        end=end,
        seg_d=seg_d,
        length2=length2,
        axes=axes,
        turns=turns,
        newton=newton,
        box_lo=box_lo - BOX_SLACK_MM,
        box_hi=box_hi + BOX_SLACK_MM,
        arc_start=arc_start,
        cum_len=np.asarray(cum_len, dtype=float),
        spline=np.array([isinstance(mv, Spline | Transition) for mv in moves], dtype=bool),
        curves=tuple(mv.curve if isinstance(mv, Spline | Transition) else None for mv in moves),
        **cols,
    )


def _assert_same(new: MoveTable, ref: MoveTable) -> None:
    """Every field equal bit for bit (same dtype and shape); curves the same curve."""
    for field in dataclasses.fields(MoveTable):
        a, b = getattr(new, field.name), getattr(ref, field.name)
        if field.name == "curves":
            assert len(a) == len(b)
            for ca, cb in zip(a, b, strict=True):
                assert type(ca) is type(cb)
                # a spline's curve is kept per move; a transition's is read anew from its row
                assert ca is cb or np.array_equal(ca.row, cb.row)
            continue
        assert a.dtype == b.dtype, field.name
        assert a.shape == b.shape, field.name
        assert a.tobytes() == b.tobytes(), field.name


def _check(moves: list[PathMove]) -> None:
    tab = move_table(moves)
    _assert_same(tab, _reference_table(moves))
    # each move's length, too (the cumulative sum can hide a last bit of one of them)
    arcs = np.flatnonzero(tab.arc)
    arc_moves = [moves[j] for j in arcs.tolist()]
    frames = _arc_frames(arc_moves, tab.start[arcs], tab.end[arcs]) if arcs.size else None
    straight = np.array([isinstance(mv, Linear | Rapid) for mv in moves], dtype=bool)
    lengths = _lengths(moves, tab.seg_d, straight, arcs, frames)
    assert lengths.tobytes() == np.array([mv.length_mm for mv in moves], dtype=float).tobytes()
    cum_len = np.cumsum(np.arange(len(moves) + 1, dtype=float)) / 7.0
    _assert_same(move_table(moves, cum_len), _reference_table(moves, cum_len))


# --- random moves -----------------------------------------------------------------------------

#: starts on an axis through the centre, (cos, sin) of their angle: the quadrant test meets them
#: exactly, and with a signed zero (and a centre coordinate -0.0) the box's min and max meet ties
#: of 0.0 and -0.0 (theta0 is pi or -pi by the zero's sign)
_AXIS_OFFSETS = (
    (1.0, 0.0), (1.0, -0.0), (-1.0, 0.0), (-1.0, -0.0),
    (0.0, 1.0), (-0.0, 1.0), (0.0, -1.0), (-0.0, -1.0),
)  # fmt: skip
_coord = st.one_of(
    st.sampled_from([0.0, -0.0, 1.0, -1.0, 1e-300, 0.1]),
    st.floats(-1e3, 1e3, allow_nan=False),
    st.floats(-1e6, 1e6, allow_nan=False),
)
_point = st.tuples(_coord, _coord, _coord)
_radius = st.one_of(st.floats(1e-9, 1e-3), st.floats(1e-3, 500.0), st.sampled_from([1.0, 0.5]))
_sweep = st.one_of(
    st.sampled_from([math.pi / 2, math.pi, 1.5 * math.pi, 2 * math.pi, 4 * math.pi, 3 * math.pi]),
    st.floats(1e-12, 1e-6),
    st.floats(1e-6, 2 * math.pi),
    st.floats(2 * math.pi, 20.0),  # more than a turn (P2, P3)
)


def _make_arc(
    plane: str,
    direction: str,
    centre: tuple[float, float, float],
    radius: float,
    start_at: float | tuple[float, float],
    angle: float,
    spiral: float = 0.0,
    rise: float = 0.0,
    closed: bool = False,
    line: int = 1,
) -> Arc:
    """An arc about ``centre`` [mm] from polar angle ``start_at`` [rad] (or from the start
    offset (cos, sin) * radius) sweeping ``angle`` [rad] (< 0: to the quadrant angle
    -angle - 1 times pi / 2 exactly, as _arc_box's test reckons the sweep to it), its end
    radius off by ``spiral`` and its end ``rise`` [mm] along the normal (a helix); ``closed``:
    the end is the start (a full circle)."""
    sigma = 1.0 if direction == "ccw" else -1.0
    i1, i2, n = PLANE_AXES[plane]
    if isinstance(start_at, tuple):
        a0 = math.atan2(start_at[1], start_at[0])
        off = (start_at[0] * radius, start_at[1] * radius)
    else:
        a0 = start_at
        off = (radius * math.cos(a0), radius * math.sin(a0))
    start, end, centre_ = list(centre), list(centre), list(centre)
    start[i1], start[i2] = centre[i1] + off[0], centre[i2] + off[1]
    if angle < 0:
        theta0 = math.atan2(start[i2] - centre[i2], start[i1] - centre[i1])
        phi = (-angle - 1) * math.pi / 2
        angle = (sigma * (phi - theta0)) % (2 * math.pi) or 2 * math.pi
    a1 = a0 + sigma * angle
    end[i1] = centre[i1] + (radius + spiral) * math.cos(a1)
    end[i2] = centre[i2] + (radius + spiral) * math.sin(a1)
    end[n] = start[n] + rise
    if closed:
        end = list(start)
    centre_[n] = start[n]
    return Arc(
        line=line,
        start=(start[0], start[1], start[2]),
        end=(end[0], end[1], end[2]),
        feed_mm_per_min=1000.0,
        plane=plane,  # type: ignore[arg-type]
        direction=direction,  # type: ignore[arg-type]
        center=(centre_[0], centre_[1], centre_[2]),
        radius=radius,
        turns=max(1, math.ceil(angle / (2 * math.pi))),
        angle=angle,
    )


@st.composite
def _arcs(draw: st.DrawFn) -> Arc:
    on_axis = draw(st.booleans())  # the start exactly on an axis through the centre
    return _make_arc(
        plane=draw(st.sampled_from(["XY", "XZ", "YZ"])),
        direction=draw(st.sampled_from(["cw", "ccw"])),
        centre=draw(_point),
        radius=draw(_radius),
        start_at=draw(st.sampled_from(_AXIS_OFFSETS) if on_axis else st.floats(-4.0, 4.0)),
        angle=draw(st.one_of(_sweep, st.integers(-4, -1).map(float))),
        spiral=draw(st.one_of(st.just(0.0), st.floats(-1e-2, 1e-2))),
        rise=draw(st.one_of(st.just(0.0), st.floats(-50.0, 50.0))),
        closed=draw(st.integers(0, 9)) == 0,
        line=draw(st.integers(1, 10**6)),
    )


@st.composite
def _segments(draw: st.DrawFn) -> Linear | Rapid:
    start = draw(_point)
    end = start if draw(st.integers(0, 4)) == 0 else draw(_point)  # zero length, too
    line = draw(st.integers(1, 10**6))
    if draw(st.booleans()):
        return Rapid(line=line, start=start, end=end)
    return Linear(line=line, start=start, end=end, feed_mm_per_min=500.0)


@given(moves=st.lists(st.one_of(_arcs(), _segments(), _arcs()), max_size=25))
@settings(max_examples=250, deadline=None)
def test_the_batch_table_is_the_one_move_tables(moves: list[PathMove]) -> None:
    _check(moves)


@given(arcs=st.lists(_arcs(), min_size=1, max_size=20))
@settings(max_examples=100, deadline=None)
def test_the_batch_boxes_are_arc_box(arcs: list[Arc]) -> None:
    _assert_boxes(arcs)


def _assert_boxes(arcs: list[Arc]) -> None:
    """_arc_boxes gives, bit for bit, every arc's _arc_box."""
    start = np.array([a.start for a in arcs], dtype=float)
    end = np.array([a.end for a in arcs], dtype=float)
    lo, hi = _arc_boxes(start, _arc_frames(arcs, start, end))
    for k, a in enumerate(arcs):
        i1, i2, _, theta0, sigma, r0, r1, _, _ = arc_frame(a)
        box = np.array(_arc_box(a, i1, i2, theta0, sigma, r0, r1))
        assert box.tobytes() == np.concatenate([lo[k], hi[k]]).tobytes()


def test_thousands_of_random_arcs() -> None:
    # many more arcs than the property tests see (a rare rounding, e.g. math.hypot's, shows)
    rng = np.random.default_rng(11)
    moves: list[PathMove] = []
    for k in range(4000):
        on_axis = rng.random() < 0.3
        moves.append(
            _make_arc(
                plane=("XY", "XZ", "YZ")[k % 3],
                direction=("cw", "ccw")[int(rng.integers(2))],
                centre=tuple(rng.uniform(-500.0, 500.0, 3).tolist()),  # type: ignore[arg-type]
                radius=float(10.0 ** rng.uniform(-4.0, 2.5)),
                start_at=_AXIS_OFFSETS[k % 8] if on_axis else float(rng.uniform(-4.0, 4.0)),
                angle=float(rng.choice([-1 - k % 4, rng.uniform(1e-9, 7.0), 2 * math.pi, 13.0])),
                spiral=float(rng.uniform(-1e-2, 1e-2)) if rng.random() < 0.5 else 0.0,
                rise=float(rng.uniform(-20.0, 20.0)) if rng.random() < 0.5 else 0.0,
                line=k + 1,
            )
        )
        if k % 3 == 0:
            p, q = rng.uniform(-500.0, 500.0, (2, 3)).tolist()
            moves.append(Linear(k + 1, (p[0], p[1], p[2]), (q[0], q[1], q[2]), 800.0))
    _check(moves)


def test_signed_zero_ties_in_the_boxes() -> None:
    # the starts on an axis through a centre at +-0.0: the box's min and max meet 0.0 and -0.0;
    # _arc_box keeps the first of them (the table's slack hides it, _arc_boxes must not)
    arcs = [
        _make_arc(plane, direction, (zero, zero, zero), radius, at, angle)
        for plane in ("XY", "XZ", "YZ")
        for direction in ("cw", "ccw")
        for zero in (0.0, -0.0)
        for radius in (1.0, 0.3)
        for at in _AXIS_OFFSETS
        for angle in (0.25, 1.0, math.pi / 2, math.pi, 2 * math.pi, -1.0, -2.0, -3.0, -4.0)
    ]
    _assert_boxes(arcs)


def test_squared_lengths_are_the_per_row_dot() -> None:
    # float(d @ d) may fuse multiply-adds (BLAS ddot); the table's batch must give its numbers
    rng = np.random.default_rng(7)
    rows = 20_000
    mant = rng.uniform(-1.0, 1.0, (rows, 3))
    d = np.ldexp(mant, rng.integers(-520, 500, (rows, 3)))
    d[: rows // 4] = mant[: rows // 4]  # like exponents, where fused rounding shows most
    d[: rows // 8, 1] = d[: rows // 8, 0] * (1.0 + 2.0**-30)
    d[rows // 8 : rows // 4, 2] = 0.0
    moves = [Linear(1, (0.0, 0.0, 0.0), (x, y, z), 100.0) for x, y, z in d.tolist()]
    tab = move_table(moves)
    assert tab.length2.tobytes() == np.array([float(v @ v) for v in tab.seg_d]).tobytes()


def test_an_empty_table() -> None:
    _check([])


# --- the interpreter's and the planner's moves ------------------------------------------------


def test_interpreted_moves() -> None:
    text = (
        "G21 G90 G17\nG0 X0 Y0 Z0\nG2 X10 Y0 I5 J0 F1000\nG18 G3 X0 Z5 I-5 K2.5\nG1 X3\n"
        "G19 G2 Y4 Z1 J2 K-2 P3\nG17 G3 X3 Y4 Z2 I-1 J0 P2\n"
        "G5 I2 J2 P-2 Q2 X10 Y4\nG5.1 I1 J-1 X12 Y6\nM2\n"
    )
    moves = parse_program(text)
    assert {type(m) for m in moves} == {Rapid, Linear, Arc, Spline}
    _check(list(moves))


def test_a_planned_path() -> None:
    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.controller.planner import plan
    from gantry_sim.models import DEFAULT_MACHINE

    lines = ["G21 G90 G17 G64 P0.01", "G0 X0 Y0 Z0", "F2000"]
    lines += [
        f"G1 X{10 * math.cos(i * 0.7) + i:.3f} Y{10 * math.sin(i * 0.9):.3f}" for i in range(40)
    ]
    lines += ["G1 X40 Y0", "G2 X50 Y0 I5 J0", "G3 X60 Y0 R5", "G1 X70 Y5"]
    lines += ["G5 I2 J2 P-2 Q2 X80 Y0", "G1 X90", "G18 G2 X100 Y2 I5 K0", "G1 X110", "M2"]
    moves = parse_program("\n".join(lines))
    path = plan(moves, load_machine_config(DEFAULT_MACHINE)).path_moves
    kinds = {type(m) for m in path}
    assert {Arc, Linear, Transition, Spline} <= kinds
    _check(list(path))
    _check(list(moves))
