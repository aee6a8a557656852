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
