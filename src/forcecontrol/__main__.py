"""``python -m forcecontrol``: the command line."""

from forcecontrol.cli import main

main()
