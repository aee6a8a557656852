"""The URDF a robot is rebuilt from in MuJoCo: the chapter arm's shipped file or a Pinocchio robot's own."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import ParameterError

__all__: list[str] = []


def _robot_source(robot) -> tuple[Path, str, tuple[str, ...], np.ndarray, np.ndarray, str]:
    """(urdf, frame, locked joints, armature, gravity, task) for a supported robot."""
    from ..robots.planar_2r import PlanarTwoLink

    if isinstance(robot, PlanarTwoLink):
        from ..robots.pinocchio import model_path
        from ..robots.planar_2r import PlanarTwoLinkParameters

        p = robot.parameters
        # the MuJoCo model is built from the shipped URDF of the chapter's arm: only the motor
        # data and gravity can differ from it; anything else would silently simulate another arm
        fixed = ("a1", "a2", "l1", "l2", "m_l1", "m_l2", "I_l1", "I_l2", "m_m2", "F1", "F2")
        ref = PlanarTwoLinkParameters()
        changed = [f for f in fixed if p is not None and getattr(p, f) != getattr(ref, f)]
        if changed:
            raise ParameterError(
                "the MuJoCo engine models the chapter's arm from its URDF: parameters "
                f"{', '.join(changed)} must keep the chapter's values; got "
                + ", ".join(f"{f} = {getattr(p, f)!r}" for f in changed)
            )
        kr1, Im1, kr2, Im2 = (100.0, 0.01, 100.0, 0.01) if p is None else (p.k_r1, p.I_m1, p.k_r2, p.I_m2)
        g = 9.81 if p is None else p.gravity
        armature = np.array([kr1**2 * Im1, kr2**2 * Im2])
        return model_path("chapter_arm"), "tip", (), armature, np.array([0.0, -g, 0.0]), "planar"
    path = getattr(robot, "urdf_path", None)
    if path is None:
        raise ParameterError(
            f"the MuJoCo engine needs the built-in arm or a PinocchioRobot loaded from a URDF; got {type(robot).__name__}"
        )
    # a payload (robot.payload) is not in the URDF: MujocoPlant adds it as a body (engines.mujoco_payload)
    from ..robots.urdf_check import check_urdf

    check_urdf(path)  # the file may have changed since Pinocchio read it: MuJoCo reads it again
    return (
        Path(path), robot.frame, tuple(robot.locked_joints), np.asarray(robot.model.armature, dtype=float).copy(),
        np.asarray(robot.model.gravity.linear, dtype=float).copy(), robot.task,
    )


def _clean_urdf(text: str, locked: tuple[str, ...]) -> str:
    text = re.sub(r"<visual\b.*?</visual>", "", text, flags=re.S)
    text = re.sub(r"<collision\b.*?</collision>", "", text, flags=re.S)
    for j in locked:
        text = re.sub(rf'(<joint\s+name="{re.escape(j)}"\s+type=")\w+(")', r"\1fixed\2", text)
    mj = '<mujoco><compiler discardvisual="true" fusestatic="false" balanceinertia="true"/></mujoco>'
    return re.sub(r"(<robot\b[^>]*>)", r"\1" + mj, text, count=1)
