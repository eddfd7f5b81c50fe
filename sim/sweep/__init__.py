"""Parameter sweeps: one full simulation per grid point of feed override x accel x jerk.

    grid.py        the grid, one point's run (a sweep.csv row), the resumable journal, the CSV
    executors.py   local processes or a Dask cluster: map a function, results as they finish

Each point is a deterministic simulation, so the numbers do not depend on the executor.
"""
