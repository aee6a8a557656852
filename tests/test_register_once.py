"""checks.register_once: the one idempotent registration of an analysis, used by the vendor modules (review D6)."""

from __future__ import annotations

import pytest

from forcecontrol.scenarios import checks


@pytest.fixture
def analyses():
    saved = list(checks._ANALYSES)
    yield checks._ANALYSES
    checks._ANALYSES[:] = saved


def test_register_once_adds_an_analysis_once(analyses):
    """A new analysis is added (True) the first time and not again (False): one entry, whatever the predicate."""

    def applies(parts):
        return True

    def fn(parts):
        return {"x": 1.0}

    n = len(analyses)
    assert checks.register_once(applies, fn) is True
    assert checks.register_once(applies, fn) is False
    assert checks.register_once(lambda parts: False, fn) is False
    assert len(analyses) == n + 1 and analyses[-1] == (applies, fn)


@pytest.mark.parametrize("module", ["parts_vendor_analysis", "parts_vendor_franka"])
def test_vendor_hooks_register_through_register_once(analyses, monkeypatch, module):
    """The vendor modules' hooks go through register_once (one idempotent pattern): run again they add nothing, their
    analysis is listed exactly once."""
    import importlib

    mod = importlib.import_module(f"forcecontrol.scenarios.{module}")
    calls = []
    real = checks.register_once
    monkeypatch.setattr(checks, "register_once", lambda applies, fn: calls.append((applies, fn)) or real(applies, fn))
    before = list(analyses)
    mod._register_analyses()
    mod._register_analyses()
    assert calls == [(mod._applies, mod._analysis)] * 2
    assert analyses == before
    assert sum(fn is mod._analysis for _, fn in analyses) == 1
