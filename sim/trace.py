"""Trace: the per-servo-tick arrays of a run (what trace.npz holds, plus the nearest points)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Trace:
    """Per servo tick, program (work) coordinates.

    Attributes:
        t: (N,) time [s].
        ref: (N, 3) commanded reference [mm].
        pos: (N, 3) traced tool tip from MuJoCo [mm].
        line: (N,) program line being executed.
        err_um: (N,) contour error of each traced point against the commanded geometry [um].
        nearest: (N, 3) nearest commanded point to each traced point [mm].
        feed: (N,) True on feed moves (G1/G2/G3), False on rapids.
        force_N: (N, 3) drive force held over each tick per axis [N].
    """

    t: np.ndarray
    ref: np.ndarray
    pos: np.ndarray
    line: np.ndarray
    err_um: np.ndarray
    nearest: np.ndarray
    feed: np.ndarray
    force_N: np.ndarray
