"""The planner's output sampled at the servo period: the reference the servo follows."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Trajectory:
    """A reference sampled every ``period_s`` from t = 0 to the end (last sample at rest).

    Attributes:
        t: (N,) sample times [s], t[k] = k * period_s.
        pos: (N, 3) reference position, program (work) coordinates [mm].
        vel: (N, 3) reference velocity [mm/s].
        acc: (N, 3) reference acceleration [mm/s^2].
        line: (N,) 1-based source line of the move being executed (int64).
        period_s: sampling period [s].
        source: (N, 2) the first and last index among the planned program's moves that the
            sample is executing (a dwell: the moves it lies between; -1: none), or None when
            not known: the contour error then searches by ``line``.
    """

    t: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    acc: np.ndarray
    line: np.ndarray
    period_s: float
    source: np.ndarray | None = None

    def __post_init__(self) -> None:
        for name in ("t", "pos", "vel", "acc", "line"):
            getattr(self, name).setflags(write=False)
        if self.source is not None:
            self.source.setflags(write=False)

    @property
    def duration_s(self) -> float:
        """Time of the last sample [s]."""
        return float(self.t[-1]) if self.t.size else 0.0

    def slice(self, lo: int, hi: int) -> Trajectory:
        """Samples lo..hi-1 (views, not copies; times keep their absolute values)."""
        return Trajectory(
            t=self.t[lo:hi],
            pos=self.pos[lo:hi],
            vel=self.vel[lo:hi],
            acc=self.acc[lo:hi],
            line=self.line[lo:hi],
            period_s=self.period_s,
            source=None if self.source is None else self.source[lo:hi],
        )

    def to_npz_dict(self) -> dict[str, np.ndarray]:
        """The arrays of the ``gantry plan --out`` contract."""
        return {"t": self.t, "pos": self.pos, "vel": self.vel, "acc": self.acc, "line": self.line}
