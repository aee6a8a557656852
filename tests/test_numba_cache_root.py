"""The compiled-kernel cache folder is keyed on the whole package's source."""

from __future__ import annotations

import subprocess
import sys

PROBE = (
    "from pathlib import Path\n"
    "import forcecontrol\n"
    "from forcecontrol.core import numba_cache as n\n"
    "root = Path(forcecontrol.__file__).parent\n"
    "whole = n._source_hash(root)\n"
    "print(Path(n.CACHE_DIR).name == 'forcecontrol-' + whole, whole != n._source_hash(root / 'core'))\n"
)


def test_cache_folder_hashes_every_module_of_the_package(tmp_path):
    """The cache folder's name is the hash of all the package's .py files (not core/ alone): a change in
    sim/plant.py (the loops' environment dispatcher) must not reuse loops compiled against the old one."""
    env = {"NUMBA_CACHE_DIR": str(tmp_path), "PATH": "/usr/bin:/bin"}
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, env=env, timeout=120, check=True)
    assert out.stdout.split() == ["True", "True"]
