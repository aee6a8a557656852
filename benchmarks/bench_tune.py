"""Slider-to-plot latency of ``forcecontrol tune`` in-process (issue 16, target: < 200 ms for Example 9.2).

Builds the tuning page of a scenario (no server, no browser) and moves every slider through a
few of its values; each move runs the page's own callback: re-simulation with the compiled
simulator, the scenario analysis, poles, stability curve, and the update of every Bokeh data
source. Reported: the median and 95th percentile of that time, and the simulation's share.
What the browser adds (websocket, serialisation, drawing) is measured by
``tests/test_workbench_browser.py`` (printed with ``-s``). Asserts nothing.

Run: ``PYTHONPATH=src python benchmarks/bench_tune.py [SCENARIO] [--moves 6]``.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", nargs="?", default="example-9.2")
    ap.add_argument("--moves", type=int, default=6, help="values visited per slider")
    args = ap.parse_args()
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
    print(f"  slider change -> data sources updated: median {statistics.median(lat):.1f} ms, "
          f"95th percentile {np.percentile(lat, 95):.1f} ms, max {lat.max():.1f} ms")
    print(f"  of which simulation: median {np.nanmedian(sim_ms):.1f} ms")
    t0 = time.perf_counter()
    app.update()
    print(f"  one more update: {1000 * (time.perf_counter() - t0):.1f} ms")


if __name__ == "__main__":
    main()
