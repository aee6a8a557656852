"""The sweeps' batch with several cases per instruction: ``LANES`` cases advanced together, sample by sample.

:mod:`forcecontrol.sim.batch` runs its cases one after the other through the scalar loop of
:mod:`forcecontrol.sim.loop`. Here ``LANES`` (8) cases sit side by side: every per-case quantity
of the plant (state, the arm's coefficients, the environment, the sub-step sizes) is a row of
``LANES`` values (layout ``(n, LANES)``, flat, with ``LANES`` a compile-time constant), and the
arm's terms, the contact wrench and the RK4 stages run as loops over the lanes with no calls and
no branches, which LLVM turns into vector instructions (8 cases per AVX-512 instruction, 4 per
AVX2). The trigonometry is :func:`forcecontrol.sim.trig.sincos` (libm calls would keep the loop
scalar).

Per sample, for every lane: the arm's terms and wrench (vectorised), then the sensor (bias,
noise, low-pass) and **the control law itself**, per lane, the same compiled law
(:mod:`forcecontrol.laws`) as the scalar loop (not a transcription: every law runs here), then
the torque held over Ts and ``nsub`` RK4 steps (vectorised, masked per lane: lanes with fewer
sub-steps hold their state). A lane whose case ends (its N samples done, or a divergence: the
status codes and checks of :mod:`forcecontrol.sim.loop`, in the same order) gets its metrics
(:func:`forcecontrol.sim.metrics.case_metrics`, the one definition) and takes the next case, so
cases of different N, Ts, sub-steps, environments and early ends keep every lane busy.

What differs from the scalar kernel: only sin/cos (:func:`~forcecontrol.sim.trig.sincos`,
within 1 ulp of libm, equal to it on about 97 % of angles). The plant's arithmetic is the scalar
plant's (:func:`forcecontrol.sim.plant.terms2_scalars`, ``wrench2``, ``rk4_sample``), operation
for operation and in the same order; with libm's sin/cos (``trig="libm"``) every output of every
case equals the scalar kernel's to the bit (tested), so the difference is the trig's one ulp
carried through the closed loop: a settling loop damps it, so outputs stay within 1e-9
relative on the 144 random cases of ``tests/test_batch_lanes.py`` (measured at most 1.5e-10) and within 1e-7 on a
360-case grid across a stability boundary (measured up to 2e-8); an unstable or bouncing loop amplifies it, and
its force metrics can differ by O(1) (its status, stable and contact_lost flags equal); a case on the edge of a
discrete event (the band of the settling time, a divergence threshold) may move by one sample.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from ..core.linalg import solve2_spd
from ..core.numba_cache import build_once, kernel_identity, stable_identities
from ..laws.inner import law_parts
from .metrics import case_metrics
from .plant import NONFINITE_STATE, NONFINITE_TORQUE, OK, RUNAWAY, SINGULAR
from .trig import sincos

__all__ = ["LANES", "run_lanes", "lane_kernel"]

#: cases advanced together.
LANES = 8
_L = LANES
# The lanes' workspace Z: one flat array of rows of _L values (row r of lane l at Z[r * _L + l]).
# One array with rows a constant distance apart is what lets LLVM prove the lanes' loops free of
# dependences between rows (separate arrays need run-time alias checks, beyond its limit here); the
# lane loops run over a run-time count (a constant 8 is unrolled whole, and then not vectorised).
_K = 0  # the arm's 12 coefficients (robots.planar_2r kernel_vector)
_P = 12  # the environment's 10 parameters (a spring's 10; a plane uses the first 6)
_KIND = 22  # environment kind (1 plane, 2 spring), as a float
_X = 23  # q0, q1, q̇0, q̇1
_U = 27  # the torque held over the sample
_DT = 29  # RK4 step, half step, step / 6 (plant.rk4_sample's dt, hdt, sdt)
_T = 32  # the sample's 17 terms (plant.terms2's layout)
_HS = 49  # the sample's true wrench
_ACT = 51  # 1.0: the lane integrates this sample
_FAIL = 52  # 1.0: an RK4 stage of this sample was not finite
_NSUB = 53  # RK4 sub-steps per sample, as a float
_A1 = 54  # RK4 stage 1 of the sub-step: ok (1.0/0.0), q̈0, q̈1
_ROWS = 57



@njit(cache=True, inline="always")
def _libm_sincos(x):  # pragma: no cover - compiled
    """(sin x, cos x) from libm: the scalar loop's trig (tests: the lanes then equal the scalar kernel to the bit)."""
    return math.sin(x), math.cos(x)


_TRIG = {"vector": sincos, "libm": _libm_sincos}
_KERNELS: dict[Any, Any] = {}
_HELPERS: dict[Any, Any] = {}


def lane_kernel(law: Any, trig: str = "vector") -> Any:
    """The lane kernel compiled for control ``law`` (built once per law and trig, cached on disk).

    ``lane_kernel(law)(order, nl, K, env_kind, env_p, ctrl_p, ctrl_s, ref_tab, ref_id, bias, noise_tab,
    noise_id, alpha, q0, q̇0, Ts, nsub, N, max_q̇, d, f_ref, window, settle_band, stable_band, out)``:
    the arguments of :func:`forcecontrol.sim.batch.run_batch`, plus ``order`` (the cases in the
    order the lanes take them) and ``nl`` (:data:`LANES`). ``trig``: ``"vector"``
    (:func:`~forcecontrol.sim.trig.sincos`) or ``"libm"`` (the scalar loop's, for tests).
    """
    def build() -> Any:
        stable_identities()  # the functions it calls, pickled into its cache key, with their stable identities
        fn = njit(cache=True, nogil=True)(_make_kernel(law, _helpers(trig)))
        kernel_identity(fn, f"forcecontrol:_lanes{LANES}.{trig}:{law._uuid}")  # its own uuid and cache files
        return fn

    return build_once(_KERNELS, (law, trig), build)  # once, even when a sweep's threads ask together


def _helpers(trig: str) -> tuple[Any, Any]:
    """The vectorised parts for ``trig``: ``(sample, substep)`` (built once per trig, each with its identity).

    Compiled on their own with NumPy's error model (a float division by zero gives inf, as IEEE, instead
    of a check that raises: that branch kept the loops scalar); the law stays in the kernel, compiled as
    the scalar loop is.
    """
    def build() -> tuple[Any, Any]:
        stable_identities()  # sincos, solve2_spd, ...: found again on disk only with their stable identities
        fns = _make_helpers(_TRIG[trig])
        for name, fn in fns.items():  # the inlined ones too: the cache keys of the others pickle them
            kernel_identity(fn, f"forcecontrol:_lanes{LANES}.{trig}.{name}")
        return fns["sample"], fns["substep"]

    return build_once(_HELPERS, trig, build)


def run_lanes(law: Any, order: np.ndarray, *args: Any, trig: str = "vector") -> None:
    """A block of cases with control ``law`` on :data:`LANES` lanes; row i of ``out`` gets ``OUT_COLUMNS``
    of :mod:`forcecontrol.sim.batch` (``args``: those of :func:`forcecontrol.sim.batch.run_batch`)."""
    lane_kernel(law, trig)(np.ascontiguousarray(order, dtype=np.int64), LANES, *args)


@njit(cache=True, inline="always")
def _wrench(Z, l, x0, x1, v0, v1):  # pragma: no cover - compiled
    """plant.wrench2 for kinds 1 (plane) and 2 (spring) on lane l, by selects (NaN for any other kind)."""
    kind = Z[_KIND * _L + l]
    p0 = Z[(_P + 0) * _L + l]
    p1 = Z[(_P + 1) * _L + l]
    p2 = Z[(_P + 2) * _L + l]
    p3 = Z[(_P + 3) * _L + l]
    p4 = Z[(_P + 4) * _L + l]
    p5 = Z[(_P + 5) * _L + l]
    # kind 1: the plane [n0, n1, x0, x1, k, c]
    delta = p0 * (p2 - x0) + p1 * (p3 - x1)
    vn = p0 * v0 + p1 * v1
    mag = p4 * delta - p5 * vn
    touch = (not (delta <= 0.0)) & (not (mag <= 0.0))
    f0 = -mag * p0 if touch else 0.0
    f1 = -mag * p1 if touch else 0.0
    # kind 2: the spring [K (2x2), D (2x2), x_rest]
    e0 = x0 - Z[(_P + 8) * _L + l]
    e1 = x1 - Z[(_P + 9) * _L + l]
    s0 = (p0 * e0 + p1 * e1) + (p4 * v0 + p5 * v1)
    s1 = (p2 * e0 + p3 * e1) + (Z[(_P + 6) * _L + l] * v0 + Z[(_P + 7) * _L + l] * v1)
    h0 = f0 if kind == 1.0 else (s0 if kind == 2.0 else math.nan)
    h1 = f1 if kind == 1.0 else (s1 if kind == 2.0 else math.nan)
    return h0, h1


def _make_helpers(sc: Any) -> dict[str, Any]:  # pragma: no cover - compiled
    """The vectorised loops over lanes with sin/cos ``sc``, by name (sample, substep and what they inline)."""

    @njit(inline="always")
    def terms(Z, l, q0, q1, w0, w1):
        """plant.terms2_scalars on lane l (the same expressions, in the same order; sin/cos by ``sc``)."""
        a1 = Z[(_K + 0) * _L + l]
        a2 = Z[(_K + 1) * _L + l]
        s1, c1 = sc(q0)
        s2, c2 = sc(q1)
        c12 = c1 * c2 - s1 * s2
        s12 = s1 * c2 + c1 * s2
        x0 = a1 * c1 + a2 * c12
        x1 = a1 * s1 + a2 * s12
        j00 = -a1 * s1 - a2 * s12
        j01 = -a2 * s12
        j10 = a1 * c1 + a2 * c12
        j11 = a2 * c12
        u12 = w0 + w1
        jdq0 = -a1 * c1 * w0 * w0 - a2 * c12 * u12 * u12
        jdq1 = -a1 * s1 * w0 * w0 - a2 * s12 * u12 * u12
        h = -Z[(_K + 7) * _L + l] * s2
        g0 = Z[(_K + 8) * _L + l] * c1 + Z[(_K + 9) * _L + l] * c12
        g1 = Z[(_K + 9) * _L + l] * c12
        return (x0, x1, j00 * w0 + j01 * w1, j10 * w0 + j11 * w1, j00, j01, j10, j11, jdq0, jdq1,
                Z[(_K + 2) * _L + l] + Z[(_K + 3) * _L + l] * c2, Z[(_K + 4) * _L + l] + Z[(_K + 5) * _L + l] * c2,
                Z[(_K + 6) * _L + l],
                h * w1 * w0 + h * (w0 + w1) * w1 + Z[(_K + 10) * _L + l] * w0 + g0,
                -h * w0 * w0 + Z[(_K + 11) * _L + l] * w1 + g1, g0, g1)

    @njit(inline="always")
    def accel(Z, l, q0, q1, w0, w1, u0, u1):
        """plant._accel2 on lane l: q̈ = B⁻¹ (u − n − Jᵀ h_e); (ok, a0, a1)."""
        x0, x1, xd0, xd1, j00, j01, j10, j11, _, _, b00, b01, b11, n0, n1, _, _ = terms(Z, l, q0, q1, w0, w1)
        h0, h1 = _wrench(Z, l, x0, x1, xd0, xd1)
        return solve2_spd(b00, b01, b11, u0 - n0 - j00 * h0 - j10 * h1, u1 - n1 - j01 * h0 - j11 * h1)

    @njit(cache=True, error_model="numpy")
    def sample(Z, nl):
        """The sample's terms and true wrench of every lane, into rows _T and _HS (plant.terms2, wrench2)."""
        for l in range(nl):
            (t0, t1, t2, t3, t4, t5, t6, t7, t8, t9, t10, t11, t12, t13, t14, t15, t16) = terms(
                Z, l, Z[(_X + 0) * _L + l], Z[(_X + 1) * _L + l], Z[(_X + 2) * _L + l], Z[(_X + 3) * _L + l])
            Z[(_T + 0) * _L + l], Z[(_T + 1) * _L + l], Z[(_T + 2) * _L + l], Z[(_T + 3) * _L + l] = t0, t1, t2, t3
            Z[(_T + 4) * _L + l], Z[(_T + 5) * _L + l], Z[(_T + 6) * _L + l], Z[(_T + 7) * _L + l] = t4, t5, t6, t7
            Z[(_T + 8) * _L + l], Z[(_T + 9) * _L + l], Z[(_T + 10) * _L + l], Z[(_T + 11) * _L + l] = t8, t9, t10, t11
            Z[(_T + 12) * _L + l], Z[(_T + 13) * _L + l], Z[(_T + 14) * _L + l] = t12, t13, t14
            Z[(_T + 15) * _L + l], Z[(_T + 16) * _L + l] = t15, t16
            Z[(_HS + 0) * _L + l], Z[(_HS + 1) * _L + l] = _wrench(Z, l, t0, t1, t2, t3)

    @njit(cache=True, error_model="numpy")
    def substep(Z, nl, j):
        """RK4 sub-step j of every lane (plant.rk4_sample's step), masked: lanes not integrating hold their state."""
        if j == 0:  # stage 1 at the sample's state: its terms and wrench are in rows _T, _HS (plant._accel_terms2)
            for l in range(nl):
                h0 = Z[(_HS + 0) * _L + l]
                h1 = Z[(_HS + 1) * _L + l]
                r0 = Z[(_U + 0) * _L + l] - Z[(_T + 13) * _L + l] - Z[(_T + 4) * _L + l] * h0 - Z[(_T + 6) * _L + l] * h1
                r1 = Z[(_U + 1) * _L + l] - Z[(_T + 14) * _L + l] - Z[(_T + 5) * _L + l] * h0 - Z[(_T + 7) * _L + l] * h1
                ok1, a10, a11 = solve2_spd(Z[(_T + 10) * _L + l], Z[(_T + 11) * _L + l], Z[(_T + 12) * _L + l], r0, r1)
                Z[(_A1 + 0) * _L + l] = 1.0 if ok1 else 0.0
                Z[(_A1 + 1) * _L + l] = a10
                Z[(_A1 + 2) * _L + l] = a11
        else:
            for l in range(nl):
                ok1, a10, a11 = accel(Z, l, Z[(_X + 0) * _L + l], Z[(_X + 1) * _L + l], Z[(_X + 2) * _L + l],
                                      Z[(_X + 3) * _L + l], Z[(_U + 0) * _L + l], Z[(_U + 1) * _L + l])
                Z[(_A1 + 0) * _L + l] = 1.0 if ok1 else 0.0
                Z[(_A1 + 1) * _L + l] = a10
                Z[(_A1 + 2) * _L + l] = a11
        # stages 2-4 written out, not looped as in plant.rk4_sample: with a loop over the stages LLVM stopped
        # vectorising the lanes (bench_sweep_process: 2.37x -> 1.09x the plain loop), for 3 s less to compile
        for l in range(nl):  # stages 2-4 and the update (plant.rk4_sample), masked
            a10 = Z[(_A1 + 1) * _L + l]
            a11 = Z[(_A1 + 2) * _L + l]
            q_0 = Z[(_X + 0) * _L + l]
            q_1 = Z[(_X + 1) * _L + l]
            w_0 = Z[(_X + 2) * _L + l]
            w_1 = Z[(_X + 3) * _L + l]
            u0 = Z[(_U + 0) * _L + l]
            u1 = Z[(_U + 1) * _L + l]
            dt = Z[(_DT + 0) * _L + l]
            hdt = Z[(_DT + 1) * _L + l]
            sdt = Z[(_DT + 2) * _L + l]
            v20 = w_0 + hdt * a10
            v21 = w_1 + hdt * a11
            ok2, a20, a21 = accel(Z, l, q_0 + hdt * w_0, q_1 + hdt * w_1, v20, v21, u0, u1)
            v30 = w_0 + hdt * a20
            v31 = w_1 + hdt * a21
            ok3, a30, a31 = accel(Z, l, q_0 + hdt * v20, q_1 + hdt * v21, v30, v31, u0, u1)
            v40 = w_0 + dt * a30
            v41 = w_1 + dt * a31
            ok4, a40, a41 = accel(Z, l, q_0 + dt * v30, q_1 + dt * v31, v40, v41, u0, u1)
            ok = (Z[(_A1 + 0) * _L + l] != 0.0) & ok2 & ok3 & ok4
            act = (Z[_ACT * _L + l] != 0.0) & (Z[_FAIL * _L + l] == 0.0) & (j < Z[_NSUB * _L + l])
            take = act & ok
            Z[(_X + 0) * _L + l] = q_0 + sdt * (w_0 + 2.0 * v20 + 2.0 * v30 + v40) if take else q_0
            Z[(_X + 1) * _L + l] = q_1 + sdt * (w_1 + 2.0 * v21 + 2.0 * v31 + v41) if take else q_1
            Z[(_X + 2) * _L + l] = w_0 + sdt * (a10 + 2.0 * a20 + 2.0 * a30 + a40) if take else w_0
            Z[(_X + 3) * _L + l] = w_1 + sdt * (a11 + 2.0 * a21 + 2.0 * a31 + a41) if take else w_1
            Z[_FAIL * _L + l] = 1.0 if (act & (not ok)) else Z[_FAIL * _L + l]

    return {"terms": terms, "accel": accel, "sample": sample, "substep": substep}


def _make_kernel(law: Any, helpers: tuple[Any, Any]) -> Any:  # pragma: no cover - compiled
    sample, substep = helpers
    split, acceleration, inner = law_parts(law)  # an inverse-dynamics law: its two parts called here

    def kernel(order, nl, K, env_kind, env_p, ctrl_p, ctrl_s, ref_tab, ref_id, bias, noise_tab, noise_id,
               alpha, q0, qd0, Ts, nsub, N, max_qd, d, f_ref, window, settle_band, stable_band, out):
        """Run the cases in ``order`` on ``nl`` lanes with the factory's ``law``; row i of ``out`` gets OUT_COLUMNS."""
        C = order.shape[0]
        nmax = 0
        for i in range(K.shape[0]):
            nmax = max(nmax, N[i])
        Z = np.zeros(_ROWS * _L)
        mode = np.zeros(_L, np.int64)  # 0 idle, 1 running, 2 ended at this sample
        case = np.zeros(_L, np.int64)
        kk = np.zeros(_L, np.int64)
        status = np.zeros(_L, np.int64)
        HM = np.zeros(2 * _L)
        peak = np.zeros(_L)
        touched = np.zeros(_L, np.bool_)
        lost = np.zeros(_L, np.bool_)
        S = np.zeros((_L, ctrl_s.shape[1]))
        Y = np.empty((_L, nmax + 1))
        for l in range(_L):  # an idle lane computes on a finite state: the arm at rest in its first case's start
            Z[(_K + 0) * _L + l] = 1.0
        # the law's inputs (the scalar loop's arrays)
        m = 2
        n = 2
        x = np.empty(m)
        xd = np.empty(m)
        J = np.empty((m, n))
        Jdq = np.empty(m)
        B = np.empty((n, n))
        nv = np.empty(n)
        g = np.empty(n)
        q = np.empty(n)
        qd = np.empty(n)
        hm = np.zeros(m)
        u = np.empty(n)
        ws = np.empty(2 * m * m + 12 * m + 2 * n + 8)
        nxt = 0
        while True:
            # ---- lanes without a case take the next one
            busy = False
            for l in range(_L):
                if mode[l] == 0 and nxt < C:
                    i = order[nxt]
                    nxt += 1
                    mode[l] = 1
                    case[l] = i
                    kk[l] = 0
                    for r in range(12):
                        Z[(_K + r) * _L + l] = K[i, r]
                    for r in range(10):
                        Z[(_P + r) * _L + l] = env_p[i, r] if r < env_p.shape[1] else 0.0
                    Z[_KIND * _L + l] = env_kind[i]
                    Z[(_X + 0) * _L + l] = q0[i, 0]
                    Z[(_X + 1) * _L + l] = q0[i, 1]
                    Z[(_X + 2) * _L + l] = qd0[i, 0]
                    Z[(_X + 3) * _L + l] = qd0[i, 1]
                    dt = Ts[i] / nsub[i]
                    Z[(_DT + 0) * _L + l] = dt
                    Z[(_DT + 1) * _L + l] = 0.5 * dt
                    Z[(_DT + 2) * _L + l] = dt / 6.0
                    Z[_NSUB * _L + l] = nsub[i]
                    for r in range(ctrl_s.shape[1]):
                        S[l, r] = ctrl_s[i, r]
                    peak[l] = 0.0
                    touched[l] = False
                    lost[l] = False
                busy = busy or mode[l] == 1
            if not busy:
                break
            # ---- the sample's terms and wrench, every lane (vectorised)
            sample(Z, nl)
            # ---- sensor, control law, log: per lane (the scalar loop's order of checks)
            maxsub = 0
            for l in range(_L):
                Z[_ACT * _L + l] = 0.0
                Z[_FAIL * _L + l] = 0.0
                if mode[l] != 1:
                    continue
                i = case[l]
                k = kk[l]
                h0 = Z[(_HS + 0) * _L + l]
                h1 = Z[(_HS + 1) * _L + l]
                raw0 = h0 + bias[i, 0] + noise_tab[noise_id[i], k, 0]
                raw1 = h1 + bias[i, 1] + noise_tab[noise_id[i], k, 1]
                if k == 0:
                    hm0 = raw0
                    hm1 = raw1
                else:
                    hm0 = HM[l] + alpha[i] * (raw0 - HM[l])
                    hm1 = HM[_L + l] + alpha[i] * (raw1 - HM[_L + l])
                HM[l] = hm0
                HM[_L + l] = hm1
                q[0], q[1], qd[0], qd[1] = Z[(_X + 0) * _L + l], Z[(_X + 1) * _L + l], Z[(_X + 2) * _L + l], Z[(_X + 3) * _L + l]
                x[0], x[1], xd[0], xd[1] = Z[(_T + 0) * _L + l], Z[(_T + 1) * _L + l], Z[(_T + 2) * _L + l], Z[(_T + 3) * _L + l]
                J[0, 0], J[0, 1] = Z[(_T + 4) * _L + l], Z[(_T + 5) * _L + l]
                J[1, 0], J[1, 1] = Z[(_T + 6) * _L + l], Z[(_T + 7) * _L + l]
                Jdq[0], Jdq[1] = Z[(_T + 8) * _L + l], Z[(_T + 9) * _L + l]
                B[0, 0], B[0, 1], B[1, 0], B[1, 1] = (Z[(_T + 10) * _L + l], Z[(_T + 11) * _L + l], Z[(_T + 11) * _L + l],
                                                      Z[(_T + 12) * _L + l])
                nv[0], nv[1] = Z[(_T + 13) * _L + l], Z[(_T + 14) * _L + l]
                g[0], g[1] = Z[(_T + 15) * _L + l], Z[(_T + 16) * _L + l]
                hm[0], hm[1] = hm0, hm1
                t = k * Ts[i]
                if split:  # a constant: Numba compiles one branch
                    m = x.shape[0]
                    comp = acceleration(t, Ts[i], x, xd, hm, ref_tab[ref_id[i], k], ctrl_p[i], S[l], ws[2 * m :], ws[0:m],
                                        ws[m : 2 * m])
                    inner(B, nv, J, Jdq, ws[0:m], ws[m : 2 * m], comp, ws[2 * m :], u)
                else:
                    law(t, Ts[i], q, qd, x, xd, J, Jdq, B, nv, g, hm, ref_tab[ref_id[i], k], ctrl_p[i], S[l], ws, u)
                u0 = u[0]
                u1 = u[1]
                Z[(_U + 0) * _L + l] = u0
                Z[(_U + 1) * _L + l] = u1
                Y[l, k] = d[i, 0] * h0 + d[i, 1] * h1
                hn = math.sqrt(h0 * h0 + h1 * h1)
                if hn > peak[l]:
                    peak[l] = hn
                if hn != 0.0:
                    touched[l] = True
                elif touched[l]:
                    lost[l] = True
                if not (math.isfinite(u0) and math.isfinite(u1)):
                    det = Z[(_T + 4) * _L + l] * Z[(_T + 7) * _L + l] - Z[(_T + 5) * _L + l] * Z[(_T + 6) * _L + l]
                    status[l] = SINGULAR if abs(det) < 1e-9 else NONFINITE_TORQUE
                    mode[l] = 2
                elif k == N[i]:
                    status[l] = OK
                    mode[l] = 2
                else:
                    Z[_ACT * _L + l] = 1.0
                    maxsub = max(maxsub, nsub[i])
            # ---- the torque held over Ts: RK4 sub-steps, every lane (vectorised, masked)
            for j in range(maxsub):
                substep(Z, nl, j)
            # ---- after the sample: the scalar loop's checks, then ended lanes give their metrics
            for l in range(_L):
                if mode[l] == 0:
                    continue
                i = case[l]
                k = kk[l]
                if mode[l] == 1:
                    q_0 = Z[(_X + 0) * _L + l]
                    q_1 = Z[(_X + 1) * _L + l]
                    w_0 = Z[(_X + 2) * _L + l]
                    w_1 = Z[(_X + 3) * _L + l]
                    if Z[_FAIL * _L + l] != 0.0 or not (math.isfinite(q_0) and math.isfinite(q_1)
                                                        and math.isfinite(w_0) and math.isfinite(w_1)):
                        status[l] = NONFINITE_STATE
                        mode[l] = 2
                    elif abs(w_0) > max_qd[i] or abs(w_1) > max_qd[i]:
                        status[l] = RUNAWAY
                        mode[l] = 2
                    else:
                        kk[l] = k + 1
                        continue
                # mode 2: the case ended at sample k
                st = status[l]
                sett, ov, err, stable, yf = case_metrics(Y[l], k, st, Ts[i], window[i], f_ref[i], settle_band, stable_band)
                out[i, 0] = st
                out[i, 1] = k
                out[i, 2] = peak[l]
                out[i, 3] = 1.0 if lost[l] else 0.0
                out[i, 4] = sett
                out[i, 5] = ov
                out[i, 6] = err
                out[i, 7] = stable
                out[i, 8] = yf
                mode[l] = 0
                Z[(_X + 0) * _L + l] = q0[i, 0]  # an idle lane computes on a finite state until it takes a case
                Z[(_X + 1) * _L + l] = q0[i, 1]
                Z[(_X + 2) * _L + l] = 0.0
                Z[(_X + 3) * _L + l] = 0.0

    return kernel
