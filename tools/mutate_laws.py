"""Mutation testing of the control laws: does a wrong law make a test fail?

    python tools/mutate_laws.py            # every law mutant, prints the kill table
    python tools/mutate_laws.py --list     # the mutants only
    python tools/mutate_laws.py M3 M7a     # some of them

Kept for its command line: the mutants and the runner are in ``tools/mutate.py`` (its successor,
which also mutates the safety layer, sweeps, metrics, energy tanks, the admittance bandwidth check
and the calibration, and takes ``--root`` to mutate a private worktree). Without mutant keys this
runs the ``laws`` area only, as before.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from mutate import MUTANTS, ROOT, SRC, TESTS, Mutant, main, run  # noqa: E402

__all__ = ["MUTANTS", "ROOT", "SRC", "TESTS", "Mutant", "main", "run"]

if __name__ == "__main__":
    sys.exit(main(default_area="laws"))
