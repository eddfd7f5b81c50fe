"""Backlash: the lost motion of a transmission between the motor (with its encoder) and the axis.

A ball-screw nut or a gearbox with play lets the axis (the load, what the tool follows) move by up
to the backlash ``b`` [mm] while the motor side stands still. The relation between the two is the
play (backlash) operator: the motor-side position p stays where it is while the axis position x
is within +-b/2 of it, and is carried along when x reaches either face of the gap:

    p_k = clamp(p_{k-1}, x_k - b/2, x_k + b/2)                        [mm]

The servo's encoder sits on the motor side (a semi-closed loop, as on most machines without
linear scales): it controls p, so after each reversal of an axis the tool lags by b until the
gap has been crossed, and the loop's reaction to the stalled encoder shows as a spike. The model
is quasi-static: the force reaches the axis at all times (no free flight of the rotor across
the gap, no impact); see the README's "Your machine" for why and what it leaves out.
"""

from __future__ import annotations


def motor_side_mm(axis_mm: float, motor_prev_mm: float, backlash_mm: float) -> float:
    """Motor-side (encoder) position [mm] after the axis moved to ``axis_mm`` [mm].

    Args:
        axis_mm: axis (load) position x_k [mm].
        motor_prev_mm: motor-side position p_{k-1} [mm].
        backlash_mm: total play b >= 0 [mm]; 0 gives p_k = x_k.
    """
    half = 0.5 * backlash_mm
    lo, hi = axis_mm - half, axis_mm + half
    return hi if motor_prev_mm > hi else (lo if motor_prev_mm < lo else motor_prev_mm)
