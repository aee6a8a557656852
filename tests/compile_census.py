"""A pytest plugin that records the package's Numba compiles per process: which function, which test, how much CPU.

Not collected as tests. Use it to see how much of a run is compiling and what both xdist workers compiled twice::

    NUMBA_CACHE_DIR=$(mktemp -d) CENSUS_DIR=/tmp/census PYTHONPATH=tests python -m pytest -q -p compile_census tests/...
    python tests/compile_census.py /tmp/census

Only outermost compiles are timed (a kernel's compile includes its callees' compiles: counted once, in
the kernel's), in thread CPU seconds; a subprocess's compiles are not seen (it has no plugin).
"""

from __future__ import annotations

import collections
import glob
import json
import os
import sys
import threading
import time
from typing import Any

_current = {"test": "<collection>"}
_records: list[tuple[str, float, str]] = []
_local = threading.local()


def pytest_configure(config: Any) -> None:
    """Register the compile listener (once per process)."""
    from numba.core import event

    class Listener(event.Listener):
        def on_start(self, ev: Any) -> None:
            depth = getattr(_local, "depth", 0)
            if depth == 0:
                _local.start = time.thread_time()
            _local.depth = depth + 1

        def on_end(self, ev: Any) -> None:
            _local.depth -= 1
            if _local.depth == 0:
                func = getattr(ev.data.get("dispatcher"), "py_func", None)
                name = f"{getattr(func, '__module__', '?')}.{getattr(func, '__qualname__', '?')}"
                _records.append((name, time.thread_time() - _local.start, _current["test"]))

    event.register("numba:compile", Listener())


def pytest_runtest_setup(item: Any) -> None:
    """Attribute the following compiles to this test (its setup included)."""
    _current["test"] = item.nodeid


def pytest_unconfigure(config: Any) -> None:
    """Write this process's records to ``$CENSUS_DIR/<worker>-<pid>.json``."""
    folder = os.environ.get("CENSUS_DIR")
    if folder:
        worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
        with open(os.path.join(folder, f"{worker}-{os.getpid()}.json"), "w", encoding="utf-8") as fh:
            json.dump(_records, fh)


def summary(folder: str, top: int = 20) -> str:
    """Total compile CPU, the functions compiled in more than one process, the most expensive ones."""
    by_name: dict[str, list[tuple[str, float, str]]] = collections.defaultdict(list)
    for path in glob.glob(os.path.join(folder, "*.json")):
        worker = os.path.basename(path).split("-")[0]
        with open(path, encoding="utf-8") as fh:
            for name, cpu, test in json.load(fh):
                by_name[name].append((worker, cpu, test))
    total = sum(c for v in by_name.values() for _, c, _ in v)
    again = {n: v for n, v in by_name.items() if len({w for w, _, _ in v}) > 1}
    extra = sum(sum(sorted(c for _, c, _ in v)[:-1]) for v in again.values())
    lines = [f"{sum(map(len, by_name.values()))} outermost compiles of {len(by_name)} names: {total:.1f} s CPU; "
             f"{len(again)} names compiled in more than one process: {extra:.1f} s of it"]
    for name, v in sorted(by_name.items(), key=lambda kv: -sum(c for _, c, _ in kv[1]))[:top]:
        lines.append(f"{sum(c for _, c, _ in v):7.1f} s  x{len(v)}  {','.join(sorted({w for w, _, _ in v}))}  {name}")
    return "\n".join(lines)


if __name__ == "__main__":
    print(summary(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 20))
