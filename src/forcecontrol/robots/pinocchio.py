"""Any robot from a URDF through Pinocchio, with the same interface as the built-in arm.

Needs the optional extra ``pinocchio`` (``pip install forcecontrol[pinocchio]``); Pinocchio is
imported here only.

The controlled frame's kinematics, in the base (world) frame:

* ``x = [o_e; φ_e]`` with φ_e the XYZ Euler angles of R_e (``task="pose"``, m = 6), or the
  position only (``"position"``, m = 3) or its x, y components (``"planar"``, m = 2);
* ``J`` the geometric Jacobian (3.4), rows ``[ȯ_e; ω_e]`` (``LOCAL_WORLD_ALIGNED``), and
  ``ẋ = J q̇`` is the twist (not the Euler rates);
* ``J̇ q̇`` the classical acceleration of the frame at ``q̈ = 0``;
* ``B = CRBA + diag(armature) + rotor_coupling`` and ``n = RNEA(q, q̇, 0) + F q̇``.

Motor inertias: the reflected rotor inertias ``k_r² I_m`` are Pinocchio's ``armature`` (diagonal
of B). The gyroscopic coupling of a rotor mounted on a preceding link (``k_r2 I_m2`` in b12 of
the chapter's arm) has no place in a URDF nor in ``armature``: pass it as ``rotor_coupling``, a
constant symmetric matrix added to B (constant, so it adds nothing to C q̇).
"""

from __future__ import annotations

import importlib.metadata
import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..core.validate import as_matrix, as_vector
from ..errors import DimensionError, ParameterError
from ..spatial.closed_form import rotation_to_euler_xyz  # per integrator stage
from .base import RobotTerms

__all__ = ["PinocchioRobot", "Payload", "chapter_arm", "panda", "ur5", "ur10", "example_robot_data_dir", "model_path"]

Task = Literal["pose", "position", "planar"]
_ROWS = {"pose": slice(0, 6), "position": slice(0, 3), "planar": slice(0, 2)}


def _pin():
    try:
        import pinocchio  # type: ignore[import-untyped]
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError(
            "forcecontrol.robots.pinocchio needs Pinocchio: pip install 'forcecontrol[pinocchio]'"
        ) from exc
    return pinocchio


def model_path(name: str) -> Path:
    """Path of a URDF shipped with forcecontrol (``robots/models/<name>.urdf``)."""
    p = resources.files("forcecontrol.robots") / "models" / f"{name}.urdf"
    return Path(str(p))


@lru_cache(maxsize=1)
def example_robot_data_dir() -> Path:
    """The ``robots`` folder installed by the ``example-robot-data`` distribution."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError as exc:  # pragma: no cover
        raise ImportError("the Panda and UR5 models need example-robot-data: pip install 'forcecontrol[pinocchio]'") from exc
    for f in dist.files or ():
        s = str(f)
        if s.endswith("panda_description/urdf/panda.urdf"):
            return Path(str(dist.locate_file(f))).parents[2]
    raise ImportError("example-robot-data is installed but its robots folder was not found")  # pragma: no cover


@dataclass(frozen=True)
class Payload:
    """A rigid payload fixed to the controlled frame (a tool, a gripper with its part).

    Attributes:
        mass: m [kg], > 0.
        com: its centre of mass in the controlled frame, (3,) [m].
        inertia: its rotational inertia about the centre of mass in the controlled frame's axes,
            (3, 3) [kg m²]; zeros (a point mass) by default.
    """

    mass: float
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inertia: Any = None

    def __post_init__(self) -> None:
        m = float(self.mass)
        if not (math.isfinite(m) and m > 0.0):
            raise ParameterError(f"payload mass must be a finite number > 0 [kg]; got {self.mass!r}")
        object.__setattr__(self, "mass", m)
        object.__setattr__(self, "com", tuple(float(c) for c in as_vector("payload com", self.com, 3)))
        I = np.zeros((3, 3)) if self.inertia is None else np.array(as_matrix("payload inertia", self.inertia, (3, 3)))
        if not np.allclose(I, I.T, atol=1e-12) or np.min(np.linalg.eigvalsh(I)) < -1e-12:
            raise ParameterError(f"payload inertia must be a symmetric positive semi-definite (3, 3) matrix; got {I.tolist()}")
        object.__setattr__(self, "inertia", I)

    def describe(self) -> dict[str, Any]:
        return {"mass": self.mass, "com": list(self.com), "inertia": np.asarray(self.inertia).tolist()}


def _frame_id(pin: Any, model: Any, frame: str, frame_type: str | None) -> int:
    """The id of the frame named ``frame`` (of type ``frame_type`` when given), or ParameterError."""
    matches = [(i, str(f.type).rsplit(".", 1)[-1]) for i, f in enumerate(model.frames) if f.name == frame]
    if frame_type is not None:
        types = ("BODY", "JOINT", "FIXED_JOINT", "OP_FRAME", "SENSOR")
        if frame_type not in types:
            raise ParameterError(f"frame_type must be one of {list(types)}; got {frame_type!r}")
        matches = [(i, t) for i, t in matches if t == frame_type]
    if len(matches) != 1:
        found = [t for _, t in matches] or "none"
        raise ParameterError(
            f"frame {frame!r} names {len(matches)} frames of the model (types {found}); "
            "give frame_type='BODY' (the link) or 'JOINT' to pick one"
            if matches else f"no frame {frame!r} of type {frame_type!r}; its types are "
            f"{[str(f.type).rsplit('.', 1)[-1] for f in model.frames if f.name == frame]}"
        )
    return int(matches[0][0])


#: the Euler angles passed to a wrench that does not read them (Environment.reads_orientation False)
_NO_ANGLES = np.full(3, np.nan)


class PinocchioRobot:
    """A :class:`~forcecontrol.robots.base.RobotModel` computed by Pinocchio.

    Holds a Pinocchio ``Data`` buffer (scratch memory, not state): one instance per thread.

    Args:
        model: a ``pinocchio.Model``.
        frame: name of the controlled frame (end-effector).
        task: ``"pose"`` (m = 6), ``"position"`` (m = 3) or ``"planar"`` (m = 2).
        armature: reflected rotor inertias ``k_r² I_m`` [kg m²], (n,); default: the model's.
        friction: viscous friction F [N m s/rad], scalar, (n,) or (n, n); default: the
            joints' URDF ``damping``.
        rotor_coupling: constant (n, n) symmetric matrix added to B (rotor couplings a URDF cannot
            express); default none.
        gravity: gravity acceleration vector in the base frame [m/s²], (3,); default the model's.
        frame_type: which of several frames named ``frame`` (a URDF link and joint may share a
            name): ``"BODY"``, ``"JOINT"``, ``"FIXED_JOINT"`` or ``"OP_FRAME"``; None when the name
            is unique.
        name: a label.

    Raises:
        ParameterError: the frame does not exist (the message lists the frames), or the name is
            ambiguous without ``frame_type``.

    ``payload``: a :class:`Payload` fixed to the controlled frame; its inertia is added to the
    body of the frame's parent joint (``model.inertias``), so B, n, g and the dynamics carry it.
    """

    def __init__(
        self,
        model: Any,
        frame: str,
        *,
        task: Task = "pose",
        armature: Any = None,
        friction: Any = None,
        rotor_coupling: Any = None,
        gravity: Any = None,
        name: str = "",
        frame_type: str | None = None,
        payload: Payload | None = None,
    ) -> None:
        pin = _pin()
        self._pin = pin
        self.model = model.copy() if hasattr(model, "copy") else model
        if task not in _ROWS:
            raise ParameterError(f"task must be one of {sorted(_ROWS)}; got {task!r}")
        if not self.model.existFrame(frame):
            frames = [f.name for f in self.model.frames]
            raise ParameterError(f"frame {frame!r} is not in the model; frames are {frames}")
        if self.model.nq != self.model.nv:
            raise ParameterError("only models with nq == nv (revolute/prismatic joints) are supported")
        n = int(self.model.nv)
        self.nq = n
        self.task = task
        self.task_dim = {"pose": 6, "position": 3, "planar": 2}[task]
        self._rows = _ROWS[task]
        self.frame = frame
        self.frame_id = _frame_id(pin, self.model, frame, frame_type)
        self.name = name or str(self.model.name)
        if armature is not None:
            self.model.armature = np.array(as_vector("armature", armature, n))
        if gravity is not None:
            self.model.gravity.linear = np.array(as_vector("gravity", gravity, 3))
        if friction is None:
            F = np.diag(np.asarray(self.model.damping, dtype=np.float64))
        else:
            f = np.asarray(friction, dtype=np.float64)
            F = f * np.eye(n) if f.ndim == 0 else (np.diag(f) if f.ndim == 1 else f)
            F = np.array(as_matrix("friction", F, (n, n)))
        self.friction = F
        self._F_diag = np.diag(F).copy() if np.count_nonzero(F - np.diag(np.diag(F))) == 0 else None
        if rotor_coupling is None:
            self.rotor_coupling = None
        else:
            Rc = np.array(as_matrix("rotor_coupling", rotor_coupling, (n, n)))
            if not np.allclose(Rc, Rc.T, atol=1e-12):
                raise ParameterError("rotor_coupling must be a symmetric (n, n) matrix")
            self.rotor_coupling = Rc
        if payload is not None and not isinstance(payload, Payload):
            raise ParameterError(f"payload must be a Payload or None; got {type(payload).__name__}")
        #: the payload on the controlled frame (None: none); already in ``model.inertias``.
        self.payload = payload
        if payload is not None:
            f = self.model.frames[self.frame_id]
            local = pin.Inertia(payload.mass, np.array(payload.com), np.asarray(payload.inertia, dtype=np.float64))
            self.model.inertias[f.parentJoint] = self.model.inertias[f.parentJoint] + f.placement.act(local)
        self.data = self.model.createData()
        self._lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        self.urdf_path: Path | None = None
        self.locked_joints: tuple[str, ...] = ()

    # -- construction
    @classmethod
    def from_urdf(
        cls,
        path: str | Path,
        frame: str,
        *,
        locked_joints: tuple[str, ...] = (),
        locked_values: Any = None,
        max_bytes: int = 64 * 2**20,
        check_inertia: bool = True,
        **kwargs: Any,
    ) -> PinocchioRobot:
        """Load a URDF; joints in ``locked_joints`` are fixed (at ``locked_values`` or the neutral).

        The file is checked first (:func:`forcecontrol.robots.urdf_check.check_urdf`): a regular
        file of at most ``max_bytes``, well-formed XML, unique names, a tree, physical masses and
        inertias (``check_inertia=False``: an indefinite or triangle-breaking inertia only warns).

        Raises:
            ParameterError: the file does not exist or fails a check (file, element and problem
                named), a locked joint or the frame is unknown.
        """
        from .urdf_check import check_urdf

        pin = _pin()
        path = Path(path)
        if not path.is_file():
            raise ParameterError(f"URDF file {str(path)!r} does not exist")
        # XML, names, tree, inertias: a clear error before Pinocchio's
        check_urdf(path, max_bytes=max_bytes, check_inertia=check_inertia)
        try:
            model = pin.buildModelFromUrdf(str(path))
        except (ValueError, RuntimeError) as exc:  # what the check does not catch; Pinocchio's text may quote the file
            raise ParameterError(
                f"URDF file {str(path)!r}: Pinocchio cannot build a model from it ({type(exc).__name__})"
            ) from None
        if locked_joints:
            ids = []
            for j in locked_joints:
                if not model.existJointName(j):
                    raise ParameterError(f"locked joint {j!r} is not in the model; joints are {list(model.names)[1:]}")
                ids.append(model.getJointId(j))
            q_ref = pin.neutral(model) if locked_values is None else np.asarray(locked_values, dtype=np.float64)
            model = pin.buildReducedModel(model, ids, q_ref)
        robot = cls(model, frame, **kwargs)
        #: where the model came from (the MuJoCo engine rebuilds the same robot from it).
        robot.urdf_path = path
        robot.locked_joints = tuple(locked_joints)
        return robot

    # -- kinematics
    def frame_pose(self, q: Any) -> tuple[np.ndarray, np.ndarray]:
        """(R_e (3, 3), o_e (3,)) of the controlled frame in the base frame."""
        pin = self._pin
        q = self._q(q)
        pin.framesForwardKinematics(self.model, self.data, q)
        M = self.data.oMf[self.frame_id]
        return M.rotation.copy(), M.translation.copy()

    def joint_positions(self, q: Any) -> np.ndarray:
        """The base, every joint's origin and the controlled frame in the base frame, (n_j + 2, 3) [m]
        (for drawing the arm as a stick figure).

        Raises:
            DimensionError, MeasurementError: ``q`` has the wrong size or is not finite.
        """
        pin = self._pin
        q = self._q(q)
        pin.framesForwardKinematics(self.model, self.data, q)
        pts = [np.zeros(3)] + [self.data.oMi[i].translation.copy() for i in range(1, self.model.njoints)]
        pts.append(self.data.oMf[self.frame_id].translation.copy())
        return np.array(pts)

    def _x(self, R: np.ndarray, p: np.ndarray) -> np.ndarray:
        if self.task == "pose":
            return np.concatenate([p, rotation_to_euler_xyz(R)])
        return p[self._rows].copy()

    def forward_kinematics(self, q: Any) -> np.ndarray:
        """x_e: ``[o_e; φ_e]`` (pose), o_e (position) or its x, y (planar)."""
        R, p = self.frame_pose(q)
        return self._x(R, p)

    def spatial_jacobian(self, q: Any) -> np.ndarray:
        """The full geometric Jacobian ``[J_P; J_O]`` of the frame, (6, n)."""
        pin = self._pin
        q = self._q(q)
        return pin.computeFrameJacobian(self.model, self.data, q, self.frame_id, self._lwa).copy()

    def jacobian(self, q: Any) -> np.ndarray:
        """Geometric Jacobian rows of the task, (m, n)."""
        return self.spatial_jacobian(q)[self._rows]

    def spatial_jdot_qdot(self, q: Any, qd: Any) -> np.ndarray:
        """``J̇ q̇`` of the full 6-D twist (classical acceleration at q̈ = 0), (6,)."""
        pin = self._pin
        q, qd = self._q(q), self._q(qd, "qd")
        pin.forwardKinematics(self.model, self.data, q, qd, np.zeros(self.nq))
        return pin.getFrameClassicalAcceleration(self.model, self.data, self.frame_id, self._lwa).vector.copy()

    def jdot_qdot(self, q: Any, qd: Any) -> np.ndarray:
        """``J̇ q̇`` rows of the task, (m,)."""
        return self.spatial_jdot_qdot(q, qd)[self._rows]

    # -- dynamics
    def mass_matrix(self, q: Any) -> np.ndarray:
        """B(q) including armature and rotor coupling, (n, n)."""
        pin = self._pin
        B = pin.crba(self.model, self.data, self._q(q)).copy()
        B = np.triu(B) + np.triu(B, 1).T
        if self.rotor_coupling is not None:
            B += self.rotor_coupling
        return B

    def gravity(self, q: Any) -> np.ndarray:
        """g(q), (n,)."""
        return self._pin.computeGeneralizedGravity(self.model, self.data, self._q(q)).copy()

    def nonlinear_effects(self, q: Any, qd: Any) -> np.ndarray:
        """``n = C q̇ + F q̇ + g``, (n,)."""
        qd = self._q(qd, "qd")
        return self._pin.nonLinearEffects(self.model, self.data, self._q(q), qd) + self.friction @ qd

    def terms(self, q: np.ndarray, qd: np.ndarray) -> RobotTerms:
        """Everything at once (one ``computeAllTerms``), 6-D quantities restricted to the task rows."""
        R, p, J6, Jdq6, B, nv, g = self.spatial_terms(q, qd)
        r = self._rows
        J = J6[r]
        return RobotTerms(self._x(R, p), J @ qd, J, Jdq6[r], B, nv, g)

    def spatial_terms(self, q: np.ndarray, qd: np.ndarray):
        """(R_e, o_e, J (6, n), J̇q̇ (6,), B, n, g) from one ``computeAllTerms`` (the hot path)."""
        pin, model, data, fid = self._pin, self.model, self.data, self.frame_id
        pin.computeAllTerms(model, data, q, qd)
        pin.updateFramePlacement(model, data, fid)
        M = data.oMf[fid]
        J6 = pin.getFrameJacobian(model, data, fid, self._lwa)
        Jdq6 = pin.getFrameClassicalAcceleration(model, data, fid, self._lwa).vector
        B = data.M.copy()
        if self.rotor_coupling is not None:
            B += self.rotor_coupling
        if self._F_diag is not None:
            nv = data.nle + self._F_diag * qd
        else:
            nv = data.nle + self.friction @ qd
        return M.rotation.copy(), M.translation.copy(), J6, Jdq6, B, nv, data.g.copy()

    def pose_twist(self, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(x_e, ẋ_e) of the task from forward kinematics alone (no Jacobian, no dynamics).

        ẋ_e is the frame's twist ``[ȯ_e; ω_e]`` in the base frame restricted to the task rows,
        the same as ``terms(q, qd).xd`` (``J q̇``) at a fraction of the cost.
        """
        pin, model, data, fid = self._pin, self.model, self.data, self.frame_id
        pin.forwardKinematics(model, data, q, qd)
        pin.updateFramePlacement(model, data, fid)
        M = data.oMf[fid]
        v = pin.getFrameVelocity(model, data, fid, self._lwa).vector
        return self._x(M.rotation, M.translation), v[self._rows]

    def elastic_acceleration(
        self, q: np.ndarray, qd: np.ndarray, u: np.ndarray, wrench: Callable[[np.ndarray, np.ndarray], np.ndarray],
        orientation: bool = True,
    ) -> tuple[np.ndarray, np.ndarray]:
        """The plant (9.1) in contact with an elastic environment: ``q̈ = B⁻¹ (u − n − Jᵀ h_e)``.

        ``h_e = wrench(x_e, ẋ_e)``. Solved by Pinocchio's articulated-body algorithm (``aba``,
        armature included) on ``τ = u − F q̇ − Jᵀ h_e``, which avoids forming and factorising B;
        the Jacobian is computed only while the wrench is non-zero. A model with a rotor coupling
        (a term of B that ABA does not know) takes ``terms`` and a linear solve instead. Equal to
        ``solve(B, u − n − Jᵀ h)`` to round-off (tested). ``orientation=False`` (an environment whose wrench
        reads only o_e and ȯ_e, :attr:`~forcecontrol.environments.base.Environment.reads_orientation`) passes NaN
        for a pose task's Euler angles instead of computing them.

        Returns:
            q̈ (n,) [rad/s²] and h_e (m,) [N].
        """
        if self.rotor_coupling is not None:
            T = self.terms(q, qd)
            h = np.asarray(wrench(T.x, T.xd), dtype=np.float64)
            return np.linalg.solve(T.B, u - T.n - T.J.T @ h), h
        pin, model, data, fid = self._pin, self.model, self.data, self.frame_id
        if orientation or self.task != "pose":
            x, xd = self.pose_twist(q, qd)
        else:  # pose_twist without the Euler angles
            pin.forwardKinematics(model, data, q, qd)
            pin.updateFramePlacement(model, data, fid)
            x = np.concatenate([data.oMf[fid].translation, _NO_ANGLES])
            xd = pin.getFrameVelocity(model, data, fid, self._lwa).vector
        h = np.asarray(wrench(x, xd), dtype=np.float64)
        tau = u - (self._F_diag * qd if self._F_diag is not None else self.friction @ qd)
        if np.count_nonzero(h):  # h.any(), a fifth of its cost
            J = pin.computeFrameJacobian(model, data, q, fid, self._lwa)
            tau = tau - J[self._rows].T @ h
        return pin.aba(model, data, q, qd, tau), h

    def _q(self, v: Any, name: str = "q") -> np.ndarray:
        a = np.asarray(v, dtype=np.float64)
        if a.shape != (self.nq,):
            raise DimensionError(f"{name} must have shape ({self.nq},); got shape {a.shape}")
        return a

    def describe(self) -> dict[str, Any]:
        """Plain description for metadata."""
        out = {"type": "PinocchioRobot", "name": self.name, "frame": self.frame, "task": self.task, "nq": self.nq}
        if self.payload is not None:
            out["payload"] = self.payload.describe()
        return out


# ----------------------------------------------------------------------------- ready-made models


def chapter_arm(task: Task = "planar") -> PinocchioRobot:
    """The chapter's two-link arm from its shipped URDF, motors included (equal to the closed form).

    Armature ``[k_r1² I_m1, k_r2² I_m2] = [100, 100]``, rotor coupling ``k_r2 I_m2 = 1`` in b12,
    friction diag(100, 100) from the URDF, gravity 9.81 m/s² along −y. Frame ``"tip"``.
    """
    k_r2_I_m2 = 100.0 * 0.01
    return PinocchioRobot.from_urdf(
        model_path("chapter_arm"),
        "tip",
        task=task,
        armature=[100.0**2 * 0.01, 100.0**2 * 0.01],
        rotor_coupling=[[0.0, k_r2_I_m2], [k_r2_I_m2, 0.0]],
        gravity=[0.0, -9.81, 0.0],
        name="chapter_arm",
    )


def panda(frame: str = "panda_hand_tcp", task: Task = "pose") -> PinocchioRobot:
    """Franka Emika Panda from example-robot-data, fingers locked: 7 DOF; frame ``panda_hand_tcp``."""
    path = example_robot_data_dir() / "panda_description" / "urdf" / "panda.urdf"
    return PinocchioRobot.from_urdf(
        path, frame, locked_joints=("panda_finger_joint1", "panda_finger_joint2"), task=task, name="panda"
    )


def ur5(frame: str = "tool0", task: Task = "pose", payload: Payload | None = None) -> PinocchioRobot:
    """Universal Robots UR5 from example-robot-data: 6 DOF; frame ``tool0``; optional payload."""
    path = example_robot_data_dir() / "ur_description" / "urdf" / "ur5_robot.urdf"
    return PinocchioRobot.from_urdf(path, frame, task=task, name="ur5", payload=payload)



def ur10(frame: str = "tool0", task: Task = "pose", payload: Payload | None = None) -> PinocchioRobot:
    """Universal Robots UR10 (CB series) from example-robot-data: 6 DOF; frame ``tool0``; optional payload.

    example-robot-data has no e-Series model (UR10e, UR16e, UR20): the UR10 stands in for them.
    """
    path = example_robot_data_dir() / "ur_description" / "urdf" / "ur10_robot.urdf"
    return PinocchioRobot.from_urdf(path, frame, task=task, name="ur10", payload=payload)


#: a neutral-ish, well-conditioned Panda posture [rad] (elbow bent, hand down).
PANDA_READY = np.array([0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398])
