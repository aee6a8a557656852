"""The layouts of p, ref and s (forcecontrol.laws.layout): offsets by name, one declaration each, no numbers in the laws."""

from __future__ import annotations

import ast
import itertools
from pathlib import Path

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.controllers.hybrid import HybridRigidController
from forcecontrol.controllers.signals import REFERENCE_FIELDS, Reference, pack_reference
from forcecontrol.errors import DimensionError, ParameterError
from forcecontrol.laws import layout
from forcecontrol.laws.layout import DECLARATIONS, FORCE, FORCE_STATE, HYBRID_RIGID, IMPEDANCE, REFERENCE, Blocks
from forcecontrol.task import inclined_plane

LAWS = Path(layout.__file__).parent
ARM = fc.CHAPTER_ARM


def _dims(decl: Blocks):
    """Every dimension tuple from 1 to 6 (hybrid: d = 1..6, k = 0..d, l = d − k)."""
    if decl.dims == ("d", "l", "k"):
        return [(d, d - k, k) for d in range(1, 7) for k in range(d + 1)]
    return list(itertools.product(range(1, 7), repeat=len(decl.dims)))


@pytest.mark.parametrize("decl", DECLARATIONS, ids=lambda d: d.name)
def test_offsets_equal_the_declaration(decl: Blocks) -> None:
    """Each block's offset constant or compiled offset function equals the declaration's offset for dimensions 1 to 6."""
    for block in decl.blocks:
        name = decl.accessor(block)
        assert hasattr(layout, name), f"{decl.name}: block {block} has no offset {name} in laws/layout.py"
        acc = getattr(layout, name)
        for dims in _dims(decl):
            want = decl.offset(block, *dims)
            if decl.fixed(block):
                assert type(acc) is int and acc == want, (name, dims)
            else:
                assert acc.py_func(*dims) == want, (name, dims)
        if not decl.fixed(block):
            dims = _dims(decl)[-1]
            assert acc(*dims) == decl.offset(block, *dims), f"{name} compiled"


def test_no_stray_offsets() -> None:
    """Every offset function or constant in laws/layout.py belongs to a declared block (none left after a block is removed)."""
    declared = {decl.accessor(b) for decl in DECLARATIONS for b in decl.blocks} | {"ref_size"}
    prefixes = tuple(d.name + "_" for d in DECLARATIONS) + tuple(d.name.upper() + "_" for d in DECLARATIONS)
    found = {n for n, v in vars(layout).items() if n.startswith(prefixes) and (callable(v) or type(v) is int)}
    assert found == declared
    for m in range(1, 7):
        assert layout.ref_size.py_func(m) == REFERENCE.size(m) == 6 * m


def test_reference_blocks_follow_the_fields() -> None:
    """The REFERENCE declaration has one block per REFERENCE_FIELDS entry, in order: pack_reference and REFERENCE.pack agree."""
    assert list(layout.REFERENCE_OF_FIELD) == list(REFERENCE_FIELDS)
    rng = np.random.default_rng(3)
    for m in (2, 6):
        ref = Reference(*(rng.normal(size=m) for _ in REFERENCE_FIELDS))
        want = REFERENCE.pack(m, **{layout.REFERENCE_OF_FIELD[f]: getattr(ref, f) for f in REFERENCE_FIELDS})
        np.testing.assert_array_equal(pack_reference(ref), want)


def test_controllers_pack_what_the_laws_read() -> None:
    """The controllers' packed vectors hold each gain at its declared block (impedance, force, rigid hybrid)."""
    imp = fc.ImpedanceController(ARM, 10.0, [[500.0, 1.0], [1.0, 400.0]], [[2500.0, 3.0], [3.0, 2000.0]])
    np.testing.assert_array_equal(imp._params[IMPEDANCE.slice("K_D", 2)], imp.damping.ravel())
    np.testing.assert_array_equal(imp._params[IMPEDANCE.slice("K_P", 2)], imp.stiffness.ravel())
    assert imp._params[IMPEDANCE.offset("use_force", 2)] == 1.0
    assert imp._params.shape == (IMPEDANCE.size(2),)
    assert list(IMPEDANCE.blocks)[:3] == ["M_d_inv", "K_D", "K_P"]  # the G the 6-D controllers concatenate per sample
    frc = fc.InnerPositionForceController(ARM, 100, 500, 2500, force_gain=[0.00064, 0.0], integral_gain=[0.0016, 0.0])
    np.testing.assert_array_equal(frc._params[FORCE.slice("K_F", 2)], [0.00064, 0.0])
    np.testing.assert_array_equal(frc._params[FORCE.slice("K_I", 2)], [0.0016, 0.0])
    np.testing.assert_array_equal(frc._params[FORCE.slice("R", 2)], np.eye(2).ravel())
    assert frc.state.shape == (FORCE_STATE.size(2),)
    hyb = HybridRigidController(ARM, inclined_plane(), velocity_gain=60.0, velocity_integral_gain=900.0, force_integral_gain=80.0)
    d, k = 2, 1
    p = hyb._params
    assert (p[layout.HYBRID_RIGID_TASK_DIM], p[layout.HYBRID_RIGID_FORCE_DIM]) == (d, k)
    np.testing.assert_array_equal(p[HYBRID_RIGID.slice("K_Ilam", d, d - k, k)], hyb.force_integral_gain.ravel())
    assert p.shape == (HYBRID_RIGID.size(d, d - k, k),)


@pytest.mark.parametrize(
    ("make", "error", "match"),
    [
        (lambda: Blocks("x", "m", ("A", "m*q")), ParameterError, r"block 'A' must be new .* dimensions \('m',\); got 'm\*q'"),
        (lambda: Blocks("x", "m", ("A", "m"), ("A", "1")), ParameterError, r"block 'A' must be new"),
        (lambda: IMPEDANCE.size(2, 3), DimensionError, r"impedance: expected the dimensions \('m',\).*got \(2, 3\)"),
        (lambda: IMPEDANCE.size(-1), DimensionError, r"non-negative integers; got \(-1,\)"),
        (lambda: IMPEDANCE.offset("K_I", 2), ParameterError, r"impedance: no block 'K_I'; expected one of \['M_d_inv'"),
        (lambda: IMPEDANCE.pack(2, M_d_inv=np.eye(2), K_D=np.eye(2), K_P=np.eye(2)), ParameterError,
         r"impedance: expected the blocks .* missing \['use_force'\], unknown \[\]"),
        (lambda: IMPEDANCE.pack(2, M_d_inv=np.eye(2), K_D=np.eye(2), K_P=np.eye(2), use_force=1.0, K_I=1.0), ParameterError,
         r"missing \[\], unknown \['K_I'\]"),
        (lambda: IMPEDANCE.pack(2, M_d_inv=np.eye(2), K_D=np.eye(3), K_P=np.eye(2), use_force=1.0), DimensionError,
         r"impedance: block K_D must hold 4 floats for \{'m': 2\}; got 9"),
    ],
)
def test_blocks_refuse_bad_declarations_and_values(make, error, match) -> None:
    """A bad declaration, unknown block, wrong dimension count, missing/unknown name or wrong size is refused, named."""
    with pytest.raises(error, match=match):
        make()


# ---------------------------------------------------------------------------------------------- no numbers in the laws
#: The flat vectors the laws read by offset.
VECTORS = {"p", "ref", "s", "G"}
#: Names of dimensions (and their squares) in the laws.
DIMS = {"m", "mm", "n", "nn", "d", "k", "l"}
#: Helpers that take an offset into one of the vectors: the positions of their offset arguments.
OFFSET_ARGS = {"pd_action": (1, 3), "_block": (1,), "_part": (1,)}


def _terms(node: ast.expr) -> list[ast.expr]:
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
        return _terms(node.left) + _terms(node.right)
    return [node]


def _offset_faults(node: ast.expr, assigned: dict[str, list[ast.expr]], size_allowed: bool, depth: int = 0) -> list[str]:
    """Why an offset expression is not by name: an integer literal, or a term made of dimensions only (m, 2 * m, m * m)."""
    out = []
    for sub in ast.walk(node):
        if isinstance(sub, ast.Constant) and type(sub.value) is int:
            out.append(f"the number {sub.value}")
    if not size_allowed:
        for term in _terms(node):
            names = {n.id for n in ast.walk(term) if isinstance(n, ast.Name)}
            calls = [n for n in ast.walk(term) if isinstance(n, ast.Call)]
            if names and names <= DIMS and not calls:
                out.append(f"the dimension term {ast.unparse(term)}")
    if depth < 3:  # a local offset variable (oR = force_R(m)) is checked where it is assigned
        for name in {n.id for n in ast.walk(node) if isinstance(n, ast.Name)} - DIMS:
            for rhs in assigned.get(name, []):
                out += _offset_faults(rhs, assigned, size_allowed, depth + 1)
    return out


def _law_offset_faults(path: Path) -> list[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    faults = []
    for fn in [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)]:
        assigned: dict[str, list[ast.expr]] = {}
        for node in ast.walk(fn):
            if isinstance(node, ast.Assign):
                for target in node.targets:
                    if isinstance(target, ast.Name):
                        assigned.setdefault(target.id, []).append(node.value)
        checks: list[tuple[ast.expr, bool, ast.AST]] = []
        for node in ast.walk(fn):
            if isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name) and node.value.id in VECTORS:
                if isinstance(node.slice, ast.Slice):
                    checks += [(node.slice.lower, False, node)] if node.slice.lower is not None else []
                    checks += [(node.slice.upper, True, node)] if node.slice.upper is not None else []
                else:
                    checks.append((node.slice, False, node))
            elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in OFFSET_ARGS:
                checks += [(node.args[i], False, node) for i in OFFSET_ARGS[node.func.id] if i < len(node.args)]
        for expr, size_allowed, where in checks:
            for why in _offset_faults(expr, assigned, size_allowed):
                faults.append(f"{path.name}:{where.lineno} {fn.name}: {ast.unparse(where)} ({why})")
    return faults


def test_no_law_reads_p_ref_s_by_a_number() -> None:
    """No law indexes p, ref, s or G (or passes an offset to pd_action/_block/_part) by a number or a dimension formula.

    The rule, over every function of laws/*.py except layout.py: in the index of ``p[...]``,
    ``ref[...]``, ``s[...]``, ``G[...]`` (a slice's start; its end may add the block's size) and in the
    offset arguments of the helpers that take one, there is no integer literal, and no additive term
    built of dimensions alone (``m``, ``2 * m``, ``m * m``); a local variable used there (``oR``) is
    checked where it is assigned. Offsets come from the names of laws/layout.py (``p[oR + i * m + j]``
    with ``oR = force_R(m)``); element indices inside a block (``i * m + j``) are free. A block at
    offset 0 read with no offset at all (``p[i]``) cannot be told from an element index: the laws
    write the constant (``p[FORCE_M_D_INV + i * m + j]``).
    """
    faults = [f for path in sorted(LAWS.glob("*.py")) if path.name != "layout.py" for f in _law_offset_faults(path)]
    assert not faults, "\n".join(faults)


def test_the_rule_catches_hand_written_offsets(tmp_path: Path) -> None:
    """The offset rule flags the forms the laws used before (3 * mm, ref[m + i], oF = 3 * mm, pd_action(p, 0, ...))."""
    src = tmp_path / "law.py"
    src.write_text(
        "def law(p, ref, s, m):\n"
        "    mm = m * m\n"
        "    oF = 3 * mm\n"
        "    a = p[3 * mm]\n"
        "    b = ref[m + 1]\n"
        "    c = p[oF + 2]\n"
        "    pd_action(p, 0, e, mm, v, 1.0, w)\n"
        "    x = ref[2 * m : 3 * m]\n"
        "    y = s[i * m + j]\n",
        encoding="utf-8",
    )
    faults = _law_offset_faults(src)
    assert {int(f.split(":")[1].split()[0]) for f in faults} == {4, 5, 6, 7, 8}  # not line 9, an element index
    assert any(":7 " in f and "number 0" in f for f in faults) and any(":7 " in f and "dimension term mm" in f for f in faults)
