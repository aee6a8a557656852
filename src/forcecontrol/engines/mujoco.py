"""MuJoCo as an independent plant: the same controller object, MuJoCo's dynamics, contact and force sensing.

Needs the optional extra ``mujoco`` (``pip install forcecontrol[mujoco]``); MuJoCo is imported
here only.

The robot is rebuilt in MuJoCo from the same URDF (visual and collision meshes dropped, locked
joints made fixed, static bodies kept so the controlled frame exists), with the joints'
armature and damping; the end-effector gets a small frictionless sphere (``contact_radius``)
centred on the controlled frame. Elastic planes and tables become MuJoCo planes shifted by that
radius, so that the penetration MuJoCo sees is the built-in environments' δ (curved surfaces, convex
meshes and friction: :mod:`.mujoco_surfaces`). A robot's payload is a
body after MuJoCo's own F/T sensor, which the controller then reads (:mod:`.mujoco_payload`).

The loop is the same sampled loop as :func:`forcecontrol.sim.simulation.simulate`: at each sample
``t_k`` read q, q̇ and the contact wrench from MuJoCo, call ``controller.step``, hold the torque
(``qfrc_applied``) over ``substeps`` MuJoCo RK4 steps.

Where MuJoCo and the built-in simulator differ (see :func:`compare_engines`):

* contacts are soft *constraints*: MuJoCo resolves ``a₁ + d (b v + k r) = (1 − d) a₀`` with an
  impedance d and a regulariser built from a constant approximate inverse inertia; this gives a
  spring of stiffness ``k_N`` at rest. ``solref = (−k, −b)`` is chosen so that ``k_N`` and the
  contact damping equal the environment's (calibrated at build time on the model itself), but
  the transient is not a pure spring: the regulariser adds a little compliance at high
  frequency;
* the contact acts at the sphere's surface, not at the frame's origin (no moment for a
  frictionless contact, the force is along the normal through the centre);
* the chapter arm: the rotor coupling ``k_r2 I_m2`` of b12 cannot be written in MuJoCo either
  (the closed form has it): b12 differs by 1 kg m² (about 4 %), which changes transients a
  little and statics not at all.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..controllers.base import REFERENCE_FIELDS, Controller, Measurement, Reference
from ..environments.base import Environment
from ..errors import ParameterError, SimulationDivergedError
from ..sim.limits import check_run_size
from ..sim.simulation import SimulationResult, _controller_signals
from ..spatial.closed_form import rotation_to_euler_xyz  # per sample
from ..trajectories import ReferenceSignal
from .compare import DIFFERENCES, compare_engines
from .mujoco_payload import PayloadReader, add_payload_body
from .mujoco_surfaces import add_friction, add_surface_geom, quat_z_to
from .urdf import _clean_urdf, _robot_source

__all__ = ["MujocoPlant", "simulate_mujoco", "compare_engines", "DIFFERENCES"]

def _mj():
    try:
        import mujoco  # type: ignore[import-untyped]
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError("the MuJoCo engine needs MuJoCo: pip install 'forcecontrol[mujoco]'") from exc
    return mujoco


class MujocoPlant:
    """A MuJoCo model of a robot and its environment, and the sampled loop around a controller.

    Args:
        robot: the built-in chapter arm or a URDF :class:`~forcecontrol.robots.pinocchio.PinocchioRobot`.
        environment: :class:`~forcecontrol.environments.elastic.ElasticPlane` or
            :class:`~forcecontrol.environments.spatial.Table` (MuJoCo contact), or a 2-/3-D
            :class:`~forcecontrol.environments.elastic.LinearSpring` (a passive force on the
            controlled frame that MuJoCo evaluates at every integrator stage).
        sample_time: control period Ts [s]; substeps: MuJoCo steps per sample.
        contact_radius: radius of the end-effector sphere [m].
        impedance: MuJoCo's constraint impedance d (solimp dmin = dmax), in (0, 1). MuJoCo's contact
            force is ``f = (a_ref − a₁) / R`` with ``R = (1 − d)/d · A``: besides the spring and
            damper of a_ref it carries an apparent mass ``d/(1 − d)`` times the end-effector's
            effective mass along the normal; the smallest d MuJoCo allows (default 1e-4) keeps that
            mass small; :meth:`describe` reports it.
    """

    def __init__(
        self,
        robot: Any,
        environment: Environment,
        *,
        sample_time: float = 1e-3,
        substeps: int = 4,
        contact_radius: float = 0.01,
        impedance: float = 1e-4,
    ) -> None:
        mujoco = _mj()
        self._mujoco = mujoco
        self.robot = robot
        self.environment = environment
        self.sample_time = float(sample_time)
        if int(substeps) != substeps or substeps < 1:
            raise ParameterError(f"substeps must be a positive integer; got {substeps!r}")
        self.substeps = int(substeps)
        self.radius = float(contact_radius)
        self.impedance = float(impedance)
        self._spring: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        # a position-interface arm (robots.servo): MuJoCo integrates its torque robot; the servo is in the controller
        urdf, frame, locked, armature, gravity, task = _robot_source(getattr(robot, "torque_robot", robot))
        self.task = task
        spec = mujoco.MjSpec.from_string(_clean_urdf(urdf.read_text(), locked))
        spec.option.timestep = self.sample_time / self.substeps
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
        spec.option.gravity = gravity
        joints = [j for j in spec.joints if j.type != mujoco.mjtJoint.mjJNT_FREE]
        if len(joints) != len(armature):
            raise ParameterError(f"MuJoCo model has {len(joints)} joints, the robot {len(armature)}")
        for j, a in zip(joints, armature):
            j.armature = float(a)
            j.limited = mujoco.mjtLimited.mjLIMITED_FALSE
        body = spec.body(frame)
        if body is None:
            raise ParameterError(f"frame {frame!r} is not a body of the MuJoCo model")
        payload = getattr(getattr(robot, "torque_robot", robot), "payload", None)
        if payload is not None:  # a body after the sensor site: it carries the contact sphere (engines.mujoco_payload)
            body = add_payload_body(mujoco, spec, body, payload, task)
        tip = body.add_geom()
        tip.name = "ee_contact"
        tip.type = mujoco.mjtGeom.mjGEOM_SPHERE
        tip.size = [self.radius, 0, 0]
        tip.mass = 0.0
        tip.density = 0.0
        tip.condim = 1
        tip.solimp = [self.impedance, self.impedance, 1e-6, 0.5, 2.0]
        self._has_contact = self._add_environment(spec)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        #: MuJoCo's F/T sensor between the flange and the payload (None without a payload): the controller reads it
        self.payload_reader = None if payload is None else PayloadReader(mujoco, self.model, int(robot.task_dim))
        self.ee_body = self.model.body(frame).id
        self.ee_geom = self.model.geom("ee_contact").id
        self.nq = int(self.model.nq)
        self._frictionless = getattr(self, "_contact_row", int(mujoco.mjtConstraint.mjCNSTR_CONTACT_FRICTIONLESS))
        self._scheduled_R = math.nan
        if self._has_contact:
            self._calibrate()

    # -- building
    def _add_environment(self, spec) -> bool:
        from ..environments.elastic import ElasticPlane, LinearSpring
        from ..environments.spatial import Table
        from ..environments.surfaces import ElasticSurface

        mujoco = self._mujoco
        env = self.environment
        if isinstance(env, LinearSpring):
            if env.dim not in (2, 3) or env.dim != self.robot.task_dim:
                raise ParameterError(
                    "a LinearSpring in MuJoCo acts on the position of the controlled frame (a 2- or 3-dimensional "
                    f"task space like the robot's); got a {env.dim}-dimensional spring for a "
                    f"{self.robot.task_dim}-dimensional task"
                )
            # a bilateral spring-damper h_e = K (x − x_r) + D ẋ on the controlled frame's origin:
            # a passive force MuJoCo evaluates at every integrator stage (see _spring_passive)
            self._spring = (np.asarray(env.stiffness), np.asarray(env.damping), np.asarray(env.rest_position))
            return False
        if getattr(env, "stateful", False):  # FrictionalContact: MuJoCo's friction on its surface (mujoco_surfaces)
            return add_friction(self, spec, env, self._add_environment)
        if isinstance(env, ElasticSurface):  # a sphere or a cylinder: MuJoCo's primitive geom
            return add_surface_geom(self, spec, env)
        if isinstance(env, (ElasticPlane, Table)):
            point = np.zeros(3)
            normal = np.zeros(3)
            point[: env.point.shape[0]] = env.point
            normal[: env.normal.shape[0]] = env.normal
            self._k_env, self._c_env = float(env.stiffness), float(env.damping)
        else:
            raise ParameterError(
                "the MuJoCo engine supports ElasticPlane, Table and LinearSpring environments and the surfaces "
                f"ElasticSphere and ElasticCylinder; got {type(env).__name__}"
            )
        g = spec.worldbody.add_geom()
        g.name = "environment"
        g.type = mujoco.mjtGeom.mjGEOM_PLANE
        g.size = [10.0, 10.0, 0.1]
        g.pos = point - self.radius * normal
        g.quat = quat_z_to(normal)  # plane normal = local z
        g.condim = 1
        g.solimp = [self.impedance, self.impedance, 1e-6, 0.5, 2.0]
        g.solref = [-1.0, -1.0]  # set by _calibrate
        return True

    def _calibrate(self) -> None:
        """Choose solref = (−k, −b) so MuJoCo's contact stiffness and damping at rest are the environment's.

        MuJoCo's soft contact at rest satisfies ``R f = a_ref = −b' v − k' r`` (R the regulariser,
        r the penetration, v its rate, k', b' from solref and the impedance d). The ratios
        ``−a_ref / (R r)`` and ``−a_ref / (R v)`` are read from the compiled model at a probe
        contact for unit solref values; both are linear in solref, which is then scaled so that
        ``f = k_env δ + c_env δ̇``.
        """
        mujoco = self._mujoco
        m = self.model
        gid = m.geom("environment").id
        probe = mujoco.MjData(m)
        probe.qpos[:] = 0.5 * (-1.0) ** np.arange(m.nq)  # away from the stretched-arm singularity
        mujoco.mj_forward(m, probe)
        depth = getattr(self, "_probe_depth", 0.0)  # a plane: 0 along its normal (local z); a sphere/cylinder: its radius
        nrm = probe.geom_xmat[gid].reshape(3, 3)[:, 0 if depth else 2]
        saved = m.geom_pos[gid].copy()
        m.geom_pos[gid] = probe.geom_xpos[self.ee_geom] - (depth + self.radius - 1e-3) * nrm

        def ratio(solref, use_velocity):
            m.geom_solref[gid] = m.geom_solref[self.ee_geom] = solref
            probe.qvel[:] = 0.0
            if use_velocity:
                probe.qvel[:] = np.linspace(0.3, -0.2, m.nv)
            mujoco.mj_forward(m, probe)
            rows = [i for i in range(probe.nefc) if probe.efc_type[i] == self._frictionless]  # a contact's normal row
            if not rows:  # pragma: no cover - the probe always touches
                raise RuntimeError("MuJoCo calibration found no contact")
            i = rows[0]
            self._last_R = float(probe.efc_R[i])
            den = probe.efc_vel[i] if use_velocity else probe.efc_pos[i]
            return -float(probe.efc_aref[i]) / (float(probe.efc_R[i]) * float(den))

        k_unit = ratio([-1.0, 0.0], False)
        R_probe = self._last_R
        b_unit = ratio([-1e-12, -1.0], True)
        m.geom_pos[gid] = saved
        # f/r = k_unit · solref_k · R_probe / R: R follows the configuration (R ∝ A(q)), so the
        # solref giving the environment's stiffness is rescheduled from R at every sample
        self._k_scale = self._k_env / (k_unit * R_probe)
        self._b_scale = self._c_env / (b_unit * R_probe) if self._c_env > 0 else 0.0
        self._gid = gid
        self._schedule(R_probe)
        self.contact_unit_stiffness = k_unit
        #: MuJoCo's apparent contact mass 1/R along the normal [kg] (at the probe posture).
        self.apparent_contact_mass = 1.0 / R_probe
        mujoco.mj_forward(m, self.data)

    def _schedule(self, R: float) -> None:
        # both geoms carry the same parameters (MuJoCo mixes the two geoms' solref/solimp)
        self._scheduled_R = R
        self.model.geom_solref[self._gid] = self.model.geom_solref[self.ee_geom] = [-self._k_scale * R, -self._b_scale * R]

    def _reschedule(self) -> None:
        """Solref for the current configuration, from R of the live contact (when there is one).

        Called before every MuJoCo step: the first frictionless-contact row is found with one
        vectorised comparison, and the model is written only when R has changed.
        """
        d = self.data
        ncon = d.ncon
        if ncon == 0:  # no contact, no contact row
            return
        if ncon == 1:  # the usual case: the contact's own row is the only candidate
            a = int(d.contact.efc_address[0])
            if a < 0 or d.efc_type[a] != self._frictionless:
                return
        else:
            rows = np.flatnonzero(d.efc_type[: d.nefc] == self._frictionless)
            if not rows.size:
                return
            a = int(rows[0])
        R = float(d.efc_R[a])
        if R != self._scheduled_R:
            self._schedule(R)

    # -- the spring environment
    def _spring_state(self, m: Any, d: Any) -> tuple[np.ndarray, np.ndarray, int]:
        """The controlled frame's origin and its velocity in the spring's m coordinates."""
        dim = self._spring[2].shape[0]
        v6 = np.zeros(6)
        self._mujoco.mj_objectVelocity(m, d, self._mujoco.mjtObj.mjOBJ_XBODY, self.ee_body, v6, 0)
        return d.xpos[self.ee_body][:dim], v6[3 : 3 + dim], dim

    def _spring_passive(self, m: Any, d: Any) -> None:
        """mjcb_passive: add ``J_Pᵀ (−h_e)`` of the spring to MuJoCo's passive forces (every RK4 stage)."""
        K, D, x_r = self._spring
        x, xd, dim = self._spring_state(m, d)
        jacp = np.zeros((3, m.nv))
        self._mujoco.mj_jacBody(m, d, jacp, None, self.ee_body)
        d.qfrc_passive[:] -= jacp[:dim].T @ (K @ (x - x_r) + D @ xd)

    # -- measuring
    def _pose_twist(self) -> tuple[np.ndarray, np.ndarray]:
        mujoco, m, d = self._mujoco, self.model, self.data
        p = d.xpos[self.ee_body].copy()
        v6 = np.zeros(6)
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_XBODY, self.ee_body, v6, 0)  # at the frame origin, like xpos
        twist = np.concatenate([v6[3:], v6[:3]])
        if self.task == "planar":
            return p[:2], twist[:2]
        if self.task == "position":
            return p, twist[:3]
        R = d.xmat[self.ee_body].reshape(3, 3)
        return np.concatenate([p, rotation_to_euler_xyz(R)]), twist

    def contact_wrench(self) -> np.ndarray:
        """h_e from MuJoCo's contacts on the end-effector sphere: ``[f; μ]`` about the frame origin, base frame
        (for a spring environment: ``K (x − x_r) + D ẋ`` at MuJoCo's current state)."""
        mujoco, m, d = self._mujoco, self.model, self.data
        if self._spring is not None:
            K, D, x_r = self._spring
            x, xd, _ = self._spring_state(m, d)
            return K @ (x - x_r) + D @ xd
        f_ee = np.zeros(3)
        mu_ee = np.zeros(3)
        o = d.xpos[self.ee_body]
        buf = np.zeros(6)
        for i in range(d.ncon):
            con = d.contact[i]
            if con.geom1 != self.ee_geom and con.geom2 != self.ee_geom:
                continue
            mujoco.mj_contactForce(m, d, i, buf)
            frame = con.frame.reshape(3, 3)
            f = frame.T @ buf[:3]  # force geom1 exerts on geom2... in world axes
            on_ee = f if con.geom2 == self.ee_geom else -f
            f_ee += on_ee
            if self.task != "pose":  # the moments are read only by a pose task
                continue
            r = con.pos - o
            mu_ee[0] += r[1] * on_ee[2] - r[2] * on_ee[1]  # r × f (np.cross costs 15 µs a call here)
            mu_ee[1] += r[2] * on_ee[0] - r[0] * on_ee[2]
            mu_ee[2] += r[0] * on_ee[1] - r[1] * on_ee[0]
        if self.task == "planar":
            return -f_ee[:2]
        if self.task == "position":
            return -f_ee
        return -np.concatenate([f_ee, mu_ee])

    def _sense(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """(h_e, reading): one array; with a payload, MuJoCo's F/T sensor (+ a spring's h_e, a joint force it misses)."""
        if self.payload_reader is None:
            h = self.contact_wrench()
            return h, h
        hm = self.payload_reader.read(self.data, np.zeros(self.model.nv) if k == 0 else None)  # at rest at the start
        h = self.contact_wrench()  # after the reader's mj_forward: the contacts of the state at t_k
        return h, (hm + h if self._spring is not None else hm)

    # -- running
    def run(
        self,
        controller: Controller,
        reference: ReferenceSignal,
        *,
        q0: Any,
        duration: float,
        qd0: Any = None,
        label: str = "",
        max_joint_speed: float = 50.0,
    ) -> SimulationResult:
        """The sampled loop with MuJoCo as the plant; returns the same log as ``simulate``."""
        mujoco, m, d = self._mujoco, self.model, self.data
        n = self.nq
        Ts = self.sample_time
        if abs(controller.sample_time - Ts) > 1e-15:
            raise ParameterError(f"controller.sample_time ({controller.sample_time}) must equal the plant's ({Ts})")
        mujoco.mj_resetData(m, d)
        d.qpos[:] = np.asarray(q0, dtype=float)
        d.qvel[:] = 0.0 if qd0 is None else np.asarray(qd0, dtype=float)
        mujoco.mj_forward(m, d)
        N = check_run_size(float(duration), Ts, n, int(self.robot.task_dim))  # before anything is allocated
        times = np.arange(N + 1) * Ts
        refs = np.ascontiguousarray(reference.sample(times), dtype=np.float64)
        mdim = refs.shape[1] // len(REFERENCE_FIELDS)
        logs = {k: np.full((N + 1, n), np.nan) for k in ("q", "qd", "torque")}
        logs.update({k: np.full((N + 1, mdim), np.nan) for k in ("x", "xd", "wrench", "wrench_measured")})
        previous = mujoco.get_mjcb_passive()
        if self._spring is not None:
            mujoco.set_mjcb_passive(self._spring_passive)  # global in MuJoCo: restored below
        try:
            status_k = self._loop(controller, reference, N, refs, logs, max_joint_speed)
        finally:
            mujoco.set_mjcb_passive(previous)
        meta = {
            "label": label,
            "engine": "mujoco",
            "robot": type(self.robot).__name__,
            "environment": self.environment.describe(),
            "controller": {"type": type(controller).__name__, **controller.gains()},
            "sample_time": Ts,
            "duration": float(duration),
            "substeps": self.substeps,
            "mujoco": self.describe(),
            "engine_notes": list(getattr(self, "notes", [])),  # e.g. how MuJoCo's friction differs (mujoco_surfaces)
        }
        # what the controller logged (a tank's energy, a search's events), as simulate keeps them
        events = [dict(e) for e in getattr(controller, "events", [])]
        if events:
            meta["events"] = events
        result = SimulationResult(t=times, reference=refs, label=label, metadata=meta, events=events,  # type: ignore[arg-type]
                                  signals=_controller_signals(controller, N + 1), **logs)
        if status_k is not None:
            raise SimulationDivergedError(
                f"MuJoCo run '{label or 'case'}' diverged at t = {status_k * Ts:.4f} s",
                time=status_k * Ts, step=status_k, cause="runaway", q=d.qpos.copy(),
            )
        return result

    def _loop(self, controller: Controller, reference: ReferenceSignal, N: int, refs: np.ndarray,
              logs: dict[str, np.ndarray], max_joint_speed: float) -> int | None:
        """The sampled loop; returns the sample at which it diverged, or None."""
        mujoco, m, d = self._mujoco, self.model, self.data
        Ts = self.sample_time
        mdim = refs.shape[1] // len(REFERENCE_FIELDS)
        mujoco.mj_forward(m, d)
        controller.reset(Measurement(d.qpos.copy(), d.qvel.copy(), self._sense(0)[1]), reference.at(0.0))
        status_k = None
        qpos, qvel, qfrc = d.qpos, d.qvel, d.qfrc_applied  # views of MuJoCo's arrays, fetched once
        for k in range(N + 1):
            q, qd = qpos.copy(), qvel.copy()
            x, xd = self._pose_twist()
            h, hm = self._sense(k)  # new arrays, not changed after: the measurement and the log share them
            row = refs[k]
            ref = Reference(*(row[i * mdim : (i + 1) * mdim] for i in range(len(REFERENCE_FIELDS))))
            u = np.asarray(controller.step(k * Ts, Measurement(q, qd, hm), ref), dtype=float)
            logs["q"][k], logs["qd"][k], logs["x"][k], logs["xd"][k] = q, qd, x, xd
            logs["wrench"][k], logs["wrench_measured"][k], logs["torque"][k] = h, hm, u
            if k == N:
                break
            qfrc[:] = u
            for _ in range(self.substeps):
                if self._has_contact:
                    self._reschedule()
                mujoco.mj_step(m, d)
            # diverged: a non-finite state (a NaN anywhere makes the sum NaN) or a runaway joint speed
            p_, v_ = qpos.tolist(), qvel.tolist()
            if not (math.isfinite(sum(p_) + sum(v_)) and max(v_) <= max_joint_speed and min(v_) >= -max_joint_speed):
                status_k = k
                break
        return status_k

    def describe(self) -> dict[str, Any]:
        """MuJoCo-side parameters (for metadata and reports)."""
        mujoco = self._mujoco
        out: dict[str, Any] = {
            "version": mujoco.__version__,
            "timestep": float(self.model.opt.timestep),
            "integrator": "RK4",
            "contact_radius": self.radius,
        }
        if self.payload_reader is not None:
            out["payload"] = self.payload_reader.describe()
        if self._has_contact:
            gid = self.model.geom("environment").id
            out.update(
                solref=self.model.geom_solref[gid].tolist(),
                solimp=self.model.geom_solimp[gid].tolist(),
                stiffness_per_unit_solref=self.contact_unit_stiffness,
                apparent_contact_mass=self.apparent_contact_mass,
            )
        return out


def simulate_mujoco(
    robot: Any, environment: Environment, controller: Controller, reference: ReferenceSignal, *, q0: Any,
    duration: float, qd0: Any = None, substeps: int = 4, contact_radius: float = 0.01, label: str = "",
) -> SimulationResult:
    """Like :func:`forcecontrol.sim.simulation.simulate`, with MuJoCo as the plant."""
    plant = MujocoPlant(
        robot, environment, sample_time=controller.sample_time, substeps=substeps, contact_radius=contact_radius
    )
    return plant.run(controller, reference, q0=q0, duration=duration, qd0=qd0, label=label)
