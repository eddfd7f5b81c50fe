"""A program or machine file whose name matplotlib would misread: ``$...$`` (mathtext, a
ValueError) or bytes that are not UTF-8 (surrogate escapes, a TypeError in the font code)
made ``gantry run`` and ``gantry ballbar`` exit 3 while drawing; now drawn as spelled."""

from __future__ import annotations

import os

import pytest

from gantry_sim.sim.plot_text import literal_text


@pytest.mark.parametrize(
    ("name", "shown"),
    [
        ("x$\\foo{$.ngc", "x\\$\\foo{\\$.ngc"),
        (os.fsdecode(b"prog\xff.ngc"), "prog\\xff.ngc"),
        ("odd\ud800.toml", "odd\\ud800.toml"),
        ("plain é.ngc", "plain é.ngc"),
    ],
)
def test_names_are_drawn_as_spelled(name, shown):
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    assert literal_text(name) == shown
    fig = Figure()
    fig.add_subplot().set_title(literal_text(name))
    fig.canvas.draw()  # raised ValueError / TypeError with the raw name
