"""How a command shows the library's warnings on stderr: one plain line each.

The library speaks through Python warnings (``warnings.warn``): a note on what it read, defaulted
or decided (:class:`~forcecontrol.scenarios.parts_vendor.ConfigNote`,
:class:`~forcecontrol.controllers.search.SearchNote`, ...), a warning on what may be wrong
(:class:`~forcecontrol.errors.DriftWarning`, ...). Python prints each one with the library file and
line that raised it and that line's source, which tell a command's user nothing. While a command
runs, a warning raised by forcecontrol (its category is defined in forcecontrol, or a plain
``UserWarning`` naming a forcecontrol file) is printed instead as ``note: TEXT`` (a category whose name ends in
``Note``) or ``warning: TEXT`` (any other); every other package's warning is printed as Python
prints it. The text keeps no escape sequence or control character (it may quote a file). Which
warnings are shown, and how often, is still decided by the warning filters.
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..core.text import terminal_safe

__all__ = ["show_library_warnings", "library_line"]

_PACKAGE = Path(__file__).resolve().parents[1]


def _ours(category: Any, filename: str) -> bool:
    if str(getattr(category, "__module__", "")).split(".")[0] == "forcecontrol":
        return True
    if category is not UserWarning:  # e.g. NumPy's RuntimeWarning in library code: Python's format, with its place
        return False
    try:
        return Path(filename).resolve().is_relative_to(_PACKAGE)
    except (OSError, ValueError, TypeError):
        return False


def library_line(message: Any, category: Any, filename: str) -> str | None:
    """The line a command prints for a warning (``note: ...`` or ``warning: ...``), or None when
    the warning is not the library's (then Python's own format applies)."""
    if not _ours(category, filename):
        return None
    kind = "note" if getattr(category, "__name__", "").endswith("Note") else "warning"
    return f"{kind}: {terminal_safe(message)}\n"


def show_library_warnings() -> Callable[[], None]:
    """Print the library's warnings as plain lines until the returned function is called (which
    puts back the display that was installed before)."""
    previous = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):  # type: ignore[no-untyped-def]
        text = library_line(message, category, filename)
        if text is None:
            previous(message, category, filename, lineno, file, line)
            return
        out = sys.stderr if file is None else file
        try:
            out.write(text)
        except (OSError, AttributeError):  # stderr closed or gone: the warning is lost, as Python's would be
            pass

    warnings.showwarning = show

    def restore() -> None:
        if warnings.showwarning is show:
            warnings.showwarning = previous

    return restore
