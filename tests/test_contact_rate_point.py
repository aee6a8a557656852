"""The RK4 substeps of a point contact (a surface's force at the end-effector origin) on a 6-D arm come from the
translational block of the mobility, and they resolve the contact (a run with 4x the substeps gives the same force)."""

from __future__ import annotations

import numpy as np
import pytest

from forcecontrol.scenarios import load_scenario
from forcecontrol.scenarios.build import build_case
from forcecontrol.sim.contact import choose_substeps, contact_rate

pytest.importorskip("pinocchio")


def test_point_contact_rate_is_the_translational_mode():
    """Panda on the unknown sphere: ω = max(√(k λ_max(J_p B⁻¹ J_pᵀ)), c λ_max(J_p B⁻¹ J_pᵀ)), from the arm's own J and B
    (the 6 x 6 mobility mixed in the wrist's rotational inertia and gave a rate ~30 times too high: 61 substeps)."""
    parts = build_case(load_scenario("panda-unknown-sphere").cases[0])
    robot, env, q0 = parts["robot"], parts["environment"], np.asarray(parts["q0"])
    J = np.asarray(robot.jacobian(q0))[:3]
    B = np.asarray(robot.mass_matrix(q0))
    lam = np.linalg.eigvalsh(J @ np.linalg.solve(B, J.T)).max()  # 1 / the lightest effective mass [1/kg]
    k, c = float(env.max_stiffness()), float(getattr(env, "damping", 0.0))
    want = max(np.sqrt(k * lam), c * lam)
    assert contact_rate(robot, env, q0) == pytest.approx(want, rel=1e-12)
    assert choose_substeps(robot, env, q0, 1e-3) == int(np.ceil(want * 1e-3 / 0.05))


def test_chosen_substeps_resolve_the_point_contact():
    """panda-sphere (6-D impedance on an elastic ball) for 0.4 s at the chosen substeps and at 4x as many: the contact
    force agrees within 5e-4 of its size and the tip within 1e-6 m. (Not 1e-9: the first touch falls inside an RK4
    step and the force's kink there is integrated to O(h), whatever the count: 12 and 61 substeps differ as much.)"""
    scn = load_scenario("panda-sphere").with_(duration=0.4)
    case = scn.cases[0]
    parts = build_case(case)
    n = choose_substeps(parts["robot"], parts["environment"], np.asarray(parts["q0"]), float(case.config["sample_time"]))
    assert n < 10  # the point contact's own rate, not the wrist's rotational mobility (61 before)
    coarse = scn.with_(substeps=n).run().cases[0].result
    fine = scn.with_(substeps=4 * n).run().cases[0].result
    f_c, f_f = coarse.wrench[:, :3], fine.wrench[:, :3]
    assert np.abs(f_f).max() > 1.0  # in contact
    assert np.abs(f_c - f_f).max() <= 5e-4 * np.abs(f_f).max()
    assert np.abs(coarse.x[:, :3] - fine.x[:, :3]).max() <= 1e-6
