"""The sampled loop of admittance control (9.37) on a position-interface arm, against an elastic environment.

Linearised about an operating posture q* in contact with an elastic plane (outward normal ν,
stiffness k_e), in deviations, at the interface period T (the controller's own discrete
structure, :class:`~forcecontrol.controllers.admittance_position.PositionAdmittanceController`)::

    law       ζ_{k+1} = A_d ζ_k + G_d Pᵀ h_k             (9.37) exact ZOH at T
              x_t,k   = −P C_z ζ_{k+1}                   (P = I, or diag(R_d, R_d) for a pose)
    IK        q_c,k   = (I − J⁺_λ J) q_c,k−1 + J⁺_λ x_t,k  (damped least squares, J at q*)
    delay     u_k     = q_c,k−n_d                          (whole interface cycles)
    low-pass  y_k     = a u_k + (1 − a) y_{k−1}            (a = 1 without one)
              (velocity interface: v_c = (u_k − u_{k−1})/T, integrated into y at every inner step)
    servo     q̈ = W² (y − q) − 2 Z W q̇  [− B⁻¹ Jᵀ h]     per joint, y held over T (c2d, ZOH);
              the bracket only for the 'dynamic' realisation (contact not compensated)
    contact   h = k_e ν νᵀ J q                             (the force the arm exerts, (9.38))

Built with python-control (``control.ss``, ``c2d``, ``feedback``): the law+IK+delay+low-pass as
one discrete system from h to y, the servo (and contact) as the c2d of the continuous one from y
to h; the closed loop is their positive-feedback connection (more force retracts the compliant
frame). From it: the closed-loop poles (modes), the spectral radius, the stability limit in k_e
(bisection on the spectral radius = 1), the gain and phase margins of the loop broken at the
measured force along ν, and the equilibrium (closed form, checked against the DC gain).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.validate import positive_scalar
from ..errors import ParameterError

__all__ = ["ServoLoop", "ServoLoopReport", "admittance_servo_loop"]


@dataclass(frozen=True)
class ServoLoopReport:
    """What the analysis of one (controller, posture, k_e) says.

    Attributes:
        environment_stiffness: k_e [N/m].
        spectral_radius: max |z| of the closed-loop poles (< 1: stable).
        stable: spectral_radius < 1.
        poles: closed-loop discrete poles (complex).
        modes: ``(ω_n [rad/s], ζ)`` of each pole pair (from s = ln z / T), slowest first.
        gain_margin: factor by which the loop gain (∝ k_e for the ideal servo) may grow [-].
        phase_margin: [deg]; crossover frequencies ``wg``, ``wp`` [rad/s].
        force: equilibrium contact force along −ν [N] per metre of the desired frame's penetration.
        stability_limit: the largest k_e with a stable loop [N/m] (None if not asked).
    """

    environment_stiffness: float
    spectral_radius: float
    stable: bool
    poles: np.ndarray
    modes: list[tuple[float, float]]
    gain_margin: float
    phase_margin: float
    wg: float
    wp: float
    force: float
    stability_limit: float | None = None

    def as_dict(self) -> dict[str, Any]:
        return {
            "environment_stiffness": self.environment_stiffness, "spectral_radius": self.spectral_radius,
            "stable": self.stable, "modes": [list(m) for m in self.modes], "gain_margin": self.gain_margin,
            "phase_margin_deg": self.phase_margin, "gain_crossover": self.wg, "phase_crossover": self.wp,
            "force_per_penetration": self.force, "stability_limit": self.stability_limit,
        }


class ServoLoop:
    """The linearised sampled loop (see the module docstring), for any k_e.

    Args:
        inertia, damping, stiffness: M_t, K_Dt, K_Pt (m, m) of (9.37) in the law's coordinates.
        period: interface period T [s].
        bandwidth, damping_ratio: the servo's ω_s, ζ_s per joint (n,).
        delay: n_d whole cycles; lowpass: a of the command low-pass (1: none).
        J: the IK's task Jacobian at q* (m, n) (pose: the geometric one); ik_damping: λ [m].
        normal: outward normal ν of the plane in task coordinates (m,) (translational rows only).
        rotation: P (m, m) from the law's coordinates to the base frame (I for position tasks).
        tracking: ``"ideal"`` or ``"dynamic"``; B: B(q*) (n, n), needed for ``"dynamic"``.
    """

    def __init__(
        self, *, inertia: np.ndarray, damping: np.ndarray, stiffness: np.ndarray, period: float, bandwidth: Any,
        damping_ratio: Any, delay: int, lowpass: float, J: np.ndarray, ik_damping: float, normal: Any,
        rotation: np.ndarray | None = None, tracking: str = "ideal", B: np.ndarray | None = None,
        interface: str = "position", substeps: int = 1,
    ) -> None:
        from ..controllers.admittance_position import discretise_admittance

        self.T = positive_scalar("period", period, "s")
        self.M, self.D, self.K = (np.asarray(a, dtype=np.float64) for a in (inertia, damping, stiffness))
        self.m = self.M.shape[0]
        self.J = np.asarray(J, dtype=np.float64)
        self.n = self.J.shape[1]
        if self.J.shape[0] != self.m:
            raise ParameterError(f"J must have {self.m} rows like the admittance's task; got shape {self.J.shape}")
        self.w = np.broadcast_to(np.asarray(bandwidth, dtype=np.float64), (self.n,)).copy()
        self.z = np.broadcast_to(np.asarray(damping_ratio, dtype=np.float64), (self.n,)).copy()
        self.delay = int(delay)
        self.a = float(lowpass)
        self.lam = float(ik_damping)
        nu = np.asarray(normal, dtype=np.float64)
        if nu.shape != (self.m,) or np.linalg.norm(nu) == 0:
            raise ParameterError(f"normal must be a non-zero ({self.m},) vector in task coordinates; got {nu.tolist()}")
        self.nu = nu / np.linalg.norm(nu)
        self.P = np.eye(self.m) if rotation is None else np.asarray(rotation, dtype=np.float64)
        if tracking not in ("ideal", "dynamic"):
            raise ParameterError(f"tracking must be 'ideal' or 'dynamic'; got {tracking!r}")
        self.tracking = tracking
        if tracking == "dynamic" and B is None:
            raise ParameterError("the 'dynamic' servo realisation needs B(q*) (its stiffness is Λ ω²)")
        self.B = None if B is None else np.asarray(B, dtype=np.float64)
        if interface not in ("position", "velocity"):
            raise ParameterError(f"interface must be 'position' or 'velocity'; got {interface!r}")
        if interface == "velocity" and self.a < 1.0:
            raise ParameterError("a velocity interface has no command low-pass (lowpass must be 1)")
        self.interface = interface
        self.substeps = int(substeps)
        # IK map and the joints' coordinates: with the same servo on every joint, x = J q follows that servo
        # from J q_c, so the loop is written exactly in task coordinates (a redundant arm's null-space
        # motion, neither excited by the force nor seen in it, then leaves no pole at z = 1)
        Jp = self.J.T @ np.linalg.inv(self.J @ self.J.T + self.lam**2 * np.eye(self.m))
        Binv = None if self.B is None else np.linalg.inv(self.B)
        if np.allclose(self.w, self.w[0]) and np.allclose(self.z, self.z[0]):
            self._Jp, self._Jx = self.J @ Jp, np.eye(self.m)
            self._Binv = None if Binv is None else self.J @ Binv @ self.J.T
            self.w, self.z = np.full(self.m, self.w[0]), np.full(self.m, self.z[0])
            self.n = self.m
        else:
            self._Jp, self._Jx, self._Binv = Jp, self.J, Binv
        self.Ad, self.Gd, _, _ = discretise_admittance(self.M, self.D, self.K, self.T)
        self._ctrl = self._controller()

    # -- blocks
    def _controller(self) -> Any:
        """Law + IK + delay + low-pass: discrete ss from h_k (m) to y_k (n)."""
        import control  # type: ignore[import-untyped]

        m, n, d = self.m, self.n, self.delay
        J, Jp = self._Jx, self._Jp
        Cz = np.hstack([np.eye(m), np.zeros((m, m))])
        # x_t = −P Cz (Ad ζ + Gd Pᵀ h);   q_c = (I − Jp J) q_prev + Jp x_t
        Xz, Xh = -self.P @ Cz @ self.Ad, -self.P @ Cz @ self.Gd @ self.P.T
        Qq, Qz, Qh = np.eye(n) - Jp @ J, Jp @ Xz, Jp @ Xh
        lp = self.a < 1.0
        vel = self.interface == "velocity"
        d = d + 1 if vel else d  # a velocity interface also needs the command before: v_c = (q_c,k−d − q_c,k−d−1)/T
        ns = 2 * m + n + d * n + (n if lp else 0)
        A = np.zeros((ns, ns))
        Bm = np.zeros((ns, m))
        iq, ir, iy = 2 * m, 2 * m + n, 2 * m + n + d * n
        A[: 2 * m, : 2 * m] = self.Ad
        Bm[: 2 * m] = self.Gd @ self.P.T
        A[iq:ir, : 2 * m] = Qz
        A[iq:ir, iq:ir] = Qq
        Bm[iq:ir] = Qh
        # u_k: q_c,k−d (ring: slot 0 = q_c,k−1, ..., slot d−1 = q_c,k−d)
        if d:
            A[ir : ir + n, : 2 * m] = Qz
            A[ir : ir + n, iq:ir] = Qq
            Bm[ir : ir + n] = Qh
            for j in range(1, d):
                A[ir + j * n : ir + (j + 1) * n, ir + (j - 1) * n : ir + j * n] = np.eye(n)

        def command(j: int) -> tuple[np.ndarray, np.ndarray]:
            """(C, D) rows of q_c,k−j: the IK's output itself (j = 0) or ring slot j − 1."""
            C = np.zeros((n, ns))
            if j == 0:
                C[:, : 2 * m], C[:, iq:ir] = Qz, Qq
                return C, Qh.copy()
            C[:, ir + (j - 1) * n : ir + j * n] = np.eye(n)
            return C, np.zeros((n, m))

        if vel:  # outputs [a; b] = [q_c,k−d−1; q_c,k−d] (here d already counts the extra slot)
            (Ca, Da), (Cb, Db) = command(d), command(d - 1)
            return control.ss(A, Bm, np.vstack([Ca, Cb]), np.vstack([Da, Db]), self.T)
        Cu, Du = command(d)
        if lp:  # y_k = a u_k + (1 − a) y_{k−1}; state y_{k−1}
            a = self.a
            Cy = a * Cu
            Cy[:, iy:] += (1.0 - a) * np.eye(n)
            Dy = a * Du
            A[iy:] = Cy
            Bm[iy:] = Dy
        else:
            Cy, Dy = Cu, Du
        return control.ss(A, Bm, Cy, Dy, self.T)

    def _plant(self, k_e: float) -> Any:
        """Servo (and, 'dynamic', the contact on the joints): c2d (ZOH) of the continuous ss y → h."""
        import control  # type: ignore[import-untyped]

        n, m = self.n, self.m
        W2, ZW = np.diag(self.w**2), np.diag(2.0 * self.z * self.w)
        N = np.outer(self.nu, self.nu)
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -W2
        A[n:, n:] = -ZW
        if self.tracking == "dynamic":
            A[n:, :n] -= self._Binv @ self._Jx.T @ (k_e * N) @ self._Jx
        C = np.hstack([k_e * N @ self._Jx, np.zeros((m, n))])
        if self.interface == "velocity":
            return self._velocity_plant(A, C)
        Bc = np.zeros((2 * n, n))
        Bc[n:] = W2
        return control.c2d(control.ss(A, Bc, C, np.zeros((m, n))), self.T, method="zoh")

    def _velocity_plant(self, A: np.ndarray, C: np.ndarray) -> Any:
        """A velocity interface over one period, from inputs [a; b] = [q_c,k−d−1; q_c,k−d].

        The servo integrates v = (b − a)/T into its command at every inner step Ts = T/N
        (y_j = a + j Ts v, held over the step, v its feed-forward), as the simulation does: the
        period's map is the product of the N exact inner steps.
        """
        import control  # type: ignore[import-untyped]
        from scipy.linalg import expm  # type: ignore[import-untyped]

        n, m, N = self.n, self.m, max(self.substeps, 1)
        Ts = self.T / N
        Bc = np.zeros((2 * n, 2 * n))
        Bc[n:, :n] = np.diag(self.w**2)
        Bc[n:, n:] = np.diag(2.0 * self.z * self.w)
        big = np.zeros((4 * n, 4 * n))
        big[: 2 * n, : 2 * n], big[: 2 * n, 2 * n :] = A * Ts, Bc * Ts
        E = expm(big)
        Ai, By, Bv = E[: 2 * n, : 2 * n], E[: 2 * n, 2 * n : 3 * n], E[: 2 * n, 3 * n :]
        Mx, Ma, Mb = np.eye(2 * n), np.zeros((2 * n, n)), np.zeros((2 * n, n))
        for j in range(N):
            f = j / N
            Mx, Ma, Mb = Ai @ Mx, Ai @ Ma + By * (1.0 - f) - Bv / self.T, Ai @ Mb + By * f + Bv / self.T
        return control.ss(Mx, np.hstack([Ma, Mb]), C, np.zeros((m, 2 * n)), self.T)

    def closed_loop(self, k_e: float) -> Any:
        """The closed loop (positive feedback h = plant(ctrl(h))) as a discrete ss."""
        import control  # type: ignore[import-untyped]

        L = control.series(self._ctrl, self._plant(k_e))
        return control.feedback(L, np.eye(self.m), sign=1)

    def spectral_radius(self, k_e: float) -> float:
        """max |z| of the closed loop's poles."""
        return float(np.max(np.abs(self.closed_loop(k_e).poles())))

    def loop(self, k_e: float) -> Any:
        """The scalar loop broken at the measured force along ν, in negative-feedback form: −νᵀ P(z) C(z) ν."""
        import control  # type: ignore[import-untyped]

        L = control.series(self._ctrl, self._plant(k_e))
        nu = self.nu.reshape(-1, 1)
        return control.series(control.ss([], [], [], nu, self.T), L, control.ss([], [], [], -nu.T, self.T))

    def margins(self, k_e: float, points: int = 4000) -> tuple[float, float, float, float]:
        """Gain margin [-], phase margin [deg] and their frequencies wp, wg [rad/s] of :meth:`loop`.

        From the loop's frequency response on a logarithmic grid up to the Nyquist frequency π/T
        (state space, no transfer-function polynomials), crossings refined by linear interpolation.
        inf where the loop never crosses.
        """
        import control  # type: ignore[import-untyped]

        w = np.logspace(math.log10(1e-3 / self.T), math.log10(math.pi / self.T * (1 - 1e-9)), points)
        L = self.loop(k_e)
        resp = control.frequency_response(L, w)
        g = np.asarray(resp.complex).reshape(-1)
        mag = np.abs(g)
        ph = np.unwrap(np.angle(g))
        gm = wp = pm = wg = math.inf
        # phase crossover: phase = −180° (mod 360°), where the gain is largest
        k180 = (ph + math.pi) / (2 * math.pi)
        idx = np.nonzero(np.floor(k180[:-1]) != np.floor(k180[1:]))[0]
        for i in idx:
            target = (math.floor(max(k180[i], k180[i + 1])) * 2 - 1) * math.pi
            f = (target - ph[i]) / (ph[i + 1] - ph[i])
            mi = mag[i] + f * (mag[i + 1] - mag[i])
            if mi > 0 and 1.0 / mi < gm:
                gm, wp = 1.0 / mi, w[i] + f * (w[i + 1] - w[i])
        idx = np.nonzero((mag[:-1] - 1.0) * (mag[1:] - 1.0) <= 0)[0]
        for i in idx:
            f = (1.0 - mag[i]) / (mag[i + 1] - mag[i]) if mag[i + 1] != mag[i] else 0.0
            p = ph[i] + f * (ph[i + 1] - ph[i])
            m = math.degrees((p + math.pi) % (2 * math.pi))
            m = m - 360.0 if m > 180.0 else m
            if abs(m) < abs(pm):
                pm, wg = m, w[i] + f * (w[i + 1] - w[i])
        return gm, pm, wg, wp

    def equilibrium_force(self, k_e: float) -> float:
        """Contact force along −ν per metre of the desired frame's penetration δ_d (closed form).

        ``f / δ_d = k / (1 + k νᵀ P K⁻¹ Pᵀ ν [+ k νᵀ J W⁻² B⁻¹ Jᵀ ν])``: the environment, the
        admittance's spring and (dynamic servo) the servo's compliance in series; the IK's
        fixed point is exact (J full row rank), the ideal servo has unit DC gain.
        """
        try:
            c = float(self.nu @ self.P @ np.linalg.solve(self.K, self.P.T @ self.nu))
        except np.linalg.LinAlgError:
            raise ParameterError("the admittance's stiffness K is singular: the equilibrium force along the contact "
                                 "normal is undefined (give a positive definite stiffness)") from None
        if self.tracking == "dynamic":
            Cs = self._Jx @ np.diag(1.0 / self.w**2) @ self._Binv @ self._Jx.T
            c += float(self.nu @ Cs @ self.nu)
        return k_e / (1.0 + k_e * c)

    def stability_limit(self, k_start: float = 1e3, k_max: float = 1e9, rtol: float = 1e-4) -> float:
        """The largest k_e with spectral radius < 1 [N/m] (bisection); inf if stable up to ``k_max``."""
        if self.spectral_radius(1e-9 * k_start) >= 1.0:
            return 0.0
        lo, hi = 0.0, positive_scalar("k_start", k_start, "N/m")
        while self.spectral_radius(hi) < 1.0:
            lo, hi = hi, 2.0 * hi
            if hi > k_max:
                return math.inf
        while hi - lo > rtol * hi:
            mid = 0.5 * (lo + hi)
            if self.spectral_radius(mid) < 1.0:
                lo = mid
            else:
                hi = mid
        return lo

    def report(self, k_e: float, *, limit: bool = False) -> ServoLoopReport:
        """Poles, modes, margins and equilibrium at k_e (and the stability limit when asked)."""
        k_e = positive_scalar("environment_stiffness", k_e, "N/m")
        poles = np.asarray(self.closed_loop(k_e).poles())
        rho = float(np.max(np.abs(poles)))
        modes = []
        for p in poles:
            if p.imag < 0 or abs(p) < 1e-12:
                continue
            s = np.log(p) / self.T
            wn = float(abs(s))
            modes.append((wn, float(-s.real / wn) if wn > 0 else 1.0))
        modes.sort()
        gm, pm, wg, wp = self.margins(k_e)
        return ServoLoopReport(
            environment_stiffness=k_e, spectral_radius=rho, stable=rho < 1.0, poles=poles, modes=modes,
            gain_margin=float(gm), phase_margin=float(pm), wg=float(wg), wp=float(wp),
            force=self.equilibrium_force(k_e), stability_limit=self.stability_limit() if limit else None,
        )


def admittance_servo_loop(controller: Any, q: Any, normal: Any, *, tracking: str | None = None) -> ServoLoop:
    """The :class:`ServoLoop` of a PositionAdmittanceController at the posture q (n,) and plane normal ν.

    Args:
        controller: a :class:`~forcecontrol.controllers.admittance_position.PositionAdmittanceController`.
        q: the operating posture q* (n,) [rad].
        normal: the plane's outward normal ν in the base frame ((m,) for position tasks, (3,) for a pose task).
        tracking: override the servo's realisation (default: the servo's).

    Raises:
        ParameterError: an option the linear model does not describe (velocity feed-forward; the
            limits are assumed inactive).
    """
    from ..controllers.admittance_position import PositionAdmittanceController
    from ..spatial.closed_form import euler_xyz_to_rotation

    if not isinstance(controller, PositionAdmittanceController):
        raise ParameterError(f"controller must be a PositionAdmittanceController; got {type(controller).__name__}")
    servo = controller.servo
    if controller.velocity_feedforward:
        raise ParameterError("the sampled-loop analysis does not model velocity_feedforward = true")
    robot = controller.robot.robot
    q = np.asarray(q, dtype=np.float64)
    m = controller._m
    nu = np.asarray(normal, dtype=np.float64)
    P = None
    if controller.pose:
        if nu.shape == (3,):
            nu = np.concatenate([nu, np.zeros(3)])
        J = np.asarray(robot.spatial_jacobian(q))
        ref_phi = getattr(controller, "_analysis_orientation", None)
        R_d = robot.frame_pose(q)[0] if ref_phi is None else euler_xyz_to_rotation(ref_phi)
        P = np.zeros((6, 6))
        P[:3, :3], P[3:, 3:] = R_d, R_d
    else:
        J = np.asarray(robot.jacobian(q))
    if nu.shape != (m,):
        raise ParameterError(f"normal must have shape ({m},) (or (3,) for a pose task); got {np.asarray(normal).shape}")
    return ServoLoop(
        inertia=controller.inertia, damping=controller.damping, stiffness=controller.stiffness,
        period=controller.interface_period, bandwidth=servo.bandwidth, damping_ratio=servo.damping, delay=servo.delay,
        lowpass=servo.lowpass_gain(), J=J, ik_damping=controller.ik_damping, normal=nu, rotation=P,
        tracking=tracking or servo.tracking, B=np.asarray(robot.mass_matrix(q)), interface=servo.interface,
        substeps=controller.steps_per_cycle,
    )
