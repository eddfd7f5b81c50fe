"""gantry-sim's simulation side: the MuJoCo machine, contour analysis, outputs and the CLI.

The stages after planning, in the order a run goes through them (``gantry run``; the Python
entry point is :mod:`.api`):

    api.py           run_program / write_run_outputs: interpret -> plan -> simulate -> analyse
    program.py       the program on the machine: tools, offsets, subroutine folders, refusals
    machine.py       MJCF -> Gantry: axis names resolved, plant read, work origin placed (SI <-> mm)
    site_slides.py   closed-form tool site when only slide joints carry it (fast trace)
    runner.py        the simulation: servo-loop ranges, each checked for divergence
    progress.py      per-stage progress bars on stderr (a terminal, or --progress)
    servo_loop.py    the servo loop around mj_step: one discrete PD tick, then physics substeps
    pd_ticks.py      the same PD ticks compiled (pd_ticks.c, optional at install), via ctypes
    mujoco_lib.py    the bindings' libmujoco via ctypes; its profiler timers off while stepping
    stateful_ticks.py  the ticks of a law with an integral term or backlash (Python)
    stream.py        a run range by range: sample, simulate, analyse; nothing kept per tick
    analysis_worker.py  a streamed run's range analysis, in a worker process
    worker_pipes.py  a run's helper processes: a fresh interpreter fed over stdin/stdout
    range_helper.py  a thread sampling the next range and handing over the last while it steps
    error_tally.py   whole-run figures (rms, p95, per block) from ranges, in bounded memory
    percentile.py    exact percentile of values kept in memory or spilled to a temporary file
    trace.py         Trace: the per-tick arrays of a run (trace.npz)
    trace_writer.py  trace.npz written range by range (a streamed run), deflated as it comes
    deflate_zip.py   a .zip (ZIP64) assembled around members deflated beforehand
    nearest.py       nearest points on commanded lines, arcs and helices
    contour.py       contour error against the commanded geometry; chord/reference/tracking parts
    blend_parts.py   the reference part split into G64 blend deviation and planning
    report.py        RunReport (typed) -> report.json, timing.json; write_outputs (+ trace, plots)
    json_text.py     json.dumps(indent=2)'s text, fast for report.json's flat per-block objects
    gates.py         error limits per kind / line range, cycle-time limit, the verdict
    compare.py       a run against a baseline report.json, block by block
    plots.py         the figure idiom (Figure + Agg, no pyplot, quiet) and the ballbar polar plot
    path_plot.py     path.png: the arcs' plane or three views, error x 1000, worst point
    path_outline.py  path.png's commanded geometry (box, arc planes, polylines), no matplotlib
    plot_prep.py     the plots' outline (and imports, if no plot worker), in a thread
    plot_worker.py   a process that imports matplotlib during the run, then draws the plots
    plot_files.py    path.png and error.png written beside the other outputs, there or here
    error_plot.py    error.png: per-bin band along the program, worst blocks, the gates
    search_plots.py  tune.png and the sweep plots (every point, faults marked, axes from 0)
    outdir.py        outputs never half-written or mixed: staged in DIR, committed whole
    interrupts.py    Ctrl-C / SIGTERM: one interruption unwound once; commits held whole
    console.py       the `gantry` console script: signal handling first, then cli.py
    circular/        circular tests after ISO 230-4: the virtual ballbar and feed tuning
    sweep/           one simulation per grid point of feed override x accel x jerk
    cli.py           ``gantry``: dispatcher over commands/
    commands/        one module per subcommand: arguments, calls into the above, printing

Only this package imports mujoco and matplotlib, and lazily: ``gantry`` starts without them.
"""
