"""Compiled rigid-body dynamics of a serial chain of revolute/prismatic joints, from a Pinocchio model.

:func:`compile_tree` reads a :class:`~forcecontrol.robots.pinocchio.PinocchioRobot`'s model
(joint placements, axes, inertias, armature, gravity, the controlled frame's placement; the
robot's friction and rotor coupling) into plain arrays, and :func:`tree_terms` computes from them,
in one compiled call with no Python in between, what one integrator stage or one control sample
needs: the frame pose (R_e, o_e), the geometric Jacobian J (``LOCAL_WORLD_ALIGNED``, rows
``[ȯ_e; ω_e]``), J̇q̇ (classical acceleration at q̈ = 0), B (CRBA + armature + rotor coupling) and
``n = RNEA(q, q̇, 0) + F q̇``: the quantities of ``PinocchioRobot.spatial_terms``.

The algorithms, all in the world frame (spatial vectors about the world origin, linear part
first, as Pinocchio orders them):

* forward kinematics ``oMᵢ = oM_λ(i) · placementᵢ · joint(qᵢ)``; the joint's motion subspace
  ``Sᵢ = [pᵢ × zᵢ; zᵢ]`` (revolute about zᵢ through pᵢ) or ``[zᵢ; 0]`` (prismatic);
* velocities ``vᵢ = v_λ + Sᵢ q̇ᵢ`` and bias accelerations ``aᵢ = a_λ + (vᵢ × Sᵢ) q̇ᵢ``, ``a₀ = [−g; 0]``;
* RNEA: ``fᵢ = Iᵢ aᵢ + vᵢ ×* Iᵢ vᵢ``, ``τᵢ = Sᵢᵀ Σ_{k ≥ i} f_k``;
* CRBA: composite inertias ``I^cᵢ = Σ_{k ≥ i} I_k``, ``B_ij = Sⱼᵀ I^cᵢ Sᵢ`` (j ≤ i);
* the frame point's velocity ``v + ω × o_e`` and classical acceleration
  ``a + α × o_e + ω × (v + ω × o_e)``.

Supported: serial chains (joint i's parent is joint i − 1) of ``JointModelRX/RY/RZ``,
``JointModelRevoluteUnaligned``, ``JointModelPX/PY/PZ`` and ``JointModelPrismaticUnaligned``
(the Panda, the UR arms, the chapter's arm). Anything else (a branching tree, a spherical or
free-flyer joint, nq ≠ nv): :func:`tree_support` says why, and the caller keeps Pinocchio.
Validated against Pinocchio to 1e-10 on random states (tests/test_compiled_tree.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from ..errors import ParameterError

__all__ = ["CompiledTree", "compile_tree", "tree_support", "tree_terms", "tree_workspace", "chol_solve"]

_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}


@dataclass(frozen=True)
class CompiledTree:
    """The arrays :func:`tree_terms` reads (n joints).

    Attributes:
        kind: (n,) int, 0 revolute, 1 prismatic; axis: (n, 3) joint axis in the joint frame.
        Rp, pp: (n, 3, 3), (n, 3) joint placement in the parent joint's frame.
        mass, com, Ic: (n,), (n, 3), (n, 3, 3) body inertias in the joint frames (Ic about the com).
        armature: (n,); friction: (n, n) F; coupling: (n, n) rotor coupling (zeros if none).
        gravity: (3,) [m/s²]; fj: the controlled frame's joint (0-based); Rf, pf: its placement.
    """

    kind: np.ndarray
    axis: np.ndarray
    Rp: np.ndarray
    pp: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    Ic: np.ndarray
    armature: np.ndarray
    friction: np.ndarray
    coupling: np.ndarray
    gravity: np.ndarray
    fj: int
    Rf: np.ndarray
    pf: np.ndarray

    @property
    def n(self) -> int:
        return int(self.kind.shape[0])

    def arrays(self) -> tuple:
        """The positional arguments of :func:`tree_terms` before (q, q̇)."""
        return (self.kind, self.axis, self.Rp, self.pp, self.mass, self.com, self.Ic, self.armature,
                self.friction, self.coupling, self.gravity, self.fj, self.Rf, self.pf)

    def spatial_terms(self, q: Any, qd: Any):
        """(R_e, o_e, J (6, n), J̇q̇ (6,), B, n) like ``PinocchioRobot.spatial_terms`` (without g)."""
        n = self.n
        R, o, J, Jdq, B, nv = np.empty((3, 3)), np.empty(3), np.empty((6, n)), np.empty(6), np.empty((n, n)), np.empty(n)
        ws = tree_workspace(n)
        tree_terms(*self.arrays(), np.asarray(q, dtype=np.float64), np.asarray(qd, dtype=np.float64),
                   True, True, R, o, J, Jdq, B, nv, ws)
        return R, o, J, Jdq, B, nv


def _joint(shortname: str, joint: Any) -> tuple[int, tuple[float, float, float]] | None:
    if shortname in ("JointModelRX", "JointModelRY", "JointModelRZ"):
        return 0, _AXES[shortname[-1]]
    if shortname in ("JointModelPX", "JointModelPY", "JointModelPZ"):
        return 1, _AXES[shortname[-1]]
    if shortname == "JointModelRevoluteUnaligned":
        return 0, tuple(float(a) for a in np.asarray(joint.extract().axis))  # type: ignore[return-value]
    if shortname == "JointModelPrismaticUnaligned":
        return 1, tuple(float(a) for a in np.asarray(joint.extract().axis))  # type: ignore[return-value]
    return None


def tree_support(robot: Any) -> str | None:
    """None when :func:`compile_tree` supports ``robot``, else why not (one sentence)."""
    model = getattr(robot, "model", None)
    if model is None or not hasattr(model, "joints") or not hasattr(robot, "frame_id"):
        return f"{type(robot).__name__} is not a Pinocchio robot"
    if model.nq != model.nv:
        return "the model has joints with nq != nv"
    for i in range(1, model.njoints):
        if int(model.parents[i]) != i - 1:
            return f"joint {model.names[i]!r} does not follow joint {i - 1} (not a serial chain)"
        j = model.joints[i]
        if _joint(j.shortname(), j) is None:
            return f"joint {model.names[i]!r} is a {j.shortname()} (only revolute and prismatic joints are compiled)"
    if int(model.frames[robot.frame_id].parentJoint) < 1:
        return "the controlled frame is on the base"
    return None


def compile_tree(robot: Any) -> CompiledTree:
    """The compiled-dynamics arrays of a Pinocchio robot (its model, friction and rotor coupling).

    Raises:
        ParameterError: the robot is not a serial chain of revolute/prismatic joints (the reason named).
    """
    why = tree_support(robot)
    if why is not None:
        raise ParameterError(f"compiled rigid-body dynamics need a serial revolute/prismatic chain: {why}")
    model = robot.model
    n = int(model.nv)
    kind = np.empty(n, dtype=np.int64)
    axis, Rp, pp = np.empty((n, 3)), np.empty((n, 3, 3)), np.empty((n, 3))
    mass, com, Ic = np.empty(n), np.empty((n, 3)), np.empty((n, 3, 3))
    for i in range(1, n + 1):
        j = model.joints[i]
        k, a = _joint(j.shortname(), j)  # type: ignore[misc]
        kind[i - 1] = k
        a = np.array(a)
        axis[i - 1] = a / np.linalg.norm(a)
        M = model.jointPlacements[i]
        Rp[i - 1], pp[i - 1] = M.rotation, M.translation
        Y = model.inertias[i]
        mass[i - 1], com[i - 1], Ic[i - 1] = Y.mass, Y.lever, Y.inertia
    f = model.frames[robot.frame_id]
    coupling = np.zeros((n, n)) if robot.rotor_coupling is None else np.array(robot.rotor_coupling, dtype=np.float64)
    return CompiledTree(
        kind, axis, Rp, pp, mass, com, Ic, np.array(model.armature, dtype=np.float64),
        np.array(robot.friction, dtype=np.float64), coupling, np.array(model.gravity.linear, dtype=np.float64),
        int(f.parentJoint) - 1, np.array(f.placement.rotation), np.array(f.placement.translation),
    )


def tree_workspace(n: int) -> np.ndarray:
    """Scratch memory for :func:`tree_terms` ((n + 1) rows of 64)."""
    return np.empty((n + 1, 64))


@njit(cache=True, inline="always")
def _rot(a0, a1, a2, q):  # pragma: no cover - compiled
    """Rotation by angle q about the unit axis a (Rodrigues)."""
    c, s = math.cos(q), math.sin(q)
    t = 1.0 - c
    return (t * a0 * a0 + c, t * a0 * a1 - s * a2, t * a0 * a2 + s * a1,
            t * a0 * a1 + s * a2, t * a1 * a1 + c, t * a1 * a2 - s * a0,
            t * a0 * a2 - s * a1, t * a1 * a2 + s * a0, t * a2 * a2 + c)


@njit(cache=True)
def tree_terms(kind, axis, Rp, pp, mass, com, Ic, armature, friction, coupling, gravity, fj, Rf, pf,
               q, qd, want_B, want_jdq, R_e, o_e, J, Jdq, B, nv, ws):  # pragma: no cover - compiled
    """Fill R_e (3, 3), o_e (3,), J (6, n), J̇q̇ (6,), B (n, n) and n = RNEA(q, q̇, 0) + F q̇ (n,).

    ``want_B`` false skips the CRBA (B untouched); ``want_jdq`` false skips J̇q̇. ``ws`` from
    :func:`tree_workspace`. Row layout of ``ws[i]`` (body i, world frame): 0-8 R, 9-11 p,
    12-17 S, 18-23 v, 24-29 a, 30-35 f, 36-56 the composite inertia's upper triangle (unused here).
    """
    n = kind.shape[0]
    # the base: R = I, p = 0, v = 0, a = [-g; 0]
    b = ws[n]
    for k in range(9):
        b[k] = 0.0
    b[0] = 1.0
    b[4] = 1.0
    b[8] = 1.0
    for k in range(9, 30):
        b[k] = 0.0
    b[24], b[25], b[26] = -gravity[0], -gravity[1], -gravity[2]
    par = b
    for i in range(n):
        w = ws[i]
        # oM_parent * placement
        A = np.empty(9)
        for r in range(3):
            for c in range(3):
                A[3 * r + c] = par[3 * r] * Rp[i, 0, c] + par[3 * r + 1] * Rp[i, 1, c] + par[3 * r + 2] * Rp[i, 2, c]
        px = par[9] + par[0] * pp[i, 0] + par[1] * pp[i, 1] + par[2] * pp[i, 2]
        py = par[10] + par[3] * pp[i, 0] + par[4] * pp[i, 1] + par[5] * pp[i, 2]
        pz = par[11] + par[6] * pp[i, 0] + par[7] * pp[i, 1] + par[8] * pp[i, 2]
        a0, a1, a2 = axis[i, 0], axis[i, 1], axis[i, 2]
        zx = A[0] * a0 + A[1] * a1 + A[2] * a2
        zy = A[3] * a0 + A[4] * a1 + A[5] * a2
        zz = A[6] * a0 + A[7] * a1 + A[8] * a2
        if kind[i] == 0:
            r00, r01, r02, r10, r11, r12, r20, r21, r22 = _rot(a0, a1, a2, q[i])
            for r in range(3):
                x0, x1, x2 = A[3 * r], A[3 * r + 1], A[3 * r + 2]
                w[3 * r] = x0 * r00 + x1 * r10 + x2 * r20
                w[3 * r + 1] = x0 * r01 + x1 * r11 + x2 * r21
                w[3 * r + 2] = x0 * r02 + x1 * r12 + x2 * r22
            w[9], w[10], w[11] = px, py, pz
            # S = [p x z; z]
            w[12], w[13], w[14] = py * zz - pz * zy, pz * zx - px * zz, px * zy - py * zx
            w[15], w[16], w[17] = zx, zy, zz
        else:
            for k in range(9):
                w[k] = A[k]
            w[9], w[10], w[11] = px + zx * q[i], py + zy * q[i], pz + zz * q[i]
            w[12], w[13], w[14] = zx, zy, zz
            w[15], w[16], w[17] = 0.0, 0.0, 0.0
        qi = qd[i]
        for k in range(6):
            w[18 + k] = par[18 + k] + w[12 + k] * qi
        # bias acceleration a = a_parent + (v x S) q̇: [ω×S_v + v×S_ω; ω×S_ω]
        vx, vy, vz, ox, oy, oz = w[18], w[19], w[20], w[21], w[22], w[23]
        sx, sy, sz, tx, ty, tz = w[12], w[13], w[14], w[15], w[16], w[17]
        w[24] = par[24] + (oy * sz - oz * sy + vy * tz - vz * ty) * qi
        w[25] = par[25] + (oz * sx - ox * sz + vz * tx - vx * tz) * qi
        w[26] = par[26] + (ox * sy - oy * sx + vx * ty - vy * tx) * qi
        w[27] = par[27] + (oy * tz - oz * ty) * qi
        w[28] = par[28] + (oz * tx - ox * tz) * qi
        w[29] = par[29] + (ox * ty - oy * tx) * qi
        par = w
    # RNEA forces f = I a + v ×* I v, with I at the world origin (com c, inertia about c in world axes)
    for i in range(n):
        w = ws[i]
        m = mass[i]
        cx = w[9] + w[0] * com[i, 0] + w[1] * com[i, 1] + w[2] * com[i, 2]
        cy = w[10] + w[3] * com[i, 0] + w[4] * com[i, 1] + w[5] * com[i, 2]
        cz = w[11] + w[6] * com[i, 0] + w[7] * com[i, 1] + w[8] * com[i, 2]
        # I_cw = R Ic Rᵀ (stored in w[36:45])
        for r in range(3):
            for c in range(3):
                s = 0.0
                for k in range(3):
                    s += w[3 * r + k] * (Ic[i, k, 0] * w[3 * c] + Ic[i, k, 1] * w[3 * c + 1] + Ic[i, k, 2] * w[3 * c + 2])
                w[36 + 3 * r + c] = s
        w[45], w[46], w[47] = cx, cy, cz
        # momentum of v, then of a
        vx, vy, vz, ox, oy, oz = w[18], w[19], w[20], w[21], w[22], w[23]
        lx = m * (vx + oy * cz - oz * cy)
        ly = m * (vy + oz * cx - ox * cz)
        lz = m * (vz + ox * cy - oy * cx)
        kx = cy * lz - cz * ly + w[36] * ox + w[37] * oy + w[38] * oz
        ky = cz * lx - cx * lz + w[39] * ox + w[40] * oy + w[41] * oz
        kz = cx * ly - cy * lx + w[42] * ox + w[43] * oy + w[44] * oz
        ax, ay, az, bx, by, bz = w[24], w[25], w[26], w[27], w[28], w[29]
        fx = m * (ax + by * cz - bz * cy)
        fy = m * (ay + bz * cx - bx * cz)
        fz = m * (az + bx * cy - by * cx)
        nx = cy * fz - cz * fy + w[36] * bx + w[37] * by + w[38] * bz
        ny = cz * fx - cx * fz + w[39] * bx + w[40] * by + w[41] * bz
        nz = cx * fy - cy * fx + w[42] * bx + w[43] * by + w[44] * bz
        # v ×* h = [ω × l; ω × k + v × l]
        w[30] = fx + oy * lz - oz * ly
        w[31] = fy + oz * lx - ox * lz
        w[32] = fz + ox * ly - oy * lx
        w[33] = nx + oy * kz - oz * ky + vy * lz - vz * ly
        w[34] = ny + oz * kx - ox * kz + vz * lx - vx * lz
        w[35] = nz + ox * ky - oy * kx + vx * ly - vy * lx
    # backward pass: τ_i = S_iᵀ Σ_{k≥i} f_k
    for i in range(n - 1, -1, -1):
        w = ws[i]
        if i < n - 1:
            c = ws[i + 1]
            for k in range(6):
                w[30 + k] += c[30 + k]
        s = 0.0
        for k in range(6):
            s += w[12 + k] * w[30 + k]
        nv[i] = s
    for i in range(n):
        s = 0.0
        for k in range(n):
            s += friction[i, k] * qd[k]
        nv[i] += s
    # the controlled frame
    w = ws[fj]
    for r in range(3):
        for c in range(3):
            R_e[r, c] = w[3 * r] * Rf[0, c] + w[3 * r + 1] * Rf[1, c] + w[3 * r + 2] * Rf[2, c]
    ex = w[9] + w[0] * pf[0] + w[1] * pf[1] + w[2] * pf[2]
    ey = w[10] + w[3] * pf[0] + w[4] * pf[1] + w[5] * pf[2]
    ez = w[11] + w[6] * pf[0] + w[7] * pf[1] + w[8] * pf[2]
    o_e[0], o_e[1], o_e[2] = ex, ey, ez
    for j in range(n):
        if j <= fj:
            s = ws[j]
            tx, ty, tz = s[15], s[16], s[17]
            J[0, j] = s[12] + ty * ez - tz * ey
            J[1, j] = s[13] + tz * ex - tx * ez
            J[2, j] = s[14] + tx * ey - ty * ex
            J[3, j], J[4, j], J[5, j] = tx, ty, tz
        else:
            for k in range(6):
                J[k, j] = 0.0
    if want_jdq:
        vx, vy, vz, ox, oy, oz = w[18], w[19], w[20], w[21], w[22], w[23]
        ax, ay, az = w[24] + gravity[0], w[25] + gravity[1], w[26] + gravity[2]
        bx, by, bz = w[27], w[28], w[29]
        px_ = vx + oy * ez - oz * ey  # the point's velocity
        py_ = vy + oz * ex - ox * ez
        pz_ = vz + ox * ey - oy * ex
        Jdq[0] = ax + by * ez - bz * ey + oy * pz_ - oz * py_
        Jdq[1] = ay + bz * ex - bx * ez + oz * px_ - ox * pz_
        Jdq[2] = az + bx * ey - by * ex + ox * py_ - oy * px_
        Jdq[3], Jdq[4], Jdq[5] = bx, by, bz
    if want_B:
        _crba(mass, armature, coupling, ws, B)


@njit(cache=True)
def _crba(mass, armature, coupling, ws, B):  # pragma: no cover - compiled
    """B_ij = S_jᵀ I^c_i S_i (j ≤ i) with the composite inertias I^c_i = Σ_{k≥i} I_k (6 × 6, world origin)."""
    n = mass.shape[0]
    Icomp = np.zeros((6, 6))
    F = np.empty(6)
    for i in range(n - 1, -1, -1):
        w = ws[i]
        m = mass[i]
        cx, cy, cz = w[45], w[46], w[47]
        # I = [[m E, −m[c]], [m[c], I_cw − m[c][c]]]
        Icomp[0, 0] += m
        Icomp[1, 1] += m
        Icomp[2, 2] += m
        Icomp[0, 4] += m * cz
        Icomp[0, 5] -= m * cy
        Icomp[1, 3] -= m * cz
        Icomp[1, 5] += m * cx
        Icomp[2, 3] += m * cy
        Icomp[2, 4] -= m * cx
        Icomp[4, 0] += m * cz
        Icomp[5, 0] -= m * cy
        Icomp[3, 1] -= m * cz
        Icomp[5, 1] += m * cx
        Icomp[3, 2] += m * cy
        Icomp[4, 2] -= m * cx
        # I_cw − m [c][c] = I_cw + m (|c|² E − c cᵀ)
        cc = cx * cx + cy * cy + cz * cz
        Icomp[3, 3] += w[36] + m * (cc - cx * cx)
        Icomp[4, 4] += w[40] + m * (cc - cy * cy)
        Icomp[5, 5] += w[44] + m * (cc - cz * cz)
        Icomp[3, 4] += w[37] - m * cx * cy
        Icomp[4, 3] += w[39] - m * cx * cy
        Icomp[3, 5] += w[38] - m * cx * cz
        Icomp[5, 3] += w[42] - m * cx * cz
        Icomp[4, 5] += w[41] - m * cy * cz
        Icomp[5, 4] += w[43] - m * cy * cz
        for r in range(6):
            s = 0.0
            for k in range(6):
                s += Icomp[r, k] * w[12 + k]
            F[r] = s
        for j in range(i + 1):
            sj = ws[j]
            s = 0.0
            for k in range(6):
                s += sj[12 + k] * F[k]
            B[i, j] = s
            B[j, i] = s
    for i in range(n):
        B[i, i] += armature[i]
        for j in range(n):
            B[i, j] += coupling[i, j]


@njit(cache=True)
def chol_solve(A, b, L, out):  # pragma: no cover - compiled
    """Solve A x = b for SPD A (n, n) by Cholesky into ``out``; ``L`` scratch (n, n). False if A is not SPD."""
    n = b.shape[0]
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > 0.0:
            return False
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / d
    for i in range(n):
        s = b[i]
        for k in range(i):
            s -= L[i, k] * out[k]
        out[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):
        s = out[i]
        for k in range(i + 1, n):
            s -= L[k, i] * out[k]
        out[i] = s / L[i, i]
    return True
