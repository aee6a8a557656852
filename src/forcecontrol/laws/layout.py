"""The layouts of the flat vectors a law reads (parameters ``p``, reference ``ref``, state ``s``), each declared once.

A law's parameters travel as one flat float64 array (one compiled signature for every law), but
no law reads them by offset: each vector is declared once as a :class:`Layout`, an ordered list
of named blocks whose sizes are expressions in the task dimensions, e.g. ::

    IMPEDANCE = Layout("impedance", "m", Md_inv=("m", "m"), K_D=("m", "m"), K_P=("m", "m"), use_force=SCALAR)

From the one declaration come

* the packer the controller uses, ``IMPEDANCE.pack(m, Md_inv=..., K_D=..., K_P=..., use_force=...)``,
  which checks every block's size (:class:`~forcecontrol.errors.DimensionError` naming the block)
  and is the only place a vector is concatenated;
* the compiled accessors the laws use, ``K_P = IMPEDANCE.view("K_P")``: ``K_P(p, m)`` is the
  block, a view of ``p`` (``(m, m)`` for a matrix block, ``(m,)`` for a vector block, a float
  for a ``SCALAR``). An accessor takes the dimensions its offset and size use, in the order of
  the layout's dimensions (none for a block at a fixed offset).

The accessors are generated as source (shown by :meth:`Layout.source`) with the offsets written
as sums of the preceding blocks' sizes, compiled ``inline="always"``: inside a law they are the
same slice arithmetic the law wrote by hand before, so the machine code and the results are
unchanged. They are not cached on their own (they are inlined into the laws, which are).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from ..core.axes import REFERENCE_FIELDS
from ..errors import DimensionError, ParameterError

__all__ = [
    "SCALAR", "Layout", "REFERENCE", "OS_PD", "JOINT_PD", "IMPEDANCE", "FORCE", "FORCE_STATE",
    "HYBRID_COMPLIANT", "HYBRID_RIGID", "HYBRID_STATE",
]

#: A block of one float (the accessor returns the float, not a view).
SCALAR = "scalar"


class Layout:
    """Named blocks of a flat float64 vector, in order; sizes are expressions in ``dims``.

    A block is ``SCALAR``, a vector size (an expression string, ``"m"``, ``"m*m"``) or a matrix
    shape (a pair of expression strings, ``("d", "l")``, stored row-major).
    """

    def __init__(self, name: str, dims: str | tuple[str, ...], **blocks: Any) -> None:
        self.name = name
        self.dims = (dims,) if isinstance(dims, str) else tuple(dims)
        self.blocks: dict[str, Any] = dict(blocks)
        self._offsets: dict[str, str] = {}
        o: list[str] = []
        for key, spec in self.blocks.items():
            self._offsets[key] = " + ".join(o) or "0"
            o.append(f"({self._size_expr(spec)})")
            for d in self._names(self._size_expr(spec)):
                if d not in self.dims:
                    raise ParameterError(f"layout {name}: block {key} uses {d!r}; expected one of the dimensions {self.dims}")
        self._total = " + ".join(o) or "0"
        self._views: dict[str, Any] = {}

    @staticmethod
    def _size_expr(spec: Any) -> str:
        if spec == SCALAR:
            return "1"
        if isinstance(spec, tuple):
            return f"({spec[0]}) * ({spec[1]})"
        return str(spec)

    @staticmethod
    def _names(expr: str) -> tuple[str, ...]:
        return compile(expr, "<layout>", "eval").co_names

    def _eval(self, expr: str, dims: tuple[int, ...]) -> int:
        return int(eval(expr, {"__builtins__": {}}, dict(zip(self.dims, dims))))  # noqa: S307 - the declarations above

    def _check_dims(self, dims: tuple[int, ...]) -> None:
        if len(dims) != len(self.dims):
            raise DimensionError(f"layout {self.name}: expected the dimensions {self.dims}; got {dims}")

    def size(self, *dims: int) -> int:
        """Floats in the vector for these dimensions."""
        self._check_dims(dims)
        return self._eval(self._total, dims)

    def shape(self, key: str, *dims: int) -> tuple[int, ...]:
        """The shape of block ``key`` (``()`` for a scalar)."""
        self._check_dims(dims)
        spec = self.blocks[key]
        if spec == SCALAR:
            return ()
        if isinstance(spec, tuple):
            return (self._eval(spec[0], dims), self._eval(spec[1], dims))
        return (self._eval(spec, dims),)

    def pack(self, *dims: int, **values: Any) -> np.ndarray:
        """The flat vector of these blocks (every block named, each of its declared shape), float64."""
        self._check_dims(dims)
        missing = [k for k in self.blocks if k not in values]
        extra = [k for k in values if k not in self.blocks]
        if missing or extra:
            raise ParameterError(
                f"layout {self.name}: expected the blocks {list(self.blocks)}; missing {missing}, unknown {extra}"
            )
        parts = []
        for key in self.blocks:
            want = self.shape(key, *dims)
            v = np.asarray(values[key], dtype=np.float64)
            if v.size != int(np.prod(want)) or (v.ndim > 1 and v.shape != want):
                raise DimensionError(f"{self.name}: block {key} must have shape {want}; got shape {v.shape}")
            parts.append(v.ravel())
        return np.concatenate(parts) if parts else np.zeros(0)

    def args(self, key: str) -> tuple[str, ...]:
        """The dimensions the accessor of block ``key`` takes after the vector (those its offset and size use)."""
        used = set(self._names(self._offsets[key])) | set(self._names(self._size_expr(self.blocks[key])))
        return tuple(d for d in self.dims if d in used)

    def source(self, key: str) -> str:
        """The Python source of the accessor of block ``key`` (what :meth:`view` compiles)."""
        spec = self.blocks[key]
        lo = self._offsets[key]
        args = ", ".join(["v", *self.args(key)])
        head = f"# generated by forcecontrol.laws.layout from the declaration of {self.name!r}, block {key!r}\n"
        if spec == SCALAR:
            body = f"    return v[{lo}]\n"
        elif isinstance(spec, tuple):
            body = f"    return v[{lo} : {lo} + ({self._size_expr(spec)})].reshape(({spec[0]}, {spec[1]}))\n"
        else:
            body = f"    return v[{lo} : {lo} + ({spec})]\n"
        return f"{head}def {self.name}_{key}({args}):\n{body}"

    def view(self, key: str) -> Any:
        """The compiled accessor of block ``key`` (see the module docstring)."""
        if key not in self.blocks:
            raise ParameterError(f"layout {self.name}: no block {key!r}; expected one of {list(self.blocks)}")
        fn = self._views.get(key)
        if fn is None:
            scope: dict[str, Any] = {}
            exec(compile(self.source(key), f"<layout {self.name}.{key}>", "exec"), scope)  # noqa: S102 - generated above
            fn = self._views[key] = njit(inline="always")(scope[f"{self.name}_{key}"])
        return fn


MM = ("m", "m")

#: The reference row ``[x_d, ẋ_d, ẍ_d, f_d, ḟ_d, f̈_d]`` (:data:`~forcecontrol.core.axes.REFERENCE_FIELDS`).
REFERENCE = Layout("reference", "m", **{f: "m" for f in REFERENCE_FIELDS})
#: (8.110): operational-space PD.
OS_PD = Layout("os_pd", "m", K_P=MM, K_D=MM)
#: (8.51): joint-space PD, in the number of joints n.
JOINT_PD = Layout("joint_pd", "n", K_P=("n", "n"), K_D=("n", "n"), q_d="n")
#: (9.28)/(9.31): impedance; ``use_force`` 1 with force measurement.
IMPEDANCE = Layout("impedance", "m", Md_inv=MM, K_D=MM, K_P=MM, use_force=SCALAR)
#: Sect. 9.4, the three direct force laws (:mod:`forcecontrol.laws.force`).
FORCE = Layout("force", "m", Md_inv=MM, K_D=MM, K_P=MM, K_F="m", K_I="m", limit="m", R=MM, bumpless=SCALAR)
#: The PI force loop's state: ξ, ξ₀ (the centre of the anti-windup band), f_s (Rᵀ f_d of the previous sample).
FORCE_STATE = Layout("force_state", "m", xi="m", xi0="m", f_s="m")
_HEAD = {"task_dim": SCALAR, "force_dim": SCALAR, "position_mode": SCALAR}
#: (9.77)–(9.82); d = task dimension, k = force-controlled, l = d − k.
HYBRID_COMPLIANT = Layout(
    "hybrid_compliant", ("d", "l", "k"), **_HEAD, S_v=("d", "l"), S_v_pinv=("l", "d"), S_f_pinv=("k", "d"),
    CpS_f=("d", "k"), L_hat=("k", "d"), K_1=("l", "l"), K_2=("l", "l"), K_Dlam=("k", "k"), K_Plam=("k", "k"),
)
#: (9.91)–(9.95); K_1, K_2 = K_Pν, K_Iν (velocity motion (9.80)) or K_Dr, K_Pr (position motion (9.95)).
HYBRID_RIGID = Layout(
    "hybrid_rigid", ("d", "l", "k"), **_HEAD, S_v=("d", "l"), S_v_pinv=("l", "d"), S_f=("d", "k"), S_f_pinv=("k", "d"),
    K_1=("l", "l"), K_2=("l", "l"), K_Plam=("k", "k"), K_Ilam=("k", "k"), S_v_dot=("d", "l"),
)
#: State of the hybrid laws: ∫(ν_d − ν) (both), ∫(λ_d − λ) (the rigid law only; the compliant law's state is the first block).
HYBRID_STATE = Layout("hybrid_state", ("l", "k"), nu_integral="l", lam_integral="k")
