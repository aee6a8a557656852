"""The layouts of the flat vectors a law reads: parameters ``p``, reference ``ref``, state ``s``, each declared once.

A law's parameters travel as one flat float64 array (one compiled signature for every law), but
no law reads them by a number: each vector is declared once below as :class:`Blocks`, an ordered
list of named blocks whose sizes are products of the vector's dimensions, e.g. ::

    IMPEDANCE = Blocks("impedance", "m", ("M_d_inv", "m*m"), ("K_D", "m*m"), ("K_P", "m*m"), ("use_force", "1"))

From the one declaration come

* on the Python side, the packer the controllers use: ``IMPEDANCE.pack(m, M_d_inv=..., K_D=...,
  K_P=..., use_force=...)`` checks the block names and sizes and is the only place a vector is
  concatenated; ``IMPEDANCE.slice("K_D", m)`` addresses a block of a packed vector;
* inside the laws, the offset of each block, by name: a compiled function
  ``<name>_<block>(*dims)`` (``impedance_K_P(m)`` = 2 m²) when the offset depends on the
  dimensions, an int constant ``<NAME>_<BLOCK>`` (``HYBRID_RIGID_TASK_DIM`` = 0) when it does not.
  A law writes ``p[impedance_K_P(m) + i * m + j]``; the functions are plain scalar arithmetic
  compiled ``inline="always"``, so the machine code is that of the hand-written offsets they
  replace (no views, no allocation) and they are cached with the laws.

The offset functions below are written by hand, next to their declaration;
``tests/test_law_layout.py`` checks every one of them (and every constant) against the declaration
for each dimension from 1 to 6, so the two cannot drift apart, and checks that no law indexes
``p``, ``ref``, ``s`` or ``G`` by a number.

Row-major matrices; m = task dimension, n = joints; hybrid: d = task dimension, k = force-controlled
directions, l = d − k.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from ..core.axes import REFERENCE_FIELDS
from ..errors import DimensionError, ParameterError

__all__ = [
    "Blocks",
    "REFERENCE",
    "OS_PD",
    "JOINT_PD",
    "IMPEDANCE",
    "FORCE",
    "FORCE_STATE",
    "HYBRID_COMPLIANT",
    "HYBRID_RIGID",
    "HYBRID_STATE",
    "DECLARATIONS",
]


class Blocks:
    """Named blocks of a flat float64 vector, in order.

    Args:
        name: the prefix of the offset functions and constants (``"impedance"``).
        dims: the vector's dimensions, a name or a tuple of names (``"m"``, ``("d", "l", "k")``).
        *blocks: ``(block, size)`` pairs; a size is a product of dimensions and integers
            (``"m*m"``, ``"d*l"``, ``"1"``).
    """

    def __init__(self, name: str, dims: str | tuple[str, ...], *blocks: tuple[str, str]) -> None:
        self.name = name
        self.dims = (dims,) if isinstance(dims, str) else tuple(dims)
        self.blocks: dict[str, tuple[str, ...]] = {}
        for block, size in blocks:
            factors = tuple(f.strip() for f in str(size).split("*"))
            bad = [f for f in factors if not (f.isdigit() or f in self.dims)]
            if bad or block in self.blocks:
                raise ParameterError(
                    f"Blocks {name}: block {block!r} must be new and its size a product of integers and "
                    f"the dimensions {self.dims}; got {size!r}"
                )
            self.blocks[block] = factors
        #: ``(block, dims) -> slice`` of the blocks already addressed (the declaration never changes):
        #: a controller that repacks blocks every sample asks the same few each time
        self._slices: dict[tuple[str, tuple[int, ...]], slice] = {}

    def _dims(self, dims: tuple[int, ...]) -> dict[str, int]:
        if len(dims) != len(self.dims) or not all(isinstance(v, (int, np.integer)) and v >= 0 for v in dims):
            raise DimensionError(f"{self.name}: expected the dimensions {self.dims} as non-negative integers; got {dims}")
        return dict(zip(self.dims, (int(v) for v in dims)))

    def _size(self, block: str, env: dict[str, int]) -> int:
        out = 1
        for f in self.blocks[block]:
            out *= int(f) if f.isdigit() else env[f]
        return out

    def _block(self, block: str) -> None:
        if block not in self.blocks:
            raise ParameterError(f"{self.name}: no block {block!r}; expected one of {list(self.blocks)}")

    def size(self, *dims: int) -> int:
        """Floats in the whole vector for these dimensions."""
        env = self._dims(dims)
        return sum(self._size(b, env) for b in self.blocks)

    def offset(self, block: str, *dims: int) -> int:
        """Where ``block`` starts, for these dimensions."""
        self._block(block)
        env = self._dims(dims)
        o = 0
        for b in self.blocks:
            if b == block:
                return o
            o += self._size(b, env)
        raise AssertionError  # pragma: no cover - _block checked it

    def slice(self, block: str, *dims: int) -> slice:
        """The slice of ``block`` in a packed vector."""
        key = (block, dims)
        out = self._slices.get(key) if all(type(v) is int for v in dims) else None
        if out is None:
            o = self.offset(block, *dims)
            out = slice(o, o + self._size(block, self._dims(dims)))
            if all(type(v) is int for v in dims):
                self._slices[key] = out
        return out

    def fixed(self, block: str) -> bool:
        """True when the offset of ``block`` does not depend on the dimensions (it is a constant)."""
        self._block(block)
        for b in self.blocks:
            if b == block:
                return True
            if any(not f.isdigit() for f in self.blocks[b]):
                return False
        raise AssertionError  # pragma: no cover

    def accessor(self, block: str) -> str:
        """The name of the offset of ``block`` in this module: a function, or a constant when fixed."""
        self._block(block)
        return f"{self.name}_{block}".upper() if self.fixed(block) else f"{self.name}_{block}"

    def pack(self, *dims: int, **values: Any) -> np.ndarray:
        """The flat float64 vector of every block, in order (each named once, of its declared size)."""
        env = self._dims(dims)
        missing = [b for b in self.blocks if b not in values]
        unknown = [b for b in values if b not in self.blocks]
        if missing or unknown:
            raise ParameterError(f"{self.name}: expected the blocks {list(self.blocks)}; missing {missing}, unknown {unknown}")
        parts = []
        for b in self.blocks:
            v = np.ravel(np.asarray(values[b], dtype=np.float64))
            want = self._size(b, env)
            if v.shape[0] != want:
                raise DimensionError(f"{self.name}: block {b} must hold {want} floats for {env}; got {v.shape[0]}")
            parts.append(v)
        return np.concatenate(parts) if parts else np.zeros(0)


# ---------------------------------------------------------------------------------------------- reference
#: The reference row ``[x_d, ẋ_d, ẍ_d, f_d, ḟ_d, f̈_d]``, one block per field of
#: :data:`~forcecontrol.core.axes.REFERENCE_FIELDS`, in that order.
REFERENCE = Blocks("ref", "m", ("x_d", "m"), ("v_d", "m"), ("a_d", "m"), ("f_d", "m"), ("fdot_d", "m"), ("fddot_d", "m"))
REFERENCE_OF_FIELD = dict(zip(REFERENCE_FIELDS, REFERENCE.blocks))
REF_X_D = 0


@njit(inline="always", cache=True)
def ref_v_d(m):  # pragma: no cover - compiled
    return m


@njit(inline="always", cache=True)
def ref_a_d(m):  # pragma: no cover - compiled
    return 2 * m


@njit(inline="always", cache=True)
def ref_f_d(m):  # pragma: no cover - compiled
    return 3 * m


@njit(inline="always", cache=True)
def ref_fdot_d(m):  # pragma: no cover - compiled
    return 4 * m


@njit(inline="always", cache=True)
def ref_fddot_d(m):  # pragma: no cover - compiled
    return 5 * m


@njit(inline="always", cache=True)
def ref_size(m):  # pragma: no cover - compiled
    """Floats in the reference row."""
    return 6 * m


# ---------------------------------------------------------------------------------------------- (8.110), (8.51)
#: (8.110): operational-space PD, no state.
OS_PD = Blocks("os_pd", "m", ("K_P", "m*m"), ("K_D", "m*m"))
OS_PD_K_P = 0


@njit(inline="always", cache=True)
def os_pd_K_D(m):  # pragma: no cover - compiled
    return m * m


#: (8.51): joint-space PD in the number of joints n, no state.
JOINT_PD = Blocks("joint_pd", "n", ("K_P", "n*n"), ("K_D", "n*n"), ("q_d", "n"))
JOINT_PD_K_P = 0


@njit(inline="always", cache=True)
def joint_pd_K_D(n):  # pragma: no cover - compiled
    return n * n


@njit(inline="always", cache=True)
def joint_pd_q_d(n):  # pragma: no cover - compiled
    return 2 * n * n


# ---------------------------------------------------------------------------------------------- (9.28)/(9.31)
#: (9.28)/(9.31): impedance; ``use_force`` 1 with force measurement. Its first three blocks are the
#: ``G`` of :func:`~forcecontrol.laws.impedance.impedance_core`.
IMPEDANCE = Blocks("impedance", "m", ("M_d_inv", "m*m"), ("K_D", "m*m"), ("K_P", "m*m"), ("use_force", "1"))
IMPEDANCE_M_D_INV = 0


@njit(inline="always", cache=True)
def impedance_K_D(m):  # pragma: no cover - compiled
    return m * m


@njit(inline="always", cache=True)
def impedance_K_P(m):  # pragma: no cover - compiled
    return 2 * m * m


@njit(inline="always", cache=True)
def impedance_use_force(m):  # pragma: no cover - compiled
    return 3 * m * m


# ---------------------------------------------------------------------------------------------- Sect. 9.4
#: The three direct force laws (:mod:`forcecontrol.laws.force`): K_F, K_I the diagonals of C_F in
#: the task frame whose axes are the columns of R; ``limit`` the anti-windup half-band; ``bumpless`` 1
#: for ``integrator_start = "tip"``.
FORCE = Blocks(
    "force", "m", ("M_d_inv", "m*m"), ("K_D", "m*m"), ("K_P", "m*m"), ("K_F", "m"), ("K_I", "m"), ("limit", "m"),
    ("R", "m*m"), ("bumpless", "1"),
)
FORCE_M_D_INV = 0


@njit(inline="always", cache=True)
def force_K_D(m):  # pragma: no cover - compiled
    return m * m


@njit(inline="always", cache=True)
def force_K_P(m):  # pragma: no cover - compiled
    return 2 * m * m


@njit(inline="always", cache=True)
def force_K_F(m):  # pragma: no cover - compiled
    return 3 * m * m


@njit(inline="always", cache=True)
def force_K_I(m):  # pragma: no cover - compiled
    return 3 * m * m + m


@njit(inline="always", cache=True)
def force_limit(m):  # pragma: no cover - compiled
    return 3 * m * m + 2 * m


@njit(inline="always", cache=True)
def force_R(m):  # pragma: no cover - compiled
    return 3 * m * m + 3 * m


@njit(inline="always", cache=True)
def force_bumpless(m):  # pragma: no cover - compiled
    return 4 * m * m + 3 * m


#: State of the PI force loop: ξ, ξ₀ (the centre of its anti-windup band), f_s (Rᵀ f_d of the previous sample).
FORCE_STATE = Blocks("force_state", "m", ("xi", "m"), ("xi0", "m"), ("f_s", "m"))
FORCE_STATE_XI = 0


@njit(inline="always", cache=True)
def force_state_xi0(m):  # pragma: no cover - compiled
    return m


@njit(inline="always", cache=True)
def force_state_f_s(m):  # pragma: no cover - compiled
    return 2 * m


# ---------------------------------------------------------------------------------------------- Sect. 9.7
#: (9.77)–(9.82): hybrid control on a compliant environment; ``L_hat`` = (S_fᵀ Ĉ S_f)⁻¹ S_fᵀ
#: (λ̇ = L̂ v_e (9.82)); K_1, K_2 as for the rigid law.
HYBRID_COMPLIANT = Blocks(
    "hybrid_compliant", ("d", "l", "k"), ("task_dim", "1"), ("force_dim", "1"), ("position_mode", "1"),
    ("S_v", "d*l"), ("S_v_pinv", "l*d"), ("S_f_pinv", "k*d"), ("CpS_f", "d*k"), ("L_hat", "k*d"),
    ("K_1", "l*l"), ("K_2", "l*l"), ("K_Dlam", "k*k"), ("K_Plam", "k*k"),
)
HYBRID_COMPLIANT_TASK_DIM = 0
HYBRID_COMPLIANT_FORCE_DIM = 1
HYBRID_COMPLIANT_POSITION_MODE = 2
HYBRID_COMPLIANT_S_V = 3


@njit(inline="always", cache=True)
def hybrid_compliant_S_v_pinv(d, l, k):  # pragma: no cover - compiled
    return 3 + d * l


@njit(inline="always", cache=True)
def hybrid_compliant_S_f_pinv(d, l, k):  # pragma: no cover - compiled
    return 3 + 2 * d * l


@njit(inline="always", cache=True)
def hybrid_compliant_CpS_f(d, l, k):  # pragma: no cover - compiled
    return 3 + 2 * d * l + k * d


@njit(inline="always", cache=True)
def hybrid_compliant_L_hat(d, l, k):  # pragma: no cover - compiled
    return 3 + 2 * d * l + 2 * k * d


@njit(inline="always", cache=True)
def hybrid_compliant_K_1(d, l, k):  # pragma: no cover - compiled
    return 3 + 2 * d * l + 3 * k * d


@njit(inline="always", cache=True)
def hybrid_compliant_K_2(d, l, k):  # pragma: no cover - compiled
    return 3 + 2 * d * l + 3 * k * d + l * l


@njit(inline="always", cache=True)
def hybrid_compliant_K_Dlam(d, l, k):  # pragma: no cover - compiled
    return 3 + 2 * d * l + 3 * k * d + 2 * l * l


@njit(inline="always", cache=True)
def hybrid_compliant_K_Plam(d, l, k):  # pragma: no cover - compiled
    return 3 + 2 * d * l + 3 * k * d + 2 * l * l + k * k


#: (9.91)–(9.95): hybrid control on a rigid environment; K_1, K_2 = K_Pν, K_Iν (velocity motion
#: (9.80)) or K_Dr, K_Pr (position motion (9.95)); ``S_v_dot`` = Ṡ_v of a moving constraint frame.
HYBRID_RIGID = Blocks(
    "hybrid_rigid", ("d", "l", "k"), ("task_dim", "1"), ("force_dim", "1"), ("position_mode", "1"),
    ("S_v", "d*l"), ("S_v_pinv", "l*d"), ("S_f", "d*k"), ("S_f_pinv", "k*d"), ("K_1", "l*l"), ("K_2", "l*l"),
    ("K_Plam", "k*k"), ("K_Ilam", "k*k"), ("S_v_dot", "d*l"),
)
HYBRID_RIGID_TASK_DIM = 0
HYBRID_RIGID_FORCE_DIM = 1
HYBRID_RIGID_POSITION_MODE = 2
HYBRID_RIGID_S_V = 3


@njit(inline="always", cache=True)
def hybrid_rigid_S_v_pinv(d, l, k):  # pragma: no cover - compiled
    return 3 + d * l


@njit(inline="always", cache=True)
def hybrid_rigid_S_f(d, l, k):  # pragma: no cover - compiled
    return 3 + 2 * d * l


@njit(inline="always", cache=True)
def hybrid_rigid_S_f_pinv(d, l, k):  # pragma: no cover - compiled
    return 3 + 2 * d * l + d * k


@njit(inline="always", cache=True)
def hybrid_rigid_K_1(d, l, k):  # pragma: no cover - compiled
    return 3 + 2 * d * l + 2 * d * k


@njit(inline="always", cache=True)
def hybrid_rigid_K_2(d, l, k):  # pragma: no cover - compiled
    return 3 + 2 * d * l + 2 * d * k + l * l


@njit(inline="always", cache=True)
def hybrid_rigid_K_Plam(d, l, k):  # pragma: no cover - compiled
    return 3 + 2 * d * l + 2 * d * k + 2 * l * l


@njit(inline="always", cache=True)
def hybrid_rigid_K_Ilam(d, l, k):  # pragma: no cover - compiled
    return 3 + 2 * d * l + 2 * d * k + 2 * l * l + k * k


@njit(inline="always", cache=True)
def hybrid_rigid_S_v_dot(d, l, k):  # pragma: no cover - compiled
    return 3 + 2 * d * l + 2 * d * k + 2 * l * l + 2 * k * k


#: State of the hybrid laws: ∫(ν_d − ν) (both), ∫(λ_d − λ) (the rigid law; the compliant law's
#: state is the first block only).
HYBRID_STATE = Blocks("hybrid_state", ("l", "k"), ("nu_integral", "l"), ("lam_integral", "k"))
HYBRID_STATE_NU_INTEGRAL = 0


@njit(inline="always", cache=True)
def hybrid_state_lam_integral(l, k):  # pragma: no cover - compiled
    return l


#: Every declaration of this module (the tests walk them).
DECLARATIONS = (REFERENCE, OS_PD, JOINT_PD, IMPEDANCE, FORCE, FORCE_STATE, HYBRID_COMPLIANT, HYBRID_RIGID, HYBRID_STATE)
