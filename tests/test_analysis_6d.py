"""6-D analysis (issue 13 item 1): equilibrium and transient of spatial impedance (9.36), base-frame
impedance (9.31) and admittance (9.37) on linear environments — tilted tables, rotated desired
frames, anisotropic gains, rotated springs, moment springs with a turned rest frame, gains that
couple translation and rotation — against full nonlinear simulations of the 7-DOF Panda.

The reference is the simulator (Pinocchio dynamics, the controller's own 6-D law), independent of
the linear model in ``scenarios/parts_spatial_analysis.py``. Agreement: the equilibrium wrench
within 1 % (forces and moments each against their own size), the position within 0.1 mm, the
orientation within 1e-3 rad; the contact force at fixed times within 2 % of its peak (impedance:
the model leaves out the admittance's inner motion loop, so admittance gets the equilibrium only).
"""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest

pytest.importorskip("pinocchio")

from forcecontrol.scenarios import load_scenario  # noqa: E402
from forcecontrol.scenarios.core import build_case, case_analysis, case_response  # noqa: E402

S20, C20 = math.sin(math.radians(20.0)), math.cos(math.radians(20.0))

IMPEDANCE = """
type = "spatial-impedance"
inertia = [4.0, 4.0, 4.0, 0.1, 0.1, 0.1]
damping = [{d}, {d}, {d}, 2.83, 2.83, 2.83]
stiffness = [{kx}, {ky}, {kz}, 20.0, 20.0, 20.0]
"""
ADMITTANCE = """
type = "admittance"
inertia = [4.0, 4.0, 4.0, 0.1, 0.1, 0.1]
damping = [{d}, {d}, {d}, 2.83, 2.83, 2.83]
stiffness = [{kx}, {ky}, {kz}, 20.0, 20.0, 20.0]
motion_stiffness = 14400.0
motion_damping = 240.0
"""
TABLE = """
type = "table"
normal = [{n}]
stiffness = {k}
damping = 50.0
"""
SPRING = """
type = "spatial-spring"
stiffness = [{kx}, {ky}, {kz}, 0.0, 0.0, 0.0]
rotation = [0.0, 0.0, {rz}]
offset = [0.0, 0.0, 0.0]
"""
MOMENT_SPRING = """
type = "spatial-spring"
stiffness = {K}
rotation = {rot}
offset = {off}
"""
COUPLED = """
type = "spatial-impedance"
inertia = [4.0, 4.0, 4.0, 0.1, 0.1, 0.1]
damping = [300, 300, 300, 2.83, 2.83, 2.83]
stiffness = [[1000, 0, 0, 0, 20, 0], [0, 1000, 0, -20, 0, 0], [0, 0, 1000, 0, 0, 0],
             [0, -20, 0, 20, 0, 0], [20, 0, 0, 0, 20, 0], [0, 0, 0, 0, 0, 20]]
"""

GEOMETRIES = {
    "impedance, flat table": (IMPEDANCE.format(d=300, kx=1000, ky=1000, kz=1000), TABLE.format(n="0.0, 0.0, 1.0", k=5000),
                              "[0.0, 0.0, -0.02]", "[0.0, 0.0, 0.0]"),
    "impedance, table tilted 20 deg": (IMPEDANCE.format(d=300, kx=1000, ky=1000, kz=1000),
                                       TABLE.format(n=f"0.0, {S20}, {C20}", k=5000), "[0.01, 0.0, -0.02]", "[0.0, 0.0, 0.0]"),
    "impedance, anisotropic, desired frame turned 30 deg, tilted table": (
        IMPEDANCE.format(d=300, kx=800, ky=1500, kz=1000), TABLE.format(n=f"0.0, {S20}, {C20}", k=8000),
        "[0.0, 0.01, -0.02]", "[0.0, 0.0, 30.0]"),
    "impedance in the base frame (9.31), anisotropic, desired frame turned 30 deg, tilted table": (
        IMPEDANCE.format(d=300, kx=800, ky=1500, kz=1000) + 'frame = "base"\n', TABLE.format(n=f"0.0, {S20}, {C20}", k=8000),
        "[0.0, 0.01, -0.02]", "[0.0, 0.0, 30.0]"),
    "admittance, table tilted 20 deg": (ADMITTANCE.format(d=200, kx=1000, ky=1000, kz=1000),
                                        TABLE.format(n=f"{S20}, 0.0, {C20}", k=5000), "[0.0, 0.0, -0.02]", "[0.0, 0.0, 0.0]"),
    "impedance, spring rotated 45 deg": (IMPEDANCE.format(d=300, kx=1000, ky=1000, kz=1000),
                                         SPRING.format(kx=4000, ky=1000, kz=2000, rz=45.0), "[0.01, 0.02, -0.01]",
                                         "[0.0, 0.0, 0.0]"),
    "impedance, moment spring, rest frame turned (2, -3, 4) deg": (
        IMPEDANCE.format(d=300, kx=1000, ky=1000, kz=1000),
        MOMENT_SPRING.format(K="[4000, 1000, 2000, 8.0, 5.0, 5.0]", rot="[2.0, -3.0, 4.0]", off="[0.01, 0.0, -0.01]"),
        "[0.0, 0.0, 0.0]", "[0.0, 0.0, 0.0]"),
    "impedance, gains coupling translation and rotation, moment spring": (
        COUPLED, MOMENT_SPRING.format(K="[4000, 1000, 2000, 5.0, 5.0, 5.0]", rot="[0.0, 0.0, 0.0]", off="[0.01, 0.01, -0.01]"),
        "[0.0, 0.0, 0.0]", "[0.0, 0.0, 0.0]"),
    "impedance in the base frame (9.31), moment spring, desired frame turned 30 deg": (
        IMPEDANCE.format(d=300, kx=800, ky=1500, kz=1000) + 'frame = "base"\n',
        MOMENT_SPRING.format(K="[3000, 1000, 2000, 6.0, 5.0, 4.0]", rot="[2.0, 3.0, 32.0]", off="[0.01, 0.0, -0.01]"),
        "[0.0, 0.0, 0.0]", "[0.0, 0.0, 30.0]"),
    "admittance, moment spring, rest frame turned (-2, 3, 2) deg": (
        ADMITTANCE.format(d=200, kx=1000, ky=1000, kz=1000),
        MOMENT_SPRING.format(K="[3000, 1000, 2000, 6.0, 5.0, 4.0]", rot="[-2.0, 3.0, 2.0]", off="[0.0, 0.01, -0.01]"),
        "[0.0, 0.0, 0.0]", "[0.0, 0.0, 0.0]"),
}


def _scenario(tmp_path, controller, environment, offset, rotation):
    text = textwrap.dedent(f"""
        name = "six-d"
        duration = 4.0
        sample_time = 0.001
        [robot]
        model = "panda"
        q0 = [0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398]
        [environment]
        {textwrap.dedent(environment)}
        [controller]
        {textwrap.dedent(controller)}
        [reference]
        type = "pose-setpoint"
        offset = {offset}
        rotation = {rotation}
    """)
    path = tmp_path / "six-d.toml"
    path.write_text("\n".join(line.strip() for line in text.splitlines()) + "\n")
    return load_scenario(path)


POSE = ("x", "y", "z", "rx", "ry", "rz")
WRENCH = ("fx", "fy", "fz", "mx", "my", "mz")


@pytest.mark.parametrize("name", list(GEOMETRIES))
def test_6d_equilibrium_and_transient_agree_with_the_panda_simulation(tmp_path, name):
    sc = _scenario(tmp_path, *GEOMETRIES[name])
    parts = build_case(sc.cases[0])
    predicted = case_analysis(parts)
    assert predicted["in_contact"]
    times = np.array([0.02, 0.05, 0.1, 0.2, 0.4, 0.8, 1.6])
    transient = case_response(parts, times)
    res = sc.run().cases[0].result
    settled = res.settled_values(0.1)
    w_pred = np.array([predicted[f"steady_{k}"] for k in WRENCH])
    w_sim = np.array([settled[k] for k in WRENCH])
    assert np.linalg.norm(w_pred[:3]) > 5.0  # a real contact
    np.testing.assert_allclose(w_sim[:3], w_pred[:3], atol=0.01 * np.linalg.norm(w_pred[:3]))
    np.testing.assert_allclose(w_sim[3:], w_pred[3:], atol=0.01 * max(np.linalg.norm(w_pred[3:]), 1e-3))
    x_pred = np.array([predicted[f"steady_{k}"] for k in POSE])
    x_sim = np.array([settled[k] for k in POSE])
    np.testing.assert_allclose(x_sim[:3], x_pred[:3], atol=1e-4)
    turn = (x_sim[3:] - x_pred[3:] + np.pi) % (2 * np.pi) - np.pi  # Euler angles of ±π are one angle
    np.testing.assert_allclose(turn, 0.0, atol=1e-3)
    assert transient is not None  # admittance too: the compliant frame's own ZOH step in the sampled model
    sim = res.wrench[np.searchsorted(res.t, times)]
    peak = np.abs(res.wrench[:, :3]).max()
    # the predicted transient is the sampled loop's (torque held, the environment pushing between
    # samples): 3–5e-5 of the peak; the base-frame (9.31) moment spring 2.5e-3, where the
    # environment's Euler-angle linearisation, not the sampling, sets the difference
    tol = 5e-3 if "base frame" in name and "moment" in name else 5e-4
    np.testing.assert_allclose(transient[:, :3], sim[:, :3], atol=tol * peak)


def test_a_moment_spring_turned_far_from_the_desired_frame_is_outside_the_linear_model(tmp_path):
    """The analysis linearises the spring's rotation vector about the desired frame: with the rest
    frame turned (60, 45, 0) deg, the simulated moments leave its 1 % band (``analyze --verify``
    reports this), while at 3 deg they agree within 1 % (about one axis alone the model is exact)."""
    def moments(rot):
        sc = _scenario(tmp_path, IMPEDANCE.format(d=300, kx=1000, ky=1000, kz=1000),
                       MOMENT_SPRING.format(K="[4000, 1000, 2000, 8.0, 8.0, 8.0]", rot=rot, off="[0.0, 0.0, -0.01]"),
                       "[0.0, 0.0, 0.0]", "[0.0, 0.0, 0.0]")
        predicted = case_analysis(build_case(sc.cases[0]))
        settled = sc.run().cases[0].result.settled_values(0.1)
        return (np.array([predicted[f"steady_{k}"] for k in ("mx", "my", "mz")]),
                np.array([settled[k] for k in ("mx", "my", "mz")]))

    pred, sim = moments("[3.0, 0.0, 0.0]")
    np.testing.assert_allclose(sim, pred, atol=0.01 * np.linalg.norm(pred))
    pred, sim = moments("[60.0, 45.0, 0.0]")
    assert np.linalg.norm(sim - pred) > 0.01 * np.linalg.norm(pred)


HYBRID = """
type = "spatial-hybrid"
force_directions = [{s}]
compliance = {c}
stiffness = 400.0
damping = 40.0
force_stiffness = 400.0
force_damping = 30.0
"""


def _hybrid_scenario(tmp_path, compliance, tilt_deg, sample_time=2e-4):
    """The Panda's hand on a table (k = 1e4 N/m) tilted about x, pressing 20 N along its normal."""
    from forcecontrol.robots.pinocchio import panda
    from forcecontrol.spatial import euler_xyz_to_rotation

    q0 = np.array([0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398])
    R0 = euler_xyz_to_rotation(panda().forward_kinematics(q0)[3:])
    t = math.radians(tilt_deg)
    n = np.array([0.0, math.sin(t), math.cos(t)])
    s = np.concatenate([R0.T @ n, np.zeros(3)])  # the force direction, desired-frame coordinates
    f = np.concatenate([-20.0 * n, np.zeros(3)])
    text = textwrap.dedent(f"""
        name = "six-d-hybrid"
        duration = 1.5
        sample_time = {sample_time}
        [robot]
        model = "panda"
        q0 = {q0.tolist()}
        [environment]
        type = "table"
        normal = {n.tolist()}
        stiffness = 10000.0
        [controller]
        {textwrap.dedent(HYBRID.format(s=', '.join(f'{v:.17g}' for v in s), c=compliance))}
        [reference]
        type = "pose-setpoint"
        offset = [0.0, 0.0, 0.0]
        force = {f.tolist()}
    """)
    path = tmp_path / "six-d-hybrid.toml"
    path.write_text("\n".join(line.strip() for line in text.splitlines()) + "\n")
    return load_scenario(path), f


@pytest.mark.parametrize("sample_time", [1e-3, 2e-4])
@pytest.mark.parametrize(("compliance", "tilt"), [(1e-4, 0.0), (2e-4, 0.0), (0.5e-4, 20.0)])
def test_6d_hybrid_force_loop_9_84_agrees_with_the_panda_simulation(tmp_path, compliance, tilt, sample_time):
    """(9.84) in 6-D: λ̈ + K_Dλ λ̇ + L_f K_Pλ (λ − λ_d) = 0 with L_f = k Ĉ (Ĉ = C, 2C, C/2; flat and
    tilted tables); ω_n = √(L_f K_Pλ) by hand, λ → λ_d whatever Ĉ, and the force transient at
    fixed times within 0.1 % of its peak of the simulation, at the chapter's 1 ms and at 0.2 ms.
    The predicted transient is the sampled loop (the torque held over the sample while the
    environment pushes on the Panda's light operational mass): the continuous (9.84) alone is
    1.2–2.1 % off at 1 ms (measured 4e-5 with the sampled model)."""
    sc, f = _hybrid_scenario(tmp_path, compliance, tilt, sample_time)
    parts = build_case(sc.cases[0])
    predicted = case_analysis(parts)
    L_f = 1e4 * compliance
    assert predicted["L_f"] == pytest.approx(L_f, rel=1e-9)
    assert predicted["force_omega_n"] == pytest.approx(math.sqrt(L_f * 400.0), rel=1e-9)
    assert predicted["force_zeta"] == pytest.approx(30.0 / (2.0 * math.sqrt(L_f * 400.0)), rel=1e-9)
    np.testing.assert_allclose([predicted[f"steady_{k}"] for k in WRENCH], f, atol=1e-9)
    times = np.array([0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.8, 1.2])
    transient = case_response(parts, times)
    res = sc.run().cases[0].result
    settled = res.settled_values(0.1)
    np.testing.assert_allclose([settled[k] for k in WRENCH], f, atol=0.01 * 20.0)
    sim = res.wrench[np.searchsorted(res.t, times)]
    peak = np.max(np.linalg.norm(res.wrench, axis=1))
    assert np.max(np.linalg.norm(sim - transient, axis=1)) <= 1e-3 * peak
