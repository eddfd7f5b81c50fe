"""Force-loop gains from a velocity-mode position loop (LinuxCNC's PID on a velocity drive).

On a velocity-mode drive LinuxCNC's pid outputs a velocity command [units/s]:

    v_cmd = P e + I int(e) dt + D de/dt + FF1 v_ref + FF2 a_ref          (FF0 = 0)

P is the position-loop gain Kv [(units/s)/unit = 1/s], the same in inch and mm. The drive closes
a velocity loop of gain Kvel [N s/mm] around it: F = Kvel (v_cmd - v). With FF1 = 1 this is

    F = Kvel P e + Kvel (1 + D) de/dt + Kvel I int(e) dt + Kvel FF2 a_ref

gantry-sim's force law (controller.servo) with kp = Kvel P [N/mm], kd = Kvel (1 + D) [N s/mm],
ki = Kvel I [N/(mm s)] and an acceleration feedforward Kvel FF2 a = ff_acceleration m a, i.e.
ff_acceleration = Kvel FF2 / m [fraction; m in N/(mm/s^2)].

The INI does not hold the drive's velocity-loop gain Kvel: it lives in the drive. It is chosen
from the axis' moving mass m so that the PD loop has damping ratio ZETA (0.7, the bundled
machine's design): with wn = 2 ZETA P, Kvel = 2 ZETA wn m, kp = m wn^2 (= Kvel P).
"""

from __future__ import annotations

from dataclasses import dataclass

#: damping ratio of the PD loop the velocity-loop gain is chosen for (the bundled machine's)
ZETA = 0.7


@dataclass(frozen=True)
class ForceGains:
    """kp [N/mm], kd [N s/mm], ki [N/(mm s)], ff_acceleration [fraction], Kvel [N s/mm]."""

    kp_N_per_mm: float
    kd_N_s_per_mm: float
    ki_N_per_mm_s: float
    ff_acceleration: float
    kvel_N_s_per_mm: float


def force_gains(
    p_per_s: float, i_per_s2: float, d_s: float, ff2_s: float, mass_kg: float
) -> ForceGains:
    """LinuxCNC P [1/s], I [1/s^2], D [s], FF2 [s] of a velocity-mode loop on an axis of moving
    mass ``mass_kg`` [kg] -> force-loop gains (module doc)."""
    m = mass_kg * 1e-3  # N per (mm/s^2)
    wn = 2 * ZETA * p_per_s
    kvel = 2 * ZETA * wn * m
    return ForceGains(
        kp_N_per_mm=kvel * p_per_s,
        kd_N_s_per_mm=kvel * (1.0 + d_s),
        ki_N_per_mm_s=kvel * i_per_s2,
        ff_acceleration=kvel * ff2_s / m,
        kvel_N_s_per_mm=kvel,
    )
