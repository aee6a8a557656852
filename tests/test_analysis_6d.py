"""6-D analysis (issue 13 item 1): the translational equilibrium of spatial impedance (9.36) and
admittance (9.37) on linear environments, for tilted tables, rotated desired frames, anisotropic
gains and rotated springs, against full nonlinear simulations of the 7-DOF Panda.

The reference is the simulator (Pinocchio dynamics, the controller's own 6-D law), independent of
the linear model in ``scenarios/parts_spatial.py``; agreement within 1 % of the contact force and
0.1 mm of the position.
"""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest

pytest.importorskip("pinocchio")

from forcecontrol.scenarios import load_scenario  # noqa: E402
from forcecontrol.scenarios.core import build_case, case_analysis  # noqa: E402

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


@pytest.mark.parametrize("name", list(GEOMETRIES))
def test_translational_equilibrium_agrees_with_the_panda_simulation(tmp_path, name):
    sc = _scenario(tmp_path, *GEOMETRIES[name])
    predicted = case_analysis(build_case(sc.cases[0]))
    assert predicted["in_contact"]
    res = sc.run().cases[0].result
    settled = res.settled_values(0.1)
    f_pred = np.array([predicted[f"steady_f{a}"] for a in "xyz"])
    f_sim = np.array([settled[f"f{a}"] for a in "xyz"])
    assert np.linalg.norm(f_pred) > 5.0  # a real contact
    np.testing.assert_allclose(f_sim, f_pred, atol=0.01 * np.linalg.norm(f_pred))
    p_pred = np.array([predicted[f"steady_{a}"] for a in "xyz"])
    p_sim = np.array([settled[a] for a in "xyz"])
    np.testing.assert_allclose(p_sim, p_pred, atol=1e-4)


def test_coupled_gains_or_moment_springs_get_no_translational_analysis(tmp_path):
    """The translational model needs decoupled gains and a force-only environment: otherwise none is claimed."""
    sc = _scenario(tmp_path, IMPEDANCE.format(d=300, kx=1000, ky=1000, kz=1000),
                   SPRING.format(kx=4000, ky=1000, kz=2000, rz=0.0).replace(
                       "[4000, 1000, 2000, 0.0, 0.0, 0.0]", "[4000, 1000, 2000, 5.0, 5.0, 5.0]"),
                   "[0.0, 0.0, -0.01]", "[0.0, 0.0, 0.0]")
    assert "steady_fz" not in case_analysis(build_case(sc.cases[0]))
