"""The browser workbench (``forcecontrol tune``) and the interactive HTML reports (``forcecontrol report``).

Not imported by ``import forcecontrol``: the web stack (Panel/Bokeh, plotly) is loaded only by the
modules that draw (:mod:`.app`, :mod:`.report`). :mod:`.session` holds what the tuning page
computes, with no web dependency.
"""

from __future__ import annotations

import importlib.util

__all__ = ["require"]


def require(package: str) -> None:
    """Check that an optional web package (``"panel"``, ``"plotly"``) is installed, without importing it.

    Raises:
        ImportError: it is missing, naming the extra that installs it.
    """
    if importlib.util.find_spec(package) is None:
        raise ImportError(f"this command needs {package}: pip install 'forcecontrol[workbench]'")
