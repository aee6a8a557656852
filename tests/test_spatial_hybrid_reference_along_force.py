"""The 6-D hybrids on the desired frame ignore the pose reference's motion along S_f (issue 31's left-over defect).

The force rate (9.82) is the environment's: λ̇ = C⁻¹ S_fᵀ (the tip's twist relative to the fixed environment), not
C⁻¹ S_fᵀ (−x̃̇), which also holds the desired frame's own velocity; and the acceleration requested along S_f is the
force law's alone, without the reference's acceleration. References: closed forms (λ = λ_d at rest, (9.84)) and a
second run whose reference has no component along S_f (the docstrings: "the pose components along S_f are ignored").
"""

from __future__ import annotations

import numpy as np
import pytest

from forcecontrol.controllers.base import Reference
from forcecontrol.trajectories import LinearPath
from forcecontrol.trajectories.profiles import ReferenceSignal

pin = pytest.importorskip("pinocchio")

from forcecontrol.controllers.spatial_hybrid import SpatialHybridController, SpatialHybridRigidController  # noqa: E402
from forcecontrol.environments.spatial import Table  # noqa: E402
from forcecontrol.robots.pinocchio import PANDA_READY, panda  # noqa: E402
from forcecontrol.sim.simulation import simulate  # noqa: E402
from forcecontrol.spatial.closed_form import rotation_to_euler_xyz  # noqa: E402
from frame_helpers import ConstantFrame  # noqa: E402

K_TABLE = 1e4  # [N/m]
F_D = 20.0  # [N] pressed along the hand's z (the table's normal, into it)


class _ConstantVelocity(ReferenceSignal):
    """x_d(t) = x_0 + t v (6-D, constant twist, zero acceleration), with a constant force h_d."""

    def __init__(self, x0, v, force):
        self.x0, self.v, self.force = (np.asarray(a, dtype=np.float64) for a in (x0, v, force))
        self.dim = 6

    def sample(self, times):
        times = np.asarray(times, dtype=np.float64)
        out = np.zeros((len(times), 36))
        out[:, :6] = self.x0 + times[:, None] * self.v
        out[:, 6:12] = self.v
        out[:, 18:24] = self.force
        return out

    def at(self, t):
        z = np.zeros(6)
        return Reference(self.x0 + t * self.v, self.v.copy(), z, self.force, z, z)


@pytest.fixture(scope="module")
def franka():
    return panda()


@pytest.fixture(scope="module")
def start(franka):
    R, p = franka.frame_pose(PANDA_READY)
    return np.concatenate([p, rotation_to_euler_xyz(R)]), Table(p, [0, 0, 1], stiffness=K_TABLE)


def _hybrid(franka, frame=None):
    return SpatialHybridController(franka, [0, 0, 1, 0, 0, 0], 1 / K_TABLE, 400.0, 40.0, 400.0, 40.0, posture=PANDA_READY,
                                   frame=frame)


def _same_run(a, b, force_tol=1e-6, pos_tol=1e-9):
    """Two runs equal to the integrator's (and the rounding's) tolerance: contact force and tip path."""
    np.testing.assert_allclose(a.wrench[:, :3], b.wrench[:, :3], rtol=0, atol=force_tol)
    np.testing.assert_allclose(a.x[:, :3], b.x[:, :3], rtol=0, atol=pos_tol)


@pytest.mark.parametrize("orientation", ["euler", "rotvec"])
def test_rest_frame_terms_are_desired_frame_error_of_a_frame_at_rest(franka, orientation):
    """The S_f inputs (x̃̇, c of the desired frame at rest: −J_Ad q̇, −J̇_Ad q̇) equal desired_frame_error (9.33)-(9.34)
    with a reference at the same pose and zero twist and acceleration, to 1e-12, on random states and moving frames."""
    from forcecontrol.controllers.spatial import desired_frame_error
    from forcecontrol.controllers.spatial_hybrid import _at_rest

    rng = np.random.default_rng(3)
    z = np.zeros(6)
    for _ in range(20):
        q, qd = PANDA_READY + rng.normal(0, 0.2, 7), rng.normal(0, 0.5, 7)
        R_e, o_e, J, Jdq, *_ = franka.spatial_terms(q, qd)
        pose = np.concatenate([o_e + rng.normal(0, 0.02, 3), rng.normal(0, 0.5, 3)])
        moving = Reference(pose, rng.normal(0, 1, 6), rng.normal(0, 1, 6), z, z, z)
        err = desired_frame_error(R_e, o_e, J, Jdq, qd, moving, orientation)
        rest = desired_frame_error(R_e, o_e, J, Jdq, qd, Reference(pose, z, z, z, z, z), orientation)
        xd, c = _at_rest(err, Jdq, qd, orientation)
        np.testing.assert_allclose(xd, rest.xd, rtol=0, atol=1e-12)
        np.testing.assert_allclose(c, rest.c, rtol=0, atol=1e-12 * max(1.0, np.abs(rest.c).max()))


def test_reference_moving_along_the_force_direction_is_ignored(franka, start):
    """x_d sliding along x at 5 cm/s and along the table's normal at 2 cm/s: the same run as without the normal
    component (the pose along S_f is not servoed, λ̇ is the table's), and at rest λ = λ_d = 20 N ((9.84))."""
    x0, table = start
    force = [0, 0, -F_D, 0, 0, 0]
    along = _ConstantVelocity(x0, [0.05, 0, 0.02, 0, 0, 0], force)
    plain = _ConstantVelocity(x0, [0.05, 0, 0.0, 0, 0, 0], force)
    runs = [simulate(franka, table, _hybrid(franka), r, q0=PANDA_READY, duration=0.8, substeps=2) for r in (along, plain)]
    late = runs[0].t >= 0.6  # K_Pλ = 400, K_Dλ = 40: ω = 20 rad/s, e^(-12) · 13 of the step by then
    np.testing.assert_allclose(-runs[0].wrench[late, 2], F_D, atol=0.01 * F_D)
    _same_run(*runs)


def test_reference_accelerating_along_the_force_direction_is_ignored(franka, start):
    """A trapezoidal line whose path also goes 3 cm along the table's normal (accelerating, cruising, braking along
    S_f): the same run as the line without the normal component, for the compliant hybrid (9.77)-(9.84)."""
    x0, table = start
    force = [0, 0, -F_D, 0, 0, 0]
    along = LinearPath(x0, x0 + [0.04, 0.02, 0.03, 0, 0, 0], duration=0.4, start_time=0.2, force=force)
    plain = LinearPath(x0, x0 + [0.04, 0.02, 0.0, 0, 0, 0], duration=0.4, start_time=0.2, force=force)
    runs = [simulate(franka, table, _hybrid(franka), r, q0=PANDA_READY, duration=0.7, substeps=2) for r in (along, plain)]
    _same_run(*runs)


def test_rigid_hybrid_ignores_a_reference_accelerating_along_the_force_direction(franka, start):
    """The rigid hybrid (9.91)-(9.95) on a rigid table: a line that also goes 3 cm along the normal gives the run of
    the line without it (the environment holds the pose along S_f; the reference's acceleration is not asked of it)."""
    from forcecontrol.environments.rigid import PlaneConstraint, RigidEnvironment

    x0, _ = start
    table = RigidEnvironment(PlaneConstraint(np.concatenate([x0[:3], np.zeros(3)]), [0, 0, 1, 0, 0, 0]), unilateral=True)
    force = [0, 0, -F_D, 0, 0, 0]
    along = LinearPath(x0, x0 + [0.04, 0.02, 0.03, 0, 0, 0], duration=0.4, start_time=0.2, force=force)
    plain = LinearPath(x0, x0 + [0.04, 0.02, 0.0, 0, 0, 0], duration=0.4, start_time=0.2, force=force)

    def run(ref):
        c = SpatialHybridRigidController(franka, [0, 0, 1, 0, 0, 0], 400.0, 40.0, force_law="integral",
                                         force_integral_gain=50.0, posture=PANDA_READY)
        return simulate(franka, table, c, ref, q0=PANDA_READY, duration=0.7, substeps=2)

    _same_run(run(along), run(plain))


def test_frame_provider_reads_the_force_rate_on_the_updated_frame(franka, start):
    """With a frame provider (normal n̂ = the table's, first guess along the hand's x, replaced at the first sample),
    x_d moving along n̂ at 2 cm/s gives the run without that motion: λ̇ is formed on the frame of this sample."""
    x0, table = start
    n, t = np.array([0.0, 0.0, -1.0]), np.array([1.0, 0.0, 0.0])
    force = [F_D, 0, 0, 0, 0, 0]  # λ_d along n̂

    def run(v):
        c = SpatialHybridController(franka, [1, 0, 0, 0, 0, 0], 1 / K_TABLE, 400.0, 40.0, 400.0, 40.0,
                                    posture=PANDA_READY, frame=ConstantFrame(n, t))
        return simulate(franka, table, c, _ConstantVelocity(x0, v, force), q0=PANDA_READY, duration=0.8, substeps=2)

    runs = [run([0.05, 0, -0.02, 0, 0, 0]), run([0.05, 0, 0, 0, 0, 0])]
    late = runs[0].t >= 0.6
    np.testing.assert_allclose(-runs[0].wrench[late, 2], F_D, atol=0.01 * F_D)
    _same_run(*runs)


@pytest.mark.parametrize(("name", "radius", "rate"), [("panda-unknown-sphere", 0.2, 0.055 / 0.22),
                                                      ("panda-unknown-cylinder", 0.1, 0.06 / 0.12)])
def test_estimated_frame_force_error_is_the_surface_following_analysis(name, radius, rate):
    """6-D, normal estimated online: while tracing, the normal force's steady error is analysis.surface_following's
    (the curvature demand and the lag term k̂ K_Dλ v sin δ / K_Pλ of the tip's velocity along the lagging n̂, as for the
    planar hybrid) within 3 % of its bound: λ̇ is the tip's motion along n̂, not also the guessed path's velocity."""
    import forcecontrol as fc
    from forcecontrol.analysis.surface_following import surface_following_error

    r = fc.scenario(name).run().cases[0].result
    c = r.t > 1.2  # the speed ramp ends at 0.8 s; the force loop's transient (ω_f = 50 rad/s) is over
    v = rate * (radius - 10.0 / 1e4)  # the arc's angular rate on the tip's radius R - f_d/k
    pred = surface_following_error(10.0, v, radius, 1e4, 2500.0, 100.0, 0.05, sample_time=1e-3)
    fn = float(np.mean(r.signals["normal_force"][c]))
    assert fn == pytest.approx(pred.normal_force, abs=0.03 * pred.bound)
