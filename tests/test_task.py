"""Task specification: selection matrices, pseudo-inverses, projections, K′, C′, named tasks (Sects. 9.5–9.6)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from forcecontrol.errors import DimensionError, FrameError, ParameterError
from forcecontrol.task import (
    TASKS,
    ConstraintFrame,
    SelectionMatrices,
    Task,
    driving_screw,
    force_selection_from_constraint,
    inclined_plane,
    named_task,
    partial_compliance,
    partial_stiffness,
    peg_in_hole,
    sliding_on_plane,
    turning_crank,
    velocity_selection_from_parametrisation,
    weighted_pseudo_inverse,
)

R2 = 1.0 / math.sqrt(2.0)
finite = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)


def _rotation3(angles: np.ndarray) -> np.ndarray:
    a, b, c = angles
    Rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    Ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    Rz = np.array([[math.cos(c), -math.sin(c), 0], [math.sin(c), math.cos(c), 0], [0, 0, 1]])
    return Rx @ Ry @ Rz


def _spd(A: np.ndarray) -> np.ndarray:
    """A well-conditioned SPD matrix from a square matrix A (entries in [-1, 1])."""
    return A @ A.T + 0.5 * np.eye(A.shape[0])


@st.composite
def tasks(draw):
    """A random task: space, natural constraint set (0 < m < d), constraint frame, weights."""
    d = draw(st.sampled_from([2, 6]))
    force_dofs = draw(st.lists(st.booleans(), min_size=d, max_size=d).filter(lambda f: 0 < sum(f) < d))
    vk = ["vx", "vy", "vz", "wx", "wy", "wz"][:d] if d == 6 else ["vx", "vy"]
    fk = ["fx", "fy", "fz", "mx", "my", "mz"][:d] if d == 6 else ["fx", "fy"]
    natural = [vk[i] if f else fk[i] for i, f in enumerate(force_dofs)]
    if d == 6:
        R = _rotation3(draw(arrays(np.float64, 3, elements=st.floats(-math.pi, math.pi))))
    else:
        a = draw(st.floats(-math.pi, math.pi))
        R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    W_f = _spd(draw(arrays(np.float64, (d, d), elements=finite)))
    W_v = _spd(draw(arrays(np.float64, (d, d), elements=finite)))
    task = Task("random", natural, frame=ConstraintFrame(R), force_weight=W_f, velocity_weight=W_v, dim=d)
    return task


@st.composite
def selections(draw):
    """Random base-frame selection matrices (rotated, non-unit columns) with random weights."""
    task = draw(tasks())
    sel = task.selection("base")
    d, m = sel.dim, sel.m
    # mix the columns (S_f A, S_v B span the same subspaces; A, B strictly diagonally dominant)
    A = np.eye(m) + 0.9 / m * draw(arrays(np.float64, (m, m), elements=finite))
    B = np.eye(d - m) + 0.9 / (d - m) * draw(arrays(np.float64, (d - m, d - m), elements=finite))
    return SelectionMatrices(
        sel.force_selection @ A, sel.velocity_selection @ B,
        force_weight=sel.force_weight, velocity_weight=sel.velocity_weight,
    )


# --------------------------------------------------------------------------- properties


@settings(max_examples=60, deadline=None)
@given(selections())
def test_projections_are_idempotent(sel):
    """P_f = S_f S_f† and P_v = S_v S_v† are projections (P² = P) for any frame, weight and constraint set."""
    for P in (sel.force_projector, sel.velocity_projector):
        np.testing.assert_allclose(P @ P, P, atol=1e-9)
    np.testing.assert_allclose(sel.force_pinv @ sel.force_selection, np.eye(sel.m), atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(tasks(), st.sampled_from(["constraint", "base"]))
def test_reciprocity_of_selection_matrices(task, frame):
    """S_fᵀ S_v = O (9.58) in every frame the task is expressed in."""
    sel = task.selection(frame)
    np.testing.assert_allclose(sel.force_selection.T @ sel.velocity_selection, 0.0, atol=1e-12)
    assert sel.force_selection.shape == (task.dim, task.m)
    assert sel.velocity_selection.shape == (task.dim, task.dim - task.m)


@settings(max_examples=60, deadline=None)
@given(selections(), st.data())
def test_weighted_pseudo_inverse_is_weighted_least_squares(sel, data):
    """λ = S_f† h (9.54)–(9.55) minimises ‖h − S_f λ‖_W: it equals lstsq on the problem whitened by chol(W) (Problem 9.5)."""
    d = sel.dim
    h = data.draw(arrays(np.float64, d, elements=st.floats(-100, 100)))
    W = sel.force_weight
    L = np.linalg.cholesky(W)  # W = L Lᵀ, ‖e‖_W² = ‖Lᵀ e‖²
    expected, *_ = np.linalg.lstsq(L.T @ sel.force_selection, L.T @ h, rcond=None)
    np.testing.assert_allclose(sel.force_coordinates(h), expected, rtol=1e-8, atol=1e-8 * (1 + np.abs(h).max()))


@settings(max_examples=60, deadline=None)
@given(selections(), st.data())
def test_partial_stiffness_is_projected_stiffness(sel, data):
    """K′ = S_f (S_fᵀ C S_f)⁻¹ S_fᵀ (9.70) equals P_f K with P_f built with W = C and K = C⁻¹ (Problem 9.6)."""
    d = sel.dim
    C = _spd(data.draw(arrays(np.float64, (d, d), elements=finite)))
    P_f = SelectionMatrices(sel.force_selection, sel.velocity_selection, force_weight=C).force_projector
    np.testing.assert_allclose(sel.stiffness(C), P_f @ np.linalg.inv(C), rtol=1e-8, atol=1e-8)


@settings(max_examples=60, deadline=None)
@given(selections(), st.data())
def test_partial_compliance_properties(sel, data):
    """C′ = (I − P_v) C (9.72): S_fᵀ C′ S_f = S_fᵀ C S_f, S_v† C′ = O, and C′ is symmetric when W_v = C⁻¹."""
    d = sel.dim
    C = _spd(data.draw(arrays(np.float64, (d, d), elements=finite)))
    Cp = sel.compliance(C)
    S_f = sel.force_selection
    np.testing.assert_allclose(S_f.T @ Cp @ S_f, S_f.T @ C @ S_f, atol=1e-9)
    np.testing.assert_allclose(sel.velocity_pinv @ Cp, 0.0, atol=1e-9)
    Cs = partial_compliance(sel.velocity_selection, C, velocity_weight=np.linalg.inv(C))
    np.testing.assert_allclose(Cs, Cs.T, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(selections(), st.data())
def test_lambda_invariant_under_units_when_weight_transformed(sel, data):
    """λ from a wrench outside R(S_f) is unchanged by a change of units (D) when W becomes D⁻ᵀ W D⁻¹ (Sect. 9.5.1)."""
    d = sel.dim
    exps = data.draw(arrays(np.int64, d, elements=st.integers(-2, 2)))
    D = np.diag(10.0 ** exps.astype(float))  # e.g. N -> kN, N m -> N mm per component
    h = data.draw(arrays(np.float64, d, elements=st.floats(-100, 100)))
    new = sel.transformed(D)
    tol = 1e-7 * (1 + np.abs(h).max())
    np.testing.assert_allclose(new.force_coordinates(D @ h), sel.force_coordinates(h), rtol=1e-7, atol=tol)
    v = data.draw(arrays(np.float64, d, elements=st.floats(-1, 1)))
    v_new = np.linalg.inv(D).T @ v
    np.testing.assert_allclose(new.velocity_coordinates(v_new), sel.velocity_coordinates(v), rtol=1e-7, atol=1e-7)
    np.testing.assert_allclose(new.force_selection.T @ new.velocity_selection, 0.0, atol=1e-9 * np.abs(D).max() ** 2)


def test_lambda_depends_on_units_when_weight_not_transformed():
    """Without transforming W, λ of a wrench outside R(S_f) changes with the units: the invariance problem is real."""
    S_f = np.array([[1.0], [1.0]])
    S_v = np.array([[1.0], [-1.0]])
    h = np.array([1.0, 0.0])
    D = np.diag([1.0, 1000.0])
    lam = SelectionMatrices(S_f, S_v).force_coordinates(h)
    lam_naive = SelectionMatrices(D @ S_f, np.linalg.inv(D) @ S_v).force_coordinates(D @ h)
    lam_ok = SelectionMatrices(S_f, S_v).transformed(D).force_coordinates(D @ h)
    assert abs(lam_naive[0] - lam[0]) > 0.4
    assert lam_ok[0] == pytest.approx(lam[0], rel=1e-12)


@settings(max_examples=40, deadline=None)
@given(tasks(), st.data())
def test_frames_change_matrices_but_not_coordinates(task, data):
    """λ and ν of a wrench and twist are the same whether computed in the constraint, base or end-effector frame."""
    d = task.dim
    if d == 6:
        R_e = _rotation3(data.draw(arrays(np.float64, 3, elements=st.floats(-math.pi, math.pi))))
        D = lambda R: scipy.linalg.block_diag(R, R)  # noqa: E731
    else:
        a = data.draw(st.floats(-math.pi, math.pi))
        R_e = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        D = lambda R: R  # noqa: E731
    h_c = data.draw(arrays(np.float64, d, elements=st.floats(-10, 10)))
    c, b = task.selection("constraint"), task.selection("base")
    e = task.selection("end-effector", end_effector_rotation=R_e)
    R_c = task.frame.rotation()
    np.testing.assert_allclose(b.force_coordinates(D(R_c) @ h_c), c.force_coordinates(h_c), atol=1e-9)
    np.testing.assert_allclose(e.force_coordinates(D(R_e.T @ R_c) @ h_c), c.force_coordinates(h_c), atol=1e-9)
    np.testing.assert_allclose(b.force_selection, D(R_c) @ c.force_selection, atol=1e-12)


# --------------------------------------------------------------------------- the chapter's numbers


def test_example_9_4_matrices_in_base_frame():
    """Example 9.4: S_f = [−1/√2, 1/√2]ᵀ, S_v = [1/√2, 1/√2]ᵀ and C′ = c22 [[½, −½], [−½, ½]] in the base frame."""
    task = inclined_plane()
    sel = task.selection("base")
    np.testing.assert_allclose(sel.force_selection, [[-R2], [R2]], atol=1e-15)
    np.testing.assert_allclose(sel.velocity_selection, [[R2], [R2]], atol=1e-15)
    c22 = 2e-4
    C_c = np.diag([7e-3, c22])  # any compliance along x_c: C′ does not see it
    R_c = task.frame.rotation()
    np.testing.assert_allclose(R_c, [[R2, -R2], [R2, R2]], atol=1e-15)  # (9.85)
    C_b = R_c @ C_c @ R_c.T
    np.testing.assert_allclose(sel.compliance(C_b), c22 * np.array([[0.5, -0.5], [-0.5, 0.5]]), atol=1e-15)
    np.testing.assert_allclose(task.compliance(C_c), np.diag([0.0, c22]), atol=1e-18)
    np.testing.assert_allclose(task.stiffness(C_c), np.diag([0.0, 1.0 / c22]), rtol=1e-12)
    np.testing.assert_allclose(task.selection("constraint").force_projector, [[0, 0], [0, 1]])
    np.testing.assert_allclose(task.selection("constraint").velocity_projector, [[1, 0], [0, 0]])


def test_problem_9_9_pseudo_inverses():
    """Problem 9.9: S_f† = [0 1], S_v† = [1 0] in the constraint frame; [−1/√2 1/√2], [1/√2 1/√2] in the base frame."""
    task = inclined_plane()
    c, b = task.selection("constraint"), task.selection("base")
    np.testing.assert_allclose(c.force_pinv, [[0, 1]], atol=1e-15)
    np.testing.assert_allclose(c.velocity_pinv, [[1, 0]], atol=1e-15)
    np.testing.assert_allclose(b.force_pinv, [[-R2, R2]], atol=1e-15)
    np.testing.assert_allclose(b.velocity_pinv, [[R2, R2]], atol=1e-15)


@pytest.mark.parametrize(
    ("factory", "S_f_cols", "S_v_cols", "rows"),
    [
        (sliding_on_plane, [2, 3, 4], [0, 1, 5],
         [("ȯ_z^c", "f_z^c"), ("ω_x^c", "μ_x^c"), ("ω_y^c", "μ_y^c"),
          ("f_x^c", "ȯ_x^c"), ("f_y^c", "ȯ_y^c"), ("μ_z^c", "ω_z^c")]),
        (peg_in_hole, [0, 1, 3, 4], [2, 5],
         [("ȯ_x^c", "f_x^c"), ("ȯ_y^c", "f_y^c"), ("ω_x^c", "μ_x^c"),
          ("ω_y^c", "μ_y^c"), ("f_z^c", "ȯ_z^c"), ("μ_z^c", "ω_z^c")]),
        (turning_crank, [0, 2, 3, 4], [1, 5],
         [("ȯ_x^c", "f_x^c"), ("ȯ_z^c", "f_z^c"), ("ω_x^c", "μ_x^c"),
          ("ω_y^c", "μ_y^c"), ("f_y^c", "ȯ_y^c"), ("μ_z^c", "ω_z^c")]),
    ],
)
def test_tables_9_1_to_9_3(factory, S_f_cols, S_v_cols, rows):
    """The sliding, peg-in-hole and crank tasks give the chapter's tables and S_f, S_v (Tables 9.1–9.3)."""
    task = factory()
    c = task.selection("constraint")
    E = np.eye(6)
    np.testing.assert_array_equal(c.force_selection, E[:, S_f_cols])
    np.testing.assert_array_equal(c.velocity_selection, E[:, S_v_cols])
    assert task.table() == rows


def test_crank_frame_moves_and_its_selection_turns():
    """Turning a crank: S_f, S_v are constant in the constraint frame but turn with the lever in the base frame."""
    w = 2.0
    task = turning_crank(radius=0.3, angular_rate=w)
    assert task.frame.moving
    b0, b1 = task.selection("base", t=0.0), task.selection("base", t=0.5)
    np.testing.assert_allclose(b0.velocity_selection[:, 0], [0, 1, 0, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(b1.velocity_selection[:, 0], [-math.sin(1.0), math.cos(1.0), 0, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(task.frame.origin(0.5), [0.3 * math.cos(1.0), 0.3 * math.sin(1.0), 0], atol=1e-15)
    _, S_v_dot = task.selection_rate(0.5)
    np.testing.assert_allclose(S_v_dot[:2, 0], [-w * math.cos(1.0), -w * math.sin(1.0)], atol=1e-6)


def test_driving_screw_with_pitch_is_reciprocal():
    """Problem 9.7: the screw task has m = 5; with a pitch p, S_v = screw motion and S_f stays reciprocal to it."""
    t0 = driving_screw()
    assert t0.m == 5
    assert t0.artificial == ("fx", "fy", "fz", "mx", "my", "wz")
    t = driving_screw(pitch=0.002)
    c = t.selection("constraint")
    np.testing.assert_allclose(c.velocity_selection[:, 0], [0, 0, 0.002 / (2 * math.pi), 0, 0, 1])
    np.testing.assert_allclose(c.force_selection.T @ c.velocity_selection, 0.0, atol=1e-18)


def test_constraint_and_parametrisation_jacobians_give_selection():
    """S_f = J⁻ᵀ J_φᵀ (9.53) and S_v = J J_ρ (9.63) for the arm on the π/4 plane reproduce Example 9.4's directions."""
    from forcecontrol import CHAPTER_ARM

    q = CHAPTER_ARM.inverse_kinematics([1.0, 0.0])
    J = CHAPTER_ARM.jacobian(q)
    n = np.array([-R2, R2])
    J_phi = (n @ J)[None, :]  # φ(q) = νᵀ (k(q) − p)
    S_f = force_selection_from_constraint(J, J_phi)
    np.testing.assert_allclose(S_f[:, 0], n, atol=1e-12)
    J_rho = np.linalg.solve(J, np.array([[R2], [R2]]))  # q = ρ(r) moving along x_c at unit speed
    S_v = velocity_selection_from_parametrisation(J, J_rho)
    np.testing.assert_allclose(S_v[:, 0], [R2, R2], atol=1e-12)
    sel = SelectionMatrices.from_constraint(J, J_phi)
    np.testing.assert_allclose(abs(sel.velocity_selection[:, 0] @ np.array([R2, R2])), 1.0, atol=1e-12)


def test_references_give_desired_wrench_and_twist():
    """Sect. 9.6: h_d = S_f λ_d and v_d = S_v ν_d from the artificial constraint values."""
    task = inclined_plane(references={"fy": -50.0, "vx": 0.2})
    np.testing.assert_allclose(task.desired_force(), [-50.0])
    np.testing.assert_allclose(task.desired_wrench(), [50 * R2, -50 * R2])
    np.testing.assert_allclose(task.desired_twist(), [0.2 * R2, 0.2 * R2])


def test_every_named_task_builds():
    """Every named task builds, is reciprocal in the base frame, and can be fetched by name."""
    for name in TASKS:
        task = named_task(name)
        sel = task.selection("base", t=0.1)
        assert np.abs(sel.force_selection.T @ sel.velocity_selection).max() < 1e-12
        assert len(task.table()) == task.dim


# --------------------------------------------------------------------------- bad inputs


def test_not_complementary_selection_raises():
    """S_f and S_v that are not reciprocal (S_fᵀ S_v ≠ O) are rejected, naming both and the value."""
    with pytest.raises(ParameterError, match=r"force_selection and velocity_selection must be reciprocal.*got max"):
        SelectionMatrices([[1.0], [0.0]], [[1.0], [1.0]])


def test_wrong_number_of_velocity_columns_raises():
    """S_v must have d − m columns, complementary to S_f."""
    with pytest.raises(DimensionError, match=r"velocity_selection must have d − m = 6 − 3 = 3 columns.*got shape \(6, 2\)"):
        SelectionMatrices(np.eye(6)[:, :3], np.eye(6)[:, 3:5])


def test_rank_deficient_force_selection_raises():
    """A rank-deficient S_f is rejected with the expected and the found rank."""
    S_f = np.zeros((6, 2))
    S_f[2, 0] = S_f[2, 1] = 1.0
    with pytest.raises(ParameterError, match=r"force_selection must have full column rank 2.*got rank 1"):
        SelectionMatrices(S_f, np.eye(6)[:, [0, 1, 3, 4]])


def test_weight_not_positive_definite_raises():
    """A weight that is not positive definite is rejected, with its eigenvalues."""
    msg = r"force_weight must be a symmetric positive definite \(2, 2\) matrix; got eigenvalues \[-1"
    with pytest.raises(ParameterError, match=msg):
        SelectionMatrices([[0.0], [1.0]], [[1.0], [0.0]], force_weight=np.diag([1.0, -1.0]))
    msg = r"weight must be a symmetric positive definite \(2, 2\) matrix; got a non-symmetric"
    with pytest.raises(ParameterError, match=msg):
        weighted_pseudo_inverse([[0.0], [1.0]], [[1.0, 1.0], [0.0, 1.0]])


def test_compliance_not_positive_definite_raises():
    """K′ needs a positive definite compliance."""
    with pytest.raises(ParameterError, match=r"compliance must be a symmetric positive definite \(2, 2\) matrix"):
        partial_stiffness([[0.0], [1.0]], np.diag([1.0, 0.0]))


def test_reference_conflicting_with_natural_constraint_raises():
    """A reference on a naturally constrained quantity (ȯ_y^c on the plane) conflicts with the task."""
    with pytest.raises(ParameterError, match=r"references conflict with the natural constraints: vy = 0.1 was given.*ȯ_y\^c = 0"):
        inclined_plane(references={"vy": 0.1, "fy": -50.0})


def test_wrench_reference_outside_force_subspace_raises():
    """A desired wrench with a component the natural constraints forbid (f_x^c) is rejected."""
    sel = inclined_plane().selection("base")
    msg = r"force reference conflicts with the natural constraints: it must lie in the force controlled"
    with pytest.raises(ParameterError, match=msg):
        sel.check_references(force=[10.0, 0.0])
    sel.check_references(force=[35.0, -35.0], velocity=[0.1, 0.1])


def test_natural_constraints_not_one_per_dof_raise():
    """Natural constraints must name exactly one quantity per DOF."""
    with pytest.raises(ParameterError, match=r"got both vx and fx for DOF x"):
        Task("bad", ("vx", "fx"), dim=2)
    with pytest.raises(ParameterError, match=r"got none for DOF y \(expected vy or fy\)"):
        Task("bad", ("vx",), dim=2)
    with pytest.raises(ParameterError, match=r"natural constraints must be keys among"):
        Task("bad", ("vx", "qq"), dim=2)


def test_end_effector_frame_needs_rotation():
    """Expressing a task in the end-effector frame without R_e is a frame error."""
    with pytest.raises(FrameError, match=r"end_effector_rotation must be given"):
        inclined_plane().selection("end-effector")
    with pytest.raises(FrameError, match=r"frame must be 'constraint', 'base' or 'end-effector'; got 'tool'"):
        inclined_plane().selection("tool")  # type: ignore[arg-type]


def test_bad_rotation_raises():
    """A constraint frame rotation must be orthonormal with det +1."""
    with pytest.raises(ParameterError, match=r"rotation must be a rotation matrix"):
        ConstraintFrame(np.diag([1.0, -1.0]))


def test_unknown_task_name_raises():
    """Asking for an unknown named task lists the valid names."""
    with pytest.raises(ParameterError, match=r"task must be one of .*'peg-in-hole'.*got 'pegs'"):
        named_task("pegs")


# --------------------------------------------------------------------------- the CLI


def test_cli_task_prints_table_and_matrices():
    """'forcecontrol task sliding-on-plane' prints Table 9.1's rows and S_f, S_v in brackets."""
    from typer.testing import CliRunner

    from forcecontrol.cli import app

    out = CliRunner().invoke(app, ["task", "sliding-on-plane"])
    assert out.exit_code == 0, out.output
    assert "ȯ_z^c" in out.output and "μ_z^c" in out.output
    assert "S_f = ⎢ 1  0  0 ⎥" in out.output
    assert "S_v = ⎢ 0  0  0 ⎥" in out.output


def test_cli_task_json_in_base_frame():
    """'forcecontrol task problem-9.10 --frame base --json' gives Example 9.4's base-frame S_f and the −50 N reference."""
    import json

    from typer.testing import CliRunner

    from forcecontrol.cli import app

    out = CliRunner().invoke(app, ["task", "problem-9.10", "--frame", "base", "--pinv", "--json"])
    assert out.exit_code == 0, out.output
    data = json.loads(out.output)
    np.testing.assert_allclose(data["S_f"], [[-R2], [R2]])
    np.testing.assert_allclose(data["S_v_pinv"], [[R2, R2]])
    assert data["constraints"][0] == {"natural": "ȯ_y^c", "artificial": "f_y^c", "reference": -50.0}


def test_cli_task_unknown_name_fails():
    """An unknown task name exits with code 2 and names the valid tasks."""
    from typer.testing import CliRunner

    from forcecontrol.cli import app

    out = CliRunner().invoke(app, ["task", "pegs"])
    assert out.exit_code == 2


def test_task_package_keeps_its_public_names():
    """Every public name of the former task.py is importable from forcecontrol.task; each module is under 450 lines."""
    from pathlib import Path

    import forcecontrol.task as tk

    expected = {
        "SelectionMatrices", "ConstraintFrame", "Task", "weighted_pseudo_inverse", "planar_rotation", "wrench_rotation",
        "force_selection_from_constraint", "velocity_selection_from_parametrisation", "partial_stiffness",
        "partial_compliance", "sliding_on_plane", "peg_in_hole", "turning_crank", "driving_screw", "inclined_plane",
        "TASKS", "named_task", "SYMBOLS", "DOFS", "VELOCITY_KEYS", "FORCE_KEYS",
    }
    assert expected <= set(tk.__all__) and expected <= set(dir(tk))
    for f in Path(tk.__file__).parent.glob("*.py"):
        assert len(f.read_text().splitlines()) < 450, f
