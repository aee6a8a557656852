"""Online estimate of the environment's stiffness from force and position during contact (RLS).

Along a contact direction n (unit), the elastic environment of the chapter (9.38) gives

    f_n = k (x_n − x_r,n) = k x_n + c,        c = −k x_r,n

with f_n = nᵀ h_e the force exerted on the environment along n and x_n = nᵀ x_e the tip's
coordinate (n points into the environment, so f_n > 0 in contact). θ = [k, c] is linear in the
data: recursive least squares with exponential forgetting λ ∈ (0, 1],

    K = P φ / (λ + φᵀ P φ),   θ ← θ + K (f_n − φᵀ θ),   P ← (P − K φᵀ P) / λ,   φ = [x_n, 1],

run only on samples in contact (f_n above ``contact_force``). The covariance is kept bounded
(its trace at most ``max_covariance``) so that forgetting without excitation (a steady press)
cannot wind it up. The residual variance is tracked with the same forgetting, so
``std = sqrt(σ̂² P₀₀)`` is the estimate's standard deviation and :meth:`interval` a range of
stiffness the gain design (:func:`forcecontrol.analysis.gain_design.design_gains`) can use.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..core.validate import as_vector, positive_scalar
from ..errors import DimensionError, ParameterError

__all__ = ["StiffnessEstimator"]


class StiffnessEstimator:
    """Recursive least-squares estimate of a contact's stiffness k and rest position x_r.

    Args:
        direction: n, the contact normal pointing into the environment (m,) (normalised).
        forgetting: λ ∈ (0, 1]; 1 = no forgetting; 0.999 at 1 kHz remembers about 1 s.
        contact_force: f_n above which a sample is in contact [N], > 0.
        initial_stiffness: prior k [N/m] (its weight is small: ``initial_covariance``).
        initial_covariance: P₀ = diag(p₀ / 1e-6, p₀) scaled for [k, c]; default 1e12.
        max_covariance: bound on trace(P).

    Attributes:
        samples: contact samples used so far.
    """

    def __init__(self, direction: Any, *, forgetting: float = 0.999, contact_force: float = 1.0,
                 initial_stiffness: float = 1e3, initial_covariance: float = 1e12, max_covariance: float = 1e16) -> None:
        d = as_vector("direction", direction)
        nrm = float(np.linalg.norm(d))
        if nrm == 0.0:
            raise ParameterError(f"direction must be a non-zero vector; got {d.tolist()}")
        self.direction = d / nrm
        lam = float(forgetting)
        if not (0.0 < lam <= 1.0):
            raise ParameterError(f"forgetting must be in (0, 1]; got {forgetting!r}")
        self.forgetting = lam
        self.contact_force = positive_scalar("contact_force", contact_force)
        self.initial_stiffness = positive_scalar("initial_stiffness", initial_stiffness)
        self.initial_covariance = positive_scalar("initial_covariance", initial_covariance)
        self.max_covariance = positive_scalar("max_covariance", max_covariance)
        self.reset()

    def reset(self) -> None:
        """Back to the prior."""
        self.theta = np.array([self.initial_stiffness, 0.0])
        self.P = np.diag([self.initial_covariance, self.initial_covariance])
        self.samples = 0
        self._s2 = 0.0  # forgetting-weighted sum of squared residuals
        self._w = 0.0  # and of weights

    def update(self, position: Any, force: Any) -> float:
        """One sample: tip position x_e (m,) [m] and contact force h_e (m,) [N]; the current k̂ [N/m].

        A sample out of contact (f_n <= contact_force) leaves the estimate unchanged.

        Raises:
            DimensionError: shapes differ from ``direction``. MeasurementError-like
                ParameterError: non-finite input.
        """
        x = np.asarray(position, dtype=np.float64).reshape(-1)
        h = np.asarray(force, dtype=np.float64).reshape(-1)
        m = self.direction.shape[0]
        if x.shape != (m,) or h.shape != (m,):
            raise DimensionError(f"position and force must have shape ({m},) like direction; got {x.shape} and {h.shape}")
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(h))):
            raise ParameterError(f"position and force must be finite; got {x.tolist()} and {h.tolist()}")
        fn = float(self.direction @ h)
        if fn <= self.contact_force:
            return self.stiffness
        phi = np.array([float(self.direction @ x), 1.0])
        lam = self.forgetting
        Pphi = self.P @ phi
        denom = lam + float(phi @ Pphi)
        K = Pphi / denom
        err = fn - float(phi @ self.theta)
        self.theta = self.theta + K * err
        self.P = (self.P - np.outer(K, Pphi)) / lam
        self.P = 0.5 * (self.P + self.P.T)
        tr = float(np.trace(self.P))
        if tr > self.max_covariance:
            self.P *= self.max_covariance / tr
        post = fn - float(phi @ self.theta)
        self._s2 = lam * self._s2 + post * post
        self._w = lam * self._w + 1.0
        self.samples += 1
        return self.stiffness

    @property
    def stiffness(self) -> float:
        """k̂ [N/m]."""
        return float(self.theta[0])

    @property
    def rest_position(self) -> float:
        """x̂_r along the direction [m] (NaN while k̂ = 0)."""
        k = self.stiffness
        return -float(self.theta[1]) / k if k != 0.0 else math.nan

    @property
    def std(self) -> float:
        """Standard deviation of k̂ [N/m] (NaN before three contact samples)."""
        if self.samples < 3 or self._w <= 2.0:
            return math.nan
        s2 = self._s2 / (self._w - 2.0)
        return math.sqrt(max(s2 * float(self.P[0, 0]), 0.0))

    def interval(self, sigmas: float = 3.0, floor: float = 0.0) -> tuple[float, float]:
        """(k̂ − sigmas·std, k̂ + sigmas·std), clipped below at ``floor`` (and at 1e-9 k̂).

        Raises:
            ParameterError: no estimate yet (fewer than three contact samples).
        """
        s = self.std
        if not math.isfinite(s):
            raise ParameterError(f"no stiffness estimate yet: {self.samples} contact samples (need at least 3)")
        k = self.stiffness
        lo = max(k - sigmas * s, floor, 1e-9 * abs(k))
        return lo, k + sigmas * s

    def scan(self, positions: Any, forces: Any) -> np.ndarray:
        """Feed a whole log ((N, m) positions and forces); k̂ after each sample (N,)."""
        X = np.asarray(positions, dtype=np.float64)
        H = np.asarray(forces, dtype=np.float64)
        if X.ndim != 2 or X.shape != H.shape:
            raise DimensionError(f"positions and forces must be (N, m) arrays of one shape; got {X.shape} and {H.shape}")
        return np.array([self.update(X[i], H[i]) for i in range(X.shape[0])])
