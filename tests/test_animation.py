"""Animations of runs (issue 16 part 5): the file is written, has several frames, and the frames differ."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image, ImageChops
from typer.testing import CliRunner

import forcecontrol as fc
from forcecontrol.cli import app
from forcecontrol.errors import ParameterError
from forcecontrol.viz.animation import animate_run, frame_indices


def _frames(path) -> list[Image.Image]:
    """Every frame of a GIF, read back with Pillow, as RGB images."""
    im = Image.open(path)
    out = []
    for k in range(im.n_frames):
        im.seek(k)
        out.append(im.convert("RGB").copy())
    return out


@pytest.fixture(scope="module")
def approach():
    """Example 9.2's arm pushing on the stiff plane for 0.6 s."""
    arm = fc.PlanarTwoLink()
    plane = fc.ElasticPlane(point=[1.0, 0.0], normal=[-1.0, 0.0], stiffness=1e4)
    ctl = fc.ImpedanceController(arm, inertia=100, damping=500, stiffness=2500)
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    return arm, plane, fc.simulate(arm, plane, ctl, fc.Setpoint([1.1, 0.1]), q0=q0, duration=0.6)


def test_planar_gif_frames_move(approach, tmp_path):
    """The GIF of a planar run has one frame per 50 ms (20 fps, real time) and consecutive frames differ."""
    arm, plane, res = approach
    path = animate_run(res, arm, plane, tmp_path / "a" / "run.gif")
    frames = _frames(path)
    assert len(frames) == 13  # 0.6 s at 20 frames/s, both ends included
    assert all(ImageChops.difference(a, b).getbbox() is not None for a, b in zip(frames, frames[1:]))


def test_force_arrow_drawn_in_the_force_colour(approach, tmp_path):
    """Once in contact the force arrow (vermilion) appears: absent in the first frame (no force), present at the end."""
    arm, plane, res = approach
    frames = _frames(animate_run(res, arm, plane, tmp_path / "run.gif", max_frames=4))

    def vermilion(img):
        a = np.asarray(img).astype(int)
        return int(np.sum((abs(a[..., 0] - 0xD5) < 30) & (abs(a[..., 1] - 0x5E) < 30) & (abs(a[..., 2] - 0x00) < 40)))

    assert res.wrench[0, 0] == 0.0 and res.wrench[-1, 0] > 100.0
    assert vermilion(frames[0]) < 20 < vermilion(frames[-1])


def test_frame_indices():
    """Frames every 1/fps of simulated time, capped at max_frames, first and last sample included."""
    t = np.arange(0, 4.0005, 0.001)
    idx = frame_indices(t, fps=20)
    assert idx[0] == 0 and idx[-1] == len(t) - 1 and len(idx) == 81
    assert np.allclose(np.diff(t[idx]), 0.05, atol=1e-3)
    assert len(frame_indices(t, fps=20, max_frames=10)) == 10
    assert len(frame_indices(t, fps=20, speed=4.0)) == 21


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"fps": 0.0}, "fps must be a positive"), ({"speed": -1.0}, "speed must be a positive"),
     ({"max_frames": 1}, "max_frames must be an integer >= 2")],
)
def test_frame_indices_rejects(kwargs, match):
    """Non-positive fps or speed and fewer than two frames are refused, naming the parameter."""
    args = {"fps": 20.0, **kwargs}
    with pytest.raises(ParameterError, match=match):
        frame_indices(np.linspace(0, 1, 11), **args)


def test_animate_rejects_bad_suffix_and_robot(approach, tmp_path):
    """Only .gif/.mp4 are written; a robot that cannot say where its joints are is refused."""
    arm, plane, res = approach
    with pytest.raises(ParameterError, match=r"must end in \.gif or \.mp4; got"):
        animate_run(res, arm, plane, tmp_path / "run.png")
    with pytest.raises(ParameterError, match="joint_positions"):
        animate_run(res, object(), plane, tmp_path / "run.gif")


def test_joint_positions_match_forward_kinematics():
    """The drawn tip is the robot's forward kinematics; the elbow is a1 away from the base."""
    arm = fc.PlanarTwoLink()
    q = np.array([0.3, -1.1])
    pts = arm.joint_positions(q)
    assert pts.shape == (3, 2)
    assert np.allclose(pts[0], 0.0) and np.allclose(pts[2], arm.forward_kinematics(q))
    assert np.isclose(np.linalg.norm(pts[1]), 1.0) and np.isclose(np.linalg.norm(pts[2] - pts[1]), 1.0)


def test_cli_run_animate(tmp_path):
    """`forcecontrol run FILE --animate` writes one GIF per case (Example 9.2 cut to 0.3 s) with frames that differ."""
    from forcecontrol.scenarios import scenario_source

    text = scenario_source("example-9.2").read_text(encoding="utf-8")
    assert "duration = 4.0" in text
    scn = tmp_path / "short.toml"
    scn.write_text(text.replace("duration = 4.0", "duration = 0.3", 1), encoding="utf-8")
    res = CliRunner().invoke(app, ["run", str(scn), "--animate", "--no-figure", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    gifs = sorted((tmp_path / "example-9.2").glob("*.gif"))
    assert len(gifs) == 2
    for g in gifs:
        frames = _frames(g)
        assert len(frames) == 7  # 0.3 s at 20 frames/s, both ends
        assert ImageChops.difference(frames[0], frames[-1]).getbbox() is not None
    assert "animation:" in res.stdout


def test_panda_stick_figure_gif(tmp_path):
    """A 6-D run is drawn in 3-D through the Panda's joint origins (last point: the TCP); frames differ."""
    from forcecontrol.robots.pinocchio import panda
    from forcecontrol.sim.simulation import SimulationResult

    robot = panda()
    qa = np.array([0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398])
    pts = robot.joint_positions(qa)
    assert pts.shape == (robot.model.njoints + 1, 3)
    assert np.allclose(pts[0], 0.0) and np.allclose(pts[-1], robot.frame_pose(qa)[1])
    n = 6
    q = np.linspace(qa, qa + np.array([0.6, 0.3, 0.0, 0.3, 0.0, -0.3, 0.0]), n)
    x = np.array([robot.forward_kinematics(qi) for qi in q])
    wrench = np.zeros((n, 6))
    wrench[:, 2] = -np.linspace(0.0, 20.0, n)  # pressing down on the table
    res = SimulationResult(t=np.linspace(0.0, 0.25, n), q=q, qd=np.zeros_like(q), x=x, xd=np.zeros_like(x),
                           wrench=wrench, wrench_measured=wrench, torque=np.zeros_like(q),
                           reference=np.zeros((n, 6 * 6)), label="panda")
    table = fc.Table(point=[0.0, 0.0, float(x[0, 2])])
    frames = _frames(animate_run(res, robot, table, tmp_path / "panda.gif"))
    assert len(frames) == n
    assert all(ImageChops.difference(a, b).getbbox() is not None for a, b in zip(frames, frames[1:]))


def test_each_frame_is_drawn_once_and_reported(approach, tmp_path, monkeypatch):
    """The figure is drawn once per frame (FuncAnimation.save drew each twice: 2.7 -> 1.7 s for Example 9.2's GIF, the
    same bytes), and the progress callback hears of every frame, in order."""
    from matplotlib.figure import Figure

    arm, plane, res = approach
    draws, heard = [], []
    original = Figure.draw

    def counted(self, renderer):
        draws.append(1)
        return original(self, renderer)

    monkeypatch.setattr(Figure, "draw", counted)
    path = animate_run(res, arm, plane, tmp_path / "run.gif", max_frames=5,
                       progress=lambda done, total: heard.append((done, total)))
    frames = _frames(path)
    assert len(frames) == 5 and len(draws) == 5
    assert heard == [(k, 5) for k in range(1, 6)]
