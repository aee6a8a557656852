"""Elastic plane and linear spring: the chapter's sign convention, one-sidedness, bad inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import forcecontrol as fc
from forcecontrol.errors import DimensionError, ParameterError


def test_plane_force_is_kx_times_penetration_and_positive_in_contact():
    """Example 9.2's plane: f_x = k_x (x_e − x_r) > 0 when the tip is beyond x_r = 1."""
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e3)
    np.testing.assert_allclose(env.wrench(np.array([1.05, 0.3]), np.zeros(2)), [50.0, 0.0])


def test_plane_never_pulls():
    """Outside the plane, and when damping would pull, the force is zero (unilateral contact)."""
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e3, damping=100.0)
    np.testing.assert_array_equal(env.wrench(np.array([0.99, 0.0]), np.zeros(2)), [0.0, 0.0])
    # barely inside but leaving fast: k δ − c ν·ẋ = 1 − 100·1 < 0 -> no force
    np.testing.assert_array_equal(env.wrench(np.array([1.001, 0.0]), np.array([-1.0, 0.0])), [0.0, 0.0])


@settings(max_examples=50, deadline=None)
@given(st.floats(-math.pi, math.pi), st.floats(0.0, 0.05), st.floats(-1.0, 1.0))
def test_inclined_plane_pushes_along_its_normal(angle, depth, slide):
    """For any plane angle the force is k δ along −ν (into the environment), whatever the sliding."""
    env = fc.ElasticPlane.inclined(angle, [1.0, 0.0], 5e3)
    tangent = np.array([math.cos(angle), math.sin(angle)])
    normal = np.array([-math.sin(angle), math.cos(angle)])
    x = np.array([1.0, 0.0]) + slide * tangent - depth * normal
    np.testing.assert_allclose(env.wrench(x, np.zeros(2)), 5e3 * depth * (-normal), atol=1e-9)


def test_example_9_4_plane_normal_is_y_c():
    """The π/4 plane's outward normal is y_c = R_c [0, 1] of (9.85)."""
    env = fc.ElasticPlane.inclined(math.pi / 4, [1.0, 0.0], 5e3)
    np.testing.assert_allclose(env.normal, [-1 / math.sqrt(2), 1 / math.sqrt(2)], atol=1e-15)


def test_linear_spring_is_k_times_displacement_plus_damping():
    """h_e = K (x − x_r) + D ẋ (9.38) with a full PSD K."""
    K = np.array([[2.0, 1.0], [1.0, 2.0]]) * 1e3
    env = fc.LinearSpring(K, [1.0, 0.5], damping=[10.0, 20.0])
    x, xd = np.array([1.1, 0.4]), np.array([0.5, -1.0])
    np.testing.assert_allclose(env.wrench(x, xd), K @ (x - [1.0, 0.5]) + np.diag([10.0, 20.0]) @ xd)


@pytest.mark.parametrize(
    "build, exc, match",
    [
        (lambda: fc.ElasticPlane([1.0, 0.0], [0.0, 0.0], 1e3), ParameterError, "normal must be a non-zero vector"),
        (lambda: fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], -1e3), ParameterError, "stiffness must be a non-negative"),
        (lambda: fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 0.0), ParameterError, "stiffness must be a positive number"),
        (lambda: fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0, 0.0], 1e3), DimensionError, r"normal must have shape \(2,\)"),
        (lambda: fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e3, damping=-1), ParameterError, "damping must be"),
        (lambda: fc.LinearSpring([[1.0, 2.0], [2.0, 1.0]], [0.0, 0.0]), ParameterError,
         r"stiffness must be a symmetric positive semi-definite \(2, 2\) matrix; got eigenvalues"),
        (lambda: fc.LinearSpring(-5.0, [0.0, 0.0]), ParameterError, "positive semi-definite"),
        (lambda: fc.LinearSpring(np.eye(3), [0.0, 0.0]), DimensionError, r"got shape \(3, 3\)"),
    ],
)
def test_bad_environments_raise_clear_errors(build, exc, match):
    """Negative stiffness, zero normal, wrong shapes and indefinite K are refused with clear messages."""
    with pytest.raises(exc, match=match):
        build()


def test_the_planes_wrench_equals_the_compiled_one_to_the_bit():
    """ElasticPlane.wrench (plain Python) equals plane_wrench, which the compiled loops run, bit for bit: random planes,
    2-D and 3-D, points in and out of contact, pushing and pulling speeds, and a non-finite point."""
    from forcecontrol.environments.elastic import plane_wrench

    rng = np.random.default_rng(12)
    for m in (2, 3):
        for _ in range(5_000):
            nu = rng.normal(size=m)
            env = fc.ElasticPlane(rng.normal(size=m), nu / np.linalg.norm(nu), float(rng.uniform(1.0, 1e5)),
                                  damping=float(rng.uniform(0.0, 300.0)))
            x, xd = rng.normal(size=m), rng.normal(scale=3.0, size=m)
            got, want = env.wrench(x, xd), plane_wrench(x, xd, env.normal, env.point, env.stiffness, env.damping)
            assert got.shape == want.shape and np.array_equal(got, want), (x, xd, got, want)
        x = np.full(m, np.nan)
        np.testing.assert_array_equal(env.wrench(x, xd), plane_wrench(x, xd, env.normal, env.point, env.stiffness,
                                                                         env.damping))
