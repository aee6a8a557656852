"""The fuzz campaign's seeded CI subset (issue 28 item 8): five kinds of hostile input, classified.

``tests/fuzz`` generates scenario files (run, analyze, sweep), recorded data (CSV, Parquet, ROS 2
bags, MCAP), URDFs, command lines and Python calls from a fixed seed; each input ends in one
outcome (``tests/fuzz/core.py``). Here a subset runs in process (a few command lines as
subprocesses: the FIFO and ``/dev/zero`` ones) and must show 0 raw tracebacks, 0 hangs, 0 silent
acceptances and 0 writes outside the case's folder. ``pytest -s`` prints the table;
``tools/fuzz_report.py`` runs the larger campaign. The time limits are hang detectors only.
"""

from __future__ import annotations

import math
import time
import warnings

import numpy as np
import pytest

import fuzz
from fuzz import api as fuzz_api
from fuzz.core import BAD, OUTCOMES, Case, classify, make_sandbox

SEED = 20261126
COUNTS = {"scenario": 40, "data": 60, "urdf": 40, "cli": 14, "api": 40}


def _warm_up(cases: list[Case]) -> None:
    """Compile what the subset runs (unguarded: a first compile is never taken for a hang): each scenario a case
    simulates or analyses, unmutated, and one step of each controller the API cases call."""
    import forcecontrol as fc
    from forcecontrol.scenarios import load_scenario, run_scenario

    names = {c.describe.split()[1].removesuffix(".toml") for c in cases
             if c.kind == "scenario" and not c.sub.startswith("load:")}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in sorted(names | {"example-9.2"}):
            run_scenario(load_scenario(name).with_(duration=0.05))
        arm = fc.PlanarTwoLink()
        q0 = np.array([math.pi / 3, -2 * math.pi / 3])
        m = fc.Measurement(q0, np.zeros(2), np.zeros(2))
        ref = fc.Reference.setpoint([1.01, 0.0], force=[10.0, 0.0])
        for name, kw in fuzz_api.CONTROLLERS.items():
            getattr(fc, name)(arm, **kw).step(0.0, m, ref)


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    root = tmp_path_factory.mktemp("fuzz-campaign")
    sentinel = make_sandbox(root)
    cases = {kind: fuzz.make_cases(kind, SEED, n, sentinel) for kind, n in COUNTS.items()}
    _warm_up(cases["scenario"])
    t0 = time.perf_counter()
    outcomes = []
    for kind in COUNTS:
        outcomes += fuzz.run_cases(cases[kind], root)
    return outcomes, time.perf_counter() - t0


def test_fuzz_campaign_subset_has_no_traceback_hang_silence_or_outside_write(campaign):
    """194 seeded hostile inputs of the five kinds: each ends in success or a clean library error, nothing else."""
    outcomes, seconds = campaign
    print(f"\nfuzz campaign subset, seed {SEED}: {len(outcomes)} inputs in {seconds:.0f} s\n" + fuzz.format_table(outcomes))
    assert len(outcomes) == sum(COUNTS.values())
    assert {o.case.kind for o in outcomes} == set(fuzz.KINDS)
    bad = fuzz.failures(outcomes)
    assert not bad, "\n".join(f"{o.case.name}: {o.outcome}: {o.case.describe}: {o.detail}" for o in bad)
    # not vacuous: every kind has clean errors, and some inputs are accepted
    for kind in fuzz.KINDS:
        assert any(o.outcome == "clean_error" for o in outcomes if o.case.kind == kind), kind
    assert any(o.outcome == "success" for o in outcomes)


def test_fuzz_generators_are_deterministic(tmp_path):
    """The same seed gives the same inputs (a failure is reproducible from its kind, seed and index)."""
    sentinel = make_sandbox(tmp_path)
    for kind in fuzz.KINDS:
        a = [(c.sub, c.describe, c.invalid) for c in fuzz.make_cases(kind, 5, 12, sentinel)]
        b = [(c.sub, c.describe, c.invalid) for c in fuzz.make_cases(kind, 5, 12, sentinel)]
        assert a == b and len(set(a)) > 1, kind


def _case(action=None, argv=None, invalid=False, escapes=False) -> Case:
    return Case("api", "probe", 0, "probe", action=action, argv=argv, invalid=invalid, check_escapes=escapes, limit=2)


def test_classifier_tells_each_outcome_apart(tmp_path):
    """The classifier itself, on inputs whose outcome is known: each of the six outcomes is recognised."""
    from forcecontrol.errors import ParameterError

    sentinel = make_sandbox(tmp_path)

    def raise_(exc):
        raise exc

    def hang(d):
        while True:
            time.sleep(0.05)

    def warn(d):
        warnings.warn("value clipped", UserWarning, stacklevel=1)

    probes = {
        "success": _case(lambda d: None),
        "clean_error": _case(lambda d: raise_(ParameterError("x must be positive; got -1"))),
        "raw_traceback": _case(lambda d: raise_(ZeroDivisionError("boom"))),
        "hang": _case(hang),
        "silent": _case(lambda d: None, invalid=True),
        "outside_write": _case(lambda d: (sentinel / "notes.csv").write_text("overwritten")),
    }
    got = {want: classify(c, tmp_path).outcome for want, c in probes.items()}
    assert got == {k: k for k in probes}
    assert set(got) == set(OUTCOMES) and set(BAD) < set(OUTCOMES)
    assert classify(_case(warn, invalid=True), tmp_path).outcome == "success"  # a warning is not silence
    assert classify(_case(lambda d: print("\x1b]0;title\x07"), escapes=True), tmp_path).outcome == "silent"
