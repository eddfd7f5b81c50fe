"""gantry-sim's controller: everything a CNC controller computes, as numbers only.

Units throughout: millimetres [mm], seconds [s], newtons [N]; feed words arrive in mm/min or
inch/min and are converted once, in the interpreter. This package never imports mujoco or
matplotlib, nor anything of ``gantry_sim.sim``.

The stages (each package's docstring is its own map):

* ``gcode/``    text + dialect -> moves (the interpreter)
* ``planner/``  moves + machine -> Plan, a jerk-limited reference (segmentation, look-ahead,
  Ruckig behind ``planner/ruckig_solver.py``, the only ruckig import)
* ``servo``     the discrete-time PID law with feedforward, per axis (a leaf)

Shared value types, used by several stages: ``errors`` (GantryError and its kinds, FILE:LINE),
``units``, ``planes`` (the one plane/axis table), ``moves`` (Rapid, Linear, Arc and the events),
``arcs`` (exact arc and helix geometry), ``spline_curve`` and ``quintic_curve`` (a G5.x
spline's curve, and the planner's G2 transitions', by arc length), ``config`` (the machine
file), ``trajectory`` (the
sampled reference), ``transmission`` (backlash), ``loop_figures`` (a position loop's figures)
``machine_import/`` (machine files from LinuxCNC INI files and grbl settings), ``gc_pause``
(the cyclic collector paused while a long program is read and planned), ``heap`` (the C heap's
free pages given back after planning), ``spill`` (long sequences kept on disk in blocks: a
long program's moves, path and reference), and ``forked`` and ``forked_runs`` (work over
forked copies of this process: one result in the background, or many runs taken from a queue).
"""
