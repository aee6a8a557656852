"""Meshes in the MuJoCo engine (issue 31, item 2): a closed convex ElasticMesh as MuJoCo's mesh geom, eroded by the
contact radius; the two engines agree on the force; what MuJoCo cannot hold (non-convex meshes, height fields) is
refused naming why."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh")
mujoco = pytest.importorskip("mujoco")

import forcecontrol as fc  # noqa: E402
from forcecontrol.environments import ElasticMesh, HeightField  # noqa: E402
from forcecontrol.errors import ParameterError  # noqa: E402

CENTER = np.array([0.306890586, 0.0, 0.286882205])  # panda-sphere's ball


def test_mujoco_mesh_contact_is_the_mesh_spring_at_rest():
    """Panda pressing 5 mm into an icosphere mesh along a slanted normal: with torques balancing g and J_Pᵀ f of the
    built-in mesh's force, MuJoCo's eroded mesh geom (calibrated) senses the same force (1e-4) and the arm rests."""
    pytest.importorskip("pinocchio")
    from forcecontrol.engines.mujoco import MujocoPlant
    from forcecontrol.robots.pinocchio import PANDA_READY, panda

    franka = panda()
    _, p = franka.frame_pose(PANDA_READY)
    n = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    R, depth = 0.1, 0.005
    ball = trimesh.creation.icosphere(subdivisions=4, radius=R)
    env = ElasticMesh(ball.vertices + p - (R - depth) * n, ball.faces, 1e4, task_dim=6)
    f = env.wrench(np.concatenate([p, np.zeros(3)]), np.zeros(6))[:3]
    assert 45.0 < np.linalg.norm(f) < 50.0 + 1e-9  # k δ with δ within the sag below 5 mm
    plant = MujocoPlant(franka, env)
    m, d = plant.model, plant.data
    d.qpos[:], d.qvel[:] = PANDA_READY, 0.0
    mujoco.mj_forward(m, d)
    plant._reschedule()
    d.qfrc_applied[:] = np.asarray(franka.gravity(PANDA_READY)) + np.asarray(franka.jacobian(PANDA_READY))[:3].T @ f
    mujoco.mj_forward(m, d)
    assert d.ncon == 1
    np.testing.assert_allclose(plant.contact_wrench()[:3], f, rtol=1e-4, atol=1e-6)
    assert np.allclose(d.qacc, 0.0, atol=1e-3)


def _mesh_scenario(tmp_path: Path) -> Path:
    """panda-sphere, frictionless, its ball an icosphere (20480 faces) in a file next to the scenario; 1 s."""
    mesh = trimesh.creation.icosphere(subdivisions=5, radius=0.2)
    mesh.apply_translation(CENTER)
    folder = tmp_path / "scn"
    folder.mkdir()
    mesh.export(folder / "ball.stl")
    text = (Path(fc.__file__).parent / "scenarios" / "panda-sphere.toml").read_text()
    head, rest = text.split("[environment]", 1)
    env_block, tail = rest.split("[controller]", 1)
    env_block = env_block.replace('type = "elastic-sphere"', 'type = "mesh"\nfile = "ball.stl"')
    env_block = "\n".join(line for line in env_block.splitlines() if not line.startswith(("center", "radius", "static")))
    tail = tail.replace('signals = ["normal_force", "tangential_speed"]', 'signals = ["fx", "fz"]')
    out = folder / "panda-mesh.toml"
    out.write_text(head.replace("duration = 3.5", "duration = 1.0") + "[environment]" + env_block + "\n[controller]" + tail)
    return out


def test_mesh_scenario_runs_on_both_engines_and_they_agree_on_the_force(tmp_path):
    """The same mesh scenario (the Panda tracing an icosphere at 5 cm/s, 10 N) on the built-in engine and on MuJoCo:
    the contact force's mean and RMS within 5 % (measured: 0.01 %), and every sample within 0.5 N."""
    pytest.importorskip("pinocchio")
    scn = fc.scenario(str(_mesh_scenario(tmp_path)))
    a = scn.run().cases[0].result
    b = scn.run(engine="mujoco").cases[0].result
    assert b.metadata["engine"] == "mujoco" and b.metadata["environment"]["type"] == "mesh"
    fa, fb = np.linalg.norm(a.wrench[:, :3], axis=1), np.linalg.norm(b.wrench[:, :3], axis=1)
    assert fa.mean() > 9.0
    assert abs(fb.mean() - fa.mean()) <= 0.05 * fa.mean()
    assert abs(np.sqrt(np.mean(fb**2)) - np.sqrt(np.mean(fa**2))) <= 0.05 * np.sqrt(np.mean(fa**2))
    assert np.abs(fa - fb).max() <= 0.5


def test_mujoco_refuses_a_non_convex_mesh_and_a_height_field_naming_why():
    """MuJoCo collides with a mesh's convex hull and sums one soft contact per height-field prism: a non-convex mesh, an
    open mesh and a height field are refused, each naming the reason and the built-in engine."""
    pytest.importorskip("pinocchio")
    from forcecontrol.engines.mujoco import MujocoPlant
    from forcecontrol.robots.pinocchio import panda

    franka = panda()
    dented = trimesh.creation.icosphere(subdivisions=2, radius=0.1)
    dented.vertices[0] *= 0.5  # one vertex pushed half-way to the centre: closed, not convex
    env = ElasticMesh(dented.vertices, dented.faces, 1e4, task_dim=6)
    assert env.closed
    with pytest.raises(ParameterError, match="convex hull: the mesh must be closed and convex; this one is not convex"):
        MujocoPlant(franka, env)
    square = ElasticMesh.from_file(Path(__file__).parent / "meshes" / "square.obj", 1e4, task_dim=6)
    with pytest.raises(ParameterError, match="this one is not closed; run the built-in engine"):
        MujocoPlant(franka, square)
    x = np.linspace(0.0, 0.3, 8)
    field = HeightField(0.01 * np.outer(np.sin(10 * x), np.cos(10 * x)), [0.2, -0.15], 0.04, 1e4, task_dim=6)
    with pytest.raises(ParameterError, match="got HeightField .*one soft contact per prism.*run the built-in engine"):
        MujocoPlant(franka, field)


def test_scenario_file_mesh_refused_in_mujoco_names_the_file(tmp_path):
    """A non-convex mesh scenario on engine='mujoco' is refused before anything runs (a library error, not a wrong run)."""
    pytest.importorskip("pinocchio")
    path = _mesh_scenario(tmp_path)
    shutil.copy(Path(__file__).parent / "meshes" / "square.obj", path.parent / "square.obj")
    path.write_text(path.read_text().replace('file = "ball.stl"', 'file = "square.obj"'))
    with pytest.raises(ParameterError, match="not closed"):
        fc.scenario(str(path)).run(engine="mujoco")


ARM = fc.PlanarTwoLink()
Q0 = ARM.inverse_kinematics([1.0, 0.6])  # the tip on the undeformed plane y = 0.6 (as in test_friction)
KP, KD, MD = 4000.0, 400.0, 10.0
F_N = 1e4 * KP * 0.01 / (KP + 1e4)  # pressed 1 cm below: K_P (0.01 − δ) = k δ


def _frictional_plane(mu_s=0.5, mu_k=0.3):
    from forcecontrol.environments.friction import FrictionalContact

    return FrictionalContact(fc.ElasticPlane([0.0, 0.6], [0.0, 1.0], 1e4), mu_s, mu_k, stick_stiffness=1e5,
                             stick_damping=200.0)


def test_mujoco_sliding_friction_is_kinetic_coefficient_times_normal_force():
    """MuJoCo's friction (μ = μ_k, elliptic cone) on a flat plane while sliding at 0.125 m/s: tangential/normal force
    = μ_k within 1e-9 (the cone's projection; built-in engine: 1 %), the normal force the closed-form spring balance
    within 0.5 % (MuJoCo's soft cone raises it: measured 0.06 %), K_P times the lag = μ_k f_n within 1 %; the note
    on stderr and in the metadata says what differs (no static coefficient)."""
    from forcecontrol.engines.mujoco import MujocoPlant
    from forcecontrol.engines.mujoco_surfaces import MujocoFrictionNote

    with pytest.warns(MujocoFrictionNote, match="no static coefficient \\(static = 0.5 not modelled"):
        plant = MujocoPlant(ARM, _frictional_plane())
    ref = fc.LinearPath([1.0, 0.59], [1.2, 0.59], duration=2.0, start_time=0.5)
    r = plant.run(fc.ImpedanceController(ARM, MD, KD, KP), ref, q0=Q0, duration=2.5)
    cruise = (r.t > 1.2) & (r.t < 2.0)
    fn = -r.wrench[cruise, 1]
    assert np.all(r.xd[cruise, 0] > 0.12)
    np.testing.assert_allclose(r.wrench[cruise, 0], 0.3 * fn, rtol=1e-9)
    np.testing.assert_allclose(fn, F_N, rtol=5e-3)
    lag = ref.sample(r.t[cruise])[:, 0] - r.x[cruise, 0]
    np.testing.assert_allclose(KP * lag, 0.3 * fn, rtol=0.01)
    assert r.metadata["environment"]["type"] == "frictional-contact"
    assert any("MuJoCo's friction is Coulomb with μ = kinetic = 0.3" in n for n in r.metadata["engine_notes"])


def test_mujoco_friction_note_is_in_the_json_warnings():
    """A scenario with friction on engine='mujoco' lists the friction note among the case's --json warnings."""
    scn = fc.scenario({
        "name": "mj-friction", "duration": 0.05, "sample_time": 0.001, "settle_window": 0.05,
        "robot": {"model": "chapter-arm", "q0": [float(q) for q in Q0]},
        "environment": {"type": "frictional-plane", "point": [0.0, 0.6], "normal": [0.0, 1.0], "stiffness": 1e4,
                        "static": 0.5, "kinetic": 0.3},
        "controller": {"type": "impedance", "inertia": MD, "damping": KD, "stiffness": KP},
        "reference": {"type": "setpoint", "position": [1.0, 0.59]},
    })
    with pytest.warns(UserWarning, match="MuJoCo's friction"):
        out = scn.run(engine="mujoco").to_json()
    notes = [w for w in out["cases"][0]["warnings"] if w["kind"] == "engine-note"]
    assert notes and "no static coefficient" in notes[0]["text"]


@pytest.mark.parametrize(("spacing", "least"), [(0.02, 2), (0.005, 10)])
def test_why_height_fields_are_refused_mujoco_hfield_gives_one_contact_per_prism(spacing, least):
    """The reason the MuJoCo engine refuses a HeightField, measured on MuJoCo itself: a 1 cm sphere 1 mm deep on a
    flat hfield gets several contacts (one per overlapped prism, some tilted through the prisms' walls), whose depths
    sum to more than the 1 mm a single surface spring would see."""
    spec = mujoco.MjSpec()
    n = int(round(0.2 / spacing)) + 1
    spec.add_hfield(name="hf", size=[0.1, 0.1, 1e-3, 0.05], nrow=n, ncol=n, userdata=[0.0] * (n * n))
    g = spec.worldbody.add_geom()
    g.type, g.hfieldname = mujoco.mjtGeom.mjGEOM_HFIELD, "hf"
    body = spec.worldbody.add_body(pos=[0.0123, 0.0071, 0.01 - 1e-3])
    body.add_freejoint()
    s = body.add_geom()
    s.type, s.size, s.mass, s.condim = mujoco.mjtGeom.mjGEOM_SPHERE, [0.01, 0, 0], 1.0, 1
    m = spec.compile()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    depths = [-float(d.contact[i].dist) for i in range(d.ncon)]
    assert d.ncon >= least
    assert max(depths) == pytest.approx(1e-3, abs=1e-9) and sum(depths) > 1.2e-3


def test_mujoco_zero_friction_is_the_frictionless_contact_without_a_note():
    """static = kinetic = 0 (a scenario that only wants the friction logs): MuJoCo builds the frictionless contact
    (condim 1), warns nothing, and its run equals the bare surface's run exactly."""
    import warnings

    from forcecontrol.engines.mujoco import MujocoPlant

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plant = MujocoPlant(ARM, _frictional_plane(0.0, 0.0))
    assert int(plant.model.geom("environment").condim[0]) == 1 and not getattr(plant, "notes", [])
    bare = MujocoPlant(ARM, fc.ElasticPlane([0.0, 0.6], [0.0, 1.0], 1e4))
    ref = fc.LinearPath([1.0, 0.59], [1.05, 0.59], duration=0.2, start_time=0.05)
    a, b = (p.run(fc.ImpedanceController(ARM, MD, KD, KP), ref, q0=Q0, duration=0.3) for p in (plant, bare))
    np.testing.assert_array_equal(a.wrench, b.wrench)
    assert a.metadata["engine_notes"] == []
