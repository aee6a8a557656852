"""Curved elastic surfaces (issue 31, item 1): geometry vs finite differences and brute force, and the
equilibrium on a circle under impedance control vs its closed form on the chapter's arm."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import forcecontrol as fc
from forcecontrol.environments import ElasticCylinder, ElasticSphere, HeightField
from forcecontrol.errors import DimensionError, ParameterError

RNG = np.random.default_rng(31)


def _grid3():
    x = np.linspace(-0.2, 0.6, 33)
    y = np.linspace(-0.3, 0.5, 41)
    X, Y = np.meshgrid(x, y, indexing="ij")
    return 0.05 * np.sin(4 * X) * np.cos(3 * Y) + 0.02 * X, (-0.2, -0.3), (0.025, 0.02)


def _surfaces():
    H, origin, spacing = _grid3()
    xs = np.linspace(0.0, 2.0, 41)
    return [
        ElasticSphere([1.0, 0.35], 0.2, 1e4),
        ElasticSphere([0.4, -0.1, 0.3], 0.15, 1e4),
        ElasticCylinder([0.1, 0.2, -0.1], [1.0, -2.0, 0.5], 0.1, 1e4),
        HeightField(0.1 * np.sin(3 * xs) + 0.3, [0.0], 0.05, 1e4),
        HeightField(H, origin, spacing, 1e4),
    ]


def _near_points(s, count=12):
    """Points within 3 cm of the surface, on both sides."""
    out = []
    while len(out) < count:
        if isinstance(s, HeightField):
            u = RNG.uniform(0.3, 1.7, 1) if s.space == 2 else RNG.uniform([0.0, -0.1], [0.4, 0.3])
            base = np.append(u, s.height(u))
        elif isinstance(s, ElasticSphere):
            d = RNG.normal(size=s.space)
            base = s.center + s.radius * d / np.linalg.norm(d)
        else:
            d = RNG.normal(size=3)
            base = s.point + RNG.uniform(-0.3, 0.3) * s.axis + s.radius * (d - (d @ s.axis) * s.axis) / np.linalg.norm(
                d - (d @ s.axis) * s.axis)
        out.append(base + RNG.uniform(-0.03, 0.03, s.space))
    return out


@pytest.mark.parametrize("surface", _surfaces(), ids=lambda s: f"{type(s).__name__}-{s.space}d")
def test_normal_and_contact_point_match_finite_differences(surface):
    """The normal is the gradient of the signed distance (central differences) and p_c = p − φ ν lies on the surface."""
    h = 1e-6
    for p in _near_points(surface):
        phi, pc, nu = surface.geometry(p)
        grad = np.array([(surface.signed_distance(p + h * e) - surface.signed_distance(p - h * e)) / (2 * h)
                         for e in np.eye(surface.space)])
        np.testing.assert_allclose(nu, grad, atol=2e-6)
        np.testing.assert_allclose(pc, p - phi * grad, atol=1e-9)
        assert abs(surface.signed_distance(pc)) < 1e-10
        assert abs(np.linalg.norm(p - pc) - abs(phi)) < 1e-12


def test_height_field_distance_is_the_closest_point_by_brute_force():
    """The height field's |φ| equals the smallest distance to a dense sampling of the spline surface (1e-6 m),
    its sign is the side of the surface (below: negative)."""
    H, origin, spacing = _grid3()
    hf = HeightField(H, origin, spacing, 1e4)

    def nearest(p, u, v):
        U, V = np.meshgrid(u, v, indexing="ij")
        S = np.stack([U, V, hf._spline2.ev(U, V)], axis=-1)
        d = np.linalg.norm(S - p, axis=-1)
        i, j = np.unravel_index(np.argmin(d), d.shape)
        return d[i, j], u[i], v[j]

    for p in ([0.2, 0.1, 0.02], [0.1, 0.0, -0.04], [0.25, 0.2, 0.05]):
        p = np.array(p)
        phi = hf.signed_distance(p)
        _, u0, v0 = nearest(p, np.linspace(-0.05, 0.45, 401), np.linspace(-0.15, 0.35, 401))
        d, _, _ = nearest(p, np.linspace(u0 - 0.003, u0 + 0.003, 601), np.linspace(v0 - 0.003, v0 + 0.003, 601))
        assert -1e-12 <= d - abs(phi) < 1e-7  # the sampled minimum is never below the exact one
        assert math.copysign(1.0, phi) == math.copysign(1.0, p[2] - hf.height(p[:2]))


def test_height_field_from_csv_and_png(tmp_path):
    """A CSV table and a grey PNG give the same surface as the array (PNG within its 1/255 quantisation)."""
    from PIL import Image

    H, origin, spacing = _grid3()
    H = H - H.min()
    csv = tmp_path / "h.csv"
    np.savetxt(csv, H, delimiter=",")
    a = HeightField(H, origin, spacing, 1e4)
    b = HeightField.from_file(csv, origin, spacing, 1e4)
    p = np.array([0.2, 0.1, 0.1])
    assert b.signed_distance(p) == pytest.approx(a.signed_distance(p), abs=1e-12)
    png = tmp_path / "h.png"
    scale = float(H.max())
    Image.fromarray(np.round(H / scale * 255).astype(np.uint8)).save(png)
    c = HeightField.from_file(png, origin, spacing, 1e4, height_scale=scale)
    assert c.signed_distance(p) == pytest.approx(a.signed_distance(p), abs=scale / 255)
    bad = tmp_path / "h.txt"
    bad.write_text("1,2\nx,y\n")
    with pytest.raises(ParameterError, match="comma-separated numbers"):
        HeightField.from_file(bad, origin, spacing, 1e4)
    with pytest.raises(ParameterError, match="regular file"):
        HeightField.from_file(tmp_path, origin, spacing, 1e4)


def test_one_sided_and_pose_task():
    """No pull: out of contact or leaving fast the wrench is zero; a 3-D surface under a pose task adds zero moments."""
    s = ElasticSphere([0.0, 0.0, 0.0], 0.1, 1e4, damping=100.0, task_dim=6)
    inside = np.array([0.0, 0.0, 0.099, 0.1, 0.2, 0.3])
    np.testing.assert_allclose(s.wrench(inside, np.zeros(6)), [0, 0, -10.0, 0, 0, 0], atol=1e-9)
    assert not s.wrench(inside, np.array([0, 0, 1.0, 0, 0, 0])).any()  # k δ − c v_n < 0: no pull
    assert not s.wrench(np.array([0, 0, 0.11, 0, 0, 0]), np.zeros(6)).any()
    with pytest.raises(DimensionError, match="task_dim must be 2"):
        ElasticSphere([0.0, 0.0], 0.1, 1e4, task_dim=6)
    with pytest.raises(ParameterError, match="radius"):
        ElasticSphere([0.0, 0.0], -0.1, 1e4)
    with pytest.raises(ParameterError, match="at least 4 samples"):
        HeightField([0.0, 0.1, 0.2], [0.0], 0.1, 1e4)


ARM = fc.PlanarTwoLink()
CENTER = np.array([1.0, 0.35])
RADIUS, K_ENV = 0.2, 1e4


def _settle(stiffness, x_d):
    env = ElasticSphere(CENTER, RADIUS, K_ENV, damping=50.0)
    ctl = fc.ImpedanceController(ARM, 10.0, np.diag(2 * np.sqrt(10.0 * np.diag(stiffness))), stiffness)
    q0 = ARM.inverse_kinematics([1.0, 0.1])
    r = fc.simulate(ARM, env, ctl, fc.Setpoint(x_d), q0=q0, duration=4.0)
    return r.x[-1], r.wrench[-1]


def test_sphere_equilibrium_along_a_radius_matches_closed_form():
    """Impedance control, x_d inside the circle off the axes: the tip settles on the radius through x_d at
    ρ = (k_p r_d + k R)/(k_p + k), with force k (R − ρ) along −ν."""
    kp = 2500.0
    u = np.array([math.cos(math.radians(-60)), math.sin(math.radians(-60))])
    r_d = 0.1
    x, h = _settle(kp * np.eye(2), CENTER + r_d * u)
    rho = (kp * r_d + K_ENV * RADIUS) / (kp + K_ENV)
    np.testing.assert_allclose(x, CENTER + rho * u, atol=1e-6)
    np.testing.assert_allclose(h, -K_ENV * (RADIUS - rho) * u, rtol=1e-4)


def test_sphere_equilibrium_with_anisotropic_stiffness_matches_closed_form():
    """With K_P = diag(a, b) the tip settles off the radius through x_d: the angle φ solving
    t(φ)ᵀ K_P (x_d − c − ρ(φ) ν(φ)) = 0 with ρ(φ) from the radial balance (a scalar root), vs simulation."""
    a, b = 4000.0, 1000.0
    KP = np.diag([a, b])
    x_d = CENTER + 0.1 * np.array([math.cos(math.radians(-50)), math.sin(math.radians(-50))])

    def rho(phi):  # radial balance: ν K_P (x_d − c − ρ ν) = −k (R − ρ)
        nu = np.array([math.cos(phi), math.sin(phi)])
        return (nu @ KP @ (x_d - CENTER) + K_ENV * RADIUS) / (nu @ KP @ nu + K_ENV)

    def tangential(phi):
        nu = np.array([math.cos(phi), math.sin(phi)])
        t = np.array([-nu[1], nu[0]])
        return t @ KP @ (x_d - CENTER - rho(phi) * nu)

    phi = brentq(tangential, math.radians(-89), math.radians(-10))
    nu = np.array([math.cos(phi), math.sin(phi)])
    expected = CENTER + rho(phi) * nu
    assert abs(math.degrees(phi) + 50) > 5  # truly off the radius through x_d
    x, h = _settle(KP, x_d)
    np.testing.assert_allclose(x, expected, atol=1e-6)
    np.testing.assert_allclose(h, -K_ENV * (RADIUS - rho(phi)) * nu, rtol=1e-4)


def test_circle_runs_compiled_and_agrees_with_the_python_loop():
    """A 2-D sphere (circle) runs in the compiled loop (kind 3) and matches the Python reference loop to round-off."""
    env = ElasticSphere(CENTER, RADIUS, K_ENV, damping=50.0)
    q0 = ARM.inverse_kinematics([1.0, 0.1])
    ref = fc.Setpoint(CENTER + 0.1 * np.array([0.6, -0.8]))
    runs = [fc.simulate(ARM, env, fc.ImpedanceController(ARM, 10.0, 316.0, 2500.0), ref, q0=q0, duration=1.0, engine=e)
            for e in ("compiled", "python")]
    assert runs[0].metadata["engine"] == "compiled"
    assert np.abs(runs[0].wrench).max() > 100.0  # in contact
    np.testing.assert_allclose(runs[0].x, runs[1].x, atol=1e-10)
    np.testing.assert_allclose(runs[0].wrench, runs[1].wrench, atol=1e-6)


def test_mujoco_sphere_force_matches_the_builtin_engine():
    """The circle as MuJoCo's sphere geom (an independent contact model) under the same impedance controller:
    the contact force's mean and RMS within 5 % of the built-in engine's, and the same rest point (0.1 mm)."""
    pytest.importorskip("mujoco")
    from forcecontrol.engines.mujoco import MujocoPlant

    env = ElasticSphere(CENTER, RADIUS, K_ENV, damping=50.0)
    q0 = ARM.inverse_kinematics([1.0, 0.1])
    ref = fc.Setpoint(CENTER + 0.1 * np.array([math.cos(-1.0), math.sin(-1.0)]))

    def ctl():
        return fc.ImpedanceController(ARM, 10.0, 316.0, 2500.0)

    a = fc.simulate(ARM, env, ctl(), ref, q0=q0, duration=1.0)
    b = MujocoPlant(ARM, env).run(ctl(), ref, q0=q0, duration=1.0)
    fa, fb = np.linalg.norm(a.wrench, axis=1), np.linalg.norm(b.wrench, axis=1)
    assert fa.mean() > 150.0
    assert abs(fb.mean() - fa.mean()) <= 0.05 * fa.mean()
    assert abs(np.sqrt(np.mean(fb**2)) - np.sqrt(np.mean(fa**2))) <= 0.05 * np.sqrt(np.mean(fa**2))
    np.testing.assert_allclose(b.x[-1], a.x[-1], atol=1e-4)


def test_arm_circle_contour_scenario_traces_at_constant_normal_force():
    """The built-in 'arm-circle-contour': while tracing at 5 cm/s the normal force stays within ±1 N of the
    closed form k k_p (R − r_d)/(k_p + k) = 20 N, and with friction the friction force is μ_k f_n (1 %)."""
    run = fc.scenario("arm-circle-contour").run()
    expected = 1e4 * 2500.0 * (0.2 - 0.19) / (2500.0 + 1e4)
    for case in run.cases:
        r = case.result
        cruise = (r.t > 1.5) & (r.t < 9.0)
        np.testing.assert_allclose(r.signals["tangential_speed"][cruise], 0.05, rtol=0.01)
        assert np.max(np.abs(r.signals["normal_force"][cruise] - expected)) < 1.0
        mu_k = r.metadata["environment"]["kinetic"]
        np.testing.assert_allclose(r.signals["friction_force"][cruise], mu_k * r.signals["normal_force"][cruise],
                                   rtol=0.01, atol=1e-9)
    assert run.all_checks_pass and run.cases[0].checks  # the frictionless case settles at 20 N (its expected table)


@pytest.mark.parametrize("shape", ["sphere", "cylinder"])
def test_mujoco_panda_surface_contact_is_the_surface_spring_at_rest(shape):
    """Panda (pose task) pressing 5 mm into a sphere / a tilted cylinder: with torques balancing g and J_Pᵀ f of the
    built-in surface's force, MuJoCo's primitive geom (calibrated) senses the same force (1e-4) and the arm rests."""
    mujoco = pytest.importorskip("mujoco")
    pytest.importorskip("pinocchio")
    from forcecontrol.engines.mujoco import MujocoPlant
    from forcecontrol.robots.pinocchio import PANDA_READY, panda

    franka = panda()
    _, p = franka.frame_pose(PANDA_READY)
    n = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])  # the outward normal at the contact
    R, depth = 0.1, 0.005
    if shape == "sphere":
        env = ElasticSphere(p - (R - depth) * n, R, 1e4, task_dim=6)
    else:
        axis = np.cross(n, [1.0, 0.0, 0.0])
        env = ElasticCylinder(p - (R - depth) * n + 0.2 * axis, axis, R, 1e4, task_dim=6)
    x = np.concatenate([p, np.zeros(3)])
    f = env.wrench(x, np.zeros(6))[:3]
    np.testing.assert_allclose(f, -1e4 * depth * n, rtol=1e-12)  # the closed form
    plant = MujocoPlant(franka, env)
    m, d = plant.model, plant.data
    d.qpos[:], d.qvel[:] = PANDA_READY, 0.0
    mujoco.mj_forward(m, d)
    plant._reschedule()
    d.qfrc_applied[:] = np.asarray(franka.gravity(PANDA_READY)) + np.asarray(franka.jacobian(PANDA_READY))[:3].T @ f
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(plant.contact_wrench()[:3], f, rtol=1e-4, atol=1e-6)
    assert np.allclose(d.qacc, 0.0, atol=1e-4)


def test_compiled_dispatcher_circle_matches_the_class():
    """environment_wrench (the compiled dispatcher, kind 3) gives the ElasticSphere's 2-D wrench to round-off."""
    from forcecontrol.environments.elastic import environment_wrench

    env = ElasticSphere(CENTER, RADIUS, K_ENV, damping=50.0)
    for x, v in (([1.0, 0.16], [0.0, 0.1]), ([1.1, 0.2], [0.3, -0.2]), ([1.0, 0.1], [0.0, 0.0])):
        x, v = np.array(x), np.array(v)
        np.testing.assert_allclose(environment_wrench(3, env.packed(), x, v), env.wrench(x, v), atol=1e-9)


def test_mujoco_refuses_friction_and_height_fields_by_name():
    """MuJoCo models a FrictionalContact with its own friction, saying how it differs (tests/test_mujoco_surfaces_more.py:
    μ_k f_n while sliding); a height field is refused, naming what is not modelled."""
    pytest.importorskip("mujoco")
    from forcecontrol.engines.mujoco import MujocoPlant
    from forcecontrol.engines.mujoco_surfaces import MujocoFrictionNote
    from forcecontrol.environments import FrictionalContact

    circle = ElasticSphere(CENTER, RADIUS, K_ENV)
    with pytest.warns(MujocoFrictionNote, match="no static coefficient"):
        MujocoPlant(ARM, FrictionalContact(circle, 0.3, 0.2))
    with pytest.raises(ParameterError, match="models ElasticSphere and ElasticCylinder surfaces; got HeightField"):
        MujocoPlant(ARM, HeightField(np.linspace(0.0, 0.1, 8), [0.5], 0.1, 1e4))


def test_panda_sphere_scenario_traces_at_10_newtons():
    """The built-in 'panda-sphere' (6-D impedance, 3-D arc reference): while tracing, the normal force stays within
    ±1 N of the closed form k k_p (R − r_d)/(k_p + k) = 10 N and the tip slides at 5 cm/s (2 %)."""
    pytest.importorskip("pinocchio")
    run = fc.scenario("panda-sphere").run()
    r = run.cases[0].result
    cruise = (r.t > 0.8) & (r.t < 2.3)
    expected = 1e4 * 1000.0 * (0.2 - 0.189) / (1000.0 + 1e4)
    assert np.max(np.abs(r.signals["normal_force"][cruise] - expected)) < 1.0
    np.testing.assert_allclose(r.signals["tangential_speed"][cruise], 0.05, rtol=0.02)
    assert run.all_checks_pass and run.cases[0].checks


def _narrow_dip(width: float, stiffness: float = 1e4, damping: float = 0.0) -> HeightField:
    """A profile 0.3 m high with a Gaussian dip 2 cm deep at x = 1 m, sampled every mm: its radius of curvature at
    the bottom is w²/d (0.8 mm for w = 4 mm, 12.5 cm for w = 5 cm)."""
    xs = np.linspace(0.8, 1.2, 401)
    return HeightField(0.3 - 0.02 * np.exp(-(xs - 1.0) ** 2 / (2 * width**2)), [0.8], 0.001, stiffness, damping)


def test_a_contact_deeper_than_the_curvature_is_said_and_a_shallow_one_is_not():
    """Below the bottom of a dip by more than its radius of curvature (|φ| κ > 1) the closest point is not unique and
    Gauss–Newton does not settle: the surface says so (once, with the first point), for the spline and the formula
    field; within the curvature, or in free space, it says nothing."""
    from forcecontrol.environments.heightfield_extra import BumpField

    hf = _narrow_dip(0.004)
    hf.geometry(np.array([1.0015, 0.275]))  # 5 mm below the bottom, radius 0.8 mm
    hf.geometry(np.array([1.0025, 0.276]))
    note = hf.take_projection_note()
    assert note is not None and note.startswith("HeightField:") and "at 2 contact evaluation(s)" in note
    assert "p = [1.0015, 0.275] m" in note and "radius of curvature" in note
    assert hf.take_projection_note() is None  # taken: cleared
    hf.geometry(np.array([1.05, 0.299]))  # 1 mm into the flat part
    hf.geometry(np.array([1.0015, 0.29]))  # in free space above the dip
    assert hf.take_projection_note() is None
    bf = BumpField([0.0, -0.05], 0.005, [41, 21], 0.1, dips=[[0.06, 0.0, 0.02, 0.004]], stiffness=1e4)
    bf.geometry(np.array([0.0615, 0.0, 0.075]))
    note = bf.take_projection_note()
    assert note is not None and note.startswith("BumpField:") and "50 steps" in note
    from forcecontrol.environments.friction import FrictionalContact

    rubbed = FrictionalContact(bf, 0.5, 0.4)  # friction passes its surface's note on (what simulate asks it)
    bf.geometry(np.array([0.0615, 0.0, 0.075]))
    assert rubbed.take_projection_note().startswith("BumpField:") and bf.take_projection_note() is None
    bf.geometry(np.array([0.1, 0.02, 0.099]))
    assert bf.take_projection_note() is None


def test_a_run_pressed_deeper_than_the_curvature_warns_and_logs_the_event():
    """The arm pressed toward a point 8 cm below the bottom of a soft, narrow dip (radius of curvature 0.8 mm; the tip
    sinks centimetres in): the run warns (ContactModelWarning) and logs a ``contact-projection`` event, which
    ``run --json`` lists among the case's warnings; the same press into a wide dip (radius 12.5 cm) says nothing."""
    from types import SimpleNamespace

    from forcecontrol.errors import ContactModelWarning
    from forcecontrol.scenarios.summary import case_warnings

    kp = 2000.0

    def press(env):
        ctl = fc.ImpedanceController(ARM, 10.0, np.diag([2 * math.sqrt(10 * kp)] * 2), kp * np.eye(2))
        return fc.simulate(ARM, env, ctl, fc.Setpoint([1.002, 0.2]), q0=ARM.inverse_kinematics([1.002, 0.31]),
                           duration=0.3, label="press")

    with pytest.warns(ContactModelWarning, match=r"^press: HeightField: the closest surface point was not found"):
        narrow = press(_narrow_dip(0.004, stiffness=300.0, damping=20.0))
    events = [e for e in narrow.events if e["event"] == "contact-projection"]
    assert len(events) == 1 and "radius of curvature" in events[0]["detail"]
    case = SimpleNamespace(result=narrow, metrics={}, checks=[])
    # a 0.3 s press through a dip it cannot follow: its force still swings (6 to 27 N over the last 0.1 s), also said
    assert [w["kind"] for w in case_warnings(case)] == ["contact-projection", "not-settled"]
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", ContactModelWarning)
        wide = press(_narrow_dip(0.05, stiffness=300.0, damping=20.0))
    assert not [e for e in wide.events or () if e["event"] == "contact-projection"]
    assert wide.wrench[-1, 1] < -5.0  # in contact: the tip pushes the surface down (h_e = −f_n ν)


@pytest.mark.parametrize("which", range(5))
def test_a_nan_position_or_velocity_gives_a_nan_wrench_never_a_silent_zero(which):
    """A NaN in the position (anywhere) or in the velocity (while in contact, with damping) gives a NaN wrench, as the
    plane's does; before, the curved surfaces returned zero (NaN fails φ >= 0 and max(0.0, nan) is 0.0), a contact
    that silently vanished for a caller outside the simulator (which checks its state itself)."""
    s = _surfaces()[which]
    s.damping = 50.0
    inside = next(p for p in _near_points(s, 40) if s.signed_distance(p) < -1e-3)
    still = np.zeros(s.space)
    assert np.all(np.isfinite(s.wrench(inside, still))) and np.any(s.wrench(inside, still) != 0.0)
    for i in range(s.space):
        bad = inside.copy()
        bad[i] = np.nan
        assert np.all(np.isnan(s.wrench(bad, still)[: s.space])), (type(s).__name__, i)
        v = still.copy()
        v[i] = np.nan
        assert np.all(np.isnan(s.wrench(inside, v)[: s.space])), (type(s).__name__, "velocity", i)
    p, v = np.zeros(3), np.zeros(3)
    p[: s.space] = inside
    p[0] = np.nan
    assert math.isnan(s.normal_force_at(*p, *v)[0])


def test_a_contact_beyond_the_height_grid_is_said_once_per_run_and_a_contact_over_it_is_not():
    """The heights cover x in [0, 2] m: pressing on the surface at x = 1 says nothing; pressing at x = 2.3 (where the
    surface is the edge's spline extrapolated) is recorded and said by take_projection_note, once, naming the point and
    the grid's extent; out of contact beyond the grid nothing is said (before: the extrapolation was silent)."""
    xs = np.linspace(0.0, 2.0, 41)
    hf = HeightField(0.1 * np.sin(3 * xs) + 0.3, [0.0], 0.05, 1e4)
    assert hf.take_projection_note() is None
    over = np.array([1.0, hf.height([1.0]) - 0.002])
    assert np.any(hf.wrench(over, np.zeros(2)) != 0.0) and hf.take_projection_note() is None
    above_beyond = np.array([2.3, hf.height([2.3]) + 0.05])
    assert np.all(hf.wrench(above_beyond, np.zeros(2)) == 0.0) and hf.take_projection_note() is None
    beyond = np.array([2.3, hf.height([2.3]) - 0.002])
    for _ in range(3):
        assert np.any(hf.wrench(beyond, np.zeros(2)) != 0.0)
    note = hf.take_projection_note()
    assert note is not None and "in contact beyond the grid at 3 contact evaluation(s)" in note, note
    assert "first at p = [2.3," in note and "x in [0, 2] m" in note and "extrapolated" in note
    assert hf.take_projection_note() is None  # said once: the record is cleared
