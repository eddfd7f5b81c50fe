"""gantry-sim simulation side: MuJoCo runner, analysis, reports and the ``gantry`` CLI.

Only this package imports mujoco (lazily, inside the commands that need it).
"""
