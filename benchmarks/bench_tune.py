"""Slider-to-plot latency of ``forcecontrol tune`` in-process (issue 16, target: < 200 ms for Example 9.2).

Builds the tuning page of a scenario (no server, no browser) and moves every slider through a
few of its values; each move runs the page's own callback: re-simulation with the compiled
simulator, the scenario analysis, poles, stability curve, and the update of every Bokeh data
source. Reported: the median and 95th percentile of that time, and the simulation's share.
What the browser adds (websocket, serialisation, drawing) is measured by
``tests/test_workbench_browser.py`` (printed with ``-s``). Asserts nothing.

``--startup N``: instead, start ``forcecontrol tune SCENARIO --no-browser`` N times and report the time
from the process start to the page answering HTTP 200 (issue 32: under 3 s once the kernels are
cached; run once before to fill the cache).

Run: ``PYTHONPATH=src python benchmarks/bench_tune.py [SCENARIO] [--moves 6] [--startup 5]``.
"""

from __future__ import annotations

import argparse
import socket
import statistics
import subprocess
import tempfile
import time
import urllib.request

import numpy as np


def startup(scenario: str, runs: int) -> list[float]:
    """Seconds from starting ``forcecontrol tune`` to its page answering HTTP 200, per run."""
    out = []
    for _ in range(runs):
        with socket.socket() as s:
            s.bind(("localhost", 0))
            port = s.getsockname()[1]
        t0 = time.perf_counter()
        proc = subprocess.Popen(["forcecontrol", "tune", scenario, "--no-browser", "--port", str(port), "--save",
                                 f"{tempfile.mkdtemp()}/tuned.toml"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            while time.perf_counter() - t0 < 120:
                try:
                    with urllib.request.urlopen(f"http://localhost:{port}/", timeout=30) as r:
                        if r.status == 200:
                            break
                except OSError:
                    time.sleep(0.02)
            out.append(time.perf_counter() - t0)
        finally:
            proc.terminate()
            proc.wait()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", nargs="?", default="example-9.2")
    ap.add_argument("--moves", type=int, default=6, help="values visited per slider")
    ap.add_argument("--startup", type=int, default=0, help="measure the start-up (process start to HTTP 200) N times")
    args = ap.parse_args()
    if args.startup:
        t = startup(args.scenario, args.startup)
        print(f"{args.scenario}: forcecontrol tune, process start to HTTP 200 [s]: {', '.join(f'{v:.2f}' for v in t)} "
              f"(median {statistics.median(t):.2f})")
        return
    from forcecontrol.workbench.app import TuneApp

    app = TuneApp(args.scenario, tempfile.mkdtemp() + "/tuned.toml")  # compiles or loads the kernels
    app.latencies.clear()
    sim = []
    for slider in app.sliders.values():
        values = list(slider.values)
        start = values.index(slider.value)
        for v in values[max(0, start - args.moves // 2): start + args.moves // 2 + 1]:
            if v == slider.value:
                continue
            slider.value = v
            sim.append(app.last.seconds.get("simulate", float("nan")))
        slider.value = values[start]
        sim.append(app.last.seconds.get("simulate", float("nan")))
    lat = np.array(app.latencies) * 1000.0
    sim_ms = np.array(sim) * 1000.0
    print(f"{args.scenario}: {len(lat)} slider moves over {len(app.sliders)} sliders")
    print(f"  slider change -> data sources and metrics table updated: median {statistics.median(lat):.1f} ms, "
          f"95th percentile {np.percentile(lat, 95):.1f} ms, max {lat.max():.1f} ms")
    print(f"  of which simulation: median {np.nanmedian(sim_ms):.1f} ms")
    t0 = time.perf_counter()
    app.update()
    print(f"  one more update: {1000 * (time.perf_counter() - t0):.1f} ms")


if __name__ == "__main__":
    main()
