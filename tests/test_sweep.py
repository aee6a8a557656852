"""Sweeps: the batched kernel against the Python loop, metrics by hand, the analytic stability
boundary, local against a real Dask cluster, kill and resume, bad definitions rejected up front."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import forcecontrol as fc
from forcecontrol.analysis import force_loop_axes
from forcecontrol.analysis.force_design import operational_mass, sampled_stability_limit
from forcecontrol.cli import app
from forcecontrol.controllers.base import Measurement
from forcecontrol.errors import ScenarioError
from forcecontrol.sim.batch import case_metrics, run_case
from forcecontrol.sweep import (
    SweepDefinition,
    SweepError,
    plot_sweep_map,
    prepare_sweep,
    read_sweep,
    run_sweep,
)
from forcecontrol.task import inclined_plane, planar_rotation

ARM = fc.PlanarTwoLink()
Q0 = ARM.inverse_kinematics([1.0, 0.0])

#: Example 9.3 set-up (chapter arm on the plane x = 1, f_d = 10 N), three schemes, short runs.
SCENARIO = {
    "name": "sweep-test",
    "title": "Example 9.3 schemes",
    "duration": 2.0,
    "robot": {"model": "chapter-arm", "start_position": [1.0, 0.0], "elbow": "up"},
    "environment": {"type": "elastic-plane", "point": [1.0, 0.0], "normal": [-1.0, 0.0], "stiffness": 1e4},
    "controller": {"type": "inner-position", "inertia": [100.0, 100.0], "damping": [500.0, 500.0],
                   "stiffness": [2500.0, 2500.0], "force_gain": [0.00064, 0.0]},
    "reference": {"type": "setpoint", "position": [1.015, 0.1], "force": [10.0, 0.0]},
    "case": [
        {"label": "inner position", "controller": {"integral_gain": [0.0016, 0.0]}},
        {"label": "inner velocity", "controller": {"type": "inner-velocity", "force_gain": [0.0024, 0.0]}},
        {"label": "parallel", "controller": {"type": "parallel", "integral_gain": [0.0016, 0.0]}},
    ],
}


def _scenario(**top):
    s = json.loads(json.dumps(SCENARIO))
    s.update(top)
    return s


#: the samples of the default settle_window (0.1 s at 1 ms) the settled values average, t >= t_end - 0.1 s, both ends
#: included, as `run`'s settled values do (the sweep took 100 and `run` 101: 199.9954210 vs 199.9954761 N)
SETTLED_SAMPLES = 101


def _reference_metrics(y, Ts, window, f_ref, band=0.02):
    """Settling time, overshoot and steady-state error computed directly with NumPy (the test's own)."""
    yf = y[-window:].mean()
    s = yf - y[0]
    outside = np.flatnonzero(np.abs(y - yf) > band * abs(s))
    settling = (outside[-1] + 1) * Ts if outside.size else 0.0
    if outside.size and outside[-1] == len(y) - 1:
        settling = math.nan  # still outside the band at the end: not settled
    overshoot = 100.0 * max(0.0, float((np.sign(s) * (y - yf)).max())) / abs(s)
    return settling, overshoot, yf - f_ref


# ----------------------------------------------------------------------------- kernel and metrics


@pytest.mark.parametrize(
    "make, env",
    [
        (lambda: fc.InnerPositionForceController(ARM, 100, 500, 2500, [0.00064, 0], [0.0016, 0]), "plane"),
        (lambda: fc.InnerVelocityForceController(ARM, 100, 500, 2500, [0.0024, 0]), "plane"),
        (lambda: fc.ParallelForcePositionController(ARM, 100, 500, 2500, [0.00064, 0], [0.0016, 0],
                                                    integral_limit=0.002), "plane"),
        (lambda: fc.InnerVelocityForceController(ARM, 100, 500, 2500, [0.0024, 0.001]), "spring"),
        (lambda: fc.InnerPositionForceController(ARM, 100, 500, 2500, [0.00064, 0], [0.0016, 0],
                                                 task_frame=planar_rotation(0.3)), "plane"),
        (lambda: fc.OperationalSpacePD(ARM, [[2000.0, 100.0], [100.0, 1500.0]], 300.0), "plane"),
        (lambda: fc.JointSpacePD(ARM, 4000.0, 300.0, ARM.inverse_kinematics([1.03, 0.05])), "spring"),
        (lambda: fc.ImpedanceController(ARM, 100, 500, 2500), "plane"),
        (lambda: fc.ImpedanceController(ARM, 100, 500, 2500, force_measurement=False), "spring"),
        (lambda: fc.HybridCompliantController(ARM, inclined_plane(0.4), [[2e-4, 0.0], [0.0, 1e-3]],
                                              20.0, 100.0, 400.0, 40.0), "spring"),
        (lambda: fc.HybridRigidController(ARM, inclined_plane(0.4), velocity_gain=20.0,
                                          velocity_integral_gain=100.0, force_integral_gain=5.0), "plane"),
    ],
)
def test_batched_kernel_reproduces_the_python_loop(make, env):
    """Each compiled law, run by the sweeps' batch kernel, gives the contact force of simulate(engine='python')
    (the user's path: ``Controller.step`` every sample) to round-off (noisy, filtered sensor); with
    tests/test_simulation.py (compiled loop vs Python loop) every law is checked on its three paths."""
    environment = (fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4, damping=20.0) if env == "plane"
                   else fc.LinearSpring([[1e4, 0.0], [0.0, 2e3]], [1.0, 0.0], [[10.0, 0.0], [0.0, 5.0]]))
    sensor = fc.ForceSensor(noise_std=0.5, bias=[0.2, -0.1], cutoff=100.0, seed=3)
    ref = fc.LinearPath([1.0, 0.0], [1.05, 0.1], 0.5, force=[10.0, 0.0])
    py = fc.simulate(ARM, environment, make(), ref, q0=Q0, duration=0.6, sensor=sensor, engine="python")
    ctl = make()
    N, Ts = 600, ctl.sample_time
    bias, noise = sensor.sequences(N + 1, 2)
    ctl.reset(Measurement(Q0, np.zeros(2), environment.wrench(ARM.forward_kinematics(Q0), np.zeros(2)) + bias + noise[0]),
              ref.at(0.0))
    y = np.empty(N + 1)
    assert ctl.compiled_law is not None
    status, last, peak, lost = run_case(
        ctl.compiled_law, np.array(ARM._K), environment.kind, environment.packed(), np.array(ctl._params), ctl.state.copy(),
        ref.sample(np.arange(N + 1) * Ts), bias, noise, sensor.alpha(Ts), Q0, np.zeros(2), Ts,
        py.metadata["substeps"], N, 50.0, np.array([0.6, 0.8]), y,
    )
    assert (status, last) == (0, N)
    np.testing.assert_allclose(y, py.wrench @ [0.6, 0.8], rtol=1e-9, atol=1e-9)
    assert peak == pytest.approx(py.peak_contact_force_norm(), rel=1e-9)


def test_metrics_of_a_first_order_step_by_hand():
    """y = 10 (1 − e^(−t/τ)): settling time τ ln 50 (2 % band), no overshoot, error y_final − f_d."""
    Ts, tau = 1e-3, 0.2
    t = np.arange(4001) * Ts
    y = 10.0 * (1.0 - np.exp(-t / tau))
    st, ov, err, stable, yf = case_metrics(y, len(y) - 1, 0, Ts, 100, 9.0, 0.02, 0.05)
    assert st == pytest.approx(tau * math.log(50.0), abs=2 * Ts)
    assert ov == pytest.approx(0.0, abs=1e-6) and stable == 1.0
    assert err == pytest.approx(1.0, abs=1e-6) and yf == pytest.approx(10.0, abs=1e-6)


def test_metrics_of_a_damped_oscillation_by_hand():
    """Second-order step with ζ = 0.3: overshoot 100 exp(−ζπ/√(1−ζ²)) %, settled and stable."""
    Ts, zeta, wn = 1e-3, 0.3, 10.0
    t = np.arange(6001) * Ts
    wd = wn * math.sqrt(1 - zeta**2)
    y = 1.0 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))
    st, ov, err, stable, yf = case_metrics(y, len(y) - 1, 0, Ts, 100, 1.0, 0.02, 0.05)
    assert ov == pytest.approx(100 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2)), rel=1e-3)
    assert stable == 1.0 and 0.9 < st < 1.5


def test_growing_oscillation_is_unstable_and_diverged_case_has_no_metrics():
    """A growing oscillation is flagged unstable; a diverged run gets NaN metrics and unstable."""
    Ts = 1e-3
    t = np.arange(3001) * Ts
    y = 10.0 + np.exp(0.5 * t) * np.sin(40 * t)
    assert case_metrics(y, len(y) - 1, 0, Ts, 100, 10.0, 0.02, 0.05)[3] == 0.0
    out = case_metrics(y, 200, 2, Ts, 100, 10.0, 0.02, 0.05)
    assert out[3] == 0.0 and all(math.isnan(v) for v in (out[0], out[1], out[2]))


def test_a_signal_that_ends_where_it_began_is_stable_only_if_it_stopped_moving():
    """No step (y_final = y_0, e.g. a tool that ends in free air as it began): settling time and overshoot NaN; a
    force that never rose, or rose once and stayed released, is stable; contact pulses to the very end (a bouncing
    limit cycle, whose last window happens to fall between two pulses) are not (they used to count as stable)."""
    Ts = 1e-3
    t = np.arange(4001) * Ts
    quiet = np.zeros_like(t)
    once = np.where((t > 0.1) & (t < 0.3), 50.0 * np.sin(np.pi * (t - 0.1) / 0.2), 0.0)
    bouncing = np.where(np.sin(2 * np.pi * 7.0 * t) > 0.5, 200.0 * (np.sin(2 * np.pi * 7.0 * t) - 0.5), 0.0)
    bouncing[-100:] = 0.0  # the last window (100 samples) between two pulses: y_final = 0 = y_0
    for y, stable in ((quiet, 1.0), (once, 1.0), (bouncing, 0.0)):
        st, ov, err, got, yf = case_metrics(y, len(y) - 1, 0, Ts, 100, 10.0, 0.02, 0.05)
        assert yf == 0.0 and err == -10.0 and math.isnan(st) and math.isnan(ov)
        assert got == stable


def test_sweep_calls_a_bouncing_case_unstable_as_run_does(tmp_path):
    """example-9.3's inner velocity loop far past its stability limit (k = 1e6 N/m, k_F = 0.005): the tool bounces to
    the end and `run` says the sampled loop is unstable; the sweep row said stable when its last window fell in free
    air (the user's report)."""
    from forcecontrol.scenarios import CaseSpec, build_case
    from forcecontrol.sweep.run import run_block

    d = SweepDefinition.from_options({"environment.stiffness": [1e6], "controller.force_gain[0]": [0.005]}, cases=["3"])
    prep = prepare_sweep("example-9.3", d)
    (job,) = prep.jobs
    row = run_block(prep.jobs, d.settle_band, d.stable_band)[0]
    assert row["status"] == "ok" and row["contact_lost"] and row["peak_force"] > 100.0
    assert row["settled_force"] == 0.0  # the last window in free air, as at t = 0: no step
    cfg = json.loads(json.dumps([c for c in prep.scenario.cases if c.label == job.label][0].config))
    cfg["controller"]["force_gain"][0] = 0.005
    p = build_case(CaseSpec(job.label, cfg, {}))
    axis = force_loop_axes(p["controller"], p["environment"].stiffness_matrix())[0]
    limit = sampled_stability_limit(axis, 1e-3, arm_inertia=operational_mass(ARM, p["q0"], [1.0, 0.0]), low=1e3,
                                    high=1e8, rtol=1e-3)
    assert limit < 1e6 / 1.25  # the analysis: far past the limit
    assert not row["stable"]

def test_sweep_table_matches_per_case_python_simulations():
    """Each row's metrics equal those computed by hand from simulate(engine='python') of the same case."""
    d = SweepDefinition.from_options({"environment.stiffness": [3e3, 3e4]})
    prep = prepare_sweep(_scenario(duration=1.5), d)
    from forcecontrol.sweep.run import run_block

    rows = run_block(prep.jobs, 0.02, 0.05)
    assert [r["engine"] for r in rows] == ["batch"] * 6
    assert any(math.isnan(r["settling_time"]) for r in rows) and any(r["settling_time"] > 0 for r in rows)
    for job, row in zip(prep.jobs, rows):
        scn_case = [c for c in prep.scenario.cases if c.label == job.label][0]
        from forcecontrol.scenarios import CaseSpec, build_case

        cfg = json.loads(json.dumps(scn_case.config))
        cfg["environment"]["stiffness"] = job.values["environment.stiffness"]
        p = build_case(CaseSpec(job.label, cfg, {}))
        res = fc.simulate(p["robot"], p["environment"], p["controller"], p["reference"], q0=p["q0"],
                          duration=1.5, engine="python")
        y = res.wrench[:, 0]
        st, ov, err = _reference_metrics(y, 1e-3, SETTLED_SAMPLES, 10.0)
        assert row["settling_time"] == pytest.approx(st, abs=1e-12, nan_ok=True)
        assert row["overshoot"] == pytest.approx(ov, rel=1e-6, abs=1e-9)
        assert row["steady_state_force_error"] == pytest.approx(err, abs=1e-8)
        assert row["peak_force"] == pytest.approx(res.peak_contact_force_norm(), rel=1e-9)
        norms = np.linalg.norm(res.wrench, axis=1)
        first_contact = np.flatnonzero(norms > 0)[0]
        assert row["status"] == "ok" and row["contact_lost"] == bool(np.any(norms[first_contact:] == 0))


def test_simulated_stability_region_agrees_with_the_analytic_sampled_loop_boundary():
    """Coarse grid over k and k_F: simulated stable exactly where k is below the analysis module's sampled-loop limit."""
    d = SweepDefinition.from_options(
        {"environment.stiffness": "logspace(4, 6, 5)", "controller.force_gain[0]": [0.0008, 0.0024]},
        cases=["inner position", "inner velocity"],
    )
    prep = prepare_sweep(_scenario(duration=4.0), d)
    from forcecontrol.scenarios import CaseSpec, build_case
    from forcecontrol.sweep.run import run_block

    rows = run_block(prep.jobs, 0.02, 0.05)
    verdicts, limits = [], {}
    for job, row in zip(prep.jobs, rows):
        key = (job.label, job.values["controller.force_gain[0]"])
        if key not in limits:  # the limit depends on the scheme and its gains, not on k
            cfg = json.loads(json.dumps([c for c in prep.scenario.cases if c.label == job.label][0].config))
            cfg["controller"]["force_gain"][0] = key[1]
            p = build_case(CaseSpec(job.label, cfg, {}))
            axis = force_loop_axes(p["controller"], p["environment"].stiffness_matrix())[0]
            mx = operational_mass(ARM, p["q0"], [1.0, 0.0])
            limits[key] = sampled_stability_limit(axis, 1e-3, arm_inertia=mx, low=1e3, high=1e8, rtol=1e-3)
        limit = limits[key]
        k = job.values["environment.stiffness"]
        if abs(math.log(k / limit)) < math.log(1.25):
            continue  # within 25 % of the boundary: the linearised model decides nothing there
        verdicts.append((k < limit, row["stable"]))
    assert len(verdicts) >= 16 and {a for a, _ in verdicts} == {True, False}
    assert all(analytic == simulated for analytic, simulated in verdicts)


# ----------------------------------------------------------------------------- where it runs


@pytest.fixture(scope="module")
def cluster():
    """A real dask.distributed.LocalCluster: two worker processes, one thread each."""
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c:
        yield c


def _cluster_sweep(duration=1.0):
    d = SweepDefinition.from_options(
        {"environment.stiffness": "logspace(3, 5.5, 4)", "sensor.seed": "range(0, 2)", "sensor.noise_std": [0.3]},
    )
    return prepare_sweep(_scenario(duration=duration), d)


def test_local_run_and_dask_localcluster_give_identical_tables(tmp_path, cluster):
    """The same sweep on this machine's threads and on a real dask.distributed.LocalCluster: identical tables."""
    prep = _cluster_sweep()
    local = run_sweep(prep, tmp_path / "local.parquet", workers=2, block_size=5)
    remote = run_sweep(prep, tmp_path / "cluster.parquet", scheduler=cluster.scheduler_address, block_size=3)
    assert remote.scheduler.startswith("tcp://") and local.scheduler == "local"
    pd.testing.assert_frame_equal(local.table, remote.table, check_exact=True)
    assert len(local.table) == 24 and local.table["case_id"].tolist() == list(range(24))


def test_a_worker_killed_mid_sweep_loses_no_case(tmp_path, cluster):
    """SIGKILL one Dask worker process while the sweep runs: its tasks rerun, the table equals the local one."""
    import threading

    from dask.distributed import Client

    prep = _cluster_sweep(duration=5.0)
    local = run_sweep(prep, tmp_path / "local.parquet", workers=2)
    with Client(cluster) as client:
        pids = list(client.run(os.getpid).values())
        parts = tmp_path / "k.parquet.parts"
        box = {}
        t = threading.Thread(target=lambda: box.update(r=run_sweep(prep, tmp_path / "k.parquet", scheduler=client,
                                                                     block_size=1)))
        t.start()
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not (parts.exists() and len(list(parts.glob("part-*"))) >= 2):
            time.sleep(0.002)
        done_at_kill = len(list(parts.glob("part-*")))
        os.kill(pids[0], signal.SIGKILL)
        t.join(120)
    assert done_at_kill < 24 and "r" in box
    pd.testing.assert_frame_equal(box["r"].table, local.table, check_exact=True)


def _sweep_file(folder):
    """A scenario file with a [sweep] table: 80 Monte Carlo cases of 40 s (inner velocity loop)."""
    scn = folder / "scn.toml"
    scn.write_text(textwrap.dedent("""
        name = "kill-test"
        duration = 40.0
        [robot]
        start_position = [1.0, 0.0]
        [environment]
        type = "elastic-plane"
        point = [1.0, 0.0]
        normal = [-1.0, 0.0]
        stiffness = 10000.0
        [controller]
        type = "inner-velocity"
        inertia = 100.0
        damping = 500.0
        stiffness = 2500.0
        force_gain = [0.0024, 0.0]
        [reference]
        type = "setpoint"
        position = [1.0, 0.0]
        force = [10.0, 0.0]
        [sweep]
        design = "random"
        samples = 80
        seed = 7
        [sweep.parameters]
        "environment.stiffness" = "loguniform(1e3, 1e5)"
        "controller.force_gain[0]" = "uniform(0.001, 0.003)"
    """))
    return scn


def test_kill_midway_then_resume_gives_the_uninterrupted_table(tmp_path):
    """A sweep SIGKILLed midway in a subprocess, then rerun, equals an uninterrupted run: no case lost or duplicated."""
    scn = _sweep_file(tmp_path)
    out = tmp_path / "killed.parquet"
    parts = tmp_path / "killed.parquet.parts"
    code = (f"from forcecontrol.sweep import run_sweep, prepare_sweep; "
            f"run_sweep(prepare_sweep({str(scn)!r}), {str(out)!r}, workers=1, block_size=1)")
    proc = subprocess.Popen([sys.executable, "-c", code])
    n_at_kill = 0
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        n_at_kill = len(list(parts.glob("part-*.parquet"))) if parts.exists() else 0
        if n_at_kill >= 2:
            os.kill(proc.pid, signal.SIGKILL)
            break
        time.sleep(0.001)
    proc.wait()
    assert proc.returncode == -signal.SIGKILL and not out.exists()
    assert 2 <= n_at_kill < 80
    resumed = run_sweep(prepare_sweep(str(scn)), out, workers=2)
    assert resumed.resumed >= n_at_kill and resumed.ran == 80 - resumed.resumed
    whole = run_sweep(prepare_sweep(str(scn)), tmp_path / "whole.parquet", workers=2)
    assert whole.ran == 80
    pd.testing.assert_frame_equal(resumed.table, whole.table, check_exact=True)
    assert resumed.table["case_id"].tolist() == list(range(80)) and not parts.exists()


def test_ctrl_c_stops_the_cli_keeping_finished_cases_and_the_same_command_resumes(tmp_path):
    """SIGINT to `forcecontrol sweep`: exit 130 with a resume hint, stored cases kept; rerun completes all 80 once."""
    scn = _sweep_file(tmp_path)
    out = tmp_path / "ctrl-c.parquet"
    parts = tmp_path / "ctrl-c.parquet.parts"
    cmd = [sys.executable, "-c", "from forcecontrol.cli import app; app()", "sweep", str(scn), "--out", str(out),
           "--workers", "1", "--block-size", "1", "--no-figure", "--json"]
    # the child starts with SIGINT at its default (a test runner or a library in this process may have set it to
    # "ignore", which a child inherits; Python then never installs its Ctrl-C handler and the signal is lost)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 120
    sent = False
    while time.monotonic() < deadline and proc.poll() is None:
        if parts.exists() and len(list(parts.glob("part-*.parquet"))) >= 2:
            proc.send_signal(signal.SIGINT)
            sent = True
            break
        time.sleep(0.001)
    _, err = proc.communicate(timeout=60)
    assert sent, f"the sweep ended before two parts were seen (exit {proc.returncode}); stderr: {err}"
    assert proc.returncode == 130 and "run the same command again to resume" in " ".join(err.split()), err
    kept = len(list(parts.glob("part-*.parquet")))
    assert 2 <= kept < 80 and not list(parts.glob(".*.tmp"))
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    summary = json.loads(again.stdout)
    assert again.returncode == 0 and summary["resumed"] == kept and summary["ran"] == 80 - kept
    df = pd.read_parquet(out)
    assert df["case_id"].tolist() == list(range(80))


def test_rerun_of_a_finished_sweep_runs_nothing_and_a_different_sweep_is_refused(tmp_path):
    """Same command again: nothing runs; another definition at the same path: SweepError naming both ids."""
    out = tmp_path / "s.parquet"
    d = SweepDefinition.from_options({"environment.stiffness": [1e4]}, cases=["parallel"])
    first = run_sweep(prepare_sweep(_scenario(duration=0.2), d), out)
    again = run_sweep(prepare_sweep(_scenario(duration=0.2), d), out)
    assert (first.ran, again.ran, again.resumed) == (1, 0, 1)
    other = SweepDefinition.from_options({"environment.stiffness": [2e4]}, cases=["parallel"])
    with pytest.raises(SweepError, match=r"holds a different sweep \(id \w+, this one \w+\); choose another output path, "
                                         r"or --overwrite \(overwrite=True\) to replace it"):
        run_sweep(prepare_sweep(_scenario(duration=0.2), other), out)


def test_table_has_the_definition_in_its_metadata_and_pandas_opens_it(tmp_path):
    """pandas.read_parquet opens the table; its schema metadata holds the sweep definition."""
    out = tmp_path / "m.parquet"
    d = SweepDefinition.from_options({"controller.damping": "linspace(400, 600, 2)"}, cases=["2"])
    run_sweep(prepare_sweep(_scenario(duration=0.3), d), out)
    df = pd.read_parquet(out)
    assert list(df["controller.damping"]) == [400.0, 600.0] and set(df["case"]) == {"inner velocity"}
    for col in ("settling_time", "overshoot", "steady_state_force_error", "peak_force", "stable", "contact_lost"):
        assert col in df.columns
    _, meta = read_sweep(out)
    assert meta["definition"]["parameters"][0] == {
        "path": "controller.damping", "spec": "linspace(400, 600, 2)", "values": [400.0, 600.0]}
    assert meta["n_cases"] == 2 and meta["scenario"] == "sweep-test"


def test_top_level_sample_time_and_substeps_can_be_swept_and_match_simulate(tmp_path):
    """Sweeping sample_time and substeps: each row's peak force equals simulate(engine='python') of that case."""
    d = SweepDefinition.from_options({"sample_time": [1e-3, 2e-3], "substeps": [1, 3]}, cases=["inner velocity"])
    res = run_sweep(prepare_sweep(_scenario(duration=0.4), d), tmp_path / "t.parquet")
    df = res.table
    assert list(df["integration_substeps"]) == [1, 3, 1, 3] and list(df["samples"]) == [400, 400, 200, 200]
    for _, row in df.iterrows():
        arm = fc.PlanarTwoLink()
        ctl = fc.InnerVelocityForceController(arm, 100, 500, 2500, [0.0024, 0.0], sample_time=row["sample_time"])
        r = fc.simulate(arm, fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4), ctl, fc.Setpoint([1.015, 0.1], [10.0, 0.0]),
                        q0=Q0, duration=0.4, substeps=int(row["substeps"]), engine="python")
        assert row["peak_force"] == pytest.approx(r.peak_contact_force_norm(), rel=1e-9)


def test_cases_outside_the_kernel_run_through_simulate_with_the_same_metrics(tmp_path):
    """A realistic sensor (delay, Python loop only) makes the case run through simulate(); metrics as by hand."""
    d = SweepDefinition.from_options({"sensor.delay_samples": [0, 3]}, cases=["inner velocity"])
    res = run_sweep(prepare_sweep(_scenario(duration=1.0), d), tmp_path / "r.parquet")
    assert list(res.table["engine"]) == ["simulate", "simulate"]
    from forcecontrol.scenarios import CaseSpec, build_case

    base = [c for c in prepare_sweep(_scenario(duration=1.0), d).scenario.cases if c.label == "inner velocity"][0]
    for _, row in res.table.iterrows():
        cfg = json.loads(json.dumps(base.config))
        cfg["sensor"] = {"delay_samples": int(row["sensor.delay_samples"])}
        p = build_case(CaseSpec("x", cfg, {}))
        r = fc.simulate(p["robot"], p["environment"], p["controller"], p["reference"], q0=p["q0"], duration=1.0,
                        sensor=p["sensor"])
        st, ov, err = _reference_metrics(r.wrench[:, 0], 1e-3, SETTLED_SAMPLES, 10.0)
        assert row["overshoot"] == pytest.approx(ov, rel=1e-9, abs=1e-12)
        assert row["steady_state_force_error"] == pytest.approx(err, abs=1e-9)
        assert row["settling_time"] == pytest.approx(st, abs=1e-12, nan_ok=True)


def test_random_design_is_reproducible_and_within_its_distributions():
    """Monte Carlo draws depend only on the seed and stay inside their ranges; seeds give distinct noise."""
    spec = {"environment.stiffness": "loguniform(1e3, 1e5)", "sensor.seed": "randint(0, 1000)"}
    a = SweepDefinition.from_options(spec, design="random", samples=50, seed=1).assignments()
    b = SweepDefinition.from_options(spec, design="random", samples=50, seed=1).assignments()
    c = SweepDefinition.from_options(spec, design="random", samples=50, seed=2).assignments()
    assert a == b and a != c
    k = np.array([x["environment.stiffness"] for x in a])
    assert np.all((k >= 1e3) & (k < 1e5)) and all(isinstance(x["sensor.seed"], int) for x in a)


# ----------------------------------------------------------------------------- bad definitions


@pytest.mark.parametrize(
    "params, kwargs, match",
    [
        ({"controller.stifness": "1,2"}, {}, r"unknown parameter path 'controller.stifness'.*has no key 'stifness'"),
        ({"enviroment.stiffness": "1e4"}, {}, r"unknown parameter path 'enviroment.stiffness': no table 'enviroment'"),
        ({"robot.parameters.m_l3": "1"}, {}, r"robot.parameters.<name>"),
        ({"environment.stiffness": "linspace(1e3, 1e4, 0)"}, {}, r"needs a positive integer num"),
        ({"sensor.seed": "range(5, 5)"}, {}, r"empty range 'range\(5, 5\)'"),
        ({"environment.stiffness": "[]"}, {}, r"empty range"),
        ({"environment.stiffness": "uniform(1e3, 1e4)"}, {}, r"is a distribution and needs design = 'random'"),
        ({"environment.stiffness": "loguniform(1e4, 1e3)"}, {"design": "random", "samples": 3}, r"empty range"),
        ({"environment.stiffness": "logspace(3, 4)"}, {}, r"takes 3 numbers; got 2"),
        ({"environment.stiffness": "1e4, -5"}, {}, r"sweep case 1 .*environment.stiffness=-5.*stiffness"),
        ({"sensor.seed": "linspace(0, 1, 2)"}, {}, r"key 'seed' must be an integer"),
        ({"controller.force_gain[5]": "0.001"}, {}, r"index \[5\] needs a list of more than 5 entries"),
        ({"environment.stiffness": "1e4"}, {"cases": ["nope"]}, r"case 'nope' is not in scenario 'sweep-test'"),
        ({"environment.stiffness": "1e4"}, {"design": "random"}, r"samples must be an integer in \[1, "),
        ({}, {}, r"at least one parameter"),
    ],
)
def test_bad_sweep_definitions_are_rejected_before_any_case_runs(tmp_path, params, kwargs, match):
    """Unknown paths, empty ranges, malformed specs and values failing validation: SweepError, nothing written."""
    out = tmp_path / "never.parquet"
    with pytest.raises(SweepError, match=match):
        d = SweepDefinition.from_options(params, **kwargs)
        run_sweep(_scenario(), out, d)
    assert not out.exists() and not (tmp_path / "never.parquet.parts").exists()
    assert issubclass(SweepError, ScenarioError)


def test_cli_sweep_writes_table_and_reports_json(tmp_path):
    """`forcecontrol sweep NAME --param ... --json` writes the table and reports the case count."""
    out = tmp_path / "cli.parquet"
    r = CliRunner().invoke(app, [
        "sweep", "example-9.3", "--param", "environment.stiffness=1e3,1e5", "--case", "3",
        "--out", str(out), "--no-figure", "--json",
    ])
    assert r.exit_code == 0, r.output
    summary = json.loads(r.output)
    assert summary["cases"] == 2 and summary["files"]["table"] == str(out) and out.exists()


def test_cli_rejects_a_bad_parameter_with_a_clear_message(tmp_path):
    """A misspelt path exits with code 2 and names the parameter and the valid keys."""
    out = str(tmp_path / "x.parquet")
    r = CliRunner().invoke(app, ["sweep", "example-9.3", "--param", "controller.stifness=1", "--out", out])
    assert r.exit_code == 2 and "controller.stifness" in r.output and "expected one of" in r.output


def test_cli_refuses_a_key_given_to_set_and_swept(tmp_path):
    """--set of a key the sweep varies: refused (exit 2) naming it, nothing written (the table ran the swept values
    while --json reported the --set one)."""
    out = tmp_path / "x.parquet"
    r = CliRunner().invoke(app, ["sweep", "example-9.3", "--param", "environment.stiffness=1e3,2e3", "--set",
                                 "environment.stiffness=5e3", "--out", str(out)])
    assert r.exit_code == 2 and "--set environment.stiffness: the sweep varies it" in r.output
    assert not out.exists()


def test_cli_names_a_scheduler_address_it_cannot_use(tmp_path):
    """--scheduler 'not an address': a clear error naming the option and the address (exit 2, JSON error object with
    --json), not a ValueError traceback."""
    r = CliRunner().invoke(app, ["sweep", "example-9.2", "--param", "environment.stiffness=1e3,2e3", "--scheduler",
                                 "not an address", "--out", str(tmp_path / "d.parquet"), "--no-figure", "--json"])
    assert r.exit_code == 2, r.output
    err = json.loads(r.stdout)["error"]
    assert err["type"] == "SweepError" and "--scheduler 'not an address': cannot connect" in err["message"]
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no parts folder left behind: nothing was run


def test_sigterm_stops_the_cli_sweep_as_ctrl_c_does_and_says_so(tmp_path, monkeypatch):
    """SIGTERM while the sweep runs (`kill`, a job scheduler's stop): the finished cases are stored, the command says it
    was terminated and how to resume, exits 143, and leaves SIGTERM's handler as it found it (before: the command
    ended at once, said nothing, and left its worker processes running)."""
    import forcecontrol.sweep.run as sweep_run

    real = sweep_run.run_sweep

    def terminated_after_two_cases(*args, progress=None, **kwargs):
        def tick(done, total):
            progress(done, total)
            if done >= 2:
                os.kill(os.getpid(), signal.SIGTERM)
        return real(*args, progress=tick, **kwargs)

    monkeypatch.setattr(sweep_run, "run_sweep", terminated_after_two_cases)
    before = signal.getsignal(signal.SIGTERM)
    out = tmp_path / "t.parquet"
    r = CliRunner().invoke(app, ["sweep", "example-9.3", "--param", "environment.stiffness=linspace(1e3,1e4,8)",
                                 "--set", "duration=0.2", "--workers", "1", "--block-size", "1", "--out", str(out),
                                 "--no-figure"])
    assert r.exit_code == 143, r.output
    said = " ".join(r.output.split())
    assert "terminated (SIGTERM): finished cases are stored in" in said and "run the same command again to resume" in said
    assert 2 <= len(list(out.with_name(out.name + ".parts").glob("part-*.parquet"))) < 48
    assert signal.getsignal(signal.SIGTERM) is before


def test_a_figure_drawn_for_another_sweep_is_not_replaced_without_force(tmp_path):
    """Two sweeps whose tables differ by their suffix (s.parquet, s.pq) share the figure s.png: the second leaves the
    first's figure untouched and says why (its table is written, exit 0); with --force it replaces it and says so; the
    same sweep again redraws its own figure without a word (before: the other sweep's figure was replaced silently)."""
    def sweep(out, stiffness, *extra):
        return CliRunner().invoke(app, ["sweep", "example-9.2", "--param", f"environment.stiffness={stiffness}",
                                        "--set", "duration=0.2", "--out", str(tmp_path / out), *extra])

    first = sweep("s.parquet", "1e3,2e3")
    assert first.exit_code == 0, first.output
    png = tmp_path / "s.png"
    drawn = png.read_bytes()
    other = sweep("s.pq", "3e3,4e3")
    said = " ".join(other.output.split())
    assert other.exit_code == 0 and (tmp_path / "s.pq").is_file(), other.output
    assert "no figure drawn: the sweep's figure" in said and "was drawn for another sweep" in said, said
    assert png.read_bytes() == drawn
    forced = sweep("s.pq", "3e3,4e3", "--force")
    said = " ".join(forced.output.split())
    assert forced.exit_code == 0 and "was drawn for another sweep" in said and "replaced by this sweep's figure" in said
    assert png.read_bytes() != drawn
    again = sweep("s.pq", "3e3,4e3")
    assert again.exit_code == 0 and "another sweep" not in again.output, again.output


def test_cli_names_an_out_folder_it_cannot_write_in():
    """--out in a folder no file can be created in (/proc): a clear error naming --out (exit 2), not a traceback."""
    r = CliRunner().invoke(app, ["sweep", "example-9.2", "--param", "environment.stiffness=1e3,2e3", "--out",
                                 "/proc/x.parquet", "--no-figure"])
    assert r.exit_code == 2, r.output
    assert "cannot write next to '/proc/x.parquet'" in r.output and "choose another --out" in r.output


def test_cli_says_what_it_does_with_a_check_only_key_and_a_table_not_named_parquet(tmp_path):
    """Sweeping `tolerance` (used only by the checks against the book) says the responses are the same (the rows were
    identical with no word); an --out not named .parquet says the table is Parquet anyway."""
    r = CliRunner().invoke(app, ["sweep", "example-9.2", "--param", "tolerance=0.1,0.2", "--param", "duration=0.2",
                                 "--case", "1", "--out", str(tmp_path / "t.csv"), "--no-figure"])
    assert r.exit_code == 0, r.output
    text = " ".join(r.output.split())
    assert "'tolerance' is used only by the checks against the book's values" in text
    assert "the table is written in Parquet whatever its suffix" in text
    rows = pd.read_parquet(tmp_path / "t.csv")
    assert len(rows) == 2 and rows["peak_force"].nunique() == 1


def test_a_sweep_over_its_run_limit_counted_with_the_cases_is_refused_before_anything_is_built(monkeypatch):
    """10⁶ variations x 6 cases: refused naming the product before a variation is made (the limit counted the
    variations alone: 6·10⁶ jobs, about 27 GB, were built)."""
    d = SweepDefinition.from_options({"environment.stiffness": "linspace(1e3, 1e6, 1000)",
                                      "duration": "linspace(1, 2, 1000)"})
    monkeypatch.setattr(SweepDefinition, "assignments", lambda *a, **k: pytest.fail("variations made before the check"))
    with pytest.raises(SweepError, match=r"1,000,000 variations x 6 cases = 6,000,000 runs, more than the 1,000,000"):
        prepare_sweep("example-9.3", d)


def test_an_out_ending_in_png_keeps_its_table_and_draws_the_figure_beside_it(tmp_path):
    """--out t.png --force: the table stays a readable Parquet file and the figure goes to t-figure.png (it was drawn
    over the table, which the next run then called a file forcecontrol had not written)."""
    out = tmp_path / "t.png"
    r = CliRunner().invoke(app, ["sweep", "example-9.2", "--param", "environment.stiffness=1e3,2e3", "--param",
                                 "duration=0.2", "--case", "1", "--out", str(out), "--force"])
    assert r.exit_code == 0, r.output
    assert len(pd.read_parquet(out)) == 2
    assert (tmp_path / "t-figure.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_map_figure_is_written_with_the_boundary(tmp_path):
    """plot_sweep_map writes a PNG of the metrics over two swept parameters (analytic boundary included)."""
    d = SweepDefinition.from_options(
        {"environment.stiffness": "logspace(4, 6, 3)", "controller.force_gain[0]": [0.001, 0.002]},
        cases=["inner velocity"],
    )
    res = run_sweep(prepare_sweep(_scenario(duration=0.5), d), tmp_path / "f.parquet")
    png = plot_sweep_map(res, "environment.stiffness", "controller.force_gain[0]", tmp_path / "f.png", resolution=6)
    assert png.exists() and png.stat().st_size > 10_000


def test_reference_keys_are_the_hash_of_each_cases_samples():
    """Sweep preparation hashes a described reference's samples once per description; every job's key
    is still the SHA-256 of its own samples (here Problem 9.10's path with the sample time swept)."""
    import hashlib

    d = SweepDefinition.from_options(["sample_time=0.001,0.002", "controller.force_gain=100,200"], cases=["1"])
    prep = prepare_sweep("problem-9.10", d)
    assert prep.n_cases == 4
    for j in prep.jobs:
        samples = np.ascontiguousarray(j.reference.sample(np.arange(j.N + 1) * j.Ts), dtype=np.float64)
        assert j.ref_key == hashlib.sha256(samples.tobytes()).hexdigest()
    assert len({j.ref_key for j in prep.jobs}) == 2  # one per sample time


def test_the_sweeps_settled_force_is_runs_settled_value(monkeypatch):
    """example-9.2, both cases: the sweep's settled_force equals `run`'s settled f_x (SimulationResult.settled_values
    over the scenario's settle_window) to round-off, and the sweep runs the kernel it was prepared with on every worker
    (the job carries it), whatever FORCECONTROL_SWEEP_KERNEL the worker has."""
    from forcecontrol.scenarios import build_case
    from forcecontrol.sweep.block import run_block

    prep = prepare_sweep("example-9.2", SweepDefinition.from_options({"duration": [1.0]}))
    rows = run_block(prep.jobs, 0.02, 0.05)
    cases = {c.label: c for c in fc.scenario("example-9.2").with_(duration=1.0).cases}
    for job, row in zip(prep.jobs, rows):
        p = build_case(cases[job.label])
        r = fc.simulate(p["robot"], p["environment"], p["controller"], p["reference"], q0=p["q0"], duration=1.0)
        want = r.settled_values(float(p["settle_window"]))["fx"]
        assert row["settled_force"] == pytest.approx(abs(want), rel=1e-9)
    assert {j.kernel for j in prep.jobs if j.fast} == {prep.metadata["kernel"]}
    monkeypatch.setenv("FORCECONTROL_SWEEP_KERNEL", "scalar" if prep.metadata["kernel"] == "lanes8" else "lanes8")
    again = run_block(prep.jobs, 0.02, 0.05)  # a worker with another setting runs the prepared kernel, to the bit
    assert json.dumps(again, sort_keys=True, default=str) == json.dumps(rows, sort_keys=True, default=str)
