"""prepare_sweep's shared parts (scenarios/build_share.PartShare) against a fresh build of every case.

A sweep's compiled cases share the parts of equal tables (an environment built once per distinct
[environment] values, a controller once per distinct [controller] values, or per environment too when
its builder reads the environment), the plant once per environment object, and set only the swept
paths in a case's configuration. The reference here is the plain route: a deep copy of the case's
configuration, ``build_case`` without any memo and ``_plant`` without a memo, for every case.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from forcecontrol.scenarios import CaseSpec, build_case, load_scenario
from forcecontrol.scenarios.schema import copy_tree
from forcecontrol.sweep import SweepDefinition, prepare_sweep
from forcecontrol.sweep.cases import _first_sample, _job, _plant
from forcecontrol.sweep.paths import _apply, set_values

#: planar scenarios whose cases the batch kernel runs (every compiled planar law, both environments)
SCENARIOS = ("example-9.1", "example-9.2", "example-9.3", "example-9.4", "problem-9.3", "hybrid-rigid-plane",
             "arm-circle-contour", "variable-stiffness", "arm-unknown-circle", "impact")
COMPILED = ("example-9.1", "example-9.2", "example-9.3", "example-9.4", "problem-9.3")  # the others: simulate()
ARRAYS = ("K", "env_p", "ctrl_p", "ctrl_s", "q0", "qd0", "d")
SCALARS = ("Ts", "N", "nsub", "window", "f_ref", "ref_key", "fast", "env_kind", "law", "alpha", "label", "row_label")


def _controller_key(cfg: dict) -> tuple[str, float]:
    ctl = cfg["controller"]
    for key in ("damping", "velocity_gain", "force_gain", "stiffness_high", "contact_force"):
        if key in ctl:
            return key, float(np.ravel(ctl[key])[0])
    raise AssertionError(f"no swept controller key in {sorted(ctl)}")


def _fresh_jobs(scn, definition):
    """Every case by the plain route: copy_tree + _apply, build_case without memo, _plant without memo."""
    out = []
    cid = 0
    for case in scn.cases:
        for values in definition.assignments():
            cfg = copy_tree(case.config)
            for p in definition.parameters:
                _apply(cfg, p, values[p.path], case.label)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                built = build_case(CaseSpec(case.label, cfg, {}), where=f"case {cid}")
            plant = _plant(case.label, built, None, None)
            sensor = built["sensor"]
            out.append(_job(cid, case.label, values, plant, sensor, _first_sample(sensor, built["robot"].task_dim)))
            cid += 1
    return out


@pytest.mark.parametrize("name", SCENARIOS)
def test_shared_parts_pack_the_same_bits_as_a_fresh_build_of_every_case(name):
    """Every job's packed arrays, law and run shape equal, bit for bit, those of a fresh build_case per case."""
    scn = load_scenario(name)
    key, v = _controller_key(scn.cases[0].config)
    env = scn.cases[0].config["environment"]
    ekey, k = ("stiffness", float(env["stiffness"])) if "stiffness" in env else ("stabilisation_frequency", 100.0)
    definition = SweepDefinition.from_options({
        f"environment.{ekey}": [k, 2 * k, 4 * k],
        f"controller.{key}": [v, 1.25 * v],
        "sensor.noise_std": [0.0, 0.3],
    })
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = prepare_sweep(scn, definition)
    fresh = _fresh_jobs(scn, definition)
    assert len(prep.jobs) == len(fresh) == 12 * len(scn.cases)
    assert any(j.fast for j in prep.jobs) == (name in COMPILED)
    for a, b in zip(prep.jobs, fresh):
        b.row_label = a.row_label or b.label
        for f in SCALARS[:-1]:
            assert getattr(a, f) == getattr(b, f), (name, a.case_id, f)
        for f in ARRAYS:
            x, y = getattr(a, f), getattr(b, f)
            assert (x is None) == (y is None), (name, a.case_id, f)
            if x is not None:
                assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), (name, a.case_id, f)
        assert a.values == b.values
        assert type(a.sensor) is type(b.sensor) and a.sensor.describe() == b.sensor.describe()
        assert np.array_equal(a.reference.sample(np.arange(5) * a.Ts), b.reference.sample(np.arange(5) * b.Ts))


def test_a_grid_builds_each_distinct_environment_and_controller_once(monkeypatch):
    """3 stiffnesses x 4 dampings: 3 planes and 4 impedance controllers built, not 12 of each (the old route built 12)."""
    from forcecontrol.controllers import impedance
    from forcecontrol.environments import elastic

    scn = load_scenario("example-9.2")  # loading builds (checks) every case once: not counted
    counts = {"plane": 0, "ctl": 0}
    plane_init, ctl_init = elastic.ElasticPlane.__init__, impedance.ImpedanceController.__init__

    def plane(self, *a, **kw):
        counts["plane"] += 1
        plane_init(self, *a, **kw)

    def ctl(self, *a, **kw):
        counts["ctl"] += 1
        ctl_init(self, *a, **kw)

    monkeypatch.setattr(elastic.ElasticPlane, "__init__", plane)
    monkeypatch.setattr(impedance.ImpedanceController, "__init__", ctl)
    definition = SweepDefinition.from_options(
        {"environment.stiffness": "logspace(3, 5, 3)", "controller.damping": "linspace(300, 700, 4)"}, cases=["1"])
    prep = prepare_sweep(scn, definition)
    assert prep.n_cases == 12 and all(j.fast for j in prep.jobs)
    assert counts == {"plane": 3, "ctl": 4}


def test_cases_run_by_simulate_keep_their_own_parts():
    """A case the batch kernel cannot run (a drifting sensor: simulate() runs it) gets its own controller and environment."""
    definition = SweepDefinition.from_options({"environment.stiffness": [1e3, 1e4], "controller.damping": [400.0, 500.0],
                                               "sensor.drift": [0.0, 0.1]}, cases=["1"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = prepare_sweep("example-9.2", definition)
    slow = [j for j in prep.jobs if not j.fast]
    assert len(slow) >= 4
    for part in ("controller", "environment"):
        assert len({id(j.parts[part]) for j in slow}) == len(slow), part


def test_set_values_equals_a_deep_copy_with_the_values_applied_and_leaves_the_scenario_alone():
    """set_values gives the configuration copy_tree + _apply gives (indexed and new paths too); the case's own is unchanged."""
    scn = load_scenario("example-9.4")
    case = scn.cases[2]
    before = copy_tree(case.config)
    definition = SweepDefinition.from_options({"environment.stiffness": [5e3], "controller.compliance": [3e-4],
                                               "controller.velocity_gain": [90.0], "sensor.seed": [7], "duration": [0.5]})
    for values in definition.assignments():
        want = copy_tree(case.config)
        for p in definition.parameters:
            _apply(want, p, values[p.path], case.label)
        got = set_values(case.config, list(definition.parameters), values, case.label)
        assert got == want
        assert got["robot"] is case.config["robot"]  # not swept: shared, not copied
    assert case.config == before


@pytest.mark.parametrize("drift", [0.0, 0.1], ids=["compiled", "simulate"])
def test_a_part_that_warns_warns_once_for_every_case_as_a_fresh_build_does(monkeypatch, drift):
    """A controller whose constructor warns is built (and warns) once per case, compiled or not: no warning lost or doubled."""
    from forcecontrol.controllers import impedance

    scn = load_scenario("example-9.2")
    init = impedance.ImpedanceController.__init__

    def noisy(self, robot, inertia, damping, *a, **kw):
        warnings.warn(f"built with damping {damping}", UserWarning, stacklevel=2)
        init(self, robot, inertia, damping, *a, **kw)

    monkeypatch.setattr(impedance.ImpedanceController, "__init__", noisy)
    params = {"environment.stiffness": [1e3, 1e4, 1e5], "controller.damping": [400.0, 500.0]}
    definition = SweepDefinition.from_options({**params, "sensor.drift": [drift]} if drift else params, cases=["1"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        prep = prepare_sweep(scn, definition)
    said = sorted(str(w.message) for w in caught if w.category is UserWarning)
    assert all(j.fast == (drift == 0.0) for j in prep.jobs)
    assert said == sorted(f"built with damping {d}" for _ in range(3) for d in (400.0, 500.0))


@pytest.mark.parametrize("drift", [0.0, 0.1], ids=["compiled", "simulate"])
def test_a_warning_shown_once_under_the_default_filter_is_shown_once(monkeypatch, drift):
    """Under the "default" filter a builder's same warning is shown once per sweep, as when every case is built afresh."""
    from forcecontrol.controllers import impedance

    scn = load_scenario("example-9.2")
    # the compiled functions loaded first: Numba's first load resets the registries of warnings shown
    prepare_sweep(scn, SweepDefinition.from_options({"environment.stiffness": [1e3]}, cases=["1"]))
    init = impedance.ImpedanceController.__init__

    def noisy(self, *a, **kw):
        warnings.warn("the same note for every controller", UserWarning, stacklevel=2)
        init(self, *a, **kw)

    monkeypatch.setattr(impedance.ImpedanceController, "__init__", noisy)
    params = {"environment.stiffness": [1e3, 1e4, 1e5], "controller.damping": [400.0, 500.0, 600.0]}
    definition = SweepDefinition.from_options({**params, "sensor.drift": [drift]} if drift else params, cases=["1"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        prepare_sweep(scn, definition)
    assert [str(w.message) for w in caught if w.category is UserWarning] == ["the same note for every controller"]
