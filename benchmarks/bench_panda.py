"""Speed of the 6-D controllers on the Panda, as ratios against baselines run in the same process.

Measures:

* one ``SpatialImpedanceController.step`` (6-D impedance (9.35) on the desired frame, XYZ Euler
  error, null-space posture, variable damped least squares, ``Jᵀ h_e``) called from Python;
* the baseline: the same law hand-written as a minimal Pinocchio + NumPy step (one
  ``computeAllTerms``, frame Jacobian and classical acceleration, Euler error, T⁻¹, J_Ad, the
  J̇_Ad q̇ term for a constant desired frame, DLS check with ``eigvalsh``, null-space posture,
  ``B y + n + Jᵀ h``), no checks, no abstractions. Target: controller / baseline <= 1.2;
* a 1 s closed loop at 1 ms (Panda, constant external wrench, ``simulate`` with the Python
  engine, RK4, one substep) against real time. Target: faster than real time.

* the built-in engine's closed loop on the three Panda scenarios (impedance-like admittance,
  hybrid on a table, hybrid on a 6-D spring) against a plain loop a user would write around the
  same controller object: Pinocchio's ``aba`` for the plant, the environment's ``wrench``, RK4
  with the same substeps, logs of q, q̇ and the wrench. Target (issue 14): engine / plain <= 0.5.

Run: ``python benchmarks/bench_panda.py`` (prints a table and the ratios; asserts nothing).
"""

from __future__ import annotations

import math
import statistics
import time

import numpy as np
import pinocchio as pin

from forcecontrol.controllers.base import Measurement, Reference
from forcecontrol.controllers.spatial import SpatialImpedanceController
from forcecontrol.environments.spatial import ConstantWrench
from forcecontrol.robots.pinocchio import PANDA_READY, panda
from forcecontrol.sim.simulation import simulate
from forcecontrol.spatial import rotation_to_euler_xyz
from forcecontrol.trajectories import Setpoint

MD = np.diag([2.0, 2.0, 2.0, 0.05, 0.05, 0.05])
KP = np.diag([400.0, 400.0, 400.0, 10.0, 10.0, 10.0])
KD = np.diag(2 * 0.7 * np.sqrt(np.diag(MD) * np.diag(KP)))


def minimal_step_factory(model, fid, o_d, R_d, q_n):
    """A hand-written minimal step of the same law for a constant desired frame."""
    data = model.createData()
    Md_inv = np.linalg.inv(MD)
    LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    RdT = R_d.T

    def step(q, qd, h):
        pin.computeAllTerms(model, data, q, qd)
        pin.updateFramePlacement(model, data, fid)
        M = data.oMf[fid]
        J = pin.getFrameJacobian(model, data, fid, LWA)
        a0 = pin.getFrameClassicalAcceleration(model, data, fid, LWA).vector
        R_de = RdT @ M.rotation
        c2 = math.hypot(R_de[0, 0], R_de[0, 1])
        p1, p2, p3 = math.atan2(-R_de[1, 2], R_de[2, 2]), math.atan2(R_de[0, 2], c2), math.atan2(-R_de[0, 1], R_de[0, 0])
        c1, s1, s2 = math.cos(p1), math.sin(p1), math.sin(p2)
        Ti = np.array([[1.0, s1 * s2 / c2, -c1 * s2 / c2], [0.0, c1, s1], [0.0, -s1 / c2, c1 / c2]])
        JAd = np.vstack([RdT @ J[:3], Ti @ (RdT @ J[3:])])
        x = np.concatenate([-(RdT @ (M.translation - o_d)), [-p1, -p2, -p3]])
        xd = -JAd @ qd
        phid = -xd[3:]
        d1, d2 = phid[0], phid[1]
        Td = np.array([[0.0, 0.0, c2 * d2], [0.0, -s1 * d1, -c1 * c2 * d1 + s1 * s2 * d2],
                       [0.0, c1 * d1, -s1 * c2 * d1 - c1 * s2 * d2]])
        cb = np.concatenate([-(RdT @ a0[:3]), -(Ti @ (RdT @ a0[3:] - Td @ phid))])
        h_d = np.concatenate([RdT @ h[:3], RdT @ h[3:]])
        r = cb - Md_inv @ (h_d - KD @ xd - KP @ x)
        JJt = JAd @ JAd.T
        s = np.linalg.eigvalsh(JJt)[0]
        if s < 0.05**2:
            JJt += 0.05**2 * (1 - s / 0.05**2) * np.eye(6)
        y0 = 25.0 * (q_n - q) - 10.0 * qd
        y = y0 + JAd.T @ np.linalg.solve(JJt, r - JAd @ y0)
        return data.M @ y + data.nle + model.damping * qd + J.T @ h

    return step


def _time(f, n=2000, repeats=7) -> float:
    for _ in range(200):
        f()
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(n):
            f()
        out.append((time.perf_counter() - t0) / n)
    return statistics.median(out)


def main() -> dict[str, float]:
    robot = panda()
    q0 = PANDA_READY
    R, p = robot.frame_pose(q0)
    x0 = np.concatenate([p, rotation_to_euler_xyz(R)])
    ctrl = SpatialImpedanceController(robot, MD, KD, KP, posture=q0)
    q = q0 + 0.05
    qd = np.full(7, 0.1)
    h = np.array([3.0, -2.0, 1.0, 0.1, 0.2, -0.1])
    meas, ref = Measurement(q, qd, h), Reference.setpoint(x0)
    minimal = minimal_step_factory(robot.model, robot.frame_id, p, R, q0)
    u_c, u_m = ctrl.step(0.0, meas, ref), minimal(q, qd, h)
    agree = float(np.max(np.abs(u_c - u_m)))

    t_ctrl = _time(lambda: ctrl.step(0.0, meas, ref))
    t_min = _time(lambda: minimal(q, qd, h))

    env = ConstantWrench(h)
    sim = lambda: simulate(robot, env, ctrl, Setpoint(x0), q0=q0, duration=1.0, substeps=1, engine="python")  # noqa: E731
    sim()
    walls = []
    for _ in range(3):
        t0 = time.perf_counter()
        sim()
        walls.append(time.perf_counter() - t0)
    wall = statistics.median(walls)

    rows = {
        "controller step [us]": t_ctrl * 1e6,
        "hand-written minimal Pinocchio step [us]": t_min * 1e6,
        "ratio controller / minimal (target <= 1.2)": t_ctrl / t_min,
        "torque agreement |u_ctrl - u_min|_inf [N m]": agree,
        "1 s closed loop at 1 ms, wall time [s]": wall,
        "real-time factor (target > 1)": 1.0 / wall,
    }
    for k, v in rows.items():
        print(f"{k:<48} {v:10.4g}")
    return rows


def plain_loop(robot, env, ctrl, ref_sig, q0, duration, nsub):
    """A plain Python + Pinocchio closed loop around the same controller (the baseline)."""
    from forcecontrol.controllers.base import REFERENCE_FIELDS

    model, data, fid = robot.model, robot.model.createData(), robot.frame_id
    lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    rows = robot._rows
    F = np.diag(robot.friction)
    Ts = ctrl.sample_time
    N = int(round(duration / Ts))
    refs = ref_sig.sample(np.arange(N + 1) * Ts)
    m = refs.shape[1] // len(REFERENCE_FIELDS)

    def x_of(q, qd):
        pin.forwardKinematics(model, data, q, qd)
        pin.updateFramePlacement(model, data, fid)
        M = data.oMf[fid]
        v = pin.getFrameVelocity(model, data, fid, lwa).vector[rows]
        if m == 6:
            return np.concatenate([M.translation, rotation_to_euler_xyz(M.rotation)]), v
        return M.translation[rows].copy(), v

    def acc(q, qd, u):
        h = env.wrench(*x_of(q, qd))
        J = pin.computeFrameJacobian(model, data, q, fid, lwa)[rows]
        return pin.aba(model, data, q, qd, u - F * qd - J.T @ h)

    q, qd = q0.copy(), np.zeros(robot.nq)
    log_q, log_h = np.empty((N + 1, robot.nq)), np.empty((N + 1, m))
    h = env.wrench(*x_of(q, qd))
    ctrl.reset(Measurement(q, qd, h), ref_sig.at(0.0))
    dt = Ts / nsub
    for k in range(N + 1):
        h = env.wrench(*x_of(q, qd))
        row = refs[k]
        u = ctrl.step(k * Ts, Measurement(q, qd, h), Reference(*(row[i * m:(i + 1) * m] for i in range(6))))
        log_q[k], log_h[k] = q, h
        for _ in range(nsub):
            a1 = acc(q, qd, u)
            v2 = qd + 0.5 * dt * a1
            a2 = acc(q + 0.5 * dt * qd, v2, u)
            v3 = qd + 0.5 * dt * a2
            a3 = acc(q + 0.5 * dt * v2, v3, u)
            v4 = qd + dt * a3
            a4 = acc(q + dt * v3, v4, u)
            q = q + dt / 6.0 * (qd + 2 * v2 + 2 * v3 + v4)
            qd = qd + dt / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)
    return log_q, log_h


def loop_ratios(duration: float = 0.5) -> dict[str, float]:
    """Built-in engine vs the plain loop on the Panda scenarios (same controller object)."""
    from forcecontrol.scenarios import build_case, load_scenario

    out = {}
    for name in ("panda-admittance-contact", "panda-table-line", "panda-peg-in-hole"):
        parts = build_case(load_scenario(name).cases[0])
        robot, env, ctrl, ref, q0 = parts["robot"], parts["environment"], parts["controller"], parts["reference"], parts["q0"]
        res = simulate(robot, env, ctrl, ref, q0=q0, duration=duration, engine="python")
        nsub = res.metadata["substeps"]
        lq, _ = plain_loop(robot, env, ctrl, ref, q0, duration, nsub)
        agree = float(np.max(np.abs(lq - res.q)))
        te, tp = [], []
        for _ in range(3):
            t0 = time.perf_counter()
            simulate(robot, env, ctrl, ref, q0=q0, duration=duration, engine="python")
            te.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            plain_loop(robot, env, ctrl, ref, q0, duration, nsub)
            tp.append(time.perf_counter() - t0)
        n = int(round(duration / ctrl.sample_time)) + 1
        e, p = statistics.median(te) / n * 1e6, statistics.median(tp) / n * 1e6
        print(f"{name:<26} engine {e:7.1f} us/step  plain {p:7.1f} us/step  ratio {e / p:5.2f}  |dq| {agree:.1e}")
        out[name] = e / p
    return out


if __name__ == "__main__":
    main()
    loop_ratios()
