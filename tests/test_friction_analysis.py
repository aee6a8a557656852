"""Friction's effect on surface following in an estimated frame (analysis/friction.py) against closed forms and the simulation."""

from __future__ import annotations

import math
from importlib.resources import files

import numpy as np
import pytest
import tomllib

from forcecontrol.analysis.friction import (
    estimated_normal_error,
    friction_effect,
    friction_normal_force,
    friction_tilt,
    sliding_friction_force,
)
from forcecontrol.errors import ParameterError
from forcecontrol.scenarios import load_scenario, run_scenario

MU_S, MU_K = 0.3, 0.2


def test_tilt_and_sliding_force_closed_forms():
    """f_t = μ_k f_n + b v and the measured force's tilt atan(f_t/f_n), by hand."""
    assert sliding_friction_force(10.0, 0.2, 4.0, 0.05) == pytest.approx(2.2, abs=1e-12)
    assert friction_tilt(0.2) == pytest.approx(math.atan(0.2), abs=1e-15)
    assert friction_tilt(0.2, 4.0, 0.05, 10.0) == pytest.approx(math.atan(0.22), abs=1e-15)
    assert estimated_normal_error(0.2, removed=False, lag=0.01) == pytest.approx(math.atan(0.2) + 0.01, abs=1e-15)
    assert estimated_normal_error(0.2, removed=True, lag=0.01) == 0.01


def test_regulating_the_tilted_force_lowers_the_normal_force_by_sqrt_one_plus_mu_squared():
    """With n̂ along the tilted force (e = atan μ) the loop regulates |h_e|: f_n = λ/√(1 + μ²)."""
    assert friction_normal_force(10.0, 0.2, math.atan(0.2)) == pytest.approx(10.0 / math.sqrt(1.04), rel=1e-14)
    assert friction_normal_force(10.0, 0.0, 0.0) == 10.0
    with pytest.raises(ParameterError, match="error_angle must leave"):
        friction_normal_force(10.0, 0.2, -1.6)


def test_friction_effect_without_friction_is_the_surface_following_error():
    """μ_k = 0: both cases reduce to analysis/surface_following.py's normal force (a second implementation)."""
    from forcecontrol.analysis.surface_following import surface_following_error

    fx = friction_effect(10.0, 0.05, 0.2, 1e4, 2500.0, 100.0, 0.05, 0.0, sample_time=1e-3)
    ref = surface_following_error(10.0, 0.05, 0.2, 1e4, 2500.0, 100.0, 0.05, sample_time=1e-3)
    assert fx.normal_force_removed == pytest.approx(ref.normal_force, rel=1e-12)
    assert fx.normal_force_not_removed == pytest.approx(ref.normal_force, rel=1e-12)
    assert fx.error_removed == pytest.approx(ref.lag, rel=1e-12)


@pytest.fixture(scope="module")
def frictional_circle():
    """arm-unknown-circle on R = 0.2 m with μ_s = 0.3, μ_k = 0.2, 2.5 s: friction removed (default) and not (min_speed 10 m/s)."""
    data = tomllib.loads((files("forcecontrol.scenarios") / "arm-unknown-circle.toml").read_text(encoding="utf-8"))
    data.pop("case")
    data["duration"] = 2.5
    data["environment"].update(static=MU_S, kinetic=MU_K)
    out = {}
    for key, min_speed in (("removed", 1e-3), ("not removed", 10.0)):
        d = {**data, "controller": {**data["controller"], "min_speed": min_speed}}
        res = run_scenario(load_scenario(d)).cases[0].result
        sel = res.t >= 2.0  # steady tracing (the motion starts at 1.0 s, ramped over 0.5 s)
        s = res.signals
        out[key] = {name: float(np.mean(np.asarray(s[name])[sel])) for name in ("normal_angle_error", "normal_force")}
    return out


def test_estimated_normal_bias_is_atan_mu_without_compensation_and_removed_with_it(frictional_circle):
    """The estimate's error is δ with the velocity-direction compensation and θ_μ + δ = atan μ_k + δ without it (1 %)."""
    fx = friction_effect(10.0, 0.05, 0.2, 1e4, 2500.0, 100.0, 0.05, MU_K, sample_time=1e-3)
    on, off = (-frictional_circle[k]["normal_angle_error"] for k in ("removed", "not removed"))  # + towards the motion
    assert on == pytest.approx(fx.error_removed, rel=0.01)
    assert off == pytest.approx(fx.error_not_removed, rel=0.01)
    assert off - on == pytest.approx(math.atan(MU_K), rel=0.01)  # the bias friction adds, removed by the compensation


def test_normal_force_with_friction_matches_the_analysis(frictional_circle):
    """f_n with friction removed within 0.1 % and not removed within 3 % (the rate leak k̂ K_Dλ v sin e / K_Pλ) of the analysis."""
    fx = friction_effect(10.0, 0.05, 0.2, 1e4, 2500.0, 100.0, 0.05, MU_K, sample_time=1e-3)
    assert frictional_circle["removed"]["normal_force"] == pytest.approx(fx.normal_force_removed, rel=1e-3)
    assert frictional_circle["not removed"]["normal_force"] == pytest.approx(fx.normal_force_not_removed, rel=0.03)
    assert frictional_circle["not removed"]["normal_force"] < 0.6 * fx.normal_force_removed  # the coupling is not small
