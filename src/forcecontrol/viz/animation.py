"""Motion you can see: an animation of a run (matplotlib.animation; matplotlib is imported inside).

The planar arm is drawn as its two links in the base frame, with the environment (a plane's
surface, hatched on the environment's side, a rigid plane constraint, or a curved surface's contour:
a circle, a height field's profile, :mod:`forcecontrol.viz.surface_mesh`) and the contact force
as an arrow at the tip. The arrow is ``h_e``, the force the end-effector exerts **on** the
environment (the chapter's sense), so it points into the surface while pushing.

6-D robots (the Panda through Pinocchio) are drawn as a 3-D stick figure through their joint
origins (``robot.joint_positions``) with the table, if any (or the patch of a sphere, a cylinder or a
height field around the tool's path), and the force arrow. MuJoCo's offscreen
renderer works headless here (``MUJOCO_GL=egl``), but the library's MuJoCo model is built without
the robot's meshes (:mod:`forcecontrol.engines.mujoco` strips visual geometry), so a rendered
frame would show nothing of the arm; the stick figure needs no graphics stack at all.

GIF files are written with Pillow (matplotlib's ``PillowWriter``), MP4 with ffmpeg when installed; each
frame is drawn once, by the writer's grab.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ParameterError

if TYPE_CHECKING:  # pragma: no cover
    from ..environments.base import Environment
    from ..sim.simulation import SimulationResult

__all__ = ["animate_run", "frame_indices"]


def frame_indices(t: np.ndarray, fps: float, speed: float = 1.0, max_frames: int = 120) -> np.ndarray:
    """Sample indices drawn as frames: one every ``speed / fps`` seconds of simulated time, at most
    ``max_frames`` (evenly spread over the run then), always including the first and last sample.

    Args:
        t: sample times (N+1,) [s]; fps: frames per second of the file; speed: simulated seconds per
        second of the animation (1 = real time); max_frames: cap on the frame count.

    Returns:
        Increasing sample indices, at least two (a run of a single sample gives ``[0]``).

    Raises:
        ParameterError: fps, speed or max_frames not positive.
    """
    if not (np.isfinite(fps) and fps > 0):
        raise ParameterError(f"fps must be a positive number [1/s]; got {fps!r}")
    if not (np.isfinite(speed) and speed > 0):
        raise ParameterError(f"speed must be a positive number (simulated seconds per second); got {speed!r}")
    if int(max_frames) != max_frames or max_frames < 2:
        raise ParameterError(f"max_frames must be an integer >= 2; got {max_frames!r}")
    t = np.asarray(t, dtype=float)
    if t.size < 2:
        return np.zeros(1, dtype=int)
    n = int(min(max_frames, max(2, np.floor((t[-1] - t[0]) * fps / speed) + 1)))
    targets = np.linspace(t[0], t[-1], n)
    idx = np.unique(np.clip(np.searchsorted(t, targets), 0, t.size - 1))
    return idx


def animate_run(
    result: SimulationResult,
    robot: Any,
    environment: Environment | None,
    path: str | Path,
    *,
    fps: float = 20.0,
    speed: float = 1.0,
    max_frames: int = 120,
    title: str = "",
    progress: Callable[[int, int], None] | None = None,
) -> Path:
    """Write an animation of one run: the arm moving, the environment and the contact force arrow.

    Args:
        result: the simulated run (its ``q`` and ``wrench`` logs are drawn).
        robot: the robot that ran it; needs ``joint_positions(q)`` (the chapter's arm and Pinocchio
            robots have it).
        environment: the environment drawn (an elastic plane, a table, a rigid plane constraint;
            others, e.g. springs, are not drawn); None draws none.
        path: ``.gif`` (Pillow) or ``.mp4`` (needs ffmpeg); the folder is created.
        fps: frames per second; speed: simulated seconds per second (1 = real time);
        max_frames: cap on the frames (longer runs are shown faster).
        title: text above the drawing (the time is appended).
        progress: called as ``progress(frames_written, total_frames)`` after each frame (a progress bar).

    Returns:
        The written file.

    Raises:
        ParameterError: unknown file suffix, a robot without ``joint_positions``, an MP4 without
            ffmpeg, or bad fps/speed/max_frames.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib import animation

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise ParameterError(f"animation file must end in .gif or .mp4; got {str(path)!r}")
    if not callable(getattr(robot, "joint_positions", None)):
        raise ParameterError(f"robot must have joint_positions(q) to be drawn; got {type(robot).__name__}")
    if suffix == ".mp4" and not animation.writers.is_available("ffmpeg"):
        raise ParameterError("writing .mp4 needs ffmpeg on the PATH; write a .gif instead")
    idx = frame_indices(result.t, fps, speed, max_frames)
    pts = np.array([np.asarray(robot.joint_positions(result.q[k]), dtype=float) for k in idx])
    dim = pts.shape[2]
    forces = np.asarray(result.wrench[idx, : min(dim, result.wrench.shape[1])], dtype=float)
    fmax = float(np.linalg.norm(result.wrench[:, : forces.shape[1]], axis=1).max()) if result.wrench.size else 0.0
    reach = float(np.ptp(pts.reshape(-1, dim), axis=0).max()) or 1.0
    scale = 0.25 * reach / fmax if fmax > 0 else 0.0  # the largest force is a quarter of the drawing
    draw = _Planar if dim == 2 else _Spatial
    fig = plt.figure(figsize=(5.6, 5.0) if dim == 2 else (6.0, 5.6))
    fig.subplots_adjust(left=0.13, right=0.97, bottom=0.1, top=0.9)  # fixed: no layout engine per frame
    scene = draw(fig, pts, environment, forces * scale, np.linalg.norm(forces, axis=1))
    from ..core.text import TITLE_LIMIT, figure_safe

    label = figure_safe(title or result.label or "", TITLE_LIMIT)  # text from files drawn literally, bounded

    def update(i: int) -> None:
        scene.show(i)
        scene.ax.set_title(f"{label}\nt = {result.t[idx[i]]:.3f} s" if label else f"t = {result.t[idx[i]]:.3f} s",
                           fontsize=9)

    path.parent.mkdir(parents=True, exist_ok=True)
    writer: Any = animation.PillowWriter(fps=fps) if suffix == ".gif" else animation.FFMpegWriter(fps=fps)
    # The writer driven directly (matplotlib's "saving" context, one grab per frame): each frame is drawn once,
    # by the grab. FuncAnimation.save drew every frame twice (its draw_idle after each update, then the grab):
    # the same file, byte for byte (compared when this was changed), in about 60 % of the time; tests/test_animation.py
    # counts the draws.
    try:
        with matplotlib.rc_context({"savefig.bbox": None}), writer.saving(fig, str(path), 90):
            for i in range(len(idx)):
                update(i)
                writer.grab_frame()
                if progress is not None:
                    progress(i + 1, len(idx))
    finally:
        plt.close(fig)
    return path


def _plane_of(environment: Any) -> tuple[np.ndarray, np.ndarray] | None:
    """(point, outward normal) of a drawable plane environment, or None."""
    if environment is None:
        return None
    source = getattr(environment, "constraint", environment)  # RigidEnvironment holds a PlaneConstraint
    point, normal = getattr(source, "point", None), getattr(source, "normal", None)
    if point is None or normal is None:
        return None
    return np.asarray(point, dtype=float), np.asarray(normal, dtype=float)


class _Planar:
    """The planar arm: links, joints, tip path, plane surface, force arrow."""

    def __init__(self, fig: Any, pts: np.ndarray, environment: Any, arrows: np.ndarray, norms: np.ndarray) -> None:
        self.ax = ax = fig.add_subplot()
        self.pts, self.arrows, self.norms = pts, arrows, norms
        allp = np.vstack([pts.reshape(-1, 2), (pts[:, -1] + arrows)])
        lo, hi = allp.min(axis=0), allp.max(axis=0)
        pad = 0.15 * float((hi - lo).max() or 1.0)
        lo, hi = lo - pad, hi + pad
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal")
        ax.set_xlabel("x₀ [m]")
        ax.set_ylabel("y₀ [m]")
        ax.grid(True, lw=0.3)
        plane = _plane_of(environment)
        if plane is not None:
            p, n = plane
            d = np.array([-n[1], n[0]])
            L = 2.0 * float(np.hypot(*(hi - lo)))
            a, b = p - L * d, p + L * d
            ax.plot([a[0], b[0]], [a[1], b[1]], color="0.3", lw=1.5, zorder=1)
            from matplotlib.collections import LineCollection

            depth = 0.04 * float((hi - lo).max())
            starts = p + np.linspace(-L, L, 160)[:, None] * d  # hatching on the environment's side (against n)
            ax.add_collection(LineCollection(np.stack([starts, starts - depth * n + 0.6 * depth * d], axis=1),
                                             colors="0.6", linewidths=0.6, zorder=0))
            ax.set_xlim(lo[0], hi[0])
            ax.set_ylim(lo[1], hi[1])
        from .surface_mesh import surface_patch

        curve = surface_patch(environment, pts[:, -1], 1.5 * float((hi - lo).max()), 181)
        if curve is not None:  # a circle or a height-field profile: the surface itself, not a plane
            ax.plot(curve[:, 0], curve[:, 1], color="0.3", lw=1.5, zorder=1)
            ax.set_xlim(lo[0], hi[0])
            ax.set_ylim(lo[1], hi[1])
        (self.path,) = ax.plot([], [], color="#0072B2", lw=0.8, alpha=0.7, label="tip path")
        (self.links,) = ax.plot([], [], "-o", color="k", lw=3, ms=6, mfc="w", zorder=3)
        self.arrow = None
        self.text = ax.text(0.02, 0.02, "", transform=ax.transAxes, fontsize=8)

    def show(self, i: int) -> None:
        p = self.pts[i]
        self.links.set_data(p[:, 0], p[:, 1])
        self.path.set_data(self.pts[: i + 1, -1, 0], self.pts[: i + 1, -1, 1])
        if self.arrow is not None:
            self.arrow.remove()
            self.arrow = None
        a = self.arrows[i]
        if np.linalg.norm(a) > 0:
            self.arrow = self.ax.annotate(
                "", xy=p[-1] + a, xytext=p[-1], arrowprops={"arrowstyle": "-|>", "color": "#D55E00", "lw": 2}, zorder=4
            )
        self.text.set_text(f"|h_e| = {self.norms[i]:.1f} N (force on the environment)")


class _Spatial:
    """A 3-D stick figure through the joint origins, the table plane and the force arrow."""

    def __init__(self, fig: Any, pts: np.ndarray, environment: Any, arrows: np.ndarray, norms: np.ndarray) -> None:
        self.ax = ax = fig.add_subplot(projection="3d")
        self.pts, self.arrows, self.norms = pts, arrows, norms
        allp = np.vstack([pts.reshape(-1, 3), pts[:, -1] + arrows])
        centre = 0.5 * (allp.min(axis=0) + allp.max(axis=0))
        half = 0.55 * float(np.ptp(allp, axis=0).max() or 1.0)
        for set_lim, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
            set_lim(c - half, c + half)
        ax.set_box_aspect((1, 1, 1))
        ax.set_xlabel("x₀ [m]")
        ax.set_ylabel("y₀ [m]")
        ax.set_zlabel("z₀ [m]")
        plane = _plane_of(environment)
        if plane is not None and plane[0].shape == (3,):
            p, n = plane
            u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
            u /= np.linalg.norm(u)
            v = np.cross(n, u)
            tip = pts[:, -1].mean(axis=0)
            c0 = p + (tip - p) - ((tip - p) @ n) * n
            s = np.linspace(-half, half, 2)
            U, V = np.meshgrid(s, s)
            X, Y, Z = (c0[k] + U * u[k] + V * v[k] for k in range(3))
            ax.plot_surface(X, Y, Z, color="0.7", alpha=0.35, linewidth=0)
        from .surface_mesh import surface_patch

        patch = surface_patch(environment, pts[:, -1], 0.5 * half)
        if patch is not None:  # a sphere, a cylinder or a height field: the surface itself around the tool's path
            ax.plot_surface(patch[..., 0], patch[..., 1], patch[..., 2], color="0.7", alpha=0.45, linewidth=0.2,
                            edgecolor="0.5")
        (self.path,) = ax.plot([], [], [], color="#0072B2", lw=0.8)
        (self.links,) = ax.plot([], [], [], "-o", color="k", lw=2.5, ms=4, mfc="w")
        (self.force,) = ax.plot([], [], [], color="#D55E00", lw=2.5)
        self.text = ax.text2D(0.02, 0.02, "", transform=ax.transAxes, fontsize=8)

    def show(self, i: int) -> None:
        p = self.pts[i]
        self.links.set_data_3d(p[:, 0], p[:, 1], p[:, 2])
        tips = self.pts[: i + 1, -1]
        self.path.set_data_3d(tips[:, 0], tips[:, 1], tips[:, 2])
        a = np.zeros(3)
        a[: self.arrows.shape[1]] = self.arrows[i]
        seg = np.array([p[-1], p[-1] + a])
        self.force.set_data_3d(seg[:, 0], seg[:, 1], seg[:, 2])
        self.text.set_text(f"|f_e| = {self.norms[i]:.1f} N (force on the environment)")
