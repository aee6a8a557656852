"""The simple force sensor model (bias, noise, first-order low-pass) the compiled loops run."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..core.validate import positive_scalar
from ..errors import DimensionError, ParameterError

__all__ = ["ForceSensor", "first_order_alpha"]


def first_order_alpha(name: str, cutoff: float, sample_time: float) -> float:
    """α = 1 − exp(−2π f_c Ts) of the first-order low-pass ``y_k = y_{k−1} + α (x_k − y_{k−1})``.

    Raises:
        ParameterError: the cut-off ``name`` is at or above the Nyquist frequency 1/(2 Ts).
    """
    nyquist = 0.5 / sample_time
    if cutoff >= nyquist:
        raise ParameterError(
            f"{name} must be below the Nyquist frequency {nyquist:.6g} Hz for sample_time "
            f"{sample_time:.6g} s; got {cutoff:.6g} Hz"
        )
    return 1.0 - math.exp(-2.0 * math.pi * cutoff * sample_time)


class ForceSensor:
    """A wrist force sensor sampled at the control rate.

    Measurement at sample k: ``raw_k = h_e(t_k) + bias + noise_k`` with ``noise_k`` Gaussian of
    standard deviation ``noise_std`` (per component), then a first-order low-pass
    ``y_k = y_{k−1} + α (raw_k − y_{k−1})``, ``α = 1 − exp(−2π f_c Ts)``, started at ``y_0 = raw_0``.
    The noise sequence is drawn once per run from ``seed`` so that the Python and compiled loops
    see the same numbers.

    Args:
        noise_std: standard deviation of the noise [N], scalar or per component; 0 = none.
        bias: constant offset [N], scalar or per component.
        cutoff: low-pass cut-off frequency f_c [Hz]; None = no filter. Must be below Nyquist.
        seed: seed of the noise generator.
    """

    def __init__(self, noise_std: Any = 0.0, bias: Any = 0.0, cutoff: float | None = None, seed: int = 0) -> None:
        self.noise_std = np.array(noise_std, dtype=np.float64)
        self.bias = np.array(bias, dtype=np.float64)
        for name, v in (("noise_std", self.noise_std), ("bias", self.bias)):
            if v.ndim > 1:
                raise DimensionError(f"{name} must be a scalar or a vector; got shape {v.shape}")
            if not np.all(np.isfinite(v)):
                raise ParameterError(f"{name} must be finite; got {v.tolist()}")
        if np.any(self.noise_std < 0):
            raise ParameterError(f"noise_std must be non-negative; got {self.noise_std.tolist()}")
        self.cutoff = None if cutoff is None else positive_scalar("cutoff", cutoff)
        if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or not 0 <= int(seed) < 2**63:
            raise ParameterError(f"seed must be an integer in [0, 2**63); got {seed!r}")
        self.seed = int(seed)

    @property
    def compiled_ok(self) -> bool:
        """True when the simulator may run this sensor inline in its compiled loop (simple kind)."""
        return True

    @property
    def exact(self) -> bool:
        """True when the sensor returns the true wrench unchanged."""
        return self.cutoff is None and not np.any(self.noise_std) and not np.any(self.bias)

    def alpha(self, sample_time: float) -> float:
        """Low-pass coefficient α for the sample time; 1 when there is no filter.

        Raises:
            ParameterError: the cut-off is at or above the Nyquist frequency 1/(2 Ts).
        """
        return 1.0 if self.cutoff is None else first_order_alpha("cutoff", self.cutoff, sample_time)

    def sequences(self, n_samples: int, dim: int) -> tuple[np.ndarray, np.ndarray]:
        """The bias (dim,) and the noise (n_samples, dim) of one run."""
        try:
            bias = np.broadcast_to(self.bias, (dim,)).astype(np.float64)
            std = np.broadcast_to(self.noise_std, (dim,)).astype(np.float64)
        except ValueError as exc:
            raise DimensionError(
                f"bias and noise_std must be scalars or have shape ({dim},); got shapes "
                f"{self.bias.shape} and {self.noise_std.shape}"
            ) from exc
        if np.any(std):
            noise = np.random.default_rng(self.seed).standard_normal((n_samples, dim)) * std
        else:
            noise = np.zeros((n_samples, dim))
        return bias, noise

    def describe(self) -> dict[str, Any]:
        return {
            "noise_std": self.noise_std.tolist(),
            "bias": self.bias.tolist(),
            "cutoff": self.cutoff,
            "seed": self.seed,
        }


# --------------------------------------------------------------------------- realistic sensor

_FILTERS = ("none", "first-order", "butterworth")


