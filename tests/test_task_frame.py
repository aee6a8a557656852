"""Sect. 9.4 force control in a rotated task frame (issue 13 item 5).

Reference: the chapter's axis-aligned case (Example 9.3's inner velocity loop and PI inner position loop
on the plane x = 1, checked against the book elsewhere). The whole set-up turned by 30° about the base
(the tip at 30° on the unit circle, the plane through it facing the arm) is physically the same problem
(the arm's dynamics depend on q2 only): with C_F diagonal in a task frame along the plane's normal, the
normal-force transient must equal the aligned one; with C_F diagonal in the base frame it does not.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.analysis import force_loop_axes
from forcecontrol.environments import ElasticPlane
from forcecontrol.errors import ParameterError
from forcecontrol.task import planar_rotation

TIMES = (0.05, 0.2, 0.5, 1.0, 2.9)


def _run(scheme, tilt_deg, task_frame):
    arm = fc.PlanarTwoLink()
    a = math.radians(tilt_deg)
    tip = [math.cos(a), math.sin(a)]
    q0 = arm.inverse_kinematics(tip, elbow="up")
    env = ElasticPlane.inclined(a + math.pi / 2, tip, 1e4)  # through the tip, facing the arm
    n_in = -env.normal
    R = planar_rotation(math.atan2(n_in[1], n_in[0])) if task_frame else None
    if scheme == "inner-velocity":
        ctl = fc.InnerVelocityForceController(arm, 100.0, 500.0, 2500.0, [0.0024, 0.0], task_frame=R)
    else:
        ctl = fc.InnerPositionForceController(arm, 100.0, 500.0, 2500.0, [0.00064, 0.0], [0.0016, 0.0],
                                              integrator_start="hold", task_frame=R)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = fc.simulate(arm, env, ctl, fc.Setpoint(tip, 10.0 * n_in), q0=q0, duration=3.0)
    fn = res.wrench @ n_in
    return np.array([fn[np.searchsorted(res.t, t)] for t in TIMES]), res, ctl, env


@pytest.mark.parametrize("scheme", ["inner-velocity", "inner-position"])
def test_tilted_plane_in_its_task_frame_reproduces_the_axis_aligned_transient(scheme):
    aligned, *_ = _run(scheme, 0.0, False)
    rotated, res, _, env = _run(scheme, 30.0, True)
    np.testing.assert_allclose(rotated, aligned, rtol=1e-4, atol=1e-4)  # compiled (aligned) vs Python engine
    assert res.settled_values(0.1)["fx"] == pytest.approx(10.0 * math.cos(math.radians(30.0)), rel=5e-3)
    base_frame, *_ = _run(scheme, 30.0, False)
    assert np.max(np.abs(base_frame - aligned)) > 0.1 * 10.0  # C_F in the base frame: another loop


def test_the_per_axis_analysis_works_in_the_task_frame():
    _, _, ctl, env = _run("inner-velocity", 30.0, True)
    axes = force_loop_axes(ctl, env.stiffness_matrix())
    assert axes[0].environment_stiffness == pytest.approx(1e4)  # the normal, in the task frame
    assert axes[1].environment_stiffness == pytest.approx(0.0, abs=1e-9)
    _, _, base_ctl, _ = _run("inner-velocity", 30.0, False)
    with pytest.raises(ParameterError, match="environment_stiffness must be diagonal for a per-axis analysis in the base frame"):
        force_loop_axes(base_ctl, env.stiffness_matrix())


def test_task_frame_must_be_a_rotation_and_scenarios_take_an_angle(tmp_path):
    arm = fc.PlanarTwoLink()
    with pytest.raises(ParameterError, match=r"task_frame must be a rotation matrix \(2, 2\)"):
        fc.InnerVelocityForceController(arm, 100.0, 500.0, 2500.0, [0.0024, 0.0], task_frame=[[1.0, 0.0], [0.0, -1.0]])
    text = fc.scenario("example-9.3").raw
    import textwrap

    from forcecontrol.scenarios import load_scenario

    (tmp_path / "tilted.toml").write_text(textwrap.dedent("""
        name = "tilted-force"
        duration = 3.0
        [robot]
        start_position = [1.0, 0.0]
        [environment]
        type = "elastic-plane"
        point = [1.0, 0.0]
        normal = [-0.8660254037844387, -0.49999999999999994]
        stiffness = 10000.0
        [controller]
        type = "inner-velocity"
        inertia = 100.0
        damping = 500.0
        stiffness = 2500.0
        force_gain = [0.0024, 0.0]
        task_frame_angle = 30.0
        [reference]
        type = "setpoint"
        position = [1.0, 0.0]
        force = [8.660254037844387, 4.999999999999999]
    """))
    res = load_scenario(tmp_path / "tilted.toml").run().cases[0].result
    assert np.linalg.norm(res.settled("wrench")) == pytest.approx(10.0, rel=2e-3)
    assert text["controller"]["type"] == "inner-position"  # the built-in is untouched
