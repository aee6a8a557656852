"""A controller object in a hand-written fixed-rate loop (what you would do on a real arm).

Replace `read_state`, `read_wrench` and `write_torque` with your robot's interface; here they
are a crude stand-in plant so the script runs anywhere.
"""

import time

import numpy as np

import forcecontrol as fc

arm = fc.PlanarTwoLink()
plane = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e3)
ctl = fc.ImpedanceController(arm, inertia=100, damping=500, stiffness=2500, sample_time=1e-3)
reference = fc.Reference.setpoint([1.1, 0.1])

q, qd = arm.inverse_kinematics([1.0, 0.0]), np.zeros(2)   # stand-in robot state
compute = []
for k in range(3000):
    t = k * ctl.sample_time
    h = plane.wrench(arm.forward_kinematics(q), arm.jacobian(q) @ qd)   # read_wrench()
    t0 = time.perf_counter()
    u = ctl.step(t, fc.Measurement(q, qd, h), reference)                # the controller
    compute.append(time.perf_counter() - t0)
    for _ in range(10):                                                 # write_torque(u): stand-in plant
        T = arm.terms(q, qd)
        qdd = np.linalg.solve(T.B, u - T.n - T.J.T @ plane.wrench(T.x, T.xd))
        qd = qd + 1e-4 * qdd
        q = q + 1e-4 * qd
print(f"f_x = {h[0]:.2f} N (book: 71.4 N); controller step median {1e6 * np.median(compute):.1f} µs, "
      f"99th percentile {1e6 * np.percentile(compute, 99):.1f} µs")
