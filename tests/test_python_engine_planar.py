"""The Python engine's planar fast paths (issue 33 item 4) against the general code they replace.

Each fast path (the arm's terms as scalars and the 2x2 solve, friction, the frame estimator and the
moving-frame hybrid on scalars, the layout's cached slices) is checked against a second
implementation: the robot's terms with ``np.linalg.solve``, the same model in 3-D (the estimator's
general NumPy code), the friction model written with NumPy vectors here, or the general matrix
products written out.
"""

from __future__ import annotations

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.controllers.base import Reference
from forcecontrol.controllers.hybrid import HybridCompliantController
from forcecontrol.environments import ElasticSphere
from forcecontrol.environments.friction import FrictionalContact
from forcecontrol.environments.spatial import Table
from forcecontrol.environments.surfaces import ElasticCylinder
from forcecontrol.errors import DimensionError, ParameterError
from forcecontrol.laws.layout import HYBRID_COMPLIANT
from forcecontrol.task.estimation import ConstraintFrameEstimator

ARM = fc.PlanarTwoLink()
RNG = np.random.default_rng(33)


def _states(n: int = 50) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    return [(RNG.uniform(-3, 3, 2), RNG.uniform(-2, 2, 2), RNG.uniform(-200, 200, 2)) for _ in range(n)]


def test_pose_twist_is_the_terms_x_and_xdot():
    """PlanarTwoLink.pose_twist gives exactly the x, ẋ of terms (same expressions, bit for bit)."""
    for q, qd, _ in _states():
        x, xd = ARM.pose_twist(q, qd)
        T = ARM.terms(q, qd)
        assert np.array_equal(x, T.x) and np.array_equal(xd, T.xd)


@pytest.mark.parametrize("env", [
    ElasticSphere([1.0, 0.35], 0.2, 1e4, 50.0),
    FrictionalContact(fc.ElasticPlane([0.0, 0.6], [0.0, 1.0], 1e4, 20.0), 0.5, 0.3, 2.0),
    fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 5000.0),
])
def test_elastic_acceleration_equals_the_linear_solve(env):
    """q̈ of PlanarTwoLink.elastic_acceleration equals np.linalg.solve(B, u − n − Jᵀ h) from terms to 1e-12."""
    hits = 0
    for q, qd, u in _states(200):
        a, h = ARM.elastic_acceleration(q, qd, u, env.wrench)
        T = ARM.terms(q, qd)
        h_ref = env.wrench(T.x, T.xd)
        want = np.linalg.solve(T.B, u - T.n - T.J.T @ h_ref)
        np.testing.assert_array_equal(h, h_ref)
        np.testing.assert_allclose(a, want, rtol=1e-12, atol=1e-12 * np.max(np.abs(want)))
        hits += bool(h.any())
    q = ARM.inverse_kinematics([1.0, 0.25] if isinstance(env, ElasticSphere) else [1.01, 0.59])
    a, h = ARM.elastic_acceleration(q, np.zeros(2), np.zeros(2), env.wrench)
    assert h.any() or hits  # the contact branch was exercised


def _twin3(env2: FrictionalContact) -> FrictionalContact:
    s = env2.surface
    if isinstance(s, ElasticSphere):
        s3 = ElasticSphere([*s.center, 0.0], s.radius, s.stiffness, s.damping)
    else:
        s3 = fc.ElasticPlane([*s.point, 0.0], [*s.normal, 0.0], s.stiffness, s.damping)
    return FrictionalContact(s3, env2.mu_s, env2.mu_k, env2.viscous, stick_stiffness=env2.sigma0,
                             stick_damping=env2.sigma1, stick_speed=env2.stick_speed)


@pytest.mark.parametrize("surface", [ElasticSphere([0.0, 0.0], 0.5, 1e4, 50.0),
                                     fc.ElasticPlane([0.0, 0.5], [0.0, 1.0], 1e4, 50.0)])
def test_planar_friction_equals_its_3d_twin(surface):
    """FrictionalContact on a planar surface gives the wrench, components and stick/slip transitions of the same
    surface in 3-D at z = 0 to 1e-12 (one scalar code, a planar point taken as (x, y, 0)), along a path
    that touches, sticks, breaks away, slides, reverses and leaves."""
    env2 = FrictionalContact(surface, 0.4, 0.3, 1.5, stick_stiffness=2e4, stick_damping=100.0, stick_speed=1e-3)
    env3 = _twin3(env2)
    t = np.linspace(0.0, 4.0, 4001)
    depth = 0.5 - 0.004 * np.sin(np.pi * t / 4.0) ** 2 - 0.0005  # in contact for most of the path
    ang = 0.05 * np.sin(2.0 * t) + 0.02 * np.sin(7.0 * t)
    modes = set()
    for k in range(t.shape[0]):
        if isinstance(surface, ElasticSphere):
            x = np.array([depth[k] * np.cos(ang[k]), depth[k] * np.sin(ang[k])])
        else:
            x = np.array([ang[k], depth[k]])
        v = RNG.normal(0.0, 0.05, 2) * (k % 3 != 0)  # some samples at rest (sticking)
        w2 = env2.wrench(x, v)
        w3 = env3.wrench(np.append(x, 0.0), np.append(v, 0.0))
        np.testing.assert_allclose(w2, w3[:2], rtol=1e-12, atol=1e-9)
        c2, c3 = env2.components(x, v), env3.components(np.append(x, 0.0), np.append(v, 0.0))
        np.testing.assert_allclose(c2[0], c3[0], rtol=1e-12, atol=1e-9)
        for a2, a3 in zip(c2[1:], c3[1:]):
            np.testing.assert_allclose(a2, a3[:2], rtol=1e-12, atol=1e-9)
        env2._update(x, v)
        env3._update(np.append(x, 0.0), np.append(v, 0.0))
        assert env2.mode == env3.mode
        np.testing.assert_allclose(env2.anchor, env3.anchor[:2], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(env2.direction, env3.direction[:2], rtol=1e-12, atol=1e-12)
        modes.add(env2.mode)
    assert modes == {0, 1, 2}  # free, stick and slip were all met


class _NumpyFriction:
    """The stick/slip friction model of environments.friction written again with NumPy arrays (a second
    implementation: the model's docstring, vector by vector), on the same surface object."""

    def __init__(self, env: FrictionalContact):
        self.env, self.space = env, env.space
        self.mode, self.anchor, self.direction = 0, np.zeros(self.space), np.zeros(self.space)

    def normal(self, p, v):
        s = self.env.surface
        if isinstance(s, (fc.ElasticPlane, Table)):
            delta = float(s.normal @ (s.point - p))
            return (0.0, s.normal) if delta <= 0.0 else (max(0.0, s.stiffness * delta - s.damping * float(s.normal @ v)),
                                                        s.normal)
        fn, nu, _ = s.normal_force(p, v)
        return fn, nu

    def components(self, x, xd):
        e, p, v = self.env, np.asarray(x, float)[: self.space], np.asarray(xd, float)[: self.space]
        fn, nu = self.normal(p, v)
        if fn <= 0.0:
            return 0.0, nu, np.zeros(self.space)
        vt = v - float(nu @ v) * nu
        if self.mode == 1:
            a = p - self.anchor
            ht = e.sigma0 * (a - float(nu @ a) * nu) + e.sigma1 * vt
        else:
            speed = float(np.linalg.norm(vt))
            s = vt / speed if speed > 1e-12 else self.direction - float(nu @ self.direction) * nu
            if speed <= 1e-12:
                s = s / np.linalg.norm(s) if np.linalg.norm(s) > 1e-12 else np.zeros(self.space)
            ht = e.mu_k * fn * s
        return fn, nu, ht + e.viscous * vt

    def update(self, x, xd):
        e, p, v = self.env, np.asarray(x, float)[: self.space], np.asarray(xd, float)[: self.space]
        fn, nu = self.normal(p, v)
        if fn <= 0.0:
            self.mode = 0
            return
        vt = v - float(nu @ v) * nu
        speed = float(np.linalg.norm(vt))
        if e.mu_s == 0.0:  # never stuck
            self.mode = 2
            self.direction = vt / speed if speed > 1e-12 else self.direction
        elif self.mode == 0:
            if speed > e.stick_speed:
                self.mode, self.direction = 2, vt / speed
            else:
                self.mode, self.anchor = 1, p.copy()
        elif self.mode == 1:
            a = p - self.anchor
            f = e.sigma0 * (a - float(nu @ a) * nu)  # the spring's load (breakaway ignores the damper's transient)
            if np.linalg.norm(f) > e.mu_s * fn:
                self.mode, self.direction = 2, vt / speed if speed > 1e-12 else f / np.linalg.norm(f)
        elif speed <= e.stick_speed or float(vt @ self.direction) <= 0.0:
            self.mode, self.anchor = 1, p.copy()  # stopped: the bristle starts unloaded at the tool
        else:
            self.direction = vt / speed


@pytest.mark.parametrize("surface", [
    ElasticSphere([0.0, 0.0], 0.5, 1e4, 50.0), fc.ElasticPlane([0.0, 0.5], [0.0, 1.0], 1e4, 50.0),
    ElasticSphere([0.0, 0.0, 0.0], 0.5, 1e4, 50.0), fc.ElasticPlane([0.0, 0.5, 0.0], [0.3, 1.0, 0.2], 1e4, 50.0),
    Table([0.0, 0.0, 0.5], [0.0, 0.2, 1.0], 1e4, 40.0), ElasticCylinder([0, 0, 0], [0.2, 0.1, 1.0], 0.5, 1e4, 150.0),
], ids=["circle", "line", "sphere", "plane-3d", "table", "cylinder"])
def test_friction_equals_a_numpy_implementation_of_the_model(surface):
    """FrictionalContact (scalar code, 2-D and 3-D) against the model written with NumPy vectors, along a path that
    touches, sticks, breaks away, slides, reverses and leaves: the same modes at every sample, the wrench, normal
    force, normal, tangential force, anchor and sliding direction to 1e-12 (round-off: NumPy's dot products may fuse
    their multiply-adds)."""
    env = FrictionalContact(surface, 0.4, 0.3, 1.5, stick_stiffness=2e4, stick_damping=100.0, stick_speed=1e-3)
    ref = _NumpyFriction(env)
    space, rng = env.space, np.random.default_rng(8)
    t = np.linspace(0.0, 4.0, 3001)
    depth = 0.5 - 0.004 * np.sin(np.pi * t / 4.0) ** 2 - 0.0005  # in contact for most of the path
    ang = 0.05 * np.sin(2.0 * t) + 0.02 * np.sin(7.0 * t)
    modes = []
    for k in range(t.shape[0]):
        if isinstance(surface, ElasticCylinder):  # at distance `depth` from the tilted axis, moving along it too
            u = surface.axis / np.linalg.norm(surface.axis)
            e1 = np.cross(u, [1.0, 0.0, 0.0])
            e1 /= np.linalg.norm(e1)
            x = depth[k] * (np.cos(ang[k]) * e1 + np.sin(ang[k]) * np.cross(u, e1)) + 0.1 * ang[k] * u
        elif isinstance(surface, ElasticSphere):
            x = np.array([depth[k] * np.cos(ang[k]), depth[k] * np.sin(ang[k]), 0.1 * ang[k]])[:space]
        elif isinstance(surface, Table):  # a pose: the position, then three angles the contact ignores
            x = np.array([ang[k], 0.3 * ang[k], 1.0 - depth[k], 0.1, 0.2, 0.3])
        else:
            x = np.array([ang[k], 0.0, 0.2 * ang[k]])[:space]
            x[1] = depth[k] - 0.3 * x[0] - (0.2 * x[2] if space == 3 else 0.0)
        v = rng.normal(0.0, 0.05, x.shape[0]) * (k % 3 != 0)  # some samples at rest (sticking)
        fn, nu, ht = ref.components(x, v)
        got = env.components(x, v)
        np.testing.assert_allclose(got[0], fn, rtol=1e-12, atol=1e-9)
        for a, b in zip(got[1:], (nu, -fn * nu, ht)):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(env.wrench(x, v)[:space], -fn * nu + ht, rtol=1e-12, atol=1e-9)
        env._update(x, v)
        ref.update(x, v)
        assert env.mode == ref.mode, k
        np.testing.assert_allclose(env.anchor, ref.anchor, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(env.direction, ref.direction, rtol=1e-12, atol=1e-12)
        modes.append(env.mode)
    assert set(modes) == {0, 1, 2}  # free, stick and slip were all met


def test_planar_estimator_equals_its_3d_twin():
    """ConstraintFrameEstimator in 2-D (scalar code) filters the normal as the 3-D one (NumPy code) does
    for the same force and velocity at z = 0, to 1e-12, and its tangent is the normal turned by +90°."""
    e2 = ConstraintFrameEstimator([0.3, 1.0], 0.05, 1e-3)
    e3 = ConstraintFrameEstimator([0.3, 1.0, 0.0], 0.05, 1e-3)
    for k in range(3000):
        ang = 0.001 * k
        f = np.array([10.0 * np.cos(ang), 10.0 * np.sin(ang)]) + RNG.normal(0.0, 0.5, 2)
        f = f * (k % 500 > 20)  # contact lost now and then: held estimate
        v = np.array([-np.sin(ang), np.cos(ang)]) * 0.05 * (k % 7 != 0) + RNG.normal(0.0, 1e-3, 2)
        n2 = e2.update(f, v)
        n3 = e3.update(np.append(f, 0.0), np.append(v, 0.0))
        np.testing.assert_allclose(n2, n3[:2], rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(e2.tangent, [-n2[1], n2[0]])
    S_f, S_v = e2.selection()
    assert S_f.shape == S_v.shape == (2, 1)


def test_planar_frame_blocks_equal_the_matrix_products():
    """The moving-frame hybrid's planar blocks (scalars) equal (I − S_v S_vᵀ) Ĉ S_f, (S_fᵀ Ĉ S_f)⁻¹ S_fᵀ and
    the mapped reference S_v ν_d, S_f λ_d computed with matrices, to 1e-12."""
    C = np.array([[1.2e-4, 0.3e-4], [0.3e-4, 0.8e-4]])
    ctl = HybridCompliantController(ARM, fc.SelectionMatrices([[0.0], [1.0]], [[1.0], [0.0]]), C, 50.0, 400.0,
                                    2500.0, 100.0, frame=ConstraintFrameEstimator([0.3, 1.0], 0.05, 1e-3))
    for _ in range(20):
        th = RNG.uniform(-np.pi, np.pi)
        S_f, S_v = np.array([[np.cos(th)], [np.sin(th)]]), np.array([[-np.sin(th)], [np.cos(th)]])
        r = Reference(*(RNG.normal(size=2) for _ in range(6)))
        values, base = ctl._planar_frame(S_f, S_v, r)
        want = np.concatenate([S_v.ravel(), S_v.T.ravel(), S_f.T.ravel(), ((np.eye(2) - S_v @ S_v.T) @ C @ S_f).ravel(),
                               np.linalg.solve(S_f.T @ C @ S_f, S_f.T).ravel()])
        np.testing.assert_allclose(values, want, rtol=1e-12, atol=1e-15)
        got_fields = (base.velocity, base.acceleration, base.force, base.force_rate, base.force_accel)
        for got, w in zip(got_fields, (S_v @ r.velocity[:1], S_v @ r.acceleration[:1], S_f @ r.force[:1],
                                     S_f @ r.force_rate[:1], S_f @ r.force_accel[:1])):
            np.testing.assert_allclose(got, w, rtol=1e-12, atol=1e-15)


def test_layout_slices_are_cached_and_still_checked():
    """Blocks.slice returns the declaration's slice from its cache, and still refuses a bad block or dimensions."""
    for block in HYBRID_COMPLIANT.blocks:
        first = HYBRID_COMPLIANT.slice(block, 2, 1, 1)
        o = HYBRID_COMPLIANT.offset(block, 2, 1, 1)
        assert first == slice(o, o + HYBRID_COMPLIANT._size(block, {"d": 2, "l": 1, "k": 1}))
        assert HYBRID_COMPLIANT.slice(block, 2, 1, 1) is first  # asked once
    with pytest.raises(ParameterError, match="no block"):
        HYBRID_COMPLIANT.slice("nope", 2, 1, 1)
    with pytest.raises(DimensionError):
        HYBRID_COMPLIANT.slice("S_v", 2, -1, 1)


def test_rigid_planar_inverse_is_the_inverse():
    """rigid._inverse2 gives B⁻¹ of the arm's inertia (B⁻¹ B = I to 1e-13) and None for a singular or NaN matrix."""
    from forcecontrol.environments.rigid import _inverse2

    for q, _, _ in _states(100):
        B = ARM.mass_matrix(q)
        np.testing.assert_allclose(_inverse2(B), np.linalg.inv(B), rtol=1e-13)
    assert _inverse2(np.array([[1.0, 1.0], [1.0, 1.0]])) is None
    assert _inverse2(np.array([[np.nan, 0.0], [0.0, 1.0]])) is None
