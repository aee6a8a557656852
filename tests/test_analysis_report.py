"""`forcecontrol analyze` for any geometry and `--verify` for every scheme (issue 27).

References: the impedance equilibrium against an elastic plane solved here by hand,
``K_P (x_d − x) = k n nᵀ (x − x_p)``; the continuous step response of the hybrid force loop (9.84),
``λ̈ + K_Dλ λ̇ + L_f K_Pλ (λ − λ_d) = 0``, in closed form; the scenarios' own simulations.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from forcecontrol.cli import app
from forcecontrol.scenarios.report import analyze_scenario

MD, KD, KP, K = 100.0, 500.0, 2500.0, 1e4
X_P = np.array([1.0, 0.0])

TILTED = """
name = "tilted-{angle}"
title = "impedance against a plane at {angle} deg"
duration = 4.0
sample_time = 0.001

[robot]
model = "chapter-arm"
start_position = [1.0, 0.0]
elbow = "up"

[environment]
type = "elastic-plane"
point = [1.0, 0.0]
angle = {angle}
stiffness = {k}

[controller]
type = "impedance"
force_measurement = true
inertia = [{md}, {md}]
damping = [{kd}, {kd}]
stiffness = [{kp}, {kp}]

[reference]
type = "setpoint"
position = [{xd0!r}, {xd1!r}]

[[case]]
label = "tilted"
"""


def _normal(angle: float) -> np.ndarray:
    a = math.radians(angle)
    return np.array([-math.sin(a), math.cos(a)])  # the plane's outward normal y_c (Example 9.4's convention)


def _desired(angle: float) -> np.ndarray:
    """5 cm into the plane and 3 cm along it from x_p."""
    n = _normal(angle)
    return X_P - 0.05 * n + 0.03 * np.array([n[1], -n[0]])


def _tilted(tmp_path, angle: float):
    xd = _desired(angle)
    p = tmp_path / f"tilted-{angle:g}.toml"
    p.write_text(TILTED.format(angle=angle, k=K, md=MD, kd=KD, kp=KP, xd0=float(xd[0]), xd1=float(xd[1])), encoding="utf-8")
    return p


def _closed_form(angle: float) -> tuple[np.ndarray, np.ndarray]:
    """x_e solving K_P (x_d − x) = k n nᵀ (x − x_p), and the force h = k n nᵀ (x − x_p) on the plane."""
    n = _normal(angle)
    Ke = K * np.outer(n, n)
    x = np.linalg.solve(KP * np.eye(2) + Ke, KP * _desired(angle) + Ke @ X_P)
    return x, Ke @ (x - X_P)


def _rows(output: str) -> dict[str, list[str]]:
    rows = {}
    for line in output.splitlines():
        if line.startswith("│"):
            cells = [c.strip() for c in line.strip("│").split("│")]
            rows.setdefault(cells[0].split(" [", 1)[0], cells)  # the quantity without its unit ('steady_x [m]')
    return rows


@pytest.mark.parametrize("angle", [30.0, 45.0, 120.0])
def test_analyze_table_on_a_tilted_plane_gives_the_closed_form_equilibrium(tmp_path, angle):
    """`analyze FILE` on an impedance case against a plane at 30/45/120 deg prints its table (it raised
    TypeError on the mode directions) with the equilibrium of K_P (x_d − x) = k n nᵀ (x − x_p)."""
    res = CliRunner().invoke(app, ["analyze", str(_tilted(tmp_path, angle))])
    assert res.exit_code == 0, res.output
    rows = _rows(res.output)
    x, h = _closed_form(angle)
    shown = [float(rows[k][1]) for k in ("steady_x", "steady_y", "steady_fx", "steady_fy")]
    np.testing.assert_allclose(shown[:2], x, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(shown[2:], h, rtol=1e-5, atol=1e-3)
    # the modes: directions printed as vectors, the fast one along the normal at sqrt((K_P + k)/M_d)
    modes = {k: v[1] for k, v in rows.items() if k.startswith(("mode_", "omega_n_"))}
    fast = max((k for k in modes if k.startswith("omega_n_")), key=lambda k: float(modes[k]))
    assert float(modes[fast]) == pytest.approx(math.sqrt((KP + K) / MD), rel=1e-5)
    direction = np.array([float(v) for v in modes["mode_" + fast.rsplit("_", 1)[1]].strip("[]").split(",")])
    assert abs(abs(direction @ _normal(angle)) - 1.0) < 1e-5
    assert rows["in_contact"][1] == "yes"


def test_analyze_json_and_verify_on_a_tilted_plane(tmp_path):
    """At 120 deg: --json carries the closed-form equilibrium and the mode directions as lists; --verify
    prints its comparison, the simulated equilibrium and transient agreeing within 1 % and 2 %."""
    p = _tilted(tmp_path, 120.0)
    js = CliRunner().invoke(app, ["analyze", str(p), "--json"])
    assert js.exit_code == 0, js.output
    an = json.loads(js.stdout)["cases"][0]["analysis"]
    x, h = _closed_form(120.0)
    np.testing.assert_allclose([an["steady_x"], an["steady_y"]], x, rtol=1e-12)
    np.testing.assert_allclose([an["steady_fx"], an["steady_fy"]], h, rtol=1e-12)
    assert isinstance(an["mode_1"], list) and an["in_contact"] is True
    res = CliRunner().invoke(app, ["analyze", str(p), "--verify"])
    assert res.exit_code == 0, res.output
    ver = [line for line in res.output.splitlines() if "agrees" in line or "differs" in line]
    assert len(ver) == 5 and all("agrees" in line for line in ver), res.output  # x, y, fx, fy, the transient
    sim = {line.split("│")[1].strip().split(" [", 1)[0]: float(line.split("│")[3]) for line in ver if "steady_" in line}
    np.testing.assert_allclose([sim["steady_x"], sim["steady_y"]], x, atol=0.01 * np.linalg.norm(_desired(120.0) - X_P))
    np.testing.assert_allclose([sim["steady_fx"], sim["steady_fy"]], h, atol=0.01 * np.linalg.norm(h))


def _force_loop_step(t, lam0, lam_d, lf, kp, kd):
    """Closed-form λ(t) of λ̈ + K_Dλ λ̇ + L_f K_Pλ (λ − λ_d) = 0 from λ(0) = λ0, λ̇(0) = 0."""
    w2 = lf * kp
    disc = kd * kd - 4.0 * w2
    t = np.asarray(t, dtype=float)
    if abs(disc) < 1e-9 * w2:  # critically damped: double root −K_Dλ/2
        r = -kd / 2.0
        e = (lam0 - lam_d) * (1.0 - r * t) * np.exp(r * t)
    elif disc > 0:
        r1, r2 = (-kd + math.sqrt(disc)) / 2.0, (-kd - math.sqrt(disc)) / 2.0
        e = (lam0 - lam_d) * (r2 * np.exp(r1 * t) - r1 * np.exp(r2 * t)) / (r2 - r1)
    else:
        a, b = -kd / 2.0, math.sqrt(-disc) / 2.0
        e = (lam0 - lam_d) * np.exp(a * t) * (np.cos(b * t) - a / b * np.sin(b * t))
    return lam_d + e


def test_verify_on_planar_hybrid_compares_the_normal_force_and_the_force_loop_transient():
    """analyze example-9.4 --verify (hybrid on an elastic plane; nothing was verified, silently): the
    settled normal force and penetration agree with the simulation, and the contact force is the
    closed-form step response of (9.84) within 2 % of the peak (the loop is sampled: a held torque lags
    the continuous response by about half a sample, 0.8 N at the steepest point for ζ = 1/√2)."""
    rep = analyze_scenario("example-9.4", verify=True)
    n = _normal(45.0)
    for case in rep["cases"]:
        ver, an = case["verification"], case["analysis"]
        assert ver["skipped"] is None and ver["agrees"] is True, ver
        assert set(ver["quantities"]) == {"steady_normal_force", "steady_penetration"}
        assert ver["quantities"]["steady_normal_force"]["simulated"] == pytest.approx(-50.0, rel=0.01)
        tr = ver["transient"]
        lam_sim = np.asarray(tr["simulated"]) @ n
        lam = _force_loop_step(tr["times"], 0.0, -50.0, an["L_f"], 2500.0, 100.0)
        np.testing.assert_allclose(lam_sim, lam, atol=0.02 * np.max(np.abs(lam_sim)))
        np.testing.assert_allclose(np.asarray(tr["predicted"]) @ n, lam, atol=0.02 * np.max(np.abs(lam_sim)))


def test_verify_on_hybrid_rigid_compares_the_normal_force_and_says_why_not_the_transient():
    """analyze hybrid-rigid-plane --verify: the settled normal force (−50 N) is compared; that there is
    no transient model for a rigid environment is said on stderr, in the table and in --json."""
    runner = CliRunner()
    res = runner.invoke(app, ["analyze", "hybrid-rigid-plane", "--verify", "--json"])
    assert res.exit_code == 0, res.output
    rep = json.loads(res.stdout)
    for case in rep["cases"]:
        ver = case["verification"]
        q = ver["quantities"]["steady_normal_force"]
        assert q["agrees"] and q["simulated"] == pytest.approx(-50.0, rel=0.01)
        assert ver["transient"] is None and "rigid environment" in ver["transient_skipped"]
    assert "transient not verified" in " ".join(res.stderr.split())
    table = runner.invoke(app, ["analyze", "hybrid-rigid-plane", "--verify"])
    text = " ".join(table.stdout.split())
    assert text.count("transient not verified: hybrid control on a rigid environment") == len(rep["cases"])


def test_a_case_without_analysis_says_so_and_is_not_verified():
    """analyze impact --verify --json: the contact supervisor's cases have no analysis; each case says
    why (analysis_skipped, verification.skipped) and stderr repeats it; no simulation is claimed."""
    res = CliRunner().invoke(app, ["analyze", "impact", "--verify", "--json"])
    assert res.exit_code == 0, res.output
    for case in json.loads(res.stdout)["cases"]:
        assert "ContactSupervisor" in case["analysis_skipped"]
        assert case["verification"]["skipped"] and case["verification"]["agrees"] is None
        assert case["verification"]["quantities"] == {}
    assert "no analysis applies to a ContactSupervisor" in " ".join(res.stderr.split())
