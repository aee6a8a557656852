"""Problem 9.10 from Python: a task, its selection matrices, hybrid control on an elastic and a rigid plane.

Run: python examples/hybrid_on_a_plane.py
"""

from __future__ import annotations

import math

import numpy as np

import forcecontrol as fc
from forcecontrol.task import inclined_plane

arm = fc.CHAPTER_ARM
task = inclined_plane(references={"fy": -50.0})  # Example 9.4's plane, λ_d = −50 N (50 N into it)
sel = task.selection("base")  # S_f = [−1/√2, 1/√2]ᵀ, S_v = [1/√2, 1/√2]ᵀ
print("natural / artificial constraints:", task.table())
print("S_f =", sel.force_selection.ravel(), " S_v =", sel.velocity_selection.ravel())

# the official path of Problem 9.10: parallel to the plane, t_f = 1 s, trapezoidal speed
start, end = np.array([1 + 0.1 * math.sqrt(2), 0.0]), np.array([1.2 + 0.1 * math.sqrt(2), 0.2])
reference = fc.LinearPath(start, end, 1.0, force=task.desired_wrench())
q0 = arm.inverse_kinematics([1 + 0.05 * math.sqrt(2), 0.05 * math.sqrt(2)])  # on the surface, at rest

# compliant plane: (9.77) with (9.80)-(9.82), double poles at −50 rad/s
plane = fc.ElasticPlane.inclined(math.pi / 4, [1.0, 0.0], 5e3)
hybrid = fc.HybridCompliantController(arm, task, 1 / 5e3, 100.0, 2500.0, 2500.0, 100.0)
res = fc.simulate(arm, plane, hybrid, reference, q0=q0, duration=2.5)
lam = res.wrench @ sel.force_pinv.T
print(f"elastic plane: λ(2.5 s) = {lam[-1, 0]:.4f} N, penetration = {plane.penetration(res.x[-1]) * 1e3:.3f} mm")

# rigid plane: (9.91) with the integral force law (9.94); constrained dynamics (9.87)-(9.88)
rigid = fc.RigidEnvironment(fc.PlaneConstraint.inclined(math.pi / 4, [1.0, 0.0]), unilateral=True)
ctrl = fc.HybridRigidController(arm, task, velocity_gain=100.0, velocity_integral_gain=2500.0, force_integral_gain=100.0)
res = fc.simulate(arm, rigid, ctrl, reference, q0=q0, duration=2.5)
phi = max(abs(rigid.violation(arm, q)[0]) for q in res.q)
print(f"rigid plane: λ(2.5 s) = {(sel.force_pinv @ res.wrench[-1])[0]:.4f} N, max |φ| = {phi:.2e} m, "
      f"max |h_eᵀ v_e| = {np.abs(np.einsum('ij,ij->i', res.wrench, res.xd)).max():.2e} W")
