"""``python -m forcecontrol``: the command line."""

from forcecontrol.cli import app

app(prog_name="forcecontrol")
