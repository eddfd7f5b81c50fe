"""Discrete-time PID position servo per axis with LinuxCNC-style feedforward; numbers only.

The servo runs at the period T [s]. At tick k it samples the axis position x_k [mm] (the encoder,
in joint coordinates), computes a force and holds it until tick k+1 (zero-order hold):

    e_k = r_k - x_k                                            following error [mm]
    u_k = kp e_k + kd (e_k - e_{k-1}) / T                      PD [N]; e_{-1} = e_0 (no kick)
        + ff_velocity     * c   * v_k                          FF1: viscous damping [N]
        + ff_acceleration * m   * a_k * 1e-3                   FF2: moving mass [N] (a in mm/s^2)
        + ff_friction     * F_c * sign(v_k)                    Coulomb friction [N]
        - ff_gravity      * g_load                             gravity (the load along the axis) [N]
        + ki * I_k                                             integral [N]
    F_k = clamp(u_k, force_min, force_max)                     the drive's force limit [N]

The integral I_k [mm s] follows LinuxCNC's pid component, anti-windup included: I_k = I_{k-1} +
e_k T, except that it does not integrate while the previous tick's force sat at the drive's limit
in the direction of e_k (conditional integration), and then is clamped to +-I_max
(``max_error_integral_mm_s``, LinuxCNC's maxerror-i; 0 = no clamp). I_{-1} = 0. With ki = 0
(the default) the law is the PD above and the integral is never computed.

with the reference r_k [mm], v_k [mm/s], a_k [mm/s^2] sampled at t_k = k T. Signs: error is
reference minus measurement, a positive force pushes the axis towards +; ``gravity_load_N`` is the
force gravity exerts along the axis (negative on a vertical Z: the ram is pulled down), so the
compensation pushes against it.

Everything that does not depend on the measurement is computed for the whole trajectory at once
(:meth:`DiscretePD.drive_terms`, vectorised); per tick only

    u_k = b_k - (kp + kd/T) x_k + (kd/T) x_{k-1}

remains (:meth:`DiscretePD.force`): a few float operations per axis, which is what the simulation
loop in sim/runner.py executes inline. With an integral term, :meth:`DiscretePD.step` is the law
of one tick (it carries I and the saturation state).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.config import Servo

#: |v| below this counts as standing still for the friction feedforward [mm/s].
FRICTION_DEADBAND_MM_PER_S = 1e-6
#: Force [N] = mass [kg] * acceleration [mm/s^2] * this.
N_PER_KG_MM_PER_S2 = 1e-3


@dataclass(frozen=True)
class AxisPlant:
    """What the servo knows of one axis (from the model; sim/machine.py reads it).

    Attributes:
        mass_kg: moving mass including the reflected rotor inertia (armature) [kg].
        damping_N_s_per_mm: viscous damping [N s/mm].
        friction_N: Coulomb friction force (frictionloss) [N], >= 0.
        gravity_load_N: force of gravity along the axis' + direction [N] (e.g. -49 on Z).
        force_min_N: most negative force the drive delivers [N], < 0.
        force_max_N: largest positive force the drive delivers [N], > 0.
    """

    mass_kg: float
    damping_N_s_per_mm: float
    friction_N: float
    gravity_load_N: float
    force_min_N: float
    force_max_N: float


class DiscretePD:
    """Three axes of the discrete PD law above, with the gains and feedforward of ``servo``.

    Args:
        servo: gains [N/mm], [N s/mm], feedforward fractions, period [s] (machine file [servo]).
        plant: the three axes' plant parameters, in order x, y, z.
    """

    def __init__(self, servo: Servo, plant: Sequence[AxisPlant]) -> None:
        if len(plant) != 3:
            raise ValueError("plant must give 3 axes (x, y, z)")
        self.period_s = servo.period_s
        self.plant = tuple(plant)
        self.kp = tuple(float(k) for k in servo.kp_N_per_mm)
        self.kd = tuple(float(k) for k in servo.kd_N_s_per_mm)
        #: coefficient of x_k and of x_{k-1} in the per-tick law [N/mm]
        self.a = tuple(kp + kd / self.period_s for kp, kd in zip(self.kp, self.kd, strict=True))
        self.c = tuple(kd / self.period_s for kd in self.kd)
        self.lo = tuple(p.force_min_N for p in self.plant)
        self.hi = tuple(p.force_max_N for p in self.plant)
        self._ff = (servo.ff_velocity, servo.ff_acceleration, servo.ff_friction, servo.ff_gravity)
        self.ki = tuple(float(k) for k in servo.ki_N_per_mm_s)
        #: clamp of the error integral [mm s]; inf where the machine file says 0 (no clamp)
        self.i_max = tuple(
            float(v) if v > 0 else float("inf") for v in servo.max_error_integral_mm_s
        )
        #: True when any axis has an integral term (the loop then carries state: :meth:`step`)
        self.has_integral = any(k != 0.0 for k in self.ki)

    def feedforward_N(self, vel: np.ndarray, acc: np.ndarray) -> np.ndarray:
        """Feedforward force per sample and axis -> (N, 3) [N].

        Args:
            vel: (N, 3) reference velocity [mm/s].
            acc: (N, 3) reference acceleration [mm/s^2].
        """
        ffv, ffa, fff, ffg = self._ff
        vel = np.asarray(vel, dtype=float).reshape(-1, 3)
        acc = np.asarray(acc, dtype=float).reshape(-1, 3)
        out = np.empty_like(vel)
        for i, p in enumerate(self.plant):
            moving = np.abs(vel[:, i]) > FRICTION_DEADBAND_MM_PER_S
            out[:, i] = (
                ffv[i] * p.damping_N_s_per_mm * vel[:, i]
                + ffa[i] * p.mass_kg * N_PER_KG_MM_PER_S2 * acc[:, i]
                + fff[i] * p.friction_N * np.sign(vel[:, i]) * moving
                - ffg * p.gravity_load_N
            )
        return out

    def drive_terms(self, ref: np.ndarray, vel: np.ndarray, acc: np.ndarray) -> np.ndarray:
        """b_k: the part of u_k that does not depend on the measurement -> (N, 3) [N].

        b_k = kp r_k + (kd/T) (r_k - r_{k-1}) + feedforward_k, with r_{-1} = r_0.

        Args:
            ref: (N, 3) reference position in the servo's (joint) coordinates [mm].
            vel: (N, 3) reference velocity [mm/s].
            acc: (N, 3) reference acceleration [mm/s^2].
        """
        ref = np.asarray(ref, dtype=float).reshape(-1, 3)
        prev = np.vstack([ref[:1], ref[:-1]])
        kp = np.asarray(self.kp)
        kd_t = np.asarray(self.c)
        return kp * ref + kd_t * (ref - prev) + self.feedforward_N(vel, acc)

    def force(
        self, b: Sequence[float], x: Sequence[float], x_prev: Sequence[float]
    ) -> tuple[float, float, float]:
        """Saturated force of one tick [N] per axis from b_k, x_k and x_{k-1} [mm].

        At the first tick pass x_prev = x (the derivative starts at zero).
        """
        out = []
        for i in range(3):
            u = b[i] - self.a[i] * x[i] + self.c[i] * x_prev[i]
            out.append(min(self.hi[i], max(self.lo[i], u)))
        return out[0], out[1], out[2]

    def step(
        self,
        b: Sequence[float],
        r: Sequence[float],
        x: Sequence[float],
        x_prev: Sequence[float],
        integral: Sequence[float],
        saturated: Sequence[int],
    ) -> tuple[tuple[float, ...], tuple[float, ...], tuple[int, ...]]:
        """One tick of the full PID law -> (force [N], integral I_k [mm s], saturation) per axis.

        Args:
            b: drive terms b_k [N] (:meth:`drive_terms`).
            r: reference r_k in joint coordinates [mm] (the integral's error is r_k - x_k).
            x: sampled positions x_k [mm]; x_prev: those of tick k-1 (x at the first tick).
            integral: I_{k-1} [mm s] (zeros at the first tick).
            saturated: the previous tick's saturation per axis: +1 force at force_max, -1 at
                force_min, 0 inside (zeros at the first tick).
        """
        t = self.period_s
        force, integ, sat = [], [], []
        for i in range(3):
            e = r[i] - x[i]
            acc = integral[i]
            winding_up = (saturated[i] > 0 and e > 0) or (saturated[i] < 0 and e < 0)
            if not winding_up:
                acc = acc + e * t
            acc = min(self.i_max[i], max(-self.i_max[i], acc))
            u = b[i] - self.a[i] * x[i] + self.c[i] * x_prev[i] + self.ki[i] * acc
            f = min(self.hi[i], max(self.lo[i], u))
            force.append(f)
            integ.append(acc)
            sat.append(1 if f >= self.hi[i] else (-1 if f <= self.lo[i] else 0))
        return tuple(force), tuple(integ), tuple(sat)

    def forces(self, b: np.ndarray, x: np.ndarray, x_prev: np.ndarray) -> np.ndarray:
        """:meth:`force` for many ticks at once -> (N, 3) [N]; the same operations in the same
        order, so each row equals ``force(b[k], x[k], x_prev[k])`` exactly.

        Args:
            b: (N, 3) drive terms b_k [N].
            x: (N, 3) sampled positions x_k [mm].
            x_prev: (N, 3) positions of the previous tick x_{k-1} [mm].
        """
        u = np.asarray(b, dtype=float) - np.asarray(self.a) * x + np.asarray(self.c) * x_prev
        return np.minimum(np.asarray(self.hi), np.maximum(np.asarray(self.lo), u))

    def closed_loop_gain(self, omega_rad_per_s: float, axis: int) -> complex:
        """Closed-loop gain G(e^{jwT}) = x / r of one axis, PD only, on a pure mass (ZOH plant).

        The plant is m x'' = F with F held over each period (no damping or friction): sampled,
        P(z) = T^2 (z + 1) / (2 m (z - 1)^2) [mm/N, with m in kg scaled to N/(mm/s^2)]; the
        controller is C(z) = kp + kd (1 - 1/z) / T; G = P C / (1 + P C). A circle of radius R
        traced at angular rate w by this loop settles at radius |G| R.
        """
        t = self.period_s
        m = self.plant[axis].mass_kg * N_PER_KG_MM_PER_S2  # N per (mm/s^2)
        z = complex(np.exp(1j * omega_rad_per_s * t))
        p = t * t * (z + 1) / (2 * m * (z - 1) ** 2)
        c = self.kp[axis] + self.kd[axis] * (1 - 1 / z) / t
        return p * c / (1 + p * c)
