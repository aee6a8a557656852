"""The compiled-kernel cache folder is keyed on the whole package's source."""

from __future__ import annotations

from pathlib import Path

import forcecontrol
from forcecontrol.core import numba_cache


def test_cache_folder_hashes_every_module_of_the_package():
    """The cache folder's name is the hash of all the package's .py files (not core/ alone): a change in
    sim/plant.py (the loops' environment dispatcher) must not reuse loops compiled against the old one."""
    root = Path(forcecontrol.__file__).parent
    assert numba_cache.CACHE_DIR is not None
    assert Path(numba_cache.CACHE_DIR).name == f"forcecontrol-{numba_cache._source_hash(root)}"
    assert numba_cache._source_hash(root) != numba_cache._source_hash(root / "core")
