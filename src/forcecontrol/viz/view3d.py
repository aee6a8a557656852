"""A scrubbable 3-D view of a run in one self-contained HTML file (meshcat's three.js viewer, embedded).

What is drawn: the robot with its URDF's visual meshes (example-robot-data's Panda and UR arms, any
URDF robot; the meshes embedded in the file), or, for a robot without a URDF (the chapter's planar
arm), its links as boxes and its joints as cylinders; the environment's contact surface (plane,
sphere, cylinder, height field, triangle mesh, a rigid plane constraint); the measured contact
force ``h_e`` (the force the tool exerts **on** the environment, the chapter's sense) as an arrow at
the tool; the tool's path. One animation frame per sampled time (:func:`frame_indices`); a slider,
a play button and the time and force read-out under the view.

Why meshcat (MIT; its bundle embeds three.js, MIT, and dat.GUI, Apache-2.0): its viewer is one
JavaScript file that takes scene commands, so a page carrying the bundle, the commands and the
animation works from ``file://`` with no server and no network, and can be linked from ``forcecontrol
report``'s HTML. viser needs its Python server running while the page is open; rerun needs its own
viewer (native or a WebAssembly bundle fetched from a server). Only meshcat's JavaScript bundle is
used here (``meshcat/viewer/dist/main.min.js``): the commands are written as JSON by
:mod:`forcecontrol.viz.view3d_scene`, no ZeroMQ server is started.

Needs the optional extra ``view3d`` (``pip install 'forcecontrol[view3d]'``).
"""

from __future__ import annotations

import html
import importlib.util
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError
from .animation import frame_indices
from .view3d_scene import _homogeneous, arrow_objects, box, cylinder, set_object, set_transform, sphere, surface_objects

__all__ = ["Scene3D", "build_scene", "write_view3d", "meshcat_bundle", "quaternion_xyzw", "notebook_view", "view3d_name",
           "report_section", "with_views"]

ROOT = "/forcecontrol"
ROBOT = f"{ROOT}/robot"
FORCE = f"{ROOT}/force"


def meshcat_bundle() -> Path:
    """meshcat's viewer bundle (three.js and the viewer in one file).

    Raises:
        ImportError: meshcat is not installed (the ``view3d`` extra).
    """
    spec = importlib.util.find_spec("meshcat")
    if spec is None or not spec.submodule_search_locations:
        raise ImportError("the 3-D view needs meshcat: pip install 'forcecontrol[view3d]'")
    path = Path(next(iter(spec.submodule_search_locations))) / "viewer" / "dist" / "main.min.js"
    if not path.is_file():  # pragma: no cover - a broken installation
        raise ImportError(f"meshcat is installed but its viewer bundle {str(path)!r} is missing: "
                          "pip install --force-reinstall 'forcecontrol[view3d]'")
    return path


def quaternion_xyzw(R: np.ndarray) -> list[float]:
    """The unit quaternion of a rotation matrix, three.js' order ``[x, y, z, w]`` (w >= 0)."""
    R = np.asarray(R, dtype=float)
    tr = float(np.trace(R))
    if tr > 0.0:
        s = 2.0 * math.sqrt(tr + 1.0)
        q = [(R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s, 0.25 * s]
    else:
        i = int(np.argmax(np.diag(R)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * math.sqrt(max(1e-300, 1.0 + R[i, i] - R[j, j] - R[k, k]))
        q = [0.0, 0.0, 0.0, (R[k, j] - R[j, k]) / s]
        q[i] = 0.25 * s
        q[j] = (R[j, i] + R[i, j]) / s
        q[k] = (R[k, i] + R[i, k]) / s
    if q[3] < 0.0:
        q = [-v for v in q]
    n = math.sqrt(sum(v * v for v in q))
    return [v / n for v in q]


@dataclass
class Scene3D:
    """A 3-D view's content: the static objects, the animated transforms per path (one 4×4 per frame),
    the frame times (from 0) [s], the force norms [N] and the notes (what was not drawn, and why)."""

    commands: list[dict[str, Any]]
    tracks: dict[str, np.ndarray]
    times: np.ndarray
    force: np.ndarray
    camera: dict[str, list[float]]
    notes: list[str] = field(default_factory=list)
    title: str = ""

    def animation(self) -> dict[str, Any]:
        """meshcat's ``set_animation`` command: per path, position and quaternion keys (and the arrow's scale)."""
        anims = []
        for path, mats in self.tracks.items():
            pos = [{"time": float(t), "value": [float(v) for v in T[:3, 3]]} for t, T in zip(self.times, mats)]
            rot = [{"time": float(t), "value": quaternion_xyzw(T[:3, :3] / np.linalg.norm(T[:3, :3], axis=0))}
                   for t, T in zip(self.times, mats)]
            tracks = [{"name": ".position", "type": "vector3", "keys": pos},
                      {"name": ".quaternion", "type": "quaternion", "keys": rot}]
            scale = np.linalg.norm(mats[:, :3, :3], axis=1)  # column norms: the scale along each axis
            if not np.allclose(scale, 1.0):
                tracks.append({"name": ".scale", "type": "vector3",
                               "keys": [{"time": float(t), "value": [float(v) for v in s]} for t, s in zip(self.times, scale)]})
            anims.append({"path": path, "clip": {"fps": 1, "name": "default", "tracks": tracks}})
        return {"type": "set_animation", "animations": anims, "options": {"play": True, "repetitions": 1}}


def _pinocchio_links(robot: Any) -> list[str] | None:
    """The link names a URDF robot's model knows (BODY frames), or None for a robot without a URDF."""
    model = getattr(robot, "model", None)
    if getattr(robot, "urdf_path", None) is None or model is None or not hasattr(model, "frames"):
        return None
    return [f.name for f in model.frames if str(f.type).rsplit(".", 1)[-1] == "BODY"]


def _link_transforms(robot: Any, q: np.ndarray, links: list[str]) -> list[np.ndarray]:
    """Each link's placement in the base frame at ``q`` (the model's frame placements after its forward
    kinematics: ``robot.joint_positions`` updates every frame)."""
    robot.joint_positions(q)
    ids = {f.name: i for i, f in reversed(list(enumerate(robot.model.frames))) if str(f.type).rsplit(".", 1)[-1] == "BODY"}
    return [np.array(robot.data.oMf[ids[name]].homogeneous) for name in links]


def _stick_links(pts: np.ndarray) -> list[np.ndarray]:
    """Placements of the links of a robot known by its joint points only: origin at joint i, x along the link
    (planar: turned about z)."""
    out = []
    for a, b in zip(pts[:-1], pts[1:]):
        d = b - a
        L = float(np.linalg.norm(d))
        x = d / L if L > 1e-12 else np.array([1.0, 0.0, 0.0])
        if abs(x[2]) < 0.9:
            y = np.cross([0.0, 0.0, 1.0], x)
        else:
            y = np.cross(x, [1.0, 0.0, 0.0])
        y /= np.linalg.norm(y)
        out.append(_homogeneous(np.column_stack([x, y, np.cross(x, y)]), a))
    return out


def _lift3(p: np.ndarray) -> np.ndarray:
    p = np.asarray(p, dtype=float)
    return np.concatenate([p, np.zeros(p.shape[:-1] + (3 - p.shape[-1],))], axis=-1) if p.shape[-1] < 3 else p[..., :3]


def _force_frames(tips: np.ndarray, forces: np.ndarray, scale: float, radius: float) -> dict[str, np.ndarray]:
    """The arrow's animated transforms: the group at the tip, y turned to the force; the shaft scaled to the
    force's length; the cone at its end (a vanishing force: a vanishing arrow)."""
    group, shaft, head = [], [], []
    for p, f in zip(tips, forces):
        n = float(np.linalg.norm(f))
        L = n * scale
        y = f / n if n > 0 else np.array([0.0, 0.0, -1.0])
        x = np.cross(y, [0.0, 0.0, 1.0] if abs(y[2]) < 0.9 else [1.0, 0.0, 0.0])
        x /= np.linalg.norm(x)
        group.append(_homogeneous(np.column_stack([x, y, np.cross(x, y)]), p))
        tiny = 1e-6 if L < 1e-9 else 1.0
        shaft.append(_homogeneous(np.diag([tiny, max(L, 1e-9), tiny]), (0.0, 0.5 * L, 0.0)))
        head.append(_homogeneous(np.eye(3) * tiny, (0.0, L, 0.0)))
    return {FORCE: np.array(group), f"{FORCE}/shaft": np.array(shaft), f"{FORCE}/head": np.array(head)}


def build_scene(result: Any, robot: Any, environment: Any, *, fps: float = 30.0, max_frames: int = 400,
                title: str = "") -> Scene3D:
    """The 3-D view of one run: objects, one frame per sampled time (:func:`frame_indices`, ``fps`` frames per
    simulated second, at most ``max_frames``), the camera.

    Raises:
        ParameterError: a robot without ``joint_positions``; a URDF whose visuals cannot be read.
    """
    from .view3d_scene import urdf_visuals, visual_objects

    if not callable(getattr(robot, "joint_positions", None)):
        raise ParameterError(f"robot must have joint_positions(q) to be drawn; got {type(robot).__name__}")
    idx = frame_indices(result.t, fps, 1.0, max_frames)
    times = np.asarray(result.t, dtype=float)[idx] - float(result.t[0])
    qs = np.asarray(result.q, dtype=float)[idx]
    notes: list[str] = []
    pts = np.array([_lift3(robot.joint_positions(q)) for q in qs])  # (frames, joints + 2, 3)
    planar = np.asarray(robot.joint_positions(qs[0])).shape[-1] == 2
    reach = float(np.ptp(pts.reshape(-1, 3), axis=0).max()) or 1.0
    commands: list[dict[str, Any]] = []
    tracks: dict[str, np.ndarray] = {}
    links = _pinocchio_links(robot)
    if links is not None:
        from ..robots.pinocchio import example_robot_data_dir

        try:
            packages = {"example-robot-data": example_robot_data_dir().parent}
        except ImportError:
            packages = {}
        visuals = urdf_visuals(robot.urdf_path, packages)
        drawn = [v for v in visuals if v.link in links]
        if len(drawn) < len(visuals):
            notes.append(f"{len(visuals) - len(drawn)} visual(s) of links the robot's model does not have are not drawn")
        if not drawn:
            notes.append(f"the URDF {str(robot.urdf_path)!r} has no visuals: the robot is drawn as its joints")
        moved = sorted({v.link for v in drawn})
        commands += visual_objects(drawn, ROBOT)
        per_frame = [_link_transforms(robot, q, moved) for q in qs]
        for k, name in enumerate(moved):
            tracks[f"{ROBOT}/{name}"] = np.array([f[k] for f in per_frame])
        tool = np.array([np.asarray(robot.frame_pose(q)[1], dtype=float) for q in qs])
    if links is None or not tracks:
        w = 0.06 * reach
        segments = [i for i in range(pts.shape[1] - 1) if float(np.linalg.norm(pts[0, i + 1] - pts[0, i])) >= 1e-9]
        frames = [_stick_links(p) for p in pts]
        for j, i in enumerate(segments):  # link j + 1 between two joints that do not coincide
            L = float(np.linalg.norm(pts[0, i + 1] - pts[0, i]))
            grey = (0.25, 0.25, 0.28, 1.0) if j % 2 else (0.85, 0.45, 0.1, 1.0)
            body = box((L, w, w), grey, _homogeneous(np.eye(3), (0.5 * L, 0, 0)))
            commands.append(set_object(f"{ROBOT}/link{j + 1}/body", body))
            joint = cylinder(0.8 * w, 1.3 * w, (0.1, 0.1, 0.1, 1.0)) if planar else sphere(0.7 * w, (0.1, 0.1, 0.1, 1.0))
            commands.append(set_object(f"{ROBOT}/link{j + 1}/joint", joint))
            tracks[f"{ROBOT}/link{j + 1}"] = np.array([f[i] for f in frames])
        tool = pts[:, -1]
    wrench = np.asarray(getattr(result, "wrench_measured", result.wrench), dtype=float)
    if wrench.shape != np.asarray(result.wrench).shape or not np.all(np.isfinite(wrench[idx, : min(3, wrench.shape[1])])):
        wrench = np.asarray(result.wrench, dtype=float)
        notes.append("the sensor's reading has missing samples: the arrow shows the true contact force")
    forces = _lift3(np.nan_to_num(wrench[idx, : min(3, wrench.shape[1])]))
    norms = np.linalg.norm(forces, axis=1)
    fmax = float(norms.max()) if norms.size else 0.0
    scale = 0.3 * reach / fmax if fmax > 0 else 0.0  # the largest force: 0.3 of the arm's extent
    radius = 0.01 * reach
    commands += arrow_objects(FORCE, radius)
    tracks.update(_force_frames(tool, forces, scale, radius))
    centre = tool.mean(axis=0)
    surface, note = surface_objects(environment, centre, 0.35 * reach, ROOT)
    commands += surface
    if note:
        notes.append(note)
    if len(tool) > 1:  # the tool's path (a line through the sampled positions)
        commands.append(set_object(f"{ROOT}/path", _line(tool)))
    if planar:  # the arm's plane upright: planar y up (meshcat's z), looked at from the front
        commands.insert(0, set_transform(ROOT, np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])))
        look = np.array([centre[0], 0.0, centre[1]])
        eye = look + 1.3 * reach * np.array([0.1, -1.0, 0.15])
    else:
        look = 0.5 * (pts.reshape(-1, 3).min(axis=0) + pts.reshape(-1, 3).max(axis=0))
        eye = look + 1.5 * reach * np.array([1.0, -0.9, 0.55]) / np.linalg.norm([1.0, -0.9, 0.55])
    # meshcat's camera sits in a frame turned +90 deg about x (three.js y up): world (x, y, z) -> (x, z, -y)
    camera = {"position": [float(eye[0]), float(eye[2]), float(-eye[1])],
              "target": [float(look[0]), float(look[2]), float(-look[1])]}
    return Scene3D(commands, tracks, times, norms, camera, notes, title)


def _line(points: np.ndarray) -> dict[str, Any]:
    from .view3d_scene import _uid, column_major

    geom = {"uuid": _uid(), "type": "BufferGeometry", "data": {"attributes": {"position": {
        "itemSize": 3, "type": "Float32Array", "array": [round(float(v), 6) for v in np.asarray(points).reshape(-1)],
        "normalized": False}}}}
    mat = {"uuid": _uid(), "type": "LineBasicMaterial", "color": 0x0072B2, "linewidth": 2}
    return {"metadata": {"version": 4.5, "type": "Object"}, "geometries": [geom], "materials": [mat],
            "object": {"uuid": _uid(), "type": "Line", "geometry": geom["uuid"], "material": mat["uuid"],
                       "matrix": column_major(np.eye(4))}}


def _script_json(doc: Any) -> str:
    """JSON safe inside ``<script>``: no ``<`` (no ``</script>``, no ``<!--``), no line separators."""
    text = json.dumps(doc, separators=(",", ":"), allow_nan=False)
    return text.replace("<", "\\u003c").replace("\u2028", "\\u2028").replace("\u2029", "\\u2029")


def page(scene: Scene3D) -> str:
    """The HTML page: the viewer bundle, the scene as JSON, the controls."""
    bundle = meshcat_bundle().read_text(encoding="utf-8").replace("</script", "<\\/script")
    doc = {"commands": scene.commands, "animation": scene.animation(), "times": [float(t) for t in scene.times],
           "force": [float(f) for f in scene.force], "camera": scene.camera, "notes": scene.notes}
    title = html.escape(scene.title or "forcecontrol 3-D view")
    return _TEMPLATE.format(title=title, bundle=bundle, scene=_script_json(doc), script=_SCRIPT,
                            last=len(scene.times) - 1, notes=html.escape("; ".join(scene.notes)))


def write_view3d(result: Any, robot: Any, environment: Any, path: str | Path, *, title: str = "",
                 fps: float = 30.0, max_frames: int = 400) -> tuple[Path, list[str]]:
    """Write the 3-D view of one run to ``path`` (an ``.html`` file; folders created).

    Returns:
        (the file, the notes: what is not drawn and why).

    Raises:
        ImportError: meshcat is missing (the ``view3d`` extra).
        ParameterError: the path does not end in .html; see :func:`build_scene`.
    """
    path = Path(path)
    if path.suffix.lower() not in (".html", ".htm"):
        raise ParameterError(f"the 3-D view is an HTML file: path must end in .html; got {str(path)!r}")
    meshcat_bundle()  # the extra first: a clear error before any work
    scene = build_scene(result, robot, environment, fps=fps, max_frames=max_frames, title=title)
    text = page(scene)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path, scene.notes


def notebook_view(path: str | Path, height: int = 520) -> Any:
    """The page in a notebook cell (an ``IPython.display.HTML`` holding it in an iframe), or the path outside one."""
    try:
        from IPython import get_ipython  # type: ignore[import-not-found]
    except ImportError:
        return Path(path)
    shell = get_ipython()
    if shell is None or type(shell).__name__ != "ZMQInteractiveShell":
        return Path(path)
    from IPython.display import HTML  # type: ignore[import-not-found]

    doc = html.escape(Path(path).read_text(encoding="utf-8"), quote=True)
    return HTML(f'<div><iframe srcdoc="{doc}" style="width:100%;height:{int(height)}px;border:0"></iframe></div>')


_TEMPLATE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{title}</title>
<style>
body {{ margin: 0; font: 13px system-ui, sans-serif; }}
#meshcat-pane {{ width: 100vw; height: calc(100vh - 44px); overflow: hidden; position: relative; }}
#fc-controls {{ height: 44px; display: flex; align-items: center; gap: 10px; padding: 0 10px; background: #f4f4f4;
  border-top: 1px solid #ccc; box-sizing: border-box; }}
#fc-time {{ flex: 1; }}
#fc-readout {{ font-variant-numeric: tabular-nums; min-width: 16em; }}
#fc-title {{ position: absolute; left: 10px; top: 8px; background: rgba(255,255,255,.8); padding: 2px 6px; }}
</style>
</head>
<body>
<div id="meshcat-pane"><div id="fc-title">{title}<br><small>{notes}</small></div></div>
<div id="fc-controls">
<button id="fc-play" type="button" title="play / pause">&#9654;</button>
<input id="fc-time" type="range" min="0" max="{last}" step="1" value="0" aria-label="time">
<label>speed <select id="fc-speed"><option>0.1</option><option>0.25</option><option selected>1</option>
<option>2</option></select></label>
<span id="fc-readout"></span>
</div>
<script>
{bundle}
</script>
<script type="application/json" id="fc-scene">{scene}</script>
<script>
{script}
</script>
</body>
</html>
"""

_SCRIPT = r"""
(function () {
  const scene = JSON.parse(document.getElementById("fc-scene").textContent);
  function bytes(o) {  // {"__base64__": ...} -> Uint8Array (STL meshes)
    if (o && typeof o === "object") {
      if (typeof o.__base64__ === "string") {
        const s = atob(o.__base64__), a = new Uint8Array(s.length);
        for (let i = 0; i < s.length; i++) a[i] = s.charCodeAt(i);
        return a;
      }
      if (!Array.isArray(o)) for (const k in o) o[k] = bytes(o[k]);
    }
    return o;
  }
  const pane = document.getElementById("meshcat-pane");
  const viewer = new MeshCat.Viewer(pane);
  window.fcViewer = viewer;
  for (const cmd of scene.commands) viewer.handle_command(bytes(cmd));
  viewer.handle_command(scene.animation);
  viewer.animator.pause();
  const cam = scene.camera;
  viewer.camera.position.set(cam.position[0], cam.position[1], cam.position[2]);
  viewer.controls.target.set(cam.target[0], cam.target[1], cam.target[2]);
  viewer.controls.update();
  const slider = document.getElementById("fc-time"), readout = document.getElementById("fc-readout");
  const button = document.getElementById("fc-play"), speed = document.getElementById("fc-speed");
  const times = scene.times, last = times.length - 1;
  function show(i) {
    i = Math.max(0, Math.min(last, i));
    viewer.animator.seek(times[i]);
    viewer.animator.display_progress(times[i]);
    slider.value = i;
    readout.textContent = "t = " + times[i].toFixed(3) + " s   |h_e| = " + scene.force[i].toFixed(2) + " N";
    window.fcFrame = i;
  }
  let playing = false, t0 = 0, w0 = 0;
  function step(now) {
    if (!playing) return;
    const t = times[0] + (now - w0) / 1000 * parseFloat(speed.value) + t0;
    let i = slider.valueAsNumber;
    while (i < last && times[i + 1] <= t) i++;
    show(i);
    if (i >= last) { playing = false; button.innerHTML = "&#9654;"; return; }
    requestAnimationFrame(step);
  }
  button.addEventListener("click", function () {
    playing = !playing;
    button.innerHTML = playing ? "&#10074;&#10074;" : "&#9654;";
    if (playing) {
      if (slider.valueAsNumber >= last) show(0);
      t0 = times[slider.valueAsNumber] - times[0]; w0 = performance.now();
      requestAnimationFrame(step);
    }
  });
  slider.addEventListener("input", function () { playing = false; button.innerHTML = "&#9654;"; show(slider.valueAsNumber); });
  window.fcShow = show;
  show(0);
  window.fcReady = true;
})();
"""


def view3d_name(labels: list[str], i: int) -> str:
    """The file of case ``i``'s 3-D view in a run folder: ``view3d.html`` for a single case, else
    ``view3d-<case>.html`` (the case's label made a safe file name)."""
    from ..core.paths import safe_name

    return "view3d.html" if len(labels) == 1 else f"view3d-{safe_name(labels[i], f'case{i + 1}')}.html"


def report_section(folder: str | Path, report: str | Path) -> str:
    """HTML for ``forcecontrol report``: the run folder's 3-D views (``view3d*.html``) embedded (an iframe,
    linked by a path relative to the report), or "" when there are none."""
    import os

    folder, report = Path(folder), Path(report)
    views = sorted(folder.glob("view3d*.html"))
    parts = []
    for v in views:
        rel = Path(os.path.relpath(v.resolve(), report.resolve().parent)).as_posix()
        src = html.escape(rel, quote=True)
        parts.append(f'<h2>3-D view: <a href="{src}">{html.escape(v.name)}</a></h2>\n'
                     f'<iframe src="{src}" title="{html.escape(v.name)}" loading="lazy" '
                     'style="width:100%;height:560px;border:1px solid #ccc"></iframe>')
    return "\n".join(parts)


def with_views(page_html: str, folder: str | Path, report: str | Path) -> str:
    """``page_html`` (a report) with :func:`report_section` before its closing ``</body>``."""
    section = report_section(folder, report)
    head, sep, tail = page_html.rpartition("</body>")
    return f"{head}{section}\n{sep}{tail}" if section and sep else page_html
