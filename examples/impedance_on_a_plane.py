"""Example 9.2 from Python: impedance control against planes of two stiffnesses.

Writes its logs and a figure into ``example-output/impedance_on_a_plane/`` (created).
"""

from pathlib import Path

import forcecontrol as fc
from forcecontrol.analysis import impedance_axis

OUT = Path("example-output") / "impedance_on_a_plane"
arm = fc.PlanarTwoLink()
q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
for k_x in (1e3, 1e4):
    plane = fc.ElasticPlane(point=[1.0, 0.0], normal=[-1.0, 0.0], stiffness=k_x)
    ctl = fc.ImpedanceController(arm, inertia=100, damping=500, stiffness=2500)
    res = fc.simulate(arm, plane, ctl, fc.Setpoint([1.1, 0.1]), q0=q0, duration=4.0, label=f"k_x={k_x:g}")
    ax = impedance_axis(100, 500, 2500, k_x, desired=1.1, rest=1.0)
    print(f"k_x = {k_x:g} N/m: simulated f_x = {res.settled('wrench')[0]:.2f} N, "
          f"predicted {ax.contact_force:.2f} N; ω_n = {ax.natural_frequency:.2f} rad/s, ζ = {ax.damping_ratio:.3f}")
    data, _ = res.save(OUT / f"example-9.2-k{k_x:g}", format="csv")
    fig = res.plot(path=OUT / f"example-9.2-k{k_x:g}.png")
    print(f"  wrote {data} and {fig}")
