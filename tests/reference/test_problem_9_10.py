"""Problem 9.10: hybrid force/velocity control of the chapter's arm on the π/4 elastic plane, at Ts = 1 ms.

Set-up (../shared/reference/two-link-arm.md): plane at π/4 to x0 through (1, 0), stiffness
5·10³ N/m along y_c; desired contact force 50 N into the plane, λ_d = −50 N along y_c (y_c points
out of the environment); motion along x_c with the trapezoidal profile of Problem 9.3, t_f = 1 s
(t_c = t_f/5), both the printed path ([1, 0] → [1.2 + 0.1√2, 0.2], whose tangential component is
used) and the official reading ([1 + 0.1√2, 0] → [1.2 + 0.1√2, 0.2], parallel to the plane); 2.5 s.
The arm starts at rest with the tip on the undeformed plane at the foot of the path's start.

Gains (Example 9.4 closed loop ν̇ = α_ν, λ̈ = f_λ): double poles at −50 rad/s for both loops,
K_Pν = 100 s⁻¹, K_Iν = 2500 s⁻², K_Dλ = 100 s⁻¹, K_Pλ = 2500 s⁻²; references from outside the
code: the force equilibrium λ = λ_d, the penetration |λ_d|/k = 1 cm, the trapezoid's cruise speed.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from forcecontrol import CHAPTER_ARM, ElasticPlane, LinearPath, Setpoint, simulate
from forcecontrol.controllers.hybrid import HybridCompliantController
from forcecontrol.task import inclined_plane

SQ2 = math.sqrt(2.0)
K_ENV = 5e3
LAMBDA_D = -50.0
NORMAL = np.array([-1.0, 1.0]) / SQ2  # y_c
PATHS = {
    "official": (np.array([1.0 + 0.1 * SQ2, 0.0]), np.array([1.2 + 0.1 * SQ2, 0.2])),
    "printed": (np.array([1.0, 0.0]), np.array([1.2 + 0.1 * SQ2, 0.2])),
}


def _foot_on_surface(p: np.ndarray) -> np.ndarray:
    """The point of the undeformed plane nearest to p."""
    return p - float(NORMAL @ (p - np.array([1.0, 0.0]))) * NORMAL


def _run(reference, compliance=1.0 / K_ENV, start=None):
    task = inclined_plane()
    env = ElasticPlane.inclined(math.pi / 4, [1.0, 0.0], K_ENV)
    ctrl = HybridCompliantController(CHAPTER_ARM, task, compliance, 100.0, 2500.0, 2500.0, 100.0, sample_time=1e-3)
    p0 = _foot_on_surface(getattr(reference, "start", None) if start is None else start)
    res = simulate(CHAPTER_ARM, env, ctrl, reference, q0=CHAPTER_ARM.inverse_kinematics(p0), duration=2.5, engine="python")
    sel = task.selection("base")
    lam = (res.wrench @ sel.force_pinv.T).ravel()
    nu = (res.xd @ sel.velocity_pinv.T).ravel()
    nu_d = (res.reference_block("velocity") @ sel.velocity_pinv.T).ravel()
    return res, lam, nu, nu_d


def _path(name, duration=1.0):
    start, end = PATHS[name]
    f_d = LAMBDA_D * NORMAL  # h_d = S_f λ_d
    return LinearPath(start, end, duration, force=f_d)


@pytest.fixture(scope="module")
def runs():
    """The two readings of the path, a run without tangential motion and one twice as fast."""
    out = {name: _run(_path(name)) for name in PATHS}
    out["still"] = _run(Setpoint(PATHS["official"][0], force=LAMBDA_D * NORMAL), start=PATHS["official"][0])
    out["fast"] = _run(_path("official", duration=0.5))
    return out


@pytest.mark.parametrize("name", list(PATHS))
def test_force_settles_to_50_newton_into_plane(runs, name):
    """The normal contact force settles to 50 N into the plane (λ = −50 N) within 1 % from 0.2 s on, and ends within 1e-4."""
    res, lam, _, _ = runs[name]
    settled = res.t >= 0.2
    assert np.all(np.abs(lam[settled] - LAMBDA_D) < 0.01 * abs(LAMBDA_D))
    assert lam[-1] == pytest.approx(LAMBDA_D, rel=1e-4)
    # the force is along y_c only (frictionless plane) and pushes into it
    np.testing.assert_allclose(res.wrench[-1], LAMBDA_D * NORMAL, atol=1e-6)


@pytest.mark.parametrize("name", list(PATHS))
def test_penetration_is_force_over_stiffness(runs, name):
    """At the end the tip is |λ_d|/k = 1 cm below the undeformed surface (the elastic model (9.65))."""
    res, _, _, _ = runs[name]
    depth = -float(NORMAL @ (res.x[-1] - np.array([1.0, 0.0])))
    assert depth == pytest.approx(abs(LAMBDA_D) / K_ENV, rel=1e-6)


@pytest.mark.parametrize("name", list(PATHS))
def test_tangential_velocity_tracks_trapezoid(runs, name):
    """Along x_c the speed follows the trapezoid within 1 % of the cruise speed during the motion, and is 0 at the end."""
    res, _, nu, nu_d = runs[name]
    start, end = PATHS[name]
    length = float(np.array([1.0, 1.0]) / SQ2 @ (end - start))  # tangential length of the path
    cruise = length / 0.8  # t_f − t_c with t_c = t_f/5
    assert nu_d.max() == pytest.approx(cruise, rel=1e-12)
    during = res.t <= 1.0
    assert np.abs(nu - nu_d)[during].max() < 0.01 * cruise
    assert abs(nu[-1]) < 1e-6


def test_force_response_independent_of_tangential_motion(runs):
    """Decoupling (9.78)–(9.79): the force history is the same (within 0.01 N) with no, normal and fast tangential motion."""
    lam_ref = runs["still"][1]
    for name in ("official", "printed", "fast"):
        assert np.abs(runs[name][1] - lam_ref).max() < 0.01


@pytest.mark.parametrize("ratio", [0.5, 2.0])
def test_estimated_compliance_still_settles(ratio):
    """With Ĉ = ratio·C ≠ C (9.83)–(9.84) the force still settles within 1 % of 50 N and the tangential tracking is unchanged."""
    res, lam, nu, nu_d = _run(_path("official"), compliance=ratio / K_ENV)
    assert np.all(np.abs(lam[res.t >= 0.6] - LAMBDA_D) < 0.01 * abs(LAMBDA_D))
    assert lam[-1] == pytest.approx(LAMBDA_D, rel=1e-4)
    cruise = 0.2 * SQ2 / 0.8
    assert np.abs(nu - nu_d)[res.t <= 1.0].max() < 0.01 * cruise


@pytest.mark.parametrize("name", ["problem-9.10", "problem-9.3"])
def test_built_in_scenario_meets_its_expected_values(name):
    """The built-in scenarios (hybrid 9.10, impedance 9.3; both path readings) meet every closed-form expected value."""
    from forcecontrol.scenarios import run_scenario

    run = run_scenario(name)
    assert len(run.cases) == 2
    failed = [(c.label, ch["metric"], ch["value"]) for c in run.cases for ch in c.checks if not ch["ok"]]
    assert not failed


@pytest.mark.parametrize("name", list(PATHS))
def test_tangential_speed_error_is_at_the_sampling_level(runs, name):
    """With the trapezoid sampled right at its breakpoints (ZOH), the tangential speed error stays below 5e-5 m/s (was 1.8e-3)."""
    res, _, nu, nu_d = runs[name]
    assert np.abs(nu - nu_d).max() < 5e-5
