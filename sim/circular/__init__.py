"""Circular tests after ISO 230-4: the virtual ballbar and the per-radius feed search.

    program.py      the circular-test G-code: tangent lead-in, full circle, lead-out (CCW, CW)
    figures.py      G, F, centre offset, G(b) of a traced circle (NumPy only)
    signatures.py   what shapes the deviation: ellipse (harmonic 2), reversal spikes and steps
    diagnostics.py  servo mismatch, squareness, scaling, backlash, lateral play: one joint fit
    summary.py      the human summary, the G gate, polar.png's scale and text
    ballbar.py      run_ballbar: simulate CCW and CW, analyse; write ballbar.json and traces
    tune.py         tune: per radius, the highest feed whose circle stays within a tolerance

ballbar and tune run full simulations through :mod:`gantry_sim.sim.api`; program, figures,
signatures, diagnostics and summary are pure functions of their inputs.
"""
