"""Sweeps and Monte Carlo runs over scenario parameters, locally or on a Dask cluster.

A sweep varies scenario parameters (grid or random design), simulates every case, and stores
per-case metrics (settling time, overshoot, steady-state force error, peak force, stable,
contact lost) in a Parquet table with the sweep's definition in its metadata::

    from forcecontrol.sweep import SweepDefinition, prepare_sweep, run_sweep

    d = SweepDefinition.from_options({"environment.stiffness": "logspace(3, 6, 40)"})
    result = run_sweep(prepare_sweep("example-9.3", d), "k-sweep.parquet")
    result.table.groupby("case").stable.mean()

The same sweep as a table of a scenario file (``forcecontrol sweep FILE`` runs it)::

    [sweep]
    design = "grid"                 # or "random" with samples = N and seed = S
    cases = ["1", "3", "5"]         # scenario cases (labels or 1-based indices); all by default
    [sweep.parameters]
    "environment.stiffness" = "logspace(3, 6, 40)"
    "controller.force_gain[0]" = [0.0006, 0.0012, 0.0024]
    "sensor.seed" = "range(0, 10)"

Dask is imported only when a scheduler is given; matplotlib only by :func:`plot_sweep_map`.
"""

from .figures import plot_sweep_map, stability_boundary
from .run import (
    METRIC_COLUMNS,
    CaseJob,
    PreparedSweep,
    SweepResult,
    load_sweep_scenario,
    prepare_sweep,
    read_sweep,
    run_block,
    run_sweep,
)
from .spec import SweepDefinition, SweepError, SweepParameter, parse_parameter, parse_values

__all__ = [
    "SweepDefinition",
    "SweepParameter",
    "SweepError",
    "PreparedSweep",
    "SweepResult",
    "CaseJob",
    "METRIC_COLUMNS",
    "parse_parameter",
    "parse_values",
    "load_sweep_scenario",
    "prepare_sweep",
    "run_sweep",
    "run_block",
    "read_sweep",
    "stability_boundary",
    "plot_sweep_map",
]
