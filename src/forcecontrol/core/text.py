"""Text from files (scenario titles, case labels, names, column names, messages) shown literally.

A scenario file is data, not markup: what it says must reach a terminal, a figure or a page as
the characters it holds, and quickly.

* :func:`terminal_safe` removes ANSI/VT escape sequences (CSI such as colours and cursor moves,
  OSC such as window titles and OSC 8 hyperlinks, DCS/SOS/PM/APC strings), their 8-bit C1 forms,
  the other C0/C1 control characters (carriage return, backspace, bell, ...) and the Unicode
  bidirectional overrides that reorder what a reader sees; newlines and tabs stay unless asked.
* :func:`figure_safe` also escapes ``$`` so matplotlib draws the text as text, not mathtext
  (``$\\frac{$`` in a title made matplotlib raise ``ParseSyntaxException``), unless the caller
  asks for mathtext; and it bounds the length (a 1 MB label took minutes to lay out).
* :func:`shorten` bounds a text's length with an ellipsis.
"""

from __future__ import annotations

import re

__all__ = ["LABEL_LIMIT", "TITLE_LIMIT", "figure_safe", "plain_text", "shorten", "terminal_safe"]

LABEL_LIMIT = 200  # characters of a label (case, legend, axis, column) shown in a figure or a terminal
TITLE_LIMIT = 500  # characters of a title

_SEQUENCES = re.compile(
    r"\x1b\[[0-?]*[ -/]*[@-~]?"  # CSI: ESC [ params intermediates final
    r"|\x1b\][^\x07\x1b\x9c]*(?:\x07|\x1b\\|\x9c)?"  # OSC (titles, OSC 8 hyperlinks) to BEL or ST
    r"|\x1b[PX^_][^\x1b\x9c]*(?:\x1b\\|\x9c)?"  # DCS, SOS, PM, APC strings to ST
    r"|\x1b[ -/]*[0-~]?"  # the other escape sequences (charset selection, ESC c reset, ...)
    r"|\x9b[0-?]*[ -/]*[@-~]?"  # 8-bit CSI
    r"|\x9d[^\x07\x1b\x9c]*(?:\x07|\x1b\\|\x9c)?"  # 8-bit OSC
    r"|[\x90\x98\x9e\x9f][^\x1b\x9c]*(?:\x1b\\|\x9c)?"  # 8-bit DCS, SOS, PM, APC
)
_CONTROLS = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u200e\u200f\u202a-\u202e\u2066-\u2069]")


def shorten(text: str, limit: int | None) -> str:
    """``text`` cut to at most ``limit`` characters, the last one an ellipsis when cut (None: no limit)."""
    if limit is None or len(text) <= limit:
        return text
    return text[: max(limit - 1, 0)] + "…"


def terminal_safe(text: object, limit: int | None = None, *, newlines: bool = True) -> str:
    """``str(text)`` without escape sequences or control characters, at most ``limit`` characters.

    Args:
        newlines: keep newlines and tabs (False: each becomes a space, for one-line fields).
    """
    s = _CONTROLS.sub("", _SEQUENCES.sub("", str(text)))
    if not newlines:
        s = s.replace("\n", " ").replace("\t", " ")
    return shorten(s, limit)


def plain_text(text: object, limit: int | None = LABEL_LIMIT) -> str:
    """One line of literal text for a figure or a page (no controls, no newlines), bounded."""
    return terminal_safe(text, limit, newlines=False)


def figure_safe(text: object, limit: int | None = LABEL_LIMIT, *, mathtext: bool = False) -> str:
    """Text for matplotlib drawn as written: controls removed, bounded, ``$`` escaped (unless ``mathtext``)."""
    s = terminal_safe(text, limit)
    return s if mathtext else s.replace("$", r"\$")
