"""Environment.reads_orientation: an environment that declares its wrench independent of the end-effector's
orientation really is (its wrench with NaN Euler angles equals its wrench with any angles), every such class of the
library is covered here, a wrong declaration gives NaN rather than a number, and the 6-D runs that skip the angles
in the integrator's stages give the same logs to the bit as the runs that compute them."""

from __future__ import annotations

import inspect
from pathlib import Path

import numpy as np
import pytest

import forcecontrol.environments as envs
from forcecontrol.environments import ElasticMesh
from forcecontrol.environments.base import Environment
from forcecontrol.environments.friction import STICK, FrictionalContact
from forcecontrol.environments.heightfield_extra import BumpField
from forcecontrol.environments.spatial import ConstantWrench, Table
from forcecontrol.environments.surfaces import ElasticCylinder, ElasticSphere, HeightField
from forcecontrol.scenarios import load_scenario, run_scenario

MESHES = Path(__file__).parent / "meshes"


def _orientation_free() -> list[Environment]:
    """One 6-D instance of every library environment class that declares ``reads_orientation = False``."""
    rng = np.random.default_rng(0)
    heights = 0.4 + 0.01 * rng.standard_normal((8, 9))
    stuck = FrictionalContact(Table([0.4, 0.0, 0.4], [0.1, -0.2, 1.0], 5e3, 30.0), 0.8, 0.5, 1.0)
    stuck.mode, stuck.anchor = STICK, np.array([0.41, 0.01, 0.38])  # the bristle's spring and damper
    return [
        Table([0.4, 0.0, 0.4], [0.1, -0.2, 1.0], 5e3, 30.0),
        ConstantWrench([1.0, -2.0, 3.0, 0.1, 0.2, -0.3]),
        ElasticSphere([0.4, 0.0, 0.4], 0.1, 5e3, 30.0, task_dim=6),
        ElasticCylinder([0.4, 0.0, 0.4], [0.3, 1.0, 0.0], 0.1, 5e3, 30.0, task_dim=6),
        HeightField(heights, [0.3, -0.1], [0.03, 0.03], 5e3, 30.0, task_dim=6),
        BumpField([0.3, -0.1], 0.02, (12, 12), 0.4, 0.005, 0.1, stiffness=5e3, damping=30.0, task_dim=6),
        ElasticMesh.from_file(MESHES / "icosphere2.stl", 5e3, 30.0, offset=[0.4, 0.0, 0.4], task_dim=6),  # R = 0.1 m
        FrictionalContact(HeightField(heights, [0.3, -0.1], [0.03, 0.03], 5e3, 30.0, task_dim=6), 0.6, 0.4, 2.0),  # sliding
        stuck,
    ]


def _subclasses(cls: type) -> set[type]:
    out = set()
    for sub in cls.__subclasses__():
        out |= {sub} | _subclasses(sub)
    return out


def test_every_orientation_free_environment_of_the_library_is_covered():
    import forcecontrol.environments.friction  # noqa: F401  (every module of the package loaded)
    import forcecontrol.environments.rigid  # noqa: F401

    declared = {c for c in _subclasses(Environment) if c.__module__.startswith("forcecontrol.")
                and not inspect.isabstract(c) and not c.reads_orientation}
    covered = {type(e) for e in _orientation_free()}
    # a base class (ElasticSurface) is covered by its subclasses; every concrete class by an instance of its own
    missing = [c for c in declared if c not in covered and not any(issubclass(k, c) for k in covered if k is not c)]
    assert not missing, missing
    assert declared >= covered
    assert envs.SpatialSpring.reads_orientation  # its moment spring reads the orientation


def test_orientation_free_wrenches_do_not_read_the_angles():
    """Near each surface (inside and outside it), at random velocities: the wrench with NaN angles is the wrench
    with random angles, bit for bit, and some states are in contact."""
    rng = np.random.default_rng(1)
    for env in _orientation_free():
        touched = 0
        for _ in range(200):
            p = np.array([0.4, 0.0, 0.4]) + 0.12 * rng.uniform(-1.0, 1.0, 3)
            v = rng.standard_normal(6) * 0.2
            with_angles = env.wrench(np.concatenate([p, rng.uniform(-3.0, 3.0, 3)]), v)
            without = env.wrench(np.concatenate([p, np.full(3, np.nan)]), v)
            np.testing.assert_array_equal(without, with_angles, err_msg=type(env).__name__)
            touched += bool(np.any(with_angles))
        assert touched > 0, type(env).__name__


def test_a_wrong_declaration_gives_nan_not_a_number():
    """A table whose wrench reads the angles (a moment from φ_e) but declares it does not: the run's plant sees NaN
    (the simulator stops on it), never a number computed from made-up angles."""
    import forcecontrol as fc
    from forcecontrol.errors import SimulationDivergedError
    from forcecontrol.scenarios import build_case

    class Twisting(Table):
        def wrench(self, x, xd):
            h = super().wrench(x, xd)
            if np.any(h):
                h[3:] = 0.1 * x[3:]
            return h

    parts = build_case(load_scenario("panda-admittance-contact").cases[0])
    table = parts["environment"]
    wrong = Twisting(table.point, table.normal, table.stiffness, table.damping)
    with pytest.raises(SimulationDivergedError):
        fc.simulate(parts["robot"], wrong, parts["controller"], parts["reference"], q0=parts["q0"], duration=0.3,
                    sensor=parts["sensor"], substeps=parts["substeps"])


@pytest.mark.parametrize("name, cls, duration", [
    ("panda-admittance-contact", Table, None), ("panda-sphere", ElasticSphere, None),
    ("panda-spiral-search", FrictionalContact, 0.4),  # sliding friction on a bump field, in contact throughout
])
def test_runs_that_skip_the_angles_equal_the_runs_that_compute_them(name, cls, duration, monkeypatch):
    scn = load_scenario(name) if duration is None else load_scenario(name).with_(duration=duration)
    skipped = run_scenario(scn).cases[0].result
    monkeypatch.setattr(cls, "reads_orientation", True)
    computed = run_scenario(scn).cases[0].result
    for a in ("q", "qd", "x", "xd", "wrench", "torque"):
        np.testing.assert_array_equal(getattr(skipped, a), getattr(computed, a), err_msg=a)
    assert skipped.signals.keys() == computed.signals.keys()
    for key, logged in skipped.signals.items():  # friction's normal force, stick/slip, ...
        np.testing.assert_array_equal(logged, computed.signals[key], err_msg=key)
