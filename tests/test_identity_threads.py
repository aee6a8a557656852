"""Identities and per-law kernels are given and built once under threads (a sweep runs its blocks on a thread pool).

Numba's ``_MemoMixin._set_uuid`` asserts that a dispatcher's uuid is unset; two sweep threads giving
identities at once tripped it and a cold sweep failed with a bare ``AssertionError()`` (fresh-clone CI
at 2643ba7). These tests run the racing calls from many threads with a tiny switch interval.
"""

from __future__ import annotations

import sys
import threading
import types
import uuid

import pytest
from numba import njit

from forcecontrol.core.numba_cache import build_once, stable_identities

THREADS = 8


def _together(fn, n=THREADS):
    """Run ``fn(i)`` on ``n`` threads released at once; return results and the exceptions raised."""
    barrier = threading.Barrier(n)
    results, errors = [None] * n, []

    def run(i):
        barrier.wait()
        try:
            results[i] = fn(i)
        except BaseException as exc:  # noqa: BLE001 - the test reports any exception
            errors.append(exc)

    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        threads = [threading.Thread(target=run, args=(i,)) for i in range(n)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(old)
    return results, errors


@pytest.fixture
def probe_module():
    """A module of the package holding 400 fresh dispatchers whose uuid is unset (as after a lazy import)."""
    name = f"forcecontrol._identity_probe_{uuid.uuid4().hex[:8]}"
    module = types.ModuleType(name)
    for i in range(400):
        def f(x):  # pragma: no cover - never called
            return x
        f.__module__ = name
        setattr(module, f"k{i:03d}", njit(cache=False)(f))
    sys.modules[name] = module
    yield name, module
    sys.modules.pop(name, None)


def test_identities_given_from_many_threads_at_once_raise_nothing_and_are_name_derived(probe_module):
    name, module = probe_module
    _, errors = _together(lambda i: stable_identities())
    assert errors == []
    for attr in ("k000", "k199", "k399"):
        assert getattr(module, attr)._uuid == f"forcecontrol:{name}.{attr}"


def test_build_once_builds_one_object_when_threads_ask_together():
    cache: dict = {}
    calls = []

    def build():
        calls.append(1)
        for _ in range(2000):  # long enough for the other threads to arrive
            pass
        return object()

    results, errors = _together(lambda i: build_once(cache, "key", build))
    assert errors == []
    assert len(calls) == 1
    assert all(r is results[0] for r in results)


def test_the_planar_loop_of_a_law_is_one_kernel_when_threads_ask_together():
    from forcecontrol.controllers import ImpedanceController
    from forcecontrol.sim import loop as loop_module

    law = ImpedanceController.law
    key = (law, False)
    saved = loop_module._LOOPS.pop(key, None)
    try:
        results, errors = _together(lambda i: loop_module.planar_loop(law, full_log=False))
        assert errors == []
        assert all(r is results[0] for r in results)
    finally:
        if saved is not None:
            loop_module._LOOPS[key] = saved
