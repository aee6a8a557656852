"""The sweeps' lane kernel (sim/batch_lanes.py) against the scalar batch kernel, and its sin/cos (sim/trig.py).

The bound: the lane kernel runs the scalar kernel's arithmetic operation for operation, with one
difference, sin/cos (``trig.sincos``, within 1 ulp of libm). So (1) built with libm's sin/cos it
equals the scalar kernel to the bit on every output of every case, and (2) with its own sin/cos
each output differs by that ulp carried through a closed loop: the loops here damp it, so the
float outputs agree to 1e-9 relative (measured on the 144 random cases here: at most 1.5e-10, the
overshoot of a lightly damped case; 44 of them equal to the bit), and the discrete ones
(status, last sample, stable, contact lost) are equal.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from compile_helpers import cli_recording_compiles
from forcecontrol.sim.batch import OUT_COLUMNS
from forcecontrol.sim.trig import sincos
from forcecontrol.sweep import SweepDefinition, prepare_sweep, read_sweep, run_sweep
from forcecontrol.sweep.block import run_fast

_DISCRETE = ("status", "last_sample", "contact_lost", "stable")
_FLOATS = tuple(c for c in OUT_COLUMNS if c not in _DISCRETE)
RTOL = 1e-9  # the float outputs: sin/cos within 1 ulp carried through a settling loop (measured <= 1.5e-10)


def _ulps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a − b| in units of the spacing of doubles at b."""
    d = np.abs(a - b)
    return np.where(d == 0.0, 0.0, d / np.spacing(np.abs(b)))


def _many(xs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    from numba import njit

    @njit
    def run(xs, s, c):  # pragma: no cover - compiled
        for i in range(xs.shape[0]):
            s[i], c[i] = sincos(xs[i])

    s, c = np.empty_like(xs), np.empty_like(xs)
    run(xs, s, c)
    return s, c


def _special() -> np.ndarray:
    k = np.arange(-8, 9)
    grid = np.concatenate([k * np.pi / 2, k * np.pi / 4])
    return np.concatenate([grid, np.nextafter(grid, np.inf), np.nextafter(grid, -np.inf),
                           [0.0, 1e-300, -1e-300, 5e-324, 2.0**-27, 1e-8, -1e-8, 4 * np.pi, -4 * np.pi]])


def test_sincos_is_within_one_ulp_of_numpy_and_libm_over_four_turns():
    """sin and cos of 10^6 random angles in [−4π, 4π] and the special points are within 1 ulp of NumPy's and libm's."""
    xs = np.concatenate([np.random.default_rng(3).uniform(-4 * np.pi, 4 * np.pi, 1_000_000), _special()])
    s, c = _many(xs)
    assert _ulps(s, np.sin(xs)).max() <= 1.0 and _ulps(c, np.cos(xs)).max() <= 1.0
    libm_s = np.array([math.sin(x) for x in xs[::50]])
    libm_c = np.array([math.cos(x) for x in xs[::50]])
    assert _ulps(s[::50], libm_s).max() <= 1.0 and _ulps(c[::50], libm_c).max() <= 1.0


def test_sincos_special_values():
    """sin(±0) = ±0 (sign kept), cos(0) = 1, sin(π/2) = 1 exactly; NaN and ±inf give NaN."""
    s, c = _many(np.array([0.0, -0.0, np.pi / 2, np.nan, np.inf, -np.inf]))
    assert s[0] == 0.0 and not np.signbit(s[0]) and s[1] == 0.0 and np.signbit(s[1])
    assert c[0] == 1.0 and c[1] == 1.0 and s[2] == 1.0
    assert np.isnan(s[3:]).all() and np.isnan(c[3:]).all()


def _scenario(environment: str = "plane") -> dict:
    """Impedance with force measurement on a plane or on a linear spring (the two built-in kinds)."""
    base = {
        "name": "lanes", "duration": 0.5, "sample_time": 0.001,
        "robot": {"model": "chapter-arm", "start_position": [1.0, 0.0], "elbow": "up"},
        "controller": {"type": "impedance", "force_measurement": True, "inertia": [100.0, 100.0],
                       "damping": [500.0, 500.0], "stiffness": [2500.0, 2500.0]},
        "reference": {"type": "setpoint", "position": [1.1, 0.1]},
        "sensor": {"noise_std": 0.0, "seed": 1},
    }
    plane = {"type": "elastic-plane", "point": [1.0, 0.0], "normal": [-1.0, 0.0], "stiffness": 1e4}
    spring = {"type": "linear-spring", "stiffness": 1e3, "rest_position": [1.0, 0.0], "damping": 5.0}
    return {**base, "environment": plane if environment == "plane" else spring}


_DEFINITION = {
    "environment.stiffness": "loguniform(1e2, 1e6)",
    "controller.inertia[0]": "loguniform(1, 200)",
    "controller.damping[0]": "loguniform(5, 2000)",
    "controller.stiffness[0]": "loguniform(1e2, 1e5)",
    "reference.position": "[[1.1, 0.1], [0.97, 0.05], [1.02, 0.3]]",
    "sample_time": "[0.0005, 0.001, 0.002]",
    "duration": "uniform(0.15, 0.6)",
    "sensor.noise_std": "[0.0, 0.5]",
}


@pytest.fixture(scope="module")
def jobs() -> list:
    """72 random cases per environment kind (144), every one in the kernels."""
    d = SweepDefinition.from_options(_DEFINITION, design="random", samples=72, seed=11)
    jobs = prepare_sweep(_scenario("plane"), d).jobs + prepare_sweep(_scenario("spring"), d).jobs
    assert all(j.fast for j in jobs) and len({j.law for j in jobs}) == 1
    return jobs


@pytest.fixture(scope="module")
def outputs(jobs: list) -> tuple[np.ndarray, np.ndarray]:
    law = jobs[0].law
    return run_fast(law, jobs, 0.02, 0.05, kernel="scalar"), run_fast(law, jobs, 0.02, 0.05, kernel="lanes8")


def test_the_random_cases_cover_what_the_lanes_must_handle(jobs: list, outputs: tuple[np.ndarray, np.ndarray]):
    """The set holds both kinds, several N, Ts and sub-step counts, diverged cases, contact lost and kept."""
    scalar, _ = outputs
    assert {j.env_kind for j in jobs} == {1, 2}
    assert len({j.N for j in jobs}) > 20 and len({j.Ts for j in jobs}) == 3 and len({j.nsub for j in jobs}) > 2
    status = scalar[:, 0]
    assert (status != 0).sum() >= 5 and (status == 0).sum() >= 50
    assert (scalar[:, 3] == 1.0).sum() >= 3 and (scalar[:, 3] == 0.0).sum() >= 3


def test_lanes_with_libm_trig_equal_the_scalar_kernel_to_the_bit(jobs: list, outputs: tuple[np.ndarray, np.ndarray]):
    """With libm's sin/cos the lane kernel's every output of every case equals the scalar kernel's (same arithmetic)."""
    from forcecontrol.sim import batch_lanes

    scalar, _ = outputs
    original = batch_lanes.run_lanes
    try:
        batch_lanes.run_lanes = lambda law, order, *a: original(law, order, *a, trig="libm")
        libm = run_fast(jobs[0].law, jobs, 0.02, 0.05, kernel="lanes8")
    finally:
        batch_lanes.run_lanes = original
    assert np.array_equal(libm, scalar, equal_nan=True)


def test_lanes_equal_the_scalar_kernel_within_the_trig_bound(outputs: tuple[np.ndarray, np.ndarray]):
    """Vector sin/cos: discrete outputs equal, float outputs within 1e-9 relative (the 1-ulp trig carried through)."""
    scalar, lanes = outputs
    for c in _DISCRETE:
        i = OUT_COLUMNS.index(c)
        assert np.array_equal(lanes[:, i], scalar[:, i]), c
    for c in _FLOATS:
        i = OUT_COLUMNS.index(c)
        np.testing.assert_allclose(lanes[:, i], scalar[:, i], rtol=RTOL, atol=1e-9, equal_nan=True, err_msg=c)
    # not a copy of the scalar kernel: the trig does move the last bits
    assert not np.array_equal(lanes, scalar, equal_nan=True)


def test_a_sweep_table_on_lanes_matches_the_scalar_one_and_names_its_kernel(tmp_path, monkeypatch):
    """run_sweep: the lanes8 table equals the scalar one in status, stable, contact_lost, samples, and within the
    bound in the metrics; the table's metadata names the kernel (and the lanes' note)."""
    d = SweepDefinition.from_options({"environment.stiffness": "logspace(3, 5, 6)", "controller.damping[0]": [300.0, 700.0]})
    tables = {}
    for kernel in ("scalar", "lanes8"):
        monkeypatch.setenv("FORCECONTROL_SWEEP_KERNEL", kernel)
        res = run_sweep(prepare_sweep(_scenario(), d), tmp_path / f"{kernel}.parquet", workers=1)
        tables[kernel], meta = read_sweep(tmp_path / f"{kernel}.parquet")
        assert res.metadata["kernel"] == meta["kernel"] == kernel
        assert ("1 ulp" in meta.get("kernel_note", "")) == (kernel == "lanes8")
    a, b = tables["scalar"], tables["lanes8"]
    for c in ("status", "stable", "contact_lost", "samples", "case_id"):
        assert a[c].tolist() == b[c].tolist(), c
    for c in ("settling_time", "overshoot", "steady_state_force_error", "peak_force", "settled_force"):
        np.testing.assert_allclose(b[c].to_numpy(), a[c].to_numpy(), rtol=RTOL, atol=1e-9, equal_nan=True, err_msg=c)


def test_an_unknown_kernel_choice_is_refused_by_name(monkeypatch):
    """FORCECONTROL_SWEEP_KERNEL=fast is a SweepError naming the variable, the choices and the value."""
    from forcecontrol.sweep.spec import SweepError

    monkeypatch.setenv("FORCECONTROL_SWEEP_KERNEL", "fast")
    d = SweepDefinition.from_options({"environment.stiffness": [1e3]})
    with pytest.raises(SweepError, match=r"FORCECONTROL_SWEEP_KERNEL must be one of lanes8, scalar; got 'fast'"):
        prepare_sweep(_scenario(), d)


def test_a_second_sweep_process_on_lanes_compiles_nothing(tmp_path):
    """The lane kernels are found again on disk: a second 'forcecontrol sweep' process compiles none of the package's
    functions."""
    import os

    runs = []
    for n in range(2):
        done, compiled = cli_recording_compiles(
            tmp_path / f"compiled-{n}.json",
            ["sweep", "example-9.2", "--case", "1", "-p", "environment.stiffness=1000,2000", "--workers", "1", "--no-figure",
             "--out", str(tmp_path / f"s{n}.parquet")],
            {k: v for k, v in os.environ.items() if k != "FORCECONTROL_SWEEP_KERNEL"}, timeout=900,
        )
        assert done.returncode == 0, done.stderr[-3000:]
        runs.append(compiled)
    assert [n for n in runs[1] if n.startswith("forcecontrol.")] == []
    assert read_sweep(tmp_path / "s1.parquet")[1]["kernel"] == "lanes8"


@pytest.mark.parametrize("scenario, parameters", [
    ("example-9.3", {"environment.stiffness": "logspace(3, 5, 4)"}),  # inner position, inner velocity, parallel (with state)
    ("example-9.4", {"duration": [0.6, 0.9]}),  # hybrid force/motion on a compliant environment (with state)
])
def test_every_law_runs_on_lanes_within_the_trig_bound(scenario: str, parameters: dict):
    """The other schemes' own compiled laws (and their state) on lanes: discrete outputs equal the scalar kernel's,
    floats within 1e-9 relative or 1e-9 absolute (the steady-state error is y_final − f_ref: its error is y_final's)."""
    prep = prepare_sweep(scenario, SweepDefinition.from_options(parameters))
    groups: dict = {}
    for j in prep.jobs:
        assert j.fast
        groups.setdefault(j.law, []).append(j)
    assert len(groups) == (3 if scenario == "example-9.3" else 1)
    assert any(j.ctrl_s.size for j in prep.jobs)  # laws with integral state
    for law, fast in groups.items():
        scalar = run_fast(law, fast, 0.02, 0.05, kernel="scalar")
        lanes = run_fast(law, fast, 0.02, 0.05, kernel="lanes8")
        for c in _DISCRETE:
            i = OUT_COLUMNS.index(c)
            assert np.array_equal(lanes[:, i], scalar[:, i]), (law.__name__, c)
        for c in _FLOATS:
            i = OUT_COLUMNS.index(c)
            np.testing.assert_allclose(lanes[:, i], scalar[:, i], rtol=RTOL, atol=1e-9, equal_nan=True,
                                       err_msg=f"{law.__name__}: {c}")
