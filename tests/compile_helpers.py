"""Run the console script's ``forcecontrol.cli.main`` in a fresh process and record what Numba compiles there."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

#: the driver: argv[1] the record file, the rest the CLI's arguments; every ``numba:compile`` event's function is
#: written to the record as "module.qualname", in order, even when the command fails
DRIVER = r"""
import json, sys
from numba.core import event

compiled = []

class Compiles(event.Listener):
    def on_start(self, ev):
        func = getattr(ev.data.get("dispatcher"), "py_func", None)
        compiled.append(f"{getattr(func, '__module__', '?')}.{getattr(func, '__qualname__', '?')}")

    def on_end(self, ev):
        pass

event.register("numba:compile", Compiles())
from forcecontrol.cli import main
try:
    main(sys.argv[2:])
finally:
    with open(sys.argv[1], "w") as f:
        json.dump(compiled, f)
"""


def cli_recording_compiles(record: Path, args: list[str], env: dict[str, str], timeout: float = 600,
                           **kwargs) -> tuple[subprocess.CompletedProcess[str], list[str]]:
    """``forcecontrol ARGS`` in a fresh process; (the finished process, the functions it compiled)."""
    done = subprocess.run([sys.executable, "-c", DRIVER, str(record), *args], capture_output=True, text=True, env=env,
                          timeout=timeout, **kwargs)
    return done, (json.loads(record.read_text()) if record.exists() else [])
