"""A pytest plugin that records where the suite's time goes: per test, its wall time and CPU time, the CPU of the
subprocesses it waited for included; per process, its wall, its own CPU and its children's.

Not collected as tests. Use it to see which files cost the suite its minutes (issue 33 item 4), on an idle machine::

    SUITE_PROFILE_DIR=/tmp/profile PYTHONPATH=tests python -m pytest -q -p suite_profile
    python tests/suite_profile.py /tmp/profile [N]

A test's CPU is ``getrusage`` of the worker (``RUSAGE_SELF``) and of its waited children (``RUSAGE_CHILDREN``)
over the test's setup, call and teardown: a subprocess counts once it has been waited for (``subprocess.run``,
``Popen.wait``); a helper process a test leaves running (a browser, a Dask cluster of a module fixture) counts in
the test that stops it, or in the process's total only.
"""

from __future__ import annotations

import collections
import glob
import json
import os
import resource
import sys
import time
from typing import Any

_t0 = time.monotonic()
_rows: list[tuple[str, float, float]] = []  # (node id, wall [s], CPU [s])
_open: dict[str, tuple[float, float]] = {}


def _cpu() -> float:
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


def pytest_runtest_logstart(nodeid: str, location: Any) -> None:
    _open[nodeid] = (time.monotonic(), _cpu())


def pytest_runtest_logfinish(nodeid: str, location: Any) -> None:
    start = _open.pop(nodeid, None)
    if start is not None:
        _rows.append((nodeid, time.monotonic() - start[0], _cpu() - start[1]))


def pytest_sessionfinish(session: Any) -> None:
    folder = os.environ.get("SUITE_PROFILE_DIR")
    if not folder:
        return
    os.makedirs(folder, exist_ok=True)
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    name = os.environ.get("PYTEST_XDIST_WORKER", "main")
    with open(os.path.join(folder, f"{name}.json"), "w", encoding="utf-8") as f:
        json.dump({"wall": time.monotonic() - _t0, "self": s.ru_utime + s.ru_stime,
                   "children": c.ru_utime + c.ru_stime, "tests": _rows}, f)


def summary(folder: str, most: int = 30) -> str:
    """Per process (wall, own and children's CPU) and the ``most`` costliest files and tests by CPU."""
    lines, files, tests = [], collections.defaultdict(lambda: [0.0, 0.0, 0]), []
    total_cpu = 0.0
    paths = sorted(glob.glob(os.path.join(folder, "*.json")))
    workers = any(not p.endswith("main.json") for p in paths)
    for path in paths:
        with open(path, encoding="utf-8") as f:
            d = json.load(f)
        main = path.endswith("main.json")
        # with xdist, the main process's children are the workers (counted in their own files), and it sees every
        # test again as a report: its own CPU only
        total_cpu += d["self"] + (0.0 if main and workers else d["children"])
        lines.append(f"{os.path.basename(path)[:-5]:>6}: wall {d['wall']:7.1f} s, CPU {d['self']:7.1f} s own "
                     f"+ {d['children']:7.1f} s children" + (" (the workers)" if main and workers else ""))
        if main and workers:
            continue
        for node, wall, cpu in d["tests"]:
            f_ = files[node.split("::")[0]]
            f_[0] += wall
            f_[1] += cpu
            f_[2] += 1
            tests.append((cpu, wall, node))
    lines.append(f"total CPU {total_cpu:.1f} s; in tests {sum(v[1] for v in files.values()):.1f} s")
    lines.append(f"\n{'CPU [s]':>8} {'wall [s]':>8} {'tests':>5}  file")
    for name, (wall, cpu, n) in sorted(files.items(), key=lambda kv: -kv[1][1])[:most]:
        lines.append(f"{cpu:8.1f} {wall:8.1f} {n:5d}  {name}")
    lines.append(f"\n{'CPU [s]':>8} {'wall [s]':>8}  test")
    for cpu, wall, node in sorted(tests, reverse=True)[:most]:
        lines.append(f"{cpu:8.1f} {wall:8.1f}  {node}")
    return "\n".join(lines)


if __name__ == "__main__":
    print(summary(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 30))
