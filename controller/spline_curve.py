"""A spline move's curve by arc length: length, points, derivatives and nearest points.

The planner and the analysis parametrise every curve by the fraction sigma = s / L of its arc
length s [mm] (L: the whole length), as arcs are (their sweep fraction is one). The spline's own
parameter t (:class:`~gantry_sim.controller.nurbs.Nurbs`) maps to s by

    s(t) = integral of |C'(t)| dt,

computed per cell of a fine grid (:data:`CELLS_PER_SPAN` cells per knot span) by 8-point
Gauss-Legendre quadrature (exact for a polynomial speed of degree 15; relative error far below
1e-9 for every spline LinuxCNC accepts), and inverted by safeguarded Newton steps on t
(bisection inside the grid cell where a step would leave it). With sigma, dp/dsigma = L T and
d2p/dsigma2 = L^2 k (T: unit tangent, k: curvature vector [1/mm]).

A zero-speed end (a G5 whose first control point equals its start, ``I0 J0``) has its tangent
along the first non-zero derivative there; its curvature is taken a hair inside the curve.
"""

from __future__ import annotations

import itertools
from functools import cached_property

import numpy as np

from gantry_sim.controller.nurbs import Nurbs

CELLS_PER_SPAN = 32
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
#: Newton / bisection steps of the arc-length inversion and of the nearest-point search.
INVERT_STEPS = 60
#: the arc-length inversion stops within this share of the curve's length (at least 1e-15 mm)
S_TOLERANCE_REL = 1e-12
NEAREST_STEPS = 8
#: samples either side of a seed in the nearest-point search's local refinement
LOCAL_SAMPLES = 16
#: point-sample pairs compared at once by the nearest-point seeding
SEED_BLOCK = 1_000_000
#: sample intervals searched again per point where they may hold a nearer point than the first
#: search found (:meth:`SplineCurve._seeds_and_rivals`)
RIVALS_KEPT = 8
#: a speed |C'| below this share of L / (t range) counts as zero (a degenerate end)
ZERO_SPEED_SHARE = 1e-9
#: t_of_s keeps its last results for arrays of at most T_OF_S_SIZE arc lengths, T_OF_S_KEPT of
#: them per curve: the planner asks again for the same ones (a chord vertex's frame, a piece's
#: search window) each time it plans the arc's chain again. On LinuxCNC's nc_files/systems.ngc
#: (826 G5.1 curves) 3,678 of its 9,560 calls repeated an earlier one (2.6 s of inversions);
#: 32 keep as many of them as 256 did, and at most about 14 kB a curve (a window of 5,000
#: splines being planned: 70 MB at worst).
T_OF_S_SIZE = 16
T_OF_S_KEPT = 32


class SplineCurve:
    """Arc-length view of one NURBS curve (see the module docstring)."""

    def __init__(self, nurbs: Nurbs) -> None:
        self.nurbs = nurbs
        breaks = np.unique(nurbs.homogeneous.knots)
        breaks = breaks[(breaks >= nurbs.t_min) & (breaks <= nurbs.t_max)]
        cells = [np.linspace(a, b, CELLS_PER_SPAN + 1)[:-1] for a, b in itertools.pairwise(breaks)]
        self.grid = np.concatenate([*cells, [nurbs.t_max]])
        lengths = self._integral(self.grid[:-1], self.grid[1:])
        self.cum = np.concatenate([[0.0], np.cumsum(lengths)])
        #: t_of_s's results by its arc lengths' bytes (see :data:`T_OF_S_KEPT`)
        self._t_of_s: dict[bytes, np.ndarray] = {}
        #: chord counts found by :func:`~gantry_sim.controller.planner.segment.
        #: spline_segment_count`, by (method, chord tolerance, segment length): the planner's
        #: path and the plan's chord vertices ask for the same move's, and a curve near a cusp
        #: needs thousands of chords, found in seconds
        self.chord_counts: dict[tuple[str, float, float], int] = {}

    def __getstate__(self) -> dict:
        return {**self.__dict__, "_t_of_s": {}}  # results kept are not worth carrying

    @property
    def length_mm(self) -> float:
        return float(self.cum[-1])

    def speed(self, t: np.ndarray) -> np.ndarray:
        """|dC/dt| [mm per unit t]."""
        return np.linalg.norm(self.nurbs.derivatives(t, 1)[1], axis=1)

    def _integral(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Arc length [mm] from ``a`` to ``b`` (m,) (Gauss-Legendre, one interval each)."""
        half, t = _gl_nodes(a, b)
        return half * (self.speed(t.ravel()).reshape(t.shape) @ _GL_W)

    def _integral_and_speed(self, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`_integral` from ``a`` to ``b`` and :meth:`speed` at ``b``, from one
        evaluation of the curve (the same numbers as the two calls)."""
        half, t = _gl_nodes(a, b)
        v = self.speed(np.concatenate([t.ravel(), b]))
        return half * (v[: t.size].reshape(t.shape) @ _GL_W), v[t.size :]

    def s_of_t(self, t: np.ndarray) -> np.ndarray:
        """Arc length [mm] from the start to parameter ``t`` (m,)."""
        t = np.clip(np.asarray(t, dtype=float), self.nurbs.t_min, self.nurbs.t_max)
        cell = np.clip(np.searchsorted(self.grid, t, side="right") - 1, 0, len(self.grid) - 2)
        return self.cum[cell] + self._integral(self.grid[cell], t)

    def t_of_s(self, s: np.ndarray) -> np.ndarray:
        """The parameter t at arc length ``s`` [mm] (m,), clamped to the curve: Newton steps
        from the grid cell's linear guess, bisection where a step would leave the cell's
        bracket, until the arc length is within :data:`S_TOLERANCE_REL` of the length."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.length_mm)
        key = s.tobytes() if s.ndim == 1 and s.size <= T_OF_S_SIZE else None
        kept = self._t_of_s.get(key) if key is not None else None
        if kept is not None:
            return kept.copy()
        t = self._t_of_s_new(s)
        if key is not None:
            if len(self._t_of_s) >= T_OF_S_KEPT:
                del self._t_of_s[next(iter(self._t_of_s))]  # the oldest
            self._t_of_s[key] = t.copy()
        return t

    def _t_of_s_new(self, s: np.ndarray) -> np.ndarray:
        """:meth:`t_of_s` of the clamped arc lengths ``s`` [mm], computed."""
        cell = np.clip(np.searchsorted(self.cum, s, side="right") - 1, 0, len(self.grid) - 2)
        lo, hi = self.grid[cell].copy(), self.grid[cell + 1].copy()
        c0, c1 = self.cum[cell], self.cum[cell + 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            frac = np.where(c1 > c0, (s - c0) / (c1 - c0), 0.0)
        t = lo + frac * (hi - lo)
        tol = S_TOLERANCE_REL * max(self.length_mm, 1e-3)
        active = np.arange(len(s))
        for _ in range(INVERT_STEPS):
            ta, ca = t[active], cell[active]
            piece, speed_ta = self._integral_and_speed(self.grid[ca], ta)
            f = self.cum[ca] + piece - s[active]
            ok = np.abs(f) <= tol
            lo_a = np.where(f < 0, ta, lo[active])
            hi_a = np.where(f > 0, ta, hi[active])
            with np.errstate(divide="ignore", invalid="ignore"):
                nt = ta - f / speed_ta
            bad = ~np.isfinite(nt) | (nt <= lo_a) | (nt >= hi_a)
            nt = np.where(bad, 0.5 * (lo_a + hi_a), nt)
            t[active] = np.where(ok, ta, nt)
            lo[active], hi[active] = lo_a, hi_a
            active = active[~ok & (hi_a - lo_a > 0)]
            if not active.size:
                break
        return t

    @cached_property
    def zero_speed_ends(self) -> tuple[bool, bool]:
        """Whether the curve's start and its end have zero speed (a G5 whose first or last
        offset is 0: its curvature grows without bound there)."""
        ends = np.array([self.nurbs.t_min, self.nurbs.t_max])
        start, end = self.zero_speed(self.nurbs.derivatives(ends, 1)[1]).tolist()
        return bool(start), bool(end)

    @cached_property
    def end_frames(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(T_start, k_start, T_end, k_end): unit tangents and curvature vectors [1/mm]; at a
        zero-speed end both are taken a hair (1e-6 of the parameter range) inside."""
        lo, hi = self.nurbs.t_min, self.nurbs.t_max
        eps = 1e-6 * (hi - lo)
        out: list[np.ndarray] = []
        for t, inside in ((lo, lo + eps), (hi, hi - eps)):
            d = self.nurbs.derivatives(np.array([t, inside]), 2)
            row = 1 if self.zero_speed(d[1][0:1])[0] else 0
            d1, d2 = d[1][row : row + 1], d[2][row : row + 1]
            out += [d1[0] / np.linalg.norm(d1[0]), _curvature(d1, d2)[0]]
        return out[0], out[1], out[2], out[3]

    def zero_speed(self, d1: np.ndarray) -> np.ndarray:
        span = self.nurbs.t_max - self.nurbs.t_min
        return np.linalg.norm(d1, axis=1) <= ZERO_SPEED_SHARE * self.length_mm / span

    def frame(self, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(points, unit tangents, curvature vectors [1/mm]) at arc-length fractions ``sigma``."""
        t = self.t_of_s(np.asarray(sigma, dtype=float) * self.length_mm)
        c, d1, d2 = self.nurbs.derivatives(t, 2)
        speed = np.linalg.norm(d1, axis=1)
        ok = ~self.zero_speed(d1)
        tangent = np.where(ok[:, None], d1 / np.where(ok, speed, 1.0)[:, None], 0.0)
        k = np.where(ok[:, None], _curvature(np.where(ok[:, None], d1, 1.0), d2), 0.0)
        if not ok.all():  # a degenerate end: its limit tangent and curvature
            t0, k0, t1, k1 = self.end_frames
            at_start = ~ok & (t < 0.5 * (self.nurbs.t_min + self.nurbs.t_max))
            tangent[~ok] = np.where(at_start[~ok][:, None], t0, t1)
            k[~ok] = np.where(at_start[~ok][:, None], k0, k1)
        return c, tangent, k

    def nearest(self, q: np.ndarray, t_seed: np.ndarray, spacing: float) -> np.ndarray:
        """Parameters t (m,) of the points nearest to ``q`` (m, 3) from seeds ``t_seed`` (m,)
        that are the nearest of samples ``spacing`` apart: the nearest of 33 samples across
        +-``spacing`` around the seed, twice (each time 16 times finer), then guarded Newton
        steps on f(t) = |C(t) - q|^2 (halved up to twice where a full step does not lower f),
        clamped to the curve. The local samples matter where C' vanishes (a zero-speed end,
        G5 ``I0 J0``): there f' = 0 at the end itself and Newton alone would not leave it."""
        t = np.asarray(t_seed, dtype=float).copy()
        lo, hi = self.nurbs.t_min, self.nurbs.t_max
        offsets = np.linspace(-1.0, 1.0, 2 * LOCAL_SAMPLES + 1)
        for scale in (spacing, spacing / LOCAL_SAMPLES):
            cand = np.clip(t[:, None] + scale * offsets[None, :], lo, hi)  # (m, 33)
            pts = self.nurbs.points(cand.ravel()).reshape(*cand.shape, 3)
            rel = pts - q[:, None, :]
            t = cand[np.arange(len(t)), np.argmin(np.einsum("ijk,ijk->ij", rel, rel), axis=1)]
        c = self.nurbs.points(t)
        f = np.einsum("ij,ij->i", c - q, c - q)
        for _ in range(NEAREST_STEPS):
            c, d1, d2 = self.nurbs.derivatives(t, 2)
            r = c - q
            g = np.einsum("ij,ij->i", r, d1)
            h = np.einsum("ij,ij->i", d1, d1) + np.einsum("ij,ij->i", r, d2)
            with np.errstate(divide="ignore", invalid="ignore"):
                step = np.where(h > 0, -g / h, 0.0)
            improved = np.zeros(len(t), dtype=bool)
            shares = np.array([1.0, 0.5, 0.25])  # the three trial steps evaluated at once
            trial = np.clip(t[None, :] + shares[:, None] * step[None, :], lo, hi)
            tc = self.nurbs.points(trial.ravel()).reshape(*trial.shape, 3) - q[None, :, :]
            trial_f = np.einsum("kij,kij->ki", tc, tc)
            for nt, nf in zip(trial, trial_f, strict=True):
                better = (nf < f) & ~improved
                t, f = np.where(better, nt, t), np.where(better, nf, f)
                improved |= better
            if not improved.any():
                break
        return t

    def seeds(self, q: np.ndarray, t_lo: float, t_hi: float, samples: int) -> np.ndarray:
        """The nearest of ``samples`` parameters evenly spread over [t_lo, t_hi], per point."""
        ts = np.linspace(t_lo, t_hi, max(samples, 2))
        pts = self.nurbs.points(ts)
        out = np.empty(len(q))
        rows = max(1, SEED_BLOCK // len(ts))  # bounded temporaries (about 32 MB)
        for a in range(0, len(q), rows):
            rel = q[a : a + rows, None, :] - pts[None, :, :]
            out[a : a + rows] = ts[np.argmin(np.einsum("ijk,ijk->ij", rel, rel), axis=1)]
        return out

    def nearest_points(self, q: np.ndarray) -> np.ndarray:
        """Nearest points (m, 3) on the whole curve to ``q`` (m, 3) [mm]: :meth:`nearest` from
        the nearest of samples at 4 per grid cell, then from every other sample interval that
        may hold a nearer point (:meth:`_seeds_and_rivals`), the nearest of all kept."""
        lo, hi = self.nurbs.t_min, self.nurbs.t_max
        samples = 4 * (len(self.grid) - 1) + 1
        ts = np.linspace(lo, hi, samples)
        spacing = (hi - lo) / (samples - 1)
        seed, which, rival, bound = self._seeds_and_rivals(q, ts)
        t = self.nearest(q, seed, spacing)
        best = np.linalg.norm(self.nurbs.points(t) - q, axis=1)
        open_ = bound < best[which] - 1e-12 * (1.0 + best[which])
        which, rival = which[open_], rival[open_]
        if which.size:
            tr = self.nearest(q[which], rival, spacing)
            dr = np.linalg.norm(self.nurbs.points(tr) - q[which], axis=1)
            order = np.lexsort((dr, which))  # per point, its nearest rival first
            first = order[np.r_[True, which[order][1:] != which[order][:-1]]]
            nearer = dr[first] < best[which[first]]
            t[which[first][nearer]] = tr[first][nearer]
        return self.nurbs.points(t)

    def _seeds_and_rivals(
        self, q: np.ndarray, ts: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per point of ``q``, the nearest of the samples at ``ts`` (as :meth:`seeds`); and
        (point index, seed t, bound [mm]) for the other sample intervals [ts[j], ts[j + 1]] that
        may hold a point nearer than that sample: a point of the curve at arc length a from one
        end of an interval of arc length h lies within its distance plus min(a, h - a) of a
        sample, so none in the interval is nearer than the bound, the nearer end's distance less
        h / 2. The caller searches those whose bound is below the distance its first search
        found (a curve turning back on itself within microns, a G5 near a cusp, had points
        seeded on the wrong pass, 56 um off): at most :data:`RIVALS_KEPT` per point, the lowest
        bounds, each seeded at its nearer end; not the two intervals next to the seed, which the
        first search covers."""
        pts = self.nurbs.points(ts)
        half = 0.5 * np.diff(self.s_of_t(ts))
        seed = np.empty(len(q))
        which: list[np.ndarray] = []
        rivals: list[np.ndarray] = []
        bounds: list[np.ndarray] = []
        rows = max(1, SEED_BLOCK // len(ts))
        for a in range(0, len(q), rows):
            rel = q[a : a + rows, None, :] - pts[None, :, :]
            d2 = np.einsum("ijk,ijk->ij", rel, rel)
            b = np.argmin(d2, axis=1)
            seed[a : a + rows] = ts[b]
            d = np.sqrt(d2)
            bound = np.minimum(d[:, :-1], d[:, 1:]) - half[None, :]
            r = np.arange(len(d))
            bound[r, np.maximum(b - 1, 0)] = np.inf  # searched from the seed
            bound[r, np.minimum(b, len(half) - 1)] = np.inf
            i, j = np.nonzero(bound < d[r, b][:, None])
            if not i.size:
                continue
            keep = np.lexsort((bound[i, j], i))
            i, j = i[keep], j[keep]
            rank = np.arange(len(i)) - np.searchsorted(i, i)  # place within its point's run
            i, j = i[rank < RIVALS_KEPT], j[rank < RIVALS_KEPT]
            which.append(i + a)
            rivals.append(ts[np.where(d[i, j] <= d[i, j + 1], j, j + 1)])
            bounds.append(bound[i, j])
        if not which:
            return seed, np.empty(0, dtype=np.intp), np.empty(0), np.empty(0)
        return seed, np.concatenate(which), np.concatenate(rivals), np.concatenate(bounds)


def _gl_nodes(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Half-widths (m,) of the intervals ``a``..``b`` and their Gauss-Legendre nodes (m, 8)."""
    half = 0.5 * (b - a)
    return half, (0.5 * (a + b))[:, None] + half[:, None] * _GL_X[None, :]


def _curvature(d1: np.ndarray, d2: np.ndarray) -> np.ndarray:
    """Curvature vectors [1/mm] (m, 3) from dC/dt and d2C/dt2 (m, 3)."""
    v2 = np.einsum("ij,ij->i", d1, d1)
    along = np.einsum("ij,ij->i", d2, d1) / v2
    return (d2 - along[:, None] * d1) / v2[:, None]


def spline_curve(move) -> SplineCurve:
    """The :class:`SplineCurve` of a :class:`~gantry_sim.controller.moves.Spline` move."""
    nurbs = Nurbs.build(
        np.array(move.control_points, dtype=float),
        np.array(move.weights, dtype=float),
        np.array(move.knots, dtype=float),
        move.degree,
    )
    return SplineCurve(nurbs)
