"""The vendor laws follow the laws' layout convention: every offset by name, checked against its one declaration."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest

from forcecontrol.laws.vendor import layout

VENDOR = Path(layout.__file__).parent


@pytest.mark.parametrize("decl", layout.DECLARATIONS, ids=lambda d: d.name)
def test_every_offset_matches_its_declaration(decl):
    """Each block's offset function (or constant, for a fixed one) equals the declaration's offset for dims 1..6."""
    for dims in itertools.product(range(1, 7), repeat=len(decl.dims)):
        for block in decl.blocks:
            acc = getattr(layout, decl.accessor(block))
            got = acc if decl.fixed(block) else acc.py_func(*dims)
            assert got == decl.offset(block, *dims), (decl.name, block, dims)


def test_no_vendor_law_reads_p_or_s_by_a_number():
    """The rule of tests/test_law_layout.py over laws/vendor/*.py: no integer literal or dimension-only term as an offset."""
    from test_law_layout import _law_offset_faults

    faults = [f for path in sorted(VENDOR.glob("*.py")) if path.name != "layout.py" for f in _law_offset_faults(path)]
    assert not faults, "\n".join(faults)
