"""The tracking part of the contour error: how far each traced point is from the reference path
(the polyline through the reference samples) near the same instant.

For sample k the segments path[s] - path[s + 1], s = k - window .. k + window - 1 (clipped to
the path: the first and last segments repeat beyond the ends), are searched:

    u = clip(((p - a) . d) / |d|^2, 0, 1),   dist^2 = |a + u d - p|^2      (0 when |d| = 0: u = 0)

All in [mm]. Both functions evaluate exactly these operations in this order, so their figures
agree to the last bit.
"""

from __future__ import annotations

import numpy as np

#: ticks per block of the full search (its ~12 working arrays stay in the CPU cache)
POLYLINE_BLOCK = 8192
#: ticks searched in full per pass of :func:`max_distance_to_polyline_near`
MAX_BATCH = 4096


class _Padded:
    """The segments of ``path`` as component arrays, edge-padded by ``w`` before and w + 1
    after, so segment s of sample k + j lives at index w + k + j."""

    def __init__(self, path: np.ndarray, w: int) -> None:
        seg_d = np.diff(path, axis=0)  # segment s: path[s] + u seg_d[s]
        length2 = np.einsum("ij,ij->i", seg_d, seg_d)
        inv = np.divide(1.0, length2, out=np.zeros_like(length2), where=length2 > 0)

        def pad(v: np.ndarray) -> np.ndarray:
            return np.concatenate([np.full(w, v[0]), v, np.full(w + 1, v[-1])])

        self.inv = pad(inv)
        self.a = [pad(path[:-1, i]) for i in range(3)]
        self.d = [pad(seg_d[:, i]) for i in range(3)]
        self.w = w


def _min_dist2(seg: _Padded, p, at, offsets, best, scratch) -> None:
    """best = min(best, dist^2 of points p (3 component arrays) to segments at[j] (index arrays
    or slices into the padded arrays), for j in offsets)."""
    u, t, s = scratch
    for j in offsets:
        sl = at(j)
        sx, sy, sz = (c[sl] for c in seg.a)
        ex, ey, ez = (c[sl] for c in seg.d)
        np.subtract(p[0], sx, out=u)
        u *= ex
        np.subtract(p[1], sy, out=t)
        t *= ey
        u += t
        np.subtract(p[2], sz, out=t)
        t *= ez
        u += t
        u *= seg.inv[sl]
        np.clip(u, 0.0, 1.0, out=u)
        for c, e, q, out in ((sx, ex, p[0], s), (sy, ey, p[1], t), (sz, ez, p[2], t)):
            np.multiply(u, e, out=out)
            out += c
            out -= q
            np.square(out, out=out)
            if out is t:
                s += t
        np.minimum(best, s, out=best)


def _blocked(seg: _Padded, pts: np.ndarray, shift: int, offsets) -> np.ndarray:
    """min over ``offsets`` of dist^2 [mm^2] for every point of pts (n, 3), pts[k] at path
    vertex k + shift: contiguous slices, POLYLINE_BLOCK points at a time, in place."""
    n, w = len(pts), seg.w
    comps = [np.ascontiguousarray(pts[:, i]) for i in range(3)]
    best = np.full(n, np.inf)
    scratch = np.empty((3, min(n, POLYLINE_BLOCK)))
    for k0 in range(0, n, POLYLINE_BLOCK):
        m = min(n, k0 + POLYLINE_BLOCK) - k0
        p = [c[k0 : k0 + m] for c in comps]
        first = w + shift + k0
        at = lambda j, first=first, m=m: slice(first + j, first + j + m)  # noqa: E731
        _min_dist2(seg, p, at, offsets, best[k0 : k0 + m], scratch[:, :m])
    return best


def _lag_offsets(
    path: np.ndarray, pts: np.ndarray, ks: np.ndarray, w: int, shift: int
) -> np.ndarray:
    """Per sample k of ``ks``: -(how many path segments pts[k] lies behind its own vertex),
    estimated as its distance from that vertex over the length of the segment that ends
    there, within 0 .. -(w - 1) (so that segments j - 1 and j lie in the searched window)."""
    own = ks + shift
    ahead = np.linalg.norm(pts[ks] - path[own], axis=1)
    step = np.linalg.norm(path[own] - path[np.maximum(own - 1, 0)], axis=1)
    lag = np.divide(ahead, step, out=np.zeros_like(ahead), where=step > 0)
    return -np.minimum(np.rint(lag), w - 1).astype(np.intp)


def distance_to_polyline_near(path: np.ndarray, pts: np.ndarray, window: int) -> np.ndarray:
    """Distance [mm] from pts[k] to the polyline ``path`` near its k-th vertex (see the module
    docstring); both (n, 3) sampled at the same instants (the reference and the trace). One
    vectorised pass per offset over blocks of POLYLINE_BLOCK samples, in place."""
    if len(pts) < 2:
        return np.linalg.norm(pts - path, axis=1)
    w = int(window)
    return np.sqrt(_blocked(_Padded(path, w), pts, 0, range(-w, w)))


def max_distance_to_polyline_near(
    path: np.ndarray, pts: np.ndarray, window: int, select: np.ndarray, shift: int = 0
) -> float:
    """max over the samples ``select`` (bool (n,)) of :func:`distance_to_polyline_near` [mm]
    (0 when none), without searching every sample in full.

    ``shift``: pts[k] is the sample at path vertex k + shift -- ``path`` may be a piece of a
    longer path, holding ``window`` vertices before pts' first sample and window + 1 after its
    last (fewer only where the whole path ends), which gives the whole path's figures.

    A sample's distance is at most that to the two segments meeting at its own vertex (j = -1,
    0), and at most that to the two meeting at the vertex it lags behind (:func:`_lag_offsets`:
    a trace that follows the path some ticks late is far from its own vertex but near that
    one); samples are searched in full in decreasing order of that bound, MAX_BATCH at a time,
    until no bound left exceeds the largest full distance found.
    """
    ks = np.flatnonzero(select)
    if ks.size == 0:
        return 0.0
    if len(path) < 2:
        return float(np.linalg.norm(pts - path[shift : shift + len(pts)], axis=1)[ks].max())
    seg, w = _Padded(path, int(window)), int(window)

    def search(ks: np.ndarray, offsets) -> np.ndarray:
        best = np.full(ks.size, np.inf)
        p = [np.ascontiguousarray(pts[ks, i]) for i in range(3)]
        at = lambda j: ks + (w + shift + j)  # noqa: E731
        _min_dist2(seg, p, at, offsets, best, np.empty((3, ks.size)))
        return best

    bound = _blocked(seg, pts, shift, (-1, 0))[ks]
    lagged = ks + (w + shift) + _lag_offsets(path, pts, ks, w, shift)
    p = [np.ascontiguousarray(pts[ks, i]) for i in range(3)]
    _min_dist2(seg, p, lambda j: lagged + j, (-1, 0), bound, np.empty((3, ks.size)))
    found = -np.inf
    while ks.size:
        if ks.size > MAX_BATCH:
            top = np.argpartition(bound, ks.size - MAX_BATCH)[ks.size - MAX_BATCH :]
        else:
            top = np.arange(ks.size)
        found = max(found, float(search(ks[top], range(-w, w)).max()))
        keep = np.ones(ks.size, dtype=bool)
        keep[top] = False
        keep &= bound > found
        ks, bound = ks[keep], bound[keep]
    return float(np.sqrt(found))
