"""gantry-sim controller: G-code interpreter, arc segmentation, Ruckig planning, discrete servo.

Units throughout this package: millimetres [mm], seconds [s], newtons [N]. Feed words arrive in
mm/min or inch/min and are converted once, in the interpreter. This package never imports mujoco.
"""
