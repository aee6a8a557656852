"""The 3-D view (forcecontrol.viz.view3d): a self-contained page, one frame per sampled time, the URDF's meshes
embedded, the robot drawn where Pinocchio (or the chapter's closed form) puts it, the force arrow, the CLI,
the Python method and the report. The page in a real browser: tests/test_view3d_browser.py."""

from __future__ import annotations

import json
import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import forcecontrol as fc

pytest.importorskip("meshcat")
pin = pytest.importorskip("pinocchio")

from forcecontrol.viz.animation import frame_indices  # noqa: E402
from forcecontrol.viz.view3d import write_view3d  # noqa: E402


def scene_of(path: Path) -> dict:
    """The scene JSON the page carries (parsed independently of the writer: the script element's text)."""
    text = path.read_text(encoding="utf-8")
    m = re.search(r'<script type="application/json" id="fc-scene">(.*?)</script>', text, re.S)
    assert m, "no scene element"
    return json.loads(m.group(1))


def track(scene: dict, path: str) -> dict[str, list]:
    anim = next(a for a in scene["animation"]["animations"] if a["path"] == path)
    return {t["name"]: t["keys"] for t in anim["clip"]["tracks"]}


def matrix(keys: dict[str, list], k: int) -> np.ndarray:
    """The 4x4 transform at key ``k`` (position and [x, y, z, w] quaternion, scale ignored)."""
    x, y, z, w = keys[".quaternion"][k]["value"]
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = keys[".position"][k]["value"]
    return T


@pytest.fixture(scope="module")
def panda_view(tmp_path_factory):
    from forcecontrol.scenarios import build_case

    run = fc.scenario("panda-admittance-contact").with_(duration=0.4).run()
    parts = build_case(run.scenario.cases[0])
    path = tmp_path_factory.mktemp("view3d") / "panda.html"
    written, notes = write_view3d(run.cases[0].result, parts["robot"], parts["environment"], path, title="panda")
    return run, parts, written, notes


@pytest.fixture(scope="module")
def planar_view(tmp_path_factory):
    run = fc.scenario("example-9.2").with_(duration=0.5).run()
    path = run.view3d(tmp_path_factory.mktemp("view3d") / "planar.html")
    return run, path


def test_page_is_self_contained(panda_view):
    """No script, stylesheet, image or fetch from the network: no element has a src/href attribute, and every
    http(s) URL in the page is an XML namespace name (the bundle's XHTML, the COLLADA meshes' schema: names,
    never loaded; tests/test_view3d_browser.py loads the page offline)."""
    text = panda_view[2].read_text(encoding="utf-8")
    assert not re.search(r"<(script|link|img|iframe)\b[^>]*\b(src|href)\s*=", text, re.I)
    urls = set(re.findall(r"https?://[^\s\"'<>)]+", text))
    assert {u.rstrip("\\") for u in urls} <= {"http://www.w3.org/1999/xhtml", "http://www.collada.org/2005/11/COLLADASchema"}
    assert "MeshCat.Viewer" in text and "fc-time" in text


def test_one_frame_per_sampled_time(panda_view):
    """The animation has one key per sampled time of frame_indices (30 frames per simulated second), on every
    animated path, at the sample's time from the start."""
    run, _, path, _ = panda_view
    t = run.cases[0].result.t
    expected = t[frame_indices(t, 30.0, 1.0, 400)] - t[0]
    scene = scene_of(path)
    assert np.allclose(scene["times"], expected, atol=1e-12)
    assert len(scene["times"]) == len(scene["force"]) > 10
    for anim in scene["animation"]["animations"]:
        for tr in anim["clip"]["tracks"]:
            assert [k["time"] for k in tr["keys"]] == pytest.approx(expected, abs=1e-12), (anim["path"], tr["name"])


def test_urdf_meshes_embedded(panda_view):
    """Every visual mesh file the Panda's URDF names is in the page, byte for byte (COLLADA text)."""
    _, parts, path, _ = panda_view
    robot = parts["robot"]
    from forcecontrol.robots.pinocchio import example_robot_data_dir

    root = ET.parse(robot.urdf_path).getroot()
    files = {m.get("filename") for link in root.findall("link") for v in link.findall("visual")
             for m in v.iter("mesh")}
    assert len(files) >= 9
    embedded = [c["object"]["object"].get("data") for c in scene_of(path)["commands"] if c["type"] == "set_object"]
    for f in sorted(files):
        rel = f.removeprefix("package://example-robot-data/")
        content = (example_robot_data_dir().parent / rel).read_text(encoding="utf-8")
        assert content in embedded, f


def _primitives(text: str) -> tuple[list[tuple[str, str]], list[int]]:
    """(material, index list) of every triangle set of a COLLADA text, sorted; the primitive count per geometry."""
    ns = {"c": "http://www.collada.org/2005/11/COLLADASchema"}
    root = ET.fromstring(text)
    prims, counts = [], []
    for g in root.findall("c:library_geometries/c:geometry", ns):
        mine = [e for e in g.find("c:mesh", ns) if e.tag.endswith(("}triangles", "}polylist"))]
        counts.append(len(mine))
        prims += [(e.get("material"), " ".join(e.find("c:p", ns).text.split())) for e in mine]
    return sorted(prims), counts


def test_ur5_multi_material_meshes_split():
    """The UR5's COLLADA meshes with two materials in one mesh (which meshcat's merge would lose) are embedded
    split, one material per geometry, with the same triangle sets; the Panda's single-material files unchanged."""
    from forcecontrol.robots.pinocchio import example_robot_data_dir, ur5
    from forcecontrol.viz.view3d_scene import urdf_visuals, visual_objects

    visuals = urdf_visuals(ur5().urdf_path, {"example-robot-data": example_robot_data_dir().parent})
    split = 0
    for v, cmd in zip(visuals, visual_objects(visuals, "/r")):
        original, embedded = v.mesh.read_text(encoding="utf-8"), cmd["object"]["object"]["data"]
        want, counts = _primitives(original)
        got, got_counts = _primitives(embedded)
        assert got == want, v.mesh.name
        if max(counts) > 1 and len(counts) > 1:
            split += 1
            assert set(got_counts) == {1} and len(got_counts) == sum(counts)
    assert split == 4  # shoulder, upperarm, wrist1, wrist2


def test_links_drawn_at_pinocchio_frame_placements(panda_view):
    """The transform sent for the hand link (the end-effector's body) and every other link equals Pinocchio's
    frame placement (a model built here from the URDF, forwardKinematics + updateFramePlacements) at q(t)."""
    run, parts, path, _ = panda_view
    scene = scene_of(path)
    model = pin.buildModelFromUrdf(str(parts["robot"].urdf_path))
    data = model.createData()
    res = run.cases[0].result
    idx = frame_indices(res.t, 30.0, 1.0, 400)
    for k in (0, len(idx) // 3, len(idx) - 1):
        q = np.concatenate([res.q[idx[k]], np.zeros(model.nq - res.q.shape[1])])  # fingers closed (the locked value)
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        for link in ("panda_hand", "panda_link4", "panda_link7"):
            want = data.oMf[model.getFrameId(link)].homogeneous
            got = matrix(track(scene, f"/forcecontrol/robot/{link}"), k)
            assert np.allclose(got, want, atol=1e-9), (link, k)
        tcp = data.oMf[model.getFrameId("panda_hand_tcp")].translation
        assert np.allclose(track(scene, "/forcecontrol/force")[".position"][k]["value"], tcp, atol=1e-9)


def test_force_arrow_follows_the_measured_force(panda_view):
    """The arrow points along the measured force at each frame and its shaft is proportional to |f| (one
    scale for the run); the read-out's |h_e| is the force's norm."""
    run, _, path, _ = panda_view
    scene = scene_of(path)
    res = run.cases[0].result
    idx = frame_indices(res.t, 30.0, 1.0, 400)
    f = np.asarray(res.wrench_measured)[idx, :3]
    norms = np.linalg.norm(f, axis=1)
    assert np.allclose(scene["force"], norms, rtol=1e-12, atol=1e-12)
    group, shaft = track(scene, "/forcecontrol/force"), track(scene, "/forcecontrol/force/shaft")
    ratios = []
    for k in np.flatnonzero(norms > 0.05 * norms.max()):
        y_axis = matrix(group, k)[:3, 1]
        assert np.allclose(y_axis, f[k] / norms[k], atol=1e-9)
        ratios.append(shaft[".scale"][k]["value"][1] / norms[k])
    assert len(ratios) > 3 and np.ptp(ratios) < 1e-9 * max(ratios)


def test_planar_arm_links_at_the_closed_form(planar_view):
    """The chapter's arm: link 2's frame is at the elbow (a1 cos q1, a1 sin q1) with x along q1 + q2, a1 = 1 m
    (the reference's data), at every frame; the arm's plane is stood upright (planar y along meshcat's z)."""
    run, path = planar_view
    scene = scene_of(path)
    res = run.cases[0].result
    idx = frame_indices(res.t, 30.0, 1.0, 400)
    keys = track(scene, "/forcecontrol/robot/link2")
    for k, i in enumerate(idx):
        q1, q2 = res.q[i]
        T = matrix(keys, k)
        assert np.allclose(T[:3, 3], [math.cos(q1), math.sin(q1), 0.0], atol=1e-9)
        assert np.allclose(T[:3, 0], [math.cos(q1 + q2), math.sin(q1 + q2), 0.0], atol=1e-9)
    root = next(c for c in scene["commands"] if c["type"] == "set_transform" and c["path"] == "/forcecontrol")
    R = np.array(root["matrix"]).reshape(4, 4).T[:3, :3]  # column-major
    assert np.allclose(R @ [0, 1, 0], [0, 0, 1])


def test_scenario_run_view3d_returns_the_path(planar_view):
    """ScenarioRun.view3d writes the page and returns its path outside a notebook; a wrong case is refused."""
    run, path = planar_view
    assert isinstance(path, Path) and path.is_file() and path.stat().st_size > 500_000
    with pytest.raises(fc.ParameterError, match="case must be an index in \\[0, 1\\]; got 5"):
        run.view3d(case=5)


def test_surfaces_drawn():
    """Sphere, cylinder, height field and plane give one surface object of the right kind and size, friction on a
    sphere draws the sphere; a spring has no surface and the note says so."""
    from forcecontrol.environments import ElasticPlane, LinearSpring
    from forcecontrol.environments.surfaces import ElasticCylinder, ElasticSphere, HeightField
    from forcecontrol.viz.view3d_scene import surface_objects

    c = np.array([0.5, 0.0, 0.3])
    (cmd,), note = surface_objects(ElasticSphere([0.5, 0.0, 0.1], 0.2, 1e4), c, 0.5, "/x")
    assert note is None and cmd["object"]["geometries"][0] == {**cmd["object"]["geometries"][0], "type": "SphereGeometry",
                                                               "radius": 0.2}
    (cmd,), _ = surface_objects(ElasticCylinder([0.5, 0.0, 0.1], [0, 1, 0], 0.1, 1e4), c, 0.5, "/x")
    assert cmd["object"]["geometries"][0]["type"] == "CylinderGeometry" and cmd["object"]["geometries"][0]["radiusTop"] == 0.1
    H = np.zeros((10, 12))
    (cmd,), _ = surface_objects(HeightField(H, [0.0, 0.0], 0.01, 1e4), c, 0.5, "/x")
    geo = cmd["object"]["geometries"][0]["data"]
    assert len(geo["attributes"]["position"]["array"]) == 3 * 120 and len(geo["index"]["array"]) == 3 * 2 * 9 * 11
    (cmd,), _ = surface_objects(ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4), np.array([1.0, 0.5, 0.0]), 0.5, "/x")
    T = np.array(cmd["object"]["object"]["matrix"]).reshape(4, 4).T
    thick = cmd["object"]["geometries"][0]["height"]
    assert np.allclose(T[:3, 3], [1.0 + 0.5 * thick, 0.5, 0.0])  # the wall's face on x = 1, the body on the +x side
    from forcecontrol.environments.friction import FrictionalContact

    (cmd,), note = surface_objects(FrictionalContact(ElasticSphere([0.5, 0.0, 0.1], 0.3, 1e4), 0.3, 0.2), c, 0.5, "/x")
    assert note is None and cmd["object"]["geometries"][0]["radius"] == 0.3  # friction on a sphere: the sphere
    cmds, note = surface_objects(LinearSpring(np.eye(2) * 1e3, [1.0, 0.0]), c, 0.5, "/x")
    assert cmds == [] and "LinearSpring has no surface" in note


def test_missing_extra_names_it(monkeypatch, tmp_path):
    """Without meshcat, the library and `run --view3d` say which extra installs it (before simulating)."""
    import importlib.util

    from typer.testing import CliRunner

    from forcecontrol.cli import app
    from forcecontrol.viz import view3d

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "meshcat" else real(name, *a))
    with pytest.raises(ImportError, match=re.escape("pip install 'forcecontrol[view3d]'")):
        view3d.meshcat_bundle()
    res = CliRunner().invoke(app, ["run", "example-9.2", "--view3d", "--no-figure", "--out", str(tmp_path)])
    assert res.exit_code == 2 and "forcecontrol[view3d]" in res.output
    assert not any(tmp_path.rglob("*.csv"))  # refused before the run wrote anything


def test_cli_writes_the_view_and_the_report_embeds_it(tmp_path):
    """`run --view3d` writes view3d.html in the run folder, lists it (files, --json), and `report` embeds it
    with a relative link."""
    from typer.testing import CliRunner

    from forcecontrol.cli import app

    res = CliRunner().invoke(app, ["run", "panda-admittance-contact", "--set", "duration=0.2", "--view3d", "--no-figure",
                                   "--json", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout[res.stdout.index("{"):])
    view = Path(doc["files"]["view3d:case 1"])
    assert view == tmp_path / "panda-admittance-contact" / "view3d.html" and view.is_file()
    pytest.importorskip("plotly")
    res = CliRunner().invoke(app, ["report", str(view.parent)])
    assert res.exit_code == 0, res.output
    report = (view.parent / "report.html").read_text(encoding="utf-8")
    assert '<iframe src="view3d.html"' in report and '<a href="view3d.html">' in report


def test_notebook_gets_the_view_in_an_iframe(tmp_path, monkeypatch):
    """In a Jupyter kernel (its shell class), the page is returned as an IPython HTML object holding the whole
    page in an iframe's srcdoc (escaped); elsewhere the path."""
    IPython = pytest.importorskip("IPython")
    from forcecontrol.viz.view3d import notebook_view

    page = tmp_path / "v.html"
    page.write_text('<p title="a&b">x</p>', encoding="utf-8")
    assert notebook_view(page) == page
    ZMQInteractiveShell = type("ZMQInteractiveShell", (), {})
    monkeypatch.setattr(IPython, "get_ipython", lambda: ZMQInteractiveShell())
    shown = notebook_view(page)
    assert type(shown).__name__ == "HTML" and 'srcdoc="&lt;p title=&quot;a&amp;b&quot;&gt;x&lt;/p&gt;"' in shown.data


def test_cli_several_cases_one_view_each(tmp_path):
    """Example 9.2's two cases give view3d-<case>.html each, listed under view3d:<case>."""
    from typer.testing import CliRunner

    from forcecontrol.cli import app

    res = CliRunner().invoke(app, ["run", "example-9.2", "--set", "duration=0.1", "--view3d", "--no-figure", "--json",
                                   "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    files = json.loads(res.stdout[res.stdout.index("{"):])["files"]
    views = {k: Path(v).name for k, v in files.items() if k.startswith("view3d:")}
    assert views == {"view3d:k_x = 1e4 N/m": "view3d-k_x-1e4-N-m.html", "view3d:k_x = 1e3 N/m": "view3d-k_x-1e3-N-m.html"}
    assert all((tmp_path / "example-9.2" / name).is_file() for name in views.values())


def test_urdf_robot_without_visuals_drawn_as_its_joints():
    """A URDF robot whose file has no <visual> (the chapter's arm through Pinocchio) is drawn as links between its
    joints, says so, and the arrow sits at the tip of the closed form (a1 = a2 = 1 m)."""
    from types import SimpleNamespace

    from forcecontrol.robots.pinocchio import chapter_arm
    from forcecontrol.viz.view3d import build_scene

    t = np.linspace(0.0, 1.0, 101)
    q = np.column_stack([0.3 + 0.5 * t, 1.2 - 0.4 * t])
    f = np.column_stack([10.0 * t, np.zeros_like(t)])
    scene = build_scene(SimpleNamespace(t=t, q=q, wrench=f, wrench_measured=f), chapter_arm(), None)
    assert any("has no visuals" in n for n in scene.notes)
    tips = scene.tracks["/forcecontrol/force"][:, :3, 3]
    qs = q[frame_indices(t, 30.0, 1.0, 400)]
    want = np.column_stack([np.cos(qs[:, 0]) + np.cos(qs.sum(1)), np.sin(qs[:, 0]) + np.sin(qs.sum(1)), 0 * qs[:, 0]])
    assert np.allclose(tips, want, atol=1e-9)
    assert "/forcecontrol/robot/link1" in scene.tracks
