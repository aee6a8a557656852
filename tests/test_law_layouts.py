"""The laws read their parameters, reference and state by name (forcecontrol.laws.layout), never by offset."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from forcecontrol.errors import DimensionError
from forcecontrol.laws import layout as L

LAWS = Path(L.__file__).resolve().parent
LAYOUTS = [
    L.REFERENCE, L.OS_PD, L.JOINT_PD, L.IMPEDANCE, L.FORCE, L.FORCE_STATE, L.HYBRID_COMPLIANT, L.HYBRID_RIGID, L.HYBRID_STATE,
]
VECTORS = {"p", "ref", "s", "G"}


def _offset_reads(path: Path) -> list[str]:
    bad = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name) and node.value.id in VECTORS:
            if not isinstance(node.slice, ast.Name):  # a bare loop index walks the whole vector; anything else is an offset
                bad.append(f"{path.name}:{node.lineno}: {ast.unparse(node)}")
    return bad


def test_no_law_reads_p_ref_or_s_by_offset():
    """No law indexes p, ref or s with a constant, an offset expression or a slice (only through the layout accessors)."""
    bad = [b for f in sorted(LAWS.glob("*.py")) if f.name != "layout.py" for b in _offset_reads(f)]
    assert bad == []


def _dims(layout, m):
    if layout.dims == ("d", "l", "k"):
        return (m, m - 1, 1)
    if layout.dims == ("l", "k"):
        return (m - 1, 1)
    return (m,) * len(layout.dims)


@pytest.mark.parametrize("m", [2, 6])
@pytest.mark.parametrize("layout", LAYOUTS, ids=lambda x: x.name)
def test_pack_then_view_round_trips_every_block(layout, m):
    """pack → compiled view returns each block as given (distinct random values, so a shifted offset cannot pass)."""
    dims = _dims(layout, m)
    rng = np.random.default_rng(m)
    blocks = {k: rng.standard_normal(layout.shape(k, *dims)) for k in layout.blocks}
    v = layout.pack(*dims, **blocks)
    assert v.shape == (layout.size(*dims),)
    assert v.shape == (sum(b.size for b in blocks.values()),)  # contiguous: nothing skipped, nothing overlapping
    for key, want in blocks.items():
        used = [d for d, name in zip(dims, layout.dims) if name in layout.args(key)]
        got = layout.view(key)(v, *used)
        np.testing.assert_array_equal(np.asarray(got), want, err_msg=f"{layout.name}.{key}")


def test_pack_checks_every_block_size():
    """A block of the wrong size raises DimensionError naming the block and both shapes."""
    with pytest.raises(DimensionError, match=r"K_P must have shape \(2, 2\); got shape \(3, 3\)"):
        L.IMPEDANCE.pack(2, Md_inv=np.eye(2), K_D=np.eye(2), K_P=np.eye(3), use_force=1.0)


def test_reference_layout_is_the_packed_reference_row():
    """The laws' REFERENCE layout reads what controllers.signals.pack_reference writes (a second packer)."""
    from forcecontrol.controllers.signals import REFERENCE_FIELDS, Reference, pack_reference

    r = Reference(*(np.arange(3.0) + 10 * i for i in range(6)))
    row = pack_reference(r)
    for f in REFERENCE_FIELDS:
        np.testing.assert_array_equal(L.REFERENCE.view(f)(row, 3), getattr(r, f))
