"""Runs too large or too stiff are refused before anything is allocated, with the size and the way out."""

from __future__ import annotations

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import ParameterError
from forcecontrol.sim.limits import MAX_SUBSTEPS, check_run_size, check_substeps

ARM = fc.PlanarTwoLink()
Q0 = ARM.inverse_kinematics([1.0, 0.0], elbow="up")


def _run(duration=1.0, sample_time=1e-3, stiffness=1e4, **kw):
    plane = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], stiffness)
    ctl = fc.ImpedanceController(ARM, 100, 500, 2500, sample_time=sample_time)
    return fc.simulate(ARM, plane, ctl, fc.Setpoint([1.1, 0.1]), q0=Q0, duration=duration, **kw)


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        (dict(sample_time=1e-9, duration=4.0), r"4,000,000,001 samples .* 805 GiB of logs .* max_log_bytes = 2 GiB"),
        (dict(duration=1e12), r"1,000,000,000,000,001 samples .* PiB of logs"),
        (dict(duration=1e300, sample_time=1e-300), r"too many to simulate"),
    ],
)
def test_huge_runs_are_refused_with_their_size(kw, match):
    """A tiny sample time or a huge duration: a ParameterError giving samples and bytes (8 (3n + 10m + 1) per sample)."""
    with pytest.raises(ParameterError, match=match):
        _run(**kw)


def test_log_budget_is_exact_and_adjustable():
    """The byte count is (N + 1) 8 (3 n + 10 m + 1): a budget one byte short refuses, the exact budget runs."""
    N = 100
    need = (N + 1) * 8 * (3 * 2 + 10 * 2 + 1)
    assert check_run_size(0.1, 1e-3, 2, 2, need) == N
    with pytest.raises(ParameterError, match="max_log_bytes"):
        check_run_size(0.1, 1e-3, 2, 2, need - 1)
    res = _run(duration=0.1, max_log_bytes=need)
    assert res.q.shape == (N + 1, 2)


def test_too_stiff_contact_is_refused_not_hung():
    """k = 1e12 N/m at Ts = 1 ms needs ~1600 substeps: refused at once, naming the stiffness and the sample time."""
    with pytest.raises(ParameterError, match=r"stiffness of 1e\+12 N/m at sample_time 0.001 s needs [\d,]+ RK4 substeps"):
        _run(stiffness=1e12, engine="python")
    with pytest.raises(ParameterError, match="more than 500"):
        check_substeps(MAX_SUBSTEPS + 1, 10, 1e-3, 1e9)
    with pytest.raises(ParameterError, match="RK4 steps"):
        check_substeps(100, 10**6, 1e-3, 1e6, "python")
    check_substeps(100, 10**6, 1e-3, 1e6, "compiled")  # the compiled loop affords it


def test_stiff_but_feasible_contact_still_runs():
    """k = 1e7 N/m (the bounce regime of the issue) is within the limits: it runs and its force stays finite."""
    res = _run(stiffness=1e7, duration=0.2)
    assert np.all(np.isfinite(res.wrench))
