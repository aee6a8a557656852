"""Direct force control on an elastic environment: linearised loops, poles, sampling, gain design.

Per axis, with M_d, K_D, K_P, C_F and K diagonal (the chapter's assumption for (9.42)–(9.49))
and the shared inner loop cancelling the arm's dynamics, each scheme is a small linear system.
States ``[x, ẋ, ξ]`` (ξ, the integral action of (9.43) [m], only with K_I > 0), inputs
``[f_d, x_d, x_r]``, outputs ``[f_e, x]`` with ``f_e = k (x − x_r)`` (9.38):

* inner position loop (9.40)–(9.43)::

      m ẍ = −k_D ẋ + k_P (k_F (f_d − f_e) + ξ − x),      ξ̇ = k_I (f_d − f_e)

  characteristic polynomial (corrected (9.42), misprint 7)
  ``m s³ + k_D s² + k_P (1 + k_F k) s + k_P k k_I``; f_e/f_d has the zero ``−k_I/k_F``;
* inner velocity loop (9.45)–(9.47): ``m ẍ = −k_D ẋ + k_P k_F (f_d − f_e)``,
  polynomial ``m s² + k_D s + k_P k_F k``;
* parallel (9.48): ``m ẍ = −k_D ẋ + k_P (x_d − x + k_F (f_d − f_e) + ξ)``, same polynomial as
  the inner position loop.

Poles, zeros and damping come from python-control (``control.poles``, ``control.zeros``,
``control.damp``). The sampled-data model (:meth:`ForceLoopAxis.sampled`) follows the simulator:
the controller reads x, ẋ and f_e at t_k, computes x_F with ξ_k, then ξ_{k+1} = ξ_k + Ts k_I
(f_d − f_k) (forward Euler); the torque is held, so with exact inverse dynamics the axis is a
double integrator ``ẍ = a_k`` over the sample; if the arm's operational mass ``m_x`` along the
axis is given, the contact force's change within the sample (not compensated, since the law
adds ``Jᵀ h_e(t_k)``) enters as ``ẍ = a_k + (f_k − k (x − x_r)) / m_x``. The plant is
discretised exactly (zero-order hold, in closed form; the same as
``control.sample_system(..., method="zoh")``, tested).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np

from ..core.lazy import lazy_import
from ..core.validate import nonnegative_scalar, positive_scalar
from ..errors import DimensionError, DriftWarning, ParameterError

control = lazy_import("control")  # python-control costs 1-5 s to import: loaded on first use

__all__ = ["SCHEMES", "ForceLoopAxis"]

Scheme = Literal["inner-position", "inner-velocity", "parallel"]
#: the three schemes of Sect. 9.4, by name.
SCHEMES: tuple[str, ...] = ("inner-position", "inner-velocity", "parallel")

_INPUTS = ["f_d", "x_d", "x_r"]
_OUTPUTS = ["f_e", "x"]


def _scheme(value: Any) -> str:
    if value not in SCHEMES:
        raise ParameterError(f"scheme must be one of {list(SCHEMES)}; got {value!r}")
    return str(value)


@dataclass(frozen=True)
class ForceLoopAxis:
    """The linearised closed loop of one operational axis under direct force control.

    Attributes:
        scheme: ``"inner-position"`` (Fig. 9.6), ``"inner-velocity"`` (Fig. 9.7) or
            ``"parallel"`` (Fig. 9.8).
        inertia: m_d [kg], > 0; damping: k_D [N s/m], >= 0; stiffness: k_P [N/m], > 0.
        force_gain: k_F [m/N], >= 0; integral_gain: k_I [m/(N s)], >= 0 (ignored by the
            inner velocity loop, whose C_F is purely proportional (9.46)).
        environment_stiffness: k along the axis [N/m], >= 0 (0: free axis).
        integrator_start: how the simulated controller presets ξ₀ and meets a change of f_d
            (``"hold"``, ``"tip"`` or ``"zero"``, as ``integrator_start`` of the force
            controllers, :data:`~forcecontrol.controllers.force.INTEGRATOR_STARTS`), used by
            :meth:`response`; None: the controllers' defaults, ``"hold"`` for the inner position
            loop (the book's step response of (9.42)–(9.43), its zero at −k_I/k_F) and
            ``"zero"`` for the parallel scheme. The state-space models, poles, zeros and
            transfer functions are the chapter's loop (the whole PI acting on f_d, as with
            ``"hold"`` and ``"zero"``); with ``"tip"`` :meth:`response` also cancels the
            proportional kick of every change of f_d (ξ moves by −k_F Δf_d), as the controller
            does: its step response has no zero.
    """

    scheme: str
    inertia: float
    damping: float
    stiffness: float
    force_gain: float
    integral_gain: float = 0.0
    environment_stiffness: float = 0.0
    integrator_start: str | None = field(default=None, compare=False)  # sets ξ₀ only, not the dynamics

    def __post_init__(self) -> None:
        object.__setattr__(self, "scheme", _scheme(self.scheme))
        object.__setattr__(self, "inertia", positive_scalar("inertia", self.inertia))
        object.__setattr__(self, "damping", nonnegative_scalar("damping", self.damping))
        object.__setattr__(self, "stiffness", positive_scalar("stiffness", self.stiffness))
        object.__setattr__(self, "force_gain", nonnegative_scalar("force_gain", self.force_gain))
        object.__setattr__(self, "integral_gain", nonnegative_scalar("integral_gain", self.integral_gain))
        object.__setattr__(
            self, "environment_stiffness", nonnegative_scalar("environment_stiffness", self.environment_stiffness)
        )
        if self.integrator_start not in (None, "hold", "tip", "zero"):
            raise ParameterError(f"integrator_start must be 'hold', 'tip', 'zero' or None; got {self.integrator_start!r}")
        if self.scheme == "inner-velocity" and self.integral_gain != 0.0:
            raise ParameterError(
                "integral_gain must be 0 for the inner velocity loop (C_F = K_F, (9.46)); "
                f"got {self.integral_gain!r}"
            )

    # ------------------------------------------------------------------ structure
    @property
    def start(self) -> str:
        """The integrator start in effect: :attr:`integrator_start`, or the scheme's default."""
        return self.integrator_start or ("hold" if self.scheme == "inner-position" else "zero")

    @property
    def has_integral(self) -> bool:
        """Whether ξ is a state (PI action (9.43) with k_I > 0)."""
        return self.scheme != "inner-velocity" and self.integral_gain > 0.0

    @property
    def states(self) -> list[str]:
        """State names: ``["x", "xdot"]`` plus ``"xi"`` with integral action."""
        return ["x", "xdot", "xi"] if self.has_integral else ["x", "xdot"]

    def with_environment_stiffness(self, environment_stiffness: float) -> ForceLoopAxis:
        """The same axis in contact with another environment stiffness k [N/m]."""
        return replace(self, environment_stiffness=environment_stiffness)

    def _law(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The control law as affine maps: ``a = Gz z + Gw w``, ``ξ̇ = Hz z + Hw w``.

        z = states, w = [f_d, x_d, x_r]; f_e = k (x − x_r) is substituted.
        """
        m, kd, kp = self.inertia, self.damping, self.stiffness
        kf, ki, k = self.force_gain, self.integral_gain, self.environment_stiffness
        nz = len(self.states)
        Gz, Gw = np.zeros(nz), np.zeros(3)
        Hz, Hw = np.zeros(nz), np.zeros(3)
        # force error e = f_d − k x + k x_r
        ez, ew = np.zeros(nz), np.array([1.0, 0.0, k])
        ez[0] = -k
        if self.scheme == "inner-velocity":
            Gz = kp * kf * ez
            Gw = kp * kf * ew
        else:
            # x_F = k_F e + ξ; inner position: k_P (x_F − x); parallel: k_P (x_d − x + x_F)
            Gz = kp * kf * ez
            Gw = kp * kf * ew
            Gz[0] -= kp
            if self.scheme == "parallel":
                Gw[1] += kp
            if self.has_integral:
                Gz[2] += kp
                Hz = ki * ez
                Hw = ki * ew
        Gz[1] -= kd
        return Gz / m, Gw / m, Hz, Hw

    def _continuous_matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(A, B, C, D) of :meth:`state_space` as arrays (no python-control import)."""
        Gz, Gw, Hz, Hw = self._law()
        nz = len(self.states)
        A = np.zeros((nz, nz))
        B = np.zeros((nz, 3))
        A[0, 1] = 1.0
        A[1], B[1] = Gz, Gw
        if self.has_integral:
            A[2], B[2] = Hz, Hw
        k = self.environment_stiffness
        C = np.zeros((2, nz))
        D = np.zeros((2, 3))
        C[0, 0], D[0, 2] = k, -k
        C[1, 0] = 1.0
        return A, B, C, D

    def state_space(self) -> control.StateSpace:
        """The continuous closed loop: states :attr:`states`, inputs [f_d, x_d, x_r], outputs [f_e, x]."""
        return control.ss(*self._continuous_matrices(), inputs=_INPUTS, outputs=_OUTPUTS, states=self.states,
                          name=self.scheme)

    def force_transfer_function(self) -> control.TransferFunction:
        """f_e(s)/f_d(s), e.g. ``k k_P (k_F s + k_I) / (m s³ + k_D s² + k_P (1 + k_F k) s + k_P k k_I)``."""
        return _clean_tf(control.ss2tf(self.state_space()[0, 0]))

    def position_transfer_function(self) -> control.TransferFunction:
        """x(s)/x_d(s) (meaningful for the parallel scheme, zero for the others)."""
        return _clean_tf(control.ss2tf(self.state_space()[1, 1]))

    def characteristic_polynomial(self) -> np.ndarray:
        """Coefficients of the closed-loop characteristic polynomial, highest power first, monic × m_d.

        Inner position and parallel with PI: ``[m, k_D, k_P (1 + k_F k), k_P k k_I]``; inner velocity:
        ``[m, k_D, k_P k_F k]`` (9.47).
        """
        return self.inertia * np.real(np.poly(self._continuous_matrices()[0]))

    # poles, zeros and damping are the eigenvalues of the state matrix and of the system pencil,
    # computed here without importing python-control (1-5 s) for the ``analyze`` command; the tests
    # check them against ``control.poles``, ``control.zeros`` and ``control.damp``.
    def poles(self) -> np.ndarray:
        """Closed-loop poles [rad/s] (eigenvalues of A), sorted by real part then imaginary part."""
        p = np.linalg.eigvals(self._continuous_matrices()[0])
        return np.array(sorted(p, key=lambda z: (round(z.real, 12), z.imag)))

    def zeros(self) -> np.ndarray:
        """Zeros of f_e/f_d [rad/s]: ``−k_I / k_F`` with PI and k_F > 0.

        The finite generalised eigenvalues of the pencil ``([[A, b], [c, d]], [[I, 0], [0, 0]])``
        of the input f_d and output f_e (the invariant zeros of a SISO system). Empty without
        contact (k = 0: f_e/f_d is identically zero).
        """
        from scipy.linalg import eigvals

        if self.environment_stiffness == 0.0:
            return np.empty(0)
        A, B, C, D = self._continuous_matrices()
        n = A.shape[0]
        M = np.block([[A, B[:, :1]], [C[:1], D[:1, :1]]])
        N = np.zeros_like(M)
        N[:n, :n] = np.eye(n)
        z = eigvals(M, N)
        z = z[np.isfinite(z)]
        return np.real_if_close(z[np.abs(z) < 1e12])

    def damping_table(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(ω_n [rad/s], ζ, poles)`` of the closed loop, as ``control.damp``: ω_n = |p|, ζ = −Re p / |p|."""
        p = np.linalg.eigvals(self._continuous_matrices()[0])
        wn = np.abs(p)
        with np.errstate(divide="ignore", invalid="ignore"):  # a pole at 0 (free axis) has ζ = nan
            zeta = -np.real(p) / wn
        return wn, zeta, p

    def is_stable(self) -> bool:
        """All continuous poles strictly in the left half-plane."""
        return bool(np.all(np.real(self.poles()) < 0.0))

    # ------------------------------------------------------------------ steady state
    def equilibrium(self, force: float, position: float = 0.0, rest_position: float = 0.0) -> tuple[float, float]:
        """Steady ``(x_e, f_e)`` for constant f_d, x_d, x_r: (9.44) or (9.49).

        With integral action (or the inner velocity loop) and k > 0: ``f_e = f_d``,
        ``x_e = x_r + f_d / k`` (9.44). Parallel with purely proportional C_F: (9.49) solved,
        ``x_e = (x_d + k_F (k x_r + f_d)) / (1 + k_F k)``. Inner position with proportional C_F:
        ``x_e = k_F (k x_r + f_d) / (1 + k_F k)`` from (9.42).

        Warns:
            DriftWarning: f_d ≠ 0 on a free axis (k = 0) where the force loop acts: no
                equilibrium, x_e drifts (Sect. 9.4.3); returns (nan, 0).
        """
        k, kf, ki = self.environment_stiffness, self.force_gain, self.integral_gain
        acts = kf > 0.0 or ki > 0.0
        integrating = self.scheme == "inner-velocity" or ki > 0.0
        if k == 0.0 and acts and integrating and force != 0.0:
            warnings.warn(
                f"force reference f_d = {force!r} N on a free axis (environment_stiffness = 0): the "
                f"{self.scheme} scheme reads it as a velocity reference and the end-effector drifts "
                "(Sect. 9.4.3)",
                DriftWarning,
                stacklevel=2,
            )
            return math.nan, 0.0
        if k > 0.0 and acts and integrating:
            return rest_position + force / k, force
        if self.scheme == "parallel":
            x = (position + kf * (k * rest_position + force)) / (1.0 + kf * k)
        elif self.scheme == "inner-position":
            x = kf * (k * rest_position + force) / (1.0 + kf * k)
        else:  # inner velocity with k_F = 0: any position is an equilibrium
            return math.nan, 0.0
        return x, k * (x - rest_position)

    # ------------------------------------------------------------------ responses
    def response(
        self,
        t: Any,
        force: Any,
        position: Any = 0.0,
        rest_position: float = 0.0,
        initial_state: Any = None,
    ) -> control.TimeResponseData:
        """Linear response (``control.forced_response``) to f_d(t), x_d(t) from an initial state.

        Args:
            t: times (N,) [s]; force: f_d, scalar or (N,) [N]; position: x_d, scalar or (N,) [m].
            rest_position: x_r [m].
            initial_state: ``[x, ẋ, ξ]`` (ξ only with integral action); default: at rest at x_r
                with ξ₀ as the controller presets it (:attr:`integrator_start`), with
                ``p = x_r`` (inner position) or ``x_r − x_d(0)`` (parallel): ``"hold"``
                ξ₀ = p, ``"tip"`` ξ₀ = p − k_F f_d(0), ``"zero"`` ξ₀ = 0.

        With ``"tip"`` every change of f_d moves ξ by −k_F Δf_d (no proportional kick, as the
        controller does): the loop is simulated in the coordinate ``ξ + k_F f_d`` (the PI with
        setpoint weight 0) and the returned state ξ converted back.
        """
        t = np.asarray(t, dtype=np.float64)
        U = np.vstack([
            np.broadcast_to(np.asarray(force, dtype=np.float64), t.shape),
            np.broadcast_to(np.asarray(position, dtype=np.float64), t.shape),
            np.full(t.shape, float(rest_position)),
        ])
        if initial_state is None:
            xi0 = [self.initial_integral(float(U[0, 0]), float(U[1, 0]), float(rest_position))] if self.has_integral else []
            x0 = np.array([rest_position, 0.0, *xi0])
        else:
            x0 = np.asarray(initial_state, dtype=np.float64).reshape(-1)
            if x0.shape != (len(self.states),):
                raise DimensionError(
                    f"initial_state must have shape ({len(self.states)},) (states {self.states}); got shape {x0.shape}"
                )
        if not (self.has_integral and self.start == "tip"):
            return control.forced_response(self.state_space(), T=t, U=U, X0=x0)
        A, B, C, D = self._continuous_matrices()
        B = B.copy()
        B[1, 0] -= self.stiffness * self.force_gain / self.inertia  # x_F = k_F (0 − f_e) + (ξ + k_F f_d)
        x0 = x0.copy()
        x0[2] += self.force_gain * U[0, 0]
        sys = control.ss(A, B, C, D, inputs=_INPUTS, outputs=_OUTPUTS, states=self.states, name=f"{self.scheme}-tip")
        resp = control.forced_response(sys, T=t, U=U, X0=x0)
        resp.states[2] -= self.force_gain * U[0]
        return resp

    def initial_integral(self, force: float, position: float, rest_position: float) -> float:
        """ξ₀ [m] the controller presets for a start at rest at x_r, with f_d(0), x_d(0) (see :meth:`response`)."""
        start = self.start
        if start == "zero":
            return 0.0
        p = rest_position if self.scheme == "inner-position" else rest_position - position
        return p - self.force_gain * force if start == "tip" else p

    # ------------------------------------------------------------------ sampled data
    def sampled(self, sample_time: float, arm_inertia: float | None = None) -> control.StateSpace:
        """The sampled-data closed loop as the simulator runs it (discrete, ``dt = sample_time``).

        Plant over one sample (zero-order hold on a and on the compensated force f_k), states
        ``[x, ẋ]``: ``ẍ = a`` (exact inverse dynamics), or ``ẍ = a + (f_k − k (x − x_r)) / m_x``
        when ``arm_inertia`` m_x [kg] is given (the contact force's change within the sample acts
        on the arm's operational mass). Discretised exactly (zero-order hold, in closed form: the
        plant is an undamped oscillator; the same as ``control.sample_system(..., "zoh")``, tested).
        Controller at t_k: ``a_k`` from x_k, ẋ_k, f_k = k (x_k − x_r) and ξ_k; then
        ``ξ_{k+1} = ξ_k + Ts k_I (f_d − f_k)``.

        Returns:
            Discrete state space, states :attr:`states`, inputs [f_d, x_d, x_r], outputs [f_e, x].
        """
        Ts = positive_scalar("sample_time", sample_time)
        A, B, C, D = self._sampled_matrices(Ts, arm_inertia)
        return control.ss(A, B, C, D, Ts, inputs=_INPUTS, outputs=_OUTPUTS, states=self.states,
                          name=f"{self.scheme}-sampled")

    def _sampled_matrices(self, Ts: float, arm_inertia: float | None) -> tuple[np.ndarray, ...]:
        """(A, B, C, D) of :meth:`sampled` (``Ts`` already checked)."""
        k = self.environment_stiffness
        # continuous plant: states [x, v]; inputs [a, f_hold, x_r]
        Ap = np.array([[0.0, 1.0], [0.0, 0.0]])
        Bp = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
        if arm_inertia is not None:
            mx = positive_scalar("arm_inertia", arm_inertia)
            Ap[1, 0] = -k / mx
            Bp[1, 1] = 1.0 / mx
            Bp[1, 2] = k / mx
        # zero-order hold: Ad = exp(Ap Ts), Bd = ∫₀^Ts exp(Ap τ) dτ Bp, in closed form (Ap is an
        # undamped oscillator of ω² = k / m_x, or a double integrator)
        w2 = -Ap[1, 0]
        Ad, Gamma = _oscillator_zoh(w2, Ts)
        Bd = Gamma @ Bp
        Gz, Gw, Hz, Hw = self._law()
        nz = len(self.states)
        # a_k = Gz z + Gw w ; f_k = k x − k x_r
        Fz = np.zeros(nz)
        Fz[0] = k
        Fw = np.array([0.0, 0.0, -k])
        A = np.zeros((nz, nz))
        B = np.zeros((nz, 3))
        Ez = np.zeros((2, nz))
        Ez[0, 0] = Ez[1, 1] = 1.0
        A[:2] = Ad @ Ez + np.outer(Bd[:, 0], Gz) + np.outer(Bd[:, 1], Fz)
        B[:2] = np.outer(Bd[:, 0], Gw) + np.outer(Bd[:, 1], Fw) + np.outer(Bd[:, 2], [0.0, 0.0, 1.0])
        if self.has_integral:
            A[2] = Hz * Ts
            A[2, 2] += 1.0
            B[2] = Hw * Ts
        C = np.zeros((2, nz))
        D = np.zeros((2, 3))
        C[0, 0], D[0, 2] = k, -k
        C[1, 0] = 1.0
        return A, B, C, D

    def spectral_radius(self, sample_time: float, arm_inertia: float | None = None) -> float:
        """Largest |pole| of :meth:`sampled` (< 1: the sampled loop is stable)."""
        A = self._sampled_matrices(positive_scalar("sample_time", sample_time), arm_inertia)[0]
        return float(np.max(np.abs(np.linalg.eigvals(A))))


def _oscillator_zoh(w2: float, Ts: float) -> tuple[np.ndarray, np.ndarray]:
    """exp(A Ts) and ∫₀^Ts exp(A τ) dτ for ``A = [[0, 1], [−ω², 0]]`` (ω² >= 0), in closed form.

    ``exp(A τ) = [[cos ωτ, sin ωτ / ω], [−ω sin ωτ, cos ωτ]]``; its integral is
    ``[[sin ωT / ω, (1 − cos ωT) / ω²], [cos ωT − 1, sin ωT / ω]]``, written without cancellation
    (``1 − cos ωT = 2 sin²(ωT/2)``); ω → 0 gives the double integrator.
    """
    w = math.sqrt(w2)
    c, sn = math.cos(w * Ts), math.sin(w * Ts)
    sinc = sn / w if w * Ts > 1e-12 else Ts  # sin(ωT)/ω
    half = math.sin(0.5 * w * Ts)
    one_minus_cos_over_w2 = 2.0 * (half / w) ** 2 if w * Ts > 1e-12 else 0.5 * Ts * Ts
    Phi = np.array([[c, sinc], [-w2 * sinc, c]])
    Gamma = np.array([[sinc, one_minus_cos_over_w2], [-w2 * one_minus_cos_over_w2, sinc]])
    return Phi, Gamma


def _clean_tf(tf: control.TransferFunction) -> control.TransferFunction:
    """Zero the round-off numerator coefficients left by ``ss2tf`` (leading ones fake huge zeros)."""
    num = np.atleast_1d(np.asarray(tf.num[0][0], dtype=np.float64))
    den = np.atleast_1d(np.asarray(tf.den[0][0], dtype=np.float64))
    scale = max(float(np.max(np.abs(num))), 1e-300)
    num = np.where(np.abs(num) <= 1e-12 * scale, 0.0, num)
    while num.size > 1 and num[0] == 0.0:
        num = num[1:]
    return control.tf(num, den, inputs=tf.input_labels, outputs=tf.output_labels)
