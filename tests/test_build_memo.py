"""A sweep's build memo changes what is rebuilt, never what is built.

Reference: the same cases built without a memo (every table checked, every part built anew).
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

from forcecontrol.scenarios import CaseSpec, build_case, load_scenario
from forcecontrol.scenarios.schema import copy_tree
from forcecontrol.sweep.cases import _plant


def _variants(name, case_index, edits):
    case = load_scenario(name).cases[case_index]
    out = []
    for edit in edits:
        cfg = copy.deepcopy(case.config)
        edit(cfg)
        out.append(CaseSpec(case.label, cfg, {}))
    return out


def _set(path, value):
    """Set ``path`` to ``value`` where the case has that key (the tables differ between schemes)."""
    def edit(cfg):
        node = cfg
        for k in path[:-1]:
            node = node.setdefault(k, {})
        if path[-1] in node:
            node[path[-1]] = value
    return edit


EDITS = [
    _set(("environment", "stiffness"), 1e3),
    _set(("environment", "stiffness"), 5e3),
    _set(("controller", "damping"), [450.0, 450.0]),
    _set(("controller", "force_gain"), 2.0),
    _set(("reference", "force"), [5.0, 0.0]),
    _set(("robot", "start_position"), [1.0, 0.05]),
    _set(("environment", "stiffness"), 1e3),  # equal to the first again
]


@pytest.mark.parametrize("name,index", [("example-9.3", 0), ("example-9.3", 4), ("example-9.2", 0), ("example-9.4", 0)])
def test_parts_with_a_memo_equal_parts_without(name, index):
    specs = _variants(name, index, EDITS)
    memo: dict = {}
    for spec in specs:
        fresh = build_case(CaseSpec(spec.label, copy.deepcopy(spec.config), {}))
        kept = build_case(CaseSpec(spec.label, copy.deepcopy(spec.config), {}), memo=memo)
        assert np.array_equal(fresh["q0"], kept["q0"])
        assert fresh["robot"].parameters == kept["robot"].parameters
        assert fresh["environment"].describe() == kept["environment"].describe()
        assert type(fresh["controller"]) is type(kept["controller"])
        assert np.array_equal(fresh["controller"]._params, kept["controller"]._params)
        t = np.linspace(0.0, 2.0, 41)
        assert np.array_equal(fresh["reference"].sample(t), kept["reference"].sample(t))
        for key in ("duration", "substeps", "settle_window", "tolerance", "qd0"):
            assert fresh[key] == kept[key]
        p_fresh, p_kept = _plant(spec.label, fresh, {}), _plant(spec.label, kept, {}, memo)
        assert (p_fresh.nsub, p_fresh.N, p_fresh.ref_key) == (p_kept.nsub, p_kept.N, p_kept.ref_key)


def test_the_memo_shares_immutable_parts_only():
    specs = _variants("example-9.3", 0, EDITS[:2])
    memo: dict = {}
    a, b = (build_case(s, memo=memo) for s in specs)
    assert a["robot"] is b["robot"] and a["reference"] is b["reference"]  # the planar arm, a set-point
    assert a["controller"] is not b["controller"] and a["environment"] is not b["environment"]
    assert a["q0"] is not b["q0"]  # arrays are handed out as copies


def test_memoised_tables_are_handed_out_as_copies():
    spec = _variants("example-9.3", 0, [_set(("environment", "stiffness"), 2e3)])[0]
    memo: dict = {}
    build_case(spec, memo=memo)
    before = copy.deepcopy(memo)
    parts = build_case(spec, memo=memo)
    parts["reference"]  # noqa: B018 - built from a copy of the memoised table
    for key, value in memo.items():
        if key[0] == "table":
            assert value == before[key]


def test_copy_tree_is_a_deep_copy():
    data = {"a": [1.0, 2.0], "b": {"c": [[1, 2], [3, 4]], "d": "x"}, "e": np.arange(3.0)}
    out = copy_tree(data)
    assert out["a"] == data["a"] and out["a"] is not data["a"]
    assert out["b"]["c"] == data["b"]["c"] and out["b"]["c"][0] is not data["b"]["c"][0]
    assert np.array_equal(out["e"], data["e"]) and out["e"] is not data["e"]


def test_a_sensor_handed_to_build_case_is_the_cases_sensor_and_a_sweep_shares_it_per_sensor_values():
    """build_case(sensor=) uses the given sensor; in a sweep over stiffness x seed, the cases of
    one seed share one sensor object across plants, and each reads the seed it was given."""
    from forcecontrol.scenarios.build import build_sensor
    from forcecontrol.sweep import SweepDefinition, prepare_sweep

    case = load_scenario("example-9.3").cases[0]
    s = build_sensor("x", {"noise_std": 0.3, "seed": 4}, 1e-3)
    assert build_case(case, sensor=s)["sensor"] is s
    d = SweepDefinition.from_options({"environment.stiffness": [1e3, 1e4, 1e5], "sensor.seed": [1, 2],
                                      "sensor.noise_std": [0.2]}, cases=["1"])
    jobs = prepare_sweep("example-9.3", d).jobs
    by_seed = {}
    for j in jobs:
        assert j.sensor.seed == j.values["sensor.seed"] and float(j.sensor.noise_std) == 0.2
        by_seed.setdefault(j.values["sensor.seed"], set()).add(id(j.sensor))
    assert {k: len(v) for k, v in by_seed.items()} == {1: 1, 2: 1}


def test_prepare_sweep_pauses_the_collector_while_building_and_restores_it():
    """The cyclic collector is off while the cases are built and as it was after (on or off),
    also when a case fails."""
    import gc

    import forcecontrol.sweep.prepare as prep
    from forcecontrol.sweep import SweepDefinition, SweepError, prepare_sweep

    seen = []
    real = prep._job

    def spy(*args, **kwargs):
        seen.append(gc.isenabled())
        return real(*args, **kwargs)

    d = SweepDefinition.from_options({"environment.stiffness": [1e3, 1e4]}, cases=["1"])
    try:
        prep._job = spy
        assert gc.isenabled()
        prepare_sweep("example-9.3", d)
        assert seen == [False, False] and gc.isenabled()
        gc.disable()
        prepare_sweep("example-9.3", d)
        assert not gc.isenabled()
        gc.enable()
        with pytest.raises(SweepError):
            prepare_sweep("example-9.3", SweepDefinition.from_options({"environment.stiffness": [-1.0]}, cases=["1"]))
        assert gc.isenabled()
    finally:
        prep._job = real
        gc.enable()


def test_a_stateful_sensor_is_never_shared_between_cases(tmp_path):
    """A realistic sensor (delay, noise: state advanced by measure()) is built for each case even when
    the sensor values repeat, so that cases run in parallel threads do not share it (review of
    session 15: a shared one failed with 'measure must be called for samples ... in order')."""
    from forcecontrol.sweep import SweepDefinition, prepare_sweep, run_sweep

    d = SweepDefinition.from_options({"sensor.delay_samples": [1], "sensor.noise_std": [0.5], "duration": [0.5],
                                      "sensor.seed": [3, 3, 3, 3]}, cases=["1"])
    prep = prepare_sweep("example-9.3", d)
    assert len({id(j.sensor) for j in prep.jobs}) == 4
    res = run_sweep(prep, tmp_path / "x.parquet", workers=4, block_size=1)
    table = res.table
    assert list(table["status"]) == ["ok"] * 4
    assert table["peak_force"].nunique() == 1  # equal cases, equal results
