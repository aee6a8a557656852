"""Text from files printed by the CLI as the characters it holds (rich is imported only in cli/).

:func:`escape` is :func:`rich.markup.escape` after :func:`~forcecontrol.core.text.terminal_safe`:
no terminal escape sequence (colours, cursor moves, window titles, OSC 8 hyperlinks) or control
character from a scenario title, case label, column name or error message reaches the terminal,
``[red]`` stays text, and a very long text is cut with an ellipsis.
"""

from __future__ import annotations

from rich.markup import escape as _rich_escape

from ..core.text import terminal_safe

__all__ = ["escape", "rich_safe", "terminal_safe"]

PRINT_LIMIT = 2000  # characters of one printed text (a label, a title, a message)


def rich_safe(text: object, limit: int | None = PRINT_LIMIT) -> str:
    """``text`` for a rich markup string: controls and escape sequences removed, markup escaped, bounded."""
    return _rich_escape(terminal_safe(text, limit))


escape = rich_safe
