"""User text in a plot (a program's or a machine file's name): drawn as it is spelled.

Matplotlib reads ``$...$`` in any text as mathtext (a file named ``x$\\foo{$.ngc`` made
``gantry run`` exit 3 with a mathtext ValueError) and cannot draw a lone surrogate (a file
name that is not UTF-8 reaches Python as surrogate escapes: TypeError in the font code).
"""

from __future__ import annotations


def literal_text(text: str) -> str:
    """``text`` as a plot may draw it: ``$`` escaped (never mathtext), and characters that are
    no text (the surrogate escapes of a path's non-UTF-8 bytes, lone surrogates) as ``\\xNN``
    or ``\\udNNN``."""
    try:  # a path's undecodable bytes, as the file system holds them
        text = text.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")
    except UnicodeEncodeError:  # a surrogate that stands for no byte
        text = text.encode("utf-8", "backslashreplace").decode("utf-8")
    return text.replace("$", r"\$")
