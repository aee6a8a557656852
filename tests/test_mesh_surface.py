"""Triangle-mesh surfaces (issue 31, item 1): ElasticMesh vs the sphere within the mesh's chordal error, vs the
plane exactly, vs trimesh's closest points (a second implementation) and finite differences, its force across an
edge, and the scenario kind ``mesh`` (file relative to the scenario file)."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh")

import forcecontrol as fc  # noqa: E402
from forcecontrol.environments import ElasticMesh, ElasticPlane, ElasticSphere, FrictionalContact  # noqa: E402
from forcecontrol.errors import DimensionError, ParameterError  # noqa: E402

MESHES = Path(__file__).parent / "meshes"
RNG = np.random.default_rng(3131)


def _shell_points(center, radius, width, count):
    d = RNG.normal(size=(count, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    return np.asarray(center) + d * (radius + RNG.uniform(-width, width, count))[:, None]


def _sag_and_tilt(mesh, center, radius):
    """The icosphere's chordal error (R − the nearest face plane's distance to the centre) and the largest angle
    between a face's normal and the radius through one of its vertices: numpy on the mesh, not the code under test."""
    a, b, c = (mesh.vertices[mesh.faces[:, i]] - center for i in range(3))
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1)[:, None]
    sag = radius - float(np.min(np.einsum("ij,ij->i", n, a)))
    tilt = max(float(np.max(np.arccos(np.clip(np.einsum("ij,ij->i", n, v) / radius, -1, 1)))) for v in (a, b, c))
    return sag, tilt


def test_icosphere_mesh_gives_the_sphere_force_within_the_chordal_error():
    """A fine icosphere (20480 faces) pushes like ElasticSphere: φ within [φ_s, φ_s + sag], |h_mesh − h_sphere| <=
    k sag + (k δ + c|v|) 2 sin(tilt/2) + c|v| sin(tilt) (the facets' sag and tilt, closed form)."""
    R, k, c = 0.2, 1e4, 30.0
    center = np.array([0.3, -0.1, 0.25])
    mesh = trimesh.creation.icosphere(subdivisions=5, radius=R)
    env = ElasticMesh(mesh.vertices + center, mesh.faces, k, c)
    ball = ElasticSphere(center, R, k, c)
    sag, tilt = _sag_and_tilt(mesh, np.zeros(3), R)
    assert env.closed and 3e-5 < sag < 1e-4
    for p in _shell_points(center, R, 0.005, 400):
        v = RNG.normal(scale=0.05, size=3)
        phi_m, phi_s = env.signed_distance(p), ball.signed_distance(p)
        assert phi_s - 1e-12 <= phi_m <= phi_s + sag + 1e-12
        delta = max(-phi_s, 0.0)
        bound = k * sag + (k * delta + c * np.linalg.norm(v)) * 2 * math.sin(tilt / 2) + c * np.linalg.norm(v) * math.sin(tilt)
        assert np.linalg.norm(env.wrench(p, v) - ball.wrench(p, v)) <= bound + 1e-9
    # 1 cm deep the sag is small against δ: the force's magnitude within 1 %, its direction within the facets' tilt
    p = center + (R - 0.01) * np.array([0.48, 0.6, 0.64])
    fm, fs = env.wrench(p, np.zeros(3)), ball.wrench(p, np.zeros(3))
    np.testing.assert_allclose(np.linalg.norm(fm), np.linalg.norm(fs), rtol=0.01)
    assert math.acos(fm @ fs / np.linalg.norm(fm) / np.linalg.norm(fs)) <= tilt


def test_flat_two_triangle_mesh_equals_the_plane():
    """The two-triangle square (tests/meshes/square.obj) tilted and moved gives ElasticPlane's wrench over it (1e-9)."""
    base = ElasticMesh.from_file(MESHES / "square.obj", 1.0)
    assert base.faces.shape == (2, 3) and not base.closed
    axis = np.array([0.3, -0.4, 0.2])
    ang = np.linalg.norm(axis)
    K = np.cross(np.eye(3), axis / ang)
    Rm = np.eye(3) + math.sin(ang) * K + (1 - math.cos(ang)) * K @ K
    offset = np.array([0.4, 0.1, -0.2])
    env = ElasticMesh(base.vertices @ Rm.T + offset, base.faces, 5e3, 40.0)
    plane = ElasticPlane(Rm @ [0, 0, 0.05] + offset, Rm @ [0, 0, 1.0], 5e3, 40.0)
    for _ in range(200):
        local = np.array([*RNG.uniform(-0.19, 0.19, 2), 0.05 + RNG.uniform(-0.02, 0.02)])
        p, v = Rm @ local + offset, RNG.normal(scale=0.1, size=3)
        np.testing.assert_allclose(env.wrench(p, v), plane.wrench(p, v), atol=1e-9)
        np.testing.assert_allclose(env.signed_distance(p), local[2] - 0.05, atol=1e-12)


def test_closest_point_matches_trimesh_and_normal_is_the_distance_gradient():
    """On tests/meshes/icosphere2.stl (320 faces): p_c equals trimesh's brute-force closest point (1e-12), |φ| the
    distance, the sign the convex solid's containment (all face planes), and ν the central-difference gradient of φ (2e-6)."""
    env = ElasticMesh.from_file(MESHES / "icosphere2.stl", 1e4, offset=[0.1, 0.2, 0.3])
    mesh = trimesh.load(MESHES / "icosphere2.stl")
    mesh.apply_translation([0.1, 0.2, 0.3])
    tris = mesh.triangles
    pts = _shell_points([0.1, 0.2, 0.3], 0.1, 0.03, 60)
    n = mesh.face_normals
    inside = np.all(np.einsum("ij,kj->ki", n, pts) - np.einsum("ij,ij->i", n, tris[:, 0]) < 0, axis=1)  # convex
    h = 1e-7
    for p, ins in zip(pts, inside):
        phi, pc, nu = env.geometry(p)
        q, dist = trimesh.triangles.closest_point(tris, np.tile(p, (len(tris), 1))), None
        dist = np.linalg.norm(q - p, axis=1)
        assert abs(abs(phi) - dist.min()) < 1e-12
        np.testing.assert_allclose(pc, q[np.argmin(dist)], atol=1e-12)
        assert (phi < 0) == bool(ins)
        grad = np.array([(env.signed_distance(p + h * e) - env.signed_distance(p - h * e)) / (2 * h) for e in np.eye(3)])
        np.testing.assert_allclose(nu, grad, atol=2e-6)


def test_force_across_an_edge_steps_by_the_dihedral_inside_and_the_normal_is_continuous_outside():
    """A roof (two faces at ±β meeting at a ridge), crossed at a fixed height: below the ridge the force steps once, on
    the bisector, by exactly 2 k δ sin β (the faces' angle), and is k-Lipschitz elsewhere; above it (no force) ν turns
    continuously round the ridge (steps <= Δx/z)."""
    beta, k = math.radians(10.0), 1e4
    s = 0.1 * math.tan(beta)
    V = [[-0.1, -0.1, -s], [0.0, -0.1, 0.0], [0.0, 0.1, 0.0], [-0.1, 0.1, -s], [0.1, -0.1, -s], [0.1, 0.1, -s]]
    env = ElasticMesh(V, [[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]], k)
    xs = np.linspace(-0.02, 0.02, 4001)
    dx = xs[1] - xs[0]
    z = -0.002
    F = np.array([env.wrench(np.array([x, 0.0, z]), np.zeros(3)) for x in xs])
    steps = np.sort(np.linalg.norm(np.diff(F, axis=0), axis=1))
    delta = -z * math.cos(beta)  # on the bisector x = 0: the distance to either face
    assert abs(steps[-1] - 2 * k * delta * math.sin(beta)) <= 2 * k * dx
    assert steps[-2] <= k * dx * (1 + 1e-9)  # one step only
    z = 0.0015
    N = np.array([env.normal(np.array([x, 0.0, z])) for x in xs])
    assert np.linalg.norm(np.diff(N, axis=0), axis=1).max() <= dx / z * (1 + 1e-9)
    np.testing.assert_allclose(N[0], [-math.sin(beta), 0, math.cos(beta)], atol=1e-12)  # the faces' normals far out
    np.testing.assert_allclose(N[-1], [math.sin(beta), 0, math.cos(beta)], atol=1e-12)


def test_mesh_checks_its_input_and_file():
    """Bad vertex/face arrays and files are the library's errors naming the parameter, what was expected and given."""
    with pytest.raises(DimensionError, match="vertices must be an \\(n, 3\\) array"):
        ElasticMesh(np.zeros((4, 2)), [[0, 1, 2]], 1e4)
    with pytest.raises(ParameterError, match="faces must index the 3 vertices .* got indices 0..3"):
        ElasticMesh(np.eye(3), [[0, 1, 3]], 1e4)
    with pytest.raises(ParameterError, match="triangle 0 is degenerate"):
        ElasticMesh([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]], 1e4)
    with pytest.raises(ParameterError, match="mesh file must be .stl, .obj, .ply; got '.csv'"):
        ElasticMesh.from_file(MESHES / "nothing.csv", 1e4)
    with pytest.raises(DimensionError, match="task_dim must be 3 or 6"):
        ElasticMesh(np.eye(3), [[0, 1, 2]], 1e4, task_dim=2)
    assert ElasticMesh(np.eye(3), [[0, 1, 2]], 1e4).kind == 0  # 3-D: the Python loop (the compiled one is planar)


TETRA_V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
TETRA_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])  # counter-clockwise seen from outside


def test_consistently_wound_tetrahedron_gives_the_closed_form_distance():
    """The unit corner tetrahedron, wound outward: φ at (1,1,1) is its distance to the plane x + y + z = 1, +2/√3 (no
    force), at (0.2, 0.3, −0.5) +0.5 (below the face z = 0), at (0.1, 0.1, 0.1) −0.1 (the three faces through the origin)."""
    env = ElasticMesh(TETRA_V, TETRA_F, 1e4)
    assert env.closed
    phi, pc, nu = env.geometry(np.array([1.0, 1.0, 1.0]))
    assert phi == pytest.approx(2.0 / math.sqrt(3.0), abs=1e-12)
    np.testing.assert_allclose(pc, [1 / 3, 1 / 3, 1 / 3], atol=1e-12)
    np.testing.assert_allclose(nu, np.ones(3) / math.sqrt(3.0), atol=1e-12)
    assert not env.wrench(np.array([1.0, 1.0, 1.0]), np.zeros(3)).any()
    assert env.signed_distance(np.array([0.2, 0.3, -0.5])) == pytest.approx(0.5, abs=1e-12)
    assert env.signed_distance(np.array([0.1, 0.1, 0.1])) == pytest.approx(-0.1, abs=1e-12)


def test_mesh_refuses_a_closed_tetrahedron_with_one_face_reversed():
    """One face of the tetrahedron reversed (was: φ(1,1,1) = −1.155 m, a 11.5 kN push in free space): its three edges
    now run the same way as in their neighbours, refused naming the count and the fix."""
    F = TETRA_F.copy()
    F[3] = F[3, ::-1]
    with pytest.raises(ParameterError, match=r"faces must be wound consistently .* got 3 edge\(s\) traversed twice in the "
                                             r"same direction .*trimesh.repair.fix_normals"):
        ElasticMesh(TETRA_V, F, 1e4)


def test_mesh_refuses_an_inside_out_mesh_and_a_repeated_triangle():
    """All faces reversed (consistent, normals inward: all the space outside would be solid) is refused with its signed
    volume, −1/6 m³ for the unit tetrahedron; so is a triangle given twice (either vertex order) and, in an open patch,
    an edge two triangles traverse the same way."""
    with pytest.raises(ParameterError, match=r"faces must be wound with outward normals .* closed surface of 4 triangles "
                                             r".* signed volume -0.166667 m\^3 \(must be positive\)"):
        ElasticMesh(TETRA_V, TETRA_F[:, ::-1], 1e4)
    for twin in (TETRA_F[1], TETRA_F[1, ::-1]):
        with pytest.raises(ParameterError, match=r"faces must each be a distinct triangle; got 1 repeated \(triangles 1 and 4"):
            ElasticMesh(TETRA_V, np.vstack([TETRA_F, twin]), 1e4)
    square = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]
    assert not ElasticMesh(square, [[0, 2, 1], [0, 3, 2]], 1e4).closed  # open, one-sided: either side may be solid
    with pytest.raises(ParameterError, match=r"got 1 edge\(s\) traversed twice in the same direction \(e.g. vertices "
                                             r"\[0, 2\] by triangles 0 and 1\)"):
        ElasticMesh(square, [[0, 1, 2], [0, 3, 2]], 1e4)


def test_mesh_parts_inward_are_refused_unless_they_bound_a_cavity():
    """Two closed parts: an inward-wound ball inside an outward one is a cavity (accepted: φ > 0 at the centre, within the
    inner icosphere's sag of its radius, < 0 in the shell); the same ball beside it, not inside, is refused though the
    total signed volume is positive."""
    outer = trimesh.creation.icosphere(subdivisions=2, radius=0.1)
    inner = trimesh.creation.icosphere(subdivisions=2, radius=0.05)
    sag, _ = _sag_and_tilt(inner, np.zeros(3), 0.05)
    n = len(outer.vertices)
    faces = np.vstack([outer.faces, inner.faces[:, ::-1] + n])
    env = ElasticMesh(np.vstack([outer.vertices, inner.vertices]), faces, 1e4)
    assert env.closed
    assert 0.05 - sag - 1e-12 <= env.signed_distance(np.zeros(3)) <= 0.05 + 1e-12
    assert env.signed_distance(np.array([0.075, 0.0, 0.0])) < 0.0 < env.signed_distance(np.array([0.2, 0.0, 0.0]))
    with pytest.raises(ParameterError, match=r"closed surface of 320 triangles \(triangle 320 among them\) wound inward"):
        ElasticMesh(np.vstack([outer.vertices, inner.vertices + [1.0, 0.0, 0.0]]), faces, 1e4)


def test_mesh_file_wound_inconsistently_is_refused_naming_the_file(tmp_path):
    """trimesh reads the faces as written (process=True merges vertices, does not fix winding): the refusal names the file."""
    F = TETRA_F.copy()
    F[3] = F[3, ::-1]
    for faces, name, match in ((F, "flipped.stl", "must be wound consistently"),
                               (TETRA_F[:, ::-1], "inside_out.obj", "must be wound with outward normals")):
        path = tmp_path / name
        trimesh.Trimesh(TETRA_V, faces, process=False).export(path)
        with pytest.raises(ParameterError, match=f"faces of mesh '{path}' {match}"):
            ElasticMesh.from_file(path, 1e4)
    good = tmp_path / "good.ply"
    trimesh.Trimesh(TETRA_V, TETRA_F, process=False).export(good)
    assert ElasticMesh.from_file(good, 1e4).signed_distance(np.ones(3)) == pytest.approx(2.0 / math.sqrt(3.0), abs=1e-12)


def _mesh_scenario(tmp_path: Path, stl: Path) -> Path:
    """panda-sphere with its ball replaced by a mesh file next to the scenario (a relative path), 1 s."""
    text = (Path(fc.__file__).parent / "scenarios" / "panda-sphere.toml").read_text()
    head, rest = text.split("[environment]", 1)
    env_block, tail = rest.split("[controller]", 1)
    env_block = env_block.replace('type = "elastic-sphere"', f'type = "mesh"\nfile = "{stl.name}"')
    env_block = "\n".join(line for line in env_block.splitlines() if not line.startswith(("center", "radius")))
    folder = tmp_path / "scn"
    folder.mkdir()
    shutil.copy(stl, folder / stl.name)
    out = folder / "panda-mesh.toml"
    out.write_text(head.replace("duration = 3.5", "duration = 1.0") + "[environment]" + env_block + "\n[controller]" + tail)
    return out


def test_scenario_kind_mesh_relative_to_the_scenario_file_matches_the_sphere(tmp_path, monkeypatch):
    """[environment] type = "mesh", file relative to the scenario's folder (run from elsewhere): the Panda presses an
    icosphere of the panda-sphere's ball with the sphere's normal force to within the closed-form shift
    k k_p/(k + k_p) · sag on the mean (0.01 N for the transient) and within 0.25 N at every sample (the facets' ripple),
    and the mesh is in the run's metadata."""
    pytest.importorskip("pinocchio")
    center = np.array([0.306890586, 0.0, 0.286882205])
    mesh = trimesh.creation.icosphere(subdivisions=5, radius=0.2)
    sag, _ = _sag_and_tilt(mesh, np.zeros(3), 0.2)
    mesh.apply_translation(center)
    stl = tmp_path / "ball.stl"
    mesh.export(stl)
    path = _mesh_scenario(tmp_path, stl)
    monkeypatch.chdir(tmp_path.parent)
    run = fc.scenario(str(path)).run()
    r = run.cases[0].result
    env = r.metadata["environment"]
    assert env["type"] == "frictional-contact" and env["surface"]["type"] == "mesh" and env["surface"]["faces"] == 20480
    assert env["surface"]["source"] == str(path.parent / "ball.stl")
    ref = fc.scenario("panda-sphere").with_(duration=1.0).run().cases[0].result
    cruise = r.t > 0.5
    shift = 1e4 * 1000.0 / (1e4 + 1000.0) * sag
    diff = r.signals["normal_force"][cruise] - ref.signals["normal_force"][cruise]
    assert abs(diff.mean()) <= shift + 0.01  # measured 0.026 N (shift 0.052 N)
    assert np.abs(diff).max() <= 0.25  # the facets' ripple while sliding over them (measured 0.18 N, 1.8 % of 10 N)
    assert abs(r.signals["normal_force"][cruise].mean() - 10.0) < 0.5


def test_scenario_mesh_keys_are_checked(tmp_path):
    """A missing mesh file and a friction-wrapped mesh: the scenario names the file; static/kinetic wrap it."""
    from types import SimpleNamespace

    from forcecontrol.scenarios import ENVIRONMENTS

    spec = ENVIRONMENTS["mesh"]
    assert {"file", "scale", "offset", "stiffness", "damping", "static", "kinetic"} <= set(spec.fields)
    ctx = {"robot": SimpleNamespace(task_dim=6)}
    p = {k: f.default for k, f in spec.fields.items()}
    p.update(file=str(MESHES / "square.obj"), stiffness=1e4, static=0.4, kinetic=0.3)
    env = spec.build(p, ctx)
    assert isinstance(env, FrictionalContact) and isinstance(env.surface, ElasticMesh) and env.dim == 6
    p["file"] = str(tmp_path / "missing.stl")
    with pytest.raises(ParameterError, match="missing.stl"):
        spec.build(p, ctx)
